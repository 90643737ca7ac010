/*
 * metric.c -- Riemannian metric algebra: validity, symmetric eigen-
 * decomposition, interpolation (linear in size), intersection,
 * clamping, and the dimension-generic entries of the length and quality
 * kernels (metric2d.h, metric3d.h).
 *
 * Every function here except pa_mesh_metric_clamp is an inner-loop kernel:
 * no allocation, no error reporting, fixed-size stack arrays only. Inputs are
 * assumed valid (finite, SPD): validity is checked once, by pa__metric_valid,
 * when a metric enters a mesh.
 *
 * Storage: a metric value has ncomp components, 1 = isotropic size h (tensor
 * I/h^2), 3 (2D) or 6 (3D) = symmetric tensor m11 m12 m22 [m13 m23 m33]
 * (pa__sym_index gives the slot of (i,j)). Kernels that accept a "value"
 * take (dim, ncomp, m) and have a fast path for ncomp 1; ncomp 0 stands for
 * the identity metric in pa__metric_tensor, pa__metric_sqlen,
 * pa__edge_length and pa__quality (m may then be NULL).
 *
 * Outputs may alias inputs (out == m[i] in pa__metric_interp, out == m1 or
 * m2 in pa__metric_intersect, ...): every
 * kernel reads all its inputs before writing its output.
 *
 * Eigen-decomposition: closed form in 2D (eigenvalue of larger magnitude
 * from mean +- radius, the other from an fma-accurate determinant, vector
 * from the cancellation-free row), cyclic Jacobi in 3D (quadratic
 * convergence, stops when every off-diagonal entry is below eps/2 of the
 * geometric mean of its diagonal entries, so small eigenvalues keep their
 * relative accuracy). Eigenvalues come out in descending order, eigenvectors
 * orthonormal and column-major: vector k is vec[dim*k .. dim*k+dim-1].
 */
#include "metric/metric.h"
#include "metric/metric2d.h"
#include "metric/metric3d.h"

#include <float.h>
#include <string.h>
#include <math.h>

/* Relative threshold below which an eigenvalue (or Cholesky pivot) counts as
 * zero: lambda_min must exceed REL_PD * lambda_max (anisotropy in sizes up to
 * about 8e6). */
#define REL_PD (64.0 * DBL_EPSILON)

/* Tolerance of the intersection's "one metric already contains the other"
 * shortcut, relative to the generalised eigenvalues (which are 1 there). */
#define INTERSECT_TOL 1e-10

/* ------------------------------------------------------------------------ */
/* Small helpers                                                            */
/* ------------------------------------------------------------------------ */

/* 1 if the off-diagonal entries of a full tensor are all exactly zero. */
static inline int is_diagonal(int dim, const double *m) {
  if (dim == 2) return m[1] == 0.0;
  return m[1] == 0.0 && m[3] == 0.0 && m[4] == 0.0;
}

/* ------------------------------------------------------------------------ */
/* Validity, expansion, determinant, inverse                               */
/* ------------------------------------------------------------------------ */

