/*
 * test_field_files.c -- element and boundary fields in files: Medit .sol /
 * .solb (SolAtVertices, SolAtEdges, SolAtTriangles, SolAtTetrahedra,
 * several types per keyword) read into a mesh and written back, Gmsh
 * $ElementData (ASCII and binary, padapt's views and Gmsh's sparse ones)
 * and the errors on bad input (a count that is not the mesh's, a value
 * that is not finite, a place the mesh has no entities for).
 */
#include "testutil.h"

static int has_msg(const char *needle) {
  if (strstr(pa_last_error(), needle)) return 1;
  fprintf(stderr, "  message \"%s\" lacks \"%s\"\n", pa_last_error(), needle);
  return 0;
}

static void write_text(const char *path, const char *text) {
  FILE *fp = fopen(path, "w");
  fputs(text, fp);
  fclose(fp);
}

/* The mesh of the unit square or cube (n a side) with fields on every kind
 * of entity: vertex "u" (scalar), element "rho" (scalar) and "sig" (a
 * tensor), boundary "bc" (a vector). Values from their indices. */
static pa_mesh *mesh_with_fields(int dim, int n) {
  pa_mesh *m = NULL;
  CHECK_OK(pa_mesh_generate_box(dim, n, &m));
  pa_idx nv = pa_mesh_nvert(m), ne = pa_mesh_nelem(m), nb = pa_mesh_nbdry(m);
  int tn = dim == 2 ? 3 : 6;
  double *u = malloc(sizeof *u * nv), *r = malloc(sizeof *r * ne);
  double *sg = malloc(sizeof *sg * ne * tn), *bc = malloc(sizeof *bc * nb * dim);
  for (pa_idx i = 0; i < nv; i++) u[i] = 0.5 * i;
  for (pa_idx i = 0; i < ne; i++) r[i] = 1.0 + i;
  for (pa_idx i = 0; i < ne * tn; i++) sg[i] = -0.25 * i;
  for (pa_idx i = 0; i < nb * dim; i++) bc[i] = 100.0 + i;
  CHECK_OK(pa_mesh_add_field(m, "u", 1, u));
  CHECK_OK(pa_mesh_add_field_at(m, PA_ELEMENT, "rho", 1, r));
  CHECK_OK(pa_mesh_add_field_at(m, PA_ELEMENT, "sig", tn, sg));
  CHECK_OK(pa_mesh_add_field_at(m, PA_BOUNDARY, "bc", dim, bc));
  free(u), free(r), free(sg), free(bc);
  return m;
}

/* 1 if field ka on entities at of a has the values of field kb of b. */
static int same_values(pa_mesh *a, pa_entity at, int ka, pa_mesh *b, int kb) {
  int na, nb;
  double *va, *vb;
  if (pa_mesh_field_at(a, at, ka, NULL, &na, &va) ||
      pa_mesh_field_at(b, at, kb, NULL, &nb, &vb) || na != nb)
    return 0;
  pa_idx n = at == PA_VERTEX    ? pa_mesh_nvert(a)
             : at == PA_ELEMENT ? pa_mesh_nelem(a)
                                : pa_mesh_nbdry(a);
  return !memcmp(va, vb, sizeof *va * (size_t)n * na);
}

/* .sol and .solb round trips through pa_mesh_fields_to_sol and
 * pa_mesh_fields_from_sol, in 2D and 3D. */
