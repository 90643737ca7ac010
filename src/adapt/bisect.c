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
 * Which skin edges (pieces.c marks the vertices from reduced values, so
 * every piece sees the same): those whose two vertices are "inner" (every
 * element around them is in a piece, they lie on no feature edge nor
 * required boundary entity nor curved boundary, and are no corner, ridge or
 * required vertex), those between an inner vertex and a "labelled" one
 * (only pieces around it, but on a ridge, a corner, a curved boundary...),
 * and those between two labelled vertices, inside the domain or on the
 * boundary, unless an end is "hard" (on a feature edge or a required
 * boundary entity). Such an edge lies in no staying element, and every
 * piece containing it has it on its skin. An inner-labelled edge is no
 * feature edge (the inner end is on none); if it lies on the boundary, its
 * boundary faces contain the inner end, whose faces are coplanar, so its
 * midpoint is on the surface. A labelled-labelled edge on the boundary is
 * split on the cubic Hermite curve of its ends' normals (pieces.c gives
 * one to the vertices of a smooth curved boundary, remesh/leb.c has the
 * rules). Only the pieces at the ends of such an edge hold a boundary face
 * of it: whether it is on the boundary comes from both ends' Bloom masks
 * of their boundary neighbours' global ids (pieces.c), which never miss
 * one; and when they err, the edge is a chord, split at its midpoint
 * unless it lies within PA_LEB_SMOOTH_DEG of the tangent planes (then a
 * point on the curve may turn an element over, caught below). Without the
 * labelled ends, every skin face touching a ridge or a curved boundary
 * would stay as coarse as the input, and its neighbours would be remeshed
 * again in another iteration (docs/BENCHMARKS.md, "The parallel loop", has
 * the measurement).
 *
 * A point on a curve may leave an element of the piece without a positive
 * volume (a thin element on the concave side); the piece counts them
 * (pc->curve_bad) and extract.c makes every piece again without curves
 * when one is found on any rank.
 *
 * In 2D (no masks, surf NULL) every labelled vertex is hard: a skin edge
 * there is interior, a labelled-labelled one (a chord) stays whole, but a
 * skin edge between a hard vertex and an inner one descended from labelled
 * ones is split (leb.c: a skin face is that edge, nothing slides); left
 * whole, the edges ending on the boundary stayed 41-50 long in the metric
 * beside a skin refined to 1.5 (plate2d.mesh -hsiz 0.0005 at 2 ranks), and
 * the pieces missed their target. The 2D remesher then splits the curved
 * boundary edge at such an end nearer its chord if needed
 * (remesh2d/split_2d.c). In 3D without masks (a mesh holding the most
 * fields) every labelled vertex is hard too.
 *
 * Edges inside the piece longer than inner_lmax are bisected too, in the
 * same longest-first order (except in elements holding less than
 * PA_LEB_VMIN unit elements of metric volume, as the remesher's own
 * pre-refinement): otherwise the elements on a refined skin face are fans
 * of slivers. The built-in 3D remesher turns those into more tets, more
 * slowly (docs/design/ADAPT.md); a plain bisection remesher (examples/)
 * cannot repair them at all, nor the next iteration's one a rolled-back
 * piece, which comes back as refined here (test_adapt_props: a threshold
 * of 3 or more leaves fans): extract.c passes PA_ADAPT_LEB_INNER. The
 * built-in 2D remesher refines the inside itself, faster than the
 * bisection, in as many passes as its boundary band needs, but the fans
 * of needles of a refined skin are better cut short: it gets
 * PA_ADAPT_LEB_INNER_2D, in the elements touching the skin only (piece.h
 * has the measurements).
 *
 * New skin vertices get temporary ids (PA_ADAPT_TEMP_GID + index), and are
 * matched after the remesh by their coordinates like the others;
 * reintegrate.c gives the copies of one vertex in several pieces one global
 * id by their coordinates. New inner vertices get no id (-1): they are new
 * vertices like those the remesher adds.
 */
#include "adapt/piece.h"
#include "remesh/leb.h"

#include <math.h>