int pa__metric_valid(int dim, int ncomp, const double *m) {
  if (!m) return 0;
  if (ncomp == 1) return isfinite(m[0]) && m[0] > 0.0;
  if ((dim != 2 && dim != 3) || ncomp != pa__tensor_ncomp(dim)) return 0;
  for (int k = 0; k < ncomp; k++)
    if (!isfinite(m[k])) return 0;
  if (dim == 2) {
    double lambda[2], vec[4];
    pa__sym_eigen(2, m, lambda, vec);
    return isfinite(lambda[0]) && lambda[0] > 0.0 &&
           lambda[1] > REL_PD * lambda[0];
  }
  /* 3D fast accept: LDL^T pivots. Both terms subtracted from a diagonal
   * entry are >= 0, so a computed pivot above 1e-3 of its diagonal entry
   * (far above the rounding error, ~200 eps of it) proves positivity.
   * Otherwise (ill-conditioned or indefinite input, where unpivoted
   * elimination is not reliable) the backward-stable Jacobi eigenvalues
   * decide: lambda_min > REL_PD * lambda_max. */
  double a11 = m[0], a12 = m[1], a22 = m[2], a13 = m[3], a23 = m[4], a33 = m[5];
  double dmax = fmax(a11, fmax(a22, a33));
  if (!(dmax > 0.0) || !isfinite(dmax)) return 0;
  double thr = REL_PD * dmax;
  if (a11 > thr) {
    double l21 = a12 / a11, l31 = a13 / a11;
    double d2 = a22 - l21 * a12;
    if (d2 > 1e-3 * a22 && d2 > thr) {
      double l32 = (a23 - l31 * a12) / d2;
      double d3 = a33 - l31 * a13 - l32 * l32 * d2;
      if (d3 > 1e-3 * a33 && d3 > thr && isfinite(d3)) return 1;
    }
  }
  double lambda[3], vec[9];
  pa__sym_eigen(3, m, lambda, vec);
  return isfinite(lambda[0]) && lambda[0] > 0.0 &&
         lambda[2] > REL_PD * lambda[0];
}

void pa__metric_tensor(int dim, int ncomp, const double *m, double *t) {
  int nt = pa__tensor_ncomp(dim);
  if (ncomp == nt) {
    for (int k = 0; k < nt; k++)
      t[k] = m[k];
    return;
  }
  double s = ncomp == 1 ? 1.0 / (m[0] * m[0]) : 1.0;
  for (int k = 0; k < nt; k++)
    t[k] = 0.0;
  t[0] = t[2] = s;
  if (dim == 3) t[5] = s;
}

/* ------------------------------------------------------------------------ */
/* Eigen-decomposition                                                      */
/* ------------------------------------------------------------------------ */

static void eigen2(const double *m, double *lambda, double *vec) {
  double a = m[0], b = m[1], c = m[2];
  double mean = 0.5 * a + 0.5 * c, d = 0.5 * a - 0.5 * c;
  double r = hypot(d, b);
  double l1, l2;
  /* The eigenvalue of larger magnitude has no cancellation; the other one
   * comes from the determinant, accurate even when l2 << l1. */
  if (mean >= 0.0) {
    l1 = mean + r;
    l2 = l1 != 0.0 ? pa__det2_accurate(a, b, c) / l1 : 0.0;
    if (l2 > l1) l2 = l1; /* equal up to rounding */
  } else {
    l2 = mean - r;
    l1 = pa__det2_accurate(a, b, c) / l2;
    if (l1 < l2) l1 = l2;
  }
  double x, y;
  if (r == 0.0) {
    x = 1.0;
    y = 0.0;
  } else {
    if (d >= 0.0) {
      x = d + r; /* >= r > 0 */
      y = b;
    } else {
      x = b;
      y = r - d; /* > r > 0 */
    }
    double n = hypot(x, y);
    x /= n;
    y /= n;
  }
  lambda[0] = l1;
  lambda[1] = l2;
  vec[0] = x;
  vec[1] = y;
  vec[2] = -y;
  vec[3] = x;
}

