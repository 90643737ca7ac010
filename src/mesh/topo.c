/*
 * topo.c -- mesh topology: element faces, element adjacency, vertex balls,
 * boundary-entity lookup, volumes, completion of the boundary and the mesh
 * checker (pa__mesh_check: everything pa_mesh_check checks but the metric
 * values, which metric/ops.c checks).
 *
 * Derived structures are caches owned by the mesh (mesh.h): adja, ball_start
 * and ball, bhash. Each is built on first request and stays valid until
 * pa__mesh_invalidate() frees it. Building never changes the entities.
 *
 * Adjacency is built without hashing and without per-face allocation: every
 * element face is put in the bucket of its smallest vertex (a counting sort),
 * then the faces of one bucket are sorted by their two other vertices (one in
 * 2D) and equal neighbours paired. Meshes numbered with some locality (all
 * generated and most read ones) keep the elements of a bucket close in memory,
 * so the three passes run at memory speed (docs/BENCHMARKS.md, "The
 * distributed mesh").
 *
 * The boundary lookup (bhash) is an open-addressing table with linear probing
 * of boundary-entity indices, keyed by the entity's sorted vertex tuple; the
 * table has a power-of-two capacity of at least twice the number of entities.
 * When an entity is listed twice, the table keeps the first.
 *
 * Messages name entities 1-based, as Medit files do.
 */
#include "mesh/mesh.h"

#include <math.h>
#include <stdio.h>

/* Local vertices of face i of a triangle / tetrahedron, oriented outward. */
static const int face_tri[3][2] = {{1, 2}, {2, 0}, {0, 1}};
static const int face_tet[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3},
                                      {0, 2, 1}};

void pa__elem_face(const pa_mesh *mesh, pa_idx e, int i, pa_idx *face) {
  const pa_idx *v = mesh->elem + (size_t)(mesh->dim + 1) * e;
  if (mesh->dim == 2) {
    face[0] = v[face_tri[i][0]];
    face[1] = v[face_tri[i][1]];
  } else {
    face[0] = v[face_tet[i][0]];
    face[1] = v[face_tet[i][1]];
    face[2] = v[face_tet[i][2]];
  }
}

double pa__simplex_volume(int dim, const double *const *x) {
  if (dim == 2) {
    double ux = x[1][0] - x[0][0], uy = x[1][1] - x[0][1];
    double vx = x[2][0] - x[0][0], vy = x[2][1] - x[0][1];
    return 0.5 * (ux * vy - uy * vx);
  }
  double u[3], v[3], w[3];
  for (int k = 0; k < 3; k++) {
    u[k] = x[1][k] - x[0][k];
    v[k] = x[2][k] - x[0][k];
    w[k] = x[3][k] - x[0][k];
  }
  return (u[0] * (v[1] * w[2] - v[2] * w[1]) +
          u[1] * (v[2] * w[0] - v[0] * w[2]) +
          u[2] * (v[0] * w[1] - v[1] * w[0])) /
         6.0;
}

double pa_mesh_elem_volume(const pa_mesh *mesh, pa_idx e) {
  if (!mesh || e < 0 || e >= mesh->ne) return NAN;
  const double *x[4];
  const pa_idx *v = mesh->elem + (size_t)(mesh->dim + 1) * e;
  for (int k = 0; k <= mesh->dim; k++)
    x[k] = mesh->coord + (size_t)mesh->dim * v[k];
  return pa__simplex_volume(mesh->dim, x);
}

double pa_mesh_volume(const pa_mesh *mesh) {
  if (!mesh) return NAN;
  pa__ksum sum = {0, 0};
  for (pa_idx e = 0; e < mesh->ne; e++)
    pa__ksum_add(&sum, pa_mesh_elem_volume(mesh, e));
  return sum.s + sum.c;
}

/* ---- adjacency ---------------------------------------------------------- */

/* A face in its bucket: the other vertices packed in key, then its code. */
typedef struct face_rec {
  uint64_t key;
  pa_idx code;
} face_rec;

/* Records in order of (key, code): codes are distinct, so the order is
 * total, and equal keys keep the increasing codes their bucket gives them. */
static inline int face_rec_less(face_rec a, face_rec b) {
  return a.key < b.key || (a.key == b.key && a.code < b.code);
}

static void face_rec_insertion(face_rec *r, pa_idx n) {
  for (pa_idx i = 1; i < n; i++) {
    face_rec x = r[i];
    pa_idx j = i - 1;
    while (j >= 0 && face_rec_less(x, r[j])) {
      r[j + 1] = r[j];
      j--;
    }
    r[j + 1] = x;
  }
}

/* Quicksort (median of three, the smaller side first so the stack stays
 * below 2 log2 n) down to runs of 16, which insertion sort finishes. A
 * bucket holds a few dozen faces, rarely a few hundred. */
