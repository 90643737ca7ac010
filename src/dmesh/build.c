/*
 * build.c -- the build pipeline shared by every way of making a distributed
 * mesh (scatter from a root, per-rank files, redistribution): from records of
 * owned elements with a destination rank and of vertices, boundary entities
 * and edges held anywhere, it migrates the elements, builds the ghost layers,
 * fetches vertices and boundary entities, resolves the owners and builds the
 * star forests (see dmesh.h for the ownership rule and the local numbering).
 *
 * Rendezvous ("directory") ranks: vertex records, and the boundary entities
 * and edges whose smallest vertex gid is theirs, are kept during the build by
 * the rank dir(gid) = gid / ceil((max gid + 1) / P). The directory learns
 * which ranks own elements touching each vertex ("touch lists", sorted by
 * rank), which gives the vertex owner (lowest touching rank) and routes the
 * ghost requests of each layer to the ranks owning the elements around a
 * vertex. Every step is a sparse all-to-all (exchange.h), so the memory per
 * rank is O(local entities), never O(global).
 */
#include "dmesh/dmesh.h"

#include <limits.h>

typedef struct dirmap {
  pa_gid block;
  int size;
} dirmap;

static void dir_init(dirmap *d, pa_gid maxgid, int size) {
  d->size = size;
  d->block = (maxgid + size) / size;
  if (d->block < 1) d->block = 1;
}

static int dir_rank(const dirmap *d, pa_gid g) {
  pa_gid r = g / d->block;
  return r >= d->size ? d->size - 1 : (int)r;
}

/* Collective: send fixed-size items (unit bytes) to ranks dest[i]. On return
 * *rcnt[r] is the number of items received from rank r and *recv holds them
 * by source rank. */
static pa_status send_items(MPI_Comm comm, size_t n, size_t unit,
                            const void *items, const int *dest, size_t **rcnt,
                            void **recv) {
  pa_status st = PA_SUCCESS;
  int size;
  size_t *cnt = NULL, *pos = NULL;
  unsigned char *buf = NULL;
  MPI_Comm_size(comm, &size);
  *rcnt = NULL;
  *recv = NULL;
  PA_CALLOC(cnt, size);
  PA_CALLOC(pos, (size_t)size + 1);
  for (size_t i = 0; i < n; i++) cnt[dest[i]]++;
  for (int r = 0; r < size; r++) pos[r + 1] = pos[r] + cnt[r];
  PA_ALLOC(buf, n * unit);
  for (size_t i = 0; i < n; i++)
    memcpy(buf + unit * pos[dest[i]]++, (const unsigned char *)items + unit * i,
           unit);
  for (int r = 0; r < size; r++) cnt[r] *= unit;
  PA_CALL(pa__xchg_sparse(comm, cnt, buf, rcnt, recv));
  for (int r = 0; r < size; r++) (*rcnt)[r] /= unit;
cleanup:
  st = pa__agree_end(comm, st);
  pa__free(cnt);
  pa__free(pos);
  pa__free(buf);
  return st;
}

/* Collective: owner of each of n local entities = lowest rank with cand = 1
 * among the ranks holding the entity (gid). owner[i] = -1 if none. */
static pa_status resolve_owner(MPI_Comm comm, size_t n, const pa_gid *gid,
                               const uint8_t *cand, int *owner) {
  pa_status st = PA_SUCCESS;
  int rank, size;
  pa_gid maxg = -1;
  dirmap d;
  int *dest = NULL;
  pa_gid *item = NULL, *rec = NULL, *back = NULL;
  size_t *rcnt = NULL, *bcnt = NULL;
  void *recv = NULL;
  int *best = NULL;
  pa__gidmap map = {0};
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  for (size_t i = 0; i < n; i++)
    if (gid[i] > maxg) maxg = gid[i];
  PA_CALL(pa__allreduce(comm, &maxg, 1, MPI_INT64_T, MPI_MAX));
  dir_init(&d, maxg, size);
  PA_ALLOC(dest, n);
  PA_ALLOC(item, 2 * n);
  for (size_t i = 0; i < n; i++) {
    dest[i] = dir_rank(&d, gid[i]);
    item[2 * i] = gid[i];
    item[2 * i + 1] = cand[i];
  }
  PA_CALL(send_items(comm, n, 2 * sizeof(pa_gid), item, dest, &rcnt, &recv));
  rec = recv;
  size_t nrec = 0;
  for (int r = 0; r < size; r++) nrec += rcnt[r];
  PA_CALL(pa__gidmap_init(&map, nrec));
  PA_ALLOC(best, nrec);
  {
    size_t j = 0;
    for (int r = 0; r < size; r++)
      for (size_t q = 0; q < rcnt[r]; q++, j++) {
        int found;
        pa_idx slot;
        PA_CALL(pa__gidmap_put(&map, rec[2 * j], (pa_idx)j, &found, &slot));
        if (!found) {
          slot = (pa_idx)j;
          best[j] = INT_MAX;
        }
        if (rec[2 * j + 1] && r < best[slot]) best[slot] = r;
      }
  }
  /* Reply, in the order received, with the owner. */
  {
    int *rdest;
    PA_ALLOC(back, 2 * nrec);
    rdest = pa__malloc((nrec ? nrec : 1) * sizeof *rdest);
    PA_CHECK(rdest, PA_ERR_MEMORY, "out of memory");
    size_t j = 0;
    for (int r = 0; r < size; r++)
      for (size_t q = 0; q < rcnt[r]; q++, j++) {
        pa_idx slot = pa__gidmap_get(&map, rec[2 * j]);
        back[2 * j] = rec[2 * j];
        back[2 * j + 1] = best[slot] == INT_MAX ? -1 : best[slot];
        rdest[j] = r;
      }
    pa__free(recv);
    recv = NULL;
    st = send_items(comm, nrec, 2 * sizeof(pa_gid), back, rdest, &bcnt, &recv);
    pa__free(rdest);
    if (st) goto cleanup;
  }
  /* Answers come back grouped by directory rank, in the order sent. */
  {
    size_t *pos;
    PA_CALLOC(pos, (size_t)size + 1);
    for (int r = 0; r < size; r++) pos[r + 1] = pos[r] + bcnt[r];
    const pa_gid *ans = recv;
    for (size_t i = 0; i < n; i++) {
      size_t k = pos[dest[i]]++;
      PA_ASSERT(ans[2 * k] == gid[i]);
      owner[i] = (int)ans[2 * k + 1];
    }
    pa__free(pos);
  }
cleanup:
  st = pa__agree_end(comm, st);
  pa__free(dest);
  pa__free(item);
  pa__free(back);
  pa__free(rcnt);
  pa__free(bcnt);
  pa__free(recv);
  pa__free(best);
  pa__gidmap_free(&map);
  return st;
}

pa_status pa__gids_unique(MPI_Comm comm, size_t n, const pa_gid *gid,
                          const char *what) {
  pa_status st = PA_SUCCESS;
  int size;
  pa_gid maxg = -1;
  dirmap d;
  int *dest = NULL;
  size_t *rcnt = NULL, nr = 0;
  void *recv = NULL;
  MPI_Comm_size(comm, &size);
  for (size_t i = 0; i < n; i++) {
    PA_CHECK(gid[i] >= 0, PA_ERR_FORMAT, "negative %s global id %lld", what,
             (long long)gid[i]);
    if (gid[i] > maxg) maxg = gid[i];
  }
  PA_CALL(pa__allreduce(comm, &maxg, 1, MPI_INT64_T, MPI_MAX));
  dir_init(&d, maxg, size);
  PA_ALLOC(dest, n);
  for (size_t i = 0; i < n; i++) dest[i] = dir_rank(&d, gid[i]);
  PA_CALL(send_items(comm, n, sizeof(pa_gid), gid, dest, &rcnt, &recv));
  for (int r = 0; r < size; r++) nr += rcnt[r];
  {
    pa_gid *g = recv;
    size_t nu = pa__gid_sort_unique(g, nr);
    PA_CHECK(nu == nr, PA_ERR_FORMAT, "%zu %s global ids are given twice",
             nr - nu, what);
  }
cleanup:
  st = pa__agree_end(comm, st);
  pa__free(dest);
  pa__free(rcnt);
  pa__free(recv);
  return st;
}

/* Build-time state. */
typedef struct bstate {
  MPI_Comm comm;
  int rank, size, dim, nve;
  dirmap vdir;
  /* directory side */
  pa__recs V, B, D;         /* vertex records, bdry/edges by smallest vertex */
  pa__gidindex vix;         /* vertex gid -> index in V */
  pa_idx *bstart, *blist;   /* V index -> B records (CSR) */
  pa_idx *dstart, *dlist;   /* V index -> D records */
  pa_idx *tstart;           /* V index -> touching ranks (CSR) */
  int *trank;
  /* the touch messages, kept: they are also the layer-1 queries and the
   * owned-vertex part of the fetch (the same gids to the same ranks) */
  size_t *tcnt;             /* items received from each rank */
  pa_gid *tgid;             /* their gids, by source rank */
  pa_idx *tv;               /* their V indices */
  /* local side */
  pa__recs L;               /* local elements: owned first; aux = owner */
  uint8_t *layer;           /* per L record */
  size_t caplayer;
  pa__gidmap emap;          /* ghost element gid -> L index */
  /* owned elements around each vertex of an owned element (one sort) */
  size_t nu;                /* vertices of owned elements */
  pa_gid *ukey;             /* their gids, ascending */
  pa_idx *ustart, *uelem;   /* CSR: u -> owned L indices */
  pa__gidindex uix;         /* gid -> u (dense without uslot: gid -> local
                             * vertex in assemble) */
  pa_idx *uslot;            /* u of each vertex slot of the owned elements */
  pa_idx *ulv;              /* LV record of each u (fetch), then its local
                             * vertex (assemble): the owned elements' vertices
                             * are numbered by two array reads a slot, not by
                             * a lookup in uix each */
  pa__recs LV, LB, LD;      /* local vertices / bdry / edges (aux = owner) */
  /* private vertices (pa__dmesh_build_priv): records kept here, sorted by
   * gid, out of the directory; upriv[u]: vertex u is one of them */
  pa__recs *P;
  size_t npriv;             /* P's records (P is emptied when they join LV) */
  uint8_t *upriv;
} bstate;

static void bstate_free(bstate *s) {
  pa__recs_free(&s->V);
  pa__recs_free(&s->B);
  pa__recs_free(&s->D);
  pa__gidindex_free(&s->vix);
  pa__free(s->bstart);
  pa__free(s->blist);
  pa__free(s->dstart);
  pa__free(s->dlist);
  pa__free(s->tstart);
  pa__free(s->trank);
  s->bstart = s->blist = s->dstart = s->dlist = s->tstart = NULL;
  s->trank = NULL;
  pa__free(s->tcnt);
  pa__free(s->tgid);
  pa__free(s->tv);
  s->tcnt = NULL;
  s->tgid = NULL;
  s->tv = NULL;
  pa__recs_free(&s->L);
  pa__free(s->layer);
  s->layer = NULL;
  s->caplayer = 0;
  pa__gidmap_free(&s->emap);
  pa__free(s->ukey);
  pa__free(s->ustart);
  pa__free(s->uelem);
  s->ukey = NULL;
  s->ustart = s->uelem = NULL;
  pa__gidindex_free(&s->uix);
  pa__free(s->uslot);
  pa__free(s->ulv);
  s->uslot = s->ulv = NULL;
  pa__recs_free(&s->LV);
  pa__recs_free(&s->LB);
  pa__recs_free(&s->LD);
  pa__free(s->upriv);
  s->upriv = NULL;
}

