/*
 * transfer.c -- the element and boundary fields carried through a remesh:
 * pa_remesh keeps the input aside (the old mesh), lets the remesher run
 * without them, then gives the new mesh its fields here, whichever
 * remesher ran.
 *
 * Element fields are piecewise constant. The old and new elements are
 * intersected (a supermesh, built locally): each new element n is located
 * in the old mesh (a walk on the old adjacency from the last element
 * located, a bucket grid where the walk leaves the mesh), then
 *  - if its vertices all lie in one old element o (barycentric coordinates
 *    >= -INSIDE_TOL), n is inside o: one piece, the value is copied (the
 *    common case in refinement, and the case of elements given back
 *    unchanged);
 *  - otherwise a breadth-first search over the old elements across their
 *    faces, from the one holding n's centroid, clips n by each (triangle by
 *    triangle: Sutherland-Hodgman; tetrahedron by tetrahedron: plane by
 *    plane on a vertex graph of degree 3, Powell and Abel's r3d scheme)
 *    and goes on from every element of positive overlap: the elements
 *    overlapping a convex n are face-connected through such elements.
 * The pieces (old element, measure of the overlap) of every new element
 * are computed once (a CSR) and serve every field:
 *  - CONSERVATIVE: value = sum(w v) / sum(w) over the pieces, the mean of
 *    the old field over the part of n the old elements cover. Where the
 *    domain does not change the pieces of an old element sum to its
 *    measure, so the integral is kept to round-off; where the boundary
 *    moves (a curved boundary), a new element poking out takes the mean over
 *    its covered part (constants and bounds kept) and the change of the
 *    integral is measured (pa_transfer_report). An element of one piece, or
 *    whose pieces carry one value, gets that value exactly.
 *  - BOUNDED: CONSERVATIVE, then each value clamped to the range of the
 *    old values it overlaps [lo, hi], and the difference between the old
 *    integral and the new (the clamped round-off and, where the boundary
 *    moves, the change of domain) given to the elements with room: room
 *    (hi - v) vol (or (v - lo) vol) each, shared in proportion to it, so
 *    every value stays in its range; when the room does not suffice all of
 *    it is used and the rest is the measured defect. Feasible whenever the
 *    domain does not change: the projected values already lie in range.
 *  - NEAREST: the value of the old element of largest overlap (ties: the
 *    first found), so the set of values is kept.
 * A new element outside every old one takes the value of the old element
 * where its location ended (the nearest on the boundary).
 *
 * Boundary fields: each new boundary entity takes the values of the old
 * boundary entity of the same reference nearest to its centroid (a bucket
 * grid of the old boundary entities searched ring by ring); with no old
 * entity of that reference, the nearest of any.
 *
 * All geometry is computed in coordinates relative to a vertex of the new
 * element, so far from the origin the measures keep their relative
 * accuracy. The results do not depend on timing; the walk's random choices
 * come from a fixed seed.
 */
#include "remesh/remesh.h"

#include <float.h>
#include <math.h>

/* A vertex counts as inside an old element when its barycentric
 * coordinates are all above -INSIDE_TOL: points computed on an old face or
 * edge (midpoints), and the vertices of an element given back unchanged,
 * are off by ~1e-16; a poke this small leaves out at most a few 1e-14 of
 * the element's measure from the old one it pokes into (1e-12 let the
 * cube of bench/transfer.sh lose 1e-12 of its measure; 1e-14 sends 0.05 %
 * more of the rod's elements to the clipping). */
#define INSIDE_TOL 1e-14
/* Steps of a walk before the bucket grid takes over (a walk between
 * neighbours of consecutive new elements takes a few). */
#define WALK_MAX_STEPS 4096
/* Buckets of a grid per item (elements or boundary entities): about one
 * item per bucket where the mesh is even (each box meets a few buckets),
 * so a lookup tests a handful of items for a grid of the mesh's size. */
#define GRID_PER_ITEM 1.0

/* ---- bucket grid of boxes ---------------------------------------------- */

typedef struct grid {
  int dim;
  double lo[3], h[3];
  int n[3];
  size_t *start; /* buckets + 1 */
  pa_idx *item;
} grid;

static void grid_free(grid *g) {
  pa__free(g->start);
  pa__free(g->item);
  memset(g, 0, sizeof *g);
}

static int grid_coord(const grid *g, int k, double x) {
  double t = (x - g->lo[k]) / g->h[k];
  int i = t > 0 ? (int)t : 0;
  return i < g->n[k] ? i : g->n[k] - 1;
}

/* Bucket range [a, b] of box (lo, hi) along each axis. */
static void grid_range(const grid *g, const double *lo, const double *hi,
                       int *a, int *b) {
  for (int k = 0; k < g->dim; k++) {
    a[k] = grid_coord(g, k, lo[k]);
    b[k] = grid_coord(g, k, hi[k]);
  }
  for (int k = g->dim; k < 3; k++) a[k] = b[k] = 0;
}

static size_t grid_index(const grid *g, const int *c) {
  return (size_t)c[0] + (size_t)g->n[0] * ((size_t)c[1] + (size_t)g->n[1] * c[2]);
}

/* A grid of n boxes (box[2 dim i ..]: lo then hi), each filed in every
 * bucket it meets. */