static void test_sol_round_trip(void) {
  for (int dim = 2; dim <= 3; dim++)
    for (int bin = 0; bin < 2; bin++) {
      pa_mesh *m = mesh_with_fields(dim, 2), *c = NULL;
      const char *path = bin ? "f.solb" : "f.sol";
      pa_sol *s = NULL, *r = NULL;
      CHECK_OK(pa_mesh_fields_to_sol(m, &s));
      CHECK(pa_sol_nfield(s) == 4);
      pa_sol_at at;
      pa_idx n;
      CHECK_OK(pa_sol_field_where(s, 1, &at, &n, NULL));
      CHECK(at == (dim == 2 ? PA_SOL_AT_TRIANGLES : PA_SOL_AT_TETRAHEDRA) &&
            n == pa_mesh_nelem(m));
      CHECK_OK(pa_sol_field_where(s, 3, &at, &n, NULL));
      CHECK(at == (dim == 2 ? PA_SOL_AT_EDGES : PA_SOL_AT_TRIANGLES) &&
            n == pa_mesh_nbdry(m));
      CHECK_OK(pa_sol_write(s, path));
      CHECK_OK(pa_sol_read(path, &r));
      CHECK(r && pa_sol_nfield(r) == 4);
      /* into a mesh of the same entities without fields */
      CHECK_OK(pa_mesh_generate_box(dim, 2, &c));
      CHECK_OK(pa_mesh_fields_from_sol(c, r));
      CHECK(pa_mesh_nfield_at(c, PA_VERTEX) == 1);
      CHECK(pa_mesh_nfield_at(c, PA_ELEMENT) == 2);
      CHECK(pa_mesh_nfield_at(c, PA_BOUNDARY) == 1);
      CHECK(pa_mesh_field_index(c, PA_ELEMENT, "cell2") == 1);
      CHECK(pa_mesh_field_index(c, PA_BOUNDARY, "face1") == 0);
      CHECK(pa_mesh_field_index(c, PA_VERTEX, "field1") == 0);
      CHECK(same_values(m, PA_VERTEX, 0, c, 0));
      CHECK(same_values(m, PA_ELEMENT, 0, c, 0));
      CHECK(same_values(m, PA_ELEMENT, 1, c, 1));
      CHECK(same_values(m, PA_BOUNDARY, 0, c, 0));
      /* a second file numbers its fields after the first's */
      CHECK_OK(pa_mesh_fields_from_sol(c, r));
      CHECK(pa_mesh_field_index(c, PA_ELEMENT, "cell4") == 3);
      pa_sol_destroy(s);
      pa_sol_destroy(r);
      pa_mesh_destroy(c);
      pa_mesh_destroy(m);
      remove(path);
    }
}

/* A hand-written file: one keyword of several types ("3 2 1 1"), each kind of
 * entity, read into a 2D mesh of 2 triangles. */
static void test_sol_hand_written(void) {
  pa_mesh *m = NULL;
  CHECK_OK(pa_mesh_generate_box(2, 1, &m)); /* 4 vertices, 2 triangles, 4 edges */
  write_text("h.sol", "MeshVersionFormatted 2\nDimension 2\n"
                      "SolAtTriangles\n2\n3 2 1 1\n1.5 2.5 2 1\n0 4 5 6\n"
                      "SolAtEdges\n4\n1 2\n1 0\n2 0\n3 0\n4 0\nEnd\n");
  pa_sol *s = NULL;
  CHECK_OK(pa_sol_read("h.sol", &s));
  CHECK_OK(pa_mesh_fields_from_sol(m, s));
  CHECK(pa_mesh_nfield_at(m, PA_ELEMENT) == 3);
  double *v;
  int nc;
  CHECK_OK(pa_mesh_field_at(m, PA_ELEMENT, 0, NULL, &nc, &v));
  CHECK(nc == 2 && v[0] == 1.5 && v[1] == 2.5 && v[2] == 0 && v[3] == 4);
  CHECK_OK(pa_mesh_field_at(m, PA_ELEMENT, 2, NULL, &nc, &v));
  CHECK(nc == 1 && v[0] == 1 && v[1] == 6);
  CHECK_OK(pa_mesh_field_at(m, PA_BOUNDARY, 0, NULL, &nc, &v));
  CHECK(nc == 2 && v[6] == 4 && v[7] == 0);
  pa_sol_destroy(s);
  /* written back: one keyword per place, the vertex count 0 */
  CHECK_OK(pa_mesh_fields_to_sol(m, &s));
  CHECK_OK(pa_sol_write(s, "h2.sol"));
  pa_sol_destroy(s);
  FILE *fp = fopen("h2.sol", "r");
  char text[4096] = "";
  size_t got = fread(text, 1, sizeof text - 1, fp);
  text[got] = '\0';
  fclose(fp);
  CHECK(strstr(text, "SolAtTriangles\n2\n3 2 1 1\n") != NULL);
  CHECK(strstr(text, "SolAtEdges\n4\n1 2\n") != NULL);
  CHECK(!strstr(text, "SolAtVertices"));
  pa_mesh_destroy(m);
  remove("h.sol");
  remove("h2.sol");
}

/* Bad input: the message names the file and line, or the entity; the mesh
 * keeps the fields it had. */
