/*
 * test_gradation.c -- properties of the metric gradation (src/metric/
 * gradation.c), sizes and tensors, 2D and 3D:
 *  - a field that satisfies the bound is left exactly as it is: the UGAWG
 *    fields at hgrad 1.3 (their frames turn, their sizes grow slowly), on
 *    boxes and on meshes adapted to them;
 *  - the result is never larger than the input in any direction;
 *  - a second gradation changes nothing;
 *  - where the input is isotropic, thin directions at right angles grade
 *    it in every direction (the centre of a shell);
 *  - a required vertex grades its neighbours with hgradreq, not hgrad, and
 *    not at all with hgradreq -1.
 */
#include "testutil.h"
#include "metric/gradation.h"

#include <math.h>

/* Grade a copy of the mesh's metric; returns the copy. */
static double *graded(pa_mesh *m, const uint8_t *frozen, double hgrad,
                      double hgradreq, pa_idx *nch) {
  size_t n = (size_t)m->nv * m->met_ncomp;
  double *g = malloc(sizeof(double) * n);
  memcpy(g, m->met, sizeof(double) * n);
  CHECK_OK(pa__metric_gradation(m->dim, m->met_ncomp, m->nv, m->coord, g,
                                m->ne, m->elem, frozen, hgrad, hgradreq, nch));
  return g;
}

/* Number of vertices whose metric differs bitwise from the mesh's. */
static pa_idx ndiff(const pa_mesh *m, const double *g) {
  pa_idx n = 0;
  int nc = m->met_ncomp;
  for (pa_idx v = 0; v < m->nv; v++)
    n += memcmp(g + (size_t)nc * v, m->met + (size_t)nc * v,
                sizeof(double) * nc) != 0;
  return n;
}

/* 1 if b contains a (b >= a in every direction, to round-off): a cap b is b. */
static int contains(int dim, int nc, const double *b, const double *a) {
  if (nc == 1) return b[0] <= a[0] * (1 + 1e-14);
  double c[6];
  pa__metric_intersect(dim, nc, b, a, c);
  double s = 0, d = 0;
  for (int k = 0; k < nc; k++) {
    s = fmax(s, fabs(b[k]));
    d = fmax(d, fabs(c[k] - b[k]));
  }
  return d <= 1e-9 * s;
}

/* The UGAWG fields on m: unchanged, bit for bit. */
static void ugawg_unchanged(pa_mesh *m, const char *what) {
  const char *f[3] = {"ugawg-linear", "ugawg-polar1", "ugawg-polar2"};
  for (int i = 0; i < 3; i++) {
    CHECK_OK(pa_metric_analytic(m, f[i]));
    pa_idx nch = -1;
    double *g = graded(m, NULL, 1.3, 2.3, &nch);
    pa_idx nd = ndiff(m, g);
    if (nch || nd)
      printf("%s, %s: %d vertices changed\n", what, f[i], (int)nd);
    for (pa_idx v = 0; v < m->nv && nd; v++) {
      int nc = m->met_ncomp, d = m->dim;
      if (!memcmp(g + nc * v, m->met + nc * v, sizeof(double) * nc)) continue;
      double l0[3], l1[3], vec[9];
      pa__sym_eigen(d, m->met + nc * v, l0, vec);
      pa__sym_eigen(d, g + nc * v, l1, vec);
      const double *x = m->coord + d * v;
      printf("  v %d at %g %g %g: sizes %g %g -> %g %g\n", (int)v, x[0], x[1], d == 3 ? x[2] : 0, 1/sqrt(l0[0]), 1/sqrt(l0[1]), 1/sqrt(l1[0]), 1/sqrt(l1[1]));
    }
    CHECK(nch == 0);
    CHECK(nd == 0);
    free(g);
  }
}

/* Adapt a box to an UGAWG field (passes with the field re-evaluated, no
 * gradation): a mesh that follows its turning frame. */
static pa_mesh *adapted(int dim, int n, const char *field, int passes) {
  pa_mesh *m = NULL;
  CHECK_OK(pa_mesh_generate_box(dim, n, &m));
  pa_remesh_opts o;
  pa_remesh_opts_default(&o);
  o.hgrad = -1;
  for (int p = 0; p < passes; p++) {
    CHECK_OK(pa_metric_analytic(m, field));
    pa_remesh_report r;
    CHECK_OK(pa_remesh(pa_remesher_builtin(), m, &o, &r));
  }
  return m;
}

static void test_ugawg_unchanged(void) {
  pa_mesh *m = NULL;
  CHECK_OK(pa_mesh_generate_box(2, 40, &m));
  ugawg_unchanged(m, "box2d 40");
  pa_mesh_destroy(m);
  m = adapted(2, 20, "ugawg-polar1", 3);
  ugawg_unchanged(m, "2D adapted to polar-1");
  pa_mesh_destroy(m);
  m = adapted(2, 20, "ugawg-polar2", 3);
  ugawg_unchanged(m, "2D adapted to polar-2");
  pa_mesh_destroy(m);
  m = adapted(3, 6, "ugawg-polar1", 3);
  printf("3D mesh adapted to polar-1: %d tets\n", (int)m->ne);
  ugawg_unchanged(m, "3D adapted to polar-1");
  pa_mesh_destroy(m);
}

