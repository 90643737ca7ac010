/*
 * cmd_adapt.c -- `padapt adapt`: sequential adaptation of a mesh to a metric
 * with the built-in remesher (Mmg-compatible options), after cutting a
 * level set into it with -ls (tools/lsopt.c).
 *
 *   padapt adapt IN [-met SOL | -sol SOL | -hsiz H] -out OUT [options]
 *
 * Outputs: the mesh OUT (format by extension), its metric in OUT's name with
 * the extension replaced by .sol (or -outsol PATH; -nosol for none), the
 * user fields carried (vertex, element and boundary fields: -field F.sol,
 * or the views of a Gmsh IN) in <OUT stem>.fields.sol (or -outfield PATH), the JSON report (-json) and the picture of the
 * histograms before and after (-svg). Prints `padapt stats` before and
 * after, the operation counts and the time. Exit status: 0 on success and on "target missed" (a
 * valid mesh that misses some edge lengths: a warning says so, and the JSON
 * report's "outcome" field), 1 on any error. The outputs are checked before
 * the work starts (pa_cli_check_io) and written in one output
 * transaction: on any error none of them is written and files already at
 * their paths stay as they were.
 *
 * On several MPI ranks (or with -distributed-output, -mem, -checkpoint or
 * -restart) the parallel piece loop of tools/cmd_adapt_parallel.c does the
 * work, with the same arguments.
 */
#include "cli.h"

#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* The options of `padapt adapt`, its remesher options among them, in the
 * order of -h. */
#define A(f) offsetof(pa_cli_adapt_args, f)
#define POSITIVE "a positive number"

static int opt_in(const pa_cli *cli, const pa_cli_spec *s, const char *name,
                  char **val, void *args) {
  pa_cli_adapt_args *a = args;
  if (a->in) return pa_cli_error(cli, "%s: more than one input mesh", s->cmd);
  if (!val[0]) return pa_cli_error(cli, "%s: %s needs a mesh file", s->cmd, name);
  a->in = val[0];
  return 0;
}

static int opt_verbosity(const pa_cli *cli, const pa_cli_spec *s,
                         const char *name, char **val, void *args) {
  pa_cli_adapt_args *a = args;
  double x;
  if (!pa_cli_parse_num(val[0], &x) || x < -1 || x > 10 || x != floor(x))
    return pa_cli_error(cli, "%s: %s needs a verbosity level in [-1, 10], "
                             "got '%s'",
                        s->cmd, name, val[0] ? val[0] : "nothing");
  a->remesh.verbosity = (int)x;
  pa_cli_set_verbosity((int)x);
  return 0;
}

static int opt_lsref(const pa_cli *cli, const pa_cli_spec *s, const char *name,
                     char **val, void *args) {
  pa_cli_adapt_args *a = args;
  for (int k = 0; k < 2; k++) {
    double x;
    if (!pa_cli_parse_num(val[k], &x) || x != floor(x) || fabs(x) > 2147483647)
      return pa_cli_error(cli, "%s: %s needs two references (integers), got "
                               "'%s'",
                          s->cmd, name, val[k] ? val[k] : "nothing");
    a->lsref[k] = (int)x;
  }
  return 0;
}

static int opt_field(const pa_cli *cli, const pa_cli_spec *s, const char *name,
                     char **val, void *args) {
  pa_cli_adapt_args *a = args;
  if (!val[0]) return pa_cli_error(cli, "%s: %s needs a .sol file", s->cmd, name);
  if (a->nfield == PA_CLI_MAX_FIELD_ARGS)
    return pa_cli_error(cli, "%s: at most %d %s", s->cmd, PA_CLI_MAX_FIELD_ARGS,
                        name);
  a->field[a->nfield++] = val[0];
  return 0;
}

/* -field-transfer [NAME=]MODE: the mode is checked here, the name once the
 * fields are read. */
static int opt_transfer(const pa_cli *cli, const pa_cli_spec *s,
                        const char *name, char **val, void *args) {
  pa_cli_adapt_args *a = args;
  pa_transfer mode;
  if (!val[0])
    return pa_cli_error(cli, "%s: %s needs [FIELD=]MODE", s->cmd, name);
  const char *eq = strchr(val[0], '=');
  if (eq == val[0])
    return pa_cli_error(cli, "%s: %s %s: no field name before '='", s->cmd,
                        name, val[0]);
  if (pa_transfer_parse(eq ? eq + 1 : val[0], &mode) != PA_SUCCESS)
    return pa_cli_error(cli, "%s: %s %s: %s", s->cmd, name, val[0],
                        pa_last_error());
  if (a->ntransfer == PA_CLI_MAX_FIELD_ARGS)
    return pa_cli_error(cli, "%s: at most %d %s", s->cmd, PA_CLI_MAX_FIELD_ARGS,
                        name);
  a->transfer[a->ntransfer++] = val[0];
  return 0;
}

