/*
 * test_adapt_grade.c -- the metric gradation of a distributed mesh
 * (src/adapt/grade.c, internal API), at any number of ranks: with sizes
 * (an analytic field with one vertex made 100 times smaller) the
 * gathered result equals the sequential gradation of the whole mesh (the
 * fixed point does not depend on the order or the distribution), every
 * copy of a vertex agrees, required vertices keep their size; with tensors
 * a second gradation changes nothing (a fixed point) and every edge obeys
 * the gradation bound of the sequential code (checked by running it on the
 * gathered result: it changes no vertex).
 */
#include "testutil.h"
#include "adapt/piece.h"
#include "metric/gradation.h"

#include <mpi.h>

/* The mesh gathered on rank 0 (vertices numbered by global id). */
static pa_mesh *gather(pa_dmesh *dm) {
  pa_mesh *g = NULL;
  CHECK_OK(pa_dmesh_gather(dm, 0, &g));
  return g;
}

/* 1 if every ghost copy holds its owner's value (bitwise). */
static int copies_agree(pa_dmesh *dm) {
  pa_mesh *m = pa_dmesh_mesh(dm);
  int nc = pa_mesh_metric_ncomp(m), ok = 1;
  pa_dmesh_value *val = NULL;
  pa_idx n = 0;
  CHECK_OK(pa_dmesh_value_add(dm, PA_VERTEX, "test.met", MPI_DOUBLE, nc, -1,
                              &val));
  double *x = pa_dmesh_value_data(val, &n, NULL);
  const double *met = pa_mesh_metric(m);
  memcpy(x, met, sizeof(double) * (size_t)nc * n);
  CHECK_OK(pa_dmesh_halo(dm, val));
  x = pa_dmesh_value_data(val, &n, NULL);
  ok = memcmp(x, met, sizeof(double) * (size_t)nc * n) == 0;
  CHECK_OK(pa_dmesh_value_remove(dm, val));
  MPI_Allreduce(MPI_IN_PLACE, &ok, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
  return ok;
}

static void run(int dim, int n, const char *metric, int overlap) {
  pa_mesh *m = NULL, *seq = NULL;
  pa_dmesh *dm = NULL;
  if (pa_test_rank == 0) {
    CHECK_OK(pa_mesh_generate_box(dim, n, &m));
    CHECK_OK(pa_metric_analytic(m, metric));
    if (m->met_ncomp == 1) /* a sharp spot: the gradation has work to do */
      m->met[m->nv / 2] *= 0.01;
    /* a required element keeps its vertices' metric */
    pa_mesh_elem_flags(m)[0] |= PA_FLAG_REQUIRED;
    CHECK_OK(pa_mesh_copy(m, &seq));
    pa__metric_gradation(dim, seq->met_ncomp, seq->nv, seq->coord, seq->met,
                         seq->ne, seq->elem, NULL, 1.3, 1.3, NULL);
  }
  CHECK_OK(pa_dmesh_distribute(MPI_COMM_WORLD, 0, m, overlap, &dm));
  int rounds = 0;
  uint8_t *frozen = NULL;
  CHECK_OK(pa__adapt_frozen(dm, &frozen));
  CHECK_OK(pa__adapt_grade(dm, frozen, 1.3, 1.3, &rounds));
  CHECK(rounds >= 1);
  CHECK(copies_agree(dm));
  /* a second gradation: nothing left to do */
  int rounds2 = 0;
  CHECK_OK(pa__adapt_grade(dm, frozen, 1.3, 1.3, &rounds2));
  pa__free(frozen);
  CHECK(rounds2 == 1);
  pa_mesh *g = gather(dm);
  if (pa_test_rank == 0 && g) {
    int nc = g->met_ncomp;
    CHECK(g->nv == m->nv);
    /* vertices of the required element: as given */
    for (int i = 0; i <= dim; i++) {
      pa_idx v = m->elem[i];
      CHECK(memcmp(g->met + (size_t)nc * v, m->met + (size_t)nc * v,
                   sizeof(double) * nc) == 0);
    }
    pa_idx changed = 0;
    if (nc == 1) {
      /* the sequential fixed point, but for the frozen vertices (the
       * sequential run above did not freeze them): compare elsewhere */
      uint8_t *fr = calloc((size_t)g->nv, 1);
      for (int i = 0; i <= dim; i++) fr[m->elem[i]] = 1;
      pa_mesh *s2 = NULL;
      CHECK_OK(pa_mesh_copy(m, &s2));
      pa__metric_gradation(dim, 1, s2->nv, s2->coord, s2->met, s2->ne,
                           s2->elem, fr, 1.3, 1.3, NULL);
      pa_idx bad = 0;
      for (pa_idx v = 0; v < g->nv; v++)
        bad += fabs(g->met[v] - s2->met[v]) > 1e-12 * s2->met[v];
      CHECK(bad == 0);
      /* and it did grade something */
      pa_idx diff = 0;
      for (pa_idx v = 0; v < g->nv; v++) diff += g->met[v] != m->met[v];
      CHECK(diff > 0);
      printf("  %dD %s: %d rounds, %d sizes graded, %d off the sequential "
             "result\n", dim, metric, rounds, (int)diff, (int)bad);
      pa_mesh_destroy(s2);
      free(fr);
    }
    /* the gathered metric is a fixed point of the sequential gradation */
    uint8_t *fr = calloc((size_t)g->nv, 1);
    for (int i = 0; i <= dim; i++) fr[m->elem[i]] = 1;
    pa__metric_gradation(dim, nc, g->nv, g->coord, g->met, g->ne, g->elem, fr,
                         1.3, 1.3, &changed);
    free(fr);
    CHECK(changed == 0);
    if (nc > 1)
      printf("  %dD %s: %d rounds, fixed point\n", dim, metric, rounds);
  }
  pa_mesh_destroy(g);
  pa_dmesh_destroy(dm);
  pa_mesh_destroy(m);
  pa_mesh_destroy(seq);
}

static void test_grade_sizes(void) {
  run(2, 16, "iso-shell:0.05", 0);
  run(3, 6, "iso-shell:0.1", 1);
}

static void test_grade_tensors(void) {
  run(2, 16, "shell:0.05", 0);
  run(3, 6, "layer:0.1", 0);
}

TEST_MPI_MAIN(test_grade_sizes, test_grade_tensors)
