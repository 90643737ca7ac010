/*
 * classify.c -- the classification of a mesh on a model (padapt.h,
 * "Geometry"): the vertices' entities and the model's entity table
 * (stored by mesh.c), the completion of a classified mesh's cells from its
 * vertices (pa_mesh_classify) and the vertices' entities recomputed from
 * the cells after a remesh (pa__mesh_derive_entities).
 *
 * What a classified mesh keeps, and every function here leaves true:
 *  - references of cells are entity tags, > 0 once classified;
 *  - each vertex's entity is the lowest-dimensional one of its cells: a
 *    point (the vertex is a corner at the point's coordinates), else a
 *    curve (3D: a feature edge; 2D: a boundary edge), else a surface (3D: a
 *    boundary triangle), else the volume (surface in 2D) of its elements;
 *  - every curve edge is listed (so the remeshers see the model's curves as
 *    ridges), and every boundary face, and every face between two volumes
 *    (two surfaces in 2D), is a boundary entity.
 * The second point is why the vertices' entities need not travel through
 * the remeshers: pa_remesh recomputes them from the cells, which carry
 * their references through every operator, and from the points (corners)
 * and frozen vertices, which never move and are found again by their
 * coordinates.
 */
#include "mesh/mesh.h"

#include <stdio.h>

const pa__entity *pa__mesh_entity(const pa_mesh *m, int dim, int32_t tag) {
  int lo = 0, hi = m->nent;
  while (lo < hi) {
    int mid = lo + (hi - lo) / 2;
    const pa__entity *e = &m->ents[mid];
    if (e->dim < dim || (e->dim == dim && e->tag < tag))
      lo = mid + 1;
    else
      hi = mid;
  }
  return lo < m->nent && m->ents[lo].dim == dim && m->ents[lo].tag == tag
             ? &m->ents[lo]
             : NULL;
}

int pa_mesh_classified(const pa_mesh *m) { return m && m->vgdim != NULL; }

const uint8_t *pa_mesh_vert_entity_dims(const pa_mesh *m) {
  return m ? m->vgdim : NULL;
}

const int32_t *pa_mesh_vert_entity_tags(const pa_mesh *m) {
  return m ? m->vgtag : NULL;
}

pa_status pa_mesh_copy_model(pa_mesh *dst, const pa_mesh *src) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(dst && src, PA_ERR_ARG, "pa_mesh_copy_model: NULL argument");
  PA_CALL(pa__mesh_copy_names(dst, src));
  PA_CALL(pa__mesh_copy_entities(dst, src));
cleanup:
  return st;
}

/* ---- the vertices' entities from the cells ---- */

/* Lexicographic order of points of dim coordinates (the exact match of a
 * vertex against the kept points). */
/* A point to compare (x) with the kept points of base (dim coordinates
 * each), by their indices. */
typedef struct ptkey {
  const double *x, *base;
  int dim;
} ptkey;

static int cmp_xyz(const double *p, const double *q, int dim) {
  for (int k = 0; k < dim; k++)
    if (p[k] != q[k]) return p[k] < q[k] ? -1 : 1;
  return 0;
}

/* bsearch's comparison of a ptkey with an index of its base */
static int cmp_key_pt(const void *key, const void *elem) {
  const ptkey *p = key;
  return cmp_xyz(p->x, p->base + (size_t)p->dim * *(const pa_idx *)elem,
                 p->dim);
}

/* A kept point to sort: its coordinates (dim), its index. */
typedef struct ptsort {
  const double *x;
  pa_idx k;
  int dim;
} ptsort;

static int cmp_ptsort(const void *a, const void *b) {
  const ptsort *p = a, *q = b;
  return cmp_xyz(p->x, q->x, p->dim);
}

/* Lower vertex v's entity to (dim, tag) if dim is lower. */
static void lower(pa_mesh *m, pa_idx v, int dim, int32_t tag) {
  if (dim < m->vgdim[v]) {
    m->vgdim[v] = (uint8_t)dim;
    m->vgtag[v] = tag;
  }
}

void pa__kept_free(pa__kept *k) {
  pa__free(k->xyz);
  pa__free(k->gdim);
  pa__free(k->gtag);
  pa__free(k->order);
  memset(k, 0, sizeof *k);
}

