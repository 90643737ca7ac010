/*
 * driver_3d.c -- the 3D remesher's passes and its entry point
 * pa__remesh3d().
 *
 * Schedule (docs/design/REMESHER3D.md):
 *  1. refinement bands: split edges longer than thr = max(sqrt 2, Lmax/1.5)
 *     (each tet's longest edge first), then collapse edges shorter than
 *     1/sqrt 2 creating no edge longer than thr. Collapsing inside every band
 *     keeps anisotropic refinement from overshooting: bisection alone refines
 *     isotropically, and the collapses remove the tangential excess before it
 *     is split again. Before the last band (thr = sqrt 2), a lattice crowd
 *     (lattice_crowd: a structured input about to be refined into the next
 *     lattice, twice the tets) is broken: a wide one is first made
 *     body-centred (its longest class split, then swaps: RM3D_CROWD_TOP);
 *     the ends of the crowd's edges (a tight crowd: every free interior
 *     vertex, RM3D_TIGHT_JIGGLE) are jiggled, and from then on the
 *     splits of short edges are spread (tight: one per neighbourhood and
 *     pass; wide: an edge waits when both its ends were touched;
 *     RM3D_SPREAD_TIGHT, RM3D_SPREAD_WIDE). A large working mesh is
 *     renumbered for locality between bands (RM3D_REORDER_MIN), and every
 *     mesh after them;
 *  2. at least 3 and at most 20 rounds of split (> sqrt 2), collapse
 *     (< 1/sqrt 2, no new edge longer than sqrt 2: p onto q, q onto p, both
 *     onto the midpoint, either onto one of its two nearest other
 *     neighbours, else the edge removed by a swap), swaps around tets of
 *     quality < 0.3 (interior edge removal, 2-3, boundary edge swap),
 *     smoothing of the vertices of tets below 0.75 and a sweep of length
 *     moves (the ends of the edges out of range), until a round
 *     changes fewer than 1 % of the tets (with frozen entities also when
 *     balanced splits and collapses stall: three rounds without a 5 % drop;
 *     the rule shared with 2D, remesh/schedule.h);
 *     the working metric is relaxed at frozen vertices beforehand
 *     (pa__rm3d_skin_relax);
 *  3. the shake (shake_lattice), for a lattice only (a crowd of lengths
 *     and a poor mean quality, or a tight crowd broken at the last band):
 *     every free interior vertex jiggled, then 4 to 8 rounds of collapses
 *     (< 0.85, guard 1.35), swaps, smoothing and length moves, each after
 *     a smaller jiggle, until a round removes under 2 % of the tets (after
 *     a tight crowd only: 3 rounds jiggling the vertices of poor tets);
 *  4. three rounds of swaps (quality < 0.7: this lifts the mean quality by
 *     about 0.03), smoothing (below 0.75) and two sweeps of length moves
 *     (the smoothing disregards lengths), the first two preceded by a
 *     collapse pass (the swaps and moves unlock short edges the rounds
 *     left), a final pass against slivers (< 0.1) and two last sweeps of
 *     length moves.
 * Every pass visits tets and vertices in index order, and every operator is
 * deterministic, so the output is identical from run to run.
 *
 * Outcome: PA_REMESH_SUCCESS when at least 90 % of the edges of free tets
 * are in [1/sqrt 2, sqrt 2) and the worst free tet has quality >= 0.01,
 * PA_REMESH_TARGET_MISSED otherwise. Any error leaves the caller's mesh as
 * given (the working structure is a copy, written back only at the end).
 */
#include "remesh/schedule.h"
#include "remesh3d/remesh3d.h"

#define RM3D_QSMOOTH 0.75 /* smooth the vertices of tets below this quality */
/* The rounds after the bands (their stopping rule: remesh/schedule.h). With
 * the working metric relaxed at frozen skins they settle in 8-10 rounds;
 * the bound ends the runs that do not. */
#define RM3D_ROUNDS_MAX 20
/* The first rounds change little while swaps and moves unlock the collapses
 * the refinement bands refused: at least this many rounds. */
#define RM3D_ROUNDS_MIN 3
/* Splits + collapses at or below this share of the live tets: settled. A
 * lower share lets the anisotropic cases ping-pong to RM3D_ROUNDS_MAX for
 * little, and the optimisation's collapses take what a last round would
 * (figures: docs/BENCHMARKS.md, "The 3D remesher"). */
#define RM3D_ROUNDS_SETTLED 1e-2
/* After a tight crowd (jiggled whole before the last band, see
 * RM3D_TIGHT_JIGGLE) the shake follows the rounds and does their last
 * work: they settle at this share (level-set sphere: 5 % less CPU, mean
 * quality 0.836 against 0.837) */
#define RM3D_ROUNDS_SETTLED_TIGHT 2e-2
/* Sweeps of length moves after each optimisation round's quality moves (which
 * disregard lengths) and at the end: a second sweep still raises the share
 * in range, a third hardly does (figures: docs/BENCHMARKS.md, "The 3D
 * remesher"). */
#define RM3D_LENGTH_SWEEPS 2
/* Sweeps after the optimisation rounds but the last: the next round's
 * collapses, swaps and quality moves change the lengths again, and its
 * sweeps take up what a second one would do. Not with frozen entities: a
 * piece of the rod at 8 ranks (iteration 2, the band along the frontiers)
 * ended at worst Q 0.126 with one sweep, 0.251 with two. */
#define RM3D_LENGTH_SWEEPS_EARLY 1
/* The rounds swap around the tets below this quality (gain 1.02). At 0.3
 * the optimisation's first swap pass still found a swap for one tet in ten
 * (Kuhn cube); swapped while the rounds split and collapse, they leave
 * fewer tets, more edges in range and less work to the later passes. With
 * frozen entities (the parallel loop's pieces) 0.3: at 0.4-0.6 the loop
 * stalled with tagged elements on tests/cli/test_geo.py's cylinder at 2
 * processes. */
#define RM3D_QSWAP_ROUNDS 0.5
#define RM3D_QSWAP_ROUNDS_FROZEN 0.3
/* Compact the working mesh between rounds once more than 1/this of its
 * tet slots are dead: a compaction renumbers every tet and vertex (0.4 %
 * of a Kuhn-cube run each); at 8 the rounds compacted three times, at 4
 * once, with the same memory peak (the output's). */
#define RM3D_COMPACT_DEAD 4
/* Neighbours collapse_other tries per end: the third and later ones
 * succeed rarely, and all of them cost as much as the rest of the
 * collapse pass (figures: docs/BENCHMARKS.md, "The 3D remesher"). */
#define RM3D_OTHER_TRIES 2

/* The six edge lengths of the tet with vertices v, as rm3d_len gives them
 * (with sizes, each vertex's 1/h is taken once, not once per edge: the
 * same operations on the same values, so the same bits). */
static inline __attribute__((always_inline)) void
lengths6(const rm3d *m, const pa_idx *v, double *L) {
  if (m->mc != 1) {
    for (int e = 0; e < 6; e++)
      L[e] = rm3d_len(m, v[pa__rm3d_edge[e][0]], v[pa__rm3d_edge[e][1]]);
    return;
  }
  /* unrolled in pa__rm3d_edge's order: the passes call this for every
   * tet they visit */
  const double *x0 = m->x + 3 * (size_t)v[0], *x1 = m->x + 3 * (size_t)v[1],
               *x2 = m->x + 3 * (size_t)v[2], *x3 = m->x + 3 * (size_t)v[3];
  double i0 = 1.0 / m->met[v[0]], i1 = 1.0 / m->met[v[1]],
         i2 = 1.0 / m->met[v[2]], i3 = 1.0 / m->met[v[3]];
  L[0] = pa__len3_inv(x0, x1, i0, i1);
  L[1] = pa__len3_inv(x0, x2, i0, i2);
  L[2] = pa__len3_inv(x0, x3, i0, i3);
  L[3] = pa__len3_inv(x1, x2, i1, i2);
  L[4] = pa__len3_inv(x1, x3, i1, i3);
  L[5] = pa__len3_inv(x2, x3, i2, i3);
}

