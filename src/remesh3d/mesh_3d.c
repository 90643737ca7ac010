/*
 * mesh_3d.c -- the 3D remesher's working structure (struct rm3d, see
 * remesh3d.h): keyed tables of boundary triangles and feature edges, building
 * it from a pa_mesh, growth, compaction, writing it back, and a checker.
 *
 * Invariants (checked by pa__rm3d_check):
 *  - every live tet is positively oriented; adjacency is symmetric and the
 *    faces it pairs carry the same three vertices; face bit i of tflag is set
 *    exactly when face i is a boundary triangle (a live record of tri), on
 *    both sides of an interior boundary triangle; every face with no
 *    neighbour, and every face between tets of different references, is a
 *    boundary triangle;
 *  - vtet[v] is a live tet holding v for every live vertex v;
 *  - vertices of frozen tets, frozen triangles, required edges and required
 *    vertices carry RM3D_V_LOCK; vertices of boundary triangles RM3D_V_BDRY.
 * Building fails, leaving the caller's mesh untouched, on a non-conforming or
 * inverted input. Writing back builds a complete new pa_mesh first and swaps
 * it in only when nothing can fail any more.
 */
#include "remesh3d/remesh3d.h"

const int pa__rm3d_edge[6][2] = {{0, 1}, {0, 2}, {0, 3},
                                 {1, 2}, {1, 3}, {2, 3}};
const int pa__rm3d_compl[4][4][2] = {
    {{-1, -1}, {2, 3}, {3, 1}, {1, 2}},
    {{3, 2}, {-1, -1}, {0, 3}, {2, 0}},
    {{1, 3}, {3, 0}, {-1, -1}, {0, 1}},
    {{2, 1}, {0, 2}, {1, 0}, {-1, -1}}};
const int pa__rm3d_face[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};

/* ---- keyed tables ------------------------------------------------------ */

static void sort_key(const pa_idx *v, int nk, pa_idx *k) {
  for (int i = 0; i < nk; i++) k[i] = v[i];
  pa__sort_small(k, nk);
}

static int same_key(const rm3d_table *t, pa_idx r, const pa_idx *key) {
  pa_idx k[3];
  sort_key(t->v + (size_t)t->nk * r, t->nk, k);
  for (int i = 0; i < t->nk; i++)
    if (k[i] != key[i]) return 0;
  return 1;
}

pa_idx pa__rm3d_table_find(const rm3d_table *t, const pa_idx *v) {
  if (!t->nslot) return -1;
  pa_idx key[3];
  sort_key(v, t->nk, key);
  size_t mask = t->nslot - 1;
  size_t h = (size_t)pa__hash_idx(key, t->nk) & mask;
  for (;;) {
    pa_idx r = t->slot[h];
    if (r == -1) return -1;
    if (r >= 0 && same_key(t, r, key)) return r;
    h = (h + 1) & mask;
  }
}

static pa_status table_rehash(rm3d_table *t, size_t nslot) {
  pa_status st = PA_SUCCESS;
  pa_idx *slot = NULL;
  PA_ALLOC(slot, nslot);
  for (size_t i = 0; i < nslot; i++) slot[i] = -1;
  size_t nfull = 0;
  for (pa_idx r = 0; r < t->n; r++) {
    if (t->flag[r] & RM3D_REC_DEAD) continue;
    pa_idx key[3];
    sort_key(t->v + (size_t)t->nk * r, t->nk, key);
    size_t h = (size_t)pa__hash_idx(key, t->nk) & (nslot - 1);
    while (slot[h] != -1) h = (h + 1) & (nslot - 1);
    slot[h] = r;
    nfull++;
  }
  pa__free(t->slot);
  t->slot = slot;
  t->nslot = nslot;
  t->nfull = nfull;
cleanup:
  return st;
}

pa_status pa__rm3d_table_add(rm3d_table *t, const pa_idx *v, int32_t ref,
                             uint8_t flag, pa_idx *index) {
  pa_status st = PA_SUCCESS;
  if ((size_t)t->n + 1 > t->cap) {
    size_t cap = t->cap + t->cap / 2 + 64;
    pa_idx *nv = pa__realloc(t->v, cap * t->nk * sizeof *nv);
    if (!nv) PA_FAIL(PA_ERR_MEMORY, "out of memory (boundary table)");
    t->v = nv;
    int32_t *nr = pa__realloc(t->ref, cap * sizeof *nr);
    if (!nr) PA_FAIL(PA_ERR_MEMORY, "out of memory (boundary table)");
    t->ref = nr;
    uint8_t *nf = pa__realloc(t->flag, cap);
    if (!nf) PA_FAIL(PA_ERR_MEMORY, "out of memory (boundary table)");
    t->flag = nf;
    t->cap = cap;
  }
  if (2 * (t->nfull + 1) > t->nslot) {
    size_t ns = 64;
    while (ns < 4 * ((size_t)t->n + 1)) ns *= 2;
    PA_CALL(table_rehash(t, ns));
  }
  pa_idx r = t->n++;
  memcpy(t->v + (size_t)t->nk * r, v, t->nk * sizeof *v);
  t->ref[r] = ref;
  t->flag[r] = flag & (uint8_t)~RM3D_REC_DEAD;
  pa_idx key[3];
  sort_key(v, t->nk, key);
  size_t mask = t->nslot - 1;
  size_t h = (size_t)pa__hash_idx(key, t->nk) & mask;
  while (t->slot[h] >= 0) h = (h + 1) & mask;
  if (t->slot[h] == -1) t->nfull++;
  t->slot[h] = r;
  if (index) *index = r;
cleanup:
  return st;
}

void pa__rm3d_table_remove(rm3d_table *t, pa_idx r) {
  pa_idx key[3];
  sort_key(t->v + (size_t)t->nk * r, t->nk, key);
  size_t mask = t->nslot - 1;
  size_t h = (size_t)pa__hash_idx(key, t->nk) & mask;
  while (t->slot[h] != r) h = (h + 1) & mask;
  t->slot[h] = -2;
  t->flag[r] |= RM3D_REC_DEAD;
}

static void table_free(rm3d_table *t) {
  pa__free(t->v);
  pa__free(t->ref);
  pa__free(t->flag);
  pa__free(t->slot);
  memset(t, 0, sizeof *t);
}

/* ---- growth ------------------------------------------------------------ */

#define GROW_TO(ptr, n)                                                      \
  do {                                                                       \
    void *np_ = pa__realloc((ptr), (n) * sizeof *(ptr));                     \
    if (!np_) PA_FAIL(PA_ERR_MEMORY, "out of memory (3D remesher)");         \
    (ptr) = np_;                                                             \
  } while (0)

