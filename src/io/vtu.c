/*
 * vtu.c -- VTK XML unstructured grid (.vtu) writer, for visualisation in
 * ParaView/VisIt (there is no .vtu reader).
 *
 * Layout: one Piece; every array is "appended" raw binary (encoding="raw",
 * header_type="UInt64": each block is its byte count as a UInt64 followed by
 * the bytes), in the host's byte order, which the header declares.
 *  - Points: Float64, 3 components (z = 0 in 2D).
 *  - Cells: the elements (triangles, VTK type 5; tetrahedra, type 10), then
 *    the boundary entities (2D edges, type 3; 3D triangles, type 5), then
 *    the feature edges (type 3). connectivity and offsets Int64, types UInt8.
 *  - PointData: "metric" (when the mesh has one) as a full 3 x 3 tensor in
 *    VTK's order (xx xy xz yx yy yz zx zy zz; a size h is I/h^2; zeros in
 *    the third row and column in 2D), and "size", the tensor M^(-1/2) whose
 *    ellipsoid (ParaView's Tensor Glyph) is the unit ball of the metric:
 *    its axes are the sizes asked for along its principal directions; every
 *    user field under its own name and component count; "ref" (Int32) the
 *    vertex references.
 *  - CellData: every element and boundary field under its own name and
 *    component count (Float64; NaN on the cells it is not on; an element
 *    and a boundary field of one name and size share one array); "ref"
 *    (Int32) the references of every cell; "entity" (UInt8)
 *    0 element, 1 boundary entity, 2 feature edge (ParaView's Threshold
 *    selects one kind); "quality" (Float64, pa_mesh_elem_quality; NaN on
 *    boundary entities and edges); with opts->diagnostics, "edge_min" and
 *    "edge_max", the shortest and longest edge of each element in its
 *    metric (NaN on the other cells, and everywhere without a metric).
 *  - A distributed set's rank file adds (pa__vtu_extra) the point data
 *    "gid" (declared GlobalIds) and "vtkGhostType" (1 on the vertices
 *    another rank owns), and the cell data "rank" and "gid".
 * The appended section ends with a newline before </AppendedData>. The file
 * is written through a temporary file (output.c), so a failure leaves none.
 */
#include "io/output.h"
#include "io/vtu.h"

#include "metric/metric.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>

/* One appended array: what goes in the XML header and how big it is. */
typedef struct vtu_array {
  const char *name; /* NULL: no Name attribute */
  const char *type; /* VTK type name */
  int ncomp;
  const char *const *compname; /* ncomp names or NULL */
  uint64_t nbytes;
  uint64_t offset;
} vtu_array;

/* Write s with XML's special characters escaped (&amp; &lt; &gt; &quot;)
 * and control characters as '?' (not allowed in XML 1.0). */
static void xml_escape(FILE *fp, const char *s) {
  for (; *s; s++) {
    switch (*s) {
    case '&':
      fputs("&amp;", fp);
      break;
    case '<':
      fputs("&lt;", fp);
      break;
    case '>':
      fputs("&gt;", fp);
      break;
    case '"':
      fputs("&quot;", fp);
      break;
    default: /* control characters are not allowed in XML 1.0 */
      fputc((unsigned char)*s < 0x20 ? '?' : *s, fp);
    }
  }
}

static void put_array(FILE *fp, const vtu_array *a) {
  fprintf(fp, "        <DataArray type=\"%s\"", a->type);
  if (a->name) {
    fputs(" Name=\"", fp);
    xml_escape(fp, a->name);
    fputc('"', fp);
  }
  if (a->ncomp > 1) fprintf(fp, " NumberOfComponents=\"%d\"", a->ncomp);
  if (a->compname)
    for (int k = 0; k < a->ncomp; k++)
      fprintf(fp, " ComponentName%d=\"%s\"", k, a->compname[k]);
  fprintf(fp, " format=\"appended\" offset=\"%llu\"/>\n",
          (unsigned long long)a->offset);
}

/* Write one appended block: its UInt64 size, then the bytes. */
static void put_block(FILE *fp, const void *data, uint64_t nbytes) {
  fwrite(&nbytes, sizeof nbytes, 1, fp);
  if (nbytes) fwrite(data, 1, (size_t)nbytes, fp);
}

/* Entities converted per chunk when an array needs converting (write errors
 * are sticky on the FILE and caught by pa__out_commit). */
#define VTU_CHUNK 8192

