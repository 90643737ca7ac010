/*
 * adapt.c -- pa_dmesh_adapt: the outer loop of the piece algorithm (tag,
 * pieces, extract, remesh, reintegrate; see piece.h), its options and
 * report, and the final rebalance.
 *
 * Before the loop the metric is prepared as pa_remesh prepares it
 * (pa__metric_prepare in the distributed context of dmetric.c: hsiz,
 * hmin/hmax and the local parameters on every local vertex, owner and
 * ghosts alike, and the gradation over the whole mesh, grade.c; pieces are
 * remeshed without gradation, as the sequential remesher grades its input
 * once); the element value PA_ADAPT_DONE_VALUE marks the elements produced
 * by a remesh, which tag.c tags again only with looser criteria (by how much
 * their piece's frozen skin constrained them). The loop stops when a tag pass
 * over the whole mesh finds nothing (converged: every element of the final mesh
 * meets its criterion) or a tail that a sequential remesh would leave
 * (TAIL_SHARE, converged too), or when it stalls: each iteration in which the
 * estimated work of the tagged elements did not fall 1 % below the least seen
 * so far halves the number of pieces of the next one (other borders, and fewer
 * of them; one piece has no inner border), and an iteration with one piece that
 * makes no progress (and rolled nothing back) ends the loop; so does
 * max_iter: as converged if nothing still tagged is clearly off
 * (pa__adapt_count_missed), else as stalled. Every step is collective and
 * agrees on its status, so all ranks leave the loop together.
 *
 * The driver is a sequence of named phases: check_opts, begin (metric, size
 * check, the done value), run (iterate, each iteration followed by a
 * checkpoint when opts->checkpoint_dir is set), finish (rebalance, check,
 * measure) and conclude (the report). Everything an iteration depends on
 * besides the distributed mesh is in pa__loop, so pa_dmesh_adapt_resume
 * continues a run from a checkpoint (checkpoint.c) through the same run and
 * finish.
 */
#include "adapt/piece.h"
#include "io/io.h"

#include <math.h>
#include <stdlib.h>

void pa_adapt_opts_default(pa_adapt_opts *o) {
  if (!o) return;
  memset(o, 0, sizeof *o);
  pa_remesh_opts_default(&o->remesh);
  o->qual_threshold = PA_DEFAULT_QUAL_THRESHOLD;
  o->max_iter = PA_DEFAULT_MAX_ITER;
  o->pieces_per_rank = PA_DEFAULT_PIECES_PER_RANK;
  o->skin_layers = PA_DEFAULT_SKIN_LAYERS;
  o->skin_layers_later = PA_DEFAULT_SKIN_LAYERS_LATER;
  o->min_piece_work = PA_DEFAULT_MIN_PIECE_WORK;
  o->min_piece_ratio = PA_DEFAULT_MIN_PIECE_RATIO;
  o->rebalance_tol = PA_DEFAULT_REBALANCE_TOL;
  o->rebalance = 1;
  o->check_pieces = -1;
}

/* The metric the pieces are remeshed to, prepared as pa_remesh prepares
 * it (pa__metric_prepare: hsiz, the carried copy of the caller's metric,
 * hmin/hmax, the gradation over the whole distributed mesh), in the
 * mesh's own metric array: a mesh without one gets the size hsiz first.
 * Collective; owners and ghosts get the same result. *changed:
 * PA_CHANGED_* bits, all ranks. */
static pa_status prepare_metric(pa_dmesh *dm, const pa_remesh_opts *ro,
                                unsigned *changed) {
  pa_status st = PA_SUCCESS;
  pa_mesh *m = dm->mesh;
  double *h = NULL;
  int carried = 0;
  pa__metric_ctx c;
  *changed = 0;
  if (!m->met_ncomp) {
    h = pa__malloc(sizeof *h * (size_t)(m->nv ? m->nv : 1));
    if (!h) {
      st = pa__error(PA_ERR_MEMORY, __FILE__, __LINE__,
                     "out of memory allocating the sizes of %ld vertices",
                     (long)m->nv);
    } else {
      for (pa_idx v = 0; v < m->nv; v++) h[v] = ro->hsiz;
      st = pa_mesh_set_metric(m, 1, h);
    }
  }
  PA_CALL(pa__agree(dm->comm, st));
  pa__adapt_metric_ctx(dm, &c);
  PA_CALL(pa__metric_prepare(&c, m->met_ncomp, m->met, ro, changed, &carried));
cleanup:
  pa__free(h);
  return st;
}