static void eigen3(const double *m, double *lambda, double *vec) {
  double a[3][3] = {{m[0], m[1], m[3]}, {m[1], m[2], m[4]}, {m[3], m[4], m[5]}};
  double v[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}; /* v[row][k] */
  for (int sweep = 0; sweep < 64; sweep++) {
    int rotated = 0;
    for (int p = 0; p < 2; p++) {
      for (int q = p + 1; q < 3; q++) {
        double apq = a[p][q];
        if (apq == 0.0) continue;
        double app = a[p][p], aqq = a[q][q];
        if (fabs(apq) <=
            0.5 * DBL_EPSILON * sqrt(fabs(app)) * sqrt(fabs(aqq))) {
          a[p][q] = a[q][p] = 0.0;
          continue;
        }
        rotated = 1;
        double theta = (aqq - app) / (2.0 * apq);
        double t;
        if (fabs(theta) > 1e150) {
          t = 0.5 / theta;
        } else {
          t = 1.0 / (fabs(theta) + sqrt(theta * theta + 1.0));
          if (theta < 0.0) t = -t;
        }
        double c = 1.0 / sqrt(t * t + 1.0), s = t * c;
        a[p][p] = app - t * apq;
        a[q][q] = aqq + t * apq;
        a[p][q] = a[q][p] = 0.0;
        int r = 3 - p - q;
        double arp = a[r][p], arq = a[r][q];
        a[r][p] = a[p][r] = c * arp - s * arq;
        a[r][q] = a[q][r] = s * arp + c * arq;
        for (int k = 0; k < 3; k++) {
          double vkp = v[k][p], vkq = v[k][q];
          v[k][p] = c * vkp - s * vkq;
          v[k][q] = s * vkp + c * vkq;
        }
      }
    }
    if (!rotated) break;
  }
  /* Sort descending (3 elements: a tiny selection sort). */
  int idx[3] = {0, 1, 2};
  for (int i = 0; i < 2; i++)
    for (int j = i + 1; j < 3; j++)
      if (a[idx[j]][idx[j]] > a[idx[i]][idx[i]]) {
        int t = idx[i];
        idx[i] = idx[j];
        idx[j] = t;
      }
  for (int k = 0; k < 3; k++) {
    lambda[k] = a[idx[k]][idx[k]];
    for (int r = 0; r < 3; r++)
      vec[3 * k + r] = v[r][idx[k]];
  }
}

void pa__sym_eigen(int dim, const double *m, double *lambda, double *vec) {
  if (dim == 2)
    eigen2(m, lambda, vec);
  else
    eigen3(m, lambda, vec);
}

void pa__sym_from_eigen(int dim, const double *lambda, const double *vec,
                        double *m) {
  for (int i = 0; i < dim; i++)
    for (int j = i; j < dim; j++) {
      double s = 0.0;
      for (int k = 0; k < dim; k++)
        s += lambda[k] * vec[dim * k + i] * vec[dim * k + j];
      m[pa__sym_index(i, j)] = s;
    }
}

/* ------------------------------------------------------------------------ */
/* Log, exp, interpolation                                                  */
/* ------------------------------------------------------------------------ */

/* Apply f to the eigenvalues of a full symmetric tensor. */
static void sym_apply(int dim, const double *m, double *out,
                      double (*f)(double)) {
  int nt = pa__tensor_ncomp(dim);
  if (is_diagonal(dim, m)) {
    double d[3];
    for (int i = 0; i < dim; i++)
      d[i] = f(m[pa__sym_index(i, i)]);
    for (int k = 0; k < nt; k++)
      out[k] = 0.0;
    for (int i = 0; i < dim; i++)
      out[pa__sym_index(i, i)] = d[i];
    return;
  }
  double lambda[3], vec[9];
  pa__sym_eigen(dim, m, lambda, vec);
  for (int i = 0; i < dim; i++)
    lambda[i] = f(lambda[i]);
  pa__sym_from_eigen(dim, lambda, vec, out);
}

/* Size tensor H = M^-1/2 and back (M = H^-2); an eigenvalue that rounding
 * pushed to zero or below is floored at DBL_MIN. */
static double inv_sqrt(double x) { return 1.0 / sqrt(x > DBL_MIN ? x : DBL_MIN); }
static double inv_sq(double x) { return 1.0 / (x * x); }

void pa__metric_interp(int dim, int ncomp, int n, const double *const *m,
                       const double *w, double *out) {
  int same = 1;
  for (int i = 1; i < n && same; i++)
    for (int k = 0; k < ncomp; k++)
      if (m[i][k] != m[0][k]) {
        same = 0;
        break;
      }
  if (same) {
    for (int k = 0; k < ncomp; k++)
      out[k] = m[0][k];
    return;
  }
  if (ncomp == 1) {
    double s = 0.0;
    for (int i = 0; i < n; i++)
      s += w[i] * m[i][0];
    out[0] = s;
    return;
  }
  double acc[6] = {0, 0, 0, 0, 0, 0}, h[6];
  for (int i = 0; i < n; i++) {
    if (w[i] == 0.0) continue;
    sym_apply(dim, m[i], h, inv_sqrt);
    for (int k = 0; k < ncomp; k++)
      acc[k] += w[i] * h[k];
  }
  sym_apply(dim, acc, out, inv_sq);
}

