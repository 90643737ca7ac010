/*
 * util.c -- gid hash map, byte buffers and sorting helpers of src/dmesh/.
 *
 * Invariants: a gidmap is at most half full, so probing always ends on an
 * empty slot; a gidindex holds either its dense array or its map; sorting
 * is an LSD radix sort on (key, index) pairs, stable, with as few passes of
 * digits of at most 11 bits as the largest key needs.
 */
#include "dmesh/util.h"

pa_status pa__gidmap_init(pa__gidmap *m, size_t nexpected) {
  pa_status st = PA_SUCCESS;
  size_t cap = 16;
  while (cap < 2 * nexpected + 2) cap *= 2;
  memset(m, 0, sizeof *m);
  PA_ALLOC(m->key, cap);
  PA_ALLOC(m->val, cap);
  for (size_t i = 0; i < cap; i++) m->key[i] = -1;
  m->cap = cap;
cleanup:
  if (st) pa__gidmap_free(m);
  return st;
}

void pa__gidmap_free(pa__gidmap *m) {
  pa__free(m->key);
  pa__free(m->val);
  memset(m, 0, sizeof *m);
}

static size_t slot_of(const pa__gidmap *m, pa_gid key) {
  return (size_t)pa__mix64((uint64_t)key) & (m->cap - 1);
}

static pa_status gidmap_grow(pa__gidmap *m) {
  pa_status st = PA_SUCCESS;
  pa__gidmap big;
  PA_CALL(pa__gidmap_init(&big, m->cap));
  for (size_t i = 0; i < m->cap; i++) {
    if (m->key[i] < 0) continue;
    size_t s = slot_of(&big, m->key[i]);
    while (big.key[s] >= 0) s = (s + 1) & (big.cap - 1);
    big.key[s] = m->key[i];
    big.val[s] = m->val[i];
  }
  big.n = m->n;
  pa__gidmap_free(m);
  *m = big;
cleanup:
  return st;
}

pa_status pa__gidmap_put_slow(pa__gidmap *m, pa_gid key, pa_idx val,
                              int *found, pa_idx *old) {
  pa_status st = PA_SUCCESS;
  if (found) *found = 0;
  PA_CHECK(key >= 0, PA_ERR_ARG, "negative global id %lld", (long long)key);
  if (m->cap == 0 || 2 * (m->n + 1) > m->cap) PA_CALL(gidmap_grow(m));
  return pa__gidmap_put(m, key, val, found, old);
cleanup:
  return st;
}

pa_status pa__gidindex_init(pa__gidindex *x, pa_gid lo, pa_gid hi,
                            size_t nexpected) {
  pa_status st = PA_SUCCESS;
  memset(x, 0, sizeof *x);
  if (hi < lo) hi = lo;
  x->lo = lo;
  x->hi = hi;
  /* (negative keys go to the map, which reports them) */
  if (lo >= 0 && (uint64_t)(hi - lo) <=
                     PA_DMESH_GIDINDEX_DENSE * (uint64_t)nexpected + 64) {
    PA_ALLOC(x->dense, hi - lo);
    memset(x->dense, 0xff, (size_t)(hi - lo) * sizeof *x->dense); /* -1 */
  } else {
    PA_CALL(pa__gidmap_init(&x->map, nexpected));
  }
cleanup:
  return st;
}

pa_status pa__gidindex_init_keys(pa__gidindex *x, const pa_gid *keys,
                                 size_t n) {
  pa_gid lo = INT64_MAX, hi = -1;
  for (size_t i = 0; i < n; i++) {
    if (keys[i] < lo) lo = keys[i];
    if (keys[i] > hi) hi = keys[i];
  }
  return pa__gidindex_init(x, n ? lo : 0, hi + 1, n);
}

void pa__gidindex_free(pa__gidindex *x) {
  pa__free(x->dense);
  pa__gidmap_free(&x->map);
  memset(x, 0, sizeof *x);
}

pa_status pa__buf_reserve(pa__buf *b, size_t extra) {
  pa_status st = PA_SUCCESS;
  PA_GROW(b->p, b->cap, b->n + extra);
cleanup:
  return st;
}