/* Order of the 6 edges by length, decreasing (dir > 0) or increasing. */
static void order6(const double *L, int dir, int *ord) {
  for (int i = 0; i < 6; i++) ord[i] = i;
  for (int i = 1; i < 6; i++) {
    int x = ord[i], j = i - 1;
    while (j >= 0 && (dir > 0 ? L[ord[j]] < L[x] : L[ord[j]] > L[x])) {
      ord[j + 1] = ord[j];
      j--;
    }
    ord[j + 1] = x;
  }
}

/* 1 if one of the six lengths is above thr (dir > 0) or below it. */
static int any6(const double *L, double thr, int dir) {
  int any = 0;
  for (int e = 0; e < 6; e++) any |= dir > 0 ? L[e] > thr : L[e] < thr;
  return any;
}

/* 1 if the six lengths are in [PA_METRIC_LEN_LO_EXACT, PA_METRIC_LEN_HI_EXACT].
 */
static int in_range6(const double *L) {
  for (int e = 0; e < 6; e++)
    if (!(L[e] >= PA_METRIC_LEN_LO_EXACT && L[e] <= PA_METRIC_LEN_HI_EXACT))
      return 0;
  return 1;
}

/* The split and collapse passes skip clean tets (RM3D_T_CLEAN) when their
 * threshold is the final one, and mark clean the tets they measure in
 * range: skipping a tet with no edge to split or collapse changes nothing,
 * so the output is the same as without the marks. */
pa_status pa__rm3d_split_pass(rm3d *m, double thr, long *count) {
  pa_status st = PA_SUCCESS;
  long c = 0;
  uint8_t skip = thr >= PA_METRIC_LEN_HI_EXACT ? RM3D_T_CLEAN : 0;
  int spread = thr <= PA_METRIC_LEN_HI_EXACT ? m->spread : 0;
  int wide = spread == RM3D_SPREAD_WIDE;
  double lspread = wide ? RM3D_LSPREAD_WIDE : RM3D_LSPREAD;
  pa_idx sht[RM3D_MAXSHELL], shr[RM3D_MAXSHELL + 1];
  for (pa_idx k = 0; k < m->ne; k++) {
    for (int guard = 0; guard < 64; guard++) {
      if (m->tflag[k] & (RM3D_T_DEAD | RM3D_T_FROZEN | skip)) break;
      double L[6];
      int ord[6], did = 0;
      lengths6(m, m->tv + 4 * (size_t)k, L);
      if (in_range6(L)) {
        m->tflag[k] |= RM3D_T_CLEAN;
        if (skip) break;
      }
      if (!any6(L, thr, 1)) break; /* nothing to split: no order needed */
      order6(L, 1, ord);
      for (int i = 0; i < 6 && L[ord[i]] > thr; i++) {
        pa_idx a = m->tv[4 * (size_t)k + pa__rm3d_edge[ord[i]][0]];
        pa_idx b = m->tv[4 * (size_t)k + pa__rm3d_edge[ord[i]][1]];
        int done, nsh = 0, info;
        /* Spread (see RM3D_SPREAD_TIGHT, RM3D_SPREAD_WIDE): a short
         * enough edge waits for the next pass when splits of this pass
         * touched one end (tight) or both (wide). */
        if (spread && L[ord[i]] < lspread) {
          uint8_t ta = m->vtag[a] & RM3D_V_TODO, tb = m->vtag[b] & RM3D_V_TODO;
          if (wide ? ta && tb : ta || tb) continue;
          if (!wide)
            nsh = pa__rm3d_shell(m, k, a, b, sht, shr, NULL, RM3D_MAXSHELL,
                                 &info);
        }
        PA_CALL(pa__rm3d_split_edge(m, k, a, b, &done));
        if (done) {
          if (spread) {
            m->vtag[a] |= RM3D_V_TODO;
            m->vtag[b] |= RM3D_V_TODO;
            for (int j = 0; j < nsh; j++) m->vtag[shr[j]] |= RM3D_V_TODO;
          }
          did = 1;
          c++;
          break;
        }
      }
      if (!did) break;
    }
  }
cleanup:
  if (spread)
    for (pa_idx i = 0; i < m->nv; i++) m->vtag[i] &= (uint8_t)~RM3D_V_TODO;
  *count = c;
  return st;
}

/* The balls of the two ends of the short edge a collapse pass works on,
 * each walked when first needed: the tries on one edge (either end onto the
 * other, the midpoint, other neighbours) change nothing until one
 * succeeds, so they can share them. */
typedef struct ball_memo {
  pa_idx v[2];
  int n[2]; /* -1: too large */
  int have[2];
  pa_idx ball[2][RM3D_MAXBALL];
} ball_memo;

static void memo_start(ball_memo *bm, pa_idx a, pa_idx b) {
  bm->v[0] = a;
  bm->v[1] = b;
  bm->have[0] = bm->have[1] = 0;
}

/* The ball of end s (0: a, 1: b) into *ball; its count, -1 if too large. */
static int memo_ball(rm3d *m, ball_memo *bm, int s, const pa_idx **ball) {
  if (!bm->have[s]) {
    bm->n[s] = pa__rm3d_ball(m, bm->v[s], bm->ball[s], RM3D_MAXBALL);
    bm->have[s] = 1;
  }
  *ball = bm->ball[s];
  return bm->n[s];
}

/* Each vertex is tried for removal at most once per pass (RM3D_V_TODO), so a
 * collapse that fails is not retried from every tet of the vertex. */
/* Fallback for a short edge (a,b) neither end of which collapses onto the
 * other: remove a or b onto another neighbour, the RM3D_OTHER_TRIES
 * shortest edges first (only edges shorter than 1, so the vertex goes where
 * it is crowded). */
static pa_status collapse_other(rm3d *m, ball_memo *bm, double guard,
                                int *done) {
  pa_status st = PA_SUCCESS;
  pa_idx nb[RM3D_OTHER_TRIES];
  double ln[RM3D_OTHER_TRIES];
  for (int s = 0; s < 2 && !*done; s++) {
    pa_idx p = bm->v[s], o = bm->v[1 - s];
    if (m->vtag[p] & (RM3D_V_LOCK | RM3D_V_CORNER)) continue;
    const pa_idx *ball;
    int n = memo_ball(m, bm, s, &ball);
    if (n < 0) continue;
    int k = 0;
    for (int i = 0; i < n; i++) {
      const pa_idx *v = m->tv + 4 * (size_t)(ball[i] >> 2);
      for (int j = 0; j < 4; j++) {
        pa_idx x = v[j];
        if (x == p || x == o || (m->vtag[x] & RM3D_V_MARK)) continue;
        m->vtag[x] |= RM3D_V_MARK;
        double l = rm3d_len(m, p, x);
        if (l >= 1.0 || (k == RM3D_OTHER_TRIES && !(l < ln[k - 1]))) continue;
        int at = k < RM3D_OTHER_TRIES ? k++ : k - 1;
        while (at > 0 && ln[at - 1] > l) {
          ln[at] = ln[at - 1];
          nb[at] = nb[at - 1];
          at--;
        }
        ln[at] = l;
        nb[at] = x;
      }
    }
    for (int i = 0; i < n; i++) {
      const pa_idx *v = m->tv + 4 * (size_t)(ball[i] >> 2);
      for (int j = 0; j < 4; j++) m->vtag[v[j]] &= (uint8_t)~RM3D_V_MARK;
    }
    for (int i = 0; i < k && !*done; i++)
      PA_CALL(pa__rm3d_collapse_ball(m, p, nb[i], ball, n, guard, done));
  }
cleanup:
  return st;
}