/* The result in the metric used and in the caller's (report->fidelity),
 * then the carried copy of the caller's metric removed. Its validity is
 * pa__dmesh_check_output's, as a sequential remesh checks the built-in
 * remesher's output (finish ran pa_dmesh_check before when the result is
 * checked). Collective. */
static pa_status measure(pa_dmesh *dm, unsigned changed, pa_fidelity *f) {
  pa_status st = PA_SUCCESS;
  pa_mesh *m = dm->mesh;
  int k = pa__user_metric_field(m);
  PA_CALL(pa__dmesh_stats_met(dm, m->met_ncomp, m->met, PA_STATS_CHECK_OUTPUT,
                              &f->used));
  f->user = f->used;
  if (k >= 0) {
    PA_CALL(pa__dmesh_stats_met(dm, m->field[k].ncomp, m->field[k].val,
                                PA_STATS_CHECK_NONE, &f->user));
    f->user.valid = f->used.valid;
    PA_CALL(pa_mesh_remove_field(m, k));
  }
  f->changed = changed;
  f->target_met = pa_stats_target_met(&f->user);
cleanup:
  return st;
}

static pa_status check_opts(pa_dmesh *dm, const pa_adapt_opts *o) {
  pa_status st = PA_SUCCESS;
  const pa_remesh_opts *ro = &o->remesh;
  const pa_remesher *r = o->remesher ? o->remesher : pa_remesher_builtin();
  PA_CHECK(r && r->remesh, PA_ERR_ARG, "pa_dmesh_adapt: no remesher");
  PA_CHECK(r->dims & (1u << dm->dim), PA_ERR_UNSUPPORTED,
           "remesher '%s' does not handle %dD meshes", r->name ? r->name : "?",
           dm->dim);
  PA_CHECK(dm->mesh->met_ncomp || ro->hsiz > 0, PA_ERR_ARG,
           "pa_dmesh_adapt: the mesh has no metric and no constant size "
           "(hsiz) was given");
  PA_CHECK(isfinite(ro->hsiz) && isfinite(ro->hmin) && isfinite(ro->hmax) &&
               isfinite(o->mem_mb) && isfinite(o->qual_threshold) &&
               isfinite(o->min_piece_work),
           PA_ERR_ARG, "pa_dmesh_adapt: options must be finite numbers");
  PA_CHECK(!(ro->hmin > 0 && ro->hmax > 0 && ro->hmin > ro->hmax), PA_ERR_ARG,
           "pa_dmesh_adapt: hmin (%g) is larger than hmax (%g)", ro->hmin,
           ro->hmax);
  PA_CHECK(o->max_iter >= 1, PA_ERR_ARG, "max_iter must be >= 1, got %d",
           o->max_iter);
  PA_CHECK(o->pieces_per_rank >= 1, PA_ERR_ARG,
           "pieces_per_rank must be >= 1, got %d", o->pieces_per_rank);
  PA_CHECK(!o->rebalance || o->rebalance_tol >= 1, PA_ERR_ARG,
           "rebalance_tol must be >= 1, got %g", o->rebalance_tol);
  PA_CHECK(!o->checkpoint_dir || !pa__output_depth(), PA_ERR_ARG,
           "pa_dmesh_adapt: checkpoints are written outside an output "
           "transaction, and one is open (pa_output_begin)");
  PA_CHECK(!ro->geometry || dm->mesh->vgdim, PA_ERR_ARG,
           "pa_dmesh_adapt: a geometry needs a mesh distributed from a "
           "classified one (pa_mesh_read_model)");
  PA_CHECK(!ro->geometry || !o->checkpoint_dir, PA_ERR_UNSUPPORTED,
           "pa_dmesh_adapt: checkpoints do not keep the classification a "
           "geometry needs");
cleanup:
  return st;
}

