/*
 * sol.c -- solutions (pa_sol): fields at the vertices, edges, triangles or
 * tetrahedra of a mesh, their files (.sol ASCII, .solb binary: keywords
 * SolAtVertices, SolAtEdges, SolAtTriangles, SolAtTetrahedra, read and
 * written through the keyword file layer of medit.c) and the bridges to
 * the mesh: its metric, and its user fields on vertices, elements and
 * boundary entities.
 *
 * Invariants of a pa_sol:
 *  - nfield fields, field k at n entities of its place (n = nvert at
 *    vertices), holding n * ncomp doubles (entity-major) with ncomp = 1
 *    (scalar), dim (vector) or 3 / 6 (symmetric tensor, stored m11 m12 m22
 *    [m13 m23 m33] exactly as in the file: Medit's order);
 *  - path is the file the solution was read from (NULL when built in
 *    memory), and each field read from a file knows the line (or byte) of
 *    its keyword: later errors about the solution (a wrong count, an
 *    invalid metric, a value that is not finite) name them.
 *
 * Reading: every solution keyword of the file contributes its fields in
 * order; keywords of one place must agree on their count; other keywords
 * (Time, Iterations...) are skipped. Values are read as they are: whether
 * they make a valid metric is checked by pa_mesh_metric_from_sol
 * (pa_mesh_set_metric), whether they are finite by the mesh's field
 * functions, which name the entity at fault. The dimensions must agree (as
 * Mmg): a solution of another Dimension than the mesh's is refused, but for
 * a 3D solution of a 2D mesh read from a file of 3D coordinates (a planar
 * mesh stored in 3D, Medit or Gmsh; or a mesh built in memory), whose
 * tensors fit when they do not couple z with x, y.
 * Writing: one keyword per place holding every field given there, binary
 * version 2 (3 beyond 2 GiB), through a temporary file (output.c).
 */
#include "io/medit.h"
#include "io/output.h"

#include <math.h>
#include <stdio.h>

typedef struct sol_field {
  pa_sol_kind kind;
  int ncomp;
  int at;       /* pa_sol_at */
  pa_idx n;     /* entities */
  char *origin; /* where its keyword was read ("u.sol:12"), or NULL */
  double *val;  /* n * ncomp */
} sol_field;

struct pa_sol {
  int dim;
  pa_idx nvert;
  int nfield;
  size_t capfield;
  sol_field *field;
  char *path;   /* file read from, NULL if built in memory */
  char *origin; /* where its vertex count was read ("u.sol:3"), or NULL */
};

#define SOL_NAT 4
/* The keyword of each place, and its entities for messages. */
static const int at_code[SOL_NAT] = {
    PA_IO_GMF_SOL_AT_VERTICES, PA_IO_GMF_SOL_AT_EDGES,
    PA_IO_GMF_SOL_AT_TRIANGLES, PA_IO_GMF_SOL_AT_TETRAHEDRA};
static const char *const at_word[SOL_NAT] = {"vertices", "edges", "triangles",
                                             "tetrahedra"};

/* Components of a field of this kind, 0 if the kind is invalid. */
static int kind_ncomp(int dim, int kind) {
  switch (kind) {
  case PA_SOL_SCALAR:
    return 1;
  case PA_SOL_VECTOR:
    return dim;
  case PA_SOL_TENSOR:
    return pa__tensor_ncomp(dim);
  default:
    return 0;
  }
}

/* A copy of s by the counting allocator (NULL for NULL or out of memory). */
static char *dup_string(const char *s) {
  if (!s) return NULL;
  size_t n = strlen(s) + 1;
  char *c = pa__malloc(n);
  if (c) memcpy(c, s, n);
  return c;
}

