/*
 * analytic.c -- built-in analytic metric fields, for tests, benchmarks and
 * demonstrations. A spec is "NAME" or "NAME:h"; h > 0 (default 0.1) is the
 * field's reference size. The fields are defined in absolute coordinates and
 * designed for the unit square [0,1]^2 / unit cube [0,1]^3; they are
 * evaluated exactly at each vertex of any mesh. Exact definitions (x is the
 * vertex position, d a distance):
 *
 *  uniform    ncomp 1, size h everywhere.
 *
 *  layer      tensor (3 or 6 components). Normal direction x (e_1), plane
 *             x = 0.5, d = |x_1 - 0.5|. Normal size
 *               hn(d) = h/100 + (h - h/100) * min(d, 0.25) / 0.25,
 *             i.e. h/100 at the plane growing linearly to h at d = 0.25 and
 *             constant beyond; tangential size h:
 *               M = diag(1/hn^2, 1/h^2 [, 1/h^2]).
 *
 *  shell      tensor. Centre c = (0.5, 0.5 [, 0.5]), r = |x - c|, radius
 *             R = 0.3, d = |r - R|, unit normal n = (x - c) / r. Normal size
 *               hn(d) = h/50 + (h - h/50) * min(d, 0.2) / 0.2,
 *             tangential size h:
 *               M = (1/hn^2) n n^T + (1/h^2) (I - n n^T).
 *             Where d >= 0.2 (including the centre, r < 0.1) M = I/h^2
 *             exactly, so the field is continuous everywhere.
 *
 *  iso-shell  ncomp 1, size hs(d) = h/10 + (h - h/10) * min(d, 0.2) / 0.2
 *             with d as in "shell".
 *
 *  ugawg-linear, ugawg-polar1, ugawg-polar2: the fields of the UGAWG
 *             benchmark (Ibanez, Barral, Krakos, Loseille, Michal, Park, "A
 *             benchmark case for unstructured mesh adaptation"), exactly as
 *             published for h = 0.1 (other h scale them). h0 = h/100,
 *             ramp(s) = h0 + 2 (h - h0) |s - 0.5|:
 *               linear  M = diag(1/h^2, 1/ramp(x_dim)^2) in 2D (x_dim = y),
 *                       diag(1/h^2, 1/h^2, 1/ramp(z)^2) in 3D;
 *               polar1  r = sqrt(x^2 + y^2), t = atan2(y, x): radial size
 *                       h_r = ramp(r), tangential size h_t = h, axial (3D)
 *                       size h: M = R diag(1/h_r^2, 1/h_t^2 [, 1/h^2]) R^T,
 *                       R the rotation by t about the z axis;
 *               polar2  polar1 with h_t = h d0 + (h/4)(1 - d0),
 *                       d0 = min(10 |r - 0.5|, 1).
 *
 * Sizes vary linearly with the distance, so along the normal consecutive
 * elements grow by a constant ratio 1 + dh/dd (about 1.4-1.5 for h = 0.1),
 * which a remesher can reach; the fields are continuous and piecewise smooth
 * (kinks only at the plane/shell and where the ramp ends).
 */
#include "metric/metric.h"

#include <errno.h>
#include <math.h>

enum {
  FIELD_UNIFORM,
  FIELD_LAYER,
  FIELD_SHELL,
  FIELD_ISO_SHELL,
  FIELD_UGAWG_LINEAR,
  FIELD_UGAWG_POLAR1,
  FIELD_UGAWG_POLAR2,
  FIELD_COUNT
};

static const char *const field_names[FIELD_COUNT + 1] = {
    "uniform",      "layer",        "shell",        "iso-shell",
    "ugawg-linear", "ugawg-polar1", "ugawg-polar2", NULL};

#define DEFAULT_H 0.1
#define LAYER_PLANE 0.5
#define LAYER_RATIO 100.0
#define LAYER_DIST 0.25
#define SHELL_RADIUS 0.3
#define SHELL_RATIO 50.0
#define ISO_SHELL_RATIO 10.0
#define SHELL_DIST 0.2

const char *const *pa_metric_analytic_names(void) { return field_names; }

/* Size growing linearly from h0 at d = 0 to h at d = dist, h beyond. */
static double ramp(double h0, double h, double d, double dist) {
  if (d >= dist) return h;
  return h0 + (h - h0) * (d / dist);
}

/* Distance to the shell and unit normal (n undefined when r == 0). */
static double shell_distance(int dim, const double *x, double *n) {
  double r2 = 0.0;
  for (int k = 0; k < dim; k++) {
    n[k] = x[k] - 0.5;
    r2 += n[k] * n[k];
  }
  double r = sqrt(r2);
  if (r > 0.0)
    for (int k = 0; k < dim; k++)
      n[k] /= r;
  return fabs(r - SHELL_RADIUS);
}

/* The UGAWG fields (see the file comment). */
#define UGAWG_H0_RATIO 100.0
#define UGAWG_POLAR2_BAND 0.1
#define UGAWG_POLAR2_RATIO 4.0

