/*
 * api_adapt.c -- the library in one program (docs/guide/api.md): a mesh,
 * a metric from a function, a sequential remesh, then the same adaptation
 * on a distributed mesh, with a value exchanged between ranks, an iterator
 * and the error handling every padapt call needs.
 *
 *   mpiexec -n P ./api_adapt [IN.mesh]     (default: the unit square)
 *
 * Writes seq.mesh (the sequential result, rank 0) and the distributed set
 * dist.meshb (dist.<r>.meshb, dist.manifest, dist.pvtu). Exit status 0 on
 * success, 1 on any error; built and run at 1 and 2 processes by the tests
 * (example.api_adapt).
 */
#include <padapt.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

/* Every padapt function returns a pa_status; on failure pa_last_error()
 * names the file and line or the entity at fault. Collective functions
 * return the same status on every rank, so every rank takes the same
 * branch. */
#define CALL(call)                                                             \
  do {                                                                         \
    st = (call);                                                               \
    if (st != PA_SUCCESS) {                                                    \
      fprintf(stderr, "rank %d: %s: %s (%s)\n", rank, #call, pa_last_error(),  \
              pa_status_string(st));                                           \
      goto cleanup;                                                            \
    }                                                                          \
  } while (0)

/* The metric: a 2D tensor m11 m12 m22 per vertex (Medit's order), fine
 * across the line x = 0.5 (size 0.01 there, growing to 0.15) and 0.1 along
 * it; in 3D the same in x, 0.1 along y and z. */
static void metric_at(int dim, const double *x, double *m) {
  double hx = fmin(0.01 + 0.5 * fabs(x[0] - 0.5), 0.15), h = 0.1;
  if (dim == 2) {
    m[0] = 1 / (hx * hx), m[1] = 0, m[2] = 1 / (h * h);
  } else { /* m11 m12 m22 m13 m23 m33 */
    m[0] = 1 / (hx * hx), m[1] = 0, m[2] = 1 / (h * h);
    m[3] = 0, m[4] = 0, m[5] = 1 / (h * h);
  }
}

/* Set the metric of every vertex of mesh from metric_at. */
static pa_status set_metric(pa_mesh *mesh) {
  int dim = pa_mesh_dim(mesh), nc = dim == 2 ? 3 : 6;
  pa_idx nv = pa_mesh_nvert(mesh);
  const double *x = pa_mesh_coords(mesh);
  double *met = malloc(sizeof(double) * (size_t)nc * (nv ? nv : 1));
  if (!met) return PA_ERR_MEMORY;
  for (pa_idx v = 0; v < nv; v++)
    metric_at(dim, x + (size_t)dim * v, met + (size_t)nc * v);
  pa_status st = pa_mesh_set_metric(mesh, nc, met); /* copies met */
  free(met);
  return st;
}

/* Rank 0 alone: read or generate the input (*input), then the sequential
 * adaptation of a copy, written to seq.mesh. */
static pa_status sequential(int argc, char **argv, pa_mesh **input) {
  const int rank = 0;
  pa_status st = PA_SUCCESS;
  pa_mesh *mesh = NULL, *missing = NULL;
  pa_remesh_opts opts;
  pa_remesh_report rep;
  char line[256];

  /* 1. A mesh: read from a file, or generated. An error is a status and a
   * message, never an exit. */
  if (pa_mesh_read("no-such-file.mesh", &missing) != PA_SUCCESS)
    printf("expected error: %s\n", pa_last_error());
  pa_clear_error();
  if (argc > 1)
    CALL(pa_mesh_read(argv[1], input));
  else
    CALL(pa_mesh_generate_box(2, 8, input));
  CALL(pa_mesh_check(*input)); /* orientation, conformity, ... */

  /* 2. Metric from a function, remesh, write. */
  pa_remesh_opts_default(&opts); /* hgrad 1.3, hausd 0.01, as the CLI */
  CALL(pa_mesh_copy(*input, &mesh));
  CALL(set_metric(mesh));
  CALL(pa_remesh(pa_remesher_builtin(), mesh, &opts, &rep));
  if (rep.outcome == PA_REMESH_FAILED) { /* the mesh is as it was */
    fprintf(stderr, "remesh failed: %s\n", pa_last_error());
    st = PA_ERR_MESH;
    goto cleanup;
  }
  pa_fidelity_describe(&rep.fidelity, line, sizeof line);
  printf("sequential: %d -> %d elements, %s\n", (int)pa_mesh_nelem(*input),
         (int)pa_mesh_nelem(mesh), line);
  CALL(pa_mesh_write(mesh, "seq.mesh", NULL));
cleanup:
  pa_mesh_destroy(mesh);
  pa_mesh_destroy(missing);
  return st;
}

