/*
 * mesh.c -- creation, growth, copy and raw access of struct pa_mesh, its
 * metric storage (the values enter through pa_mesh_set_metric, metric/ops.c,
 * which validates them), user fields and physical names, the storage of the
 * classification (the entity table and the vertices' entities, filled by
 * classify.c), and memory accounting.
 *
 * Vertex-attached arrays (coord, vref, vflag, the entities vgdim and vgtag,
 * met, field values) always share the capacity capv; every growth goes
 * through pa__mesh_grow_vertices(). Element fields share cape with the
 * element arrays and boundary fields capb with the boundary arrays:
 * grow_cells and pa__mesh_fields_realloc keep them in step.
 */
#include "mesh/mesh.h"

#include <math.h>

pa_status pa_mesh_create(int dim, pa_mesh **mesh) {
  pa_status st = PA_SUCCESS;
  pa_mesh *m = NULL;
  PA_CHECK(mesh, PA_ERR_ARG, "pa_mesh_create: NULL output pointer");
  *mesh = NULL;
  PA_CHECK(dim == 2 || dim == 3, PA_ERR_ARG,
           "pa_mesh_create: dimension must be 2 or 3, got %d", dim);
  PA_CALLOC(m, 1);
  m->dim = dim;
  *mesh = m;
cleanup:
  return st;
}

void pa_mesh_invalidate(pa_mesh *mesh) {
  if (mesh) pa__mesh_invalidate(mesh);
}

void pa__mesh_invalidate(pa_mesh *mesh) {
  pa__free(mesh->adja);
  pa__free(mesh->ball_start);
  pa__free(mesh->ball);
  pa__free(mesh->bhash);
  mesh->adja = mesh->ball_start = mesh->ball = mesh->bhash = NULL;
  mesh->bhash_cap = 0;
}

void pa__mesh_drop_cells(pa_mesh *mesh) {
  pa__mesh_invalidate(mesh);
  pa__free(mesh->elem);
  pa__free(mesh->eref);
  pa__free(mesh->eflag);
  pa__free(mesh->bdry);
  pa__free(mesh->bref);
  pa__free(mesh->bflag);
  pa__free(mesh->edge);
  pa__free(mesh->edref);
  pa__free(mesh->edflag);
  pa__free(mesh->met);
  for (int k = 0; k < mesh->nfield; k++) pa__free(mesh->field[k].val);
  for (int k = 0; k < mesh->nefield; k++) pa__free(mesh->efield[k].val);
  for (int k = 0; k < mesh->nbfield; k++) pa__free(mesh->bfield[k].val);
  memset(mesh->field, 0, sizeof mesh->field);
  memset(mesh->efield, 0, sizeof mesh->efield);
  memset(mesh->bfield, 0, sizeof mesh->bfield);
  mesh->nefield = mesh->nbfield = 0;
  mesh->elem = mesh->bdry = mesh->edge = NULL;
  mesh->eref = mesh->bref = mesh->edref = NULL;
  mesh->eflag = mesh->bflag = mesh->edflag = NULL;
  mesh->met = NULL;
  mesh->ne = mesh->nb = mesh->ned = 0;
  mesh->cape = mesh->capb = mesh->caped = 0;
  mesh->met_ncomp = mesh->nfield = 0;
}

/* ---- storage of the classification (filled by classify.c) ---- */

void pa__mesh_free_entities(pa_mesh *m) {
  for (int k = 0; k < m->nent; k++) {
    pa__free(m->ents[k].phys);
    pa__free(m->ents[k].bound);
  }
  pa__free(m->ents);
  m->ents = NULL;
  m->nent = 0;
}

pa_status pa__mesh_copy_entities(pa_mesh *dst, const pa_mesh *src) {
  pa_status st = PA_SUCCESS;
  pa__entity *e = NULL;
  int n = 0;
  if (src->nent) {
    PA_CALLOC(e, src->nent);
    for (; n < src->nent; n++) {
      const pa__entity *s = &src->ents[n];
      e[n] = *s;
      e[n].phys = e[n].bound = NULL;
      PA_ALLOC(e[n].phys, s->nphys);
      PA_ALLOC(e[n].bound, s->nbound);
      if (s->nphys) memcpy(e[n].phys, s->phys, s->nphys * sizeof *s->phys);
      if (s->nbound)
        memcpy(e[n].bound, s->bound, s->nbound * sizeof *s->bound);
    }
  }
  pa__mesh_free_entities(dst);
  dst->ents = e;
  dst->nent = n;
  e = NULL;
cleanup:
  if (e) {
    for (int k = 0; k <= n && k < src->nent; k++) {
      pa__free(e[k].phys);
      pa__free(e[k].bound);
    }
    pa__free(e);
  }
  return st;
}

