/*
 * keysort.c -- the sort of (64-bit key, index) records (pa__key64): an LSD
 * radix sort, stable, so records given by increasing index come out in
 * pa__key64_cmp's order: the Morton keys of the 2D remesher's renumbering
 * (about ten times fewer instructions than qsort on a few hundred thousand
 * keys) and the distributed mesh's sorts by global id (dmesh/util.c); a
 * digit all keys share costs no pass.
 */
#include "core/core.h"

/* Bits per digit: the counters of a digit (2^11 of them) stay in the L1
 * cache, and a 64-bit key takes six passes. */
#define KEYSORT_DIGIT_BITS 11
#define KEYSORT_DIGITS ((64 + KEYSORT_DIGIT_BITS - 1) / KEYSORT_DIGIT_BITS)
#define KEYSORT_BUCKETS (1 << KEYSORT_DIGIT_BITS)
/* Below this many records an insertion sort is cheaper than the passes. */
#define KEYSORT_SMALL 64

static unsigned digit(uint64_t key, int d) {
  return (unsigned)(key >> (d * KEYSORT_DIGIT_BITS)) & (KEYSORT_BUCKETS - 1);
}

pa_status pa__key64_sort(pa__key64 *a, size_t n) {
  pa_status st = PA_SUCCESS;
  pa__key64 *tmp = NULL;
  uint32_t *cnt = NULL;
  if (n < KEYSORT_SMALL) {
    for (size_t i = 1; i < n; i++) {
      pa__key64 x = a[i];
      size_t j = i;
      for (; j > 0 && pa__key64_cmp(&a[j - 1], &x) > 0; j--) a[j] = a[j - 1];
      a[j] = x;
    }
    return PA_SUCCESS;
  }
  PA_CHECK(n <= UINT32_MAX, PA_ERR_INTERNAL, "key sort: too many keys");
  PA_ALLOC(tmp, n);
  PA_CALLOC(cnt, (size_t)KEYSORT_DIGITS * KEYSORT_BUCKETS);
  /* the counts of every digit in one read of the keys */
  for (size_t i = 0; i < n; i++)
    for (int d = 0; d < KEYSORT_DIGITS; d++)
      cnt[d * KEYSORT_BUCKETS + digit(a[i].key, d)]++;
  pa__key64 *src = a, *dst = tmp;
  for (int d = 0; d < KEYSORT_DIGITS; d++) {
    uint32_t *c = cnt + d * KEYSORT_BUCKETS;
    if (c[digit(src[0].key, d)] == n) continue; /* one value: order kept */
    uint32_t sum = 0;
    for (int b = 0; b < KEYSORT_BUCKETS; b++) {
      uint32_t k = c[b];
      c[b] = sum;
      sum += k;
    }
    for (size_t i = 0; i < n; i++) dst[c[digit(src[i].key, d)]++] = src[i];
    pa__key64 *t = src;
    src = dst;
    dst = t;
  }
  if (src != a) memcpy(a, src, n * sizeof *a);
cleanup:
  pa__free(tmp);
  pa__free(cnt);
  return st;
}
