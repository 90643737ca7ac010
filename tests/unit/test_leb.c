/*
 * test_leb.c -- longest-edge bisection (remesh/leb.c), in 2D and 3D:
 *  - plain refinement: a valid mesh of the same volume, boundary entities and
 *    original vertices untouched, and every inner edge longer than lmax lies
 *    in an element with a longer edge (the rule that stops the bisection);
 *    every new vertex is the exact midpoint of its two parents, which are
 *    earlier vertices, and a linear field is carried exactly (parents' mean);
 *  - frozen (PA_FLAG_REQUIRED) elements come back bit for bit;
 *  - skins: the two halves of a box, refined separately, end with the same
 *    skin vertices (coordinates and metric, bit for bit) and skin faces, no
 *    splittable skin edge longer than skin_lmax, and onskin marking exactly
 *    the new vertices on the skin; with the vertices of the cut on the
 *    box's boundary labelled: hard ones (their boundary edges stay whole,
 *    and the faces leaning on them terminate), soft ones (their boundary
 *    edges split at the midpoint); with the box's top bent into a curve,
 *    the cut's vertices on it given the normals of the curve: the skin
 *    edges on it split onto it (five times closer than the chord's
 *    midpoint), and with the normals of a curve much deeper than the mesh
 *    (a thin slab), the elements the points turn over counted;
 *  - a failed allocation leaks nothing.
 */
#include "testutil.h"

#include "remesh/leb.h"

#define SKIN_REF 77
#define LMAX 2.0
#define SKIN_LMAX 1.4142

/* ---- helpers ---- */

/* Unit box of n cells per side with the uniform size h. */
static pa_mesh *box(int dim, int n, double h) {
  pa_mesh *m = NULL;
  CHECK_OK(pa_mesh_generate_box(dim, n, &m));
  double *s = malloc(sizeof *s * m->nv);
  for (pa_idx v = 0; v < m->nv; v++)
    s[v] = h;
  CHECK_OK(pa_mesh_set_metric(m, 1, s));
  free(s);
  return m;
}

/* Lexicographic order of the coordinates of a and b (as leb.c orders ends). */
static int vcmp(const pa_mesh *m, pa_idx a, pa_idx b) {
  const double *x = m->coord + (size_t)m->dim * a;
  const double *y = m->coord + (size_t)m->dim * b;
  for (int k = 0; k < m->dim; k++)
    if (x[k] != y[k]) return x[k] < y[k] ? -1 : 1;
  return 0;
}

/* Metric length of edge ab, computed from its ends in coordinate order. */
static double elen(const pa_mesh *m, pa_idx a, pa_idx b) {
  if (vcmp(m, a, b) > 0) return elen(m, b, a);
  int d = m->dim, nc = m->met_ncomp;
  return pa__edge_length(d, nc, m->coord + (size_t)d * a,
                         m->coord + (size_t)d * b, m->met + (size_t)nc * a,
                         m->met + (size_t)nc * b);
}

static uint64_t ekey(pa_idx a, pa_idx b) {
  return a < b ? (uint64_t)a << 32 | (uint32_t)b
               : (uint64_t)b << 32 | (uint32_t)a;
}

static int ucmp(const void *p, const void *q) {
  uint64_t a = *(const uint64_t *)p, b = *(const uint64_t *)q;
  return a < b ? -1 : a > b;
}

/* Sorted keys of the edges of boundary entities and feature edges. */
static uint64_t *bdry_edges(const pa_mesh *m, size_t *n) {
  int d = m->dim, per = d == 2 ? 1 : 3;
  uint64_t *k = malloc(sizeof *k * ((size_t)per * m->nb + m->ned + 1));
  *n = 0;
  for (pa_idx b = 0; b < m->nb; b++) {
    const pa_idx *v = m->bdry + (size_t)d * b;
    for (int i = 0; i < per; i++)
      k[(*n)++] = ekey(v[i], v[(i + 1) % d]);
  }
  for (pa_idx e = 0; e < m->ned; e++)
    k[(*n)++] = ekey(m->edge[2 * e], m->edge[2 * e + 1]);
  qsort(k, *n, sizeof *k, ucmp);
  return k;
}

