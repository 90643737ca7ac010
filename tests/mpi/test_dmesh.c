/*
 * test_dmesh.c -- distributed mesh: distribution from a root, ghosts, halo
 * exchange (sync and async) of global ids and multi-component fields,
 * reductions, iterators, gather, checksum independence of the number of
 * ranks, reordering, redistribution round trips, bad input, the checks
 * (whole and of an adaptation's result) and MPI errors.
 * Runs at any number of ranks.
 */
#include "testutil.h"
#include "dmesh/dmesh.h"
#include "dmesh/exchange.h"
#include "metric/metric.h"

#include <mpi.h>

static int rank, size;

/* A 2D or 3D box on rank 0 (NULL elsewhere). */
static pa_mesh *box_on_root(int dim, int n) {
  pa_mesh *m = NULL;
  if (rank == 0) CHECK_OK(pa_mesh_generate_box(dim, n, &m));
  return m;
}

/* The checksum of a mesh distributed on MPI_COMM_SELF (one rank). */
static uint64_t serial_checksum(int dim, int n) {
  pa_mesh *m = NULL;
  pa_dmesh *dm = NULL;
  uint64_t sum = 0;
  CHECK_OK(pa_mesh_generate_box(dim, n, &m));
  CHECK_OK(pa_dmesh_distribute(MPI_COMM_SELF, 0, m, 0, &dm));
  if (dm) CHECK_OK(pa_dmesh_checksum(dm, &sum));
  pa_dmesh_destroy(dm);
  pa_mesh_destroy(m);
  return sum;
}

/* Every owned entity of every kind is owned once over the ranks, and the
 * owned gids cover [0, nglobal). */
static void check_owned_once(pa_dmesh *dm) {
  for (int k = 0; k < 4; k++) {
    pa_dmesh_iter it;
    pa_idx i;
    pa_gid ng = pa_dmesh_nglobal(dm, (pa_entity)k);
    int *seen = calloc((size_t)ng + 1, sizeof *seen);
    const pa_gid *g = pa_dmesh_gids(dm, (pa_entity)k);
    CHECK_OK(pa_dmesh_iter_init(dm, (pa_entity)k, PA_OWNED, &it));
    while (pa_dmesh_iter_next(&it, &i)) {
      CHECK(g[i] >= 0 && g[i] < ng);
      if (g[i] >= 0 && g[i] < ng) seen[g[i]]++;
    }
    MPI_Allreduce(MPI_IN_PLACE, seen, (int)ng, MPI_INT, MPI_SUM, MPI_COMM_WORLD);
    int bad = 0;
    for (pa_gid q = 0; q < ng; q++) bad += seen[q] != 1;
    CHECK(bad == 0);
    free(seen);
    /* interior + frontier = owned, disjoint */
    pa_dmesh_iter a, b;
    CHECK_OK(pa_dmesh_iter_init(dm, (pa_entity)k, PA_INTERIOR, &a));
    CHECK_OK(pa_dmesh_iter_init(dm, (pa_entity)k, PA_FRONTIER, &b));
    CHECK(pa_dmesh_iter_count(&a) + pa_dmesh_iter_count(&b) ==
          pa_dmesh_nowned(dm, (pa_entity)k));
    pa_idx ng_ = 0;
    CHECK_OK(pa_dmesh_iter_init(dm, (pa_entity)k, PA_GHOST, &it));
    while (pa_dmesh_iter_next(&it, &i)) {
      CHECK(pa_dmesh_owners(dm, (pa_entity)k)[i] != rank);
      ng_++;
    }
    CHECK(ng_ == pa_dmesh_nlocal(dm, (pa_entity)k) - pa_dmesh_nowned(dm, (pa_entity)k));
  }
}

/* Halo of the global ids of every kind (int64, sync) and of a 3-component
 * double field from the coordinates (async, with work in between). */
