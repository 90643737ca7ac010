/*
 * splice.c -- change a distributed mesh in place (pa__dmesh_splice): keep
 * the local entities that do not change and put in those of a part, a
 * small distributed mesh built over the same ranks from the records of
 * everything that changed (and what touches it). The parallel adaptation
 * uses it when few elements change: a rebuild from records (build.c) of the
 * whole mesh gives the same result at the cost of the whole local mesh.
 *
 * What the caller guarantees (the build's checks are not repeated): a kept
 * entity keeps its owner and its copies (every element containing it on
 * any rank is kept, or in the part); an entity of the part has in the part
 * every element containing it on any rank, so that the part's owners and
 * ghosts are the mesh's. A vertex can be in both (a kept one on the part's
 * border): dm's copy stays.
 *
 * Result: what pa__dmesh_build gives from the records of the kept entities
 * and the part's. Each kind is numbered as a build numbers it (owned first,
 * then ghosts, each in increasing global id order), by merging the kept
 * entities, in that order already, with the part's; each array of the local
 * mesh is rewritten in turn (at most one array more than the mesh is held);
 * values keep the data of kept entities and take the part's for the others;
 * the star forests are built again from the owners and global ids (a
 * request per ghost, answered by binary search among the owned ids).
 */
#include "dmesh/dmesh.h"

int pa__dmesh_canonical(const pa_dmesh *dm) {
  for (int k = 0; k < PA_DMESH_NKIND; k++) {
    const pa_gid *g = dm->gid[k];
    pa_idx nown = dm->nown[k], nloc = dm->nloc[k];
    for (pa_idx i = 0; i < nloc; i++) {
      if ((dm->owner[k][i] == dm->rank) != (i < nown)) return 0;
      if (i > 0 && i != nown && g[i] <= g[i - 1]) return 0;
    }
  }
  for (pa_idx e = 0; e < dm->nloc[PA_ELEMENT]; e++)
    if (dm->layer[e]) return 0;
  return 1;
}

/* The new order of one kind: src[j] is the old local index of new entity j
 * (>= 0) or -1 - its index in the part; newof[i] the new index of old
 * entity i (-1: gone), pnew[p] that of part entity p (for a part vertex
 * dm keeps: the kept one's). */
typedef struct korder {
  int kind;
  pa_idx nown, nloc;
  pa_idx *src, *newof, *pnew;
} korder;

static void korder_free(korder *o) {
  pa__free(o->src);
  pa__free(o->newof);
  pa__free(o->pnew);
  o->src = o->newof = o->pnew = NULL;
}

/* Local index of global id g among the n entities of gid array gid that
 * are numbered as a build leaves (owned [0, nown), ghosts after, each in
 * increasing order), or -1. */
static pa_idx find_gid(const pa_gid *gid, pa_idx nown, pa_idx n, pa_gid g) {
  for (int part = 0; part < 2; part++) {
    pa_idx lo = part ? nown : 0, end = part ? n : nown, hi = end;
    while (lo < hi) {
      pa_idx mid = lo + (hi - lo) / 2;
      if (gid[mid] < g) lo = mid + 1;
      else hi = mid;
    }
    if (lo < end && gid[lo] == g) return lo;
  }
  return -1;
}

/* Append to o->src the old entities [i0, i1) with keep and the part's
 * [p0, p1) with take (NULL: all), merged by global id. */
static pa_status merge_range(korder *o, pa_idx *j, int kind, const pa_gid *g,
                             pa_idx i0, pa_idx i1, const uint8_t *keep,
                             const pa_gid *pg, pa_idx p0, pa_idx p1,
                             const uint8_t *take) {
  pa_status st = PA_SUCCESS;
  pa_idx i = i0, p = p0;
  for (;;) {
    while (i < i1 && !keep[i]) o->newof[i++] = -1;
    while (p < p1 && take && !take[p]) p++;
    if (i == i1 && p == p1) break;
    if (p < p1 && (i == i1 || pg[p] < g[i])) {
      o->pnew[p] = *j;
      o->src[(*j)++] = -1 - p++;
      continue;
    }
    PA_CHECK(p == p1 || pg[p] != g[i], PA_ERR_INTERNAL,
             "splice: global id %lld (kind %d) is given twice",
             (long long)g[i], kind);
    o->newof[i] = *j;
    o->src[(*j)++] = i++;
  }
cleanup:
  return st;
}

/* The new order of one kind: the staying owned entities (keep) merged with
 * the part's owned ones by global id, then the staying ghosts merged with
 * the part's ghosts. For vertices, the part's copy of a vertex dm keeps is
 * left out (take). */