typedef struct edge_figures {
  double inner_max; /* longest edge on no boundary entity */
  double bdry_max;  /* longest edge of a boundary entity */
  int unblocked;    /* inner edges longer than lmax with no longer edge in an
                       element around them: leb should have split them */
} edge_figures;

static edge_figures measure_edges(pa_mesh *m, double lmax) {
  edge_figures f = {0, 0, 0};
  const pa_idx *start, *ball;
  CHECK_OK(pa_mesh_build_balls(m, &start, &ball));
  size_t nk;
  uint64_t *bk = bdry_edges(m, &nk);
  int nve = m->dim + 1;
  for (pa_idx e = 0; e < m->ne; e++) {
    const pa_idx *v = m->elem + (size_t)nve * e;
    for (int i = 0; i < nve; i++)
      for (int j = i + 1; j < nve; j++) {
        double len = elen(m, v[i], v[j]);
        uint64_t key = ekey(v[i], v[j]);
        if (bsearch(&key, bk, nk, sizeof key, ucmp)) {
          f.bdry_max = fmax(f.bdry_max, len);
          continue;
        }
        f.inner_max = fmax(f.inner_max, len);
        if (!(len > lmax)) continue;
        int blocked = 0;
        for (pa_idx q = start[v[i]]; q < start[v[i] + 1] && !blocked; q++) {
          const pa_idx *w = m->elem + (size_t)nve * ball[q];
          int hasb = 0;
          for (int k = 0; k < nve; k++)
            hasb |= w[k] == v[j];
          for (int k = 0; k < nve && hasb; k++)
            for (int l = k + 1; l < nve; l++)
              if (ekey(w[k], w[l]) != key && elen(m, w[k], w[l]) >= len)
                blocked = 1;
        }
        f.unblocked += !blocked;
      }
  }
  free(bk);
  return f;
}

/* The x coordinate of the centroid of element e. */
static double centroid_x(const pa_mesh *m, pa_idx e) {
  int d = m->dim, nve = d + 1;
  double cx = 0.0;
  for (int k = 0; k < nve; k++)
    cx += m->coord[(size_t)d * m->elem[(size_t)nve * e + k]];
  return cx / nve;
}

/* New vertices (index >= nv0) that are not the exact midpoint of two earlier
 * vertices named by parent (when placed on a curve, onskin 2: only the
 * parents are checked), or whose fields are not the parents' mean. */
static int bad_midpoints(const pa_mesh *m, pa_idx nv0, const pa_idx *parent,
                         const uint8_t *onskin) {
  int bad = 0, d = m->dim;
  for (pa_idx v = nv0; v < m->nv; v++) {
    pa_idx a = parent[2 * (v - nv0)], b = parent[2 * (v - nv0) + 1];
    if (a < 0 || b < 0 || a >= v || b >= v || a == b) {
      bad++;
      continue;
    }
    if (onskin && onskin[v - nv0] == 2) continue;
    const double *x = m->coord + (size_t)d * v;
    const double *xa = m->coord + (size_t)d * a, *xb = m->coord + (size_t)d * b;
    int ok = 1;
    for (int k = 0; k < d; k++)
      ok &= x[k] == 0.5 * xa[k] + 0.5 * xb[k];
    for (int f = 0; f < m->nfield; f++) {
      int nc = m->field[f].ncomp;
      const double *y = m->field[f].val;
      for (int c = 0; c < nc; c++)
        ok &= y[(size_t)nc * v + c] ==
              0.5 * y[(size_t)nc * a + c] + 0.5 * y[(size_t)nc * b + c];
    }
    bad += !ok;
  }
  return bad;
}

/* ---- plain refinement, carrying a linear field ---- */

