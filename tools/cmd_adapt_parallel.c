/*
 * cmd_adapt_parallel.c -- the parallel `padapt adapt`:
 *
 *   mpiexec -n P padapt adapt IN [-met SOL | -hsiz H] -out OUT
 *       [-distributed-output] [-field F.sol] [-mem MB] [-json REPORT.json]
 *       [-svg HIST.svg] [-max-iter N] [-pieces K] [-checkpoint DIR]
 *       [remesher options]
 *   mpiexec -n P padapt adapt -restart DIR -out OUT [the same options]
 *
 * Reads IN (a sequential mesh on rank 0 with its metric and fields, then
 * distributed; or a distributed set written by pa_dmesh_write, read by all
 * ranks), cuts the level set of -ls into the distributed mesh
 * (pa_dmesh_levelset_cut: the level set travels as the vertex field
 * "levelset", removed after the cut), runs
 * pa_dmesh_adapt, prints one progress line per iteration and the final
 * report in the form of Table 1 of the seed paper (Lachat, Dobrzynski,
 * Pellegrini) on rank 0, and writes OUT gathered on rank 0 (with OUT.sol and
 * <OUT stem>.fields.sol) or, with -distributed-output, as a distributed set.
 * The physical names of the input (Gmsh $PhysicalNames) stay on rank 0 and
 * go onto the gathered output; a distributed set carries none.
 * The JSON report holds the statistics of the output, the times of every
 * step and iteration, the bytes moved and the peak memory of every rank.
 * With -checkpoint DIR the loop writes a checkpoint after each iteration
 * (pa_adapt_opts.checkpoint_dir); -restart DIR resumes the run it belongs
 * to (pa_dmesh_adapt_resume) instead of reading IN, on as many ranks and
 * with the same options, and writes the uninterrupted run's output.
 *
 * Every rank parses the same arguments, so usage errors are seen by all
 * ranks at once; failures on rank 0 alone (reading) are broadcast before
 * any collective call. Exit status: 0 on success, 1 on any error,
 * including a loop that stalled (unless -best-effort: then the valid mesh
 * is written and a warning says so). Every output (the mesh or the set,
 * the metric, the fields, the JSON report, the -svg histograms) is written
 * in one output transaction per rank, committed only when every rank wrote
 * all of its files: on any error none of them is written.
 */
#include "cli.h"

#include <math.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>

/* The name of the vertex field that carries the level set of -ls from rank
 * 0's mesh to the distributed mesh's cut (removed after it). */
#define LS_FIELD "levelset"

/* Rank 0, after pa_cli_read_mesh: the metric (pa_cli_adapt_metric), the
 * fields and the level set of -ls (the last field). Prints its own errors;
 * returns 1 on success. */
static int prepare_root(const pa_cli *cli, const pa_cli_adapt_args *args,
                        pa_mesh *mesh) {
  if (pa_cli_adapt_metric(cli, args, mesh)) return 0;
  if (pa_cli_fail(cli, pa_cli_attach_fields(mesh, args))) return 0;
  if (args->ls) {
    double *phi = NULL;
    if (pa_cli_ls_read(cli, args, mesh, &phi)) return 0;
    pa_status st = pa_mesh_add_field(mesh, LS_FIELD, 1, phi);
    free(phi);
    if (pa_cli_fail(cli, st)) return 0;
  }
  return 1;
}

/* -ls: cut the level set (the last vertex field) into the distributed mesh,
 * remove that field and report on rank 0 (*ls: the report). Collective;
 * returns 0, or 1 after printing the error. */
