/*
 * padapt.c -- entry point of the padapt command-line tool: MPI start-up,
 * global options, command dispatch, and the basic sequential commands
 * (generate, metric, stats, convert). Heavier commands live in cmd_*.c.
 *
 * Every command returns an exit status; main() makes the ranks agree on it
 * (the maximum) so that `mpiexec` reports a failure on any rank. Commands that
 * work on one sequential mesh run on rank 0 while the other ranks wait.
 *
 * Outputs: every file goes through the library's output transactions; a
 * command writing several files writes them in one (pa_cli_output_end), so
 * they all appear or none does. SIGINT and SIGTERM remove the temporaries
 * being written (pa_output_handle_signals); main() blocks both before MPI
 * starts its threads, so that only the main thread ever runs the handler.
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

static const char *usage_text =
    "usage: padapt [-v N] COMMAND [ARGS]\n"
    "\n"
    "Commands:\n"
    "  generate box2d|box3d N OUT     unit square (n x n x 2 triangles) or cube\n"
    "                                 (n^3 x 6 tetrahedra) with boundary refs\n"
    "  metric NAME[:h] IN OUT.sol     a built-in analytic metric on IN's vertices\n"
    "                                 (uniform layer shell iso-shell\n"
    "                                 ugawg-linear ugawg-polar1 ugawg-polar2)\n"
    "  metric hessian|levelset|intersect|scale|clamp|grade|complexity ...\n"
    "                                 the metric toolbox (padapt metric -h)\n"
    "  levelset NAME IN OUT.sol       signed distance to a sphere, ellipsoid,\n"
    "                                 box or plane on IN's vertices\n"
    "  stats IN [-met SOL] [-json OUT.json] [-svg OUT.svg]\n"
    "                                 counts, volume, edge lengths in the metric,\n"
    "                                 quality, validity (exit 1 if invalid);\n"
    "                                 -svg: their histograms as a picture\n"
    "  convert IN OUT [-met SOL] [-binary] [-meshb-version V] [-diag]\n"
    "                                 formats by extension: .mesh .meshb .msh .vtu\n"
    "                                 (-diag: .vtu cell data edge_min, edge_max)\n"
    "  adapt IN [-met SOL|-sol SOL|-hsiz H] -out OUT [options]\n"
    "                                 adapt the mesh to the metric (see adapt -h)\n"
    "  partition IN -out OUT [-overlap K]\n"
    "                                 write a distributed set OUT.<rank>.meshb\n"
    "  plot IN OUT.svg [-color quality|ref] [-window X0 Y0 X1 Y1] [-cut z=V]\n"
    "                                 picture of a 2D mesh or of a 3D cut\n"
    "                                 (see plot -h)\n"
    "\n"
    "Global options: -v N (verbosity: -1 errors only, 0 the reports (default),\n"
    "1-10 more detail), -h/--help, --version.\n"
    "Meshes: Medit .mesh/.meshb, Gmsh .msh (4.1, 2.2); metrics: .sol/.solb.\n"
    "A mesh that lists no boundary entity gets them all (reference 0) on\n"
    "reading; one that lists some must list them all.\n";

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

int pa_cli_remesh_option(const pa_cli *cli, int argc, char **argv, int *i,
                         pa_remesh_opts *opts) {
  static const struct {
    const char *name;
    int flag; /* 1: a switch, 0: takes a number */
  } known[] = {{"-hsiz", 0},   {"-hmin", 0},    {"-hmax", 0},
               {"-hgrad", 0},  {"-hgradreq", 0}, {"-hausd", 0},
               {"-ar", 0},
               {"-v", 0},      {"-nr", 1},      {"-noinsert", 1},
               {"-noswap", 1}, {"-nomove", 1},  {"-nosurf", 1}};
  const char *a = argv[*i];
  size_t k = 0, nk = sizeof known / sizeof *known;
  while (k < nk && strcmp(a, known[k].name)) k++;
  if (k == nk) return 0;
  if (known[k].flag) {
    if (!strcmp(a, "-nr")) opts->no_angle = 1;
    if (!strcmp(a, "-noinsert")) opts->no_insert = 1;
    if (!strcmp(a, "-noswap")) opts->no_swap = 1;
    if (!strcmp(a, "-nomove")) opts->no_move = 1;
    if (!strcmp(a, "-nosurf")) opts->no_surf = 1;
    return 1;
  }
  double x;
  const char *val = *i + 1 < argc ? argv[*i + 1] : NULL;
  int ok = pa_cli_parse_num(val, &x);
  const char *want = "a positive number";
  if (!strcmp(a, "-hgrad") || !strcmp(a, "-hgradreq")) {
    want = "a number (> 1; -1 or any value <= 1 disables)";
  } else if (!strcmp(a, "-ar")) {
    want = "an angle in [0, 180] degrees";
    ok = ok && x >= 0 && x <= 180;
  } else if (!strcmp(a, "-v")) {
    want = "a verbosity level in [-1, 10]";
    ok = ok && x >= -1 && x <= 10 && x == floor(x);
  } else {
    ok = ok && x > 0;
  }
  if (!ok) {
    pa_cli_error(cli, "adapt: %s needs %s, got '%s'", a, want,
                 val ? val : "nothing");
    return -1;
  }
  (*i)++;
  if (!strcmp(a, "-hsiz")) opts->hsiz = x;
  if (!strcmp(a, "-hmin")) opts->hmin = x;
  if (!strcmp(a, "-hmax")) opts->hmax = x;
  if (!strcmp(a, "-hgrad")) opts->hgrad = x;
  if (!strcmp(a, "-hgradreq")) opts->hgradreq = x;
  if (!strcmp(a, "-hausd")) opts->hausd = x;
  if (!strcmp(a, "-ar")) opts->angle = x;
  if (!strcmp(a, "-v")) {
    opts->verbosity = (int)x;
    pa_cli_set_verbosity((int)x);
  }
  return 1;
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