static pa_status order_kind(const pa_dmesh *dm, int kind, const uint8_t *keep,
                            const pa_dmesh *part, korder *o) {
  pa_status st = PA_SUCCESS;
  pa_idx nown = dm->nown[kind], nloc = dm->nloc[kind];
  pa_idx pown = part->nown[kind], ploc = part->nloc[kind], j = 0, n = 0;
  const pa_gid *g = dm->gid[kind], *pg = part->gid[kind];
  uint8_t *take = NULL;
  o->kind = kind;
  PA_ALLOC(o->newof, nloc);
  PA_ALLOC(o->pnew, ploc);
  if (kind == PA_VERTEX) {
    PA_ALLOC(take, ploc);
    for (pa_idx p = 0; p < ploc; p++) {
      pa_idx i = find_gid(g, nown, nloc, pg[p]);
      take[p] = !(i >= 0 && keep[i]);
      o->pnew[p] = -1 - i; /* resolved below for the kept ones */
    }
  }
  for (pa_idx i = 0; i < nloc; i++) n += keep[i] != 0;
  for (pa_idx p = 0; p < ploc; p++) n += !take || take[p];
  PA_ALLOC(o->src, n);
  PA_CALL(merge_range(o, &j, kind, g, 0, nown, keep, pg, 0, pown, take));
  o->nown = j;
  PA_CALL(merge_range(o, &j, kind, g, nown, nloc, keep, pg, pown, ploc, take));
  o->nloc = j;
  for (pa_idx p = 0; take && p < ploc; p++)
    if (!take[p]) o->pnew[p] = o->newof[-1 - o->pnew[p]];
cleanup:
  pa__free(take);
  return st;
}

/* *out: o->nloc items of unit bytes, item j old[src[j]] when src[j] >= 0,
 * else item -1 - src[j] of pa (the part's array of the same layout). */
static pa_status remapped(const void *old, size_t unit, const korder *o,
                          const void *pa, void **out) {
  pa_status st = PA_SUCCESS;
  unsigned char *nw = NULL;
  const unsigned char *po = old, *pp = pa;
  PA_ALLOC(nw, (size_t)o->nloc * unit);
  for (pa_idx j = 0; j < o->nloc; j++) {
    pa_idx s = o->src[j];
    const unsigned char *p =
        s >= 0 ? po + unit * (size_t)s : pp + unit * (size_t)(-1 - s);
    memcpy(nw + unit * (size_t)j, p, unit);
  }
  *out = nw;
cleanup:
  return st;
}

/* Replace the array arr by its remapped copy (in a function with a
 * cleanup label). */
#define REMAP(arr, unit, o, pa)                                              \
  do {                                                                       \
    void *nw_ = NULL;                                                        \
    PA_CALL(remapped((arr), (unit), (o), (pa), &nw_));                       \
    pa__free(arr);                                                           \
    (arr) = nw_;                                                             \
  } while (0)

/* *conn (nv vertices each, reallocated): the vertices renumbered (vo: the
 * vertex order), a staying entity's from dm's numbering, a part entity's
 * from the part's (pconn). */
static pa_status remap_conn(pa_idx **conn, int nv, const korder *o,
                            const pa_idx *pconn, const korder *vo) {
  pa_status st = PA_SUCCESS;
  pa_idx *nw = NULL;
  PA_ALLOC(nw, (size_t)o->nloc * nv);
  for (pa_idx j = 0; j < o->nloc; j++) {
    pa_idx s = o->src[j];
    for (int k = 0; k < nv; k++) {
      pa_idx v = s >= 0 ? vo->newof[(*conn)[(size_t)nv * s + k]]
                        : vo->pnew[pconn[(size_t)nv * (-1 - s) + k]];
      PA_CHECK(v >= 0, PA_ERR_INTERNAL,
               "splice: a local entity of kind %d lost a vertex", o->kind);
      nw[(size_t)nv * j + k] = v;
    }
  }
  pa__free(*conn);
  *conn = nw;
cleanup:
  return st;
}

/* The vertices of the local mesh: coordinates, references, flags, metric
 * and fields. */
static pa_status splice_vertices(pa_mesh *m, const korder *o,
                                 const pa_mesh *pm) {
  pa_status st = PA_SUCCESS;
  int d = m->dim, nm = m->met_ncomp;
  PA_CHECK(pm->met_ncomp == nm && pm->nfield == m->nfield, PA_ERR_INTERNAL,
           "splice: the part has another metric or other fields");
  REMAP(m->coord, d * sizeof(double), o, pm->coord);
  REMAP(m->vref, sizeof(int32_t), o, pm->vref);
  REMAP(m->vflag, 1, o, pm->vflag);
  if (nm) REMAP(m->met, nm * sizeof(double), o, pm->met);
  for (int f = 0; f < m->nfield; f++)
    REMAP(m->field[f].val, m->field[f].ncomp * sizeof(double), o,
          pm->field[f].val);
  m->nv = o->nloc;
  m->capv = (size_t)o->nloc;
cleanup:
  return st;
}

