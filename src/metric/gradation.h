/*
 * gradation.h -- metric gradation: bound how fast the prescribed size may grow
 * along the edges of a mesh (Mmg's -hgrad).
 */
#ifndef PA_GRADATION_H
#define PA_GRADATION_H

#include "metric/metric.h"

/*
 * Grade the metric met (nv values of ncomp components, 1 = size, 3/6 =
 * tensor) over the edges of the simplices elem (ne of dim+1 vertices) so that
 * along every edge pq the size grows at most like h_q <= h_p + ln(hgrad) |pq|
 * (isotropic); for tensors the sorted eigenvalues of M_q are bounded by those
 * of M_p / (1 + L ln(hgrad))^2, L the larger length of pq in M_p and M_q (a rotation
 * of the principal directions is no size jump; gradation.c explains the law).
 * Vertices with frozen[v] != 0 (frozen may be NULL) keep their metric and
 * constrain their neighbours with hgradreq instead of hgrad. A rate <= 1
 * turns its propagation off. *nchanged (may be NULL) receives the number of
 * vertices whose metric changed. Iterates to a fixed point (sweeps over the
 * edges touching a vertex changed in the previous sweep); sizes only shrink.
 * Not collective.
 */
pa_status pa__metric_gradation(int dim, int ncomp, pa_idx nv,
                               const double *coord, double *met, pa_idx ne,
                               const pa_idx *elem, const uint8_t *frozen,
                               double hgrad, double hgradreq,
                               pa_idx *nchanged);

#endif /* PA_GRADATION_H */
