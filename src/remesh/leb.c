/*
 * leb.c -- longest-edge bisection of a simplex mesh in its metric: a fast,
 * shape-preserving refinement used before the built-in remesher's own passes
 * and to refine the skins of the parallel loop's pieces identically on both
 * sides (adapt/bisect.c).
 *
 * Edges are taken longest first (length in the metric; ties by the
 * coordinates of their ends) and split at their midpoint in every element
 * and boundary entity containing them; the new edges join the queue. The
 * new vertex gets the mean of the ends' fields and their interpolated
 * metric (pa__metric_interp), computed from the ends in coordinate order (so the same bits
 * wherever the same edge is split). The halves of a split element or
 * boundary entity keep its element or boundary field values (exact for a
 * piecewise-constant field: conservative and bounded).
 *
 *  - An edge of a boundary entity of reference o->skin_ref (a piece's skin)
 *    is split while longer than o->skin_lmax if o->skin_ok marks both its
 *    ends (1: inner; 2: labelled; 3: labelled, on a smooth curved
 *    boundary, a surface vertex), by these rules:
 *     . inner-inner, and inner-labelled: at the midpoint (an inner-labelled
 *       edge is interior or lies in the plane of the inner end's boundary
 *       faces). The new vertex is inner; if an end was labelled or so
 *       descended, in 3D it pairs with no hard labelled vertex.
 *       Otherwise
 *       a skin face whose longest edge cannot be split (two labelled
 *       vertices on the boundary: a ridge) would have its other edges
 *       bisected towards it without end, the apex sliding to the ridge (a
 *       denormal away after 1075 steps, on box3d 3). In 2D a skin face is
 *       that edge: nothing slides, and it pairs with any.
 *     . labelled-labelled: on a feature edge, never; inside the domain (a
 *       chord: o->on_boundary says no) at its midpoint, the new vertex
 *       inner and descended from a labelled one; on the boundary (every
 *       piece around such an edge has it on its skin, but only those at
 *       its ends hold a boundary face of it, so o->on_boundary decides
 *       from both ends' data, the same bits in every piece) only between
 *       two surface vertices, and only when o->normal gives their normals:
 *       at the midpoint of the cubic Hermite curve of the ends,
 *       x = (a + b) / 2 + ((e.nb) nb - (e.na) na) / 8 with e = b - a
 *       (exact on a plane, about h^4 / R^3 off a circle of radius R where
 *       the chord's midpoint is h^2 / 8R off), ends in canonical order.
 *       The new vertex is a surface vertex whose normal is the normalised
 *       sum of the ends', and the edges it makes with the ends, and with
 *       the other points of the input edge's curve, are on the boundary
 *       (o->on_boundary is asked only about input edges). o->on_boundary
 *       may err towards the boundary (a Bloom filter): two input surface
 *       vertices whose edge is not within PA_LEB_SMOOTH_DEG of both
 *       tangent planes, as every boundary edge between them is, are a
 *       chord.
 *    Termination: an edge never split joins two labelled vertices on the
 *    boundary (not two surface ones when curves are on), or a labelled
 *    vertex other than a surface one and an inner one descended from a
 *    labelled vertex. The vertices added on the faces around it so
 *    descend, and pair with one of its ends at most (the surface or the
 *    inner one): the apexes of those faces move towards that end, their
 *    edges to it halving.
 *    SKIN_MAX_DEPTH bounds the splits in a row all the same. With the
 *    longest edge first,
 *    the edge split is the longest of every skin face whose edges can all be
 *    split, so each such face is refined as by recursive longest-edge
 *    bisection of that face alone. In every case, whether a skin edge is
 *    split, where, and in which order, depends only on its length, its
 *    ends' coordinates, marks and normals: the result depends only on the
 *    face's vertices (a face with one or two splittable edges is cut by
 *    the bisections of those edges, in their own order). A point on a
 *    curve may leave an element of the shell without a positive volume (a
 *    thin element on the concave side): counted in *o->curve_bad, which
 *    the caller must treat as a failure of the whole refinement, since the
 *    other pieces, which see other elements, cannot know.
 *    In a classified mesh, a skin edge whose ends are both on the boundary
 *    (model entities of lower dimension) is not split: whether it lies on
 *    the model is known only where its boundary faces are.
 *  - Any other edge on a boundary entity or feature edge, or on a frozen
 *    element, is never split (the surface is the remesher's business).
 *  - Any other edge is split while longer than o->lmax, when no element
 *    around it has a longer edge: an element is bisected by its longest
 *    edge; otherwise elements on an unsplittable long edge would be
 *    bisected towards it without end. With o->vmin > 0, not when an element
 *    around it holds less metric volume than o->vmin: bisection halves an
 *    element's volume whichever edge it cuts, so it would make more
 *    elements there than the metric asks for. That happens where the mesh
 *    is finer than the metric in some direction and coarser in another (a
 *    strongly anisotropic metric on a mesh not aligned with it): each cut
 *    shortens the long direction and keeps the excess of the fine one, and
 *    the count grows with their product (box3d 6 in sizes 10, 10, 1e-4,
 *    where 850 elements are asked for: 45 M elements, 12 GB).
 * Bisection of a valid mesh stays valid and conforming: each element is cut
 * by a plane through an edge's midpoint and the opposite vertices.
 */