pa_status pa_sol_create(int dim, pa_idx nvert, pa_sol **sol) {
  pa_status st = PA_SUCCESS;
  pa_sol *s = NULL;
  PA_CHECK(sol, PA_ERR_ARG, "pa_sol_create: NULL output pointer");
  *sol = NULL;
  PA_CHECK(dim == 2 || dim == 3, PA_ERR_ARG,
           "pa_sol_create: dimension must be 2 or 3, got %d", dim);
  PA_CHECK(nvert >= 0, PA_ERR_ARG, "pa_sol_create: negative vertex count %d",
           (int)nvert);
  PA_CALLOC(s, 1);
  s->dim = dim;
  s->nvert = nvert;
  *sol = s;
cleanup:
  return st;
}

void pa_sol_destroy(pa_sol *sol) {
  if (!sol) return;
  for (int k = 0; k < sol->nfield; k++) {
    pa__free(sol->field[k].val);
    pa__free(sol->field[k].origin);
  }
  pa__free(sol->field);
  pa__free(sol->path);
  pa__free(sol->origin);
  pa__free(sol);
}

const char *pa_sol_origin(const pa_sol *sol) {
  return sol ? (sol->origin ? sol->origin : sol->path) : NULL;
}

int pa_sol_dim(const pa_sol *sol) { return sol->dim; }
pa_idx pa_sol_nvert(const pa_sol *sol) { return sol->nvert; }
int pa_sol_nfield(const pa_sol *sol) { return sol->nfield; }

/* Append a field with uninitialised values at n entities of place at; its
 * index in *index. */
static pa_status add_empty(pa_sol *s, int at, pa_idx n, pa_sol_kind kind,
                           const char *origin, int *index) {
  pa_status st = PA_SUCCESS;
  double *val = NULL;
  char *org = NULL;
  int nc = kind_ncomp(s->dim, kind);
  PA_CHECK(nc, PA_ERR_ARG,
           "invalid solution kind %d (1 scalar, 2 vector, 3 "
           "symmetric tensor)",
           (int)kind);
  PA_GROW(s->field, s->capfield, (size_t)s->nfield + 1);
  PA_ALLOC(val, (size_t)(n ? n : 1) * nc);
  if (origin) {
    org = dup_string(origin);
    PA_CHECK(org, PA_ERR_MEMORY, "out of memory");
  }
  sol_field *f = &s->field[s->nfield];
  f->kind = kind;
  f->ncomp = nc;
  f->at = at;
  f->n = n;
  f->origin = org;
  f->val = val;
  val = NULL;
  org = NULL;
  *index = s->nfield++;
cleanup:
  pa__free(val);
  pa__free(org);
  return st;
}

pa_status pa_sol_add_field_at(pa_sol *sol, pa_sol_at at, pa_idx n,
                              pa_sol_kind kind, const double *values) {
  pa_status st = PA_SUCCESS;
  int k = 0;
  PA_CHECK(sol, PA_ERR_ARG, "pa_sol_add_field: NULL solution");
  PA_CHECK((int)at >= 0 && (int)at < SOL_NAT, PA_ERR_ARG,
           "pa_sol_add_field: unknown place %d", (int)at);
  PA_CHECK(n >= 0 && (at != PA_SOL_AT_VERTICES || n == sol->nvert), PA_ERR_ARG,
           "pa_sol_add_field: %d values for a solution at %d vertices", (int)n,
           (int)sol->nvert);
  PA_CHECK(values || n == 0, PA_ERR_ARG, "pa_sol_add_field: NULL values");
  PA_CALL(add_empty(sol, at, n, kind, NULL, &k));
  if (n)
    memcpy(sol->field[k].val, values,
           (size_t)n * sol->field[k].ncomp * sizeof(double));
cleanup:
  return st;
}

pa_status pa_sol_add_field(pa_sol *sol, pa_sol_kind kind,
                           const double *values) {
  return pa_sol_add_field_at(sol, PA_SOL_AT_VERTICES, sol ? sol->nvert : 0,
                             kind, values);
}

pa_status pa_sol_field(pa_sol *sol, int k, pa_sol_kind *kind, int *ncomp,
                       double **values) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(sol && k >= 0 && k < sol->nfield, PA_ERR_ARG,
           "pa_sol_field: no field %d", k);
  if (kind) *kind = sol->field[k].kind;
  if (ncomp) *ncomp = sol->field[k].ncomp;
  if (values) *values = sol->field[k].val;
