/*
 * fmt.c -- pa__fmt_g: a double in printf's "%.*g" form, the same bytes as
 * snprintf, about ten times faster for the values a mesh holds.
 *
 * |x| = m 2^e exactly (m < 2^53). With E the decimal exponent of x's first
 * digit and p = prec - 1 - E, the prec significant digits are the integer
 * N = round(m 5^p 2^(e+p)), rounded half to even as glibc does in the
 * default rounding mode: for 0 <= p <= 27, m 5^p < 2^116 holds in 128 bits
 * and the power of two is a shift whose remainder decides the rounding
 * exactly. That covers |x| from about 1e-11 to 1e17 at 17 digits; zeros
 * are "0" and "-0"; other values, subnormals, infinities and NaN go to
 * snprintf. pa__fmt_shortest: the shorter of %.15g and %.17g that reads
 * back exactly, mostly decided from the 17 digits alone (decided_17).
 * pa__fmt_int: an integer in decimal, two digits per division.
 */
#include "io/fmt.h"

#include <math.h>
#include <stdio.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* 5^27 < 2^63: the largest power of 5 that keeps m 5^p within 128 bits */
#define FMT_P_MAX 27

/* 10^k for k < 20: every uint64_t has at most 20 digits */
static const uint64_t pow10_u64[20] = {1ULL,
                                       10ULL,
                                       100ULL,
                                       1000ULL,
                                       10000ULL,
                                       100000ULL,
                                       1000000ULL,
                                       10000000ULL,
                                       100000000ULL,
                                       1000000000ULL,
                                       10000000000ULL,
                                       100000000000ULL,
                                       1000000000000ULL,
                                       10000000000000ULL,
                                       100000000000000ULL,
                                       1000000000000000ULL,
                                       10000000000000000ULL,
                                       100000000000000000ULL,
                                       1000000000000000000ULL,
                                       10000000000000000000ULL};

static const uint64_t pow5_u64[FMT_P_MAX + 1] = {
    1ULL,
    5ULL,
    25ULL,
    125ULL,
    625ULL,
    3125ULL,
    15625ULL,
    78125ULL,
    390625ULL,
    1953125ULL,
    9765625ULL,
    48828125ULL,
    244140625ULL,
    1220703125ULL,
    6103515625ULL,
    30517578125ULL,
    152587890625ULL,
    762939453125ULL,
    3814697265625ULL,
    19073486328125ULL,
    95367431640625ULL,
    476837158203125ULL,
    2384185791015625ULL,
    11920928955078125ULL,
    59604644775390625ULL,
    298023223876953125ULL,
    1490116119384765625ULL,
    7450580596923828125ULL};

__extension__ typedef unsigned __int128 fmt_u128;

/* N = round(m 5^p 2^sh) half to even into *n; 0 if it does not fit. */
static int scaled(uint64_t m, int p, int sh, uint64_t *n) {
  fmt_u128 v = (fmt_u128)m * pow5_u64[p];
  if (sh >= 0) {
    if (sh > 60 || (v >> (64 - sh)) != 0) return 0;
    *n = (uint64_t)(v << sh);
    return 1;
  }
  int r = -sh;
  if (r > 120) return 0;
  fmt_u128 q = v >> r, rem = v - (q << r), half = (fmt_u128)1 << (r - 1);
  if (rem > half || (rem == half && (q & 1))) q++;
  if (q >> 63) return 0;
  *n = (uint64_t)q;
  return 1;
}

/* The two digits of each of 0-99. */
static const char digit_pairs[201] = "00010203040506070809"
                                     "10111213141516171819"
                                     "20212223242526272829"
                                     "30313233343536373839"
                                     "40414243444546474849"
                                     "50515253545556575859"
                                     "60616263646566676869"
                                     "70717273747576777879"
                                     "80818283848586878889"
                                     "90919293949596979899";

/* The decimal digits of u ending at end (the caller counted them). */
static void digits_before(uint64_t u, char *end) {
  while (u >= 100) {
    uint64_t q = u / 100;
    end -= 2;
    memcpy(end, digit_pairs + 2 * (u - 100 * q), 2);
    u = q;
  }
  if (u >= 10) memcpy(end - 2, digit_pairs + 2 * u, 2);
  else end[-1] = (char)('0' + u);
}

int pa__fmt_int(char *s, int64_t v) {
  uint64_t u = v < 0 ? (uint64_t)0 - (uint64_t)v : (uint64_t)v;
  int neg = v < 0;
  /* the digits of u from its bit length b: floor(b log10 2) is the number
   * of digits or one less (1233 / 4096 ~ log10 2) */
  int t = (64 - __builtin_clzll(u | 1)) * 1233 >> 12;
  int n = t + (u >= pow10_u64[t]);
  n += n == 0;
  if (neg) *s = '-';
  digits_before(u, s + neg + n);
  return neg + n;
}

/* The prec significant digits d[0..prec) of the normal double x rounded
 * half to even, and the decimal exponent *E of the first; 0 when x is out
 * of the range of the 128-bit arithmetic (the caller asks snprintf). */
