/*
 * collapse_3d.c -- edge collapse p -> q: vertex p disappears, the tets
 * holding the edge (p,q) are deleted, the others of p's ball take q.
 *
 * Checked before applied: p is free (not locked, not a corner, not on a
 * frozen entity -- so no edge of a frozen tet is touched); the ball has one
 * reference, or the faces between its references are all boundary
 * triangles (an interface: p lies on it and moves along it); every modified tet keeps quality >= max(RM3D_QFLOOR, qratio *
 * old worst of the ball); no new edge longer than lguard. A boundary p (only
 * in surface mode) moves onto q along a boundary edge: a ridge vertex along
 * its ridge only (exactly two feature edges), its triangles keep their
 * references, no triangle is duplicated, no tet is left with two boundary
 * faces glued, and the new surface stays within hausd of p (exactly planar
 * on planar patches, since no point moves). For an interior p, positive
 * volumes of the new tets imply that they tile p's old ball.
 *
 * Midpoint collapse (pa__rm3d_collapse_mid): q first moves to the middle of
 * (p,q) where it stays on its entity (interior; plane of a planar patch
 * holding p; straight ridge holding p), its ball checked like a collapse;
 * then p collapses onto it with all the checks above, or q moves back bit
 * for bit. The new edges are about half the short edge shorter than from
 * either end, which unlocks most collapses the length guard refuses.
 */
#include "remesh3d/remesh3d.h"

#define R3_COL_MAXTRI 128

/* Apply a checked collapse p -> q: glue the faces around the deleted tets
 * (nq[i] < 0), rename p in the others (new qualities nq), then rename the
 * surface records trec[0..ntri) and feature edges erec[0..nerec). */
static pa_status collapse_apply(rm3d *m, pa_idx p, pa_idx q, const pa_idx *ball,
                                int n, const float *nq, const pa_idx *trec,
                                int ntri, const pa_idx *erec, int nerec) {
  pa_status st = PA_SUCCESS;
  for (int i = 0; i < n; i++) {
    if (nq[i] >= 0) continue;
    pa_idx t = ball[i] >> 2;
    int ip = ball[i] & 3;
    const pa_idx *v = m->tv + 4 * (size_t)t;
    int iq = rm3d_loc(v, q);
    pa_idx o1 = m->adj[4 * (size_t)t + iq], o2 = m->adj[4 * (size_t)t + ip];
    unsigned tag = ((m->tflag[t] >> iq) | (m->tflag[t] >> ip)) & 1u;
    if (o1 >= 0) {
      m->adj[o1] = o2;
      if (tag) m->tflag[o1 >> 2] |= (uint8_t)(1u << (o1 & 3));
    }
    if (o2 >= 0) {
      m->adj[o2] = o1;
      if (tag) m->tflag[o2 >> 2] |= (uint8_t)(1u << (o2 & 3));
    }
    pa_idx keep = o1 >= 0 ? (o1 >> 2) : (o2 >> 2);
    for (int j = 0; j < 4; j++)
      if (j != ip && j != iq) m->vtet[v[j]] = keep;
    m->tflag[t] = RM3D_T_DEAD;
    m->ndead_t++;
  }
  for (int i = 0; i < n; i++) {
    if (nq[i] < 0) continue;
    pa_idx t = ball[i] >> 2;
    m->tv[4 * (size_t)t + (ball[i] & 3)] = q;
    m->q[t] = nq[i];
    m->tflag[t] &= (uint8_t)~RM3D_T_CLEAN;
    m->vtet[q] = t;
  }
  for (int j = 0; j < ntri; j++) {
    pa_idx r = trec[j];
    pa_idx tv3[3];
    memcpy(tv3, m->tri.v + 3 * (size_t)r, sizeof tv3);
    int32_t ref = m->tri.ref[r];
    uint8_t fl = m->tri.flag[r];
    pa__rm3d_table_remove(&m->tri, r);
    if (tv3[0] == q || tv3[1] == q || tv3[2] == q) continue;
    for (int c = 0; c < 3; c++)
      if (tv3[c] == p) tv3[c] = q;
    PA_CALL(pa__rm3d_table_add(&m->tri, tv3, ref, fl, NULL));
  }
  if (nerec == 2) {
    for (int j = 0; j < 2; j++) {
      pa_idx r = erec[j];
      pa_idx ev[2];
      memcpy(ev, m->edg.v + 2 * (size_t)r, sizeof ev);
      int32_t ref = m->edg.ref[r];
      uint8_t fl = m->edg.flag[r];
      pa__rm3d_table_remove(&m->edg, r);
      if (ev[0] == q || ev[1] == q) continue;
      for (int c = 0; c < 2; c++)
        if (ev[c] == p) ev[c] = q;
      PA_CALL(pa__rm3d_table_add(&m->edg, ev, ref, fl, NULL));
    }
  }
  m->vtag[p] = RM3D_V_DEAD;
  m->ndead_v++;
  m->ncollapse++;
cleanup:
  return st;
}

