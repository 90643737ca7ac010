/*
 * levelset.c -- analytic signed distances (pa_levelset_analytic) and the
 * anisotropic metric that captures the zero set of a level set function
 * (pa_metric_from_levelset).
 *
 * Signed distances, negative inside, exact to rounding:
 *  - sphere (circle in 2D): |x - c| - R;
 *  - box of half lengths l: with q_i = |x_i - c_i| - l_i,
 *    |max(q, 0)| + min(max_i q_i, 0);
 *  - plane n.x = d: (n.x - d) / |n|;
 *  - ellipsoid (ellipse in 2D): the Euclidean distance to the closest
 *    point, by Eberly's method ("Distance from a point to an ellipse, an
 *    ellipsoid, or a hyperellipsoid", Geometric Tools, 2013): by symmetry
 *    the point is moved to the first orthant and the semi-axes sorted
 *    e_0 >= ... >= e_{n-1}; the closest point is x_i = e_i^2 y_i / (t +
 *    e_i^2), t the unique root in (-e_{n-1}^2, inf) of
 *    F(t) = sum (e_i y_i / (t + e_i^2))^2 - 1, found by bisection until the
 *    bracket cannot shrink in floating point. Points with zero coordinates
 *    (on the axes, at the centre) are the special cases of the paper: a zero
 *    coordinate keeps its x_i = 0, except along the smallest axis, where
 *    the closest point leaves the plane y_{n-1} = 0 when the point lies
 *    inside the sub-ellipsoid of the evolute. The distance is summed from
 *    x_i - y_i = -t y_i / (t + e_i^2), so that it keeps its relative
 *    accuracy close to the surface.
 *
 * The level-set metric (after Ducrot & Frey, "Anisotropic level set
 * adaptation for accurate interface capturing", IMR 2008). The gradient g
 * and the Hessian H of phi are recovered at the vertices (least squares,
 * exact for quadratics; recovery.c). The distance of a vertex to the zero
 * set is estimated to first order as dist = |phi| / |g| (exact for a signed
 * distance, and independent of the scaling of phi). Inside the band
 * dist <= band:
 *  - normal n = g / |g|, size hn = hmin + (hmax - hmin) dist / band: hmin
 *    at the interface, growing linearly to hmax at the band's edge (a
 *    growth of the gradation's kind, which the default gradation then
 *    leaves as it is; hmin across the whole band would ask for
 *    2 band / hmin layers of elements);
 *  - tangent directions: the principal directions of the iso-surface
 *    through the vertex, eigenvectors of B = T^T H T / |g| (T an orthonormal
 *    basis of the plane normal to n; in 2D the one tangent t and
 *    kappa = t^T H t / |g|), with the chord sizes h = sqrt(8 eps / |kappa|)
 *    clamped to [hmin, hmax] (a piecewise linear interpolation of a curve
 *    of curvature kappa with chords of length h stays within kappa h^2 / 8
 *    of it). The curvature is that of the iso-surface through the vertex,
 *    not the zero set's: carrying the zero set's curvature along the normal
 *    (kappa0 = kappa / (1 - kappa phi / |g|) for a signed distance) was
 *    measured to cost 40 % more tetrahedra on a sphere (the outer part of
 *    the band keeps the interface's sizes) for the same distance to the
 *    surface, which only the elements at the interface set.
 * Outside the band the metric is isotropic hmax. Then the whole metric is
 * graded with o->hgrad (gradation.c; sizes only shrink). Before the
 * gradation the metric of a vertex depends only on phi over its recovery
 * stencil. Measured (tests/unit/test_levelset.c): after two rounds of
 * adaptation from a box, the linear zero crossings of the mesh edges lie
 * within 0.85-1.9 eps of circles, ellipses, spheres and ellipsoids (mean
 * 0.15-0.35 eps).
 *
 * The default band is LS_BAND_HMAX hmax (see there). A vertex with phi = 0
 * and a zero recovered gradient (the zero set through a critical point of
 * phi: no normal) gets the isotropic size hmin.
 *
 * Invariants: every output tensor is SPD with eigenvalues in
 * [1/hmax^2, 1/hmin^2] before the gradation (which keeps them SPD and
 * only shrinks sizes); the functions are not collective, allocate only
 * their work arrays and leave the mesh unchanged (the recovery may build
 * its cached vertex balls).
 */