static int fast_digits(double x, int prec, char *d, int *Ep) {
  uint64_t bits;
  memcpy(&bits, &x, sizeof bits);
  /* |x| = m 2^e, m in [2^52, 2^53) */
  uint64_t m = (bits & 0xFFFFFFFFFFFFFull) | 1ull << 52;
  int e = (int)(bits >> 52 & 0x7FF) - 1075;
  /* |x| in [2^(e+52), 2^(e+53)): floor((e + 52) log10 2) is E or E - 1,
   * and the loop below takes the one step up */
  int E = (int)floor((e + 52) * 0.30102999566398120);
  uint64_t n = 0;
  for (int tries = 0;; tries++) {
    int p = prec - 1 - E;
    if (tries > 2 || p < 0 || p > FMT_P_MAX || !scaled(m, p, e + p, &n))
      return 0;
    if (n >= pow10_u64[prec])
      E++; /* E was low, or the rounding carried to 10^prec */
    else if (n < pow10_u64[prec - 1])
      E--;
    else
      break;
  }
  /* 10^(prec-1) may be x rounded up at the scale of an E one too high:
   * one digit more of scale keeps prec digits when x is below 10^E */
  if (n == pow10_u64[prec - 1]) {
    uint64_t lower;
    if (prec - E > FMT_P_MAX || !scaled(m, prec - E, e + prec - E, &lower))
      return 0;
    if (lower < pow10_u64[prec]) {
      n = lower;
      E--;
    }
  }
  digits_before(n, d + prec); /* 10^(prec-1) <= n < 10^prec */
  *Ep = E;
  return 1;
}

/* The "%.*g" form of the digits d[0..prec) of x (first digit at decimal
 * exponent E) into s; its length. */
static int layout(char *s, double x, const char *d, int prec, int E) {
  int nd = prec; /* %g drops the trailing zeros of the fraction */
  while (nd > 1 && d[nd - 1] == '0') nd--;
  char *o = s;
  if (x < 0) *o++ = '-';
  if (E < -4 || E >= prec) { /* d.ddde+XX */
    *o++ = d[0];
    if (nd > 1) {
      *o++ = '.';
      memcpy(o, d + 1, (size_t)nd - 1);
      o += nd - 1;
    }
    *o++ = 'e';
    *o++ = E < 0 ? '-' : '+';
    int a = E < 0 ? -E : E;
    if (a >= 100) *o++ = (char)('0' + a / 100);
    *o++ = (char)('0' + a / 10 % 10);
    *o++ = (char)('0' + a % 10);
  } else if (E >= 0) { /* ddd.ddd */
    int ni = E + 1;
    for (int i = 0; i < ni; i++) *o++ = i < nd ? d[i] : '0';
    if (nd > ni) {
      *o++ = '.';
      memcpy(o, d + ni, (size_t)(nd - ni));
      o += nd - ni;
    }
  } else { /* 0.000ddd */
    *o++ = '0';
    *o++ = '.';
    for (int i = 0; i < -E - 1; i++) *o++ = '0';
    memcpy(o, d, (size_t)nd);
    o += nd;
  }
  *o = '\0';
  return (int)(o - s);
}

int pa__fmt_g(char *s, double x, int prec) {
  char d[17];
  int E;
  if (x == 0 && prec >= 1 && prec <= 17) { /* "%g" prints 0 and -0 bare */
    s[0] = '-';
    s[signbit(x) != 0] = '0';
    s[(signbit(x) != 0) + 1] = '\0';
    return (signbit(x) != 0) + 1;
  }
  if (prec < 1 || prec > 17 || !isnormal(x) || !fast_digits(x, prec, d, &E))
    return snprintf(s, 32, "%.*g", prec, x);
  return layout(s, x, d, prec, E);
}

/* 10^k for 0 <= k <= 22, all exact doubles */
static const double pow10_exact[23] = {
    1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,  1e8,  1e9,  1e10, 1e11,
    1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};

/* Half an ulp of the normal double x: 2^(ilogb(x) - 53). */
static double half_ulp(double x) {
  uint64_t b;
  memcpy(&b, &x, sizeof b);
  int ex = (int)(b >> 52 & 0x7FF); /* biased: ilogb(x) = ex - 1023 */
  if (ex <= 53) return ldexp(1.0, ex - 1023 - 53);
  b = (uint64_t)(ex - 53) << 52;
  double h;
  memcpy(&h, &b, sizeof h);
  return h;
}

/* Whether %.15g of the normal double x is known from d, its 17 digits
 * (correctly rounded; first at decimal exponent E), without printing it:
 * - digits 16-17 are 00 (15 digits or fewer): x rounded to 15 digits is
 *   d's value, so below an exponent of 15 (where %.15g would switch to the
 *   d.ddde+XX form) %.15g prints the %.17g bytes;
 * - else, unless they are 50, %.15g's digits are d's rounded to 15, at
 *   diff units of the 17th digit from d, and x lies within half a unit of
 *   d: that form reads back only if diff - 1/2 units is within half an ulp
 *   of x, and when it is not %.17g is the answer.
 * 1 when %.17g is the answer, 0 when undecided. */
static int decided_17(const char *d, int E, double x) {
  int t = 10 * (d[15] - '0') + (d[16] - '0');
  if (t == 0) return E < 15;
  if (t == 50) return 0;
  double diff = t < 50 ? t : 100 - t; /* in units of the 17th digit */
  int k = 16 - E;
  double scale = k >= 0 && k <= 22 ? pow10_exact[k] : pow(10.0, k);
  return diff - 0.5 > half_ulp(x) * scale * (1 + 1e-9);
}

int pa__fmt_shortest(char *s, double x) {
  char d[17];
  int E;
  if (isnormal(x) && fast_digits(x, 17, d, &E) && decided_17(d, E, x))
    return layout(s, x, d, 17, E);
  int n = pa__fmt_g(s, x, 15);
  if (strtod(s, NULL) != x && !isnan(x)) n = pa__fmt_g(s, x, 17);
  return n;
}
