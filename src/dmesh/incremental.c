/*
 * incremental.c -- the records a rebuild starts from, written straight
 * from the arrays of the local mesh into exactly reserved record sets: of
 * every owned entity (pa__dmesh_owned_recs, a redistribution), and of the
 * owned entities that stay when a distributed mesh changed only in part
 * (pa__dmesh_kept_recs, the parallel adaptation loop).
 */
#include "dmesh/dmesh.h"

size_t pa__entity_payload(const pa_dmesh *dm, int kind, pa_idx e,
                          unsigned char *buf) {
  int32_t ref = pa__dmesh_ref(dm, kind, e);
  size_t off = 0;
  for (int k = 0; k < dm->nvalue; k++) {
    const pa_dmesh_value *v = dm->value[k];
    if ((int)v->kind != kind || (v->ref >= 0 && v->ref != ref)) continue;
    pa_idx slot = v->slot ? v->slot[e] : e;
    memcpy(buf + off, v->data + v->unit * (size_t)slot, v->unit);
    off += v->unit;
  }
  return off;
}

/* Records of the owned entities of one kind with keep[i] (keep NULL: all),
 * with room for extra more records; those with priv[i] (priv NULL: none)
 * go to P instead of R, also with room for extra more. */
static pa_status kept_kind(pa_dmesh *dm, int kind, const uint8_t *keep,
                           size_t extra, pa__recs *R, const uint8_t *priv,
                           pa__recs *P) {
  pa_status st = PA_SUCCESS;
  const pa_mesh *m = dm->mesh;
  int d = dm->dim, nv = pa__kind_nv(d, kind), nd = R->ndbl;
  pa_idx nown = dm->nown[kind];
  const pa_idx *conn = kind == PA_ELEMENT    ? m->elem
                       : kind == PA_BOUNDARY ? m->bdry
                                             : m->edge;
  const uint8_t *fl = kind == PA_VERTEX    ? m->vflag
                      : kind == PA_ELEMENT ? m->eflag
                      : kind == PA_BOUNDARY ? m->bflag
                                            : m->edflag;
  size_t n[2] = {0, 0}, unit = pa__kind_unit(dm, kind), paybytes[2] = {0, 0};
  for (pa_idx e = 0; e < nown; e++) {
    if (keep && !keep[e]) continue;
    int t = priv && priv[e];
    n[t]++;
    if (!unit) continue;
    int32_t ref = pa__dmesh_ref(dm, kind, e);
    for (int k = 0; k < dm->nvalue; k++) {
      const pa_dmesh_value *v = dm->value[k];
      if ((int)v->kind == kind && (v->ref < 0 || v->ref == ref))
        paybytes[t] += v->unit;
    }
  }
  PA_CALL(pa__recs_reserve(R, n[0] + extra, paybytes[0] + extra * unit));
  if (priv)
    PA_CALL(pa__recs_reserve(P, n[1] + extra, paybytes[1] + extra * unit));
  for (pa_idx e = 0; e < nown; e++) {
    if (keep && !keep[e]) continue;
    pa__recs *T = priv && priv[e] ? P : R;
    size_t i = T->n++;
    T->gid[i] = dm->gid[kind][e];
    for (int j = 0; j < nv; j++)
      T->vgid[(size_t)nv * i + j] =
          dm->gid[PA_VERTEX][conn[(size_t)nv * e + j]];
    T->ref[i] = pa__dmesh_ref(dm, kind, e);
    T->flag[i] = fl[e];
    T->aux[i] = dm->rank;
    if (nd) pa__entity_doubles(m, kind, e, T->dbl + (size_t)nd * i);
    if (T->poff)
      T->poff[i + 1] =
          T->poff[i] + pa__entity_payload(dm, kind, e, T->pay + T->poff[i]);
  }
cleanup:
  return st;
}

