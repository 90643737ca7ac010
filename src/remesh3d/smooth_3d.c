/*
 * smooth_3d.c -- vertex relocation. An interior free vertex moves towards
 * the mean of the "ideal points" of its ball (for each tet, the apex of the
 * regular tet standing on the opposite face); the move is accepted only when
 * the worst quality of the ball rises, halving the step up to three times.
 * The ideal apex is that of the regular tetrahedron with unit edges in the
 * metric of p, so the move evens out edge lengths as well as shapes.
 *
 * Boundary vertices move only in surface mode and only where the surface
 * stays exactly what it was: a vertex whose boundary triangles are coplanar
 * moves in their plane (the target's normal component removed; an
 * axis-aligned plane keeps its coordinate bit for bit), a vertex of a
 * straight ridge (exactly two feature edges, collinear) moves along the
 * line; a vertex of a curved patch moves in its tangent plane and then onto
 * the PN surface (cubic patch from the vertex normals, the surface the
 * curved splits sample) of the boundary triangle below the target, if that
 * stays within hausd of the flat triangle and turns none of its triangles
 * by more than about 11 degrees; its normal is interpolated. With a model
 * (pa_remesh_opts.geometry) every such position goes onto the vertex's
 * curve or surface (model_3d.c), and a move the kernel cannot project is
 * refused. Locked and corner vertices never move, so frozen entities stay
 * untouched. The moved vertex's metric and fields are re-interpolated in the
 * old ball (metric only when anisotropic: an isotropic size field is treated
 * as attached to the vertex).
 *
 * The jiggle (pa__rm3d_jiggle_vertex) moves a free interior vertex by a
 * fixed metric length in a direction drawn from its coordinates' bits,
 * accepting a loss of quality down to half the ball's worst: the driver
 * uses it to break lattices, the one the last band would only refine
 * further and the one the rounds leave (the shake).
 */
#include "remesh3d/remesh3d.h"

/* Barycentric coordinates of point x in tet (p0..p3); 0 if degenerate. */
static int bary(const double *p0, const double *p1, const double *p2,
                const double *p3, const double *x, double *w) {
  const double *p[4] = {p0, p1, p2, p3};
  double vol = pa__orient3d(p0, p1, p2, p3);
  if (vol <= 0) return 0;
  for (int i = 0; i < 4; i++) {
    const double *s[4] = {p[0], p[1], p[2], p[3]};
    s[i] = x;
    double a[3] = {s[1][0] - s[0][0], s[1][1] - s[0][1], s[1][2] - s[0][2]};
    double b[3] = {s[2][0] - s[0][0], s[2][1] - s[0][1], s[2][2] - s[0][2]};
    double c[3] = {s[3][0] - s[0][0], s[3][1] - s[0][1], s[3][2] - s[0][2]};
    double d = a[0] * (b[1] * c[2] - b[2] * c[1]) -
               a[1] * (b[0] * c[2] - b[2] * c[0]) +
               a[2] * (b[0] * c[1] - b[1] * c[0]);
    w[i] = d;
  }
  double s = w[0] + w[1] + w[2] + w[3];
  if (!(s > 0)) return 0;
  for (int i = 0; i < 4; i++) w[i] /= s;
  return 1;
}

/* The other ends r[0], r[1] of the two feature edges at the ridge vertex
 * p (its ball[0..n)): 1 when p has exactly two, neither required. */
static int ridge_ends(const rm3d *m, pa_idx p, const pa_idx *ball, int n,
                      pa_idx *r) {
  int nr = 0;
  for (int i = 0; i < n && nr <= 2; i++) {
    const pa_idx *v = m->tv + 4 * (size_t)(ball[i] >> 2);
    for (int j = 0; j < 4 && nr <= 2; j++) {
      pa_idx x = v[j];
      if (x == p || !(m->vtag[x] & RM3D_V_FEAT)) continue;
      if (nr > 0 && (x == r[0] || (nr > 1 && x == r[1]))) continue;
      pa_idx key[2] = {p, x};
      pa_idx e = pa__rm3d_table_find(&m->edg, key);
      if (e < 0) continue;
      if (m->edg.flag[e] & PA_FLAG_REQUIRED) return 0;
      if (nr < 2) r[nr] = x;
      nr++;
    }
  }
  return nr == 2;
}

/* 1 when the ridge r[0]-p-r[1] is straight (p on the line to 1e-12), its
 * unit direction then in dir. */
static int ridge_straight(const rm3d *m, pa_idx p, const pa_idx *r,
                          double *dir) {
  const double *xp = m->x + 3 * (size_t)p, *a = m->x + 3 * (size_t)r[0],
               *b = m->x + 3 * (size_t)r[1];
  double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
  double w[3] = {xp[0] - a[0], xp[1] - a[1], xp[2] - a[2]};
  double cr[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2],
                  u[0] * w[1] - u[1] * w[0]};
  double lu = rm3d_unit(u);
  if (!(lu > 0) || rm3d_unit(cr) > 1e-12 * lu * lu) return 0;
  memcpy(dir, u, sizeof u);
  return 1;
}

int pa__rm3d_bdry_freedom(rm3d *m, pa_idx p, const pa_idx *ball, int n,
                          double *dir) {
  if (!m->surf || (m->vtag[p] & (RM3D_V_CURVED))) return 0;
  if (m->vtag[p] & RM3D_V_FEAT) {
    pa_idx r[2];
    return ridge_ends(m, p, ball, n, r) && ridge_straight(m, p, r, dir);
  }
  int found = 0;
  for (int i = 0; i < n; i++) {
    pa_idx t = ball[i] >> 2;
    int ip = ball[i] & 3;
    uint8_t fl = m->tflag[t] & RM3D_T_FACES & (uint8_t)~(1u << ip);
    if (!fl) continue;
    const pa_idx *v = m->tv + 4 * (size_t)t;
    for (int f = 0; f < 4; f++) {
      if (!((fl >> f) & 1)) continue;
      double nn[3];
      if (!(rm3d_tri_normal(m->x + 3 * (size_t)v[pa__rm3d_face[f][0]],
                            m->x + 3 * (size_t)v[pa__rm3d_face[f][1]],
                            m->x + 3 * (size_t)v[pa__rm3d_face[f][2]], nn) > 0))
        return 0;
      if (!found) {
        memcpy(dir, nn, sizeof nn);
        found = 1;
      } else if (fabs(nn[0] * dir[0] + nn[1] * dir[1] + nn[2] * dir[2]) <
                 1.0 - 1e-12) { /* both sides of an interface: opposite */
        return 0;
      }
    }
  }
  return found ? 2 : 0;
}

