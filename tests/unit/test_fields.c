/*
 * test_fields.c -- user fields on vertices, elements and boundary entities
 * of a pa_mesh: adding, reading, removing, the transfer modes each kind
 * takes, and the values following the entities through pa_mesh_copy,
 * pa_mesh_resize and pa_mesh_add_*.
 */
#include "testutil.h"

static int has_msg(const char *needle) {
  if (strstr(pa_last_error(), needle)) return 1;
  fprintf(stderr, "  message \"%s\" lacks \"%s\"\n", pa_last_error(), needle);
  return 0;
}

/* A field of n entities, ncomp values each: value (i, c) = i + c / 10. */
static double *ramp(pa_idx n, int ncomp) {
  double *v = malloc(sizeof *v * (size_t)(n ? n : 1) * ncomp);
  for (pa_idx i = 0; i < n; i++)
    for (int c = 0; c < ncomp; c++) v[(size_t)i * ncomp + c] = i + c / 10.0;
  return v;
}

static int same_ramp(const double *v, pa_idx n, int ncomp) {
  for (pa_idx i = 0; i < n; i++)
    for (int c = 0; c < ncomp; c++)
      if (v[(size_t)i * ncomp + c] != i + c / 10.0) return 0;
  return 1;
}

static void test_add_and_read(void) {
  for (int dim = 2; dim <= 3; dim++) {
    pa_mesh *m = NULL;
    CHECK_OK(pa_mesh_generate_box(dim, 2, &m));
    pa_idx ne = pa_mesh_nelem(m), nb = pa_mesh_nbdry(m);
    double *e = ramp(ne, 1), *b = ramp(nb, dim);
    CHECK_OK(pa_mesh_add_field_at(m, PA_ELEMENT, "density", 1, e));
    CHECK_OK(pa_mesh_add_field_at(m, PA_BOUNDARY, "flux", dim, b));
    CHECK(pa_mesh_nfield_at(m, PA_ELEMENT) == 1);
    CHECK(pa_mesh_nfield_at(m, PA_BOUNDARY) == 1);
    CHECK(pa_mesh_nfield_at(m, PA_VERTEX) == 0);
    CHECK(pa_mesh_nfield(m) == 0);
    CHECK(pa_mesh_nfield_at(m, PA_EDGE) == 0);
    CHECK(pa_mesh_field_index(m, PA_ELEMENT, "density") == 0);
    CHECK(pa_mesh_field_index(m, PA_BOUNDARY, "density") == -1);
    const char *name = NULL;
    int nc = 0;
    double *val = NULL;
    CHECK_OK(pa_mesh_field_at(m, PA_BOUNDARY, 0, &name, &nc, &val));
    CHECK(!strcmp(name, "flux") && nc == dim && same_ramp(val, nb, dim));
    CHECK(pa_mesh_field_transfer(m, PA_ELEMENT, 0) == PA_TRANSFER_CONSERVATIVE);
    CHECK(pa_mesh_field_transfer(m, PA_BOUNDARY, 0) == PA_TRANSFER_NEAREST);
    CHECK(pa_mesh_field_transfer(m, PA_ELEMENT, 3) == PA_TRANSFER_DEFAULT);

    /* the vertex functions are the case PA_VERTEX */
    double *u = ramp(pa_mesh_nvert(m), 1);
    CHECK_OK(pa_mesh_add_field(m, "u", 1, u));
    CHECK(pa_mesh_field_index(m, PA_VERTEX, "u") == 0);
    CHECK(pa_mesh_field_transfer(m, PA_VERTEX, 0) == PA_TRANSFER_LINEAR);

    /* a copy carries every field */
    pa_mesh *c = NULL;
    CHECK_OK(pa_mesh_copy(m, &c));
    CHECK_OK(pa_mesh_set_field_transfer(m, PA_ELEMENT, 0, PA_TRANSFER_BOUNDED));
    pa_mesh *c2 = NULL;
    CHECK_OK(pa_mesh_copy(m, &c2));
    CHECK(pa_mesh_field_transfer(c2, PA_ELEMENT, 0) == PA_TRANSFER_BOUNDED);
    CHECK_OK(pa_mesh_field_at(c, PA_ELEMENT, 0, &name, &nc, &val));
    CHECK(!strcmp(name, "density") && nc == 1 && same_ramp(val, ne, 1));
    CHECK_OK(pa_mesh_field_at(c, PA_BOUNDARY, 0, NULL, NULL, &val));
    CHECK(same_ramp(val, nb, dim));
    pa_mesh_destroy(c2);

    /* added entities get zeros; the others keep their values across the
     * growth of the arrays */
    const pa_idx *ev = pa_mesh_elems(c);
    pa_idx v[4];
    memcpy(v, ev, sizeof *v * (dim + 1));
    for (int k = 0; k < 100; k++) CHECK_OK(pa_mesh_add_elem(c, v, 1, NULL));
    CHECK_OK(pa_mesh_add_bdry(c, v, 1, NULL));
    CHECK_OK(pa_mesh_field_at(c, PA_ELEMENT, 0, NULL, NULL, &val));
    CHECK(same_ramp(val, ne, 1));
    int zero = 1;
    for (pa_idx i = ne; i < ne + 100; i++) zero &= val[i] == 0;
    CHECK(zero);
    CHECK_OK(pa_mesh_field_at(c, PA_BOUNDARY, 0, NULL, NULL, &val));
    CHECK(same_ramp(val, nb, dim));
    for (int k = 0; k < dim; k++) CHECK(val[(size_t)nb * dim + k] == 0);

    /* resize: a shrink drops the last values, a growth adds zeros */
    CHECK_OK(pa_mesh_resize(c, pa_mesh_nvert(c), 3, 2, 0));
    CHECK_OK(pa_mesh_resize(c, pa_mesh_nvert(c), ne + 1000, nb, 0));
    CHECK_OK(pa_mesh_field_at(c, PA_ELEMENT, 0, NULL, NULL, &val));
    CHECK(same_ramp(val, 3, 1));
    zero = 1;
    for (pa_idx i = 3; i < ne + 1000; i++) zero &= val[i] == 0;
    CHECK(zero);
    CHECK(pa_mesh_memory_used(c) >
          (size_t)(ne + 1000) * sizeof(double)); /* fields are counted */

    /* removal */
    CHECK_OK(pa_mesh_remove_field_at(c, PA_ELEMENT, 0));
    CHECK(pa_mesh_nfield_at(c, PA_ELEMENT) == 0);
    CHECK(pa_mesh_remove_field_at(c, PA_ELEMENT, 0) == PA_ERR_ARG);
    CHECK(pa_mesh_nfield_at(c, PA_BOUNDARY) == 1);
    pa_mesh_destroy(c);
    pa_mesh_destroy(m);
    free(e);
    free(b);
    free(u);
  }
}

