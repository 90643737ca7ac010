/*
 * dmesh.h -- the distributed mesh (struct pa_dmesh) and the internal services
 * the parallel adaptation builds on (record sets, the build pipeline, the
 * distributed dual graph).
 *
 * Distribution (see docs/design/DMESH.md):
 *  - every element is owned by exactly one rank;
 *  - a vertex is owned by the lowest rank owning an element that contains it;
 *  - a boundary entity (and a 3D feature edge) is owned by the lowest rank
 *    owning an element that contains all its vertices;
 *  - ghosts: with overlap K, layer k (1 <= k <= K) holds the elements that
 *    share a vertex with layers < k and are not among them; every vertex of a
 *    local element is local; boundary entities and edges contained in a
 *    local element are local.
 *
 * Local numbering of each kind: owned entities first, [0, nown), sorted by
 * global id; ghosts after, [nown, nloc), sorted by global id (elements: by
 * layer, then global id) -- until pa_dmesh_reorder permutes owned and ghosts
 * separately. Global ids are 64-bit, unique per kind, kept by redistribution.
 *
 * The local mesh `mesh` holds the nloc entities of every kind in this order,
 * its metric and user vertex fields included.
 */
#ifndef PA_DMESH_H
#define PA_DMESH_H

#include "dmesh/exchange.h"
#include "dmesh/util.h"
#include "mesh/mesh.h"

#define PA_DMESH_NKIND 4
#define PA_DMESH_VALUE_NAME_LEN 64

/* A user value attached to entities of one kind (see pa_dmesh_value_add). */
struct pa_dmesh_value {
  int id;             /* creation number: tag of its messages */
  pa_entity kind;
  char name[PA_DMESH_VALUE_NAME_LEN];
  MPI_Datatype type;  /* element type: a predefined one, or our dup */
  int duped;          /* type is a dup of a user type (freed with the value) */
  int ncomp;
  int double_type;    /* type is MPI_DOUBLE (gathered as a mesh field) */
  size_t unit;        /* bytes per entity: type size * ncomp */
  int32_t ref;        /* sub-class filter: entity reference, or -1 for all */
  pa_idx nslot;       /* entities holding the value (local) */
  pa_idx nslotown;    /* of which owned (the first ones) */
  pa_idx *ent;        /* ref >= 0: slot -> local entity; NULL otherwise */
  pa_idx *slot;       /* ref >= 0: local entity -> slot or -1 */
  unsigned char *data; /* nslot * unit */
  pa__sf sf;          /* ref >= 0: restricted sf (kind sf otherwise) */
  pa__sfop op;        /* buffers of the in-flight halo/reduce */
  int ready;          /* sf/op built for the current distribution */
};

struct pa_dmesh {
  MPI_Comm comm;      /* private duplicate of the user's communicator */
  int rank, size;
  int dim;
  int overlap;
  pa_mesh *mesh;      /* local mesh: owned + ghost entities of every kind */

  pa_idx nown[PA_DMESH_NKIND];
  pa_idx nloc[PA_DMESH_NKIND];
  pa_gid nglob[PA_DMESH_NKIND];
  pa_gid *gid[PA_DMESH_NKIND];   /* nloc */
  int *owner[PA_DMESH_NKIND];    /* nloc */
  uint8_t *layer;          /* elements: 0 owned, k ghost of layer k */
  pa__sf sf[PA_DMESH_NKIND];     /* owned -> ghost copies */

  int nneigh;              /* neighbour ranks (either side of any sf) */
  int *neigh;

  int nvalue, capvalue, nextid;
  pa_dmesh_value **value;

  /* Derived, built on demand (NULL when not built). */
  /* 1 if the entity has copies on other ranks */
  pa_idx *shared[PA_DMESH_NKIND];
  pa_idx *iterlist[PA_DMESH_NKIND][2]; /* interior / frontier owned entities */
  pa_idx niter[PA_DMESH_NKIND][2];
  pa_idx *adja;            /* (dim+1) * nelem local face neighbours or -1 */
  pa_idx *vstart, *velem;  /* vertex -> local elements (CSR) */
  pa_idx *bface;           /* boundary entity -> 2 elements (-1 if none) */
};

/* Bytes of the values attached to one entity of a kind when every value
 * of that kind holds it (the most its payload takes). */