pa_status pa__mesh_kept_points(const pa_mesh *m, const uint8_t *frozen,
                               pa__kept *kept) {
  pa_status st = PA_SUCCESS;
  int d = m->dim;
  pa_idx n = 0;
  ptsort *pts = NULL;
  memset(kept, 0, sizeof *kept);
  if (!m->vgdim) return PA_SUCCESS;
  for (pa_idx v = 0; v < m->nv; v++)
    n += m->vgdim[v] == 0 || (frozen && frozen[v] && m->vgdim[v] < d);
  if (!n) return PA_SUCCESS;
  PA_ALLOC(kept->xyz, (size_t)d * n);
  PA_ALLOC(kept->gdim, n);
  PA_ALLOC(kept->gtag, n);
  PA_ALLOC(kept->order, n);
  for (pa_idx v = 0; v < m->nv; v++)
    if (m->vgdim[v] == 0 || (frozen && frozen[v] && m->vgdim[v] < d)) {
      pa_idx k = kept->n++;
      memcpy(kept->xyz + (size_t)d * k, m->coord + (size_t)d * v,
             d * sizeof *kept->xyz);
      kept->gdim[k] = m->vgdim[v];
      kept->gtag[k] = m->vgtag[v];
    }
  /* sorted now, so that pa__mesh_derive_entities allocates nothing */
  PA_ALLOC(pts, n);
  for (pa_idx k = 0; k < n; k++)
    pts[k] = (ptsort){kept->xyz + (size_t)d * k, k, d};
  qsort(pts, (size_t)n, sizeof *pts, cmp_ptsort);
  for (pa_idx k = 0; k < n; k++) kept->order[k] = pts[k].k;
cleanup:
  pa__free(pts);
  if (st) pa__kept_free(kept);
  return st;
}

void pa__mesh_derive_entities(pa_mesh *m, const pa__kept *kept) {
  int d = m->dim;
  memset(m->vgdim, 255, (size_t)m->nv);
  memset(m->vgtag, 0, (size_t)m->nv * sizeof *m->vgtag);
  for (pa_idx e = 0; e < m->ne; e++)
    for (int i = 0; i <= d; i++)
      lower(m, m->elem[(size_t)(d + 1) * e + i], d, m->eref[e]);
  for (pa_idx b = 0; b < m->nb; b++)
    if (m->bref[b] > 0)
      for (int i = 0; i < d; i++)
        lower(m, m->bdry[(size_t)d * b + i], d - 1, m->bref[b]);
  for (pa_idx k = 0; k < m->ned; k++)
    if (m->edref[k] > 0)
      for (int i = 0; i < 2; i++)
        lower(m, m->edge[2 * (size_t)k + i], 1, m->edref[k]);
  if (kept && kept->n > 0)
    for (pa_idx v = 0; v < m->nv; v++) {
      ptkey key = {m->coord + (size_t)d * v, kept->xyz, d};
      const pa_idx *hit = bsearch(&key, kept->order, (size_t)kept->n,
                                  sizeof *kept->order, cmp_key_pt);
      if (hit) lower(m, v, kept->gdim[*hit], kept->gtag[*hit]);
    }
  for (pa_idx v = 0; v < m->nv; v++)
    if (m->vgdim[v] == 255) m->vgdim[v] = (uint8_t)d; /* in no element */
}

/* ---- completion (pa_mesh_classify) ---- */

/* 1 if entity (dim, tag) lies in the closure of entity (fdim, ftag) of the
 * model's table (itself, or a boundary entity of it, recursively). */
static int in_closure(const pa_mesh *m, int fdim, int32_t ftag, int dim,
                      int32_t tag) {
  if (fdim == dim) return ftag == tag;
  if (fdim < dim) return 0;
  const pa__entity *f = pa__mesh_entity(m, fdim, ftag);
  if (!f) return 0;
  for (int k = 0; k < f->nbound; k++) {
    int32_t b = f->bound[k] < 0 ? -f->bound[k] : f->bound[k];
    if (in_closure(m, fdim - 1, b, dim, tag)) return 1;
  }
  return 0;
}

/* The entity of dimension kdim of a cell of n vertices v: the entity of a
 * vertex of that dimension (all such must agree), else the only entity of
 * the table whose closure holds every vertex's entity. *tag = 0 when
 * there is none, -1 when several are possible; the candidates are named
 * in buf. */
