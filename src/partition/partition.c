/*
 * partition.c -- PT-Scotch partitioning of a distributed graph and the
 * remapping of parts to ranks. Only this file includes PT-Scotch.
 *
 * Invariants: Scotch sees 0-based (baseval 0) 32-bit SCOTCH_Num arrays copied
 * from the caller's CSR; integer vertex loads are the caller's weights scaled
 * to [1, S] with S = min(10^6, 2^30 / global vertex count), so that the sum
 * of the loads, which Scotch keeps in a SCOTCH_Num, cannot overflow (it did
 * with S = 10^6: 2:1 weights on 1.3 M elements gave a 1.96 imbalance); every
 * collective step agrees on the status first (one MPI_Allreduce), so a
 * failure on one rank never leaves another waiting.
 */
#include "partition/partition.h"

#include <limits.h>
#include <math.h>
#include <stdio.h>
/* PT-Scotch needs these before its header. */
#include <mpi.h>
#include <stdint.h>
#include <string.h>
#include <scotch/ptscotch.h>

/* A Scotch context whose threads and random generator behave the same on
 * every run (0 on success; SCOTCH_contextExit it then). */
static int deterministic_context(SCOTCH_Context *ctx) {
  if (SCOTCH_contextInit(ctx) != 0) return 1;
  if (SCOTCH_contextOptionSetNum(ctx, SCOTCH_OPTIONNUMDETERMINISTIC, 1) != 0 ||
      SCOTCH_contextOptionSetNum(ctx, SCOTCH_OPTIONNUMRANDOMFIXEDSEED, 1) != 0) {
    SCOTCH_contextExit(ctx);
    return 1;
  }
  return 0;
}

/* The Scotch objects of one partitioning, and which are initialised. */
typedef struct scotch_run {
  SCOTCH_Num *vert, *edge, *velo, *parttab;
  SCOTCH_Dgraph graph, bound;
  SCOTCH_Strat strat;
  SCOTCH_Context ctx;
  int64_t nglob; /* vertices over all ranks */
  int graph_init, strat_init, ctx_init, bound_init;
} scotch_run;

static void scotch_run_free(scotch_run *s) {
  if (s->bound_init) SCOTCH_dgraphExit(&s->bound);
  if (s->ctx_init) SCOTCH_contextExit(&s->ctx);
  if (s->strat_init) SCOTCH_stratExit(&s->strat);
  if (s->graph_init) SCOTCH_dgraphExit(&s->graph);
  pa__free(s->vert);
  pa__free(s->edge);
  pa__free(s->velo);
  pa__free(s->parttab);
}

/* Check the arguments and copy the graph into Scotch's integers, with the
 * weights scaled to integers; the result is not agreed on (the caller
 * does). */
static pa_status copy_graph(MPI_Comm comm, pa_idx n, const pa_idx *xadj,
                            const int64_t *adj, const double *weights,
                            int nparts, scotch_run *s) {
  pa_status st = PA_SUCCESS;
  int64_t nglob = n, wmax_ok = 1;
  double wmax = 0;
  if (weights)
    for (pa_idx i = 0; i < n; i++) {
      if (!(weights[i] > 0) || !isfinite(weights[i])) wmax_ok = 0;
      if (weights[i] > wmax) wmax = weights[i];
    }
  /* The only collectives before the agreement: every rank reaches them. */
  MPI_Allreduce(MPI_IN_PLACE, &nglob, 1, MPI_INT64_T, MPI_SUM, comm);
  MPI_Allreduce(MPI_IN_PLACE, &wmax, 1, MPI_DOUBLE, MPI_MAX, comm);
  PA_CHECK(nglob < INT32_MAX, PA_ERR_ARG,
           "graph of %lld vertices: PT-Scotch is built with 32-bit integers",
           (long long)nglob);
  PA_CHECK(nparts >= 1, PA_ERR_ARG, "nparts must be >= 1, got %d", nparts);
  PA_CHECK(wmax_ok, PA_ERR_ARG, "element weights must be finite and > 0");
  s->nglob = nglob;
  PA_ALLOC(s->vert, n + 1);
  PA_ALLOC(s->edge, xadj[n]);
  PA_ALLOC(s->parttab, n);
  for (pa_idx i = 0; i <= n; i++) s->vert[i] = xadj[i];
  for (pa_idx j = 0; j < xadj[n]; j++) s->edge[j] = (SCOTCH_Num)adj[j];
  if (weights) {
    double scale = (double)(1 << 30) / (double)(nglob ? nglob : 1);
    if (scale > 1e6) scale = 1e6;
    PA_ALLOC(s->velo, n);
    for (pa_idx i = 0; i < n; i++) {
      double w = weights[i] / wmax * scale;
      s->velo[i] = w < 1 ? 1 : (SCOTCH_Num)w;
    }
  }
cleanup:
  return st;
}

