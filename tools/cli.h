/*
 * cli.h -- shared declarations of the padapt command-line tool. Each command
 * lives in its own file (tools/cmd_*.c; generate, stats and convert in
 * main.c with main) and returns the process exit status; the helpers they
 * share are in cli_util.c, the option tables' parser and -h printer in
 * cli_opts.c. The CLI uses the public API only (padapt.h) and is the only
 * code of padapt allowed to exit().
 */
#ifndef PA_CLI_H
#define PA_CLI_H

#include "padapt.h"

#include <mpi.h>

typedef struct pa_cli {
  MPI_Comm comm;
  int rank, size;
  int verbosity;
} pa_cli;

/* Commands: argv[0] is the command name; argv[1..argc-1] its arguments. */
int pa_cli_generate(const pa_cli *cli, int argc, char **argv);
int pa_cli_metric(const pa_cli *cli, int argc, char **argv);
int pa_cli_levelset(const pa_cli *cli, int argc, char **argv);
int pa_cli_stats(const pa_cli *cli, int argc, char **argv);
int pa_cli_convert(const pa_cli *cli, int argc, char **argv);
int pa_cli_adapt(const pa_cli *cli, int argc, char **argv);
int pa_cli_partition(const pa_cli *cli, int argc, char **argv);
int pa_cli_plot(const pa_cli *cli, int argc, char **argv);

/* Set the verbosity of the library and the CLI: -1 silences the reports on
 * stdout (errors and warnings still go to stderr), 0 is the default, 1-10
 * add detail on stderr. */
void pa_cli_set_verbosity(int level);

/* The live progress line on stderr (tools/progress.c): give
 * pa_cli_progress_cb and the state as pa_remesh_opts.progress and its ctx;
 * enabled on rank 0 at verbosity >= 0. */
typedef struct pa_cli_progress {
  int enabled, tty, printed;
  double last;  /* elapsed time of the last line, -1 before the first */
  double after; /* seconds of silence at the start */
} pa_cli_progress;
void pa_cli_progress_init(pa_cli_progress *pr, int enabled);
void pa_cli_progress_cb(const pa_progress *p, void *ctx);
/* End the line rewritten on a terminal. */
void pa_cli_progress_end(pa_cli_progress *pr);

/* Read Mmg's parameter file (tools/params.c) for a mesh of dimension dim:
 * the local parameters into *out (malloc'ed, *nout entries), the materials
 * of its LSReferences section into *mat (malloc'ed, *nmat entries; mat may
 * be NULL: not kept). Returns 0, or 1 after printing the error
 * (file:line). */
int pa_cli_read_params(const pa_cli *cli, const char *path, int dim,
                       pa_local_param **out, int *nout, pa_ls_material **mat,
                       int *nmat);

/* Most -field files and -field-transfer choices of `padapt adapt`. */
#define PA_CLI_MAX_FIELD_ARGS 32

/* The arguments of `padapt adapt`, sequential and parallel alike. */
typedef struct pa_cli_adapt_args {
  const char *in, *out, *met, *outsol, *outfield, *json;
  const char *field[PA_CLI_MAX_FIELD_ARGS];    /* -field F.sol, in order */
  int nfield;
  const char *transfer[PA_CLI_MAX_FIELD_ARGS]; /* -field-transfer
                                                  [NAME=]MODE, in order */
  int ntransfer;
  const char *svg; /* -svg: before/after histograms */
  int nosol;       /* -nosol: no output metric file */
  int distributed; /* -distributed-output */
  int best_effort; /* -best-effort: write the mesh even if the loop stalled */
  double mem_mb;   /* -mem MB (0: none) */
  int max_iter;    /* -max-iter N (0: default) */
  int pieces;      /* -pieces K (0: default) */
  double serial_below; /* -serial-below N (-1: the default of the dimension) */
  int check;       /* -check: check every piece and the result */
  int optim;       /* -optim: the metric is the input mesh's own sizes */
  const char *params; /* -f FILE, or IN.padapt when it exists */
  const char *checkpoint; /* -checkpoint DIR: a checkpoint per iteration */
  const char *restart;    /* -restart DIR: resume from DIR's checkpoint */
  /* the level-set cut (tools/lsopt.c) */
  const char *ls;  /* -ls PHI.sol: cut its zero set into IN first */
  double lsval;    /* -lsval V: the iso-value */
  int lsref[2];    /* -lsref IN OUT (default 3 2) */
  int isoref;      /* -isoref R (default 10) */
  double rmc;      /* -rmc [VOL] (0: off) */
  pa_remesh_opts remesh;
  /* storage of the defaults a Mmg user expects: OUT = IN.o.EXT when -out is
   * not given, the metric IN.sol when it exists and none is given */
  char out_default[4096], met_default[4096], params_default[4096];
} pa_cli_adapt_args;