static void linear(const double *x, int dim, double *y) {
  double z = dim == 3 ? x[2] : 0.0;
  y[0] = 1.0 + 2.0 * x[0] - 3.0 * x[1] + 0.5 * z;
  y[1] = -x[0] + 4.0 * x[1] + 0.25 * z;
}

static void plain(int dim) {
  pa_mesh *m = box(dim, 4, 0.05), *m0 = NULL;
  double *y = malloc(sizeof *y * 2 * m->nv), err = 0.0;
  for (pa_idx v = 0; v < m->nv; v++)
    linear(m->coord + (size_t)dim * v, dim, y + 2 * v);
  CHECK_OK(pa_mesh_add_field(m, "linear", 2, y));
  free(y);
  CHECK_OK(pa_mesh_copy(m, &m0));
  edge_figures f0 = measure_edges(m0, LMAX);
  CHECK(f0.unblocked > 0); /* the input needs refining */
  pa__leb_opts o = {.lmax = LMAX};
  pa_idx *parent = NULL;
  uint8_t *onskin = NULL;
  CHECK_OK(pa__leb_refine(m, &o, &parent, &onskin));
  CHECK_OK(pa_mesh_check(m));
  CHECK_NEAR(pa_mesh_volume(m), pa_mesh_volume(m0), 1e-12);
  CHECK(m->ne > 4 * m0->ne);
  /* Boundary entities and original vertices are untouched. */
  CHECK(m->nb == m0->nb && m->ned == m0->ned);
  CHECK(!memcmp(m->bdry, m0->bdry, sizeof(pa_idx) * dim * m0->nb));
  CHECK(!memcmp(m->bref, m0->bref, sizeof(int32_t) * m0->nb));
  CHECK(!memcmp(m->coord, m0->coord, sizeof(double) * dim * m0->nv));
  CHECK(parent && bad_midpoints(m, m0->nv, parent, NULL) == 0);
  CHECK_OK(pa_mesh_field(m, 0, NULL, NULL, &y));
  for (pa_idx v = 0; v < m->nv; v++) {
    double exact[2];
    linear(m->coord + (size_t)dim * v, dim, exact);
    for (int c = 0; c < 2; c++)
      err = fmax(err, fabs(y[2 * v + c] - exact[c]));
  }
  CHECK(err <= 1e-13);
  int nskin = 0;
  for (pa_idx v = m0->nv; v < m->nv && onskin; v++)
    nskin += onskin[v - m0->nv];
  CHECK(onskin && nskin == 0);
  /* Inner edges end short, except where a longer (boundary) edge blocks. */
  edge_figures f = measure_edges(m, LMAX);
  printf("plain %dD: %d -> %d elements, inner edges %.2f -> %.2f (boundary "
         "%.2f)\n",
         dim, (int)m0->ne, (int)m->ne, f0.inner_max, f.inner_max, f.bdry_max);
  CHECK(f.unblocked == 0);
  CHECK(f.inner_max <= fmax(LMAX, f.bdry_max));
  CHECK(f.inner_max < 0.75 * f0.inner_max);
  pa__free(parent);
  pa__free(onskin);
  pa_mesh_destroy(m);
  pa_mesh_destroy(m0);
}

/* ---- frozen elements: the first column of cells ---- */

