/*
 * vtu.c -- VTK XML unstructured grid (.vtu) writer, for visualisation in
 * ParaView/VisIt (there is no .vtu reader).
 *
 * Layout: one Piece; every array is "appended" raw binary (encoding="raw",
 * header_type="UInt64": each block is its byte count as a UInt64 followed by
 * the bytes), in the host's byte order, which the header declares.
 *  - Points: Float64, 3 components (z = 0 in 2D).
 *  - Cells: the elements only (triangles, VTK type 5; tetrahedra, type 10);
 *    boundary entities and feature edges are not written. connectivity and
 *    offsets Int64, types UInt8.
 *  - PointData: "metric" (when the mesh has one) with the stored components:
 *    1 (size h) or 3/6 (m11 m12 m22 [m13 m23 m33], named by ComponentName
 *    attributes); every user field under its own name and component count;
 *    "ref" (Int32) the vertex references.
 *  - CellData: "ref" (Int32) the element references and "quality" (Float64,
 *    pa_mesh_elem_quality).
 * The appended section ends with a newline before </AppendedData>. The file
 * is written through a temporary file (output.c), so a failure leaves none.
 */
#include "io/io.h"

#include <errno.h>
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

/* Write name with the XML special characters escaped. */
static void put_escaped(FILE *fp, const char *s) {
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
    default:
      fputc(*s, fp);
    }
  }
}

