/*
 * pieces.c -- step 2 of the piece algorithm: split the tagged elements into
 * disjoint pieces and grow each into a skin of neighbours.
 *
 *  1. The number of pieces: npieces_max (processes x pieces per process),
 *     fewer when the tagged work is small (min_piece_work each, and
 *     min_piece_ratio of the mean elements per rank), more when a piece
 *     would not fit the memory bound (mem_mb).
 *  2. PT-Scotch partitions the distributed dual graph of the tagged elements
 *     only (pa__dual_graph on their vertex ids), weighted by the work.
 *  3. The labels grow skin_layers vertex layers outward (skin_layers_later
 *     from the second iteration on): every vertex takes
 *     the smallest label of the labelled owned elements around it (reduced
 *     over the ranks, then sent back to the ghosts), and every unlabelled
 *     owned element takes the smallest label of its vertices. After one
 *     layer, every element sharing a vertex with a tagged element is
 *     labelled, except user-required ones: they stay outside the pieces.
 *  4. Per local vertex, the smallest and largest label of the elements
 *     around it (unlabelled: PA_ADAPT_NOLABEL), and of the tagged ones, reduced
 *     the same way (it->vlab). A piece's skin is its outer surface: the
 *     faces it shares with elements of another label or of none, frozen
 *     while it is remeshed; its vertices are those whose two labels differ.
 *     A skin vertex is hot for piece p when a tagged element of another
 *     piece touches it (extract.c). A vertex is inner (it->vinner =
 *     PA_ADAPT_INNER_TRANSIT) when only labelled elements touch it and it lies
 *     on no feature edge, required boundary entity, boundary entity inside
 *     the domain (an interface between two references, it->bside) or
 *     curved boundary and
 *     is no corner, ridge or required vertex; the other vertices that only
 *     labelled elements touch (on a ridge, a curved boundary, ...) are
 *     PA_ADAPT_LABELLED_TRANSIT. bisect.c splits a skin edge between two inner
 *     vertices, or between an inner and a labelled one: such an edge is
 *     interior, or lies in the plane of the inner end's boundary faces, so
 *     its midpoint is exact.
 *  5. Per local boundary entity (it->bside), whether two elements hold it
 *     (it lies inside the domain) and whether they have two labels: such
 *     an entity on a piece's outer surface is frozen in that piece
 *     (extract.c), as its skin is.
 * Only vertex and boundary values with reduce/halo cross the ranks here: no point-to-point
 * code, and the result does not depend on timing.
 */
#include "adapt/adapt.h"
#include "partition/partition.h"

#include <limits.h>
#include <math.h>

#define NOLABEL PA_ADAPT_NOLABEL
/* Load imbalance tolerance of the piece partition: the iteration waits for
 * the heaviest piece (Scotch's default 5 % left a 4.8 % gap in estimated
 * work on box3d 10 -> 0.019, 2 ranks). */
#define PIECE_KBAL 0.01

/* Vertex value comp 0 = min over the owned elements around v of lab(e),
 * comp 1 = min of -lab(e), where lab = label or NOLABEL; only_labelled skips
 * unlabelled elements. Reduced (MIN) and sent to the ghosts. */
static pa_status vertex_labels(pa__iter *it, pa_dmesh_value *val,
                               int only_labelled) {
  /* only_labelled == 2: the tagged elements only */
  pa_status st = PA_SUCCESS;
  pa_idx n;
  int *d = pa_dmesh_value_data(val, &n, NULL);
  const pa_idx *conn = it->dm->mesh->elem;
  for (pa_idx v = 0; v < n; v++) d[2 * v] = d[2 * v + 1] = NOLABEL;
  for (pa_idx e = 0; e < it->ne; e++) {
    int l = it->label[e] < 0 ? NOLABEL : it->label[e];
    if (only_labelled && l == NOLABEL) continue;
    if (only_labelled == 2 && !it->tag[e]) continue;
    for (int k = 0; k < it->nve; k++) {
      int *x = d + 2 * conn[(size_t)it->nve * e + k];
      if (l < x[0]) x[0] = l;
      if (-l < x[1]) x[1] = -l;
    }
  }
  PA_CALL(pa__agree(it->dm->comm, st));
  PA_CALL(pa_dmesh_reduce(it->dm, val, MPI_MIN));
  PA_CALL(pa_dmesh_halo(it->dm, val));
cleanup:
  return st;
}