/* Point at barycentric (u, v, w) of the PN triangle (cubic Bezier patch) on
 * vertices P[0..2] with unit normals N[0..2]; its edges are the curves the
 * curved splits use. */
static void pn_eval(const double *const *P, const double *const *N, double u,
                    double v, double w, double *out) {
  const double *P1 = P[0], *P2 = P[1], *P3 = P[2];
  const double *N1 = N[0], *N2 = N[1], *N3 = N[2];
  double w12 = 0, w21 = 0, w23 = 0, w32 = 0, w31 = 0, w13 = 0;
  for (int i = 0; i < 3; i++) {
    w12 += (P2[i] - P1[i]) * N1[i];
    w21 += (P1[i] - P2[i]) * N2[i];
    w23 += (P3[i] - P2[i]) * N2[i];
    w32 += (P2[i] - P3[i]) * N3[i];
    w31 += (P1[i] - P3[i]) * N3[i];
    w13 += (P3[i] - P1[i]) * N1[i];
  }
  for (int i = 0; i < 3; i++) {
    double b210 = (2 * P1[i] + P2[i] - w12 * N1[i]) / 3;
    double b120 = (2 * P2[i] + P1[i] - w21 * N2[i]) / 3;
    double b021 = (2 * P2[i] + P3[i] - w23 * N2[i]) / 3;
    double b012 = (2 * P3[i] + P2[i] - w32 * N3[i]) / 3;
    double b102 = (2 * P3[i] + P1[i] - w31 * N3[i]) / 3;
    double b201 = (2 * P1[i] + P3[i] - w13 * N1[i]) / 3;
    double e = (b210 + b120 + b021 + b012 + b102 + b201) / 6;
    double vv = (P1[i] + P2[i] + P3[i]) / 3;
    double b111 = e + (e - vv) / 2;
    out[i] = P1[i] * u * u * u + P2[i] * v * v * v + P3[i] * w * w * w +
             3 * (b210 * u * u * v + b120 * u * v * v + b201 * u * u * w +
                  b021 * v * v * w + b102 * u * w * w + b012 * v * w * w) +
             6 * b111 * u * v * w;
  }
}

/* Curved patch: the point of the PN surface over the boundary triangle
 * around p whose plane projection holds y (tri[3 * i..] vertex triples);
 * its normal interpolated in *nrm_out. 0 when none holds y, a vertex has no
 * normal (ridge), or the patch leaves the flat triangle by more than hausd. */
static int curved_point(const rm3d *m, const pa_idx *tri, int ntri,
                        double hausd, const double *y, double *out,
                        double *nrm_out) {
  for (int t = 0; t < ntri; t++) {
    const pa_idx *v = tri + 3 * t;
    const double *P[3], *N[3];
    for (int j = 0; j < 3; j++) {
      P[j] = m->x + 3 * (size_t)v[j];
      N[j] = m->nrm + 3 * (size_t)v[j];
      if (!(m->vtag[v[j]] & RM3D_V_CURVED)) return 0;
    }
    double e1[3], e2[3], nn[3];
    for (int j = 0; j < 3; j++) {
      e1[j] = P[1][j] - P[0][j];
      e2[j] = P[2][j] - P[0][j];
    }
    nn[0] = e1[1] * e2[2] - e1[2] * e2[1];
    nn[1] = e1[2] * e2[0] - e1[0] * e2[2];
    nn[2] = e1[0] * e2[1] - e1[1] * e2[0];
    double a2 = nn[0] * nn[0] + nn[1] * nn[1] + nn[2] * nn[2];
    if (!(a2 > 0)) continue;
    double bc[3];
    for (int j = 0; j < 3; j++) {
      const double *q1 = P[(j + 1) % 3], *q2 = P[(j + 2) % 3];
      double a[3] = {q1[0] - y[0], q1[1] - y[1], q1[2] - y[2]};
      double b[3] = {q2[0] - y[0], q2[1] - y[1], q2[2] - y[2]};
      double c[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                     a[0] * b[1] - a[1] * b[0]};
      bc[j] = (c[0] * nn[0] + c[1] * nn[1] + c[2] * nn[2]) / a2;
    }
    if (bc[0] < -1e-9 || bc[1] < -1e-9 || bc[2] < -1e-9) continue;
    double sb = bc[0] + bc[1] + bc[2];
    for (int j = 0; j < 3; j++) bc[j] /= sb;
    pn_eval(P, N, bc[0], bc[1], bc[2], out);
    double la = sqrt(a2), d = 0;
    for (int j = 0; j < 3; j++) d += (out[j] - P[0][j]) * nn[j] / la;
    if (fabs(d) > hausd) return 0;
    double sn = 0;
    for (int j = 0; j < 3; j++) {
      nrm_out[j] = bc[0] * N[0][j] + bc[1] * N[1][j] + bc[2] * N[2][j];
      sn += nrm_out[j] * nrm_out[j];
    }
    if (!(sn > 0)) return 0;
    for (int j = 0; j < 3; j++) nrm_out[j] /= sqrt(sn);
    return 1;
  }
  return 0;
}


/* 1 if moving p to np keeps each of the ntri boundary triangles tri
 * (vertex triples holding p) valid and within RM3D_NORMAL_COS of its
 * normal before the move. */
static int surface_kept(const rm3d *m, const pa_idx *tri, int ntri, pa_idx p,
                        const double *np) {
  for (int i = 0; i < ntri; i++) {
    const double *y[3], *yn[3];
    for (int j = 0; j < 3; j++) {
      y[j] = m->x + 3 * (size_t)tri[3 * i + j];
      yn[j] = tri[3 * i + j] == p ? np : y[j];
    }
    double n0[3], n1[3];
    if (!(rm3d_tri_normal(y[0], y[1], y[2], n0) > 0)) continue;
    if (!(rm3d_tri_normal(yn[0], yn[1], yn[2], n1) > 0)) return 0;
    if (n0[0] * n1[0] + n0[1] * n1[1] + n0[2] * n1[2] < RM3D_NORMAL_COS)
      return 0;
  }
  return 1;
}