/* Refuse a metric whose output would not fit: the estimate from its
 * complexity against opts->mem_mb per process, or else the memory available
 * on each node shared by its ranks (the least over the nodes). Collective. */
static pa_status check_size(pa_dmesh *dm, const pa_adapt_opts *o,
                            double *expected) {
  pa_status st = PA_SUCCESS;
  MPI_Comm node = MPI_COMM_NULL;
  double c = 0, budget = 0;
  char what[64] = "the available memory";
  PA_CALL(pa_dmesh_metric_complexity(dm, &c));
  *expected = c / pa__unit_simplex_volume(dm->dim);
  if (o->mem_mb > 0) {
    budget = o->mem_mb * 1e6;
    snprintf(what, sizeof what, "-mem %g", o->mem_mb);
  } else {
    int nlocal = 1;
    if (MPI_Comm_split_type(dm->comm, MPI_COMM_TYPE_SHARED, 0, MPI_INFO_NULL,
                            &node) == MPI_SUCCESS)
      MPI_Comm_size(node, &nlocal);
    double b = (double)pa__mem_available() / nlocal;
    if (b <= 0) b = -1; /* unknown somewhere: no bound */
    PA_CALL(pa__allreduce(dm->comm, &b, 1, MPI_DOUBLE, MPI_MIN));
    budget = b;
  }
  st = pa__check_output_size(dm->dim, c, dm->size, 1, budget, what);
cleanup:
  if (node != MPI_COMM_NULL) MPI_Comm_free(&node);
  return st;
}

/* The progress callback after a tag pass: the share of elements that meet
 * their criterion is the untagged share (the same on every rank). */
static void report_progress(const pa_dmesh *dm, const pa_adapt_opts *o,
                            int iter, pa_gid ntagged, const pa__loop *L) {
  if (!o->remesh.progress) return;
  double n = (double)dm->nglob[PA_ELEMENT];
  pa_progress p = {"iteration", iter, n, (double)L->rep.nelem_initial,
                   L->expected, n > 0 ? 1 - (double)ntagged / n : 1,
                   L->time + pa_wtime() - L->t0};
  o->remesh.progress(&p, o->remesh.progress_ctx);
}

/* Max over the ranks of n doubles and the sums of two more (busy[0..2)). */
static pa_status max_times(MPI_Comm comm, double *t, int n, double *busy) {
  pa_status st = PA_SUCCESS;
  PA_CALL(pa__allreduce(comm, t, n, MPI_DOUBLE, MPI_MAX));
  PA_CALL(pa__allreduce(comm, busy, 2, MPI_DOUBLE, MPI_SUM));
cleanup:
  return st;
}

/* The state of iteration iter of the loop on dm. */
static void iter_init(pa__iter *it, pa_dmesh *dm, const pa_adapt_opts *opts,
                      int iter) {
  memset(it, 0, sizeof *it);
  it->dm = dm;
  it->opts = opts;
  it->rank = dm->rank;
  it->size = dm->size;
  it->dim = dm->dim;
  it->nve = dm->dim + 1;
  it->iter = iter;
}

/* A tail of tagged elements at most this share of the mesh, none of which
 * the sequential remesher's verdict calls missed (pa__adapt_count_missed
 * strict), ends the loop as converged: they miss only the loop's tighter
 * bounds for remeshed elements (tag.c), and another iteration passes over
 * the whole mesh (tag, pieces, splice: 0.45 s of a 6.3 s run on the
 * 4.85 M-triangle plate at 2 ranks, for 2 triangles). */
#define TAIL_SHARE 1e-4

