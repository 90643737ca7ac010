/*
 * overlap.c -- the check that a mesh covers its domain once around each of
 * its vertices (2D) and edges (3D): no folded or overlapping elements
 * (pa__mesh_check_overlap, part of pa_mesh_check on input meshes).
 *
 * Why this criterion. The other checks (check.c) make every element positive
 * and pair every interior face between two elements on opposite sides of it,
 * so the mesh can only fold where elements meet around a lower-dimensional
 * entity: a vertex in 2D, an edge (and then a vertex) in 3D. Around such an
 * entity the elements form one ring (interior) or one fan (boundary,
 * manifold), each element turning about it by an angle in (0, pi), all in the
 * same direction. The mesh is one sheet there exactly when
 *  - a ring turns once around the entity (its angles sum to 2 pi, not
 *    2 pi k with k > 1),
 *  - a fan turns less than once, from its first boundary edge (face) to its
 *    last (its angles sum to the angle between them, below 2 pi).
 * In 3D, when every edge passes, the elements around an interior vertex
 * cover the sphere of directions once (a locally one-to-one map of a sphere
 * onto the sphere is one to one); around a boundary vertex they form a disc
 * of directions, which covers some direction twice only if its area, the sum
 * of their solid angles there, exceeds 4 pi (tested), or if the boundary
 * surface passes through itself at the vertex: the one local fold this check
 * does not see. Two parts of a mesh lying on each other without sharing an
 * entity are not detected either (docs/guide/limits.md).
 *
 * How the turns are counted, exactly and without trigonometry. A reference
 * ray d leaves the entity through a point inside the sector of one of its
 * elements (at the fraction PA_OVERLAP_RAY of it, so that d lies in no plane
 * of a structured mesh and the orientation tests below stay on their fast
 * path). An element turning from ring vertex k to the next, l, by less than
 * pi crosses d exactly when k lies at an angle in [pi, 2 pi) from d and l in
 * [0, pi) (the classes N and P of half_turn); the number of crossings is the
 * number of times the elements cover d. A ring must cover it once. A fan
 * must cover it once (d is inside one of its elements) and, measured from
 * d, end before it starts: its last vertex at a smaller angle than its first.
 * Every class and comparison is the exact sign of one orientation test
 * (pa__orient2d/3d), so the verdict is exact.
 *
 * Work: one walk over each vertex's ball: in 3D, the edges of a vertex a to
 * larger vertices b are found with a marker array over the vertices, and
 * each element adds two orientation tests per edge. The angles are summed
 * only for the message of a failure. Needs the adjacency and the balls
 * (pa__mesh_check builds them first). Messages name entities 1-based.
 */
#include "mesh/mesh.h"

#include <math.h>
#include <stdio.h>

#define TWO_PI 6.283185307179586476925286766559
/* Where the reference ray crosses the segment between the ring vertices of
 * one element: 1 - 1/golden ratio, a fraction no symmetry of a structured
 * mesh puts another vertex in line with. */
#define PA_OVERLAP_RAY 0.3819660112501051

/* Local vertices of the face opposite vertex i of a tetrahedron. */
static const int tet_face[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};

/* turn[i][j] = {k, l}: (i, j, k, l) is an even permutation of (0, 1, 2, 3),
 * so that about the edge from local vertex i to j a positive tetrahedron
 * turns right-handedly from k to l. */
static const int8_t tet_turn[4][4][2] = {
    {{-1, -1}, {2, 3}, {3, 1}, {1, 2}},
    {{3, 2}, {-1, -1}, {0, 3}, {2, 0}},
    {{1, 3}, {3, 0}, {-1, -1}, {0, 1}},
    {{2, 1}, {0, 2}, {1, 0}, {-1, -1}}};

