/*
 * metric.h -- Riemannian metric algebra, edge lengths and element quality.
 *
 * A metric value has ncomp components: 1 = isotropic size h (tensor I/h^2),
 * 3 (2D) or 6 (3D) = symmetric tensor m11 m12 m22 [m13 m23 m33].
 * Functions taking (dim, ncomp, m) accept both forms. These are the kernels of
 * the remeshers' inner loops: no allocation, no error reporting; validity of
 * inputs is checked once, when a metric enters the mesh.
 *
 * Conventions (shared with Mmg so our figures are comparable):
 *  - edge length L = (la - lb) / ln(la/lb) with la = sqrt(e^T Ma e), the mean
 *    (la + lb)/2 when |la - lb| < 1e-3 * max(la, lb);
 *  - quality with the arithmetic mean M of the vertex tensors:
 *    3D Q = 72 sqrt(3) V_M / (sum l_M^2)^(3/2), 2D Q = 4 sqrt(3) A_M / sum l_M^2,
 *    V_M = V sqrt(det M), l_M^2 = e^T M e. 1 = regular, 0 = flat, < 0 inverted;
 *  - an edge is "in range" when its length lies in [1/sqrt(2), sqrt(2)).
 */
#ifndef PA_METRIC_H
#define PA_METRIC_H

#include "mesh/mesh.h"
#include "metric/sym.h"

#include <math.h>

/* The band of edge lengths in range, [1/sqrt(2), sqrt(2)): the target of
 * every remesher (an edge in it is neither split nor collapsed), and the
 * share of edges in it measures how a mesh meets its metric. Spelled as Mmg
 * prints and counts it, 0.7071 and 1.4142, so that the statistics compare
 * with Mmg's: the statistics' in-range bin (pa_stats_edge_bin), which
 * PA_TARGET_IN_RANGE judges, and the parallel loop's tags. */
#define PA_METRIC_LEN_LO 0.7071
#define PA_METRIC_LEN_HI 1.4142
/* The same band to the last bit (sqrt(1/2) and sqrt(2), correctly
 * rounded), where a threshold is not compared with Mmg's figures: the 3D
 * remesher's collapse and split bounds. */
#define PA_METRIC_LEN_LO_EXACT 0.7071067811865476
#define PA_METRIC_LEN_HI_EXACT 1.4142135623730951


/* Index of entry (i,j) of a symmetric tensor stored m11 m12 m22 m13 m23 m33. */
static inline int pa__sym_index(int i, int j) {
  if (i > j) { int t = i; i = j; j = t; }
  return j * (j + 1) / 2 + i;
}

/* 1 if a metric value is a finite positive size (ncomp 1) or a finite SPD
 * tensor (metric.c). */
int pa__metric_valid(int dim, int ncomp, const double *m);
/* PA_ERR_METRIC naming the first vertex whose metric value is not valid
 * (ops.c); the part of pa_mesh_check that pa__mesh_check (mesh/check.c)
 * leaves to this component. */
pa_status pa__mesh_check_metric(const pa_mesh *mesh);

/* Expand a metric value to a full tensor (3 or 6 components). */
void pa__metric_tensor(int dim, int ncomp, const double *m, double *t);

/* Symmetric eigen-decomposition: m = V diag(lambda) V^T; vec column-major
 * (eigenvector k is vec[dim*k .. dim*k+dim-1]). Robust for repeated and tiny
 * eigenvalues (Jacobi rotations in 3D, closed form in 2D). */
void pa__sym_eigen(int dim, const double *m, double *lambda, double *vec);
/* Rebuild a symmetric tensor from eigenpairs. */
void pa__sym_from_eigen(int dim, const double *lambda, const double *vec,
                        double *m);
/* Solve the SPD system a x = b of size n in place (a row-major, overwritten
 * by its Cholesky factor; b by x); 0 if a is not positive definite to
 * working precision (a pivot under 1e-12 of the largest diagonal entry)
 * (recovery.c: the least-squares fits of the recoveries and of the
 * remeshers' surface normals). */
int pa__cholesky_solve(int n, double *a, double *b);

