/*
 * dmesh.c -- life cycle and accessors of the distributed mesh, user values
 * and their exchange (halo and reduction through the exchange layer).
 *
 * Invariants: a value's data has one block per slot; slot == local entity
 * when ref < 0, otherwise slots list the local entities of that reference in
 * increasing local index, so owned slots come first. Once the kind's sf is
 * built, each value has its sf (the kind's, or its restriction to the slots)
 * and operation buffers, so halo/reduce never allocate.
 */
#include "dmesh/dmesh.h"

#include <stdio.h>

enum { TAG_VALUE_BASE = 1000, TAG_VALUE_SPAN = 30000, TAG_SYNC = 900 };

pa_status pa__dmesh_create(MPI_Comm comm, int dim, pa_dmesh **dmp) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = NULL;
  *dmp = NULL;
  dm = pa__calloc(1, sizeof *dm);
  st = dm ? PA_SUCCESS
          : pa__error(PA_ERR_MEMORY, __FILE__, __LINE__, "out of memory");
  PA_CALL(pa__agree(comm, st));
  MPI_Comm_dup(comm, &dm->comm);
  MPI_Comm_rank(dm->comm, &dm->rank);
  MPI_Comm_size(dm->comm, &dm->size);
  dm->dim = dim;
  *dmp = dm;
  dm = NULL;
cleanup:
  pa__free(dm);
  return st;
}

void pa__dmesh_invalidate(pa_dmesh *dm) {
  for (int k = 0; k < PA_DMESH_NKIND; k++) {
    pa__free(dm->shared[k]);
    dm->shared[k] = NULL;
    for (int s = 0; s < 2; s++) {
      pa__free(dm->iterlist[k][s]);
      dm->iterlist[k][s] = NULL;
      dm->niter[k][s] = 0;
    }
  }
  pa__free(dm->adja);
  pa__free(dm->vstart);
  pa__free(dm->velem);
  pa__free(dm->bface);
  dm->adja = dm->vstart = dm->velem = dm->bface = NULL;
}

static void value_release(pa_dmesh_value *v) {
  pa__sfop_free(&v->op);
  if (v->ref >= 0) pa__sf_free(&v->sf);
  memset(&v->sf, 0, sizeof v->sf);
  pa__free(v->ent);
  pa__free(v->slot);
  pa__free(v->data);
  v->ent = v->slot = NULL;
  v->data = NULL;
  v->nslot = v->nslotown = 0;
  v->ready = 0;
}

void pa__dmesh_clear(pa_dmesh *dm) {
  pa__dmesh_invalidate(dm);
  for (int k = 0; k < dm->nvalue; k++) value_release(dm->value[k]);
  pa_mesh_destroy(dm->mesh);
  dm->mesh = NULL;
  for (int k = 0; k < PA_DMESH_NKIND; k++) {
    pa__free(dm->gid[k]);
    pa__free(dm->owner[k]);
    dm->gid[k] = NULL;
    dm->owner[k] = NULL;
    pa__sf_free(&dm->sf[k]);
    dm->nown[k] = dm->nloc[k] = 0;
    dm->nglob[k] = 0;
  }
  pa__free(dm->layer);
  dm->layer = NULL;
  pa__free(dm->neigh);
  dm->neigh = NULL;
  dm->nneigh = 0;
}

void pa_dmesh_destroy(pa_dmesh *dm) {
  if (!dm) return;
  pa__dmesh_clear(dm);
  for (int k = 0; k < dm->nvalue; k++) {
    if (dm->value[k]->duped) MPI_Type_free(&dm->value[k]->type);
    pa__free(dm->value[k]);
  }
  pa__free(dm->value);
  MPI_Comm_free(&dm->comm);
  pa__free(dm);
}

