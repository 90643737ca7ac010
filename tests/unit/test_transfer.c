/*
 * test_transfer.c -- element and boundary fields carried through a remesh
 * (src/remesh/transfer.c, pa_remesh): the intersection of two unrelated
 * meshes of one domain (every new element clipped), then pa_remesh
 * refining and coarsening in 2D and 3D. Judged by what each mode
 * guarantees: the integral kept to 1e-12 relative (conservative, bounded),
 * a constant exactly constant, values within the range of the source
 * (bounded), the set of values kept (nearest), boundary values kept per
 * reference.
 */
#include "testutil.h"
#include "mesh/mesh.h"
#include "remesh/remesh.h"

/* Measure of element e of m. */
static double elem_volume(pa_mesh *m, pa_idx e) {
  int d = pa_mesh_dim(m);
  const pa_idx *v = pa_mesh_elems(m) + (size_t)(d + 1) * e;
  const double *x[4];
  for (int i = 0; i <= d; i++) x[i] = pa_mesh_coords(m) + (size_t)d * v[i];
  return pa__simplex_volume(d, x);
}

/* Integral and integral of the absolute value of component c of element
 * field k of m. */
static void integral(pa_mesh *m, int k, int c, double *in, double *abs_in) {
  double *val;
  int nc;
  CHECK_OK(pa_mesh_field_at(m, PA_ELEMENT, k, NULL, &nc, &val));
  *in = *abs_in = 0;
  for (pa_idx e = 0; e < pa_mesh_nelem(m); e++) {
    double w = elem_volume(m, e);
    *in += w * val[(size_t)nc * e + c];
    *abs_in += w * fabs(val[(size_t)nc * e + c]);
  }
}

/* Centroid of element e of m. */
static void centroid(pa_mesh *m, pa_idx e, double *c) {
  int d = pa_mesh_dim(m);
  const pa_idx *v = pa_mesh_elems(m) + (size_t)(d + 1) * e;
  for (int k = 0; k < d; k++) c[k] = 0;
  for (int i = 0; i <= d; i++)
    for (int k = 0; k < d; k++)
      c[k] += pa_mesh_coords(m)[(size_t)d * v[i] + k] / (d + 1);
}

/* The test fields on the elements of m: "smooth" (2 components: a smooth
 * function and random values), "const" (3.7), "bounded" (random in
 * [-1, 2]), "material" (integers 1..4 by region), with their modes. */
static void add_fields(pa_mesh *m, unsigned long long seed) {
  int d = pa_mesh_dim(m);
  pa_idx ne = pa_mesh_nelem(m);
  double *a = malloc(sizeof *a * 2 * ne), *b = malloc(sizeof *b * ne);
  double *r = malloc(sizeof *r * ne), *mat = malloc(sizeof *mat * ne);
  pa_test_seed(seed);
  for (pa_idx e = 0; e < ne; e++) {
    double c[3];
    centroid(m, e, c);
    a[2 * e] = sin(3 * c[0]) * cos(2 * c[1]) + (d == 3 ? c[2] * c[2] : 0);
    a[2 * e + 1] = pa_test_rand_range(-5, 5);
    b[e] = 3.7;
    r[e] = pa_test_rand_range(-1, 2);
    mat[e] = 1 + (c[0] > 0.5) + 2 * (c[1] > 0.3);
  }
  CHECK_OK(pa_mesh_add_field_at(m, PA_ELEMENT, "smooth", 2, a));
  CHECK_OK(pa_mesh_add_field_at(m, PA_ELEMENT, "const", 1, b));
  CHECK_OK(pa_mesh_add_field_at(m, PA_ELEMENT, "bounded", 1, r));
  CHECK_OK(pa_mesh_set_field_transfer(m, PA_ELEMENT, 2, PA_TRANSFER_BOUNDED));
  CHECK_OK(pa_mesh_add_field_at(m, PA_ELEMENT, "material", 1, mat));
  CHECK_OK(pa_mesh_set_field_transfer(m, PA_ELEMENT, 3, PA_TRANSFER_NEAREST));
  /* boundary: the reference times 10, and the first coordinate of the
   * centroid as a second component (not kept: only the reference's value
   * is) */
  pa_idx nb = pa_mesh_nbdry(m);
  double *bv = malloc(sizeof *bv * (nb ? nb : 1));
  for (pa_idx f = 0; f < nb; f++) bv[f] = 10.0 * pa_mesh_bdry_refs(m)[f];
  CHECK_OK(pa_mesh_add_field_at(m, PA_BOUNDARY, "bc", 1, bv));
  free(a), free(b), free(r), free(mat), free(bv);
}