/* Interpolation of n metrics with weights w (sum to 1) at a new vertex,
 * linear in size: M = (sum w_i M_i^-1/2)^-2, h = sum w_i h_i (Mmg's
 * choice). The one interpolation of the code: splits, moves, bisection,
 * 2D and 3D. Chosen by measurement over log-Euclidean interpolation
 * (exp(sum w_i log M_i), exact where sizes vary geometrically): exact on
 * sizes that vary linearly, which is what the gradation leaves and what
 * the UGAWG fields are (the measurement: docs/BENCHMARKS.md, the UGAWG
 * benchmark). Output in the same ncomp as the inputs. */
void pa__metric_interp(int dim, int ncomp, int n, const double *const *m,
                       const double *w, double *out);

/* 1 if a vertex field holds a metric (PA_FIELD_METRIC_PREFIX name and 1 or
 * the tensor count of components): the remeshers interpolate it as one. */
int pa__field_is_metric(int dim, const char *name, int ncomp);

/* Interpolation of one vertex field value (ncomp components) from n values
 * v[i] with weights w: pa__metric_interp for a metric field, linear
 * otherwise. out may alias one of v. */
void pa__field_interp(int dim, int ncomp, int is_metric, int n,
                      const double *const *v, const double *w, double *out);

/* Intersection by simultaneous reduction: the largest metric contained in
 * both (full tensors in, full tensor out; sizes: out = min). */
void pa__metric_intersect(int dim, int ncomp, const double *m1,
                          const double *m2, double *out);

/* Clamp eigenvalues into [1/hmax^2, 1/hmin^2]; a bound <= 0 is ignored.
 * Returns the PA_CHANGED_HMIN / PA_CHANGED_HMAX bits of the bounds that
 * changed m. */
unsigned pa__metric_clamp(int dim, int ncomp, double *m, double hmin,
                          double hmax);

/* Steps of the metric preparation (pa__metric_prepare), on nv values of nc
 * components; vertices with frozen[v] (frozen may be NULL) keep theirs.
 * set_hsiz gives every vertex the size hsiz (the caller's metric then);
 * clamp_all clamps into [hmin, hmax] and returns the PA_CHANGED_* bits of
 * what it changed. */
void pa__metric_set_hsiz(int dim, int nc, pa_idx nv, double *met,
                         const uint8_t *frozen, double hsiz);
unsigned pa__metric_clamp_all(int dim, int nc, pa_idx nv, double *met,
                              const uint8_t *frozen, double hmin, double hmax);
/* The clamp with the local parameters of o (o->local): at the vertices of
 * the entities they name their bounds replace o->hmin/o->hmax
 * (pa_local_param). In three steps, so that a distributed mesh can merge
 * the bounds of the copies of a vertex before clamping: pa__local_bounds
 * gives each vertex the triple (seen, hmin, hmax) of the local parameters
 * of its entities (seen 0: the global bounds; b holds 3 * mesh->nv
 * values), pa__local_bounds_merge merges two triples, and
 * pa__metric_clamp_bounds clamps met (nv values) and returns the
 * PA_CHANGED_* bits of what it changed. */
void pa__local_bounds(const pa_mesh *mesh, const pa_remesh_opts *o,
                      double *b);
void pa__local_bounds_merge(const double *in, double *inout);
unsigned pa__metric_clamp_bounds(int dim, int nc, pa_idx nv, double *met,
                                 const uint8_t *frozen, const double *b);
/* The Hausdorff distance bounding the boundary entities of reference ref:
 * a local parameter's (kind PA_BOUNDARY) or the global one, def. */
double pa__local_hausd(const pa_remesh_opts *o, int ref, double def);

/* Squared length of vector e in metric m (value of ncomp components):
 * pa__sqlen2 or pa__sqlen3. */
double pa__metric_sqlen(int dim, int ncomp, const double *m, const double *e);


/* Edge length between points a and b with end metrics ma, mb: the kernel
 * of the dimension (pa__len2, metric2d.h; pa__len3, metric3d.h). */
double pa__edge_length(int dim, int ncomp, const double *a, const double *b,
                       const double *ma, const double *mb);

/* Quality of the simplex with vertex coordinates x[0..dim] and metrics
 * m[0..dim] (ncomp 0: identity metric, m may be NULL): the statistics'
 * kernel of the dimension (pa__qual2_stat, pa__qual3_stat), signed. */
