/*
 * exchange.c -- the exchange layer (see exchange.h): agreement on the status
 * of collective routines, the star forest with split begin/end broadcast and
 * reduction, the sparse all-to-all and blocking buffer transfers of setup.
 *
 * This is the only file of padapt that calls point-to-point MPI functions.
 * Every MPI call is checked (PA_CALL_MPI: a failure is PA_ERR_MPI naming
 * the call), but for the clean-up on an error path (the wait of
 * pa__sfop_free, the datatype of an operation that failed to start),
 * which runs on the way out of an error already being reported.
 * Invariants: an sf lists, for each neighbour rank, root indices on the root
 * side and leaf indices on the leaf side in the same order; messages of one
 * operation use the tag of its pa__sfop, so operations on different values may
 * be in flight at once; setup messages use tags below those of any operation
 * (dmesh.c's TAG_SYNC and TAG_VALUE_BASE); the requests of an operation not
 * posted yet are MPI_REQUEST_NULL, so an operation that failed half-way is
 * waited for and freed like any other.
 */
#include "dmesh/exchange.h"
#include "dmesh/util.h"

#include <limits.h>
#include <stdio.h>

enum {
  TAG_SPARSE = 11,
  TAG_SFBUILD = 12,
  TAG_P2P_SIZE = 13,
  TAG_P2P_DATA = 14,
  CHUNK = 1 << 30 /* bytes per message at most */
};

pa_status pa__allreduce(MPI_Comm comm, void *buf, int n, MPI_Datatype t,
                        MPI_Op op) {
  pa_status st = PA_SUCCESS;
  PA_CALL(pa__agree(comm, PA_SUCCESS));
  PA_CALL_MPI(MPI_Allreduce(MPI_IN_PLACE, buf, n, t, op, comm));
cleanup:
  return st;
}

/* ---- sparse all-to-all ---- */

/* Post the receives and sends of one rank pair, chunked below CHUNK bytes. */
static int nchunks(size_t n) { return (int)((n + CHUNK - 1) / CHUNK); }

pa_status pa__xchg_sparse(MPI_Comm comm, const size_t *sendcount,
                          const void *sendbuf, size_t **recvcountp,
                          void **recvbufp) {
  pa_status st = PA_SUCCESS;
  int size;
  uint64_t *sc = NULL, *rc = NULL;
  size_t *recvcount = NULL;
  unsigned char *recvbuf = NULL;
  MPI_Request *req = NULL;
  *recvcountp = NULL;
  *recvbufp = NULL;
  PA_CALL_MPI(MPI_Comm_size(comm, &size));
  sc = pa__malloc((size_t)size * sizeof *sc);
  rc = pa__malloc((size_t)size * sizeof *rc);
  recvcount = pa__malloc((size_t)size * sizeof *recvcount);
  st = (!sc || !rc || !recvcount)
           ? pa__error(PA_ERR_MEMORY, __FILE__, __LINE__,
                       "out of memory exchanging counts")
           : PA_SUCCESS;
  PA_CALL(pa__agree(comm, st));
  for (int r = 0; r < size; r++) sc[r] = sendcount[r];
  PA_CALL_MPI(MPI_Alltoall(sc, 1, MPI_UINT64_T, rc, 1, MPI_UINT64_T, comm));
  size_t total = 0;
  int nreq = 0;
  for (int r = 0; r < size; r++) {
    recvcount[r] = (size_t)rc[r];
    total += recvcount[r];
    nreq += nchunks(recvcount[r]) + nchunks(sendcount[r]);
  }
  /* Allocation failures here must not leave others waiting for messages. */
  recvbuf = pa__malloc(total ? total : 1);
  req = pa__malloc((size_t)(nreq ? nreq : 1) * sizeof *req);
  st = (!recvbuf || !req)
           ? pa__error(PA_ERR_MEMORY, __FILE__, __LINE__,
                       "out of memory receiving %zu bytes", total)
           : PA_SUCCESS;
  PA_CALL(pa__agree(comm, st));
  int k = 0;
  size_t off = 0;
  for (int r = 0; r < size; r++) {
    for (size_t o = 0; o < recvcount[r]; o += CHUNK) {
      size_t n = recvcount[r] - o < CHUNK ? recvcount[r] - o : CHUNK;
      PA_CALL_MPI(MPI_Irecv(recvbuf + off + o, (int)n, MPI_BYTE, r,
                            TAG_SPARSE, comm, &req[k++]));
    }
    off += recvcount[r];
  }
  off = 0;
  for (int r = 0; r < size; r++) {
    for (size_t o = 0; o < sendcount[r]; o += CHUNK) {
      size_t n = sendcount[r] - o < CHUNK ? sendcount[r] - o : CHUNK;
      PA_CALL_MPI(MPI_Isend((const unsigned char *)sendbuf + off + o, (int)n,
                            MPI_BYTE, r, TAG_SPARSE, comm, &req[k++]));
    }
    off += sendcount[r];
  }
  PA_CALL_MPI(MPI_Waitall(k, req, MPI_STATUSES_IGNORE));
  *recvcountp = recvcount;
  *recvbufp = recvbuf;
  recvcount = NULL;
  recvbuf = NULL;
cleanup:
  pa__free(sc);
  pa__free(rc);
  pa__free(recvcount);
  pa__free(recvbuf);
  pa__free(req);
  return st;
}

