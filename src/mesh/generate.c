/*
 * generate.c -- structured meshes of the unit square and the unit cube.
 *
 * Vertex (i, j[, k]) of the (n+1)^dim grid has index i + (n+1) (j + (n+1) k)
 * (x fastest) and coordinates (i/n, j/n[, k/n]).
 *  - 2D: square (i, j) with corners a, b, c, d counter-clockwise from (i, j)
 *    becomes triangles (a, b, c) and (a, c, d): one diagonal direction, so the
 *    mesh is conforming, and every triangle counter-clockwise.
 *  - 3D: every cube is split into the 6 tetrahedra of Kuhn (Freudenthal) along
 *    its main diagonal (0,0,0)-(1,1,1): one per path from (0,0,0) to (1,1,1)
 *    along the cube's edges. The split is the same in every cube, so each face
 *    of a cube carries the diagonal from its lowest to its highest corner on
 *    both sides and the mesh is conforming; odd paths list their last two
 *    vertices swapped so that every tetrahedron is positive.
 * Boundary entities are oriented outward (the convention of pa__elem_face):
 * sides in the order of their references x=0:1 x=1:2 y=0:3 y=1:4 [z=0:5
 * z=1:6], n edges (2D) or 2n^2 triangles (3D) per side. The box
 * corners are flagged PA_FLAG_CORNER; in 3D the 12 box edges are feature
 * edges (reference 0, flag PA_FLAG_RIDGE, one per grid segment) and their
 * vertices are flagged PA_FLAG_RIDGE. Entities are written straight into the
 * reserved arrays.
 */
#include "mesh/mesh.h"

/* Kuhn tetrahedra as cube corners (bit 0: +x, bit 1: +y, bit 2: +z). */
static const int kuhn[6][4] = {
    {0, 1, 3, 7}, {0, 2, 6, 7}, {0, 4, 5, 7}, /* even paths */
    {0, 1, 7, 5}, {0, 2, 7, 3}, {0, 4, 7, 6}  /* odd paths, last two swapped */
};

static void generate_square(pa_mesh *m, pa_idx n) {
  const pa_idx nn = n + 1;
#define VID(i, j) ((pa_idx)((i) + nn * (j)))
  for (pa_idx j = 0; j <= n; j++)
    for (pa_idx i = 0; i <= n; i++) {
      pa_idx v = VID(i, j);
      m->coord[2 * v] = (double)i / n;
      m->coord[2 * v + 1] = (double)j / n;
      m->vref[v] = 0;
      m->vflag[v] = (i == 0 || i == n) && (j == 0 || j == n) ? PA_FLAG_CORNER
                                                             : 0;
    }
  pa_idx *t = m->elem;
  for (pa_idx j = 0; j < n; j++)
    for (pa_idx i = 0; i < n; i++) {
      pa_idx a = VID(i, j), b = VID(i + 1, j), c = VID(i + 1, j + 1),
             d = VID(i, j + 1);
      t[0] = a, t[1] = b, t[2] = c;
      t[3] = a, t[4] = c, t[5] = d;
      t += 6;
    }
  pa_idx *e = m->bdry, nb = 0;
  for (pa_idx k = 0; k < n; k++, nb++, e += 2) /* x = 0, downwards */
    e[0] = VID(0, k + 1), e[1] = VID(0, k), m->bref[nb] = 1;
  for (pa_idx k = 0; k < n; k++, nb++, e += 2) /* x = 1, upwards */
    e[0] = VID(n, k), e[1] = VID(n, k + 1), m->bref[nb] = 2;
  for (pa_idx k = 0; k < n; k++, nb++, e += 2) /* y = 0, rightwards */
    e[0] = VID(k, 0), e[1] = VID(k + 1, 0), m->bref[nb] = 3;
  for (pa_idx k = 0; k < n; k++, nb++, e += 2) /* y = 1, leftwards */
    e[0] = VID(k + 1, n), e[1] = VID(k, n), m->bref[nb] = 4;
#undef VID
}