static inline size_t pa__kind_unit(const pa_dmesh *dm, int kind) {
  size_t u = 0;
  for (int k = 0; k < dm->nvalue; k++)
    if ((int)dm->value[k]->kind == kind) u += dm->value[k]->unit;
  return u;
}

/* Number of vertices of one entity of a kind (vertex: 0). */
static inline int pa__kind_nv(int dim, int kind) {
  return kind == PA_VERTEX ? 0
         : kind == PA_ELEMENT ? dim + 1
         : kind == PA_BOUNDARY ? dim
                               : 2;
}

/* ---- record sets: entities in transit between ranks ---- */

/* Records of one kind: global id, vertex global ids, reference, flag, an int
 * (destination rank or owner), doubles (vertices: coordinates, metric,
 * fields) and an opaque payload (the bytes of the user values). */
typedef struct pa__recs {
  int kind, nv, ndbl;
  size_t n, cap;
  pa_gid *gid;
  pa_gid *vgid;         /* nv * cap */
  int32_t *ref;
  uint8_t *flag;
  int *aux;
  double *dbl;          /* ndbl * cap */
  size_t *poff;         /* cap + 1 payload offsets (NULL: no payloads) */
  unsigned char *pay;
  size_t paycap;
} pa__recs;

void pa__recs_init(pa__recs *r, int kind, int nv, int ndbl);
void pa__recs_free(pa__recs *r);
/* Grow r for one more record with a payload of paylen bytes (the slow path
 * of pa__recs_add). */
pa_status pa__recs_room(pa__recs *r, size_t paylen);
/* Append one record (vgid nv ids, dbl ndbl doubles, pay of paylen bytes).
 * Inline: it runs once per entity in every transfer and rebuild, and the
 * arrays are usually reserved already (plain loops, not memcpy: a few items
 * each, a library call per array cost more than the copy). */
static inline pa_status pa__recs_add(pa__recs *r, pa_gid gid,
                                     const pa_gid *vgid, int32_t ref,
                                     uint8_t flag, int aux, const double *dbl,
                                     const void *pay, size_t paylen) {
  size_t i = r->n;
  if (i >= r->cap || (paylen && !r->poff) ||
      (r->poff && r->poff[i] + paylen > r->paycap)) {
    pa_status st = pa__recs_room(r, paylen);
    if (st) return st;
  }
  r->gid[i] = gid;
  for (int k = 0; k < r->nv; k++) r->vgid[(size_t)r->nv * i + k] = vgid[k];
  r->ref[i] = ref;
  r->flag[i] = flag;
  r->aux[i] = aux;
  for (int k = 0; k < r->ndbl; k++) r->dbl[(size_t)r->ndbl * i + k] = dbl[k];
  if (r->poff) {
    size_t off = r->poff[i];
    for (size_t k = 0; k < paylen; k++)
      r->pay[off + k] = ((const unsigned char *)pay)[k];
    r->poff[i + 1] = off + paylen;
  }
  r->n = i + 1;
  return PA_SUCCESS;
}
/* Append the records [k0, k0 + n) of in (same layout) to r, array by
 * array. */
pa_status pa__recs_append(pa__recs *r, const pa__recs *in, size_t k0,
                          size_t n);
/* Bytes of record i in transit (the traffic counted as bytes moved). */
size_t pa__recs_wire(const pa__recs *r, size_t i);
/* Collective: send record i to rank dest[i] (the records' aux if dest NULL);
 * *out receives (initialised by the call) the records sent to this rank,
 * sorted by gid. */
pa_status pa__recs_migrate(MPI_Comm comm, const pa__recs *in, const int *dest,
                           pa__recs *out);

/* Collective: as pa__recs_migrate, but frees *in as soon as it is packed
 * (before the exchange), to lower the peak memory. */
pa_status pa__recs_migrate_free(MPI_Comm comm, pa__recs *in, const int *dest,
                                pa__recs *out);

/* Bulk transfer of records: a block of n records stored array by array
 * (format in recs.c), filled and read in place. */