/* ---- point to point buffers ---- */

pa_status pa__xchg_send(MPI_Comm comm, int dest, const void *buf, size_t n) {
  pa_status st = PA_SUCCESS;
  uint64_t n64 = n;
  PA_CALL_MPI(MPI_Send(&n64, 1, MPI_UINT64_T, dest, TAG_P2P_SIZE, comm));
  for (size_t o = 0; o < n; o += CHUNK) {
    size_t c = n - o < CHUNK ? n - o : CHUNK;
    PA_CALL_MPI(MPI_Send((const unsigned char *)buf + o, (int)c, MPI_BYTE,
                         dest, TAG_P2P_DATA, comm));
  }
cleanup:
  return st;
}

pa_status pa__xchg_recv(MPI_Comm comm, int src, void **bufp, size_t *np) {
  pa_status st = PA_SUCCESS;
  uint64_t n64;
  unsigned char *buf = NULL, *sink = NULL;
  PA_CALL_MPI(MPI_Recv(&n64, 1, MPI_UINT64_T, src, TAG_P2P_SIZE, comm,
                       MPI_STATUS_IGNORE));
  size_t n = (size_t)n64;
  buf = pa__malloc(n ? n : 1);
  if (!buf) { /* drain the message so the sender is not left blocked */
    sink = malloc(CHUNK < n ? CHUNK : (n ? n : 1));
    for (size_t o = 0; o < n; o += CHUNK)
      PA_CALL_MPI(MPI_Recv(sink, (int)(n - o < CHUNK ? n - o : CHUNK),
                           MPI_BYTE, src, TAG_P2P_DATA, comm,
                           MPI_STATUS_IGNORE));
    PA_FAIL(PA_ERR_MEMORY, "out of memory receiving %zu bytes", n);
  }
  for (size_t o = 0; o < n; o += CHUNK)
    PA_CALL_MPI(MPI_Recv(buf + o, (int)(n - o < CHUNK ? n - o : CHUNK),
                         MPI_BYTE, src, TAG_P2P_DATA, comm,
                         MPI_STATUS_IGNORE));
  *bufp = buf;
  *np = n;
  buf = NULL;
cleanup:
  free(sink);
  pa__free(buf);
  return st;
}

/* ---- star forest ---- */

void pa__sf_free(pa__sf *sf) {
  pa__free(sf->rootrank);
  pa__free(sf->rootoff);
  pa__free(sf->rootidx);
  pa__free(sf->leafrank);
  pa__free(sf->leafoff);
  pa__free(sf->leafidx);
  memset(sf, 0, sizeof *sf);
}

size_t pa__sf_memory(const pa__sf *sf) {
  return pa__alloc_size(sf->rootrank) + pa__alloc_size(sf->rootoff) +
         pa__alloc_size(sf->rootidx) + pa__alloc_size(sf->leafrank) +
         pa__alloc_size(sf->leafoff) + pa__alloc_size(sf->leafidx);
}