/* Build (and in debug builds check) Scotch's distributed graph; collective,
 * agreed. */
static pa_status build_graph(MPI_Comm comm, scotch_run *s, pa_idx n,
                             const pa_idx *xadj) {
  pa_status st = PA_SUCCESS;
  if (SCOTCH_dgraphInit(&s->graph, comm) != 0)
    st = pa__error(PA_ERR_PARTITION, __FILE__, __LINE__,
                   "SCOTCH_dgraphInit failed");
  else
    s->graph_init = 1;
  st = pa__agree(comm, st);
  if (st) return st;
  if (SCOTCH_dgraphBuild(&s->graph, 0, n, n, s->vert, NULL, s->velo, NULL,
                         xadj[n], xadj[n], s->edge, NULL, NULL) != 0)
    st = pa__error(PA_ERR_PARTITION, __FILE__, __LINE__,
                   "SCOTCH_dgraphBuild failed on a graph of %d local vertices",
                   (int)n);
  st = pa__agree(comm, st);
  if (st) return st;
#ifndef NDEBUG
  if (SCOTCH_dgraphCheck(&s->graph) != 0)
    st = pa__error(PA_ERR_INTERNAL, __FILE__, __LINE__,
                   "SCOTCH_dgraphCheck: the dual graph is inconsistent");
  st = pa__agree(comm, st);
#endif
  return st;
}

/* The partitioning strategy; collective, agreed. On large graphs Scotch's
 * default: no strategy of SCOTCH_stratDgraphMapBuild (SPEED / QUALITY /
 * BALANCE) is faster on 2+ ranks, and BALANCE buys little balance with more
 * edge cut (figures: docs/BENCHMARKS.md, "The distributed mesh",
 * bench/bench_scotch.c). Up to
 * PA_PARTITION_SPEED_MAX vertices, SPEED: half the instructions on a
 * 6 000-vertex graph, the same adapted meshes' quality (figures:
 * docs/BENCHMARKS.md, "Small jobs on two ranks"). kbal > 0 asks for that
 * imbalance, else Scotch's default one. */
static pa_status make_strategy(MPI_Comm comm, scotch_run *s, int nparts,
                               double kbal) {
  pa_status st = PA_SUCCESS;
  SCOTCH_stratInit(&s->strat);
  s->strat_init = 1;
  int speed = s->nglob <= PA_PARTITION_SPEED_MAX;
  if (kbal > 0 || speed) {
    int size;
    MPI_Comm_size(comm, &size);
    if (SCOTCH_stratDgraphMapBuild(&s->strat,
                                   speed ? SCOTCH_STRATSPEED : SCOTCH_STRATDEFAULT,
                                   size, nparts,
                                   kbal > 0 ? kbal : PA_PARTITION_KBAL) != 0)
      st = pa__error(PA_ERR_PARTITION, __FILE__, __LINE__,
                     "SCOTCH_stratDgraphMapBuild failed");
    st = pa__agree(comm, st);
  }
  return st;
}

/* Bind the graph to a deterministic context; collective, agreed. The same
 * graph always gets the same partition: Scotch's random state persists
 * across calls in a process (reset it), and its threads
 * (SCOTCH_PTHREAD_NUMBER, all cores by default) race unless the context
 * bound to the graph asks for deterministic behaviour (without it, three
 * np=4 runs of the gmsh rod gave three different meshes). */