static void test_sol_errors(void) {
  pa_mesh *m = NULL;
  pa_sol *s = NULL;
  CHECK_OK(pa_mesh_generate_box(2, 1, &m));
  CHECK_OK(pa_mesh_add_field_at(m, PA_ELEMENT, "keep", 1, (double[]){1, 2}));
  /* a count that is not the mesh's */
  write_text("e1.sol", "MeshVersionFormatted 2\nDimension 2\n\n"
                       "SolAtVertices\n4\n1 1\n1\n2\n3\n4\n"
                       "SolAtTriangles\n3\n1 1\n1\n2\n3\nEnd\n");
  CHECK_OK(pa_sol_read("e1.sol", &s));
  CHECK(pa_mesh_fields_from_sol(m, s) == PA_ERR_FORMAT);
  CHECK(has_msg("e1.sol:11: 3 values per field at triangles, but the mesh "
                "has 2 triangles"));
  CHECK(pa_mesh_nfield(m) == 0 && pa_mesh_nfield_at(m, PA_ELEMENT) == 1);
  pa_sol_destroy(s);
  /* a value that is not finite */
  write_text("e2.sol", "MeshVersionFormatted 2\nDimension 2\n"
                       "SolAtEdges\n4\n1 1\n1\n2\ninf\n4\nEnd\n");
  CHECK_OK(pa_sol_read("e2.sol", &s));
  CHECK(pa_mesh_fields_from_sol(m, s) == PA_ERR_ARG);
  CHECK(has_msg("e2.sol:3") && has_msg("boundary entity 3 is not finite"));
  CHECK(pa_mesh_nfield_at(m, PA_BOUNDARY) == 0);
  pa_sol_destroy(s);
  /* tetrahedra in 2D */
  write_text("e3.sol", "MeshVersionFormatted 2\nDimension 2\n"
                       "SolAtTetrahedra\n2\n1 1\n1\n2\nEnd\n");
  CHECK_OK(pa_sol_read("e3.sol", &s));
  CHECK(pa_mesh_fields_from_sol(m, s) == PA_ERR_FORMAT);
  CHECK(has_msg("e3.sol:3") && has_msg("tetrahedra"));
  /* not a metric */
  CHECK(pa_mesh_metric_from_sol(m, s, 0) == PA_ERR_ARG);
  CHECK(has_msg("not at vertices"));
  pa_sol_destroy(s);
  /* two keywords of one place that disagree on their count */
  write_text("e4.sol", "MeshVersionFormatted 2\nDimension 2\n"
                       "SolAtTriangles\n2\n1 1\n1\n2\n"
                       "SolAtTriangles\n1\n1 1\n1\nEnd\n");
  CHECK(pa_sol_read("e4.sol", &s) == PA_ERR_FORMAT);
  CHECK(has_msg("e4.sol:8: SolAtTriangles with 1 triangles after one with 2"));
  /* no solution at all */
  write_text("e5.sol", "MeshVersionFormatted 2\nDimension 2\nEnd\n");
  CHECK(pa_sol_read("e5.sol", &s) == PA_ERR_FORMAT);
  CHECK(has_msg("no SolAtVertices"));
  CHECK(pa_mesh_nfield_at(m, PA_ELEMENT) == 1);
  pa_mesh_destroy(m);
  for (int k = 1; k <= 5; k++) {
    char p[16];
    snprintf(p, sizeof p, "e%d.sol", k);
    remove(p);
  }
}

/* Gmsh: element and boundary fields as $ElementData, ASCII and binary, in
 * a mesh whose cells the writer reorders (references not sorted). */
static void test_gmsh(void) {
  for (int dim = 2; dim <= 3; dim++)
    for (int bin = 0; bin < 2; bin++) {
      pa_mesh *m = mesh_with_fields(dim, 2), *r = NULL;
      /* unsorted references: the writer groups cells by reference */
      int32_t *er = pa_mesh_elem_refs(m);
      for (pa_idx e = 0; e < pa_mesh_nelem(m); e++) er[e] = 1 + (e * 7) % 3;
      /* a boundary field named as an element field shares its view */
      double *bv = malloc(sizeof *bv * pa_mesh_nbdry(m));
      for (pa_idx b = 0; b < pa_mesh_nbdry(m); b++) bv[b] = -1.0 - b;
      CHECK_OK(pa_mesh_add_field_at(m, PA_BOUNDARY, "rho", 1, bv));
      free(bv);
      pa_write_opts o = {0};
      o.binary = bin;
      CHECK_OK(pa_mesh_write(m, "f.msh", &o));
      CHECK_OK(pa_mesh_read("f.msh", &r));
      CHECK(pa_mesh_nfield_at(r, PA_ELEMENT) == 2);
      CHECK(pa_mesh_nfield_at(r, PA_BOUNDARY) == 2);
      /* cells come back grouped by reference: compare by centroid order */
      for (int at = PA_ELEMENT; at <= PA_BOUNDARY; at++)
        for (int k = 0; k < pa_mesh_nfield_at(m, (pa_entity)at); k++) {
          const char *name;
          int nc, nc2;
          double *v, *v2;
          CHECK_OK(pa_mesh_field_at(m, (pa_entity)at, k, &name, &nc, &v));
          int k2 = pa_mesh_field_index(r, (pa_entity)at, name);
          CHECK(k2 >= 0);
          if (k2 < 0) continue;
          CHECK_OK(pa_mesh_field_at(r, (pa_entity)at, k2, NULL, &nc2, &v2));
          CHECK(nc == nc2);
          int nvc = at == PA_ELEMENT ? dim + 1 : dim;
          pa_idx n = at == PA_ELEMENT ? pa_mesh_nelem(m) : pa_mesh_nbdry(m);
          const pa_idx *cm = at == PA_ELEMENT ? pa_mesh_elems(m) : pa_mesh_bdrys(m);
          const pa_idx *cr = at == PA_ELEMENT ? pa_mesh_elems(r) : pa_mesh_bdrys(r);
          int ok = 1;
          for (pa_idx i = 0; i < n && ok; i++) { /* find cell i of m in r */
            pa_idx j = 0;
            for (; j < n; j++) {
              int same = 1;
              for (int a = 0; a < nvc; a++) same &= cm[nvc * i + a] == cr[nvc * j + a];
              if (same) break;
            }
            ok = j < n && !memcmp(v + (size_t)nc * i, v2 + (size_t)nc * j,
                                  sizeof *v * nc);
          }
          CHECK(ok);
        }
      pa_mesh_destroy(m);
      pa_mesh_destroy(r);
    }
  remove("f.msh");
}