/* The 3 x 3 metric tensor (sq 0) or M^(-1/2) (sq 1) of a metric value of nc
 * components, in VTK's row-major order. */
static void tensor9(int dim, int nc, const double *m, int sq, double *t) {
  double lam[3], vec[9], full[6];
  memset(t, 0, 9 * sizeof *t);
  if (nc == 1) {
    double v = sq ? m[0] : 1.0 / (m[0] * m[0]);
    for (int k = 0; k < dim; k++) t[4 * k] = v;
    return;
  }
  if (!sq) {
    /* Medit order m11 m12 m22 [m13 m23 m33] */
    t[0] = m[0], t[1] = t[3] = m[1], t[4] = m[2];
    if (dim == 3) t[2] = t[6] = m[3], t[5] = t[7] = m[4], t[8] = m[5];
    return;
  }
  pa__sym_eigen(dim, m, lam, vec);
  for (int k = 0; k < dim; k++) lam[k] = lam[k] > 0 ? 1.0 / sqrt(lam[k]) : 0;
  pa__sym_from_eigen(dim, lam, vec, full);
  double *u = full;
  t[0] = u[0], t[1] = t[3] = u[1], t[4] = u[2];
  if (dim == 3) t[2] = t[6] = u[3], t[5] = t[7] = u[4], t[8] = u[5];
}

/* Shortest and longest edge of element e in the mesh's metric. */
static void edge_range(const pa_mesh *m, pa_idx e, double *lo, double *hi) {
  int nn = m->dim + 1, nc = m->met_ncomp;
  const pa_idx *v = m->elem + (size_t)nn * e;
  *lo = HUGE_VAL;
  *hi = 0;
  for (int i = 0; i < nn; i++)
    for (int j = i + 1; j < nn; j++) {
      double l = pa__edge_length(m->dim, nc, m->coord + (size_t)m->dim * v[i],
                                 m->coord + (size_t)m->dim * v[j],
                                 m->met + (size_t)nc * v[i],
                                 m->met + (size_t)nc * v[j]);
      if (l < *lo) *lo = l;
      if (l > *hi) *hi = l;
    }
}

/* The appended arrays, by the index of each in vtu_layout.arr; the user
 * fields follow A_FIELD. */
enum {
  A_MET,
  A_SIZE,
  A_VREF,
  A_REF,
  A_ENT,
  A_QUAL,
  A_LMIN,
  A_LMAX,
  A_PTS,
  A_CONN,
  A_OFFS,
  A_TYPES,
  A_VGID,
  A_VGHOST,
  A_RANK,
  A_CGID,
  A_FIELD
};

/* The file's arrays and the order of their blocks: order[0, npoint) the
 * point data, the next ncelld the cell data, then points and cells. */
typedef struct vtu_layout {
  vtu_array arr[A_FIELD + 3 * PA_MESH_MAX_FIELDS];
  int order[A_FIELD + 3 * PA_MESH_MAX_FIELDS];
  /* cell array j (A_FIELD + PA_MESH_MAX_FIELDS + j): its element field
   * and boundary field (-1 for none) */
  int cfield[2 * PA_MESH_MAX_FIELDS][2];
  int ncfield;
  int no, npoint, ncelld;
  uint64_t nv, ne, nb, nd, ncell; /* nd: feature edges, 0 in 2D */
  int diag;
} vtu_layout;

/* Declare every array of mesh m (x: a rank file's extras, or NULL) and give
 * each its offset in the appended section. */