#include "remesh/leb.h"

#include <math.h>
#include <stdlib.h>

/* The elements (or boundary entities) of each vertex, as segments of one
 * pool: the initial mesh's lists are laid out by a counting pass, and a list
 * that outgrows its segment moves to the end of the pool with twice the room
 * (its old segment is left unused), so no vertex has an allocation of its
 * own. The order within a list (appends at the end; a deletion moves the
 * last entry into the hole) fixes the numbering of the entities that
 * split_cells adds. */
typedef struct ilist {
  size_t off; /* first entry in the pool */
  int n, cap;
} ilist;

typedef struct balls {
  ilist *l; /* per vertex */
  pa_idx *pool;
  size_t npool, cappool;
} balls;

static pa_status ball_add(balls *b, pa_idx v, pa_idx k) {
  pa_status st = PA_SUCCESS;
  ilist *l = &b->l[v];
  if (l->n == l->cap) {
    size_t cap = l->cap ? 2 * (size_t)l->cap : 8;
    if (l->off + (size_t)l->cap == b->npool) { /* the last segment: in place */
      PA_GROW(b->pool, b->cappool, l->off + cap);
    } else {
      PA_GROW(b->pool, b->cappool, b->npool + cap);
      memcpy(b->pool + b->npool, b->pool + l->off,
             (size_t)l->n * sizeof *b->pool);
      l->off = b->npool;
    }
    b->npool = l->off + cap;
    l->cap = (int)cap;
  }
  b->pool[l->off + (size_t)l->n++] = k;
cleanup:
  return st;
}

static void ball_del(balls *b, pa_idx v, pa_idx k) {
  ilist *l = &b->l[v];
  pa_idx *x = b->pool + l->off;
  for (int i = 0; i < l->n; i++)
    if (x[i] == k) {
      x[i] = x[--l->n];
      return;
    }
}

/* The lists of the ncell cells (nvc vertices each) of the initial mesh, each
 * in cell order, in segments of exactly their size. */
static pa_status balls_init(balls *b, const pa_idx *cell, pa_idx ncell, int nvc,
                            size_t nv) {
  pa_status st = PA_SUCCESS;
  size_t nent = (size_t)ncell * nvc, off = 0;
  for (size_t i = 0; i < nent; i++)
    b->l[cell[i]].cap++;
  for (size_t v = 0; v < nv; v++) {
    b->l[v].off = off;
    off += (size_t)b->l[v].cap;
  }
  PA_GROW(b->pool, b->cappool, off);
  b->npool = off;
  for (size_t i = 0; i < nent; i++) {
    ilist *l = &b->l[cell[i]];
    b->pool[l->off + (size_t)l->n++] = (pa_idx)(i / (size_t)nvc);
  }
cleanup:
  return st;
}

typedef struct qedge {
  double len;
  pa_idx a, b; /* canonical order: a before b by coordinates */
} qedge;

/* Marks of s->inner (see the file comment): inner, labelled, added on
 * the skin, descended from a labelled vertex (an inner vertex), with a
 * normal (a labelled vertex on a smooth curved boundary), on a feature
 * edge or a required boundary entity (a labelled vertex). */
#define M_INNER 1
#define M_LABELLED 2
#define M_ADDED 4
#define M_NOLAB 8
#define M_SURF 16
#define M_HARD 32
/* Skin splits in a row down from an input edge: far more than a
 * refinement needs (2^40 times shorter), so only a fault of the rules
 * (a face sliding towards an edge it cannot split) gets there; it stops
 * the sliding, the same way in every piece. */
#define SKIN_MAX_DEPTH 40

typedef struct bis {
  pa_mesh *m;
  const pa__leb_opts *o;
  int d;
  pa_idx nv0; /* input vertices */
  size_t nball; /* entries of eball.l, bball.l, inner, depth, nrm, curve */
  balls eball, bball;
  uint8_t *inner; /* per vertex: M_* marks */
  uint8_t *depth; /* per vertex: skin splits from the input down to it */
  double *nrm;    /* with o->normal, d per vertex: the normal of a vertex
                     marked M_SURF */
  pa_idx *curve;  /* with o->on_boundary, per vertex: the input edge (an
                     index into ends) on whose curve a vertex added on the
                     boundary lies, -1 for the others */
  pa_idx *ends;   /* 2 per such input edge */
  size_t nends, capends;
  pa_idx curve_bad;
  qedge *heap;
  size_t nheap, capheap;
  uint64_t *feat; /* feature edges as sorted (lo << 32 | hi) pairs */
  size_t nfeat;
  pa_idx *el, *fc; /* the elements and boundary entities around the edge
                      popped last */
  size_t capel, capfc;
  pa_idx *tmp; /* scratch of order_as_list, split_cells, longer_around */
  size_t captmp;
} bis;