pa_status pa__mesh_enable_entities(pa_mesh *m) {
  pa_status st = PA_SUCCESS;
  uint8_t *gd = NULL;
  int32_t *gt = NULL;
  if (m->vgdim) return PA_SUCCESS;
  size_t cap = m->capv > 0 ? m->capv : 1;
  PA_ALLOC(gd, cap);
  PA_CALLOC(gt, cap);
  memset(gd, m->dim, cap);
  m->vgdim = gd;
  m->vgtag = gt;
  gd = NULL;
  gt = NULL;
cleanup:
  pa__free(gd);
  pa__free(gt);
  return st;
}

void pa__mesh_disable_entities(pa_mesh *m) {
  pa__free(m->vgdim);
  pa__free(m->vgtag);
  m->vgdim = NULL;
  m->vgtag = NULL;
}

void pa_mesh_destroy(pa_mesh *mesh) {
  if (!mesh) return;
  pa__mesh_drop_cells(mesh);
  pa__free(mesh->coord);
  pa__free(mesh->vref);
  pa__free(mesh->vflag);
  pa__mesh_free_names(mesh);
  pa__mesh_disable_entities(mesh);
  pa__mesh_free_entities(mesh);
  pa__free(mesh);
}

/* Reallocate p to n items of size sz; on failure p is left untouched. */
static pa_status grow_array(void **p, size_t n, size_t sz) {
  void *q = pa__realloc(*p, (n ? n : 1) * sz);
  if (!q)
    return pa__error(PA_ERR_MEMORY, __FILE__, __LINE__,
                     "out of memory growing a mesh array to %zu entries", n);
  *p = q;
  return PA_SUCCESS;
}

pa_status pa__mesh_grow_vertices(pa_mesh *m, size_t n) {
  pa_status st = PA_SUCCESS;
  if (n <= m->capv) return PA_SUCCESS;
  size_t cap = m->capv + m->capv / 2 + 16;
  if (cap < n) cap = n;
  PA_CHECK(cap <= INT32_MAX, PA_ERR_ARG, "too many vertices (%zu)", cap);
  PA_CALL(grow_array((void **)&m->coord, cap * m->dim, sizeof(double)));
  PA_CALL(grow_array((void **)&m->vref, cap, sizeof(int32_t)));
  PA_CALL(grow_array((void **)&m->vflag, cap, sizeof(uint8_t)));
  if (m->vgdim) {
    PA_CALL(grow_array((void **)&m->vgdim, cap, sizeof(uint8_t)));
    PA_CALL(grow_array((void **)&m->vgtag, cap, sizeof(int32_t)));
  }
  if (m->met_ncomp)
    PA_CALL(grow_array((void **)&m->met, cap * m->met_ncomp, sizeof(double)));
  for (int k = 0; k < m->nfield; k++)
    PA_CALL(grow_array((void **)&m->field[k].val, cap * m->field[k].ncomp,
                       sizeof(double)));
  m->capv = cap;
cleanup:
  return st;
}

static pa_status grow_cells(pa_idx **v, int32_t **ref, uint8_t **flag,
                            size_t *capp, size_t n, int nv) {
  pa_status st = PA_SUCCESS;
  if (n <= *capp) return PA_SUCCESS;
  size_t cap = *capp + *capp / 2 + 16;
  if (cap < n) cap = n;
  PA_CHECK(cap <= INT32_MAX, PA_ERR_ARG, "too many entities (%zu)", cap);
  PA_CALL(grow_array((void **)v, cap * nv, sizeof(pa_idx)));
  PA_CALL(grow_array((void **)ref, cap, sizeof(int32_t)));
  PA_CALL(grow_array((void **)flag, cap, sizeof(uint8_t)));
  *capp = cap;
cleanup:
  return st;
}

pa__field *pa__mesh_fields(pa_mesh *m, int at, int **count) {
  switch (at) {
  case PA_VERTEX:
    if (count) *count = &m->nfield;
    return m->field;
  case PA_ELEMENT:
    if (count) *count = &m->nefield;
    return m->efield;
  case PA_BOUNDARY:
    if (count) *count = &m->nbfield;
    return m->bfield;
  default:
    return NULL;
  }
}

int pa__transfer_default(int at) {
  return at == PA_VERTEX    ? PA_TRANSFER_LINEAR
         : at == PA_ELEMENT ? PA_TRANSFER_CONSERVATIVE
                            : PA_TRANSFER_NEAREST;
}

pa_status pa__mesh_fields_realloc(pa_mesh *m, int at, size_t cap) {
  pa_status st = PA_SUCCESS;
  int *n;
  pa__field *f = pa__mesh_fields(m, at, &n);
  for (int k = 0; k < *n; k++)
    PA_CALL(grow_array((void **)&f[k].val, cap * f[k].ncomp, sizeof(double)));
cleanup:
  return st;
}

