/*
 * cli_util.c -- the helpers the commands of the CLI share (cli.h): messages
 * and exit statuses, reading a mesh given on the command line, numbers and
 * paths of arguments, the metric `padapt adapt` adapts to, the report of how
 * a result meets the metric, vertex fields in .sol files, the output
 * checks and transactions, and the -svg picture of `padapt adapt`, sequential
 * or parallel.
 */
#include "cli.h"
#include "svg.h"

#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <time.h>

int pa_cli_error(const pa_cli *cli, const char *fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  fprintf(stderr, "padapt: ");
  if (cli && cli->size > 1) fprintf(stderr, "[rank %d] ", cli->rank);
  vfprintf(stderr, fmt, ap);
  fputc('\n', stderr);
  va_end(ap);
  return 1;
}

int pa_cli_fail(const pa_cli *cli, pa_status st) {
  if (st == PA_SUCCESS) return 0;
  const char *msg = pa_last_error();
  return pa_cli_error(cli, "%s", msg[0] ? msg : pa_status_string(st));
}

pa_status pa_cli_read_mesh(const pa_cli *cli, const char *path,
                           pa_mesh **mesh) {
  pa_idx nadded = 0;
  pa_status st;
  char msg[1100];
  *mesh = NULL;
  /* A distributed set is read by every rank and gathered on rank 0; a
   * sequential file is read by rank 0 alone. */
  int is_set = cli->rank == 0 ? pa_dmesh_is_set(path) : 0;
  MPI_Bcast(&is_set, 1, MPI_INT, 0, cli->comm);
  if (is_set) {
    st = pa_dmesh_read_gathered(cli->comm, 0, path, mesh);
    if (cli->rank != 0 || st != PA_SUCCESS) return st;
  } else {
    if (cli->rank != 0) return PA_SUCCESS;
    st = pa_mesh_read(path, mesh);
    if (st != PA_SUCCESS) return st;
  }
  /* A file that lists no boundary at all gets one; a file that lists some
   * must list all (a missing one reveals a non-conforming mesh). */
  if (pa_mesh_nbdry(*mesh) == 0) st = pa_mesh_build_boundary(*mesh, 0, &nadded);
  if (st == PA_SUCCESS && nadded > 0 && cli->verbosity >= 1)
    fprintf(stderr, "padapt: %s: added %d missing boundary entities (ref 0)\n",
            path, (int)nadded);
  if (st == PA_SUCCESS) st = pa_mesh_check(*mesh);
  if (st != PA_SUCCESS) {
    /* The topology and check messages name the entity, not the file. */
    snprintf(msg, sizeof msg, "%s: %s", path, pa_last_error());
    pa_mesh_destroy(*mesh);
    *mesh = NULL;
    st = pa_set_error(st, "%s", msg);
  }
  return st;
}

void pa_cli_set_verbosity(int level) {
  pa_set_verbosity(level);
  /* -v -1: errors and warnings only (stderr); the reports go nowhere */
  if (level < 0 && !freopen("/dev/null", "w", stdout)) fclose(stdout);
}

int pa_cli_parse_num(const char *s, double *v) {
  char *end;
  if (!s || !*s) return 0;
  *v = strtod(s, &end);
  return *end == '\0' && isfinite(*v);
}

int pa_cli_is_svg(const char *path) {
  size_t n = strlen(path);
  return n > 4 && !strcasecmp(path + n - 4, ".svg");
}

char *pa_cli_replace_ext(const char *path, const char *ext) {
  const char *dot = strrchr(path, '.'), *slash = strrchr(path, '/');
  size_t n = (dot && (!slash || dot > slash)) ? (size_t)(dot - path)
                                               : strlen(path);
  char *s = malloc(n + strlen(ext) + 1);
  if (!s) return NULL;
  memcpy(s, path, n);
  strcpy(s + n, ext);
  return s;
}

void pa_cli_sb_printf(pa_cli_sbuf *b, const char *fmt, ...) {
  if (b->fail) return;
  for (;;) {
    va_list ap;
    va_start(ap, fmt);
    int k = vsnprintf(b->p ? b->p + b->n : NULL, b->p ? b->cap - b->n : 0, fmt, ap);
    va_end(ap);
    if (k < 0) {
      b->fail = 1;
      return;
    }
    if (b->p && b->n + (size_t)k < b->cap) {
      b->n += (size_t)k;
      return;
    }
    size_t cap = (b->cap + (size_t)k + 1) * 2;
    char *q = realloc(b->p, cap);
    if (!q) {
      b->fail = 1;
      return;
    }
    b->p = q;
    b->cap = cap;
  }
}

