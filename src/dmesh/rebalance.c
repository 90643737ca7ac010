/*
 * rebalance.c -- pa_dmesh_rebalance: even out the owned elements (or their
 * weights) over the ranks by moving only the excess across the existing
 * interfaces, instead of repartitioning the whole mesh.
 *
 *  1. Every rank learns the load of every rank and which ranks share faces
 *     (from the distributed dual graph of the owned elements, which needs
 *     no ghosts): allgathers of P loads and of the neighbour lists.
 *  2. Every rank solves, identically (same data, same operations), L x = b
 *     on that graph of ranks, L its Laplacian and b the load minus the mean
 *     (conjugate gradients, P unknowns). The flow from rank r to a neighbour
 *     s is x_r - x_s: the diffusion solution of minimal Euclidean norm (Hu
 *     and Blake, 1999), which moves the excess along the shortest routes.
 *  3. Rank r gives each neighbour s with a positive flow that much load of
 *     its own elements, grown greedily from the faces it shares with s: the
 *     element with the most faces on s's side first (a compact band, a low
 *     cut), and pa_dmesh_redistribute moves them. Flows through a rank
 *     (r -> s -> t) are served by s's own elements, so one redistribution
 *     does it.
 * Falls back to a PT-Scotch repartition (pa_dmesh_redistribute(dm, NULL, w))
 * when a rank holds more than 1.5 times the mean (RB_DIFFUSE_MAX), the
 * graph of ranks is disconnected, or the predicted loads still exceed
 * tol x mean (a flow larger than what is reachable from an interface).
 */
#include "dmesh/dmesh.h"

#include <math.h>

/* Above this load over the mean, a fresh partition: moving that much as
 * bands along the interfaces (up to half a rank's elements at 1.5) grows
 * the cut by 1.4-2 times in the tests, where PT-Scotch's is lower. */
#define RB_DIFFUSE_MAX 1.5

/* Load of owned element e. */
static double elem_load(const double *w, pa_idx e) { return w ? w[e] : 1.0; }

/* y = L x on the graph of ranks (CSR xadj/adj, unit edge weights). */
static void laplacian(int P, const int *xadj, const int *adj, const double *x,
                      double *y) {
  for (int r = 0; r < P; r++) {
    double s = (double)(xadj[r + 1] - xadj[r]) * x[r];
    for (int k = xadj[r]; k < xadj[r + 1]; k++) s -= x[adj[k]];
    y[r] = s;
  }
}

/* Solve L x = b (b sums to zero, the graph is connected) by conjugate
 * gradients; x has zero mean. Deterministic: every rank gets the same x. */
static pa_status diffusion(int P, const int *xadj, const int *adj,
                           const double *b, double *x) {
  pa_status st = PA_SUCCESS;
  double *r = NULL, *p = NULL, *q = NULL;
  PA_ALLOC(r, P);
  PA_ALLOC(p, P);
  PA_ALLOC(q, P);
  double bb = 0, rr = 0;
  for (int i = 0; i < P; i++) {
    x[i] = 0;
    r[i] = p[i] = b[i];
    bb += b[i] * b[i];
  }
  rr = bb;
  for (int it = 0; it < 10 * P + 10 && rr > 1e-24 * bb; it++) {
    laplacian(P, xadj, adj, p, q);
    double pq = 0;
    for (int i = 0; i < P; i++) pq += p[i] * q[i];
    if (!(pq > 0)) break;
    double a = rr / pq, rn = 0;
    for (int i = 0; i < P; i++) {
      x[i] += a * p[i];
      r[i] -= a * q[i];
      rn += r[i] * r[i];
    }
    for (int i = 0; i < P; i++) p[i] = r[i] + rn / rr * p[i];
    rr = rn;
  }
cleanup:
  pa__free(r);
  pa__free(p);
  pa__free(q);
  return st;
}

/* The graph of ranks: s is a neighbour of r if an owned element of r has a
 * face neighbour owned by s (eadjrank: the owner of each face neighbour in
 * the distributed dual graph exadj), which is symmetric: every rank's own
 * list, gathered, is its row. CSR over all P ranks, neighbours ascending. */