/* pa_cli_adapt_parallel's answer when the job is too small to share out
 * (-serial-below): the caller adapts it on rank 0 alone. */
#define PA_CLI_SERIAL 2
/* The default of -serial-below: below these many elements (input and
 * expected output), two processes took longer than one on the development
 * VM (own time: box3d 10 -> 0.1, 12 k tets, 0.078 against 0.072 s; the
 * plate -> 0.003, 140 k triangles, 0.317-0.374 against 0.309-0.317 s). */
#define PA_CLI_SERIAL_BELOW_3D 30000
#define PA_CLI_SERIAL_BELOW_2D 150000
/* The text of a number macro, for the lines of -h that give a default
 * (PA_CLI_TEXT(PA_DEFAULT_HGRAD) is "1.3"): each default is spelled once. */
#define PA_CLI_TEXT_(x) #x
#define PA_CLI_TEXT(x) PA_CLI_TEXT_(x)
/* The parallel `padapt adapt` (pa_dmesh_adapt), called by pa_cli_adapt on more
 * than one rank or for -distributed-output/-mem, with the parsed arguments.
 * Collective; the exit status is the same on every rank, or PA_CLI_SERIAL
 * on every rank. */
int pa_cli_adapt_parallel(const pa_cli *cli, const pa_cli_adapt_args *args);
/* Write the -svg picture of `padapt adapt` (args->svg): the histograms
 * before and after, side by side. Not collective. */
pa_status pa_cli_adapt_svg(const pa_cli_adapt_args *args, const pa_stats *before,
                           const pa_stats *after);
/* The metric `padapt adapt` adapts to, on the mesh read from args->in (rank
 * 0 of the parallel run, cli_util.c): the input's own sizes (-optim), the
 * -met file, or the mesh's own view "metric", which comes before a metric
 * found beside IN; with -hsiz and no metric, the constant size H, so that
 * the statistics before are taken in the target size. Returns 0, or 1 after
 * printing the error (a mesh left without a metric is one). Not
 * collective. */
int pa_cli_adapt_metric(const pa_cli *cli, const pa_cli_adapt_args *args,
                        pa_mesh *mesh);

/* The level-set cut of `padapt adapt -ls` (tools/lsopt.c). */
/* Its options from the arguments and the LSReferences of args->params (a
 * mesh of dimension dim); *mat (malloc'ed or NULL) holds the materials o
 * points to. Every rank reads the file. Returns 0, or 1 after printing the
 * error. Not collective. */
int pa_cli_ls_opts(const pa_cli *cli, const pa_cli_adapt_args *args, int dim,
                   pa_levelset_opts *o, pa_ls_material **mat);
/* The level set of args->ls, one value per vertex of mesh, into *phi
 * (malloc'ed). Returns 0, or 1 after printing the error (the file names
 * the count that does not match). Not collective. */
int pa_cli_ls_read(const pa_cli *cli, const pa_cli_adapt_args *args,
                   pa_mesh *mesh, double **phi);
/* Print what the cut did (stdout, at verbosity >= 0) and its warnings (a
 * level set that does not cross the mesh, entities of the interface's
 * reference on the boundary) on stderr. Not collective. */
void pa_cli_ls_report(const pa_cli_adapt_args *args,
                      const pa_levelset_opts *o, const pa_levelset_report *r);
/* The report as a JSON member "levelset": {...} followed by ", ", for the
 * -json report (malloc'ed; NULL when out of memory). */
char *pa_cli_ls_json(const pa_levelset_report *r);
/* The sequential cut of mesh by args->ls (read, options, cut, report):
 * *rep receives the report. Returns 0, or 1 after printing the error. */
int pa_cli_ls_cut(const pa_cli *cli, const pa_cli_adapt_args *args,
                  pa_mesh *mesh, pa_levelset_report *rep);

/* Print "padapt: <message>" on stderr (every rank that calls it); returns 1. */
int pa_cli_error(const pa_cli *cli, const char *fmt, ...)
    __attribute__((format(printf, 2, 3)));
/* Print the library's last error for status st; returns 1 (0 on success). */
int pa_cli_fail(const pa_cli *cli, pa_status st);

/* The files a command reads and writes (NULL entries skipped), for
 * pa_cli_check_io. */
