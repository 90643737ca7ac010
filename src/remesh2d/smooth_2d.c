/*
 * smooth_2d.c -- vertex relocation in the 2D remesher: quality moves (an
 * interior vertex towards the mean of the ideal apexes of its ball) and
 * length moves (a Gauss-Newton step on the lengths of its edges, as in 3D:
 * smooth_3d.c), with their passes. Only free interior vertices move (not
 * frozen, corner or feature ones); the metric and fields of a moved vertex
 * are interpolated in its old ball. Shared contract of the operators:
 * ops_2d.h.
 */
#include "remesh2d/ops_2d.h"

/* A move is kept when it raises the ball's worst or mean quality by 1 %. */
#define MOVE_GAIN_MIN 1.01
#define MOVE_GAIN_MEAN 1.01

/* Move interior vertex p (its closed ball el[0..n), local indices loc) to
 * np: metric and fields interpolated from the old triangle holding np
 * (barycentric; linear fields stay exact), qualities updated. */
static void apply_move(pa__rmesh *rm, pa_idx p, const pa_idx *el,
                       const int *loc, int n, const double *np) {
  double *xp = rm->x + 2 * (size_t)p;
  double x0 = xp[0], y0 = xp[1];
  for (int s = 0; s < n; s++) {
    const pa_idx *v = rm->ev + 3 * (size_t)el[s];
    pa_idx va = v[RM_NX3(loc[s])], vb = v[RM_PV3(loc[s])];
    const double *a = RM_X(va), *b = RM_X(vb);
    double area = (a[0] - x0) * (b[1] - y0) - (a[1] - y0) * (b[0] - x0);
    double wa = ((np[0] - x0) * (b[1] - y0) - (np[1] - y0) * (b[0] - x0)) / area;
    double wb = ((a[0] - x0) * (np[1] - y0) - (a[1] - y0) * (np[0] - x0)) / area;
    double wp = 1 - wa - wb;
    if (wa >= -1e-12 && wb >= -1e-12 && wp >= -1e-12) {
      pa_idx src[3] = {p, va, vb};
      double w[3] = {wp, wa, wb};
      pa__rm_interp(rm, p, 3, src, w);
      break;
    }
  }
  xp[0] = np[0];
  xp[1] = np[1];
  for (int s = 0; s < n; s++) {
    const pa_idx *v = rm->ev + 3 * (size_t)el[s];
    rm->q[el[s]] = (float)rm_elem_qual(rm, v[0], v[1], v[2]);
    rm_elem_changed(rm, el[s]); /* p's neighbours see a new ball */
  }
  rm->nmove++;
}

/* The triangles of a ball for the trial qualities of a move under a size
 * metric (where the quality is the Euclidean one, pa__qual2): vertex j of
 * triangle s at (x[j][s], y[j][s]), in the element's order, p's entry
 * rewritten at each trial. One loop then evaluates the whole ball with the
 * kernel (pa__qual2_xy), and vectorises. */
typedef struct ball_xy {
  double x[3][RM_BALL_MAX], y[3][RM_BALL_MAX];
} ball_xy;

static void ball_xy_qual(const ball_xy *b, int n, double *q) {
  for (int s = 0; s < n; s++)
    q[s] = pa__qual2_xy(b->x[0][s], b->y[0][s], b->x[1][s], b->y[1][s],
                        b->x[2][s], b->y[2][s]);
}

/* Move interior vertex p = v[ip] of element k towards the mean of the ideal
 * apexes of its ball (equilateral in the metric of p). Returns 1 if moved. */
