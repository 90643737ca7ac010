/*
 * padapt.h -- the only public header of padapt, a library for parallel mesh
 * adaptation of simplex meshes (2D triangles, 3D tetrahedra) to a metric field.
 *
 * Conventions used throughout:
 *  - Names: pa_<object>_<verb> for functions, pa_<name> for types, PA_ for
 *    constants; everything named so is declared here and nowhere else.
 *  - Every function that can fail returns a pa_status; results come back through
 *    out-pointers. On failure, pa_last_error() gives a one-line message naming
 *    the file and line (or the entity) at fault.
 *  - Each function's comment says what it does, what each parameter is
 *    ("out": the function writes it; "in/out": reads and writes it; the
 *    others are read only), whether it is collective and what it returns.
 *    A pa_status return is PA_SUCCESS or the error named; PA_ERR_ARG for a
 *    NULL pointer where one is needed goes without saying.
 *  - Indices are 0-based. Local indices are pa_idx (32-bit), global ids pa_gid
 *    (64-bit).
 *  - "Collective" means every rank of the communicator must call the function.
 *    Every function says whether it is; "Not collective" ones are local.
 *  - Test hooks and expert knobs are apart, in the last section.
 *  - Metric storage per vertex: ncomp = 1 is an isotropic size h (the metric is
 *    I/h^2); ncomp = 3 (2D) or 6 (3D) is a symmetric positive definite tensor
 *    stored as m11 m12 m22 [m13 m23 m33] (Medit's order).
 *  - The library never calls exit(), abort() or MPI_Abort().
 */
#ifndef PADAPT_H
#define PADAPT_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include <mpi.h>