/* Lexicographic comparison of the coordinates of vertices a and b. */
static int vcmp(const pa_mesh *m, pa_idx a, pa_idx b) {
  const double *x = m->coord + (size_t)m->dim * a,
               *y = m->coord + (size_t)m->dim * b;
  for (int k = 0; k < m->dim; k++)
    if (x[k] != y[k]) return x[k] < y[k] ? -1 : 1;
  return 0;
}

/* 1 if edge p comes before edge q: longer, or as long and smaller ends. */
static int qbefore(const pa_mesh *m, const qedge *p, const qedge *q) {
  if (p->len != q->len) return p->len > q->len;
  int c = vcmp(m, p->a, q->a);
  if (c) return c < 0;
  return vcmp(m, p->b, q->b) < 0;
}

/* Length of edge ab in the metric, from its ends in canonical order (the
 * same bits in every piece). */
static double elen(const pa_mesh *m, pa_idx a, pa_idx b) {
  if (vcmp(m, a, b) > 0) {
    pa_idx t = a;
    a = b;
    b = t;
  }
  int d = m->dim, nc = m->met_ncomp;
  return pa__edge_length(d, nc, m->coord + (size_t)d * a,
                         m->coord + (size_t)d * b, m->met + (size_t)nc * a,
                         m->met + (size_t)nc * b);
}

static pa_status push(bis *s, pa_idx a, pa_idx b) {
  pa_status st = PA_SUCCESS;
  const pa_mesh *m = s->m;
  if (vcmp(m, a, b) > 0) {
    pa_idx t = a;
    a = b;
    b = t;
  }
  double len = elen(m, a, b);
  /* the skin threshold only for an edge both of whose ends are marked (any
   * other edge that short is split neither as a skin nor as an inner edge,
   * and a piece has many inner edges between the two thresholds) */
  double lo = s->o->lmax;
  if (s->o->skin_ok && s->o->skin_lmax < lo && (s->inner[a] & 3) &&
      (s->inner[b] & 3))
    lo = s->o->skin_lmax;
  if (!(len > lo) || !isfinite(len)) return PA_SUCCESS;
  PA_GROW(s->heap, s->capheap, s->nheap + 1);
  size_t i = s->nheap++;
  qedge e = {len, a, b};
  while (i > 0 && qbefore(m, &e, &s->heap[(i - 1) / 2])) {
    s->heap[i] = s->heap[(i - 1) / 2];
    i = (i - 1) / 2;
  }
  s->heap[i] = e;
cleanup:
  return st;
}

static qedge pop(bis *s) {
  qedge top = s->heap[0], e = s->heap[--s->nheap];
  size_t i = 0, n = s->nheap;
  for (;;) {
    size_t c = 2 * i + 1;
    if (c >= n) break;
    if (c + 1 < n && qbefore(s->m, &s->heap[c + 1], &s->heap[c])) c++;
    if (!qbefore(s->m, &s->heap[c], &e)) break;
    s->heap[i] = s->heap[c];
    i = c;
  }
  if (n) s->heap[i] = e;
  return top;
}

static int cmp_u64(const void *p, const void *q) {
  uint64_t a = *(const uint64_t *)p, b = *(const uint64_t *)q;
  return (a > b) - (a < b);
}

static uint64_t pair_key(pa_idx a, pa_idx b) {
  return a < b ? ((uint64_t)a << 32) | (uint32_t)b
               : ((uint64_t)b << 32) | (uint32_t)a;
}

/* 1 if ab is a feature edge of the input (those are never split). */
static int is_feature(const bis *s, pa_idx a, pa_idx b) {
  uint64_t k = pair_key(a, b);
  return s->nfeat && bsearch(&k, s->feat, s->nfeat, sizeof k, cmp_u64) != NULL;
}

static int has(const pa_idx *v, int n, pa_idx x) {
  for (int k = 0; k < n; k++)
    if (v[k] == x) return 1;
  return 0;
}

