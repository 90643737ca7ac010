/*
 * cmd_partition.c -- `padapt partition`: distribute a mesh over the MPI ranks
 * with PT-Scotch and write the distributed set.
 *
 *   mpiexec -n P padapt partition IN -out OUT [-overlap K] [-check]
 *
 * IN is a sequential mesh (read on rank 0, scattered, partitioned) or a
 * distributed set written by any number of ranks. Writes OUT.<r>.meshb for
 * every rank and OUT.pvtu (see docs/design/DMESH.md), then prints the owned elements
 * per rank, the imbalance (max / mean) and the edge cut (faces between
 * elements of different ranks). -check runs the collective check of the
 * distributed mesh. With -v 2, each rank reports its time and peak memory per
 * step. The set is written in one output transaction per rank: all of its
 * files, or (on any error, or on SIGINT/SIGTERM) none, with the files of a
 * previous set of the same name left as they were.
 */
#include "cli.h"

#include <stddef.h>
#include <stdlib.h>
#include <string.h>

/* The arguments of `padapt partition`. */
typedef struct partition_args {
  const char *in, *out;
  int overlap, check;
} partition_args;

#define P(f) offsetof(partition_args, f)
/* One ghost layer: the halo of a stencil of face or vertex neighbours. */
#define OVERLAP_DEFAULT 1

static const pa_cli_opt partition_opts[] = {
    {.kind = PA_CLI_HELP, .label = "IN",
     .help = "mesh file, or distributed set OUT.meshb (OUT.<r>.meshb)"},
    {.names = "-out", .kind = PA_CLI_STR, .at = P(out), .want = "a set name",
     .label = "-out OUT",
     .help = "output set: OUT.<rank>.meshb, OUT.manifest, and\n"
             "OUT.<rank>.vtu + OUT.pvtu for ParaView"},
    {.names = "-overlap", .kind = PA_CLI_INT, .at = P(overlap),
     .want = "an integer in [0, 8]", .lo = 0, .hi = 8, .label = "-overlap K",
     .help = "ghost element layers kept in memory (default "
             PA_CLI_TEXT(OVERLAP_DEFAULT) ")"},
    {.names = "-check", .kind = PA_CLI_FLAG, .at = P(check), .label = "-check",
     .help = "check the distributed mesh (collective)"},
    {.kind = PA_CLI_END}};

static int partition_positional(const pa_cli *cli, const char *arg,
                                void *args) {
  partition_args *a = args;
  if (a->in)
    return pa_cli_error(cli, "partition: unexpected argument '%s'", arg);
  a->in = arg;
  return 0;
}

static const pa_cli_spec partition_spec = {
    .cmd = "partition",
    .usage = "usage: mpiexec -n P padapt partition IN -out OUT [-overlap K] "
             "[-check]\n",
    .width = 13,
    .opt = partition_opts,
    .positional = partition_positional};

/* Step report: wall time and peak memory of every rank, printed by rank 0. */
static void report(const pa_cli *cli, const char *step, double t) {
  if (cli->verbosity < 2) return;
  double v[3] = {t, (double)pa_memory_peak() / 1048576.0,
                 (double)pa_peak_rss() / 1048576.0};
  double *all = cli->rank == 0 ? malloc(sizeof v * cli->size) : NULL;
  MPI_Gather(v, 3, MPI_DOUBLE, all, 3, MPI_DOUBLE, 0, cli->comm);
  if (cli->rank == 0) {
    for (int r = 0; r < cli->size; r++)
      printf("timing: %-10s rank %d: %8.3f s, padapt peak %8.1f MB, "
             "process peak RSS %8.1f MB\n",
             step, r, all[3 * r], all[3 * r + 1], all[3 * r + 2]);
    free(all);
  }
}

int pa_cli_partition(const pa_cli *cli, int argc, char **argv) {
  partition_args args = {NULL, NULL, OVERLAP_DEFAULT, 0};
  int prc = pa_cli_parse(cli, &partition_spec, argc, argv, &args);
  if (prc) return prc > 0 ? 1 : 0;
  const char *in = args.in, *out = args.out;
  int overlap = args.overlap, check = args.check;
  if (!in || !out) {
    if (cli->rank == 0) pa_cli_help(&partition_spec, stderr);
    return 1;
  }
  pa_cli_io io = {.in = {in}, .set = out};
  if (pa_cli_check_io(cli, "partition", &io)) return 1;
  pa_dmesh *dm = NULL;
  pa_gid *nel = NULL;
  double imb = 0, t;
  pa_gid cut = 0;
  int rc = 0;
  t = pa_wtime();
  /* a sequential file as every command reads one (boundary completed,
   * checked) and then distributed; a set by every rank */
  int is_set = cli->rank == 0 ? pa_dmesh_is_set(in) : 0;
  MPI_Bcast(&is_set, 1, MPI_INT, 0, cli->comm);
  pa_status st;
  if (is_set) {
    st = pa_dmesh_read(cli->comm, in, overlap, &dm);
  } else {
    pa_mesh *mesh = NULL;
    st = pa_cli_read_mesh(cli, in, &mesh); /* collective */
    int bad = st != PA_SUCCESS;
    MPI_Bcast(&bad, 1, MPI_INT, 0, cli->comm);
    if (bad) {
      pa_mesh_destroy(mesh);
      return cli->rank == 0 ? pa_cli_fail(cli, st) : 1;
    }
    st = pa_dmesh_distribute(cli->comm, 0, mesh, overlap, &dm);
    pa_mesh_destroy(mesh);
  }
  report(cli, "distribute", pa_wtime() - t);
  if (st) return pa_cli_fail(cli, st);
  if (check) {
    t = pa_wtime();
    st = pa_dmesh_check(dm);
    report(cli, "check", pa_wtime() - t);
    if (st) {
      rc = pa_cli_fail(cli, st);
      goto done;
    }
  }
  nel = malloc(sizeof *nel * (size_t)cli->size);
  t = pa_wtime();
  st = pa_dmesh_partition_stats(dm, nel, &imb, &cut);
  report(cli, "stats", pa_wtime() - t);
  if (st) {
    rc = pa_cli_fail(cli, st);
    goto done;
  }
  t = pa_wtime();
  pa_output *tx = NULL;
  st = pa_output_begin(&tx);
  if (st == PA_SUCCESS) st = pa_dmesh_write(dm, out);
  st = pa_cli_output_end(cli->comm, tx, st);
  report(cli, "write", pa_wtime() - t);
  if (st) {
    rc = pa_cli_fail(cli, st);
    goto done;
  }
  if (cli->rank == 0) {
    printf("partition: %lld elements, %lld vertices on %d ranks (overlap %d)\n",
           (long long)pa_dmesh_nglobal(dm, PA_ELEMENT),
           (long long)pa_dmesh_nglobal(dm, PA_VERTEX), cli->size, overlap);
    for (int r = 0; r < cli->size; r++)
      printf("  rank %d: %lld elements\n", r, (long long)nel[r]);
    printf("imbalance: %.4f\nedge cut: %lld\n", imb, (long long)cut);
    printf("wrote %s (%d rank files and a .pvtu)\n", out, cli->size);
  }
done:
  free(nel);
  pa_dmesh_destroy(dm);
  return rc;
}
