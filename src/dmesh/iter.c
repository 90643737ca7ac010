/*
 * iter.c -- iterators over owned / ghost / interior / frontier entities,
 * adjacency queries on the local mesh (valid across the overlap), and the
 * locality reordering of local entities (Hilbert curve, or Scotch ordering
 * of the local dual graph).
 *
 * Invariants: "shared" marks the local entities that have copies on other
 * ranks (roots with leaves, and leaves); an owned entity is interior when
 * none of its vertices is shared (a vertex: when it is not shared itself).
 * Derived structures are dropped by pa__dmesh_invalidate whenever the
 * numbering changes. Reordering permutes owned and ghost ranges separately,
 * so the owned-first invariant holds, then rebuilds the star forests.
 */
#include "dmesh/dmesh.h"
#include "partition/partition.h"

/* ---- iterators ---- */

static pa_status build_shared(pa_dmesh *dm, int kind) {
  pa_status st = PA_SUCCESS;
  if (dm->shared[kind]) return PA_SUCCESS;
  const pa__sf *sf = &dm->sf[kind];
  PA_CALLOC(dm->shared[kind], dm->nloc[kind]);
  for (pa_idx j = 0; j < sf->rootoff[sf->nrootrank]; j++)
    dm->shared[kind][sf->rootidx[j]] = 1;
  for (pa_idx j = 0; j < sf->leafoff[sf->nleafrank]; j++)
    dm->shared[kind][sf->leafidx[j]] = 1;
cleanup:
  return st;
}

static pa_status build_iter(pa_dmesh *dm, int kind) {
  pa_status st = PA_SUCCESS;
  if (dm->iterlist[kind][0]) return PA_SUCCESS;
  PA_CALL(build_shared(dm, PA_VERTEX));
  pa_mesh *m = dm->mesh;
  int nv = pa__kind_nv(dm->dim, kind);
  const pa_idx *conn = kind == PA_ELEMENT ? m->elem : kind == PA_BOUNDARY ? m->bdry : m->edge;
  pa_idx n = dm->nown[kind];
  PA_ALLOC(dm->iterlist[kind][0], n);
  PA_ALLOC(dm->iterlist[kind][1], n);
  pa_idx ni = 0, nf = 0;
  for (pa_idx e = 0; e < n; e++) {
    int sh = 0;
    if (kind == PA_VERTEX)
      sh = dm->shared[PA_VERTEX][e];
    else
      for (int j = 0; j < nv; j++) sh |= dm->shared[PA_VERTEX][conn[(size_t)nv * e + j]];
    if (sh) dm->iterlist[kind][1][nf++] = e;
    else dm->iterlist[kind][0][ni++] = e;
  }
  dm->niter[kind][0] = ni;
  dm->niter[kind][1] = nf;
cleanup:
  if (st) {
    pa__free(dm->iterlist[kind][0]);
    pa__free(dm->iterlist[kind][1]);
    dm->iterlist[kind][0] = dm->iterlist[kind][1] = NULL;
  }
  return st;
}

pa_status pa_dmesh_iter_init(pa_dmesh *dm, pa_entity kind, pa_dmesh_set set,
                             pa_dmesh_iter *it) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(dm && it && (unsigned)kind < PA_DMESH_NKIND, PA_ERR_ARG,
           "pa_dmesh_iter_init: bad argument");
  memset(it, 0, sizeof *it);
  switch (set) {
  case PA_OWNED: it->first = 0; it->end = dm->nown[kind]; break;
  case PA_GHOST: it->first = dm->nown[kind]; it->end = dm->nloc[kind]; break;
  case PA_LOCAL: it->first = 0; it->end = dm->nloc[kind]; break;
  case PA_INTERIOR:
  case PA_FRONTIER: {
    int s = set == PA_FRONTIER;
    PA_CALL(build_iter(dm, kind));
    it->list = dm->iterlist[kind][s];
    it->first = 0;
    it->end = dm->niter[kind][s];
    break;
  }
  default: PA_FAIL(PA_ERR_ARG, "unknown entity set %d", (int)set);
  }
  it->pos = it->first;
