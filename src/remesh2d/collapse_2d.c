/*
 * collapse_2d.c -- edge collapse of the 2D remesher: a vertex
 * merged into a neighbour, the elements on the edge removed. A feature
 * vertex slides only along its feature, and the merged record must stay
 * within hausd of the curve (chord and Hermite sagitta). When neither end
 * of a short edge can go along it, an end is collapsed onto another
 * neighbour (pa__rm2d_remove_vertex). Its pass is in driver_2d.c. Shared
 * contract of the operators: ops_2d.h.
 */
#include "remesh2d/ops_2d.h"

static double dist_point_segment(const double *p, const double *a,
                                 const double *b) {
  double dx = b[0] - a[0], dy = b[1] - a[1];
  double l2 = dx * dx + dy * dy;
  double t = l2 > 0 ? ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / l2 : 0;
  if (t < 0) t = 0;
  if (t > 1) t = 1;
  double ex = a[0] + t * dx - p[0], ey = a[1] + t * dy - p[1];
  return sqrt(ex * ex + ey * ey);
}

/* Feature collapse of p onto q along record r2 = (p, q): the other record
 * at p, *r1 = (u, p), found on the faces of p's ball (el, loc, n), must
 * merge with r2 into a record (u, q) within hausd of the curve: p within
 * hausd of the chord uq, the sagitta of the merged Hermite arc within
 * hausd, and the arc not folded. 1 when it does. */
static int feature_kept(const rm2d *rm, pa_idx p, pa_idx q, pa_idx r2,
                        const pa_idx *el, const int *loc, int n, pa_idx *r1p) {
  pa_idx r1 = -1;
  for (int t = 0; t < n && r1 < 0; t++) {
    pa_idx e = el[t];
    int l = loc[t];
    for (int side = 0; side < 2; side++) {
      pa_idx c = 3 * e + (side ? RM2D_NX3(l) : RM2D_PV3(l));
      pa_idx oc = rm->adj[c];
      if (oc < 0 && -oc - 1 != r2) {
        r1 = -oc - 1;
        break;
      }
    }
  }
  *r1p = r1;
  if (r1 < 0) return 0;
  pa_idx u = rm->bv[2 * r1] == p ? rm->bv[2 * r1 + 1] : rm->bv[2 * r1];
  if (u == q) return 0;
  const double *xu = RM2D_X(u), *xq = RM2D_X(q);
  double ha = pa__local_hausd(rm->opts, rm->bref[r1], rm->hausd);
  double hb = pa__local_hausd(rm->opts, rm->bref[r2], rm->hausd);
  double hausd = ha < hb ? ha : hb;
  if (dist_point_segment(RM2D_X(p), xu, xq) > hausd) return 0;
  /* sagitta of the merged arc: tangent at u from r1, at q from r2 */
  double tu[2], tq[2];
  int ue = rm->bv[2 * r1] == u ? 0 : 1, qe = rm->bv[2 * r2] == q ? 0 : 1;
  /* orient both along u -> p -> q */
  double dir_r1 = rm->bv[2 * r1] == u ? 1 : -1; /* r1 runs u -> p */
  double dir_r2 = rm->bv[2 * r2] == p ? 1 : -1; /* r2 runs p -> q */
  tu[0] = dir_r1 * rm->btan[4 * r1 + 2 * ue];
  tu[1] = dir_r1 * rm->btan[4 * r1 + 2 * ue + 1];
  tq[0] = dir_r2 * rm->btan[4 * r2 + 2 * qe];
  tq[1] = dir_r2 * rm->btan[4 * r2 + 2 * qe + 1];
  double dx = xq[0] - xu[0], dy = xq[1] - xu[1];
  double L = sqrt(dx * dx + dy * dy);
  /* Hermite midpoint minus chord midpoint = L/8 (tu - tq) */
  double sx = 0.125 * L * (tu[0] - tq[0]), sy = 0.125 * L * (tu[1] - tq[1]);
  if (sqrt(sx * sx + sy * sy) > hausd) return 0;
  /* the new arc must not fold: both tangents point forward */
  return !(tu[0] * dx + tu[1] * dy <= 0 || tq[0] * dx + tq[1] * dy <= 0);
}

