/*
 * recovery.c -- gradient and Hessian of a scalar vertex field, at the
 * vertices (pa_mesh_recover; pa__recover for a subset, which the distributed
 * metric commands use on their owned vertices).
 *
 * PA_RECOVER_LSQ: at vertex p, with d_j = x_j - x_p and du_j = u_j - u_p over
 * its neighbours j, the weighted least-squares fit of
 *     du_j = g . d_j + 1/2 d_j^T H d_j
 * (2 + 3 unknowns in 2D, 3 + 6 in 3D), weights 1/|d_j|^2, the unknowns
 * scaled by the mean neighbour distance so that the normal equations are
 * well conditioned (Cholesky). The neighbours are the 1-ring (vertices
 * sharing an element with p); where it holds fewer than RECOVER_MIN_RATIO
 * times the unknowns (boundary and corner vertices), the 2-ring. Exact for
 * quadratic fields whenever the stencil determines the fit; a vertex whose
 * 2-ring still does not (a degenerate stencil) gets a zero Hessian and the
 * L2 gradient of its ball.
 *
 * PA_RECOVER_L2: the double L2 projection: the gradient of u is constant on
 * each element; its volume-weighted mean over a vertex's ball is the
 * recovered gradient; the same applied to each recovered gradient component
 * gives the Hessian (symmetrised). Exact for linear fields only; cheaper,
 * and local to the ball.
 *
 * Measured (tests/unit/test_recovery.c, boxes with randomly moved interior
 * vertices): LSQ recovers the Hessian of a quadratic to 2e-13 at every
 * vertex, boundary included; on sin 4x cos 3y (+ z^2 e^x in 3D) its mean
 * relative error at interior vertices is 0.024 in 2D and 0.053 in 3D,
 * against 0.133 and 0.086 for L2. LSQ is the default; L2 is about twice as
 * cheap and needs only the ball.
 */
#include "metric/metric.h"

#include <math.h>

/* Fewer 1-ring neighbours than this times the unknowns: use the 2-ring. */
#define RECOVER_MIN_RATIO 1.5
#define RECOVER_MAXNB 512

int pa__cholesky_solve(int n, double *a, double *b) {
  double dmax = 0;
  for (int i = 0; i < n; i++)
    dmax = fmax(dmax, a[n * i + i]);
  for (int j = 0; j < n; j++) {
    double s = a[n * j + j];
    for (int k = 0; k < j; k++)
      s -= a[n * j + k] * a[n * j + k];
    if (!(s > 1e-12 * dmax)) return 0;
    double l = sqrt(s);
    a[n * j + j] = l;
    for (int i = j + 1; i < n; i++) {
      double t = a[n * i + j];
      for (int k = 0; k < j; k++)
        t -= a[n * i + k] * a[n * j + k];
      a[n * i + j] = t / l;
    }
  }
  for (int i = 0; i < n; i++) { /* L y = b */
    double t = b[i];
    for (int k = 0; k < i; k++)
      t -= a[n * i + k] * b[k];
    b[i] = t / a[n * i + i];
  }
  for (int i = n - 1; i >= 0; i--) { /* L^T x = y */
    double t = b[i];
    for (int k = i + 1; k < n; k++)
      t -= a[n * k + i] * b[k];
    b[i] = t / a[n * i + i];
  }
  return 1;
}

/* Add the vertices of the elements around v (not in seen) to nb[n..);
 * returns the new count (at most RECOVER_MAXNB: the rest is dropped). */
static int add_ring(const pa_mesh *m, const pa_idx *start, const pa_idx *ball,
                    pa_idx v, pa_idx *nb, int n, uint8_t *seen) {
  int nve = m->dim + 1;
  for (pa_idx i = start[v]; i < start[v + 1]; i++) {
    const pa_idx *e = m->elem + (size_t)nve * ball[i];
    for (int k = 0; k < nve && n < RECOVER_MAXNB; k++) {
      pa_idx w = e[k];
      if (seen[w]) continue;
      seen[w] = 1;
      nb[n++] = w;
    }
  }
  return n;
}

/* The least-squares fit at p over nb[0..n); 0 if the stencil does not
 * determine it. g: dim values, h: tensor. */