static void frozen(int dim) {
  pa_mesh *m = box(dim, 4, 0.05), *m0 = NULL;
  int nve = dim + 1, nfrozen = 0;
  for (pa_idx e = 0; e < m->ne; e++)
    if (centroid_x(m, e) < 0.25) {
      m->eflag[e] |= PA_FLAG_REQUIRED;
      nfrozen++;
    }
  CHECK_OK(pa_mesh_copy(m, &m0));
  pa__leb_opts o = {.lmax = LMAX};
  CHECK_OK(pa__leb_refine(m, &o, NULL, NULL));
  CHECK_OK(pa_mesh_check(m));
  CHECK_NEAR(pa_mesh_volume(m), pa_mesh_volume(m0), 1e-12);
  CHECK(m->ne > 4 * m0->ne);
  int same = 0, now = 0;
  for (pa_idx e = 0; e < m0->ne; e++)
    same += (m0->eflag[e] & PA_FLAG_REQUIRED) &&
            (m->eflag[e] & PA_FLAG_REQUIRED) &&
            !memcmp(m->elem + (size_t)nve * e, m0->elem + (size_t)nve * e,
                    sizeof(pa_idx) * nve);
  for (pa_idx e = 0; e < m->ne; e++)
    now += (m->eflag[e] & PA_FLAG_REQUIRED) != 0;
  CHECK(nfrozen > 0 && same == nfrozen && now == nfrozen);
  pa_mesh_destroy(m);
  pa_mesh_destroy(m0);
}

/* ---- skins ---- */

/* A vertex on the cut x = 0.5, as a sortable tuple: coordinates then metric;
 * or a skin face: the coordinates of its vertices in coordinate order. */
typedef struct tuple {
  double x[9];
} tuple;

static int tuple_cmp(const void *p, const void *q) {
  const double *a = ((const tuple *)p)->x, *b = ((const tuple *)q)->x;
  for (int k = 0; k < 9; k++)
    if (a[k] != b[k]) return a[k] < b[k] ? -1 : 1;
  return 0;
}

static int on_cut(const pa_mesh *m, pa_idx v) {
  return m->coord[(size_t)m->dim * v] == 0.5;
}

/* On the cut and off the box's boundary: skin edges may be split there. */
static int skin_inner(const pa_mesh *m, pa_idx v) {
  const double *x = m->coord + (size_t)m->dim * v;
  int ok = x[0] == 0.5;
  for (int k = 1; k < m->dim; k++)
    ok &= x[k] > 0.0 && x[k] < 1.0;
  return ok;
}

static tuple *cut_vertices(const pa_mesh *m, int *n) {
  tuple *t = calloc((size_t)m->nv + 1, sizeof *t);
  int d = m->dim, nc = m->met_ncomp;
  *n = 0;
  for (pa_idx v = 0; v < m->nv; v++) {
    if (!on_cut(m, v)) continue;
    memcpy(t[*n].x, m->coord + (size_t)d * v, sizeof(double) * d);
    memcpy(t[*n].x + d, m->met + (size_t)nc * v, sizeof(double) * nc);
    (*n)++;
  }
  qsort(t, (size_t)*n, sizeof *t, tuple_cmp);
  return t;
}

static tuple *skin_faces(const pa_mesh *m, int *n) {
  tuple *t = calloc((size_t)m->nb + 1, sizeof *t);
  int d = m->dim;
  *n = 0;
  for (pa_idx b = 0; b < m->nb; b++) {
    if (m->bref[b] != SKIN_REF) continue;
    pa_idx v[3];
    memcpy(v, m->bdry + (size_t)d * b, sizeof(pa_idx) * d);
    for (int i = 1; i < d; i++)
      for (int j = i; j > 0 && vcmp(m, v[j - 1], v[j]) > 0; j--) {
        pa_idx s = v[j];
        v[j] = v[j - 1];
        v[j - 1] = s;
      }
    for (int i = 0; i < d; i++)
      memcpy(t[*n].x + d * i, m->coord + (size_t)d * v[i], sizeof(double) * d);
    (*n)++;
  }
  qsort(t, (size_t)*n, sizeof *t, tuple_cmp);
  return t;
}

static int same_tuples(const tuple *a, int na, const tuple *b, int nb) {
  if (na != nb) return 0;
  for (int i = 0; i < na; i++)
    if (tuple_cmp(a + i, b + i)) return 0;
  return 1;
}

/* The elements of box on one side of x = 0.5 (side 0: centroid below) as a
 * mesh of their own: vertices renumbered, metric copied, the box's boundary
 * entities of that side kept and the faces on the cut added as SKIN_REF. */
