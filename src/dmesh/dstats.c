/*
 * dstats.c -- pa_dmesh_stats: the statistics of pa_mesh_stats for a
 * distributed mesh, without gathering it.
 *
 * Elements are counted by their owner (volume, inversion, quality). The
 * local edges come from pa__edges_csr, as in pa_mesh_stats, filed under
 * their endpoint of smaller global id. Each
 * edge is measured once over the ranks: an edge with an endpoint that has
 * no copy on another rank exists on this rank only and is counted here;
 * every other edge is sent (as a record keyed by a hash of its two vertex
 * global ids) to the rank hash % size, which counts each distinct pair
 * once. Lengths are computed with the endpoints in global-id order, so every
 * rank computes the same value for the same edge. Each rank counts through
 * the accumulator of pa_mesh_stats (pa__stats_acc, metric/stats.c), so bins
 * and conventions are the same; the ranks' partial figures are then
 * combined.
 */
#include "dmesh/dmesh.h"
#include "metric/metric.h"
#include "metric/metric2d.h"
#include "metric/metric3d.h"

#include <math.h>

static uint64_t pair_hash(pa_gid a, pa_gid b) {
  return pa__mix64(pa__mix64((uint64_t)a) ^ (uint64_t)b) >> 1;
}

/* Combine the partial statistics of the ranks (a rank that counted no
 * edge or no element takes no part in their extremes). */
static pa_status combine(MPI_Comm comm, pa__stats_acc *a) {
  pa_status st = PA_SUCCESS;
  pa_stats *s = &a->s;
  pa_gid c[4 + PA_STATS_EDGE_NBIN + PA_STATS_QUAL_NBIN];
  double sum[3] = {s->volume, s->edge_sum, s->qual_sum};
  double mn[2] = {s->nedge ? s->edge_min : INFINITY,
                  a->nelem ? s->qual_min : INFINITY};
  double mx[2] = {s->nedge ? s->edge_max : -INFINITY,
                  a->nelem ? s->qual_max : -INFINITY};
  int n = 0;
  c[n++] = s->ninverted;
  c[n++] = s->nedge;
  c[n++] = s->qual_above_05;
  c[n++] = s->qual_above_012;
  for (int k = 0; k < PA_STATS_EDGE_NBIN; k++) c[n++] = s->edge_hist[k];
  for (int k = 0; k < PA_STATS_QUAL_NBIN; k++) c[n++] = s->qual_hist[k];
  PA_CALL(pa__allreduce(comm, c, n, MPI_INT64_T, MPI_SUM));
  PA_CALL(pa__allreduce(comm, sum, 3, MPI_DOUBLE, MPI_SUM));
  PA_CALL(pa__allreduce(comm, mn, 2, MPI_DOUBLE, MPI_MIN));
  PA_CALL(pa__allreduce(comm, mx, 2, MPI_DOUBLE, MPI_MAX));
  n = 0;
  s->ninverted = c[n++];
  s->nedge = c[n++];
  s->qual_above_05 = c[n++];
  s->qual_above_012 = c[n++];
  for (int k = 0; k < PA_STATS_EDGE_NBIN; k++) s->edge_hist[k] = c[n++];
  for (int k = 0; k < PA_STATS_QUAL_NBIN; k++) s->qual_hist[k] = c[n++];
  s->volume = sum[0];
  s->edge_sum = sum[1];
  s->qual_sum = sum[2];
  s->edge_min = s->nedge ? mn[0] : 0;
  s->edge_max = s->nedge ? mx[0] : 0;
  s->qual_min = isfinite(mn[1]) ? mn[1] : 0;
  s->qual_max = isfinite(mx[1]) ? mx[1] : 0;
cleanup:
  return st;
}

pa_status pa_dmesh_stats(pa_dmesh *dm, pa_stats *stats) {
  if (!dm)
    return pa__error(PA_ERR_ARG, __FILE__, __LINE__,
                     "pa_dmesh_stats: NULL argument");
  return pa__dmesh_stats_met(dm, dm->mesh->met_ncomp, dm->mesh->met,
                             PA_STATS_CHECK_FULL, stats);
}

/* Count the ne owned elements of m (dimension d, a constant once inlined:
 * the kernels pa__quality and pa__edge_length dispatch to, inline) in
 * metric met (nc components). */
static inline void add_elements_dim(pa__stats_acc *acc, const pa_mesh *m,
                                    const int d, pa_idx ne, int nc,
                                    const double *met) {
  const int nve = d + 1;
  for (pa_idx e = 0; e < ne; e++) {
    const pa_idx *v = m->elem + (size_t)nve * e;
    const double *x[4], *mm[4] = {NULL, NULL, NULL, NULL};
    for (int k = 0; k < nve; k++) {
      x[k] = m->coord + (size_t)d * v[k];
      if (nc) mm[k] = met + (size_t)nc * v[k];
    }
    pa__stats_add_elem(acc, pa__simplex_volume(d, x),
                       d == 2 ? pa__qual2_stat(nc, x, mm)
                              : pa__qual3_stat(nc, x, mm));
  }
}

static void add_elements(pa__stats_acc *acc, const pa_mesh *m, int d,
                         pa_idx ne, int nc, const double *met) {
  if (d == 2) add_elements_dim(acc, m, 2, ne, nc, met);
  else add_elements_dim(acc, m, 3, ne, nc, met);
}

/* shared[v] = 1 on the vertices with copies elsewhere: ghosts, and owned
 * ones with ghosts (nv entries, allocated here). */