/* curved[v] = 1 for a local vertex on boundary entities that do not all lie
 * in one plane (one line in 2D), over every rank: a skin edge there is not
 * bisected (its midpoint would lie on the chord, inside a curved boundary,
 * and stay there frozen). Per vertex, the smallest and largest component of
 * the unit normals of its boundary entities (sign made canonical), reduced. */
static pa_status curved_vertices(pa_dmesh *dm, uint8_t *curved) {
  pa_status st = PA_SUCCESS;
  const pa_mesh *m = dm->mesh;
  int d = dm->dim;
  pa_idx nv = dm->nloc[PA_VERTEX];
  pa_dmesh_value *val = NULL;
  PA_CALL(pa_dmesh_value_add(dm, PA_VERTEX, "pa.adapt.normals", MPI_DOUBLE,
                             2 * d, -1, &val));
  {
    double *x = pa_dmesh_value_data(val, NULL, NULL);
    for (size_t i = 0; i < (size_t)2 * d * nv; i++) x[i] = HUGE_VAL;
    for (pa_idx b = 0; b < m->nb; b++) {
      const pa_idx *f = m->bdry + (size_t)d * b;
      const double *p0 = m->coord + (size_t)d * f[0], *p1 = m->coord + (size_t)d * f[1];
      double n[3] = {0, 0, 0};
      if (d == 2) {
        n[0] = p1[1] - p0[1];
        n[1] = p0[0] - p1[0];
      } else {
        const double *p2 = m->coord + 3 * (size_t)f[2];
        double u[3] = {p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]};
        double w[3] = {p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]};
        n[0] = u[1] * w[2] - u[2] * w[1];
        n[1] = u[2] * w[0] - u[0] * w[2];
        n[2] = u[0] * w[1] - u[1] * w[0];
      }
      double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
      if (!(len > 0)) continue;
      int k0 = 0; /* the largest component made positive */
      for (int k = 1; k < d; k++)
        if (fabs(n[k]) > fabs(n[k0])) k0 = k;
      double s = n[k0] < 0 ? -1.0 / len : 1.0 / len;
      for (int j = 0; j < d; j++) {
        double *y = x + (size_t)2 * d * f[j];
        for (int k = 0; k < d; k++) {
          double c = n[k] * s;
          if (c < y[k]) y[k] = c;
          if (-c < y[d + k]) y[d + k] = -c;
        }
      }
    }
  }
  PA_CALL(pa_dmesh_reduce(dm, val, MPI_MIN));
  PA_CALL(pa_dmesh_halo(dm, val));
  {
    const double *x = pa_dmesh_value_data(val, NULL, NULL);
    for (pa_idx v = 0; v < nv; v++) {
      const double *y = x + (size_t)2 * d * v;
      int c = 0;
      for (int k = 0; k < d; k++)
        c |= y[k] != HUGE_VAL && -y[d + k] - y[k] > 1e-9;
      curved[v] = (uint8_t)c;
    }
  }
cleanup:
  st = pa__dmesh_value_drop(dm, val, pa__agree_end(dm->comm, st));
  return st;
}

/* The tagged elements, the graph to partition: nt here, their vertex gids
 * (vg, nve per element) and work (wt), the work over every rank (wsum);
 * part receives their pieces. */
typedef struct tagged {
  pa_idx nt;
  pa_gid *vg;
  double *wt, wsum;
  int *part;
} tagged;

