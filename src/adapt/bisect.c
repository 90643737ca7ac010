/*
 * bisect.c -- refine the skin two pieces share before they are remeshed.
 *
 * A piece's skin faces are frozen: without this step, where two pieces meet
 * the interface keeps the size of the input (coarse, in a refinement), the
 * remesher grades the size away from it, and a band of elements on both
 * sides must be remeshed again in the next iteration, as one more set of
 * pieces whose own borders leave another band. So every piece first refines
 * its skin faces by longest-edge bisection (remesh/leb.c), which gives the
 * same faces on both sides of an interface: a face's refinement depends
 * only on its vertices (coordinates and metric, shipped bit for bit).
 *
 * Which skin edges: those whose two vertices are "inner" (pieces.c: every
 * element around them is in a piece, they lie on no feature edge nor
 * required boundary entity nor curved boundary, and are no corner, ridge or
 * required vertex; from reduced vertex values, so every piece sees the
 * same), and those between an inner vertex and a "labelled" one (only
 * pieces around it, but on a ridge, a corner, a curved boundary...). Such
 * an edge lies in no staying element, and every piece containing it has it
 * on its skin. An inner-labelled edge is no feature edge (the inner end is
 * on none); if it lies on the boundary, its boundary faces contain the
 * inner end, whose faces are coplanar, so its midpoint is on the surface.
 * Without the labelled ends, every skin face touching a ridge of a box
 * would stay as coarse as the input, and its neighbours would be remeshed
 * again in another iteration (docs/BENCHMARKS.md, "The parallel loop", has
 * the measurement).
 *
 * With inside, edges inside the piece longer than PA_ADAPT_LEB_INNER are
 * bisected too, in the same longest-first order: otherwise the elements on
 * a refined skin face are fans of slivers. The built-in 3D remesher turns
 * those into more tets, more slowly (docs/design/ADAPT.md); a plain
 * bisection remesher (examples/) cannot repair them at all, nor the next
 * iteration's one a rolled-back piece, which comes back as refined here
 * (test_adapt_props: a threshold of 3 or more leaves fans). The built-in 2D
 * remesher repairs fans of triangles itself, faster than the bisection
 * (docs/BENCHMARKS.md, "The parallel loop"): extract.c passes inside = 0
 * for it.
 *
 * New skin vertices get temporary ids (PA_ADAPT_TEMP_GID + index), and are
 * matched after the remesh by their coordinates like the others;
 * reintegrate.c gives the copies of one vertex in several pieces one global
 * id by their coordinates. New inner vertices get no id (-1): they are new
 * vertices like those the remesher adds.
 */
#include "adapt/adapt.h"
#include "remesh/leb.h"

#include <math.h>

pa_status pa__piece_refine_skin(pa__piece *pc, const uint8_t *inner,
                                int inside) {
  pa_status st = PA_SUCCESS;
  pa_mesh *m = pc->in;
  pa_idx nv0 = m->nv, *parent = NULL;
  uint8_t *onskin = NULL;
  pa__leb_opts o;
  o.lmax = inside ? PA_ADAPT_LEB_INNER : HUGE_VAL;
  o.skin_ref = PA_ADAPT_SKIN_REF;
  o.skin_ok = inner;
  o.skin_lmax = PA_ADAPT_LEB_SKIN;
  PA_CALL(pa__leb_refine(m, &o, &parent, &onskin));
  if (m->nv > nv0) {
    pa_gid *g = pa__realloc(pc->vgid, (size_t)m->nv * sizeof *g);
    PA_CHECK(g, PA_ERR_MEMORY, "out of memory refining a piece's skin");
    pc->vgid = g;
    uint8_t *sk = pa__realloc(pc->skin, (size_t)m->nv);
    PA_CHECK(sk, PA_ERR_MEMORY, "out of memory refining a piece's skin");
    pc->skin = sk;
    uint8_t *h = pa__realloc(pc->hot, (size_t)m->nv);
    PA_CHECK(h, PA_ERR_MEMORY, "out of memory refining a piece's skin");
    pc->hot = h;
    int *r = pa__realloc(pc->vrank, (size_t)m->nv * sizeof *r);
    PA_CHECK(r, PA_ERR_MEMORY, "out of memory refining a piece's skin");
    pc->vrank = r;
    for (pa_idx v = nv0; v < m->nv; v++) {
      int s = onskin[v - nv0];
      pa_idx a = parent[2 * (v - nv0)], b = parent[2 * (v - nv0) + 1];
      pc->vgid[v] = s ? PA_ADAPT_TEMP_GID + v : -1;
      pc->skin[v] = (uint8_t)s;
      /* hot if an end is: elements produced near it may be tagged again */
      pc->hot[v] = (uint8_t)(s && (pc->hot[a] || pc->hot[b]));
      pc->vrank[v] = pc->vrank[a] < pc->vrank[b] ? pc->vrank[a] : pc->vrank[b];
      pc->nsplit += s;
    }
  }
cleanup:
  pa__free(parent);
  pa__free(onskin);
  return st;
}
