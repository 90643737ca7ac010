/*
 * split_3d.c -- edge split: a new vertex on the edge (a,b), every tet of
 * the shell cut in two (a,m,r_i,r_i+1) + (m,b,r_i,r_i+1).
 *
 * Checked before applied: no frozen tet in the shell; a boundary edge only
 * in surface mode and only when none of its triangles / feature edges is
 * required; every new tet passes rm3d_q_ok against its parent (only validity for an
 * edge longer than 2 sqrt 2). The new vertex is the
 * midpoint, or for an edge of a curved surface patch the midpoint of the
 * cubic curve given by the end normals (exact on planes, so planar patches
 * stay planar); for a ridge edge, the midpoint of the cubic given by the
 * ridge tangents at both ends (exact midpoint on straight ridges). With a
 * model (pa_remesh_opts.geometry), the point of the edge's curve or surface
 * closest to that one is tried first (model_3d.c), its halves within
 * RM3D_NORMAL_COS_MODEL of the triangles' normals; when it fails, the
 * points below are, and the new vertex is marked off the model (voff) for
 * the snap moves. Boundary triangles and feature edges holding (a,b) are split too, keeping
 * references and flags; each half of a boundary triangle stays within
 * RM3D_NORMAL_COS of its normal. When that point fails, points closer to
 * the chord are tried (CURVE_BACKOFF).
 */
#include "remesh3d/remesh3d.h"

/* Points tried on a curved or ridge edge: the curve's midpoint, then 1/2
 * and 1/4 of its offset from the chord, then the chord's midpoint (valid
 * whenever the shell is, and in the plane of each boundary triangle). */
#define CURVE_BACKOFF 4

/* Midpoint of the cubic Hermite-like curve between a and b whose tangents
 * are the chord projected on the tangent planes of na, nb (PN triangles). */
static void curved_mid(const double *a, const double *b, const double *na,
                       const double *nb, double *p) {
  double e[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
  double wa = e[0] * na[0] + e[1] * na[1] + e[2] * na[2];
  double wb = -(e[0] * nb[0] + e[1] * nb[1] + e[2] * nb[2]);
  for (int i = 0; i < 3; i++) {
    double b1 = a[i] + (e[i] - wa * na[i]) / 3.0;
    double b2 = b[i] - (e[i] + wb * nb[i]) / 3.0;
    p[i] = (a[i] + 3.0 * b1 + 3.0 * b2 + b[i]) / 8.0;
  }
}

/* Unit tangent of the ridge through v, oriented away from its feature
 * neighbour r other than w (so towards w's side): the tangent at v of the
 * circle through r, v, w. 0 when v has not exactly two feature edges. */
static int ridge_tangent(rm3d *m, pa_idx v, pa_idx w, double *t) {
  pa_idx ball[RM3D_MAXBALL];
  if (m->vtag[v] & RM3D_V_CORNER) return 0;
  int n = pa__rm3d_ball(m, v, ball, RM3D_MAXBALL);
  if (n < 0) return 0;
  pa_idx r = -1;
  int nr = 0;
  for (int i = 0; i < n && nr < 3; i++) {
    const pa_idx *tv = m->tv + 4 * (size_t)(ball[i] >> 2);
    for (int j = 0; j < 4; j++) {
      pa_idx x = tv[j];
      if (x == v || x == w || x == r || !(m->vtag[x] & RM3D_V_FEAT)) continue;
      pa_idx key[2] = {v, x};
      if (pa__rm3d_table_find(&m->edg, key) < 0) continue;
      r = x;
      nr++;
    }
  }
  if (nr != 1) return 0;
  const double *xv = m->x + 3 * (size_t)v, *xw = m->x + 3 * (size_t)w,
               *xr = m->x + 3 * (size_t)r;
  double u[3] = {xw[0] - xv[0], xw[1] - xv[1], xw[2] - xv[2]};
  double z[3] = {xv[0] - xr[0], xv[1] - xr[1], xv[2] - xr[2]};
  double lu = sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
  double lz = sqrt(z[0] * z[0] + z[1] * z[1] + z[2] * z[2]);
  if (!(lu > 0) || !(lz > 0)) return 0;
  /* Weights exact for points on a circle (the tangent of the circle through
   * r, v, w at v). */
  for (int i = 0; i < 3; i++) t[i] = u[i] * (lz / lu) + z[i] * (lu / lz);
  double lt = sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]);
  if (!(lt > 0)) return 0;
  for (int i = 0; i < 3; i++) t[i] /= lt;
  return 1;
}

