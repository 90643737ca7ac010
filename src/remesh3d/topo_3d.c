/*
 * topo_3d.c -- topological primitives of the 3D remesher: edge shells,
 * vertex balls and the generic cavity replacement used by the swaps.
 *
 * Invariants: these functions leave no RM3D_T_MARK bit set; pa__rm3d_replace
 * keeps every invariant of mesh_3d.c provided the new tetrahedra tile the
 * cavity exactly (same outer faces), which callers guarantee by checking
 * orientation and quality before calling it.
 */
#include "remesh3d/remesh3d.h"

/* Local edge index (pa__rm3d_edge) of the local vertex pair (i, j). */
static const signed char edge_of[4][4] = {
    {-1, 0, 1, 2}, {0, -1, 3, 4}, {1, 3, -1, 5}, {2, 4, 5, -1}};

/* Forward from k: around a closed shell once. An open one is completed
 * by a walk backward from k, whose tets go in front (the shell then starts
 * at its boundary face). */
int pa__rm3d_shell(const rm3d *m, pa_idx k, pa_idx a, pa_idx b, pa_idx *tets,
                   pa_idx *ring, signed char *edge, int max, int *info) {
  int inf = 0, n = 0;
  int32_t ref0 = m->tref[k];
  pa_idx t = k;
  for (;;) {
    if (n >= max) return -1;
    const pa_idx *v = m->tv + 4 * (size_t)t;
    int ia = rm3d_loc(v, a), ib = rm3d_loc(v, b);
    int ic = pa__rm3d_compl[ia][ib][0], id = pa__rm3d_compl[ia][ib][1];
    tets[n] = t;
    ring[n] = v[ic];
    if (edge) edge[n] = edge_of[ia][ib];
    n++;
    uint8_t fl = m->tflag[t];
    if (fl & ((1u << ic) | (1u << id))) inf |= RM3D_SH_BDRY;
    if (fl & RM3D_T_FROZEN) inf |= RM3D_SH_FROZEN;
    if (m->tref[t] != ref0) inf |= RM3D_SH_REFS;
    pa_idx nb = m->adj[4 * (size_t)t + ic];
    if (nb < 0) {
      ring[n] = v[id];
      break;
    }
    t = nb >> 2;
    if (t == k) {
      ring[n] = ring[0];
      *info = inf | RM3D_SH_CLOSED;
      return n;
    }
  }
  /* Open: count the tets behind k, make room, then fill them in. */
  int nback = 0;
  for (t = k;;) {
    const pa_idx *v = m->tv + 4 * (size_t)t;
    int id = pa__rm3d_compl[rm3d_loc(v, a)][rm3d_loc(v, b)][1];
    pa_idx nb = m->adj[4 * (size_t)t + id];
    if (nb < 0) break;
    t = nb >> 2;
    if (n + ++nback > max) return -1;
  }
  if (nback) {
    memmove(tets + nback, tets, (size_t)n * sizeof *tets);
    memmove(ring + nback, ring, (size_t)(n + 1) * sizeof *ring);
    if (edge) memmove(edge + nback, edge, (size_t)n * sizeof *edge);
    int i = nback;
    for (t = k; i > 0;) {
      const pa_idx *v = m->tv + 4 * (size_t)t;
      int id = pa__rm3d_compl[rm3d_loc(v, a)][rm3d_loc(v, b)][1];
      t = m->adj[4 * (size_t)t + id] >> 2;
      v = m->tv + 4 * (size_t)t;
      int ia = rm3d_loc(v, a), ib = rm3d_loc(v, b);
      int ic = pa__rm3d_compl[ia][ib][0];
      id = pa__rm3d_compl[ia][ib][1];
      tets[--i] = t;
      ring[i] = v[ic];
      if (edge) edge[i] = edge_of[ia][ib];
      uint8_t fl = m->tflag[t];
      if (fl & ((1u << ic) | (1u << id))) inf |= RM3D_SH_BDRY;
      if (fl & RM3D_T_FROZEN) inf |= RM3D_SH_FROZEN;
      if (m->tref[t] != ref0) inf |= RM3D_SH_REFS;
    }
    n += nback;
  }
  *info = inf;
  return n;
}

