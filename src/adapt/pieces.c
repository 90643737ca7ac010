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
 *     curved boundary and is no corner, ridge or required vertex; a surface
 *     vertex (PA_ADAPT_SURFACE_TRANSIT) when the same holds but for a curved
 *     boundary, smooth there: the outward normals of its boundary faces lie
 *     within PA_LEB_SMOOTH_DEG of each other; the other vertices that only
 *     labelled elements touch (on a ridge, a sharp curved boundary, ...)
 *     are PA_ADAPT_LABELLED_TRANSIT. In 3D every local vertex gets, in
 *     it->vsurf, the normal of a surface vertex (the normalised sum of its
 *     faces' outward normals, each face counted once, by the owner of the
 *     element holding it) and a Bloom mask of the global ids of its
 *     boundary neighbours, the hard bit set on a feature edge or a required
 *     boundary entity; extract.c ships them, bisect.c splits the skin edges
 *     by them (see there).
 *  5. Per local boundary entity (it->bside), whether two elements hold it
 *     (it lies inside the domain) and whether they have two labels: such
 *     an entity on a piece's outer surface is frozen in that piece
 *     (extract.c), as its skin is.
 * Only vertex and boundary values with reduce/halo cross the ranks here: no
 * point-to-point
 * code, and the result does not depend on timing.
 */
#include "adapt/piece.h"
#include "partition/partition.h"
#include "remesh/leb.h"

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
 * the unit normals of its boundary entities (sign made canonical), reduced.
 * Found for the vertices near a piece only (pa__adapt_near_piece): 0 for
 * the others. */
static pa_status curved_vertices(pa__iter *it, uint8_t *curved) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = it->dm;
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
      if (!pa__adapt_near_piece(it, f, d)) continue;
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

/* Per local vertex (3D), in the value surface_vertices reduces: the sum
 * of the outward normals of its boundary faces (twice their areas long),
 * the smallest component of their unit normals and of their opposites,
 * the Bloom mask of its boundary neighbours. */
#define SV_SUM 0
#define SV_MIN 3
#define SV_NEGMIN 6
#define SV_MASK 9
#define SV_N 10

/* Combine two copies of the vertices of surface_vertices: sums, minima,
 * and the union of the masks. */
static void combine_surface(const void *in, void *inout, pa_idx n, void *ctx) {
  const double *x = in;
  double *y = inout;
  (void)ctx;
  for (pa_idx v = 0; v < n; v++, x += SV_N, y += SV_N) {
    for (int k = SV_SUM; k < SV_MIN; k++) y[k] += x[k];
    for (int k = SV_MIN; k < SV_MASK; k++) y[k] = x[k] < y[k] ? x[k] : y[k];
    y[SV_MASK] = (double)((uint64_t)x[SV_MASK] | (uint64_t)y[SV_MASK]);
  }
}

/* The outward normal of boundary triangle f as a face of owned tetrahedron
 * e, twice its area long, into n; 0 if e does not contain f. */
static int face_normal(const pa_mesh *m, pa_idx e, const pa_idx *f, double *n) {
  const pa_idx *ev = m->elem + 4 * (size_t)e;
  pa_idx q = -1;
  int in = 0;
  for (int j = 0; j < 4; j++) {
    if (ev[j] == f[0] || ev[j] == f[1] || ev[j] == f[2])
      in++;
    else
      q = ev[j];
  }
  if (in != 3) return 0;
  const double *p0 = m->coord + 3 * (size_t)f[0], *p1 = m->coord + 3 * (size_t)f[1],
               *p2 = m->coord + 3 * (size_t)f[2], *pq = m->coord + 3 * (size_t)q;
  double u[3] = {p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]};
  double w[3] = {p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]};
  n[0] = u[1] * w[2] - u[2] * w[1];
  n[1] = u[2] * w[0] - u[0] * w[2];
  n[2] = u[0] * w[1] - u[1] * w[0];
  if (n[0] * (pq[0] - p0[0]) + n[1] * (pq[1] - p0[1]) + n[2] * (pq[2] - p0[2]) > 0)
    for (int k = 0; k < 3; k++) n[k] = -n[k];
  return 1;
}

/* 3D: the vertices on a smooth curved boundary (bisect.c, remesh/leb.c):
 * smooth[v] = 1 when the outward unit normals of v's boundary faces, each
 * oriented by an element containing it and counted by that element's
 * owner, lie within PA_LEB_SMOOTH_DEG of each other (judged on the box of
 * their components, whose diagonal bounds their distances: an internal
 * face, seen from both sides, fails), over every rank; it->vsurf receives
 * per local vertex the unit normal of such a vertex (the normalised
 * area-weighted sum; 0 for the others) and the Bloom mask of its boundary
 * neighbours' global ids (edges of boundary entities), reduced over the
 * ranks, the same bits on every copy. Found for the vertices near a piece
 * only (pa__adapt_near_piece): the others get 0 and no mask. */