/* Report a failed read on rank 0 (the other ranks return quietly). */
static int read_failed(const pa_cli *cli, pa_status st) {
  return cli->rank == 0 ? pa_cli_fail(cli, st) : 1;
}

pa_status pa_cli_attach_metric(pa_mesh *mesh, const char *path) {
  pa_sol *sol = NULL;
  pa_status st = pa_sol_read(path, &sol);
  if (st == PA_SUCCESS) st = pa_mesh_metric_from_sol(mesh, sol, 0);
  pa_sol_destroy(sol);
  return st;
}

static const char *generate_usage =
    "usage: padapt generate box2d|box3d N OUT\n"
    "  box2d N      unit square, n x n x 2 triangles; boundary refs x=0:1\n"
    "               x=1:2 y=0:3 y=1:4, element ref 1\n"
    "  box3d N      unit cube, n^3 x 6 tetrahedra; boundary refs as box2d,\n"
    "               z=0:5 z=1:6\n"
    "  N            1 to 2000; OUT: .mesh .meshb .msh .vtu\n";

int pa_cli_generate(const pa_cli *cli, int argc, char **argv) {
  if (argc == 2 && (!strcmp(argv[1], "-h") || !strcmp(argv[1], "--help"))) {
    if (cli->rank == 0) fputs(generate_usage, stdout);
    return 0;
  }
  if (argc != 4)
    return pa_cli_error(cli, "usage: padapt generate box2d|box3d N OUT");
  int dim = !strcmp(argv[1], "box2d") ? 2 : !strcmp(argv[1], "box3d") ? 3 : 0;
  if (!dim)
    return pa_cli_error(cli, "generate: unknown shape '%s' (box2d or box3d)",
                        argv[1]);
  char *end;
  long n = strtol(argv[2], &end, 10);
  if (*end || n < 1 || n > 2000)
    return pa_cli_error(cli, "generate: N must be an integer in [1, 2000], "
                             "got '%s'", argv[2]);
  if (cli->rank != 0) return 0;
  pa_mesh *mesh = NULL;
  pa_status st = pa_mesh_generate_box(dim, (int)n, &mesh);
  if (st == PA_SUCCESS) st = pa_mesh_write(mesh, argv[3], NULL);
  if (st == PA_SUCCESS && cli->verbosity >= 1)
    printf("%s: %d vertices, %d elements, %d boundary entities\n", argv[3],
           (int)pa_mesh_nvert(mesh), (int)pa_mesh_nelem(mesh),
           (int)pa_mesh_nbdry(mesh));
  pa_mesh_destroy(mesh);
  return pa_cli_fail(cli, st);
}

