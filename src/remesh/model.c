/*
 * model.c -- the remeshers' one way onto the model of a classified mesh
 * (pa_remesh_opts.geometry): pa__remesh_project, which the 2D and 3D
 * operators call wherever they compute a new boundary point (a split) or
 * move a boundary vertex. Dimension-independent; the operators decide what
 * to do when it says no (a split keeps its own reconstruction, a move is
 * refused).
 */
#include "geom/geom.h"
#include "remesh/remesh.h"

int pa__remesh_project(const pa_remesh_opts *o, int dim, int32_t tag,
                       int sdim, const double *x, double scale, double *y) {
  if (!o->geometry || tag <= 0 || (dim != 1 && dim != 2)) return 0;
  return pa__geom_project(o->geometry, dim, tag, sdim, x,
                          PA_GEOM_MAXJUMP * scale, y)
             ? 1
             : -1;
}

int pa__remesh_model_curvature(const pa_remesh_opts *o) {
  return o->geometry && o->geometry->ops.curvature;
}