static void face_rec_sort(face_rec *r, pa_idx n) {
  pa_idx lo_stack[64], hi_stack[64];
  int top = 0;
  pa_idx lo = 0, hi = n;
  for (;;) {
    while (hi - lo > 16) {
      face_rec *a = r + lo, *b = r + lo + (hi - lo) / 2, *c = r + hi - 1, t;
      if (face_rec_less(*b, *a)) { t = *a; *a = *b; *b = t; }
      if (face_rec_less(*c, *b)) { t = *b; *b = *c; *c = t; }
      if (face_rec_less(*b, *a)) { t = *a; *a = *b; *b = t; }
      face_rec piv = *b;
      pa_idx i = lo, j = hi - 1;
      for (;;) {
        while (face_rec_less(r[i], piv)) i++;
        while (face_rec_less(piv, r[j])) j--;
        if (i >= j) break;
        t = r[i];
        r[i] = r[j];
        r[j] = t;
        i++;
        j--;
      }
      /* [lo, j] <= piv <= [j+1, hi) */
      if (j + 1 - lo < hi - (j + 1)) {
        lo_stack[top] = j + 1;
        hi_stack[top++] = hi;
        hi = j + 1;
      } else {
        lo_stack[top] = lo;
        hi_stack[top++] = j + 1;
        lo = j + 1;
      }
    }
    face_rec_insertion(r + lo, hi - lo);
    if (!top) break;
    top--;
    lo = lo_stack[top];
    hi = hi_stack[top];
  }
}

/* Sorted vertices of face i (opposite local vertex i) of element vertices v. */
static inline void sorted_face(const pa_idx *v, int dim, int i, pa_idx *s) {
  int n = 0;
  for (int k = 0; k <= dim; k++)
    if (k != i) s[n++] = v[k];
  if (s[0] > s[1]) { pa_idx t = s[0]; s[0] = s[1]; s[1] = t; }
  if (dim == 3) {
    if (s[1] > s[2]) { pa_idx t = s[1]; s[1] = s[2]; s[2] = t; }
    if (s[0] > s[1]) { pa_idx t = s[0]; s[0] = s[1]; s[1] = t; }
  }
}

/* Fail unless (dim+1)*count fits a pa_idx (face codes, ball sizes). */
static pa_status check_code_range(const pa_mesh *m) {
  if ((int64_t)(m->dim + 1) * m->ne > INT32_MAX)
    return pa__error(PA_ERR_UNSUPPORTED, __FILE__, __LINE__,
                     "%d elements are too many for 32-bit face codes",
                     (int)m->ne);
  return PA_SUCCESS;
}

/* Fail with PA_ERR_MESH on the first element vertex index out of range. */
static pa_status check_elem_range(const pa_mesh *m) {
  pa_status st = PA_SUCCESS;
  size_t n = (size_t)(m->dim + 1) * m->ne;
  for (size_t k = 0; k < n; k++)
    PA_CHECK((uint32_t)m->elem[k] < (uint32_t)m->nv, PA_ERR_MESH,
             "element %zu references vertex %lld, out of range (the mesh has "
             "%d vertices)",
             k / (size_t)(m->dim + 1) + 1, (long long)m->elem[k] + 1,
             (int)m->nv);
cleanup:
  return st;
}

/* Compute the adjacency of m's elements into a new array *out. Always
 * inlined in adja_compute with a constant dim, so that divisions by nf and the
 * small loops are specialised. */