static int cut_levelset(const pa_cli *cli, const pa_cli_adapt_args *args,
                        pa_dmesh *dm, pa_levelset_report *ls) {
  pa_levelset_opts o;
  pa_ls_material *mat = NULL;
  int bad = pa_cli_ls_opts(cli, args, pa_dmesh_dim(dm), &o, &mat), any = bad;
  MPI_Allreduce(&bad, &any, 1, MPI_INT, MPI_MAX, cli->comm);
  if (any) {
    free(mat);
    return 1;
  }
  pa_mesh *m = pa_dmesh_mesh(dm);
  int k = pa_mesh_nfield(m) - 1;
  pa_status st = pa_dmesh_levelset_cut(dm, k, &o, ls);
  if (st == PA_SUCCESS) st = pa_mesh_remove_field(pa_dmesh_mesh(dm), k);
  if (st == PA_SUCCESS && cli->rank == 0) pa_cli_ls_report(args, &o, ls);
  free(mat);
  if (st == PA_SUCCESS) return 0;
  if (cli->rank == 0)
    pa_cli_error(cli, "adapt: -ls %s: %s", args->ls, pa_last_error());
  return 1;
}

/* 1 when the job on rank 0's mesh (its metric prepared) is too small to
 * share out (-serial-below): its input and the metric's estimate of its
 * output both have fewer elements than the bound. */
static int too_small(const pa_cli *cli, const pa_cli_adapt_args *args,
                     pa_mesh *mesh) {
  int d = pa_mesh_dim(mesh), nc = pa_mesh_metric_ncomp(mesh);
  double bound = args->serial_below >= 0 ? args->serial_below
                 : d == 2               ? PA_CLI_SERIAL_BELOW_2D
                                        : PA_CLI_SERIAL_BELOW_3D;
  double c = 0;
  if (!(pa_mesh_nelem(mesh) < bound) || nc == 0 ||
      pa_metric_complexity(mesh, nc, pa_mesh_metric(mesh), &c) != PA_SUCCESS)
    return 0;
  /* unit elements asked for: 4/sqrt(3) C in 2D, 6 sqrt(2) C in 3D */
  double expected = c * (d == 2 ? 4 / sqrt(3.0) : 6 * sqrt(2.0));
  if (!(expected < bound)) return 0;
  if (cli->verbosity >= 1)
    fprintf(stderr,
            "padapt: %lld elements in, about %.0f out, below -serial-below "
            "%.0f: rank 0 adapts alone\n",
            (long long)pa_mesh_nelem(mesh), expected, bound);
  return 1;
}


/* The progress callback's context. kill_iter: test hook, see progress. */
typedef struct progress_ctx {
  const pa_cli *cli;
  int kill_iter;
} progress_ctx;

/* One line per iteration on rank 0. Test hook: with PADAPT_TEST_KILL_ITER=K
 * in the environment, rank 0 kills itself (SIGKILL, no handler runs) when
 * iteration K reports, after its remeshing and before its checkpoint
 * (tests/cli/test_checkpoint.sh). */
static void progress(const pa_adapt_iter *it, void *ctx) {
  const progress_ctx *pc = ctx;
  const pa_cli *cli = pc->cli;
  if (cli->rank != 0) return;
  if (it->iter == pc->kill_iter) raise(SIGKILL);
  printf("  iter %2d: %9lld tagged, %4d pieces, imbalance %.2f, %3d failed, "
         "%10lld elements | tag %.2f pieces %.2f gather %.2f remesh %.2f "
         "reintegrate %.2f s | peak MB remesh %.0f reintegrate %.0f, "
         "after %.0f\n",
         it->iter, (long long)it->ntagged, it->npieces, it->imbalance,
         it->nfailed, (long long)it->nelem, it->t_tag, it->t_pieces,
         it->t_gather, it->t_remesh, it->t_reintegrate, it->mem_remesh / 1e6,
         it->mem_reintegrate / 1e6, it->mem_after / 1e6);
  fflush(stdout);
}

/* Report the failure of a collective call (same error on every rank) once. */
static void fail_collective(const pa_cli *cli, pa_status st) {
  if (cli->rank == 0) pa_cli_fail(cli, st);
}