static int move_vertex(pa__rmesh *rm, pa_idx k, int ip) {
  int mc = rm->mcomp;
  pa_idx p = rm->ev[3 * k + ip];
  pa_idx el[RM_BALL_MAX];
  int loc[RM_BALL_MAX], closed;
  int n = rm_ball_2d(rm, k, ip, el, loc, &closed);
  if (n < 3 || !closed) return 0;
  double t[3];
  rm_tensor2(mc, RM_M(p), t);
  double det = t[0] * t[2] - t[1] * t[1];
  if (!(det > 0)) return 0;
  double sd = 1.0 / sqrt(det);
  double cx = 0, cy = 0, qold = 1, qmean = 0;
  ball_xy bxy;
  for (int s = 0; s < n; s++) {
    const pa_idx *v = rm->ev + 3 * (size_t)el[s];
    if (rm->etag[el[s]] & RM_E_FROZEN) return 0;
    int l1 = RM_NX3(loc[s]), l2 = RM_PV3(loc[s]);
    const double *a = RM_X(v[l1]), *b = RM_X(v[l2]);
    if (mc <= 1) {
      bxy.x[l1][s] = a[0];
      bxy.y[l1][s] = a[1];
      bxy.x[l2][s] = b[0];
      bxy.y[l2][s] = b[1];
    }
    double dx = b[0] - a[0], dy = b[1] - a[1];
    /* metric rotation by +90 degrees: adj(M) R d / sqrt(det M) */
    double rx = -dy, ry = dx;
    double yx = (t[2] * rx - t[1] * ry) * sd, yy = (-t[1] * rx + t[0] * ry) * sd;
    cx += 0.5 * (a[0] + b[0]) + 0.8660254037844386 * yx;
    cy += 0.5 * (a[1] + b[1]) + 0.8660254037844386 * yy;
    double q = rm->q[el[s]];
    if (q < qold) qold = q;
    qmean += q;
  }
  qmean /= n;
  cx /= n;
  cy /= n;
  /* edge lengths in range before the move must stay in range (computed
   * when a candidate first passes the quality test) */
  uint8_t inr[RM_BALL_MAX];
  int have_inr = 0;
  double *xp = rm->x + 2 * (size_t)p;
  double x0 = xp[0], y0 = xp[1];
  double qn[RM_BALL_MAX];
  double om = 1.0;
  for (int tr = 0; tr < 3; tr++, om *= 0.5) {
    xp[0] = x0 + om * (cx - x0);
    xp[1] = y0 + om * (cy - y0);
    double qmin = 1, qm = 0;
    int ok = 1;
    if (mc <= 1) {
      for (int s = 0; s < n; s++) {
        bxy.x[loc[s]][s] = xp[0];
        bxy.y[loc[s]][s] = xp[1];
      }
      ball_xy_qual(&bxy, n, qn);
    }
    for (int s = 0; s < n && ok; s++) {
      if (mc > 1) {
        const pa_idx *v = rm->ev + 3 * (size_t)el[s];
        qn[s] = rm_elem_qual(rm, v[0], v[1], v[2]);
      }
      /* >= qold passes the floor (rm_qfloor); below RM_QFLOOR the
       * Euclidean shape is checked too */
      if (qn[s] < qold) {
        ok = 0;
      } else if (qold < RM_QFLOOR) {
        const pa_idx *v = rm->ev + 3 * (size_t)el[s];
        ok = rm_qual_ok(rm, qn[s], rm_qfloor(qold), v[0], v[1], v[2]);
      }
      if (qn[s] < qmin) qmin = qn[s];
      qm += qn[s];
    }
    if (!ok) continue;
    qm /= n;
    if (!(qmin > MOVE_GAIN_MIN * qold || qm > MOVE_GAIN_MEAN * qmean)) continue;
    if (!have_inr) {
      double np[2] = {xp[0], xp[1]};
      xp[0] = x0;
      xp[1] = y0;
      for (int s = 0; s < n; s++) {
        double l =
            rm_edge_len(rm, p, rm->ev[3 * (size_t)el[s] + RM_NX3(loc[s])]);
        inr[s] = l >= PA_METRIC_LEN_LO && l <= PA_METRIC_LEN_HI;
      }
      xp[0] = np[0];
      xp[1] = np[1];
      have_inr = 1;
    }
    for (int s = 0; s < n && ok; s++) {
      if (!inr[s]) continue;
      double l = rm_edge_len(rm, p, rm->ev[3 * (size_t)el[s] + RM_NX3(loc[s])]);
      ok = l >= PA_METRIC_LEN_LO && l <= PA_METRIC_LEN_HI;
    }
    if (!ok) continue;
    /* accepted */
    double np[2] = {xp[0], xp[1]};
    xp[0] = x0;
    xp[1] = y0;
    apply_move(rm, p, el, loc, n, np);
    return 1;
  }
  xp[0] = x0;
  xp[1] = y0;
  return 0;
}