cleanup:
  return st;
}

/* ---- adjacency ---- */

const pa_idx *pa_dmesh_elem_verts(pa_dmesh *dm, pa_idx e) {
  return dm->mesh->elem + (size_t)(dm->dim + 1) * e;
}

static pa_status build_balls(pa_dmesh *dm) {
  pa_status st = PA_SUCCESS;
  if (dm->vstart) return PA_SUCCESS;
  pa_mesh *m = dm->mesh;
  int d = dm->dim;
  PA_CALLOC(dm->vstart, (size_t)m->nv + 1);
  PA_ALLOC(dm->velem, (size_t)m->ne * (d + 1));
  for (size_t k = 0; k < (size_t)m->ne * (d + 1); k++) dm->vstart[m->elem[k] + 1]++;
  for (pa_idx v = 0; v < m->nv; v++) dm->vstart[v + 1] += dm->vstart[v];
  for (size_t k = 0; k < (size_t)m->ne * (d + 1); k++)
    dm->velem[dm->vstart[m->elem[k]]++] = (pa_idx)(k / (d + 1));
  for (pa_idx v = m->nv; v > 0; v--) dm->vstart[v] = dm->vstart[v - 1];
  dm->vstart[0] = 0;
cleanup:
  if (st) {
    pa__free(dm->vstart);
    pa__free(dm->velem);
    dm->vstart = dm->velem = NULL;
  }
  return st;
}

pa_status pa_dmesh_vert_elems(pa_dmesh *dm, pa_idx v, pa_idx *n,
                              const pa_idx **elems) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(dm && n && elems && v >= 0 && v < dm->mesh->nv, PA_ERR_ARG,
           "pa_dmesh_vert_elems: bad argument");
  PA_CALL(build_balls(dm));
  *n = dm->vstart[v + 1] - dm->vstart[v];
  *elems = dm->velem + dm->vstart[v];
cleanup:
  return st;
}

/* Does element e contain the k vertices of f? */
static int contains(const pa_mesh *m, pa_idx e, const pa_idx *f, int k) {
  const pa_idx *ev = m->elem + (size_t)(m->dim + 1) * e;
  for (int j = 0; j < k; j++) {
    int in = 0;
    for (int c = 0; c <= m->dim; c++) in |= ev[c] == f[j];
    if (!in) return 0;
  }
  return 1;
}

static pa_status build_adja(pa_dmesh *dm) {
  pa_status st = PA_SUCCESS;
  pa_gid *mate = NULL;
  if (dm->adja) return PA_SUCCESS;
  pa_mesh *m = dm->mesh;
  int nf = dm->dim + 1;
  size_t nface = (size_t)m->ne * nf;
  PA_ALLOC(mate, nface);
  PA_CALL(pa__match_faces(dm->dim, m->ne, m->elem, m->nv, NULL, mate));
  PA_ALLOC(dm->adja, nface);
  for (size_t k = 0; k < nface; k++)
    dm->adja[k] = mate[k] < 0 ? -1 : (pa_idx)(mate[k] / nf);
cleanup:
  pa__free(mate);
  return st;
}

pa_status pa_dmesh_elem_neighbours(pa_dmesh *dm, pa_idx e, const pa_idx **nb) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(dm && nb && e >= 0 && e < dm->mesh->ne, PA_ERR_ARG,
           "pa_dmesh_elem_neighbours: bad argument");
  PA_CALL(build_adja(dm));
  *nb = dm->adja + (size_t)(dm->dim + 1) * e;
cleanup:
  return st;
}