/* The ball lists grow with the vertices. */
static pa_status grow_balls(bis *s, size_t nv) {
  pa_status st = PA_SUCCESS;
  if (nv <= s->nball) return PA_SUCCESS;
  size_t n = s->nball ? 2 * s->nball : 64;
  if (n < nv) n = nv;
  ilist *e = pa__realloc(s->eball.l, n * sizeof *e);
  PA_CHECK(e, PA_ERR_MEMORY, "out of memory in longest-edge bisection");
  s->eball.l = e;
  ilist *b = pa__realloc(s->bball.l, n * sizeof *b);
  PA_CHECK(b, PA_ERR_MEMORY, "out of memory in longest-edge bisection");
  s->bball.l = b;
  uint8_t *in = pa__realloc(s->inner, n);
  PA_CHECK(in, PA_ERR_MEMORY, "out of memory in longest-edge bisection");
  s->inner = in;
  uint8_t *dp = pa__realloc(s->depth, n);
  PA_CHECK(dp, PA_ERR_MEMORY, "out of memory in longest-edge bisection");
  s->depth = dp;
  memset(s->depth + s->nball, 0, n - s->nball);
  if (s->o->normal) {
    double *x = pa__realloc(s->nrm, n * (size_t)s->d * sizeof *x);
    PA_CHECK(x, PA_ERR_MEMORY, "out of memory in longest-edge bisection");
    s->nrm = x;
  }
  if (s->o->on_boundary) {
    pa_idx *c = pa__realloc(s->curve, n * sizeof *c);
    PA_CHECK(c, PA_ERR_MEMORY, "out of memory in longest-edge bisection");
    s->curve = c;
    for (size_t v = s->nball; v < n; v++) c[v] = -1;
  }
  memset(s->eball.l + s->nball, 0, (n - s->nball) * sizeof *e);
  memset(s->bball.l + s->nball, 0, (n - s->nball) * sizeof *b);
  memset(s->inner + s->nball, 0, n - s->nball);
  s->nball = n;
cleanup:
  return st;
}

/* Put the n cells c of vertex a (elements, or faces) in the order of its
 * list, which fixes the numbering of the cells split_cells adds. */
static pa_status order_as_list(bis *s, const balls *ball, pa_idx a, pa_idx *c,
                               int n) {
  pa_status st = PA_SUCCESS;
  const ilist *l = &ball->l[a];
  int k = 0;
  if (n < 2) return PA_SUCCESS;
  PA_GROW(s->tmp, s->captmp, (size_t)n);
  for (int q = 0; q < l->n && k < n; q++)
    if (has(c, n, ball->pool[l->off + (size_t)q]))
      s->tmp[k++] = ball->pool[l->off + (size_t)q];
  memcpy(c, s->tmp, (size_t)n * sizeof *c);
cleanup:
  return st;
}

/* Split the n cells c (elements: nvc = d + 1, or faces: nvc = d) around
 * edge ab, in the order of the list of a: each keeps b with m for a and a
 * copy keeps a with m for b. The new edges of split elements are queued,
 * each once (the queue order does not depend on the order of pushes, and a
 * second copy of an edge would only be popped and judged again). */
static pa_status split_cells(bis *s, int faces, pa_idx a, pa_idx b, pa_idx mid,
                             const pa_idx *c, int n) {
  pa_status st = PA_SUCCESS;
  pa_mesh *m = s->m;
  int nvc = faces ? s->d : s->d + 1, nfar = 0;
  balls *ball = faces ? &s->bball : &s->eball;
  /* the far ends of the new edges */
  PA_GROW(s->tmp, s->captmp, (size_t)n * (size_t)(nvc - 2) + 1);
  pa_idx *far = s->tmp;
  for (int q = 0; q < n; q++) {
    pa_idx k = c[q], k2;
    pa_idx *cv = (faces ? m->bdry : m->elem) + (size_t)nvc * k;
    pa_idx v2[4];
    for (int j = 0; j < nvc; j++)
      v2[j] = cv[j] == b ? mid : cv[j];
    if (faces) {
      PA_CALL(pa_mesh_add_bdry(m, v2, m->bref[k], &k2));
      m->bflag[k2] = m->bflag[k];
      pa__mesh_copy_values(m, PA_BOUNDARY, k, k2); /* halves keep the values */
      cv = m->bdry + (size_t)nvc * k; /* the arrays may have moved */
    } else {
      PA_CALL(pa_mesh_add_elem(m, v2, m->eref[k], &k2));
      m->eflag[k2] = m->eflag[k];
      pa__mesh_copy_values(m, PA_ELEMENT, k, k2);
      cv = m->elem + (size_t)nvc * k;
    }
    for (int j = 0; j < nvc; j++)
      if (cv[j] == a) cv[j] = mid;
    ball_del(ball, a, k);
    PA_CALL(ball_add(ball, a, k2));
    PA_CALL(ball_add(ball, mid, k));
    PA_CALL(ball_add(ball, mid, k2));
    for (int j = 0; j < nvc; j++)
      if (v2[j] != mid && v2[j] != a) {
        PA_CALL(ball_add(ball, v2[j], k2));
        if (!faces && !has(far, nfar, v2[j])) far[nfar++] = v2[j];
      }
  }
  for (int j = 0; j < nfar; j++)
    PA_CALL(push(s, mid, far[j]));
cleanup:
  return st;
}

/* 1 if edge xy comes before edge e in the queue order. */
static int before(const pa_mesh *m, pa_idx x, pa_idx y, const qedge *e) {
  qedge f = {0, x, y};
  if (vcmp(m, x, y) > 0) {
    f.a = y;
    f.b = x;
  }
  f.len = elen(m, f.a, f.b);
  return qbefore(m, &f, e);
}

