/* test_medit_keywords.c -- the keywords other tools write that padapt does
 * not use: FreeFem++'s (savemesh's bamg keywords, savesol's layout, ASCII
 * under a .meshb name), Gmsh's (leading blanks, high-order elements), Mmg's
 * (normals, tangents, Parallel*, required entities) and libMeshb's (binary
 * codes padapt does not know, skipped through their next position). Each
 * file must read as the same file without those keywords does; the note at
 * verbosity 1 must name them once each; a malformed keyword padapt reads
 * must still fail with FILE:LINE. The CLI side, on files FreeFem++ and Gmsh
 * write during the test: tests/cli/test_freefem_files.sh. */
#include "testutil.h"

#include <fcntl.h>
#include <stdint.h>
#include <unistd.h>

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

static int msg_has(const char *s) {
  if (strstr(pa_last_error(), s)) return 1;
  fprintf(stderr, "  message '%s' lacks '%s'\n", pa_last_error(), s);
  return 0;
}

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

/* Same vertices, elements, boundary, references and flags. */
static int same_mesh(pa_mesh *a, pa_mesh *b) {
  if (!a || !b) return 0;
  int d = pa_mesh_dim(a);
  if (d != pa_mesh_dim(b) || pa_mesh_nvert(a) != pa_mesh_nvert(b) ||
      pa_mesh_nelem(a) != pa_mesh_nelem(b) ||
      pa_mesh_nbdry(a) != pa_mesh_nbdry(b) ||
      pa_mesh_nedge(a) != pa_mesh_nedge(b))
    return 0;
  size_t nv = (size_t)pa_mesh_nvert(a), ne = (size_t)pa_mesh_nelem(a),
         nb = (size_t)pa_mesh_nbdry(a);
  return !memcmp(pa_mesh_coords(a), pa_mesh_coords(b),
                 nv * d * sizeof(double)) &&
         !memcmp(pa_mesh_vert_refs(a), pa_mesh_vert_refs(b),
                 nv * sizeof(int32_t)) &&
         !memcmp(pa_mesh_vert_flags(a), pa_mesh_vert_flags(b), nv) &&
         !memcmp(pa_mesh_elems(a), pa_mesh_elems(b),
                 ne * (d + 1) * sizeof(pa_idx)) &&
         !memcmp(pa_mesh_elem_refs(a), pa_mesh_elem_refs(b),
                 ne * sizeof(int32_t)) &&
         !memcmp(pa_mesh_bdrys(a), pa_mesh_bdrys(b), nb * d * sizeof(pa_idx)) &&
         !memcmp(pa_mesh_bdry_refs(a), pa_mesh_bdry_refs(b),
                 nb * sizeof(int32_t)) &&
         !memcmp(pa_mesh_bdry_flags(a), pa_mesh_bdry_flags(b), nb);
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
  CHECK(same_mesh(m, ref));
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
  CHECK(same_mesh(m, ref));
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
  CHECK(same_mesh(m, ref));
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
      0x01, 0, 0, 0,    0x01, 0, 0, 0, 0x03, 0, 0, 0, 0x14, 0, 0, 0,
      0x02, 0, 0, 0,    0x3e, 0, 0, 0, 0x40, 0, 0, 0, 0x06, 0, 0, 0,
      0x01, 0, 0, 0,    0x01, 0, 0, 0, 0,    0, 0, 0, 0,    0, 0, 0x3f,
      0,    0, 0x80, 0x3f, 0, 0, 0, 0x40, 0,  0, 0x20, 0x40, 0, 0, 0x40, 0x40,
      0x36, 0, 0, 0,    0,    0, 0, 0};
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
  CHECK(same_mesh(m, ref));
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
  CHECK(same_mesh(m, ref));
  pa_mesh_destroy(m);
  pa_mesh_destroy(ref);
  remove("plain.mesh");
  remove("odd.mesh");
  remove("noend.mesh");
}

static void expect_error(const char *file, const char *text, pa_status want,
                         const char *frag) {
  pa_mesh *m = NULL;
  write_text(file, text);
  pa_status st = pa_mesh_read(file, &m);
  CHECK(st == want);
  CHECK(m == NULL);
  CHECK(msg_has(file) && msg_has(frag));
  pa_mesh_destroy(m);
  remove(file);
}

