/*
 * test_gmsh.c -- Gmsh .msh reader and writer: 2D and 3D round trips in ASCII
 * and binary (coordinates bit for bit, connectivity, references, boundary,
 * feature edges, corners), hand-written MSH 4.1 and 2.2 files, error messages,
 * every truncation and random corruptions of a file, allocation failures, and
 * the malformed files of tests/data/bad (gmsh.expected); physical names and
 * node data views (metric and fields) in both encodings, and their errors.
 */
#include "testutil.h"

#include <math.h>
#include <sys/stat.h>
#include <unistd.h>

/* ---- test meshes, built by hand ---- */

/* Unit square, n x n squares of two triangles, coordinates jittered so that
 * they have no short decimal form. Element references by column half (sorted
 * in element order), boundary references 1..4, corners flagged with ref 7. */
static pa_mesh *make_square(int n) {
  pa_mesh *m = NULL;
  if (pa_mesh_create(2, &m)) return NULL;
  pa_test_seed(42);
  for (int j = 0; j <= n; j++)
    for (int i = 0; i <= n; i++) {
      double x[2] = {(double)i / n, (double)j / n};
      if (i > 0 && i < n) x[0] += pa_test_rand_range(-0.1, 0.1) / n;
      if (j > 0 && j < n) x[1] += pa_test_rand_range(-0.1, 0.1) / n;
      pa_mesh_add_vertex(m, x, 0, NULL);
    }
  for (int half = 0; half < 2; half++)
    for (int j = 0; j < n; j++)
      for (int i = half * n / 2; i < (half + 1) * n / 2; i++) {
        pa_idx a = j * (n + 1) + i, b = a + 1, c = a + n + 2, d = a + n + 1;
        pa_idx t1[3] = {a, b, c}, t2[3] = {a, c, d};
        pa_mesh_add_elem(m, t1, half + 1, NULL);
        pa_mesh_add_elem(m, t2, half + 1, NULL);
      }
  for (int k = 0; k < n; k++) {
    pa_idx e1[2] = {k * (n + 1), (k + 1) * (n + 1)};         /* x=0 */
    pa_idx e2[2] = {k * (n + 1) + n, (k + 1) * (n + 1) + n}; /* x=1 */
    pa_idx e3[2] = {k, k + 1};                               /* y=0 */
    pa_idx e4[2] = {n * (n + 1) + k, n * (n + 1) + k + 1};   /* y=1 */
    pa_mesh_add_bdry(m, e1, 1, NULL);
    pa_mesh_add_bdry(m, e2, 2, NULL);
    pa_mesh_add_bdry(m, e3, 3, NULL);
    pa_mesh_add_bdry(m, e4, 4, NULL);
  }
  pa_idx corners[4] = {0, n, n * (n + 1), n * (n + 1) + n};
  for (int k = 0; k < 4; k++) {
    pa_mesh_vert_flags(m)[corners[k]] |= PA_FLAG_CORNER;
    pa_mesh_vert_refs(m)[corners[k]] = 7;
  }
  return m;
}

/* Unit cube, n^3 hexahedra of six tetrahedra, jittered coordinates; element
 * references 1 then 2 (sorted); boundary triangles on z = 0 (ref 5) and
 * z = 1 (ref 6); feature edges along the x axis (ref 9); corner 0 flagged. */
static pa_mesh *make_cube(int n) {
  pa_mesh *m = NULL;
  if (pa_mesh_create(3, &m)) return NULL;
  pa_test_seed(7);
  int p = n + 1;
  for (int k = 0; k <= n; k++)
    for (int j = 0; j <= n; j++)
      for (int i = 0; i <= n; i++) {
        double x[3] = {(double)i / n, (double)j / n, (double)k / n};
        for (int d = 0; d < 3; d++)
          x[d] += pa_test_rand_range(-1e-3, 1e-3);
        pa_mesh_add_vertex(m, x, 0, NULL);
      }
  static const int tet[6][4] = {{0, 1, 2, 6}, {0, 2, 3, 6}, {0, 3, 7, 6},
                                {0, 7, 4, 6}, {0, 4, 5, 6}, {0, 5, 1, 6}};
  int ncell = n * n * n, c = 0;
  for (int k = 0; k < n; k++)
    for (int j = 0; j < n; j++)
      for (int i = 0; i < n; i++, c++) {
        pa_idx v0 = i + p * (j + p * k);
        pa_idx h[8] = {
            v0,         v0 + 1,         v0 + 1 + p,         v0 + p,
            v0 + p * p, v0 + 1 + p * p, v0 + 1 + p + p * p, v0 + p + p * p};
        for (int t = 0; t < 6; t++) {
          pa_idx v[4] = {h[tet[t][0]], h[tet[t][1]], h[tet[t][2]],
                         h[tet[t][3]]};
          pa_mesh_add_elem(m, v, c < ncell / 2 ? 1 : 2, NULL);
        }
      }
  for (int z = 0; z <= n; z += n)
    for (int j = 0; j < n; j++)
      for (int i = 0; i < n; i++) {
        pa_idx a = i + p * (j + p * z), b = a + 1, cc = a + 1 + p, d = a + p;
        pa_idx t1[3] = {a, cc, b}, t2[3] = {a, d, cc};
        pa_mesh_add_bdry(m, t1, z ? 6 : 5, NULL);
        pa_mesh_add_bdry(m, t2, z ? 6 : 5, NULL);
      }
  for (int i = 0; i < n; i++) {
    pa_idx e[2] = {i, i + 1};
    pa_mesh_add_edge(m, e, 9, NULL);
  }
  pa_mesh_vert_flags(m)[0] |= PA_FLAG_CORNER;
  pa_mesh_vert_refs(m)[0] = 3;
  return m;
}

/* Stable order of n references (what the writer does with cells). */
static pa_idx *stable_order(const int32_t *ref, pa_idx n) {
  pa_idx *o = malloc((n ? n : 1) * sizeof *o);
  for (pa_idx i = 0; i < n; i++)
    o[i] = i;
  for (pa_idx i = 1; i < n; i++) { /* insertion sort: stable */
    pa_idx x = o[i], j = i - 1;
    while (j >= 0 && ref[o[j]] > ref[x]) {
      o[j + 1] = o[j];
      j--;
    }
    o[j + 1] = x;
  }
  return o;
}

/* Cells of b equal to the cells of a taken in the writer's order. */
static int same_cells(const pa_idx *va, const int32_t *ra, pa_idx na,
                      const pa_idx *vb, const int32_t *rb, pa_idx nb, int nn) {
  if (na != nb) return 0;
  pa_idx *o = stable_order(ra, na);
  int ok = 1;
  for (pa_idx k = 0; k < na && ok; k++) {
    ok = ra[o[k]] == rb[k] &&
         !memcmp(va + (size_t)nn * o[k], vb + (size_t)nn * k, nn * sizeof *va);
  }
  free(o);
  return ok;
}

