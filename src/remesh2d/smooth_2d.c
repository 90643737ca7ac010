/*
 * smooth_2d.c -- vertex relocation in the 2D remesher: quality moves (an
 * interior vertex towards the mean of the ideal apexes of its ball) and
 * length moves (a Gauss-Newton step on the lengths of its edges, as in 3D:
 * smooth_3d.c), feature moves along their curve, curve snaps (a vertex onto
 * its fitted curve) and the jiggle of a lattice crowd; their passes are in
 * driver_2d.c. Frozen and corner vertices never move; the metric and fields
 * of a moved vertex are interpolated in its old ball. Shared contract of the
 * operators: ops_2d.h.
 */
#include "remesh2d/ops_2d.h"

/* A move is kept when it raises the ball's worst or mean quality by 1 %. */
#define MOVE_GAIN_MIN 1.01
#define MOVE_GAIN_MEAN 1.01
/* A quality move whose target lies within this metric length of the vertex
 * is no move: it changes the qualities of a ball no worse than RM2D_QFLOOR
 * by far less than the gain asks, so the trials would all be rejected. The
 * symmetric vertices of a bisected lattice sit exactly on their target (on
 * the plate of bench/vs_mmg.sh, 150 000 of the 730 000 tries). */
#define MOVE_NULL 1e-12

/* Move interior vertex p (its closed ball el[0..n), local indices loc) to
 * np: metric and fields interpolated from the old triangle holding np
 * (barycentric; linear fields stay exact), qualities updated: qn[0..n) when
 * given (the trial's, which with sizes do not depend on the metric), else
 * computed. same: p and its neighbours carry the same metric, which the
 * interpolation then gives back (pa__metric_interp), so without fields, and
 * with the same target metric too where it is kept apart (rm2d.met0: a
 * piece of the parallel loop, whose working metric is relaxed at its skin;
 * same_target), there is nothing to interpolate. ln[0..n), when
 * given, are the lengths from np to the
 * neighbours v[RM2D_NX3(loc[s])] in p's metric before the move: where the
 * interpolation leaves that metric as it was, they are the new lengths, and
 * an element in range (RM2D_E_INRANGE) whose two edges at p stay in the
 * band keeps its mark (its third edge has not moved). */
/* p and the vertices of its ball el[0..n) (local indices loc) carry the same
 * target metric rm->met0. */
static int same_target(const rm2d *rm, pa_idx p, const pa_idx *el,
                       const int *loc, int n) {
  const int mc = rm->mc;
  const double *m0 = rm->met0 + (size_t)mc * p;
  for (int s = 0; s < n; s++) {
    const pa_idx *v = rm->tv + 3 * (size_t)el[s];
    const double *ma = rm->met0 + (size_t)mc * v[RM2D_NX3(loc[s])];
    const double *mb = rm->met0 + (size_t)mc * v[RM2D_PV3(loc[s])];
    for (int c = 0; c < mc; c++)
      if (ma[c] != m0[c] || mb[c] != m0[c]) return 0;
  }
  return 1;
}

static void apply_move(rm2d *rm, pa_idx p, const pa_idx *el, const int *loc,
                       int n, const double *np, const double *qn, int same,
                       const double *ln) {
  int mc = rm->mc;
  double *xp = rm->x + 2 * (size_t)p;
  double x0 = xp[0], y0 = xp[1], m0[3];
  memcpy(m0, RM2D_M(p), sizeof(double) * (size_t)mc);
  int ns = same && !rm->nfield &&
                   (!rm->met0 || same_target(rm, p, el, loc, n))
               ? 0
               : n;
  for (int s = 0; s < ns; s++) {
    const pa_idx *v = rm->tv + 3 * (size_t)el[s];
    pa_idx va = v[RM2D_NX3(loc[s])], vb = v[RM2D_PV3(loc[s])];
    const double *a = RM2D_X(va), *b = RM2D_X(vb);
    double area = (a[0] - x0) * (b[1] - y0) - (a[1] - y0) * (b[0] - x0);
    double wa = ((np[0] - x0) * (b[1] - y0) - (np[1] - y0) * (b[0] - x0)) / area;
    double wb = ((a[0] - x0) * (np[1] - y0) - (a[1] - y0) * (np[0] - x0)) / area;
    double wp = 1 - wa - wb;
    if (wa >= -1e-12 && wb >= -1e-12 && wp >= -1e-12) {
      pa_idx src[3] = {p, va, vb};
      double w[3] = {wp, wa, wb};
      pa__rm2d_interp(rm, p, 3, src, w);
      break;
    }
  }
  xp[0] = np[0];
  xp[1] = np[1];
  int keep = ln != NULL;
  for (int c = 0; c < mc; c++) /* (a call to memcmp here costs more) */
    keep &= m0[c] == RM2D_M(p)[c];
  for (int s = 0; s < n; s++) {
    const pa_idx *v = rm->tv + 3 * (size_t)el[s];
    int inr = keep && (rm->tflag[el[s]] & RM2D_E_INRANGE) &&
              rm2d_len_settled(rm, ln[s]) &&
              rm2d_len_settled(rm, ln[s + 1 < n ? s + 1 : 0]);
    rm->q[el[s]] = (float)(qn ? qn[s] : rm2d_elem_qual(rm, v[0], v[1], v[2]));
    rm2d_elem_changed(rm, el[s]); /* p's neighbours see a new ball */
    if (inr) rm->tflag[el[s]] |= RM2D_E_INRANGE;
  }
  rm->nmove++;
}