static void generate_cube(pa_mesh *m, pa_idx n) {
  const pa_idx nn = n + 1;
  const pa_idx stride[3] = {1, nn, nn * nn};
  for (pa_idx k = 0; k <= n; k++)
    for (pa_idx j = 0; j <= n; j++)
      for (pa_idx i = 0; i <= n; i++) {
        pa_idx v = i + stride[1] * j + stride[2] * k;
        double *x = m->coord + 3 * (size_t)v;
        x[0] = (double)i / n;
        x[1] = (double)j / n;
        x[2] = (double)k / n;
        m->vref[v] = 0;
        int nside = (i == 0 || i == n) + (j == 0 || j == n) + (k == 0 || k == n);
        m->vflag[v] = nside == 3   ? PA_FLAG_CORNER | PA_FLAG_RIDGE
                      : nside == 2 ? PA_FLAG_RIDGE
                                   : 0;
      }

  pa_idx off[8];
  for (int c = 0; c < 8; c++)
    off[c] = (c & 1) * stride[0] + (c >> 1 & 1) * stride[1] +
             (c >> 2 & 1) * stride[2];
  pa_idx *t = m->elem;
  for (pa_idx k = 0; k < n; k++)
    for (pa_idx j = 0; j < n; j++)
      for (pa_idx i = 0; i < n; i++) {
        pa_idx base = i + stride[1] * j + stride[2] * k;
        for (int s = 0; s < 6; s++, t += 4)
          for (int l = 0; l < 4; l++) t[l] = base + off[kuhn[s][l]];
      }

  /* Side (axis a, low or high): squares in the axes p, q with (p, q, a)
   * right-handed; triangles (A,B,C), (A,C,D) counter-clockwise in (p, q) have
   * their normal along +a, and are reversed on the low side. */
  pa_idx *f = m->bdry, nb = 0;
  for (int a = 0; a < 3; a++)
    for (int high = 0; high < 2; high++) {
      int p = (a + 1) % 3, q = (a + 2) % 3;
      pa_idx base0 = high ? n * stride[a] : 0;
      for (pa_idx iq = 0; iq < n; iq++)
        for (pa_idx ip = 0; ip < n; ip++) {
          pa_idx A = base0 + ip * stride[p] + iq * stride[q];
          pa_idx B = A + stride[p], C = B + stride[q], D = A + stride[q];
          if (high) {
            f[0] = A, f[1] = B, f[2] = C;
            f[3] = A, f[4] = C, f[5] = D;
          } else {
            f[0] = A, f[1] = C, f[2] = B;
            f[3] = A, f[4] = D, f[5] = C;
          }
          f += 6;
          m->bref[nb] = m->bref[nb + 1] = 2 * a + high + 1;
          nb += 2;
        }
    }

  /* The 12 box edges: 4 lines along each axis a, at the low or high end of
   * the two other axes. */
  pa_idx *g = m->edge;
  for (int a = 0; a < 3; a++)
    for (int corner = 0; corner < 4; corner++) {
      int p = (a + 1) % 3, q = (a + 2) % 3;
      pa_idx base0 = (corner & 1) * n * stride[p] + (corner >> 1) * n * stride[q];
      for (pa_idx s = 0; s < n; s++, g += 2) {
        g[0] = base0 + s * stride[a];
        g[1] = g[0] + stride[a];
      }
    }
}

pa_status pa_mesh_generate_box(int dim, int n, pa_mesh **mesh) {
  pa_status st = PA_SUCCESS;
  pa_mesh *m = NULL;
  PA_CHECK(mesh, PA_ERR_ARG, "pa_mesh_generate_box: NULL output pointer");
  *mesh = NULL;
  PA_CHECK(dim == 2 || dim == 3, PA_ERR_ARG,
           "pa_mesh_generate_box: dimension must be 2 or 3, got %d", dim);
  PA_CHECK(n >= 1, PA_ERR_ARG,
           "pa_mesh_generate_box: n must be positive, got %d", n);
  int64_t n64 = n, nn = n64 + 1;
  int64_t nv = dim == 2 ? nn * nn : nn * nn * nn;
  int64_t ne = dim == 2 ? 2 * n64 * n64 : 6 * n64 * n64 * n64;
  int64_t nb = dim == 2 ? 4 * n64 : 12 * n64 * n64;
  int64_t ned = dim == 2 ? 0 : 12 * n64;
  PA_CHECK((dim + 1) * ne <= INT32_MAX, PA_ERR_ARG,
           "pa_mesh_generate_box: n = %d gives too many elements", n);
  PA_CALL(pa_mesh_create(dim, &m));
  PA_CALL(pa_mesh_reserve(m, (pa_idx)nv, (pa_idx)ne, (pa_idx)nb, (pa_idx)ned));
  m->nv = (pa_idx)nv;
  m->ne = (pa_idx)ne;
  m->nb = (pa_idx)nb;
  m->ned = (pa_idx)ned;
  if (dim == 2)
    generate_square(m, n);
  else
    generate_cube(m, n);
  for (int64_t e = 0; e < ne; e++) m->eref[e] = 1;
  memset(m->eflag, 0, (size_t)ne);
  memset(m->bflag, 0, (size_t)nb);
  if (ned) {
    memset(m->edref, 0, (size_t)ned * sizeof *m->edref);
    memset(m->edflag, PA_FLAG_RIDGE, (size_t)ned);
  }
  *mesh = m;
  m = NULL;
cleanup:
  pa_mesh_destroy(m);
  return st;
}