/* The tag pass (t[0], t[5]: its time since t0 and peak memory), and
 * whether the loop ends with it (*end, L->rep says how): nothing tagged,
 * or a tail of TAIL_SHARE that a sequential remesh would leave
 * (converged), or the iterations spent or no progress (converged all the
 * same if nothing still tagged is clearly off, else stalled). Progress:
 * the tagged work 1 % below the least seen so far (work that goes up and
 * down, e.g. the same badly shaped elements tagged again next to other
 * borders, is no progress). */
static pa_status tag_step(pa__iter *it, pa_dmesh_value *done, pa__loop *L,
                          double t0, double *t, int *end) {
  pa_status st = PA_SUCCESS;
  const pa_adapt_opts *opts = it->opts;
  pa_adapt_report *rep = &L->rep;
  int iter = it->iter;
  PA_CALL(pa__adapt_tag(it, done, !L->tagged));
  L->tagged = 1;
  t[0] = pa_wtime() - t0;
  t[5] = (double)pa__memory_window_peak();
  report_progress(it->dm, opts, iter, it->ntagged, L);
  rep->ntagged_left = it->ntagged;
  if (it->ntagged == 0) {
    rep->converged = 1;
    *end = 1;
    goto cleanup;
  }
  if (it->ntagged <= TAIL_SHARE * (double)it->dm->nglob[PA_ELEMENT]) {
    pa_gid missed = 0;
    PA_CALL(pa__adapt_count_missed(it, 1, &missed));
    if (missed == 0) {
      pa__info(1, "padapt: the loop ends with %lld elements tagged, none "
                  "that a sequential remesh would leave: converged\n",
               (long long)it->ntagged);
      rep->converged = 1;
      *end = 1;
      goto cleanup;
    }
  }
  L->nostep =
      L->least >= 0 && it->tagwork >= 0.99 * L->least ? L->nostep + 1 : 0;
  if (iter > opts->max_iter ||
      (L->nostep >= 1 && L->lastpieces == 1 && !L->lastfailed) ||
      L->nostep >= 6) {
    /* the loop ends: converged all the same if nothing still tagged is
     * clearly off */
    pa_gid missed = 0;
    PA_CALL(pa__adapt_count_missed(it, 0, &missed));
    rep->converged = missed == 0;
    rep->stalled = missed > 0;
    pa__info(1, "padapt: the loop ends with %lld elements tagged, %lld "
                "of them clearly off: %s\n",
             (long long)it->ntagged, (long long)missed,
             missed ? "stalled" : "converged");
    *end = 1;
    goto cleanup;
  }
  if (L->least < 0 || it->tagwork < L->least) L->least = it->tagwork;
cleanup:
  return st;
}

/* The number of pieces wanted: pieces_per_rank per rank, halved for each
 * iteration without progress (other borders, fewer of them), and then
 * fewer than the last iteration's. */
static int pieces_wanted(const pa_dmesh *dm, const pa_adapt_opts *opts,
                         const pa__loop *L) {
  int np = dm->size * opts->pieces_per_rank;
  for (int k = 0; k < L->nostep && np > 1; k++) np = (np + 1) / 2;
  if (L->nostep && np >= L->lastpieces)
    np = L->lastpieces > 1 ? L->lastpieces - 1 : 1;
  return np;
}

/* The end of step k (1-4: pieces, extract, remesh, reintegrate): its
 * seconds since *t0 in t[k] and the peak bytes of the memory window in
 * t[5 + k]; both restart for the next step. */
static void step_done(double *t, int k, double *t0) {
  double now = pa_wtime();
  t[k] = now - *t0;
  t[5 + k] = (double)pa__memory_window_peak();
  *t0 = now;
  pa__memory_window_begin();
}

/* The figures of the iteration into *ir and L->rep: times and memory (t)
 * over the ranks; the remesher's wall-clock and CPU seconds (busy[0],
 * busy[1]), the rollbacks, bytes moved and remesher operations summed. */