pa_status pa__rm3d_reserve(rm3d *m, size_t nv, size_t ne) {
  pa_status st = PA_SUCCESS;
  if (nv > m->capv) {
    size_t cap = m->capv + m->capv / 4 + 1024;
    if (cap < nv) cap = nv;
    PA_CHECK(cap <= INT32_MAX, PA_ERR_ARG, "too many vertices");
    GROW_TO(m->x, 3 * cap);
    GROW_TO(m->met, (size_t)m->mc * cap);
    if (m->met0) GROW_TO(m->met0, (size_t)m->mc * cap);
    GROW_TO(m->vref, cap);
    GROW_TO(m->vpf, cap);
    GROW_TO(m->vtag, cap);
    GROW_TO(m->vtet, cap);
    if (m->nrm) GROW_TO(m->nrm, 3 * cap);
    if (m->vcur) GROW_TO(m->vcur, 3 * cap);
    if (m->voff) GROW_TO(m->voff, cap);
    for (int k = 0; k < m->nfield; k++)
      GROW_TO(m->fval[k], (size_t)m->fcomp[k] * cap);
    m->capv = cap;
  }
  if (ne > m->cape) {
    size_t cap = m->cape + m->cape / 4 + 4096;
    if (cap < ne) cap = ne;
    PA_CHECK(cap <= INT32_MAX / 4, PA_ERR_ARG, "too many tetrahedra");
    GROW_TO(m->tv, 4 * cap);
    GROW_TO(m->adj, 4 * cap);
    GROW_TO(m->q, cap);
    GROW_TO(m->tflag, cap);
    GROW_TO(m->tpf, cap);
    GROW_TO(m->tref, cap);
    m->cape = cap;
  }
cleanup:
  return st;
}

pa_status pa__rm3d_new_vertex(rm3d *m, const double *x, const double *met,
                              pa_idx *index) {
  pa_status st = PA_SUCCESS;
  PA_CALL(pa__rm3d_reserve(m, (size_t)m->nv + 1, 0));
  pa_idx i = m->nv++;
  memcpy(m->x + 3 * (size_t)i, x, 3 * sizeof *x);
  if (met) memcpy(m->met + (size_t)m->mc * i, met, m->mc * sizeof *met);
  if (met && m->met0)
    memcpy(m->met0 + (size_t)m->mc * i, met, m->mc * sizeof *met);
  m->vref[i] = 0;
  m->vpf[i] = 0;
  m->vtag[i] = 0;
  m->vtet[i] = -1;
  if (m->nrm) memset(m->nrm + 3 * (size_t)i, 0, 3 * sizeof(double));
  if (m->vcur) memset(m->vcur + 3 * (size_t)i, 0, 3 * sizeof(double));
  if (m->voff) m->voff[i] = 0;
  for (int k = 0; k < m->nfield; k++)
    memset(m->fval[k] + (size_t)m->fcomp[k] * i, 0,
           m->fcomp[k] * sizeof(double));
  *index = i;
cleanup:
  return st;
}

static void interp_met(int mc, double *met, pa_idx dst, int n,
                       const pa_idx *src, const double *w) {
  const double *ms[8] = {NULL};
  double out[6];
  for (int i = 0; i < n; i++) ms[i] = met + (size_t)mc * src[i];
  pa__metric_interp(3, mc, n, ms, w, out); /* dst may be one of src */
  memcpy(met + (size_t)mc * dst, out, sizeof(double) * mc);
}

void pa__rm3d_met0_mid(rm3d *m, pa_idx dst, pa_idx a, pa_idx b) {
  if (!m->met0) return;
  pa_idx src[2] = {a, b};
  double w[2] = {0.5, 0.5};
  interp_met(m->mc, m->met0, dst, 2, src, w);
}

void pa__rm3d_interp(rm3d *m, pa_idx dst, int n, const pa_idx *src,
                     const double *w) {
  int mc = m->mc;
  interp_met(mc, m->met, dst, n, src, w);
  if (m->met0) interp_met(mc, m->met0, dst, n, src, w);
  for (int k = 0; k < m->nfield; k++) {
    int c = m->fcomp[k];
    const double *vs[8] = {NULL};
    for (int i = 0; i < n && i < 8; i++) vs[i] = m->fval[k] + (size_t)c * src[i];
    pa__field_interp(3, c, m->fmetric[k], n < 8 ? n : 8, vs, w,
                     m->fval[k] + (size_t)c * dst);
  }
}

void pa__rm3d_free(rm3d *m) {
  pa__free(m->x);
  pa__free(m->met);
  pa__free(m->met0);
  pa__free(m->vref);
  pa__free(m->vpf);
  pa__free(m->vtag);
  pa__free(m->vtet);
  pa__free(m->nrm);
  pa__free(m->vcur);
  pa__free(m->voff);
  pa__free(m->tv);
  pa__free(m->adj);
  pa__free(m->q);
  pa__free(m->tflag);
  pa__free(m->tpf);
  pa__free(m->tref);
  for (int k = 0; k < m->nfield; k++) pa__free(m->fval[k]);
  table_free(&m->tri);
  table_free(&m->edg);
  memset(m, 0, sizeof *m);
}

/* ---- build ------------------------------------------------------------- */

/* The sorted vertices f[0..2] of face i of tet k. */
static void face_of(const rm3d *m, pa_idx k, int i, pa_idx *f) {
  f[0] = m->tv[4 * (size_t)k + pa__rm3d_face[i][0]];
  f[1] = m->tv[4 * (size_t)k + pa__rm3d_face[i][1]];
  f[2] = m->tv[4 * (size_t)k + pa__rm3d_face[i][2]];
  pa__sort_small(f, 3);
}

/* Pair tet faces (and locate boundary triangles) by bucketing each face on
 * its smallest vertex, the other two packed in one key per face: O(n)
 * time, 12 bytes per face of temporary memory. */
