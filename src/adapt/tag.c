/*
 * tag.c -- step 1 of the piece algorithm: which owned elements to remesh and
 * how much work each is.
 *
 * An owned element is tagged when it is not user-required and either
 * carries PA_FLAG_USER (and was not produced by a remesh of this run: the
 * "done" element value) or (unless opts->user_tags_only) has an edge whose
 * length in the metric lies outside the band [PA_METRIC_LEN_LO,
 * PA_METRIC_LEN_HI) (metric/metric.h) or a quality below
 * opts->qual_threshold; an element produced in this run, with the looser
 * criteria below, by how much its piece's frozen skin constrained it, and
 * with a model when a vertex of it lies off the model (off_model). So
 * the loop ends (nothing tagged) only when every element of the final mesh
 * passes its criterion. Work ~ expected output elements + 1: the element's
 * volume in the metric over the volume of the unit regular simplex, plus one
 * for removing the element itself (the coarsening term). Every figure is a
 * function of the element's own data, so it is the same whatever the
 * distribution. The work is computed only for the tagged elements (the
 * others' entries are not written: the array of a final tag over millions
 * of new elements is never touched); extract.c computes it for the
 * untagged skin elements it needs. An element that passed the last tag
 * and has not changed since (PA_ADAPT_DONE_PASSED, piece.h) is not
 * measured again: after the first iteration a tag costs what the last
 * remesh changed (debug builds measure it all the same and check that it
 * still passes).
 */
#include "adapt/piece.h"
#include "geom/geom.h"
#include "metric/metric2d.h"
#include "metric/metric3d.h"

#include <float.h>
#include <math.h>

/* Elements produced in this run are tagged again with looser criteria
 * than the others, by how much the frozen skin of their piece constrained
 * them (their done value; see criteria()). The measurements behind each
 * bound: docs/design/ADAPT.md, "Convergence".
 *
 * - on a hot skin (PA_ADAPT_DONE_ON_SKIN): an edge outside [0.65, 1.5). A
 *   skin face refined by bisection (bisect.c) keeps edges a little shorter
 *   than PA_METRIC_LEN_LO, which only another iteration could change, and
 *   edges just outside the range are as many as the sequential remesher
 *   leaves anywhere (2-3 % with an anisotropic metric): with the strict
 *   range every iteration's borders would be the next one's work.
 * - near a hot skin (PA_ADAPT_DONE_NEAR_SKIN): an edge outside [0.5,
 *   1.5); elsewhere in a piece among several (PA_ADAPT_DONE): outside
 *   [0.5, 1.6). The remesher relaxes its working metric at frozen skin
 *   vertices whose edges are far from the target (remesh2d/mesh_2d.c,
 *   remesh3d/mesh_3d.c) over the first ring of input elements, which may
 *   be many output layers wide: those elements come back coarser than the
 *   target, away from any hot vertex, and only another iteration refines
 *   them (an upper bound of 2 leaves edges of 1.5 to 3.5 there). Away from
 *   a hot skin the bound is a little above the longest edges the
 *   sequential remesher leaves (1.55 in 2D): with 1.5, plate2d.mesh -hsiz
 *   0.0005 at 2 ranks ran a second iteration over its 4.85 M triangles for
 *   10 of them, whose longest edges were 1.505-1.555.
 * - made by a single piece away from its skin (PA_ADAPT_DONE_FREE): only
 *   what the remesher itself calls missed (an edge of 2 or more, a quality
 *   below QUAL_CLEARLY_BAD; remesh2d/driver_2d.c): another pass would
 *   remesh it the same way, and with [0.5, 1.5) the sequential remesher's
 *   leftovers (0.1-0.3 % of the edges in 3D, up to 1.7 long) would come
 *   back iteration after iteration until the loop stalls.
 * Quality: below opts->qual_threshold, or below QUAL_CLEARLY_BAD for
 * PA_ADAPT_DONE and PA_ADAPT_DONE_FREE (the sequential remesher leaves
 * elements between the two: its worst on the gmsh rod and the UGAWG fields
 * are 0.1-0.4). */
