/*
 * sol.c -- solutions at vertices (pa_sol), their files (.sol ASCII, .solb
 * binary: keyword SolAtVertices, read and written through the keyword file
 * layer of medit.c) and the bridge to the mesh metric.
 *
 * Invariants of a pa_sol:
 *  - nfield fields, field k holding nvert * ncomp doubles (vertex-major) with
 *    ncomp = 1 (scalar), dim (vector) or 3 / 6 (symmetric tensor, stored
 *    m11 m12 m22 [m13 m23 m33] exactly as in the file: Medit's order);
 *  - path is the file the solution was read from (NULL when built in memory);
 *    later errors about the solution (wrong vertex count, invalid metric)
 *    name it.
 *
 * Reading: every SolAtVertices keyword of the file contributes its fields in
 * order (all must have the same vertex count); other keywords (solutions at
 * elements, Time, Iterations...) are skipped. Values are read as they are:
 * whether they make a valid metric is checked by pa_mesh_metric_from_sol
 * (pa_mesh_set_metric), which names the vertex at fault. The vertex counts
 * must agree; a scalar field fits a mesh of any dimension, and 3D tensors fit
 * a 2D mesh (a planar mesh stored in 3D) when they do not couple z with x, y.
 * Writing: one SolAtVertices keyword holding every field, binary version 2
 * (3 beyond 2 GiB), through a temporary file (output.c).
 */
#include "io/medit.h"
#include "io/output.h"