cleanup:
  return st;
}

pa_status pa_sol_field_where(const pa_sol *sol, int k, pa_sol_at *at,
                             pa_idx *n, const char **origin) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(sol && k >= 0 && k < sol->nfield, PA_ERR_ARG,
           "pa_sol_field_where: no field %d", k);
  if (at) *at = (pa_sol_at)sol->field[k].at;
  if (n) *n = sol->field[k].n;
  if (origin) *origin = sol->field[k].origin;
cleanup:
  return st;
}

/* Read the solution keyword of place at that g is on; creates *sp on the
 * first one. count[at] is the count of the first keyword of that place
 * (-1 before). */
static pa_status read_sol_keyword(pa__gmf *g, int at, pa_sol **sp,
                                  pa_idx *count) {
  pa_status st = PA_SUCCESS;
  int *type = NULL, ntype = 0, size = 0, first;
  pa_idx n;
  const double *rv;
  int64_t loc = pa__gmf_kwd_loc(g);
  const char *kname = pa__gmf_kwd_name(at_code[at]);
  char where[600];
  int dim;
  PA_CALL(pa__gmf_count(g, 1, 0, &n)); /* fails if there is no Dimension */
  dim = pa__gmf_dim(g);
  PA_CALL(pa__gmf_word(g, &ntype));
  if (ntype < 1 || ntype > PA_IO_GMF_MAX_TYPES)
    PA_IO_GMF_FAIL(g, pa__gmf_loc(g), "%s: %d solution types (1 to %d)", kname,
                   ntype, PA_IO_GMF_MAX_TYPES);
  PA_ALLOC(type, ntype);
  for (int i = 0; i < ntype; i++) {
    PA_CALL(pa__gmf_word(g, &type[i]));
    if (type[i] == 4)
      PA_CALL(pa__gmf_error(g, pa__gmf_loc(g), PA_ERR_UNSUPPORTED,
                            "%s: full (non-symmetric) matrix solutions (type "
                            "4) are not supported",
                            kname));
    if (type[i] < 1 || type[i] > 3)
      PA_IO_GMF_FAIL(g, pa__gmf_loc(g),
                     "%s: solution type %d (1 scalar, 2 vector, 3 symmetric "
                     "tensor)",
                     kname, type[i]);
    size += kind_ncomp(dim, type[i]);
  }
  PA_CALL(pa__gmf_check_room(g, n, size, 0));
  pa__gmf_where(g, loc, where, sizeof where);
  if (!*sp) PA_CALL(pa_sol_create(dim, 0, sp));
  pa_sol *s = *sp;
  if (count[at] >= 0 && count[at] != n)
    PA_IO_GMF_FAIL(g, loc, "%s with %d %s after one with %d", kname, (int)n,
                   at_word[at], (int)count[at]);
  if (count[at] < 0) {
    count[at] = n;
    if (at == PA_SOL_AT_VERTICES) {
      s->nvert = n;
      pa__free(s->origin);
      s->origin = dup_string(where);
      PA_CHECK(s->origin, PA_ERR_MEMORY, "out of memory");
    }
  }
  first = s->nfield;
  for (int i = 0; i < ntype; i++) {
    int k;
    PA_CALL(add_empty(s, at, n, (pa_sol_kind)type[i], where, &k));
  }
  size_t chunk = pa__gmf_chunk(size, 0), m;
  for (size_t done = 0; done < (size_t)n; done += m) {
    m = (size_t)n - done < chunk ? (size_t)n - done : chunk;
    PA_CALL(pa__gmf_records(g, m, size, 0, &rv, NULL));
    for (size_t k = 0; k < m; k++) {
      const double *p = rv + k * size;
      for (int i = 0; i < ntype; i++) {
        sol_field *f = &s->field[first + i];
        memcpy(f->val + (done + k) * f->ncomp, p, f->ncomp * sizeof(double));
        p += f->ncomp;
      }
    }
  }
  PA_CALL(pa__gmf_done(g));
cleanup:
  pa__free(type);
  return st;
}