static const char *stats_usage =
    "usage: padapt stats IN [-met SOL] [-json OUT.json] [-svg OUT.svg]\n"
    "  IN             mesh file, or distributed set OUT.meshb (OUT.<r>.meshb)\n"
    "  -met/-sol SOL  measure edge lengths and qualities in this metric\n"
    "                 (default: the unit metric)\n"
    "  -json OUT.json write the statistics as JSON\n"
    "  -svg OUT.svg   draw the edge-length and quality histograms\n"
    "Exit status: 0 valid mesh; 1 invalid mesh (the message names the\n"
    "entity) or error.\n";

int pa_cli_stats(const pa_cli *cli, int argc, char **argv) {
  const char *in = NULL, *met = NULL, *json = NULL, *svg = NULL;
  for (int i = 1; i < argc; i++) {
    if (!strcmp(argv[i], "-h") || !strcmp(argv[i], "--help")) {
      if (cli->rank == 0) fputs(stats_usage, stdout);
      return 0;
    } else if (!strcmp(argv[i], "-met") || !strcmp(argv[i], "-sol")) {
      if (++i >= argc) return pa_cli_error(cli, "stats: -met needs a file");
      met = argv[i];
    } else if (!strcmp(argv[i], "-json")) {
      if (++i >= argc) return pa_cli_error(cli, "stats: -json needs a file");
      json = argv[i];
    } else if (!strcmp(argv[i], "-svg")) {
      if (++i >= argc) return pa_cli_error(cli, "stats: -svg needs a file");
      svg = argv[i];
      if (!pa_cli_is_svg(svg))
        return pa_cli_error(cli, "stats: %s: only SVG pictures are written "
                                 "(.svg); convert with e.g. rsvg-convert",
                            svg);
    } else if (argv[i][0] == '-' && argv[i][1]) {
      return pa_cli_error(cli, "stats: unknown option '%s'", argv[i]);
    } else if (!in) {
      in = argv[i];
    } else {
      return pa_cli_error(cli, "stats: more than one input ('%s')", argv[i]);
    }
  }
  if (!in)
    return pa_cli_error(cli, "usage: padapt stats IN [-met SOL] "
                             "[-json OUT.json] [-svg OUT.svg]");
  const char *outs[2] = {json, svg};
  if (pa_cli_check_outputs(cli, "stats", outs, 2)) return 1;
  pa_mesh *mesh = NULL;
  pa_stats stats;
  int valid = 1;
  /* Read without the validity check so that an invalid mesh is still
   * reported; the check result is part of the statistics. */
  int is_set = cli->rank == 0 ? pa_dmesh_is_set(in) : 0;
  MPI_Bcast(&is_set, 1, MPI_INT, 0, cli->comm);
  pa_status st = PA_SUCCESS;
  if (is_set)
    st = pa_dmesh_read_gathered(cli->comm, 0, in, &mesh);
  else if (cli->rank == 0)
    st = pa_mesh_read(in, &mesh);
  if (cli->rank != 0) return st ? 1 : 0;
  if (st == PA_SUCCESS && pa_mesh_nbdry(mesh) == 0) {
    pa_idx nadded = 0;
    if (pa_mesh_build_boundary(mesh, 0, &nadded) != PA_SUCCESS) pa_clear_error();
  }
  if (st == PA_SUCCESS && met) st = pa_cli_attach_metric(mesh, met);
  if (st == PA_SUCCESS) st = pa_mesh_stats(mesh, &stats);
  if (st == PA_SUCCESS) {
    pa_stats_print(&stats, stdout);
    fflush(stdout);
    /* both outputs or neither */
    pa_output *tx = NULL;
    st = pa_output_begin(&tx);
    if (st == PA_SUCCESS && json) st = pa_stats_write_json(&stats, NULL, json);
    if (st == PA_SUCCESS && svg) {
      char title[1200];
      snprintf(title, sizeof title, "%s%s%s", in, met ? " in the metric " : "",
               met ? met : "");
      st = pa_cli_svg_histograms(svg, title, &stats, 1, NULL);
    }
    st = pa_cli_output_end(MPI_COMM_SELF, tx, st);
  }
  if (st == PA_SUCCESS && !stats.valid) {
    valid = 0;
    pa_mesh_check(mesh); /* recover the message naming the entity */
    pa_cli_error(cli, "%s: %s", in, pa_last_error());
  }
  pa_mesh_destroy(mesh);
  if (st != PA_SUCCESS) return pa_cli_fail(cli, st);
  return valid ? 0 : 1;
}

