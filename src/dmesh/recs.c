/*
 * recs.c -- record sets: entities in transit between ranks (see dmesh.h).
 *
 * Wire format of one record, native byte order (all ranks of a run share it):
 *   gid int64 | nv vertex gids int64 | ref int32 | flag uint8 | aux int32 |
 *   ndbl doubles | payload length uint32 | payload bytes.
 * Bulk format of a block of n records (pa__recblock, used by every bulk
 * transfer: migration, scatter, gather, the build's fetches): a header of two
 * int64 (n, payload bytes), then the arrays gid[n], vgid[nv n], dbl[ndbl n],
 * ref[n], aux[n], paylen[n] (uint32, only if payload bytes > 0), flag[n],
 * payload bytes, padded to a multiple of 8 bytes; every array is naturally
 * aligned when the block starts on an 8-byte boundary, so blocks are filled
 * and read in place, array by array.
 *
 * Invariants: arrays of a set share the capacity cap; poff is NULL until the
 * first non-empty payload, after which poff[0..n] are valid offsets into pay.
 */
#include "dmesh/dmesh.h"

#include <sys/mman.h>
#include <unistd.h>

void pa__recs_init(pa__recs *r, int kind, int nv, int ndbl) {
  memset(r, 0, sizeof *r);
  r->kind = kind;
  r->nv = nv;
  r->ndbl = ndbl;
}

void pa__recs_free(pa__recs *r) {
  pa__free(r->gid);
  pa__free(r->vgid);
  pa__free(r->ref);
  pa__free(r->flag);
  pa__free(r->aux);
  pa__free(r->dbl);
  pa__free(r->poff);
  pa__free(r->pay);
  int kind = r->kind, nv = r->nv, ndbl = r->ndbl;
  pa__recs_init(r, kind, nv, ndbl);
}

/* Room for need records: grown by a factor (exact: to need exactly, for
 * reservations of a known size). */
static pa_status recs_grow_to(pa__recs *r, size_t need, int exact) {
  pa_status st = PA_SUCCESS;
  if (need <= r->cap) return PA_SUCCESS;
  size_t cap = exact ? need : r->cap + r->cap / 2 + 64;
  if (cap < need) cap = need;
  void *p;
#define GROW1(f, m)                                                          \
  do {                                                                       \
    p = pa__realloc(r->f, (m) * cap * sizeof *r->f + 1);                     \
    PA_CHECK(p, PA_ERR_MEMORY, "out of memory growing records to %zu", cap); \
    r->f = p;                                                                \
  } while (0)
  GROW1(gid, 1);
  GROW1(vgid, (size_t)r->nv);
  GROW1(ref, 1);
  GROW1(flag, 1);
  GROW1(aux, 1);
  GROW1(dbl, (size_t)r->ndbl);
  if (r->poff) {
    p = pa__realloc(r->poff, (cap + 1) * sizeof *r->poff);
    PA_CHECK(p, PA_ERR_MEMORY, "out of memory growing records to %zu", cap);
    r->poff = p;
  }
#undef GROW1
  r->cap = cap;
cleanup:
  return st;
}

/* The payload offsets of r, created when its first payload comes: the
 * records so far have none (zeros up to n; the offsets beyond are written
 * as records are added, so the rest is left as it is). */
static pa_status poff_create(pa__recs *r) {
  pa_status st = PA_SUCCESS;
  PA_ALLOC(r->poff, r->cap + 1);
  for (size_t i = 0; i <= r->n; i++) r->poff[i] = 0;
cleanup:
  return st;
}

static pa_status recs_grow(pa__recs *r, size_t need) {
  return recs_grow_to(r, need, 0);
}

pa_status pa__recs_room(pa__recs *r, size_t paylen) {
  pa_status st = PA_SUCCESS;
  PA_CALL(recs_grow(r, r->n + 1));
  if (paylen && !r->poff) {
    PA_CALL(poff_create(r));
  }
  if (r->poff) PA_GROW(r->pay, r->paycap, r->poff[r->n] + paylen);
cleanup:
  return st;
}