MPI_Comm pa_dmesh_comm(const pa_dmesh *dm) { return dm->comm; }
int pa_dmesh_dim(const pa_dmesh *dm) { return dm->dim; }
int pa_dmesh_overlap(const pa_dmesh *dm) { return dm->overlap; }
pa_idx pa_dmesh_nowned(const pa_dmesh *dm, pa_entity k) {
  return (unsigned)k < PA_DMESH_NKIND ? dm->nown[k] : 0;
}
pa_idx pa_dmesh_nlocal(const pa_dmesh *dm, pa_entity k) {
  return (unsigned)k < PA_DMESH_NKIND ? dm->nloc[k] : 0;
}
pa_gid pa_dmesh_nglobal(const pa_dmesh *dm, pa_entity k) {
  return (unsigned)k < PA_DMESH_NKIND ? dm->nglob[k] : 0;
}
const pa_gid *pa_dmesh_gids(const pa_dmesh *dm, pa_entity k) {
  return (unsigned)k < PA_DMESH_NKIND ? dm->gid[k] : NULL;
}
const int *pa_dmesh_owners(const pa_dmesh *dm, pa_entity k) {
  return (unsigned)k < PA_DMESH_NKIND ? dm->owner[k] : NULL;
}
const uint8_t *pa_dmesh_elem_layers(const pa_dmesh *dm) { return dm->layer; }
int pa_dmesh_neighbours(const pa_dmesh *dm, const int **ranks) {
  if (ranks) *ranks = dm->neigh;
  return dm->nneigh;
}
pa_mesh *pa_dmesh_mesh(pa_dmesh *dm) { return dm->mesh; }

size_t pa_dmesh_memory_used(const pa_dmesh *dm) {
  if (!dm) return 0;
  size_t n = sizeof *dm + pa_mesh_memory_used(dm->mesh) +
             pa__alloc_size(dm->layer) + pa__alloc_size(dm->neigh) +
             pa__alloc_size(dm->adja) + pa__alloc_size(dm->vstart) +
             pa__alloc_size(dm->velem) + pa__alloc_size(dm->bface) +
             pa__alloc_size(dm->value);
  for (int k = 0; k < PA_DMESH_NKIND; k++) {
    n += pa__alloc_size(dm->gid[k]) + pa__alloc_size(dm->owner[k]) +
         pa__sf_memory(&dm->sf[k]) + pa__alloc_size(dm->shared[k]) +
         pa__alloc_size(dm->iterlist[k][0]) + pa__alloc_size(dm->iterlist[k][1]);
  }
  for (int k = 0; k < dm->nvalue; k++) {
    const pa_dmesh_value *v = dm->value[k];
    n += sizeof *v + pa__alloc_size(v->data) + pa__alloc_size(v->ent) +
         pa__alloc_size(v->slot) + pa__alloc_size(v->op.rootbuf) +
         pa__alloc_size(v->op.leafbuf) + pa__alloc_size(v->op.req) +
         pa__alloc_size(v->op.scratch);
    if (v->ref >= 0) n += pa__sf_memory(&v->sf);
  }
  return n;
}

int32_t pa__dmesh_ref(const pa_dmesh *dm, int kind, pa_idx e) {
  const pa_mesh *m = dm->mesh;
  switch (kind) {
  case PA_VERTEX: return m->vref[e];
  case PA_ELEMENT: return m->eref[e];
  case PA_BOUNDARY: return m->bref[e];
  default: return m->edref[e];
  }
}

/* ---- values ---- */

pa_status pa__value_alloc(pa_dmesh *dm, pa_dmesh_value *v) {
  pa_status st = PA_SUCCESS;
  value_release(v);
  pa_idx n = dm->nloc[v->kind], nown = dm->nown[v->kind];
  if (v->ref < 0) {
    v->nslot = n;
    v->nslotown = nown;
  } else {
    PA_ALLOC(v->slot, n);
    pa_idx k = 0, ko = 0;
    for (pa_idx e = 0; e < n; e++) {
      int in = pa__dmesh_ref(dm, v->kind, e) == v->ref;
      v->slot[e] = in ? k++ : -1;
      if (in && e < nown) ko++;
    }
    PA_ALLOC(v->ent, k);
    for (pa_idx e = 0; e < n; e++)
      if (v->slot[e] >= 0) v->ent[v->slot[e]] = e;
    v->nslot = k;
    v->nslotown = ko;
  }
  PA_CALLOC(v->data, (size_t)v->nslot * v->unit);
cleanup:
  return st;
}

pa_status pa__value_setup(pa_dmesh *dm, pa_dmesh_value *v) {
  pa_status st = PA_SUCCESS;
  const pa__sf *sf = &dm->sf[v->kind];
  pa__sfop_free(&v->op);
  if (v->ref >= 0) {
    pa__sf_free(&v->sf);
    PA_CALL(pa__sf_restrict(sf, v->slot, &v->sf));
    sf = &v->sf;
  }
  PA_CALL(pa__sfop_init(&v->op, sf, v->unit,
                        TAG_VALUE_BASE + v->id % TAG_VALUE_SPAN));
  v->ready = 1;
cleanup:
  return st;
}