static void layout_arrays(const pa_mesh *m, int diag, const pa__vtu_extra *x,
                          vtu_layout *lay) {
  vtu_array *arr = lay->arr;
  int *order = lay->order;
  int dim = m->dim, nn = dim + 1;
  uint64_t nv = (uint64_t)m->nv, ne = (uint64_t)m->ne;
  uint64_t nb = (uint64_t)m->nb, nd = dim == 3 ? (uint64_t)m->ned : 0;
  uint64_t ncell = ne + nb + nd;
  uint64_t nconn = ne * (uint64_t)nn + nb * (uint64_t)dim + nd * 2;
  lay->nv = nv, lay->ne = ne, lay->nb = nb, lay->nd = nd, lay->ncell = ncell;
  lay->diag = diag;

  memset(arr, 0, sizeof lay->arr);
  arr[A_MET] = (vtu_array){"metric", "Float64", 9, NULL, 72 * nv, 0};
  arr[A_SIZE] = (vtu_array){"size", "Float64", 9, NULL, 72 * nv, 0};
  arr[A_VREF] = (vtu_array){"ref", "Int32", 1, NULL, 4 * nv, 0};
  arr[A_REF] = (vtu_array){"ref", "Int32", 1, NULL, 4 * ncell, 0};
  arr[A_ENT] = (vtu_array){"entity", "UInt8", 1, NULL, ncell, 0};
  arr[A_QUAL] = (vtu_array){"quality", "Float64", 1, NULL, 8 * ncell, 0};
  arr[A_LMIN] = (vtu_array){"edge_min", "Float64", 1, NULL, 8 * ncell, 0};
  arr[A_LMAX] = (vtu_array){"edge_max", "Float64", 1, NULL, 8 * ncell, 0};
  arr[A_PTS] = (vtu_array){NULL, "Float64", 3, NULL, 24 * nv, 0};
  arr[A_CONN] = (vtu_array){"connectivity", "Int64", 1, NULL, 8 * nconn, 0};
  arr[A_OFFS] = (vtu_array){"offsets", "Int64", 1, NULL, 8 * ncell, 0};
  arr[A_TYPES] = (vtu_array){"types", "UInt8", 1, NULL, ncell, 0};
  arr[A_VGID] = (vtu_array){"gid", "Int64", 1, NULL, 8 * nv, 0};
  arr[A_VGHOST] = (vtu_array){"vtkGhostType", "UInt8", 1, NULL, nv, 0};
  arr[A_RANK] = (vtu_array){"rank", "Int32", 1, NULL, 4 * ncell, 0};
  arr[A_CGID] = (vtu_array){"gid", "Int64", 1, NULL, 8 * ncell, 0};
  for (int k = 0; k < m->nfield; k++)
    arr[A_FIELD + k] = (vtu_array){m->field[k].name,
                                   "Float64",
                                   m->field[k].ncomp,
                                   NULL,
                                   8 * nv * (uint64_t)m->field[k].ncomp,
                                   0};
  /* element and boundary fields: one array per name and size */
  lay->ncfield = 0;
  for (int k = 0; k < m->nefield; k++) {
    int j = lay->ncfield++;
    lay->cfield[j][0] = k;
    lay->cfield[j][1] = -1;
    for (int b = 0; b < m->nbfield && lay->cfield[j][1] < 0; b++)
      if (!strcmp(m->bfield[b].name, m->efield[k].name) &&
          m->bfield[b].ncomp == m->efield[k].ncomp)
        lay->cfield[j][1] = b;
  }
  for (int b = 0; b < m->nbfield; b++) {
    int taken = 0;
    for (int j = 0; j < lay->ncfield; j++) taken |= lay->cfield[j][1] == b;
    if (taken) continue;
    int j = lay->ncfield++;
    lay->cfield[j][0] = -1;
    lay->cfield[j][1] = b;
  }
  for (int j = 0; j < lay->ncfield; j++) {
    const pa__field *f = lay->cfield[j][0] >= 0 ? &m->efield[lay->cfield[j][0]]
                                                : &m->bfield[lay->cfield[j][1]];
    arr[A_FIELD + PA_MESH_MAX_FIELDS + j] =
        (vtu_array){f->name, "Float64", f->ncomp, NULL,
                    8 * ncell * (uint64_t)f->ncomp, 0};
  }
  /* Appended order: point data, cell data, points, cells. */
  int no = 0;
  if (m->met_ncomp) order[no++] = A_MET, order[no++] = A_SIZE;
  for (int k = 0; k < m->nfield; k++) order[no++] = A_FIELD + k;
  order[no++] = A_VREF;
  if (x && x->vgid) order[no++] = A_VGID;
  if (x && x->vghost) order[no++] = A_VGHOST;
  lay->npoint = no;
  for (int j = 0; j < lay->ncfield; j++) order[no++] = A_FIELD + PA_MESH_MAX_FIELDS + j;
  order[no++] = A_REF;
  order[no++] = A_ENT;
  order[no++] = A_QUAL;
  if (diag) order[no++] = A_LMIN, order[no++] = A_LMAX;
  if (x) order[no++] = A_RANK;
  if (x && x->cgid) order[no++] = A_CGID;
  lay->ncelld = no - lay->npoint;
  order[no++] = A_PTS;
  order[no++] = A_CONN;
  order[no++] = A_OFFS;
  order[no++] = A_TYPES;
  lay->no = no;
  uint64_t off = 0;
  for (int i = 0; i < no; i++) {
    arr[order[i]].offset = off;
    off += 8 + arr[order[i]].nbytes;
  }
}

