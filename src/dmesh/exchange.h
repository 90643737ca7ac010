/*
 * exchange.h -- the exchange layer: every point-to-point MPI message of padapt
 * goes through the functions declared here (src/dmesh/exchange.c is the only
 * file that calls MPI_Isend/MPI_Irecv/MPI_Send/MPI_Recv).
 *
 * Three services:
 *
 *  1. Agreement (pa__agree, defined in core/agree.c so that the partitioner
 *     below this layer shares it). pa__agree() is the one synchronisation
 *     point of collective routines: every rank passes its local status,
 *     every rank gets back the
 *     status (and the message) of the lowest failing rank. A rank that fails
 *     locally jumps to its cleanup label and calls pa__agree_end(), which
 *     matches the pa__agree() the other ranks are blocked in; so no rank is
 *     ever left waiting. Rule for collective code: every collective MPI call
 *     is preceded by a pa__agree() (the helpers below do it themselves).
 *
 *  2. A star forest (pa__sf), modelled on PETSc's PetscSF: roots are owned
 *     entities, leaves are their ghost copies on other ranks. For every
 *     neighbour rank the root side lists its root indices and the leaf side
 *     its leaf indices in the same order, so no remote index is ever stored.
 *     Broadcast (root -> leaves) and reduction (leaves -> root with an MPI_Op)
 *     are split in begin/end so that work overlaps communication. An operation
 *     (pa__sfop) owns its buffers, allocated once: begin/end never allocate and
 *     cannot fail locally, hence need no agreement.
 *
 *  3. Setup traffic: a sparse all-to-all of byte buffers of any size
 *     (pa__xchg_sparse, counts exchanged with MPI_Alltoall, data with
 *     Isend/Irecv in chunks below 2^30 bytes), and a blocking transfer of one
 *     byte buffer between two ranks (root scatter/gather with one part in
 *     flight).
 */
#ifndef PA_EXCHANGE_H
#define PA_EXCHANGE_H

#include "core/core.h"

#include <mpi.h>

/* ---- agreement ---- */

/* pa__agree, pa__agree_end, pa__agree_reset: core/core.h (agree.c). */

/* Agreeing Allreduce (sum/min/max of n values of type t). */
pa_status pa__allreduce(MPI_Comm comm, void *buf, int n, MPI_Datatype t,
                        MPI_Op op);

/* ---- star forest ---- */

typedef struct pa__sf {
  MPI_Comm comm;
  /* root side: ranks holding leaves of my roots, and per rank my root indices */
  int nrootrank;
  int *rootrank;    /* nrootrank */
  pa_idx *rootoff;  /* nrootrank + 1 */
  pa_idx *rootidx;  /* rootoff[nrootrank] */
  /* leaf side: ranks owning my leaves, and per rank my leaf indices */
  int nleafrank;
  int *leafrank;    /* nleafrank */
  pa_idx *leafoff;  /* nleafrank + 1 */
  pa_idx *leafidx;  /* leafoff[nleafrank] */
} pa__sf;

/* One in-flight operation on an sf for one data layout (unit bytes per
 * index). Buffers are allocated by pa__sfop_init and reused. */
typedef struct pa__sfop {
  const pa__sf *sf;
  size_t unit;
  int tag;
  int active;         /* 0 idle, 1 bcast in flight, 2 reduce in flight */
  unsigned char *rootbuf; /* unit * rootoff[nrootrank] */
  unsigned char *leafbuf; /* unit * leafoff[nleafrank] */
  unsigned char *scratch; /* unit * largest root block (reductions) */
  MPI_Request *req;       /* nrootrank + nleafrank */
} pa__sfop;

/* Collective: build the sf of an entity kind from the owner rank and the
 * global id of every local entity (n entities, ghosts are those with
 * owner != my rank). The owners resolve the requested gids against their
 * owned entities (the first one with a gid wins). Fails with PA_ERR_MESH if
 * an owner does not own a requested gid. */
pa_status pa__sf_build(MPI_Comm comm, pa_idx n, const pa_gid *gid,
                       const int *owner, pa__sf *sf);
/* Restrict an sf to the indices with slot[i] >= 0 and renumber them to slots.
 * Local: both sides must apply the same filter (e.g. an entity reference,
 * equal on owner and ghost). */
pa_status pa__sf_restrict(const pa__sf *sf, const pa_idx *slot, pa__sf *out);
void pa__sf_free(pa__sf *sf);
size_t pa__sf_memory(const pa__sf *sf);

pa_status pa__sfop_init(pa__sfop *op, const pa__sf *sf, size_t unit, int tag);
void pa__sfop_free(pa__sfop *op);
/* Broadcast root values to leaves: data[i*unit] for every root/leaf index i
 * (roots and leaves live in the same array, as owned and ghost entities do).
 * These four fail only when MPI does (PA_ERR_MPI naming the call); an
 * operation that failed half-way is still ended by pa__sfop_free. */
pa_status pa__sf_bcast_begin(pa__sfop *op, const void *data);
pa_status pa__sf_bcast_end(pa__sfop *op, void *data);
/* Reduce leaf values onto roots: root = op(root, leaf) for each leaf, with
 * count items of the predefined datatype type per index. */
pa_status pa__sf_reduce_begin(pa__sfop *op, const void *data);
pa_status pa__sf_reduce_end(pa__sfop *op, void *data, MPI_Datatype type,
                            int count, MPI_Op mop);
/* The same with a combining function instead of an MPI operation:
 * fn(in, inout, n, ctx) combines n leaf values into n root values (each of
 * the op's unit bytes), for operations MPI has no name for (e.g. the
 * intersection of metric tensors). Ranks are combined in increasing order. */
typedef void (*pa__combine_fn)(const void *in, void *inout, pa_idx n, void *ctx);
pa_status pa__sf_reduce_end_fn(pa__sfop *op, void *data, pa__combine_fn fn,
                               void *ctx);

/* ---- setup traffic ---- */

/* Collective (agrees first): rank r sends sendcount[s] bytes starting at
 * sendbuf + sum(sendcount[0..s-1]) to every rank s. On return *recvcount
 * (size ranks, allocated) holds the byte counts received from each rank and
 * *recvbuf (allocated) the data, by source rank. */
pa_status pa__xchg_sparse(MPI_Comm comm, const size_t *sendcount,
                          const void *sendbuf, size_t **recvcount,
                          void **recvbuf);

/* Point to point, blocking: send n bytes to rank dest / receive a buffer
 * (allocated, size in *n) from rank src. Not agreed: callers pair them. */
pa_status pa__xchg_send(MPI_Comm comm, int dest, const void *buf, size_t n);
pa_status pa__xchg_recv(MPI_Comm comm, int src, void **buf, size_t *n);

#endif /* PA_EXCHANGE_H */