int pa__user_metric_field(const pa_mesh *mesh) {
  for (int k = 0; k < mesh->nfield; k++)
    if (!strcmp(mesh->field[k].name, PA_METRIC_USER) &&
        pa__field_is_metric(mesh->dim, mesh->field[k].name,
                            mesh->field[k].ncomp))
      return k;
  return -1;
}

int pa__field_is_metric(int dim, const char *name, int ncomp) {
  size_t n = strlen(PA_FIELD_METRIC_PREFIX);
  return name && !strncmp(name, PA_FIELD_METRIC_PREFIX, n) &&
         (ncomp == 1 || ncomp == pa__tensor_ncomp(dim));
}

void pa__field_interp(int dim, int ncomp, int is_metric, int n,
                      const double *const *v, const double *w, double *out) {
  if (is_metric) {
    pa__metric_interp(dim, ncomp, n, v, w, out);
    return;
  }
  for (int c = 0; c < ncomp; c++) { /* component c read before written */
    double x = 0;
    for (int i = 0; i < n; i++) x += w[i] * v[i][c];
    out[c] = x;
  }
}

/* ------------------------------------------------------------------------ */
/* Intersection, clamping                                                   */
/* ------------------------------------------------------------------------ */

void pa__metric_intersect(int dim, int ncomp, const double *m1,
                          const double *m2, double *out) {
  if (ncomp == 1) {
    out[0] = m1[0] < m2[0] ? m1[0] : m2[0];
    return;
  }
  int nt = pa__tensor_ncomp(dim);
  /* M1 = L L^T (Cholesky); P = L^-1 M2 L^-T is symmetric with the
   * generalised eigenvalues mu of (M2, M1); P = Q diag(mu) Q^T. The
   * intersection is L Q diag(max(mu, 1)) Q^T L^T. */
  double L[3][3] = {{0}}, A[3][3], B[3][3];
  for (int i = 0; i < dim; i++)
    for (int j = 0; j < dim; j++) {
      A[i][j] = m1[pa__sym_index(i, j)];
      B[i][j] = m2[pa__sym_index(i, j)];
    }
  for (int j = 0; j < dim; j++) {
    double s = A[j][j];
    for (int k = 0; k < j; k++)
      s -= L[j][k] * L[j][k];
    if (!(s > 0.0)) { /* not SPD: nothing sensible, keep the larger one */
      for (int k = 0; k < nt; k++)
        out[k] = m2[k];
      return;
    }
    L[j][j] = sqrt(s);
    for (int i = j + 1; i < dim; i++) {
      double t = A[i][j];
      for (int k = 0; k < j; k++)
        t -= L[i][k] * L[j][k];
      L[i][j] = t / L[j][j];
    }
  }
  /* X = L^-1 B (forward substitution, column by column), P = L^-1 X^T. */
  double X[3][3] = {{0}}, P[3][3] = {{0}};
  for (int c = 0; c < dim; c++)
    for (int i = 0; i < dim; i++) {
      double t = B[i][c];
      for (int k = 0; k < i; k++)
        t -= L[i][k] * X[k][c];
      X[i][c] = t / L[i][i];
    }
  for (int c = 0; c < dim; c++)
    for (int i = 0; i < dim; i++) {
      double t = X[c][i]; /* (X^T)[i][c] */
      for (int k = 0; k < i; k++)
        t -= L[i][k] * P[k][c];
      P[i][c] = t / L[i][i];
    }
  double p[6] = {0}, mu[3] = {0}, q[9] = {0};
  for (int i = 0; i < dim; i++)
    for (int j = i; j < dim; j++)
      p[pa__sym_index(i, j)] = 0.5 * (P[i][j] + P[j][i]);
  pa__sym_eigen(dim, p, mu, q);
  double mumin = mu[dim - 1], mumax = mu[0];
  if (mumin >= 1.0 - INTERSECT_TOL) { /* M2 contains M1's demands */
    for (int k = 0; k < nt; k++)
      out[k] = m2[k];
    return;
  }
  if (mumax <= 1.0 + INTERSECT_TOL) {
    for (int k = 0; k < nt; k++)
      out[k] = m1[k];
    return;
  }
  /* G = L Q: column k is L q_k. */
  double G[3][3] = {{0}};
  for (int i = 0; i < dim; i++)
    for (int k = 0; k < dim; k++) {
      double t = 0.0;
      for (int l = 0; l <= i; l++)
        t += L[i][l] * q[dim * k + l];
      G[i][k] = t;
    }
  for (int i = 0; i < dim; i++)
    for (int j = i; j < dim; j++) {
      double t = 0.0;
      for (int k = 0; k < dim; k++)
        t += (mu[k] > 1.0 ? mu[k] : 1.0) * G[i][k] * G[j][k];
      out[pa__sym_index(i, j)] = t;
    }
}