/* The triangles of a ball for the trial qualities of a move under a size
 * metric (where the quality is the Euclidean one, pa__qual2): vertex j of
 * triangle s at (x[j][s], y[j][s]), in the element's order, p's entry
 * rewritten at each trial. One loop then evaluates the whole ball with the
 * kernel (pa__qual2_xy), and vectorises. */
typedef struct ball_xy {
  double x[3][RM2D_BALL_MAX], y[3][RM2D_BALL_MAX];
} ball_xy;

static void ball_xy_qual(const ball_xy *b, int n, double *q) {
  for (int s = 0; s < n; s++)
    q[s] = pa__qual2_xy(b->x[0][s], b->y[0][s], b->x[1][s], b->y[1][s],
                        b->x[2][s], b->y[2][s]);
}

/* Add to c the apex of the triangle on edge (a, b), to its left, that is
 * equilateral in the metric t (3 components, sd = 1 / sqrt(det t)): the
 * midpoint plus sqrt(3)/2 times the edge rotated by +90 degrees in the
 * metric, adj(t) R (b - a) / sqrt(det t). */
static void add_ideal_apex(const double *t, double sd, const double *a,
                           const double *b, double *c) {
  double rx = a[1] - b[1], ry = b[0] - a[0];
  double yx = (t[2] * rx - t[1] * ry) * sd, yy = (-t[1] * rx + t[0] * ry) * sd;
  c[0] += 0.5 * (a[0] + b[0]) + 0.8660254037844386 * yx;
  c[1] += 0.5 * (a[1] + b[1]) + 0.8660254037844386 * yy;
}

/* The edges from a vertex p to its neighbours nb[0..nn), gathered once for
 * the trial positions of a move: the neighbours' coordinates, and
 * with sizes (mc <= 1) the factor that turns a Euclidean length into the
 * metric one, which does not depend on p's position (pa__len2: n / h, or n
 * times the logarithmic mean of 1 / ha and 1 / hb; the same operations, so
 * the same bits). */
typedef struct len_ball {
  int nn, mc;
  int same; /* every neighbour's metric is p's */
  const double *mp;
  /* a feature vertex has up to one neighbour more than elements */
  double x[2 * RM2D_BALL_MAX], y[2 * RM2D_BALL_MAX], f[2 * RM2D_BALL_MAX];
  const double *m[2 * RM2D_BALL_MAX];
} len_ball;

static void len_ball_init(const rm2d *rm, const double *mp, const pa_idx *nb,
                          int nn, len_ball *lb) {
  int mc = rm->mc;
  lb->nn = nn;
  lb->mc = mc;
  lb->mp = mp;
  lb->same = 1;
  for (int i = 0; i < nn; i++) {
    const double *xi = RM2D_X(nb[i]), *mi = RM2D_M(nb[i]);
    lb->x[i] = xi[0];
    lb->y[i] = xi[1];
    lb->m[i] = mi;
    for (int c = 0; c < mc; c++)
      lb->same &= mi[c] == mp[c];
    if (mc == 0) lb->f[i] = 1.0;
    else if (mc == 1)
      lb->f[i] = mp[0] == mi[0] ? 1.0 / mp[0]
                                : pa__log_mean(1.0 / mp[0], 1.0 / mi[0]);
  }
}