pa_status pa__dmesh_kept_recs(pa_dmesh *dm,
                              const uint8_t *const keep[PA_DMESH_NKIND],
                              const size_t extra[PA_DMESH_NKIND], pa__recs *E,
                              pa__recs *V, pa__recs *B, pa__recs *D,
                              const uint8_t *vpriv, pa__recs *P) {
  pa_status st = PA_SUCCESS;
  pa__layout lay;
  pa__recs *R[PA_DMESH_NKIND];
  pa__dmesh_layout(dm, &lay);
  pa__recs_init(E, PA_ELEMENT, dm->dim + 1, pa__layout_kind_ndbl(&lay, PA_ELEMENT));
  pa__recs_init(V, PA_VERTEX, 0, pa__layout_ndbl(&lay));
  pa__recs_init(B, PA_BOUNDARY, dm->dim, pa__layout_kind_ndbl(&lay, PA_BOUNDARY));
  pa__recs_init(D, PA_EDGE, 2, 0);
  pa__recs_init(P, PA_VERTEX, 0, pa__layout_ndbl(&lay));
  R[PA_VERTEX] = V;
  R[PA_ELEMENT] = E;
  R[PA_BOUNDARY] = B;
  R[PA_EDGE] = D;
  for (int k = 0; k < PA_DMESH_NKIND; k++)
    PA_CALL(kept_kind(dm, k, keep ? keep[k] : NULL, extra ? extra[k] : 0, R[k],
                      k == PA_VERTEX ? vpriv : NULL, P));
cleanup:
  if (st) {
    pa__recs_free(E);
    pa__recs_free(V);
    pa__recs_free(B);
    pa__recs_free(D);
    pa__recs_free(P);
  }
  return st;
}

/* ---- records of the owned entities ---- */

static pa_status owned_kind(pa_dmesh *dm, int kind, const int *dest,
                            pa__recs *R, unsigned char *pay) {
  pa_status st = PA_SUCCESS;
  pa_mesh *m = dm->mesh;
  int d = dm->dim, nv = pa__kind_nv(d, kind);
  double *dbl = NULL;
  const pa_idx *conn = kind == PA_ELEMENT    ? m->elem
                       : kind == PA_BOUNDARY ? m->bdry
                                             : m->edge;
  if (R->ndbl) PA_ALLOC(dbl, R->ndbl);
  { /* exact sizes: no growth, no realloc copies at the peak */
    size_t paybytes = 0;
    for (int k = 0; k < dm->nvalue; k++)
      if ((int)dm->value[k]->kind == kind)
        paybytes += (size_t)dm->value[k]->nslotown * dm->value[k]->unit;
    PA_CALL(pa__recs_reserve(R, (size_t)dm->nown[kind], paybytes));
  }
  for (pa_idx e = 0; e < dm->nown[kind]; e++) {
    pa_gid vg[4];
    for (int j = 0; j < nv; j++)
      vg[j] = dm->gid[PA_VERTEX][conn[(size_t)nv * e + j]];
    if (dbl) pa__entity_doubles(m, kind, e, dbl);
    int32_t ref = pa__dmesh_ref(dm, kind, e);
    size_t pl = pa__entity_payload(dm, kind, e, pay);
    uint8_t flag = kind == PA_VERTEX    ? m->vflag[e]
                   : kind == PA_ELEMENT ? m->eflag[e]
                   : kind == PA_BOUNDARY ? m->bflag[e]
                                         : m->edflag[e];
    PA_CALL(pa__recs_add(R, dm->gid[kind][e], vg, ref, flag,
                         dest ? dest[e] : dm->rank, dbl, pay, pl));
  }
cleanup:
  pa__free(dbl);
  return st;
}

pa_status pa__dmesh_owned_recs(pa_dmesh *dm, const int *dest, pa__recs *E,
                               pa__recs *V, pa__recs *B, pa__recs *D) {
  pa_status st = PA_SUCCESS;
  unsigned char *pay = NULL;
  pa__layout lay;
  size_t maxpay = 0;
  pa__dmesh_layout(dm, &lay);
  pa__recs_init(E, PA_ELEMENT, dm->dim + 1, pa__layout_kind_ndbl(&lay, PA_ELEMENT));
  pa__recs_init(V, PA_VERTEX, 0, pa__layout_ndbl(&lay));
  pa__recs_init(B, PA_BOUNDARY, dm->dim, pa__layout_kind_ndbl(&lay, PA_BOUNDARY));
  pa__recs_init(D, PA_EDGE, 2, 0);
  for (int k = 0; k < dm->nvalue; k++) maxpay += dm->value[k]->unit;
  PA_ALLOC(pay, maxpay);
  PA_CALL(owned_kind(dm, PA_ELEMENT, dest, E, pay));
  PA_CALL(owned_kind(dm, PA_VERTEX, NULL, V, pay));
  PA_CALL(owned_kind(dm, PA_BOUNDARY, NULL, B, pay));
  PA_CALL(owned_kind(dm, PA_EDGE, NULL, D, pay));
cleanup:
  pa__free(pay);
  if (st) {
    pa__recs_free(E);
    pa__recs_free(V);
    pa__recs_free(B);
    pa__recs_free(D);
  }
  return st;
}
