/* test_metric.c -- metric algebra kernels of src/metric/metric.c against
 * independent computations: tensors built from known rotations and
 * eigenvalues, numerical integration of lengths, regular elements mapped by
 * known linear maps. */
#include "metric/metric.h"
#include "testutil.h"

#include <float.h>

/* ---- independent helpers (plain dense 3x3 algebra) ---------------------- */

/* Random rotation R (row-major dim x dim). */
static void rand_rotation(int dim, double R[3][3]) {
  if (dim == 2) {
    double a = pa_test_rand_range(0, 2 * M_PI);
    R[0][0] = cos(a), R[0][1] = -sin(a);
    R[1][0] = sin(a), R[1][1] = cos(a);
    return;
  }
  double q[4], n = 0;
  do {
    n = 0;
    for (int k = 0; k < 4; k++) {
      q[k] = pa_test_rand_range(-1, 1);
      n += q[k] * q[k];
    }
  } while (n < 1e-2 || n > 1);
  n = sqrt(n);
  double w = q[0] / n, x = q[1] / n, y = q[2] / n, z = q[3] / n;
  R[0][0] = 1 - 2 * (y * y + z * z), R[0][1] = 2 * (x * y - z * w),
  R[0][2] = 2 * (x * z + y * w);
  R[1][0] = 2 * (x * y + z * w), R[1][1] = 1 - 2 * (x * x + z * z),
  R[1][2] = 2 * (y * z - x * w);
  R[2][0] = 2 * (x * z - y * w), R[2][1] = 2 * (y * z + x * w),
  R[2][2] = 1 - 2 * (x * x + y * y);
}

/* m = R diag(l) R^T in storage order. */
static void build_sym(int dim, double R[3][3], const double *l, double *m) {
  for (int i = 0; i < dim; i++)
    for (int j = i; j < dim; j++) {
      double s = 0;
      for (int k = 0; k < dim; k++)
        s += R[i][k] * l[k] * R[j][k];
      m[pa__sym_index(i, j)] = s;
    }
}

static double rand_log_uniform(double lo, double hi) {
  return exp(pa_test_rand_range(log(lo), log(hi)));
}

static double quad(int dim, const double *m, const double *x) {
  double s = 0;
  for (int i = 0; i < dim; i++)
    for (int j = 0; j < dim; j++)
      s += x[i] * m[pa__sym_index(i, j)] * x[j];
  return s;
}

static double max_abs_diff(int n, const double *a, const double *b) {
  double d = 0;
  for (int k = 0; k < n; k++)
    d = fmax(d, fabs(a[k] - b[k]));
  return d;
}

static double max_abs(int n, const double *a) {
  double d = 0;
  for (int k = 0; k < n; k++)
    d = fmax(d, fabs(a[k]));
  return d;
}

static void sort_desc(int n, double *l) {
  for (int i = 0; i < n; i++)
    for (int j = i + 1; j < n; j++)
      if (l[j] > l[i]) {
        double t = l[i];
        l[i] = l[j];
        l[j] = t;
      }
}

/* Check one eigen-decomposition of m built from (R, l). */
static void check_eigen(int dim, const double *m, const double *ltrue) {
  int nt = pa__tensor_ncomp(dim);
  double lam[3] = {0}, vec[9] = {0}, back[6] = {0}, ls[3] = {0};
  pa__sym_eigen(dim, m, lam, vec);
  double scale = max_abs(dim, ltrue);
  if (scale == 0) scale = 1;
  /* reconstruction (own loop, not pa__sym_from_eigen) */
  for (int i = 0; i < dim; i++)
    for (int j = i; j < dim; j++) {
      double s = 0;
      for (int k = 0; k < dim; k++)
        s += lam[k] * vec[dim * k + i] * vec[dim * k + j];
      back[pa__sym_index(i, j)] = s;
    }
  CHECK(max_abs_diff(nt, back, m) <= 1e-10 * scale);
  /* orthonormal */
  for (int a = 0; a < dim; a++)
    for (int b = 0; b < dim; b++) {
      double s = 0;
      for (int k = 0; k < dim; k++)
        s += vec[dim * a + k] * vec[dim * b + k];
      CHECK_NEAR(s, a == b ? 1.0 : 0.0, 1e-12);
    }
  /* eigenvalues, descending */
  for (int k = 0; k < dim; k++)
    ls[k] = ltrue[k];
  sort_desc(dim, ls);
  for (int k = 0; k < dim; k++)
    CHECK_NEAR(lam[k], ls[k], 1e-10 * scale);
  for (int k = 0; k + 1 < dim; k++)
    CHECK(lam[k] >= lam[k + 1]);
  /* pa__sym_from_eigen agrees */
  double fe[6];
  pa__sym_from_eigen(dim, lam, vec, fe);
  CHECK(max_abs_diff(nt, fe, m) <= 1e-10 * scale);
}