/* Everything the .msh format stores is equal. */
static void check_same(pa_mesh *a, pa_mesh *b) {
  int d = pa_mesh_dim(a);
  CHECK(pa_mesh_dim(b) == d);
  CHECK(pa_mesh_nvert(b) == pa_mesh_nvert(a));
  if (pa_mesh_dim(b) != d || pa_mesh_nvert(b) != pa_mesh_nvert(a)) return;
  pa_idx nv = pa_mesh_nvert(a);
  CHECK(!memcmp(pa_mesh_coords(a), pa_mesh_coords(b),
                (size_t)nv * d * sizeof(double)));
  int flags_ok = 1;
  for (pa_idx i = 0; i < nv; i++) {
    int ca = pa_mesh_vert_flags(a)[i] & PA_FLAG_CORNER;
    int cb = pa_mesh_vert_flags(b)[i] & PA_FLAG_CORNER;
    if (ca != cb || (ca && pa_mesh_vert_refs(a)[i] != pa_mesh_vert_refs(b)[i]))
      flags_ok = 0;
  }
  CHECK(flags_ok);
  CHECK(same_cells(pa_mesh_elems(a), pa_mesh_elem_refs(a), pa_mesh_nelem(a),
                   pa_mesh_elems(b), pa_mesh_elem_refs(b), pa_mesh_nelem(b),
                   d + 1));
  CHECK(same_cells(pa_mesh_bdrys(a), pa_mesh_bdry_refs(a), pa_mesh_nbdry(a),
                   pa_mesh_bdrys(b), pa_mesh_bdry_refs(b), pa_mesh_nbdry(b),
                   d));
  CHECK(same_cells(pa_mesh_edges(a), pa_mesh_edge_refs(a), pa_mesh_nedge(a),
                   pa_mesh_edges(b), pa_mesh_edge_refs(b), pa_mesh_nedge(b),
                   2));
}

static void roundtrip(pa_mesh *m, const char *path, int binary) {
  pa_write_opts opts = {binary, 0, 0};
  pa_mesh *r = NULL;
  CHECK_OK(pa_mesh_write(m, path, &opts));
  CHECK_OK(pa_mesh_read(path, &r));
  if (r) check_same(m, r);
  pa_mesh_destroy(r);
  /* The header says what was asked for. */
  FILE *fp = fopen(path, "rb");
  char head[32] = {0};
  CHECK(fp && fread(head, 1, 20, fp) == 20);
  if (fp) fclose(fp);
  CHECK(strstr(head, binary ? "4.1 1 8" : "4.1 0 8") != NULL);
}

static void test_roundtrip_2d(void) {
  pa_mesh *m = make_square(6);
  CHECK(m && pa_mesh_nelem(m) == 72 && pa_mesh_nbdry(m) == 24);
  roundtrip(m, "sq_ascii.msh", 0);
  roundtrip(m, "sq_binary.msh", 1);
  pa_mesh_destroy(m);
}

static void test_roundtrip_3d(void) {
  pa_mesh *m = make_cube(4);
  CHECK(m && pa_mesh_nelem(m) == 384 && pa_mesh_nedge(m) == 4);
  roundtrip(m, "cube_ascii.msh", 0);
  roundtrip(m, "cube_binary.msh", 1);
  pa_mesh_destroy(m);
}

/* References in any order, zero and negative: cells come back grouped by
 * reference, stably, with the same references. */
static void test_roundtrip_refs(void) {
  pa_mesh *m = make_square(4);
  int32_t *er = pa_mesh_elem_refs(m), *br = pa_mesh_bdry_refs(m);
  for (pa_idx e = 0; e < pa_mesh_nelem(m); e++)
    er[e] = (int32_t[]){3, -2, 0, 3, 1000}[e % 5];
  for (pa_idx b = 0; b < pa_mesh_nbdry(m); b++)
    br[b] = b % 3 - 1;
  roundtrip(m, "refs_ascii.msh", 0);
  roundtrip(m, "refs_binary.msh", 1);
  /* An empty mesh and a mesh without elements survive too. */
  pa_mesh *e = NULL, *r = NULL;
  CHECK_OK(pa_mesh_create(3, &e));
  CHECK_OK(pa_mesh_write(e, "empty.msh", NULL));
  CHECK_OK(pa_mesh_read("empty.msh", &r));
  CHECK(r && pa_mesh_nvert(r) == 0 && pa_mesh_nelem(r) == 0);
  pa_mesh_destroy(r);
  r = NULL;
  double x[3] = {0.5, 0.25, 1.0 / 3};
  CHECK_OK(pa_mesh_add_vertex(e, x, 0, NULL));
  roundtrip(e, "lonely.msh", 1);
  pa_mesh_destroy(e);
  pa_mesh_destroy(m);
}

static void write_text(const char *path, const char *text) {
  FILE *fp = fopen(path, "wb");
  CHECK(fp != NULL);
  if (!fp) return;
  fputs(text, fp);
  fclose(fp);
}

/* MSH 4.1 ASCII as Gmsh writes it, with sparse node tags, two surfaces of
 * different physical tags, a curve without physical tag, a point, names and
 * an unknown section. */
static void test_read_handwritten41(void) {
  write_text("hand41.msh",
             "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n"
             "$PhysicalNames\n3\n1 7 \"wall\"\n2 100 \"left part\"\n"
             "2 200 \"right\"\n$EndPhysicalNames\n"
             "$Comments\nanything $Nodes 1 2 3\n$EndComments\n"
             "$Entities\n1 2 2 0\n"
             "4 0 0 0 1 11\n"
             "5 0 0 0 1 0 0 1 7 2 4 -4\n"
             "6 0 1 0 1 1 0 0 0\n"
             "1 0 0 0 0.5 1 0 1 100 0\n"
             "2 0.5 0 0 1 1 0 2 200 300 0\n"
             "$EndEntities\n"
             "$Nodes\n2 5 10 99\n"
             "2 1 0 3\n10\n20\n99\n0 0 0\n1 0 0\n0.5 0.5 0\n"
             "2 2 0 2\n40\n30\n0 1 0\n1 1 0\n"
             "$EndNodes\n"
             "$Elements\n5 7 1 7\n"
             "0 4 15 1\n1 10\n"
             "1 5 1 1\n2 10 20\n"
             "1 6 1 1\n3 30 40\n"
             "2 1 2 2\n4 10 20 99\n5 10 99 40\n"
             "2 2 2 2\n6 20 30 99\n7 99 30 40\n"
             "$EndElements\n"
             "$NodeData\n1\n\"u\"\n1\n0.0\n3\n0\n1\n1\n10 1.5\n$EndNodeData\n");
  pa_mesh *m = NULL;
  CHECK_OK(pa_mesh_read("hand41.msh", &m));
  if (!m) return;
  CHECK(pa_mesh_dim(m) == 2);
  CHECK(pa_mesh_nvert(m) == 5 && pa_mesh_nelem(m) == 4);
  CHECK(pa_mesh_nbdry(m) == 2 && pa_mesh_nedge(m) == 0);
  /* vertices in tag order: 10 20 30 40 99 */
  const double *x = pa_mesh_coords(m);
  static const double want_x[10] = {0, 0, 1, 0, 1, 1, 0, 1, 0.5, 0.5};
  CHECK(!memcmp(x, want_x, sizeof want_x));
  const pa_idx *t = pa_mesh_elems(m);
  static const pa_idx want[12] = {0, 1, 4, 0, 4, 3, 1, 2, 4, 4, 2, 3};
  CHECK(!memcmp(t, want, sizeof want));
  const int32_t *r = pa_mesh_elem_refs(m);
  CHECK(r[0] == 100 && r[1] == 100 && r[2] == 200 && r[3] == 200);
  const pa_idx *b = pa_mesh_bdrys(m);
  CHECK(b[0] == 0 && b[1] == 1 && b[2] == 2 && b[3] == 3);
  CHECK(pa_mesh_bdry_refs(m)[0] == 7); /* physical tag of curve 5 */
  CHECK(pa_mesh_bdry_refs(m)[1] == 6); /* curve 6 has none: entity tag */
  CHECK(pa_mesh_vert_flags(m)[0] & PA_FLAG_CORNER);
  CHECK(pa_mesh_vert_refs(m)[0] == 11);
  CHECK(!(pa_mesh_vert_flags(m)[1] & PA_FLAG_CORNER));
  /* the names, sorted by (dimension, tag); the view "u" covers one node
   * only: ignored */
  CHECK(pa_mesh_nnames(m) == 3);
  int dim = -1;
  int32_t tag = 0;
  const char *name = NULL;
  CHECK_OK(pa_mesh_name(m, 1, &dim, &tag, &name));
  CHECK(dim == 2 && tag == 100 && name && !strcmp(name, "left part"));
  CHECK(pa_mesh_nfield(m) == 0 && pa_mesh_metric_ncomp(m) == 0);
  pa_mesh_destroy(m);
}