/* Move p to np (its ball[0..n) of qualities nq when isotropic): the fields
 * (and an anisotropic metric) are re-interpolated in the old ball first.
 * The tets of the ball lose their RM3D_T_CLEAN mark unless p_in_range says
 * that every edge at p is in range at np with p's metric: the other edges
 * of a tet did not change (nor did p's metric, unless re-interpolated). */
static void apply_move(rm3d *m, pa_idx p, const pa_idx *ball, int n,
                       const double *np, const float *nq, int p_in_range) {
  int mc = m->mc;
  if (m->nfield || mc == 6) {
    p_in_range = 0;
    for (int i = 0; i < n; i++) {
      const pa_idx *v = m->tv + 4 * (size_t)(ball[i] >> 2);
      double w[4];
      if (!bary(m->x + 3 * (size_t)v[0], m->x + 3 * (size_t)v[1],
                m->x + 3 * (size_t)v[2], m->x + 3 * (size_t)v[3], np, w))
        continue;
      if (w[0] < -1e-12 || w[1] < -1e-12 || w[2] < -1e-12 || w[3] < -1e-12)
        continue;
      pa__rm3d_interp(m, p, 4, v, w);
      break;
    }
  }
  memcpy(m->x + 3 * (size_t)p, np, 3 * sizeof *np);
  for (int i = 0; i < n; i++) {
    pa_idx t = ball[i] >> 2;
    m->q[t] = mc == 6 ? (float)rm3d_qual_v(m, m->tv + 4 * (size_t)t) : nq[i];
    if (!p_in_range) m->tflag[t] &= (uint8_t)~RM3D_T_CLEAN;
  }
  m->nmove++;
}

/* Restrict a displacement c to the freedom of a boundary vertex: in_plane
 * removes its component along the normal dir, on_line keeps only its
 * component along the ridge direction dir. */
static void restrict_move(double *c, const double *dir, int in_plane,
                          int on_line) {
  if (in_plane) {
    double d = c[0] * dir[0] + c[1] * dir[1] + c[2] * dir[2];
    for (int j = 0; j < 3; j++) c[j] -= d * dir[j];
  } else if (on_line) {
    double d = c[0] * dir[0] + c[1] * dir[1] + c[2] * dir[2];
    for (int j = 0; j < 3; j++) c[j] = d * dir[j];
  }
}

/* The boundary triangles of the ball[0..n) of a vertex on a curved patch
 * (vertex triples; 0 if more than 32), and in *hausdp the least Hausdorff
 * distance of their references. */
static int curved_patch(const rm3d *m, const pa_idx *ball, int n, pa_idx *tri,
                        int *ntrip, double *hausdp) {
  int ntri = 0;
  double hausd = m->hausd;
  for (int i = 0; i < n; i++) {
    pa_idx t = ball[i] >> 2;
    int ip = ball[i] & 3;
    uint8_t fl = m->tflag[t] & RM3D_T_FACES & (uint8_t)~(1u << ip);
    const pa_idx *v = m->tv + 4 * (size_t)t;
    for (int f = 0; f < 4; f++) {
      if (!((fl >> f) & 1)) continue;
      if (ntri == 32) return 0;
      for (int j = 0; j < 3; j++) tri[3 * ntri + j] = v[pa__rm3d_face[f][j]];
      ntri++;
    }
  }
  for (int t = 0; t < ntri && m->opts && m->opts->nlocal > 0; t++) {
    pa_idx r = pa__rm3d_table_find(&m->tri, tri + 3 * t);
    double h = r >= 0 ? rm3d_tri_hausd(m, r) : m->hausd;
    if (t == 0 || h < hausd) hausd = h;
  }
  *ntrip = ntri;
  *hausdp = hausd;
  return 1;
}

/* The inverse mi (xx xy yy xz yz zz) of the metric mp of mc components; 0
 * if a tensor is not positive definite. */
static int metric_inverse(int mc, const double *mp, double *mi) {
  if (mc == 1) {
    for (int j = 0; j < 6; j++) mi[j] = 0;
    mi[0] = mi[2] = mi[5] = mp[0] * mp[0];
    return 1;
  }
  double a = mp[0], b = mp[1], cc = mp[2], d = mp[3], e = mp[4], f = mp[5];
  double det = a * (cc * f - e * e) - b * (b * f - e * d) +
               d * (b * e - cc * d);
  if (!(det > 0)) return 0;
  mi[0] = (cc * f - e * e) / det;
  mi[1] = (d * e - b * f) / det;
  mi[2] = (a * f - d * d) / det;
  mi[3] = (b * e - cc * d) / det;
  mi[4] = (b * d - a * e) / det;
  mi[5] = (a * cc - b * b) / det;
  return 1;
}

/* The shift c from p to the mean of the ideal apexes over the faces of its
 * ball[0..n) opposite p, mi the inverse metric at p (the ideal apex over a
 * face with normal n sits at height sqrt(2/3) along M^-1 n /
 * sqrt(n^T M^-1 n): the regular tet of unit edges in the metric); *qoldp
 * the ball's worst quality. 0 if the ball holds a frozen element. */
