/*
 * swap_3d.c -- topological swaps: edge removal (3-2 for a shell of three,
 * n -> 2n-4 for closed shells of up to 7 tets, choosing the triangulation of
 * the ring that maximises the worst quality by dynamic programming, as in
 * Shewchuk's "Two discrete optimization algorithms for the topological
 * improvement of tetrahedral meshes") and the 2-3 face swap.
 *
 * Boundary edge swap (surface mode): for a boundary edge (a,b) with an open
 * shell, the two surface triangles (a,b,c), (a,b,d) become (a,c,d), (b,d,c)
 * and the shell's ring polygon c..d is triangulated by the same dynamic
 * programming (edge cd as its base). Only where the surface is kept: ab is
 * no feature edge, both triangles free with one reference and flags, and
 * coplanar (normals equal to 1e-12, so planar patches stay exactly planar)
 * or, on a curved patch, the distance between the diagonals ab and cd is at
 * most hausd; the new triangles face the way the old ones do (normals
 * within RM3D_NORMAL_COS of their mean); cd must not be an edge yet. A
 * boundary edge held by one tet only (a cap) has no ring: that tet is
 * removed instead (remove_cap).
 *
 * Checked before applied: no frozen tet, one reference; interior swaps need
 * a closed shell with no boundary triangle around the edge; the new worst
 * quality exceeds gain times the old one (gain >= 1), so a swap never lowers
 * the worst quality.
 */
#include "remesh3d/remesh3d.h"

#define R3_SWAP_MAXRING 7
#define R3_SWAP_MAXPOLY (R3_SWAP_MAXRING + 1)

/* The qualities of the two tets over the ring triangles (i < j < l) of
 * ring_dp, each computed when first needed. */
typedef struct ring_q {
  const rm3d *m;
  pa_idx a, b;
  const pa_idx *ring;
  double target;
  float tq[R3_SWAP_MAXPOLY][R3_SWAP_MAXPOLY][R3_SWAP_MAXPOLY];
  uint8_t known[R3_SWAP_MAXPOLY][R3_SWAP_MAXPOLY]; /* bit l: tq[i][j][l] */
} ring_q;

static float ring_tri(ring_q *r, int i, int j, int l) {
  if (r->known[i][j] & (1u << l)) return r->tq[i][j][l];
  const rm3d *m = r->m;
  int mc = m->mc;
  const pa_idx *ring = r->ring;
  const double *xi = m->x + 3 * (size_t)ring[i];
  const double *xj = m->x + 3 * (size_t)ring[j];
  const double *xl = m->x + 3 * (size_t)ring[l];
  const double *mi = m->met + (size_t)mc * ring[i];
  const double *mj = m->met + (size_t)mc * ring[j];
  const double *ml = m->met + (size_t)mc * ring[l];
  const double *xa = m->x + 3 * (size_t)r->a, *xb = m->x + 3 * (size_t)r->b;
  double q1, q2;
  if (mc <= 1) { /* the same bits as pa__qual3, no metric passed */
    q1 = pa__qual3_iso(xi, xj, xl, xb);
    q2 = q1 > r->target ? pa__qual3_iso(xi, xl, xj, xa) : q1;
  } else {
    q1 = pa__qual3(mc, xi, xj, xl, xb, mi, mj, ml, m->met + (size_t)mc * r->b);
    q2 = q1 > r->target ? pa__qual3(mc, xi, xl, xj, xa, mi, ml, mj,
                                    m->met + (size_t)mc * r->a)
                        : q1;
  }
  r->known[i][j] |= (uint8_t)(1u << l);
  return r->tq[i][j][l] = (float)(q1 < q2 ? q1 : q2);
}

/* 0 when some side (i, i+1) of the polygon ring[0..nr), or its base
 * (0, nr-1), lies on no triangle better than the target: every
 * triangulation holds one such triangle then, and the swap fails. */