/* A classified MSH 4.1 file as Gmsh writes one with physical groups on the
 * surface only: a square of 4 model points, 4 curves (lines listed for
 * curves 1 and 2 only) and a surface, node tags out of order.
 * pa_mesh_read_model keeps the entities, lists the missing curve edges,
 * and the writer gives the classification back; a file without $Entities,
 * and MSH 2.2, are refused. */
static const char *CLASSIFIED =
    "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n"
    "$PhysicalNames\n1\n2 7 \"plate\"\n$EndPhysicalNames\n"
    "$Entities\n4 4 1 0\n"
    "1 0 0 0 0\n2 1 0 0 0\n3 1 1 0 0\n4 0 1 0 0\n"
    "1 0 0 0 1 0 0 0 2 1 -2\n2 1 0 0 1 1 0 0 2 2 -3\n"
    "3 0 1 0 1 1 0 0 2 3 -4\n4 0 0 0 0 1 0 0 2 4 -1\n"
    "1 0 0 0 1 1 0 1 7 4 1 2 3 4\n"
    "$EndEntities\n"
    "$Nodes\n5 5 5 40\n"
    "0 1 0 1\n40\n0 0 0\n0 2 0 1\n30\n1 0 0\n"
    "0 3 0 1\n20\n1 1 0\n0 4 0 1\n10\n0 1 0\n"
    "2 1 0 1\n5\n0.5 0.5 0\n"
    "$EndNodes\n"
    "$Elements\n3 6 1 6\n"
    "1 1 1 1\n1 40 30\n1 2 1 1\n2 30 20\n"
    "2 1 2 4\n3 40 30 5\n4 30 20 5\n5 20 10 5\n6 10 40 5\n"
    "$EndElements\n";

static void test_read_classified(void) {
  write_text("classified.msh", CLASSIFIED);
  pa_mesh *m = NULL, *back = NULL, *plain = NULL;
  CHECK_OK(pa_mesh_read_model("classified.msh", &m));
  if (!m) return;
  CHECK(pa_mesh_classified(m));
  /* vertices in tag order: 5 (the surface's), 10 (P4), 20 (P3), 30 (P2),
   * 40 (P1) */
  static const uint8_t want_dim[5] = {2, 0, 0, 0, 0};
  static const int32_t want_tag[5] = {1, 4, 3, 2, 1};
  CHECK(!memcmp(pa_mesh_vert_entity_dims(m), want_dim, 5));
  CHECK(!memcmp(pa_mesh_vert_entity_tags(m), want_tag, sizeof want_tag));
  for (pa_idx v = 1; v < 5; v++)
    CHECK((pa_mesh_vert_flags(m)[v] & PA_FLAG_CORNER) &&
          pa_mesh_vert_refs(m)[v] == want_tag[v]);
  CHECK(pa_mesh_nbdry(m) == 4); /* curves 3 and 4 added */
  int seen = 0;
  for (pa_idx b = 0; b < pa_mesh_nbdry(m); b++) {
    const pa_idx *e = pa_mesh_bdrys(m) + 2 * b;
    int32_t r = pa_mesh_bdry_refs(m)[b];
    /* curve c joins points c and c % 4 + 1: vertices 5 - c, 5 - c % 4 - 1 */
    pa_idx a = 5 - r, c = 5 - (r % 4 + 1);
    CHECK((e[0] == a && e[1] == c) || (e[0] == c && e[1] == a));
    seen |= 1 << r;
  }
  CHECK(seen == 0x1e);
  for (pa_idx k = 0; k < 4; k++) CHECK(pa_mesh_elem_refs(m)[k] == 1);
  CHECK_OK(pa_mesh_check(m));
  /* written back: the same classification; the physical tag again */
  CHECK_OK(pa_mesh_write(m, "classified-out.msh", NULL));
  CHECK_OK(pa_mesh_read_model("classified-out.msh", &back));
  if (back) {
    CHECK(pa_mesh_nvert(back) == 5 && pa_mesh_nbdry(back) == 4);
    CHECK(!memcmp(pa_mesh_vert_entity_dims(back), want_dim, 5));
    CHECK(!memcmp(pa_mesh_vert_entity_tags(back), want_tag, sizeof want_tag));
    CHECK(pa_mesh_nnames(back) == 1);
  }
  CHECK_OK(pa_mesh_read("classified-out.msh", &plain));
  if (plain) {
    CHECK(!pa_mesh_classified(plain));
    CHECK(pa_mesh_elem_refs(plain)[0] == 7);
  }
  pa_mesh_destroy(back);
  pa_mesh_destroy(plain);
  pa_mesh_destroy(m);
  /* no $Entities: nothing says where a node lies */
  const char *ent = strstr(CLASSIFIED, "$Entities");
  const char *end = strstr(CLASSIFIED, "$Nodes");
  char buf[2048];
  snprintf(buf, sizeof buf, "%.*s%s", (int)(ent - CLASSIFIED), CLASSIFIED,
           end);
  write_text("noentities.msh", buf);
  m = NULL;
  CHECK(pa_mesh_read_model("noentities.msh", &m) == PA_ERR_FORMAT && !m);
  CHECK(strstr(pa_last_error(), "noentities.msh") &&
        strstr(pa_last_error(), "$Entities"));
  /* a node block on an entity $Entities lacks */
  snprintf(buf, sizeof buf, "%s", CLASSIFIED);
  char *blk = strstr(buf, "2 1 0 1\n5\n");
  if (blk) blk[2] = '9';
  write_text("badentity.msh", buf);
  CHECK(pa_mesh_read_model("badentity.msh", &m) == PA_ERR_FORMAT && !m);
  CHECK(strstr(pa_last_error(), "(2, 9)") != NULL);
  CHECK(pa_mesh_read_model("classified.mesh", &m) == PA_ERR_UNSUPPORTED);
  /* out of memory anywhere in the classified read and write: an error, no
   * mesh, no file, no leak */
  int nok = 0, nbad = 0;
  for (long k = 1; k < 120; k++) {
    remove("classified-w.msh");
    pa_memory_fail_after(k);
    pa_status st = pa_mesh_read_model("classified.msh", &m);
    if (st == PA_SUCCESS) st = pa_mesh_write(m, "classified-w.msh", NULL);
    pa_memory_fail_after(0);
    int exists = access("classified-w.msh", F_OK) == 0;
    if (st == PA_SUCCESS)
      nok += exists;
    else if (st != PA_ERR_MEMORY || exists)
      nbad++;
    pa_mesh_destroy(m);
    m = NULL;
  }
  CHECK(nok > 0 && nbad == 0);
}

