/*
 * leb.c -- longest-edge bisection of a simplex mesh in its metric: a fast,
 * shape-preserving refinement used before the built-in remesher's own passes
 * and to refine the skins of the parallel loop's pieces identically on both
 * sides (adapt/bisect.c).
 *
 * Edges are taken longest first (length in the metric; ties by the
 * coordinates of their ends) and split at their midpoint in every element
 * and boundary entity containing them; the new edges join the queue. The
 * new vertex gets the mean of the ends' fields and their log-Euclidean mean
 * metric, computed from the ends in coordinate order (so the same bits
 * wherever the same edge is split).
 *
 *  - An edge of a boundary entity of reference o->skin_ref (a piece's skin)
 *    is split while longer than o->skin_lmax if o->skin_ok marks both its
 *    ends, one of them with bit 0 (1: inner, any marked partner; 2:
 *    labelled, an inner partner only). A vertex added on such an edge is
 *    inner, but never pairs with a labelled vertex if an end was labelled
 *    or so descended: otherwise a skin face whose longest edge joins two
 *    labelled vertices (a ridge) would have its other edges bisected
 *    towards it without end, the apex sliding to the ridge (a denormal
 *    away after 1075 steps, on box3d 3). With the longest edge first,
 *    the edge split is the longest of every skin face whose edges can all be
 *    split, so each such face is refined as by recursive longest-edge
 *    bisection of that face alone. In every case, whether a skin edge is
 *    split, and in which order, depends only on its length, its ends'
 *    coordinates and marks: the result depends only on the face's vertices
 *    (a face with one or two splittable edges is cut by the bisections of
 *    those edges, in their own order).
 *  - Any other edge on a boundary entity or feature edge, or on a frozen
 *    element, is never split (the surface is the remesher's business).
 *  - Any other edge is split while longer than o->lmax, when no element
 *    around it has a longer edge: an element is bisected by its longest
 *    edge; otherwise elements on an unsplittable long edge would be
 *    bisected towards it without end.
 * Bisection of a valid mesh stays valid and conforming: each element is cut
 * by a plane through an edge's midpoint and the opposite vertices.
 */
#include "remesh/leb.h"

#include <math.h>
#include <stdlib.h>

/* A growable list of entity indices (the elements or faces of a vertex). */
typedef struct ilist {
  pa_idx *x;
  int n, cap;
} ilist;

static pa_status ilist_add(ilist *l, pa_idx k) {
  pa_status st = PA_SUCCESS;
  if (l->n == l->cap) {
    int cap = l->cap ? 2 * l->cap : 8;
    pa_idx *x = pa__realloc(l->x, (size_t)cap * sizeof *x);
    PA_CHECK(x, PA_ERR_MEMORY, "out of memory in longest-edge bisection");
    l->x = x;
    l->cap = cap;
  }
  l->x[l->n++] = k;
cleanup:
  return st;
}

static void ilist_del(ilist *l, pa_idx k) {
  for (int i = 0; i < l->n; i++)
    if (l->x[i] == k) {
      l->x[i] = l->x[--l->n];
      return;
    }
}

typedef struct qedge {
  double len;
  pa_idx a, b; /* canonical order: a before b by coordinates */
} qedge;

typedef struct bis {
  pa_mesh *m;
  const pa__leb_opts *o;
  int d;
  size_t nball; /* entries of eball, bball, inner */
  ilist *eball, *bball;
  uint8_t *inner; /* per vertex: bit 0 inner (skin edges may be split
                     there), bit 1 labelled (only towards an inner vertex),
                     bit 2 added on the skin, bit 3 never with a labelled
                     partner */
  qedge *heap;
  size_t nheap, capheap;
  uint64_t *feat; /* feature edges as sorted (lo << 32 | hi) pairs */
  size_t nfeat;
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
  ilist *e = pa__realloc(s->eball, n * sizeof *e);
  PA_CHECK(e, PA_ERR_MEMORY, "out of memory in longest-edge bisection");
  s->eball = e;
  ilist *b = pa__realloc(s->bball, n * sizeof *b);
  PA_CHECK(b, PA_ERR_MEMORY, "out of memory in longest-edge bisection");
  s->bball = b;
  uint8_t *in = pa__realloc(s->inner, n);
  PA_CHECK(in, PA_ERR_MEMORY, "out of memory in longest-edge bisection");
  s->inner = in;
  memset(s->eball + s->nball, 0, (n - s->nball) * sizeof *e);
  memset(s->bball + s->nball, 0, (n - s->nball) * sizeof *b);
  memset(s->inner + s->nball, 0, n - s->nball);
  s->nball = n;
cleanup:
  return st;
}

