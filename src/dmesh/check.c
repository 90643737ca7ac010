/*
 * check.c -- collective validity check of a distributed mesh, the checksum
 * independent of the number of ranks and of the numbering, and partition
 * statistics.
 *
 * The check compares every ghost with its owner by broadcasting the owner's
 * data over the kind's star forest into a scratch copy; uniqueness of global
 * ids and the ownership rule are checked at rendezvous ranks (block of the
 * gid range), conformity with the distributed dual graph.
 */
#include "dmesh/dmesh.h"

#include <math.h>
#include <stdio.h>

static const char *kind_name(int k) {
  static const char *n[] = {"vertex", "element", "boundary entity", "edge"};
  return n[k];
}

/* Signed volume (3D) / area (2D) of local element e, computed here so that
 * the check does not depend on the sequential mesh code; d a constant once
 * inlined (the loops unroll). */
static inline double elem_volume_dim(const pa_mesh *m, pa_idx e, const int d) {
  const pa_idx *v = m->elem + (size_t)(d + 1) * e;
  const double *a = m->coord + (size_t)d * v[0];
  double u[3][3];
  for (int i = 0; i < d; i++)
    for (int k = 0; k < d; k++) u[i][k] = m->coord[(size_t)d * v[i + 1] + k] - a[k];
  if (d == 2) return 0.5 * (u[0][0] * u[1][1] - u[0][1] * u[1][0]);
  return (u[0][0] * (u[1][1] * u[2][2] - u[1][2] * u[2][1]) -
          u[0][1] * (u[1][0] * u[2][2] - u[1][2] * u[2][0]) +
          u[0][2] * (u[1][0] * u[2][1] - u[1][1] * u[2][0])) / 6.0;
}

static double elem_volume(const pa_mesh *m, pa_idx e) {
  return m->dim == 2 ? elem_volume_dim(m, e, 2) : elem_volume_dim(m, e, 3);
}

/* Broadcast owners' blocks over sf into a copy of a; compare ghosts. Returns
 * the first differing local index in *bad (-1 if none). */
static pa_status ghosts_equal(pa_dmesh *dm, int kind, const void *a,
                              size_t unit, pa_idx *bad) {
  pa_status st = PA_SUCCESS;
  unsigned char *c = NULL;
  pa__sfop op;
  memset(&op, 0, sizeof op);
  pa_idx n = dm->nloc[kind];
  *bad = -1;
  c = pa__malloc(unit * (size_t)n + 1);
  st = c ? pa__sfop_init(&op, &dm->sf[kind], unit, 901)
         : pa__error(PA_ERR_MEMORY, __FILE__, __LINE__, "out of memory");
  PA_CALL(pa__agree(dm->comm, st));
  if (n) memcpy(c, a, unit * (size_t)n);
  PA_CALL(pa__sf_bcast_begin(&op, c));
  PA_CALL(pa__sf_bcast_end(&op, c));
  for (pa_idx i = dm->nown[kind]; i < n && *bad < 0; i++)
    if (memcmp(c + unit * (size_t)i, (const unsigned char *)a + unit * (size_t)i, unit))
      *bad = i;
cleanup:
  pa__sfop_free(&op);
  pa__free(c);
  return st;
}

/* A claim on an entity, sent to its rendezvous rank: the sender's view of
 * its owner, and whether the sender is a candidate owner (2 * rank + cand). */
typedef struct claim {
  pa_gid gid;
  int32_t owner;
  int32_t rank_cand;
} claim;

static int claim_cmp(const void *x, const void *y) {
  const claim *a = x, *b = y;
  if (a->gid != b->gid) return a->gid < b->gid ? -1 : 1;
  return (a->rank_cand > b->rank_cand) - (a->rank_cand < b->rank_cand);
}

/* Sort the claims it[0..n) by (gid, rank_cand) into *sorted (it itself,
 * or a new array that replaces it; the caller frees both): by counting
 * when their ids allow it (a rendezvous rank receives a block of
 * consecutive ids: pa__gid_span_countable), else by qsort. The claims arrive
 * by sending rank and a rank claims a gid once, so a stable sort by gid
 * orders each gid's claims by rank_cand. */