/* MSH 2.2 ASCII: a tetrahedron, one face and one edge. */
/* Very sparse tags (sorted map) listed out of order. */
static void test_read_sparse_tags(void) {
  write_text("sparse.msh", "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n"
                           "$Nodes\n2 3 5 9000000000\n"
                           "2 1 0 2\n9000000000\n5\n0 1 0\n0 0 0\n"
                           "2 1 0 1\n70000\n1 0 0\n$EndNodes\n"
                           "$Elements\n1 1 1 1\n2 1 2 1\n1 5 70000 9000000000\n"
                           "$EndElements\n");
  pa_mesh *m = NULL;
  CHECK_OK(pa_mesh_read("sparse.msh", &m));
  if (!m) return;
  static const double want_x[6] = {0, 0, 1, 0, 0, 1};
  static const pa_idx want_t[3] = {0, 1, 2};
  CHECK(pa_mesh_nvert(m) == 3 && pa_mesh_nelem(m) == 1);
  CHECK(!memcmp(pa_mesh_coords(m), want_x, sizeof want_x));
  CHECK(!memcmp(pa_mesh_elems(m), want_t, sizeof want_t));
  CHECK(pa_mesh_elem_refs(m)[0] == 1); /* no $Entities: the entity tag */
  pa_mesh_destroy(m);
}

static void test_read_handwritten22(void) {
  write_text("hand22.msh",
             "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n"
             "$PhysicalNames\n1\n3 5 \"volume\"\n$EndPhysicalNames\n"
             "$Nodes\n4\n3 0 0 0\n5 1 0 0\n8 0 1 0\n13 0 0 1\n$EndNodes\n"
             "$Elements\n4\n"
             "1 4 2 5 1 3 5 8 13\n"
             "2 2 2 0 4 3 8 5\n"
             "3 1 3 6 2 0 3 5\n"
             "4 15 2 0 1 13\n"
             "$EndElements\n");
  pa_mesh *m = NULL;
  {
    pa_mesh *c = NULL; /* no classification in MSH 2.2 */
    CHECK(pa_mesh_read_model("hand22.msh", &c) == PA_ERR_FORMAT && !c);
    CHECK(strstr(pa_last_error(), "MSH 2.2") != NULL);
  }
  CHECK_OK(pa_mesh_read("hand22.msh", &m));
  if (!m) return;
  CHECK(pa_mesh_dim(m) == 3 && pa_mesh_nvert(m) == 4);
  CHECK(pa_mesh_nelem(m) == 1 && pa_mesh_nbdry(m) == 1 &&
        pa_mesh_nedge(m) == 1);
  CHECK(pa_mesh_coords(m)[3 * 3 + 2] == 1.0);
  static const pa_idx tet[4] = {0, 1, 2, 3}, tri[3] = {0, 2, 1};
  static const pa_idx edge[2] = {0, 1};
  CHECK(!memcmp(pa_mesh_elems(m), tet, sizeof tet));
  CHECK(!memcmp(pa_mesh_bdrys(m), tri, sizeof tri));
  CHECK(!memcmp(pa_mesh_edges(m), edge, sizeof edge));
  CHECK(pa_mesh_elem_refs(m)[0] == 5); /* physical */
  CHECK(pa_mesh_bdry_refs(m)[0] == 4); /* physical 0: elementary */
  CHECK(pa_mesh_edge_refs(m)[0] == 6);
  CHECK(pa_mesh_vert_flags(m)[3] & PA_FLAG_CORNER);
  pa_mesh_destroy(m);
}

/* Read text as a .msh file: must fail with status code and a message that
 * contains the file name and each fragment. */
static void expect_error(const char *text, pa_status code, const char *frag1,
                         const char *frag2) {
  pa_mesh *m = NULL;
  write_text("bad.msh", text);
  pa_status st = pa_mesh_read("bad.msh", &m);
  CHECK(st == code);
  CHECK(m == NULL);
  const char *msg = pa_last_error();
  int ok = strstr(msg, "bad.msh") && strstr(msg, frag1) &&
           (!frag2 || strstr(msg, frag2));
  CHECK(ok);
  if (!ok || st != code)
    fprintf(stderr, "  message was: %s (%s)\n", msg, pa_status_string(st));
  pa_mesh_destroy(m);
}

#define HEAD "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n"
#define NODES3                                                                 \
  "$Nodes\n1 3 1 3\n2 1 0 3\n1\n2\n3\n0 0 0\n1 0 0\n0 1 0\n$EndNodes\n"