static int ring_feasible(ring_q *r, int nr) {
  for (int s = 0; s < nr; s++) {
    int i = s < nr - 1 ? s : 0, j = s < nr - 1 ? s + 1 : nr - 1, ok = 0;
    for (int l = 0; l < nr && !ok; l++) {
      if (l == i || l == j) continue;
      int t0 = l < i ? l : i, t2 = l > j ? l : j, t1 = i + j + l - t0 - t2;
      ok = ring_tri(r, t0, t1, t2) > r->target;
    }
    if (!ok) return 0;
  }
  return 1;
}

/* Best triangulation of the polygon ring[0..nr) (base edge ring[0] ring[nr-1])
 * for the edge (a,b): each triangle (i,l,j) gives the tets (r_i, r_l, r_j, b)
 * and (r_i, r_j, r_l, a). Maximises the worst quality by dynamic programming
 * over sub-polygons. Returns the worst quality reached (-1 when none beats
 * target) and the new tets in nv4[0..4 * *nnew). */
static double ring_dp(const rm3d *m, pa_idx a, pa_idx b, const pa_idx *ring,
                      int nr, double target, pa_idx *nv4, int *nnew) {
  ring_q r;
  r.m = m;
  r.a = a;
  r.b = b;
  r.ring = ring;
  r.target = target;
  memset(r.known, 0, sizeof r.known);
  float best[R3_SWAP_MAXPOLY][R3_SWAP_MAXPOLY];
  signed char arg[R3_SWAP_MAXPOLY][R3_SWAP_MAXPOLY];
  if (!ring_feasible(&r, nr)) return -1;
  /* best[i][j]: best worst quality triangulating ring[i..j] (j - i >= 2). */
  for (int len = 2; len < nr; len++)
    for (int i = 0; i + len < nr; i++) {
      int j = i + len;
      float bq = -1;
      signed char bk = -1;
      for (int l = i + 1; l < j; l++) {
        /* the sub-polygons bound v: no better than bq, no need of tq */
        float v = 2;
        if (l - i >= 2 && best[i][l] < v) v = best[i][l];
        if (j - l >= 2 && best[l][j] < v) v = best[l][j];
        if (!(v > bq)) continue;
        float t = ring_tri(&r, i, l, j);
        if (t < v) v = t;
        if (v > bq) {
          bq = v;
          bk = (signed char)l;
        }
      }
      best[i][j] = bq;
      arg[i][j] = bk;
    }
  double bw = best[0][nr - 1];
  if (!(bw > target) || bw < m->qabs) return -1;
  int n = 0;
  int stack[2 * R3_SWAP_MAXPOLY], sp = 0;
  stack[sp++] = 0;
  stack[sp++] = nr - 1;
  while (sp) {
    int j = stack[--sp], i = stack[--sp];
    if (j - i < 2) continue;
    int l = arg[i][j];
    pa_idx *t1 = nv4 + 4 * n++, *t2 = nv4 + 4 * n++;
    t1[0] = ring[i];
    t1[1] = ring[l];
    t1[2] = ring[j];
    t1[3] = b;
    t2[0] = ring[i];
    t2[1] = ring[j];
    t2[2] = ring[l];
    t2[3] = a;
    stack[sp++] = i;
    stack[sp++] = l;
    stack[sp++] = l;
    stack[sp++] = j;
  }
  *nnew = n;
  return bw;
}

/* Is d a neighbour of c (an edge (c,d) exists)? */
static int has_edge(rm3d *m, pa_idx c, pa_idx d) {
  pa_idx ball[RM3D_MAXBALL];
  int n = pa__rm3d_ball(m, c, ball, RM3D_MAXBALL);
  if (n < 0) return 1;
  for (int i = 0; i < n; i++)
    if (rm3d_loc(m->tv + 4 * (size_t)(ball[i] >> 2), d) >= 0) return 1;
  return 0;
}

/* The diagonals ab and cd of a curved quad stay within hausd of each
 * other: their distance (the volume of a, b, c, d over |ab x cd|) is at
 * most hausd. 0 also for parallel diagonals. */