/* Keywords padapt reads stay strict next to skipped ones. */
static void test_still_strict(void) {
  const char *verts = "Vertices\n3\n0 0 0\n1 0 0\n0 1 0\n";
  char text[512];
  /* A count larger than the data: the next keyword is not a number. */
  snprintf(text, sizeof text,
           "Dimension 2\nFoo 1 2\n%sTriangles\n2\n1 2 3 0\nBar 4\n", verts);
  expect_error("s1.mesh", text, PA_ERR_FORMAT,
               "s1.mesh:11: expected an integer in Triangles, found 'Bar'");
  /* A count smaller than the data, after an unknown keyword's data. */
  snprintf(text, sizeof text,
           "Dimension 2\nFoo 1 2\nVertices\n2\n0 0 0\n1 0 0\n0 1 0\n");
  expect_error("s2.mesh", text, PA_ERR_FORMAT,
               "s2.mesh:7: expected a keyword, found '0'");
  /* A stray word inside a known keyword's records. */
  snprintf(text, sizeof text,
           "Dimension 2\nVertices\n3\n0 0 0\n1 x 0\n0 1 0\nFoo 1\n");
  expect_error("s3.mesh", text, PA_ERR_FORMAT,
               "s3.mesh:5: expected a real number in Vertices, found 'x'");
  /* An index out of range after a skipped keyword. */
  snprintf(text, sizeof text,
           "Dimension 2\n%sSubDomainFromMesh 1 3 1 1 0\nTriangles 1\n"
           "1 2 4 0\n",
           verts);
  expect_error("s4.mesh", text, PA_ERR_FORMAT,
               "s4.mesh:9: triangle 1: vertex index 4 is outside [1, 3]");
  /* A string left open. */
  snprintf(text, sizeof text, "Dimension 2\n%sNames 1 \"open to the end\n",
           verts);
  expect_error("s5.mesh", text, PA_ERR_FORMAT, "unexpected end of file");
  /* A misspelt Triangles: vertices and no elements, the keyword named at
   * its line. */
  snprintf(text, sizeof text, "Dimension 2\n%sTriangle\n1\n1 2 3 0\n", verts);
  expect_error("s6.mesh", text, PA_ERR_FORMAT,
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
  expect_error("s8.meshb", "\x7f"
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
  expect_error("p1.mesh", text, PA_ERR_UNSUPPORTED,
               "p1.mesh:12: EdgesP2 are not supported");
  snprintf(text, sizeof text, "%s TrianglesP2\n 1\n 1 2 3 4 5 6 9\n End\n",
           head);
  expect_error("p2.mesh", text, PA_ERR_UNSUPPORTED,
               "p2.mesh:12: TrianglesP2 are not supported");
  expect_error("p3.mesh",
               "Dimension 3\nTetrahedraP2 1 1 2 3 4 5 6 7 8 9 10 0\n",
               PA_ERR_UNSUPPORTED, "TetrahedraP2 are not supported");
  expect_error("p4.mesh", "Dimension 2\nQuadrilateralsQ2 1 1 2 3 4 5 6 7 8 9 0\n",
               PA_ERR_UNSUPPORTED, "QuadrilateralsQ2 are not supported");
  expect_error("p5.mesh", "Dimension 3\nHexahedraQ2 1 1 2 3 4 5 6 7 8 9 10 "
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
  CHECK(strstr(note, "skipped the keywords padapt does not use: "
                     "ParallelTriangles, ParallelVertices, Normals, "
                     "NormalAtVertices, Tangents, TangentAtVertices\n") !=
        NULL);
  pa_mesh_destroy(m);
  remove("mmg.mesh");
}

/* ---- binary ---- */

typedef struct bbuf {
  unsigned char b[2048];
  size_t n;
} bbuf;

static void put_bytes(bbuf *b, const void *p, size_t n) {
  memcpy(b->b + b->n, p, n);
  b->n += n;
}
static void put_i32(bbuf *b, int32_t v) { put_bytes(b, &v, 4); }
static void put_f64(bbuf *b, double v) { put_bytes(b, &v, 8); }

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
  CHECK(same_mesh(m, ref));
  pa_mesh_destroy(m);
  m = NULL;

  build_square_meshb(&b, 1, 0);
  write_file("sq.meshb", b.b, b.n);
  CHECK_OK(read_noted("sq.meshb", &m, note, sizeof note));
  CHECK(same_mesh(m, ref));
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

TEST_MAIN(test_freefem, test_freefem_sol, test_unknown_ascii,
          test_still_strict, test_high_order, test_mmg, test_unknown_binary)
