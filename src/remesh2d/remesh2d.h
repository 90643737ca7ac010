/*
 * remesh2d.h -- private header of the built-in 2D (triangle) remesher, whose
 * entry pa__remesh2d() (driver_2d.c) is declared with the driver in
 * remesh/remesh.h: the compact working mesh (struct rm2d), its tags,
 * the inline metric kernels of the inner loops, and the interfaces between
 * its files: the working mesh (mesh_2d.c), the feature lines
 * (boundary_2d.c), the operators (split_2d.c, collapse_2d.c, swap_2d.c,
 * smooth_2d.c, with ops_2d.h) and their passes and schedule (driver_2d.c),
 * as the 3D remesher's files.
 *
 * Working mesh invariants (checked by pa__rm2d_check):
 *  - structure of arrays, 0-based, 32-bit indices; a dead entity keeps its slot
 *    (tag RM_*_DEAD) and sits on a free list until reused;
 *  - elements are positively oriented; adj[(dim+1)*k + i] is the face opposite
 *    local vertex i: >= 0 is (dim+1)*f + j (face j of element f), < 0 is
 *    -(b+1) for feature record b (a boundary edge or an interior curve edge in
 *    2D); adjacency is symmetric, and across a feature the two sides are found
 *    through the record (bside);
 *  - q[k] is the element quality (Mmg's normalisation) with the current
 *    coordinates and metric;
 *  - tag bits RM2D_E_TOUCHED / RM2D_V_DONE are scratch, cleared by each pass
 *    that uses them; RM2D_E_INRANGE / RM2D_E_NOSWAP / RM2D_V_SETTLED /
 *    RM2D_V_LSETTLED / RM2D_V_CSETTLED are caches
 *    that skip work a pass would find useless, cleared by any change that
 *    could invalidate them (so the passes decide exactly as without them);
 *  - a frozen element (PA_FLAG_REQUIRED in its flags) is never rewritten; its
 *    vertices carry RM2D_V_FROZEN, so they are never moved or removed.
 */
#ifndef PA_REMESH2D_H
#define PA_REMESH2D_H

#include "metric/metric.h"
#include "metric/metric2d.h"
#include "remesh/remesh.h"

#include <math.h>

/* Vertex tags. */
enum {
  RM2D_V_FROZEN = 1, /* never moved, never removed, metric never changed */
  RM2D_V_CORNER = 2, /* never moved, never removed */
  RM2D_V_FEAT = 4,   /* lies on a feature line (boundary or interior curve) */
  RM2D_V_DEAD = 8,
  /* The removal of this vertex by the collapse passes
   * (pa__rm2d_remove_vertex: onto any neighbour, RM2D_QREL_COLLAPSE, no new
   * edge longer than rm2d.cguard) was tried and rejected, and its ball has
   * not changed since: cleared with RM2D_V_SETTLED, and on every vertex
   * when a collapse pass allows longer edges than rm2d.cguard. */
  RM2D_V_CSETTLED = 16,
  RM2D_V_DONE = 32, /* scratch */
  /* A relocation of this vertex was tried and rejected, and no element of
   * its ball changed since (nor any vertex of them moved): trying again
   * would give the same answer, so relocation passes skip it. Cleared by
   * every operator on the vertices of each element it rewrites or kills,
   * and by a move on the vertices of the moved vertex's ball. */
  RM2D_V_SETTLED = 64,
  /* The same for a length move (pa__rm2d_length_vertex, whose verdict
   * depends on the ball alone): cleared with RM2D_V_SETTLED. */
  RM2D_V_LSETTLED = 128
};

/* Element tags share the byte with the input flags (PA_FLAG_*, low nibble). */
enum {
  RM2D_E_FROZEN = PA_FLAG_REQUIRED,
  RM2D_E_DEAD = 16,
  RM2D_E_TOUCHED = 32, /* modified during the current pass */
  /* Every swap of the element at the swap pass's gain was tried and
   * rejected, and neither it nor a neighbour changed since: skipped by swap
   * passes. Cleared with RM2D_E_INRANGE, on the element and its neighbours. */
  RM2D_E_NOSWAP = 64,
  /* The three edges lie in [RM2D_LSHORT_OPT, rm2d.lset_hi]
   * (rm2d_len_settled) with the current coordinates and metric, so split passes
   * at lset_hi or above, collapse passes at RM2D_LSHORT_OPT or below and length
   * moves have nothing to do here. Cleared with RM2D_V_SETTLED (an element
   * rewritten, or one of its vertices moved); new elements start without. */
  RM2D_E_INRANGE = 128
};

