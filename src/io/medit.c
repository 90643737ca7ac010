/*
 * medit.c -- Medit mesh files (.mesh ASCII, .meshb binary) and the keyword
 * file layer (pa__gmf reader, pa__gmfw writer) they share with .sol/.solb.
 *
 * A Medit file is a sequence of keywords, libMeshb's layout:
 *  - ASCII: a keyword name, for most keywords a record count, then the
 *    records as numbers separated by white space; '#' starts a comment that
 *    runs to the end of the line. MeshVersionFormatted 1 (float) and 2
 *    (double) read the same way; we write 2.
 *  - binary: the code word 1 (written in the writer's byte order; read back
 *    as 16777216 it means "swap bytes"), the version, then per keyword: its
 *    code (int32), the byte position of the next keyword (int32 in versions
 *    1-2, int64 in 3-4; 0 for the last one), for table keywords the record
 *    count (int32, int64 in version 4) and the packed records: reals are float
 *    in version 1 and double otherwise, integers int32 in versions 1-3 and
 *    int64 in version 4. Dimension carries one int32; End carries nothing.
 *
 * Reader invariants (pa__gmf):
 *  - nothing is read past the end of the file or of a buffer: a count is
 *    checked against the bytes left in the file before anything is allocated
 *    for it (an ASCII number takes at least 2 bytes), so a corrupt count fails
 *    cleanly instead of allocating gigabytes;
 *  - ASCII goes through a 1 MiB window, so memory does not grow with the file;
 *    a token always lies whole in the window followed by white space or the
 *    NUL kept at buf[blen], so strtod never reads past it;
 *  - binary keywords are visited through their next-position fields, which
 *    must point forward and inside the file (no loop, no seek out of range);
 *  - errors are PA_ERR_FORMAT (PA_ERR_IO for open/read failures,
 *    PA_ERR_UNSUPPORTED for well-formed but unsupported contents) with the
 *    message "FILE:LINE: ..." (ASCII) or "FILE: byte OFFSET: ..." (binary).
 *
 * Mesh mapping (struct pa_mesh, 0-based; files are 1-based):
 *  - 2D: Triangles are the elements and Edges the boundary entities; 3D:
 *    Tetrahedra are the elements, Triangles the boundary, Edges the feature
 *    edges (mesh->edge);
 *  - a file of Dimension 3 with triangles, no tetrahedra and z == 0 at every
 *    vertex is read as a 2D mesh (some tools write planar meshes that way);
 *  - Corners / RequiredVertices set PA_FLAG_CORNER / PA_FLAG_REQUIRED on
 *    vertices; Ridges / RequiredEdges set PA_FLAG_RIDGE / PA_FLAG_REQUIRED on
 *    the Edges entities (boundary edges in 2D, feature edges in 3D);
 *    RequiredTriangles and RequiredTetrahedra set PA_FLAG_REQUIRED; the
 *    vertices of a ridge edge get PA_FLAG_RIDGE. The writer emits these
 *    sections from the flags; other flag bits (PA_FLAG_USER, a ridge flag on
 *    a vertex of no ridge edge or on a triangle) have no Medit keyword and
 *    are not written. The metric and fields go to .sol files (sol.c).
 *  - an index is checked as its section is read when the section it refers to
 *    was read before (the usual order); otherwise once the file is read, and
 *    the message then names the line of the referring section's keyword.
 *  - harmless keywords (normals, tangents, geometry links, Mmg's Parallel*)
 *    are skipped by their documented layout; quadrilaterals, prisms,
 *    hexahedra, pyramids and the high-order elements Gmsh writes
 *    (TrianglesP2...) are PA_ERR_UNSUPPORTED (straight-sided simplex meshes
 *    only). Keywords of no layout known here (FreeFem++'s SubDomainFromMesh,
 *    VertexOnGeometricEdge...) are skipped as libMeshb and Mmg skip them: in
 *    ASCII up to the next word that is not a number, in binary to their
 *    next-keyword position. A note at verbosity 1 names what was skipped;
 *    a file left with vertices and no elements after skipping an unknown
 *    keyword is refused, naming it (a misspelt Triangles, say).
 */
#include "io/fmt.h"
#include "io/medit.h"
#include "io/output.h"

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <sys/stat.h>

#define GMF_WINDOW ((size_t)1 << 20) /* ASCII read window */
#define GMF_CHUNK_WORDS                                                        \
  ((size_t)1 << 19)                /* values per pa__gmf_records call          \
                                    */
#define GMFW_BUF ((size_t)1 << 20) /* writer buffer */
#define GMFW_SLACK 64              /* room kept for one formatted number */
/* Room for the names of the skipped keywords a note lists: a dozen names,
 * more than the files of FreeFem++, Gmsh and Mmg hold. */
#define GMF_SKIPPED_ROOM 256

/* ------------------------------------------------------------------------ */
/* Keyword table                                                            */
/* ------------------------------------------------------------------------ */

/* rec: layout of one record, to skip keywords padapt does not use:
 * 'i' integer, 'r' real, 'R' dim reals, 'S' solution (types header then
 * reals), 's' one string, 'L' one line of text. */
typedef struct gmf_kwd {
  const char *name;
  int code;
  int counted; /* a record count follows the name */
  const char *rec;
} gmf_kwd;

static const gmf_kwd gmf_kwds[] = {
    {"MeshVersionFormatted", 1, 0, "i"},
    {"Dimension", PA_IO_GMF_DIMENSION, 0, "i"},
    {"Vertices", PA_IO_GMF_VERTICES, 1, "Ri"},
    {"Edges", PA_IO_GMF_EDGES, 1, "iii"},
    {"Triangles", PA_IO_GMF_TRIANGLES, 1, "iiii"},
    {"Quadrilaterals", PA_IO_GMF_QUADRILATERALS, 1, "iiiii"},
    {"Tetrahedra", PA_IO_GMF_TETRAHEDRA, 1, "iiiii"},
    {"Prisms", PA_IO_GMF_PRISMS, 1, "iiiiiii"},
    {"Hexahedra", PA_IO_GMF_HEXAHEDRA, 1, "iiiiiiiii"},
    {"RequiredTetrahedra", PA_IO_GMF_REQUIRED_TETRAHEDRA, 1, "i"},
    {"Corners", PA_IO_GMF_CORNERS, 1, "i"},
    {"Ridges", PA_IO_GMF_RIDGES, 1, "i"},
    {"RequiredVertices", PA_IO_GMF_REQUIRED_VERTICES, 1, "i"},
    {"RequiredEdges", PA_IO_GMF_REQUIRED_EDGES, 1, "i"},
    {"RequiredTriangles", PA_IO_GMF_REQUIRED_TRIANGLES, 1, "i"},
    {"RequiredQuadrilaterals", 18, 1, "i"},
    {"TangentAtEdgeVertices", 19, 1, "iii"},
    {"NormalAtVertices", 20, 1, "ii"},
    {"NormalAtTriangleVertices", 21, 1, "iii"},
    {"NormalAtQuadrilateralVertices", 22, 1, "iiii"},
    {"AngleOfCornerBound", 23, 0, "r"},
    {"TrianglesP2", 24, 1, "iiiiiii"},
    {"EdgesP2", 25, 1, "iiii"},
    {"QuadrilateralsQ2", 27, 1, "iiiiiiiiii"},
    {"TetrahedraP2", 30, 1, "iiiiiiiiiii"},
    {"HexahedraQ2", 33, 1, "iiiiiiiiiiiiiiiiiiiiiiiiiiii"},
    {"VerticesOnGeometricVertices", 40, 1, "ii"},
    {"VerticesOnGeometricEdges", 41, 1, "iirr"},
    {"VerticesOnGeometricTriangles", 42, 1, "iirrr"},
    {"VerticesOnGeometricQuadrilaterals", 43, 1, "iirrr"},
    {"EdgesOnGeometricEdges", 44, 1, "ii"},
    {"Pyramids", PA_IO_GMF_PYRAMIDS, 1, "iiiiii"},
    {"BoundingBox", 50, 0, "RR"},
    {"End", PA_IO_GMF_END, 0, ""},
    {"TrianglesOnGeometricTriangles", 55, 1, "ii"},
    {"TrianglesOnGeometricQuadrilaterals", 56, 1, "ii"},
    {"QuadrilateralsOnGeometricTriangles", 57, 1, "ii"},
    {"QuadrilateralsOnGeometricQuadrilaterals", 58, 1, "ii"},
    {"Tangents", 59, 1, "R"},
    {"Normals", 60, 1, "R"},
    {"TangentAtVertices", 61, 1, "ii"},
    {"SolAtVertices", PA_IO_GMF_SOL_AT_VERTICES, 1, "S"},
    {"SolAtEdges", 63, 1, "S"},
    {"SolAtTriangles", 64, 1, "S"},
    {"SolAtQuadrilaterals", 65, 1, "S"},
    {"SolAtTetrahedra", 66, 1, "S"},
    {"SolAtPrisms", 67, 1, "S"},
    {"SolAtHexahedra", 68, 1, "S"},
    {"Iterations", 77, 0, "i"},
    {"Time", 78, 0, "r"},
    {"Comments", 81, 1, "L"},
    /* Not in libMeshb: Medit's and Mmg's own keywords (codes of our own). */
    {"Identifier", 1001, 0, "s"},
    {"Geometry", 1002, 0, "s"},
    {"ParallelVertices", 1003, 1, "i"},
    {"ParallelEdges", 1004, 1, "i"},
    {"ParallelTriangles", 1005, 1, "i"},
    {"ParallelQuadrilaterals", 1006, 1, "i"},
    {"ParallelTetrahedra", 1007, 1, "i"},
};
#define GMF_NKWD ((int)(sizeof gmf_kwds / sizeof *gmf_kwds))

