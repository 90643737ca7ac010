/*
 * gmsh_model.c -- models read through Gmsh's library (its C API, gmshc.h,
 * with OpenCASCADE inside): pa_geometry_read and pa_geometry_available.
 * The only code of padapt that calls Gmsh (scripts/check-layers.sh checks
 * that no other file includes gmshc.h).
 *
 * Gmsh's library is opened at the first pa_geometry_read (dlopen of the
 * library CMake found, PADAPT_GMSH_LIBRARY), not linked: it brings
 * OpenCASCADE, FLTK and OpenGL with it, whose loading costs every padapt
 * process about 60 ms of CPU (measured on the development machine) and
 * which a user who never reads a model needs not install. Built without it
 * (PADAPT_HAVE_GMSH undefined: no gmshc.h, or -DPADAPT_GMSH=OFF), every
 * entry fails with a message saying so.
 *
 * Gmsh keeps one current model per process: one Gmsh geometry lives at a
 * time (a second read fails until the first is destroyed). The model's
 * entities are listed once at load (tags sorted per dimension, the points'
 * coordinates), so that an entity the model lacks is refused without
 * asking Gmsh, and a point's closest point is its own.
 */
#include "geom/geom.h"

#ifdef PADAPT_HAVE_GMSH

#include <dlfcn.h>
#include <errno.h>
#include <gmshc.h>
#include <stdio.h>

/* The functions of Gmsh's C API padapt calls, resolved by dlsym. */
typedef struct gmsh_api {
  __typeof__(gmshInitialize) *initialize;
  __typeof__(gmshFinalize) *finalize;
  __typeof__(gmshOptionSetNumber) *option_set_number;
  __typeof__(gmshOpen) *open;
  __typeof__(gmshFree) *free;
  __typeof__(gmshModelGetEntities) *get_entities;
  __typeof__(gmshModelGetBoundingBox) *get_bounding_box;
  __typeof__(gmshModelGetValue) *get_value;
  __typeof__(gmshModelGetClosestPoint) *get_closest_point;
  __typeof__(gmshModelGetCurvature) *get_curvature;
  __typeof__(gmshModelGetPrincipalCurvatures) *get_principal_curvatures;
  __typeof__(gmshLoggerStart) *logger_start;
  __typeof__(gmshLoggerStop) *logger_stop;
  __typeof__(gmshLoggerGetLastError) *logger_get_last_error;
} gmsh_api;

static gmsh_api api;
static int api_state;       /* 0 not tried, 1 loaded, -1 failed */
static char api_why[512];   /* why it failed */
static int model_live;      /* a Gmsh geometry exists */

/* Open the library and resolve the API once per process (never closed:
 * OpenCASCADE's static objects do not survive an unload). */
static int api_load(void) {
  if (api_state) return api_state > 0;
  api_state = -1;
  void *lib = dlopen(PADAPT_GMSH_LIBRARY, RTLD_NOW | RTLD_LOCAL);
  if (!lib) {
    snprintf(api_why, sizeof api_why,
             "cannot load Gmsh's library %s (%s): install it (Debian: "
             "libgmsh4.8)",
             PADAPT_GMSH_LIBRARY, dlerror());
    return 0;
  }
  struct {
    const char *name;
    void **slot;
  } sym[] = {
      {"gmshInitialize", (void **)&api.initialize},
      {"gmshFinalize", (void **)&api.finalize},
      {"gmshOptionSetNumber", (void **)&api.option_set_number},
      {"gmshOpen", (void **)&api.open},
      {"gmshFree", (void **)&api.free},
      {"gmshModelGetEntities", (void **)&api.get_entities},
      {"gmshModelGetBoundingBox", (void **)&api.get_bounding_box},
      {"gmshModelGetValue", (void **)&api.get_value},
      {"gmshModelGetClosestPoint", (void **)&api.get_closest_point},
      {"gmshModelGetCurvature", (void **)&api.get_curvature},
      {"gmshModelGetPrincipalCurvatures",
       (void **)&api.get_principal_curvatures},
      {"gmshLoggerStart", (void **)&api.logger_start},
      {"gmshLoggerStop", (void **)&api.logger_stop},
      {"gmshLoggerGetLastError", (void **)&api.logger_get_last_error},
  };
  for (size_t i = 0; i < sizeof sym / sizeof *sym; i++) {
    void *f = dlsym(lib, sym[i].name);
    if (!f) {
      snprintf(api_why, sizeof api_why,
               "Gmsh's library %s has no function %s (another version "
               "than the one padapt was built with?)",
               PADAPT_GMSH_LIBRARY, sym[i].name);
      return 0;
    }
    memcpy(sym[i].slot, &f, sizeof f);
  }
  api_state = 1;
  return 1;
}

int pa_geometry_available(const char **why) {
  int ok = api_load();
  if (why) *why = ok ? "" : api_why;
  return ok;
}

/* A loaded model: its entities' tags per dimension (sorted) and its
 * points' coordinates (in the order of tags[0]). */
