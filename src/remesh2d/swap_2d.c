/*
 * swap_2d.c -- edge swap of the 2D remesher (the diagonal of the pair of
 * elements on an edge turned, when the pair's worst quality rises). Feature
 * edges are never swapped. Its passes (and the pass on the worst elements)
 * are in driver_2d.c. Shared contract of the operators: ops_2d.h.
 */
#include "remesh2d/ops_2d.h"

/* Swap face i of k if it raises the worst quality of the pair by the factor
 * gain. Returns 1 if done. */
int pa__rm2d_swap_edge(rm2d *rm, pa_idx k, int i, double gain) {
  pa_idx o = rm->adj[3 * k + i];
  if (o < 0) return 0;
  pa_idx f = o / 3;
  int j = o % 3;
  if ((rm->tflag[k] | rm->tflag[f]) & RM2D_E_FROZEN) return 0;
  int i1 = RM2D_NX3(i), i2 = RM2D_PV3(i), j1 = RM2D_NX3(j), j2 = RM2D_PV3(j);
  pa_idx p0 = rm->tv[3 * k + i], a = rm->tv[3 * k + i1], b = rm->tv[3 * k + i2];
  pa_idx p1 = rm->tv[3 * f + j];
  double qo = rm->q[k] < rm->q[f] ? rm->q[k] : rm->q[f];
  const double fl = rm2d_qfloor(qo);
  double q1 = rm2d_elem_qual(rm, p0, a, p1);
  if (q1 <= gain * qo || !rm2d_qual_ok(rm, q1, fl, p0, a, p1)) return 0;
  double q2 = rm2d_elem_qual(rm, p1, b, p0);
  if (q2 <= gain * qo || !rm2d_qual_ok(rm, q2, fl, p1, b, p0)) return 0;
  pa_idx oA = rm->adj[3 * k + i1], oB = rm->adj[3 * k + i2];
  pa_idx fB = rm->adj[3 * f + j1], fA = rm->adj[3 * f + j2];
  /* T1 = k (p0 a p1), T2 = f (p1 b p0) */
  rm2d_elem_changed(rm, k);
  rm2d_elem_changed(rm, f);
  rm2d_set_elem(rm, k, p0, a, p1, q1);
  rm2d_set_elem(rm, f, p1, b, p0, q2);
  rm2d_attach(rm, 3 * k, fB, 3 * f + j1);
  rm2d_attach(rm, 3 * k + 2, oB, 3 * k + i2);
  rm2d_attach(rm, 3 * f, oA, 3 * k + i1);
  rm2d_attach(rm, 3 * f + 2, fA, 3 * f + j2);
  rm->adj[3 * k + 1] = 3 * f + 1;
  rm->adj[3 * f + 1] = 3 * k + 1;
  rm->nswap++;
  return 1;
}