void pa__rm3d_mid_metric(const rm3d *m, pa_idx a, pa_idx b, double *mp) {
  int mc = m->mc;
  const double *ms[2] = {m->met + (size_t)mc * a, m->met + (size_t)mc * b};
  double w[2] = {0.5, 0.5};
  pa__metric_interp(3, mc, 2, ms, w, mp);
}

/* Point of a ridge edge (a,b): the midpoint of the cubic Hermite curve with
 * the ridge tangents at both ends (a corner end mirrors the other), so curved
 * ridges are followed; straight ridges (tangents along the chord to 1e-12)
 * get the exact midpoint. */
static void ridge_mid(rm3d *m, pa_idx a, pa_idx b, double *p) {
  const double *xa = m->x + 3 * (size_t)a, *xb = m->x + 3 * (size_t)b;
  double e[3] = {xb[0] - xa[0], xb[1] - xa[1], xb[2] - xa[2]};
  double le = sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
  for (int i = 0; i < 3; i++) p[i] = 0.5 * (xa[i] + xb[i]);
  if (!(le > 0)) return;
  double ta[3], tb[3], ue[3] = {e[0] / le, e[1] / le, e[2] / le};
  int ha = ridge_tangent(m, a, b, ta), hb = ridge_tangent(m, b, a, tb);
  if (!ha && !hb) return;
  /* An end without a tangent (corner) takes the mirror image of the other
   * end's tangent across the chord's bisecting plane (exact on a circle). */
  if (!ha) {
    double d = -(tb[0] * ue[0] + tb[1] * ue[1] + tb[2] * ue[2]);
    for (int i = 0; i < 3; i++) ta[i] = 2.0 * d * ue[i] + tb[i];
  }
  if (!hb) {
    double d = ta[0] * ue[0] + ta[1] * ue[1] + ta[2] * ue[2];
    for (int i = 0; i < 3; i++) tb[i] = -(2.0 * d * ue[i] - ta[i]);
  }
  /* tb points from b towards a: the curve's tangent at b is -tb. */
  double ca = (ta[0] * e[0] + ta[1] * e[1] + ta[2] * e[2]) / le;
  double cb = -(tb[0] * e[0] + tb[1] * e[1] + tb[2] * e[2]) / le;
  if (ca < 0.77 || cb < 0.77) return; /* turns by more than ~40 degrees */
  double d[3], ld = 0;
  for (int i = 0; i < 3; i++) {
    d[i] = le / 8.0 * (ta[i] + tb[i]);
    ld += d[i] * d[i];
  }
  if (sqrt(ld) <= 1e-12 * le) return;
  for (int i = 0; i < 3; i++) p[i] += d[i];
}

/* Qualities of the two halves of each of the n tets of the shell of (a,b)
 * when a point p (metric mp) is put on the edge, in q1 (the half holding a)
 * and q2; 1 if every one is accepted: valid when relax, else rm3d_q_ok
 * against its parent. */