static pa_status grid_build(grid *g, int dim, pa_idx n, const double *box) {
  pa_status st = PA_SUCCESS;
  double lo[3] = {DBL_MAX, DBL_MAX, DBL_MAX}, hi[3] = {-DBL_MAX, -DBL_MAX, -DBL_MAX};
  memset(g, 0, sizeof *g);
  g->dim = dim;
  for (pa_idx i = 0; i < n; i++)
    for (int k = 0; k < dim; k++) {
      lo[k] = fmin(lo[k], box[(size_t)2 * dim * i + k]);
      hi[k] = fmax(hi[k], box[(size_t)2 * dim * i + dim + k]);
    }
  double ext = 0, vol = 1;
  for (int k = 0; k < dim; k++) ext = fmax(ext, hi[k] - lo[k]);
  if (!(ext > 0)) ext = 1;
  for (int k = 0; k < dim; k++) vol *= fmax(hi[k] - lo[k], 1e-3 * ext);
  double cell = pow(vol / fmax(1.0, GRID_PER_ITEM * n), 1.0 / dim);
  size_t nb = 1;
  for (int k = 0; k < 3; k++) {
    g->lo[k] = k < dim ? lo[k] : 0;
    double len = k < dim ? fmax(hi[k] - lo[k], 1e-3 * ext) : 1;
    g->n[k] = k < dim ? (int)fmin(fmax(1.0, ceil(len / cell)), 1 << 20) : 1;
    g->h[k] = len / g->n[k];
    nb *= (size_t)g->n[k];
  }
  PA_CALLOC(g->start, nb + 1);
  for (int pass = 0; pass < 2; pass++) {
    for (pa_idx i = 0; i < n; i++) {
      int a[3], b[3], c[3];
      const double *bx = box + (size_t)2 * dim * i;
      grid_range(g, bx, bx + dim, a, b);
      for (c[2] = a[2]; c[2] <= b[2]; c[2]++)
        for (c[1] = a[1]; c[1] <= b[1]; c[1]++)
          for (c[0] = a[0]; c[0] <= b[0]; c[0]++) {
            size_t q = grid_index(g, c);
            if (pass == 0)
              g->start[q + 1]++;
            else
              g->item[g->start[q]++] = i;
          }
    }
    if (pass == 0) {
      for (size_t q = 0; q < nb; q++) g->start[q + 1] += g->start[q];
      PA_ALLOC(g->item, g->start[nb] ? g->start[nb] : 1);
    } else {
      for (size_t q = nb; q > 0; q--) g->start[q] = g->start[q - 1];
      g->start[0] = 0;
    }
  }
cleanup:
  if (st != PA_SUCCESS) grid_free(g);
  return st;
}

/* ---- geometry kernels -------------------------------------------------- */

/* Signed distance-like function of the face planes of a positive simplex
 * q (dim+1 points, dim coordinates each): s[i](p) >= 0 on the side of
 * vertex i of the face opposite it; s[i](q_i) = dim! |q|. */
typedef struct planes {
  double n[4][3], off[4];
} planes;