pa_status pa__rm3d_collapse_pass(rm3d *m, double thr, double guard,
                                 long *count) {
  pa_status st = PA_SUCCESS;
  long c = 0;
  uint8_t skip = thr <= PA_METRIC_LEN_LO_EXACT ? RM3D_T_CLEAN : 0;
  ball_memo *bm = NULL;
  PA_CALLOC(bm, 1);
  for (pa_idx i = 0; i < m->nv; i++) m->vtag[i] |= RM3D_V_TODO;
  for (pa_idx k = 0; k < m->ne; k++) {
    if (m->tflag[k] & (RM3D_T_DEAD | RM3D_T_FROZEN | skip)) continue;
    double L[6];
    int ord[6];
    lengths6(m, m->tv + 4 * (size_t)k, L);
    if (in_range6(L)) {
      m->tflag[k] |= RM3D_T_CLEAN;
      if (skip) continue;
    }
    if (!any6(L, thr, -1)) continue; /* nothing to collapse */
    order6(L, -1, ord);
    for (int i = 0; i < 6 && L[ord[i]] < thr; i++) {
      pa_idx a = m->tv[4 * (size_t)k + pa__rm3d_edge[ord[i]][0]];
      pa_idx b = m->tv[4 * (size_t)k + pa__rm3d_edge[ord[i]][1]];
      int done = 0;
      memo_start(bm, a, b);
      for (int dir = 0; dir < 2 && !done; dir++) {
        pa_idx p = dir ? b : a, q = dir ? a : b;
        if (!(m->vtag[p] & RM3D_V_TODO)) continue;
        const pa_idx *bp, *bq;
        if (rm3d_collapse_allowed(m, p, q)) {
          int np = memo_ball(m, bm, dir, &bp);
          if (np >= 0)
            PA_CALL(pa__rm3d_collapse_ball(m, p, q, bp, np, guard, &done));
        }
        /* Both ends refused: meet in the middle (new edges about half the
         * short edge shorter than from either end). */
        if (!done && dir == 1 && (m->vtag[b] & RM3D_V_TODO) &&
            !((m->vtag[a] | m->vtag[b]) &
              (RM3D_V_LOCK | RM3D_V_CORNER | RM3D_V_DEAD))) {
          int na = memo_ball(m, bm, 0, &bp), nb = memo_ball(m, bm, 1, &bq);
          PA_CALL(pa__rm3d_collapse_mid(m, a, b, bp, na, bq, nb, guard, &done));
        }
        if (!done && dir == 1) PA_CALL(collapse_other(m, bm, guard, &done));
        /* Last resort: remove the edge by a swap (its ring stays). */
        if (!done && dir == 1 && m->swap)
          PA_CALL(pa__rm3d_swap_edge(m, k, a, b, 0.3, &done));
        if (!done) m->vtag[p] &= (uint8_t)~RM3D_V_TODO;
      }
      if (done) {
        c++;
        break;
      }
    }
  }
cleanup:
  pa__free(bm);
  for (pa_idx i = 0; i < m->nv; i++) m->vtag[i] &= (uint8_t)~RM3D_V_TODO;
  *count = c;
  return st;
}

pa_status pa__rm3d_swap_pass(rm3d *m, double qthr, double gain, long *count) {
  pa_status st = PA_SUCCESS;
  long c = 0;
  pa_idx ne0 = m->ne;
  PA_CALLOC(m->swapfail, (size_t)ne0 + 1);
  m->nswapfail = ne0;
  for (pa_idx k = 0; k < ne0; k++) {
    if ((m->tflag[k] & (RM3D_T_DEAD | RM3D_T_FROZEN)) || m->q[k] >= qthr)
      continue;
    int done = 0;
    for (int e = 0; e < 6 && !done; e++) {
      pa_idx a = m->tv[4 * (size_t)k + pa__rm3d_edge[e][0]];
      pa_idx b = m->tv[4 * (size_t)k + pa__rm3d_edge[e][1]];
      PA_CALL(pa__rm3d_swap_edge(m, k, a, b, gain, &done));
    }
    for (int f = 0; f < 4 && !done; f++)
      PA_CALL(pa__rm3d_swap_face(m, k, f, gain, &done));
    c += done;
  }
cleanup:
  pa__free(m->swapfail);
  m->swapfail = NULL;
  m->nswapfail = 0;
  *count = c;
  return st;
}

pa_status pa__rm3d_smooth_pass(rm3d *m, double qthr, rm3d_balls *b,
                               long *count) {
  pa_status st = PA_SUCCESS;
  pa_idx sball[RM3D_MAXBALL];
  long c = 0;
  /* first the vertices off the model onto it (pa__rm3d_snap_vertex) */
  for (pa_idx p = 0; m->voff && p < m->nv; p++)
    c += pa__rm3d_snap_vertex(m, p, sball);
  /* and the vertices a split put off their curve onto it */
  for (pa_idx p = 0; m->vcur && p < m->nv; p++)
    c += pa__rm3d_curve_snap_vertex(m, p, sball);
  if (!b->start) PA_CALL(pa__rm3d_balls_build(m, b));
  for (pa_idx k = 0; k < m->ne; k++) {
    if ((m->tflag[k] & RM3D_T_DEAD) || m->q[k] >= qthr) continue;
    for (int j = 0; j < 4; j++)
      m->vtag[m->tv[4 * (size_t)k + j]] |= RM3D_V_TODO;
  }
  for (pa_idx p = 0; p < m->nv; p++) {
    if (!(m->vtag[p] & RM3D_V_TODO)) continue;
    m->vtag[p] &= (uint8_t)~RM3D_V_TODO;
    /* A vertex of a curved patch walks its ball: its move goes onto the
     * first triangle around it that holds the target (curved_point), so
     * the order of the walk stays its order. */
    const pa_idx *ball = sball;
    int n = m->vtag[p] & RM3D_V_CURVED
                ? pa__rm3d_ball(m, p, sball, RM3D_MAXBALL)
                : rm3d_balls_get(b, p, &ball);
    c += pa__rm3d_smooth_vertex(m, p, ball, n);
  }
cleanup:
  *count = c;
  return st;
}

/* Relocate the ends of the edges out of range (pa__rm3d_length_vertex),
 * then sweeps-1 more times those around a vertex that moved: a vertex whose
 * ball did not change gives the same answer again, so this is the same as
 * repeating the whole sweep. Of those, a later sweep visits only the ones
 * that may have an edge out of range (LEN_OUT), which are the only ones
 * that can move: most of the vertices around a move have every edge in
 * range. A vertex may have one when its last visit left it (refused, or
 * moved with one out), or when a move of a neighbour measured their edge
 * out of range; a move in this sweep also puts its neighbour on the list
 * when that neighbour comes later in the sweep. */
#define LEN_BALL 1u /* in the ball of a vertex that moved in this sweep */
#define LEN_OUT 2u  /* may have an edge out of range */
#define LEN_CAND 4u /* in the ball of a vertex that moved in the last sweep */

/* After p moved (its ball[0..n)): its ball's vertices LEN_BALL, and both
 * ends of each of its edges out of range LEN_OUT (a candidate of this sweep
 * not visited yet becomes RM3D_V_TODO). */
static void len_mark(rm3d *m, pa_idx p, const pa_idx *ball, int n,
                     uint8_t *ls) {
  for (int i = 0; i < n; i++) {
    const pa_idx *v = m->tv + 4 * (size_t)(ball[i] >> 2);
    for (int j = 0; j < 4; j++) {
      pa_idx x = v[j];
      ls[x] |= LEN_BALL;
      if (x == p || (m->vtag[x] & RM3D_V_MARK)) continue;
      m->vtag[x] |= RM3D_V_MARK;
      double l = rm3d_len(m, p, x);
      if (l >= PA_METRIC_LEN_LO_EXACT && l < PA_METRIC_LEN_HI_EXACT) continue;
      ls[x] |= LEN_OUT;
      ls[p] |= LEN_OUT;
      if ((ls[x] & LEN_CAND) && x > p) m->vtag[x] |= RM3D_V_TODO;
    }
  }
  for (int i = 0; i < n; i++) {
    const pa_idx *v = m->tv + 4 * (size_t)(ball[i] >> 2);
    for (int j = 0; j < 4; j++) m->vtag[v[j]] &= (uint8_t)~RM3D_V_MARK;
  }
}