static void cell_entity(const pa_mesh *m, int kdim, const pa_idx *v, int n,
                        int32_t *tag, char *buf, size_t nbuf) {
  int32_t t = 0;
  buf[0] = '\0';
  for (int i = 0; i < n; i++) {
    if (m->vgdim[v[i]] != kdim) continue;
    if (t && t != m->vgtag[v[i]]) {
      snprintf(buf, nbuf, "its vertices lie on entities (%d, %d) and (%d, %d)",
               kdim, (int)t, kdim, (int)m->vgtag[v[i]]);
      *tag = -1;
      return;
    }
    t = m->vgtag[v[i]];
  }
  if (t) {
    *tag = t;
    return;
  }
  int found = 0;
  size_t len = 0;
  for (int k = 0; k < m->nent; k++) {
    const pa__entity *f = &m->ents[k];
    if (f->dim != kdim) continue;
    int all = 1;
    for (int i = 0; i < n && all; i++)
      all = m->vgdim[v[i]] < kdim &&
            in_closure(m, kdim, f->tag, m->vgdim[v[i]], m->vgtag[v[i]]);
    if (!all) continue;
    if (!found++) t = f->tag;
    if (len + 16 < nbuf)
      len += (size_t)snprintf(buf + len, nbuf - len, "%s(%d, %d)",
                              found > 1 ? ", " : "candidates ", kdim,
                              (int)f->tag);
  }
  if (!found) snprintf(buf, nbuf, "no entity of dimension %d holds all its "
                                  "vertices' entities", kdim);
  *tag = found == 1 ? t : found ? -1 : 0;
}

/* A message naming the entities of the n vertices v, into buf. */
static const char *vertex_entities(const pa_mesh *m, const pa_idx *v, int n,
                                   char *buf, size_t nbuf) {
  size_t len = 0;
  for (int i = 0; i < n && len + 40 < nbuf; i++)
    len += (size_t)snprintf(buf + len, nbuf - len, "%s%ld on (%d, %d)",
                            i ? ", " : "", (long)v[i] + 1, m->vgdim[v[i]],
                            (int)m->vgtag[v[i]]);
  return buf;
}

/* Cells of a kind whose reference is not positive take their entity. */
static pa_status infer_cells(pa_mesh *m, const char *what, pa_idx *conn,
                             int32_t *ref, pa_idx n, int nv, int kdim) {
  pa_status st = PA_SUCCESS;
  char why[256], vs[256];
  for (pa_idx c = 0; c < n; c++) {
    if (ref[c] > 0) continue;
    int32_t t;
    const pa_idx *v = conn + (size_t)nv * c;
    cell_entity(m, kdim, v, nv, &t, why, sizeof why);
    PA_CHECK(t > 0, PA_ERR_MESH,
             "%s %ld (vertices %s): cannot tell which model entity it lies "
             "on: %s",
             what, (long)c + 1, vertex_entities(m, v, nv, vs, sizeof vs),
             why);
    ref[c] = t;
  }
cleanup:
  return st;
}

/* The boundary faces and the faces between two elements of different
 * references that are not listed become boundary entities (reference 0:
 * infer_cells then names their entity). */
static pa_status add_faces(pa_mesh *m) {
  pa_status st = PA_SUCCESS;
  const pa_idx *adja;
  pa_idx *faces = NULL, nf = 0;
  size_t cap = 0;
  int d = m->dim;
  PA_CALL(pa_mesh_build_adjacency(m, &adja));
  for (pa_idx e = 0; e < m->ne; e++)
    for (int i = 0; i <= d; i++) {
      pa_idx o = adja[(size_t)(d + 1) * e + i];
      if (o >= 0 && (o / (d + 1) < e || m->eref[o / (d + 1)] == m->eref[e]))
        continue;
      pa_idx f[3], idx;
      pa__elem_face(m, e, i, f);
      PA_CALL(pa_mesh_find_bdry(m, f, &idx));
      if (idx >= 0) continue;
      PA_GROW(faces, cap, (size_t)d * (nf + 1));
      memcpy(faces + (size_t)d * nf++, f, d * sizeof *f);
    }
  for (pa_idx k = 0; k < nf; k++)
    PA_CALL(pa_mesh_add_bdry(m, faces + (size_t)d * k, 0, NULL));
cleanup:
  pa__free(faces);
  return st;
}

/* An edge of a boundary triangle: ends a < b, the triangle's reference. */
typedef struct tedge {
  pa_idx a, b;
  int32_t ref;
} tedge;

static int cmp_tedge(const void *x, const void *y) {
  const tedge *p = x, *q = y;
  if (p->a != q->a) return p->a < q->a ? -1 : 1;
  if (p->b != q->b) return p->b < q->b ? -1 : 1;
  return (p->ref > q->ref) - (p->ref < q->ref);
}

/* The curve the edge (a, b) may lie on by its ends' entities: a curve both
 * lie on or bound (the only one, from the table, for two points); 0 for
 * none, -1 for several. */