/* The XML part: every DataArray with its offset, up to the opening of the
 * appended data. */
static void write_header(FILE *fp, const pa_mesh *m, const pa__vtu_extra *x,
                         const vtu_layout *lay) {
  const vtu_array *arr = lay->arr;
  const int *order = lay->order;
  int npoint = lay->npoint, ncelld = lay->ncelld;
  const uint16_t probe = 1;
  int little = *(const uint8_t *)&probe == 1;
  fprintf(fp,
          "<?xml version=\"1.0\"?>\n"
          "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" "
          "byte_order=\"%s\" header_type=\"UInt64\">\n"
          "  <UnstructuredGrid>\n"
          "    <Piece NumberOfPoints=\"%llu\" NumberOfCells=\"%llu\">\n",
          little ? "LittleEndian" : "BigEndian", (unsigned long long)lay->nv,
          (unsigned long long)lay->ncell);
  fprintf(fp, "      <PointData%s%s>\n",
          m->met_ncomp ? " Tensors=\"size\"" : "",
          x && x->vgid ? " GlobalIds=\"gid\"" : "");
  for (int i = 0; i < npoint; i++) put_array(fp, &arr[order[i]]);
  fputs("      </PointData>\n      <CellData Scalars=\"quality\">\n", fp);
  for (int i = npoint; i < npoint + ncelld; i++) put_array(fp, &arr[order[i]]);
  fputs("      </CellData>\n      <Points>\n", fp);
  put_array(fp, &arr[A_PTS]);
  fputs("      </Points>\n      <Cells>\n", fp);
  put_array(fp, &arr[A_CONN]);
  put_array(fp, &arr[A_OFFS]);
  put_array(fp, &arr[A_TYPES]);
  fputs("      </Cells>\n    </Piece>\n  </UnstructuredGrid>\n"
        "  <AppendedData encoding=\"raw\">\n   _",
        fp);
}

/* The point data blocks: metric and size tensors, user fields, references,
 * then a rank file's gid and vtkGhostType (f64: 9 VTU_CHUNK doubles). */
static void write_point_data(FILE *fp, const pa_mesh *m,
                             const pa__vtu_extra *x, const vtu_layout *lay,
                             double *f64) {
  const vtu_array *arr = lay->arr;
  int dim = m->dim, nc = m->met_ncomp;
  uint64_t nv = lay->nv;
  for (int sq = 0; sq < 2 && nc; sq++) {
    fwrite(&arr[sq ? A_SIZE : A_MET].nbytes, 8, 1, fp);
    for (uint64_t v0 = 0; v0 < nv; v0 += VTU_CHUNK) {
      size_t n = (size_t)(nv - v0 < VTU_CHUNK ? nv - v0 : VTU_CHUNK);
      for (size_t v = 0; v < n; v++)
        tensor9(dim, nc, m->met + (size_t)nc * (v0 + v), sq, f64 + 9 * v);
      fwrite(f64, sizeof *f64, 9 * n, fp);
    }
  }
  for (int k = 0; k < m->nfield; k++)
    put_block(fp, m->field[k].val, arr[A_FIELD + k].nbytes);
  put_block(fp, m->vref, arr[A_VREF].nbytes);
  if (x && x->vgid) put_block(fp, x->vgid, arr[A_VGID].nbytes);
  if (x && x->vghost) put_block(fp, x->vghost, arr[A_VGHOST].nbytes);
}

/* The blocks "quality", then with diagnostics "edge_min" and "edge_max":
 * element values, NaN on the boundary entities and edges. */