/* Every owned element unlabelled (-1), and the tagged ones collected. */
static pa_status collect_tagged(pa__iter *it, tagged *t) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = it->dm;
  const pa_idx *conn = dm->mesh->elem;
  PA_ALLOC(it->label, it->ne);
  for (pa_idx e = 0; e < it->ne; e++) {
    it->label[e] = -1;
    if (it->tag[e]) {
      t->nt++;
      t->wsum += it->work[e];
    }
  }
  PA_ALLOC(t->vg, (size_t)t->nt * it->nve);
  PA_ALLOC(t->wt, t->nt);
  PA_ALLOC(t->part, t->nt);
  for (pa_idx e = 0, k = 0; e < it->ne; e++)
    if (it->tag[e]) {
      for (int j = 0; j < it->nve; j++)
        t->vg[(size_t)it->nve * k + j] = dm->gid[PA_VERTEX][conn[(size_t)it->nve * e + j]];
      t->wt[k++] = it->work[e];
    }
  PA_CALL(pa__allreduce(dm->comm, &t->wsum, 1, MPI_DOUBLE, MPI_SUM));
cleanup:
  return st;
}

/* Step 1: the number of pieces (the same on every rank: from global
 * figures). A piece must be worth an iteration: at least min_piece_work,
 * and at least min_piece_ratio of the mean number of elements per rank
 * (each iteration passes over the whole local mesh, in its tag, pieces
 * and reintegration, and the skins between pieces of a small tagged set
 * are tagged again: splitting it costs more iterations than it saves). */
static void count_pieces(pa__iter *it, int npieces_max, double wsum) {
  const pa_adapt_opts *o = it->opts;
  double np = npieces_max;
  double minw = o->min_piece_work > 0 ? o->min_piece_work : 1;
  double byrank = o->min_piece_ratio * (double)it->dm->nglob[PA_ELEMENT] / it->size;
  if (byrank > minw) minw = byrank;
  if (np > floor(wsum / minw)) np = floor(wsum / minw);
  if (o->mem_mb > 0) {
    double npm = ceil(wsum * PA_ADAPT_BYTES_PER_WORK / (o->mem_mb * 1e6));
    if (npm > np) np = npm;
  }
  if (np > (double)it->ntagged) np = (double)it->ntagged;
  if (np > 1e6) np = 1e6;
  if (np < 1) np = 1;
  it->npieces = (int)np;
}

/* Step 2: partition the tagged elements, weighted by their work, and label
 * them. pa__partition_dgraph scales the weights to integer loads in [1, S],
 * S = min(1e6, 2^30 / tagged elements), so that their sum fits Scotch's
 * 32-bit integers whatever the count. */
static pa_status partition_tagged(pa__iter *it, tagged *t) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = it->dm;
  pa_idx *xadj = NULL;
  pa_gid *adj = NULL;
  if (it->npieces > 1) {
    PA_CALL(pa__dual_graph(dm->comm, it->dim, t->nt, t->vg, NULL, 0, &xadj,
                           &adj, NULL, NULL));
    st = pa__partition_dgraph(dm->comm, t->nt, xadj, adj, t->wt, it->npieces,
                              PIECE_KBAL, t->part);
    PA_CALL(pa__agree(dm->comm, st));
  } else {
    for (pa_idx k = 0; k < t->nt; k++) t->part[k] = 0;
  }
  for (pa_idx e = 0, k = 0; e < it->ne; e++)
    if (it->tag[e]) it->label[e] = t->part[k++];
cleanup:
  pa__free(xadj);
  pa__free(adj);
  return st;
}

/* Step 3: grow the labels, one vertex layer at a time (skin_layers, or
 * skin_layers_later from the second iteration on): every unlabelled owned
 * element that is not required takes the smallest label of its vertices.
 * val: the vertex value of vertex_labels. */