static pa_status surface_vertices(pa__iter *it, uint8_t *smooth) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = it->dm;
  const pa_mesh *m = dm->mesh;
  pa_idx nv = dm->nloc[PA_VERTEX];
  pa_dmesh_value *val = NULL;
  double spread = 2 * sin(PA_LEB_SMOOTH_DEG * M_PI / 360);
  PA_CALL(pa__adapt_entity_balls(it));
  PA_CALL(pa_dmesh_value_add(dm, PA_VERTEX, "pa.adapt.surface", MPI_DOUBLE,
                             SV_N, -1, &val));
  double *x = pa_dmesh_value_data(val, NULL, NULL);
  for (pa_idx v = 0; v < nv; v++)
    for (int k = 0; k < SV_N; k++)
      x[(size_t)SV_N * v + k] = k >= SV_MIN && k < SV_MASK ? HUGE_VAL : 0;
  for (pa_idx b = 0; b < m->nb; b++) {
    const pa_idx *f = m->bdry + 3 * (size_t)b;
    if (!pa__adapt_near_piece(it, f, 3)) continue;
    for (int j = 0; j < 3; j++) /* the masks: every edge of b */
      for (int i = 0; i < 3; i++) {
        double *y = x + (size_t)SV_N * f[j] + SV_MASK;
        if (i != j)
          *y = (double)((uint64_t)*y |
                        pa__adapt_bloom_bit(dm->gid[PA_VERTEX][f[i]]));
      }
    for (pa_idx q = it->bstart[f[0]]; q < it->bstart[f[0] + 1]; q++) {
      double n[3];
      if (!face_normal(m, it->belem[q], f, n)) continue;
      double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
      if (!(len > 0)) continue;
      for (int j = 0; j < 3; j++) {
        double *y = x + (size_t)SV_N * f[j];
        for (int k = 0; k < 3; k++) {
          double u = n[k] / len;
          y[SV_SUM + k] += n[k];
          if (u < y[SV_MIN + k]) y[SV_MIN + k] = u;
          if (-u < y[SV_NEGMIN + k]) y[SV_NEGMIN + k] = -u;
        }
      }
    }
  }
  PA_CALL(pa__agree(dm->comm, st));
  PA_CALL(pa__dmesh_reduce_fn(dm, val, combine_surface, NULL));
  PA_CALL(pa_dmesh_halo(dm, val));
  PA_ALLOC(it->vsurf, (size_t)4 * nv);
  x = pa_dmesh_value_data(val, NULL, NULL);
  for (pa_idx v = 0; v < nv; v++) {
    const double *y = x + (size_t)SV_N * v;
    double *z = it->vsurf + (size_t)4 * v, dd = 0, ss = 0;
    for (int k = 0; k < 3; k++) {
      double r = -y[SV_NEGMIN + k] - y[SV_MIN + k];
      dd += r * r;
      ss += y[SV_SUM + k] * y[SV_SUM + k];
    }
    ss = sqrt(ss);
    smooth[v] = (uint8_t)(y[SV_MIN] != HUGE_VAL && dd <= spread * spread &&
                          ss > 0);
    for (int k = 0; k < 3; k++) z[k] = smooth[v] ? y[SV_SUM + k] / ss : 0;
    z[3] = y[SV_MASK];
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

/* Extra vertex layers at most, beyond skin_layers(_later), around pieces
 * holding fewer than min_piece_work elements (grow_labels): enough for a
 * 2D tagged band of a few dozen elements to cover the 1 100 triangles of
 * a UGAWG field, at one pass over the mesh each. */
#define SMALL_PIECE_LAYERS 12

/* One layer of step 3: every unlabelled owned element that is not
 * required takes the smallest label of its vertices. */
static pa_status grow_layer(pa__iter *it, pa_dmesh_value *val) {
  pa_status st = PA_SUCCESS;
  const pa_mesh *m = it->dm->mesh;
  const pa_idx *conn = m->elem;
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
cleanup:
  return st;
}

/* Step 3: grow the labels, one vertex layer at a time: skin_layers, or
 * skin_layers_later from the second iteration on; then, while the pieces
 * hold fewer than min_piece_work elements each on average and a layer
 * still adds some, up to SMALL_PIECE_LAYERS more. A small piece costs
 * little more for being wider, and its frozen skin then lies where the
 * mesh is at size: a band of a few dozen tagged elements remeshed behind
 * a skin two layers away leaves edges the next adaptation finds out of
 * range (UGAWG polar-1 at 2 ranks, 5 passes: 98.48 % of the edges in
 * range, 99.32 % when its pieces hold the whole mesh; docs/BENCHMARKS.md).
 * val: the vertex value of vertex_labels. */
static pa_status grow_labels(pa__iter *it, pa_dmesh_value *val) {
  pa_status st = PA_SUCCESS;
  const pa_adapt_opts *o = it->opts;
  int nlayer = it->iter > 1 ? o->skin_layers_later : o->skin_layers;
  double want = (double)it->npieces * o->min_piece_work, last = -1;
  for (int layer = 0; layer < (nlayer > 0 ? nlayer : 1); layer++)
    PA_CALL(grow_layer(it, val));
  for (int layer = 0; layer < SMALL_PIECE_LAYERS; layer++) {
    double n = 0;
    for (pa_idx e = 0; e < it->ne; e++) n += it->label[e] >= 0;
    PA_CALL(pa__allreduce(it->dm->comm, &n, 1, MPI_DOUBLE, MPI_SUM));
    if (n >= want || n == last) break;
    last = n;
    PA_CALL(grow_layer(it, val));
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

pa_status pa__adapt_entity_balls(pa__iter *it) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = it->dm;
  const pa_mesh *m = dm->mesh;
  uint8_t *need = NULL;
  if (it->bstart) goto cleanup;
  PA_CALLOC(need, dm->nloc[PA_VERTEX] ? dm->nloc[PA_VERTEX] : 1);
  for (pa_idx b = 0; b < m->nb; b++) {
    const pa_idx *f = m->bdry + (size_t)it->dim * b;
    if (pa__adapt_near_piece(it, f, it->dim)) need[f[0]] = 1;
  }
  for (pa_idx b = 0; b < m->ned; b++) {
    const pa_idx *f = m->edge + 2 * (size_t)b;
    if (pa__adapt_near_piece(it, f, 2)) need[f[0]] = 1;
  }
  PA_CALL(pa__balls_of(m->elem, dm->nown[PA_ELEMENT], it->nve,
                       dm->nloc[PA_VERTEX], need, &it->bstart, &it->belem));
cleanup:
  pa__free(need);
  return st;
}

/* Step 4b: it->bside, which boundary entities lie inside the domain
 * (held by two elements) and which are held by elements of two labels (a
 * labelled and an unlabelled one included): per entity, the smallest and
 * largest global id and label of the owned elements holding it, reduced
 * (MIN) over the ranks and sent back to the ghosts. Found for the entities
 * near a piece only (pa__adapt_near_piece, the same on every copy): 0 for
 * the others. */
static pa_status boundary_sides(pa__iter *it) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = it->dm;
  const pa_mesh *m = dm->mesh;
  pa_dmesh_value *val = NULL;
  pa_idx nb = dm->nloc[PA_BOUNDARY];
  int d = it->dim;
  PA_CALL(pa__adapt_entity_balls(it));
  PA_CALL(pa_dmesh_value_add(dm, PA_BOUNDARY, "pa.adapt.bside", MPI_INT64_T,
                             4, -1, &val));
  {
    int64_t *x = pa_dmesh_value_data(val, NULL, NULL);
    for (pa_idx b = 0; b < nb; b++) {
      int64_t *y = x + 4 * (size_t)b;
      const pa_idx *f = m->bdry + (size_t)d * b;
      if (!pa__adapt_near_piece(it, f, d)) { /* both bits 0 */
        y[0] = y[1] = y[2] = y[3] = 0;
        continue;
      }
      y[0] = y[1] = y[2] = y[3] = INT64_MAX;
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
 * (it->bside) nor curved boundary (reduced over the ranks: every piece sees
 * the same), and no corner, ridge or required vertex; the surface vertices, the same on a smooth curved
 * boundary; it->vinner and it->vsurf as described at the top of the
 * file. */
static pa_status inner_vertices(pa__iter *it, pa_dmesh_value *val) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = it->dm;
  pa_idx nloc = dm->nloc[PA_VERTEX];
  uint8_t *smooth = NULL;
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
  PA_ALLOC(smooth, nloc);
  PA_CALL(curved_vertices(it, it->vinner)); /* 1: curved, for now */
  if (dm->dim == 3) /* 2D: no surface vertices (bisect.c) */
    PA_CALL(surface_vertices(it, smooth));
  else
    memset(smooth, 0, (size_t)nloc);
  {
    const int *d = pa_dmesh_value_data(val, NULL, NULL);
    const uint8_t *vf = dm->mesh->vflag;
    for (pa_idx v = 0; v < nloc; v++) {
      int labelled = it->vlab[4 * v + 1] != NOLABEL;
      int ok = labelled && !d[2 * v] &&
               !(vf[v] & (PA_FLAG_CORNER | PA_FLAG_RIDGE | PA_FLAG_REQUIRED));
      it->vinner[v] = (uint8_t)(ok && !it->vinner[v] ? PA_ADAPT_INNER_TRANSIT
                                : ok && smooth[v]    ? PA_ADAPT_SURFACE_TRANSIT
                                : labelled           ? PA_ADAPT_LABELLED_TRANSIT
                                                     : 0);
      if (it->vsurf && d[2 * v]) it->vsurf[4 * (size_t)v + 3] += (double)PA_ADAPT_HARD_BIT;
    }
  }
cleanup:
  pa__free(smooth);
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
