/*
 * swap_2d.c -- edge swap of the 2D remesher (the diagonal of the pair of
 * elements on an edge turned, when the pair's worst quality rises), its
 * pass, and the pass on the worst elements (swap, else collapse of the
 * shortest edge when the ball's worst quality rises). Feature edges are
 * never swapped. Shared contract of the operators: ops_2d.h.
 */
#include "remesh2d/ops_2d.h"

/* Swap face i of k if it raises the worst quality of the pair by the factor
 * gain. Returns 1 if done. */
static int swap_edge(rm2d *rm, pa_idx k, int i, double gain) {
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

/* The first element slot from k on, or rm->ne, with quality below qmax and
 * none of the tag bits `skip`: the scan of the swap passes, reading the
 * arrays once (see rm2d_tflag_clear). */
static pa_idx next_below(const rm2d *rm, pa_idx k, uint8_t skip, double qmax) {
  const uint8_t *t = rm->tflag;
  const float *q = rm->q;
  const pa_idx n = rm->ne;
  while (k < n && ((t[k] & skip) || q[k] >= qmax)) k++;
  return k;
}

long pa__rm2d_swap_pass(rm2d *rm, double qmax) {
  long cnt = 0;
  rm2d_tflag_clear(rm, RM2D_E_TOUCHED);
  const uint8_t skip =
      RM2D_E_DEAD | RM2D_E_TOUCHED | RM2D_E_FROZEN | RM2D_E_NOSWAP;
  for (pa_idx k = next_below(rm, 0, skip, qmax); k < rm->ne;
       k = next_below(rm, k + 1, skip, qmax)) {
    int done = 0, all = 1;
    for (int i = 0; i < 3 && !done; i++) {
      pa_idx o = rm->adj[3 * k + i];
      if (o < 0) continue;
      if (rm->tflag[o / 3] & RM2D_E_TOUCHED) {
        all = 0; /* not tried: no verdict for this face */
        continue;
      }
      done = swap_edge(rm, k, i, 1.02);
    }
    cnt += done;
    if (!done && all) rm->tflag[k] |= RM2D_E_NOSWAP;
  }
  return cnt;
}

long pa__rm2d_sliver_pass(rm2d *rm, double qbad) {
  long cnt = 0;
  rm2d_tflag_clear(rm, RM2D_E_TOUCHED);
  for (pa_idx k = 0; k < rm->ne; k++) {
    uint8_t t = rm->tflag[k];
    if (t & (RM2D_E_DEAD | RM2D_E_TOUCHED | RM2D_E_FROZEN)) continue;
    if (rm->q[k] >= qbad) continue;
    int done = 0;
    for (int i = 0; i < 3 && !done; i++) done = swap_edge(rm, k, i, 1.0);
    if (!done && !rm->opts->no_insert) {
      /* collapse the shortest edge if the ball gets better */
      const pa_idx *v = rm->tv + 3 * (size_t)k;
      int best = 0;
      double lb = 1e300;
      for (int i = 0; i < 3; i++) {
        double l = rm2d_edge_len(rm, v[RM2D_NX3(i)], v[RM2D_PV3(i)]);
        if (l < lb) {
          lb = l;
          best = i;
        }
      }
      if (lb < PA_METRIC_LEN_HI) {
        double g = rm->lguard;
        rm->lguard = PA_METRIC_LEN_HI * 1.2;
        done =
            pa__rm2d_collapse_edge(rm, k, best, RM2D_NX3(best), 1.0 + 1e-9) ||
            pa__rm2d_collapse_edge(rm, k, best, RM2D_PV3(best), 1.0 + 1e-9);
        rm->lguard = g;
      }
    }
    cnt += done;
  }
  return cnt;
}