static pa_status build_adjacency(rm3d *m, pa_mesh *mesh) {
  pa_status st = PA_SUCCESS;
  pa_idx *start = NULL, *face = NULL, *fill = NULL;
  uint64_t *key = NULL; /* face[s]'s two largest vertices */
  pa_idx nv = m->nv, ne = m->ne;
  PA_CALLOC(start, (size_t)nv + 1);
  PA_ALLOC(face, 4 * (size_t)ne);
  PA_ALLOC(key, 4 * (size_t)ne);
  PA_ALLOC(fill, (size_t)nv);
  for (pa_idx k = 0; k < ne; k++)
    for (int i = 0; i < 4; i++) {
      pa_idx f[3];
      face_of(m, k, i, f);
      start[f[0] + 1]++;
      m->adj[4 * k + i] = -1;
    }
  for (pa_idx v = 0; v < nv; v++) start[v + 1] += start[v];
  memcpy(fill, start, nv * sizeof *fill);
  for (pa_idx k = 0; k < ne; k++)
    for (int i = 0; i < 4; i++) {
      pa_idx f[3];
      face_of(m, k, i, f);
      pa_idx s = fill[f[0]]++;
      face[s] = 4 * k + i;
      key[s] = (uint64_t)(uint32_t)f[1] << 32 | (uint32_t)f[2];
    }
  /* Match faces within each bucket. */
  for (pa_idx v = 0; v < nv; v++) {
    for (pa_idx s = start[v]; s < start[v + 1]; s++) {
      pa_idx fs = face[s];
      if (m->adj[fs] != -1) continue;
      for (pa_idx t = s + 1; t < start[v + 1]; t++) {
        if (key[t] != key[s]) continue;
        pa_idx ft = face[t];
        PA_CHECK(m->adj[ft] == -1, PA_ERR_MESH,
                 "face (%d %d %d) is shared by more than two tetrahedra",
                 (int)v + 1, (int)(key[s] >> 32) + 1,
                 (int)(key[s] & 0xffffffffu) + 1);
        m->adj[fs] = ft;
        m->adj[ft] = fs;
      }
    }
  }
  /* Boundary triangles: records in the table, face bits on the tets. */
  for (pa_idx b = 0; b < mesh->nb; b++) {
    const pa_idx *tb = mesh->bdry + 3 * (size_t)b;
    pa_idx a[3] = {tb[0], tb[1], tb[2]};
    pa__sort_small(a, 3);
    PA_CHECK(a[0] >= 0 && a[2] < nv && a[0] != a[1] && a[1] != a[2],
             PA_ERR_MESH, "boundary triangle %d: invalid vertices", (int)b + 1);
    if (pa__rm3d_table_find(&m->tri, tb) >= 0) continue; /* duplicate */
    int found = 0;
    uint64_t ka = (uint64_t)(uint32_t)a[1] << 32 | (uint32_t)a[2];
    for (pa_idx s = start[a[0]]; s < start[a[0] + 1]; s++) {
      if (key[s] != ka) continue;
      m->tflag[face[s] >> 2] |= (uint8_t)(1u << (face[s] & 3));
      found = 1;
    }
    PA_CHECK(found, PA_ERR_MESH,
             "boundary triangle %d is not a face of any tetrahedron",
             (int)b + 1);
    PA_CALL(pa__rm3d_table_add(&m->tri, tb, mesh->bref[b], mesh->bflag[b],
                               NULL));
    uint8_t lock = (mesh->bflag[b] & PA_FLAG_REQUIRED) ? RM3D_V_LOCK : 0;
    for (int j = 0; j < 3; j++) m->vtag[tb[j]] |= (uint8_t)(RM3D_V_BDRY | lock);
  }
  pa__free(key);
  key = NULL;
  /* Faces without neighbour that the input did not list: add them. */
  for (pa_idx k = 0; k < ne; k++)
    for (int i = 0; i < 4; i++) {
      if (m->adj[4 * k + i] != -1 || (m->tflag[k] & (1u << i))) continue;
      pa_idx f[3] = {m->tv[4 * k + pa__rm3d_face[i][0]],
                     m->tv[4 * k + pa__rm3d_face[i][1]],
                     m->tv[4 * k + pa__rm3d_face[i][2]]};
      PA_CALL(pa__rm3d_table_add(&m->tri, f, 0, 0, NULL));
      m->tflag[k] |= (uint8_t)(1u << i);
      for (int j = 0; j < 3; j++) m->vtag[f[j]] |= RM3D_V_BDRY;
    }
  /* Faces between references that the input did not list: records it
   * does not get back (RM3D_REC_UNLISTED), so that every interface is a
   * surface of the remesher. */
  for (pa_idx k = 0; k < ne; k++)
    for (int i = 0; i < 4; i++) {
      pa_idx o = m->adj[4 * k + i];
      if (o < 4 * k + i || m->tref[o >> 2] == m->tref[k] ||
          (m->tflag[k] & (1u << i)))
        continue;
      pa_idx f[3] = {m->tv[4 * k + pa__rm3d_face[i][0]],
                     m->tv[4 * k + pa__rm3d_face[i][1]],
                     m->tv[4 * k + pa__rm3d_face[i][2]]};
      PA_CALL(pa__rm3d_table_add(&m->tri, f, 0, RM3D_REC_UNLISTED, NULL));
      m->tflag[k] |= (uint8_t)(1u << i);
      m->tflag[o >> 2] |= (uint8_t)(1u << (o & 3));
      for (int j = 0; j < 3; j++) m->vtag[f[j]] |= RM3D_V_BDRY;
    }
cleanup:
  pa__free(start);
  pa__free(face);
  pa__free(key);
  pa__free(fill);
  return st;
}

