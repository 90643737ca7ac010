/*
 * sym.h -- what the metric kernels (metric2d.h, metric3d.h) take from the
 * rest of the component, kept below both so that the kernels and metric.c,
 * which calls them, depend one way: the determinant of a symmetric tensor,
 * the logarithmic mean of two lengths and the quality normalisations.
 * Static inline: the kernels sit in the remeshers' inner loops.
 */
#ifndef PA_METRIC_SYM_H
#define PA_METRIC_SYM_H

#include <math.h>

/* The normalisations of the quality (Mmg's), which make it 1 on the
 * regular simplex:
 *  - 2D, 4 sqrt(3): Q = 4 sqrt(3) A_M / sum l_M^2 (the equilateral triangle
 *    of unit edges has A = sqrt(3)/4 and sum l^2 = 3);
 *  - 3D, 72 sqrt(3): Q = 72 sqrt(3) V_M / (sum l_M^2)^(3/2) (the regular
 *    tetrahedron of unit edges has V = sqrt(2)/12 and sum l^2 = 6);
 *  - 3D from the triple product det = 6 V, 12 sqrt(3) = 72 sqrt(3) / 6:
 *    Q = 12 sqrt(3) det_M / (sum l_M^2)^(3/2).
 * Each is the double nearest its exact value. */
#define PA_METRIC_QUAL_NORM_2D 6.928203230275509
#define PA_METRIC_QUAL_NORM_3D 124.70765814495915
#define PA_METRIC_QUAL_NORM_3D_DET 20.784609690826528

/* a*c - b*b with one rounding error at most (Kahan's fma trick). */
static inline double pa__det2_accurate(double a, double b, double c) {
  double w = b * b;
  double e = fma(-b, b, w); /* w - b*b exactly, i.e. minus the rounding error */
  double f = fma(a, c, -w);
  return f + e;
}

/* det m of a symmetric tensor stored m11 m12 m22 (m13 m23 m33). */
static inline double pa__sym_det(int dim, const double *m) {
  if (dim == 2) return pa__det2_accurate(m[0], m[1], m[2]);
  double a11 = m[0], a12 = m[1], a22 = m[2], a13 = m[3], a23 = m[4], a33 = m[5];
  return a11 * (a22 * a33 - a23 * a23) - a12 * (a12 * a33 - a23 * a13) +
         a13 * (a12 * a23 - a22 * a13);
}

/* Logarithmic mean of two metric lengths: (la - lb) / ln(la / lb), the
 * arithmetic mean when they differ by less than 1e-3 relatively (also when
 * both are zero or one is not finite, where the log form is undefined).
 * Mmg's edge length from the two end lengths; the remeshers use it too, so
 * that their decisions and the statistics see the same lengths. */
static inline double pa__log_mean(double la, double lb) {
  /* Equal ends (a uniform size: every edge of an -hsiz run) first, the
   * cheapest case: 0.5 (la + la) is la, to the bit, below overflow. */
  if (la == lb) return la;
  if (la < lb) { /* symmetric to the last bit: L(a,b) == L(b,a) */
    double t = la;
    la = lb;
    lb = t;
  }
  double d = la - lb;
  if (!(d >= 1e-3 * la) || !(lb > 0.0)) return 0.5 * (la + lb);
  return d / log(la / lb);
}

#endif