/* 1 if one of the nel elements el (those containing edge e) has another
 * edge before e in the queue order (longer, or as long with smaller ends).
 * The edges from the ends of e to a far vertex are in two elements each:
 * they are judged once per far vertex, listed in far (room for
 * nel * (d - 1)). */
static int longer_around(const bis *s, const qedge *e, const pa_idx *el,
                         int nel, pa_idx *far) {
  const pa_mesh *m = s->m;
  int nve = s->d + 1, nfar = 0;
  for (int q = 0; q < nel; q++) {
    const pa_idx *v = m->elem + (size_t)nve * el[q];
    pa_idx c[2];
    int nc = 0;
    for (int i = 0; i < nve; i++)
      if (v[i] != e->a && v[i] != e->b) c[nc++] = v[i];
    if (nc == 2 && before(m, c[0], c[1], e)) return 1;
    for (int i = 0; i < nc; i++)
      if (!has(far, nfar, c[i])) far[nfar++] = c[i];
  }
  for (int i = 0; i < nfar; i++)
    if (before(m, e->a, far[i], e) || before(m, e->b, far[i], e)) return 1;
  return 0;
}

/* A size field's metric volume of element e, as pa__elem_complexity
 * gives it up to rounding (h^-dim as a product rather than pow, which
 * costs most of it): where it is not within LEB_VMIN_SURE of the bound,
 * its side of the bound is the exact value's. */
#define LEB_VMIN_SURE 1e-9
static double size_volume(const pa_mesh *m, pa_idx e) {
  int d = m->dim, nve = d + 1;
  const pa_idx *v = m->elem + (size_t)nve * e;
  const double *x[4];
  double s = 0;
  for (int k = 0; k < nve; k++) {
    double h = m->met[v[k]];
    x[k] = m->coord + (size_t)d * v[k];
    s += 1.0 / (d == 3 ? h * h * h : h * h);
  }
  return fabs(pa__simplex_volume(d, x)) * s / nve;
}

/* 1 if one of the nel elements el holds less metric volume than o->vmin. */
static int small_around(const bis *s, const pa_idx *el, int nel) {
  const pa_mesh *m = s->m;
  double vmin = s->o->vmin;
  for (int q = 0; q < nel; q++) {
    if (m->met_ncomp == 1 && size_volume(m, el[q]) > vmin * (1 + LEB_VMIN_SURE))
      continue;
    if (pa__elem_complexity(m, m->met_ncomp, m->met, el[q]) < vmin) return 1;
  }
  return 0;
}

/* The state of a refinement of s->m (s->m, s->o, s->d set): the skin marks,
 * the sorted feature edges, the vertex balls of the elements and of the
 * boundary entities, and every edge queued once. */
static pa_status start(bis *s) {
  pa_status st = PA_SUCCESS;
  pa_mesh *m = s->m;
  const pa__leb_opts *o = s->o;
  pa_idx nv0 = m->nv, *seen = NULL;
  s->nv0 = nv0;
  PA_CALL(grow_balls(s, (size_t)nv0));
  if (o->skin_ok)
    for (pa_idx v = 0; v < nv0; v++)
      s->inner[v] = o->skin_ok[v] == 4   ? M_LABELLED | M_HARD
                    : o->skin_ok[v] != 3 ? o->skin_ok[v] & 3
                    : o->normal          ? M_LABELLED | M_SURF
                                         : M_LABELLED;
  if (o->normal)
    memcpy(s->nrm, o->normal, (size_t)nv0 * (size_t)s->d * sizeof *s->nrm);
  if (m->ned) {
    PA_ALLOC(s->feat, m->ned);
    for (pa_idx r = 0; r < m->ned; r++)
      s->feat[r] = pair_key(m->edge[2 * (size_t)r], m->edge[2 * (size_t)r + 1]);
    s->nfeat = (size_t)m->ned;
    qsort(s->feat, s->nfeat, sizeof *s->feat, cmp_u64);
  }
  PA_CALL(balls_init(&s->eball, m->elem, m->ne, s->d + 1, (size_t)nv0));
  PA_CALL(balls_init(&s->bball, m->bdry, m->nb, s->d, (size_t)nv0));
  /* queue each edge once (an edge is in several elements): those of a to
   * its later neighbours b, found in its ball; seen[b] == a marks b done */
  PA_ALLOC(seen, nv0);
  for (pa_idx v = 0; v < nv0; v++)
    seen[v] = -1;
  for (pa_idx a = 0; a < nv0; a++) {
    const ilist *l = &s->eball.l[a];
    for (int q = 0; q < l->n; q++) {
      const pa_idx *v =
          m->elem + (size_t)(s->d + 1) * s->eball.pool[l->off + (size_t)q];
      for (int j = 0; j <= s->d; j++)
        if (v[j] > a && seen[v[j]] != a) {
          seen[v[j]] = a;
          PA_CALL(push(s, a, v[j]));
        }
    }
  }
cleanup:
  pa__free(seen);
  return st;
}

