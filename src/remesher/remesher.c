/*
 * remesher.c -- the remesher plug-in interface: default options, the
 * built-in remesher (its callback sends 2D meshes to src/remesh2d/, 3D ones
 * through longest-edge bisection, remesh/leb.c, to src/remesh3d/), and the
 * driver pa_remesh() that validates the input, prepares the metric (hsiz,
 * hmin/hmax, gradation) and calls a remesher, then carries the element and
 * boundary fields onto the result (remesh/transfer.c). It sits above the
 * two remeshers and the code they share (src/remesh/).
 *
 * Invariants:
 *  - pa_remesh never leaves a half-changed mesh: the prepared metric is built
 *    in a new array and installed only for the call; on an error or the
 *    FAILED outcome the original metric (and everything else) is restored;
 *  - a remesher never sees element nor boundary fields: a mesh that has
 *    some is copied whole first (the old mesh of the transfer, and what an
 *    error after the remesher gives back) and remeshed without them;
 *  - frozen vertices (PA_FLAG_REQUIRED, or vertices of a frozen element or
 *    boundary entity) keep their metric value bit for bit: hsiz, clamping and
 *    gradation skip them (gradation still lets them constrain neighbours);
 *    with -hsiz on a mesh without a metric every vertex gets hsiz.
 */
#include "geom/geom.h"
#include "metric/gradation.h"
#include "remesh/remesh.h"
#include "remesh/leb.h"

#include <stdio.h>

/* leb.c before the 3D passes: bisect edges longer than this. Bisected
 * tets are smaller than regular ones of the same longest edge, so the last
 * factor of 2 is left to the band splits; a higher or lower value gives
 * more tets in more time (figures: docs/BENCHMARKS.md, "The 3D remesher"). */
#define LEB_PRE 2.0

void pa_remesh_opts_default(pa_remesh_opts *o) {
  memset(o, 0, sizeof *o);
  o->hgrad = PA_DEFAULT_HGRAD;
  o->hgradreq = PA_DEFAULT_HGRADREQ;
  o->hausd = PA_DEFAULT_HAUSD;
  o->angle = PA_DEFAULT_ANGLE;
}

/* 3D: longest-edge bisection to length LEB_PRE first (leb.c: cheaper
 * than the band splits, and well-shaped), on a copy so that a FAILED
 * outcome leaves the mesh as given. */
static pa_status remesh3d(pa_mesh *mesh, const pa_remesh_opts *opts,
                          pa_remesh_report *report) {
  pa_status st = PA_SUCCESS;
  pa_mesh *w = NULL;
  pa__leb_opts lo;
  double t0 = pa_wtime();
  memset(&lo, 0, sizeof lo);
  lo.lmax = LEB_PRE;
  lo.vmin = PA_LEB_VMIN * pa__unit_simplex_volume(3);
  if (opts->no_insert) return pa__remesh3d(mesh, opts, report);
  PA_CALL(pa_mesh_copy(mesh, &w));
  PA_CALL(pa__leb_refine(w, &lo, NULL, NULL));
  if (opts->verbosity > 0)
    fprintf(stderr, "  leb: %d -> %d tets in %.2fs\n", (int)mesh->ne, (int)w->ne,
            pa_wtime() - t0);
  PA_CALL(pa__remesh3d(w, opts, report));
  if (report->outcome != PA_REMESH_FAILED) {
    pa_mesh t = *mesh;
    *mesh = *w;
    *w = t;
  }
cleanup:
  pa_mesh_destroy(w);
  return st;
}

/* The built-in remesher's callback. */
static pa_status builtin_remesh(void *ctx, pa_mesh *mesh,
                                const pa_remesh_opts *opts,
                                pa_remesh_report *report) {
  (void)ctx;
  if (mesh->dim == 3) return remesh3d(mesh, opts, report);
  return pa__remesh2d(mesh, opts, report);
}

const pa_remesher *pa_remesher_builtin(void) {
  static const pa_remesher builtin = {"padapt", (1u << 2) | (1u << 3),
                                     builtin_remesh, NULL};
  return &builtin;
}

/* Remove the copy of the caller's metric, if the mesh carries one. */
static pa_status drop_user_metric(pa_mesh *mesh) {
  int k = pa__user_metric_field(mesh);
  return k >= 0 ? pa_mesh_remove_field(mesh, k) : PA_SUCCESS;
}