static const char *convert_usage =
    "usage: padapt convert IN OUT [-met SOL] [-binary] [-meshb-version V]\n"
    "                     [-diag]\n"
    "  IN                 .mesh .meshb .msh, or distributed set OUT.meshb\n"
    "  OUT                format by extension: .mesh .meshb .msh .vtu\n"
    "  -met/-sol SOL      check this metric and write it as the point data\n"
    "                     \"metric\" and \"size\" of a .vtu (the other\n"
    "                     formats keep no metric)\n"
    "  -binary            binary Gmsh .msh (default ASCII)\n"
    "  -meshb-version V   .meshb file version 1-4 (default 2; 3 when the\n"
    "                     file needs 64-bit positions)\n"
    "  -diag              .vtu: the cell data edge_min and edge_max, each\n"
    "                     element's extreme edge lengths in the metric\n";

int pa_cli_convert(const pa_cli *cli, int argc, char **argv) {
  const char *in = NULL, *out = NULL, *met = NULL;
  pa_write_opts opts = {0, 0, 0};
  for (int i = 1; i < argc; i++) {
    if (!strcmp(argv[i], "-h") || !strcmp(argv[i], "--help")) {
      if (cli->rank == 0) fputs(convert_usage, stdout);
      return 0;
    } else if (!strcmp(argv[i], "-met") || !strcmp(argv[i], "-sol")) {
      if (++i >= argc) return pa_cli_error(cli, "convert: -met needs a file");
      met = argv[i];
    } else if (!strcmp(argv[i], "-binary")) {
      opts.binary = 1;
    } else if (!strcmp(argv[i], "-diag")) {
      opts.diagnostics = 1;
    } else if (!strcmp(argv[i], "-meshb-version")) {
      if (++i >= argc || atoi(argv[i]) < 1 || atoi(argv[i]) > 4)
        return pa_cli_error(cli, "convert: -meshb-version needs 1, 2, 3 or 4");
      opts.version = atoi(argv[i]);
    } else if (argv[i][0] == '-' && argv[i][1]) {
      return pa_cli_error(cli, "convert: unknown option '%s'", argv[i]);
    } else if (!in) {
      in = argv[i];
    } else if (!out) {
      out = argv[i];
    } else {
      return pa_cli_error(cli, "convert: too many arguments ('%s')", argv[i]);
    }
  }
  if (!in || !out)
    return pa_cli_error(cli, "usage: padapt convert IN OUT [-met SOL] "
                             "[-binary] [-meshb-version V] [-diag]");
  pa_mesh *mesh = NULL;
  pa_status st = pa_cli_read_mesh(cli, in, &mesh);
  if (st != PA_SUCCESS) return read_failed(cli, st);
  if (cli->rank != 0) return 0;
  if (met) st = pa_cli_attach_metric(mesh, met);
  if (st == PA_SUCCESS) st = pa_mesh_write(mesh, out, &opts);
  pa_mesh_destroy(mesh);
  return pa_cli_fail(cli, st);
}

typedef int (*pa_cli_cmd)(const pa_cli *, int, char **);