/* The element (boundary) arrays and fields grown to n entities. */
static pa_status grow_elems(pa_mesh *m, size_t n) {
  pa_status st = PA_SUCCESS;
  size_t cap = m->cape;
  PA_CALL(grow_cells(&m->elem, &m->eref, &m->eflag, &m->cape, n, m->dim + 1));
  if (m->cape != cap) PA_CALL(pa__mesh_fields_realloc(m, PA_ELEMENT, m->cape));
cleanup:
  return st;
}

static pa_status grow_bdrys(pa_mesh *m, size_t n) {
  pa_status st = PA_SUCCESS;
  size_t cap = m->capb;
  PA_CALL(grow_cells(&m->bdry, &m->bref, &m->bflag, &m->capb, n, m->dim));
  if (m->capb != cap) PA_CALL(pa__mesh_fields_realloc(m, PA_BOUNDARY, m->capb));
cleanup:
  return st;
}

void pa__mesh_zero_values(pa_mesh *m, int at, size_t i0, size_t i1) {
  int *n;
  pa__field *f = pa__mesh_fields(m, at, &n);
  for (int k = 0; k < *n && i1 > i0; k++)
    memset(f[k].val + i0 * f[k].ncomp, 0, (i1 - i0) * f[k].ncomp * sizeof(double));
}

void pa__mesh_copy_values(pa_mesh *m, int at, pa_idx from, pa_idx to) {
  int *n;
  pa__field *f = pa__mesh_fields(m, at, &n);
  for (int k = 0; k < *n; k++) {
    size_t nc = (size_t)f[k].ncomp;
    memcpy(f[k].val + nc * to, f[k].val + nc * from, nc * sizeof(double));
  }
}

void pa__mesh_move_cell_fields(pa_mesh *dst, pa_mesh *src) {
  for (int k = 0; k < dst->nefield; k++) pa__free(dst->efield[k].val);
  for (int k = 0; k < dst->nbfield; k++) pa__free(dst->bfield[k].val);
  memcpy(dst->efield, src->efield, sizeof dst->efield);
  memcpy(dst->bfield, src->bfield, sizeof dst->bfield);
  dst->nefield = src->nefield;
  dst->nbfield = src->nbfield;
  memset(src->efield, 0, sizeof src->efield);
  memset(src->bfield, 0, sizeof src->bfield);
  src->nefield = src->nbfield = 0;
}

pa_status pa_mesh_reserve(pa_mesh *m, pa_idx nvert, pa_idx nelem, pa_idx nbdry,
                          pa_idx nedge) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(m && nvert >= 0 && nelem >= 0 && nbdry >= 0 && nedge >= 0,
           PA_ERR_ARG, "pa_mesh_reserve: invalid arguments");
  PA_CALL(pa__mesh_grow_vertices(m, (size_t)nvert));
  PA_CALL(grow_elems(m, (size_t)nelem));
  PA_CALL(grow_bdrys(m, (size_t)nbdry));
  PA_CALL(grow_cells(&m->edge, &m->edref, &m->edflag, &m->caped,
                     (size_t)nedge, 2));
cleanup:
  return st;
}

/* Set *count to n for one cell kind: grown entries zeroed, shrinking drops
 * the last ones. */
static pa_status resize_cells(pa_idx **v, int32_t **ref, uint8_t **flag,
                              size_t *cap, pa_idx *count, pa_idx n, int nv) {
  pa_status st = PA_SUCCESS;
  PA_CALL(grow_cells(v, ref, flag, cap, (size_t)n, nv));
  if (n > *count) {
    size_t d = (size_t)(n - *count);
    memset(*v + (size_t)nv * *count, 0, d * nv * sizeof(pa_idx));
    memset(*ref + *count, 0, d * sizeof(int32_t));
    memset(*flag + *count, 0, d);
  }
  *count = n;
cleanup:
  return st;
}