static int ideal_shift(const rm3d *m, pa_idx p, const pa_idx *ball, int n,
                       const double *mi, double *qoldp, int *iworst,
                       double *c) {
  const double *xp = m->x + 3 * (size_t)p;
  double qold = 1e30;
  int iw = 0;
  c[0] = c[1] = c[2] = 0;
  int iso = m->mc <= 1;
  for (int i = 0; i < n; i++) {
    pa_idx t = ball[i] >> 2;
    int ip = ball[i] & 3;
    if (m->tflag[t] & RM3D_T_FROZEN) return 0;
    if (m->q[t] < qold) {
      qold = m->q[t];
      iw = i;
    }
    const pa_idx *v = m->tv + 4 * (size_t)t;
    const double *f0 = m->x + 3 * (size_t)v[pa__rm3d_face[ip][0]];
    const double *f1 = m->x + 3 * (size_t)v[pa__rm3d_face[ip][1]];
    const double *f2 = m->x + 3 * (size_t)v[pa__rm3d_face[ip][2]];
    /* Outward normal of the face points away from p. */
    double nn[3];
    rm3d_tri_cross(f0, f1, f2, nn);
    double dn[3];
    if (iso) { /* mi = h^2 I: the same products without the zero terms */
      dn[0] = mi[0] * nn[0];
      dn[1] = mi[0] * nn[1];
      dn[2] = mi[0] * nn[2];
    } else {
      dn[0] = mi[0] * nn[0] + mi[1] * nn[1] + mi[3] * nn[2];
      dn[1] = mi[1] * nn[0] + mi[2] * nn[1] + mi[4] * nn[2];
      dn[2] = mi[3] * nn[0] + mi[4] * nn[1] + mi[5] * nn[2];
    }
    double s2 = dn[0] * nn[0] + dn[1] * nn[1] + dn[2] * nn[2];
    double h = s2 > 0 ? 0.816496580927726 / sqrt(s2) : 0;
    for (int j = 0; j < 3; j++)
      c[j] += (f0[j] + f1[j] + f2[j]) / 3.0 - h * dn[j];
  }
  for (int j = 0; j < 3; j++) c[j] = c[j] / n - xp[j];
  *qoldp = qold;
  *iworst = iw;
  return 1;
}

/* The qualities nq[0..n) of p's ball[0..n) with p at np (metric mp), each
 * of which must be above qlo (at or above it when !strict) and at least
 * m->qabs. Returns -1 when all are, else the index of a tet that is not
 * (nq then partly filled). The tet *first is tried first and then the
 * failing one is kept there: a move's trials at shorter steps, and the
 * ball's worst tet, fail on the same tets, so most refusals take one
 * quality instead of a ball's worth. Which tets fail does not depend on
 * the order, so neither does the outcome. */
static int moved_qualities(const rm3d *m, const pa_idx *ball, int n,
                           const double *np, const double *mp, double qlo,
                           int strict, int *first, float *nq) {
  int f = *first;
  for (int k = 0; k < n; k++) {
    int i = k == 0 ? f : k == f ? 0 : k;
    double q = rm3d_qual_moved(m, ball[i] >> 2, ball[i] & 3, np, mp);
    nq[i] = (float)q;
    if (!(strict ? q > qlo : q >= qlo) || q < m->qabs) {
      *first = i;
      return i;
    }
  }
  return -1;
}

/* Move p by c, else by half or a quarter of it, to the first position
 * that raises the ball's worst quality qold (and on a curved patch, kind 3,
 * projects onto the surface of tri[0..ntri) and keeps its normals). */
static int try_smooth(rm3d *m, pa_idx p, const pa_idx *ball, int n, int kind,
                      const pa_idx *tri, int ntri, double hausd,
                      const double *c, double qold, int first) {
  const double *xp = m->x + 3 * (size_t)p;
  const double *mp = m->met + (size_t)m->mc * p;
  double np[3], step = 1.0;
  float nq[RM3D_MAXBALL];
  for (int tr = 0; tr < 3; tr++, step *= 0.5) {
    for (int j = 0; j < 3; j++) np[j] = xp[j] + step * c[j];
    double nnew[3];
    if (kind == 3) {
      double y[3];
      memcpy(y, np, sizeof y);
      if (!curved_point(m, tri, ntri, hausd, y, np, nnew)) continue;
    }
    if (kind && pa__rm3d_project_vertex(m, p, ball, n, np) < 0) continue;
    if (kind == 3 && !surface_kept(m, tri, ntri, p, np)) continue;
    if (moved_qualities(m, ball, n, np, mp, qold, 1, &first, nq) >= 0)
      continue;
    if (kind == 3) memcpy(m->nrm + 3 * (size_t)p, nnew, sizeof nnew);
    apply_move(m, p, ball, n, np, nq, 0);
    return 1;
  }
  return 0;
}

int pa__rm3d_smooth_vertex(rm3d *m, pa_idx p, const pa_idx *ball, int n) {
  if (m->vtag[p] & (RM3D_V_LOCK | RM3D_V_CORNER | RM3D_V_DEAD)) return 0;
  if ((m->vtag[p] & RM3D_V_BDRY) && !m->surf) return 0;
  if (n < 0) return 0;
  int kind = 0;
  double dir[3] = {0, 0, 0};
  pa_idx tri[3 * 32];
  int ntri = 0;
  double hausd = m->hausd;
  if ((m->vtag[p] & (RM3D_V_BDRY | RM3D_V_CURVED | RM3D_V_FEAT)) ==
          (RM3D_V_BDRY | RM3D_V_CURVED) &&
      m->surf && m->nrm) {
    /* Curved patch: move in the tangent plane, then onto the PN surface. */
    kind = 3;
    memcpy(dir, m->nrm + 3 * (size_t)p, sizeof dir);
    if (!curved_patch(m, ball, n, tri, &ntri, &hausd)) return 0;
  } else if (m->vtag[p] & RM3D_V_BDRY) {
    kind = pa__rm3d_bdry_freedom(m, p, ball, n, dir);
    if (!kind) return 0;
  }
  double mi[6], qold, c[3];
  int iworst;
  if (!metric_inverse(m->mc, m->met + (size_t)m->mc * p, mi)) return 0;
  if (!ideal_shift(m, p, ball, n, mi, &qold, &iworst, c)) return 0;
  /* on the boundary: remove the normal component, or keep the tangential
   * one along a ridge */
  restrict_move(c, dir, kind == 2 || kind == 3, kind == 1);
  return try_smooth(m, p, ball, n, kind, tri, ntri, hausd, c, qold, iworst);
}

/* Steps of a snap move toward the model (pa__rm3d_snap_vertex): the whole
 * way, then half and a quarter of it, which the next passes take on once
 * the neighbours moved (a split's model point is refused where a tet of
 * its shell lies flatter than the point's distance to the model: the
 * vertex then reaches the model in a few passes instead of never). */