unsigned pa__metric_clamp(int dim, int ncomp, double *m, double hmin,
                          double hmax) {
  unsigned changed = 0;
  if (ncomp == 1) {
    if (hmin > 0.0 && m[0] < hmin) m[0] = hmin, changed |= PA_CHANGED_HMIN;
    if (hmax > 0.0 && m[0] > hmax) m[0] = hmax, changed |= PA_CHANGED_HMAX;
    return changed;
  }
  double lo = hmax > 0.0 ? 1.0 / (hmax * hmax) : 0.0;
  double hi = hmin > 0.0 ? 1.0 / (hmin * hmin) : INFINITY;
  double lambda[3], vec[9];
  pa__sym_eigen(dim, m, lambda, vec);
  for (int i = 0; i < dim; i++) {
    if (lambda[i] < lo) lambda[i] = lo, changed |= PA_CHANGED_HMAX;
    if (lambda[i] > hi) lambda[i] = hi, changed |= PA_CHANGED_HMIN;
  }
  if (changed) pa__sym_from_eigen(dim, lambda, vec, m);
  return changed;
}

void pa__metric_set_hsiz(int dim, int nc, pa_idx nv, double *met,
                         const uint8_t *frozen, double hsiz) {
  for (pa_idx v = 0; v < nv; v++) {
    if (frozen && frozen[v]) continue;
    double *m = met + (size_t)nc * v;
    if (nc == 1) {
      m[0] = hsiz;
    } else {
      for (int i = 0; i < nc; i++) m[i] = 0;
      for (int i = 0; i < dim; i++) m[pa__sym_index(i, i)] = 1.0 / (hsiz * hsiz);
    }
  }
}

unsigned pa__metric_clamp_all(int dim, int nc, pa_idx nv, double *met,
                              const uint8_t *frozen, double hmin,
                              double hmax) {
  unsigned changed = 0;
  if (!(hmin > 0) && !(hmax > 0)) return 0;
  for (pa_idx v = 0; v < nv; v++)
    if (!(frozen && frozen[v]))
      changed |= pa__metric_clamp(dim, nc, met + (size_t)nc * v, hmin, hmax);
  return changed;
}

/* Merge the bounds triple (seen, lo, hi) in into inout: a first one is
 * taken as it is, then the largest lo and the smallest positive hi. */
void pa__local_bounds_merge(const double *in, double *inout) {
  if (!(in[0] > 0)) return;
  if (!(inout[0] > 0)) {
    memcpy(inout, in, 3 * sizeof *in);
    return;
  }
  if (in[1] > inout[1]) inout[1] = in[1];
  if (in[2] > 0 && (!(inout[2] > 0) || in[2] < inout[2])) inout[2] = in[2];
}