pa_status pa_dmesh_bdry_elems(pa_dmesh *dm, pa_idx b, pa_idx e[2]) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(dm && e && b >= 0 && b < dm->mesh->nb, PA_ERR_ARG,
           "pa_dmesh_bdry_elems: bad argument");
  PA_CALL(build_balls(dm));
  const pa_idx *f = dm->mesh->bdry + (size_t)dm->dim * b;
  int k = 0;
  e[0] = e[1] = -1;
  for (pa_idx q = dm->vstart[f[0]]; q < dm->vstart[f[0] + 1] && k < 2; q++)
    if (contains(dm->mesh, dm->velem[q], f, dm->dim)) e[k++] = dm->velem[q];
cleanup:
  return st;
}

/* ---- reordering ---- */

/* Hilbert index of a point with integer coordinates of b bits per axis
 * (Skilling's transpose algorithm), dims 2 or 3. */
static uint64_t hilbert(uint32_t *x, int n, int b) {
  uint32_t M = 1u << (b - 1), P, Q, t;
  for (Q = M; Q > 1; Q >>= 1) { /* inverse undo */
    P = Q - 1;
    for (int i = 0; i < n; i++) {
      if (x[i] & Q) x[0] ^= P;
      else {
        t = (x[0] ^ x[i]) & P;
        x[0] ^= t;
        x[i] ^= t;
      }
    }
  }
  for (int i = 1; i < n; i++) x[i] ^= x[i - 1]; /* Gray encode */
  t = 0;
  for (Q = M; Q > 1; Q >>= 1)
    if (x[n - 1] & Q) t ^= Q - 1;
  for (int i = 0; i < n; i++) x[i] ^= t;
  uint64_t h = 0; /* interleave the transposed bits */
  for (int bit = b - 1; bit >= 0; bit--)
    for (int i = 0; i < n; i++) h = (h << 1) | ((x[i] >> bit) & 1u);
  return h;
}

/* Sort the index range [lo, hi) of perm by key (stable). */
static pa_status sort_range(pa_idx *perm, pa_idx lo, pa_idx hi,
                            const pa_gid *key) {
  return pa__sort_by_gid(perm + lo, (size_t)(hi - lo), key);
}

/* Scotch ordering of the elements, one group (owned, each ghost layer) at a
 * time, on the dual graph restricted to the group. pe[k] = old element at
 * new position k; groups stay in layer order. */
static pa_status scotch_elements(pa_dmesh *dm, pa_idx *pe) {
  pa_status st = PA_SUCCESS;
  pa_mesh *m = dm->mesh;
  int nf = dm->dim + 1;
  pa_gid *mate = NULL;
  pa_idx *byl = NULL, *loc = NULL, *xadj = NULL, *adj = NULL, *sub = NULL;
  size_t c[257] = {0};
  PA_ALLOC(mate, (size_t)m->ne * nf);
  PA_CALL(pa__match_faces(dm->dim, m->ne, m->elem, m->nv, NULL, mate));
  /* elements by layer (stable), and their index inside their group */
  PA_ALLOC(byl, m->ne);
  PA_ALLOC(loc, m->ne);
  for (pa_idx e = 0; e < m->ne; e++) c[dm->layer[e] + 1]++;
  for (int l = 0; l < 256; l++) c[l + 1] += c[l];
  for (pa_idx e = 0; e < m->ne; e++) {
    size_t k = c[dm->layer[e]]++;
    byl[k] = e;
  }
  PA_ALLOC(xadj, m->ne + 1);
  PA_ALLOC(adj, (size_t)m->ne * nf);
  PA_ALLOC(sub, m->ne);
  for (size_t g0 = 0; g0 < (size_t)m->ne;) {
    int l = dm->layer[byl[g0]];
    size_t g1 = g0;
    while (g1 < (size_t)m->ne && dm->layer[byl[g1]] == l) g1++;
    pa_idx n = (pa_idx)(g1 - g0);
    for (pa_idx i = 0; i < n; i++) loc[byl[g0 + i]] = i;
    xadj[0] = 0;
    for (pa_idx i = 0; i < n; i++) {
      pa_idx e = byl[g0 + i], k = xadj[i];
      for (int j = 0; j < nf; j++) {
        pa_gid f = mate[(size_t)e * nf + j];
        if (f >= 0 && dm->layer[f / nf] == l) adj[k++] = loc[f / nf];
      }
      xadj[i + 1] = k;
    }
    PA_CALL(pa__order_graph(n, xadj, adj, sub));
    for (pa_idx i = 0; i < n; i++) pe[g0 + i] = byl[g0 + sub[i]];
    g0 = g1;
  }
cleanup:
  pa__free(mate);
  pa__free(byl);
  pa__free(loc);
  pa__free(xadj);
  pa__free(adj);
  pa__free(sub);
  return st;
}

