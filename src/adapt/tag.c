/*
 * tag.c -- step 1 of the piece algorithm: which owned elements to remesh and
 * how much work each is.
 *
 * An owned element is tagged when it is not user-required, was not produced
 * by a remesh of this run (the "done" element value), and either carries
 * PA_FLAG_USER or (unless opts->user_tags_only) has an edge whose length in
 * the metric lies outside [0.7071, 1.4142) or a quality below
 * opts->qual_threshold. An element produced with two vertices or more on
 * the skin of another piece that was tagged (done value PA__DONE_ON_SKIN:
 * the remesher could not touch the edge or face it leans on) is tagged
 * again if it fails the quality criterion or an edge lies outside the
 * looser [LEN_LO_SKIN, LEN_HI_SKIN); one merely near such a skin
 * (PA__DONE_NEAR_SKIN) only for its quality or an edge outside [LEN_LO_NEAR,
 * LEN_HI_NEAR), clearly off: the remesher was free to fix it, as anywhere
 * else. Work ~ expected output elements + 1: the element's
 * volume in the metric over the volume of the unit regular simplex, plus one
 * for removing the element itself (the coarsening term). Every figure is a
 * function of the element's own data, so it is the same whatever the
 * distribution. The work is computed only for elements that may be tagged
 * (-1 for the others: done or required); extract.c computes it for the
 * untagged skin elements it needs.
 */
#include "adapt/adapt.h"

#include <math.h>

#define LEN_LO 0.7071
#define LEN_HI 1.4142
/* Elements produced next to the skin of another piece are tagged again only
 * for edges clearly off: a skin face refined by bisection (bisect.c) keeps
 * edges a little shorter than LEN_LO, which only another iteration could
 * change, and edges just outside the range are as many as the sequential
 * remesher leaves anywhere (2-3 % with an anisotropic metric). Tagging them
 * with the strict range makes every iteration's borders the next one's
 * work: 3D shell:0.1 on box3d 5 at 4 ranks took 10 iterations (3 with
 * this range), box3d 10 -> 0.019 on 2 ranks tagged 16 k elements again (a
 * piece of 138 k elements, 0.8 s; 3 k with this range). Both end with the
 * edges in range within 1 point of the sequential remesher. */
#define LEN_LO_SKIN 0.65
#define LEN_HI_SKIN 1.5
/* Near the skin only: box3d 10 -> 0.019 on 2 ranks tagged 783 elements
 * again with the skin range, 389 with this one, same result. */
#define LEN_LO_NEAR 0.5
#define LEN_HI_NEAR 2.0

pa_status pa__owned_balls(pa_dmesh *dm, pa_idx **startp, pa_idx **elemsp) {
  pa_status st = PA_SUCCESS;
  PA_CALL(pa__balls(dm->mesh->elem, dm->nown[PA_ELEMENT], dm->dim + 1,
                    dm->nloc[PA_VERTEX], startp, elemsp));
cleanup:
  return st;
}

double pa__elem_work(const pa_mesh *m, pa_idx e) {
  int d = m->dim, nc = m->met_ncomp, tc = pa__tensor_ncomp(d);
  const pa_idx *v = m->elem + (size_t)(d + 1) * e;
  const double *x[4] = {NULL, NULL, NULL, NULL};
  double mean[6] = {0, 0, 0, 0, 0, 0}, t[6];
  for (int k = 0; k <= d; k++) {
    x[k] = m->coord + (size_t)d * v[k];
    pa__metric_tensor(d, nc, m->met + (size_t)nc * v[k], t);
    for (int c = 0; c < tc; c++) mean[c] += t[c] / (d + 1);
  }
  double vol = fabs(pa__simplex_volume(d, x));
  double det = pa__sym_det(d, mean);
  double vreg = d == 2 ? sqrt(3.0) / 4.0 : sqrt(2.0) / 12.0;
  double w = det > 0 ? vol * sqrt(det) / vreg : 0;
  return (isfinite(w) ? w : 0) + 1.0;
}

/* 1 if an edge of element e is outside [lo, hi) in the metric. */
static int bad_edge(const pa_mesh *m, pa_idx e, double lo, double hi) {
  int d = m->dim, nc = m->met_ncomp;
  const pa_idx *v = m->elem + (size_t)(d + 1) * e;
  for (int i = 0; i <= d; i++)
    for (int j = i + 1; j <= d; j++) {
      double l = pa__edge_length(d, nc, m->coord + (size_t)d * v[i],
                                 m->coord + (size_t)d * v[j],
                                 m->met + (size_t)nc * v[i],
                                 m->met + (size_t)nc * v[j]);
      if (!(l >= lo && l < hi)) return 1;
    }
  return 0;
}

pa_status pa__adapt_tag(pa__iter *it, pa_dmesh_value *done, int first) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = it->dm;
  const pa_mesh *m = dm->mesh;
  const pa_adapt_opts *o = it->opts;
  const uint8_t *dn = pa_dmesh_value_data(done, NULL, NULL);
  double x[2] = {0, 0};
  (void)first;
  it->ne = dm->nown[PA_ELEMENT];
  PA_CALLOC(it->tag, it->ne);
  PA_ALLOC(it->work, it->ne);
  for (pa_idx e = 0; e < it->ne; e++) {
    const pa_idx *v = m->elem + (size_t)it->nve * e;
    /* never tagged: its work is only needed if it joins a piece's skin
     * (extract.c computes it then) */
    it->work[e] = -1;
    if (dn[e] == PA__DONE || (m->eflag[e] & PA_FLAG_REQUIRED)) continue;
    it->work[e] = pa__elem_work(m, e);
    if (dn[e] && o->user_tags_only) continue;
    int t = !dn[e] && (m->eflag[e] & PA_FLAG_USER) != 0;
    if (!t && !o->user_tags_only) {
      t = dn[e] == PA__DONE_ON_SKIN ? bad_edge(m, e, LEN_LO_SKIN, LEN_HI_SKIN)
          : dn[e]                  ? bad_edge(m, e, LEN_LO_NEAR, LEN_HI_NEAR)
                                   : bad_edge(m, e, LEN_LO, LEN_HI);
      if (!t && o->qual_threshold > 0) {
        const double *x[4], *mm[4];
        for (int k = 0; k < it->nve; k++) {
          x[k] = m->coord + (size_t)it->dim * v[k];
          mm[k] = m->met + (size_t)m->met_ncomp * v[k];
        }
        t = pa__quality(it->dim, m->met_ncomp, x, mm) < o->qual_threshold;
      }
    }
    it->tag[e] = (uint8_t)t;
    x[0] += t;
    x[1] += t ? it->work[e] : 0;
  }
cleanup:
  st = pa__agree(dm->comm, st);
  if (st == PA_SUCCESS) {
    st = pa__allreduce(dm->comm, x, 2, MPI_DOUBLE, MPI_SUM);
    it->ntagged = (pa_gid)x[0];
    it->tagwork = x[1];
  }
  return st;
}