#include "metric/gradation.h"

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>

/* Default band half-width, in units of hmax. With the linear normal law the
 * normal size grows by (hmax - hmin) / band <= 0.2 per unit length, gentler
 * than the default gradation (ln 1.3 = 0.26), so the gradation leaves the
 * normal sizes as they are; and the vertices of coarse elements of size up
 * to hmax that the interface crosses (within sqrt(3) hmax of it) lie well
 * inside the band. Measured against 3 hmax (two rounds of adaptation of
 * random circles, ellipses, spheres and ellipsoids): 3 hmax gives 20 %
 * fewer elements and a 10 % larger largest distance of the discrete zero
 * set to the surface. */
#define LS_BAND_HMAX 5.0
/* Largest hmax / hmin: sizes in that ratio keep the tensors SPD to working
 * precision (pa__metric_valid accepts eigenvalue ratios up to
 * 1 / (64 DBL_EPSILON), about 7e13). */
#define LS_MAX_ANISO 1e6
/* Bisection steps for the ellipsoid root: enough to exhaust the doubles
 * between any two bounds (53 mantissa bits + 1021 binary exponents, as in
 * Eberly's code); the loop stops much earlier, when the midpoint equals a
 * bound. */
#define LS_BISECT_MAXIT 1100

/* ---- analytic signed distances ----------------------------------------- */

enum { LS_SPHERE, LS_ELLIPSOID, LS_BOX, LS_PLANE };

typedef struct ls_shape {
  int kind, dim;
  double p[4]; /* R | semi-axes | half lengths | normal and d */
  double c[3]; /* centre (not for planes) */
} ls_shape;

/* The squared distance from y to the ellipsoid of the n (>= 1) semi-axes e
 * (sorted decreasing, y_i > 0 for every i), from the root s of
 * F(s) = sum_i (p_i z_i / (s + p_i))^2 - 1 with p_i = (e_i / e_{n-1})^2,
 * z_i = y_i / e_i, s = t / e_{n-1}^2 (Eberly's Bisector). */
static double ell_bisect(int n, const double *e, const double *y) {
  double z[3] = {0, 0, 0}, p[3] = {1, 1, 1}, num[3] = {0, 0, 0};
  double sumz = 0, nnum = 0;
  double emin = e[n - 1];
  for (int i = 0; i < n; i++) {
    z[i] = y[i] / e[i];
    sumz += z[i] * z[i];
    p[i] = (e[i] / emin) * (e[i] / emin);
    num[i] = p[i] * z[i];
    nnum += num[i] * num[i];
  }
  if (sumz == 1.0) return 0.0;
  double s0 = z[n - 1] - 1.0, s1 = sumz < 1.0 ? 0.0 : sqrt(nnum) - 1.0;
  double s = 0.0;
  for (int it = 0; it < LS_BISECT_MAXIT; it++) {
    s = 0.5 * (s0 + s1);
    if (s == s0 || s == s1) break;
    double f = -1.0;
    for (int i = 0; i < n; i++) {
      double r = num[i] / (s + p[i]);
      f += r * r;
    }
    if (f > 0.0)
      s0 = s;
    else if (f < 0.0)
      s1 = s;
    else
      break;
  }
  /* x_i - y_i = -s y_i / (s + p_i) */
  double d2 = 0.0;
  for (int i = 0; i < n; i++) {
    double r = s * y[i] / (s + p[i]);
    d2 += r * r;
  }
  return d2;
}