static const pa_cli_opt adapt_opts[] = {
    {.names = "-in", .kind = PA_CLI_FN, .fn = opt_in, .nval = 1,
     .label = "-in IN", .help = "input mesh (same as the positional IN)"},
    {.names = "-met -sol", .kind = PA_CLI_STR, .at = A(met),
     .want = "a .sol file", .label = "-met/-sol SOL",
     .help = "metric: sizes (scalar) or tensors, .sol/.solb\n"
             "(default: IN.sol or IN.solb when it exists, else the\n"
             "view \"metric\" of a Gmsh IN.msh)"},
    {.names = "-hsiz", .kind = PA_CLI_POS, .at = A(remesh.hsiz),
     .want = POSITIVE, .label = "-hsiz H",
     .help = "constant size H (replaces the metric)"},
    {.names = "-out", .kind = PA_CLI_STR, .at = A(out), .want = "a mesh file",
     .label = "-out OUT",
     .help = "output mesh (.mesh .meshb .msh .vtu; default IN.o.EXT)"},
    {.names = "-outsol", .kind = PA_CLI_STR, .at = A(outsol),
     .want = "a .sol file", .label = "-outsol PATH",
     .help = "output metric (default: OUT with extension .sol)"},
    {.names = "-nosol", .kind = PA_CLI_FLAG, .at = A(nosol), .label = "-nosol",
     .help = "do not write the output metric"},
    {.names = "-hmin", .kind = PA_CLI_POS, .at = A(remesh.hmin),
     .want = POSITIVE, .label = "-hmin H -hmax H", .help = "clamp the sizes"},
    {.names = "-hmax", .kind = PA_CLI_POS, .at = A(remesh.hmax),
     .want = POSITIVE},
    {.names = "-hgrad", .kind = PA_CLI_NUM, .at = A(remesh.hgrad),
     .want = "a number (> 1; -1 or any value <= 1 disables)",
     .lo = -INFINITY, .hi = INFINITY, .label = "-hgrad G",
     .help = "gradation: size ratio bound along a unit edge\n"
             "(default " PA_CLI_TEXT(PA_DEFAULT_HGRAD) "; -1 disables)"},
    {.names = "-hgradreq", .kind = PA_CLI_NUM, .at = A(remesh.hgradreq),
     .want = "a number (> 1; -1 or any value <= 1 disables)",
     .lo = -INFINITY, .hi = INFINITY, .label = "-hgradreq G",
     .help = "gradation from required entities (default "
             PA_CLI_TEXT(PA_DEFAULT_HGRADREQ) ";\n"
             "-1: they constrain nothing)"},
    {.names = "-hausd", .kind = PA_CLI_POS, .at = A(remesh.hausd),
     .want = POSITIVE, .label = "-hausd D",
     .help = "max boundary deviation from the curve (default "
             PA_CLI_TEXT(PA_DEFAULT_HAUSD) ")"},
    {.names = "-ar", .kind = PA_CLI_NUM, .at = A(remesh.angle),
     .want = "an angle in [0, 180] degrees", .lo = 0, .hi = 180,
     .label = "-ar A", .help = "corner detection angle in degrees (default "
                               PA_CLI_TEXT(PA_DEFAULT_ANGLE) ")"},
    {.names = "-nr", .kind = PA_CLI_FLAG, .at = A(remesh.no_angle),
     .label = "-nr", .help = "no corner detection by angle"},
    {.names = "-noinsert", .kind = PA_CLI_FLAG, .at = A(remesh.no_insert),
     .label = "-noinsert -noswap -nomove", .help = "disable operators"},
    {.names = "-noswap", .kind = PA_CLI_FLAG, .at = A(remesh.no_swap)},
    {.names = "-nomove", .kind = PA_CLI_FLAG, .at = A(remesh.no_move)},
    {.names = "-nosurf", .kind = PA_CLI_FLAG, .at = A(remesh.no_surf),
     .label = "-nosurf", .help = "leave the boundary unchanged (3D)"},
    {.names = "-geo", .kind = PA_CLI_STR, .at = A(geo),
     .want = "a model file", .label = "-geo MODEL",
     .help = "the CAD model IN was meshed from (.geo .step .stp .brep\n"
             ".iges .igs, through Gmsh's library; IN a Gmsh .msh): new\n"
             "boundary vertices go onto it, -hausd is measured against\n"
             "its curvature, OUT keeps its entities"},
    {.names = "-f", .kind = PA_CLI_STR, .at = A(params),
     .want = "a parameter file", .label = "-f FILE",
     .help = "local parameters per reference (Mmg's format: REF\n"
             "Triangles|Tetrahedra|Edges HMIN HMAX HAUSD; default\n"
             "IN.padapt when it exists)"},
    {.names = "-ls", .kind = PA_CLI_STR, .at = A(ls), .want = "a .sol file",
     .label = "-ls PHI.sol",
     .help = "cut the zero set of the level set PHI (one value per\n"
             "vertex of IN) into IN first, then adapt, keeping it:\n"
             "inside (phi < V) reference 3, outside 2, interface 10\n"
             "(Mmg's -ls; materials: LSReferences in the -f file)"},
    {.names = "-lsval", .kind = PA_CLI_NUM, .at = A(lsval),
     .want = "a number", .lo = -INFINITY, .hi = INFINITY,
     .label = "-lsval V", .help = "the iso-value V of -ls (default 0)"},
    {.names = "-lsref", .kind = PA_CLI_FN, .fn = opt_lsref, .nval = 2,
     .label = "-lsref IN OUT",
     .help = "references of the inside and the outside (default 3 2)"},
    {.names = "-isoref", .kind = PA_CLI_INT, .at = A(isoref),
     .want = "an integer reference", .lo = -2147483647.0, .hi = 2147483647.0,
     .label = "-isoref R",
     .help = "reference of the interface and its vertices (default 10)"},
    {.names = "-rmc", .kind = PA_CLI_OPTNUM, .at = A(rmc),
     .want = "a volume share in (0, 1)", .lo = 1e-300, .hi = 0.999999,
     .dflt = PA_LS_RMC, .label = "-rmc [VOL]",
     .help = "with -ls: a component of either side whose volume is\n"
             "below VOL times the mesh's changes side (default 1e-5)"},
    {.names = "-optim", .kind = PA_CLI_FLAG, .at = A(optim), .label = "-optim",
     .help = "keep the sizes of the input mesh (the mean length of\n"
             "each vertex's edges), improve the quality"},
    {.names = "-field", .kind = PA_CLI_FN, .fn = opt_field, .nval = 1,
     .label = "-field F.sol",
     .help = "fields to carry (repeatable): SolAtVertices (interpolated),\n"
             "SolAtTriangles/SolAtTetrahedra (elements) and\n"
             "SolAtEdges/SolAtTriangles (boundary); written, each kind\n"
             "under its keyword, to <OUT stem>.fields.sol (or -outfield)"},
    {.names = "-outfield", .kind = PA_CLI_STR, .at = A(outfield),
     .want = "a .sol file"},
    {.names = "-field-transfer", .kind = PA_CLI_FN, .fn = opt_transfer,
     .nval = 1, .label = "-field-transfer [F=]M",
     .help = "how element field F (cell1, ... from a .sol; every one\n"
             "without F=) is carried: conservative (default), bounded\n"
             "or nearest (repeatable; docs/guide/fields.md)"},
    {.names = "-json", .kind = PA_CLI_STR, .at = A(json), .want = "a file",
     .label = "-json R.json",
     .help = "write the after-statistics, time and counts as JSON"},
    {.names = "-svg", .kind = PA_CLI_STR, .at = A(svg), .want = "an .svg file",
     .label = "-svg H.svg",
     .help = "picture of the edge-length and quality histograms,\n"
             "before and after"},
    {.names = "-v", .kind = PA_CLI_FN, .fn = opt_verbosity, .nval = 1,
     .label = "-v N",
     .help = "verbosity: -1 errors and warnings only, 0 the report\n"
             "(default), 1-10 more detail on stderr"},
    {.kind = PA_CLI_HELP,
     .help = "Parallel (mpiexec -n P, P > 1; IN may be a distributed set "
             "OUT.<r>.meshb):\n"},
    {.names = "-distributed-output", .kind = PA_CLI_FLAG,
     .at = A(distributed), .label = "-distributed-output",
     .help = "write OUT as a distributed set"},
    {.names = "-mem -m", .kind = PA_CLI_POS, .at = A(mem_mb), .want = POSITIVE,
     .label = "-mem MB, -m MB",
     .help = "memory bound per process (default: the available memory;\n"
             "a metric whose output would not fit is refused, and\n"
             "padapt's memory past MB is an error: nothing written)"},
    {.names = "-max-iter", .kind = PA_CLI_INT, .at = A(max_iter),
     .want = "an integer in [1, 1000]", .lo = 1, .hi = 1000,
     .label = "-max-iter N",
     .help = "at most N iterations (default " PA_CLI_TEXT(PA_DEFAULT_MAX_ITER)
             ")"},
    {.names = "-best-effort", .kind = PA_CLI_FLAG, .at = A(best_effort),
     .label = "-best-effort",
     .help = "write the (valid) mesh even if the loop stalled; without\n"
             "it a stalled loop is an error and nothing is written"},
    {.names = "-serial-below", .kind = PA_CLI_NUM, .at = A(serial_below),
     .want = "a number >= 0", .lo = 0, .hi = 1e15, .label = "-serial-below N",
     .help = "rank 0 adapts alone, as one process would, when the input\n"
             "and the metric's estimate of the output both have fewer\n"
             "than N elements: sharing out so small a job costs more\n"
             "than it saves (default " PA_CLI_TEXT(PA_CLI_SERIAL_BELOW_3D)
             " in 3D, " PA_CLI_TEXT(PA_CLI_SERIAL_BELOW_2D) " in 2D; 0:\n"
             "always share out)"},
    {.names = "-pieces", .kind = PA_CLI_INT, .at = A(pieces),
     .want = "an integer in [1, 1000]", .lo = 1, .hi = 1000,
     .label = "-pieces K",
     .help = "pieces per process (default "
             PA_CLI_TEXT(PA_DEFAULT_PIECES_PER_RANK) ")"},
    {.names = "-check", .kind = PA_CLI_FLAG, .at = A(check), .label = "-check",
     .help = "check every remeshed piece and the distributed result\n"
             "(always done with a plug-in remesher)"},
    {.names = "-checkpoint", .kind = PA_CLI_STR, .at = A(checkpoint),
     .want = "a directory", .label = "-checkpoint DIR",
     .help = "after each iteration, write the distributed state to\n"
             "DIR (created if missing; only the latest checkpoint\n"
             "is kept, replaced atomically)"},
    {.names = "-restart", .kind = PA_CLI_STR, .at = A(restart),
     .want = "a checkpoint directory", .label = "-restart DIR",
     .help = "resume the run whose checkpoint is in DIR: same number\n"
             "of processes and same options (IN, -met and -field are\n"
             "not read: the checkpoint holds the mesh); the output\n"
             "is the uninterrupted run's, byte for byte"},
    {.kind = PA_CLI_END}};

