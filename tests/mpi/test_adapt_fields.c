/*
 * test_adapt_fields.c -- element and boundary fields of a distributed mesh:
 * they follow the entities through distribution, ghosts, reordering,
 * redistribution, set files and gathering unchanged, and come back from
 * pa_dmesh_adapt transferred (piece by piece, inside pa_remesh): the
 * integral kept to 1e-12 relative, a constant exactly constant, bounded
 * values in the source range, the set of material ids kept, boundary
 * values following the references; comparable to the sequential remesh.
 * Runs at any number of ranks.
 */
#include "testutil.h"
#include "bisect_remesher.h"

#include <mpi.h>

/* Measure of element e of m. */
static double elem_volume(pa_mesh *m, pa_idx e) {
  int d = pa_mesh_dim(m);
  const pa_idx *v = pa_mesh_elems(m) + (size_t)(d + 1) * e;
  double a[3][3];
  for (int i = 0; i < d; i++)
    for (int k = 0; k < d; k++)
      a[i][k] = pa_mesh_coords(m)[(size_t)d * v[i + 1] + k] -
                pa_mesh_coords(m)[(size_t)d * v[0] + k];
  if (d == 2) return 0.5 * (a[0][0] * a[1][1] - a[0][1] * a[1][0]);
  return (a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) -
          a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
          a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0])) / 6;
}

/* The box of dimension dim with its test fields: element "smooth"
 * (conservative), "const" (3.7), "bounded" (random, bounded), "material"
 * (1..4, nearest); boundary "bc" (10 x reference). */
static pa_mesh *box_with_fields(int dim, int n) {
  pa_mesh *m = NULL;
  CHECK_OK(pa_mesh_generate_box(dim, n, &m));
  pa_idx ne = pa_mesh_nelem(m), nb = pa_mesh_nbdry(m);
  double *a = malloc(sizeof *a * ne), *c = malloc(sizeof *c * ne);
  double *r = malloc(sizeof *r * ne), *mat = malloc(sizeof *mat * ne);
  double *bc = malloc(sizeof *bc * nb);
  pa_test_seed(17);
  for (pa_idx e = 0; e < ne; e++) {
    const pa_idx *v = pa_mesh_elems(m) + (size_t)(dim + 1) * e;
    double x[3] = {0, 0, 0};
    for (int i = 0; i <= dim; i++)
      for (int k = 0; k < dim; k++) x[k] += pa_mesh_coords(m)[(size_t)dim * v[i] + k] / (dim + 1);
    a[e] = 2 + sin(4 * x[0]) * cos(3 * x[1]) + x[dim - 1];
    c[e] = 3.7;
    r[e] = pa_test_rand_range(-1, 2);
    mat[e] = 1 + (x[0] > 0.5) + 2 * (x[1] > 0.3);
  }
  for (pa_idx b = 0; b < nb; b++) bc[b] = 10.0 * pa_mesh_bdry_refs(m)[b];
  CHECK_OK(pa_mesh_add_field_at(m, PA_ELEMENT, "smooth", 1, a));
  CHECK_OK(pa_mesh_add_field_at(m, PA_ELEMENT, "const", 1, c));
  CHECK_OK(pa_mesh_add_field_at(m, PA_ELEMENT, "bounded", 1, r));
  CHECK_OK(pa_mesh_set_field_transfer(m, PA_ELEMENT, 2, PA_TRANSFER_BOUNDED));
  CHECK_OK(pa_mesh_add_field_at(m, PA_ELEMENT, "material", 1, mat));
  CHECK_OK(pa_mesh_set_field_transfer(m, PA_ELEMENT, 3, PA_TRANSFER_NEAREST));
  CHECK_OK(pa_mesh_add_field_at(m, PA_BOUNDARY, "bc", 1, bc));
  free(a), free(c), free(r), free(mat), free(bc);
  return m;
}

/* Integral of element field k of m. */
static double integral(pa_mesh *m, int k) {
  double *v, s = 0;
  CHECK_OK(pa_mesh_field_at(m, PA_ELEMENT, k, NULL, NULL, &v));
  for (pa_idx e = 0; e < pa_mesh_nelem(m); e++) s += elem_volume(m, e) * v[e];
  return s;
}