#define LEN_LO_SKIN 0.65
#define LEN_LO_DONE 0.5
#define LEN_HI_DONE 1.5
#define LEN_HI_PIECE 1.6
#define LEN_HI_FREE 2.0
#define QUAL_CLEARLY_BAD 0.05
/* When the loop ends without converging, what is still tagged makes it a
 * failure (stalled) only with an edge of LEN_CLEARLY_OFF or more or a
 * quality below QUAL_CLEARLY_BAD: the UGAWG polar-1 field on 2 ranks ends
 * its third pass with 2 elements tagged for an edge of 2.02 (the
 * sequential remesher's verdict bound is 2), while the defects this must
 * catch are far off (edges of 3-12, qualities of 0.016 and below). */
#define LEN_CLEARLY_OFF 2.5

/* The edge-length range [lo, hi) and the least quality an element of done
 * value dn must meet. */
static void criteria(uint8_t dn, double qual_threshold, double *lo, double *hi,
                     double *qmin) {
  *lo = PA_METRIC_LEN_LO;
  *hi = PA_METRIC_LEN_HI;
  *qmin = qual_threshold;
  if (!dn) return;
  *lo = dn == PA_ADAPT_DONE_ON_SKIN ? LEN_LO_SKIN
        : dn == PA_ADAPT_DONE_FREE  ? 0
                                    : LEN_LO_DONE;
  *hi = dn == PA_ADAPT_DONE_FREE ? LEN_HI_FREE
        : dn == PA_ADAPT_DONE    ? LEN_HI_PIECE
                                 : LEN_HI_DONE;
  if (dn == PA_ADAPT_DONE || dn == PA_ADAPT_DONE_FREE)
    *qmin = fmin(QUAL_CLEARLY_BAD, qual_threshold);
}

double pa__elem_work(const pa_mesh *m, pa_idx e) {
  int d = m->dim, nc = m->met_ncomp, tc = pa__tensor_ncomp(d);
  const pa_idx *v = m->elem + (size_t)(d + 1) * e;
  const double *x[4] = {NULL, NULL, NULL, NULL};
  double mean[6] = {0, 0, 0, 0, 0, 0}, t[6];
  for (int k = 0; k <= d; k++) {
    x[k] = m->coord + (size_t)d * v[k];
    pa__metric_tensor(d, nc, m->met + (size_t)nc * v[k], t);
    for (int c = 0; c < tc; c++)
      mean[c] += t[c] / (d + 1);
  }
  double vol = fabs(pa__simplex_volume(d, x));
  double det = pa__sym_det(d, mean);
  double w = det > 0 ? vol * sqrt(det) / pa__unit_simplex_volume(d) : 0;
  return (isfinite(w) ? w : 0) + 1.0;
}

/* 1 if element e has an edge outside [lo, hi) in the metric or (qmin > 0)
 * a quality below qmin, by the kernels of metric/metric2d.h and
 * metric3d.h inline, d a constant once inlined: the generic
 * pa__edge_length and pa__quality cost a call and a dispatch per edge. */
static inline int fails_dim(const pa_mesh *m, pa_idx e, const int d,
                            double lo, double hi, double qmin) {
  const int n = d + 1, nc = m->met_ncomp;
  const pa_idx *v = m->elem + (size_t)n * e;
  const double *x[4], *mt[4];
  for (int i = 0; i < n; i++) {
    x[i] = m->coord + (size_t)d * v[i];
    mt[i] = nc ? m->met + (size_t)nc * v[i] : NULL;
  }
  for (int i = 0; i < n; i++)
    for (int j = i + 1; j < n; j++) {
      double l = d == 2 ? pa__len2(nc, x[i], x[j], mt[i], mt[j])
                        : pa__len3(nc, x[i], x[j], mt[i], mt[j]);
      if (!(l >= lo && l < hi)) return 1;
    }
  if (!(qmin > 0)) return 0;
  return (d == 2 ? pa__qual2_stat(nc, x, mt) : pa__qual3_stat(nc, x, mt)) <
         qmin;
}

