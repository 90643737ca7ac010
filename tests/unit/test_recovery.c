/*
 * test_recovery.c -- gradient and Hessian recovery (src/metric/recovery.c),
 * the Lp Hessian metric (hessian.c) and the whole-field metric operations
 * (ops.c):
 *  - the least-squares fit recovers the gradient and Hessian of a quadratic
 *    exactly at every vertex, boundary and corners included, on structured
 *    and randomly perturbed boxes, 2D and 3D; the double L2 projection the
 *    gradient of a linear field;
 *  - on a smooth field (sin 4x cos 3y ...) the least-squares Hessian is
 *    closer to the exact one than the L2 projection's (the choice of the
 *    default, recorded in recovery.c);
 *  - the Hessian metric reaches its target complexity within 5 % after
 *    clamping and gradation; an error target gives a finer metric for a
 *    smaller error; a quadratic with constant Hessian gives a constant
 *    metric;
 *  - scaling to a complexity is exact, intersection contains both metrics.
 */
#include "metric/metric.h"
#include "testutil.h"

#include <math.h>

/* A box with its interior vertices moved at random by up to amount times
 * the spacing (half that in 3D, whose Kuhn tetrahedra are thinner): the
 * boundary stays put, every element stays positive. */
static pa_mesh *perturbed_box(int dim, int n, double amount) {
  pa_mesh *m = NULL;
  CHECK_OK(pa_mesh_generate_box(dim, n, &m));
  double h = (dim == 2 ? 1.0 : 0.5) / n;
  for (pa_idx v = 0; v < m->nv; v++) {
    double *x = m->coord + (size_t)dim * v;
    int inner = 1;
    for (int k = 0; k < dim; k++)
      inner &= x[k] > 1e-12 && x[k] < 1 - 1e-12;
    if (!inner) continue;
    for (int k = 0; k < dim; k++)
      x[k] += amount * h * (2 * pa_test_rand() - 1);
  }
  CHECK_OK(pa_mesh_check(m));
  return m;
}

/* A quadratic with a full Hessian: u = c.x + 1/2 x^T A x. */
static const double QA[6] = {2.0, -0.7, 3.0, 0.4, 1.1, -1.5};
static const double QC[3] = {0.3, -1.2, 0.8};

static double quad(int dim, const double *x) {
  double u = 0;
  for (int i = 0; i < dim; i++) {
    u += QC[i] * x[i];
    for (int j = 0; j < dim; j++)
      u += 0.5 * QA[pa__sym_index(i, j)] * x[i] * x[j];
  }
  return u;
}

static void test_quadratic_exact(void) {
  pa_test_seed(5);
  for (int dim = 2; dim <= 3; dim++)
    for (int pert = 0; pert < 2; pert++) {
      pa_mesh *m = perturbed_box(dim, dim == 2 ? 12 : 5, pert ? 0.3 : 0.0);
      int nt = pa__tensor_ncomp(dim);
      double *u = malloc(sizeof(double) * m->nv);
      double *g = malloc(sizeof(double) * dim * m->nv);
      double *h = malloc(sizeof(double) * nt * m->nv);
      for (pa_idx v = 0; v < m->nv; v++)
        u[v] = quad(dim, m->coord + dim * v);
      CHECK_OK(pa_mesh_recover(m, u, 1, PA_RECOVER_LSQ, g, h));
      double eg = 0, eh = 0;
      for (pa_idx v = 0; v < m->nv; v++) {
        const double *x = m->coord + dim * v;
        for (int i = 0; i < dim; i++) {
          double gi = QC[i];
          for (int j = 0; j < dim; j++)
            gi += QA[pa__sym_index(i, j)] * x[j];
          eg = fmax(eg, fabs(g[dim * v + i] - gi));
        }
        for (int k = 0; k < nt; k++)
          eh = fmax(eh, fabs(h[nt * v + k] - QA[k]));
      }
      printf("%dD %s: quadratic, max gradient error %.2e, Hessian %.2e\n", dim,
             pert ? "perturbed" : "structured", eg, eh);
      CHECK(eg < 1e-9);
      CHECK(eh < 1e-8);
      /* L2 projection: exact gradient of a linear field */
      for (pa_idx v = 0; v < m->nv; v++) {
        const double *x = m->coord + dim * v;
        u[v] = 1 + QC[0] * x[0] + QC[1] * x[1] + (dim == 3 ? QC[2] * x[2] : 0);
      }
      CHECK_OK(pa_mesh_recover(m, u, 1, PA_RECOVER_L2, g, h));
      double el = 0, ehl = 0;
      for (pa_idx v = 0; v < m->nv; v++) {
        for (int i = 0; i < dim; i++)
          el = fmax(el, fabs(g[dim * v + i] - QC[i]));
        for (int k = 0; k < nt; k++)
          ehl = fmax(ehl, fabs(h[nt * v + k]));
      }
      CHECK(el < 1e-10);
      CHECK(ehl < 1e-8);
      free(u);
      free(g);
      free(h);
      pa_mesh_destroy(m);
    }
}