static void check_halo(pa_dmesh *dm) {
  for (int k = 0; k < 4; k++) {
    pa_dmesh_value *v = NULL;
    char name[32];
    snprintf(name, sizeof name, "gid%d", k);
    CHECK_OK(pa_dmesh_value_add(dm, (pa_entity)k, name, MPI_INT64_T, 1, -1, &v));
    if (!v) continue;
    pa_idx n, nown;
    int64_t *d = pa_dmesh_value_data(v, &n, &nown);
    const pa_gid *g = pa_dmesh_gids(dm, (pa_entity)k);
    CHECK(n == pa_dmesh_nlocal(dm, (pa_entity)k));
    for (pa_idx i = 0; i < n; i++) d[i] = i < nown ? g[i] : -1;
    CHECK_OK(pa_dmesh_halo(dm, v));
    int bad = 0;
    for (pa_idx i = 0; i < n; i++) bad += d[i] != g[i];
    CHECK(bad == 0);
    CHECK_OK(pa_dmesh_value_remove(dm, v));
  }
  int dim = pa_dmesh_dim(dm);
  pa_dmesh_value *x = NULL;
  CHECK_OK(pa_dmesh_value_add(dm, PA_VERTEX, "x3", MPI_DOUBLE, 3, -1, &x));
  if (!x) return;
  pa_idx n, nown;
  double *d = pa_dmesh_value_data(x, &n, &nown);
  const double *c = pa_mesh_coords(pa_dmesh_mesh(dm));
  for (pa_idx i = 0; i < n; i++)
    for (int j = 0; j < 3; j++)
      d[3 * i + j] = i < nown ? c[dim * i + j % dim] * (j + 1) + 1 : -99;
  CHECK_OK(pa_dmesh_halo_begin(dm, x));
  /* work on interior vertices while the messages fly */
  pa_dmesh_iter it;
  pa_idx i;
  double acc = 0;
  CHECK_OK(pa_dmesh_iter_init(dm, PA_VERTEX, PA_INTERIOR, &it));
  while (pa_dmesh_iter_next(&it, &i)) acc += d[3 * i];
  CHECK(acc >= 0);
  CHECK(pa_dmesh_halo_begin(dm, x) == PA_ERR_ARG); /* already in flight */
  CHECK_OK(pa_dmesh_halo_end(dm, x));
  int bad = 0;
  for (pa_idx q = 0; q < n; q++)
    for (int j = 0; j < 3; j++)
      bad += d[3 * q + j] != c[dim * q + j % dim] * (j + 1) + 1;
  CHECK(bad == 0);
  CHECK_OK(pa_dmesh_value_remove(dm, x));
}

/* Reductions: SUM of ones counts the copies; MIN/MAX of the holding rank. */
static void check_reduce(pa_dmesh *dm) {
  pa_dmesh_value *one = NULL, *mn = NULL, *mx = NULL;
  CHECK_OK(pa_dmesh_value_add(dm, PA_VERTEX, "one", MPI_INT, 1, -1, &one));
  CHECK_OK(pa_dmesh_value_add(dm, PA_VERTEX, "mn", MPI_INT, 1, -1, &mn));
  CHECK_OK(pa_dmesh_value_add(dm, PA_VERTEX, "mx", MPI_INT, 2, -1, &mx));
  if (!one || !mn || !mx) return;
  pa_idx n, nown;
  int *a = pa_dmesh_value_data(one, &n, &nown);
  int *b = pa_dmesh_value_data(mn, NULL, NULL);
  int *c = pa_dmesh_value_data(mx, NULL, NULL);
  for (pa_idx i = 0; i < n; i++) {
    a[i] = 1;
    b[i] = rank;
    c[2 * i] = rank;
    c[2 * i + 1] = -rank;
  }
  CHECK_OK(pa_dmesh_reduce(dm, one, MPI_SUM));
  CHECK_OK(pa_dmesh_reduce_begin(dm, mn));
  CHECK_OK(pa_dmesh_reduce_begin(dm, mx));
  CHECK_OK(pa_dmesh_reduce_end(dm, mx, MPI_MAX));
  CHECK_OK(pa_dmesh_reduce_end(dm, mn, MPI_MIN));
  long copies = 0, local = n;
  int bad = 0;
  for (pa_idx i = 0; i < nown; i++) {
    copies += a[i];
    bad += b[i] > rank || c[2 * i] < rank || c[2 * i + 1] < -rank;
  }
  CHECK(bad == 0);
  MPI_Allreduce(MPI_IN_PLACE, &copies, 1, MPI_LONG, MPI_SUM, MPI_COMM_WORLD);
  MPI_Allreduce(MPI_IN_PLACE, &local, 1, MPI_LONG, MPI_SUM, MPI_COMM_WORLD);
  CHECK(copies == local);
  /* after a halo, every copy knows the number of copies */
  CHECK_OK(pa_dmesh_halo(dm, one));
  bad = 0;
  for (pa_idx i = 0; i < n; i++) bad += a[i] < 1 || a[i] > size;
  CHECK(bad == 0);
  CHECK_OK(pa_dmesh_value_remove(dm, one));
  CHECK_OK(pa_dmesh_value_remove(dm, mn));
  CHECK_OK(pa_dmesh_value_remove(dm, mx));
}