pa_status pa_mesh_resize(pa_mesh *m, pa_idx nvert, pa_idx nelem, pa_idx nbdry,
                         pa_idx nedge) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(m && nvert >= 0 && nelem >= 0 && nbdry >= 0 && nedge >= 0,
           PA_ERR_ARG, "pa_mesh_resize: invalid arguments");
  PA_CHECK(m->dim == 3 || nedge == 0, PA_ERR_ARG,
           "pa_mesh_resize: feature edges exist in 3D only");
  PA_CALL(pa_mesh_reserve(m, nvert, nelem, nbdry, nedge));
  if (nvert > m->nv) {
    size_t i = (size_t)m->nv, d = (size_t)(nvert - m->nv);
    memset(m->coord + (size_t)m->dim * i, 0, d * m->dim * sizeof(double));
    memset(m->vref + i, 0, d * sizeof(int32_t));
    memset(m->vflag + i, 0, d);
    if (m->vgdim) {
      memset(m->vgdim + i, m->dim, d);
      memset(m->vgtag + i, 0, d * sizeof(int32_t));
    }
    if (m->met_ncomp)
      memset(m->met + (size_t)m->met_ncomp * i, 0,
             d * m->met_ncomp * sizeof(double));
    for (int k = 0; k < m->nfield; k++)
      memset(m->field[k].val + (size_t)m->field[k].ncomp * i, 0,
             d * m->field[k].ncomp * sizeof(double));
  }
  m->nv = nvert;
  if (nelem > m->ne) pa__mesh_zero_values(m, PA_ELEMENT, (size_t)m->ne, (size_t)nelem);
  if (nbdry > m->nb) pa__mesh_zero_values(m, PA_BOUNDARY, (size_t)m->nb, (size_t)nbdry);
  PA_CALL(resize_cells(&m->elem, &m->eref, &m->eflag, &m->cape, &m->ne, nelem,
                       m->dim + 1));
  PA_CALL(resize_cells(&m->bdry, &m->bref, &m->bflag, &m->capb, &m->nb, nbdry,
                       m->dim));
  PA_CALL(resize_cells(&m->edge, &m->edref, &m->edflag, &m->caped, &m->ned,
                       nedge, 2));
  pa__mesh_invalidate(m);
cleanup:
  return st;
}

pa_status pa_mesh_add_vertex(pa_mesh *m, const double *x, int32_t ref,
                             pa_idx *index) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(m && x, PA_ERR_ARG, "pa_mesh_add_vertex: NULL argument");
  PA_CHECK(m->nv < INT32_MAX, PA_ERR_ARG, "too many vertices");
  PA_CALL(pa__mesh_grow_vertices(m, (size_t)m->nv + 1));
  pa_idx i = m->nv++;
  memcpy(m->coord + (size_t)m->dim * i, x, m->dim * sizeof(double));
  m->vref[i] = ref;
  m->vflag[i] = 0;
  if (m->vgdim) {
    m->vgdim[i] = (uint8_t)m->dim;
    m->vgtag[i] = 0;
  }
  if (m->met_ncomp)
    memset(m->met + (size_t)m->met_ncomp * i, 0, m->met_ncomp * sizeof(double));
  for (int k = 0; k < m->nfield; k++)
    memset(m->field[k].val + (size_t)m->field[k].ncomp * i, 0,
           m->field[k].ncomp * sizeof(double));
  pa__mesh_invalidate(m);
  if (index) *index = i;
cleanup:
  return st;
}

static pa_status add_cell(pa_mesh *m, pa_idx **v, int32_t **ref,
                          uint8_t **flag, size_t *cap, pa_idx *count, int nv,
                          const pa_idx *verts, int32_t r, pa_idx *index) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(verts, PA_ERR_ARG, "NULL vertex list");
  PA_CHECK(*count < INT32_MAX, PA_ERR_ARG, "too many entities");
  PA_CALL(grow_cells(v, ref, flag, cap, (size_t)*count + 1, nv));
  pa_idx i = (*count)++;
  memcpy(*v + (size_t)nv * i, verts, nv * sizeof(pa_idx));
  (*ref)[i] = r;
  (*flag)[i] = 0;
  pa__mesh_invalidate(m);
  if (index) *index = i;
cleanup:
  return st;
}

pa_status pa_mesh_add_elem(pa_mesh *m, const pa_idx *v, int32_t ref,
                           pa_idx *index) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(m, PA_ERR_ARG, "NULL mesh");
  if ((size_t)m->ne + 1 > m->cape && m->ne < INT32_MAX)
    PA_CALL(grow_elems(m, (size_t)m->ne + 1));
  PA_CALL(add_cell(m, &m->elem, &m->eref, &m->eflag, &m->cape, &m->ne,
                   m->dim + 1, v, ref, index));
  pa__mesh_zero_values(m, PA_ELEMENT, (size_t)m->ne - 1, (size_t)m->ne);
cleanup:
  return st;
}

pa_status pa_mesh_add_bdry(pa_mesh *m, const pa_idx *v, int32_t ref,
                           pa_idx *index) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(m, PA_ERR_ARG, "NULL mesh");
  if ((size_t)m->nb + 1 > m->capb && m->nb < INT32_MAX)
    PA_CALL(grow_bdrys(m, (size_t)m->nb + 1));
  PA_CALL(add_cell(m, &m->bdry, &m->bref, &m->bflag, &m->capb, &m->nb, m->dim,
                   v, ref, index));
  pa__mesh_zero_values(m, PA_BOUNDARY, (size_t)m->nb - 1, (size_t)m->nb);
cleanup:
  return st;
}

pa_status pa_mesh_add_edge(pa_mesh *m, const pa_idx *v, int32_t ref,
                           pa_idx *index) {
  if (!m) return pa__error(PA_ERR_ARG, __FILE__, __LINE__, "NULL mesh");
  if (m->dim == 2)
    return pa__error(PA_ERR_ARG, __FILE__, __LINE__,
                     "feature edges exist in 3D only; use pa_mesh_add_bdry");
  return add_cell(m, &m->edge, &m->edref, &m->edflag, &m->caped, &m->ned, 2,
                  v, ref, index);
}

