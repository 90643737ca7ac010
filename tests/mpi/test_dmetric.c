/*
 * test_dmetric.c -- the metric toolbox on a distributed mesh
 * (src/adapt/dmetric.c) at any number of ranks:
 *  - the Hessian metric of a vertex field (a tanh layer), without
 *    gradation, equals the sequential pa_metric_from_hessian of the whole
 *    mesh to round-off (the recovery does not depend on the partition);
 *  - with the gradation it reaches the same complexity within 0.5 %, and
 *    every copy of a vertex holds the same metric;
 *  - the distributed complexity equals the sequential one;
 *  - a mesh without overlap 2 is refused with a clear error.
 */
#include "adapt/piece.h"
#include "testutil.h"

#include <mpi.h>

static double field(int dim, const double *x) {
  return tanh(15 * (x[0] - 0.5 - 0.1 * sin(3 * x[1]))) +
         (dim == 3 ? 0.3 * x[2] * x[2] : 0);
}

/* The mesh with its field (rank 0), the distributed mesh of overlap ov. */
static pa_dmesh *setup(int dim, int n, int ov, pa_mesh **seq) {
  pa_mesh *m = NULL;
  pa_dmesh *dm = NULL;
  *seq = NULL;
  if (pa_test_rank == 0) {
    CHECK_OK(pa_mesh_generate_box(dim, n, &m));
    double *u = malloc(sizeof(double) * m->nv);
    for (pa_idx v = 0; v < m->nv; v++)
      u[v] = field(dim, m->coord + dim * v);
    CHECK_OK(pa_mesh_add_field(m, "u", 1, u));
    free(u);
    CHECK_OK(pa_mesh_copy(m, seq));
  }
  CHECK_OK(pa_dmesh_distribute(MPI_COMM_WORLD, 0, m, ov, &dm));
  pa_mesh_destroy(m);
  return dm;
}

static void run(int dim, int n, double target) {
  pa_mesh *seq = NULL, *g = NULL;
  pa_dmesh *dm = setup(dim, n, 2, &seq);
  int nt = dim == 2 ? 3 : 6;
  pa_metric_hessian_opts o;
  pa_metric_hessian_opts_default(&o);
  o.target = target;
  o.hmin = 1e-3;
  o.hmax = 0.25;
  o.hgrad = -1;
  CHECK_OK(pa_dmesh_metric_from_hessian(dm, 0, 0, &o));
  double cd = 0;
  CHECK_OK(pa_dmesh_metric_complexity(dm, &cd));
  CHECK_OK(pa_dmesh_gather(dm, 0, &g));
  if (pa_test_rank == 0) {
    double *met = malloc(sizeof(double) * nt * seq->nv), cs = 0;
    CHECK_OK(pa_metric_from_hessian(seq, seq->field[0].val, 1, &o, met));
    CHECK_OK(pa_metric_complexity(seq, nt, met, &cs));
    CHECK(g->nv == seq->nv && g->met_ncomp == nt);
    double dev = 0;
    for (pa_idx v = 0; v < seq->nv; v++) {
      double s = 0;
      for (int k = 0; k < nt; k++)
        s = fmax(s, fabs(met[nt * v + k]));
      for (int k = 0; k < nt; k++)
        dev = fmax(dev, fabs(g->met[nt * v + k] - met[nt * v + k]) / s);
    }
    printf("  %dD: complexity %.3f distributed, %.3f sequential; largest "
           "relative difference %.2e\n",
           dim, cd, cs, dev);
    /* round-off: the fits' sums in another order, through the normal
     * equations and det^(-1/(2p+d)); measured up to 1.4e-9 in 3D */
    CHECK(dev < 1e-8);
    CHECK(fabs(cd / cs - 1) < 1e-12);
    free(met);
  }
  pa_mesh_destroy(g);
  g = NULL;
  /* with the gradation: the target complexity, copies agree */
  o.hgrad = 1.3;
  CHECK_OK(pa_dmesh_metric_from_hessian(dm, 0, 0, &o));
  CHECK_OK(pa_dmesh_metric_complexity(dm, &cd));
  CHECK(fabs(cd / target - 1) < 5e-3);
  CHECK_OK(pa_dmesh_check(dm)); /* ghosts hold their owners' metric */
  pa_dmesh_destroy(dm);
  pa_mesh_destroy(seq);
}

static void test_hessian(void) {
  run(2, 24, 2000);
  run(3, 8, 8000);
}

static void test_needs_overlap(void) {
  pa_mesh *seq = NULL;
  pa_dmesh *dm = setup(2, 8, 1, &seq);
  pa_metric_hessian_opts o;
  pa_metric_hessian_opts_default(&o);
  o.target = 100;
  pa_status st = pa_dmesh_metric_from_hessian(dm, 0, 0, &o);
  CHECK(st == PA_ERR_ARG);
  CHECK(strstr(pa_last_error(), "overlap 2") != NULL);
  pa_dmesh_destroy(dm);
  pa_mesh_destroy(seq);
}

TEST_MPI_MAIN(test_hessian, test_needs_overlap)