static void planes_of(int d, const double q[4][3], planes *P) {
  if (d == 2) {
    for (int i = 0; i < 3; i++) {
      const double *a = q[(i + 1) % 3], *b = q[(i + 2) % 3];
      /* left of a -> b (counter-clockwise triangles) */
      P->n[i][0] = -(b[1] - a[1]);
      P->n[i][1] = b[0] - a[0];
      P->n[i][2] = 0;
      P->off[i] = -(P->n[i][0] * a[0] + P->n[i][1] * a[1]);
    }
    return;
  }
  static const int fv[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  for (int i = 0; i < 4; i++) {
    const double *a = q[fv[i][0]], *b = q[fv[i][1]], *c = q[fv[i][2]];
    double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    double v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    /* inward: minus the outward normal u x v */
    P->n[i][0] = -(u[1] * v[2] - u[2] * v[1]);
    P->n[i][1] = -(u[2] * v[0] - u[0] * v[2]);
    P->n[i][2] = -(u[0] * v[1] - u[1] * v[0]);
    P->off[i] = -(P->n[i][0] * a[0] + P->n[i][1] * a[1] + P->n[i][2] * a[2]);
  }
}

static inline double plane_at(const planes *P, int i, const double *p, int d) {
  double s = P->off[i] + P->n[i][0] * p[0] + P->n[i][1] * p[1];
  return d == 3 ? s + P->n[i][2] * p[2] : s;
}

/* Area of the triangle y clipped by the half-planes P (Sutherland-Hodgman). */
static double clip2(const double y[4][3], const planes *P) {
  double a[12][2], b[12][2];
  int na = 3;
  for (int k = 0; k < 3; k++) a[k][0] = y[k][0], a[k][1] = y[k][1];
  for (int i = 0; i < 3 && na > 0; i++) {
    double s[12];
    int nb = 0;
    for (int k = 0; k < na; k++) s[k] = plane_at(P, i, a[k], 2);
    for (int k = 0; k < na; k++) {
      int l = (k + 1) % na;
      if (s[k] >= 0) b[nb][0] = a[k][0], b[nb][1] = a[k][1], nb++;
      if ((s[k] > 0 && s[l] < 0) || (s[k] < 0 && s[l] > 0)) {
        double t = s[k] / (s[k] - s[l]);
        b[nb][0] = a[k][0] + t * (a[l][0] - a[k][0]);
        b[nb][1] = a[k][1] + t * (a[l][1] - a[k][1]);
        nb++;
      }
    }
    na = nb;
    memcpy(a, b, sizeof(double) * 2 * nb);
  }
  double area = 0;
  for (int k = 0; k < na; k++) {
    int l = (k + 1) % na;
    area += a[k][0] * a[l][1] - a[l][0] * a[k][1];
  }
  return 0.5 * area;
}

/* A convex polyhedron as a graph of degree 3 (r3d): around every vertex
 * its three neighbours in a fixed turning order, so that the faces are
 * walked by "next = the neighbour after the one we came from". Cut
 * vertices are marked dead rather than removed. A tetrahedron clipped by 4
 * planes has at most 12 live vertices; each clip adds one per cut edge. */
#define POLY_MAXV 64
typedef struct poly3 {
  int nv;
  double x[POLY_MAXV][3];
  int nb[POLY_MAXV][3];
  unsigned char dead[POLY_MAXV];
} poly3;

static void poly3_tet(poly3 *p, const double y[4][3]) {
  static const int nb[4][3] = {{1, 3, 2}, {2, 3, 0}, {0, 3, 1}, {1, 2, 0}};
  p->nv = 4;
  memcpy(p->x, y, sizeof(double) * 12);
  memcpy(p->nb, nb, sizeof nb);
  memset(p->dead, 0, 4);
}

/* Keep the part of p where off + n.x >= 0, given s (that value at each
 * vertex, POLY_MAXV entries, dead ones included); 0 if nothing is left. */
static int poly3_clip(poly3 *p, const double *s) {
  int onv = p->nv, ncut = 0, nlive = 0;
  unsigned char cut[POLY_MAXV];
  for (int v = 0; v < onv; v++) {
    cut[v] = !p->dead[v] && s[v] < 0;
    ncut += cut[v];
    nlive += !p->dead[v];
  }
  if (ncut == 0) return 1;
  if (ncut == nlive || onv + 3 * ncut > POLY_MAXV) return 0;
  /* a new vertex on every edge from a kept vertex to a cut one */
  for (int v = 0; v < onv; v++) {
    if (p->dead[v] || cut[v]) continue;
    for (int k = 0; k < 3; k++) {
      int w = p->nb[v][k];
      if (!cut[w]) continue;
      int q = p->nv++;
      double a = -s[w], b = s[v], t = a + b;
      for (int c = 0; c < 3; c++) p->x[q][c] = (p->x[v][c] * a + p->x[w][c] * b) / t;
      p->nb[q][0] = v;
      p->nb[v][k] = q;
      p->dead[q] = 0;
      cut[q] = 0;
    }
  }
  /* link the new vertices around the cut face: from each, walk its face
   * through kept vertices to the next new one */
  for (int q0 = onv; q0 < p->nv; q0++) {
    int cur = q0, next = p->nb[q0][0];
    do {
      int k = p->nb[next][0] == cur ? 0 : p->nb[next][1] == cur ? 1 : 2;
      cur = next;
      next = p->nb[cur][k == 2 ? 0 : k + 1];
    } while (cur < onv);
    p->nb[q0][2] = cur;
    p->nb[cur][1] = q0;
  }
  for (int v = 0; v < onv; v++) p->dead[v] |= cut[v];
  return 1;
}

/* Step along a face of p: from the edge cur -> *next, the next edge. */
static inline int face_step(const poly3 *p, int *cur, int *next,
                            unsigned char (*mark)[3]) {
  const int *nb = p->nb[*next];
  int k = nb[0] == *cur ? 1 : nb[1] == *cur ? 2 : 0;
  *cur = *next;
  mark[*cur][k] = 1;
  *next = p->nb[*cur][k];
  return *next;
}

/* Volume of p: every face walked once and fanned from its first vertex. */
static double poly3_volume(const poly3 *p) {
  unsigned char mark[POLY_MAXV][3];
  double six = 0;
  memset(mark, 0, sizeof mark[0] * p->nv);
  for (int v0 = 0; v0 < p->nv; v0++)
    for (int k0 = 0; k0 < 3; k0++) {
      if (p->dead[v0] || mark[v0][k0]) continue;
      const double *a = p->x[v0];
      int cur = v0, next = p->nb[v0][k0];
      mark[v0][k0] = 1;
      face_step(p, &cur, &next, mark);
      while (next != v0) {
        const double *b = p->x[next], *c = p->x[cur];
        six += a[0] * (b[1] * c[2] - b[2] * c[1]) -
               a[1] * (b[0] * c[2] - b[2] * c[0]) +
               a[2] * (b[0] * c[1] - b[1] * c[0]);
        face_step(p, &cur, &next, mark);
      }
    }
  return six / 6;
}

/* The share of a tetrahedron where s >= 0, given s at its vertices (some
 * negative, some not), in closed form. One vertex apart (alone on its
 * side): the corner it cuts is a tetrahedron whose edges are the fractions
 * s_l / (s_l - s_j) of the three edges from it. Two and two (a, b kept, c,
 * d cut): the plane through b, d and the cut point of ac splits the
 * tetrahedron into two of shares t = s_a / (s_a - s_c) and 1 - t, each
 * with one vertex apart. */
static double half_share(const double *s) {
  int neg = 0, lone = -1;
  for (int j = 0; j < 4; j++) neg += s[j] < 0;
  if (neg == 1 || neg == 3) {
    for (int j = 0; j < 4; j++)
      if ((s[j] < 0) == (neg == 1)) lone = j;
    double f = 1;
    for (int j = 0; j < 4; j++)
      if (j != lone) f *= s[lone] / (s[lone] - s[j]);
    return neg == 1 ? 1 - f : f;
  }
  int k[2], c[2], nk = 0, nc = 0;
  for (int j = 0; j < 4; j++) {
    if (s[j] < 0)
      c[nc++] = j;
    else
      k[nk++] = j;
  }
  double sa = s[k[0]], sb = s[k[1]], sc = s[c[0]], sd = s[c[1]];
  double t = sa / (sa - sc);
  double cut_a = (sd / (sd - sa)) * (sd / (sd - sb)); /* corner d of (a,b,P,d) */
  double kept_c = (sb / (sb - sc)) * (sb / (sb - sd)); /* corner b of (P,b,c,d) */
  return t * (1 - cut_a) + (1 - t) * kept_c;
}

/* Volume of the tetrahedron y (measure vol) clipped by the half-spaces P,
 * given s[i][j], plane i at vertex j: in closed form when one plane cuts
 * it (half_share), else clipped plane by plane. */
static double clip3(const double y[4][3], double vol, const planes *P,
                    double s[4][4]) {
  int ncross = 0, plane = -1;
  for (int i = 0; i < 4; i++) {
    int neg = 0;
    for (int j = 0; j < 4; j++) neg += s[i][j] < 0;
    if (neg) ncross++, plane = i;
  }
  if (ncross == 1) return vol * half_share(s[plane]);
  poly3 p;
  poly3_tet(&p, y);
  double sv[POLY_MAXV];
  for (int i = 0; i < 4; i++) {
    int neg = 0;
    for (int j = 0; j < 4; j++) neg += s[i][j] < 0;
    if (!neg) continue;
    for (int v = 0; v < p.nv; v++)
      sv[v] = v < 4 ? s[i][v]
                    : P->off[i] + P->n[i][0] * p.x[v][0] + P->n[i][1] * p.x[v][1] +
                          P->n[i][2] * p.x[v][2];
    if (!poly3_clip(&p, sv)) return 0;
  }
  return poly3_volume(&p);
}

/* ---- the transfer ------------------------------------------------------ */

/* A sum of many terms, compensated (Neumaier): the integrals and measures
 * the report compares differ by round-off of the sum itself otherwise
 * (1e-12 of a cube's measure over 0.3 M pieces). */
typedef struct ksum {
  double s, c;
} ksum;

static inline void ksum_add(ksum *k, double x) {
  double t = k->s + x;
  k->c += fabs(k->s) >= fabs(x) ? (k->s - t) + x : (x - t) + k->s;
  k->s = t;
}

static inline double ksum_value(const ksum *k) { return k->s + k->c; }

typedef struct tctx {
  int d, nve;
  pa_mesh *o;           /* old mesh */
  const pa_idx *adja;   /* its adjacency */
  pa_mesh *m;           /* new mesh */
  grid eg;              /* old elements by box, built on first need */
  int eg_built;
  uint64_t rng;
  pa_idx *stamp;        /* per old element: last new element that met it */
  pa_idx *queue;
  size_t capq;
  /* pieces of new element n: pold/pw[pstart[n] .. pstart[n+1]) */
  size_t *pstart;
  pa_idx *pold;
  double *pw;
  size_t npiece, cappiece;
  double *volo, *voln;  /* measures of old and new elements */
  pa_transfer_report *rep;
} tctx;

static uint64_t next_rand(uint64_t *s) {
  *s ^= *s >> 12;
  *s ^= *s << 25;
  *s ^= *s >> 27;
  return *s * 0x2545F4914F6CDD1Dull;
}

/* The dim+1 vertices of element e of m, relative to origin, into q. */
static void elem_points(const pa_mesh *m, pa_idx e, const double *origin,
                        double q[4][3]) {
  int d = m->dim;
  const pa_idx *v = m->elem + (size_t)(d + 1) * e;
  for (int i = 0; i <= d; i++) {
    const double *x = m->coord + (size_t)d * v[i];
    for (int k = 0; k < 3; k++) q[i][k] = k < d ? x[k] - origin[k] : 0;
  }
}

/* Barycentric coordinates of p (absolute) in old element e. */
static void bary(const tctx *t, pa_idx e, const double *p, double *l) {
  double q[4][3], y[3];
  planes P;
  int d = t->d;
  const double *o = t->o->coord + (size_t)d * t->o->elem[(size_t)t->nve * e];
  elem_points(t->o, e, o, q);
  for (int k = 0; k < 3; k++) y[k] = k < d ? p[k] - o[k] : 0;
  planes_of(d, q, &P);
  for (int i = 0; i <= d; i++) l[i] = plane_at(&P, i, y, d) / plane_at(&P, i, q[i], d);
}

static int contains(const tctx *t, pa_idx e, const double *p) {
  double l[4];
  bary(t, e, p, l);
  for (int i = 0; i <= t->d; i++)
    if (!(l[i] >= -INSIDE_TOL)) return 0;
  return 1;
}

static pa_status build_elem_grid(tctx *t) {
  pa_status st = PA_SUCCESS;
  int d = t->d;
  pa_idx ne = t->o->ne;
  double *box = NULL;
  PA_ALLOC(box, (size_t)2 * d * (ne ? ne : 1));
  for (pa_idx e = 0; e < ne; e++) {
    double *b = box + (size_t)2 * d * e;
    for (int k = 0; k < d; k++) b[k] = DBL_MAX, b[d + k] = -DBL_MAX;
    for (int i = 0; i <= d; i++) {
      const double *x = t->o->coord + (size_t)d * t->o->elem[(size_t)t->nve * e + i];
      for (int k = 0; k < d; k++) {
        b[k] = fmin(b[k], x[k]);
        b[d + k] = fmax(b[d + k], x[k]);
      }
    }
  }
  PA_CALL(grid_build(&t->eg, d, ne, box));
  t->eg_built = 1;
cleanup:
  pa__free(box);
  return st;
}

/* The old element holding p, walking from e (*inside = 1); when p is
 * outside the old mesh, the element where the search ended (*inside = 0). */
static pa_status locate(tctx *t, const double *p, pa_idx e, pa_idx *found,
                        int *inside) {
  pa_status st = PA_SUCCESS;
  int d = t->d;
  for (int step = 0; step < WALK_MAX_STEPS; step++) {
    double l[4];
    bary(t, e, p, l);
    int neg[4], nneg = 0, nfree = 0;
    for (int i = 0; i <= d; i++)
      if (!(l[i] >= -INSIDE_TOL)) {
        neg[nneg++] = i;
        nfree += t->adja[(size_t)t->nve * e + i] >= 0;
      }
    if (!nneg) {
      *found = e;
      *inside = 1;
      return PA_SUCCESS;
    }
    if (!nfree) break; /* out through the boundary: outside, or a concave part */
    /* a random face among those p is beyond (a walk in a non-Delaunay mesh
     * may cycle otherwise) */
    int r = (int)(next_rand(&t->rng) % (uint64_t)nneg), i = -1;
    for (int k = 0; k < nneg; k++) {
      int c = neg[(r + k) % nneg];
      if (t->adja[(size_t)t->nve * e + c] >= 0) {
        i = c;
        break;
      }
    }
    e = t->adja[(size_t)t->nve * e + i] / t->nve;
  }
  /* the grid: an element holding p, else the walk's end stays */
  if (!t->eg_built) PA_CALL(build_elem_grid(t));
  {
    int a[3], b[3];
    grid_range(&t->eg, p, p, a, b);
    size_t q = grid_index(&t->eg, a);
    for (size_t k = t->eg.start[q]; k < t->eg.start[q + 1]; k++)
      if (contains(t, t->eg.item[k], p)) {
        *found = t->eg.item[k];
        *inside = 1;
        return PA_SUCCESS;
      }
  }
  *found = e;
  *inside = 0;
cleanup:
  return st;
}

static pa_status add_piece(tctx *t, pa_idx old, double w) {
  pa_status st = PA_SUCCESS;
  if (t->npiece >= t->cappiece) {
    size_t cap = t->cappiece + t->cappiece / 2 + 1024;
    PA_GROW(t->pold, t->cappiece, cap);
    t->cappiece = 0;
    PA_GROW(t->pw, t->cappiece, cap);
  }
  t->pold[t->npiece] = old;
  t->pw[t->npiece++] = w;
cleanup:
  return st;
}

/* The planes of old element o relative to origin, into P (q: its points). */
static void old_planes(const tctx *t, pa_idx o, const double *origin,
                       double q[4][3], planes *P) {
  elem_points(t->o, o, origin, q);
  planes_of(t->d, q, P);
}

/* The pieces of new element n. *seed: where the last location ended (in),
 * where this one ended (out). */
static pa_status pieces_of(tctx *t, pa_idx n, pa_idx *seed) {
  pa_status st = PA_SUCCESS;
  int d = t->d, nve = t->nve;
  double y[4][3], c[3] = {0, 0, 0}, vol, q[4][3];
  planes P;
  const double *origin = t->m->coord + (size_t)d * t->m->elem[(size_t)nve * n];
  elem_points(t->m, n, origin, y);
  {
    const double *py[4] = {y[0], y[1], y[2], y[3]};
    vol = pa__simplex_volume(d, py);
  }
  t->voln[n] = vol;
  for (int i = 0; i <= d; i++)
    for (int k = 0; k < d; k++) c[k] += (y[i][k] + origin[k]) / (d + 1);
  pa_idx e;
  int inside;
  PA_CALL(locate(t, c, *seed, &e, &inside));
  *seed = e;
  if (inside) { /* n inside e: its vertices' barycentric coordinates */
    int all = 1;
    old_planes(t, e, origin, q, &P);
    for (int i = 0; i <= d && all; i++) {
      double tol = -INSIDE_TOL * plane_at(&P, i, q[i], d);
      for (int j = 0; j <= d && all; j++) all = plane_at(&P, i, y[j], d) >= tol;
    }
    if (all) {
      t->rep->nfast++;
      PA_CALL(add_piece(t, e, vol));
      t->pstart[n + 1] = t->npiece;
      return PA_SUCCESS;
    }
  }
  t->rep->nclip++;
  size_t q0 = 0, q1 = 0, first = t->npiece;
  PA_GROW(t->queue, t->capq, (size_t)d + 2);
  t->queue[q1++] = e;
  t->stamp[e] = n;
  if (!inside) /* the centroid is outside: start from the vertices too */
    for (int i = 0; i <= d; i++) {
      double p[3];
      pa_idx f;
      int in;
      for (int k = 0; k < d; k++) p[k] = y[i][k] + origin[k];
      PA_CALL(locate(t, p, e, &f, &in));
      if (in && t->stamp[f] != n) {
        t->stamp[f] = n;
        t->queue[q1++] = f;
      }
    }
  while (q0 < q1) {
    pa_idx o = t->queue[q0++];
    double w;
    old_planes(t, o, origin, q, &P);
    /* n beyond one face of o (apart), inside all of them (in), and the
     * faces of o it crosses: the only ones with overlapping elements
     * beyond */
    int apart = 0, in = 1, cross[4];
    double sv[4][4];
    for (int i = 0; i <= d && !apart; i++) {
      int below = 0, above = 0;
      for (int j = 0; j <= d; j++) {
        double s = sv[i][j] = plane_at(&P, i, y[j], d);
        below += s <= 0;
        above += s >= 0;
      }
      apart = below == d + 1;
      in &= above == d + 1;
      cross[i] = above < d + 1;
    }
    if (apart) continue;
    w = in ? vol : d == 2 ? clip2(y, &P) : clip3(y, vol, &P, sv);
    if (!(w > 0)) continue;
    PA_CALL(add_piece(t, o, w));
    for (int i = 0; i <= d; i++) {
      pa_idx a = t->adja[(size_t)nve * o + i];
      if (a < 0 || !cross[i] || t->stamp[a / nve] == n) continue;
      t->stamp[a / nve] = n;
      PA_GROW(t->queue, t->capq, q1 + 1);
      t->queue[q1++] = a / nve;
    }
  }
  if (t->npiece == first) /* outside every old element */
    PA_CALL(add_piece(t, e, 0));
  t->pstart[n + 1] = t->npiece;
cleanup:
  return st;
}

/* The values of one element field (old values ov, nc components) on the
 * new mesh into nv, by mode; the defect and out-of-range count into the
 * report. */
static pa_status element_field(tctx *t, int mode, int nc, const double *ov,
                               double *nv) {
  pa_status st = PA_SUCCESS;
  pa_idx ne = t->m->ne, neo = t->o->ne;
  double *lo = NULL, *hi = NULL;
  PA_ALLOC(lo, (size_t)(ne ? ne : 1));
  PA_ALLOC(hi, (size_t)(ne ? ne : 1));
  for (int c = 0; c < nc; c++) {
    ksum ko = {0, 0}, ka = {0, 0}, kn = {0, 0};
    for (pa_idx e = 0; e < neo; e++) {
      double v = ov[(size_t)nc * e + c];
      ksum_add(&ko, t->volo[e] * v);
      ksum_add(&ka, t->volo[e] * fabs(v));
    }
    double iold = ksum_value(&ko), iabs = ksum_value(&ka);
    for (pa_idx n = 0; n < ne; n++) {
      size_t a = t->pstart[n], b = t->pstart[n + 1];
      double vmin = DBL_MAX, vmax = -DBL_MAX, sw = 0, swv = 0, wbest = -1, v = 0;
      for (size_t k = a; k < b; k++) {
        double x = ov[(size_t)nc * t->pold[k] + c], w = t->pw[k];
        vmin = fmin(vmin, x);
        vmax = fmax(vmax, x);
        sw += w;
        swv += w * x;
        if (w > wbest) wbest = w, v = x;
      }
      /* else v is the value of the largest piece: all the same when
       * vmin == vmax, the only one outside the old mesh */
      if (mode != PA_TRANSFER_NEAREST && vmin != vmax && sw > 0) v = swv / sw;
      lo[n] = vmin;
      hi[n] = vmax;
      if (mode == PA_TRANSFER_BOUNDED) v = fmin(fmax(v, vmin), vmax);
      nv[(size_t)nc * n + c] = v;
      ksum_add(&kn, t->voln[n] * v);
    }
    double inew = ksum_value(&kn);
    if (mode == PA_TRANSFER_BOUNDED) /* give back what the clamping and the
                                        boundary changed */
      for (int round = 0; round < 2; round++) {
        double def = iold - inew, room = 0;
        if (def == 0) break;
        for (pa_idx n = 0; n < ne; n++) {
          double v = nv[(size_t)nc * n + c];
          room += t->voln[n] * (def > 0 ? hi[n] - v : v - lo[n]);
        }
        if (!(room > 0)) break;
        double f = fmin(1.0, fabs(def) / room);
        kn.s = kn.c = 0;
        for (pa_idx n = 0; n < ne; n++) {
          double *v = &nv[(size_t)nc * n + c];
          *v += f * (def > 0 ? hi[n] - *v : lo[n] - *v);
          *v = fmin(fmax(*v, lo[n]), hi[n]);
          ksum_add(&kn, t->voln[n] * *v);
        }
        inew = ksum_value(&kn);
      }
    for (pa_idx n = 0; n < ne; n++) {
      double v = nv[(size_t)nc * n + c];
      t->rep->nout += v < lo[n] || v > hi[n];
    }
    if (mode != PA_TRANSFER_NEAREST && iabs > 0)
      t->rep->defect = fmax(t->rep->defect, fabs(inew - iold) / iabs);
  }
cleanup:
  pa__free(lo);
  pa__free(hi);
  return st;
}

/* ---- boundary fields --------------------------------------------------- */

/* Squared distance from p to segment ab (2D) or triangle abc (3D). */
static double dist2_face(int d, const double *p, const double *const *x) {
  double r[3];
  if (d == 2) {
    double ab[2] = {x[1][0] - x[0][0], x[1][1] - x[0][1]};
    double ap[2] = {p[0] - x[0][0], p[1] - x[0][1]};
    double l = ab[0] * ab[0] + ab[1] * ab[1];
    double s = l > 0 ? (ap[0] * ab[0] + ap[1] * ab[1]) / l : 0;
    s = fmin(fmax(s, 0), 1);
    r[0] = ap[0] - s * ab[0], r[1] = ap[1] - s * ab[1];
    return r[0] * r[0] + r[1] * r[1];
  }
  /* closest point on a triangle, by regions (Ericson, Real-Time Collision
   * Detection 5.1.5) */
  const double *a = x[0], *b = x[1], *c = x[2];
  double ab[3], ac[3], ap[3], q[3];
  for (int k = 0; k < 3; k++) ab[k] = b[k] - a[k], ac[k] = c[k] - a[k], ap[k] = p[k] - a[k];
#define DOT(u, v) ((u)[0] * (v)[0] + (u)[1] * (v)[1] + (u)[2] * (v)[2])
  double d1 = DOT(ab, ap), d2 = DOT(ac, ap);
  if (d1 <= 0 && d2 <= 0) {
    memcpy(q, a, sizeof q);
    goto done;
  }
  double bp[3] = {p[0] - b[0], p[1] - b[1], p[2] - b[2]};
  double d3 = DOT(ab, bp), d4 = DOT(ac, bp);
  if (d3 >= 0 && d4 <= d3) {
    memcpy(q, b, sizeof q);
    goto done;
  }
  double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    double v = d1 / (d1 - d3);
    for (int k = 0; k < 3; k++) q[k] = a[k] + v * ab[k];
    goto done;
  }
  double cp[3] = {p[0] - c[0], p[1] - c[1], p[2] - c[2]};
  double d5 = DOT(ab, cp), d6 = DOT(ac, cp);
  if (d6 >= 0 && d5 <= d6) {
    memcpy(q, c, sizeof q);
    goto done;
  }
  double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    double w = d2 / (d2 - d6);
    for (int k = 0; k < 3; k++) q[k] = a[k] + w * ac[k];
    goto done;
  }
  double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    for (int k = 0; k < 3; k++) q[k] = b[k] + w * (c[k] - b[k]);
    goto done;
  }
  {
    double den = 1 / (va + vb + vc), v = vb * den, w = vc * den;
    for (int k = 0; k < 3; k++) q[k] = a[k] + ab[k] * v + ac[k] * w;
  }
