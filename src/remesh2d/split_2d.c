/*
 * split_2d.c -- edge split of the 2D remesher: the new vertex at
 * the midpoint of the edge, or of the reconstructed curve on a feature
 * (boundary_2d.c) or, with a model (pa_remesh_opts.geometry), the curve's
 * point closest to it, the one or two elements on the edge cut in two. Its
 * pass is in driver_2d.c. Shared contract of the operators: ops_2d.h.
 */
#include "remesh2d/ops_2d.h"

/* An edge to split: face i of element k (vertex p0 opposite, ends a and b),
 * the element f across it (face j, vertex p1 opposite) or -1, and the
 * feature record feat on it or -1. */
typedef struct split_cfg {
  pa_idx k, f, feat, p0, a, b, p1;
  int i, i1, i2, j, j1, j2;
} split_cfg;

/* The configuration of face i of element k. */
static void edge_config(const rm2d *rm, pa_idx k, int i, split_cfg *s) {
  pa_idx te = 3 * k + i;
  pa_idx o = rm->adj[te];
  pa_idx fcode = o >= 0 ? o : rm2d_other_side(rm, te);
  s->k = k;
  s->i = i;
  s->i1 = RM2D_NX3(i);
  s->i2 = RM2D_PV3(i);
  s->p0 = rm->tv[3 * k + i];
  s->a = rm->tv[3 * k + s->i1];
  s->b = rm->tv[3 * k + s->i2];
  s->feat = o < 0 ? -o - 1 : -1;
  s->f = -1;
  s->p1 = -1;
  s->j = s->j1 = s->j2 = 0;
  if (fcode >= 0) {
    s->f = fcode / 3;
    s->j = fcode % 3;
    s->j1 = RM2D_NX3(s->j);
    s->j2 = RM2D_PV3(s->j);
    s->p1 = rm->tv[3 * s->f + s->j];
  }
}

/* The new vertex at the midpoint of the edge (on a feature, of the
 * reconstructed curve, with its tangent in tm), its fields interpolated;
 * room reserved by the caller. */
static pa_idx new_midpoint(rm2d *rm, const split_cfg *s, double *tm) {
  pa_idx m, a = s->a, b = s->b;
  pa__rm2d_new_vertex(rm, &m); /* cannot fail after the reserve */
  double *xm = rm->x + 2 * (size_t)m;
  if (s->feat >= 0) {
    pa__rm2d_curve_point(rm, s->feat, 0.5, xm, tm);
    /* on a model's curve: its point (else the reconstruction's) */
    double ch = hypot(RM2D_X(b)[0] - RM2D_X(a)[0], RM2D_X(b)[1] - RM2D_X(a)[1]);
    pa__remesh_project(rm->opts, 1, rm->bref[s->feat], 2, xm, ch, xm);
  } else {
    xm[0] = 0.5 * (RM2D_X(a)[0] + RM2D_X(b)[0]);
    xm[1] = 0.5 * (RM2D_X(a)[1] + RM2D_X(b)[1]);
  }
  pa_idx src[2] = {a, b};
  double w[2] = {0.5, 0.5};
  pa__rm2d_interp(rm, m, 2, src, w);
  return m;
}

/* The qualities q of the four halves (1 where there is no f), and whether
 * all pass the quality floor (rm2d_qfloor of the worst of k and f). */
static int halves_ok(rm2d *rm, const split_cfg *s, pa_idx m, double *q) {
  double qold = rm->q[s->k];
  if (s->f >= 0 && rm->q[s->f] < qold) qold = rm->q[s->f];
  double fl = rm2d_qfloor(qold);
  q[0] = rm2d_elem_qual(rm, s->p0, s->a, m);
  q[1] = rm2d_elem_qual(rm, s->p0, m, s->b);
  q[2] = 1;
  q[3] = 1;
  if (!rm2d_qual_ok(rm, q[0], fl, s->p0, s->a, m) ||
      !rm2d_qual_ok(rm, q[1], fl, s->p0, m, s->b))
    return 0;
  if (s->f < 0) return 1;
  q[2] = rm2d_elem_qual(rm, s->p1, s->b, m);
  q[3] = rm2d_elem_qual(rm, s->p1, m, s->a);
  return rm2d_qual_ok(rm, q[2], fl, s->p1, s->b, m) &&
         rm2d_qual_ok(rm, q[3], fl, s->p1, m, s->a);
}

/* Cut k, and f if any, in two at m: T1 = k (p0 a m), T2 = *k2 (p0 m b),
 * T3 = f (p1 b m), T4 = *f2 (p1 m a), with the adjacency of all but the
 * faces on the split edge (faces 0). */