pa_status pa_dmesh_value_add(pa_dmesh *dm, pa_entity kind, const char *name,
                             MPI_Datatype type, int ncomp, int32_t ref,
                             pa_dmesh_value **value) {
  pa_status st = PA_SUCCESS;
  pa_dmesh_value *v = NULL;
  int tsize = 0;
  MPI_Aint lb = 0, extent = 0;
  PA_CHECK(dm && value, PA_ERR_ARG, "pa_dmesh_value_add: NULL argument");
  pa__agree_reset();
  *value = NULL;
  PA_CHECK((unsigned)kind < PA_DMESH_NKIND, PA_ERR_ARG, "bad entity kind %d",
           (int)kind);
  PA_CHECK(name && strlen(name) < PA_DMESH_VALUE_NAME_LEN, PA_ERR_ARG,
           "value name missing or longer than %d", PA_DMESH_VALUE_NAME_LEN - 1);
  PA_CHECK(!pa_dmesh_value_find(dm, name), PA_ERR_ARG,
           "a value named '%s' already exists", name);
  PA_CHECK(ncomp >= 1, PA_ERR_ARG, "ncomp must be >= 1, got %d", ncomp);
  PA_CHECK(ref >= -1, PA_ERR_ARG, "ref must be >= 0 or -1 (all), got %d", ref);
  PA_CHECK(type != MPI_DATATYPE_NULL, PA_ERR_ARG, "MPI_DATATYPE_NULL");
  MPI_Type_size(type, &tsize);
  MPI_Type_get_extent(type, &lb, &extent);
  PA_CHECK(tsize > 0 && lb == 0 && extent == tsize, PA_ERR_ARG,
           "value '%s': the datatype must be contiguous (size %d, extent %ld)",
           name, tsize, (long)extent);
  PA_GROW(dm->value, dm->capvalue, dm->nvalue + 1);
  PA_CALLOC(v, 1);
  v->id = dm->nextid;
  v->kind = kind;
  snprintf(v->name, sizeof v->name, "%s", name);
  {
    int ni, na, nd, comb;
    MPI_Type_get_envelope(type, &ni, &na, &nd, &comb);
    v->duped = comb != MPI_COMBINER_NAMED;
    if (v->duped) MPI_Type_dup(type, &v->type);
    else v->type = type;
  }
  v->double_type = type == MPI_DOUBLE;
  v->ncomp = ncomp;
  v->unit = (size_t)tsize * ncomp;
  v->ref = ref;
  PA_CALL(pa__value_alloc(dm, v));
  PA_CALL(pa__value_setup(dm, v));
  dm->value[dm->nvalue++] = v;
  dm->nextid++;
  *value = v;
  v = NULL;
cleanup:
  if (v) {
    value_release(v);
    if (v->duped) MPI_Type_free(&v->type);
    pa__free(v);
  }
  if (dm) {
    st = pa__agree_end(dm->comm, st);
    if (st && value && *value) { /* another rank failed: undo */
      pa_dmesh_value *w = *value;
      dm->nvalue--;
      value_release(w);
      if (w->duped) MPI_Type_free(&w->type);
      pa__free(w);
      *value = NULL;
    }
  }
  return st;
}

pa_status pa__value_define(pa_dmesh *dm, int kind, const char *name,
                           MPI_Datatype type, int ncomp, int32_t ref) {
  pa_status st = PA_SUCCESS;
  pa_dmesh_value *v = NULL;
  int tsize = 0;
  PA_CHECK(kind >= 0 && kind < PA_DMESH_NKIND && ncomp >= 1 && ref >= -1 &&
               strlen(name) < PA_DMESH_VALUE_NAME_LEN &&
               !pa_dmesh_value_find(dm, name),
           PA_ERR_FORMAT, "bad or duplicate value description '%.64s'", name);
  MPI_Type_size(type, &tsize);
  PA_GROW(dm->value, dm->capvalue, dm->nvalue + 1);
  PA_CALLOC(v, 1);
  v->id = dm->nextid++;
  v->kind = (pa_entity)kind;
  snprintf(v->name, sizeof v->name, "%s", name);
  v->type = type;
  v->double_type = type == MPI_DOUBLE;
  v->ncomp = ncomp;
  v->unit = (size_t)tsize * ncomp;
  v->ref = ref;
  dm->value[dm->nvalue++] = v;
cleanup:
  return st;
}

