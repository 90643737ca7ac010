/*
 * bisect_remesher.c -- longest-edge bisection as a padapt remesher plug-in.
 *
 * It uses only the public API of padapt.h, as a third-party remesher would,
 * and shows what the plug-in contract asks for (see pa_remesher): adapt the
 * mesh in place to its metric, keep PA_FLAG_REQUIRED entities bit for bit,
 * interpolate the metric and the user fields onto new vertices, report an
 * outcome.
 *
 * Algorithm: passes until no edge can be split (or 200 passes). Each pass
 * lists the edges (vertex pairs with the elements around them, by sorting
 * the element edge instances), keeps those longer than sqrt(2) in the
 * metric, not frozen, and longest in every element around them (Rivara's
 * terminal edges: an element is only cut through its longest edge, so the
 * quality stays bounded and the refinement cannot run away next to a long
 * frozen edge -- such elements are left alone), and splits them longest
 * first (ties by vertex indices, so the result is deterministic). Splitting edge ab at its midpoint m replaces
 * every element around ab by its two halves (b -> m and a -> m), which keeps
 * the mesh conforming and the orientation positive; boundary entities and
 * feature edges containing ab are split the same way. An element is split
 * at most once per pass: an edge whose elements were already split in this
 * pass waits for the next pass. Capacity is reserved before each pass, so a
 * pass never fails half-way: on an allocation error the mesh is valid and
 * conforming (possibly partly refined).
 *
 * An edge is frozen when it is an edge of a required element, of a required
 * boundary entity, or a required feature edge.
 */
#include "bisect_remesher.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define LONG_EDGE 1.4142
#define SHORT_EDGE 0.7071
#define MAX_PASSES 200

/* One occurrence of edge (a, b), a < b, in entity `ent` (element, boundary
 * entity or feature edge). */
typedef struct inst {
  pa_idx a, b, ent;
} inst;

typedef struct cand {
  double len;
  pa_idx a, b;
  size_t first, last; /* element instances [first, last) */
} cand;

static int inst_cmp(const void *x, const void *y) {
  const inst *p = x, *q = y;
  if (p->a != q->a) return p->a < q->a ? -1 : 1;
  if (p->b != q->b) return p->b < q->b ? -1 : 1;
  return p->ent < q->ent ? -1 : p->ent > q->ent;
}

static int cand_cmp(const void *x, const void *y) {
  const cand *p = x, *q = y;
  if (p->len != q->len) return p->len > q->len ? -1 : 1;
  if (p->a != q->a) return p->a < q->a ? -1 : 1;
  return p->b < q->b ? -1 : p->b > q->b;
}

/* Edge instances of n entities of k vertices each (conn), sorted. */
static inst *instances(const pa_idx *conn, pa_idx n, int k, size_t *count) {
  size_t per = (size_t)k * (k - 1) / 2, c = 0;
  inst *in = malloc((n * per + 1) * sizeof *in);
  if (!in) return NULL;
  for (pa_idx e = 0; e < n; e++) {
    const pa_idx *v = conn + (size_t)k * e;
    for (int i = 0; i < k; i++)
      for (int j = i + 1; j < k; j++) {
        pa_idx a = v[i] < v[j] ? v[i] : v[j], b = v[i] < v[j] ? v[j] : v[i];
        in[c++] = (inst){a, b, e};
      }
  }
  qsort(in, c, sizeof *in, inst_cmp);
  *count = c;
  return in;
}

/* Range [*lo, *hi) of the instances of edge (a, b) in a sorted list. */
static void find_range(const inst *in, size_t n, pa_idx a, pa_idx b,
                       size_t *lo, size_t *hi) {
  size_t l = 0, h = n;
  while (l < h) {
    size_t m = (l + h) / 2;
    if (in[m].a < a || (in[m].a == a && in[m].b < b)) l = m + 1;
    else h = m;
  }
  *lo = l;
  while (l < n && in[l].a == a && in[l].b == b) l++;
  *hi = l;
}

static double edge_len(pa_mesh *m, pa_idx a, pa_idx b) {
  int d = pa_mesh_dim(m), nc = pa_mesh_metric_ncomp(m);
  const double *x = pa_mesh_coords(m), *met = pa_mesh_metric(m);
  return pa_metric_edge_length(d, nc, x + (size_t)d * a, x + (size_t)d * b,
                               met + (size_t)nc * a, met + (size_t)nc * b);
}