static int shell_qualities(const rm3d *m, const pa_idx *tets, int n, pa_idx a,
                           pa_idx b, const double *p, const double *mp,
                           int relax, float *q1, float *q2) {
  int mc = m->mc;
  for (int i = 0; i < n; i++) {
    const pa_idx *v = m->tv + 4 * (size_t)tets[i];
    const double *px[4], *pm[4];
    for (int j = 0; j < 4; j++) {
      px[j] = m->x + 3 * (size_t)v[j];
      pm[j] = m->met + (size_t)mc * v[j];
    }
    int ia = rm3d_loc(v, a), ib = rm3d_loc(v, b);
    const double *sx = px[ib], *sm = pm[ib];
    px[ib] = p;
    pm[ib] = mp;
    double qa =
        pa__qual3(mc, px[0], px[1], px[2], px[3], pm[0], pm[1], pm[2], pm[3]);
    px[ib] = sx;
    pm[ib] = sm;
    px[ia] = p;
    pm[ia] = mp;
    double qb =
        pa__qual3(mc, px[0], px[1], px[2], px[3], pm[0], pm[1], pm[2], pm[3]);
    double qp = m->q[tets[i]];
    if (relax ? (qa < m->qabs || qb < m->qabs)
              : (!rm3d_q_ok(m, qa, qp) || !rm3d_q_ok(m, qb, qp)))
      return 0;
    q1[i] = (float)qa;
    q2[i] = (float)qb;
  }
  return 1;
}

/* 1 if the halves of each of the ntri boundary triangles trec of edge
 * (a,b), split at p, are valid and within cmin (a cosine) of its normal. */
static int split_surface_kept(const rm3d *m, const pa_idx *trec, int ntri,
                              pa_idx a, pa_idx b, const double *p,
                              double cmin) {
  for (int i = 0; i < ntri; i++) {
    const pa_idx *v = m->tri.v + 3 * (size_t)trec[i];
    const double *y[3], *ya[3], *yb[3];
    for (int j = 0; j < 3; j++) {
      y[j] = m->x + 3 * (size_t)v[j];
      ya[j] = v[j] == b ? p : y[j];
      yb[j] = v[j] == a ? p : y[j];
    }
    double n0[3], na[3], nb[3];
    if (!(rm3d_tri_normal(y[0], y[1], y[2], n0) > 0)) continue;
    if (!(rm3d_tri_normal(ya[0], ya[1], ya[2], na) > 0) ||
        !(rm3d_tri_normal(yb[0], yb[1], yb[2], nb) > 0))
      return 0;
    if (n0[0] * na[0] + n0[1] * na[1] + n0[2] * na[2] < cmin ||
        n0[0] * nb[0] + n0[1] * nb[1] + n0[2] * nb[2] < cmin)
      return 0;
  }
  return 1;
}

/* A split of the edge (a,b): what the checks found, which the application
 * then uses. */
typedef struct split_plan {
  pa_idx a, b;
  int n, info; /* the shell: tets[i] = (a, b, ring[i], ring[i+1]) */
  pa_idx tets[RM3D_MAXSHELL], ring[RM3D_MAXSHELL + 1];
  int bdry;    /* a boundary edge */
  int ntri;    /* the boundary triangles holding (a,b): trec[0..ntri) */
  pa_idx trec[RM3D_MAXSHELL + 1];
  pa_idx erec; /* the feature edge (a,b), or -1 */
  double p[3], mp[6];                         /* the new vertex, its metric */
  int offmodel; /* with a model, p is not on it (its point was refused) */
  double dcur[3]; /* from p to the point of the curve (0: p on it) */
  float q1[RM3D_MAXSHELL], q2[RM3D_MAXSHELL]; /* qualities of the halves */
} split_plan;

/* The boundary triangles and the feature edge holding the boundary edge
 * (a,b): faces crossed between shell tets, plus both ends of an open shell.
 * *ok = 0 when one of them is required. */
