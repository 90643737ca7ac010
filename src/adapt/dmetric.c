/*
 * dmetric.c -- the metric toolbox on a distributed mesh: the Lp metric of a
 * vertex field (pa_dmesh_metric_from_hessian), the level-set metric
 * (pa_dmesh_metric_from_levelset), the complexity of the metric, and the
 * distributed context of the whole-field metric operations
 * (pa__adapt_metric_ctx), which pa_dmesh_adapt prepares its metric in too.
 *
 * The same kernels as the sequential functions (src/metric/recovery.c,
 * hessian.c, levelset.c) in a distributed context (pa__metric_ctx): the
 * domain is the owned elements, sums and maxima are reduced over the ranks,
 * the frozen vertices and local-parameter bounds are merged over the copies
 * of a vertex, the gradation runs over the whole distributed mesh
 * (grade.c). The
 * recovery needs each owned vertex's 2-ring, which two layers of ghost
 * elements hold: the mesh must have overlap 2. Values are computed at the
 * owned vertices and sent to their ghost copies, so every copy agrees bit
 * for bit, and the recovered Hessian does not depend on the partition (the
 * same stencil, summed in another order: round-off apart). The gradation
 * does (its sweeps and the copies' intersections run in another order);
 * without it, so does the whole metric.
 */
#include "adapt/piece.h"
#include "metric/gradation.h"

#include <math.h>

static pa_status d_sum(void *ctx, double *x) {
  pa_dmesh *dm = ctx;
  return pa__allreduce(dm->comm, x, 1, MPI_DOUBLE, MPI_SUM);
}

static pa_status d_max(void *ctx, double *x) {
  pa_dmesh *dm = ctx;
  return pa__allreduce(dm->comm, x, 1, MPI_DOUBLE, MPI_MAX);
}

static pa_status d_bor(void *ctx, unsigned *x) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = ctx;
  int c = (int)*x;
  PA_CALL(pa__allreduce(dm->comm, &c, 1, MPI_INT, MPI_BOR));
  *x = (unsigned)c;
cleanup:
  return st;
}

static pa_status d_agree(void *ctx, pa_status st) {
  pa_dmesh *dm = ctx;
  return pa__agree(dm->comm, st);
}

static pa_status d_frozen(void *ctx, uint8_t **frozen) {
  return pa__adapt_frozen(ctx, frozen);
}

static void combine_bounds(const void *in, void *inout, pa_idx n, void *ctx) {
  (void)ctx;
  for (pa_idx i = 0; i < n; i++)
    pa__local_bounds_merge((const double *)in + 3 * (size_t)i,
                           (double *)inout + 3 * (size_t)i);
}

/* The bounds of every copy of a vertex merged on the owner, sent back to
 * the ghosts. */
static pa_status d_merge_bounds(void *ctx, double *b) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = ctx;
  pa_dmesh_value *val = NULL;
  size_t bytes = 3 * sizeof *b * (size_t)dm->nloc[PA_VERTEX];
  PA_CALL(pa_dmesh_value_add(dm, PA_VERTEX, "pa.adapt.bounds", MPI_DOUBLE, 3,
                             -1, &val));
  memcpy(pa_dmesh_value_data(val, NULL, NULL), b, bytes);
  PA_CALL(pa__dmesh_reduce_fn(dm, val, combine_bounds, NULL));
  PA_CALL(pa_dmesh_halo(dm, val));
  memcpy(b, pa_dmesh_value_data(val, NULL, NULL), bytes);
cleanup:
  return pa__dmesh_value_drop(dm, val, pa__agree_end(dm->comm, st));
}

/* The gradation of met, which is the mesh's metric array. */
static pa_status d_grade(void *ctx, int nc, double *met, const uint8_t *frozen,
                         double hgrad, double hgradreq, int *changed) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = ctx;
  int rounds = 0;
  PA_ASSERT(met == dm->mesh->met && nc == dm->mesh->met_ncomp);
  (void)met;
  (void)nc;
  PA_CALL(pa__adapt_grade(dm, frozen, hgrad, hgradreq, &rounds));
  if (changed) *changed = rounds > 1;
cleanup:
  return st;
}

void pa__adapt_metric_ctx(pa_dmesh *dm, pa__metric_ctx *c) {
  c->mesh = dm->mesh;
  c->nelem = dm->nown[PA_ELEMENT];
  c->sum = d_sum;
  c->max = d_max;
  c->bor = d_bor;
  c->agree = d_agree;
  c->frozen = d_frozen;
  c->merge_bounds = d_merge_bounds;
  c->grade = d_grade;
  c->ctx = dm;
}

/* Give every ghost copy the owner's n doubles per local vertex of x. */
static pa_status halo_doubles(pa_dmesh *dm, double *x, int n) {
  pa_status st = PA_SUCCESS;
  pa_dmesh_value *val = NULL;
  pa_idx nv = dm->nloc[PA_VERTEX];
  PA_CALL(pa_dmesh_value_add(dm, PA_VERTEX, "pa.dmetric.halo", MPI_DOUBLE, n,
                             -1, &val));
  memcpy(pa_dmesh_value_data(val, NULL, NULL), x, sizeof(double) * n * nv);
  PA_CALL(pa_dmesh_halo(dm, val));
  memcpy(x, pa_dmesh_value_data(val, NULL, NULL), sizeof(double) * n * nv);
cleanup:
  return pa__dmesh_value_drop(dm, val, st);
}

