/*
 * test_adapt_curved.c -- skins on curved boundaries (internal API,
 * src/adapt/piece.h; adapt/bisect.c, remesh/leb.c): a tube (the inner and
 * outer walls curved, 16 facets around) made on rank 0 from a structured
 * grid, cut into pieces whose skins cross both walls.
 *  - the skin edges on the walls are split, identically in the two pieces
 *    around every skin face (each face of every piece's skin is found in
 *    exactly one other piece), the new vertices on the walls off the chords
 *    and on the circles to a tenth of the chord's sagitta (the Hermite
 *    curve of the ends' normals), every element positive;
 *  - the whole adaptation puts the pieces back (it fails when two pieces
 *    disagree) and converges to a valid mesh;
 *  - planted: the inner wall's first layer of elements thinner than the
 *    chord's sagitta, so a split onto the curve inverts an element next to
 *    it: the pieces are made again without curves (it->nocurve), every
 *    element positive, the skins still shared.
 * Runs at any number of ranks (two pieces per rank).
 */
#include "testutil.h"
#include "adapt/piece.h"

#include <math.h>
#include <mpi.h>

#define NTHETA 16
#define NZ 3
#define LEN 1.0
#define R_IN 1.0
#define R_OUT 1.5
/* the chord's sagitta between two neighbours of a wall */
#define SAGITTA(r) ((r) * (1 - cos(M_PI / NTHETA)))

/* The tube with its radial levels r[0..nr]: hexahedra of the (r, theta, z)
 * grid cut into 6 tetrahedra along their main diagonal (Kuhn's split: the
 * faces match, the periodic one too), the outer surface as boundary
 * entities of reference 1. */