static pa_status find_bdry_records(const rm3d *m, split_plan *s, int *ok) {
  pa_idx a = s->a, b = s->b;
  *ok = 0;
  for (int i = 0; i <= s->n; i++) {
    pa_idx t, r;
    int f;
    if (i < s->n) { /* forward face of tets[i]: (a, b, ring[i+1]) */
      t = s->tets[i];
      const pa_idx *v = m->tv + 4 * (size_t)t;
      f = pa__rm3d_compl[rm3d_loc(v, a)][rm3d_loc(v, b)][0];
      r = s->ring[i + 1];
    } else { /* start face of an open shell: (a, b, ring[0]) */
      if (s->info & RM3D_SH_CLOSED) break;
      t = s->tets[0];
      const pa_idx *v = m->tv + 4 * (size_t)t;
      f = pa__rm3d_compl[rm3d_loc(v, a)][rm3d_loc(v, b)][1];
      r = s->ring[0];
    }
    if (!((m->tflag[t] >> f) & 1)) continue;
    pa_idx key[3] = {a, b, r};
    pa_idx rec = pa__rm3d_table_find(&m->tri, key);
    if (rec < 0)
      return pa__error(PA_ERR_INTERNAL, __FILE__, __LINE__,
                       "rm3d: tagged face not in the table");
    if (m->tri.flag[rec] & PA_FLAG_REQUIRED) return PA_SUCCESS;
    s->trec[s->ntri++] = rec;
  }
  pa_idx key[2] = {a, b};
  s->erec = pa__rm3d_table_find(&m->edg, key);
  if (s->erec >= 0 && (m->edg.flag[s->erec] & PA_FLAG_REQUIRED))
    return PA_SUCCESS;
  *ok = 1;
  return PA_SUCCESS;
}

/* The new vertex s->p and its metric s->mp, and the qualities of the
 * halves: the point on the curve (see the opening comment), else points
 * closer to the chord. 1 when a point passes every check. */
static int place_vertex(rm3d *m, split_plan *s) {
  pa_idx a = s->a, b = s->b;
  const double *xa = m->x + 3 * (size_t)a, *xb = m->x + 3 * (size_t)b;
  double c[3], p0[3];
  for (int i = 0; i < 3; i++) c[i] = 0.5 * (xa[i] + xb[i]);
  int curved = s->bdry && s->erec < 0 && m->nrm &&
               (m->vtag[a] & RM3D_V_CURVED) && (m->vtag[b] & RM3D_V_CURVED);
  if (curved)
    curved_mid(xa, xb, m->nrm + 3 * (size_t)a, m->nrm + 3 * (size_t)b, p0);
  else if (s->erec >= 0)
    ridge_mid(m, a, b, p0);
  else
    memcpy(p0, c, sizeof c);
  /* with a model, its point first (pmod), then the points above (off it:
   * the vertex is marked for the snap moves) */
  double pmod[3];
  memcpy(pmod, p0, sizeof pmod);
  int on_model = s->bdry && pa__rm3d_project_split(m, s->erec, s->trec,
                                                   s->ntri, a, b, pmod) > 0;
  s->offmodel = 0;
  pa__rm3d_mid_metric(m, a, b, s->mp);
  /* A far too long edge is split whenever the result is valid: keeping it
   * would be worse than a poor tet the later passes improve. The point on
   * the curve lies off the chord by the curve's sagitta: next to a flat tet
   * of the shell it may invert it, and next to a boundary triangle whose
   * apex is nearly on the chord it stands the halves up across the
   * surface. Then the point goes closer to the chord, where the halves stay
   * in the triangle's plane (a surface tilt is always retried, a refused
   * quality only for a far too long edge). */
  int relax = rm3d_len(m, a, b) > 2.0 * PA_METRIC_LEN_HI_EXACT;
  int ok = 0;
  if (on_model) {
    memcpy(s->p, pmod, sizeof pmod);
    ok = split_surface_kept(m, s->trec, s->ntri, a, b, s->p,
                            RM3D_NORMAL_COS_MODEL) &&
         shell_qualities(m, s->tets, s->n, a, b, s->p, s->mp, relax, s->q1,
                         s->q2);
    s->offmodel = !ok;
  }
  for (int f = 0; f < CURVE_BACKOFF && !ok; f++) {
    double w = f == CURVE_BACKOFF - 1 ? 0 : ldexp(1.0, -f);
    if (f && !memcmp(p0, c, sizeof c)) break;
    for (int i = 0; i < 3; i++)
      s->p[i] = f ? c[i] + w * (p0[i] - c[i]) : p0[i];
    if (!split_surface_kept(m, s->trec, s->ntri, a, b, s->p, RM3D_NORMAL_COS))
      continue;
    ok = shell_qualities(m, s->tets, s->n, a, b, s->p, s->mp, relax, s->q1,
                         s->q2);
    if (!ok && !relax) break;
  }
  /* the rest of the way to the curve, for the curve snaps */
  for (int i = 0; i < 3; i++) s->dcur[i] = curved && ok ? p0[i] - s->p[i] : 0;
  return ok;
}

