/*
 * check.c -- the mesh checker (pa__mesh_check: everything pa_mesh_check
 * checks but the metric values, which metric/ops.c checks): indices, sizes,
 * orientation, conformity, boundary entities, and on input meshes
 * coincident vertices, folds (overlap.c) and non-manifold vertices. The
 * derived structures the mesh caches (topo.c) are recomputed and compared
 * with the caches.
 *
 * Messages name entities 1-based, as Medit files do.
 */
#include "mesh/mesh.h"

#include <math.h>
#include <stdio.h>

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

/* Conformity (in pa__mesh_adja_compute), symmetric adjacency, and neighbours on
 * opposite sides of their common face: two positive elements on the same
 * side of it overlap (or are one element listed twice). The cache is
 * recomputed, not trusted: a stale cache is reported. */
static pa_status check_adjacency(pa_mesh *m) {
  pa_status st = PA_SUCCESS;
  pa_idx *adja = NULL;
  const int nf = m->dim + 1;
  const pa_idx ne = m->ne;
  PA_CALL(pa__mesh_adja_compute(m, &adja));
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
    PA_CALL(pa__mesh_bhash_build(m));
  } else {
    size_t cap;
    PA_CALL(pa__mesh_bhash_compute(m, &bh, &cap));
    PA_CHECK(cap == m->bhash_cap, PA_ERR_MESH,
             "the cached boundary table is out of date (the mesh changed "
             "without pa__mesh_invalidate)");
    PA_CALL(adopt_cache(&m->bhash, &bh, cap, "boundary table"));
  }
  for (size_t c = 0; c < (size_t)nf * m->ne; c++) {
    if (m->adja[c] >= 0) continue;
    pa_idx f[3];
    pa__elem_face(m, (pa_idx)(c / nf), (int)(c % nf), f);
    PA_CHECK(pa__mesh_bhash_find(m, f) >= 0, PA_ERR_MESH,
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
  PA_CALL(pa__mesh_balls_compute(m, &bstart, &ball));
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
    pa_idx first = pa__mesh_bhash_find(m, bv);
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
