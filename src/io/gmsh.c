/*
 * gmsh.c -- Gmsh .msh files: MSH 4.1 read and write (ASCII and binary), MSH
 * 2.2 ASCII read.
 *
 * How Gmsh entities map onto a pa_mesh:
 *  - The mesh dimension is the highest dimension of the elements read: 3 if
 *    there is a tetrahedron, else 2 if there is a triangle. A file with
 *    neither is read as 2D if every node has z = 0, as 3D otherwise. A 2D
 *    mesh must lie in the plane z = 0 (a non-zero z is an error).
 *  - 2D: triangles (type 2) are the elements, lines (type 1) the boundary
 *    edges. 3D: tetrahedra (type 4) are the elements, triangles the boundary
 *    triangles, lines the feature edges. Other element types are refused.
 *  - Points (type 15) mark their vertex as a corner (PA_FLAG_CORNER) and give
 *    it the point's reference. On write, every corner vertex becomes a point
 *    element on a point entity of its own, so corners and their references
 *    round-trip; the references of other vertices are not stored.
 *  - The reference of an element is the first physical tag of its entity in
 *    $Entities, or the entity tag when the entity has no physical tag or the
 *    file has no $Entities. MSH 2.2: the physical tag, or the elementary tag
 *    when the physical tag is 0 or absent.
 *  - On write there is one entity per (dimension, reference), whose physical
 *    tag is the reference and whose entity tag is the reference when positive
 *    (otherwise a tag above every positive reference of that dimension).
 *    Cells are written grouped by reference, stably: the order of cells with
 *    equal references is kept, so a mesh whose references are sorted comes
 *    back in its own order. All nodes go in one block, tags 1..nvert.
 *  - $PhysicalNames: every name is kept on the mesh (pa_mesh_name) and
 *    written back, used by a cell or not, sorted by (dimension, tag).
 *  - $NodeData views (one time step; a view may come in several sections,
 *    e.g. one per partition): the view "metric" is the metric, 1 component
 *    a size, 9 a symmetric 3 x 3 tensor (row-major; 2D: no z coupling, zz
 *    ignored) stored as 3 (2D) or 6 (3D) values; every other view is a user
 *    field of its name: a 3-component vector in 2D (z = 0) keeps x and y, a
 *    symmetric 9-component tensor becomes 3/6 values, anything else is kept
 *    as it is. A field view that misses nodes is ignored (Gmsh allows views
 *    on part of the mesh; a field has a value at every vertex); a metric
 *    view must cover every node. On write: the metric as "metric" (size: 1
 *    component; tensor: 9, with zz = 1 in 2D), then each field: 1 component,
 *    a vector (dim components) as 3, a symmetric tensor (3 in 2D, 6 in 3D)
 *    as 9 (zz = 0 in 2D), other counts as they are. Binary files write the
 *    node tags of views as 4-byte ints, as Gmsh and meshio do.
 *  - $ElementData views (one time step): a view holding a value at every
 *    element is an element field of its name, one holding a value at every
 *    boundary entity a boundary field (both, for a view on both); values
 *    at corners and feature edges are not read; 3-component vectors in 2D
 *    with z = 0 and symmetric 9-component tensors shrink as for $NodeData.
 *    On write: one view per name of the element and boundary fields, over
 *    every cell of the file in tag order with 0 on the cells the view's
 *    fields are not on (Gmsh and meshio read such views), and a fifth
 *    integer tag (1 elements, 2 boundary entities, 3 both) saying which
 *    cells carry it, which the reader follows when present.
 *  - Flags other than corners are not stored.
 *  - Node tags may be sparse and unordered: vertices are numbered in
 *    increasing tag order (tags 1..n give vertex tag - 1, whatever the order
 *    of the node blocks).
 *
 * Reader invariants: the whole file sits in one NUL-terminated buffer and
 * every read is bounds-checked against it; every count is checked against the
 * bytes left in the file before anything is allocated for it. Errors are
 * "FILE:LINE: message" in ASCII files and "FILE: byte OFFSET: message" in
 * binary ones. Binary files must have data size 8 and the endianness of the
 * machine reading them. In binary files $ElementNodeData is skipped record
 * by record; the sections whose binary layout we do not
 * parse ($Periodic, $GhostElements...) are refused before $Elements and
 * ignored, with everything after them, once the mesh is read; other unknown
 * sections are skipped up to their $End line.
 */
#include "io/fmt.h"
#include "io/gmsh.h"
#include "io/output.h"
#include "metric/metric.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <sys/stat.h>

/* ------------------------------------------------------------------------ */
/* Reading: the file buffer, locations and errors                           */
/* ------------------------------------------------------------------------ */

typedef struct reader {
  const char *path;
  char *buf; /* whole file, buf[len] == '\0' */
  size_t len;
  size_t pos;    /* read cursor */
  long line;     /* line number at pos (ASCII parts only) */
  long tokline;  /* line of the item being read, for messages */
  size_t tokpos; /* offset of the item being read, for binary messages */
  int binary;
} reader;