static int adapt_positional(const pa_cli *cli, const char *arg, void *args) {
  pa_cli_adapt_args *a = args;
  if (a->in)
    return pa_cli_error(cli, "adapt: more than one input mesh ('%s')", arg);
  a->in = arg;
  return 0;
}

static const pa_cli_spec adapt_spec = {
    .cmd = "adapt",
    .usage = "usage: padapt adapt IN [-met SOL | -sol SOL | -hsiz H] [-out "
             "OUT] [options]\n",
    .width = 16,
    .opt = adapt_opts,
    .tail = "Exit status: 0 success (also \"target missed\": a valid mesh, "
            "written,\n"
            "with a warning); 1 failure, nothing written (previous files "
            "untouched).\n",
    .positional = adapt_positional};

static const char *outcome_name(pa_remesh_outcome o) {
  return o == PA_REMESH_SUCCESS         ? "success"
         : o == PA_REMESH_TARGET_MISSED ? "target missed"
                                        : "failed";
}

/* IN's name without its extension (a distributed set's name ends at its
 * extension as well) into buf. */
static int stem(const char *in, char *buf, size_t n) {
  const char *dot = strrchr(in, '.'), *slash = strrchr(in, '/');
  size_t k = dot && (!slash || dot > slash) ? (size_t)(dot - in) : strlen(in);
  return snprintf(buf, n, "%.*s", (int)k, in) < (int)n;
}

