/*
 * ops_2d.h -- what the 2D operator files (split_2d.c, collapse_2d.c,
 * swap_2d.c, smooth_2d.c) and the passes that call them (driver_2d.c)
 * share: the operators' entries (below), local numbering, the walk across
 * feature records, the cache invalidation of a rewritten element, vertex balls.
 *
 * Every operator evaluates its result before changing anything ("sim then
 * apply"): each new element must have quality >= RM2D_QFLOOR (so its
 * orientation is certain; where the elements it replaces are already
 * worse, at least half their worst and a certain Euclidean orientation:
 * rm2d_qfloor, rm2d_qual_ok), plus the operator's own acceptance rule. The
 * frozen contract is enforced by the operators: an element tagged
 * RM2D_E_FROZEN is never rewritten nor deleted, so none of its edges is
 * split, swapped or collapsed (a collapse removes a vertex, and vertices of
 * frozen elements are RM2D_V_FROZEN); frozen and corner vertices never move
 * nor disappear; feature edges are never swapped.
 *
 * Local numbering: in element k = (v0, v1, v2), counter-clockwise, face i is
 * the edge from v[i+1] to v[i+2] (indices mod 3), opposite v[i]. Across a
 * shared edge the neighbour runs it the other way.
 *
 * Passes visit elements in slot order and skip elements already touched in
 * the same pass (RM2D_E_TOUCHED), so each neighbourhood changes at most once
 * per pass and the result is deterministic.
 */
#ifndef PA_OPS_2D_H
#define PA_OPS_2D_H

#include "remesh2d/remesh2d.h"

#define RM2D_BALL_MAX 128
#define RM2D_X(v) (rm->x + 2 * (size_t)(v))
#define RM2D_M(v) (rm->met + (size_t)mc * (v))
#define RM2D_NX3(i) ((i) == 2 ? 0 : (i) + 1)
#define RM2D_PV3(i) ((i) == 0 ? 2 : (i)-1)

static inline double rm2d_elem_qual(const rm2d *rm, pa_idx a, pa_idx b,
                                    pa_idx c) {
  int mc = rm->mc;
  return pa__qual2(mc, RM2D_X(a), RM2D_X(b), RM2D_X(c), RM2D_M(a), RM2D_M(b),
                   RM2D_M(c));
}

/* The quality floor of the new elements of an operation that replaces
 * elements of worst quality qold: RM2D_QFLOOR, or half of qold when that is
 * lower (the two meet at qold = 2 RM2D_QFLOOR). An input far from its metric
 * (an isotropic mesh under a 1e6:1 metric has quality about 1e-6) can then
 * be adapted: the first splits of its needles halve their quality before
 * the later ones raise it. */
static inline double rm2d_qfloor(double qold) {
  return qold < 2 * RM2D_QFLOOR ? 0.5 * qold : RM2D_QFLOOR;
}

/* New element (a, b, c) of quality q is acceptable against floor (from
 * rm2d_qfloor): q >= floor, and below RM2D_QFLOOR also a Euclidean quality of
 * at least RM2D_QFLOOR_EUCL, so its orientation is certain. Under a size
 * metric the two qualities are the same. */
static inline int rm2d_qual_ok(const rm2d *rm, double q, double floor, pa_idx a,
                               pa_idx b, pa_idx c) {
  if (!(q >= floor)) return 0;
  if (floor >= RM2D_QFLOOR || rm->mc <= 1) return 1;
  const double *xa = RM2D_X(a), *xb = RM2D_X(b), *xc = RM2D_X(c);
  return pa__qual2_xy(xa[0], xa[1], xb[0], xb[1], xc[0], xc[1]) >=
         RM2D_QFLOOR_EUCL;
}

static inline double rm2d_edge_len(const rm2d *rm, pa_idx a, pa_idx b) {
  int mc = rm->mc;
  return pa__len2(mc, RM2D_X(a), RM2D_X(b), RM2D_M(a), RM2D_M(b));
}

/* Face on the other side of face `code` (through a feature record if need
 * be), or -1 on the domain boundary. */
static inline pa_idx rm2d_other_side(const rm2d *rm, pa_idx code) {
  pa_idx o = rm->adj[code];
  if (o >= 0) return o;
  pa_idx b = -o - 1;
  return rm->bside[2 * b] == code ? rm->bside[2 * b + 1] : rm->bside[2 * b];
}

/* Edge (face code) can be split, collapsed or swapped: no frozen element on
 * either side, no frozen feature record. */
static inline int rm2d_edge_free(const rm2d *rm, pa_idx code) {
  if (rm->tflag[code / 3] & RM2D_E_FROZEN) return 0;
  pa_idx o = rm->adj[code];
  if (o < 0 && (rm->btag[-o - 1] & RM2D_B_FROZEN)) return 0;
  pa_idx s = rm2d_other_side(rm, code);
  return s < 0 || !(rm->tflag[s / 3] & RM2D_E_FROZEN);
}