/* Elements padapt does not support (not simplices, or high-order): their
 * records are their vertices and a reference. */
static const int gmf_cells[] = {PA_IO_GMF_QUADRILATERALS,
                                PA_IO_GMF_PRISMS,
                                PA_IO_GMF_HEXAHEDRA,
                                PA_IO_GMF_PYRAMIDS,
                                24 /* TrianglesP2 */,
                                25 /* EdgesP2 */,
                                27 /* QuadrilateralsQ2 */,
                                30 /* TetrahedraP2 */,
                                33 /* HexahedraQ2 */};

static const gmf_kwd *kwd_by_code(int code) {
  for (int i = 0; i < GMF_NKWD; i++)
    if (gmf_kwds[i].code == code) return &gmf_kwds[i];
  return NULL;
}

static const gmf_kwd *kwd_by_name(const char *s, size_t n) {
  for (int i = 0; i < GMF_NKWD; i++)
    if (strlen(gmf_kwds[i].name) == n && !memcmp(gmf_kwds[i].name, s, n))
      return &gmf_kwds[i];
  return NULL;
}

const char *pa__gmf_kwd_name(int code) {
  const gmf_kwd *k = kwd_by_code(code);
  return k ? k->name : "?";
}

int pa__gmf_default_version(int64_t bytes) {
  return bytes < INT32_MAX - ((int64_t)1 << 20) ? 2 : 3;
}

/* ------------------------------------------------------------------------ */
/* Reader                                                                   */
/* ------------------------------------------------------------------------ */

struct pa__gmf {
  const char *path;
  FILE *fp;
  int binary;
  int swap;       /* binary: the file's byte order is not ours */
  int ver;        /* 1..4 (ASCII: 2 until MeshVersionFormatted) */
  int dim;        /* 0 until Dimension */
  int kwd;        /* code of the current keyword */
  int last;       /* no keyword after the current one */
  int64_t fsize;  /* bytes in the file */
  int64_t kwdloc; /* location of the current keyword */
  /* ASCII window: buf[0 .. blen) holds file bytes [boff, boff + blen) */
  char *buf;
  size_t blen, bpos;
  int64_t boff;
  int eof, comment;
  long line;    /* line of buf[bpos] */
  long tokline; /* line of the last token */
  /* binary */
  int64_t off;    /* offset of the next byte to read */
  int64_t tokoff; /* offset of the last item read */
  int64_t next;   /* position of the next keyword (0: none) */
  unsigned char *raw;
  size_t rawcap;
  /* records of the last pa__gmf_records call */
  double *rv;
  size_t rvcap;
  int64_t *iv;
  size_t ivcap;
  long *recline;
  size_t reclinecap;
  int64_t recoff;
  size_t recsize;
  /* keywords skipped so far, for the note at the end of the file */
  char skipped[GMF_SKIPPED_ROOM]; /* "Identifier, SubDomainFromMesh" */
  int skipmore;                   /* more names than the room holds */
  int64_t unknown;                /* location of the first one not in
                                     gmf_kwds, -1 if none */
  int noted;
};

int pa__gmf_dim(const pa__gmf *g) { return g->dim; }

int64_t pa__gmf_loc(const pa__gmf *g) {
  return g->binary ? g->tokoff : (int64_t)g->tokline;
}

int64_t pa__gmf_rec_loc(const pa__gmf *g, size_t k) {
  return g->binary ? g->recoff + (int64_t)(k * g->recsize)
                   : (int64_t)g->recline[k];
}

int64_t pa__gmf_kwd_loc(const pa__gmf *g) { return g->kwdloc; }

pa_status pa__gmf_error(const pa__gmf *g, int64_t loc, pa_status code,
                        const char *fmt, ...) {
  char msg[768];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(msg, sizeof msg, fmt, ap);
  va_end(ap);
  char where[600];
  pa__gmf_where(g, loc, where, sizeof where);
  return pa__error(code, __FILE__, __LINE__, "%s: %s", where, msg);
}

void pa__gmf_where(const pa__gmf *g, int64_t loc, char *buf, size_t n) {
  if (g->binary)
    snprintf(buf, n, "%s: byte %lld", g->path, (long long)loc);
  else
    snprintf(buf, n, "%s:%lld", g->path, (long long)loc);
}

/* Add a keyword to the list of those skipped, once. */
static void note_skip(pa__gmf *g, const char *name, size_t n, int unknown) {
  size_t len = strlen(g->skipped);
  if (unknown && g->unknown < 0) g->unknown = g->kwdloc;
  for (const char *p = g->skipped; *p;) {
    size_t l = strcspn(p, ",");
    if (l == n && !memcmp(p, name, n)) return;
    p += l;
    p += *p ? 2 : 0;
  }
  if (len + n + 3 > sizeof g->skipped) {
    g->skipmore = 1;
    return;
  }
  if (len) {
    memcpy(g->skipped + len, ", ", 2);
    len += 2;
  }
  memcpy(g->skipped + len, name, n);
  g->skipped[len + n] = '\0';
}

static void note_skip_code(pa__gmf *g, int code) {
  const gmf_kwd *k = kwd_by_code(code);
  char buf[32];
  if (k) {
    note_skip(g, k->name, strlen(k->name), 0);
    return;
  }
  int n = snprintf(buf, sizeof buf, "code %d", code);
  note_skip(g, buf, (size_t)n, 1);
}

/* At the end of the file: the note naming the keywords skipped. */
static void note_end(pa__gmf *g) {
  if (!g->skipped[0] || g->noted) return;
  g->noted = 1;
  pa__info(1, "padapt: %s: skipped the keywords padapt does not use: %s%s\n",
           g->path, g->skipped, g->skipmore ? " and more" : "");
}

const char *pa__gmf_skipped(const pa__gmf *g, int64_t *unknown) {
  if (unknown) *unknown = g->unknown;
  return g->skipped;
}

/* Name of the current keyword for messages. */
static const char *cur_name(const pa__gmf *g) {
  const gmf_kwd *k = kwd_by_code(g->kwd);
  return k ? k->name : "keyword";
}

/* Printable, shortened copy of a token for messages. */
static const char *tokstr(const char *t, size_t n, char out[48]) {
  size_t m = n < 40 ? n : 40, i;
  for (i = 0; i < m; i++) {
    unsigned char c = (unsigned char)t[i];
    out[i] = (c >= 32 && c < 127) ? (char)c : '?';
  }
  if (m < n) {
    memcpy(out + m, "...", 3);
    m += 3;
  }
  out[m] = '\0';
  return out;
}

static inline uint32_t rd32(const unsigned char *p, int swap) {
  uint32_t x;
  memcpy(&x, p, 4);
  return swap ? __builtin_bswap32(x) : x;
}

static inline uint64_t rd64(const unsigned char *p, int swap) {
  uint64_t x;
  memcpy(&x, p, 8);
  return swap ? __builtin_bswap64(x) : x;
}

/* Binary: read n bytes at the current offset. */
static pa_status bin_read(pa__gmf *g, void *dst, size_t n) {
  pa_status st = PA_SUCCESS;
  if ((int64_t)n > g->fsize - g->off)
    PA_IO_GMF_FAIL(g, g->off,
                   "unexpected end of file: %zu bytes needed, %lld left "
                   "(truncated file?)",
                   n, (long long)(g->fsize - g->off));
  if (n && fread(dst, 1, n, g->fp) != n)
    PA_FAIL(PA_ERR_IO, "%s: read error at byte %lld: %s", g->path,
            (long long)g->off, ferror(g->fp) ? strerror(errno) : "short read");
  g->tokoff = g->off;
  g->off += (int64_t)n;
cleanup:
  return st;
}

