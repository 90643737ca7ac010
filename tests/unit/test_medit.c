/* test_medit.c -- Medit .mesh/.meshb and .sol/.solb: exact round trips in
 * every version, hand-written files (comments, flat 2D stored in 3D, skipped
 * keywords, opposite byte order), the keywords FreeFem++, Gmsh and Mmg
 * write, the metric bridge, error messages, the corpus of malformed files
 * (tests/data/bad), failing writes and failing allocations. */
#include "testutil.h"

#include <dirent.h>
#include <fcntl.h>
#include <stdint.h>
#include <sys/stat.h>
#include <unistd.h>

static int file_exists(const char *path) {
  struct stat sb;
  return stat(path, &sb) == 0;
}

static void write_file(const char *path, const void *data, size_t n) {
  FILE *f = fopen(path, "wb");
  CHECK(f != NULL);
  if (!f) return;
  CHECK(fwrite(data, 1, n, f) == n);
  fclose(f);
}

static void write_text(const char *path, const char *text) {
  write_file(path, text, strlen(text));
}

/* No "*.tmp.*" file left in the working directory. */
static int no_temp_files(void) {
  DIR *d = opendir(".");
  struct dirent *e;
  int ok = 1;
  if (!d) return 0;
  while ((e = readdir(d)))
    if (strstr(e->d_name, ".tmp.")) ok = 0;
  closedir(d);
  return ok;
}

/* Message of the last error contains s (printed when not). */
static int msg_has(const char *s) {
  if (strstr(pa_last_error(), s)) return 1;
  fprintf(stderr, "  message '%s' lacks '%s'\n", pa_last_error(), s);
  return 0;
}

/* A mesh with random coordinates, references and representable flags; the
 * I/O layer does not look at the geometry. */
static pa_mesh *random_mesh(int dim, pa_idx nv, pa_idx ne, pa_idx nb,
                            pa_idx ned, unsigned long long seed) {
  pa_mesh *m = NULL;
  pa_test_seed(seed);
  CHECK_OK(pa_mesh_create(dim, &m));
  if (!m) return NULL;
  CHECK_OK(pa_mesh_reserve(m, nv, ne, nb, ned));
  for (pa_idx i = 0; i < nv; i++) {
    double x[3];
    for (int k = 0; k < dim; k++)
      x[k] = pa_test_rand_range(-1e3, 1e3);
    if (i == 0) x[0] = 0.1; /* not exact in binary */
    if (i == 1) x[dim - 1] = -0.0;
    /* references of every length and sign, both ends of int32 included */
    int32_t ref = (int32_t)((pa_test_rand() - 0.5) * 4e9) /
                  (int32_t)(1 + pa_test_rand() * 1e6);
    if (i == 2) ref = INT32_MIN;
    if (i == 3) ref = INT32_MAX;
    CHECK_OK(pa_mesh_add_vertex(m, x, ref, NULL));
  }
  pa_idx v[4];
  for (pa_idx e = 0; e < ne; e++) {
    for (int k = 0; k <= dim; k++)
      v[k] = (pa_idx)(pa_test_rand() * nv);
    CHECK_OK(pa_mesh_add_elem(m, v, (int32_t)(pa_test_rand() * 7), NULL));
  }
  for (pa_idx b = 0; b < nb; b++) {
    for (int k = 0; k < dim; k++)
      v[k] = (pa_idx)(pa_test_rand() * nv);
    CHECK_OK(pa_mesh_add_bdry(m, v, (int32_t)(pa_test_rand() * 9) + 1, NULL));
  }
  for (pa_idx e = 0; e < ned; e++) {
    for (int k = 0; k < 2; k++)
      v[k] = (pa_idx)(pa_test_rand() * nv);
    CHECK_OK(pa_mesh_add_edge(m, v, INT32_MAX - (int32_t)e, NULL));
  }
  /* Flags Medit can store: vertices CORNER/REQUIRED, elements REQUIRED,
   * Medit Edges RIDGE/REQUIRED (boundary in 2D, features in 3D), boundary
   * triangles REQUIRED (3D). */
  uint8_t *vf = pa_mesh_vert_flags(m), *ef = pa_mesh_elem_flags(m);
  uint8_t *bf = pa_mesh_bdry_flags(m), *df = pa_mesh_edge_flags(m);
  for (pa_idx i = 0; i < nv; i++)
    vf[i] = (uint8_t)((pa_test_rand() < 0.5 ? PA_FLAG_CORNER : 0) |
                      (pa_test_rand() < 0.5 ? PA_FLAG_REQUIRED : 0));
  for (pa_idx i = 0; i < ne; i++)
    ef[i] = pa_test_rand() < 0.3 ? PA_FLAG_REQUIRED : 0;
  for (pa_idx i = 0; i < nb; i++) {
    if (dim == 2)
      bf[i] = (uint8_t)((pa_test_rand() < 0.5 ? PA_FLAG_RIDGE : 0) |
                        (pa_test_rand() < 0.5 ? PA_FLAG_REQUIRED : 0));
    else
      bf[i] = pa_test_rand() < 0.5 ? PA_FLAG_REQUIRED : 0;
  }
  for (pa_idx i = 0; i < ned; i++)
    df[i] = (uint8_t)((pa_test_rand() < 0.5 ? PA_FLAG_RIDGE : 0) |
                      (pa_test_rand() < 0.5 ? PA_FLAG_REQUIRED : 0));
  /* The vertices of ridge edges are ridge vertices (derived on reading). */
  pa_idx nmed = dim == 2 ? nb : ned;
  const pa_idx *med = dim == 2 ? pa_mesh_bdrys(m) : pa_mesh_edges(m);
  const uint8_t *mf = dim == 2 ? bf : df;
  for (pa_idx i = 0; i < nmed; i++)
    if (mf[i] & PA_FLAG_RIDGE) {
      vf[med[2 * i]] |= PA_FLAG_RIDGE;
      vf[med[2 * i + 1]] |= PA_FLAG_RIDGE;
    }
  return m;
}

