/*
 * test_vtu.c -- the VTK XML (.vtu) writer, checked by an independent minimal
 * parser: counts in the header, every DataArray's appended block (size prefix,
 * contiguous tiling of the appended section) and its bytes (points,
 * connectivity, offsets, types of the element, boundary and edge cells,
 * references, entity kinds, quality, the metric and size tensors, fields), XML
 * escaping of field names, atomic writes.
 */
#include "testutil.h"

#include <unistd.h>

typedef struct vtu_file {
  unsigned char *buf;
  size_t len;
  size_t base;     /* offset of the first byte after '_' */
  size_t data_end; /* offset of "\n  </AppendedData>" */
} vtu_file;

static int load(const char *path, vtu_file *f) {
  memset(f, 0, sizeof *f);
  FILE *fp = fopen(path, "rb");
  if (!fp) return 0;
  fseek(fp, 0, SEEK_END);
  f->len = (size_t)ftell(fp);
  rewind(fp);
  f->buf = malloc(f->len + 1);
  if (fread(f->buf, 1, f->len, fp) != f->len) f->len = 0;
  fclose(fp);
  f->buf[f->len] = 0;
  const char *tag = "<AppendedData encoding=\"raw\">";
  char *a = strstr((char *)f->buf, tag);
  if (!a) return 0;
  char *u = strchr(a + strlen(tag), '_');
  if (!u) return 0;
  f->base = (size_t)(u + 1 - (char *)f->buf);
  const char *end = "\n  </AppendedData>\n</VTKFile>\n";
  size_t n = strlen(end);
  if (f->len < f->base + n || memcmp(f->buf + f->len - n, end, n)) return 0;
  f->data_end = f->len - n;
  return 1;
}

/* Integer value of attribute `attr` inside the XML text [s, e). */
static long long attr_int(const char *s, const char *e, const char *attr) {
  char key[64];
  snprintf(key, sizeof key, " %s=\"", attr);
  const char *p = strstr(s, key);
  if (!p || p >= e) return -1;
  return atoll(p + strlen(key));
}

/* Whether attribute `attr` of [s, e) has value `val`. */
static int attr_is(const char *s, const char *e, const char *attr,
                   const char *val) {
  char key[128];
  snprintf(key, sizeof key, " %s=\"%s\"", attr, val);
  const char *p = strstr(s, key);
  return p && p < e;
}

/* The DataArray named `name` (NULL: the one without Name) inside section
 * `sect` ("PointData", "CellData", "Points", "Cells"): its appended bytes,
 * after checking the type, component count and block size prefix. */
static const unsigned char *array(const vtu_file *f, const char *sect,
                                  const char *name, const char *type, int ncomp,
                                  size_t nbytes) {
  char open[64], close[64];
  snprintf(open, sizeof open, "<%s", sect); /* then '>' or attributes */
  snprintf(close, sizeof close, "</%s>", sect);
  const char *s = (const char *)f->buf;
  while ((s = strstr(s, open)) && s[strlen(open)] != '>' && s[strlen(open)] != ' ')
    s++;
  const char *e = s ? strstr(s, close) : NULL;
  if (!s || !e) return NULL;
  for (const char *d = strstr(s, "<DataArray"); d && d < e;
       d = strstr(d + 1, "<DataArray")) {
    const char *de = strstr(d, "/>");
    const char *np = strstr(d, " Name=\"");
    int has_name = np && np < de;
    if (name ? !attr_is(d, de, "Name", name) : has_name) continue;
    if (!attr_is(d, de, "type", type)) return NULL;
    if (!attr_is(d, de, "format", "appended")) return NULL;
    long long nc = attr_int(d, de, "NumberOfComponents");
    if ((nc == -1 ? 1 : nc) != ncomp) return NULL;
    long long off = attr_int(d, de, "offset");
    if (off < 0 || f->base + (size_t)off + 8 > f->data_end) return NULL;
    uint64_t size;
    memcpy(&size, f->buf + f->base + off, 8);
    if (size != nbytes || f->base + off + 8 + size > f->data_end) return NULL;
    return f->buf + f->base + off + 8;
  }
  return NULL;
}

/* The appended blocks tile [base, data_end) exactly, in offset order. */
static int tiled(const vtu_file *f) {
  size_t at = 0, nblock = 0;
  while (f->base + at < f->data_end) {
    char key[64];
    snprintf(key, sizeof key, "offset=\"%zu\"", at);
    if (!strstr((const char *)f->buf, key)) return 0;
    uint64_t size;
    if (f->base + at + 8 > f->data_end) return 0;
    memcpy(&size, f->buf + f->base + at, 8);
    at += 8 + size;
    nblock++;
  }
  return f->base + at == f->data_end && nblock > 0;
}

