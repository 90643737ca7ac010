/*
 * mesh.h -- the sequential simplex mesh (struct pa_mesh) shared by every
 * component. Structure of arrays, 0-based, 32-bit local indices.
 *
 * Invariants kept by the functions of src/mesh/:
 *  - nX <= capX for every entity kind; arrays of one kind grow together;
 *  - derived structures (adja, ball_start/ball) are either NULL or valid for
 *    the current elements: anything that changes elements or vertices must call
 *    pa__mesh_invalidate();
 *  - the metric and vertex fields have one value block per vertex (grown
 *    with the vertices, contents of new vertices set by whoever adds them);
 *    element fields one per element, with room for cape elements, and
 *    boundary fields one per boundary entity, room for capb: every growth
 *    of the elements or boundary entities grows their fields, and code
 *    that installs element or boundary arrays of its own (a reader, a
 *    remesher's write-back) does so on a mesh without such fields
 *    (pa_remesh holds them aside while the remesher runs).
 */
#ifndef PA_MESH_H
#define PA_MESH_H

#include "core/core.h"

/* Most user fields of a mesh on one kind of entity, and the longest name
 * of one. */
#define PA_MESH_MAX_FIELDS 16
#define PA_MESH_FIELD_NAME_LEN 64

typedef struct pa__field {
  char name[PA_MESH_FIELD_NAME_LEN];
  int ncomp;
  int transfer; /* pa_transfer, never PA_TRANSFER_DEFAULT */
  double *val;  /* (capv, cape or capb) * ncomp */
} pa__field;

/* A physical name (Gmsh $PhysicalNames): the name of the entities of
 * topological dimension dim (0-3) whose reference is tag. */
typedef struct pa__name {
  int dim;
  int32_t tag;
  char *name; /* NUL-terminated, allocated */
} pa__name;

/* A model entity of a classified mesh ($Entities of its .msh file): its
 * physical tags, the entities of one dimension less that bound it (signed
 * tags, as Gmsh lists them; a seam appears with both signs) and its box
 * (a point: its coordinates, twice). */
typedef struct pa__entity {
  int dim;
  int32_t tag;
  int nphys, nbound;
  int32_t *phys;  /* nphys physical tags */
  int32_t *bound; /* nbound signed tags of dim - 1 entities */
  double box[6];  /* min x y z, max x y z */
} pa__entity;

struct pa_mesh {
  int dim; /* 2 or 3 */
  /* the Dimension of the file it was read from (3 for a planar mesh stored
   * in 3D, and for Gmsh files), 0 when built in memory: which solution
   * files fit it (pa_mesh_metric_from_sol) */
  int file_dim;

  /* vertices */
  pa_idx nv;
  size_t capv;
  double *coord;   /* dim * capv */
  int32_t *vref;   /* capv */
  uint8_t *vflag;  /* capv */

  /* elements: triangles (2D) or tetrahedra (3D) */
  pa_idx ne;
  size_t cape;
  pa_idx *elem;    /* (dim+1) * cape */
  int32_t *eref;
  uint8_t *eflag;

  /* boundary entities: edges (2D) or triangles (3D) */
  pa_idx nb;
  size_t capb;
  pa_idx *bdry;    /* dim * capb */
  int32_t *bref;
  uint8_t *bflag;

  /* feature edges (3D only) */
  pa_idx ned;
  size_t caped;
  pa_idx *edge;    /* 2 * caped */
  int32_t *edref;
  uint8_t *edflag;

  /* metric: 0 (none), 1 (size), 3 (2D tensor) or 6 (3D tensor) per vertex */
  int met_ncomp;
  double *met;     /* met_ncomp * capv */

  /* user fields: on vertices, on elements, on boundary entities */
  int nfield;
  pa__field field[PA_MESH_MAX_FIELDS];
  int nefield;
  pa__field efield[PA_MESH_MAX_FIELDS];
  int nbfield;
  pa__field bfield[PA_MESH_MAX_FIELDS];

  /* physical names, sorted by (dim, tag), each (dim, tag) once */
  int nname;
  pa__name *names;

  /* classification (padapt.h, "Geometry"): the model entity of each
   * vertex (NULL both when the mesh is not classified; capv entries, grown
   * with the vertices), and the model's entities, sorted by (dim, tag) */
  uint8_t *vgdim;
  int32_t *vgtag;
  int nent;
  pa__entity *ents;

  /* derived structures, NULL when not built */
  pa_idx *adja;       /* (dim+1) * ne: (dim+1)*f + j, or -1 */
  pa_idx *ball_start; /* nv + 1 */
  pa_idx *ball;       /* ball_start[nv] */
  /* boundary lookup: open-addressing hash of sorted bdry vertex tuples */
  pa_idx *bhash;      /* bhash_cap slots, -1 empty */
  size_t bhash_cap;
};

/* Free the physical names (the mesh then has none). */
void pa__mesh_free_names(pa_mesh *mesh);
/* Replace the physical names of dst by copies of those of src. */
pa_status pa__mesh_copy_names(pa_mesh *dst, const pa_mesh *src);