/* Mmg's default output name: IN.o.EXT with IN's extension (.mesh when IN
 * has none). */
static int default_paths(const pa_cli *cli, pa_cli_adapt_args *a) {
  char base[4096];
  const char *dot = strrchr(a->in, '.'), *slash = strrchr(a->in, '/');
  const char *ext = dot && (!slash || dot > slash) ? dot : ".mesh";
  if (!stem(a->in, base, sizeof base) ||
      snprintf(a->out_default, sizeof a->out_default, "%s.o%s", base, ext) >=
          (int)sizeof a->out_default)
    return pa_cli_error(cli, "adapt: input name too long for a default output");
  a->out = a->out_default;
  return 0;
}

/* As Mmg does: with no metric option, IN.sol (or IN.solb) beside the mesh is
 * its metric when it exists. */
static void find_metric(const pa_cli *cli, pa_cli_adapt_args *a) {
  static const char *ext[] = {".sol", ".solb"};
  char base[4000];
  if (!stem(a->in, base, sizeof base)) return;
  for (int k = 0; k < 2; k++) {
    if (snprintf(a->met_default, sizeof a->met_default, "%s%s", base,
                 ext[k]) >= (int)sizeof a->met_default)
      return;
    if (access(a->met_default, R_OK) == 0) {
      a->met = a->met_default;
      if (cli->rank == 0 && a->remesh.verbosity >= 0)
        printf("padapt: adapt: metric %s (found beside %s)\n", a->met, a->in);
      return;
    }
  }
}

