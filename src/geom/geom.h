/*
 * geom.h -- the geometry component: a model (CAD) a classified mesh
 * discretizes, behind the kernel callbacks of the public pa_geometry_ops
 * (Gmsh's library in gmsh_model.c, the only code that calls it, or the
 * caller's own kernel), and what the remeshers and the metric preparation
 * ask of it: the closest point of an entity, its curvature.
 *
 * Invariants: a pa_geometry is used by one thread at a time (the kernels
 * are not thread-safe, and the counters below are plain fields); the
 * counters only grow, and readers take differences.
 */
#ifndef PA_GEOM_H
#define PA_GEOM_H

#include "mesh/mesh.h"

struct pa_geometry {
  pa_geometry_ops ops;
  void *ctx;
  double size; /* diagonal of the model's bounding box */
  /* called by pa_geometry_destroy on ctx (the Gmsh model's unload), or
   * NULL for a caller's kernel */
  void (*release)(void *ctx);
  /* counters of pa__geom_project, for the remesh reports */
  long nproject, nfailed;
  double seconds;
};

/* How far a projection may land from the point it projects, relative to
 * the length of the feature the point was built on (the edge split, the
 * move's step): the midpoint of a boundary edge lies within the edge's
 * sagitta of the model, a small fraction of its length on any surface the
 * mesh resolves. A closest point farther away is another sheet of the
 * entity (the far side of a thin wall, an untrimmed surface's extension)
 * and counts as a failure. */
#define PA_GEOM_MAXJUMP 1.0

/* A vertex farther than this from its entity, relative to the model's size,
 * is off the model: a point the kernel gives lies on the entity to its
 * tolerance (OpenCASCADE's, about 1e-7 of the size; Gmsh's projections
 * land within 1e-10), while a point left on a reconstruction lies off it by
 * a share of an edge's sagitta, far more. */
#define PA_GEOM_SNAP_TOL 1e-9

/* Put the point x (sdim = 2 or 3 coordinates; z = 0 in 2D) on entity
 * (dim, tag), dim 1 or 2, into y (sdim values; may be x): 1 on success, 0
 * when the kernel fails, returns a non-finite point or one farther than
 * maxjump from x (then y is untouched). Counted in g's counters. */
int pa__geom_project(const pa_geometry *g, int dim, int tag, int sdim,
                     const double *x, double maxjump, double *y);

/* The largest absolute curvature kappa of entity (dim, tag) (1 or 2) at the
 * point of it closest to x (sdim values): 1 on success, 0 when the kernel
 * has no curvature or fails. */
int pa__geom_curvature(const pa_geometry *g, int dim, int tag, int sdim,
                       const double *x, double *kappa);

/* The sizes at the boundary vertices of the classified mesh m bounded by
 * the model's curvature: for each vertex v with b[3v] ... (the local
 * bounds of pa__local_bounds: flag, lowest hmin, hmax), hmax lowered to
 * sqrt(8 hausd / kappa) (not below hmin > 0) where kappa > 0, kappa the
 * curvature of v's own curve or surface at v and, for a vertex on a point
 * or curve, of each curve or surface it bounds (at the centroid of the
 * cells there); frozen[v] vertices skipped. Returns how many it lowered. */
pa_idx pa__geom_hausd_bounds(const pa_geometry *g, const pa_mesh *m,
                             double hausd, double hmin, const uint8_t *frozen,
                             double *b);

#endif /* PA_GEOM_H */