static double pct(pa_gid n, pa_gid total) {
  return total > 0 ? 100.0 * (double)n / (double)total : 0.0;
}

/* Table 1 of the seed paper, from the report and the output statistics. */
static void print_table(const pa_cli *cli, const pa_adapt_report *r,
                        const pa_stats *s, const char *remesher) {
  printf(" -- PARALLEL ADAPTATION (%d processes, remesher %s)\n", cli->size,
         remesher);
  printf("    initial elements              %lld\n", (long long)r->nelem_initial);
  printf("    final elements                %lld\n", (long long)r->nelem_final);
  printf("    elapsed time                  %.3f s\n", r->time_total);
  printf("    elapsed time x processes      %.3f s\n", r->time_total * cli->size);
  printf("    smallest edge length          %.4f\n", s->edge_min);
  printf("    largest edge length           %.4f\n", s->edge_max);
  printf("    worst element quality         %.4f\n", s->qual_min);
  printf("    elements with Q in (0.5, 1]   %.2f %%\n", pct(s->qual_above_05, s->nelem));
  printf("    edges in [0.71, 1.41]         %.2f %%\n",
         pct(s->edge_hist[PA_STATS_EDGE_NBIN - 1], s->nedge));
  printf("    iterations %d (%s), pieces %ld, rolled back %ld\n", r->niter,
         r->converged ? "converged" : "stalled", r->npieces, r->nfailed);
  printf("    steps: tag %.3f pieces %.3f gather %.3f remesh %.3f "
         "reintegrate %.3f rebalance %.3f measure %.3f s\n",
         r->t_tag, r->t_pieces, r->t_gather, r->t_remesh, r->t_reintegrate,
         r->t_rebalance, r->t_measure);
  printf("    remeshing busy time (all ranks) %.3f s, CPU %.3f s, bytes "
         "moved %.3g, peak memory per rank %.1f MB\n",
         r->remesh_busy, r->remesh_cpu, r->bytes_moved, r->peak_memory / 1e6);
  printf("    remesher operations: %ld splits, %ld collapses, %ld swaps, %ld "
         "moves\n", r->nsplit, r->ncollapse, r->nswap, r->nmove);
  pa_cli_print_transfer(&r->transfer);
  fflush(stdout);
}