size_t pa__gid_sort_unique(pa_gid *a, size_t n) {
  /* through (key, 0) pairs and pa__key64_sort (a stable radix sort) */
  pa__key64 *p = pa__malloc((n ? n : 1) * sizeof *p);
  if (!p) { /* out of memory: degrade to a heap sort, still correct */
    for (size_t i = n / 2; i-- > 0;) {
      size_t r = i;
      for (;;) {
        size_t c = 2 * r + 1;
        if (c >= n) break;
        if (c + 1 < n && a[c + 1] > a[c]) c++;
        if (a[r] >= a[c]) break;
        pa_gid t = a[r]; a[r] = a[c]; a[c] = t;
        r = c;
      }
    }
    for (size_t e = n; e-- > 1;) {
      pa_gid t = a[0]; a[0] = a[e]; a[e] = t;
      size_t r = 0;
      for (;;) {
        size_t c = 2 * r + 1;
        if (c >= e) break;
        if (c + 1 < e && a[c + 1] > a[c]) c++;
        if (a[r] >= a[c]) break;
        t = a[r]; a[r] = a[c]; a[c] = t;
        r = c;
      }
    }
  } else {
    for (size_t i = 0; i < n; i++) p[i].key = (uint64_t)a[i], p[i].idx = 0;
    if (pa__key64_sort(p, n) == PA_SUCCESS)
      for (size_t i = 0; i < n; i++) a[i] = (pa_gid)p[i].key;
    pa__free(p);
  }
  size_t m = 0;
  for (size_t i = 0; i < n; i++)
    if (m == 0 || a[i] != a[m - 1]) a[m++] = a[i];
  return m;
}

/* The global ids of a gathered mesh span little more than their count:
 * sorted by counting (one count per id value, 4 bytes each), the counts
 * and the sorted copy touch 8-20 bytes per key where the radix sort's
 * pairs and their copy touch 32 (fresh pages cost more than the sort). */
#define COUNT_SPAN_PER_KEY 3

int pa__gid_span_countable(pa_gid lo, pa_gid hi, size_t n) {
  return (uint64_t)(hi - lo) < (uint64_t)COUNT_SPAN_PER_KEY * n &&
         (uint64_t)COUNT_SPAN_PER_KEY * n < (uint64_t)INT32_MAX;
}

/* Stable counting sort of idx by key over [lo, lo + span); the caller
 * checked pa__gid_span_countable. */
static pa_status counting_sort(pa_idx *idx, size_t n, const pa_gid *key,
                               pa_gid lo, size_t span) {
  pa_status st = PA_SUCCESS;
  pa_idx *cnt = NULL, *out = NULL;
  PA_CALLOC(cnt, span + 1);
  PA_ALLOC(out, n);
  for (size_t i = 0; i < n; i++) cnt[key[idx[i]] - lo + 1]++;
  for (size_t b = 0; b < span; b++) cnt[b + 1] += cnt[b];
  for (size_t i = 0; i < n; i++) out[cnt[key[idx[i]] - lo]++] = idx[i];
  memcpy(idx, out, n * sizeof *idx);
cleanup:
  pa__free(cnt);
  pa__free(out);
  return st;
}

pa_status pa__sort_by_gid(pa_idx *idx, size_t n, const pa_gid *key) {
  pa_status st = PA_SUCCESS;
  pa__key64 *p = NULL;
  size_t s = 1;
  while (s < n && key[idx[s - 1]] <= key[idx[s]]) s++;
  if (s >= n) return PA_SUCCESS; /* already in order */
  pa_gid lo = key[idx[0]], hi = lo;
  for (size_t i = 1; i < n; i++) {
    pa_gid k = key[idx[i]];
    lo = k < lo ? k : lo;
    hi = k > hi ? k : hi;
  }
  if (pa__gid_span_countable(lo, hi, n))
    return counting_sort(idx, n, key, lo, (size_t)(hi - lo) + 1);
  PA_ALLOC(p, n);
  for (size_t i = 0; i < n; i++) {
    p[i].key = (uint64_t)key[idx[i]];
    p[i].idx = idx[i];
  }
  PA_CALL(pa__key64_sort(p, n));
  for (size_t i = 0; i < n; i++) idx[i] = p[i].idx;
cleanup:
  pa__free(p);
  return st;
}
