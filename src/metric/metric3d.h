/*
 * metric3d.h -- the 3D metric kernels: the squared length of a vector, the
 * length of an edge and the quality of a tetrahedron in a Riemannian
 * metric, static inline for the remeshers' inner loops. metric2d.h holds
 * the same for 2D, with the reasoning of each formula; metric.h the
 * conventions and the dimension-generic entries that call these.
 *
 * A metric value has mc components: 0 = the identity (m may be NULL), 1 = an
 * isotropic size h (the tensor I/h^2), 6 = a tensor m11 m12 m22 m13 m23 m33.
 *
 * As in 2D the operation order is part of the contract (outputs are
 * reproducible to the bit): keep it when editing, or accept changed
 * outputs.
 */
#ifndef PA_METRIC3D_H
#define PA_METRIC3D_H

#include "metric/sym.h"

#include <math.h>

/* e^T M e for a tensor m11 m12 m22 m13 m23 m33: the diagonal terms, then
 * the off-diagonal ones, each counted twice by symmetry. */
static inline double pa__sqlen3_tensor(const double *m, const double *e) {
  return m[0] * e[0] * e[0] + m[2] * e[1] * e[1] + m[5] * e[2] * e[2] +
         2.0 * (m[1] * e[0] * e[1] + m[3] * e[0] * e[2] + m[4] * e[1] * e[2]);
}

/* e^T M e for a metric value of mc components (a size h: |e|^2 / h^2, the
 * length in units of the local target size). */
static inline double pa__sqlen3(int mc, const double *m, const double *e) {
  double n2 = e[0] * e[0] + e[1] * e[1] + e[2] * e[2];
  if (mc == 0) return n2;
  if (mc == 1) return n2 / (m[0] * m[0]);
  return pa__sqlen3_tensor(m, e);
}

/* Length of the edge from a to b whose ends carry the metrics ma, mb: the
 * logarithmic mean of the end lengths, exact when the length grows
 * geometrically along the edge (pa__len2 says why). With sizes
 * L = n * logmean(1/ha, 1/hb), n the Euclidean length: one square root.
 * The statistics and the 3D remesher measure with this one kernel. */
/* pa__len3 with sizes, given the inverse sizes ia = 1/ha and ib = 1/hb: for
 * a caller that takes each vertex's inverse once for several edges, with
 * the same bits. */
static inline double pa__len3_inv(const double *a, const double *b, double ia,
                                  double ib) {
  double e[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
  return sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]) * pa__log_mean(ia, ib);
}