static int fails(const pa_mesh *m, pa_idx e, double lo, double hi,
                 double qmin) {
  return m->dim == 2 ? fails_dim(m, e, 2, lo, hi, qmin)
                     : fails_dim(m, e, 3, lo, hi, qmin);
}

/* The relative margin of the tests of fails_sizes_dim and qual2_below
 * that skip a square root or a division: far above the error of the
 * lengths and qualities the kernels compute (a few units in the last
 * place; ~1e-13 for pa__log_mean's logarithmic form at its nearest ends),
 * far below any spread of the lengths and qualities a remesher leaves. */
#define SQ_MARGIN 1e-9

/* pa__qual2_stat_euclid(x, s) < qmin, to the bit, without the division
 * when the area scaled by PA_METRIC_QUAL_NORM_2D is below or above qmin s
 * by SQ_MARGIN (qmin s a normal number); the kernel decides the others. */
static inline int qual2_below(const double *const *x, double s, double qmin) {
  double t = qmin * s;
  if (t >= DBL_MIN && s <= DBL_MAX) {
    double a = PA_METRIC_QUAL_NORM_2D * pa__simplex_volume(2, x);
    if (a < t * (1.0 - SQ_MARGIN)) return 1;
    if (a >= t * (1.0 + SQ_MARGIN)) return 0;
  }
  return pa__qual2_stat_euclid(x, s) < qmin;
}

/* fails_dim with sizes (met_ncomp 1, every -hsiz run), by the same
 * kernels with the squared edge lengths shared by the lengths
 * (pa__len3_inv's form) and the quality (pa__qual*_stat_euclid): the same
 * answer to the bit. The kernel's length sqrt(s2) * pa__log_mean(1/ha,
 * 1/hb) lies between sqrt(s2) / hmax and sqrt(s2) / hmin over the
 * element's sizes, so an edge whose squared Euclidean length s2 lies
 * within [lo^2 hmax^2, hi^2 hmin^2) by SQ_MARGIN passes without a square
 * root or a division (every edge of a near-uniform size field but those
 * near a bound); the others are measured as the kernel measures them. In
 * 2D the quality goes through qual2_below likewise. Debug builds check
 * each answer against fails_dim. */
static inline int fails_sizes_dim(const pa_mesh *m, pa_idx e, const int d,
                                  double lo, double hi, double qmin) {
  const int n = d + 1;
  const pa_idx *v = m->elem + (size_t)n * e;
  const double *x[4];
  double h[4], s = 0.0;
  for (int i = 0; i < n; i++) {
    x[i] = m->coord + (size_t)d * v[i];
    h[i] = m->met[v[i]];
  }
  /* the band of s2 that passes for sure: empty unless the sizes and their
   * squares are positive normal numbers (NaN fails the tests) */
  double hmin = h[0], hmax = h[0], sqlo = 1.0, sqhi = 0.0;
  int pos = 1;
  for (int i = 0; i < n; i++) {
    pos &= h[i] > 0;
    hmin = h[i] < hmin ? h[i] : hmin;
    hmax = h[i] > hmax ? h[i] : hmax;
  }
  if (pos && hmin * hmin >= DBL_MIN && hmax * hmax <= DBL_MAX) {
    sqlo = lo * lo * (hmax * hmax) * (1.0 + SQ_MARGIN);
    sqhi = hi * hi * (hmin * hmin) * (1.0 - SQ_MARGIN);
  }
  for (int i = 0; i < n; i++)
    for (int j = i + 1; j < n; j++) {
      double s2 = 0.0;
      for (int c = 0; c < d; c++)
        s2 += (x[j][c] - x[i][c]) * (x[j][c] - x[i][c]);
      s += s2;
      if (s2 >= sqlo && s2 < sqhi) continue;
      double l = sqrt(s2) * pa__log_mean(1.0 / h[i], 1.0 / h[j]);
      if (!(l >= lo && l < hi)) return 1;
    }
  if (!(qmin > 0)) return 0;
  return d == 2 ? qual2_below(x, s, qmin) : pa__qual3_stat_euclid(x, s) < qmin;
}