static int lsq_fit(const pa_mesh *m, const double *u, int stride, pa_idx p,
                   const pa_idx *nb, int n, double *g, double *h) {
  int d = m->dim, nu = d == 2 ? 5 : 9;
  const double *xp = m->coord + (size_t)d * p;
  double up = u[(size_t)stride * p], scale = 0;
  for (int j = 0; j < n; j++) {
    const double *xj = m->coord + (size_t)d * nb[j];
    double s = 0;
    for (int k = 0; k < d; k++)
      s += (xj[k] - xp[k]) * (xj[k] - xp[k]);
    scale += sqrt(s);
  }
  if (n < nu || !(scale > 0)) return 0;
  scale /= n;
  double a[81] = {0}, b[9] = {0};
  for (int j = 0; j < n; j++) {
    const double *xj = m->coord + (size_t)d * nb[j];
    double e[3] = {0, 0, 0}, r[9], s2 = 0;
    for (int k = 0; k < d; k++) {
      e[k] = (xj[k] - xp[k]) / scale;
      s2 += e[k] * e[k];
    }
    if (!(s2 > 0)) continue;
    /* row: gradient, then the Hessian in storage order xx xy yy xz yz zz */
    for (int k = 0; k < d; k++)
      r[k] = e[k];
    for (int i = 0; i < d; i++)
      for (int k = i; k < d; k++)
        r[d + pa__sym_index(i, k)] = i == k ? 0.5 * e[i] * e[i] : e[i] * e[k];
    double w = 1.0 / s2, du = u[(size_t)stride * nb[j]] - up;
    for (int i = 0; i < nu; i++) {
      b[i] += w * r[i] * du;
      for (int k = 0; k < nu; k++)
        a[nu * i + k] += w * r[i] * r[k];
    }
  }
  if (!pa__cholesky_solve(nu, a, b)) return 0;
  for (int k = 0; k < d; k++)
    g[k] = b[k] / scale;
  for (int k = 0; k < pa__tensor_ncomp(d); k++)
    h[k] = b[d + k] / (scale * scale);
  return 1;
}

/* Gradient of u on element e (constant), and the element's volume. */
static double elem_gradient(const pa_mesh *m, const double *u, int stride,
                            pa_idx e, double *g) {
  int d = m->dim, nve = d + 1;
  const pa_idx *v = m->elem + (size_t)nve * e;
  const double *x0 = m->coord + (size_t)d * v[0];
  double j[3][3], du[3];
  for (int i = 0; i < d; i++) {
    const double *xi = m->coord + (size_t)d * v[i + 1];
    for (int k = 0; k < d; k++)
      j[i][k] = xi[k] - x0[k];
    du[i] = u[(size_t)stride * v[i + 1]] - u[(size_t)stride * v[0]];
  }
  /* solve J g = du (rows: edge vectors) by Cramer */
  double det;
  if (d == 2) {
    det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
    if (det == 0) return g[0] = g[1] = 0, 0;
    g[0] = (du[0] * j[1][1] - j[0][1] * du[1]) / det;
    g[1] = (j[0][0] * du[1] - du[0] * j[1][0]) / det;
    return 0.5 * fabs(det);
  }
  double c[3][3];
  c[0][0] = j[1][1] * j[2][2] - j[1][2] * j[2][1];
  c[0][1] = j[1][2] * j[2][0] - j[1][0] * j[2][2];
  c[0][2] = j[1][0] * j[2][1] - j[1][1] * j[2][0];
  c[1][0] = j[0][2] * j[2][1] - j[0][1] * j[2][2];
  c[1][1] = j[0][0] * j[2][2] - j[0][2] * j[2][0];
  c[1][2] = j[0][1] * j[2][0] - j[0][0] * j[2][1];
  c[2][0] = j[0][1] * j[1][2] - j[0][2] * j[1][1];
  c[2][1] = j[0][2] * j[1][0] - j[0][0] * j[1][2];
  c[2][2] = j[0][0] * j[1][1] - j[0][1] * j[1][0];
  det = j[0][0] * c[0][0] + j[0][1] * c[0][1] + j[0][2] * c[0][2];
  if (det == 0) return g[0] = g[1] = g[2] = 0, 0;
  /* g = J^-1 du, J^-1 = C^T / det (C the cofactors of J's entries) */
  for (int k = 0; k < 3; k++)
    g[k] = (c[0][k] * du[0] + c[1][k] * du[1] + c[2][k] * du[2]) / det;
  return fabs(det) / 6.0;
}

