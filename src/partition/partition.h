/*
 * partition.h -- graph partitioning: the only component that includes
 * PT-Scotch. It partitions a distributed graph given in CSR form and remaps
 * parts to ranks; building the graph (the mesh's dual graph) is dmesh's job.
 */
#ifndef PA_PARTITION_H
#define PA_PARTITION_H

#include "core/core.h"

#include <mpi.h>

/* Graphs of at most this many vertices (over all ranks) are partitioned
 * with Scotch's SPEED strategy, larger ones with its default strategy. */
#define PA_PARTITION_SPEED_MAX 50000
/* The load imbalance Scotch tolerates by default. */
#define PA_PARTITION_KBAL 0.05

/* Collective: partition a distributed graph into nparts parts with
 * PT-Scotch (SCOTCH_dgraphPart; the SPEED strategy up to
 * PA_PARTITION_SPEED_MAX vertices, else the default one). Rank r holds n vertices
 * numbered offset(r) + i globally (offsets: exclusive scan of n); the
 * neighbours of local vertex i are adj[xadj[i] .. xadj[i+1]-1] (global
 * numbers, symmetric graph, no self loop). weights: per vertex (> 0) or NULL.
 * kbal > 0: the load imbalance tolerated, else PA_PARTITION_KBAL.
 * part[i] receives the part of local vertex i in [0, nparts). Fails with
 * PA_ERR_PARTITION if Scotch does, PA_ERR_ARG if the graph has 2^31 vertices
 * or more (SCOTCH_Num is 32-bit). */
pa_status pa__partition_dgraph(MPI_Comm comm, pa_idx n, const pa_idx *xadj,
                               const int64_t *adj, const double *weights,
                               int nparts, double kbal, int *part);

/* Collective: map parts to ranks (nparts == number of ranks) so that the
 * weight kept in place is large: greedy on the part x rank matrix of weights
 * (heaviest pair first). On return part[i] is the destination rank. */
pa_status pa__partition_remap(MPI_Comm comm, pa_idx n, int *part,
                              const double *weights);

/* Local: Scotch ordering (SCOTCH_graphOrder, Gibbs-Poole-Stockmeyer
 * strategy "g": bandwidth reduction, for locality) of a sequential graph of n vertices in CSR form (0-based,
 * symmetric, no self loop). perm[k] receives the old vertex placed at new
 * position k. Fails with PA_ERR_PARTITION if Scotch does. */
pa_status pa__order_graph(pa_idx n, const pa_idx *xadj, const pa_idx *adj,
                          pa_idx *perm);

#endif /* PA_PARTITION_H */