#define SNAP_STEPS 3

/* 1 if moving the curved-patch vertex p to np keeps each of the ntri
 * boundary triangles tri (vertex triples holding p) valid and turning as
 * pa__rm3d_turn_ok allows. */
static int curve_surface_kept(const rm3d *m, const pa_idx *tri, int ntri,
                              pa_idx p, const double *np) {
  for (int i = 0; i < ntri; i++) {
    const double *y[3], *yn[3];
    pa_idx v[3];
    for (int j = 0; j < 3; j++) {
      v[j] = tri[3 * i + j];
      y[j] = m->x + 3 * (size_t)v[j];
      yn[j] = v[j] == p ? np : y[j];
    }
    double n0[3], n1[3];
    if (!(rm3d_tri_normal(y[0], y[1], y[2], n0) > 0)) continue;
    if (!(rm3d_tri_normal(yn[0], yn[1], yn[2], n1) > 0)) return 0;
    if (!pa__rm3d_turn_ok(m, v, n0, n1)) return 0;
  }
  return 1;
}

/* The snap moves of p (its ball ball[0..n)) by the offset d: the whole
 * way (to y0 exactly when given), then half and a quarter of it
 * (SNAP_STEPS), the first whose tets keep rm3d_q_min of the ball's worst
 * and, with tri (ntri boundary triangles), whose surface is kept
 * (curve_surface_kept). Returns the step taken + 1, or 0 (also with a
 * frozen tet in the ball). */
static int snap_steps(rm3d *m, pa_idx p, pa_idx *ball, int n, const double *d,
                      const double *y0, const pa_idx *tri, int ntri) {
  double qold = 1e30;
  for (int i = 0; i < n; i++) {
    pa_idx t = ball[i] >> 2;
    if (m->tflag[t] & RM3D_T_FROZEN) return 0;
    if (m->q[t] < qold) qold = m->q[t];
  }
  const double *xp = m->x + 3 * (size_t)p;
  const double *mp = m->met + (size_t)m->mc * p;
  float nq[RM3D_MAXBALL];
  int first = 0;
  for (int s = 0; s < SNAP_STEPS; s++) {
    double w = ldexp(1.0, -s), np[3];
    for (int j = 0; j < 3; j++) np[j] = !s && y0 ? y0[j] : xp[j] + w * d[j];
    if (tri && !curve_surface_kept(m, tri, ntri, p, np)) continue;
    if (moved_qualities(m, ball, n, np, mp, rm3d_q_min(m, qold), 0, &first,
                        nq) >= 0)
      continue;
    apply_move(m, p, ball, n, np, nq, 0);
    return s + 1;
  }
  return 0;
}

int pa__rm3d_snap_vertex(rm3d *m, pa_idx p, pa_idx *ball) {
  if (!m->voff || !m->voff[p] ||
      (m->vtag[p] & (RM3D_V_LOCK | RM3D_V_CORNER | RM3D_V_DEAD)))
    return 0;
  int n = pa__rm3d_ball(m, p, ball, RM3D_MAXBALL);
  if (n < 0) return 0;
  const double *xp = m->x + 3 * (size_t)p;
  double y[3], d[3];
  memcpy(y, xp, sizeof y);
  if (pa__rm3d_project_vertex(m, p, ball, n, y) <= 0) return 0;
  for (int j = 0; j < 3; j++) d[j] = y[j] - xp[j];
  /* The tets' quality is the only check: a boundary triangle that would
   * turn over turns its tet inside out, and one that stands up is the
   * model's own shape between points on it. */
  int r = snap_steps(m, p, ball, n, d, y, NULL, 0);
  if (r) m->voff[p] = r > 1;
  return r > 0;
}

int pa__rm3d_curve_snap_vertex(rm3d *m, pa_idx p, pa_idx *ball) {
  if (!m->vcur || (m->vtag[p] & (RM3D_V_LOCK | RM3D_V_CORNER | RM3D_V_DEAD |
                                 RM3D_V_FEAT)) ||
      !(m->vtag[p] & RM3D_V_CURVED))
    return 0;
  double *d = m->vcur + 3 * (size_t)p;
  if (d[0] == 0 && d[1] == 0 && d[2] == 0) return 0;
  int n = pa__rm3d_ball(m, p, ball, RM3D_MAXBALL);
  if (n < 0) return 0;
  pa_idx tri[3 * 32];
  int ntri;
  double hausd;
  if (!curved_patch(m, ball, n, tri, &ntri, &hausd)) return 0;
  int r = snap_steps(m, p, ball, n, d, NULL, tri, ntri);
  if (!r) return 0;
  double w = ldexp(1.0, -(r - 1));
  for (int j = 0; j < 3; j++) d[j] -= w * d[j];
  return 1;
}

int pa__rm3d_jiggle_vertex(rm3d *m, pa_idx p, double delta, pa_idx *ball) {
  if (m->vtag[p] & (RM3D_V_LOCK | RM3D_V_CORNER | RM3D_V_DEAD | RM3D_V_BDRY))
    return 0;
  int n = pa__rm3d_ball(m, p, ball, RM3D_MAXBALL);
  if (n < 0) return 0;
  int mc = m->mc;
  double *xp = m->x + 3 * (size_t)p, qold = 1e30;
  const double *mp = m->met + (size_t)mc * p;
  for (int i = 0; i < n; i++) {
    pa_idx t = ball[i] >> 2;
    if (m->tflag[t] & RM3D_T_FROZEN) return 0;
    if (m->q[t] < qold) qold = m->q[t];
  }
  double d[3];
  pa__remesh_hash_dir(xp, 3, d);
  double s2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
  /* length delta in the metric of p */
  double lm = mc == 1 ? sqrt(s2) / mp[0] : sqrt(pa__sqlen3_tensor(mp, d));
  if (!(lm > 0)) return 0;
  double np[3];
  for (int j = 0; j < 3; j++) np[j] = xp[j] + delta * d[j] / lm;
  float nq[RM3D_MAXBALL];
  for (int i = 0; i < n; i++) {
    double q = rm3d_qual_moved(m, ball[i] >> 2, ball[i] & 3, np, mp);
    if (!(q >= 0.5 * qold) || q < RM3D_QFLOOR) return 0;
    nq[i] = (float)q;
  }
  apply_move(m, p, ball, n, np, nq, 0);
  return 1;
}