static pa_status bin_seek(pa__gmf *g, int64_t pos) {
  pa_status st = PA_SUCCESS;
  if (pos == g->off) return PA_SUCCESS;
  PA_CHECK(fseeko(g->fp, (off_t)pos, SEEK_SET) == 0, PA_ERR_IO,
           "%s: cannot seek to byte %lld: %s", g->path, (long long)pos,
           strerror(errno));
  g->off = pos;
cleanup:
  return st;
}

/* Integer size, real size and position size of a binary file. */
static size_t int_size(const pa__gmf *g) { return g->ver >= 4 ? 8 : 4; }
static size_t real_size(const pa__gmf *g) { return g->ver == 1 ? 4 : 8; }
static size_t pos_size(const pa__gmf *g) { return g->ver >= 3 ? 8 : 4; }

static inline int is_space(char c) {
  return c == ' ' || c == '\n' || c == '\t' || c == '\r' || c == '\v' ||
         c == '\f';
}

/* ASCII: drop buf[0 .. keep) and read more bytes after the rest. */
static pa_status refill(pa__gmf *g, size_t keep) {
  pa_status st = PA_SUCCESS;
  size_t rest = g->blen - keep;
  memmove(g->buf, g->buf + keep, rest);
  g->boff += (int64_t)keep;
  g->bpos -= keep;
  g->blen = rest;
  size_t want = GMF_WINDOW - rest;
  size_t got = fread(g->buf + rest, 1, want, g->fp);
  if (got < want) {
    PA_CHECK(!ferror(g->fp), PA_ERR_IO, "%s: read error: %s", g->path,
             strerror(errno));
    g->eof = 1;
  }
  g->blen += got;
  g->buf[g->blen] = '\0';
cleanup:
  return st;
}

/* ASCII: next token (*tok = NULL at the end of the file). */
static pa_status next_token(pa__gmf *g, const char **tok, size_t *len) {
  pa_status st = PA_SUCCESS;
  *tok = NULL;
  *len = 0;
  for (;;) {
    if (g->bpos == g->blen) {
      if (g->eof) return PA_SUCCESS;
      PA_CALL(refill(g, g->blen));
      continue;
    }
    char c = g->buf[g->bpos];
    if (c == '\n') {
      g->comment = 0;
      g->line++;
      g->bpos++;
    } else if (g->comment || is_space(c)) {
      g->bpos++;
    } else if (c == '#') {
      g->comment = 1;
      g->bpos++;
    } else {
      break;
    }
  }
  size_t e = g->bpos;
  for (;;) {
    while (e < g->blen && !is_space(g->buf[e]))
      e++;
    if (e < g->blen || g->eof) break;
    /* The token reaches the end of the window: keep it and read more. */
    if (g->bpos == 0)
      PA_IO_GMF_FAIL(g, g->line,
                     "a token longer than %zu bytes (not a Medit "
                     "ASCII file?)",
                     GMF_WINDOW);
    size_t rel = e - g->bpos;
    PA_CALL(refill(g, g->bpos));
    e = rel;
  }
  *tok = g->buf + g->bpos;
  *len = e - g->bpos;
  g->tokline = g->line;
  g->bpos = e;
cleanup:
  return st;
}

/* Parse a whole token as a decimal integer; 0 if it is not one. */
static int parse_int(const char *s, size_t n, int64_t *v) {
  size_t i = 0;
  int neg = 0;
  uint64_t x = 0;
  if (i < n && (s[i] == '-' || s[i] == '+')) neg = s[i++] == '-';
  if (i == n) return 0;
  for (; i < n; i++) {
    unsigned d = (unsigned)(unsigned char)s[i] - '0';
    if (d > 9 || x > (uint64_t)INT64_MAX / 10 - 1) return 0;
    x = x * 10 + d;
  }
  *v = neg ? -(int64_t)x : (int64_t)x;
  return 1;
}

/* Parse a whole token as a real number; 0 if it is not one. The token is
 * followed by white space or NUL, so strtod stops inside the window. */
static int parse_real(const char *s, size_t n, double *v) {
  char *end;
  *v = strtod(s, &end);
  return end == s + n;
}

/* ASCII: read an integer token; what names it in messages. */
static pa_status tok_int(pa__gmf *g, const char *what, int64_t *v) {
  pa_status st = PA_SUCCESS;
  const char *t;
  size_t n;
  char buf[48];
  PA_CALL(next_token(g, &t, &n));
  if (!t)
    PA_IO_GMF_FAIL(g, g->line, "unexpected end of file: expected %s", what);
  if (!parse_int(t, n, v))
    PA_IO_GMF_FAIL(g, g->tokline, "expected %s, found '%s'", what,
                   tokstr(t, n, buf));
cleanup:
  return st;
}

/* The first bytes of a file are those of ASCII Medit: printable text
 * starting, after white space, with a keyword. */
static int looks_ascii(const unsigned char *h, size_t n) {
  size_t i = 0;
  while (i < n && is_space((char)h[i]))
    i++;
  if (i == n || !isalpha(h[i])) return 0;
  for (; i < n; i++)
    if (!is_space((char)h[i]) && (h[i] < 32 || h[i] > 126)) return 0;
  return 1;
}

