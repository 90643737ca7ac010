/*
 * recs.c -- record sets: entities in transit between ranks (see dmesh.h).
 *
 * Wire format of one record, native byte order (all ranks of a run share it):
 *   gid int64 | nv vertex gids int64 | ref int32 | flag uint8 | aux int32 |
 *   ndbl doubles | payload length uint32 | payload bytes.
 * Invariants: arrays of a set share the capacity cap; poff is NULL until the
 * first non-empty payload, after which poff[0..n] are valid offsets into pay.
 */
#include "dmesh/dmesh.h"

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

static pa_status recs_grow(pa__recs *r, size_t need) {
  pa_status st = PA_SUCCESS;
  if (need <= r->cap) return PA_SUCCESS;
  size_t cap = r->cap + r->cap / 2 + 64;
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

pa_status pa__recs_add(pa__recs *r, pa_gid gid, const pa_gid *vgid,
                       int32_t ref, uint8_t flag, int aux, const double *dbl,
                       const void *pay, size_t paylen) {
  pa_status st = PA_SUCCESS;
  PA_CALL(recs_grow(r, r->n + 1));
  if (paylen && !r->poff) {
    PA_CALLOC(r->poff, r->cap + 1);
  }
  size_t i = r->n;
  r->gid[i] = gid;
  if (r->nv) memcpy(r->vgid + (size_t)r->nv * i, vgid, r->nv * sizeof *vgid);
  r->ref[i] = ref;
  r->flag[i] = flag;
  r->aux[i] = aux;
  if (r->ndbl) memcpy(r->dbl + (size_t)r->ndbl * i, dbl, r->ndbl * sizeof *dbl);
  if (r->poff) {
    size_t off = r->poff[i];
    PA_GROW(r->pay, r->paycap, off + paylen);
    if (paylen) memcpy(r->pay + off, pay, paylen);
    r->poff[i + 1] = off + paylen;
  }
  r->n++;
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

void pa__recs_pack(const pa__recs *r, size_t i, pa__buf *b) {
  uint32_t pl = (uint32_t)paylen_of(r, i);
  pa__buf_put(b, &r->gid[i], 8);
  pa__buf_put(b, r->vgid + (size_t)r->nv * i, 8 * (size_t)r->nv);
  pa__buf_put(b, &r->ref[i], 4);
  pa__buf_put(b, &r->flag[i], 1);
  pa__buf_put(b, &r->aux[i], 4);
  pa__buf_put(b, r->dbl + (size_t)r->ndbl * i, 8 * (size_t)r->ndbl);
  pa__buf_put(b, &pl, 4);
  if (pl) pa__buf_put(b, r->pay + r->poff[i], pl);
}

pa_status pa__recs_unpack(pa__recs *r, const unsigned char *p, size_t *pos) {
  pa_status st = PA_SUCCESS;
  pa_gid gid, vg[4];
  int32_t ref;
  uint8_t flag;
  int aux;
  double dbl[3 + 6 + 64];
  uint32_t pl;
  const double *dp = dbl;
  PA_CHECK(r->nv <= 4, PA_ERR_INTERNAL, "record with %d vertices", r->nv);
  pa__get(p, pos, &gid, 8);
  pa__get(p, pos, vg, 8 * (size_t)r->nv);
  pa__get(p, pos, &ref, 4);
  pa__get(p, pos, &flag, 1);
  pa__get(p, pos, &aux, 4);
  if ((size_t)r->ndbl <= sizeof dbl / sizeof *dbl)
    pa__get(p, pos, dbl, 8 * (size_t)r->ndbl);
  else { /* many fields: copy through an aligned heap buffer */
    double *big;
    PA_ALLOC(big, r->ndbl);
    pa__get(p, pos, big, 8 * (size_t)r->ndbl);
    pa__get(p, pos, &pl, 4);
    st = pa__recs_add(r, gid, vg, ref, flag, aux, big, p + *pos, pl);
    pa__free(big);
    *pos += pl;
    return st;
  }
  pa__get(p, pos, &pl, 4);
  PA_CALL(pa__recs_add(r, gid, vg, ref, flag, aux, dp, p + *pos, pl));
  *pos += pl;
cleanup:
  return st;
}

pa_status pa__recs_migrate(MPI_Comm comm, const pa__recs *in, const int *dest,
                           pa__recs *out) {
  pa_status st = PA_SUCCESS;
  int size;
  size_t *cnt = NULL, *rcnt = NULL, *pos = NULL;
  pa__buf b = {0};
  void *recv = NULL;
  pa_idx *order = NULL;
  pa__recs tmp;
  MPI_Comm_size(comm, &size);
  pa__recs_init(out, in->kind, in->nv, in->ndbl);
  pa__recs_init(&tmp, in->kind, in->nv, in->ndbl);
  if (!dest) dest = in->aux;
  PA_CALLOC(cnt, size);
  PA_CALLOC(pos, (size_t)size + 1);
  for (size_t i = 0; i < in->n; i++) {
    PA_CHECK(dest[i] >= 0 && dest[i] < size, PA_ERR_ARG,
             "destination rank %d of entity %lld out of [0, %d)", dest[i],
             (long long)in->gid[i], size);
    cnt[dest[i]] += pa__recs_wire(in, i);
  }
  for (int r = 0; r < size; r++) pos[r + 1] = pos[r] + cnt[r];
  PA_CALL(pa__buf_reserve(&b, pos[size]));
  /* Pack in place by destination: write each record at its rank's cursor. */
  for (size_t i = 0; i < in->n; i++) {
    pa__buf w = {b.p, pos[dest[i]], b.cap};
    pa__recs_pack(in, i, &w);
    pos[dest[i]] = w.n;
  }
  b.n = pos[size - 1 + 1];
  PA_CALL(pa__xchg_sparse(comm, cnt, b.p, &rcnt, &recv));
  pa__buf_free(&b);
  {
    size_t total = 0;
    for (int r = 0; r < size; r++) total += rcnt[r];
    size_t q = 0;
    while (q < total) PA_CALL(pa__recs_unpack(&tmp, recv, &q));
  }
  pa__free(recv);
  recv = NULL;
  /* Sort by gid, so that the result does not depend on arrival order. */
  PA_ALLOC(order, tmp.n);
  for (size_t i = 0; i < tmp.n; i++) order[i] = (pa_idx)i;
  PA_CALL(pa__sort_by_gid(order, tmp.n, tmp.gid));
  PA_CALL(recs_grow(out, tmp.n));
  for (size_t k = 0; k < tmp.n; k++) {
    size_t i = (size_t)order[k];
    PA_CALL(pa__recs_add(out, tmp.gid[i], tmp.vgid + (size_t)tmp.nv * i,
                         tmp.ref[i], tmp.flag[i], tmp.aux[i],
                         tmp.dbl + (size_t)tmp.ndbl * i,
                         tmp.poff ? tmp.pay + tmp.poff[i] : NULL,
                         paylen_of(&tmp, i)));
  }
cleanup:
  st = pa__agree_end(comm, st);
  pa__free(cnt);
  pa__free(rcnt);
  pa__free(pos);
  pa__buf_free(&b);
  pa__free(recv);
  pa__free(order);
  pa__recs_free(&tmp);
  if (st) pa__recs_free(out);
  return st;
}