/* ---- relocation for lengths -------------------------------------------- */

/* Lengths l[0..nn) of the edges from p at y (metric mp) to its neighbours
 * nb[0..nn); returns how many are out of [PA_METRIC_LEN_LO_EXACT,
 * PA_METRIC_LEN_HI_EXACT), or stops at limit + 1 of them (l then partly
 * filled). */
static int len_out(const rm3d *m, const double *y, const double *mp,
                   const pa_idx *nb, const double *inb, int nn, int limit,
                   double *l) {
  int out = 0, mc = m->mc;
  double ip = mc == 1 ? 1.0 / mp[0] : 0;
  for (int i = 0; i < nn && out <= limit; i++) {
    /* with sizes pa__len3 is pa__len3_inv of the inverses, taken once */
    l[i] = mc == 1 ? pa__len3_inv(y, m->x + 3 * (size_t)nb[i], ip, inb[i])
                   : pa__len3(mc, y, m->x + 3 * (size_t)nb[i], mp,
                              m->met + (size_t)mc * nb[i]);
    out += !(l[i] >= PA_METRIC_LEN_LO_EXACT && l[i] < PA_METRIC_LEN_HI_EXACT);
  }
  return out;
}

/* Sum of ln^2 l[i] over i < nn; with lg, also the logarithms. */
static double len_sum(const double *l, int nn, double *lg) {
  double s = 0;
  for (int i = 0; i < nn; i++) {
    double g = log(l[i]);
    if (lg) lg[i] = g;
    s += g * g;
  }
  return s;
}

/* 1 if len_sum(l, nn) < bound; stops at the first partial sum at or
 * above it (the terms are not negative, so the partial sums never
 * decrease: the same answer, fewer logarithms). */
static int len_sum_below(const double *l, int nn, double bound) {
  double s = 0;
  for (int i = 0; i < nn; i++) {
    double g = log(l[i]);
    s += g * g;
    if (s >= bound) return 0;
  }
  return s < bound;
}

/* Solve the symmetric 3x3 system a x = b (a: xx xy yy xz yz zz); 0 if
 * singular. */
static int solve3(const double *a, const double *b, double *x) {
  double c0 = a[2] * a[5] - a[4] * a[4], c1 = a[3] * a[4] - a[1] * a[5],
         c2 = a[1] * a[4] - a[2] * a[3];
  double det = a[0] * c0 + a[1] * c1 + a[3] * c2;
  if (!(fabs(det) > 0)) return 0;
  double i01 = c1, i02 = c2, i11 = a[0] * a[5] - a[3] * a[3],
         i12 = a[1] * a[3] - a[0] * a[4], i22 = a[0] * a[2] - a[1] * a[1];
  x[0] = (c0 * b[0] + i01 * b[1] + i02 * b[2]) / det;
  x[1] = (i01 * b[0] + i11 * b[1] + i12 * b[2]) / det;
  x[2] = (i02 * b[0] + i12 * b[1] + i22 * b[2]) / det;
  return isfinite(x[0]) && isfinite(x[1]) && isfinite(x[2]);
}

/* What a length relocation of p compares with: its neighbours, each once,
 * the number of edges at p out of range and their sum of ln^2 L, and the
 * ball's worst quality. */
typedef struct len_ctx {
  pa_idx nb[RM3D_LNB];
  double inb[RM3D_LNB]; /* with sizes: 1 / the size of nb[i] */
  double l0[RM3D_LNB], lg0[RM3D_LNB]; /* lengths from p and their logs */
  int nn, out0;
  int iworst; /* the ball's worst tet */
  double s0, qold;
} len_ctx;

/* The neighbours of p in its ball[0..n), each once (in the order the ball
 * meets them), and the ball's worst quality; 0 if the ball holds a frozen
 * element or has more than RM3D_LNB neighbours. */
static int ball_neighbours(rm3d *m, pa_idx p, const pa_idx *ball, int n,
                           len_ctx *lc) {
  pa_idx *nb = lc->nb;
  int nn = 0, ok = 1, iw = 0;
  double qold = 1e30;
  for (int i = 0; i < n && ok; i++) {
    pa_idx t = ball[i] >> 2;
    if (m->tflag[t] & RM3D_T_FROZEN) ok = 0;
    if (m->q[t] < qold) {
      qold = m->q[t];
      iw = i;
    }
    const pa_idx *v = m->tv + 4 * (size_t)t;
    for (int j = 0; j < 4 && ok; j++) {
      pa_idx x = v[j];
      if (x == p || (m->vtag[x] & RM3D_V_MARK)) continue;
      if (nn == RM3D_LNB) ok = 0;
      else {
        m->vtag[x] |= RM3D_V_MARK;
        nb[nn++] = x;
      }
    }
  }
  for (int i = 0; i < nn; i++) m->vtag[nb[i]] &= (uint8_t)~RM3D_V_MARK;
  if (m->mc == 1)
    for (int i = 0; i < nn; i++) lc->inb[i] = 1.0 / m->met[nb[i]];
  lc->nn = nn;
  lc->qold = qold;
  lc->iworst = iw;
  return ok;
}

/* Gauss-Newton step d on r_i = ln L_i over the edges from p to nb[0..nn):
 * d ln L_i / dx = -M e / (e^T M e), e = x_i - x, M the mean of the two end
 * metrics; Levenberg damping relative to the system's scale. 0 if an edge
 * is degenerate or the system singular. */