static pa_status sort_claims(claim *it, size_t n, claim **sorted) {
  pa_status st = PA_SUCCESS;
  pa_idx *cnt = NULL;
  claim *out = NULL;
  *sorted = it;
  if (!n) return PA_SUCCESS;
  pa_gid lo = it[0].gid, hi = it[0].gid;
  for (size_t i = 1; i < n; i++) {
    lo = it[i].gid < lo ? it[i].gid : lo;
    hi = it[i].gid > hi ? it[i].gid : hi;
  }
  size_t span = (size_t)(hi - lo) + 1;
  if (!pa__gid_span_countable(lo, hi, n)) {
    qsort(it, n, sizeof *it, claim_cmp);
    return PA_SUCCESS;
  }
  PA_CALLOC(cnt, span + 1);
  PA_ALLOC(out, n);
  for (size_t i = 0; i < n; i++) cnt[it[i].gid - lo + 1]++;
  for (size_t b = 0; b < span; b++) cnt[b + 1] += cnt[b];
  for (size_t i = 0; i < n; i++) out[cnt[it[i].gid - lo]++] = it[i];
  *sorted = out;
  out = NULL;
cleanup:
  pa__free(cnt);
  pa__free(out);
  return st;
}

/* Rendezvous check: every rank sends a claim for each local entity to the
 * rank of its block of global ids; there, the owner must be unique among
 * the claims, owned by exactly one rank, and the lowest candidate. Memory:
 * 16 bytes per local entity sent, and as much received. */
static pa_status check_rule(pa_dmesh *dm, int kind, const uint8_t *cand) {
  pa_status st = PA_SUCCESS;
  int size = dm->size;
  pa_idx n = dm->nloc[kind];
  pa_gid maxg = -1, block;
  size_t *cnt = NULL, *pos = NULL, *rcnt = NULL;
  claim *item = NULL, *it = NULL;
  void *recv = NULL;
  for (pa_idx i = 0; i < n; i++)
    if (dm->gid[kind][i] > maxg) maxg = dm->gid[kind][i];
  PA_CALL(pa__allreduce(dm->comm, &maxg, 1, MPI_INT64_T, MPI_MAX));
  block = (maxg + size) / size;
  if (block < 1) block = 1;
  PA_CALLOC(cnt, size);
  PA_CALLOC(pos, (size_t)size + 1);
  PA_ALLOC(item, (size_t)n);
  for (pa_idx i = 0; i < n; i++) {
    pa_gid r = dm->gid[kind][i] / block;
    cnt[r >= size ? size - 1 : r]++;
  }
  for (int r = 0; r < size; r++) pos[r + 1] = pos[r] + cnt[r];
  for (pa_idx i = 0; i < n; i++) {
    pa_gid r = dm->gid[kind][i] / block;
    claim *c = item + pos[r >= size ? size - 1 : r]++;
    c->gid = dm->gid[kind][i];
    c->owner = dm->owner[kind][i];
    c->rank_cand = 2 * dm->rank + (cand[i] != 0);
  }
  for (int r = 0; r < size; r++) cnt[r] *= sizeof(claim);
  PA_CALL(pa__xchg_sparse(dm->comm, cnt, item, &rcnt, &recv));
  pa__free(item);
  item = NULL;
  size_t nr = 0;
  for (int r = 0; r < size; r++) nr += rcnt[r] / sizeof(claim);
  PA_CALL(sort_claims(recv, nr, &it));
  for (size_t a = 0; a < nr;) {
    size_t b = a;
    pa_gid g = it[a].gid, own = it[a].owner, mincand = size;
    int nowners = 0;
    for (; b < nr && it[b].gid == g; b++) {
      int rank = it[b].rank_cand >> 1;
      PA_CHECK(it[b].owner == own, PA_ERR_MESH,
               "%s %lld: ranks disagree on its owner (%lld and %lld)",
               kind_name(kind), (long long)g, (long long)own,
               (long long)it[b].owner);
      if (rank == it[b].owner) nowners++;
      if ((it[b].rank_cand & 1) && rank < mincand) mincand = rank;
    }
    PA_CHECK(nowners == 1, PA_ERR_MESH,
             "%s global id %lld is owned %d times", kind_name(kind),
             (long long)g, nowners);
    PA_CHECK(own == mincand, PA_ERR_MESH,
             "%s %lld is owned by rank %lld, but the ownership rule gives %lld",
             kind_name(kind), (long long)g, (long long)own, (long long)mincand);
    a = b;
  }
cleanup:
  st = pa__agree_end(dm->comm, st);
  pa__free(cnt);
  pa__free(pos);
  pa__free(rcnt);
  pa__free(item);
  if (it != recv) pa__free(it);
  pa__free(recv);
  return st;
}