/* Attach new face `code` to outer value o, which was attached to `oldcode`. */
static inline void rm2d_attach(rm2d *rm, pa_idx code, pa_idx o,
                               pa_idx oldcode) {
  rm->adj[code] = o;
  if (o >= 0) {
    rm->adj[o] = code;
  } else {
    pa_idx b = -o - 1;
    if (rm->bside[2 * b] == oldcode) rm->bside[2 * b] = code;
    else rm->bside[2 * b + 1] = code;
  }
}

/* Clear tag bits on every element (vertex) slot, at the start of a pass.
 * The array and the count are read once: through a uint8_t * a store may
 * alias any field of rm, which the loop would otherwise reload at each slot,
 * and it would not vectorise. */
static inline void rm2d_tflag_clear(rm2d *rm, uint8_t bits) {
  uint8_t *t = rm->tflag;
  const pa_idx n = rm->ne;
  for (pa_idx k = 0; k < n; k++) t[k] &= (uint8_t)~bits;
}
static inline void rm2d_vtag_clear(rm2d *rm, uint8_t bits) {
  uint8_t *t = rm->vtag;
  const pa_idx n = rm->nv;
  for (pa_idx v = 0; v < n; v++) t[v] &= (uint8_t)~bits;
}

/* The first element slot from k on whose tag has none of the bits `skip`,
 * or rm->ne: the scan of a pass, eight tags at a time through the runs it
 * skips (most of the mesh once it has settled). The tags are read as the
 * pass reaches them, so it visits the same elements as a slot-by-slot
 * loop. */
static inline pa_idx rm2d_next_elem(const rm2d *rm, pa_idx k, uint8_t skip) {
  const uint8_t *t = rm->tflag;
  const pa_idx n = rm->ne;
  const uint64_t ones = 0x0101010101010101ULL, low7 = 0x7F7F7F7F7F7F7F7FULL,
                 high = 0x8080808080808080ULL;
  const uint64_t m = ones * skip;
  while (k + 8 <= n) {
    uint64_t w;
    memcpy(&w, t + k, sizeof w);
    w &= m;
    /* the high bit of each byte, set when the byte is zero: a tag with
     * none of the bits */
    uint64_t zero = ~(((w & low7) + low7) | w) & high;
    if (zero) {
#if defined(__GNUC__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
      return k + (pa_idx)(__builtin_ctzll(zero) >> 3);
#else
      break;
#endif
    }
    k += 8;
  }
  while (k < n && (t[k] & skip)) k++;
  return k;
}

/* Element k is rewritten or about to be killed, or one of its vertices
 * moved: drop the caches that depend on it (RM2D_E_INRANGE of k, RM2D_E_NOSWAP
 * of k and its neighbours, RM2D_V_SETTLED, RM2D_V_LSETTLED and
 * RM2D_V_CSETTLED of its vertices, whose balls change).
 * Call with k's current vertices and, on a rewrite, before its adjacency is
 * updated (the old neighbours are the ones to tell; a new neighbour of a
 * rewritten element is an old neighbour of the rewritten group). */
static inline void rm2d_elem_changed(rm2d *rm, pa_idx k) {
  const pa_idx *v = rm->tv + 3 * (size_t)k;
  const pa_idx *a = rm->adj + 3 * (size_t)k;
  rm->tflag[k] &= (uint8_t) ~(RM2D_E_INRANGE | RM2D_E_NOSWAP);
  /* neighbours: their swaps across k see a new k (swaps never cross a
   * feature record, so only direct neighbours matter) */
  if (a[0] >= 0) rm->tflag[a[0] / 3] &= (uint8_t)~RM2D_E_NOSWAP;
  if (a[1] >= 0) rm->tflag[a[1] / 3] &= (uint8_t)~RM2D_E_NOSWAP;
  if (a[2] >= 0) rm->tflag[a[2] / 3] &= (uint8_t)~RM2D_E_NOSWAP;
  const uint8_t vs =
      (uint8_t)~(RM2D_V_SETTLED | RM2D_V_LSETTLED | RM2D_V_CSETTLED);
  rm->vtag[v[0]] &= vs;
  rm->vtag[v[1]] &= vs;
  rm->vtag[v[2]] &= vs;
}

/* Write element k (an existing or a new slot). The caller has called
 * rm2d_elem_changed on every existing element it rewrites, before the rewrite;
 * the vertices of the new elements are then those old ones plus new vertices
 * (no cached flags), and new slots start with no cached flags either. */
static inline void rm2d_set_elem(rm2d *rm, pa_idx k, pa_idx a, pa_idx b,
                                 pa_idx c, double q) {
  rm->tv[3 * k] = a;
  rm->tv[3 * k + 1] = b;
  rm->tv[3 * k + 2] = c;
  rm->q[k] = (float)q;
  rm->tflag[k] |= RM2D_E_TOUCHED;
}

/*
 * Elements around vertex p starting from element k (local index ip): counter-
 * clockwise until back to k or the domain boundary, then clockwise from k.
 * Fills el[] and loc[] (local index of p) and returns the count, or -1 if the
 * ball exceeds RM2D_BALL_MAX. *closed is 1 for an interior vertex.
 *
 * Each step waits for the neighbour it reads (the walks are latency-bound),
 * so the two directions advance together, two independent chains: a
 * closed ball ends where they meet, its clockwise part then read back.
 */