/* 1 if g is the gid of a private vertex (binary search in s->P). */
static int is_private(const bstate *s, pa_gid g) {
  if (!s->P || !s->P->n) return 0;
  size_t k = pa__gid_lower_bound(s->P->gid, s->P->n, g);
  return k < s->P->n && s->P->gid[k] == g;
}

static pa_gid min_vgid(const pa__recs *r, size_t i) {
  const pa_gid *v = r->vgid + (size_t)r->nv * i;
  pa_gid m = v[0];
  for (int k = 1; k < r->nv; k++)
    if (v[k] < m) m = v[k];
  return m;
}

/* Attach records of R (bdry or edges) to their smallest vertex in V (CSR);
 * those whose smallest vertex is private (sent to this rank, see
 * build_directory) are left out: they are local here. */
static pa_status attach(bstate *s, const pa__recs *R, pa_idx **start,
                        pa_idx **list) {
  pa_status st = PA_SUCCESS;
  size_t nV = s->V.n;
  PA_CALLOC(*start, nV + 1);
  PA_ALLOC(*list, R->n);
  for (size_t i = 0; i < R->n; i++) {
    pa_idx v = pa__gidindex_get(&s->vix, min_vgid(R, i));
    if (v < 0 && is_private(s, min_vgid(R, i))) continue;
    PA_CHECK(v >= 0, PA_ERR_MESH,
             "%s of global id %lld references vertex %lld, which does not "
             "exist", R->kind == PA_BOUNDARY ? "boundary entity" : "edge",
             (long long)R->gid[i], (long long)min_vgid(R, i));
    (*start)[v + 1]++;
  }
  for (size_t v = 0; v < nV; v++) (*start)[v + 1] += (*start)[v];
  for (size_t i = 0; i < R->n; i++) {
    pa_idx v = pa__gidindex_get(&s->vix, min_vgid(R, i));
    if (v >= 0) (*list)[(*start)[v]++] = (pa_idx)i;
  }
  for (size_t v = nV; v > 0; v--) (*start)[v] = (*start)[v - 1];
  (*start)[0] = 0;
cleanup:
  return st;
}

/* Steps 1-2: directory of vertices, boundary entities and edges. */
static pa_status build_directory(bstate *s, pa__recs *verts, pa__recs *bdry,
                                 pa__recs *edges) {
  pa_status st = PA_SUCCESS;
  int *dest = NULL;
  size_t nmax = verts->n > bdry->n ? verts->n : bdry->n;
  if (edges->n > nmax) nmax = edges->n;
  PA_ALLOC(dest, nmax);
  for (size_t i = 0; i < verts->n; i++) dest[i] = dir_rank(&s->vdir, verts->gid[i]);
  PA_CALL(pa__recs_migrate_free(s->comm, verts, dest, &s->V));
  /* (a boundary entity or edge whose smallest vertex is private is in
   * local elements only: it stays here) */
  for (size_t i = 0; i < bdry->n; i++)
    dest[i] = is_private(s, min_vgid(bdry, i))
                  ? s->rank
                  : dir_rank(&s->vdir, min_vgid(bdry, i));
  PA_CALL(pa__recs_migrate_free(s->comm, bdry, dest, &s->B));
  for (size_t i = 0; i < edges->n; i++)
    dest[i] = is_private(s, min_vgid(edges, i))
                  ? s->rank
                  : dir_rank(&s->vdir, min_vgid(edges, i));
  PA_CALL(pa__recs_migrate_free(s->comm, edges, dest, &s->D));
  /* V is sorted by gid and holds the gids of this directory's block: dense */
  PA_CALL(pa__gidindex_init(&s->vix, s->V.n ? s->V.gid[0] : 0,
                            s->V.n ? s->V.gid[s->V.n - 1] + 1 : 0, s->V.n));
  for (size_t i = 0; i < s->V.n; i++) {
    int found;
    PA_CALL(pa__gidindex_put(&s->vix, s->V.gid[i], (pa_idx)i, &found, NULL));
    PA_CHECK(!found, PA_ERR_MESH, "vertex global id %lld is given twice",
             (long long)s->V.gid[i]);
  }
  for (size_t i = 1; i < s->B.n; i++)
    PA_CHECK(s->B.gid[i] != s->B.gid[i - 1], PA_ERR_MESH,
             "boundary entity global id %lld is given twice",
             (long long)s->B.gid[i]);
  PA_CALL(attach(s, &s->B, &s->bstart, &s->blist));
  PA_CALL(attach(s, &s->D, &s->dstart, &s->dlist));
cleanup:
  pa__free(dest);
  return st;
}

/* The vertices of the owned elements: ukey (sorted unique gids), the index
 * uix (gid -> u), the u of each vertex slot (uslot) and, if csr (ghost
 * layers to build), the owned elements around each (CSR ustart/uelem).
 * When the gids of the slots are dense (uix is an array over their range:
 * the usual case), marking the range and one scan of it number the
 * vertices in ascending gid order, with no sort, and without csr uslot
 * stays NULL (assemble turns uix into gid -> local vertex: one read a
 * slot, cheaper than uslot's two); otherwise they are
 * numbered by hashing and only the nu unique gids are sorted (not the
 * (dim+1) nown element slots). */
static pa_status owned_csr(bstate *s, pa_idx nown, int csr) {
  pa_status st = PA_SUCCESS;
  size_t np = (size_t)nown * s->nve, nu = 0;
  pa_idx *slotu = NULL, *ord = NULL, *rankof = NULL;
  pa_gid *key = NULL, lo = INT64_MAX, hi = -1;
  const pa_gid *vg = s->L.vgid;
  for (size_t p = 0; p < np; p++) {
    if (vg[p] < lo) lo = vg[p];
    if (vg[p] > hi) hi = vg[p];
  }
  /* sized to the vertices (about n/5 in 3D, n/2 in 2D), not to the slots:
   * smaller, so it stays closer to cache (a map grows if needed) */
  PA_CALL(pa__gidindex_init(&s->uix, np ? lo : 0, hi + 1,
                            (size_t)nown / (s->dim == 3 ? 5 : 2) + 16));
  if (s->uix.dense) {
    pa_idx *u = s->uix.dense; /* u[gid - lo] */
    /* -2: present, not numbered yet (stores only, no branch on what was
     * there: a vertex is first seen at random among its elements) */
    for (size_t p = 0; p < np; p++) u[vg[p] - lo] = -2;
    /* ukey sized to at most the range or the slots (the pages beyond nu
     * stay untouched): one scan numbers the vertices */
    size_t ncap = (size_t)(hi - lo) + 1 < np ? (size_t)(hi - lo) + 1 : np;
    PA_ALLOC(s->ukey, ncap);
    for (pa_gid g = lo; g <= hi; g++)
      if (u[g - lo] == -2) {
        s->ukey[nu] = g;
        u[g - lo] = (pa_idx)nu++;
      }
    if (csr) {
      PA_ALLOC(slotu, np);
      for (size_t p = 0; p < np; p++) slotu[p] = u[vg[p] - lo];
    }
  } else {
    PA_ALLOC(slotu, np);
    for (size_t p = 0; p < np; p++) {
      int found;
      pa_idx old;
      PA_CALL(pa__gidmap_put(&s->uix.map, vg[p], (pa_idx)nu, &found, &old));
      slotu[p] = found ? old : (pa_idx)nu++;
    }
    /* first-seen numbers -> ascending gid numbers */
    PA_ALLOC(key, nu);
    PA_ALLOC(ord, nu);
    PA_ALLOC(rankof, nu);
    for (size_t p = 0; p < np; p++) key[slotu[p]] = vg[p];
    for (size_t u = 0; u < nu; u++) ord[u] = (pa_idx)u;
    PA_CALL(pa__sort_by_gid(ord, nu, key));
    PA_ALLOC(s->ukey, nu);
    for (size_t k = 0; k < nu; k++) {
      s->ukey[k] = key[ord[k]];
      rankof[ord[k]] = (pa_idx)k;
    }
    pa__gidmap *m = &s->uix.map;
    for (size_t q = 0; q < m->cap; q++)
      if (m->key[q] >= 0) m->val[q] = rankof[m->val[q]];
    for (size_t p = 0; p < np; p++) slotu[p] = rankof[slotu[p]];
  }
  s->nu = nu;
  s->uslot = slotu;
  slotu = NULL;
  if (!csr) goto cleanup;
  PA_CALLOC(s->ustart, nu + 1);
  PA_ALLOC(s->uelem, np);
  for (size_t p = 0; p < np; p++) s->ustart[s->uslot[p] + 1]++;
  for (size_t u = 0; u < nu; u++) s->ustart[u + 1] += s->ustart[u];
  for (size_t e = 0, p = 0; e < (size_t)nown; e++)
    for (int k = 0; k < s->nve; k++, p++)
      s->uelem[s->ustart[s->uslot[p]]++] = (pa_idx)e;
  for (size_t u = nu; u > 0; u--) s->ustart[u] = s->ustart[u - 1];
  s->ustart[0] = 0;
cleanup:
  pa__free(slotu);
  pa__free(ord);
  pa__free(rankof);
  pa__free(key);
  return st;
}

/* Unique vertex gids, ascending, of the ghost elements with layer in
 * [l0, l1] that are not vertices of owned elements. */
static pa_status ghost_verts(bstate *s, int l0, int l1, pa_gid **out,
                             size_t *nout) {
  pa_status st = PA_SUCCESS;
  size_t n = 0;
  pa_gid *g = NULL;
  for (size_t e = 0; e < s->L.n; e++)
    if (s->layer[e] >= l0 && s->layer[e] <= l1) n += (size_t)s->nve;
  PA_ALLOC(g, n);
  n = 0;
  for (size_t e = 0; e < s->L.n; e++)
    if (s->layer[e] >= l0 && s->layer[e] <= l1)
      for (int k = 0; k < s->nve; k++) {
        pa_gid v = s->L.vgid[(size_t)s->nve * e + k];
        if (pa__gidindex_get(&s->uix, v) < 0) g[n++] = v;
      }
  *nout = pa__gid_sort_unique(g, n);
  *out = g;
cleanup:
  return st;
}

/* Collective: send the n vertex gids g to their rendezvous ranks (as
 * send_items). */