/* The output in the metric used and in the caller's (the carried copy, or
 * the metric used when nothing changed it), checked as the output of the
 * built-in remesher or, from a plug-in, as an input (PA_STATS_CHECK_*). */
static pa_status measure(const pa_remesher *r, pa_mesh *mesh, int carried,
                         pa_fidelity *f) {
  pa_status st = PA_SUCCESS;
  int k = carried ? pa__user_metric_field(mesh) : -1;
  int check = r == pa_remesher_builtin() ? PA_STATS_CHECK_OUTPUT
                                         : PA_STATS_CHECK_FULL;
  PA_CALL(pa__mesh_stats_met(mesh, mesh->met_ncomp, mesh->met, check,
                             &f->used));
  f->user = f->used;
  if (k >= 0) {
    PA_CALL(pa__mesh_stats_met(mesh, mesh->field[k].ncomp, mesh->field[k].val,
                               PA_STATS_CHECK_NONE, &f->user));
    f->user.valid = f->used.valid;
  }
  f->target_met = pa_stats_target_met(&f->user);
cleanup:
  return st;
}

/* A classified mesh's classification around a remesher, which knows
 * nothing of it: the model's table, held aside, and the vertices that come
 * back where they are (the points and frozen vertices, by their
 * coordinates), from which pa__mesh_derive_entities recomputes the
 * entities of the result. The vertices' entity arrays stay on the mesh:
 * a remesher that replaces the vertices gives the result room for them
 * (as the mesh's own functions do when they add vertices), so that
 * nothing is allocated once the mesh holds the result. */
typedef struct held_model {
  pa__entity *ents;
  int nent;
  pa__kept kept;
  int held;
} held_model;

static pa_status hold_model(pa_mesh *mesh, held_model *h) {
  pa_status st = PA_SUCCESS;
  uint8_t *frozen = NULL;
  if (!mesh->vgdim) return PA_SUCCESS;
  PA_CALLOC(frozen, mesh->nv);
  pa__mesh_frozen_vertices(mesh, frozen);
  PA_CALL(pa__mesh_kept_points(mesh, frozen, &h->kept));
  h->ents = mesh->ents;
  h->nent = mesh->nent;
  mesh->ents = NULL;
  mesh->nent = 0;
  h->held = 1;
cleanup:
  pa__free(frozen);
  return st;
}

/* Give the classification back: derived from the cells of the result
 * (done), else the mesh is as given, its entities too. */
static pa_status restore_model(pa_mesh *mesh, held_model *h, int done) {
  pa_status st = PA_SUCCESS;
  if (!h->held) return PA_SUCCESS;
  pa__mesh_free_entities(mesh);
  mesh->ents = h->ents;
  mesh->nent = h->nent;
  h->ents = NULL;
  if (done) {
    PA_CHECK(mesh->vgdim, PA_ERR_INTERNAL,
             "pa_remesh: the remesher dropped the vertices' model entities");
    pa__mesh_derive_entities(mesh, &h->kept);
  }
cleanup:
  pa__kept_free(&h->kept);
  h->held = 0;
  return st;
}

/* The caller's progress callback, given what the remesher does not know:
 * the expected count and the time since pa_remesh started. */
typedef struct progress_wrap {
  pa_progress_fn fn;
  void *ctx;
  double initial, expected, t0;
} progress_wrap;

static void progress_relay(const pa_progress *p, void *ctx) {
  const progress_wrap *w = ctx;
  pa_progress q = *p;
  q.nelem_initial = w->initial;
  q.nelem_expected = w->expected;
  q.elapsed = pa_wtime() - w->t0;
  w->fn(&q, w->ctx);
}

/* The checks of pa_remesh on its arguments (r and mesh not NULL), its
 * options, and the mesh unless opts->trusted. */