/* 1 if the edge uv between two labelled vertices lies on the boundary
 * (see the file comment): two input vertices as o->on_boundary says; else
 * both on one input edge's curve (a point of it and one of its ends, or
 * two of its points). */
static int on_boundary(const bis *s, pa_idx u, pa_idx v) {
  pa_idx cu = s->curve ? s->curve[u] : -1, cv = s->curve ? s->curve[v] : -1;
  if (cu < 0 && cv < 0)
    return s->o->on_boundary && s->o->on_boundary(s->o->ctx, u, v);
  if (cu >= 0 && cv >= 0) return cu == cv;
  pa_idx c = cu >= 0 ? cu : cv, w = cu >= 0 ? v : u;
  return s->ends[2 * c] == w || s->ends[2 * c + 1] == w;
}

/* The normal of vertex v (with o->normal, of a vertex marked M_SURF), or
 * NULL. */
static const double *vnormal(const bis *s, pa_idx v) {
  return (s->inner[v] & M_SURF) ? s->nrm + (size_t)s->d * v : NULL;
}

/* 1 if the edge e = ab lies within PA_LEB_SMOOTH_DEG of the tangent planes
 * of those of its ends that have a normal. */
static int tangent(const bis *s, const qedge *e) {
  const double *xa = s->m->coord + (size_t)s->d * e->a,
               *xb = s->m->coord + (size_t)s->d * e->b;
  const double *na = vnormal(s, e->a), *nb = vnormal(s, e->b);
  double ea = 0, eb = 0, ee = 0, sn = sin(PA_LEB_SMOOTH_DEG * M_PI / 180);
  for (int k = 0; k < s->d; k++) {
    double c = xb[k] - xa[k];
    ea += na ? c * na[k] : 0;
    eb += nb ? c * nb[k] : 0;
    ee += c * c;
  }
  return ea * ea <= sn * sn * ee && eb * eb <= sn * sn * ee;
}

/* How the skin edge e, whose ends are marked ia and ib (M_INNER or
 * M_LABELLED each), is split (see the file comment): 0 at its midpoint, 1
 * on its curve, -1 not at all. bnd: a boundary entity of the mesh (not of
 * the skin) or a feature edge holds it; feat: a feature edge. */
static int skin_split(bis *s, const qedge *e, int ia, int ib, int bnd,
                      int feat) {
  int la = ia & M_LABELLED, lb = ib & M_LABELLED;
  if (!la && !lb) return 0;
  if (!la || !lb) { /* an inner end, descended from a labelled vertex or not */
    int in = la ? ib : ia, lab = la ? ia : ib;
    return s->d == 3 && (in & M_NOLAB) && (lab & M_HARD) ? -1 : 0;
  }
  if (feat) return -1;
  if (!on_boundary(s, e->a, e->b)) {
    /* a chord; with bnd, cannot be (on_boundary has no false negative): a
     * failure, and no split, which the other pieces would not know of */
    if (bnd) s->curve_bad++;
    return bnd ? -1 : 0;
  }
  if ((ia | ib) & M_HARD) return -1;
  /* two input vertices whose masks meet: a chord, unless the edge lies
   * within PA_LEB_SMOOTH_DEG of the tangent planes of those with a normal,
   * as every boundary edge of theirs does */
  if (s->curve[e->a] < 0 && s->curve[e->b] < 0 && !tangent(s, e)) return 0;
  return 1;
}

/* The point halfway along the boundary edge e (ends in canonical order)
 * into x (see the file comment): on the cubic Hermite curve of the ends'
 * normals, an end without one taking the other's mirrored in the plane
 * that bisects e (as on a circle), or the midpoint when neither has one;
 * the normalised sum of the two normals into n. Returns the number of
 * normals the ends have. */
static int curve_point(const bis *s, const qedge *e, double *x, double *n) {
  int d = s->d;
  const double *xa = s->m->coord + (size_t)d * e->a,
               *xb = s->m->coord + (size_t)d * e->b;
  const double *na = vnormal(s, e->a), *nb = vnormal(s, e->b);
  double ma[3], mb[3], ev[3], ee = 0, ea = 0, eb = 0, nn = 0;
  int got = (na != NULL) + (nb != NULL);
  for (int k = 0; k < d; k++) {
    ev[k] = xb[k] - xa[k];
    ee += ev[k] * ev[k];
  }
  if (got == 1) { /* the mirror image of the one normal */
    const double *g = na ? na : nb;
    double *h = na ? mb : ma, c = 0;
    for (int k = 0; k < d; k++) c += g[k] * ev[k];
    for (int k = 0; k < d; k++) h[k] = g[k] - 2 * c * ev[k] / ee;
    if (!na) na = ma;
    if (!nb) nb = mb;
  }
  for (int k = 0; k < d; k++) {
    x[k] = 0.5 * xa[k] + 0.5 * xb[k];
    n[k] = 0;
  }
  if (!got) return 0;
  for (int k = 0; k < d; k++) {
    ea += ev[k] * na[k];
    eb += ev[k] * nb[k];
  }
  for (int k = 0; k < d; k++) {
    x[k] += (eb * nb[k] - ea * na[k]) / 8;
    n[k] = na[k] + nb[k];
    nn += n[k] * n[k];
  }
  nn = sqrt(nn);
  for (int k = 0; k < d && nn > 0; k++) n[k] /= nn;
  return got;
}