static int diagonals_close(const double *xa, const double *xb,
                           const double *xc, const double *xd, double hausd) {
  double u[3] = {xb[0] - xa[0], xb[1] - xa[1], xb[2] - xa[2]};
  double w[3] = {xd[0] - xc[0], xd[1] - xc[1], xd[2] - xc[2]};
  double z[3] = {xc[0] - xa[0], xc[1] - xa[1], xc[2] - xa[2]};
  double cr[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2],
                  u[0] * w[1] - u[1] * w[0]};
  double lc = sqrt(cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]);
  double vol = fabs(cr[0] * z[0] + cr[1] * z[1] + cr[2] * z[2]);
  return lc > 0 && vol <= hausd * lc;
}

/* The boundary triangles (a,b,c) and (a,b,d) of the surface edge ab, as
 * records *r1 and *r2; *pair 1 when a swap may replace them: ab is no
 * feature edge and they are free, with one reference and the same flags. */
static pa_status surface_pair(const rm3d *m, pa_idx a, pa_idx b, pa_idx c,
                              pa_idx d, const char *what, pa_idx *r1,
                              pa_idx *r2, int *pair) {
  pa_idx ek[2] = {a, b}, k1[3] = {a, b, c}, k2[3] = {a, b, d};
  *pair = 0;
  if (pa__rm3d_table_find(&m->edg, ek) >= 0) return PA_SUCCESS;
  *r1 = pa__rm3d_table_find(&m->tri, k1);
  *r2 = pa__rm3d_table_find(&m->tri, k2);
  if (*r1 < 0 || *r2 < 0)
    return pa__error(PA_ERR_INTERNAL, __FILE__, __LINE__,
                     "rm3d: boundary face of a %s not in the table", what);
  *pair = !((m->tri.flag[*r1] | m->tri.flag[*r2]) & PA_FLAG_REQUIRED) &&
          m->tri.ref[*r1] == m->tri.ref[*r2] &&
          m->tri.flag[*r1] == m->tri.flag[*r2];
  return PA_SUCCESS;
}

/* Remove the cap t = (a,b,c,d): a tet whose two boundary triangles (a,b,c)
 * and (a,b,d) meet at its edge ab, held by no other tet (an open shell of
 * one, where swap_bdry has no ring to retriangulate). Its faces (a,c,d) and
 * (b,d,c) become the boundary. With the checks of a boundary swap on a
 * curved patch (ab no feature edge, both triangles free with one reference
 * and flags, normals within RM3D_NORMAL_COS or the new pair closer to each
 * other than the old (a kink the removal smooths), the diagonals within hausd,
 * the new triangles within RM3D_NORMAL_COS of the old pair's mean; the two
 * triangles of a cap are never coplanar, so a vertex without a normal is
 * allowed), when cd lies on no boundary triangle yet and the two tets
 * behind the new triangles are free. The worst quality can only rise. */