void pa_cli_print_fidelity(const pa_fidelity *f, FILE *out) {
  const pa_stats *u = &f->used;
  char line[512];
  if (!f->measured) {
    fprintf(out, "    outcome not measured (out of memory after the remesh)\n");
    return;
  }
  if (f->changed) {
    fprintf(out, " -- IN THE METRIC USED (the given one after%s%s%s)\n",
            f->changed & PA_CHANGED_HMIN ? " -hmin" : "",
            f->changed & PA_CHANGED_HMAX ? " -hmax" : "",
            f->changed & PA_CHANGED_GRADATION ? " -hgrad" : "");
    double lo, hi;
    pa_stats_edge_bin(PA_STATS_EDGE_NBIN - 1, &lo, &hi);
    fprintf(out, "    edges in [%.4f, %.4f)  %6.2f %%   length [%.4g, %.4g]\n",
            lo, hi, u->nedge ? 100.0 * (double)u->edge_hist[PA_STATS_EDGE_NBIN - 1] /
                           (double)u->nedge
                     : 0.0,
            u->edge_min, u->edge_max);
    fprintf(out, "    quality worst %.4g, average %.4f\n", u->qual_min,
            u->nelem ? u->qual_sum / (double)u->nelem : 0.0);
  }
  pa_fidelity_describe(f, line, sizeof line);
  fprintf(out, "    outcome %s: %s\n",
          f->target_met ? "success" : "target missed", line);
}

char *pa_cli_fidelity_json(const pa_fidelity *f) {
  pa_cli_sbuf b = {NULL, 0, 0, 0};
  const pa_stats *u = &f->used;
  int met = pa_stats_target_met(u);
  if (!f->measured) {
    pa_cli_sb_printf(&b, "\"outcome\": \"not measured\"");
    return b.fail ? (free(b.p), NULL) : b.p;
  }
  pa_cli_sb_printf(&b, "\"outcome\": \"%s\", \"target_met\": %s, \"limited_by\": [",
                   f->target_met ? "success" : "target missed",
                   f->target_met ? "true" : "false");
  if (!f->target_met) {
    int n = 0;
    if (!met) pa_cli_sb_printf(&b, "\"remesher\""), n++;
    if (met && (f->changed & PA_CHANGED_HMIN))
      pa_cli_sb_printf(&b, "%s\"hmin\"", n++ ? ", " : "");
    if (met && (f->changed & PA_CHANGED_HMAX))
      pa_cli_sb_printf(&b, "%s\"hmax\"", n++ ? ", " : "");
    if (met && (f->changed & PA_CHANGED_GRADATION))
      pa_cli_sb_printf(&b, "%s\"gradation\"", n++ ? ", " : "");
  }
  pa_cli_sb_printf(
      &b,
      "], \"metric_used\": {\"changed\": %s, \"edge_in_range\": %.6f, "
      "\"edge_min\": %.6g, \"edge_max\": %.6g, \"quality_worst\": %.6g, "
      "\"quality_mean\": %.6f, \"target_met\": %s}",
      f->changed ? "true" : "false",
      u->nedge ? (double)u->edge_hist[PA_STATS_EDGE_NBIN - 1] / (double)u->nedge
               : 0.0,
      u->edge_min, u->edge_max, u->qual_min,
      u->nelem ? u->qual_sum / (double)u->nelem : 0.0, met ? "true" : "false");
  if (b.fail) {
    free(b.p);
    return NULL;
  }
  return b.p;
}

pa_status pa_cli_attach_fields(pa_mesh *mesh, const char *path) {
  pa_sol *sol = NULL;
  char msg[600];
  pa_status st = pa_sol_read(path, &sol);
  if (st) return st;
  if (pa_sol_nvert(sol) != pa_mesh_nvert(mesh)) {
    snprintf(msg, sizeof msg,
             "%s: %d values per field, but the mesh has %d vertices",
             pa_sol_origin(sol), (int)pa_sol_nvert(sol),
             (int)pa_mesh_nvert(mesh));
    pa_sol_destroy(sol);
    return pa_set_error(PA_ERR_FORMAT, "%s", msg);
  }
  for (int k = 0; k < pa_sol_nfield(sol) && st == PA_SUCCESS; k++) {
    pa_sol_kind kind;
    int nc;
    double *val;
    char name[32];
    st = pa_sol_field(sol, k, &kind, &nc, &val);
    snprintf(name, sizeof name, "field%d", k + 1);
    if (st == PA_SUCCESS) st = pa_mesh_add_field(mesh, name, nc, val);
  }
  pa_sol_destroy(sol);
  return st;
}