/* Split the cells (elements: nvc = d + 1, or faces: nvc = d) of the list of
 * a that contain b: each keeps b with m for a and a copy keeps a with m for
 * b. The new edges of split elements are queued. */
static pa_status split_cells(bis *s, int faces, pa_idx a, pa_idx b,
                             pa_idx mid) {
  pa_status st = PA_SUCCESS;
  pa_mesh *m = s->m;
  int nvc = faces ? s->d : s->d + 1;
  ilist *ball = faces ? s->bball : s->eball;
  pa_idx *x = NULL;
  int n = ball[a].n;
  PA_ALLOC(x, n ? n : 1);
  if (n) memcpy(x, ball[a].x, (size_t)n * sizeof *x);
  for (int q = 0; q < n; q++) {
    pa_idx k = x[q], k2;
    pa_idx *cv = (faces ? m->bdry : m->elem) + (size_t)nvc * k;
    if (!has(cv, nvc, b)) continue;
    pa_idx v2[4];
    for (int j = 0; j < nvc; j++)
      v2[j] = cv[j] == b ? mid : cv[j];
    if (faces) {
      PA_CALL(pa_mesh_add_bdry(m, v2, m->bref[k], &k2));
      m->bflag[k2] = m->bflag[k];
      cv = m->bdry + (size_t)nvc * k; /* the arrays may have moved */
    } else {
      PA_CALL(pa_mesh_add_elem(m, v2, m->eref[k], &k2));
      m->eflag[k2] = m->eflag[k];
      cv = m->elem + (size_t)nvc * k;
    }
    for (int j = 0; j < nvc; j++)
      if (cv[j] == a) cv[j] = mid;
    ilist_del(&ball[a], k);
    PA_CALL(ilist_add(&ball[a], k2));
    PA_CALL(ilist_add(&ball[mid], k));
    PA_CALL(ilist_add(&ball[mid], k2));
    for (int j = 0; j < nvc; j++)
      if (v2[j] != mid && v2[j] != a) {
        PA_CALL(ilist_add(&ball[v2[j]], k2));
        if (!faces) PA_CALL(push(s, mid, v2[j]));
      }
  }
cleanup:
  pa__free(x);
  return st;
}

/* 1 if an element containing edge e has another edge before it in the
 * queue order (longer, or as long with smaller ends). */