static pa_status check_args(const pa_remesher *r, pa_mesh *mesh,
                            const pa_remesh_opts *opts) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(r->dims & (1u << mesh->dim), PA_ERR_UNSUPPORTED,
           "remesher '%s' does not handle %dD meshes", r->name ? r->name : "?",
           mesh->dim);
  PA_CHECK(mesh->met_ncomp || opts->hsiz > 0, PA_ERR_ARG,
           "pa_remesh: the mesh has no metric and no constant size (hsiz) was "
           "given");
  PA_CHECK(isfinite(opts->hsiz) && isfinite(opts->hmin) && isfinite(opts->hmax) &&
               isfinite(opts->hgrad) && isfinite(opts->hgradreq) &&
               isfinite(opts->hausd) &&
               isfinite(opts->angle) && isfinite(opts->mem_mb),
           PA_ERR_ARG, "pa_remesh: options must be finite numbers");
  PA_CHECK(!(opts->hmin > 0 && opts->hmax > 0 && opts->hmin > opts->hmax),
           PA_ERR_ARG, "pa_remesh: hmin (%g) is larger than hmax (%g)",
           opts->hmin, opts->hmax);
  PA_CHECK(opts->hausd >= 0, PA_ERR_ARG, "pa_remesh: hausd must be >= 0");
  PA_CHECK(opts->angle >= 0 && opts->angle <= 180, PA_ERR_ARG,
           "pa_remesh: the angle must lie in [0, 180] degrees, got %g",
           opts->angle);
  PA_CHECK(!opts->geometry || mesh->vgdim, PA_ERR_ARG,
           "pa_remesh: a geometry needs a classified mesh (read with "
           "pa_mesh_read_model, or pa_mesh_set_vertex_entities)");
  if (!opts->trusted) PA_CALL(pa_mesh_check(mesh));
cleanup:
  return st;
}

/* The metric the remesher works with, prepared in a new array *met of nc
 * components per vertex (the caller frees it): the caller's metric (or
 * hsiz), then hmin/hmax and the gradation (pa__metric_prepare in the
 * sequential context); frozen vertices keep theirs.
 * Unless opts->no_stats, the caller's metric is carried as the field
 * metric:user (*carried = 1; the caller drops it) when a step changed it;
 * *changed says which (PA_CHANGED_*). */
static pa_status prepare_metric(pa_mesh *mesh, const pa_remesh_opts *opts,
                                int nc, double **met, int *carried,
                                unsigned *changed) {
  pa_status st = PA_SUCCESS;
  pa__metric_ctx c;
  double *newmet = NULL;
  size_t cap = mesh->capv > (size_t)mesh->nv ? mesh->capv : (size_t)mesh->nv;
  PA_ALLOC(newmet, (cap ? cap : 1) * nc);
  *met = newmet;
  if (mesh->met_ncomp)
    memcpy(newmet, mesh->met, sizeof(double) * nc * mesh->nv);
  pa__metric_ctx_seq(mesh, &c);
  PA_CALL(pa__metric_prepare(&c, nc, newmet, opts, changed, carried));
cleanup:
  return st;
}