static pa_mesh *half(const pa_mesh *box, int side) {
  int d = box->dim, nve = d + 1, nc = box->met_ncomp;
  pa_mesh *m = NULL;
  CHECK_OK(pa_mesh_create(d, &m));
  pa_idx *map = malloc(sizeof *map * box->nv);
  double *met = malloc(sizeof *met * nc * box->nv);
  for (pa_idx v = 0; v < box->nv; v++)
    map[v] = -1;
  for (pa_idx i = 0; i < box->ne; i++) {
    pa_idx e =
        side ? box->ne - 1 - i : i; /* the halves number the cut differently */
    const pa_idx *v = box->elem + (size_t)nve * e;
    if ((centroid_x(box, e) < 0.5) != (side == 0)) continue;
    pa_idx w[4];
    for (int k = 0; k < nve; k++) {
      if (map[v[k]] < 0) {
        CHECK_OK(pa_mesh_add_vertex(m, box->coord + (size_t)d * v[k], 0,
                                    &map[v[k]]));
        memcpy(met + (size_t)nc * map[v[k]], box->met + (size_t)nc * v[k],
               sizeof(double) * nc);
      }
      w[k] = map[v[k]];
    }
    CHECK_OK(pa_mesh_add_elem(m, w, 1, NULL));
  }
  CHECK_OK(pa_mesh_set_metric(m, nc, met));
  for (pa_idx b = 0; b < box->nb; b++) {
    pa_idx w[3], in = 1;
    for (int k = 0; k < d; k++)
      in &= (w[k] = map[box->bdry[(size_t)d * b + k]]) >= 0;
    if (in) CHECK_OK(pa_mesh_add_bdry(m, w, box->bref[b], NULL));
  }
  pa_idx nadded = 0;
  CHECK_OK(pa_mesh_build_boundary(m, SKIN_REF, &nadded));
  int off = 0;
  for (pa_idx b = m->nb - nadded; b < m->nb; b++)
    for (int k = 0; k < d; k++)
      off += !on_cut(m, m->bdry[(size_t)d * b + k]);
  CHECK(nadded > 0 && off == 0);
  CHECK_OK(pa_mesh_check(m));
  free(map);
  free(met);
  return m;
}

/* Refine one half with its skin, and check it on its own: valid, same
 * volume, the box's boundary entities untouched, exact midpoints, onskin set
 * exactly on the cut, no splittable skin edge longer than SKIN_LMAX. */
/* labelled: the vertices of the cut on the box's boundary are marked 4
 * (hard: their boundary edges stay whole) with LAB_HARD, 2 (labelled) with
 * LAB_SOFT, 2 and 3 (with the normal of the curve) on a bent top with
 * LAB_CURVE (the top a cylinder of radius 1 along x through the top
 * edges, top()), the same for a slab 100 times thinner with LAB_THIN (the
 * normals of the unthinned top); else 0. */
enum { LAB_NONE, LAB_HARD, LAB_SOFT, LAB_CURVE, LAB_THIN };
static int labelled;
#define THIN 0.01
/* the height of the cylinder's axis */
#define AXIS (1 - sqrt(0.75))

static double top(double y) { return AXIS + sqrt(1 - (y - 0.5) * (y - 0.5)); }

/* Vertex v of the bent box (LAB_CURVE, LAB_THIN) on its top. */
static int on_top(const pa_mesh *m, pa_idx v) {
  const double *x = m->coord + 3 * (size_t)v;
  double f = labelled == LAB_THIN    ? THIN * top(x[1])
             : labelled == LAB_CURVE ? top(x[1])
                                     : 1;
  return fabs(x[2] - f) < 1e-12;
}

/* The box bent (and made thin) as labelled says. */
static void bend(pa_mesh *m) {
  if (m->dim != 3 || labelled < LAB_CURVE) return;
  for (pa_idx v = 0; v < m->nv; v++) {
    double *x = m->coord + 3 * (size_t)v;
    x[2] *= top(x[1]) * (labelled == LAB_THIN ? THIN : 1);
  }
}

