/*
 * model_3d.c -- the 3D remesher's calls onto the model of a classified mesh
 * (pa_remesh_opts.geometry, through pa__remesh_project): the entity a new
 * or moved boundary point lies on, read from the boundary records around
 * it (a feature edge: its curve; else a boundary triangle: its surface),
 * and the projection of the point onto it. The operators call these where
 * they compute the point (split_3d.c, smooth_3d.c, collapse_3d.c).
 */
#include "geom/geom.h"
#include "remesh3d/remesh3d.h"

/* The entity of boundary vertex p, from its ball[0..n): the curve of a
 * feature edge at p of positive reference, else the surface of a boundary
 * triangle at p; *scale the longest edge at p seen. 0 when none. */
static int vertex_entity(const rm3d *m, pa_idx p, const pa_idx *ball, int n,
                         int *dim, int32_t *tag, double *scale) {
  const double *xp = m->x + 3 * (size_t)p;
  int found = 0;
  *scale = 0;
  for (int i = 0; i < n; i++) {
    pa_idx t = ball[i] >> 2;
    int ip = ball[i] & 3;
    const pa_idx *v = m->tv + 4 * (size_t)t;
    for (int j = 0; j < 4; j++) {
      if (j == ip) continue;
      const double *xj = m->x + 3 * (size_t)v[j];
      double d = sqrt((xj[0] - xp[0]) * (xj[0] - xp[0]) +
                      (xj[1] - xp[1]) * (xj[1] - xp[1]) +
                      (xj[2] - xp[2]) * (xj[2] - xp[2]));
      if (d > *scale) *scale = d;
      if (found == 1 || !(m->vtag[v[j]] & RM3D_V_FEAT)) continue;
      pa_idx key[2] = {p, v[j]};
      pa_idx r = pa__rm3d_table_find(&m->edg, key);
      if (r >= 0 && m->edg.ref[r] > 0) {
        *dim = 1;
        *tag = m->edg.ref[r];
        found = 1;
      }
    }
    if (found) continue;
    for (int f = 0; f < 4; f++) {
      if (f == ip || !((m->tflag[t] >> f) & 1)) continue;
      pa_idx key[3];
      for (int j = 0; j < 3; j++) key[j] = v[pa__rm3d_face[f][j]];
      pa_idx r = pa__rm3d_table_find(&m->tri, key);
      if (r >= 0 && m->tri.ref[r] > 0 && !found) {
        *dim = 2;
        *tag = m->tri.ref[r];
        found = 2;
      }
    }
  }
  return found != 0;
}

int pa__rm3d_project_vertex(const rm3d *m, pa_idx p, const pa_idx *ball,
                            int n, double *x) {
  int dim = 0;
  int32_t tag = 0;
  double scale;
  if (!m->opts || !m->opts->geometry || !(m->vtag[p] & RM3D_V_BDRY) ||
      !vertex_entity(m, p, ball, n, &dim, &tag, &scale))
    return 0;
  return pa__remesh_project(m->opts, dim, tag, 3, x, scale, x);
}

void pa__rm3d_mark_off_model(rm3d *m) {
  pa_idx ball[RM3D_MAXBALL];
  double tol = PA_GEOM_SNAP_TOL * m->opts->geometry->size;
  for (pa_idx p = 0; p < m->nv; p++) {
    if ((m->vtag[p] & (RM3D_V_LOCK | RM3D_V_CORNER | RM3D_V_DEAD)) ||
        !(m->vtag[p] & RM3D_V_BDRY))
      continue;
    int n = pa__rm3d_ball(m, p, ball, RM3D_MAXBALL);
    double y[3];
    const double *x = m->x + 3 * (size_t)p;
    memcpy(y, x, sizeof y);
    if (n < 0 || pa__rm3d_project_vertex(m, p, ball, n, y) <= 0) continue;
    double d = sqrt((y[0] - x[0]) * (y[0] - x[0]) +
                    (y[1] - x[1]) * (y[1] - x[1]) +
                    (y[2] - x[2]) * (y[2] - x[2]));
    m->voff[p] = d > tol;
  }
}

int pa__rm3d_project_split(const rm3d *m, pa_idx erec, const pa_idx *trec,
                           int ntri, pa_idx a, pa_idx b, double *x) {
  if (!m->opts || !m->opts->geometry || (erec < 0 && ntri == 0)) return 0;
  const double *xa = m->x + 3 * (size_t)a, *xb = m->x + 3 * (size_t)b;
  double l = sqrt((xb[0] - xa[0]) * (xb[0] - xa[0]) +
                  (xb[1] - xa[1]) * (xb[1] - xa[1]) +
                  (xb[2] - xa[2]) * (xb[2] - xa[2]));
  if (erec >= 0)
    return pa__remesh_project(m->opts, 1, m->edg.ref[erec], 3, x, l, x);
  return pa__remesh_project(m->opts, 2, m->tri.ref[trec[0]], 3, x, l, x);
}