pa_status pa_dmesh_reorder(pa_dmesh *dm) {
  return pa_dmesh_reorder_by(dm, PA_ORDER_HILBERT);
}

/* What the phases of pa_dmesh_reorder_by share: perm[kind][k] = the old
 * local entity at new position k, ivn[v] = the new position of old vertex
 * v, a sort key long enough for every kind, and the renumbered local mesh
 * (nm) until it replaces dm's. */
typedef struct reorder {
  pa_idx *perm[PA_DMESH_NKIND];
  pa_idx *ivn;
  pa_gid *key;
  pa_mesh *nm;
} reorder;

/* Elements by the Hilbert index of their centroid in the bounding box of
 * the local vertices; the layer in the key's top bits keeps owned first,
 * then each ghost layer. pe[k] = old element at new position k. */
static pa_status hilbert_elements(pa_dmesh *dm, pa_gid *key, pa_idx *pe) {
  pa_status st = PA_SUCCESS;
  const pa_mesh *m = dm->mesh;
  int d = dm->dim, b = d == 2 ? 31 : 21;
  double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
  for (int c = 0; c < d; c++) {
    lo[c] = m->nv ? m->coord[c] : 0;
    hi[c] = lo[c];
  }
  for (pa_idx v = 0; v < m->nv; v++)
    for (int c = 0; c < d; c++) {
      double x = m->coord[(size_t)d * v + c];
      lo[c] = x < lo[c] ? x : lo[c];
      hi[c] = x > hi[c] ? x : hi[c];
    }
  for (pa_idx e = 0; e < m->ne; e++) {
    uint32_t x[3];
    for (int c = 0; c < d; c++) {
      double s = 0;
      for (int j = 0; j <= d; j++) s += m->coord[(size_t)d * m->elem[(size_t)(d + 1) * e + j] + c];
      s /= d + 1;
      double t = hi[c] > lo[c] ? (s - lo[c]) / (hi[c] - lo[c]) : 0;
      x[c] = (uint32_t)(t * (double)((1u << b) - 1));
    }
    key[e] = (pa_gid)(hilbert(x, d, b) >> 4) + ((pa_gid)dm->layer[e] << 59);
    pe[e] = e;
  }
  PA_CALL(sort_range(pe, 0, m->ne, key)); /* layer bits keep owned first */
cleanup:
  return st;
}

/* The new element order (Hilbert or Scotch, owned then each ghost layer);
 * allocates the sort key, long enough for every kind. */
static pa_status order_elements(pa_dmesh *dm, pa_dmesh_ordering how,
                                reorder *r) {
  pa_status st = PA_SUCCESS;
  const pa_mesh *m = dm->mesh;
  size_t nmax = (size_t)m->ne;
  if ((size_t)m->nv > nmax) nmax = (size_t)m->nv;
  if ((size_t)m->nb > nmax) nmax = (size_t)m->nb;
  if ((size_t)m->ned > nmax) nmax = (size_t)m->ned;
  PA_ALLOC(r->key, nmax);
  PA_ALLOC(r->perm[PA_ELEMENT], m->ne);
  if (how == PA_ORDER_SCOTCH)
    PA_CALL(scotch_elements(dm, r->perm[PA_ELEMENT]));
  else
    PA_CALL(hilbert_elements(dm, r->key, r->perm[PA_ELEMENT]));
cleanup:
  return st;
}