pa_status pa__rm3d_length_pass(rm3d *m, int sweeps, rm3d_balls *b,
                               long *count) {
  pa_status st = PA_SUCCESS;
  uint8_t *ls = NULL; /* LEN_* */
  long c = 0;
  if (!b->start) PA_CALL(pa__rm3d_balls_build(m, b));
  for (pa_idx k = 0; k < m->ne; k++) {
    if (m->tflag[k] & (RM3D_T_DEAD | RM3D_T_FROZEN | RM3D_T_CLEAN)) continue;
    const pa_idx *v = m->tv + 4 * (size_t)k;
    double L[6];
    int clean = 1;
    lengths6(m, v, L);
    for (int e = 0; e < 6; e++)
      if (!(L[e] >= PA_METRIC_LEN_LO_EXACT && L[e] < PA_METRIC_LEN_HI_EXACT)) {
        m->vtag[v[pa__rm3d_edge[e][0]]] |= RM3D_V_TODO;
        m->vtag[v[pa__rm3d_edge[e][1]]] |= RM3D_V_TODO;
        clean = 0;
      }
    if (clean) m->tflag[k] |= RM3D_T_CLEAN;
  }
  if (sweeps > 1) PA_CALLOC(ls, (size_t)m->nv);
  for (int s = 0; s < sweeps; s++) {
    long moved = 0;
    for (pa_idx p = 0; p < m->nv; p++) {
      if (!(m->vtag[p] & RM3D_V_TODO)) continue;
      m->vtag[p] &= (uint8_t)~RM3D_V_TODO;
      const pa_idx *ball;
      int nb = rm3d_balls_get(b, p, &ball);
      int n = pa__rm3d_length_vertex(m, p, ball, nb);
      if (!ls) {
        moved += n != 0;
        continue;
      }
      if (!n) {
        ls[p] |= LEN_OUT;
        continue;
      }
      moved++;
      len_mark(m, p, ball, n, ls);
    }
    c += moved;
    if (!moved || !ls || s + 1 == sweeps) break;
    for (pa_idx p = 0; p < m->nv; p++) {
      uint8_t l = ls[p];
      ls[p] = (uint8_t)((l & LEN_OUT) | ((l & LEN_BALL) ? LEN_CAND : 0));
      if (!(l & LEN_BALL) || (m->vtag[p] & RM3D_V_DEAD)) continue;
      if (l & LEN_OUT) m->vtag[p] |= RM3D_V_TODO;
    }
  }
  *count = c;
cleanup:
  pa__free(ls);
  return st;
}

/* Fraction of edges of free tets in range (each edge counted once per tet
 * holding it) and worst quality of free tets. */
static void measure(const rm3d *m, double *inrange, double *qworst,
                    double *qmean) {
  long nin = 0, nall = 0, nt = 0;
  double qw = 1, qs = 0;
  for (pa_idx k = 0; k < m->ne; k++) {
    if (m->tflag[k] & (RM3D_T_DEAD | RM3D_T_FROZEN)) continue;
    double L[6];
    lengths6(m, m->tv + 4 * (size_t)k, L);
    for (int e = 0; e < 6; e++)
      nin += L[e] >= PA_METRIC_LEN_LO_EXACT && L[e] < PA_METRIC_LEN_HI_EXACT;
    nall += 6;
    double q = rm3d_qual_v(m, m->tv + 4 * (size_t)k);
    if (q < qw) qw = q;
    qs += q;
    nt++;
  }
  if (m->verbosity > 1) {
    /* Where the misses are: short / long edges with both ends on the
     * boundary surface versus the others (tet-edge counts). */
    long c[2][3] = {{0, 0, 0}, {0, 0, 0}};
    for (pa_idx k = 0; k < m->ne; k++) {
      if (m->tflag[k] & (RM3D_T_DEAD | RM3D_T_FROZEN)) continue;
      const pa_idx *v = m->tv + 4 * (size_t)k;
      double L[6];
      lengths6(m, v, L);
      for (int e = 0; e < 6; e++) {
        int b = (m->vtag[v[pa__rm3d_edge[e][0]]] &
                 m->vtag[v[pa__rm3d_edge[e][1]]] & RM3D_V_BDRY) != 0;
        c[b][L[e] < PA_METRIC_LEN_LO_EXACT   ? 0
             : L[e] < PA_METRIC_LEN_HI_EXACT ? 1
                                             : 2]++;
      }
    }
    long nb[4] = {0, 0, 0, 0};
    for (pa_idx k = 0; k < m->ne; k++) {
      if ((m->tflag[k] & (RM3D_T_DEAD | RM3D_T_FROZEN)) || m->q[k] >= 0.2)
        continue;
      const pa_idx *v = m->tv + 4 * (size_t)k;
      int nbv = 0;
      for (int j = 0; j < 4; j++) nbv += (m->vtag[v[j]] & RM3D_V_BDRY) != 0;
      nb[(m->tflag[k] & RM3D_T_FACES) ? 3 : nbv ? 2 : m->q[k] < 0.1 ? 1 : 0]++;
    }
    fprintf(stderr,
            "  rm3d Q<0.2: interior %ld (+%ld < 0.1), bdry vertex %ld, bdry "
            "face %ld\n",
            nb[0], nb[1], nb[2], nb[3]);
    fprintf(stderr,
            "  rm3d edges: interior %ld short %ld long %ld ok; surface %ld "
            "short %ld long %ld ok\n",
            c[0][0], c[0][2], c[0][1], c[1][0], c[1][2], c[1][1]);
  }
  *inrange = nall ? (double)nin / nall : 1.0;
  *qworst = qw;
  *qmean = nt ? qs / nt : 1.0;
}

/* Lattice crowds. A structured input (box3d: cubes of 6 tets) bisected
 * level by level stays a lattice: its edges fall into a few classes of one
 * length each. When the class about to be split lies just above sqrt 2 and
 * its midpoints are at least 1/sqrt 2 from the other vertices of its tets,
 * splitting it refines a lattice that has nothing to collapse: the next
 * lattice has all its edges in range and twice the tets (figures:
 * docs/BENCHMARKS.md, "Lattice crowds"). Breaking the lattice
 * first (a small random move of the ends of those edges, then the splits
 * spread over the rounds) lets the passes build an unstructured mesh of the
 * usual density instead. Unstructured inputs have no such crowd: their
 * lengths are spread over every bin.
 *
 * Returns the largest fraction of the free tet-edges (an edge once per tet
 * holding it) that fall into one bin of width sqrt 2 / 100 of (sqrt 2,
 * RM3D_LSPREAD), counting an edge when its midpoint is at least 1/sqrt 2
 * from the other two vertices of the tet; *longer is the fraction of
 * tet-edges of RM3D_LSPREAD or more, *far the largest fraction in one bin
 * of the same width anywhere in (sqrt 2, 2), counting every edge. The
 * ends of the edges counted in (sqrt 2, RM3D_LSPREAD) are marked
 * RM3D_V_TODO (the caller clears them). */