/* The qualities nq[i] of the tets of p's ball (ball[0..n)) with p moved to
 * q, -1 for the tets holding (p,q), which disappear. 1 when no deleted
 * tet is a cap (two boundary faces glued), some but not all tets disappear,
 * and the new worst quality is acceptable against the old one. (A ball of
 * several references has p on the triangles between them, which the
 * surface collapse keeps.) */
static int ball_qualities(const rm3d *m, pa_idx q, const pa_idx *ball, int n,
                          float *nq) {
  double qold = 1e30;
  int nd = 0;
  for (int i = 0; i < n; i++) {
    pa_idx t = ball[i] >> 2;
    if (m->q[t] < qold) qold = m->q[t];
  }
  /* the lowest new quality accepted against qold (rm3d_q_ok, and at least
   * 0.3 qold): one tet below it refuses the collapse */
  double qmin = fmax(0.3 * qold, rm3d_q_min(m, qold));
  const double *xq = m->x + 3 * (size_t)q;
  const double *mq = m->met + (size_t)m->mc * q;
  for (int i = 0; i < n; i++) {
    pa_idx t = ball[i] >> 2;
    int ip = ball[i] & 3;
    const pa_idx *v = m->tv + 4 * (size_t)t;
    int iq = rm3d_loc(v, q);
    if (iq >= 0) {
      /* Deleted: both faces (p,x,y) and (q,x,y) on a surface is a cap. */
      if (((m->tflag[t] >> ip) & 1) && ((m->tflag[t] >> iq) & 1)) return 0;
      nd++;
      nq[i] = -1;
      continue;
    }
    double qq = rm3d_qual_moved(m, t, ip, xq, mq);
    if (!(qq >= qmin)) return 0;
    nq[i] = (float)qq;
  }
  return nd != 0 && nd != n;
}

/* Length guard: 1 when no new edge (q, x) is longer than lguard (the tets
 * holding q disappear: their vertices are not renamed). */
static int new_edges_short(rm3d *m, pa_idx p, pa_idx q, const pa_idx *ball,
                           int n, double lguard) {
  int ok = 1;
  for (int i = 0; i < n && ok; i++) {
    const pa_idx *v = m->tv + 4 * (size_t)(ball[i] >> 2);
    if (rm3d_loc(v, q) >= 0) continue;
    for (int j = 0; j < 4; j++) {
      pa_idx x = v[j];
      if (x == p || (m->vtag[x] & RM3D_V_MARK)) continue;
      m->vtag[x] |= RM3D_V_MARK;
      if (rm3d_len(m, q, x) > lguard) {
        ok = 0;
        break;
      }
    }
  }
  for (int i = 0; i < n; i++) {
    const pa_idx *v = m->tv + 4 * (size_t)(ball[i] >> 2);
    for (int j = 0; j < 4; j++) m->vtag[v[j]] &= (uint8_t)~RM3D_V_MARK;
  }
  return ok;
}

/* The boundary triangles around the boundary vertex p into trec[0..*ntri),
 * and whether the surface is kept (*ok): (p,q) is a boundary edge, no
 * triangle is required, the renamed ones (p -> q) do not exist yet, keep
 * one reference off features, and stay within RM3D_NORMAL_COS of their
 * normal and within hausd of p. */