/* Breadth first through the faces holding p. A tet's local index of p is
 * found when the tet is taken from the queue, and its records are
 * prefetched when it is queued: the walk is bound by memory latency. */
int pa__rm3d_ball(rm3d *m, pa_idx p, pa_idx *ball, int max) {
  pa_idx k = m->vtet[p];
  int n = 0, head = 0, over = 0;
  ball[n++] = 4 * k;
  m->tflag[k] |= RM3D_T_MARK;
  while (head < n && !over) {
    pa_idx t = ball[head] >> 2;
    int ip = rm3d_loc(m->tv + 4 * (size_t)t, p);
    ball[head++] = 4 * t + ip;
    for (int i = 0; i < 4; i++) {
      if (i == ip) continue;
      pa_idx nb = m->adj[4 * (size_t)t + i];
      if (nb < 0) continue;
      pa_idx u = nb >> 2;
      if (m->tflag[u] & RM3D_T_MARK) continue;
      if (n >= max) {
        over = 1;
        break;
      }
      __builtin_prefetch(m->tv + 4 * (size_t)u);
      __builtin_prefetch(m->adj + 4 * (size_t)u);
      m->tflag[u] |= RM3D_T_MARK;
      ball[n++] = 4 * u;
    }
  }
  for (int i = 0; i < n; i++) m->tflag[ball[i] >> 2] &= (uint8_t)~RM3D_T_MARK;
  return over ? -1 : n;
}

pa_status pa__rm3d_balls_build(const rm3d *m, rm3d_balls *b) {
  pa_status st = PA_SUCCESS;
  pa_idx nv = m->nv;
  b->start = b->ent = NULL;
  PA_CALLOC(b->start, (size_t)nv + 2);
  pa_idx *c = b->start + 1; /* c[p + 1] counts, then c[p] fills p */
  size_t nent = 0;
  for (pa_idx k = 0; k < m->ne; k++) {
    if (m->tflag[k] & RM3D_T_DEAD) continue;
    const pa_idx *v = m->tv + 4 * (size_t)k;
    for (int j = 0; j < 4; j++) c[v[j] + 1]++;
    nent += 4;
  }
  for (pa_idx p = 0; p < nv; p++) c[p + 1] += c[p];
  PA_ALLOC(b->ent, nent);
  for (pa_idx k = 0; k < m->ne; k++) {
    if (m->tflag[k] & RM3D_T_DEAD) continue;
    const pa_idx *v = m->tv + 4 * (size_t)k;
    for (int j = 0; j < 4; j++) b->ent[c[v[j]]++] = 4 * k + j;
  }
cleanup:
  if (st) pa__rm3d_balls_free(b);
  return st;
}

void pa__rm3d_balls_free(rm3d_balls *b) {
  pa__free(b->start);
  pa__free(b->ent);
  b->start = b->ent = NULL;
}

typedef struct face_key {
  pa_idx k[3];
  pa_idx slot; /* outer neighbour slot (ext) or new tet slot (pending) */
  int tag;
} face_key;

static void face_sorted(const pa_idx *v, int f, pa_idx *k) {
  k[0] = v[pa__rm3d_face[f][0]];
  k[1] = v[pa__rm3d_face[f][1]];
  k[2] = v[pa__rm3d_face[f][2]];
  pa__sort_small(k, 3);
}

#define R3_REPLACE_MAXOLD 24
#define R3_REPLACE_MAXNEW 48