/* A Gmsh view on the elements only (Gmsh writes views on part of the
 * cells) becomes an element field; one with a value missing is not read;
 * one with a NaN is refused naming the element. MSH 2.2 too. */
static void test_gmsh_hand_written(void) {
  const char *head = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n"
                     "$Nodes\n1 4 1 4\n2 1 0 4\n1\n2\n3\n4\n"
                     "0 0 0\n1 0 0\n1 1 0\n0 1 0\n$EndNodes\n"
                     "$Elements\n2 6 1 6\n1 1 1 4\n1 1 2\n2 2 3\n3 3 4\n4 4 1\n"
                     "2 1 2 2\n5 1 2 3\n6 1 3 4\n$EndElements\n";
  char text[2048];
  snprintf(text, sizeof text,
           "%s$ElementData\n1\n\"rho\"\n1\n0.0\n3\n0\n1\n2\n6 7.5\n5 2.5\n"
           "$EndElementData\n$ElementData\n1\n\"part\"\n1\n0.0\n3\n0\n1\n1\n"
           "5 1\n$EndElementData\n",
           head);
  write_text("h.msh", text);
  pa_mesh *m = NULL;
  CHECK_OK(pa_mesh_read("h.msh", &m));
  CHECK(m && pa_mesh_nfield_at(m, PA_ELEMENT) == 1 &&
        pa_mesh_nfield_at(m, PA_BOUNDARY) == 0);
  double *v;
  if (m) {
    CHECK_OK(pa_mesh_field_at(m, PA_ELEMENT, 0, NULL, NULL, &v));
    CHECK(v[0] == 2.5 && v[1] == 7.5);
  }
  pa_mesh_destroy(m);
  m = NULL;
  snprintf(text, sizeof text,
           "%s$ElementData\n1\n\"rho\"\n1\n0.0\n3\n0\n1\n2\n6 nan\n5 2.5\n"
           "$EndElementData\n",
           head);
  write_text("h.msh", text);
  CHECK(pa_mesh_read("h.msh", &m) == PA_ERR_FORMAT);
  CHECK(has_msg("h.msh:") && has_msg("element 6 is not finite"));
  write_text("h22.msh",
             "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n3\n1 0 0 0\n"
             "2 1 0 0\n3 0 1 0\n$EndNodes\n$Elements\n1\n7 2 2 0 1 1 2 3\n"
             "$EndElements\n$ElementData\n1\n\"rho\"\n1\n0.0\n3\n0\n1\n1\n"
             "7 -3\n$EndElementData\n");
  m = NULL;
  CHECK_OK(pa_mesh_read("h22.msh", &m));
  CHECK(m && pa_mesh_nfield_at(m, PA_ELEMENT) == 1);
  if (m) {
    CHECK_OK(pa_mesh_field_at(m, PA_ELEMENT, 0, NULL, NULL, &v));
    CHECK(v[0] == -3);
  }
  pa_mesh_destroy(m);
  remove("h.msh");
  remove("h22.msh");
}

TEST_MAIN(test_sol_round_trip, test_sol_hand_written, test_sol_errors, test_gmsh,
          test_gmsh_hand_written)
