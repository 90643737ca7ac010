/*
 * dio.c -- distributed I/O: a set of per-rank Medit files OUT.<r>.meshb, its
 * manifest OUT.manifest, plus OUT.pvtu / OUT.<r>.vtu for ParaView, readable
 * by any number of ranks; and the collective end of output transactions.
 *
 * File convention (docs/design/DMESH.md): OUT.<r>.meshb is a standard binary Medit
 * mesh (written by pa_mesh_write) of the elements owned by rank r, all their
 * vertices and the boundary entities / edges they contain, in the rank's
 * local order, with its End keyword; after that End we append (as ParMmg
 * does, so that standard readers, which stop at the first End, never see
 * them), then a second End:
 *  - ParMmg's vertex communicators (codes 71 ParallelVertexCommunicators and
 *    73 ParallelCommunicatorVertices, 32-bit, 1-based local indices): for each
 *    other rank owning elements around some of our vertices, the shared
 *    vertices in increasing global id, so item k is the same vertex on both
 *    sides;
 *  - padapt keywords (codes 2101-2110, unknown to other readers, which skip
 *    them through the next-keyword position): header, global ids and owner
 *    ranks of vertices / boundary entities / edges, element global ids,
 *    metric and vertex fields, the element and boundary fields (only when
 *    there are some), entity flags, and one keyword per user value
 *    (description, then the value of every file entity holding it, in file
 *    order).
 * Every keyword starts with its code (int32) and the absolute position of the
 * next keyword (int32 in versions 1-2, int64 in 3-4), as libMeshb does.
 * The manifest (text, written by rank 0) lists the number of ranks, the
 * dimension, the global counts and, per rank file, its entity counts, size
 * and FNV-1a 64 checksum.
 * Invariants: the files of one write are one output transaction per rank,
 * committed only when every rank wrote all of its files (pa__output_end); a
 * write also removes what would shadow or pollute the set (a file at OUT
 * itself, rank files of higher ranks left by a write on more ranks). A
 * reader checks every rank file against the manifest (size, checksum,
 * counts) and its header (number of ranks, own rank, global counts) before
 * trusting it; a set without manifest gets the header checks only.
 */
#include "dmesh/dmesh.h"
#include "io/io.h"
#include "partition/partition.h"

#include <errno.h>
#include <stdio.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

enum {
  KW_PARMMG_VCOMMS = 71,   /* ParallelVertexCommunicators (ParMmg) */
  KW_PARMMG_VITEMS = 73,   /* ParallelCommunicatorVertices (ParMmg) */
  KW_HEADER = 2101,        /* PadaptDistribution: 16 int64 */
  KW_VGID = 2102,          /* PadaptVertexGlobalIds: int64 per vertex */
  KW_VOWNER = 2103,        /* PadaptVertexOwners: int32 per vertex */
  KW_EGID = 2104,          /* PadaptElementGlobalIds */
  KW_BGID = 2105,          /* PadaptBoundaryGlobalIds */
  KW_BOWNER = 2106,        /* PadaptBoundaryOwners */
  KW_DGID = 2107,          /* PadaptEdgeGlobalIds */
  KW_DOWNER = 2108,        /* PadaptEdgeOwners */
  KW_VDBL = 2109,          /* PadaptVertexData: metric and fields */
  KW_FLAGS = 2110,         /* PadaptFlags: uint8 per V, E, B, D entity */
  KW_VALUE = 2111,         /* PadaptValue: one user value (vdesc + data) */
  KW_CDBL = 2112,          /* PadaptCellData: element and boundary fields */
  KW_END = 54,
  FORMAT_VERSION = 1,
  MANIFEST_VERSION = 1
};

/* Words per rank in a manifest: file counts (V, E, B, D), bytes, checksum. */
enum { MF_COUNT = 0, MF_BYTES = PA_DMESH_NKIND, MF_HASH, MF_WORDS };

/* Entity kinds as messages name them. */
static const char *const kind_name[PA_DMESH_NKIND] = {
    "vertices", "elements", "boundary entities", "edges"};

/* Header words. */
enum { H_FORMAT, H_NRANKS, H_RANK, H_DIM, H_NGLOB, H_NFILE = H_NGLOB + 4,
       H_MET = H_NFILE + 4, H_NFIELD, H_WORDS = 16 };

/* ---- paths ---- */

/* "OUT.meshb" / "OUT.mesh" / "OUT" -> base "OUT". */
static void path_base(const char *path, char *base, size_t len) {
  snprintf(base, len, "%s", path);
  size_t n = strlen(base);
  if (n > 6 && !strcmp(base + n - 6, ".meshb")) base[n - 6] = '\0';
  else if (n > 5 && !strcmp(base + n - 5, ".mesh")) base[n - 5] = '\0';
}

static void rank_path(const char *base, int r, const char *ext, char *out,
                      size_t len) {
  snprintf(out, len, "%s.%d%s", base, r, ext);
}

static void manifest_path(const char *base, char *out, size_t len) {
  snprintf(out, len, "%s.manifest", base);
}

static int file_exists(const char *p) {
  struct stat sb;
  return stat(p, &sb) == 0;
}

int pa_dmesh_is_set(const char *path) {
  char base[4096], p[4200];
  if (!path || file_exists(path)) return 0;
  path_base(path, base, sizeof base);
  manifest_path(base, p, sizeof p);
  if (file_exists(p)) return 1;
  rank_path(base, 0, ".meshb", p, sizeof p);
  return file_exists(p);
}

/* ---- appending keywords to a binary Medit file ---- */

typedef struct kwfile {
  FILE *fp; /* the temporary of path, open in out */
  const char *path;
  int ver;
  int64_t pos; /* where the next keyword starts */
} kwfile;

/* Reopen path, a Medit file completed in the open output transaction, to
 * append keywords after its End. */
static pa_status kw_open_append(kwfile *k, pa__outfile *out, const char *path) {
  pa_status st = PA_SUCCESS;
  int32_t h[2];
  memset(k, 0, sizeof *k);
  k->path = path;
  PA_CALL(pa__out_reopen(out, path));
  k->fp = out->fp;
  PA_CHECK(fread(h, 4, 2, k->fp) == 2 && h[0] == 1 && h[1] >= 1 && h[1] <= 4,
           PA_ERR_FORMAT, "%s: not a native binary Medit file", path);
  k->ver = h[1];
  /* walk to End */
  int64_t pos = 8;
  for (;;) {
    int32_t code;
    int64_t next;
    PA_CHECK(fseeko(k->fp, pos, SEEK_SET) == 0 && fread(&code, 4, 1, k->fp) == 1,
             PA_ERR_FORMAT, "%s: byte %lld: no End keyword", path, (long long)pos);
    if (code == KW_END) break;
    if (k->ver >= 3) {
      PA_CHECK(fread(&next, 8, 1, k->fp) == 1, PA_ERR_FORMAT, "%s: truncated", path);
    } else {
      int32_t n32;
      PA_CHECK(fread(&n32, 4, 1, k->fp) == 1, PA_ERR_FORMAT, "%s: truncated", path);
      next = n32;
    }
    PA_CHECK(next > pos, PA_ERR_FORMAT,
             "%s: byte %lld: keyword %d has no next position", path,
             (long long)pos, code);
    pos = next;
  }
  /* keep the End of the standard part: our keywords follow it (ParMmg's
   * convention), so standard readers stop before them */
  k->pos = pos + 4 + (k->ver >= 3 ? 8 : 4);
  PA_CHECK(fseeko(k->fp, k->pos, SEEK_SET) == 0, PA_ERR_IO, "%s: seek failed",
           path);
cleanup:
  return st;
}

/* Write one keyword made of up to 3 data blocks; its next position is the
 * byte after it. */
static pa_status kw_write(kwfile *k, int code, const void *a, size_t na,
                          const void *b, size_t nb, const void *c, size_t nc) {
  pa_status st = PA_SUCCESS;
  int ps = k->ver >= 3 ? 8 : 4;
  int64_t next = k->pos + 4 + ps + (int64_t)(na + nb + nc);
  int32_t c32 = code;
  PA_CHECK(k->ver >= 3 || next < INT32_MAX, PA_ERR_IO,
           "%s: too large for a version %d Medit file", k->path, k->ver);
  int ok = fwrite(&c32, 4, 1, k->fp) == 1;
  if (ps == 8) ok &= fwrite(&next, 8, 1, k->fp) == 1;
  else {
    int32_t n32 = (int32_t)next;
    ok &= fwrite(&n32, 4, 1, k->fp) == 1;
  }
  if (na) ok &= fwrite(a, 1, na, k->fp) == na;
  if (nb) ok &= fwrite(b, 1, nb, k->fp) == nb;
  if (nc) ok &= fwrite(c, 1, nc, k->fp) == nc;
  PA_CHECK(ok, PA_ERR_IO, "%s: write error: %s", k->path, strerror(errno));
  k->pos = next;
cleanup:
  return st;
}

/* Write the final End and complete the file (pa__out_commit). */
static pa_status kw_close(kwfile *k, pa__outfile *out) {
  pa_status st = PA_SUCCESS;
  int32_t end = KW_END;
  int64_t zero = 0;
  int ok = fwrite(&end, 4, 1, k->fp) == 1;
  ok &= fwrite(&zero, k->ver >= 3 ? 8 : 4, 1, k->fp) == 1;
  ok &= fflush(k->fp) == 0;
  ok &= ftruncate(fileno(k->fp), k->pos + 4 + (k->ver >= 3 ? 8 : 4)) == 0;
  PA_CHECK(ok, PA_ERR_IO, "%s: write error: %s", k->path, strerror(errno));
  k->fp = NULL;
  PA_CALL(pa__out_commit(out));
cleanup:
  return st;
}

/* ---- user values ---- */

/* Description of a user value in a file (keyword 2111, then count * unit
 * bytes of data). type: code of a predefined MPI type (value_type), 0 for
 * the bytes of a derived type (read back as MPI_BYTE x unit). */
typedef struct vdesc {
  char name[PA_DMESH_VALUE_NAME_LEN];
  int32_t kind, ref, ncomp, type;
  int64_t count; /* file entities holding the value */
} vdesc;

enum { NVALUE_TYPES = 18 };

static MPI_Datatype value_type(int code) {
  switch (code) {
  case 1: return MPI_DOUBLE;
  case 2: return MPI_FLOAT;
  case 3: return MPI_INT;
  case 4: return MPI_LONG;
  case 5: return MPI_LONG_LONG;
  case 6: return MPI_UNSIGNED;
  case 7: return MPI_UNSIGNED_LONG;
  case 8: return MPI_SHORT;
  case 9: return MPI_CHAR;
  case 10: return MPI_UNSIGNED_CHAR;
  case 11: return MPI_INT8_T;
  case 12: return MPI_INT16_T;
  case 13: return MPI_INT32_T;
  case 14: return MPI_INT64_T;
  case 15: return MPI_UINT8_T;
  case 16: return MPI_UINT16_T;
  case 17: return MPI_UINT32_T;
  case 18: return MPI_UINT64_T;
  default: return MPI_BYTE;
  }
}

