/*
 * test_adapt_pieces.c -- steps 1-2 of the parallel adaptation (internal
 * API, src/adapt/adapt.h): tagging and pieces. The labels and frozen marks
 * of every owned element are gathered on pa_test_rank 0 and checked by brute force
 * against the invariants: pieces are disjoint and cover the tagged elements,
 * every element sharing a vertex with a tagged one is labelled, and a
 * labelled element is frozen exactly when it is required or one of its
 * vertices touches an element of another label or of none (so every vertex
 * a piece shares with the outside lies on a frozen element). With one piece,
 * no tagged element is frozen. Runs at any number of ranks.
 */
#include "testutil.h"
#include "adapt/adapt.h"

#include <mpi.h>


/* Gather (label, frozen, tagged, required, vertex gids) of the owned
 * elements and check the invariants on pa_test_rank 0. */
static void check_labels(pa__iter *it) {
  pa_dmesh *dm = it->dm;
  int nve = it->nve, w = 4 + nve;
  long long *mine = malloc(sizeof(long long) * (size_t)w * (it->ne + 1));
  const pa_idx *el = pa_mesh_elems(pa_dmesh_mesh(dm));
  const uint8_t *fl = pa_mesh_elem_flags(pa_dmesh_mesh(dm));
  const pa_gid *vg = pa_dmesh_gids(dm, PA_VERTEX);
  for (pa_idx e = 0; e < it->ne; e++) {
    long long *r = mine + (size_t)w * e;
    r[0] = it->label[e];
    r[1] = it->frozen[e];
    r[2] = it->tag[e];
    r[3] = (fl[e] & PA_FLAG_REQUIRED) != 0;
    for (int k = 0; k < nve; k++) r[4 + k] = vg[el[nve * e + k]];
  }
  int cnt = (int)(it->ne * w), *counts = NULL, *displs = NULL, total = 0;
  if (pa_test_rank == 0) {
    counts = malloc(sizeof(int) * pa_test_size);
    displs = malloc(sizeof(int) * pa_test_size);
  }
  MPI_Gather(&cnt, 1, MPI_INT, counts, 1, MPI_INT, 0, MPI_COMM_WORLD);
  long long *all = NULL;
  if (pa_test_rank == 0) {
    for (int r = 0; r < pa_test_size; r++) {
      displs[r] = total;
      total += counts[r];
    }
    all = malloc(sizeof(long long) * (total + 1));
  }
  MPI_Gatherv(mine, cnt, MPI_LONG_LONG, all, counts, displs, MPI_LONG_LONG, 0,
              MPI_COMM_WORLD);
  if (pa_test_rank == 0) {
    int ne = total / w;
    pa_gid nv = pa_dmesh_nglobal(dm, PA_VERTEX) + 1, maxg = 0;
    for (int e = 0; e < ne; e++)
      for (int k = 0; k < nve; k++)
        if (all[(size_t)w * e + 4 + k] > maxg) maxg = all[(size_t)w * e + 4 + k];
    nv = maxg + 1;
    /* per vertex: min and max label (unlabelled = INT_MAX), tagged nearby */
    long long *vmin = malloc(sizeof(long long) * nv), *vmax = malloc(sizeof(long long) * nv);
    char *vtag = calloc((size_t)nv, 1);
    for (pa_gid v = 0; v < nv; v++) {
      vmin[v] = 1LL << 40;
      vmax[v] = -1;
    }
    int bad_cover = 0, bad_frozen = 0, bad_grow = 0, nfree_tagged = 0, nfrozen_tagged = 0;
    for (int e = 0; e < ne; e++) {
      const long long *r = all + (size_t)w * e;
      long long l = r[0] < 0 ? (1LL << 40) : r[0];
      bad_cover += r[2] && r[0] < 0;
      for (int k = 0; k < nve; k++) {
        long long v = r[4 + k];
        if (l < vmin[v]) vmin[v] = l;
        if (l > vmax[v]) vmax[v] = l;
        if (r[2]) vtag[v] = 1;
      }
    }
    for (int e = 0; e < ne; e++) {
      const long long *r = all + (size_t)w * e;
      int near_tag = 0, mixed = 0;
      for (int k = 0; k < nve; k++) {
        long long v = r[4 + k];
        near_tag |= vtag[v];
        mixed |= vmin[v] != r[0] || vmax[v] != r[0];
      }
      bad_grow += near_tag && r[0] < 0;
      if (r[0] >= 0) bad_frozen += r[1] != (mixed || r[3]);
      else bad_frozen += r[1] != 0;
      if (r[2]) {
        nfree_tagged += !r[1];
        nfrozen_tagged += r[1];
      }
    }
    CHECK(bad_cover == 0);
    CHECK(bad_grow == 0);
    CHECK(bad_frozen == 0);
    CHECK(nfree_tagged > 0);
    if (it->npieces == 1) CHECK(nfrozen_tagged == 0);
    printf("  %d pieces: %d tagged free, %d tagged frozen\n", it->npieces,
           nfree_tagged, nfrozen_tagged);
    free(vmin);
    free(vmax);
    free(vtag);
  }
  free(mine);
  free(counts);
  free(displs);
  free(all);
}

static void run(int dim, int n, const char *metric, int npieces, int layers) {
  pa_mesh *m = NULL;
  pa_dmesh *dm = NULL;
  pa_dmesh_value *done = NULL;
  pa_adapt_opts o;
  pa__iter it;
  memset(&it, 0, sizeof it);
  if (pa_test_rank == 0) {
    CHECK_OK(pa_mesh_generate_box(dim, n, &m));
    CHECK_OK(pa_metric_analytic(m, metric));
    /* a few required elements */
    for (pa_idx e = 0; e < pa_mesh_nelem(m); e += 17)
      pa_mesh_elem_flags(m)[e] |= PA_FLAG_REQUIRED;
  }
  CHECK_OK(pa_dmesh_distribute(MPI_COMM_WORLD, 0, m, 0, &dm));
  pa_adapt_opts_default(&o);
  o.min_piece_work = 1;
  o.min_piece_ratio = 0;
  o.skin_layers = layers;
  CHECK_OK(pa_dmesh_value_add(dm, PA_ELEMENT, PA__DONE_VALUE, MPI_UINT8_T, 1,
                              -1, &done));
  it.dm = dm;
  it.opts = &o;
  it.rank = pa_test_rank;
  it.size = pa_test_size;
  it.dim = dim;
  it.nve = dim + 1;
  CHECK_OK(pa__adapt_tag(&it, done, 1));
  CHECK(it.ntagged > 0);
  CHECK_OK(pa__adapt_pieces(&it, npieces));
  CHECK(it.npieces == npieces);
  check_labels(&it);
  pa__iter_free(&it);
  CHECK_OK(pa_dmesh_value_remove(dm, done));
  pa_dmesh_destroy(dm);
  pa_mesh_destroy(m);
}

static void test_pieces_2d(void) {
  run(2, 16, "iso-shell:0.1", 2 * pa_test_size, 2);
  run(2, 16, "iso-shell:0.1", 1, 1);
  run(2, 16, "uniform:0.02", 3 * pa_test_size, 1);
}

static void test_pieces_3d(void) {
  run(3, 5, "iso-shell:0.2", 2 * pa_test_size, 2);
  run(3, 5, "iso-shell:0.2", 1, 2);
}

TEST_MPI_MAIN(test_pieces_2d, test_pieces_3d)