/* The fields of the adapted mesh a against those of the input o. */
static void judge(pa_mesh *o, pa_mesh *a, const char *what) {
  CHECK(pa_mesh_nfield_at(a, PA_ELEMENT) == 4 && pa_mesh_nfield_at(a, PA_BOUNDARY) == 1);
  CHECK(pa_mesh_field_transfer(a, PA_ELEMENT, 2) == PA_TRANSFER_BOUNDED);
  CHECK(pa_mesh_field_transfer(a, PA_ELEMENT, 3) == PA_TRANSFER_NEAREST);
  for (int k = 0; k < 3; k++) {
    double i0 = integral(o, k), i1 = integral(a, k);
    if (!(fabs(i1 - i0) <= 1e-12 * fabs(i0)))
      fprintf(stderr, "  %s: field %d: integral %.17g -> %.17g\n", what, k, i0, i1);
    CHECK(fabs(i1 - i0) <= 1e-12 * fabs(i0));
  }
  double *c, *r, *mat, *bc, *r0;
  CHECK_OK(pa_mesh_field_at(a, PA_ELEMENT, 1, NULL, NULL, &c));
  CHECK_OK(pa_mesh_field_at(a, PA_ELEMENT, 2, NULL, NULL, &r));
  CHECK_OK(pa_mesh_field_at(a, PA_ELEMENT, 3, NULL, NULL, &mat));
  CHECK_OK(pa_mesh_field_at(a, PA_BOUNDARY, 0, NULL, NULL, &bc));
  CHECK_OK(pa_mesh_field_at(o, PA_ELEMENT, 2, NULL, NULL, &r0));
  double lo = 1e300, hi = -1e300;
  for (pa_idx e = 0; e < pa_mesh_nelem(o); e++) lo = fmin(lo, r0[e]), hi = fmax(hi, r0[e]);
  int exact = 1, inside = 1, ints = 1, seen[5] = {0}, bok = 1;
  for (pa_idx e = 0; e < pa_mesh_nelem(a); e++) {
    exact &= c[e] == 3.7;
    inside &= r[e] >= lo && r[e] <= hi;
    ints &= mat[e] == 1 || mat[e] == 2 || mat[e] == 3 || mat[e] == 4;
    if (mat[e] >= 1 && mat[e] <= 4) seen[(int)mat[e]] = 1;
  }
  for (pa_idx b = 0; b < pa_mesh_nbdry(a); b++)
    bok &= bc[b] == 10.0 * pa_mesh_bdry_refs(a)[b];
  CHECK(exact);
  CHECK(inside);
  CHECK(ints && seen[1] && seen[2] && seen[3] && seen[4]);
  CHECK(bok);
}

static void opts_small(pa_adapt_opts *o, const pa_remesher *r) {
  pa_adapt_opts_default(o);
  o->remesher = r;
  o->min_piece_work = 20; /* many pieces even on small meshes */
  o->min_piece_ratio = 0;
}

/* ||u||_2 of element field k of m. */
static double norm2(pa_mesh *m, int k) {
  double *v, s = 0;
  CHECK_OK(pa_mesh_field_at(m, PA_ELEMENT, k, NULL, NULL, &v));
  for (pa_idx e = 0; e < pa_mesh_nelem(m); e++) s += elem_volume(m, e) * v[e] * v[e];
  return sqrt(s);
}

/* pa_dmesh_adapt refining, with the built-in remesher (2D, 3D) and a
 * plug-in one (2D bisection), judged on the gathered mesh; the built-in
 * runs against the sequential remesh of the same input. */
static void test_adapt(void) {
  for (int c = 0; c < 3; c++) {
    int dim = c == 1 ? 3 : 2;
    pa_mesh *m = NULL, *g = NULL;
    pa_dmesh *dm = NULL;
    if (pa_test_rank == 0) m = box_with_fields(dim, dim == 2 ? 6 : 3);
    CHECK_OK(pa_dmesh_distribute(MPI_COMM_WORLD, 0, m, c == 1 ? 1 : 0, &dm));
    pa_adapt_opts o;
    pa_adapt_report rep;
    opts_small(&o, c == 2 ? bisect_remesher() : NULL);
    o.remesh.hsiz = dim == 2 ? 0.06 : 0.2;
    CHECK_OK(pa_dmesh_adapt(dm, &o, &rep));
    CHECK(rep.nelem_final > rep.nelem_initial);
    CHECK(rep.nfailed == 0);
    CHECK(rep.transfer.nfield == 5 && rep.transfer.nfast + rep.transfer.nclip > 0);
    CHECK(rep.transfer.defect < 1e-13);
    CHECK_OK(pa_dmesh_check(dm));
    CHECK_OK(pa_dmesh_gather(dm, 0, &g));
    if (pa_test_rank == 0) {
      const char *what = c == 0 ? "2D builtin" : c == 1 ? "3D builtin" : "2D bisection";
      judge(m, g, what);
      if (c < 2) { /* the sequential remesh of the same input */
        pa_mesh *s = NULL;
        pa_remesh_opts so = o.remesh;
        CHECK_OK(pa_mesh_copy(m, &s));
        CHECK_OK(pa_remesh(pa_remesher_builtin(), s, &so, NULL));
        judge(m, s, "sequential");
        double ns = norm2(s, 0), np = norm2(g, 0);
        CHECK(fabs(np - ns) <= 0.02 * ns);
        printf("%s: %lld -> %lld elements (sequential %d), %ld pieces; "
               "||smooth||_2 %.6f (sequential %.6f, input %.6f)\n", what,
               (long long)rep.nelem_initial, (long long)rep.nelem_final,
               (int)pa_mesh_nelem(s), rep.npieces, np, ns, norm2(m, 0));
        pa_mesh_destroy(s);
      }
    }
    pa_mesh_destroy(g);
    pa_mesh_destroy(m);
    pa_dmesh_destroy(dm);
  }
}