/* u = sin(4x) cos(3y) (+ z^2 e^x in 3D): mean relative Hessian error at the
 * vertices away from the boundary, LSQ against L2. */
static void test_smooth_field(void) {
  pa_test_seed(6);
  for (int dim = 2; dim <= 3; dim++) {
    pa_mesh *m = perturbed_box(dim, dim == 2 ? 40 : 12, 0.3);
    int nt = pa__tensor_ncomp(dim);
    double *u = malloc(sizeof(double) * m->nv);
    double *h = malloc(sizeof(double) * nt * m->nv);
    for (pa_idx v = 0; v < m->nv; v++) {
      const double *x = m->coord + dim * v;
      u[v] = sin(4 * x[0]) * cos(3 * x[1]) +
             (dim == 3 ? x[2] * x[2] * exp(x[0]) : 0);
    }
    double err[2];
    for (int meth = 0; meth < 2; meth++) {
      CHECK_OK(pa_mesh_recover(m, u, 1, meth ? PA_RECOVER_L2 : PA_RECOVER_LSQ,
                               NULL, h));
      double se = 0;
      long cnt = 0;
      for (pa_idx v = 0; v < m->nv; v++) {
        const double *x = m->coord + dim * v;
        int inner = 1;
        for (int k = 0; k < dim; k++)
          inner &= x[k] > 0.15 && x[k] < 0.85;
        if (!inner) continue;
        double e[6] = {0};
        e[0] = -16 * sin(4 * x[0]) * cos(3 * x[1]);
        e[1] = -12 * cos(4 * x[0]) * sin(3 * x[1]);
        e[2] = -9 * sin(4 * x[0]) * cos(3 * x[1]);
        if (dim == 3) {
          e[0] += x[2] * x[2] * exp(x[0]);
          e[3] = 2 * x[2] * exp(x[0]);
          e[5] = 2 * exp(x[0]);
        }
        double num = 0, den = 0;
        for (int k = 0; k < nt; k++) {
          num += (h[nt * v + k] - e[k]) * (h[nt * v + k] - e[k]);
          den += e[k] * e[k];
        }
        se += sqrt(num / (den + 1e-30));
        cnt++;
      }
      err[meth] = se / cnt;
    }
    printf("%dD smooth field: mean relative Hessian error LSQ %.3f, L2 %.3f\n",
           dim, err[0], err[1]);
    CHECK(err[0] < err[1]);
    free(u);
    free(h);
    pa_mesh_destroy(m);
  }
}