/* Raise code with "FILE:LINE: message" (ASCII) or "FILE: byte N: message". */
static pa_status rd_error(const reader *r, pa_status code, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
static pa_status rd_error(const reader *r, pa_status code, const char *fmt,
                          ...) {
  char msg[512];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(msg, sizeof msg, fmt, ap);
  va_end(ap);
  if (r->binary)
    return pa__error(code, __FILE__, __LINE__, "%s: byte %zu: %s", r->path,
                     r->tokpos, msg);
  return pa__error(code, __FILE__, __LINE__, "%s:%ld: %s", r->path, r->tokline,
                   msg);
}

#define RD_FAIL(r, code, ...)                                                  \
  do {                                                                         \
    st = rd_error((r), (code), __VA_ARGS__);                                   \
    goto cleanup;                                                              \
  } while (0)

static int is_blank(char c) {
  return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' ||
         c == '\v';
}

/* Skip blanks and newlines; returns 0 at the end of the file. */
static int rd_skip(reader *r) {
  while (r->pos < r->len) {
    char c = r->buf[r->pos];
    if (!is_blank(c)) return 1;
    if (c == '\n') r->line++;
    r->pos++;
  }
  return 0;
}

/* Mark the start of the next item (after blanks) for messages. */
static int rd_mark(reader *r) {
  int more = rd_skip(r);
  r->tokline = r->line;
  r->tokpos = r->pos;
  return more;
}

/* The word at pos, quoted for a message (non-printable bytes as '?'). */
static const char *rd_word(const reader *r, char *out, size_t n) {
  if (r->pos >= r->len) return "end of file";
  size_t i = 0;
  while (i + 1 < n && r->pos + i < r->len && !is_blank(r->buf[r->pos + i])) {
    unsigned char c = (unsigned char)r->buf[r->pos + i];
    out[i] = (c >= 32 && c < 127) ? (char)c : '?';
    i++;
  }
  out[i] = '\0';
  return out;
}

/* 1 if offset k ends a token (blank or end of file). */
static int rd_ends(const reader *r, size_t k) {
  return k >= r->len || is_blank(r->buf[k]);
}

static pa_status rd_eof(reader *r, const char *what) {
  return rd_error(r, PA_ERR_FORMAT, "unexpected end of file, expected %s",
                  what);
}

static pa_status rd_bad(reader *r, const char *what) {
  char w[40];
  return rd_error(r, PA_ERR_FORMAT, "expected %s, found '%s'", what,
                  rd_word(r, w, sizeof w));
}

/* ASCII unsigned integer. */
static pa_status rd_u64(reader *r, uint64_t *v, const char *what) {
  if (!rd_mark(r)) return rd_eof(r, what);
  const char *s = r->buf + r->pos;
  size_t i = s[0] == '+';
  uint64_t x = 0;
  if (s[i] < '0' || s[i] > '9') return rd_bad(r, what);
  for (; s[i] >= '0' && s[i] <= '9'; i++) {
    unsigned d = (unsigned)(s[i] - '0');
    if (x > (UINT64_MAX - d) / 10)
      return rd_error(r, PA_ERR_FORMAT, "%s is too large", what);
    x = 10 * x + d;
  }
  if (!rd_ends(r, r->pos + i)) return rd_bad(r, what);
  r->pos += i;
  *v = x;
  return PA_SUCCESS;
}

/* ASCII signed integer within [lo, hi]. */
static pa_status rd_i64(reader *r, int64_t lo, int64_t hi, int64_t *v,
                        const char *what) {
  if (!rd_mark(r)) return rd_eof(r, what);
  const char *s = r->buf + r->pos;
  int neg = s[0] == '-';
  size_t i = (s[0] == '-' || s[0] == '+');
  uint64_t x = 0;
  if (s[i] < '0' || s[i] > '9') return rd_bad(r, what);
  for (; s[i] >= '0' && s[i] <= '9'; i++) {
    x = 10 * x + (unsigned)(s[i] - '0');
    if (x > (uint64_t)INT64_MAX)
      return rd_error(r, PA_ERR_FORMAT, "%s is out of range", what);
  }
  if (!rd_ends(r, r->pos + i)) return rd_bad(r, what);
  int64_t y = neg ? -(int64_t)x : (int64_t)x;
  if (y < lo || y > hi)
    return rd_error(r, PA_ERR_FORMAT, "%s %lld is out of range [%lld, %lld]",
                    what, (long long)y, (long long)lo, (long long)hi);
  r->pos += i;
  *v = y;
  return PA_SUCCESS;
}

/* ASCII floating-point number (not checked for finiteness). */
static pa_status rd_f64(reader *r, double *v, const char *what) {
  if (!rd_mark(r)) return rd_eof(r, what);
  const char *s = r->buf + r->pos;
  char *end;
  double x = strtod(s, &end);
  if (end == s || !rd_ends(r, r->pos + (size_t)(end - s)))
    return rd_bad(r, what);
  r->pos += (size_t)(end - s);
  *v = x;
  return PA_SUCCESS;
}

/* Check that n more bytes of binary data are available. */
static pa_status rd_need(reader *r, size_t n, const char *what) {
  r->tokpos = r->pos;
  if (n > r->len - r->pos)
    return rd_error(r, PA_ERR_FORMAT,
                    "unexpected end of file (truncated binary data) in %s",
                    what);
  return PA_SUCCESS;
}

/* Copy the next n bytes of binary data to v. */
static pa_status rd_bytes(reader *r, void *v, size_t n, const char *what) {
  pa_status st = rd_need(r, n, what);
  if (st) return st;
  memcpy(v, r->buf + r->pos, n);
  r->pos += n;
  return PA_SUCCESS;
}

/* Items of the MSH 4.1 layout: int, size_t and double, ASCII or binary. */
static pa_status get_int(reader *r, int32_t *v, const char *what) {
  if (!r->binary) {
    int64_t x;
    pa_status st = rd_i64(r, INT32_MIN, INT32_MAX, &x, what);
    *v = (int32_t)x;
    return st;
  }
  return rd_bytes(r, v, 4, what);
}

static pa_status get_size(reader *r, uint64_t *v, const char *what) {
  if (!r->binary) return rd_u64(r, v, what);
  return rd_bytes(r, v, 8, what);
}

static pa_status get_f64(reader *r, double *v, const char *what) {
  if (!r->binary) return rd_f64(r, v, what);
  return rd_bytes(r, v, 8, what);
}

/* Bytes left after the cursor. */
static size_t rd_left(const reader *r) { return r->len - r->pos; }

/* Check that count items of at least `each` bytes fit in the rest of the
 * file (each: ASCII or binary minimum) before anything is allocated. */
static pa_status rd_fits(reader *r, uint64_t count, size_t each_ascii,
                         size_t each_binary, const char *what) {
  size_t each = r->binary ? each_binary : each_ascii;
  if (count > rd_left(r) / each)
    return rd_error(r, PA_ERR_FORMAT,
                    "truncated file or bad count: the %s announces %llu "
                    "items, more than the remaining %zu bytes can hold",
                    what, (unsigned long long)count, rd_left(r));
  return PA_SUCCESS;
}

/* Read the next word and check it is `kw` (e.g. "$EndNodes"). */
static pa_status rd_expect(reader *r, const char *kw) {
  if (!rd_mark(r)) return rd_eof(r, kw);
  size_t n = strlen(kw);
  if (n > rd_left(r) || memcmp(r->buf + r->pos, kw, n) ||
      !rd_ends(r, r->pos + n))
    return rd_bad(r, kw);
  r->pos += n;
  return PA_SUCCESS;
}

/* In binary files: consume the end of the line after a section keyword. The
 * binary data starts right after it, so blanks must not be skipped. */
static pa_status rd_eol(reader *r) {
  r->tokpos = r->pos;
  if (r->pos < r->len && r->buf[r->pos] == '\r') r->pos++;
  if (r->pos < r->len && r->buf[r->pos] == '\n') {
    r->pos++;
    r->line++;
    return PA_SUCCESS;
  }
  return rd_error(r, PA_ERR_FORMAT, "expected the end of the line");
}

/* ------------------------------------------------------------------------ */
/* Reading: what the sections hold before the mesh is built                 */
/* ------------------------------------------------------------------------ */

/* Cells of one kind: points, lines, triangles or tetrahedra (kind = its
 * topological dimension, kind + 1 vertices). */
typedef struct cellbuf {
  pa_idx *v;
  int32_t *ref;
  uint64_t *tag; /* element tags, for $ElementData */
  size_t n, capv, capr, capt;
} cellbuf;

typedef struct entity {
  int32_t tag, ref;
} entity;

typedef struct tagidx {
  uint64_t tag;
  pa_idx idx;
} tagidx;

/* A $NodeData view being read: values by node index (the vertex numbering
 * of build_node_map). Sections of one name (a view written in parts) fill
 * the same view. */
typedef struct view {
  char name[PA_MESH_FIELD_NAME_LEN];
  int ncomp;
  int32_t step;  /* time step index */
  double *val;   /* nnode * ncomp */
  uint8_t *seen; /* nnode: 1 once the node has its value */
  long line;     /* where its first section starts, for messages */
  size_t pos;
} view;

/* Most views read: the fields and the metric. */
#define MSH_MAX_VIEWS (PA_MESH_MAX_FIELDS + 1)

/* The fifth integer tag padapt writes on an $ElementData view: the cells
 * whose values it carries (bits). A view without it (Gmsh's, meshio's) is
 * read on every kind of cell it covers whole. */
#define GMSH_VIEW_ELEMENTS 1
#define GMSH_VIEW_BOUNDARY 2

/* An $ElementData view being read: values by element tag, matched with
 * the cells once the mesh is built. */
typedef struct eview {
  char name[PA_MESH_FIELD_NAME_LEN];
  int ncomp;
  int32_t step;
  int mark;      /* fifth integer tag, -1 when absent */
  uint64_t *tag; /* n */
  double *val;   /* n * ncomp */
  size_t n, capt, capv;
  long line; /* where its first section starts, for messages */
  size_t pos;
} eview;

/* Most $ElementData views read: an element and a boundary field each. */
#define MSH_MAX_EVIEWS (2 * PA_MESH_MAX_FIELDS)

typedef struct msh {
  int version; /* 41 or 22 */
  size_t nnode;
  double *xyz;   /* 3 * nnode */
  uint64_t *tag; /* nnode */
  /* node tag -> index: dense table over [tagmin, tagmin + ndense) or a sorted
   * table searched by bisection when tags are too sparse */
  uint64_t tagmin;
  size_t ndense;
  pa_idx *dense;
  tagidx *sorted;
  int has_entities;
  entity *ent[4];
  size_t nent[4];
  cellbuf cell[4];
  int have_nodes, have_elems, have_names;
  pa__name *names; /* $PhysicalNames, sorted by (dim, tag) once checked */
  size_t nname;
  view views[MSH_MAX_VIEWS];
  int nview;
  eview eviews[MSH_MAX_EVIEWS];
  int neview;
} msh;

static void msh_free(msh *w) {
  for (size_t k = 0; k < w->nname; k++)
    pa__free(w->names[k].name);
  pa__free(w->names);
  for (int k = 0; k < w->nview; k++) {
    pa__free(w->views[k].val);
    pa__free(w->views[k].seen);
  }
  pa__free(w->xyz);
  pa__free(w->tag);
  pa__free(w->dense);
  pa__free(w->sorted);
  for (int d = 0; d < 4; d++) {
    pa__free(w->ent[d]);
    pa__free(w->cell[d].v);
    pa__free(w->cell[d].ref);
    pa__free(w->cell[d].tag);
  }
  for (int k = 0; k < w->neview; k++) {
    pa__free(w->eviews[k].tag);
    pa__free(w->eviews[k].val);
  }
}

/* Node index of a tag, -1 if unknown. */
static pa_idx node_index(const msh *w, uint64_t tag) {
  if (w->dense) {
    if (tag < w->tagmin || tag - w->tagmin >= w->ndense) return -1;
    return w->dense[tag - w->tagmin];
  }
  size_t lo = 0, hi = w->nnode;
  while (lo < hi) {
    size_t mid = lo + (hi - lo) / 2;
    if (w->sorted[mid].tag < tag)
      lo = mid + 1;
    else
      hi = mid;
  }
  return (lo < w->nnode && w->sorted[lo].tag == tag) ? w->sorted[lo].idx : -1;
}

static int cmp_tagidx(const void *a, const void *b) {
  uint64_t x = ((const tagidx *)a)->tag, y = ((const tagidx *)b)->tag;
  return (x > y) - (x < y);
}

/* Build the tag -> index map once all nodes are read, and renumber the
 * vertices in increasing tag order (files often list nodes by entity, not by
 * tag; dense tags 1..n give vertex tag - 1). */
static pa_status build_node_map(reader *r, msh *w) {
  pa_status st = PA_SUCCESS;
  pa_idx *from = NULL; /* from[k]: file position of the node of rank k */
  double *xyz = NULL;
  uint64_t *tag = NULL;
  uint64_t lo = UINT64_MAX, hi = 0;
  size_t n = w->nnode;
  for (size_t i = 0; i < n; i++) {
    if (w->tag[i] < lo) lo = w->tag[i];
    if (w->tag[i] > hi) hi = w->tag[i];
  }
  if (!n) return PA_SUCCESS;
  if (lo == 0)
    PA_FAIL(PA_ERR_FORMAT, "%s: node tag 0 is invalid (node tags start at 1)",
            r->path);
  PA_ALLOC(from, n);
  if (hi - lo < 4 * (uint64_t)n + 1024) {
    w->tagmin = lo;
    w->ndense = (size_t)(hi - lo) + 1;
    PA_ALLOC(w->dense, w->ndense);
    for (size_t k = 0; k < w->ndense; k++)
      w->dense[k] = -1;
    for (size_t i = 0; i < n; i++) {
      pa_idx *slot = &w->dense[w->tag[i] - lo];
      if (*slot >= 0)
        PA_FAIL(PA_ERR_FORMAT, "%s: duplicate node tag %llu", r->path,
                (unsigned long long)w->tag[i]);
      *slot = (pa_idx)i;
    }
    pa_idx k = 0;
    for (size_t t = 0; t < w->ndense; t++)
      if (w->dense[t] >= 0) {
        from[k] = w->dense[t];
        w->dense[t] = k++;
      }
  } else {
    PA_ALLOC(w->sorted, n);
    for (size_t i = 0; i < n; i++) {
      w->sorted[i].tag = w->tag[i];
      w->sorted[i].idx = (pa_idx)i;
    }
    qsort(w->sorted, n, sizeof *w->sorted, cmp_tagidx);
    for (size_t k = 0; k < n; k++) {
      if (k && w->sorted[k].tag == w->sorted[k - 1].tag)
        PA_FAIL(PA_ERR_FORMAT, "%s: duplicate node tag %llu", r->path,
                (unsigned long long)w->sorted[k].tag);
      from[k] = w->sorted[k].idx;
      w->sorted[k].idx = (pa_idx)k;
    }
  }
  int in_order = 1;
  for (size_t k = 0; k < n && in_order; k++)
    in_order = from[k] == (pa_idx)k;
  if (!in_order) {
    PA_ALLOC(xyz, 3 * n);
    PA_ALLOC(tag, n);
    for (size_t k = 0; k < n; k++) {
      memcpy(xyz + 3 * k, w->xyz + 3 * (size_t)from[k], 3 * sizeof *xyz);
      tag[k] = w->tag[from[k]];
    }
    pa__free(w->xyz);
    pa__free(w->tag);
    w->xyz = xyz;
    w->tag = tag;
    xyz = NULL;
    tag = NULL;
  }
cleanup:
  pa__free(from);
  pa__free(xyz);
  pa__free(tag);
  return st;
}

/* Make room for `need` cells of kind (kind + 1 vertices each). */
static pa_status cell_reserve(reader *r, cellbuf *c, int kind, size_t need) {
  pa_status st = PA_SUCCESS;
  if (need > INT32_MAX)
    RD_FAIL(r, PA_ERR_UNSUPPORTED,
            "more than %d cells of one kind do not fit 32-bit indices",
            INT32_MAX);
  PA_GROW(c->v, c->capv, need * (size_t)(kind + 1));
  PA_GROW(c->ref, c->capr, need);
  PA_GROW(c->tag, c->capt, need);
cleanup:
  return st;
}

/* Name of a Gmsh element type, for messages. */
static const char *elem_type_name(int64_t type) {
  static const char *const names[] = {NULL,
                                      "2-node line",
                                      "3-node triangle",
                                      "4-node quadrangle",
                                      "4-node tetrahedron",
                                      "8-node hexahedron",
                                      "6-node prism",
                                      "5-node pyramid",
                                      "3-node second-order line",
                                      "6-node second-order triangle",
                                      "9-node second-order quadrangle",
                                      "10-node second-order tetrahedron",
                                      "27-node second-order hexahedron",
                                      "18-node second-order prism",
                                      "14-node second-order pyramid",
                                      "1-node point",
                                      "8-node second-order quadrangle",
                                      "20-node second-order hexahedron",
                                      "15-node second-order prism",
                                      "13-node second-order pyramid"};
  if (type > 0 && type < (int64_t)(sizeof names / sizeof *names))
    return names[type];
  return "unknown type";
}

/* Kind (points 0, lines 1, triangles 2, tetrahedra 3) of an element type. */
static pa_status elem_kind(reader *r, int64_t type, int *kind) {
  switch (type) {
  case 15:
    *kind = 0;
    return PA_SUCCESS;
  case 1:
    *kind = 1;
    return PA_SUCCESS;
  case 2:
    *kind = 2;
    return PA_SUCCESS;
  case 4:
    *kind = 3;
    return PA_SUCCESS;
  default:
    return rd_error(r, PA_ERR_UNSUPPORTED,
                    "unsupported element type %lld (%s): padapt reads points "
                    "(15), lines (1), triangles (2) and tetrahedra (4) only",
                    (long long)type, elem_type_name(type));
  }
}

static pa_status unknown_node(reader *r, uint64_t etag, uint64_t ntag) {
  return rd_error(r, PA_ERR_FORMAT,
                  "element %llu refers to unknown node tag %llu",
                  (unsigned long long)etag, (unsigned long long)ntag);
}

static int cmp_entity(const void *a, const void *b) {
  int32_t x = ((const entity *)a)->tag, y = ((const entity *)b)->tag;
  return (x > y) - (x < y);
}

/* Reference of the elements of entity (dim, tag): its first physical tag,
 * else the entity tag. */
static int32_t entity_ref(const msh *w, int dim, int32_t tag) {
  if (!w->has_entities || dim < 0 || dim > 3) return tag;
  const entity *e = w->ent[dim];
  size_t lo = 0, hi = w->nent[dim];
  while (lo < hi) {
    size_t mid = lo + (hi - lo) / 2;
    if (e[mid].tag < tag)
      lo = mid + 1;
    else
      hi = mid;
  }
  return (lo < w->nent[dim] && e[lo].tag == tag) ? e[lo].ref : tag;
}

/* ------------------------------------------------------------------------ */
/* Reading: sections                                                        */
/* ------------------------------------------------------------------------ */

/* A double-quoted string on the current line: its first byte at *start, its
 * length in *len (the quotes not included). */
static pa_status rd_quoted(reader *r, size_t *start, size_t *len,
                           const char *what) {
  if (!rd_mark(r)) return rd_eof(r, what);
  if (r->buf[r->pos] != '"') return rd_bad(r, what);
  size_t e = r->pos + 1;
  while (e < r->len && r->buf[e] != '"' && r->buf[e] != '\n')
    e++;
  if (e >= r->len || r->buf[e] != '"')
    return rd_error(r, PA_ERR_FORMAT, "unterminated %s", what);
  *start = r->pos + 1;
  *len = e - r->pos - 1;
  r->pos = e + 1;
  return PA_SUCCESS;
}

static int cmp_name(const void *a, const void *b) {
  const pa__name *x = a, *y = b;
  if (x->dim != y->dim) return (x->dim > y->dim) - (x->dim < y->dim);
  return (x->tag > y->tag) - (x->tag < y->tag);
}

/* $PhysicalNames (always ASCII): the names, each (dimension, tag) once. */
static pa_status read_physical_names(reader *r, msh *w) {
  pa_status st = PA_SUCCESS;
  uint64_t n;
  int64_t dim, tag;
  if (w->have_names)
    RD_FAIL(r, PA_ERR_UNSUPPORTED, "repeated $PhysicalNames section");
  w->have_names = 1;
  PA_CALL(rd_u64(r, &n, "the number of physical names"));
  long line = r->tokline;
  size_t pos = r->tokpos;
  PA_CALL(rd_fits(r, n, 6, 6, "$PhysicalNames header"));
  if (n > INT32_MAX)
    RD_FAIL(r, PA_ERR_UNSUPPORTED, "more than %d physical names", INT32_MAX);
  PA_CALLOC(w->names, n);
  for (uint64_t k = 0; k < n; k++) {
    size_t start = 0, len = 0;
    PA_CALL(rd_i64(r, 0, 3, &dim, "a physical dimension"));
    PA_CALL(rd_i64(r, INT32_MIN, INT32_MAX, &tag, "a physical tag"));
    PA_CALL(rd_quoted(r, &start, &len, "quoted physical name"));
    if (!len) RD_FAIL(r, PA_ERR_FORMAT, "empty physical name");
    if (memchr(r->buf + start, '\0', len) || memchr(r->buf + start, '\r', len))
      RD_FAIL(r, PA_ERR_FORMAT, "physical name holds a NUL or CR byte");
    pa__name *p = &w->names[w->nname];
    PA_ALLOC(p->name, len + 1);
    memcpy(p->name, r->buf + start, len);
    p->name[len] = '\0';
    p->dim = (int)dim;
    p->tag = (int32_t)tag;
    w->nname++;
  }
  qsort(w->names, w->nname, sizeof *w->names, cmp_name);
  for (size_t k = 1; k < w->nname; k++)
    if (!cmp_name(&w->names[k - 1], &w->names[k])) {
      r->tokline = line;
      r->tokpos = pos;
      RD_FAIL(r, PA_ERR_FORMAT,
              "$PhysicalNames names (dimension %d, tag %d) twice",
              w->names[k].dim, (int)w->names[k].tag);
    }
  PA_CALL(rd_expect(r, "$EndPhysicalNames"));
cleanup:
  return st;
}

/* $Entities (MSH 4.1): the reference of each entity. */
static pa_status read_entities(reader *r, msh *w) {
  pa_status st = PA_SUCCESS;
  uint64_t count[4], total = 0;
  if (w->has_entities)
    RD_FAIL(r, PA_ERR_UNSUPPORTED, "repeated $Entities section");
  if (r->binary) PA_CALL(rd_eol(r));
  for (int d = 0; d < 4; d++) {
    PA_CALL(get_size(r, &count[d], "the number of entities"));
    PA_CALL(rd_fits(r, count[d], 10, 36, "$Entities header"));
    total += count[d];
  }
  PA_CALL(rd_fits(r, total, 10, 36, "$Entities header"));
  for (int d = 0; d < 4; d++) {
    PA_ALLOC(w->ent[d], count[d]);
    w->nent[d] = (size_t)count[d];
    for (uint64_t k = 0; k < count[d]; k++) {
      int32_t tag, phys = 0, dummy;
      uint64_t nphys, nbound;
      double bb;
      PA_CALL(get_int(r, &tag, "an entity tag"));
      for (int i = 0; i < (d == 0 ? 3 : 6); i++)
        PA_CALL(get_f64(r, &bb, "an entity bounding box"));
      PA_CALL(get_size(r, &nphys, "a number of physical tags"));
      PA_CALL(rd_fits(r, nphys, 2, 4, "physical tag list"));
      for (uint64_t i = 0; i < nphys; i++)
        PA_CALL(get_int(r, i ? &dummy : &phys, "a physical tag"));
      if (d > 0) {
        PA_CALL(get_size(r, &nbound, "a number of bounding entities"));
        PA_CALL(rd_fits(r, nbound, 2, 4, "bounding entity list"));
        if (r->binary)
          r->pos += 4 * (size_t)nbound;
        else
          for (uint64_t i = 0; i < nbound; i++)
            PA_CALL(get_int(r, &dummy, "a bounding entity tag"));
      }
      w->ent[d][k].tag = tag;
      w->ent[d][k].ref = nphys ? phys : tag;
    }
    qsort(w->ent[d], w->nent[d], sizeof *w->ent[d], cmp_entity);
  }
  w->has_entities = 1;
  PA_CALL(rd_expect(r, "$EndEntities"));
cleanup:
  return st;
}

/* Allocate node storage for n nodes announced by a $Nodes header. */
static pa_status alloc_nodes(reader *r, msh *w, uint64_t n, size_t each_ascii,
                             size_t each_binary) {
  pa_status st = PA_SUCCESS;
  if (w->have_nodes) RD_FAIL(r, PA_ERR_UNSUPPORTED, "repeated $Nodes section");
  PA_CALL(rd_fits(r, n, each_ascii, each_binary, "$Nodes header"));
  if (n > INT32_MAX - 1)
    RD_FAIL(r, PA_ERR_UNSUPPORTED, "%llu nodes do not fit 32-bit indices",
            (unsigned long long)n);
  PA_ALLOC(w->xyz, 3 * n);
  PA_ALLOC(w->tag, n);
cleanup:
  return st;
}

/* Check a coordinate just read (at r->tokpos / r->tokline). */
static pa_status check_coord(reader *r, double x) {
  if (isfinite(x)) return PA_SUCCESS;
  return rd_error(r, PA_ERR_FORMAT, "node coordinate is not finite (%g)", x);
}

/* $Nodes of MSH 4.1. */
static pa_status read_nodes41(reader *r, msh *w) {
  pa_status st = PA_SUCCESS;
  uint64_t nblock, nnode, tmin, tmax;
  size_t done = 0;
  if (r->binary) PA_CALL(rd_eol(r));
  PA_CALL(get_size(r, &nblock, "the number of node blocks"));
  PA_CALL(get_size(r, &nnode, "the number of nodes"));
  PA_CALL(get_size(r, &tmin, "the minimum node tag"));
  PA_CALL(get_size(r, &tmax, "the maximum node tag"));
  PA_CALL(alloc_nodes(r, w, nnode, 8, 32));
  PA_CALL(rd_fits(r, nblock, 8, 20, "$Nodes header's block count"));
  for (uint64_t b = 0; b < nblock; b++) {
    int32_t edim, etag, param;
    uint64_t n;
    PA_CALL(get_int(r, &edim, "a node block entity dimension"));
    PA_CALL(get_int(r, &etag, "a node block entity tag"));
    PA_CALL(get_int(r, &param, "a node block parametric flag"));
    PA_CALL(get_size(r, &n, "the number of nodes in a block"));
    if (edim < 0 || edim > 3)
      RD_FAIL(r, PA_ERR_FORMAT, "invalid entity dimension %d", (int)edim);
    if (param != 0 && param != 1)
      RD_FAIL(r, PA_ERR_FORMAT, "invalid parametric flag %d", (int)param);
    if (n > nnode - done)
      RD_FAIL(r, PA_ERR_FORMAT,
              "node blocks hold more nodes than the %llu of the $Nodes header",
              (unsigned long long)nnode);
    int ncoord = 3 + (param ? edim : 0); /* parametric u, v, w discarded */
    PA_CALL(rd_fits(r, n, 2 + 2 * (size_t)ncoord, 8 + 8 * (size_t)ncoord,
                    "node block"));
    if (r->binary) {
      memcpy(w->tag + done, r->buf + r->pos, 8 * n);
      r->pos += 8 * n;
      for (uint64_t i = 0; i < n; i++) {
        const char *p = r->buf + r->pos + 8 * (size_t)ncoord * i;
        memcpy(w->xyz + 3 * (done + i), p, 24);
        for (int k = 0; k < 3; k++) {
          r->tokpos = r->pos + 8 * ((size_t)ncoord * i + k);
          PA_CALL(check_coord(r, w->xyz[3 * (done + i) + k]));
        }
      }
      r->pos += 8 * (size_t)ncoord * n;
    } else {
      for (uint64_t i = 0; i < n; i++)
        PA_CALL(rd_u64(r, &w->tag[done + i], "a node tag"));
      for (uint64_t i = 0; i < n; i++)
        for (int k = 0; k < ncoord; k++) {
          double x;
          PA_CALL(rd_f64(r, &x, "a node coordinate"));
          PA_CALL(check_coord(r, x));
          if (k < 3) w->xyz[3 * (done + i) + k] = x;
        }
    }
    done += n;
  }
  if (done != nnode)
    RD_FAIL(r, PA_ERR_FORMAT,
            "the $Nodes header declares %llu nodes but its blocks hold %zu",
            (unsigned long long)nnode, done);
  w->nnode = done;
  w->have_nodes = 1;
  PA_CALL(rd_expect(r, "$EndNodes"));
  PA_CALL(build_node_map(r, w));
cleanup:
  return st;
}

/* $Nodes of MSH 2.2 (ASCII). */
static pa_status read_nodes22(reader *r, msh *w) {
  pa_status st = PA_SUCCESS;
  uint64_t n;
  PA_CALL(rd_u64(r, &n, "the number of nodes"));
  PA_CALL(alloc_nodes(r, w, n, 8, 8));
  for (uint64_t i = 0; i < n; i++) {
    PA_CALL(rd_u64(r, &w->tag[i], "a node tag"));
    for (int k = 0; k < 3; k++) {
      PA_CALL(rd_f64(r, &w->xyz[3 * i + k], "a node coordinate"));
      PA_CALL(check_coord(r, w->xyz[3 * i + k]));
    }
  }
  w->nnode = (size_t)n;
  w->have_nodes = 1;
  PA_CALL(rd_expect(r, "$EndNodes"));
  PA_CALL(build_node_map(r, w));
cleanup:
  return st;
}

/* One block of n elements of a kind, reference ref (MSH 4.1). */
static pa_status read_elem_block(reader *r, msh *w, int kind, uint64_t n,
                                 int32_t ref) {
  pa_status st = PA_SUCCESS;
  int nn = kind + 1;
  cellbuf *c = &w->cell[kind];
  PA_CALL(rd_fits(r, n, 2 * (size_t)(1 + nn), 8 * (size_t)(1 + nn),
                  "element block"));
  PA_CALL(cell_reserve(r, c, kind, c->n + n));
  pa_idx *v = c->v + (size_t)nn * c->n;
  for (uint64_t i = 0; i < n; i++) {
    uint64_t etag, t;
    if (r->binary) {
      const char *p = r->buf + r->pos + 8 * (size_t)(1 + nn) * i;
      memcpy(&etag, p, 8);
      for (int k = 0; k < nn; k++) {
        memcpy(&t, p + 8 * (k + 1), 8);
        pa_idx idx = node_index(w, t);
        if (idx < 0) {
          r->tokpos = (size_t)(p + 8 * (k + 1) - r->buf);
          PA_CALL(unknown_node(r, etag, t));
        }
        v[(size_t)nn * i + k] = idx;
      }
    } else {
      PA_CALL(rd_u64(r, &etag, "an element tag"));
      for (int k = 0; k < nn; k++) {
        PA_CALL(rd_u64(r, &t, "a node tag of an element"));
        pa_idx idx = node_index(w, t);
        if (idx < 0) PA_CALL(unknown_node(r, etag, t));
        v[(size_t)nn * i + k] = idx;
      }
    }
    c->ref[c->n + i] = ref;
    c->tag[c->n + i] = etag;
  }
  if (r->binary) r->pos += 8 * (size_t)(1 + nn) * n;
  c->n += n;
cleanup:
  return st;
}

/* $Elements of MSH 4.1. */
static pa_status read_elements41(reader *r, msh *w) {
  pa_status st = PA_SUCCESS;
  uint64_t nblock, nelem, tmin, tmax, done = 0;
  if (!w->have_nodes) RD_FAIL(r, PA_ERR_FORMAT, "$Elements before $Nodes");
  if (w->have_elems)
    RD_FAIL(r, PA_ERR_UNSUPPORTED, "repeated $Elements section");
  if (r->binary) PA_CALL(rd_eol(r));
  PA_CALL(get_size(r, &nblock, "the number of element blocks"));
  PA_CALL(get_size(r, &nelem, "the number of elements"));
  PA_CALL(get_size(r, &tmin, "the minimum element tag"));
  PA_CALL(get_size(r, &tmax, "the maximum element tag"));
  PA_CALL(rd_fits(r, nblock, 8, 20, "$Elements header's block count"));
  PA_CALL(rd_fits(r, nelem, 4, 16, "$Elements header"));
  for (uint64_t b = 0; b < nblock; b++) {
    int32_t edim, etag, type;
    uint64_t n;
    int kind = 0;
    PA_CALL(get_int(r, &edim, "an element block entity dimension"));
    PA_CALL(get_int(r, &etag, "an element block entity tag"));
    PA_CALL(get_int(r, &type, "an element type"));
    PA_CALL(elem_kind(r, type, &kind));
    PA_CALL(get_size(r, &n, "the number of elements in a block"));
    if (edim < 0 || edim > 3)
      RD_FAIL(r, PA_ERR_FORMAT, "invalid entity dimension %d", (int)edim);
    if (n > nelem - done)
      RD_FAIL(r, PA_ERR_FORMAT,
              "element blocks hold more elements than the %llu of the "
              "$Elements header",
              (unsigned long long)nelem);
    PA_CALL(read_elem_block(r, w, kind, n, entity_ref(w, edim, etag)));
    done += n;
  }
  if (done != nelem)
    RD_FAIL(r, PA_ERR_FORMAT,
            "the $Elements header declares %llu elements but its blocks hold "
            "%llu",
            (unsigned long long)nelem, (unsigned long long)done);
  w->have_elems = 1;
  PA_CALL(rd_expect(r, "$EndElements"));
cleanup:
  return st;
}

/* $Elements of MSH 2.2 (ASCII): tag type ntags tags... nodes... per line. */
static pa_status read_elements22(reader *r, msh *w) {
  pa_status st = PA_SUCCESS;
  uint64_t n;
  if (!w->have_nodes) RD_FAIL(r, PA_ERR_FORMAT, "$Elements before $Nodes");
  if (w->have_elems)
    RD_FAIL(r, PA_ERR_UNSUPPORTED, "repeated $Elements section");
  PA_CALL(rd_u64(r, &n, "the number of elements"));
  PA_CALL(rd_fits(r, n, 8, 8, "$Elements header"));
  for (uint64_t i = 0; i < n; i++) {
    uint64_t etag, ntag, t;
    int64_t type, tg, phys = 0, elem = 0;
    int kind = 0;
    PA_CALL(rd_u64(r, &etag, "an element tag"));
    PA_CALL(rd_i64(r, 0, INT32_MAX, &type, "an element type"));
    PA_CALL(elem_kind(r, type, &kind));
    PA_CALL(rd_u64(r, &ntag, "the number of element tags"));
    PA_CALL(rd_fits(r, ntag, 2, 2, "element tag list"));
    for (uint64_t k = 0; k < ntag; k++) {
      PA_CALL(rd_i64(r, INT32_MIN, INT32_MAX, &tg, "an element tag value"));
      if (k == 0) phys = tg;
      if (k == 1) elem = tg;
    }
    cellbuf *c = &w->cell[kind];
    PA_CALL(cell_reserve(r, c, kind, c->n + 1));
    for (int k = 0; k <= kind; k++) {
      PA_CALL(rd_u64(r, &t, "a node tag of an element"));
      pa_idx idx = node_index(w, t);
      if (idx < 0) PA_CALL(unknown_node(r, etag, t));
      c->v[(size_t)(kind + 1) * c->n + k] = idx;
    }
    c->tag[c->n] = etag;
    c->ref[c->n++] = (int32_t)(phys != 0 ? phys : elem);
  }
  w->have_elems = 1;
  PA_CALL(rd_expect(r, "$EndElements"));
cleanup:
  return st;
}

/* The header of a $NodeData, $ElementData or $ElementNodeData section (its
 * tags are ASCII in binary files too): the first string tag (the view name)
 * at name/namelen, the time step, the number of components and of records.
 * In binary files the data starts after the line of the last integer tag. */
static pa_status read_data_header(reader *r, size_t *name, size_t *namelen,
                                  int32_t *step, int32_t *ncomp, uint64_t *n,
                                  int *mark) {
  pa_status st = PA_SUCCESS;
  uint64_t nstr, nreal, nint;
  double x;
  int64_t t[3] = {0, 0, 0}, extra;
  PA_CALL(rd_u64(r, &nstr, "the number of string tags"));
  if (nstr < 1)
    RD_FAIL(r, PA_ERR_FORMAT, "a data section needs a string tag (its name)");
  PA_CALL(rd_fits(r, nstr, 3, 3, "string tag list"));
  for (uint64_t k = 0; k < nstr; k++) {
    size_t a = 0, l = 0;
    PA_CALL(rd_quoted(r, &a, &l, "quoted string tag"));
    if (k == 0) {
      *name = a;
      *namelen = l;
    }
  }
  PA_CALL(rd_u64(r, &nreal, "the number of real tags"));
  PA_CALL(rd_fits(r, nreal, 2, 2, "real tag list"));
  for (uint64_t k = 0; k < nreal; k++)
    PA_CALL(rd_f64(r, &x, "a real tag"));
  PA_CALL(rd_u64(r, &nint, "the number of integer tags"));
  if (nint < 3)
    RD_FAIL(r, PA_ERR_FORMAT,
            "a data section needs 3 integer tags (time step, number of "
            "components, number of values), found %llu",
            (unsigned long long)nint);
  PA_CALL(rd_fits(r, nint, 2, 2, "integer tag list"));
  PA_CALL(rd_i64(r, 0, INT32_MAX, &t[0], "a time step index"));
  PA_CALL(rd_i64(r, 1, 9, &t[1], "a number of components (1 to 9)"));
  PA_CALL(rd_i64(r, 0, INT64_MAX, &t[2], "a number of values"));
  *mark = -1;
  for (uint64_t k = 3; k < nint; k++) {
    PA_CALL(rd_i64(r, INT32_MIN, INT32_MAX, &extra, "an integer tag"));
    if (k == 4) *mark = (int)extra;
  }
  if (r->binary) {
    while (r->pos < r->len && (r->buf[r->pos] == ' ' || r->buf[r->pos] == '\t'))
      r->pos++;
    PA_CALL(rd_eol(r));
  }
  *step = (int32_t)t[0];
  *ncomp = (int32_t)t[1];
  *n = (uint64_t)t[2];
cleanup:
  return st;
}

/* The view named name (created when new, with ncomp components and time
 * step step; an existing one must agree). */
static pa_status find_view(reader *r, msh *w, const char *name, int32_t ncomp,
                           int32_t step, view **out) {
  pa_status st = PA_SUCCESS;
  view *v = NULL;
  for (int k = 0; k < w->nview; k++)
    if (!strcmp(w->views[k].name, name)) v = &w->views[k];
  if (v) {
    if (v->step != step)
      RD_FAIL(r, PA_ERR_UNSUPPORTED,
              "view \"%s\" has several time steps (%d and %d); padapt reads "
              "views of one time step",
              name, (int)v->step, (int)step);
    if (v->ncomp != ncomp)
      RD_FAIL(r, PA_ERR_FORMAT,
              "view \"%s\" has %d components here and %d in an earlier "
              "section",
              name, (int)ncomp, v->ncomp);
  } else {
    if (w->nview == MSH_MAX_VIEWS)
      RD_FAIL(r, PA_ERR_UNSUPPORTED,
              "more than %d node data views (the metric and %d fields)",
              MSH_MAX_VIEWS, PA_MESH_MAX_FIELDS);
    v = &w->views[w->nview++]; /* counted now: msh_free frees its arrays */
    snprintf(v->name, sizeof v->name, "%s", name);
    v->ncomp = ncomp;
    v->step = step;
    v->line = r->tokline;
    v->pos = r->tokpos;
    PA_CALLOC(v->val, w->nnode * (size_t)ncomp);
    PA_CALLOC(v->seen, w->nnode);
  }
  *out = v;
cleanup:
  return st;
}

/* $NodeData: one view (or part of one) of values at the nodes. */
static pa_status read_node_data(reader *r, msh *w) {
  pa_status st = PA_SUCCESS;
  size_t a = 0, l = 0;
  int32_t step, nc;
  uint64_t n;
  char name[PA_MESH_FIELD_NAME_LEN];
  view *v = NULL;
  if (!w->have_nodes) RD_FAIL(r, PA_ERR_FORMAT, "$NodeData before $Nodes");
  rd_mark(r);
  long line = r->tokline;
  size_t pos = r->tokpos;
  int mark;
  PA_CALL(read_data_header(r, &a, &l, &step, &nc, &n, &mark));
  if (l == 0 || l >= sizeof name || memchr(r->buf + a, '\0', l) ||
      memchr(r->buf + a, '\r', l)) {
    r->tokline = line;
    r->tokpos = pos;
    RD_FAIL(r, PA_ERR_FORMAT,
            "a view name has 1 to %d bytes, none of them NUL or CR",
            (int)sizeof name - 1);
  }
  memcpy(name, r->buf + a, l);
  name[l] = '\0';
  r->tokline = line;
  r->tokpos = pos;
  PA_CALL(find_view(r, w, name, nc, step, &v));
  PA_CALL(rd_fits(r, n, 2 + 2 * (size_t)nc, 4 + 8 * (size_t)nc,
                  "$NodeData header"));
  for (uint64_t i = 0; i < n; i++) {
    uint64_t tag;
    double x[9];
    if (r->binary) {
      int32_t t32;
      PA_CALL(rd_bytes(r, &t32, 4, "a node tag"));
      tag = t32 < 0 ? 0 : (uint64_t)t32;
      for (int k = 0; k < nc; k++)
        PA_CALL(rd_bytes(r, &x[k], 8, "a node value"));
    } else {
      PA_CALL(rd_u64(r, &tag, "a node tag"));
      for (int k = 0; k < nc; k++)
        PA_CALL(rd_f64(r, &x[k], "a node value"));
    }
    pa_idx idx = node_index(w, tag);
    if (idx < 0)
      RD_FAIL(r, PA_ERR_FORMAT, "view \"%s\": unknown node tag %llu", name,
              (unsigned long long)tag);
    if (v->seen[idx])
      RD_FAIL(r, PA_ERR_FORMAT, "view \"%s\": node %llu has two values", name,
              (unsigned long long)tag);
    for (int k = 0; k < nc; k++)
      if (!isfinite(x[k]))
        RD_FAIL(r, PA_ERR_FORMAT,
                "view \"%s\": the value of node %llu is not "
                "finite",
                name, (unsigned long long)tag);
    v->seen[idx] = 1;
    memcpy(v->val + (size_t)nc * idx, x, (size_t)nc * sizeof *x);
  }
  PA_CALL(rd_expect(r, "$EndNodeData"));
cleanup:
  return st;
}

/* $ElementData: one view (or part of one) of values at the cells, kept by
 * element tag until the mesh is built (attach_cell_views). */
static pa_status read_element_data(reader *r, msh *w) {
  pa_status st = PA_SUCCESS;
  size_t a = 0, l = 0;
  int32_t step, nc;
  uint64_t n;
  int mark;
  eview *v = NULL;
  rd_mark(r);
  long line = r->tokline;
  size_t pos = r->tokpos;
  PA_CALL(read_data_header(r, &a, &l, &step, &nc, &n, &mark));
  r->tokline = line;
  r->tokpos = pos;
  if (l == 0 || l >= sizeof v->name || memchr(r->buf + a, '\0', l) ||
      memchr(r->buf + a, '\r', l))
    RD_FAIL(r, PA_ERR_FORMAT,
            "a view name has 1 to %d bytes, none of them NUL or CR",
            (int)sizeof v->name - 1);
  for (int k = 0; k < w->neview; k++)
    if (strlen(w->eviews[k].name) == l && !memcmp(w->eviews[k].name, r->buf + a, l))
      v = &w->eviews[k];
  if (v && (v->step != step || v->ncomp != nc))
    RD_FAIL(r, PA_ERR_UNSUPPORTED,
            "element view \"%s\": a section of another time step or number "
            "of components; padapt reads views of one time step",
            v->name);
  if (!v) {
    if (w->neview == MSH_MAX_EVIEWS)
      RD_FAIL(r, PA_ERR_UNSUPPORTED, "more than %d element data views",
              MSH_MAX_EVIEWS);
    v = &w->eviews[w->neview++];
    memset(v, 0, sizeof *v);
    memcpy(v->name, r->buf + a, l);
    v->name[l] = '\0';
    v->ncomp = nc;
    v->step = step;
    v->mark = mark;
    v->line = line;
    v->pos = pos;
  }
  PA_CALL(rd_fits(r, n, 2 + 2 * (size_t)nc, 4 + 8 * (size_t)nc,
                  "$ElementData header"));
  PA_GROW(v->tag, v->capt, v->n + n);
  PA_GROW(v->val, v->capv, (v->n + n) * (size_t)nc);
  for (uint64_t i = 0; i < n; i++) {
    uint64_t tag;
    double *x = v->val + (v->n + i) * (size_t)nc;
    if (r->binary) {
      int32_t t32;
      PA_CALL(rd_bytes(r, &t32, 4, "an element tag"));
      tag = t32 < 0 ? 0 : (uint64_t)t32;
      for (int k = 0; k < nc; k++) PA_CALL(rd_bytes(r, &x[k], 8, "an element value"));
    } else {
      PA_CALL(rd_u64(r, &tag, "an element tag"));
      for (int k = 0; k < nc; k++) PA_CALL(rd_f64(r, &x[k], "an element value"));
    }
    for (int k = 0; k < nc; k++)
      if (!isfinite(x[k]))
        RD_FAIL(r, PA_ERR_FORMAT,
                "view \"%s\": the value of element %llu is not finite",
                v->name, (unsigned long long)tag);
    v->tag[v->n + i] = tag;
  }
  v->n += n;
  PA_CALL(rd_expect(r, "$EndElementData"));
cleanup:
  return st;
}

/* A binary $ElementNodeData section: skipped record by record (values at
 * the nodes of each element are not read). */
static pa_status skip_binary_data(reader *r, const char *name) {
  pa_status st = PA_SUCCESS;
  size_t a, l;
  int32_t step, nc;
  uint64_t n;
  int pernode = !strcmp(name, "ElementNodeData"), mark;
  PA_CALL(read_data_header(r, &a, &l, &step, &nc, &n, &mark));
  PA_CALL(rd_fits(r, n, 1, 4 + (pernode ? 4 : 8 * (size_t)nc), name));
  for (uint64_t i = 0; i < n; i++) {
    int32_t hdr[2] = {0, 1};
    PA_CALL(rd_bytes(r, hdr, pernode ? 8 : 4, "an element tag"));
    if (hdr[1] < 0)
      RD_FAIL(r, PA_ERR_FORMAT, "negative number of nodes per element");
    size_t bytes = 8 * (size_t)nc * (size_t)hdr[1];
    PA_CALL(rd_need(r, bytes, "element values"));
    r->pos += bytes;
  }
  PA_CALL(rd_expect(r, pernode ? "$EndElementNodeData" : "$EndElementData"));
cleanup:
  return st;
}

/* Skip a section we do not read, up to its "$End<name>" line. */
static pa_status skip_section(reader *r, const char *name) {
  pa_status st = PA_SUCCESS;
  char end[80];
  snprintf(end, sizeof end, "$End%s", name);
  size_t n = strlen(end);
  for (size_t k = r->pos;; k++) {
    const char *p = memchr(r->buf + k, '$', r->len - k);
    if (!p)
      RD_FAIL(r, PA_ERR_FORMAT, "section $%s has no %s line (truncated?)", name,
              end);
    k = (size_t)(p - r->buf);
    if (n <= r->len - k && !memcmp(p, end, n) && r->buf[k - 1] == '\n' &&
        rd_ends(r, k + n)) {
      for (size_t i = r->pos; i < k; i++)
        r->line += r->buf[i] == '\n';
      r->pos = k + n;
      break;
    }
  }
cleanup:
  return st;
}

/* 1 for the sections whose binary layout we know but do not read. */
static int binary_layout_section(const char *name) {
  static const char *const known[] = {"PartitionedEntities", "Periodic",
                                      "GhostElements", "Parametrizations",
                                      "InterpolationScheme"};
  for (size_t i = 0; i < sizeof known / sizeof *known; i++)
    if (!strcmp(name, known[i])) return 1;
  return 0;
}

/* $MeshFormat: version, file type, data size, endianness. */
static pa_status read_header(reader *r, msh *w) {
  pa_status st = PA_SUCCESS;
  double version;
  int64_t ftype, dsize;
  char word[40];
  if (!rd_mark(r)) PA_CALL(rd_eof(r, "$MeshFormat"));
  if (strcmp(rd_word(r, word, sizeof word), "$MeshFormat"))
    RD_FAIL(r, PA_ERR_FORMAT,
            "missing $MeshFormat header (not a Gmsh .msh file?), found '%s'",
            word);
  r->pos += strlen("$MeshFormat");
  PA_CALL(rd_f64(r, &version, "the MSH version"));
  PA_CALL(rd_i64(r, 0, 1, &ftype, "the file type (0 ASCII, 1 binary)"));
  PA_CALL(rd_i64(r, 0, 64, &dsize, "the data size"));
  if (fabs(version - 4.1) < 1e-9)
    w->version = 41;
  else if (version >= 2.0 && version < 3.0)
    w->version = 22;
  else
    RD_FAIL(r, PA_ERR_UNSUPPORTED,
            "MSH version %g is not supported (padapt reads MSH 4.1, ASCII or "
            "binary, and MSH 2.2 ASCII)",
            version);
  if (ftype == 1) {
    if (w->version != 41)
      RD_FAIL(r, PA_ERR_UNSUPPORTED,
              "binary MSH %g is not supported (padapt reads binary MSH 4.1 "
              "only)",
              version);
    if (dsize != 8)
      RD_FAIL(r, PA_ERR_UNSUPPORTED,
              "binary data size %d is not supported (only 8)", (int)dsize);
    PA_CALL(rd_eol(r));
    r->binary = 1;
    int32_t one;
    PA_CALL(rd_need(r, 4, "the endianness marker"));
    memcpy(&one, r->buf + r->pos, 4);
    if (one == 0x01000000)
      RD_FAIL(r, PA_ERR_UNSUPPORTED,
              "binary file of the opposite endianness is not supported");
    if (one != 1)
      RD_FAIL(r, PA_ERR_FORMAT, "bad endianness marker (expected the int 1)");
    r->pos += 4;
  }
  PA_CALL(rd_expect(r, "$EndMeshFormat"));
cleanup:
  return st;
}

/* Every section after $MeshFormat. */
static pa_status read_sections(reader *r, msh *w) {
  pa_status st = PA_SUCCESS;
  char word[72];
  while (rd_mark(r)) {
    rd_word(r, word, sizeof word);
    if (word[0] != '$')
      RD_FAIL(r, PA_ERR_FORMAT, "expected a section ($Name), found '%s'", word);
    size_t len = strlen(word);
    if (!rd_ends(r, r->pos + len))
      RD_FAIL(r, PA_ERR_FORMAT, "section name '%s...' is too long", word);
    r->pos += len;
    const char *name = word + 1;
    if (!strcmp(name, "PhysicalNames"))
      PA_CALL(read_physical_names(r, w));
    else if (!strcmp(name, "Entities") && w->version == 41)
      PA_CALL(read_entities(r, w));
    else if (!strcmp(name, "Nodes"))
      PA_CALL(w->version == 41 ? read_nodes41(r, w) : read_nodes22(r, w));
    else if (!strcmp(name, "Elements"))
      PA_CALL(w->version == 41 ? read_elements41(r, w) : read_elements22(r, w));
    else if (!strcmp(name, "NodeData"))
      PA_CALL(read_node_data(r, w));
    else if (!strcmp(name, "ElementData"))
      PA_CALL(read_element_data(r, w));
    else if (r->binary && !strcmp(name, "ElementNodeData"))
      PA_CALL(skip_binary_data(r, name));
    else if (r->binary && binary_layout_section(name)) {
      if (w->have_nodes && w->have_elems) {
        pa__info(2, "%s: ignoring binary section $%s and what follows\n",
                 r->path, name);
        break;
      }
      RD_FAIL(r, PA_ERR_UNSUPPORTED,
              "binary section $%s before the mesh is not supported", name);
    } else
      PA_CALL(skip_section(r, name));
  }
  r->tokline = r->line;
  r->tokpos = r->pos;
  if (!w->have_nodes) RD_FAIL(r, PA_ERR_FORMAT, "no $Nodes section");
  if (!w->have_elems) RD_FAIL(r, PA_ERR_FORMAT, "no $Elements section");
cleanup:
  return st;
}

/* Give the cells of a buffer to the mesh (exact-size arrays, zero flags). */
static pa_status adopt_cells(cellbuf *c, int nn, pa_idx **v, int32_t **ref,
                             uint8_t **flag, size_t *cap, pa_idx *count) {
  pa_status st = PA_SUCCESS;
  if (!c->n) return PA_SUCCESS;
  PA_CALLOC(*flag, c->n);
  void *p = pa__realloc(c->v, c->n * nn * sizeof *c->v);
  if (p) c->v = p; /* shrinking failed: keep the larger block */
  p = pa__realloc(c->ref, c->n * sizeof *c->ref);
  if (p) c->ref = p;
  *v = c->v;
  *ref = c->ref;
  *cap = c->n;
  *count = (pa_idx)c->n;
  c->v = NULL;
  c->ref = NULL;
  c->n = c->capv = c->capr = 0;
cleanup:
  return st;
}

/* How far a 3 x 3 tensor of a view may be from symmetric (and, in 2D, from
 * having no z coupling), relative to its largest entry, and still be read
 * as a symmetric tensor: the two halves of a symmetric tensor written by a
 * program are equal; the margin covers writers that print each half after
 * its own rounding. */
#define VIEW_SYM_TOL 1e-12

/* The symmetric tensor (3 values in 2D: m11 m12 m22; 6 in 3D: m11 m12 m22
 * m13 m23 m33) of a row-major 3 x 3 tensor t; 0 if t is not symmetric or,
 * in 2D, couples z with x or y (its zz entry is ignored). */
static int sym_tensor(int dim, const double *t, double *out) {
  double big = 0;
  for (int k = 0; k < 9; k++)
    big = fmax(big, fabs(t[k]));
  double tol = VIEW_SYM_TOL * big;
  if (fabs(t[1] - t[3]) > tol || fabs(t[2] - t[6]) > tol ||
      fabs(t[5] - t[7]) > tol)
    return 0;
  out[0] = t[0];
  out[1] = 0.5 * (t[1] + t[3]);
  out[2] = t[4];
  if (dim == 2) return fabs(t[2]) <= tol && fabs(t[5]) <= tol;
  out[3] = 0.5 * (t[2] + t[6]);
  out[4] = 0.5 * (t[5] + t[7]);
  out[5] = t[8];
  return 1;
}

/* The views become the metric ("metric") and the fields of m. */
static pa_status attach_views(reader *r, msh *w, pa_mesh *m) {
  pa_status st = PA_SUCCESS;
  double *buf = NULL;
  int d = m->dim, tn = pa__tensor_ncomp(d);
  size_t n = w->nnode;
  for (int k = 0; k < w->nview; k++) {
    view *v = &w->views[k];
    int ismet = !strcmp(v->name, "metric");
    r->tokline = v->line;
    r->tokpos = v->pos;
    size_t miss = 0;
    while (miss < n && v->seen[miss])
      miss++;
    if (miss < n && ismet)
      RD_FAIL(r, PA_ERR_FORMAT, "view \"metric\" has no value at node %llu",
              (unsigned long long)w->tag[miss]);
    if (miss < n) { /* valid Gmsh, but a field has a value at every vertex */
      pa__info(1, "%s: view \"%s\" ignored: no value at node %llu\n", r->path,
               v->name, (unsigned long long)w->tag[miss]);
      continue;
    }
    int nc = v->ncomp; /* components kept */
    if (ismet && nc != 1 && nc != 9)
      RD_FAIL(r, PA_ERR_UNSUPPORTED,
              "view \"metric\" has %d components: padapt reads 1 (a size) or "
              "9 (a symmetric tensor)",
              nc);
    if (v->ncomp == 9) {
      PA_ALLOC(buf, n * (size_t)tn);
      size_t i = 0;
      while (i < n && sym_tensor(d, v->val + 9 * i, buf + (size_t)tn * i))
        i++;
      if (i < n && ismet)
        RD_FAIL(r, PA_ERR_METRIC,
                "view \"metric\": the tensor at node %llu is not symmetric%s",
                (unsigned long long)w->tag[i],
                d == 2 ? " or couples z with x, y (2D mesh)" : "");
      if (i == n) {
        nc = tn;
        pa__free(v->val);
        v->val = buf;
        buf = NULL;
      }
      pa__free(buf);
      buf = NULL;
    } else if (v->ncomp == 3 && d == 2 && !ismet) {
      for (size_t i = 0; i < n; i++)
        if (v->val[3 * i + 2] != 0.0)
          RD_FAIL(r, PA_ERR_UNSUPPORTED,
                  "view \"%s\": the vector at node %llu has z = %g, but the "
                  "mesh is 2D",
                  v->name, (unsigned long long)w->tag[i], v->val[3 * i + 2]);
      for (size_t i = 0; i < n; i++) {
        v->val[2 * i] = v->val[3 * i];
        v->val[2 * i + 1] = v->val[3 * i + 1];
      }
      nc = 2;
    }
    if (ismet) {
      for (size_t i = 0; i < n; i++)
        if (!pa__metric_valid(d, nc, v->val + (size_t)nc * i))
          RD_FAIL(r, PA_ERR_METRIC,
                  "view \"metric\": the value at node %llu is not %s",
                  (unsigned long long)w->tag[i],
                  nc == 1 ? "a finite positive size"
                          : "a symmetric positive definite tensor");
      PA_CALL(pa_mesh_set_metric(m, nc, v->val));
    } else {
      PA_CALL(pa_mesh_add_field(m, v->name, nc, v->val));
    }
  }
cleanup:
  pa__free(buf);
  return st;
}

/* The element views become element fields (on a view holding a value at
 * every element) and boundary fields (at every boundary entity), as far
 * as a padapt view's mark allows; values at other cells (corners, feature
 * edges) are not read. Vectors of 3 components in 2D with z = 0 keep x
 * and y; symmetric 3 x 3 tensors become 3 or 6 values. */
static pa_status attach_cell_views(reader *r, msh *w, pa_mesh *m) {
  pa_status st = PA_SUCCESS;
  int d = m->dim, tn = pa__tensor_ncomp(d);
  tagidx *map[2] = {NULL, NULL};
  size_t nmap[2] = {(size_t)m->ne, (size_t)m->nb};
  double *val[2] = {NULL, NULL}, *tmp = NULL;
  uint8_t *seen[2] = {NULL, NULL};
  if (!w->neview) return PA_SUCCESS;
  for (int k = 0; k < 2; k++) {
    const cellbuf *c = &w->cell[d - k];
    PA_ALLOC(map[k], nmap[k] ? nmap[k] : 1);
    for (size_t i = 0; i < nmap[k]; i++) map[k][i].tag = c->tag[i], map[k][i].idx = (pa_idx)i;
    qsort(map[k], nmap[k], sizeof *map[k], cmp_tagidx);
  }
  for (int e = 0; e < w->neview; e++) {
    eview *v = &w->eviews[e];
    int nc = v->ncomp;
    r->tokline = v->line;
    r->tokpos = v->pos;
    for (int k = 0; k < 2; k++) {
      PA_CALLOC(val[k], (nmap[k] ? nmap[k] : 1) * (size_t)nc);
      PA_CALLOC(seen[k], nmap[k] ? nmap[k] : 1);
    }
    for (size_t i = 0; i < v->n; i++) {
      tagidx key = {v->tag[i], 0};
      for (int k = 0; k < 2; k++) {
        const tagidx *f = bsearch(&key, map[k], nmap[k], sizeof key, cmp_tagidx);
        if (!f) continue;
        if (seen[k][f->idx])
          RD_FAIL(r, PA_ERR_FORMAT, "view \"%s\": element %llu has two values",
                  v->name, (unsigned long long)v->tag[i]);
        seen[k][f->idx] = 1;
        memcpy(val[k] + (size_t)nc * f->idx, v->val + (size_t)nc * i,
               (size_t)nc * sizeof(double));
      }
    }
    for (int k = 0; k < 2; k++) {
      int bit = k == 0 ? GMSH_VIEW_ELEMENTS : GMSH_VIEW_BOUNDARY;
      size_t miss = 0, n = nmap[k];
      while (miss < n && seen[k][miss]) miss++;
      if (!n || (v->mark >= 0 && !(v->mark & bit))) continue;
      if (miss < n) {
        if (v->mark >= 0)
          RD_FAIL(r, PA_ERR_FORMAT, "view \"%s\" has no value at %s %llu",
                  v->name, k ? "boundary entity" : "element",
                  (unsigned long long)w->cell[d - k].tag[miss]);
        pa__info(1, "%s: view \"%s\" not read on the %s: no value at "
                    "element %llu\n",
                 r->path, v->name, k ? "boundary entities" : "elements",
                 (unsigned long long)w->cell[d - k].tag[miss]);
        continue;
      }
      int mc = nc;
      const double *x = val[k];
      PA_ALLOC(tmp, n * (size_t)(nc > tn ? nc : tn));
      if (nc == 9) {
        size_t i = 0;
        while (i < n && sym_tensor(d, val[k] + 9 * i, tmp + (size_t)tn * i)) i++;
        if (i == n) mc = tn, x = tmp;
      } else if (nc == 3 && d == 2) {
        size_t i = 0;
        while (i < n && val[k][3 * i + 2] == 0.0) {
          tmp[2 * i] = val[k][3 * i];
          tmp[2 * i + 1] = val[k][3 * i + 1];
          i++;
        }
        if (i == n) mc = 2, x = tmp;
      }
      PA_CALL(pa_mesh_add_field_at(m, k ? PA_BOUNDARY : PA_ELEMENT, v->name, mc, x));
      pa__free(tmp);
      tmp = NULL;
    }
    for (int k = 0; k < 2; k++) {
      pa__free(val[k]);
      pa__free(seen[k]);
      val[k] = NULL;
      seen[k] = NULL;
    }
  }
cleanup:
  for (int k = 0; k < 2; k++) {
    pa__free(map[k]);
    pa__free(val[k]);
    pa__free(seen[k]);
  }
  pa__free(tmp);
  return st;
}

/* Build the mesh from what was read; the buffers move into it. */
static pa_status build_mesh(reader *r, msh *w, pa_mesh **out) {
  pa_status st = PA_SUCCESS;
  pa_mesh *m = NULL;
  int dim = w->cell[3].n ? 3 : w->cell[2].n ? 2 : 0;
  if (!dim) {
    dim = 2;
    for (size_t i = 0; i < w->nnode; i++)
      if (w->xyz[3 * i + 2] != 0.0) dim = 3;
  }
  if (dim == 2)
    for (size_t i = 0; i < w->nnode; i++)
      if (w->xyz[3 * i + 2] != 0.0)
        PA_FAIL(PA_ERR_FORMAT,
                "%s: node %llu has z = %g, but a mesh without tetrahedra is "
                "read as 2D and must lie in the plane z = 0",
                r->path, (unsigned long long)w->tag[i], w->xyz[3 * i + 2]);
  PA_CALL(pa_mesh_create(dim, &m));
  if (w->nnode) {
    size_t n = w->nnode;
    if (dim == 2) {
      for (size_t i = 0; i < n; i++) {
        w->xyz[2 * i] = w->xyz[3 * i];
        w->xyz[2 * i + 1] = w->xyz[3 * i + 1];
      }
      void *p = pa__realloc(w->xyz, 2 * n * sizeof *w->xyz);
      if (p) w->xyz = p;
    }
    PA_CALLOC(m->vref, n);
    PA_CALLOC(m->vflag, n);
    m->coord = w->xyz;
    w->xyz = NULL;
    m->capv = n;
    m->nv = (pa_idx)n;
  }
  const cellbuf *pts = &w->cell[0];
  for (size_t i = 0; i < pts->n; i++) {
    m->vflag[pts->v[i]] |= PA_FLAG_CORNER;
    m->vref[pts->v[i]] = pts->ref[i];
  }
  PA_CALL(adopt_cells(&w->cell[dim], dim + 1, &m->elem, &m->eref, &m->eflag,
                      &m->cape, &m->ne));
  PA_CALL(adopt_cells(&w->cell[dim - 1], dim, &m->bdry, &m->bref, &m->bflag,
                      &m->capb, &m->nb));
  if (dim == 3)
    PA_CALL(adopt_cells(&w->cell[1], 2, &m->edge, &m->edref, &m->edflag,
                        &m->caped, &m->ned));
  m->names = w->names; /* sorted, each (dim, tag) once */
  m->nname = (int)w->nname;
  w->names = NULL;
  w->nname = 0;
  PA_CALL(attach_views(r, w, m));
  PA_CALL(attach_cell_views(r, w, m));
  *out = m;
  m = NULL;
cleanup:
  pa_mesh_destroy(m);
  return st;
}

/* Read the whole file into a NUL-terminated buffer. */
static pa_status load_file(reader *r) {
  pa_status st = PA_SUCCESS;
  struct stat sb;
  FILE *fp = fopen(r->path, "rb");
  PA_CHECK(fp, PA_ERR_IO, "%s: cannot open: %s", r->path, strerror(errno));
  PA_CHECK(fstat(fileno(fp), &sb) == 0 && S_ISREG(sb.st_mode), PA_ERR_IO,
           "%s: not a regular file", r->path);
  PA_CHECK(fseeko(fp, 0, SEEK_END) == 0, PA_ERR_IO, "%s: cannot seek: %s",
           r->path, strerror(errno));
  off_t size = ftello(fp);
  PA_CHECK(size >= 0 && fseeko(fp, 0, SEEK_SET) == 0, PA_ERR_IO,
           "%s: cannot read: %s", r->path, strerror(errno));
  PA_ALLOC(r->buf, (size_t)size + 1);
  r->len = (size_t)size;
  PA_CHECK(fread(r->buf, 1, r->len, fp) == r->len, PA_ERR_IO,
           "%s: cannot read: %s", r->path,
           ferror(fp) ? strerror(errno) : "file shrank while reading");
  r->buf[r->len] = '\0';
cleanup:
  if (fp) fclose(fp);
  return st;
}

pa_status pa__gmsh_read(const char *path, pa_mesh **mesh) {
  pa_status st = PA_SUCCESS;
  reader r = {0};
  msh w = {0};
  PA_CHECK(path && mesh, PA_ERR_ARG, "pa__gmsh_read: NULL argument");
  *mesh = NULL;
  r.path = path;
  r.line = r.tokline = 1;
  PA_CALL(load_file(&r));
  PA_CALL(read_header(&r, &w));
  PA_CALL(read_sections(&r, &w));
  PA_CALL(build_mesh(&r, &w, mesh));
  (*mesh)->file_dim = 3; /* nodes have three coordinates */
  pa__info(2, "%s: read MSH %s %s, %d vertices, %d elements\n", path,
           w.version == 41 ? "4.1" : "2.2", r.binary ? "binary" : "ASCII",
           (int)pa_mesh_nvert(*mesh), (int)pa_mesh_nelem(*mesh));
cleanup:
  msh_free(&w);
  pa__free(r.buf);
  return st;
}

/* ------------------------------------------------------------------------ */
/* Writing                                                                  */
/* ------------------------------------------------------------------------ */

/* Buffered output of MSH 4.1 items: ASCII (blank-separated, one record per
 * line) or binary (native bytes). Write errors are remembered in err. */
typedef struct writer {
  FILE *fp;
  char *buf;
  size_t len, cap;
  int binary;
  int bol; /* at the beginning of a line (ASCII) */
  int err;
} writer;

static void wr_flush(writer *b) {
  if (b->len && fwrite(b->buf, 1, b->len, b->fp) != b->len) b->err = 1;
  b->len = 0;
}

/* Room for n <= cap more bytes. */
static char *wr_room(writer *b, size_t n) {
  if (b->len + n > b->cap) wr_flush(b);
  return b->buf + b->len;
}

static void wr_bytes(writer *b, const void *p, size_t n) {
  if (n > b->cap / 2) {
    wr_flush(b);
    if (fwrite(p, 1, n, b->fp) != n) b->err = 1;
    return;
  }
  memcpy(wr_room(b, n), p, n);
  b->len += n;
}

/* Literal text (section keywords, header lines). */
static void wr_text(writer *b, const char *s) {
  size_t n = strlen(s);
  wr_bytes(b, s, n);
  b->bol = n && s[n - 1] == '\n';
}

static void wr_sep(writer *b) {
  if (!b->bol) b->buf[b->len++] = ' ';
  b->bol = 0;
}

/* ASCII integer: separator, sign, digits. */
static void wr_digits(writer *b, int neg, uint64_t x) {
  char tmp[24];
  int n = 0;
  do {
    tmp[n++] = (char)('0' + x % 10);
    x /= 10;
  } while (x);
  wr_room(b, 32);
  wr_sep(b);
  if (neg) b->buf[b->len++] = '-';
  while (n)
    b->buf[b->len++] = tmp[--n];
}

static void wr_u64(writer *b, uint64_t x) {
  if (b->binary)
    wr_bytes(b, &x, 8);
  else
    wr_digits(b, 0, x);
}

static void wr_int(writer *b, int32_t x) {
  if (b->binary)
    wr_bytes(b, &x, 4);
  else
    wr_digits(b, x < 0, x < 0 ? (uint64_t)(-(int64_t)x) : (uint64_t)x);
}

static void wr_f64(writer *b, double x) {
  if (b->binary) {
    wr_bytes(b, &x, 8);
    return;
  }
  wr_room(b, 40);
  wr_sep(b);
  b->len += (size_t)pa__fmt_shortest(b->buf + b->len, x);
}

static void wr_eol(writer *b) {
  if (b->binary) return;
  wr_room(b, 1);
  b->buf[b->len++] = '\n';
  b->bol = 1;
}

/* End a section: Gmsh puts a newline between binary data and "$End...". */
static void wr_end(writer *b, const char *kw) {
  if (b->binary) wr_text(b, "\n");
  wr_text(b, kw);
}

/* Cells of one kind of the mesh, grouped by reference for writing. */
typedef struct group {
  int gdim, type, nn;
  pa_idx n;
  const pa_idx *v;
  const int32_t *ref;
  int nent;
  int32_t *eref; /* distinct references, ascending */
  int32_t *etag; /* entity tag of each */
  pa_idx *start; /* nent + 1: cells of entity k are order[start[k]..] */
  pa_idx *order; /* cell indices grouped by entity, stable */
} group;

static void group_free(group *g) {
  pa__free(g->eref);
  pa__free(g->etag);
  pa__free(g->start);
  pa__free(g->order);
}

static int cmp_i32(const void *a, const void *b) {
  int32_t x = *(const int32_t *)a, y = *(const int32_t *)b;
  return (x > y) - (x < y);
}

static int find_ref(const group *g, int32_t ref) {
  int lo = 0, hi = g->nent;
  while (lo < hi) {
    int mid = lo + (hi - lo) / 2;
    if (g->eref[mid] < ref)
      lo = mid + 1;
    else
      hi = mid;
  }
  return lo;
}

static pa_status group_make(group *g, int gdim, int type, int nn, pa_idx n,
                            const pa_idx *v, const int32_t *ref) {
  pa_status st = PA_SUCCESS;
  memset(g, 0, sizeof *g);
  g->gdim = gdim;
  g->type = type;
  g->nn = nn;
  g->n = n;
  g->v = v;
  g->ref = ref;
  PA_ALLOC(g->eref, n);
  if (n) memcpy(g->eref, ref, n * sizeof *ref);
  qsort(g->eref, (size_t)n, sizeof *g->eref, cmp_i32);
  for (pa_idx i = 0; i < n; i++)
    if (!g->nent || g->eref[g->nent - 1] != g->eref[i])
      g->eref[g->nent++] = g->eref[i];
  PA_ALLOC(g->etag, g->nent);
  int64_t next = 1;
  for (int k = 0; k < g->nent; k++)
    if (g->eref[k] >= next) next = (int64_t)g->eref[k] + 1;
  for (int k = 0; k < g->nent; k++) {
    if (g->eref[k] > 0) {
      g->etag[k] = g->eref[k];
    } else {
      PA_CHECK(next <= INT32_MAX, PA_ERR_UNSUPPORTED,
               "cannot number Gmsh entities: references reach %d", INT32_MAX);
      g->etag[k] = (int32_t)next++;
    }
  }
  PA_CALLOC(g->start, g->nent + 1);
  PA_ALLOC(g->order, n);
  for (pa_idx i = 0; i < n; i++)
    g->start[find_ref(g, ref[i]) + 1]++;
  for (int k = 0; k < g->nent; k++)
    g->start[k + 1] += g->start[k];
  for (pa_idx i = 0; i < n; i++)
    g->order[g->start[find_ref(g, ref[i])]++] = i;
  for (int k = g->nent; k > 0; k--)
    g->start[k] = g->start[k - 1];
  g->start[0] = 0;
cleanup:
  return st;
}

/* Coordinate k of vertex i as written (z = 0 in 2D). */
static double coord(const pa_mesh *m, pa_idx i, int k) {
  return k < m->dim ? m->coord[(size_t)m->dim * i + k] : 0.0;
}

/* Bounding box (min xyz, max xyz) of the cells of entity k of g. */
static void entity_bbox(const pa_mesh *m, const group *g, int k, double *bb) {
  for (int j = 0; j < 3; j++) {
    bb[j] = INFINITY;
    bb[3 + j] = -INFINITY;
  }
  for (pa_idx s = g->start[k]; s < g->start[k + 1]; s++) {
    const pa_idx *cv = g->v + (size_t)g->nn * g->order[s];
    for (int a = 0; a < g->nn; a++)
      for (int j = 0; j < 3; j++) {
        double x = coord(m, cv[a], j);
        if (x < bb[j]) bb[j] = x;
        if (x > bb[3 + j]) bb[3 + j] = x;
      }
  }
}

/* One curve/surface/volume entity: tag, box, physical tags, no boundary. */
static void write_entity(writer *b, int32_t tag, const double *bb, int nphys,
                         int32_t phys) {
  wr_int(b, tag);
  for (int j = 0; j < 6; j++)
    wr_f64(b, bb[j]);
  wr_u64(b, (uint64_t)nphys);
  if (nphys) wr_int(b, phys);
  wr_u64(b, 0);
  wr_eol(b);
}

/* Components of the view of a vertex array of nc values per vertex: a
 * size or scalar 1, a vector (nc = dim) 3, a symmetric tensor (3 in 2D, 6
 * in 3D) 9; any other count as it is. */
static int view_ncomp(int dim, int nc) {
  if (nc == 1) return 1;
  if (nc == dim) return 3;
  if (nc == pa__tensor_ncomp(dim)) return 9;
  return nc;
}

/* The tag of a view's record: 4 bytes in binary files, as Gmsh and meshio
 * write (and read) them. */
static void wr_view_tag(writer *b, uint64_t tag) {
  if (b->binary)
    wr_int(b, (int32_t)tag);
  else
    wr_u64(b, tag);
}

/* One $NodeData view of the vertex array val (nc values per vertex) named
 * name, time step 0, time 0. Vectors get z = 0 in 2D; symmetric tensors are
 * written whole, row-major, with zz = zz2d in 2D. */
static void write_view(writer *b, const pa_mesh *m, const char *name, int nc,
                       const double *val, double zz2d) {
  char head[PA_MESH_FIELD_NAME_LEN + 64];
  int d = m->dim, vc = view_ncomp(d, nc);
  snprintf(head, sizeof head, "$NodeData\n1\n\"%s\"\n1\n0\n3\n0\n%d\n%lld\n",
           name, vc, (long long)m->nv);
  wr_text(b, head);
  for (pa_idx i = 0; i < m->nv; i++) {
    const double *x = val + (size_t)nc * i;
    double t[9] = {0};
    if (vc == 3 && nc == d) {
      for (int k = 0; k < d; k++)
        t[k] = x[k];
    } else if (vc == 9 && nc == pa__tensor_ncomp(d)) {
      /* m11 m12 m22 [m13 m23 m33] */
      t[0] = x[0];
      t[1] = t[3] = x[1];
      t[4] = x[2];
      t[8] = d == 2 ? zz2d : x[5];
      if (d == 3) {
        t[2] = t[6] = x[3];
        t[5] = t[7] = x[4];
      }
    } else {
      memcpy(t, x, (size_t)nc * sizeof *t);
    }
    if (b->binary)
      wr_int(b, (int32_t)i + 1);
    else
      wr_u64(b, (uint64_t)i + 1);
    for (int k = 0; k < vc; k++)
      wr_f64(b, t[k]);
    wr_eol(b);
  }
  wr_end(b, "$EndNodeData\n");
}

/* Check that the fields of m can be written as views: names that fit a
 * quoted string tag and do not read back as the metric. */
static pa_status check_view_names(const pa_mesh *m, const char *path) {
  pa_status st = PA_SUCCESS;
  for (int k = 0; k < m->nfield; k++) {
    const pa__field *f = &m->field[k];
    PA_CHECK(strcmp(f->name, "metric"), PA_ERR_UNSUPPORTED,
             "%s: a field named \"metric\" would read back as the metric; "
             "rename it",
             path);
    PA_CHECK(f->name[0] && !strpbrk(f->name, "\"\n\r"), PA_ERR_UNSUPPORTED,
             "%s: field %d's name '%s' is empty or holds a quote or line "
             "break, which a Gmsh string tag cannot hold",
             path, k + 1, f->name);
    PA_CHECK(f->ncomp <= 9, PA_ERR_UNSUPPORTED,
             "%s: field \"%s\" has %d components; a Gmsh view has at most 9",
             path, f->name, f->ncomp);
  }
cleanup:
  return st;
}

/* The groups of m in Gmsh dimension order: 2D lines, triangles; 3D lines,
 * triangles, tetrahedra. */
static pa_status make_groups(const pa_mesh *m, group *grp, int *ngrp) {
  pa_status st = PA_SUCCESS;
  int n = 0;
  if (m->dim == 2) {
    PA_CALL(group_make(&grp[n++], 1, 1, 2, m->nb, m->bdry, m->bref));
    PA_CALL(group_make(&grp[n++], 2, 2, 3, m->ne, m->elem, m->eref));
  } else {
    PA_CALL(group_make(&grp[n++], 1, 1, 2, m->ned, m->edge, m->edref));
    PA_CALL(group_make(&grp[n++], 2, 2, 3, m->nb, m->bdry, m->bref));
    PA_CALL(group_make(&grp[n++], 3, 4, 4, m->ne, m->elem, m->eref));
  }
cleanup:
  *ngrp = n;
  return st;
}

/* $MeshFormat: version 4.1, ASCII or binary with the endianness probe. */
static void write_format(writer *b, int binary) {
  wr_text(b, binary ? "$MeshFormat\n4.1 1 8\n" : "$MeshFormat\n4.1 0 8\n");
  if (binary) {
    int32_t one = 1;
    wr_bytes(b, &one, 4);
    wr_text(b, "\n");
  }
  wr_text(b, "$EndMeshFormat\n");
}

/* $PhysicalNames, when m has any (ASCII in binary files too). */
static void write_physical_names(writer *b, const pa_mesh *m) {
  if (!m->nname) return;
  char line[40];
  snprintf(line, sizeof line, "$PhysicalNames\n%d\n", m->nname);
  wr_text(b, line);
  for (int k = 0; k < m->nname; k++) {
    snprintf(line, sizeof line, "%d %d \"", m->names[k].dim,
             (int)m->names[k].tag);
    wr_text(b, line);
    wr_text(b, m->names[k].name);
    wr_text(b, "\"\n");
  }
  wr_text(b, "$EndPhysicalNames\n");
}

/* $Entities: a point per corner, an entity per reference of each group,
 * and with extra one more top-dimension entity (tag 1) boxing all nodes. */
static void write_entities(writer *b, const pa_mesh *m, const group *grp,
                           int ngrp, const pa_idx *corner, pa_idx ncorner,
                           int extra) {
  wr_text(b, "$Entities\n");
  uint64_t count[4] = {(uint64_t)ncorner, 0, 0, 0};
  for (int g = 0; g < ngrp; g++)
    count[grp[g].gdim] += (uint64_t)grp[g].nent;
  count[m->dim] += (uint64_t)extra;
  for (int d = 0; d < 4; d++)
    wr_u64(b, count[d]);
  wr_eol(b);
  for (pa_idx k = 0; k < ncorner; k++) {
    wr_int(b, (int32_t)k + 1);
    for (int j = 0; j < 3; j++)
      wr_f64(b, coord(m, corner[k], j));
    wr_u64(b, 1);
    wr_int(b, m->vref[corner[k]]);
    wr_eol(b);
  }
  for (int g = 0; g < ngrp; g++) {
    double bb[6];
    for (int k = 0; k < grp[g].nent; k++) {
      entity_bbox(m, &grp[g], k, bb);
      write_entity(b, grp[g].etag[k], bb, 1, grp[g].eref[k]);
    }
  }
  if (extra) {
    double bb[6] = {INFINITY,  INFINITY,  INFINITY,
                    -INFINITY, -INFINITY, -INFINITY};
    for (pa_idx i = 0; i < m->nv; i++)
      for (int j = 0; j < 3; j++) {
        bb[j] = fmin(bb[j], coord(m, i, j));
        bb[3 + j] = fmax(bb[3 + j], coord(m, i, j));
      }
    write_entity(b, 1, bb, 0, 0);
  }
  wr_end(b, "$EndEntities\n");
}

/* $Nodes: one block, tags 1..nv, on entity node_etag. */
static void write_nodes(writer *b, const pa_mesh *m, int32_t node_etag,
                        int binary) {
  int dim = m->dim;
  wr_text(b, "$Nodes\n");
  wr_u64(b, m->nv ? 1 : 0);
  wr_u64(b, (uint64_t)m->nv);
  wr_u64(b, m->nv ? 1 : 0);
  wr_u64(b, (uint64_t)m->nv);
  wr_eol(b);
  if (m->nv) {
    wr_int(b, dim);
    wr_int(b, node_etag);
    wr_int(b, 0);
    wr_u64(b, (uint64_t)m->nv);
    wr_eol(b);
    for (pa_idx i = 0; i < m->nv; i++) {
      wr_u64(b, (uint64_t)i + 1);
      wr_eol(b);
    }
    if (binary && dim == 3) {
      wr_bytes(b, m->coord, 3 * sizeof(double) * (size_t)m->nv);
    } else {
      for (pa_idx i = 0; i < m->nv; i++) {
        for (int j = 0; j < 3; j++)
          wr_f64(b, coord(m, i, j));
        wr_eol(b);
      }
    }
  }
  wr_end(b, "$EndNodes\n");
}

/* $Elements: corner points, then each group by entity; tags 1, 2, ... */
static void write_elements(writer *b, const group *grp, int ngrp,
                           const pa_idx *corner, pa_idx ncorner) {
  uint64_t nblock = (uint64_t)ncorner, ncell = (uint64_t)ncorner;
  for (int g = 0; g < ngrp; g++) {
    nblock += (uint64_t)grp[g].nent;
    ncell += (uint64_t)grp[g].n;
  }
  wr_text(b, "$Elements\n");
  wr_u64(b, nblock);
  wr_u64(b, ncell);
  wr_u64(b, ncell ? 1 : 0);
  wr_u64(b, ncell);
  wr_eol(b);
  uint64_t etag = 1;
  for (pa_idx k = 0; k < ncorner; k++) {
    wr_int(b, 0);
    wr_int(b, (int32_t)k + 1);
    wr_int(b, 15);
    wr_u64(b, 1);
    wr_eol(b);
    wr_u64(b, etag++);
    wr_u64(b, (uint64_t)corner[k] + 1);
    wr_eol(b);
  }
  for (int g = 0; g < ngrp; g++) {
    const group *gp = &grp[g];
    for (int k = 0; k < gp->nent; k++) {
      wr_int(b, gp->gdim);
      wr_int(b, gp->etag[k]);
      wr_int(b, gp->type);
      wr_u64(b, (uint64_t)(gp->start[k + 1] - gp->start[k]));
      wr_eol(b);
      for (pa_idx s = gp->start[k]; s < gp->start[k + 1]; s++) {
        const pa_idx *cv = gp->v + (size_t)gp->nn * gp->order[s];
        wr_u64(b, etag++);
        for (int a = 0; a < gp->nn; a++)
          wr_u64(b, (uint64_t)cv[a] + 1);
        wr_eol(b);
      }
    }
  }
  wr_end(b, "$EndElements\n");
}

/* $NodeData: the metric (a 2D tensor gets zz = 1, as Mmg writes it, so that
 * it is positive definite in 3D too), then the fields. */
static void write_views(writer *b, const pa_mesh *m) {
  if (m->met_ncomp) write_view(b, m, "metric", m->met_ncomp, m->met, 1.0);
  for (int k = 0; k < m->nfield; k++)
    write_view(b, m, m->field[k].name, m->field[k].ncomp, m->field[k].val,
               0.0);
}

/* The field called name on the entities at of m (NULL if none). */
static const pa__field *field_named(pa_mesh *m, int at, const char *name) {
  int k = pa_mesh_field_index(m, (pa_entity)at, name);
  return k >= 0 ? &pa__mesh_fields(m, at, NULL)[k] : NULL;
}

/* Check that the element and boundary fields of m can be written as views:
 * a quotable name, at most 9 components, and an element and a boundary
 * field of one name (one view) of one shape. */
static pa_status check_cell_view_names(pa_mesh *m, const char *path) {
  pa_status st = PA_SUCCESS;
  for (int at = PA_ELEMENT; at <= PA_BOUNDARY; at++) {
    int *n;
    const pa__field *f = pa__mesh_fields(m, at, &n);
    for (int k = 0; k < *n; k++) {
      PA_CHECK(f[k].name[0] && !strpbrk(f[k].name, "\"\n\r"),
               PA_ERR_UNSUPPORTED,
               "%s: %s field %d's name '%s' is empty or holds a quote or line "
               "break, which a Gmsh string tag cannot hold",
               path, at == PA_ELEMENT ? "element" : "boundary", k + 1, f[k].name);
      PA_CHECK(f[k].ncomp <= 9, PA_ERR_UNSUPPORTED,
               "%s: field \"%s\" has %d components; a Gmsh view has at most 9",
               path, f[k].name, f[k].ncomp);
      const pa__field *o = field_named(m, PA_ELEMENT + PA_BOUNDARY - at, f[k].name);
      PA_CHECK(!o || view_ncomp(m->dim, o->ncomp) == view_ncomp(m->dim, f[k].ncomp),
               PA_ERR_UNSUPPORTED,
               "%s: the element and boundary fields \"%s\" (one Gmsh view) "
               "have different numbers of components",
               path, f[k].name);
    }
  }
cleanup:
  return st;
}

/* One view value: nc values at x as vc components (see write_view). */
static void write_value(writer *b, int d, int nc, int vc, const double *x) {
  double t[9] = {0};
  if (x && vc == 3 && nc == d) {
    for (int k = 0; k < d; k++) t[k] = x[k];
  } else if (x && vc == 9 && nc == pa__tensor_ncomp(d)) {
    t[0] = x[0];
    t[1] = t[3] = x[1];
    t[4] = x[2];
    if (d == 3) {
      t[2] = t[6] = x[3];
      t[5] = t[7] = x[4];
      t[8] = x[5];
    }
  } else if (x) {
    memcpy(t, x, (size_t)nc * sizeof *t);
  }
  for (int k = 0; k < vc; k++) wr_f64(b, t[k]);
  wr_eol(b);
}

/* $ElementData: a view per name of the element and boundary fields, over
 * every cell of the file in tag order (corners, then the groups as
 * write_elements numbers them), 0 on the cells the view's fields are not
 * on: Gmsh and meshio read such views. A fifth integer tag says which
 * cells carry the values (GMSH_VIEW_ELEMENTS, GMSH_VIEW_BOUNDARY). */
static void write_cell_views(writer *b, pa_mesh *m, const group *grp, int ngrp,
                             pa_idx ncorner) {
  int d = m->dim;
  uint64_t ncell = (uint64_t)ncorner;
  for (int g = 0; g < ngrp; g++) ncell += (uint64_t)grp[g].n;
  for (int at = PA_ELEMENT; at <= PA_BOUNDARY; at++) {
    int *n;
    const pa__field *f = pa__mesh_fields(m, at, &n);
    for (int k = 0; k < *n; k++) {
      const pa__field *fe = field_named(m, PA_ELEMENT, f[k].name);
      const pa__field *fb = field_named(m, PA_BOUNDARY, f[k].name);
      if (at == PA_BOUNDARY && fe) continue; /* written with the element one */
      if ((at == PA_ELEMENT && fe != &f[k]) || (at == PA_BOUNDARY && fb != &f[k]))
        continue; /* a second field of one name: the first one's view */
      int nc = f[k].ncomp, vc = view_ncomp(d, nc);
      char head[PA_MESH_FIELD_NAME_LEN + 96];
      snprintf(head, sizeof head,
               "$ElementData\n1\n\"%s\"\n1\n0\n5\n0\n%d\n%llu\n0\n%d\n",
               f[k].name, vc, (unsigned long long)ncell,
               (fe ? GMSH_VIEW_ELEMENTS : 0) | (fb ? GMSH_VIEW_BOUNDARY : 0));
      wr_text(b, head);
      uint64_t tag = 1;
      for (pa_idx c = 0; c < ncorner; c++) {
        wr_view_tag(b, tag++);
        write_value(b, d, nc, vc, NULL);
      }
      for (int g = 0; g < ngrp; g++) {
        const pa__field *src = grp[g].gdim == d ? fe : grp[g].gdim == d - 1 ? fb : NULL;
        for (pa_idx s = 0; s < grp[g].n; s++) {
          wr_view_tag(b, tag++);
          write_value(b, d, nc, vc,
                      src ? src->val + (size_t)src->ncomp * grp[g].order[s] : NULL);
        }
      }
      wr_end(b, "$EndElementData\n");
    }
  }
}

pa_status pa__gmsh_write(pa_mesh *mesh, const char *path, int binary) {
  pa_status st = PA_SUCCESS;
  pa__outfile out = {0};
  writer b = {0};
  group grp[3] = {{0}};
  int ngrp = 0;
  pa_idx *corner = NULL;
  pa_idx ncorner = 0;
  PA_CHECK(mesh && path, PA_ERR_ARG, "pa__gmsh_write: NULL argument");
  const pa_mesh *m = mesh;
  PA_CALL(check_view_names(m, path));
  PA_CALL(check_cell_view_names(mesh, path));
  PA_CALL(make_groups(m, grp, &ngrp));
  const group *top = &grp[ngrp - 1];
  PA_ALLOC(corner, m->nv);
  for (pa_idx i = 0; i < m->nv; i++)
    if (m->vflag[i] & PA_FLAG_CORNER) corner[ncorner++] = i;
  /* All nodes go in one block, on the first top-dimension entity; when the
   * mesh has no element, on an extra entity of tag 1 without physical tag. */
  int extra = top->nent == 0 && m->nv > 0;
  int32_t node_etag = top->nent ? top->etag[0] : 1;

  PA_CALL(pa__out_open(&out, path));
  b.fp = out.fp;
  b.binary = binary != 0;
  b.cap = (size_t)1 << 16;
  b.bol = 1;
  PA_ALLOC(b.buf, b.cap);
  write_format(&b, binary);
  write_physical_names(&b, m);
  write_entities(&b, m, grp, ngrp, corner, ncorner, extra);
  write_nodes(&b, m, node_etag, binary);
  write_elements(&b, grp, ngrp, corner, ncorner);
  write_views(&b, m);
  write_cell_views(&b, mesh, grp, ngrp, ncorner);
  wr_flush(&b);
  PA_CHECK(!b.err, PA_ERR_IO, "%s: write error: %s", path, strerror(errno));
  PA_CALL(pa__out_commit(&out));
cleanup:
  if (st) pa__out_abort(&out);
  pa__free(b.buf);
  pa__free(corner);
  for (int g = 0; g < 3; g++)
    group_free(&grp[g]);
  return st;
}