/* ---- tests --------------------------------------------------------------- */

static void test_eigen(void) {
  pa_test_seed(1);
  for (int dim = 2; dim <= 3; dim++) {
    for (int it = 0; it < 3000; it++) {
      double R[3][3], l[3], m[6];
      rand_rotation(dim, R);
      for (int k = 0; k < dim; k++)
        l[k] = rand_log_uniform(1e-4, 1e4);
      int kind = it % 6;
      if (kind == 1) l[1] = l[0];                     /* double */
      if (kind == 2) l[dim - 1] = l[0], l[1] = l[0];  /* all equal */
      if (kind == 3) l[dim - 1] = l[0] * (1 + 1e-13); /* nearly equal */
      if (kind == 4) l[0] = -l[0];                    /* indefinite */
      build_sym(dim, R, l, m);
      check_eigen(dim, m, l);
    }
    /* diagonal input, unsorted, with zeros and repeated values */
    double d3[][3] = {{1, 2, 3}, {3, 2, 1}, {5, 5, 1},
                      {0, 0, 0}, {2, 7, 2}, {1e-4, 1e4, 1}};
    for (size_t t = 0; t < sizeof d3 / sizeof *d3; t++) {
      double m[6] = {0};
      for (int i = 0; i < dim; i++)
        m[pa__sym_index(i, i)] = d3[t][i];
      check_eigen(dim, m, d3[t]);
    }
  }
  /* 2D: the small eigenvalue keeps relative accuracy for exact entries. */
  double m2[3] = {1e8, 1e4 - 1e-4, 1}; /* det = 1e8 - (1e4-1e-4)^2 ~ 2 */
  double lam[2], vec[4];
  pa__sym_eigen(2, m2, lam, vec);
  double det = 1e8 - (1e4 - 1e-4) * (1e4 - 1e-4);
  CHECK_NEAR(lam[1] * lam[0] / det, 1.0, 1e-6);
}

static void test_det(void) {
  pa_test_seed(2);
  for (int dim = 2; dim <= 3; dim++) {
    for (int it = 0; it < 500; it++) {
      double R[3][3], l[3], m[6];
      rand_rotation(dim, R);
      for (int k = 0; k < dim; k++)
        l[k] = rand_log_uniform(0.1, 10);
      build_sym(dim, R, l, m);
      double prod = 1;
      for (int k = 0; k < dim; k++)
        prod *= l[k];
      CHECK_NEAR(pa__sym_det(dim, m) / prod, 1.0, 1e-10);
    }
  }
}