/* The leaves of a star forest: the ghosts (owner[i] != rank) grouped by
 * owner rank, sorted by gid within a rank, into *orderp (*nleafp of them);
 * cnt[r] (size zeroed entries) becomes the number of ghosts rank r owns.
 * The i0 entities that lead are owned (usually all the owned ones): the
 * leaves are searched for only past them. */
static pa_status order_leaves(pa_idx n, const pa_gid *gid, const int *owner,
                              int rank, int size, pa_idx i0, size_t *cnt,
                              pa_idx **orderp, pa_idx *nleafp) {
  pa_status st = PA_SUCCESS;
  pa_idx nleaf = 0;
  for (pa_idx i = i0; i < n; i++)
    if (owner[i] != rank) {
      PA_CHECK(owner[i] >= 0 && owner[i] < size, PA_ERR_INTERNAL,
               "entity %d has owner %d out of range", (int)i, owner[i]);
      cnt[owner[i]]++;
      nleaf++;
    }
  *nleafp = nleaf;
  PA_ALLOC(*orderp, nleaf);
  pa_idx *order = *orderp;
  pa_idx k = 0;
  for (pa_idx i = i0; i < n; i++)
    if (owner[i] != rank) order[k++] = i;
  PA_CALL(pa__sort_by_gid(order, (size_t)nleaf, gid));
  /* stable counting sort by owner keeps gid order within an owner */
  pa_idx *tmp;
  PA_ALLOC(tmp, nleaf);
  size_t *pos;
  pos = pa__calloc((size_t)size + 1, sizeof *pos);
  if (!pos) {
    pa__free(tmp);
    PA_FAIL(PA_ERR_MEMORY, "out of memory");
  }
  for (int r = 0; r < size; r++) pos[r + 1] = pos[r] + cnt[r];
  for (pa_idx j = 0; j < nleaf; j++) tmp[pos[owner[order[j]]]++] = order[j];
  memcpy(order, tmp, (size_t)nleaf * sizeof *order);
  pa__free(tmp);
  pa__free(pos);
cleanup:
  return st;
}

/* Fill the leaf side of sf: a range of order (nleaf ghosts, as
 * order_leaves leaves them) per rank with cnt[r] > 0. */
static pa_status set_leaves(pa__sf *sf, int size, const size_t *cnt,
                            const pa_idx *order, pa_idx nleaf) {
  pa_status st = PA_SUCCESS;
  int nlr = 0;
  for (int r = 0; r < size; r++) nlr += cnt[r] > 0;
  PA_ALLOC(sf->leafrank, nlr);
  PA_ALLOC(sf->leafoff, nlr + 1);
  PA_ALLOC(sf->leafidx, nleaf);
  sf->nleafrank = nlr;
  sf->leafoff[0] = 0;
  for (int r = 0, k = 0; r < size; r++)
    if (cnt[r]) {
      sf->leafrank[k] = r;
      sf->leafoff[k + 1] = sf->leafoff[k] + (pa_idx)cnt[r];
      k++;
    }
  memcpy(sf->leafidx, order, (size_t)nleaf * sizeof *order);
cleanup:
  return st;
}

/* Allocate the root side of sf for the requests received: rcnt[r] bytes
 * of gids from rank r, *nrootp gids in all. */
static pa_status alloc_roots(pa__sf *sf, int size, const size_t *rcnt,
                             size_t *nrootp) {
  pa_status st = PA_SUCCESS;
  int nrr = 0;
  size_t nroot = 0;
  for (int r = 0; r < size; r++) {
    nrr += rcnt[r] > 0;
    nroot += rcnt[r] / sizeof(pa_gid);
  }
  *nrootp = nroot;
  PA_ALLOC(sf->rootrank, nrr);
  PA_ALLOC(sf->rootoff, nrr + 1);
  PA_ALLOC(sf->rootidx, nroot);
  sf->nrootrank = nrr;
  sf->rootoff[0] = 0;
cleanup:
  return st;
}