static pa_status rank_graph(pa_dmesh *dm, const pa_idx *exadj,
                            const int *eadjrank, int **xadjp, int **adjp) {
  pa_status st = PA_SUCCESS;
  int P = dm->size, nmine = 0;
  uint8_t *nbr = NULL;
  int *mine = NULL, *deg = NULL, *xadj = NULL, *adj = NULL;
  PA_CALLOC(nbr, P);
  for (pa_idx k = 0; k < exadj[dm->nown[PA_ELEMENT]]; k++) nbr[eadjrank[k]] = 1;
  PA_ALLOC(mine, P);
  for (int s = 0; s < P; s++)
    if (nbr[s] && s != dm->rank) mine[nmine++] = s;
  PA_ALLOC(deg, P);
  PA_ALLOC(xadj, P + 1);
  PA_CALL(pa__agree(dm->comm, st));
  MPI_Allgather(&nmine, 1, MPI_INT, deg, 1, MPI_INT, dm->comm);
  xadj[0] = 0;
  for (int r = 0; r < P; r++) xadj[r + 1] = xadj[r] + deg[r];
  PA_ALLOC(adj, xadj[P] ? xadj[P] : 1);
  MPI_Allgatherv(mine, nmine, MPI_INT, adj, deg, xadj, MPI_INT, dm->comm);
  *xadjp = xadj;
  *adjp = adj;
  xadj = adj = NULL;
cleanup:
  pa__free(nbr);
  pa__free(mine);
  pa__free(deg);
  pa__free(xadj);
  pa__free(adj);
  return st;
}

/* Is the graph of ranks connected? */
static int connected(int P, const int *xadj, const int *adj, int *queue,
                     uint8_t *seen) {
  int head = 0, tail = 0;
  memset(seen, 0, (size_t)P);
  queue[tail++] = 0;
  seen[0] = 1;
  while (head < tail) {
    int r = queue[head++];
    for (int k = xadj[r]; k < xadj[r + 1]; k++)
      if (!seen[adj[k]]) {
        seen[adj[k]] = 1;
        queue[tail++] = adj[k];
      }
  }
  return tail == P;
}

/* Max-heap of keys gain << 32 | (UINT32_MAX - e): the largest gain first,
 * then the lowest element index. */
static uint64_t gain_key(int gain, pa_idx e) {
  return (uint64_t)gain << 32 | (uint64_t)(UINT32_MAX - (uint32_t)e);
}

static void heap_push(uint64_t *h, size_t *n, uint64_t key) {
  size_t i = (*n)++;
  while (i > 0 && h[(i - 1) / 2] < key) {
    h[i] = h[(i - 1) / 2];
    i = (i - 1) / 2;
  }
  h[i] = key;
}

static uint64_t heap_pop(uint64_t *h, size_t *n) {
  uint64_t top = h[0], last = h[--*n];
  size_t i = 0;
  for (;;) {
    size_t c = 2 * i + 1;
    if (c >= *n) break;
    if (c + 1 < *n && h[c + 1] > h[c]) c++;
    if (h[c] <= last) break;
    h[i] = h[c];
    i = c;
  }
  h[i] = last;
  return top;
}

/* What the phases of pa_dmesh_rebalance share: the load of every rank
 * (load; mean, largest mx), the owned elements' dual graph (exadj/eadj:
 * face neighbours as global graph vertices, eadjrank their owners, eoff
 * this rank's first graph vertex), the graph of ranks (xadj/adj), the
 * diffusion solution x (the flow from r to s is x[r] - x[s]), the new
 * owner of each owned element (part) and the load each rank gains by it
 * (delta). */
typedef struct rebal {
  pa_dmesh *dm;
  const double *weights;
  int P;
  pa_idx ne;
  double *load, mean, mx;
  pa_idx *exadj;
  pa_gid *eadj, eoff;
  int *eadjrank, *xadj, *adj, *part;
  double *x, *delta;
} rebal;

/* The load of every rank, their mean and the largest. */
static pa_status rank_loads(rebal *c) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = c->dm;
  PA_CALLOC(c->load, c->P);
  for (pa_idx e = 0; e < c->ne; e++) c->load[dm->rank] += elem_load(c->weights, e);
  PA_CALL(pa__allreduce(dm->comm, c->load, c->P, MPI_DOUBLE, MPI_SUM));
  c->mean = c->mx = 0;
  for (int r = 0; r < c->P; r++) {
    c->mean += c->load[r] / c->P;
    c->mx = fmax(c->mx, c->load[r]);
  }
cleanup:
  return st;
}