static int32_t edge_curve(const pa_mesh *m, pa_idx a, pa_idx b) {
  int da = m->vgdim[a], db = m->vgdim[b];
  int32_t ta = m->vgtag[a], tb = m->vgtag[b];
  if (da > 1 || db > 1) return 0;
  if (da == 1 && db == 1) return ta == tb ? ta : 0;
  if (da == 1 || db == 1) {
    int32_t c = da == 1 ? ta : tb, p = da == 1 ? tb : ta;
    return !m->nent || in_closure(m, 1, c, 0, p) ? c : 0;
  }
  int32_t c = 0;
  int found = 0;
  for (int k = 0; k < m->nent; k++)
    if (m->ents[k].dim == 1 && in_closure(m, 1, m->ents[k].tag, 0, ta) &&
        in_closure(m, 1, m->ents[k].tag, 0, tb)) {
      c = m->ents[k].tag;
      found++;
    }
  return found == 1 ? c : found ? -1 : 0;
}

/* 1 if curve c bounds surface s on both sides (a seam: listed with both
 * signs among the surface's boundary curves). */
static int is_seam(const pa_mesh *m, int32_t s, int32_t c) {
  const pa__entity *f = pa__mesh_entity(m, 2, s);
  int plus = 0, minus = 0;
  for (int k = 0; f && k < f->nbound; k++) {
    plus |= f->bound[k] == c;
    minus |= f->bound[k] == -c;
  }
  return plus && minus;
}

/* 3D: every edge of the boundary triangles on a curve becomes a feature
 * edge of that curve: an edge between triangles of two surfaces, on the
 * open rim of a surface or where more than two meet must lie on a curve;
 * an edge inside one surface does when it runs along a seam of it. */
static pa_status add_curve_edges(pa_mesh *m) {
  pa_status st = PA_SUCCESS;
  tedge *te = NULL, *le = NULL;
  pa_idx *add = NULL, nadd = 0;
  size_t cap = 0, n = 0;
  char vs[256];
  PA_ALLOC(te, 3 * (size_t)m->nb);
  for (pa_idx k = 0; k < m->nb; k++)
    for (int i = 0; i < 3; i++) {
      pa_idx a = m->bdry[3 * (size_t)k + i], b = m->bdry[3 * (size_t)k + (i + 1) % 3];
      te[n++] = (tedge){a < b ? a : b, a < b ? b : a, m->bref[k]};
    }
  qsort(te, n, sizeof *te, cmp_tedge);
  /* the listed edges, sorted, to skip */
  PA_ALLOC(le, m->ned);
  for (pa_idx k = 0; k < m->ned; k++) {
    pa_idx a = m->edge[2 * (size_t)k], b = m->edge[2 * (size_t)k + 1];
    le[k] = (tedge){a < b ? a : b, a < b ? b : a, 0};
  }
  qsort(le, (size_t)m->ned, sizeof *le, cmp_tedge);
  for (size_t i = 0; i < n;) {
    size_t j = i + 1;
    while (j < n && te[j].a == te[i].a && te[j].b == te[i].b) j++;
    tedge key = {te[i].a, te[i].b, 0};
    if (!bsearch(&key, le, (size_t)m->ned, sizeof *le, cmp_tedge)) {
      int feature = j - i != 2 || te[i].ref != te[i + 1].ref;
      int32_t c = edge_curve(m, te[i].a, te[i].b);
      pa_idx ev[2] = {te[i].a, te[i].b};
      PA_CHECK(!feature || c > 0, PA_ERR_MESH,
               "the edge of vertices %s %s surfaces %d and %d but the "
               "vertices' entities name %s curve it lies on",
               vertex_entities(m, ev, 2, vs, sizeof vs),
               j - i == 2 ? "separates" : "borders", (int)te[i].ref,
               (int)te[j - 1].ref, c < 0 ? "more than one" : "no");
      if (c > 0 && (feature || is_seam(m, te[i].ref, c))) {
        PA_GROW(add, cap, 3 * ((size_t)nadd + 1));
        add[3 * nadd] = te[i].a;
        add[3 * nadd + 1] = te[i].b;
        add[3 * nadd++ + 2] = c;
      }
    }
    i = j;
  }
  for (pa_idx k = 0; k < nadd; k++)
    PA_CALL(pa_mesh_add_edge(m, add + 3 * k, add[3 * k + 2], NULL));
cleanup:
  pa__free(le);
  pa__free(te);
  pa__free(add);
  return st;
}