static inline __attribute__((always_inline)) pa_status
adja_compute_dim(const pa_mesh *m, const int dim, pa_idx **out) {
  pa_status st = PA_SUCCESS;
  pa_idx *start = NULL, *bucket = NULL, *adja = NULL;
  face_rec *rec = NULL;
  const int nf = dim + 1;
  const pa_idx nv = m->nv, ne = m->ne;
  *out = NULL;
  PA_CALL(check_code_range(m));
  PA_CALL(check_elem_range(m));
  size_t nface = (size_t)nf * ne;
  PA_CALLOC(start, (size_t)nv + 1);
  PA_ALLOC(bucket, nface);
  PA_ALLOC(adja, nface);

  /* Count the faces of each bucket; a face's smallest vertex is the element's
   * smallest, except for the face opposite it (second smallest). */
  for (pa_idx e = 0; e < ne; e++) {
    const pa_idx *v = m->elem + (size_t)nf * e;
    pa_idx m1 = INT32_MAX, m2 = INT32_MAX;
    for (int k = 0; k < nf; k++) {
      if (v[k] < m1) {
        m2 = m1;
        m1 = v[k];
      } else if (v[k] < m2) {
        m2 = v[k];
      }
    }
    start[m1 + 1] += dim;
    start[m2 + 1] += 1;
  }
  pa_idx maxb = 0;
  for (pa_idx v = 0; v < nv; v++) {
    if (start[v + 1] > maxb) maxb = start[v + 1];
    start[v + 1] += start[v];
  }
  /* Fill: afterwards start[v] is the end of bucket v, shifted back below. */
  for (pa_idx e = 0; e < ne; e++) {
    const pa_idx *v = m->elem + (size_t)nf * e;
    int p1 = 0;
    for (int k = 1; k < nf; k++)
      if (v[k] < v[p1]) p1 = k;
    int p2 = p1 == 0 ? 1 : 0;
    for (int k = 0; k < nf; k++)
      if (k != p1 && v[k] < v[p2]) p2 = k;
    for (int i = 0; i < nf; i++) {
      pa_idx mn = i == p1 ? v[p2] : v[p1];
      bucket[start[mn]++] = nf * e + i;
    }
  }
  for (pa_idx v = nv; v > 0; v--) start[v] = start[v - 1];
  start[0] = 0;

  /* Pair equal faces inside each bucket. */
  PA_ALLOC(rec, maxb);
  for (pa_idx v = 0; v < nv; v++) {
    pa_idx b0 = start[v], n = start[v + 1] - b0;
    for (pa_idx k = 0; k < n; k++) {
      pa_idx code = bucket[b0 + k], e = code / nf, s[3];
      sorted_face(m->elem + (size_t)nf * e, dim, code - nf * e, s);
      rec[k].key = dim == 2 ? (uint64_t)(uint32_t)s[1]
                            : (uint64_t)(uint32_t)s[1] << 32 | (uint32_t)s[2];
      rec[k].code = code;
    }
    face_rec_sort(rec, n);
    for (pa_idx k = 0; k < n;) {
      pa_idx k1 = k + 1;
      while (k1 < n && rec[k1].key == rec[k].key) k1++;
      if (k1 - k == 1) {
        adja[rec[k].code] = -1;
      } else if (k1 - k == 2) {
        adja[rec[k].code] = rec[k + 1].code;
        adja[rec[k + 1].code] = rec[k].code;
      } else {
        char face[64];
        uint64_t key = rec[k].key;
        /* two of them with the same opposite vertex: one element twice */
        for (pa_idx a = k; a < k1; a++)
          for (pa_idx b = a + 1; b < k1; b++)
            PA_CHECK(m->elem[rec[a].code] != m->elem[rec[b].code], PA_ERR_MESH,
                     "elements %d and %d have the same vertices (a "
                     "duplicated element): remove one",
                     (int)(rec[a].code / nf) + 1, (int)(rec[b].code / nf) + 1);
        if (dim == 2)
          snprintf(face, sizeof face, "%d %d", (int)v + 1, (int)key + 1);
        else
          snprintf(face, sizeof face, "%d %d %d", (int)v + 1,
                   (int)(key >> 32) + 1, (int)(key & 0xffffffffu) + 1);
        PA_FAIL(PA_ERR_MESH,
                "face (%s) is shared by more than two elements (elements %d, "
                "%d, %d%s)",
                face, (int)(rec[k].code / nf) + 1,
                (int)(rec[k + 1].code / nf) + 1,
                (int)(rec[k + 2].code / nf) + 1, k1 - k > 3 ? ", ..." : "");
      }
      k = k1;
    }
  }
  *out = adja;
  adja = NULL;
cleanup:
  pa__free(start);
  pa__free(bucket);
  pa__free(adja);
  pa__free(rec);
  return st;
}

static pa_status adja_compute(const pa_mesh *m, pa_idx **out) {
  return m->dim == 2 ? adja_compute_dim(m, 2, out) : adja_compute_dim(m, 3, out);
}

pa_status pa_mesh_build_adjacency(pa_mesh *mesh, const pa_idx **adja) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(mesh, PA_ERR_ARG, "pa_mesh_build_adjacency: NULL mesh");
  if (!mesh->adja) PA_CALL(adja_compute(mesh, &mesh->adja));
  if (adja) *adja = mesh->adja;
cleanup:
  return st;
}

/* ---- vertex balls ------------------------------------------------------- */

pa_status pa__balls_of(const pa_idx *elem, pa_idx ne, int nve, pa_idx nv,
                       const uint8_t *need, pa_idx **pstart, pa_idx **pball) {
  pa_status st = PA_SUCCESS;
  pa_idx *start = NULL, *ball = NULL;
  size_t n = (size_t)nve * ne;
  *pstart = *pball = NULL;
  PA_CALLOC(start, (size_t)nv + 1);
  for (size_t k = 0; k < n; k++)
    if (!need || need[elem[k]]) start[elem[k] + 1]++;
  for (pa_idx v = 0; v < nv; v++) start[v + 1] += start[v];
  PA_ALLOC(ball, start[nv] ? (size_t)start[nv] : 1);
  for (size_t k = 0; k < n; k++)
    if (!need || need[elem[k]]) ball[start[elem[k]]++] = (pa_idx)(k / (size_t)nve);
  for (pa_idx v = nv; v > 0; v--) start[v] = start[v - 1];
  start[0] = 0;
  *pstart = start;
  *pball = ball;
  start = ball = NULL;
cleanup:
  pa__free(start);
  pa__free(ball);
  return st;
}

pa_status pa__balls(const pa_idx *elem, pa_idx ne, int nve, pa_idx nv,
                    pa_idx **pstart, pa_idx **pball) {
  return pa__balls_of(elem, ne, nve, nv, NULL, pstart, pball);
}

