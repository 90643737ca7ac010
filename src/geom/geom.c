/*
 * geom.c -- the geometry handle over a kernel's callbacks (pa_geometry_*),
 * the projections and curvatures the remeshers and the metric preparation
 * ask for (pa__geom_*), and the check of a classified mesh against its
 * model (pa_geometry_check).
 *
 * A projection never fails loudly: the kernel's failure, a point that is
 * not finite or that jumps farther than the caller allows (another sheet
 * of the entity) is counted and reported as 0, and the remesher keeps its
 * own reconstruction (docs/guide/geometry.md).
 */
#include "geom/geom.h"

#include <math.h>

pa_status pa_geometry_create(const pa_geometry_ops *ops, void *ctx,
                             double size, pa_geometry **geom) {
  pa_status st = PA_SUCCESS;
  pa_geometry *g = NULL;
  PA_CHECK(ops && geom, PA_ERR_ARG, "pa_geometry_create: NULL argument");
  *geom = NULL;
  PA_CHECK(ops->closest, PA_ERR_ARG,
           "pa_geometry_create: the kernel has no closest-point callback");
  PA_CHECK(isfinite(size) && size > 0, PA_ERR_ARG,
           "pa_geometry_create: the model size must be positive and finite, "
           "got %g",
           size);
  PA_CALLOC(g, 1);
  g->ops = *ops;
  g->ctx = ctx;
  g->size = size;
  *geom = g;
cleanup:
  return st;
}

void pa_geometry_destroy(pa_geometry *geom) {
  if (!geom) return;
  if (geom->release) geom->release(geom->ctx);
  pa__free(geom);
}

double pa_geometry_size(const pa_geometry *geom) {
  return geom ? geom->size : 0.0;
}

/* The counters of a geometry, which the const handles of the options
 * update: one thread at a time uses a geometry (geom.h). */
static pa_geometry *counters(const pa_geometry *g) { return (pa_geometry *)g; }

/* The kernel's closest point of (dim, tag) to x (3 values) in y: 1 when it
 * succeeded with a finite point. */
static int kernel_closest(const pa_geometry *g, int dim, int tag,
                          const double *x, double *y) {
  double t0 = pa_wtime();
  int rc = g->ops.closest(g->ctx, dim, tag, x, y);
  counters(g)->seconds += pa_wtime() - t0;
  return rc == 0 && isfinite(y[0]) && isfinite(y[1]) && isfinite(y[2]);
}

pa_status pa_geometry_closest(const pa_geometry *geom, int dim, int tag,
                              const double *x, double *y) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(geom && x && y, PA_ERR_ARG, "pa_geometry_closest: NULL argument");
  PA_CHECK(dim >= 0 && dim <= 2, PA_ERR_ARG,
           "pa_geometry_closest: entity dimension %d is not 0, 1 or 2", dim);
  PA_CHECK(kernel_closest(geom, dim, tag, x, y), PA_ERR_ARG,
           "the geometry kernel cannot project onto entity (%d, %d) (unknown "
           "entity, or the projection failed)",
           dim, tag);
cleanup:
  return st;
}

int pa__geom_project(const pa_geometry *g, int dim, int tag, int sdim,
                     const double *x, double maxjump, double *y) {
  double p[3] = {x[0], x[1], sdim == 3 ? x[2] : 0.0}, q[3];
  pa_geometry *c = counters(g);
  c->nproject++;
  int ok = kernel_closest(g, dim, tag, p, q);
  if (ok) {
    double d2 = 0;
    for (int k = 0; k < sdim; k++) d2 += (q[k] - p[k]) * (q[k] - p[k]);
    ok = sqrt(d2) <= maxjump;
  }
  if (!ok) {
    c->nfailed++;
    return 0;
  }
  for (int k = 0; k < sdim; k++) y[k] = q[k];
  return 1;
}

int pa__geom_curvature(const pa_geometry *g, int dim, int tag, int sdim,
                       const double *x, double *kappa) {
  if (!g->ops.curvature) return 0;
  double p[3] = {x[0], x[1], sdim == 3 ? x[2] : 0.0}, k = 0;
  double t0 = pa_wtime();
  int rc = g->ops.curvature(g->ctx, dim, tag, p, &k);
  counters(g)->seconds += pa_wtime() - t0;
  if (rc != 0 || !isfinite(k)) return 0;
  *kappa = fabs(k);
  return 1;
}

/* Lower the bound b (3 values: flag, hmin, hmax) of a vertex to the size
 * sqrt(8 hausd / kappa) of curvature kappa > 0 (not below the vertex's
 * hmin, else hmin): 1 when it lowered it. */
static int bound_by(double kappa, double hausd, double hmin, double *bv) {
  if (!(kappa > 0)) return 0;
  double h = sqrt(8.0 * hausd / kappa);
  double lo = bv[1] > 0 ? bv[1] : hmin;
  if (lo > 0 && h < lo) h = lo;
  if (bv[2] > 0 && bv[2] <= h) return 0;
  bv[0] = 1;
  bv[2] = h;
  return 1;
}