static void put_array(FILE *fp, const vtu_array *a) {
  fprintf(fp, "        <DataArray type=\"%s\"", a->type);
  if (a->name) {
    fputs(" Name=\"", fp);
    put_escaped(fp, a->name);
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

pa_status pa__vtu_write(pa_mesh *mesh, const char *path) {
  pa_status st = PA_SUCCESS;
  pa_outfile out = {0};
  int64_t *i64 = NULL;
  double *f64 = NULL;
  uint8_t *u8 = NULL;
  static const char *const met2[] = {"m11", "m12", "m22"};
  static const char *const met3[] = {"m11", "m12", "m22", "m13", "m23", "m33"};
  enum {
    A_MET,
    A_VREF,
    A_EREF,
    A_QUAL,
    A_PTS,
    A_CONN,
    A_OFFS,
    A_TYPES,
    A_FIELD
  };
  vtu_array arr[A_FIELD + PA_MAX_FIELDS];
  PA_CHECK(mesh && path, PA_ERR_ARG, "pa__vtu_write: NULL argument");
  pa_mesh *m = mesh;
  int dim = m->dim, nn = dim + 1;
  uint64_t nv = (uint64_t)m->nv, ne = (uint64_t)m->ne;

  memset(arr, 0, sizeof arr);
  arr[A_MET] = (vtu_array){"metric",
                           "Float64",
                           m->met_ncomp,
                           m->met_ncomp == 3   ? met2
                           : m->met_ncomp == 6 ? met3
                                               : NULL,
                           8 * nv * (uint64_t)m->met_ncomp,
                           0};
  arr[A_VREF] = (vtu_array){"ref", "Int32", 1, NULL, 4 * nv, 0};
  arr[A_EREF] = (vtu_array){"ref", "Int32", 1, NULL, 4 * ne, 0};
  arr[A_QUAL] = (vtu_array){"quality", "Float64", 1, NULL, 8 * ne, 0};
  arr[A_PTS] = (vtu_array){NULL, "Float64", 3, NULL, 24 * nv, 0};
  arr[A_CONN] =
      (vtu_array){"connectivity", "Int64", 1, NULL, 8 * ne * (uint64_t)nn, 0};
  arr[A_OFFS] = (vtu_array){"offsets", "Int64", 1, NULL, 8 * ne, 0};
  arr[A_TYPES] = (vtu_array){"types", "UInt8", 1, NULL, ne, 0};
  for (int k = 0; k < m->nfield; k++)
    arr[A_FIELD + k] = (vtu_array){m->field[k].name,
                                   "Float64",
                                   m->field[k].ncomp,
                                   NULL,
                                   8 * nv * (uint64_t)m->field[k].ncomp,
                                   0};
  /* Appended order: point data, cell data, points, cells. */
  int order[A_FIELD + PA_MAX_FIELDS], no = 0;
  if (m->met_ncomp) order[no++] = A_MET;
  for (int k = 0; k < m->nfield; k++)
    order[no++] = A_FIELD + k;
  order[no++] = A_VREF;
  order[no++] = A_EREF;
  order[no++] = A_QUAL;
  order[no++] = A_PTS;
  order[no++] = A_CONN;
  order[no++] = A_OFFS;
  order[no++] = A_TYPES;
  uint64_t off = 0;
  for (int i = 0; i < no; i++) {
    arr[order[i]].offset = off;
    off += 8 + arr[order[i]].nbytes;
  }

  PA_ALLOC(i64, VTU_CHUNK * 4);
  PA_ALLOC(f64, VTU_CHUNK * 3);
  PA_ALLOC(u8, VTU_CHUNK);
  PA_CALL(pa__out_open(&out, path));
  FILE *fp = out.fp;
  const uint16_t probe = 1;
  int little = *(const uint8_t *)&probe == 1;
  fprintf(fp,
          "<?xml version=\"1.0\"?>\n"
          "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" "
          "byte_order=\"%s\" header_type=\"UInt64\">\n"
          "  <UnstructuredGrid>\n"
          "    <Piece NumberOfPoints=\"%llu\" NumberOfCells=\"%llu\">\n",
          little ? "LittleEndian" : "BigEndian", (unsigned long long)nv,
          (unsigned long long)ne);
  fputs("      <PointData>\n", fp);
  if (m->met_ncomp) put_array(fp, &arr[A_MET]);
  for (int k = 0; k < m->nfield; k++)
    put_array(fp, &arr[A_FIELD + k]);
  put_array(fp, &arr[A_VREF]);
  fputs("      </PointData>\n      <CellData>\n", fp);
  put_array(fp, &arr[A_EREF]);
  put_array(fp, &arr[A_QUAL]);
  fputs("      </CellData>\n      <Points>\n", fp);
  put_array(fp, &arr[A_PTS]);
  fputs("      </Points>\n      <Cells>\n", fp);
  put_array(fp, &arr[A_CONN]);
  put_array(fp, &arr[A_OFFS]);
  put_array(fp, &arr[A_TYPES]);
  fputs("      </Cells>\n    </Piece>\n  </UnstructuredGrid>\n"
        "  <AppendedData encoding=\"raw\">\n   _",
        fp);

  /* Blocks in the order of the offsets computed above. */
  if (m->met_ncomp) put_block(fp, m->met, arr[A_MET].nbytes);
  for (int k = 0; k < m->nfield; k++)
    put_block(fp, m->field[k].val, arr[A_FIELD + k].nbytes);
  put_block(fp, m->vref, arr[A_VREF].nbytes);
  put_block(fp, m->eref, arr[A_EREF].nbytes);
  fwrite(&arr[A_QUAL].nbytes, 8, 1, fp);
  for (uint64_t e0 = 0; e0 < ne; e0 += VTU_CHUNK) {
    size_t n = (size_t)(ne - e0 < VTU_CHUNK ? ne - e0 : VTU_CHUNK);
    for (size_t e = 0; e < n; e++)
      f64[e] = pa_mesh_elem_quality(m, (pa_idx)(e0 + e));
    fwrite(f64, sizeof *f64, n, fp);
  }
  if (dim == 3) {
    put_block(fp, m->coord, arr[A_PTS].nbytes);
  } else {
    fwrite(&arr[A_PTS].nbytes, 8, 1, fp);
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
  fwrite(&arr[A_CONN].nbytes, 8, 1, fp);
  for (uint64_t e0 = 0; e0 < ne; e0 += VTU_CHUNK) {
    size_t n = (size_t)(ne - e0 < VTU_CHUNK ? ne - e0 : VTU_CHUNK);
    for (size_t k = 0; k < n * nn; k++)
      i64[k] = m->elem[(size_t)nn * e0 + k];
    fwrite(i64, sizeof *i64, n * nn, fp);
  }
  fwrite(&arr[A_OFFS].nbytes, 8, 1, fp);
  for (uint64_t e0 = 0; e0 < ne; e0 += VTU_CHUNK) {
    size_t n = (size_t)(ne - e0 < VTU_CHUNK ? ne - e0 : VTU_CHUNK);
    for (size_t e = 0; e < n; e++)
      i64[e] = (int64_t)((e0 + e + 1) * nn);
    fwrite(i64, sizeof *i64, n, fp);
  }
  fwrite(&arr[A_TYPES].nbytes, 8, 1, fp);
  memset(u8, dim == 2 ? 5 : 10, VTU_CHUNK);
  for (uint64_t e0 = 0; e0 < ne; e0 += VTU_CHUNK) {
    size_t n = (size_t)(ne - e0 < VTU_CHUNK ? ne - e0 : VTU_CHUNK);
    fwrite(u8, 1, n, fp);
  }
  fputs("\n  </AppendedData>\n</VTKFile>\n", fp);
  PA_CALL(pa__out_commit(&out));
cleanup:
  if (st) pa__out_abort(&out);
  pa__free(i64);
  pa__free(f64);
  pa__free(u8);
  return st;
}