/* Feature-record tags (high nibble; low nibble = input PA_FLAG_*). */
enum {
  RM2D_B_FROZEN = PA_FLAG_REQUIRED,
  RM2D_B_DEAD = 16,
  RM2D_B_LISTED = 32 /* came from (and goes back to) the mesh's boundary list */
};

/* Face without neighbour while the working mesh is being built (afterwards
 * every such face holds a feature record). */
#define RM2D_NOADJ INT32_MIN

/* Quality floor: no operator creates an element below it, or below half
 * the worst of the elements it replaces when those are already under
 * twice the floor (rm2d_qfloor, ops_2d.h). */
#define RM2D_QFLOOR 1e-4
/* Below RM2D_QFLOOR the metric quality no longer vouches for the orientation
 * (with anisotropy r it can exceed the Euclidean one r times), so a new
 * element must also have a Euclidean quality of at least this: its
 * computed area is then far above the rounding error of the cross product
 * (a few 1e-16 of the product of its edges). */
#define RM2D_QFLOOR_EUCL 1e-10
/* A length move may lower the ball's worst quality down to this (never
 * below its old worst if lower), and one that leaves as many edges out of
 * range must cut their sum of ln^2 L by 3 % (as in 3D, remesh3d.h). */
#define RM2D_QLEN 0.5
#define RM2D_LGAIN 0.97
/* The length the 2D length moves aim at: a little above 1, where an edge
 * is in range with room on both sides, so the mesh keeps fewer vertices
 * for the same share in range (figures: docs/BENCHMARKS.md, "The 2D
 * remesher"). */
#define RM2D_LTARGET 1.2

/* The polish relocation (pa__rm2d_smooth_pass with qfree > 0): balls of
 * worst quality under qfree may shorten the edges at the moved vertex down
 * to this bound, never lengthen them past PA_METRIC_LEN_HI. Letting them
 * reach 1.5 made most of the too-long edges of the last UGAWG polar-1
 * passes (tests/cli/test_ugawg_pass.sh: 6 of 1 755 in the given metric
 * against 1) for a worst quality 0.65 -> 0.68; without this bound (0.7071)
 * the plate -hsiz 0.0005 loses worst quality, 0.66 -> 0.64. */
#define RM2D_LFREE_LO 0.65
/* A feature vertex moves along its curve by at most this share of the
 * record it moves along. */
#define RM2D_FEAT_STEP 0.45

/* The optimisation rounds' relaxed collapses take edges below this, a little
 * above 1/sqrt(2): a split of an edge just above sqrt(2) leaves two halves
 * just above 1/sqrt(2), which these collapses merge into an edge the next
 * split cuts at a better place. The mesh keeps the same share in range
 * with fewer triangles; a higher value loses edges in range (figures:
 * docs/BENCHMARKS.md, "The 2D remesher"). */
#define RM2D_LSHORT_OPT 0.715