/* The local structure: counts as the dmesh's, owned-first numbering,
 * owners in range, layers (0 for owned elements only, at most the
 * overlap), element vertices in range, owned elements positively
 * oriented. */
/* The local elements' layers, vertex numbers and (owned ones) volumes, d a
 * constant once inlined. */
static inline pa_status check_elements(const pa_dmesh *dm, const int d) {
  pa_status st = PA_SUCCESS;
  const pa_mesh *m = dm->mesh;
  for (pa_idx e = 0; e < m->ne; e++) {
    const pa_idx *v = m->elem + (size_t)(d + 1) * e;
    PA_CHECK((dm->layer[e] == 0) == (e < dm->nown[PA_ELEMENT]) &&
                 dm->layer[e] <= dm->overlap,
             PA_ERR_MESH, "rank %d: element %lld has layer %d", dm->rank,
             (long long)dm->gid[PA_ELEMENT][e], dm->layer[e]);
    int out = 0;
    for (int j = 0; j <= d; j++) out |= v[j] < 0 || v[j] >= m->nv;
    PA_CHECK(!out, PA_ERR_MESH, "rank %d: element %d has a vertex out of range",
             dm->rank, (int)e);
    if (e >= dm->nown[PA_ELEMENT]) continue;
    double vol = elem_volume_dim(m, e, d);
    PA_CHECK(vol > 0, PA_ERR_MESH,
             "element %lld (rank %d) is inverted or flat (volume %g)",
             (long long)dm->gid[PA_ELEMENT][e], dm->rank, vol);
  }
cleanup:
  return st;
}

static pa_status check_local(pa_dmesh *dm) {
  pa_status st = PA_SUCCESS;
  const pa_mesh *m = dm->mesh;
  int d = dm->dim;
  PA_CHECK(m->nv == dm->nloc[PA_VERTEX] && m->ne == dm->nloc[PA_ELEMENT] &&
               m->nb == dm->nloc[PA_BOUNDARY] && m->ned == dm->nloc[PA_EDGE],
           PA_ERR_MESH, "rank %d: local mesh counts differ from the dmesh's",
           dm->rank);
  for (int k = 0; k < PA_DMESH_NKIND; k++)
    for (pa_idx i = 0; i < dm->nloc[k]; i++) {
      PA_CHECK((dm->owner[k][i] == dm->rank) == (i < dm->nown[k]), PA_ERR_MESH,
               "rank %d: local %s %d (gid %lld, owner %d) breaks the owned-first "
               "numbering", dm->rank, kind_name(k), (int)i,
               (long long)dm->gid[k][i], dm->owner[k][i]);
      PA_CHECK(dm->owner[k][i] >= 0 && dm->owner[k][i] < dm->size, PA_ERR_MESH,
               "rank %d: %s %lld has owner %d out of range", dm->rank,
               kind_name(k), (long long)dm->gid[k][i], dm->owner[k][i]);
    }
  PA_CALL(d == 2 ? check_elements(dm, 2) : check_elements(dm, 3));
cleanup:
  return st;
}

/* Every ghost equal to its owner: global ids, coordinates and references,
 * then connectivity by vertex global ids. Each comparison is agreed. */
