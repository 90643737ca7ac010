/*
 * skin.c -- the working metric relaxed at a frozen skin, for both
 * remeshers (docs/design/REMESHER.md, "Frozen skins far from the size").
 * A frozen vertex whose frozen edges are on average far from unit length
 * bounds the free elements around it to bridge the difference, and a free
 * element on a long frozen edge or face can only be split on its free
 * edges. So each such vertex gets its working metric scaled until that
 * mean reaches the band's bound (or the remesher's target above it); the
 * size returns to the target over the first ring of input elements (by
 * interpolation at the splits), and the target itself stays in met0,
 * written back. The remeshers sum the lengths of their frozen edges (each
 * knows its frozen entities); the scaling is here.
 */
#include "remesh/remesh.h"

pa_status pa__remesh_skin_relax(const pa__skin_relax *r, int mc, pa_idx nv,
                                size_t capv, double *met, double **met0,
                                const double *sum, const int32_t *cnt,
                                pa_idx *nrelaxed) {
  pa_status st = PA_SUCCESS;
  pa_idx nr = 0;
  /* every lambda comes from the target metric, before any change */
  for (pa_idx v = 0; v < nv; v++) {
    if (!cnt[v]) continue;
    double lam = sum[v] / cnt[v];
    if (!(lam > r->hi || lam < r->lo) || !(lam > 0) || !isfinite(lam))
      continue;
    if (!*met0) {
      PA_ALLOC(*met0, capv * (size_t)mc);
      memcpy(*met0, met, sizeof(double) * (size_t)mc * nv);
    }
    /* the least change that brings the mean to the bound (or the target) */
    double f = lam > r->hi ? lam / r->to_hi : lam / r->lo;
    double *m = met + (size_t)mc * v;
    if (mc == 1) {
      m[0] *= f;
    } else {
      double s = 1.0 / (f * f);
      for (int c = 0; c < mc; c++) m[c] *= s;
    }
    nr++;
  }
  *nrelaxed = nr;
cleanup:
  return st;
}
