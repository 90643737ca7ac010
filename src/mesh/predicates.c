/*
 * predicates.c -- exact orientation tests of 3 points in the plane and 4
 * points in space, after J. R. Shewchuk, "Adaptive Precision Floating-Point
 * Arithmetic and Fast Robust Geometric Predicates" (1997).
 *
 * pa__orient2d(a, b, c) has the exact sign of det(b - a, c - a) and
 * pa__orient3d(a, b, c, d) the exact sign of det(b - a, c - a, d - a): positive
 * for a counter-clockwise triangle / a positively oriented tetrahedron, zero
 * exactly when the points are collinear / coplanar.
 *
 * Method: the determinant is first evaluated in double precision together with
 * Shewchuk's a-priori bound on its rounding error (stage A); when the value
 * exceeds the bound its sign is certain and is returned at once, which is the
 * case for all but nearly degenerate inputs. Otherwise the determinant is
 * evaluated exactly with floating-point expansions: every difference of
 * coordinates is a two-term expansion (two_diff), products use two_product
 * (exact through fma) and sums use the expansion sum; the sign of an expansion
 * is the sign of its most significant component.
 *
 * Invariants of the expansion routines: expansions are arrays of doubles,
 * nonoverlapping and sorted by increasing magnitude; the *_zeroelim routines
 * drop zero components and return the length (at least 1; the zero expansion
 * is {0}). Inputs must be finite and far from overflow/underflow, and the code
 * needs plain double evaluation (FLT_EVAL_METHOD 0, e.g. x86-64 SSE2).
 */
#include "mesh/mesh.h"

#include <float.h>
#include <math.h>

#if !defined(FLT_EVAL_METHOD) || FLT_EVAL_METHOD != 0
#error "exact predicates need double evaluation of double expressions (FLT_EVAL_METHOD 0)"
#endif

/* Shewchuk's epsilon (half an ulp of 1) and stage-A error bound factors. */
#define EPS 0x1p-53
#define CCW_BOUND_A ((3.0 + 16.0 * EPS) * EPS)
#define O3D_BOUND_A ((7.0 + 56.0 * EPS) * EPS)

/* a + b = x + y exactly, x = fl(a + b). */
static inline void two_sum(double a, double b, double *x, double *y) {
  double s = a + b;
  double bv = s - a;
  double av = s - bv;
  *x = s;
  *y = (a - av) + (b - bv);
}

/* Same as two_sum when |a| >= |b| (or a == 0). */
static inline void fast_two_sum(double a, double b, double *x, double *y) {
  double s = a + b;
  *x = s;
  *y = b - (s - a);
}

/* a - b = x + y exactly, x = fl(a - b). */
static inline void two_diff(double a, double b, double *x, double *y) {
  double d = a - b;
  double bv = a - d;
  double av = d + bv;
  *x = d;
  *y = (a - av) + (bv - b);
}

/* a * b = x + y exactly, x = fl(a * b); fma rounds once, so y is exact. */
static inline void two_product(double a, double b, double *x, double *y) {
  double p = a * b;
  *x = p;
  *y = fma(a, b, -p);
}

/* h = e + f (Shewchuk's expansion_sum_zeroelim1); h has room for elen+flen. */
static int expansion_sum(int elen, const double *e, int flen, const double *f,
                         double *h) {
  double q = f[0], qnew;
  int hlast;
  for (int i = 0; i < elen; i++) {
    two_sum(q, e[i], &qnew, &h[i]);
    q = qnew;
  }
  h[elen] = q;
  hlast = elen;
  for (int j = 1; j < flen; j++) {
    q = f[j];
    for (int i = j; i <= hlast; i++) {
      two_sum(q, h[i], &qnew, &h[i]);
      q = qnew;
    }
    h[++hlast] = q;
  }
  int n = 0;
  for (int i = 0; i <= hlast; i++)
    if (h[i] != 0.0) h[n++] = h[i];
  if (n == 0) {
    h[0] = 0.0;
    n = 1;
  }
  return n;
}

/* h = b * e (Shewchuk's scale_expansion_zeroelim); h has room for 2*elen. */
static int scale_expansion(int elen, const double *e, double b, double *h) {
  double q, hh, p1, p0, sum;
  int n = 0;
  two_product(e[0], b, &q, &hh);
  if (hh != 0.0) h[n++] = hh;
  for (int i = 1; i < elen; i++) {
    two_product(e[i], b, &p1, &p0);
    two_sum(q, p0, &sum, &hh);
    if (hh != 0.0) h[n++] = hh;
    fast_two_sum(p1, sum, &q, &hh);
    if (hh != 0.0) h[n++] = hh;
  }
  if (q != 0.0 || n == 0) h[n++] = q;
  return n;
}

