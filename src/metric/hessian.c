/*
 * hessian.c -- the metric that minimises the Lp norm of the linear
 * interpolation error of a scalar field for a given number of vertices
 * (Loseille & Alauzet, "Continuous mesh framework", part II: the multiscale
 * metric), from its Hessian recovered at the vertices (recovery.c).
 *
 *   M = D det(|H|)^(-1/(2p+d)) |H|,
 *
 * |H| the Hessian with absolute eigenvalues (floored at HESS_FLOOR times the
 * largest over the mesh, so that flat regions get finite, large sizes that
 * the clamp to hmax then bounds). The global factor D is set so that the
 * complexity (ops.c) equals the target N, or so that the estimated error
 *
 *   e = c_d ( integral of (d D^-1 det|H|^(1/(2p+d)))^p )^(1/p),
 *
 * (the continuous interpolation error of M, trace(M^-1/2 |H| M^-1/2) times
 * c_d = 1/8 in 2D, 1/10 in 3D) equals the target error; L-infinity (p <= 0):
 * M = D |H|, e = c_d d / D. An error target thus sets the complexity of the
 * unclamped optimal metric. Then sizes are clamped to [hmin, hmax] and
 * graded, which changes the complexity, so D is corrected and the three
 * steps repeated until the complexity is within HESS_TOL of its target
 * (scaling M by s^2 scales the complexity by s^d; at most HESS_MAXIT
 * rounds: a target hmin or hmax cannot reach stays missed, the
 * complexity reached is what pa_metric_complexity then reports).
 */
#include "metric/gradation.h"

#include <math.h>

/* Eigenvalues of |H| below this times the largest over the mesh are
 * raised to it: the metric stays definite where the field is flat. */
#define HESS_FLOOR 1e-12
#define HESS_TOL 1e-3
#define HESS_MAXIT 30

void pa_metric_hessian_opts_default(pa_metric_hessian_opts *o) {
  memset(o, 0, sizeof *o);
  o->p = PA_DEFAULT_LP;
  o->hgrad = PA_DEFAULT_HGRAD;
  o->recovery = PA_RECOVER_LSQ;
}

void pa__lp_metric(int dim, const double *h, double p, double lmin, double *m) {
  double lam[3], vec[9], det = 1;
  pa__sym_eigen(dim, h, lam, vec);
  for (int k = 0; k < dim; k++) {
    lam[k] = fmax(fabs(lam[k]), lmin);
    det *= lam[k];
  }
  double s = p > 0 ? pow(det, -1.0 / (2 * p + dim)) : 1.0;
  for (int k = 0; k < dim; k++)
    lam[k] *= s;
  pa__sym_from_eigen(dim, lam, vec, m);
}

/* The error constant c_d of the continuous interpolation error. */
static double err_const(int dim) { return dim == 2 ? 1.0 / 8.0 : 1.0 / 10.0; }

/* The factor D that gives the estimated Lp error err for the unscaled
 * metric base (pa__lp_metric of |H|, det of |H| in hdet). */
static pa_status factor_for_error(const pa__metric_ctx *c, const double *hdet,
                                  double p, double err, double *dfac) {
  pa_mesh *mesh = c->mesh;
  int d = mesh->dim, nve = d + 1;
  double cd = err_const(d);
  if (!(p > 0)) {
    *dfac = cd * d / err;
    return PA_SUCCESS;
  }
  /* e^p = (c_d d / D)^p integral of det|H|^(p/(2p+d)) */
  double integral = 0;
  for (pa_idx e = 0; e < c->nelem; e++) {
    const pa_idx *v = mesh->elem + (size_t)nve * e;
    const double *x[4];
    double s = 0;
    for (int k = 0; k < nve; k++) {
      x[k] = mesh->coord + (size_t)d * v[k];
      s += pow(hdet[v[k]], p / (2 * p + d));
    }
    integral += fabs(pa__simplex_volume(d, x)) * s / nve;
  }
  pa_status st = c->sum(c->ctx, &integral);
  *dfac = cd * d * pow(integral, 1.0 / p) / err;
  return st;
}

static pa_status complexity_of(const pa__metric_ctx *c, int nt, const double *m,
                               double *cx) {
  double s = 0;
  for (pa_idx e = 0; e < c->nelem; e++)
    s += pa__elem_complexity(c->mesh, nt, m, e);
  *cx = s;
  return c->sum(c->ctx, cx);
}