pa_status pa_sol_read(const char *path, pa_sol **sol) {
  pa_status st = PA_SUCCESS;
  pa__gmf *g = NULL;
  pa_sol *s = NULL;
  pa_idx count[SOL_NAT] = {-1, -1, -1, -1};
  char ext[16];
  PA_CHECK(path && sol, PA_ERR_ARG, "pa_sol_read: NULL argument");
  *sol = NULL;
  pa__path_ext(path, ext, sizeof ext);
  PA_CHECK(!strcmp(ext, ".sol") || !strcmp(ext, ".solb"), PA_ERR_UNSUPPORTED,
           "%s: unknown solution file extension '%s' (expected .sol or .solb)",
           path, ext);
  PA_CALL(pa__gmf_open(path, !strcmp(ext, ".solb"), &g));
  for (;;) {
    int code, at = -1;
    PA_CALL(pa__gmf_next(g, &code));
    if (code == PA_IO_GMF_END) break;
    for (int k = 0; k < SOL_NAT; k++)
      if (code == at_code[k]) at = k;
    if (at >= 0)
      PA_CALL(read_sol_keyword(g, at, &s, count));
    else
      PA_CALL(pa__gmf_skip(g));
  }
  if (!pa__gmf_dim(g))
    PA_IO_GMF_FAIL(g, pa__gmf_loc(g),
                   "missing Dimension keyword (not a Medit "
                   "solution file?)");
  if (!s)
    PA_IO_GMF_FAIL(g, pa__gmf_loc(g),
                   "no SolAtVertices, SolAtEdges, SolAtTriangles nor "
                   "SolAtTetrahedra keyword");
  s->path = dup_string(path);
  PA_CHECK(s->path, PA_ERR_MEMORY, "out of memory");
  *sol = s;
  s = NULL;
cleanup:
  pa_sol_destroy(s);
  pa__gmf_close(g);
  return st;
}

pa_status pa_sol_write(const pa_sol *sol, const char *path) {
  pa_status st = PA_SUCCESS;
  pa__gmfw *w = NULL;
  int *type = NULL, *idx = NULL;
  double *rec = NULL;
  char ext[16];
  PA_CHECK(sol && path, PA_ERR_ARG, "pa_sol_write: NULL argument");
  pa__path_ext(path, ext, sizeof ext);
  PA_CHECK(!strcmp(ext, ".sol") || !strcmp(ext, ".solb"), PA_ERR_UNSUPPORTED,
           "%s: unknown solution file extension '%s' (expected .sol or .solb)",
           path, ext);
  PA_CHECK(sol->nfield > 0, PA_ERR_ARG, "%s: the solution has no field", path);
  PA_ALLOC(type, sol->nfield);
  PA_ALLOC(idx, sol->nfield);
  int64_t bytes = 0, maxsize = 1;
  for (int k = 0; k < sol->nfield; k++) {
    bytes += (int64_t)sol->field[k].n * sol->field[k].ncomp * 8;
    maxsize += sol->field[k].ncomp;
  }
  PA_ALLOC(rec, (size_t)maxsize);
  int binary = !strcmp(ext, ".solb");
  PA_CALL(pa__gmfw_open(path, binary, pa__gmf_default_version(bytes), sol->dim,
                        &w));
  for (int at = 0; at < SOL_NAT; at++) {
    int nt = 0, size = 0;
    pa_idx n = 0;
    for (int k = 0; k < sol->nfield; k++)
      if (sol->field[k].at == at) {
        PA_CHECK(nt == 0 || sol->field[k].n == n, PA_ERR_ARG,
                 "%s: fields at %s with %d and %d values", path, at_word[at],
                 (int)n, (int)sol->field[k].n);
        n = sol->field[k].n;
        idx[nt] = k;
        type[nt++] = (int)sol->field[k].kind;
        size += sol->field[k].ncomp;
      }
    if (!nt) continue;
    PA_CHECK(nt <= PA_IO_GMF_MAX_TYPES, PA_ERR_ARG,
             "%s: at most %d fields per place", path, PA_IO_GMF_MAX_TYPES);
    PA_CALL(pa__gmfw_kwd(w, at_code[at], n, size, 0, nt, type));
    for (pa_idx i = 0; i < n; i++) {
      double *p = rec;
      for (int j = 0; j < nt; j++) {
        const sol_field *f = &sol->field[idx[j]];
        memcpy(p, f->val + (size_t)i * f->ncomp, f->ncomp * sizeof(double));
        p += f->ncomp;
      }
      PA_CALL(pa__gmfw_rec(w, rec, NULL));
    }
  }
  pa__gmfw *done = w;
  w = NULL;
  PA_CALL(pa__gmfw_close(done));
cleanup:
  pa__gmfw_abort(w);
  pa__free(type);
  pa__free(idx);
  pa__free(rec);
  return st;
}

