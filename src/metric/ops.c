/*
 * ops.c -- operations on whole metric fields: attaching a metric to a mesh
 * and checking it (pa_mesh_set_metric, pa_mesh_check: a metric value enters
 * a mesh only through them, so the kernels may assume valid values),
 * complexity, scaling to a complexity, intersection of two fields,
 * gradation of a mesh's metric.
 *
 * Complexity C = integral of sqrt(det M): on each element, its volume times
 * the mean of sqrt(det M) at its vertices. Scaling a metric by s^2 scales
 * the complexity by s^dim, so pa_metric_scale_complexity is exact in one
 * step.
 */
#include "metric/gradation.h"

#include <math.h>

/* PA_ERR_METRIC naming the first of nv values of nc components that is not
 * a valid metric (pa__metric_valid). */
static pa_status check_values(int dim, int nc, pa_idx nv, const double *val) {
  pa_status st = PA_SUCCESS;
  for (pa_idx v = 0; v < nv; v++)
    PA_CHECK(pa__metric_valid(dim, nc, val + (size_t)nc * v), PA_ERR_METRIC,
             "metric at vertex %d is not %s", (int)v + 1,
             nc == 1 ? "a finite positive size"
                     : "a finite symmetric positive definite tensor");
cleanup:
  return st;
}

pa_status pa_mesh_set_metric(pa_mesh *m, int ncomp, const double *values) {
  pa_status st = PA_SUCCESS;
  double *met = NULL;
  PA_CHECK(m, PA_ERR_ARG, "pa_mesh_set_metric: NULL mesh");
  PA_CHECK(ncomp == 0 || ncomp == 1 || ncomp == pa__tensor_ncomp(m->dim),
           PA_ERR_ARG, "a %dD metric has 1 or %d components, not %d", m->dim,
           pa__tensor_ncomp(m->dim), ncomp);
  if (ncomp == 0) {
    pa__free(m->met);
    m->met = NULL;
    m->met_ncomp = 0;
    return PA_SUCCESS;
  }
  PA_CHECK(values || m->nv == 0, PA_ERR_ARG, "pa_mesh_set_metric: NULL values");
  PA_CALL(check_values(m->dim, ncomp, m->nv, values));
  PA_ALLOC(met, (m->capv ? m->capv : 1) * ncomp);
  if (m->nv) memcpy(met, values, (size_t)m->nv * ncomp * sizeof(double));
  pa__free(m->met);
  m->met = met;
  met = NULL;
  m->met_ncomp = ncomp;
cleanup:
  pa__free(met);
  return st;
}

pa_status pa__mesh_check_metric(const pa_mesh *mesh) {
  if (!mesh->met_ncomp) return PA_SUCCESS;
  return check_values(mesh->dim, mesh->met_ncomp, mesh->nv, mesh->met);
}

pa_status pa_mesh_check(pa_mesh *mesh) {
  pa_status st = PA_SUCCESS;
  PA_CALL(pa__mesh_check(mesh, 1));
  PA_CALL(pa__mesh_check_metric(mesh));
cleanup:
  return st;
}

/* sqrt(det M) of a metric value (a size: h^-dim). */
static double density(int dim, int nc, const double *m) {
  if (nc == 1) return pow(m[0], -dim);
  double det = pa__sym_det(dim, m);
  return det > 0 ? sqrt(det) : 0.0;
}

double pa__elem_complexity(const pa_mesh *mesh, int nc, const double *met,
                           pa_idx e) {
  int d = mesh->dim, nve = d + 1;
  const pa_idx *v = mesh->elem + (size_t)nve * e;
  const double *x[4];
  double s = 0;
  for (int k = 0; k < nve; k++) {
    x[k] = mesh->coord + (size_t)d * v[k];
    s += density(d, nc, met + (size_t)nc * v[k]);
  }
  return fabs(pa__simplex_volume(d, x)) * s / nve;
}

static pa_status check_field(const pa_mesh *mesh, int nc, const double *met,
                             const char *who) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(mesh && met, PA_ERR_ARG, "%s: NULL argument", who);
  PA_CHECK(nc == 1 || nc == pa__tensor_ncomp(mesh->dim), PA_ERR_ARG,
           "%s: %d metric components in %dD", who, nc, mesh->dim);
cleanup:
  return st;
}

pa_status pa_metric_complexity(pa_mesh *mesh, int nc, const double *met,
                               double *complexity) {
  pa_status st = PA_SUCCESS;
  PA_CALL(check_field(mesh, nc, met, "pa_metric_complexity"));
  double c = 0;
  for (pa_idx e = 0; e < mesh->ne; e++)
    c += pa__elem_complexity(mesh, nc, met, e);
  *complexity = c;
cleanup:
  return st;
}

pa_status pa_metric_scale_complexity(pa_mesh *mesh, int nc, double *met,
                                     double target) {
  pa_status st = PA_SUCCESS;
  double c = 0;
  PA_CHECK(isfinite(target) && target > 0, PA_ERR_ARG,
           "pa_metric_scale_complexity: the target must be positive, got %g",
           target);
  PA_CALL(pa_metric_complexity(mesh, nc, met, &c));
  PA_CHECK(c > 0, PA_ERR_METRIC,
           "pa_metric_scale_complexity: the metric "
           "has no complexity on this mesh");
  /* M -> s^2 M multiplies sqrt(det M) by s^dim; a size h -> h / s */
  double s = pow(target / c, 1.0 / mesh->dim);
  for (pa_idx v = 0; v < mesh->nv; v++) {
    double *m = met + (size_t)nc * v;
    if (nc == 1)
      m[0] /= s;
    else
      for (int k = 0; k < nc; k++)
        m[k] *= s * s;
  }
cleanup:
  return st;
}