/* The cells of one kind (elements, boundary entities, edges), with their
 * fields. */
static pa_status splice_cells(pa_mesh *m, int kind, const korder *o,
                              const pa_mesh *pm, const korder *vo) {
  pa_status st = PA_SUCCESS;
  int nv = pa__kind_nv(m->dim, kind);
  pa_idx **conn = kind == PA_ELEMENT ? &m->elem
                  : kind == PA_BOUNDARY ? &m->bdry
                                        : &m->edge;
  int32_t **ref = kind == PA_ELEMENT ? &m->eref
                  : kind == PA_BOUNDARY ? &m->bref
                                        : &m->edref;
  uint8_t **flag = kind == PA_ELEMENT ? &m->eflag
                   : kind == PA_BOUNDARY ? &m->bflag
                                         : &m->edflag;
  const pa_idx *pconn = kind == PA_ELEMENT ? pm->elem
                        : kind == PA_BOUNDARY ? pm->bdry
                                              : pm->edge;
  const int32_t *pref = kind == PA_ELEMENT ? pm->eref
                        : kind == PA_BOUNDARY ? pm->bref
                                              : pm->edref;
  const uint8_t *pflag = kind == PA_ELEMENT ? pm->eflag
                         : kind == PA_BOUNDARY ? pm->bflag
                                               : pm->edflag;
  PA_CALL(remap_conn(conn, nv, o, pconn, vo));
  REMAP(*ref, sizeof(int32_t), o, pref);
  REMAP(*flag, 1, o, pflag);
  if (kind != PA_EDGE) { /* element or boundary fields */
    int *n, *pn;
    pa__field *f = pa__mesh_fields(m, kind, &n);
    const pa__field *pf = pa__mesh_fields((pa_mesh *)pm, kind, &pn);
    PA_CHECK(*n == *pn, PA_ERR_INTERNAL, "splice: the part has other fields");
    for (int k = 0; k < *n; k++) {
      PA_CHECK(f[k].ncomp == pf[k].ncomp, PA_ERR_INTERNAL,
               "splice: the part has other fields");
      REMAP(f[k].val, f[k].ncomp * sizeof(double), o, pf[k].val);
    }
  }
  if (kind == PA_ELEMENT) {
    m->ne = o->nloc;
    m->cape = (size_t)o->nloc;
  } else if (kind == PA_BOUNDARY) {
    m->nb = o->nloc;
    m->capb = (size_t)o->nloc;
  } else {
    m->ned = o->nloc;
    m->caped = (size_t)o->nloc;
  }
cleanup:
  return st;
}

/* Global ids and owners of one kind. */
static pa_status splice_ids(pa_dmesh *dm, int kind, const korder *o,
                            const pa_dmesh *part) {
  pa_status st = PA_SUCCESS;
  REMAP(dm->gid[kind], sizeof(pa_gid), o, part->gid[kind]);
  REMAP(dm->owner[kind], sizeof(int), o, part->owner[kind]);
  dm->nown[kind] = o->nown;
  dm->nloc[kind] = o->nloc;
cleanup:
  return st;
}

/* One value for the new numbering (after the entities): slots from the
 * references, the data of a staying entity kept, a part entity's from the
 * part's value pv. */
static pa_status splice_value(pa_dmesh *dm, pa_dmesh_value *v, const korder *o,
                              const pa_dmesh_value *pv) {
  pa_status st = PA_SUCCESS;
  unsigned char *odata = v->data;
  pa_idx *oslot = v->slot;
  v->data = NULL; /* kept apart from pa__value_alloc, which frees */
  v->slot = NULL;
  PA_CHECK(pv->kind == v->kind && pv->unit == v->unit && pv->ref == v->ref,
           PA_ERR_INTERNAL, "splice: the part has other values");
  PA_CALL(pa__value_alloc(dm, v));
  for (pa_idx j = 0; j < o->nloc; j++) {
    pa_idx s = o->src[j], ns = v->slot ? v->slot[j] : j, os;
    const unsigned char *from = odata;
    if (ns < 0) continue;
    if (s >= 0) {
      os = oslot ? oslot[s] : s;
    } else {
      os = pv->slot ? pv->slot[-1 - s] : -1 - s;
      from = pv->data;
    }
    PA_CHECK(os >= 0, PA_ERR_INTERNAL, "splice: a value lost its slot");
    memcpy(v->data + v->unit * (size_t)ns, from + v->unit * (size_t)os,
           v->unit);
  }
cleanup:
  pa__free(odata);
  pa__free(oslot);
  return st;
}

