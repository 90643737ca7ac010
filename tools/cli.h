/*
 * cli.h -- shared declarations of the padapt command-line tool. Each command
 * lives in its own file (tools/cmd_*.c) and returns the process exit status.
 * The CLI is the only code of padapt allowed to exit().
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

/* The parallel `padapt adapt` (pa_dmesh_adapt), called by pa_cli_adapt on more
 * than one rank or for -distributed-output/-mem, with the parsed arguments.
 * Collective; the exit status is the same on every rank. */
int pa_cli_adapt_parallel(const pa_cli *cli, const pa_cli_adapt_args *args);
/* Write the -svg picture of `padapt adapt` (args->svg): the histograms
 * before and after, side by side. Not collective. */
pa_status pa_cli_adapt_svg(const pa_cli_adapt_args *args, const pa_stats *before,
                           const pa_stats *after);

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
/* Parse the remesher option at argv[*i] (-hsiz -hmin -hmax -hgrad -hgradreq
 * -hausd -ar
 * -v -nr -noinsert -noswap -nomove -nosurf) into opts, moving *i past its
 * value. Returns 1 when it was one, 0 when argv[*i] is not a remesher
 * option, -1 after printing an error. */
int pa_cli_remesh_option(const pa_cli *cli, int argc, char **argv, int *i,
                         pa_remesh_opts *opts);

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