pa_status pa__recs_append(pa__recs *r, const pa__recs *in, size_t k0,
                          size_t n) {
  pa_status st = PA_SUCCESS;
  size_t nv = (size_t)r->nv, nd = (size_t)r->ndbl, i0 = r->n;
  size_t pay = in->poff ? in->poff[k0 + n] - in->poff[k0] : 0;
  PA_ASSERT(in->nv == r->nv && in->ndbl == r->ndbl);
  if (!n) return PA_SUCCESS;
  PA_CALL(recs_grow(r, i0 + n));
  if (pay && !r->poff) PA_CALL(poff_create(r));
  memcpy(r->gid + i0, in->gid + k0, n * sizeof *r->gid);
  if (nv)
    memcpy(r->vgid + nv * i0, in->vgid + nv * k0, nv * n * sizeof *r->vgid);
  memcpy(r->ref + i0, in->ref + k0, n * sizeof *r->ref);
  memcpy(r->flag + i0, in->flag + k0, n * sizeof *r->flag);
  memcpy(r->aux + i0, in->aux + k0, n * sizeof *r->aux);
  if (nd) memcpy(r->dbl + nd * i0, in->dbl + nd * k0, nd * n * sizeof *r->dbl);
  if (r->poff) {
    size_t off = r->poff[i0];
    PA_GROW(r->pay, r->paycap, off + pay);
    if (pay) memcpy(r->pay + off, in->pay + in->poff[k0], pay);
    for (size_t i = 0; i < n; i++)
      r->poff[i0 + i + 1] =
          off + (in->poff ? in->poff[k0 + i + 1] - in->poff[k0] : 0);
  }
  r->n = i0 + n;
cleanup:
  return st;
}

static size_t paylen_of(const pa__recs *r, size_t i) {
  return r->poff ? r->poff[i + 1] - r->poff[i] : 0;
}

size_t pa__recs_wire(const pa__recs *r, size_t i) {
  return 8 + 8 * (size_t)r->nv + 4 + 1 + 4 + 8 * (size_t)r->ndbl + 4 +
         paylen_of(r, i);
}

size_t pa__recblock_bytes(int nv, int ndbl, size_t n, size_t paybytes) {
  size_t b = 16 + n * (8 + 8 * (size_t)nv + 8 * (size_t)ndbl + 4 + 4 + 1) +
             (paybytes ? 4 * n + paybytes : 0);
  return (b + 7) & ~(size_t)7;
}

/* Point the arrays of b at the block starting at p (header already set). */
static void block_map(unsigned char *p, int nv, int ndbl, pa__recblock *b) {
  int64_t h[2];
  memcpy(h, p, sizeof h);
  size_t n = (size_t)h[0];
  b->n = n;
  b->paybytes = (size_t)h[1];
  p += 16;
  b->gid = (pa_gid *)(void *)p;
  p += 8 * n;
  b->vgid = (pa_gid *)(void *)p;
  p += 8 * (size_t)nv * n;
  b->dbl = (double *)(void *)p;
  p += 8 * (size_t)ndbl * n;
  b->ref = (int32_t *)(void *)p;
  p += 4 * n;
  b->aux = (int32_t *)(void *)p;
  p += 4 * n;
  b->paylen = NULL;
  if (b->paybytes) {
    b->paylen = (uint32_t *)(void *)p;
    p += 4 * n;
  }
  b->flag = p;
  p += n;
  b->pay = p;
  b->bytes = pa__recblock_bytes(nv, ndbl, n, b->paybytes);
}

void pa__recblock_init(unsigned char *p, int nv, int ndbl, size_t n,
                       size_t paybytes, pa__recblock *b) {
  int64_t h[2] = {(int64_t)n, (int64_t)paybytes};
  memcpy(p, h, sizeof h);
  block_map(p, nv, ndbl, b);
}

void pa__recblock_map(const unsigned char *p, int nv, int ndbl,
                      pa__recblock *b) {
  block_map((unsigned char *)(uintptr_t)p, nv, ndbl, b);
}

size_t pa__recs_paybytes(const pa__recs *r, const pa_idx *idx, size_t n) {
  size_t s = 0;
  if (!r->poff) return 0;
  for (size_t k = 0; k < n; k++) {
    size_t i = idx ? (size_t)idx[k] : k;
    s += r->poff[i + 1] - r->poff[i];
  }
  return s;
}

