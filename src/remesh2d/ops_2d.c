/*
 * ops_2d.c -- the 2D local operators and their passes: edge split, edge
 * collapse, edge swap, vertex relocation, and a pass aimed at the worst
 * elements.
 *
 * Every operator evaluates its result before changing anything ("sim then
 * apply"): each new element must have quality >= RM_QFLOOR (so its orientation
 * is certain), plus the operator's own acceptance rule. The frozen contract is
 * enforced here: an element tagged RME_FROZEN is never rewritten nor deleted,
 * so none of its edges is split, swapped or collapsed (a collapse removes a
 * vertex, and vertices of frozen elements are RMV_FROZEN); frozen and corner
 * vertices never move nor disappear; feature edges are never swapped.
 *
 * Local numbering: in element k = (v0, v1, v2), counter-clockwise, face i is
 * the edge from v[i+1] to v[i+2] (indices mod 3), opposite v[i]. Across a
 * shared edge the neighbour runs it the other way.
 *
 * Passes visit elements in slot order and skip elements already touched in
 * the same pass (RME_TOUCHED), so each neighbourhood changes at most once
 * per pass and the result is deterministic.
 */
#include "remesh2d/remesh2d.h"

#define BALL_MAX 128
/* A move is kept when it raises the ball's worst or mean quality by 1 %. */
#define MOVE_GAIN_MIN 1.01
#define MOVE_GAIN_MEAN 1.01
#define X(v) (rm->x + 2 * (size_t)(v))
#define M(v) (rm->met + (size_t)mc * (v))
#define NX3(i) ((i) == 2 ? 0 : (i) + 1)
#define PV3(i) ((i) == 0 ? 2 : (i) - 1)

static inline double elem_qual(const pa__rmesh *rm, pa_idx a, pa_idx b,
                               pa_idx c) {
  int mc = rm->mcomp;
  return rm_qual2(mc, X(a), X(b), X(c), M(a), M(b), M(c));
}

static inline double edge_len(const pa__rmesh *rm, pa_idx a, pa_idx b) {
  int mc = rm->mcomp;
  return rm_len2(mc, X(a), X(b), M(a), M(b));
}

/* Face on the other side of face `code` (through a feature record if need
 * be), or -1 on the domain boundary. */
static inline pa_idx other_side(const pa__rmesh *rm, pa_idx code) {
  pa_idx o = rm->adj[code];
  if (o >= 0) return o;
  pa_idx b = -o - 1;
  return rm->bside[2 * b] == code ? rm->bside[2 * b + 1] : rm->bside[2 * b];
}

/* Edge (face code) can be split, collapsed or swapped: no frozen element on
 * either side, no frozen feature record. */
static inline int edge_free(const pa__rmesh *rm, pa_idx code) {
  if (rm->etag[code / 3] & RME_FROZEN) return 0;
  pa_idx o = rm->adj[code];
  if (o < 0 && (rm->btag[-o - 1] & RMB_FROZEN)) return 0;
  pa_idx s = other_side(rm, code);
  return s < 0 || !(rm->etag[s / 3] & RME_FROZEN);
}

/* Attach new face `code` to outer value o, which was attached to `oldcode`. */
static inline void attach(pa__rmesh *rm, pa_idx code, pa_idx o, pa_idx oldcode) {
  rm->adj[code] = o;
  if (o >= 0) {
    rm->adj[o] = code;
  } else {
    pa_idx b = -o - 1;
    if (rm->bside[2 * b] == oldcode) rm->bside[2 * b] = code;
    else rm->bside[2 * b + 1] = code;
  }
}

/* Element k is rewritten or about to be killed, or one of its vertices
 * moved: drop the caches that depend on it (RME_INRANGE of k, RME_NOSWAP of
 * k and its neighbours, RMV_SETTLED of its vertices, whose balls change).
 * Call with k's current vertices and, on a rewrite, before its adjacency is
 * updated (the old neighbours are the ones to tell; a new neighbour of a
 * rewritten element is an old neighbour of the rewritten group). */
static inline void elem_changed(pa__rmesh *rm, pa_idx k) {
  const pa_idx *v = rm->ev + 3 * (size_t)k;
  const pa_idx *a = rm->adj + 3 * (size_t)k;
  rm->etag[k] &= (uint8_t)~(RME_INRANGE | RME_NOSWAP);
  /* neighbours: their swaps across k see a new k (swaps never cross a
   * feature record, so only direct neighbours matter) */
  if (a[0] >= 0) rm->etag[a[0] / 3] &= (uint8_t)~RME_NOSWAP;
  if (a[1] >= 0) rm->etag[a[1] / 3] &= (uint8_t)~RME_NOSWAP;
  if (a[2] >= 0) rm->etag[a[2] / 3] &= (uint8_t)~RME_NOSWAP;
  rm->vtag[v[0]] &= (uint8_t)~RMV_SETTLED;
  rm->vtag[v[1]] &= (uint8_t)~RMV_SETTLED;
  rm->vtag[v[2]] &= (uint8_t)~RMV_SETTLED;
}

