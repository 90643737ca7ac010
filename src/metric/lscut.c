/*
 * lscut.c -- the level-set cut (Mmg's -ls): the zero set of phi - V cut
 * into a simplex mesh as an interface between two references
 * (pa_mesh_levelset_cut; the distributed driver, pa_dmesh_levelset_cut,
 * runs the same steps through the hooks of lscut.h).
 *
 *  1. Snapping. With s = phi - V, an edge (a, b) whose ends have opposite
 *     signs is cut at the share t = s_a / (s_a - s_b) from a (a the end of
 *     smaller key, so every copy of the edge computes the same bits). When
 *     t < snap, a takes s = 0; when t > 1 - snap, b does: no cut point lies
 *     closer than snap times its edge to an end, so every element of the
 *     cut keeps a volume of at least about snap times its parent's (the
 *     orientation of each is certain) and the interface moves by at most
 *     snap times an edge. The flags are taken from the unsnapped values
 *     and combined over the copies of each vertex, so the result does not
 *     depend on the order of the elements nor on the ranks.
 *  2. Components (rmc). The vertices of one side linked by edges form
 *     components (labels: the smallest key, by union-find over this rank's
 *     elements, then the minimum over the copies of each vertex, until no
 *     label changes on any rank); the volume of the side in each element
 *     (the cut's own decomposition, below) goes to its component; a
 *     component below rmc times the mesh volume changes side (s -> -s),
 *     the outside's first, then the inside's (as Mmg).
 *  3. The cut. Each edge with a sign change gets a vertex at its share t
 *     (coordinates x_a + t (x_b - x_a); metric and fields interpolated).
 *     The part of an element on one side (the points of that side, zeros
 *     and added ones included) is a convex polytope, cut into simplices by
 *     the pulling rule: every facet is fanned from its smallest point (key
 *     order: original vertices by key, then added ones by the keys of their
 *     edge), and the polytope is the union of the cones from its smallest
 *     point over the facets that do not hold it. A facet shared by two
 *     elements is fanned the same way from both sides (its fan depends on
 *     its points only), so the mesh stays conforming, on every rank; the
 *     pulling triangulation of a convex polytope is valid for any order of
 *     its points (no cyclic choice of quadrilateral diagonals can arise,
 *     which would need a Steiner point). In 2D a quadrilateral lies inside
 *     one triangle and is cut by its diagonal of better quality instead.
 *     Boundary entities and feature edges crossed are cut the same way, and
 *     keep their reference, flags and orientation.
 *  4. The interface: in a cut element of a split material, the cut facet
 *     (fanned as above, oriented out of the inside); and every face whose
 *     vertices are all on the zero set held by an inside and an outside
 *     element of split materials (pa__ls_zero_faces).
 *
 * Invariants: the output elements tile this rank's input elements (sum of
 * volumes equal to rounding), each on one side (its vertices' s all <= 0
 * or all >= 0, not all 0 inside), all positively oriented (exact test);
 * every vertex of an interface entity has s = 0 exactly.
 */
#include "metric/lscut.h"

#include <math.h>
#include <stdlib.h>

#define NOLABEL INT64_MAX

/* ---- options and the sequential context -------------------------------- */

void pa_levelset_opts_default(pa_levelset_opts *o) {
  memset(o, 0, sizeof *o);
  o->ref_in = PA_LS_REF_IN;
  o->ref_out = PA_LS_REF_OUT;
  o->ref_iface = PA_LS_REF_IFACE;
  o->snap = PA_LS_SNAP;
}

pa_status pa__ls_check_opts(const pa_levelset_opts *o) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(o, PA_ERR_ARG, "level set: NULL options");
  PA_CHECK(isfinite(o->value), PA_ERR_ARG,
           "level set: the iso-value is not a number");
  PA_CHECK(o->snap >= 0 && o->snap <= 0.25, PA_ERR_ARG,
           "level set: snap must be in [0, 0.25], got %g", o->snap);
  PA_CHECK(o->rmc >= 0 && o->rmc < 1, PA_ERR_ARG,
           "level set: rmc must be in [0, 1), got %g", o->rmc);
  PA_CHECK(o->nmat >= 0 && (o->nmat == 0 || o->mat), PA_ERR_ARG,
           "level set: %d materials but no table", o->nmat);
  PA_CHECK(o->nmat > 0 || o->ref_in != o->ref_out, PA_ERR_ARG,
           "level set: the inside and outside references are both %d",
           (int)o->ref_in);
  for (int i = 0; i < o->nmat; i++) {
    const pa_ls_material *a = &o->mat[i];
    PA_CHECK(!a->split || a->ref_in != a->ref_out, PA_ERR_ARG,
             "level set: material %d splits into one reference, %d",
             (int)a->ref, (int)a->ref_in);
    for (int j = 0; j < i; j++)
      PA_CHECK(o->mat[j].ref != a->ref, PA_ERR_ARG,
               "level set: material %d is listed twice", (int)a->ref);
  }
cleanup:
  return st;
}

static pa_status seq_none(void *ctx, double *x, int n) {
  (void)ctx;
  (void)x;
  (void)n;
  return PA_SUCCESS;
}

static pa_status seq_gather(void *ctx, const pa_gid *lab, const double *vol,
                            size_t n, pa_gid **alab, double **avol,
                            size_t *nall) {
  pa_status st = PA_SUCCESS;
  (void)ctx;
  *alab = NULL;
  *avol = NULL;
  PA_ALLOC(*alab, n);
  PA_ALLOC(*avol, n);
  if (n) {
    memcpy(*alab, lab, n * sizeof *lab);
    memcpy(*avol, vol, n * sizeof *vol);
  }
  *nall = n;
cleanup:
  return st;
}

static pa_status seq_agree(void *ctx, pa_status st) {
  (void)ctx;
  return st;
}

void pa__ls_ctx_seq(pa_mesh *mesh, pa__ls_ctx *c) {
  memset(c, 0, sizeof *c);
  c->mesh = mesh;
  c->nelem = mesh->ne;
  c->nbdry = mesh->nb;
  c->nedge = mesh->ned;
  c->nvert = mesh->nv;
  c->sum = seq_none;
  c->max = seq_none;
  c->gather = seq_gather;
  c->agree = seq_agree;
}

static pa_gid vkey(const pa__ls_ctx *c, pa_idx v) {
  return c->vkey ? c->vkey[v] : (pa_gid)v;
}

static int sgn(double x) { return (x > 0) - (x < 0); }

/* ---- the polytope of one side of an element ---------------------------- */

/* A point of an element's cut: an original vertex, or a point added on the
 * edge of keys (k0, k1), k0 < k1. */
typedef struct lpt {
  const double *x;
  pa_idx id;      /* output vertex: local index, or nv + k */
  int added, sign; /* sign of s (0 for added points) */
  pa_gid k0, k1;  /* order: originals by key, then added by edge keys */
} lpt;