pa_status pa__gmf_open(const char *path, int binary, pa__gmf **out) {
  pa_status st = PA_SUCCESS;
  pa__gmf *g = NULL;
  struct stat sb;
  *out = NULL;
  PA_CALLOC(g, 1);
  g->path = path;
  g->binary = binary;
  g->ver = 2;
  g->line = g->tokline = 1;
  g->unknown = -1;
  g->fp = fopen(path, "rb");
  PA_CHECK(g->fp, PA_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
  PA_CHECK(fstat(fileno(g->fp), &sb) == 0, PA_ERR_IO, "%s: cannot stat: %s",
           path, strerror(errno));
  PA_CHECK(!S_ISDIR(sb.st_mode), PA_ERR_IO, "%s: is a directory", path);
  g->fsize = (int64_t)sb.st_size;
  if (binary) {
    unsigned char h[8];
    PA_CALL(bin_read(g, h, 8));
    uint32_t code;
    memcpy(&code, h, 4);
    if (code == 1 || code == 0x01000000u) {
      g->swap = code != 1;
      int32_t ver = (int32_t)rd32(h + 4, g->swap);
      if (ver < 1 || ver > 4)
        PA_IO_GMF_FAIL(g, 4, "unsupported binary Medit version %d (1 to 4)",
                       (int)ver);
      g->ver = ver;
    } else if (looks_ascii(h, sizeof h)) {
      /* FreeFem++'s 2D savemesh writes ASCII whatever the extension. */
      pa__info(1,
               "padapt: %s: an ASCII Medit file under a binary name, read "
               "as ASCII\n",
               path);
      PA_CALL(bin_seek(g, 0));
      g->binary = 0;
    } else {
      PA_IO_GMF_FAIL(g, 0,
                     "not a binary Medit file: the code word is %u, expected 1",
                     (unsigned)code);
    }
  }
  if (!g->binary) {
    PA_ALLOC(g->buf, GMF_WINDOW + 1);
    g->buf[0] = '\0';
  }
  *out = g;
  g = NULL;
cleanup:
  pa__gmf_close(g);
  return st;
}

void pa__gmf_close(pa__gmf *g) {
  if (!g) return;
  if (g->fp) fclose(g->fp);
  pa__free(g->buf);
  pa__free(g->raw);
  pa__free(g->rv);
  pa__free(g->iv);
  pa__free(g->recline);
  pa__free(g);
}

static pa_status set_dim(pa__gmf *g, int64_t d, int64_t loc) {
  pa_status st = PA_SUCCESS;
  if (d != 2 && d != 3)
    PA_IO_GMF_FAIL(g, loc, "Dimension must be 2 or 3, got %lld", (long long)d);
  if (g->dim && g->dim != d)
    PA_IO_GMF_FAIL(g, loc,
                   "Dimension %lld contradicts the earlier Dimension %d",
                   (long long)d, g->dim);
  g->dim = (int)d;
cleanup:
  return st;
}

pa_status pa__gmf_done(pa__gmf *g) {
  pa_status st = PA_SUCCESS;
  if (!g->binary) return PA_SUCCESS;
  if (!g->next) {
    g->last = 1;
    return PA_SUCCESS;
  }
  if (g->off > g->next)
    PA_IO_GMF_FAIL(g, g->kwdloc,
                   "%s: the data runs past the next keyword position %lld",
                   cur_name(g), (long long)g->next);
  PA_CALL(bin_seek(g, g->next));
cleanup:
  return st;
}

static pa_status next_binary(pa__gmf *g, int *code) {
  pa_status st = PA_SUCCESS;
  unsigned char h[16];
  size_t ps = pos_size(g);
  for (;;) {
    if (g->last) {
      g->kwd = PA_IO_GMF_END;
      break;
    }
    int64_t start = g->off;
    if (start >= g->fsize)
      PA_IO_GMF_FAIL(g, start,
                     "unexpected end of file: no End keyword "
                     "(truncated file?)");
    PA_CALL(bin_read(g, h, 4 + ps));
    int c = (int32_t)rd32(h, g->swap);
    int64_t pos = ps == 8 ? (int64_t)rd64(h + 4, g->swap)
                          : (int64_t)(int32_t)rd32(h + 4, g->swap);
    g->kwdloc = g->tokoff = start;
    g->kwd = c;
    if (c == PA_IO_GMF_END) {
      g->last = 1;
      break;
    }
    if (pos != 0 && (pos < g->off || pos > g->fsize))
      PA_IO_GMF_FAIL(g, start,
                     "keyword %d (%s): next keyword position %lld is outside "
                     "[%lld, %lld] (corrupt or truncated file)",
                     c, pa__gmf_kwd_name(c), (long long)pos, (long long)g->off,
                     (long long)g->fsize);
    g->next = pos;
    if (c == PA_IO_GMF_DIMENSION) {
      unsigned char d[4];
      PA_CALL(bin_read(g, d, 4));
      PA_CALL(set_dim(g, (int32_t)rd32(d, g->swap), g->tokoff));
      PA_CALL(pa__gmf_done(g));
      continue;
    }
    *code = c;
    break;
  }
cleanup:
  return st;
}

/* ASCII: the rest of a string that opened with token t ("several words"
 * in double quotes spread over tokens). */
static pa_status skip_quoted(pa__gmf *g, const char *t, size_t len) {
  pa_status st = PA_SUCCESS;
  if (t[0] != '"' || (len >= 2 && t[len - 1] == '"')) return PA_SUCCESS;
  do {
    PA_CALL(next_token(g, &t, &len));
  } while (t && t[len - 1] != '"');
  if (!t)
    PA_IO_GMF_FAIL(g, g->line, "unexpected end of file in a string of %s",
                   cur_name(g));
cleanup:
  return st;
}

/* A keyword name that is not in gmf_kwds is skipped with what follows it up
 * to the next word that is not a number (the next keyword), as libMeshb and
 * Mmg do: its layout is unknown, but records are numbers and strings. */
static pa_status next_ascii(pa__gmf *g, int *code) {
  pa_status st = PA_SUCCESS;
  const char *t;
  size_t n;
  char buf[48];
  int skipping = 0; /* inside the data of an unknown keyword */
  for (;;) {
    int64_t v;
    double x;
    PA_CALL(next_token(g, &t, &n));
    if (!t) {
      g->kwd = PA_IO_GMF_END;
      break;
    }
    if (!isalpha((unsigned char)t[0]) || parse_real(t, n, &x)) {
      if (!skipping)
        PA_IO_GMF_FAIL(g, g->tokline,
                       "expected a keyword, found '%s' (a count smaller than "
                       "the data?)",
                       tokstr(t, n, buf));
      PA_CALL(skip_quoted(g, t, n));
      continue;
    }
    g->kwdloc = g->tokline;
    const gmf_kwd *k = kwd_by_name(t, n);
    if (!k) {
      tokstr(t, n, buf);
      note_skip(g, buf, strlen(buf), 1);
      g->kwd = 0;
      skipping = 1;
      continue;
    }
    skipping = 0;
    g->kwd = k->code;
    if (k->code == 1) {
      PA_CALL(tok_int(g, "the MeshVersionFormatted number", &v));
      if (v < 1 || v > 4)
        PA_IO_GMF_FAIL(g, g->tokline,
                       "MeshVersionFormatted must be 1 to 4, got "
                       "%lld",
                       (long long)v);
      g->ver = (int)v;
      continue;
    }
    if (k->code == PA_IO_GMF_DIMENSION) {
      PA_CALL(tok_int(g, "the dimension", &v));
      PA_CALL(set_dim(g, v, g->tokline));
      continue;
    }
    if (k->code == PA_IO_GMF_END) {
      g->last = 1;
      break;
    }
    *code = k->code;
    break;
  }
cleanup:
  return st;
}

pa_status pa__gmf_next(pa__gmf *g, int *code) {
  *code = PA_IO_GMF_END;
  pa_status st = g->binary ? next_binary(g, code) : next_ascii(g, code);
  if (st == PA_SUCCESS && *code == PA_IO_GMF_END) note_end(g);
  return st;
}

int pa__gmf_unsupported_cell(int code) {
  for (size_t i = 0; i < sizeof gmf_cells / sizeof *gmf_cells; i++)
    if (gmf_cells[i] == code) return (int)strlen(kwd_by_code(code)->rec);
  return 0;
}

pa_status pa__gmf_check_room(pa__gmf *g, pa_idx n, int nreal, int nint) {
  pa_status st = PA_SUCCESS;
  int64_t left, need;
  if (g->binary) {
    left = g->fsize - g->off;
    need = (int64_t)n * (int64_t)(nreal * real_size(g) + nint * int_size(g));
  } else {
    /* Each number takes a character and a separator (none after the last). */
    left = g->fsize - (g->boff + (int64_t)g->bpos);
    need = n ? (int64_t)n * (nreal + nint) * 2 - 1 : 0;
  }
  if (need > left)
    PA_IO_GMF_FAIL(
        g, pa__gmf_loc(g),
        "%s: count %d does not fit in the %lld bytes left in the file "
        "(truncated file or corrupt count)",
        cur_name(g), (int)n, (long long)left);
cleanup:
  return st;
}

pa_status pa__gmf_count(pa__gmf *g, int nreal, int nint, pa_idx *n) {
  pa_status st = PA_SUCCESS;
  int64_t v;
  char what[96];
  *n = 0;
  if (!g->dim)
    PA_IO_GMF_FAIL(g, g->kwdloc, "%s before Dimension (missing Dimension)",
                   cur_name(g));
  if (g->binary) {
    unsigned char b[8];
    PA_CALL(bin_read(g, b, int_size(g)));
    v = int_size(g) == 8 ? (int64_t)rd64(b, g->swap)
                         : (int64_t)(int32_t)rd32(b, g->swap);
  } else {
    snprintf(what, sizeof what, "the number of %s", cur_name(g));
    PA_CALL(tok_int(g, what, &v));
  }
  if (v < 0)
    PA_IO_GMF_FAIL(g, pa__gmf_loc(g), "negative count %lld for %s",
                   (long long)v, cur_name(g));
  if (v > INT32_MAX)
    PA_IO_GMF_FAIL(g, pa__gmf_loc(g),
                   "count %lld for %s is too large (at most "
                   "%d)",
                   (long long)v, cur_name(g), INT32_MAX);
  PA_CALL(pa__gmf_check_room(g, (pa_idx)v, nreal, nint));
  *n = (pa_idx)v;
cleanup:
  return st;
}

pa_status pa__gmf_word(pa__gmf *g, int *value) {
  pa_status st = PA_SUCCESS;
  int64_t v;
  char what[96];
  if (g->binary) {
    unsigned char b[4];
    PA_CALL(bin_read(g, b, 4));
    v = (int32_t)rd32(b, g->swap);
  } else {
    snprintf(what, sizeof what, "an integer in the %s header", cur_name(g));
    PA_CALL(tok_int(g, what, &v));
    if (v < INT32_MIN || v > INT32_MAX)
      PA_IO_GMF_FAIL(g, g->tokline, "integer %lld out of range", (long long)v);
  }
  *value = (int)v;
cleanup:
  return st;
}

size_t pa__gmf_chunk(int nreal, int nint) {
  size_t w = (size_t)(nreal + nint);
  size_t n = GMF_CHUNK_WORDS / (w ? w : 1);
  return n ? n : 1;
}

pa_status pa__gmf_records(pa__gmf *g, size_t n, int nreal, int nint,
                          const double **rv, const int64_t **iv) {
  pa_status st = PA_SUCCESS;
  char buf[48];
  PA_GROW(g->rv, g->rvcap, n * nreal + 1);
  PA_GROW(g->iv, g->ivcap, n * nint + 1);
  if (g->binary) {
    size_t rs = real_size(g), is = int_size(g);
    size_t recsize = nreal * rs + nint * is;
    PA_GROW(g->raw, g->rawcap, n * recsize + 1);
    g->recoff = g->off;
    g->recsize = recsize;
    PA_CALL(bin_read(g, g->raw, n * recsize));
    const unsigned char *p = g->raw;
    double *r = g->rv;
    int64_t *x = g->iv;
    for (size_t k = 0; k < n; k++) {
      for (int j = 0; j < nreal; j++, p += rs) {
        if (rs == 4) {
          uint32_t u = rd32(p, g->swap);
          float f;
          memcpy(&f, &u, 4);
          *r++ = f;
        } else {
          uint64_t u = rd64(p, g->swap);
          memcpy(r++, &u, 8);
        }
      }
      for (int j = 0; j < nint; j++, p += is)
        *x++ = is == 4 ? (int64_t)(int32_t)rd32(p, g->swap)
                       : (int64_t)rd64(p, g->swap);
    }
  } else {
    PA_GROW(g->recline, g->reclinecap, n + 1);
    double *r = g->rv;
    int64_t *x = g->iv;
    for (size_t k = 0; k < n; k++) {
      for (int j = 0; j < nreal + nint; j++) {
        const char *t;
        size_t len;
        PA_CALL(next_token(g, &t, &len));
        if (!t)
          PA_IO_GMF_FAIL(
              g, g->line,
              "unexpected end of file in %s (truncated file or count "
              "larger than the data)",
              cur_name(g));
        if (j == 0) g->recline[k] = g->tokline;
        if (j < nreal) {
          if (!parse_real(t, len, r++))
            PA_IO_GMF_FAIL(g, g->tokline,
                           "expected a real number in %s, found "
                           "'%s'",
                           cur_name(g), tokstr(t, len, buf));
        } else if (!parse_int(t, len, x++)) {
          PA_IO_GMF_FAIL(g, g->tokline, "expected an integer in %s, found '%s'",
                         cur_name(g), tokstr(t, len, buf));
        }
      }
    }
  }
  if (rv) *rv = g->rv;
  if (iv) *iv = g->iv;
cleanup:
  return st;
}

/* ASCII: skip to the start of the next line. */
static pa_status skip_line(pa__gmf *g) {
  pa_status st = PA_SUCCESS;
  for (;;) {
    while (g->bpos < g->blen) {
      if (g->buf[g->bpos++] == '\n') {
        g->line++;
        g->comment = 0;
        return PA_SUCCESS;
      }
    }
    if (g->eof) return PA_SUCCESS;
    PA_CALL(refill(g, g->blen));
  }
cleanup:
  return st;
}

/* ASCII: skip count numbers. */
static pa_status skip_numbers(pa__gmf *g, int64_t count) {
  pa_status st = PA_SUCCESS;
  char buf[48];
  for (int64_t i = 0; i < count; i++) {
    const char *t;
    size_t len;
    double v;
    PA_CALL(next_token(g, &t, &len));
    if (!t)
      PA_IO_GMF_FAIL(g, g->line,
                     "unexpected end of file in %s (truncated file "
                     "or count larger than the data)",
                     cur_name(g));
    if (!parse_real(t, len, &v))
      PA_IO_GMF_FAIL(g, g->tokline, "expected a number in %s, found '%s'",
                     cur_name(g), tokstr(t, len, buf));
  }
cleanup:
  return st;
}

pa_status pa__gmf_skip(pa__gmf *g) {
  pa_status st = PA_SUCCESS;
  const gmf_kwd *k;
  pa_idx n = 1;
  note_skip_code(g, g->kwd);
  if (g->binary) return pa__gmf_done(g);
  k = kwd_by_code(g->kwd);
  PA_CHECK(k, PA_ERR_INTERNAL, "pa__gmf_skip: no current keyword");
  if (k->rec[0] == 's') {
    /* One string: a token, or "several words" in double quotes. */
    const char *t;
    size_t len;
    PA_CALL(next_token(g, &t, &len));
    if (!t) PA_IO_GMF_FAIL(g, g->line, "unexpected end of file in %s", k->name);
    return skip_quoted(g, t, len);
  }
  if (k->rec[0] == 'L') {
    PA_CALL(pa__gmf_count(g, 0, 1, &n));
    PA_CALL(skip_line(g));
    for (pa_idx i = 0; i < n; i++) {
      if (g->eof && g->bpos == g->blen)
        PA_IO_GMF_FAIL(g, g->line, "unexpected end of file in %s", k->name);
      PA_CALL(skip_line(g));
    }
    return PA_SUCCESS;
  }
  if (k->rec[0] == 'S') {
    int ntype, size = 0;
    PA_CALL(pa__gmf_count(g, 1, 0, &n));
    PA_CALL(pa__gmf_word(g, &ntype));
    if (ntype < 1 || ntype > PA_IO_GMF_MAX_TYPES)
      PA_IO_GMF_FAIL(g, g->tokline, "%s: %d solution types (1 to %d)", k->name,
                     ntype, PA_IO_GMF_MAX_TYPES);
    for (int i = 0; i < ntype; i++) {
      int t;
      PA_CALL(pa__gmf_word(g, &t));
      if (t < 1 || t > 4)
        PA_IO_GMF_FAIL(g, g->tokline, "%s: solution type %d (1 to 4)", k->name,
                       t);
      size += t == 1   ? 1
              : t == 2 ? g->dim
              : t == 3 ? g->dim * (g->dim + 1) / 2
                       : g->dim * g->dim;
    }
    PA_CALL(pa__gmf_check_room(g, n, size, 0));
    PA_CALL(skip_numbers(g, (int64_t)n * size));
    return PA_SUCCESS;
  }
  int words = 0;
  for (const char *c = k->rec; *c; c++)
    words += *c == 'R' ? g->dim : 1;
  if (k->counted) PA_CALL(pa__gmf_count(g, 0, words, &n));
  PA_CALL(skip_numbers(g, (int64_t)n * words));
cleanup:
  return st;
}

/* ------------------------------------------------------------------------ */
/* Writer                                                                   */
/* ------------------------------------------------------------------------ */

struct pa__gmfw {
  pa__outfile out;
  const char *path;
  int binary, ver, dim;
  int nreal, nint; /* layout of the current keyword's records */
  char *buf;
  size_t len;
  int64_t off; /* bytes written, buffered included */
  int64_t end; /* binary: where the current keyword's data ends */
};

static pa_status wflush(pa__gmfw *w) {
  pa_status st = PA_SUCCESS;
  if (w->len && fwrite(w->buf, 1, w->len, w->out.fp) != w->len)
    PA_FAIL(PA_ERR_IO, "%s: write error: %s", w->path, strerror(errno));
  w->len = 0;
cleanup:
  return st;
}

static pa_status wbytes(pa__gmfw *w, const void *p, size_t n) {
  pa_status st = PA_SUCCESS;
  if (w->len + n > GMFW_BUF) PA_CALL(wflush(w));
  memcpy(w->buf + w->len, p, n);
  w->len += n;
  w->off += (int64_t)n;
cleanup:
  return st;
}

static pa_status w32(pa__gmfw *w, int32_t v) { return wbytes(w, &v, 4); }
static pa_status w64(pa__gmfw *w, int64_t v) { return wbytes(w, &v, 8); }

static pa_status wtext(pa__gmfw *w, const char *fmt, ...)
    __attribute__((format(printf, 2, 3)));
static pa_status wtext(pa__gmfw *w, const char *fmt, ...) {
  pa_status st = PA_SUCCESS;
  char line[256];
  va_list ap;
  va_start(ap, fmt);
  int n = vsnprintf(line, sizeof line, fmt, ap);
  va_end(ap);
  PA_CHECK(n >= 0 && (size_t)n < sizeof line, PA_ERR_INTERNAL,
           "header line too long");
  PA_CALL(wbytes(w, line, (size_t)n));
cleanup:
  return st;
}

pa_status pa__gmfw_open(const char *path, int binary, int version, int dim,
                        pa__gmfw **out) {
  pa_status st = PA_SUCCESS;
  pa__gmfw *w = NULL;
  *out = NULL;
  PA_CHECK(dim == 2 || dim == 3, PA_ERR_ARG, "%s: dimension %d", path, dim);
  PA_CHECK(!binary || (version >= 1 && version <= 4), PA_ERR_ARG,
           "%s: binary Medit version must be 1 to 4, got %d", path, version);
  PA_CALLOC(w, 1);
  w->path = path;
  w->binary = binary;
  w->ver = binary ? version : 2;
  w->dim = dim;
  PA_ALLOC(w->buf, GMFW_BUF);
  PA_CALL(pa__out_open(&w->out, path));
  if (binary) {
    /* Code word, version, then Dimension: code, next position, value. */
    int64_t next = 8 + 4 + (w->ver >= 3 ? 8 : 4) + 4;
    PA_CALL(w32(w, 1));
    PA_CALL(w32(w, w->ver));
    PA_CALL(w32(w, PA_IO_GMF_DIMENSION));
    PA_CALL(w->ver >= 3 ? w64(w, next) : w32(w, (int32_t)next));
    PA_CALL(w32(w, dim));
  } else {
    PA_CALL(wtext(w, "MeshVersionFormatted 2\n\nDimension %d\n", dim));
  }
  w->end = w->off;
  *out = w;
  w = NULL;
cleanup:
  pa__gmfw_abort(w);
  return st;
}

pa_status pa__gmfw_kwd(pa__gmfw *w, int code, pa_idx n, int nreal, int nint,
                       int ntype, const int *type) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(n >= 0 && ntype >= 0 && ntype <= PA_IO_GMF_MAX_TYPES, PA_ERR_ARG,
           "pa__gmfw_kwd: bad arguments");
  PA_CHECK(!w->binary || w->off == w->end, PA_ERR_INTERNAL,
           "%s: keyword %s started before the previous one was complete",
           w->path, pa__gmf_kwd_name(code));
  w->nreal = nreal;
  w->nint = nint;
  if (w->binary) {
    int64_t ps = w->ver >= 3 ? 8 : 4, is = w->ver >= 4 ? 8 : 4;
    int64_t rs = w->ver == 1 ? 4 : 8;
    int64_t hdr = 4 + ps + is + (ntype ? 4 + 4 * (int64_t)ntype : 0);
    int64_t end = w->off + hdr + (int64_t)n * (nreal * rs + nint * is);
    PA_CHECK(ps == 8 || end <= INT32_MAX, PA_ERR_ARG,
             "%s: too large for binary Medit version %d (32-bit positions "
             "address 2 GiB); use version 3 or 4",
             w->path, w->ver);
    PA_CALL(w32(w, code));
    PA_CALL(ps == 8 ? w64(w, end) : w32(w, (int32_t)end));
    PA_CALL(is == 8 ? w64(w, n) : w32(w, n));
    if (ntype) {
      PA_CALL(w32(w, ntype));
      for (int i = 0; i < ntype; i++)
        PA_CALL(w32(w, type[i]));
    }
    w->end = end;
  } else {
    PA_CALL(wtext(w, "\n%s\n%d\n", pa__gmf_kwd_name(code), (int)n));
    if (ntype) {
      PA_CALL(wtext(w, "%d", ntype));
      for (int i = 0; i < ntype; i++)
        PA_CALL(wtext(w, " %d", type[i]));
      PA_CALL(wtext(w, "\n"));
    }
  }
cleanup:
  return st;
}

