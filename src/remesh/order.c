/*
 * order.c -- the sort of the remeshers' spatial (Morton) keys: an LSD
 * radix sort, stable, in the order pa__key64_cmp gives when the records
 * come in increasing index (as the remeshers build them). The renumbering
 * of a working mesh sorts its live vertices each time it runs, so this
 * replaces a comparison sort: about ten times fewer instructions on the
 * keys of a few hundred thousand vertices.
 */
#include "remesh/remesh.h"

/* Bits per digit: the counters of a digit (2^11 of them) stay in the L1
 * cache, and a 64-bit key takes six passes. */
#define ORDER_DIGIT_BITS 11
#define ORDER_DIGITS ((64 + ORDER_DIGIT_BITS - 1) / ORDER_DIGIT_BITS)
#define ORDER_BUCKETS (1 << ORDER_DIGIT_BITS)
/* Below this many records an insertion sort is cheaper than the passes. */
#define ORDER_SMALL 64

static unsigned digit(uint64_t key, int d) {
  return (unsigned)(key >> (d * ORDER_DIGIT_BITS)) & (ORDER_BUCKETS - 1);
}

pa_status pa__remesh_sort_keys(pa__key64 *a, size_t n) {
  pa_status st = PA_SUCCESS;
  pa__key64 *tmp = NULL;
  uint32_t *cnt = NULL;
  if (n < ORDER_SMALL) {
    for (size_t i = 1; i < n; i++) {
      pa__key64 x = a[i];
      size_t j = i;
      for (; j > 0 && pa__key64_cmp(&a[j - 1], &x) > 0; j--) a[j] = a[j - 1];
      a[j] = x;
    }
    return PA_SUCCESS;
  }
  PA_CHECK(n <= UINT32_MAX, PA_ERR_INTERNAL, "remesher: too many keys to sort");
  PA_ALLOC(tmp, n);
  PA_CALLOC(cnt, (size_t)ORDER_DIGITS * ORDER_BUCKETS);
  /* the counts of every digit in one read of the keys */
  for (size_t i = 0; i < n; i++)
    for (int d = 0; d < ORDER_DIGITS; d++)
      cnt[d * ORDER_BUCKETS + digit(a[i].key, d)]++;
  pa__key64 *src = a, *dst = tmp;
  for (int d = 0; d < ORDER_DIGITS; d++) {
    uint32_t *c = cnt + d * ORDER_BUCKETS;
    if (c[digit(src[0].key, d)] == n) continue; /* one value: order kept */
    uint32_t sum = 0;
    for (int b = 0; b < ORDER_BUCKETS; b++) {
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