typedef struct rm2d {
  int dim;   /* 2 */
  int nvpe;  /* vertices per element: dim + 1 */
  int mc;    /* metric components per vertex: 1 or 3 (2D) / 6 (3D) */
  int fcomp; /* total user field components per vertex */
  int nfield;
  int fncomp[PA_MESH_MAX_FIELDS];
  uint8_t fmetric[PA_MESH_MAX_FIELDS]; /* field holds a metric (metric.h) */

  /* vertices */
  pa_idx nv, vfree;  /* slots in use (live + dead), free-list head (-1) */
  size_t capv;
  double *x;        /* dim * capv */
  double *met;      /* mc * capv: the working metric the operators use */
  double *met0;     /* mc * capv or NULL: the target metric, written back,
                       when the working one was relaxed at frozen skins
                       (mesh_2d.c); interpolated alongside met */
  double *vcur;     /* 2 * capv or NULL: the step from a vertex of an interior
                       curve to its curve point still to make (the fitted
                       curve's, boundary_2d.c, or the rest of a split that
                       fell back toward the chord, split_2d.c); the curve
                       snaps (pa__rm2d_curve_snap_vertex) take it on */
  double *fld;      /* fcomp * capv (NULL without fields) */
  int32_t *vref;    /* free list link for dead vertices */
  uint8_t *vpf;     /* input PA_FLAG_* */
  uint8_t *vtag;    /* RM2D_V_* */

  /* elements */
  pa_idx ne, efree;
  size_t cape;
  pa_idx *tv;  /* nvpe * cape; tv[nvpe*k] is the free-list link if dead */
  pa_idx *adj; /* nvpe * cape */
  float *q;
  int32_t *tref;
  uint8_t *tflag;

  /* 2D feature records: boundary edges and interior-curve edges */
  pa_idx nb, bfree;
  size_t capb;
  pa_idx *bv;     /* 2 * capb: end vertices (bv[2b] is the free link if dead) */
  pa_idx *bside;  /* 2 * capb: element faces on each side (second -1 on the
                     domain boundary) */
  double *btan;   /* 4 * capb: unit tangent of the curve at each end, oriented
                     from bv[2b] to bv[2b+1] */
  int32_t *bref;
  uint8_t *btag;

  /* live counts */
  pa_idx nvlive, nelive, nblive;

  /* options and statistics */
  const pa_remesh_opts *opts;
  double hausd;
  double lguard; /* no operation creates an edge longer than this */
  double lset_hi; /* upper end of the RM2D_E_INRANGE band (rm2d_len_settled) */
  double cguard;  /* RM2D_V_CSETTLED holds for collapse guards up to this */
  int frozen;    /* the mesh has a frozen element or feature record */
  long nsplit, ncollapse, nswap, nmove;
  double tlast; /* time of the last verbose pass report */
} rm2d;

/* ---- working mesh (mesh_2d.c) ---- */

/* Build the working mesh from a (checked) sequential mesh with a metric:
 * vertices, elements (the vertices of frozen ones frozen), adjacency; the
 * features come next (pa__rm2d_feature_analyze). Capacities are reserved
 * for about the elements the metric asks for. */
pa_status pa__rm2d_build(pa_mesh *mesh, const pa_remesh_opts *opts, rm2d **rm);
/* Relax the working metric at frozen vertices whose frozen edges are on
 * average far from unit length (target kept in met0); *nrelaxed vertices. */
pa_status pa__rm2d_skin_relax(rm2d *rm, pa_idx *nrelaxed);
void pa__rm2d_free(rm2d *rm);
/* New vertex / element / feature slot (from the free list or appended). */
pa_status pa__rm2d_new_vertex(rm2d *rm, pa_idx *v);
pa_status pa__rm2d_new_elem(rm2d *rm, pa_idx *k);
pa_status pa__rm2d_new_feat(rm2d *rm, pa_idx *b);
void pa__rm2d_kill_vertex(rm2d *rm, pa_idx v);
void pa__rm2d_kill_elem(rm2d *rm, pa_idx k);
void pa__rm2d_kill_feat(rm2d *rm, pa_idx b);
/* Reserve room for n more vertices and elements (so that operators after it
 * cannot fail). */
pa_status pa__rm2d_reserve(rm2d *rm, pa_idx nvmore, pa_idx nemore,
                           pa_idx nbmore);
/* Interpolate the metric (pa__metric_interp) and fields (linearly) of
 * vertex v from n vertices src with weights w (sum 1). */
void pa__rm2d_interp(rm2d *rm, pa_idx v, int n, const pa_idx *src,
                     const double *w);
/* Write the working mesh back into mesh, renumbered compactly. Frees the
 * working arrays as it goes; on failure the mesh is left as it was. */
pa_status pa__rm2d_write(rm2d *rm, pa_mesh *mesh);
/* 2D: renumber the live vertices along the Morton curve of their bounding
 * box and the live elements by their smallest vertex, dropping the dead
 * slots of both (feature records keep theirs). The passes are memory-bound:
 * entities created by splits sit at the end of the arrays, far from their
 * neighbours. A failure (out of memory) may leave the working mesh partly
 * reordered: the remesh then fails as a whole, the caller's mesh untouched
 * (it is only written at write-back). */