/* As Mmg reads IN.mmg3d: IN.padapt beside the mesh holds its local
 * parameters when it exists. */
static void find_params(const pa_cli *cli, pa_cli_adapt_args *a) {
  char base[4000];
  if (!stem(a->in, base, sizeof base) ||
      snprintf(a->params_default, sizeof a->params_default, "%s.padapt",
               base) >= (int)sizeof a->params_default ||
      access(a->params_default, R_OK) != 0)
    return;
  a->params = a->params_default;
  if (cli->rank == 0 && a->remesh.verbosity >= 0)
    printf("padapt: adapt: local parameters %s (found beside %s)\n",
           a->params, a->in);
}

/* Parse the arguments of `padapt adapt`. Returns 0 when parsed, 1 after
 * printing an error, -1 after printing the usage (-h). */
static int parse_args(const pa_cli *cli, int argc, char **argv,
                      pa_cli_adapt_args *a) {
  memset(a, 0, sizeof *a);
  /* -serial-below's default: the dimension's, or PADAPT_SERIAL_BELOW (the
   * test suite sets 0, so that its small meshes go through the piece loop) */
  const char *sb = getenv("PADAPT_SERIAL_BELOW");
  a->serial_below = sb && sb[0] ? atof(sb) : -1;
  pa_remesh_opts_default(&a->remesh);
  a->remesh.verbosity = cli->verbosity;
  a->lsref[0] = PA_LS_REF_IN;
  a->lsref[1] = PA_LS_REF_OUT;
  a->isoref = PA_LS_REF_IFACE;
  int rc = pa_cli_parse(cli, &adapt_spec, argc, argv, a);
  if (rc) return rc;
  if (!a->ls && (a->lsval != 0 || a->rmc > 0 || a->isoref != PA_LS_REF_IFACE ||
                 a->lsref[0] != PA_LS_REF_IN || a->lsref[1] != PA_LS_REF_OUT))
    return pa_cli_error(cli, "adapt: -lsval, -lsref, -isoref and -rmc go "
                             "with -ls PHI.sol");
  if (a->ls && a->lsref[0] == a->lsref[1])
    return pa_cli_error(cli, "adapt: -lsref: the inside and the outside need "
                             "two references, got %d twice",
                        a->lsref[0]);
  if (!a->in && !a->restart) {
    pa_cli_error(cli, "adapt: no input mesh");
    if (cli->rank == 0) pa_cli_help(&adapt_spec, stderr);
    return 1;
  }
  if (!a->out && !a->in)
    return pa_cli_error(cli, "adapt: no output mesh (-out OUT)");
  if (!a->out && default_paths(cli, a)) return 1;
  if (a->optim && (a->met || a->remesh.hsiz > 0))
    return pa_cli_error(cli, "adapt: -optim takes the sizes of the input "
                             "mesh: give no -met/-sol/-hsiz");
  if (!a->met && a->remesh.hsiz <= 0 && !a->restart && !a->optim)
    find_metric(cli, a);
  if (!a->params && a->in && !a->restart) find_params(cli, a);
  if (a->params && a->restart)
    return pa_cli_error(cli, "adapt: -f and -restart: the local parameters "
                             "are not checkpointed; restart without them");
  if (a->svg && !pa_cli_is_svg(a->svg))
    return pa_cli_error(cli, "adapt: -svg %s: only SVG pictures are written "
                             "(.svg); convert with e.g. rsvg-convert",
                        a->svg);
  if (a->met && a->remesh.hsiz > 0)
    return pa_cli_error(cli, "adapt: give either -met/-sol or -hsiz, not both");
  if (a->geo && a->ls)
    return pa_cli_error(cli, "adapt: -geo and -ls: the cut's interface lies "
                             "on no entity of the model");
  if (a->geo && (a->restart || a->checkpoint || a->distributed))
    return pa_cli_error(cli, "adapt: -geo and %s: a distributed set does not "
                             "keep the model's entities",
                        a->restart      ? "-restart"
                        : a->checkpoint ? "-checkpoint"
                                        : "-distributed-output");
  if (a->remesh.hmin > 0 && a->remesh.hmax > 0 &&
      a->remesh.hmin > a->remesh.hmax)
    return pa_cli_error(cli, "adapt: -hmin (%g) is larger than -hmax (%g)",
                        a->remesh.hmin, a->remesh.hmax);
  return 0;
}