pa_status pa__rm3d_build(rm3d *m, pa_mesh *mesh, const pa_remesh_opts *opts) {
  pa_status st = PA_SUCCESS;
  memset(m, 0, sizeof *m);
  PA_CHECK(mesh->dim == 3, PA_ERR_ARG, "the 3D remesher needs a 3D mesh");
  PA_CHECK(mesh->ne > 0, PA_ERR_ARG, "the mesh has no tetrahedra");
  /* the metric pa_remesh prepared (hsiz folded in, then hmin/hmax, local
   * parameters and the gradation); hsiz alone only for a mesh without one
   * (the remesher called directly) */
  int mc = mesh->met_ncomp;
  PA_CHECK(mc == 1 || mc == 6 || (mc == 0 && opts->hsiz > 0), PA_ERR_ARG,
           "the mesh has no metric and no -hsiz was given");
  if (mc == 0) mc = 1;
  m->mc = mc;
  m->tri.nk = 3;
  m->edg.nk = 2;
  m->nfield = mesh->nfield;
  for (int k = 0; k < mesh->nfield; k++) {
    m->fcomp[k] = mesh->field[k].ncomp;
    m->fmetric[k] = (uint8_t)pa__field_is_metric(3, mesh->field[k].name,
                                                 mesh->field[k].ncomp);
  }
  m->surf = !opts->no_surf;
  m->swap = !opts->no_swap;
  m->hausd = opts->hausd > 0 ? opts->hausd : 0.01;
  m->opts = opts;
  m->ridge_cos = cos((opts->angle > 0 ? opts->angle : 45.0) * M_PI / 180.0);
  m->verbosity = opts->verbosity;
  m->qabs = RM3D_QABS;
  pa_idx nv = mesh->nv, ne = mesh->ne;
  PA_CALL(pa__rm3d_reserve(m, (size_t)nv, (size_t)ne));
  m->nv = nv;
  m->ne = ne;
  memcpy(m->x, mesh->coord, 3 * sizeof(double) * (size_t)nv);
  for (pa_idx i = 0; i < nv; i++) {
    const double *p = m->x + 3 * (size_t)i;
    PA_CHECK(isfinite(p[0]) && isfinite(p[1]) && isfinite(p[2]), PA_ERR_MESH,
             "vertex %d has a non-finite coordinate", (int)i + 1);
  }
  if (mesh->met_ncomp == 0) {
    for (pa_idx i = 0; i < nv; i++) m->met[i] = opts->hsiz;
  } else {
    memcpy(m->met, mesh->met, sizeof(double) * (size_t)mc * nv);
  }
  memcpy(m->vref, mesh->vref, sizeof(int32_t) * (size_t)nv);
  memcpy(m->vpf, mesh->vflag, (size_t)nv);
  if (opts->geometry) PA_CALLOC(m->voff, m->capv);
  for (pa_idx i = 0; i < nv; i++) {
    uint8_t f = mesh->vflag[i], t = 0;
    if (f & PA_FLAG_REQUIRED) t |= RM3D_V_LOCK;
    if (f & PA_FLAG_CORNER) t |= RM3D_V_LOCK | RM3D_V_CORNER;
    m->vtag[i] = t;
    m->vtet[i] = -1;
  }
  for (int k = 0; k < m->nfield; k++)
    memcpy(m->fval[k], mesh->field[k].val,
           sizeof(double) * (size_t)m->fcomp[k] * nv);
  memcpy(m->tv, mesh->elem, 4 * sizeof(pa_idx) * (size_t)ne);
  memcpy(m->tref, mesh->eref, sizeof(int32_t) * (size_t)ne);
  memcpy(m->tpf, mesh->eflag, (size_t)ne);
  for (pa_idx k = 0; k < ne; k++) {
    const pa_idx *v = m->tv + 4 * (size_t)k;
    for (int j = 0; j < 4; j++)
      PA_CHECK(v[j] >= 0 && v[j] < nv, PA_ERR_MESH,
               "tetrahedron %d: vertex index out of range", (int)k + 1);
    PA_CHECK(v[0] != v[1] && v[0] != v[2] && v[0] != v[3] && v[1] != v[2] &&
                 v[1] != v[3] && v[2] != v[3],
             PA_ERR_MESH, "tetrahedron %d has a repeated vertex", (int)k + 1);
    PA_CHECK(pa__orient3d(m->x + 3 * (size_t)v[0], m->x + 3 * (size_t)v[1],
                          m->x + 3 * (size_t)v[2], m->x + 3 * (size_t)v[3]) > 0,
             PA_ERR_MESH, "tetrahedron %d is inverted or flat", (int)k + 1);
    m->tflag[k] = (m->tpf[k] & PA_FLAG_REQUIRED) ? RM3D_T_FROZEN : 0;
    for (int j = 0; j < 4; j++) {
      m->vtet[v[j]] = k;
      if (m->tflag[k] & RM3D_T_FROZEN) m->vtag[v[j]] |= RM3D_V_LOCK;
    }
    m->q[k] = (float)rm3d_qual_v(m, v);
    if (!(m->tflag[k] & RM3D_T_FROZEN) && RM3D_QABS_INPUT * m->q[k] < m->qabs)
      m->qabs = RM3D_QABS_INPUT * m->q[k];
  }
  for (pa_idx i = 0; i < nv; i++)
    PA_CHECK(m->vtet[i] >= 0, PA_ERR_MESH,
             "vertex %d belongs to no tetrahedron", (int)i + 1);
  PA_CALL(build_adjacency(m, mesh));
  for (pa_idx e = 0; e < mesh->ned; e++) {
    const pa_idx *ev = mesh->edge + 2 * (size_t)e;
    PA_CHECK(ev[0] >= 0 && ev[0] < nv && ev[1] >= 0 && ev[1] < nv &&
                 ev[0] != ev[1],
             PA_ERR_MESH, "edge %d: invalid vertices", (int)e + 1);
    if (pa__rm3d_table_find(&m->edg, ev) >= 0) continue;
    PA_CALL(pa__rm3d_table_add(&m->edg, ev, mesh->edref[e], mesh->edflag[e],
                               NULL));
    uint8_t t = RM3D_V_FEAT;
    if (mesh->edflag[e] & PA_FLAG_REQUIRED) t |= RM3D_V_LOCK;
    m->vtag[ev[0]] |= t;
    m->vtag[ev[1]] |= t;
  }
cleanup:
  if (st != PA_SUCCESS) pa__rm3d_free(m);
  return st;
}

/* ---- compaction -------------------------------------------------------- */

