/*
 * gradation.c -- metric gradation (Mmg's -hgrad): limit the growth of the
 * prescribed size along mesh edges.
 *
 * Method: the unique edges are gathered once as a vertex-to-higher-neighbour
 * CSR (no sort of the whole edge list, deterministic order). Then sweeps relax
 * every edge touching a vertex that changed in the previous sweep, until no
 * vertex changes. Isotropic relaxation h_q = min(h_q, h_p + ln(beta)|pq|) is
 * monotone and converges exactly; the tensor version intersects M_q with
 * M_p / (1 + L_p ln(beta))^2 and counts a change only when a size shrinks by
 * more than 0.1 %, so it terminates. Frozen vertices keep their metric.
 *
 * Invariant: every metric value stays finite and positive definite (sizes only
 * shrink; an intersection of SPD tensors is SPD).
 */
#include "metric/gradation.h"

#include <math.h>

#define GRAD_TOL 1e-3
#define GRAD_MAXSWEEP 10000

/* Apply f to the eigenvalues of a 2x2 SPD tensor (f: 0 sqrt, 1 inverse sqrt). */
static void sym2_pow(const double *m, double *out, int inv) {
  double a = m[0], b = m[1], c = m[2];
  double hm = 0.5 * (a + c), hd = 0.5 * (a - c);
  double r = sqrt(hd * hd + b * b);
  double l1 = hm + r, l2 = (a * c - b * b) / l1;
  double f1 = inv ? 1.0 / sqrt(l1) : sqrt(l1);
  double f2 = inv ? 1.0 / sqrt(l2) : sqrt(l2);
  double s;
  if (r <= 1e-14 * hm)
    s = inv ? -0.5 / (hm * sqrt(hm)) : 0.5 / sqrt(hm);
  else
    s = (f1 - f2) / (l1 - l2);
  out[0] = f2 + s * (a - l2);
  out[1] = s * b;
  out[2] = f2 + s * (c - l2);
}

/* C = A B A for symmetric 2x2 A, B. */
static void sym2_aba(const double *a, const double *b, double *c) {
  double t00 = a[0] * b[0] + a[1] * b[1], t01 = a[0] * b[1] + a[1] * b[2];
  double t10 = a[1] * b[0] + a[2] * b[1], t11 = a[1] * b[1] + a[2] * b[2];
  c[0] = t00 * a[0] + t01 * a[1];
  c[1] = t00 * a[1] + t01 * a[2];
  c[2] = t10 * a[1] + t11 * a[2];
}

/*
 * Intersect the 2D tensor mq with mg (in place in mq) if mg is more
 * restrictive in some direction by more than GRAD_TOL; returns 1 if mq changed.
 * In the frame where mq is the identity, mg becomes G with eigenpairs
 * (g_i, v_i); the intersection is mq^(1/2) V diag(max(1, g_i)) V^T mq^(1/2).
 */
static int intersect2(double *mq, const double *mg) {
  double s[3], is[3], g[3];
  sym2_pow(mq, s, 0);
  sym2_pow(mq, is, 1);
  sym2_aba(is, mg, g);
  double hm = 0.5 * (g[0] + g[2]), hd = 0.5 * (g[0] - g[2]);
  double r = sqrt(hd * hd + g[1] * g[1]);
  double g1 = hm + r, g2 = hm - r;
  if (g1 <= 1.0 + GRAD_TOL) return 0;
  /* eigenvector of g1 */
  double vx, vy;
  if (r <= 1e-14 * hm) {
    vx = 1;
    vy = 0;
  } else if (hd >= 0) {
    vx = hd + r;
    vy = g[1];
  } else {
    vx = g[1];
    vy = r - hd;
  }
  double n = sqrt(vx * vx + vy * vy);
  vx /= n;
  vy /= n;
  double d1 = g1 > 1 ? g1 : 1, d2 = g2 > 1 ? g2 : 1;
  double k[3] = {d1 * vx * vx + d2 * vy * vy, (d1 - d2) * vx * vy,
                 d1 * vy * vy + d2 * vx * vx};
  sym2_aba(s, k, mq);
  return 1;
}

/* 3D: intersection through the shared metric kernels. */
static int intersect3(double *mq, const double *mg) {
  double out[6];
  pa__metric_intersect(3, 6, mq, mg, out);
  int changed = 0;
  for (int i = 0; i < 6; i++)
    if (fabs(out[i] - mq[i]) > GRAD_TOL * (fabs(mq[0]) + fabs(mq[3]) + fabs(mq[5])))
      changed = 1;
  if (changed) memcpy(mq, out, sizeof out);
  return changed;
}

