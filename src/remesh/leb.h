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
                             a partner marked 1 only), and between two
                             vertices marked 3 (on a smooth curved
                             boundary) as leb.c says */
  double skin_lmax;       /* split such skin edges longer than this */
  double vmin;            /* > 0: an inner edge is not split when an element
                             around it holds less than this metric volume
                             (pa__elem_complexity) */
  const double *normal;   /* dim per input vertex, or NULL: the outward unit
                             normal of the vertices marked 3; NULL: a skin
                             edge on the boundary between two of them is not
                             split */
  /* 1 if the input edge ab between two vertices marked 3 may lie on the
   * boundary (never 0 for one that does); NULL: none does (2D, where skin
   * edges are interior) */
  int (*on_boundary)(void *ctx, pa_idx a, pa_idx b);
  void *ctx;
  pa_idx *curve_bad;      /* out (may be NULL): elements a split onto the
                             curve left without a positive volume */
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

/* Angle bound of a smooth curved boundary (adapt/pieces.c marks its
 * vertices 3 when their boundary faces' normals lie within it of each
 * other) and of a skin edge with its ends' tangent planes: the remesher
 * takes a turn of 45 degrees for a ridge (remesh3d, -ar), and 40 keeps 228
 * of the 604 curved input vertices of the gmsh rod (185 at 30, 230 at 45;
 * the others are on its sharp edges). */
#define PA_LEB_SMOOTH_DEG 40.0

/* Refine m in place (see leb.c). New vertices are appended; *parent (if not
 * NULL) receives the two ends of the edge each was added on, *onskin (if
 * not NULL, and vertices were added) 1 for those added on a skin edge, 2
 * for those placed on a curved boundary. */
pa_status pa__leb_refine(pa_mesh *m, const pa__leb_opts *o, pa_idx **parent,
                         uint8_t **onskin);

#endif /* PA_LEB_H */