static pa_status bind_deterministic(MPI_Comm comm, scotch_run *s) {
  pa_status st = PA_SUCCESS;
  SCOTCH_randomReset();
  if (deterministic_context(&s->ctx) != 0)
    st = pa__error(PA_ERR_PARTITION, __FILE__, __LINE__,
                   "SCOTCH_contextInit failed");
  else
    s->ctx_init = 1;
  if (!st && SCOTCH_dgraphInit(&s->bound, comm) != 0)
    st = pa__error(PA_ERR_PARTITION, __FILE__, __LINE__,
                   "SCOTCH_dgraphInit failed");
  else if (!st)
    s->bound_init = 1;
  if (!st && SCOTCH_contextBindDgraph(&s->ctx, &s->graph, &s->bound) != 0)
    st = pa__error(PA_ERR_PARTITION, __FILE__, __LINE__,
                   "SCOTCH_contextBindDgraph failed");
  return pa__agree(comm, st);
}

pa_status pa__partition_dgraph(MPI_Comm comm, pa_idx n, const pa_idx *xadj,
                               const int64_t *adj, const double *weights,
                               int nparts, double kbal, int *part) {
  pa_status st = PA_SUCCESS;
  scotch_run s;
  memset(&s, 0, sizeof s);
  st = copy_graph(comm, n, xadj, adj, weights, nparts, &s);
  st = pa__agree(comm, st);
  if (st) goto done;
  if (nparts == 1) {
    for (pa_idx i = 0; i < n; i++) part[i] = 0;
    goto done;
  }
  if ((st = build_graph(comm, &s, n, xadj))) goto done;
  if ((st = make_strategy(comm, &s, nparts, kbal))) goto done;
  if ((st = bind_deterministic(comm, &s))) goto done;
  if (SCOTCH_dgraphPart(&s.bound, nparts, &s.strat, s.parttab) != 0)
    st = pa__error(PA_ERR_PARTITION, __FILE__, __LINE__,
                   "SCOTCH_dgraphPart failed (%d parts)", nparts);
  st = pa__agree(comm, st);
  if (st) goto done;
  for (pa_idx i = 0; i < n; i++) part[i] = (int)s.parttab[i];
done:
  scotch_run_free(&s);
  return st;
}

typedef struct cell {
  double w;
  int p, r;
} cell;

static int cell_cmp(const void *a, const void *b) {
  const cell *x = a, *y = b;
  if (x->w != y->w) return x->w > y->w ? -1 : 1;
  if (x->p != y->p) return x->p - y->p;
  return x->r - y->r;
}

pa_status pa__partition_remap(MPI_Comm comm, pa_idx n, int *part,
                              const double *weights) {
  pa_status st = PA_SUCCESS;
  int size;
  double *mine = NULL, *all = NULL;
  cell *c = NULL;
  int *map = NULL, *used = NULL;
  MPI_Comm_size(comm, &size);
  PA_CALLOC(mine, size);
  PA_ALLOC(all, (size_t)size * size);
  PA_ALLOC(c, (size_t)size * size);
  PA_ALLOC(map, size);
  PA_CALLOC(used, size);
  for (pa_idx i = 0; i < n; i++) {
    PA_CHECK(part[i] >= 0 && part[i] < size, PA_ERR_ARG,
             "part %d of element %d out of [0, %d)", part[i], (int)i, size);
    mine[part[i]] += weights ? weights[i] : 1.0;
  }
cleanup:
  st = pa__agree(comm, st);
  if (st) goto done;
  /* all[r * size + p]: weight of part p currently on rank r. */
  MPI_Allgather(mine, size, MPI_DOUBLE, all, size, MPI_DOUBLE, comm);
  for (int r = 0; r < size; r++)
    for (int p = 0; p < size; p++)
      c[(size_t)r * size + p] = (cell){all[(size_t)r * size + p], p, r};
  qsort(c, (size_t)size * size, sizeof *c, cell_cmp);
  for (int p = 0; p < size; p++) map[p] = -1;
  for (size_t k = 0; k < (size_t)size * size; k++)
    if (c[k].w > 0 && map[c[k].p] < 0 && !used[c[k].r]) {
      map[c[k].p] = c[k].r;
      used[c[k].r] = 1;
    }
  for (int p = 0, r = 0; p < size; p++)
    if (map[p] < 0) {
      while (used[r]) r++;
      map[p] = r;
      used[r] = 1;
    }
  for (pa_idx i = 0; i < n; i++) part[i] = map[part[i]];
done:
  pa__free(mine);
  pa__free(all);
  pa__free(c);
  pa__free(map);
  pa__free(used);
  return st;
}