/* The JSON members added to the output statistics. */
static char *json_extra(const pa_cli *cli, const pa_adapt_report *r,
                        const pa_stats *before, const uint64_t *mem,
                        const uint64_t *rss, const char *remesher,
                        const char *lsjson) {
  pa_cli_sbuf b = {NULL, 0, 0, 0};
  if (lsjson) pa_cli_sb_printf(&b, "%s", lsjson);
  pa_cli_sb_printf(&b, "\"processes\": %d, \"remesher\": \"%s\", \"time_s\": %.6f, "
                "\"time_x_processes_s\": %.6f, \"iterations\": %d, "
                "\"converged\": %s, \"stalled\": %s, \"pieces\": %ld, "
                "\"pieces_rolled_back\": %ld, \"elements_before\": %lld, "
                "\"vertices_before\": %lld, \"edge_in_range_before\": %.6f, "
                "\"bytes_moved\": %.0f, \"remesh_busy_s\": %.6f, "
                "\"remesh_cpu_s\": %.6f, \"nsplit\": %ld, \"ncollapse\": %ld, "
                "\"nswap\": %ld, \"nmove\": %ld, ",
            cli->size, remesher, r->time_total, r->time_total * cli->size,
            r->niter, r->converged ? "true" : "false",
            r->stalled ? "true" : "false", r->npieces, r->nfailed,
            (long long)before->nelem, (long long)before->nvert,
            before->nedge ? (double)before->edge_hist[PA_STATS_EDGE_NBIN - 1] /
                                (double)before->nedge
                          : 0.0,
            r->bytes_moved, r->remesh_busy, r->remesh_cpu, r->nsplit,
            r->ncollapse, r->nswap, r->nmove);
  pa_cli_sb_printf(&b, "\"steps_s\": {\"tag\": %.6f, \"pieces\": %.6f, \"gather\": "
                "%.6f, \"remesh\": %.6f, \"reintegrate\": %.6f, \"rebalance\": "
                "%.6f, \"measure\": %.6f}, ",
            r->t_tag, r->t_pieces, r->t_gather, r->t_remesh, r->t_reintegrate,
            r->t_rebalance, r->t_measure);
  pa_cli_sb_printf(&b, "\"peak_memory_bytes_per_rank\": [");
  for (int k = 0; k < cli->size; k++)
    pa_cli_sb_printf(&b, "%s%llu", k ? ", " : "", (unsigned long long)mem[k]);
  pa_cli_sb_printf(&b, "], \"peak_rss_bytes_per_rank\": [");
  for (int k = 0; k < cli->size; k++)
    pa_cli_sb_printf(&b, "%s%llu", k ? ", " : "", (unsigned long long)rss[k]);
  pa_cli_sb_printf(&b, "], \"iteration_detail\": [");
  for (int k = 0; k < r->niter_recorded; k++) {
    const pa_adapt_iter *it = &r->iters[k];
    pa_cli_sb_printf(&b, "%s{\"iter\": %d, \"tagged\": %lld, \"pieces\": %d, "
                  "\"rolled_back\": %d, \"imbalance\": %.4f, \"elements\": %lld, "
                  "\"tag_s\": %.6f, \"pieces_s\": %.6f, \"gather_s\": %.6f, "
                  "\"remesh_s\": %.6f, \"reintegrate_s\": %.6f, "
                  "\"remesh_busy_s\": %.6f, \"remesh_cpu_s\": %.6f, "
                  "\"nsplit\": %ld, \"ncollapse\": %ld, \"nswap\": %ld, "
                  "\"nmove\": %ld, \"bytes_moved\": %.0f, "
                  "\"peak_bytes\": {\"tag\": %.0f, \"pieces\": %.0f, "
                  "\"gather\": %.0f, \"remesh\": %.0f, \"reintegrate\": %.0f}, "
                  "\"bytes_after\": %.0f}",
              k ? ", " : "", it->iter, (long long)it->ntagged, it->npieces,
              it->nfailed, it->imbalance, (long long)it->nelem, it->t_tag,
              it->t_pieces, it->t_gather, it->t_remesh, it->t_reintegrate,
              it->remesh_busy, it->remesh_cpu, it->nsplit, it->ncollapse,
              it->nswap, it->nmove, it->bytes_moved, it->mem_tag, it->mem_pieces,
              it->mem_gather, it->mem_remesh, it->mem_reintegrate,
              it->mem_after);
  }
  char *fid = pa_cli_fidelity_json(&r->fidelity);
  char *tr = pa_cli_transfer_json(&r->transfer);
  pa_cli_sb_printf(&b, "], %s%s", tr ? tr : "", fid ? fid : "");
  if (!fid || !tr) b.fail = 1;
  free(fid);
  free(tr);
  if (b.fail) {
    free(b.p);
    return NULL;
  }
  return b.p;
}

/* Seconds since *t0, which becomes now (the -v 2 phase timings). */
static double lap(double *t0) {
  double t = pa_wtime(), dt = t - *t0;
  *t0 = t;
  return dt;
}

/* Read IN (a set, or a mesh on rank 0 with its metric and fields, then
 * distributed), print its statistics and adapt it into *dm: the statistics
 * before in *before, the report in *rep, the read and stats times in
 * tstep[0..1], on rank 0 the input's physical names on a mesh of their own
 * in *names. Collective; returns 0, or 1 after printing the error (*dm
 * and *names may then be set: the caller destroys them). */