/* The inputs and outputs of `padapt adapt`, checked before the work
 * starts. */
static int check_outputs(const pa_cli *cli, const pa_cli_adapt_args *a) {
  char *sol = NULL, *fields = NULL;
  pa_cli_io io = {.in = {a->in, a->met, a->params, a->ls},
                  .out = {a->json, a->svg},
                  .ckpt = a->checkpoint,
                  .restart = a->restart};
  for (int k = 0; k < a->nfield; k++) io.in[4 + k] = a->field[k];
  if (a->distributed) { /* a set carries its metric and fields */
    io.set = a->out;
  } else {
    io.out[2] = a->out;
    if (!a->nosol)
      io.out[3] = a->outsol ? a->outsol
                            : (sol = pa_cli_replace_ext(a->out, ".sol"));
    if (a->nfield || a->outfield)
      io.out[4] = a->outfield
                      ? a->outfield
                      : (fields = pa_cli_replace_ext(a->out, ".fields.sol"));
  }
  int bad = pa_cli_check_io(cli, "adapt", &io);
  if (!bad && a->checkpoint) {
    /* the state file in an existing directory, or the directory itself */
    struct stat sb;
    size_t n = strlen(a->checkpoint) + sizeof "/checkpoint";
    char *state = malloc(n);
    if (state) snprintf(state, n, "%s/checkpoint", a->checkpoint);
    pa_cli_io ck = {
        .out = {stat(a->checkpoint, &sb) == 0 ? state : a->checkpoint}};
    bad = pa_cli_check_io(cli, "adapt -checkpoint", &ck);
    free(state);
  }
  free(sol);
  free(fields);
  return bad;
}

/* Everything the sequential run reads beside the mesh: the metric, the local
 * parameters (into opts; *local owns them) and the -field fields (the level
 * set of -ls is read by the cut). Returns 0, or 1 after printing the error. */
static int read_inputs(const pa_cli *cli, const pa_cli_adapt_args *a,
                       pa_mesh *mesh, pa_remesh_opts *opts,
                       pa_local_param **local) {
  if (pa_cli_adapt_metric(cli, a, mesh)) return 1;
  if (a->params) {
    if (pa_cli_read_params(cli, a->params, pa_mesh_dim(mesh), local,
                           &opts->nlocal, NULL, NULL))
      return 1;
    opts->local = *local;
  }
  return pa_cli_fail(cli, pa_cli_attach_fields(mesh, a));
}

/* The statistics of the input in the target metric (pa_cli_adapt_metric:
 * -hsiz's constant size when the mesh has none), printed. Returns 0, or 1
 * after printing the error. */
static int report_before(const pa_cli *cli, const pa_cli_adapt_args *a,
                         pa_mesh *mesh, pa_stats *before) {
  pa_status st = pa_mesh_stats(mesh, before);
  if (st) return pa_cli_fail(cli, st);
  printf(" -- INPUT %s\n", a->in);
  pa_stats_print(before, stdout);
  fflush(stdout);
  return 0;
}

/* The built-in remesher on the mesh, with the live progress line; the
 * figures of the result in the given metric in rep->fidelity.user. Returns 0
 * for a valid mesh (target met or missed), or 1 after printing the error. */