static void test_errors(void) {
  expect_error(
      HEAD NODES3 "$Elements\n1 1 1 1\n2 1 2 1\n1 1 2", PA_ERR_FORMAT,
      ":16: truncated file or bad count: the element block announces 1", NULL);
  expect_error(HEAD NODES3 "$Elements\n1 1 1 1\n2 1 2 1\n1 1 2 3\n",
               PA_ERR_FORMAT,
               ":18: unexpected end of file, expected "
               "$EndElements",
               NULL);
  expect_error(HEAD NODES3 "$Elements\n1 1 1 1\n2 1 3 1\n1 1 2 3 3\n"
                           "$EndElements\n",
               PA_ERR_UNSUPPORTED,
               ":16:", "element type 3 (4-node quadrangle)");
  expect_error(HEAD NODES3 "$Elements\n1 1 1 1\n2 1 2 1\n1 1 2 77\n"
                           "$EndElements\n",
               PA_ERR_FORMAT, ":17: element 1 refers to unknown node tag 77",
               NULL);
  expect_error(HEAD "$Nodes\n1 3 1 3\n2 1 0 3\n1\n2\n3\n0 0 0\nnan 0 0\n"
                    "0 1 0\n$EndNodes\n",
               PA_ERR_FORMAT, ":11: node coordinate is not finite", NULL);
  expect_error(HEAD "$Nodes\n1 3 1 3\n2 1 0 2\n1\n2\n0 0 0\n1 0 0\n"
                    "$EndNodes\n",
               PA_ERR_FORMAT, "declares 3 nodes but its blocks hold 2", NULL);
  expect_error(HEAD "$Nodes\n1 3 1 3\n2 1 0 4\n1\n2\n3\n4\n0 0 0\n1 0 0\n"
                    "0 1 0\n0 1 1\n$EndNodes\n",
               PA_ERR_FORMAT, ":6: node blocks hold more nodes", NULL);
  expect_error(
      HEAD "$Nodes\n1 3000000 1 3\n", PA_ERR_FORMAT,
      ":5: truncated file or bad count: the $Nodes header announces 3000000",
      NULL);
  expect_error(HEAD "$Nodes\n1 3 1 3\n2 1 0 3\n1\n2\n1\n0 0 0\n1 0 0\n"
                    "0 1 0\n$EndNodes\n",
               PA_ERR_FORMAT, "duplicate node tag 1", NULL);
  expect_error(NODES3, PA_ERR_FORMAT, ":1: missing $MeshFormat", NULL);
  expect_error("$MeshFormat\n3.0 0 8\n$EndMeshFormat\n", PA_ERR_UNSUPPORTED,
               ":2: MSH version 3 is not supported", NULL);
  expect_error("$MeshFormat\n2.2 1 8\n$EndMeshFormat\n", PA_ERR_UNSUPPORTED,
               "binary MSH 2.2", NULL);
  expect_error(HEAD NODES3 "$Comments\nno end\n", PA_ERR_FORMAT,
               "no $EndComments line", NULL);
  expect_error(HEAD NODES3, PA_ERR_FORMAT, "no $Elements section", NULL);
  expect_error(HEAD "$Nodes\n1 3 1 3\n2 1 0 3\n1\n2\n3\n0 0 0\n1 0 0\n"
                    "0 1 0.5\n$EndNodes\n$Elements\n1 1 1 1\n2 1 2 1\n"
                    "1 1 2 3\n$EndElements\n",
               PA_ERR_FORMAT, "node 3 has z = 0.5", "plane z = 0");
  expect_error(HEAD NODES3 "$Elements\n1 1 1 1\n2 1 2 1\n1 1 2 3x\n"
                           "$EndElements\n",
               PA_ERR_FORMAT,
               ":17: expected a node tag of an element, found "
               "'3x'",
               NULL);
  expect_error(HEAD NODES3 "$Elements\n1 2 1 2\n2 1 2 1\n1 1 2 3\n"
                           "$EndElements\n",
               PA_ERR_FORMAT, "declares 2 elements but its blocks hold 1",
               NULL);
  expect_error("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n3\n1 0 0 0\n"
               "2 1 0 0\n3 0 1 0\n$EndNodes\n$Elements\n1\n1 5 2 1 1 1 2 3 4 5"
               " 6 7 8\n$EndElements\n",
               PA_ERR_UNSUPPORTED, ":12:", "8-node hexahedron");
  /* A missing file and a directory are i/o errors. */
  pa_mesh *m = NULL;
  CHECK(pa_mesh_read("no_such_file.msh", &m) == PA_ERR_IO);
  CHECK(strstr(pa_last_error(), "no_such_file.msh") != NULL);
  mkdir("adir.msh", 0755);
  CHECK(pa_mesh_read("adir.msh", &m) == PA_ERR_IO);
  CHECK(m == NULL);
}

static unsigned char *slurp(const char *path, size_t *len) {
  FILE *fp = fopen(path, "rb");
  if (!fp) return NULL;
  fseek(fp, 0, SEEK_END);
  *len = (size_t)ftell(fp);
  rewind(fp);
  unsigned char *buf = malloc(*len + 1);
  if (fread(buf, 1, *len, fp) != *len) *len = 0;
  fclose(fp);
  return buf;
}

static void spill(const char *path, const unsigned char *buf, size_t len) {
  FILE *fp = fopen(path, "wb");
  if (!fp) return;
  fwrite(buf, 1, len, fp);
  fclose(fp);
}

/* Every proper prefix of a file (that cuts into "$EndElements") is refused
 * as a format error, without crash or leak (ASan build). */
static void truncations(const char *src, const char *dst) {
  size_t len = 0;
  unsigned char *buf = slurp(src, &len);
  CHECK(buf && len > 100);
  if (!buf) return;
  int bad = 0;
  for (size_t cut = 0; cut + 1 < len; cut++) {
    spill(dst, buf, cut);
    pa_mesh *m = NULL;
    pa_status st = pa_mesh_read(dst, &m);
    if (st != PA_ERR_FORMAT || m) {
      if (!bad++)
        fprintf(stderr, "  %s cut at %zu: %s: %s\n", src, cut,
                pa_status_string(st), pa_last_error());
    }
    pa_mesh_destroy(m);
  }
  CHECK(bad == 0);
  free(buf);
}

static void test_truncated(void) {
  pa_mesh *m = make_cube(1);
  pa_write_opts bin = {1, 0, 0};
  CHECK_OK(pa_mesh_write(m, "trunc_a.msh", NULL));
  CHECK_OK(pa_mesh_write(m, "trunc_b.msh", &bin));
  truncations("trunc_a.msh", "cut.msh");
  truncations("trunc_b.msh", "cut.msh");
  pa_mesh_destroy(m);
}

/* Random byte corruptions of binary and ASCII files: whatever the outcome,
 * no crash, no read past the buffer, no leak; a success gives a mesh whose
 * indices are in range. */
static void test_corrupted(void) {
  pa_mesh *m = make_square(2);
  pa_write_opts bin = {1, 0, 0};
  CHECK_OK(pa_mesh_write(m, "fuzz_b.msh", &bin));
  CHECK_OK(pa_mesh_write(m, "fuzz_a.msh", NULL));
  pa_mesh_destroy(m);
  const char *src[2] = {"fuzz_b.msh", "fuzz_a.msh"};
  pa_test_seed(1234);
  int bad = 0, nfail = 0;
  for (int f = 0; f < 2; f++) {
    size_t len = 0;
    unsigned char *orig = slurp(src[f], &len), *buf = malloc(len);
    for (int it = 0; it < 1500 && orig; it++) {
      memcpy(buf, orig, len);
      int nflip = 1 + (int)(pa_test_rand() * 3);
      for (int k = 0; k < nflip; k++) {
        size_t at = (size_t)(pa_test_rand() * len);
        double u = pa_test_rand();
        buf[at] =
            u < 0.3 ? (unsigned char)(pa_test_rand() * 256)
            : u < 0.6
                ? (unsigned char)"0123456789 -\n$"[(int)(pa_test_rand() * 15)]
                : (unsigned char)(buf[at] ^ (1u << (int)(pa_test_rand() * 8)));
      }
      spill("fuzz.msh", buf, len);
      pa_mesh *r = NULL;
      pa_status st = pa_mesh_read("fuzz.msh", &r);
      if (st) {
        nfail++;
        if (!strstr(pa_last_error(), "fuzz.msh")) bad++;
      } else {
        int d = pa_mesh_dim(r);
        pa_idx nv = pa_mesh_nvert(r);
        for (pa_idx e = 0; e < pa_mesh_nelem(r) * (d + 1); e++)
          if (pa_mesh_elems(r)[e] < 0 || pa_mesh_elems(r)[e] >= nv) bad++;
        for (pa_idx e = 0; e < pa_mesh_nbdry(r) * d; e++)
          if (pa_mesh_bdrys(r)[e] < 0 || pa_mesh_bdrys(r)[e] >= nv) bad++;
      }
      pa_mesh_destroy(r);
    }
    free(orig);
    free(buf);
  }
  CHECK(bad == 0);
  CHECK(nfail > 1000); /* most corruptions are caught */
}