static int value_code(MPI_Datatype t) {
  for (int c = 1; c <= NVALUE_TYPES; c++)
    if (value_type(c) == t) return c;
  return t == MPI_BYTE ? 19 : 0;
}

/* Bytes per entity of a described value. */
static size_t vdesc_unit(const vdesc *d) {
  int ts = 1;
  if (d->type >= 1 && d->type <= NVALUE_TYPES) MPI_Type_size(value_type(d->type), &ts);
  return (size_t)ts * (size_t)d->ncomp;
}

/* The description of value v as stored (derived types as bytes). */
static void vdesc_of(const pa_dmesh_value *v, int64_t count, vdesc *d) {
  memset(d, 0, sizeof *d);
  snprintf(d->name, sizeof d->name, "%s", v->name);
  d->kind = (int32_t)v->kind;
  d->ref = v->ref;
  d->type = value_code(v->type);
  d->ncomp = d->type ? v->ncomp : (int32_t)v->unit;
  if (!d->type) d->type = 19; /* bytes */
  d->count = count;
}

/* ---- scanning our keywords ---- */

typedef struct dfile {
  int64_t h[H_WORDS];
  pa_gid *gid[PA_DMESH_NKIND];
  int32_t *owner[PA_DMESH_NKIND];
  int met_ncomp, nfield;
  char fieldname[PA_MESH_MAX_FIELDS][PA_MESH_FIELD_NAME_LEN];
  int32_t fieldncomp[PA_MESH_MAX_FIELDS];
  double *vdbl;
  /* element (c = 0) and boundary (c = 1) fields, and their values */
  int32_t ncfield[2];
  char cfieldname[2][PA_MESH_MAX_FIELDS][PA_MESH_FIELD_NAME_LEN];
  int32_t cfieldncomp[2][PA_MESH_MAX_FIELDS], cfieldmode[2][PA_MESH_MAX_FIELDS];
  double *cdbl[2];
  uint8_t *flags;
  int have_header;
  int nval;
  vdesc *val;              /* nval descriptions */
  unsigned char **valdata; /* nval blocks of count * unit bytes */
} dfile;

static void dfile_free(dfile *f) {
  for (int k = 0; k < PA_DMESH_NKIND; k++) {
    pa__free(f->gid[k]);
    pa__free(f->owner[k]);
  }
  pa__free(f->vdbl);
  pa__free(f->cdbl[0]);
  pa__free(f->cdbl[1]);
  pa__free(f->flags);
  for (int q = 0; q < f->nval; q++) pa__free(f->valdata[q]);
  pa__free(f->val);
  pa__free(f->valdata);
  memset(f, 0, sizeof *f);
}

static pa_status read_block(FILE *fp, const char *path, void **p, size_t n,
                            int64_t avail) {
  pa_status st = PA_SUCCESS;
  *p = NULL;
  PA_CHECK((int64_t)n <= avail, PA_ERR_FORMAT,
           "%s: a padapt keyword is larger than its room in the file", path);
  *p = pa__malloc(n ? n : 1);
  PA_CHECK(*p, PA_ERR_MEMORY, "out of memory reading %s", path);
  PA_CHECK(fread(*p, 1, n, fp) == n, PA_ERR_FORMAT, "%s: truncated", path);
cleanup:
  if (st != PA_SUCCESS && *p) { /* the caller keeps only a block it got */
    pa__free(*p);
    *p = NULL;
  }
  return st;
}

/* The keyword at byte pos of a version ver file: its code and, unless it
 * is an End, the position of the next keyword (0: none); fp is left at its
 * data. */
static pa_status keyword_at(FILE *fp, const char *path, int ver, int64_t pos,
                            int32_t *code, int64_t *next) {
  pa_status st = PA_SUCCESS;
  *next = 0;
  PA_CHECK(fseeko(fp, pos, SEEK_SET) == 0 && fread(code, 4, 1, fp) == 1,
           PA_ERR_FORMAT, "%s: byte %lld: no End keyword", path, (long long)pos);
  if (*code == KW_END) goto cleanup;
  if (ver >= 3) {
    PA_CHECK(fread(next, 8, 1, fp) == 1, PA_ERR_FORMAT, "%s: truncated", path);
  } else {
    int32_t n32;
    PA_CHECK(fread(&n32, 4, 1, fp) == 1, PA_ERR_FORMAT, "%s: truncated", path);
    *next = n32;
  }
  PA_CHECK(*next == 0 || *next > pos, PA_ERR_FORMAT,
           "%s: byte %lld: bad next keyword position", path, (long long)pos);
cleanup:
  return st;
}

/* KW_HEADER: the distribution header, its version and counts checked. */
static pa_status read_header_kw(FILE *fp, const char *path, int64_t room,
                                dfile *f) {
  pa_status st = PA_SUCCESS;
  const int64_t *H = f->h;
  PA_CHECK(room >= (int64_t)sizeof f->h && fread(f->h, sizeof f->h, 1, fp) == 1,
           PA_ERR_FORMAT, "%s: truncated header", path);
  PA_CHECK(f->h[H_FORMAT] == FORMAT_VERSION, PA_ERR_UNSUPPORTED,
           "%s: distributed format version %lld, expected %d", path,
           (long long)f->h[H_FORMAT], FORMAT_VERSION);
  for (int k = 0; k < PA_DMESH_NKIND; k++)
    PA_CHECK(H[H_NFILE + k] >= 0 && H[H_NFILE + k] < INT32_MAX &&
                 H[H_NGLOB + k] >= 0,
             PA_ERR_FORMAT, "%s: bad counts in the header", path);
  f->have_header = 1;
cleanup:
  return st;
}

/* KW_VDBL: the metric's components and the fields' descriptions, then the
 * vertex doubles; next: the position of the next keyword (0: none). */
static pa_status read_vdbl_kw(FILE *fp, const char *path, int64_t room,
                              int64_t next, dfile *f) {
  pa_status st = PA_SUCCESS;
  int32_t mn[2];
  void *p = NULL;
  PA_CHECK(f->have_header && room >= 8 && fread(mn, 4, 2, fp) == 2 &&
               mn[0] >= 0 && mn[0] <= 6 && mn[1] >= 0 &&
               mn[1] <= PA_MESH_MAX_FIELDS,
           PA_ERR_FORMAT, "%s: bad vertex data keyword", path);
  f->met_ncomp = mn[0];
  f->nfield = mn[1];
  int nd = mn[0];
  for (int q = 0; q < f->nfield; q++) {
    PA_CHECK(fread(f->fieldname[q], PA_MESH_FIELD_NAME_LEN, 1, fp) == 1 &&
                 fread(&f->fieldncomp[q], 4, 1, fp) == 1 &&
                 f->fieldncomp[q] > 0 && f->fieldncomp[q] < 1000,
             PA_ERR_FORMAT, "%s: bad field description", path);
    f->fieldname[q][PA_MESH_FIELD_NAME_LEN - 1] = '\0';
    nd += f->fieldncomp[q];
  }
  room = (next ? next : INT64_MAX) - ftello(fp);
  PA_CALL(read_block(fp, path, &p, sizeof(double) * nd * (size_t)f->h[H_NFILE], room));
  f->vdbl = p;
cleanup:
  return st;
}

/* KW_CDBL: the element and boundary fields' descriptions (counts, then
 * name, components and transfer mode of each), then the values of the file
 * elements and of the file boundary entities. */
static pa_status read_cdbl_kw(FILE *fp, const char *path, int64_t room,
                              int64_t next, dfile *f) {
  pa_status st = PA_SUCCESS;
  void *p = NULL;
  PA_CHECK(f->have_header && room >= 8 && fread(f->ncfield, 4, 2, fp) == 2,
           PA_ERR_FORMAT, "%s: bad cell data keyword", path);
  int nd[2] = {0, 0};
  for (int c = 0; c < 2; c++) {
    PA_CHECK(f->ncfield[c] >= 0 && f->ncfield[c] <= PA_MESH_MAX_FIELDS,
             PA_ERR_FORMAT, "%s: bad cell data keyword", path);
    for (int q = 0; q < f->ncfield[c]; q++) {
      PA_CHECK(fread(f->cfieldname[c][q], PA_MESH_FIELD_NAME_LEN, 1, fp) == 1 &&
                   fread(&f->cfieldncomp[c][q], 4, 1, fp) == 1 &&
                   fread(&f->cfieldmode[c][q], 4, 1, fp) == 1 &&
                   f->cfieldncomp[c][q] > 0 && f->cfieldncomp[c][q] < 1000 &&
                   f->cfieldmode[c][q] > PA_TRANSFER_DEFAULT &&
                   f->cfieldmode[c][q] <= PA_TRANSFER_NEAREST,
               PA_ERR_FORMAT, "%s: bad cell field description", path);
      f->cfieldname[c][q][PA_MESH_FIELD_NAME_LEN - 1] = '\0';
      nd[c] += f->cfieldncomp[c][q];
    }
  }
  for (int c = 0; c < 2; c++) {
    room = (next ? next : INT64_MAX) - ftello(fp);
    PA_CALL(read_block(fp, path, &p,
                       sizeof(double) * nd[c] * (size_t)f->h[H_NFILE + 1 + c], room));
    f->cdbl[c] = p;
  }
cleanup:
  return st;
}

/* KW_VALUE: one user value's description, checked, then its data. */
static pa_status read_value_kw(FILE *fp, const char *path, int64_t room,
                               int64_t next, dfile *f) {
  pa_status st = PA_SUCCESS;
  const int64_t *H = f->h;
  vdesc d;
  void *p = NULL;
  PA_CHECK(f->have_header && room >= (int64_t)sizeof d &&
               fread(&d, sizeof d, 1, fp) == 1,
           PA_ERR_FORMAT, "%s: truncated value keyword", path);
  d.name[PA_DMESH_VALUE_NAME_LEN - 1] = '\0';
  PA_CHECK(d.kind >= 0 && d.kind < PA_DMESH_NKIND && d.ncomp >= 1 &&
               d.ncomp < (1 << 24) && d.ref >= -1 && d.type >= 1 &&
               d.type <= NVALUE_TYPES + 1 && d.count >= 0 &&
               d.count <= H[H_NFILE + d.kind] && f->nval < 4096,
           PA_ERR_FORMAT, "%s: bad description of value '%s'", path, d.name);
  void *grown = pa__realloc(f->val, (size_t)(f->nval + 1) * sizeof *f->val);
  PA_CHECK(grown, PA_ERR_MEMORY, "out of memory reading %s", path);
  f->val = grown;
  grown = pa__realloc(f->valdata, (size_t)(f->nval + 1) * sizeof *f->valdata);
  PA_CHECK(grown, PA_ERR_MEMORY, "out of memory reading %s", path);
  f->valdata = grown;
  room = (next ? next : INT64_MAX) - ftello(fp);
  PA_CALL(read_block(fp, path, &p, vdesc_unit(&d) * (size_t)d.count, room));
  f->val[f->nval] = d;
  f->valdata[f->nval++] = p;
cleanup:
  return st;
}

/* One keyword of a rank file, fp at its data, next: the position of the
 * next keyword (0: none): padapt's are read into f, others skipped. */