/* Write element k (an existing or a new slot). The caller has called
 * elem_changed on every existing element it rewrites, before the rewrite;
 * the vertices of the new elements are then those old ones plus new vertices
 * (no cached flags), and new slots start with no cached flags either. */
static inline void set_elem(pa__rmesh *rm, pa_idx k, pa_idx a, pa_idx b,
                            pa_idx c, double q) {
  rm->ev[3 * k] = a;
  rm->ev[3 * k + 1] = b;
  rm->ev[3 * k + 2] = c;
  rm->q[k] = (float)q;
  rm->etag[k] |= RME_TOUCHED;
}

/* ------------------------------------------------------------------------ */
/* Split                                                                    */
/* ------------------------------------------------------------------------ */

/*
 * Split face i of element k at its midpoint (on a feature: the midpoint of
 * the reconstructed curve). Returns 1 if done, 0 if rejected; *st on memory
 * failure (then nothing changed).
 */
static int split_edge(pa__rmesh *rm, pa_idx k, int i, pa_status *st) {
  pa_idx te = 3 * k + i;
  int i1 = NX3(i), i2 = PV3(i);
  pa_idx p0 = rm->ev[3 * k + i], a = rm->ev[3 * k + i1], b = rm->ev[3 * k + i2];
  pa_idx o = rm->adj[te];
  pa_idx feat = o < 0 ? -o - 1 : -1;
  pa_idx fcode = o >= 0 ? o : other_side(rm, te);
  pa_idx f = -1, p1 = -1;
  int j = 0, j1 = 0, j2 = 0;
  if (fcode >= 0) {
    f = fcode / 3;
    j = fcode % 3;
    j1 = NX3(j);
    j2 = PV3(j);
    p1 = rm->ev[3 * f + j];
  }
  *st = pa__rm_reserve(rm, 1, 2, 1);
  if (*st) return 0;

  pa_idx m;
  pa__rm_new_vertex(rm, &m); /* cannot fail after the reserve */
  double *xm = rm->x + 2 * (size_t)m, tm[2] = {0, 0};
  if (feat >= 0) {
    pa__rm_curve_point_2d(rm, feat, 0.5, xm, tm);
  } else {
    xm[0] = 0.5 * (X(a)[0] + X(b)[0]);
    xm[1] = 0.5 * (X(a)[1] + X(b)[1]);
  }
  pa_idx src[2] = {a, b};
  double w[2] = {0.5, 0.5};
  pa__rm_interp(rm, m, 2, src, w);

  double q1 = elem_qual(rm, p0, a, m), q2 = elem_qual(rm, p0, m, b);
  double q3 = 1, q4 = 1;
  if (f >= 0) {
    q3 = elem_qual(rm, p1, b, m);
    q4 = elem_qual(rm, p1, m, a);
  }
  if (q1 < RM_QFLOOR || q2 < RM_QFLOOR || q3 < RM_QFLOOR || q4 < RM_QFLOOR) {
    pa__rm_kill_vertex(rm, m);
    return 0;
  }

  pa_idx oA = rm->adj[3 * k + i1], oB = rm->adj[3 * k + i2];
  pa_idx fA = -1, fB = -1;
  if (f >= 0) {
    fB = rm->adj[3 * f + j1];
    fA = rm->adj[3 * f + j2];
  }
  pa_idx k2, f2 = -1, nb2 = -1;
  elem_changed(rm, k);
  if (f >= 0) elem_changed(rm, f);
  pa__rm_new_elem(rm, &k2);
  rm->eref[k2] = rm->eref[k];
  rm->etag[k2] = rm->etag[k] & 0x0F;
  if (f >= 0) {
    pa__rm_new_elem(rm, &f2);
    rm->eref[f2] = rm->eref[f];
    rm->etag[f2] = rm->etag[f] & 0x0F;
  }
  /* T1 = k (p0 a m), T2 = k2 (p0 m b), T3 = f (p1 b m), T4 = f2 (p1 m a) */
  set_elem(rm, k, p0, a, m, q1);
  set_elem(rm, k2, p0, m, b, q2);
  attach(rm, 3 * k + 2, oB, 3 * k + i2);
  attach(rm, 3 * k2 + 1, oA, 3 * k + i1);
  rm->adj[3 * k + 1] = 3 * k2 + 2;
  rm->adj[3 * k2 + 2] = 3 * k + 1;
  if (f >= 0) {
    set_elem(rm, f, p1, b, m, q3);
    set_elem(rm, f2, p1, m, a, q4);
    attach(rm, 3 * f + 2, fA, 3 * f + j2);
    attach(rm, 3 * f2 + 1, fB, 3 * f + j1);
    rm->adj[3 * f + 1] = 3 * f2 + 2;
    rm->adj[3 * f2 + 2] = 3 * f + 1;
  }
  if (feat < 0) {
    rm->adj[3 * k] = 3 * f2;
    rm->adj[3 * f2] = 3 * k;
    rm->adj[3 * k2] = 3 * f;
    rm->adj[3 * f] = 3 * k2;
  } else {
    /* record (u, w) -> (u, m) + new (m, w); sides by which half they hold */
    pa__rm_new_feat(rm, &nb2);
    pa_idx u = rm->bv[2 * feat], wv = rm->bv[2 * feat + 1];
    rm->bv[2 * nb2] = m;
    rm->bv[2 * nb2 + 1] = wv;
    rm->bv[2 * feat + 1] = m;
    rm->bref[nb2] = rm->bref[feat];
    rm->btag[nb2] = rm->btag[feat];
    rm->btan[4 * nb2] = tm[0];
    rm->btan[4 * nb2 + 1] = tm[1];
    rm->btan[4 * nb2 + 2] = rm->btan[4 * feat + 2];
    rm->btan[4 * nb2 + 3] = rm->btan[4 * feat + 3];
    rm->btan[4 * feat + 2] = tm[0];
    rm->btan[4 * feat + 3] = tm[1];
    /* half (a, m) is held by T1 face 0 and T4 face 0 */
    pa_idx ram = u == a ? feat : nb2, rmb = u == a ? nb2 : feat;
    rm->adj[3 * k] = -ram - 1;
    rm->adj[3 * k2] = -rmb - 1;
    rm->bside[2 * ram] = 3 * k;
    rm->bside[2 * ram + 1] = f >= 0 ? 3 * f2 : -1;
    rm->bside[2 * rmb] = 3 * k2;
    rm->bside[2 * rmb + 1] = f >= 0 ? 3 * f : -1;
    if (f >= 0) {
      rm->adj[3 * f2] = -ram - 1;
      rm->adj[3 * f] = -rmb - 1;
    }
    rm->vtag[m] |= RMV_FEAT;
    rm->vref[m] = rm->bref[feat];
  }
  rm->nsplit++;
  return 1;
}