/* The records of a feature collapse merged: r1 = (u, p) becomes (u, q) and
 * takes r2's tangent at q; r2 = (p, q) dies. */
static void merge_records(rm2d *rm, pa_idx p, pa_idx q, pa_idx r1, pa_idx r2) {
  int qe = rm->bv[2 * r2] == q ? 0 : 1;
  double arr = qe == 1 ? 1 : -1; /* r2's tangent arriving at q */
  double tqx = arr * rm->btan[4 * r2 + 2 * qe],
         tqy = arr * rm->btan[4 * r2 + 2 * qe + 1];
  int pe = rm->bv[2 * r1] == p ? 0 : 1;
  double sgn = pe == 1 ? 1 : -1; /* r1 arrives at its end 1 */
  rm->bv[2 * r1 + pe] = q;
  rm->btan[4 * r1 + 2 * pe] = sgn * tqx;
  rm->btan[4 * r1 + 2 * pe + 1] = sgn * tqy;
  pa__rm2d_kill_feat(rm, r2);
}

int pa__rm2d_collapse_edge(rm2d *rm, pa_idx k, int fi, int ip, double qrel) {
  pa_idx te = 3 * k + fi;
  pa_idx p = rm->tv[3 * k + ip];
  int iq = 3 - fi - ip;
  pa_idx q = rm->tv[3 * k + iq];
  uint8_t tp = rm->vtag[p];
  if (tp & (RM2D_V_FROZEN | RM2D_V_CORNER)) return 0;
  pa_idx o = rm->adj[te];
  /* a feature vertex slides only along its feature */
  if ((tp & RM2D_V_FEAT) && o >= 0) return 0;
  if (!rm2d_edge_free(rm, te)) return 0;

  pa_idx el[RM2D_BALL_MAX];
  int loc[RM2D_BALL_MAX], closed;
  int n = rm2d_ball(rm, k, ip, el, loc, &closed);
  if (n < 0 || n < (closed ? 3 : 2)) return 0;

  pa_idx s = rm2d_other_side(rm, te);
  pa_idx f = s >= 0 ? s / 3 : -1;
  double qold = 1, qnew = 1;
  for (int t = 0; t < n; t++) {
    if (rm->q[el[t]] < qold) qold = rm->q[el[t]];
  }
  const double fl = rm2d_qfloor(qold);
  for (int t = 0; t < n; t++) {
    pa_idx e = el[t];
    if (e == k || e == f) continue;
    if (rm->tflag[e] & RM2D_E_FROZEN) return 0;
    const pa_idx *v = rm->tv + 3 * (size_t)e;
    int l = loc[t];
    pa_idx a = v[RM2D_NX3(l)], b = v[RM2D_PV3(l)];
    if (a == q || b == q) return 0; /* q seen twice: not a simple ball */
    double qq = rm2d_elem_qual(rm, q, a, b);
    if (qq < qrel * qold || !rm2d_qual_ok(rm, qq, fl, q, a, b)) return 0;
    if (qq < qnew) qnew = qq;
    /* ping-pong guard: no new edge longer than lguard */
    if (rm2d_edge_len(rm, q, a) > rm->lguard ||
        rm2d_edge_len(rm, q, b) > rm->lguard)
      return 0;
  }

  /* outer faces of the deleted elements */
  pa_idx o1k = rm->adj[3 * k + ip], o2k = rm->adj[3 * k + iq];
  if (o1k < 0 && o2k < 0) return 0;
  pa_idx o1f = -1, o2f = -1;
  int jf = 0, jp = 0, jq = 0;
  if (f >= 0) {
    jf = s % 3;
    const pa_idx *vf = rm->tv + 3 * (size_t)f;
    jp = vf[RM2D_NX3(jf)] == p ? RM2D_NX3(jf) : RM2D_PV3(jf);
    jq = 3 - jf - jp;
    o1f = rm->adj[3 * f + jp];
    o2f = rm->adj[3 * f + jq];
    if (o1f < 0 && o2f < 0) return 0;
  }

  /* feature collapse: the merged record must stay within hausd of the curve */
  pa_idx r2 = -1, r1 = -1;
  if (tp & RM2D_V_FEAT) {
    r2 = -o - 1;
    if (!feature_kept(rm, p, q, r2, el, loc, n, &r1)) return 0;
  }

  /* apply: rewrite the ball, then stitch the outer faces of k (and f) */
  for (int t = 0; t < n; t++) {
    pa_idx e = el[t];
    if (e == k || e == f) continue;
    rm2d_elem_changed(rm, e);
    rm->tv[3 * e + loc[t]] = q;
    rm2d_elem_changed(rm, e);
    const pa_idx *v = rm->tv + 3 * (size_t)e;
    rm->q[e] = (float)rm2d_elem_qual(rm, v[0], v[1], v[2]);
    rm->tflag[e] |= RM2D_E_TOUCHED;
  }
  /* link o1 <-> o2 (at most one of them is a feature record) */
  pa_idx pairs[2][4] = {{o1k, 3 * k + ip, o2k, 3 * k + iq},
                        {o1f, 3 * f + jp, o2f, 3 * f + jq}};
  for (int h = 0; h < (f >= 0 ? 2 : 1); h++) {
    pa_idx x1 = pairs[h][0], c1 = pairs[h][1], x2 = pairs[h][2], c2 = pairs[h][3];
    if (x1 >= 0 && x2 >= 0) {
      rm->adj[x1] = x2;
      rm->adj[x2] = x1;
    } else if (x1 < 0) {
      rm2d_attach(rm, x2, x1, c1);
    } else {
      rm2d_attach(rm, x1, x2, c2);
    }
  }
  if (r2 >= 0) merge_records(rm, p, q, r1, r2);
  rm2d_elem_changed(rm, k); /* the third vertices' balls lose k and f */
  if (f >= 0) rm2d_elem_changed(rm, f);
  pa__rm2d_kill_elem(rm, k);
  if (f >= 0) pa__rm2d_kill_elem(rm, f);
  pa__rm2d_kill_vertex(rm, p);
  rm->ncollapse++;
  return 1;
}