/* Unsigned distance from y (y_i >= 0) to the ellipsoid of semi-axes e
 * (sorted decreasing), n = 2 or 3 (Eberly's SqrDistanceSpecial). */
static double ell_dist_orthant(int n, const double *e, const double *y) {
  double ep[3], yp[3];
  int np = 0;
  for (int i = 0; i < n; i++)
    if (y[i] > 0.0) {
      ep[np] = e[i];
      yp[np] = y[i];
      np++;
    }
  if (y[n - 1] > 0.0) return sqrt(ell_bisect(np, ep, yp));
  /* y_{n-1} = 0: the closest point leaves that plane when y lies inside the
   * sub-ellipsoid of semi-axes (e_i^2 - e_{n-1}^2) / e_i (the test on the
   * box first guards the division when e_i = e_{n-1}) */
  double emin2 = e[n - 1] * e[n - 1], xde[3], discr = 1.0;
  int inside = 1;
  for (int i = 0; i < np && inside; i++) {
    double numer = ep[i] * yp[i], denom = ep[i] * ep[i] - emin2;
    if (numer >= denom)
      inside = 0;
    else {
      xde[i] = numer / denom;
      discr -= xde[i] * xde[i];
    }
  }
  if (inside && discr > 0.0) {
    double d2 = emin2 * discr; /* (x_{n-1} - 0)^2 */
    for (int i = 0; i < np; i++) {
      double r = ep[i] * xde[i] - yp[i];
      d2 += r * r;
    }
    return sqrt(d2);
  }
  return np ? sqrt(ell_bisect(np, ep, yp)) : 0.0;
}

/* Signed distance from x to the ellipsoid of semi-axes a centred at c. */
static double ell_signed_dist(int n, const double *a, const double *c,
                              const double *x) {
  /* first orthant, axes sorted decreasing (insertion sort of n <= 3) */
  double e[3], y[3], g = -1.0;
  for (int i = 0; i < n; i++) {
    double yi = fabs(x[i] - c[i]), ei = a[i];
    g += (yi / ei) * (yi / ei);
    int j = i;
    while (j > 0 && e[j - 1] < ei) {
      e[j] = e[j - 1];
      y[j] = y[j - 1];
      j--;
    }
    e[j] = ei;
    y[j] = yi;
  }
  double d = ell_dist_orthant(n, e, y);
  return g < 0.0 ? -d : d;
}

static double shape_signed_dist(const ls_shape *s, const double *x) {
  int n = s->dim;
  switch (s->kind) {
  case LS_SPHERE: {
    double r2 = 0.0;
    for (int i = 0; i < n; i++)
      r2 += (x[i] - s->c[i]) * (x[i] - s->c[i]);
    return sqrt(r2) - s->p[0];
  }
  case LS_ELLIPSOID:
    return ell_signed_dist(n, s->p, s->c, x);
  case LS_BOX: {
    double out2 = 0.0, qmax = -INFINITY;
    for (int i = 0; i < n; i++) {
      double q = fabs(x[i] - s->c[i]) - s->p[i];
      if (q > 0.0) out2 += q * q;
      qmax = fmax(qmax, q);
    }
    return sqrt(out2) + fmin(qmax, 0.0);
  }
  default: { /* LS_PLANE, normalised when parsed */
    double d = -s->p[n];
    for (int i = 0; i < n; i++)
      d += s->p[i] * x[i];
    return d;
  }
  }
}

/* Parse up to max comma-separated numbers from *s, which ends at ':' or at
 * the end of the string; *s is left on that character. Returns the count,
 * or -1 (why filled) if one is not a finite number. */