static int run_remesher(const pa_cli *cli, pa_mesh *mesh, pa_remesh_opts *opts,
                        pa_remesh_report *rep) {
  pa_cli_progress live;
  pa_cli_progress_init(&live, opts->verbosity >= 0);
  if (live.enabled) { /* the remesher samples its mesh for each call */
    opts->progress = pa_cli_progress_cb;
    opts->progress_ctx = &live;
  }
  pa_status st = pa_remesh(pa_remesher_builtin(), mesh, opts, rep);
  pa_cli_progress_end(&live);
  if (st != PA_SUCCESS) return pa_cli_fail(cli, st);
  if (rep->outcome == PA_REMESH_FAILED)
    return pa_cli_error(cli, "adapt: the remesher failed (%s); nothing written",
                        pa_last_error()[0] ? pa_last_error() : "no detail");
  if (!rep->fidelity.measured) /* out of memory measuring: try once more */
    return pa_cli_fail(cli, pa_mesh_stats(mesh, &rep->fidelity.user));
  return 0;
}

/* The statistics of the output in the given metric, the operation counts and
 * the remesher's verdict on stdout; the warning of a missed target. */
static void report_after(const pa_cli_adapt_args *a, const pa_mesh *mesh,
                         const pa_remesh_report *rep) {
  printf(" -- OUTPUT %s, in the given metric\n", a->out);
  pa_stats_print(&rep->fidelity.user, stdout);
  pa_cli_print_fidelity(&rep->fidelity, stdout);
  printf(" -- ADAPTATION\n"
         "    splits %ld, collapses %ld, swaps %ld, moves %ld, passes %d\n"
         "    time %.3f s (%.0f output elements/s), remesher CPU %.3f s, peak "
         "padapt memory %.1f MB\n"
         "    remesher verdict on the metric used: %s\n",
         rep->nsplit, rep->ncollapse, rep->nswap, rep->nmove, rep->npass,
         rep->time_s, rep->time_s > 0 ? pa_mesh_nelem(mesh) / rep->time_s : 0.0,
         rep->cpu_s, pa_memory_peak() / 1e6, outcome_name(rep->outcome));
  pa_cli_print_transfer(&rep->transfer);
  if (a->geo)
    printf("    model %s: %ld boundary points put on it (%ld left on the "
           "reconstruction), %.3f s in its kernel\n",
           a->geo, rep->nproject - rep->nproject_failed, rep->nproject_failed,
           rep->project_s);
  fflush(stdout);
  if (!rep->fidelity.target_met)
    fprintf(stderr, "padapt: warning: adapt: target missed (valid mesh, but "
                    "the given metric is not met; see the outcome line)\n");
}

/* The -json report: the after-statistics with the time, memory and counts of
 * the run and the figures before. */
static pa_status write_json(const pa_cli_adapt_args *a, const pa_stats *before,
                            const pa_remesh_report *rep,
                            const pa_levelset_report *ls) {
  char *fid = pa_cli_fidelity_json(&rep->fidelity);
  char *lsj = a->ls ? pa_cli_ls_json(ls) : NULL;
  char *tr = pa_cli_transfer_json(&rep->transfer);
  pa_cli_sbuf b = {NULL, 0, 0, 0};
  if (a->ls) pa_cli_sb_printf(&b, "%s", lsj ? lsj : "");
  pa_cli_sb_printf(&b,
                   "\"time_s\": %.6f, \"remesh_cpu_s\": %.6f, "
                   "\"peak_rss_bytes\": %zu, "
                   "\"peak_memory_bytes\": %zu, \"remesher_outcome\": "
                   "\"%s\", \"nsplit\": %ld, \"ncollapse\": %ld, "
                   "\"nswap\": %ld, \"nmove\": %ld, \"npass\": %d, "
                   "\"elements_before\": %lld, \"vertices_before\": %lld, ",
                   rep->time_s, rep->cpu_s, pa_peak_rss(), pa_memory_peak(),
                   outcome_name(rep->outcome), rep->nsplit, rep->ncollapse,
                   rep->nswap, rep->nmove, rep->npass, (long long)before->nelem,
                   (long long)before->nvert);
  if (a->geo)
    pa_cli_sb_printf(&b,
                     "\"projections\": %ld, \"projections_failed\": %ld, "
                     "\"projection_s\": %.6f, ",
                     rep->nproject, rep->nproject_failed, rep->project_s);
  pa_cli_sb_printf(&b, "%s%s", tr ? tr : "", fid ? fid : "");
  pa_status st = b.fail || !fid || !tr || (a->ls && !lsj)
                     ? pa_set_error(PA_ERR_MEMORY, "out of memory")
                     : pa_stats_write_json(&rep->fidelity.user, b.p, a->json);
  free(fid);
  free(tr);
  free(lsj);
  free(b.p);
  return st;
}

