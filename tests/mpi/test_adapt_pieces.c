/*
 * test_adapt_pieces.c -- steps 1-2 of the parallel adaptation (internal
 * API, src/adapt/piece.h): tagging and pieces. The labels of every owned
 * element, and the label ranges and inner marks of every local vertex, are
 * gathered on pa_test_rank 0 and checked by brute force against the
 * invariants: pieces are disjoint and cover the tagged elements, every
 * element sharing a vertex with a tagged one is labelled unless it is
 * required (required elements never are), the smallest and largest label
 * around each vertex (of all elements, and of the tagged ones) are those
 * the elements give, every copy of a vertex (owner and ghosts) agrees, and
 * exactly the elements within the skin layers of the iteration (first or
 * later) are labelled, a vertex is inner only when labelled elements alone
 * touch it (and always
 * then, for a vertex inside the box), never on a curved boundary (a box
 * whose top is bent), where it is a surface vertex exactly when labelled
 * elements alone touch it off the top's rim (in 3D; 2D has none). Runs at
 * any number of ranks.
 */
#include "testutil.h"
#include "adapt/piece.h"

#include <math.h>
#include <mpi.h>

/* Gather rows of w long longs from every rank on rank 0; *n receives the
 * number of rows there. */
static long long *gather_rows(const long long *mine, int nrow, int w, int *n) {
  int cnt = nrow * w, *counts = NULL, *displs = NULL, total = 0;
  long long *all = NULL;
  if (pa_test_rank == 0) {
    counts = malloc(sizeof(int) * pa_test_size);
    displs = malloc(sizeof(int) * pa_test_size);
  }
  MPI_Gather(&cnt, 1, MPI_INT, counts, 1, MPI_INT, 0, MPI_COMM_WORLD);
  if (pa_test_rank == 0) {
    for (int r = 0; r < pa_test_size; r++) {
      displs[r] = total;
      total += counts[r];
    }
    all = malloc(sizeof(long long) * (total + 1));
  }
  MPI_Gatherv(mine, cnt, MPI_LONG_LONG, all, counts, displs, MPI_LONG_LONG, 0,
              MPI_COMM_WORLD);
  *n = total / w;
  free(counts);
  free(displs);
  return all;
}

/* The top face z = 1 (y = 1 in 2D) is bent into a curve by warp(): the
 * skins must not be bisected there. */
static int warp;
static int sparse = 0; /* a few user-tagged elements (run_iter) */
static double small_work; /* min_piece_work if > 0 (else 1) */

static double bump(double x) { return 1.0 + 0.05 * sin(3.141592653589793 * x); }

static void warp_mesh(pa_mesh *m, int dim) {
  double *x = pa_mesh_coords(m);
  for (pa_idx v = 0; v < pa_mesh_nvert(m); v++) {
    double *p = x + (size_t)dim * v;
    p[dim - 1] *= bump(p[0]);
  }
}

static int on_curved_top(const double *p, int dim) {
  return warp && p[0] > 0 && p[0] < 1 && fabs(p[dim - 1] - bump(p[0])) < 1e-12;
}

/* The number of skin layers the pieces grew (pieces.c): skin_layers in the
 * first iteration, skin_layers_later after. */
static int layers_of(const pa__iter *it) {
  int l = it->iter > 1 ? it->opts->skin_layers_later : it->opts->skin_layers;
  return l > 0 ? l : 1;
}