static int read_and_adapt(const pa_cli *cli, const pa_cli_adapt_args *args,
                          int set, const pa_adapt_opts *opts, pa_dmesh **dm,
                          pa_mesh **names, pa_stats *before,
                          pa_levelset_report *ls, pa_adapt_report *rep,
                          double *tstep, double *t0) {
  const char *in = args->in;
  pa_mesh *mesh = NULL;
  pa_status st;
  int ok = 1;
  if (set) {
    st = pa_dmesh_read(cli->comm, in, 0, dm);
    /* -field-transfer on the set's fields (the same on every rank) */
    if (st == PA_SUCCESS) st = pa_cli_attach_fields(pa_dmesh_mesh(*dm), args);
    if (st) {
      fail_collective(cli, st);
      return 1;
    }
  } else {
    st = pa_cli_read_adapt_mesh(cli, args, args->remesh.geometry,
                                &mesh); /* collective */
    if (cli->rank == 0) {
      if (st) pa_cli_fail(cli, st);
      ok = st == PA_SUCCESS && prepare_root(cli, args, mesh);
      if (ok && !args->distributed && !args->mem_mb && !args->checkpoint &&
          too_small(cli, args, mesh))
        ok = PA_CLI_SERIAL;
      if (ok == 1 && (pa_mesh_nnames(mesh) > 0 || pa_mesh_classified(mesh))) {
        st = pa_mesh_create(pa_mesh_dim(mesh), names);
        if (st == PA_SUCCESS) st = pa_mesh_copy_model(*names, mesh);
        if (st) ok = !pa_cli_fail(cli, st);
      }
    }
    MPI_Bcast(&ok, 1, MPI_INT, 0, cli->comm);
    if (ok == 1) st = pa_dmesh_distribute(cli->comm, 0, mesh, 0, dm);
    pa_mesh_destroy(mesh);
    if (ok == PA_CLI_SERIAL) return PA_CLI_SERIAL;
    if (!ok) return 1;
    if (st) {
      fail_collective(cli, st);
      return 1;
    }
  }
  if (args->ls && cut_levelset(cli, args, *dm, ls)) return 1;
  if (pa_mesh_metric_ncomp(pa_dmesh_mesh(*dm)) == 0 && opts->remesh.hsiz <= 0) {
    if (cli->rank == 0) pa_cli_error(cli, "adapt: no metric: give -hsiz H");
    return 1;
  }
  tstep[0] = lap(t0);
  if (pa_mesh_metric_ncomp(pa_dmesh_mesh(*dm)) > 0) {
    st = pa_dmesh_stats(*dm, before);
    if (st) {
      fail_collective(cli, st);
      return 1;
    }
  } else {
    memset(before, 0, sizeof *before);
    before->nelem = pa_dmesh_nglobal(*dm, PA_ELEMENT);
    before->nvert = pa_dmesh_nglobal(*dm, PA_VERTEX);
  }
  if (cli->rank == 0) {
    printf(" -- INPUT %s (%d processes)\n", in, cli->size);
    if (before->nedge) pa_stats_print(before, stdout);
    printf(" -- ITERATIONS\n");
    fflush(stdout);
  }
  tstep[1] = lap(t0);
  /* the local parameters, read by every rank: the pieces need them */
  pa_adapt_opts o = *opts;
  pa_local_param *local = NULL;
  if (args->params) {
    int bad = pa_cli_read_params(cli, args->params, pa_dmesh_dim(*dm), &local,
                                 &o.remesh.nlocal, NULL, NULL), any = bad;
    MPI_Allreduce(&bad, &any, 1, MPI_INT, MPI_MAX, cli->comm);
    if (any) {
      free(local);
      return 1;
    }
    o.remesh.local = local;
  }
  st = pa_dmesh_adapt(*dm, &o, rep);
  free(local);
  if (st) {
    fail_collective(cli, st);
    return 1;
  }
  return 0;
}

/* -restart DIR: resume the checkpointed run into *dm (pa_dmesh_adapt_resume;
 * the statistics before are not known: *before holds the counts only).
 * Collective; returns 0, or 1 after printing the error. */