static int gauss_newton_step(const rm3d *m, pa_idx p, const len_ctx *lc,
                             double *d) {
  const pa_idx *nb = lc->nb;
  int nn = lc->nn;
  int mc = m->mc;
  const double *xp = m->x + 3 * (size_t)p;
  const double *mp = m->met + (size_t)mc * p;
  double jj[6] = {0, 0, 0, 0, 0, 0}, jr[3] = {0, 0, 0};
  for (int i = 0; i < nn; i++) {
    const double *xi = m->x + 3 * (size_t)nb[i];
    const double *mi = m->met + (size_t)mc * nb[i];
    double e[3] = {xi[0] - xp[0], xi[1] - xp[1], xi[2] - xp[2]}, g[3];
    if (mc == 1) {
      double s = e[0] * e[0] + e[1] * e[1] + e[2] * e[2];
      if (!(s > 0)) return 0;
      for (int j = 0; j < 3; j++) g[j] = -e[j] / s;
    } else {
      double a[6];
      for (int j = 0; j < 6; j++) a[j] = 0.5 * (mp[j] + mi[j]);
      double me[3] = {a[0] * e[0] + a[1] * e[1] + a[3] * e[2],
                      a[1] * e[0] + a[2] * e[1] + a[4] * e[2],
                      a[3] * e[0] + a[4] * e[1] + a[5] * e[2]};
      double s = me[0] * e[0] + me[1] * e[1] + me[2] * e[2];
      if (!(s > 0)) return 0;
      for (int j = 0; j < 3; j++) g[j] = -me[j] / s;
    }
    double r = lc->lg0[i];
    jj[0] += g[0] * g[0];
    jj[1] += g[0] * g[1];
    jj[2] += g[1] * g[1];
    jj[3] += g[0] * g[2];
    jj[4] += g[1] * g[2];
    jj[5] += g[2] * g[2];
    for (int j = 0; j < 3; j++) jr[j] -= g[j] * r;
  }
  double lam = 1e-3 * (jj[0] + jj[2] + jj[5]);
  jj[0] += lam;
  jj[2] += lam;
  jj[5] += lam;
  return solve3(jj, jr, d);
}

/* The second candidate d2: along the edge from p to nb[0..nn) furthest out
 * of range, by the fraction that brings it to unit length (at most half). */
static void worst_edge_step(const rm3d *m, pa_idx p, const len_ctx *lc,
                            double *d2) {
  const double *xp = m->x + 3 * (size_t)p;
  double worst = 0;
  d2[0] = d2[1] = d2[2] = 0;
  for (int i = 0; i < lc->nn; i++) {
    const double *xi = m->x + 3 * (size_t)lc->nb[i];
    double l = lc->l0[i];
    double g = fabs(lc->lg0[i]);
    if (g <= worst) continue;
    worst = g;
    double f = l > 1 ? 1 - 1 / l : l - 1; /* < 0: away from x_i */
    if (f > 0.5) f = 0.5;
    if (f < -0.5) f = -0.5;
    for (int j = 0; j < 3; j++) d2[j] = f * (xi[j] - xp[j]);
  }
}

/* Move p to np when a length move may go there: fewer edges at p out of
 * range (or as many and a sum of ln^2 L less by RM3D_LGAIN), and no tet of
 * the ball below qfloor (*first: see moved_qualities). n if moved, else 0. */
static int length_accept(rm3d *m, pa_idx p, const pa_idx *ball, int n,
                         const len_ctx *lc, const double *np, double qfloor,
                         int *first) {
  const double *mp = m->met + (size_t)m->mc * p;
  float nq[RM3D_MAXBALL];
  double l1[RM3D_LNB];
  int out1 = len_out(m, np, mp, lc->nb, lc->inb, lc->nn, lc->out0, l1);
  if (out1 > lc->out0 ||
      (out1 == lc->out0 && !len_sum_below(l1, lc->nn, RM3D_LGAIN * lc->s0)))
    return 0;
  if (moved_qualities(m, ball, n, np, mp, qfloor, 0, first, nq) >= 0)
    return 0;
  /* out1 = 0: every edge at p in [LO, HI) */
  apply_move(m, p, ball, n, np, nq, out1 == 0);
  return n;
}

/* Move p by d, then by d2, each at steps 1, 1/2, 1/4, 1/8, to the first
 * position length_accept takes. */
static int try_length_moves(rm3d *m, pa_idx p, const pa_idx *ball, int n,
                            int kind,
                            const double *dir, const len_ctx *lc,
                            const double *d, const double *d2) {
  const double *xp = m->x + 3 * (size_t)p;
  double qfloor = fmin(lc->qold, RM3D_QLEN), np[3], step = 1.0;
  int first = lc->iworst;
  for (int tr = 0; tr < 8; tr++, step *= 0.5) {
    if (tr == 4) step = 1.0;
    const double *dd = tr < 4 ? d : d2;
    for (int j = 0; j < 3; j++) np[j] = xp[j] + step * dd[j];
    if (kind == 2) /* an axis plane keeps its coordinate bit for bit */
      for (int j = 0; j < 3; j++)
        if (fabs(dir[j]) == 1.0) np[j] = xp[j];
    if (kind && pa__rm3d_project_vertex(m, p, ball, n, np) < 0) continue;
    if (length_accept(m, p, ball, n, lc, np, qfloor, &first)) return n;
  }
  return 0;
}

/* Bisection steps of the balanced point on a ridge's circle (the angle
 * to 1e-12 of its range). */
#define ARC_BISECT 40

/* A vertex p of a curved ridge between its feature neighbours r[0] and
 * r[1] moves on the circle through the three, to where its two ridge edges
 * have the same length in the metric (where the collapse of a short ridge
 * edge is refused because the neighbour edge would grow past sqrt 2, this
 * evens the two out), else half or a quarter of the way. A position is
 * taken as the other length moves take theirs (fewer edges out of range,
 * or as many and a sum of ln^2 L less by RM3D_LGAIN, the ball's quality
 * kept), within hausd of the old ridge, every boundary triangle at p
 * turning by less than RM3D_NORMAL_COS, and on the model if there is one. */