static pa_status surface_kept(const rm3d *m, pa_idx p, pa_idx q,
                              const pa_idx *ball, int n, pa_idx *trec,
                              int *ntri, int *ok) {
  uint8_t tp = m->vtag[p];
  int onsurf = 0;
  const double *xp = m->x + 3 * (size_t)p;
  *ok = 0;
  for (int i = 0; i < n; i++) {
    pa_idx t = ball[i] >> 2;
    int ip = ball[i] & 3;
    uint8_t fl = m->tflag[t];
    if (!(fl & RM3D_T_FACES & ~(1u << ip))) continue;
    const pa_idx *v = m->tv + 4 * (size_t)t;
    for (int f = 0; f < 4; f++) {
      if (f == ip || !((fl >> f) & 1)) continue;
      pa_idx key[3] = {v[pa__rm3d_face[f][0]], v[pa__rm3d_face[f][1]],
                       v[pa__rm3d_face[f][2]]};
      pa_idx r = pa__rm3d_table_find(&m->tri, key);
      if (r < 0)
        return pa__error(PA_ERR_INTERNAL, __FILE__, __LINE__,
                         "rm3d: tagged face not in the table");
      int seen = 0;
      for (int j = 0; j < *ntri; j++) seen |= trec[j] == r;
      if (seen) continue;
      if (*ntri >= R3_COL_MAXTRI) return PA_SUCCESS;
      if (m->tri.flag[r] & PA_FLAG_REQUIRED) return PA_SUCCESS;
      trec[(*ntri)++] = r;
    }
  }
  int32_t tref0 = *ntri ? m->tri.ref[trec[0]] : 0;
  for (int j = 0; j < *ntri; j++) {
    const pa_idx *tvv = m->tri.v + 3 * (size_t)trec[j];
    int hasq = tvv[0] == q || tvv[1] == q || tvv[2] == q;
    if (hasq) {
      onsurf = 1;
      continue;
    }
    if (!(tp & RM3D_V_FEAT) && m->tri.ref[trec[j]] != tref0) return PA_SUCCESS;
    /* The renamed triangle must not exist yet, and must stay close to
     * the old surface. */
    pa_idx nk[3];
    const double *y[3], *yo[3];
    for (int c = 0; c < 3; c++) {
      nk[c] = tvv[c] == p ? q : tvv[c];
      y[c] = m->x + 3 * (size_t)nk[c];
      yo[c] = m->x + 3 * (size_t)tvv[c];
    }
    if (pa__rm3d_table_find(&m->tri, nk) >= 0) return PA_SUCCESS;
    double n0[3], n1[3];
    rm3d_tri_normal(yo[0], yo[1], yo[2], n0);
    if (rm3d_tri_normal(y[0], y[1], y[2], n1) <= 0) return PA_SUCCESS;
    if (n0[0] * n1[0] + n0[1] * n1[1] + n0[2] * n1[2] < RM3D_NORMAL_COS)
      return PA_SUCCESS;
    double d = fabs((xp[0] - y[0][0]) * n1[0] + (xp[1] - y[0][1]) * n1[1] +
                    (xp[2] - y[0][2]) * n1[2]);
    if (d > rm3d_tri_hausd(m, trec[j])) return PA_SUCCESS;
  }
  *ok = onsurf;
  return PA_SUCCESS;
}

/* The feature edges at the ridge vertex p into erec (*nerec of them, the
 * first four kept): 1 when they are exactly (p,q) and (p,r), neither
 * required, (q,r) no feature edge yet, and p projects inside the segment
 * qr within hausd (the least of the triangles trec[0..ntri) at p). */