size_t pa__recs_put(const pa__recs *r, const pa_idx *idx, size_t n,
                    unsigned char *p) {
  pa__recblock b;
  int nv = r->nv, nd = r->ndbl;
  pa__recblock_init(p, nv, nd, n, pa__recs_paybytes(r, idx, n), &b);
#define SEL(k) (idx ? (size_t)idx[k] : (k))
  for (size_t k = 0; k < n; k++) b.gid[k] = r->gid[SEL(k)];
  if (nv)
    for (size_t k = 0; k < n; k++)
      memcpy(b.vgid + (size_t)nv * k, r->vgid + (size_t)nv * SEL(k),
             (size_t)nv * sizeof(pa_gid));
  if (nd)
    for (size_t k = 0; k < n; k++)
      memcpy(b.dbl + (size_t)nd * k, r->dbl + (size_t)nd * SEL(k),
             (size_t)nd * sizeof(double));
  for (size_t k = 0; k < n; k++) b.ref[k] = r->ref[SEL(k)];
  for (size_t k = 0; k < n; k++) b.aux[k] = r->aux[SEL(k)];
  for (size_t k = 0; k < n; k++) b.flag[k] = r->flag[SEL(k)];
  if (b.paybytes) {
    unsigned char *q = b.pay;
    for (size_t k = 0; k < n; k++) {
      size_t i = SEL(k), len = r->poff[i + 1] - r->poff[i];
      b.paylen[k] = (uint32_t)len;
      memcpy(q, r->pay + r->poff[i], len);
      q += len;
    }
  }
#undef SEL
  return b.bytes;
}

pa_status pa__recs_reserve(pa__recs *r, size_t n, size_t paybytes) {
  pa_status st = PA_SUCCESS;
  PA_CALL(recs_grow_to(r, n, 1));
  if (paybytes && !r->poff) {
    PA_CALL(poff_create(r));
  }
  if (r->poff && paybytes > r->paycap) {
    void *p = pa__realloc(r->pay, paybytes);
    PA_CHECK(p, PA_ERR_MEMORY, "out of memory reserving %zu payload bytes",
             paybytes);
    r->pay = p;
    r->paycap = paybytes;
  }
cleanup:
  return st;
}

/* Records smaller than this are not worth a system call to prefault. */
#define PREFAULT_MIN_BYTES (1u << 22)

/* Ask the kernel to map the pages of [p, p + bytes) now, in one call
 * (MADV_POPULATE_WRITE, Linux 5.14 on): a fresh page then costs its
 * clearing, not a fault each; a no-op where unsupported. */
static void prefault(void *p, size_t bytes) {
#ifdef MADV_POPULATE_WRITE
  if (bytes < PREFAULT_MIN_BYTES) return;
  uintptr_t pg = (uintptr_t)sysconf(_SC_PAGESIZE);
  uintptr_t a = ((uintptr_t)p + pg - 1) & ~(pg - 1);
  uintptr_t b = ((uintptr_t)p + bytes) & ~(pg - 1);
  if (b > a) (void)madvise((void *)a, b - a, MADV_POPULATE_WRITE);
#else
  (void)p;
  (void)bytes;
#endif
}

void pa__recs_prefault(pa__recs *r, size_t i0, size_t n) {
  size_t nv = (size_t)r->nv, nd = (size_t)r->ndbl;
  if (i0 + n > r->cap) return;
  prefault(r->gid + i0, n * sizeof *r->gid);
  if (nv) prefault(r->vgid + nv * i0, nv * n * sizeof *r->vgid);
  prefault(r->ref + i0, n * sizeof *r->ref);
  prefault(r->flag + i0, n * sizeof *r->flag);
  prefault(r->aux + i0, n * sizeof *r->aux);
  if (nd) prefault(r->dbl + nd * i0, nd * n * sizeof *r->dbl);
  if (r->poff) {
    prefault(r->poff + i0 + 1, n * sizeof *r->poff);
    prefault(r->pay + r->poff[i0], r->paycap - r->poff[i0]);
  }
}