static pa_status send_to_directory(bstate *s, const pa_gid *g, size_t n,
                                   size_t **rcnt, void **recv) {
  pa_status st = PA_SUCCESS;
  int *dest = NULL;
  PA_ALLOC(dest, n ? n : 1);
  for (size_t i = 0; i < n; i++) dest[i] = dir_rank(&s->vdir, g[i]);
  PA_CALL(send_items(s->comm, n, sizeof(pa_gid), g, dest, rcnt, recv));
cleanup:
  st = pa__agree_end(s->comm, st);
  pa__free(dest);
  return st;
}

/* Step 3: the directory records which ranks own elements touching each
 * vertex. The messages stay in s (tcnt, tgid, tv) for the layer-1 queries
 * and the fetch. */
static pa_status build_touch(bstate *s) {
  pa_status st = PA_SUCCESS;
  size_t n;
  void *recv = NULL;
  pa_gid *g = NULL;
  n = s->nu;
  if (s->P && s->P->n) {
    /* mark the private vertices (both lists sorted) and leave them out */
    PA_CALLOC(s->upriv, s->nu ? s->nu : 1);
    PA_ALLOC(g, s->nu ? s->nu : 1);
    n = 0;
    for (size_t u = 0, i = 0; u < s->nu; u++) {
      while (i < s->P->n && s->P->gid[i] < s->ukey[u]) i++;
      if (i < s->P->n && s->P->gid[i] == s->ukey[u]) s->upriv[u] = 1;
      else g[n++] = s->ukey[u];
    }
  }
  PA_CALL(send_to_directory(s, g ? g : s->ukey, n, &s->tcnt, &recv));
  s->tgid = recv;
  recv = NULL;
  const pa_gid *rg = s->tgid;
  size_t nV = s->V.n, tot = 0;
  PA_CALLOC(s->tstart, nV + 1);
  for (int r = 0; r < s->size; r++) tot += s->tcnt[r];
  PA_ALLOC(s->trank, tot);
  PA_ALLOC(s->tv, tot);
  for (size_t j = 0; j < tot; j++) {
    pa_idx v = pa__gidindex_get(&s->vix, rg[j]);
    PA_CHECK(v >= 0, PA_ERR_MESH,
             "an element references vertex %lld, which does not exist",
             (long long)rg[j]);
    s->tv[j] = v;
    s->tstart[v + 1]++;
  }
  for (size_t v = 0; v < nV; v++) s->tstart[v + 1] += s->tstart[v];
  {
    size_t j = 0;
    for (int r = 0; r < s->size; r++) /* by rank: lists come out sorted */
      for (size_t q = 0; q < s->tcnt[r]; q++, j++)
        s->trank[s->tstart[s->tv[j]]++] = r;
  }
  for (size_t v = nV; v > 0; v--) s->tstart[v] = s->tstart[v - 1];
  s->tstart[0] = 0;
cleanup:
  st = pa__agree_end(s->comm, st);
  pa__free(recv);
  pa__free(g);
  return st;
}

static pa_status add_local_elem(bstate *s, const pa__recs *R, size_t i,
                                int owner, int layer) {
  pa_status st = PA_SUCCESS;
  int found;
  PA_CALL(pa__gidmap_put(&s->emap, R->gid[i], (pa_idx)s->L.n, &found, NULL));
  if (found) return PA_SUCCESS;
  PA_CALL(pa__recs_add(&s->L, R->gid[i], R->vgid + (size_t)R->nv * i, R->ref[i],
                       R->flag[i], owner, R->dbl + (size_t)R->ndbl * i,
                       R->poff ? R->pay + R->poff[i] : NULL,
                       R->poff ? R->poff[i + 1] - R->poff[i] : 0));
  PA_GROW(s->layer, s->caplayer, s->L.n);
  s->layer[s->L.n - 1] = (uint8_t)layer;
cleanup:
  return st;
}

/* Step 4a (layer l): the vertices queried for layer l, as the directory
 * received them: their count per source rank (*qcnt), global ids (*rg) and
 * V indices (*qv), *tot in all. Layer 1 queries the vertices of the owned
 * elements, sent already as the touch messages; layer l > 1 the vertices of
 * layer l-1 not queried yet. What it allocates goes to *rcnt, *recv, *vq. */
static pa_status layer_queries(bstate *s, int l, pa__gidmap *queried,
                               const size_t **qcnt, const pa_gid **rg,
                               const pa_idx **qv, size_t *tot, size_t **rcnt,
                               void **recv, pa_idx **vq) {
  pa_status st = PA_SUCCESS;
  pa_gid *g = NULL;
  *tot = 0;
  if (l == 1) {
    *qcnt = s->tcnt;
    *rg = s->tgid;
    *qv = s->tv;
    for (int r = 0; r < s->size; r++) *tot += s->tcnt[r];
    goto cleanup;
  }
  size_t n, nq = 0;
  PA_CALL(ghost_verts(s, l - 1, l - 1, &g, &n));
  for (size_t i = 0; i < n; i++) {
    int found;
    PA_CALL(pa__gidmap_put(queried, g[i], 0, &found, NULL));
    if (!found) g[nq++] = g[i];
  }
  PA_CALL(send_to_directory(s, g, nq, rcnt, recv));
  *rg = *recv;
  for (int r = 0; r < s->size; r++) *tot += (*rcnt)[r];
  PA_ALLOC(*vq, *tot);
  for (size_t j = 0; j < *tot; j++) {
    (*vq)[j] = pa__gidindex_get(&s->vix, (*rg)[j]);
    PA_CHECK((*vq)[j] >= 0, PA_ERR_INTERNAL,
             "ghost query of unknown vertex %lld", (long long)(*rg)[j]);
  }
  *qcnt = *rcnt;
  *qv = *vq;
cleanup:
  pa__free(g);
  return st;
}

/* Step 4b: the directory forwards each query (vertex, requester) to the
 * other ranks touching the vertex; *fcnt, *frecv: what this rank received
 * as an owner of elements. */
static pa_status forward_queries(bstate *s, const size_t *qcnt,
                                 const pa_gid *rg, const pa_idx *qv,
                                 size_t tot, size_t **fcnt, void **frecv) {
  pa_status st = PA_SUCCESS;
  pa_gid *fw = NULL;
  int *fwdest = NULL;
  size_t nfw = 0, j = 0, k = 0;
  for (size_t q = 0; q < tot; q++)
    nfw += (size_t)(s->tstart[qv[q] + 1] - s->tstart[qv[q]]);
  PA_ALLOC(fw, 2 * nfw);
  PA_ALLOC(fwdest, nfw);
  for (int r = 0; r < s->size; r++)
    for (size_t q = 0; q < qcnt[r]; q++, j++) {
      pa_idx v = qv[j];
      for (pa_idx t = s->tstart[v]; t < s->tstart[v + 1]; t++)
        if (s->trank[t] != r) {
          fw[2 * k] = rg[j];
          fw[2 * k + 1] = r;
          fwdest[k++] = s->trank[t];
        }
    }
  PA_CALL(send_items(s->comm, k, 2 * sizeof(pa_gid), fw, fwdest, fcnt, frecv));
cleanup:
  pa__free(fw);
  pa__free(fwdest);
  return st;
}

/* Step 4c (owner side): the (requester, owned element) pairs of the
 * forwarded queries, as requester * nown + element, sorted and unique. */
static pa_status owner_pairs(bstate *s, pa_idx nown, const size_t *fcnt,
                             const pa_gid *fr, pa_gid **pair, size_t *npair) {
  pa_status st = PA_SUCCESS;
  size_t nf = 0, n = 0;
  for (int r = 0; r < s->size; r++) nf += fcnt[r];
  for (size_t j = 0; j < nf; j++) {
    pa_idx u = pa__gidindex_get(&s->uix, fr[2 * j]);
    PA_CHECK(u >= 0, PA_ERR_INTERNAL, "forwarded query of vertex %lld "
             "that no owned element has", (long long)fr[2 * j]);
    n += (size_t)(s->ustart[u + 1] - s->ustart[u]);
  }
  PA_ALLOC(*pair, n);
  n = 0;
  for (size_t j = 0; j < nf; j++) {
    pa_idx u = pa__gidindex_get(&s->uix, fr[2 * j]);
    for (pa_idx p = s->ustart[u]; p < s->ustart[u + 1]; p++)
      (*pair)[n++] = fr[2 * j + 1] * (pa_gid)nown + s->uelem[p];
  }
  *npair = pa__gid_sort_unique(*pair, n);
cleanup:
  return st;
}

/* Step 4d (owner side): one record block of elements per requester, sent;
 * *bcnt, *erecv: the blocks this rank received as a requester. */
static pa_status send_layer_elements(bstate *s, pa_idx nown,
                                     const pa_gid *pair, size_t npair,
                                     size_t **bcnt, void **erecv) {
  pa_status st = PA_SUCCESS;
  pa_gid div = nown ? nown : 1;
  size_t *pstart = NULL, *ecnt = NULL, bytes = 0, off = 0;
  pa_idx *sel = NULL;
  unsigned char *sbuf = NULL;
  PA_CALLOC(ecnt, s->size);
  PA_ALLOC(sel, npair);
  PA_CALLOC(pstart, (size_t)s->size + 1);
  for (size_t p = 0; p < npair; p++) {
    sel[p] = (pa_idx)(pair[p] % div);
    pstart[pair[p] / div + 1]++;
  }
  for (int r = 0; r < s->size; r++) pstart[r + 1] += pstart[r];
  for (int r = 0; r < s->size; r++) {
    size_t c = pstart[r + 1] - pstart[r];
    ecnt[r] = c ? pa__recblock_bytes(s->nve, s->L.ndbl, c,
                                     pa__recs_paybytes(&s->L, sel + pstart[r], c))
                : 0;
    bytes += ecnt[r];
  }
  PA_ALLOC(sbuf, bytes ? bytes : 1);
  for (int r = 0; r < s->size; r++) {
    size_t c = pstart[r + 1] - pstart[r];
    if (c) off += pa__recs_put(&s->L, sel + pstart[r], c, sbuf + off);
  }
  pa__free(sel);
  sel = NULL;
  PA_CALL(pa__xchg_sparse(s->comm, ecnt, sbuf, bcnt, erecv));
cleanup:
  pa__free(pstart);
  pa__free(ecnt);
  pa__free(sel);
  pa__free(sbuf);
  return st;
}

/* Step 4e (requester side): the received elements become layer l, their
 * owner the sender (room reserved first: L is large, growing it would copy
 * it). tmp: scratch records. */
static pa_status receive_layer(bstate *s, int l, const size_t *bcnt,
                               void *erecv, pa__recs *tmp) {
  pa_status st = PA_SUCCESS;
  size_t q = 0, tot = 0, nrec = 0, npay = 0;
  for (int r = 0; r < s->size; r++) tot += bcnt[r];
  while (q < tot) {
    pa__recblock bk;
    pa__recblock_map((unsigned char *)erecv + q, s->nve, s->L.ndbl, &bk);
    nrec += bk.n;
    npay += bk.paybytes;
    q += bk.bytes;
  }
  PA_CALL(pa__recs_reserve(&s->L, s->L.n + nrec,
                           (s->L.poff ? s->L.poff[s->L.n] : 0) + npay));
  PA_GROW(s->layer, s->caplayer, s->L.n + nrec);
  q = 0;
  for (int r = 0; r < s->size; r++) {
    size_t end = q + bcnt[r];
    while (q < end) {
      tmp->n = 0;
      if (tmp->poff) tmp->poff[0] = 0;
      PA_CALL(pa__recs_get(tmp, erecv, &q));
      for (size_t i = 0; i < tmp->n; i++)
        PA_CALL(add_local_elem(s, tmp, i, r, l));
    }
  }
cleanup:
  return st;
}

