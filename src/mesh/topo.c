/*
 * topo.c -- mesh topology: element faces, element adjacency, vertex balls,
 * boundary-entity lookup, volumes and completion of the boundary. The
 * checker of these structures is check.c.
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
 * inlined in pa__mesh_adja_compute with a constant dim, so that divisions
 * by nf and the small loops are specialised. */
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

pa_status pa__mesh_adja_compute(const pa_mesh *m, pa_idx **out) {
  return m->dim == 2 ? adja_compute_dim(m, 2, out)
                     : adja_compute_dim(m, 3, out);
}

pa_status pa_mesh_build_adjacency(pa_mesh *mesh, const pa_idx **adja) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(mesh, PA_ERR_ARG, "pa_mesh_build_adjacency: NULL mesh");
  if (!mesh->adja) PA_CALL(pa__mesh_adja_compute(mesh, &mesh->adja));
  if (adja) *adja = mesh->adja;
cleanup:
  return st;
}

/* ---- vertex balls ------------------------------------------------------- */

pa_status pa__balls_of(const pa_idx *elem, pa_idx ne, int nve, pa_idx nv,
                       const uint8_t *need, pa_idx **pstart, pa_idx **pball) {
  pa_status st = PA_SUCCESS;
  pa_idx *start = NULL, *ball = NULL, *slot = NULL;
  size_t n = (size_t)nve * ne, ns = n, cap = 0;
  *pstart = *pball = NULL;
  if (need) { /* the slots of the marked vertices, in one pass: few */
    ns = 0;
    for (size_t k = 0; k < n; k++)
      if (need[elem[k]]) {
        PA_GROW(slot, cap, ns + 1);
        slot[ns++] = (pa_idx)k;
      }
  }
#define SLOT(q) (slot ? (size_t)slot[q] : (q))
  PA_CALLOC(start, (size_t)nv + 1);
  for (size_t q = 0; q < ns; q++) start[elem[SLOT(q)] + 1]++;
  for (pa_idx v = 0; v < nv; v++) start[v + 1] += start[v];
  PA_ALLOC(ball, start[nv] ? (size_t)start[nv] : 1);
  for (size_t q = 0; q < ns; q++)
    ball[start[elem[SLOT(q)]]++] = (pa_idx)(SLOT(q) / (size_t)nve);
#undef SLOT
  for (pa_idx v = nv; v > 0; v--) start[v] = start[v - 1];
  start[0] = 0;
  *pstart = start;
  *pball = ball;
  start = ball = NULL;
cleanup:
  pa__free(start);
  pa__free(ball);
  pa__free(slot);
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

pa_status pa__mesh_balls_compute(const pa_mesh *m, pa_idx **pstart,
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
    PA_CALL(pa__mesh_balls_compute(mesh, &mesh->ball_start, &mesh->ball));
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

pa_status pa__mesh_bhash_compute(const pa_mesh *m, pa_idx **out, size_t *pcap) {
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
pa_status pa__mesh_bhash_build(pa_mesh *m) {
  if (m->bhash) return PA_SUCCESS;
  return pa__mesh_bhash_compute(m, &m->bhash, &m->bhash_cap);
}

/* Index of the listed boundary entity with vertices v (any order), or -1. */
pa_idx pa__mesh_bhash_find(const pa_mesh *m, const pa_idx *v) {
  pa_idx s[3];
  memcpy(s, v, (size_t)m->dim * sizeof *s);
  pa__sort_small(s, m->dim);
  return m->bhash[bhash_probe(m, m->bhash, m->bhash_cap, s)];
}

pa_status pa_mesh_find_bdry(pa_mesh *mesh, const pa_idx *v, pa_idx *index) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(mesh && v && index, PA_ERR_ARG, "pa_mesh_find_bdry: NULL argument");
  *index = -1;
  PA_CALL(pa__mesh_bhash_build(mesh));
  *index = pa__mesh_bhash_find(mesh, v);
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
  PA_CALL(pa__mesh_bhash_build(mesh));
  int64_t nadd = 0;
  for (size_t c = 0; c < (size_t)nf * mesh->ne; c++) {
    if (adja[c] >= 0) continue;
    pa_idx f[3];
    pa__elem_face(mesh, (pa_idx)(c / nf), (int)(c % nf), f);
    if (pa__mesh_bhash_find(mesh, f) < 0) nadd++;
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
    if (pa__mesh_bhash_find(mesh, f) >= 0) continue;
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