static pa_status read_keyword(FILE *fp, const char *path, int32_t code,
                              int64_t next, dfile *f) {
  pa_status st = PA_SUCCESS;
  int64_t room = (next ? next : INT64_MAX) - ftello(fp);
  const int64_t *H = f->h;
  void *p = NULL;
  switch (code) {
  case KW_HEADER:
    PA_CALL(read_header_kw(fp, path, room, f));
    break;
  case KW_VGID: case KW_EGID: case KW_BGID: case KW_DGID: {
    int k = code == KW_VGID ? 0 : code == KW_EGID ? 1 : code == KW_BGID ? 2 : 3;
    PA_CHECK(f->have_header, PA_ERR_FORMAT, "%s: ids before the header", path);
    PA_CALL(read_block(fp, path, &p, sizeof(pa_gid) * (size_t)H[H_NFILE + k], room));
    f->gid[k] = p;
    break;
  }
  case KW_VOWNER: case KW_BOWNER: case KW_DOWNER: {
    int k = code == KW_VOWNER ? 0 : code == KW_BOWNER ? 2 : 3;
    PA_CHECK(f->have_header, PA_ERR_FORMAT, "%s: owners before the header", path);
    PA_CALL(read_block(fp, path, &p, 4 * (size_t)H[H_NFILE + k], room));
    f->owner[k] = p;
    break;
  }
  case KW_VDBL:
    PA_CALL(read_vdbl_kw(fp, path, room, next, f));
    break;
  case KW_VALUE:
    PA_CALL(read_value_kw(fp, path, room, next, f));
    break;
  case KW_CDBL:
    PA_CALL(read_cdbl_kw(fp, path, room, next, f));
    break;
  case KW_FLAGS: {
    size_t n = 0;
    for (int k = 0; k < PA_DMESH_NKIND; k++) n += (size_t)H[H_NFILE + k];
    PA_CHECK(f->have_header, PA_ERR_FORMAT, "%s: flags before the header", path);
    PA_CALL(read_block(fp, path, &p, n, room));
    f->flags = p;
    break;
  }
  default:
    break;
  }
cleanup:
  return st;
}

/* Read padapt's keywords of a rank file, after the End of its standard
 * part, up to the second End; the header, global ids and owners must be
 * there. */
