/*
 * util.h -- small data structures of the distributed mesh: a hash map from
 * 64-bit global ids to 32-bit local indices, sorting helpers, and a growable
 * byte buffer used to pack messages.
 */
#ifndef PA_DMESH_UTIL_H
#define PA_DMESH_UTIL_H

#include "core/core.h"

/* Open-addressing hash map pa_gid -> pa_idx (keys >= 0; linear probing;
 * capacity a power of two at most half full). */
typedef struct pa__gidmap {
  size_t cap;   /* slots, power of two (0: empty map) */
  size_t n;     /* keys stored */
  pa_gid *key;  /* -1: empty slot */
  pa_idx *val;
} pa__gidmap;

pa_status pa__gidmap_init(pa__gidmap *m, size_t nexpected);
void pa__gidmap_free(pa__gidmap *m);
/* Insert, slow path (negative key, growth). */
pa_status pa__gidmap_put_slow(pa__gidmap *m, pa_gid key, pa_idx val,
                              int *found, pa_idx *old);
/* Insert key -> val; if key is present, leave it and return its value in
 * *old (may be NULL) with *found = 1. Inline: hash maps sit in the inner
 * loops of the build. */
static inline pa_status pa__gidmap_put(pa__gidmap *m, pa_gid key, pa_idx val,
                                       int *found, pa_idx *old) {
  if (key < 0 || m->cap == 0 || 2 * (m->n + 1) > m->cap)
    return pa__gidmap_put_slow(m, key, val, found, old);
  size_t s = (size_t)pa__mix64((uint64_t)key) & (m->cap - 1);
  while (m->key[s] >= 0) {
    if (m->key[s] == key) {
      if (found) *found = 1;
      if (old) *old = m->val[s];
      return PA_SUCCESS;
    }
    s = (s + 1) & (m->cap - 1);
  }
  if (found) *found = 0;
  m->key[s] = key;
  m->val[s] = val;
  m->n++;
  return PA_SUCCESS;
}
/* Value of key, or -1 if absent. */
static inline pa_idx pa__gidmap_get(const pa__gidmap *m, pa_gid key) {
  if (m->cap == 0 || key < 0) return -1;
  size_t s = (size_t)pa__mix64((uint64_t)key) & (m->cap - 1);
  while (m->key[s] >= 0) {
    if (m->key[s] == key) return m->val[s];
    s = (s + 1) & (m->cap - 1);
  }
  return -1;
}

/* Index gid -> pa_idx for keys known to lie in [lo, hi) (other keys are
 * absent). When the range holds at most PA_DMESH_GIDINDEX_DENSE times the
 * expected count of keys, a plain array over the range (the keys are dense:
 * one array read per lookup, and nearby gids -- nearby entities -- share
 * cache lines, where a hash spreads them over a map far beyond cache); it
 * then takes no more memory than the hash map, which is used otherwise. */
#define PA_DMESH_GIDINDEX_DENSE 4
typedef struct pa__gidindex {
  pa_gid lo, hi;  /* the key range */
  pa_idx *dense;  /* hi - lo values, -1: absent; NULL: map is used */
  pa__gidmap map;
} pa__gidindex;

pa_status pa__gidindex_init(pa__gidindex *x, pa_gid lo, pa_gid hi,
                            size_t nexpected);
/* pa__gidindex_init over the range of the n keys (nexpected = n). */
pa_status pa__gidindex_init_keys(pa__gidindex *x, const pa_gid *keys,
                                 size_t n);
void pa__gidindex_free(pa__gidindex *x);
/* As pa__gidmap_put; fails with PA_ERR_INTERNAL for a key out of [lo, hi). */
static inline pa_status pa__gidindex_put(pa__gidindex *x, pa_gid key,
                                         pa_idx val, int *found, pa_idx *old) {
  if (!x->dense) return pa__gidmap_put(&x->map, key, val, found, old);
  if (key < x->lo || key >= x->hi)
    return pa__error(PA_ERR_INTERNAL, __FILE__, __LINE__,
                     "global id %lld out of the index range [%lld, %lld)",
                     (long long)key, (long long)x->lo, (long long)x->hi);
  pa_idx *v = x->dense + (key - x->lo);
  if (found) *found = *v >= 0;
  if (*v >= 0) {
    if (old) *old = *v;
  } else {
    *v = val;
  }
  return PA_SUCCESS;
}
/* Value of key, or -1 if absent. */
static inline pa_idx pa__gidindex_get(const pa__gidindex *x, pa_gid key) {
  if (!x->dense) return pa__gidmap_get(&x->map, key);
  return key >= x->lo && key < x->hi ? x->dense[key - x->lo] : -1;
}

/* Growable byte buffer. */
typedef struct pa__buf {
  unsigned char *p;
  size_t n, cap;
} pa__buf;

pa_status pa__buf_reserve(pa__buf *b, size_t extra);
static inline void pa__buf_free(pa__buf *b) {
  pa__free(b->p);
  b->p = NULL;
  b->n = b->cap = 0;
}
/* Sort gids ascending and remove duplicates; returns the new count. */
size_t pa__gid_sort_unique(pa_gid *a, size_t n);
/* The position of the first of the n ascending gids g not below x (n if
 * none): a binary search. */
static inline size_t pa__gid_lower_bound(const pa_gid *g, size_t n,
                                         pa_gid x) {
  size_t lo = 0, hi = n;
  while (lo < hi) {
    size_t mid = lo + (hi - lo) / 2;
    if (g[mid] < x) lo = mid + 1;
    else hi = mid;
  }
  return lo;
}
/* Sort idx[0..n) so that key[idx[i]] is ascending (stable). */
pa_status pa__sort_by_gid(pa_idx *idx, size_t n, const pa_gid *key);
/* 1 if n global ids in [lo, hi] span little enough (at most 3 values per
 * id, and a count array below 2^31) for a counting sort to pay: its counts
 * touch fewer fresh pages than a comparison or radix sort. */
int pa__gid_span_countable(pa_gid lo, pa_gid hi, size_t n);

#endif /* PA_DMESH_UTIL_H */