/* Relax edge p -> q: constrain q's metric by p's. Returns 1 if q changed. */
static int relax(int dim, int ncomp, const double *coord, double *met,
                 pa_idx p, pa_idx q, double lnb) {
  const double *xp = coord + (size_t)dim * p, *xq = coord + (size_t)dim * q;
  double e[3] = {0, 0, 0}, d2 = 0;
  for (int k = 0; k < dim; k++) {
    e[k] = xq[k] - xp[k];
    d2 += e[k] * e[k];
  }
  if (ncomp == 1) {
    double hmax = met[p] + lnb * sqrt(d2);
    if (met[q] > hmax * (1 + 1e-12)) {
      met[q] = hmax;
      return 1;
    }
    return 0;
  }
  const double *mp = met + (size_t)ncomp * p;
  double *mq = met + (size_t)ncomp * q;
  double l = sqrt(pa__metric_sqlen(dim, ncomp, mp, e));
  double eta = 1.0 + l * lnb;
  double mg[6];
  for (int k = 0; k < ncomp; k++) mg[k] = mp[k] / (eta * eta);
  return dim == 2 ? intersect2(mq, mg) : intersect3(mq, mg);
}

pa_status pa__metric_gradation(int dim, int ncomp, pa_idx nv,
                               const double *coord, double *met, pa_idx ne,
                               const pa_idx *elem, const uint8_t *frozen,
                               double hgrad, pa_idx *nchanged) {
  pa_status st = PA_SUCCESS;
  pa_idx *start = NULL, *nbr = NULL;
  uint8_t *act = NULL, *chg = NULL;
  pa_idx nch = 0;
  if (nchanged) *nchanged = 0;
  PA_CHECK(dim == 2 || dim == 3, PA_ERR_ARG, "gradation: bad dimension %d", dim);
  PA_CHECK(ncomp == 1 || ncomp == pa__tensor_ncomp(dim), PA_ERR_ARG,
           "gradation: bad metric component count %d", ncomp);
  if (!(hgrad > 1.0) || nv == 0 || ne == 0) return PA_SUCCESS;
  int nvpe = dim + 1;
  double lnb = log(hgrad);

  /* Unique edges as a CSR from each vertex to its higher neighbours. */
  PA_CALLOC(start, (size_t)nv + 1);
  for (pa_idx k = 0; k < ne; k++)
    for (int i = 0; i < nvpe; i++)
      for (int j = i + 1; j < nvpe; j++) {
        pa_idx a = elem[(size_t)nvpe * k + i], b = elem[(size_t)nvpe * k + j];
        start[(a < b ? a : b) + 1]++;
      }
  for (pa_idx v = 0; v < nv; v++) start[v + 1] += start[v];
  PA_ALLOC(nbr, start[nv]);
  for (pa_idx k = 0; k < ne; k++)
    for (int i = 0; i < nvpe; i++)
      for (int j = i + 1; j < nvpe; j++) {
        pa_idx a = elem[(size_t)nvpe * k + i], b = elem[(size_t)nvpe * k + j];
        pa_idx lo = a < b ? a : b, hi = a < b ? b : a;
        nbr[start[lo]++] = hi;
      }
  for (pa_idx v = nv; v > 0; v--) start[v] = start[v - 1];
  start[0] = 0;
  /* sort and deduplicate each row in place, then compact */
  pa_idx w = 0;
  for (pa_idx v = 0; v < nv; v++) {
    pa_idx b = start[v], e = start[v + 1];
    for (pa_idx i = b + 1; i < e; i++) { /* insertion sort: rows are short */
      pa_idx x = nbr[i], j = i - 1;
      while (j >= b && nbr[j] > x) {
        nbr[j + 1] = nbr[j];
        j--;
      }
      nbr[j + 1] = x;
    }
    start[v] = w;
    for (pa_idx i = b; i < e; i++)
      if (i == b || nbr[i] != nbr[i - 1]) nbr[w++] = nbr[i];
  }
  start[nv] = w;

  PA_ALLOC(act, nv);
  PA_CALLOC(chg, nv);
  memset(act, 1, (size_t)nv);
  for (int sweep = 0; sweep < GRAD_MAXSWEEP; sweep++) {
    int any = 0;
    for (pa_idx p = 0; p < nv; p++)
      for (pa_idx i = start[p]; i < start[p + 1]; i++) {
        pa_idx q = nbr[i];
        if (!act[p] && !act[q]) continue;
        if (!(frozen && frozen[q]) &&
            relax(dim, ncomp, coord, met, p, q, lnb)) {
          if (!chg[q]) nch++;
          chg[q] = 2 | (chg[q] & 1);
          any = 1;
        }
        if (!(frozen && frozen[p]) &&
            relax(dim, ncomp, coord, met, q, p, lnb)) {
          if (!chg[p]) nch++;
          chg[p] = 2 | (chg[p] & 1);
          any = 1;
        }
      }
    if (!any) break;
    /* bit 2: changed in this sweep -> active in the next; bit 1: ever */
    for (pa_idx v = 0; v < nv; v++) {
      act[v] = (chg[v] & 2) ? 1 : 0;
      if (chg[v]) chg[v] = 1;
    }
  }
  if (nchanged) *nchanged = nch;
cleanup:
  pa__free(start);
  pa__free(nbr);
  pa__free(act);
  pa__free(chg);
  return st;
}