/* fails, by fails_sizes_dim when the metric is sizes. */
static int fails_fast(const pa_mesh *m, pa_idx e, double lo, double hi,
                      double qmin) {
  if (m->met_ncomp != 1) return fails(m, e, lo, hi, qmin);
  int t = m->dim == 2 ? fails_sizes_dim(m, e, 2, lo, hi, qmin)
                      : fails_sizes_dim(m, e, 3, lo, hi, qmin);
  PA_ASSERT(t == fails(m, e, lo, hi, qmin));
  return t;
}

/* With a model (opts->remesh.geometry), 1 if a vertex of element e lies on
 * a curve or surface but off it by more than PA_GEOM_SNAP_TOL of the
 * model's size: a point the remesher of a piece left on its reconstruction
 * (the model's was refused, and the piece's skin kept the snap moves from
 * it), which only another remesh puts on the model. off[v] caches the
 * answer per local vertex (0 not known, 1 on, 2 off). */
static int off_model(const pa_mesh *m, const pa_geometry *g, pa_idx e,
                     uint8_t *off) {
  int d = m->dim;
  const pa_idx *v = m->elem + (size_t)(d + 1) * e;
  for (int k = 0; k <= d; k++) {
    pa_idx x = v[k];
    if (!off[x]) {
      const double *p = m->coord + (size_t)d * x;
      double y[3] = {p[0], p[1], d == 3 ? p[2] : 0}, s2 = 0;
      off[x] = 1;
      if (m->vgdim[x] > 0 && m->vgdim[x] < d &&
          pa__geom_project(g, m->vgdim[x], m->vgtag[x], d, p, INFINITY, y)) {
        for (int j = 0; j < d; j++)
          s2 += (y[j] - p[j]) * (y[j] - p[j]);
        if (sqrt(s2) > PA_GEOM_SNAP_TOL * g->size) off[x] = 2;
      }
    }
    if (off[x] == 2) return 1;
  }
  return 0;
}

/* The criteria of each done value kind, made once per tag pass. */
typedef struct crit {
  double lo[PA_ADAPT_DONE_KIND + 1], hi[PA_ADAPT_DONE_KIND + 1],
      qmin[PA_ADAPT_DONE_KIND + 1];
} crit;

static void crit_init(crit *c, double qual_threshold) {
  for (int k = 0; k <= PA_ADAPT_DONE_KIND; k++)
    criteria((uint8_t)k, qual_threshold, &c->lo[k], &c->hi[k], &c->qmin[k]);
}

/* 1 if element e, of done value kind dn (without PA_ADAPT_DONE_PASSED), is
 * to be remeshed, by the criteria c; off: off_model's cache (NULL without
 * a model), which an element produced in this run always fills. */
static int tagged(const pa_mesh *m, const pa_adapt_opts *o, const crit *c,
                  pa_idx e, uint8_t dn, uint8_t *off) {
  int t = !dn && (m->eflag[e] & PA_FLAG_USER) != 0;
  if (!t && !o->user_tags_only)
    t = fails_fast(m, e, c->lo[dn], c->hi[dn], c->qmin[dn]);
  if (dn && off) t |= off_model(m, o->remesh.geometry, e, off);
  return t;
}

/* With a model: the owned elements within two rings of a vertex off it
 * (off[v] == 2) are tagged too, whatever they passed: a piece that holds
 * them holds the vertex free (not on its skin) with free neighbours, which
 * the remesher moves to make room for the vertex's point on the model. */