pa_status pa__edges_csr(const pa_idx *elem, pa_idx ne, int nve, pa_idx nv,
                        const pa_gid *key, size_t **pstart, pa_idx **pother) {
  pa_status st = PA_SUCCESS;
  size_t *start = NULL;
  pa_idx *other = NULL, *mark = NULL;
  *pstart = NULL;
  *pother = NULL;
#define LOW(a, b) ((key ? key[a] < key[b] : (a) < (b)) ? (a) : (b))
  PA_CALLOC(start, (size_t)nv + 1);
  for (pa_idx e = 0; e < ne; e++) {
    const pa_idx *v = elem + (size_t)nve * e;
    for (int i = 0; i < nve; i++)
      for (int j = i + 1; j < nve; j++)
        if (v[i] != v[j]) start[LOW(v[i], v[j]) + 1]++;
  }
  for (pa_idx a = 0; a < nv; a++) start[a + 1] += start[a];
  PA_ALLOC(other, start[nv] ? start[nv] : 1);
  for (pa_idx e = 0; e < ne; e++) { /* start[a] moves to the end of a's range */
    const pa_idx *v = elem + (size_t)nve * e;
    for (int i = 0; i < nve; i++)
      for (int j = i + 1; j < nve; j++)
        if (v[i] != v[j]) {
          pa_idx a = LOW(v[i], v[j]);
          other[start[a]++] = a == v[i] ? v[j] : v[i];
        }
  }
#undef LOW
  for (pa_idx a = nv; a > 0; a--) start[a] = start[a - 1];
  start[0] = 0;
  /* keep the first instance of each edge, compacting in place */
  PA_ALLOC(mark, nv ? (size_t)nv : 1);
  for (pa_idx a = 0; a < nv; a++) mark[a] = -1;
  size_t w = 0;
  for (pa_idx a = 0; a < nv; a++) {
    size_t b0 = start[a], b1 = start[a + 1];
    start[a] = w;
    for (size_t k = b0; k < b1; k++)
      if (mark[other[k]] != a) {
        mark[other[k]] = a;
        other[w++] = other[k];
      }
  }
  start[nv] = w;
  *pstart = start;
  *pother = other;
  start = NULL;
  other = NULL;
cleanup:
  pa__free(start);
  pa__free(other);
  pa__free(mark);
  return st;
}

static pa_status balls_compute(const pa_mesh *m, pa_idx **pstart,
                               pa_idx **pball) {
  pa_status st = PA_SUCCESS;
  pa_idx *start = NULL, *ball = NULL;
  const int nf = m->dim + 1;
  const pa_idx nv = m->nv, ne = m->ne;
  *pstart = *pball = NULL;
  PA_CALL(check_code_range(m));
  PA_CALL(check_elem_range(m));
  PA_CALL(pa__balls(m->elem, ne, nf, nv, &start, &ball));
  *pstart = start;
  *pball = ball;
  start = ball = NULL;
cleanup:
  pa__free(start);
  pa__free(ball);
  return st;
}

pa_status pa_mesh_build_balls(pa_mesh *mesh, const pa_idx **start,
                              const pa_idx **ball) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(mesh, PA_ERR_ARG, "pa_mesh_build_balls: NULL mesh");
  if (!mesh->ball_start) {
    pa__free(mesh->ball);
    mesh->ball = NULL;
    PA_CALL(balls_compute(mesh, &mesh->ball_start, &mesh->ball));
  }
  if (start) *start = mesh->ball_start;
  if (ball) *ball = mesh->ball;
cleanup:
  return st;
}

/* ---- boundary lookup ---------------------------------------------------- */

/* Slot of the table holding the entity with sorted vertices key, or else the
 * empty slot where it would go. */
static size_t bhash_probe(const pa_mesh *m, const pa_idx *bh, size_t cap,
                          const pa_idx *key) {
  const int d = m->dim;
  size_t mask = cap - 1, h = (size_t)pa__hash_idx(key, d) & mask;
  for (;;) {
    pa_idx b = bh[h];
    if (b < 0) return h;
    pa_idx s[3];
    memcpy(s, m->bdry + (size_t)d * b, (size_t)d * sizeof *s);
    pa__sort_small(s, d);
    if (s[0] == key[0] && s[1] == key[1] && (d == 2 || s[2] == key[2]))
      return h;
    h = (h + 1) & mask;
  }
}

static pa_status bhash_compute(const pa_mesh *m, pa_idx **out, size_t *pcap) {
  pa_status st = PA_SUCCESS;
  pa_idx *bh = NULL;
  const int d = m->dim;
  size_t cap = 16;
  while (cap < 2 * (size_t)m->nb) cap *= 2;
  PA_ALLOC(bh, cap);
  memset(bh, 0xff, cap * sizeof *bh);
  for (pa_idx b = 0; b < m->nb; b++) {
    pa_idx s[3];
    memcpy(s, m->bdry + (size_t)d * b, (size_t)d * sizeof *s);
    pa__sort_small(s, d);
    size_t h = bhash_probe(m, bh, cap, s);
    if (bh[h] < 0) bh[h] = b;
  }
  *out = bh;
  *pcap = cap;
cleanup:
  return st;
}