static int lpt_less(const lpt *a, const lpt *b) {
  if (a->added != b->added) return a->added < b->added;
  if (a->k0 != b->k0) return a->k0 < b->k0;
  return a->k1 < b->k1;
}

/* Points of a cut element (3D: 4 originals and at most 4 added), cut[i][j]
 * the added point on edge (i, j) or -1. */
typedef struct epts {
  int dim, n;
  lpt p[8];
  int cut[4][4];
} epts;

static int on_side(const lpt *p, int side) {
  return p->added || p->sign == 0 || p->sign == side;
}

/* The clipped polygon of the face f[0..nf) (cyclic) of the points on side,
 * in order, into poly; returns its point count. */
static int clip_face(const epts *E, const int *f, int nf, int side,
                     int *poly) {
  int n = 0;
  for (int j = 0; j < nf; j++) {
    int a = f[j], b = f[(j + 1) % nf];
    if (on_side(&E->p[a], side)) poly[n++] = a;
    if (nf > 2 || j == 0)
      if (E->cut[a][b] >= 0) poly[n++] = E->cut[a][b];
  }
  return n;
}

/* The points of the zero set of a 3D element (zero originals and added
 * points) in cyclic order into poly; returns their count. A quadrilateral
 * arises only from two vertices of each sign: its points lie on the four
 * edges between the signs, and two of them are neighbours when their edges
 * share an end. */
static int cut_facet(const epts *E, int *poly) {
  int n = 0;
  for (int i = 0; i < E->n; i++)
    if (E->p[i].added || E->p[i].sign == 0) poly[n++] = i;
  if (n == 4) {
    int end[8][2] = {{0}}, q[4] = {poly[0], poly[1], poly[2], poly[3]};
    for (int i = 0; i < 4; i++)
      for (int j = 0; j < 4; j++)
        if (E->cut[i][j] >= 0) {
          end[E->cut[i][j]][0] = i;
          end[E->cut[i][j]][1] = j;
        }
    q[0] = poly[0];
    int used = 1 << 0;
    for (int k = 1; k < 4; k++) {
      const int *pe = end[q[k - 1]];
      for (int m = 1; m < 4; m++) {
        if (used & (1 << m)) continue;
        const int *qe = end[poly[m]];
        if (pe[0] == qe[0] || pe[0] == qe[1] || pe[1] == qe[0] ||
            pe[1] == qe[1]) {
          q[k] = poly[m];
          used |= 1 << m;
          break;
        }
      }
    }
    memcpy(poly, q, sizeof q);
  }
  return n;
}

/* The smallest point of poly[0..n) (key order). */
static int smallest(const epts *E, const int *poly, int n) {
  int m = 0;
  for (int i = 1; i < n; i++)
    if (lpt_less(&E->p[poly[i]], &E->p[poly[m]])) m = i;
  return m;
}

/* A simplex of the cut, given as point indices of E (positively oriented
 * by the caller of the sink). */
typedef pa_status (*simplex_sink)(void *ctx, const epts *E, const int *s);

/* Euclidean quality of triangle abc (4 sqrt 3 A / sum l^2). */
static double tri_quality(const double *a, const double *b, const double *c) {
  double u[2] = {b[0] - a[0], b[1] - a[1]}, v[2] = {c[0] - a[0], c[1] - a[1]};
  double w[2] = {c[0] - b[0], c[1] - b[1]};
  double area = 0.5 * fabs(u[0] * v[1] - u[1] * v[0]);
  double l2 = u[0] * u[0] + u[1] * u[1] + v[0] * v[0] + v[1] * v[1] +
              w[0] * w[0] + w[1] * w[1];
  return l2 > 0 ? 4 * sqrt(3.0) * area / l2 : 0;
}

/* The simplices of the part of the element on side (-1 inside, +1
 * outside), given to sink. */
