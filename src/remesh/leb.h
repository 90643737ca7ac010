/*
 * leb.h -- longest-edge bisection of a simplex mesh in its metric (leb.c).
 */
#ifndef PA_LEB_H
#define PA_LEB_H

#include "metric/metric.h"

typedef struct pa__leb_opts {
  double lmax;            /* split inner edges longer than this */
  int32_t skin_ref;       /* boundary entities of this reference are a skin */
  const uint8_t *skin_ok; /* per vertex (or NULL: no skin): skin edges
                             between two marked vertices, one of them with
                             bit 0, may be split (1: any marked partner, 2:
                             a partner marked 1 only) */
  double skin_lmax;       /* split such skin edges longer than this */
  double vmin;            /* > 0: an inner edge is not split when an element
                             around it holds less than this metric volume
                             (pa__elem_complexity) */
} pa__leb_opts;

/* The vmin of a pre-refinement (the built-in 3D remesher's, and inside a
 * piece of the parallel loop, adapt/bisect.c), in unit tets: an element
 * holding less than a quarter of a unit tet of metric volume is not
 * bisected, its halves would hold less than an eighth of one, more
 * elements than the metric asks for. Where the metric is isotropic the
 * bisection stops at length 2 with 2-8 unit volumes per tet, so only flat
 * or strongly anisotropic elements meet it. At 1 unit tet, flat input
 * tets of the gmsh rod were left whole and its worst quality fell from
 * 0.249 to 0.207; at 1/4 the rod is bisected as before (figures:
 * docs/BENCHMARKS.md, "The 3D remesher"). */
#define PA_LEB_VMIN 0.25

/* Refine m in place (see leb.c). New vertices are appended; *parent (if not
 * NULL) receives the two ends of the edge each was added on, *onskin (if
 * not NULL, and vertices were added) 1 for those added on a skin edge. */
pa_status pa__leb_refine(pa_mesh *m, const pa__leb_opts *o, pa_idx **parent,
                         uint8_t **onskin);

#endif /* PA_LEB_H */
