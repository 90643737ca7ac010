/*
 * test_adapt.c -- the parallel adaptation driver (pa_dmesh_adapt) with the
 * example bisection remesher and the built-in remesher: valid conforming
 * output (collective check, and again after gathering), volume kept,
 * convergence (and a tail of tagged elements ending it), and the
 * statistics of pa_dmesh_stats equal to those of the gathered mesh. Runs
 * at any number of ranks.
 */
#include "testutil.h"
#include "bisect_remesher.h"

#include <math.h>
#include <mpi.h>


/* A box of dimension dim on pa_test_rank 0 with an analytic metric (or none),
 * distributed with the given overlap. */
static pa_dmesh *make(int dim, int n, const char *metric, int overlap) {
  pa_mesh *m = NULL;
  pa_dmesh *dm = NULL;
  if (pa_test_rank == 0) {
    CHECK_OK(pa_mesh_generate_box(dim, n, &m));
    if (metric) CHECK_OK(pa_metric_analytic(m, metric));
  }
  CHECK_OK(pa_dmesh_distribute(MPI_COMM_WORLD, 0, m, overlap, &dm));
  pa_mesh_destroy(m);
  return dm;
}

/* Collective check, then gather and check sequentially; returns the
 * gathered statistics on every pa_test_rank (broadcast). */
static void check_valid(pa_dmesh *dm, pa_stats *gs) {
  pa_mesh *g = NULL;
  pa_stats s;
  memset(&s, 0, sizeof s);
  CHECK_OK(pa_dmesh_check(dm));
  CHECK_OK(pa_dmesh_gather(dm, 0, &g));
  if (pa_test_rank == 0) {
    CHECK(g != NULL);
    if (g) {
      CHECK_OK(pa_mesh_check(g));
      CHECK_OK(pa_mesh_stats(g, &s));
      CHECK_NEAR(pa_mesh_volume(g), 1.0, 1e-9);
    }
  }
  MPI_Bcast(&s, sizeof s, MPI_BYTE, 0, MPI_COMM_WORLD);
  if (gs) *gs = s;
  pa_mesh_destroy(g);
}

static void opts_small(pa_adapt_opts *o, const pa_remesher *r) {
  pa_adapt_opts_default(o);
  o->remesher = r;
  o->min_piece_work = 20; /* many pieces even on small meshes */
  o->min_piece_ratio = 0;
}

static void test_bisect_uniform(void) {
  pa_dmesh *dm = make(2, 8, NULL, 0);
  pa_adapt_opts o;
  pa_adapt_report rep;
  pa_stats s, ds;
  opts_small(&o, bisect_remesher());
  o.remesh.hsiz = 0.05;
  CHECK_OK(pa_dmesh_adapt(dm, &o, &rep));
  CHECK(rep.converged);
  CHECK(rep.nfailed == 0);
  CHECK(rep.nelem_final > rep.nelem_initial);
  check_valid(dm, &s);
  CHECK_OK(pa_dmesh_stats(dm, &ds));
  CHECK(ds.nelem == s.nelem && ds.nedge == s.nedge && ds.nvert == s.nvert);
  for (int k = 0; k < PA_STATS_EDGE_NBIN; k++) CHECK(ds.edge_hist[k] == s.edge_hist[k]);
  CHECK(ds.valid);
  /* bisection never makes an edge longer than sqrt 2 stay */
  CHECK(ds.edge_max <= 1.4142);
  if (pa_test_rank == 0)
    printf("bisect 2D: %lld -> %lld elements, %d iterations, %ld pieces, "
           "edges in range %.1f %%\n", (long long)rep.nelem_initial,
           (long long)rep.nelem_final, rep.niter, rep.npieces,
           100.0 * s.edge_hist[PA_STATS_EDGE_NBIN - 1] / (double)s.nedge);
  pa_dmesh_destroy(dm);
}

static void test_bisect_3d(void) {
  pa_dmesh *dm = make(3, 3, NULL, 1);
  pa_adapt_opts o;
  pa_adapt_report rep;
  opts_small(&o, bisect_remesher());
  o.remesh.hsiz = 0.15;
  CHECK_OK(pa_dmesh_adapt(dm, &o, &rep));
  CHECK(rep.converged);
  CHECK(rep.nfailed == 0);
  check_valid(dm, NULL);
  if (pa_test_rank == 0)
    printf("bisect 3D: %lld -> %lld elements, %d iterations\n",
           (long long)rep.nelem_initial, (long long)rep.nelem_final, rep.niter);
  pa_dmesh_destroy(dm);
}

static void test_builtin(void) {
  pa_dmesh *dm = make(2, 8, "iso-shell:0.2", 0);
  pa_adapt_opts o;
  pa_adapt_report rep;
  pa_stats s;
  opts_small(&o, NULL);
  CHECK_OK(pa_dmesh_adapt(dm, &o, &rep));
  CHECK(rep.converged);
  check_valid(dm, &s);
  if (pa_test_rank == 0)
    printf("builtin 2D: %lld -> %lld elements, %d iterations, %ld pieces, "
           "edges in range %.1f %%, worst quality %.3f\n",
           (long long)rep.nelem_initial, (long long)rep.nelem_final, rep.niter,
           rep.npieces,
           100.0 * s.edge_hist[PA_STATS_EDGE_NBIN - 1] / (double)s.nedge,
           s.qual_min);
  pa_dmesh_destroy(dm);
}

/* box2d n at size 1.05 / n (every edge in range, nothing tagged) with its
 * vertex at (0.5, 0.5) moved by f cells in x, distributed. */
static pa_dmesh *make_moved(int n, double f) {
  pa_mesh *m = NULL;
  pa_dmesh *dm = NULL;
  if (pa_test_rank == 0) {
    CHECK_OK(pa_mesh_generate_box(2, n, &m));
    double *x = pa_mesh_coords(m);
    for (pa_idx v = 0; v < pa_mesh_nvert(m); v++)
      if (fabs(x[2 * v] - 0.5) < 0.1 / n && fabs(x[2 * v + 1] - 0.5) < 0.1 / n)
        x[2 * v] += f / n;
  }
  CHECK_OK(pa_dmesh_distribute(MPI_COMM_WORLD, 0, m, 0, &dm));
  pa_mesh_destroy(m);
  return dm;
}

/* A tail of tagged elements (a few in 180 000) that a sequential remesh
 * would leave as they are (a short edge, a long one under 2, no quality
 * under 0.05) ends the loop as converged before any piece; one with a
 * quality under 0.05 is remeshed. */
static void test_tail(void) {
  for (int bad = 0; bad < 2; bad++) {
    pa_dmesh *dm = make_moved(300, bad ? 0.97 : 0.6);
    pa_adapt_opts o;
    pa_adapt_report rep;
    pa_adapt_opts_default(&o);
    o.remesh.hsiz = 1.05 / 300;
    CHECK_OK(pa_dmesh_adapt(dm, &o, &rep));
    CHECK(rep.converged);
    if (bad) {
      CHECK(rep.npieces >= 1);
    } else {
      CHECK(rep.npieces == 0);
      CHECK(rep.ntagged_left > 0 && rep.ntagged_left <= 18);
    }
    if (pa_test_rank == 0)
      printf("tail (%s): %lld tagged left, %d iterations, %ld pieces\n",
             bad ? "a sliver" : "edges out of range",
             (long long)rep.ntagged_left, rep.niter, rep.npieces);
    pa_dmesh_destroy(dm);
  }
}

TEST_MPI_MAIN(test_bisect_uniform, test_bisect_3d, test_builtin, test_tail)
