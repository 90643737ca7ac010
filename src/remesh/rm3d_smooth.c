/*
 * rm3d_smooth.c -- vertex relocation. An interior free vertex moves towards
 * the mean of the "ideal points" of its ball (for each tet, the apex of the
 * regular tet standing on the opposite face); the move is accepted only when
 * the worst quality of the ball rises, halving the step up to three times.
 * Locked, corner and boundary vertices never move here, so frozen entities
 * and the boundary surface are untouched. The moved vertex's metric and
 * fields are re-interpolated in the old ball (metric only when anisotropic:
 * an isotropic size field is treated as attached to the vertex).
 */
#include "remesh/remesh3d.h"

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

int pa__rm3d_smooth_vertex(rm3d *m, pa_idx p, pa_idx *ball) {
  if (m->vtag[p] & (R3V_LOCK | R3V_CORNER | R3V_BDRY | R3V_DEAD)) return 0;
  int n = pa__rm3d_ball(m, p, ball, RM3D_MAXBALL);
  if (n < 0) return 0;
  int mc = m->mc;
  double *xp = m->x + 3 * (size_t)p;
  double qold = 1e30, c[3] = {0, 0, 0};
  int32_t ref0 = m->tref[ball[0] >> 2];
  for (int i = 0; i < n; i++) {
    pa_idx t = ball[i] >> 2;
    int ip = ball[i] & 3;
    if (m->tref[t] != ref0 || (m->tflag[t] & R3T_FROZEN)) return 0;
    if (m->q[t] < qold) qold = m->q[t];
    const pa_idx *v = m->tv + 4 * (size_t)t;
    const double *f0 = m->x + 3 * (size_t)v[rm3d_face[ip][0]];
    const double *f1 = m->x + 3 * (size_t)v[rm3d_face[ip][1]];
    const double *f2 = m->x + 3 * (size_t)v[rm3d_face[ip][2]];
    double u[3] = {f1[0] - f0[0], f1[1] - f0[1], f1[2] - f0[2]};
    double w[3] = {f2[0] - f0[0], f2[1] - f0[1], f2[2] - f0[2]};
    double z[3] = {f2[0] - f1[0], f2[1] - f1[1], f2[2] - f1[2]};
    /* Outward normal of the face points away from p. */
    double nn[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2],
                    u[0] * w[1] - u[1] * w[0]};
    double ln = sqrt(nn[0] * nn[0] + nn[1] * nn[1] + nn[2] * nn[2]);
    double le = (sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]) +
                 sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]) +
                 sqrt(z[0] * z[0] + z[1] * z[1] + z[2] * z[2])) /
                3.0;
    double h = le * 0.816496580927726 / (ln > 0 ? ln : 1);
    for (int j = 0; j < 3; j++)
      c[j] += (f0[j] + f1[j] + f2[j]) / 3.0 - h * nn[j];
  }
  for (int j = 0; j < 3; j++) c[j] /= n;
  double np[3], step = 1.0;
  float nq[RM3D_MAXBALL];
  const double *mp = m->met + (size_t)mc * p;
  for (int tr = 0; tr < 3; tr++, step *= 0.5) {
    for (int j = 0; j < 3; j++) np[j] = xp[j] + step * (c[j] - xp[j]);
    int ok = 1;
    for (int i = 0; i < n && ok; i++) {
      pa_idx t = ball[i] >> 2;
      int ip = ball[i] & 3;
      const pa_idx *v = m->tv + 4 * (size_t)t;
      const double *px[4], *pm[4];
      for (int j = 0; j < 4; j++) {
        px[j] = m->x + 3 * (size_t)v[j];
        pm[j] = m->met + (size_t)mc * v[j];
      }
      px[ip] = np;
      pm[ip] = mp;
      double q = rm3d_qual_pts(mc, px[0], px[1], px[2], px[3], pm[0], pm[1],
                               pm[2], pm[3]);
      if (!(q > qold) || q < RM3D_QABS) ok = 0;
      nq[i] = (float)q;
    }
    if (!ok) continue;
    /* Accepted: re-interpolate in the old ball, then move. */
    if (m->nfield || mc == 6) {
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
    memcpy(xp, np, sizeof np);
    for (int i = 0; i < n; i++) {
      pa_idx t = ball[i] >> 2;
      m->q[t] = mc == 6 ? (float)rm3d_qual_v(m, m->tv + 4 * (size_t)t) : nq[i];
    }
    m->nmove++;
    return 1;
  }
  return 0;
}