int pa_mesh_dim(const pa_mesh *m) { return m->dim; }
pa_idx pa_mesh_nvert(const pa_mesh *m) { return m->nv; }
pa_idx pa_mesh_nelem(const pa_mesh *m) { return m->ne; }
pa_idx pa_mesh_nbdry(const pa_mesh *m) { return m->nb; }
pa_idx pa_mesh_nedge(const pa_mesh *m) { return m->ned; }
double *pa_mesh_coords(pa_mesh *m) { return m->coord; }
pa_idx *pa_mesh_elems(pa_mesh *m) { return m->elem; }
pa_idx *pa_mesh_bdrys(pa_mesh *m) { return m->bdry; }
pa_idx *pa_mesh_edges(pa_mesh *m) { return m->edge; }
int32_t *pa_mesh_vert_refs(pa_mesh *m) { return m->vref; }
int32_t *pa_mesh_elem_refs(pa_mesh *m) { return m->eref; }
int32_t *pa_mesh_bdry_refs(pa_mesh *m) { return m->bref; }
int32_t *pa_mesh_edge_refs(pa_mesh *m) { return m->edref; }
uint8_t *pa_mesh_vert_flags(pa_mesh *m) { return m->vflag; }
uint8_t *pa_mesh_elem_flags(pa_mesh *m) { return m->eflag; }
uint8_t *pa_mesh_bdry_flags(pa_mesh *m) { return m->bflag; }
uint8_t *pa_mesh_edge_flags(pa_mesh *m) { return m->edflag; }
int pa_mesh_metric_ncomp(const pa_mesh *m) { return m->met_ncomp; }
double *pa_mesh_metric(pa_mesh *m) { return m->met_ncomp ? m->met : NULL; }
int pa_mesh_nfield(const pa_mesh *m) { return m->nfield; }

/* Entities of kind at in m. */
static pa_idx entity_count(const pa_mesh *m, int at) {
  return at == PA_VERTEX ? m->nv : at == PA_ELEMENT ? m->ne : m->nb;
}

/* Room for entities of kind at in m. */
static size_t entity_cap(const pa_mesh *m, int at) {
  return at == PA_VERTEX ? m->capv : at == PA_ELEMENT ? m->cape : m->capb;
}

static const char *const entity_word[] = {"vertex", "element",
                                          "boundary entity"};

int pa_mesh_nfield_at(const pa_mesh *m, pa_entity at) {
  int *n;
  if (!m || !pa__mesh_fields((pa_mesh *)m, at, &n)) return 0;
  return *n;
}

pa_status pa_mesh_field_at(pa_mesh *m, pa_entity at, int k, const char **name,
                           int *ncomp, double **values) {
  pa_status st = PA_SUCCESS;
  int *n = NULL;
  pa__field *f = m ? pa__mesh_fields(m, at, &n) : NULL;
  PA_CHECK(f && k >= 0 && k < *n, PA_ERR_ARG, "pa_mesh_field: no field %d", k);
  if (name) *name = f[k].name;
  if (ncomp) *ncomp = f[k].ncomp;
  if (values) *values = f[k].val;
cleanup:
  return st;
}

pa_status pa_mesh_field(pa_mesh *m, int k, const char **name, int *ncomp,
                        double **values) {
  return pa_mesh_field_at(m, PA_VERTEX, k, name, ncomp, values);
}

int pa_mesh_field_index(const pa_mesh *m, pa_entity at, const char *name) {
  int *n;
  const pa__field *f = m && name ? pa__mesh_fields((pa_mesh *)m, at, &n) : NULL;
  for (int k = 0; f && k < *n; k++)
    if (!strncmp(f[k].name, name, PA_MESH_FIELD_NAME_LEN - 1)) return k;
  return -1;
}