static void check_labels(pa__iter *it) {
  pa_dmesh *dm = it->dm;
  pa_mesh *m = pa_dmesh_mesh(dm);
  int nve = it->nve, w = 3 + nve, wv = 10;
  pa_idx nloc = pa_dmesh_nlocal(dm, PA_VERTEX);
  long long *mine = malloc(sizeof(long long) * (size_t)w * (it->ne + 1));
  long long *vmine = malloc(sizeof(long long) * (size_t)wv * (nloc + 1));
  const pa_idx *el = pa_mesh_elems(m);
  const uint8_t *fl = pa_mesh_elem_flags(m);
  const double *x = pa_mesh_coords(m);
  const pa_gid *vg = pa_dmesh_gids(dm, PA_VERTEX);
  for (pa_idx e = 0; e < it->ne; e++) {
    long long *r = mine + (size_t)w * e;
    r[0] = it->label[e];
    r[1] = it->tag[e];
    r[2] = (fl[e] & PA_FLAG_REQUIRED) != 0;
    for (int k = 0; k < nve; k++) r[3 + k] = vg[el[nve * e + k]];
  }
  for (pa_idx v = 0; v < nloc; v++) {
    long long *r = vmine + (size_t)wv * v;
    int nb = 0;
    for (int k = 0; k < it->dim; k++) {
      double c = x[(size_t)it->dim * v + k];
      nb += c == 0.0 || c == 1.0;
    }
    r[0] = vg[v];
    for (int k = 0; k < 4; k++) r[1 + k] = it->vlab[4 * v + k];
    r[5] = it->vinner[v] == PA_ADAPT_INNER_TRANSIT;
    r[8] = it->vinner[v] == PA_ADAPT_LABELLED_TRANSIT;
    r[9] = it->vinner[v] == PA_ADAPT_SURFACE_TRANSIT;
    r[6] = nb;
    r[7] = on_curved_top(x + (size_t)it->dim * v, it->dim);
  }
  int ne = 0, nvr = 0;
  long long *all = gather_rows(mine, (int)it->ne, w, &ne);
  long long *vall = gather_rows(vmine, (int)nloc, wv, &nvr);
  if (pa_test_rank == 0) {
    pa_gid nv = 0;
    for (int e = 0; e < ne; e++)
      for (int k = 0; k < nve; k++)
        if (all[(size_t)w * e + 3 + k] + 1 > nv) nv = all[(size_t)w * e + 3 + k] + 1;
    /* per vertex: min and max label (unlabelled = PA_ADAPT_NOLABEL), the same
     * over the tagged elements, tagged nearby */
    long long *lo = malloc(sizeof(long long) * nv), *hi = malloc(sizeof(long long) * nv);
    long long *tlo = malloc(sizeof(long long) * nv), *thi = malloc(sizeof(long long) * nv);
    char *vtag = calloc((size_t)nv, 1);
    for (pa_gid v = 0; v < nv; v++) {
      lo[v] = tlo[v] = PA_ADAPT_NOLABEL;
      hi[v] = thi[v] = -PA_ADAPT_NOLABEL;
    }
    int bad_cover = 0, bad_grow = 0, bad_req = 0, bad_range = 0, bad_inner = 0;
    int ninner = 0, ncurved = 0, nlabelled = 0, nsurface = 0;
    for (int e = 0; e < ne; e++) {
      const long long *r = all + (size_t)w * e;
      long long l = r[0] < 0 ? PA_ADAPT_NOLABEL : r[0];
      bad_cover += r[1] && r[0] < 0;
      bad_req += r[2] && r[0] >= 0;
      for (int k = 0; k < nve; k++) {
        long long v = r[3 + k];
        if (l < lo[v]) lo[v] = l;
        if (l > hi[v]) hi[v] = l;
        if (r[1]) {
          vtag[v] = 1;
          if (l < tlo[v]) tlo[v] = l;
          if (l > thi[v]) thi[v] = l;
        }
      }
    }
    for (int e = 0; e < ne; e++) {
      const long long *r = all + (size_t)w * e;
      int near_tag = 0;
      for (int k = 0; k < nve; k++) near_tag |= vtag[r[3 + k]];
      bad_grow += near_tag && r[0] < 0 && !r[2];
    }
    /* exactly the elements within layers_of(it) vertex layers of the
     * tagged ones are labelled (required elements neither are nor pass a
     * layer on) */
    int bad_layers = 0;
    {
      char *lab = calloc((size_t)ne + 1, 1), *vm = calloc((size_t)nv + 1, 1);
      for (int e = 0; e < ne; e++) lab[e] = all[(size_t)w * e + 1] != 0;
      /* the layers, then more while the pieces average fewer than
       * min_piece_work elements and a layer adds some (at most 12) */
      double want = (double)it->npieces * it->opts->min_piece_work;
      int last = -1, nextra = 0;
      for (int l = 0;; l++) {
        if (l >= layers_of(it)) {
          int cnt = 0;
          for (int e = 0; e < ne; e++) cnt += lab[e];
          if (nextra == 12 || cnt >= want || cnt == last) break;
          last = cnt;
          nextra++;
        }
        memset(vm, 0, (size_t)nv);
        for (int e = 0; e < ne; e++)
          if (lab[e])
            for (int k = 0; k < nve; k++) vm[all[(size_t)w * e + 3 + k]] = 1;
        for (int e = 0; e < ne; e++) {
          const long long *r = all + (size_t)w * e;
          for (int k = 0; k < nve && !lab[e] && !r[2]; k++)
            if (vm[r[3 + k]]) lab[e] = 2; /* 2: this layer */
        }
        for (int e = 0; e < ne; e++) lab[e] = lab[e] != 0;
      }
      for (int e = 0; e < ne; e++) bad_layers += lab[e] != (all[(size_t)w * e] >= 0);
      if (nextra) printf("  %d layers more around small pieces\n", nextra);
      free(lab);
      free(vm);
    }
    for (int i = 0; i < nvr; i++) {
      const long long *r = vall + (size_t)wv * i;
      long long v = r[0];
      bad_range += r[1] != lo[v] || r[2] != hi[v] || r[3] != tlo[v] || r[4] != thi[v];
      int labelled = hi[v] != PA_ADAPT_NOLABEL;
      bad_inner += r[5] && (!labelled || r[7]);
      bad_inner += !r[5] && labelled && r[6] == 0 && !r[7];
      /* on the smooth part of the bent top (off its rim), in 3D */
      bad_inner += r[9] != (it->dim == 3 && labelled && r[7] && r[6] == 0);
      /* labelled only, not inner: skin edges towards an inner vertex only */
      bad_inner += r[8] != (labelled && !r[5] && !r[9]);
      nlabelled += r[8] != 0;
      nsurface += r[9] != 0;
      ncurved += r[7] != 0;
      ninner += r[5] != 0;
    }
    CHECK(bad_cover == 0);
    CHECK(bad_grow == 0);
    CHECK(bad_layers == 0);
    CHECK(bad_req == 0);
    CHECK(bad_range == 0);
    CHECK(bad_inner == 0);
    CHECK(ninner > 0);
    if (!sparse) CHECK(nlabelled > 0); /* sparse tags may miss the sides */
    if (warp) CHECK(ncurved > 0 && (nsurface > 0) == (it->dim == 3));
    int ntag = 0, nlab = 0;
    for (int e = 0; e < ne; e++) {
      ntag += all[(size_t)w * e + 1] != 0;
      nlab += all[(size_t)w * e] >= 0;
    }
    printf("  %d pieces, %d skin layers: %d elements (%d tagged, %d "
           "labelled), %d vertex copies, %d inner, %d labelled only, %d on a "
           "curved boundary (%d surface)\n", it->npieces, layers_of(it), ne,
           ntag, nlab, nvr, ninner, nlabelled, ncurved, nsurface);
    free(lo);
    free(hi);
    free(tlo);
    free(thi);
    free(vtag);
  }
  free(mine);
  free(vmine);
  free(all);
  free(vall);
}