typedef struct pa__recblock {
  size_t n, paybytes, bytes; /* records, payload bytes, block bytes */
  pa_gid *gid, *vgid;
  double *dbl;
  int32_t *ref, *aux;
  uint32_t *paylen;          /* NULL if paybytes == 0 */
  uint8_t *flag;
  unsigned char *pay;
} pa__recblock;
/* Bytes of a block (a multiple of 8: consecutive blocks stay aligned). */
size_t pa__recblock_bytes(int nv, int ndbl, size_t n, size_t paybytes);
/* Write the header of a block at p (8-byte aligned) and map its arrays. */
void pa__recblock_init(unsigned char *p, int nv, int ndbl, size_t n,
                       size_t paybytes, pa__recblock *b);
/* Map the arrays of the block at p. */
void pa__recblock_map(const unsigned char *p, int nv, int ndbl,
                      pa__recblock *b);
/* Payload bytes of records idx[0..n) of r (idx NULL: the first n). */
size_t pa__recs_paybytes(const pa__recs *r, const pa_idx *idx, size_t n);
/* Write records idx[0..n) of r (idx NULL: the first n) as one block at p
 * (pa__recblock_bytes(r->nv, r->ndbl, n, pa__recs_paybytes(...)) bytes);
 * returns the bytes written. */
size_t pa__recs_put(const pa__recs *r, const pa_idx *idx, size_t n,
                    unsigned char *p);
/* Append the block at p + *pos to r and advance *pos. */
pa_status pa__recs_get(pa__recs *r, const unsigned char *p, size_t *pos);
/* Reserve room for n records and paybytes payload bytes in total. */
pa_status pa__recs_reserve(pa__recs *r, size_t n, size_t paybytes);
/* Map the pages of records [i0, i0 + n) (reserved) in one system call
 * per array, where the kernel supports it: for records about to be
 * written in bulk into fresh memory. */
void pa__recs_prefault(pa__recs *r, size_t i0, size_t n);
/* Sort records by gid (stable; nothing done if already sorted). */
pa_status pa__recs_sort(pa__recs *r);

/* Description of the values and fields carried by a build: the metric and
 * vertex fields, and the element (c = 0) and boundary (c = 1) fields with
 * their transfer modes. */
typedef struct pa__layout {
  int dim;
  int met_ncomp;
  int geo; /* 1: the vertices' model entities (a classified mesh) */
  int nfield;
  char fieldname[PA_MESH_MAX_FIELDS][PA_MESH_FIELD_NAME_LEN];
  int fieldncomp[PA_MESH_MAX_FIELDS];
  int ncfield[2];
  char cfieldname[2][PA_MESH_MAX_FIELDS][PA_MESH_FIELD_NAME_LEN];
  int cfieldncomp[2][PA_MESH_MAX_FIELDS];
  int cfieldmode[2][PA_MESH_MAX_FIELDS];
} pa__layout;
/* A vertex's model entity in one double of its record: dim * 2^32 + tag
 * (as unsigned 32 bits), exact below 2^53. */
static inline double pa__entity_pack(int dim, int32_t tag) {
  return (double)dim * 4294967296.0 + (double)(uint32_t)tag;
}
static inline void pa__entity_unpack(double x, uint8_t *dim, int32_t *tag) {
  double d = floor(x / 4294967296.0);
  *dim = (uint8_t)d;
  *tag = (int32_t)(uint32_t)(x - d * 4294967296.0);
}
/* Doubles per vertex record: dim + metric + entity + fields. */
int pa__layout_ndbl(const pa__layout *l);
/* Doubles per record of a kind: the vertex doubles, the components of the
 * element or of the boundary fields, 0 for edges. */
int pa__layout_kind_ndbl(const pa__layout *l, int kind);
/* The layout of mesh m's metric and fields (dim from m). */
void pa__mesh_layout(const pa_mesh *m, pa__layout *lay);
/* Give m (without element nor boundary fields) those of lay, named and
 * moded, with room for m's capacities (values not set). */
pa_status pa__layout_cell_fields(const pa__layout *l, pa_mesh *m);
/* The doubles of the record of vertex v of m: coordinates, metric, its
 * model entity (a classified m: dim * 2^32 + tag, exact), then the first
 * nfield fields (in that order, the layout's); returns the count. */
/* Inline, plain loops: a few doubles each, once per vertex of every
 * transfer and rebuild (a call per vertex cost more than the copy). */