pa_status pa__recs_get(pa__recs *r, const unsigned char *p, size_t *pos) {
  pa_status st = PA_SUCCESS;
  pa__recblock b;
  int nv = r->nv, nd = r->ndbl;
  PA_CHECK((*pos & 7) == 0 && ((uintptr_t)p & 7) == 0, PA_ERR_INTERNAL,
           "misaligned record block");
  pa__recblock_map(p + *pos, nv, nd, &b);
  size_t n0 = r->n, n = b.n;
  size_t pay0 = r->poff ? r->poff[n0] : 0;
  if (!n) {
    *pos += b.bytes;
    return PA_SUCCESS;
  }
  /* grown by a factor: callers that know the total reserve it first */
  PA_CALL(recs_grow(r, n0 + n));
  if (b.paybytes && !r->poff) PA_CALL(poff_create(r));
  if (r->poff) PA_GROW(r->pay, r->paycap, pay0 + b.paybytes);
  memcpy(r->gid + n0, b.gid, n * sizeof(pa_gid));
  memcpy(r->vgid + (size_t)nv * n0, b.vgid, (size_t)nv * n * sizeof(pa_gid));
  memcpy(r->dbl + (size_t)nd * n0, b.dbl, (size_t)nd * n * sizeof(double));
  memcpy(r->ref + n0, b.ref, n * sizeof(int32_t));
  memcpy(r->aux + n0, b.aux, n * sizeof(int));
  memcpy(r->flag + n0, b.flag, n);
  if (r->poff) {
    size_t off = pay0;
    for (size_t k = 0; k < n; k++) {
      r->poff[n0 + k] = off;
      off += b.paybytes ? b.paylen[k] : 0;
    }
    r->poff[n0 + n] = off;
    if (b.paybytes) memcpy(r->pay + pay0, b.pay, b.paybytes);
  }
  r->n = n0 + n;
  *pos += b.bytes;
cleanup:
  return st;
}

/* Permute the fixed-size array a (n items of u bytes) in place so that
 * item k becomes old item ord[k], following the cycles of ord (done marks
 * visited items; cleared on return). */
static void permute_array(unsigned char *a, size_t u, size_t n,
                          const pa_idx *ord, uint8_t *done) {
  unsigned char t[64];
  if (!u) return;
  for (size_t k = 0; k < n; k++) {
    if (done[k] || (size_t)ord[k] == k) continue;
    memcpy(t, a + u * k, u);
    size_t j = k;
    for (;;) {
      size_t i = (size_t)ord[j];
      done[j] = 1;
      if (i == k) {
        memcpy(a + u * j, t, u);
        break;
      }
      memcpy(a + u * j, a + u * i, u);
      j = i;
    }
  }
  memset(done, 0, n);
}

/* Permute the records of r so that record k becomes old record ord[k]
 * (array by array, in place; payloads through a new buffer). */
static pa_status recs_permute(pa__recs *r, const pa_idx *ord) {
  pa_status st = PA_SUCCESS;
  size_t n = r->n;
  uint8_t *done = NULL;
  unsigned char *pay = NULL;
  size_t *poff = NULL;
  PA_CALLOC(done, n);
  PA_CHECK(8 * (size_t)r->nv <= 64, PA_ERR_INTERNAL, "record too wide");
  permute_array((unsigned char *)r->gid, 8, n, ord, done);
  permute_array((unsigned char *)r->vgid, 8 * (size_t)r->nv, n, ord, done);
  permute_array((unsigned char *)r->ref, 4, n, ord, done);
  permute_array((unsigned char *)r->aux, sizeof(int), n, ord, done);
  permute_array(r->flag, 1, n, ord, done);
  if (r->ndbl) { /* wide rows: in chunks of 8 doubles */
    double *tmp;
    size_t nd = (size_t)r->ndbl;
    PA_ALLOC(tmp, n * nd);
    for (size_t k = 0; k < n; k++)
      memcpy(tmp + nd * k, r->dbl + nd * (size_t)ord[k], nd * sizeof(double));
    memcpy(r->dbl, tmp, n * nd * sizeof(double));
    pa__free(tmp);
  }
  if (r->poff) {
    PA_ALLOC(pay, r->poff[n]);
    PA_ALLOC(poff, r->cap + 1);
    size_t off = 0;
    for (size_t k = 0; k < n; k++) {
      size_t i = (size_t)ord[k], len = r->poff[i + 1] - r->poff[i];
      poff[k] = off;
      memcpy(pay + off, r->pay + r->poff[i], len);
      off += len;
    }
    poff[n] = off;
    pa__free(r->pay);
    pa__free(r->poff);
    r->pay = pay;
    r->paycap = off;
    r->poff = poff;
    pay = NULL;
    poff = NULL;
  }
cleanup:
  pa__free(done);
  pa__free(pay);
  pa__free(poff);
  return st;
}

/* Merge the sorted runs [run[q], run[q+1]) of ord (keys gid) pairwise until
 * one is left (stable); tmp holds n indices. */