/* Every allocation of a read or a write may fail: PA_ERR_MEMORY, no leak,
 * and no file left behind by a failed write. */
static void test_alloc_failures(void) {
  pa_mesh *m = make_cube(1), *r = NULL;
  pa_write_opts bin = {1, 0, 0};
  CHECK_OK(pa_mesh_write(m, "alloc.msh", &bin));
  int nok = 0, nbad = 0;
  for (long k = 1; k < 200; k++) {
    pa_memory_fail_after(k);
    pa_status st = pa_mesh_read("alloc.msh", &r);
    pa_memory_fail_after(0);
    if (st == PA_SUCCESS) {
      nok++;
      check_same(m, r);
      pa_mesh_destroy(r);
      r = NULL;
    } else if (st != PA_ERR_MEMORY || r) {
      nbad++;
    }
  }
  CHECK(nok > 0 && nbad == 0);
  nok = nbad = 0;
  for (long k = 1; k < 100; k++) {
    remove("alloc_w.msh");
    pa_memory_fail_after(k);
    pa_status st = pa_mesh_write(m, "alloc_w.msh", &bin);
    pa_memory_fail_after(0);
    int exists = access("alloc_w.msh", F_OK) == 0;
    if (st == PA_SUCCESS)
      nok += exists;
    else if (st != PA_ERR_MEMORY || exists)
      nbad++;
  }
  CHECK(nok > 0 && nbad == 0);
  /* A write that cannot open its file leaves nothing either. */
  CHECK(pa_mesh_write(m, "no_such_dir/x.msh", NULL) == PA_ERR_IO);
  CHECK(strstr(pa_last_error(), "no_such_dir/x.msh") != NULL);
  pa_mesh_destroy(m);
}

/* The malformed files of tests/data/bad listed in gmsh.expected. */
static void test_bad_corpus(void) {
  const char *dir = getenv("PADAPT_TESTDATA");
  CHECK(dir != NULL);
  if (!dir) return;
  char path[1024], line[512];
  snprintf(path, sizeof path, "%s/bad/gmsh.expected", dir);
  FILE *fp = fopen(path, "r");
  CHECK(fp != NULL);
  if (!fp) return;
  int n = 0;
  while (fgets(line, sizeof line, fp)) {
    line[strcspn(line, "\r\n")] = '\0';
    char *tab = strchr(line, '\t');
    if (!line[0] || line[0] == '#') continue;
    CHECK(tab != NULL);
    if (!tab) continue;
    *tab = '\0';
    const char *frag = tab + 1;
    snprintf(path, sizeof path, "%s/bad/%s", dir, line);
    pa_mesh *m = NULL;
    pa_status st = pa_mesh_read(path, &m);
    int ok = st != PA_SUCCESS && !m && strstr(pa_last_error(), line) &&
             strstr(pa_last_error(), frag);
    CHECK(ok);
    if (!ok)
      fprintf(stderr, "  %s: expected '%s', got %s: %s\n", line, frag,
              pa_status_string(st), pa_last_error());
    pa_mesh_destroy(m);
    n++;
  }
  fclose(fp);
  CHECK(n >= 8);
}

/* ---- physical names and node data ---- */

/* Names, metric and fields: equal after a round trip, values bit for bit. */
static void check_same_data(pa_mesh *a, pa_mesh *b) {
  CHECK(pa_mesh_nnames(b) == pa_mesh_nnames(a));
  for (int k = 0; k < pa_mesh_nnames(a) && k < pa_mesh_nnames(b); k++) {
    int da, db;
    int32_t ta, tb;
    const char *na, *nb;
    CHECK_OK(pa_mesh_name(a, k, &da, &ta, &na));
    CHECK_OK(pa_mesh_name(b, k, &db, &tb, &nb));
    CHECK(da == db && ta == tb && !strcmp(na, nb));
  }
  pa_idx nv = pa_mesh_nvert(a);
  int nc = pa_mesh_metric_ncomp(a);
  CHECK(pa_mesh_metric_ncomp(b) == nc);
  if (nc && pa_mesh_metric_ncomp(b) == nc)
    CHECK(!memcmp(pa_mesh_metric(a), pa_mesh_metric(b),
                  (size_t)nv * nc * sizeof(double)));
  CHECK(pa_mesh_nfield(b) == pa_mesh_nfield(a));
  for (int k = 0; k < pa_mesh_nfield(a) && k < pa_mesh_nfield(b); k++) {
    const char *na, *nb;
    int ca, cb;
    double *va, *vb;
    CHECK_OK(pa_mesh_field(a, k, &na, &ca, &va));
    CHECK_OK(pa_mesh_field(b, k, &nb, &cb, &vb));
    CHECK(!strcmp(na, nb) && ca == cb);
    if (ca == cb) CHECK(!memcmp(va, vb, (size_t)nv * ca * sizeof(double)));
  }
}

/* Attach names, a metric of ncomp values and fields of 1, dim (vector),
 * tensor, 9 (not symmetric) and 4 components to m. */
static void add_data(pa_mesh *m, int met_ncomp) {
  int d = pa_mesh_dim(m), tn = d == 2 ? 3 : 6;
  pa_idx nv = pa_mesh_nvert(m);
  double *v = malloc(sizeof(double) * 9 * (size_t)nv);
  CHECK_OK(pa_mesh_add_name(m, d, 2, "right half"));
  CHECK_OK(pa_mesh_add_name(m, d - 1, 3, "bottom"));
  CHECK_OK(pa_mesh_add_name(m, 0, 7, "corner points"));
  CHECK_OK(pa_mesh_add_name(m, d, 1, "left"));
  CHECK_OK(pa_mesh_add_name(m, 3, 1000, "unused: kept all the same"));
  for (pa_idx i = 0; i < nv; i++) {
    double x = pa_mesh_coords(m)[(size_t)d * i] + 1.0 / 3;
    double *t = v + (size_t)tn * i;
    if (met_ncomp == 1) {
      v[i] = 0.1 + x / 7;
    } else { /* diagonally dominant: SPD */
      for (int k = 0; k < tn; k++)
        t[k] = 0.01 * x * (k + 1);
      t[0] += 2 + x;
      t[2] += 3;
      if (d == 3) t[5] += 4 / x;
    }
  }
  CHECK_OK(pa_mesh_set_metric(m, met_ncomp, v));
  static const int nc[5] = {1, 0, -1, 9, 4}; /* 0: dim, -1: tensor */
  static const char *names[5] = {"u", "velocity", "stress tensor", "grad",
                                 "four"};
  for (int f = 0; f < 5; f++) {
    int c = nc[f] == 0 ? d : nc[f] < 0 ? tn : nc[f];
    for (size_t k = 0; k < (size_t)nv * c; k++)
      v[k] = sin(0.7 * k + f) / 3;
    CHECK_OK(pa_mesh_add_field(m, names[f], c, v));
  }
  free(v);
}