pa_status pa__order_graph(pa_idx n, const pa_idx *xadj, const pa_idx *adj,
                          pa_idx *perm) {
  pa_status st = PA_SUCCESS;
  SCOTCH_Num *vert = NULL, *edge = NULL, *permtab = NULL, *peritab = NULL;
  SCOTCH_Graph graph, bound;
  SCOTCH_Strat strat;
  SCOTCH_Context ctx;
  int graph_init = 0, strat_init = 0, ctx_init = 0, bound_init = 0;
  if (n <= 1) {
    for (pa_idx i = 0; i < n; i++) perm[i] = i;
    return PA_SUCCESS;
  }
  PA_ALLOC(vert, n + 1);
  PA_ALLOC(edge, xadj[n]);
  PA_ALLOC(permtab, n);
  PA_ALLOC(peritab, n);
  for (pa_idx i = 0; i <= n; i++) vert[i] = xadj[i];
  for (pa_idx j = 0; j < xadj[n]; j++) edge[j] = adj[j];
  PA_CHECK(SCOTCH_graphInit(&graph) == 0, PA_ERR_PARTITION,
           "SCOTCH_graphInit failed");
  graph_init = 1;
  PA_CHECK(SCOTCH_graphBuild(&graph, 0, n, vert, NULL, NULL, NULL, xadj[n],
                             edge, NULL) == 0,
           PA_ERR_PARTITION, "SCOTCH_graphBuild failed (%d vertices)", (int)n);
  PA_CHECK(SCOTCH_stratInit(&strat) == 0, PA_ERR_PARTITION,
           "SCOTCH_stratInit failed");
  strat_init = 1;
  /* Gibbs-Poole-Stockmeyer: a bandwidth-reducing ordering in linear time,
   * what locality needs; Scotch's default nested dissection (for sparse
   * factorisation) is far slower for a similar locality (figures:
   * docs/BENCHMARKS.md, "The distributed mesh") */
  PA_CHECK(SCOTCH_stratGraphOrder(&strat, "g") == 0, PA_ERR_PARTITION,
           "SCOTCH_stratGraphOrder failed");
  SCOTCH_randomReset(); /* reproducible, as the partitions */
  PA_CHECK(deterministic_context(&ctx) == 0, PA_ERR_PARTITION,
           "SCOTCH_contextInit failed");
  ctx_init = 1;
  PA_CHECK(SCOTCH_graphInit(&bound) == 0, PA_ERR_PARTITION,
           "SCOTCH_graphInit failed");
  bound_init = 1;
  PA_CHECK(SCOTCH_contextBindGraph(&ctx, &graph, &bound) == 0,
           PA_ERR_PARTITION, "SCOTCH_contextBindGraph failed");
  PA_CHECK(SCOTCH_graphOrder(&bound, &strat, permtab, peritab, NULL, NULL,
                             NULL) == 0,
           PA_ERR_PARTITION, "SCOTCH_graphOrder failed (%d vertices)", (int)n);
  for (pa_idx k = 0; k < n; k++) perm[k] = (pa_idx)peritab[k];
cleanup:
  if (bound_init) SCOTCH_graphExit(&bound);
  if (ctx_init) SCOTCH_contextExit(&ctx);
  if (strat_init) SCOTCH_stratExit(&strat);
  if (graph_init) SCOTCH_graphExit(&graph);
  pa__free(vert);
  pa__free(edge);
  pa__free(permtab);
  pa__free(peritab);
  return st;
}