/* Whether the owned entities come first, in strictly increasing gid order;
 * *nownp: how many owned entities lead. */
static int owned_first_sorted(pa_idx n, const pa_gid *gid, const int *owner,
                              int rank, pa_idx *nownp) {
  pa_idx nown = 0;
  int sorted = 1;
  while (nown < n && owner[nown] == rank) {
    if (nown && gid[nown] <= gid[nown - 1]) sorted = 0;
    nown++;
  }
  for (pa_idx i = nown; sorted && i < n; i++) sorted = owner[i] != rank;
  *nownp = nown;
  return sorted;
}

/* Resolve each requested gid rg[j] by a binary search among the nown owned
 * entities that lead, in increasing gid order; -1 where none has it. */
static void resolve_sorted(pa__sf *sf, const pa_gid *gid, pa_idx nown,
                           const pa_gid *rg, size_t nroot) {
  for (size_t j = 0; j < nroot; j++) {
    size_t k = pa__gid_lower_bound(gid, (size_t)nown, rg[j]);
    sf->rootidx[j] = k < (size_t)nown && gid[k] == rg[j] ? (pa_idx)k : -1;
  }
}

/* Resolve each requested gid rg[j] through a map of the requested gids
 * (chained through next when several ranks ask for one gid), then one pass
 * over the owned entities; the first owned entity of a gid wins, -1 where
 * none has it. */
static pa_status resolve_mapped(pa__sf *sf, pa_idx n, const pa_gid *gid,
                                const int *owner, int rank, const pa_gid *rg,
                                size_t nroot) {
  pa_status st = PA_SUCCESS;
  pa_idx *next = NULL;
  pa__gidmap map = {0};
  PA_ALLOC(next, nroot);
  PA_CALL(pa__gidmap_init(&map, nroot));
  for (size_t j = 0; j < nroot; j++) {
    int found;
    pa_idx first;
    sf->rootidx[j] = -1;
    next[j] = -1;
    if (rg[j] < 0) continue; /* never owned: reported by set_roots */
    PA_CALL(pa__gidmap_put(&map, rg[j], (pa_idx)j, &found, &first));
    if (found) { /* insert j second in the chain of its gid */
      next[j] = next[first];
      next[first] = (pa_idx)j;
    }
  }
  for (pa_idx i = 0; i < n && nroot; i++) {
    if (owner[i] != rank) continue;
    pa_idx j = pa__gidmap_get(&map, gid[i]);
    if (j < 0 || sf->rootidx[j] >= 0) continue;
    for (; j >= 0; j = next[j]) sf->rootidx[j] = i;
  }
cleanup:
  pa__free(next);
  pa__gidmap_free(&map);
  return st;
}

/* Fill the root ranges of sf, one per rank that sent requests, and fail
 * where a request found no owned entity. */
static pa_status set_roots(pa__sf *sf, int rank, int size, const size_t *rcnt,
                           const pa_gid *rg) {
  pa_status st = PA_SUCCESS;
  size_t j = 0;
  for (int r = 0, k = 0; r < size; r++) {
    if (!rcnt[r]) continue;
    size_t m = rcnt[r] / sizeof(pa_gid);
    sf->rootrank[k] = r;
    sf->rootoff[k + 1] = sf->rootoff[k] + (pa_idx)m;
    for (size_t q = 0; q < m; q++, j++)
      PA_CHECK(sf->rootidx[j] >= 0, PA_ERR_MESH,
               "rank %d holds a ghost of gid %lld that its owner %d does not "
               "own", r, (long long)rg[j], rank);
    k++;
  }
cleanup:
  return st;
}

