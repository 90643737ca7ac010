/*
 * bench_scotch.c -- PT-Scotch strategies on a mesh's dual graph: time and
 * quality (edge cut, imbalance) of SCOTCH_dgraphPart into P parts, for the
 * default strategy and SCOTCH_stratDgraphMapBuild with SCOTCH_STRATQUALITY,
 * SPEED, BALANCE, SPEED|BALANCE (imbalance ratio, default 5 %), with unit
 * weights and with the 2:1 weights of bench_dmesh's redistribution (x < 0.5
 * weighs 2).
 *
 *   mpiexec -n R bench_scotch MESH [P] [repeats] [imbalance]
 *
 * Every rank reads MESH and holds a contiguous block of its elements (as
 * after pa_dmesh_distribute's scatter). Prints, per strategy, the best wall
 * time over the repeats, the process CPU time summed over the ranks (with
 * R = 1 it is the real work, immune to the other jobs of a loaded machine),
 * the edge cut and the (weighted) imbalance. Used to choose the strategy of
 * src/partition/partition.c (docs/design/DMESH.md). Built by bench/bench_dmesh.sh.
 */
#define _POSIX_C_SOURCE 200809L
#include "padapt.h"

#include <mpi.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include <scotch/ptscotch.h>

static double cpu_time(void) {
  struct timespec t;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

int main(int argc, char **argv) {
  int rank, size, provided;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_MULTIPLE, &provided);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  if (argc < 2) {
    if (rank == 0) fprintf(stderr, "usage: bench_scotch MESH [P] [repeats]\n");
    MPI_Finalize();
    return 1;
  }
  int nparts = argc > 2 ? atoi(argv[2]) : 2, reps = argc > 3 ? atoi(argv[3]) : 3;
  double balrat = argc > 4 ? atof(argv[4]) : 0.05;
  pa_mesh *m = NULL;
  const pa_idx *adja;
  if (pa_mesh_read(argv[1], &m) || pa_mesh_build_adjacency(m, &adja)) {
    fprintf(stderr, "rank %d: %s\n", rank, pa_last_error());
    MPI_Abort(MPI_COMM_WORLD, 1);
  }
  int d = pa_mesh_dim(m), nf = d + 1;
  pa_idx ne = pa_mesh_nelem(m);
  const pa_idx *el = pa_mesh_elems(m);
  const double *x = pa_mesh_coords(m);
  SCOTCH_Num lo = (SCOTCH_Num)((int64_t)ne * rank / size),
             hi = (SCOTCH_Num)((int64_t)ne * (rank + 1) / size), n = hi - lo;
  SCOTCH_Num *vert = malloc(sizeof *vert * (n + 1)),
             *edge = malloc(sizeof *edge * (size_t)n * nf),
             *velo = malloc(sizeof *velo * (n + 1)),
             *part = malloc(sizeof *part * (n + 1)),
             *all = malloc(sizeof *all * ne);
  int *cnts = malloc(sizeof *cnts * size), *displs = malloc(sizeof *displs * size);
  vert[0] = 0;
  for (SCOTCH_Num i = 0; i < n; i++) {
    SCOTCH_Num e = lo + i, k = vert[i];
    for (int j = 0; j < nf; j++)
      if (adja[(size_t)nf * e + j] >= 0) edge[k++] = adja[(size_t)nf * e + j] / nf;
    vert[i + 1] = k;
    velo[i] = x[(size_t)d * el[(size_t)nf * e]] < 0.5 ? 2 : 1;
  }
  for (int r = 0; r < size; r++) {
    displs[r] = (int)((int64_t)ne * r / size);
    cnts[r] = (int)((int64_t)ne * (r + 1) / size) - displs[r];
  }
  static const char *names[] = {"default", "quality", "speed", "balance",
                                "speed+balance"};
  static const SCOTCH_Num flags[] = {-1, SCOTCH_STRATQUALITY, SCOTCH_STRATSPEED,
                                     SCOTCH_STRATBALANCE,
                                     SCOTCH_STRATSPEED | SCOTCH_STRATBALANCE};
  if (rank == 0)
    printf("%d elements, %d parts on %d ranks, best of %d, imbalance ratio %.3f "
           "(built strategies)\n", (int)ne, nparts, size, reps, balrat);
  for (int w = 0; w < 2; w++)
    for (int s = 0; s < 5; s++) {
      double best = 1e30, cpu = 0;
      for (int r = 0; r < reps; r++) {
        SCOTCH_Dgraph g;
        SCOTCH_Strat st;
        SCOTCH_dgraphInit(&g, MPI_COMM_WORLD);
        SCOTCH_dgraphBuild(&g, 0, n, n, vert, NULL, w ? velo : NULL, NULL,
                           vert[n], vert[n], edge, NULL, NULL);
        SCOTCH_stratInit(&st);
        if (flags[s] >= 0)
          SCOTCH_stratDgraphMapBuild(&st, flags[s], nparts, nparts, balrat);
        MPI_Barrier(MPI_COMM_WORLD);
        double t = MPI_Wtime(), c = cpu_time();
        SCOTCH_dgraphPart(&g, nparts, &st, part);
        c = cpu_time() - c;
        t = MPI_Wtime() - t;
        MPI_Allreduce(MPI_IN_PLACE, &t, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
        MPI_Allreduce(MPI_IN_PLACE, &c, 1, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
        if (t < best) {
          best = t;
          cpu = c;
        }
        SCOTCH_stratExit(&st);
        SCOTCH_dgraphExit(&g);
      }
      /* quality of the last run */
      MPI_Allgatherv(part, (int)n, sizeof(SCOTCH_Num) == 8 ? MPI_INT64_T : MPI_INT32_T,
                     all, cnts, displs,
                     sizeof(SCOTCH_Num) == 8 ? MPI_INT64_T : MPI_INT32_T, MPI_COMM_WORLD);
      long long cut = 0;
      double *load = calloc((size_t)nparts, sizeof *load), lmax = 0, lsum = 0;
      for (pa_idx e = 0; e < ne; e++) {
        load[all[e]] += w ? (x[(size_t)d * el[(size_t)nf * e]] < 0.5 ? 2 : 1) : 1;
        for (int j = 0; j < nf; j++) {
          pa_idx a = adja[(size_t)nf * e + j];
          cut += a >= 0 && all[a / nf] != all[e];
        }
      }
      for (int p = 0; p < nparts; p++) {
        lsum += load[p];
        lmax = load[p] > lmax ? load[p] : lmax;
      }
      free(load);
      if (rank == 0)
        printf("%-5s weights, %-14s best %7.3f s, CPU %7.3f s, edge cut %8lld, "
               "imbalance %.4f\n", w ? "2:1" : "unit", names[s], best, cpu,
               cut / 2, lmax * nparts / lsum);
      fflush(stdout);
    }
  free(vert);
  free(edge);
  free(velo);
  free(part);
  free(all);
  free(cnts);
  free(displs);
  pa_mesh_destroy(m);
  MPI_Finalize();
  return 0;
}