double pa__quality(int dim, int ncomp, const double *const *x,
                   const double *const *m);

/* n / total, 0 when total is 0 (the shares of the statistics). */
static inline double pa__share(pa_gid n, pa_gid total) {
  return total > 0 ? (double)n / (double)total : 0.0;
}

/* The statistics of a pa_stats accumulated one element and one edge at a
 * time (stats.c): pa_mesh_stats and pa_dmesh_stats (dmesh/dstats.c) both
 * count through it, so they bin, count and sum alike. The caller fills the
 * entity counts and validity of s (dim, has_metric, nvert, nelem, nbdry,
 * valid); pa__stats_acc_sums then puts the sums in s. */
typedef struct pa__stats_acc {
  pa_stats s;
  pa_gid nelem; /* elements added (s.nelem may be a global count) */
  pa__ksum volume, edge_sum, qual_sum;
} pa__stats_acc;

/* Start with nothing counted. */
void pa__stats_acc_init(pa__stats_acc *a);
/* Count an element of signed volume vol (inverted when vol <= 0) and
 * quality q: the quality bins (floor(q / 0.2) clamped to the bins, so an
 * inverted or NaN quality counts in the first), the shares above 0.5 and
 * 0.12, extremes and sums. */
void pa__stats_add_elem(pa__stats_acc *a, double vol, double q);
/* Count an edge of length len in the metric: its bin, the in-range bin,
 * extremes and sum. */
void pa__stats_add_edge(pa__stats_acc *a, double len);
/* Write the compensated sums into a->s (volume, edge_sum, qual_sum). */
void pa__stats_acc_sums(pa__stats_acc *a);

/* The validity check pa__mesh_stats_met runs: none (stats->valid is then
 * 1), pa_mesh_check's, or that of the built-in remesher's output:
 * pa__mesh_check without the input-only parts (overlaps, coincident
 * vertices, manifold vertices), which its local operators, each keeping
 * its cavity star-shaped and positive, cannot create from a valid input. */
enum { PA_STATS_CHECK_NONE, PA_STATS_CHECK_FULL, PA_STATS_CHECK_OUTPUT };
/* pa_mesh_stats measured in the metric met (nv values of nc components; nc
 * 0: identity) instead of the mesh's own (stats.c), with the check given
 * (PA_STATS_CHECK_*). */
pa_status pa__mesh_stats_met(pa_mesh *mesh, int nc, const double *met,
                             int check, pa_stats *stats);

/* The name of the vertex field carrying the caller's metric
 * (pa__metric_prepare). */
#define PA_METRIC_USER PA_FIELD_METRIC_PREFIX "user"

/* The index of the vertex field holding the caller's metric ("metric:user",
 * PA_FIELD_METRIC_PREFIX), or -1. */
int pa__user_metric_field(const pa_mesh *mesh);

/* pa_mesh_recover at the vertices with mask[v] only (mask NULL: all); the
 * others' grad and hess are left as they are (recovery.c). */
pa_status pa__recover(pa_mesh *mesh, const double *u, int stride,
                      pa_recovery method, const uint8_t *mask, double *grad,
                      double *hess);

/* The complexity's contribution of element e (its volume times the mean of
 * sqrt(det M) at its vertices; ops.c). */
double pa__elem_complexity(const pa_mesh *mesh, int ncomp, const double *met,
                           pa_idx e);

/* Volume of the regular simplex of unit edge: an element of the unit mesh
 * of a metric, so the complexity / this is the expected element count. */
static inline double pa__unit_simplex_volume(int dim) {
  return dim == 2 ? 0.4330127018922193 /* sqrt 3 / 4 */
                  : 0.1178511301977579 /* sqrt 2 / 12 */;
}

/* Refuse, before any work, a metric that asks for more elements than the
 * memory holds: about complexity / (volume of the unit regular simplex)
 * output elements, spread over nproc processes, at the peak bytes per
 * element of the sequential remesher (parallel 0) or of a rank of the
 * parallel driver (1), against budget bytes per process (<= 0: unknown,
 * only a non-finite estimate is refused). PA_ERR_MEMORY names the
 * estimate, what it needs and the budget (budget_what, e.g. "-mem 100"). */
pa_status pa__check_output_size(int dim, double complexity, int nproc,
                                int parallel, double budget,
                                const char *budget_what);