static pa_status scan_file(const char *path, dfile *f) {
  pa_status st = PA_SUCCESS;
  FILE *fp = NULL;
  int32_t h[2];
  memset(f, 0, sizeof *f);
  fp = fopen(path, "rb");
  PA_CHECK(fp, PA_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
  PA_CHECK(fread(h, 4, 2, fp) == 2 && h[0] == 1 && h[1] >= 1 && h[1] <= 4,
           PA_ERR_FORMAT, "%s: not a native binary Medit file", path);
  int ver = h[1], nend = 0;
  int64_t pos = 8;
  for (;;) {
    int32_t code;
    int64_t next;
    PA_CALL(keyword_at(fp, path, ver, pos, &code, &next));
    if (code == KW_END) { /* the first End closes the standard part */
      if (++nend == 2) break;
      pos += 4 + (ver >= 3 ? 8 : 4);
      continue;
    }
    PA_CALL(read_keyword(fp, path, code, next, f));
    if (!next) break;
    pos = next;
  }
  PA_CHECK(f->have_header, PA_ERR_FORMAT,
           "%s: no PadaptDistribution keyword (not a padapt distributed file)",
           path);
  PA_CHECK(f->gid[0] && f->gid[1] && f->owner[0] &&
               (!f->h[H_NFILE + 2] || (f->gid[2] && f->owner[2])) &&
               (!f->h[H_NFILE + 3] || (f->gid[3] && f->owner[3])),
           PA_ERR_FORMAT, "%s: global ids or owners missing", path);
cleanup:
  if (fp) fclose(fp);
  if (st) dfile_free(f);
  return st;
}

/* ---- VTU output ---- */

/* Keep, in place, the boundary entities and edges of the file mesh fm that
 * this rank owns (in file order): the others are in another rank's ParaView
 * file already. map[k] becomes their new file indices (-1: dropped), nfile
 * their counts. The rank file (.meshb) was written before, whole. */
static pa_status keep_owned(const pa_dmesh *dm, pa_mesh *fm,
                            pa_idx *const map[PA_DMESH_NKIND],
                            pa_idx nfile[PA_DMESH_NKIND]) {
  pa_status st = PA_SUCCESS;
  pa_idx *to = NULL;
  for (int k = PA_BOUNDARY; k <= PA_EDGE; k++) {
    int nv = pa__kind_nv(dm->dim, k);
    pa_idx *conn = k == PA_BOUNDARY ? fm->bdry : fm->edge, n = 0;
    int32_t *ref = k == PA_BOUNDARY ? fm->bref : fm->edref;
    uint8_t *flag = k == PA_BOUNDARY ? fm->bflag : fm->edflag;
    pa__free(to);
    to = NULL;
    PA_ALLOC(to, nfile[k] ? (size_t)nfile[k] : 1);
    for (pa_idx f = 0; f < nfile[k]; f++) to[f] = -1;
    for (pa_idx i = 0; i < dm->nloc[k]; i++)
      if (map[k][i] >= 0 && dm->owner[k][i] == dm->rank) to[map[k][i]] = 0;
    for (pa_idx f = 0; f < nfile[k]; f++) {
      if (to[f] < 0) continue;
      memmove(conn + (size_t)nv * n, conn + (size_t)nv * f, sizeof *conn * nv);
      ref[n] = ref[f];
      flag[n] = flag[f];
      to[f] = n++;
    }
    for (pa_idx i = 0; i < dm->nloc[k]; i++)
      if (map[k][i] >= 0) map[k][i] = to[map[k][i]];
    nfile[k] = n;
  }
  fm->nb = nfile[PA_BOUNDARY];
  fm->ned = nfile[PA_EDGE];
  pa__mesh_invalidate(fm);
cleanup:
  pa__free(to);
  return st;
}

/* This rank's ParaView file: the file mesh fm with its metric and fields
 * (vd: nd values per file vertex, metric first), global ids, ghost types
 * and rank (pa__vtu_write); the boundary entities and edges this rank owns
 * only (keep_owned: fm, map and nfile change), so that the set shows each
 * once. */
static pa_status write_vtu(const pa_dmesh *dm, pa_mesh *fm,
                           pa_idx *const map[PA_DMESH_NKIND],
                           pa_idx nfile[PA_DMESH_NKIND], const double *vd,
                           int nd, const char *path) {
  pa_status st = PA_SUCCESS;
  const pa_mesh *m = dm->mesh;
  pa_idx nv = nfile[PA_VERTEX];
  int64_t *vgid = NULL, *cgid = NULL;
  uint8_t *ghost = NULL;
  double *col = NULL;
  PA_CALL(keep_owned(dm, fm, map, nfile));
  size_t ncell = (size_t)nfile[PA_ELEMENT] + (size_t)nfile[PA_BOUNDARY] +
                 (dm->dim == 3 ? (size_t)nfile[PA_EDGE] : 0);
  PA_ALLOC(vgid, nv);
  PA_ALLOC(ghost, nv);
  PA_ALLOC(cgid, ncell);
  for (pa_idx v = 0; v < m->nv; v++) {
    pa_idx f = map[PA_VERTEX][v];
    if (f < 0) continue;
    vgid[f] = dm->gid[PA_VERTEX][v];
    ghost[f] = dm->owner[PA_VERTEX][v] != dm->rank;
  }
  {
    size_t base = 0;
    for (int k = PA_ELEMENT; k <= PA_EDGE; k++) {
      if (k == PA_EDGE && dm->dim != 3) break;
      for (pa_idx i = 0; i < dm->nloc[k]; i++)
        if (map[k][i] >= 0) cgid[base + (size_t)map[k][i]] = dm->gid[k][i];
      base += (size_t)nfile[k];
    }
  }
  /* the metric and fields, one array each, as pa_mesh holds them */
  int off = 0;
  PA_ALLOC(col, (size_t)nv * (nd ? nd : 1));
  for (int q = -1; q < m->nfield; q++) {
    int nc = q < 0 ? m->met_ncomp : m->field[q].ncomp;
    if (!nc) continue;
    for (pa_idx f = 0; f < nv; f++)
      memcpy(col + (size_t)nc * f, vd + (size_t)nd * f + off, sizeof(double) * nc);
    if (q < 0)
      PA_CALL(pa_mesh_set_metric(fm, nc, col));
    else
      PA_CALL(pa_mesh_add_field(fm, m->field[q].name, nc, col));
    off += nc;
  }
  /* the element and boundary fields, on the file's cells */
  for (int c = 0; c < 2; c++) {
    int kind = PA_ELEMENT + c, *nf;
    const pa__field *fl = pa__mesh_fields((pa_mesh *)m, kind, &nf);
    for (int q = 0; q < *nf; q++) {
      int nc = fl[q].ncomp;
      pa__free(col);
      col = NULL;
      PA_ALLOC(col, (size_t)nc * (nfile[kind] ? nfile[kind] : 1));
      for (pa_idx i = 0; i < dm->nloc[kind]; i++)
        if (map[kind][i] >= 0)
          memcpy(col + (size_t)nc * map[kind][i], fl[q].val + (size_t)nc * i,
                 sizeof(double) * nc);
      PA_CALL(pa_mesh_add_field_at(fm, (pa_entity)kind, fl[q].name, nc, col));
    }
  }
  {
    pa__vtu_extra x = {dm->rank, vgid, ghost, cgid};
    PA_CALL(pa__vtu_write(fm, path, 0, &x));
  }
cleanup:
  pa__free(vgid);
  pa__free(ghost);
  pa__free(cgid);
  pa__free(col);
  return st;
}

/* The ParaView index of the rank files: the arrays write_vtu gives each. */
static pa_status write_pvtu(const char *base, int nranks, const pa_mesh *m) {
  pa_status st = PA_SUCCESS;
  pa__outfile out;
  char path[4200];
  const char *slash = strrchr(base, '/');
  const char *name = slash ? slash + 1 : base;
  memset(&out, 0, sizeof out);
  snprintf(path, sizeof path, "%s.pvtu", base);
  PA_CALL(pa__out_open(&out, path));
  FILE *fp = out.fp;
  fprintf(fp,
          "<?xml version=\"1.0\"?>\n<VTKFile type=\"PUnstructuredGrid\" "
          "version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n"
          "<PUnstructuredGrid GhostLevel=\"0\">\n"
          "<PPoints><PDataArray type=\"Float64\" NumberOfComponents=\"3\"/></PPoints>\n"
          "<PPointData GlobalIds=\"gid\"%s>\n",
          m->met_ncomp ? " Tensors=\"size\"" : "");
  if (m->met_ncomp)
    fprintf(fp, "<PDataArray type=\"Float64\" Name=\"metric\" NumberOfComponents=\"9\"/>\n"
                "<PDataArray type=\"Float64\" Name=\"size\" NumberOfComponents=\"9\"/>\n");
  for (int q = 0; q < m->nfield; q++)
    fprintf(fp, "<PDataArray type=\"Float64\" Name=\"%s\" NumberOfComponents=\"%d\"/>\n",
            m->field[q].name, m->field[q].ncomp);
  fprintf(fp,
          "<PDataArray type=\"Int32\" Name=\"ref\"/>\n"
          "<PDataArray type=\"Int64\" Name=\"gid\"/>\n"
          "<PDataArray type=\"UInt8\" Name=\"vtkGhostType\"/>\n"
          "</PPointData>\n<PCellData Scalars=\"quality\">\n");
  /* the cell arrays of pa__vtu_write: one per name and size */
  for (int q = 0; q < m->nefield; q++)
    fprintf(fp, "<PDataArray type=\"Float64\" Name=\"%s\" NumberOfComponents=\"%d\"/>\n",
            m->efield[q].name, m->efield[q].ncomp);
  for (int q = 0; q < m->nbfield; q++) {
    int k = pa_mesh_field_index(m, PA_ELEMENT, m->bfield[q].name);
    if (k >= 0 && m->efield[k].ncomp == m->bfield[q].ncomp) continue;
    fprintf(fp, "<PDataArray type=\"Float64\" Name=\"%s\" NumberOfComponents=\"%d\"/>\n",
            m->bfield[q].name, m->bfield[q].ncomp);
  }
  fprintf(fp,
          "<PDataArray type=\"Int32\" Name=\"ref\"/>\n"
          "<PDataArray type=\"UInt8\" Name=\"entity\"/>\n"
          "<PDataArray type=\"Float64\" Name=\"quality\"/>\n"
          "<PDataArray type=\"Int32\" Name=\"rank\"/>\n"
          "<PDataArray type=\"Int64\" Name=\"gid\"/>\n"
          "</PCellData>\n");
  for (int r = 0; r < nranks; r++)
    fprintf(fp, "<Piece Source=\"%s.%d.vtu\"/>\n", name, r);
  fprintf(fp, "</PUnstructuredGrid>\n</VTKFile>\n");
  PA_CALL(pa__out_commit(&out));
cleanup:
  pa__out_abort(&out);
  return st;
}

/* ---- the manifest ---- */

/* Rank 0: the manifest of a set of dm->size rank files; info: MF_WORDS per
 * rank. */
static pa_status write_manifest(const char *base, const pa_dmesh *dm,
                                const int64_t *info) {
  pa_status st = PA_SUCCESS;
  pa__outfile out;
  char path[4200];
  memset(&out, 0, sizeof out);
  manifest_path(base, path, sizeof path);
  PA_CALL(pa__out_open(&out, path));
  fprintf(out.fp, "padapt-distributed-set %d\nranks %d\ndim %d\n",
          MANIFEST_VERSION, dm->size, dm->dim);
  fprintf(out.fp, "global vertices %lld elements %lld boundary %lld edges %lld\n",
          (long long)dm->nglob[PA_VERTEX], (long long)dm->nglob[PA_ELEMENT],
          (long long)dm->nglob[PA_BOUNDARY], (long long)dm->nglob[PA_EDGE]);
  for (int r = 0; r < dm->size; r++) {
    const int64_t *w = info + (size_t)MF_WORDS * r;
    fprintf(out.fp,
            "rank %d vertices %lld elements %lld boundary %lld edges %lld "
            "bytes %lld fnv1a64 %016llx\n",
            r, (long long)w[MF_COUNT + PA_VERTEX],
            (long long)w[MF_COUNT + PA_ELEMENT],
            (long long)w[MF_COUNT + PA_BOUNDARY], (long long)w[MF_COUNT + PA_EDGE],
            (long long)w[MF_BYTES], (unsigned long long)w[MF_HASH]);
  }
  PA_CALL(pa__out_commit(&out));
cleanup:
  pa__out_abort(&out);
  return st;
}

/* Rank 0: remove, when the write commits, what would shadow the set or be
 * taken for part of it: a file at path itself (pa_dmesh_is_set prefers it)
 * and the rank files of ranks >= nranks (a write on more ranks). */
static pa_status remove_shadows(const char *path, const char *base,
                                int nranks) {
  pa_status st = PA_SUCCESS;
  char p[4200];
  struct stat sb;
  if (lstat(path, &sb) == 0) PA_CALL(pa__out_remove(path));
  for (int r = nranks;; r++) {
    int found = 0;
    static const char *const ext[] = {".meshb", ".vtu"};
    for (int i = 0; i < 2; i++) {
      rank_path(base, r, ext[i], p, sizeof p);
      if (lstat(p, &sb) != 0) continue;
      found = 1;
      PA_CALL(pa__out_remove(p));
    }
    if (!found) break;
  }
cleanup:
  return st;
}

/* A manifest as read: nranks lines of MF_WORDS. */
typedef struct manifest {
  int nranks, dim;
  int64_t nglob[PA_DMESH_NKIND];
  int64_t *rk;
} manifest;

/* Read "path" (rank 0). Errors name path and the line. */
static pa_status manifest_read(const char *path, manifest *mf) {
  pa_status st = PA_SUCCESS;
  FILE *fp = NULL;
  char line[512];
  int lno = 0, ver = 0, n = -1;
  long long a[PA_DMESH_NKIND + 2];
  memset(mf, 0, sizeof *mf);
  fp = fopen(path, "r");
  PA_CHECK(fp, PA_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
#define MF_LINE()                                                            \
  do {                                                                       \
    lno++;                                                                   \
    PA_CHECK(fgets(line, sizeof line, fp), PA_ERR_FORMAT,                    \
             "%s:%d: truncated manifest", path, lno);                        \
  } while (0)
  MF_LINE();
  PA_CHECK(sscanf(line, "padapt-distributed-set %d %n", &ver, &n) == 1 &&
               line[n] == '\0',
           PA_ERR_FORMAT, "%s:%d: not a padapt manifest", path, lno);
  PA_CHECK(ver == MANIFEST_VERSION, PA_ERR_UNSUPPORTED,
           "%s:%d: manifest version %d, expected %d", path, lno, ver,
           MANIFEST_VERSION);
  MF_LINE();
  n = -1;
  PA_CHECK(sscanf(line, "ranks %d %n", &mf->nranks, &n) == 1 && line[n] == '\0' &&
               mf->nranks >= 1 && mf->nranks < (1 << 24),
           PA_ERR_FORMAT, "%s:%d: expected 'ranks N'", path, lno);
  MF_LINE();
  n = -1;
  PA_CHECK(sscanf(line, "dim %d %n", &mf->dim, &n) == 1 && line[n] == '\0' &&
               (mf->dim == 2 || mf->dim == 3),
           PA_ERR_FORMAT, "%s:%d: expected 'dim 2' or 'dim 3'", path, lno);
  MF_LINE();
  n = -1;
  PA_CHECK(sscanf(line, "global vertices %lld elements %lld boundary %lld edges %lld %n",
                  &a[0], &a[1], &a[2], &a[3], &n) == 4 && line[n] == '\0',
           PA_ERR_FORMAT, "%s:%d: expected the global counts", path, lno);
  for (int k = 0; k < PA_DMESH_NKIND; k++) mf->nglob[k] = a[k];
  PA_ALLOC(mf->rk, (size_t)MF_WORDS * mf->nranks);
  for (int r = 0; r < mf->nranks; r++) {
    int rr = -1;
    unsigned long long h = 0;
    MF_LINE();
    n = -1;
    PA_CHECK(sscanf(line,
                    "rank %d vertices %lld elements %lld boundary %lld edges "
                    "%lld bytes %lld fnv1a64 %16llx %n",
                    &rr, &a[0], &a[1], &a[2], &a[3], &a[4], &h, &n) == 7 &&
                 line[n] == '\0' && rr == r,
             PA_ERR_FORMAT, "%s:%d: expected the line of rank %d", path, lno, r);
    int64_t *w = mf->rk + (size_t)MF_WORDS * r;
    for (int k = 0; k < PA_DMESH_NKIND; k++) w[MF_COUNT + k] = a[k];
    w[MF_BYTES] = a[4];
    w[MF_HASH] = (int64_t)h;
  }
  PA_CHECK(!fgets(line, sizeof line, fp), PA_ERR_FORMAT,
           "%s:%d: text after the last rank", path, lno + 1);
#undef MF_LINE
cleanup:
  if (fp) fclose(fp);
  if (st) {
    pa__free(mf->rk);
    mf->rk = NULL;
  }
  return st;
}

/* Check rank file f of a set against its manifest line w: size, checksum. */
static pa_status manifest_check_file(const char *fpath, const char *mpath,
                                     int f, const int64_t *w) {
  pa_status st = PA_SUCCESS;
  int64_t bytes = 0;
  uint64_t hash = 0;
  PA_CALL(pa__file_fnv1a64(fpath, &bytes, &hash));
  PA_CHECK(bytes == w[MF_BYTES], PA_ERR_FORMAT,
           "%s: not the file of rank %d of this set: %lld bytes, its manifest "
           "%s lists %lld (a stale file of another write, or a modified one)",
           fpath, f, (long long)bytes, mpath, (long long)w[MF_BYTES]);
  PA_CHECK(hash == (uint64_t)w[MF_HASH], PA_ERR_FORMAT,
           "%s: not the file of rank %d of this set: its FNV-1a checksum "
           "%016llx differs from %016llx in its manifest %s (a stale file of "
           "another write, or a modified one)",
           fpath, f, (unsigned long long)hash, (unsigned long long)w[MF_HASH],
           mpath);
cleanup:
  return st;
}

/* ---- writing a set ---- */

/* The file mesh of this rank: owned elements, their vertices, the boundary
 * entities and edges they contain. map[k][i] = file index of local entity i
 * of kind k, or -1. */
static pa_status file_mesh(pa_dmesh *dm, pa_mesh **fmp,
                           pa_idx *map[PA_DMESH_NKIND],
                           pa_idx nfile[PA_DMESH_NKIND]) {
  pa_status st = PA_SUCCESS;
  pa_mesh *m = dm->mesh, *fm = NULL;
  int d = dm->dim;
  pa_idx ne = dm->nown[PA_ELEMENT], *vstart = NULL, *vel = NULL;
  for (int k = 0; k < PA_DMESH_NKIND; k++) {
    PA_ALLOC(map[k], dm->nloc[k]);
    for (pa_idx i = 0; i < dm->nloc[k]; i++) map[k][i] = -1;
  }
  nfile[PA_ELEMENT] = ne;
  for (pa_idx e = 0; e < ne; e++) map[PA_ELEMENT][e] = e;
  nfile[PA_VERTEX] = 0;
  for (size_t q = 0; q < (size_t)ne * (d + 1); q++) map[PA_VERTEX][m->elem[q]] = 0;
  for (pa_idx v = 0; v < m->nv; v++)
    if (map[PA_VERTEX][v] == 0) map[PA_VERTEX][v] = nfile[PA_VERTEX]++;
  /* owned elements around each vertex */
  PA_CALL(pa__balls(m->elem, ne, d + 1, m->nv, &vstart, &vel));
  for (int k = PA_BOUNDARY; k <= PA_EDGE; k++) {
    int nv = pa__kind_nv(d, k);
    const pa_idx *conn = k == PA_BOUNDARY ? m->bdry : m->edge;
    nfile[k] = 0;
    for (pa_idx b = 0; b < dm->nloc[k]; b++) {
      const pa_idx *bv = conn + (size_t)nv * b;
      int in = 0;
      for (pa_idx q = vstart[bv[0]]; q < vstart[bv[0] + 1] && !in; q++) {
        const pa_idx *ev = m->elem + (size_t)(d + 1) * vel[q];
        int all = 1;
        for (int j = 1; j < nv && all; j++) {
          int c = 0;
          for (int i = 0; i <= d; i++) c |= ev[i] == bv[j];
          all = c;
        }
        in = all;
      }
      if (in) map[k][b] = nfile[k]++;
    }
  }
  PA_CALL(pa_mesh_create(d, &fm));
  PA_CALL(pa_mesh_reserve(fm, nfile[0], nfile[1], nfile[2], nfile[3]));
  for (pa_idx v = 0; v < m->nv; v++) {
    pa_idx f = map[PA_VERTEX][v];
    if (f < 0) continue;
    memcpy(fm->coord + (size_t)d * f, m->coord + (size_t)d * v, sizeof(double) * d);
    fm->vref[f] = m->vref[v];
    fm->vflag[f] = m->vflag[v];
  }
  fm->nv = nfile[PA_VERTEX];
  for (pa_idx e = 0; e < ne; e++) {
    for (int j = 0; j <= d; j++)
      fm->elem[(size_t)(d + 1) * e + j] = map[PA_VERTEX][m->elem[(size_t)(d + 1) * e + j]];
    fm->eref[e] = m->eref[e];
    fm->eflag[e] = m->eflag[e];
  }
  fm->ne = ne;
  for (int k = PA_BOUNDARY; k <= PA_EDGE; k++) {
    int nv = pa__kind_nv(d, k);
    const pa_idx *conn = k == PA_BOUNDARY ? m->bdry : m->edge;
    pa_idx *fc = k == PA_BOUNDARY ? fm->bdry : fm->edge;
    for (pa_idx b = 0; b < dm->nloc[k]; b++) {
      pa_idx f = map[k][b];
      if (f < 0) continue;
      for (int j = 0; j < nv; j++) fc[(size_t)nv * f + j] = map[PA_VERTEX][conn[(size_t)nv * b + j]];
      if (k == PA_BOUNDARY) {
        fm->bref[f] = m->bref[b];
        fm->bflag[f] = m->bflag[b];
      } else {
        fm->edref[f] = m->edref[b];
        fm->edflag[f] = m->edflag[b];
      }
    }
  }
  fm->nb = nfile[PA_BOUNDARY];
  fm->ned = nfile[PA_EDGE];
  *fmp = fm;
  fm = NULL;
cleanup:
  pa_mesh_destroy(fm);
  pa__free(vstart);
  pa__free(vel);
  return st;
}

/* For each local vertex, the set of ranks owning elements around it, as a
 * bit mask of `words` uint64 (reduced to the owner with MPI_BOR, then
 * broadcast back). Collective. */
static pa_status touch_masks(pa_dmesh *dm, int words, uint64_t **maskp) {
  pa_status st = PA_SUCCESS;
  uint64_t *mask = NULL;
  pa__sfop op;
  memset(&op, 0, sizeof op);
  pa_mesh *m = dm->mesh;
  int d = dm->dim;
  mask = pa__calloc((size_t)m->nv * words + 1, sizeof *mask);
  st = mask ? pa__sfop_init(&op, &dm->sf[PA_VERTEX], 8 * (size_t)words, 902)
            : pa__error(PA_ERR_MEMORY, __FILE__, __LINE__, "out of memory");
  PA_CALL(pa__agree(dm->comm, st));
  for (size_t q = 0; q < (size_t)dm->nown[PA_ELEMENT] * (d + 1); q++)
    mask[(size_t)words * m->elem[q] + dm->rank / 64] |= 1ull << (dm->rank % 64);
  PA_CALL(pa__sf_reduce_begin(&op, mask));
  PA_CALL(pa__sf_reduce_end(&op, mask, MPI_UINT64_T, words, MPI_BOR));
  PA_CALL(pa__sf_bcast_begin(&op, mask));
  PA_CALL(pa__sf_bcast_end(&op, mask));
  *maskp = mask;
  mask = NULL;
cleanup:
  pa__sfop_free(&op);
  pa__free(mask);
  return st;
}

/* What the phases of pa_dmesh_write share: the rank file's mesh (fm, with
 * map[k][i] the file index of local entity i, -1 if not in the file), the
 * ranks each local vertex touches (mask, words per vertex), the keyword
 * appender, the vertex doubles (metric, then fields; kept for the vtu) and
 * this rank's line of the manifest. */
typedef struct dwriter {
  pa_dmesh *dm;
  pa_mesh *fm;
  pa_idx *map[PA_DMESH_NKIND], nfile[PA_DMESH_NKIND];
  int words;
  uint64_t *mask;
  kwfile kw;
  pa__outfile kwout;
  double *vd;
  int nd;
  int64_t info[MF_WORDS];
} dwriter;

/* ParMmg's vertex communicators: per neighbour rank, the file vertices it
 * also holds, in global id order (ParMmg's convention). */
static pa_status write_comms(dwriter *w) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = w->dm;
  const pa_mesh *m = dm->mesh;
  const pa_idx *vmap = w->map[PA_VERTEX];
  int words = w->words, ncomm = 0;
  size_t nitem = 0, k = 0;
  int32_t *comms = NULL, *items = NULL;
  pa_idx *ord = NULL;
  PA_ALLOC(comms, 1 + 2 * (size_t)dm->size);
  int32_t *cnt = comms + 1;
  for (int r = 0; r < dm->size; r++) {
    if (r == dm->rank) continue;
    int32_t c = 0;
    for (pa_idx v = 0; v < m->nv; v++)
      if (vmap[v] >= 0 && (w->mask[(size_t)words * v + r / 64] >> (r % 64) & 1)) c++;
    if (c) {
      cnt[2 * ncomm] = r;
      cnt[2 * ncomm + 1] = c;
      ncomm++;
      nitem += (size_t)c;
    }
  }
  comms[0] = ncomm;
  PA_ALLOC(items, 3 * nitem);
  PA_ALLOC(ord, m->nv);
  for (pa_idx v = 0; v < m->nv; v++) ord[v] = v;
  PA_CALL(pa__sort_by_gid(ord, (size_t)m->nv, dm->gid[PA_VERTEX]));
  for (int c = 0; c < ncomm; c++) {
    int r = cnt[2 * c], idx = 0;
    for (pa_idx q = 0; q < m->nv; q++) {
      pa_idx v = ord[q];
      if (vmap[v] >= 0 && (w->mask[(size_t)words * v + r / 64] >> (r % 64) & 1)) {
        items[3 * k] = vmap[v] + 1;
        items[3 * k + 1] = ++idx;
        items[3 * k + 2] = c;
        k++;
      }
    }
  }
  PA_CALL(kw_write(&w->kw, KW_PARMMG_VCOMMS, comms, 4 * (1 + 2 * (size_t)ncomm), NULL, 0, NULL, 0));
  PA_CALL(kw_write(&w->kw, KW_PARMMG_VITEMS, items, 12 * nitem, NULL, 0, NULL, 0));
cleanup:
  pa__free(ord);
  pa__free(items);
  pa__free(comms);
  return st;
}

/* The header, then the global id (and owner) of every file entity. */
static pa_status write_ids(dwriter *w) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = w->dm;
  const pa_mesh *m = dm->mesh;
  pa_gid *g = NULL;
  int32_t *o = NULL;
  int64_t h[H_WORDS] = {0};
  h[H_FORMAT] = FORMAT_VERSION;
  h[H_NRANKS] = dm->size;
  h[H_RANK] = dm->rank;
  h[H_DIM] = dm->dim;
  for (int k = 0; k < PA_DMESH_NKIND; k++) {
    h[H_NGLOB + k] = dm->nglob[k];
    h[H_NFILE + k] = w->nfile[k];
  }
  h[H_MET] = m->met_ncomp;
  h[H_NFIELD] = m->nfield;
  PA_CALL(kw_write(&w->kw, KW_HEADER, h, sizeof h, NULL, 0, NULL, 0));
  pa_idx nmax = 0;
  for (int k = 0; k < PA_DMESH_NKIND; k++)
    nmax = w->nfile[k] > nmax ? w->nfile[k] : nmax;
  PA_ALLOC(g, nmax);
  PA_ALLOC(o, nmax);
  static const int kwg[PA_DMESH_NKIND] = {KW_VGID, KW_EGID, KW_BGID, KW_DGID};
  static const int kwo[PA_DMESH_NKIND] = {KW_VOWNER, 0, KW_BOWNER, KW_DOWNER};
  for (int k = 0; k < PA_DMESH_NKIND; k++) {
    for (pa_idx i = 0; i < dm->nloc[k]; i++)
      if (w->map[k][i] >= 0) {
        g[w->map[k][i]] = dm->gid[k][i];
        o[w->map[k][i]] = dm->owner[k][i];
      }
    PA_CALL(kw_write(&w->kw, kwg[k], g, sizeof(pa_gid) * w->nfile[k], NULL, 0, NULL, 0));
    if (kwo[k]) PA_CALL(kw_write(&w->kw, kwo[k], o, 4 * (size_t)w->nfile[k], NULL, 0, NULL, 0));
  }
cleanup:
  pa__free(g);
  pa__free(o);
  return st;
}