static void test_interp(void) {
  pa_test_seed(4);
  for (int dim = 2; dim <= 3; dim++) {
    int nt = pa__tensor_ncomp(dim);
    for (int it = 0; it < 500; it++) {
      double R[3][3], R2[3][3], l1[3], l2[3], m1[6], m2[6], out[6];
      rand_rotation(dim, R);
      rand_rotation(dim, R2);
      for (int k = 0; k < dim; k++) {
        l1[k] = rand_log_uniform(1e-4, 1e4);
        l2[k] = rand_log_uniform(1e-4, 1e4);
      }
      build_sym(dim, R, l1, m1);
      build_sym(dim, R2, l2, m2);
      double t = pa_test_rand();
      double w[2] = {1 - t, t};
      const double *mm[2] = {m1, m2};
      pa__metric_interp(dim, nt, 2, mm, w, out);
      CHECK(pa__metric_valid(dim, nt, out));
      /* identical metrics come back unchanged */
      const double *same[3] = {m1, m1, m1};
      double w3[3] = {0.2, 0.5, 0.3};
      pa__metric_interp(dim, nt, 3, same, w3, out);
      CHECK(max_abs_diff(nt, out, m1) == 0.0);
      /* commuting metrics: sizes lambda^-1/2 interpolate linearly */
      double m2c[6], lref[3], ref[6];
      build_sym(dim, R, l2, m2c);
      const double *mc[2] = {m1, m2c};
      pa__metric_interp(dim, nt, 2, mc, w, out);
      for (int k = 0; k < dim; k++)
        lref[k] = pow((1 - t) / sqrt(l1[k]) + t / sqrt(l2[k]), -2);
      build_sym(dim, R, lref, ref);
      CHECK(max_abs_diff(nt, out, ref) <= 1e-8 * max_abs(dim, lref));
      /* weight (1, 0) gives the first metric */
      double w10[2] = {1, 0};
      pa__metric_interp(dim, nt, 2, mm, w10, out);
      CHECK(max_abs_diff(nt, out, m1) <= 1e-10 * max_abs(dim, l1));
      /* sizes: h = (1-t) h1 + t h2, also through the tensor form */
      double h1 = rand_log_uniform(1e-3, 10), h2 = rand_log_uniform(1e-3, 10);
      const double *hh[2] = {&h1, &h2};
      double h;
      pa__metric_interp(dim, 1, 2, hh, w, &h);
      double href = (1 - t) * h1 + t * h2;
      CHECK_NEAR(h / href, 1.0, 1e-13);
      double t1[6], t2[6];
      pa__metric_tensor(dim, 1, &h1, t1);
      pa__metric_tensor(dim, 1, &h2, t2);
      const double *tt[2] = {t1, t2};
      pa__metric_interp(dim, nt, 2, tt, w, out);
      for (int i = 0; i < dim; i++) {
        CHECK_NEAR(out[pa__sym_index(i, i)] * href * href, 1.0, 1e-12);
        for (int j = i + 1; j < dim; j++)
          CHECK(out[pa__sym_index(i, j)] == 0);
      }
    }
  }
}

static void test_intersect(void) {
  pa_test_seed(5);
  for (int dim = 2; dim <= 3; dim++) {
    int nt = pa__tensor_ncomp(dim);
    for (int it = 0; it < 1000; it++) {
      double R1[3][3], R2[3][3], l1[3], l2[3], m1[6], m2[6], r[6], r21[6];
      rand_rotation(dim, R1);
      rand_rotation(dim, R2);
      double lo = it % 2 ? 1e-4 : 1e-1, hi = it % 2 ? 1e4 : 1e1;
      for (int k = 0; k < dim; k++) {
        l1[k] = rand_log_uniform(lo, hi);
        l2[k] = rand_log_uniform(lo, hi);
      }
      build_sym(dim, R1, l1, m1);
      build_sym(dim, R2, l2, m2);
      pa__metric_intersect(dim, nt, m1, m2, r);
      pa__metric_intersect(dim, nt, m2, m1, r21);
      CHECK(pa__metric_valid(dim, nt, r));
      double scale = fmax(max_abs(dim, l1), max_abs(dim, l2));
      CHECK(max_abs_diff(nt, r, r21) <= 1e-7 * scale);
      for (int s = 0; s < 50; s++) {
        double x[3];
        for (int k = 0; k < dim; k++)
          x[k] = pa_test_rand_range(-1, 1);
        double qr = quad(dim, r, x), q1 = quad(dim, m1, x),
               q2 = quad(dim, m2, x);
        double tol = 1e-8 * scale *
                     (x[0] * x[0] + x[1] * x[1] + (dim == 3 ? x[2] * x[2] : 0));
        CHECK(qr >= q1 - tol);
        CHECK(qr >= q2 - tol);
        CHECK(qr <=
              q1 + q2 + tol); /* max(a, b) <= a + b in the reduced basis */
      }
      /* common eigenbasis: eigenvalue-wise maximum */
      double m2c[6], lmax[3], ref[6];
      build_sym(dim, R1, l2, m2c);
      for (int k = 0; k < dim; k++)
        lmax[k] = fmax(l1[k], l2[k]);
      build_sym(dim, R1, lmax, ref);
      pa__metric_intersect(dim, nt, m1, m2c, r);
      CHECK(max_abs_diff(nt, r, ref) <= 1e-8 * max_abs(dim, lmax));
      /* ordered pairs: the larger metric is returned as it is */
      double big[6], v[3];
      for (int k = 0; k < dim; k++)
        v[k] = pa_test_rand_range(-1, 1) * sqrt(scale);
      for (int i = 0; i < dim; i++)
        for (int j = i; j < dim; j++)
          big[pa__sym_index(i, j)] = m1[pa__sym_index(i, j)] + v[i] * v[j];
      /* exact when well conditioned (shortcut), else within cond * eps */
      double tol_ord = it % 2 ? 1e-7 * max_abs(nt, big) : 0.0;
      pa__metric_intersect(dim, nt, m1, big, r);
      CHECK(max_abs_diff(nt, r, big) <= tol_ord);
      pa__metric_intersect(dim, nt, big, m1, r);
      CHECK(max_abs_diff(nt, r, big) <= tol_ord);
      pa__metric_intersect(dim, nt, m1, m1, r);
      CHECK(max_abs_diff(nt, r, m1) == 0.0);
    }
  }
  double a = 0.3, b = 0.2, out;
  pa__metric_intersect(3, 1, &a, &b, &out);
  CHECK(out == 0.2);
  pa__metric_intersect(2, 1, &b, &a, &out);
  CHECK(out == 0.2);
}