static void check_file(pa_mesh *m, const char *path) {
  vtu_file f;
  CHECK(load(path, &f));
  if (!f.buf || !f.base) {
    free(f.buf);
    return;
  }
  int d = pa_mesh_dim(m), nn = d + 1;
  size_t nv = (size_t)pa_mesh_nvert(m), ne = (size_t)pa_mesh_nelem(m);
  const char *hdr = (const char *)f.buf;
  const char *hend = strstr(hdr, "<AppendedData");
  CHECK(!strncmp(
      hdr, "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\"", 54));
  CHECK(attr_is(hdr, hend, "header_type", "UInt64"));
  CHECK(attr_is(hdr, hend, "byte_order", "LittleEndian"));
  CHECK(attr_int(hdr, hend, "NumberOfPoints") == (long long)nv);
  size_t nb = (size_t)pa_mesh_nbdry(m), ned = d == 3 ? (size_t)pa_mesh_nedge(m) : 0;
  size_t nc = ne + nb + ned; /* elements, boundary entities, feature edges */
  size_t width[3] = {(size_t)nn, (size_t)d, 2}, count[3] = {ne, nb, ned};
  const pa_idx *conn[3] = {pa_mesh_elems(m), pa_mesh_bdrys(m), pa_mesh_edges(m)};
  const int32_t *refs[3] = {pa_mesh_elem_refs(m), pa_mesh_bdry_refs(m),
                            pa_mesh_edge_refs(m)};
  uint8_t type[3] = {d == 2 ? 5 : 10, d == 2 ? 3 : 5, 3};
  size_t nconn = nn * ne + d * nb + 2 * ned;
  CHECK(attr_int(hdr, hend, "NumberOfCells") == (long long)nc);
  CHECK(tiled(&f));

  const unsigned char *p = array(&f, "Points", NULL, "Float64", 3, 24 * nv);
  CHECK(p != NULL);
  int ok = p != NULL;
  for (size_t i = 0; p && i < nv; i++)
    for (int k = 0; k < 3; k++) {
      double x;
      memcpy(&x, p + 8 * (3 * i + k), 8);
      double want = k < d ? pa_mesh_coords(m)[d * i + k] : 0.0;
      if (memcmp(&x, &want, 8)) ok = 0;
    }
  CHECK(ok);

  /* cells of the three kinds in turn, with their refs and entity kinds */
  const unsigned char *pc = array(&f, "Cells", "connectivity", "Int64", 1, 8 * nconn);
  const unsigned char *po = array(&f, "Cells", "offsets", "Int64", 1, 8 * nc);
  const unsigned char *pt = array(&f, "Cells", "types", "UInt8", 1, nc);
  const unsigned char *pr = array(&f, "CellData", "ref", "Int32", 1, 4 * nc);
  const unsigned char *pe = array(&f, "CellData", "entity", "UInt8", 1, nc);
  const unsigned char *pq = array(&f, "CellData", "quality", "Float64", 1, 8 * nc);
  CHECK(pc && po && pt && pr && pe && pq);
  ok = pc && po && pt && pr && pe && pq;
  size_t cell = 0, at = 0;
  for (int kind = 0; ok && kind < 3; kind++)
    for (size_t i = 0; i < count[kind]; i++, cell++) {
      for (size_t j = 0; j < width[kind]; j++, at++) {
        int64_t v;
        memcpy(&v, pc + 8 * at, 8);
        if (v != conn[kind][width[kind] * i + j]) ok = 0;
      }
      int64_t off;
      int32_t r;
      double q;
      memcpy(&off, po + 8 * cell, 8);
      memcpy(&r, pr + 4 * cell, 4);
      memcpy(&q, pq + 8 * cell, 8);
      if (off != (int64_t)at || pt[cell] != type[kind] || pe[cell] != kind ||
          r != refs[kind][i])
        ok = 0;
      if (kind == 0) {
        double want = pa_mesh_elem_quality(m, (pa_idx)i);
        if (memcmp(&q, &want, 8)) ok = 0;
      } else if (!isnan(q)) {
        ok = 0;
      }
    }
  CHECK(ok);
  p = array(&f, "PointData", "ref", "Int32", 1, 4 * nv);
  CHECK(p && (!nv || !memcmp(p, pa_mesh_vert_refs(m), 4 * nv)));

  /* the metric as a 3 x 3 tensor, and the size tensor S with S M S = I */
  int mc = pa_mesh_metric_ncomp(m);
  const unsigned char *pm = array(&f, "PointData", "metric", "Float64", 9, 72 * nv);
  const unsigned char *ps = array(&f, "PointData", "size", "Float64", 9, 72 * nv);
  CHECK(mc ? pm && ps : !pm && !ps);
  ok = 1;
  for (size_t v = 0; mc && pm && ps && v < nv; v++) {
    double M[9], S[9], full[9] = {0};
    const double *mv = pa_mesh_metric(m) + (size_t)mc * v;
    memcpy(M, pm + 72 * v, 72);
    memcpy(S, ps + 72 * v, 72);
    if (mc == 1) {
      for (int k = 0; k < d; k++) full[4 * k] = 1 / (mv[0] * mv[0]);
    } else {
      full[0] = mv[0], full[1] = full[3] = mv[1], full[4] = mv[2];
      if (d == 3)
        full[2] = full[6] = mv[3], full[5] = full[7] = mv[4], full[8] = mv[5];
    }
    if (memcmp(M, full, 72)) ok = 0;
    for (int i = 0; i < d; i++)
      for (int j = 0; j < d; j++) {
        double sms = 0;
        for (int k = 0; k < d; k++)
          for (int l = 0; l < d; l++) sms += S[3 * i + k] * M[3 * k + l] * S[3 * l + j];
        if (fabs(sms - (i == j)) > 1e-9) ok = 0;
      }
  }
  CHECK(ok);
  for (int k = 0; k < pa_mesh_nfield(m); k++) {
    const char *name;
    int nc;
    double *val;
    pa_mesh_field(m, k, &name, &nc, &val);
    char esc[128] = "";
    for (const char *c = name; *c; c++) /* the test names use '&' only */
      strcat(esc, *c == '&' ? "&amp;" : (char[]){*c, 0});
    p = array(&f, "PointData", esc, "Float64", nc, 8 * nc * nv);
    CHECK(p && !memcmp(p, val, 8 * nc * nv));
  }
  free(f.buf);
}