/* Compare every array and flag; float_coords: b went through float32. */
static int same_mesh(pa_mesh *a, pa_mesh *b, int float_coords) {
  int d = pa_mesh_dim(a), ok = 1;
  if (pa_mesh_dim(b) != d || pa_mesh_nvert(a) != pa_mesh_nvert(b) ||
      pa_mesh_nelem(a) != pa_mesh_nelem(b) ||
      pa_mesh_nbdry(a) != pa_mesh_nbdry(b) ||
      pa_mesh_nedge(a) != pa_mesh_nedge(b)) {
    fprintf(stderr,
            "  counts differ: dim %d/%d nv %d/%d ne %d/%d nb %d/%d "
            "ned %d/%d\n",
            d, pa_mesh_dim(b), pa_mesh_nvert(a), pa_mesh_nvert(b),
            pa_mesh_nelem(a), pa_mesh_nelem(b), pa_mesh_nbdry(a),
            pa_mesh_nbdry(b), pa_mesh_nedge(a), pa_mesh_nedge(b));
    return 0;
  }
  size_t nv = (size_t)pa_mesh_nvert(a), ne = (size_t)pa_mesh_nelem(a);
  size_t nb = (size_t)pa_mesh_nbdry(a), ned = (size_t)pa_mesh_nedge(a);
  const double *ca = pa_mesh_coords(a), *cb = pa_mesh_coords(b);
  for (size_t i = 0; i < nv * d; i++) {
    double want = float_coords ? (double)(float)ca[i] : ca[i];
    if (memcmp(&want, &cb[i], sizeof want)) { /* exact, sign of zero too */
      fprintf(stderr, "  coordinate %zu: %.17g != %.17g\n", i, want, cb[i]);
      ok = 0;
      break;
    }
  }
#define SAME(get, n)                                                           \
  if ((n) != 0 && memcmp(get(a), get(b), (n) * sizeof *get(a))) {              \
    fprintf(stderr, "  %s differ\n", #get);                                    \
    ok = 0;                                                                    \
  }
  SAME(pa_mesh_vert_refs, nv);
  SAME(pa_mesh_vert_flags, nv);
  SAME(pa_mesh_elems, ne * (d + 1));
  SAME(pa_mesh_elem_refs, ne);
  SAME(pa_mesh_elem_flags, ne);
  SAME(pa_mesh_bdrys, nb * d);
  SAME(pa_mesh_bdry_refs, nb);
  SAME(pa_mesh_bdry_flags, nb);
  SAME(pa_mesh_edges, ned * 2);
  SAME(pa_mesh_edge_refs, ned);
  SAME(pa_mesh_edge_flags, ned);
#undef SAME
  return ok;
}

/* Version word of a binary file. */
static int file_version(const char *path) {
  int32_t h[2] = {0, 0};
  FILE *f = fopen(path, "rb");
  if (!f) return -1;
  if (fread(h, 4, 2, f) != 2) h[1] = -1;
  fclose(f);
  return h[1];
}

static void round_trip(pa_mesh *m, const char *path, int version) {
  pa_write_opts opts = {0, version, 0};
  pa_mesh *r = NULL;
  CHECK_OK(pa_mesh_write(m, path, &opts));
  if (strstr(path, ".meshb"))
    CHECK(file_version(path) == (version ? version : 2));
  CHECK_OK(pa_mesh_read(path, &r));
  if (r) {
    int ok = same_mesh(m, r, version == 1 && strstr(path, ".meshb"));
    if (!ok) fprintf(stderr, "  round trip through %s v%d\n", path, version);
    CHECK(ok);
  }
  pa_mesh_destroy(r);
  remove(path);
}

static void test_round_trips(void) {
  pa_mesh *m2 = random_mesh(2, 300, 500, 120, 0, 7);
  pa_mesh *m3 = random_mesh(3, 400, 900, 300, 60, 8);
  pa_mesh *e3 = NULL;
  CHECK_OK(pa_mesh_create(3, &e3)); /* empty mesh */
  pa_mesh *ms[] = {m2, m3, e3};
  for (int i = 0; i < 3; i++) {
    if (!ms[i]) continue;
    round_trip(ms[i], "rt.mesh", 0);
    round_trip(ms[i], "RT.MESH", 0); /* extensions are case-insensitive */
    for (int v = 0; v <= 4; v++)
      round_trip(ms[i], "rt.meshb", v);
  }
  /* ASCII always writes version 2 and ignores the option. */
  pa_write_opts v1 = {0, 1, 0};
  pa_mesh *r = NULL;
  CHECK_OK(pa_mesh_write(m2, "rt1.mesh", &v1));
  CHECK_OK(pa_mesh_read("rt1.mesh", &r));
  CHECK(r && same_mesh(m2, r, 0));
  pa_mesh_destroy(r);
  remove("rt1.mesh");
  pa_mesh_destroy(m2);
  pa_mesh_destroy(m3);
  pa_mesh_destroy(e3);
}

static const char *flat2d_text =
    "# A unit square from a tool that always writes Dimension 3.\n"
    "MeshVersionFormatted 1\n"
    "Dimension\n"
    "3   # the z coordinates are all 0\n"
    "Identifier\n"
    "\"made by hand\"\n"
    "Vertices # four of them\n"
    "4\n"
    "0 0 0 1\n"
    "1. 0 0 2\n"
    "1 1e0 -0 3\n"
    "  0\t1 0 4 # trailing comment\n"
    "\n"
    "Triangles\n"
    "2\n"
    "1 2 3 7\n"
    "1 3 4 8\n"
    "Normals\n"
    "1\n"
    "0 0 1\n"
    "NormalAtVertices 1 1 1\n"
    "Edges 4\n"
    "1 2 1  2 3 2\n"
    "3 4 3  4 1 4\n"
    "Corners 2 1 3\n"
    "Ridges\n"
    "2\n"
    "1\n"
    "3\n"
    "RequiredEdges 1 4\n"
    "RequiredTriangles 1 2\n"
    "RequiredVertices 1 4\n"
    "ParallelVertices 0\n"
    "End\n"
    "anything after End is ignored\n";

static void test_hand_written(void) {
  pa_mesh *m = NULL;
  write_text("flat.mesh", flat2d_text);
  CHECK_OK(pa_mesh_read("flat.mesh", &m));
  if (m) {
    CHECK(pa_mesh_dim(m) == 2);
    CHECK(pa_mesh_nvert(m) == 4 && pa_mesh_nelem(m) == 2);
    CHECK(pa_mesh_nbdry(m) == 4 && pa_mesh_nedge(m) == 0);
    const double *c = pa_mesh_coords(m);
    CHECK(c[2] == 1.0 && c[3] == 0.0 && c[4] == 1.0 && c[5] == 1.0);
    CHECK(c[6] == 0.0 && c[7] == 1.0);
    CHECK(pa_mesh_vert_refs(m)[3] == 4);
    CHECK(pa_mesh_elems(m)[3] == 0 && pa_mesh_elems(m)[5] == 3);
    CHECK(pa_mesh_elem_refs(m)[1] == 8);
    CHECK(pa_mesh_bdrys(m)[6] == 3 && pa_mesh_bdry_refs(m)[3] == 4);
    const uint8_t *vf = pa_mesh_vert_flags(m), *bf = pa_mesh_bdry_flags(m);
    /* Corners 1 3, required 4, ridges: edges 1 (1-2) and 3 (3-4). */
    CHECK(vf[0] == (PA_FLAG_CORNER | PA_FLAG_RIDGE));
    CHECK(vf[1] == PA_FLAG_RIDGE);
    CHECK(vf[2] == (PA_FLAG_CORNER | PA_FLAG_RIDGE));
    CHECK(vf[3] == (PA_FLAG_REQUIRED | PA_FLAG_RIDGE));
    CHECK(bf[0] == PA_FLAG_RIDGE && bf[1] == 0);
    CHECK(bf[2] == PA_FLAG_RIDGE && bf[3] == PA_FLAG_REQUIRED);
    CHECK(pa_mesh_elem_flags(m)[0] == 0);
    CHECK(pa_mesh_elem_flags(m)[1] == PA_FLAG_REQUIRED);
  }
  pa_mesh_destroy(m);
  m = NULL;

  /* Triangles only but not flat: a 3D surface mesh (no elements). */
  write_text("surf.mesh", "MeshVersionFormatted 2\nDimension 3\nVertices\n3\n"
                          "0 0 0 0\n1 0 0 0\n0 1 0.5 0\nTriangles\n1\n1 2 3 "
                          "5\nEnd\n");
  CHECK_OK(pa_mesh_read("surf.mesh", &m));
  CHECK(m && pa_mesh_dim(m) == 3 && pa_mesh_nelem(m) == 0 &&
        pa_mesh_nbdry(m) == 1 && pa_mesh_bdry_refs(m)[0] == 5);
  pa_mesh_destroy(m);
  m = NULL;

  /* No End keyword, Windows line ends, sections in an unusual order: the
   * index lists come before what they refer to. */
  write_text("order.mesh",
             "MeshVersionFormatted 2\r\nDimension 3\r\nRequiredTetrahedra\r\n"
             "1\r\n1\r\nRidges 1 1\r\nTetrahedra\r\n1\r\n1 2 3 4 9\r\n"
             "Edges 1 1 2 0\r\nVertices\r\n4\r\n0 0 0 0\r\n1 0 0 0\r\n"
             "0 1 0 0\r\n0 0 1 0\r\n");
  CHECK_OK(pa_mesh_read("order.mesh", &m));
  CHECK(m && pa_mesh_dim(m) == 3 && pa_mesh_nelem(m) == 1 &&
        pa_mesh_nedge(m) == 1);
  if (m) {
    CHECK(pa_mesh_elem_flags(m)[0] == PA_FLAG_REQUIRED);
    CHECK(pa_mesh_edge_flags(m)[0] == PA_FLAG_RIDGE);
    CHECK(pa_mesh_elem_refs(m)[0] == 9);
  }
  pa_mesh_destroy(m);
  remove("flat.mesh");
  remove("surf.mesh");
  remove("order.mesh");
}

/* ---- binary files built by hand ---- */

typedef struct bbuf {
  unsigned char b[4096];
  size_t n;
  int swap;
} bbuf;

static void put_bytes(bbuf *b, const void *p, size_t n) {
  const unsigned char *c = p;
  for (size_t i = 0; i < n; i++)
    b->b[b->n + i] = b->swap ? c[n - 1 - i] : c[i];
  b->n += n;
}
static void put_i32(bbuf *b, int32_t v) { put_bytes(b, &v, 4); }
static void put_f64(bbuf *b, double v) { put_bytes(b, &v, 8); }

/* A 2D mesh of 3 vertices and 1 triangle, version 2, in the opposite byte
 * order, with an unknown keyword (code 999) and Normals to skip. */
static void test_binary_swapped(void) {
  bbuf b;
  memset(&b, 0, sizeof b);
  b.swap = 1;
  put_i32(&b, 1);
  put_i32(&b, 2);
  put_i32(&b, 3); /* Dimension */
  put_i32(&b, (int32_t)(b.n + 8));
  put_i32(&b, 2);
  put_i32(&b, 999); /* unknown: skipped through its next position */
  put_i32(&b, (int32_t)(b.n + 4 + 12));
  put_i32(&b, 1);
  put_i32(&b, 2);
  put_i32(&b, 3);
  put_i32(&b, 4); /* Vertices */
  put_i32(&b, (int32_t)(b.n + 8 + 3 * 20));
  put_i32(&b, 3);
  double x[3][2] = {{0, 0}, {1, 0}, {0, 1}};
  for (int i = 0; i < 3; i++) {
    put_f64(&b, x[i][0]);
    put_f64(&b, x[i][1]);
    put_i32(&b, 10 + i);
  }
  put_i32(&b, 60); /* Normals: 1 normal of 2 doubles */
  put_i32(&b, (int32_t)(b.n + 8 + 16));
  put_i32(&b, 1);
  put_f64(&b, 0.0);
  put_f64(&b, 1.0);
  put_i32(&b, 6); /* Triangles */
  put_i32(&b, (int32_t)(b.n + 8 + 16));
  put_i32(&b, 1);
  put_i32(&b, 1);
  put_i32(&b, 2);
  put_i32(&b, 3);
  put_i32(&b, -7);
  put_i32(&b, 54);
  put_i32(&b, 0);
  write_file("swapped.meshb", b.b, b.n);
  pa_mesh *m = NULL;
  CHECK_OK(pa_mesh_read("swapped.meshb", &m));
  CHECK(m && pa_mesh_dim(m) == 2 && pa_mesh_nvert(m) == 3 &&
        pa_mesh_nelem(m) == 1);
  if (m) {
    CHECK(pa_mesh_coords(m)[2] == 1.0 && pa_mesh_coords(m)[5] == 1.0);
    CHECK(pa_mesh_vert_refs(m)[2] == 12);
    CHECK(pa_mesh_elems(m)[2] == 2 && pa_mesh_elem_refs(m)[0] == -7);
  }
  pa_mesh_destroy(m);
  m = NULL;

  /* The same file cut before End: an error, not a mesh. */
  write_file("swapped.meshb", b.b, b.n - 8);
  CHECK(pa_mesh_read("swapped.meshb", &m) == PA_ERR_FORMAT);
  CHECK(m == NULL && msg_has("no End keyword"));
  remove("swapped.meshb");
}

/* ---- solutions ---- */

static pa_sol *random_sol(int dim, pa_idx n, const pa_sol_kind *kinds, int nk) {
  pa_sol *s = NULL;
  CHECK_OK(pa_sol_create(dim, n, &s));
  double *v = malloc(sizeof(double) * 6 * (n ? n : 1));
  for (int k = 0; k < nk; k++) {
    for (pa_idx i = 0; i < 6 * n; i++)
      v[i] = pa_test_rand_range(-5, 5);
    CHECK_OK(pa_sol_add_field(s, kinds[k], v));
  }
  free(v);
  return s;
}

static int same_sol(pa_sol *a, pa_sol *b, int float_values) {
  if (pa_sol_dim(a) != pa_sol_dim(b) || pa_sol_nvert(a) != pa_sol_nvert(b) ||
      pa_sol_nfield(a) != pa_sol_nfield(b))
    return 0;
  for (int k = 0; k < pa_sol_nfield(a); k++) {
    pa_sol_kind ka, kb;
    int na, nb;
    double *va, *vb;
    CHECK_OK(pa_sol_field(a, k, &ka, &na, &va));
    CHECK_OK(pa_sol_field(b, k, &kb, &nb, &vb));
    if (ka != kb || na != nb) return 0;
    for (size_t i = 0; i < (size_t)na * pa_sol_nvert(a); i++) {
      double want = float_values ? (double)(float)va[i] : va[i];
      if (want != vb[i]) return 0;
    }
  }
  return 1;
}

static void test_sol_round_trips(void) {
  pa_sol_kind k2[] = {PA_SOL_SCALAR, PA_SOL_TENSOR, PA_SOL_VECTOR};
  pa_sol_kind k3[] = {PA_SOL_SCALAR, PA_SOL_VECTOR, PA_SOL_TENSOR,
                      PA_SOL_SCALAR};
  pa_test_seed(11);
  pa_sol *s2 = random_sol(2, 77, k2, 3), *s3 = random_sol(3, 130, k3, 4);
  pa_sol *ss[] = {s2, s3};
  const char *paths[] = {"rt.sol", "rt.solb"};
  for (int i = 0; i < 2; i++)
    for (int p = 0; p < 2; p++) {
      pa_sol *r = NULL;
      CHECK_OK(pa_sol_write(ss[i], paths[p]));
      CHECK_OK(pa_sol_read(paths[p], &r));
      CHECK(r && same_sol(ss[i], r, 0));
      pa_sol_destroy(r);
      remove(paths[p]);
    }
  /* Field access and argument checks. */
  pa_sol_kind kind;
  int nc;
  double *val;
  CHECK_OK(pa_sol_field(s3, 2, &kind, &nc, &val));
  CHECK(kind == PA_SOL_TENSOR && nc == 6);
  CHECK(pa_sol_field(s3, 4, &kind, &nc, &val) == PA_ERR_ARG);
  CHECK(pa_sol_add_field(s3, (pa_sol_kind)4, val) == PA_ERR_ARG);
  CHECK(pa_sol_create(4, 3, &ss[0]) == PA_ERR_ARG);
  pa_sol *empty = NULL;
  CHECK_OK(pa_sol_create(2, 3, &empty));
  CHECK(pa_sol_write(empty, "empty.sol") == PA_ERR_ARG);
  CHECK(!file_exists("empty.sol"));
  CHECK(pa_sol_write(s2, "x.txt") == PA_ERR_UNSUPPORTED);
  pa_sol_destroy(empty);

  /* ASCII with comments, a solution at elements, then two SolAtVertices
   * keywords whose fields add up; MeshVersionFormatted 1. */
  write_text("hand.sol", "MeshVersionFormatted 1 # float\nDimension 2\n"
                         "SolAtTriangles\n1\n1 1\n3.5\n"
                         "SolAtVertices\n3\n2 1 2 # scalar, vector\n"
                         "1 10 11\n2 20 21\n3 30 31\n"
                         "Time 0.5\n"
                         "SolAtVertices 3 1 3\n1 0 1\n2 0 2\n3 0 3\nEnd\n");
  pa_sol *h = NULL;
  CHECK_OK(pa_sol_read("hand.sol", &h));
  CHECK(h && pa_sol_nfield(h) == 4 && pa_sol_nvert(h) == 3);
  if (h) {
    pa_sol_at at;
    pa_idx n;
    const char *org;
    CHECK_OK(pa_sol_field_where(h, 0, &at, &n, &org));
    CHECK(at == PA_SOL_AT_TRIANGLES && n == 1 && !strcmp(org, "hand.sol:3"));
    CHECK_OK(pa_sol_field(h, 0, &kind, &nc, &val));
    CHECK(kind == PA_SOL_SCALAR && nc == 1 && val[0] == 3.5);
    CHECK_OK(pa_sol_field(h, 2, &kind, &nc, &val));
    CHECK(kind == PA_SOL_VECTOR && nc == 2 && val[3] == 21.0);
    CHECK_OK(pa_sol_field(h, 3, &kind, &nc, &val));
    CHECK(kind == PA_SOL_TENSOR && nc == 3 && val[8] == 3.0);
    CHECK_OK(pa_sol_field_where(h, 3, &at, &n, &org));
    CHECK(at == PA_SOL_AT_VERTICES && n == 3 && !strcmp(org, "hand.sol:14"));
  }
  pa_sol_destroy(h);
  remove("hand.sol");
  pa_sol_destroy(s2);
  pa_sol_destroy(s3);
}

static void test_metric_bridge(void) {
  /* c: the same mesh, without metric nor fields. */
  pa_mesh *m = random_mesh(2, 40, 30, 10, 0, 21),
          *c = random_mesh(2, 40, 30, 10, 0, 21);
  if (!m || !c) return;
  double met[40 * 3], f1[40], f2[40 * 2], f3[40 * 3], f4[40 * 4];
  for (int i = 0; i < 40; i++) {
    met[3 * i] = 1.0 + i;
    met[3 * i + 1] = 0.5;
    met[3 * i + 2] = 2.0 + i;
    f1[i] = i + 1;
    for (int k = 0; k < 2; k++)
      f2[2 * i + k] = i + k;
    for (int k = 0; k < 3; k++)
      f3[3 * i + k] = -i - k;
    for (int k = 0; k < 4; k++)
      f4[4 * i + k] = k;
  }
  CHECK_OK(pa_mesh_set_metric(m, 3, met));
  CHECK_OK(pa_mesh_add_field(m, "u", 1, f1));
  CHECK_OK(pa_mesh_add_field(m, "velocity", 2, f2));
  CHECK_OK(pa_mesh_add_field(m, "stress", 3, f3));
  CHECK_OK(pa_mesh_add_field(m, "four", 4, f4)); /* no Medit kind: skipped */
  pa_sol *s = NULL, *r = NULL;
  CHECK_OK(pa_mesh_metric_to_sol(m, 1, &s));
  CHECK(s && pa_sol_nfield(s) == 4);
  CHECK_OK(pa_sol_write(s, "met.solb"));
  CHECK_OK(pa_sol_read("met.solb", &r));
  CHECK(r && same_sol(s, r, 0));
  if (r && c) {
    pa_sol_kind kind;
    CHECK_OK(pa_sol_field(r, 1, &kind, NULL, NULL));
    CHECK(kind == PA_SOL_SCALAR);
    CHECK_OK(pa_mesh_metric_from_sol(c, r, 0));
    CHECK(pa_mesh_metric_ncomp(c) == 3);
    CHECK(pa_mesh_metric(c) && !memcmp(pa_mesh_metric(c), met, sizeof met));
    CHECK_OK(pa_mesh_metric_from_sol(c, r, 1)); /* scalar: a size */
    CHECK(pa_mesh_metric_ncomp(c) == 1 && pa_mesh_metric(c)[5] == 6.0);
    CHECK(pa_mesh_metric_from_sol(c, r, 2) == PA_ERR_ARG); /* a vector */
    CHECK(msg_has("vector"));
    CHECK(pa_mesh_metric_from_sol(c, r, 4) == PA_ERR_ARG);
  }
  pa_sol_destroy(s);
  s = NULL;
  CHECK(pa_mesh_metric_from_sol(c, r, 3) == PA_ERR_METRIC); /* -i - k */
  CHECK(msg_has("met.solb") && msg_has("vertex 1"));
  pa_sol_destroy(r);
  r = NULL;

  /* Vertex count mismatch: the file's fault (PA_ERR_FORMAT, names it) or,
   * in memory, the caller's. */
  pa_sol *small = NULL;
  CHECK_OK(pa_sol_create(2, 39, &small));
  CHECK_OK(pa_sol_add_field(small, PA_SOL_SCALAR, f1 + 1));
  CHECK(pa_mesh_metric_from_sol(c, small, 0) == PA_ERR_ARG);
  CHECK_OK(pa_sol_write(small, "small.sol"));
  pa_sol_destroy(small);
  small = NULL;
  CHECK_OK(pa_sol_read("small.sol", &small));
  CHECK(pa_mesh_metric_from_sol(c, small, 0) == PA_ERR_FORMAT);
  CHECK(msg_has("small.sol") && msg_has("39 vertices"));
  pa_sol_destroy(small);

  /* 3D tensors with no z coupling are accepted on a 2D mesh. */
  pa_sol *s3 = NULL;
  double t3[40 * 6];
  for (int i = 0; i < 40; i++) {
    double t[6] = {1.0 + i, 0.25, 3.0, 0.0, 0.0, 7.0};
    memcpy(t3 + 6 * i, t, sizeof t);
  }
  CHECK_OK(pa_sol_create(3, 40, &s3));
  CHECK_OK(pa_sol_add_field(s3, PA_SOL_TENSOR, t3));
  CHECK_OK(pa_mesh_metric_from_sol(c, s3, 0));
  CHECK(pa_mesh_metric_ncomp(c) == 3 && pa_mesh_metric(c)[3 * 7] == 8.0);
  pa_sol_destroy(s3);
  t3[6 * 4 + 4] = 0.1;
  CHECK_OK(pa_sol_create(3, 40, &s3));
  CHECK_OK(pa_sol_add_field(s3, PA_SOL_TENSOR, t3));
  CHECK(pa_mesh_metric_from_sol(c, s3, 0) == PA_ERR_METRIC);
  CHECK(msg_has("vertex 5"));
  pa_sol_destroy(s3);

  /* Metric only (no fields), and no metric at all. */
  CHECK_OK(pa_mesh_metric_to_sol(m, 0, &s));
  CHECK(s && pa_sol_nfield(s) == 1);
  pa_sol_destroy(s);
  s = NULL;
  CHECK(pa_mesh_metric_to_sol(c, 0, &s) == PA_SUCCESS); /* c has one now */
  pa_sol_destroy(s);
  s = NULL;
  pa_mesh *bare = NULL;
  CHECK_OK(pa_mesh_create(2, &bare));
  CHECK(pa_mesh_metric_to_sol(bare, 0, &s) == PA_ERR_ARG && s == NULL);
  pa_mesh_destroy(bare);
  remove("met.solb");
  remove("small.sol");
  pa_mesh_destroy(m);
  pa_mesh_destroy(c);
}

/* ---- errors ---- */

/* Read text as FILE and expect status st with a message holding frag and
 * the file name. */
static void expect_mesh_error(const char *file, const char *text,
                              pa_status want, const char *frag) {
  pa_mesh *m = NULL;
  write_text(file, text);
  pa_status st = pa_mesh_read(file, &m);
  CHECK(st == want);
  CHECK(m == NULL);
  CHECK(msg_has(file) && msg_has(frag));
  pa_mesh_destroy(m);
  remove(file);
}

static void test_errors(void) {
  const char *head = "MeshVersionFormatted 2\nDimension 2\nVertices\n3\n"
                     "0 0 0\n1 0 0\n0 1 0\n";
  char text[512];
  snprintf(text, sizeof text, "%sTriangles\n1\n1 2 4 0\nEnd\n", head);
  expect_mesh_error("e1.mesh", text, PA_ERR_FORMAT,
                    "e1.mesh:10: triangle 1: "
                    "vertex index 4 is outside [1, 3]");
  snprintf(text, sizeof text, "%sEdges 1 0 1 3\n", head);
  expect_mesh_error("e2.mesh", text, PA_ERR_FORMAT, "indices start at 1");
  expect_mesh_error("e3.mesh", "Dimension 2\nVertices 1\n0 nan 0\n",
                    PA_ERR_FORMAT, ":3: vertex 1: coordinate 2 is NaN");
  expect_mesh_error("e4.mesh", "Dimension 2\nVertices 1 0 0 0\nFoo 3\n",
                    PA_ERR_FORMAT,
                    ":3: vertices but no Triangles nor Tetrahedra, and "
                    "keywords padapt does not know were skipped: Foo");
  expect_mesh_error("e5.mesh", "Vertices 1 0 0 0\n", PA_ERR_FORMAT,
                    "missing Dimension");
  expect_mesh_error("e6.mesh", "Dimension 3\nPrisms 1 1 2 3 4 5 6 0\n",
                    PA_ERR_UNSUPPORTED, "Prisms are not supported");
  expect_mesh_error("e7.mesh", "Dimension 3\nVertices 99999999\n0 0 0 0\n",
                    PA_ERR_FORMAT, "count 99999999 does not fit");
  expect_mesh_error("e8.mesh",
                    "Dimension 2\nTriangles 1 1 2 3 0\nVertices 2 "
                    "0 0 0 1 0 0\n",
                    PA_ERR_FORMAT,
                    "e8.mesh:2: Triangles: "
                    "triangle 1 refers to vertex 3, outside [1, 2]");
  expect_mesh_error("e9.mesh", "Dimension 2\nVertices 1 0 0 3000000000\n",
                    PA_ERR_FORMAT, "does not fit in 32 bits");
  expect_mesh_error("e10.mesh", "Dimension 2\nVertices 1 0 0 1\nVertices 0\n",
                    PA_ERR_FORMAT, ":3: duplicate Vertices");

  pa_mesh *m = NULL;
  CHECK(pa_mesh_read("does-not-exist.mesh", &m) == PA_ERR_IO);
  CHECK(msg_has("does-not-exist.mesh: cannot open"));
  CHECK(pa_mesh_read("does-not-exist.meshb", &m) == PA_ERR_IO);
  mkdir("dir.mesh", 0755);
  CHECK(pa_mesh_read("dir.mesh", &m) == PA_ERR_IO);
  rmdir("dir.mesh");
  pa_sol *s = NULL;
  CHECK(pa_sol_read("x.txt", &s) == PA_ERR_UNSUPPORTED);

  /* A corrupt binary count must fail before allocating for it. */
  unsigned char b[64];
  int32_t w[] = {1, 2, 3, 20, 3, 4, 0, 1000000000};
  memcpy(b, w, sizeof w);
  write_file("huge.meshb", b, sizeof w);
  pa_memory_reset_peak();
  size_t before = pa_memory_peak();
  CHECK(pa_mesh_read("huge.meshb", &m) == PA_ERR_FORMAT);
  CHECK(msg_has("huge.meshb: byte 28: Vertices: count 1000000000"));
  CHECK(pa_memory_peak() - before < ((size_t)1 << 24));
  remove("huge.meshb");
}

/* Every file of tests/data/bad/medit.expected fails with a message naming
 * the file and holding the fragment; every medit_ / sol_ file is listed. */
static void test_corpus(void) {
  const char *dir = getenv("PADAPT_TESTDATA");
  char path[2048], line[1024], base[2048];
  int nfile = 0;
  if (!dir) {
    fprintf(stderr, "  PADAPT_TESTDATA not set: corpus skipped\n");
    return;
  }
  snprintf(path, sizeof path, "%s/bad/medit.expected", dir);
  FILE *f = fopen(path, "r");
  CHECK(f != NULL);
  if (!f) return;
  pa_mesh *b2 = NULL, *b3 = NULL;
  snprintf(base, sizeof base, "%s/bad/base2d.mesh", dir);
  CHECK_OK(pa_mesh_read(base, &b2));
  snprintf(base, sizeof base, "%s/bad/base3d.mesh", dir);
  CHECK_OK(pa_mesh_read(base, &b3));
  CHECK(b2 && pa_mesh_dim(b2) == 2 && pa_mesh_nvert(b2) == 9);
  CHECK(b3 && pa_mesh_dim(b3) == 3 && pa_mesh_nelem(b3) == 6);
  while (b2 && b3 && fgets(line, sizeof line, f)) {
    char *tab = strchr(line, '\t');
    CHECK(tab != NULL);
    if (!tab) continue;
    *tab = '\0';
    char *frag = tab + 1;
    frag[strcspn(frag, "\n")] = '\0';
    snprintf(path, sizeof path, "%s/bad/%s", dir, line);
    CHECK(file_exists(path));
    pa_status st;
    nfile++;
    if (!strncmp(line, "medit_", 6)) {
      pa_mesh *m = NULL;
      st = pa_mesh_read(path, &m);
      CHECK(m == NULL);
      pa_mesh_destroy(m);
    } else {
      pa_sol *s = NULL;
      pa_mesh *on = !strncmp(line, "sol_3d_", 7) ? b3 : b2;
      st = pa_sol_read(path, &s);
      if (st == PA_SUCCESS && pa_sol_nfield(s) > 1) {
        /* several solutions: the library takes the one asked for, the CLI
         * refuses them as a metric (tests/cli/test_bad_input.sh) */
        CHECK(strstr(frag, "solutions") != NULL);
        pa_sol_destroy(s);
        continue;
      }
      if (st == PA_SUCCESS) st = pa_mesh_metric_from_sol(on, s, 0);
      pa_sol_destroy(s);
      CHECK(pa_mesh_metric_ncomp(on) == 0); /* a failure changes nothing */
    }
    int ok = st != PA_SUCCESS && strstr(pa_last_error(), line) &&
             strstr(pa_last_error(), frag);
    if (!ok)
      fprintf(stderr, "  %s: status '%s', message '%s', expected '%s'\n", line,
              pa_status_string(st), pa_last_error(), frag);
    CHECK(ok);
  }
  fclose(f);
  CHECK(nfile >= 15);
  /* Every corpus file of ours is listed. */
  snprintf(path, sizeof path, "%s/bad", dir);
  DIR *d = opendir(path);
  CHECK(d != NULL);
  struct dirent *e;
  while (d && (e = readdir(d))) {
    if (strncmp(e->d_name, "medit_", 6) && strncmp(e->d_name, "sol_", 4))
      continue;
    snprintf(path, sizeof path, "%s/bad/medit.expected", dir);
    FILE *g = fopen(path, "r");
    int listed = 0;
    while (g && fgets(line, sizeof line, g))
      if (!strncmp(line, e->d_name, strlen(e->d_name)) &&
          line[strlen(e->d_name)] == '\t')
        listed = 1;
    if (g) fclose(g);
    if (!listed) fprintf(stderr, "  %s not in medit.expected\n", e->d_name);
    CHECK(listed);
  }
  if (d) closedir(d);
  pa_mesh_destroy(b2);
  pa_mesh_destroy(b3);
}

/* ---- failing writes and allocations ---- */

static void test_failing_writes(void) {
  pa_mesh *m = random_mesh(3, 100, 200, 80, 10, 31);
  if (!m) return;
  CHECK(pa_mesh_write(m, "no-such-dir/out.mesh", NULL) == PA_ERR_IO);
  CHECK(msg_has("no-such-dir/out.mesh"));
  CHECK(!file_exists("no-such-dir/out.mesh"));
  pa_write_opts bad = {0, 5, 0};
  CHECK(pa_mesh_write(m, "v5.meshb", &bad) == PA_ERR_ARG);
  CHECK(!file_exists("v5.meshb") && no_temp_files());
  pa_write_opts v1 = {0, 1, 0};
  pa_mesh_coords(m)[7] = 1e300; /* beyond float */
  CHECK(pa_mesh_write(m, "v1.meshb", &v1) == PA_ERR_ARG);
  CHECK(msg_has("does not fit in a float"));
  CHECK(!file_exists("v1.meshb") && no_temp_files());
  pa_mesh_coords(m)[7] = 0.5;

  /* A failed write leaves an existing file as it was and no temporary. */
  const char *paths[] = {"keep.mesh", "keep.meshb"};
  for (int p = 0; p < 2; p++) {
    write_text(paths[p], "old contents");
    int k, done = 0;
    for (k = 1; k < 100 && !done; k++) {
      pa_memory_fail_after(k);
      pa_status st = pa_mesh_write(m, paths[p], NULL);
      pa_memory_fail_after(0);
      if (st == PA_SUCCESS) {
        done = 1;
        break;
      }
      CHECK(st == PA_ERR_MEMORY);
      FILE *f = fopen(paths[p], "r");
      char buf[32] = "";
      if (f) {
        CHECK(fgets(buf, sizeof buf, f) != NULL);
        fclose(f);
      }
      CHECK(!strcmp(buf, "old contents"));
      CHECK(no_temp_files());
    }
    CHECK(done && k > 1);
    pa_mesh *r = NULL;
    CHECK_OK(pa_mesh_read(paths[p], &r));
    CHECK(r && same_mesh(m, r, 0));
    pa_mesh_destroy(r);
    remove(paths[p]);
  }
  pa_sol *s = NULL;
  pa_sol_kind k1 = PA_SOL_SCALAR;
  s = random_sol(3, 10, &k1, 1);
  CHECK(pa_sol_write(s, "no-such-dir/x.solb") == PA_ERR_IO);
  CHECK(!file_exists("no-such-dir/x.solb"));
  pa_sol_destroy(s);
  pa_mesh_destroy(m);
}

/* Make each allocation of a read fail in turn: PA_ERR_MEMORY, no mesh, no
 * leak, until the read succeeds. */
static void fail_each_allocation(const char *path, int is_sol) {
  size_t before = pa_memory_current();
  int k, done = 0;
  for (k = 1; k < 200 && !done; k++) {
    pa_mesh *m = NULL;
    pa_sol *s = NULL;
    pa_memory_fail_after(k);
    pa_status st = is_sol ? pa_sol_read(path, &s) : pa_mesh_read(path, &m);
    pa_memory_fail_after(0);
    if (st == PA_SUCCESS) {
      done = 1;
    } else {
      CHECK(st == PA_ERR_MEMORY);
      CHECK(m == NULL && s == NULL);
      CHECK(pa_memory_current() == before);
    }
    pa_mesh_destroy(m);
    pa_sol_destroy(s);
  }
  CHECK(done && k > 3);
  CHECK(pa_memory_current() == before);
}

static void test_failing_allocations(void) {
  pa_mesh *m = random_mesh(3, 50, 60, 30, 8, 41);
  if (!m) return;
  CHECK_OK(pa_mesh_write(m, "alloc.mesh", NULL));
  CHECK_OK(pa_mesh_write(m, "alloc.meshb", NULL));
  fail_each_allocation("alloc.mesh", 0);
  fail_each_allocation("alloc.meshb", 0);
  write_text("flat.mesh", flat2d_text);
  fail_each_allocation("flat.mesh", 0);
  pa_sol_kind k[] = {PA_SOL_TENSOR, PA_SOL_SCALAR};
  pa_sol *s = random_sol(3, 50, k, 2);
  CHECK_OK(pa_sol_write(s, "alloc.sol"));
  fail_each_allocation("alloc.sol", 1);
  pa_sol_destroy(s);
  remove("alloc.mesh");
  remove("alloc.meshb");
  remove("alloc.sol");
  remove("flat.mesh");
  pa_mesh_destroy(m);
}

/* The text form of a real: the shorter of %.15g and %.17g that reads back
 * exactly, by snprintf and strtod (the oracle of the writer's fast path). */
static void shortest_real(char *s, size_t n, double x) {
  snprintf(s, n, "%.15g", x);
  if (strtod(s, NULL) != x && !isnan(x)) snprintf(s, n, "%.17g", x);
}

/* A coordinate of every kind the writer tells apart: computed ones (17
 * digits), short decimals, exact binary ties, zeros of both signs, powers
 * of 10 and their neighbours, exponents 15 and 16 (where %.15g and %.17g
 * switch forms at different digits), and random scales. */
static double text_real(int i) {
  double u = pa_test_rand();
  switch (i % 10) {
  case 0: return pa_test_rand_range(-1, 1);
  case 1: return round(u * 1000) / 1000 - 0.5;
  case 2: return (int)(u * 4096 - 2048) / 64.0;
  case 3: return i % 20 == 3 ? 0.0 : -0.0;
  case 4: return pow(10, (int)(u * 40) - 20);
  case 5: return nextafter(pow(10, (int)(u * 40) - 20), i % 20 == 5 ? 0 : 1e300);
  case 6: return (1 + round(u * 1e6)) * 1e10 * (i % 20 == 6 ? 1 : -1);
  case 7: return pa_test_rand_range(1e15, 1e17);
  case 8: return round(pa_test_rand_range(1e14, 1e17));
  default: return pa_test_rand_range(-1, 1) * pow(10, (int)(u * 60) - 30);
  }
}

/* The text writer's numbers, token by token, against snprintf: the
 * vertices' coordinates (shortest_real) and references, the elements'
 * vertex numbers and references ("%lld"). */
static void test_text_numbers(void) {
  pa_mesh *m = NULL;
  const pa_idx nv = 20000;
  pa_test_seed(20261127);
  CHECK_OK(pa_mesh_create(3, &m));
  if (!m) return;
  CHECK_OK(pa_mesh_reserve(m, nv, nv / 4, 0, 0));
  for (pa_idx i = 0; i < nv; i++) {
    double x[3];
    for (int k = 0; k < 3; k++) x[k] = text_real(3 * (int)i + k);
    int32_t ref = (int32_t)((pa_test_rand() - 0.5) * 4.2e9);
    CHECK_OK(pa_mesh_add_vertex(m, x, ref, NULL));
  }
  for (pa_idx e = 0; e < nv / 4; e++) {
    pa_idx v[4] = {4 * e, 4 * e + 1, 4 * e + 2, 4 * e + 3};
    CHECK_OK(pa_mesh_add_elem(m, v, (int32_t)(e * 7919 % 200001) - 100000,
                              NULL));
  }
  CHECK_OK(pa_mesh_write(m, "numbers.mesh", NULL));
  FILE *f = fopen("numbers.mesh", "r");
  CHECK(f != NULL);
  char tok[64], want[64];
  long bad = 0;
  while (f && fscanf(f, "%63s", tok) == 1 && strcmp(tok, "Vertices")) {}
  CHECK(f && fscanf(f, "%63s", tok) == 1 && atol(tok) == nv);
  const double *c = pa_mesh_coords(m);
  const int32_t *vr = pa_mesh_vert_refs(m);
  for (pa_idx i = 0; f && i < nv; i++)
    for (int k = 0; k <= 3; k++) {
      if (k < 3) shortest_real(want, sizeof want, c[3 * (size_t)i + k]);
      else snprintf(want, sizeof want, "%d", (int)vr[i]);
      if (fscanf(f, "%63s", tok) != 1 || strcmp(tok, want)) {
        if (bad++ < 5)
          fprintf(stderr, "  vertex %d: '%s', snprintf '%s'\n", (int)i, tok,
                  want);
      }
    }
  while (f && fscanf(f, "%63s", tok) == 1 && strcmp(tok, "Tetrahedra")) {}
  CHECK(f && fscanf(f, "%63s", tok) == 1 && atol(tok) == nv / 4);
  const pa_idx *ev = pa_mesh_elems(m);
  const int32_t *er = pa_mesh_elem_refs(m);
  for (pa_idx e = 0; f && e < nv / 4; e++)
    for (int k = 0; k <= 4; k++) {
      snprintf(want, sizeof want, "%lld",
               k < 4 ? (long long)ev[4 * (size_t)e + k] + 1 : (long long)er[e]);
      if (fscanf(f, "%63s", tok) != 1 || strcmp(tok, want)) {
        if (bad++ < 5)
          fprintf(stderr, "  element %d: '%s', snprintf '%s'\n", (int)e, tok,
                  want);
      }
    }
  CHECK(bad == 0);
  if (f) fclose(f);
  remove("numbers.mesh");
  pa_mesh_destroy(m);
}

/* A generated mesh (when the generator is there) through every format. */
static void test_generated(void) {
  pa_mesh *m = NULL;
  pa_status st = pa_mesh_generate_box(3, 16, &m);
  if (st == PA_ERR_UNSUPPORTED) {
    fprintf(stderr, "  pa_mesh_generate_box not available: skipped\n");
    return;
  }
  CHECK_OK(st);
  if (!m) return;
  const char *paths[] = {"gen.mesh", "gen.meshb"};
  for (int p = 0; p < 2; p++) {
    pa_mesh *r = NULL;
    double t0 = pa_wtime();
    CHECK_OK(pa_mesh_write(m, paths[p], NULL));
    double t1 = pa_wtime();
    CHECK_OK(pa_mesh_read(paths[p], &r));
    double t2 = pa_wtime();
    CHECK(r && same_mesh(m, r, 0));
    printf("  %s: %d tets, write %.3f s, read %.3f s\n", paths[p],
           (int)pa_mesh_nelem(m), t1 - t0, t2 - t1);
    pa_mesh_destroy(r);
    remove(paths[p]);
  }
  pa_mesh_destroy(m);
}

/* ---- the keywords other tools write ----
 *
 * FreeFem++'s (savemesh's bamg keywords, savesol's layout, ASCII under a
 * .meshb name), Gmsh's (leading blanks, high-order elements), Mmg's
 * (normals, tangents, Parallel*, required entities) and libMeshb's (binary
 * codes padapt does not know, skipped through their next position). Each
 * file must read as the same file without those keywords does; the note at
 * verbosity 1 must name them once each; a malformed keyword padapt reads
 * must still fail with FILE:LINE. The CLI side, on files FreeFem++ and Gmsh
 * write during the test: tests/cli/test_freefem_files.sh. */

/* Read path at verbosity 1 with stderr captured into note (n bytes). */
static pa_status read_noted(const char *path, pa_mesh **m, char *note,
                            size_t n) {
  fflush(stderr);
  int saved = dup(2);
  int fd = open("note.txt", O_CREAT | O_TRUNC | O_RDWR, 0644);
  CHECK(saved >= 0 && fd >= 0);
  dup2(fd, 2);
  pa_set_verbosity(1);
  pa_status st = pa_mesh_read(path, m);
  pa_set_verbosity(0);
  fflush(stderr);
  dup2(saved, 2);
  close(saved);
  ssize_t got = pread(fd, note, n - 1, 0);
  note[got > 0 ? got : 0] = '\0';
  close(fd);
  remove("note.txt");
  return st;
}

static int count_of(const char *text, const char *s) {
  int n = 0;
  for (const char *p = strstr(text, s); p; p = strstr(p + 1, s))
    n++;
  return n;
}

/* The file FreeFem++ 4.11 writes for savemesh(square(2,1), "sq.mesh"),
 * byte for byte. */
static const char ff_square[] =
    "MeshVersionFormatted 1\n\nDimension\n2\n\nIdentifier\n"
    "\";1, Date: 26/11/28 16:51 16s\"\n\nGeometry\n\"sq.mesh.gmsh\"\n\n"
    "Vertices\n6\n0 0 4\n0.5 0 1\n1 0 2\n0 1 4\n0.5 1 3\n1 1 3\n\n"
    "Edges\n6\n1 2 1\n2 3 1\n3 6 2\n5 4 3\n6 5 3\n4 1 4\n\n"
    "Triangles\n4\n1 2 5 0\n1 5 4 0\n2 3 6 0\n2 6 5 0\n\n"
    "SubDomainFromMesh\n1\n3 1 1 0\n\nSubDomainFromGeom\n1\n2 1 1 0\n\n"
    "VertexOnGeometricVertex\n6\n 1 1\n 2 2\n 3 3\n 4 4\n 5 5\n 6 6\n\n"
    "VertexOnGeometricEdge\n0\n\n"
    "EdgeOnGeometricEdge\n6\n1 1\n2 2\n3 3\n4 4\n5 5\n6 6\n\nEnd\n";

/* The same mesh with the keywords padapt uses only. */
static const char ff_square_plain[] =
    "MeshVersionFormatted 1\nDimension 2\n"
    "Vertices\n6\n0 0 4\n0.5 0 1\n1 0 2\n0 1 4\n0.5 1 3\n1 1 3\n"
    "Edges\n6\n1 2 1\n2 3 1\n3 6 2\n5 4 3\n6 5 3\n4 1 4\n"
    "Triangles\n4\n1 2 5 0\n1 5 4 0\n2 3 6 0\n2 6 5 0\nEnd\n";

static void test_freefem(void) {
  pa_mesh *m = NULL, *ref = NULL;
  char note[1024];
  write_text("plain.mesh", ff_square_plain);
  CHECK_OK(pa_mesh_read("plain.mesh", &ref));
  write_text("ff.mesh", ff_square);
  CHECK_OK(read_noted("ff.mesh", &m, note, sizeof note));
  CHECK(m && same_mesh(m, ref, 0));
  /* One note, every keyword skipped named once, in file order. */
  CHECK(strstr(note, "ff.mesh: skipped the keywords padapt does not use: "
                     "Identifier, Geometry, SubDomainFromMesh, "
                     "SubDomainFromGeom, VertexOnGeometricVertex, "
                     "VertexOnGeometricEdge, EdgeOnGeometricEdge\n") != NULL);
  CHECK(count_of(note, "skipped") == 1);
  pa_mesh_destroy(m);
  m = NULL;

  /* Nothing printed at verbosity 0. */
  CHECK_OK(pa_mesh_read("ff.mesh", &m));
  pa_mesh_destroy(m);
  m = NULL;

  /* FreeFem++'s 2D savemesh writes ASCII under a .meshb name too. */
  write_text("ff.meshb", ff_square);
  CHECK_OK(read_noted("ff.meshb", &m, note, sizeof note));
  CHECK(m && same_mesh(m, ref, 0));
  CHECK(strstr(note, "an ASCII Medit file under a binary name") != NULL);
  pa_mesh_destroy(m);
  m = NULL;

  /* Geometric links with records, as bamg writes them after an adaptation:
   * vertex, edge and a real abscissa. */
  char text[2048];
  snprintf(text, sizeof text, "%s",
           "MeshVersionFormatted 1\nDimension 2\n"
           "VertexOnGeometricEdge\n2\n2 1 0.5\n5 3 0.5\n"
           "CrackedEdges\n0\n"
           "Vertices\n6\n0 0 4\n0.5 0 1\n1 0 2\n0 1 4\n0.5 1 3\n1 1 3\n"
           "MaximalAngleOfCorner\n46\n"
           "Edges\n6\n1 2 1\n2 3 1\n3 6 2\n5 4 3\n6 5 3\n4 1 4\n"
           "Triangles\n4\n1 2 5 0\n1 5 4 0\n2 3 6 0\n2 6 5 0\n");
  write_text("bamg.mesh", text);
  CHECK_OK(pa_mesh_read("bamg.mesh", &m));
  CHECK(m && same_mesh(m, ref, 0));
  pa_mesh_destroy(m);
  pa_mesh_destroy(ref);
  remove("plain.mesh");
  remove("ff.mesh");
  remove("ff.meshb");
  remove("bamg.mesh");
}

/* FreeFem++'s savesol: version 1, a blank line after the types, trailing
 * blanks; the binary one in version 1 (floats). */
static void test_freefem_sol(void) {
  static const char sol[] = "MeshVersionFormatted 1\n\nDimension 2\n\n"
                            "SolAtVertices\n6\n1 1 \n\n0 \n0.5 \n1 \n2 \n"
                            "2.5 \n3 \n\nEnd\n";
  static const unsigned char solb[] = {
      0x01, 0, 0,    0,    0x01, 0, 0, 0,    0x03, 0, 0,    0,
      0x14, 0, 0,    0,    0x02, 0, 0, 0,    0x3e, 0, 0,    0,
      0x40, 0, 0,    0,    0x06, 0, 0, 0,    0x01, 0, 0,    0,
      0x01, 0, 0,    0,    0,    0, 0, 0,    0,    0, 0,    0x3f,
      0,    0, 0x80, 0x3f, 0,    0, 0, 0x40, 0,    0, 0x20, 0x40,
      0,    0, 0x40, 0x40, 0x36, 0, 0, 0,    0,    0, 0,    0};
  const double want[6] = {0, 0.5, 1, 2, 2.5, 3};
  const char *files[2] = {"ff.sol", "ff.solb"};
  write_text("ff.sol", sol);
  write_file("ff.solb", solb, sizeof solb);
  for (int f = 0; f < 2; f++) {
    pa_sol *s = NULL;
    CHECK_OK(pa_sol_read(files[f], &s));
    CHECK(s && pa_sol_dim(s) == 2 && pa_sol_nvert(s) == 6 &&
          pa_sol_nfield(s) == 1);
    if (s) {
      pa_sol_kind kind;
      int ncomp;
      double *v;
      CHECK_OK(pa_sol_field(s, 0, &kind, &ncomp, &v));
      CHECK(kind == PA_SOL_SCALAR && ncomp == 1);
      for (int i = 0; i < 6 && ncomp == 1; i++)
        CHECK(v[i] == want[i]);
    }
    pa_sol_destroy(s);
  }
  /* A solution file with keywords padapt does not know around it. */
  write_text("extra.sol", "MeshVersionFormatted 2\nDimension 2\n"
                          "ReferenceStrings 1 2 7 \"inlet pipe\"\n"
                          "SolAtVertices\n3\n1 1\n1\n2\n3\n"
                          "HOSolAtTrianglesP2 0\nEnd\n");
  pa_sol *s = NULL;
  CHECK_OK(pa_sol_read("extra.sol", &s));
  CHECK(s && pa_sol_nvert(s) == 3);
  pa_sol_destroy(s);
  remove("ff.sol");
  remove("ff.solb");
  remove("extra.sol");
}

/* What the ASCII skip crosses: numbers of every form (nan and inf are
 * numbers, not keywords), comments, strings of several words holding a
 * keyword's name, an unknown keyword first, last, and before End. */
static void test_unknown_ascii(void) {
  pa_mesh *m = NULL, *ref = NULL;
  char note[1024];
  write_text("plain.mesh", ff_square_plain);
  CHECK_OK(pa_mesh_read("plain.mesh", &ref));
  write_text("odd.mesh",
             "Foo 3 1e-3 -2.5E+07 nan inf -Infinity .5 0x10\n"
             "MeshVersionFormatted 1\nDimension 2\n"
             "Names 2 \"Vertices of the inlet\" \"wall\"\n"
             "Bar # Triangles in a comment\n 7\n"
             "Vertices\n6\n0 0 4\n0.5 0 1\n1 0 2\n0 1 4\n0.5 1 3\n1 1 3\n"
             "Foo 1 2 3\n"
             "Edges\n6\n1 2 1\n2 3 1\n3 6 2\n5 4 3\n6 5 3\n4 1 4\n"
             "Triangles\n4\n1 2 5 0\n1 5 4 0\n2 3 6 0\n2 6 5 0\n"
             "Baz\nEnd\n");
  CHECK_OK(read_noted("odd.mesh", &m, note, sizeof note));
  CHECK(m && same_mesh(m, ref, 0));
  CHECK(strstr(note, "skipped the keywords padapt does not use: Foo, Names, "
                     "Bar, Baz\n") != NULL);
  pa_mesh_destroy(m);
  m = NULL;

  /* No End: the file ends inside an unknown keyword's data. */
  write_text("noend.mesh", "MeshVersionFormatted 1\nDimension 2\n"
                           "Vertices\n6\n0 0 4\n0.5 0 1\n1 0 2\n0 1 4\n"
                           "0.5 1 3\n1 1 3\nEdges\n6\n1 2 1\n2 3 1\n3 6 2\n"
                           "5 4 3\n6 5 3\n4 1 4\nTriangles\n4\n1 2 5 0\n"
                           "1 5 4 0\n2 3 6 0\n2 6 5 0\nQux 1 2 3");
  CHECK_OK(pa_mesh_read("noend.mesh", &m));
  CHECK(m && same_mesh(m, ref, 0));
  pa_mesh_destroy(m);
  pa_mesh_destroy(ref);
  remove("plain.mesh");
  remove("odd.mesh");
  remove("noend.mesh");
}

/* Keywords padapt reads stay strict next to skipped ones. */
static void test_still_strict(void) {
  const char *verts = "Vertices\n3\n0 0 0\n1 0 0\n0 1 0\n";
  char text[512];
  /* A count larger than the data: the next keyword is not a number. */
  snprintf(text, sizeof text,
           "Dimension 2\nFoo 1 2\n%sTriangles\n2\n1 2 3 0\nBar 4\n", verts);
  expect_mesh_error(
      "s1.mesh", text, PA_ERR_FORMAT,
      "s1.mesh:11: expected an integer in Triangles, found 'Bar'");
  /* A count smaller than the data, after an unknown keyword's data. */
  snprintf(text, sizeof text,
           "Dimension 2\nFoo 1 2\nVertices\n2\n0 0 0\n1 0 0\n0 1 0\n");
  expect_mesh_error("s2.mesh", text, PA_ERR_FORMAT,
                    "s2.mesh:7: expected a keyword, found '0'");
  /* A stray word inside a known keyword's records. */
  snprintf(text, sizeof text,
           "Dimension 2\nVertices\n3\n0 0 0\n1 x 0\n0 1 0\nFoo 1\n");
  expect_mesh_error("s3.mesh", text, PA_ERR_FORMAT,
                    "s3.mesh:5: expected a real number in Vertices, found 'x'");
  /* An index out of range after a skipped keyword. */
  snprintf(text, sizeof text,
           "Dimension 2\n%sSubDomainFromMesh 1 3 1 1 0\nTriangles 1\n"
           "1 2 4 0\n",
           verts);
  expect_mesh_error("s4.mesh", text, PA_ERR_FORMAT,
                    "s4.mesh:9: triangle 1: vertex index 4 is outside [1, 3]");
  /* A string left open. */
  snprintf(text, sizeof text, "Dimension 2\n%sNames 1 \"open to the end\n",
           verts);
  expect_mesh_error("s5.mesh", text, PA_ERR_FORMAT, "unexpected end of file");
  /* A misspelt Triangles: vertices and no elements, the keyword named at
   * its line. */
  snprintf(text, sizeof text, "Dimension 2\n%sTriangle\n1\n1 2 3 0\n", verts);
  expect_mesh_error("s6.mesh", text, PA_ERR_FORMAT,
                    "s6.mesh:7: vertices but no Triangles nor Tetrahedra, and "
                    "keywords padapt does not know were skipped: Triangle");
  /* Skipped keywords padapt knows (Normals) do not make that an error:
   * an element-free file reads as before. */
  snprintf(text, sizeof text, "Dimension 3\nVertices 1 0 0 0 0\nNormals 0\n");
  pa_mesh *m = NULL;
  write_text("s7.mesh", text);
  CHECK_OK(pa_mesh_read("s7.mesh", &m));
  pa_mesh_destroy(m);
  remove("s7.mesh");
  /* Text that is not Medit under a .meshb name is still refused. */
  expect_mesh_error("s8.meshb",
                    "\x7f"
                    "ELF garbage.....",
                    PA_ERR_FORMAT, "s8.meshb: byte 0: not a binary Medit file");
}

/* Gmsh's high-order elements (gmsh -order 2 -format mesh) and the other
 * element kinds padapt does not adapt are refused when present, accepted
 * empty. */
static void test_high_order(void) {
  const char *head = " MeshVersionFormatted 2\n Dimension\n 3\n Vertices\n"
                     " 6\n 0 0 0 1\n 1 0 0 2\n 0 1 0 3\n 0.5 0 0 1\n"
                     " 0.5 0.5 0 2\n 0 0.5 0 3\n";
  char text[1024];
  snprintf(text, sizeof text,
           "%s EdgesP2\n 1\n 1 2 4 1\n TrianglesP2\n 1\n 1 2 3 4 5 6 9\n"
           " End\n",
           head);
  expect_mesh_error("p1.mesh", text, PA_ERR_UNSUPPORTED,
                    "p1.mesh:12: EdgesP2 are not supported");
  snprintf(text, sizeof text, "%s TrianglesP2\n 1\n 1 2 3 4 5 6 9\n End\n",
           head);
  expect_mesh_error("p2.mesh", text, PA_ERR_UNSUPPORTED,
                    "p2.mesh:12: TrianglesP2 are not supported");
  expect_mesh_error("p3.mesh",
                    "Dimension 3\nTetrahedraP2 1 1 2 3 4 5 6 7 8 9 10 0\n",
                    PA_ERR_UNSUPPORTED, "TetrahedraP2 are not supported");
  expect_mesh_error("p4.mesh",
                    "Dimension 2\nQuadrilateralsQ2 1 1 2 3 4 5 6 7 8 9 0\n",
                    PA_ERR_UNSUPPORTED, "QuadrilateralsQ2 are not supported");
  expect_mesh_error("p5.mesh",
                    "Dimension 3\nHexahedraQ2 1 1 2 3 4 5 6 7 8 9 10 "
                    "11 12 13 14 15 16 17 18 19 20 21 22 23 24 25 26 27 0\n",
                    PA_ERR_UNSUPPORTED, "HexahedraQ2 are not supported");
  /* Empty: nothing to refuse. */
  snprintf(text, sizeof text,
           "%s Triangles\n 1\n 1 2 3 0\n TrianglesP2\n 0\n EdgesP2 0\n"
           " Quadrilaterals 0\n End\n",
           head);
  pa_mesh *m = NULL;
  write_text("p6.mesh", text);
  CHECK_OK(pa_mesh_read("p6.mesh", &m));
  CHECK(m && pa_mesh_nelem(m) == 1);
  pa_mesh_destroy(m);
  remove("p6.mesh");
}

/* The keywords Mmg 5.8's savers write (mmg3d: normals and tangents at
 * ridge vertices, required entities, Parallel* under -nosurf): read, the
 * flags kept, the rest skipped. */
static void test_mmg(void) {
  static const char mmg3d[] =
      "MeshVersionFormatted 2\n\nDimension 3\n\nVertices\n4\n"
      "0 0 0 1\n1 0 0 1\n0 1 0 1\n0 0 1 1\n\n"
      "Edges\n1\n1 2 7\n\nTriangles\n4\n1 3 2 1\n1 2 4 1\n1 4 3 1\n"
      "2 3 4 1\n\nTetrahedra\n1\n1 2 3 4 3\n\nCorners\n1\n1\n\n"
      "RequiredVertices\n1\n2\n\nRidges\n1\n1\n\nRequiredEdges\n1\n1\n\n"
      "RequiredTriangles\n1\n4\n\nRequiredTetrahedra\n1\n1\n\n"
      "ParallelTriangles\n1\n4\n\nParallelVertices\n1\n2\n\n"
      "Normals\n1\n0 0 1\n\nNormalAtVertices\n1\n3 1\n\n"
      "Tangents\n1\n1 0 0\n\nTangentAtVertices\n1\n1 1\n\nEnd\n";
  pa_mesh *m = NULL;
  char note[1024];
  write_text("mmg.mesh", mmg3d);
  CHECK_OK(read_noted("mmg.mesh", &m, note, sizeof note));
  CHECK(m && pa_mesh_dim(m) == 3 && pa_mesh_nelem(m) == 1 &&
        pa_mesh_nbdry(m) == 4 && pa_mesh_nedge(m) == 1);
  if (m) {
    const uint8_t *vf = pa_mesh_vert_flags(m);
    CHECK(vf[0] == (PA_FLAG_CORNER | PA_FLAG_RIDGE));
    CHECK(vf[1] == (PA_FLAG_REQUIRED | PA_FLAG_RIDGE));
    CHECK(pa_mesh_edge_flags(m)[0] == (PA_FLAG_RIDGE | PA_FLAG_REQUIRED));
    CHECK(pa_mesh_bdry_flags(m)[3] == PA_FLAG_REQUIRED);
    CHECK(pa_mesh_elem_flags(m)[0] == PA_FLAG_REQUIRED);
  }
  CHECK(strstr(note,
               "skipped the keywords padapt does not use: "
               "ParallelTriangles, ParallelVertices, Normals, "
               "NormalAtVertices, Tangents, TangentAtVertices\n") != NULL);
  pa_mesh_destroy(m);
  remove("mmg.mesh");
}

/* Keyword header: code, next position (version 2: int32) of a keyword of
 * `bytes` bytes of data after the header. */
static void put_kwd(bbuf *b, int code, size_t bytes) {
  put_i32(b, code);
  put_i32(b, (int32_t)(b->n + 4 + bytes));
}

/* The square of ff_square_plain in version 2, with keywords padapt does
 * not know between its own: libMeshb's SubDomainFromGeom (code 29), a code
 * beyond libMeshb's table holding a byte count no layout explains, and a
 * NormalAtVertices. The next positions alone say where each ends. */
static void build_square_meshb(bbuf *b, int extra, int p2) {
  static const double x[6][2] = {{0, 0}, {0.5, 0}, {1, 0},
                                 {0, 1}, {0.5, 1}, {1, 1}};
  static const int vref[6] = {4, 1, 2, 4, 3, 3};
  static const int ed[6][3] = {{1, 2, 1}, {2, 3, 1}, {3, 6, 2},
                               {5, 4, 3}, {6, 5, 3}, {4, 1, 4}};
  static const int tr[4][4] = {
      {1, 2, 5, 0}, {1, 5, 4, 0}, {2, 3, 6, 0}, {2, 6, 5, 0}};
  memset(b, 0, sizeof *b);
  put_i32(b, 1);
  put_i32(b, 2);
  put_kwd(b, 3, 4);
  put_i32(b, 2);
  if (extra) {
    put_kwd(b, 29, 4 + 16); /* SubDomainFromGeom: 1 record of 4 ints */
    put_i32(b, 1);
    for (int k = 0; k < 4; k++)
      put_i32(b, k);
    put_kwd(b, 777, 13); /* 13 bytes: no record layout gives that */
    for (int k = 0; k < 13; k++)
      b->b[b->n++] = (unsigned char)(0xf0 + k);
  }
  put_kwd(b, 4, 4 + 6 * 20);
  put_i32(b, 6);
  for (int i = 0; i < 6; i++) {
    put_f64(b, x[i][0]);
    put_f64(b, x[i][1]);
    put_i32(b, vref[i]);
  }
  if (extra) {
    put_kwd(b, 20, 4 + 8); /* NormalAtVertices */
    put_i32(b, 1);
    put_i32(b, 1);
    put_i32(b, 1);
  }
  put_kwd(b, 5, 4 + 6 * 12);
  put_i32(b, 6);
  for (int i = 0; i < 6; i++)
    for (int k = 0; k < 3; k++)
      put_i32(b, ed[i][k]);
  put_kwd(b, 6, 4 + 4 * 16);
  put_i32(b, 4);
  for (int i = 0; i < 4; i++)
    for (int k = 0; k < 4; k++)
      put_i32(b, tr[i][k]);
  if (p2) {
    put_kwd(b, 24, 4 + 28); /* TrianglesP2 */
    put_i32(b, 1);
    for (int k = 0; k < 7; k++)
      put_i32(b, k < 6 ? k + 1 : 0);
  }
  put_i32(b, 54);
  put_i32(b, 0);
}

static void test_unknown_binary(void) {
  pa_mesh *m = NULL, *ref = NULL;
  bbuf b;
  char note[1024];
  write_text("plain.mesh", ff_square_plain);
  CHECK_OK(pa_mesh_read("plain.mesh", &ref));
  build_square_meshb(&b, 0, 0);
  write_file("sq.meshb", b.b, b.n);
  CHECK_OK(pa_mesh_read("sq.meshb", &m));
  CHECK(m && same_mesh(m, ref, 0));
  pa_mesh_destroy(m);
  m = NULL;

  build_square_meshb(&b, 1, 0);
  write_file("sq.meshb", b.b, b.n);
  CHECK_OK(read_noted("sq.meshb", &m, note, sizeof note));
  CHECK(m && same_mesh(m, ref, 0));
  CHECK(strstr(note, "sq.meshb: skipped the keywords padapt does not use: "
                     "code 29, code 777, NormalAtVertices\n") != NULL);
  pa_mesh_destroy(m);
  m = NULL;

  /* The unknown keyword's next position pointing backwards is corrupt. */
  size_t at = 8 + 12 + 4; /* next position of code 29 */
  int32_t back = 8;
  memcpy(b.b + at, &back, 4);
  write_file("sq.meshb", b.b, b.n);
  CHECK(pa_mesh_read("sq.meshb", &m) == PA_ERR_FORMAT);
  CHECK(m == NULL && msg_has("sq.meshb: byte 20: keyword 29 (?): next "
                             "keyword position 8 is outside"));

  /* High-order elements in a binary file: refused. */
  build_square_meshb(&b, 1, 1);
  write_file("sq.meshb", b.b, b.n);
  CHECK(pa_mesh_read("sq.meshb", &m) == PA_ERR_UNSUPPORTED);
  CHECK(m == NULL && msg_has("TrianglesP2 are not supported"));
  pa_mesh_destroy(ref);
  remove("plain.mesh");
  remove("sq.meshb");
}

TEST_MAIN(test_round_trips, test_hand_written, test_binary_swapped,
          test_sol_round_trips, test_metric_bridge, test_errors, test_corpus,
          test_failing_writes, test_failing_allocations, test_text_numbers,
          test_generated, test_freefem, test_freefem_sol, test_unknown_ascii,
          test_still_strict, test_high_order, test_mmg, test_unknown_binary)
