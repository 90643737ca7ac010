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

/* Read Mmg's parameter file (tools/params.c) for a mesh of dimension dim
 * into *out (malloc'ed, *nout entries). Returns 0, or 1 after printing the
 * error (file:line). */
int pa_cli_read_params(const pa_cli *cli, const char *path, int dim,
                       pa_local_param **out, int *nout);

/* The arguments of `padapt adapt`, sequential and parallel alike. */
typedef struct pa_cli_adapt_args {
  const char *in, *out, *met, *outsol, *field, *outfield, *json;
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

/* Print "padapt: <message>" on stderr (every rank that calls it); returns 1. */
int pa_cli_error(const pa_cli *cli, const char *fmt, ...)
    __attribute__((format(printf, 2, 3)));
/* Print the library's last error for status st; returns 1 (0 on success). */
int pa_cli_fail(const pa_cli *cli, pa_status st);

/* Check, on rank 0 before the work starts, that the n output paths (NULL
 * entries skipped) can be written and are all different; prints the error
 * ("CMD: ...") and returns 1 on every rank if not, 0 if they can.
 * Collective. */
int pa_cli_check_outputs(const pa_cli *cli, const char *cmd,
                         const char *const *paths, int n);
/* End the output transaction of a command (pa_output_end over comm:
 * MPI_COMM_SELF for outputs written by rank 0 alone). Collective over comm.
 * Test hook: with PADAPT_TEST_HOLD_OUTPUT=FILE in the environment and every
 * output written, rank 0 creates FILE and every rank waits 30 s before the
 * commit, so that a test can signal the command while its temporaries
 * exist. */
pa_status pa_cli_output_end(MPI_Comm comm, pa_output *tx, pa_status st);

/* Read a mesh given on the command line: a sequential file (read by rank 0)
 * or a distributed set OUT.<r>.meshb (read by all ranks, gathered on rank 0).
 * Collective. A mesh listing no boundary entity gets them all (ref 0); the
 * mesh is checked, and errors name the file. *mesh is set on rank 0 only. */
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
  double lo, hi;      /* PA_CLI_NUM, PA_CLI_INT: the range accepted */
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
/* Attach every field of a .sol file to the mesh as user fields field1, ...
 * (the vertex count must match: the error names the file). */
pa_status pa_cli_attach_fields(pa_mesh *mesh, const char *path);
/* Write the mesh's user fields as one .sol file (scalar, vector or tensor by
 * number of components). */
pa_status pa_cli_write_fields(pa_mesh *mesh, const char *path);

/* A growable string (the JSON reports); fail is set when out of memory. */
typedef struct pa_cli_sbuf {
  char *p;
  size_t n, cap;
  int fail;
} pa_cli_sbuf;
void pa_cli_sb_printf(pa_cli_sbuf *b, const char *fmt, ...)
    __attribute__((format(printf, 2, 3)));

/* How the result meets the given metric (pa_fidelity): the figures in the
 * metric used, when it differs, and the outcome line, on out. */
void pa_cli_print_fidelity(const pa_fidelity *f, FILE *out);
/* The same as JSON members ("outcome", "target_met", "limited_by",
 * "metric_used"), for pa_stats_write_json's extra; malloc'ed, NULL when out
 * of memory. */
char *pa_cli_fidelity_json(const pa_fidelity *f);

#endif
