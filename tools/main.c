/*
 * main.c -- entry point of the padapt command-line tool: MPI start-up,
 * global options, command dispatch, and the basic sequential commands
 * (generate, stats, convert). Heavier commands live in cmd_*.c, the helpers
 * they share in cli_util.c; each command reads its arguments by its option
 * table (cli_opts.c), which its -h prints.
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
#include <stddef.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#ifdef __GLIBC__
#include <malloc.h>
#endif

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
    "The boundary entities a mesh does not list are added on reading\n"
    "(reference 0), as Mmg does; the listed ones keep theirs.\n";

/* Report a failed read on rank 0 (the other ranks return quietly). */
static int read_failed(const pa_cli *cli, pa_status st) {
  return cli->rank == 0 ? pa_cli_fail(cli, st) : 1;
}

/* `padapt generate` takes no option: its table is its arguments' help. */
static const pa_cli_opt generate_opts[] = {
    {.kind = PA_CLI_HELP, .label = "box2d N",
     .help = "unit square, n x n x 2 triangles; boundary refs x=0:1\n"
             "x=1:2 y=0:3 y=1:4, element ref 1"},
    {.kind = PA_CLI_HELP, .label = "box3d N",
     .help = "unit cube, n^3 x 6 tetrahedra; boundary refs as box2d,\n"
             "z=0:5 z=1:6"},
    {.kind = PA_CLI_HELP, .label = "N",
     .help = "1 to 2000; OUT: .mesh .meshb .msh .vtu"},
    {.kind = PA_CLI_END}};

static const pa_cli_spec generate_spec = {
    .cmd = "generate",
    .usage = "usage: padapt generate box2d|box3d N OUT\n",
    .width = 13,
    .opt = generate_opts};