/* Every output in one transaction, all of them or none: the mesh, its metric
 * (unless -nosol), its fields, the -json report and the -svg picture.
 * Returns 0, or 1 after printing the error. */
static int write_outputs(const pa_cli *cli, const pa_cli_adapt_args *a,
                         pa_mesh *mesh, const pa_stats *before,
                         const pa_remesh_report *rep,
                         const pa_levelset_report *ls) {
  char *solpath = NULL, *fieldpath = NULL;
  pa_output *tx = NULL;
  pa_status st = pa_output_begin(&tx);
  if (st == PA_SUCCESS) st = pa_mesh_write(mesh, a->out, NULL);
  if (st == PA_SUCCESS && !a->nosol) {
    pa_sol *sol = NULL;
    solpath = a->outsol ? NULL : pa_cli_replace_ext(a->out, ".sol");
    st = pa_mesh_metric_to_sol(mesh, 0, &sol);
    if (st == PA_SUCCESS)
      st = pa_sol_write(sol, a->outsol ? a->outsol : solpath);
    pa_sol_destroy(sol);
  }
  if (st == PA_SUCCESS && pa_cli_has_fields(mesh)) {
    fieldpath = a->outfield ? NULL : pa_cli_replace_ext(a->out, ".fields.sol");
    st = pa_cli_write_fields(mesh, a->outfield ? a->outfield : fieldpath);
  }
  if (st == PA_SUCCESS && a->json) st = write_json(a, before, rep, ls);
  if (st == PA_SUCCESS && a->svg)
    st = pa_cli_adapt_svg(a, before, &rep->fidelity.user);
  st = pa_cli_output_end(MPI_COMM_SELF, tx, st);
  free(solpath);
  free(fieldpath);
  if (st == PA_SUCCESS) return 0;
  pa_cli_fail(cli, st);
  return pa_cli_error(cli, "adapt: no output written");
}

/* The sequential adaptation on rank 0 alone: read, report before, remesh,
 * report after, write. */
static int adapt_sequential(const pa_cli *cli, const pa_cli_adapt_args *a) {
  pa_mesh *mesh = NULL;
  pa_local_param *local = NULL;
  pa_remesh_opts opts = a->remesh;
  pa_stats before;
  pa_remesh_report rep;
  pa_levelset_report ls;
  pa_status st = pa_cli_read_adapt_mesh(cli, a, a->remesh.geometry,
                                        &mesh); /* collective */
  if (cli->rank != 0) return st ? 1 : 0;
  int rc = pa_cli_fail(cli, st);
  if (!rc) rc = read_inputs(cli, a, mesh, &opts, &local);
  if (!rc && a->ls) rc = pa_cli_ls_cut(cli, a, mesh, &ls);
  if (!rc) rc = report_before(cli, a, mesh, &before);
  if (!rc) rc = run_remesher(cli, mesh, &opts, &rep);
  if (!rc) report_after(a, mesh, &rep);
  if (!rc) rc = write_outputs(cli, a, mesh, &before, &rep, &ls);
  free(local);
  pa_mesh_destroy(mesh);
  return rc;
}

int pa_cli_adapt(const pa_cli *cli, int argc, char **argv) {
  pa_cli_adapt_args args;
  int prc = parse_args(cli, argc, argv, &args);
  if (prc) return prc > 0 ? 1 : 0;
  if (check_outputs(cli, &args)) return 1;
  /* -mem bounds padapt's memory in every phase: reading, remeshing,
   * gathering, writing */
  if (args.mem_mb > 0) pa_memory_set_limit((size_t)(args.mem_mb * 1e6));
  pa_geometry *geo = NULL; /* -geo: loaded on every rank */
  if (pa_cli_read_geometry(cli, &args, &geo)) return 1;
  args.remesh.geometry = geo;
  /* On several ranks, or when asked for a distributed output, a memory
   * bound or a checkpoint, the parallel piece loop (tools/cmd_adapt_parallel.c) does
   * the work, unless it finds the job too small to share out
   * (-serial-below): then rank 0 adapts it as one process would. */
  int rc = PA_CLI_SERIAL;
  if (cli->size > 1 || args.distributed || args.mem_mb > 0 ||
      args.checkpoint || args.restart)
    rc = pa_cli_adapt_parallel(cli, &args);
  if (rc == PA_CLI_SERIAL) rc = adapt_sequential(cli, &args);
  pa_geometry_destroy(geo);
  return rc;
}