static void test_bad_arguments(void) {
  pa_mesh *m = NULL;
  CHECK_OK(pa_mesh_generate_box(2, 2, &m));
  double *e = ramp(pa_mesh_nvert(m) + pa_mesh_nelem(m) + pa_mesh_nbdry(m), 1);
  e[5] = NAN;
  CHECK(pa_mesh_add_field_at(m, PA_ELEMENT, "bad", 1, e) == PA_ERR_ARG);
  CHECK(has_msg("element 6 is not finite"));
  e[5] = INFINITY;
  CHECK(pa_mesh_add_field_at(m, PA_BOUNDARY, "bad", 1, e) == PA_ERR_ARG);
  CHECK(has_msg("boundary entity 6"));
  e[5] = 0;
  CHECK(pa_mesh_add_field_at(m, PA_EDGE, "e", 1, e) == PA_ERR_ARG);
  CHECK(pa_mesh_add_field_at(m, PA_ELEMENT, "e", 0, e) == PA_ERR_ARG);
  for (int k = 0; k < 16; k++)
    CHECK_OK(pa_mesh_add_field_at(m, PA_ELEMENT, "e", 1, e));
  CHECK(pa_mesh_add_field_at(m, PA_ELEMENT, "e", 1, e) == PA_ERR_ARG);
  CHECK(has_msg("at most 16"));
  /* the limit is per kind */
  CHECK_OK(pa_mesh_add_field_at(m, PA_BOUNDARY, "b", 1, e));
  CHECK_OK(pa_mesh_add_field(m, "v", 1, e));

  /* the modes each kind takes */
  CHECK(pa_mesh_set_field_transfer(m, PA_VERTEX, 0, PA_TRANSFER_CONSERVATIVE) ==
        PA_ERR_ARG);
  CHECK(has_msg("linear"));
  CHECK(pa_mesh_set_field_transfer(m, PA_BOUNDARY, 0, PA_TRANSFER_BOUNDED) ==
        PA_ERR_ARG);
  CHECK(has_msg("nearest"));
  CHECK(pa_mesh_set_field_transfer(m, PA_ELEMENT, 0, PA_TRANSFER_LINEAR) ==
        PA_ERR_ARG);
  CHECK(has_msg("conservative (the default), bounded or nearest"));
  CHECK(pa_mesh_set_field_transfer(m, PA_ELEMENT, 16, PA_TRANSFER_NEAREST) ==
        PA_ERR_ARG);
  CHECK_OK(pa_mesh_set_field_transfer(m, PA_ELEMENT, 1, PA_TRANSFER_NEAREST));
  CHECK(pa_mesh_field_transfer(m, PA_ELEMENT, 1) == PA_TRANSFER_NEAREST);
  CHECK_OK(pa_mesh_set_field_transfer(m, PA_ELEMENT, 1, PA_TRANSFER_DEFAULT));
  CHECK(pa_mesh_field_transfer(m, PA_ELEMENT, 1) == PA_TRANSFER_CONSERVATIVE);
  pa_mesh_destroy(m);
  free(e);
}

static void test_transfer_names(void) {
  pa_transfer t;
  for (int k = 0; k <= PA_TRANSFER_NEAREST; k++) {
    CHECK_OK(pa_transfer_parse(pa_transfer_name((pa_transfer)k), &t));
    CHECK((int)t == k);
  }
  CHECK_OK(pa_transfer_parse("copy", &t));
  CHECK(t == PA_TRANSFER_NEAREST);
  CHECK(pa_transfer_parse("cubic", &t) == PA_ERR_ARG);
  CHECK(has_msg("'cubic'") && has_msg("conservative") && has_msg("bounded"));
  CHECK(!strcmp(pa_transfer_name((pa_transfer)42), "?"));
}

TEST_MAIN(test_add_and_read, test_bad_arguments, test_transfer_names)