static const struct {
  const char *name;
  pa_cli_cmd run;
} commands[] = {{"generate", pa_cli_generate}, {"metric", pa_cli_metric},
                {"levelset", pa_cli_levelset}, {"stats", pa_cli_stats},
                {"convert", pa_cli_convert},   {"adapt", pa_cli_adapt},
                {"partition", pa_cli_partition}, {"plot", pa_cli_plot}};

/* padapt's version, and the MPI library's, as they run. */
static void print_version(void) {
  char mpi[MPI_MAX_LIBRARY_VERSION_STRING];
  int n = 0;
  MPI_Get_library_version(mpi, &n);
  mpi[strcspn(mpi, "\n,")] = '\0';
  printf("padapt %s (header %d.%d.%d)\nMPI: %s\n", pa_version(),
         PADAPT_VERSION_MAJOR, PADAPT_VERSION_MINOR, PADAPT_VERSION_PATCH, mpi);
}

static int dispatch(pa_cli *cli, int argc, char **argv) {
  int i = 1;
  while (i < argc && argv[i][0] == '-') {
    if (!strcmp(argv[i], "-h") || !strcmp(argv[i], "--help")) {
      if (cli->rank == 0) fputs(usage_text, stdout);
      return 0;
    } else if (!strcmp(argv[i], "--version") || !strcmp(argv[i], "-version")) {
      if (cli->rank == 0) print_version();
      return 0;
    } else if (!strcmp(argv[i], "-v") && i + 1 < argc) {
      double v;
      if (!pa_cli_parse_num(argv[i + 1], &v) || v < -1 || v > 10 ||
          v != floor(v))
        return pa_cli_error(cli, "-v needs a verbosity level in [-1, 10], "
                                 "got '%s'", argv[i + 1]);
      cli->verbosity = (int)v;
      i += 2;
    } else {
      break;
    }
  }
  pa_cli_set_verbosity(cli->verbosity);
  if (i >= argc) {
    if (cli->rank == 0) fputs(usage_text, stderr);
    return 1;
  }
  /* Mmg-style invocation: `padapt -in IN ...` means `padapt adapt -in IN`. */
  if (!strcmp(argv[i], "-in")) return pa_cli_adapt(cli, argc - i + 1, argv + i - 1);
  for (size_t k = 0; k < sizeof commands / sizeof *commands; k++)
    if (!strcmp(argv[i], commands[k].name))
      return commands[k].run(cli, argc - i, argv + i);
  if (cli->rank == 0)
    pa_cli_error(cli, "unknown command '%s' (try padapt --help)", argv[i]);
  return 1;
}

int main(int argc, char **argv) {
  int provided = 0;
  sigset_t term, old;
  sigemptyset(&term);
  sigaddset(&term, SIGINT);
  sigaddset(&term, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &term, &old); /* inherited by MPI's threads */
  if (MPI_Init_thread(&argc, &argv, MPI_THREAD_MULTIPLE, &provided) !=
      MPI_SUCCESS) {
    fprintf(stderr, "padapt: MPI initialisation failed\n");
    return 1;
  }
  if (pa_output_handle_signals() != PA_SUCCESS)
    fprintf(stderr, "padapt: warning: %s\n", pa_last_error());
  pthread_sigmask(SIG_SETMASK, &old, NULL);
  pa_cli cli = {MPI_COMM_WORLD, 0, 1, 0};
  MPI_Comm_rank(cli.comm, &cli.rank);
  MPI_Comm_size(cli.comm, &cli.size);
  {
    /* test hook: fail the k-th allocation of padapt's allocator, on every
     * rank or on rank PADAPT_TEST_FAIL_RANK only (fault injection,
     * tests/cli/test_alloc_faults.sh) */
    const char *k = getenv("PADAPT_TEST_FAIL_ALLOC");
    const char *r = getenv("PADAPT_TEST_FAIL_RANK");
    if (k && k[0] && (!r || !r[0] || atoi(r) == cli.rank))
      pa_memory_fail_after(atol(k));
  }
  int rc = dispatch(&cli, argc, argv);
  int all = rc;
  MPI_Allreduce(&rc, &all, 1, MPI_INT, MPI_MAX, cli.comm);
  MPI_Finalize();
  return all;
}