/* The metric and the fields of every file vertex (w->vd, kept for the vtu),
 * after a description of the fields. */
static pa_status write_vertex_doubles(dwriter *w) {
  pa_status st = PA_SUCCESS;
  const pa_mesh *m = w->dm->mesh;
  const pa_idx *vmap = w->map[PA_VERTEX];
  unsigned char *fdesc = NULL;
  int nd = m->met_ncomp;
  for (int f = 0; f < m->nfield; f++) nd += m->field[f].ncomp;
  w->nd = nd;
  PA_ALLOC(w->vd, (size_t)nd * w->nfile[PA_VERTEX]);
  for (pa_idx v = 0; v < m->nv; v++) {
    pa_idx f = vmap[v];
    if (f < 0) continue;
    double *x = w->vd + (size_t)nd * f;
    if (m->met_ncomp) memcpy(x, m->met + (size_t)m->met_ncomp * v, sizeof(double) * m->met_ncomp);
    x += m->met_ncomp;
    for (int q = 0; q < m->nfield; q++) {
      memcpy(x, m->field[q].val + (size_t)m->field[q].ncomp * v, sizeof(double) * m->field[q].ncomp);
      x += m->field[q].ncomp;
    }
  }
  size_t dl = 8 + (size_t)m->nfield * (PA_MESH_FIELD_NAME_LEN + 4);
  PA_CALLOC(fdesc, dl);
  int32_t mn[2] = {m->met_ncomp, m->nfield};
  memcpy(fdesc, mn, 8);
  for (int q = 0; q < m->nfield; q++) {
    memcpy(fdesc + 8 + (size_t)q * (PA_MESH_FIELD_NAME_LEN + 4),
           m->field[q].name, PA_MESH_FIELD_NAME_LEN);
    int32_t nc = m->field[q].ncomp;
    memcpy(fdesc + 8 + (size_t)q * (PA_MESH_FIELD_NAME_LEN + 4) +
               PA_MESH_FIELD_NAME_LEN,
           &nc, 4);
  }
  PA_CALL(kw_write(&w->kw, KW_VDBL, fdesc, dl, w->vd, sizeof(double) * nd * w->nfile[PA_VERTEX], NULL, 0));
cleanup:
  pa__free(fdesc);
  return st;
}