static pa_status remove_cap(rm3d *m, pa_idx a, pa_idx b, pa_idx t,
                            pa_idx c, pa_idx d, int *done) {
  pa_status st = PA_SUCCESS;
  const pa_idx *v = m->tv + 4 * (size_t)t;
  int la = rm3d_loc(v, a), lb = rm3d_loc(v, b), lc = rm3d_loc(v, c),
      ld = rm3d_loc(v, d);
  if (la < 0 || lb < 0 || lc < 0 || ld < 0) return st;
  uint8_t fl = m->tflag[t];
  if (!((fl >> lc) & 1) || !((fl >> ld) & 1) || ((fl >> la) & 1) ||
      ((fl >> lb) & 1))
    return st;
  pa_idx o1 = m->adj[4 * (size_t)t + lb], o2 = m->adj[4 * (size_t)t + la];
  if (o1 < 0 || o2 < 0 || (o1 >> 2) == (o2 >> 2)) return st;
  if ((m->tflag[o1 >> 2] | m->tflag[o2 >> 2]) & RM3D_T_FROZEN) return st;
  if (m->tref[o1 >> 2] != m->tref[t] || m->tref[o2 >> 2] != m->tref[t])
    return st;
  pa_idx r1, r2;
  int pair = 0;
  st = surface_pair(m, a, b, c, d, "cap", &r1, &r2, &pair);
  if (st || !pair) return st;
  /* cd on no boundary triangle: its shell is closed, with none */
  {
    pa_idx tets[R3_SWAP_MAXRING + 1], ring[R3_SWAP_MAXRING + 2];
    int info;
    int n = pa__rm3d_shell(m, t, c, d, tets, ring, NULL, R3_SWAP_MAXRING + 1,
                           &info);
    if (n < 0 || !(info & RM3D_SH_CLOSED) || (info & RM3D_SH_BDRY)) return st;
  }
  /* Outward normals: old faces (a,b,c), (a,b,d) of t; new faces seen from
   * the tets behind them, i.e. t's faces opposite b and a turned over. */
  double n1[3], n2[3], nt1[3], nt2[3];
  const double *x[4];
  for (int j = 0; j < 4; j++) x[j] = m->x + 3 * (size_t)v[j];
  rm3d_tri_normal(x[pa__rm3d_face[ld][0]], x[pa__rm3d_face[ld][1]],
                  x[pa__rm3d_face[ld][2]], n1);
  rm3d_tri_normal(x[pa__rm3d_face[lc][0]], x[pa__rm3d_face[lc][1]],
                  x[pa__rm3d_face[lc][2]], n2);
  if (!(rm3d_tri_normal(x[pa__rm3d_face[lb][0]], x[pa__rm3d_face[lb][2]],
                        x[pa__rm3d_face[lb][1]], nt1) > 0) ||
      !(rm3d_tri_normal(x[pa__rm3d_face[la][0]], x[pa__rm3d_face[la][2]],
                        x[pa__rm3d_face[la][1]], nt2) > 0))
    return st;
  /* the old pair within RM3D_NORMAL_COS, or a kink the new pair smooths */
  double dold = n1[0] * n2[0] + n1[1] * n2[1] + n1[2] * n2[2];
  double dnew = nt1[0] * nt2[0] + nt1[1] * nt2[1] + nt1[2] * nt2[2];
  if (dold < RM3D_NORMAL_COS && !(dnew > dold)) return st;
  const double *xa = m->x + 3 * (size_t)a, *xb = m->x + 3 * (size_t)b,
               *xc = m->x + 3 * (size_t)c, *xd = m->x + 3 * (size_t)d;
  if (!diagonals_close(xa, xb, xc, xd, rm3d_tri_hausd(m, r1))) return st;
  double no[3] = {n1[0] + n2[0], n1[1] + n2[1], n1[2] + n2[2]};
  rm3d_unit(no);
  if (nt1[0] * no[0] + nt1[1] * no[1] + nt1[2] * no[2] < RM3D_NORMAL_COS ||
      nt2[0] * no[0] + nt2[1] * no[1] + nt2[2] * no[2] < RM3D_NORMAL_COS)
    return st;
  /* Orientation of the records: keep the old convention (outward or not). */
  const pa_idx *ov = m->tri.v + 3 * (size_t)r1;
  double on[3];
  rm3d_tri_normal(m->x + 3 * (size_t)ov[0], m->x + 3 * (size_t)ov[1],
                  m->x + 3 * (size_t)ov[2], on);
  int outward = on[0] * n1[0] + on[1] * n1[1] + on[2] * n1[2] > 0;
  int32_t ref = m->tri.ref[r1];
  uint8_t tfl = m->tri.flag[r1];
  pa_idx t1[3] = {a, c, d}, t2[3] = {b, d, c};
  {
    /* the records' vertex order: outward like nt1 / nt2, or reversed */
    double q1[3];
    rm3d_tri_normal(xa, xc, xd, q1);
    if ((q1[0] * nt1[0] + q1[1] * nt1[1] + q1[2] * nt1[2] > 0) != outward) {
      t1[1] = d;
      t1[2] = c;
      t2[1] = c;
      t2[2] = d;
    }
  }
  pa__rm3d_table_remove(&m->tri, r1);
  pa__rm3d_table_remove(&m->tri, r2);
  PA_CALL(pa__rm3d_table_add(&m->tri, t1, ref, tfl, NULL));
  PA_CALL(pa__rm3d_table_add(&m->tri, t2, ref, tfl, NULL));
  m->adj[o1] = -1;
  m->adj[o2] = -1;
  m->tflag[o1 >> 2] |= (uint8_t)(1u << (o1 & 3));
  m->tflag[o2 >> 2] |= (uint8_t)(1u << (o2 & 3));
  pa_idx keep[4] = {a, b, c, d};
  for (int j = 0; j < 4; j++)
    if (m->vtet[keep[j]] == t) m->vtet[keep[j]] = j == 1 ? o2 >> 2 : o1 >> 2;
  pa_idx changed[3] = {t, o1 >> 2, o2 >> 2};
  for (int j = 0; j < 3; j++)
    if (changed[j] < m->nswapfail) m->swapfail[changed[j]] = 0;
  m->tflag[t] = RM3D_T_DEAD;
  m->ndead_t++;
  m->nswap++;
  *done = 1;
cleanup:
  return st;
}