/* Length of an edge by composite Simpson integration of f(t), t in [0,1]. */
static double simpson(double (*f)(double, const double *), const double *p,
                      int n) {
  double s = f(0, p) + f(1, p);
  for (int i = 1; i < n; i++)
    s += (i % 2 ? 4 : 2) * f((double)i / n, p);
  return s / (3.0 * n);
}

/* p = {|e|, ha, hb}: |e| / h(t), h geometric. */
static double integrand_size(double t, const double *p) {
  return p[0] / (pow(p[1], 1 - t) * pow(p[2], t));
}

/* p = {|e|, la, lb}: sqrt(e^T M(t) e) = |e| sqrt(la^(1-t) lb^t). */
static double integrand_eig(double t, const double *p) {
  return p[0] * sqrt(pow(p[1], 1 - t) * pow(p[2], t));
}

static void test_length(void) {
  pa_test_seed(6);
  for (int dim = 2; dim <= 3; dim++) {
    int nt = pa__tensor_ncomp(dim);
    double id[6], one = 1.0;
    pa__metric_tensor(dim, 0, NULL, id);
    for (int it = 0; it < 200; it++) {
      /* unit edge in the identity metric, all forms */
      double a[3], b[3], d[3], n = 0;
      for (int k = 0; k < dim; k++) {
        a[k] = pa_test_rand_range(-5, 5);
        d[k] = pa_test_rand_range(-1, 1);
        n += d[k] * d[k];
      }
      for (int k = 0; k < dim; k++)
        b[k] = a[k] + d[k] / sqrt(n);
      CHECK_NEAR(pa__edge_length(dim, 0, a, b, NULL, NULL), 1.0, 1e-14);
      CHECK_NEAR(pa__edge_length(dim, 1, a, b, &one, &one), 1.0, 1e-14);
      CHECK_NEAR(pa__edge_length(dim, nt, a, b, id, id), 1.0, 1e-14);
      CHECK_NEAR(pa_metric_edge_length(dim, nt, a, b, id, id), 1.0, 1e-14);

      /* constant metric: sqrt(e^T M e) */
      double R[3][3], l[3], m[6], e[3];
      rand_rotation(dim, R);
      for (int k = 0; k < dim; k++)
        l[k] = rand_log_uniform(1e-2, 1e2);
      build_sym(dim, R, l, m);
      for (int k = 0; k < dim; k++)
        e[k] = b[k] - a[k];
      CHECK_NEAR(pa__edge_length(dim, nt, a, b, m, m) / sqrt(quad(dim, m, e)),
                 1.0, 1e-13);
      CHECK_NEAR(pa__metric_sqlen(dim, nt, m, e) / quad(dim, m, e), 1.0, 1e-13);

      /* geometric size variation: exact formula vs integration */
      double ha = rand_log_uniform(1e-2, 1), hb = rand_log_uniform(1e-2, 1);
      if (it % 4 == 0) hb = ha * (1 + 5e-4); /* arithmetic-mean branch */
      double len = pa_test_rand_range(0.1, 2);
      for (int k = 0; k < dim; k++)
        b[k] = a[k] + len * d[k] / sqrt(n);
      double p[3] = {len, ha, hb};
      double ref = simpson(integrand_size, p, 4000);
      double got = pa__edge_length(dim, 1, a, b, &ha, &hb);
      CHECK_NEAR(got / ref, 1.0, it % 4 == 0 ? 1e-7 : 1e-10);
      CHECK(got == pa__edge_length(dim, 1, b, a, &hb, &ha));
      /* same through tensors I/h^2 */
      double ta[6], tb[6];
      pa__metric_tensor(dim, 1, &ha, ta);
      pa__metric_tensor(dim, 1, &hb, tb);
      CHECK_NEAR(pa__edge_length(dim, nt, a, b, ta, tb) / got, 1.0, 1e-12);

      /* commuting tensors, edge along a common eigenvector */
      double la[3], lb[3], ma[6], mb[6];
      for (int k = 0; k < dim; k++) {
        la[k] = rand_log_uniform(1e-2, 1e4);
        lb[k] = rand_log_uniform(1e-2, 1e4);
      }
      build_sym(dim, R, la, ma);
      build_sym(dim, R, lb, mb);
      for (int k = 0; k < dim; k++)
        b[k] = a[k] + len * R[k][0];
      double p2[3] = {len, la[0], lb[0]};
      double ref2 = simpson(integrand_eig, p2, 4000);
      CHECK_NEAR(pa__edge_length(dim, nt, a, b, ma, mb) / ref2, 1.0, 1e-9);
    }
  }
  /* degenerate edge */
  double a[3] = {1, 2, 3}, h = 0.1;
  CHECK(pa__edge_length(3, 1, a, a, &h, &h) == 0.0);
}