pa_status pa_mesh_add_field_at(pa_mesh *m, pa_entity at, const char *name,
                               int ncomp, const double *values) {
  pa_status st = PA_SUCCESS;
  double *val = NULL;
  int *n = NULL;
  pa__field *fl = m ? pa__mesh_fields(m, at, &n) : NULL;
  PA_CHECK(m && name && ncomp > 0, PA_ERR_ARG, "pa_mesh_add_field: bad arguments");
  PA_CHECK(fl, PA_ERR_ARG,
           "pa_mesh_add_field: fields live on vertices, elements or boundary "
           "entities (kind %d)", (int)at);
  PA_CHECK(*n < PA_MESH_MAX_FIELDS, PA_ERR_ARG,
           "a mesh holds at most %d fields per kind of entity",
           PA_MESH_MAX_FIELDS);
  size_t ne = (size_t)entity_count(m, at), cap = entity_cap(m, at);
  PA_CHECK(values || ne == 0, PA_ERR_ARG, "pa_mesh_add_field: NULL values");
  for (size_t i = 0; i < ne * ncomp; i++)
    PA_CHECK(isfinite(values[i]), PA_ERR_ARG,
             "field '%s': value at %s %zu is not finite", name, entity_word[at],
             i / ncomp + 1);
  PA_ALLOC(val, (cap > ne ? cap : ne ? ne : 1) * ncomp);
  if (ne) memcpy(val, values, ne * ncomp * sizeof(double));
  pa__field *f = &fl[(*n)++];
  snprintf(f->name, sizeof f->name, "%s", name);
  f->ncomp = ncomp;
  f->transfer = pa__transfer_default(at);
  f->val = val;
  val = NULL;
cleanup:
  pa__free(val);
  return st;
}

pa_status pa_mesh_add_field(pa_mesh *m, const char *name, int ncomp,
                            const double *values) {
  return pa_mesh_add_field_at(m, PA_VERTEX, name, ncomp, values);
}

pa_status pa_mesh_remove_field_at(pa_mesh *m, pa_entity at, int k) {
  pa_status st = PA_SUCCESS;
  int *n = NULL;
  pa__field *f = m ? pa__mesh_fields(m, at, &n) : NULL;
  PA_CHECK(f && k >= 0 && k < *n, PA_ERR_ARG,
           "pa_mesh_remove_field: no field %d", k);
  pa__free(f[k].val);
  for (int j = k; j + 1 < *n; j++) f[j] = f[j + 1];
  (*n)--;
  memset(&f[*n], 0, sizeof f[0]);
cleanup:
  return st;
}

pa_status pa_mesh_remove_field(pa_mesh *m, int k) {
  return pa_mesh_remove_field_at(m, PA_VERTEX, k);
}

/* The modes each kind of entity takes, and their list for messages. */
static int transfer_ok(int at, int mode) {
  if (at == PA_VERTEX) return mode == PA_TRANSFER_LINEAR;
  if (at == PA_BOUNDARY) return mode == PA_TRANSFER_NEAREST;
  return mode == PA_TRANSFER_CONSERVATIVE || mode == PA_TRANSFER_BOUNDED ||
         mode == PA_TRANSFER_NEAREST;
}
static const char *const transfer_list[] = {
    "linear (the default and only mode of vertex fields)",
    "conservative (the default), bounded or nearest",
    "nearest (the default and only mode of boundary fields)"};

pa_status pa_mesh_set_field_transfer(pa_mesh *m, pa_entity at, int k,
                                     pa_transfer mode) {
  pa_status st = PA_SUCCESS;
  int *n = NULL;
  pa__field *f = m ? pa__mesh_fields(m, at, &n) : NULL;
  PA_CHECK(f && k >= 0 && k < *n, PA_ERR_ARG,
           "pa_mesh_set_field_transfer: no field %d", k);
  if (mode == PA_TRANSFER_DEFAULT) mode = (pa_transfer)pa__transfer_default(at);
  PA_CHECK(transfer_ok(at, mode), PA_ERR_ARG,
           "field '%s': transfer mode '%s' does not apply to a field on %s; "
           "valid: %s", f[k].name, pa_transfer_name(mode),
           at == PA_VERTEX ? "vertices" : at == PA_ELEMENT ? "elements"
                                                           : "boundary entities",
           transfer_list[at]);
  f[k].transfer = (int)mode;
cleanup:
  return st;
}

pa_transfer pa_mesh_field_transfer(const pa_mesh *m, pa_entity at, int k) {
  int *n;
  const pa__field *f = m ? pa__mesh_fields((pa_mesh *)m, at, &n) : NULL;
  if (!f || k < 0 || k >= *n) return PA_TRANSFER_DEFAULT;
  return (pa_transfer)f[k].transfer;
}

static const char *const transfer_names[] = {"default", "linear", "conservative",
                                             "bounded", "nearest"};

const char *pa_transfer_name(pa_transfer mode) {
  return (int)mode >= 0 && (int)mode <= PA_TRANSFER_NEAREST
             ? transfer_names[mode]
             : "?";
}

pa_status pa_transfer_parse(const char *name, pa_transfer *mode) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(name && mode, PA_ERR_ARG, "pa_transfer_parse: NULL argument");
  for (int k = 0; k <= PA_TRANSFER_NEAREST; k++)
    if (!strcmp(name, transfer_names[k])) {
      *mode = (pa_transfer)k;
      return PA_SUCCESS;
    }
  if (!strcmp(name, "copy")) {
    *mode = PA_TRANSFER_NEAREST;
    return PA_SUCCESS;
  }
  PA_FAIL(PA_ERR_ARG,
          "unknown transfer mode '%s' (valid: linear, conservative, bounded, "
          "nearest or copy, default)", name);