pa_status pa__metric_from_hessian(const pa__metric_ctx *c, const double *h,
                                  const pa_metric_hessian_opts *o,
                                  double *met) {
  pa_status st = PA_SUCCESS;
  double *base = NULL, *hdet = NULL;
  uint8_t *frozen = NULL;
  pa_mesh *mesh = c->mesh;
  int d = mesh->dim, nt = pa__tensor_ncomp(d);
  pa_idx nv = mesh->nv;
  size_t n = nv ? (size_t)nv : 1;
  PA_CHECK((o->target > 0) != (o->err > 0), PA_ERR_ARG,
           "pa_metric_from_hessian: give either a target complexity or a "
           "target error (> 0), not both");
  PA_CHECK(isfinite(o->target) && isfinite(o->err) && isfinite(o->p) &&
               isfinite(o->hmin) && isfinite(o->hmax) && isfinite(o->hgrad),
           PA_ERR_ARG, "pa_metric_from_hessian: options must be numbers");
  PA_CHECK(!(o->hmin > 0 && o->hmax > 0 && o->hmin > o->hmax), PA_ERR_ARG,
           "pa_metric_from_hessian: hmin (%g) is larger than hmax (%g)",
           o->hmin, o->hmax);
  PA_ALLOC(base, n * nt);
  PA_ALLOC(hdet, n);
  double lmax = 0;
  for (pa_idx v = 0; v < nv; v++) {
    double lam[3], vec[9];
    pa__sym_eigen(d, h + (size_t)nt * v, lam, vec);
    for (int k = 0; k < d; k++)
      lmax = fmax(lmax, fabs(lam[k]));
  }
  PA_CALL(c->max(c->ctx, &lmax));
  PA_CHECK(lmax > 0, PA_ERR_ARG,
           "pa_metric_from_hessian: the field's Hessian is zero everywhere "
           "(a linear field has no interpolation error to balance)");
  if (o->hgrad > 1) PA_CALL(c->frozen(c->ctx, &frozen));
  double lmin = HESS_FLOOR * lmax;
  for (pa_idx v = 0; v < nv; v++) {
    double lam[3], vec[9], det = 1;
    pa__sym_eigen(d, h + (size_t)nt * v, lam, vec);
    for (int k = 0; k < d; k++)
      det *= fmax(fabs(lam[k]), lmin);
    hdet[v] = det;
    pa__lp_metric(d, h + (size_t)nt * v, o->p, lmin, base + (size_t)nt * v);
  }
  /* D: from the error, or from the target complexity of the base */
  double c0, dfac, target = o->target;
  PA_CALL(complexity_of(c, nt, base, &c0));
  PA_CHECK(c0 > 0, PA_ERR_METRIC, "pa_metric_from_hessian: no complexity");
  if (o->err > 0) {
    PA_CALL(factor_for_error(c, hdet, o->p, o->err, &dfac));
    target = pow(dfac, 0.5 * d) * c0; /* before clamping and gradation */
  } else {
    dfac = pow(target / c0, 2.0 / d);
  }
  for (int it = 0; it < HESS_MAXIT; it++) {
    for (pa_idx v = 0; v < nv; v++) {
      double *m = met + (size_t)nt * v;
      for (int k = 0; k < nt; k++)
        m[k] = dfac * base[(size_t)nt * v + k];
      pa__metric_clamp(d, nt, m, o->hmin, o->hmax);
    }
    if (o->hgrad > 1)
      PA_CALL(c->grade(c->ctx, nt, met, frozen, o->hgrad, 0, NULL));
    double cm;
    PA_CALL(complexity_of(c, nt, met, &cm));
    if (!(cm > 0) || fabs(cm / target - 1) <= HESS_TOL) break;
    dfac *= pow(target / cm, 2.0 / d);
  }
cleanup:
  pa__free(base);
  pa__free(hdet);
  pa__free(frozen);
  return st;
}

pa_status pa_metric_from_hessian(pa_mesh *mesh, const double *u, int stride,
                                 const pa_metric_hessian_opts *o, double *met) {
  pa_status st = PA_SUCCESS;
  double *h = NULL;
  PA_CHECK(mesh && u && o && met, PA_ERR_ARG,
           "pa_metric_from_hessian: NULL argument");
  PA_ALLOC(h, (size_t)pa__tensor_ncomp(mesh->dim) * (mesh->nv ? mesh->nv : 1));
  PA_CALL(pa__recover(mesh, u, stride, o->recovery, NULL, NULL, h));
  pa__metric_ctx c;
  pa__metric_ctx_seq(mesh, &c);
  PA_CALL(pa__metric_from_hessian(&c, h, o, met));
cleanup:
  pa__free(h);
  return st;
}