/* 1 if an element around vertex v has no positive volume (exactly). */
static int flat_around(const bis *s, pa_idx v) {
  const pa_mesh *m = s->m;
  const ilist *l = &s->eball.l[v];
  for (int q = 0; q < l->n; q++) {
    const pa_idx *ev = m->elem + (size_t)(s->d + 1) * s->eball.pool[l->off + (size_t)q];
    const double *x[4];
    for (int j = 0; j <= s->d; j++) x[j] = m->coord + (size_t)s->d * ev[j];
    if (!(pa__orient(s->d, x) > 0)) return 1;
  }
  return 0;
}

/* The vertex *mid at the midpoint of e (on its curve when curve = 1), from
 * the ends in canonical order, with their metric and fields interpolated,
 * and its skin mark: a vertex added on the skin is inner, on a curve
 * M_SURF; descended from a labelled vertex, an inner one never pairs with
 * a labelled vertex (see the file comment). */
static pa_status add_midpoint(bis *s, const qedge *e, int skin, int curve,
                              pa_idx *mid, int *moved) {
  pa_status st = PA_SUCCESS;
  pa_mesh *m = s->m;
  double x[3], n[3];
  const double *xa = m->coord + (size_t)s->d * e->a,
               *xb = m->coord + (size_t)s->d * e->b;
  *moved = 0;
  if (curve)
    *moved = curve_point(s, e, x, n);
  else
    for (int k = 0; k < s->d; k++)
      x[k] = 0.5 * xa[k] + 0.5 * xb[k];
  PA_CALL(pa_mesh_add_vertex(m, x, 0, mid));
  PA_CALL(grow_balls(s, (size_t)m->nv));
  if (m->met_ncomp) {
    int nc = m->met_ncomp;
    const double *mm[2] = {m->met + (size_t)nc * e->a,
                           m->met + (size_t)nc * e->b};
    const double w[2] = {0.5, 0.5};
    pa__metric_interp(s->d, nc, 2, mm, w, m->met + (size_t)nc * *mid);
  }
  for (int f = 0; f < m->nfield; f++) {
    int nc = m->field[f].ncomp;
    double *y = m->field[f].val;
    const double *yy[2] = {y + (size_t)nc * e->a, y + (size_t)nc * e->b};
    const double w[2] = {0.5, 0.5};
    pa__field_interp(s->d, nc, pa__field_is_metric(s->d, m->field[f].name, nc),
                     2, yy, w, y + (size_t)nc * *mid);
  }
  if (curve) {
    s->inner[*mid] = (uint8_t)(M_LABELLED | M_ADDED | (*moved ? M_SURF : 0));
    if (*moved) memcpy(s->nrm + (size_t)s->d * *mid, n, (size_t)s->d * sizeof *n);
    pa_idx c = s->curve[e->a] >= 0 ? s->curve[e->a] : s->curve[e->b];
    if (c < 0) { /* a new input edge */
      PA_GROW(s->ends, s->capends, 2 * s->nends + 2);
      s->ends[2 * s->nends] = e->a;
      s->ends[2 * s->nends + 1] = e->b;
      c = (pa_idx)s->nends++;
    }
    s->curve[*mid] = c;
  } else {
    int lab = (s->inner[e->a] | s->inner[e->b]) & (M_LABELLED | M_NOLAB);
    s->inner[*mid] = skin ? (uint8_t)(M_INNER | M_ADDED | (lab ? M_NOLAB : 0)) : 0;
  }
  if (skin) {
    int da = s->depth[e->a], db = s->depth[e->b];
    s->depth[*mid] = (uint8_t)((da > db ? da : db) + 1);
  }
cleanup:
  return st;
}