static void merge_runs(pa_idx *ord, pa_idx *tmp, size_t *run, size_t nrun,
                       const pa_gid *gid) {
  pa_idx *src = ord, *dst = tmp;
  while (nrun > 1) {
    size_t m = 0;
    for (size_t q = 0; q < nrun; q += 2) {
      size_t lo = run[q], mid = run[q + 1], hi = q + 2 <= nrun ? run[q + 2] : mid;
      size_t i = lo, j = mid, k = lo;
      if (q + 1 >= nrun) mid = hi = run[q + 1];
      while (i < mid && j < hi)
        dst[k++] = gid[src[j]] < gid[src[i]] ? src[j++] : src[i++];
      while (i < mid) dst[k++] = src[i++];
      while (j < hi) dst[k++] = src[j++];
      run[m++] = lo;
    }
    run[m] = run[nrun];
    nrun = m;
    pa_idx *t = src;
    src = dst;
    dst = t;
  }
  if (src != ord) memcpy(ord, src, run[1] * sizeof *ord);
}

pa_status pa__recs_sort(pa__recs *r) {
  pa_status st = PA_SUCCESS;
  pa_idx *ord = NULL, *tmp = NULL;
  size_t *run = NULL, nrun = 1;
  for (size_t i = 1; i < r->n; i++) nrun += r->gid[i] < r->gid[i - 1];
  if (r->n < 2 || nrun == 1) return PA_SUCCESS; /* already sorted */
  PA_ALLOC(ord, r->n);
  for (size_t k = 0; k < r->n; k++) ord[k] = (pa_idx)k;
  if (nrun <= 64) { /* a few sorted runs (one per source rank): merge */
    PA_ALLOC(tmp, r->n);
    PA_ALLOC(run, nrun + 1);
    size_t q = 0;
    run[q++] = 0;
    for (size_t i = 1; i < r->n; i++)
      if (r->gid[i] < r->gid[i - 1]) run[q++] = i;
    run[q] = r->n;
    merge_runs(ord, tmp, run, nrun, r->gid);
    pa__free(tmp);
    tmp = NULL;
  } else {
    PA_CALL(pa__sort_by_gid(ord, r->n, r->gid));
  }
  PA_CALL(recs_permute(r, ord));
cleanup:
  pa__free(ord);
  pa__free(tmp);
  pa__free(run);
  return st;
}

/* Append one record to r (room reserved): the fields of record k of a
 * block (take) or of a record set (take_rec). */
static void put_one(pa__recs *r, pa_gid gid, const pa_gid *vgid,
                    const double *dbl, int32_t ref, int aux, uint8_t flag,
                    const unsigned char *pay, size_t len) {
  size_t i = r->n, nv = (size_t)r->nv, nd = (size_t)r->ndbl;
  r->gid[i] = gid;
  if (nv) memcpy(r->vgid + nv * i, vgid, nv * sizeof(pa_gid));
  if (nd) memcpy(r->dbl + nd * i, dbl, nd * sizeof(double));
  r->ref[i] = ref;
  r->aux[i] = aux;
  r->flag[i] = flag;
  if (r->poff) {
    if (len) memcpy(r->pay + r->poff[i], pay, len);
    r->poff[i + 1] = r->poff[i] + len;
  }
  r->n++;
}

static void take(pa__recs *r, const pa__recblock *b, size_t k,
                 const unsigned char *pay) {
  size_t nv = (size_t)r->nv, nd = (size_t)r->ndbl;
  put_one(r, b->gid[k], nv ? b->vgid + nv * k : NULL,
          nd ? b->dbl + nd * k : NULL, b->ref[k], b->aux[k], b->flag[k], pay,
          b->paybytes ? b->paylen[k] : 0);
}

static void take_rec(pa__recs *r, const pa__recs *in, size_t k) {
  size_t nv = (size_t)r->nv, nd = (size_t)r->ndbl;
  put_one(r, in->gid[k], nv ? in->vgid + nv * k : NULL,
          nd ? in->dbl + nd * k : NULL, in->ref[k], in->aux[k], in->flag[k],
          in->pay ? in->pay + in->poff[k] : NULL, paylen_of(in, k));
}

/* One sorted source of a merge: a received block (sel NULL), or the
 * records sel[0..n) of the set being migrated (those staying here). */
typedef struct msrc {
  pa__recblock b;
  const pa_idx *sel;
  size_t n, cur, pcur; /* records, next one, its payload offset in b */
} msrc;

static pa_gid msrc_gid(const msrc *q, const pa__recs *in, size_t k) {
  return q->sel ? in->gid[q->sel[k]] : q->b.gid[k];
}