static inline int pa__vertex_doubles(const pa_mesh *m, pa_idx v, int nfield,
                                     double *out) {
  int d = m->dim, nm = m->met_ncomp, n = d + nm;
  const double *c = m->coord + (size_t)d * v;
  for (int k = 0; k < d; k++) out[k] = c[k];
  if (nm) {
    const double *t = m->met + (size_t)nm * v;
    for (int k = 0; k < nm; k++) out[d + k] = t[k];
  }
  if (m->vgdim) out[n++] = pa__entity_pack(m->vgdim[v], m->vgtag[v]);
  for (int f = 0; f < nfield; f++) {
    int nc = m->field[f].ncomp;
    const double *x = m->field[f].val + (size_t)nc * v;
    for (int k = 0; k < nc; k++) out[n++] = x[k];
  }
  return n;
}
/* The inverse for all of m's fields: vertex v of m takes the doubles of a
 * record (coordinates, metric, entity when m is classified, fields). */
static inline void pa__vertex_set_doubles(pa_mesh *m, pa_idx v,
                                          const double *in) {
  int d = m->dim, nm = m->met_ncomp;
  double *c = m->coord + (size_t)d * v;
  for (int k = 0; k < d; k++) c[k] = in[k];
  in += d;
  if (nm) {
    double *t = m->met + (size_t)nm * v;
    for (int k = 0; k < nm; k++) t[k] = in[k];
    in += nm;
  }
  if (m->vgdim) pa__entity_unpack(*in++, &m->vgdim[v], &m->vgtag[v]);
  for (int f = 0; f < m->nfield; f++) {
    int nc = m->field[f].ncomp;
    double *x = m->field[f].val + (size_t)nc * v;
    for (int k = 0; k < nc; k++) x[k] = in[k];
    in += nc;
  }
}
/* The doubles of the record of entity e of a kind of m (vertices: as
 * pa__vertex_doubles with all fields; elements and boundary entities:
 * their fields' values in field order; edges: none); returns the count.
 * pa__entity_set_doubles is the inverse. */
int pa__entity_doubles(const pa_mesh *m, int kind, pa_idx e, double *out);
void pa__entity_set_doubles(pa_mesh *m, int kind, pa_idx e, const double *in);

/* Collective: remove value val (if not NULL) at the end of a collective
 * function; returns st, or the removal's status if st is PA_SUCCESS. */
pa_status pa__dmesh_value_drop(pa_dmesh *dm, pa_dmesh_value *val,
                               pa_status st);

/* Collective: pa_dmesh_reduce with a combining function (see
 * pa__sf_reduce_end_fn); v may have any datatype. */
pa_status pa__dmesh_reduce_fn(pa_dmesh *dm, pa_dmesh_value *v,
                              pa__combine_fn fn, void *ctx);

/* Collective: build a distributed mesh from records. elems: the owned
 * elements, aux = destination rank; verts, bdry, edges: every vertex,
 * boundary entity and edge exactly once over the ranks, anywhere. Records
 * carry value payloads laid out for the values of dm (if dm has values).
 * Fills dm (created with comm, dim set) -- its previous distribution must
 * have been released. Fails with PA_ERR_MESH on inconsistent input (unknown
 * vertex, entity in no element, duplicate ids). The record sets are freed. */
pa_status pa__dmesh_build(pa_dmesh *dm, const pa__layout *lay, int overlap,
                          pa__recs *elems, pa__recs *verts, pa__recs *bdry,
                          pa__recs *edges);
/* As pa__dmesh_build, with private vertices: records (sorted by gid, on
 * the rank that gives them) of vertices that only elements owned by this
 * rank after the migration reference, owned here. With overlap 0 they skip
 * the directory (no migration there, no touch list, no fetch back): the
 * rebuild after a remeshing, whose new vertices are nearly all private.
 * With overlap > 0 (ghost elements elsewhere reference them) they are
 * ordinary vertex records. A private vertex in no owned element, or
 * referenced by another rank's elements, is an error. priv is freed. */
pa_status pa__dmesh_build_priv(pa_dmesh *dm, const pa__layout *lay,
                               int overlap, pa__recs *elems, pa__recs *verts,
                               pa__recs *bdry, pa__recs *edges,
                               pa__recs *priv);