int main(int argc, char **argv) {
  int rank = 0, rc = 1;
  pa_status st = PA_SUCCESS;
  pa_mesh *input = NULL;
  pa_dmesh *dm = NULL;
  MPI_Init(&argc, &argv);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);

  /* 1-2. Sequential, on rank 0; the others learn whether it worked. */
  int failed = rank == 0 && sequential(argc, argv, &input) != PA_SUCCESS;
  MPI_Bcast(&failed, 1, MPI_INT, 0, MPI_COMM_WORLD);
  if (failed) goto cleanup;

  /* 3. Distributed: rank 0's mesh spread over every rank (PT-Scotch), one
   * ghost layer. Collective from here on. */
  CALL(pa_dmesh_distribute(MPI_COMM_WORLD, 0, input, 1, &dm));
  /* The metric on the local mesh (owned and ghost vertices): computed from
   * the coordinates, so every copy of a vertex gets the same value;
   * pa_dmesh_sync_mesh makes ghosts equal their owners in any case. */
  CALL(set_metric(pa_dmesh_mesh(dm)));
  CALL(pa_dmesh_sync_mesh(dm));

  pa_adapt_opts aopts;
  pa_adapt_report arep;
  pa_adapt_opts_default(&aopts); /* built-in remesher, 30 iterations */
  CALL(pa_dmesh_adapt(dm, &aopts, &arep));
  if (!arep.converged) /* stalled: valid mesh, some elements still off */
    fprintf(stderr, "rank %d: stalled, %lld elements still tagged\n", rank,
            (long long)arep.ntagged_left);

  /* 4. A value per vertex, owned copies set, ghosts updated by the halo
   * exchange; an iterator over the owned elements. */
  pa_dmesh_value *owner = NULL;
  pa_idx n = 0, nowned = 0, e;
  CALL(pa_dmesh_value_add(dm, PA_VERTEX, "owner", MPI_INT, 1, -1, &owner));
  int *who = pa_dmesh_value_data(owner, &n, &nowned);
  for (pa_idx v = 0; v < nowned; v++)
    who[v] = rank;
  CALL(pa_dmesh_halo(dm, owner));
  const int *owners = pa_dmesh_owners(dm, PA_VERTEX);
  int bad = 0;
  for (pa_idx v = 0; v < n; v++)
    bad += who[v] != owners[v];

  pa_dmesh_iter it;
  double area = 0;
  CALL(pa_dmesh_iter_init(dm, PA_ELEMENT, PA_OWNED, &it));
  while (pa_dmesh_iter_next(&it, &e))
    area += pa_mesh_elem_volume(pa_dmesh_mesh(dm), e);
  MPI_Allreduce(MPI_IN_PLACE, &area, 1, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
  MPI_Allreduce(MPI_IN_PLACE, &bad, 1, MPI_INT, MPI_SUM, MPI_COMM_WORLD);

  /* 5. Statistics, check and the distributed set. */
  pa_stats stats;
  CALL(pa_dmesh_stats(dm, &stats)); /* the same on every rank */
  CALL(pa_dmesh_check(dm));
  CALL(pa_dmesh_write(dm, "dist.meshb"));
  if (rank == 0)
    printf("distributed: %lld elements on %d ranks, %d iterations (%s), "
           "volume %.6f, %.1f %% of the edges in range, halo %s\n",
           (long long)stats.nelem, arep.nranks, arep.niter,
           arep.converged ? "converged" : "stalled", area,
           100.0 * (double)stats.edge_hist[PA_STATS_EDGE_NBIN - 1] /
               (double)stats.nedge,
           bad ? "WRONG" : "ok");
  rc = bad || !stats.valid || !arep.converged;

cleanup:
  pa_dmesh_destroy(dm); /* collective */
  pa_mesh_destroy(input);
  /* padapt counts its allocations: everything was freed */
  if (pa_memory_current() != 0) {
    fprintf(stderr, "rank %d: %zu bytes still allocated by padapt\n", rank,
            pa_memory_current());
    rc = 1;
  }
  /* every rank exits with the same status */
  MPI_Allreduce(MPI_IN_PLACE, &rc, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
  MPI_Finalize();
  return rc;
}