/* Longest free edge of element k above thr: face index or -1, length in *len;
 * *inr (may be NULL) = all three edges in [RM_LSHORT, RM_LLONG]. */
static int longest_free(const pa__rmesh *rm, pa_idx k, double thr, double *len,
                        int *inr) {
  const pa_idx *v = rm->ev + 3 * (size_t)k;
  int best = -1, in = 1;
  double lb = thr;
  for (int i = 0; i < 3; i++) {
    double l = edge_len(rm, v[NX3(i)], v[PV3(i)]);
    in &= l >= RM_LSHORT && l <= RM_LLONG;
    if (l > lb && edge_free(rm, 3 * k + i)) {
      lb = l;
      best = i;
    }
  }
  *len = lb;
  if (inr) *inr = in;
  return best;
}

pa_status pa__rm_split_pass_2d(pa__rmesh *rm, double thr, long *n) {
  pa_status st = PA_SUCCESS;
  long cnt = 0;
  for (pa_idx k = 0; k < rm->ne; k++) rm->etag[k] &= ~RME_TOUCHED;
  for (pa_idx k = 0; k < rm->ne; k++) {
    uint8_t t = rm->etag[k];
    if (t & (RME_DEAD | RME_TOUCHED | RME_FROZEN)) continue;
    if ((t & RME_INRANGE) && thr >= RM_LLONG) continue; /* nothing above thr */
    double l;
    int inr;
    int i = longest_free(rm, k, thr, &l, &inr);
    if (inr) rm->etag[k] |= RME_INRANGE;
    if (i < 0) continue;
    /* Longest-edge propagation: split only if the edge is also the longest
     * free edge of the neighbour (else the neighbour goes first). */
    pa_idx s = other_side(rm, 3 * k + i);
    if (s >= 0) {
      pa_idx f = s / 3;
      if (rm->etag[f] & RME_TOUCHED) continue;
      double lf;
      int jf = longest_free(rm, f, l * (1 + 1e-12), &lf, NULL);
      if (jf >= 0 && jf != s % 3) continue;
    }
    cnt += split_edge(rm, k, i, &st);
    if (st) goto cleanup;
  }
cleanup:
  *n = cnt;
  return st;
}

/* ------------------------------------------------------------------------ */
/* Ball walks                                                               */
/* ------------------------------------------------------------------------ */