pa_status pa_mesh_metric_from_sol(pa_mesh *mesh, const pa_sol *sol, int k) {
  pa_status st = PA_SUCCESS;
  double *tmp = NULL;
  char msg[1024];
  PA_CHECK(mesh && sol, PA_ERR_ARG, "pa_mesh_metric_from_sol: NULL argument");
  const char *src = sol->path ? sol->path : "solution";
  /* A mismatch with the file read is a format error; in memory, the caller's.
   */
  pa_status bad = sol->path ? PA_ERR_FORMAT : PA_ERR_ARG;
  PA_CHECK(k >= 0 && k < sol->nfield, PA_ERR_ARG,
           "%s: no field %d (the solution has %d)", src, k, sol->nfield);
  const sol_field *f = &sol->field[k];
  PA_CHECK(f->at == PA_SOL_AT_VERTICES, PA_ERR_ARG,
           "%s: field %d is given at %s, not at vertices: not a metric",
           f->origin ? f->origin : src, k + 1, at_word[f->at]);
  PA_CHECK(sol->nvert == mesh->nv, bad,
           "%s: %d vertices in the solution but %d in the mesh",
           sol->origin ? sol->origin : src, (int)sol->nvert, (int)mesh->nv);
  PA_CHECK(f->kind != PA_SOL_VECTOR, PA_ERR_ARG,
           "%s: field %d is a vector, not a metric (expected a scalar size or "
           "a symmetric tensor)",
           src, k + 1);
  const double *values = f->val;
  int ncomp = f->ncomp;
  PA_CHECK(sol->dim == mesh->dim ||
               (sol->dim == 3 && mesh->dim == 2 && mesh->file_dim != 2),
           bad,
           "%s: a solution of Dimension %d for a %dD mesh (%s): give the "
           "solution of this mesh",
           src, sol->dim, mesh->dim,
           mesh->file_dim == 2 ? "its file has Dimension 2"
                               : "a 2D solution cannot hold a 3D metric");
  if (f->kind == PA_SOL_TENSOR && sol->dim != mesh->dim) {
    /* A planar mesh stored in 3D comes with 3D tensors: keep their xy block
     * when it is decoupled from z. */
    PA_CHECK(sol->dim == 3 && mesh->dim == 2, bad,
             "%s: a %dD tensor field cannot be the metric of a %dD mesh", src,
             sol->dim, mesh->dim);
    PA_ALLOC(tmp, (size_t)mesh->nv * 3);
    for (pa_idx i = 0; i < mesh->nv; i++) {
      const double *m = f->val + 6 * (size_t)i;
      PA_CHECK(m[3] == 0.0 && m[4] == 0.0, PA_ERR_METRIC,
               "%s: metric at vertex %d couples z with x or y (m13 or m23 is "
               "not 0), not a metric of the 2D mesh",
               src, (int)i + 1);
      memcpy(tmp + 3 * (size_t)i, m, 3 * sizeof(double));
    }
    values = tmp;
    ncomp = 3;
  }
  st = pa_mesh_set_metric(mesh, ncomp, values);
  if (st != PA_SUCCESS && sol->path) {
    snprintf(msg, sizeof msg, "%s", pa_last_error());
    st = pa__error(st, __FILE__, __LINE__, "%s: %s", sol->path, msg);
  }
cleanup:
  pa__free(tmp);
  return st;
}