long pa__rm_smooth_pass_2d(pa__rmesh *rm) {
  long cnt = 0;
  rm_vtag_clear(rm, RM_V_DONE);
  for (pa_idx k = 0; k < rm->ne; k++) {
    if (rm->etag[k] & (RM_E_DEAD | RM_E_FROZEN)) continue;
    for (int i = 0; i < 3; i++) {
      pa_idx p = rm->ev[3 * k + i];
      uint8_t tp = rm->vtag[p];
      if (tp & (RM_V_DONE | RM_V_FROZEN | RM_V_CORNER | RM_V_FEAT)) continue;
      /* DONE even when skipped: a neighbour's move later in this pass must
       * not make p eligible again from another start element */
      rm->vtag[p] |= RM_V_DONE;
      /* the answer depends only on p's ball: a rejected p stays settled
       * until an operator or a move changes that ball (rm_elem_changed) */
      if (tp & RM_V_SETTLED) continue;
      if (move_vertex(rm, k, i)) cnt++;
      else rm->vtag[p] |= RM_V_SETTLED;
    }
  }
  return cnt;
}

/* Edges at p out of [PA_METRIC_LEN_LO, PA_METRIC_LEN_HI] and their sum of ln^2
 * (L / RM_LTARGET), with p at y (metric mp) and its neighbours nb[0..nn). */
static int len_score_2d(const pa__rmesh *rm, const double *y, const double *mp,
                        const pa_idx *nb, int nn, double *sum) {
  int mc = rm->mcomp, out = 0;
  double s = 0;
  for (int i = 0; i < nn; i++) {
    double l = pa__len2(mc, y, RM_X(nb[i]), mp, RM_M(nb[i]));
    out += !(l >= PA_METRIC_LEN_LO && l <= PA_METRIC_LEN_HI);
    double g = log(l / RM_LTARGET);
    s += g * g;
  }
  *sum = s;
  return out;
}

/* Move interior vertex p = v[ip] of element k to bring its edges into range:
 * a Gauss-Newton step on sum ln^2 (L / RM_LTARGET) (halved up to three
 * times), or along its
 * edge furthest out of range; kept when fewer edges are out of range (or as
 * many with the sum RM_LGAIN lower) and the ball's worst quality stays at
 * least min(old worst, RM_QLEN). As 3D (smooth_3d.c). 1 if moved. */
