/*
 * gradation.c -- metric gradation (Mmg's -hgrad, -hgradreq): limit the
 * growth of the prescribed size along mesh edges.
 *
 * Method: the unique edges are gathered once as a vertex-to-higher-neighbour
 * CSR (no sort of the whole edge list, deterministic order). Then sweeps relax
 * every edge touching a vertex that changed in the previous sweep, until no
 * vertex changes. A relaxation p -> q constrains q's metric by p's grown
 * along the edge; it only ever shrinks sizes.
 *
 * Sizes (isotropic): h_q = min(h_q, h_p + ln(beta) |pq|). Monotone; the fixed
 * point (a shortest-path problem) does not depend on the order.
 *
 * Tensors: M_q must contain T M_p T^T / eta^2, with
 *  - eta = 1 + L ln(beta), L = max(|pq| in M_p, |pq| in M_q): for sizes this
 *    is the size law above (the smaller size gives the longer length), and an
 *    edge that leaves p along its long axis but crosses q's thin one (a chord
 *    of a polar field) is measured by both ends;
 *  - T the rotation that takes the principal frame of M_p onto M_q's (ranks
 *    matched), on the axes both define (eigenvalues apart by more than
 *    GRAD_GAP_MIN), and by at most GRAD_ROT_RATE radians per unit length
 *    (at least one unit); T = I where a frame is undefined.
 * The frame of an anisotropic field may turn smoothly: on the UGAWG polar
 * fields it turns by 0.2 rad from one vertex to the next. The usual law
 * (T = I) makes two thin ellipses at an angle refine each other in every
 * direction and turns a 1:100 stretching into an isotropic over-refinement;
 * with T, a field whose sizes grow slowly enough is left exactly as it is,
 * however its frame turns. Where a metric is isotropic it is the usual
 * intersection, and the bound on the turn keeps the law honest where the
 * directions really disagree (the centre of a shell, which the thin
 * directions around it at right angles must grade in every direction).
 * When the bound is violated, M_q becomes M_q cap (T M_p T^T / eta^2)
 * (simultaneous reduction), which contains M_q and satisfies the bound.
 * Metrics only grow, by at least GRAD_TOL each time, so the sweeps end; at
 * the end every edge satisfies the bound with the final frames, so a second
 * gradation changes nothing. The eigen-decompositions are cached: an edge
 * whose frames T matches exactly costs two metric lengths and a comparison
 * of eigenvalues.
 *
 * Frozen vertices keep their metric; they constrain their neighbours with
 * hgradreq instead of hgrad. A rate <= 1 turns its propagation off.
 *
 * Invariant: every metric value stays finite and positive definite (sizes only
 * shrink; an intersection of SPD tensors is SPD).
 */
#include "metric/gradation.h"

#include <math.h>

/* A size must shrink by more than this (relative) to count as a change: the
 * sweeps end, and round-off never makes a change. */
#define GRAD_TOL 1e-3
#define GRAD_MAXSWEEP 10000
/* Free turn of the principal frame per unit length in the metric, radians:
 * an anisotropic element can follow a frame turning by 0.2-0.4 rad from one
 * element to the next (polar fields at radius 0.25-0.5), not by 90 degrees. */
#define GRAD_ROT_RATE 0.5
/* A principal direction is defined where the eigenvalues around it differ
 * by more than this (log ratio, about 10 % in size). */
#define GRAD_GAP_MIN 0.2
/* Eigenvalues closer than this (log ratio) are equal: any frame of theirs
 * is as good as another, so comparing sorted eigenvalues is exact. */
#define GRAD_GAP_NONE 1e-4

typedef struct grad_ctx {
  int dim, nc;
  const double *coord;
  double *met;
  /* tensors: eigenvalues (descending) and eigenvectors (pa__sym_eigen's
   * layout) of every vertex's metric */
  double *lam, *vec;
} grad_ctx;

/* Size law: constrain q by p; 1 if q changed. */
static int relax_size(const grad_ctx *c, pa_idx p, pa_idx q, double lnb) {
  const double *xp = c->coord + (size_t)c->dim * p;
  const double *xq = c->coord + (size_t)c->dim * q;
  double d2 = 0;
  for (int k = 0; k < c->dim; k++)
    d2 += (xq[k] - xp[k]) * (xq[k] - xp[k]);
  double hmax = c->met[p] + lnb * sqrt(d2);
  if (c->met[q] > hmax * (1 + 1e-12)) {
    c->met[q] = hmax;
    return 1;
  }
  return 0;
}