pa_dmesh_value *pa_dmesh_value_find(pa_dmesh *dm, const char *name) {
  if (!dm || !name) return NULL;
  for (int k = 0; k < dm->nvalue; k++)
    if (!strcmp(dm->value[k]->name, name)) return dm->value[k];
  return NULL;
}

pa_status pa_dmesh_value_remove(pa_dmesh *dm, pa_dmesh_value *value) {
  pa_status st = PA_SUCCESS;
  int k = 0;
  PA_CHECK(dm, PA_ERR_ARG, "pa_dmesh_value_remove: NULL dmesh");
  pa__agree_reset();
  while (k < dm->nvalue && dm->value[k] != value) k++;
  PA_CHECK(k < dm->nvalue, PA_ERR_ARG, "value does not belong to this dmesh");
cleanup:
  if (!dm) return st;
  st = pa__agree_end(dm->comm, st);
  if (st) return st;
  value_release(value);
  if (value->duped) MPI_Type_free(&value->type);
  pa__free(value);
  memmove(dm->value + k, dm->value + k + 1,
          (size_t)(dm->nvalue - k - 1) * sizeof *dm->value);
  dm->nvalue--;
  return st;
}

void *pa_dmesh_value_data(pa_dmesh_value *v, pa_idx *n, pa_idx *nowned) {
  if (n) *n = v ? v->nslot : 0;
  if (nowned) *nowned = v ? v->nslotown : 0;
  return v ? v->data : NULL;
}

const pa_idx *pa_dmesh_value_entities(const pa_dmesh_value *v) {
  return v ? v->ent : NULL;
}

void pa_dmesh_value_info(const pa_dmesh_value *v, pa_entity *kind,
                         const char **name, MPI_Datatype *type, int *ncomp,
                         int32_t *ref) {
  if (kind) *kind = v->kind;
  if (name) *name = v->name;
  if (type) *type = v->type;
  if (ncomp) *ncomp = v->ncomp;
  if (ref) *ref = v->ref;
}

/* ---- exchange of values ---- */

static pa_status value_ok(pa_dmesh *dm, pa_dmesh_value *v, int idle) {
  if (!dm || !v)
    return pa__error(PA_ERR_ARG, __FILE__, __LINE__, "NULL dmesh or value");
  if (!v->ready)
    return pa__error(PA_ERR_ARG, __FILE__, __LINE__,
                     "value '%s' is not set up", v->name);
  if (idle && v->op.active)
    return pa__error(PA_ERR_ARG, __FILE__, __LINE__,
                     "value '%s' already has an exchange in flight", v->name);
  return PA_SUCCESS;
}

pa_status pa_dmesh_halo_begin(pa_dmesh *dm, pa_dmesh_value *v) {
  pa_status st = value_ok(dm, v, 1);
  if (st) return st;
  return pa__sf_bcast_begin(&v->op, v->data);
}

pa_status pa_dmesh_halo_end(pa_dmesh *dm, pa_dmesh_value *v) {
  pa_status st = value_ok(dm, v, 0);
  if (st) return st;
  if (v->op.active != 1)
    return pa__error(PA_ERR_ARG, __FILE__, __LINE__,
                     "pa_dmesh_halo_end without pa_dmesh_halo_begin on '%s'",
                     v->name);
  return pa__sf_bcast_end(&v->op, v->data);
}

pa_status pa_dmesh_halo(pa_dmesh *dm, pa_dmesh_value *v) {
  pa_status st = pa_dmesh_halo_begin(dm, v);
  if (st) return st;
  return pa_dmesh_halo_end(dm, v);
}

static int predefined(MPI_Datatype t) {
  int ni, na, nd, comb;
  MPI_Type_get_envelope(t, &ni, &na, &nd, &comb);
  return comb == MPI_COMBINER_NAMED;
}

pa_status pa_dmesh_reduce_begin(pa_dmesh *dm, pa_dmesh_value *v) {
  pa_status st = value_ok(dm, v, 1);
  if (st) return st;
  if (!predefined(v->type))
    return pa__error(PA_ERR_ARG, __FILE__, __LINE__,
                     "value '%s': reductions need a predefined datatype",
                     v->name);
  return pa__sf_reduce_begin(&v->op, v->data);
}

