/*
 * remesh.h -- private header of the code the remeshers share and of the
 * remesher driver (src/remesher/remesher.c): the built-in remesher's
 * entries, one per dimension, which the driver calls and the remeshers
 * define; the field transfer; the projection onto the CAD model.
 *
 * Layering (scripts/check-layers.sh): src/remesh2d/ and src/remesh3d/
 * include the headers of this folder (this one for their entry, schedule.h
 * for the pass schedule they share), never the reverse, and neither
 * includes the other; src/remesher/ sits above the three.
 */
#ifndef PA_REMESH_H
#define PA_REMESH_H

#include "metric/metric.h"

#include <stdint.h>
#include <string.h>

/*
 * Adapt the triangle mesh (pa__remesh2d, src/remesh2d/driver_2d.c) or the
 * tetrahedral mesh (pa__remesh3d, src/remesh3d/driver_3d.c) in place to its
 * metric; the 3D one also takes opts->hsiz when the mesh has none. Contract
 * of pa_remesher.remesh: entities flagged PA_FLAG_REQUIRED come back bit for
 * bit, report->outcome is set on PA_SUCCESS, and on any error or
 * PA_REMESH_FAILED the mesh is as given. The driver prepares the metric
 * (pa_remesh) and, in 3D, bisects the mesh first (leb.c). Not collective.
 */
pa_status pa__remesh2d(pa_mesh *mesh, const pa_remesh_opts *opts,
                       pa_remesh_report *report);
pa_status pa__remesh3d(pa_mesh *mesh, const pa_remesh_opts *opts,
                       pa_remesh_report *report);

/*
 * The element and boundary fields of the old mesh o (the remesher's input,
 * with those fields) carried onto the new mesh m (the output, without them;
 * transfer.c): each field is added to m with the values its transfer mode
 * gives (pa_transfer), and *rep says what it took. o is in/out only for its
 * cached adjacency. On failure m gets none of them. Not collective.
 */
pa_status pa__transfer_fields(pa_mesh *o, pa_mesh *m, pa_transfer_report *rep);

/*
 * The model's point for a new or moved boundary point x (sdim = 2 or 3
 * coordinates) of a cell on entity (dim, tag) (a curve 1 or a surface 2,
 * the cell's reference), built on a feature of length scale (the edge
 * split, the neighbourhood of the vertex moved), into y (may be x):
 * 1 when y is on the model, 0 when there is no model to follow (no
 * opts->geometry, a cell of reference <= 0: y untouched), -1 when the
 * kernel failed or jumped farther than PA_GEOM_MAXJUMP * scale (y
 * untouched). Not collective (model.c).
 */
int pa__remesh_project(const pa_remesh_opts *o, int dim, int32_t tag,
                       int sdim, const double *x, double scale, double *y);
/* The working metric relaxed at a frozen skin (skin.c): the band of mean
 * frozen-edge lengths left alone, [lo, hi], and the mean a vertex above it
 * is brought to (hi itself, or a remesher's lower target); below it, lo. */
typedef struct pa__skin_relax {
  double lo, hi, to_hi;
} pa__skin_relax;
/* Scale met (mc components at nv vertices, capv the capacity) at every
 * vertex whose mean frozen-edge length sum[v] / cnt[v] (cnt 0: no frozen
 * edge) is out of [r->lo, r->hi]; *met0 (NULL on entry) becomes a copy of
 * the target metric the first time. *nrelaxed: vertices scaled. Not
 * collective. */
pa_status pa__remesh_skin_relax(const pa__skin_relax *r, int mc, pa_idx nv,
                                size_t capv, double *met, double **met0,
                                const double *sum, const int32_t *cnt,
                                pa_idx *nrelaxed);

/* 1 when opts->geometry bounds the sizes by its curvature (the metric
 * preparation does, pa__geom_hausd_bounds): the remeshers' own estimates
 * of the curvature from the facets then stand aside. */
int pa__remesh_model_curvature(const pa_remesh_opts *o);

/* A direction in the cube [-1,1]^dim (not normalised) drawn from the bits
 * of the coordinates x[0..dim) (dim <= 3): the same on every run and for
 * any numbering. The jiggle of a lattice crowd moves a vertex along it
 * (pa__rm2d_jiggle_vertex, pa__rm3d_jiggle_vertex). */
static inline void pa__remesh_hash_dir(const double *x, int dim, double *d) {
  uint64_t h = 0x2545f4914f6cdd1dull;
  for (int j = 0; j < dim; j++) {
    uint64_t u;
    memcpy(&u, x + j, sizeof u);
    h = pa__mix64(h ^ u);
  }
  for (int j = 0; j < dim; j++) {
    h = pa__mix64(h + 0x9e3779b97f4a7c15ull);
    d[j] = (double)(h >> 11) * (2.0 / 9007199254740992.0) - 1.0;
  }
}

#endif /* PA_REMESH_H */
