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
#include <signal.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <time.h>
#include <unistd.h>

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

/* Drop the boundary entities listed twice (the first listing stays, with
 * its reference): *ndropped of them, *nref of which had another reference. */
static pa_status drop_duplicates(pa_mesh *mesh, pa_idx *ndropped,
                                 pa_idx *nref) {
  pa_status st = PA_SUCCESS;
  const int d = pa_mesh_dim(mesh);
  pa_idx nb = pa_mesh_nbdry(mesh), w = 0;
  *ndropped = *nref = 0;
  for (pa_idx b = 0; b < nb && st == PA_SUCCESS; b++) {
    pa_idx first = b;
    st = pa_mesh_find_bdry(mesh, pa_mesh_bdrys(mesh) + (size_t)d * b, &first);
    if (first >= 0 && first != b) {
      (*ndropped)++;
      if (pa_mesh_bdry_refs(mesh)[first] != pa_mesh_bdry_refs(mesh)[b]) (*nref)++;
    }
  }
  if (st != PA_SUCCESS || *ndropped == 0) return st;
  /* compact: the lookup answers from the list as it was, so decide first */
  uint8_t *keep = malloc((size_t)nb);
  if (!keep) return pa_set_error(PA_ERR_MEMORY, "out of memory");
  for (pa_idx b = 0; b < nb && st == PA_SUCCESS; b++) {
    pa_idx first = b;
    st = pa_mesh_find_bdry(mesh, pa_mesh_bdrys(mesh) + (size_t)d * b, &first);
    keep[b] = first == b;
  }
  pa_idx *v = pa_mesh_bdrys(mesh);
  int32_t *ref = pa_mesh_bdry_refs(mesh);
  uint8_t *flag = pa_mesh_bdry_flags(mesh);
  for (pa_idx b = 0; b < nb && st == PA_SUCCESS; b++) {
    if (!keep[b]) continue;
    memmove(v + (size_t)d * w, v + (size_t)d * b, sizeof *v * (size_t)d);
    ref[w] = ref[b];
    flag[w] = flag[b];
    w++;
  }
  free(keep);
  pa_mesh_invalidate(mesh);
  if (st == PA_SUCCESS)
    st = pa_mesh_resize(mesh, pa_mesh_nvert(mesh), pa_mesh_nelem(mesh), w,
                        pa_mesh_nedge(mesh));
  return st;
}

pa_status pa_cli_complete_boundary(const pa_cli *cli, const char *path,
                                   pa_mesh *mesh) {
  pa_idx nadded = 0, ndropped = 0, nref = 0;
  const char *what = pa_mesh_dim(mesh) == 2 ? "edges" : "triangles";
  pa_status st = drop_duplicates(mesh, &ndropped, &nref);
  if (st == PA_SUCCESS && ndropped > 0 && cli->verbosity >= 1)
    fprintf(stderr, "padapt: %s: %d boundary %s listed twice: kept the first "
                    "listing%s\n",
            path, (int)ndropped, what,
            nref ? " (its reference; the second gave another)" : "");
  pa_idx nlisted = pa_mesh_nbdry(mesh);
  if (st == PA_SUCCESS)
    st = pa_mesh_build_boundary(mesh, PA_CLI_BOUNDARY_REF, &nadded);
  if (st == PA_SUCCESS && nadded > 0 && cli->verbosity >= 1) {
    if (nlisted == 0)
      fprintf(stderr, "padapt: %s: lists no boundary %s: added all %d "
                      "(reference %d)\n",
              path, what, (int)nadded, PA_CLI_BOUNDARY_REF);
    else
      fprintf(stderr, "padapt: %s: lists %d of its %d boundary %s: added "
                      "the %d missing (reference %d), kept the others' "
                      "references\n",
              path, (int)nlisted, (int)(nlisted + nadded), what, (int)nadded,
              PA_CLI_BOUNDARY_REF);
  }
  return st;
}