static int resume(const pa_cli *cli, const pa_cli_adapt_args *args,
                  const pa_adapt_opts *opts, pa_dmesh **dm, pa_stats *before,
                  pa_adapt_report *rep) {
  if (cli->rank == 0) {
    printf(" -- RESTART from %s (%d processes)\n -- ITERATIONS\n",
           args->restart, cli->size);
    fflush(stdout);
  }
  pa_status st = pa_dmesh_adapt_resume(cli->comm, args->restart, opts, dm, rep);
  if (st) {
    fail_collective(cli, st);
    if (cli->rank == 0) pa_cli_error(cli, "adapt: no output written");
    return 1;
  }
  memset(before, 0, sizeof *before);
  before->nelem = rep->nelem_initial;
  before->nvert = rep->nvert_initial;
  return 0;
}

/* Whether IN is a distributed set (*set, the same on every rank), and the
 * inputs that go with it: -restart reads none of them (a note says so), a
 * set takes no -met nor -field. Collective; returns 0, or 1 after printing
 * the error. */
static int check_input(const pa_cli *cli, const pa_cli_adapt_args *args,
                       int *set) {
  const char *in = args->in;
  *set = cli->rank == 0 && in ? pa_dmesh_is_set(in) : 0;
  MPI_Bcast(set, 1, MPI_INT, 0, cli->comm);
  if (args->restart) {
    if (cli->rank == 0 &&
        (in || args->met || args->nfield || args->ntransfer || args->ls))
      fprintf(stderr, "padapt: adapt: -restart: the mesh (cut already), its "
                      "metric and fields come from the checkpoint (IN, -met, "
                      "-field, -field-transfer and -ls are not read)\n");
  } else if (*set && (args->met || args->nfield || args->ls)) {
    if (cli->rank == 0)
      pa_cli_error(cli, "adapt: -met, -field and -ls need a sequential input "
                        "mesh, not a distributed set");
    return 1;
  }
  return 0;
}

/* The options of the piece loop from the command's. */
static void loop_opts(const pa_cli_adapt_args *args, pa_adapt_opts *opts) {
  pa_adapt_opts_default(opts);
  opts->remesh = args->remesh;
  if (args->mem_mb > 0) opts->mem_mb = args->mem_mb;
  if (args->max_iter > 0) opts->max_iter = args->max_iter;
  if (args->pieces > 0) opts->pieces_per_rank = args->pieces;
  if (args->check) opts->check_pieces = 1;
  opts->checkpoint_dir = args->checkpoint;
}

/* Read and adapt IN, or resume from the checkpoint (read_and_adapt, resume,
 * with their arguments), with one progress line per iteration and, on rank
 * 0, the remesher's live line. Collective; returns 0, or 1 after printing
 * the error. */
static int adapt(const pa_cli *cli, const pa_cli_adapt_args *args, int set,
                 pa_dmesh **dm, pa_mesh **names, pa_stats *before,
                 pa_levelset_report *ls, pa_adapt_report *rep, double *tstep,
                 double *t0) {
  pa_adapt_opts opts;
  loop_opts(args, &opts);
  const char *kill_iter = getenv("PADAPT_TEST_KILL_ITER");
  progress_ctx pctx = {cli, kill_iter && kill_iter[0] ? atoi(kill_iter) : 0};
  pa_cli_progress live;
  opts.progress = progress;
  opts.progress_ctx = &pctx;
  pa_cli_progress_init(&live, cli->rank == 0 && opts.remesh.verbosity >= 0);
  opts.remesh.progress = pa_cli_progress_cb;
  opts.remesh.progress_ctx = &live;
  int adapted = args->restart
                    ? resume(cli, args, &opts, dm, before, rep)
                    : read_and_adapt(cli, args, set, &opts, dm, names, before,
                                     ls, rep, tstep, t0);
  pa_cli_progress_end(&live);
  return adapted;
}