/* Euclidean quality computed independently (Mmg normalisation). */
static double euclid_quality(int dim, double x[4][3]) {
  double s = 0;
  for (int i = 0; i <= dim; i++)
    for (int j = i + 1; j <= dim; j++)
      for (int k = 0; k < dim; k++)
        s += (x[j][k] - x[i][k]) * (x[j][k] - x[i][k]);
  double u[3][3];
  for (int i = 0; i < dim; i++)
    for (int k = 0; k < dim; k++)
      u[i][k] = x[i + 1][k] - x[0][k];
  if (dim == 2)
    return 4 * sqrt(3) * 0.5 * (u[0][0] * u[1][1] - u[0][1] * u[1][0]) / s;
  double det = u[0][0] * (u[1][1] * u[2][2] - u[1][2] * u[2][1]) -
               u[0][1] * (u[1][0] * u[2][2] - u[1][2] * u[2][0]) +
               u[0][2] * (u[1][0] * u[2][1] - u[1][1] * u[2][0]);
  return 72 * sqrt(3) * det / 6 / pow(s, 1.5);
}

static double quality_of(int dim, int ncomp, double x[4][3],
                         const double *const *m) {
  const double *xp[4] = {x[0], x[1], x[2], x[3]};
  return pa__quality(dim, ncomp, xp, m);
}

/* Regular simplex with unit-ish size, positively oriented. */
static void regular(int dim, double y[4][3]) {
  memset(y, 0, 4 * 3 * sizeof(double));
  if (dim == 2) {
    y[1][0] = 1;
    y[2][0] = 0.5, y[2][1] = sqrt(3) / 2;
    return;
  }
  double v[4][3] = {{1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}};
  memcpy(y, v, sizeof v);
  if (euclid_quality(3, y) < 0)
    for (int k = 0; k < 3; k++) {
      double t = y[2][k];
      y[2][k] = y[3][k];
      y[3][k] = t;
    }
}