pa_status pa__gmfw_rec(pa__gmfw *w, const double *rv, const int64_t *iv) {
  pa_status st = PA_SUCCESS;
  if (w->binary) {
    for (int j = 0; j < w->nreal; j++) {
      if (w->ver == 1) {
        float f = (float)rv[j];
        PA_CHECK(isfinite(f) || !isfinite(rv[j]), PA_ERR_ARG,
                 "%s: %g does not fit in a float (version 1); use version 2",
                 w->path, rv[j]);
        PA_CALL(wbytes(w, &f, 4));
      } else {
        PA_CALL(wbytes(w, &rv[j], 8));
      }
    }
    for (int j = 0; j < w->nint; j++) {
      if (w->ver >= 4) {
        PA_CALL(w64(w, iv[j]));
      } else {
        PA_CHECK(iv[j] >= INT32_MIN && iv[j] <= INT32_MAX, PA_ERR_ARG,
                 "%s: integer %lld does not fit in 32 bits; use version 4",
                 w->path, (long long)iv[j]);
        PA_CALL(w32(w, (int32_t)iv[j]));
      }
    }
    return PA_SUCCESS;
  }
  int nval = w->nreal + w->nint, j = 0;
  while (j < nval) {
    if (w->len + GMFW_SLACK > GMFW_BUF) PA_CALL(wflush(w));
    /* the numbers that fit, formatted into a local cursor (the buffer's
     * chars may alias *w, which would be reloaded at every char) */
    char *s0 = w->buf + w->len, *s = s0;
    size_t room = (GMFW_BUF - w->len) / GMFW_SLACK;
    int end = room < (size_t)(nval - j) ? j + (int)room : nval;
    for (; j < end; j++) {
      s += j < w->nreal ? pa__fmt_shortest(s, rv[j])
                          : pa__fmt_int(s, iv[j - w->nreal]);
      *s++ = j + 1 < nval ? ' ' : '\n';
    }
    w->len += (size_t)(s - s0);
    w->off += s - s0;
  }
cleanup:
  return st;
}