static int ridge_kept(rm3d *m, pa_idx p, pa_idx q, const pa_idx *ball, int n,
                      const pa_idx *trec, int ntri, pa_idx *erec,
                      int *nerec) {
  const double *xp = m->x + 3 * (size_t)p, *xq = m->x + 3 * (size_t)q;
  for (int i = 0; i < n; i++) {
    const pa_idx *v = m->tv + 4 * (size_t)(ball[i] >> 2);
    for (int j = 0; j < 4; j++) {
      pa_idx x = v[j];
      if (x == p || (m->vtag[x] & RM3D_V_MARK)) continue;
      m->vtag[x] |= RM3D_V_MARK;
      if (!(m->vtag[x] & RM3D_V_FEAT)) continue;
      pa_idx key[2] = {p, x};
      pa_idx r = pa__rm3d_table_find(&m->edg, key);
      if (r < 0) continue;
      if (*nerec < 4) erec[*nerec] = r;
      (*nerec)++;
    }
  }
  for (int i = 0; i < n; i++) {
    const pa_idx *v = m->tv + 4 * (size_t)(ball[i] >> 2);
    for (int j = 0; j < 4; j++) m->vtag[v[j]] &= (uint8_t)~RM3D_V_MARK;
  }
  if (*nerec != 2) return 0;
  int iq = -1;
  for (int j = 0; j < 2; j++) {
    const pa_idx *ev = m->edg.v + 2 * (size_t)erec[j];
    if (ev[0] == q || ev[1] == q) iq = j;
    if (m->edg.flag[erec[j]] & PA_FLAG_REQUIRED) return 0;
  }
  if (iq < 0) return 0;
  const pa_idx *eo = m->edg.v + 2 * (size_t)erec[1 - iq];
  pa_idx r = eo[0] == p ? eo[1] : eo[0];
  if (r == q) return 0;
  pa_idx key[2] = {q, r};
  if (pa__rm3d_table_find(&m->edg, key) >= 0) return 0;
  const double *xr = m->x + 3 * (size_t)r;
  double u[3] = {xr[0] - xq[0], xr[1] - xq[1], xr[2] - xq[2]};
  double w[3] = {xp[0] - xq[0], xp[1] - xq[1], xp[2] - xq[2]};
  double uu = u[0] * u[0] + u[1] * u[1] + u[2] * u[2];
  double uw = u[0] * w[0] + u[1] * w[1] + u[2] * w[2];
  if (uu <= 0 || uw <= 0 || uw >= uu) return 0;
  double d2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2] - uw * uw / uu;
  double h = m->hausd; /* the least over the triangles at p */
  for (int j = 0; j < ntri; j++) {
    double hj = rm3d_tri_hausd(m, trec[j]);
    if (hj < h || j == 0) h = hj;
  }
  return !(d2 > h * h);
}

pa_status pa__rm3d_collapse_ball(rm3d *m, pa_idx p, pa_idx q,
                                 const pa_idx *ball, int n, double lguard,
                                 int *done) {
  pa_status st = PA_SUCCESS;
  float nq[RM3D_MAXBALL];
  pa_idx trec[R3_COL_MAXTRI];
  pa_idx erec[4];
  int ntri = 0, nerec = 0;
  *done = 0;
  if (!rm3d_collapse_allowed(m, p, q)) return st;
  uint8_t tp = m->vtag[p];
  int surfp = (tp & RM3D_V_BDRY) != 0;
  /* the length guard first: it refuses most of the collapses tried (84 %
   * on the Kuhn cube, 77 % on the rod), for a length per neighbour
   * instead of a quality per tet; both must pass, so the order changes no
   * outcome */
  if (!new_edges_short(m, p, q, ball, n, lguard)) return st;
  if (!ball_qualities(m, q, ball, n, nq)) return st;
  if (surfp) {
    int ok;
    PA_CALL(surface_kept(m, p, q, ball, n, trec, &ntri, &ok));
    if (!ok) return st;
    if ((tp & RM3D_V_FEAT) &&
        !ridge_kept(m, p, q, ball, n, trec, ntri, erec, &nerec))
      return st;
  }
  PA_CALL(collapse_apply(m, p, q, ball, n, nq, trec, ntri, erec, nerec));
  *done = 1;
cleanup:
  return st;
}

/* Whether q, of ball bq[0..nb), stays on its entity at the middle of
 * (p,q): an interior q (then p is interior too), a q of a planar patch
 * with p in that plane, a q of a straight ridge with p on that line. */