/* the inputs: a mesh, -met, -f, -ls and the -field files */
#define PA_CLI_IO_MAX (4 + PA_CLI_MAX_FIELD_ARGS)
typedef struct pa_cli_io {
  const char *in[PA_CLI_IO_MAX];  /* files read; a distributed set: its files */
  const char *out[PA_CLI_IO_MAX]; /* files written */
  const char *set;     /* a distributed set written on every rank */
  const char *ckpt;    /* -checkpoint DIR: its "checkpoint" and "iter-*" */
  const char *restart; /* -restart DIR: every file in it is read */
} pa_cli_io;
/* Check, on rank 0 before the work starts (cli_paths.c), that every output
 * can be written (pa_output_check), that no two outputs and no output and
 * input are the same file (resolved: links and relative paths count), and
 * that no file but the checkpoint's own is in the checkpoint directory;
 * prints the error ("CMD: ...") and returns 1 on every rank if not, 0 if
 * the files are fine. Collective. */
int pa_cli_check_io(const pa_cli *cli, const char *cmd, const pa_cli_io *io);
/* End the output transaction of a command (pa_output_end over comm:
 * MPI_COMM_SELF for outputs written by rank 0 alone), with a note on stderr
 * when a signal arrived while the outputs were committed (they are
 * complete, the command goes on to exit 0). Collective over comm. */
pa_status pa_cli_output_end(MPI_Comm comm, pa_output *tx, pa_status st);
/* The test hooks of the environment (never set them in production), on
 * this rank: PADAPT_TEST_FAIL_ALLOC=k makes the k-th allocation of padapt's
 * allocator fail (on rank PADAPT_TEST_FAIL_RANK only, if set);
 * PADAPT_TEST_PAUSE=STEP with PADAPT_TEST_PAUSE_FLAG=FILE makes rank
 * PADAPT_TEST_PAUSE_RANK (default 0) write its process id into FILE when
 * its output transaction reaches STEP (pa_output_hook's steps) and wait
 * there up to 30 s, until SIGINT or SIGTERM comes, so that a test can
 * signal or kill it at that step. */
void pa_cli_test_hooks(const pa_cli *cli);

/* The reference of the boundary entities a mesh file does not list, as
 * Mmg gives them. */
#define PA_CLI_BOUNDARY_REF 0
/* Add the boundary entities the mesh read from path does not list (every
 * element face without a neighbour), with reference PA_CLI_BOUNDARY_REF,
 * keeping the listed ones; a note on stderr at verbosity >= 1. Not
 * collective. */
pa_status pa_cli_complete_boundary(const pa_cli *cli, const char *path,
                                   pa_mesh *mesh);
/* Read a mesh given on the command line: a sequential file (read by rank 0)
 * or a distributed set OUT.<r>.meshb (read by all ranks, gathered on rank 0).
 * Collective. The boundary entities the file does not list are added
 * (pa_cli_complete_boundary); the mesh is checked, and errors name the
 * file. *mesh is set on rank 0 only. */
pa_status pa_cli_read_mesh(const pa_cli *cli, const char *path, pa_mesh **mesh);

/* Strict number parsing: the whole argument, finite. Returns 1 on success. */
int pa_cli_parse_num(const char *s, double *v);
/* 1 if path ends with ".svg" (any case): the only picture format written. */
int pa_cli_is_svg(const char *path);
/* path with its extension replaced by ext (with the dot); malloc'ed. */
char *pa_cli_replace_ext(const char *path, const char *ext);

/* ---- option tables (cli_opts.c) ----
 *
 * Each command declares its options once, in a table of pa_cli_opt: the
 * names, the kind of value and where it goes in the command's argument
 * struct, and the option's line of -h. pa_cli_parse reads argv by the
 * table and pa_cli_help prints -h from it. */

/* How an option takes its value (at: its offset in the argument struct). */
typedef enum pa_cli_kind {
  PA_CLI_END = 0, /* ends a table */
  PA_CLI_HELP,    /* no option: a line of -h only (a positional argument
                     with label, a section title without) */
  PA_CLI_FLAG,    /* a switch: int at = 1 */
  PA_CLI_STR,     /* the next argument: const char *at */
  PA_CLI_POS,     /* a number > 0: double at */
  PA_CLI_NUM,     /* a number in [lo, hi]: double at */
  PA_CLI_INT,     /* an integer in [lo, hi]: int at */
  PA_CLI_OPTNUM,  /* an optional number in [lo, hi]: double at = the next
                     argument when it is one, else dflt */
  PA_CLI_FN       /* nval arguments, read by fn */
} pa_cli_kind;