/* What on_boundary reads: the piece's vertices' global ids and their
 * Bloom masks (4 doubles per vertex, the fourth). */
typedef struct bloom {
  const pa_gid *vgid;
  const double *surf;
} bloom;

/* leb.c's o->on_boundary: 1 if each of a and b is in the other's mask of
 * boundary neighbours (a Bloom filter: never 0 for a boundary edge). */
static int on_boundary(void *ctx, pa_idx a, pa_idx b) {
  const bloom *f = ctx;
  uint64_t ma = (uint64_t)f->surf[4 * (size_t)a + 3],
           mb = (uint64_t)f->surf[4 * (size_t)b + 3];
  return (ma & pa__adapt_bloom_bit(f->vgid[b])) &&
         (mb & pa__adapt_bloom_bit(f->vgid[a]));
}

/* o->on_boundary without masks: any two labelled vertices may lie on a
 * boundary edge. */
static int maybe_on_boundary(void *ctx, pa_idx a, pa_idx b) {
  (void)ctx;
  (void)a;
  (void)b;
  return 1;
}

pa_status pa__piece_refine_skin(pa__piece *pc, const uint8_t *inner,
                                double inner_lmax, int near_skin,
                                const double *surf, int curves) {
  pa_status st = PA_SUCCESS;
  pa_mesh *m = pc->in;
  pa_idx nv0 = m->nv, *parent = NULL;
  uint8_t *onskin = NULL, *mark = NULL, *eflag0 = NULL;
  double *nrm = NULL;
  bloom f = {pc->vgid, surf};
  pa__leb_opts o;
  memset(&o, 0, sizeof o);
  o.lmax = inner_lmax;
  o.skin_ref = PA_ADAPT_SKIN_REF;
  o.skin_ok = inner;
  o.skin_lmax = PA_ADAPT_LEB_SKIN;
  o.vmin = PA_LEB_VMIN * pa__unit_simplex_volume(m->dim);
  o.curve_bad = &pc->curve_bad;
  if (surf) {
    o.on_boundary = on_boundary;
    o.ctx = &f;
  } else {
    o.on_boundary = maybe_on_boundary;
  }
  if (surf && curves) {
    PA_ALLOC(nrm, (size_t)3 * nv0);
    for (pa_idx v = 0; v < nv0; v++)
      memcpy(nrm + 3 * (size_t)v, surf + 4 * (size_t)v, 3 * sizeof *nrm);
    o.normal = nrm;
  }
  /* the labelled vertices whose boundary edges stay whole: all of them
   * without masks (2D: see the file comment) */
  PA_ALLOC(mark, nv0);
  for (pa_idx v = 0; v < nv0; v++) {
    int hard = !surf || ((uint64_t)surf[4 * (size_t)v + 3] & PA_ADAPT_HARD_BIT);
    mark[v] = inner[v] >= 2 && hard ? 4 : inner[v];
  }
  o.skin_ok = mark;
  /* near_skin: the elements away from the skin are frozen meanwhile
   * (leb.c splits no edge of a frozen element; the halves of a split one
   * keep its flags) */
  pa_idx ne0 = m->ne;
  if (near_skin) {
    PA_ALLOC(eflag0, ne0);
    memcpy(eflag0, m->eflag, (size_t)ne0);
    for (pa_idx e = 0; e < ne0; e++) {
      const pa_idx *v = m->elem + (size_t)(m->dim + 1) * e;
      int sk = 0;
      for (int k = 0; k <= m->dim; k++) sk |= pc->skin[v[k]];
      if (!sk) m->eflag[e] |= PA_FLAG_REQUIRED;
    }
  }
  st = pa__leb_refine(m, &o, &parent, &onskin);
  if (near_skin) memcpy(m->eflag, eflag0, (size_t)ne0);
  PA_CALL(st);
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
      int s = onskin[v - nv0] != 0;
      pa_idx a = parent[2 * (v - nv0)], b = parent[2 * (v - nv0) + 1];
      pc->ncurved += onskin[v - nv0] == 2;
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
  pa__free(mark);
  pa__free(eflag0);
  pa__free(nrm);
  return st;
}