static int mid_on_entity(rm3d *m, pa_idx p, pa_idx q, const pa_idx *bq,
                         int nb) {
  uint8_t tp = m->vtag[p], tq = m->vtag[q];
  const double *xq = m->x + 3 * (size_t)q;
  const double *xp = m->x + 3 * (size_t)p;
  if (!(tq & RM3D_V_BDRY)) return !(tp & RM3D_V_BDRY);
  if (!m->surf || !(tp & RM3D_V_BDRY) || ((tp ^ tq) & RM3D_V_FEAT)) return 0;
  double dir[3];
  int kind = pa__rm3d_bdry_freedom(m, q, bq, nb, dir);
  if (kind != ((tq & RM3D_V_FEAT) ? 1 : 2)) return 0;
  double e[3] = {xp[0] - xq[0], xp[1] - xq[1], xp[2] - xq[2]};
  double le = sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
  if (kind == 2)
    return !(fabs(e[0] * dir[0] + e[1] * dir[1] + e[2] * dir[2]) > 1e-12 * le);
  double c[3] = {e[1] * dir[2] - e[2] * dir[1], e[2] * dir[0] - e[0] * dir[2],
                 e[0] * dir[1] - e[1] * dir[0]};
  return !(sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]) > 1e-12 * le);
}

/* The qualities of q's ball bq[0..nb) with q at xm (metric mm): oq the old
 * ones, nq the new (-1 on the tets holding p, which the collapse checks).
 * 0 if a tet is frozen or the ball's quality would drop too far. */
static int mid_qualities(const rm3d *m, pa_idx p, const pa_idx *bq, int nb,
                         const double *xm, const double *mm, float *oq,
                         float *nq) {
  double qold = 1e30, qnew = 1e30;
  for (int i = 0; i < nb; i++) {
    pa_idx t = bq[i] >> 2;
    int iq = bq[i] & 3;
    if (m->tflag[t] & RM3D_T_FROZEN) return 0;
    const pa_idx *v = m->tv + 4 * (size_t)t;
    oq[i] = m->q[t];
    if (m->q[t] < qold) qold = m->q[t];
    if (rm3d_loc(v, p) >= 0) {
      nq[i] = -1;
      continue;
    }
    double qq = rm3d_qual_moved(m, t, iq, xm, mm);
    if (qq < m->qabs) return 0;
    if (qq < qnew) qnew = qq;
    nq[i] = (float)qq;
  }
  return !(qnew < 0.3 * qold || !rm3d_q_ok(m, qnew, qold));
}

/* Whether every edge from xm (metric mm) to the vertices of the tets of
 * bq[0..nb) that q keeps (those without p) is at most lguard long. */
static int mid_lengths_ok(rm3d *m, pa_idx p, pa_idx q, const pa_idx *bq,
                          int nb, const double *xm, const double *mm,
                          double lguard) {
  int mc = m->mc, ok = 1;
  for (int i = 0; i < nb && ok; i++) {
    const pa_idx *v = m->tv + 4 * (size_t)(bq[i] >> 2);
    if (rm3d_loc(v, p) >= 0) continue;
    for (int j = 0; j < 4; j++) {
      pa_idx x = v[j];
      if (x == q || (m->vtag[x] & RM3D_V_MARK)) continue;
      m->vtag[x] |= RM3D_V_MARK;
      if (pa__len3(mc, xm, m->x + 3 * (size_t)x, mm, m->met + (size_t)mc * x) >
          lguard) {
        ok = 0;
        break;
      }
    }
  }
  for (int i = 0; i < nb; i++) {
    const pa_idx *v = m->tv + 4 * (size_t)(bq[i] >> 2);
    for (int j = 0; j < 4; j++) m->vtag[v[j]] &= (uint8_t)~RM3D_V_MARK;
  }
  return ok;
}

/* Move q to xm (metric mm, its ball's qualities nq), try the collapse of p
 * (ball bp[0..np)) onto it, and move q back (coordinates, metric, cached
 * qualities oq bit for bit) if refused; if done, q's fields become the mean
 * of p's and q's. */