static double dot3(const double *a, const double *b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static double det3(const double *a, const double *b, const double *c) {
  return a[0] * (b[1] * c[2] - b[2] * c[1]) + a[1] * (b[2] * c[0] - b[0] * c[2]) +
         a[2] * (b[0] * c[1] - b[1] * c[0]);
}

static void sub3(const double *a, const double *b, double *d) {
  for (int k = 0; k < 3; k++) d[k] = a[k] - b[k];
}

static void cross3(const double *a, const double *b, double *c) {
  c[0] = a[1] * b[2] - a[2] * b[1];
  c[1] = a[2] * b[0] - a[0] * b[2];
  c[2] = a[0] * b[1] - a[1] * b[0];
}

static double deg(double a) { return a * (360.0 / TWO_PI); }

/* The angle in [0, 2 pi) from x - a to y - a, counter-clockwise (2D) or
 * right-handed about b - a (3D, both projected on the plane normal to it;
 * b NULL in 2D); oriented 0: the unsigned angle in [0, pi], an element's. */
static double angle_about(int dim, const double *a, const double *b,
                          const double *x, const double *y, int oriented) {
  double u[3], w[3], s, c;
  for (int q = 0; q < dim; q++) u[q] = x[q] - a[q], w[q] = y[q] - a[q];
  if (dim == 2) {
    s = u[0] * w[1] - u[1] * w[0];
    c = u[0] * w[0] + u[1] * w[1];
  } else {
    double e[3];
    sub3(b, a, e);
    double ee = dot3(e, e);
    s = sqrt(ee) * det3(e, u, w);
    c = ee * dot3(u, w) - dot3(u, e) * dot3(w, e);
  }
  double ang = atan2(oriented ? s : fabs(s), c);
  return ang < 0 ? ang + TWO_PI : ang;
}

/* Solid angle at the origin of the trihedron (a, b, c), either orientation
 * (Van Oosterom and Strackee). */
static double solid_angle(const double *a, const double *b, const double *c) {
  double la = sqrt(dot3(a, a)), lb = sqrt(dot3(b, b)), lc = sqrt(dot3(c, c));
  double den = la * lb * lc + dot3(a, b) * lc + dot3(a, c) * lb +
               dot3(b, c) * la;
  return 2 * atan2(fabs(det3(a, b, c)), den);
}

/* The exact sign of the turn from x - a to y - a (about b - a in 3D). */
static inline __attribute__((always_inline)) double turn_sign(int dim, const double *a, const double *b,
                               const double *x, const double *y) {
  return dim == 2 ? pa__orient2d(a, x, y) : pa__orient3d(a, b, x, y);
}

/* 1 (class P) if x - a is at an angle in [0, pi) from d - a, turning
 * counter-clockwise (2D) or right-handed about b - a (3D); 0 (class N) if in
 * [pi, 2 pi). On the line of d (sign 0), x is far from the axis (d is not on
 * it), so the dot product that tells the side of a has a certain sign. */
static inline __attribute__((always_inline)) int half_turn(int dim, const double *a, const double *b,
                            const double *d, const double *x) {
  double s = turn_sign(dim, a, b, d, x);
  if (s != 0) return s > 0;
  if (dim == 2)
    return (d[0] - a[0]) * (x[0] - a[0]) + (d[1] - a[1]) * (x[1] - a[1]) > 0;
  double e[3], u[3], w[3];
  sub3(b, a, e);
  sub3(d, a, u);
  sub3(x, a, w);
  return dot3(e, e) * dot3(u, w) - dot3(u, e) * dot3(w, e) > 0;
}

/* The ring or fan around vertex a (2D) or edge (a, b) (3D). */
typedef struct fan {
  pa_idx b;           /* 3D: the edge's other vertex */
  pa_idx first, last; /* a fan's first and last vertices */
  pa_idx nbdry;       /* boundary edges (faces) around it: 0 or 2 */
  pa_idx e0;          /* its first element, for the messages */
  pa_idx ncross;      /* times its elements cover d */
  double d[3];        /* the point the reference ray goes through */
} fan;

/* Element e turns about vertex a (about edge (a, b) in 3D) from its local
 * vertex k to l: count its crossing of d, and note the boundary. */
static inline __attribute__((always_inline)) void
step(const pa_mesh *m, const int d, pa_idx a, fan *f, pa_idx e, int k, int l) {
  const int nf = d + 1;
  const pa_idx *ev = m->elem + (size_t)nf * e;
  const double *xa = m->coord + (size_t)d * a;
  const double *xb = d == 3 ? m->coord + 3 * (size_t)f->b : NULL;
  const double *xk = m->coord + (size_t)d * ev[k];
  const double *xl = m->coord + (size_t)d * ev[l];
  if (f->e0 < 0) {
    f->e0 = e;
    for (int q = 0; q < d; q++) f->d[q] = xk[q] + PA_OVERLAP_RAY * (xl[q] - xk[q]);
  }
  f->ncross += !half_turn(d, xa, xb, f->d, xk) && half_turn(d, xa, xb, f->d, xl);
  /* the face (edge) opposite l holds k: on the boundary, the fan starts at
   * k; the one opposite k on the boundary: the fan ends at l */
  if (m->adja[(size_t)nf * e + l] < 0) f->first = ev[k], f->nbdry++;
  if (m->adja[(size_t)nf * e + k] < 0) f->last = ev[l], f->nbdry++;
}

/* 1 if fan f covers its domain once around vertex a (edge (a, f->b)). */
static int fan_ok(const pa_mesh *m, pa_idx a, const fan *f) {
  if (f->nbdry == 0) return f->ncross == 1;
  if (f->nbdry != 2 || f->ncross != 1) return 0;
  /* measured from d, the last vertex comes before the first */
  const int d = m->dim;
  const double *xa = m->coord + (size_t)d * a;
  const double *xb = d == 3 ? m->coord + 3 * (size_t)f->b : NULL;
  const double *x0 = m->coord + (size_t)d * f->first;
  const double *x1 = m->coord + (size_t)d * f->last;
  int h0 = half_turn(d, xa, xb, f->d, x0), h1 = half_turn(d, xa, xb, f->d, x1);
  if (h0 != h1) return h1; /* last in [0, pi), first in [pi, 2 pi) */
  return turn_sign(d, xa, xb, x1, x0) > 0;
}

/* The failure of fan f around vertex a (edge (a, f->b) in 3D), with the sum
 * of its angles. */
static pa_status fan_error(const pa_mesh *m, pa_idx a, const fan *f) {
  const int d = m->dim, nf = d + 1;
  char what[96];
  const char *elems = d == 2 ? "triangles" : "tetrahedra";
  const char *sides = d == 2 ? "edges" : "faces";
  const double *xa = m->coord + (size_t)d * a;
  const double *xb = d == 3 ? m->coord + 3 * (size_t)f->b : NULL;
  if (d == 2)
    snprintf(what, sizeof what, "%svertex %d", f->nbdry ? "boundary " : "",
             (int)a + 1);
  else
    snprintf(what, sizeof what, "%sedge (%d %d)", f->nbdry ? "boundary " : "",
             (int)a + 1, (int)f->b + 1);
  if (f->nbdry != 0 && f->nbdry != 2)
    return pa__error(PA_ERR_MESH, __FILE__, __LINE__,
                     "%s is non-manifold: %d boundary %s meet there, not 2 "
                     "(elements that touch only there, or a slit)",
                     what, (int)f->nbdry, sides);
  double sum = 0;
  for (pa_idx q = m->ball_start[a]; q < m->ball_start[a + 1]; q++) {
    const pa_idx *ev = m->elem + (size_t)nf * m->ball[q];
    int i = 0, j = -1;
    while (ev[i] != a) i++;
    if (d == 3)
      for (int t = 0; t < 4; t++)
        if (ev[t] == f->b) j = t;
    if (d == 3 && j < 0) continue;
    int k = d == 2 ? (i + 1) % 3 : tet_turn[i][j][0];
    int l = d == 2 ? (i + 2) % 3 : tet_turn[i][j][1];
    sum += angle_about(d, xa, xb, m->coord + (size_t)d * ev[k],
                       m->coord + (size_t)d * ev[l], 0);
  }
  if (f->nbdry == 2)
    return pa__error(
        PA_ERR_MESH, __FILE__, __LINE__,
        "the %s around %s turn through %.6g degrees where its boundary %s "
        "make an angle of %.6g degrees: they overlap (a folded mesh), e.g. "
        "element %d",
        elems, what, deg(sum), sides,
        deg(angle_about(d, xa, xb, m->coord + (size_t)d * f->first,
                        m->coord + (size_t)d * f->last, 1)),
        (int)f->e0 + 1);
  return pa__error(PA_ERR_MESH, __FILE__, __LINE__,
                   "the %s around %s turn %.0f times around it (%sangles "
                   "summing to %.6g degrees, not 360): they overlap (a "
                   "folded mesh), e.g. element %d",
                   elems, what, round(sum / TWO_PI), d == 3 ? "dihedral " : "",
                   deg(sum), (int)f->e0 + 1);
}

/* 2D: the fan of every vertex. */
static pa_status check_2d(const pa_mesh *m) {
  pa_status st = PA_SUCCESS;
  for (pa_idx a = 0; a < m->nv; a++) {
    fan f = {-1, -1, -1, 0, -1, 0, {0, 0, 0}};
    for (pa_idx q = m->ball_start[a]; q < m->ball_start[a + 1]; q++) {
      pa_idx e = m->ball[q];
      const pa_idx *ev = m->elem + 3 * (size_t)e;
      int i = ev[0] == a ? 0 : ev[1] == a ? 1 : 2;
      step(m, 2, a, &f, e, (i + 1) % 3, (i + 2) % 3);
    }
    if (f.e0 >= 0 && !fan_ok(m, a, &f)) PA_CALL(fan_error(m, a, &f));
  }
cleanup:
  return st;
}

/* 3D: the solid angles of the elements around vertex a, if it is on the
 * boundary, stay below 4 pi. */
static pa_status check_solid_angle(const pa_mesh *m, pa_idx a) {
  pa_status st = PA_SUCCESS;
  int onbdry = 0;
  for (pa_idx k = m->ball_start[a]; k < m->ball_start[a + 1] && !onbdry; k++) {
    pa_idx e = m->ball[k];
    const pa_idx *ev = m->elem + 4 * (size_t)e;
    for (int f = 0; f < 4; f++)
      if (ev[f] != a && m->adja[4 * (size_t)e + f] < 0) onbdry = 1;
  }
  if (!onbdry) return PA_SUCCESS;
  double omega = 0;
  const double *xa = m->coord + 3 * (size_t)a;
  for (pa_idx k = m->ball_start[a]; k < m->ball_start[a + 1]; k++) {
    const pa_idx *ev = m->elem + 4 * (size_t)m->ball[k];
    int i = ev[0] == a ? 0 : ev[1] == a ? 1 : ev[2] == a ? 2 : 3;
    double u[3], w[3], z[3];
    sub3(m->coord + 3 * (size_t)ev[tet_face[i][0]], xa, u);
    sub3(m->coord + 3 * (size_t)ev[tet_face[i][1]], xa, w);
    sub3(m->coord + 3 * (size_t)ev[tet_face[i][2]], xa, z);
    omega += solid_angle(u, w, z);
  }
  PA_CHECK(omega < 2 * TWO_PI, PA_ERR_MESH,
           "the tetrahedra around boundary vertex %d fill a solid angle of "
           "%.6g steradians, more than the whole sphere (4 pi): they overlap "
           "(a folded mesh), e.g. element %d",
           (int)a + 1, omega, (int)m->ball[m->ball_start[a]] + 1);
cleanup:
  return st;
}

/* 3D: the fan of every edge, filed under its smaller vertex (slot[b]: the
 * fan of edge (a, b) while a is walked, -1 otherwise), and the solid angles
 * of the boundary vertices. */
static pa_status check_3d(const pa_mesh *m) {
  pa_status st = PA_SUCCESS;
  pa_idx *slot = NULL, maxball = 0;
  fan *fans = NULL;
  for (pa_idx v = 0; v < m->nv; v++)
    if (m->ball_start[v + 1] - m->ball_start[v] > maxball)
      maxball = m->ball_start[v + 1] - m->ball_start[v];
  /* at most three edges of a vertex per element of its ball */
  PA_ALLOC(fans, 3 * (size_t)maxball + 1);
  PA_ALLOC(slot, m->nv ? (size_t)m->nv : 1);
  for (pa_idx v = 0; v < m->nv; v++) slot[v] = -1;
  for (pa_idx a = 0; a < m->nv; a++) {
    pa_idx n = 0;
    for (pa_idx q = m->ball_start[a]; q < m->ball_start[a + 1]; q++) {
      pa_idx e = m->ball[q];
      const pa_idx *ev = m->elem + 4 * (size_t)e;
      int i = ev[0] == a ? 0 : ev[1] == a ? 1 : ev[2] == a ? 2 : 3;
      for (int j = 0; j < 4; j++) {
        pa_idx b = ev[j];
        if (j == i || b < a) continue;
        if (slot[b] < 0) {
          slot[b] = n;
          fans[n++] = (fan){b, -1, -1, 0, -1, 0, {0, 0, 0}};
        }
        step(m, 3, a, &fans[slot[b]], e, tet_turn[i][j][0], tet_turn[i][j][1]);
      }
    }
    for (pa_idx q = 0; q < n; q++) slot[fans[q].b] = -1;
    for (pa_idx q = 0; q < n; q++)
      if (!fan_ok(m, a, &fans[q])) PA_CALL(fan_error(m, a, &fans[q]));
    PA_CALL(check_solid_angle(m, a));
  }
cleanup:
  pa__free(fans);
  pa__free(slot);
  return st;
}

/* How close to a boundary face, relative to its longest edge, a boundary
 * vertex counts as on it: far below any element's size relative to its
 * edges, far above the rounding of a midpoint computed in floating point
 * (a refinement's hanging vertex). */
#define PA_HANGING_TOL 1e-9

/* A boundary face f (its d vertices) as on_face tests points against it:
 * its first vertex, edge vectors, normal and tolerances, computed once. */
typedef struct face_geo {
  int dim;
  const double *p[3];
  double u[3], n[3], uu, nn, plane_tol;
} face_geo;

static void face_geo_of(const pa_mesh *m, const pa_idx *f, face_geo *g) {
  const int d = m->dim;
  memset(g, 0, sizeof *g);
  g->dim = d;
  for (int q = 0; q < d; q++) g->p[q] = m->coord + (size_t)d * f[q];
  for (int q = 0; q < d; q++) g->u[q] = g->p[1][q] - g->p[0][q];
  g->uu = g->u[0] * g->u[0] + g->u[1] * g->u[1] + (d == 3 ? g->u[2] * g->u[2] : 0);
  if (d == 2) return;
  double v[3];
  sub3(g->p[2], g->p[0], v);
  cross3(g->u, v, g->n);
  g->nn = dot3(g->n, g->n);
  /* |n| times the distance to the plane, at most the tolerance */
  g->plane_tol = PA_HANGING_TOL * sqrt(fmax(g->uu, dot3(v, v)) * g->nn);
}

/* 1 if x (not a vertex of the face) lies on the face g, within
 * PA_HANGING_TOL. */
static int on_face(const face_geo *g, const double *x) {
  double w[3];
  for (int q = 0; q < g->dim; q++) w[q] = x[q] - g->p[0][q];
  if (g->dim == 2) {
    double t = g->u[0] * w[0] + g->u[1] * w[1];
    double cr = g->u[0] * w[1] - g->u[1] * w[0], tol = PA_HANGING_TOL;
    return fabs(cr) <= tol * g->uu && t > -tol * g->uu && t < (1 + tol) * g->uu;
  }
  if (!(g->nn > 0) || fabs(dot3(g->n, w)) > g->plane_tol) return 0;
  /* the barycentric coordinates of x's projection, times nn */
  for (int q = 0; q < 3; q++) {
    const double *s0 = g->p[(q + 1) % 3], *s1 = g->p[(q + 2) % 3];
    double e[3], r[3], t[3];
    sub3(s1, s0, e);
    sub3(x, s0, r);
    cross3(e, r, t);
    if (dot3(t, g->n) < -PA_HANGING_TOL * g->nn) return 0;
  }
  return 1;
}

/* No boundary vertex lies on a boundary face it is not a vertex of, among
 * the faces around its boundary neighbours: a hanging vertex, whose
 * neighbour across the slit lists (or is completed with) the face it
 * hangs on. The elements on either side of a slit meet no face of each
 * other, so no other check sees it. */
static pa_status check_hanging(const pa_mesh *m) {
  pa_status st = PA_SUCCESS;
  pa_idx *start = NULL, *ball = NULL;
  const int d = m->dim;
  char buf[96];
  PA_CALL(pa__balls(m->bdry, m->nb, d, m->nv, &start, &ball));
  for (pa_idx f = 0; f < m->nb; f++) {
    const pa_idx *fv = m->bdry + (size_t)d * f;
    face_geo g;
    face_geo_of(m, fv, &g);
    for (int i = 0; i < d; i++)
      for (pa_idx k = start[fv[i]]; k < start[fv[i] + 1]; k++) {
        const pa_idx *gv = m->bdry + (size_t)d * ball[k];
        for (int j = 0; j < d; j++) {
          pa_idx x = gv[j];
          int mine = 0;
          for (int q = 0; q < d; q++) mine |= fv[q] == x;
          if (mine || !on_face(&g, m->coord + (size_t)d * x)) continue;
          int w = 0;
          buf[0] = '\0';
          for (int q = 0; q < d && w >= 0 && (size_t)w < sizeof buf; q++)
            w += snprintf(buf + w, sizeof buf - (size_t)w, q ? " %d" : "%d",
                          (int)fv[q] + 1);
          PA_FAIL(PA_ERR_MESH,
                  "vertex %d lies on the boundary %s (%s) without being one "
                  "of its vertices: a hanging vertex, the mesh is not "
                  "conforming there (split the %s at it)",
                  (int)x + 1, d == 2 ? "edge" : "face", buf,
                  d == 2 ? "edge" : "face");
        }
      }
  }
cleanup:
  pa__free(start);
  pa__free(ball);
  return st;
}

pa_status pa__mesh_check_overlap(const pa_mesh *m) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(m->adja && m->ball_start && m->ball, PA_ERR_INTERNAL,
           "pa__mesh_check_overlap: adjacency and balls not built");
  PA_CALL(check_hanging(m));
  PA_CALL(m->dim == 2 ? check_2d(m) : check_3d(m));
cleanup:
  return st;
}
