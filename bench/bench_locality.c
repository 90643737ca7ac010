/*
 * bench_locality.c -- does a locality renumbering of the adapted mesh pay
 * (issue #21 item 3)? Adapt a 3D mesh in parallel (pa_dmesh_adapt) to a
 * constant size, write the result once as a distributed set, then for each
 * element ordering {as adapted, Hilbert, Scotch} re-read that set (same
 * number of ranks: every rank reads back its own part, owned elements and
 * vertices in the order the adaptation left them; the fingerprint printed
 * at the start checks it), renumber it (pa_dmesh_reorder_by, timed) and
 * time what follows on it:
 *   - a halo exchange (pa_dmesh_halo, synchronous) of a vertex value of 6
 *     and of 48 doubles, R calls, each timed (their median);
 *   - a solver-like sweep over the owned elements, R times: "gather" reads
 *     the four vertices' coordinates and a vertex value and sums volume x
 *     mean value; "assemble" also adds that to a vertex residual (scatter);
 *     each sweep timed (their median);
 *   - the next adaptation of that mesh to a second size (default 0.8 x the
 *     first: more refinement), with its remesh and reintegrate steps.
 * Every ordering starts from the same mesh (the re-read set; the
 * order-independent checksum printed per run shows it). The orderings are
 * interleaved within each repetition (rotated, so none always runs first)
 * and medians with [min, max] over the repetitions are printed: on a shared
 * machine single runs say little. Times are the maximum over the ranks.
 * Also printed, as load-independent measures: the mean spread of vertex
 * indices within an element (max - min) and the number of distinct 64-byte
 * lines of coordinates an element sweep touches per element (cold-cache
 * estimate: new lines compared with the previous element's four).
 *
 *   mpiexec -n P bench_locality [-mesh M] [-hsiz H] [-hsiz2 H2] [-reps K]
 *                               [-r R] [-overlap O] [-work DIR] [-v N]
 *
 * Built by bench/bench_locality.sh with mpicc against build/lib/libpadapt.so.
 */
#include "padapt.h"

#include <mpi.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define NORDER 3
#define NMEAS 11
static const char *order_name[NORDER] = {"adapted", "hilbert", "scotch"};
static const char *meas_name[NMEAS] = {
    "reorder", "halo6", "halo48", "gather", "assemble", "adapt",
    "adapt.remesh", "adapt.reint", "adapt.other", "spread", "lines/elem"};
static int rank, size;

static void die(pa_status st, const char *what) {
  fprintf(stderr, "rank %d: %s: %s\n", rank, what, pa_last_error());
  MPI_Abort(MPI_COMM_WORLD, (int)st);
}