static pa_status collapse_at_mid(rm3d *m, pa_idx p, pa_idx q,
                                 const pa_idx *bp, int np, const pa_idx *bq,
                                 int nb, const double *xm, const double *mm,
                                 const float *oq, const float *nq,
                                 double lguard, int *done) {
  pa_status st = PA_SUCCESS;
  int mc = m->mc;
  double *xq = m->x + 3 * (size_t)q;
  double xo[3], mo[6], mo0[6];
  memcpy(xo, xq, sizeof xo);
  memcpy(mo, m->met + (size_t)mc * q, (size_t)mc * sizeof(double));
  memcpy(xq, xm, 3 * sizeof *xm);
  memcpy(m->met + (size_t)mc * q, mm, (size_t)mc * sizeof(double));
  if (m->met0) {
    memcpy(mo0, m->met0 + (size_t)mc * q, (size_t)mc * sizeof(double));
    pa__rm3d_met0_mid(m, q, p, q);
  }
  for (int i = 0; i < nb; i++) { /* q moves: its ball changes */
    m->tflag[bq[i] >> 2] &= (uint8_t)~RM3D_T_CLEAN;
    if (nq[i] >= 0) m->q[bq[i] >> 2] = nq[i];
  }
  *done = 0;
  if (np >= 0)
    PA_CALL(pa__rm3d_collapse_ball(m, p, q, bp, np, lguard, done));
  if (!*done) {
    memcpy(xq, xo, sizeof xo);
    memcpy(m->met + (size_t)mc * q, mo, (size_t)mc * sizeof(double));
    if (m->met0)
      memcpy(m->met0 + (size_t)mc * q, mo0, (size_t)mc * sizeof(double));
    for (int i = 0; i < nb; i++) m->q[bq[i] >> 2] = oq[i];
  } else {
    for (int k = 0; k < m->nfield; k++) {
      int c = m->fcomp[k];
      double *fq = m->fval[k] + (size_t)c * q;
      const double *fp = m->fval[k] + (size_t)c * p;
      for (int j = 0; j < c; j++) fq[j] = 0.5 * (fq[j] + fp[j]);
    }
  }
cleanup:
  return st;
}

/* Midpoint collapse: q first moves to the middle of (p,q) -- only where it
 * stays on its entity (mid_on_entity) --, its ball checked like a collapse
 * (quality, length guard); then p collapses onto it with every check of
 * pa__rm3d_collapse_ball. When that collapse is refused, q goes back
 * (coordinates, metric, cached qualities bit for bit). */
pa_status pa__rm3d_collapse_mid(rm3d *m, pa_idx p, pa_idx q,
                                const pa_idx *bp, int np, const pa_idx *bq,
                                int nb, double lguard, int *done) {
  pa_status st = PA_SUCCESS;
  float oq[RM3D_MAXBALL], nq[RM3D_MAXBALL];
  *done = 0;
  uint8_t tp = m->vtag[p], tq = m->vtag[q];
  if ((tp | tq) & (RM3D_V_LOCK | RM3D_V_CORNER | RM3D_V_DEAD)) return st;
  if (nb < 0) return st;
  if (!mid_on_entity(m, p, q, bq, nb)) return st;
  const double *xp = m->x + 3 * (size_t)p, *xq = m->x + 3 * (size_t)q;
  double xm[3], mm[6];
  for (int i = 0; i < 3; i++) xm[i] = 0.5 * (xp[i] + xq[i]);
  if (pa__rm3d_project_vertex(m, q, bq, nb, xm) < 0) return st; /* model */
  pa__rm3d_mid_metric(m, p, q, mm);
  if (!mid_lengths_ok(m, p, q, bq, nb, xm, mm, lguard)) return st;
  if (!mid_qualities(m, p, bq, nb, xm, mm, oq, nq)) return st;
  PA_CALL(collapse_at_mid(m, p, q, bp, np, bq, nb, xm, mm, oq, nq, lguard,
                          done));
cleanup:
  return st;
}