/* The element and boundary fields of the file entities (KW_CDBL), when
 * the mesh has some. */
static pa_status write_cell_doubles(dwriter *w) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = w->dm;
  const pa_mesh *m = dm->mesh;
  unsigned char *desc = NULL;
  double *val[2] = {NULL, NULL};
  size_t nval[2] = {0, 0};
  if (!m->nefield && !m->nbfield) return PA_SUCCESS;
  int32_t n[2] = {m->nefield, m->nbfield};
  size_t unit = PA_MESH_FIELD_NAME_LEN + 8, dl = 8 + unit * (size_t)(n[0] + n[1]);
  PA_CALLOC(desc, dl);
  memcpy(desc, n, 8);
  unsigned char *q = desc + 8;
  for (int c = 0; c < 2; c++) {
    int *nf;
    const pa__field *f = pa__mesh_fields((pa_mesh *)m, PA_ELEMENT + c, &nf);
    int nd = 0;
    for (int k = 0; k < *nf; k++, q += unit) {
      int32_t x[2] = {f[k].ncomp, f[k].transfer};
      memcpy(q, f[k].name, PA_MESH_FIELD_NAME_LEN);
      memcpy(q + PA_MESH_FIELD_NAME_LEN, x, 8);
      nd += f[k].ncomp;
    }
    int kind = PA_ELEMENT + c;
    nval[c] = (size_t)nd * w->nfile[kind];
    PA_ALLOC(val[c], nval[c] ? nval[c] : 1);
    for (pa_idx i = 0; i < dm->nloc[kind]; i++)
      if (w->map[kind][i] >= 0)
        pa__entity_doubles(m, kind, i, val[c] + (size_t)nd * w->map[kind][i]);
  }
  PA_CALL(kw_write(&w->kw, KW_CDBL, desc, dl, val[0], sizeof(double) * nval[0],
                   val[1], sizeof(double) * nval[1]));
cleanup:
  pa__free(desc);
  pa__free(val[0]);
  pa__free(val[1]);
  return st;
}

/* The flags of every file entity, kind after kind. */
static pa_status write_flags(dwriter *w) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = w->dm;
  const pa_mesh *m = dm->mesh;
  uint8_t *flags = NULL;
  size_t nf = 0, off = 0;
  for (int k = 0; k < PA_DMESH_NKIND; k++) nf += (size_t)w->nfile[k];
  PA_ALLOC(flags, nf);
  const uint8_t *src[PA_DMESH_NKIND] = {m->vflag, m->eflag, m->bflag,
                                        m->edflag};
  for (int k = 0; k < PA_DMESH_NKIND; k++) {
    for (pa_idx i = 0; i < dm->nloc[k]; i++)
      if (w->map[k][i] >= 0) flags[off + w->map[k][i]] = src[k][i];
    off += (size_t)w->nfile[k];
  }
  PA_CALL(kw_write(&w->kw, KW_FLAGS, flags, nf, NULL, 0, NULL, 0));
cleanup:
  pa__free(flags);
  return st;
}

/* The user values: the owned copies are authoritative; the file holds the
 * value of every file entity with it (ghost vertices included), and the
 * reader keeps the one of the owner's file. */
static pa_status write_values(dwriter *w) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = w->dm;
  pa_idx *fslot = NULL;
  unsigned char *vb = NULL;
  for (int q = 0; q < dm->nvalue; q++) {
    const pa_dmesh_value *v = dm->value[q];
    int k = (int)v->kind;
    vdesc d;
    int64_t count = 0;
    PA_ALLOC(fslot, w->nfile[k]);
    for (pa_idx f = 0; f < w->nfile[k]; f++) fslot[f] = -1;
    for (pa_idx i = 0; i < dm->nloc[k]; i++) {
      pa_idx sl = v->slot ? v->slot[i] : i;
      if (w->map[k][i] >= 0 && sl >= 0) fslot[w->map[k][i]] = sl;
    }
    for (pa_idx f = 0; f < w->nfile[k]; f++) count += fslot[f] >= 0;
    vb = pa__malloc((size_t)count * v->unit + 1);
    PA_CHECK(vb, PA_ERR_MEMORY, "out of memory writing value '%s'", v->name);
    for (pa_idx f = 0, c = 0; f < w->nfile[k]; f++)
      if (fslot[f] >= 0)
        memcpy(vb + v->unit * (size_t)c++, v->data + v->unit * (size_t)fslot[f], v->unit);
    vdesc_of(v, count, &d);
    PA_CALL(kw_write(&w->kw, KW_VALUE, &d, sizeof d, vb, v->unit * (size_t)count, NULL, 0));
    pa__free(fslot);
    pa__free(vb);
    fslot = NULL;
    vb = NULL;
  }
cleanup:
  pa__free(fslot);
  pa__free(vb);
  return st;
}

/* This rank's line of the manifest: its entity counts, and the size and
 * hash of its rank file as written (its temporary). */
static pa_status manifest_line(dwriter *w, const char *fpath) {
  pa_status st = PA_SUCCESS;
  const char *tmp = pa__out_tmppath(fpath);
  uint64_t hash = 0;
  PA_CHECK(tmp, PA_ERR_INTERNAL, "%s: its temporary is not listed", fpath);
  PA_CALL(pa__file_fnv1a64(tmp, &w->info[MF_BYTES], &hash));
  w->info[MF_HASH] = (int64_t)hash;
  for (int k = 0; k < PA_DMESH_NKIND; k++) w->info[MF_COUNT + k] = w->nfile[k];
cleanup:
  return st;
}

pa_status pa_dmesh_write(pa_dmesh *dm, const char *path) {
  pa_status st = PA_SUCCESS;
  char base[4096], fpath[4200];
  pa_output *tx = NULL;
  int64_t *all = NULL;
  dwriter w;
  memset(&w, 0, sizeof w);
  PA_CHECK(dm && path, PA_ERR_ARG, "pa_dmesh_write: NULL argument");
  pa__agree_reset();
  PA_CALL(pa_output_begin(&tx)); /* or join the caller's */
  w.dm = dm;
  w.words = (dm->size + 63) / 64;
  path_base(path, base, sizeof base);
  /* the rank file: its mesh, then padapt's and ParMmg's keywords */
  PA_CALL(file_mesh(dm, &w.fm, w.map, w.nfile));
  PA_CALL(touch_masks(dm, w.words, &w.mask));
  rank_path(base, dm->rank, ".meshb", fpath, sizeof fpath);
  PA_CALL(pa_mesh_write(w.fm, fpath, NULL));
  PA_CALL(kw_open_append(&w.kw, &w.kwout, fpath));
  PA_CALL(write_comms(&w));
  PA_CALL(write_ids(&w));
  PA_CALL(write_vertex_doubles(&w));
  PA_CALL(write_cell_doubles(&w));
  PA_CALL(write_flags(&w));
  PA_CALL(write_values(&w));
  PA_CALL(kw_close(&w.kw, &w.kwout));
  PA_CALL(manifest_line(&w, fpath));
  /* ParaView: per-rank vtu of the owned elements */
  rank_path(base, dm->rank, ".vtu", fpath, sizeof fpath);
  PA_CALL(write_vtu(dm, w.fm, w.map, w.nfile, w.vd, w.nd, fpath));
  /* rank 0: the pvtu and the manifest of every rank's line */
  if (dm->rank == 0) {
    all = pa__malloc(sizeof *all * MF_WORDS * (size_t)dm->size);
    if (!all) st = pa__error(PA_ERR_MEMORY, __FILE__, __LINE__, "out of memory");
  }
  PA_CALL(pa__agree(dm->comm, st));
  MPI_Gather(w.info, MF_WORDS, MPI_INT64_T, all, MF_WORDS, MPI_INT64_T, 0,
             dm->comm);
  if (dm->rank == 0) {
    PA_CALL(write_pvtu(base, dm->size, dm->mesh));
    PA_CALL(write_manifest(base, dm, all));
    PA_CALL(remove_shadows(path, base, dm->size));
  }
cleanup:
  pa__out_abort(&w.kwout);
  if (dm && tx) st = pa__output_end(dm->comm, tx, st);
  else if (dm) st = pa__agree_end(dm->comm, st);
  pa__free(all);
  pa_mesh_destroy(w.fm);
  for (int k = 0; k < PA_DMESH_NKIND; k++) pa__free(w.map[k]);
  pa__free(w.mask);
  pa__free(w.vd);
  return st;
}

/* ---- reading ---- */

/* Records of the entities file f owns (elements: all). */
/* Payload of file entity i of kind k (reference ref): the data of the values
 * of kind k holding it, in value order; advances their cursors. */
static pa_status file_payload(const char *path, const dfile *df, int k,
                              int32_t ref, int64_t *cur, unsigned char *pay,
                              size_t *len) {
  pa_status st = PA_SUCCESS;
  *len = 0;
  for (int q = 0; q < df->nval; q++) {
    const vdesc *v = &df->val[q];
    if (v->kind != k || (v->ref >= 0 && v->ref != ref)) continue;
    PA_CHECK(cur[q] < v->count, PA_ERR_FORMAT,
             "%s: value '%s' has data for %lld entities, more hold it", path,
             v->name, (long long)v->count);
    size_t u = vdesc_unit(v);
    memcpy(pay + *len, df->valdata[q] + u * (size_t)cur[q]++, u);
    *len += u;
  }
cleanup:
  return st;
}