/* Cut every tet of the shell in two at the new vertex pm. */
static void cut_shell(rm3d *m, const split_plan *s, pa_idx pm) {
  pa_idx a = s->a, b = s->b;
  int n = s->n;
  pa_idx base = m->ne;
  m->ne += n;
  for (int i = 0; i < n; i++) {
    pa_idx t = s->tets[i], nt = base + i;
    pa_idx *v = m->tv + 4 * (size_t)t, *w = m->tv + 4 * (size_t)nt;
    int ia = rm3d_loc(v, a), ib = rm3d_loc(v, b);
    int ic = pa__rm3d_compl[ia][ib][0], id = pa__rm3d_compl[ia][ib][1];
    memcpy(w, v, 4 * sizeof *w);
    w[ia] = pm;
    v[ib] = pm;
    pa_idx *at = m->adj + 4 * (size_t)t, *an = m->adj + 4 * (size_t)nt;
    pa_idx oa = at[ia];
    an[ia] = oa;
    if (oa >= 0) m->adj[oa] = 4 * nt + ia;
    at[ia] = 4 * nt + ib;
    an[ib] = 4 * t + ia;
    pa_idx fw = at[ic], bw = at[id];
    an[ic] = fw < 0 ? -1 : 4 * (base + (i + 1 == n ? 0 : i + 1)) + (fw & 3);
    an[id] = bw < 0 ? -1 : 4 * (base + (i == 0 ? n - 1 : i - 1)) + (bw & 3);
    m->tflag[nt] =
        (uint8_t)(m->tflag[t] & ~(1u << ib) & ~(RM3D_T_MARK | RM3D_T_CLEAN));
    m->tflag[t] &= (uint8_t)~((1u << ia) | RM3D_T_CLEAN);
    m->tpf[nt] = m->tpf[t];
    m->tref[nt] = m->tref[t];
    m->q[t] = s->q1[i];
    m->q[nt] = s->q2[i];
  }
  m->vtet[b] = base;
  m->vtet[pm] = s->tets[0];
}

/* The boundary triangles and the feature edge of a split boundary edge cut
 * in two at pm, keeping their references and flags; pm's boundary tags and
 * normal. */