/* Step 4: ghost layers. For layer l, the vertices of layer l-1 not queried
 * yet go to the directory, which forwards (vertex, requester) to every other
 * rank owning elements around the vertex; those reply with these elements
 * (one record block per requester). Owned elements never come back to their
 * owner (queries are forwarded to the other touching ranks only), so only
 * ghosts enter emap. */
static pa_status build_layers(bstate *s, int overlap, pa_idx nown) {
  pa_status st = PA_SUCCESS;
  pa_gid *pair = NULL;
  size_t *rcnt = NULL, *fcnt = NULL, *bcnt = NULL;
  void *recv = NULL, *frecv = NULL, *erecv = NULL;
  pa__gidmap queried = {0};
  pa_idx *vq = NULL;
  pa__recs tmp;
  pa__recs_init(&tmp, PA_ELEMENT, s->nve, s->L.ndbl);
  if (overlap <= 0) goto cleanup;
  PA_CALL(pa__gidmap_init(&queried, 16));
  for (int l = 1; l <= overlap; l++) {
    const size_t *qcnt = NULL;
    const pa_gid *rg = NULL;
    const pa_idx *qv = NULL;
    size_t tot = 0, npair = 0;
    PA_CALL(layer_queries(s, l, &queried, &qcnt, &rg, &qv, &tot, &rcnt,
                          &recv, &vq));
    PA_CALL(forward_queries(s, qcnt, rg, qv, tot, &fcnt, &frecv));
    pa__free(recv);
    pa__free(rcnt);
    pa__free(vq);
    recv = NULL;
    rcnt = NULL;
    vq = NULL;
    PA_CALL(owner_pairs(s, nown, fcnt, frecv, &pair, &npair));
    pa__free(frecv);
    pa__free(fcnt);
    frecv = NULL;
    fcnt = NULL;
    PA_CALL(send_layer_elements(s, nown, pair, npair, &bcnt, &erecv));
    pa__free(pair);
    pair = NULL;
    PA_CALL(receive_layer(s, l, bcnt, erecv, &tmp));
    pa__free(erecv);
    pa__free(bcnt);
    erecv = NULL;
    bcnt = NULL;
  }
cleanup:
  st = pa__agree_end(s->comm, st);
  pa__free(pair);
  pa__free(rcnt);
  pa__free(fcnt);
  pa__free(bcnt);
  pa__free(recv);
  pa__free(frecv);
  pa__free(erecv);
  pa__free(vq);
  pa__gidmap_free(&queried);
  pa__recs_free(&tmp);
  return st;
}

/* The first of the n gids g (ascending) above x (n if none). */
static size_t first_above(const pa_gid *g, size_t n, pa_gid x) {
  size_t lo = 0, hi = n;
  while (lo < hi) {
    size_t mid = lo + (hi - lo) / 2;
    if (g[mid] > x) hi = mid;
    else lo = mid + 1;
  }
  return lo;
}

/* Records [from, from + n) of src to [k, k + n) of dst (the same layout,
 * without vertex ids or payloads; the ranges may overlap). */
static void move_run(pa__recs *dst, size_t k, const pa__recs *src,
                     size_t from, size_t n) {
  size_t nd = (size_t)dst->ndbl;
  memmove(dst->gid + k, src->gid + from, n * sizeof *dst->gid);
  memmove(dst->ref + k, src->ref + from, n * sizeof *dst->ref);
  memmove(dst->flag + k, src->flag + from, n * sizeof *dst->flag);
  memmove(dst->aux + k, src->aux + from, n * sizeof *dst->aux);
  if (nd) memmove(dst->dbl + nd * k, src->dbl + nd * from, nd * n * sizeof *dst->dbl);
}

/* Merge LV into P from the back, in place (P grown to hold both: the
 * records are moved by runs, and P's pages, already touched, are reused
 * instead of a fresh copy of both); both sorted by gid, without payloads. */
static pa_status merge_into_private(bstate *s) {
  pa_status st = PA_SUCCESS;
  pa__recs *P = s->P, *V = &s->LV;
  size_t i = V->n, j = P->n, k = V->n + P->n;
  PA_CALL(pa__recs_reserve(P, k, 0));
  while (i > 0) {
    /* the run of P above V's last record, then the run of V above P's
     * last (binary searches: the runs are long) */
    size_t lo = first_above(P->gid, j, V->gid[i - 1]);
    PA_CHECK(lo == 0 || P->gid[lo - 1] != V->gid[i - 1], PA_ERR_INTERNAL,
             "private vertex %lld is also in the directory",
             (long long)V->gid[i - 1]);
    k -= j - lo;
    move_run(P, k, P, lo, j - lo);
    j = lo;
    lo = j ? first_above(V->gid, i, P->gid[j - 1]) : 0;
    k -= i - lo;
    move_run(P, k, V, lo, i - lo);
    i = lo;
  }
  PA_ASSERT(k == j);
  P->n += V->n;
  pa__recs_free(V);
  *V = *P;
  pa__recs_init(P, PA_VERTEX, 0, V->ndbl);
cleanup:
  return st;
}

/* The private vertices join LV (owned here; both sorted by gid, merged),
 * and the boundary entities and edges whose smallest vertex is private,
 * which stayed here out of the directory, join LB and LD. Without
 * payloads the merge takes P's arrays (merge_into_private), which are then
 * LV's. */
static pa_status add_private(bstate *s) {
  pa_status st = PA_SUCCESS;
  pa__recs *P = s->P;
  pa__recs M;
  pa__recs_init(&M, PA_VERTEX, 0, s->LV.ndbl);
  for (int t = 0; t < 2; t++) {
    const pa__recs *R = t ? &s->D : &s->B;
    pa__recs *L = t ? &s->LD : &s->LB;
    for (size_t i = 0; i < R->n; i++) /* (their owner: assemble) */
      if (is_private(s, min_vgid(R, i))) PA_CALL(pa__recs_append(L, R, i, 1));
  }
  for (size_t j = 0; j < P->n; j++) P->aux[j] = s->rank;
  s->npriv = P->n;
  if (!P->poff && !s->LV.poff && P->ndbl == s->LV.ndbl) {
    PA_CALL(merge_into_private(s));
    goto cleanup;
  }
  size_t pb = (s->LV.poff ? s->LV.poff[s->LV.n] : 0) +
              (P->poff ? P->poff[P->n] : 0);
  PA_CALL(pa__recs_reserve(&M, s->LV.n + P->n, pb));
  /* merged by runs, copied array by array */
  for (size_t i = 0, j = 0; i < s->LV.n || j < P->n;) {
    PA_CHECK(i >= s->LV.n || j >= P->n || s->LV.gid[i] != P->gid[j],
             PA_ERR_INTERNAL, "private vertex %lld is also in the directory",
             (long long)P->gid[j]);
    size_t i1 = i, j1 = j;
    while (i1 < s->LV.n && (j >= P->n || s->LV.gid[i1] < P->gid[j])) i1++;
    if (i1 == i)
      while (j1 < P->n && (i >= s->LV.n || P->gid[j1] < s->LV.gid[i])) j1++;
    PA_CALL(pa__recs_append(&M, &s->LV, i, i1 - i));
    PA_CALL(pa__recs_append(&M, P, j, j1 - j));
    i = i1;
    j = j1;
  }
  pa__recs_free(&s->LV);
  s->LV = M;
  memset(&M, 0, sizeof M);
cleanup:
  pa__recs_free(&M);
  return st;
}

/* What the phases of fetch_vertices share, on the directory side: the V
 * records it answers (tot in all; requester r's are vi[vs[r]..vs[r+1]))
 * and the B and D records attached to them (bi/bs and di/ds likewise). */
typedef struct fetch {
  size_t tot;
  pa_idx *vi, *bi, *di;
  size_t *vs, *bs, *ds;
} fetch;

/* Step 5a (directory side): the vertices each requester gets, its two
 * sorted lists (the touch messages and the ghost requests rcnt/rg) merged
 * by gid so that they come back sorted; sets the owner of each (the lowest
 * touching rank) and counts the boundary entities and edges attached. */
static pa_status answered_vertices(bstate *s, const size_t *rcnt,
                                   const pa_gid *rg, fetch *f) {
  pa_status st = PA_SUCCESS;
  size_t i = 0, j = 0, k = 0;
  f->tot = 0;
  for (int r = 0; r < s->size; r++) f->tot += rcnt[r] + s->tcnt[r];
  PA_ALLOC(f->vi, f->tot);
  PA_CALLOC(f->vs, (size_t)s->size + 1);
  PA_CALLOC(f->bs, (size_t)s->size + 1);
  PA_CALLOC(f->ds, (size_t)s->size + 1);
  for (int r = 0; r < s->size; r++) {
    size_t iend = i + s->tcnt[r], jend = j + rcnt[r];
    while (i < iend || j < jend) {
      pa_idx v;
      if (j >= jend || (i < iend && s->tgid[i] < rg[j])) {
        v = s->tv[i++];
      } else {
        v = pa__gidindex_get(&s->vix, rg[j]);
        PA_CHECK(v >= 0 && s->tstart[v + 1] > s->tstart[v], PA_ERR_INTERNAL,
                 "vertex %lld requested but untouched", (long long)rg[j]);
        j++;
      }
      f->vi[k++] = v;
      s->V.aux[v] = s->trank[s->tstart[v]]; /* owner: lowest touching rank */
      f->bs[r + 1] += (size_t)(s->bstart[v + 1] - s->bstart[v]);
      f->ds[r + 1] += (size_t)(s->dstart[v + 1] - s->dstart[v]);
    }
    f->vs[r + 1] = f->vs[r] + s->tcnt[r] + rcnt[r];
  }
cleanup:
  return st;
}

/* Step 5b (directory side): the boundary entities and edges attached to
 * the answered vertices, in the same order. */
static pa_status attached_records(bstate *s, fetch *f) {
  pa_status st = PA_SUCCESS;
  for (int r = 0; r < s->size; r++) {
    f->bs[r + 1] += f->bs[r];
    f->ds[r + 1] += f->ds[r];
  }
  PA_ALLOC(f->bi, f->bs[s->size]);
  PA_ALLOC(f->di, f->ds[s->size]);
  for (size_t j = 0, kb = 0, kd = 0; j < f->tot; j++) {
    pa_idx v = f->vi[j];
    for (pa_idx k = s->bstart[v]; k < s->bstart[v + 1]; k++) f->bi[kb++] = s->blist[k];
    for (pa_idx k = s->dstart[v]; k < s->dstart[v + 1]; k++) f->di[kd++] = s->dlist[k];
  }
cleanup:
  return st;
}