static pa_status tag_off_model(pa__iter *it, uint8_t *dn, uint8_t *off) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = it->dm;
  const pa_mesh *m = dm->mesh;
  int d = m->dim;
  uint8_t *ring = NULL;
  pa_idx nv = dm->nloc[PA_VERTEX];
  PA_ALLOC(ring, nv);
  memcpy(ring, off, (size_t)nv);
  for (int r = 0; r < 2; r++) {
    uint8_t mark = (uint8_t)(3 + r); /* the new ring's vertices */
    for (pa_idx e = 0; e < it->ne; e++) {
      const pa_idx *v = m->elem + (size_t)(d + 1) * e;
      int near = 0;
      for (int k = 0; k <= d && !near; k++)
        near = ring[v[k]] == 2 || (ring[v[k]] >= 3 && ring[v[k]] < mark);
      if (!near) continue;
      for (int k = 0; k <= d; k++)
        if (ring[v[k]] < 2) ring[v[k]] = mark;
      if (it->tag[e] || (m->eflag[e] & PA_FLAG_REQUIRED)) continue;
      it->tag[e] = 1;
      dn[e] &= (uint8_t)~PA_ADAPT_DONE_PASSED;
      it->work[e] = pa__elem_work(m, e);
    }
  }
cleanup:
  pa__free(ring);
  return st;
}

pa_status pa__adapt_tag(pa__iter *it, pa_dmesh_value *done, int fresh) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = it->dm;
  const pa_mesh *m = dm->mesh;
  const pa_adapt_opts *o = it->opts;
  uint8_t *dn = pa_dmesh_value_data(done, NULL, NULL);
  uint8_t *off = NULL;
  double x[2] = {0, 0};
  crit c;
  crit_init(&c, o->qual_threshold);
  it->ne = dm->nown[PA_ELEMENT];
  if (o->remesh.geometry && m->vgdim) PA_CALLOC(off, dm->nloc[PA_VERTEX]);
  PA_CALLOC(it->tag, it->ne);
  PA_ALLOC(it->work, it->ne);
  for (pa_idx e = 0; e < it->ne; e++) {
    if (m->eflag[e] & PA_FLAG_REQUIRED) continue;
    uint8_t kind = dn[e] & PA_ADAPT_DONE_KIND;
    if (kind && o->user_tags_only) continue;
    if (!fresh && (dn[e] & PA_ADAPT_DONE_PASSED)) {
#ifndef NDEBUG
      PA_CHECK(!tagged(m, o, &c, e, kind, off), PA_ERR_INTERNAL,
               "tag: element %lld passed the last tag, has not changed "
               "since, and fails it now",
               (long long)dm->gid[PA_ELEMENT][e]);
#endif
      continue;
    }
    int t = tagged(m, o, &c, e, kind, off);
    dn[e] = t ? kind : kind | PA_ADAPT_DONE_PASSED;
    it->tag[e] = (uint8_t)t;
    if (t) it->work[e] = pa__elem_work(m, e);
  }
  if (off) PA_CALL(tag_off_model(it, dn, off));
  for (pa_idx e = 0; e < it->ne; e++) {
    x[0] += it->tag[e];
    x[1] += it->tag[e] ? it->work[e] : 0;
  }
cleanup:
  pa__free(off);
  st = pa__agree(dm->comm, st);
  if (st == PA_SUCCESS) {
    st = pa__allreduce(dm->comm, x, 2, MPI_DOUBLE, MPI_SUM);
    it->ntagged = (pa_gid)x[0];
    it->tagwork = x[1];
  }
  return st;
}

pa_status pa__adapt_count_missed(pa__iter *it, int strict, pa_gid *missed) {
  pa_status st = PA_SUCCESS;
  const pa_mesh *m = it->dm->mesh;
  double lo, hi, qmin, n = 0;
  criteria(PA_ADAPT_DONE_FREE, it->opts->qual_threshold, &lo, &hi, &qmin);
  if (!strict) hi = LEN_CLEARLY_OFF;
  for (pa_idx e = 0; e < it->ne; e++) {
    if (!it->tag[e]) continue;
    n += fails(m, e, lo, hi, qmin);
  }
  PA_CALL(pa__allreduce(it->dm->comm, &n, 1, MPI_DOUBLE, MPI_SUM));
  *missed = (pa_gid)n;
cleanup:
  return st;
}