done:
#undef DOT
  for (int k = 0; k < 3; k++) r[k] = p[k] - q[k];
  return r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
}

/* 1 if some boundary entity of o has reference ref (refs: o's sorted). */
static int has_ref(const int32_t *refs, pa_idx n, int32_t ref) {
  pa_idx a = 0, b = n;
  while (a < b) {
    pa_idx c = a + (b - a) / 2;
    if (refs[c] < ref)
      a = c + 1;
    else
      b = c;
  }
  return a < n && refs[a] == ref;
}

static int cmp_i32(const void *a, const void *b) {
  int32_t x = *(const int32_t *)a, y = *(const int32_t *)b;
  return (x > y) - (x < y);
}

/* For each new boundary entity, the old one of the same reference nearest
 * to its centroid (of any reference if none has it) into src: the grid's
 * buckets searched ring by ring around the centroid's, until no unseen
 * entity can be nearer. */
static pa_status match_boundary(const pa_mesh *o, const pa_mesh *m, pa_idx *src) {
  pa_status st = PA_SUCCESS;
  int d = o->dim;
  pa_idx nbo = o->nb;
  double *box = NULL;
  int32_t *refs = NULL;
  grid g;
  memset(&g, 0, sizeof g);
  if (!nbo) {
    for (pa_idx b = 0; b < m->nb; b++) src[b] = -1;
    return PA_SUCCESS;
  }
  PA_ALLOC(box, (size_t)2 * d * nbo);
  PA_ALLOC(refs, (size_t)nbo);
  for (pa_idx b = 0; b < nbo; b++) {
    double *bx = box + (size_t)2 * d * b;
    for (int k = 0; k < d; k++) bx[k] = DBL_MAX, bx[d + k] = -DBL_MAX;
    for (int i = 0; i < d; i++) {
      const double *x = o->coord + (size_t)d * o->bdry[(size_t)d * b + i];
      for (int k = 0; k < d; k++) {
        bx[k] = fmin(bx[k], x[k]);
        bx[d + k] = fmax(bx[d + k], x[k]);
      }
    }
    refs[b] = o->bref[b];
  }
  qsort(refs, (size_t)nbo, sizeof *refs, cmp_i32);
  PA_CALL(grid_build(&g, d, nbo, box));
  double hmin = fmin(g.h[0], g.h[1]);
  if (d == 3) hmin = fmin(hmin, g.h[2]);
  for (pa_idx b = 0; b < m->nb; b++) {
    double c[3] = {0, 0, 0};
    for (int i = 0; i < d; i++)
      for (int k = 0; k < d; k++)
        c[k] += m->coord[(size_t)d * m->bdry[(size_t)d * b + i] + k] / d;
    int32_t ref = m->bref[b];
    int any = !has_ref(refs, nbo, ref);
    pa_idx best = -1;
    double dbest = DBL_MAX;
    int a[3], z[3];
    grid_range(&g, c, c, a, z);
    for (int r = 0;; r++) {
      /* unseen entities lie beyond the rings < r: at least (r-1) hmin away */
      double reach = (r - 1) * hmin;
      if (best >= 0 && reach > 0 && reach * reach > dbest) break;
      int lo[3], hi[3], cc[3], all = 1;
      for (int k = 0; k < 3; k++) {
        lo[k] = a[k] - r < 0 ? 0 : a[k] - r;
        hi[k] = a[k] + r >= g.n[k] ? g.n[k] - 1 : a[k] + r;
        all &= lo[k] == 0 && hi[k] == g.n[k] - 1;
      }
      for (cc[2] = lo[2]; cc[2] <= hi[2]; cc[2]++)
        for (cc[1] = lo[1]; cc[1] <= hi[1]; cc[1]++)
          for (cc[0] = lo[0]; cc[0] <= hi[0]; cc[0]++) {
            int ring = 0;
            for (int k = 0; k < 3; k++)
              if (abs(cc[k] - a[k]) > ring) ring = abs(cc[k] - a[k]);
            if (ring != r) continue; /* seen in an earlier ring */
            size_t q = grid_index(&g, cc);
            for (size_t k = g.start[q]; k < g.start[q + 1]; k++) {
              pa_idx f = g.item[k];
              if (!any && o->bref[f] != ref) continue;
              const double *x[3];
              for (int i = 0; i < d; i++)
                x[i] = o->coord + (size_t)d * o->bdry[(size_t)d * f + i];
              double dd = dist2_face(d, c, x);
              if (dd < dbest || (dd == dbest && f < best)) dbest = dd, best = f;
            }
          }
      if (all) break;
    }
    src[b] = best;
  }
cleanup:
  grid_free(&g);
  pa__free(box);
  pa__free(refs);
  return st;
}