static void msrc_take(pa__recs *r, msrc *q, const pa__recs *in) {
  size_t k = q->cur++;
  if (q->sel) {
    take_rec(r, in, (size_t)q->sel[k]);
  } else {
    take(r, &q->b, k, q->b.pay + q->pcur);
    if (q->b.paybytes) q->pcur += q->b.paylen[k];
  }
}

/* Append to r (room reserved) the records of the received blocks
 * buf[0..tot) (one per rank with a nonzero rcnt, in rank order) and the
 * records sel[0..nsel) of in, which stay on this rank (me), sorted by gid,
 * ties in rank order (stable). Senders sort each block (and sel), so this
 * is a merge: no sort and no permutation of the records; beyond 64 sources
 * the records are appended in rank order and sorted. */
static pa_status merge_sources(pa__recs *r, const unsigned char *buf,
                               const size_t *rcnt, int me, int size,
                               const pa__recs *in, const pa_idx *sel,
                               size_t nsel) {
  pa_status st = PA_SUCCESS;
  msrc *src = NULL;
  size_t ns = 0, q = 0;
  PA_CALLOC(src, (size_t)size);
  for (int p = 0; p < size; p++) {
    if (p == me && nsel) {
      src[ns].sel = sel;
      src[ns++].n = nsel;
    }
    if (rcnt[p]) {
      pa__recblock_map(buf + q, r->nv, r->ndbl, &src[ns].b);
      q += src[ns].b.bytes;
      src[ns].n = src[ns].b.n;
      ns++;
    }
  }
  for (size_t k = 0; k < ns; k++)
    for (size_t i = 1; i < src[k].n; i++)
      PA_ASSERT(msrc_gid(&src[k], in, i - 1) <= msrc_gid(&src[k], in, i));
  if (ns > 64) {
    for (size_t k = 0; k < ns; k++)
      while (src[k].cur < src[k].n) msrc_take(r, &src[k], in);
    PA_CALL(pa__recs_sort(r));
    goto cleanup;
  }
  for (;;) { /* smallest head; a linear scan over at most 64 sources */
    size_t best = ns;
    for (size_t k = 0; k < ns; k++)
      if (src[k].cur < src[k].n &&
          (best == ns || msrc_gid(&src[k], in, src[k].cur) <
                             msrc_gid(&src[best], in, src[best].cur)))
        best = k;
    if (best == ns) break;
    /* take the run of best that stays below every other head */
    pa_gid lim = INT64_MAX;
    for (size_t k = 0; k < ns; k++)
      if (k != best && src[k].cur < src[k].n &&
          msrc_gid(&src[k], in, src[k].cur) < lim)
        lim = msrc_gid(&src[k], in, src[k].cur);
    msrc *bq = &src[best];
    do {
      msrc_take(r, bq, in);
    } while (bq->cur < bq->n && msrc_gid(bq, in, bq->cur) < lim);
  }
cleanup:
  pa__free(src);
  return st;
}

/* Migration; with consume, the input is freed once its records are out.
 * The records of each destination are sorted by gid at the sender (an
 * index sort: the packing gathers through the index anyway), so the
 * receiver merges the blocks instead of sorting and permuting every array.
 * The records staying on this rank (most of them in the adaptation loop)
 * are neither packed nor sent: they are merged straight from in. */