/* Add the midpoint of edge ab with interpolated metric and fields. */
static pa_status add_midpoint(pa_mesh *m, pa_idx a, pa_idx b, pa_idx *mid) {
  int d = pa_mesh_dim(m), nc = pa_mesh_metric_ncomp(m);
  double x[3];
  const double *c = pa_mesh_coords(m);
  for (int k = 0; k < d; k++)
    x[k] = 0.5 * (c[(size_t)d * a + k] + c[(size_t)d * b + k]);
  pa_status st = pa_mesh_add_vertex(m, x, 0, mid);
  if (st) return st;
  double *met = pa_mesh_metric(m);
  for (int k = 0; k < nc; k++) {
    double ma = met[(size_t)nc * a + k], mb = met[(size_t)nc * b + k];
    met[(size_t)nc * *mid + k] = nc == 1 ? sqrt(ma * mb) : 0.5 * (ma + mb);
  }
  for (int f = 0; f < pa_mesh_nfield(m); f++) {
    int fc;
    double *val;
    pa_mesh_field(m, f, NULL, &fc, &val);
    for (int k = 0; k < fc; k++)
      val[(size_t)fc * *mid + k] =
          0.5 * (val[(size_t)fc * a + k] + val[(size_t)fc * b + k]);
  }
  return PA_SUCCESS;
}

/* Split the entities listed in in[lo, hi) (k vertices each, arrays of the
 * mesh fetched by the caller after the reserve) at mid. */
static pa_status split_entities(pa_mesh *m, int kind, const inst *in,
                                size_t lo, size_t hi, pa_idx mid) {
  int d = pa_mesh_dim(m);
  int k = kind == 0 ? d + 1 : kind == 1 ? d : 2;
  for (size_t q = lo; q < hi; q++) {
    pa_idx e = in[q].ent;
    pa_idx *conn = kind == 0 ? pa_mesh_elems(m) : kind == 1 ? pa_mesh_bdrys(m)
                                                            : pa_mesh_edges(m);
    int32_t *ref = kind == 0 ? pa_mesh_elem_refs(m) : kind == 1 ? pa_mesh_bdry_refs(m)
                                                                : pa_mesh_edge_refs(m);
    uint8_t *fl = kind == 0 ? pa_mesh_elem_flags(m) : kind == 1 ? pa_mesh_bdry_flags(m)
                                                                : pa_mesh_edge_flags(m);
    pa_idx v[4], idx;
    memcpy(v, conn + (size_t)k * e, (size_t)k * sizeof *v);
    int32_t r = ref[e];
    uint8_t f = fl[e];
    for (int i = 0; i < k; i++)
      if (v[i] == in[q].b) v[i] = mid; /* the half on a's side */
    for (int i = 0; i < k; i++)
      if (conn[(size_t)k * e + i] == in[q].a) conn[(size_t)k * e + i] = mid;
    pa_status st = kind == 0 ? pa_mesh_add_elem(m, v, r, &idx)
                   : kind == 1 ? pa_mesh_add_bdry(m, v, r, &idx)
                               : pa_mesh_add_edge(m, v, r, &idx);
    if (st) return st;
    fl = kind == 0 ? pa_mesh_elem_flags(m) : kind == 1 ? pa_mesh_bdry_flags(m)
                                                       : pa_mesh_edge_flags(m);
    fl[idx] = f;
  }
  return PA_SUCCESS;
}

/* One pass; *nsplit receives the number of edges split, *nlong the number
 * of long edges that cannot be split (frozen), *nshort the number of short
 * edges (not frozen). */