static void eval_ugawg(int field, int dim, double h, const double *x,
                       double *m) {
  int nt = pa__tensor_ncomp(dim);
  double h0 = h / UGAWG_H0_RATIO;
  for (int k = 0; k < nt; k++)
    m[k] = 0.0;
  for (int i = 0; i < dim; i++)
    m[pa__sym_index(i, i)] = 1.0 / (h * h);
  if (field == FIELD_UGAWG_LINEAR) {
    double hl = h0 + 2.0 * (h - h0) * fabs(x[dim - 1] - 0.5);
    m[pa__sym_index(dim - 1, dim - 1)] = 1.0 / (hl * hl);
    return;
  }
  double r = sqrt(x[0] * x[0] + x[1] * x[1]), t = atan2(x[1], x[0]);
  double hr = h0 + 2.0 * (h - h0) * fabs(r - 0.5), ht = h;
  if (field == FIELD_UGAWG_POLAR2) {
    double d0 = fmin(fabs(r - 0.5) / UGAWG_POLAR2_BAND, 1.0);
    ht = h * d0 + (h / UGAWG_POLAR2_RATIO) * (1.0 - d0);
  }
  double c = cos(t), s = sin(t), lr = 1.0 / (hr * hr), lt = 1.0 / (ht * ht);
  m[0] = lr * c * c + lt * s * s;
  m[1] = (lr - lt) * c * s;
  m[2] = lr * s * s + lt * c * c;
}

static void eval_field(int field, int dim, double h, const double *x,
                       double *m) {
  if (field >= FIELD_UGAWG_LINEAR) {
    eval_ugawg(field, dim, h, x, m);
    return;
  }
  int nt = pa__tensor_ncomp(dim);
  double n[3];
  switch (field) {
  case FIELD_UNIFORM:
    m[0] = h;
    return;
  case FIELD_ISO_SHELL:
    m[0] = ramp(h / ISO_SHELL_RATIO, h, shell_distance(dim, x, n), SHELL_DIST);
    return;
  case FIELD_LAYER: {
    double hn = ramp(h / LAYER_RATIO, h, fabs(x[0] - LAYER_PLANE), LAYER_DIST);
    double t = 1.0 / (h * h);
    for (int k = 0; k < nt; k++)
      m[k] = 0.0;
    m[0] = 1.0 / (hn * hn);
    m[2] = t;
    if (dim == 3) m[5] = t;
    return;
  }
  default: { /* FIELD_SHELL */
    double d = shell_distance(dim, x, n);
    double t = 1.0 / (h * h);
    for (int k = 0; k < nt; k++)
      m[k] = 0.0;
    for (int i = 0; i < dim; i++)
      m[pa__sym_index(i, i)] = t;
    if (d >= SHELL_DIST) return;
    double hn = ramp(h / SHELL_RATIO, h, d, SHELL_DIST);
    double a = 1.0 / (hn * hn) - t;
    for (int i = 0; i < dim; i++)
      for (int j = i; j < dim; j++)
        m[pa__sym_index(i, j)] += a * n[i] * n[j];
    return;
  }
  }
}

/* Parse "NAME[:h]" into a field index and a size; PA_ERR_ARG otherwise. */
static pa_status parse_spec(const char *spec, int *field, double *h) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(spec, PA_ERR_ARG, "pa_metric_analytic: NULL field name");
  const char *colon = strchr(spec, ':');
  size_t len = colon ? (size_t)(colon - spec) : strlen(spec);
  *field = -1;
  for (int f = 0; f < FIELD_COUNT; f++)
    if (strlen(field_names[f]) == len && !strncmp(spec, field_names[f], len))
      *field = f;
  PA_CHECK(*field >= 0, PA_ERR_ARG,
           "unknown metric field '%.*s' (valid names: uniform, layer, shell, "
           "iso-shell, ugawg-linear, ugawg-polar1, ugawg-polar2; each "
           "optionally followed by ':h', h > 0)",
           (int)(len > 200 ? 200 : len), spec);
  *h = DEFAULT_H;
  if (colon) {
    char *end = NULL;
    errno = 0;
    double v = strtod(colon + 1, &end);
    PA_CHECK(end != colon + 1 && *end == '\0' && errno == 0 && isfinite(v) &&
                 v > 0.0,
             PA_ERR_ARG,
             "metric field '%.200s': the size after ':' must be a finite "
             "positive number",
             spec);
    *h = v;
  }
cleanup:
  return st;
}

pa_status pa_metric_analytic(pa_mesh *mesh, const char *spec) {
  pa_status st = PA_SUCCESS;
  double *val = NULL;
  int field = FIELD_UNIFORM;
  double h = DEFAULT_H;
  PA_CHECK(mesh, PA_ERR_ARG, "pa_metric_analytic: NULL mesh");
  PA_CALL(parse_spec(spec, &field, &h));
  int dim = mesh->dim;
  int ncomp = (field == FIELD_UNIFORM || field == FIELD_ISO_SHELL)
                  ? 1
                  : pa__tensor_ncomp(dim);
  PA_ALLOC(val, (size_t)mesh->nv * ncomp);
  for (pa_idx i = 0; i < mesh->nv; i++)
    eval_field(field, dim, h, mesh->coord + (size_t)dim * i,
               val + (size_t)ncomp * i);
  PA_CALL(pa_mesh_set_metric(mesh, ncomp, val));
cleanup:
  pa__free(val);
  return st;
}