static void test_hessian_metric(void) {
  pa_test_seed(7);
  for (int dim = 2; dim <= 3; dim++) {
    pa_mesh *m = perturbed_box(dim, dim == 2 ? 30 : 10, 0.2);
    int nt = pa__tensor_ncomp(dim);
    double *u = malloc(sizeof(double) * m->nv);
    double *met = malloc(sizeof(double) * nt * m->nv);
    for (pa_idx v = 0; v < m->nv; v++) {
      const double *x = m->coord + dim * v;
      u[v] = tanh(20 * (x[0] - 0.5 - 0.1 * sin(3 * x[1])));
    }
    pa_metric_hessian_opts o;
    pa_metric_hessian_opts_default(&o);
    o.target = dim == 2 ? 3000 : 20000;
    o.hmin = 1e-3;
    o.hmax = 0.3;
    CHECK_OK(pa_metric_from_hessian(m, u, 1, &o, met));
    double c = 0;
    for (pa_idx v = 0; v < m->nv; v++)
      CHECK(pa__metric_valid(dim, nt, met + nt * v));
    CHECK_OK(pa_metric_complexity(m, nt, met, &c));
    printf("%dD tanh layer: complexity %.1f for the target %.0f\n", dim, c,
           o.target);
    CHECK(fabs(c / o.target - 1) < 0.05);
    /* error target: smaller error, finer metric */
    double ce[2];
    for (int k = 0; k < 2; k++) {
      o.target = 0;
      o.err = k ? 1e-3 : 1e-2;
      CHECK_OK(pa_metric_from_hessian(m, u, 1, &o, met));
      CHECK_OK(pa_metric_complexity(m, nt, met, &ce[k]));
    }
    CHECK(ce[1] > 3 * ce[0]);
    /* both options, or neither, is an error */
    o.target = 100;
    CHECK(pa_metric_from_hessian(m, u, 1, &o, met) == PA_ERR_ARG);
    /* a quadratic: constant Hessian, constant metric (no clamp, no grading) */
    for (pa_idx v = 0; v < m->nv; v++)
      u[v] = quad(dim, m->coord + dim * v);
    pa_metric_hessian_opts_default(&o);
    o.target = 500;
    o.hgrad = -1;
    CHECK_OK(pa_metric_from_hessian(m, u, 1, &o, met));
    double dev = 0;
    for (pa_idx v = 0; v < m->nv; v++)
      for (int k = 0; k < nt; k++)
        dev = fmax(dev, fabs(met[nt * v + k] - met[k]) / fabs(met[0]));
    CHECK(dev < 1e-6);
    free(u);
    free(met);
    pa_mesh_destroy(m);
  }
}

static void test_ops(void) {
  pa_mesh *m = NULL;
  CHECK_OK(pa_mesh_generate_box(3, 4, &m));
  CHECK_OK(pa_metric_analytic(m, "shell:0.2"));
  int nt = 6;
  double c = 0, c2 = 0;
  CHECK_OK(pa_metric_complexity(m, nt, m->met, &c));
  CHECK_OK(pa_metric_scale_complexity(m, nt, m->met, 3 * c));
  CHECK_OK(pa_metric_complexity(m, nt, m->met, &c2));
  CHECK_NEAR(c2 / (3 * c), 1.0, 1e-12);
  /* uniform size h on the unit cube: complexity 1/h^3 */
  double *h = malloc(sizeof(double) * m->nv);
  for (pa_idx v = 0; v < m->nv; v++)
    h[v] = 0.1;
  CHECK_OK(pa_metric_complexity(m, 1, h, &c));
  CHECK_NEAR(c, 1000.0, 1e-9);
  /* intersection contains both */
  double *a = malloc(sizeof(double) * nt * m->nv),
         *b = malloc(sizeof(double) * nt * m->nv);
  double *o = malloc(sizeof(double) * nt * m->nv);
  memcpy(a, m->met, sizeof(double) * nt * m->nv);
  CHECK_OK(pa_metric_analytic(m, "layer:0.2"));
  memcpy(b, m->met, sizeof(double) * nt * m->nv);
  CHECK_OK(pa_metric_intersect_all(3, nt, m->nv, a, b, o));
  for (pa_idx v = 0; v < m->nv; v++) {
    double t[6];
    pa__metric_intersect(3, nt, o + nt * v, a + nt * v, t);
    for (int k = 0; k < nt; k++)
      CHECK(fabs(t[k] - o[nt * v + k]) <= 1e-9 * fabs(o[nt * v]));
  }
  free(h);
  free(a);
  free(b);
  free(o);
  pa_mesh_destroy(m);
}

TEST_MAIN(test_quadratic_exact, test_smooth_field, test_hessian_metric,
          test_ops)