/* The bounds of the vertices of the nc cells (k vertices each, in cell,
 * references ref: the tags of entities of dimension edim) that lie on
 * lower entities (the entity's boundary: its curves and points) by the
 * curvature at the cell's centroid, which stays clear of the entity's
 * edges, where a kernel's curvature may be singular (a cone's apex). */
static pa_idx bound_entity_ends(const pa_geometry *g, const pa_mesh *m,
                                int edim, int k, pa_idx nc,
                                const pa_idx *cell, const int32_t *ref,
                                double hausd, double hmin,
                                const uint8_t *frozen, double *b) {
  pa_idx n = 0;
  int d = m->dim;
  for (pa_idx c = 0; c < nc; c++) {
    const pa_idx *v = cell + (size_t)k * c;
    int lower = 0;
    for (int i = 0; i < k; i++)
      lower |= m->vgdim[v[i]] < edim && !(frozen && frozen[v[i]]);
    if (!lower || ref[c] <= 0) continue;
    double x[3] = {0, 0, 0}, kappa;
    for (int i = 0; i < k; i++)
      for (int j = 0; j < d; j++) x[j] += m->coord[(size_t)d * v[i] + j] / k;
    if (!pa__geom_curvature(g, edim, ref[c], d, x, &kappa)) continue;
    for (int i = 0; i < k; i++)
      if (m->vgdim[v[i]] < edim && !(frozen && frozen[v[i]]))
        n += bound_by(kappa, hausd, hmin, b + 3 * (size_t)v[i]);
  }
  return n;
}

pa_idx pa__geom_hausd_bounds(const pa_geometry *g, const pa_mesh *m,
                             double hausd, double hmin, const uint8_t *frozen,
                             double *b) {
  pa_idx n = 0;
  int d = m->dim;
  if (!g->ops.curvature || !m->vgdim || !(hausd > 0)) return 0;
  for (pa_idx v = 0; v < m->nv; v++) {
    int gd = m->vgdim[v];
    double kappa;
    if ((gd != 1 && gd != 2) || (frozen && frozen[v])) continue;
    if (pa__geom_curvature(g, gd, m->vgtag[v], d,
                           m->coord + (size_t)d * v, &kappa))
      n += bound_by(kappa, hausd, hmin, b + 3 * (size_t)v);
  }
  /* the vertices on an entity's curves and points: its curvature there too
   * (a curve's end, a surface's rim), not only their own entity's */
  n += bound_entity_ends(g, m, d - 1, d, m->nb, m->bdry, m->bref, hausd, hmin,
                         frozen, b);
  if (d == 3)
    n += bound_entity_ends(g, m, 1, 2, m->ned, m->edge, m->edref, hausd, hmin,
                           frozen, b);
  return n;
}

pa_status pa_geometry_check(const pa_geometry *geom, pa_mesh *mesh,
                            double tol, pa_geometry_report *rep) {
  pa_status st = PA_SUCCESS;
  pa_geometry_report r;
  memset(&r, 0, sizeof r);
  r.worst = -1;
  PA_CHECK(geom && mesh, PA_ERR_ARG, "pa_geometry_check: NULL argument");
  PA_CHECK(mesh->vgdim, PA_ERR_ARG,
           "pa_geometry_check: the mesh is not classified (no vertex has a "
           "model entity)");
  double t0 = geom->seconds, sum = 0, bound = tol >= 0 ? tol * geom->size : -1;
  int d = mesh->dim;
  for (pa_idx v = 0; v < mesh->nv; v++) {
    int gd = mesh->vgdim[v], tag = mesh->vgtag[v];
    if (gd >= d) continue; /* interior: a volume (3D), a surface (2D) */
    const double *x = mesh->coord + (size_t)d * v;
    double p[3] = {x[0], x[1], d == 3 ? x[2] : 0.0}, y[3];
    PA_CHECK(kernel_closest(geom, gd, tag, p, y), PA_ERR_MESH,
             "vertex %ld lies on model entity (%d, %d), which the geometry "
             "does not have (or cannot project onto)",
             (long)v + 1, gd, tag);
    double dist = sqrt((y[0] - p[0]) * (y[0] - p[0]) +
                       (y[1] - p[1]) * (y[1] - p[1]) +
                       (y[2] - p[2]) * (y[2] - p[2]));
    sum += dist;
    r.nvert++;
    if (r.worst < 0 || dist > r.dist_max) {
      r.dist_max = dist;
      r.worst = v;
      r.worst_dim = gd;
      r.worst_tag = tag;
    }
    PA_CHECK(bound < 0 || dist <= bound, PA_ERR_MESH,
             "vertex %ld (%g %g %g) lies %g from its model entity (%d, %d), "
             "more than %g (%g of the model size %g): the mesh does not "
             "match the model",
             (long)v + 1, p[0], p[1], p[2], dist, gd, tag, bound, tol,
             geom->size);
  }
  r.dist_mean = r.nvert ? sum / r.nvert : 0;
  r.seconds = geom->seconds - t0;
cleanup:
  if (rep) *rep = r;
  return st;
}