pa_status pa__gmfw_close(pa__gmfw *w) {
  pa_status st = PA_SUCCESS;
  if (w->binary) {
    PA_CHECK(w->off == w->end, PA_ERR_INTERNAL,
             "%s: the last keyword is incomplete", w->path);
    PA_CALL(w32(w, PA_IO_GMF_END));
    PA_CALL(w->ver >= 3 ? w64(w, 0) : w32(w, 0));
  } else {
    PA_CALL(wtext(w, "\nEnd\n"));
  }
  PA_CALL(wflush(w));
  PA_CALL(pa__out_commit(&w->out));
cleanup:
  pa__gmfw_abort(w);
  return st;
}

void pa__gmfw_abort(pa__gmfw *w) {
  if (!w) return;
  pa__out_abort(&w->out);
  pa__free(w->buf);
  pa__free(w);
}

/* ------------------------------------------------------------------------ */
/* Mesh reading                                                             */
/* ------------------------------------------------------------------------ */

/* Sections of vertex-indexed entities and of index lists. */
enum {
  S_EDGE,
  S_TRI,
  S_TET,
  S_CORNER,
  S_RIDGE,
  S_REQV,
  S_REQE,
  S_REQT,
  S_REQTET,
  S_NSEC
};
#define S_VERT (-1) /* target: the vertices */

static const struct {
  int code;
  int nper;   /* indices per record */
  int hasref; /* a reference follows */
  int target; /* section the indices refer to */
  const char *what;
} sec_info[S_NSEC] = {
    [S_EDGE] = {PA_IO_GMF_EDGES, 2, 1, S_VERT, "edge"},
    [S_TRI] = {PA_IO_GMF_TRIANGLES, 3, 1, S_VERT, "triangle"},
    [S_TET] = {PA_IO_GMF_TETRAHEDRA, 4, 1, S_VERT, "tetrahedron"},
    [S_CORNER] = {PA_IO_GMF_CORNERS, 1, 0, S_VERT, "corner"},
    [S_RIDGE] = {PA_IO_GMF_RIDGES, 1, 0, S_EDGE, "ridge"},
    [S_REQV] = {PA_IO_GMF_REQUIRED_VERTICES, 1, 0, S_VERT, "required vertex"},
    [S_REQE] = {PA_IO_GMF_REQUIRED_EDGES, 1, 0, S_EDGE, "required edge"},
    [S_REQT] = {PA_IO_GMF_REQUIRED_TRIANGLES, 1, 0, S_TRI, "required triangle"},
    [S_REQTET] = {PA_IO_GMF_REQUIRED_TETRAHEDRA, 1, 0, S_TET,
                  "required tetrahedron"},
};

typedef struct msec {
  int present;
  int checked; /* indices validated against the target's count */
  pa_idx n;
  pa_idx *v;    /* n * nper, 0-based */
  int32_t *ref; /* n, entity sections only */
  int64_t loc;  /* location of the keyword */
} msec;

typedef struct medit_raw {
  int fdim; /* Dimension of the file */
  int vpresent;
  pa_idx nv;
  double *coord; /* fdim * nv */
  int32_t *vref;
  msec sec[S_NSEC];
} medit_raw;

static void raw_free(medit_raw *r) {
  pa__free(r->coord);
  pa__free(r->vref);
  for (int s = 0; s < S_NSEC; s++) {
    pa__free(r->sec[s].v);
    pa__free(r->sec[s].ref);
  }
}

static const char *target_name(int target) {
  return target == S_VERT ? "vertex" : sec_info[target].what;
}

/* Number of entities indices of section s may refer to; -1 if not read yet. */
static int64_t target_count(const medit_raw *r, int s) {
  int t = sec_info[s].target;
  if (t == S_VERT) return r->vpresent ? r->nv : -1;
  return r->sec[t].present ? r->sec[t].n : -1;
}