pa_status pa_remesh(const pa_remesher *r, pa_mesh *mesh,
                    const pa_remesh_opts *opts, pa_remesh_report *report) {
  pa_status st = PA_SUCCESS;
  pa_remesh_opts def, relayed, modelled;
  held_model held;
  long nproj0 = 0, nfail0 = 0;
  double tproj0 = 0;
  memset(&held, 0, sizeof held);
  pa_remesh_report dummy;
  progress_wrap wrap = {NULL, NULL, 0, 0, 0};
  double *newmet = NULL, *oldmet = NULL;
  int oldnc = 0, installed = 0, carried = 0;
  pa__name *names = NULL; /* the caller's physical names, held aside */
  int nname = 0, bound_set = 0;
  size_t bound0 = 0, bound = 0;
  pa_mesh *orig = NULL; /* the input, when it has element or boundary fields */
  double t0 = pa_wtime(), cpu0;
  wrap.t0 = t0;
  PA_CHECK(r && r->remesh && mesh, PA_ERR_ARG, "pa_remesh: NULL argument");
  if (!opts) {
    pa_remesh_opts_default(&def);
    opts = &def;
  }
  if (!report) report = &dummy;
  memset(report, 0, sizeof *report);
  report->outcome = PA_REMESH_FAILED;
  PA_CALL(check_args(r, mesh, opts));
  /* opts->mem_mb bounds the memory for the call, under any bound set */
  bound0 = pa_memory_limit();
  bound = bound0;
  if (opts->mem_mb > 0 && (!bound || opts->mem_mb * 1e6 < (double)bound)) {
    bound = (size_t)(opts->mem_mb * 1e6);
    pa_memory_set_limit(bound);
    bound_set = 1;
  }
  if (mesh->nefield || mesh->nbfield) {
    PA_CALL(pa_mesh_copy(mesh, &orig));
    for (int at = PA_ELEMENT; at <= PA_BOUNDARY; at++)
      while (pa_mesh_nfield_at(mesh, (pa_entity)at))
        PA_CALL(pa_mesh_remove_field_at(
            mesh, (pa_entity)at, pa_mesh_nfield_at(mesh, (pa_entity)at) - 1));
  }

  int d = mesh->dim, nc = mesh->met_ncomp ? mesh->met_ncomp : 1;
  unsigned changed = 0;
  PA_CALL(prepare_metric(mesh, opts, nc, &newmet, &carried, &changed));
  if (!opts->trusted || opts->progress) {
    double c = 0;
    PA_CALL(pa_metric_complexity(mesh, nc, newmet, &c));
    if (!opts->trusted) { /* the parallel driver checks for its pieces */
      char what[64] = "the available memory";
      double budget = (double)pa__mem_available();
      if (bound) {
        budget = (double)bound;
        snprintf(what, sizeof what, "the memory bound of %.1f MB",
                 (double)bound / 1e6);
      }
      PA_CALL(pa__check_output_size(d, c, 1, 0, budget, what));
    }
    wrap.expected = c / pa__unit_simplex_volume(d);
  }
  if (opts->geometry) {
    /* the model's curves and points are the ridges and corners */
    modelled = *opts;
    modelled.no_angle = 1;
    opts = &modelled;
    nproj0 = opts->geometry->nproject;
    nfail0 = opts->geometry->nfailed;
    tproj0 = opts->geometry->seconds;
  }
  if (opts->progress) {
    wrap.fn = opts->progress;
    wrap.initial = mesh->ne;
    wrap.ctx = opts->progress_ctx;
    relayed = *opts;
    relayed.progress = progress_relay;
    relayed.progress_ctx = &wrap;
    opts = &relayed;
  }

  oldmet = mesh->met;
  oldnc = mesh->met_ncomp;
  mesh->met = newmet;
  mesh->met_ncomp = nc;
  newmet = NULL;
  installed = 1;

  /* A remesher may replace the mesh's contents: the names wait aside. */
  names = mesh->names;
  nname = mesh->nname;
  mesh->names = NULL;
  mesh->nname = 0;
  PA_CALL(hold_model(mesh, &held));
  cpu0 = pa__thread_cputime();
  st = r->remesh(r->ctx, mesh, opts, report);
  report->cpu_s = pa__thread_cputime() - cpu0;
  if (st != PA_SUCCESS) goto cleanup;
  if (report->outcome == PA_REMESH_FAILED) goto cleanup;
  PA_CALL(restore_model(mesh, &held, 1));
  if (orig) PA_CALL(pa__transfer_fields(orig, mesh, &report->transfer));
  pa__free(oldmet);
  oldmet = NULL;
  installed = 0;
  report->time_s = pa_wtime() - t0; /* the remesh, not its measurement */
  if (!opts->no_stats) {
    /* the mesh is the result now: a failure to measure it is no error */
    pa_fidelity *f = &report->fidelity;
    if (measure(r, mesh, carried, f) == PA_SUCCESS) {
      f->measured = 1;
      f->changed = changed;
    } else {
      memset(f, 0, sizeof *f);
      pa_clear_error();
    }
  }
cleanup:
  if (held.held) restore_model(mesh, &held, 0); /* allocates nothing */
  if (opts && opts->geometry && report) {
    report->nproject = opts->geometry->nproject - nproj0;
    report->nproject_failed = opts->geometry->nfailed - nfail0;
    report->project_s = opts->geometry->seconds - tproj0;
  }
  if (orig && (st != PA_SUCCESS || report->outcome == PA_REMESH_FAILED)) {
    /* the input comes back whole (its metric and names as below) */
    pa_mesh t = *mesh;
    *mesh = *orig;
    *orig = t;
  }
  pa_mesh_destroy(orig);
  if (names) {
    pa__mesh_free_names(mesh);
    mesh->names = names;
    mesh->nname = nname;
  }
  if (installed) { /* error or FAILED: give the mesh back as it was */
    pa__free(mesh->met);
    mesh->met = oldmet;
    mesh->met_ncomp = oldnc;
  }
  if (carried && drop_user_metric(mesh) != PA_SUCCESS && st == PA_SUCCESS)
    st = PA_ERR_INTERNAL;
  pa__free(newmet);
  if (bound_set) pa_memory_set_limit(bound0);
  if (st != PA_SUCCESS) report->outcome = PA_REMESH_FAILED;
  if (!(report->time_s > 0)) report->time_s = pa_wtime() - t0;
  return st;
}