static pa_status file_records(const char *path, int f, int nwriters,
                              const dfile *df, const pa_mesh *fm,
                              const pa__layout *lay, const vdesc *vals,
                              int nval, int me, pa__recs *R) {
  pa_status st = PA_SUCCESS;
  int d = fm->dim;
  double *dbl = NULL;
  int64_t *cur = NULL;
  unsigned char *pay = NULL;
  size_t plen;
  const int64_t *h = df->h;
  PA_CHECK(h[H_NRANKS] == nwriters && h[H_RANK] == f, PA_ERR_FORMAT,
           "%s: this is the file of rank %lld of %lld, expected rank %d of %d",
           path, (long long)h[H_RANK], (long long)h[H_NRANKS], f, nwriters);
  PA_CHECK(h[H_DIM] == lay->dim && fm->dim == lay->dim, PA_ERR_FORMAT,
           "%s: dimension %d differs from the set's (%d)", path, fm->dim, lay->dim);
  PA_CHECK(fm->nv == h[H_NFILE] && fm->ne == h[H_NFILE + 1] &&
               fm->nb == h[H_NFILE + 2] && fm->ned == h[H_NFILE + 3],
           PA_ERR_FORMAT, "%s: the mesh counts differ from the padapt header",
           path);
  PA_CHECK(df->met_ncomp == lay->met_ncomp && df->nfield == lay->nfield &&
               df->ncfield[0] == lay->ncfield[0] && df->ncfield[1] == lay->ncfield[1],
           PA_ERR_FORMAT, "%s: metric or fields differ from rank 0's file", path);
  for (int c = 0; c < 2; c++)
    for (int q = 0; q < lay->ncfield[c]; q++)
      PA_CHECK(!strcmp(df->cfieldname[c][q], lay->cfieldname[c][q]) &&
                   df->cfieldncomp[c][q] == lay->cfieldncomp[c][q] &&
                   df->cfieldmode[c][q] == lay->cfieldmode[c][q],
               PA_ERR_FORMAT, "%s: %s field %d differs from rank 0's file", path,
               c ? "boundary" : "element", q + 1);
  int nd = pa__layout_ndbl(lay) - d;
  /* user values: same descriptions as rank 0's file; cur[q] walks value q's
   * data over the file entities holding it, in file order */
  PA_CHECK(df->nval == nval, PA_ERR_FORMAT,
           "%s: %d user values, rank 0's file has %d", path, df->nval, nval);
  size_t maxpay = 0;
  for (int q = 0; q < nval; q++) {
    PA_CHECK(!strcmp(df->val[q].name, vals[q].name) &&
                 df->val[q].kind == vals[q].kind && df->val[q].ref == vals[q].ref &&
                 df->val[q].ncomp == vals[q].ncomp && df->val[q].type == vals[q].type,
             PA_ERR_FORMAT, "%s: user value %d differs from rank 0's file", path, q);
    maxpay += vdesc_unit(&vals[q]);
  }
  PA_CALLOC(cur, nval);
  PA_ALLOC(pay, maxpay);
  PA_ALLOC(dbl, d + nd);
  for (pa_idx v = 0; v < fm->nv; v++) {
    PA_CHECK(df->owner[0][v] >= 0 && df->owner[0][v] < nwriters, PA_ERR_FORMAT,
             "%s: vertex %d has owner %d out of range", path, (int)v + 1,
             df->owner[0][v]);
    PA_CALL(file_payload(path, df, PA_VERTEX, fm->vref[v], cur, pay, &plen));
    if (df->owner[0][v] != f) continue;
    memcpy(dbl, fm->coord + (size_t)d * v, sizeof(double) * d);
    if (nd) memcpy(dbl + d, df->vdbl + (size_t)nd * v, sizeof(double) * nd);
    uint8_t flag = df->flags ? df->flags[v] : fm->vflag[v];
    PA_CALL(pa__recs_add(&R[PA_VERTEX], df->gid[0][v], NULL, fm->vref[v], flag,
                         me, dbl, pay, plen));
  }
  size_t foff = (size_t)fm->nv;
  for (int k = PA_ELEMENT; k < PA_DMESH_NKIND; k++) {
    int nv = pa__kind_nv(d, k);
    pa_idx n = (pa_idx)h[H_NFILE + k];
    const pa_idx *conn = k == PA_ELEMENT ? fm->elem : k == PA_BOUNDARY ? fm->bdry : fm->edge;
    const int32_t *ref = k == PA_ELEMENT ? fm->eref : k == PA_BOUNDARY ? fm->bref : fm->edref;
    const uint8_t *fl = k == PA_ELEMENT ? fm->eflag : k == PA_BOUNDARY ? fm->bflag : fm->edflag;
    for (pa_idx i = 0; i < n; i++) {
      PA_CALL(file_payload(path, df, k, ref[i], cur, pay, &plen));
      if (k != PA_ELEMENT && df->owner[k][i] != f) continue;
      pa_gid vg[4];
      for (int j = 0; j < nv; j++) vg[j] = df->gid[0][conn[(size_t)nv * i + j]];
      uint8_t flag = df->flags ? df->flags[foff + (size_t)i] : fl[i];
      int cnd = R[k].ndbl;
      const double *cd = cnd ? df->cdbl[k - PA_ELEMENT] + (size_t)cnd * i : NULL;
      PA_CALL(pa__recs_add(&R[k], df->gid[k][i], vg, ref[i], flag, me, cd,
                           pay, plen));
    }
    foff += (size_t)n;
  }
  for (int q = 0; q < nval; q++)
    PA_CHECK(cur[q] == df->val[q].count, PA_ERR_FORMAT,
             "%s: value '%s' has data for %lld entities, %lld hold it", path,
             df->val[q].name, (long long)df->val[q].count, (long long)cur[q]);
cleanup:
  pa__free(dbl);
  pa__free(cur);
  pa__free(pay);
  return st;
}

/* What the phases of read_set share: the set's base path and manifest path,
 * its manifest (have_mf; mf.rk broadcast to every rank), rank 0's header
 * (hdr: nw writers, global counts) and layout, the user values the set
 * describes (vals), and the records of the files this rank reads (R). */
typedef struct rset {
  MPI_Comm comm;
  int rank, size, nw;
  const char *path;
  char base[4096], mpath[4200];
  manifest mf;
  int have_mf;
  int64_t hdr[H_WORDS];
  pa__layout lay;
  vdesc *vals;
  int nval;
  pa__recs R[PA_DMESH_NKIND];
} rset;

/* On rank 0: the manifest (or, without one, rank 0's file) fixes the number
 * of writers; rank 0's file, checked against the manifest, fixes the
 * layout, the global counts and the user values. */
static pa_status read_first_file(rset *s) {
  pa_status st = PA_SUCCESS;
  char fpath[4200];
  dfile df;
  int64_t *hdr = s->hdr;
  memset(&df, 0, sizeof df);
  s->have_mf = file_exists(s->mpath);
  if (s->have_mf) PA_CALL(manifest_read(s->mpath, &s->mf));
  rank_path(s->base, 0, ".meshb", fpath, sizeof fpath);
  PA_CHECK(file_exists(fpath), PA_ERR_IO,
           "%s: missing file of the distributed set %s (rank 0 of %d)",
           fpath, s->path, s->have_mf ? s->mf.nranks : 1);
  if (s->have_mf) PA_CALL(manifest_check_file(fpath, s->mpath, 0, s->mf.rk));
  PA_CALL(scan_file(fpath, &df));
  memcpy(hdr, df.h, sizeof s->hdr);
  s->lay.dim = (int)df.h[H_DIM];
  s->lay.met_ncomp = df.met_ncomp;
  s->lay.nfield = df.nfield;
  memcpy(s->lay.fieldname, df.fieldname, sizeof s->lay.fieldname);
  memcpy(s->lay.fieldncomp, df.fieldncomp, sizeof s->lay.fieldncomp);
  for (int c = 0; c < 2; c++) {
    s->lay.ncfield[c] = df.ncfield[c];
    for (int q = 0; q < df.ncfield[c]; q++) {
      memcpy(s->lay.cfieldname[c][q], df.cfieldname[c][q], PA_MESH_FIELD_NAME_LEN);
      s->lay.cfieldncomp[c][q] = df.cfieldncomp[c][q];
      s->lay.cfieldmode[c][q] = df.cfieldmode[c][q];
    }
  }
  PA_CHECK(hdr[H_NRANKS] >= 1 && hdr[H_NRANKS] < (1 << 24) &&
               (hdr[H_DIM] == 2 || hdr[H_DIM] == 3),
           PA_ERR_FORMAT, "%s: bad header", fpath);
  if (s->have_mf) {
    PA_CHECK(hdr[H_NRANKS] == s->mf.nranks && hdr[H_DIM] == s->mf.dim,
             PA_ERR_FORMAT,
             "%s: written by %lld ranks in %lldD, its manifest %s lists %d "
             "ranks in %dD", fpath, (long long)hdr[H_NRANKS],
             (long long)hdr[H_DIM], s->mpath, s->mf.nranks, s->mf.dim);
    for (int k = 0; k < PA_DMESH_NKIND; k++)
      PA_CHECK(hdr[H_NGLOB + k] == s->mf.nglob[k], PA_ERR_FORMAT,
               "%s: global counts differ from its manifest %s", fpath,
               s->mpath);
  }
  s->nval = df.nval;
  PA_ALLOC(s->vals, s->nval);
  if (s->nval) memcpy(s->vals, df.val, (size_t)s->nval * sizeof *s->vals);
cleanup:
  dfile_free(&df);
  return st;
}

/* Rank 0's header, layout, user values and manifest lines to every rank
 * (rank 0's read agreed before). */
static pa_status bcast_set_header(rset *s) {
  pa_status st = PA_SUCCESS;
  MPI_Comm comm = s->comm;
  MPI_Bcast(s->hdr, H_WORDS, MPI_INT64_T, 0, comm);
  MPI_Bcast(&s->lay, (int)sizeof s->lay, MPI_BYTE, 0, comm);
  MPI_Bcast(&s->nval, 1, MPI_INT, 0, comm);
  if (s->rank != 0) {
    s->vals = pa__malloc(((size_t)s->nval + 1) * sizeof *s->vals);
    st = s->vals ? PA_SUCCESS
                 : pa__error(PA_ERR_MEMORY, __FILE__, __LINE__, "out of memory");
  }
  PA_CALL(pa__agree(comm, st));
  MPI_Bcast(s->vals, (int)((size_t)s->nval * sizeof *s->vals), MPI_BYTE, 0, comm);
  s->nw = (int)s->hdr[H_NRANKS];
  MPI_Bcast(&s->have_mf, 1, MPI_INT, 0, comm);
  if (s->have_mf) {
    if (s->rank != 0) {
      s->mf.rk = pa__malloc(sizeof *s->mf.rk * MF_WORDS * (size_t)s->nw);
      st = s->mf.rk ? PA_SUCCESS
                    : pa__error(PA_ERR_MEMORY, __FILE__, __LINE__, "out of memory");
    }
    PA_CALL(pa__agree(comm, st));
    MPI_Bcast(s->mf.rk, MF_WORDS * s->nw, MPI_INT64_T, 0, comm);
  }
cleanup:
  return st;
}

/* This rank's share of the files, [rank*nw/size, (rank+1)*nw/size): each
 * checked against the manifest and rank 0's header, its owned entities
 * appended to R. */