int pa_cli_generate(const pa_cli *cli, int argc, char **argv) {
  if (argc == 2 && (!strcmp(argv[1], "-h") || !strcmp(argv[1], "--help"))) {
    if (cli->rank == 0) pa_cli_help(&generate_spec, stdout);
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

/* The arguments of `padapt stats`. */
typedef struct stats_args {
  const char *in, *met, *json, *svg;
} stats_args;

#define S(f) offsetof(stats_args, f)

static const pa_cli_opt stats_opts[] = {
    {.kind = PA_CLI_HELP, .label = "IN",
     .help = "mesh file, or distributed set OUT.meshb (OUT.<r>.meshb)"},
    {.names = "-met -sol", .kind = PA_CLI_STR, .at = S(met),
     .want = "a .sol file", .label = "-met/-sol SOL",
     .help = "measure edge lengths and qualities in this metric\n"
             "(default: the unit metric)"},
    {.names = "-json", .kind = PA_CLI_STR, .at = S(json), .want = "a file",
     .label = "-json OUT.json", .help = "write the statistics as JSON"},
    {.names = "-svg", .kind = PA_CLI_STR, .at = S(svg), .want = "an .svg file",
     .label = "-svg OUT.svg",
     .help = "draw the edge-length and quality histograms"},
    {.kind = PA_CLI_END}};

static int stats_positional(const pa_cli *cli, const char *arg, void *args) {
  stats_args *a = args;
  if (a->in)
    return pa_cli_error(cli, "stats: more than one input ('%s')", arg);
  a->in = arg;
  return 0;
}

static const pa_cli_spec stats_spec = {
    .cmd = "stats",
    .usage = "usage: padapt stats IN [-met SOL] [-json OUT.json] [-svg "
             "OUT.svg]\n",
    .width = 15,
    .opt = stats_opts,
    .tail = "Exit status: 0 valid mesh; 1 invalid mesh (the message names "
            "the\n"
            "entity) or error.\n",
    .positional = stats_positional};

int pa_cli_stats(const pa_cli *cli, int argc, char **argv) {
  stats_args args = {NULL, NULL, NULL, NULL};
  int prc = pa_cli_parse(cli, &stats_spec, argc, argv, &args);
  if (prc) return prc > 0 ? 1 : 0;
  const char *in = args.in, *met = args.met, *json = args.json;
  const char *svg = args.svg;
  if (svg && !pa_cli_is_svg(svg))
    return pa_cli_error(cli, "stats: %s: only SVG pictures are written "
                             "(.svg); convert with e.g. rsvg-convert",
                        svg);
  if (!in)
    return pa_cli_error(cli, "usage: padapt stats IN [-met SOL] "
                             "[-json OUT.json] [-svg OUT.svg]");
  pa_cli_io io = {.in = {in, met}, .out = {json, svg}};
  if (pa_cli_check_io(cli, "stats", &io)) return 1;
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
  if (st == PA_SUCCESS && pa_cli_complete_boundary(cli, in, mesh) != PA_SUCCESS)
    pa_clear_error(); /* the check below reports it */
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

/* The arguments of `padapt convert`. */
typedef struct convert_args {
  const char *in, *out, *met;
  pa_write_opts opts;
} convert_args;

#define C(f) offsetof(convert_args, f)

static const pa_cli_opt convert_opts[] = {
    {.kind = PA_CLI_HELP, .label = "IN",
     .help = ".mesh .meshb .msh, or distributed set OUT.meshb"},
    {.kind = PA_CLI_HELP, .label = "OUT",
     .help = "format by extension: .mesh .meshb .msh .vtu"},
    {.names = "-met -sol", .kind = PA_CLI_STR, .at = C(met),
     .want = "a .sol file", .label = "-met/-sol SOL",
     .help = "check this metric and write it as the point data\n"
             "\"metric\" and \"size\" of a .vtu (the other\n"
             "formats keep no metric)"},
    {.names = "-binary", .kind = PA_CLI_FLAG, .at = C(opts.binary),
     .label = "-binary", .help = "binary Gmsh .msh (default ASCII)"},
    {.names = "-meshb-version", .kind = PA_CLI_INT, .at = C(opts.version),
     .want = "1, 2, 3 or 4", .lo = 1, .hi = 4, .label = "-meshb-version V",
     .help = ".meshb file version 1-4 (default 2; 3 when the\n"
             "file needs 64-bit positions)"},
    {.names = "-diag", .kind = PA_CLI_FLAG, .at = C(opts.diagnostics),
     .label = "-diag",
     .help = ".vtu: the cell data edge_min and edge_max, each\n"
             "element's extreme edge lengths in the metric"},
    {.kind = PA_CLI_END}};

static int convert_positional(const pa_cli *cli, const char *arg,
                              void *args) {
  convert_args *a = args;
  if (a->in && a->out)
    return pa_cli_error(cli, "convert: too many arguments ('%s')", arg);
  *(a->in ? &a->out : &a->in) = arg;
  return 0;
}

static const pa_cli_spec convert_spec = {
    .cmd = "convert",
    .usage = "usage: padapt convert IN OUT [-met SOL] [-binary] "
             "[-meshb-version V]\n"
             "                     [-diag]\n",
    .width = 19,
    .opt = convert_opts,
    .positional = convert_positional};

int pa_cli_convert(const pa_cli *cli, int argc, char **argv) {
  convert_args args;
  memset(&args, 0, sizeof args);
  int prc = pa_cli_parse(cli, &convert_spec, argc, argv, &args);
  if (prc) return prc > 0 ? 1 : 0;
  const char *in = args.in, *out = args.out, *met = args.met;
  pa_write_opts opts = args.opts;
  if (!in || !out)
    return pa_cli_error(cli, "usage: padapt convert IN OUT [-met SOL] "
                             "[-binary] [-meshb-version V] [-diag]");
  pa_cli_io io = {.in = {in, met}, .out = {out}};
  if (pa_cli_check_io(cli, "convert", &io)) return 1;
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

/* The base of an isolated singleton's Open MPI session directory, its own:
 * every isolated singleton takes the same job name, so under a shared base
 * they share one session directory, which the first to end removes while
 * the others use it (3 to 7 % of 60 concurrent `padapt stats` failed in
 * MPI_Init). A fresh directory under $TMPDIR (or /tmp), unless the user
 * chose a base (OMPI_MCA_orte_tmpdir_base); Open MPI empties it at
 * MPI_Finalize and the exit removes it. */
static char session_base[4096];

static void remove_session_base(void) {
  if (session_base[0]) rmdir(session_base);
}

static void own_session_base(void) {
  const char *tmp = getenv("TMPDIR");
  if (getenv("OMPI_MCA_orte_tmpdir_base")) return;
  int n = snprintf(session_base, sizeof session_base, "%s/padapt-mpi.XXXXXX",
                   tmp && tmp[0] ? tmp : "/tmp");
  if (n < 0 || (size_t)n >= sizeof session_base || !mkdtemp(session_base)) {
    session_base[0] = '\0'; /* Open MPI's shared base, as without this */
    return;
  }
  setenv("OMPI_MCA_orte_tmpdir_base", session_base, 1);
  atexit(remove_session_base);
}

/* Open MPI's start-up defaults, set before MPI_Init. A process that no
 * launcher started (no mpiexec or srun: no OMPI_COMM_WORLD_SIZE, PMIX_RANK
 * or PMI_RANK) is a singleton: it runs isolated (no runtime daemon forked
 * for it) with the ob1 messaging layer. Ranks that mpiexec placed on one
 * node get ob1 too. Left alone, Open MPI probes every messaging component
 * and a singleton forks a daemon: 0.40 s of start and 0.05 s of end per
 * command on the development VM, against 0.05 s and 0.006 s. A setting in
 * the environment wins over these defaults. Returns what was set, for
 * -v 2. */
static const char *mpi_start_defaults(void) {
  const char *ws = getenv("OMPI_COMM_WORLD_SIZE");
  const char *ls = getenv("OMPI_COMM_WORLD_LOCAL_SIZE");
  const char *pml = getenv("OMPI_MCA_pml");
  if (!ws && !getenv("PMIX_RANK") && !getenv("PMI_RANK")) {
    int iso = !getenv("OMPI_MCA_ess_singleton_isolated");
    setenv("OMPI_MCA_ess_singleton_isolated", "1", 0);
    setenv("OMPI_MCA_pml", "ob1", 0);
    if (!strcmp(getenv("OMPI_MCA_ess_singleton_isolated"), "1"))
      own_session_base();
    return iso && !pml ? "one process: isolated singleton, pml ob1"
           : iso       ? "one process: isolated singleton, the user's pml"
           : !pml      ? "one process: the user's singleton setting, pml ob1"
                       : "one process: the user's settings";
  }
  if (ws && ls && !strcmp(ws, ls)) {
    setenv("OMPI_MCA_pml", "ob1", 0);
    return pml ? "ranks on one node: the user's pml" : "ranks on one node: pml ob1";
  }
  return "ranks on several nodes: Open MPI's defaults";
}

/* On several processes, glibc keeps freed blocks of up to 32 MiB for reuse
 * (M_MMAP_THRESHOLD: the most its own sliding threshold reaches; memory
 * above twice that at the top of the heap goes back to the kernel) instead
 * of mapping fresh pages for each. The parallel loop's steps allocate and
 * free their arrays every iteration, and each first touch of a fresh page
 * costs a fault: on the development VM the 1-second cube job's rank 0 spent
 * 0.035 s of its 0.47 s on them; the rod at 4.9 M tets keeps 5 % more
 * resident memory (docs/BENCHMARKS.md, "Small jobs on two ranks"). A
 * sequential run frees little and gains nothing. The user's glibc malloc
 * tunables win. */
static void keep_freed_memory(void) {
#ifdef __GLIBC__
  const char *t = getenv("GLIBC_TUNABLES");
  if ((t && (strstr(t, "glibc.malloc.mmap_threshold") ||
             strstr(t, "glibc.malloc.trim_threshold"))) ||
      getenv("MALLOC_MMAP_THRESHOLD_") || getenv("MALLOC_TRIM_THRESHOLD_"))
    return;
  mallopt(M_MMAP_THRESHOLD, 32 << 20);
  mallopt(M_TRIM_THRESHOLD, 64 << 20);
#endif
}

int main(int argc, char **argv) {
  int provided = 0;
  const char *mpi_defaults = mpi_start_defaults();
  double tstart = pa_wtime();
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
  double tinit = pa_wtime();
  pa_cli cli = {MPI_COMM_WORLD, 0, 1, 0};
  MPI_Comm_rank(cli.comm, &cli.rank);
  MPI_Comm_size(cli.comm, &cli.size);
  if (cli.size > 1) keep_freed_memory();
  pa_cli_test_hooks(&cli);
  int rc = dispatch(&cli, argc, argv);
  double tcmd = pa_wtime();
  int all = rc;
  MPI_Allreduce(&rc, &all, 1, MPI_INT, MPI_MAX, cli.comm);
  MPI_Finalize();
  /* the command's own time apart from MPI's start and end, which cost
   * about half a second even on one process (bench/vs_mmg.sh reads it) */
  if (cli.verbosity >= 1 && cli.rank == 0)
    fprintf(stderr, "padapt: MPI start %.3f s, command %.3f s, MPI end %.3f s\n",
            tinit - tstart, tcmd - tinit, pa_wtime() - tcmd);
  if (cli.verbosity >= 2 && cli.rank == 0)
    fprintf(stderr, "padapt: MPI start-up: %s\n", mpi_defaults);
  return all;
}