pa_status pa__leb_refine(pa_mesh *m, const pa__leb_opts *o, pa_idx **parentp,
                         uint8_t **onskinp) {
  pa_status st = PA_SUCCESS;
  bis s;
  pa_idx nv0 = m->nv;
  size_t capp = 0, np = 0;
  pa_idx *parent = NULL;
  memset(&s, 0, sizeof s);
  s.m = m;
  s.o = o;
  s.d = m->dim;
  if (parentp) *parentp = NULL;
  if (onskinp) *onskinp = NULL;
  PA_CALL(start(&s));
  while (s.nheap) {
    qedge e = pop(&s);
    /* the elements around e, from the smaller ball (none if e is gone:
     * skip it); note a frozen one */
    int nel = 0, nfc = 0, frozen = 0;
    int esw = s.eball.l[e.b].n < s.eball.l[e.a].n;
    const ilist *eb = &s.eball.l[esw ? e.b : e.a];
    pa_idx other = esw ? e.a : e.b;
    PA_GROW(s.el, s.capel, (size_t)eb->n);
    for (int q = 0; q < eb->n; q++) {
      pa_idx k = s.eball.pool[eb->off + (size_t)q];
      if (!has(m->elem + (size_t)(s.d + 1) * k, s.d + 1, other)) continue;
      s.el[nel++] = k;
      frozen |= (m->eflag[k] & PA_FLAG_REQUIRED) != 0;
    }
    if (!nel || frozen) continue;
    /* the boundary entities around e */
    int skin = 0, bnd = 0;
    int bsw = s.bball.l[e.b].n < s.bball.l[e.a].n;
    const ilist *bb = &s.bball.l[bsw ? e.b : e.a];
    other = bsw ? e.a : e.b;
    PA_GROW(s.fc, s.capfc, (size_t)bb->n);
    for (int q = 0; q < bb->n; q++) {
      pa_idx r = s.bball.pool[bb->off + (size_t)q];
      if (!has(m->bdry + (size_t)s.d * r, s.d, other)) continue;
      s.fc[nfc++] = r;
      if (o->skin_ok && m->bref[r] == o->skin_ref)
        skin = 1;
      else
        bnd = 1;
    }
    int feat = is_feature(&s, e.a, e.b), curve = 0;
    bnd |= feat;
    PA_GROW(s.tmp, s.captmp, (size_t)nel * (size_t)(s.d - 1)); /* far */
    if (skin) {
      int ia = s.inner[e.a], ib = s.inner[e.b];
      if (!(ia & 3) || !(ib & 3) || !(e.len > o->skin_lmax)) continue;
      if (s.depth[e.a] >= SKIN_MAX_DEPTH || s.depth[e.b] >= SKIN_MAX_DEPTH)
        continue;
      /* a classified mesh: a skin edge between two boundary vertices may
       * lie on the model, which only the pieces holding its boundary faces
       * know; it stays (both sides decide alike from the vertices) */
      if (m->vgdim && m->vgdim[e.a] < s.d && m->vgdim[e.b] < s.d) continue;
      curve = skin_split(&s, &e, ia, ib, bnd, feat);
      if (curve < 0) continue;
    } else if (bnd || !(e.len > o->lmax) ||
               longer_around(&s, &e, s.el, nel, s.tmp) ||
               (o->vmin > 0 && m->met_ncomp && small_around(&s, s.el, nel))) {
      continue;
    }
    pa_idx mid;
    int moved;
    PA_CALL(add_midpoint(&s, &e, skin, curve, &mid, &moved));
    if (m->vgdim) m->vgtag[mid] = m->eref[s.el[0]]; /* inside a volume */
    PA_GROW(parent, capp, 2 * (np + 1));
    parent[2 * np] = e.a;
    parent[2 * np + 1] = e.b;
    np++;
    /* split_cells takes the cells in the order of the lists of e.a */
    if (esw) PA_CALL(order_as_list(&s, &s.eball, e.a, s.el, nel));
    if (bsw) PA_CALL(order_as_list(&s, &s.bball, e.a, s.fc, nfc));
    PA_CALL(split_cells(&s, 0, e.a, e.b, mid, s.el, nel));
    PA_CALL(split_cells(&s, 1, e.a, e.b, mid, s.fc, nfc));
    /* a split at the midpoint keeps every volume positive: only those on
     * the curve need a look, at the elements they make */
    if (moved && flat_around(&s, mid)) s.curve_bad++;
    PA_CALL(push(&s, e.a, mid));
    PA_CALL(push(&s, mid, e.b));
  }
  if (onskinp && m->nv > nv0) {
    PA_ALLOC(*onskinp, (size_t)(m->nv - nv0));
    for (pa_idx v = nv0; v < m->nv; v++)
      (*onskinp)[v - nv0] = !(s.inner[v] & M_ADDED) ? 0
                            : (s.inner[v] & M_SURF) ? 2
                                                    : 1;
  }
  if (o->curve_bad) *o->curve_bad = s.curve_bad;

  if (parentp) {
    *parentp = parent;
    parent = NULL;
  }
cleanup:
  pa__free(s.eball.l);
  pa__free(s.eball.pool);
  pa__free(s.bball.l);
  pa__free(s.bball.pool);
  pa__free(s.el);
  pa__free(s.fc);
  pa__free(s.tmp);
  pa__free(s.inner);
  pa__free(s.depth);
  pa__free(s.nrm);
  pa__free(s.curve);
  pa__free(s.ends);
  pa__free(s.heap);
  pa__free(s.feat);
  pa__free(parent);
  return st;
}