static void write_quality(FILE *fp, pa_mesh *m, const vtu_layout *lay,
                          double *f64) {
  int nc = m->met_ncomp;
  uint64_t ne = lay->ne, nb = lay->nb, nd = lay->nd;
  for (int a = 0; a < (lay->diag ? 3 : 1); a++) {
    fwrite(&lay->arr[A_QUAL].nbytes, 8, 1, fp);
    for (uint64_t e0 = 0; e0 < ne; e0 += VTU_CHUNK) {
      size_t n = (size_t)(ne - e0 < VTU_CHUNK ? ne - e0 : VTU_CHUNK);
      for (size_t e = 0; e < n; e++) {
        double lo = NAN, hi = NAN;
        if (a == 0)
          f64[e] = pa_mesh_elem_quality(m, (pa_idx)(e0 + e));
        else if (nc)
          edge_range(m, (pa_idx)(e0 + e), &lo, &hi), f64[e] = a == 1 ? lo : hi;
        else
          f64[e] = NAN;
      }
      fwrite(f64, sizeof *f64, n, fp);
    }
    for (size_t k = 0; k < VTU_CHUNK; k++) f64[k] = NAN;
    for (uint64_t c = 0; c < nb + nd; c += VTU_CHUNK)
      fwrite(f64, sizeof *f64,
             (size_t)(nb + nd - c < VTU_CHUNK ? nb + nd - c : VTU_CHUNK), fp);
  }
}

/* The values of field f (NULL: NaN) on n cells, as a part of a block
 * (f64: 9 VTU_CHUNK doubles). */
static void put_cell_values(FILE *fp, const pa__field *f, int nc, uint64_t n,
                            double *f64) {
  if (f) {
    if (n) fwrite(f->val, sizeof(double) * (size_t)nc, (size_t)n, fp);
    return;
  }
  for (size_t k = 0; k < 9 * VTU_CHUNK; k++) f64[k] = NAN;
  uint64_t per = 9 * VTU_CHUNK / (uint64_t)nc;
  for (uint64_t c = 0; c < n; c += per)
    fwrite(f64, sizeof(double) * (size_t)nc, (size_t)(n - c < per ? n - c : per), fp);
}

/* The cell data blocks: element and boundary fields, references, entity
 * kinds, quality (and diagnostics), then a rank file's rank and gid (u8:
 * VTU_CHUNK bytes). */
static void write_cell_data(FILE *fp, pa_mesh *m, const pa__vtu_extra *x,
                            const vtu_layout *lay, double *f64, uint8_t *u8) {
  const vtu_array *arr = lay->arr;
  uint64_t ne = lay->ne, nb = lay->nb, nd = lay->nd, ncell = lay->ncell;
  for (int j = 0; j < lay->ncfield; j++) {
    const vtu_array *a = &arr[A_FIELD + PA_MESH_MAX_FIELDS + j];
    int ke = lay->cfield[j][0], kb = lay->cfield[j][1];
    fwrite(&a->nbytes, 8, 1, fp);
    put_cell_values(fp, ke >= 0 ? &m->efield[ke] : NULL, a->ncomp, ne, f64);
    put_cell_values(fp, kb >= 0 ? &m->bfield[kb] : NULL, a->ncomp, nb, f64);
    put_cell_values(fp, NULL, a->ncomp, nd, f64);
  }
  fwrite(&arr[A_REF].nbytes, 8, 1, fp);
  if (ne) fwrite(m->eref, 4, (size_t)ne, fp);
  if (nb) fwrite(m->bref, 4, (size_t)nb, fp);
  if (nd) fwrite(m->edref, 4, (size_t)nd, fp);
  fwrite(&arr[A_ENT].nbytes, 8, 1, fp);
  for (int kind = 0; kind < 3; kind++) {
    uint64_t n = kind == 0 ? ne : kind == 1 ? nb : nd;
    memset(u8, kind, VTU_CHUNK);
    for (uint64_t c = 0; c < n; c += VTU_CHUNK)
      fwrite(u8, 1, (size_t)(n - c < VTU_CHUNK ? n - c : VTU_CHUNK), fp);
  }
  write_quality(fp, m, lay, f64);
  if (x) {
    fwrite(&arr[A_RANK].nbytes, 8, 1, fp);
    int32_t rk[VTU_CHUNK];
    for (size_t i = 0; i < VTU_CHUNK; i++) rk[i] = x->rank;
    for (uint64_t c = 0; c < ncell; c += VTU_CHUNK)
      fwrite(rk, 4, (size_t)(ncell - c < VTU_CHUNK ? ncell - c : VTU_CHUNK), fp);
  }
  if (x && x->cgid) put_block(fp, x->cgid, arr[A_CGID].nbytes);
}