static pa_status side_simplices(const epts *E, int side, simplex_sink sink,
                                void *ctx) {
  pa_status st = PA_SUCCESS;
  if (E->dim == 2) {
    int tri[3] = {0, 1, 2}, poly[5];
    int n = clip_face(E, tri, 3, side, poly);
    if (n < 3) return st;
    if (n == 3) {
      int s[3] = {poly[0], poly[1], poly[2]};
      return sink(ctx, E, s);
    }
    /* a quadrilateral: the diagonal whose triangles' worst is better (ties:
     * the one from poly[0]) */
    const double *x[4];
    for (int i = 0; i < 4; i++) x[i] = E->p[poly[i]].x;
    double q0 = fmin(tri_quality(x[0], x[1], x[2]),
                     tri_quality(x[0], x[2], x[3]));
    double q1 = fmin(tri_quality(x[1], x[2], x[3]),
                     tri_quality(x[1], x[3], x[0]));
    int o = q1 > q0 ? 1 : 0;
    int s1[3] = {poly[o], poly[o + 1], poly[(o + 2) % 4]};
    int s2[3] = {poly[o], poly[(o + 2) % 4], poly[(o + 3) % 4]};
    PA_CALL(sink(ctx, E, s1));
    PA_CALL(sink(ctx, E, s2));
    return st;
  }
  /* facets: the clipped faces and the cut facet */
  static const int face[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  int fac[5][6], nf[5], nfac = 0;
  for (int f = 0; f < 4; f++) {
    int n = clip_face(E, face[f], 3, side, fac[nfac]);
    if (n >= 3) nf[nfac++] = n;
  }
  {
    int n = cut_facet(E, fac[nfac]);
    if (n >= 3) nf[nfac++] = n;
  }
  /* the smallest point of the side */
  int apex = -1;
  for (int i = 0; i < E->n; i++)
    if (on_side(&E->p[i], side) &&
        (apex < 0 || lpt_less(&E->p[i], &E->p[apex])))
      apex = i;
  for (int f = 0; f < nfac; f++) {
    const int *F = fac[f];
    int n = nf[f], has = 0;
    for (int i = 0; i < n; i++) has |= F[i] == apex;
    if (has) continue;
    int m = smallest(E, F, n);
    for (int i = 1; i + 1 < n; i++) {
      int s[4] = {apex, F[m], F[(m + i) % n], F[(m + i + 1) % n]};
      PA_CALL(sink(ctx, E, s));
    }
  }
cleanup:
  return st;
}

/* The signed volume of simplex s of E. */
static double simplex_vol(const epts *E, const int *s) {
  const double *x[4] = {E->p[s[0]].x, E->p[s[1]].x, E->p[s[2]].x,
                        E->dim == 3 ? E->p[s[3]].x : NULL};
  return pa__simplex_volume(E->dim, x);
}

/* The points of element e for s (added points numbered from nv by
 * addidx, or -1 when only volumes are wanted; coordinates in ax, 3 per
 * added point of this element). */
static void element_points(const pa__ls_ctx *c, const double *s, pa_idx e,
                           epts *E, double (*ax)[3],
                           const pa_idx *addidx) {
  const pa_mesh *m = c->mesh;
  int d = m->dim, nve = d + 1;
  const pa_idx *v = m->elem + (size_t)nve * e;
  E->dim = d;
  E->n = nve;
  for (int i = 0; i < nve; i++) {
    lpt *p = &E->p[i];
    p->x = m->coord + (size_t)d * v[i];
    p->id = v[i];
    p->added = 0;
    p->sign = sgn(s[v[i]]);
    p->k0 = vkey(c, v[i]);
    p->k1 = -1;
    for (int j = 0; j < 4; j++) E->cut[i][j] = -1;
  }
  int na = 0;
  for (int i = 0; i < nve; i++)
    for (int j = i + 1; j < nve; j++) {
      if (E->p[i].sign * E->p[j].sign >= 0) continue;
      int a = i, b = j;
      if (E->p[b].k0 < E->p[a].k0) {
        a = j;
        b = i;
      }
      double sa = s[v[a]], sb = s[v[b]], t = sa / (sa - sb);
      const double *xa = E->p[a].x, *xb = E->p[b].x;
      for (int k = 0; k < d; k++) ax[na][k] = xa[k] + t * (xb[k] - xa[k]);
      lpt *p = &E->p[E->n];
      p->x = ax[na];
      p->id = addidx ? addidx[na] : -1;
      p->added = 1;
      p->sign = 0;
      p->k0 = E->p[a].k0;
      p->k1 = E->p[b].k0;
      E->cut[i][j] = E->cut[j][i] = E->n;
      E->n++;
      na++;
    }
}

/* ---- side volumes (components) ------------------------------------------ */

static pa_status vol_sink(void *ctx, const epts *E, const int *s) {
  *(double *)ctx += fabs(simplex_vol(E, s));
  return PA_SUCCESS;
}

/* The volume of the part of element e on side (s values). */
static pa_status side_volume(const pa__ls_ctx *c, const double *s, pa_idx e,
                             int side, double *vol) {
  pa_status st = PA_SUCCESS;
  const pa_mesh *m = c->mesh;
  int nve = m->dim + 1, has[3] = {0, 0, 0};
  const pa_idx *v = m->elem + (size_t)nve * e;
  for (int i = 0; i < nve; i++) has[sgn(s[v[i]]) + 1] = 1;
  *vol = 0;
  if (!has[1 + side]) return st;
  if (!has[1 - side]) {
    *vol = fabs(pa_mesh_elem_volume(m, e));
    return st;
  }
  epts E;
  double ax[4][3];
  element_points(c, s, e, &E, ax, NULL);
  PA_CALL(side_simplices(&E, side, vol_sink, vol));
cleanup:
  return st;
}

/* ---- step 1 and 2: snapping and components ----------------------------- */

static pa_idx uf_find(pa_idx *up, pa_idx x) {
  while (up[x] != x) {
    up[x] = up[up[x]];
    x = up[x];
  }
  return x;
}

/* lab[v]: the smallest key of the component of side of each vertex of
 * that side (NOLABEL for the others), over every rank. */
static pa_status components(const pa__ls_ctx *c, const double *s, int side,
                            pa_gid *lab) {
  pa_status st = PA_SUCCESS;
  const pa_mesh *m = c->mesh;
  pa_idx nv = m->nv, *up = NULL;
  int nve = m->dim + 1;
  pa_gid *old = NULL;
  PA_ALLOC(up, nv);
  if (c->vmin) PA_ALLOC(old, nv);
  for (pa_idx v = 0; v < nv; v++)
    lab[v] = sgn(s[v]) == side ? vkey(c, v) : NOLABEL;
  for (;;) {
    for (pa_idx v = 0; v < nv; v++) up[v] = v;
    for (pa_idx e = 0; e < c->nelem; e++) {
      const pa_idx *ev = m->elem + (size_t)nve * e;
      pa_idx r0 = -1;
      for (int i = 0; i < nve; i++) {
        if (lab[ev[i]] == NOLABEL) continue;
        pa_idx r = uf_find(up, ev[i]);
        if (r0 < 0) r0 = r;
        else if (r != r0) up[r] = r0;
      }
    }
    for (pa_idx v = 0; v < nv; v++) {
      if (lab[v] == NOLABEL) continue;
      pa_idx r = uf_find(up, v);
      if (lab[v] < lab[r]) lab[r] = lab[v];
    }
    for (pa_idx v = 0; v < nv; v++)
      if (lab[v] != NOLABEL) lab[v] = lab[uf_find(up, v)];
    if (!c->vmin) break;
    memcpy(old, lab, (size_t)nv * sizeof *lab);
    PA_CALL(c->vmin(c->ctx, lab));
    double changed = 0;
    for (pa_idx v = 0; v < nv && !changed; v++) changed = lab[v] != old[v];
    PA_CALL(c->max(c->ctx, &changed, 1));
    if (!changed) break;
  }
cleanup:
  pa__free(up);
  pa__free(old);
  return st;
}

typedef struct labvol {
  pa_gid lab;
  double vol;
} labvol;

static int labvol_cmp(const void *a, const void *b) {
  const labvol *x = a, *y = b;
  return (x->lab > y->lab) - (x->lab < y->lab);
}

/* Sort pairs by label and sum the volumes of equal labels; returns the
 * count left. */
static size_t labvol_merge(labvol *p, size_t n) {
  if (!n) return 0;
  qsort(p, n, sizeof *p, labvol_cmp);
  size_t w = 0;
  for (size_t i = 1; i < n; i++) {
    if (p[i].lab == p[w].lab) p[w].vol += p[i].vol;
    else p[++w] = p[i];
  }
  return w + 1;
}

/* The components of side below rmc times the mesh volume (total) change
 * side; *nremoved: how many, over every rank. */
static pa_status remove_small(const pa__ls_ctx *c, double *s, int side,
                              double bound, pa_gid *nremoved) {
  pa_status st = PA_SUCCESS;
  const pa_mesh *m = c->mesh;
  pa_idx nv = m->nv;
  int nve = m->dim + 1;
  pa_gid *lab = NULL, *alab = NULL;
  double *avol = NULL, *vol = NULL;
  labvol *p = NULL, *all = NULL;
  size_t np = 0, nall = 0;
  *nremoved = 0;
  PA_ALLOC(lab, nv);
  PA_CALL(components(c, s, side, lab));
  PA_ALLOC(p, c->nelem);
  for (pa_idx e = 0; e < c->nelem; e++) {
    const pa_idx *ev = m->elem + (size_t)nve * e;
    pa_gid l = NOLABEL;
    for (int i = 0; i < nve && l == NOLABEL; i++) l = lab[ev[i]];
    if (l == NOLABEL) continue;
    double w;
    PA_CALL(side_volume(c, s, e, side, &w));
    p[np].lab = l;
    p[np++].vol = w;
  }
  np = labvol_merge(p, np);
  {
    pa_gid *l = NULL;
    PA_ALLOC(l, np);
    PA_ALLOC(vol, np);
    for (size_t i = 0; i < np; i++) {
      l[i] = p[i].lab;
      vol[i] = p[i].vol;
    }
    st = c->gather(c->ctx, l, vol, np, &alab, &avol, &nall);
    pa__free(l);
    PA_CALL(st);
  }
  PA_ALLOC(all, nall);
  for (size_t i = 0; i < nall; i++) {
    all[i].lab = alab[i];
    all[i].vol = avol[i];
  }
  nall = labvol_merge(all, nall);
  {
    size_t w = 0; /* keep the small ones */
    for (size_t i = 0; i < nall; i++)
      if (all[i].vol < bound) all[w++] = all[i];
    nall = w;
  }
  *nremoved = (pa_gid)nall;
  for (pa_idx v = 0; v < nv && nall; v++) {
    if (lab[v] == NOLABEL) continue;
    labvol key = {lab[v], 0};
    if (bsearch(&key, all, nall, sizeof *all, labvol_cmp)) s[v] = -s[v];
  }
cleanup:
  pa__free(lab);
  pa__free(alab);
  pa__free(avol);
  pa__free(vol);
  pa__free(p);
  pa__free(all);
  return st;
}

pa_status pa__ls_prepare(const pa__ls_ctx *c, const pa_levelset_opts *o,
                         double *s, pa_levelset_report *rep) {
  pa_status st = PA_SUCCESS;
  const pa_mesh *m = c->mesh;
  pa_idx nv = m->nv;
  int nve = m->dim + 1;
  uint8_t *flag = NULL;
  double range[2] = {-INFINITY, -INFINITY}; /* max phi, -min phi */
  for (pa_idx v = 0; v < c->nvert && st == PA_SUCCESS; v++) {
    if (!isfinite(s[v]))
      st = pa__error(PA_ERR_ARG, __FILE__, __LINE__,
                     "level set: vertex %lld has the value %g, not a finite "
                     "number",
                     (long long)vkey(c, v) + 1, s[v]);
    if (s[v] > range[0]) range[0] = s[v];
    if (-s[v] > range[1]) range[1] = -s[v];
  }
  PA_CALL(c->agree(c->ctx, st));
  PA_CALL(c->max(c->ctx, range, 2));
  rep->phi_max = range[0];
  rep->phi_min = -range[1];
  for (pa_idx v = 0; v < nv; v++) s[v] -= o->value;
  /* snapping, from the values as given */
  PA_CALLOC(flag, nv);
  for (pa_idx e = 0; e < c->nelem; e++) {
    const pa_idx *ev = m->elem + (size_t)nve * e;
    for (int i = 0; i < nve; i++)
      for (int j = i + 1; j < nve; j++) {
        pa_idx a = ev[i], b = ev[j];
        if (!(s[a] * s[b] < 0)) continue;
        if (vkey(c, b) < vkey(c, a)) {
          pa_idx x = a;
          a = b;
          b = x;
        }
        double t = s[a] / (s[a] - s[b]);
        if (t < o->snap) flag[a] = 1;
        if (t > 1 - o->snap) flag[b] = 1;
      }
  }
  if (c->vmax) PA_CALL(c->vmax(c->ctx, flag));
  {
    double n = 0;
    for (pa_idx v = 0; v < nv; v++)
      if (flag[v]) {
        s[v] = 0;
        n += v < c->nvert;
      }
    PA_CALL(c->sum(c->ctx, &n, 1));
    rep->nsnapped = (pa_gid)n;
  }
  /* parasitic components */
  if (o->rmc > 0) {
    double total = 0;
    for (pa_idx e = 0; e < c->nelem; e++)
      total += fabs(pa_mesh_elem_volume(m, e));
    PA_CALL(c->sum(c->ctx, &total, 1));
    PA_CALL(remove_small(c, s, 1, o->rmc * total, &rep->nremoved_out));
    PA_CALL(remove_small(c, s, -1, o->rmc * total, &rep->nremoved_in));
  }
cleanup:
  pa__free(flag);
  return st;
}

/* ---- materials ---------------------------------------------------------- */

pa_status pa__ls_materials(const pa__ls_ctx *c, const pa_levelset_opts *o,
                           uint8_t *split, int32_t *rin, int32_t *rex) {
  pa_status st = PA_SUCCESS;
  const pa_mesh *m = c->mesh;
  for (pa_idx e = 0; e < c->nelem; e++) {
    int32_t r = m->eref[e];
    if (o->nmat == 0) {
      split[e] = 1;
      rin[e] = o->ref_in;
      rex[e] = o->ref_out;
      continue;
    }
    const pa_ls_material *a = NULL;
    for (int i = 0; i < o->nmat && !a; i++)
      if (o->mat[i].ref == r) a = &o->mat[i];
    /* a side of a material split before: that material */
    for (int i = 0; i < o->nmat && !a; i++)
      if (o->mat[i].split && (o->mat[i].ref_in == r || o->mat[i].ref_out == r))
        a = &o->mat[i];
    PA_CHECK(a, PA_ERR_ARG,
             "level set: element %lld has the reference %d, which the "
             "material table (LSReferences) does not list",
             (long long)(c->ekey ? c->ekey[e] : e) + 1, (int)r);
    split[e] = (uint8_t)(a->split != 0);
    rin[e] = a->split ? a->ref_in : r;
    rex[e] = a->split ? a->ref_out : r;
  }
cleanup:
  return st;
}

/* ---- the cut ------------------------------------------------------------- */

void pa__ls_out_free(pa__ls_out *o) {
  pa__ls_cells *cl[4] = {&o->elem, &o->bdry, &o->edge, &o->zero};
  for (int k = 0; k < 4; k++) {
    pa__free(cl[k]->v);
    pa__free(cl[k]->ref);
    pa__free(cl[k]->flag);
    pa__free(cl[k]->parent);
  }
  pa__free(o->end);
  pa__free(o->t);
  pa__free(o->addtouch);
  pa__free(o->touch);
  memset(o, 0, sizeof *o);
}

static pa_status cells_add(pa__ls_cells *c, const pa_idx *v, int32_t ref,
                           uint8_t flag, pa_idx parent) {
  pa_status st = PA_SUCCESS;
  if ((size_t)c->n >= c->cap) {
    size_t cap = c->cap ? c->cap + c->cap / 2 : 64;
    pa_idx *nv = pa__realloc(c->v, cap * (size_t)c->nvc * sizeof *nv);
    PA_CHECK(nv, PA_ERR_MEMORY, "out of memory cutting a level set");
    c->v = nv;
    int32_t *nr = pa__realloc(c->ref, cap * sizeof *nr);
    PA_CHECK(nr, PA_ERR_MEMORY, "out of memory cutting a level set");
    c->ref = nr;
    uint8_t *nf = pa__realloc(c->flag, cap);
    PA_CHECK(nf, PA_ERR_MEMORY, "out of memory cutting a level set");
    c->flag = nf;
    pa_idx *np = pa__realloc(c->parent, cap * sizeof *np);
    PA_CHECK(np, PA_ERR_MEMORY, "out of memory cutting a level set");
    c->parent = np;
    c->cap = cap;
  }
  memcpy(c->v + (size_t)c->nvc * c->n, v, (size_t)c->nvc * sizeof *v);
  c->ref[c->n] = ref;
  c->flag[c->n] = flag;
  c->parent[c->n] = parent;
  c->n++;
cleanup:
  return st;
}

/* The working state of pa__ls_cut. */
typedef struct cutter {
  const pa__ls_ctx *c;
  const pa_levelset_opts *o;
  const double *s;
  size_t *estart;   /* edges of this rank's elements (pa__edges_csr) */
  pa_idx *eother;
  pa_idx *eadd;     /* per edge entry: its added vertex, or -1 */
  pa__ls_out *out;
  /* the element being cut */
  pa_idx e;
  int32_t ref;      /* the reference of the simplices sunk */
  uint8_t flag;
  int side;         /* their side */
  int split;        /* their element's material is split */
} cutter;

/* The added vertex of edge (a, b), or -1. */
static pa_idx added_on(const cutter *k, pa_idx a, pa_idx b) {
  if (vkey(k->c, b) < vkey(k->c, a)) {
    pa_idx x = a;
    a = b;
    b = x;
  }
  for (size_t q = k->estart[a]; q < k->estart[a + 1]; q++)
    if (k->eother[q] == b) return k->eadd[q];
  return -1;
}

/* Record the vertices of an output element of a split material. */
static void touch(cutter *k, const pa_idx *v, int n, int side, int split) {
  if (!split) return;
  uint8_t bit = side < 0 ? PA_LS_TOUCH_IN : PA_LS_TOUCH_OUT;
  pa_idx nv = k->c->mesh->nv;
  for (int i = 0; i < n; i++) {
    if (v[i] < nv) k->out->touch[v[i]] |= bit;
    else k->out->addtouch[v[i] - nv] |= bit;
  }
}

/* An output element from simplex s of E on k->side, positively oriented. */
static pa_status elem_sink(void *ctx, const epts *E, const int *s) {
  cutter *k = ctx;
  int n = E->dim + 1, q[4] = {s[0], s[1], s[2], E->dim == 3 ? s[3] : 0};
  double vol = simplex_vol(E, q);
  const double *x[4] = {E->p[q[0]].x, E->p[q[1]].x, E->p[q[2]].x,
                        E->dim == 3 ? E->p[q[3]].x : NULL};
  if (pa__orient(E->dim, x) < 0) {
    int t = q[1];
    q[1] = q[2];
    q[2] = t;
  }
  pa_idx v[4];
  for (int i = 0; i < n; i++) v[i] = E->p[q[i]].id;
  k->out->vol[k->side < 0 ? 0 : 1] += fabs(vol);
  touch(k, v, n, k->side, k->split);
  return cells_add(&k->out->elem, v, k->ref, k->flag, -2 - k->e);
}

/* The interface entities of cut element E (split material): the cut
 * facet, fanned from its smallest point, oriented out of the inside. */
static pa_status element_interface(cutter *k, const epts *E) {
  pa_status st = PA_SUCCESS;
  int32_t ref = k->o->ref_iface;
  int in = -1;
  for (int i = 0; i < E->n && in < 0; i++)
    if (!E->p[i].added && E->p[i].sign < 0) in = i;
  if (E->dim == 2) {
    /* the zero points, in the inside polygon's order */
    int tri[3] = {0, 1, 2}, poly[5];
    int n = clip_face(E, tri, 3, -1, poly);
    for (int i = 0; i < n; i++) {
      const lpt *a = &E->p[poly[i]], *b = &E->p[poly[(i + 1) % n]];
      if ((a->added || a->sign == 0) && (b->added || b->sign == 0)) {
        pa_idx v[2] = {a->id, b->id};
        return cells_add(&k->out->bdry, v, ref, 0, -1);
      }
    }
    return st;
  }
  int F[6];
  int n = cut_facet(E, F);
  if (n < 3) return st;
  int m = smallest(E, F, n);
  for (int i = 1; i + 1 < n; i++) {
    int t[3] = {F[m], F[(m + i) % n], F[(m + i + 1) % n]};
    if (pa__orient3d(E->p[t[0]].x, E->p[t[1]].x, E->p[t[2]].x, E->p[in].x) >
        0) {
      int x = t[1];
      t[1] = t[2];
      t[2] = x;
    }
    pa_idx v[3] = {E->p[t[0]].id, E->p[t[1]].id, E->p[t[2]].id};
    PA_CALL(cells_add(&k->out->bdry, v, ref, 0, -1));
  }
cleanup:
  return st;
}

/* Cut (or keep) element e. */
static pa_status cut_element(cutter *k, pa_idx e, const uint8_t *split,
                             const int32_t *rin, const int32_t *rex) {
  pa_status st = PA_SUCCESS;
  const pa_mesh *m = k->c->mesh;
  int d = m->dim, nve = d + 1, has[3] = {0, 0, 0};
  const pa_idx *v = m->elem + (size_t)nve * e;
  const double *s = k->s;
  for (int i = 0; i < nve; i++) has[sgn(s[v[i]]) + 1] = 1;
  k->e = e;
  k->flag = m->eflag[e];
  if (!has[0] || !has[2]) { /* one side: kept whole */
    int side = has[0] ? -1 : 1;
    int32_t ref = side < 0 ? rin[e] : rex[e];
    k->out->vol[side < 0 ? 0 : 1] += fabs(pa_mesh_elem_volume(m, e));
    touch(k, v, nve, side, split[e]);
    PA_CALL(cells_add(&k->out->elem, v, ref, k->flag, e));
    /* faces on the zero set: candidates for the interface */
    for (int i = 0; i < nve; i++) {
      int zero = 1;
      for (int j = 0; j < nve; j++) zero &= j == i || s[v[j]] == 0;
      if (!zero) continue;
      pa_idx f[3];
      pa__elem_face(m, e, i, f);
      int32_t code = !split[e] ? 0 : side < 0 ? 1 : 2;
      PA_CALL(cells_add(&k->out->zero, f, code, 0, e));
    }
    return st;
  }
  k->out->nelem_cut++;
  epts E;
  double ax[4][3];
  pa_idx addidx[4];
  {
    int na = 0;
    for (int i = 0; i < nve; i++)
      for (int j = i + 1; j < nve; j++)
        if (sgn(s[v[i]]) * sgn(s[v[j]]) < 0)
          addidx[na++] = m->nv + added_on(k, v[i], v[j]);
  }
  element_points(k->c, s, e, &E, ax, addidx);
  k->split = split[e];
  for (int side = -1; side <= 1; side += 2) {
    k->side = side;
    k->ref = side < 0 ? rin[e] : rex[e];
    PA_CALL(side_simplices(&E, side, elem_sink, k));
  }
  if (split[e]) PA_CALL(element_interface(k, &E));
cleanup:
  return st;
}

/* Cut (or keep) boundary entity b (dim vertices) or feature edge (2), of
 * reference ref and flag fl, into cells. */
static pa_status cut_face(cutter *k, const pa_idx *v, int nv, int32_t ref,
                          uint8_t fl, pa_idx b, pa__ls_cells *cells) {
  pa_status st = PA_SUCCESS;
  const pa_mesh *m = k->c->mesh;
  const double *s = k->s;
  int has[3] = {0, 0, 0};
  for (int i = 0; i < nv; i++) has[sgn(s[v[i]]) + 1] = 1;
  if (!has[0] || !has[2]) return cells_add(cells, v, ref, fl, b);
  if (nv == 2) { /* an edge: two halves, same direction */
    pa_idx p = m->nv + added_on(k, v[0], v[1]);
    pa_idx h1[2] = {v[0], p}, h2[2] = {p, v[1]};
    PA_CALL(cells_add(cells, h1, ref, fl, -2 - b));
    PA_CALL(cells_add(cells, h2, ref, fl, -2 - b));
    return st;
  }
  /* a triangle: its two clipped polygons, fanned from their smallest point,
   * each piece turned as the triangle */
  epts E;
  double ax[3][3];
  E.dim = 3;
  E.n = 3;
  for (int i = 0; i < 3; i++) {
    lpt *p = &E.p[i];
    p->x = m->coord + 3 * (size_t)v[i];
    p->id = v[i];
    p->added = 0;
    p->sign = sgn(s[v[i]]);
    p->k0 = vkey(k->c, v[i]);
    p->k1 = -1;
    for (int j = 0; j < 4; j++) E.cut[i][j] = -1;
  }
  for (int i = 0; i < 3; i++)
    for (int j = i + 1; j < 3; j++) {
      if (E.p[i].sign * E.p[j].sign >= 0) continue;
      int a = E.p[j].k0 < E.p[i].k0 ? j : i, z = a == i ? j : i;
      double sa = s[v[a]], sz = s[v[z]], t = sa / (sa - sz);
      lpt *p = &E.p[E.n];
      for (int q = 0; q < 3; q++)
        ax[E.n - 3][q] = E.p[a].x[q] + t * (E.p[z].x[q] - E.p[a].x[q]);
      p->x = ax[E.n - 3];
      p->id = m->nv + added_on(k, v[i], v[j]);
      p->added = 1;
      p->sign = 0;
      p->k0 = E.p[a].k0;
      p->k1 = E.p[z].k0;
      E.cut[i][j] = E.cut[j][i] = E.n++;
    }
  double n0[3];
  {
    const double *a = E.p[0].x, *b = E.p[1].x, *c = E.p[2].x;
    double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    double w[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    n0[0] = u[1] * w[2] - u[2] * w[1];
    n0[1] = u[2] * w[0] - u[0] * w[2];
    n0[2] = u[0] * w[1] - u[1] * w[0];
  }
  int tri[3] = {0, 1, 2};
  for (int side = -1; side <= 1; side += 2) {
    int poly[5];
    int n = clip_face(&E, tri, 3, side, poly);
    if (n < 3) continue;
    int q = smallest(&E, poly, n);
    for (int i = 1; i + 1 < n; i++) {
      int t[3] = {poly[q], poly[(q + i) % n], poly[(q + i + 1) % n]};
      const double *xa = E.p[t[0]].x, *xb = E.p[t[1]].x, *xc = E.p[t[2]].x;
      double u[3] = {xb[0] - xa[0], xb[1] - xa[1], xb[2] - xa[2]};
      double w[3] = {xc[0] - xa[0], xc[1] - xa[1], xc[2] - xa[2]};
      double n1[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2],
                      u[0] * w[1] - u[1] * w[0]};
      if (n1[0] * n0[0] + n1[1] * n0[1] + n1[2] * n0[2] < 0) {
        int x = t[1];
        t[1] = t[2];
        t[2] = x;
      }
      pa_idx pv[3] = {E.p[t[0]].id, E.p[t[1]].id, E.p[t[2]].id};
      PA_CALL(cells_add(cells, pv, ref, fl, -2 - b));
    }
  }
cleanup:
  return st;
}

/* The edges of this rank's elements and the vertices added on those that
 * change sign. */
static pa_status add_vertices_on_edges(cutter *k) {
  pa_status st = PA_SUCCESS;
  const pa_mesh *m = k->c->mesh;
  pa__ls_out *o = k->out;
  const double *s = k->s;
  PA_CALL(pa__edges_csr(m->elem, k->c->nelem, m->dim + 1, m->nv, k->c->vkey,
                        &k->estart, &k->eother));
  size_t ne = k->estart[m->nv];
  PA_ALLOC(k->eadd, ne);
  for (pa_idx a = 0; a < m->nv; a++)
    for (size_t q = k->estart[a]; q < k->estart[a + 1]; q++) {
      pa_idx b = k->eother[q];
      k->eadd[q] = -1;
      if (!(sgn(s[a]) * sgn(s[b]) < 0)) continue;
      if ((size_t)o->nadd >= o->capadd) {
        size_t cap = o->capadd ? o->capadd + o->capadd / 2 : 64;
        pa_idx *ne2 = pa__realloc(o->end, 2 * cap * sizeof *ne2);
        PA_CHECK(ne2, PA_ERR_MEMORY, "out of memory cutting a level set");
        o->end = ne2;
        double *nt = pa__realloc(o->t, cap * sizeof *nt);
        PA_CHECK(nt, PA_ERR_MEMORY, "out of memory cutting a level set");
        o->t = nt;
        o->capadd = cap;
      }
      k->eadd[q] = o->nadd;
      o->end[2 * (size_t)o->nadd] = a; /* filed under the end of smaller key */
      o->end[2 * (size_t)o->nadd + 1] = b;
      o->t[o->nadd] = s[a] / (s[a] - s[b]);
      o->nadd++;
    }
  PA_CALLOC(o->addtouch, o->nadd);
cleanup:
  return st;
}

pa_status pa__ls_cut(const pa__ls_ctx *c, const pa_levelset_opts *o,
                     const double *s, const uint8_t *split,
                     const int32_t *rin, const int32_t *rex,
                     const uint8_t *bdrop, pa__ls_out *out) {
  pa_status st = PA_SUCCESS;
  const pa_mesh *m = c->mesh;
  int d = m->dim;
  cutter k;
  memset(&k, 0, sizeof k);
  memset(out, 0, sizeof *out);
  k.c = c;
  k.o = o;
  k.s = s;
  k.out = out;
  out->elem.nvc = d + 1;
  out->bdry.nvc = d;
  out->edge.nvc = 2;
  out->zero.nvc = d;
  PA_CALLOC(out->touch, m->nv);
  PA_CALL(add_vertices_on_edges(&k));
  for (pa_idx e = 0; e < c->nelem; e++)
    PA_CALL(cut_element(&k, e, split, rin, rex));
  for (pa_idx b = 0; b < c->nbdry; b++) {
    if (bdrop && bdrop[b]) continue;
    PA_CALL(cut_face(&k, m->bdry + (size_t)d * b, d, m->bref[b], m->bflag[b],
                     b, &out->bdry));
  }
  for (pa_idx b = 0; b < c->nedge; b++)
    PA_CALL(cut_face(&k, m->edge + 2 * (size_t)b, 2, m->edref[b],
                     m->edflag[b], b, &out->edge));
cleanup:
  pa__free(k.estart);
  pa__free(k.eother);
  pa__free(k.eadd);
  if (st != PA_SUCCESS) pa__ls_out_free(out);
  return st;
}

/* ---- interface faces on the zero set ------------------------------------- */

typedef struct zkey {
  pa_gid k[3];
  pa_idx i;
} zkey;

static int zkey_cmp(const void *a, const void *b) {
  const zkey *x = a, *y = b;
  for (int j = 0; j < 3; j++)
    if (x->k[j] != y->k[j]) return (x->k[j] > y->k[j]) - (x->k[j] < y->k[j]);
  return (x->i > y->i) - (x->i < y->i);
}

pa_status pa__ls_zero_faces(const pa__ls_cells *z, const pa_gid *key,
                            int32_t ref, pa__ls_cells *cells) {
  pa_status st = PA_SUCCESS;
  zkey *zk = NULL;
  int nvc = z->nvc;
  PA_ALLOC(zk, z->n);
  for (pa_idx i = 0; i < z->n; i++) {
    zkey *x = &zk[i];
    x->k[2] = -1;
    for (int j = 0; j < nvc; j++) {
      pa_idx v = z->v[(size_t)nvc * i + j];
      x->k[j] = key ? key[v] : (pa_gid)v;
    }
    for (int a = 1; a < nvc; a++) /* sort the keys */
      for (int b = a; b > 0 && x->k[b] < x->k[b - 1]; b--) {
        pa_gid t = x->k[b];
        x->k[b] = x->k[b - 1];
        x->k[b - 1] = t;
      }
    x->i = i;
  }
  qsort(zk, (size_t)z->n, sizeof *zk, zkey_cmp);
  for (pa_idx i = 0; i < z->n;) {
    pa_idx j = i + 1;
    while (j < z->n && !memcmp(zk[j].k, zk[i].k, sizeof zk[i].k)) j++;
    if (j - i == 2) {
      int32_t c0 = z->ref[zk[i].i], c1 = z->ref[zk[i + 1].i];
      if (c0 + c1 == 3 && c0 && c1) {
        pa_idx in = c0 == 1 ? zk[i].i : zk[i + 1].i;
        PA_CALL(cells_add(cells, z->v + (size_t)nvc * in, ref, 0, -1));
      }
    }
    i = j;
  }
cleanup:
  pa__free(zk);
  return st;
}

/* ---- added vertices ------------------------------------------------------- */

pa_status pa__ls_add_vertices(const pa_mesh *src, pa_idx nadd,
                              const pa_idx *end, const double *t, pa_mesh *m) {
  pa_status st = PA_SUCCESS;
  int d = m->dim, nc = m->met_ncomp;
  pa_idx nv0 = m->nv;
  PA_CALL(pa__mesh_grow_vertices(m, (size_t)nv0 + (size_t)nadd));
  /* (src may be m: its arrays are read through it after the growth) */
  for (pa_idx k = 0; k < nadd; k++) {
    pa_idx a = end[2 * (size_t)k], b = end[2 * (size_t)k + 1], v = nv0 + k;
    double w[2] = {1 - t[k], t[k]};
    const double *xa = src->coord + (size_t)d * a, *xb = src->coord + (size_t)d * b;
    for (int j = 0; j < d; j++)
      m->coord[(size_t)d * v + j] = xa[j] + t[k] * (xb[j] - xa[j]);
    m->vref[v] = 0;
    m->vflag[v] = 0;
    if (nc) {
      const double *mv[2] = {src->met + (size_t)nc * a, src->met + (size_t)nc * b};
      pa__metric_interp(d, nc, 2, mv, w, m->met + (size_t)nc * v);
    }
    for (int f = 0; f < m->nfield; f++) {
      int fc = m->field[f].ncomp;
      const double *fv[2] = {src->field[f].val + (size_t)fc * a,
                             src->field[f].val + (size_t)fc * b};
      pa__field_interp(d, fc, pa__field_is_metric(d, m->field[f].name, fc), 2,
                       fv, w, m->field[f].val + (size_t)fc * v);
    }
  }
  m->nv = nv0 + nadd;
cleanup:
  return st;
}

/* ---- the sequential cut --------------------------------------------------- */

/* drop[b]: boundary entity b lies inside the domain (two elements hold it)
 * with the interface's reference; *ninner, *nouter: the counts of that
 * reference inside and on the boundary. */
static pa_status old_interface(pa_mesh *mesh, int32_t ref, uint8_t *drop,
                               pa_gid *ninner, pa_gid *nouter) {
  pa_status st = PA_SUCCESS;
  const pa_idx *adja;
  int d = mesh->dim, nve = d + 1;
  *ninner = *nouter = 0;
  int any = 0;
  for (pa_idx b = 0; b < mesh->nb && !any; b++) any = mesh->bref[b] == ref;
  if (!any) return st;
  PA_CALL(pa_mesh_build_adjacency(mesh, &adja));
  for (pa_idx e = 0; e < mesh->ne; e++)
    for (int i = 0; i < nve; i++) {
      pa_idx o = adja[(size_t)nve * e + i];
      if (o < 0 || o / nve < e) continue;
      pa_idx f[3], b;
      pa__elem_face(mesh, e, i, f);
      PA_CALL(pa_mesh_find_bdry(mesh, f, &b));
      if (b >= 0 && mesh->bref[b] == ref) drop[b] = 1;
    }
  for (pa_idx b = 0; b < mesh->nb; b++)
    if (mesh->bref[b] == ref) {
      *ninner += drop[b];
      *nouter += !drop[b];
    }
cleanup:
  return st;
}

/* Copy the cells into the arrays of a mesh kind (conn: nvc per cell). */
static pa_status cells_to(const pa__ls_cells *c, pa_idx *conn, int32_t *ref,
                          uint8_t *flag) {
  if (!c->n) return PA_SUCCESS;
  memcpy(conn, c->v, (size_t)c->n * (size_t)c->nvc * sizeof *conn);
  memcpy(ref, c->ref, (size_t)c->n * sizeof *ref);
  memcpy(flag, c->flag, (size_t)c->n);
  return PA_SUCCESS;
}

/* The fields of mesh on its entities at onto the new cells c of nm: a cell
 * takes the values of the one it comes from (kept whole, or a part of it:
 * the parts cover their parent, so a density keeps its integral), a new
 * interface entity zeros; with their transfer modes. */
static pa_status carry_fields(const pa_mesh *mesh, pa_entity at,
                              const pa__ls_cells *c, pa_mesh *nm) {
  pa_status st = PA_SUCCESS;
  int *nf;
  const pa__field *fl = pa__mesh_fields((pa_mesh *)mesh, at, &nf);
  double *y = NULL;
  for (int f = 0; f < *nf; f++) {
    int nc = fl[f].ncomp;
    PA_ALLOC(y, (size_t)nc * (c->n ? (size_t)c->n : 1));
    for (pa_idx i = 0; i < c->n; i++) {
      pa_idx o = pa__ls_origin(c->parent[i]);
      for (int j = 0; j < nc; j++)
        y[(size_t)nc * i + j] = o >= 0 ? fl[f].val[(size_t)nc * o + j] : 0;
    }
    PA_CALL(pa_mesh_add_field_at(nm, at, fl[f].name, nc, y));
    PA_CALL(pa_mesh_set_field_transfer(nm, at, f, (pa_transfer)fl[f].transfer));
    pa__free(y);
    y = NULL;
  }
cleanup:
  pa__free(y);
  return st;
}

pa_status pa_mesh_levelset_cut(pa_mesh *mesh, const double *phi,
                               const pa_levelset_opts *opts,
                               pa_levelset_report *report) {
  pa_status st = PA_SUCCESS;
  pa_levelset_opts def;
  pa_levelset_report rep;
  pa__ls_ctx c;
  pa__ls_out out;
  double *s = NULL;
  uint8_t *split = NULL, *drop = NULL;
  int32_t *rin = NULL, *rex = NULL;
  pa_mesh *nm = NULL;
  memset(&out, 0, sizeof out);
  memset(&rep, 0, sizeof rep);
  PA_CHECK(mesh && phi, PA_ERR_ARG, "pa_mesh_levelset_cut: NULL argument");
  if (!opts) {
    pa_levelset_opts_default(&def);
    opts = &def;
  }
  PA_CALL(pa__ls_check_opts(opts));
  PA_CHECK(mesh->ne > 0, PA_ERR_ARG, "level set: the mesh has no elements");
  pa__ls_ctx_seq(mesh, &c);
  int d = mesh->dim;
  PA_ALLOC(s, mesh->nv);
  memcpy(s, phi, (size_t)mesh->nv * sizeof *s);
  PA_CALL(pa__ls_prepare(&c, opts, s, &rep));
  PA_ALLOC(split, mesh->ne);
  PA_ALLOC(rin, mesh->ne);
  PA_ALLOC(rex, mesh->ne);
  PA_CALL(pa__ls_materials(&c, opts, split, rin, rex));
  PA_CALLOC(drop, mesh->nb);
  PA_CALL(old_interface(mesh, opts->ref_iface, drop, &rep.ndropped,
                        &rep.nbdry_iface));
  PA_CALL(pa__ls_cut(&c, opts, s, split, rin, rex, drop, &out));
  PA_CALL(pa__ls_zero_faces(&out.zero, NULL, opts->ref_iface, &out.bdry));
  for (pa_idx b = 0; b < out.bdry.n; b++) rep.niface += out.bdry.parent[b] == -1;
  rep.ncut = out.nadd;
  rep.nelem_cut = out.nelem_cut;
  rep.vol_in = out.vol[0];
  rep.vol_out = out.vol[1];
  /* the new mesh: the vertices, the added ones, the cells */
  PA_CALL(pa_mesh_create(d, &nm));
  nm->met_ncomp = mesh->met_ncomp;
  nm->nfield = mesh->nfield;
  for (int f = 0; f < mesh->nfield; f++) {
    memcpy(nm->field[f].name, mesh->field[f].name, PA_MESH_FIELD_NAME_LEN);
    nm->field[f].ncomp = mesh->field[f].ncomp;
  }
  PA_CALL(pa_mesh_reserve(nm, mesh->nv + out.nadd, out.elem.n, out.bdry.n,
                          out.edge.n));
  nm->nv = mesh->nv;
  memcpy(nm->coord, mesh->coord, sizeof(double) * (size_t)d * mesh->nv);
  memcpy(nm->vref, mesh->vref, sizeof(int32_t) * (size_t)mesh->nv);
  memcpy(nm->vflag, mesh->vflag, (size_t)mesh->nv);
  if (mesh->met_ncomp)
    memcpy(nm->met, mesh->met,
           sizeof(double) * (size_t)mesh->met_ncomp * mesh->nv);
  for (int f = 0; f < mesh->nfield; f++)
    memcpy(nm->field[f].val, mesh->field[f].val,
           sizeof(double) * (size_t)mesh->field[f].ncomp * mesh->nv);
  PA_CALL(pa__ls_add_vertices(mesh, out.nadd, out.end, out.t, nm));
  for (pa_idx v = 0; v < nm->nv; v++) {
    uint8_t t = v < mesh->nv ? out.touch[v] : out.addtouch[v - mesh->nv];
    if (t == (PA_LS_TOUCH_IN | PA_LS_TOUCH_OUT)) nm->vref[v] = opts->ref_iface;
    else if (nm->vref[v] == opts->ref_iface) nm->vref[v] = 0;
  }
  cells_to(&out.elem, nm->elem, nm->eref, nm->eflag);
  cells_to(&out.bdry, nm->bdry, nm->bref, nm->bflag);
  cells_to(&out.edge, nm->edge, nm->edref, nm->edflag);
  nm->ne = out.elem.n;
  nm->nb = out.bdry.n;
  nm->ned = out.edge.n;
  PA_CALL(carry_fields(mesh, PA_ELEMENT, &out.elem, nm));
  PA_CALL(carry_fields(mesh, PA_BOUNDARY, &out.bdry, nm));
  /* swap: the caller's handle holds the new mesh, with its names */
  {
    int nn = nm->nname;
    pa__name *nms = nm->names;
    nm->nname = mesh->nname;
    nm->names = mesh->names;
    mesh->nname = nn;
    mesh->names = nms;
    pa_mesh tmp = *mesh;
    *mesh = *nm;
    *nm = tmp;
  }
  if (report) *report = rep;
cleanup:
  pa_mesh_destroy(nm);
  pa__ls_out_free(&out);
  pa__free(s);
  pa__free(split);
  pa__free(rin);
  pa__free(rex);
  pa__free(drop);
  return st;
}