static int length_vertex(pa__rmesh *rm, pa_idx k, int ip) {
  int mc = rm->mcomp;
  pa_idx p = rm->ev[3 * k + ip];
  pa_idx el[RM_BALL_MAX], nb[RM_BALL_MAX];
  int loc[RM_BALL_MAX], closed;
  int n = rm_ball_2d(rm, k, ip, el, loc, &closed);
  if (n < 3 || !closed) return 0;
  double qold = 1;
  for (int s = 0; s < n; s++) {
    if (rm->etag[el[s]] & RM_E_FROZEN) return 0;
    if (rm->q[el[s]] < qold) qold = rm->q[el[s]];
    nb[s] = rm->ev[3 * (size_t)el[s] + RM_NX3(loc[s])];
  }
  double *xp = rm->x + 2 * (size_t)p;
  const double *mp = RM_M(p);
  double s0;
  int out0 = len_score_2d(rm, xp, mp, nb, n, &s0);
  if (out0 == 0) return 0;
  double jj[3] = {0, 0, 0}, jr[2] = {0, 0}, d2[2] = {0, 0}, worst = 0;
  double tp[3];
  rm_tensor2(mc, mp, tp);
  for (int s = 0; s < n; s++) {
    const double *xi = RM_X(nb[s]);
    double ti[3];
    rm_tensor2(mc, RM_M(nb[s]), ti);
    double a[3] = {0.5 * (tp[0] + ti[0]), 0.5 * (tp[1] + ti[1]),
                   0.5 * (tp[2] + ti[2])};
    double e[2] = {xi[0] - xp[0], xi[1] - xp[1]};
    double me[2] = {a[0] * e[0] + a[1] * e[1], a[1] * e[0] + a[2] * e[1]};
    double q = me[0] * e[0] + me[1] * e[1];
    if (!(q > 0)) return 0;
    double g[2] = {-me[0] / q, -me[1] / q};
    double l = pa__len2(mc, xp, xi, mp, RM_M(nb[s])), r = log(l / RM_LTARGET);
    jj[0] += g[0] * g[0];
    jj[1] += g[0] * g[1];
    jj[2] += g[1] * g[1];
    jr[0] -= g[0] * r;
    jr[1] -= g[1] * r;
    if (fabs(r) > worst) { /* the candidate along the worst edge */
      worst = fabs(r);
      double f = l > 1 ? 1 - 1 / l : l - 1;
      if (f > 0.5) f = 0.5;
      if (f < -0.5) f = -0.5;
      d2[0] = f * e[0];
      d2[1] = f * e[1];
    }
  }
  double lam = 1e-3 * (jj[0] + jj[2]);
  jj[0] += lam;
  jj[2] += lam;
  double det = jj[0] * jj[2] - jj[1] * jj[1];
  if (!(det > 0)) return 0;
  double d[2] = {(jj[2] * jr[0] - jj[1] * jr[1]) / det,
                 (jj[0] * jr[1] - jj[1] * jr[0]) / det};
  double x0 = xp[0], y0 = xp[1], step = 1.0, qfloor = fmin(qold, RM_QLEN);
  for (int tr = 0; tr < 8; tr++, step *= 0.5) {
    if (tr == 4) step = 1.0;
    const double *dd = tr < 4 ? d : d2;
    double np[2] = {x0 + step * dd[0], y0 + step * dd[1]}, s1;
    int out1 = len_score_2d(rm, np, mp, nb, n, &s1);
    if (!(out1 < out0 || (out1 == out0 && s1 < RM_LGAIN * s0))) continue;
    xp[0] = np[0];
    xp[1] = np[1];
    int ok = 1;
    for (int s = 0; s < n && ok; s++) {
      const pa_idx *v = rm->ev + 3 * (size_t)el[s];
      double q = rm_elem_qual(rm, v[0], v[1], v[2]);
      if (!(q >= qfloor) ||
          !rm_qual_ok(rm, q, rm_qfloor(qold), v[0], v[1], v[2]))
        ok = 0;
    }
    xp[0] = x0;
    xp[1] = y0;
    if (!ok) continue;
    apply_move(rm, p, el, loc, n, np);
    return 1;
  }
  return 0;
}

long pa__rm_length_pass_2d(pa__rmesh *rm) {
  int mc = rm->mcomp;
  long cnt = 0;
  rm_vtag_clear(rm, RM_V_DONE);
  const uint8_t skip = RM_E_DEAD | RM_E_FROZEN | RM_E_INRANGE;
  for (pa_idx k = rm_next_elem(rm, 0, skip); k < rm->ne;
       k = rm_next_elem(rm, k + 1, skip)) {
    const pa_idx *v = rm->ev + 3 * (size_t)k;
    int bad = 0, settled = 1;
    for (int i = 0; i < 3 && !bad; i++) {
      double l = pa__len2(mc, RM_X(v[RM_NX3(i)]), RM_X(v[RM_PV3(i)]),
                          RM_M(v[RM_NX3(i)]), RM_M(v[RM_PV3(i)]));
      bad = !(l >= PA_METRIC_LEN_LO && l <= PA_METRIC_LEN_HI);
      settled &= rm_len_settled(l);
    }
    if (settled) rm->etag[k] |= RM_E_INRANGE;
    if (!bad) continue;
    for (int i = 0; i < 3; i++) {
      pa_idx p = v[i];
      uint8_t tp = rm->vtag[p];
      if (tp & (RM_V_DONE | RM_V_FROZEN | RM_V_CORNER | RM_V_FEAT)) continue;
      rm->vtag[p] |= RM_V_DONE;
      cnt += length_vertex(rm, k, i);
    }
  }
  return cnt;
}
