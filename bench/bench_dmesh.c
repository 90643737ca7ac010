/*
 * bench_dmesh.c -- benchmark of the distributed mesh (issue #5): read on rank
 * 0, distribute (scatter + PT-Scotch + migration + ghosts), redistribution
 * (PT-Scotch on the distributed weighted dual graph, with the weighted
 * imbalance and edge cut it gives), halo exchange and reduction bandwidth
 * for vertex fields of 6, 48 and 192 doubles, the locality reorderings
 * (Hilbert, Scotch: time, and an element kernel's time in each numbering).
 * Prints the time and the peak memory of every rank per step (verbosity 2:
 * the library's step split).
 *
 *   mpiexec -n P bench_dmesh MESH [overlap] [verbosity]
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
      printf("%-16s rank %d: %8.3f s   padapt peak %8.1f MB   RSS peak %8.1f MB\n",
             step, r, all[3 * r], all[3 * r + 1], all[3 * r + 2]);
  fflush(stdout);
  free(all);
  pa_memory_reset_peak();
}

/* Locality of the local numbering: best time over 10 sweeps of a kernel
 * that reads every local element's vertex coordinates (sum of edge lengths
 * squared), and the mean index distance between an element's vertices. */
static void locality(pa_dmesh *dm, double *best, double *spread) {
  pa_mesh *m = pa_dmesh_mesh(dm);
  const double *x = pa_mesh_coords(m);
  const pa_idx *el = pa_mesh_elems(m);
  pa_idx ne = pa_mesh_nelem(m);
  double sp = 0, acc = 0;
  *best = 1e30;
  for (pa_idx e = 0; e < ne; e++) {
    pa_idx lo = el[4 * e], hi = el[4 * e];
    for (int j = 1; j < 4; j++) {
      lo = el[4 * e + j] < lo ? el[4 * e + j] : lo;
      hi = el[4 * e + j] > hi ? el[4 * e + j] : hi;
    }
    sp += hi - lo;
  }
  for (int r = 0; r < 10; r++) {
    double t = MPI_Wtime();
    for (pa_idx e = 0; e < ne; e++)
      for (int i = 0; i < 4; i++)
        for (int j = i + 1; j < 4; j++)
          for (int c = 0; c < 3; c++) {
            double d = x[3 * el[4 * e + i] + c] - x[3 * el[4 * e + j] + c];
            acc += d * d;
          }
    t = MPI_Wtime() - t;
    *best = t < *best ? t : *best;
  }
  *spread = ne ? sp / ne : 0;
  if (acc < 0) printf("%g\n", acc); /* keep the kernel */
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
  pa_set_verbosity(argc > 3 ? atoi(argv[3]) : 1);
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

  /* halo bandwidth: double vertex fields of 6 (a 3D metric), 48 and 192
   * components, so that the larger exchanges measure bandwidth, not latency */
  const int ncomps[3] = {6, 48, 192};
  for (int c = 0; c < 3; c++) {
    int nc = ncomps[c];
    pa_dmesh_value *v = NULL;
    if ((st = pa_dmesh_value_add(dm, PA_VERTEX, "halo", MPI_DOUBLE, nc, -1, &v))) die(st);
    pa_idx n, nown;
    double *d = pa_dmesh_value_data(v, &n, &nown);
    for (size_t i = 0; i < (size_t)n * nc; i++) d[i] = (double)i;
    long long ghosts = n - nown, allghosts;
    MPI_Allreduce(&ghosts, &allghosts, 1, MPI_LONG_LONG, MPI_SUM, MPI_COMM_WORLD);
    int iters = nc > 48 ? 10 : 30;
    double hmin = 1e30, hsum = 0, rmin = 1e30, rsum = 0, bytes = allghosts * 8.0 * nc;
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
      printf("halo %3d doubles: %lld ghost vertices, %.1f MB per exchange: best "
             "%.2f ms (%.2f GB/s), mean %.2f ms (%.2f GB/s); reduce(sum) best "
             "%.2f ms (%.2f GB/s), mean %.2f ms\n", nc, allghosts, bytes / 1e6,
             hmin * 1e3, bytes / hmin / 1e9, hsum / iters * 1e3,
             bytes / (hsum / iters) / 1e9, rmin * 1e3, bytes / rmin / 1e9,
             rsum / iters * 1e3);
    if ((st = pa_dmesh_value_remove(dm, v))) die(st);
  }
  pa_memory_reset_peak();

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
    /* quality: weighted imbalance and edge cut of the new partition */
    ne = pa_dmesh_nowned(dm, PA_ELEMENT);
    x = pa_mesh_coords(pa_dmesh_mesh(dm));
    el = pa_mesh_elems(pa_dmesh_mesh(dm));
    double wl = 0, wmax, wsum;
    for (pa_idx e = 0; e < ne; e++) wl += x[3 * el[4 * e]] < 0.5 ? 2.0 : 1.0;
    MPI_Allreduce(&wl, &wmax, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
    MPI_Allreduce(&wl, &wsum, 1, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
    pa_gid cut;
    if ((st = pa_dmesh_partition_stats(dm, NULL, NULL, &cut))) die(st);
    if (rank == 0)
      printf("redistributed: weighted imbalance %.4f, edge cut %lld\n",
             wmax * size / wsum, (long long)cut);
    free(w);
  }
  uint64_t sum;
  t = MPI_Wtime();
  if ((st = pa_dmesh_checksum(dm, &sum))) die(st);
  report("checksum", MPI_Wtime() - t);

  /* locality reordering: build order, Hilbert, Scotch */
  for (int o = 0; o < 3; o++) {
    double kt, sp;
    t = MPI_Wtime();
    if (o == 1 && (st = pa_dmesh_reorder_by(dm, PA_ORDER_HILBERT))) die(st);
    if (o == 2 && (st = pa_dmesh_reorder_by(dm, PA_ORDER_SCOTCH))) die(st);
    double tr = MPI_Wtime() - t;
    if (o) report(o == 1 ? "reorder hilbert" : "reorder scotch", tr);
    locality(dm, &kt, &sp);
    if (rank == 0)
      printf("numbering %-8s: element kernel best %.3f s, mean vertex index "
             "spread per element %.0f (rank 0)\n",
             o == 0 ? "build" : o == 1 ? "hilbert" : "scotch", kt, sp);
  }
  pa_dmesh_destroy(dm);
  MPI_Finalize();
  return 0;
}