/* The length of edge i of lb from p at y. */
static inline double len_one(const len_ball *lb, const double *y, int i) {
  double dx = lb->x[i] - y[0], dy = lb->y[i] - y[1];
  if (lb->mc <= 1) return sqrt(dx * dx + dy * dy) * lb->f[i];
  double b[2] = {lb->x[i], lb->y[i]};
  return pa__len2(lb->mc, y, b, lb->mp, lb->m[i]);
}

/* Whether a move of p keeps its edges in the band: every edge to nb[0..nn)
 * in [PA_METRIC_LEN_LO, PA_METRIC_LEN_HI] at the old position stays in it
 * at the current one, and none out of it goes further out (the old
 * lengths lold are measured on the first call: *have; the current ones go
 * to lnew, all of them when the test passes). Balls whose worst
 * quality qold is under qfree may also shorten them to RM2D_LFREE_LO
 * (their elements matter more than those lengths). */
static int keeps_band(rm2d *rm, pa_idx p, const pa_idx *nb, int nn,
                      const double *old, len_ball *lb, double *lold, int *have,
                      double qold, double qfree, double *lnew) {
  const double *xp = rm->x + 2 * (size_t)p;
  if (!*have) {
    int mc = rm->mc;
    len_ball_init(rm, RM2D_M(p), nb, nn, lb);
    for (int s = 0; s < nn; s++)
      lold[s] = len_one(lb, old, s);
    *have = 1;
  }
  const double lo = qold < qfree ? RM2D_LFREE_LO : PA_METRIC_LEN_LO,
               hi = PA_METRIC_LEN_HI;
  for (int s = 0; s < nn; s++) {
    double l = lnew[s] = len_one(lb, xp, s);
    /* l in [min(lo, lold), max(hi, lold)] (no NaN among lo, hi, lold) */
    if (!((l >= lo || l >= lold[s]) && (l <= hi || l <= lold[s]))) return 0;
  }
  return 1;
}

/* Move interior vertex p = v[ip] of element k towards the mean of the ideal
 * apexes of its ball (equilateral in the metric of p). Balls of worst
 * quality under qfree may stretch their lengths (keeps_band). Returns 1 if
 * moved. */