#define RM3D_NCROWD 14 /* bins up to RM3D_LSPREAD / sqrt 2 = 1.13 */
#define RM3D_NCROWD_FAR 42 /* bins up to 2 / sqrt 2 */
static double lattice_crowd(rm3d *m, double *longer, double *far_top) {
  long hist[RM3D_NCROWD] = {0}, hfar[RM3D_NCROWD_FAR] = {0}, nall = 0,
       nlong = 0;
  int mc = m->mc;
  for (pa_idx k = 0; k < m->ne; k++) {
    if (m->tflag[k] & (RM3D_T_DEAD | RM3D_T_FROZEN)) continue;
    const pa_idx *v = m->tv + 4 * (size_t)k;
    double L[6];
    lengths6(m, v, L);
    nall += 6;
    for (int e = 0; e < 6; e++) {
      nlong += L[e] >= RM3D_LSPREAD;
      if (!(L[e] > PA_METRIC_LEN_HI_EXACT && L[e] < 2.0)) continue;
      int bin = (int)((L[e] / PA_METRIC_LEN_HI_EXACT - 1.0) * 100.0);
      if (bin >= RM3D_NCROWD_FAR) continue;
      hfar[bin]++;
      if (!(L[e] < RM3D_LSPREAD && bin < RM3D_NCROWD)) continue;
      pa_idx a = v[pa__rm3d_edge[e][0]], b = v[pa__rm3d_edge[e][1]];
      const double *xa = m->x + 3 * (size_t)a, *xb = m->x + 3 * (size_t)b;
      double x[3], mp[6];
      for (int i = 0; i < 3; i++) x[i] = 0.5 * (xa[i] + xb[i]);
      pa__rm3d_mid_metric(m, a, b, mp);
      int far = 1;
      for (int j = 0; j < 4 && far; j++) {
        pa_idx c = v[j];
        if (c != a && c != b &&
            pa__len3(mc, x, m->x + 3 * (size_t)c, mp, m->met + (size_t)mc * c) <
                PA_METRIC_LEN_LO_EXACT)
          far = 0;
      }
      if (!far) continue;
      hist[bin]++;
      m->vtag[a] |= RM3D_V_TODO;
      m->vtag[b] |= RM3D_V_TODO;
    }
  }
  long top = 0, ftop = 0;
  for (int i = 0; i < RM3D_NCROWD_FAR; i++) {
    if (i < RM3D_NCROWD && hist[i] > top) top = hist[i];
    if (hfar[i] > ftop) ftop = hfar[i];
  }
  *longer = nall ? (double)nlong / nall : 0.0;
  *far_top = nall ? (double)ftop / nall : 0.0;
  return nall ? (double)top / nall : 0.0;
}

/* Longest edge of free tets. */
/* The caller's progress callback (pa_remesh_opts.progress) after a band
 * or a round. */
static void progress(const pa_remesh_opts *o, int step, const rm3d *m) {
  if (!o->progress) return;
  /* the share of tet edges in range on a sample of about
   * PA_PROGRESS_SAMPLE tets (every k-th): cheap at any size */
  pa_idx stride = m->ne / PA_PROGRESS_SAMPLE + 1;
  long nin = 0, n = 0;
  for (pa_idx k = 0; k < m->ne; k += stride) {
    if (m->tflag[k] & (RM3D_T_DEAD | RM3D_T_FROZEN)) continue;
    double L[6];
    lengths6(m, m->tv + 4 * (size_t)k, L);
    for (int e = 0; e < 6; e++)
      nin += L[e] >= PA_METRIC_LEN_LO_EXACT && L[e] < PA_METRIC_LEN_HI_EXACT;
    n += 6;
  }
  pa_progress p = {"pass", step, (double)(m->ne - m->ndead_t), 0, 0,
                   n ? (double)nin / (double)n : -1, 0};
  o->progress(&p, o->progress_ctx);
}

static double max_length(const rm3d *m) {
  double lmax = 0;
  for (pa_idx k = 0; k < m->ne; k++) {
    if (m->tflag[k] & (RM3D_T_DEAD | RM3D_T_FROZEN)) continue;
    const pa_idx *v = m->tv + 4 * (size_t)k;
    double L[6];
    lengths6(m, v, L);
    for (int e = 0; e < 6; e++) {
      /* between two locked vertices (a frozen skin, mostly): skipped, it
       * would keep the bands from reaching their end */
      if ((m->vtag[v[pa__rm3d_edge[e][0]]] & RM3D_V_LOCK) &&
          (m->vtag[v[pa__rm3d_edge[e][1]]] & RM3D_V_LOCK))
        continue;
      if (L[e] > lmax) lmax = L[e];
    }
  }
  return lmax;
}

/* Expected number of tets of the adapted mesh: metric volume over the
 * volume of the unit regular tet. */
static double estimate_ntets(const rm3d *m) {
  double s = 0;
  for (pa_idx k = 0; k < m->ne; k++) {
    const pa_idx *v = m->tv + 4 * (size_t)k;
    const double *p0 = m->x + 3 * (size_t)v[0], *p1 = m->x + 3 * (size_t)v[1],
                 *p2 = m->x + 3 * (size_t)v[2], *p3 = m->x + 3 * (size_t)v[3];
    double a[3] = {p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]};
    double b[3] = {p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]};
    double c[3] = {p3[0] - p0[0], p3[1] - p0[1], p3[2] - p0[2]};
    double vol = (a[0] * (b[1] * c[2] - b[2] * c[1]) -
                  a[1] * (b[0] * c[2] - b[2] * c[0]) +
                  a[2] * (b[0] * c[1] - b[1] * c[0])) /
                 6.0;
    double d = 0;
    for (int j = 0; j < 4; j++) {
      const double *mt = m->met + (size_t)m->mc * v[j];
      if (m->mc == 1)
        d += 1.0 / (mt[0] * mt[0] * mt[0]);
      else
        d += sqrt(fabs(mt[0] * (mt[2] * mt[5] - mt[4] * mt[4]) -
                       mt[1] * (mt[1] * mt[5] - mt[4] * mt[3]) +
                       mt[3] * (mt[1] * mt[4] - mt[2] * mt[3])));
    }
    s += vol * d / 4.0;
  }
  return s / pa__unit_simplex_volume(3);
}

/* Before the remeshing: the surface analysis, the working metric relaxed
 * at frozen skins, and room reserved for the expected output. */
static pa_status prepare(rm3d *m, const pa_remesh_opts *opts) {
  pa_status st = PA_SUCCESS;
  pa_idx nrel = 0;
  if (m->surf) PA_CALL(pa__rm3d_surface_analyze(m, !opts->no_angle));
  if (m->voff) pa__rm3d_mark_off_model(m); /* for the snap moves */
  PA_CALL(pa__rm3d_skin_relax(m, &nrel));
  if (m->verbosity > 0 && nrel)
    fprintf(stderr, "  rm3d: metric relaxed at %d frozen vertices\n",
            (int)nrel);
  /* the estimate is the metric volume over a regular tet's, about 1.3 x
   * the final count of a uniform refinement: 0.95 of it is room enough
   * (the arrays grow by 1.25 if not), and more raises the memory peak
   * (figures: docs/BENCHMARKS.md, "The 3D remesher") */
  double est = estimate_ntets(m) * 0.95;
  if (est > m->ne && est < 1.5e9) {
    size_t ne = (size_t)est;
    PA_CALL(pa__rm3d_reserve(m, ne / 5 + (size_t)m->nv, ne));
  }
cleanup:
  return st;
}

/* Before the last band: a lattice crowd (see lattice_crowd) at the top of
 * the lengths is broken. A tight crowd is more than 5 % of the tet-edges in
 * one bin with under 10 % longer: the trapped lattices have far more in a
 * bin, the unstructured meshes far less. A wide crowd is more than
 * RM3D_CROWD_WIDE in one bin with longer edges beside it: splitting them
 * all makes a lattice about twice as dense as the target, which the rounds
 * then collapse. Smaller crowds with longer edges are left alone: there
 * the cure costs more than it saves (figures: docs/BENCHMARKS.md, "The 3D
 * remesher"). Jiggle (a tight crowd's whole mesh, a wide crowd's edge
 * ends by 0.1) and spread the splits from now on (m->spread). */
/* crowds of 30-32 % gain, one of 12.6 % loses (docs/BENCHMARKS.md) */
#define RM3D_CROWD_WIDE 0.25
/* A tight crowd: the share in one bin (crowd) and the share longer
 * (longer) that lattice_crowd measures. */