static void test_quality(void) {
  pa_test_seed(7);
  for (int dim = 2; dim <= 3; dim++) {
    int nt = pa__tensor_ncomp(dim), nv = dim + 1;
    double y[4][3];
    regular(dim, y);
    CHECK_NEAR(quality_of(dim, 0, y, NULL), 1.0, 1e-14);
    for (int it = 0; it < 300; it++) {
      /* rotated, translated, scaled regular element: Q = 1 in every
       * isotropic form */
      double R[3][3], x[4][3], s = rand_log_uniform(1e-3, 1e3), c[3];
      rand_rotation(dim, R);
      for (int k = 0; k < dim; k++)
        c[k] = pa_test_rand_range(-10, 10);
      for (int i = 0; i < nv; i++)
        for (int k = 0; k < 3; k++) {
          x[i][k] = 0;
          if (k < dim) {
            x[i][k] = c[k];
            for (int j = 0; j < dim; j++)
              x[i][k] += s * R[k][j] * y[i][j];
          }
        }
      CHECK_NEAR(quality_of(dim, 0, x, NULL), 1.0, 1e-10);
      double h[4];
      const double *hp[4] = {&h[0], &h[1], &h[2], &h[3]};
      for (int i = 0; i < nv; i++)
        h[i] = rand_log_uniform(1e-3, 1e3);
      CHECK_NEAR(quality_of(dim, 1, x, hp), 1.0, 1e-10);

      /* anisotropic: x = F^-1 y with F = M^(1/2) maps to a regular element;
       * vertex metrics M + D, M - D, M, M average to M. */
      double l[3], lf[3], lfi[3], M[6], Fi[6], D[6], m4[4][6];
      for (int k = 0; k < dim; k++) {
        l[k] = rand_log_uniform(1e-2, 1e2);
        lf[k] = sqrt(l[k]);
        lfi[k] = 1 / lf[k];
      }
      build_sym(dim, R, l, M);
      build_sym(dim, R, lfi, Fi);
      double lmin = l[0];
      for (int k = 1; k < dim; k++)
        lmin = fmin(lmin, l[k]);
      for (int k = 0; k < nt; k++)
        D[k] = 0;
      for (int i = 0; i < dim; i++)
        D[pa__sym_index(i, i)] = 0.5 * lmin;
      for (int i = 0; i < nv; i++) {
        for (int k = 0; k < 3; k++) {
          x[i][k] = 0;
          for (int j = 0; j < dim && k < dim; j++)
            x[i][k] += Fi[pa__sym_index(k, j)] * y[i][j];
        }
        for (int k = 0; k < nt; k++)
          m4[i][k] = M[k] + (i == 0 ? D[k] : i == 1 ? -D[k] : 0.0);
      }
      const double *mp[4] = {m4[0], m4[1], m4[2], m4[3]};
      CHECK_NEAR(quality_of(dim, nt, x, mp), 1.0, 1e-9);
      const double *mc[4] = {M, M, M, M};
      CHECK_NEAR(quality_of(dim, nt, x, mc), 1.0, 1e-9);
      /* inverted: swap two vertices */
      double xs[4][3];
      memcpy(xs, x, sizeof xs);
      memcpy(xs[0], x[1], sizeof xs[0]);
      memcpy(xs[1], x[0], sizeof xs[1]);
      CHECK_NEAR(quality_of(dim, nt, xs, mc), -1.0, 1e-9);

      /* random element, constant metric: Q_M(x) = Q_euclid(F x) */
      double xr[4][3], fx[4][3], F[6];
      build_sym(dim, R, lf, F);
      for (int i = 0; i < nv; i++) {
        for (int k = 0; k < 3; k++)
          xr[i][k] = k < dim ? pa_test_rand() : 0;
      }
      for (int i = 0; i < nv; i++)
        for (int k = 0; k < 3; k++) {
          fx[i][k] = 0;
          for (int j = 0; j < dim && k < dim; j++)
            fx[i][k] += F[pa__sym_index(k, j)] * xr[i][j];
        }
      double qe = euclid_quality(dim, fx);
      CHECK_NEAR(quality_of(dim, nt, xr, mc), qe, 1e-10 * fmax(1, fabs(qe)));
      CHECK_NEAR(quality_of(dim, 0, xr, NULL), euclid_quality(dim, xr), 1e-12);
    }
    /* flat elements */
    double flat[4][3] = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {0.5, 0.5, 0}};
    if (dim == 3) flat[2][1] = 1; /* 4 points in the plane z = 0 */
    CHECK(fabs(quality_of(dim, 0, flat, NULL)) < 1e-15);
    double same[4][3] = {{0}};
    CHECK(quality_of(dim, 0, same, NULL) == 0.0);
  }
}