int pa__rm2d_smooth_vertex(rm2d *rm, pa_idx k, int ip, double qfree) {
  int mc = rm->mc;
  pa_idx p = rm->tv[3 * k + ip];
  pa_idx el[RM2D_BALL_MAX];
  int loc[RM2D_BALL_MAX], closed;
  int n = rm2d_ball(rm, k, ip, el, loc, &closed);
  if (n < 3 || !closed) return 0;
  double t[3];
  rm2d_tensor2(mc, RM2D_M(p), t);
  double det = t[0] * t[2] - t[1] * t[1];
  if (!(det > 0)) return 0;
  double sd = 1.0 / sqrt(det);
  double c[2] = {0, 0}, qold = 1, qmean = 0;
  pa_idx nb[RM2D_BALL_MAX];
  ball_xy bxy;
  for (int s = 0; s < n; s++) {
    const pa_idx *v = rm->tv + 3 * (size_t)el[s];
    if (rm->tflag[el[s]] & RM2D_E_FROZEN) return 0;
    int l1 = RM2D_NX3(loc[s]), l2 = RM2D_PV3(loc[s]);
    const double *a = RM2D_X(v[l1]), *b = RM2D_X(v[l2]);
    if (mc <= 1) {
      bxy.x[l1][s] = a[0];
      bxy.y[l1][s] = a[1];
      bxy.x[l2][s] = b[0];
      bxy.y[l2][s] = b[1];
    }
    add_ideal_apex(t, sd, a, b, c);
    nb[s] = v[l1];
    double q = rm->q[el[s]];
    if (q < qold) qold = q;
    qmean += q;
  }
  qmean /= n;
  double cx = c[0] / n, cy = c[1] / n;
  double *xp = rm->x + 2 * (size_t)p;
  const double x0 = xp[0], y0 = xp[1], old[2] = {x0, y0};
  if (qold >= RM2D_QFLOOR &&
      pa__sqlen2(3, t, cx - x0, cy - y0) < MOVE_NULL * MOVE_NULL)
    return 0;
  /* edge lengths in range before the move must stay in range (computed
   * when a candidate first passes the quality test) */
  double lold[RM2D_BALL_MAX];
  len_ball lb;
  int have_inr = 0;
  double qn[RM2D_BALL_MAX];
  double om = 1.0;
  /* p's entries in bxy (sizes), rewritten at each trial */
  double *px[RM2D_BALL_MAX], *py[RM2D_BALL_MAX];
  if (mc <= 1)
    for (int s = 0; s < n; s++) {
      px[s] = &bxy.x[loc[s]][s];
      py[s] = &bxy.y[loc[s]][s];
    }
  for (int tr = 0; tr < 3; tr++, om *= 0.5) {
    const double tx = x0 + om * (cx - x0), ty = y0 + om * (cy - y0);
    xp[0] = tx;
    xp[1] = ty;
    double qmin = 1, qm = 0;
    int ok = 1;
    if (mc <= 1) {
      for (int s = 0; s < n; s++) {
        *px[s] = tx;
        *py[s] = ty;
      }
      ball_xy_qual(&bxy, n, qn);
      if (qold >= RM2D_QFLOOR) { /* the floor is qold itself */
        for (int s = 0; s < n; s++) {
          if (qn[s] < qold) {
            ok = 0;
            break;
          }
          if (qn[s] < qmin) qmin = qn[s];
          qm += qn[s];
        }
      }
    }
    /* (done above with sizes when the floor is qold) */
    for (int s = mc <= 1 && qold >= RM2D_QFLOOR ? n : 0; s < n && ok; s++) {
      if (mc > 1) {
        const pa_idx *v = rm->tv + 3 * (size_t)el[s];
        qn[s] = rm2d_elem_qual(rm, v[0], v[1], v[2]);
      }
      /* >= qold passes the floor (rm2d_qfloor); below RM2D_QFLOOR the
       * Euclidean shape is checked too */
      if (qn[s] < qold) {
        ok = 0;
      } else if (qold < RM2D_QFLOOR) {
        const pa_idx *v = rm->tv + 3 * (size_t)el[s];
        ok = rm2d_qual_ok(rm, qn[s], rm2d_qfloor(qold), v[0], v[1], v[2]);
      }
      if (qn[s] < qmin) qmin = qn[s];
      qm += qn[s];
    }
    if (!ok) continue;
    qm /= n;
    if (!(qmin > MOVE_GAIN_MIN * qold || qm > MOVE_GAIN_MEAN * qmean)) continue;
    double lnew[RM2D_BALL_MAX];
    if (!keeps_band(rm, p, nb, n, old, &lb, lold, &have_inr, qold, qfree,
                    lnew))
      continue;
    /* accepted */
    double np[2] = {xp[0], xp[1]};
    xp[0] = x0;
    xp[1] = y0;
    apply_move(rm, p, el, loc, n, np, mc <= 1 ? qn : NULL, lb.same, lnew);
    return 1;
  }
  xp[0] = x0;
  xp[1] = y0;
  return 0;
}

/* The tangent of record b at its end v, oriented away from v. */
static void tangent_from(const rm2d *rm, pa_idx b, pa_idx v, double *t) {
  int e = rm->bv[2 * b] == v ? 0 : 1;
  double sg = e == 0 ? 1 : -1; /* stored along bv[2b] -> bv[2b+1] */
  t[0] = sg * rm->btan[4 * b + 2 * e];
  t[1] = sg * rm->btan[4 * b + 2 * e + 1];
}

/* Whether record r = (y, p) of feature vertex p, stretched to (y, np) with
 * tangent g at np (oriented from y to np), stays within hausd of the
 * curve it replaces: p within hausd of the new chord, the sagitta of the
 * new Hermite arc within hausd, the arc not folded (as the feature
 * collapses, collapse_2d.c). */
static int stretch_kept(const rm2d *rm, pa_idx r, pa_idx p, const double *np,
                        const double *g, double hausd) {
  pa_idx y = rm->bv[2 * r] == p ? rm->bv[2 * r + 1] : rm->bv[2 * r];
  const double *xy = RM2D_X(y), *xp = RM2D_X(p);
  double dx = np[0] - xy[0], dy = np[1] - xy[1];
  double l2 = dx * dx + dy * dy;
  if (!(l2 > 0)) return 0;
  double t = ((xp[0] - xy[0]) * dx + (xp[1] - xy[1]) * dy) / l2;
  t = t < 0 ? 0 : t > 1 ? 1 : t;
  double ex = xy[0] + t * dx - xp[0], ey = xy[1] + t * dy - xp[1];
  if (ex * ex + ey * ey > hausd * hausd) return 0;
  double ty[2];
  tangent_from(rm, r, y, ty);
  double sx = 0.125 * (ty[0] - g[0]), sy = 0.125 * (ty[1] - g[1]);
  if ((sx * sx + sy * sy) * l2 > hausd * hausd) return 0;
  return ty[0] * dx + ty[1] * dy > 0 && g[0] * dx + g[1] * dy > 0;
}