static int ridge_arc_move(rm3d *m, pa_idx p, const pa_idx *ball, int n,
                          const pa_idx *r, const len_ctx *lc) {
  const double *xp = m->x + 3 * (size_t)p, *xa = m->x + 3 * (size_t)r[0],
               *xb = m->x + 3 * (size_t)r[1];
  const double *mp = m->met + (size_t)m->mc * p;
  const double *ma = m->met + (size_t)m->mc * r[0];
  const double *mb = m->met + (size_t)m->mc * r[1];
  double u[3] = {xa[0] - xp[0], xa[1] - xp[1], xa[2] - xp[2]};
  double w[3] = {xb[0] - xp[0], xb[1] - xp[1], xb[2] - xp[2]};
  double z[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2],
                 u[0] * w[1] - u[1] * w[0]};
  double zz = z[0] * z[0] + z[1] * z[1] + z[2] * z[2];
  double uu = u[0] * u[0] + u[1] * u[1] + u[2] * u[2];
  double ww = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
  if (!(zz > 1e-24 * uu * ww)) return 0; /* straight: bdry_freedom's */
  /* the circle: centre c = p + (uu w - ww u) x z / (2 zz), p at angle 0 */
  double g[3] = {uu * w[0] - ww * u[0], uu * w[1] - ww * u[1],
                 uu * w[2] - ww * u[2]};
  double c[3], e1[3], e2[3];
  c[0] = xp[0] + (g[1] * z[2] - g[2] * z[1]) / (2 * zz);
  c[1] = xp[1] + (g[2] * z[0] - g[0] * z[2]) / (2 * zz);
  c[2] = xp[2] + (g[0] * z[1] - g[1] * z[0]) / (2 * zz);
  for (int j = 0; j < 3; j++) e1[j] = xp[j] - c[j];
  double rad = rm3d_unit(e1);
  rm3d_unit(z);
  e2[0] = z[1] * e1[2] - z[2] * e1[1];
  e2[1] = z[2] * e1[0] - z[0] * e1[2];
  e2[2] = z[0] * e1[1] - z[1] * e1[0];
  double ang[2];
  for (int s = 0; s < 2; s++) {
    const double *y = s ? xb : xa;
    double d[3] = {y[0] - c[0], y[1] - c[1], y[2] - c[2]};
    ang[s] = atan2(d[0] * e2[0] + d[1] * e2[1] + d[2] * e2[2],
                   d[0] * e1[0] + d[1] * e1[1] + d[2] * e1[2]);
  }
  if (!(ang[0] * ang[1] < 0)) return 0; /* p not between a and b */
  /* the balanced angle: len(a, P) - len(P, b) changes sign between a and b */
  double lo = ang[0], hi = ang[1], np[3];
  for (int it = 0; it < ARC_BISECT; it++) {
    double t = 0.5 * (lo + hi);
    for (int j = 0; j < 3; j++)
      np[j] = c[j] + rad * (cos(t) * e1[j] + sin(t) * e2[j]);
    double f = pa__len3(m->mc, xa, np, ma, mp) - pa__len3(m->mc, np, xb, mp, mb);
    if (f < 0) lo = t;
    else hi = t;
  }
  double target = 0.5 * (lo + hi), hausd, qfloor = fmin(lc->qold, RM3D_QLEN);
  pa_idx tri[3 * 32];
  int ntri, first = lc->iworst;
  if (!curved_patch(m, ball, n, tri, &ntri, &hausd)) return 0;
  for (int tr = 0; tr < 3; tr++) {
    double t = target / (double)(1 << tr);
    for (int j = 0; j < 3; j++)
      np[j] = c[j] + rad * (cos(t) * e1[j] + sin(t) * e2[j]);
    if (pa__rm3d_project_vertex(m, p, ball, n, np) < 0) continue;
    /* within hausd of the old ridge a-p-b */
    double dmin = 1e300;
    for (int s = 0; s < 2; s++) {
      const double *y = s ? xb : xa;
      double e[3] = {y[0] - xp[0], y[1] - xp[1], y[2] - xp[2]};
      double q[3] = {np[0] - xp[0], np[1] - xp[1], np[2] - xp[2]};
      double ee = e[0] * e[0] + e[1] * e[1] + e[2] * e[2];
      double k = (q[0] * e[0] + q[1] * e[1] + q[2] * e[2]) / ee;
      k = k < 0 ? 0 : k > 1 ? 1 : k;
      double d2 = 0;
      for (int j = 0; j < 3; j++) d2 += (q[j] - k * e[j]) * (q[j] - k * e[j]);
      if (d2 < dmin) dmin = d2;
    }
    if (dmin > hausd * hausd) continue;
    if (!surface_kept(m, tri, ntri, p, np)) continue;
    if (length_accept(m, p, ball, n, lc, np, qfloor, &first)) return n;
  }
  return 0;
}

int pa__rm3d_length_vertex(rm3d *m, pa_idx p, const pa_idx *ball, int n) {
  if (m->vtag[p] & (RM3D_V_LOCK | RM3D_V_CORNER | RM3D_V_DEAD | RM3D_V_CURVED))
    return 0;
  if ((m->vtag[p] & RM3D_V_BDRY) && !m->surf) return 0;
  if (n < 0) return 0;
  int kind = 0, arc = 0;
  double dir[3] = {0, 0, 0};
  pa_idx r[2];
  if (m->vtag[p] & RM3D_V_FEAT) {
    /* along a straight ridge, or on a curved one's circle (ridge_arc_move) */
    if (!ridge_ends(m, p, ball, n, r)) return 0;
    kind = ridge_straight(m, p, r, dir);
    arc = !kind;
  } else if (m->vtag[p] & RM3D_V_BDRY) {
    kind = pa__rm3d_bdry_freedom(m, p, ball, n, dir);
    if (!kind) return 0;
  }
  len_ctx lc;
  if (!ball_neighbours(m, p, ball, n, &lc)) return 0;
  lc.out0 = len_out(m, m->x + 3 * (size_t)p, m->met + (size_t)m->mc * p,
                    lc.nb, lc.inb, lc.nn, lc.nn, lc.l0);
  if (lc.out0 == 0) return 0;
  lc.s0 = len_sum(lc.l0, lc.nn, lc.lg0);
  if (arc) return ridge_arc_move(m, p, ball, n, r, &lc);
  /* two candidates, each kept in the plane (kind 2) or along the ridge
   * (kind 1) of a boundary vertex */
  double d[3], d2[3];
  if (!gauss_newton_step(m, p, &lc, d)) return 0;
  restrict_move(d, dir, kind == 2, kind == 1);
  worst_edge_step(m, p, &lc, d2);
  restrict_move(d2, dir, kind == 2, kind == 1);
  return try_length_moves(m, p, ball, n, kind, dir, &lc, d, d2);
}