/* The owned elements' dual graph: face neighbours with their owner,
 * whatever the overlap. */
static pa_status owned_dual_graph(rebal *c) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = c->dm;
  int d = dm->dim;
  pa_gid *vg = NULL;
  PA_ALLOC(vg, (size_t)c->ne * (d + 1) + 1);
  for (size_t k = 0; k < (size_t)c->ne * (d + 1); k++)
    vg[k] = dm->gid[PA_VERTEX][dm->mesh->elem[k]];
  PA_CALL(pa__agree(dm->comm, st));
  PA_CALL(pa__dual_graph(dm->comm, d, c->ne, vg, dm->mesh->elem, dm->mesh->nv,
                         &c->exadj, &c->eadj, &c->eadjrank, &c->eoff));
cleanup:
  pa__free(vg);
  return st;
}

/* *ok = 1 if the graph of ranks is connected (the same on every rank). */
static pa_status ranks_connected(rebal *c, int *ok) {
  pa_status st = PA_SUCCESS;
  int *queue = NULL;
  uint8_t *seen = NULL;
  PA_ALLOC(queue, c->P);
  PA_ALLOC(seen, c->P);
  *ok = connected(c->P, c->xadj, c->adj, queue, seen);
cleanup:
  pa__free(queue);
  pa__free(seen);
  return st;
}

/* Step 2: the diffusion solution x of L x = load - mean. */
static pa_status diffusion_flows(rebal *c) {
  pa_status st = PA_SUCCESS;
  double *b = NULL;
  PA_ALLOC(b, c->P);
  PA_ALLOC(c->x, c->P);
  for (int r = 0; r < c->P; r++) b[r] = c->load[r] - c->mean;
  PA_CALL(diffusion(c->P, c->xadj, c->adj, b, c->x));
cleanup:
  pa__free(b);
  return st;
}

/* Step 3: serve each positive outflow greedily: the element with the most
 * faces on s's side goes first (a lazy max-heap keyed by that gain, then
 * the lowest index), so the band grows compact and the cut stays low. */
static pa_status serve_outflows(rebal *c) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = c->dm;
  pa_idx ne = c->ne;
  const pa_idx *exadj = c->exadj;
  const int *eadjrank = c->eadjrank;
  int *part, *gain = NULL;
  uint64_t *heap = NULL;
  PA_ALLOC(c->part, ne ? ne : 1);
  part = c->part;
  PA_ALLOC(gain, ne ? ne : 1);
  PA_ALLOC(heap, (size_t)ne * (dm->dim + 1) + 1);
  PA_CALLOC(c->delta, c->P);
  for (pa_idx e = 0; e < ne; e++) part[e] = dm->rank;
  for (int k = c->xadj[dm->rank]; k < c->xadj[dm->rank + 1]; k++) {
    int s = c->adj[k];
    double want = c->x[dm->rank] - c->x[s], given = 0;
    if (want <= 0) continue;
    size_t nh = 0;
    for (pa_idx e = 0; e < ne; e++) {
      gain[e] = 0;
      if (part[e] != dm->rank) continue;
      for (pa_idx q = exadj[e]; q < exadj[e + 1]; q++) gain[e] += eadjrank[q] == s;
      if (gain[e]) heap_push(heap, &nh, gain_key(gain[e], e));
    }
    while (nh > 0) {
      uint64_t key = heap_pop(heap, &nh);
      pa_idx e = (pa_idx)(UINT32_MAX - (uint32_t)key);
      if (part[e] != dm->rank || (int)(key >> 32) != gain[e]) continue; /* stale */
      double w = elem_load(c->weights, e);
      if (given + 0.5 * w > want) break;
      part[e] = s;
      given += w;
      for (pa_idx q = exadj[e]; q < exadj[e + 1]; q++) {
        pa_idx f = (pa_idx)(c->eadj[q] - c->eoff); /* local if on this rank */
        if (eadjrank[q] == dm->rank && part[f] == dm->rank)
          heap_push(heap, &nh, gain_key(++gain[f], f));
      }
    }
    c->delta[s] += given;
    c->delta[dm->rank] -= given;
  }
cleanup:
  pa__free(gain);
  pa__free(heap);
  return st;
}

/* *ok = 1 if the loads predicted after the moves are within tol x mean,
 * up to rounding: rounding each flow to whole elements is off by half an
 * element per neighbour; more means the flows could not be served (too
 * few elements reachable from an interface). */