static pa_status read_vertices(pa__gmf *g, medit_raw *r) {
  pa_status st = PA_SUCCESS;
  int d = pa__gmf_dim(g);
  pa_idx n;
  const double *rv;
  const int64_t *iv;
  if (r->vpresent)
    PA_IO_GMF_FAIL(g, pa__gmf_kwd_loc(g), "duplicate Vertices section");
  PA_CALL(pa__gmf_count(g, d, 1, &n));
  PA_ALLOC(r->coord, (size_t)n * d);
  PA_ALLOC(r->vref, n);
  r->vpresent = 1;
  r->nv = n;
  r->fdim = d;
  size_t chunk = pa__gmf_chunk(d, 1), m;
  for (size_t done = 0; done < (size_t)n; done += m) {
    m = (size_t)n - done < chunk ? (size_t)n - done : chunk;
    PA_CALL(pa__gmf_records(g, m, d, 1, &rv, &iv));
    for (size_t k = 0; k < m; k++) {
      for (int j = 0; j < d; j++)
        if (!isfinite(rv[k * d + j]))
          PA_IO_GMF_FAIL(g, pa__gmf_rec_loc(g, k),
                         "vertex %zu: coordinate %d is %s", done + k + 1, j + 1,
                         isnan(rv[k * d + j]) ? "NaN" : "infinite");
      if (iv[k] < INT32_MIN || iv[k] > INT32_MAX)
        PA_IO_GMF_FAIL(g, pa__gmf_rec_loc(g, k),
                       "vertex %zu: reference %lld does not fit in 32 bits",
                       done + k + 1, (long long)iv[k]);
      r->vref[done + k] = (int32_t)iv[k];
    }
    memcpy(r->coord + done * d, rv, m * d * sizeof(double));
  }
  PA_CALL(pa__gmf_done(g));
cleanup:
  return st;
}

static pa_status read_section(pa__gmf *g, medit_raw *r, int s) {
  pa_status st = PA_SUCCESS;
  msec *sec = &r->sec[s];
  int nper = sec_info[s].nper, ni = nper + sec_info[s].hasref;
  const int64_t *iv;
  pa_idx n;
  if (sec->present)
    PA_IO_GMF_FAIL(g, pa__gmf_kwd_loc(g), "duplicate %s section",
                   pa__gmf_kwd_name(sec_info[s].code));
  sec->loc = pa__gmf_kwd_loc(g);
  PA_CALL(pa__gmf_count(g, 0, ni, &n));
  PA_ALLOC(sec->v, (size_t)n * nper);
  if (sec_info[s].hasref) PA_ALLOC(sec->ref, n);
  sec->present = 1;
  sec->n = n;
  int64_t lim = target_count(r, s);
  sec->checked = lim >= 0;
  if (lim < 0) lim = INT32_MAX;
  size_t chunk = pa__gmf_chunk(0, ni), m;
  for (size_t done = 0; done < (size_t)n; done += m) {
    m = (size_t)n - done < chunk ? (size_t)n - done : chunk;
    PA_CALL(pa__gmf_records(g, m, 0, ni, NULL, &iv));
    pa_idx *v = sec->v + done * nper;
    for (size_t k = 0; k < m; k++) {
      const int64_t *rec = iv + k * ni;
      for (int j = 0; j < nper; j++) {
        if (rec[j] < 1 || rec[j] > lim)
          PA_IO_GMF_FAIL(
              g, pa__gmf_rec_loc(g, k),
              "%s %zu: %s index %lld is outside [1, %lld]%s", sec_info[s].what,
              done + k + 1, target_name(sec_info[s].target), (long long)rec[j],
              (long long)lim, rec[j] == 0 ? " (indices start at 1)" : "");
        v[k * nper + j] = (pa_idx)(rec[j] - 1);
      }
      if (sec_info[s].hasref) {
        if (rec[nper] < INT32_MIN || rec[nper] > INT32_MAX)
          PA_IO_GMF_FAIL(g, pa__gmf_rec_loc(g, k),
                         "%s %zu: reference %lld does not fit in 32 bits",
                         sec_info[s].what, done + k + 1, (long long)rec[nper]);
        sec->ref[done + k] = (int32_t)rec[nper];
      }
    }
  }
  PA_CALL(pa__gmf_done(g));
cleanup:
  return st;
}

/* Check the indices of sections read before the section they refer to. */
static pa_status check_deferred(pa__gmf *g, medit_raw *r) {
  pa_status st = PA_SUCCESS;
  for (int s = 0; s < S_NSEC; s++) {
    msec *sec = &r->sec[s];
    if (!sec->present || sec->checked) continue;
    int64_t lim = target_count(r, s);
    if (lim < 0) lim = 0;
    int nper = sec_info[s].nper;
    for (size_t i = 0; i < (size_t)sec->n * nper; i++)
      if (sec->v[i] >= lim)
        PA_IO_GMF_FAIL(g, sec->loc,
                       "%s: %s %zu refers to %s %lld, outside [1, %lld]",
                       pa__gmf_kwd_name(sec_info[s].code), sec_info[s].what,
                       i / nper + 1, target_name(sec_info[s].target),
                       (long long)sec->v[i] + 1, (long long)lim);
    sec->checked = 1;
  }
cleanup:
  return st;
}

/* Move the raw arrays into a new mesh of dimension dim (nothing can fail once
 * the mesh exists, so *out is either complete or untouched). */
static pa_status build_mesh(medit_raw *r, int dim, pa_mesh **out) {
  pa_status st = PA_SUCCESS;
  pa_mesh *m = NULL;
  uint8_t *vflag = NULL, *fl[3] = {NULL, NULL, NULL};
  PA_CALLOC(vflag, r->nv);
  for (int s = S_EDGE; s <= S_TET; s++)
    PA_CALLOC(fl[s], r->sec[s].n);
  PA_CALL(pa_mesh_create(dim, &m));

  static const struct {
    int list;
    int sec; /* -1: vertices */
    uint8_t bit;
  } lists[] = {
      {S_CORNER, -1, PA_FLAG_CORNER},    {S_REQV, -1, PA_FLAG_REQUIRED},
      {S_RIDGE, S_EDGE, PA_FLAG_RIDGE},  {S_REQE, S_EDGE, PA_FLAG_REQUIRED},
      {S_REQT, S_TRI, PA_FLAG_REQUIRED}, {S_REQTET, S_TET, PA_FLAG_REQUIRED}};
  for (size_t i = 0; i < sizeof lists / sizeof *lists; i++) {
    const msec *l = &r->sec[lists[i].list];
    uint8_t *f = lists[i].sec < 0 ? vflag : fl[lists[i].sec];
    for (pa_idx k = 0; k < l->n; k++)
      f[l->v[k]] |= lists[i].bit;
  }
  /* A vertex of a ridge is a ridge vertex (Medit has no keyword for it). */
  for (pa_idx k = 0; k < r->sec[S_EDGE].n; k++)
    if (fl[S_EDGE][k] & PA_FLAG_RIDGE) {
      vflag[r->sec[S_EDGE].v[2 * (size_t)k]] |= PA_FLAG_RIDGE;
      vflag[r->sec[S_EDGE].v[2 * (size_t)k + 1]] |= PA_FLAG_RIDGE;
    }

  if (r->fdim == 3 && dim == 2 && r->nv) {
    for (pa_idx i = 0; i < r->nv; i++) {
      r->coord[2 * (size_t)i] = r->coord[3 * (size_t)i];
      r->coord[2 * (size_t)i + 1] = r->coord[3 * (size_t)i + 1];
    }
    double *c = pa__realloc(r->coord, 2 * (size_t)r->nv * sizeof(double));
    if (c) r->coord = c; /* shrinking is optional */
  }
  m->nv = r->nv;
  m->capv = (size_t)r->nv;
  m->coord = r->coord;
  m->vref = r->vref;
  m->vflag = vflag;
  r->coord = NULL;
  r->vref = NULL;
  vflag = NULL;

  /* Medit sections -> mesh entity kinds. */
  int elem = dim == 2 ? S_TRI : S_TET, bdry = dim == 2 ? S_EDGE : S_TRI;
  msec *se = &r->sec[elem], *sb = &r->sec[bdry];
  m->ne = se->n;
  m->cape = (size_t)se->n;
  m->elem = se->v;
  m->eref = se->ref;
  m->eflag = fl[elem];
  m->nb = sb->n;
  m->capb = (size_t)sb->n;
  m->bdry = sb->v;
  m->bref = sb->ref;
  m->bflag = fl[bdry];
  se->v = sb->v = NULL;
  se->ref = sb->ref = NULL;
  fl[elem] = fl[bdry] = NULL;
  if (dim == 3) {
    msec *sd = &r->sec[S_EDGE];
    m->ned = sd->n;
    m->caped = (size_t)sd->n;
    m->edge = sd->v;
    m->edref = sd->ref;
    m->edflag = fl[S_EDGE];
    sd->v = NULL;
    sd->ref = NULL;
    fl[S_EDGE] = NULL;
  }
  *out = m;
  m = NULL;
cleanup:
  pa__free(vflag);
  for (int s = 0; s < 3; s++)
    pa__free(fl[s]);
  pa_mesh_destroy(m);
  return st;
}