/* leb.c's o->on_boundary for vertices of the cut on the box's boundary:
 * with LAB_HARD any two (it may err that way), else exactly: both on one
 * face of the (bent) box. */
static int cut_on_boundary(void *ctx, pa_idx a, pa_idx b) {
  const pa_mesh *m = ctx;
  const double *x = m->coord + 3 * (size_t)a, *y = m->coord + 3 * (size_t)b;
  if (labelled == LAB_HARD) return 1;
  return (x[1] == 0 && y[1] == 0) || (x[1] == 1 && y[1] == 1) ||
         (x[2] == 0 && y[2] == 0) || (on_top(m, a) && on_top(m, b));
}

static void refine_half(pa_mesh *m) {
  int d = m->dim;
  pa_idx nv0 = m->nv, nb0 = m->nb, nbox = 0, *parent = NULL;
  while (nbox < m->nb && m->bref[nbox] != SKIN_REF)
    nbox++;
  pa_idx *bdry0 = malloc(sizeof *bdry0 * d * (nbox + 1));
  memcpy(bdry0, m->bdry, sizeof *bdry0 * d * nbox);
  double vol0 = pa_mesh_volume(m);
  uint8_t *ok = malloc((size_t)nv0), *onskin = NULL;
  double *nrm = calloc((size_t)d * nv0, sizeof *nrm), *mid = NULL;
  int curved = labelled >= LAB_CURVE && d == 3;
  for (pa_idx v = 0; v < nv0; v++) {
    int inner = skin_inner(m, v) && !(curved && on_top(m, v));
    ok[v] = (uint8_t)(inner ? 1 : labelled && on_cut(m, v) ? 2 : 0);
    if (ok[v] == 2 && labelled == LAB_HARD) ok[v] = 4;
    if (ok[v] == 2 && curved && on_top(m, v) && m->coord[3 * (size_t)v + 1] > 0 &&
        m->coord[3 * (size_t)v + 1] < 1) {
      /* the normal of the cylinder, also for the thin slab */
      double *n = nrm + 3 * (size_t)v, y = m->coord[3 * (size_t)v + 1];
      n[1] = y - 0.5;
      n[2] = top(y) - AXIS;
      ok[v] = 3;
    }
  }
  pa_idx curve_bad = 0;
  pa__leb_opts o = {.lmax = LMAX, .skin_ref = SKIN_REF, .skin_ok = ok,
                    .skin_lmax = SKIN_LMAX, .curve_bad = &curve_bad};
  if (labelled && d == 3) {
    o.on_boundary = cut_on_boundary;
    o.ctx = m;
  }
  if (curved) o.normal = nrm;
  CHECK_OK(pa__leb_refine(m, &o, &parent, &onskin));
  if (labelled == LAB_THIN) {
    /* the points on the deep curve cross the slab */
    CHECK(curve_bad > 0);
    printf("skin on a thin slab: %d elements turned over\n", (int)curve_bad);
    goto done;
  }
  CHECK(curve_bad == 0);
  CHECK_OK(pa_mesh_check(m));
  /* the points on the curve add volume */
  if (!curved) CHECK_NEAR(pa_mesh_volume(m), vol0, 1e-12);
  /* the box's faces on the cut's border are split with its edges */
  if (!labelled || labelled == LAB_HARD || d == 2) {
    CHECK(!memcmp(m->bdry, bdry0, sizeof *bdry0 * d * nbox));
    int nbad = 0;
    for (pa_idx f = nbox; f < m->nb; f++)
      nbad += m->bref[f] != SKIN_REF;
    CHECK(nbad == 0);
  }
  CHECK(m->nv > nv0 && parent && onskin);
  CHECK(parent && bad_midpoints(m, nv0, parent, onskin) == 0);
  int wrong = 0, nchecked = 0, nlong = 0, nlab = 0, nbord = 0, ncurve = 0,
      nfar = 0;
  mid = malloc(sizeof *mid * 3 * (size_t)(m->nv + 1));
  for (pa_idx v = nv0; v < m->nv && onskin; v++) {
    wrong += (onskin[v - nv0] != 0) != on_cut(m, v);
    pa_idx a = parent[2 * (v - nv0)], b = parent[2 * (v - nv0) + 1];
    /* split next to a labelled vertex: one end inner, the other not */
    if (a < nv0 && b < nv0) nlab += (ok[a] == 1) != (ok[b] == 1) && ok[a] && ok[b];
    /* a border edge of the cut split: both ends labelled */
    if (a < nv0 && b < nv0) nbord += ok[a] >= 2 && ok[b] >= 2;
    if (onskin[v - nv0] == 2) {
      /* on the curve: much closer to it than the chord's midpoint */
      const double *x = m->coord + 3 * (size_t)v;
      const double *xa = m->coord + 3 * (size_t)a, *xb = m->coord + 3 * (size_t)b;
      double c[3];
      for (int k = 0; k < 3; k++) c[k] = 0.5 * xa[k] + 0.5 * xb[k];
      double chord = fabs(c[2] - top(c[1]));
      ncurve++;
      nfar += chord > 1e-12 && !(fabs(x[2] - top(x[1])) < 0.2 * chord);
    }
  }
  CHECK(labelled ? nlab > 0 : nlab == 0);
  /* hard border edges stay whole, the others are split (in 3D, where the
   * cut's border lies on the box's faces) */
  if (d == 3) CHECK(labelled == LAB_HARD || !labelled ? nbord == 0 : nbord > 0);
  CHECK(curved ? ncurve > 0 && nfar == 0 : ncurve == 0);
  if (curved)
    printf("skin on a bent top: %d vertices on the curve, %d far from it\n",
           ncurve, nfar);
  for (pa_idx f = nbox; f < m->nb; f++) {
    const pa_idx *v = m->bdry + (size_t)d * f;
    for (int i = 0; i < (d == 2 ? 1 : 3); i++) {
      pa_idx x = v[i], y = v[(i + 1) % d];
      if (!skin_inner(m, x) || !skin_inner(m, y)) continue;
      nchecked++;
      nlong += elen(m, x, y) > SKIN_LMAX;
    }
  }
  CHECK(wrong == 0);
  CHECK(nchecked > 0 && nlong == 0);
  if (d == 2 && labelled == LAB_HARD) {
    /* a 2D skin face is its edge: split down to a hard end too */
    int nhard = 0, nhlong = 0;
    for (pa_idx f = nbox; f < m->nb; f++) {
      pa_idx x = m->bdry[2 * (size_t)f], y = m->bdry[2 * (size_t)f + 1];
      int hx = x < nv0 && ok[x] == 4, hy = y < nv0 && ok[y] == 4;
      if (hx == hy) continue;
      nhard++;
      nhlong += elen(m, x, y) > SKIN_LMAX;
    }
    CHECK(nhard > 0 && nhlong == 0);
  }
  printf("skin %dD half: %d -> %d vertices, %d -> %d skin faces\n", d, (int)nv0,
         (int)m->nv, (int)(nb0 - nbox), (int)(m->nb - nbox));
done:
  free(bdry0);
  free(ok);
  free(nrm);
  free(mid);
  pa__free(parent);
  pa__free(onskin);
}