/* Boundary edge (a,b) with the open shell tets[0..n), ring[0..n]: the two
 * surface triangles (a,b,c = ring[0]) and (a,b,d = ring[n]) become (a,c,d)
 * and (b,c,d). Allowed when ab is no feature edge, both triangles are free,
 * have one reference and lie in one plane (or, on a curved patch, the new
 * diagonal is within hausd of the old one), and cd is no edge yet. */
static pa_status swap_bdry(rm3d *m, pa_idx a, pa_idx b, const pa_idx *tets,
                           const pa_idx *ring, int n, double qold,
                           double gain, int *done) {
  pa_status st = PA_SUCCESS;
  pa_idx nv4[4 * 2 * (R3_SWAP_MAXPOLY - 2)];
  int nnew = 0;
  if (!m->surf) return st;
  if (n == 1) return remove_cap(m, a, b, tets[0], ring[0], ring[1], done);
  if (n < 2) return st;
  pa_idx c = ring[0], d = ring[n];
  if (c == d) return st;
  /* The faces crossed inside the shell are no boundary triangles; the two
   * end faces are. */
  for (int i = 0; i + 1 < n; i++) {
    const pa_idx *v = m->tv + 4 * (size_t)tets[i];
    int f = pa__rm3d_compl[rm3d_loc(v, a)][rm3d_loc(v, b)][0];
    if ((m->tflag[tets[i]] >> f) & 1) return st;
  }
  pa_idx r1, r2;
  int pair = 0;
  st = surface_pair(m, a, b, c, d, "shell", &r1, &r2, &pair);
  if (st || !pair) return st;
  const double *xa = m->x + 3 * (size_t)a, *xb = m->x + 3 * (size_t)b,
               *xc = m->x + 3 * (size_t)c, *xd = m->x + 3 * (size_t)d;
  /* Outward normals of the old faces (the shell's end faces). */
  double n1[3], n2[3];
  {
    const pa_idx *v = m->tv + 4 * (size_t)tets[0];
    int f = pa__rm3d_compl[rm3d_loc(v, a)][rm3d_loc(v, b)][1];
    rm3d_tri_normal(m->x + 3 * (size_t)v[pa__rm3d_face[f][0]],
                    m->x + 3 * (size_t)v[pa__rm3d_face[f][1]],
                    m->x + 3 * (size_t)v[pa__rm3d_face[f][2]], n1);
    v = m->tv + 4 * (size_t)tets[n - 1];
    f = pa__rm3d_compl[rm3d_loc(v, a)][rm3d_loc(v, b)][0];
    rm3d_tri_normal(m->x + 3 * (size_t)v[pa__rm3d_face[f][0]],
                    m->x + 3 * (size_t)v[pa__rm3d_face[f][1]],
                    m->x + 3 * (size_t)v[pa__rm3d_face[f][2]], n2);
  }
  double nt1[3], nt2[3];
  if (!(rm3d_tri_normal(xa, xc, xd, nt1) > 0) ||
      !(rm3d_tri_normal(xb, xd, xc, nt2) > 0))
    return st;
  double dot = n1[0] * n2[0] + n1[1] * n2[1] + n1[2] * n2[2];
  if (dot < 1.0 - 1e-12) {
    /* Curved patch: the diagonals cd and ab stay within hausd. */
    if (!(m->vtag[a] & m->vtag[b] & m->vtag[c] & m->vtag[d] & RM3D_V_CURVED) ||
        dot < RM3D_NORMAL_COS)
      return st;
    if (!diagonals_close(xa, xb, xc, xd, rm3d_tri_hausd(m, r1))) return st;
  }
  /* New faces (a,c,d) / (b,d,c) must face outwards like the old ones and
   * stay within RM3D_NORMAL_COS of their mean normal: on a curved patch a
   * quad abcd that is nearly not convex passes the hausd test, and its swap
   * stood a triangle across the surface (at 84 degrees to the old ones, the
   * gmsh rod in a piece of the parallel loop). */
  double no[3] = {n1[0] + n2[0], n1[1] + n2[1], n1[2] + n2[2]};
  rm3d_unit(no);
  if (nt1[0] * no[0] + nt1[1] * no[1] + nt1[2] * no[2] < RM3D_NORMAL_COS ||
      nt2[0] * no[0] + nt2[1] * no[1] + nt2[2] * no[2] < RM3D_NORMAL_COS)
    return st;
  if (ring_dp(m, a, b, ring, n + 1, gain * qold, nv4, &nnew) < 0) return st;
  if (has_edge(m, c, d)) return st;
  /* Orientation of the records: keep the old convention (outward or not). */
  const pa_idx *ov = m->tri.v + 3 * (size_t)r1;
  double on[3];
  rm3d_tri_normal(m->x + 3 * (size_t)ov[0], m->x + 3 * (size_t)ov[1],
                  m->x + 3 * (size_t)ov[2], on);
  int outward = on[0] * n1[0] + on[1] * n1[1] + on[2] * n1[2] > 0;
  int32_t ref = m->tri.ref[r1];
  uint8_t fl = m->tri.flag[r1];
  PA_CALL(pa__rm3d_replace(m, tets, n, nv4, nnew, m->tref[tets[0]],
                           m->tpf[tets[0]], 2));
  pa__rm3d_table_remove(&m->tri, r1);
  pa__rm3d_table_remove(&m->tri, r2);
  pa_idx t1[3] = {a, c, d}, t2[3] = {b, d, c};
  if (!outward) {
    t1[1] = d;
    t1[2] = c;
    t2[1] = c;
    t2[2] = d;
  }
  PA_CALL(pa__rm3d_table_add(&m->tri, t1, ref, fl, NULL));
  PA_CALL(pa__rm3d_table_add(&m->tri, t2, ref, fl, NULL));
  m->nswap++;
  *done = 1;
cleanup:
  return st;
}