/* Move feature vertex p = v[ip] of element k along its curve (the
 * reconstructed arc of one of its two records) by the tangential part of
 * the step to the mean of the ideal apexes of its ball, halved up to twice;
 * kept under the rules of the interior moves (pa__rm2d_smooth_vertex), with the
 * record it leaves behind within hausd of the curve (stretch_kept). The
 * metric and fields are interpolated along the record; straight features
 * stay straight. Returns 1 if moved. */
int pa__rm2d_smooth_feature(rm2d *rm, pa_idx k, int ip, double qfree) {
  int mc = rm->mc;
  pa_idx p = rm->tv[3 * k + ip];
  pa_idx el[RM2D_BALL_MAX], nb[2 * RM2D_BALL_MAX], rec[2];
  int loc[RM2D_BALL_MAX], closed, nr = 0, nn = 0;
  int n = rm2d_ball(rm, k, ip, el, loc, &closed);
  if (n < 1) return 0;
  double t[3];
  rm2d_tensor2(mc, RM2D_M(p), t);
  double det = t[0] * t[2] - t[1] * t[1];
  if (!(det > 0)) return 0;
  double sd = 1.0 / sqrt(det), c[2] = {0, 0}, qold = 1, qmean = 0;
  for (int s = 0; s < n; s++) {
    if (rm->tflag[el[s]] & RM2D_E_FROZEN) return 0;
    const pa_idx *v = rm->tv + 3 * (size_t)el[s];
    int l1 = RM2D_NX3(loc[s]), l2 = RM2D_PV3(loc[s]);
    add_ideal_apex(t, sd, RM2D_X(v[l1]), RM2D_X(v[l2]), c);
    double q = rm->q[el[s]];
    if (q < qold) qold = q;
    qmean += q;
    for (int side = 0; side < 2; side++) { /* the faces at p */
      pa_idx o = rm->adj[3 * el[s] + (side ? l1 : l2)], w = v[side ? l2 : l1];
      int dup = 0;
      for (int j = 0; j < nn; j++) dup |= nb[j] == w;
      if (!dup) nb[nn++] = w;
      if (o >= 0) continue;
      pa_idx b = -o - 1;
      if ((nr == 0 || rec[0] != b) && nr < 2) rec[nr++] = b;
      else if (nr == 2 && rec[0] != b && rec[1] != b) return 0;
    }
  }
  if (nr != 2) return 0;
  qmean /= n;
  double *xp = rm->x + 2 * (size_t)p;
  const double old[2] = {xp[0], xp[1]};
  double tp[2]; /* along the curve, from rec[0] to rec[1] */
  tangent_from(rm, rec[1], p, tp);
  double d = (c[0] / n - old[0]) * tp[0] + (c[1] / n - old[1]) * tp[1];
  /* towards rec[1]'s other end z (d > 0) or rec[0]'s (d < 0) */
  pa_idx rr = d > 0 ? rec[1] : rec[0], ro = d > 0 ? rec[0] : rec[1];
  pa_idx z = rm->bv[2 * rr] == p ? rm->bv[2 * rr + 1] : rm->bv[2 * rr];
  double lz = hypot(RM2D_X(z)[0] - old[0], RM2D_X(z)[1] - old[1]);
  double s0 = fabs(d) / lz;
  if (!(s0 > 1e-6)) return 0;
  if (s0 > RM2D_FEAT_STEP) s0 = RM2D_FEAT_STEP;
  double hausd = fmin(pa__local_hausd(rm->opts, rm->bref[rr], rm->hausd),
                      pa__local_hausd(rm->opts, rm->bref[ro], rm->hausd));
  double lold[2 * RM2D_BALL_MAX];
  len_ball lb;
  int have_inr = 0;
  for (int tr = 0; tr < 3; tr++, s0 *= 0.5) {
    int from0 = rm->bv[2 * rr] == p;
    double np[2], tn[2], g[2];
    pa__rm2d_curve_point(rm, rr, from0 ? s0 : 1 - s0, np, tn);
    /* on a model's curve: its point (no move when the kernel fails) */
    if (pa__remesh_project(rm->opts, 1, rm->bref[rr], 2, np, s0 * lz, np) < 0)
      continue;
    g[0] = from0 ? tn[0] : -tn[0]; /* along p -> z */
    g[1] = from0 ? tn[1] : -tn[1];
    if (!stretch_kept(rm, ro, p, np, g, hausd)) continue;
    xp[0] = np[0];
    xp[1] = np[1];
    double qmin = 1, qm = 0;
    int ok = 1;
    for (int s = 0; s < n && ok; s++) {
      const pa_idx *v = rm->tv + 3 * (size_t)el[s];
      double q = rm2d_elem_qual(rm, v[0], v[1], v[2]);
      ok =
          q >= qold && rm2d_qual_ok(rm, q, rm2d_qfloor(qold), v[0], v[1], v[2]);
      qmin = fmin(qmin, q);
      qm += q;
    }
    ok = ok && (qmin > MOVE_GAIN_MIN * qold || qm / n > MOVE_GAIN_MEAN * qmean);
    double lnew[2 * RM2D_BALL_MAX];
    ok = ok && keeps_band(rm, p, nb, nn, old, &lb, lold, &have_inr, qold,
                          qfree, lnew);
    xp[0] = old[0];
    xp[1] = old[1];
    if (!ok) continue;
    /* apply: metric and fields along the record, then the position, the
     * tangents at p, the qualities */
    pa_idx src[2] = {p, z};
    double w[2] = {1 - s0, s0};
    pa__rm2d_interp(rm, p, 2, src, w);
    xp[0] = np[0];
    xp[1] = np[1];
    for (int j = 0; j < 2; j++) {
      pa_idx b = rec[j];
      int e = rm->bv[2 * b] == p ? 0 : 1;
      /* g runs p -> z; the record's own orientation is bv[2b] -> bv[2b+1] */
      double sg = ((b == rr) == (e == 0)) ? 1 : -1;
      rm->btan[4 * b + 2 * e] = sg * g[0];
      rm->btan[4 * b + 2 * e + 1] = sg * g[1];
    }
    for (int s = 0; s < n; s++) {
      const pa_idx *v = rm->tv + 3 * (size_t)el[s];
      rm->q[el[s]] = (float)rm2d_elem_qual(rm, v[0], v[1], v[2]);
      rm2d_elem_changed(rm, el[s]);
    }
    rm->nmove++;
    return 1;
  }
  return 0;
}