static int longer_around(const bis *s, const qedge *e) {
  const pa_mesh *m = s->m;
  int nve = s->d + 1;
  /* the elements of the end with the smaller ball */
  int sw = s->eball[e->b].n < s->eball[e->a].n;
  const ilist *ball = &s->eball[sw ? e->b : e->a];
  pa_idx other = sw ? e->a : e->b;
  for (int q = 0; q < ball->n; q++) {
    const pa_idx *v = m->elem + (size_t)nve * ball->x[q];
    if (!has(v, nve, other)) continue;
    for (int i = 0; i < nve; i++)
      for (int j = i + 1; j < nve; j++) {
        qedge f = {0, v[i], v[j]};
        if ((f.a == e->a && f.b == e->b) || (f.a == e->b && f.b == e->a))
          continue;
        if (vcmp(m, f.a, f.b) > 0) {
          f.a = v[j];
          f.b = v[i];
        }
        f.len = elen(m, f.a, f.b);
        if (qbefore(m, &f, e)) return 1;
      }
  }
  return 0;
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
  PA_CALL(grow_balls(&s, (size_t)nv0));
  if (o->skin_ok)
    for (pa_idx v = 0; v < nv0; v++)
      s.inner[v] = o->skin_ok[v] & 3;
  if (m->ned) {
    PA_ALLOC(s.feat, m->ned);
    for (pa_idx r = 0; r < m->ned; r++)
      s.feat[r] = pair_key(m->edge[2 * (size_t)r], m->edge[2 * (size_t)r + 1]);
    s.nfeat = (size_t)m->ned;
    qsort(s.feat, s.nfeat, sizeof *s.feat, cmp_u64);
  }
  for (pa_idx e = 0; e < m->ne; e++)
    for (int j = 0; j <= s.d; j++)
      PA_CALL(ilist_add(&s.eball[m->elem[(size_t)(s.d + 1) * e + j]], e));
  for (pa_idx b = 0; b < m->nb; b++)
    for (int j = 0; j < s.d; j++)
      PA_CALL(ilist_add(&s.bball[m->bdry[(size_t)s.d * b + j]], b));
  for (pa_idx e = 0; e < m->ne; e++) {
    const pa_idx *v = m->elem + (size_t)(s.d + 1) * e;
    for (int i = 0; i <= s.d; i++)
      for (int j = i + 1; j <= s.d; j++)
        PA_CALL(push(&s, v[i], v[j]));
  }
  while (s.nheap) {
    qedge e = pop(&s);
    /* skip an edge queued twice and already split; note a frozen element */
    int live = 0, frozen = 0;
    int sw = s.eball[e.b].n < s.eball[e.a].n; /* the smaller ball */
    const ilist *eb = &s.eball[sw ? e.b : e.a];
    pa_idx other = sw ? e.a : e.b;
    for (int q = 0; q < eb->n; q++) {
      pa_idx k = eb->x[q];
      if (!has(m->elem + (size_t)(s.d + 1) * k, s.d + 1, other)) continue;
      live = 1;
      frozen |= (m->eflag[k] & PA_FLAG_REQUIRED) != 0;
    }
    if (!live || frozen) continue;
    int skin = 0, bnd = 0;
    sw = s.bball[e.b].n < s.bball[e.a].n;
    const ilist *bb = &s.bball[sw ? e.b : e.a];
    other = sw ? e.a : e.b;
    for (int q = 0; q < bb->n; q++) {
      pa_idx r = bb->x[q];
      if (!has(m->bdry + (size_t)s.d * r, s.d, other)) continue;
      if (o->skin_ok && m->bref[r] == o->skin_ref)
        skin = 1;
      else
        bnd = 1;
    }
    bnd |= is_feature(&s, e.a, e.b);
    if (skin) {
      int ia = s.inner[e.a], ib = s.inner[e.b];
      if (!(ia & 3) || !(ib & 3) || !(e.len > o->skin_lmax)) continue;
      if ((ia & 2) ? !(ib & 1) || (ib & 8) : (ib & 2) && (ia & 8)) continue;
    } else if (bnd || !(e.len > o->lmax) || longer_around(&s, &e)) {
      continue;
    }
    /* the midpoint, from the ends in canonical order */
    double x[3];
    const double *xa = m->coord + (size_t)s.d * e.a,
                 *xb = m->coord + (size_t)s.d * e.b;
    for (int k = 0; k < s.d; k++)
      x[k] = 0.5 * xa[k] + 0.5 * xb[k];
    pa_idx mid;
    PA_CALL(pa_mesh_add_vertex(m, x, 0, &mid));
    PA_CALL(grow_balls(&s, (size_t)m->nv));
    if (m->met_ncomp) {
      int nc = m->met_ncomp;
      const double *mm[2] = {m->met + (size_t)nc * e.a,
                             m->met + (size_t)nc * e.b};
      const double w[2] = {0.5, 0.5};
      pa__metric_interp(s.d, nc, 2, mm, w, m->met + (size_t)nc * mid);
    }
    for (int f = 0; f < m->nfield; f++) {
      int nc = m->field[f].ncomp;
      double *y = m->field[f].val;
      for (int c = 0; c < nc; c++)
        y[(size_t)nc * mid + c] =
            0.5 * y[(size_t)nc * e.a + c] + 0.5 * y[(size_t)nc * e.b + c];
    }
    /* a vertex added on the skin is inner; descended from a labelled
     * vertex, it never pairs with one (see the file comment) */
    s.inner[mid] =
        skin ? (uint8_t)(1 | 4 | ((s.inner[e.a] | s.inner[e.b]) & (2 | 8) ? 8 : 0))
             : 0;
    PA_GROW(parent, capp, 2 * (np + 1));
    parent[2 * np] = e.a;
    parent[2 * np + 1] = e.b;
    np++;
    PA_CALL(split_cells(&s, 0, e.a, e.b, mid));
    PA_CALL(split_cells(&s, 1, e.a, e.b, mid));
    PA_CALL(push(&s, e.a, mid));
    PA_CALL(push(&s, mid, e.b));
  }
  if (onskinp && m->nv > nv0) {
    PA_ALLOC(*onskinp, (size_t)(m->nv - nv0));
    for (pa_idx v = nv0; v < m->nv; v++)
      (*onskinp)[v - nv0] = (s.inner[v] & 4) != 0;
  }
  if (parentp) {
    *parentp = parent;
    parent = NULL;
  }
cleanup:
  for (size_t v = 0; v < s.nball; v++) {
    pa__free(s.eball[v].x);
    pa__free(s.bball[v].x);
  }
  pa__free(s.eball);
  pa__free(s.bball);
  pa__free(s.inner);
  pa__free(s.heap);
  pa__free(s.feat);
  pa__free(parent);
  return st;
}