/* Vertices by first use in the new element order, owned then ghosts;
 * vertices in no element keep their relative order at the end of their
 * range. */
static pa_status order_vertices(pa_dmesh *dm, reorder *r) {
  pa_status st = PA_SUCCESS;
  const pa_mesh *m = dm->mesh;
  const pa_idx *pe = r->perm[PA_ELEMENT];
  int d = dm->dim;
  PA_ALLOC(r->ivn, m->nv);
  pa_idx *ivn = r->ivn;
  for (pa_idx v = 0; v < m->nv; v++) ivn[v] = -1;
  pa_idx nvo = dm->nown[PA_VERTEX], co = 0, cg = nvo;
  for (pa_idx q = 0; q < m->ne; q++)
    for (int j = 0; j <= d; j++) {
      pa_idx v = m->elem[(size_t)(d + 1) * pe[q] + j];
      if (ivn[v] < 0) ivn[v] = v < nvo ? co++ : cg++;
    }
  for (pa_idx v = 0; v < m->nv; v++)
    if (ivn[v] < 0) ivn[v] = v < nvo ? co++ : cg++;
  PA_ALLOC(r->perm[PA_VERTEX], m->nv);
  for (pa_idx v = 0; v < m->nv; v++) r->perm[PA_VERTEX][ivn[v]] = v;
cleanup:
  return st;
}

/* Boundary entities and edges by their smallest new vertex, owned first. */
static pa_status order_subentities(pa_dmesh *dm, reorder *r) {
  pa_status st = PA_SUCCESS;
  const pa_mesh *m = dm->mesh;
  int d = dm->dim;
  pa_idx cnt[2] = {m->nb, m->ned};
  PA_ALLOC(r->perm[PA_BOUNDARY], m->nb);
  PA_ALLOC(r->perm[PA_EDGE], m->ned);
  for (int t = 0; t < 2; t++) {
    int kind = PA_BOUNDARY + t, nv = pa__kind_nv(d, kind);
    const pa_idx *conn = t ? m->edge : m->bdry;
    pa_idx *pk = r->perm[kind];
    for (pa_idx i = 0; i < cnt[t]; i++) {
      pa_idx mn = r->ivn[conn[(size_t)nv * i]];
      for (int j = 1; j < nv; j++)
        if (r->ivn[conn[(size_t)nv * i + j]] < mn) mn = r->ivn[conn[(size_t)nv * i + j]];
      r->key[i] = (pa_gid)mn + ((pa_gid)(i >= dm->nown[kind]) << 40);
      pk[i] = i;
    }
    PA_CALL(sort_range(pk, 0, cnt[t], r->key));
  }
cleanup:
  return st;
}

/* The local mesh in the new order: every entity array gathered through
 * perm, connectivity renamed through ivn. */