static pa_status check_ghosts(pa_dmesh *dm) {
  pa_status st = PA_SUCCESS;
  const pa_mesh *m = dm->mesh;
  int d = dm->dim;
  pa_gid *vg = NULL;
  struct {
    int kind;
    const void *a;
    size_t unit;
    const char *what;
  } arr[] = {
      {PA_VERTEX, dm->gid[PA_VERTEX], sizeof(pa_gid), "global id"},
      {PA_VERTEX, m->coord, sizeof(double) * d, "coordinates"},
      {PA_VERTEX, m->vref, 4, "reference"},
      {PA_ELEMENT, dm->gid[PA_ELEMENT], sizeof(pa_gid), "global id"},
      {PA_ELEMENT, m->eref, 4, "reference"},
      {PA_BOUNDARY, dm->gid[PA_BOUNDARY], sizeof(pa_gid), "global id"},
      {PA_BOUNDARY, m->bref, 4, "reference"},
      {PA_EDGE, dm->gid[PA_EDGE], sizeof(pa_gid), "global id"},
      {PA_EDGE, m->edref, 4, "reference"},
  };
  for (size_t q = 0; q < sizeof arr / sizeof *arr; q++) {
    pa_idx bad;
    PA_CALL(pa__agree(dm->comm, st));
    PA_CALL(ghosts_equal(dm, arr[q].kind, arr[q].a, arr[q].unit, &bad));
    PA_CHECK(bad < 0, PA_ERR_MESH,
             "rank %d: ghost %s %lld differs from its owner's (rank %d) in "
             "its %s", dm->rank, kind_name(arr[q].kind),
             (long long)dm->gid[arr[q].kind][bad], dm->owner[arr[q].kind][bad],
             arr[q].what);
  }
  /* connectivity, by vertex global ids */
  for (int k = PA_ELEMENT; k < PA_DMESH_NKIND; k++) {
    int nv = pa__kind_nv(d, k);
    const pa_idx *conn = k == PA_ELEMENT ? m->elem : k == PA_BOUNDARY ? m->bdry : m->edge;
    pa_idx n = dm->nloc[k], bad;
    PA_ALLOC(vg, (size_t)n * nv);
    for (size_t i = 0; i < (size_t)n * nv; i++)
      vg[i] = dm->gid[PA_VERTEX][conn[i]];
    PA_CALL(pa__agree(dm->comm, st));
    PA_CALL(ghosts_equal(dm, k, vg, sizeof(pa_gid) * nv, &bad));
    PA_CHECK(bad < 0, PA_ERR_MESH,
             "rank %d: ghost %s %lld has other vertices than its owner's",
             dm->rank, kind_name(k), (long long)dm->gid[k][bad]);
    pa__free(vg);
    vg = NULL;
  }
cleanup:
  pa__free(vg);
  return st;
}

/* cand[i] = 1 for the local entities of a kind that an owned element
 * contains (vstart/vel: the local elements around each vertex): the ranks
 * that may own them. */
static void owner_candidates(const pa_dmesh *dm, int k, const pa_idx *vstart,
                             const pa_idx *vel, uint8_t *cand) {
  const pa_mesh *m = dm->mesh;
  int d = dm->dim;
  pa_idx n = dm->nloc[k];
  if (k == PA_VERTEX) {
    for (pa_idx v = 0; v < n; v++)
      for (pa_idx q = vstart[v]; q < vstart[v + 1]; q++)
        if (vel[q] < dm->nown[PA_ELEMENT]) cand[v] = 1;
  } else if (k == PA_ELEMENT) {
    for (pa_idx e = 0; e < dm->nown[PA_ELEMENT]; e++) cand[e] = 1;
  } else {
    int nv = pa__kind_nv(d, k);
    const pa_idx *conn = k == PA_BOUNDARY ? m->bdry : m->edge;
    for (pa_idx b = 0; b < n; b++) {
      const pa_idx *bv = conn + (size_t)nv * b;
      for (pa_idx q = vstart[bv[0]]; q < vstart[bv[0] + 1] && !cand[b]; q++) {
        if (vel[q] >= dm->nown[PA_ELEMENT]) continue;
        const pa_idx *ev = m->elem + (size_t)(d + 1) * vel[q];
        int all = 1;
        for (int j = 1; j < nv && all; j++) {
          int in = 0;
          for (int c = 0; c <= d; c++) in |= ev[c] == bv[j];
          all = in;
        }
        cand[b] = (uint8_t)all;
      }
    }
  }
}

/* The ownership rule and the uniqueness of global ids, kind by kind, at
 * the rendezvous ranks (check_rule). */
static pa_status check_ownership(pa_dmesh *dm) {
  pa_status st = PA_SUCCESS;
  const pa_mesh *m = dm->mesh;
  uint8_t *cand = NULL;
  pa_idx *vstart = NULL, *vel = NULL;
  PA_CALL(pa__balls(m->elem, m->ne, dm->dim + 1, m->nv, &vstart, &vel));
  for (int k = 0; k < PA_DMESH_NKIND; k++) {
    pa__free(cand);
    cand = NULL;
    PA_CALLOC(cand, dm->nloc[k]);
    owner_candidates(dm, k, vstart, vel, cand);
    PA_CALL(pa__agree(dm->comm, st));
    PA_CALL(check_rule(dm, k, cand));
  }
cleanup:
  pa__free(cand);
  pa__free(vstart);
  pa__free(vel);
  return st;
}