pa_status pa__sf_build(MPI_Comm comm, pa_idx n, const pa_gid *gid,
                       const int *owner, pa__sf *sf) {
  pa_status st = PA_SUCCESS;
  int rank, size;
  size_t *cnt = NULL, *rcnt = NULL;
  pa_idx *order = NULL;
  pa_gid *sendg = NULL;
  void *recv = NULL;
  memset(sf, 0, sizeof *sf);
  sf->comm = comm;
  PA_CALL_MPI(MPI_Comm_rank(comm, &rank));
  PA_CALL_MPI(MPI_Comm_size(comm, &size));
  PA_CALLOC(cnt, size);
  pa_idx nleaf = 0, nown = 0;
  /* owned first with gids strictly increasing: only the first can be
   * negative */
  int sorted = owned_first_sorted(n, gid, owner, rank, &nown);
  PA_CALL(order_leaves(n, gid, owner, rank, size, nown, cnt, &order, &nleaf));
  PA_CALL(set_leaves(sf, size, cnt, order, nleaf));
  /* Each leaf asks its owner for the gid. */
  PA_ALLOC(sendg, nleaf);
  for (pa_idx j = 0; j < nleaf; j++) sendg[j] = gid[order[j]];
  for (int r = 0; r < size; r++) cnt[r] *= sizeof(pa_gid);
  for (pa_idx i = 0; i < (sorted ? (nown > 0) : n); i++)
    PA_CHECK(owner[i] != rank || gid[i] >= 0, PA_ERR_ARG,
             "negative global id %lld", (long long)gid[i]);
  PA_CALL(pa__xchg_sparse(comm, cnt, sendg, &rcnt, &recv));
  size_t nroot = 0;
  PA_CALL(alloc_roots(sf, size, rcnt, &nroot));
  /* Resolve the requests. When the owned entities come first, in strictly
   * increasing gid order (what every build leaves), each request is a
   * binary search among them. Otherwise (after pa_dmesh_reorder): a map of
   * the requested gids; the requests are the ghosts of the neighbours, far
   * fewer than the owned entities, so the map stays in cache, where a map
   * of every owned gid would not. */
  if (sorted)
    resolve_sorted(sf, gid, nown, recv, nroot);
  else
    PA_CALL(resolve_mapped(sf, n, gid, owner, rank, recv, nroot));
  PA_CALL(set_roots(sf, rank, size, rcnt, recv));
cleanup:
  st = pa__agree_end(comm, st);
  if (st) pa__sf_free(sf);
  pa__free(cnt);
  pa__free(rcnt);
  pa__free(order);
  pa__free(sendg);
  pa__free(recv);
  return st;
}

pa_status pa__sf_restrict(const pa__sf *sf, const pa_idx *slot, pa__sf *out) {
  pa_status st = PA_SUCCESS;
  memset(out, 0, sizeof *out);
  out->comm = sf->comm;
  for (int side = 0; side < 2; side++) {
    int nr = side ? sf->nleafrank : sf->nrootrank;
    const int *rk = side ? sf->leafrank : sf->rootrank;
    const pa_idx *off = side ? sf->leafoff : sf->rootoff;
    const pa_idx *idx = side ? sf->leafidx : sf->rootidx;
    int *ork = NULL;
    pa_idx *ooff = NULL, *oidx = NULL;
    PA_ALLOC(ork, nr);
    if (side) out->leafrank = ork; else out->rootrank = ork;
    PA_ALLOC(ooff, nr + 1);
    if (side) out->leafoff = ooff; else out->rootoff = ooff;
    PA_ALLOC(oidx, off[nr]);
    if (side) out->leafidx = oidx; else out->rootidx = oidx;
    int k = 0;
    pa_idx m = 0;
    ooff[0] = 0;
    for (int r = 0; r < nr; r++) {
      pa_idx m0 = m;
      for (pa_idx j = off[r]; j < off[r + 1]; j++)
        if (slot[idx[j]] >= 0) oidx[m++] = slot[idx[j]];
      if (m > m0) {
        ork[k] = rk[r];
        ooff[++k] = m;
      }
    }
    if (side) out->nleafrank = k; else out->nrootrank = k;
  }
cleanup:
  if (st) pa__sf_free(out);
  return st;
}