/* A run of steps 1-2 on a box with an analytic metric. */
typedef struct prun {
  pa_mesh *m;
  pa_dmesh *dm;
  pa_dmesh_value *done;
  pa_adapt_opts o;
  pa__iter it;
} prun;

/* Rank 0 makes the box (n cells a side) with its metric and applies prep
 * (if not NULL); then distribute and tag for iteration iter with layers skin
 * layers (skin_layers_later from the second iteration on), as the driver
 * does. Released by end_iter. */
static void start_iter(prun *r, int dim, int n, const char *metric,
                       void (*prep)(pa_mesh *, int), int layers, int iter) {
  memset(r, 0, sizeof *r);
  if (pa_test_rank == 0) {
    CHECK_OK(pa_mesh_generate_box(dim, n, &r->m));
    CHECK_OK(pa_metric_analytic(r->m, metric));
    if (prep) prep(r->m, dim);
  }
  CHECK_OK(pa_dmesh_distribute(MPI_COMM_WORLD, 0, r->m, 0, &r->dm));
  pa_adapt_opts_default(&r->o);
  r->o.min_piece_work = small_work > 0 ? small_work : 1;
  r->o.min_piece_ratio = 0;
  if (iter > 1) {
    r->o.skin_layers = 3; /* not these */
    r->o.skin_layers_later = layers;
  } else {
    r->o.skin_layers = layers;
  }
  CHECK_OK(pa_dmesh_value_add(r->dm, PA_ELEMENT, PA_ADAPT_DONE_VALUE,
                              MPI_UINT8_T, 1, -1, &r->done));
  pa__iter *it = &r->it;
  it->dm = r->dm;
  it->opts = &r->o;
  it->rank = pa_test_rank;
  it->size = pa_test_size;
  it->dim = dim;
  it->nve = dim + 1;
  it->iter = iter;
  CHECK_OK(pa__adapt_tag(it, r->done, 1));
  CHECK(it->ntagged > 0);
}

static void end_iter(prun *r) {
  pa__iter_free(&r->it);
  CHECK_OK(pa_dmesh_value_remove(r->dm, r->done));
  pa_dmesh_destroy(r->dm);
  pa_mesh_destroy(r->m);
}

/* The meshes of run_iter: warped (warp), a few required elements, and with
 * sparse a few user tags in a mesh that fits its metric, so that the skin
 * layers do not reach every element. */
static void prep_box(pa_mesh *m, int dim) {
  if (warp) warp_mesh(m, dim);
  for (pa_idx e = 0; e < pa_mesh_nelem(m); e += 17)
    pa_mesh_elem_flags(m)[e] |= PA_FLAG_REQUIRED;
  for (pa_idx e = 5; sparse && e < pa_mesh_nelem(m); e += 61)
    pa_mesh_elem_flags(m)[e] |= PA_FLAG_USER;
}