static pa_status grow_labels(pa__iter *it, pa_dmesh_value *val) {
  pa_status st = PA_SUCCESS;
  const pa_adapt_opts *o = it->opts;
  const pa_mesh *m = it->dm->mesh;
  const pa_idx *conn = m->elem;
  int nlayer = it->iter > 1 ? o->skin_layers_later : o->skin_layers;
  for (int layer = 0; layer < (nlayer > 0 ? nlayer : 1); layer++) {
    PA_CALL(vertex_labels(it, val, 1));
    const int *d = pa_dmesh_value_data(val, NULL, NULL);
    for (pa_idx e = 0; e < it->ne; e++) {
      if (it->label[e] >= 0) continue;
      if (m->eflag[e] & PA_FLAG_REQUIRED) continue;
      int l = NOLABEL;
      for (int k = 0; k < it->nve; k++) {
        int x = d[2 * conn[(size_t)it->nve * e + k]];
        if (x < l) l = x;
      }
      /* labels of this layer are set after the loop: use a marker */
      if (l != NOLABEL) it->label[e] = -2 - l;
    }
    for (pa_idx e = 0; e < it->ne; e++)
      if (it->label[e] <= -2) it->label[e] = -2 - it->label[e];
  }
cleanup:
  return st;
}

/* Step 4a: per local vertex, the smallest and largest label of the
 * elements around it (it->vlab[4v], [4v+1]; unlabelled: NOLABEL) and of
 * the tagged ones ([4v+2], [4v+3]), over every rank: the skin and the hot
 * vertices. */
static pa_status label_ranges(pa__iter *it, pa_dmesh_value *val) {
  pa_status st = PA_SUCCESS;
  pa_idx nloc = it->dm->nloc[PA_VERTEX];
  const int *d;
  PA_CALL(vertex_labels(it, val, 0));
  PA_ALLOC(it->vlab, (size_t)4 * nloc);
  d = pa_dmesh_value_data(val, NULL, NULL);
  for (pa_idx v = 0; v < nloc; v++) {
    it->vlab[4 * v] = d[2 * v];
    it->vlab[4 * v + 1] = -d[2 * v + 1];
  }
  PA_CALL(vertex_labels(it, val, 2));
  d = pa_dmesh_value_data(val, NULL, NULL);
  for (pa_idx v = 0; v < nloc; v++) {
    it->vlab[4 * v + 2] = d[2 * v];
    it->vlab[4 * v + 3] = -d[2 * v + 1];
  }
cleanup:
  return st;
}

/* Step 4b: it->bside, which boundary entities lie inside the domain
 * (held by two elements) and which are held by elements of two labels (a
 * labelled and an unlabelled one included): per entity, the smallest and
 * largest global id and label of the owned elements holding it, reduced
 * (MIN) over the ranks and sent back to the ghosts. */
static pa_status boundary_sides(pa__iter *it) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = it->dm;
  const pa_mesh *m = dm->mesh;
  pa_dmesh_value *val = NULL;
  pa_idx nb = dm->nloc[PA_BOUNDARY];
  int d = it->dim;
  if (!it->bstart) PA_CALL(pa__owned_balls(dm, &it->bstart, &it->belem));
  PA_CALL(pa_dmesh_value_add(dm, PA_BOUNDARY, "pa.adapt.bside", MPI_INT64_T,
                             4, -1, &val));
  {
    int64_t *x = pa_dmesh_value_data(val, NULL, NULL);
    for (pa_idx b = 0; b < nb; b++) {
      int64_t *y = x + 4 * (size_t)b;
      y[0] = y[1] = y[2] = y[3] = INT64_MAX;
      const pa_idx *f = m->bdry + (size_t)d * b;
      for (pa_idx q = it->bstart[f[0]]; q < it->bstart[f[0] + 1]; q++) {
        pa_idx e = it->belem[q];
        const pa_idx *ev = m->elem + (size_t)it->nve * e;
        int all = 1;
        for (int i = 1; i < d && all; i++) {
          int in = 0;
          for (int j = 0; j < it->nve; j++) in |= ev[j] == f[i];
          all = in;
        }
        if (!all) continue;
        int64_t g = dm->gid[PA_ELEMENT][e];
        int64_t l = it->label[e] < 0 ? NOLABEL : it->label[e];
        if (g < y[0]) y[0] = g;
        if (-g < y[1]) y[1] = -g;
        if (l < y[2]) y[2] = l;
        if (-l < y[3]) y[3] = -l;
      }
    }
  }
  PA_CALL(pa__agree(dm->comm, st));
  PA_CALL(pa_dmesh_reduce(dm, val, MPI_MIN));
  PA_CALL(pa_dmesh_halo(dm, val));
  PA_ALLOC(it->bside, nb);
  {
    const int64_t *x = pa_dmesh_value_data(val, NULL, NULL);
    for (pa_idx b = 0; b < nb; b++) {
      const int64_t *y = x + 4 * (size_t)b;
      it->bside[b] = (uint8_t)((y[0] != -y[1] ? PA_ADAPT_B_INTERIOR : 0) |
                               (y[2] != -y[3] ? PA_ADAPT_B_CUT : 0));
    }
  }
