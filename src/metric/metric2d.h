/*
 * metric2d.h -- the 2D metric kernels: the squared length of a vector, the
 * length of an edge and the quality of a triangle in a Riemannian metric,
 * static inline for the remeshers' inner loops. metric3d.h holds the same
 * for 3D; metric.h the conventions they follow and the dimension-generic
 * entries (pa__metric_sqlen, pa__edge_length, pa__quality) that call them.
 *
 * A metric value has mc components: 0 = the identity (m may be NULL), 1 = an
 * isotropic size h (the tensor I/h^2), 3 = a tensor m11 m12 m22.
 *
 * The arithmetic is part of the contract. The remeshers decide on these
 * values (split above PA_METRIC_LEN_HI, refuse an element below a quality
 * floor) and the statistics print them, and padapt's outputs are reproducible
 * to the bit: each kernel keeps the exact operation order of the copy it
 * replaced. A different association, x / 3 for x * (1.0 / 3.0), changes
 * outputs; so does merging the two quality kernels (see pa__qual2_stat).
 */
#ifndef PA_METRIC2D_H
#define PA_METRIC2D_H

#include "metric/sym.h"

#include <math.h>

/* e^T M e, the squared length of the vector e = (x, y) in the metric m.
 * A size h stands for M = I / h^2, so the length is the Euclidean one
 * divided by h: edges are measured in units of the local target size. */
static inline double pa__sqlen2(int mc, const double *m, double x, double y) {
  if (mc == 0) return x * x + y * y;
  if (mc == 1) return (x * x + y * y) / (m[0] * m[0]);
  return m[0] * x * x + 2.0 * m[1] * x * y + m[2] * y * y;
}

/* Length of the edge from a to b whose ends carry the metrics ma, mb.
 *
 * The length in a metric field M(t) is the integral over the edge of
 * l(t) = sqrt(e^T M(t) e); only the end values la, lb are known. Their
 * logarithmic mean (la - lb) / ln(la / lb) (pa__log_mean) is that integral
 * when l grows geometrically along the edge, l(t) = la^(1-t) lb^t, which is
 * what a graded size field does (each step a bounded ratio); it lies
 * between the geometric and the arithmetic mean, and is the arithmetic mean
 * when the ends nearly agree. The statistics and both remeshers measure
 * with this one kernel, so that an edge the remesher leaves in range is
 * counted in range.
 *
 * With sizes, la = n / ha and lb = n / hb for the Euclidean length n, and
 * the mean is homogeneous, so L = n * logmean(1/ha, 1/hb): one square root
 * instead of two. Equal sizes (a uniform size field) skip the mean, which
 * is then 0.5 * (1/h + 1/h) = 1/h to the bit. mc 0: the Euclidean length. */
static inline double pa__len2(int mc, const double *a, const double *b,
                              const double *ma, const double *mb) {
  double x = b[0] - a[0], y = b[1] - a[1];
  if (mc <= 1) {
    double n = sqrt(x * x + y * y);
    if (mc == 0) return n;
    if (ma[0] == mb[0]) return n * (1.0 / ma[0]);
    return n * pa__log_mean(1.0 / ma[0], 1.0 / mb[0]);
  }
  double la = sqrt(pa__sqlen2(mc, ma, x, y));
  double lb = sqrt(pa__sqlen2(mc, mb, x, y));
  return pa__log_mean(la, lb);
}

/* Quality of the triangle abc (counter-clockwise) whose vertices carry the
 * metrics ma, mb, mcv: the remeshers' kernel.
 *
 * Q = 4 sqrt(3) A_M / (l1^2 + l2^2 + l3^2), measured in the arithmetic
 * mean M of the three vertex tensors: l_i^2 = e_i^T M e_i and
 * A_M = A sqrt(det M), the area the triangle has once M maps it to the
 * Euclidean plane. The ratio of an area to a squared length depends on the
 * shape alone; PA_METRIC_QUAL_NORM_2D makes it 1 on the triangle equilateral in
 * M. It tends to 0 as the triangle flattens and is negative when inverted. One
 * mean tensor rather than each edge in its ends' metrics: a shape needs one
 * inner product, and this one is cheap (Mmg's choice too, so that the figures
 * compare).
 *
 * With sizes (mc 1) the mean M = s I scales the area and every l^2 by s
 * alike: the quality is the Euclidean one and the sizes are not read; so
 * with mc 0. */