static pa_status permuted_mesh(pa_dmesh *dm, reorder *r) {
  pa_status st = PA_SUCCESS;
  const pa_mesh *m = dm->mesh;
  const pa_idx *pv = r->perm[PA_VERTEX], *pe = r->perm[PA_ELEMENT],
               *pb = r->perm[PA_BOUNDARY], *pd = r->perm[PA_EDGE],
               *ivn = r->ivn;
  int d = dm->dim;
  PA_CALL(pa_mesh_create(d, &r->nm));
  pa_mesh *nm = r->nm;
  nm->met_ncomp = m->met_ncomp;
  nm->nfield = m->nfield;
  for (int f = 0; f < m->nfield; f++) {
    memcpy(nm->field[f].name, m->field[f].name, sizeof nm->field[f].name);
    nm->field[f].ncomp = m->field[f].ncomp;
  }
  PA_CALL(pa_mesh_reserve(nm, m->nv, m->ne, m->nb, m->ned));
  {
    pa__layout lay;
    pa__mesh_layout(m, &lay);
    PA_CALL(pa__layout_cell_fields(&lay, nm));
  }
  for (pa_idx i = 0; i < m->nv; i++) {
    pa_idx o = pv[i];
    memcpy(nm->coord + (size_t)d * i, m->coord + (size_t)d * o, d * sizeof(double));
    nm->vref[i] = m->vref[o];
    nm->vflag[i] = m->vflag[o];
    if (m->met_ncomp)
      memcpy(nm->met + (size_t)m->met_ncomp * i, m->met + (size_t)m->met_ncomp * o,
             m->met_ncomp * sizeof(double));
    for (int f = 0; f < m->nfield; f++)
      memcpy(nm->field[f].val + (size_t)m->field[f].ncomp * i,
             m->field[f].val + (size_t)m->field[f].ncomp * o,
             m->field[f].ncomp * sizeof(double));
  }
  for (pa_idx i = 0; i < m->ne; i++) {
    for (int j = 0; j <= d; j++)
      nm->elem[(size_t)(d + 1) * i + j] = ivn[m->elem[(size_t)(d + 1) * pe[i] + j]];
    nm->eref[i] = m->eref[pe[i]];
    nm->eflag[i] = m->eflag[pe[i]];
    for (int f = 0; f < m->nefield; f++) {
      size_t nc = (size_t)m->efield[f].ncomp;
      memcpy(nm->efield[f].val + nc * i, m->efield[f].val + nc * pe[i],
             nc * sizeof(double));
    }
  }
  for (pa_idx i = 0; i < m->nb; i++) {
    for (int j = 0; j < d; j++)
      nm->bdry[(size_t)d * i + j] = ivn[m->bdry[(size_t)d * pb[i] + j]];
    nm->bref[i] = m->bref[pb[i]];
    nm->bflag[i] = m->bflag[pb[i]];
    for (int f = 0; f < m->nbfield; f++) {
      size_t nc = (size_t)m->bfield[f].ncomp;
      memcpy(nm->bfield[f].val + nc * i, m->bfield[f].val + nc * pb[i],
             nc * sizeof(double));
    }
  }
  for (pa_idx i = 0; i < m->ned; i++) {
    for (int j = 0; j < 2; j++) nm->edge[2 * i + j] = ivn[m->edge[2 * pd[i] + j]];
    nm->edref[i] = m->edref[pd[i]];
    nm->edflag[i] = m->edflag[pd[i]];
  }
  nm->nv = m->nv;
  nm->ne = m->ne;
  nm->nb = m->nb;
  nm->ned = m->ned;
cleanup:
  return st;
}

/* The data of every value, its blocks gathered in the new entity order
 * (sub-class values: the blocks of the entities holding it). */
static pa_status permute_values(pa_dmesh *dm, const reorder *r) {
  pa_status st = PA_SUCCESS;
  unsigned char *tmp = NULL;
  for (int q = 0; q < dm->nvalue; q++) {
    pa_dmesh_value *v = dm->value[q];
    const pa_idx *p = r->perm[v->kind];
    pa__free(tmp);
    tmp = NULL;
    PA_ALLOC(tmp, (size_t)v->nslot * v->unit);
    pa_idx s = 0;
    for (pa_idx i = 0; i < dm->nloc[v->kind]; i++) {
      pa_idx o = p[i];
      pa_idx os = v->slot ? v->slot[o] : o;
      if (os < 0) continue;
      memcpy(tmp + v->unit * (size_t)s++, v->data + v->unit * (size_t)os, v->unit);
    }
    memcpy(v->data, tmp, (size_t)v->nslot * v->unit);
  }
cleanup:
  pa__free(tmp);
  return st;
}

/* Global ids and owners of every kind, and the element layers, in the new
 * order. */