static inline double pa__len3(int mc, const double *a, const double *b,
                              const double *ma, const double *mb) {
  if (mc == 1) return pa__len3_inv(a, b, 1.0 / ma[0], 1.0 / mb[0]);
  double e[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
  if (mc == 0) return sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
  return pa__log_mean(sqrt(pa__sqlen3_tensor(ma, e)),
                      sqrt(pa__sqlen3_tensor(mb, e)));
}

/* Quality of the tetrahedron p0..p3 whose vertices carry the metrics
 * m0..m3: the remeshers' kernel.
 *
 * Q = 72 sqrt(3) V_M / (sum of the six l_i^2)^(3/2) in the arithmetic mean
 * M of the four vertex tensors, V_M = V sqrt(det M): a volume over a length
 * cubed, so the shape alone; 1 on the tetrahedron regular in M, towards 0
 * as it flattens (Mmg's measure, pa__qual2 says why one mean tensor). From
 * the triple product det = 6 V the factor is PA_METRIC_QUAL_NORM_3D_DET.
 *
 * The remeshers compare qualities against floors and each other, so this
 * one is guarded rather than signed: an inverted tetrahedron is -1, a flat
 * one 0, and with a tensor so is one whose Euclidean volume is at rounding
 * level (det < 1e-11 |e|^3: its sign is not reliable, and the metric would
 * magnify it) or whose mean tensor is not positive. With sizes (mc 1, or
 * the identity, mc 0) the mean M = s I scales V^2 and l^6 alike: the
 * quality is Euclidean and the sizes are not read. */
/* pa__qual3 with sizes or the identity (mc <= 1): Euclidean, no metric
 * read. Its own function so the remeshers' isotropic inner loops (moves,
 * swaps) need not gather metrics nor pass them; the same operations, so
 * the same bits as pa__qual3. */
/* The edge vectors E of the tetrahedron p0..p3 (p1 - p0, p2 - p0, p3 - p0,
 * then the differences of those: p2 - p1, p3 - p1, p3 - p2) and the triple
 * product of the first three, 6 V: the common start of the qualities. */
static inline double pa__tet_edges3(const double *p0, const double *p1,
                                    const double *p2, const double *p3,
                                    double (*E)[3]) {
  for (int i = 0; i < 3; i++) {
    E[0][i] = p1[i] - p0[i];
    E[1][i] = p2[i] - p0[i];
    E[2][i] = p3[i] - p0[i];
  }
  const double *a = E[0], *b = E[1], *c = E[2];
  double det = a[0] * (b[1] * c[2] - b[2] * c[1]) -
               a[1] * (b[0] * c[2] - b[2] * c[0]) +
               a[2] * (b[0] * c[1] - b[1] * c[0]);
  for (int i = 0; i < 3; i++) {
    E[3][i] = b[i] - a[i];
    E[4][i] = c[i] - a[i];
    E[5][i] = c[i] - b[i];
  }
  return det;
}

/* pa__qual3 with sizes or the identity (mc <= 1): Euclidean, no metric
 * read. Its own function so the remeshers' isotropic inner loops (moves,
 * swaps) need not gather metrics nor pass them. */
static inline double pa__qual3_iso(const double *p0, const double *p1,
                                   const double *p2, const double *p3) {
  double E[6][3];
  double det = pa__tet_edges3(p0, p1, p2, p3, E);
  if (det <= 0.0) return det < 0.0 ? -1.0 : 0.0;
  double s = 0.0; /* term by term: the order of pa__qual3's sum */
  for (int k = 0; k < 6; k++)
    for (int i = 0; i < 3; i++) s += E[k][i] * E[k][i];
  return PA_METRIC_QUAL_NORM_3D_DET * det / (s * sqrt(s));
}

static inline double pa__qual3(int mc, const double *p0, const double *p1,
                               const double *p2, const double *p3,
                               const double *m0, const double *m1,
                               const double *m2, const double *m3) {
  if (mc <= 1) return pa__qual3_iso(p0, p1, p2, p3);
  double E[6][3];
  double det = pa__tet_edges3(p0, p1, p2, p3, E);
  if (det <= 0.0) return det < 0.0 ? -1.0 : 0.0;
  double se = 0.0;
  for (int k = 0; k < 3; k++)
    for (int i = 0; i < 3; i++) se += E[k][i] * E[k][i];
  if (det < 1e-11 * se * sqrt(se)) return 0.0;
  double M[6];
  for (int i = 0; i < 6; i++) M[i] = 0.25 * (m0[i] + m1[i] + m2[i] + m3[i]);
  double dm = M[0] * (M[2] * M[5] - M[4] * M[4]) -
              M[1] * (M[1] * M[5] - M[4] * M[3]) +
              M[3] * (M[1] * M[4] - M[2] * M[3]);
  if (dm <= 0.0) return 0.0;
  double s = 0.0;
  for (int k = 0; k < 6; k++) s += pa__sqlen3_tensor(M, E[k]);
  return PA_METRIC_QUAL_NORM_3D_DET * det * sqrt(dm) / (s * sqrt(s));
}

/* The same quality for the statistics (pa__quality, which the CLI's stats,
 * the parallel loop's tags and the VTU writer read), of the tetrahedron
 * x[0..3] with metrics m[0..3]: signed, Q < 0 exactly for the elements the
 * checker counts as inverted, since the volume is the mesh's own
 * (pa__simplex_volume).
 *
 * Two kernels because they differ beyond rounding: pa__qual3 clamps
 * (-1 inverted, 0 flat or at rounding level), this one does not. They also
 * round differently: this one scales V = det / 6 by PA_METRIC_QUAL_NORM_3D
 * where pa__qual3 scales det by PA_METRIC_QUAL_NORM_3D_DET, forms the edges
 * opposite x[0] as x[j] - x[i] where pa__qual3 subtracts the edge vectors from
 * x[0], and sums l^2 over the edges in a loop. Each one's figures are in use.
 */
/* pa__qual3_stat without a tensor: the Euclidean quality of the
 * tetrahedron x from s, the sum of its squared edge lengths in
 * pa__qual3_stat's order (a caller that has them sums them itself:
 * tag.c). */
static inline double pa__qual3_stat_euclid(const double *const *x, double s) {
  if (!(s > 0.0)) return 0.0;
  return PA_METRIC_QUAL_NORM_3D * pa__simplex_volume(3, x) / (s * sqrt(s));
}

static inline double pa__qual3_stat(int mc, const double *const *x,
                                    const double *const *m) {
  int tensor = mc > 1;
  double mb[6] = {0, 0, 0, 0, 0, 0};
  if (tensor) {
    for (int i = 0; i < 4; i++)
      for (int k = 0; k < 6; k++)
        mb[k] += m[i][k];
    for (int k = 0; k < 6; k++)
      mb[k] /= 4;
  }
  int mcm = tensor ? mc : 0;
  double s = 0.0;
  for (int i = 0; i < 3; i++)
    for (int j = i + 1; j <= 3; j++) {
      double e[3] = {x[j][0] - x[i][0], x[j][1] - x[i][1], x[j][2] - x[i][2]};
      s += pa__sqlen3(mcm, mb, e);
    }
  if (!tensor) return pa__qual3_stat_euclid(x, s);
  if (!(s > 0.0)) return 0.0;
  double sd = sqrt(fmax(pa__sym_det(3, mb), 0.0));
  return PA_METRIC_QUAL_NORM_3D * pa__simplex_volume(3, x) * sd /
         (s * sqrt(s));
}

#endif /* PA_METRIC3D_H */