static inline int rm2d_ball(const rm2d *rm, pa_idx k, int ip, pa_idx *el,
                            int *loc, int *closed) {
  pa_idx cw[RM2D_BALL_MAX];
  int lcw[RM2D_BALL_MAX];
  int na = 0, nc = 0, enda = 0, endc = 0;
  pa_idx a = k, c = k; /* the last element of each chain */
  int la = ip, lc = ip;
  el[0] = k;
  loc[0] = ip;
  *closed = 0;
  while (!enda || !endc) {
    if (!enda) { /* counter-clockwise */
      pa_idx s = rm2d_other_side(rm, 3 * a + RM2D_NX3(la));
      if (s < 0) {
        enda = 1;
      } else if (s / 3 == c) { /* met the other chain (or k): closed */
        *closed = 1;
        break;
      } else {
        if (1 + na + nc >= RM2D_BALL_MAX) return -1;
        a = s / 3;
        la = RM2D_NX3(s % 3);
        na++;
        el[na] = a;
        loc[na] = la;
      }
    }
    if (!endc) { /* clockwise */
      pa_idx s = rm2d_other_side(rm, 3 * c + RM2D_PV3(lc));
      if (s < 0) {
        endc = 1;
      } else if (s / 3 == a) {
        *closed = 1;
        break;
      } else {
        if (1 + na + nc >= RM2D_BALL_MAX) return -1;
        c = s / 3;
        lc = RM2D_PV3(s % 3);
        cw[nc] = c;
        lcw[nc++] = lc;
      }
    }
  }
  int n = 1 + na;
  if (*closed) { /* the clockwise chain, read back, closes the turn */
    for (int j = nc - 1; j >= 0; j--) {
      el[n] = cw[j];
      loc[n++] = lcw[j];
    }
  } else {
    for (int j = 0; j < nc; j++) {
      el[n] = cw[j];
      loc[n++] = lcw[j];
    }
  }
  return n;
}

/* The collapses of the collapse passes may lower the ball's worst quality
 * to this share of it: removing short edges comes first there, and the
 * swaps and relocations that follow restore the quality (not tuned). */
#define RM2D_QREL_COLLAPSE 0.3

/* Collapse vertex p = v[ip] of element k onto q, the other end of face fi of
 * k (fi != ip), if every new element has quality >= qrel times the ball's old
 * worst (collapse_2d.c). Returns 1 if done, 0 if rejected. */
int pa__rm2d_collapse_edge(rm2d *rm, pa_idx k, int fi, int ip, double qrel);
/* The operators the passes (driver_2d.c) call on element k; each returns
 * 1 if done, 0 if rejected (nothing changed).
 *  - split_2d.c: split face i of k at its midpoint (on a feature: on the
 *    reconstructed curve, or nearer the chord); *st on memory failure;
 *  - collapse_2d.c: remove vertex v[ip] of k by collapsing it onto another
 *    neighbour, the shortest edges first (when its own edge cannot go);
 *  - swap_2d.c: swap face i of k if the pair's worst quality rises by gain;
 *  - smooth_2d.c: move interior vertex v[ip] towards the ideal apexes of
 *    its ball (balls of worst quality under qfree may stretch their
 *    lengths), feature vertex v[ip] along its curve, and interior vertex
 *    v[ip] to bring its edges into range (the length moves). */
int pa__rm2d_split_edge(rm2d *rm, pa_idx k, int i, pa_status *st);
int pa__rm2d_remove_vertex(rm2d *rm, pa_idx k, int ip);
int pa__rm2d_swap_edge(rm2d *rm, pa_idx k, int i, double gain);
int pa__rm2d_smooth_vertex(rm2d *rm, pa_idx k, int ip, double qfree);
int pa__rm2d_smooth_feature(rm2d *rm, pa_idx k, int ip, double qfree);
int pa__rm2d_length_vertex(rm2d *rm, pa_idx k, int ip);
/* Move vertex v[ip] by its step onto its curve (rm2d.vcur), or half or a
 * quarter of it, when its ball's worst quality stays at least min(old
 * worst, RM2D_QLEN); the step left shrinks by what was made. Metric and
 * fields interpolated in the old ball. 1 if moved. As 3D's
 * pa__rm3d_curve_snap_vertex (smooth_3d.c). */
int pa__rm2d_curve_snap_vertex(rm2d *rm, pa_idx k, int ip);
/* Move free interior vertex v[ip] by delta (metric length of p) in a
 * direction drawn from its coordinates' bits, when every element of its
 * ball keeps half the ball's old worst quality. 1 if moved. As 3D's
 * pa__rm3d_jiggle_vertex (smooth_3d.c). */
int pa__rm2d_jiggle_vertex(rm2d *rm, pa_idx k, int ip, double delta);

#endif /* PA_OPS_2D_H */