pa_status pa__sfop_init(pa__sfop *op, const pa__sf *sf, size_t unit, int tag) {
  pa_status st = PA_SUCCESS;
  memset(op, 0, sizeof *op);
  op->sf = sf;
  op->unit = unit;
  op->tag = tag;
  PA_ALLOC(op->rootbuf, unit * (size_t)sf->rootoff[sf->nrootrank]);
  PA_ALLOC(op->leafbuf, unit * (size_t)sf->leafoff[sf->nleafrank]);
  PA_ALLOC(op->req, sf->nrootrank + sf->nleafrank);
  {
    pa_idx big = 0;
    for (int r = 0; r < sf->nrootrank; r++)
      if (sf->rootoff[r + 1] - sf->rootoff[r] > big)
        big = sf->rootoff[r + 1] - sf->rootoff[r];
    PA_ALLOC(op->scratch, unit * (size_t)big);
  }
cleanup:
  if (st) pa__sfop_free(op);
  return st;
}

void pa__sfop_free(pa__sfop *op) {
  /* unchecked: an operation still in flight here is one an error cut
   * short, and that error is the one to report */
  if (op->active)
    (void)MPI_Waitall(op->sf->nrootrank + op->sf->nleafrank, op->req,
                      MPI_STATUSES_IGNORE);
  pa__free(op->rootbuf);
  pa__free(op->leafbuf);
  pa__free(op->scratch);
  pa__free(op->req);
  memset(op, 0, sizeof *op);
}

/* Every message of an sf fits in one MPI message (counts are 32-bit indices
 * times unit); units above 2^31/n would overflow int, guarded by a derived
 * contiguous datatype of `unit` bytes (*t, to free with MPI_Type_free). */
static pa_status unit_type(size_t unit, MPI_Datatype *t) {
  pa_status st = PA_SUCCESS;
  PA_CALL_MPI(MPI_Type_contiguous((int)unit, MPI_BYTE, t));
  PA_CALL_MPI(MPI_Type_commit(t));
cleanup:
  return st;
}

/* Mark op in flight with none of its requests posted yet. */
static void op_start(pa__sfop *op, int active) {
  for (int k = 0; k < op->sf->nrootrank + op->sf->nleafrank; k++)
    op->req[k] = MPI_REQUEST_NULL;
  op->active = active;
}

pa_status pa__sf_bcast_begin(pa__sfop *op, const void *data) {
  pa_status st = PA_SUCCESS;
  const pa__sf *sf = op->sf;
  const unsigned char *d = data;
  size_t u = op->unit;
  MPI_Datatype t = MPI_DATATYPE_NULL;
  int k = 0;
  op_start(op, 1);
  PA_CALL(unit_type(u, &t));
  for (int r = 0; r < sf->nleafrank; r++)
    PA_CALL_MPI(MPI_Irecv(op->leafbuf + u * (size_t)sf->leafoff[r],
                          (int)(sf->leafoff[r + 1] - sf->leafoff[r]), t,
                          sf->leafrank[r], op->tag, sf->comm, &op->req[k++]));
  for (int r = 0; r < sf->nrootrank; r++) {
    for (pa_idx j = sf->rootoff[r]; j < sf->rootoff[r + 1]; j++)
      memcpy(op->rootbuf + u * (size_t)j, d + u * (size_t)sf->rootidx[j], u);
    PA_CALL_MPI(MPI_Isend(op->rootbuf + u * (size_t)sf->rootoff[r],
                          (int)(sf->rootoff[r + 1] - sf->rootoff[r]), t,
                          sf->rootrank[r], op->tag, sf->comm, &op->req[k++]));
  }
  PA_CALL_MPI(MPI_Type_free(&t));
cleanup:
  if (t != MPI_DATATYPE_NULL) (void)MPI_Type_free(&t); /* on an error */
  return st;
}

pa_status pa__sf_bcast_end(pa__sfop *op, void *data) {
  pa_status st = PA_SUCCESS;
  const pa__sf *sf = op->sf;
  unsigned char *d = data;
  size_t u = op->unit;
  PA_CALL_MPI(MPI_Waitall(sf->nrootrank + sf->nleafrank, op->req,
                          MPI_STATUSES_IGNORE));
  op->active = 0;
  for (pa_idx j = 0; j < sf->leafoff[sf->nleafrank]; j++)
    memcpy(d + u * (size_t)sf->leafidx[j], op->leafbuf + u * (size_t)j, u);
cleanup:
  return st;
}