/* The owned entities of every kind add up to the global counts. */
static pa_status check_global_counts(pa_dmesh *dm) {
  pa_status st = PA_SUCCESS;
  pa_gid own[PA_DMESH_NKIND];
  for (int k = 0; k < PA_DMESH_NKIND; k++) own[k] = dm->nown[k];
  PA_CALL(pa__allreduce(dm->comm, own, PA_DMESH_NKIND, MPI_INT64_T, MPI_SUM));
  for (int k = 0; k < PA_DMESH_NKIND; k++)
    PA_CHECK(own[k] == dm->nglob[k], PA_ERR_MESH,
             "%lld %s entities owned, %lld expected", (long long)own[k],
             kind_name(k), (long long)dm->nglob[k]);
cleanup:
  return st;
}

pa_status pa__dmesh_check_output(pa_dmesh *dm) {
  pa_status st = PA_SUCCESS;
  pa__agree_reset();
  PA_CALL(check_local(dm));
  PA_CALL(pa__agree(dm->comm, st));
  PA_CALL(check_global_counts(dm));
cleanup:
  return pa__agree_end(dm->comm, st);
}

pa_status pa_dmesh_check(pa_dmesh *dm) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(dm && dm->mesh, PA_ERR_ARG, "pa_dmesh_check: NULL dmesh");
  pa__agree_reset();
  PA_CALL(check_local(dm));
  PA_CALL(check_ghosts(dm));
  PA_CALL(check_ownership(dm));
  /* conformity across ranks */
  PA_CALL(pa__agree(dm->comm, st));
  PA_CALL(pa__faces_conform(dm->comm, dm->dim, dm->nown[PA_ELEMENT],
                            dm->mesh->elem, dm->mesh->nv, dm->gid[PA_VERTEX],
                            dm->gid[PA_ELEMENT]));
  PA_CALL(check_global_counts(dm));
cleanup:
  if (dm) st = pa__agree_end(dm->comm, st);
  return st;
}

/* ---- checksum ---- */

static uint64_t hash_bytes(uint64_t h, const void *p, size_t n) {
  const unsigned char *c = p;
  uint64_t w;
  size_t i = 0;
  for (; i + 8 <= n; i += 8) {
    memcpy(&w, c + i, 8);
    h = pa__mix64(h ^ w);
  }
  if (i < n) {
    w = 0;
    memcpy(&w, c + i, n - i);
    h = pa__mix64(h ^ w ^ ((uint64_t)(n - i) << 56));
  }
  return h;
}

static void sort_u64(uint64_t *a, int n) {
  for (int i = 1; i < n; i++) {
    uint64_t x = a[i];
    int j = i - 1;
    while (j >= 0 && a[j] > x) {
      a[j + 1] = a[j];
      j--;
    }
    a[j + 1] = x;
  }
}

pa_status pa_dmesh_checksum(pa_dmesh *dm, uint64_t *checksum) {
  pa_status st = PA_SUCCESS;
  uint64_t *hv = NULL, *he[PA_DMESH_NKIND] = {NULL};
  uint64_t sum = 0;
  PA_CHECK(dm && checksum, PA_ERR_ARG, "pa_dmesh_checksum: NULL argument");
  pa__agree_reset();
  pa_mesh *m = dm->mesh;
  int d = dm->dim;
  PA_ALLOC(hv, m->nv);
  for (pa_idx v = 0; v < m->nv; v++) {
    uint64_t h = hash_bytes(0x5EED0001ull, m->coord + (size_t)d * v, sizeof(double) * d);
    h = hash_bytes(h, &m->vref[v], 4);
    hv[v] = h;
    if (v < dm->nown[PA_VERTEX]) sum += hash_bytes(h, &m->vflag[v], 1);
  }
  for (int k = PA_ELEMENT; k < PA_DMESH_NKIND; k++) {
    int nv = pa__kind_nv(d, k);
    const pa_idx *conn = k == PA_ELEMENT ? m->elem : k == PA_BOUNDARY ? m->bdry : m->edge;
    const int32_t *ref = k == PA_ELEMENT ? m->eref : k == PA_BOUNDARY ? m->bref : m->edref;
    PA_ALLOC(he[k], dm->nown[k]);
    for (pa_idx e = 0; e < dm->nown[k]; e++) {
      uint64_t key[5];
      for (int j = 0; j < nv; j++) key[j] = hv[conn[(size_t)nv * e + j]];
      sort_u64(key, nv);
      key[nv] = (uint64_t)(int64_t)ref[e];
      uint64_t h = hash_bytes(0xE1E0000ull + (uint64_t)k, key, 8 * (size_t)(nv + 1));
      if (k == PA_ELEMENT) h = pa__mix64(h ^ (elem_volume(m, e) > 0 ? 1u : 2u));
      he[k][e] = h;
      sum += h;
    }
  }
  /* values: owned blocks, tied to their entity's hash */
  for (int q = 0; q < dm->nvalue; q++) {
    const pa_dmesh_value *v = dm->value[q];
    uint64_t salt = hash_bytes(0xA1ull, v->name, strlen(v->name));
    for (pa_idx s = 0; s < v->nslotown; s++) {
      pa_idx e = v->ent ? v->ent[s] : s;
      uint64_t eh = v->kind == PA_VERTEX ? hv[e] : he[v->kind][e];
      sum += hash_bytes(salt ^ eh, v->data + v->unit * (size_t)s, v->unit);
    }
  }
cleanup:
  if (dm) {
    st = pa__agree_end(dm->comm, st);
    if (!st) {
      st = pa__allreduce(dm->comm, &sum, 1, MPI_UINT64_T, MPI_SUM);
      if (!st) *checksum = sum;
    }
  }
  pa__free(hv);
  for (int k = 0; k < PA_DMESH_NKIND; k++) pa__free(he[k]);
  return st;
}