pa_status pa_metric_intersect_all(int dim, int nc, pa_idx nv, const double *a,
                                  const double *b, double *out) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(a && b && out && (dim == 2 || dim == 3) &&
               (nc == 1 || nc == pa__tensor_ncomp(dim)),
           PA_ERR_ARG, "pa_metric_intersect_all: bad arguments");
  for (pa_idx v = 0; v < nv; v++)
    pa__metric_intersect(dim, nc, a + (size_t)nc * v, b + (size_t)nc * v,
                         out + (size_t)nc * v);
cleanup:
  return st;
}

pa_status pa_mesh_metric_grade(pa_mesh *mesh, double hgrad, double hgradreq) {
  pa_status st = PA_SUCCESS;
  uint8_t *frozen = NULL;
  PA_CHECK(mesh && mesh->met_ncomp, PA_ERR_ARG,
           "pa_mesh_metric_grade: the mesh has no metric");
  PA_CHECK(isfinite(hgrad) && isfinite(hgradreq), PA_ERR_ARG,
           "pa_mesh_metric_grade: the rates must be numbers");
  PA_CALLOC(frozen, mesh->nv ? mesh->nv : 1);
  pa__mesh_frozen_vertices(mesh, frozen);
  PA_CALL(pa__metric_gradation(mesh->dim, mesh->met_ncomp, mesh->nv,
                               mesh->coord, mesh->met, mesh->ne, mesh->elem,
                               frozen, hgrad, hgradreq, NULL));
cleanup:
  pa__free(frozen);
  return st;
}

pa_status pa_mesh_metric_from_edges(pa_mesh *mesh) {
  pa_status st = PA_SUCCESS;
  size_t *start = NULL;
  pa_idx *other = NULL, *count = NULL;
  double *h = NULL;
  PA_CHECK(mesh, PA_ERR_ARG, "pa_mesh_metric_from_edges: NULL mesh");
  int d = mesh->dim;
  PA_CALL(pa__edges_csr(mesh->elem, mesh->ne, d + 1, mesh->nv, NULL, &start,
                        &other));
  PA_CALLOC(h, mesh->nv ? mesh->nv : 1);
  PA_CALLOC(count, mesh->nv ? mesh->nv : 1);
  for (pa_idx a = 0; a < mesh->nv; a++)
    for (size_t k = start[a]; k < start[a + 1]; k++) {
      pa_idx b = other[k];
      double l = 0;
      for (int c = 0; c < d; c++) {
        double e = mesh->coord[(size_t)d * a + c] - mesh->coord[(size_t)d * b + c];
        l += e * e;
      }
      l = sqrt(l);
      h[a] += l, h[b] += l;
      count[a]++, count[b]++;
    }
  for (pa_idx v = 0; v < mesh->nv; v++) {
    PA_CHECK(count[v] > 0 && h[v] > 0, PA_ERR_MESH,
             "vertex %d belongs to no element: it has no size", (int)v + 1);
    h[v] /= count[v];
  }
  PA_CALL(pa_mesh_set_metric(mesh, 1, h));
cleanup:
  pa__free(start);
  pa__free(other);
  pa__free(count);
  pa__free(h);
  return st;
}

/* Peak bytes per element the metric asks for, [parallel][dim == 3]: the
 * sequential remesher's (75 B per triangle on the gmsh plate, 138-162 B per
 * tetrahedron on the gmsh rod, padapt's counting allocator; BENCHMARKS.md),
 * and a rank's of the parallel driver per local element: in 3D 141-148 B
 * per output tetrahedron at 2 ranks from 1 M to 20 M (counted and RSS,
 * BENCHMARKS.md "Scale"), with 15-18 % more tetrahedra than the metric's
 * count, so 170, rounded up; in 2D 256-300 B, not measured since. */
static const double bytes_per_elem[2][2] = {{100, 200}, {350, 200}};

pa_status pa__check_output_size(int dim, double complexity, int nproc,
                                int parallel, double budget,
                                const char *budget_what) {
  pa_status st = PA_SUCCESS;
  double n = complexity / pa__unit_simplex_volume(dim);
  const char *what = dim == 2 ? "triangles" : "tetrahedra";
  PA_CHECK(isfinite(n) && n >= 0, PA_ERR_METRIC,
           "the metric asks for an unbounded number of %s (complexity %g): "
           "a size is zero or not finite",
           what, complexity);
  double need = n / (nproc > 0 ? nproc : 1) * bytes_per_elem[parallel != 0][dim == 3];
  PA_CHECK(!(budget > 0 && need > budget), PA_ERR_MEMORY,
           "the metric asks for about %.3g %s (complexity %.3g): about "
           "%.3g GiB per process at %d process%s, more than %s allows "
           "(%.3g GiB); give larger sizes (-hsiz, -hmin, the metric)%s",
           n, what, complexity, need / 1073741824.0, nproc > 0 ? nproc : 1,
           nproc > 1 ? "es" : "", budget_what, budget / 1073741824.0,
           parallel ? " or more processes" : " or run in parallel");
cleanup:
  return st;
}
