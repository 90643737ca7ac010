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
/* Insert key -> val; if key is present, leave it and return its value in
 * *old (may be NULL) with *found = 1. */
pa_status pa__gidmap_put(pa__gidmap *m, pa_gid key, pa_idx val, int *found,
                         pa_idx *old);
/* Value of key, or -1 if absent. */
pa_idx pa__gidmap_get(const pa__gidmap *m, pa_gid key);

/* Growable byte buffer. */
typedef struct pa__buf {
  unsigned char *p;
  size_t n, cap;
} pa__buf;

pa_status pa__buf_reserve(pa__buf *b, size_t extra);
/* Append n bytes (buffer must have room: call pa__buf_reserve first). */
static inline void pa__buf_put(pa__buf *b, const void *x, size_t n) {
  memcpy(b->p + b->n, x, n);
  b->n += n;
}
static inline void pa__buf_free(pa__buf *b) {
  pa__free(b->p);
  b->p = NULL;
  b->n = b->cap = 0;
}
/* Read n bytes at *pos of a received buffer and advance. */
static inline void pa__get(const unsigned char *p, size_t *pos, void *x,
                           size_t n) {
  memcpy(x, p + *pos, n);
  *pos += n;
}

/* Sort gids ascending and remove duplicates; returns the new count. */
size_t pa__gid_sort_unique(pa_gid *a, size_t n);
/* Sort idx[0..n) so that key[idx[i]] is ascending (stable). */
pa_status pa__sort_by_gid(pa_idx *idx, size_t n, const pa_gid *key);
/* 64-bit mix of a value (splitmix64 finaliser). */
static inline uint64_t pa__mix64(uint64_t x) {
  x ^= x >> 30;
  x *= 0xBF58476D1CE4E5B9ull;
  x ^= x >> 27;
  x *= 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

#endif /* PA_DMESH_UTIL_H */