void pa__local_bounds(const pa_mesh *mesh, const pa_remesh_opts *o,
                      double *b) {
  int d = mesh->dim;
  for (pa_idx v = 0; v < mesh->nv; v++)
    b[3 * v] = 0, b[3 * v + 1] = o->hmin, b[3 * v + 2] = o->hmax;
  for (int k = 0; o->local && k < o->nlocal; k++) {
    const pa_local_param *p = &o->local[k];
    int elem = p->kind == PA_ELEMENT, nn = elem ? d + 1 : d;
    pa_idx n = elem ? mesh->ne : mesh->nb;
    const pa_idx *conn = elem ? mesh->elem : mesh->bdry;
    const int32_t *ref = elem ? mesh->eref : mesh->bref;
    double t[3] = {1, p->hmin > 0 ? p->hmin : o->hmin,
                   p->hmax > 0 ? p->hmax : o->hmax};
    for (pa_idx e = 0; e < n; e++)
      if (ref[e] == p->ref)
        for (int j = 0; j < nn; j++)
          pa__local_bounds_merge(t, b + 3 * (size_t)conn[(size_t)nn * e + j]);
  }
}

unsigned pa__metric_clamp_bounds(int dim, int nc, pa_idx nv, double *met,
                                 const uint8_t *frozen, const double *b) {
  unsigned changed = 0;
  for (pa_idx v = 0; v < nv; v++) {
    if (frozen && frozen[v]) continue;
    double l = b[3 * v + 1], h = b[3 * v + 2];
    if (l > 0 && h > 0 && l > h) l = h; /* hmax wins a conflict */
    changed |= pa__metric_clamp(dim, nc, met + (size_t)nc * v, l, h);
  }
  return changed;
}

double pa__local_hausd(const pa_remesh_opts *o, int ref, double def) {
  for (int k = 0; o->local && k < o->nlocal; k++)
    if (o->local[k].kind == PA_BOUNDARY && o->local[k].ref == ref &&
        o->local[k].hausd > 0)
      return o->local[k].hausd;
  return def;
}

pa_status pa_mesh_metric_clamp(pa_mesh *mesh, double hmin, double hmax) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(mesh, PA_ERR_ARG, "pa_mesh_metric_clamp: NULL mesh");
  PA_CHECK(!isnan(hmin) && !isnan(hmax) && !isinf(hmin), PA_ERR_ARG,
           "pa_mesh_metric_clamp: hmin and hmax must be numbers "
           "(got %g, %g)",
           hmin, hmax);
  PA_CHECK(!(hmin > 0.0 && hmax > 0.0 && hmin > hmax), PA_ERR_ARG,
           "pa_mesh_metric_clamp: hmin (%g) is larger than hmax (%g)", hmin,
           hmax);
  PA_CHECK(mesh->met_ncomp > 0, PA_ERR_ARG,
           "pa_mesh_metric_clamp: the mesh has no metric");
  int nc = mesh->met_ncomp;
  for (pa_idx i = 0; i < mesh->nv; i++)
    pa__metric_clamp(mesh->dim, nc, mesh->met + (size_t)nc * i, hmin, hmax);
cleanup:
  return st;
}

/* ------------------------------------------------------------------------ */
/* Lengths and quality                                                      */
/* ------------------------------------------------------------------------ */

/* The kernels are in metric2d.h and metric3d.h; these entries pick one by
 * dimension for the callers that hold dim at run time. */

double pa__metric_sqlen(int dim, int ncomp, const double *m, const double *e) {
  if (dim == 2) return pa__sqlen2(ncomp, m, e[0], e[1]);
  return pa__sqlen3(ncomp, m, e);
}

double pa__edge_length(int dim, int ncomp, const double *a, const double *b,
                       const double *ma, const double *mb) {
  if (dim == 2) return pa__len2(ncomp, a, b, ma, mb);
  return pa__len3(ncomp, a, b, ma, mb);
}

double pa_metric_edge_length(int dim, int ncomp, const double *a,
                             const double *b, const double *ma,
                             const double *mb) {
  return pa__edge_length(dim, ncomp, a, b, ma, mb);
}

double pa__quality(int dim, int ncomp, const double *const *x,
                   const double *const *m) {
  if (dim == 2) return pa__qual2_stat(ncomp, x, m);
  return pa__qual3_stat(ncomp, x, m);
}