cleanup:
  return st;
}

void pa__mesh_free_names(pa_mesh *m) {
  for (int k = 0; k < m->nname; k++)
    pa__free(m->names[k].name);
  pa__free(m->names);
  m->names = NULL;
  m->nname = 0;
}

/* A copy of s by the counting allocator, NULL when out of memory. */
static char *copy_string(const char *s) {
  size_t n = strlen(s) + 1;
  char *c = pa__malloc(n);
  if (c) memcpy(c, s, n);
  return c;
}

pa_status pa__mesh_copy_names(pa_mesh *dst, const pa_mesh *src) {
  pa_status st = PA_SUCCESS;
  pa__name *names = NULL;
  int n = 0;
  if (src->nname) {
    PA_CALLOC(names, src->nname);
    for (; n < src->nname; n++) {
      names[n] = src->names[n];
      names[n].name = copy_string(src->names[n].name);
      PA_CHECK(names[n].name, PA_ERR_MEMORY,
               "out of memory copying a physical name");
    }
  }
  pa__mesh_free_names(dst);
  dst->names = names;
  dst->nname = src->nname;
  names = NULL;
cleanup:
  if (names)
    for (int k = 0; k < n; k++)
      pa__free(names[k].name);
  pa__free(names);
  return st;
}

int pa_mesh_nnames(const pa_mesh *m) { return m ? m->nname : 0; }

pa_status pa_mesh_name(const pa_mesh *m, int k, int *dim, int32_t *tag,
                       const char **name) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(m && k >= 0 && k < m->nname, PA_ERR_ARG,
           "pa_mesh_name: no physical name %d", k);
  if (dim) *dim = m->names[k].dim;
  if (tag) *tag = m->names[k].tag;
  if (name) *name = m->names[k].name;
cleanup:
  return st;
}

pa_status pa_mesh_add_name(pa_mesh *m, int dim, int32_t tag, const char *name) {
  pa_status st = PA_SUCCESS;
  char *copy = NULL;
  PA_CHECK(m, PA_ERR_ARG, "pa_mesh_add_name: NULL mesh");
  PA_CHECK(dim >= 0 && dim <= 3, PA_ERR_ARG,
           "pa_mesh_add_name: dimension %d is not 0, 1, 2 or 3", dim);
  PA_CHECK(!name || (name[0] && !strpbrk(name, "\"\n\r")), PA_ERR_ARG,
           "pa_mesh_add_name: a physical name is non-empty and holds no "
           "double quote nor line break");
  int k = 0; /* first entry not below (dim, tag) */
  while (k < m->nname && (m->names[k].dim < dim ||
                          (m->names[k].dim == dim && m->names[k].tag < tag)))
    k++;
  int found = k < m->nname && m->names[k].dim == dim && m->names[k].tag == tag;
  if (!name) {
    if (found) {
      pa__free(m->names[k].name);
      memmove(m->names + k, m->names + k + 1,
              (size_t)(m->nname - k - 1) * sizeof *m->names);
      m->nname--;
    }
    return PA_SUCCESS;
  }
  copy = copy_string(name);
  PA_CHECK(copy, PA_ERR_MEMORY, "out of memory storing a physical name");
  if (found) {
    pa__free(m->names[k].name);
  } else {
    PA_CHECK(m->nname < INT32_MAX, PA_ERR_ARG, "too many physical names");
    void *p = pa__realloc(m->names, (size_t)(m->nname + 1) * sizeof *m->names);
    PA_CHECK(p, PA_ERR_MEMORY, "out of memory storing a physical name");
    m->names = p;
    memmove(m->names + k + 1, m->names + k,
            (size_t)(m->nname - k) * sizeof *m->names);
    m->nname++;
    m->names[k].dim = dim;
    m->names[k].tag = tag;
  }
  m->names[k].name = copy;
  copy = NULL;
cleanup:
  pa__free(copy);
  return st;
}