pa_status pa__rm3d_replace(rm3d *m, const pa_idx *old, int nold,
                           const pa_idx *nv4, int nnew, int32_t ref,
                           uint8_t pf, int nbswap) {
  pa_status st = PA_SUCCESS;
  face_key ext[4 * R3_REPLACE_MAXOLD], pend[4 * R3_REPLACE_MAXNEW];
  int next = 0, npend = 0;
  pa_idx idx[R3_REPLACE_MAXNEW];
  PA_CHECK(nold <= R3_REPLACE_MAXOLD && nnew <= R3_REPLACE_MAXNEW,
           PA_ERR_INTERNAL, "rm3d: cavity too large");
  PA_CALL(pa__rm3d_reserve(m, 0, (size_t)m->ne + nnew));
  for (int i = 0; i < nold; i++) m->tflag[old[i]] |= RM3D_T_MARK;
  for (int i = 0; i < nold; i++) {
    pa_idx t = old[i];
    for (int f = 0; f < 4; f++) {
      pa_idx a = m->adj[4 * (size_t)t + f];
      if (a >= 0 && (m->tflag[a >> 2] & RM3D_T_MARK)) continue;
      face_sorted(m->tv + 4 * (size_t)t, f, ext[next].k);
      ext[next].slot = a;
      ext[next].tag = (m->tflag[t] >> f) & 1;
      next++;
    }
  }
  for (int i = 0; i < nold; i++) m->tflag[old[i]] &= (uint8_t)~RM3D_T_MARK;
  for (int i = 0; i < nnew; i++) idx[i] = i < nold ? old[i] : m->ne++;
  for (int i = nnew; i < nold; i++) {
    m->tflag[old[i]] = RM3D_T_DEAD;
    m->ndead_t++;
  }
  for (int i = 0; i < nnew; i++) {
    pa_idx t = idx[i];
    memcpy(m->tv + 4 * (size_t)t, nv4 + 4 * i, 4 * sizeof(pa_idx));
    m->tflag[t] = 0;
    m->tpf[t] = pf;
    m->tref[t] = ref;
  }
  for (int i = 0; i < nnew; i++) {
    pa_idx t = idx[i];
    for (int f = 0; f < 4; f++) {
      pa_idx key[3];
      face_sorted(nv4 + 4 * i, f, key);
      pa_idx self = 4 * t + f;
      int j;
      for (j = 0; j < next; j++)
        if (ext[j].k[0] == key[0] && ext[j].k[1] == key[1] &&
            ext[j].k[2] == key[2])
          break;
      if (j < next) {
        pa_idx a = ext[j].slot;
        m->adj[self] = a;
        if (a >= 0) m->adj[a] = self;
        if (ext[j].tag) m->tflag[t] |= (uint8_t)(1u << f);
        ext[j] = ext[--next];
        continue;
      }
      for (j = 0; j < npend; j++)
        if (pend[j].k[0] == key[0] && pend[j].k[1] == key[1] &&
            pend[j].k[2] == key[2])
          break;
      if (j < npend) {
        m->adj[self] = pend[j].slot;
        m->adj[pend[j].slot] = self;
        pend[j] = pend[--npend];
        continue;
      }
      PA_CHECK(npend < 4 * R3_REPLACE_MAXNEW, PA_ERR_INTERNAL,
               "rm3d: cavity faces overflow");
      memcpy(pend[npend].k, key, sizeof key);
      pend[npend].slot = self;
      npend++;
    }
  }
  /* A boundary swap leaves nbswap old domain-boundary faces unmatched and
   * as many new faces without a partner: these become the new boundary. */
  PA_CHECK(npend == nbswap && next == nbswap, PA_ERR_INTERNAL,
           "rm3d: new tetrahedra do not fill the cavity");
  for (int j = 0; j < next; j++)
    PA_CHECK(ext[j].slot < 0 && ext[j].tag, PA_ERR_INTERNAL,
             "rm3d: boundary swap would open an interior face");
  for (int j = 0; j < npend; j++) {
    pa_idx self = pend[j].slot;
    m->adj[self] = -1;
    m->tflag[self >> 2] |= (uint8_t)(1u << (self & 3));
  }
  for (int i = 0; i < nnew; i++) {
    pa_idx t = idx[i];
    const pa_idx *v = m->tv + 4 * (size_t)t;
    if (t < m->nswapfail) m->swapfail[t] = 0;
    for (int j = 0; j < 4; j++) m->vtet[v[j]] = t;
    m->q[t] = (float)rm3d_qual_v(m, v);
    m->tflag[t] &= (uint8_t)~RM3D_T_CLEAN;
  }
cleanup:
  return st;
}