/* Longest expansion built below: a 192-term 3D determinant. */
#define EXP_MAX 192

/* h = e * f (both short); h has room for 2*elen*flen <= EXP_MAX. */
static int expansion_product(int elen, const double *e, int flen,
                             const double *f, double *h) {
  double part[EXP_MAX], acc[EXP_MAX];
  int n = scale_expansion(elen, e, f[0], h);
  for (int j = 1; j < flen; j++) {
    int np = scale_expansion(elen, e, f[j], part);
    memcpy(acc, h, (size_t)n * sizeof *acc);
    n = expansion_sum(n, acc, np, part, h);
  }
  return n;
}

static void negate(int n, double *e) {
  for (int i = 0; i < n; i++) e[i] = -e[i];
}

/* Exact a*d - b*c for two-term expansions a, b, c, d; returns the length. */
static int exact_minor(const double *a, const double *b, const double *c,
                       const double *d, double *h) {
  double ad[8], bc[8];
  int nad = expansion_product(2, a, 2, d, ad);
  int nbc = expansion_product(2, b, 2, c, bc);
  negate(nbc, bc);
  return expansion_sum(nad, ad, nbc, bc, h);
}

/* p - q as a two-term expansion {low, high}. */
static void diff_expansion(double p, double q, double *h) {
  two_diff(p, q, &h[1], &h[0]);
}

static double orient2d_exact(const double *a, const double *b,
                             const double *c) {
  double ux[2], uy[2], vx[2], vy[2], h[16];
  diff_expansion(b[0], a[0], ux);
  diff_expansion(b[1], a[1], uy);
  diff_expansion(c[0], a[0], vx);
  diff_expansion(c[1], a[1], vy);
  int n = exact_minor(ux, uy, vx, vy, h);
  return h[n - 1];
}

static double orient3d_exact(const double *a, const double *b, const double *c,
                             const double *d) {
  double u[3][2], v[3][2], w[3][2];
  for (int k = 0; k < 3; k++) {
    diff_expansion(b[k], a[k], u[k]);
    diff_expansion(c[k], a[k], v[k]);
    diff_expansion(d[k], a[k], w[k]);
  }
  /* det = ux (vy wz - vz wy) + uy (vz wx - vx wz) + uz (vx wy - vy wx) */
  double minor[16], term[3][64], s01[128], det[EXP_MAX];
  int nterm[3];
  for (int k = 0; k < 3; k++) {
    int k1 = (k + 1) % 3, k2 = (k + 2) % 3;
    int nm = exact_minor(v[k1], v[k2], w[k1], w[k2], minor);
    nterm[k] = expansion_product(2, u[k], nm, minor, term[k]);
  }
  int n01 = expansion_sum(nterm[0], term[0], nterm[1], term[1], s01);
  int n = expansion_sum(n01, s01, nterm[2], term[2], det);
  return det[n - 1];
}

double pa__orient2d(const double *a, const double *b, const double *c) {
  double l = (b[0] - a[0]) * (c[1] - a[1]);
  double r = (b[1] - a[1]) * (c[0] - a[0]);
  double det = l - r;
  double bound = CCW_BOUND_A * (fabs(l) + fabs(r));
  if (det > bound || -det > bound) return det;
  return orient2d_exact(a, b, c);
}

double pa__orient3d(const double *a, const double *b, const double *c,
                    const double *d) {
  double ux = b[0] - a[0], uy = b[1] - a[1], uz = b[2] - a[2];
  double vx = c[0] - a[0], vy = c[1] - a[1], vz = c[2] - a[2];
  double wx = d[0] - a[0], wy = d[1] - a[1], wz = d[2] - a[2];
  double vywz = vy * wz, vzwy = vz * wy;
  double vzwx = vz * wx, vxwz = vx * wz;
  double vxwy = vx * wy, vywx = vy * wx;
  double det = ux * (vywz - vzwy) + uy * (vzwx - vxwz) + uz * (vxwy - vywx);
  double perm = fabs(ux) * (fabs(vywz) + fabs(vzwy)) +
                fabs(uy) * (fabs(vzwx) + fabs(vxwz)) +
                fabs(uz) * (fabs(vxwy) + fabs(vywx));
  double bound = O3D_BOUND_A * perm;
  if (det > bound || -det > bound) return det;
  return orient3d_exact(a, b, c, d);
}

double pa__orient(int dim, const double *const *x) {
  return dim == 2 ? pa__orient2d(x[0], x[1], x[2])
                  : pa__orient3d(x[0], x[1], x[2], x[3]);
}