/* Step 5c: the answers sent, three record blocks per requester (its
 * vertices, their boundary entities, their edges; the lists of f are freed
 * once packed); *bcnt, *brecv: the blocks this rank receives. */
static pa_status send_answers(bstate *s, fetch *f, size_t **bcnt,
                              void **brecv) {
  pa_status st = PA_SUCCESS;
  size_t *cnt = NULL, bytes = 0, off = 0;
  unsigned char *sbuf = NULL;
  const size_t *vs = f->vs, *bs = f->bs, *ds = f->ds;
  PA_CALLOC(cnt, s->size);
  for (int r = 0; r < s->size; r++) {
    size_t nv = vs[r + 1] - vs[r], nb = bs[r + 1] - bs[r], nd = ds[r + 1] - ds[r];
    if (!nv) continue;
    cnt[r] = pa__recblock_bytes(0, s->V.ndbl, nv, pa__recs_paybytes(&s->V, f->vi + vs[r], nv)) +
             pa__recblock_bytes(s->B.nv, s->B.ndbl, nb, pa__recs_paybytes(&s->B, f->bi + bs[r], nb)) +
             pa__recblock_bytes(2, 0, nd, pa__recs_paybytes(&s->D, f->di + ds[r], nd));
    bytes += cnt[r];
  }
  PA_ALLOC(sbuf, bytes);
  for (int r = 0; r < s->size; r++) {
    size_t nv = vs[r + 1] - vs[r];
    if (!nv) continue;
    off += pa__recs_put(&s->V, f->vi + vs[r], nv, sbuf + off);
    off += pa__recs_put(&s->B, f->bi + bs[r], bs[r + 1] - bs[r], sbuf + off);
    off += pa__recs_put(&s->D, f->di + ds[r], ds[r + 1] - ds[r], sbuf + off);
  }
  pa__free(f->vi);
  pa__free(f->bi);
  pa__free(f->di);
  f->vi = f->bi = f->di = NULL;
  PA_CALL(pa__xchg_sparse(s->comm, cnt, sbuf, bcnt, brecv));
cleanup:
  pa__free(cnt);
  pa__free(sbuf);
  return st;
}

/* Step 5d (requester side): the received blocks appended to LV, LB and LD
 * (exact reservations first). */
static pa_status receive_fetched(bstate *s, const size_t *bcnt, void *brecv) {
  pa_status st = PA_SUCCESS;
  size_t btot = 0, q = 0, n3[3] = {0, 0, 0}, p3[3] = {0, 0, 0};
  pa__recs *R3[3] = {&s->LV, &s->LB, &s->LD};
  for (int r = 0; r < s->size; r++) btot += bcnt[r];
  for (int t = 0; q < btot; t = (t + 1) % 3) { /* exact reservations */
    pa__recblock bk;
    pa__recblock_map((unsigned char *)brecv + q, R3[t]->nv, R3[t]->ndbl, &bk);
    n3[t] += bk.n;
    p3[t] += bk.paybytes;
    q += bk.bytes;
  }
  for (int t = 0; t < 3; t++) PA_CALL(pa__recs_reserve(R3[t], n3[t], p3[t]));
  q = 0;
  while (q < btot) {
    PA_CALL(pa__recs_get(&s->LV, brecv, &q));
    PA_CALL(pa__recs_get(&s->LB, brecv, &q));
    PA_CALL(pa__recs_get(&s->LD, brecv, &q));
  }
cleanup:
  return st;
}

/* Step 5e: the LV record of each owned element's vertex (-1: not fetched,
 * an internal error reported by assemble); both lists are sorted by gid.
 * Every private vertex must be one of them. */
static pa_status owned_vertex_records(bstate *s) {
  pa_status st = PA_SUCCESS;
  size_t npriv = 0;
  PA_ALLOC(s->ulv, s->nu);
  for (size_t u = 0, i = 0; u < s->nu; u++) {
    while (i < s->LV.n && s->LV.gid[i] < s->ukey[u]) i++;
    s->ulv[u] = i < s->LV.n && s->LV.gid[i] == s->ukey[u] ? (pa_idx)i : -1;
    npriv += s->upriv && s->upriv[u];
  }
  PA_CHECK(!s->P || npriv == s->npriv, PA_ERR_INTERNAL,
           "%zu private vertices are in no owned element",
           s->P ? s->npriv - npriv : 0);
cleanup:
  return st;
}

/* Step 5: fetch the records of every local vertex (aux = owner) with the
 * boundary entities and edges attached to it: the directory answers each
 * requester with three record blocks (vertices in the order asked, their
 * boundary entities, their edges). Requests are sorted and directory ranks
 * own increasing gid ranges, so LV arrives sorted by gid. */
static pa_status fetch_vertices(bstate *s) {
  pa_status st = PA_SUCCESS;
  pa_gid *g = NULL;
  size_t n = 0, *rcnt = NULL, *bcnt = NULL;
  void *recv = NULL, *brecv = NULL;
  fetch f;
  memset(&f, 0, sizeof f);
  /* local vertices: those of the owned elements, which the directory has
   * from the touch messages, and the ghosts' (not among them), sent now */
  if (s->emap.n) PA_CALL(ghost_verts(s, 1, 255, &g, &n)); /* ghosts */
  PA_CALL(send_to_directory(s, g, n, &rcnt, &recv));
  pa__free(g);
  g = NULL;
  PA_CALL(answered_vertices(s, rcnt, recv, &f));
  pa__free(recv);
  recv = NULL;
  PA_CALL(attached_records(s, &f));
  PA_CALL(send_answers(s, &f, &bcnt, &brecv));
  PA_CALL(receive_fetched(s, bcnt, brecv));
  if (s->P && s->P->n) PA_CALL(add_private(s));
  PA_CALL(owned_vertex_records(s));
cleanup:
  st = pa__agree_end(s->comm, st);
  pa__free(g);
  pa__free(rcnt);
  pa__free(bcnt);
  pa__free(recv);
  pa__free(brecv);
  pa__free(f.vi);
  pa__free(f.bi);
  pa__free(f.di);
  pa__free(f.vs);
  pa__free(f.bs);
  pa__free(f.ds);
  return st;
}

/* Order of local entities: owned (aux == rank) first, each group by gid (and
 * elements by layer). out[k] = record index of local entity k; *ident: 1
 * if that is the identity. A stable
 * counting pass by group, then a sort by gid of each group, skipped when it
 * is already in order (the owned elements and the vertices arrive sorted). */
static pa_status number_local(const pa__recs *R, const uint8_t *layer,
                              int rank, pa_idx *out, pa_idx *nown,
                              uint8_t *ident) {
  pa_status st = PA_SUCCESS;
  size_t c[258] = {0}, i0 = 0;
#define GROUP(i) (layer ? layer[i] : (R->aux[i] == rank ? 0 : 1))
  /* (the leading owned records in gid order keep their places: all of
   * them when only owned elements arrive) */
  while (i0 < R->n && GROUP(i0) == 0 && (!i0 || R->gid[i0] >= R->gid[i0 - 1]))
    i0++;
  *ident = i0 == R->n;
  if (*ident) {
    for (size_t i = 0; i < R->n; i++) out[i] = (pa_idx)i;
    *nown = (pa_idx)R->n;
    return PA_SUCCESS;
  }
  for (size_t i = 0; i < R->n; i++) c[GROUP(i) + 2]++;
  for (int b = 0; b < 256; b++) c[b + 2] += c[b + 1];
  *nown = (pa_idx)c[2];
  for (size_t i = 0; i < R->n; i++) out[c[GROUP(i) + 1]++] = (pa_idx)i;
#undef GROUP
  /* now c[g] is the start of group g */
  for (int g = 0; g < 256; g++)
    if (c[g + 1] > c[g] + 1)
      PA_CALL(pa__sort_by_gid(out + c[g], c[g + 1] - c[g], R->gid));
cleanup:
  return st;
}

/* Copy the payloads of the records ord[0..n) of R (kind) into the values
 * of that kind at local entities 0..n. A value restricted to a reference
 * is in a record's payload only when the record has that reference; when
 * no value of the kind is restricted (the usual case), the layout of every
 * payload is the same (checked) and the values are filled one after the
 * other. */
static void unpack_payloads(pa_dmesh *dm, int kind, const pa__recs *R,
                            const pa_idx *ord, int ident, pa_idx n) {
  if (!R->poff) return;
  int anyref = 0;
  size_t off = 0, tot = 0;
  for (int k = 0; k < dm->nvalue; k++)
    if ((int)dm->value[k]->kind == kind) {
      anyref |= dm->value[k]->ref >= 0;
      tot += dm->value[k]->unit;
    }
  for (pa_idx e = 0; e < n && !anyref; e++)
    anyref = R->poff[ord[e] + 1] - R->poff[ord[e]] != tot;
  if (!anyref) {
    for (int k = 0; k < dm->nvalue; k++) {
      pa_dmesh_value *v = dm->value[k];
      if ((int)v->kind != kind) continue;
      if (ident && v->unit == tot && !v->slot && n) {
        /* the only value of its kind, records in local order: the
         * payloads are its data, one after the other */
        memcpy(v->data, R->pay + R->poff[0], (size_t)n * tot);
        continue;
      }
      for (pa_idx e = 0; e < n; e++) {
        const unsigned char *p = R->pay + R->poff[ord[e]] + off;
        pa_idx slot = v->slot ? v->slot[e] : e;
        unsigned char *q = v->data + v->unit * (size_t)slot;
        if (v->unit == 1) q[0] = p[0]; /* (the adaptation's done values) */
        else memcpy(q, p, v->unit);
      }
      off += v->unit;
    }
    return;
  }
  for (pa_idx e = 0; e < n; e++) {
    size_t i = (size_t)ord[e];
    const unsigned char *p = R->pay + R->poff[i];
    for (int k = 0; k < dm->nvalue; k++) {
      pa_dmesh_value *v = dm->value[k];
      if ((int)v->kind != kind || (v->ref >= 0 && v->ref != R->ref[i]))
        continue;
      pa_idx slot = v->slot ? v->slot[e] : e;
      memcpy(v->data + v->unit * (size_t)slot, p, v->unit);
      p += v->unit;
    }
  }
}

/* What the phases of assemble share: the local order of the records of
 * each kind (ord[kind][k] = record of local entity k), the local vertex of
 * each vertex record (lvof) and, for many lookups, of each vertex global
 * id (lv), and the local mesh being filled. With the identity (ident) the
 * records' arrays of ids, owners and layers become dm's. */
typedef struct assembly {
  pa_idx *ord[PA_DMESH_NKIND];
  uint8_t ident[PA_DMESH_NKIND]; /* ord[kind] is the identity */
  pa_idx *lvof;
  pa__gidindex lv; /* built only for many lookups (uselv) */
  int uselv;
  pa_mesh *m;
} assembly;