/* iter: the iteration the pieces are made for (1, or 2 for the layers of
 * the later iterations: layers then goes to skin_layers_later). */
static void run_iter(int dim, int n, const char *metric, int npieces,
                     int layers, int iter) {
  prun r;
  start_iter(&r, dim, n, metric, prep_box, layers, iter);
  CHECK_OK(pa__adapt_pieces(&r.it, npieces));
  CHECK(r.it.npieces == npieces);
  check_labels(&r.it);
  end_iter(&r);
}

static void run(int dim, int n, const char *metric, int npieces, int layers) {
  run_iter(dim, n, metric, npieces, layers, 1);
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

/* Few tagged elements: exactly skin_layers (first iteration) or
 * skin_layers_later vertex layers are grown around them. The metrics fit
 * the boxes (edges and qualities in range): only the user tags count. */
static void test_pieces_layers(void) {
  sparse = 1;
  for (int layers = 1; layers <= 3; layers++)
    for (int iter = 1; iter <= 2; iter++) {
      run_iter(2, 16, "uniform:0.07", pa_test_size, layers, iter);
      run_iter(3, 5, "uniform:0.25", pa_test_size, layers, iter);
    }
  sparse = 0;
}

/* Small pieces grow wider: a few user tags in a box whose metric fits,
 * min_piece_work above what the nominal layers reach, so that more layers
 * are grown (up to the whole box on the 2D one). */
static void test_pieces_small(void) {
  sparse = 1;
  small_work = 600;
  run_iter(2, 16, "uniform:0.07", 1, 1, 1);
  run_iter(2, 16, "uniform:0.07", 1, 2, 2);
  run_iter(3, 5, "uniform:0.25", 1, 1, 1);
  small_work = 0;
  sparse = 0;
}

static void test_pieces_curved(void) {
  warp = 1;
  run(2, 16, "uniform:0.02", 2 * pa_test_size, 1);
  run(3, 5, "uniform:0.05", 2 * pa_test_size, 1);
  warp = 0;
}

/* The pieces balance the estimated work, not the element counts: a graded
 * metric (sizes 0.005 to 0.05 on a 40 x 40 box: of its 3 200 triangles,
 * more than 2 147 are tagged, their work varies by a factor over 10) in 2
 * pieces per rank. Until 2026-11-22 a
 * guard dropped the weights beyond 2147 tagged elements: the counts were
 * balanced and one piece had 1.6 times the mean work. */
static void test_pieces_weighted(void) {
  prun r;
  start_iter(&r, 2, 40, "iso-shell:0.05", NULL, 2, 1);
  pa__iter *it = &r.it;
  CHECK(it->ntagged > 2147);
  int np = 2 * pa_test_size;
  CHECK_OK(pa__adapt_pieces(it, np));
  CHECK(it->npieces == np);
  /* per piece: work and count of its tagged elements; the work range */
  double *w = calloc((size_t)np, sizeof *w), *c = calloc((size_t)np, sizeof *c);
  double wr[2] = {1e300, 1e300}; /* min, -max */
  for (pa_idx e = 0; e < it->ne; e++) {
    if (!it->tag[e]) continue;
    CHECK(it->label[e] >= 0 && it->label[e] < np);
    w[it->label[e]] += it->work[e];
    c[it->label[e]] += 1;
    wr[0] = fmin(wr[0], it->work[e]);
    wr[1] = fmin(wr[1], -it->work[e]);
  }
  MPI_Allreduce(MPI_IN_PLACE, w, np, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
  MPI_Allreduce(MPI_IN_PLACE, c, np, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
  MPI_Allreduce(MPI_IN_PLACE, wr, 2, MPI_DOUBLE, MPI_MIN, MPI_COMM_WORLD);
  double wsum = 0, wmax = 0, csum = 0, cmax = 0;
  for (int p = 0; p < np; p++) {
    wsum += w[p];
    wmax = fmax(wmax, w[p]);
    csum += c[p];
    cmax = fmax(cmax, c[p]);
  }
  if (pa_test_rank == 0)
    printf("weighted pieces: work %.3g-%.3g per element, max piece %.3f x "
           "mean work, %.3f x mean count\n",
           wr[0], -wr[1], wmax * np / wsum, cmax * np / csum);
  CHECK(-wr[1] > 10 * wr[0]); /* the work is far from uniform */
  CHECK(wmax <= 1.05 * wsum / np);
  /* and balancing it unbalances the counts (else the case proves nothing) */
  CHECK(cmax >= 1.1 * csum / np);
  free(w);
  free(c);
  end_iter(&r);
}

TEST_MPI_MAIN(test_pieces_2d, test_pieces_3d, test_pieces_layers,
              test_pieces_small, test_pieces_curved, test_pieces_weighted)