/* 1 if every local element and boundary entity of dm (owned and ghost)
 * holds the values of the entity of m its global id names. */
static int local_values_match(pa_dmesh *dm, pa_mesh *m) {
  pa_mesh *lm = pa_dmesh_mesh(dm);
  int ok = pa_mesh_nfield_at(lm, PA_ELEMENT) == pa_mesh_nfield_at(m, PA_ELEMENT) &&
           pa_mesh_nfield_at(lm, PA_BOUNDARY) == pa_mesh_nfield_at(m, PA_BOUNDARY);
  for (int at = PA_ELEMENT; ok && at <= PA_BOUNDARY; at++) {
    const pa_gid *gid = pa_dmesh_gids(dm, (pa_entity)at);
    for (int k = 0; ok && k < pa_mesh_nfield_at(m, (pa_entity)at); k++) {
      double *v, *w;
      int nc;
      const char *name;
      pa_mesh_field_at(m, (pa_entity)at, k, &name, &nc, &v);
      ok = pa_mesh_field_index(lm, (pa_entity)at, name) == k;
      pa_mesh_field_at(lm, (pa_entity)at, k, NULL, NULL, &w);
      for (pa_idx i = 0; ok && i < pa_dmesh_nlocal(dm, (pa_entity)at); i++)
        ok = !memcmp(w + (size_t)nc * i, v + (size_t)nc * gid[i], sizeof *v * nc);
    }
  }
  return ok;
}

/* The fields stay with their entities: distribution with ghosts,
 * reordering, redistribution, a set written and read back, gathering. */
static void test_follow(void) {
  for (int dim = 2; dim <= 3; dim++) {
    pa_mesh *m = box_with_fields(dim, dim == 2 ? 6 : 3), *g = NULL; /* every rank */
    pa_dmesh *dm = NULL, *rd = NULL;
    CHECK_OK(pa_dmesh_distribute(MPI_COMM_WORLD, 0, pa_test_rank == 0 ? m : NULL,
                                 2, &dm));
    CHECK(local_values_match(dm, m));
    CHECK_OK(pa_dmesh_reorder(dm));
    CHECK(local_values_match(dm, m));
    { /* every element one rank further */
      pa_idx ne = pa_dmesh_nowned(dm, PA_ELEMENT);
      int *part = malloc(sizeof *part * (ne ? ne : 1));
      for (pa_idx e = 0; e < ne; e++) part[e] = (pa_test_rank + 1 + e % 2) % pa_test_size;
      CHECK_OK(pa_dmesh_redistribute(dm, part, NULL));
      free(part);
    }
    CHECK(local_values_match(dm, m));
    /* a changed owner value reaches the ghosts */
    CHECK_OK(pa_dmesh_sync_mesh(dm));
    CHECK(local_values_match(dm, m));
    CHECK_OK(pa_dmesh_write(dm, dim == 2 ? "set2.meshb" : "set3.meshb"));
    CHECK_OK(pa_dmesh_read(MPI_COMM_WORLD, dim == 2 ? "set2.meshb" : "set3.meshb",
                           1, &rd));
    CHECK(local_values_match(rd, m));
    CHECK_OK(pa_dmesh_gather(rd, 0, &g));
    if (pa_test_rank == 0) {
      CHECK(g != NULL);
      for (int at = PA_ELEMENT; g && at <= PA_BOUNDARY; at++)
        for (int k = 0; k < pa_mesh_nfield_at(m, (pa_entity)at); k++) {
          double *v, *w;
          int nc;
          pa_mesh_field_at(m, (pa_entity)at, k, NULL, &nc, &v);
          CHECK_OK(pa_mesh_field_at(g, (pa_entity)at, k, NULL, NULL, &w));
          pa_idx n = at == PA_ELEMENT ? pa_mesh_nelem(m) : pa_mesh_nbdry(m);
          CHECK(!memcmp(v, w, sizeof *v * nc * (size_t)n));
        }
    }
    pa_mesh_destroy(g);
    pa_dmesh_destroy(rd);
    pa_dmesh_destroy(dm);
    pa_mesh_destroy(m);
  }
}

TEST_MPI_MAIN(test_adapt, test_follow)