/* ---- driver ------------------------------------------------------------ */

pa_status pa__transfer_fields(pa_mesh *o, pa_mesh *m, pa_transfer_report *rep) {
  pa_status st = PA_SUCCESS;
  tctx t;
  double *val = NULL;
  pa_idx *bsrc = NULL;
  double t0 = pa_wtime(), c0 = pa__thread_cputime();
  memset(&t, 0, sizeof t);
  memset(rep, 0, sizeof *rep);
  rep->nfield = o->nefield + o->nbfield;
  t.d = o->dim;
  t.nve = o->dim + 1;
  t.o = o;
  t.m = m;
  t.rep = rep;
  t.rng = 0x9E3779B97F4A7C15ull;
  if (o->nefield && m->ne) {
    PA_CHECK(o->ne > 0, PA_ERR_ARG, "element fields on a mesh without elements");
    PA_CALL(pa_mesh_build_adjacency(o, &t.adja));
    PA_ALLOC(t.stamp, (size_t)o->ne);
    for (pa_idx e = 0; e < o->ne; e++) t.stamp[e] = -1;
    PA_ALLOC(t.volo, (size_t)o->ne);
    PA_ALLOC(t.voln, (size_t)m->ne);
    PA_ALLOC(t.pstart, (size_t)m->ne + 1);
    t.pstart[0] = 0;
    ksum vold = {0, 0}, vnew = {0, 0}, cov = {0, 0};
    for (pa_idx e = 0; e < o->ne; e++) {
      double q[4][3];
      const double *x0 = o->coord + (size_t)t.d * o->elem[(size_t)t.nve * e];
      const double *pq[4] = {q[0], q[1], q[2], q[3]};
      elem_points(o, e, x0, q);
      t.volo[e] = pa__simplex_volume(t.d, pq);
      ksum_add(&vold, t.volo[e]);
    }
    pa_idx seed = 0;
    for (pa_idx n = 0; n < m->ne; n++) PA_CALL(pieces_of(&t, n, &seed));
    for (pa_idx n = 0; n < m->ne; n++) ksum_add(&vnew, t.voln[n]);
    for (size_t k = 0; k < t.npiece; k++) ksum_add(&cov, t.pw[k]);
    double vo = ksum_value(&vold), vn = ksum_value(&vnew), cv = ksum_value(&cov);
    if (vo > 0) {
      rep->uncovered = fmax(0, vn - cv) / vo;
      rep->lost = fmax(0, vo - cv) / vo;
    }
  }
  for (int f = 0; f < o->nefield; f++) {
    const pa__field *of = &o->efield[f];
    size_t nval = (size_t)(m->ne ? m->ne : 1) * of->ncomp;
    PA_ALLOC(val, nval);
    memset(val, 0, nval * sizeof *val);
    if (m->ne) PA_CALL(element_field(&t, of->transfer, of->ncomp, of->val, val));
    PA_CALL(pa_mesh_add_field_at(m, PA_ELEMENT, of->name, of->ncomp, val));
    m->efield[m->nefield - 1].transfer = of->transfer;
    pa__free(val);
    val = NULL;
  }
  if (o->nbfield) {
    PA_ALLOC(bsrc, (size_t)(m->nb ? m->nb : 1));
    PA_CALL(match_boundary(o, m, bsrc));
  }
  for (int f = 0; f < o->nbfield; f++) {
    const pa__field *of = &o->bfield[f];
    int nc = of->ncomp;
    PA_ALLOC(val, (size_t)(m->nb ? m->nb : 1) * nc);
    for (pa_idx b = 0; b < m->nb; b++)
      for (int c = 0; c < nc; c++)
        val[(size_t)nc * b + c] = bsrc[b] >= 0 ? of->val[(size_t)nc * bsrc[b] + c] : 0;
    PA_CALL(pa_mesh_add_field_at(m, PA_BOUNDARY, of->name, nc, val));
    m->bfield[m->nbfield - 1].transfer = of->transfer;
    pa__free(val);
    val = NULL;
  }
cleanup:
  if (st != PA_SUCCESS) { /* the new mesh gets none of them */
    while (m->nefield) pa_mesh_remove_field_at(m, PA_ELEMENT, m->nefield - 1);
    while (m->nbfield) pa_mesh_remove_field_at(m, PA_BOUNDARY, m->nbfield - 1);
  }
  grid_free(&t.eg);
  pa__free(t.stamp);
  pa__free(t.queue);
  pa__free(t.pstart);
  pa__free(t.pold);
  pa__free(t.pw);
  pa__free(t.volo);
  pa__free(t.voln);
  pa__free(val);
  pa__free(bsrc);
  rep->time_s = pa_wtime() - t0;
  rep->cpu_s = pa__thread_cputime() - c0;
  return st;
}