/* g has in's vertices, elements and boundary entities, in order. */
static void check_same(pa_mesh *g, pa_mesh *in) {
  int d = pa_mesh_dim(in);
  CHECK(pa_mesh_nvert(g) == pa_mesh_nvert(in));
  CHECK(pa_mesh_nelem(g) == pa_mesh_nelem(in));
  CHECK(pa_mesh_nbdry(g) == pa_mesh_nbdry(in));
  if (pa_mesh_nvert(g) == pa_mesh_nvert(in) && pa_mesh_nelem(g) == pa_mesh_nelem(in) &&
      pa_mesh_nbdry(g) == pa_mesh_nbdry(in)) {
    CHECK(!memcmp(pa_mesh_coords(g), pa_mesh_coords(in),
                  sizeof(double) * d * pa_mesh_nvert(in)));
    CHECK(!memcmp(pa_mesh_elems(g), pa_mesh_elems(in),
                  sizeof(pa_idx) * (d + 1) * pa_mesh_nelem(in)));
    CHECK(!memcmp(pa_mesh_elem_refs(g), pa_mesh_elem_refs(in),
                  sizeof(int32_t) * pa_mesh_nelem(in)));
    CHECK(!memcmp(pa_mesh_bdrys(g), pa_mesh_bdrys(in),
                  sizeof(pa_idx) * d * pa_mesh_nbdry(in)));
    CHECK(!memcmp(pa_mesh_bdry_refs(g), pa_mesh_bdry_refs(in),
                  sizeof(int32_t) * pa_mesh_nbdry(in)));
  }
}

/* The mesh gathered on every rank in turn equals the input (numbered by
 * global id = input index; the box generated again where the root is not
 * rank 0, which holds the input): the root's own records join the others
 * unpacked, first, and the assembly orders them. */
static void check_gather(pa_dmesh *dm, pa_mesh *in0) {
  for (int root = 0; root < size; root++) {
    pa_mesh *g = NULL, *in = in0, *again = NULL;
    CHECK_OK(pa_dmesh_gather(dm, root, &g));
    if (rank != root) {
      CHECK(g == NULL);
      continue;
    }
    CHECK(g != NULL);
    if (!g) continue;
    if (root != 0) {
      int n = pa_mesh_dim(g) == 2 ? 12 : 5; /* as test_distribute */
      CHECK_OK(pa_mesh_generate_box(pa_mesh_dim(g), n, &again));
      in = again;
    }
    if (in) check_same(g, in);
    pa_mesh_destroy(again);
    pa_mesh_destroy(g);
  }
}

/* A vertex value of doubles gathered as a mesh field, at every root: each
 * gathered vertex carries the value its owner computed from its
 * coordinates (the root's own vertices and the others' take different
 * paths to the gathered mesh). */
static void check_gather_value(pa_dmesh *dm) {
  int dim = pa_dmesh_dim(dm);
  pa_dmesh_value *x = NULL;
  CHECK_OK(pa_dmesh_value_add(dm, PA_VERTEX, "f2", MPI_DOUBLE, 2, -1, &x));
  if (!x) return;
  pa_idx n, nown;
  double *d = pa_dmesh_value_data(x, &n, &nown);
  const double *c = pa_mesh_coords(pa_dmesh_mesh(dm));
  for (pa_idx i = 0; i < n; i++) {
    d[2 * i] = c[dim * i] + 2 * c[dim * i + 1];
    d[2 * i + 1] = 1 - c[dim * i + dim - 1];
  }
  for (int root = 0; root < size; root++) {
    pa_mesh *g = NULL;
    CHECK_OK(pa_dmesh_gather(dm, root, &g));
    if (rank != root || !g) continue;
    int k = pa_mesh_nfield(g) - 1, ncomp = 0;
    const char *name = NULL;
    double *val = NULL;
    CHECK(k >= 0);
    CHECK_OK(pa_mesh_field(g, k < 0 ? 0 : k, &name, &ncomp, &val));
    CHECK(name && !strcmp(name, "f2") && ncomp == 2 && val);
    const double *gc = pa_mesh_coords(g);
    int bad = 0;
    for (pa_idx v = 0; val && v < pa_mesh_nvert(g); v++)
      bad += val[2 * v] != gc[dim * v] + 2 * gc[dim * v + 1] ||
             val[2 * v + 1] != 1 - gc[dim * v + dim - 1];
    CHECK(bad == 0);
    pa_mesh_destroy(g);
  }
  CHECK_OK(pa_dmesh_value_remove(dm, x));
}