pa_status pa_mesh_copy(const pa_mesh *src, pa_mesh **dst) {
  pa_status st = PA_SUCCESS;
  pa_mesh *m = NULL;
  PA_CHECK(src && dst, PA_ERR_ARG, "pa_mesh_copy: NULL argument");
  PA_CALL(pa_mesh_create(src->dim, &m));
  m->file_dim = src->file_dim;
  m->met_ncomp = src->met_ncomp;
  for (int at = PA_VERTEX; at <= PA_BOUNDARY; at++) {
    int *sn, *dn;
    const pa__field *sf = pa__mesh_fields((pa_mesh *)src, at, &sn);
    pa__field *df = pa__mesh_fields(m, at, &dn);
    *dn = *sn;
    for (int k = 0; k < *sn; k++) {
      df[k] = sf[k];
      df[k].val = NULL;
    }
  }
  if (src->vgdim) PA_CALL(pa__mesh_enable_entities(m));
  PA_CALL(pa_mesh_reserve(m, src->nv, src->ne, src->nb, src->ned));
  int d = src->dim;
  m->nv = src->nv;
  m->ne = src->ne;
  m->nb = src->nb;
  m->ned = src->ned;
  /* Empty arrays may be NULL: copy only what exists (memcpy(NULL,..,0) is
   * undefined behaviour). */
#define COPY_ARRAY(dst, srcp, n)                                             \
  do {                                                                       \
    if ((n) > 0) memcpy((dst), (srcp), (n) * sizeof(*(srcp)));               \
  } while (0)
  COPY_ARRAY(m->coord, src->coord, (size_t)d * src->nv);
  COPY_ARRAY(m->vref, src->vref, (size_t)src->nv);
  COPY_ARRAY(m->vflag, src->vflag, (size_t)src->nv);
  if (src->vgdim) {
    COPY_ARRAY(m->vgdim, src->vgdim, (size_t)src->nv);
    COPY_ARRAY(m->vgtag, src->vgtag, (size_t)src->nv);
  }
  COPY_ARRAY(m->elem, src->elem, (size_t)(d + 1) * src->ne);
  COPY_ARRAY(m->eref, src->eref, (size_t)src->ne);
  COPY_ARRAY(m->eflag, src->eflag, (size_t)src->ne);
  COPY_ARRAY(m->bdry, src->bdry, (size_t)d * src->nb);
  COPY_ARRAY(m->bref, src->bref, (size_t)src->nb);
  COPY_ARRAY(m->bflag, src->bflag, (size_t)src->nb);
  COPY_ARRAY(m->edge, src->edge, (size_t)2 * src->ned);
  COPY_ARRAY(m->edref, src->edref, (size_t)src->ned);
  COPY_ARRAY(m->edflag, src->edflag, (size_t)src->ned);
  if (src->met_ncomp)
    COPY_ARRAY(m->met, src->met, (size_t)src->met_ncomp * src->nv);
  for (int k = 0; k < src->nfield; k++)
    COPY_ARRAY(m->field[k].val, src->field[k].val,
               (size_t)src->field[k].ncomp * src->nv);
  for (int k = 0; k < src->nefield; k++)
    COPY_ARRAY(m->efield[k].val, src->efield[k].val,
               (size_t)src->efield[k].ncomp * src->ne);
  for (int k = 0; k < src->nbfield; k++)
    COPY_ARRAY(m->bfield[k].val, src->bfield[k].val,
               (size_t)src->bfield[k].ncomp * src->nb);
#undef COPY_ARRAY
  PA_CALL(pa__mesh_copy_names(m, src));
  PA_CALL(pa__mesh_copy_entities(m, src));
  *dst = m;
  m = NULL;
cleanup:
  pa_mesh_destroy(m);
  return st;
}

size_t pa_mesh_memory_used(const pa_mesh *m) {
  if (!m) return 0;
  size_t n = sizeof *m;
  const void *blocks[] = {m->coord, m->vref,  m->vflag, m->elem,  m->eref,
                          m->eflag, m->bdry,  m->bref,  m->bflag, m->edge,
                          m->edref, m->edflag, m->met,  m->adja,  m->ball_start,
                          m->ball,  m->bhash, m->vgdim, m->vgtag, m->ents};
  for (size_t i = 0; i < sizeof blocks / sizeof *blocks; i++)
    n += pa__alloc_size(blocks[i]);
  for (int k = 0; k < m->nfield; k++) n += pa__alloc_size(m->field[k].val);
  for (int k = 0; k < m->nefield; k++) n += pa__alloc_size(m->efield[k].val);
  for (int k = 0; k < m->nbfield; k++) n += pa__alloc_size(m->bfield[k].val);
  n += pa__alloc_size(m->names);
  for (int k = 0; k < m->nname; k++)
    n += pa__alloc_size(m->names[k].name);
  for (int k = 0; k < m->nent; k++)
    n += pa__alloc_size(m->ents[k].phys) + pa__alloc_size(m->ents[k].bound);
  return n;
}

void pa__mesh_frozen_vertices(const pa_mesh *m, uint8_t *f) {
  int d = m->dim;
  for (pa_idx v = 0; v < m->nv; v++) f[v] = (m->vflag[v] & PA_FLAG_REQUIRED) != 0;
  for (pa_idx k = 0; k < m->ne; k++)
    if (m->eflag[k] & PA_FLAG_REQUIRED)
      for (int i = 0; i <= d; i++) f[m->elem[(size_t)(d + 1) * k + i]] = 1;
  for (pa_idx b = 0; b < m->nb; b++)
    if (m->bflag[b] & PA_FLAG_REQUIRED)
      for (int i = 0; i < d; i++) f[m->bdry[(size_t)d * b + i]] = 1;
}