static pa_status migrate(MPI_Comm comm, pa__recs *in, const int *dest,
                         pa__recs *out, int consume) {
  pa_status st = PA_SUCCESS;
  int rank, size;
  size_t *cnt = NULL, *rcnt = NULL, *start = NULL, *pay = NULL;
  pa_idx *byrank = NULL;
  unsigned char *sbuf = NULL;
  void *recv = NULL;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  pa__recs_init(out, in->kind, in->nv, in->ndbl);
  if (!dest) dest = in->aux;
  PA_CALLOC(cnt, size);
  PA_CALLOC(pay, size);
  PA_CALLOC(start, (size_t)size + 1);
  size_t nstay = 0;
  while (nstay < in->n && dest[nstay] == rank) nstay++;
  int allstay = nstay == in->n; /* (in may be freed before the merge) */
  if (nstay == in->n) {
    /* every record stays (the adaptation's rebuild, mostly): nothing to
     * pack, and the index of the staying records is the identity */
    start[rank + 1] = in->n;
    for (int r = rank + 1; r < size; r++) start[r + 1] = in->n;
    if (in->poff) pay[rank] = in->poff[in->n] - in->poff[0];
  }
  for (size_t i = nstay; i < in->n; i++) {
    PA_CHECK(dest[i] >= 0 && dest[i] < size, PA_ERR_ARG,
             "destination rank %d of entity %lld out of [0, %d)", dest[i],
             (long long)in->gid[i], size);
    start[dest[i] + 1]++;
    if (in->poff) pay[dest[i]] += in->poff[i + 1] - in->poff[i];
  }
  if (nstay < in->n) {
    /* (the records before the first leaving one stay) */
    start[rank + 1] += nstay;
    if (in->poff) pay[rank] += in->poff[nstay] - in->poff[0];
    for (int r = 0; r < size; r++) start[r + 1] += start[r];
  }
  /* records by destination (stable), each destination's sorted by gid;
   * when every record stays, the identity, made only if blocks arrive */
  if (nstay < in->n) {
    PA_ALLOC(byrank, in->n);
    size_t *cur;
    PA_ALLOC(cur, size);
    memcpy(cur, start, (size_t)size * sizeof *cur);
    for (size_t i = 0; i < in->n; i++) byrank[cur[dest[i]]++] = (pa_idx)i;
    pa__free(cur);
  }
  for (int r = 0; r < size && nstay < in->n; r++)
    PA_CALL(pa__sort_by_gid(byrank + start[r], start[r + 1] - start[r],
                            in->gid));
  size_t total = 0, nself = start[rank + 1] - start[rank];
  for (int r = 0; r < size; r++) {
    size_t nr = start[r + 1] - start[r];
    cnt[r] = nr && r != rank
                 ? pa__recblock_bytes(in->nv, in->ndbl, nr, pay[r])
                 : 0;
    total += cnt[r];
  }
  PA_ALLOC(sbuf, total);
  {
    size_t off = 0;
    for (int r = 0; r < size; r++)
      if (cnt[r])
        off += pa__recs_put(in, byrank + start[r], start[r + 1] - start[r],
                            sbuf + off);
  }
  if (consume && !nself) pa__recs_free(in);
  PA_CALL(pa__xchg_sparse(comm, cnt, sbuf, &rcnt, &recv));
  pa__free(sbuf);
  sbuf = NULL;
  {
    size_t tot = 0, nrec = nself, q = 0, npay;
    for (int r = 0; r < size; r++) tot += rcnt[r];
    if (consume && nself == in->n && !tot) {
      /* nothing moves: the input becomes the output, sorted (in place,
       * unless it is in order already) */
      *out = *in;
      pa__recs_init(in, out->kind, out->nv, out->ndbl);
      PA_CALL(pa__recs_sort(out));
      goto cleanup;
    }
    if (allstay) { /* the identity index, sorted for the merge */
      PA_ALLOC(byrank, in->n ? in->n : 1);
      for (size_t i = 0; i < in->n; i++) byrank[i] = (pa_idx)i;
      PA_CALL(pa__sort_by_gid(byrank, in->n, in->gid));
    }
    npay = pa__recs_paybytes(in, byrank + start[rank], nself);
    while (q < tot) {
      pa__recblock b;
      pa__recblock_map((unsigned char *)recv + q, out->nv, out->ndbl, &b);
      nrec += b.n;
      npay += b.paybytes;
      q += b.bytes;
    }
    PA_CHECK(q == tot, PA_ERR_INTERNAL, "record blocks of %zu bytes, %zu read",
             tot, q);
    PA_CALL(pa__recs_reserve(out, nrec, npay));
    PA_CALL(merge_sources(out, recv, rcnt, rank, size, in,
                          byrank + start[rank], nself));
  }
cleanup:
  st = pa__agree_end(comm, st);
  if (consume) pa__recs_free(in);
  pa__free(cnt);
  pa__free(rcnt);
  pa__free(start);
  pa__free(pay);
  pa__free(byrank);
  pa__free(sbuf);
  pa__free(recv);
  if (st) pa__recs_free(out);
  return st;
}

pa_status pa__recs_migrate(MPI_Comm comm, const pa__recs *in, const int *dest,
                           pa__recs *out) {
  return migrate(comm, (pa__recs *)(uintptr_t)in, dest, out, 0);
}

pa_status pa__recs_migrate_free(MPI_Comm comm, pa__recs *in, const int *dest,
                                pa__recs *out) {
  return migrate(comm, in, dest, out, 1);
}