/* The Lp metric of a recovered Hessian h (tensor) before scaling:
 * det|H|^(-1/(2p+d)) |H| with the eigenvalues of |H| floored at lmin (> 0),
 * into m (tensor; hessian.c). p <= 0: L-infinity (|H| itself). */
void pa__lp_metric(int dim, const double *h, double p, double lmin, double *m);

/* Where a whole-field metric operation runs: the mesh, the first nelem of
 * its elements (the owned ones of a distributed mesh) as the domain, and
 * the steps that involve other ranks. The sequential context
 * (pa__metric_ctx_seq) works on the mesh alone; the distributed one
 * (pa__adapt_metric_ctx, src/adapt/dmetric.c) reduces over the ranks,
 * merges the copies of a vertex and grades over the distributed mesh, so
 * that the whole-field operations (pa__metric_from_hessian,
 * pa__metric_prepare) are written once. Every hook is collective in the
 * distributed context and returns the same status on every rank. */
typedef struct pa__metric_ctx {
  pa_mesh *mesh;
  pa_idx nelem;
  /* in place: the local value -> the global sum, maximum, bitwise or */
  pa_status (*sum)(void *ctx, double *x);
  pa_status (*max)(void *ctx, double *x);
  pa_status (*bor)(void *ctx, unsigned *x);
  /* PA_SUCCESS if every rank's st is, else the first failure (pa__agree):
   * called before a collective step, so a rank that failed on its own
   * meets the others there */
  pa_status (*agree)(void *ctx, pa_status st);
  /* *frozen (pa__malloc'ed, mesh->nv): 1 for the vertices that keep their
   * metric, pa__mesh_frozen_vertices on any copy of the vertex */
  pa_status (*frozen)(void *ctx, uint8_t **frozen);
  /* the local-parameter bounds b (3 per vertex, pa__local_bounds) merged
   * over every copy of a vertex (pa__local_bounds_merge) */
  pa_status (*merge_bounds)(void *ctx, double *b);
  /* grade met, the mesh->nv values of nc components of the mesh's vertices
   * (in the distributed context: the mesh's own metric array), the frozen
   * vertices keeping theirs (pa__metric_gradation's rates); *changed (may
   * be NULL): 1 if a value changed on any rank */
  pa_status (*grade)(void *ctx, int nc, double *met, const uint8_t *frozen,
                     double hgrad, double hgradreq, int *changed);
  void *ctx;
} pa__metric_ctx;

/* The sequential context of mesh (prepare.c). */
void pa__metric_ctx_seq(pa_mesh *mesh, pa__metric_ctx *c);

/* The metric preparation of pa_remesh and pa_dmesh_adapt (prepare.c), in
 * the context c, on met: c->mesh->nv values of nc components, the caller's
 * metric (or, when the mesh has none, nc 1 and any values). In order:
 *  1. o->hsiz > 0 replaces the caller's metric by the size hsiz, except at
 *     the frozen vertices (c->frozen) when the mesh has a metric;
 *  2. unless o->no_stats, a copy of the result is carried as the vertex
 *     field PA_METRIC_USER (if the mesh has room and carries none yet;
 *     *carried = 1), for the final report against the caller's metric;
 *  3. hmin/hmax and the local parameters o->local (pa__local_bounds,
 *     the bounds merged over the copies of a vertex);
 *  4. the gradation o->hgrad, o->hgradreq (c->grade).
 * Frozen vertices keep their metric throughout (the gradation lets them
 * constrain their neighbours). *changed: the PA_CHANGED_* bits of what 3
 * and 4 changed on any rank; when nothing, the carried copy is dropped
 * again (*carried = 0), and so it is on failure. Collective when c is. */
pa_status pa__metric_prepare(const pa__metric_ctx *c, int nc, double *met,
                             const pa_remesh_opts *o, unsigned *changed,
                             int *carried);

/* pa_metric_from_hessian from the recovered Hessian h (tensor per vertex,
 * every local vertex) in the context c (hessian.c). */
pa_status pa__metric_from_hessian(const pa__metric_ctx *c, const double *h,
                                  const pa_metric_hessian_opts *o,
                                  double *met);

#endif /* PA_METRIC_H */