/* The worst quality of the ball el[0..n), or -1 when it holds a frozen
 * element. */
static double ball_worst(const rm2d *rm, const pa_idx *el, int n) {
  double qold = 1;
  for (int s = 0; s < n; s++) {
    if (rm->tflag[el[s]] & RM2D_E_FROZEN) return -1;
    if (rm->q[el[s]] < qold) qold = rm->q[el[s]];
  }
  return qold;
}

/* Whether every element of the ball el[0..n) of p, with p at np, has
 * quality at least qmin and passes the floor of the ball's old worst qold
 * (rm2d_qual_ok); p is left where it was. */
static int ball_keeps(rm2d *rm, pa_idx p, const pa_idx *el, int n,
                      const double *np, double qmin, double qold) {
  double *xp = rm->x + 2 * (size_t)p;
  const double x0 = xp[0], y0 = xp[1];
  xp[0] = np[0];
  xp[1] = np[1];
  int ok = 1;
  for (int s = 0; s < n && ok; s++) {
    const pa_idx *v = rm->tv + 3 * (size_t)el[s];
    double q = rm2d_elem_qual(rm, v[0], v[1], v[2]);
    ok = q >= qmin && rm2d_qual_ok(rm, q, rm2d_qfloor(qold), v[0], v[1], v[2]);
  }
  xp[0] = x0;
  xp[1] = y0;
  return ok;
}

/* Steps of a curve snap: the whole way, then half and a quarter of it
 * (as 3D's SNAP_STEPS, smooth_3d.c). */
#define SNAP_STEPS 3