static pa_status split_bdry_records(rm3d *m, const split_plan *s, pa_idx pm) {
  pa_status st = PA_SUCCESS;
  pa_idx a = s->a, b = s->b;
  m->vtag[pm] |= RM3D_V_BDRY;
  if ((m->vtag[a] & RM3D_V_CURVED) && (m->vtag[b] & RM3D_V_CURVED) && m->nrm &&
      s->erec < 0) {
    double *np = m->nrm + 3 * (size_t)pm;
    const double *na = m->nrm + 3 * (size_t)a, *nb = m->nrm + 3 * (size_t)b;
    double w = 0;
    for (int i = 0; i < 3; i++) {
      np[i] = na[i] + nb[i];
      w += np[i] * np[i];
    }
    w = w > 0 ? 1.0 / sqrt(w) : 0;
    for (int i = 0; i < 3; i++) np[i] *= w;
    m->vtag[pm] |= RM3D_V_CURVED;
  }
  for (int i = 0; i < s->ntri; i++) {
    pa_idx r = s->trec[i];
    pa_idx t1[3], t2[3];
    memcpy(t1, m->tri.v + 3 * (size_t)r, sizeof t1);
    memcpy(t2, t1, sizeof t2);
    for (int j = 0; j < 3; j++) {
      if (t1[j] == b) t1[j] = pm;
      if (t2[j] == a) t2[j] = pm;
    }
    int32_t ref = m->tri.ref[r];
    uint8_t fl = m->tri.flag[r];
    pa__rm3d_table_remove(&m->tri, r);
    PA_CALL(pa__rm3d_table_add(&m->tri, t1, ref, fl, NULL));
    PA_CALL(pa__rm3d_table_add(&m->tri, t2, ref, fl, NULL));
  }
  if (s->erec >= 0) {
    pa_idx e1[2], e2[2];
    memcpy(e1, m->edg.v + 2 * (size_t)s->erec, sizeof e1);
    memcpy(e2, e1, sizeof e2);
    for (int j = 0; j < 2; j++) {
      if (e1[j] == b) e1[j] = pm;
      if (e2[j] == a) e2[j] = pm;
    }
    int32_t ref = m->edg.ref[s->erec];
    uint8_t fl = m->edg.flag[s->erec];
    pa__rm3d_table_remove(&m->edg, s->erec);
    PA_CALL(pa__rm3d_table_add(&m->edg, e1, ref, fl, NULL));
    PA_CALL(pa__rm3d_table_add(&m->edg, e2, ref, fl, NULL));
    m->vtag[pm] |= RM3D_V_FEAT;
  }
cleanup:
  return st;
}

pa_status pa__rm3d_split_edge(rm3d *m, pa_idx k, pa_idx a, pa_idx b,
                              int *done) {
  pa_status st = PA_SUCCESS;
  split_plan s;
  int ok = 1;
  *done = 0;
  s.a = a;
  s.b = b;
  s.ntri = 0;
  s.erec = -1;
  s.n = pa__rm3d_shell(m, k, a, b, s.tets, s.ring, NULL, RM3D_MAXSHELL,
                       &s.info);
  if (s.n < 0 || (s.info & RM3D_SH_FROZEN)) return st;
  s.bdry = (s.info & RM3D_SH_BDRY) != 0;
  if (s.bdry) {
    if (!m->surf) return st;
    PA_CALL(find_bdry_records(m, &s, &ok));
    if (!ok) return st;
  }
  if (!place_vertex(m, &s)) return st;
  /* Apply. */
  int mc = m->mc;
  PA_CALL(pa__rm3d_reserve(m, (size_t)m->nv + 1, (size_t)m->ne + s.n));
  pa_idx pm;
  PA_CALL(pa__rm3d_new_vertex(m, s.p, s.mp, &pm));
  {
    pa_idx src[2] = {a, b};
    double w[2] = {0.5, 0.5};
    if (m->nfield) pa__rm3d_interp(m, pm, 2, src, w);
    memcpy(m->met + (size_t)mc * pm, s.mp, sizeof(double) * mc);
    pa__rm3d_met0_mid(m, pm, a, b); /* the target, when relaxed */
  }
  if (m->vref[a] == m->vref[b]) m->vref[pm] = m->vref[a];
  if (m->voff) m->voff[pm] = (uint8_t)s.offmodel;
  if (m->vcur) memcpy(m->vcur + 3 * (size_t)pm, s.dcur, sizeof s.dcur);
  cut_shell(m, &s, pm);
  if (s.bdry) PA_CALL(split_bdry_records(m, &s, pm));
  m->nsplit++;
  *done = 1;
cleanup:
  return st;
}