/* Judge the fields of the new mesh m against those of the old one o. */
static void judge(pa_mesh *o, pa_mesh *m, const char *what) {
  double tol = 1e-12;
  CHECK(pa_mesh_nfield_at(m, PA_ELEMENT) == 4);
  CHECK(pa_mesh_nfield_at(m, PA_BOUNDARY) == 1);
  /* conservative and bounded keep the integral */
  for (int k = 0; k < 3; k++)
    for (int c = 0; c < (k == 0 ? 2 : 1); c++) {
      double i0, a0, i1, a1;
      integral(o, k, c, &i0, &a0);
      integral(m, k, c, &i1, &a1);
      if (!(fabs(i1 - i0) <= tol * a0))
        fprintf(stderr, "  %s: field %d.%d: integral %.17g -> %.17g (%.2e)\n",
                what, k, c, i0, i1, fabs(i1 - i0) / a0);
      CHECK(fabs(i1 - i0) <= tol * a0);
    }
  pa_idx ne = pa_mesh_nelem(m);
  double *cv, *bv, *mv, *obv;
  CHECK_OK(pa_mesh_field_at(m, PA_ELEMENT, 1, NULL, NULL, &cv));
  CHECK_OK(pa_mesh_field_at(m, PA_ELEMENT, 2, NULL, NULL, &bv));
  CHECK_OK(pa_mesh_field_at(m, PA_ELEMENT, 3, NULL, NULL, &mv));
  int exact = 1, inside = 1, ints = 1;
  double lo = 1e300, hi = -1e300;
  CHECK_OK(pa_mesh_field_at(o, PA_ELEMENT, 2, NULL, NULL, &obv));
  for (pa_idx e = 0; e < pa_mesh_nelem(o); e++)
    lo = fmin(lo, obv[e]), hi = fmax(hi, obv[e]);
  for (pa_idx e = 0; e < ne; e++) {
    exact &= cv[e] == 3.7;
    inside &= bv[e] >= lo && bv[e] <= hi;
    ints &= mv[e] == 1 || mv[e] == 2 || mv[e] == 3 || mv[e] == 4;
  }
  CHECK(exact);
  CHECK(inside);
  CHECK(ints);
  /* every material comes through */
  for (int v = 1; v <= 4; v++) {
    int found = 0;
    for (pa_idx e = 0; e < ne && !found; e++) found = mv[e] == v;
    CHECK(found);
  }
  /* boundary values follow the reference */
  double *fv;
  CHECK_OK(pa_mesh_field_at(m, PA_BOUNDARY, 0, NULL, NULL, &fv));
  int bok = 1;
  for (pa_idx f = 0; f < pa_mesh_nbdry(m); f++)
    bok &= fv[f] == 10.0 * pa_mesh_bdry_refs(m)[f];
  CHECK(bok);
}

/* Two unrelated meshes of the unit square or cube (n and n2 cells a side,
 * the interior vertices of the second moved at random): every new
 * element straddles old ones. */