static int parse_numbers(const char **s, double *v, int max, char *why,
                         size_t nwhy) {
  const char *q = *s;
  int n = 0;
  for (;;) {
    char *end = NULL;
    errno = 0;
    double x = strtod(q, &end);
    if (end == q || isspace((unsigned char)*q) || errno == ERANGE ||
        !isfinite(x) || (*end != ',' && *end != ':' && *end != '\0')) {
      snprintf(why, nwhy, "value %d is not a finite number", n + 1);
      return -1;
    }
    if (n < max) v[n] = x;
    n++;
    q = end;
    if (*q != ',') break;
    q++;
  }
  *s = q;
  return n;
}

/* Parse a spec into a shape; 0 and why filled if it is not valid in dim. */
static int parse_shape(const char *spec, int dim, ls_shape *s, char *why,
                       size_t nwhy) {
  static const struct {
    const char *name;
    int kind, dims; /* bit mask of the dimensions it exists in */
  } names[] = {{"sphere", LS_SPHERE, 12},
               {"ellipsoid", LS_ELLIPSOID, 12},
               {"ellipse", LS_ELLIPSOID, 4},
               {"box", LS_BOX, 12},
               {"plane", LS_PLANE, 12}};
  memset(s, 0, sizeof *s);
  s->dim = dim;
  const char *colon = strchr(spec, ':');
  size_t len = colon ? (size_t)(colon - spec) : strlen(spec);
  int k = -1;
  for (int i = 0; i < (int)(sizeof names / sizeof *names); i++)
    if (strlen(names[i].name) == len && !strncmp(spec, names[i].name, len))
      k = i;
  if (k < 0 || !(names[k].dims & (1 << dim))) {
    snprintf(why, nwhy, "unknown %dD surface '%.*s'", dim,
             (int)(len > 40 ? 40 : len), spec);
    return 0;
  }
  s->kind = names[k].kind;
  if (!colon) {
    snprintf(why, nwhy, "no parameters after '%s'", names[k].name);
    return 0;
  }
  int want = s->kind == LS_SPHERE ? 1 : s->kind == LS_PLANE ? dim + 1 : dim;
  const char *q = colon + 1;
  int n = parse_numbers(&q, s->p, 4, why, nwhy);
  if (n < 0) return 0;
  if (n != want) {
    snprintf(why, nwhy, "'%s' takes %d parameter%s before the centre, got %d",
             names[k].name, want, want > 1 ? "s" : "", n);
    return 0;
  }
  if (*q == ':') {
    if (s->kind == LS_PLANE) {
      snprintf(why, nwhy, "a plane takes no centre");
      return 0;
    }
    q++;
    n = parse_numbers(&q, s->c, 3, why, nwhy);
    if (n < 0) return 0;
    if (n != dim || *q != '\0') {
      snprintf(why, nwhy, "the centre must have %d coordinates", dim);
      return 0;
    }
  }
  if (s->kind == LS_PLANE) {
    double nn = 0.0;
    for (int i = 0; i < dim; i++)
      nn += s->p[i] * s->p[i];
    nn = sqrt(nn);
    if (!(nn > 0.0) || !isfinite(nn)) {
      snprintf(why, nwhy, "the normal must be non-zero");
      return 0;
    }
    for (int i = 0; i <= dim; i++)
      s->p[i] /= nn;
  } else {
    for (int i = 0; i < want; i++)
      if (!(s->p[i] > 0.0)) {
        snprintf(why, nwhy, "radii, semi-axes and half lengths must be > 0");
        return 0;
      }
  }
  return 1;
}

pa_status pa_levelset_analytic(pa_mesh *mesh, const char *spec, double *phi) {
  pa_status st = PA_SUCCESS;
  ls_shape shape;
  char why[160];
  PA_CHECK(mesh && spec && phi, PA_ERR_ARG,
           "pa_levelset_analytic: NULL argument");
  int d = mesh->dim;
  PA_CHECK(parse_shape(spec, d, &shape, why, sizeof why), PA_ERR_ARG,
           "pa_levelset_analytic: bad level set '%.200s' (%s); valid %dD "
           "forms: %s",
           spec, why, d,
           d == 2 ? "sphere:R[:cx,cy] (a circle), ellipse:a,b[:cx,cy] (or "
                    "ellipsoid:a,b[:cx,cy]), box:lx,ly[:cx,cy] (half "
                    "lengths), plane:nx,ny,d (a line)"
                  : "sphere:R[:cx,cy,cz], ellipsoid:a,b,c[:cx,cy,cz], "
                    "box:lx,ly,lz[:cx,cy,cz] (half lengths), plane:nx,ny,nz,d");
  for (pa_idx v = 0; v < mesh->nv; v++)
    phi[v] = shape_signed_dist(&shape, mesh->coord + (size_t)d * v);
cleanup:
  return st;
}