/* Lookups of local vertices by gid (the vertices of ghost elements; of
 * boundary entities and edges, each looked up about twice) per local
 * vertex below which a binary search in the sorted vertex records (some
 * 20 steps each) costs less than indexing them all (a store a vertex, and
 * an array over their gid range): 1/16. */
#define LV_SEARCH_SHARE 16

/* The local vertex of global id g, or -1: through the index lv when the
 * lookups are many (uselv), else by a binary search in the vertex records
 * (sorted by gid). */
static pa_idx local_vertex(const bstate *s, const assembly *a, pa_gid g) {
  if (a->uselv) return pa__gidindex_get(&a->lv, g);
  size_t k = pa__gid_lower_bound(s->LV.gid, s->LV.n, g);
  return k < s->LV.n && s->LV.gid[k] == g ? a->lvof[k] : -1;
}

/* Step 6: number the local elements and vertices (owned first) and index
 * the vertices by global id if the lookups are many. */
static pa_status number_vertices_elements(pa_dmesh *dm, bstate *s,
                                          assembly *a) {
  pa_status st = PA_SUCCESS;
  PA_ALLOC(a->ord[PA_ELEMENT], s->L.n);
  PA_CALL(number_local(&s->L, s->layer, s->rank, a->ord[PA_ELEMENT],
                       &dm->nown[PA_ELEMENT], &a->ident[PA_ELEMENT]));
  dm->nloc[PA_ELEMENT] = (pa_idx)s->L.n;
  a->uselv = (s->L.n - (size_t)dm->nown[PA_ELEMENT]) * (size_t)s->nve +
                  (s->LB.n * (size_t)s->LB.nv + s->LD.n * 2) * 2 >
              s->LV.n / LV_SEARCH_SHARE;
  PA_ALLOC(a->ord[PA_VERTEX], s->LV.n);
  PA_CALL(number_local(&s->LV, NULL, s->rank, a->ord[PA_VERTEX],
                       &dm->nown[PA_VERTEX], &a->ident[PA_VERTEX]));
  dm->nloc[PA_VERTEX] = (pa_idx)s->LV.n;
  PA_ALLOC(a->lvof, s->LV.n);
  for (size_t k = 0; k < s->LV.n; k++) a->lvof[a->ord[PA_VERTEX][k]] = (pa_idx)k;
  if (a->uselv) {
    PA_CALL(pa__gidindex_init_keys(&a->lv, s->LV.gid, s->LV.n));
    for (size_t r = 0; r < s->LV.n; r++)
      PA_CALL(pa__gidindex_put(&a->lv, s->LV.gid[r], a->lvof[r], NULL, NULL));
  }
cleanup:
  return st;
}

/* Step 7a: the local mesh's vertices (coordinates, metric, fields). */
static pa_status fill_vertices(bstate *s, const pa__layout *lay, assembly *a) {
  pa_status st = PA_SUCCESS;
  int d = s->dim;
  pa_mesh *m = NULL;
  PA_CALL(pa_mesh_create(d, &a->m));
  m = a->m;
  m->met_ncomp = lay->met_ncomp;
  m->nfield = lay->nfield;
  for (int f = 0; f < lay->nfield; f++) {
    snprintf(m->field[f].name, sizeof m->field[f].name, "%s", lay->fieldname[f]);
    m->field[f].ncomp = lay->fieldncomp[f];
  }
  if (lay->geo) PA_CALL(pa__mesh_enable_entities(m));
  PA_CALL(pa_mesh_reserve(m, (pa_idx)s->LV.n, (pa_idx)s->L.n, 0, 0));
  PA_CALL(pa__layout_cell_fields(lay, m));
  for (size_t k = 0; k < s->LV.n; k++) {
    size_t i = (size_t)a->ord[PA_VERTEX][k];
    pa__vertex_set_doubles(m, (pa_idx)k, s->LV.dbl + (size_t)s->LV.ndbl * i);
    m->vref[k] = s->LV.ref[i];
    m->vflag[k] = s->LV.flag[i];
  }
  m->nv = (pa_idx)s->LV.n;
  pa__free(s->LV.dbl); /* in the mesh now: lower the peak */
  s->LV.dbl = NULL;
cleanup:
  return st;
}

/* The vertices of the local elements (see fill_elements), nve a constant
 * once inlined; returns 1 if one was not fetched. */
static inline int elem_vertices(const pa_dmesh *dm, const bstate *s,
                                const assembly *a, const int nve) {
  const pa_idx *ord = a->ord[PA_ELEMENT], *ulv = s->ulv;
  size_t nown = (size_t)dm->nown[PA_ELEMENT];
  pa_idx *elem = a->m->elem, bad = 0;
  for (size_t k = 0; k < s->L.n; k++) {
    size_t i = (size_t)ord[k];
    pa_idx *dst = elem + (size_t)nve * k;
    if (i < nown && s->uslot) {
      const pa_idx *us = s->uslot + (size_t)nve * i;
      for (int j = 0; j < nve; j++) dst[j] = ulv[us[j]];
    } else if (i < nown) { /* uix dense, to local vertices (fill_elements) */
      const pa_gid *vg = s->L.vgid + (size_t)nve * i;
      for (int j = 0; j < nve; j++) dst[j] = s->uix.dense[vg[j] - s->uix.lo];
    } else {
      for (int j = 0; j < nve; j++)
        dst[j] = local_vertex(s, a, s->L.vgid[(size_t)nve * i + j]);
    }
    for (int j = 0; j < nve; j++) bad |= dst[j] < 0;
  }
  return bad != 0;
}

/* Step 7b: the local mesh's elements. Owned elements (records [0, nown)):
 * vertex slot -> u -> LV record -> local vertex, two array reads, or
 * without slots the gid through uix dense, turned first into gid -> local
 * vertex (one pass in order), one array read; ghost elements through
 * local_vertex. */
static pa_status fill_elements(pa_dmesh *dm, bstate *s, assembly *a) {
  pa_status st = PA_SUCCESS;
  int d = s->dim;
  pa_mesh *m = a->m;
  if (!s->uslot && s->uix.dense) { /* gid -> u -> LV record -> local */
    pa_idx *x = s->uix.dense;
    for (size_t g = 0; g < (size_t)(s->uix.hi - s->uix.lo); g++)
      if (x[g] >= 0) x[g] = s->ulv[x[g]] >= 0 ? a->lvof[s->ulv[x[g]]] : -1;
  } else {
    for (size_t u = 0; u < s->nu; u++)
      if (s->ulv[u] >= 0) s->ulv[u] = a->lvof[s->ulv[u]];
  }
  PA_CHECK(!(d == 2 ? elem_vertices(dm, s, a, 3) : elem_vertices(dm, s, a, 4)),
           PA_ERR_INTERNAL, "element vertex not fetched");
  const pa_idx *ord = a->ord[PA_ELEMENT];
  if (a->ident[PA_ELEMENT] && s->L.n) {
    memcpy(m->eref, s->L.ref, s->L.n * sizeof *m->eref);
    memcpy(m->eflag, s->L.flag, s->L.n * sizeof *m->eflag);
  } else {
    for (size_t k = 0; k < s->L.n; k++) {
      m->eref[k] = s->L.ref[ord[k]];
      m->eflag[k] = s->L.flag[ord[k]];
    }
  }
  for (size_t k = 0; s->L.ndbl && k < s->L.n; k++)
    pa__entity_set_doubles(m, PA_ELEMENT, (pa_idx)k,
                           s->L.dbl + (size_t)s->L.ndbl * (size_t)ord[k]);
  m->ne = (pa_idx)s->L.n;
  pa__free(s->uslot);
  pa__free(s->ulv);
  s->uslot = s->ulv = NULL;
  pa__gidindex_free(&s->uix);
  pa__free(s->L.vgid); /* in the mesh now */
  s->L.vgid = NULL;
cleanup:
  return st;
}

/* Step 8 for the records R (boundary entities or edges): keep those inside
 * a local element (compacted in place); the owner is the lowest rank with
 * an owned element containing them (in R->aux). vstart/vel: the local
 * elements around the first vertex of each record. */
static pa_status own_subentities(pa_dmesh *dm, bstate *s, assembly *a,
                                 pa__recs *R, const pa_idx *vstart,
                                 const pa_idx *vel) {
  pa_status st = PA_SUCCESS;
  int d = s->dim, nv = R->nv;
  const pa_mesh *m = a->m;
  uint8_t *keep = NULL, *cand = NULL;
  int *kown = NULL;
  PA_CALLOC(keep, R->n);
  PA_CALLOC(cand, R->n);
  size_t nk = 0;
  for (size_t i = 0; i < R->n; i++) {
    pa_idx lvx[4];
    int ok = 1;
    for (int j = 0; j < nv; j++) {
      lvx[j] = local_vertex(s, a, R->vgid[(size_t)nv * i + j]);
      if (lvx[j] < 0) ok = 0;
    }
    if (!ok) continue;
    for (pa_idx q = vstart[lvx[0]]; q < vstart[lvx[0] + 1]; q++) {
      const pa_idx *ev = m->elem + (size_t)(d + 1) * vel[q];
      int all = 1;
      for (int j = 1; j < nv && all; j++) {
        int in = 0;
        for (int c = 0; c <= d; c++) in |= ev[c] == lvx[j];
        all = in;
      }
      if (all) {
        keep[i] = 1;
        if (vel[q] < dm->nown[PA_ELEMENT]) cand[i] = 1;
      }
    }
    nk += keep[i];
  }
  /* compact the kept records in place */
  size_t k = 0;
  for (size_t i = 0; i < R->n; i++) {
    if (!keep[i]) continue;
    if (k != i) {
      R->gid[k] = R->gid[i];
      memcpy(R->vgid + (size_t)nv * k, R->vgid + (size_t)nv * i,
             nv * sizeof(pa_gid));
      R->ref[k] = R->ref[i];
      R->flag[k] = R->flag[i];
      if (R->ndbl)
        memmove(R->dbl + (size_t)R->ndbl * k, R->dbl + (size_t)R->ndbl * i,
                (size_t)R->ndbl * sizeof *R->dbl);
      if (R->poff) { /* payload offsets: move the slice pointers */
        size_t len = R->poff[i + 1] - R->poff[i];
        memmove(R->pay + R->poff[k], R->pay + R->poff[i], len);
        R->poff[k + 1] = R->poff[k] + len;
      }
    } else if (R->poff) {
      R->poff[k + 1] = R->poff[k] + (R->poff[i + 1] - R->poff[i]);
    }
    cand[k] = cand[i];
    k++;
  }
  R->n = k;
  PA_ASSERT(k == nk);
  (void)nk;
  PA_ALLOC(kown, R->n);
  PA_CALL(resolve_owner(s->comm, R->n, R->gid, cand, kown));
  for (size_t i = 0; i < R->n; i++) {
    PA_CHECK(kown[i] >= 0, PA_ERR_INTERNAL,
             "entity %lld is in no owned element", (long long)R->gid[i]);
    R->aux[i] = kown[i];
  }
cleanup:
  pa__free(keep);
  pa__free(cand);
  pa__free(kown);
  return st;
}