static void test_vtu_2d(void) {
  pa_mesh *m = NULL;
  CHECK_OK(pa_mesh_create(2, &m));
  double x[5][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}, {0.4, 0.6}};
  for (int i = 0; i < 5; i++)
    CHECK_OK(pa_mesh_add_vertex(m, x[i], i, NULL));
  pa_idx t[4][3] = {{0, 1, 4}, {1, 2, 4}, {2, 3, 4}, {3, 0, 4}};
  for (int e = 0; e < 4; e++)
    CHECK_OK(pa_mesh_add_elem(m, t[e], 10 + e, NULL));
  pa_idx b[2] = {0, 1};
  CHECK_OK(pa_mesh_add_bdry(m, b, 3, NULL));
  double met[15], u[10];
  for (int i = 0; i < 5; i++) {
    met[3 * i] = 4 + i;
    met[3 * i + 1] = 0.5;
    met[3 * i + 2] = 9;
    u[2 * i] = i;
    u[2 * i + 1] = -i;
  }
  CHECK_OK(pa_mesh_set_metric(m, 3, met));
  CHECK_OK(pa_mesh_add_field(m, "u&v", 2, u));
  CHECK_OK(pa_mesh_write(m, "square.vtu", NULL));
  check_file(m, "square.vtu");
  pa_mesh_destroy(m);
}

static void test_vtu_3d(void) {
  pa_mesh *m = NULL;
  CHECK_OK(pa_mesh_create(3, &m));
  pa_test_seed(3);
  for (int i = 0; i < 40; i++) {
    double x[3] = {pa_test_rand(), pa_test_rand(), pa_test_rand()};
    CHECK_OK(pa_mesh_add_vertex(m, x, -i, NULL));
  }
  for (int e = 0; e < 30; e++) {
    pa_idx v[4] = {e, e + 1, e + 5, e + 9};
    CHECK_OK(pa_mesh_add_elem(m, v, e % 4, NULL));
  }
  double h[40], s[40];
  for (int i = 0; i < 40; i++) {
    h[i] = 0.1 + 0.01 * i;
    s[i] = i * 0.5;
  }
  CHECK_OK(pa_mesh_set_metric(m, 1, h));
  CHECK_OK(pa_mesh_add_field(m, "pressure", 1, s));
  CHECK_OK(pa_mesh_write(m, "cube.vtu", NULL));
  check_file(m, "cube.vtu");
  /* No metric, no field, no element. */
  CHECK_OK(pa_mesh_set_metric(m, 0, NULL));
  pa_mesh *e = NULL;
  CHECK_OK(pa_mesh_create(3, &e));
  CHECK_OK(pa_mesh_write(e, "empty.vtu", NULL));
  check_file(e, "empty.vtu");
  pa_mesh_destroy(e);
  pa_mesh_destroy(m);
}

/* A failed write leaves no file, and allocation failures are reported. */
static void test_vtu_failures(void) {
  pa_mesh *m = NULL;
  CHECK_OK(pa_mesh_create(2, &m));
  double x[3][2] = {{0, 0}, {1, 0}, {0, 1}};
  for (int i = 0; i < 3; i++)
    CHECK_OK(pa_mesh_add_vertex(m, x[i], 0, NULL));
  pa_idx t[3] = {0, 1, 2};
  CHECK_OK(pa_mesh_add_elem(m, t, 1, NULL));
  CHECK(pa_mesh_write(m, "no_such_dir/a.vtu", NULL) == PA_ERR_IO);
  int nok = 0, nbad = 0;
  for (long k = 1; k < 20; k++) {
    remove("fail.vtu");
    pa_memory_fail_after(k);
    pa_status st = pa_mesh_write(m, "fail.vtu", NULL);
    pa_memory_fail_after(0);
    int exists = access("fail.vtu", F_OK) == 0;
    if (st == PA_SUCCESS)
      nok += exists;
    else if (st != PA_ERR_MEMORY || exists)
      nbad++;
  }
  CHECK(nok > 0 && nbad == 0);
  check_file(m, "fail.vtu");
  pa_mesh_destroy(m);
}

TEST_MAIN(test_vtu_2d, test_vtu_3d, test_vtu_failures)
