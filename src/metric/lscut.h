/*
 * lscut.h -- the level-set cut (Mmg's -ls), written once for the sequential
 * mesh (pa_mesh_levelset_cut, lscut.c) and the distributed one
 * (pa_dmesh_levelset_cut, src/adapt/dlevelset.c): the steps that involve
 * other ranks go through the hooks of a pa__ls_ctx, as the metric toolbox's
 * go through a pa__metric_ctx.
 *
 * The cut works on "this rank's" elements [0, nelem), boundary entities
 * [0, nbdry) and feature edges [0, nedge) of a mesh (all of them
 * sequentially; the owned ones, numbered first, of a distributed mesh's
 * local mesh), whose vertices carry distinct keys (global ids; the index
 * sequentially). Added vertices are numbered nv + k in the output cells.
 */
#ifndef PA_METRIC_LSCUT_H
#define PA_METRIC_LSCUT_H

#include "metric/metric.h"

/* The hooks of the steps that involve other ranks. Every hook is collective
 * in the distributed context and returns the same status on every rank;
 * the sequential context (pa__ls_ctx_seq) computes them on the one mesh. */
typedef struct pa__ls_ctx {
  pa_mesh *mesh;
  pa_idx nelem, nbdry, nedge; /* this rank's entities: the first ones */
  pa_idx nvert;               /* this rank's vertices (checked, counted) */
  const pa_gid *vkey;         /* per local vertex: its global id; NULL: index */
  const pa_gid *ekey;         /* per local element: its global id; NULL: index */
  /* in place, n values: the global sum, the global maximum */
  pa_status (*sum)(void *ctx, double *x, int n);
  pa_status (*max)(void *ctx, double *x, int n);
  /* per local vertex, over the copies of each vertex: the maximum of f
   * (bytes), the minimum of x (global ids); the result on every copy */
  pa_status (*vmax)(void *ctx, uint8_t *f);
  pa_status (*vmin)(void *ctx, pa_gid *x);
  /* every rank's n pairs (lab, vol) one after the other, in *alab, *avol
   * (pa__malloc'ed, *nall pairs) */
  pa_status (*gather)(void *ctx, const pa_gid *lab, const double *vol,
                      size_t n, pa_gid **alab, double **avol, size_t *nall);
  /* PA_SUCCESS if every rank's st is, else the first failure */
  pa_status (*agree)(void *ctx, pa_status st);
  void *ctx;
} pa__ls_ctx;

/* The sequential context of mesh: every entity is this rank's. */
void pa__ls_ctx_seq(pa_mesh *mesh, pa__ls_ctx *c);

/* Check the options (PA_ERR_ARG). Not collective. */
pa_status pa__ls_check_opts(const pa_levelset_opts *o);

/* The level set before the cut: s (in: phi, one value per local vertex;
 * out: phi - V, snapped to 0 where a cut point would fall within o->snap
 * of an edge's end, and with the small components of o->rmc changed side);
 * fills rep's phi_min, phi_max, nsnapped, nremoved_*. PA_ERR_ARG names a
 * value that is not finite (its key + 1). Collective when c is. */
pa_status pa__ls_prepare(const pa__ls_ctx *c, const pa_levelset_opts *o,
                         double *s, pa_levelset_report *rep);

/* The material of each of this rank's elements (PA_ERR_ARG naming the first
 * whose reference the table does not list, by key + 1): split[e], and
 * the references of its two sides, rin[e], rex[e] (its own reference for a
 * material that is not split). Not collective. */
pa_status pa__ls_materials(const pa__ls_ctx *c, const pa_levelset_opts *o,
                           uint8_t *split, int32_t *rin, int32_t *rex);

/* Cells of the cut: dim + 1 (elements), dim (boundary entities) or 2
 * (edges) vertices each, as local vertex indices or nv + k for added
 * vertex k; reference, flags, and the parent: e for entity e kept whole,
 * -2 - e for a part of entity e, -1 for a new interface entity. */
typedef struct pa__ls_cells {
  int nvc;
  pa_idx n;
  size_t cap;
  pa_idx *v;
  int32_t *ref;
  uint8_t *flag;
  pa_idx *parent;
} pa__ls_cells;

/* The entity a cell of parent p comes from, whole or in part; -1 for a new
 * interface entity. */
static inline pa_idx pa__ls_origin(pa_idx p) {
  return p >= 0 ? p : p <= -2 ? -2 - p : -1;
}

/* Bits of the sides a vertex touches (pa__ls_out.touch): an element of the
 * inside, of the outside, of a split material. */
#define PA_LS_TOUCH_IN 1
#define PA_LS_TOUCH_OUT 2

/* What the cut of this rank's entities makes. */
typedef struct pa__ls_out {
  /* added vertices: k on the edge (end[2k], end[2k+1]) (local indices, the
   * one of smaller key first) at the share t[k] from the first */
  pa_idx nadd;
  size_t capadd;
  pa_idx *end;
  double *t;
  uint8_t *addtouch; /* PA_LS_TOUCH_* of each added vertex */
  uint8_t *touch;    /* per local vertex, PA_LS_TOUCH_* from this rank's
                        output elements of split materials */
  pa__ls_cells elem, bdry, edge;
  /* faces of this rank's elements whose vertices all lie on the zero set
   * (dim each, oriented out of their element), with the side of their
   * element: 1 inside, 2 outside (of a split material), 0 otherwise; the
   * face is an interface entity when one element on each side holds it
   * (pa__ls_zero_faces) */
  pa__ls_cells zero;
  pa_idx nelem_cut;
  double vol[2]; /* volume of this rank's output elements inside, outside */
} pa__ls_out;

void pa__ls_out_free(pa__ls_out *o);

/* Cut this rank's entities of c->mesh by s (pa__ls_prepare's) with the
 * materials of pa__ls_materials; bdrop (may be NULL): this rank's boundary
 * entities to leave out (an earlier interface). Output in *o (zeroed
 * first). Not collective. */
pa_status pa__ls_cut(const pa__ls_ctx *c, const pa_levelset_opts *o,
                     const double *s, const uint8_t *split,
                     const int32_t *rin, const int32_t *rex,
                     const uint8_t *bdrop, pa__ls_out *out);

/* The interface entities among zero-face candidates z (keys: the vertices'
 * keys, key(v) for v of z): the faces held by one element of each side,
 * appended to cells (reference ref, flag 0, parent -1) as oriented by
 * their inside element. Not collective. */
pa_status pa__ls_zero_faces(const pa__ls_cells *z, const pa_gid *key,
                            int32_t ref, pa__ls_cells *cells);

/* Append added vertices: vertex nv0 + k of m (grown) on the edge (end[2k],
 * end[2k+1]) of the vertices of src at the share t[k]: coordinates, metric
 * (pa__metric_interp) and fields (pa__field_interp), reference 0, flags 0.
 * src and m may be the same mesh (then nv0 is its vertex count). */
pa_status pa__ls_add_vertices(const pa_mesh *src, pa_idx nadd,
                              const pa_idx *end, const double *t, pa_mesh *m);

#endif /* PA_METRIC_LSCUT_H */