static void test_clamp(void) {
  pa_test_seed(8);
  double h = 0.001;
  pa__metric_clamp(2, 1, &h, 0.01, 0.1);
  CHECK(h == 0.01);
  h = 1;
  pa__metric_clamp(2, 1, &h, 0.01, 0.1);
  CHECK(h == 0.1);
  h = 0.05;
  pa__metric_clamp(2, 1, &h, 0.01, 0.1);
  CHECK(h == 0.05);
  h = 1;
  pa__metric_clamp(2, 1, &h, 0.01, 0); /* hmax ignored */
  CHECK(h == 1);
  h = 1e-5;
  pa__metric_clamp(2, 1, &h, -1, 0.1); /* hmin ignored */
  CHECK(h == 1e-5);
  for (int dim = 2; dim <= 3; dim++) {
    int nt = pa__tensor_ncomp(dim);
    for (int it = 0; it < 300; it++) {
      double R[3][3], l[3], m[6], lc[3], ref[6];
      rand_rotation(dim, R);
      for (int k = 0; k < dim; k++)
        l[k] = rand_log_uniform(1e-4, 1e4);
      build_sym(dim, R, l, m);
      double hmin = 0.1, hmax = 10; /* eigenvalues into [0.01, 100] */
      for (int k = 0; k < dim; k++)
        lc[k] = fmin(fmax(l[k], 0.01), 100);
      build_sym(dim, R, lc, ref);
      pa__metric_clamp(dim, nt, m, hmin, hmax);
      CHECK(max_abs_diff(nt, m, ref) <= 1e-10 * 100);
      /* already within bounds: untouched */
      double in[6], copy[6];
      for (int k = 0; k < dim; k++)
        lc[k] = rand_log_uniform(0.02, 50);
      build_sym(dim, R, lc, in);
      memcpy(copy, in, sizeof copy);
      pa__metric_clamp(dim, nt, in, hmin, hmax);
      CHECK(max_abs_diff(nt, in, copy) == 0.0);
      /* only hmin */
      build_sym(dim, R, l, m);
      for (int k = 0; k < dim; k++)
        lc[k] = fmin(l[k], 100);
      build_sym(dim, R, lc, ref);
      pa__metric_clamp(dim, nt, m, hmin, 0);
      CHECK(max_abs_diff(nt, m, ref) <= 1e-10 * 1e4);
    }
  }
  /* on a mesh */
  pa_mesh *mesh = NULL;
  CHECK_OK(pa_mesh_create(2, &mesh));
  double x[2] = {0, 0};
  for (int i = 0; i < 3; i++)
    CHECK_OK(pa_mesh_add_vertex(mesh, x, 0, NULL));
  CHECK(pa_mesh_metric_clamp(mesh, 0.1, 1) == PA_ERR_ARG); /* no metric */
  double hs[3] = {0.01, 0.5, 5};
  CHECK_OK(pa_mesh_set_metric(mesh, 1, hs));
  CHECK(pa_mesh_metric_clamp(mesh, 1, 0.1) == PA_ERR_ARG); /* hmin > hmax */
  CHECK_OK(pa_mesh_metric_clamp(mesh, 0.1, 1));
  double *mm = pa_mesh_metric(mesh);
  CHECK(mm[0] == 0.1 && mm[1] == 0.5 && mm[2] == 1);
  double t[9] = {1e6, 0, 1e-6, 4, 0, 4, 1, 0.5, 1};
  CHECK_OK(pa_mesh_set_metric(mesh, 3, t));
  CHECK_OK(pa_mesh_metric_clamp(mesh, 0.01, 100));
  mm = pa_mesh_metric(mesh);
  CHECK_NEAR(mm[0], 1e4, 1e-8);
  CHECK_NEAR(mm[2], 1e-4, 1e-16);
  CHECK(mm[3] == 4 && mm[5] == 4 && mm[6] == 1 && mm[7] == 0.5);
  pa_mesh_destroy(mesh);
}