pa_status pa__rm2d_reorder(rm2d *rm);
/* Check the working mesh invariants; PA_ERR_INTERNAL naming the first fault.
 * The RM2D_E_INRANGE cache is checked in debug builds only (a stale mark costs
 * operations, not validity). */
pa_status pa__rm2d_check(const rm2d *rm);
/* Edge-length and quality figures over the modifiable part of the mesh. */
typedef struct rm2d_figures {
  long nedge, nin, nlong, nshort; /* modifiable edges, in range, > sqrt2, < 1/sqrt2 */
  double lmin, lmax, qmin, qmean;
} rm2d_figures;
void pa__rm2d_figures(const rm2d *rm, rm2d_figures *f);

/* ---- features (boundary_2d.c) and operator passes ---- */

/* Feature analysis of the working mesh just built from mesh (the driver
 * calls it after pa__rm2d_build, as the 3D driver its surface analysis):
 * records from the boundary list, from unlisted boundary edges and from
 * element-reference interfaces; frozen records freeze their vertices;
 * corners; tangents; the Hausdorff size bound on curved features (then
 * spread by the gradation); element qualities. */
pa_status pa__rm2d_feature_analyze(rm2d *rm, pa_mesh *mesh);
/* Point at parameter s in [0,1] on the reconstructed curve of record b (from
 * bv[2b] to bv[2b+1]), and its unit tangent oriented the same way. */
void pa__rm2d_curve_point(const rm2d *rm, pa_idx b, double s, double *p,
                          double *t);
/* Passes (driver_2d.c, over the operators of split_2d.c, collapse_2d.c,
 * swap_2d.c and smooth_2d.c): each gives the number of operations done. */
pa_status pa__rm2d_split_pass(rm2d *rm, double thr, long *n);
pa_status pa__rm2d_collapse_pass(rm2d *rm, double thr, long *n);
long pa__rm2d_swap_pass(rm2d *rm, double qmax);
/* The relocation pass: quality moves of the interior vertices, and with
 * feat of the feature vertices along their curves; balls of worst quality
 * under qfree may shorten their edges to RM2D_LFREE_LO (driver_2d.c). A
 * vertex rejected under one (qfree, feat) is marked settled: the driver
 * clears RM2D_V_SETTLED when it changes them. */
long pa__rm2d_smooth_pass(rm2d *rm, double qfree, int feat);
long pa__rm2d_length_pass(rm2d *rm);
long pa__rm2d_sliver_pass(rm2d *rm, double qbad);

/* ---- metric preparation (gradation.c in metric/) ---- */
#include "metric/gradation.h"

/* ---- inline 2D kernels ---- */

/* Full tensor (m11 m12 m22) of a 2D metric value of mc components. */
static inline void rm2d_tensor2(int mc, const double *m, double *t) {
  if (mc == 1) {
    double a = 1.0 / (m[0] * m[0]);
    t[0] = a; t[1] = 0; t[2] = a;
  } else {
    t[0] = m[0]; t[1] = m[1]; t[2] = m[2];
  }
}

/* An edge length no split, collapse or length-move pass acts on: the band
 * of RM2D_E_INRANGE. Its lower end is the highest collapse threshold
 * (RM2D_LSHORT_OPT), above PA_METRIC_LEN_LO, so that one mark serves every
 * pass; the elements it leaves unmarked (an edge in [PA_METRIC_LEN_LO,
 * RM2D_LSHORT_OPT)) are few. Its upper end rm->lset_hi is the lowest split
 * threshold of the phase: PA_METRIC_LEN_HI, and in the refinement rounds
 * (which split above RM2D_LSPLIT_REFINE and make no length moves) that
 * threshold, so that their lattice of edges up to it is marked too (the
 * driver clears every mark when the band narrows). */
static inline int rm2d_len_settled(const rm2d *rm, double l) {
  return l >= RM2D_LSHORT_OPT && l <= rm->lset_hi;
}

/* Lengths and qualities are metric/metric2d.h's kernels (pa__len2,
 * pa__qual2): the statistics measure with the same lengths. The band the
 * passes aim at is PA_METRIC_LEN_LO..PA_METRIC_LEN_HI, the bounds as Mmg prints
 * them (the 3D remesher's are the exact PA_METRIC_LEN_*_EXACT; the two differ
 * by 1e-5 and each remesher's outputs are tuned to its own). */

#endif /* PA_REMESH2D_H */