pa_status pa__medit_read(const char *path, pa_mesh **mesh) {
  pa_status st = PA_SUCCESS;
  medit_raw r;
  pa__gmf *g = NULL;
  char ext[16];
  memset(&r, 0, sizeof r);
  *mesh = NULL;
  pa__path_ext(path, ext, sizeof ext);
  PA_CALL(pa__gmf_open(path, !strcmp(ext, ".meshb"), &g));
  for (;;) {
    int code, s = -1, ni;
    pa_idx n;
    PA_CALL(pa__gmf_next(g, &code));
    if (code == PA_IO_GMF_END) break;
    for (int i = 0; i < S_NSEC; i++)
      if (sec_info[i].code == code) s = i;
    switch (code) {
    case PA_IO_GMF_VERTICES:
      PA_CALL(read_vertices(g, &r));
      break;
    case PA_IO_GMF_TETRAHEDRA:
      if (pa__gmf_dim(g) == 2)
        PA_IO_GMF_FAIL(g, pa__gmf_kwd_loc(g),
                       "Tetrahedra in a mesh of "
                       "Dimension 2");
      PA_CALL(read_section(g, &r, s));
      break;
    default:
      if (s >= 0) {
        PA_CALL(read_section(g, &r, s));
      } else if ((ni = pa__gmf_unsupported_cell(code))) {
        PA_CALL(pa__gmf_count(g, 0, ni, &n));
        if (n)
          PA_CALL(pa__gmf_error(g, pa__gmf_kwd_loc(g), PA_ERR_UNSUPPORTED,
                                "%s are not supported (straight-sided simplex "
                                "meshes only)",
                                pa__gmf_kwd_name(code)));
        PA_CALL(pa__gmf_done(g));
      } else {
        PA_CALL(pa__gmf_skip(g));
      }
    }
  }
  if (!pa__gmf_dim(g))
    PA_IO_GMF_FAIL(g, pa__gmf_loc(g),
                   "missing Dimension keyword (not a Medit "
                   "mesh file?)");
  if (!r.vpresent) r.fdim = pa__gmf_dim(g);
  PA_CALL(check_deferred(g, &r));
  int64_t unknown;
  const char *skipped = pa__gmf_skipped(g, &unknown);
  if (unknown >= 0 && r.nv && !r.sec[S_TRI].n && !r.sec[S_TET].n)
    PA_IO_GMF_FAIL(g, unknown,
                   "vertices but no Triangles nor Tetrahedra, and keywords "
                   "padapt does not know were skipped: %s (misspelt, or "
                   "elements padapt does not support?)",
                   skipped);

  int dim = r.fdim;
  if (dim == 3 && r.sec[S_TET].n == 0 && r.sec[S_TRI].n > 0) {
    dim = 2; /* planar mesh written in 3D? */
    for (pa_idx i = 0; i < r.nv && dim == 2; i++)
      if (r.coord[3 * (size_t)i + 2] != 0.0) dim = 3;
  }
  PA_CALL(build_mesh(&r, dim, mesh));
  (*mesh)->file_dim = r.fdim;
cleanup:
  raw_free(&r);
  pa__gmf_close(g);
  return st;
}

/* ------------------------------------------------------------------------ */
/* Mesh writing                                                             */
/* ------------------------------------------------------------------------ */

static pa_status write_cells(pa__gmfw *w, int code, pa_idx n, int nper,
                             const pa_idx *v, const int32_t *ref) {
  pa_status st = PA_SUCCESS;
  int64_t iv[5];
  if (!n) return PA_SUCCESS;
  PA_CALL(pa__gmfw_kwd(w, code, n, 0, nper + 1, 0, NULL));
  for (pa_idx e = 0; e < n; e++) {
    for (int j = 0; j < nper; j++)
      iv[j] = (int64_t)v[(size_t)e * nper + j] + 1;
    iv[nper] = ref[e];
    PA_CALL(pa__gmfw_rec(w, NULL, iv));
  }
cleanup:
  return st;
}

static pa_status write_list(pa__gmfw *w, int code, pa_idx n,
                            const uint8_t *flag, uint8_t bit) {
  pa_status st = PA_SUCCESS;
  pa_idx count = 0;
  for (pa_idx i = 0; i < n; i++)
    count += (flag[i] & bit) != 0;
  if (!count) return PA_SUCCESS;
  PA_CALL(pa__gmfw_kwd(w, code, count, 0, 1, 0, NULL));
  for (pa_idx i = 0; i < n; i++) {
    if (!(flag[i] & bit)) continue;
    int64_t iv = (int64_t)i + 1;
    PA_CALL(pa__gmfw_rec(w, NULL, &iv));
  }
cleanup:
  return st;
}

pa_status pa__medit_write(pa_mesh *m, const char *path, int binary,
                          int version) {
  pa_status st = PA_SUCCESS;
  pa__gmfw *w = NULL;
  int d = m->dim;
  PA_CHECK(version >= 0 && version <= 4, PA_ERR_ARG,
           "%s: .meshb version must be 1 to 4 (0: default), got %d", path,
           version);
  if (binary && !version) {
    int64_t bytes = (int64_t)m->nv * (8 * d + 4) +
                    (int64_t)m->ne * 4 * (d + 2) +
                    (int64_t)m->nb * 4 * (d + 1) + (int64_t)m->ned * 12 +
                    4 * ((int64_t)m->nv + m->ne + m->nb + m->ned);
    version = pa__gmf_default_version(bytes);
  }
  PA_CALL(pa__gmfw_open(path, binary, version, d, &w));

  PA_CALL(pa__gmfw_kwd(w, PA_IO_GMF_VERTICES, m->nv, d, 1, 0, NULL));
  for (pa_idx i = 0; i < m->nv; i++) {
    int64_t ref = m->vref[i];
    PA_CALL(pa__gmfw_rec(w, m->coord + (size_t)d * i, &ref));
  }
  /* Medit's Edges: the boundary in 2D, the feature edges in 3D. */
  pa_idx nedg = d == 2 ? m->nb : m->ned;
  const pa_idx *edg = d == 2 ? m->bdry : m->edge;
  const int32_t *edgref = d == 2 ? m->bref : m->edref;
  const uint8_t *edgflag = d == 2 ? m->bflag : m->edflag;
  pa_idx ntri = d == 2 ? m->ne : m->nb;
  const pa_idx *tri = d == 2 ? m->elem : m->bdry;
  const int32_t *triref = d == 2 ? m->eref : m->bref;
  const uint8_t *triflag = d == 2 ? m->eflag : m->bflag;
  PA_CALL(write_cells(w, PA_IO_GMF_EDGES, nedg, 2, edg, edgref));
  PA_CALL(write_cells(w, PA_IO_GMF_TRIANGLES, ntri, 3, tri, triref));
  if (d == 3)
    PA_CALL(write_cells(w, PA_IO_GMF_TETRAHEDRA, m->ne, 4, m->elem, m->eref));
  PA_CALL(write_list(w, PA_IO_GMF_CORNERS, m->nv, m->vflag, PA_FLAG_CORNER));
  PA_CALL(write_list(w, PA_IO_GMF_REQUIRED_VERTICES, m->nv, m->vflag,
                     PA_FLAG_REQUIRED));
  PA_CALL(write_list(w, PA_IO_GMF_RIDGES, nedg, edgflag, PA_FLAG_RIDGE));
  PA_CALL(
      write_list(w, PA_IO_GMF_REQUIRED_EDGES, nedg, edgflag, PA_FLAG_REQUIRED));
  PA_CALL(write_list(w, PA_IO_GMF_REQUIRED_TRIANGLES, ntri, triflag,
                     PA_FLAG_REQUIRED));
  if (d == 3)
    PA_CALL(write_list(w, PA_IO_GMF_REQUIRED_TETRAHEDRA, m->ne, m->eflag,
                       PA_FLAG_REQUIRED));
  pa__gmfw *done = w;
  w = NULL;
  PA_CALL(pa__gmfw_close(done));
cleanup:
  pa__gmfw_abort(w);
  return st;
}
