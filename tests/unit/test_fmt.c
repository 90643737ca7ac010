/*
 * test_fmt.c -- pa__fmt_g (src/io/fmt.c) gives the bytes of snprintf's
 * "%.*g" for every kind of double: random bit patterns (every exponent),
 * mesh-like coordinates, short decimals and exact ties (the half-to-even
 * rounding), powers of 2 and 10 and their neighbours, subnormals, zeros,
 * infinities, NaN, at every precision from 1 to 17; pa__fmt_shortest
 * those of the shorter of "%.15g" and "%.17g" that strtod reads back;
 * pa__fmt_int those of "%lld" for every digit count and sign.
 */
#include "testutil.h"
#include "io/io.h"

#include <float.h>
#include <math.h>
#include <stdint.h>
#include <string.h>

static long nfail = 0;

static void same(double x, int prec) {
  char a[40], b[40];
  int na = pa__fmt_g(a, x, prec);
  int nb = snprintf(b, sizeof b, "%.*g", prec, x);
  if (na != nb || strcmp(a, b) != 0) {
    if (nfail++ < 10)
      fprintf(stderr, "fmt: %a at %d digits: '%s', snprintf '%s'\n", x, prec,
              a, b);
  }
}

/* pa__fmt_shortest against snprintf and strtod. */
static void same_shortest(double x) {
  char a[40], b[40];
  int na = pa__fmt_shortest(a, x);
  int nb = snprintf(b, sizeof b, "%.15g", x);
  if (strtod(b, NULL) != x && !isnan(x))
    nb = snprintf(b, sizeof b, "%.17g", x);
  if (na != nb || strcmp(a, b) != 0) {
    if (nfail++ < 10)
      fprintf(stderr, "fmt: shortest of %a: '%s', snprintf '%s'\n", x, a, b);
  }
}

static void all_precisions(double x) {
  for (int p = 1; p <= 17; p++) {
    same(x, p);
    same(-x, p);
  }
  same_shortest(x);
  same_shortest(-x);
}

static double from_bits(uint64_t u) {
  double x;
  memcpy(&x, &u, sizeof x);
  return x;
}

static void test_fmt_g(void) {
  pa_test_seed(20261127);
  /* random bit patterns: every exponent, subnormals, NaN, infinities */
  for (int i = 0; i < 200000; i++) {
    uint64_t u = 0;
    for (int k = 0; k < 4; k++)
      u = (u << 16) ^ (uint64_t)(pa_test_rand() * 65536.0);
    same(from_bits(u), 17);
    same(from_bits(u), 15);
    same_shortest(from_bits(u));
    if (i % 50 == 0) all_precisions(from_bits(u));
  }
  /* coordinates of a mesh, as computed and as typed */
  for (int i = 0; i < 200000; i++) {
    double x = pa_test_rand_range(-1e3, 1e3) *
               pow(10, (int)(pa_test_rand() * 12) - 8);
    same(x, 17);
    same(x, 15);
    same(round(x * 1000) / 1000, 15);
    same(round(x * 1000) / 1000, 17);
    same_shortest(x);
    same_shortest(round(x * 1000) / 1000);
    same_shortest(pa_test_rand());
    same_shortest(round(pa_test_rand_range(1e14, 1e17)));
  }
  /* short decimals and exact binary ties: 0.5, 0.125, 2.5, 1.0625 ... */
  for (int k = -1000; k <= 1000; k++) {
    all_precisions(k / 8.0);
    all_precisions(k / 1024.0);
    all_precisions(k / 10.0);
    all_precisions(k * 1e-3);
    all_precisions(k * 1e15 + 0.5);
  }
  /* powers of 2 and 10 and their neighbours (the first digit's exponent) */
  for (int e = -330; e <= 310; e++) {
    double t = pow(10, e), u = ldexp(1.0, e > 300 ? 300 : e);
    all_precisions(t);
    all_precisions(nextafter(t, 0));
    all_precisions(nextafter(t, INFINITY));
    all_precisions(u);
    all_precisions(nextafter(u, 0));
    all_precisions(9.5 * t);
    all_precisions(9.9999999999999999 * t);
  }
  /* the special values */
  double special[] = {0.0, -0.0, INFINITY, -INFINITY, NAN, 5e-324, DBL_MAX,
                      DBL_MIN, 1e17, 99999999999999999.0, 1e-11, 0.1};
  for (size_t i = 0; i < sizeof special / sizeof *special; i++)
    all_precisions(special[i]);
  CHECK(nfail == 0);
  if (nfail) fprintf(stderr, "fmt: %ld differences from snprintf\n", nfail);
}

static void same_int(int64_t v) {
  char a[32], b[32];
  int na = pa__fmt_int(a, v);
  int nb = snprintf(b, sizeof b, "%lld", (long long)v);
  if (na != nb || memcmp(a, b, (size_t)nb) != 0) {
    if (nfail++ < 10)
      fprintf(stderr, "fmt: %s as '%.*s'\n", b, na > 0 && na < 32 ? na : 0, a);
  }
}

static void test_fmt_int(void) {
  nfail = 0;
  pa_test_seed(20261128);
  same_int(0);
  same_int(INT64_MAX);
  same_int(INT64_MIN);
  /* every power of 10 and of 2 and their neighbours, both signs */
  for (int k = 0; k < 63; k++)
    for (int64_t d = -1; d <= 1; d++) {
      int64_t p2 = ((int64_t)1 << k) + d, p10 = 1;
      for (int j = 0; j < k % 19; j++) p10 *= 10;
      same_int(p2);
      same_int(-p2);
      same_int(p10 + d);
      same_int(-(p10 + d));
    }
  for (int64_t v = -100000; v <= 100000; v++) same_int(v);
  for (int i = 0; i < 200000; i++) {
    uint64_t u = 0;
    for (int k = 0; k < 4; k++)
      u = (u << 16) ^ (uint64_t)(pa_test_rand() * 65536.0);
    same_int((int64_t)(u >> (i % 64)));
    same_int(-(int64_t)(u >> (i % 64) >> 1));
  }
  CHECK(nfail == 0);
}

TEST_MAIN(test_fmt_g, test_fmt_int)