int pa__rm2d_curve_snap_vertex(rm2d *rm, pa_idx k, int ip) {
  pa_idx p = rm->tv[3 * k + ip];
  double *d = rm->vcur + 2 * (size_t)p;
  if (d[0] == 0 && d[1] == 0) return 0;
  if (rm->vtag[p] & (RM2D_V_FROZEN | RM2D_V_CORNER)) return 0;
  pa_idx el[RM2D_BALL_MAX];
  int loc[RM2D_BALL_MAX], closed;
  int n = rm2d_ball(rm, k, ip, el, loc, &closed);
  if (n < 1) return 0;
  double qold = ball_worst(rm, el, n);
  if (qold < 0) return 0;
  double qfloor = qold < RM2D_QLEN ? qold : RM2D_QLEN;
  const double *xp = rm->x + 2 * (size_t)p;
  for (int tr = 0; tr < SNAP_STEPS; tr++) {
    double w = ldexp(1.0, -tr), np[2] = {xp[0] + w * d[0], xp[1] + w * d[1]};
    if (!ball_keeps(rm, p, el, n, np, qfloor, qold)) continue;
    apply_move(rm, p, el, loc, n, np, NULL, 0, NULL);
    d[0] -= w * d[0];
    d[1] -= w * d[1];
    return 1;
  }
  return 0;
}

/* The lengths l of the edges of lb from p at y, and how many are out of
 * [PA_METRIC_LEN_LO, PA_METRIC_LEN_HI]; the count stops (l then partial)
 * once it passes outmax. */
static int len_out_2d(const len_ball *lb, const double *y, double *l,
                      int outmax) {
  int out = 0;
  for (int i = 0; i < lb->nn && out <= outmax; i++) {
    double dx = lb->x[i] - y[0], dy = lb->y[i] - y[1];
    if (lb->mc <= 1) {
      l[i] = sqrt(dx * dx + dy * dy) * lb->f[i];
    } else {
      double b[2] = {lb->x[i], lb->y[i]};
      l[i] = pa__len2(lb->mc, y, b, lb->mp, lb->m[i]);
    }
    out += !(l[i] >= PA_METRIC_LEN_LO && l[i] <= PA_METRIC_LEN_HI);
  }
  return out;
}

/* Whether the sum of ln^2 (l / RM2D_LTARGET) over l[0..nn) is below bound.
 * |ln x| >= |2 (x - 1) / (x + 1)| for every x > 0 (within 2.5 % over the
 * band), so a sum of those squares above the bound, by more than any
 * rounding, decides without a logarithm (three trials in four on the
 * plate); else the terms, which are not negative, stop at a partial sum
 * at or above it. */
static int len_sum_below(const double *l, int nn, double bound) {
  double lo = 0;
  for (int i = 0; i < nn; i++) {
    double x = l[i] / RM2D_LTARGET, u = 2 * (x - 1) / (x + 1);
    lo += u * u;
  }
  if (lo >= bound * (1 + 1e-12)) return 0;
  double s = 0;
  for (int i = 0; i < nn; i++) {
    double g = log(l[i] / RM2D_LTARGET);
    s += g * g;
    if (!(s < bound)) return 0;
  }
  return s < bound;
}

/* Move interior vertex p = v[ip] of element k to bring its edges into range:
 * a Gauss-Newton step on sum ln^2 (L / RM2D_LTARGET) (halved up to three
 * times), or along its
 * edge furthest out of range; kept when fewer edges are out of range (or as
 * many with the sum RM2D_LGAIN lower) and the ball's worst quality stays at
 * least min(old worst, RM2D_QLEN). As 3D (smooth_3d.c). 1 if moved. */