static pa_status read_my_files(rset *s) {
  pa_status st = PA_SUCCESS;
  char fpath[4200];
  dfile df;
  pa_mesh *fm = NULL;
  int nw = s->nw;
  memset(&df, 0, sizeof df);
  for (int k = 0; k < PA_DMESH_NKIND; k++)
    pa__recs_init(&s->R[k], k, pa__kind_nv(s->lay.dim, k),
                  pa__layout_kind_ndbl(&s->lay, k));
  int f0 = (int)((int64_t)s->rank * nw / s->size),
      f1 = (int)((int64_t)(s->rank + 1) * nw / s->size);
  for (int f = f0; f < f1; f++) {
    const int64_t *w = s->have_mf ? s->mf.rk + (size_t)MF_WORDS * f : NULL;
    rank_path(s->base, f, ".meshb", fpath, sizeof fpath);
    PA_CHECK(file_exists(fpath), PA_ERR_IO,
             "%s: missing file of the distributed set %s (rank %d of %d)",
             fpath, s->path, f, nw);
    if (w && f > 0) PA_CALL(manifest_check_file(fpath, s->mpath, f, w));
    PA_CALL(scan_file(fpath, &df));
    PA_CALL(pa_mesh_read(fpath, &fm));
    PA_CALL(file_records(fpath, f, nw, &df, fm, &s->lay, s->vals, s->nval,
                         s->rank, s->R));
    for (int k = 0; w && k < PA_DMESH_NKIND; k++)
      PA_CHECK(df.h[H_NFILE + k] == w[MF_COUNT + k], PA_ERR_FORMAT,
               "%s: %lld %s, its manifest %s lists %lld", fpath,
               (long long)df.h[H_NFILE + k], kind_name[k], s->mpath,
               (long long)w[MF_COUNT + k]);
    for (int k = 0; k < PA_DMESH_NKIND; k++)
      PA_CHECK(df.h[H_NGLOB + k] == s->hdr[H_NGLOB + k], PA_ERR_FORMAT,
               "%s: global counts differ from rank 0's file", fpath);
    pa_mesh_destroy(fm);
    fm = NULL;
    dfile_free(&df);
  }
cleanup:
  dfile_free(&df);
  pa_mesh_destroy(fm);
  return st;
}

/* Every entity of the set exactly once over the ranks: the counts of the
 * records read against the header, and their global ids unique. */
static pa_status check_set_counts(rset *s) {
  pa_status st = PA_SUCCESS;
  int64_t n[PA_DMESH_NKIND];
  for (int k = 0; k < PA_DMESH_NKIND; k++) n[k] = (int64_t)s->R[k].n;
  PA_CALL(pa__allreduce(s->comm, n, PA_DMESH_NKIND, MPI_INT64_T, MPI_SUM));
  for (int k = 0; k < PA_DMESH_NKIND; k++)
    PA_CHECK(n[k] == s->hdr[H_NGLOB + k], PA_ERR_FORMAT,
             "%s: inconsistent distributed set: the files own %lld %s, the "
             "header says %lld", s->path, (long long)n[k], kind_name[k],
             (long long)s->hdr[H_NGLOB + k]);
  PA_CALL(pa__gids_unique(s->comm, s->R[PA_ELEMENT].n, s->R[PA_ELEMENT].gid,
                          "element"));
  PA_CALL(pa__gids_unique(s->comm, s->R[PA_BOUNDARY].n, s->R[PA_BOUNDARY].gid,
                          "boundary entity"));
  PA_CALL(pa__gids_unique(s->comm, s->R[PA_EDGE].n, s->R[PA_EDGE].gid, "edge"));
cleanup:
  return st;
}

/* Read on another number of ranks than wrote the set: PT-Scotch
 * repartitions the elements read (R[PA_ELEMENT].aux: their new owner). */
static pa_status repartition_set(pa_dmesh *dm, rset *s) {
  pa_status st = PA_SUCCESS;
  pa__recs *E = &s->R[PA_ELEMENT];
  int *part = pa__malloc((E->n + 1) * sizeof *part);
  st = part ? PA_SUCCESS : pa__error(PA_ERR_MEMORY, __FILE__, __LINE__, "out of memory");
  PA_CALL(pa__agree(dm->comm, st));
  PA_CALL(pa__dmesh_partition(dm->comm, s->lay.dim, (pa_idx)E->n, E->vgid,
                              NULL, part));
  for (size_t i = 0; i < E->n; i++) E->aux[i] = part[i];
cleanup:
  pa__free(part);
  return st;
}

static pa_status read_set(MPI_Comm comm, const char *path, int overlap,
                          pa_dmesh **dmp) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = NULL;
  rset s;
  memset(&s, 0, sizeof s);
  s.comm = comm;
  s.path = path;
  MPI_Comm_rank(comm, &s.rank);
  MPI_Comm_size(comm, &s.size);
  path_base(path, s.base, sizeof s.base);
  manifest_path(s.base, s.mpath, sizeof s.mpath);
  if (s.rank == 0) PA_CALL(read_first_file(&s));
  PA_CALL(pa__agree(comm, st));
  PA_CALL(bcast_set_header(&s));
  PA_CALL(read_my_files(&s));
  PA_CALL(check_set_counts(&s));
  PA_CALL(pa__dmesh_create(comm, s.lay.dim, &dm));
  for (int q = 0; q < s.nval && !st; q++) /* same on every rank: no agreement */
    st = pa__value_define(dm, s.vals[q].kind, s.vals[q].name,
                          value_type(s.vals[q].type), s.vals[q].ncomp,
                          s.vals[q].ref);
  PA_CALL(pa__agree(comm, st));
  if (s.nw != s.size) PA_CALL(repartition_set(dm, &s));
  PA_CALL(pa__dmesh_build(dm, &s.lay, overlap, &s.R[PA_ELEMENT],
                          &s.R[PA_VERTEX], &s.R[PA_BOUNDARY], &s.R[PA_EDGE]));
  *dmp = dm;
  dm = NULL;
cleanup:
  st = pa__agree_end(comm, st);
  pa__free(s.mf.rk);
  for (int k = 0; k < PA_DMESH_NKIND; k++) pa__recs_free(&s.R[k]);
  pa_dmesh_destroy(dm);
  pa__free(s.vals);
  return st;
}

pa_status pa_dmesh_read(MPI_Comm comm, const char *path, int overlap,
                        pa_dmesh **dmp) {
  pa_status st = PA_SUCCESS;
  int rank = 0, isset = 0;
  pa_mesh *m = NULL;
  pa__agree_reset();
  PA_CHECK(path && dmp, PA_ERR_ARG, "pa_dmesh_read: NULL argument");
  *dmp = NULL;
  MPI_Comm_rank(comm, &rank);
  if (rank == 0) isset = pa_dmesh_is_set(path);
cleanup:
  if (!path || !dmp) return st;
  st = pa__agree(comm, st);
  if (st) return st;
  MPI_Bcast(&isset, 1, MPI_INT, 0, comm);
  if (isset) {
    /* A file made or edited by hand may hold what the remeshers cannot
     * take (one element listed twice, two on the same side of a face):
     * each rank checks its part, then the faces between the parts. */
    st = read_set(comm, path, overlap, dmp);
    if (st == PA_SUCCESS) {
      pa_dmesh *dm = *dmp;
      st = pa__agree(comm, pa__mesh_check_elements(dm->mesh));
      if (st == PA_SUCCESS)
        st = pa__faces_conform(comm, dm->dim, dm->nown[PA_ELEMENT],
                               dm->mesh->elem, dm->mesh->nv,
                               dm->gid[PA_VERTEX], dm->gid[PA_ELEMENT]);
    }
    if (st && !strstr(pa_last_error(), path)) { /* the entity, not the file */
      char msg[600];
      snprintf(msg, sizeof msg, "%s: %s", path, pa_last_error());
      st = pa_set_error(st, "%s", msg);
    }
    if (st) {
      pa_dmesh_destroy(*dmp);
      *dmp = NULL;
    }
    return st;
  }
  if (rank == 0) st = pa_mesh_read(path, &m);
  st = pa__agree(comm, st);
  if (!st) st = pa_dmesh_distribute(comm, 0, m, overlap, dmp);
  pa_mesh_destroy(m);
  return st;
}

pa_status pa_dmesh_read_gathered(MPI_Comm comm, int root, const char *path,
                                 pa_mesh **mesh) {
  pa_status st = PA_SUCCESS;
  int rank = 0, size = 1, isset = 0;
  pa_dmesh *dm = NULL;
  pa__agree_reset();
  PA_CHECK(path && mesh, PA_ERR_ARG, "pa_dmesh_read_gathered: NULL argument");
  *mesh = NULL;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  PA_CHECK(root >= 0 && root < size, PA_ERR_ARG, "root %d out of range", root);
  if (rank == root) isset = pa_dmesh_is_set(path);
cleanup:
  if (!path || !mesh) return st;
  st = pa__agree(comm, st);
  if (st) return st;
  MPI_Bcast(&isset, 1, MPI_INT, root, comm);
  if (!isset) {
    if (rank == root) st = pa_mesh_read(path, mesh);
    return pa__agree(comm, st);
  }
  st = pa_dmesh_read(comm, path, 0, &dm);
  if (!st) st = pa_dmesh_gather(dm, root, mesh);
  pa_dmesh_destroy(dm);
  return st;
}

/* ---- the collective end of output transactions ---- */

/* How long a rank that has entered the last agreement of a commit, and then
 * received SIGINT or SIGTERM, waits for the other ranks before it gives up
 * (one of them is gone): ranks that are alive come within microseconds
 * (the first agreement brought them all there), and Open MPI's mpiexec
 * kills a job with SIGKILL a second after its SIGTERM. */
#define PA_OUTPUT_GRACE_S 0.5
/* The pause between two tests of that agreement. */
#define PA_OUTPUT_POLL_NS 100000

/* The last agreement of a commit: a barrier that every rank enters only once
 * the first agreement completed on it, so that no rank passes it when
 * another died before. Tested without blocking, SIGINT and SIGTERM blocked:
 * returns 1 when every rank is in, 0 when a signal came and the others did
 * not within PA_OUTPUT_GRACE_S. */
static int commit_barrier(MPI_Comm comm) {
  MPI_Request rq;
  double since = -1;
  if (MPI_Ibarrier(comm, &rq) != MPI_SUCCESS) return 0;
  for (;;) {
    int done = 0;
    if (MPI_Test(&rq, &done, MPI_STATUS_IGNORE) != MPI_SUCCESS) return 0;
    if (done) return 1;
    if (pa__output_signal_pending()) {
      if (since < 0) since = pa_wtime();
      if (pa_wtime() - since > PA_OUTPUT_GRACE_S) return 0;
    }
    struct timespec pause = {0, PA_OUTPUT_POLL_NS};
    nanosleep(&pause, NULL);
  }
}

pa_status pa__output_end(MPI_Comm comm, pa_output *tx, pa_status st) {
  int outer = pa__output_depth() == 1; /* a nested end only reports */
  if (outer && st == PA_SUCCESS) pa__output_hook("written");
  st = pa__agree_end(comm, st);
  if (st) {
    pa_output_abort(tx);
    return st;
  }
  if (!outer) return pa__agree(comm, pa_output_commit(tx));
  pa__output_hook("voted");
  sigset_t old;
  pa__output_hold_begin(&old);
  if (!commit_barrier(comm)) {
    pa_output_abort(tx);
    st = pa_set_error(PA_ERR_IO, "interrupted: another process did not come "
                                 "to commit the outputs; nothing written");
    pa__output_hold_end(&old, 0); /* the pending signal ends the process */
    return st;
  }
  pa__output_hook("agreed");
  st = pa_output_commit(tx);
  pa__output_hook("committed");
  st = pa__agree(comm, st);
  pa__output_hold_end(&old, 1);
  return st;
}

pa_status pa_output_end(MPI_Comm comm, pa_output *tx, pa_status st) {
  pa__agree_reset();
  return pa__output_end(comm, tx, st);
}