static pa_status record_iteration(const pa__iter *it, pa__loop *L, double *t,
                                  double *busy, int nfail, pa_adapt_iter *ir) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = it->dm;
  pa_adapt_report *rep = &L->rep;
  PA_CALL(max_times(dm->comm, t, 11, busy));
  {
    double x[6] = {(double)nfail, it->bytes_moved, 0, 0, 0, 0};
    for (int q = 0; q < it->npiece_local; q++) {
      const pa_remesh_report *p = &it->pieces[q].rep;
      x[2] += (double)p->nsplit;
      x[3] += (double)p->ncollapse;
      x[4] += (double)p->nswap;
      x[5] += (double)p->nmove;
    }
    PA_CALL(pa__allreduce(dm->comm, x, 6, MPI_DOUBLE, MPI_SUM));
    ir->nfailed = (int)x[0];
    L->lastfailed = ir->nfailed > 0;
    ir->bytes_moved = x[1];
    ir->nsplit = (long)x[2];
    ir->ncollapse = (long)x[3];
    ir->nswap = (long)x[4];
    ir->nmove = (long)x[5];
  }
  ir->iter = it->iter;
  ir->ntagged = it->ntagged;
  ir->nelem = dm->nglob[PA_ELEMENT];
  ir->npieces = it->npieces;
  ir->imbalance = it->imbalance;
  ir->t_tag = t[0];
  ir->t_pieces = t[1];
  ir->t_gather = t[2];
  ir->t_remesh = t[3];
  ir->t_reintegrate = t[4];
  ir->mem_tag = t[5];
  ir->mem_pieces = t[6];
  ir->mem_gather = t[7];
  ir->mem_remesh = t[8];
  ir->mem_reintegrate = t[9];
  ir->mem_after = t[10];
  ir->remesh_busy = busy[0];
  ir->remesh_cpu = busy[1];
  L->iter = it->iter;
  rep->niter = it->iter;
  rep->npieces += ir->npieces;
  rep->nfailed += ir->nfailed;
  rep->t_tag += t[0];
  rep->t_pieces += t[1];
  rep->t_gather += t[2];
  rep->t_remesh += t[3];
  rep->t_reintegrate += t[4];
  rep->remesh_busy += busy[0];
  rep->remesh_cpu += busy[1];
  rep->nsplit += ir->nsplit;
  rep->ncollapse += ir->ncollapse;
  rep->nswap += ir->nswap;
  rep->nmove += ir->nmove;
  rep->bytes_moved += ir->bytes_moved;
  { /* the pieces' field transfers: sums, then the largest figures */
    pa_transfer_report *tr = &rep->transfer;
    double sum[5] = {0, 0, 0, 0, 0}, mx[4] = {0, 0, 0, 0};
    for (int q = 0; q < it->npiece_local; q++) {
      const pa_transfer_report *p = &it->pieces[q].rep.transfer;
      sum[0] += (double)p->nfast;
      sum[1] += (double)p->nclip;
      sum[2] += (double)p->nout;
      sum[3] += p->time_s;
      sum[4] += p->cpu_s;
      mx[0] = fmax(mx[0], p->nfield);
      mx[1] = fmax(mx[1], p->defect);
      mx[2] = fmax(mx[2], p->uncovered);
      mx[3] = fmax(mx[3], p->lost);
    }
    PA_CALL(pa__allreduce(dm->comm, sum, 5, MPI_DOUBLE, MPI_SUM));
    PA_CALL(pa__allreduce(dm->comm, mx, 4, MPI_DOUBLE, MPI_MAX));
    tr->nfast += (long)sum[0];
    tr->nclip += (long)sum[1];
    tr->nout += (long)sum[2];
    tr->time_s += sum[3];
    tr->cpu_s += sum[4];
    tr->nfield = tr->nfield > (int)mx[0] ? tr->nfield : (int)mx[0];
    tr->defect = fmax(tr->defect, mx[1]);
    tr->uncovered = fmax(tr->uncovered, mx[2]);
    tr->lost = fmax(tr->lost, mx[3]);
  }
  if (rep->niter_recorded < PA_ADAPT_MAX_ITERS)
    rep->iters[rep->niter_recorded++] = *ir;