static pa_status flows_served(rebal *c, double tol, int *ok) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = c->dm;
  double after = 0, wmax = 0;
  int maxdeg = 0;
  PA_CALL(pa__allreduce(dm->comm, c->delta, c->P, MPI_DOUBLE, MPI_SUM));
  for (pa_idx e = 0; e < c->ne; e++) wmax = fmax(wmax, elem_load(c->weights, e));
  PA_CALL(pa__allreduce(dm->comm, &wmax, 1, MPI_DOUBLE, MPI_MAX));
  for (int r = 0; r < c->P; r++) {
    after = fmax(after, c->load[r] + c->delta[r]);
    if (c->xadj[r + 1] - c->xadj[r] > maxdeg) maxdeg = c->xadj[r + 1] - c->xadj[r];
  }
  *ok = !(after > tol * c->mean + 0.5 * (maxdeg + 1) * wmax);
cleanup:
  return st;
}

/* Steps 1-3: the new owners of the owned elements (c->part) that serve the
 * diffusion flows. *ok = 0 when they cannot: the graph of ranks is
 * disconnected, or the flows cannot be served. */
static pa_status diffusion_parts(rebal *c, double tol, int *ok) {
  pa_status st = PA_SUCCESS;
  *ok = 0;
  PA_CALL(owned_dual_graph(c));
  PA_CALL(rank_graph(c->dm, c->exadj, c->eadjrank, &c->xadj, &c->adj));
  PA_CALL(ranks_connected(c, ok));
  if (!*ok) goto cleanup;
  PA_CALL(diffusion_flows(c));
  PA_CALL(serve_outflows(c));
  PA_CALL(flows_served(c, tol, ok));
cleanup:
  return st;
}

pa_status pa_dmesh_rebalance(pa_dmesh *dm, const double *weights, double tol,
                             pa_gid *nmoved) {
  pa_status st = PA_SUCCESS;
  pa_gid moved = 0;
  rebal c;
  memset(&c, 0, sizeof c);
  PA_CHECK(dm && tol >= 1.0, PA_ERR_ARG,
           "pa_dmesh_rebalance: NULL dmesh or tolerance below 1");
  pa__agree_reset();
  c.dm = dm;
  c.weights = weights;
  c.P = dm->size;
  c.ne = dm->nown[PA_ELEMENT];
  if (weights)
    for (pa_idx e = 0; e < c.ne; e++)
      PA_CHECK(isfinite(weights[e]) && weights[e] >= 0, PA_ERR_ARG,
               "pa_dmesh_rebalance: weight of owned element %d is %g",
               (int)e, weights[e]);
  PA_CALL(rank_loads(&c));
  if (c.P > 1 && c.mx > tol * c.mean) { /* not balanced enough */
    /* a large excess: a repartition, without trying diffusion */
    int diffuse = c.mx <= RB_DIFFUSE_MAX * c.mean;
    if (diffuse) PA_CALL(diffusion_parts(&c, tol, &diffuse));
    if (diffuse) {
      for (pa_idx e = 0; e < c.ne; e++) moved += c.part[e] != dm->rank;
      PA_CALL(pa__allreduce(dm->comm, &moved, 1, MPI_INT64_T, MPI_SUM));
      PA_CALL(pa_dmesh_redistribute(dm, c.part, weights));
      if (dm->rank == 0)
        pa__info(2, "padapt: rebalance: largest load %.6g (mean %.6g, "
                 "tolerance %g): %lld elements moved by diffusion\n", c.mx,
                 c.mean, tol, (long long)moved);
    } else {
      if (dm->rank == 0)
        pa__info(2, "padapt: rebalance: largest load %.6g (mean %.6g): "
                 "repartitioning with PT-Scotch\n", c.mx, c.mean);
      moved = -1;
      PA_CALL(pa_dmesh_redistribute(dm, NULL, weights));
    }
  }
  if (nmoved) *nmoved = moved;
cleanup:
  if (dm) st = pa__agree_end(dm->comm, st);
  pa__free(c.load);
  pa__free(c.exadj);
  pa__free(c.eadj);
  pa__free(c.eadjrank);
  pa__free(c.xadj);
  pa__free(c.adj);
  pa__free(c.x);
  pa__free(c.part);
  pa__free(c.delta);
  return st;
}