static void roundtrip_data(pa_mesh *m, const char *path, int binary) {
  pa_write_opts opts = {binary, 0, 0};
  pa_mesh *r = NULL;
  CHECK_OK(pa_mesh_write(m, path, &opts));
  CHECK_OK(pa_mesh_read(path, &r));
  if (r) {
    check_same(m, r);
    check_same_data(m, r);
  }
  pa_mesh_destroy(r);
}

static void test_roundtrip_data(void) {
  pa_mesh *m = make_square(4), *c = NULL;
  add_data(m, 3);
  roundtrip_data(m, "data2_ascii.msh", 0);
  roundtrip_data(m, "data2_binary.msh", 1);
  CHECK_OK(pa_mesh_copy(m, &c));
  if (c) check_same_data(m, c);
  pa_mesh_destroy(c);
  pa_mesh_destroy(m);
  m = make_cube(2);
  add_data(m, 6);
  roundtrip_data(m, "data3_ascii.msh", 0);
  roundtrip_data(m, "data3_binary.msh", 1);
  pa_mesh_destroy(m);
  m = make_cube(1);
  add_data(m, 1);
  roundtrip_data(m, "data3s_ascii.msh", 0);
  roundtrip_data(m, "data3s_binary.msh", 1);
  /* the view of a 2D tensor and of a 3D vector, as Gmsh shows them */
  pa_mesh_destroy(m);
  m = make_square(1);
  double met[12] = {1, 2, 9, 1, 2, 9, 1, 2, 9, 1, 2, 9};
  CHECK_OK(pa_mesh_set_metric(m, 3, met));
  CHECK_OK(pa_mesh_write(m, "view2d.msh", NULL));
  FILE *fp = fopen("view2d.msh", "r");
  char buf[4096];
  size_t n = fp ? fread(buf, 1, sizeof buf - 1, fp) : 0;
  buf[n] = '\0';
  if (fp) fclose(fp);
  CHECK(strstr(buf, "$NodeData\n1\n\"metric\"\n1\n0\n3\n0\n9\n4\n"
                    "1 1 2 0 2 9 0 0 0 1\n") != NULL);
  pa_mesh_destroy(m);
}

/* The names API: sorted, replaced, removed, checked. */
static void test_names_api(void) {
  pa_mesh *m = NULL;
  const char *name = NULL;
  int dim = -1;
  int32_t tag = 0;
  CHECK_OK(pa_mesh_create(2, &m));
  CHECK(pa_mesh_nnames(m) == 0);
  CHECK_OK(pa_mesh_add_name(m, 2, 5, "b"));
  CHECK_OK(pa_mesh_add_name(m, 1, 9, "a"));
  CHECK_OK(pa_mesh_add_name(m, 2, -1, "c"));
  CHECK_OK(pa_mesh_add_name(m, 2, 5, "b again"));
  CHECK(pa_mesh_nnames(m) == 3);
  CHECK_OK(pa_mesh_name(m, 0, &dim, &tag, &name));
  CHECK(dim == 1 && tag == 9 && !strcmp(name, "a"));
  CHECK_OK(pa_mesh_name(m, 2, &dim, &tag, &name));
  CHECK(dim == 2 && tag == 5 && !strcmp(name, "b again"));
  CHECK_OK(pa_mesh_add_name(m, 2, -1, NULL));
  CHECK_OK(pa_mesh_add_name(m, 0, 1, NULL)); /* nothing to remove */
  CHECK(pa_mesh_nnames(m) == 2);
  CHECK(pa_mesh_add_name(m, 4, 1, "x") == PA_ERR_ARG);
  CHECK(pa_mesh_add_name(m, 1, 1, "") == PA_ERR_ARG);
  CHECK(pa_mesh_add_name(m, 1, 1, "a \"quote\"") == PA_ERR_ARG);
  CHECK(pa_mesh_add_name(m, 1, 1, "two\nlines") == PA_ERR_ARG);
  CHECK(pa_mesh_name(m, 2, NULL, NULL, NULL) == PA_ERR_ARG);
  /* a field named "metric" cannot be written as a view */
  double u = 1;
  double x[2] = {0, 0};
  CHECK_OK(pa_mesh_add_vertex(m, x, 0, NULL));
  CHECK_OK(pa_mesh_add_field(m, "metric", 1, &u));
  CHECK(pa_mesh_write(m, "metric_field.msh", NULL) == PA_ERR_UNSUPPORTED);
  CHECK(strstr(pa_last_error(), "named \"metric\"") != NULL);
  CHECK(access("metric_field.msh", F_OK) != 0);
  pa_mesh_destroy(m);
}

#define ELEMS1 "$Elements\n1 1 1 1\n2 1 2 1\n1 1 2 3\n$EndElements\n"
/* A $NodeData section (it starts at line 19 after HEAD NODES3 ELEMS1; its
 * string tag count, where the view's messages point, at line 20). */
#define VIEW(name, nc, body)                                                   \
  "$NodeData\n1\n\"" name "\"\n1\n0.0\n3\n0\n" #nc "\n3\n" body                \
  "$EndNodeData\n"