typedef struct sol_field {
  pa_sol_kind kind;
  int ncomp;
  double *val; /* nvert * ncomp */
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
  for (int k = 0; k < sol->nfield; k++)
    pa__free(sol->field[k].val);
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

/* Append a field with uninitialised values; its index in *index. */
static pa_status add_empty(pa_sol *s, pa_sol_kind kind, int *index) {
  pa_status st = PA_SUCCESS;
  double *val = NULL;
  int nc = kind_ncomp(s->dim, kind);
  PA_CHECK(nc, PA_ERR_ARG,
           "invalid solution kind %d (1 scalar, 2 vector, 3 "
           "symmetric tensor)",
           (int)kind);
  PA_GROW(s->field, s->capfield, (size_t)s->nfield + 1);
  PA_ALLOC(val, (size_t)s->nvert * nc);
  s->field[s->nfield].kind = kind;
  s->field[s->nfield].ncomp = nc;
  s->field[s->nfield].val = val;
  val = NULL;
  *index = s->nfield++;
cleanup:
  pa__free(val);
  return st;
}

pa_status pa_sol_add_field(pa_sol *sol, pa_sol_kind kind,
                           const double *values) {
  pa_status st = PA_SUCCESS;
  int k = 0;
  PA_CHECK(sol, PA_ERR_ARG, "pa_sol_add_field: NULL solution");
  PA_CHECK(values || sol->nvert == 0, PA_ERR_ARG,
           "pa_sol_add_field: NULL values");
  PA_CALL(add_empty(sol, kind, &k));
  if (sol->nvert)
    memcpy(sol->field[k].val, values,
           (size_t)sol->nvert * sol->field[k].ncomp * sizeof(double));
cleanup:
  return st;
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

/* Read the SolAtVertices keyword g is on; creates *sp on the first one. */
static pa_status read_sol_at_vertices(pa__gmf *g, pa_sol **sp) {
  pa_status st = PA_SUCCESS;
  int *type = NULL, ntype = 0, size = 0, first;
  pa_idx n;
  const double *rv;
  int64_t loc = pa__gmf_kwd_loc(g);
  int dim;
  PA_CALL(pa__gmf_count(g, 1, 0, &n)); /* fails if there is no Dimension */
  dim = pa__gmf_dim(g);
  PA_CALL(pa__gmf_word(g, &ntype));
  if (ntype < 1 || ntype > PA_IO_GMF_MAX_TYPES)
    PA_IO_GMF_FAIL(g, pa__gmf_loc(g),
                   "SolAtVertices: %d solution types (1 to "
                   "%d)",
                   ntype, PA_IO_GMF_MAX_TYPES);
  PA_ALLOC(type, ntype);
  for (int i = 0; i < ntype; i++) {
    PA_CALL(pa__gmf_word(g, &type[i]));
    if (type[i] == 4)
      PA_CALL(pa__gmf_error(g, pa__gmf_loc(g), PA_ERR_UNSUPPORTED,
                            "SolAtVertices: full (non-symmetric) matrix "
                            "solutions (type 4) are not supported"));
    if (type[i] < 1 || type[i] > 3)
      PA_IO_GMF_FAIL(g, pa__gmf_loc(g),
                     "SolAtVertices: solution type %d (1 "
                     "scalar, 2 vector, 3 symmetric tensor)",
                     type[i]);
    size += kind_ncomp(dim, type[i]);
  }
  PA_CALL(pa__gmf_check_room(g, n, size, 0));
  if (!*sp) {
    char where[600];
    size_t len;
    PA_CALL(pa_sol_create(dim, n, sp));
    pa__gmf_where(g, loc, where, sizeof where);
    len = strlen(where);
    PA_ALLOC((*sp)->origin, len + 1);
    memcpy((*sp)->origin, where, len + 1);
  }
  else if ((*sp)->nvert != n)
    PA_IO_GMF_FAIL(g, loc, "SolAtVertices with %d vertices after one with %d",
                   (int)n, (int)(*sp)->nvert);
  pa_sol *s = *sp;
  first = s->nfield;
  for (int i = 0; i < ntype; i++) {
    int k;
    PA_CALL(add_empty(s, (pa_sol_kind)type[i], &k));
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
  char ext[16];
  PA_CHECK(path && sol, PA_ERR_ARG, "pa_sol_read: NULL argument");
  *sol = NULL;
  pa__path_ext(path, ext, sizeof ext);
  PA_CHECK(!strcmp(ext, ".sol") || !strcmp(ext, ".solb"), PA_ERR_UNSUPPORTED,
           "%s: unknown solution file extension '%s' (expected .sol or .solb)",
           path, ext);
  PA_CALL(pa__gmf_open(path, !strcmp(ext, ".solb"), &g));
  for (;;) {
    int code;
    PA_CALL(pa__gmf_next(g, &code));
    if (code == PA_IO_GMF_END) break;
    if (code == PA_IO_GMF_SOL_AT_VERTICES)
      PA_CALL(read_sol_at_vertices(g, &s));
    else
      PA_CALL(pa__gmf_skip(g));
  }
  if (!pa__gmf_dim(g))
    PA_IO_GMF_FAIL(g, pa__gmf_loc(g),
                   "missing Dimension keyword (not a Medit "
                   "solution file?)");
  if (!s) PA_IO_GMF_FAIL(g, pa__gmf_loc(g), "no SolAtVertices keyword");
  size_t len = strlen(path);
  PA_ALLOC(s->path, len + 1);
  memcpy(s->path, path, len + 1);
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
  int *type = NULL, size = 0;
  double *rec = NULL;
  char ext[16];
  PA_CHECK(sol && path, PA_ERR_ARG, "pa_sol_write: NULL argument");
  pa__path_ext(path, ext, sizeof ext);
  PA_CHECK(!strcmp(ext, ".sol") || !strcmp(ext, ".solb"), PA_ERR_UNSUPPORTED,
           "%s: unknown solution file extension '%s' (expected .sol or .solb)",
           path, ext);
  PA_CHECK(sol->nfield > 0, PA_ERR_ARG, "%s: the solution has no field", path);
  PA_CHECK(sol->nfield <= PA_IO_GMF_MAX_TYPES, PA_ERR_ARG,
           "%s: at most %d fields per file", path, PA_IO_GMF_MAX_TYPES);
  PA_ALLOC(type, sol->nfield);
  for (int k = 0; k < sol->nfield; k++) {
    type[k] = (int)sol->field[k].kind;
    size += sol->field[k].ncomp;
  }
  PA_ALLOC(rec, size);
  int binary = !strcmp(ext, ".solb");
  int version = pa__gmf_default_version((int64_t)sol->nvert * size * 8);
  PA_CALL(pa__gmfw_open(path, binary, version, sol->dim, &w));
  PA_CALL(pa__gmfw_kwd(w, PA_IO_GMF_SOL_AT_VERTICES, sol->nvert, size, 0,
                       sol->nfield, type));
  for (pa_idx i = 0; i < sol->nvert; i++) {
    double *p = rec;
    for (int k = 0; k < sol->nfield; k++) {
      int nc = sol->field[k].ncomp;
      memcpy(p, sol->field[k].val + (size_t)i * nc, nc * sizeof(double));
      p += nc;
    }
    PA_CALL(pa__gmfw_rec(w, rec, NULL));
  }
  pa__gmfw *done = w;
  w = NULL;
  PA_CALL(pa__gmfw_close(done));
cleanup:
  pa__gmfw_abort(w);
  pa__free(type);
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
  PA_CHECK(sol->nvert == mesh->nv, bad,
           "%s: %d vertices in the solution but %d in the mesh",
           sol->origin ? sol->origin : src, (int)sol->nvert, (int)mesh->nv);
  PA_CHECK(f->kind != PA_SOL_VECTOR, PA_ERR_ARG,
           "%s: field %d is a vector, not a metric (expected a scalar size or "
           "a symmetric tensor)",
           src, k + 1);
  const double *values = f->val;
  int ncomp = f->ncomp;
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