pa_status pa_dmesh_reduce_end(pa_dmesh *dm, pa_dmesh_value *v, MPI_Op op) {
  pa_status st = value_ok(dm, v, 0);
  if (st) return st;
  if (v->op.active != 2)
    return pa__error(PA_ERR_ARG, __FILE__, __LINE__,
                     "pa_dmesh_reduce_end without pa_dmesh_reduce_begin on '%s'",
                     v->name);
  return pa__sf_reduce_end(&v->op, v->data, v->type, v->ncomp, op);
}

pa_status pa__dmesh_value_drop(pa_dmesh *dm, pa_dmesh_value *val,
                               pa_status st) {
  if (!val) return st;
  pa_status s2 = pa_dmesh_value_remove(dm, val);
  return st ? st : s2;
}

pa_status pa__dmesh_reduce_fn(pa_dmesh *dm, pa_dmesh_value *v,
                              pa__combine_fn fn, void *ctx) {
  pa_status st = value_ok(dm, v, 1);
  if (st) return st;
  st = pa__sf_reduce_begin(&v->op, v->data);
  if (st) return st;
  return pa__sf_reduce_end_fn(&v->op, v->data, fn, ctx);
}

pa_status pa_dmesh_reduce(pa_dmesh *dm, pa_dmesh_value *v, MPI_Op op) {
  pa_status st = pa_dmesh_reduce_begin(dm, v);
  if (st) return st;
  return pa_dmesh_reduce_end(dm, v, op);
}

/* ---- synchronising the local mesh ---- */

typedef struct sync_item {
  int kind;
  void *a;
  size_t unit;
} sync_item;

pa_status pa_dmesh_sync_mesh(pa_dmesh *dm) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(dm, PA_ERR_ARG, "pa_dmesh_sync_mesh: NULL dmesh");
  pa__agree_reset();
  pa_mesh *m = dm->mesh;
  int d = dm->dim;
  sync_item arr[14 + 3 * PA_MESH_MAX_FIELDS];
  int na = 0;
  arr[na++] = (sync_item){PA_VERTEX, m->coord, sizeof(double) * d};
  arr[na++] = (sync_item){PA_VERTEX, m->vref, 4};
  arr[na++] = (sync_item){PA_VERTEX, m->vflag, 1};
  if (m->vgdim) {
    arr[na++] = (sync_item){PA_VERTEX, m->vgdim, 1};
    arr[na++] = (sync_item){PA_VERTEX, m->vgtag, 4};
  }
  if (m->met_ncomp)
    arr[na++] = (sync_item){PA_VERTEX, m->met, sizeof(double) * m->met_ncomp};
  for (int f = 0; f < m->nfield; f++)
    arr[na++] = (sync_item){PA_VERTEX, m->field[f].val,
                            sizeof(double) * m->field[f].ncomp};
  for (int f = 0; f < m->nefield; f++)
    arr[na++] = (sync_item){PA_ELEMENT, m->efield[f].val,
                            sizeof(double) * m->efield[f].ncomp};
  for (int f = 0; f < m->nbfield; f++)
    arr[na++] = (sync_item){PA_BOUNDARY, m->bfield[f].val,
                            sizeof(double) * m->bfield[f].ncomp};
  arr[na++] = (sync_item){PA_ELEMENT, m->eref, 4};
  arr[na++] = (sync_item){PA_ELEMENT, m->eflag, 1};
  arr[na++] = (sync_item){PA_BOUNDARY, m->bref, 4};
  arr[na++] = (sync_item){PA_BOUNDARY, m->bflag, 1};
  arr[na++] = (sync_item){PA_EDGE, m->edref, 4};
  arr[na++] = (sync_item){PA_EDGE, m->edflag, 1};
  for (int k = 0; k < na; k++) {
    pa__sfop op;
    /* buffers first, then agree, then communicate: no rank waits in vain */
    st = pa__sfop_init(&op, &dm->sf[arr[k].kind], arr[k].unit, TAG_SYNC);
    st = pa__agree(dm->comm, st);
    if (st) {
      pa__sfop_free(&op);
      goto cleanup;
    }
    st = pa__sf_bcast_begin(&op, arr[k].a);
    if (st == PA_SUCCESS) st = pa__sf_bcast_end(&op, arr[k].a);
    pa__sfop_free(&op);
    if (st) goto cleanup;
  }
cleanup:
  if (dm) st = pa__agree_end(dm->comm, st);
  return st;
}