/* Local: dm->neigh, dm->nneigh: the ranks at the other end of any star
 * forest, in increasing order (dm->neigh must be free). */
pa_status pa__dmesh_neighbours(pa_dmesh *dm);

/* Collective: fail with PA_ERR_FORMAT naming the first global id given
 * twice over the ranks (what: "element", ...). */
pa_status pa__gids_unique(MPI_Comm comm, size_t n, const pa_gid *gid,
                          const char *what);

/* Create an empty pa_dmesh on a duplicate of comm. Collective. */
pa_status pa__dmesh_create(MPI_Comm comm, int dim, pa_dmesh **dm);
/* Free the distribution (mesh, ids, sfs, derived data), keep the values'
 * definitions (their data is freed). */
void pa__dmesh_clear(pa_dmesh *dm);
/* Free derived structures (adjacency, iterator lists). */
void pa__dmesh_invalidate(pa_dmesh *dm);
/* Layout of the local mesh's metric and fields. */
void pa__dmesh_layout(pa_dmesh *dm, pa__layout *lay);
/* Local: add the definition of a value of a predefined MPI type to a
 * pa_dmesh without distribution (no data: the next build allocates it and
 * fills it from the record payloads). Fails with PA_ERR_FORMAT on a bad or
 * duplicate description (it comes from a file). */
pa_status pa__value_define(pa_dmesh *dm, int kind, const char *name,
                           MPI_Datatype type, int ncomp, int32_t ref);
/* Local: (re)compute the value's slots from the entity references and
 * allocate its data (zeroed) for the current distribution. */
pa_status pa__value_alloc(pa_dmesh *dm, pa_dmesh_value *v);
/* Local: build the value's restricted sf and operation buffers (after the
 * kind's sf exists). */
pa_status pa__value_setup(pa_dmesh *dm, pa_dmesh_value *v);
/* Reference of local entity e of a kind (vertices: vertex reference). */
int32_t pa__dmesh_ref(const pa_dmesh *dm, int kind, pa_idx e);

/* Collective: the distributed dual graph of n elements (vertex gids in
 * vgid, dim+1 per element; lv, if not NULL, the same vertices as local
 * numbers in [0, nv), which saves numbering them here through a hash map):
 * for element i, its face neighbours are
 * adj[xadj[i] .. xadj[i+1]-1], given as global graph vertex numbers
 * (offset of the holding rank + its local index; offsets from an exclusive
 * scan of n), with the holding rank in adjrank. Fails with PA_ERR_MESH if a
 * face is shared by more than two elements. */
pa_status pa__dual_graph(MPI_Comm comm, int dim, pa_idx n, const pa_gid *vgid,
                         const pa_idx *lv, pa_idx nv, pa_idx **xadj,
                         pa_gid **adj, int **adjrank, pa_gid *offset);

/* Collective: every face of the n elements lv (dim+1 local vertex numbers in
 * [0, nv) each; vglob the global id of each local vertex, egid of each
 * element) is in at most one other of the elements given on all the ranks,
 * on the other side of it.
 * Faces are matched locally, and the unmatched ones at the rank hash % size.
 * The memory it takes: 8 bytes per local face and the unmatched faces.
 * Fails with PA_ERR_MESH, naming the face, on every rank. */
pa_status pa__faces_conform(MPI_Comm comm, int dim, pa_idx n,
                            const pa_idx *lv, pa_idx nv, const pa_gid *vglob,
                            const pa_gid *egid);

/* Local: match the faces of n elements (dim+1 local vertex numbers in
 * [0, nv) each in lv): mate[e*(dim+1)+i] = f*(dim+1)+j if face i of element
 * e (opposite its vertex i) is face j of element f, -1 if no other element
 * has it. Linear time (faces bucketed by their smallest vertex). Fails with
 * PA_ERR_MESH if a face is in three elements or more (vgid, if not NULL,
 * names its vertices by global id). */
pa_status pa__match_faces(int dim, pa_idx n, const pa_idx *lv, pa_idx nv,
                          const pa_gid *vgid, pa_gid *mate);

/* Collective: new owner rank of each of the n owned elements, by PT-Scotch on
 * the dual graph (weights per element or NULL), remapped so that ranks keep
 * most of their elements. */