/* The key property: both halves of a cut box, refined on their own, agree on
 * the cut (vertices with their metric, and faces) bit for bit. */
static void skin(int dim, int n, const char *spec) {
  pa_mesh *b = NULL, *p[2];
  CHECK_OK(pa_mesh_generate_box(dim, n, &b));
  /* iso-shell sizes scaled by 0.5 + x: the halves see different fields */
  CHECK_OK(pa_metric_analytic(b, spec));
  for (pa_idx v = 0; v < b->nv; v++)
    b->met[v] *= 0.5 + b->coord[(size_t)dim * v];
  bend(b);
  int n0, ncut[2], nface[2];
  tuple *cut[2], *face[2];
  free(cut_vertices(b, &n0));
  for (int s = 0; s < 2; s++) {
    p[s] = half(b, s);
    refine_half(p[s]);
    cut[s] = cut_vertices(p[s], &ncut[s]);
    face[s] = skin_faces(p[s], &nface[s]);
    if (labelled != LAB_THIN) CHECK(ncut[s] > 2 * n0);
  }
  CHECK(same_tuples(cut[0], ncut[0], cut[1], ncut[1]));
  CHECK(same_tuples(face[0], nface[0], face[1], nface[1]));
  for (int s = 0; s < 2; s++) {
    free(cut[s]);
    free(face[s]);
    pa_mesh_destroy(p[s]);
  }
  pa_mesh_destroy(b);
}