/* A tensor metric on every local vertex (the identity, to be overwritten). */
static pa_status install_tensor_metric(pa_mesh *m) {
  pa_status st = PA_SUCCESS;
  int nt = pa__tensor_ncomp(m->dim);
  double *id = NULL;
  PA_CALLOC(id, (size_t)nt * (m->nv ? m->nv : 1));
  for (pa_idx v = 0; v < m->nv; v++)
    for (int i = 0; i < m->dim; i++)
      id[(size_t)nt * v + pa__sym_index(i, i)] = 1;
  PA_CALL(pa_mesh_set_metric(m, nt, id));
cleanup:
  pa__free(id);
  return st;
}

/* The scalar u of vertex field `field`, component comp (0-based). */
static pa_status field_of(pa_dmesh *dm, int field, int comp, const double **u,
                          int *stride) {
  pa_status st = PA_SUCCESS;
  pa_mesh *m = dm->mesh;
  PA_CHECK(pa_dmesh_overlap(dm) >= 2, PA_ERR_ARG,
           "the distributed metric tools need a mesh with overlap 2 (the "
           "recovery uses each vertex's 2-ring), this one has %d",
           pa_dmesh_overlap(dm));
  PA_CHECK(field >= 0 && field < m->nfield, PA_ERR_ARG,
           "no vertex field %d (the mesh has %d)", field, m->nfield);
  PA_CHECK(comp >= 0 && comp < m->field[field].ncomp, PA_ERR_ARG,
           "field '%s' has %d components, no component %d",
           m->field[field].name, m->field[field].ncomp, comp + 1);
  *u = m->field[field].val + comp;
  *stride = m->field[field].ncomp;
cleanup:
  return st;
}

pa_status pa_dmesh_metric_from_hessian(pa_dmesh *dm, int field, int comp,
                                       const pa_metric_hessian_opts *o) {
  pa_status st = PA_SUCCESS;
  double *h = NULL;
  uint8_t *owned = NULL;
  PA_CHECK(dm && o, PA_ERR_ARG, "pa_dmesh_metric_from_hessian: NULL argument");
  pa__agree_reset();
  pa_mesh *m = dm->mesh;
  const double *u = NULL;
  int stride = 1, nt = pa__tensor_ncomp(dm->dim);
  pa_idx nv = dm->nloc[PA_VERTEX];
  PA_CALL(field_of(dm, field, comp, &u, &stride));
  PA_ALLOC(h, (size_t)nt * (nv ? nv : 1));
  PA_CALLOC(owned, nv ? nv : 1);
  memset(owned, 1, (size_t)dm->nown[PA_VERTEX]);
  PA_CALL(pa__recover(m, u, stride, o->recovery, owned, NULL, h));
  PA_CALL(pa__agree(dm->comm, st));
  PA_CALL(halo_doubles(dm, h, nt));
  PA_CALL(install_tensor_metric(m));
  pa__metric_ctx c;
  pa__adapt_metric_ctx(dm, &c);
  PA_CALL(pa__metric_from_hessian(&c, h, o, m->met));
cleanup:
  pa__free(h);
  pa__free(owned);
  return dm ? pa__agree_end(dm->comm, st) : st;
}

pa_status pa_dmesh_metric_from_levelset(pa_dmesh *dm, int field,
                                        const pa_metric_levelset_opts *o) {
  pa_status st = PA_SUCCESS;
  double *met = NULL, *phi = NULL;
  uint8_t *frozen = NULL;
  PA_CHECK(dm && o, PA_ERR_ARG, "pa_dmesh_metric_from_levelset: NULL argument");
  pa__agree_reset();
  pa_mesh *m = dm->mesh;
  const double *u = NULL;
  int stride = 1, nt = pa__tensor_ncomp(dm->dim);
  pa_idx nv = dm->nloc[PA_VERTEX];
  PA_CALL(field_of(dm, field, 0, &u, &stride));
  PA_ALLOC(phi, nv ? nv : 1);
  for (pa_idx v = 0; v < nv; v++)
    phi[v] = u[(size_t)stride * v];
  /* the local metric without gradation; the ghosts' copies (incomplete
   * stencils at the outer layer) replaced by their owners' */
  pa_metric_levelset_opts lo = *o;
  lo.hgrad = 0;
  PA_ALLOC(met, (size_t)nt * (nv ? nv : 1));
  st = pa_metric_from_levelset(m, phi, &lo, met);
  PA_CALL(pa__agree(dm->comm, st));
  PA_CALL(halo_doubles(dm, met, nt));
  PA_CALL(pa_mesh_set_metric(m, nt, met));
  PA_CALL(pa__agree(dm->comm, st));
  if (o->hgrad > 1) {
    PA_CALL(pa__adapt_frozen(dm, &frozen));
    PA_CALL(pa__adapt_grade(dm, frozen, o->hgrad, 0, NULL));
  }
cleanup:
  pa__free(met);
  pa__free(phi);
  pa__free(frozen);
  return dm ? pa__agree_end(dm->comm, st) : st;
}

pa_status pa_dmesh_metric_complexity(pa_dmesh *dm, double *complexity) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(dm && complexity, PA_ERR_ARG,
           "pa_dmesh_metric_complexity: NULL argument");
  pa__agree_reset();
  pa_mesh *m = dm->mesh;
  PA_CHECK(m->met_ncomp, PA_ERR_ARG,
           "pa_dmesh_metric_complexity: the mesh has no metric");
  double c = 0;
  for (pa_idx e = 0; e < dm->nown[PA_ELEMENT]; e++)
    c += pa__elem_complexity(m, m->met_ncomp, m->met, e);
  PA_CALL(pa__allreduce(dm->comm, &c, 1, MPI_DOUBLE, MPI_SUM));
  *complexity = c;
cleanup:
  return dm ? pa__agree_end(dm->comm, st) : st;
}