pa_status pa_mesh_metric_to_sol(pa_mesh *mesh, int with_fields, pa_sol **sol) {
  pa_status st = PA_SUCCESS;
  pa_sol *s = NULL;
  PA_CHECK(mesh && sol, PA_ERR_ARG, "pa_mesh_metric_to_sol: NULL argument");
  *sol = NULL;
  PA_CHECK(mesh->met_ncomp || (with_fields && mesh->nfield), PA_ERR_ARG,
           "pa_mesh_metric_to_sol: the mesh has no metric%s",
           with_fields ? " and no field" : "");
  PA_CALL(pa_sol_create(mesh->dim, mesh->nv, &s));
  if (mesh->met_ncomp)
    PA_CALL(pa_sol_add_field(
        s, mesh->met_ncomp == 1 ? PA_SOL_SCALAR : PA_SOL_TENSOR, mesh->met));
  for (int k = 0; with_fields && k < mesh->nfield; k++) {
    int nc = mesh->field[k].ncomp;
    pa_sol_kind kind = nc == 1                             ? PA_SOL_SCALAR
                       : nc == mesh->dim                   ? PA_SOL_VECTOR
                       : nc == pa__tensor_ncomp(mesh->dim) ? PA_SOL_TENSOR
                                                           : (pa_sol_kind)0;
    if (kind) PA_CALL(pa_sol_add_field(s, kind, mesh->field[k].val));
  }
  *sol = s;
  s = NULL;
cleanup:
  pa_sol_destroy(s);
  return st;
}

/* The kind of a field of nc components in dimension dim, 0 for none. */
static pa_sol_kind kind_of(int dim, int nc) {
  return nc == 1                           ? PA_SOL_SCALAR
         : nc == dim                       ? PA_SOL_VECTOR
         : nc == pa__tensor_ncomp(dim)     ? PA_SOL_TENSOR
                                           : (pa_sol_kind)0;
}

pa_status pa_mesh_fields_to_sol(pa_mesh *mesh, pa_sol **sol) {
  pa_status st = PA_SUCCESS;
  pa_sol *s = NULL;
  double *tmp = NULL;
  PA_CHECK(mesh && sol, PA_ERR_ARG, "pa_mesh_fields_to_sol: NULL argument");
  *sol = NULL;
  int d = mesh->dim;
  PA_CHECK(mesh->nfield + mesh->nefield + mesh->nbfield > 0, PA_ERR_ARG,
           "pa_mesh_fields_to_sol: the mesh has no field");
  PA_CALL(pa_sol_create(d, mesh->nv, &s));
  for (int at = PA_VERTEX; at <= PA_BOUNDARY; at++) {
    int *nf;
    const pa__field *f = pa__mesh_fields(mesh, at, &nf);
    pa_idx n = at == PA_VERTEX ? mesh->nv : at == PA_ELEMENT ? mesh->ne : mesh->nb;
    pa_sol_at where = at == PA_VERTEX    ? PA_SOL_AT_VERTICES
                      : at == PA_ELEMENT ? (d == 2 ? PA_SOL_AT_TRIANGLES
                                                   : PA_SOL_AT_TETRAHEDRA)
                                         : (d == 2 ? PA_SOL_AT_EDGES
                                                   : PA_SOL_AT_TRIANGLES);
    for (int k = 0; k < *nf; k++) {
      int nc = f[k].ncomp;
      pa_sol_kind kind = kind_of(d, nc);
      if (kind) {
        PA_CALL(pa_sol_add_field_at(s, where, n, kind, f[k].val));
        continue;
      }
      /* another count: that many scalars */
      PA_ALLOC(tmp, (size_t)(n ? n : 1));
      for (int c = 0; c < nc; c++) {
        for (pa_idx i = 0; i < n; i++) tmp[i] = f[k].val[(size_t)nc * i + c];
        PA_CALL(pa_sol_add_field_at(s, where, n, PA_SOL_SCALAR, tmp));
      }
      pa__free(tmp);
      tmp = NULL;
    }
  }
  *sol = s;
  s = NULL;
cleanup:
  pa__free(tmp);
  pa_sol_destroy(s);
  return st;
}