static pa_status permute_ids(pa_dmesh *dm, reorder *r) {
  pa_status st = PA_SUCCESS;
  for (int k = 0; k < PA_DMESH_NKIND; k++) {
    pa_gid *g;
    int *o;
    PA_ALLOC(g, dm->nloc[k]);
    o = pa__malloc(((size_t)dm->nloc[k] + 1) * sizeof *o);
    if (!o) {
      pa__free(g);
      PA_FAIL(PA_ERR_MEMORY, "out of memory");
    }
    for (pa_idx i = 0; i < dm->nloc[k]; i++) {
      g[i] = dm->gid[k][r->perm[k][i]];
      o[i] = dm->owner[k][r->perm[k][i]];
    }
    pa__free(dm->gid[k]);
    pa__free(dm->owner[k]);
    dm->gid[k] = g;
    dm->owner[k] = o;
  }
  const pa_idx *pe = r->perm[PA_ELEMENT];
  for (pa_idx i = 0; i < dm->mesh->ne; i++) r->key[i] = dm->layer[pe[i]];
  for (pa_idx i = 0; i < dm->mesh->ne; i++) dm->layer[i] = (uint8_t)r->key[i];
cleanup:
  return st;
}

/* The slots of sub-class values for the new numbering (their data is
 * already in the new order). */
static void renumber_value_slots(pa_dmesh *dm) {
  for (int q = 0; q < dm->nvalue; q++) {
    pa_dmesh_value *v = dm->value[q];
    if (!v->slot) continue;
    pa_idx s = 0;
    for (pa_idx e = 0; e < dm->nloc[v->kind]; e++)
      v->slot[e] = pa__dmesh_ref(dm, v->kind, e) == v->ref ? s++ : -1;
    for (pa_idx e = 0; e < dm->nloc[v->kind]; e++)
      if (v->slot[e] >= 0) v->ent[v->slot[e]] = e;
  }
}

pa_status pa_dmesh_reorder_by(pa_dmesh *dm, pa_dmesh_ordering how) {
  pa_status st = PA_SUCCESS;
  reorder r;
  memset(&r, 0, sizeof r);
  PA_CHECK(dm && dm->mesh, PA_ERR_ARG, "pa_dmesh_reorder: NULL dmesh");
  pa__agree_reset();
  PA_CHECK(how == PA_ORDER_HILBERT || how == PA_ORDER_SCOTCH, PA_ERR_ARG,
           "pa_dmesh_reorder_by: unknown ordering %d", (int)how);
  for (int k = 0; k < dm->nvalue; k++)
    PA_CHECK(!dm->value[k]->op.active, PA_ERR_ARG,
             "value '%s' has an exchange in flight", dm->value[k]->name);
  /* the permutations, then a new local mesh, values, ids, owners, layers */
  PA_CALL(order_elements(dm, how, &r));
  PA_CALL(order_vertices(dm, &r));
  PA_CALL(order_subentities(dm, &r));
  PA_CALL(permuted_mesh(dm, &r));
  PA_CALL(permute_values(dm, &r));
  PA_CALL(permute_ids(dm, &r));
  pa_mesh_destroy(dm->mesh);
  dm->mesh = r.nm;
  r.nm = NULL;
  pa__dmesh_invalidate(dm);
  renumber_value_slots(dm);
  /* exchange patterns for the new numbering */
  for (int k = 0; k < PA_DMESH_NKIND; k++) {
    pa__sf_free(&dm->sf[k]);
    PA_CALL(pa__agree(dm->comm, st));
    PA_CALL(pa__sf_build(dm->comm, dm->nloc[k], dm->gid[k], dm->owner[k], &dm->sf[k]));
  }
  for (int q = 0; q < dm->nvalue; q++) PA_CALL(pa__value_setup(dm, dm->value[q]));
cleanup:
  if (dm) st = pa__agree_end(dm->comm, st);
  for (int k = 0; k < PA_DMESH_NKIND; k++) pa__free(r.perm[k]);
  pa__free(r.ivn);
  pa__free(r.key);
  pa_mesh_destroy(r.nm);
  return st;
}