/* pa__qual2 with sizes (the Euclidean quality) of the triangle (ax, ay),
 * (bx, by), (cx, cy), from scalars: a loop over many triangles then
 * vectorises (smooth_2d.c). */
static inline double pa__qual2_xy(double ax, double ay, double bx, double by,
                                  double cx, double cy) {
  double e1x = bx - ax, e1y = by - ay;
  double e2x = cx - ax, e2y = cy - ay;
  double e3x = cx - bx, e3y = cy - by;
  double area = 0.5 * (e1x * e2y - e1y * e2x);
  double s = e1x * e1x + e1y * e1y + e2x * e2x + e2y * e2y + e3x * e3x +
             e3y * e3y;
  return PA_METRIC_QUAL_NORM_2D * area / s;
}

static inline double pa__qual2(int mc, const double *a, const double *b,
                               const double *c, const double *ma,
                               const double *mb, const double *mcv) {
  if (mc <= 1) return pa__qual2_xy(a[0], a[1], b[0], b[1], c[0], c[1]);
  double e1x = b[0] - a[0], e1y = b[1] - a[1];
  double e2x = c[0] - a[0], e2y = c[1] - a[1];
  double e3x = c[0] - b[0], e3y = c[1] - b[1];
  double area = 0.5 * (e1x * e2y - e1y * e2x);
  double m0 = (ma[0] + mb[0] + mcv[0]) * (1.0 / 3.0);
  double m1 = (ma[1] + mb[1] + mcv[1]) * (1.0 / 3.0);
  double m2 = (ma[2] + mb[2] + mcv[2]) * (1.0 / 3.0);
  double det = m0 * m2 - m1 * m1;
  double s = m0 * (e1x * e1x + e2x * e2x + e3x * e3x) +
             2 * m1 * (e1x * e1y + e2x * e2y + e3x * e3y) +
             m2 * (e1y * e1y + e2y * e2y + e3y * e3y);
  return PA_METRIC_QUAL_NORM_2D * area * sqrt(det > 0 ? det : 0) / s;
}

/* The same quality for the statistics (pa__quality, which the CLI's stats,
 * the parallel loop's tags and the VTU writer read), of the triangle
 * x[0..2] with metrics m[0..2].
 *
 * Two kernels because they round differently, and each one's figures are
 * in use: this one divides the summed tensors by 3 where pa__qual2
 * multiplies by 1/3, takes det M with one rounding (pa__sym_det) where
 * pa__qual2 rounds twice, sums l^2 edge by edge where pa__qual2 gathers
 * each coordinate's products, and returns 0 for a triangle of no extent
 * rather than dividing by 0. The area is the same expression in both (this
 * one takes the mesh's own, pa__simplex_volume, so Q < 0 exactly for the
 * elements the checker counts as inverted): they differ by rounding only,
 * never in sign. */
/* pa__qual2_stat without a tensor: the Euclidean quality of the triangle
 * x from s, the sum of its squared edge lengths in pa__qual2_stat's order
 * (a caller that has them sums them itself: tag.c). */
static inline double pa__qual2_stat_euclid(const double *const *x, double s) {
  if (!(s > 0.0)) return 0.0;
  return PA_METRIC_QUAL_NORM_2D * pa__simplex_volume(2, x) / s;
}

static inline double pa__qual2_stat(int mc, const double *const *x,
                                    const double *const *m) {
  int tensor = mc > 1;
  double mb[3] = {0, 0, 0};
  if (tensor) {
    for (int i = 0; i < 3; i++)
      for (int k = 0; k < 3; k++)
        mb[k] += m[i][k];
    for (int k = 0; k < 3; k++)
      mb[k] /= 3;
  }
  int mcm = tensor ? mc : 0;
  double s = 0.0;
  for (int i = 0; i < 2; i++)
    for (int j = i + 1; j <= 2; j++)
      s += pa__sqlen2(mcm, mb, x[j][0] - x[i][0], x[j][1] - x[i][1]);
  if (!tensor) return pa__qual2_stat_euclid(x, s);
  if (!(s > 0.0)) return 0.0;
  double sd = sqrt(fmax(pa__sym_det(2, mb), 0.0));
  return PA_METRIC_QUAL_NORM_2D * pa__simplex_volume(2, x) * sd / s;
}

#endif /* PA_METRIC2D_H */