static pa_status mark_shared(pa_dmesh *dm, pa_idx nv, uint8_t **sharedp) {
  pa_status st = PA_SUCCESS;
  pa_dmesh_iter iv;
  pa_idx v;
  PA_CALLOC(*sharedp, nv);
  uint8_t *shared = *sharedp;
  for (pa_idx i = 0; i < nv; i++) shared[i] = 1;
  PA_CALL(pa_dmesh_iter_init(dm, PA_VERTEX, PA_INTERIOR, &iv));
  while (pa_dmesh_iter_next(&iv, &v)) shared[v] = 0;
cleanup:
  return st;
}

/* The unique local edges, each filed under its endpoint of smaller global
 * id (pa__edges_csr): counted here when an endpoint is not shared, else
 * added to S with its destination rank in *destp (allocated here). */
static pa_status file_edges(pa_dmesh *dm, pa_idx ne, int nc,
                            const double *met, const uint8_t *shared,
                            pa__stats_acc *acc, pa__recs *S, int **destp) {
  pa_status st = PA_SUCCESS;
  size_t *pos = NULL;
  pa_idx *other = NULL;
  pa_mesh *m = dm->mesh;
  int d = dm->dim, nve = d + 1;
  pa_idx nv = dm->nloc[PA_VERTEX];
  const pa_gid *vg = dm->gid[PA_VERTEX];
  size_t ns = 0;
  PA_CALL(pa__edges_csr(m->elem, ne, nve, nv, vg, &pos, &other));
  PA_ALLOC(*destp, pos[nv] ? pos[nv] : 1);
  int *dest = *destp;
  for (pa_idx a = 0; a < nv; a++)
    for (size_t k = pos[a]; k < pos[a + 1]; k++) {
      pa_idx b = other[k];
      const double *xa = m->coord + (size_t)d * a, *xb = m->coord + (size_t)d * b;
      const double *ma = nc ? met + (size_t)nc * a : NULL;
      const double *mb = nc ? met + (size_t)nc * b : NULL;
      double len = d == 2 ? pa__len2(nc, xa, xb, ma, mb)
                          : pa__len3(nc, xa, xb, ma, mb);
      if (!shared[a] || !shared[b]) {
        pa__stats_add_edge(acc, len);
        continue;
      }
      pa_gid ab[2] = {vg[a], vg[b]};
      uint64_t h = pair_hash(ab[0], ab[1]);
      PA_CALL(pa__recs_add(S, (pa_gid)h, ab, 0, 0, 0, &len, NULL, 0));
      dest[ns++] = (int)(h % (uint64_t)dm->size);
    }
cleanup:
  pa__free(pos);
  pa__free(other);
  return st;
}

/* Count each distinct edge of R once. R is sorted by hash: equal pairs are
 * in the same run of equal hashes. */
static void add_received_edges(pa__stats_acc *acc, const pa__recs *R) {
  for (size_t i = 0; i < R->n; i++) {
    int dup = 0;
    for (size_t j = i; j > 0 && R->gid[j - 1] == R->gid[i] && !dup; j--)
      dup = R->vgid[2 * (j - 1)] == R->vgid[2 * i] &&
            R->vgid[2 * (j - 1) + 1] == R->vgid[2 * i + 1];
    if (!dup) pa__stats_add_edge(acc, R->dbl[i]);
  }
}

pa_status pa__dmesh_stats_met(pa_dmesh *dm, int nc, const double *met,
                              int check, pa_stats *stats) {
  pa_status st = PA_SUCCESS;
  pa__stats_acc acc;
  pa_stats *s = &acc.s;
  uint8_t *shared = NULL;
  int *dest = NULL;
  pa__recs S, R;
  pa__recs_init(&S, PA_EDGE, 2, 1);
  pa__recs_init(&R, PA_EDGE, 2, 1);
  pa__stats_acc_init(&acc);
  PA_CHECK(dm && stats, PA_ERR_ARG, "pa_dmesh_stats: NULL argument");
  pa__agree_reset();
  pa_idx ne = dm->nown[PA_ELEMENT];
  s->dim = dm->dim;
  s->has_metric = nc > 0;
  s->nvert = dm->nglob[PA_VERTEX];
  s->nelem = dm->nglob[PA_ELEMENT];
  s->nbdry = dm->nglob[PA_BOUNDARY];
  add_elements(&acc, dm->mesh, dm->dim, ne, nc, met);
  PA_CALL(mark_shared(dm, dm->nloc[PA_VERTEX], &shared));
  PA_CALL(file_edges(dm, ne, nc, met, shared, &acc, &S, &dest));
  PA_CALL(pa__recs_migrate(dm->comm, &S, dest, &R));
  add_received_edges(&acc, &R);
  pa__stats_acc_sums(&acc);
  PA_CALL(combine(dm->comm, &acc));
  {
    pa_status c = check == PA_STATS_CHECK_FULL     ? pa_dmesh_check(dm)
                  : check == PA_STATS_CHECK_OUTPUT ? pa__dmesh_check_output(dm)
                                                   : PA_SUCCESS;
    if (c == PA_ERR_MEMORY) PA_CALL(c);
    s->valid = c == PA_SUCCESS;
    if (!s->valid) pa_clear_error();
  }
  *stats = *s;
cleanup:
  if (dm) st = pa__agree_end(dm->comm, st);
  pa__free(shared);
  pa__free(dest);
  pa__recs_free(&S);
  pa__recs_free(&R);
  return st;
}