pa_status pa__dmesh_partition(MPI_Comm comm, int dim, pa_idx n,
                              const pa_gid *vgid, const double *weights,
                              int *part);

/* ---- output transactions (dio.c) ---- */

/* Collective end of one output transaction per rank (pa_output_end without
 * its reset of the agreement): agrees on st with pa__agree_end, so a
 * collective routine calls it at its cleanup label; commits everywhere if
 * every rank succeeded, aborts everywhere otherwise. */
pa_status pa__output_end(MPI_Comm comm, pa_output *tx, pa_status st);

/* The part of pa_dmesh_check a result of the adaptation loop with the
 * built-in remesher gets (check.c): counts, ownership ranges and the
 * orientation of every owned element. The ghosts, the ownership and the
 * conformity across ranks, which pa_dmesh_check adds, are invariants of
 * the rebuild (tests/mpi check them after every adaptation). Collective. */
pa_status pa__dmesh_check_output(pa_dmesh *dm);

/* ---- statistics (dstats.c) ---- */

/* pa_dmesh_stats measured in the metric met (local vertex values of nc
 * components) instead of the mesh's own, with the validity check given
 * (PA_STATS_CHECK_*: none, stats->valid is then 1; pa_dmesh_check's; or
 * pa__dmesh_check_output's). Collective. */
pa_status pa__dmesh_stats_met(pa_dmesh *dm, int nc, const double *met,
                              int check, pa_stats *stats);

/* ---- the records a rebuild starts from (incremental.c) ---- */

/* Records of the owned entities of dm (with value payloads; the elements'
 * aux dest[e], or this rank with dest NULL). */
pa_status pa__dmesh_owned_recs(pa_dmesh *dm, const int *dest, pa__recs *elems,
                               pa__recs *verts, pa__recs *bdry,
                               pa__recs *edges);

/* Local: the bytes of the values of local entity e of a kind (those whose
 * reference filter it passes, in the order of dm->value) into buf; returns
 * their count (the payload of its record). */
size_t pa__entity_payload(const pa_dmesh *dm, int kind, pa_idx e,
                          unsigned char *buf);

/* Local: records of the owned entities of dm (with value payloads, aux =
 * this rank) whose keep[kind][i] is set (keep NULL, or keep[kind] NULL: all
 * of that kind), written straight from the local arrays into record sets
 * reserved for extra[kind] more records (extra NULL: none) and their
 * largest payloads; the owned vertices with vpriv[i] (vpriv NULL: none) go
 * to P (the private vertices of pa__dmesh_build_priv), also reserved for
 * extra[PA_VERTEX] more. Initialises the five record sets (freed on
 * failure). */
pa_status pa__dmesh_kept_recs(pa_dmesh *dm,
                              const uint8_t *const keep[PA_DMESH_NKIND],
                              const size_t extra[PA_DMESH_NKIND], pa__recs *E,
                              pa__recs *V, pa__recs *B, pa__recs *D,
                              const uint8_t *vpriv, pa__recs *P);

/* ---- in-place change (splice.c) ---- */

/* Local: 1 if dm has the local numbering a build leaves (each kind owned
 * first, then ghosts, each part in increasing global id order; no ghost
 * element layer), which pa__dmesh_splice needs. */
int pa__dmesh_canonical(const pa_dmesh *dm);

/* Collective: change dm in place: the local entities with keep[kind][i]
 * (over the nloc local ones) stay, the others go, and the entities of part
 * (a distributed mesh on the same ranks, as pa__dmesh_build leaves it, with
 * the values of dm: pa__dmesh_values_like) join, but for the part's copies
 * of vertices dm keeps. Needs overlap 0 and pa__dmesh_canonical on both.
 * The caller guarantees what splice.c states; the result is what
 * pa__dmesh_build gives from the records of the kept entities and the
 * part's. part is left as it was. */
pa_status pa__dmesh_splice(pa_dmesh *dm,
                           const uint8_t *const keep[PA_DMESH_NKIND],
                           const pa_dmesh *part);
/* Local: define in dm (no distribution yet) the values of like (same
 * names, kinds, types, components, filters; types borrowed: like must
 * outlive dm). */
pa_status pa__dmesh_values_like(pa_dmesh *dm, const pa_dmesh *like);

#endif /* PA_DMESH_H */