/* On rank 0, the output's statistics, Table 1 and the outcome, with the
 * warnings of a missed target and of a stalled loop written anyway
 * (-best-effort). Returns 0, or 1 after printing the error of a loop that
 * stalled without -best-effort (on every rank: rep is the same on all). */
static int report(const pa_cli *cli, const pa_cli_adapt_args *args,
                  const pa_adapt_report *rep) {
  if (cli->rank == 0) {
    printf(" -- OUTPUT %s, in the given metric\n", args->out);
    pa_stats_print(&rep->fidelity.user, stdout);
    print_table(cli, rep, &rep->fidelity.user, pa_remesher_builtin()->name);
    pa_cli_print_fidelity(&rep->fidelity, stdout);
    fflush(stdout);
    if (!rep->fidelity.target_met)
      fprintf(stderr, "padapt: warning: adapt: target missed (valid mesh, but "
                      "the given metric is not met; see the outcome line)\n");
    if (!rep->converged && args->best_effort)
      fprintf(stderr, "padapt: warning: adapt: the loop stalled with %lld "
                      "elements still tagged (valid mesh, written: "
                      "-best-effort)\n",
              (long long)rep->ntagged_left);
  }
  if (rep->converged || args->best_effort) return 0;
  if (cli->rank == 0)
    pa_cli_error(cli, "adapt: the loop stalled with %lld elements still "
                      "tagged after %d iteration%s: no output written "
                      "(-best-effort writes the valid mesh anyway)",
                 (long long)rep->ntagged_left, rep->niter,
                 rep->niter > 1 ? "s" : "");
  return 1;
}

/* The mesh: a distributed set (which carries its metric and fields), or
 * gathered into *g on rank 0 with the input's physical names and written
 * with its metric (unless -nosol) and its fields; *tgather: the seconds of
 * the gather. Collective. */
static pa_status write_mesh(const pa_cli *cli, const pa_cli_adapt_args *args,
                            pa_dmesh *dm, const pa_mesh *names, pa_mesh **g,
                            double *tgather) {
  const char *out = args->out;
  double t0 = pa_wtime();
  *tgather = 0;
  if (args->distributed) return pa_dmesh_write(dm, out);
  pa_status st = pa_dmesh_gather(dm, 0, g);
  *tgather = pa_wtime() - t0;
  if (st != PA_SUCCESS || cli->rank != 0) return st;
  char *path = NULL;
  if (names) st = pa_mesh_copy_model(*g, names);
  if (st == PA_SUCCESS) st = pa_mesh_write(*g, out, NULL);
  if (st == PA_SUCCESS && !args->nosol) {
    pa_sol *sol = NULL;
    path = pa_cli_replace_ext(out, ".sol");
    st = pa_mesh_metric_to_sol(*g, 0, &sol);
    if (st == PA_SUCCESS)
      st = pa_sol_write(sol, args->outsol ? args->outsol : path);
    pa_sol_destroy(sol);
    free(path);
    path = NULL;
  }
  if (st == PA_SUCCESS && pa_cli_has_fields(*g)) {
    path = pa_cli_replace_ext(out, ".fields.sol");
    st = pa_cli_write_fields(*g, args->outfield ? args->outfield : path);
  }
  free(path);
  return st;
}

/* The peak memory of every rank (padapt's, and the resident set) into
 * mem[] and rss[] on rank 0, malloc'ed (NULL elsewhere, and when out of
 * memory). Collective. */
static void gather_peaks(const pa_cli *cli, uint64_t **mem, uint64_t **rss) {
  uint64_t mine[2] = {pa_memory_peak(), pa_peak_rss()}, *both = NULL;
  if (cli->rank == 0) {
    *mem = calloc((size_t)cli->size, sizeof **mem);
    *rss = calloc((size_t)cli->size, sizeof **rss);
    both = calloc(2 * (size_t)cli->size, sizeof *both);
  }
  MPI_Gather(mine, 2, MPI_UINT64_T, both, 2, MPI_UINT64_T, 0, cli->comm);
  if (cli->rank == 0 && both && *mem && *rss)
    for (int k = 0; k < cli->size; k++) {
      (*mem)[k] = both[2 * k];
      (*rss)[k] = both[2 * k + 1];
    }
  free(both);
}