int pa__rm2d_length_vertex(rm2d *rm, pa_idx k, int ip) {
  int mc = rm->mc;
  pa_idx p = rm->tv[3 * k + ip];
  pa_idx el[RM2D_BALL_MAX], nb[RM2D_BALL_MAX];
  int loc[RM2D_BALL_MAX], closed;
  int n = rm2d_ball(rm, k, ip, el, loc, &closed);
  if (n < 3 || !closed) return 0;
  /* the ball from its first slot, whichever element the pass came from:
   * the sums below, and so the verdict, then depend on the ball alone
   * (RM2D_V_LSETTLED) */
  int s0min = 0;
  for (int s = 1; s < n; s++)
    if (el[s] < el[s0min]) s0min = s;
  if (s0min > 0) {
    pa_idx et[RM2D_BALL_MAX];
    int lt[RM2D_BALL_MAX];
    for (int s = 0; s < n; s++) {
      et[s] = el[(s + s0min) % n];
      lt[s] = loc[(s + s0min) % n];
    }
    memcpy(el, et, (size_t)n * sizeof *el);
    memcpy(loc, lt, (size_t)n * sizeof *loc);
  }
  double qold = 1;
  for (int s = 0; s < n; s++) {
    if (rm->tflag[el[s]] & RM2D_E_FROZEN) return 0;
    if (rm->q[el[s]] < qold) qold = rm->q[el[s]];
    nb[s] = rm->tv[3 * (size_t)el[s] + RM2D_NX3(loc[s])];
  }
  double *xp = rm->x + 2 * (size_t)p;
  const double *mp = RM2D_M(p);
  double l0[RM2D_BALL_MAX], l1[RM2D_BALL_MAX], s0 = 0;
  len_ball lb;
  len_ball_init(rm, mp, nb, n, &lb);
  int out0 = len_out_2d(&lb, xp, l0, n);
  if (out0 == 0) return 0;
  double jj[3] = {0, 0, 0}, jr[2] = {0, 0}, d2[2] = {0, 0}, worst = 0;
  double tp[3];
  rm2d_tensor2(mc, mp, tp);
  for (int s = 0; s < n; s++) {
    const double *xi = RM2D_X(nb[s]);
    double ti[3];
    rm2d_tensor2(mc, RM2D_M(nb[s]), ti);
    double a[3] = {0.5 * (tp[0] + ti[0]), 0.5 * (tp[1] + ti[1]),
                   0.5 * (tp[2] + ti[2])};
    double e[2] = {xi[0] - xp[0], xi[1] - xp[1]};
    double me[2] = {a[0] * e[0] + a[1] * e[1], a[1] * e[0] + a[2] * e[1]};
    double q = me[0] * e[0] + me[1] * e[1];
    if (!(q > 0)) return 0;
    double g[2] = {-me[0] / q, -me[1] / q};
    double l = l0[s], r = log(l / RM2D_LTARGET);
    s0 += r * r;
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
  double x0 = xp[0], y0 = xp[1], step = 1.0, qfloor = qold < RM2D_QLEN ? qold : RM2D_QLEN;
  for (int tr = 0; tr < 8; tr++, step *= 0.5) {
    if (tr == 4) step = 1.0;
    const double *dd = tr < 4 ? d : d2;
    double np[2] = {x0 + step * dd[0], y0 + step * dd[1]};
    int out1 = len_out_2d(&lb, np, l1, out0);
    if (!(out1 < out0 || (out1 == out0 && len_sum_below(l1, n, RM2D_LGAIN * s0))))
      continue;
    xp[0] = np[0];
    xp[1] = np[1];
    int ok = 1;
    double qn[RM2D_BALL_MAX];
    for (int s = 0; s < n && ok; s++) {
      const pa_idx *v = rm->tv + 3 * (size_t)el[s];
      double q = qn[s] = rm2d_elem_qual(rm, v[0], v[1], v[2]);
      if (!(q >= qfloor) ||
          !rm2d_qual_ok(rm, q, rm2d_qfloor(qold), v[0], v[1], v[2]))
        ok = 0;
    }
    xp[0] = x0;
    xp[1] = y0;
    if (!ok) continue;
    apply_move(rm, p, el, loc, n, np, mc <= 1 ? qn : NULL, lb.same, l1);
    return 1;
  }
  return 0;
}

int pa__rm2d_jiggle_vertex(rm2d *rm, pa_idx k, int ip, double delta) {
  int mc = rm->mc;
  pa_idx p = rm->tv[3 * k + ip];
  if (rm->vtag[p] & (RM2D_V_FROZEN | RM2D_V_CORNER | RM2D_V_FEAT)) return 0;
  pa_idx el[RM2D_BALL_MAX];
  int loc[RM2D_BALL_MAX], closed;
  int n = rm2d_ball(rm, k, ip, el, loc, &closed);
  if (n < 3 || !closed) return 0;
  double qold = ball_worst(rm, el, n);
  if (qold < 0) return 0;
  const double *xp = rm->x + 2 * (size_t)p;
  double d[2];
  pa__remesh_hash_dir(xp, 2, d);
  double t[3]; /* length delta in the metric of p */
  rm2d_tensor2(mc, RM2D_M(p), t);
  double lm = sqrt(pa__sqlen2(3, t, d[0], d[1]));
  if (!(lm > 0)) return 0;
  double np[2] = {xp[0] + delta * d[0] / lm, xp[1] + delta * d[1] / lm};
  if (!ball_keeps(rm, p, el, n, np, 0.5 * qold, qold)) return 0;
  apply_move(rm, p, el, loc, n, np, NULL, 0, NULL);
  return 1;
}