static double dot3(const double *a, const double *b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void cross3(const double *a, const double *b, double *c) {
  c[0] = a[1] * b[2] - a[2] * b[1];
  c[1] = a[2] * b[0] - a[0] * b[2];
  c[2] = a[0] * b[1] - a[1] * b[0];
}

/* Rotation by angle t about the unit axis n (row-major). */
static void rot3(const double *n, double t, double *r) {
  double c = cos(t), s = sin(t), u = 1 - c;
  r[0] = c + n[0] * n[0] * u;
  r[1] = n[0] * n[1] * u - n[2] * s;
  r[2] = n[0] * n[2] * u + n[1] * s;
  r[3] = n[1] * n[0] * u + n[2] * s;
  r[4] = c + n[1] * n[1] * u;
  r[5] = n[1] * n[2] * u - n[0] * s;
  r[6] = n[2] * n[0] * u - n[1] * s;
  r[7] = n[2] * n[1] * u + n[0] * s;
  r[8] = c + n[2] * n[2] * u;
}

static void matmul3(const double *a, const double *b, double *c) {
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      c[3 * i + j] = a[3 * i] * b[j] + a[3 * i + 1] * b[3 + j] +
                     a[3 * i + 2] * b[6 + j];
}

/* The rotation r (row-major) taking u onto w or -w, whichever is nearer. */
static void onto3(const double *u, const double *w0, double *r) {
  double w[3] = {w0[0], w0[1], w0[2]}, n[3];
  if (dot3(u, w) < 0)
    for (int i = 0; i < 3; i++) w[i] = -w[i];
  cross3(u, w, n);
  double sn = sqrt(dot3(n, n));
  if (!(sn > 1e-14)) {
    for (int i = 0; i < 9; i++) r[i] = i % 4 == 0;
    return;
  }
  for (int i = 0; i < 3; i++) n[i] /= sn;
  rot3(n, atan2(sn, dot3(u, w)), r);
}

/* The transport T of an edge p -> q (file comment) from the input frames
 * (lp, vp), (lq, vq); amax bounds its angle. Returns 1 if T matches the
 * frames exactly: T M_p T^T is then diagonal in q's frame, up to a rotation
 * within eigenspaces of p or q whose eigenvalues are equal, so M_q contains
 * it iff every eigenvalue of M_q is at least the eigenvalue of the same
 * rank. */
static int transport2(const double *lp, const double *vp, const double *lq,
                      const double *vq, double amax, double *t) {
  double gp = log(lp[0] / lp[1]), gq = log(lq[0] / lq[1]);
  t[0] = t[3] = 1;
  t[1] = t[2] = 0;
  if (gp < GRAD_GAP_MIN || gq < GRAD_GAP_MIN)
    return gp < GRAD_GAP_NONE || gq < GRAD_GAP_NONE;
  double c = vp[0] * vq[0] + vp[1] * vq[1], s = vp[0] * vq[1] - vp[1] * vq[0];
  if (c < 0) c = -c, s = -s;
  double a = atan2(s, c);
  int full = fabs(a) <= amax;
  if (!full) a = a > 0 ? amax : -amax;
  t[0] = t[3] = cos(a);
  t[2] = sin(a);
  t[1] = -t[2];
  return full;
}

static int transport3(const double *lp, const double *vp, const double *lq,
                      const double *vq, double amax, double *t) {
  double gq[2] = {log(lq[0] / lq[1]), log(lq[1] / lq[2])};
  double gp[2] = {log(lp[0] / lp[1]), log(lp[1] / lp[2])};
  for (int i = 0; i < 9; i++) t[i] = i % 4 == 0;
  /* the axis on q's larger gap first: the thin direction (rank 0) or the
   * long one (rank 2); then the other two about it */
  int g0 = gq[0] >= gq[1] ? 0 : 1, k0 = 2 * g0, g1 = 1 - g0;
  if (gq[g0] < GRAD_GAP_MIN || gp[g0] < GRAD_GAP_MIN)
    return (gq[0] < GRAD_GAP_NONE && gq[1] < GRAD_GAP_NONE) ||
           (gp[0] < GRAD_GAP_NONE && gp[1] < GRAD_GAP_NONE);
  int full = 1;
  onto3(vp + 3 * k0, vq + 3 * k0, t);
  if (gq[g1] >= GRAD_GAP_MIN && gp[g1] >= GRAD_GAP_MIN) {
    double u[3], r2[9], tt[9];
    for (int i = 0; i < 3; i++) u[i] = dot3(t + 3 * i, vp + 3);
    onto3(u, vq + 3, r2);
    matmul3(r2, t, tt);
    memcpy(t, tt, sizeof tt);
  } else {
    full = gq[g1] < GRAD_GAP_NONE || gp[g1] < GRAD_GAP_NONE;
  }
  double ct = 0.5 * (t[0] + t[4] + t[8] - 1);
  double a = acos(ct > 1 ? 1 : ct < -1 ? -1 : ct);
  if (a > amax) { /* the same axis, angle amax */
    double n[3] = {t[7] - t[5], t[2] - t[6], t[3] - t[1]};
    double sn = sqrt(dot3(n, n));
    if (sn > 1e-12) {
      for (int i = 0; i < 3; i++) n[i] /= sn;
      rot3(n, amax, t);
    } else { /* a half turn: no axis to scale, no turn */
      for (int i = 0; i < 9; i++) t[i] = i % 4 == 0;
    }
    full = 0;
  }
  return full;
}

/* out = s T M T^T for a full symmetric tensor m and a rotation t (row-major
 * dim x dim). */
static void rotate_tensor(int dim, const double *t, const double *m, double s,
                          double *out) {
  double a[3][3], tm[3][3];
  for (int i = 0; i < dim; i++)
    for (int j = 0; j < dim; j++) a[i][j] = m[pa__sym_index(i, j)];
  for (int i = 0; i < dim; i++)
    for (int j = 0; j < dim; j++) {
      double x = 0;
      for (int k = 0; k < dim; k++) x += t[dim * i + k] * a[k][j];
      tm[i][j] = x;
    }
  for (int i = 0; i < dim; i++)
    for (int j = i; j < dim; j++) {
      double x = 0;
      for (int k = 0; k < dim; k++) x += tm[i][k] * t[dim * j + k];
      out[pa__sym_index(i, j)] = s * x;
    }
}

/* Tensor law (file comment): constrain q by p; 1 if q changed. */
static int relax_tensor(const grad_ctx *c, pa_idx p, pa_idx q, double lnb) {
  int dim = c->dim, nc = c->nc, nd = dim * dim;
  const double *xp = c->coord + (size_t)dim * p;
  const double *xq = c->coord + (size_t)dim * q;
  const double *mp = c->met + (size_t)nc * p;
  double *mq = c->met + (size_t)nc * q;
  const double *lp = c->lam + (size_t)dim * p;
  const double *vp = c->vec + (size_t)nd * p;
  double *lq = c->lam + (size_t)dim * q, *vq = c->vec + (size_t)nd * q;
  double e[3] = {0, 0, 0};
  for (int k = 0; k < dim; k++)
    e[k] = xq[k] - xp[k];
  double l = sqrt(fmax(pa__metric_sqlen(dim, nc, mp, e),
                       pa__metric_sqlen(dim, nc, mq, e)));
  double eta = 1.0 + l * lnb, s = 1.0 / (eta * eta);
  double amax = fmin(GRAD_ROT_RATE * fmax(l, 1.0), 0.5 * M_PI);
  double t[9];
  int full = dim == 2 ? transport2(lp, vp, lq, vq, amax, t)
                      : transport3(lp, vp, lq, vq, amax, t);
  if (full) { /* compare the eigenvalues rank by rank */
    int fits = 1;
    for (int k = 0; k < dim; k++)
      if (s * lp[k] > lq[k] * (1.0 + GRAD_TOL)) fits = 0;
    if (fits) return 0;
  }
  double g[6], a[6];
  rotate_tensor(dim, t, mp, s, g);
  pa__metric_intersect(dim, nc, mq, g, a);
  if (pa__sym_det(dim, a) <= pa__sym_det(dim, mq) * (1.0 + GRAD_TOL)) return 0;
  memcpy(mq, a, sizeof(double) * nc);
  pa__sym_eigen(dim, mq, lq, vq);
  return 1;
}

/* Unique edges as a CSR from each vertex to its higher neighbours. */
static pa_status edge_csr(int dim, pa_idx nv, pa_idx ne, const pa_idx *elem,
                          pa_idx **startp, pa_idx **nbrp) {
  pa_status st = PA_SUCCESS;
  pa_idx *start = NULL, *nbr = NULL;
  int nvpe = dim + 1;
  PA_CALLOC(start, (size_t)nv + 1);
  for (pa_idx k = 0; k < ne; k++)
    for (int i = 0; i < nvpe; i++)
      for (int j = i + 1; j < nvpe; j++) {
        pa_idx a = elem[(size_t)nvpe * k + i], b = elem[(size_t)nvpe * k + j];
        start[(a < b ? a : b) + 1]++;
      }
  for (pa_idx v = 0; v < nv; v++) start[v + 1] += start[v];
  PA_ALLOC(nbr, start[nv] ? start[nv] : 1);
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
  *startp = start;
  *nbrp = nbr;
  start = nbr = NULL;
cleanup:
  pa__free(start);
  pa__free(nbr);
  return st;
}

pa_status pa__metric_gradation(int dim, int ncomp, pa_idx nv,
                               const double *coord, double *met, pa_idx ne,
                               const pa_idx *elem, const uint8_t *frozen,
                               double hgrad, double hgradreq,
                               pa_idx *nchanged) {
  pa_status st = PA_SUCCESS;
  pa_idx *start = NULL, *nbr = NULL;
  uint8_t *act = NULL, *chg = NULL;
  double *lam = NULL, *vec = NULL;
  pa_idx nch = 0;
  if (nchanged) *nchanged = 0;
  PA_CHECK(dim == 2 || dim == 3, PA_ERR_ARG, "gradation: bad dimension %d", dim);
  PA_CHECK(ncomp == 1 || ncomp == pa__tensor_ncomp(dim), PA_ERR_ARG,
           "gradation: bad metric component count %d", ncomp);
  if (!(hgrad > 1.0 || hgradreq > 1.0) || nv == 0 || ne == 0)
    return PA_SUCCESS;
  /* ln of the growth rate from p; 0: p constrains nothing */
  double lnb = hgrad > 1.0 ? log(hgrad) : 0.0;
  double lnbreq = hgradreq > 1.0 ? log(hgradreq) : 0.0;
  grad_ctx c = {dim, ncomp, coord, met, NULL, NULL};
  int (*relax)(const grad_ctx *, pa_idx, pa_idx, double) =
      ncomp == 1 ? relax_size : relax_tensor;

  PA_CALL(edge_csr(dim, nv, ne, elem, &start, &nbr));
  if (ncomp > 1) {
    PA_ALLOC(lam, (size_t)dim * nv);
    PA_ALLOC(vec, (size_t)dim * dim * nv);
    for (pa_idx v = 0; v < nv; v++)
      pa__sym_eigen(dim, met + (size_t)ncomp * v, lam + (size_t)dim * v,
                    vec + (size_t)dim * dim * v);
    c.lam = lam;
    c.vec = vec;
  }

  PA_ALLOC(act, nv);
  PA_CALLOC(chg, nv);
  memset(act, 1, (size_t)nv);
  for (int sweep = 0; sweep < GRAD_MAXSWEEP; sweep++) {
    int any = 0;
    for (pa_idx p = 0; p < nv; p++)
      for (pa_idx i = start[p]; i < start[p + 1]; i++) {
        pa_idx q = nbr[i];
        if (!act[p] && !act[q]) continue;
        int fp = frozen && frozen[p], fq = frozen && frozen[q];
        double lpq = fp ? lnbreq : lnb, lqp = fq ? lnbreq : lnb;
        if (!fq && lpq > 0 && relax(&c, p, q, lpq)) {
          if (!chg[q]) nch++;
          chg[q] = 2 | (chg[q] & 1);
          any = 1;
        }
        if (!fp && lqp > 0 && relax(&c, q, p, lqp)) {
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
  pa__free(lam);
  pa__free(vec);
  return st;
}