/* The swap pass's memory of failed edge removals (m->swapfail): 1 when
 * every tet of the closed shell tets[0..n) of an edge has the bit of the
 * edge (its local index edge[i] in tets[i]; mark = 0), or sets that bit
 * on each (mark = 1). A tet keeps the bit
 * until it changes, so when every tet of the shell has it the shell is the
 * one that failed, unchanged (a tet changed or added since would lack it),
 * and nothing else the removal reads changes during a swap pass. */
static int shell_failed(rm3d *m, const pa_idx *tets, const signed char *edge,
                        int n, int mark) {
  for (int i = 0; i < n; i++) {
    pa_idx t = tets[i];
    if (t >= m->nswapfail) return 0;
    uint8_t bit = (uint8_t)(1u << edge[i]);
    if (mark)
      m->swapfail[t] |= bit;
    else if (!(m->swapfail[t] & bit))
      return 0;
  }
  return 1;
}

pa_status pa__rm3d_swap_edge(rm3d *m, pa_idx k, pa_idx a, pa_idx b,
                             double gain, int *done) {
  pa_status st = PA_SUCCESS;
  pa_idx tets[R3_SWAP_MAXRING], ring[R3_SWAP_MAXRING + 1];
  signed char edge[R3_SWAP_MAXRING];
  pa_idx nv4[4 * 2 * (R3_SWAP_MAXPOLY - 2)];
  int nnew = 0;
  *done = 0;
  int info;
  int n = pa__rm3d_shell(m, k, a, b, tets, ring, edge, R3_SWAP_MAXRING, &info);
  if (n < 1 || (info & (RM3D_SH_FROZEN | RM3D_SH_REFS))) return st;
  double qold = 1e30;
  for (int i = 0; i < n; i++)
    if (m->q[tets[i]] < qold) qold = m->q[tets[i]];
  if (!(info & RM3D_SH_CLOSED))
    return gain < 1.0 ? st
                      : swap_bdry(m, a, b, tets, ring, n, qold, gain, done);
  if (n < 3 || (info & RM3D_SH_BDRY)) return st;
  int memo = m->swapfail != NULL;
  if (memo && shell_failed(m, tets, edge, n, 0)) return st;
  double bw = ring_dp(m, a, b, ring, n, gain * qold, nv4, &nnew);
  if (bw < 0) {
    if (memo) shell_failed(m, tets, edge, n, 1);
    return st;
  }
  if (gain < 1.0) {
    /* Removal of a short edge: the quality floor, and no new edge longer
     * than sqrt 2. */
    if (!rm3d_q_ok(m, bw, qold)) return st;
    for (int i = 0; i < nnew; i++) {
      const pa_idx *t = nv4 + 4 * i;
      for (int e = 0; e < 3; e++) {
        double l = rm3d_len(m, t[e], t[(e + 1) % 3]);
        if (l > PA_METRIC_LEN_HI_EXACT) return st;
      }
    }
  }
  PA_CALL(pa__rm3d_replace(m, tets, n, nv4, nnew, m->tref[tets[0]],
                           m->tpf[tets[0]], 0));
  m->nswap++;
  *done = 1;
cleanup:
  return st;
}