/* Build the boundary lookup table if it is not cached. */
static pa_status bhash_build(pa_mesh *m) {
  if (m->bhash) return PA_SUCCESS;
  return bhash_compute(m, &m->bhash, &m->bhash_cap);
}

/* Index of the listed boundary entity with vertices v (any order), or -1. */
static pa_idx bhash_find(const pa_mesh *m, const pa_idx *v) {
  pa_idx s[3];
  memcpy(s, v, (size_t)m->dim * sizeof *s);
  pa__sort_small(s, m->dim);
  return m->bhash[bhash_probe(m, m->bhash, m->bhash_cap, s)];
}

pa_status pa_mesh_find_bdry(pa_mesh *mesh, const pa_idx *v, pa_idx *index) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(mesh && v && index, PA_ERR_ARG, "pa_mesh_find_bdry: NULL argument");
  *index = -1;
  PA_CALL(bhash_build(mesh));
  *index = bhash_find(mesh, v);
cleanup:
  return st;
}

pa_status pa_mesh_build_boundary(pa_mesh *mesh, int32_t ref, pa_idx *nadded) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(mesh, PA_ERR_ARG, "pa_mesh_build_boundary: NULL mesh");
  if (nadded) *nadded = 0;
  const int d = mesh->dim, nf = d + 1;
  const pa_idx *adja = NULL;
  PA_CALL(pa_mesh_build_adjacency(mesh, &adja));
  PA_CALL(bhash_build(mesh));
  int64_t nadd = 0;
  for (size_t c = 0; c < (size_t)nf * mesh->ne; c++) {
    if (adja[c] >= 0) continue;
    pa_idx f[3];
    pa__elem_face(mesh, (pa_idx)(c / nf), (int)(c % nf), f);
    if (bhash_find(mesh, f) < 0) nadd++;
  }
  if (nadd == 0) goto cleanup;
  PA_CHECK(mesh->nb + nadd <= INT32_MAX, PA_ERR_ARG,
           "too many boundary entities (%lld)", (long long)(mesh->nb + nadd));
  PA_CALL(pa_mesh_reserve(mesh, mesh->nv, mesh->ne, (pa_idx)(mesh->nb + nadd),
                          mesh->ned));
  /* Lookups above use the table of the old list; append after them all. */
  pa_idx nb = mesh->nb;
  for (size_t c = 0; c < (size_t)nf * mesh->ne; c++) {
    if (adja[c] >= 0) continue;
    pa_idx f[3];
    pa__elem_face(mesh, (pa_idx)(c / nf), (int)(c % nf), f);
    if (bhash_find(mesh, f) >= 0) continue;
    memcpy(mesh->bdry + (size_t)d * nb, f, (size_t)d * sizeof *f);
    mesh->bref[nb] = ref;
    mesh->bflag[nb] = 0;
    nb++;
  }
  PA_ASSERT(nb == mesh->nb + nadd);
  pa__mesh_zero_values(mesh, PA_BOUNDARY, (size_t)mesh->nb, (size_t)nb);
  mesh->nb = nb;
  /* Elements are unchanged, so adjacency and balls stay valid. */
  pa__free(mesh->bhash);
  mesh->bhash = NULL;
  mesh->bhash_cap = 0;
  if (nadded) *nadded = (pa_idx)nadd;
cleanup:
  return st;
}

/* ---- checker ------------------------------------------------------------ */

/* Write the 1-based vertices of n indices as "a b c" into buf. */
static const char *fmt_verts(char *buf, size_t len, const pa_idx *v, int n) {
  int w = 0;
  buf[0] = '\0';
  for (int k = 0; k < n && w >= 0 && (size_t)w < len; k++)
    w += snprintf(buf + w, len - (size_t)w, k ? " %lld" : "%lld",
                  (long long)v[k] + 1);
  return buf;
}

/* Vertex indices of count cells of nvc vertices: in range and distinct. */
static pa_status check_cells(const pa_idx *cells, pa_idx count, int nvc,
                             pa_idx nv, const char *what) {
  pa_status st = PA_SUCCESS;
  for (pa_idx c = 0; c < count; c++) {
    const pa_idx *v = cells + (size_t)nvc * c;
    for (int k = 0; k < nvc; k++) {
      PA_CHECK(v[k] >= 0 && v[k] < nv, PA_ERR_MESH,
               "%s %d references vertex %lld, out of range (the mesh has %d "
               "vertices)",
               what, (int)c + 1, (long long)v[k] + 1, (int)nv);
      for (int j = 0; j < k; j++)
        PA_CHECK(v[j] != v[k], PA_ERR_MESH, "%s %d has vertex %d twice", what,
                 (int)c + 1, (int)v[k] + 1);
    }
  }
cleanup:
  return st;
}

