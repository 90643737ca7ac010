/*
 * prepare.c -- the metric a remesher works with, prepared from the caller's
 * (pa__metric_prepare), once for pa_remesh and pa_dmesh_adapt, and the
 * sequential context of the whole-field metric operations
 * (pa__metric_ctx_seq).
 *
 * The preparation runs in a pa__metric_ctx: the sequential context works on
 * one mesh; the distributed one (src/adapt/dmetric.c) agrees the frozen
 * vertices and the local-parameter bounds over every copy of a vertex,
 * grades over the whole distributed mesh and combines the PA_CHANGED_* bits,
 * so that owner and ghosts end with the same metric bit for bit.
 *
 * Invariants:
 *  - a frozen vertex (pa__mesh_frozen_vertices: required, or a vertex of a
 *    required element or boundary entity; in the distributed context on
 *    any rank) keeps its metric value bit for bit: hsiz, clamping and
 *    gradation skip it, though the gradation lets it constrain its
 *    neighbours; on a mesh without a metric every vertex gets hsiz;
 *  - the copy of the caller's metric (PA_METRIC_USER) is on the mesh
 *    exactly when *carried says so, on success and on failure;
 *  - in the distributed context, a rank that fails a local step meets the
 *    others at the next agreement (c->agree) before any collective step.
 */
#include "geom/geom.h"
#include "metric/gradation.h"

/* ---- the sequential context ---- */

static pa_status seq_sum(void *ctx, double *x) {
  (void)ctx;
  (void)x;
  return PA_SUCCESS;
}

static pa_status seq_bor(void *ctx, unsigned *x) {
  (void)ctx;
  (void)x;
  return PA_SUCCESS;
}

static pa_status seq_agree(void *ctx, pa_status st) {
  (void)ctx;
  return st;
}

static pa_status seq_frozen(void *ctx, uint8_t **frozen) {
  pa_status st = PA_SUCCESS;
  const pa_mesh *m = ctx;
  uint8_t *f = NULL;
  PA_CALLOC(f, m->nv);
  pa__mesh_frozen_vertices(m, f);
  *frozen = f;
cleanup:
  return st;
}

static pa_status seq_merge_bounds(void *ctx, double *b) {
  (void)ctx;
  (void)b;
  return PA_SUCCESS;
}

static pa_status seq_grade(void *ctx, int nc, double *met,
                           const uint8_t *frozen, double hgrad,
                           double hgradreq, int *changed) {
  pa_status st = PA_SUCCESS;
  const pa_mesh *m = ctx;
  pa_idx n = 0;
  PA_CALL(pa__metric_gradation(m->dim, nc, m->nv, m->coord, met, m->ne,
                               m->elem, frozen, hgrad, hgradreq, &n));
  if (changed) *changed = n > 0;
cleanup:
  return st;
}

void pa__metric_ctx_seq(pa_mesh *mesh, pa__metric_ctx *c) {
  c->mesh = mesh;
  c->nelem = mesh->ne;
  c->sum = seq_sum;
  c->max = seq_sum;
  c->bor = seq_bor;
  c->agree = seq_agree;
  c->frozen = seq_frozen;
  c->merge_bounds = seq_merge_bounds;
  c->grade = seq_grade;
  c->ctx = mesh;
}

/* ---- the preparation ---- */

pa_status pa__metric_prepare(const pa__metric_ctx *c, int nc, double *met,
                             const pa_remesh_opts *o, unsigned *changed,
                             int *carried) {
  pa_status st = PA_SUCCESS;
  pa_mesh *m = c->mesh;
  uint8_t *frozen = NULL;
  double *b = NULL;
  int d = m->dim, local = o->local && o->nlocal > 0, graded = 0;
  /* the model's curvature bounds the sizes at boundary vertices (hausd) */
  int model = o->geometry && o->geometry->ops.curvature && m->vgdim &&
              o->hausd > 0;
  *changed = 0;
  *carried = 0;
  PA_CALL(c->frozen(c->ctx, &frozen));
  if (o->hsiz > 0)
    pa__metric_set_hsiz(d, nc, m->nv, met, m->met_ncomp ? frozen : NULL,
                        o->hsiz);
  if (!o->no_stats && m->nfield < PA_MESH_MAX_FIELDS &&
      pa__user_metric_field(m) < 0) {
    st = pa_mesh_add_field(m, PA_METRIC_USER, nc, met);
    *carried = st == PA_SUCCESS;
  }
  if (st == PA_SUCCESS && (local || model)) {
    b = pa__malloc(3 * sizeof *b * (size_t)(m->nv ? m->nv : 1));
    if (!b)
      st = pa__error(PA_ERR_MEMORY, __FILE__, __LINE__,
                     "out of memory allocating the bounds of %ld vertices",
                     (long)m->nv);
  }
  PA_CALL(c->agree(c->ctx, st));
  if (local || model) {
    pa__local_bounds(m, o, b);
    if (model)
      pa__geom_hausd_bounds(o->geometry, m, o->hausd, o->hmin, frozen, b);
    PA_CALL(c->merge_bounds(c->ctx, b));
    *changed = pa__metric_clamp_bounds(d, nc, m->nv, met, frozen, b);
  } else {
    *changed = pa__metric_clamp_all(d, nc, m->nv, met, frozen, o->hmin,
                                    o->hmax);
  }
  PA_CALL(c->grade(c->ctx, nc, met, frozen, o->hgrad, o->hgradreq, &graded));
  if (graded) *changed |= PA_CHANGED_GRADATION;
  PA_CALL(c->bor(c->ctx, changed));
  if (*carried && !*changed) { /* the metric used is the caller's */
    *carried = 0;
    PA_CALL(pa_mesh_remove_field(m, pa__user_metric_field(m)));
  }
cleanup:
  if (st != PA_SUCCESS && *carried) {
    pa_mesh_remove_field(m, pa__user_metric_field(m));
    *carried = 0;
  }
  pa__free(b);
  pa__free(frozen);
  return st;
}