/* The points block, 3 coordinates each (z = 0 in 2D). */
static void write_points(FILE *fp, const pa_mesh *m, const vtu_layout *lay,
                         double *f64) {
  uint64_t nv = lay->nv;
  if (m->dim == 3) {
    put_block(fp, m->coord, lay->arr[A_PTS].nbytes);
    return;
  }
  fwrite(&lay->arr[A_PTS].nbytes, 8, 1, fp);
  for (uint64_t v0 = 0; v0 < nv; v0 += VTU_CHUNK) {
    size_t n = (size_t)(nv - v0 < VTU_CHUNK ? nv - v0 : VTU_CHUNK);
    for (size_t v = 0; v < n; v++) {
      f64[3 * v] = m->coord[2 * (v0 + v)];
      f64[3 * v + 1] = m->coord[2 * (v0 + v) + 1];
      f64[3 * v + 2] = 0.0;
    }
    fwrite(f64, sizeof *f64, 3 * n, fp);
  }
}

/* Connectivity, offsets and types of the three kinds of cells (i64: 4
 * VTU_CHUNK integers, u8: VTU_CHUNK bytes). */
static void write_cells(FILE *fp, const pa_mesh *m, const vtu_layout *lay,
                        int64_t *i64, uint8_t *u8) {
  const vtu_array *arr = lay->arr;
  int dim = m->dim, nn = dim + 1;
  const pa_idx *src[3] = {m->elem, m->bdry, m->edge};
  int width[3] = {nn, dim, 2};
  uint8_t type[3] = {dim == 2 ? 5 : 10, dim == 2 ? 3 : 5, 3};
  uint64_t count[3] = {lay->ne, lay->nb, lay->nd}, end = 0;
  fwrite(&arr[A_CONN].nbytes, 8, 1, fp);
  for (int kind = 0; kind < 3; kind++)
    for (uint64_t c0 = 0; c0 < count[kind]; c0 += VTU_CHUNK) {
      size_t n = (size_t)(count[kind] - c0 < VTU_CHUNK ? count[kind] - c0
                                                       : VTU_CHUNK);
      size_t w = (size_t)width[kind];
      for (size_t k = 0; k < n * w; k++) i64[k] = src[kind][w * c0 + k];
      fwrite(i64, sizeof *i64, n * w, fp);
    }
  fwrite(&arr[A_OFFS].nbytes, 8, 1, fp);
  for (int kind = 0; kind < 3; kind++)
    for (uint64_t c0 = 0; c0 < count[kind]; c0 += VTU_CHUNK) {
      size_t n = (size_t)(count[kind] - c0 < VTU_CHUNK ? count[kind] - c0
                                                       : VTU_CHUNK);
      for (size_t c = 0; c < n; c++) i64[c] = (int64_t)(end += width[kind]);
      fwrite(i64, sizeof *i64, n, fp);
    }
  fwrite(&arr[A_TYPES].nbytes, 8, 1, fp);
  for (int kind = 0; kind < 3; kind++) {
    memset(u8, type[kind], VTU_CHUNK);
    for (uint64_t c = 0; c < count[kind]; c += VTU_CHUNK)
      fwrite(u8, 1, (size_t)(count[kind] - c < VTU_CHUNK ? count[kind] - c
                                                         : VTU_CHUNK), fp);
  }
}

pa_status pa__vtu_write(pa_mesh *mesh, const char *path, int diagnostics,
                        const pa__vtu_extra *x) {
  pa_status st = PA_SUCCESS;
  pa__outfile out = {0};
  int64_t *i64 = NULL;
  double *f64 = NULL;
  uint8_t *u8 = NULL;
  vtu_layout lay;
  PA_CHECK(mesh && path, PA_ERR_ARG, "pa__vtu_write: NULL argument");
  layout_arrays(mesh, diagnostics != 0, x, &lay);
  PA_ALLOC(i64, VTU_CHUNK * 4);
  PA_ALLOC(f64, VTU_CHUNK * 9);
  PA_ALLOC(u8, VTU_CHUNK);
  PA_CALL(pa__out_open(&out, path));
  /* The appended blocks follow in the order of the offsets. */
  write_header(out.fp, mesh, x, &lay);
  write_point_data(out.fp, mesh, x, &lay, f64);
  write_cell_data(out.fp, mesh, x, &lay, f64, u8);
  write_points(out.fp, mesh, &lay, f64);
  write_cells(out.fp, mesh, &lay, i64, u8);
  fputs("\n  </AppendedData>\n</VTKFile>\n", out.fp);
  PA_CALL(pa__out_commit(&out));
cleanup:
  if (st) pa__out_abort(&out);
  pa__free(i64);
  pa__free(f64);
  pa__free(u8);
  return st;
}