/* Install a freshly computed structure as the mesh's cache, or, when a cache
 * exists, make sure it equals the fresh one. Takes ownership of *fresh. */
static pa_status adopt_cache(pa_idx **cache, pa_idx **fresh, size_t n,
                             const char *what) {
  pa_status st = PA_SUCCESS;
  if (!*cache) {
    *cache = *fresh;
    *fresh = NULL;
    return PA_SUCCESS;
  }
  for (size_t k = 0; k < n; k++)
    PA_CHECK((*cache)[k] == (*fresh)[k], PA_ERR_MESH,
             "the cached %s is out of date at entry %zu (the mesh changed "
             "without pa__mesh_invalidate)",
             what, k);
cleanup:
  pa__free(*fresh);
  *fresh = NULL;
  return st;
}

/* Each vertex's elements form one group connected through the faces that
 * contain it (no two fans or cones touching only at the vertex), from the
 * adjacency and the balls. */
static pa_status check_manifold_vertices(const pa_mesh *m) {
  pa_status st = PA_SUCCESS;
  const int nf = m->dim + 1;
  pa_idx *stamp = NULL, *stack = NULL;
  PA_ALLOC(stamp, m->ne ? (size_t)m->ne : 1);
  PA_ALLOC(stack, m->ne ? (size_t)m->ne : 1);
  for (pa_idx e = 0; e < m->ne; e++) stamp[e] = -1;
  for (pa_idx v = 0; v < m->nv; v++) {
    pa_idx b0 = m->ball_start[v], n = m->ball_start[v + 1] - b0, seen = 1,
           top = 0;
    if (n == 0) continue;
    stack[top++] = m->ball[b0];
    stamp[m->ball[b0]] = v;
    while (top) {
      pa_idx e = stack[--top];
      const pa_idx *ev = m->elem + (size_t)nf * e;
      for (int i = 0; i < nf; i++) {
        if (ev[i] == v) continue; /* face i does not contain v */
        pa_idx a = m->adja[(size_t)nf * e + i];
        if (a < 0 || stamp[a / nf] == v) continue;
        stamp[a / nf] = v;
        stack[top++] = a / nf;
        seen++;
      }
    }
    PA_CHECK(seen == n, PA_ERR_MESH,
             "vertex %d is non-manifold: its %d elements form separate "
             "groups that touch only at it (e.g. element %d and element %d); "
             "padapt needs a manifold mesh: split the vertex or fill the gap",
             (int)v + 1, (int)n, (int)m->ball[b0] + 1,
             (int)m->ball[b0 + n - 1] + 1);
  }
cleanup:
  pa__free(stamp);
  pa__free(stack);
  return st;
}

/* No two vertices at the same coordinates (a crack: duplicated vertices
 * along an interior face, or a mesh glued from parts without merging). */
static pa_status check_coincident(const pa_mesh *m) {
  pa_status st = PA_SUCCESS;
  const int d = m->dim;
  size_t cap = 16;
  pa_idx *slot = NULL;
  while (cap < 2 * (size_t)m->nv + 2) cap *= 2;
  PA_ALLOC(slot, cap);
  for (size_t k = 0; k < cap; k++) slot[k] = -1;
  for (pa_idx v = 0; v < m->nv; v++) {
    const double *x = m->coord + (size_t)d * v;
    uint64_t h = 0x9e3779b97f4a7c15ull;
    for (int k = 0; k < d; k++) {
      double c = x[k] == 0 ? 0.0 : x[k]; /* -0 and +0 alike */
      uint64_t b;
      memcpy(&b, &c, sizeof b);
      h = pa__mix64(h ^ b);
    }
    size_t i = (size_t)h & (cap - 1);
    for (;; i = (i + 1) & (cap - 1)) {
      pa_idx u = slot[i];
      if (u < 0) {
        slot[i] = v;
        break;
      }
      const double *y = m->coord + (size_t)d * u;
      int same = 1;
      for (int k = 0; k < d; k++) same &= x[k] == y[k];
      if (same) {
        char pt[96];
        if (d == 3)
          snprintf(pt, sizeof pt, "%g, %g, %g", x[0], x[1], x[2]);
        else
          snprintf(pt, sizeof pt, "%g, %g", x[0], x[1]);
        PA_CHECK(0, PA_ERR_MESH,
                 "vertices %d and %d are at the same point (%s): a crack or "
                 "a duplicated vertex; padapt needs a conforming mesh: merge "
                 "them",
                 (int)u + 1, (int)v + 1, pt);
      }
    }
  }
cleanup:
  pa__free(slot);
  return st;
}

/* Every coordinate finite. */
static pa_status check_coords(const pa_mesh *m) {
  pa_status st = PA_SUCCESS;
  const int d = m->dim;
  for (pa_idx v = 0; v < m->nv; v++)
    for (int k = 0; k < d; k++)
      PA_CHECK(isfinite(m->coord[(size_t)d * v + k]), PA_ERR_MESH,
               "vertex %d has a non-finite coordinate (%g)", (int)v + 1,
               m->coord[(size_t)d * v + k]);
cleanup:
  return st;
}