#ifdef __cplusplus
extern "C" {
#endif

#define PADAPT_VERSION_MAJOR 0
#define PADAPT_VERSION_MINOR 1
#define PADAPT_VERSION_PATCH 0

/** Returns the library's version, "MAJOR.MINOR.PATCH" (the macros above, as
 *  the library was built: compare both to detect a header/library
 *  mismatch); a static string. Not collective. */
const char *pa_version(void);

/** Local index (vertex, element, ...) on one process. */
typedef int32_t pa_idx;
/** Global id of an entity across all processes. */
typedef int64_t pa_gid;

/* ------------------------------------------------------------------------ */
/* Status, errors, memory                                                   */
/* ------------------------------------------------------------------------ */

typedef enum pa_status {
  PA_SUCCESS = 0,
  PA_ERR_ARG,         /**< the caller passed an invalid argument */
  PA_ERR_MEMORY,      /**< an allocation failed */
  PA_ERR_IO,          /**< a file could not be opened, read or written */
  PA_ERR_FORMAT,      /**< a file is malformed (message names file:line) */
  PA_ERR_MESH,        /**< the mesh is invalid (inverted, non-conforming...) */
  PA_ERR_METRIC,      /**< a metric is not finite or not positive definite */
  PA_ERR_MPI,         /**< an MPI call failed (the message names it; MPI
                           returns errors only on a communicator whose
                           error handler is MPI_ERRORS_RETURN) or ranks
                           disagree */
  PA_ERR_PARTITION,   /**< the graph partitioner failed */
  PA_ERR_UNSUPPORTED, /**< a feature or file variant that is not supported */
  PA_ERR_INTERNAL     /**< an internal invariant was violated (a bug) */
} pa_status;

/** Short constant name of status ("success", "format error", ...); a
 *  static string, "unknown status" for a value out of the enum. Not
 *  collective. */
const char *pa_status_string(pa_status status);

/** Message of the last error raised in the calling thread ("" if none),
 *  valid until the thread's next error. Not collective. */
const char *pa_last_error(void);

/** Clear the calling thread's last error message. Not collective. */
void pa_clear_error(void);

/**
 * Set the calling thread's last error message to fmt and its arguments
 * (printf-style) and return status, for code whose own failures travel
 * through padapt: a plug-in remesher's callback (pa_remesher), or the
 * status a caller gives to pa_output_end, whose agreement gives every rank
 * the message of the lowest failing rank. Not collective. Returns status.
 */
pa_status pa_set_error(pa_status status, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

/** Returns the bytes padapt has allocated in this process (every thread)
 *  and not freed. Not collective. */
size_t pa_memory_current(void);
/** Returns the peak of pa_memory_current() since the start or the last
 *  pa_memory_reset_peak. Not collective. */
size_t pa_memory_peak(void);
/** Reset the peak to the current value. Not collective. */
void pa_memory_reset_peak(void);
/** Bound the bytes padapt may hold in this process (pa_memory_current) to
 *  bytes (0: no bound, the default): an allocation that would pass it
 *  fails, and the function that asked returns PA_ERR_MEMORY with a message
 *  saying that the bound is reached. Memory of the libraries padapt calls
 *  (MPI, PT-Scotch) and of the C library is not counted. pa_remesh and
 *  pa_dmesh_adapt lower the bound for their call to their options' mem_mb.
 *  Process-wide, not collective. Returns the previous bound. */
size_t pa_memory_set_limit(size_t bytes);
/** Returns the bound set by pa_memory_set_limit (0: none). Not
 *  collective. */
size_t pa_memory_limit(void);
/** Returns the peak resident set size of the process in bytes (from the
 *  OS), 0 if unknown. Not collective. */
size_t pa_peak_rss(void);

/** Set the verbosity of the messages the library prints on stderr (level:
 *  -1 errors and warnings only, 0 the default, 1-10 more detail).
 *  Process-wide, not collective. */
void pa_set_verbosity(int level);
/** Returns the verbosity set by pa_set_verbosity (default 0). Not
 *  collective. */
int pa_verbosity(void);

/** Returns the wall-clock time in seconds from a fixed origin (monotonic).
 *  Not collective. */
double pa_wtime(void);

/* ------------------------------------------------------------------------ */
/* Sequential simplex mesh                                                  */
/* ------------------------------------------------------------------------ */

/**
 * A simplex mesh of runtime dimension dim (2 or 3):
 *  - vertices (dim coordinates, a reference, flags),
 *  - elements: triangles in 2D, tetrahedra in 3D (dim+1 vertices),
 *  - boundary entities: edges in 2D, triangles in 3D (dim vertices),
 *  - in 3D only, feature edges (2 vertices): Medit "Edges" (ridges, required
 *    edges, interior curves). In 2D, Medit Edges are the boundary entities.
 * Every entity has an integer reference and a flag byte (PA_FLAG_*).
 * A mesh may carry a metric and user fields on its vertices, elements and
 * boundary entities.
 */
typedef struct pa_mesh pa_mesh;

/** Entity kinds: of a mesh's fields (on vertices, elements or boundary
 *  entities), of a distributed mesh's entities and values. */
typedef enum pa_entity {
  PA_VERTEX = 0,
  PA_ELEMENT = 1,
  PA_BOUNDARY = 2, /**< boundary entities: edges (2D), triangles (3D) */
  PA_EDGE = 3      /**< feature edges (3D only) */
} pa_entity;

/** Entity flags (bit mask). */
enum {
  PA_FLAG_CORNER = 1,   /**< vertex: corner, never removed nor moved */
  PA_FLAG_RIDGE = 2,    /**< edge (or vertex on a ridge): sharp feature */
  PA_FLAG_REQUIRED = 4, /**< entity frozen: never modified by the remesher */
  PA_FLAG_USER = 8      /**< free for callers (e.g. "tagged for remeshing") */
};

/** Create an empty mesh of dimension dim (2 or 3) into *mesh (out; free it
 *  with pa_mesh_destroy). Not collective. Returns PA_ERR_ARG for another
 *  dim, PA_ERR_MEMORY. */
pa_status pa_mesh_create(int dim, pa_mesh **mesh);
/** Destroy mesh (in/out; NULL allowed). Not collective. */
void pa_mesh_destroy(pa_mesh *mesh);
/** A deep copy of src, its metric, fields and physical names included, into
 *  *dst (out). Not collective. Returns PA_ERR_MEMORY. */
pa_status pa_mesh_copy(const pa_mesh *src, pa_mesh **dst);

/** The counts of mesh: returns its dimension (2 or 3), its vertices,
 *  elements, boundary entities (edges in 2D, triangles in 3D) and feature
 *  edges (3D only; 0 in 2D). Not collective. */
int pa_mesh_dim(const pa_mesh *mesh);
pa_idx pa_mesh_nvert(const pa_mesh *mesh);
pa_idx pa_mesh_nelem(const pa_mesh *mesh);
pa_idx pa_mesh_nbdry(const pa_mesh *mesh);
pa_idx pa_mesh_nedge(const pa_mesh *mesh);

/** Reserve room in mesh (in/out) so that adding up to these counts of
 *  entities (>= 0) does not reallocate. Not collective. Returns PA_ERR_ARG
 *  for a negative count, PA_ERR_MEMORY. */
pa_status pa_mesh_reserve(pa_mesh *mesh, pa_idx nvert, pa_idx nelem,
                          pa_idx nbdry, pa_idx nedge);
/**
 * Append an entity to mesh (in/out): a vertex of dim coordinates x, an
 * element of dim+1 vertex indices v, a boundary entity of dim, a feature
 * edge (3D only; in 2D the boundary edges are boundary entities) of 2; ref
 * is its reference, its flags are 0. *index (out, may be NULL) receives its
 * index. The indices are not checked here (pa_mesh_check does). Drops the
 * cached adjacency, balls and boundary lookup. Not collective. Returns
 * PA_ERR_ARG beyond INT32_MAX entities or for a feature edge in 2D,
 * PA_ERR_MEMORY.
 */
pa_status pa_mesh_add_vertex(pa_mesh *mesh, const double *x, int32_t ref,
                             pa_idx *index);
pa_status pa_mesh_add_elem(pa_mesh *mesh, const pa_idx *v, int32_t ref,
                           pa_idx *index);
pa_status pa_mesh_add_bdry(pa_mesh *mesh, const pa_idx *v, int32_t ref,
                           pa_idx *index);
pa_status pa_mesh_add_edge(pa_mesh *mesh, const pa_idx *v, int32_t ref,
                           pa_idx *index);

/**
 * Set the entity counts of mesh (in/out) at once, to fill the entities
 * through the raw accessors below (e.g. from arrays): the entities added
 * are zeroed (coordinates, vertex indices, references, flags, metric and
 * fields), a smaller count drops the last entities. Drops the cached
 * adjacency, balls and boundary lookup. The caller makes the filled mesh
 * valid (see pa_mesh_check). Not collective. Returns PA_ERR_ARG for a
 * negative count or feature edges in 2D, PA_ERR_MEMORY.
 */
pa_status pa_mesh_resize(pa_mesh *mesh, pa_idx nvert, pa_idx nelem,
                         pa_idx nbdry, pa_idx nedge);

/**
 * Raw array access (structure of arrays): returns the array of mesh (the
 * caller may read and write it; after a change of vertex indices call
 * pa_mesh_invalidate), valid until the next call that adds entities.
 * Layouts: coords[dim*i + k], elems[(dim+1)*e + k], bdry[dim*b + k],
 * edges[2*e + k]; refs and flags one per entity. Not collective.
 */
double *pa_mesh_coords(pa_mesh *mesh);
pa_idx *pa_mesh_elems(pa_mesh *mesh);
pa_idx *pa_mesh_bdrys(pa_mesh *mesh);
pa_idx *pa_mesh_edges(pa_mesh *mesh);
int32_t *pa_mesh_vert_refs(pa_mesh *mesh);
int32_t *pa_mesh_elem_refs(pa_mesh *mesh);
int32_t *pa_mesh_bdry_refs(pa_mesh *mesh);
int32_t *pa_mesh_edge_refs(pa_mesh *mesh);
uint8_t *pa_mesh_vert_flags(pa_mesh *mesh);
uint8_t *pa_mesh_elem_flags(pa_mesh *mesh);
uint8_t *pa_mesh_bdry_flags(pa_mesh *mesh);
uint8_t *pa_mesh_edge_flags(pa_mesh *mesh);

/**
 * Attach a metric to mesh (in/out): values holds ncomp = 1 (size h > 0) or
 * 3 (2D) / 6 (3D) SPD tensor components per vertex, copied; ncomp = 0
 * removes the metric (values unused). Not collective. Returns PA_ERR_ARG
 * for another ncomp, PA_ERR_METRIC naming the first vertex whose value is
 * not finite or not positive definite (the mesh unchanged), PA_ERR_MEMORY.
 */
pa_status pa_mesh_set_metric(pa_mesh *mesh, int ncomp, const double *values);
/** Returns the number of metric components per vertex of mesh (0 when it
 *  has no metric). Not collective. */
int pa_mesh_metric_ncomp(const pa_mesh *mesh);
/** Returns the metric array of mesh (nvert * ncomp values, which the
 *  caller may change: pa_mesh_check then checks them), NULL when there is
 *  none. Not collective. */
double *pa_mesh_metric(pa_mesh *mesh);

/** A vertex field whose name starts with this prefix and that has 1 (size)
 *  or 3/6 (tensor) components holds a metric: the remeshers interpolate it
 *  at new vertices as they interpolate the metric, not component by
 *  component. pa_remesh and pa_dmesh_adapt carry the caller's metric so
 *  (as "metric:user", removed before they return) to measure the result
 *  against it. */
#define PA_FIELD_METRIC_PREFIX "metric:"

/** Attach to mesh (in/out) a user vertex field called name (its first 63
 *  bytes), of ncomp > 0 components per vertex: values (nvert * ncomp) are
 *  copied; it becomes field pa_mesh_nfield - 1. Not collective. Returns
 *  PA_ERR_ARG for ncomp <= 0, a value that is not finite or a mesh holding
 *  16 fields already, PA_ERR_MEMORY. */
pa_status pa_mesh_add_field(pa_mesh *mesh, const char *name, int ncomp,
                            const double *values);
/** Remove field k of mesh (in/out; the later fields move down by one). Not
 *  collective. Returns PA_ERR_ARG for k out of [0, pa_mesh_nfield). */
pa_status pa_mesh_remove_field(pa_mesh *mesh, int k);
/** Returns the number of user vertex fields of mesh. Not collective. */
int pa_mesh_nfield(const pa_mesh *mesh);
/** Field k of mesh: *name, *ncomp and *values (out, each may be NULL; the
 *  values, nvert * ncomp, may be changed in place), valid until the fields
 *  or the vertices change. Not collective. Returns PA_ERR_ARG for k out of
 *  [0, pa_mesh_nfield). */
pa_status pa_mesh_field(pa_mesh *mesh, int k, const char **name, int *ncomp,
                        double **values);

/*
 * Fields on elements and boundary entities. Besides its vertex fields a
 * mesh carries up to 16 element fields (ncomp values per triangle or
 * tetrahedron: a finite-volume unknown, a density, a material id) and up to
 * 16 boundary fields (per boundary entity: boundary-condition values). A
 * field's kind follows from ncomp as in Medit files: 1 a scalar, dim a
 * vector, 3 (2D) or 6 (3D) a symmetric tensor m11 m12 m22 [m13 m23 m33];
 * another count is ncomp scalars. The vertex functions above are the case
 * at = PA_VERTEX of those below. pa_mesh_copy copies every field; entities
 * added by pa_mesh_resize or pa_mesh_add_* get zeros; pa_remesh carries
 * every field onto the new mesh by its transfer mode (user guide:
 * docs/guide/fields.md).
 */

/** How pa_remesh carries a field onto the new entities. */
typedef enum pa_transfer {
  /** The default of the field's entities: LINEAR for vertex fields,
   *  CONSERVATIVE for element fields, NEAREST for boundary fields. */
  PA_TRANSFER_DEFAULT = 0,
  /** Vertex fields (their only mode): linear interpolation at new
   *  vertices; kept vertices keep their values. */
  PA_TRANSFER_LINEAR = 1,
  /** Element fields: each new element takes the mean of the old
   *  piecewise-constant field over the part of it the old elements cover
   *  (old and new elements intersected). The integral is kept to round-off
   *  where the boundary does not move, a constant stays exactly constant,
   *  and each value is a weighted mean of the old elements it overlaps. */
  PA_TRANSFER_CONSERVATIVE = 2,
  /** Element fields: CONSERVATIVE, then each value is held exactly within
   *  the values of the old elements it overlaps, and the integral that
   *  this and a moving boundary change is given back to the elements with
   *  room left below (above) their bound. */
  PA_TRANSFER_BOUNDED = 3,
  /** Element fields: the value of the old element of largest overlap (a
   *  field of integers keeps its set of values). Boundary fields (their
   *  only mode): the value of the old boundary entity of the same
   *  reference nearest to the new one's centre. */
  PA_TRANSFER_NEAREST = 4
} pa_transfer;

/** Attach to mesh (in/out) a user field called name (its first 63 bytes)
 *  on its entities at
 *  (PA_VERTEX, PA_ELEMENT or PA_BOUNDARY), of ncomp > 0 components per
 *  entity: values (nvert, nelem or nbdry times ncomp) are copied; its
 *  transfer mode is the default one. It becomes field
 *  pa_mesh_nfield_at - 1. Not collective. Returns PA_ERR_ARG for another
 *  kind, ncomp <= 0, 16 fields on those entities already,
 *  or a value that is not finite (naming the entity, 1-based),
 *  PA_ERR_MEMORY. */
pa_status pa_mesh_add_field_at(pa_mesh *mesh, pa_entity at, const char *name,
                               int ncomp, const double *values);
/** Remove field k on entities at of mesh (in/out; the later ones move down
 *  by one). Not collective. Returns PA_ERR_ARG for another kind or k out of
 *  range. */
pa_status pa_mesh_remove_field_at(pa_mesh *mesh, pa_entity at, int k);
/** Returns the number of user fields on entities at of mesh (0 for another
 *  kind). Not collective. */
int pa_mesh_nfield_at(const pa_mesh *mesh, pa_entity at);
/** Field k on entities at of mesh: *name, *ncomp and *values (out, each may
 *  be NULL; the values, one block of ncomp per entity, may be changed in
 *  place), valid until the fields or the entities change. Not collective.
 *  Returns PA_ERR_ARG for another kind or k out of range. */
pa_status pa_mesh_field_at(pa_mesh *mesh, pa_entity at, int k,
                           const char **name, int *ncomp, double **values);
/** Returns the index of the first field called name on entities at of
 *  mesh, -1 if there is none. Not collective. */
int pa_mesh_field_index(const pa_mesh *mesh, pa_entity at, const char *name);
/** Set the transfer mode of field k on entities at of mesh (in/out);
 *  PA_TRANSFER_DEFAULT sets the default one. Not collective. Returns
 *  PA_ERR_ARG for k out of range or a mode the field's entities do not
 *  take (see pa_transfer), the message listing those they take. */
pa_status pa_mesh_set_field_transfer(pa_mesh *mesh, pa_entity at, int k,
                                     pa_transfer mode);
/** Returns the transfer mode of field k on entities at of mesh (never
 *  PA_TRANSFER_DEFAULT), PA_TRANSFER_DEFAULT for k out of range. Not
 *  collective. */
pa_transfer pa_mesh_field_transfer(const pa_mesh *mesh, pa_entity at, int k);
/** Returns the name of a transfer mode ("linear", "conservative",
 *  "bounded", "nearest", "default"), "?" for another value. Not
 *  collective. */
const char *pa_transfer_name(pa_transfer mode);
/** The transfer mode called name (as pa_transfer_name gives it; "copy" is
 *  "nearest") into *mode (out). Not collective. Returns PA_ERR_ARG for
 *  another name, the message listing the valid ones. */
pa_status pa_transfer_parse(const char *name, pa_transfer *mode);

/*
 * Physical names: Gmsh's names of the entities of one dimension and one
 * reference ($PhysicalNames), e.g. (2, 3, "inlet"). The .msh reader stores
 * them and the .msh writer writes them all back; pa_mesh_copy copies them and
 * pa_remesh keeps them. Medit and VTU files do not hold them.
 */
/** Returns the number of physical names of mesh (0 for NULL). Not
 *  collective. */
int pa_mesh_nnames(const pa_mesh *mesh);
/**
 * Physical name k of mesh (0 <= k < pa_mesh_nnames; sorted by dimension,
 * then tag): *dim (out) the dimension of its entities (0 points, 1 lines,
 * 2 surfaces, 3 volumes), *tag (out) their reference (the Gmsh physical
 * tag) and *name (out) the name, valid until the names change. Any
 * out-pointer may be NULL. Not collective. Returns PA_ERR_ARG for k out of
 * range.
 */
pa_status pa_mesh_name(const pa_mesh *mesh, int k, int *dim, int32_t *tag,
                       const char **name);
/**
 * Name the entities of dimension dim (0-3) and reference tag of mesh
 * (in/out): the name (copied) replaces the one (dim, tag) had; name NULL
 * removes it. Not collective. Returns PA_ERR_ARG for dim out of [0, 3] or
 * a name that is empty or holds a double quote or a line break (Gmsh writes
 * it quoted on one line), PA_ERR_MEMORY.
 */
pa_status pa_mesh_add_name(pa_mesh *mesh, int dim, int32_t tag,
                           const char *name);

/**
 * Element-to-element adjacency of mesh (in/out: built once, cached until a
 * change): *adja (out, nelem * (dim+1) entries, owned by the mesh)
 * adja[(dim+1)*e + i] = (dim+1)*f + j when face i of e (the face opposite
 * its vertex i) is face j of element f, -1 on the boundary. O(n log n) or
 * better. Not collective. Returns PA_ERR_MESH if a face is shared by more
 * than two elements, PA_ERR_MEMORY.
 */
pa_status pa_mesh_build_adjacency(pa_mesh *mesh, const pa_idx **adja);
/** Vertex balls of mesh (in/out: cached as the adjacency) as CSR: *start
 *  (out, nvert + 1 entries) and *ball (out): the elements of vertex v are
 *  ball[start[v] .. start[v+1]-1]; both owned by the mesh. Not collective.
 *  Returns PA_ERR_MEMORY. */
pa_status pa_mesh_build_balls(pa_mesh *mesh, const pa_idx **start,
                              const pa_idx **ball);
/** The boundary entity of mesh (in/out: the lookup is cached) with the dim
 *  vertices v (any order) into *index (out; -1 if none). Not collective.
 *  Returns PA_ERR_MEMORY. */
pa_status pa_mesh_find_bdry(pa_mesh *mesh, const pa_idx *v, pa_idx *index);

/**
 * Add the missing boundary entities to mesh (in/out): every element face
 * that has no neighbour and is not yet listed becomes a boundary entity of
 * reference ref; *nadded (out, may be NULL) receives their number. Meshes
 * read from files that list no boundary get one this way. Not collective.
 * Returns PA_ERR_MESH if a face is shared by more than two elements,
 * PA_ERR_MEMORY.
 */
pa_status pa_mesh_build_boundary(pa_mesh *mesh, int32_t ref, pa_idx *nadded);

/** Drop the cached adjacency, balls and boundary lookup of mesh (in/out):
 *  call it after changing entity arrays directly through the raw
 *  accessors. Not collective. */
void pa_mesh_invalidate(pa_mesh *mesh);

/** Returns the signed volume (3D) or area (2D) of element e of mesh (NaN
 *  for e out of range). Not collective. */
double pa_mesh_elem_volume(const pa_mesh *mesh, pa_idx e);
/** Returns the sum of the signed element volumes (areas in 2D) of mesh,
 *  compensated (NaN for NULL). Not collective. */
double pa_mesh_volume(const pa_mesh *mesh);

/**
 * Check mesh (in/out: may build the cached adjacency, balls and boundary
 * lookup): indices in range, positive orientation, no face shared by more
 * than two elements, symmetric adjacency, every topological boundary face
 * listed as a boundary entity, no unused vertex, finite coordinates,
 * manifold vertices (the elements around a vertex connected through faces:
 * no two fans or cones touching only there), no two vertices at the same
 * point (a crack: duplicated vertices along an interior face), then a valid
 * metric. Not collective. Returns PA_ERR_MESH (PA_ERR_METRIC for the
 * metric) with a message naming the first violated invariant and the
 * entity, PA_ERR_MEMORY.
 */
pa_status pa_mesh_check(pa_mesh *mesh);

/** Returns the bytes used by mesh and its derived structures (0 for NULL).
 *  Not collective. */
size_t pa_mesh_memory_used(const pa_mesh *mesh);

/**
 * Structured generators, into *mesh (out): for dim 2 the unit square
 * [0,1]^2 split in n x n squares of two triangles; for dim 3 the unit cube
 * [0,1]^3 split in n^3 hexahedra of six tetrahedra. Boundary references:
 * 2D x=0:1 x=1:2 y=0:3 y=1:4; 3D x=0:1 x=1:2 y=0:3 y=1:4 z=0:5 z=1:6.
 * Element reference 1, vertex reference 0. Not collective. Returns
 * PA_ERR_ARG for another dim or n < 1, PA_ERR_MEMORY.
 */
pa_status pa_mesh_generate_box(int dim, int n, pa_mesh **mesh);

/* ------------------------------------------------------------------------ */
/* Metrics, quality, statistics                                             */
/* ------------------------------------------------------------------------ */

/**
 * Attach a built-in analytic metric field to the vertices of mesh (in/out;
 * it replaces the metric). spec is "NAME" or "NAME:h" where h scales the
 * field's reference size:
 *  - "uniform[:h]"   isotropic size h (default 0.1);
 *  - "layer[:h]"     anisotropic boundary layer along the plane x = 0.5, size
 *                    h tangentially and h/100 normally at the plane, growing to
 *                    h at distance 0.25 (1:100 stretching);
 *  - "shell[:h]"     anisotropic spherical (circular in 2D) shell of radius
 *                    0.3 centred at the box centre, size h/50 normally at the
 *                    shell, h tangentially;
 *  - "iso-shell[:h]" the isotropic version of "shell" (size h/10 at the shell);
 *  - "ugawg-linear", "ugawg-polar1", "ugawg-polar2": the anisotropic fields
 *                    of the UGAWG benchmark (exact at the default h = 0.1):
 *                    size h0 = h/100 at the plane z = 0.5 (y = 0.5 in 2D),
 *                    resp. the cylinder r = 0.5 around the z axis, growing
 *                    linearly to h; polar2 also shrinks the tangential size
 *                    to h/4 near the cylinder. Exact formulas in
 *                    src/metric/analytic.c.
 * Not collective. Returns PA_ERR_ARG for an unknown NAME or a bad h,
 * PA_ERR_MEMORY.
 */
pa_status pa_metric_analytic(pa_mesh *mesh, const char *spec);

/** Returns the names of the built-in metric fields, a static
 *  NULL-terminated list. Not collective. */
const char *const *pa_metric_analytic_names(void);

/**
 * Clamp the metric of mesh (in/out): eigenvalues into [1/hmax^2, 1/hmin^2]
 * (sizes into [hmin, hmax]); a bound <= 0 is ignored. Not collective.
 * Returns PA_ERR_ARG if the mesh has no metric, a bound is not a number or
 * hmin > hmax.
 */
pa_status pa_mesh_metric_clamp(pa_mesh *mesh, double hmin, double hmax);

/**
 * Replace the metric of mesh (in/out) by the sizes of the mesh itself: at
 * each vertex the mean length of its edges (isotropic; Mmg's -optim), so
 * that a remesh keeps the sizes and improves the quality. Not collective.
 * Returns PA_ERR_MESH if a vertex belongs to no element, PA_ERR_MEMORY.
 */
pa_status pa_mesh_metric_from_edges(pa_mesh *mesh);

/* ---- metric toolbox (src/metric/recovery.c, hessian.c, levelset.c) ---- */

/** How a gradient and a Hessian are recovered from vertex values. */
typedef enum pa_recovery {
  /** weighted least-squares quadratic fit over each vertex's neighbours
   *  (the 2-ring where the 1-ring is too small): exact for quadratics */
  PA_RECOVER_LSQ = 0,
  /** double L2 projection: volume-weighted means of the element gradients,
   *  twice; exact for linear fields only */
  PA_RECOVER_L2 = 1
} pa_recovery;

/**
 * Gradient and Hessian of the scalar vertex field u (value of vertex v at
 * u[v * stride]) at every vertex of mesh (in/out: builds its cached
 * balls), by method, into grad (out, dim values per vertex) and hess (out,
 * 3 or 6 per vertex: xx xy yy [xz yz zz]); either may be NULL. Not
 * collective. Returns PA_ERR_MESH where a vertex has too few neighbours
 * for the fit, PA_ERR_MEMORY.
 */
pa_status pa_mesh_recover(pa_mesh *mesh, const double *u, int stride,
                          pa_recovery method, double *grad, double *hess);

/** The complexity of the metric met (ncomp 1: sizes, M = I/h^2; or the
 *  tensor count per vertex) on mesh into *complexity (out): the integral
 *  of sqrt(det M), by the vertex mean over each element. The number of
 *  unit elements it asks for is about 4/sqrt(3) C (2D) or 6 sqrt(2) C
 *  (3D). Not collective. Returns PA_ERR_ARG for another ncomp. */
pa_status pa_metric_complexity(pa_mesh *mesh, int ncomp, const double *met,
                               double *complexity);

/* Option defaults: the default of each numeric option, spelled once. The
 * *_opts_default functions set them, the CLI's -h prints them, and the
 * Python package reads them through the *_opts_default functions. */
/** Gradation (pa_remesh_opts.hgrad and the metric toolbox's hgrad): Mmg's
 *  -hgrad, a size ratio of 1.3 per unit edge. */
#define PA_DEFAULT_HGRAD 1.3
/** Gradation from required entities (pa_remesh_opts.hgradreq): Mmg's
 *  -hgradreq. */
#define PA_DEFAULT_HGRADREQ 2.3
/** Distance of the new boundary to the reconstructed one
 *  (pa_remesh_opts.hausd): Mmg's -hausd. */
#define PA_DEFAULT_HAUSD 0.01
/** Ridge and corner detection angle in degrees (pa_remesh_opts.angle):
 *  Mmg's -ar. */
#define PA_DEFAULT_ANGLE 45
/** Norm of the interpolation error the Hessian metric controls
 *  (pa_metric_hessian_opts.p): L2, the usual choice of Loseille and
 *  Alauzet's multiscale metric. */
#define PA_DEFAULT_LP 2
/** The parallel loop (pa_adapt_opts): quality below which an element is
 *  tagged (the 3D remesher's rounds work on the tets below it too), */
#define PA_DEFAULT_QUAL_THRESHOLD 0.3
/** iterations at most (converged runs take 2-4), */
#define PA_DEFAULT_MAX_ITER 30
/** pieces per process (more pieces per rank cost an iteration on large
 *  structured meshes; docs/BENCHMARKS.md, "The parallel loop"), */
#define PA_DEFAULT_PIECES_PER_RANK 1
/** vertex layers around the tagged elements, in the first iteration and
 *  in the later ones (docs/design/ADAPT.md), */
#define PA_DEFAULT_SKIN_LAYERS 2
#define PA_DEFAULT_SKIN_LAYERS_LATER 1
/** smallest work and smallest share of the mean elements per rank worth a
 *  piece of its own (every iteration passes over the whole mesh), */
#define PA_DEFAULT_MIN_PIECE_WORK 2000
#define PA_DEFAULT_MIN_PIECE_RATIO 0.25
/** and the imbalance the final rebalance leaves alone. */
#define PA_DEFAULT_REBALANCE_TOL 1.05

/** Options of pa_metric_from_hessian (pa_metric_hessian_opts_default). */
typedef struct pa_metric_hessian_opts {
  double p;       /**< Lp norm of the interpolation error (default
                       PA_DEFAULT_LP; <= 0: L-infinity) */
  double target;  /**< complexity to reach (> 0), or ... */
  double err;     /**< ... the Lp interpolation error to reach (> 0) */
  double hmin, hmax; /**< size bounds (<= 0: none) */
  double hgrad;   /**< gradation of the result (<= 1: none; default
                       PA_DEFAULT_HGRAD) */
  pa_recovery recovery; /**< default PA_RECOVER_LSQ */
} pa_metric_hessian_opts;
/** Fill *opts (out) with the defaults: p PA_DEFAULT_LP, no target nor
 *  error, no bounds, hgrad PA_DEFAULT_HGRAD, PA_RECOVER_LSQ. Not
 *  collective. */
void pa_metric_hessian_opts_default(pa_metric_hessian_opts *opts);

/**
 * The Lp-optimal metric of a scalar vertex field u of mesh (value of vertex
 * v at u[v * stride]; Loseille & Alauzet's multiscale metric):
 * M = D det|H|^(-1/(2p+d)) |H|, |H| the recovered Hessian with absolute
 * eigenvalues, D set so that the complexity is opts->target (or the
 * estimated Lp error opts->err), then clamped and graded; the complexity
 * is reached again after clamping and gradation. met (out): the tensor
 * metric, 3 or 6 values per vertex (the mesh's own metric is not changed).
 * Not collective. Returns PA_ERR_ARG for options out of range (both or
 * neither of target and err, hmin > hmax) or a field whose Hessian is zero
 * everywhere, PA_ERR_MESH as pa_mesh_recover, PA_ERR_MEMORY.
 */
pa_status pa_metric_from_hessian(pa_mesh *mesh, const double *u, int stride,
                                 const pa_metric_hessian_opts *opts,
                                 double *met);

/** Scale the metric met (in/out; ncomp 1 or the tensor count per vertex)
 *  on mesh so that its complexity becomes target (> 0). Not collective.
 *  Returns PA_ERR_ARG for another ncomp or target, PA_ERR_METRIC if the
 *  metric has no complexity on the mesh. */
pa_status pa_metric_scale_complexity(pa_mesh *mesh, int ncomp, double *met,
                                     double target);

/** The intersection of the metrics a and b (nv values of ncomp components
 *  each, in dimension dim): the largest metric contained in both, by
 *  simultaneous reduction, into out (out; may be a or b). Not collective.
 *  Returns PA_ERR_ARG for dim or ncomp out of range. */
pa_status pa_metric_intersect_all(int dim, int ncomp, pa_idx nv,
                                  const double *a, const double *b,
                                  double *out);

/** Grade the metric of mesh (in/out) in place with the rates hgrad and
 *  hgradreq (see pa_remesh_opts); required vertices keep their metric. Not
 *  collective. Returns PA_ERR_ARG if the mesh has no metric or a rate is
 *  not a number, PA_ERR_MEMORY. */
pa_status pa_mesh_metric_grade(pa_mesh *mesh, double hgrad, double hgradreq);

/**
 * The signed distance to the analytic surface spec at every vertex of mesh
 * (negative inside) into phi (out, one value per vertex): spec is
 * "sphere:R[:cx,cy,cz]", "ellipsoid:a,b,c[:cx,cy,cz]" (semi-axes along x,
 * y, z; in 2D "ellipse:a,b[:cx,cy]"), "box:lx,ly,lz[:cx,cy,cz]" (half
 * lengths; 2D "box:lx,ly[:cx,cy]"), "plane:nx,ny,nz,d" (nx x + ... = d; 2D
 * "plane:nx,ny,d", a line). In 2D "sphere" is a circle and
 * "ellipsoid:a,b" an ellipse. Not collective. Returns PA_ERR_ARG for a
 * spec that is not one of these (the message says why).
 */
pa_status pa_levelset_analytic(pa_mesh *mesh, const char *spec, double *phi);

/** Options of pa_metric_from_levelset (pa_metric_levelset_opts_default). */
typedef struct pa_metric_levelset_opts {
  double eps;        /**< distance bound between the surface and the mesh */
  double hmin, hmax; /**< size bounds (hmin: the normal size at the surface) */
  double band;       /**< half-width of the anisotropic band around the zero
                          set (<= 0: 5 hmax) */
  double hgrad;      /**< gradation away from the interface (default
                          PA_DEFAULT_HGRAD) */
} pa_metric_levelset_opts;
/** Fill *opts (out) with the defaults: hgrad PA_DEFAULT_HGRAD, the rest 0
 *  (eps, hmin and hmax must then be set). Not collective. */
void pa_metric_levelset_opts_default(pa_metric_levelset_opts *opts);

/**
 * The metric that captures the zero set of the level set phi (one value per
 * vertex of mesh) to within opts->eps: inside the band, along the recovered
 * gradient of phi the size hmin at the zero set growing linearly to hmax at
 * the band's edge, along the principal curvature directions of the
 * iso-surface the chord bound sqrt(8 eps / |kappa|) clamped to [hmin,
 * hmax]; hmax outside; then graded. met (out): tensors (3 or 6 per vertex;
 * the mesh's own metric is not changed). Not collective. Returns
 * PA_ERR_ARG for options out of range (eps, hmin <= 0, hmax < hmin, too
 * large a ratio hmax / hmin) or a value of phi that is not finite,
 * PA_ERR_MESH as pa_mesh_recover, PA_ERR_MEMORY.
 */
pa_status pa_metric_from_levelset(pa_mesh *mesh, const double *phi,
                                  const pa_metric_levelset_opts *opts,
                                  double *met);

/* Level-set discretisation (Mmg's -ls): the zero set of a level set cut
 * into the mesh as an interface between two references. User guide:
 * docs/guide/levelset.md. */

/** Mmg's default references of the level-set cut: the elements where phi
 *  < value, the others, and the interface (Mmg's MG_MINUS, MG_PLUS and
 *  -isoref). */
#define PA_LS_REF_IN 3
#define PA_LS_REF_OUT 2
#define PA_LS_REF_IFACE 10
/** Default of pa_levelset_opts.snap: a cut point closer than this share of
 *  its edge to one end moves onto it (the value there becomes the
 *  iso-value). A cut point at a share t makes elements of quality about t
 *  times their parent's; at 0.01 the interface moves by at most 1 % of an
 *  edge, less than the interpolation error of a level set sampled at ten
 *  vertices per radius of curvature (h^2 / 8R = 1.25 % of h). */
#define PA_LS_SNAP 0.01
/** Default of pa_levelset_opts.rmc when removal is asked without a volume
 *  (Mmg's -rmc without value): 1e-5 of the mesh volume. */
#define PA_LS_RMC 1e-5

/** One material of the multi-material mode (Mmg's LSReferences): the
 *  elements of reference ref are split by the level set into ref_in (phi <
 *  value) and ref_out (the others); with split 0 they keep ref, are cut
 *  where the level set crosses them only so that the mesh stays
 *  conforming, and no interface is made inside them. */
typedef struct pa_ls_material {
  int32_t ref;
  int split;
  int32_t ref_in, ref_out;
} pa_ls_material;

/** Options of the level-set cut (pa_levelset_opts_default). */
typedef struct pa_levelset_opts {
  double value;      /**< the iso-value V (default 0) */
  int32_t ref_in;    /**< elements where phi < V (default PA_LS_REF_IN) */
  int32_t ref_out;   /**< the other elements (default PA_LS_REF_OUT) */
  int32_t ref_iface; /**< the interface's boundary entities and vertices
                          (default PA_LS_REF_IFACE) */
  /** Multi-material table (NULL, 0: every element is split into ref_in and
   *  ref_out). Every element reference must be one of its ref, or of the
   *  ref_in and ref_out of a split material (a mesh cut before: its
   *  elements count as that material). The array must live as long as the
   *  options are used. */
  const pa_ls_material *mat;
  int nmat;
  /** > 0: a connected region of one side (its vertices on that side,
   *  linked by edges) whose volume is below rmc times the mesh volume
   *  changes side before the cut (Mmg's -rmc; PA_LS_RMC is Mmg's value);
   *  the outside's first, then the inside's. Default 0: none. */
  double rmc;
  /** Expert: the snapping share (default PA_LS_SNAP, in [0, 0.25]): a
   *  vertex whose value would put a cut point within snap times the edge
   *  of it takes the value V. */
  double snap;
} pa_levelset_opts;

/** Fill *opts (out) with the defaults: value 0, references 3, 2 and 10, no
 *  materials, no removal, snap PA_LS_SNAP. Not collective. */
void pa_levelset_opts_default(pa_levelset_opts *opts);

/** What a level-set cut did (the same on every rank for the distributed
 *  one). */
typedef struct pa_levelset_report {
  double phi_min, phi_max; /**< range of the level set (before snapping) */
  pa_gid nsnapped;   /**< vertices that took the value V (snapping) */
  pa_gid nremoved_out, nremoved_in; /**< components that changed side (rmc) */
  pa_gid ncut;       /**< edges cut (vertices added) */
  pa_gid nelem_cut;  /**< elements split */
  pa_gid niface;     /**< boundary entities of the interface; 0 when the
                          level set does not cross the mesh */
  pa_gid ndropped;   /**< entities of reference ref_iface inside the domain
                          that were removed before the cut (the interface
                          of an earlier cut) */
  pa_gid nbdry_iface; /**< entities of reference ref_iface on the domain
                           boundary, kept: the output does not tell them
                           from the interface */
  double vol_in, vol_out; /**< volume of the elements of either side */
} pa_levelset_report;

/**
 * Cut the zero set of phi - opts->value into mesh (in/out; Mmg's -ls):
 * phi holds one value per vertex (P1). Values that would put a cut point
 * within opts->snap of an edge's end become the iso-value there; with
 * opts->rmc, small components change side; every edge where phi - V
 * changes sign is split at the zero of its linear interpolant (metric and
 * fields interpolated there), every element it crosses is split into
 * elements of either side (faces shared by two elements are split the same
 * way on both: quadrilaterals are cut by their diagonal from the vertex of
 * smallest key, original vertices by index, added ones after them by the
 * indices of their edge), and so are the boundary entities and feature
 * edges it crosses (keeping their reference and flags). Elements get
 * ref_in (phi < V) or ref_out (or their material's references); the faces
 * between the two sides become boundary entities of reference ref_iface
 * (oriented from the inside out), their vertices take that reference, and
 * other vertices of that reference take 0. Entities of reference ref_iface
 * inside the domain (an earlier cut's interface) are removed first. Every
 * vertex of the interface has phi = V exactly in the P1 interpolation of
 * the (snapped) level set. The physical names stay. *report (out, may be
 * NULL): what was done. Not collective. On error the mesh is as given.
 * Returns PA_ERR_ARG for options out of range, a phi value that is not
 * finite (naming the vertex, 1-based), an element reference the material
 * table does not list (naming the element); PA_ERR_MEMORY.
 */
pa_status pa_mesh_levelset_cut(pa_mesh *mesh, const double *phi,
                               const pa_levelset_opts *opts,
                               pa_levelset_report *report);

/** Returns the length of the edge ab (dim coordinates each) in the metric
 *  (ncomp components at each end: ma at a, mb at b; ncomp 0: Euclidean,
 *  ma and mb unused), by the geometric formula of Mmg. Not collective. */
double pa_metric_edge_length(int dim, int ncomp, const double *a,
                             const double *b, const double *ma,
                             const double *mb);

/** Returns the quality of element e of mesh in Mmg's normalisation (1
 *  regular, 0 flat, < 0 inverted), in its metric (the identity when it has
 *  none); NaN for e or one of its vertices out of range. Not collective. */
double pa_mesh_elem_quality(pa_mesh *mesh, pa_idx e);

/** Mesh statistics, as printed by `padapt stats`. Sums/min/max so that they can
 *  be combined across processes. */
#define PA_STATS_EDGE_NBIN 10
#define PA_STATS_QUAL_NBIN 5
typedef struct pa_stats {
  int dim;
  int has_metric;
  pa_gid nvert, nelem, nbdry;
  double volume;
  pa_gid ninverted;   /**< elements with volume <= 0 */
  int valid;          /**< pa_mesh_check succeeded */
  pa_gid nedge;       /**< unique edges */
  double edge_min, edge_max, edge_sum;
  /** Edge length bins: [0,0.3) [0.3,0.6) [0.6,0.7071) [0.7071,0.9) [0.9,1.3)
   *  [1.3,1.4142) [1.4142,2) [2,5) [5,inf) and (last) [0.7071,1.4142). */
  pa_gid edge_hist[PA_STATS_EDGE_NBIN];
  double qual_min, qual_max, qual_sum;
  /** Quality bins [0,0.2) ... [0.8,1]. */
  pa_gid qual_hist[PA_STATS_QUAL_NBIN];
  pa_gid qual_above_05, qual_above_012;
} pa_stats;

/**
 * Bounds of bin b of pa_stats.edge_hist: lengths L with *lo <= L < *hi.
 * Bins 0 .. PA_STATS_EDGE_NBIN - 2 partition [0, inf) (the last of them has
 * *hi = INFINITY); bin PA_STATS_EDGE_NBIN - 1 is the in-range band
 * [0.7071, 1.4142), the union of bins 3, 4 and 5. The values are Mmg's
 * printed ones (0.7071 is not 1/sqrt(2)). Not collective.
 *
 * \param[in]  b   bin index, 0 <= b < PA_STATS_EDGE_NBIN
 * \param[out] lo  lower bound (included)
 * \param[out] hi  upper bound (excluded)
 * \return PA_SUCCESS, or PA_ERR_ARG for b out of range or a NULL pointer.
 */
pa_status pa_stats_edge_bin(int b, double *lo, double *hi);
/**
 * Bounds of bin b of pa_stats.qual_hist: qualities Q with *lo <= Q < *hi,
 * except that bin 0 also holds every Q < 0 (inverted elements) and the
 * last bin also holds Q = 1 (its *hi is 1). Not collective.
 *
 * \param[in]  b   bin index, 0 <= b < PA_STATS_QUAL_NBIN
 * \param[out] lo  lower bound
 * \param[out] hi  upper bound
 * \return PA_SUCCESS, or PA_ERR_ARG for b out of range or a NULL pointer.
 */
pa_status pa_stats_qual_bin(int b, double *lo, double *hi);

/** The statistics of mesh (in/out: the check builds its cached structures)
 *  in its metric (the identity when it has none) into *stats (out); an
 *  invalid mesh is no error (stats->valid 0). Not collective. Returns
 *  PA_ERR_MESH for a vertex index out of range, PA_ERR_MEMORY. */
pa_status pa_mesh_stats(pa_mesh *mesh, pa_stats *stats);
/** Print stats in human-readable form (the report of `padapt stats`) on
 *  out. Not collective. */
void pa_stats_print(const pa_stats *stats, FILE *out);
/** Write stats as a JSON object to path (keys: dim vertices elements
 *  boundary volume inverted valid edge_min edge_max edge_mean
 *  edge_in_range quality_worst quality_mean quality_above_0.5 ...); extra,
 *  if not NULL, is inserted verbatim as further members (e.g. "\"time_s\":
 *  1.0"). Written through a temporary (see pa_output_begin). Not
 *  collective. Returns PA_ERR_IO naming the path. */
pa_status pa_stats_write_json(const pa_stats *stats, const char *extra,
                              const char *path);

/** The tolerance to which an adapted mesh meets a metric: at least this share
 *  of its edges in [0.7071, 1.4142) ... */
#define PA_TARGET_IN_RANGE 0.9
/** ... and no element of quality below this. */
#define PA_TARGET_QUALITY 0.01
/** Returns 1 if stats meet PA_TARGET_IN_RANGE and PA_TARGET_QUALITY, 0
 *  otherwise (and for NULL). Not collective. */
int pa_stats_target_met(const pa_stats *stats);

/** What made the metric a remesher used differ from the caller's. */
enum {
  PA_CHANGED_HMIN = 1u,      /**< -hmin shrank some size */
  PA_CHANGED_HMAX = 2u,      /**< -hmax capped some size */
  PA_CHANGED_GRADATION = 4u  /**< the gradation shrank some size */
};

/**
 * How an adapted mesh meets the metric the caller gave. `user`: the output
 * measured in the caller's metric (before hmin/hmax and gradation; at new
 * vertices interpolated from the input as the remesher interpolates its
 * own); `used`: measured in the metric the remesher worked with. Equal when
 * nothing changed the caller's metric (changed == 0).
 */
typedef struct pa_fidelity {
  int measured;     /**< 1 when the figures below were computed (0: not
                         asked for, or out of memory after the remesh) */
  pa_stats user, used;
  int target_met;   /**< pa_stats_target_met(&user) */
  unsigned changed; /**< PA_CHANGED_* bits */
} pa_fidelity;

/** One line saying how the result f describes meets the caller's metric
 *  and, if not, what limited it (hmin/hmax, gradation, or the remesher in
 *  the metric it used), into buf (out, at most n bytes, NUL-terminated).
 *  Not collective. */
void pa_fidelity_describe(const pa_fidelity *f, char *buf, size_t n);

/* ------------------------------------------------------------------------ */
/* Solutions (.sol / .solb) and mesh files                                  */
/* ------------------------------------------------------------------------ */

/** Kinds of fields in a solution file (Medit's codes). */
typedef enum pa_sol_kind {
  PA_SOL_SCALAR = 1,
  PA_SOL_VECTOR = 2,
  PA_SOL_TENSOR = 3 /**< symmetric: m11 m12 m22 [m13 m23 m33] */
} pa_sol_kind;

/** Where the values of a solution's field are given: the Medit keyword
 *  that holds them. A mesh of dimension 2 has its element fields at
 *  triangles and its boundary fields at edges; of dimension 3, at
 *  tetrahedra and at triangles. */
typedef enum pa_sol_at {
  PA_SOL_AT_VERTICES = 0,  /**< SolAtVertices */
  PA_SOL_AT_EDGES = 1,     /**< SolAtEdges */
  PA_SOL_AT_TRIANGLES = 2, /**< SolAtTriangles */
  PA_SOL_AT_TETRAHEDRA = 3 /**< SolAtTetrahedra */
} pa_sol_at;

/** A set of fields at the vertices, edges, triangles or tetrahedra of a
 *  mesh (SolAtVertices, SolAtEdges, SolAtTriangles, SolAtTetrahedra). */
typedef struct pa_sol pa_sol;

/** Create an empty solution of dimension dim (2 or 3) for nvert >= 0
 *  vertices into *sol (out; free it with pa_sol_destroy). Not collective.
 *  Returns PA_ERR_ARG for another dim or a negative nvert, PA_ERR_MEMORY. */
pa_status pa_sol_create(int dim, pa_idx nvert, pa_sol **sol);
/** Destroy sol (in/out; NULL allowed). Not collective. */
void pa_sol_destroy(pa_sol *sol);
/** Returns the dimension, the vertex count (of its fields at vertices)
 *  and the number of fields of sol. Not collective. */
int pa_sol_dim(const pa_sol *sol);
pa_idx pa_sol_nvert(const pa_sol *sol);
int pa_sol_nfield(const pa_sol *sol);
/** Returns where the vertex count of sol was read, for messages: "u.sol:3"
 *  (the line of its SolAtVertices keyword) or "u.solb: byte 40"; the path
 *  if unknown; NULL for a solution built in memory. Valid as long as sol.
 *  Not collective. */
const char *pa_sol_origin(const pa_sol *sol);
/** Append a field of kind to sol (in/out): values (nvert * ncomp, ncomp
 *  from kind and dim) are copied. Not collective. Returns PA_ERR_ARG for
 *  an unknown kind, PA_ERR_MEMORY. */
pa_status pa_sol_add_field(pa_sol *sol, pa_sol_kind kind, const double *values);
/** Field k of sol: *kind, *ncomp (components per entity) and *values (out,
 *  each may be NULL; n * ncomp values owned by sol, n as
 *  pa_sol_field_where gives it: nvert for a field at vertices). Not
 *  collective. Returns PA_ERR_ARG for k out of [0, pa_sol_nfield). */
pa_status pa_sol_field(pa_sol *sol, int k, pa_sol_kind *kind, int *ncomp,
                       double **values);
/** Append to sol (in/out) a field of kind at n >= 0 entities of the kind
 *  at: values (n * ncomp, ncomp from kind and dim) are copied. A field at
 *  vertices needs n = pa_sol_nvert. Not collective. Returns PA_ERR_ARG
 *  for an unknown kind or place, a wrong vertex count, PA_ERR_MEMORY. */
pa_status pa_sol_add_field_at(pa_sol *sol, pa_sol_at at, pa_idx n,
                              pa_sol_kind kind, const double *values);
/** Where field k of sol is given: *at, *n (its entities) and *origin
 *  (where it was read, for messages: "u.sol:12", the line of its keyword,
 *  or "u.solb: byte 40"; NULL for a field built in memory), each may be
 *  NULL. Not collective. Returns PA_ERR_ARG for k out of range. */
pa_status pa_sol_field_where(const pa_sol *sol, int k, pa_sol_at *at,
                             pa_idx *n, const char **origin);

/** Read path, .sol (ASCII) or .solb (binary, versions 1-4) by extension,
 *  into *sol (out): the fields of every SolAtVertices, SolAtEdges,
 *  SolAtTriangles and SolAtTetrahedra keyword, in file order (keywords of
 *  one kind must agree on their count). Values are not checked (NaN
 *  included): the mesh functions that take them do. Not collective.
 *  Returns PA_ERR_IO or PA_ERR_FORMAT naming the file and line (or byte),
 *  PA_ERR_UNSUPPORTED for another extension, PA_ERR_MEMORY. */
pa_status pa_sol_read(const char *path, pa_sol **sol);
/** Write sol to path, .sol or .solb by extension, through a temporary file
 *  (see pa_output_begin): the fields of each place under its keyword
 *  (several types per keyword), vertices, edges, triangles, tetrahedra.
 *  Not collective. Returns PA_ERR_ARG for a solution without field,
 *  PA_ERR_UNSUPPORTED for another extension, PA_ERR_IO naming the path. */
pa_status pa_sol_write(const pa_sol *sol, const char *path);

/** Attach field k of sol as the metric of mesh (in/out; a scalar field:
 *  sizes, a tensor field: SPD tensors). Not collective. Returns PA_ERR_ARG
 *  for k out of range, a vector field or one not at vertices, PA_ERR_FORMAT
 *  (naming the file) for a vertex count that is not the mesh's,
 *  PA_ERR_METRIC as pa_mesh_set_metric. */
pa_status pa_mesh_metric_from_sol(pa_mesh *mesh, const pa_sol *sol, int k);
/** A new solution *sol (out) holding the metric of mesh and, if
 *  with_fields, its user vertex fields. Not collective. Returns PA_ERR_ARG
 *  if there is nothing to hold, PA_ERR_MEMORY. */
pa_status pa_mesh_metric_to_sol(pa_mesh *mesh, int with_fields, pa_sol **sol);
/**
 * Attach every field of sol to mesh (in/out) as user fields: those at
 * vertices on its vertices, at triangles (2D) or tetrahedra (3D) on its
 * elements, at edges (2D) or triangles (3D) on its boundary entities, in
 * the mesh's own numbering of those entities. A .sol names no field: they
 * are called field1, field2, ... on the vertices, cell1, ... on the
 * elements and face1, ... on the boundary entities, numbered after the
 * fields the mesh has there. Not collective. Returns PA_ERR_FORMAT naming
 * where a field was read (file and line) for a count that is not the
 * mesh's or a place the mesh has no entities for (edges of a 3D mesh),
 * PA_ERR_ARG naming the file and the entity (1-based) of a value that is
 * not finite, or for too many fields; the mesh is then as it was.
 * PA_ERR_MEMORY.
 */
pa_status pa_mesh_fields_from_sol(pa_mesh *mesh, const pa_sol *sol);
/** A new solution *sol (out) holding the user fields of mesh, each at its
 *  entities (vertex fields at vertices, element fields at triangles or
 *  tetrahedra, boundary fields at edges or triangles; kind by number of
 *  components: 1 scalar, dim vector, 3 or 6 symmetric tensor, another
 *  count as that many scalars). Not collective. Returns PA_ERR_ARG if the
 *  mesh has no field, PA_ERR_MEMORY. */
pa_status pa_mesh_fields_to_sol(pa_mesh *mesh, pa_sol **sol);

/** Options for writing mesh files. */
typedef struct pa_write_opts {
  int binary;      /**< Gmsh .msh: 1 binary, 0 ASCII (default) */
  int version;     /**< .meshb: file version 1-4 (0: default 2) */
  int diagnostics; /**< .vtu: 1 adds the cell data "edge_min" and
                        "edge_max", each element's extreme edge lengths in
                        its metric (default 0) */
} pa_write_opts;

/**
 * Read the mesh at path into *mesh (out), format chosen by extension:
 * .mesh/.meshb (Medit), .msh (Gmsh 4.1 ASCII or binary, or 2.2 ASCII).
 * From a .msh: the physical names, and the $NodeData views: the one named
 * "metric" (1 component: sizes; 9: a symmetric tensor) becomes the metric,
 * the others fields of their names (docs/guide/gmsh.md). The mesh is not
 * checked (pa_mesh_check). Not collective. Returns PA_ERR_IO,
 * PA_ERR_FORMAT or PA_ERR_METRIC naming the file and the line (or byte),
 * PA_ERR_UNSUPPORTED for another extension or file variant, PA_ERR_MEMORY.
 */
pa_status pa_mesh_read(const char *path, pa_mesh **mesh);
/**
 * Write mesh to path, format chosen by extension: .mesh/.meshb, .msh (Gmsh
 * 4.1: with the physical names, and the metric and fields as $NodeData
 * views), .vtu (VTK XML, appended raw binary; point data: metric and
 * fields; cell data: reference and quality), with opts (may be NULL: the
 * defaults). Written to a temporary file then renamed (see
 * pa_output_begin), so a failure never leaves a partial file. mesh is
 * in/out only for its cached structures. Not collective. Returns PA_ERR_IO
 * naming the path, PA_ERR_UNSUPPORTED for another extension or a .msh
 * field named "metric", PA_ERR_ARG for a bad opts->version, PA_ERR_MEMORY.
 */
pa_status pa_mesh_write(pa_mesh *mesh, const char *path,
                        const pa_write_opts *opts);

/* ------------------------------------------------------------------------ */
/* Geometry: the CAD model a mesh discretizes (user guide: geometry.md)     */
/* ------------------------------------------------------------------------ */

/*
 * A classified mesh knows which entity of a model (a point, a curve, a
 * surface or a volume, of dimension 0 to 3, and its tag) each of its
 * vertices and cells discretizes, as Gmsh's MSH 4.1 files record it:
 *  - the reference of every element, boundary entity and feature edge is
 *    the tag of its entity (positive): elements on volumes (3D) or surfaces
 *    (2D), boundary entities on surfaces (3D) or curves (2D), feature edges
 *    on curves (3D);
 *  - every curve is listed, as feature edges in 3D and boundary edges in
 *    2D (between two surfaces too);
 *  - every vertex has its entity (pa_mesh_vert_entity_dims, _tags), and the
 *    vertices of model points are corners (PA_FLAG_CORNER).
 * pa_mesh_read_model reads one; pa_mesh_set_vertex_entities and
 * pa_mesh_classify make one of a mesh built otherwise. With a geometry in
 * pa_remesh_opts, the remeshers put every new boundary vertex on its entity
 * and slide boundary vertices along it; pa_remesh and pa_dmesh_adapt keep
 * the classification up to date, and the .msh writer writes it back.
 */

/** A model the remeshers project onto: Gmsh's (pa_geometry_read) or the
 *  caller's own kernel (pa_geometry_create). */
typedef struct pa_geometry pa_geometry;

/** A geometry kernel, as callbacks on the caller's context. Each returns 0
 *  on success and anything else on failure (an unknown entity, a
 *  projection that did not converge). Coordinates are 3D (z = 0 for a 2D
 *  mesh). padapt calls them from one thread at a time. */
typedef struct pa_geometry_ops {
  /** Required: in y (3 values) the point of entity (dim, tag), dim 0 to 2,
   *  closest to x (3 values). */
  int (*closest)(void *ctx, int dim, int tag, const double *x, double *y);
  /** Optional (NULL: -hausd keeps the remeshers' own estimate): in *kappa
   *  the largest absolute curvature (1/length) of curve or surface (dim 1
   *  or 2, tag) at its point y (3 values). */
  int (*curvature)(void *ctx, int dim, int tag, const double *y,
                   double *kappa);
} pa_geometry_ops;

/** A geometry over the caller's kernel ops (copied) and its context ctx
 *  (kept; it must outlive the geometry), for a model whose bounding box
 *  has diagonal size > 0 (the scale of the distance tests), into *geom
 *  (out; free with pa_geometry_destroy). Not collective. Returns
 *  PA_ERR_ARG for a NULL closest or a size that is not positive and
 *  finite, PA_ERR_MEMORY. */
pa_status pa_geometry_create(const pa_geometry_ops *ops, void *ctx,
                             double size, pa_geometry **geom);
/**
 * Load the model at path (.geo, .step/.stp, .brep, .iges/.igs) through
 * Gmsh's library (OpenCASCADE inside) into *geom (out). Gmsh holds one
 * model per process: a second pa_geometry_read fails while the first lives.
 * Not collective (each process of a parallel run loads its own). Returns
 * PA_ERR_UNSUPPORTED when padapt was built without Gmsh's library or
 * cannot load it (pa_geometry_available), PA_ERR_IO naming the file when
 * Gmsh cannot read it or it holds no curve nor surface, PA_ERR_MEMORY.
 */
pa_status pa_geometry_read(const char *path, pa_geometry **geom);
/** Destroy geom (NULL allowed; Gmsh's model is unloaded). Not collective. */
void pa_geometry_destroy(pa_geometry *geom);
/** Returns 1 when pa_geometry_read can load models (padapt was built with
 *  Gmsh's library and it loads), else 0 with the reason in *why (out, may
 *  be NULL; a static string). Not collective. */
int pa_geometry_available(const char **why);
/** Returns the diagonal of the bounding box of geom's model. Not
 *  collective. */
double pa_geometry_size(const pa_geometry *geom);
/** The point y (out, 3 values) of entity (dim, tag) of geom closest to x
 *  (3 values). Not collective. Returns PA_ERR_ARG for a dim out of [0, 2],
 *  or naming the entity when the kernel fails (an unknown entity, no
 *  convergence). */
pa_status pa_geometry_closest(const pa_geometry *geom, int dim, int tag,
                              const double *x, double *y);

/** What pa_geometry_check measured: the distance of the vertices of the
 *  points, curves and surfaces of a mesh to their entities. */
typedef struct pa_geometry_report {
  pa_idx nvert;       /**< vertices on points, curves and surfaces */
  double dist_max;    /**< the largest distance of one to its entity */
  double dist_mean;   /**< the mean distance */
  pa_idx worst;       /**< the vertex at dist_max (-1: none) */
  int worst_dim;      /**< its entity */
  int worst_tag;
  double seconds;     /**< time spent in the kernel's projections */
} pa_geometry_report;

/**
 * Measure how far the vertices of the classified mesh (in/out only for its
 * cached structures) on points, curves and surfaces lie from their entity
 * of geom, into *rep (out, may be NULL), and check it: each entity must
 * exist in geom and each vertex lie within tol times pa_geometry_size
 * (tol < 0: no bound). Not collective. Returns PA_ERR_ARG for a mesh that
 * is not classified, PA_ERR_MESH naming the vertex (1-based) and the
 * entity that is missing from geom or too far from it.
 */
pa_status pa_geometry_check(const pa_geometry *geom, pa_mesh *mesh,
                            double tol, pa_geometry_report *rep);

/**
 * Read a Gmsh MSH 4.1 file (ASCII or binary) keeping its classification
 * (see above) into *mesh (out): the references are entity tags, the
 * vertices get the entities of their node blocks, and the entities'
 * physical tags and boundaries ($Entities) stay on the mesh for
 * pa_mesh_write, which writes them back. Boundary entities and curves the
 * file does not list are added (pa_mesh_classify). Not collective. Returns
 * what pa_mesh_read returns, and PA_ERR_FORMAT naming the file for a file
 * without $Entities (a MSH 2.2 file, or one written without its model) and
 * for a cell or node whose entity it cannot tell.
 */
pa_status pa_mesh_read_model(const char *path, pa_mesh **mesh);
/** Returns 1 when mesh is classified (its vertices have entities), else 0.
 *  Not collective. */
int pa_mesh_classified(const pa_mesh *mesh);
/** The entities of the vertices of mesh: dims[v] (0 to 3) and tags[v],
 *  arrays of nvert values owned by the mesh, NULL when it is not
 *  classified. Not collective. */
const uint8_t *pa_mesh_vert_entity_dims(const pa_mesh *mesh);
const int32_t *pa_mesh_vert_entity_tags(const pa_mesh *mesh);
/**
 * Make mesh (in/out) classified: the vertices take the entities dims[v]
 * (0 to dim) and tags[v] (> 0), copied, and pa_mesh_classify completes the
 * cells (the caller sets the references of the cells it lists to entity
 * tags; any that is not positive is found). dims NULL removes the
 * classification. Not collective. Returns PA_ERR_ARG for a dimension or
 * tag out of range, pa_mesh_classify's errors (then the mesh is not
 * classified), PA_ERR_MEMORY.
 */
pa_status pa_mesh_set_vertex_entities(pa_mesh *mesh, const int *dims,
                                      const int32_t *tags);
/**
 * Complete the classification of mesh (in/out) from its vertices': the
 * boundary faces (and, in 3D, the faces between elements of two volumes)
 * that are not listed become boundary entities, each cell whose reference
 * is not positive takes the entity of its vertices (the one of its
 * dimension among them, else the only one whose boundary, as the mesh's
 * model entities record it, holds all its vertices' entities), every curve
 * edge is listed and every vertex of a point is a corner. Not collective.
 * Returns PA_ERR_MESH naming the cell (1-based) and the candidate entities
 * when it cannot tell which entity a cell lies on, PA_ERR_ARG for a mesh
 * that is not classified, PA_ERR_MEMORY; after a failure the vertices keep
 * their entities, and the cells what was completed until then.
 */
pa_status pa_mesh_classify(pa_mesh *mesh);
/** dst (in/out) takes copies of the physical names and model entities
 *  (their physical tags and boundaries) of src: what a gathered mesh needs
 *  to be written as its input was (a distributed mesh carries neither).
 *  Not collective. Returns PA_ERR_MEMORY. */
pa_status pa_mesh_copy_model(pa_mesh *dst, const pa_mesh *src);

/* ------------------------------------------------------------------------ */
/* Output transactions: several output files, all or nothing                */
/* ------------------------------------------------------------------------ */

/**
 * An output transaction of the calling thread. Every file padapt writes
 * (pa_mesh_write, pa_sol_write, pa_stats_write_json, pa_dmesh_write) goes to
 * a temporary "PATH.tmp.PID" in PATH's directory, flushed, synced and closed
 * before anything is renamed. Outside a transaction each file is renamed
 * onto PATH as soon as it is complete; between pa_output_begin and
 * pa_output_commit the temporaries wait, and the commit renames them all
 * only if none failed. A path that exists and is not a regular file (a
 * directory, a symbolic link, a device such as /dev/null) is refused: the
 * write fails naming it and the transaction fails.
 */
typedef struct pa_output pa_output;

/**
 * Open an output transaction in the calling thread, or join the one already
 * open (transactions nest; only the outermost commit or abort acts): *tx
 * (out) is the handle to end it with. Not collective. Fails only on a NULL
 * argument.
 */
pa_status pa_output_begin(pa_output **tx);
/**
 * End the transaction tx (from pa_output_begin): if no file of it failed,
 * rename every temporary onto its path (with SIGINT and SIGTERM blocked, so
 * that those signals never stop the renames half-way); otherwise remove
 * every temporary and leave every path as it was. An inner end of nested
 * begins only reports the failure so far. Not collective. Returns the
 * first failure (PA_ERR_IO ... naming the file), PA_ERR_ARG if no
 * transaction is open. A rename that fails (the directory changed
 * meanwhile) is reported naming the file; the files renamed before it
 * stay.
 */
pa_status pa_output_commit(pa_output *tx);
/** End the transaction tx removing every temporary: no path changes (an
 *  inner end of nested begins marks the transaction failed). Not
 *  collective. */
void pa_output_abort(pa_output *tx);
/**
 * Collective end over comm of one transaction per rank (tx, from
 * pa_output_begin on each rank): commit on every rank if st, the caller's
 * status, is PA_SUCCESS on every rank, abort everywhere otherwise. Returns
 * the same status on every rank (the lowest failing rank's, with its
 * message: see pa_set_error).
 * The commit is one agreed step: the ranks agree on st, then agree again
 * (each rank only once the first agreement completed on it, so a rank
 * killed while the others still wrote stops every commit), and only then
 * rename. SIGINT and SIGTERM act at once (with pa_output_handle_signals:
 * the temporaries removed) until a rank enters the second agreement; from
 * there to the end of its renames they wait, and once every rank is in
 * they are held (pa_output_held_signal): the outputs are committed
 * everywhere. A rank whose second agreement does not complete within half
 * a second of such a signal (another rank is gone) aborts and lets the
 * signal act.
 */
pa_status pa_output_end(MPI_Comm comm, pa_output *tx, pa_status st);
/**
 * The SIGINT or SIGTERM that arrived while pa_output_end committed and was
 * held until the commit completed (0 if none); the call forgets it. Not
 * collective. The padapt CLI prints a note and exits 0: its outputs are
 * complete.
 */
int pa_output_held_signal(void);
/** Test hook: called by pa_output_end with the step reached on this rank
 *  ("written": its files complete, entering the first agreement; "voted":
 *  past it; "agreed": past the second, before the renames; "renamed":
 *  after the first rename; "committed": after the renames, before agreeing
 *  on them). */
typedef void (*pa_output_hook)(const char *step, void *ctx);
/** Install hook (NULL: none) with its ctx, process-wide. Not collective;
 *  for tests (the CLI's PADAPT_TEST_PAUSE). */
void pa_output_set_hook(pa_output_hook hook, void *ctx);
/**
 * Check, before a long computation, that path can be written. Not
 * collective. Returns PA_ERR_IO naming the path if it exists and is not a
 * regular file, or if its directory is missing or not writable.
 */
pa_status pa_output_check(const char *path);
/**
 * A file the caller writes itself (a format padapt does not write, e.g. a
 * picture) as one of padapt's outputs: the same temporary beside its path,
 * the same checks and the same transaction as pa_mesh_write's files.
 */
typedef struct pa_output_file pa_output_file;
/**
 * Open path for writing: *file (out) is the handle for
 * pa_output_file_commit or pa_output_file_abort (NULL on failure), *fp
 * (out) the stream to write (binary mode), valid until then, on the
 * temporary "PATH.tmp.PID"; inside a transaction the file is one of its
 * files. Not collective. Returns PA_ERR_IO naming path if it exists and is
 * not a regular file or its temporary cannot be created (the open
 * transaction then fails), PA_ERR_ARG for a path already written in the
 * transaction, PA_ERR_MEMORY.
 */
pa_status pa_output_file_open(const char *path, pa_output_file **file,
                              FILE **fp);
/**
 * Complete file (in/out: freed, also on failure): flush, sync and close
 * its stream, every write error checked, then rename the temporary onto the
 * path, or, inside a transaction, leave it for pa_output_commit. On failure
 * the temporary is removed and the transaction fails. Not collective.
 * Returns PA_ERR_IO naming the path.
 */
pa_status pa_output_file_commit(pa_output_file *file);
/** Drop file (in/out: freed; NULL allowed): close its stream and remove
 *  the temporary (an open transaction then fails). Not collective. */
void pa_output_file_abort(pa_output_file *file);
/**
 * Install handlers of SIGINT and SIGTERM that remove the temporaries of every
 * output being written (async-signal-safe calls only), then end the process
 * by the signal's default action. A signal that is ignored or already has a
 * handler is left alone. The handler runs in the thread that receives the
 * signal: block SIGINT/SIGTERM in threads that may free output names while
 * another thread runs it (the padapt CLI blocks them before MPI starts its
 * threads). Process-wide, not collective. Returns PA_ERR_INTERNAL if
 * sigaction fails.
 */
pa_status pa_output_handle_signals(void);

/* ------------------------------------------------------------------------ */
/* Sequential remeshers (plug-in interface)                                 */
/* ------------------------------------------------------------------------ */

/** Outcome of a remesh, in Mmg's three levels. */
typedef enum pa_remesh_outcome {
  PA_REMESH_SUCCESS = 0,       /**< target reached, mesh valid */
  PA_REMESH_TARGET_MISSED = 1, /**< mesh valid, but some edges/qualities off target */
  PA_REMESH_FAILED = 2         /**< failed; the mesh was left as it was given */
} pa_remesh_outcome;

/** Where a running adaptation stands (given to pa_remesh_opts.progress). */
typedef struct pa_progress {
  const char *stage;     /**< "pass" (a remesher's) or "iteration" (the
                              parallel loop's) */
  int step;              /**< pass or iteration number, from 1 */
  double nelem;          /**< elements now (over every rank in parallel) */
  double nelem_initial;  /**< elements when the adaptation started */
  double nelem_expected; /**< the metric's estimate of the final count
                              (complexity over the unit simplex volume;
                              0: unknown) */
  double done;           /**< the share done ([0, 1]; -1: not measured):
                              for an iteration the share of elements that
                              meet their criterion, for a pass the share
                              of edges in range on a sample of about
                              PA_PROGRESS_SAMPLE elements */
  double elapsed;        /**< seconds since the adaptation started */
} pa_progress;

/** Elements sampled by a remesher pass to measure pa_progress.done. */
#define PA_PROGRESS_SAMPLE 4000

/** A progress callback; ctx is the caller's. It must not call padapt. */
typedef void (*pa_progress_fn)(const pa_progress *p, void *ctx);

/** A local parameter (Mmg's parameter file): the entities of one kind with
 *  one reference get their own size bounds and Hausdorff distance. At a
 *  vertex of such entities the local hmin/hmax replace the global ones
 *  (several local parameters at a vertex: the largest hmin and the
 *  smallest hmax, hmax winning a conflict); the local hausd bounds the
 *  boundary entities of that reference (kind PA_BOUNDARY; on elements it
 *  has no effect). A bound <= 0 keeps the global value. */
typedef struct pa_local_param {
  int kind;    /**< PA_ELEMENT or PA_BOUNDARY (pa_entity) */
  int ref;     /**< the entities' reference */
  double hmin, hmax, hausd;
} pa_local_param;

/** Options common to every remesher (the CLI's -hmin, -hmax, ... flags). */
typedef struct pa_remesh_opts {
  double hmin;      /**< minimal size (<= 0: none) */
  double hmax;      /**< maximal size (<= 0: none) */
  double hsiz;      /**< > 0: constant isotropic size, replaces the metric */
  double hgrad;     /**< gradation: bound on the size ratio along an edge of
                         unit length (Mmg's -hgrad); <= 1 (e.g. -1): off */
  double hgradreq;  /**< the same from required (frozen) vertices towards the
                         others (Mmg's -hgradreq); <= 1: they constrain
                         nothing */
  double hausd;     /**< max distance of the new boundary to the reconstructed one */
  double angle;     /**< ridge/corner detection angle in degrees (-ar) */
  int no_angle;     /**< -nr: no corner/ridge detection by angle */
  int no_insert;    /**< -noinsert: no split nor collapse */
  int no_swap;      /**< -noswap */
  int no_move;      /**< -nomove */
  int no_surf;      /**< -nosurf: boundary left unchanged (3D) */
  int verbosity;
  /** Expert. 1: the caller guarantees a valid, conforming mesh (as
   *  pa_mesh_check would find it), so pa_remesh skips that check (the
   *  parallel loop's pieces, built valid; default 0) */
  int trusted;
  /** Expert. 1: pa_remesh leaves report->fidelity empty and carries no
   *  copy of the caller's metric (the parallel loop's pieces; default 0) */
  int no_stats;
  /** Called by the remesher after each pass (may be NULL; the parallel
   *  loop's pieces never call it): a remesher fills stage, step and nelem,
   *  pa_remesh adds nelem_initial, nelem_expected and elapsed.
   *  pa_dmesh_adapt calls it after each tag pass, on every rank with the
   *  same figures. */
  pa_progress_fn progress;
  void *progress_ctx;
  /** Local parameters per reference (the CLI's -f FILE; NULL, 0: none);
   *  the array must live as long as the options are used. */
  const pa_local_param *local;
  int nlocal;
  /** Memory bound in MB (<= 0: none): pa_remesh refuses a metric whose
   *  output would not fit, and holds padapt's memory under it for the call
   *  (pa_memory_set_limit; a lower bound already set stays) */
  double mem_mb;
  /** The model of a classified mesh (NULL: none; it must outlive the
   *  options' use): new boundary vertices go onto their entity (the
   *  remesher's own reconstruction when the kernel fails), boundary
   *  vertices slide along it, ridges and corners are the model's curves
   *  and points only (no detection by angle), and hausd bounds the sizes
   *  at boundary vertices by the model's curvature (h <= sqrt(8 hausd /
   *  kappa)) when the geometry has a curvature callback. pa_dmesh_adapt
   *  takes one for a mesh distributed from a classified one, without
   *  checkpoints (they do not keep the classification). */
  const pa_geometry *geometry;
} pa_remesh_opts;

/** Fill *opts (out) with the defaults: no hmin/hmax/hsiz, hgrad
 *  PA_DEFAULT_HGRAD, hgradreq PA_DEFAULT_HGRADREQ, hausd PA_DEFAULT_HAUSD,
 *  angle PA_DEFAULT_ANGLE, the rest 0. Not collective. */
void pa_remesh_opts_default(pa_remesh_opts *opts);

/** What carrying the element and boundary fields through a remesh did
 *  (all zero when the mesh has none; docs/guide/fields.md). */
typedef struct pa_transfer_report {
  int nfield;        /**< element and boundary fields carried */
  long nfast;        /**< new elements inside one old element (no clipping) */
  long nclip;        /**< new elements intersected with the old ones */
  long nout;         /**< element values outside the range of the old
                          elements they overlap (round-off in mode
                          CONSERVATIVE; 0 in mode BOUNDED) */
  /** The largest change of the integral of an element field (any field,
   *  any component) relative to the integral of its absolute value:
   *  round-off where the boundary does not move. */
  double defect;
  /** Measure of the new elements not covered by the old ones, and of the
   *  old elements not covered by the new ones, relative to the old
   *  domain's measure: 0 but for round-off unless the boundary moved. */
  double uncovered, lost;
  double time_s;     /**< seconds spent */
  double cpu_s;      /**< CPU seconds the calling thread spent (which the
                          load of the machine does not inflate) */
} pa_transfer_report;

/** What a remesh did. */
typedef struct pa_remesh_report {
  /** The remesher's verdict on the metric it worked with. */
  pa_remesh_outcome outcome;
  long nsplit, ncollapse, nswap, nmove;
  int npass;
  double time_s;
  /** CPU seconds the calling thread spent in the remesher (its thread CPU
   *  clock): the remeshing work, which does not grow with the load of the
   *  machine as time_s does. Filled by pa_remesh. */
  double cpu_s;
  /** Filled by pa_remesh unless opts->no_stats (not by remesher callbacks). */
  pa_fidelity fidelity;
  /** Filled by pa_remesh (not by remesher callbacks). */
  pa_transfer_report transfer;
  /** With opts->geometry: the new or moved boundary points put on the
   *  model, those left on the remesher's reconstruction because the kernel
   *  failed, and the seconds spent in the kernel. */
  long nproject, nproject_failed;
  double project_s;
} pa_remesh_report;

/**
 * A sequential remesher. remesh() adapts `mesh` in place to its metric (the
 * mesh always carries one: the caller sets it, from -hsiz if needed). Entities
 * flagged PA_FLAG_REQUIRED are frozen and must come back bit for bit: a frozen
 * element keeps its vertices (coordinates, references, metric, fields), a
 * frozen vertex is never moved or removed, no edge of a frozen element is
 * split, collapsed or swapped. User fields are interpolated onto new vertices.
 * remesh's parameters: ctx (the remesher's ctx), mesh (in/out), opts, report
 * (out: outcome and counts; pa_remesh fills the rest). It returns
 * PA_SUCCESS with report->outcome set (on PA_REMESH_FAILED the mesh is as
 * given), or an error status for a hard error (also leaving the mesh as
 * given; pa_set_error gives the message). Not collective: the parallel
 * driver calls it on one piece.
 */
typedef struct pa_remesher {
  const char *name;
  /** Bit mask of supported dimensions: 1 << 2 for 2D, 1 << 3 for 3D. */
  unsigned dims;
  pa_status (*remesh)(void *ctx, pa_mesh *mesh, const pa_remesh_opts *opts,
                      pa_remesh_report *report);
  void *ctx;
} pa_remesher;

/** Returns the built-in remesher (2D triangles and 3D tetrahedra), a static
 *  object. Not collective. */
const pa_remesher *pa_remesher_builtin(void);

/**
 * Remesh mesh (in/out) through the remesher r with opts (NULL: the
 * defaults): checks the input (valid mesh, metric present or opts->hsiz >
 * 0), prepares the metric (hsiz replaces the caller's; then hmin/hmax and
 * the gradation hgrad/hgradreq), calls r->remesh and times it, then
 * (unless opts->no_stats) measures the result in the caller's metric and
 * in the metric used (report->fidelity; the caller's metric travels
 * through the remesher as the vertex field "metric:user", removed before
 * return). The mesh keeps the metric used, interpolated at new vertices.
 * *report (out, may be NULL): the outcome, counts, time and fidelity. Not
 * collective. Returns PA_SUCCESS with report->outcome SUCCESS or
 * TARGET_MISSED (a valid mesh) or FAILED (the mesh as given); or an error,
 * the mesh as given: PA_ERR_ARG for options out of range or no metric,
 * PA_ERR_UNSUPPORTED for a dimension r does not handle, PA_ERR_MESH or
 * PA_ERR_METRIC from pa_mesh_check (unless opts->trusted), PA_ERR_MEMORY
 * (also, unless opts->trusted, for a metric whose output would not fit in
 * the available memory, estimated from its complexity, before any work),
 * or the remesher's error.
 */
pa_status pa_remesh(const pa_remesher *r, pa_mesh *mesh,
                    const pa_remesh_opts *opts, pa_remesh_report *report);

/* ------------------------------------------------------------------------ */
/* Distributed mesh (MPI)                                                   */
/* ------------------------------------------------------------------------ */

/*
 * A mesh distributed over the ranks of an MPI communicator (2D or 3D), in the
 * spirit of PaMPA. Ownership rule (see docs/design/DMESH.md):
 *  - every element is owned by exactly one rank (its part);
 *  - a vertex is owned by the lowest rank owning an element that contains it;
 *  - a boundary entity or a feature edge is owned by the lowest rank owning an
 *    element that contains all its vertices.
 * Ghosts: with overlap K in {0, 1, 2, ...}, ghost layer k holds the elements
 * that share a vertex with the owned elements or layers < k; every vertex of
 * a local element is local (owned or ghost), and so is every boundary entity
 * or edge contained in a local element. Overlap 0 still has ghost vertices:
 * the interface vertices owned by another rank.
 * Local numbering of each entity kind: the nowned owned entities first,
 * [0, nowned), then the ghosts, [nowned, nlocal). Every entity has a 64-bit
 * global id, unique per kind and kept by redistribution and file round trips.
 * The local mesh (owned + ghost entities, same numbering) is a pa_mesh with
 * the metric and user fields (on vertices, elements, boundary entities) of
 * the distributed mesh; they follow the entities through every change
 * (redistribution, reordering, files, gathering, adaptation).
 * All point-to-point traffic goes through one exchange layer (a star forest
 * per entity kind, roots = owned entities, leaves = ghost copies).
 */
typedef struct pa_dmesh pa_dmesh;

/**
 * Distribute a mesh held by rank root. Collective. The root sends contiguous
 * blocks of the mesh to the ranks one at a time (it never holds more than the
 * input plus one block in flight), then the ranks partition the dual graph
 * (elements sharing a face) with PT-Scotch and migrate to the final parts.
 * Global ids are the 0-based indices of the input. comm: the ranks (dm
 * keeps a duplicate); mesh: the mesh on root (not modified), ignored
 * elsewhere (may be NULL); overlap: ghost layers (>= 0); *dm (out): the
 * distributed mesh (pa_dmesh_destroy it), NULL on failure. Returns the
 * same status on every rank: PA_ERR_ARG for a bad root or overlap,
 * PA_ERR_MESH on an inconsistent mesh (vertex out of range, entity in no
 * element, a face in three elements), PA_ERR_PARTITION, PA_ERR_MEMORY,
 * PA_ERR_MPI.
 */
pa_status pa_dmesh_distribute(MPI_Comm comm, int root, pa_mesh *mesh,
                              int overlap, pa_dmesh **dm);

/**
 * Read a distributed mesh. Collective. path is either a sequential mesh file
 * (any format of pa_mesh_read; read on rank 0, then pa_dmesh_distribute) or
 * a distributed set written by pa_dmesh_write (see pa_dmesh_is_set) by any
 * number of ranks: with as many ranks as writers each rank reads its own
 * file; otherwise the files are shared out and the mesh is repartitioned.
 * Every rank file is checked against the set's manifest OUT.manifest (size,
 * FNV-1a checksum, counts) and its own header: a missing file, a stale file
 * of another write or a modified one gives the same error on every rank,
 * naming the file. A set without manifest gets the header checks only.
 * overlap: ghost layers (>= 0); *dm (out): the distributed mesh, NULL on
 * failure. Returns the same status on every rank: the errors of
 * pa_mesh_read and pa_dmesh_distribute, PA_ERR_IO or PA_ERR_FORMAT naming
 * a rank file or the manifest.
 */
pa_status pa_dmesh_read(MPI_Comm comm, const char *path, int overlap,
                        pa_dmesh **dm);

/**
 * Write a distributed set. Collective. For path "OUT.meshb" (or "OUT.mesh"),
 * rank r writes OUT.<r>.meshb: its owned elements with their vertices and
 * boundary entities as a standard Medit file (readable by any Medit reader),
 * plus ParMmg's vertex communicators and padapt keywords (global ids, owners,
 * number of ranks, metric and fields, and the user values: pa_dmesh_read
 * recreates them by name, kind, reference and type -- a value of a derived
 * datatype comes back as MPI_BYTE x its size); rank 0 also writes OUT.pvtu
 * referencing OUT.<r>.vtu (owned elements, cell fields "rank" and "ref"),
 * which ParaView opens, and the manifest OUT.manifest (number of ranks,
 * counts, size and FNV-1a 64 checksum of every rank file). All the files are
 * one output transaction per rank (pa_output_begin; or part of the caller's
 * open transaction), committed only when every rank wrote all of its files;
 * the commit also removes a file at path itself and the rank files of ranks
 * beyond the communicator's size, which would shadow or pollute the set.
 * dm is in/out only for its cached structures. Returns the same status on
 * every rank: PA_ERR_IO naming a file, PA_ERR_UNSUPPORTED for another
 * extension, PA_ERR_MEMORY; nothing is written then.
 */
pa_status pa_dmesh_write(pa_dmesh *dm, const char *path);

/**
 * Returns 1 if path ("OUT.meshb" or "OUT.mesh") names a distributed set:
 * the file itself does not exist but OUT.manifest or OUT.0.meshb does; 0
 * otherwise. Not collective.
 */
int pa_dmesh_is_set(const char *path);

/**
 * Read any mesh at path onto rank root of comm: a sequential file is read
 * by root alone; a distributed set is read by all ranks and gathered on
 * root. Collective. *mesh (out) is set on root, NULL elsewhere. Returns the
 * errors of pa_mesh_read (on root only, for a sequential file) or of
 * pa_dmesh_read and pa_dmesh_gather (the same on every rank).
 */
pa_status pa_dmesh_read_gathered(MPI_Comm comm, int root, const char *path,
                                 pa_mesh **mesh);

/**
 * Gather the owned entities of every rank into one mesh on rank root,
 * numbered by global id (so that gathering a freshly distributed mesh gives
 * back the input). Metric and vertex fields are gathered; user values that are
 * vertex values of MPI_DOUBLE on all vertices become vertex fields. Collective;
 * *mesh (out) is set on root, NULL elsewhere. Returns the same status on
 * every rank: PA_ERR_ARG for a bad root, PA_ERR_MEMORY (root holds the whole
 * mesh), PA_ERR_MPI.
 */
pa_status pa_dmesh_gather(pa_dmesh *dm, int root, pa_mesh **mesh);

/** Destroy dm (in/out; NULL allowed). Collective (frees a communicator). */
void pa_dmesh_destroy(pa_dmesh *dm);

/** Returns the communicator of dm (a private duplicate of the caller's:
 *  do not free it). Not collective. */
MPI_Comm pa_dmesh_comm(const pa_dmesh *dm);
/** Returns the dimension of dm (2 or 3). Not collective. */
int pa_dmesh_dim(const pa_dmesh *dm);
/** Returns the number of ghost element layers of dm. Not collective. */
int pa_dmesh_overlap(const pa_dmesh *dm);
/** Returns the owned entities of a kind on this rank (they are the local
 *  indices [0, n)). Not collective. */
pa_idx pa_dmesh_nowned(const pa_dmesh *dm, pa_entity kind);
/** Returns the local (owned + ghost) entities of a kind on this rank. Not
 *  collective. */
pa_idx pa_dmesh_nlocal(const pa_dmesh *dm, pa_entity kind);
/** Returns the global number of entities of a kind (the sum of the owned
 *  counts; the same on every rank). Not collective. */
pa_gid pa_dmesh_nglobal(const pa_dmesh *dm, pa_entity kind);
/** Returns the global ids of the local entities of a kind (nlocal), owned
 *  by dm. Not collective. */
const pa_gid *pa_dmesh_gids(const pa_dmesh *dm, pa_entity kind);
/** Returns the owner rank of each local entity of a kind (nlocal), owned
 *  by dm. Not collective. */
const int *pa_dmesh_owners(const pa_dmesh *dm, pa_entity kind);
/** Returns the layer of each local element (0 owned, k for a ghost of
 *  layer k), owned by dm. Not collective. */
const uint8_t *pa_dmesh_elem_layers(const pa_dmesh *dm);
/** The ranks this rank exchanges with into *ranks (out, owned by dm);
 *  returns their number. Not collective. */
int pa_dmesh_neighbours(const pa_dmesh *dm, const int **ranks);
/**
 * Returns the local mesh of dm: owned and ghost entities in local
 * numbering. Callers may read it and change coordinates, references, flags,
 * metric and fields (then call pa_dmesh_sync_mesh to make ghosts equal
 * owners again); adding or removing entities breaks the distribution. Not
 * collective.
 */
pa_mesh *pa_dmesh_mesh(pa_dmesh *dm);
/** Copy the coordinates, references, flags, metric and fields of the owned
 *  entities of dm (in/out) to their ghosts. Collective. Returns the same
 *  status on every rank: PA_ERR_MEMORY, PA_ERR_MPI. */
pa_status pa_dmesh_sync_mesh(pa_dmesh *dm);
/** Returns the bytes used by this rank's part of dm (mesh, ids, exchange
 *  patterns, values). Not collective. */
size_t pa_dmesh_memory_used(const pa_dmesh *dm);

/* ---- values attached to entities ---- */

/** A user value: ncomp items of an MPI datatype per entity of one kind. */
typedef struct pa_dmesh_value pa_dmesh_value;

/**
 * Attach to dm (in/out) a value called name (unique, shorter than 64
 * bytes), initialised to zero: ncomp items of type per entity of a kind,
 * or only of the entities of reference ref (a sub-class, e.g. boundary
 * faces of reference 3); ref = -1 for all. type: any MPI datatype whose
 * extent equals its size (MPI_DOUBLE, MPI_INT, a contiguous type, MPI_BYTE
 * with ncomp = bytes...); reductions need a predefined type. Values follow
 * the entities through redistribution and reordering. *value (out) belongs
 * to dm (freed by pa_dmesh_value_remove or pa_dmesh_destroy). Collective
 * (same calls in the same order on every rank). Returns the same status on
 * every rank: PA_ERR_ARG for a bad kind, ncomp or type, or a name in use
 * or too long, PA_ERR_MEMORY.
 */
pa_status pa_dmesh_value_add(pa_dmesh *dm, pa_entity kind, const char *name,
                             MPI_Datatype type, int ncomp, int32_t ref,
                             pa_dmesh_value **value);
/** Returns the value of dm called name, NULL if none. Not collective. */
pa_dmesh_value *pa_dmesh_value_find(pa_dmesh *dm, const char *name);
/** Detach value from dm (in/out) and free it. Collective. Returns
 *  PA_ERR_ARG for a value that is not dm's. */
pa_status pa_dmesh_value_remove(pa_dmesh *dm, pa_dmesh_value *value);
/**
 * Returns the data of value, n blocks of ncomp items (read and written by
 * the caller), valid until the distribution changes
 * (pa_dmesh_redistribute, pa_dmesh_reorder); *n (out, may be NULL) the
 * number of local entities holding it (all local entities of the kind when
 * ref = -1), *nowned (out, may be NULL) the number of those that are owned
 * (the first ones). Not collective.
 */
void *pa_dmesh_value_data(pa_dmesh_value *value, pa_idx *n, pa_idx *nowned);
/** Returns the local entity of each block of a sub-class value (NULL when
 *  ref = -1: block i is entity i), owned by the value. Not collective. */
const pa_idx *pa_dmesh_value_entities(const pa_dmesh_value *value);
/** The *kind, *name, *type, *ncomp and *ref (out, each may be NULL) of
 *  value. Not collective. */
void pa_dmesh_value_info(const pa_dmesh_value *value, pa_entity *kind,
                         const char **name, MPI_Datatype *type, int *ncomp,
                         int32_t *ref);

/* ---- exchange ---- */

/**
 * Owner -> ghost update of value (in/out) of dm: every ghost block receives
 * its owner's. pa_dmesh_halo = begin + end; between begin and end the
 * caller may work on owned data (not on ghosts); only one exchange per
 * value at a time. Collective over the neighbour ranks (every rank must
 * call it); the status is this rank's. begin and end never allocate, so
 * they fail only on invalid arguments (PA_ERR_ARG: a value not set up, an
 * exchange already in flight, an end without its begin) or an MPI error
 * (PA_ERR_MPI naming the call).
 */
pa_status pa_dmesh_halo(pa_dmesh *dm, pa_dmesh_value *value);
pa_status pa_dmesh_halo_begin(pa_dmesh *dm, pa_dmesh_value *value);
pa_status pa_dmesh_halo_end(pa_dmesh *dm, pa_dmesh_value *value);
/**
 * Ghost -> owner reduction: owner = op(owner, each ghost copy), op MPI_SUM,
 * MPI_MIN or MPI_MAX (any predefined MPI_Op on a predefined type). Ghost
 * blocks are left as they are (follow with pa_dmesh_halo to update them).
 * Contributions are combined in rank order, so results do not depend on
 * timing. Same parameters, collective rules and errors as pa_dmesh_halo
 * (and PA_ERR_ARG for a type that is not predefined).
 */
pa_status pa_dmesh_reduce(pa_dmesh *dm, pa_dmesh_value *value, MPI_Op op);
pa_status pa_dmesh_reduce_begin(pa_dmesh *dm, pa_dmesh_value *value);
pa_status pa_dmesh_reduce_end(pa_dmesh *dm, pa_dmesh_value *value, MPI_Op op);

/* ---- iterators and adjacency ---- */

/** Entity sets to iterate over. */
typedef enum pa_dmesh_set {
  PA_OWNED,    /**< owned entities */
  PA_GHOST,    /**< ghost entities */
  PA_LOCAL,    /**< owned and ghost */
  PA_INTERIOR, /**< owned, none of whose vertices has a copy on another rank:
                    computable without any halo data */
  PA_FRONTIER  /**< owned, not interior */
} pa_dmesh_set;

/** Iterator state (plain struct, no allocation). */
typedef struct pa_dmesh_iter {
  const pa_idx *list; /**< explicit list, or NULL for the range [first, end) */
  pa_idx first, end, pos;
} pa_dmesh_iter;

/** Start *it (out) iterating over a set of the entities of a kind of dm
 *  (in/out: builds its interior and frontier lists on first use). Not
 *  collective. Returns PA_ERR_ARG for a bad kind or set, PA_ERR_MEMORY. */
pa_status pa_dmesh_iter_init(pa_dmesh *dm, pa_entity kind, pa_dmesh_set set,
                             pa_dmesh_iter *it);
/** Move it (in/out) on: the next local entity index into *i (out); returns
 *  1, or 0 when the set is exhausted. Not collective. */
static inline int pa_dmesh_iter_next(pa_dmesh_iter *it, pa_idx *i) {
  if (it->pos >= it->end) return 0;
  *i = it->list ? it->list[it->pos] : it->pos;
  it->pos++;
  return 1;
}
/** Returns the number of entities of the set of it (without moving it).
 *  Not collective. */
static inline pa_idx pa_dmesh_iter_count(const pa_dmesh_iter *it) {
  return it->end - it->first;
}

/** Returns the dim+1 local vertices of local element e of dm (owned by dm;
 *  e is not checked). Not collective. */
const pa_idx *pa_dmesh_elem_verts(pa_dmesh *dm, pa_idx e);
/** The local elements of dm (in/out: builds the cached balls) containing
 *  local vertex v: *n (out) of them in (*elems)[0..n) (out, owned by dm).
 *  Complete for owned vertices when overlap >= 1. Not collective. Returns
 *  PA_ERR_ARG for v out of range, PA_ERR_MEMORY. */
pa_status pa_dmesh_vert_elems(pa_dmesh *dm, pa_idx v, pa_idx *n,
                              const pa_idx **elems);
/**
 * The face neighbours of local element e of dm (in/out: builds the cached
 * adjacency) into *nb (out, dim+1 entries owned by dm): nb[i] is the local
 * element across the face opposite vertex i, or -1 if there is none in the
 * local mesh (a domain boundary face, or -- for owned elements with overlap
 * 0 and ghosts of the last layer -- a face whose neighbour is not local).
 * Not collective. Returns PA_ERR_ARG for e out of range, PA_ERR_MEMORY.
 */
pa_status pa_dmesh_elem_neighbours(pa_dmesh *dm, pa_idx e, const pa_idx **nb);
/** The (one or two) local elements of dm (in/out: builds the cached
 *  adjacency) having boundary entity b as a face into e (out; e[1] = -1
 *  if only one). Not collective. Returns PA_ERR_ARG for b out of range,
 *  PA_ERR_MEMORY. */
pa_status pa_dmesh_bdry_elems(pa_dmesh *dm, pa_idx b, pa_idx e[2]);

/**
 * Renumber owned and ghost entities separately for locality: elements by
 * the Hilbert curve index of their centroid, vertices by first use in the
 * new element order, boundary entities and edges by their first vertex.
 * Owned entities stay first; values, ids and owners follow. dm: in/out.
 * Collective (rebuilds the exchange patterns). Returns the same status on
 * every rank: PA_ERR_MEMORY, PA_ERR_MPI. (Another element ordering:
 * pa_dmesh_reorder_by, in the expert section.)
 */
pa_status pa_dmesh_reorder(pa_dmesh *dm);

/**
 * Move elements to new owners and migrate their vertices, boundary entities,
 * edges and every value; ghosts are rebuilt, global ids kept. newpart: new
 * owner rank of each owned element, or NULL to repartition with PT-Scotch on
 * the distributed dual graph (weights: one per owned element, or NULL for
 * unit weights), parts being remapped to the ranks that already hold most of
 * them. dm: in/out. Collective. Returns the same status on every rank:
 * PA_ERR_ARG for a part out of [0, size), PA_ERR_PARTITION, PA_ERR_MEMORY,
 * PA_ERR_MPI.
 */
pa_status pa_dmesh_redistribute(pa_dmesh *dm, const int *newpart,
                                const double *weights);

/**
 * Even out the load (weights: one per owned element, or NULL for element
 * counts) when a rank holds more than tol (>= 1) times the mean, by moving
 * only the excess across the existing interfaces: diffusion flows on the
 * graph of ranks, each served by a band of elements along the interface,
 * then pa_dmesh_redistribute. Nothing moves when the load is within tol.
 * Falls back to a full PT-Scotch repartition when a rank holds more than
 * 1.5 times the mean, the ranks' graph is disconnected or the flows cannot
 * be served. dm: in/out; *nmoved (out, may be NULL): elements moved, 0 if
 * none, -1 after a fallback. Collective. Returns the same status on every
 * rank: PA_ERR_ARG for tol < 1, the errors of pa_dmesh_redistribute.
 */
pa_status pa_dmesh_rebalance(pa_dmesh *dm, const double *weights, double tol,
                             pa_gid *nmoved);

/**
 * Check dm (in/out only for its cached structures): global ids unique and
 * counts consistent, every ghost equal to its owner (coordinates,
 * reference, vertices by global id), owners following the ownership rule,
 * conformity across ranks (no face shared by more than two elements),
 * positive orientation of owned elements, owned-first numbering.
 * Collective. Returns the same status on every rank: PA_ERR_MESH with a
 * message naming the entity, PA_ERR_MEMORY, PA_ERR_MPI.
 */
pa_status pa_dmesh_check(pa_dmesh *dm);

/**
 * A checksum of dm and its values into *checksum (out, the same on every
 * rank) that depends neither on the number of ranks nor on the numbering:
 * the sum over owned entities of hashes of their coordinates, references,
 * sorted vertex coordinates and orientation, and value bytes. Collective.
 * Returns the same status on every rank: PA_ERR_MEMORY, PA_ERR_MPI.
 */
pa_status pa_dmesh_checksum(pa_dmesh *dm, uint64_t *checksum);

/**
 * The partition quality of dm, on every rank: nelem (out, may be NULL; an
 * array of the communicator's size) the owned elements per rank,
 * *imbalance (out) max/mean and *edgecut (out) the faces between elements
 * of different owners. Collective. Returns the same status on every rank:
 * PA_ERR_MEMORY, PA_ERR_MPI.
 */
pa_status pa_dmesh_partition_stats(pa_dmesh *dm, pa_gid *nelem,
                                   double *imbalance, pa_gid *edgecut);

/* ------------------------------------------------------------------------ */
/* Parallel adaptation                                                      */
/* ------------------------------------------------------------------------ */

/*
 * pa_dmesh_adapt adapts a distributed mesh to its metric with any sequential
 * remesher, by the iterative piece algorithm of PaMPA (Lachat, Dobrzynski,
 * Pellegrini): tag the elements to remesh, partition the tagged ones into
 * pieces with PT-Scotch, give each piece a frozen skin, gather each piece on
 * one process, remesh the pieces concurrently, put them back, and repeat
 * until no element is tagged; then repartition for balance. See
 * docs/design/ADAPT.md.
 */

/** Figures of one iteration (the same on every rank). Times are wall-clock
 *  seconds of each step, the maximum over the ranks. */
typedef struct pa_adapt_iter {
  int iter;            /**< 1-based */
  pa_gid ntagged;      /**< tagged elements at the start of the iteration */
  pa_gid nelem;        /**< elements after the iteration */
  int npieces;
  int nfailed;         /**< pieces rolled back */
  double imbalance;    /**< estimated work of the most loaded rank / mean */
  double t_tag, t_pieces, t_gather, t_remesh, t_reintegrate;
  double remesh_busy;  /**< seconds spent remeshing, summed over the ranks */
  /** CPU seconds spent inside the remesher (pa_remesh_report.cpu_s of the
   *  pieces), summed over the ranks: the remeshing work */
  double remesh_cpu;
  /** The pieces' remesher operations (pa_remesh_report's counts), summed
   *  over the ranks: the remeshing work in counts the machine does not
   *  change */
  long nsplit, ncollapse, nswap, nmove;
  double bytes_moved;  /**< bytes of records sent between ranks */
  /** Peak bytes of padapt memory (pa_memory_peak's count) during each step,
   *  the maximum over the ranks. */
  double mem_tag, mem_pieces, mem_gather, mem_remesh, mem_reintegrate;
  /** Bytes of padapt memory held at the end of the reintegration (the
   *  distributed mesh, its values, the iteration's bookkeeping and whatever
   *  the caller holds), the maximum over the ranks. */
  double mem_after;
} pa_adapt_iter;

/** Options of pa_dmesh_adapt. */
typedef struct pa_adapt_opts {
  /** Options given to the remesher for every piece. hsiz, hmin and hmax are
   *  applied to the whole metric before the loop, then the gradation (hgrad,
   *  hgradreq); the pieces are remeshed without gradation. */
  pa_remesh_opts remesh;
  /** The sequential remesher (NULL: pa_remesher_builtin()). */
  const pa_remesher *remesher;
  /** Memory bound per process, in MB (<= 0: the memory available on each
   *  node, shared by its ranks): the number of pieces grows so that each
   *  piece's estimated remesher memory fits, and a metric whose whole output
   *  would not fit is refused (PA_ERR_MEMORY). A bound > 0 also holds
   *  padapt's memory under it on every rank for the call
   *  (pa_memory_set_limit): reaching it is an error on every rank. */
  double mem_mb;
  /** Tag elements whose quality is below this (default
   *  PA_DEFAULT_QUAL_THRESHOLD; <= 0: off). */
  double qual_threshold;
  /** 1: tag only the elements flagged PA_FLAG_USER (default 0: also the
   *  elements with an edge outside [0.7071, 1.4142) or a poor quality). */
  int user_tags_only;
  /** Maximum number of iterations (default PA_DEFAULT_MAX_ITER). */
  int max_iter;
  /** Pieces per process (default PA_DEFAULT_PIECES_PER_RANK). */
  int pieces_per_rank;
  /** Expert. Vertex layers of untagged elements added around the tagged
   *  ones (default PA_DEFAULT_SKIN_LAYERS, at least 1); up to 12 more
   *  while the pieces average fewer than min_piece_work elements. */
  int skin_layers;
  /** Expert. The same from the second iteration on (default
   *  PA_DEFAULT_SKIN_LAYERS_LATER, at least 1): its
   *  tagged elements lie next to the last skins, and each layer multiplies
   *  a piece's size by about 10 in 3D; a poor element forced by the closer
   *  frozen faces is tagged again (docs/design/ADAPT.md, Convergence). */
  int skin_layers_later;
  /** Expert. Smallest estimated work (about output elements) worth a piece
   *  of its own: fewer pieces are made when the tagged work is small
   *  (default PA_DEFAULT_MIN_PIECE_WORK; tests lower it to get many pieces
   *  on small meshes). */
  double min_piece_work;
  /** Expert. Smallest piece as a fraction of the mean number of elements
   *  per rank (default PA_DEFAULT_MIN_PIECE_RATIO): an iteration passes
   *  over the whole distributed mesh, so a small tagged set is remeshed in
   *  fewer, larger pieces (0: off). */
  double min_piece_ratio;
  /** Expert. Skip the final rebalance when the owned elements per rank are
   *  within this ratio of the mean (default PA_DEFAULT_REBALANCE_TOL;
   *  >= 1). */
  double rebalance_tol;
  /** Rebalance after the loop (pa_dmesh_rebalance: only the excess moves;
   *  default 1). */
  int rebalance;
  /** Expert. Check every remeshed piece (pa_mesh_check) before using it,
   *  and the result (pa_dmesh_check) after the loop: 1 always, 0 never, -1
   *  (default) only with a plug-in remesher (the built-in one is trusted;
   *  docs/BENCHMARKS.md has what the checks cost). A piece that fails the
   *  check is rolled back. Its skin and global ids are checked in every
   *  case. */
  int check_pieces;
  /** Called on every rank after each iteration with the same figures (may be
   *  NULL), e.g. to print a progress line on rank 0. */
  void (*progress)(const pa_adapt_iter *iter, void *ctx);
  void *progress_ctx;
  /** Checkpoint directory (NULL, the default: none). After each iteration
   *  (after the progress call) the distributed mesh with its values and the
   *  loop's state are written there: the set DIR/iter-K (K iterations done;
   *  see pa_dmesh_write) and, once every rank wrote its file, the text file
   *  DIR/checkpoint naming it, renamed into place; the older set is removed
   *  only then, so a run killed at any point leaves the latest complete
   *  checkpoint. The directory is created if missing (its parent must
   *  exist); pa_dmesh_adapt must then be called outside an output
   *  transaction. A checkpoint that cannot be written fails the call
   *  (PA_ERR_IO naming the file; the previous checkpoint stays).
   *  pa_dmesh_adapt_resume continues from it. */
  const char *checkpoint_dir;
} pa_adapt_opts;

#define PA_ADAPT_MAX_ITERS 64

/** What pa_dmesh_adapt did (the same on every rank). */
typedef struct pa_adapt_report {
  int nranks;
  int niter;
  int converged;       /**< 1: no element is left tagged */
  int stalled;         /**< 1: stopped because the tagged count stopped
                            decreasing (or max_iter was reached) */
  pa_gid nelem_initial, nelem_final, nvert_initial, nvert_final;
  pa_gid ntagged_left; /**< elements still tagged at the end */
  long npieces;        /**< pieces remeshed, all iterations */
  long nfailed;        /**< pieces rolled back, all iterations */
  double time_total;   /**< wall-clock seconds of the whole call */
  /** wall-clock seconds of each step, the slowest rank's, summed over the
   *  iterations (t_tag includes the tag that ends the loop) */
  double t_tag, t_pieces, t_gather, t_remesh, t_reintegrate, t_rebalance;
  /** wall-clock seconds measuring the result (fidelity), part of
   *  time_total; pa_remesh_report.time_s leaves its measurement out */
  double t_measure;
  double remesh_busy;  /**< seconds spent in the remesher, summed over ranks */
  /** CPU seconds spent inside the remesher, summed over the ranks and the
   *  iterations: the remeshing work, comparable with the sequential
   *  pa_remesh_report.cpu_s at any number of ranks */
  double remesh_cpu;
  /** The remesher's operations summed over the ranks and the iterations,
   *  comparable with the sequential pa_remesh_report's counts */
  long nsplit, ncollapse, nswap, nmove;
  double bytes_moved;  /**< bytes of records sent between ranks, all steps */
  size_t peak_memory;  /**< max over ranks of pa_memory_peak() at the end */
  size_t peak_rss;     /**< max over ranks of pa_peak_rss() at the end */
  int niter_recorded;  /**< entries of iters (at most PA_ADAPT_MAX_ITERS) */
  pa_adapt_iter iters[PA_ADAPT_MAX_ITERS];
  /** The result measured in the caller's metric and in the metric used
   *  (unless opts->remesh.no_stats). */
  pa_fidelity fidelity;
  /** The element and boundary fields carried through the pieces' remeshes:
   *  counts and times summed over the pieces and ranks; defect, uncovered
   *  and lost the largest over the pieces, each relative to its piece (a
   *  piece's frozen skin keeps its region: they are round-off unless it
   *  touches a boundary that moves). */
  pa_transfer_report transfer;
} pa_adapt_report;

/** Fill *opts (out) with the defaults: built-in remesher,
 *  pa_remesh_opts_default, no memory bound, the PA_DEFAULT_* of the
 *  parallel loop, rebalance on, pieces checked with a plug-in remesher only
 *  (NULL: nothing). Not collective. */
void pa_adapt_opts_default(pa_adapt_opts *opts);

/**
 * Adapt a distributed mesh to its metric (or to opts->remesh.hsiz) in place.
 * Collective; the same status and report on every rank. Entities never
 * touched keep their global ids and values, and so do the vertices the
 * remesher keeps inside a remeshed region and the elements, boundary
 * entities and edges it gives back unchanged (same vertices and
 * reference); new entities get fresh global
 * ids (ids stay unique, not contiguous) and zero user values. Metric and user
 * vertex fields of the local mesh are interpolated by the remesher; its
 * element and boundary fields are carried by pa_remesh on every piece, by
 * their transfer modes (the integral of a conservative field is kept to
 * round-off over the whole mesh where its boundary does not move).
 * Elements and boundary entities flagged PA_FLAG_REQUIRED are kept as they
 * are. A piece whose remesh fails is rolled back: its elements stay, still
 * tagged, and the mesh stays valid; if the tagged count stops decreasing the
 * loop stops with report->stalled = 1 and PA_SUCCESS (the mesh is valid).
 * report->converged is set when a tag pass over the final mesh finds
 * nothing, or when the loop ends (no progress, max_iter) with nothing
 * tagged clearly off (an edge of length 2.5 or more, a quality below 0.05);
 * otherwise report->stalled. dm: in/out; opts may be NULL (defaults);
 * *report (out, may be NULL): the same on every rank. Returns the same
 * status on every rank: PA_ERR_ARG for options out of range or no metric,
 * PA_ERR_UNSUPPORTED for a dimension the remesher does not handle,
 * PA_ERR_MEMORY (also for a metric whose output would not fit, estimated
 * from its complexity against opts->mem_mb per rank or the memory available
 * on each node, before any remeshing), PA_ERR_IO for a checkpoint that
 * cannot be written, PA_ERR_PARTITION, PA_ERR_MPI; the mesh is then not
 * usable (destroy it).
 */
pa_status pa_dmesh_adapt(pa_dmesh *dm, const pa_adapt_opts *opts,
                         pa_adapt_report *report);

/**
 * Resume the pa_dmesh_adapt run whose latest checkpoint is in dir (that
 * run's opts->checkpoint_dir) and carry it on to its end. Collective over
 * comm, which must have as many ranks as the run that wrote the checkpoint
 * (each rank reads back its own local mesh, in its own order): the result
 * is then the uninterrupted run's, bit for bit, and so is the report but
 * for its times (time_total adds the time spent before the checkpoint).
 * opts must be the options of that run: every option that can change the
 * result (all but progress, progress_ctx, checkpoint_dir and
 * remesh.verbosity) is compared with the checkpoint's, and a difference
 * fails naming the option; opts may be NULL (defaults). With
 * opts->checkpoint_dir set (dir itself or another directory) the resumed
 * run goes on writing checkpoints.
 *
 * dm: receives the adapted distributed mesh (pa_dmesh_destroy it), NULL on
 * failure. report: as pa_dmesh_adapt's (may be NULL).
 * Returns the same status on every rank: PA_ERR_ARG for another number of
 * ranks (the message names the checkpoint's) or other options; PA_ERR_IO or
 * PA_ERR_FORMAT for a missing, altered or inconsistent checkpoint, naming
 * the file (DIR/checkpoint, the set's manifest or a rank file); nothing is
 * written then.
 */
pa_status pa_dmesh_adapt_resume(MPI_Comm comm, const char *dir,
                                const pa_adapt_opts *opts, pa_dmesh **dm,
                                pa_adapt_report *report);

/**
 * The metric toolbox on dm (in/out), a distributed mesh of overlap 2 (the
 * recovery uses each vertex's 2-ring): pa_metric_from_hessian of component
 * comp (0-based) of vertex field `field` of the local mesh, and
 * pa_metric_from_levelset of field `field` (a scalar), with opts; the
 * result becomes the metric of the distributed mesh (every copy of a
 * vertex the same). *complexity (out, the same on every rank) is that of
 * the mesh's metric over the owned elements, summed over the ranks.
 * Collective. Without gradation the result does not depend on the number of
 * ranks (round-off apart). Return the same status on every rank: PA_ERR_ARG
 * for an overlap below 2, a field or component that does not exist, a mesh
 * without metric (complexity) or the options' errors of the sequential
 * functions, PA_ERR_MEMORY, PA_ERR_MPI.
 */
pa_status pa_dmesh_metric_from_hessian(pa_dmesh *dm, int field, int comp,
                                       const pa_metric_hessian_opts *opts);
pa_status pa_dmesh_metric_from_levelset(pa_dmesh *dm, int field,
                                        const pa_metric_levelset_opts *opts);
pa_status pa_dmesh_metric_complexity(pa_dmesh *dm, double *complexity);

/**
 * pa_mesh_levelset_cut on a distributed mesh dm (in/out, any overlap): the
 * level set is vertex field `field` of the local mesh (a scalar; after the
 * cut it is V at the added vertices). Each rank cuts its owned elements;
 * the copies of an edge cut on several ranks make one vertex (one global id
 * agreed by the edge's end ids), so the result is the sequential cut of the
 * same mesh, whatever the number of ranks: the same vertices, elements and
 * references. Kept entities keep their global ids and values, new ones get
 * fresh ids and zero values; then the distributed mesh is rebuilt with its
 * overlap. *report (out, may be NULL) is the same on every rank.
 * Collective. Returns the same status on every rank: PA_ERR_ARG as the
 * sequential one, or for a field that is not a scalar field of the mesh;
 * PA_ERR_MEMORY, PA_ERR_MPI; the mesh is then not usable (destroy it).
 */
pa_status pa_dmesh_levelset_cut(pa_dmesh *dm, int field,
                                const pa_levelset_opts *opts,
                                pa_levelset_report *report);

/**
 * The statistics of dm (in/out only for its cached structures) into *stats
 * (out, the same on every rank), equal to pa_mesh_stats of the gathered
 * mesh (each edge counted once over the ranks; sums may differ in the last
 * bits); valid is the outcome of pa_dmesh_check. Collective. Returns the
 * same status on every rank: PA_ERR_MEMORY, PA_ERR_MPI.
 */
pa_status pa_dmesh_stats(pa_dmesh *dm, pa_stats *stats);

/* ------------------------------------------------------------------------ */
/* Test hooks and expert knobs                                              */
/* ------------------------------------------------------------------------ */

/*
 * What a program rarely needs: the hooks the tests use to reach the error
 * paths, and the knobs that tune the algorithms (their defaults are
 * measured: docs/BENCHMARKS.md). The option structs above hold more knobs,
 * each marked "Expert" at its field: pa_remesh_opts.trusted and .no_stats
 * (what the parallel loop tells the remesher about its pieces),
 * pa_adapt_opts.skin_layers, .skin_layers_later, .min_piece_work,
 * .min_piece_ratio, .rebalance_tol and .check_pieces.
 */

/** Test hook: make the n-th next allocation of padapt fail (n >= 1; n = 0
 *  disables), whichever thread makes it, so that a test reaches every
 *  out-of-memory path (the CLI sets it from PADAPT_TEST_FAIL_ALLOC).
 *  Process-wide, not collective. */
void pa_memory_fail_after(long n);

/** Element orderings of pa_dmesh_reorder_by. */
typedef enum pa_dmesh_ordering {
  PA_ORDER_HILBERT = 0, /**< Hilbert curve index of the centroid (geometric) */
  PA_ORDER_SCOTCH = 1   /**< Scotch ordering (Gibbs-Poole-Stockmeyer,
                             bandwidth reducing) of the local dual graph
                             (faces), one group at a time (owned, then each
                             ghost layer): topological */
} pa_dmesh_ordering;

/**
 * pa_dmesh_reorder of dm (in/out) with a choice of element ordering, how
 * (pa_dmesh_reorder is PA_ORDER_HILBERT, measured the better of the two);
 * vertices, boundary entities and edges follow the new element order as
 * there. Collective. Returns the same status on every rank: PA_ERR_ARG for
 * another ordering, PA_ERR_PARTITION, PA_ERR_MEMORY, PA_ERR_MPI.
 */
pa_status pa_dmesh_reorder_by(pa_dmesh *dm, pa_dmesh_ordering how);

#ifdef __cplusplus
}
#endif
#endif /* PADAPT_H */