static void cut_elements(rm2d *rm, const split_cfg *s, pa_idx m,
                         const double *q, pa_idx *k2p, pa_idx *f2p) {
  pa_idx k = s->k, f = s->f;
  pa_idx oA = rm->adj[3 * k + s->i1], oB = rm->adj[3 * k + s->i2];
  pa_idx fA = -1, fB = -1;
  if (f >= 0) {
    fB = rm->adj[3 * f + s->j1];
    fA = rm->adj[3 * f + s->j2];
  }
  pa_idx k2, f2 = -1;
  rm2d_elem_changed(rm, k);
  if (f >= 0) rm2d_elem_changed(rm, f);
  pa__rm2d_new_elem(rm, &k2);
  rm->tref[k2] = rm->tref[k];
  rm->tflag[k2] = rm->tflag[k] & 0x0F;
  if (f >= 0) {
    pa__rm2d_new_elem(rm, &f2);
    rm->tref[f2] = rm->tref[f];
    rm->tflag[f2] = rm->tflag[f] & 0x0F;
  }
  rm2d_set_elem(rm, k, s->p0, s->a, m, q[0]);
  rm2d_set_elem(rm, k2, s->p0, m, s->b, q[1]);
  rm2d_attach(rm, 3 * k + 2, oB, 3 * k + s->i2);
  rm2d_attach(rm, 3 * k2 + 1, oA, 3 * k + s->i1);
  rm->adj[3 * k + 1] = 3 * k2 + 2;
  rm->adj[3 * k2 + 2] = 3 * k + 1;
  if (f >= 0) {
    rm2d_set_elem(rm, f, s->p1, s->b, m, q[2]);
    rm2d_set_elem(rm, f2, s->p1, m, s->a, q[3]);
    rm2d_attach(rm, 3 * f + 2, fA, 3 * f + s->j2);
    rm2d_attach(rm, 3 * f2 + 1, fB, 3 * f + s->j1);
    rm->adj[3 * f + 1] = 3 * f2 + 2;
    rm->adj[3 * f2 + 2] = 3 * f + 1;
  }
  *k2p = k2;
  *f2p = f2;
}

/* Split the feature record (u, w) on the edge into (u, m) and a new (m, w),
 * each held by the halves on its side; m becomes a feature vertex. */
static void split_feature(rm2d *rm, const split_cfg *s, pa_idx m,
                          const double *tm, pa_idx k2, pa_idx f2) {
  pa_idx k = s->k, f = s->f, feat = s->feat, nb2;
  pa__rm2d_new_feat(rm, &nb2);
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
  pa_idx ram = u == s->a ? feat : nb2, rmb = u == s->a ? nb2 : feat;
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
  rm->vtag[m] |= RM2D_V_FEAT;
  rm->vref[m] = rm->bref[feat];
}

/* A long curved feature edge under a thin element (next to a frozen
 * vertex: a piece's skin refined down to the boundary, in the parallel
 * loop): the curve's midpoint, off the chord by the sagitta, may turn a
 * half over, and nothing moves the frozen vertex away, so the edge stayed
 * as long as it was (plate2d.mesh -hsiz 0.0005 at 2 ranks: a boundary
 * edge of length 95 beside a skin refined to 0.8 on the hole). Then m
 * comes back towards the chord's midpoint, which turns no half over:
 * halfway, then onto it; the halves are split on their own curves later.
 * Returns 1 with m placed and q set when a position passes. */
static int split_toward_chord(rm2d *rm, const split_cfg *s, pa_idx m,
                              double *q) {
  if (s->feat < 0) return 0;
  double *xm = rm->x + 2 * (size_t)m;
  double c[2] = {0.5 * (RM2D_X(s->a)[0] + RM2D_X(s->b)[0]),
                 0.5 * (RM2D_X(s->a)[1] + RM2D_X(s->b)[1])};
  double d[2] = {xm[0] - c[0], xm[1] - c[1]};
  for (double w = 0.5; w >= 0; w -= 0.5) {
    xm[0] = c[0] + w * d[0];
    xm[1] = c[1] + w * d[1];
    if (halves_ok(rm, s, m, q)) return 1;
  }
  return 0;
}

/* The step still to make from the new vertex m of a split of feature edge
 * (a, b) onto the curve (rm2d.vcur): the mean of the ends' (the curve
 * through them once they have made theirs passes about so much further
 * out at its midpoint), plus what a fall back toward the chord
 * (split_toward_chord) left of the way to the curve point xc. */
static void curve_rest(rm2d *rm, const split_cfg *s, pa_idx m,
                       const double *xc) {
  const double *da = rm->vcur + 2 * (size_t)s->a,
               *db = rm->vcur + 2 * (size_t)s->b;
  double *dm = rm->vcur + 2 * (size_t)m;
  for (int j = 0; j < 2; j++)
    dm[j] = 0.5 * (da[j] + db[j]) + (xc[j] - RM2D_X(m)[j]);
}

/*
 * Split face i of element k at its midpoint (on a feature: the midpoint of
 * the reconstructed curve, or nearer the chord: split_toward_chord).
 * Returns 1 if done, 0 if rejected; *st on memory failure (then nothing
 * changed).
 */
int pa__rm2d_split_edge(rm2d *rm, pa_idx k, int i, pa_status *st) {
  split_cfg s;
  edge_config(rm, k, i, &s);
  *st = pa__rm2d_reserve(rm, 1, 2, 1);
  if (*st) return 0;
  double tm[2] = {0, 0}, q[4];
  pa_idx m = new_midpoint(rm, &s, tm);
  double xc[2] = {RM2D_X(m)[0], RM2D_X(m)[1]}; /* the curve's point */
  if (!halves_ok(rm, &s, m, q) && !split_toward_chord(rm, &s, m, q)) {
    pa__rm2d_kill_vertex(rm, m);
    return 0;
  }
  if (rm->vcur && s.feat >= 0) curve_rest(rm, &s, m, xc);
  pa_idx k2, f2;
  cut_elements(rm, &s, m, q, &k2, &f2);
  if (s.feat < 0) { /* an interior edge: join the halves across it */
    rm->adj[3 * k] = 3 * f2;
    rm->adj[3 * f2] = 3 * k;
    rm->adj[3 * k2] = 3 * s.f;
    rm->adj[3 * s.f] = 3 * k2;
  } else {
    split_feature(rm, &s, m, tm, k2, f2);
  }
  rm->nsplit++;
  return 1;
}