static void test_valid(void) {
  pa_test_seed(9);
  double h[] = {0.1, 0, -1, NAN, INFINITY, 1e-300};
  CHECK(pa__metric_valid(2, 1, &h[0]));
  CHECK(!pa__metric_valid(2, 1, &h[1]));
  CHECK(!pa__metric_valid(3, 1, &h[2]));
  CHECK(!pa__metric_valid(3, 1, &h[3]));
  CHECK(!pa__metric_valid(3, 1, &h[4]));
  CHECK(pa__metric_valid(3, 1, &h[5]));
  /* 2D tensors */
  double good2[3] = {1, 0, 1}, aniso2[3] = {1, 0, 1e-12};
  double bad2[][3] = {{1, 2, 1},        {0, 0, 0},     {1, 1, 1},
                      {-1, 0, -1},      {1, NAN, 1},   {1, 0, -1},
                      {INFINITY, 0, 1}, {1, 0, 1e-17}, {-1, 0, 1}};
  CHECK(pa__metric_valid(2, 3, good2));
  CHECK(pa__metric_valid(2, 3, aniso2));
  for (size_t i = 0; i < sizeof bad2 / sizeof *bad2; i++)
    CHECK(!pa__metric_valid(2, 3, bad2[i]));
  CHECK(!pa__metric_valid(2, 6, good2)); /* wrong ncomp */
  /* 3D tensors */
  double good3[6] = {1, 0, 1, 0, 0, 1};
  double bad3[][6] = {{1, 0, 1, 0, 0, -1},   {1, 0, 1, 0, 0, 0},
                      {1, 0, 1, 0, 2, 1},    {1, 0, 1, NAN, 0, 1},
                      {0, 0, 0, 0, 0, 0},    {1, 1, 1, 1, 1, 1},
                      {1, 0, 1, 0, 0, 1e-17}};
  CHECK(pa__metric_valid(3, 6, good3));
  for (size_t i = 0; i < sizeof bad3 / sizeof *bad3; i++)
    CHECK(!pa__metric_valid(3, 6, bad3[i]));
  CHECK(!pa__metric_valid(3, 3, good3));
  /* every random SPD tensor of anisotropy up to 1e8 is valid; flipping the
   * sign of one eigenvalue makes it invalid */
  for (int dim = 2; dim <= 3; dim++) {
    int nt = pa__tensor_ncomp(dim);
    for (int it = 0; it < 2000; it++) {
      double R[3][3], l[3], m[6];
      rand_rotation(dim, R);
      for (int k = 0; k < dim; k++)
        l[k] = rand_log_uniform(1e-4, 1e4);
      build_sym(dim, R, l, m);
      CHECK(pa__metric_valid(dim, nt, m));
      int k = it % dim;
      l[k] = -l[k];
      build_sym(dim, R, l, m);
      CHECK(!pa__metric_valid(dim, nt, m));
      l[k] = 0;
      build_sym(dim, R, l, m);
      CHECK(!pa__metric_valid(dim, nt, m));
    }
  }
  /* pa_mesh_set_metric rejects through it and names the vertex 1-based */
  pa_mesh *mesh = NULL;
  CHECK_OK(pa_mesh_create(3, &mesh));
  double x[3] = {0, 0, 0};
  for (int i = 0; i < 3; i++)
    CHECK_OK(pa_mesh_add_vertex(mesh, x, 0, NULL));
  double t[18] = {1, 0, 1, 0, 0, 1, 1, 0, 1, 0, 0, 1, 1, 2, 1, 0, 0, 1};
  CHECK(pa_mesh_set_metric(mesh, 6, t) == PA_ERR_METRIC);
  CHECK(strstr(pa_last_error(), "vertex 3") != NULL);
  pa_mesh_destroy(mesh);
}

/* Outputs may alias inputs (the remeshers interpolate in place). */
static void test_alias(void) {
  pa_test_seed(10);
  for (int dim = 2; dim <= 3; dim++) {
    int nt = pa__tensor_ncomp(dim);
    for (int it = 0; it < 100; it++) {
      double R[3][3], l1[3], l2[3], m1[6], m2[6], ref[6], a[6];
      rand_rotation(dim, R);
      for (int k = 0; k < dim; k++) {
        l1[k] = rand_log_uniform(1e-2, 1e2);
        l2[k] = rand_log_uniform(1e-2, 1e2);
      }
      if (it % 2) /* diagonal fast paths */
        memset(R, 0, sizeof R), R[0][0] = R[1][1] = R[2][2] = 1;
      build_sym(dim, R, l1, m1);
      rand_rotation(dim, R);
      build_sym(dim, R, l2, m2);
      const double *mm[2] = {m1, m2};
      double w[2] = {0.3, 0.7};
      pa__metric_interp(dim, nt, 2, mm, w, ref);
      memcpy(a, m1, sizeof a);
      const double *ma[2] = {a, m2};
      pa__metric_interp(dim, nt, 2, ma, w, a);
      CHECK(max_abs_diff(nt, a, ref) == 0.0);
      pa__metric_intersect(dim, nt, m1, m2, ref);
      memcpy(a, m1, sizeof a);
      pa__metric_intersect(dim, nt, a, m2, a);
      CHECK(max_abs_diff(nt, a, ref) == 0.0);
      memcpy(a, m2, sizeof a);
      pa__metric_intersect(dim, nt, m1, a, a);
      CHECK(max_abs_diff(nt, a, ref) == 0.0);
      double h = l1[0];
      pa__metric_tensor(dim, 1, &h, ref);
      a[0] = h;
      pa__metric_tensor(dim, 1, a, a);
      CHECK(max_abs_diff(nt, a, ref) == 0.0);
    }
  }
}

TEST_MAIN(test_eigen, test_det, test_interp,
          test_intersect, test_length, test_quality, test_clamp, test_valid,
          test_alias)