/* Vertices but no element: say what the file is (a boundary or surface
 * mesh), rather than that its first vertex is in no element. */
static pa_status check_has_elements(const pa_mesh *m) {
  pa_status st = PA_SUCCESS;
  if (m->ne > 0 || m->nv == 0) return PA_SUCCESS;
  if (m->nb == 0)
    PA_FAIL(PA_ERR_MESH,
            "the mesh has %d vertices but no %s: padapt adapts %s meshes",
            (int)m->nv, m->dim == 2 ? "triangles" : "tetrahedra",
            m->dim == 2 ? "triangle" : "tetrahedral (volume)");
  if (m->dim == 2)
    PA_FAIL(PA_ERR_MESH,
            "the mesh has no triangles, only %d edges: a boundary "
            "discretisation, not a mesh of the domain; padapt adapts "
            "triangle meshes: mesh the domain first (e.g. with mmg2d or gmsh)",
            (int)m->nb);
  PA_FAIL(PA_ERR_MESH,
          "the mesh has no tetrahedra, only %d triangles: a surface mesh; "
          "padapt adapts volume (tetrahedral) meshes: mesh the volume "
          "first (e.g. with tetgen or gmsh), or adapt the surface with mmgs",
          (int)m->nb);
cleanup:
  return st;
}

/* Every vertex in some element. */
static pa_status check_used(const pa_mesh *m) {
  pa_status st = PA_SUCCESS;
  uint8_t *used = NULL;
  const int nf = m->dim + 1;
  PA_CALLOC(used, (size_t)m->nv);
  for (size_t k = 0; k < (size_t)nf * m->ne; k++) used[m->elem[k]] = 1;
  for (pa_idx v = 0; v < m->nv; v++)
    PA_CHECK(used[v], PA_ERR_MESH, "vertex %d is in no element", (int)v + 1);
cleanup:
  pa__free(used);
  return st;
}

/* Orientation, with the exact predicate. */
static pa_status check_orientation(const pa_mesh *m) {
  pa_status st = PA_SUCCESS;
  const int d = m->dim, nf = d + 1;
  for (pa_idx e = 0; e < m->ne; e++) {
    const double *x[4];
    const pa_idx *v = m->elem + (size_t)nf * e;
    for (int k = 0; k < nf; k++) x[k] = m->coord + (size_t)d * v[k];
    PA_CHECK(pa__orient(d, x) > 0.0, PA_ERR_MESH,
             "element %d is inverted or flat (volume %.3g)", (int)e + 1,
             pa__simplex_volume(d, x));
  }
cleanup:
  return st;
}

/* 1 if face i of element e and face j of element f (the same vertices) are
 * seen from opposite sides, as two positive elements sharing a face are:
 * their outward orders are reverse permutations of each other. */
static int opposite_sides(const pa_mesh *m, pa_idx e, int i, pa_idx f, int j) {
  pa_idx a[3], b[3];
  pa__elem_face(m, e, i, a);
  pa__elem_face(m, f, j, b);
  if (m->dim == 2) return a[0] == b[1];
  int p = b[0] == a[0] ? 0 : b[1] == a[0] ? 1 : 2;
  return b[(p + 1) % 3] == a[2];
}

/* Conformity (in adja_compute), symmetric adjacency, and neighbours on
 * opposite sides of their common face: two positive elements on the same
 * side of it overlap (or are one element listed twice). The cache is
 * recomputed, not trusted: a stale cache is reported. */
static pa_status check_adjacency(pa_mesh *m) {
  pa_status st = PA_SUCCESS;
  pa_idx *adja = NULL;
  const int nf = m->dim + 1;
  const pa_idx ne = m->ne;
  PA_CALL(adja_compute(m, &adja));
  PA_CALL(adopt_cache(&m->adja, &adja, (size_t)nf * ne, "adjacency"));
  for (size_t c = 0; c < (size_t)nf * ne; c++) {
    pa_idx a = m->adja[c];
    PA_CHECK(a < 0 || (a < nf * ne && m->adja[a] == (pa_idx)c && a / nf !=
                       (pa_idx)(c / nf)),
             PA_ERR_MESH,
             "adjacency is not symmetric: face %d of element %d points to "
             "face %d of element %d",
             (int)(c % nf) + 1, (int)(c / nf) + 1, (int)(a % nf) + 1,
             (int)(a / nf) + 1);
    if (a < 0 || a < (pa_idx)c) continue;
    pa_idx e = (pa_idx)(c / nf), f = a / nf;
    if (opposite_sides(m, e, (int)(c % nf), f, a % nf)) continue;
    PA_CHECK(m->elem[c] != m->elem[a], PA_ERR_MESH,
             "elements %d and %d have the same vertices (a duplicated "
             "element): remove one",
             (int)e + 1, (int)f + 1);
    pa_idx fv[3];
    char buf[96];
    pa__elem_face(m, e, (int)(c % nf), fv);
    PA_FAIL(PA_ERR_MESH,
            "elements %d and %d overlap: both lie on the same side of their "
            "common face (%s) (a folded mesh)",
            (int)e + 1, (int)f + 1, fmt_verts(buf, sizeof buf, fv, m->dim));
  }
cleanup:
  pa__free(adja);
  return st;
}