/*
 * Elements around vertex p starting from element k (local index ip): counter-
 * clockwise until back to k or the domain boundary, then clockwise from k.
 * Fills el[] and loc[] (local index of p) and returns the count, or -1 if the
 * ball exceeds BALL_MAX. *closed is 1 for an interior vertex.
 */
static int ball_2d(const pa__rmesh *rm, pa_idx k, int ip, pa_idx *el, int *loc,
                   int *closed) {
  int n = 0;
  el[n] = k;
  loc[n++] = ip;
  pa_idx c = k;
  int l = ip;
  *closed = 0;
  for (;;) {
    pa_idx s = other_side(rm, 3 * c + NX3(l));
    if (s < 0) break;
    c = s / 3;
    l = NX3(s % 3);
    if (c == k) {
      *closed = 1;
      return n;
    }
    if (n >= BALL_MAX) return -1;
    el[n] = c;
    loc[n++] = l;
  }
  /* clockwise from k: the order is then [k, ccw..., cw...] */
  c = k;
  l = ip;
  for (;;) {
    pa_idx s = other_side(rm, 3 * c + PV3(l));
    if (s < 0) break;
    c = s / 3;
    l = PV3(s % 3);
    if (n >= BALL_MAX) return -1;
    el[n] = c;
    loc[n++] = l;
  }
  return n;
}

/* ------------------------------------------------------------------------ */
/* Collapse                                                                 */
/* ------------------------------------------------------------------------ */

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

/*
 * Collapse vertex p = v[ip] of element k onto q, the other end of face fi of
 * k (fi != ip). Returns 1 if done, 0 if rejected.
 */
static int collapse_edge(pa__rmesh *rm, pa_idx k, int fi, int ip, double qrel) {
  pa_idx te = 3 * k + fi;
  pa_idx p = rm->ev[3 * k + ip];
  int iq = 3 - fi - ip;
  pa_idx q = rm->ev[3 * k + iq];
  uint8_t tp = rm->vtag[p];
  if (tp & (RMV_FROZEN | RMV_CORNER)) return 0;
  pa_idx o = rm->adj[te];
  if ((tp & RMV_FEAT) && o >= 0) return 0; /* a feature vertex slides only along its feature */
  if (!edge_free(rm, te)) return 0;

  pa_idx el[BALL_MAX];
  int loc[BALL_MAX], closed;
  int n = ball_2d(rm, k, ip, el, loc, &closed);
  if (n < 0 || n < (closed ? 3 : 2)) return 0;

  pa_idx s = other_side(rm, te);
  pa_idx f = s >= 0 ? s / 3 : -1;
  double qold = 1, qnew = 1;
  for (int t = 0; t < n; t++) {
    if (rm->q[el[t]] < qold) qold = rm->q[el[t]];
  }
  for (int t = 0; t < n; t++) {
    pa_idx e = el[t];
    if (e == k || e == f) continue;
    if (rm->etag[e] & RME_FROZEN) return 0;
    const pa_idx *v = rm->ev + 3 * (size_t)e;
    int l = loc[t];
    pa_idx a = v[NX3(l)], b = v[PV3(l)];
    if (a == q || b == q) return 0; /* q seen twice: not a simple ball */
    double qq = elem_qual(rm, q, a, b);
    if (qq < RM_QFLOOR || qq < qrel * qold) return 0;
    if (qq < qnew) qnew = qq;
    /* ping-pong guard: no new edge longer than lguard */
    if (edge_len(rm, q, a) > rm->lguard || edge_len(rm, q, b) > rm->lguard)
      return 0;
  }

  /* outer faces of the deleted elements */
  pa_idx o1k = rm->adj[3 * k + ip], o2k = rm->adj[3 * k + iq];
  if (o1k < 0 && o2k < 0) return 0;
  pa_idx o1f = -1, o2f = -1;
  int jf = 0, jp = 0, jq = 0;
  if (f >= 0) {
    jf = s % 3;
    const pa_idx *vf = rm->ev + 3 * (size_t)f;
    jp = vf[NX3(jf)] == p ? NX3(jf) : PV3(jf);
    jq = 3 - jf - jp;
    o1f = rm->adj[3 * f + jp];
    o2f = rm->adj[3 * f + jq];
    if (o1f < 0 && o2f < 0) return 0;
  }

  /* feature collapse: the merged record must stay within hausd of the curve */
  pa_idx r2 = -1, r1 = -1;
  if (tp & RMV_FEAT) {
    r2 = -o - 1;
    /* the other record at p: found on the faces of the ball holding p */
    for (int t = 0; t < n && r1 < 0; t++) {
      pa_idx e = el[t];
      int l = loc[t];
      for (int side = 0; side < 2; side++) {
        pa_idx c = 3 * e + (side ? NX3(l) : PV3(l));
        pa_idx oc = rm->adj[c];
        if (oc < 0 && -oc - 1 != r2) {
          r1 = -oc - 1;
          break;
        }
      }
    }
    if (r1 < 0) return 0;
    pa_idx u = rm->bv[2 * r1] == p ? rm->bv[2 * r1 + 1] : rm->bv[2 * r1];
    if (u == q) return 0;
    const double *xu = X(u), *xq = X(q);
    double ha = pa__local_hausd(rm->opts, rm->bref[r1], rm->hausd);
    double hb = pa__local_hausd(rm->opts, rm->bref[r2], rm->hausd);
    double hausd = ha < hb ? ha : hb;
    if (dist_point_segment(X(p), xu, xq) > hausd) return 0;
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
    if (tu[0] * dx + tu[1] * dy <= 0 || tq[0] * dx + tq[1] * dy <= 0) return 0;
  }

  /* apply: rewrite the ball, then stitch the outer faces of k (and f) */
  for (int t = 0; t < n; t++) {
    pa_idx e = el[t];
    if (e == k || e == f) continue;
    elem_changed(rm, e);
    rm->ev[3 * e + loc[t]] = q;
    elem_changed(rm, e);
    const pa_idx *v = rm->ev + 3 * (size_t)e;
    rm->q[e] = (float)elem_qual(rm, v[0], v[1], v[2]);
    rm->etag[e] |= RME_TOUCHED;
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
      attach(rm, x2, x1, c1);
    } else {
      attach(rm, x1, x2, c2);
    }
  }
  if (r2 >= 0) {
    /* r1 = (u, p) becomes (u, q) and takes r2's tangent at q */
    int qe = rm->bv[2 * r2] == q ? 0 : 1;
    double arr = qe == 1 ? 1 : -1; /* r2's tangent arriving at q */
    double tqx = arr * rm->btan[4 * r2 + 2 * qe], tqy = arr * rm->btan[4 * r2 + 2 * qe + 1];
    int pe = rm->bv[2 * r1] == p ? 0 : 1;
    double sgn = pe == 1 ? 1 : -1; /* r1 arrives at its end 1 */
    rm->bv[2 * r1 + pe] = q;
    rm->btan[4 * r1 + 2 * pe] = sgn * tqx;
    rm->btan[4 * r1 + 2 * pe + 1] = sgn * tqy;
    pa__rm_kill_feat(rm, r2);
  }
  elem_changed(rm, k); /* the third vertices' balls lose k and f */
  if (f >= 0) elem_changed(rm, f);
  pa__rm_kill_elem(rm, k);
  if (f >= 0) pa__rm_kill_elem(rm, f);
  pa__rm_kill_vertex(rm, p);
  rm->ncollapse++;
  return 1;
}