static double maxall(double x) {
  MPI_Allreduce(MPI_IN_PLACE, &x, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
  return x;
}

static int cmp_double(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

/* Median of n values (sorts them). */
static double median(double *v, int n) {
  qsort(v, (size_t)n, sizeof *v, cmp_double);
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/* FNV-1a of the global ids of the owned elements in local order, folded over
 * the ranks in rank order: equal only for the same owned numbering. */
static uint64_t order_fingerprint(pa_dmesh *dm) {
  const pa_gid *g = pa_dmesh_gids(dm, PA_ELEMENT);
  pa_idx n = pa_dmesh_nowned(dm, PA_ELEMENT);
  uint64_t h = 1469598103934665603ull;
  for (pa_idx e = 0; e < n; e++) h = (h ^ (uint64_t)g[e]) * 1099511628211ull;
  uint64_t *all = malloc(sizeof *all * size);
  MPI_Allgather(&h, 1, MPI_UINT64_T, all, 1, MPI_UINT64_T, MPI_COMM_WORLD);
  h = 1469598103934665603ull;
  for (int r = 0; r < size; r++) h = (h ^ all[r]) * 1099511628211ull;
  free(all);
  return h;
}

/* Structural locality of the owned elements (rank mean over the ranks):
 * mean vertex index spread within an element, and mean number of 64-byte
 * lines of coordinates (24 bytes per vertex) an element needs that the
 * previous element did not touch. */
static void structure(pa_dmesh *dm, double *spread, double *lines) {
  pa_mesh *m = pa_dmesh_mesh(dm);
  const pa_idx *el = pa_mesh_elems(m);
  pa_idx ne = pa_dmesh_nowned(dm, PA_ELEMENT);
  double sp = 0, nl = 0;
  long prev[8];
  int nprev = 0;
  for (pa_idx e = 0; e < ne; e++) {
    const pa_idx *v = el + 4 * (size_t)e;
    pa_idx lo = v[0], hi = v[0];
    long cur[8];
    int ncur = 0;
    for (int i = 0; i < 4; i++) {
      lo = v[i] < lo ? v[i] : lo;
      hi = v[i] > hi ? v[i] : hi;
      long a = (long)v[i] * 24 / 64, b = ((long)v[i] * 24 + 23) / 64;
      for (long l = a; l <= b; l++) {
        int seen = 0;
        for (int k = 0; k < ncur; k++) seen |= cur[k] == l;
        if (!seen) cur[ncur++] = l;
      }
    }
    for (int k = 0; k < ncur; k++) {
      int seen = 0;
      for (int j = 0; j < nprev; j++) seen |= prev[j] == cur[k];
      nl += !seen;
    }
    memcpy(prev, cur, sizeof cur);
    nprev = ncur;
    sp += hi - lo;
  }
  double v[2] = {ne ? sp / ne : 0, ne ? nl / ne : 0};
  MPI_Allreduce(MPI_IN_PLACE, v, 2, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
  *spread = v[0] / size;
  *lines = v[1] / size;
}

/* Median time of one synchronous halo exchange of a vertex value of nc
 * doubles over r calls (max over the ranks). */
static double time_halo(pa_dmesh *dm, int nc, int r) {
  pa_dmesh_value *val = NULL;
  pa_status st;
  if ((st = pa_dmesh_value_add(dm, PA_VERTEX, "bench", MPI_DOUBLE, nc, -1, &val)))
    die(st, "value_add");
  pa_idx n, nown;
  double *d = pa_dmesh_value_data(val, &n, &nown);
  for (size_t i = 0; i < (size_t)nown * nc; i++) d[i] = (double)i;
  if ((st = pa_dmesh_halo(dm, val))) die(st, "halo"); /* warm up */
  double *t = malloc(sizeof *t * r);
  MPI_Barrier(MPI_COMM_WORLD);
  for (int k = 0; k < r; k++) {
    t[k] = MPI_Wtime();
    if ((st = pa_dmesh_halo(dm, val))) die(st, "halo");
    t[k] = MPI_Wtime() - t[k];
  }
  if ((st = pa_dmesh_value_remove(dm, val))) die(st, "value_remove");
  double med = median(t, r);
  free(t);
  return maxall(med);
}

/* Median time of one sweep over the owned elements over r sweeps (max over
 * the ranks):
 * volume x mean vertex value summed (gather), and with scatter = 1 also
 * added to a vertex residual (assembly). */
static double time_sweep(pa_dmesh *dm, int scatter, int r, double *out) {
  pa_mesh *m = pa_dmesh_mesh(dm);
  const double *x = pa_mesh_coords(m);
  const pa_idx *el = pa_mesh_elems(m);
  pa_idx ne = pa_dmesh_nowned(dm, PA_ELEMENT);
  pa_idx nv = pa_dmesh_nlocal(dm, PA_VERTEX);
  double *u = malloc(sizeof *u * (nv + 1)), *res = calloc(nv + 1, sizeof *res);
  const pa_gid *vg = pa_dmesh_gids(dm, PA_VERTEX);
  for (pa_idx v = 0; v < nv; v++) u[v] = 1.0 + (double)(vg[v] % 7);
  double acc = 0, *t = malloc(sizeof *t * r), t0 = 0;
  for (int k = -1; k < r; k++) { /* k = -1: warm up, not timed */
    if (k >= 0) t0 = MPI_Wtime();
    for (pa_idx e = 0; e < ne; e++) {
      const pa_idx *v = el + 4 * (size_t)e;
      const double *p0 = x + 3 * (size_t)v[0], *p1 = x + 3 * (size_t)v[1];
      const double *p2 = x + 3 * (size_t)v[2], *p3 = x + 3 * (size_t)v[3];
      double a[3], b[3], c[3];
      for (int i = 0; i < 3; i++) {
        a[i] = p1[i] - p0[i];
        b[i] = p2[i] - p0[i];
        c[i] = p3[i] - p0[i];
      }
      double vol = (a[0] * (b[1] * c[2] - b[2] * c[1]) -
                    a[1] * (b[0] * c[2] - b[2] * c[0]) +
                    a[2] * (b[0] * c[1] - b[1] * c[0])) / 6.0;
      double w = vol * 0.25 * (u[v[0]] + u[v[1]] + u[v[2]] + u[v[3]]);
      acc += w;
      if (scatter)
        for (int i = 0; i < 4; i++) res[v[i]] += 0.25 * w;
    }
    if (k >= 0) t[k] = MPI_Wtime() - t0;
  }
  *out = acc + res[nv / 2];
  double med = median(t, r);
  free(u);
  free(res);
  free(t);
  return maxall(med);
}

int main(int argc, char **argv) {
  int provided;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_MULTIPLE, &provided);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  const char *mesh = "tests/data/rod3d.mesh", *work = "/tmp/padapt-bench-locality";
  double hsiz = 0.03, hsiz2 = 0;
  int reps = 3, r = 50, overlap = 1, verb = 0;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!strcmp(argv[i], "-mesh")) mesh = argv[i + 1];
    else if (!strcmp(argv[i], "-hsiz")) hsiz = atof(argv[i + 1]);
    else if (!strcmp(argv[i], "-hsiz2")) hsiz2 = atof(argv[i + 1]);
    else if (!strcmp(argv[i], "-reps")) reps = atoi(argv[i + 1]);
    else if (!strcmp(argv[i], "-r")) r = atoi(argv[i + 1]);
    else if (!strcmp(argv[i], "-overlap")) overlap = atoi(argv[i + 1]);
    else if (!strcmp(argv[i], "-work")) work = argv[i + 1];
    else if (!strcmp(argv[i], "-v")) verb = atoi(argv[i + 1]);
    else {
      if (rank == 0) fprintf(stderr, "bench_locality: unknown option %s\n", argv[i]);
      MPI_Abort(MPI_COMM_WORLD, 1);
    }
  }
  if (hsiz2 <= 0) hsiz2 = 0.8 * hsiz;
  if (reps < 1) reps = 1;
  if (r < 1) r = 1;
  pa_set_verbosity(verb);
  char set[4096];
  snprintf(set, sizeof set, "%s/adapted-np%d.meshb", work, size);
  pa_status st;
  pa_dmesh *dm = NULL;
  pa_adapt_opts opts;
  pa_adapt_report rep;

  /* the starting mesh: adapt once, write it as a set */
  if ((st = pa_dmesh_read(MPI_COMM_WORLD, mesh, overlap, &dm))) die(st, mesh);
  pa_adapt_opts_default(&opts);
  opts.remesh.hsiz = hsiz;
  if ((st = pa_dmesh_adapt(dm, &opts, &rep))) die(st, "adapt");
  uint64_t fp_adapted = order_fingerprint(dm), sum0;
  if ((st = pa_dmesh_checksum(dm, &sum0))) die(st, "checksum");
  if ((st = pa_dmesh_write(dm, set))) die(st, set);
  if (rank == 0)
    printf("%s -hsiz %g on %d ranks, overlap %d: %lld tetrahedra, %lld "
           "vertices in %.1f s; written to %s\n", mesh, hsiz, size, overlap,
           (long long)rep.nelem_final, (long long)rep.nvert_final,
           rep.time_total, set);
  pa_dmesh_destroy(dm);
  dm = NULL;

  double *meas = calloc((size_t)NORDER * NMEAS * reps, sizeof *meas);
  long long nafter[NORDER] = {0};
#define M(o, q, k) meas[((size_t)(o) * NMEAS + (q)) * reps + (k)]
  for (int k = 0; k < reps; k++) {
    for (int j = 0; j < NORDER; j++) {
      int o = (j + k) % NORDER;
      if ((st = pa_dmesh_read(MPI_COMM_WORLD, set, overlap, &dm))) die(st, set);
      uint64_t sum, fp = order_fingerprint(dm);
      if ((st = pa_dmesh_checksum(dm, &sum))) die(st, "checksum");
      if (k == 0 && o == 0 && rank == 0)
        printf("re-read set: owned element order %s the adapted one, "
               "checksum %s\n", fp == fp_adapted ? "equals" : "DIFFERS FROM",
               sum == sum0 ? "equal" : "DIFFERS");
      MPI_Barrier(MPI_COMM_WORLD);
      double t = MPI_Wtime();
      if (o && (st = pa_dmesh_reorder_by(dm, o == 1 ? PA_ORDER_HILBERT
                                                    : PA_ORDER_SCOTCH)))
        die(st, "reorder");
      M(o, 0, k) = maxall(MPI_Wtime() - t);
      structure(dm, &M(o, 9, k), &M(o, 10, k));
      M(o, 1, k) = time_halo(dm, 6, r);
      M(o, 2, k) = time_halo(dm, 48, r);
      double sink1, sink2;
      M(o, 3, k) = time_sweep(dm, 0, r, &sink1);
      M(o, 4, k) = time_sweep(dm, 1, r, &sink2);
      if (sink1 + sink2 == -1.0) printf("%g\n", sink1); /* keep the sweeps */
      pa_adapt_opts_default(&opts);
      opts.remesh.hsiz = hsiz2;
      if ((st = pa_dmesh_adapt(dm, &opts, &rep))) die(st, "next adapt");
      M(o, 5, k) = rep.time_total;
      M(o, 6, k) = rep.t_remesh;
      M(o, 7, k) = rep.t_reintegrate;
      M(o, 8, k) = rep.time_total - rep.t_remesh - rep.t_reintegrate;
      nafter[o] = (long long)rep.nelem_final;
      if (rank == 0) {
        printf("rep %d %-7s: reorder %.3f s, halo6 %.3f ms, halo48 %.3f ms, "
               "gather %.2f ms, assemble %.2f ms, next adapt %.1f s (remesh "
               "%.1f, reintegrate %.1f) -> %lld tets in %d iterations\n",
               k, order_name[o], M(o, 0, k), 1e3 * M(o, 1, k),
               1e3 * M(o, 2, k), 1e3 * M(o, 3, k), 1e3 * M(o, 4, k),
               M(o, 5, k), M(o, 6, k), M(o, 7, k), nafter[o], rep.niter);
        fflush(stdout);
      }
      pa_dmesh_destroy(dm);
      dm = NULL;
    }
  }
  if (rank == 0) {
    printf("\nmedian [min, max] over %d repetitions, %d ranks (times: max "
           "over ranks; halo and sweeps in ms per call, reorder and adapt "
           "in s)\n%-13s", reps, size, "");
    for (int o = 0; o < NORDER; o++) printf(" %-27s", order_name[o]);
    printf("\n");
    for (int q = 0; q < NMEAS; q++) {
      double scale = q >= 1 && q <= 4 ? 1e3 : 1;
      printf("%-13s", meas_name[q]);
      for (int o = 0; o < NORDER; o++) {
        double *v = &M(o, q, 0);
        double med = median(v, reps); /* sorts: v[0] min, v[reps-1] max */
        printf(" %8.3f [%7.3f, %7.3f]", scale * med, scale * v[0],
               scale * v[reps - 1]);
      }
      printf("\n");
    }
    printf("%-13s", "tets after");
    for (int o = 0; o < NORDER; o++) printf(" %-27lld", nafter[o]);
    printf("\n");
  }
#undef M
  free(meas);
  MPI_Finalize();
  return 0;
}