/* The fields of mesh on entities at (PA_VERTEX, PA_ELEMENT or
 * PA_BOUNDARY; NULL for another kind) and, in *count, where their number
 * is kept. */
pa__field *pa__mesh_fields(pa_mesh *mesh, int at, int **count);
/* The mode a field on entities at gets for PA_TRANSFER_DEFAULT. */
int pa__transfer_default(int at);
/* Entity `to` of kind at (PA_ELEMENT or PA_BOUNDARY) takes the field values
 * of entity `from` (a piece of it made by a bisection). */
void pa__mesh_copy_values(pa_mesh *mesh, int at, pa_idx from, pa_idx to);
/* Zero the values of entities [i0, i1) (room reserved) of the fields of
 * mesh on entities at. */
void pa__mesh_zero_values(pa_mesh *mesh, int at, size_t i0, size_t i1);
/* Move the element and boundary fields of src into dst (whose own are
 * freed first), leaving src without any: the arrays are dst's now, sized
 * for src's capacities (the caller sizes them for dst's). */
void pa__mesh_move_cell_fields(pa_mesh *dst, pa_mesh *src);
/* Reallocate the element (at PA_ELEMENT) or boundary fields of mesh to
 * room for cap entities (contents kept up to the smaller size). */
pa_status pa__mesh_fields_realloc(pa_mesh *mesh, int at, size_t cap);

/* ---- classification: storage (mesh.c), lookup (classify.c) ---- */

/* Free the model entities (the mesh then has none). */
void pa__mesh_free_entities(pa_mesh *mesh);
/* Replace the model entities of dst by copies of those of src. */
pa_status pa__mesh_copy_entities(pa_mesh *dst, const pa_mesh *src);
/* Make mesh classified: vgdim/vgtag allocated for capv vertices, every
 * vertex (dim, 0) until set (no-op when already classified). */
pa_status pa__mesh_enable_entities(pa_mesh *mesh);
/* Make mesh unclassified (its model entities stay). */
void pa__mesh_disable_entities(pa_mesh *mesh);
/* The model entity (dim, tag) of the model's table, or NULL. */
const pa__entity *pa__mesh_entity(const pa_mesh *mesh, int dim, int32_t tag);
/* Vertices whose entity a remesh keeps: their coordinates (dim each),
 * entity dimension and tag, n of them, and their indices in the order of
 * their coordinates (lexicographic). */
typedef struct pa__kept {
  double *xyz;
  uint8_t *gdim;
  int32_t *gtag;
  pa_idx *order;
  pa_idx n;
} pa__kept;
void pa__kept_free(pa__kept *k);
/* The vertices of the classified mesh a remesh gives back where they are
 * with their entity: its points (corners, never moved), and with frozen
 * (NULL: none) the frozen vertices on points, curves and surfaces, whose
 * boundary cells a piece of the parallel loop may not hold. */
pa_status pa__mesh_kept_points(const pa_mesh *mesh, const uint8_t *frozen,
                               pa__kept *kept);
/* The vertices' entities of the classified mesh recomputed from its cells
 * (lowest dimension first: a vertex at one of the kept points (compared
 * exactly) has its entity; a vertex of a feature edge (3D) of positive
 * reference is on that curve; of a boundary entity on its curve (2D) or
 * surface (3D); else on the volume (3D) or surface (2D) of an element).
 * Cells of reference <= 0 (a piece's skin, unclassified) are passed
 * over. Allocates nothing. */
void pa__mesh_derive_entities(pa_mesh *mesh, const pa__kept *kept);

/* Free derived structures after a topological change. */
void pa__mesh_invalidate(pa_mesh *mesh);
/* Free the elements, boundary entities, edges, metric and fields (and the
 * derived structures), keeping the vertices and the names: what is left
 * is a mesh of nv vertices and no cells. */
void pa__mesh_drop_cells(pa_mesh *mesh);
/* The derived structures computed afresh, not cached (topo.c), for the
 * checker (check.c) to compare with the caches: the adjacency, the balls
 * and the boundary table (*pcap its capacity). */
pa_status pa__mesh_adja_compute(const pa_mesh *mesh, pa_idx **out);
pa_status pa__mesh_balls_compute(const pa_mesh *mesh, pa_idx **pstart,
                                 pa_idx **pball);
pa_status pa__mesh_bhash_compute(const pa_mesh *mesh, pa_idx **out,
                                 size_t *pcap);
/* Build the boundary table if it is not cached (topo.c). */
pa_status pa__mesh_bhash_build(pa_mesh *mesh);
/* Index of the listed boundary entity with vertices v (any order), or -1,
 * from the boundary table (built). */
pa_idx pa__mesh_bhash_find(const pa_mesh *mesh, const pa_idx *v);
/* The checker (check.c): pa_mesh_check but for the metric values, which the
 * metric component checks (pa__mesh_check_metric, metric/metric.h); input 0
 * leaves out what only a user's input must meet (manifold vertices, no two
 * vertices at one point): a piece of the parallel loop may touch itself at a
 * vertex. */