/*
 * Fallback when a short edge cannot be collapsed along itself: remove its
 * end p = v[ip] of element k by collapsing p onto another neighbour, the
 * shortest edges first. Returns 1 if done.
 */
static int remove_vertex(pa__rmesh *rm, pa_idx k, int ip) {
  pa_idx p = rm->ev[3 * k + ip];
  if (rm->vtag[p] & (RMV_FROZEN | RMV_CORNER)) return 0;
  pa_idx el[BALL_MAX];
  int loc[BALL_MAX], closed;
  int n = ball_2d(rm, k, ip, el, loc, &closed);
  if (n < 0) return 0;
  /* candidate edges (element, face) from p, by increasing length */
  pa_idx ce[BALL_MAX * 2], cr[BALL_MAX * 2];
  int cf[BALL_MAX * 2], nc = 0;
  double cl[BALL_MAX * 2];
  for (int t = 0; t < n; t++) {
    pa_idx e = el[t];
    int l = loc[t];
    for (int side = 0; side < 2; side++) {
      int face = side ? NX3(l) : PV3(l);
      pa_idx r = rm->ev[3 * e + (side ? PV3(l) : NX3(l))];
      double len = edge_len(rm, p, r);
      if (len >= RM_LLONG) continue;
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
    const pa_idx *v = rm->ev + 3 * (size_t)ce[c];
    int lp = v[0] == p ? 0 : v[1] == p ? 1 : 2;
    if (collapse_edge(rm, ce[c], cf[c], lp, 0.3)) return 1;
  }
  return 0;
}

pa_status pa__rm_collapse_pass_2d(pa__rmesh *rm, double thr, long *n) {
  long cnt = 0;
  for (pa_idx k = 0; k < rm->ne; k++) rm->etag[k] &= ~RME_TOUCHED;
  for (pa_idx k = 0; k < rm->ne; k++) {
    uint8_t t = rm->etag[k];
    if (t & (RME_DEAD | RME_TOUCHED | RME_FROZEN)) continue;
    if ((t & RME_INRANGE) && thr <= RM_LSHORT) continue; /* nothing below thr */
    const pa_idx *v = rm->ev + 3 * (size_t)k;
    /* shortest edge first */
    int best = -1, inr = 1;
    double lb = thr;
    for (int i = 0; i < 3; i++) {
      double l = edge_len(rm, v[NX3(i)], v[PV3(i)]);
      inr &= l >= RM_LSHORT && l <= RM_LLONG;
      if (l < lb) {
        lb = l;
        best = i;
      }
    }
    if (inr) rm->etag[k] |= RME_INRANGE;
    if (best < 0) continue;
    pa_idx s = other_side(rm, 3 * k + best);
    if (s >= 0 && (rm->etag[s / 3] & RME_TOUCHED)) continue;
    if (collapse_edge(rm, k, best, NX3(best), 0.3) ||
        collapse_edge(rm, k, best, PV3(best), 0.3) ||
        remove_vertex(rm, k, NX3(best)) || remove_vertex(rm, k, PV3(best)))
      cnt++;
  }
  *n = cnt;
  return PA_SUCCESS;
}

/* ------------------------------------------------------------------------ */
/* Swap                                                                     */
/* ------------------------------------------------------------------------ */

/* Swap face i of k if it raises the worst quality of the pair by the factor
 * gain. Returns 1 if done. */
static int swap_edge(pa__rmesh *rm, pa_idx k, int i, double gain) {
  pa_idx o = rm->adj[3 * k + i];
  if (o < 0) return 0;
  pa_idx f = o / 3;
  int j = o % 3;
  if ((rm->etag[k] | rm->etag[f]) & RME_FROZEN) return 0;
  int i1 = NX3(i), i2 = PV3(i), j1 = NX3(j), j2 = PV3(j);
  pa_idx p0 = rm->ev[3 * k + i], a = rm->ev[3 * k + i1], b = rm->ev[3 * k + i2];
  pa_idx p1 = rm->ev[3 * f + j];
  double qo = rm->q[k] < rm->q[f] ? rm->q[k] : rm->q[f];
  double q1 = elem_qual(rm, p0, a, p1);
  if (q1 < RM_QFLOOR || q1 <= gain * qo) return 0;
  double q2 = elem_qual(rm, p1, b, p0);
  if (q2 < RM_QFLOOR || q2 <= gain * qo) return 0;
  pa_idx oA = rm->adj[3 * k + i1], oB = rm->adj[3 * k + i2];
  pa_idx fB = rm->adj[3 * f + j1], fA = rm->adj[3 * f + j2];
  /* T1 = k (p0 a p1), T2 = f (p1 b p0) */
  elem_changed(rm, k);
  elem_changed(rm, f);
  set_elem(rm, k, p0, a, p1, q1);
  set_elem(rm, f, p1, b, p0, q2);
  attach(rm, 3 * k, fB, 3 * f + j1);
  attach(rm, 3 * k + 2, oB, 3 * k + i2);
  attach(rm, 3 * f, oA, 3 * k + i1);
  attach(rm, 3 * f + 2, fA, 3 * f + j2);
  rm->adj[3 * k + 1] = 3 * f + 1;
  rm->adj[3 * f + 1] = 3 * k + 1;
  rm->nswap++;
  return 1;
}

long pa__rm_swap_pass_2d(pa__rmesh *rm, double qmax) {
  long cnt = 0;
  for (pa_idx k = 0; k < rm->ne; k++) rm->etag[k] &= ~RME_TOUCHED;
  for (pa_idx k = 0; k < rm->ne; k++) {
    uint8_t t = rm->etag[k];
    if (t & (RME_DEAD | RME_TOUCHED | RME_FROZEN)) continue;
    if (rm->q[k] >= qmax || (t & RME_NOSWAP)) continue;
    int done = 0, all = 1;
    for (int i = 0; i < 3 && !done; i++) {
      pa_idx o = rm->adj[3 * k + i];
      if (o < 0) continue;
      if (rm->etag[o / 3] & RME_TOUCHED) {
        all = 0; /* not tried: no verdict for this face */
        continue;
      }
      done = swap_edge(rm, k, i, 1.02);
    }
    cnt += done;
    if (!done && all) rm->etag[k] |= RME_NOSWAP;
  }
  return cnt;
}

/* ------------------------------------------------------------------------ */
/* Relocation                                                               */
/* ------------------------------------------------------------------------ */

/* Move interior vertex p (its closed ball el[0..n), local indices loc) to
 * np: metric and fields interpolated from the old triangle holding np
 * (barycentric; linear fields stay exact), qualities updated. */
static void apply_move(pa__rmesh *rm, pa_idx p, const pa_idx *el,
                       const int *loc, int n, const double *np) {
  double *xp = rm->x + 2 * (size_t)p;
  double x0 = xp[0], y0 = xp[1];
  for (int s = 0; s < n; s++) {
    const pa_idx *v = rm->ev + 3 * (size_t)el[s];
    pa_idx va = v[NX3(loc[s])], vb = v[PV3(loc[s])];
    const double *a = X(va), *b = X(vb);
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
    rm->q[el[s]] = (float)elem_qual(rm, v[0], v[1], v[2]);
    elem_changed(rm, el[s]); /* p's neighbours see a new ball */
  }
  rm->nmove++;
}

/* Move interior vertex p = v[ip] of element k towards the mean of the ideal
 * apexes of its ball (equilateral in the metric of p). Returns 1 if moved. */
static int move_vertex(pa__rmesh *rm, pa_idx k, int ip) {
  int mc = rm->mcomp;
  pa_idx p = rm->ev[3 * k + ip];
  pa_idx el[BALL_MAX];
  int loc[BALL_MAX], closed;
  int n = ball_2d(rm, k, ip, el, loc, &closed);
  if (n < 3 || !closed) return 0;
  double t[3];
  rm_tensor2(mc, M(p), t);
  double det = t[0] * t[2] - t[1] * t[1];
  if (!(det > 0)) return 0;
  double sd = 1.0 / sqrt(det);
  double cx = 0, cy = 0, qold = 1, qmean = 0;
  for (int s = 0; s < n; s++) {
    const pa_idx *v = rm->ev + 3 * (size_t)el[s];
    if (rm->etag[el[s]] & RME_FROZEN) return 0;
    const double *a = X(v[NX3(loc[s])]), *b = X(v[PV3(loc[s])]);
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
  uint8_t inr[BALL_MAX];
  int have_inr = 0;
  double *xp = rm->x + 2 * (size_t)p;
  double x0 = xp[0], y0 = xp[1];
  double qn[BALL_MAX];
  double om = 1.0;
  for (int tr = 0; tr < 3; tr++, om *= 0.5) {
    xp[0] = x0 + om * (cx - x0);
    xp[1] = y0 + om * (cy - y0);
    double qmin = 1, qm = 0;
    int ok = 1;
    for (int s = 0; s < n && ok; s++) {
      const pa_idx *v = rm->ev + 3 * (size_t)el[s];
      qn[s] = elem_qual(rm, v[0], v[1], v[2]);
      if (qn[s] < RM_QFLOOR || qn[s] < qold) ok = 0;
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
        double l = edge_len(rm, p, rm->ev[3 * (size_t)el[s] + NX3(loc[s])]);
        inr[s] = l >= RM_LSHORT && l <= RM_LLONG;
      }
      xp[0] = np[0];
      xp[1] = np[1];
      have_inr = 1;
    }
    for (int s = 0; s < n && ok; s++) {
      if (!inr[s]) continue;
      double l = edge_len(rm, p, rm->ev[3 * (size_t)el[s] + NX3(loc[s])]);
      ok = l >= RM_LSHORT && l <= RM_LLONG;
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
  for (pa_idx v = 0; v < rm->nv; v++) rm->vtag[v] &= ~RMV_DONE;
  for (pa_idx k = 0; k < rm->ne; k++) {
    if (rm->etag[k] & (RME_DEAD | RME_FROZEN)) continue;
    for (int i = 0; i < 3; i++) {
      pa_idx p = rm->ev[3 * k + i];
      uint8_t tp = rm->vtag[p];
      if (tp & (RMV_DONE | RMV_FROZEN | RMV_CORNER | RMV_FEAT)) continue;
      /* DONE even when skipped: a neighbour's move later in this pass must
       * not make p eligible again from another start element */
      rm->vtag[p] |= RMV_DONE;
      /* the answer depends only on p's ball: a rejected p stays settled
       * until an operator or a move changes that ball (elem_changed) */
      if (tp & RMV_SETTLED) continue;
      if (move_vertex(rm, k, i)) cnt++;
      else rm->vtag[p] |= RMV_SETTLED;
    }
  }
  return cnt;
}

/* ------------------------------------------------------------------------ */
/* Relocation for lengths                                                   */
/* ------------------------------------------------------------------------ */

/* Edges at p out of [RM_LSHORT, RM_LLONG] and their sum of ln^2 (L /
 * RM_LTARGET), with p at
 * y (metric mp) and its neighbours nb[0..nn). */
static int len_score_2d(const pa__rmesh *rm, const double *y, const double *mp,
                        const pa_idx *nb, int nn, double *sum) {
  int mc = rm->mcomp, out = 0;
  double s = 0;
  for (int i = 0; i < nn; i++) {
    double l = rm_len2(mc, y, X(nb[i]), mp, M(nb[i]));
    out += !(l >= RM_LSHORT && l <= RM_LLONG);
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
  pa_idx el[BALL_MAX], nb[BALL_MAX];
  int loc[BALL_MAX], closed;
  int n = ball_2d(rm, k, ip, el, loc, &closed);
  if (n < 3 || !closed) return 0;
  double qold = 1;
  for (int s = 0; s < n; s++) {
    if (rm->etag[el[s]] & RME_FROZEN) return 0;
    if (rm->q[el[s]] < qold) qold = rm->q[el[s]];
    nb[s] = rm->ev[3 * (size_t)el[s] + NX3(loc[s])];
  }
  double *xp = rm->x + 2 * (size_t)p;
  const double *mp = M(p);
  double s0;
  int out0 = len_score_2d(rm, xp, mp, nb, n, &s0);
  if (out0 == 0) return 0;
  double jj[3] = {0, 0, 0}, jr[2] = {0, 0}, d2[2] = {0, 0}, worst = 0;
  double tp[3];
  rm_tensor2(mc, mp, tp);
  for (int s = 0; s < n; s++) {
    const double *xi = X(nb[s]);
    double ti[3];
    rm_tensor2(mc, M(nb[s]), ti);
    double a[3] = {0.5 * (tp[0] + ti[0]), 0.5 * (tp[1] + ti[1]),
                   0.5 * (tp[2] + ti[2])};
    double e[2] = {xi[0] - xp[0], xi[1] - xp[1]};
    double me[2] = {a[0] * e[0] + a[1] * e[1], a[1] * e[0] + a[2] * e[1]};
    double q = me[0] * e[0] + me[1] * e[1];
    if (!(q > 0)) return 0;
    double g[2] = {-me[0] / q, -me[1] / q};
    double l = rm_len2(mc, xp, xi, mp, M(nb[s])), r = log(l / RM_LTARGET);
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
      double q = elem_qual(rm, v[0], v[1], v[2]);
      if (!(q >= qfloor) || q < RM_QFLOOR) ok = 0;
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
  for (pa_idx v = 0; v < rm->nv; v++) rm->vtag[v] &= ~RMV_DONE;
  for (pa_idx k = 0; k < rm->ne; k++) {
    if (rm->etag[k] & (RME_DEAD | RME_FROZEN)) continue;
    const pa_idx *v = rm->ev + 3 * (size_t)k;
    int bad = 0;
    for (int i = 0; i < 3 && !bad; i++) {
      double l = rm_len2(mc, X(v[NX3(i)]), X(v[PV3(i)]), M(v[NX3(i)]),
                         M(v[PV3(i)]));
      bad = !(l >= RM_LSHORT && l <= RM_LLONG);
    }
    if (!bad) continue;
    for (int i = 0; i < 3; i++) {
      pa_idx p = v[i];
      uint8_t tp = rm->vtag[p];
      if (tp & (RMV_DONE | RMV_FROZEN | RMV_CORNER | RMV_FEAT)) continue;
      rm->vtag[p] |= RMV_DONE;
      cnt += length_vertex(rm, k, i);
    }
  }
  return cnt;
}

/* ------------------------------------------------------------------------ */
/* Worst elements                                                           */
/* ------------------------------------------------------------------------ */

long pa__rm_sliver_pass_2d(pa__rmesh *rm, double qbad) {
  long cnt = 0;
  for (pa_idx k = 0; k < rm->ne; k++) rm->etag[k] &= ~RME_TOUCHED;
  for (pa_idx k = 0; k < rm->ne; k++) {
    uint8_t t = rm->etag[k];
    if (t & (RME_DEAD | RME_TOUCHED | RME_FROZEN)) continue;
    if (rm->q[k] >= qbad) continue;
    int done = 0;
    for (int i = 0; i < 3 && !done; i++) done = swap_edge(rm, k, i, 1.0);
    if (!done && !rm->opts->no_insert) {
      /* collapse the shortest edge if the ball gets better */
      const pa_idx *v = rm->ev + 3 * (size_t)k;
      int best = 0;
      double lb = 1e300;
      for (int i = 0; i < 3; i++) {
        double l = edge_len(rm, v[NX3(i)], v[PV3(i)]);
        if (l < lb) {
          lb = l;
          best = i;
        }
      }
      if (lb < RM_LLONG) {
        double g = rm->lguard;
        rm->lguard = RM_LLONG * 1.2;
        done = collapse_edge(rm, k, best, NX3(best), 1.0 + 1e-9) ||
               collapse_edge(rm, k, best, PV3(best), 1.0 + 1e-9);
        rm->lguard = g;
      }
    }
    cnt += done;
  }
  return cnt;
}

const pa__rm_ops pa__rm_ops_2d = {
    pa__rm_split_pass_2d,  pa__rm_collapse_pass_2d, pa__rm_swap_pass_2d,
    pa__rm_smooth_pass_2d, pa__rm_length_pass_2d,   pa__rm_sliver_pass_2d,
    pa__rm_figures_2d,     pa__rm_reorder};