/* Step 8: own the boundary entities and edges, number them (owned first)
 * and put them in the local mesh. */
static pa_status fill_subentities(pa_dmesh *dm, bstate *s, assembly *a) {
  pa_status st = PA_SUCCESS;
  int d = s->dim;
  pa_mesh *m = a->m;
  pa__recs *SB[2] = {&s->LB, &s->LD};
  pa_idx *vstart = NULL, *vel = NULL;
  uint8_t *need = NULL;
  /* vertex -> local elements, for the containment tests: only for the
   * first vertex of each boundary entity and edge (the balls of a few
   * thousand vertices, not of the whole local mesh) */
  PA_CALLOC(need, m->nv);
  for (int t = 0; t < 2; t++)
    for (size_t i = 0; i < SB[t]->n; i++) {
      pa_idx v = local_vertex(s, a, SB[t]->vgid[(size_t)SB[t]->nv * i]);
      if (v >= 0) need[v] = 1;
    }
  PA_CALL(pa__balls_of(m->elem, m->ne, m->dim + 1, m->nv, need, &vstart,
                       &vel));
  pa__free(need);
  need = NULL;
  for (int t = 0; t < 2; t++)
    PA_CALL(own_subentities(dm, s, a, SB[t], vstart, vel));
  PA_ALLOC(a->ord[PA_BOUNDARY], s->LB.n);
  PA_CALL(number_local(&s->LB, NULL, s->rank, a->ord[PA_BOUNDARY],
                       &dm->nown[PA_BOUNDARY], &a->ident[PA_BOUNDARY]));
  dm->nloc[PA_BOUNDARY] = (pa_idx)s->LB.n;
  PA_ALLOC(a->ord[PA_EDGE], s->LD.n);
  PA_CALL(number_local(&s->LD, NULL, s->rank, a->ord[PA_EDGE],
                       &dm->nown[PA_EDGE], &a->ident[PA_EDGE]));
  dm->nloc[PA_EDGE] = (pa_idx)s->LD.n;
  PA_CALL(pa_mesh_reserve(m, 0, 0, (pa_idx)s->LB.n, (pa_idx)s->LD.n));
  for (size_t k = 0; k < s->LB.n; k++) {
    size_t i = (size_t)a->ord[PA_BOUNDARY][k];
    for (int j = 0; j < d; j++)
      m->bdry[(size_t)d * k + j] =
          local_vertex(s, a, s->LB.vgid[(size_t)d * i + j]);
    m->bref[k] = s->LB.ref[i];
    m->bflag[k] = s->LB.flag[i];
    if (s->LB.ndbl)
      pa__entity_set_doubles(m, PA_BOUNDARY, (pa_idx)k,
                             s->LB.dbl + (size_t)s->LB.ndbl * i);
  }
  m->nb = (pa_idx)s->LB.n;
  for (size_t k = 0; k < s->LD.n; k++) {
    size_t i = (size_t)a->ord[PA_EDGE][k];
    for (int j = 0; j < 2; j++)
      m->edge[2 * k + j] = local_vertex(s, a, s->LD.vgid[2 * i + j]);
    m->edref[k] = s->LD.ref[i];
    m->edflag[k] = s->LD.flag[i];
  }
  m->ned = (pa_idx)s->LD.n;
cleanup:
  pa__free(vstart);
  pa__free(vel);
  pa__free(need);
  return st;
}

/* Step 9: global ids, owners and layers of the local entities, the mesh
 * into dm, then the values (slots for the new distribution, then the
 * payloads). */
static pa_status fill_dmesh(pa_dmesh *dm, bstate *s, assembly *a) {
  pa_status st = PA_SUCCESS;
  pa__recs *R[PA_DMESH_NKIND] = {&s->LV, &s->L, &s->LB, &s->LD};
  int any = 0;
  for (int kind = 0; kind < PA_DMESH_NKIND; kind++) {
    pa_idx n = dm->nloc[kind];
    if (a->ident[kind] && n) { /* the records' arrays, as they are */
      dm->gid[kind] = R[kind]->gid;
      dm->owner[kind] = R[kind]->aux;
      R[kind]->gid = NULL;
      R[kind]->aux = NULL;
      continue;
    }
    PA_ALLOC(dm->gid[kind], n);
    PA_ALLOC(dm->owner[kind], n);
    for (pa_idx k = 0; k < n; k++) {
      dm->gid[kind][k] = R[kind]->gid[a->ord[kind][k]];
      dm->owner[kind][k] = R[kind]->aux[a->ord[kind][k]];
    }
  }
  if (a->ident[PA_ELEMENT] && dm->nloc[PA_ELEMENT]) {
    dm->layer = s->layer;
    s->layer = NULL;
    s->caplayer = 0;
  } else {
    PA_ALLOC(dm->layer, dm->nloc[PA_ELEMENT]);
    for (pa_idx k = 0; k < dm->nloc[PA_ELEMENT]; k++)
      dm->layer[k] = s->layer[a->ord[PA_ELEMENT][k]];
  }
  dm->mesh = a->m;
  a->m = NULL;
  for (int kind = 0; kind < PA_DMESH_NKIND; kind++)
    any |= R[kind]->poff != NULL;
  if (any || dm->nvalue) {
    /* slots from the references (local); sfs are built later */
    for (int k = 0; k < dm->nvalue; k++) PA_CALL(pa__value_alloc(dm, dm->value[k]));
    for (int kind = 0; kind < PA_DMESH_NKIND; kind++)
      unpack_payloads(dm, kind, R[kind], a->ord[kind], a->ident[kind],
                      dm->nloc[kind]);
  }
cleanup:
  return st;
}

/* Steps 6-9: number all local entities, fill the local mesh, own the
 * boundary entities / edges, fill dm. */
static pa_status assemble(pa_dmesh *dm, bstate *s, const pa__layout *lay) {
  pa_status st = PA_SUCCESS;
  assembly a;
  memset(&a, 0, sizeof a);
  PA_CALL(number_vertices_elements(dm, s, &a));
  PA_CALL(fill_vertices(s, lay, &a));
  PA_CALL(fill_elements(dm, s, &a));
  PA_CALL(fill_subentities(dm, s, &a));
  PA_CALL(fill_dmesh(dm, s, &a));
cleanup:
  pa_mesh_destroy(a.m);
  for (int k = 0; k < PA_DMESH_NKIND; k++) pa__free(a.ord[k]);
  pa__free(a.lvof);
  pa__gidindex_free(&a.lv);
  return st;
}

int pa__layout_ndbl(const pa__layout *l) {
  int n = l->dim + l->met_ncomp + (l->geo != 0);
  for (int f = 0; f < l->nfield; f++) n += l->fieldncomp[f];
  return n;
}

int pa__layout_kind_ndbl(const pa__layout *l, int kind) {
  if (kind == PA_VERTEX) return pa__layout_ndbl(l);
  if (kind == PA_EDGE) return 0;
  int c = kind == PA_ELEMENT ? 0 : 1, n = 0;
  for (int f = 0; f < l->ncfield[c]; f++) n += l->cfieldncomp[c][f];
  return n;
}

void pa__mesh_layout(const pa_mesh *m, pa__layout *lay) {
  memset(lay, 0, sizeof *lay);
  lay->dim = m->dim;
  lay->met_ncomp = m->met_ncomp;
  lay->geo = m->vgdim != NULL;
  lay->nfield = m->nfield;
  for (int f = 0; f < m->nfield; f++) {
    snprintf(lay->fieldname[f], PA_MESH_FIELD_NAME_LEN, "%s", m->field[f].name);
    lay->fieldncomp[f] = m->field[f].ncomp;
  }
  for (int c = 0; c < 2; c++) {
    int *n;
    const pa__field *fl = pa__mesh_fields((pa_mesh *)m, PA_ELEMENT + c, &n);
    lay->ncfield[c] = *n;
    for (int f = 0; f < *n; f++) {
      snprintf(lay->cfieldname[c][f], PA_MESH_FIELD_NAME_LEN, "%s", fl[f].name);
      lay->cfieldncomp[c][f] = fl[f].ncomp;
      lay->cfieldmode[c][f] = fl[f].transfer;
    }
  }
}

void pa__dmesh_layout(pa_dmesh *dm, pa__layout *lay) {
  memset(lay, 0, sizeof *lay);
  lay->dim = dm->dim;
  if (dm->mesh) pa__mesh_layout(dm->mesh, lay);
}

pa_status pa__layout_cell_fields(const pa__layout *l, pa_mesh *m) {
  pa_status st = PA_SUCCESS;
  for (int c = 0; c < 2; c++) {
    int *n;
    pa__field *fl = pa__mesh_fields(m, PA_ELEMENT + c, &n);
    size_t cap = c == 0 ? m->cape : m->capb;
    PA_ASSERT(*n == 0);
    for (int f = 0; f < l->ncfield[c]; f++) {
      pa__field *x = &fl[f];
      memset(x, 0, sizeof *x);
      snprintf(x->name, sizeof x->name, "%s", l->cfieldname[c][f]);
      x->ncomp = l->cfieldncomp[c][f];
      x->transfer = l->cfieldmode[c][f];
      PA_ALLOC(x->val, (cap ? cap : 1) * (size_t)x->ncomp);
      (*n)++;
    }
  }
cleanup:
  return st;
}

int pa__entity_doubles(const pa_mesh *m, int kind, pa_idx e, double *out) {
  if (kind == PA_VERTEX) return pa__vertex_doubles(m, e, m->nfield, out);
  if (kind == PA_EDGE) return 0;
  int *nf, n = 0;
  const pa__field *f = pa__mesh_fields((pa_mesh *)m, kind, &nf);
  for (int k = 0; k < *nf; k++) {
    int nc = f[k].ncomp;
    for (int c = 0; c < nc; c++) out[n++] = f[k].val[(size_t)nc * e + c];
  }
  return n;
}

void pa__entity_set_doubles(pa_mesh *m, int kind, pa_idx e, const double *in) {
  if (kind == PA_VERTEX) {
    pa__vertex_set_doubles(m, e, in);
    return;
  }
  if (kind == PA_EDGE) return;
  int *nf;
  pa__field *f = pa__mesh_fields(m, kind, &nf);
  for (int k = 0; k < *nf; k++) {
    int nc = f[k].ncomp;
    for (int c = 0; c < nc; c++) f[k].val[(size_t)nc * e + c] = *in++;
  }
}

pa_status pa__dmesh_build(pa_dmesh *dm, const pa__layout *lay, int overlap,
                          pa__recs *elems, pa__recs *verts, pa__recs *bdry,
                          pa__recs *edges) {
  return pa__dmesh_build_priv(dm, lay, overlap, elems, verts, bdry, edges,
                              NULL);
}

/* The build state of dm's communicator, its record sets empty with the
 * doubles of lay. */