static void test_unrelated_meshes(void) {
  for (int d = 2; d <= 3; d++) {
    pa_mesh *o = NULL, *m = NULL;
    CHECK_OK(pa_mesh_generate_box(d, d == 2 ? 7 : 4, &o));
    CHECK_OK(pa_mesh_generate_box(d, d == 2 ? 11 : 5, &m));
    int n2 = d == 2 ? 11 : 5;
    pa_test_seed(7);
    for (pa_idx v = 0; v < pa_mesh_nvert(m); v++) {
      double *x = pa_mesh_coords(m) + (size_t)d * v;
      int interior = 1;
      for (int k = 0; k < d; k++) interior &= x[k] > 1e-9 && x[k] < 1 - 1e-9;
      if (interior)
        for (int k = 0; k < d; k++) x[k] += pa_test_rand_range(-0.2, 0.2) / n2;
    }
    add_fields(o, 11);
    pa_transfer_report rep;
    CHECK_OK(pa__transfer_fields(o, m, &rep));
    CHECK(rep.nclip > 0);
    CHECK(rep.nfield == 5);
    CHECK(rep.defect < 1e-13);
    CHECK(rep.uncovered < 1e-13 && rep.lost < 1e-13);
    judge(o, m, d == 2 ? "2D unrelated" : "3D unrelated");
    /* a mesh given back unchanged gets its values back exactly */
    pa_mesh *c = NULL;
    CHECK_OK(pa_mesh_copy(o, &c));
    for (int at = PA_ELEMENT; at <= PA_BOUNDARY; at++)
      while (pa_mesh_nfield_at(c, (pa_entity)at))
        CHECK_OK(pa_mesh_remove_field_at(c, (pa_entity)at, 0));
    CHECK_OK(pa__transfer_fields(o, c, &rep));
    CHECK(rep.nclip == 0 && rep.nfast == pa_mesh_nelem(o));
    for (int k = 0; k < 4; k++) {
      double *a, *b;
      int nc;
      CHECK_OK(pa_mesh_field_at(o, PA_ELEMENT, k, NULL, &nc, &a));
      CHECK_OK(pa_mesh_field_at(c, PA_ELEMENT, k, NULL, NULL, &b));
      CHECK(!memcmp(a, b, sizeof *a * nc * pa_mesh_nelem(o)));
    }
    pa_mesh_destroy(c);
    pa_mesh_destroy(o);
    pa_mesh_destroy(m);
  }
}

/* pa_remesh refining (hsiz small) and coarsening (hsiz large). */
static void test_remesh(void) {
  for (int d = 2; d <= 3; d++)
    for (int pass = 0; pass < 2; pass++) {
      pa_mesh *m = NULL, *o = NULL;
      CHECK_OK(pa_mesh_generate_box(d, pass == 0 ? 4 : (d == 2 ? 24 : 8), &m));
      add_fields(m, 3 + pass);
      CHECK_OK(pa_mesh_copy(m, &o));
      pa_remesh_opts opts;
      pa_remesh_report rep;
      pa_remesh_opts_default(&opts);
      opts.hsiz = pass == 0 ? (d == 2 ? 0.04 : 0.12) : 0.4;
      CHECK_OK(pa_remesh(pa_remesher_builtin(), m, &opts, &rep));
      CHECK(rep.outcome != PA_REMESH_FAILED);
      if (pass == 0)
        CHECK(pa_mesh_nelem(m) > 4 * pa_mesh_nelem(o));
      else
        CHECK(pa_mesh_nelem(m) < pa_mesh_nelem(o));
      CHECK(rep.transfer.nfield == 5);
      CHECK(rep.transfer.nfast + rep.transfer.nclip == pa_mesh_nelem(m));
      CHECK(rep.transfer.nout == 0 || rep.transfer.defect < 1e-13);
      char what[64];
      snprintf(what, sizeof what, "%dD %s", d, pass ? "coarsened" : "refined");
      judge(o, m, what);
      CHECK(pa_mesh_check(m) == PA_SUCCESS);
      pa_mesh_destroy(m);
      pa_mesh_destroy(o);
    }
}

/* A remesh that fails gives the mesh back with its fields. */
static void test_failure_keeps_fields(void) {
  pa_mesh *m = NULL;
  size_t used = pa_memory_current();
  int nfail = 0;
  CHECK_OK(pa_mesh_generate_box(2, 4, &m));
  add_fields(m, 5);
  pa_remesh_opts opts;
  pa_remesh_opts_default(&opts);
  opts.hsiz = 0.01;
  for (long k = 1; k < 400; k += 7) {
    pa_memory_fail_after(k);
    pa_status st = pa_remesh(pa_remesher_builtin(), m, &opts, NULL);
    pa_memory_fail_after(0);
    if (st == PA_SUCCESS) break;
    CHECK(pa_mesh_nelem(m) == 32);
    CHECK(pa_mesh_nfield_at(m, PA_ELEMENT) == 4);
    CHECK(pa_mesh_nfield_at(m, PA_BOUNDARY) == 1);
    CHECK(pa_mesh_check(m) == PA_SUCCESS);
    nfail++;
  }
  CHECK(nfail > 10);
  CHECK(pa_mesh_nfield_at(m, PA_ELEMENT) == 4);
  pa_mesh_destroy(m);
  CHECK(pa_memory_current() == used);
}

TEST_MAIN(test_unrelated_meshes, test_remesh, test_failure_keeps_fields)