pa_status pa__sf_reduce_begin(pa__sfop *op, const void *data) {
  pa_status st = PA_SUCCESS;
  const pa__sf *sf = op->sf;
  const unsigned char *d = data;
  size_t u = op->unit;
  MPI_Datatype t = MPI_DATATYPE_NULL;
  int k = 0;
  op_start(op, 2);
  PA_CALL(unit_type(u, &t));
  for (int r = 0; r < sf->nrootrank; r++)
    PA_CALL_MPI(MPI_Irecv(op->rootbuf + u * (size_t)sf->rootoff[r],
                          (int)(sf->rootoff[r + 1] - sf->rootoff[r]), t,
                          sf->rootrank[r], op->tag, sf->comm, &op->req[k++]));
  for (int r = 0; r < sf->nleafrank; r++) {
    for (pa_idx j = sf->leafoff[r]; j < sf->leafoff[r + 1]; j++)
      memcpy(op->leafbuf + u * (size_t)j, d + u * (size_t)sf->leafidx[j], u);
    PA_CALL_MPI(MPI_Isend(op->leafbuf + u * (size_t)sf->leafoff[r],
                          (int)(sf->leafoff[r + 1] - sf->leafoff[r]), t,
                          sf->leafrank[r], op->tag, sf->comm, &op->req[k++]));
  }
  PA_CALL_MPI(MPI_Type_free(&t));
cleanup:
  if (t != MPI_DATATYPE_NULL) (void)MPI_Type_free(&t); /* on an error */
  return st;
}

/* Combine with an MPI operation (see reduce_end). A combining function
 * returns nothing: the first error of MPI_Reduce_local waits in err for
 * pa__sf_reduce_end to report it. */
typedef struct mpi_combine {
  MPI_Datatype type;
  int count;
  MPI_Op op;
  int err; /* the first MPI error code, MPI_SUCCESS if none */
} mpi_combine;

static void combine_mpi(const void *in, void *inout, pa_idx n, void *ctx) {
  mpi_combine *c = ctx;
  int e = MPI_Reduce_local(in, inout, c->count * (int)n, c->type, c->op);
  if (e != MPI_SUCCESS && c->err == MPI_SUCCESS) c->err = e;
}

pa_status pa__sf_reduce_end(pa__sfop *op, void *data, MPI_Datatype type,
                            int count, MPI_Op mop) {
  pa_status st = PA_SUCCESS;
  mpi_combine c = {type, count, mop, MPI_SUCCESS};
  PA_CALL(pa__sf_reduce_end_fn(op, data, combine_mpi, &c));
  if (c.err != MPI_SUCCESS)
    st = pa__mpi_error(c.err, "MPI_Reduce_local", __FILE__, __LINE__);
cleanup:
  return st;
}

pa_status pa__sf_reduce_end_fn(pa__sfop *op, void *data, pa__combine_fn fn,
                               void *ctx) {
  pa_status st = PA_SUCCESS;
  const pa__sf *sf = op->sf;
  unsigned char *d = data;
  size_t u = op->unit;
  PA_CALL_MPI(MPI_Waitall(sf->nrootrank + sf->nleafrank, op->req,
                          MPI_STATUSES_IGNORE));
  op->active = 0;
  /* Ranks in increasing order, so the result does not depend on timing. A
   * rank's block lists each root once: gather the roots, combine the block
   * in one call, scatter back. */
  for (int r = 0; r < sf->nrootrank; r++) {
    pa_idx j0 = sf->rootoff[r], n = sf->rootoff[r + 1] - j0;
    unsigned char *in = op->rootbuf + u * (size_t)j0;
    for (pa_idx j = 0; j < n; j++)
      memcpy(op->scratch + u * (size_t)j, d + u * (size_t)sf->rootidx[j0 + j], u);
    fn(in, op->scratch, n, ctx);
    for (pa_idx j = 0; j < n; j++)
      memcpy(d + u * (size_t)sf->rootidx[j0 + j], op->scratch + u * (size_t)j, u);
  }
cleanup:
  return st;
}