static void bstate_init(bstate *s, const pa_dmesh *dm, const pa__layout *lay) {
  int nvd = pa__layout_ndbl(lay), ned = pa__layout_kind_ndbl(lay, PA_ELEMENT);
  int nbd = pa__layout_kind_ndbl(lay, PA_BOUNDARY);
  memset(s, 0, sizeof *s);
  s->comm = dm->comm;
  s->rank = dm->rank;
  s->size = dm->size;
  s->dim = dm->dim;
  s->nve = dm->dim + 1;
  pa__recs_init(&s->L, PA_ELEMENT, s->nve, ned);
  pa__recs_init(&s->LV, PA_VERTEX, 0, nvd);
  pa__recs_init(&s->LB, PA_BOUNDARY, s->dim, nbd);
  pa__recs_init(&s->LD, PA_EDGE, 2, 0);
  pa__recs_init(&s->V, PA_VERTEX, 0, nvd);
  pa__recs_init(&s->B, PA_BOUNDARY, s->dim, nbd);
  pa__recs_init(&s->D, PA_EDGE, 2, 0);
}

/* The input checked (record layouts, overlap, private vertices sorted by
 * gid), its totals over all ranks (cnt_in, to find dropped entities at the
 * end) and the directory's blocks (from the largest vertex gid). Private
 * vertices stay out of the directory (s->P) unless there are ghost layers,
 * which other ranks' ghosts may need them for: then they join verts. */
static pa_status count_input(bstate *s, int overlap, const pa__recs *elems,
                             pa__recs *verts, const pa__recs *bdry,
                             const pa__recs *edges, pa__recs *priv, int ndbl,
                             pa_gid *cnt_in) {
  pa_status st = PA_SUCCESS;
  pa_gid maxg = -1;
  cnt_in[PA_VERTEX] = (pa_gid)verts->n;
  cnt_in[PA_ELEMENT] = (pa_gid)elems->n;
  cnt_in[PA_BOUNDARY] = (pa_gid)bdry->n;
  cnt_in[PA_EDGE] = (pa_gid)edges->n;
  PA_CHECK(verts->ndbl == ndbl && elems->nv == s->nve && bdry->nv == s->dim &&
               edges->nv == 2 && elems->ndbl == s->L.ndbl &&
               bdry->ndbl == s->B.ndbl && edges->ndbl == 0,
           PA_ERR_INTERNAL, "record layout mismatch");
  PA_CHECK(overlap >= 0 && overlap <= 8, PA_ERR_ARG,
           "overlap must be in [0, 8], got %d", overlap);
  if (priv && priv->n) {
    PA_CHECK(priv->ndbl == ndbl && priv->kind == PA_VERTEX, PA_ERR_INTERNAL,
             "record layout mismatch");
    for (size_t i = 1; i < priv->n; i++)
      PA_CHECK(priv->gid[i] > priv->gid[i - 1], PA_ERR_INTERNAL,
               "private vertices not sorted by global id");
    cnt_in[PA_VERTEX] += (pa_gid)priv->n;
    if (overlap > 0) { /* ghosts of other ranks may need them: directory */
      PA_CALL(pa__recs_append(verts, priv, 0, priv->n));
    } else {
      s->P = priv;
      maxg = priv->gid[priv->n - 1];
    }
  }
  for (size_t i = 0; i < verts->n; i++)
    if (verts->gid[i] > maxg) maxg = verts->gid[i];
  PA_CALL(pa__allreduce(s->comm, cnt_in, PA_DMESH_NKIND, MPI_INT64_T, MPI_SUM));
  PA_CALL(pa__allreduce(s->comm, &maxg, 1, MPI_INT64_T, MPI_MAX));
  dir_init(&s->vdir, maxg, s->size);
cleanup:
  return st;
}

/* Step 1: elements to their owners: the received records become the owned
 * part of L (aux = destination = this rank), sorted by gid, in layer 0. */
static pa_status migrate_elements(bstate *s, pa__recs *elems) {
  pa_status st = PA_SUCCESS;
  PA_CALL(pa__recs_migrate_free(s->comm, elems, NULL, &s->L));
  for (size_t i = 1; i < s->L.n; i++)
    PA_CHECK(s->L.gid[i] != s->L.gid[i - 1], PA_ERR_MESH,
             "element global id %lld is given twice", (long long)s->L.gid[i]);
  PA_CALLOC(s->layer, s->L.n);
  s->caplayer = s->L.n;
  PA_CALL(pa__gidmap_init(&s->emap, 16));
cleanup:
  return st;
}

/* After the fetch: free the directory, the touch lists and messages and
 * the index of the owned elements' vertices; keep the local records and
 * what assemble reads (uslot, or uix without it, ulv and their count
 * nu). */
static void drop_directory(bstate *s) {
  bstate keep = *s;
  memset(&keep.V, 0, sizeof keep.V);
  memset(&keep.B, 0, sizeof keep.B);
  memset(&keep.D, 0, sizeof keep.D);
  memset(&keep.vix, 0, sizeof keep.vix);
  keep.bstart = keep.blist = keep.dstart = keep.dlist = keep.tstart = NULL;
  keep.trank = NULL;
  keep.upriv = NULL;
  keep.tcnt = NULL;
  keep.tgid = NULL;
  keep.tv = NULL;
  memset(&keep.emap, 0, sizeof keep.emap);
  keep.ukey = NULL; /* keep.nu stays: the count of keep.ulv */
  keep.ustart = keep.uelem = NULL;
  if (keep.uslot) memset(&keep.uix, 0, sizeof keep.uix);
  else memset(&s->uix, 0, sizeof s->uix);
  s->uslot = s->ulv = NULL;
  /* free what keep no longer references */
  memset(&s->L, 0, sizeof s->L);
  s->layer = NULL;
  memset(&s->LV, 0, sizeof s->LV);
  memset(&s->LB, 0, sizeof s->LB);
  memset(&s->LD, 0, sizeof s->LD);
  bstate_free(s);
  *s = keep;
}

/* Step 10: the global counts; an input entity in no element was dropped,
 * which is an error. */
static pa_status check_totals(pa_dmesh *dm, const pa_gid *cnt_in) {
  pa_status st = PA_SUCCESS;
  pa_gid own[PA_DMESH_NKIND];
  for (int k = 0; k < PA_DMESH_NKIND; k++) own[k] = dm->nown[k];
  PA_CALL(pa__allreduce(dm->comm, own, PA_DMESH_NKIND, MPI_INT64_T, MPI_SUM));
  for (int k = 0; k < PA_DMESH_NKIND; k++) dm->nglob[k] = own[k];
  PA_CHECK(own[PA_VERTEX] == cnt_in[PA_VERTEX], PA_ERR_MESH,
           "%lld of %lld vertices belong to no element",
           (long long)(cnt_in[PA_VERTEX] - own[PA_VERTEX]),
           (long long)cnt_in[PA_VERTEX]);
  PA_CHECK(own[PA_BOUNDARY] == cnt_in[PA_BOUNDARY], PA_ERR_MESH,
           "%lld of %lld boundary entities are not faces of any element",
           (long long)(cnt_in[PA_BOUNDARY] - own[PA_BOUNDARY]),
           (long long)cnt_in[PA_BOUNDARY]);
  PA_CHECK(own[PA_EDGE] == cnt_in[PA_EDGE], PA_ERR_MESH,
           "%lld of %lld edges are in no element",
           (long long)(cnt_in[PA_EDGE] - own[PA_EDGE]),
           (long long)cnt_in[PA_EDGE]);
cleanup:
  return st;
}

pa_status pa__dmesh_neighbours(pa_dmesh *dm) {
  pa_status st = PA_SUCCESS;
  uint8_t *mark = NULL;
  int nn = 0;
  PA_CALLOC(mark, dm->size);
  for (int k = 0; k < PA_DMESH_NKIND; k++) {
    for (int r = 0; r < dm->sf[k].nrootrank; r++) mark[dm->sf[k].rootrank[r]] = 1;
    for (int r = 0; r < dm->sf[k].nleafrank; r++) mark[dm->sf[k].leafrank[r]] = 1;
  }
  for (int r = 0; r < dm->size; r++) nn += mark[r];
  dm->neigh = pa__malloc((size_t)(nn ? nn : 1) * sizeof *dm->neigh);
  PA_CHECK(dm->neigh, PA_ERR_MEMORY, "out of memory");
  dm->nneigh = 0;
  for (int r = 0; r < dm->size; r++)
    if (mark[r]) dm->neigh[dm->nneigh++] = r;
cleanup:
  pa__free(mark);
  return st;
}

pa_status pa__dmesh_build_priv(pa_dmesh *dm, const pa__layout *lay,
                               int overlap, pa__recs *elems, pa__recs *verts,
                               pa__recs *bdry, pa__recs *edges,
                               pa__recs *priv) {
  pa_status st = PA_SUCCESS;
  bstate s;
  pa_gid cnt_in[PA_DMESH_NKIND];
  double t0 = pa_wtime();
  int ndbl = pa__layout_ndbl(lay);
  bstate_init(&s, dm, lay);
  dm->overlap = overlap;
  /* input totals and the directory of vertex gids */
  PA_CALL(count_input(&s, overlap, elems, verts, bdry, edges, priv, ndbl,
                      cnt_in));
  /* 1. elements to their owners */
  PA_CALL(migrate_elements(&s, elems));
  pa_idx nown_e = (pa_idx)s.L.n;
  double t1 = pa_wtime();
  /* 2-3. directory and touch lists */
  PA_CALL(build_directory(&s, verts, bdry, edges));
  st = owned_csr(&s, nown_e, overlap > 0);
  PA_CALL(pa__agree(s.comm, st));
  PA_CALL(build_touch(&s));
  /* 4. ghost layers */
  PA_CALL(build_layers(&s, overlap, nown_e));
  double t2 = pa_wtime();
  /* 5. vertices, boundary entities, edges; the directory is done with */
  PA_CALL(fetch_vertices(&s));
  drop_directory(&s);
  /* 6-9. numbering, local mesh, values */
  PA_CALL(assemble(dm, &s, lay));
  bstate_free(&s);
  /* 10. totals: an entity in no element was dropped */
  PA_CALL(check_totals(dm, cnt_in));
  /* 11. star forests, neighbour ranks, value exchanges */
  PA_CALL(pa__agree(dm->comm, PA_SUCCESS));
  for (int k = 0; k < PA_DMESH_NKIND; k++)
    PA_CALL(pa__sf_build(dm->comm, dm->nloc[k], dm->gid[k], dm->owner[k],
                         &dm->sf[k]));
  PA_CALL(pa__dmesh_neighbours(dm));
  for (int k = 0; k < dm->nvalue; k++)
    PA_CALL(pa__value_setup(dm, dm->value[k]));
  pa__info(2, "padapt: dmesh build: migrate %.3f s, directory+ghosts %.3f s, "
              "rest %.3f s\n", t1 - t0, t2 - t1, pa_wtime() - t2);
cleanup:
  st = pa__agree_end(dm->comm, st);
  bstate_free(&s);
  pa__recs_free(elems);
  pa__recs_free(verts);
  pa__recs_free(bdry);
  pa__recs_free(edges);
  if (priv) pa__recs_free(priv);
  return st;
}