pa_status pa_mesh_classify(pa_mesh *m) {
  pa_status st = PA_SUCCESS;
  uint8_t *gd = NULL;
  int32_t *gt = NULL;
  pa__kept kept = {NULL, NULL, NULL, NULL, 0};
  int saved = 0;
  char vs[256];
  PA_CHECK(m, PA_ERR_ARG, "pa_mesh_classify: NULL mesh");
  PA_CHECK(m->vgdim, PA_ERR_ARG,
           "pa_mesh_classify: the mesh is not classified (its vertices have "
           "no model entities)");
  int d = m->dim;
  for (pa_idx v = 0; v < m->nv; v++)
    PA_CHECK(m->vgdim[v] <= d && (m->vgtag[v] > 0 || m->vgdim[v] == d),
             PA_ERR_MESH,
             "vertex %ld lies on model entity (%d, %d): the dimension must "
             "lie in [0, %d] and the tag be positive",
             (long)v + 1, m->vgdim[v], (int)m->vgtag[v], d);
  PA_CALL(infer_cells(m, "element", m->elem, m->eref, m->ne, d + 1, d));
  PA_CALL(add_faces(m));
  PA_CALL(infer_cells(m, "boundary entity", m->bdry, m->bref, m->nb, d,
                      d - 1));
  if (d == 3) {
    PA_CALL(infer_cells(m, "edge", m->edge, m->edref, m->ned, 2, 1));
    PA_CALL(add_curve_edges(m));
  }
  for (pa_idx v = 0; v < m->nv; v++)
    if (m->vgdim[v] == 0) {
      m->vflag[v] |= PA_FLAG_CORNER;
      m->vref[v] = m->vgtag[v];
    }
  /* the entities the cells give must agree with the vertices' */
  PA_CALL(pa__mesh_kept_points(m, NULL, &kept));
  PA_ALLOC(gd, m->nv);
  PA_ALLOC(gt, m->nv);
  if (m->nv) {
    memcpy(gd, m->vgdim, (size_t)m->nv);
    memcpy(gt, m->vgtag, (size_t)m->nv * sizeof *gt);
  }
  saved = 1;
  pa__mesh_derive_entities(m, &kept);
  for (pa_idx v = 0; v < m->nv; v++) {
    int dd = m->vgdim[v];
    int32_t dt = m->vgtag[v];
    /* a vertex the cells put higher (on a seam the table does not name)
     * keeps the cells' entity: the remeshers follow the cells */
    PA_CHECK(dd > gd[v] || (dd == gd[v] && dt == gt[v]) || dd == d,
             PA_ERR_MESH,
             "vertex %ld is on model entity (%d, %d) but its cells put it on "
             "(%d, %d)",
             (long)v + 1, gd[v], (int)gt[v], dd, (int)dt);
    if (dd == d && gd[v] < d) {
      pa_idx one = v;
      PA_FAIL(PA_ERR_MESH,
              "vertex %s is on no boundary entity nor curve of the mesh",
              vertex_entities(m, &one, 1, vs, sizeof vs));
    }
  }
cleanup:
  if (st && saved && m->nv) { /* the caller's entities back */
    memcpy(m->vgdim, gd, (size_t)m->nv);
    memcpy(m->vgtag, gt, (size_t)m->nv * sizeof *gt);
  }
  pa__free(gd);
  pa__free(gt);
  pa__kept_free(&kept);
  return st;
}

pa_status pa_mesh_set_vertex_entities(pa_mesh *m, const int *dims,
                                      const int32_t *tags) {
  pa_status st = PA_SUCCESS;
  int enabled = 0;
  PA_CHECK(m, PA_ERR_ARG, "pa_mesh_set_vertex_entities: NULL mesh");
  if (!dims) {
    pa__mesh_disable_entities(m);
    return PA_SUCCESS;
  }
  PA_CHECK(tags, PA_ERR_ARG, "pa_mesh_set_vertex_entities: NULL tags");
  for (pa_idx v = 0; v < m->nv; v++)
    PA_CHECK(dims[v] >= 0 && dims[v] <= m->dim &&
                 (tags[v] > 0 || dims[v] == m->dim),
             PA_ERR_ARG,
             "pa_mesh_set_vertex_entities: vertex %ld: entity (%d, %d) "
             "(dimension in [0, %d], tag > 0)",
             (long)v + 1, dims[v], (int)tags[v], m->dim);
  enabled = !m->vgdim;
  PA_CALL(pa__mesh_enable_entities(m));
  for (pa_idx v = 0; v < m->nv; v++) {
    m->vgdim[v] = (uint8_t)dims[v];
    m->vgtag[v] = tags[v];
  }
  PA_CALL(pa_mesh_classify(m));
cleanup:
  if (st && enabled) pa__mesh_disable_entities(m);
  return st;
}