/* Every face without neighbour is listed as a boundary entity (the
 * boundary table is built, or recomputed and compared with the cache). */
static pa_status check_boundary_faces(pa_mesh *m) {
  pa_status st = PA_SUCCESS;
  pa_idx *bh = NULL;
  char buf[96];
  const int d = m->dim, nf = d + 1;
  if (!m->bhash) {
    PA_CALL(bhash_build(m));
  } else {
    size_t cap;
    PA_CALL(bhash_compute(m, &bh, &cap));
    PA_CHECK(cap == m->bhash_cap, PA_ERR_MESH,
             "the cached boundary table is out of date (the mesh changed "
             "without pa__mesh_invalidate)");
    PA_CALL(adopt_cache(&m->bhash, &bh, cap, "boundary table"));
  }
  for (size_t c = 0; c < (size_t)nf * m->ne; c++) {
    if (m->adja[c] >= 0) continue;
    pa_idx f[3];
    pa__elem_face(m, (pa_idx)(c / nf), (int)(c % nf), f);
    PA_CHECK(bhash_find(m, f) >= 0, PA_ERR_MESH,
             "face (%s) of element %d is on the boundary but not listed as a "
             "boundary entity",
             fmt_verts(buf, sizeof buf, f, d), (int)(c / nf) + 1);
  }
cleanup:
  pa__free(bh);
  return st;
}

/* Every boundary entity is a face of some element, and listed once (the
 * balls are built, or recomputed and compared with the cache). */
static pa_status check_boundary_entities(pa_mesh *m) {
  pa_status st = PA_SUCCESS;
  pa_idx *bstart = NULL, *ball = NULL;
  char buf[96];
  const int d = m->dim, nf = d + 1;
  PA_CALL(balls_compute(m, &bstart, &ball));
  if (m->ball_start && m->ball) {
    PA_CALL(adopt_cache(&m->ball_start, &bstart, (size_t)m->nv + 1,
                        "ball index"));
    PA_CALL(adopt_cache(&m->ball, &ball, (size_t)nf * m->ne, "balls"));
  } else {
    pa__free(m->ball_start);
    pa__free(m->ball);
    m->ball_start = bstart;
    m->ball = ball;
    bstart = ball = NULL;
  }
  for (pa_idx b = 0; b < m->nb; b++) {
    const pa_idx *bv = m->bdry + (size_t)d * b;
    pa_idx first = bhash_find(m, bv);
    PA_CHECK(first == b, PA_ERR_MESH,
             "boundary entity %d (%s) duplicates boundary entity %d", (int)b + 1,
             fmt_verts(buf, sizeof buf, bv, d), (int)first + 1);
    int found = 0;
    for (pa_idx k = m->ball_start[bv[0]]; k < m->ball_start[bv[0] + 1] && !found;
         k++) {
      const pa_idx *ev = m->elem + (size_t)nf * m->ball[k];
      int nin = 0;
      for (int j = 0; j < d; j++)
        for (int i = 0; i < nf; i++)
          if (ev[i] == bv[j]) {
            nin++;
            break;
          }
      found = nin == d;
    }
    PA_CHECK(found, PA_ERR_MESH,
             "boundary entity %d (%s) is not a face of any element", (int)b + 1,
             fmt_verts(buf, sizeof buf, bv, d));
  }
cleanup:
  pa__free(bstart);
  pa__free(ball);
  return st;
}

pa_status pa__mesh_check_elements(pa_mesh *m) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(m, PA_ERR_ARG, "pa_mesh_check: NULL mesh");
  const int d = m->dim, nf = d + 1;
  const pa_idx nv = m->nv, ne = m->ne;
  /* Indices in range, no repeated vertex. */
  PA_CALL(check_cells(m->elem, ne, nf, nv, "element"));
  PA_CALL(check_cells(m->bdry, m->nb, d, nv, "boundary entity"));
  PA_CALL(check_cells(m->edge, m->ned, 2, nv, "feature edge"));
  PA_CALL(check_coords(m));
  PA_CALL(check_has_elements(m));
  PA_CALL(check_used(m));
  PA_CALL(check_orientation(m));
  PA_CALL(check_adjacency(m));
cleanup:
  return st;
}

pa_status pa__mesh_check(pa_mesh *m, int input) {
  pa_status st = PA_SUCCESS;
  PA_CALL(pa__mesh_check_elements(m));
  PA_CALL(check_boundary_faces(m));
  PA_CALL(check_boundary_entities(m));
  if (input) {
    PA_CALL(check_coincident(m));
    PA_CALL(pa__mesh_check_overlap(m));
    PA_CALL(check_manifold_vertices(m));
  }
cleanup:
  return st;
}