/* ---- partition statistics ---- */

pa_status pa_dmesh_partition_stats(pa_dmesh *dm, pa_gid *nelem,
                                   double *imbalance, pa_gid *edgecut) {
  pa_status st = PA_SUCCESS;
  pa_gid *all = NULL, *vg = NULL, *adj = NULL;
  pa_idx *xadj = NULL;
  int *adjrank = NULL;
  PA_CHECK(dm, PA_ERR_ARG, "pa_dmesh_partition_stats: NULL dmesh");
  pa__agree_reset();
  int d = dm->dim;
  pa_idx ne = dm->nown[PA_ELEMENT];
  PA_ALLOC(all, dm->size);
  PA_CALL(pa__agree(dm->comm, st));
  pa_gid mine = ne;
  MPI_Allgather(&mine, 1, MPI_INT64_T, all, 1, MPI_INT64_T, dm->comm);
  pa_gid cut = 0, tot = 0, mx = 0;
  if (dm->overlap >= 1) {
    /* every face neighbour of an owned element is local: count the owned
     * elements' faces shared with a ghost (pa_dmesh_elem_neighbours) */
    const pa_idx *nb;
    int had = dm->adja != NULL;
    st = ne ? pa_dmesh_elem_neighbours(dm, 0, &nb) : PA_SUCCESS;
    PA_CALL(pa__agree(dm->comm, st));
    for (size_t k = 0; k < (size_t)ne * (d + 1); k++)
      cut += dm->adja[k] >= ne;
    if (!had) { /* leave no cache behind */
      pa__free(dm->adja);
      dm->adja = NULL;
    }
  } else {
    st = PA_SUCCESS;
    vg = pa__malloc(((size_t)ne * (d + 1) + 1) * sizeof *vg);
    if (!vg) st = pa__error(PA_ERR_MEMORY, __FILE__, __LINE__, "out of memory");
    for (size_t k = 0; vg && k < (size_t)ne * (d + 1); k++)
      vg[k] = dm->gid[PA_VERTEX][dm->mesh->elem[k]];
    PA_CALL(pa__agree(dm->comm, st));
    PA_CALL(pa__dual_graph(dm->comm, d, ne, vg, dm->mesh->elem, dm->mesh->nv,
                           &xadj, &adj, &adjrank, NULL));
    for (pa_idx j = 0; j < xadj[ne]; j++) cut += adjrank[j] != dm->rank;
  }
  PA_CALL(pa__allreduce(dm->comm, &cut, 1, MPI_INT64_T, MPI_SUM));
  for (int r = 0; r < dm->size; r++) {
    tot += all[r];
    if (all[r] > mx) mx = all[r];
    if (nelem) nelem[r] = all[r];
  }
  if (imbalance) *imbalance = tot ? (double)mx * dm->size / (double)tot : 1.0;
  if (edgecut) *edgecut = cut / 2;
cleanup:
  if (dm) st = pa__agree_end(dm->comm, st);
  pa__free(all);
  pa__free(vg);
  pa__free(adj);
  pa__free(xadj);
  pa__free(adjrank);
  return st;
}