/* ---- the level-set metric ---------------------------------------------- */

void pa_metric_levelset_opts_default(pa_metric_levelset_opts *o) {
  memset(o, 0, sizeof *o);
  o->hgrad = PA_DEFAULT_HGRAD;
}

/* Chord size of a curvature kappa, clamped to [hmin, hmax] (hmin if kappa
 * is not a number). */
static double curvature_size(double kappa, double eps, double hmin,
                             double hmax) {
  double h = sqrt(8.0 * eps / fabs(kappa));
  if (isnan(h)) return hmin;
  return fmin(fmax(h, hmin), hmax);
}

/* The metric at one vertex of the band: gradient g (|g| = gn > 0), Hessian
 * h (tensor), distance estimate dist; into m (tensor). */
static void band_metric(int dim, const double *g, double gn, const double *h,
                        double dist, const pa_metric_levelset_opts *o,
                        double band, double *m) {
  double lam[3], vec[9];
  double hn = o->hmin + (o->hmax - o->hmin) * fmin(dist / band, 1.0);
  double n[3] = {0, 0, 0};
  for (int i = 0; i < dim; i++)
    n[i] = g[i] / gn;
  /* orthonormal tangent basis t[0..dim-2] */
  double t[2][3] = {{0, 0, 0}, {0, 0, 0}};
  if (dim == 2) {
    t[0][0] = -n[1];
    t[0][1] = n[0];
  } else {
    /* the coordinate axis least aligned with n, made orthogonal to it */
    int k = 0;
    for (int i = 1; i < 3; i++)
      if (fabs(n[i]) < fabs(n[k])) k = i;
    double a[3] = {0, 0, 0}, tn = 0;
    a[k] = 1.0;
    for (int i = 0; i < 3; i++)
      t[0][i] = a[i] - n[k] * n[i];
    for (int i = 0; i < 3; i++)
      tn += t[0][i] * t[0][i];
    tn = sqrt(tn);
    for (int i = 0; i < 3; i++)
      t[0][i] /= tn;
    t[1][0] = n[1] * t[0][2] - n[2] * t[0][1];
    t[1][1] = n[2] * t[0][0] - n[0] * t[0][2];
    t[1][2] = n[0] * t[0][1] - n[1] * t[0][0];
  }
  /* B = T^T H T / |g| */
  double b[3];
  for (int p = 0; p < dim - 1; p++)
    for (int q = p; q < dim - 1; q++) {
      double acc = 0.0;
      for (int i = 0; i < dim; i++)
        for (int j = 0; j < dim; j++)
          acc += t[p][i] * h[pa__sym_index(i, j)] * t[q][j];
      b[pa__sym_index(p, q)] = acc / gn;
    }
  lam[0] = 1.0 / (hn * hn);
  for (int i = 0; i < dim; i++)
    vec[i] = n[i];
  if (dim == 2) {
    double ht = curvature_size(b[0], o->eps, o->hmin, o->hmax);
    lam[1] = 1.0 / (ht * ht);
    for (int i = 0; i < 2; i++)
      vec[2 + i] = t[0][i];
  } else {
    double kap[2], w[4];
    pa__sym_eigen(2, b, kap, w);
    for (int k = 0; k < 2; k++) {
      double ht = curvature_size(kap[k], o->eps, o->hmin, o->hmax);
      lam[1 + k] = 1.0 / (ht * ht);
      for (int i = 0; i < 3; i++)
        vec[3 * (1 + k) + i] = w[2 * k] * t[0][i] + w[2 * k + 1] * t[1][i];
    }
  }
  pa__sym_from_eigen(dim, lam, vec, m);
}