/* Every output of every rank in one transaction, all of them or none: the
 * mesh (write_mesh), then on rank 0 the -json report, with the peak memory
 * of every rank, writing included, and the -svg picture; *tgather: the
 * seconds of the gather. Collective; returns 0, or 1 after printing the
 * error. */
static int write_outputs(const pa_cli *cli, const pa_cli_adapt_args *args,
                         pa_dmesh *dm, const pa_mesh *names,
                         const pa_stats *before, const pa_levelset_report *ls,
                         const pa_adapt_report *rep, double *tgather) {
  pa_mesh *g = NULL;
  uint64_t *mem = NULL, *rss = NULL;
  pa_output *tx = NULL;
  pa_status st = pa_output_begin(&tx);
  *tgather = 0;
  if (st == PA_SUCCESS) st = write_mesh(cli, args, dm, names, &g, tgather);
  gather_peaks(cli, &mem, &rss);
  if (st == PA_SUCCESS && args->json && cli->rank == 0) {
    char *lsj = args->ls && !args->restart ? pa_cli_ls_json(ls) : NULL;
    char *extra = mem && rss && (lsj || !args->ls || args->restart)
                      ? json_extra(cli, rep, before, mem, rss,
                                   pa_remesher_builtin()->name, lsj)
                      : NULL;
    free(lsj);
    st = extra ? pa_stats_write_json(&rep->fidelity.user, extra, args->json)
               : pa_set_error(PA_ERR_MEMORY, "out of memory");
    free(extra);
  }
  if (st == PA_SUCCESS && args->svg && cli->rank == 0)
    st = pa_cli_adapt_svg(args, before, &rep->fidelity.user);
  st = pa_cli_output_end(cli->comm, tx, st);
  free(mem);
  free(rss);
  pa_mesh_destroy(g);
  if (st == PA_SUCCESS) return 0;
  if (cli->rank == 0) {
    pa_cli_fail(cli, st);
    pa_cli_error(cli, "adapt: no output written");
  }
  return 1;
}

int pa_cli_adapt_parallel(const pa_cli *cli, const pa_cli_adapt_args *args) {
  int set;
  if (check_input(cli, args, &set)) return 1;
  pa_dmesh *dm = NULL;
  pa_mesh *names = NULL;
  pa_stats before;
  pa_adapt_report rep;
  pa_levelset_report ls;
  double tstep[5] = {0}, tgather = 0; /* read, stats, adapt, stats, write */
  double t0 = pa_wtime();
  memset(&rep, 0, sizeof rep);
  memset(&ls, 0, sizeof ls);
  int rc = adapt(cli, args, set, &dm, &names, &before, &ls, &rep, tstep, &t0);
  if (!rc) {
    tstep[2] = lap(&t0);
    rc = report(cli, args, &rep);
  }
  if (!rc) {
    tstep[3] = lap(&t0);
    rc = write_outputs(cli, args, dm, names, &before, &ls, &rep, &tgather);
  }
  if (!rc && cli->verbosity >= 2 && cli->rank == 0) {
    tstep[4] = lap(&t0);
    fprintf(stderr, "padapt: rank 0: read and distribute %.3f s, stats %.3f s, "
                    "adapt %.3f s, stats %.3f s, gather %.3f s, write %.3f s\n",
            tstep[0], tstep[1], tstep[2], tstep[3], tgather, tstep[4] - tgather);
  }
  pa_mesh_destroy(names);
  pa_dmesh_destroy(dm);
  return rc;
}