pa_status pa_cli_read_mesh(const pa_cli *cli, const char *path,
                           pa_mesh **mesh) {
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
  st = pa_cli_complete_boundary(cli, path, *mesh);
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

char *pa_cli_transfer_json(const pa_transfer_report *t) {
  pa_cli_sbuf b = {NULL, 0, 0, 0};
  pa_cli_sb_printf(&b,
                   "\"transfer\": {\"nfield\": %d, \"nfast\": %ld, \"nclip\": %ld, "
                   "\"nout\": %ld, \"defect\": %.6g, \"uncovered\": %.6g, "
                   "\"lost\": %.6g, \"time_s\": %.6f, \"cpu_s\": %.6f}, ",
                   t->nfield, t->nfast, t->nclip, t->nout, t->defect,
                   t->uncovered, t->lost, t->time_s, t->cpu_s);
  if (b.fail) {
    free(b.p);
    return NULL;
  }
  return b.p;
}

void pa_cli_print_transfer(const pa_transfer_report *t) {
  if (!t->nfield) return;
  printf("    fields carried %d: %ld elements inside an old one, %ld "
         "intersected, conservation defect %.2e, %.3f s\n",
         t->nfield, t->nfast, t->nclip, t->defect, t->time_s);
}

int pa_cli_has_fields(const pa_mesh *mesh) {
  return pa_mesh_nfield_at(mesh, PA_VERTEX) + pa_mesh_nfield_at(mesh, PA_ELEMENT) +
             pa_mesh_nfield_at(mesh, PA_BOUNDARY) > 0;
}

/* The names of the fields of mesh on entities at, ", "-separated, into buf. */
static void field_names(pa_mesh *mesh, pa_entity at, char *buf, size_t n) {
  size_t len = 0;
  buf[0] = '\0';
  for (int k = 0; k < pa_mesh_nfield_at(mesh, at) && len < n; k++) {
    const char *name = "";
    pa_mesh_field_at(mesh, at, k, &name, NULL, NULL);
    len += (size_t)snprintf(buf + len, n - len, "%s%s", k ? ", " : "", name);
  }
}

/* One -field-transfer choice, [NAME=]MODE, set on the mesh's fields. */
static pa_status apply_transfer(pa_mesh *mesh, const char *spec) {
  const char *eq = strchr(spec, '=');
  pa_transfer mode;
  pa_status st = pa_transfer_parse(eq ? eq + 1 : spec, &mode);
  if (st != PA_SUCCESS || !eq) {
    for (int k = 0; st == PA_SUCCESS && k < pa_mesh_nfield_at(mesh, PA_ELEMENT); k++)
      st = pa_mesh_set_field_transfer(mesh, PA_ELEMENT, k, mode);
    return st;
  }
  char name[256];
  snprintf(name, sizeof name, "%.*s", (int)(eq - spec), spec);
  static const pa_entity order[3] = {PA_ELEMENT, PA_BOUNDARY, PA_VERTEX};
  for (int i = 0; i < 3; i++) {
    int k = pa_mesh_field_index(mesh, order[i], name);
    if (k >= 0) return pa_mesh_set_field_transfer(mesh, order[i], k, mode);
  }
  char list[3][1024];
  for (int i = 0; i < 3; i++) field_names(mesh, order[i], list[i], sizeof list[i]);
  return pa_set_error(PA_ERR_ARG,
                      "-field-transfer %s: no field '%s' (element fields: %s; "
                      "boundary fields: %s; vertex fields: %s)",
                      spec, name, list[0][0] ? list[0] : "none",
                      list[1][0] ? list[1] : "none", list[2][0] ? list[2] : "none");
}

pa_status pa_cli_attach_fields(pa_mesh *mesh, const pa_cli_adapt_args *a) {
  pa_status st = PA_SUCCESS;
  for (int f = 0; f < a->nfield && st == PA_SUCCESS; f++) {
    pa_sol *sol = NULL;
    st = pa_sol_read(a->field[f], &sol);
    if (st == PA_SUCCESS) st = pa_mesh_fields_from_sol(mesh, sol);
    pa_sol_destroy(sol);
  }
  for (int t = 0; t < a->ntransfer && st == PA_SUCCESS; t++)
    st = apply_transfer(mesh, a->transfer[t]);
  return st;
}

pa_status pa_cli_write_fields(pa_mesh *mesh, const char *path) {
  pa_sol *sol = NULL;
  pa_status st = pa_mesh_fields_to_sol(mesh, &sol);
  if (st == PA_SUCCESS) st = pa_sol_write(sol, path);
  pa_sol_destroy(sol);
  return st;
}

pa_status pa_cli_output_end(MPI_Comm comm, pa_output *tx, pa_status st) {
  st = pa_output_end(comm, tx, st);
  int sig = pa_output_held_signal();
  if (sig)
    fprintf(stderr, "padapt: %s arrived while the outputs were committed: "
                    "they are complete; the command ends normally\n",
            sig == SIGINT ? "SIGINT" : "SIGTERM");
  return st;
}

/* How long the test hook PADAPT_TEST_PAUSE holds a process: long enough for
 * a test under the sanitizers to act, short enough that a forgotten hook
 * only delays a run. */
#define PA_CLI_PAUSE_S 30

/* The test hook's settings: pause at step on rank, after writing the
 * process id into flag. */
typedef struct pause_hook {
  const char *step, *flag;
  int rank;
} pause_hook;

static void pause_at(const char *step, void *ctx) {
  const pause_hook *h = ctx;
  if (strcmp(step, h->step)) return;
  FILE *fp = fopen(h->flag, "w");
  if (fp) {
    fprintf(fp, "%ld\n", (long)getpid());
    fclose(fp);
  }
  /* until a signal comes: at once if it acts, else (blocked while the
   * outputs are committed) when it is pending */
  sigset_t term, pend;
  sigemptyset(&term);
  sigaddset(&term, SIGINT);
  sigaddset(&term, SIGTERM);
  struct timespec tenth = {0, 100000000};
  for (int i = 0; i < 10 * PA_CLI_PAUSE_S; i++) {
    if (sigpending(&pend) == 0 &&
        (sigismember(&pend, SIGINT) || sigismember(&pend, SIGTERM)))
      break;
    nanosleep(&tenth, NULL);
  }
}

void pa_cli_test_hooks(const pa_cli *cli) {
  static pause_hook h;
  const char *step = getenv("PADAPT_TEST_PAUSE");
  const char *rank = getenv("PADAPT_TEST_PAUSE_RANK");
  h.step = step;
  h.flag = getenv("PADAPT_TEST_PAUSE_FLAG");
  h.rank = rank && rank[0] ? atoi(rank) : 0;
  if (step && step[0] && h.flag && h.flag[0] && h.rank == cli->rank)
    pa_output_set_hook(pause_at, &h);
  /* fail the k-th allocation of padapt's allocator, on every rank or on
   * rank PADAPT_TEST_FAIL_RANK only */
  const char *k = getenv("PADAPT_TEST_FAIL_ALLOC");
  const char *r = getenv("PADAPT_TEST_FAIL_RANK");
  if (k && k[0] && (!r || !r[0] || atoi(r) == cli->rank))
    pa_memory_fail_after(atol(k));
}

pa_status pa_cli_attach_metric(pa_mesh *mesh, const char *path) {
  pa_sol *sol = NULL;
  pa_status st = pa_sol_read(path, &sol);
  /* one solution, the metric: Mmg refuses several too, rather than guess */
  if (st == PA_SUCCESS && pa_sol_nfield(sol) > 1)
    st = pa_set_error(PA_ERR_FORMAT,
                      "%s: holds %d solutions, not one: a metric file holds "
                      "the metric alone (write it to a file of its own; "
                      "-field takes files of several)",
                      pa_sol_origin(sol), pa_sol_nfield(sol));
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