typedef struct gmodel {
  int *tags[3];
  size_t ntag[3];
  double *pxyz;
} gmodel;

static int find_tag(const gmodel *g, int dim, int tag) {
  size_t lo = 0, hi = g->ntag[dim];
  while (lo < hi) {
    size_t mid = lo + (hi - lo) / 2;
    if (g->tags[dim][mid] < tag)
      lo = mid + 1;
    else
      hi = mid;
  }
  return lo < g->ntag[dim] && g->tags[dim][lo] == tag ? (int)lo : -1;
}

/* The closest point of (dim, tag) to x, and in *par (when not NULL) its
 * parametric coordinates (dim values). Returns 0 on success. */
static int closest_par(void *ctx, int dim, int tag, const double *x,
                       double *y, double *par) {
  const gmodel *g = ctx;
  if (dim < 0 || dim > 2) return 1;
  int k = find_tag(g, dim, tag);
  if (k < 0) return 1;
  if (dim == 0) {
    memcpy(y, g->pxyz + 3 * (size_t)k, 3 * sizeof *y);
    return 0;
  }
  double xyz[3] = {x[0], x[1], x[2]}, *c = NULL, *p = NULL;
  size_t nc = 0, np = 0;
  int ierr = 0;
  api.get_closest_point(dim, tag, xyz, 3, &c, &nc, &p, &np, &ierr);
  int rc = ierr || nc != 3 || np != (size_t)dim;
  if (!rc) {
    memcpy(y, c, 3 * sizeof *y);
    if (par) memcpy(par, p, (size_t)dim * sizeof *par);
  }
  api.free(c);
  api.free(p);
  return rc;
}

static int gm_closest(void *ctx, int dim, int tag, const double *x,
                      double *y) {
  return closest_par(ctx, dim, tag, x, y, NULL);
}

static int gm_curvature(void *ctx, int dim, int tag, const double *y,
                        double *kappa) {
  double q[3], par[2];
  int ierr = 0;
  if ((dim != 1 && dim != 2) || closest_par(ctx, dim, tag, y, q, par))
    return 1;
  if (dim == 1) {
    double *k = NULL;
    size_t nk = 0;
    api.get_curvature(1, tag, par, 1, &k, &nk, &ierr);
    int rc = ierr || nk != 1;
    if (!rc) *kappa = fabs(k[0]);
    api.free(k);
    return rc;
  }
  double *k1 = NULL, *k2 = NULL, *d1 = NULL, *d2 = NULL;
  size_t n1 = 0, n2 = 0, m1 = 0, m2 = 0;
  api.get_principal_curvatures(tag, par, 2, &k1, &n1, &k2, &n2, &d1, &m1, &d2,
                               &m2, &ierr);
  int rc = ierr || n1 != 1 || n2 != 1;
  if (!rc) *kappa = fmax(fabs(k1[0]), fabs(k2[0]));
  api.free(k1);
  api.free(k2);
  api.free(d1);
  api.free(d2);
  return rc;
}

static void gmodel_free(gmodel *g) {
  if (!g) return;
  for (int d = 0; d < 3; d++) pa__free(g->tags[d]);
  pa__free(g->pxyz);
  pa__free(g);
}

/* The release of a Gmsh geometry: the model and Gmsh's state go. */
static void gm_release(void *ctx) {
  int ierr = 0;
  gmodel_free(ctx);
  api.finalize(&ierr);
  model_live = 0;
}

/* Gmsh's last error message (or "no message") into buf. */
static const char *last_error(char *buf, size_t n) {
  char *e = NULL;
  int ierr = 0;
  api.logger_get_last_error(&e, &ierr);
  snprintf(buf, n, "%s", !ierr && e && e[0] ? e : "no message from Gmsh");
  api.free(e);
  return buf;
}

static int cmp_int(const void *a, const void *b) {
  int x = *(const int *)a, y = *(const int *)b;
  return (x > y) - (x < y);
}

/* 1 for the extensions of the files read as models. */
static int model_ext(const char *path) {
  static const char *const ext[] = {".geo", ".step", ".stp", ".brep",
                                    ".iges", ".igs", ".STEP", ".STP",
                                    ".IGES", ".IGS", ".BREP"};
  const char *dot = strrchr(path, '.');
  if (!dot || strchr(dot, '/')) return 0;
  for (size_t i = 0; i < sizeof ext / sizeof *ext; i++)
    if (!strcmp(dot, ext[i])) return 1;
  return 0;
}

/* The entities of the current model into g (tags sorted per dimension,
 * points' coordinates), the diagonal of its box in *size. */