/* Malformed names and node data: errors naming the file and the line. */
static void test_data_errors(void) {
  expect_error(HEAD "$PhysicalNames\n2\n1 3 \"a\"\n1 3 \"b\"\n"
                    "$EndPhysicalNames\n" NODES3 ELEMS1,
               PA_ERR_FORMAT,
               ":5: $PhysicalNames names (dimension 1, tag 3) "
               "twice",
               NULL);
  expect_error(HEAD "$PhysicalNames\n1\n1 3 \"\"\n$EndPhysicalNames\n",
               PA_ERR_FORMAT, ":6: empty physical name", NULL);
  expect_error(HEAD "$PhysicalNames\n1\n1 3 \"open\n$EndPhysicalNames\n",
               PA_ERR_FORMAT, ":6: unterminated quoted physical name", NULL);
  expect_error(
      HEAD "$NodeData\n1\n\"u\"\n0\n3\n0\n1\n0\n$EndNodeData\n" NODES3 ELEMS1,
      PA_ERR_FORMAT, ":4: $NodeData before $Nodes", NULL);
  expect_error(
      HEAD NODES3 ELEMS1 VIEW("metric", 3, "1 1 0 1\n2 1 0 1\n3 1 0 1\n"),
      PA_ERR_UNSUPPORTED, ":20: view \"metric\" has 3 components",
      "1 (a size) or 9");
  expect_error(HEAD NODES3 ELEMS1 VIEW("u", 1, "1 1\n2 2\n7 3\n"),
               PA_ERR_FORMAT, ":30: view \"u\": unknown node tag 7", NULL);
  expect_error(HEAD NODES3 ELEMS1 VIEW("u", 1, "1 1\n1 2\n3 3\n"),
               PA_ERR_FORMAT, ":29: view \"u\": node 1 has two values", NULL);
  expect_error(HEAD NODES3 ELEMS1 VIEW("u", 1, "1 1\n2 inf\n3 3\n"),
               PA_ERR_FORMAT,
               ":29: view \"u\": the value of node 2 is not "
               "finite",
               NULL);
  expect_error(HEAD NODES3 ELEMS1 VIEW("u", 1, "1 1\n2 2x\n3 3\n"),
               PA_ERR_FORMAT, ":29: expected a node value, found '2x'", NULL);
  expect_error(HEAD NODES3 ELEMS1 VIEW("u", 1, "1 1\n2 2\n"), PA_ERR_FORMAT,
               ":30:", "expected a node tag");
  expect_error(HEAD NODES3 ELEMS1 VIEW("metric", 1, "1 1\n2 -2\n3 3\n"),
               PA_ERR_METRIC,
               ":20: view \"metric\": the value at node 2 is "
               "not a finite positive size",
               NULL);
  expect_error(HEAD NODES3 ELEMS1 VIEW("metric", 9,
                                       "1 1 0 0 0 1 0 0 0 1\n"
                                       "2 1 0.5 0 0 1 0 0 0 1\n"
                                       "3 1 0 0 0 1 0 0 0 1\n"),
               PA_ERR_METRIC,
               ":20: view \"metric\": the tensor at node 2 "
               "is not symmetric",
               NULL);
  expect_error(HEAD NODES3 ELEMS1 "$NodeData\n1\n\"metric\"\n1\n0.0\n3\n0\n"
                                  "1\n2\n1 1\n3 3\n$EndNodeData\n",
               PA_ERR_FORMAT, ":20: view \"metric\" has no value at node 2",
               NULL);
  expect_error(HEAD NODES3 ELEMS1 VIEW("v", 3,
                                       "1 1 0 0\n2 1 0 0.5\n"
                                       "3 1 0 0\n"),
               PA_ERR_UNSUPPORTED,
               ":20: view \"v\": the vector at node 2 has "
               "z = 0.5, but the mesh is 2D",
               NULL);
  expect_error(HEAD NODES3 ELEMS1 VIEW("u", 10, "1 1\n2 2\n3 3\n"),
               PA_ERR_FORMAT,
               ":26: a number of components (1 to 9) 10 is "
               "out of range",
               NULL);
  expect_error(HEAD NODES3 ELEMS1
               "$NodeData\n0\n1\n0.0\n3\n0\n1\n0\n$EndNodeData\n",
               PA_ERR_FORMAT, ":20: a data section needs a string tag", NULL);
  expect_error(HEAD NODES3 ELEMS1
               "$NodeData\n1\n\"u\"\n0\n2\n0\n1\n$EndNodeData\n",
               PA_ERR_FORMAT, ":23: a data section needs 3 integer tags", NULL);
  expect_error(
      HEAD NODES3 ELEMS1 VIEW(
          "u", 1, "1 1\n2 2\n3 3\n") "$NodeData\n1\n\"u\"\n1\n0."
                                     "0\n3\n1\n1\n1\n1 1\n$EndNodeData\n",
      PA_ERR_UNSUPPORTED, ":33: view \"u\" has several time steps", NULL);
  /* a view in parts (by partition) is one view */
  pa_mesh *m = NULL;
  write_text("parts.msh", HEAD NODES3 ELEMS1
             "$NodeData\n1\n\"u\"\n1\n0.0\n4\n0\n1\n2\n1\n1 10\n3 30\n"
             "$EndNodeData\n"
             "$NodeData\n1\n\"u\"\n1\n0.0\n4\n0\n1\n1\n2\n2 20\n"
             "$EndNodeData\n");
  CHECK_OK(pa_mesh_read("parts.msh", &m));
  double *u = NULL;
  if (m) CHECK_OK(pa_mesh_field(m, 0, NULL, NULL, &u));
  CHECK(u && u[0] == 10 && u[1] == 20 && u[2] == 30);
  pa_mesh_destroy(m);
}

/* Every truncation of a file with names and a view is refused, except the
 * two that end the file right after $EndElements (a valid file without the
 * view); every allocation of its read may fail. */
static void test_data_truncated(void) {
  pa_mesh *m = make_square(1);
  double h[4] = {0.5, 0.25, 0.125, 1};
  CHECK_OK(pa_mesh_set_metric(m, 1, h));
  CHECK_OK(pa_mesh_add_name(m, 1, 3, "bottom"));
  for (int binary = 0; binary < 2; binary++) {
    pa_write_opts opts = {binary, 0, 0};
    CHECK_OK(pa_mesh_write(m, "trunc_d.msh", &opts));
    size_t len = 0;
    unsigned char *buf = slurp("trunc_d.msh", &len);
    if (!buf) continue;
    const char *p = strstr((const char *)buf, "$NodeData");
    if (binary) { /* strstr stops at the first NUL byte */
      p = NULL;
      for (size_t k = 0; k + 9 < len && !p; k++)
        if (!memcmp(buf + k, "$NodeData", 9)) p = (const char *)buf + k;
    }
    CHECK(p != NULL);
    size_t at = p ? (size_t)(p - (const char *)buf) : 0;
    int bad = 0;
    for (size_t cut = 0; cut + 1 < len; cut++) {
      spill("cut_d.msh", buf, cut);
      pa_mesh *r = NULL;
      pa_status st = pa_mesh_read("cut_d.msh", &r);
      int whole = cut == at || cut + 1 == at;
      if (whole ? st != PA_SUCCESS : (st != PA_ERR_FORMAT || r)) {
        if (!bad++)
          fprintf(stderr, "  trunc_d.msh cut at %zu: %s: %s\n", cut,
                  pa_status_string(st), pa_last_error());
      }
      pa_mesh_destroy(r);
    }
    CHECK(bad == 0);
    free(buf);
    int nok = 0, nbad = 0;
    for (long k = 1; k < 60; k++) {
      pa_mesh *r = NULL;
      pa_memory_fail_after(k);
      pa_status st = pa_mesh_read("trunc_d.msh", &r);
      pa_memory_fail_after(0);
      if (st == PA_SUCCESS) {
        nok++;
        check_same_data(m, r);
      } else if (st != PA_ERR_MEMORY || r) {
        nbad++;
      }
      pa_mesh_destroy(r);
    }
    CHECK(nok > 0 && nbad == 0);
  }
  pa_mesh_destroy(m);
}

/* A larger mesh: both encodings round trip, binary is the faster. */
static void test_larger(void) {
  pa_mesh *m = make_cube(16), *r = NULL;
  pa_write_opts bin = {1, 0, 0};
  double t0 = pa_wtime();
  CHECK_OK(pa_mesh_write(m, "big.msh", &bin));
  CHECK_OK(pa_mesh_read("big.msh", &r));
  double t1 = pa_wtime();
  if (r) check_same(m, r);
  pa_mesh_destroy(r);
  r = NULL;
  CHECK_OK(pa_mesh_write(m, "big_a.msh", NULL));
  CHECK_OK(pa_mesh_read("big_a.msh", &r));
  double t2 = pa_wtime();
  if (r) check_same(m, r);
  printf("24576 tets: binary write+read %.3f s, ASCII %.3f s\n", t1 - t0,
         t2 - t1);
  pa_mesh_destroy(r);
  pa_mesh_destroy(m);
}

TEST_MAIN(test_roundtrip_2d, test_roundtrip_3d, test_roundtrip_refs,
          test_read_handwritten41, test_read_classified, test_read_sparse_tags,
          test_read_handwritten22, test_errors, test_truncated, test_corrupted,
          test_alloc_failures, test_bad_corpus, test_roundtrip_data,
          test_names_api, test_data_errors, test_data_truncated, test_larger)