static pa_mesh *tube(const double *r, int nr) {
  pa_mesh *m = NULL;
  CHECK_OK(pa_mesh_create(3, &m));
  for (int k = 0; k <= NZ; k++)
    for (int j = 0; j < NTHETA; j++)
      for (int i = 0; i <= nr; i++) {
        double t = 2 * M_PI * j / NTHETA;
        double x[3] = {r[i] * cos(t), r[i] * sin(t), LEN * k / NZ};
        CHECK_OK(pa_mesh_add_vertex(m, x, 0, NULL));
      }
  static const int perm[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2},
                                 {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (int k = 0; k < NZ; k++)
    for (int j = 0; j < NTHETA; j++)
      for (int i = 0; i < nr; i++)
        for (int p = 0; p < 6; p++) {
          int c[3] = {0, 0, 0};
          pa_idx v[4];
          for (int s = 0; s < 4; s++) {
            if (s) c[perm[p][s - 1]] = 1;
            int jj = (j + c[1]) % NTHETA;
            v[s] = (pa_idx)(((k + c[2]) * NTHETA + jj) * (nr + 1) + i + c[0]);
          }
          const double *x[4];
          for (int s = 0; s < 4; s++) x[s] = pa_mesh_coords(m) + 3 * (size_t)v[s];
          if (pa__orient(3, x) < 0) {
            pa_idx t = v[2];
            v[2] = v[3];
            v[3] = t;
          }
          CHECK_OK(pa_mesh_add_elem(m, v, 1, NULL));
        }
  CHECK_OK(pa_mesh_build_boundary(m, 1, NULL));
  CHECK_OK(pa_mesh_check(m));
  return m;
}

/* A tube distributed over the ranks with the size h. */
static pa_dmesh *make(const double *r, int nr, double h) {
  pa_mesh *m = NULL;
  pa_dmesh *dm = NULL;
  if (pa_test_rank == 0) {
    m = tube(r, nr);
    double *s = malloc(sizeof *s * (size_t)pa_mesh_nvert(m));
    for (pa_idx v = 0; v < pa_mesh_nvert(m); v++) s[v] = h;
    CHECK_OK(pa_mesh_set_metric(m, 1, s));
    free(s);
  }
  CHECK_OK(pa_dmesh_distribute(MPI_COMM_WORLD, 0, m, 0, &dm));
  pa_mesh_destroy(m);
  return dm;
}

/* Steps 1-3 of an iteration (tag, pieces, extraction) on dm into *it. */
static void extract(pa_dmesh *dm, pa_adapt_opts *o, pa_dmesh_value **done,
                    pa__iter *it) {
  pa_adapt_opts_default(o);
  o->min_piece_work = 1;
  o->min_piece_ratio = 0;
  CHECK_OK(pa_dmesh_value_add(dm, PA_ELEMENT, PA_ADAPT_DONE_VALUE, MPI_UINT8_T,
                              1, -1, done));
  memset(it, 0, sizeof *it);
  it->dm = dm;
  it->opts = o;
  it->rank = pa_test_rank;
  it->size = pa_test_size;
  it->dim = 3;
  it->nve = 4;
  it->iter = 1;
  CHECK_OK(pa__adapt_tag(it, *done, 1));
  CHECK_OK(pa__adapt_pieces(it, 2 * pa_test_size));
  CHECK(it->npieces == 2 * pa_test_size);
  CHECK_OK(pa__adapt_extract(it));
}

/* A skin face by the coordinates of its vertices, in coordinate order. */
typedef struct face9 {
  double x[9];
} face9;

static int face_cmp(const void *p, const void *q) {
  const double *a = p, *b = q;
  for (int k = 0; k < 9; k++)
    if (a[k] != b[k]) return a[k] < b[k] ? -1 : 1;
  return 0;
}

static int xcmp(const double *a, const double *b) {
  for (int k = 0; k < 3; k++)
    if (a[k] != b[k]) return a[k] < b[k] ? -1 : 1;
  return 0;
}

/* What the local pieces hold: their skin faces (appended to *f, *nf), the
 * elements without a positive volume, the new skin vertices on a wall
 * (*nwall) and those off its circle by more than a tenth of the sagitta
 * (*nfar). */
static void examine(const pa__iter *it, face9 **f, int *nf, int *nbad,
                    int *nwall, int *nfar) {
  for (int q = 0; q < it->npiece_local; q++) {
    const pa__piece *pc = &it->pieces[q];
    pa_mesh *m = pc->in;
    const double *x = pa_mesh_coords(m);
    const pa_idx *el = pa_mesh_elems(m), *bd = pa_mesh_bdrys(m);
    const int32_t *bref = pa_mesh_bdry_refs(m);
    for (pa_idx e = 0; e < pa_mesh_nelem(m); e++) {
      const double *p[4];
      for (int s = 0; s < 4; s++) p[s] = x + 3 * (size_t)el[4 * e + s];
      *nbad += !(pa__orient(3, p) > 0);
    }
    uint8_t *wall = calloc((size_t)pa_mesh_nvert(m) + 1, 1);
    for (pa_idx b = 0; b < pa_mesh_nbdry(m); b++) {
      const pa_idx *v = bd + 3 * (size_t)b;
      if (bref[b] != PA_ADAPT_SKIN_REF) {
        for (int s = 0; s < 3; s++) wall[v[s]] = 1;
        continue;
      }
      face9 g;
      pa_idx w[3] = {v[0], v[1], v[2]};
      for (int i = 1; i < 3; i++)
        for (int j = i; j > 0 && xcmp(x + 3 * (size_t)w[j - 1], x + 3 * (size_t)w[j]) > 0; j--) {
          pa_idx t = w[j];
          w[j] = w[j - 1];
          w[j - 1] = t;
        }
      for (int s = 0; s < 3; s++) memcpy(g.x + 3 * s, x + 3 * (size_t)w[s], 3 * sizeof(double));
      *f = realloc(*f, sizeof **f * (size_t)(*nf + 1));
      (*f)[(*nf)++] = g;
    }
    for (pa_idx v = pc->nv0; v < pa_mesh_nvert(m); v++) {
      const double *p = x + 3 * (size_t)v;
      double r = hypot(p[0], p[1]);
      if (!pc->skin[v] || !wall[v] || p[2] == 0 || p[2] == LEN) continue;
      double R = fabs(r - R_IN) < fabs(r - R_OUT) ? R_IN : R_OUT;
      (*nwall)++;
      *nfar += fabs(r - R) > 0.1 * SAGITTA(R);
    }
    free(wall);
  }
}

/* Every skin face of every piece is in exactly two pieces: gathered on
 * rank 0, sorted, in runs of two. */
static void check_shared(face9 *f, int nf) {
  int *cnt = NULL, *displ = NULL, tot = 0, n9 = 9 * nf;
  face9 *all = NULL;
  if (pa_test_rank == 0) {
    cnt = malloc(sizeof *cnt * (size_t)pa_test_size);
    displ = malloc(sizeof *displ * (size_t)pa_test_size);
  }
  MPI_Gather(&n9, 1, MPI_INT, cnt, 1, MPI_INT, 0, MPI_COMM_WORLD);
  if (pa_test_rank == 0) {
    for (int r = 0; r < pa_test_size; r++) {
      displ[r] = tot;
      tot += cnt[r];
    }
    all = malloc(sizeof(double) * (size_t)(tot + 9));
  }
  MPI_Gatherv(f, n9, MPI_DOUBLE, all, cnt, displ, MPI_DOUBLE, 0, MPI_COMM_WORLD);
  if (pa_test_rank == 0) {
    int n = tot / 9, odd = 0;
    qsort(all, (size_t)n, sizeof *all, face_cmp);
    for (int i = 0; i < n;) {
      int j = i + 1;
      while (j < n && !face_cmp(all + i, all + j)) j++;
      odd += j - i != 2;
      i = j;
    }
    printf("  %d skin faces, %d not in exactly two pieces\n", n, odd);
    CHECK(n > 0 && odd == 0);
  }
  free(cnt);
  free(displ);
  free(all);
}

/* One extraction of the tube with radial levels r: the checks above;
 * planted: the fallback is expected. */
static void run(const double *r, int nr, int planted) {
  pa_dmesh *dm = make(r, nr, 0.12);
  pa_adapt_opts o;
  pa_dmesh_value *done = NULL;
  pa__iter it;
  face9 *f = NULL;
  int nf = 0, nbad = 0, nwall = 0, nfar = 0;
  extract(dm, &o, &done, &it);
  double nc = 0;
  for (int q = 0; q < it.npiece_local; q++) nc += it.pieces[q].ncurved;
  examine(&it, &f, &nf, &nbad, &nwall, &nfar);
  int x[4] = {nbad, nwall, nfar, it.nocurve};
  MPI_Allreduce(MPI_IN_PLACE, x, 4, MPI_INT, MPI_SUM, MPI_COMM_WORLD);
  MPI_Allreduce(MPI_IN_PLACE, &nc, 1, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
  if (pa_test_rank == 0)
    printf("  %s tube: %d pieces, %.0f skin vertices on curves, %d new skin "
           "vertices on a wall (%d off its circle), %d non-positive elements, "
           "fallback %d\n", planted ? "planted" : "plain", it.npieces, nc,
           x[1], x[2], x[0], x[3] > 0);
  CHECK(x[0] == 0);
  CHECK(x[1] > 0);
  if (planted) {
    CHECK(x[3] == pa_test_size && nc == 0);
  } else {
    CHECK(x[3] == 0 && nc > 0 && x[2] == 0);
  }
  check_shared(f, nf);
  free(f);
  pa__iter_free(&it);
  CHECK_OK(pa_dmesh_value_remove(dm, done));
  pa_dmesh_destroy(dm);
}

static const double plain_r[3] = {R_IN, 0.5 * (R_IN + R_OUT), R_OUT};
/* a first layer 0.005 thick, a quarter of the inner wall's sagitta */
static const double thin_r[4] = {R_IN, R_IN + 0.005, 0.5 * (R_IN + R_OUT), R_OUT};

static void test_curved_skins(void) { run(plain_r, 2, 0); }

static void test_planted_fallback(void) { run(thin_r, 3, 1); }

/* The whole loop on the tube: the pieces are put back (a vertex a single
 * piece added on a shared skin is an internal error) and the result is a
 * valid mesh, converged. */
static void test_adapt_tube(void) {
  pa_dmesh *dm = make(plain_r, 2, 0.15);
  pa_adapt_opts o;
  pa_adapt_report rep;
  pa_adapt_opts_default(&o);
  o.min_piece_work = 1;
  o.min_piece_ratio = 0;
  CHECK_OK(pa_dmesh_adapt(dm, &o, &rep));
  CHECK(rep.converged);
  CHECK_OK(pa_dmesh_check(dm));
  if (pa_test_rank == 0)
    printf("  adapted tube: %lld elements in %d iterations\n",
           (long long)pa_dmesh_nglobal(dm, PA_ELEMENT), rep.niter);
  pa_dmesh_destroy(dm);
}

TEST_MPI_MAIN(test_curved_skins, test_planted_fallback, test_adapt_tube)