static pa_status pass(pa_mesh *m, long *nsplit, long *nlong, long *nshort) {
  pa_status st = PA_SUCCESS;
  int d = pa_mesh_dim(m);
  pa_idx ne = pa_mesh_nelem(m), nb = pa_mesh_nbdry(m), ned = pa_mesh_nedge(m);
  size_t nei = 0, nbi = 0, ndi = 0, nc = 0, grow_e = 0, grow_b = 0, grow_d = 0;
  inst *ei = NULL, *bi = NULL, *di = NULL;
  cand *c = NULL;
  double *lens = NULL;
  size_t *best = NULL;
  uint8_t *touched = NULL, *frozen = NULL;
  *nsplit = *nlong = *nshort = 0;
  ei = instances(pa_mesh_elems(m), ne, d + 1, &nei);
  bi = instances(pa_mesh_bdrys(m), nb, d, &nbi);
  di = instances(pa_mesh_edges(m), ned, 2, &ndi);
  c = malloc((nei + 1) * sizeof *c);
  touched = calloc((size_t)ne + 1, 1);
  frozen = calloc(nei + 1, 1);
  if (!ei || !bi || !di || !c || !touched || !frozen) {
    st = PA_ERR_MEMORY;
    goto cleanup;
  }
  /* frozen edges: marked on their element instances */
  {
    const uint8_t *ef = pa_mesh_elem_flags(m), *bf = pa_mesh_bdry_flags(m),
                  *df = pa_mesh_edge_flags(m);
    for (size_t q = 0; q < nei;) {
      size_t r = q;
      int fr = 0;
      while (r < nei && ei[r].a == ei[q].a && ei[r].b == ei[q].b)
        fr |= (ef[ei[r++].ent] & PA_FLAG_REQUIRED) != 0;
      size_t lo, hi;
      find_range(bi, nbi, ei[q].a, ei[q].b, &lo, &hi);
      for (size_t s = lo; s < hi; s++) fr |= (bf[bi[s].ent] & PA_FLAG_REQUIRED) != 0;
      find_range(di, ndi, ei[q].a, ei[q].b, &lo, &hi);
      for (size_t s = lo; s < hi; s++) fr |= (df[di[s].ent] & PA_FLAG_REQUIRED) != 0;
      for (size_t s = q; s < r; s++) frozen[s] = (uint8_t)fr;
      q = r;
    }
  }
  /* edge lengths, and the longest edge of every element (ties: the edge
   * with the smaller vertex pair) */
  lens = malloc((nei + 1) * sizeof *lens);
  best = malloc(((size_t)ne + 1) * sizeof *best);
  if (!lens || !best) {
    st = PA_ERR_MEMORY;
    goto cleanup;
  }
  for (pa_idx e = 0; e < ne; e++) best[e] = (size_t)-1;
  for (size_t q = 0; q < nei;) {
    size_t r = q;
    while (r < nei && ei[r].a == ei[q].a && ei[r].b == ei[q].b) r++;
    double len = edge_len(m, ei[q].a, ei[q].b);
    for (size_t s = q; s < r; s++) {
      lens[s] = len;
      size_t *b = &best[ei[s].ent];
      if (*b == (size_t)-1 || len > lens[*b] ||
          (len == lens[*b] && inst_cmp(&ei[s], &ei[*b]) < 0))
        *b = s;
    }
    q = r;
  }
  /* candidates: long, not frozen, the longest edge of all their elements
   * (Rivara's terminal edges, so elements are only ever cut through their
   * longest edge and keep their quality) */
  for (size_t q = 0; q < nei;) {
    size_t r = q;
    int terminal = 1;
    while (r < nei && ei[r].a == ei[q].a && ei[r].b == ei[q].b) {
      const inst *b = &ei[best[ei[r].ent]];
      terminal &= b->a == ei[q].a && b->b == ei[q].b;
      r++;
    }
    double len = lens[q];
    if (len > LONG_EDGE) {
      if (frozen[q]) {
        (*nlong)++;
      } else if (terminal) {
        c[nc++] = (cand){len, ei[q].a, ei[q].b, q, r};
        size_t lo, hi;
        grow_e += r - q;
        find_range(bi, nbi, ei[q].a, ei[q].b, &lo, &hi);
        grow_b += hi - lo;
        find_range(di, ndi, ei[q].a, ei[q].b, &lo, &hi);
        grow_d += hi - lo;
      }
    } else if (len < SHORT_EDGE && !frozen[q]) {
      (*nshort)++;
    }
    q = r;
  }
  if (nc == 0) goto cleanup;
  qsort(c, nc, sizeof *c, cand_cmp);
  st = pa_mesh_reserve(m, pa_mesh_nvert(m) + (pa_idx)nc, ne + (pa_idx)grow_e,
                       nb + (pa_idx)grow_b, ned + (pa_idx)grow_d);
  if (st) goto cleanup;
  for (size_t k = 0; k < nc; k++) {
    int busy = 0;
    for (size_t q = c[k].first; q < c[k].last && !busy; q++) busy = touched[ei[q].ent];
    if (busy) continue;
    pa_idx mid;
    size_t lo, hi;
    st = add_midpoint(m, c[k].a, c[k].b, &mid);
    if (st) goto cleanup;
    st = split_entities(m, 0, ei, c[k].first, c[k].last, mid);
    if (st) goto cleanup;
    find_range(bi, nbi, c[k].a, c[k].b, &lo, &hi);
    st = split_entities(m, 1, bi, lo, hi, mid);
    if (st) goto cleanup;
    find_range(di, ndi, c[k].a, c[k].b, &lo, &hi);
    st = split_entities(m, 2, di, lo, hi, mid);
    if (st) goto cleanup;
    for (size_t q = c[k].first; q < c[k].last; q++) touched[ei[q].ent] = 1;
    (*nsplit)++;
  }
cleanup:
  free(ei);
  free(bi);
  free(di);
  free(c);
  free(lens);
  free(best);
  free(touched);
  free(frozen);
  return st;
}

static pa_status bisect(void *ctx, pa_mesh *m, const pa_remesh_opts *opts,
                        pa_remesh_report *report) {
  (void)ctx;
  (void)opts;
  long nsplit = 0, nlong = 0, nshort = 0;
  int npass = 0;
  pa_status st = PA_SUCCESS;
  if (pa_mesh_metric_ncomp(m) == 0) return PA_ERR_ARG;
  for (npass = 0; npass < MAX_PASSES; npass++) {
    long n;
    st = pass(m, &n, &nlong, &nshort);
    if (st) break;
    nsplit += n;
    if (n == 0) break;
  }
  report->nsplit = nsplit;
  report->npass = npass;
  report->outcome = st ? PA_REMESH_FAILED
                    : (nlong || nshort || npass == MAX_PASSES)
                        ? PA_REMESH_TARGET_MISSED
                        : PA_REMESH_SUCCESS;
  return st;
}

const pa_remesher *bisect_remesher(void) {
  static const pa_remesher r = {"bisect", (1u << 2) | (1u << 3), bisect, NULL};
  return &r;
}