static int tight_crowd(double crowd, double longer) {
  return crowd > 0.05 && longer < 0.1;
}
/* A wide crowd's lattice (more than RM3D_CROWD_WIDE in one bin, anywhere
 * in (sqrt 2, 2), and not a tight crowd) is first made body-centred: the
 * edges within this factor of the longest (a cube lattice's body
 * diagonals) are split, then the swaps remove the crowd's edges (the face
 * diagonals, between two new centres) instead of splitting them. box3d 16
 * -> 0.06: mean quality 0.828 -> 0.893; -> 0.03: 0.813 -> 0.913; -> 0.055
 * (face diagonals at 1.61, beyond the spread's bins): 98 304 tets -> 52 240
 * (docs/BENCHMARKS.md, "Lattice crowds"). */
#define RM3D_CROWD_TOP 1.1
/* A tight crowd's mesh is jiggled whole by this metric length (a wide
 * crowd's edge ends by 0.1): the lattice the last band would refine is
 * broken everywhere, so the rounds and a short shake make an unstructured
 * mesh. Level-set sphere: mean quality 0.815 without the shake at 0.3, 0.808
 * at 0.2, 0.780 at 0.1; 0.819 at 0.4-0.5 with a larger worst distance. */
#define RM3D_TIGHT_JIGGLE 0.3
static pa_status break_lattice_crowd(rm3d *m) {
  pa_status st = PA_SUCCESS;
  double longer, far, crowd = lattice_crowd(m, &longer, &far);
  long nj = 0, ns = 0, nw = 0;
  pa_idx ball[RM3D_MAXBALL];
  if (!tight_crowd(crowd, longer) &&
      (crowd > RM3D_CROWD_WIDE || far > RM3D_CROWD_WIDE)) {
    double top = max_length(m) / RM3D_CROWD_TOP;
    for (pa_idx p = 0; p < m->nv; p++) m->vtag[p] &= (uint8_t)~RM3D_V_TODO;
    if (top > PA_METRIC_LEN_HI_EXACT)
      PA_CALL(pa__rm3d_split_pass(m, top, &ns));
    if (m->swap) PA_CALL(pa__rm3d_swap_pass(m, 0.7, 1.02, &nw));
    if (m->verbosity > 0)
      fprintf(stderr,
              "  rm3d lattice crowd: %.1f %% of the edges in one bin, %.1f "
              "%% longer; body-centred: %ld splits, %ld swaps\n",
              100 * crowd, 100 * longer, ns, nw);
    crowd = lattice_crowd(m, &longer, &far);
  }
  m->spread = tight_crowd(crowd, longer)  ? RM3D_SPREAD_TIGHT
              : crowd > RM3D_CROWD_WIDE ? RM3D_SPREAD_WIDE
                                        : 0;
  for (pa_idx p = 0; p < m->nv; p++) {
    int crowded = (m->vtag[p] & RM3D_V_TODO) != 0;
    m->vtag[p] &= (uint8_t)~RM3D_V_TODO;
    if (m->spread == RM3D_SPREAD_TIGHT)
      nj += pa__rm3d_jiggle_vertex(m, p, RM3D_TIGHT_JIGGLE, ball);
    else if (m->spread && crowded)
      nj += pa__rm3d_jiggle_vertex(m, p, 0.1, ball);
  }
  if (m->verbosity > 1 || (m->verbosity > 0 && m->spread))
    fprintf(stderr,
            "  rm3d lattice crowd: %.1f %% of the edges in one bin, "
            "%.1f %% longer%s, %ld vertices jiggled\n",
            100 * crowd, 100 * longer,
            m->spread == RM3D_SPREAD_TIGHT  ? " (splits spread)"
            : m->spread == RM3D_SPREAD_WIDE ? " (splits spread wide)"
                                            : "",
            nj);
cleanup:
  return st;
}

/* The bands renumber the working mesh for locality (pa__rm3d_reorder)
 * before a band once it has grown RM3D_REORDER_GROWTH times since it was
 * last ordered and holds at least RM3D_REORDER_MIN live tets: splits append
 * their tets at the end, so after a few bands a large mesh's neighbourhoods
 * are spread over its whole memory and every ball and shell walk misses the
 * cache. Below the bound the mesh fits in the caches that matter and the
 * order is left as it is (figures: docs/BENCHMARKS.md, "The 3D remesher"). */
#define RM3D_REORDER_GROWTH 4
#define RM3D_REORDER_MIN 1000000

/* Schedule step 1, the refinement bands. Far too coarse input: split
 * longest edges first, in bands of lengths decreasing by a constant factor,
 * so that tets are bisected roughly in the order of a global longest-edge
 * refinement (no needles); each band collapses after its splits. *step
 * counts the progress reports. */
static pa_status refine_bands(rm3d *m, const pa_remesh_opts *opts,
                              int *step) {
  pa_status st = PA_SUCCESS;
  double prev = HUGE_VAL;
  pa_idx ne_ordered = m->ne;
  for (int it = 0; it < 40; it++) {
    if (m->ne - m->ndead_t >= RM3D_REORDER_MIN &&
        m->ne - m->ndead_t > RM3D_REORDER_GROWTH * ne_ordered) {
      PA_CALL(pa__rm3d_reorder(m));
      ne_ordered = m->ne;
    }
    /* decreasing even when the longest edge cannot be split (frozen, or
     * refused next to a frozen skin): the bands must reach
     * PA_METRIC_LEN_HI_EXACT */
    double thr = max_length(m) / 1.5;
    if (thr > prev / 1.5) thr = prev / 1.5;
    /* A band just above sqrt 2 costs a sweep; taking it as sqrt 2 instead
     * (below 1.1 sqrt 2) made a last band of ratio up to 1.65, which
     * over-splits: pieces of the rod at 4 ranks (7.8 M tets) split 700 k
     * edges and collapsed 420 k again in it, 6 % more remesher CPU in all
     * (helper work3, 2026-11-29). */
    if (thr < PA_METRIC_LEN_HI_EXACT) thr = PA_METRIC_LEN_HI_EXACT;
    prev = thr;
    long ns = 0, nc = 0;
    double t1 = pa_wtime();
    if (thr == PA_METRIC_LEN_HI_EXACT) PA_CALL(break_lattice_crowd(m));
    PA_CALL(pa__rm3d_split_pass(m, thr, &ns));
    PA_CALL(pa__rm3d_collapse_pass(m, PA_METRIC_LEN_LO_EXACT, thr, &nc));
    if (m->ndead_t > m->ne / RM3D_COMPACT_DEAD) PA_CALL(pa__rm3d_compact(m, 1));
    if (m->verbosity > 0)
      fprintf(stderr,
              "  rm3d band %.2f: %ld splits %ld collapses (%.2fs), %d tets "
              "(%d slots), memory %.1f MB (peak %.1f)\n",
              thr, ns, nc, pa_wtime() - t1, (int)(m->ne - m->ndead_t),
              (int)m->ne, pa_memory_current() / 1e6, pa_memory_peak() / 1e6);
    progress(opts, ++*step, m);
    if (thr == PA_METRIC_LEN_HI_EXACT) break;
  }
cleanup:
  return st;
}

/* The shake (schedule step 3): a lattice the rounds left, whose symmetric
 * vertices no swap or move can improve, is shaken and optimised again.
 * Only meshes that are lattices now (more than RM3D_SHAKE_CROWD of the
 * tet-edges in one 1 % bin of lengths, mean quality under
 * RM3D_SHAKE_QMEAN: the Kuhn-type tets of a cube lattice refined by whole
 * levels) or were one at the last band (a tight crowd, m->spread) are
 * shaken; the rest skip it. Figures: docs/BENCHMARKS.md,
 * "Lattice crowds". */
/* after the rounds, a lattice holds 30-69 % of its tet-edges in one bin,
 * an unstructured mesh about 2 % */
#define RM3D_SHAKE_CROWD 0.1
/* Kuhn-type lattices have a mean quality of about 0.66; the lattices of
 * the intermediate bisection levels about 0.9, better than Mmg's outputs:
 * those are left alone */