pa_status pa__mesh_check(pa_mesh *mesh, int input);
/* The part of pa__mesh_check a rank's part of a distributed mesh must meet
 * too (its faces on the partition's interfaces are not boundary entities):
 * indices, coordinates, every vertex used, orientation, conformity, and
 * neighbours on opposite sides of their faces (no element listed twice). */
pa_status pa__mesh_check_elements(pa_mesh *mesh);
/* No folded or overlapping elements around a vertex (2D) or an edge and a
 * boundary vertex (3D) (overlap.c); needs the adjacency and the balls
 * built. Part of pa__mesh_check for input meshes. */
pa_status pa__mesh_check_overlap(const pa_mesh *mesh);

/* Number of metric components of a full tensor in dimension dim (3 or 6). */
static inline int pa__tensor_ncomp(int dim) { return dim == 2 ? 3 : 6; }

/* Vertices of face i of element e (the face opposite local vertex i), in an
 * order that makes the face's normal point out of e. Writes dim indices.
 * Orientation convention: a triangle (v0,v1,v2) is positive when
 * counter-clockwise, a tetrahedron when det(v1-v0, v2-v0, v3-v0) > 0. Faces:
 *   triangle     0:(v1,v2)  1:(v2,v0)  2:(v0,v1)
 *   tetrahedron  0:(v1,v2,v3)  1:(v0,v3,v2)  2:(v0,v1,v3)  3:(v0,v2,v1)
 * For a positive element the face's outward normal is, in 2D, the edge
 * direction (b - a) turned clockwise, in 3D (b - a) x (c - a): boundary
 * entities oriented "outward" follow the same rule. */
void pa__elem_face(const pa_mesh *mesh, pa_idx e, int i, pa_idx *face);

/* Signed volume/area of the simplex with the given dim+1 vertex coordinates
 * (2D: cross(x1-x0, x2-x0)/2, 3D: det(x1-x0, x2-x0, x3-x0)/6), in plain
 * floating point. Inline: the per-element loops that call it (the tag's
 * quality, the statistics) would otherwise pay a call for a few
 * multiplications. */
static inline double pa__simplex_volume(int dim, const double *const *x) {
  if (dim == 2) {
    double ux = x[1][0] - x[0][0], uy = x[1][1] - x[0][1];
    double vx = x[2][0] - x[0][0], vy = x[2][1] - x[0][1];
    return 0.5 * (ux * vy - uy * vx);
  }
  double u[3], v[3], w[3];
  for (int k = 0; k < 3; k++) {
    u[k] = x[1][k] - x[0][k];
    v[k] = x[2][k] - x[0][k];
    w[k] = x[3][k] - x[0][k];
  }
  return (u[0] * (v[1] * w[2] - v[2] * w[1]) +
          u[1] * (v[2] * w[0] - v[0] * w[2]) +
          u[2] * (v[0] * w[1] - v[1] * w[0])) /
         6.0;
}

/* Exact orientation predicates (predicates.c): a value with the exact sign of
 * det(b-a, c-a) (2D) or det(b-a, c-a, d-a) (3D), 0 exactly when degenerate;
 * its magnitude is only approximate. Inputs finite. pa__orient dispatches on
 * dim with x[0..dim]. */
double pa__orient2d(const double *a, const double *b, const double *c);
double pa__orient3d(const double *a, const double *b, const double *c,
                    const double *d);
double pa__orient(int dim, const double *const *x);

/* Grow vertex arrays (and metric/fields) to hold at least n vertices. */
pa_status pa__mesh_grow_vertices(pa_mesh *mesh, size_t n);

/* Vertex balls as a CSR: the elements (ne of nve vertices in elem, indices
 * below nv) around vertex v are (*ball)[(*start)[v] .. (*start)[v+1]), in
 * increasing order. Both arrays are allocated here. pa__balls_of: only the
 * balls of the vertices with need[v] (the others empty; need NULL: all),
 * from one pass that collects their slots (few, in the dmesh build). */
pa_status pa__balls_of(const pa_idx *elem, pa_idx ne, int nve, pa_idx nv,
                       const uint8_t *need, pa_idx **pstart, pa_idx **pball);
pa_status pa__balls(const pa_idx *elem, pa_idx ne, int nve, pa_idx nv,
                    pa_idx **start, pa_idx **ball);

/* Unique edges of ne elements (nve vertex indices each, below nv) as a CSR:
 * each edge filed once under its endpoint of smaller key (key: one per
 * vertex, e.g. global ids, all distinct; NULL: the index), the other
 * endpoints of vertex a being (*other)[(*start)[a] .. (*start)[a+1]) in the
 * order first met over the elements. Two equal vertices of an element make
 * no edge. Linear time (counting, fill, then deduplication with a marker
 * array); 4 bytes per edge instance plus 12 per vertex. */
pa_status pa__edges_csr(const pa_idx *elem, pa_idx ne, int nve, pa_idx nv,
                        const pa_gid *key, size_t **start, pa_idx **other);

/* f[v] = 1 (mesh->nv entries) for the vertices whose metric a remesh keeps:
 * required vertices and the vertices of required elements and boundary
 * entities; 0 for the others. */
void pa__mesh_frozen_vertices(const pa_mesh *mesh, uint8_t *f);

#endif /* PA_MESH_H */