/*
 * Fallback when a short edge cannot be collapsed along itself: remove its
 * end p = v[ip] of element k by collapsing p onto another neighbour, the
 * shortest edges first. Returns 1 if done.
 */
int pa__rm2d_remove_vertex(rm2d *rm, pa_idx k, int ip) {
  pa_idx p = rm->tv[3 * k + ip];
  if (rm->vtag[p] & (RM2D_V_FROZEN | RM2D_V_CORNER)) return 0;
  pa_idx el[RM2D_BALL_MAX];
  int loc[RM2D_BALL_MAX], closed;
  int n = rm2d_ball(rm, k, ip, el, loc, &closed);
  if (n < 0) return 0;
  /* candidate edges (element, face) from p, by increasing length */
  pa_idx ce[RM2D_BALL_MAX * 2], cr[RM2D_BALL_MAX * 2];
  int cf[RM2D_BALL_MAX * 2], nc = 0;
  double cl[RM2D_BALL_MAX * 2];
  for (int t = 0; t < n; t++) {
    pa_idx e = el[t];
    int l = loc[t];
    for (int side = 0; side < 2; side++) {
      int face = side ? RM2D_NX3(l) : RM2D_PV3(l);
      pa_idx r = rm->tv[3 * e + (side ? RM2D_PV3(l) : RM2D_NX3(l))];
      double len = rm2d_edge_len(rm, p, r);
      if (len >= PA_METRIC_LEN_HI) continue;
      int dup = 0;
      for (int c = 0; c < nc; c++) dup |= cr[c] == r;
      if (dup) continue; /* each neighbour once (it is in two elements) */
      int c = nc++;
      while (c > 0 && cl[c - 1] > len) {
        ce[c] = ce[c - 1];
        cf[c] = cf[c - 1];
        cl[c] = cl[c - 1];
        cr[c] = cr[c - 1];
        c--;
      }
      ce[c] = e;
      cf[c] = face;
      cl[c] = len;
      cr[c] = r;
    }
  }
  for (int c = 0; c < nc; c++) {
    const pa_idx *v = rm->tv + 3 * (size_t)ce[c];
    int lp = v[0] == p ? 0 : v[1] == p ? 1 : 2;
    if (pa__rm2d_collapse_edge(rm, ce[c], cf[c], lp, RM2D_QREL_COLLAPSE))
      return 1;
  }
  return 0;
}