pa_status pa__rm3d_swap_face(rm3d *m, pa_idx k, int f, double gain,
                             int *done) {
  pa_status st = PA_SUCCESS;
  *done = 0;
  pa_idx o = m->adj[4 * (size_t)k + f];
  if (o < 0 || ((m->tflag[k] >> f) & 1)) return st;
  pa_idx l = o >> 2;
  if ((m->tflag[k] | m->tflag[l]) & RM3D_T_FROZEN) return st;
  if (m->tref[k] != m->tref[l]) return st;
  const pa_idx *vk = m->tv + 4 * (size_t)k;
  pa_idx d = vk[f], e = m->tv[4 * (size_t)l + (o & 3)];
  pa_idx fv[3] = {vk[pa__rm3d_face[f][0]], vk[pa__rm3d_face[f][1]],
                  vk[pa__rm3d_face[f][2]]};
  double qold = m->q[k] < m->q[l] ? m->q[k] : m->q[l];
  double target = gain * qold;
  pa_idx nv4[12];
  for (int i = 0; i < 3; i++) {
    pa_idx *t = nv4 + 4 * i;
    t[0] = fv[i];
    t[1] = fv[(i + 1) % 3];
    t[2] = d;
    t[3] = e;
    double q = rm3d_qual_v(m, t);
    if (!(q > target) || q < m->qabs) return st;
  }
  pa_idx old[2] = {k, l};
  PA_CALL(pa__rm3d_replace(m, old, 2, nv4, 3, m->tref[k], m->tpf[k], 0));
  m->nswap++;
  *done = 1;
cleanup:
  return st;
}
