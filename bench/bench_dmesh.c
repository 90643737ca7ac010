/*
 * bench_dmesh.c -- benchmark of the distributed mesh (issue #5): read on rank
 * 0, distribute (scatter + PT-Scotch + migration + ghosts), redistribution
 * (PT-Scotch on the distributed weighted dual graph), halo exchange
 * bandwidth. Prints the time and the peak memory of every rank per step.
 *
 *   mpiexec -n P bench_dmesh MESH [overlap]
 *
 * Built by bench/bench_dmesh.sh with mpicc against build/lib/libpadapt.so.
 */
#include "padapt.h"

#include <mpi.h>
#include <stdio.h>
#include <stdlib.h>

static int rank, size;

/* Print time, padapt peak and process peak RSS of every rank for a step. */
static void report(const char *step, double t) {
  double v[3] = {t, (double)pa_memory_peak() / 1048576.0,
                 (double)pa_peak_rss() / 1048576.0};
  double *all = malloc(sizeof v * size);
  MPI_Gather(v, 3, MPI_DOUBLE, all, 3, MPI_DOUBLE, 0, MPI_COMM_WORLD);
  if (rank == 0)
    for (int r = 0; r < size; r++)
      printf("%-14s rank %d: %8.3f s   padapt peak %8.1f MB   RSS peak %8.1f MB\n",
             step, r, all[3 * r], all[3 * r + 1], all[3 * r + 2]);
  fflush(stdout);
  free(all);
  pa_memory_reset_peak();
}

static void die(pa_status st) {
  fprintf(stderr, "rank %d: %s\n", rank, pa_last_error());
  MPI_Abort(MPI_COMM_WORLD, (int)st);
}

int main(int argc, char **argv) {
  int provided;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_MULTIPLE, &provided);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  if (argc < 2) {
    if (rank == 0) fprintf(stderr, "usage: bench_dmesh MESH [overlap]\n");
    MPI_Finalize();
    return 1;
  }
  int overlap = argc > 2 ? atoi(argv[2]) : 1;
  pa_set_verbosity(1);
  pa_mesh *m = NULL;
  pa_dmesh *dm = NULL;
  pa_status st;
  double t;

  MPI_Barrier(MPI_COMM_WORLD);
  t = MPI_Wtime();
  if (rank == 0 && (st = pa_mesh_read(argv[1], &m))) die(st);
  report("read", MPI_Wtime() - t);
  if (rank == 0)
    printf("mesh: %d vertices, %d elements, %d boundary entities\n",
           pa_mesh_nvert(m), pa_mesh_nelem(m), pa_mesh_nbdry(m));

  MPI_Barrier(MPI_COMM_WORLD);
  t = MPI_Wtime();
  if ((st = pa_dmesh_distribute(MPI_COMM_WORLD, 0, m, overlap, &dm))) die(st);
  report("distribute", MPI_Wtime() - t);
  pa_mesh_destroy(m);
  m = NULL;
  {
    pa_gid *nel = malloc(sizeof *nel * size), cut;
    double imb;
    if ((st = pa_dmesh_partition_stats(dm, nel, &imb, &cut))) die(st);
    if (rank == 0) {
      printf("partition:");
      for (int r = 0; r < size; r++) printf(" %lld", (long long)nel[r]);
      printf(" elements, imbalance %.4f, edge cut %lld\n", imb, (long long)cut);
    }
    free(nel);
  }
  printf("rank %d: %d owned + %d ghost elements, %d owned + %d ghost vertices, "
         "dmesh %.1f MB\n", rank, pa_dmesh_nowned(dm, PA_ELEMENT),
         pa_dmesh_nlocal(dm, PA_ELEMENT) - pa_dmesh_nowned(dm, PA_ELEMENT),
         pa_dmesh_nowned(dm, PA_VERTEX),
         pa_dmesh_nlocal(dm, PA_VERTEX) - pa_dmesh_nowned(dm, PA_VERTEX),
         (double)pa_dmesh_memory_used(dm) / 1048576.0);
  fflush(stdout);
  pa_memory_reset_peak();

  /* halo bandwidth: a 6-component double vertex field (a 3D metric) */
  pa_dmesh_value *v = NULL;
  if ((st = pa_dmesh_value_add(dm, PA_VERTEX, "met", MPI_DOUBLE, 6, -1, &v))) die(st);
  pa_idx n, nown;
  double *d = pa_dmesh_value_data(v, &n, &nown);
  for (pa_idx i = 0; i < n * 6; i++) d[i] = i;
  long long ghosts = n - nown, allghosts;
  MPI_Allreduce(&ghosts, &allghosts, 1, MPI_LONG_LONG, MPI_SUM, MPI_COMM_WORLD);
  int iters = 50;
  double hmin = 1e30, hsum = 0, rmin = 1e30, rsum = 0;
  for (int k = 0; k < iters; k++) {
    MPI_Barrier(MPI_COMM_WORLD);
    t = MPI_Wtime();
    if ((st = pa_dmesh_halo(dm, v))) die(st);
    MPI_Barrier(MPI_COMM_WORLD);
    double th = MPI_Wtime() - t;
    t = MPI_Wtime();
    if ((st = pa_dmesh_reduce(dm, v, MPI_SUM))) die(st);
    MPI_Barrier(MPI_COMM_WORLD);
    double tr = MPI_Wtime() - t;
    hsum += th;
    rsum += tr;
    hmin = th < hmin ? th : hmin;
    rmin = tr < rmin ? tr : rmin;
  }
  if (rank == 0)
    printf("halo: %lld ghost vertices x 48 B = %.1f MB per exchange: best %.2f ms "
           "(%.2f GB/s), mean %.2f ms (%.2f GB/s); reduce(sum) best %.2f ms, "
           "mean %.2f ms\n", allghosts, allghosts * 48 / 1e6, hmin * 1e3,
           allghosts * 48 / hmin / 1e9, hsum / iters * 1e3,
           allghosts * 48 / (hsum / iters) / 1e9, rmin * 1e3, rsum / iters * 1e3);

  /* redistribution: PT-Scotch on weights that double on half the box */
  {
    pa_idx ne = pa_dmesh_nowned(dm, PA_ELEMENT);
    double *w = malloc(sizeof *w * (ne + 1));
    const double *x = pa_mesh_coords(pa_dmesh_mesh(dm));
    const pa_idx *el = pa_mesh_elems(pa_dmesh_mesh(dm));
    for (pa_idx e = 0; e < ne; e++) w[e] = x[3 * el[4 * e]] < 0.5 ? 2.0 : 1.0;
    MPI_Barrier(MPI_COMM_WORLD);
    t = MPI_Wtime();
    if ((st = pa_dmesh_redistribute(dm, NULL, w))) die(st);
    report("redistribute", MPI_Wtime() - t);
    free(w);
  }
  uint64_t sum;
  t = MPI_Wtime();
  if ((st = pa_dmesh_checksum(dm, &sum))) die(st);
  report("checksum", MPI_Wtime() - t);
  pa_dmesh_destroy(dm);
  MPI_Finalize();
  return 0;
}