cleanup:
  return st;
}

/* *same = 1 when every piece on every rank came back unchanged: the
 * reintegration would rebuild the mesh as it is. Collective. */
static pa_status pieces_unchanged(const pa__iter *it, int *same) {
  pa_status st = PA_SUCCESS;
  *same = 1;
  for (int q = 0; q < it->npiece_local; q++)
    if (it->pieces[q].in->ne > 0 && !it->pieces[q].unchanged) *same = 0;
  PA_CALL(pa__allreduce(it->dm->comm, same, 1, MPI_INT, MPI_MIN));
cleanup:
  return st;
}

/* One iteration: tag, then (unless the loop ends there) pieces, extract,
 * remesh and reintegrate (not when every piece came back unchanged: the
 * next tag finds the same elements, and the loop ends as without progress);
 * its figures go to L->rep and the progress callback. *end: the loop ended
 * at the tag (L->rep says how). Collective. */
static pa_status iterate(pa_dmesh *dm, const pa_adapt_opts *opts,
                         pa_dmesh_value *done, pa__loop *L, int *end) {
  pa_status st = PA_SUCCESS;
  pa__iter it;
  pa_adapt_iter ir;
  /* per step: t[0..4] seconds, t[5..9] peak bytes, t[10] bytes held at
   * the end (the maximum over the ranks of each) */
  double t[11], busy[2], ta = pa_wtime();
  int nfail = 0, same = 0;
  pa__memory_window_begin();
  iter_init(&it, dm, opts, L->iter + 1);
  memset(&ir, 0, sizeof ir);
  *end = 0;
  PA_CALL(tag_step(&it, done, L, ta, t, end));
  if (*end) { /* the last tag counts in the report's tag step */
    PA_CALL(pa__allreduce(dm->comm, t, 1, MPI_DOUBLE, MPI_MAX));
    L->rep.t_tag += t[0];
    goto cleanup;
  }
  ta = pa_wtime();
  pa__memory_window_begin();
  PA_CALL(pa__adapt_pieces(&it, pieces_wanted(dm, opts, L)));
  L->lastpieces = it.npieces;
  step_done(t, 1, &ta);
  PA_CALL(pa__adapt_extract(&it));
  step_done(t, 2, &ta);
  st = pa__adapt_remesh(&it, &nfail, &busy[1]);
  busy[0] = pa_wtime() - ta;
  PA_CALL(pa__agree(dm->comm, st)); /* the ranks wait for the slowest */
  step_done(t, 3, &ta);
  PA_CALL(pieces_unchanged(&it, &same));
  if (same)
    pa__info(1, "padapt: iteration %d: every piece came back unchanged, "
                "no rebuild\n", it.iter);
  else
    PA_CALL(pa__adapt_reintegrate(&it, done));
  step_done(t, 4, &ta);
  t[10] = (double)pa_memory_current();
  PA_CALL(record_iteration(&it, L, t, busy, nfail, &ir));
  pa__iter_free(&it);
  if (opts->progress) opts->progress(&ir, opts->progress_ctx);
cleanup:
  pa__iter_free(&it);
  return st;
}

/* Before the loop: the report's initial figures, the metric the pieces are
 * remeshed to, the size check, and the element value marking what the loop
 * produces (*done). Collective. */
static pa_status begin(pa_dmesh *dm, const pa_adapt_opts *opts, pa__loop *L,
                       pa_dmesh_value **done) {
  pa_status st = PA_SUCCESS;
  double t0 = pa_wtime();
  L->least = -1;
  L->rep.nranks = dm->size;
  L->rep.nelem_initial = dm->nglob[PA_ELEMENT];
  L->rep.nvert_initial = dm->nglob[PA_VERTEX];
  PA_CALL(prepare_metric(dm, &opts->remesh, &L->changed));
  PA_CALL(check_size(dm, opts, &L->expected));
  PA_CALL(pa_dmesh_value_add(dm, PA_ELEMENT, PA_ADAPT_DONE_VALUE, MPI_UINT8_T,
                             1, -1, done));
  pa__info(2, "padapt: rank %d: metric and gradation %.3f s\n", dm->rank,
           pa_wtime() - t0);
cleanup:
  return st;
}