/* Random fields with sharp spots: never larger in any direction, and a
 * fixed point after one gradation. */
static void test_random_fields(void) {
  pa_test_seed(31);
  for (int dim = 2; dim <= 3; dim++)
    for (int tensor = 0; tensor < 2; tensor++) {
      pa_mesh *m = NULL;
      CHECK_OK(pa_mesh_generate_box(dim, dim == 2 ? 24 : 8, &m));
      int nc = tensor ? pa__tensor_ncomp(dim) : 1;
      double *met = malloc(sizeof(double) * nc * m->nv);
      for (pa_idx v = 0; v < m->nv; v++) {
        double *x = met + (size_t)nc * v;
        double s = pa_test_rand() < 0.05 ? 1e-3 : 1.0; /* spots */
        if (!tensor) {
          x[0] = s * pa_test_rand_range(0.05, 0.5);
          continue;
        }
        /* random SPD: A A^T / 4 + diag, sizes spread over 1:100 */
        double a[9];
        for (int k = 0; k < 9; k++) a[k] = pa_test_rand_range(-1, 1);
        for (int i = 0; i < dim; i++)
          for (int j = i; j < dim; j++) {
            double t = 0;
            for (int k = 0; k < dim; k++) t += a[3 * i + k] * a[3 * j + k];
            x[pa__sym_index(i, j)] = (t / 4 + (i == j ? 0.01 : 0)) * 100 / s;
          }
      }
      CHECK_OK(pa_mesh_set_metric(m, nc, met));
      pa_idx nch = 0, nch2 = -1;
      double *g = graded(m, NULL, 1.3, 2.3, &nch);
      CHECK(nch > 0);
      pa_idx bad = 0;
      for (pa_idx v = 0; v < m->nv; v++) {
        CHECK(pa__metric_valid(dim, nc, g + (size_t)nc * v));
        bad += !contains(dim, nc, g + (size_t)nc * v, met + (size_t)nc * v);
      }
      CHECK(bad == 0);
      /* idempotent */
      memcpy(m->met, g, sizeof(double) * nc * m->nv);
      double *g2 = graded(m, NULL, 1.3, 2.3, &nch2);
      CHECK(nch2 == 0);
      CHECK(ndiff(m, g2) == 0);
      printf("%dD %s: %d of %d vertices graded, a second gradation changes "
             "%d\n", dim, tensor ? "tensors" : "sizes", (int)nch, (int)m->nv,
             (int)nch2);
      free(g);
      free(g2);
      free(met);
      pa_mesh_destroy(m);
    }
}

/* The shell field's centre is isotropic with size h; the thin normal
 * directions around it (h/50 at radius 0.3) must grade it in every
 * direction: both sizes at most 0.6 h there (the bound alone, from the
 * nearest shell point at distance 0.3, gives h/50 + 0.3 ln 1.3 = 0.083;
 * the free turn of the frames leaves some of the anisotropy). */
static void test_shell_centre(void) {
  pa_mesh *m = NULL;
  CHECK_OK(pa_mesh_generate_box(2, 40, &m));
  CHECK_OK(pa_metric_analytic(m, "shell:0.2"));
  double *g = graded(m, NULL, 1.3, 2.3, NULL);
  for (pa_idx v = 0; v < m->nv; v++) {
    const double *x = m->coord + 2 * (size_t)v;
    if (fabs(x[0] - 0.5) > 1e-12 || fabs(x[1] - 0.5) > 1e-12) continue;
    double lam[2], vec[4];
    pa__sym_eigen(2, g + 3 * (size_t)v, lam, vec);
    printf("shell centre: sizes %.4f %.4f\n", 1 / sqrt(lam[0]),
           1 / sqrt(lam[1]));
    CHECK(1 / sqrt(lam[1]) <= 0.12);
  }
  free(g);
  pa_mesh_destroy(m);
}

/* A required vertex with a tiny size: hgradreq sets the growth from it. */
static void test_hgradreq(void) {
  pa_mesh *m = NULL;
  CHECK_OK(pa_mesh_generate_box(2, 10, &m));
  pa_idx nv = m->nv;
  double *h = malloc(sizeof(double) * nv);
  uint8_t *fz = calloc((size_t)nv, 1);
  for (pa_idx v = 0; v < nv; v++) h[v] = 1.0;
  h[0] = 0.001;
  fz[0] = 1;
  CHECK_OK(pa_mesh_set_metric(m, 1, h));
  double rates[3] = {2.3, 1.5, -1};
  for (int r = 0; r < 3; r++) {
    double *g = graded(m, fz, 1.3, rates[r], NULL);
    CHECK(g[0] == 0.001);
    /* vertex 1 is the neighbour at (0.1, 0) */
    double want = rates[r] > 1 ? 0.001 + log(rates[r]) * 0.1 : 1.0;
    CHECK_NEAR(g[1], want, 1e-12);
    free(g);
  }
  free(h);
  free(fz);
  pa_mesh_destroy(m);
}

TEST_MAIN(test_ugawg_unchanged, test_random_fields, test_shell_centre,
          test_hgradreq)