pa_status pa_cli_write_fields(pa_mesh *mesh, const char *path) {
  pa_sol *sol = NULL;
  int d = pa_mesh_dim(mesh);
  pa_status st = pa_sol_create(d, pa_mesh_nvert(mesh), &sol);
  for (int k = 0; k < pa_mesh_nfield(mesh) && st == PA_SUCCESS; k++) {
    int nc;
    double *val;
    st = pa_mesh_field(mesh, k, NULL, &nc, &val);
    pa_sol_kind kind = nc == 1   ? PA_SOL_SCALAR
                       : nc == d ? PA_SOL_VECTOR
                                 : PA_SOL_TENSOR;
    if (st == PA_SUCCESS) st = pa_sol_add_field(sol, kind, val);
  }
  if (st == PA_SUCCESS) st = pa_sol_write(sol, path);
  pa_sol_destroy(sol);
  return st;
}

int pa_cli_check_outputs(const pa_cli *cli, const char *cmd,
                         const char *const *paths, int n) {
  int bad = 0;
  if (cli->rank == 0) {
    for (int i = 0; i < n && !bad; i++) {
      if (!paths[i]) continue;
      for (int j = 0; j < i && !bad; j++)
        if (paths[j] && !strcmp(paths[i], paths[j]))
          bad = pa_cli_error(cli, "%s: %s is given for two outputs", cmd,
                             paths[i]);
      pa_status st = bad ? PA_SUCCESS : pa_output_check(paths[i]);
      if (st) bad = pa_cli_fail(cli, st);
    }
  }
  MPI_Bcast(&bad, 1, MPI_INT, 0, cli->comm);
  return bad;
}

/* How long the test hook of pa_cli_output_end holds the outputs: long
 * enough for a test under the sanitizers to send its signal, short enough
 * that a forgotten hook only delays a run. */
#define PA_CLI_HOLD_S 30

pa_status pa_cli_output_end(MPI_Comm comm, pa_output *tx, pa_status st) {
  const char *hold = getenv("PADAPT_TEST_HOLD_OUTPUT");
  if (hold && hold[0] && st == PA_SUCCESS) {
    int rank = 0;
    MPI_Comm_rank(comm, &rank);
    if (rank == 0) {
      FILE *fp = fopen(hold, "w");
      if (fp) fclose(fp);
    }
    struct timespec tenth = {0, 100000000};
    for (int i = 0; i < 10 * PA_CLI_HOLD_S; i++) nanosleep(&tenth, NULL);
  }
  return pa_output_end(comm, tx, st);
}

pa_status pa_cli_attach_metric(pa_mesh *mesh, const char *path) {
  pa_sol *sol = NULL;
  pa_status st = pa_sol_read(path, &sol);
  if (st == PA_SUCCESS) st = pa_mesh_metric_from_sol(mesh, sol, 0);
  pa_sol_destroy(sol);
  return st;
}

int pa_cli_adapt_metric(const pa_cli *cli, const pa_cli_adapt_args *a,
                        pa_mesh *mesh) {
  const char *met = a->met;
  pa_status st = PA_SUCCESS;
  if (met == a->met_default && pa_mesh_metric_ncomp(mesh) > 0) {
    if (a->remesh.verbosity >= 0)
      printf("padapt: adapt: metric: the view \"metric\" of %s (not %s)\n",
             a->in, met);
    met = NULL; /* the file's own metric comes first */
  }
  if (a->optim)
    st = pa_mesh_metric_from_edges(mesh);
  else if (met)
    st = pa_cli_attach_metric(mesh, met);
  else if (a->remesh.hsiz <= 0 && pa_mesh_metric_ncomp(mesh) == 0)
    return pa_cli_error(cli, "adapt: no metric: give -met SOL, -sol SOL or "
                             "-hsiz H (%s has no view \"metric\" and no .sol "
                             "beside it)",
                        a->in);
  /* the statistics before the adaptation are taken in the target size */
  if (st == PA_SUCCESS && a->remesh.hsiz > 0 &&
      pa_mesh_metric_ncomp(mesh) == 0) {
    pa_idx nv = pa_mesh_nvert(mesh);
    double *h = malloc(sizeof(double) * (nv ? nv : 1));
    if (!h) return pa_cli_error(cli, "adapt: out of memory");
    for (pa_idx v = 0; v < nv; v++) h[v] = a->remesh.hsiz;
    st = pa_mesh_set_metric(mesh, 1, h);
    free(h);
  }
  return pa_cli_fail(cli, st);
}

pa_status pa_cli_adapt_svg(const pa_cli_adapt_args *a, const pa_stats *before,
                           const pa_stats *after) {
  pa_stats two[2] = {*before, *after};
  const char *names[2] = {"before", "after"};
  char title[1200];
  snprintf(title, sizeof title, "%s -> %s%s%s", a->in, a->out,
           a->met ? ", in the metric " : "", a->met ? a->met : "");
  return pa_cli_svg_histograms(a->svg, title, two, 2, names);
}