#define RM3D_SHAKE_QMEAN 0.8
/* rounds of the shake: at least RM3D_SHAKE_ROUNDS, then until a round
 * removes less than RM3D_SHAKE_SETTLED of the tets, at most
 * RM3D_SHAKE_ROUNDS_MAX. Each round removes a few % of a lattice twice too
 * dense: box3d 16 -> 0.0325 ends 1.08x Mmg's count after 4 rounds, 1.02x
 * after 8; the level-set sphere settles after 4 (docs/BENCHMARKS.md,
 * "Lattice crowds") */
#define RM3D_SHAKE_ROUNDS 4
#define RM3D_SHAKE_ROUNDS_MAX 8
#define RM3D_SHAKE_SETTLED 0.02
/* A mesh shaken only for its tight crowd, jiggled whole before the last
 * band (RM3D_TIGHT_JIGGLE), is no lattice: at most this many rounds, each
 * jiggling only the vertices of tets below RM3D_SHAKE_QJIG (the first
 * round RM3D_SHAKE_QJIG_FIRST). Level-set sphere: mean quality 0.836 in
 * 1.29 s of CPU, against 0.835 in 1.65 s with the lattice's shake
 * (docs/BENCHMARKS.md, "A level set cut into the mesh") */
#define RM3D_SHAKE_ROUNDS_TIGHT 3
#define RM3D_SHAKE_QJIG_FIRST 0.8
#define RM3D_SHAKE_QJIG 0.7
/* jiggle lengths (metric) of the first round and of the later ones: the
 * level-set sphere's mean quality 0.812 with one jiggle of 0.2, 0.835
 * with 0.15 more in every later round */
#define RM3D_SHAKE_FIRST 0.2
#define RM3D_SHAKE_NEXT 0.15
/* the shake collapses edges shorter than this, creating none longer than
 * RM3D_SHAKE_GUARD: a lattice refined to edges of 0.78 and 1.1 keeps twice
 * the ideal count with the rounds' 1/sqrt 2 and sqrt 2 */
#define RM3D_SHAKE_SHORT 0.85
#define RM3D_SHAKE_GUARD 1.35

/* length_crowd looks at every k-th tet, about this many: a share of 10 %
 * against 2 % needs no more */
#define RM3D_SHAKE_SAMPLE 20000

/* The largest share of the free tet-edges in one bin of width 1 % of the
 * length (logarithmic bins over [0.5, 2)), and the mean quality of the
 * free tets, on a sample of about RM3D_SHAKE_SAMPLE tets (every k-th). */
static double length_crowd(const rm3d *m, double *qmean) {
  enum { NBIN = 139 }; /* ln(2 / 0.5) / 0.01 */
  long hist[NBIN] = {0}, nall = 0, top = 0, nt = 0;
  double qs = 0;
  pa_idx stride = m->ne / RM3D_SHAKE_SAMPLE + 1;
  for (pa_idx k = 0; k < m->ne; k += stride) {
    if (m->tflag[k] & (RM3D_T_DEAD | RM3D_T_FROZEN)) continue;
    double L[6];
    lengths6(m, m->tv + 4 * (size_t)k, L);
    for (int e = 0; e < 6; e++) {
      double b = log(L[e] / 0.5) / 0.01;
      if (b >= 0 && b < NBIN) hist[(int)b]++;
    }
    nall += 6;
    qs += m->q[k];
    nt++;
  }
  for (int i = 0; i < NBIN; i++)
    if (hist[i] > top) top = hist[i];
  *qmean = nt ? qs / nt : 1.0;
  return nall ? (double)top / nall : 0.0;
}

/* Schedule step 3, the shake (see RM3D_SHAKE_CROWD): rounds of a jiggle
 * (pa__rm3d_jiggle_vertex; every free interior vertex on a lattice, after
 * a tight crowd only those of tets below RM3D_SHAKE_QJIG_FIRST, then
 * RM3D_SHAKE_QJIG), collapses (< RM3D_SHAKE_SHORT, guard
 * RM3D_SHAKE_GUARD), swaps (Q < 0.7), smoothing and a sweep of length
 * moves, the jiggle smaller after the first round; on a lattice
 * RM3D_SHAKE_ROUNDS and more while they remove tets (RM3D_SHAKE_SETTLED),
 * after a tight crowd RM3D_SHAKE_ROUNDS_TIGHT; with -nomove neither
 * jiggles nor moves. *npass counts the rounds. */
static pa_status shake_lattice(rm3d *m, const pa_remesh_opts *opts,
                               int *npass) {
  pa_status st = PA_SUCCESS;
  rm3d_balls balls = {NULL, NULL};
  pa_idx ball[RM3D_MAXBALL];
  double qmean, crowd = length_crowd(m, &qmean);
  int tight = m->spread == RM3D_SPREAD_TIGHT;
  if (m->verbosity > 1)
    fprintf(stderr,
            "  rm3d lattice after the rounds: %.1f %% of the edges in one "
            "bin, mean Q %.3f\n",
            100 * crowd, qmean);
  int lattice = crowd > RM3D_SHAKE_CROWD && qmean < RM3D_SHAKE_QMEAN;
  if (!tight && !lattice) return st;
  int rounds = lattice ? RM3D_SHAKE_ROUNDS_MAX : RM3D_SHAKE_ROUNDS_TIGHT;
  for (int it = 0; it < rounds; it++, (*npass)++) {
    long nj = 0, nc = 0, nw = 0, nm = 0, nl = 0;
    double live0 = (double)(m->ne - m->ndead_t);
    double d = it ? RM3D_SHAKE_NEXT : RM3D_SHAKE_FIRST;
    /* which vertices: all on a lattice, else those of the poorer tets */
    double qjig = lattice ? 2 : it ? RM3D_SHAKE_QJIG : RM3D_SHAKE_QJIG_FIRST;
    for (pa_idx k = 0; !opts->no_move && k < m->ne; k++)
      if (!(m->tflag[k] & RM3D_T_DEAD) && m->q[k] < qjig)
        for (int j = 0; j < 4; j++)
          m->vtag[m->tv[4 * (size_t)k + j]] |= RM3D_V_MARK;
    for (pa_idx p = 0; !opts->no_move && p < m->nv; p++) {
      if (!(m->vtag[p] & RM3D_V_MARK)) continue;
      m->vtag[p] &= (uint8_t)~RM3D_V_MARK;
      nj += pa__rm3d_jiggle_vertex(m, p, d, ball);
    }
    PA_CALL(pa__rm3d_collapse_pass(m, RM3D_SHAKE_SHORT, RM3D_SHAKE_GUARD,
                                   &nc));
    if (!opts->no_swap) PA_CALL(pa__rm3d_swap_pass(m, 0.7, 1.01, &nw));
    if (!opts->no_move) {
      PA_CALL(pa__rm3d_smooth_pass(m, RM3D_QSMOOTH, &balls, &nm));
      PA_CALL(pa__rm3d_length_pass(m, 1, &balls, &nl));
      pa__rm3d_balls_free(&balls);
    }
    if (m->ndead_t > m->ne / RM3D_COMPACT_DEAD) PA_CALL(pa__rm3d_compact(m, 1));
    if (m->verbosity > 0)
      fprintf(stderr,
              "  rm3d shake %d: %ld jiggled, %ld collapses %ld swaps %ld "
              "moves, %d tets\n",
              it, nj, nc, nw, nm + nl, (int)(m->ne - m->ndead_t));
    if (it + 1 >= RM3D_SHAKE_ROUNDS &&
        (double)(m->ne - m->ndead_t) > (1 - RM3D_SHAKE_SETTLED) * live0)
      break;
  }
cleanup:
  pa__rm3d_balls_free(&balls);
  return st;
}

/* 1 if the mesh has a frozen tet or boundary triangle. */
static int has_frozen(const rm3d *m) {
  for (pa_idx k = 0; k < m->ne; k++)
    if (m->tflag[k] & RM3D_T_FROZEN) return 1;
  for (pa_idx r = 0; r < m->tri.n; r++)
    if (m->tri.flag[r] & PA_FLAG_REQUIRED) return 1;
  return 0;
}