cleanup:
  return pa__dmesh_value_drop(dm, val, pa__agree_end(dm->comm, st));
}

/* Step 4c: the inner vertices (bisect.c): only pieces around, on no
 * feature edge nor required boundary entity nor interior boundary entity
 * (it->bside) nor curved boundary (reduced
 * over the ranks: every piece sees the same), and no corner, ridge or
 * required vertex; it->vinner as described at the top of the file. */
static pa_status inner_vertices(pa__iter *it, pa_dmesh_value *val) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = it->dm;
  pa_idx nloc = dm->nloc[PA_VERTEX];
  {
    int *d = pa_dmesh_value_data(val, NULL, NULL);
    const pa_mesh *m = dm->mesh;
    for (pa_idx v = 0; v < nloc; v++) d[2 * v] = d[2 * v + 1] = 0;
    for (pa_idx b = 0; b < m->nb; b++)
      if ((m->bflag[b] & PA_FLAG_REQUIRED) ||
          (it->bside[b] & PA_ADAPT_B_INTERIOR))
        for (int k = 0; k < it->dim; k++) d[2 * m->bdry[(size_t)it->dim * b + k]] = 1;
    for (pa_idx b = 0; b < m->ned; b++)
      for (int k = 0; k < 2; k++) d[2 * m->edge[2 * (size_t)b + k]] = 1;
  }
  PA_CALL(pa__agree(dm->comm, st));
  PA_CALL(pa_dmesh_reduce(dm, val, MPI_MAX));
  PA_CALL(pa_dmesh_halo(dm, val));
  PA_ALLOC(it->vinner, nloc);
  PA_CALL(curved_vertices(dm, it->vinner)); /* 1: curved, for now */
  {
    const int *d = pa_dmesh_value_data(val, NULL, NULL);
    const uint8_t *vf = dm->mesh->vflag;
    for (pa_idx v = 0; v < nloc; v++) {
      int labelled = it->vlab[4 * v + 1] != NOLABEL;
      int inner = labelled && !d[2 * v] && !it->vinner[v] &&
                  !(vf[v] & (PA_FLAG_CORNER | PA_FLAG_RIDGE | PA_FLAG_REQUIRED));
      it->vinner[v] = (uint8_t)(inner      ? PA_ADAPT_INNER_TRANSIT
                                : labelled ? PA_ADAPT_LABELLED_TRANSIT
                                           : 0);
    }
  }
cleanup:
  return st;
}

pa_status pa__adapt_pieces(pa__iter *it, int npieces_max) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = it->dm;
  tagged t;
  int added = 0;
  pa_dmesh_value *val = NULL;
  memset(&t, 0, sizeof t);
  PA_CALL(collect_tagged(it, &t));
  count_pieces(it, npieces_max, t.wsum);
  PA_CALL(partition_tagged(it, &t));
  PA_CALL(pa_dmesh_value_add(dm, PA_VERTEX, "pa.adapt.label", MPI_INT, 2, -1,
                             &val));
  added = 1;
  PA_CALL(grow_labels(it, val));
  PA_CALL(label_ranges(it, val));
  PA_CALL(boundary_sides(it));
  PA_CALL(inner_vertices(it, val));
cleanup:
  st = pa__dmesh_value_drop(dm, added ? val : NULL,
                            pa__agree_end(dm->comm, st));
  pa__free(t.vg);
  pa__free(t.wt);
  pa__free(t.part);
  return st;
}