/* Most arguments a PA_CLI_FN option takes. */
#define PA_CLI_MAX_VALUES 4

typedef struct pa_cli_spec pa_cli_spec;

/* Read the values of a PA_CLI_FN option given as name: val[0..nval-1]
 * (NULL where argv ran out). Returns 0, or 1 after printing an error. */
typedef int (*pa_cli_opt_fn)(const pa_cli *cli, const pa_cli_spec *s,
                             const char *name, char **val, void *args);

typedef struct pa_cli_opt {
  const char *names;  /* the option and its aliases: "-met -sol" */
  pa_cli_kind kind;
  size_t at;          /* offsetof the value in the argument struct */
  const char *want;   /* what the value must be, for the messages */
  double lo, hi;      /* PA_CLI_NUM, PA_CLI_INT, PA_CLI_OPTNUM: the range */
  double dflt;        /* PA_CLI_OPTNUM: the value when none is given */
  pa_cli_opt_fn fn;   /* PA_CLI_FN: reads its nval values */
  int nval;
  const char *label;  /* -h: the left column (NULL: no line of its own) */
  const char *help;   /* -h: the right column, lines separated by \n; with
                         neither names nor label, a text of its own */
} pa_cli_opt;

/* A command's arguments: its options, what to do with a positional
 * argument, and the -h text around the table. */
struct pa_cli_spec {
  const char *cmd;      /* "adapt": messages start with it */
  const char *help_cmd; /* "padapt HELP_CMD -h" (NULL: cmd) */
  const char *usage;    /* -h before the table */
  int width;            /* -h: the width of the table's left column */
  const pa_cli_opt *opt;
  const char *tail;     /* -h after the table (may be NULL) */
  /* a positional argument, in its order among the options: 0, or 1
   * after printing an error */
  int (*positional)(const pa_cli *cli, const char *arg, void *args);
};

/* Parse argv[1..argc-1] into args by s. Returns 0, 1 after printing an
 * error, -1 after printing the help (-h, --help; rank 0 prints). */
int pa_cli_parse(const pa_cli *cli, const pa_cli_spec *s, int argc,
                 char **argv, void *args);
/* Print the -h text of s. */
void pa_cli_help(const pa_cli_spec *s, FILE *out);

/* Attach field 0 of a .sol/.solb file as the mesh's metric. */
pa_status pa_cli_attach_metric(pa_mesh *mesh, const char *path);
/* Attach the fields of every -field file to the mesh (pa_mesh_fields_from_sol:
 * vertex fields field1, ..., element fields cell1, ..., boundary fields
 * face1, ...; a count that does not match names the file and line), then
 * set the -field-transfer modes: NAME=MODE for the field NAME (an element
 * field first, else a boundary or vertex field of that name), MODE alone
 * for every element field. */
pa_status pa_cli_attach_fields(pa_mesh *mesh, const pa_cli_adapt_args *a);
/* 1 if the mesh has a user field on any kind of entity. */
int pa_cli_has_fields(const pa_mesh *mesh);
/* Write the mesh's user fields as one .sol file, each kind under its
 * keyword (pa_mesh_fields_to_sol). */
pa_status pa_cli_write_fields(pa_mesh *mesh, const char *path);

/* A growable string (the JSON reports); fail is set when out of memory. */
typedef struct pa_cli_sbuf {
  char *p;
  size_t n, cap;
  int fail;
} pa_cli_sbuf;
void pa_cli_sb_printf(pa_cli_sbuf *b, const char *fmt, ...)
    __attribute__((format(printf, 2, 3)));

/* The JSON member "transfer" (what carrying the element and boundary
 * fields did, pa_transfer_report) followed by ", "; malloc'ed, NULL when
 * out of memory. */
char *pa_cli_transfer_json(const pa_transfer_report *t);
/* Its line of the report on stdout, when fields were carried. */
void pa_cli_print_transfer(const pa_transfer_report *t);

/* How the result meets the given metric (pa_fidelity): the figures in the
 * metric used, when it differs, and the outcome line, on out. */
void pa_cli_print_fidelity(const pa_fidelity *f, FILE *out);
/* The same as JSON members ("outcome", "target_met", "limited_by",
 * "metric_used"), for pa_stats_write_json's extra; malloc'ed, NULL when out
 * of memory. */
char *pa_cli_fidelity_json(const pa_fidelity *f);

#endif