/* Volume-weighted mean of the element gradients of u around v. */
static void ball_gradient(const pa_mesh *m, const double *u, int stride,
                          const pa_idx *start, const pa_idx *ball, pa_idx v,
                          double *g) {
  int d = m->dim;
  double s = 0, acc[3] = {0, 0, 0}, ge[3];
  for (pa_idx i = start[v]; i < start[v + 1]; i++) {
    double w = elem_gradient(m, u, stride, ball[i], ge);
    for (int k = 0; k < d; k++)
      acc[k] += w * ge[k];
    s += w;
  }
  for (int k = 0; k < d; k++)
    g[k] = s > 0 ? acc[k] / s : 0;
}

pa_status pa__recover(pa_mesh *mesh, const double *u, int stride,
                      pa_recovery method, const uint8_t *mask, double *grad,
                      double *hess) {
  pa_status st = PA_SUCCESS;
  const pa_idx *start = NULL, *ball = NULL;
  uint8_t *seen = NULL;
  double *g1 = NULL;
  int d = mesh->dim, nt = pa__tensor_ncomp(d), nu = d == 2 ? 5 : 9;
  pa_idx nv = mesh->nv;
  PA_CHECK(u && stride >= 1, PA_ERR_ARG, "pa_mesh_recover: bad field");
  PA_CHECK(method == PA_RECOVER_LSQ || method == PA_RECOVER_L2, PA_ERR_ARG,
           "pa_mesh_recover: unknown method %d", (int)method);
  for (pa_idx v = 0; v < nv; v++)
    PA_CHECK(isfinite(u[(size_t)stride * v]), PA_ERR_ARG,
             "pa_mesh_recover: the value at vertex %ld is not finite",
             (long)v + 1);
  PA_CALL(pa_mesh_build_balls(mesh, &start, &ball));
  if (method == PA_RECOVER_L2) {
    /* gradient everywhere (the Hessian needs the neighbours' too) */
    PA_ALLOC(g1, (size_t)d * (nv ? nv : 1));
    for (pa_idx v = 0; v < nv; v++)
      ball_gradient(mesh, u, stride, start, ball, v, g1 + (size_t)d * v);
    for (pa_idx v = 0; v < nv; v++) {
      if (mask && !mask[v]) continue;
      if (grad)
        memcpy(grad + (size_t)d * v, g1 + (size_t)d * v, sizeof(double) * d);
      if (!hess) continue;
      double h[3][3], gk[3];
      for (int k = 0; k < d; k++) {
        ball_gradient(mesh, g1 + k, d, start, ball, v, gk);
        for (int i = 0; i < d; i++)
          h[k][i] = gk[i];
      }
      for (int i = 0; i < d; i++)
        for (int k = i; k < d; k++)
          hess[(size_t)nt * v + pa__sym_index(i, k)] =
              0.5 * (h[i][k] + h[k][i]);
    }
    goto cleanup;
  }
  PA_CALLOC(seen, nv ? nv : 1);
  pa_idx nb[RECOVER_MAXNB];
  for (pa_idx p = 0; p < nv; p++) {
    if (mask && !mask[p]) continue;
    double g[3], h[6];
    seen[p] = 1;
    int n = add_ring(mesh, start, ball, p, nb, 0, seen), ok = 0;
    if (n >= RECOVER_MIN_RATIO * nu)
      ok = lsq_fit(mesh, u, stride, p, nb, n, g, h);
    if (!ok) { /* the 2-ring */
      int n1 = n;
      for (int j = 0; j < n1; j++)
        n = add_ring(mesh, start, ball, nb[j], nb, n, seen);
      ok = lsq_fit(mesh, u, stride, p, nb, n, g, h);
    }
    seen[p] = 0;
    for (int j = 0; j < n; j++)
      seen[nb[j]] = 0;
    if (!ok) {
      ball_gradient(mesh, u, stride, start, ball, p, g);
      for (int k = 0; k < nt; k++)
        h[k] = 0;
    }
    if (grad) memcpy(grad + (size_t)d * p, g, sizeof(double) * d);
    if (hess) memcpy(hess + (size_t)nt * p, h, sizeof(double) * nt);
  }
cleanup:
  pa__free(seen);
  pa__free(g1);
  return st;
}

pa_status pa_mesh_recover(pa_mesh *mesh, const double *u, int stride,
                          pa_recovery method, double *grad, double *hess) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(mesh, PA_ERR_ARG, "pa_mesh_recover: NULL mesh");
  PA_CALL(pa__recover(mesh, u, stride, method, NULL, grad, hess));
cleanup:
  return st;
}