/* Every local vertex is in a local element (a kept ghost no longer
 * referenced would mean the caller's guarantees do not hold). */
static pa_status vertices_used(const pa_mesh *m) {
  pa_status st = PA_SUCCESS;
  uint8_t *used = NULL;
  size_t n = (size_t)m->ne * (m->dim + 1);
  PA_CALLOC(used, m->nv);
  for (size_t p = 0; p < n; p++) used[m->elem[p]] = 1;
  for (pa_idx v = 0; v < m->nv; v++)
    PA_CHECK(used[v], PA_ERR_INTERNAL, "splice: local vertex %d is in no "
             "element", (int)v);
cleanup:
  pa__free(used);
  return st;
}

pa_status pa__dmesh_splice(pa_dmesh *dm,
                           const uint8_t *const keep[PA_DMESH_NKIND],
                           const pa_dmesh *part) {
  pa_status st = PA_SUCCESS;
  korder o[PA_DMESH_NKIND];
  pa_mesh *m = dm->mesh;
  memset(o, 0, sizeof o);
  PA_CHECK(dm->overlap == 0 && part->overlap == 0 &&
               part->nvalue == dm->nvalue,
           PA_ERR_INTERNAL, "splice: ghost layers or other values");
  PA_ASSERT(pa__dmesh_canonical(dm) && pa__dmesh_canonical(part));
  pa__dmesh_invalidate(dm);
  pa__mesh_invalidate(m);
  /* the new order of every kind, then the arrays kind by kind (vertices
   * first: the others' connectivity refers to their new numbers) */
  for (int k = 0; k < PA_DMESH_NKIND; k++)
    PA_CALL(order_kind(dm, k, keep[k], part, &o[k]));
  PA_CALL(splice_vertices(m, &o[PA_VERTEX], part->mesh));
  PA_CALL(splice_ids(dm, PA_VERTEX, &o[PA_VERTEX], part));
  for (int k = PA_ELEMENT; k < PA_DMESH_NKIND; k++) {
    PA_CALL(splice_cells(m, k, &o[k], part->mesh, &o[PA_VERTEX]));
    PA_CALL(splice_ids(dm, k, &o[k], part));
  }
  pa__free(dm->layer);
  PA_CALLOC(dm->layer, dm->nloc[PA_ELEMENT]);
  PA_CALL(vertices_used(m));
  for (int k = 0; k < dm->nvalue; k++)
    PA_CALL(splice_value(dm, dm->value[k], &o[dm->value[k]->kind],
                         part->value[k]));
  /* across ranks: the global counts, the star forests, the neighbours */
  PA_CALL(pa__agree(dm->comm, st));
  {
    pa_gid own[PA_DMESH_NKIND];
    for (int k = 0; k < PA_DMESH_NKIND; k++) own[k] = dm->nown[k];
    PA_CALL(pa__allreduce(dm->comm, own, PA_DMESH_NKIND, MPI_INT64_T, MPI_SUM));
    for (int k = 0; k < PA_DMESH_NKIND; k++) dm->nglob[k] = own[k];
  }
  for (int k = 0; k < PA_DMESH_NKIND; k++) {
    pa__sf_free(&dm->sf[k]);
    PA_CALL(pa__sf_build(dm->comm, dm->nloc[k], dm->gid[k], dm->owner[k],
                         &dm->sf[k]));
  }
  pa__free(dm->neigh);
  dm->neigh = NULL;
  PA_CALL(pa__dmesh_neighbours(dm));
  for (int k = 0; k < dm->nvalue; k++)
    PA_CALL(pa__value_setup(dm, dm->value[k]));
cleanup:
  st = pa__agree_end(dm->comm, st);
  for (int k = 0; k < PA_DMESH_NKIND; k++) korder_free(&o[k]);
  return st;
}

pa_status pa__dmesh_values_like(pa_dmesh *dm, const pa_dmesh *like) {
  pa_status st = PA_SUCCESS;
  for (int k = 0; k < like->nvalue; k++) {
    const pa_dmesh_value *v = like->value[k];
    PA_CALL(pa__value_define(dm, v->kind, v->name, v->type, v->ncomp, v->ref));
  }
cleanup:
  return st;
}