static pa_status list_entities(const char *path, gmodel *g, double *size) {
  pa_status st = PA_SUCCESS;
  int *dt = NULL, ierr = 0;
  size_t ndt = 0;
  char msg[256];
  api.get_entities(&dt, &ndt, -1, &ierr);
  PA_CHECK(!ierr, PA_ERR_IO, "%s: Gmsh cannot list the model's entities: %s",
           path, last_error(msg, sizeof msg));
  for (size_t i = 0; i + 1 < ndt; i += 2)
    if (dt[i] >= 0 && dt[i] <= 2) g->ntag[dt[i]]++;
  for (int d = 0; d < 3; d++) {
    PA_ALLOC(g->tags[d], g->ntag[d]);
    g->ntag[d] = 0;
  }
  for (size_t i = 0; i + 1 < ndt; i += 2)
    if (dt[i] >= 0 && dt[i] <= 2) g->tags[dt[i]][g->ntag[dt[i]]++] = dt[i + 1];
  for (int d = 0; d < 3; d++)
    qsort(g->tags[d], g->ntag[d], sizeof *g->tags[d], cmp_int);
  PA_CHECK(g->ntag[1] + g->ntag[2] > 0, PA_ERR_IO,
           "%s: the model has no curve nor surface to project onto", path);
  PA_ALLOC(g->pxyz, 3 * g->ntag[0]);
  for (size_t k = 0; k < g->ntag[0]; k++) {
    double *c = NULL;
    size_t nc = 0;
    api.get_value(0, g->tags[0][k], NULL, 0, &c, &nc, &ierr);
    if (!ierr && nc == 3) memcpy(g->pxyz + 3 * k, c, 3 * sizeof *c);
    api.free(c);
    PA_CHECK(!ierr && nc == 3, PA_ERR_IO,
             "%s: Gmsh cannot give the coordinates of model point %d: %s",
             path, g->tags[0][k], last_error(msg, sizeof msg));
  }
  double b[6];
  api.get_bounding_box(-1, -1, &b[0], &b[1], &b[2], &b[3], &b[4], &b[5],
                       &ierr);
  PA_CHECK(!ierr, PA_ERR_IO, "%s: Gmsh cannot give the model's box: %s", path,
           last_error(msg, sizeof msg));
  *size = sqrt((b[3] - b[0]) * (b[3] - b[0]) + (b[4] - b[1]) * (b[4] - b[1]) +
               (b[5] - b[2]) * (b[5] - b[2]));
  PA_CHECK(isfinite(*size) && *size > 0, PA_ERR_IO,
           "%s: the model's box is empty", path);
cleanup:
  api.free(dt);
  return st;
}

pa_status pa_geometry_read(const char *path, pa_geometry **geom) {
  pa_status st = PA_SUCCESS;
  gmodel *g = NULL;
  int started = 0, ierr = 0;
  double size = 0;
  char msg[256];
  PA_CHECK(path && geom, PA_ERR_ARG, "pa_geometry_read: NULL argument");
  *geom = NULL;
  PA_CHECK(model_ext(path), PA_ERR_UNSUPPORTED,
           "%s: not a model file (padapt reads .geo, .step/.stp, .brep and "
           ".iges/.igs models)",
           path);
  FILE *fp = fopen(path, "rb");
  PA_CHECK(fp, PA_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
  fclose(fp);
  PA_CHECK(api_load(), PA_ERR_UNSUPPORTED, "%s: %s", path, api_why);
  PA_CHECK(!model_live, PA_ERR_UNSUPPORTED,
           "%s: Gmsh holds one model per process and another is loaded",
           path);
  api.initialize(0, NULL, 0, &ierr);
  PA_CHECK(!ierr, PA_ERR_IO, "%s: Gmsh does not start", path);
  started = 1;
  /* quiet: errors are kept by the logger and go into padapt's messages */
  api.option_set_number("General.Terminal", 0, &ierr);
  api.option_set_number("General.Verbosity", 1, &ierr);
  api.logger_start(&ierr);
  api.open(path, &ierr);
  PA_CHECK(!ierr, PA_ERR_IO, "%s: Gmsh cannot read the model: %s", path,
           last_error(msg, sizeof msg));
  PA_CALLOC(g, 1);
  PA_CALL(list_entities(path, g, &size));
  api.logger_stop(&ierr);
  pa_geometry_ops ops = {gm_closest, gm_curvature};
  PA_CALL(pa_geometry_create(&ops, g, size, geom));
  (*geom)->release = gm_release;
  g = NULL;
  started = 0;
  model_live = 1;
cleanup:
  gmodel_free(g);
  if (started) api.finalize(&ierr);
  return st;
}

#else /* without Gmsh's library */

#define NO_GMSH                                                              \
  "padapt was built without Gmsh's library (install libgmsh-dev and "       \
  "rebuild, with -DPADAPT_GMSH=ON)"

int pa_geometry_available(const char **why) {
  if (why) *why = NO_GMSH;
  return 0;
}

pa_status pa_geometry_read(const char *path, pa_geometry **geom) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(path && geom, PA_ERR_ARG, "pa_geometry_read: NULL argument");
  *geom = NULL;
  PA_FAIL(PA_ERR_UNSUPPORTED, "%s: %s", path, NO_GMSH);
cleanup:
  return st;
}

#endif
