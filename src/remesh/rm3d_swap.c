/*
 * rm3d_swap.c -- topological swaps: edge removal (3-2 for a shell of three,
 * n -> 2n-4 for closed shells of up to 7 tets, choosing the triangulation of
 * the ring that maximises the worst quality by dynamic programming, as in
 * Shewchuk's "Two discrete optimization algorithms for the topological
 * improvement of tetrahedral meshes") and the 2-3 face swap.
 *
 * Checked before applied: closed shell, no boundary triangle containing the
 * edge, no frozen tet, one reference; the new worst quality exceeds gain
 * times the old one (gain >= 1), so a swap never lowers the worst quality.
 */
#include "remesh/remesh3d.h"

#define R3_SWAP_MAXRING 7

pa_status pa__rm3d_swap_edge(rm3d *m, pa_idx k, pa_idx a, pa_idx b,
                             double gain, int *done) {
  pa_status st = PA_SUCCESS;
  pa_idx tets[R3_SWAP_MAXRING], ring[R3_SWAP_MAXRING + 1];
  float tq[R3_SWAP_MAXRING][R3_SWAP_MAXRING][R3_SWAP_MAXRING];
  float best[R3_SWAP_MAXRING][R3_SWAP_MAXRING];
  signed char arg[R3_SWAP_MAXRING][R3_SWAP_MAXRING];
  *done = 0;
  int info;
  int n = pa__rm3d_shell(m, k, a, b, tets, ring, R3_SWAP_MAXRING, &info);
  if (n < 3 || !(info & R3SH_CLOSED) ||
      (info & (R3SH_BDRY | R3SH_FROZEN | R3SH_REFS)))
    return st;
  double qold = 1e30;
  for (int i = 0; i < n; i++)
    if (m->q[tets[i]] < qold) qold = m->q[tets[i]];
  double target = gain * qold;
  int mc = m->mc;
  const double *xa = m->x + 3 * (size_t)a, *xb = m->x + 3 * (size_t)b;
  const double *ma = m->met + (size_t)mc * a, *mb = m->met + (size_t)mc * b;
  /* Quality of the two tets over each ring triangle (i < j < l). */
  for (int i = 0; i < n; i++)
    for (int j = i + 1; j < n; j++)
      for (int l = j + 1; l < n; l++) {
        const double *xi = m->x + 3 * (size_t)ring[i];
        const double *xj = m->x + 3 * (size_t)ring[j];
        const double *xl = m->x + 3 * (size_t)ring[l];
        const double *mi = m->met + (size_t)mc * ring[i];
        const double *mj = m->met + (size_t)mc * ring[j];
        const double *ml = m->met + (size_t)mc * ring[l];
        double q1 = rm3d_qual_pts(mc, xi, xj, xl, xb, mi, mj, ml, mb);
        double q2 = q1 > target
                        ? rm3d_qual_pts(mc, xi, xl, xj, xa, mi, ml, mj, ma)
                        : q1;
        tq[i][j][l] = (float)(q1 < q2 ? q1 : q2);
      }
  /* best[i][j]: best worst quality triangulating ring[i..j] (j - i >= 2). */
  for (int len = 2; len < n; len++)
    for (int i = 0; i + len < n; i++) {
      int j = i + len;
      float bq = -1;
      signed char bk = -1;
      for (int l = i + 1; l < j; l++) {
        float v = tq[i][l][j];
        if (l - i >= 2 && best[i][l] < v) v = best[i][l];
        if (j - l >= 2 && best[l][j] < v) v = best[l][j];
        if (v > bq) {
          bq = v;
          bk = (signed char)l;
        }
      }
      best[i][j] = bq;
      arg[i][j] = bk;
    }
  if (!(best[0][n - 1] > target) || best[0][n - 1] < RM3D_QABS) return st;
  /* Rebuild the triangulation and the new tets. */
  pa_idx nv4[4 * 2 * (R3_SWAP_MAXRING - 2)];
  int nnew = 0;
  int stack[2 * R3_SWAP_MAXRING], sp = 0;
  stack[sp++] = 0;
  stack[sp++] = n - 1;
  while (sp) {
    int j = stack[--sp], i = stack[--sp];
    if (j - i < 2) continue;
    int l = arg[i][j];
    pa_idx *t1 = nv4 + 4 * nnew++, *t2 = nv4 + 4 * nnew++;
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
  PA_CALL(pa__rm3d_replace(m, tets, n, nv4, nnew, m->tref[tets[0]],
                           m->tpf[tets[0]]));
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
  if ((m->tflag[k] | m->tflag[l]) & R3T_FROZEN) return st;
  if (m->tref[k] != m->tref[l]) return st;
  const pa_idx *vk = m->tv + 4 * (size_t)k;
  pa_idx d = vk[f], e = m->tv[4 * (size_t)l + (o & 3)];
  pa_idx fv[3] = {vk[rm3d_face[f][0]], vk[rm3d_face[f][1]],
                  vk[rm3d_face[f][2]]};
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
    if (!(q > target) || q < RM3D_QABS) return st;
  }
  pa_idx old[2] = {k, l};
  PA_CALL(pa__rm3d_replace(m, old, 2, nv4, 3, m->tref[k], m->tpf[k]));
  m->nswap++;
  *done = 1;
cleanup:
  return st;
}