/* ---- allocation failure: an error status, no output, nothing leaked ---- */

static void test_alloc_failure(void) {
  int nfail = 0;
  for (int n = 1; n < 10000; n++) {
    pa_mesh *m = box(2, 4, 0.05);
    pa_idx *parent = NULL;
    uint8_t *onskin = NULL;
    pa__leb_opts o = {.lmax = LMAX};
    pa_memory_fail_after(n);
    pa_status st = pa__leb_refine(m, &o, &parent, &onskin);
    pa_memory_fail_after(0);
    int done = st == PA_SUCCESS;
    CHECK(done || (st == PA_ERR_MEMORY && !parent && !onskin));
    pa__free(parent);
    pa__free(onskin);
    pa_mesh_destroy(m);
    if (done) break;
    nfail++;
  }
  CHECK(nfail > 10);
}

static void test_plain_2d(void) { plain(2); }
static void test_plain_3d(void) { plain(3); }
static void test_frozen_2d(void) { frozen(2); }
static void test_frozen_3d(void) { frozen(3); }
static void test_skin_2d(void) { skin(2, 8, "iso-shell:0.1"); }
static void test_skin_3d(void) { skin(3, 6, "iso-shell:0.1"); }
/* With labelled vertices on the cut's border: skin faces leaning on an
 * unsplittable border edge are bisected from their inner vertex, and still
 * terminate (an apex sliding to that edge without end was a bug) and agree
 * on both sides. */
static void test_skin_labelled_2d(void) {
  labelled = LAB_SOFT;
  skin(2, 8, "iso-shell:0.1");
  labelled = LAB_NONE;
}
/* Hard vertices on the border of a 2D cut: the skin edges ending there are
 * split down to them (a 2D skin face slides nowhere), both halves alike. */
static void test_skin_hard_2d(void) {
  labelled = LAB_HARD;
  skin(2, 2, "uniform:0.05");
  labelled = LAB_NONE;
}
static void test_skin_labelled_3d(void) {
  for (labelled = LAB_HARD; labelled <= LAB_SOFT; labelled++) {
    skin(3, 2, "uniform:0.15");
    skin(3, 6, "iso-shell:0.1");
  }
  labelled = LAB_NONE;
}
/* The top bent, the cut's vertices on it with the normals of the curve:
 * the skin edges on it split onto it; on a thin slab with the normals of
 * the deep curve, the elements the points turn over are counted. */
static void test_skin_curved_3d(void) {
  labelled = LAB_CURVE;
  skin(3, 6, "uniform:0.05");
  labelled = LAB_THIN;
  skin(3, 4, "uniform:0.1");
  labelled = LAB_NONE;
}

TEST_MAIN(test_plain_2d, test_plain_3d, test_frozen_2d, test_frozen_3d,
          test_skin_2d, test_skin_3d, test_skin_labelled_2d,
          test_skin_hard_2d, test_skin_labelled_3d, test_skin_curved_3d, test_alloc_failure)