pa_status pa__rm3d_compact(rm3d *m, int keep_q) {
  pa_status st = PA_SUCCESS;
  pa_idx *newt = NULL;
  if (m->ndead_t == 0 && m->ndead_v == 0 && (keep_q || !m->q)) return st;
  /* The quality cache moves with its tets when kept (the passes' own
   * values, which are rm3d_qual_v's); else it goes first, so that the
   * renumbering scratch does not raise the memory peak. */
  if (!keep_q) {
    pa__free(m->q);
    m->q = NULL;
  }
  PA_ALLOC(newt, (size_t)m->ne + 1);
  /* Tetrahedra: new index = rank among live ones; adjacency remapped. The
   * vertex array vtet is reused as scratch only after tets are done. */
  pa_idx ne = 0;
  for (pa_idx k = 0; k < m->ne; k++)
    newt[k] = (m->tflag[k] & RM3D_T_DEAD) ? -1 : ne++;
  for (pa_idx k = 0; k < m->ne; k++) {
    pa_idx j = newt[k];
    if (j < 0) continue;
    for (int i = 0; i < 4; i++) {
      if (m->adj) {
        pa_idx a = m->adj[4 * (size_t)k + i];
        m->adj[4 * (size_t)j + i] = a < 0 ? a : 4 * newt[a >> 2] + (a & 3);
      }
      m->tv[4 * (size_t)j + i] = m->tv[4 * (size_t)k + i];
    }
    m->tflag[j] = m->tflag[k];
    if (keep_q) m->q[j] = m->q[k];
    m->tpf[j] = m->tpf[k];
    m->tref[j] = m->tref[k];
  }
  m->ne = ne;
  /* Vertices: renumber in order; tets and tables remapped. */
  pa_idx nv = 0;
  pa_idx *newv = m->vtet;
  for (pa_idx i = 0; i < m->nv; i++)
    newv[i] = (m->vtag[i] & RM3D_V_DEAD) ? -1 : nv++;
  for (size_t i = 0; i < 4 * (size_t)ne; i++) m->tv[i] = newv[m->tv[i]];
  rm3d_table *tabs[2] = {&m->tri, &m->edg};
  for (int t = 0; t < 2; t++) {
    rm3d_table *tb = tabs[t];
    pa_idx n = 0;
    for (pa_idx r = 0; r < tb->n; r++) {
      if (tb->flag[r] & RM3D_REC_DEAD) continue;
      for (int j = 0; j < tb->nk; j++)
        tb->v[(size_t)tb->nk * n + j] = newv[tb->v[(size_t)tb->nk * r + j]];
      tb->ref[n] = tb->ref[r];
      tb->flag[n] = tb->flag[r];
      n++;
    }
    tb->n = n;
    /* Rehash in place: the slot array is large enough. */
    for (size_t s = 0; s < tb->nslot; s++) tb->slot[s] = -1;
    tb->nfull = 0;
    for (pa_idx r = 0; r < n; r++) {
      pa_idx key[3];
      sort_key(tb->v + (size_t)tb->nk * r, tb->nk, key);
      size_t h = (size_t)pa__hash_idx(key, tb->nk) & (tb->nslot - 1);
      while (tb->slot[h] != -1) h = (h + 1) & (tb->nslot - 1);
      tb->slot[h] = r;
      tb->nfull++;
    }
  }
  for (pa_idx i = 0; i < m->nv; i++) {
    pa_idx j = newv[i];
    if (j < 0) continue;
    memmove(m->x + 3 * (size_t)j, m->x + 3 * (size_t)i, 3 * sizeof(double));
    memmove(m->met + (size_t)m->mc * j, m->met + (size_t)m->mc * i,
            m->mc * sizeof(double));
    if (m->met0)
      memmove(m->met0 + (size_t)m->mc * j, m->met0 + (size_t)m->mc * i,
              m->mc * sizeof(double));
    if (m->nrm)
      memmove(m->nrm + 3 * (size_t)j, m->nrm + 3 * (size_t)i,
              3 * sizeof(double));
    if (m->vcur)
      memmove(m->vcur + 3 * (size_t)j, m->vcur + 3 * (size_t)i,
              3 * sizeof(double));
    m->vref[j] = m->vref[i];
    m->vpf[j] = m->vpf[i];
    m->vtag[j] = m->vtag[i];
    if (m->voff) m->voff[j] = m->voff[i];
    for (int k = 0; k < m->nfield; k++) {
      int c = m->fcomp[k];
      memmove(m->fval[k] + (size_t)c * j, m->fval[k] + (size_t)c * i,
              c * sizeof(double));
    }
  }
  m->nv = nv;
  for (pa_idx k = 0; k < ne; k++)
    for (int i = 0; i < 4; i++) m->vtet[m->tv[4 * (size_t)k + i]] = k;
  m->ndead_t = m->ndead_v = 0;
  pa__free(newt);
  newt = NULL;
cleanup:
  pa__free(newt);
  return st;
}

/* ---- write back -------------------------------------------------------- */

pa_status pa__rm3d_write(rm3d *m, pa_mesh *mesh) {
  pa_status st = PA_SUCCESS;
  pa_mesh *out = NULL;
  /* Adjacency and qualities are not needed any more: free them first so
   * that the peak memory holds the output and the rest, not both. */
  pa__free(m->adj);
  m->adj = NULL;
  PA_CALL(pa__rm3d_compact(m, 0));
  pa_idx nb = 0, ned = 0;
  for (pa_idx r = 0; r < m->tri.n; r++)
    nb += !(m->tri.flag[r] & (RM3D_REC_DEAD | RM3D_REC_UNLISTED));
  for (pa_idx r = 0; r < m->edg.n; r++)
    ned += !(m->edg.flag[r] & (RM3D_REC_DEAD | RM3D_REC_UNLISTED));
  PA_CALL(pa_mesh_create(3, &out));
  out->met_ncomp = mesh->met_ncomp ? mesh->met_ncomp : 0;
  if (out->met_ncomp && out->met_ncomp != m->mc) out->met_ncomp = m->mc;
  out->nfield = mesh->nfield;
  for (int k = 0; k < mesh->nfield; k++) {
    memcpy(out->field[k].name, mesh->field[k].name, PA_MESH_FIELD_NAME_LEN);
    out->field[k].ncomp = mesh->field[k].ncomp;
  }
  PA_CALL(pa_mesh_reserve(out, m->nv, m->ne, nb, ned));
  /* a classified mesh: room for its entities, which pa_remesh fills from
   * the cells (remesher.c) */
  if (mesh->vgdim) PA_CALL(pa__mesh_enable_entities(out));
  out->nv = m->nv;
  out->ne = m->ne;
  memcpy(out->coord, m->x, 3 * sizeof(double) * (size_t)m->nv);
  memcpy(out->vref, m->vref, sizeof(int32_t) * (size_t)m->nv);
  memcpy(out->vflag, m->vpf, (size_t)m->nv);
  if (out->met_ncomp)
    memcpy(out->met, m->met0 ? m->met0 : m->met,
           sizeof(double) * (size_t)m->mc * m->nv);
  for (int k = 0; k < m->nfield; k++)
    memcpy(out->field[k].val, m->fval[k],
           sizeof(double) * (size_t)m->fcomp[k] * m->nv);
  memcpy(out->elem, m->tv, 4 * sizeof(pa_idx) * (size_t)m->ne);
  memcpy(out->eref, m->tref, sizeof(int32_t) * (size_t)m->ne);
  memcpy(out->eflag, m->tpf, (size_t)m->ne);
  for (pa_idx r = 0; r < m->tri.n; r++) {
    if (m->tri.flag[r] & (RM3D_REC_DEAD | RM3D_REC_UNLISTED)) continue;
    memcpy(out->bdry + 3 * (size_t)out->nb, m->tri.v + 3 * (size_t)r,
           3 * sizeof(pa_idx));
    out->bref[out->nb] = m->tri.ref[r];
    out->bflag[out->nb] = m->tri.flag[r];
    out->nb++;
  }
  for (pa_idx r = 0; r < m->edg.n; r++) {
    if (m->edg.flag[r] & (RM3D_REC_DEAD | RM3D_REC_UNLISTED)) continue;
    memcpy(out->edge + 2 * (size_t)out->ned, m->edg.v + 2 * (size_t)r,
           2 * sizeof(pa_idx));
    out->edref[out->ned] = m->edg.ref[r];
    out->edflag[out->ned] = m->edg.flag[r];
    out->ned++;
  }
  /* Swap contents: the caller's handle now holds the new mesh. */
  {
    pa_mesh tmp = *mesh;
    *mesh = *out;
    *out = tmp;
  }
cleanup:
  pa_mesh_destroy(out);
  return st;
}

/* ---- checker ----------------------------------------------------------- */