static void iso_metric(int dim, double hsz, double *m) {
  int nt = pa__tensor_ncomp(dim);
  for (int k = 0; k < nt; k++)
    m[k] = 0.0;
  for (int i = 0; i < dim; i++)
    m[pa__sym_index(i, i)] = 1.0 / (hsz * hsz);
}

pa_status pa_metric_from_levelset(pa_mesh *mesh, const double *phi,
                                  const pa_metric_levelset_opts *o,
                                  double *met) {
  pa_status st = PA_SUCCESS;
  double *grad = NULL, *hess = NULL;
  PA_CHECK(mesh && phi && o && met, PA_ERR_ARG,
           "pa_metric_from_levelset: NULL argument");
  PA_CHECK(isfinite(o->eps) && o->eps > 0, PA_ERR_ARG,
           "pa_metric_from_levelset: eps (the distance bound) must be a "
           "positive number, got %g",
           o->eps);
  PA_CHECK(isfinite(o->hmin) && o->hmin > 0, PA_ERR_ARG,
           "pa_metric_from_levelset: hmin must be a positive number, got %g",
           o->hmin);
  PA_CHECK(isfinite(o->hmax) && o->hmax >= o->hmin, PA_ERR_ARG,
           "pa_metric_from_levelset: hmax (%g) must be a number >= hmin (%g)",
           o->hmax, o->hmin);
  PA_CHECK(o->hmax <= LS_MAX_ANISO * o->hmin, PA_ERR_ARG,
           "pa_metric_from_levelset: hmax / hmin = %g exceeds %g",
           o->hmax / o->hmin, LS_MAX_ANISO);
  PA_CHECK(isfinite(o->band) && isfinite(o->hgrad), PA_ERR_ARG,
           "pa_metric_from_levelset: band (%g) and hgrad (%g) must be numbers",
           o->band, o->hgrad);
  int d = mesh->dim, nt = pa__tensor_ncomp(d);
  pa_idx nv = mesh->nv;
  for (pa_idx v = 0; v < nv; v++)
    PA_CHECK(isfinite(phi[v]), PA_ERR_ARG,
             "pa_metric_from_levelset: the level set value at vertex %ld is "
             "not finite",
             (long)v + 1);
  double band = o->band > 0 ? o->band : LS_BAND_HMAX * o->hmax;
  size_t n = nv ? (size_t)nv : 1;
  PA_ALLOC(grad, n * d);
  PA_ALLOC(hess, n * nt);
  PA_CALL(pa__recover(mesh, phi, 1, PA_RECOVER_LSQ, NULL, grad, hess));
  for (pa_idx v = 0; v < nv; v++) {
    const double *g = grad + (size_t)d * v;
    double *m = met + (size_t)nt * v;
    double gn = 0.0;
    for (int i = 0; i < d; i++)
      gn += g[i] * g[i];
    gn = sqrt(gn);
    double dist = gn > 0 ? fabs(phi[v]) / gn : phi[v] == 0 ? 0 : INFINITY;
    if (!(dist <= band))
      iso_metric(d, o->hmax, m);
    else if (!(gn > 0) || !isfinite(gn))
      iso_metric(d, o->hmin, m);
    else
      band_metric(d, g, gn, hess + (size_t)nt * v, dist, o, band, m);
  }
  PA_CALL(pa__metric_gradation(d, nt, nv, mesh->coord, met, mesh->ne,
                               mesh->elem, NULL, o->hgrad, 0, NULL));
cleanup:
  pa__free(grad);
  pa__free(hess);
  return st;
}