/* Schedule step 2, the rounds at the final thresholds: split, collapse,
 * swap, move, until the stopping rule (remesh/schedule.h) says they
 * settled or stalled. frozen: has_frozen(m). *step counts the progress
 * reports, *npass the rounds (all but the one that stops them). */
static pa_status refine_rounds(rm3d *m, const pa_remesh_opts *opts,
                               int frozen, int *step, int *npass) {
  pa_status st = PA_SUCCESS;
  pa__rounds rounds;
  rm3d_balls balls = {NULL, NULL};
  /* Balanced splits and collapses are a ping-pong only with frozen
   * entities: the anisotropic shell balances them too, and stopping it
   * early loses edges in range (docs/BENCHMARKS.md, "The 3D remesher"). */
  double qswap = frozen ? RM3D_QSWAP_ROUNDS_FROZEN : RM3D_QSWAP_ROUNDS;
  pa__rounds_start(&rounds, RM3D_ROUNDS_MIN,
                   m->spread == RM3D_SPREAD_TIGHT ? RM3D_ROUNDS_SETTLED_TIGHT
                                                  : RM3D_ROUNDS_SETTLED,
                   0, frozen);
  for (int it = 0; it < RM3D_ROUNDS_MAX; it++, (*npass)++) {
    long ns = 0, nc = 0, nw = 0, nm = 0;
    long nc0 = m->ncollapse;
    double t1 = pa_wtime();
    PA_CALL(pa__rm3d_split_pass(m, PA_METRIC_LEN_HI_EXACT, &ns));
    double t2 = pa_wtime();
    PA_CALL(pa__rm3d_collapse_pass(m, PA_METRIC_LEN_LO_EXACT,
                                   PA_METRIC_LEN_HI_EXACT, &nc));
    double t3 = pa_wtime();
    long nvc = m->ncollapse - nc0; /* the others removed an edge by a swap */
    if (!opts->no_swap)
      PA_CALL(pa__rm3d_swap_pass(m, qswap, 1.02, &nw));
    double t4 = pa_wtime();
    if (!opts->no_move) {
      long nl = 0;
      PA_CALL(pa__rm3d_smooth_pass(m, RM3D_QSMOOTH, &balls, &nm));
      PA_CALL(pa__rm3d_length_pass(m, 1, &balls, &nl));
      pa__rm3d_balls_free(&balls);
      nm += nl;
    }
    double t5 = pa_wtime();
    if (m->ndead_t > m->ne / RM3D_COMPACT_DEAD) PA_CALL(pa__rm3d_compact(m, 1));
    if (m->verbosity > 0)
      fprintf(stderr,
              "  rm3d round %d: %ld splits (%.2fs) %ld collapses (%ld by "
              "swaps, %.2fs) %ld swaps (%.2fs) %ld moves (%.2fs), %d tets\n",
              it, ns, t2 - t1, nc, nc - nvc, t3 - t2, nw, t4 - t3, nm, t5 - t4,
              (int)(m->ne - m->ndead_t));
    progress(opts, ++*step, m);
    if (pa__rounds_stop(&rounds, ns, nvc, m->ne - m->ndead_t)) break;
  }
cleanup:
  pa__rm3d_balls_free(&balls);
  return st;
}

/* Schedule step 3, the optimisation: three rounds of swaps and moves, a
 * pass against slivers, and the last length moves. frozen: has_frozen(m).
 * *npass counts the passes. */
static pa_status optimise(rm3d *m, const pa_remesh_opts *opts, int frozen,
                          int *npass) {
  pa_status st = PA_SUCCESS;
  rm3d_balls balls = {NULL, NULL};
  int early = frozen ? RM3D_LENGTH_SWEEPS : RM3D_LENGTH_SWEEPS_EARLY;
  for (int it = 0; it < 3; it++, (*npass)++) {
    long nc = 0, nw = 0, nm = 0;
    /* The swaps (Q < 0.7) and moves of this phase unlock short edges the
     * rounds could not collapse (mostly interior ones refused by the length
     * guard): collapse again in the first two rounds; the last one only
     * swaps and smooths, so the worst quality is repaired after them. */
    if (it < 2 && !opts->no_insert)
      PA_CALL(pa__rm3d_collapse_pass(m, PA_METRIC_LEN_LO_EXACT,
                                     PA_METRIC_LEN_HI_EXACT, &nc));
    if (!opts->no_swap) PA_CALL(pa__rm3d_swap_pass(m, 0.7, 1.01, &nw));
    if (!opts->no_move) {
      long nl = 0;
      PA_CALL(pa__rm3d_smooth_pass(m, RM3D_QSMOOTH, &balls, &nm));
      PA_CALL(pa__rm3d_length_pass(m, it < 2 ? early : RM3D_LENGTH_SWEEPS,
                                   &balls, &nl));
      pa__rm3d_balls_free(&balls);
      nm += nl;
    }
    if (m->verbosity > 0)
      fprintf(stderr,
              "  rm3d optimisation %d: %ld collapses %ld swaps %ld moves\n",
              it, nc, nw, nm);
  }
  if (!opts->no_swap) {
    long nw = 0;
    PA_CALL(pa__rm3d_swap_pass(m, 0.1, 1.0, &nw));
    (*npass)++;
  }
  /* Last, lengths: the sliver swaps changed a few (and the length moves
   * keep the worst quality at min(its old value, RM3D_QLEN)). */
  if (!opts->no_move) {
    long nl = 0;
    PA_CALL(pa__rm3d_length_pass(m, RM3D_LENGTH_SWEEPS, &balls, &nl));
    if (m->verbosity > 0) fprintf(stderr, "  rm3d length moves: %ld\n", nl);
  }
cleanup:
  pa__rm3d_balls_free(&balls);
  return st;
}

/* The verdict (see the outcome above) and the counts in the report, and
 * the working mesh written back into mesh. */
static pa_status conclude(rm3d *m, pa_mesh *mesh, int npass,
                          pa_remesh_report *report) {
  pa_status st = PA_SUCCESS;
#ifndef NDEBUG
  PA_CALL(pa__rm3d_check(m));
#endif
  double inrange, qworst, qmean;
  measure(m, &inrange, &qworst, &qmean);
  if (m->verbosity > 0)
    fprintf(stderr, "  rm3d: %.2f%% edges in range, worst Q %.3f, mean Q %.3f\n",
            100 * inrange, qworst, qmean);
  report->nsplit = m->nsplit;
  report->ncollapse = m->ncollapse;
  report->nswap = m->nswap;
  report->nmove = m->nmove;
  report->npass = npass;
  PA_CALL(pa__rm3d_write(m, mesh));
  report->outcome = (inrange >= 0.9 && qworst >= 0.01)
                        ? PA_REMESH_SUCCESS
                        : PA_REMESH_TARGET_MISSED;
cleanup:
  return st;
}

pa_status pa__remesh3d(pa_mesh *mesh, const pa_remesh_opts *opts,
                       pa_remesh_report *report) {
  pa_status st = PA_SUCCESS;
  rm3d m;
  int built = 0, npass = 0, step = 0, frozen;
  double t0 = pa_wtime();
  PA_CHECK(mesh && opts && report, PA_ERR_ARG, "pa__remesh3d: NULL argument");
  memset(report, 0, sizeof *report);
  report->outcome = PA_REMESH_FAILED;
  PA_CALL(pa__rm3d_build(&m, mesh, opts));
  built = 1;
  PA_CALL(prepare(&m, opts));
  frozen = has_frozen(&m);
  if (!opts->no_insert) {
    PA_CALL(refine_bands(&m, opts, &step));
    PA_CALL(pa__rm3d_reorder(&m));
    PA_CALL(refine_rounds(&m, opts, frozen, &step, &npass));
    PA_CALL(shake_lattice(&m, opts, &npass));
  }
  PA_CALL(optimise(&m, opts, frozen, &npass));
  PA_CALL(conclude(&m, mesh, npass, report));
cleanup:
  if (built) pa__rm3d_free(&m);
  if (report) report->time_s = pa_wtime() - t0;
  return st;
}