pa_status pa__rm3d_check(rm3d *m) {
  pa_status st = PA_SUCCESS;
  for (pa_idx k = 0; k < m->ne; k++) {
    if (m->tflag[k] & RM3D_T_DEAD) continue;
    const pa_idx *v = m->tv + 4 * (size_t)k;
    for (int i = 0; i < 4; i++) {
      PA_CHECK(v[i] >= 0 && v[i] < m->nv && !(m->vtag[v[i]] & RM3D_V_DEAD),
               PA_ERR_INTERNAL, "rm3d: tet %d has a dead vertex", (int)k);
    }
    PA_CHECK(pa__orient3d(m->x + 3 * (size_t)v[0], m->x + 3 * (size_t)v[1],
                          m->x + 3 * (size_t)v[2], m->x + 3 * (size_t)v[3]) > 0,
             PA_ERR_INTERNAL, "rm3d: tet %d is not positive", (int)k);
    PA_CHECK(!(m->tflag[k] & RM3D_T_MARK), PA_ERR_INTERNAL,
             "rm3d: tet %d left marked", (int)k);
    if (m->tflag[k] & RM3D_T_CLEAN) /* a change did not clear the mark */
      for (int e = 0; e < 6; e++) {
        double l = rm3d_len(m, v[pa__rm3d_edge[e][0]], v[pa__rm3d_edge[e][1]]);
        PA_CHECK(l >= PA_METRIC_LEN_LO_EXACT && l <= PA_METRIC_LEN_HI_EXACT,
                 PA_ERR_INTERNAL,
                 "rm3d: tet %d is marked clean, its edge %d has length %g",
                 (int)k, e, l);
      }
    for (int i = 0; i < 4; i++) {
      pa_idx a = m->adj[4 * (size_t)k + i];
      pa_idx f[3] = {v[pa__rm3d_face[i][0]], v[pa__rm3d_face[i][1]],
                     v[pa__rm3d_face[i][2]]};
      pa__sort_small(f, 3);
      int tagged = (m->tflag[k] >> i) & 1;
      if (tagged)
        PA_CHECK(pa__rm3d_table_find(&m->tri, f) >= 0, PA_ERR_INTERNAL,
                 "rm3d: tet %d face %d tagged but not in the table", (int)k, i);
      else
        PA_CHECK(pa__rm3d_table_find(&m->tri, f) < 0, PA_ERR_INTERNAL,
                 "rm3d: tet %d face %d in the table but not tagged", (int)k, i);
      if (a < 0) {
        PA_CHECK(tagged, PA_ERR_INTERNAL,
                 "rm3d: tet %d face %d has no neighbour and no triangle",
                 (int)k, i);
        continue;
      }
      pa_idx l = a >> 2;
      int j = a & 3;
      PA_CHECK(l < m->ne && !(m->tflag[l] & RM3D_T_DEAD), PA_ERR_INTERNAL,
               "rm3d: tet %d face %d points at a dead tet", (int)k, i);
      PA_CHECK(tagged || m->tref[l] == m->tref[k], PA_ERR_INTERNAL,
               "rm3d: tet %d face %d lies between references %d and %d "
               "and is no triangle", (int)k, i, (int)m->tref[k],
               (int)m->tref[l]);
      PA_CHECK(m->adj[4 * (size_t)l + j] == 4 * k + i, PA_ERR_INTERNAL,
               "rm3d: adjacency of tet %d face %d not symmetric", (int)k, i);
      const pa_idx *w = m->tv + 4 * (size_t)l;
      pa_idx g[3] = {w[pa__rm3d_face[j][0]], w[pa__rm3d_face[j][1]],
                     w[pa__rm3d_face[j][2]]};
      pa__sort_small(g, 3);
      PA_CHECK(f[0] == g[0] && f[1] == g[1] && f[2] == g[2], PA_ERR_INTERNAL,
               "rm3d: tet %d face %d and its neighbour differ", (int)k, i);
      PA_CHECK(((m->tflag[l] >> j) & 1) == tagged, PA_ERR_INTERNAL,
               "rm3d: face tag of tet %d face %d not symmetric", (int)k, i);
    }
  }
  for (pa_idx i = 0; i < m->nv; i++) {
    if (m->vtag[i] & RM3D_V_DEAD) continue;
    pa_idx k = m->vtet[i];
    PA_CHECK(k >= 0 && k < m->ne && !(m->tflag[k] & RM3D_T_DEAD) &&
                 rm3d_loc(m->tv + 4 * (size_t)k, i) >= 0,
             PA_ERR_INTERNAL, "rm3d: vtet of vertex %d is wrong", (int)i);
  }
cleanup:
  return st;
}

/* ---- spatial reordering ------------------------------------------------ */

static uint64_t spread3(uint64_t x) {
  x &= 0x1fffff;
  x = (x | x << 32) & 0x1f00000000ffffull;
  x = (x | x << 16) & 0x1f0000ff0000ffull;
  x = (x | x << 8) & 0x100f00f00f00f00full;
  x = (x | x << 4) & 0x10c30c30c30c30c3ull;
  x = (x | x << 2) & 0x1249249249249249ull;
  return x;
}

/* Arrays of records that one permutation moves together (permute). */
#define RM3D_PERM_MAX (8 + PA_MESH_MAX_FIELDS)
typedef struct perm_arrays {
  int n;
  char *base[RM3D_PERM_MAX];
  size_t sz[RM3D_PERM_MAX]; /* record sizes, each <= 64 bytes */
} perm_arrays;

static void perm_add(perm_arrays *pa, void *base, size_t sz) {
  PA_ASSERT(pa->n < RM3D_PERM_MAX && sz <= 64);
  pa->base[pa->n] = base;
  pa->sz[pa->n++] = sz;
}

/* Copy a record of sz bytes: the sizes of permute's arrays inline (a call
 * to memcpy per record was half the reordering's time). */
static inline void copy_rec(char *dst, const char *src, size_t sz) {
  switch (sz) {
  case 1: *dst = *src; break;
  case 4: memcpy(dst, src, 4); break;
  case 8: memcpy(dst, src, 8); break;
  case 16: memcpy(dst, src, 16); break;
  case 24: memcpy(dst, src, 24); break;
  case 48: memcpy(dst, src, 48); break;
  default: memcpy(dst, src, sz);
  }
}

/* Apply the permutation "old slot i goes to slot pos[i]" to the n records
 * of every array of pa in place, following each cycle once for all of
 * them; done[] is n bytes of scratch (in place: the reordering does not
 * raise the memory peak). A cycle's steps wait on each other (the next slot
 * is read from pos), so one walk moving every array's records, whose loads
 * overlap, takes a fraction of a walk per array (rod -> 0.03: 0.31 -> 0.12
 * s CPU for the reordering). */