/* The iterations, each followed by a checkpoint when asked for; t0: when
 * this call started (the checkpoint's time adds to L->time). Collective. */
static pa_status run(pa_dmesh *dm, const pa_adapt_opts *opts,
                     pa_dmesh_value *done, pa__loop *L, double t0) {
  pa_status st = PA_SUCCESS;
  for (;;) {
    int end = 0;
    PA_CALL(iterate(dm, opts, done, L, &end));
    if (end) break;
    if (opts->checkpoint_dir)
      PA_CALL(pa__adapt_checkpoint(dm, opts, L, L->time + pa_wtime() - t0));
  }
cleanup:
  return st;
}

/* After the loop: rebalance, drop the done value, check (if asked) and
 * measure the result. Collective. */
static pa_status finish(pa_dmesh *dm, const pa_adapt_opts *opts,
                        pa_dmesh_value **done, pa__loop *L) {
  pa_status st = PA_SUCCESS;
  pa_adapt_report *rep = &L->rep;
  double ta = pa_wtime();
  pa__memory_window_begin();
  if (opts->rebalance && dm->size > 1)
    PA_CALL(pa_dmesh_rebalance(dm, NULL, opts->rebalance_tol, NULL));
  rep->t_rebalance = pa_wtime() - ta;
  pa__info(2, "padapt: rank %d: rebalance %.3f s, peak %.1f MB, then %.1f MB\n",
           dm->rank, rep->t_rebalance, pa__memory_window_peak() / 1e6,
           pa_memory_current() / 1e6);
  PA_CALL(pa__allreduce(dm->comm, &rep->t_rebalance, 1, MPI_DOUBLE, MPI_MAX));
  PA_CALL(pa_dmesh_value_remove(dm, *done));
  *done = NULL;
  if (pa__adapt_checks(opts)) {
    ta = pa_wtime();
    PA_CALL(pa_dmesh_check(dm));
    pa__info(2, "padapt: rank %d: final check %.3f s\n", dm->rank,
             pa_wtime() - ta);
  }
  pa__memory_window_begin();
  ta = pa_wtime();
  if (!opts->remesh.no_stats) PA_CALL(measure(dm, L->changed, &rep->fidelity));
  rep->t_measure = pa_wtime() - ta;
  pa__info(2, "padapt: rank %d: statistics %.3f s, peak %.1f MB\n", dm->rank,
           rep->t_measure, pa__memory_window_peak() / 1e6);
  PA_CALL(pa__allreduce(dm->comm, &rep->t_measure, 1, MPI_DOUBLE, MPI_MAX));
  rep->fidelity.measured = !opts->remesh.no_stats;
cleanup:
  return st;
}

/* The common end of pa_dmesh_adapt and pa_dmesh_adapt_resume: drop what an
 * error left, agree on st, complete the report (memory, final counts, the
 * time since t0 plus L->time) into *report. Collective (dm not NULL). */