static void test_distribute(void) {
  for (int dim = 2; dim <= 3; dim++) {
    int n = dim == 2 ? 12 : 5;
    pa_mesh *in = box_on_root(dim, n);
    uint64_t ref = serial_checksum(dim, n);
    for (int overlap = 0; overlap <= 2; overlap++) {
      pa_dmesh *dm = NULL;
      CHECK_OK(pa_dmesh_distribute(MPI_COMM_WORLD, 0, in, overlap, &dm));
      if (!dm) continue;
      CHECK(pa_dmesh_overlap(dm) == overlap);
      CHECK_OK(pa_dmesh_check(dm));
      uint64_t sum = 0;
      CHECK_OK(pa_dmesh_checksum(dm, &sum));
      CHECK(sum == ref);
      check_owned_once(dm);
      check_halo(dm);
      check_reduce(dm);
      check_gather(dm, in);
      check_gather_value(dm);
      /* layers: every ghost of layer k has a vertex of layer k-1 */
      const uint8_t *lay = pa_dmesh_elem_layers(dm);
      int maxl = 0;
      for (pa_idx e = 0; e < pa_dmesh_nlocal(dm, PA_ELEMENT); e++)
        if (lay[e] > maxl) maxl = lay[e];
      CHECK(maxl <= overlap);
      if (size > 1 && overlap > 0) {
        int any = maxl == overlap;
        MPI_Allreduce(MPI_IN_PLACE, &any, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
        CHECK(any);
      }
      /* renumbered by locality, owned global ids no longer come in order:
       * the gather sorts them */
      CHECK_OK(pa_dmesh_reorder(dm));
      check_gather(dm, in);
      pa_dmesh_destroy(dm);
    }
    pa_mesh_destroy(in);
  }
}

/* Values of every kind survive redistribution and reordering; the checksum
 * (which covers the values) is unchanged. */
static void test_redistribute(void) {
  for (int dim = 2; dim <= 3; dim++) {
    pa_mesh *in = box_on_root(dim, dim == 2 ? 10 : 4);
    pa_dmesh *dm = NULL;
    CHECK_OK(pa_dmesh_distribute(MPI_COMM_WORLD, 0, in, 1, &dm));
    pa_mesh_destroy(in);
    if (!dm) continue;
    pa_dmesh_value *vx = NULL, *ve = NULL, *vb = NULL;
    CHECK_OK(pa_dmesh_value_add(dm, PA_VERTEX, "vx", MPI_DOUBLE, 2, -1, &vx));
    CHECK_OK(pa_dmesh_value_add(dm, PA_ELEMENT, "ve", MPI_INT64_T, 1, -1, &ve));
    CHECK_OK(pa_dmesh_value_add(dm, PA_BOUNDARY, "b3", MPI_FLOAT, 1, 3, &vb));
    if (!vx || !ve || !vb) {
      pa_dmesh_destroy(dm);
      continue;
    }
    for (int round = 0; round < 4; round++) {
      pa_idx n, nown;
      double *x = pa_dmesh_value_data(vx, &n, &nown);
      const double *c = pa_mesh_coords(pa_dmesh_mesh(dm));
      if (round == 0)
        for (pa_idx i = 0; i < n; i++) {
          x[2 * i] = c[dim * i] + 2 * c[dim * i + 1];
          x[2 * i + 1] = -c[dim * i + 1];
        }
      int bad = 0;
      for (pa_idx i = 0; i < n; i++)
        bad += x[2 * i] != c[dim * i] + 2 * c[dim * i + 1] || x[2 * i + 1] != -c[dim * i + 1];
      CHECK(bad == 0);
      int64_t *e = pa_dmesh_value_data(ve, &n, &nown);
      const pa_gid *eg = pa_dmesh_gids(dm, PA_ELEMENT);
      if (round == 0)
        for (pa_idx i = 0; i < n; i++) e[i] = 7 * eg[i] + 1;
      for (pa_idx i = 0; i < n; i++) bad += e[i] != 7 * eg[i] + 1;
      CHECK(bad == 0);
      float *b = pa_dmesh_value_data(vb, &n, &nown);
      const pa_idx *ent = pa_dmesh_value_entities(vb);
      const pa_gid *bg = pa_dmesh_gids(dm, PA_BOUNDARY);
      const int32_t *br = pa_mesh_bdry_refs(pa_dmesh_mesh(dm));
      if (round == 0)
        for (pa_idx i = 0; i < n; i++) b[i] = (float)bg[ent[i]] + 0.5f;
      for (pa_idx i = 0; i < n; i++) bad += b[i] != (float)bg[ent[i]] + 0.5f || br[ent[i]] != 3;
      CHECK(bad == 0);
      uint64_t before = 0, after = 0;
      CHECK_OK(pa_dmesh_checksum(dm, &before));
      if (round == 0) { /* shift every element to the next rank */
        pa_idx ne = pa_dmesh_nowned(dm, PA_ELEMENT);
        int *part = malloc(sizeof(int) * (ne + 1));
        for (pa_idx i = 0; i < ne; i++) part[i] = (rank + 1) % size;
        CHECK_OK(pa_dmesh_redistribute(dm, part, NULL));
        free(part);
      } else if (round == 1) { /* back with PT-Scotch, weighted */
        pa_idx ne = pa_dmesh_nowned(dm, PA_ELEMENT);
        double *w = malloc(sizeof(double) * (ne + 1));
        for (pa_idx i = 0; i < ne; i++) w[i] = 1.0 + (eg[i] % 3);
        CHECK_OK(pa_dmesh_redistribute(dm, NULL, w));
        free(w);
        /* balanced by weight (the loads once overflowed Scotch's sum) */
        double wl = 0, wmax = 0, wsum = 0;
        ne = pa_dmesh_nowned(dm, PA_ELEMENT);
        eg = pa_dmesh_gids(dm, PA_ELEMENT);
        for (pa_idx i = 0; i < ne; i++) wl += 1.0 + (eg[i] % 3);
        MPI_Allreduce(&wl, &wmax, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
        MPI_Allreduce(&wl, &wsum, 1, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
        CHECK(wmax * size / wsum < 1.15);
      } else if (round == 2) {
        CHECK_OK(pa_dmesh_reorder(dm));
      } else {
        CHECK_OK(pa_dmesh_reorder_by(dm, PA_ORDER_SCOTCH));
      }
      CHECK_OK(pa_dmesh_check(dm));
      CHECK_OK(pa_dmesh_checksum(dm, &after));
      CHECK(before == after);
    }
    pa_dmesh_destroy(dm);
  }
}

/* PT-Scotch balances weighted loads on a mesh large enough for the loads
 * to have overflowed Scotch's 32-bit sum (they were scaled to [1, 10^6]). */
/* pa_dmesh_rebalance (overlap 0 and 1): a band of elements (centroid
 * x < band) is moved to rank 0, then rebalanced: within the tolerance;
 * under 1.5 times the mean, by diffusion moving about the excess (not the
 * whole mesh), above by a PT-Scotch repartition; the mesh and its values
 * the same (checksum); a balanced mesh left alone. */
static void test_rebalance(void) {
  for (int c = 0; c < 4; c++) {
    int dim = 2 + c % 2;
    double band = c < 2 ? 0.08 : 0.45; /* a moderate and a large excess */
    pa_mesh *in = box_on_root(dim, dim == 2 ? 40 : 8);
    pa_dmesh *dm = NULL;
    /* 2D without ghosts (the adaptation's case), 3D with one layer */
    CHECK_OK(pa_dmesh_distribute(MPI_COMM_WORLD, 0, in, dim == 2 ? 0 : 1, &dm));
    pa_mesh_destroy(in);
    if (!dm) continue;
    pa_dmesh_value *ve = NULL;
    CHECK_OK(pa_dmesh_value_add(dm, PA_ELEMENT, "ve", MPI_INT64_T, 1, -1, &ve));
    if (ve) {
      pa_idx n, nown;
      int64_t *v = pa_dmesh_value_data(ve, &n, &nown);
      const pa_gid *eg = pa_dmesh_gids(dm, PA_ELEMENT);
      for (pa_idx i = 0; i < n; i++) v[i] = 3 * eg[i] + 2;
    }
    pa_idx ne = pa_dmesh_nowned(dm, PA_ELEMENT);
    const double *x = pa_mesh_coords(pa_dmesh_mesh(dm));
    int *part = malloc(sizeof(int) * (ne + 1));
    for (pa_idx e = 0; e < ne; e++) {
      const pa_idx *ev = pa_dmesh_elem_verts(dm, e);
      double cx = 0;
      for (int k = 0; k <= dim; k++) cx += x[dim * ev[k]] / (dim + 1);
      part[e] = cx < band ? 0 : rank;
    }
    CHECK_OK(pa_dmesh_redistribute(dm, part, NULL));
    free(part);
    uint64_t before = 0, after = 0;
    CHECK_OK(pa_dmesh_checksum(dm, &before));
    double imb;
    pa_gid cut0 = 0, cut = 0, cutscotch = 0;
    CHECK_OK(pa_dmesh_partition_stats(dm, NULL, &imb, &cut0));
    long mine = pa_dmesh_nowned(dm, PA_ELEMENT), mx, tot, excess;
    MPI_Allreduce(&mine, &mx, 1, MPI_LONG, MPI_MAX, MPI_COMM_WORLD);
    MPI_Allreduce(&mine, &tot, 1, MPI_LONG, MPI_SUM, MPI_COMM_WORLD);
    long over = mine > tot / size ? mine - tot / size : 0;
    MPI_Allreduce(&over, &excess, 1, MPI_LONG, MPI_SUM, MPI_COMM_WORLD);
    pa_gid moved = -2;
    CHECK_OK(pa_dmesh_rebalance(dm, NULL, 1.05, &moved));
    mine = pa_dmesh_nowned(dm, PA_ELEMENT);
    long mx2;
    MPI_Allreduce(&mine, &mx2, 1, MPI_LONG, MPI_MAX, MPI_COMM_WORLD);
    double mean = (double)tot / size;
    if (size == 1) {
      CHECK(moved == 0);
    } else if (mx > 1.5 * mean) { /* large: a full repartition */
      CHECK(moved == -1);
      CHECK(mx2 <= 1.05 * mean + size + 1);
    } else {
      CHECK(mx > 1.05 * mean); /* the set-up was imbalanced */
      CHECK(moved > 0);        /* diffusion, no fallback (-1) */
      CHECK(mx2 <= 1.05 * mean + size + 1);
      CHECK(moved <= (size - 1) * excess + 10 * size);
      CHECK(moved < tot / 2);
    }
    CHECK_OK(pa_dmesh_check(dm));
    CHECK_OK(pa_dmesh_checksum(dm, &after));
    CHECK(before == after);
    if (ve) {
      pa_idx n, nown;
      int64_t *v = pa_dmesh_value_data(ve, &n, &nown);
      const pa_gid *eg = pa_dmesh_gids(dm, PA_ELEMENT);
      int bad = 0;
      for (pa_idx i = 0; i < n; i++) bad += v[i] != 3 * eg[i] + 2;
      CHECK(bad == 0);
    }
    /* balanced now: nothing moves */
    pa_gid moved2 = -2;
    CHECK_OK(pa_dmesh_rebalance(dm, NULL, 1.05, &moved2));
    CHECK(moved2 == 0);
    /* the cut: the band that moves adds some interface (measured, not
     * checked: it depends on the shape of the excess), against a PT-Scotch
     * repartition of the same mesh */
    CHECK_OK(pa_dmesh_partition_stats(dm, NULL, &imb, &cut));
    CHECK_OK(pa_dmesh_redistribute(dm, NULL, NULL));
    CHECK_OK(pa_dmesh_partition_stats(dm, NULL, &imb, &cutscotch));
    if (rank == 0)
      printf("rebalance %dD, band %.2f: max %ld -> %ld elements per rank "
             "(mean %.0f), excess %ld, moved %lld, cut %lld -> %lld "
             "(PT-Scotch: %lld)\n",
             dim, band, mx, mx2, mean, excess, (long long)moved, (long long)cut0,
             (long long)cut, (long long)cutscotch);
    pa_dmesh_destroy(dm);
  }
}

static void test_weighted_balance(void) {
  pa_mesh *in = box_on_root(3, 12); /* 10,368 tetrahedra */
  pa_dmesh *dm = NULL;
  CHECK_OK(pa_dmesh_distribute(MPI_COMM_WORLD, 0, in, 1, &dm));
  pa_mesh_destroy(in);
  if (!dm) return;
  for (int pass = 0; pass < 2; pass++) {
    pa_idx ne = pa_dmesh_nowned(dm, PA_ELEMENT);
    const double *x = pa_mesh_coords(pa_dmesh_mesh(dm));
    const pa_idx *el = pa_mesh_elems(pa_dmesh_mesh(dm));
    double *w = malloc(sizeof(double) * (ne + 1)), wl = 0, wmax, wsum;
    for (pa_idx e = 0; e < ne; e++) wl += w[e] = x[3 * el[4 * e]] < 0.5 ? 2.0 : 1.0;
    MPI_Allreduce(&wl, &wmax, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
    MPI_Allreduce(&wl, &wsum, 1, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
    if (pass == 1) CHECK(wmax * size / wsum < 1.06);
    if (pass == 0) CHECK_OK(pa_dmesh_redistribute(dm, NULL, w));
    free(w);
  }
  CHECK_OK(pa_dmesh_check(dm));
  pa_dmesh_destroy(dm);
}

/* Adjacency queries agree with each other across the overlap. */
static void test_adjacency(void) {
  pa_mesh *in = box_on_root(3, 4);
  pa_dmesh *dm = NULL;
  CHECK_OK(pa_dmesh_distribute(MPI_COMM_WORLD, 0, in, 1, &dm));
  pa_mesh_destroy(in);
  if (!dm) return;
  int d = 3, bad = 0;
  pa_idx ne = pa_dmesh_nowned(dm, PA_ELEMENT);
  for (pa_idx e = 0; e < ne; e++) {
    const pa_idx *nb;
    CHECK_OK(pa_dmesh_elem_neighbours(dm, e, &nb));
    for (int i = 0; i <= d; i++) {
      if (nb[i] < 0) continue;
      const pa_idx *nn;
      CHECK_OK(pa_dmesh_elem_neighbours(dm, nb[i], &nn));
      int back = 0;
      for (int j = 0; j <= d; j++) back += nn[j] == e;
      bad += back != 1;
    }
    const pa_idx *ev = pa_dmesh_elem_verts(dm, e);
    for (int i = 0; i <= d; i++) {
      pa_idx n;
      const pa_idx *el;
      CHECK_OK(pa_dmesh_vert_elems(dm, ev[i], &n, &el));
      int found = 0;
      for (pa_idx q = 0; q < n; q++) found += el[q] == e;
      bad += found != 1;
    }
  }
  /* owned elements with overlap 1: a face without neighbour is a boundary
   * face, listed as a boundary entity */
  long nfree = 0, nbdry = 0;
  for (pa_idx e = 0; e < ne; e++) {
    const pa_idx *nb;
    CHECK_OK(pa_dmesh_elem_neighbours(dm, e, &nb));
    for (int i = 0; i <= d; i++) nfree += nb[i] < 0;
  }
  for (pa_idx b = 0; b < pa_dmesh_nlocal(dm, PA_BOUNDARY); b++) {
    pa_idx e2[2];
    CHECK_OK(pa_dmesh_bdry_elems(dm, b, e2));
    bad += e2[0] < 0 || e2[1] >= 0;
    if (e2[0] >= 0 && e2[0] < ne) nbdry++;
  }
  CHECK(bad == 0);
  CHECK(nfree == nbdry);
  pa_dmesh_destroy(dm);
}

/* Inconsistent input: the same error on every rank, never a hang. */
static void test_bad_input(void) {
  pa_mesh *in = box_on_root(2, 3);
  pa_dmesh *dm = NULL;
  if (rank == 0) pa_mesh_elems(in)[5] = 999;
  pa_status st = pa_dmesh_distribute(MPI_COMM_WORLD, 0, in, 1, &dm);
  CHECK(st == PA_ERR_MESH);
  CHECK(dm == NULL);
  CHECK(strstr(pa_last_error(), "999") != NULL);
  pa_mesh_destroy(in);
  /* a boundary edge that is in no element */
  in = box_on_root(2, 3);
  if (rank == 0) {
    pa_idx v[2] = {0, 15};
    CHECK_OK(pa_mesh_add_bdry(in, v, 7, NULL));
  }
  st = pa_dmesh_distribute(MPI_COMM_WORLD, 0, in, 0, &dm);
  CHECK(st == PA_ERR_MESH);
  CHECK(strstr(pa_last_error(), "boundary") != NULL);
  pa_dmesh_destroy(dm);
  pa_mesh_destroy(in);
  /* a face in three elements (the last element given twice: the three are
   * in the last rank's block of the scatter): the dual graph, built when
   * partitioning on more than one rank, refuses it */
  in = box_on_root(2, 4);
  if (rank == 0) {
    pa_idx v[3];
    memcpy(v, pa_mesh_elems(in) + 3 * (pa_mesh_nelem(in) - 1), sizeof v);
    CHECK_OK(pa_mesh_add_elem(in, v, 1, NULL));
  }
  st = pa_dmesh_distribute(MPI_COMM_WORLD, 0, in, 0, &dm);
  if (size > 1) {
    CHECK(st == PA_ERR_MESH);
    CHECK(strstr(pa_last_error(), "more than two") != NULL);
  }
  pa_dmesh_destroy(dm);
  dm = NULL;
  pa_mesh_destroy(in);
  /* a bad argument on one rank only */
  in = box_on_root(2, 3);
  st = pa_dmesh_distribute(MPI_COMM_WORLD, 0, in, rank == size - 1 ? -1 : 0, &dm);
  CHECK(st == PA_ERR_ARG);
  pa_mesh_destroy(in);
  /* a wrong new part on one rank */
  in = box_on_root(2, 4);
  CHECK_OK(pa_dmesh_distribute(MPI_COMM_WORLD, 0, in, 0, &dm));
  pa_mesh_destroy(in);
  if (dm) {
    pa_idx ne = pa_dmesh_nowned(dm, PA_ELEMENT);
    int *part = calloc((size_t)ne + 1, sizeof *part);
    if (rank == size - 1 && ne > 0) part[0] = size;
    st = pa_dmesh_redistribute(dm, part, NULL);
    CHECK(st == PA_ERR_ARG);
    free(part);
    pa_dmesh_destroy(dm);
  }
}

/* pa_dmesh_check finds a corrupted mesh on every rank: an element given the
 * vertices of another (faces in three elements; with one rank nothing else
 * is wrong, so the conformity check must say so), then two elements with
 * the same global id (the ownership rendezvous must say so). */
static void test_check_detects(void) {
  for (int what = 0; what < 2; what++) {
    pa_mesh *in = box_on_root(3, 4);
    pa_dmesh *dm = NULL;
    CHECK_OK(pa_dmesh_distribute(MPI_COMM_WORLD, 0, in, 1, &dm));
    pa_mesh_destroy(in);
    CHECK_OK(pa_dmesh_check(dm));
    pa_mesh *m = pa_dmesh_mesh(dm);
    pa_idx ne = pa_dmesh_nowned(dm, PA_ELEMENT);
    int corrupted = what == 1;
    if (rank == 0 && what == 0) {
      /* B: an owned element with no vertex on the cube's surface */
      const double *x = pa_mesh_coords(m);
      pa_idx *ev = pa_mesh_elems(m), b = -1;
      for (pa_idx e = 1; e < ne && b < 0; e++) {
        int inside = 1;
        for (int j = 0; j < 4; j++)
          for (int k = 0; k < 3; k++) {
            double c = x[3 * ev[4 * e + j] + k];
            inside &= c > 1e-9 && c < 1 - 1e-9;
          }
        if (inside) b = e;
      }
      CHECK(b > 0 || size > 1);
      if (b > 0) memcpy(ev + 4 * b, ev, 4 * sizeof *ev);
      corrupted = b > 0;
    }
    MPI_Bcast(&corrupted, 1, MPI_INT, 0, MPI_COMM_WORLD);
    if (rank == 0 && what == 1 && ne > 1) {
      pa_gid *g = (pa_gid *)pa_dmesh_gids(dm, PA_ELEMENT);
      g[1] = g[0];
    }
    pa_status st = pa_dmesh_check(dm);
    if (corrupted) CHECK(st == PA_ERR_MESH);
    if (size == 1)
      CHECK(strstr(pa_last_error(), what ? "owned 2 times" : "more than two"));
    pa_dmesh_destroy(dm);
  }
}

/* The check of an adaptation's result (pa__dmesh_check_output, the
 * validity its measurement reports) finds an inverted owned element, on
 * every rank, as pa_dmesh_check does. */
static void test_check_output(void) {
  pa_mesh *in = box_on_root(3, 4);
  pa_dmesh *dm = NULL;
  CHECK_OK(pa_dmesh_distribute(MPI_COMM_WORLD, 0, in, 1, &dm));
  pa_mesh_destroy(in);
  CHECK_OK(pa__dmesh_check_output(dm));
  pa_stats s;
  pa_mesh *m = pa_dmesh_mesh(dm);
  CHECK_OK(pa__dmesh_stats_met(dm, 0, NULL, PA_STATS_CHECK_OUTPUT, &s));
  CHECK(s.valid);
  if (rank == 0 && pa_dmesh_nowned(dm, PA_ELEMENT) > 0) {
    pa_idx *ev = pa_mesh_elems(m), t = ev[0];
    ev[0] = ev[1];
    ev[1] = t;
  }
  CHECK(pa__dmesh_check_output(dm) == PA_ERR_MESH);
  CHECK(strstr(pa_last_error(), "inverted") != NULL);
  pa_clear_error();
  CHECK_OK(pa__dmesh_stats_met(dm, 0, NULL, PA_STATS_CHECK_OUTPUT, &s));
  CHECK(!s.valid);
  CHECK(pa_dmesh_check(dm) == PA_ERR_MESH);
  pa_clear_error();
  pa_dmesh_destroy(dm);
}

/* A failed MPI call on a communicator that returns errors: PA_ERR_MPI
 * naming the call, the same on every rank for a call every rank makes. */
static void test_mpi_errors(void) {
  MPI_Comm comm;
  double x = 1;
  MPI_Comm_dup(MPI_COMM_WORLD, &comm);
  MPI_Comm_set_errhandler(comm, MPI_ERRORS_RETURN);
  pa_status st = pa__allreduce(comm, &x, -1, MPI_DOUBLE, MPI_SUM);
  CHECK(st == PA_ERR_MPI);
  CHECK(strstr(pa_last_error(), "MPI_Allreduce failed: ") != NULL);
  st = pa__xchg_send(comm, size, &x, sizeof x); /* no such rank */
  CHECK(st == PA_ERR_MPI);
  CHECK(strstr(pa_last_error(), "MPI_Send failed: ") != NULL);
  pa_clear_error();
  CHECK_OK(pa__agree(comm, PA_SUCCESS)); /* the communicator still works */
  MPI_Comm_free(&comm);
}

int main(int argc, char **argv) {
  int provided;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_MULTIPLE, &provided);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  size_t mem0 = pa_memory_current();
  pa_test_fn tests[] = {test_distribute, test_redistribute, test_rebalance,
                        test_weighted_balance, test_adjacency, test_bad_input,
                        test_check_detects, test_check_output,
                        test_mpi_errors};
  const char *names[] = {"distribute", "redistribute", "rebalance",
                         "weighted_balance", "adjacency", "bad_input",
                         "check_detects", "check_output", "mpi_errors"};
  for (size_t t = 0; t < sizeof tests / sizeof *tests; t++) {
    int before = pa_test_failures;
    double t0 = MPI_Wtime();
    tests[t]();
    if (pa_test_failures != before)
      fprintf(stderr, "rank %d: test %s failed\n", rank, names[t]);
    if (rank == 0) printf("%s: %.2f s\n", names[t], MPI_Wtime() - t0);
  }
  if (pa_memory_current() != mem0) {
    fprintf(stderr, "rank %d: %zu bytes leaked\n", rank,
            pa_memory_current() - mem0);
    pa_test_failures++;
  }
  int fails = pa_test_failures;
  MPI_Allreduce(MPI_IN_PLACE, &fails, 1, MPI_INT, MPI_SUM, MPI_COMM_WORLD);
  if (rank == 0)
    printf("test_dmesh: %d ranks, %d checks on rank 0, %d failures\n", size,
           pa_test_checks, fails);
  MPI_Finalize();
  return fails ? 1 : 0;
}