pa_status pa_mesh_fields_from_sol(pa_mesh *mesh, const pa_sol *sol) {
  static const char *const prefix[3] = {"field", "cell", "face"};
  pa_status st = PA_SUCCESS;
  int added[3] = {0, 0, 0};
  char msg[1024];
  PA_CHECK(mesh && sol, PA_ERR_ARG, "pa_mesh_fields_from_sol: NULL argument");
  int d = mesh->dim;
  const char *src = sol->path ? sol->path : "solution";
  /* every field's place and count first: nothing is added on a mismatch */
  for (int k = 0; k < sol->nfield; k++) {
    const sol_field *f = &sol->field[k];
    const char *org = f->origin ? f->origin : src;
    int at = f->at == PA_SOL_AT_VERTICES ? PA_VERTEX
             : f->at == PA_SOL_AT_EDGES ? (d == 2 ? PA_BOUNDARY : -1)
             : f->at == PA_SOL_AT_TRIANGLES ? (d == 2 ? PA_ELEMENT : PA_BOUNDARY)
                                            : (d == 3 ? PA_ELEMENT : -1);
    PA_CHECK(at >= 0, PA_ERR_FORMAT,
             "%s: values at %s do not fit a %dD mesh (%s)", org,
             at_word[f->at], d,
             d == 2 ? "its elements are triangles"
                    : "values at feature edges are not read");
    pa_idx n = at == PA_VERTEX ? mesh->nv : at == PA_ELEMENT ? mesh->ne : mesh->nb;
    PA_CHECK(f->n == n, PA_ERR_FORMAT,
             "%s: %d values per field at %s, but the mesh has %d %s", org,
             (int)f->n, at_word[f->at], (int)n,
             at == PA_VERTEX    ? "vertices"
             : at == PA_ELEMENT ? (d == 2 ? "triangles" : "tetrahedra")
                                : (d == 2 ? "boundary edges" : "boundary triangles"));
    PA_CHECK(f->kind == PA_SOL_SCALAR || sol->dim == d, PA_ERR_FORMAT,
             "%s: a %s field of a %dD solution on a %dD mesh", org,
             f->kind == PA_SOL_VECTOR ? "vector" : "tensor", sol->dim, d);
  }
  for (int k = 0; k < sol->nfield; k++) {
    const sol_field *f = &sol->field[k];
    int at = f->at == PA_SOL_AT_VERTICES ? PA_VERTEX
             : (f->at == PA_SOL_AT_TRIANGLES && d == 2) ||
                     f->at == PA_SOL_AT_TETRAHEDRA
                 ? PA_ELEMENT
                 : PA_BOUNDARY;
    char name[PA_MESH_FIELD_NAME_LEN];
    snprintf(name, sizeof name, "%s%d", prefix[at],
             pa_mesh_nfield_at(mesh, (pa_entity)at) + 1);
    st = pa_mesh_add_field_at(mesh, (pa_entity)at, name, f->ncomp, f->val);
    if (st != PA_SUCCESS) {
      snprintf(msg, sizeof msg, "%s", pa_last_error());
      st = pa__error(st, __FILE__, __LINE__, "%s: %s",
                     f->origin ? f->origin : src, msg);
      goto cleanup;
    }
    added[at]++;
  }
cleanup:
  if (st != PA_SUCCESS && mesh)
    for (int at = 0; at < 3; at++)
      while (added[at]--)
        pa_mesh_remove_field_at(mesh, (pa_entity)at,
                                pa_mesh_nfield_at(mesh, (pa_entity)at) - 1);
  return st;
}