static void permute(const perm_arrays *pa, const pa_idx *pos, pa_idx n,
                    uint8_t *done) {
  char tmp[RM3D_PERM_MAX][64], tmp2[64];
  memset(done, 0, (size_t)n);
  for (pa_idx s = 0; s < n; s++) {
    if (done[s]) continue;
    for (int k = 0; k < pa->n; k++)
      copy_rec(tmp[k], pa->base[k] + pa->sz[k] * s, pa->sz[k]);
    pa_idx i = s;
    for (;;) {
      pa_idx j = pos[i];
      done[i] = 1;
      if (j == s) {
        for (int k = 0; k < pa->n; k++)
          copy_rec(pa->base[k] + pa->sz[k] * s, tmp[k], pa->sz[k]);
        break;
      }
      for (int k = 0; k < pa->n; k++) {
        char *r = pa->base[k] + pa->sz[k] * j;
        copy_rec(tmp2, r, pa->sz[k]);
        copy_rec(r, tmp[k], pa->sz[k]);
        copy_rec(tmp[k], tmp2, pa->sz[k]);
      }
      i = j;
    }
  }
}

/* pos[i]: the new slot of vertex i, along the Morton curve of the bounding
 * box (key: nv records of scratch). */
static void vertex_positions(const rm3d *m, pa__key64 *key, pa_idx *pos) {
  pa_idx nv = m->nv;
  double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
  for (pa_idx i = 0; i < nv; i++)
    for (int j = 0; j < 3; j++) {
      double c = m->x[3 * (size_t)i + j];
      if (c < lo[j]) lo[j] = c;
      if (c > hi[j]) hi[j] = c;
    }
  double sc = 0;
  for (int j = 0; j < 3; j++)
    if (hi[j] - lo[j] > sc) sc = hi[j] - lo[j];
  sc = sc > 0 ? 2097151.0 / sc : 0;
  for (pa_idx i = 0; i < nv; i++) {
    const double *p = m->x + 3 * (size_t)i;
    key[i].key = spread3((uint64_t)((p[0] - lo[0]) * sc)) |
                 spread3((uint64_t)((p[1] - lo[1]) * sc)) << 1 |
                 spread3((uint64_t)((p[2] - lo[2]) * sc)) << 2;
    key[i].idx = i;
  }
  qsort(key, (size_t)nv, sizeof *key, pa__key64_cmp);
  for (pa_idx i = 0; i < nv; i++) pos[key[i].idx] = i;
}

/* Move the vertex records to slots pos, and renumber the tets and the
 * entity tables (rehashed) to them. */
static void move_vertices(rm3d *m, const pa_idx *pos, uint8_t *done) {
  pa_idx nv = m->nv;
  perm_arrays pa = {0};
  perm_add(&pa, m->x, 3 * sizeof(double));
  perm_add(&pa, m->met, (size_t)m->mc * sizeof(double));
  if (m->met0) perm_add(&pa, m->met0, (size_t)m->mc * sizeof(double));
  if (m->nrm) perm_add(&pa, m->nrm, 3 * sizeof(double));
  if (m->vcur) perm_add(&pa, m->vcur, 3 * sizeof(double));
  perm_add(&pa, m->vref, sizeof(int32_t));
  perm_add(&pa, m->vpf, 1);
  perm_add(&pa, m->vtag, 1);
  if (m->voff) perm_add(&pa, m->voff, 1);
  for (int k = 0; k < m->nfield; k++)
    perm_add(&pa, m->fval[k], (size_t)m->fcomp[k] * sizeof(double));
  permute(&pa, pos, nv, done);
  for (size_t i = 0; i < 4 * (size_t)m->ne; i++) m->tv[i] = pos[m->tv[i]];
  rm3d_table *tabs[2] = {&m->tri, &m->edg};
  for (int t = 0; t < 2; t++) {
    rm3d_table *tb = tabs[t];
    for (size_t i = 0; i < (size_t)tb->nk * tb->n; i++) tb->v[i] = pos[tb->v[i]];
    for (size_t s = 0; s < tb->nslot; s++) tb->slot[s] = -1;
    tb->nfull = 0;
    for (pa_idx r = 0; r < tb->n; r++) {
      pa_idx kk[3];
      sort_key(tb->v + (size_t)tb->nk * r, tb->nk, kk);
      size_t h = (size_t)pa__hash_idx(kk, tb->nk) & (tb->nslot - 1);
      while (tb->slot[h] != -1) h = (h + 1) & (tb->nslot - 1);
      tb->slot[h] = r;
      tb->nfull++;
    }
  }
}

/* pos[k]: the new slot of tet k, by its smallest vertex (a stable counting
 * sort; start: nv + 1 zeroed counters). */
static void tet_positions(const rm3d *m, pa_idx *start, pa_idx *pos) {
  pa_idx nv = m->nv, ne = m->ne;
  for (pa_idx k = 0; k < ne; k++) {
    const pa_idx *v = m->tv + 4 * (size_t)k;
    pa_idx a = v[0] < v[1] ? v[0] : v[1], b = v[2] < v[3] ? v[2] : v[3];
    start[(a < b ? a : b) + 1]++;
  }
  for (pa_idx i = 0; i < nv; i++) start[i + 1] += start[i];
  for (pa_idx k = 0; k < ne; k++) {
    const pa_idx *v = m->tv + 4 * (size_t)k;
    pa_idx a = v[0] < v[1] ? v[0] : v[1], b = v[2] < v[3] ? v[2] : v[3];
    pos[k] = start[a < b ? a : b]++;
  }
}

/* Move the tet records to slots pos, renumbering the adjacency, and point
 * each vertex to a tet holding it. */
static void move_tets(rm3d *m, const pa_idx *pos, uint8_t *done) {
  pa_idx ne = m->ne;
  for (size_t i = 0; i < 4 * (size_t)ne; i++) {
    pa_idx a = m->adj[i];
    if (a >= 0) m->adj[i] = 4 * pos[a >> 2] + (a & 3);
  }
  perm_arrays pa = {0};
  perm_add(&pa, m->tv, 4 * sizeof(pa_idx));
  perm_add(&pa, m->adj, 4 * sizeof(pa_idx));
  perm_add(&pa, m->tflag, 1);
  perm_add(&pa, m->tpf, 1);
  perm_add(&pa, m->tref, sizeof(int32_t));
  permute(&pa, pos, ne, done);
  for (pa_idx k = 0; k < ne; k++)
    for (int i = 0; i < 4; i++) m->vtet[m->tv[4 * (size_t)k + i]] = k;
}