static pa_status conclude(pa_dmesh *dm, pa_status st, pa_dmesh_value *done,
                          pa__loop *L, double t0, pa_adapt_report *report) {
  if (!dm) return st;
  /* a field left by an error (a failed step may have dropped the mesh) */
  int k = dm->mesh ? pa__user_metric_field(dm->mesh) : -1;
  if (k >= 0) pa_mesh_remove_field(dm->mesh, k);
  st = pa__agree_end(dm->comm, st);
  if (done) pa_dmesh_value_remove(dm, done);
  if (st) return st;
  pa_adapt_report *rep = &L->rep;
  uint64_t mem[2] = {pa_memory_peak(), pa_peak_rss()};
  MPI_Allreduce(MPI_IN_PLACE, mem, 2, MPI_UINT64_T, MPI_MAX, dm->comm);
  rep->peak_memory = (size_t)mem[0];
  rep->peak_rss = (size_t)mem[1];
  rep->nelem_final = dm->nglob[PA_ELEMENT];
  rep->nvert_final = dm->nglob[PA_VERTEX];
  rep->time_total = pa_wtime() - t0;
  MPI_Allreduce(MPI_IN_PLACE, &rep->time_total, 1, MPI_DOUBLE, MPI_MAX,
                dm->comm);
  rep->time_total += L->time;
  if (report) *report = *rep;
  return st;
}

/* opts->mem_mb as the memory bound of the call, under a lower one already
 * set (pa_memory_set_limit): the bound to restore after the call. */
static size_t bound_begin(const pa_adapt_opts *opts) {
  size_t old = pa_memory_limit();
  if (opts->mem_mb > 0 && isfinite(opts->mem_mb) &&
      (!old || opts->mem_mb * 1e6 < (double)old))
    pa_memory_set_limit((size_t)(opts->mem_mb * 1e6));
  return old;
}

pa_status pa_dmesh_adapt(pa_dmesh *dm, const pa_adapt_opts *opts,
                         pa_adapt_report *report) {
  pa_status st = PA_SUCCESS;
  pa_adapt_opts def;
  pa__loop L;
  pa_dmesh_value *done = NULL;
  double t0 = pa_wtime();
  size_t bound = pa_memory_limit();
  memset(&L, 0, sizeof L);
  L.t0 = t0;
  PA_CHECK(dm, PA_ERR_ARG, "pa_dmesh_adapt: NULL dmesh");
  pa__agree_reset();
  if (!opts) {
    pa_adapt_opts_default(&def);
    opts = &def;
  }
  bound = bound_begin(opts);
  PA_CALL(check_opts(dm, opts));
  PA_CALL(begin(dm, opts, &L, &done));
  PA_CALL(run(dm, opts, done, &L, t0));
  PA_CALL(finish(dm, opts, &done, &L));
cleanup:
  st = conclude(dm, st, done, &L, t0, report);
  pa_memory_set_limit(bound);
  return st;
}

pa_status pa_dmesh_adapt_resume(MPI_Comm comm, const char *dir,
                                const pa_adapt_opts *opts, pa_dmesh **dmp,
                                pa_adapt_report *report) {
  pa_status st = PA_SUCCESS;
  pa_adapt_opts def;
  pa__loop L;
  pa_dmesh *dm = NULL;
  pa_dmesh_value *done = NULL;
  double t0 = pa_wtime();
  size_t bound = pa_memory_limit();
  memset(&L, 0, sizeof L);
  pa__agree_reset();
  if (!dir || !dmp)
    return pa__error(PA_ERR_ARG, __FILE__, __LINE__,
                     "pa_dmesh_adapt_resume: NULL argument");
  *dmp = NULL;
  if (!opts) {
    pa_adapt_opts_default(&def);
    opts = &def;
  }
  bound = bound_begin(opts);
  PA_CALL(pa__adapt_restore(comm, dir, opts, &dm, &L));
  done = pa_dmesh_value_find(dm, PA_ADAPT_DONE_VALUE);
  PA_CALL(check_opts(dm, opts));
  L.t0 = t0;
  if (opts->remesh.progress) { /* the checkpoint holds the prepared metric */
    PA_CALL(pa_dmesh_metric_complexity(dm, &L.expected));
    L.expected /= pa__unit_simplex_volume(dm->dim);
  }
  PA_CALL(run(dm, opts, done, &L, t0));
  PA_CALL(finish(dm, opts, &done, &L));
cleanup:
  st = conclude(dm, st, done, &L, t0, report);
  pa_memory_set_limit(bound);
  if (st) pa_dmesh_destroy(dm);
  else *dmp = dm;
  return st;
}
