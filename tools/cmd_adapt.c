/*
 * cmd_adapt.c -- `padapt adapt`: sequential adaptation of a mesh to a metric
 * with the built-in remesher (Mmg-compatible options).
 *
 *   padapt adapt IN [-met SOL | -sol SOL | -hsiz H] -out OUT [options]
 *
 * Outputs: the mesh OUT (format by extension), its metric in OUT's name with
 * the extension replaced by .sol (or -outsol PATH; -nosol for none), the
 * interpolated user fields (-field F.sol) in <OUT stem>.fields.sol (or
 * -outfield PATH). Prints `padapt stats` before and after, the operation
 * counts and the time. Exit status: 0 on success and on "target missed" (a
 * valid mesh that misses some edge lengths: a warning says so, and the JSON
 * report's "outcome" field), 1 on any error (no output written).
 *
 * With several MPI ranks, rank 0 does the work (the parallel driver is
 * `padapt adapt` with distributed input, issue #6).
 */
#include "cli.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static const char *adapt_usage =
    "usage: padapt adapt IN [-met SOL | -sol SOL | -hsiz H] -out OUT [options]\n"
    "  -in IN          input mesh (same as the positional IN)\n"
    "  -met/-sol SOL   metric: sizes (scalar) or tensors, .sol/.solb\n"
    "  -hsiz H         constant size H (replaces the metric)\n"
    "  -out OUT        output mesh (.mesh .meshb .msh .vtu)\n"
    "  -outsol PATH    output metric (default: OUT with extension .sol)\n"
    "  -nosol          do not write the output metric\n"
    "  -hmin H -hmax H clamp the sizes\n"
    "  -hgrad G        gradation (default 1.3; <= 1 disables)\n"
    "  -hausd D        max boundary deviation from the curve (default 0.01)\n"
    "  -ar A           corner detection angle in degrees (default 45)\n"
    "  -nr             no corner detection by angle\n"
    "  -noinsert -noswap -nomove   disable operators\n"
    "  -field F.sol    vertex fields to interpolate; written to\n"
    "                  <OUT stem>.fields.sol (or -outfield PATH)\n"
    "  -json R.json    write the after-statistics, time and counts as JSON\n"
    "  -v N            verbosity\n";

static const char *outcome_name(pa_remesh_outcome o) {
  return o == PA_REMESH_SUCCESS         ? "success"
         : o == PA_REMESH_TARGET_MISSED ? "target missed"
                                        : "failed";
}