pa_status pa__rm3d_reorder(rm3d *m) {
  pa_status st = PA_SUCCESS;
  pa__key64 *key = NULL;
  pa_idx *pos = NULL, *start = NULL;
  uint8_t *done = NULL;
  for (int k = 0; k < m->nfield; k++)
    if (m->fcomp[k] > 8) return pa__rm3d_compact(m, 1); /* no reordering */
  PA_CALL(pa__rm3d_compact(m, 0)); /* q is rebuilt at the end */
  pa_idx nv = m->nv, ne = m->ne;
  size_t nmax = (size_t)(nv > ne ? nv : ne);
  PA_ALLOC(key, (size_t)nv + 1);
  PA_ALLOC(pos, (size_t)nv + 1);
  PA_ALLOC(done, nmax);
  vertex_positions(m, key, pos);
  move_vertices(m, pos, done);
  pa__free(key);
  key = NULL;
  pa__free(pos);
  pos = NULL;
  PA_CALLOC(start, (size_t)nv + 1);
  PA_ALLOC(pos, (size_t)ne + 1);
  tet_positions(m, start, pos);
  pa__free(start);
  start = NULL;
  move_tets(m, pos, done);
  pa__free(pos);
  pos = NULL;
  pa__free(done);
  done = NULL;
  PA_ALLOC(m->q, m->cape);
  for (pa_idx k = 0; k < ne; k++)
    m->q[k] = (float)rm3d_qual_v(m, m->tv + 4 * (size_t)k);
cleanup:
  pa__free(key);
  pa__free(pos);
  pa__free(start);
  pa__free(done);
  return st;
}

/* ---- frozen skins -------------------------------------------------------- */

/*
 * The edges of frozen tets, frozen boundary triangles and required feature
 * edges never change, so where their metric length is far from 1 (a piece of
 * the parallel loop whose frozen skin is the coarse input, refined to a much
 * smaller size, or the reverse) the free tets next to them must bridge the
 * difference. In the target metric a tet on a long frozen edge or face can
 * only be split on its free edges, so it flattens towards the quality floor
 * and splits and collapses undo each other there round after round (the
 * 2D remesher had the same disease, docs/design/REMESHER.md).
 *
 * The working metric is relaxed at the skin (as in 2D, pa__rm2d_skin_relax;
 * the scaling is remesh/skin.c's, pa__remesh_skin_relax): a frozen vertex
 * whose frozen edges have a mean length lambda outside [1/sqrt 2, sqrt 2]
 * gets its metric scaled so that this mean becomes
 * RM3D_LRELAX = 1.2 (or 1/sqrt 2 for a fine skin); the size then varies
 * linearly to the target over the first input ring (interpolation at the
 * splits). 1.2 rather than the 2D's sqrt 2: the free apex over a frozen
 * face whose mean edge is sqrt 2 is pulled towards it by the smaller sizes
 * around, worst Q 0.16-0.19 on the reproducers, 0.29-0.34 at 1.2, 0.32 at
 * 1.0 (docs/design/REMESHER3D.md). Every lambda comes from the target metric
 * before any change. The
 * target stays in met0, interpolated alongside, and is what the write-back
 * returns: frozen vertices come back bit for bit, new vertices carry the
 * target, so the next iteration of the parallel loop sees the tets near the
 * old skin as still to adapt. met0 stays NULL when nothing was relaxed.
 */
pa_status pa__rm3d_skin_relax(rm3d *m, pa_idx *nrelaxed) {
  pa_status st = PA_SUCCESS;
  int mc = m->mc;
  double *acc = NULL;
  int32_t *cnt = NULL;
  pa_idx nv = m->nv, nr = 0;
  int any = 0;
  *nrelaxed = 0;
  for (pa_idx k = 0; k < m->ne && !any; k++) any = m->tflag[k] & RM3D_T_FROZEN;
  for (pa_idx r = 0; r < m->tri.n && !any; r++)
    any = m->tri.flag[r] & PA_FLAG_REQUIRED;
  for (pa_idx r = 0; r < m->edg.n && !any; r++)
    any = m->edg.flag[r] & PA_FLAG_REQUIRED;
  if (!any) return PA_SUCCESS;
  PA_CALLOC(acc, nv);
  PA_CALLOC(cnt, nv);
  /* Edges shared by several frozen entities count once per entity: a
   * weighting, not a fault. */
  for (pa_idx k = 0; k < m->ne; k++) {
    if (!(m->tflag[k] & RM3D_T_FROZEN)) continue;
    const pa_idx *v = m->tv + 4 * (size_t)k;
    for (int e = 0; e < 6; e++) {
      pa_idx a = v[pa__rm3d_edge[e][0]], b = v[pa__rm3d_edge[e][1]];
      double l = rm3d_len(m, a, b);
      acc[a] += l;
      acc[b] += l;
      cnt[a]++;
      cnt[b]++;
    }
  }
  for (pa_idx r = 0; r < m->tri.n; r++) {
    if ((m->tri.flag[r] & RM3D_REC_DEAD) ||
        !(m->tri.flag[r] & PA_FLAG_REQUIRED))
      continue;
    const pa_idx *v = m->tri.v + 3 * (size_t)r;
    for (int i = 0; i < 3; i++) {
      pa_idx a = v[i], b = v[i == 2 ? 0 : i + 1];
      double l = rm3d_len(m, a, b);
      acc[a] += l;
      acc[b] += l;
      cnt[a]++;
      cnt[b]++;
    }
  }
  for (pa_idx r = 0; r < m->edg.n; r++) {
    if ((m->edg.flag[r] & RM3D_REC_DEAD) ||
        !(m->edg.flag[r] & PA_FLAG_REQUIRED))
      continue;
    pa_idx a = m->edg.v[2 * (size_t)r], b = m->edg.v[2 * (size_t)r + 1];
    double l = rm3d_len(m, a, b);
    acc[a] += l;
    acc[b] += l;
    cnt[a]++;
    cnt[b]++;
  }
  const pa__skin_relax r = {PA_METRIC_LEN_LO_EXACT, PA_METRIC_LEN_HI_EXACT,
                             RM3D_LRELAX};
  PA_CALL(pa__remesh_skin_relax(&r, mc, nv, m->capv, m->met, &m->met0, acc,
                                cnt, &nr));
  if (m->met0 && mc == 6) /* isotropic qualities do not see a size change */
    for (pa_idx k = 0; k < m->ne; k++)
      m->q[k] = (float)rm3d_qual_v(m, m->tv + 4 * (size_t)k);
  if (nr) /* lengths changed */
    for (pa_idx k = 0; k < m->ne; k++) m->tflag[k] &= (uint8_t)~RM3D_T_CLEAN;
  *nrelaxed = nr;
cleanup:
  pa__free(acc);
  pa__free(cnt);
  return st;
}
