/*
 * grade.c -- metric gradation of a distributed mesh, once, before the
 * piece loop (the sequential remesher grades its input once too).
 *
 * Each round grades the local metric over the local elements
 * (pa__metric_gradation, to its local fixed point), then gives every copy
 * of a vertex the intersection of all copies (sizes: the smallest; tensors:
 * pa__metric_intersect), reduced on the owner in rank order and sent back
 * to the ghosts, so all copies agree bit for bit. Gradation only shrinks
 * sizes, so the rounds stop when a round changes no vertex on any rank; a
 * constraint crosses one rank boundary per round. Frozen vertices (required,
 * or on a required element or boundary entity, on any rank) keep their
 * metric but constrain their neighbours, as in pa_remesh.
 *
 * For sizes the result is the sequential one (the fixed point h_q = min over
 * the edges pq of h_p + ln(hgrad) |pq| does not depend on the order); for
 * tensors it depends on the order of the intersections, like the sequential
 * gradation itself.
 */
#include "adapt/piece.h"
#include "metric/gradation.h"

#define MAX_ROUNDS 200

typedef struct grade_ctx {
  int dim, nc;
} grade_ctx;

/* Intersection of n metric values (in into inout). */
static void combine_metric(const void *in, void *inout, pa_idx n, void *ctx) {
  const grade_ctx *c = ctx;
  const double *a = in;
  double *b = inout;
  for (pa_idx i = 0; i < n; i++) {
    const double *x = a + (size_t)c->nc * i;
    double *y = b + (size_t)c->nc * i;
    if (c->nc == 1) {
      if (x[0] < y[0]) y[0] = x[0];
    } else {
      double t[6];
      pa__metric_intersect(c->dim, c->nc, x, y, t);
      memcpy(y, t, (size_t)c->nc * sizeof *t);
    }
  }
}

pa_status pa__adapt_frozen(pa_dmesh *dm, uint8_t **frozenp) {
  pa_status st = PA_SUCCESS;
  pa_idx nv = dm->nloc[PA_VERTEX];
  pa_dmesh_value *val = NULL;
  uint8_t *f = NULL;
  PA_CALL(pa_dmesh_value_add(dm, PA_VERTEX, "pa.adapt.gradefrozen", MPI_INT, 1,
                             -1, &val));
  PA_ALLOC(f, nv ? nv : 1);
  pa__mesh_frozen_vertices(dm->mesh, f); /* the local view */
  {
    int *x = pa_dmesh_value_data(val, NULL, NULL);
    for (pa_idx v = 0; v < nv; v++)
      x[v] = f[v];
  }
  PA_CALL(pa_dmesh_reduce(dm, val, MPI_MAX));
  PA_CALL(pa_dmesh_halo(dm, val));
  {
    const int *x = pa_dmesh_value_data(val, NULL, NULL);
    for (pa_idx v = 0; v < nv; v++)
      f[v] = (uint8_t)(x[v] != 0);
  }
  *frozenp = f;
  f = NULL;
cleanup:
  st = pa__dmesh_value_drop(dm, val, pa__agree_end(dm->comm, st));
  pa__free(f);
  return st;
}

pa_status pa__adapt_grade(pa_dmesh *dm, const uint8_t *frozen, double hgrad,
                          double hgradreq, int *nrounds) {
  pa_status st = PA_SUCCESS;
  pa_mesh *m = dm->mesh;
  int nc = m->met_ncomp;
  pa_idx nv = dm->nloc[PA_VERTEX];
  pa_dmesh_value *val = NULL;
  grade_ctx ctx = {dm->dim, nc};
  int round = 0;
  if (nrounds) *nrounds = 0;
  if (!(hgrad > 1.0 || hgradreq > 1.0) || nc == 0) return PA_SUCCESS;
  PA_CALL(pa_dmesh_value_add(dm, PA_VERTEX, "pa.adapt.grademet", MPI_DOUBLE, nc,
                             -1, &val));
  for (round = 1; round <= MAX_ROUNDS; round++) {
    pa_idx nch = 0;
    PA_CALL(pa__metric_gradation(dm->dim, nc, nv, m->coord, m->met, m->ne,
                                 m->elem, frozen, hgrad, hgradreq, &nch));
    PA_CALL(pa__agree(dm->comm, st));
    double changed = (double)nch;
    PA_CALL(pa__allreduce(dm->comm, &changed, 1, MPI_DOUBLE, MPI_SUM));
    if (changed == 0) break;
    double *x = pa_dmesh_value_data(val, NULL, NULL);
    memcpy(x, m->met, sizeof(double) * (size_t)nc * nv);
    PA_CALL(pa__dmesh_reduce_fn(dm, val, combine_metric, &ctx));
    PA_CALL(pa_dmesh_halo(dm, val));
    x = pa_dmesh_value_data(val, NULL, NULL);
    memcpy(m->met, x, sizeof(double) * (size_t)nc * nv);
  }
  if (nrounds) *nrounds = round;
cleanup:
  return pa__dmesh_value_drop(dm, val, pa__agree_end(dm->comm, st));
}