int pa_cli_adapt(const pa_cli *cli, int argc, char **argv) {
  /* On several ranks, or when asked for a distributed output, the parallel
   * piece loop (tools/cmd_padapt.c) does the work. */
  if (cli->size > 1) return pa_cli_adapt_parallel(cli, argc, argv);
  for (int i = 1; i < argc; i++)
    if (!strcmp(argv[i], "-distributed-output") || !strcmp(argv[i], "-mem"))
      return pa_cli_adapt_parallel(cli, argc, argv);
  const char *in = NULL, *out = NULL, *met = NULL, *outsol = NULL;
  const char *field = NULL, *outfield = NULL, *json = NULL;
  int nosol = 0, rc = 1;
  pa_remesh_opts opts;
  pa_remesh_opts_default(&opts);
  opts.verbosity = cli->verbosity;

  for (int i = 1; i < argc; i++) {
    const char *a = argv[i];
    const char *val = i + 1 < argc ? argv[i + 1] : NULL;
#define NEEDS_FILE(what)                                                     \
  do {                                                                       \
    if (!val) return pa_cli_error(cli, "adapt: %s needs %s", a, what);       \
    i++;                                                                     \
  } while (0)
    int r = pa_cli_remesh_option(cli, argc, argv, &i, &opts);
    if (r < 0) return 1;
    if (r > 0) continue;
    if (!strcmp(a, "-h") || !strcmp(a, "--help")) {
      if (cli->rank == 0) fputs(adapt_usage, stdout);
      return 0;
    } else if (!strcmp(a, "-in")) {
      NEEDS_FILE("a mesh file");
      if (in) return pa_cli_error(cli, "adapt: more than one input mesh");
      in = val;
    } else if (!strcmp(a, "-met") || !strcmp(a, "-sol")) {
      NEEDS_FILE("a .sol file");
      met = val;
    } else if (!strcmp(a, "-out")) {
      NEEDS_FILE("a mesh file");
      out = val;
    } else if (!strcmp(a, "-outsol")) {
      NEEDS_FILE("a .sol file");
      outsol = val;
    } else if (!strcmp(a, "-nosol")) {
      nosol = 1;
    } else if (!strcmp(a, "-field")) {
      NEEDS_FILE("a .sol file");
      field = val;
    } else if (!strcmp(a, "-outfield")) {
      NEEDS_FILE("a .sol file");
      outfield = val;
    } else if (!strcmp(a, "-json")) {
      NEEDS_FILE("a file");
      json = val;
    } else if (a[0] == '-' && a[1]) {
      return pa_cli_error(cli, "adapt: unknown option '%s' (see padapt adapt -h)", a);
    } else if (!in) {
      in = a;
    } else {
      return pa_cli_error(cli, "adapt: more than one input mesh ('%s')", a);
    }
#undef NEEDS_FILE
  }
  if (!in) return pa_cli_error(cli, "adapt: no input mesh\n%s", adapt_usage);
  if (!out) return pa_cli_error(cli, "adapt: no output mesh (-out OUT)");
  if (met && opts.hsiz > 0)
    return pa_cli_error(cli, "adapt: give either -met/-sol or -hsiz, not both");
  if (opts.hmin > 0 && opts.hmax > 0 && opts.hmin > opts.hmax)
    return pa_cli_error(cli, "adapt: -hmin (%g) is larger than -hmax (%g)",
                        opts.hmin, opts.hmax);

  pa_mesh *mesh = NULL;
  pa_sol *sol = NULL;
  char *solpath = NULL, *fieldpath = NULL, *extra = NULL;
  pa_stats before, after;
  pa_remesh_report rep;
  pa_status st = pa_cli_read_mesh(cli, in, &mesh); /* collective */
  if (cli->rank != 0) return st ? 1 : 0;
  if (st != PA_SUCCESS) {
    pa_cli_fail(cli, st);
    goto done;
  }
  if (met) {
    st = pa_cli_attach_metric(mesh, met);
    if (st) {
      pa_cli_fail(cli, st);
      goto done;
    }
  } else if (opts.hsiz <= 0 && pa_mesh_metric_ncomp(mesh) == 0) {
    pa_cli_error(cli, "adapt: no metric: give -met SOL, -sol SOL or -hsiz H");
    goto done;
  }
  if (field) {
    st = pa_cli_attach_fields(mesh, field);
    if (st) {
      pa_cli_fail(cli, st);
      goto done;
    }
  }

  /* statistics before, in the target metric */
  if (opts.hsiz > 0 && pa_mesh_metric_ncomp(mesh) == 0) {
    pa_idx nv = pa_mesh_nvert(mesh);
    double *h = malloc(sizeof(double) * (nv ? nv : 1));
    if (!h) {
      pa_cli_error(cli, "adapt: out of memory");
      goto done;
    }
    for (pa_idx v = 0; v < nv; v++) h[v] = opts.hsiz;
    st = pa_mesh_set_metric(mesh, 1, h);
    free(h);
    if (st) {
      pa_cli_fail(cli, st);
      goto done;
    }
  }
  st = pa_mesh_stats(mesh, &before);
  if (st) {
    pa_cli_fail(cli, st);
    goto done;
  }
  printf(" -- INPUT %s\n", in);
  pa_stats_print(&before, stdout);
  fflush(stdout);

  st = pa_remesh(pa_remesher_builtin(), mesh, &opts, &rep);
  if (st != PA_SUCCESS) {
    pa_cli_fail(cli, st);
    goto done;
  }
  if (rep.outcome == PA_REMESH_FAILED) {
    pa_cli_error(cli, "adapt: the remesher failed (%s); nothing written",
                 pa_last_error()[0] ? pa_last_error() : "no detail");
    goto done;
  }
  st = pa_mesh_stats(mesh, &after);
  if (st) {
    pa_cli_fail(cli, st);
    goto done;
  }
  printf(" -- OUTPUT %s\n", out);
  pa_stats_print(&after, stdout);
  printf(" -- ADAPTATION\n"
         "    splits %ld, collapses %ld, swaps %ld, moves %ld, passes %d\n"
         "    time %.3f s (%.0f output elements/s), peak padapt memory %.1f MB\n"
         "    outcome %s\n",
         rep.nsplit, rep.ncollapse, rep.nswap, rep.nmove, rep.npass, rep.time_s,
         rep.time_s > 0 ? pa_mesh_nelem(mesh) / rep.time_s : 0.0,
         pa_memory_peak() / 1e6, outcome_name(rep.outcome));
  fflush(stdout);
  if (rep.outcome == PA_REMESH_TARGET_MISSED)
    fprintf(stderr, "padapt: warning: adapt: target missed (valid mesh, but "
                    "some edge lengths or qualities are off target)\n");

  st = pa_mesh_write(mesh, out, NULL);
  if (st == PA_SUCCESS && !nosol) {
    solpath = outsol ? NULL : pa_cli_replace_ext(out, ".sol");
    st = pa_mesh_metric_to_sol(mesh, 0, &sol);
    if (st == PA_SUCCESS) st = pa_sol_write(sol, outsol ? outsol : solpath);
    pa_sol_destroy(sol);
    sol = NULL;
  }
  if (st == PA_SUCCESS && pa_mesh_nfield(mesh) > 0) {
    fieldpath = outfield ? NULL : pa_cli_replace_ext(out, ".fields.sol");
    st = pa_cli_write_fields(mesh, outfield ? outfield : fieldpath);
  }
  if (st == PA_SUCCESS && json) {
    size_t n = 512;
    extra = malloc(n);
    if (extra)
      snprintf(extra, n,
               "\"time_s\": %.6f, \"peak_rss_bytes\": %zu, "
               "\"peak_memory_bytes\": %zu, \"outcome\": \"%s\", "
               "\"nsplit\": %ld, \"ncollapse\": %ld, \"nswap\": %ld, "
               "\"nmove\": %ld, \"npass\": %d, \"elements_before\": %lld, "
               "\"vertices_before\": %lld",
               rep.time_s, pa_peak_rss(), pa_memory_peak(),
               outcome_name(rep.outcome), rep.nsplit, rep.ncollapse, rep.nswap,
               rep.nmove, rep.npass, (long long)before.nelem,
               (long long)before.nvert);
    st = pa_stats_write_json(&after, extra, json);
  }
  if (st != PA_SUCCESS) {
    pa_cli_fail(cli, st);
    goto done;
  }
  rc = 0;
done:
  free(solpath);
  free(fieldpath);
  free(extra);
  pa_mesh_destroy(mesh);
  return rc;
}
