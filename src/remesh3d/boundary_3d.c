/*
 * boundary_3d.c -- analysis of the boundary surface before remeshing it:
 * feature (ridge) edges, corners and vertex normals of curved patches.
 *
 * A boundary edge becomes a feature edge (added to the edge table with
 * PA_FLAG_RIDGE unless already listed) when it is not shared by exactly two
 * boundary triangles, when its two triangles have different references, or
 * (unless -nr) when their normals make an angle above -ar. A vertex with a
 * number of feature edges other than 0 or 2, or whose two feature edges turn
 * by more than -ar, is a corner (locked). A feature edge or corner that the
 * written triangles alone would not make (one of unlisted interfaces,
 * RM3D_REC_UNLISTED) is not written back. Boundary vertices off features get
 * the mean normal of their free triangles, refined by a quadric fit of the
 * neighbouring vertices (fit_normals), and RM3D_V_CURVED when the triangles'
 * normals are not all equal, which lets splits place new points on a smooth
 * (cubic) reconstruction; planar patches have no curved vertex and stay planar. So
 * does a vertex whose feature edges all separate a free triangle from a
 * frozen one (where a piece's frozen skin meets the boundary). The triangles
 * of an interface inside the domain (two tets hold them) count with the
 * orientation of their records, where those agree (the two records of each
 * edge run it in opposite directions; a level-set cut orients them all
 * from the inside out): its vertices then get normals too, and the
 * interface is refined on the same smooth reconstruction.
 */
#include "remesh3d/remesh3d.h"

/* Unknowns of the quadric fit of fit_one: the two slopes and the three
 * curvature terms, the quadric passing through x (the sixth term of its
 * row, an offset, gives the same accuracy on bench/levelset_cut.sh). */
#define FIT_NPAR 5
/* At most this many points per fit (two rings hold 20 to 40). */
#define FIT_MAXPTS 64
/* A fitted normal turned by more than ~45 degrees from the mean normal is
 * not trusted (a fold or a sheet of too few points); the mean is up to 25
 * degrees off the exact normal on the benchmark torus, so a tighter bound
 * refuses good fits. */
#define FIT_MAX_TURN 0.7
/* A vertex with a neighbour closer than this share of its farthest one
 * (one of a cluster of cut points around a vertex near the zero set)
 * keeps its mean normal: its fit mixes the cluster's cut errors, of the
 * order of its edges, and the cluster's slivers then resist removal. */
#define FIT_CLUSTER 0.1

typedef struct bedge {
  pa_idx a, b;   /* a < b */
  pa_idx rec;    /* triangle record */
  int dir;       /* +1 when the triangle runs a -> b */
} bedge;

static int bedge_cmp(const void *x, const void *y) {
  const bedge *p = x, *q = y;
  if (p->a != q->a) return p->a < q->a ? -1 : 1;
  if (p->b != q->b) return p->b < q->b ? -1 : 1;
  return p->rec < q->rec ? -1 : p->rec > q->rec;
}

static void rec_normal(const rm3d *m, pa_idx r, double *n) {
  const pa_idx *v = m->tri.v + 3 * (size_t)r;
  rm3d_tri_cross(m->x + 3 * (size_t)v[0], m->x + 3 * (size_t)v[1],
                 m->x + 3 * (size_t)v[2], n);
}

/* 1 if face f of tet k is a boundary triangle taken once: on the outer
 * surface, oriented out of k; inside the domain (an interface between two
 * references), from the tet of smaller index, oriented as its record (the
 * records of an interface are oriented alike where twisted[] marks none
 * of its vertices: pa__rm3d_surface_analyze checks it). fv receives its
 * vertices and n its normal (twice its area long). */
static int outer_face(const rm3d *m, pa_idx k, int f, pa_idx *fv, double *n) {
  if (!((m->tflag[k] >> f) & 1)) return 0;
  pa_idx o = m->adj[4 * (size_t)k + f];
  if (o >= 0 && (o >> 2) < k) return 0;
  const pa_idx *v = m->tv + 4 * (size_t)k;
  for (int j = 0; j < 3; j++) fv[j] = v[pa__rm3d_face[f][j]];
  if (o >= 0) {
    pa_idx r = pa__rm3d_table_find(&m->tri, fv);
    if (r < 0) return 0;
    memcpy(fv, m->tri.v + 3 * (size_t)r, 3 * sizeof *fv);
  }
  rm3d_tri_cross(m->x + 3 * (size_t)fv[0], m->x + 3 * (size_t)fv[1],
                 m->x + 3 * (size_t)fv[2], n);
  return 1;
}

/* 1 if the boundary triangle fv is frozen (required). */
static int frozen_face(const rm3d *m, const pa_idx *fv) {
  pa_idx r = pa__rm3d_table_find(&m->tri, fv);
  return r >= 0 && (m->tri.flag[r] & PA_FLAG_REQUIRED);
}

/* The edges of the live boundary triangles into be (three per triangle,
 * ends sorted), sorted so that the copies of an edge are adjacent. Returns
 * their count. */
static size_t sorted_edges(const rm3d *m, bedge *be) {
  size_t nbe = 0;
  for (pa_idx r = 0; r < m->tri.n; r++) {
    if (m->tri.flag[r] & RM3D_REC_DEAD) continue;
    const pa_idx *v = m->tri.v + 3 * (size_t)r;
    for (int i = 0; i < 3; i++) {
      pa_idx x = v[i], y = v[(i + 1) % 3];
      bedge *e = &be[nbe++];
      e->a = x < y ? x : y;
      e->b = x < y ? y : x;
      e->rec = r;
      e->dir = x < y ? 1 : -1;
    }
  }
  qsort(be, nbe, sizeof *be, bedge_cmp);
  return nbe;
}

/* Whether the boundary edge of records e[0..n) (one edge's run of the
 * sorted boundary edges) is a feature: not two records, two of different
 * references, or (use_angle) a turn above -ar. With written, only the
 * records written back count (an edge of unlisted interfaces alone is no
 * feature of the output). */
static int edge_feature(const rm3d *m, int use_angle, const bedge *e,
                        size_t n, int written) {
  const bedge *r[2] = {NULL, NULL};
  size_t k = 0;
  for (size_t i = 0; i < n; i++) {
    if (written && (m->tri.flag[e[i].rec] & RM3D_REC_UNLISTED)) continue;
    if (k < 2) r[k] = e + i;
    k++;
  }
  if (k != 2) return k > 0 || !written;
  if (m->tri.ref[r[0]->rec] != m->tri.ref[r[1]->rec]) return 1;
  if (!use_angle) return 0;
  double n1[3], n2[3];
  rec_normal(m, r[0]->rec, n1);
  rec_normal(m, r[1]->rec, n2);
  rm3d_unit(n1);
  rm3d_unit(n2);
  double d = n1[0] * n2[0] + n1[1] * n2[1] + n1[2] * n2[2];
  if (r[0]->dir == r[1]->dir) d = -d; /* inconsistent orientations */
  return d < m->ridge_cos;
}

/* Feature edges (see the opening comment) added to the edge table from the
 * sorted boundary edges be[0..nbe), RM3D_REC_UNLISTED when no feature of
 * the written records; nborder[x] counts the feature edges at x between a
 * frozen and a free triangle. */
static pa_status add_feature_edges(rm3d *m, int use_angle, const bedge *be,
                                   size_t nbe, uint8_t *nborder,
                                   uint8_t *twisted) {
  pa_status st = PA_SUCCESS;
  for (size_t i = 0; i < nbe;) {
    size_t j = i + 1;
    while (j < nbe && be[j].a == be[i].a && be[j].b == be[i].b) j++;
    if (j - i == 2 && be[i].dir == be[i + 1].dir) /* records turned apart */
      twisted[be[i].a] = twisted[be[i].b] = 1;
    int feat = edge_feature(m, use_angle, be + i, j - i, 0);
    if (feat && j - i == 2 &&
        ((m->tri.flag[be[i].rec] ^ m->tri.flag[be[i + 1].rec]) &
         PA_FLAG_REQUIRED))
      for (int s2 = 0; s2 < 2; s2++) {
        pa_idx x = s2 ? be[i].b : be[i].a;
        if (nborder[x] < 255) nborder[x]++;
      }
    pa_idx ev[2] = {be[i].a, be[i].b};
    if (feat && pa__rm3d_table_find(&m->edg, ev) < 0) {
      uint8_t hidden = edge_feature(m, use_angle, be + i, j - i, 1)
                           ? 0
                           : RM3D_REC_UNLISTED;
      PA_CALL(pa__rm3d_table_add(&m->edg, ev, 0, PA_FLAG_RIDGE | hidden,
                                 NULL));
    }
    i = j;
  }
cleanup:
  return st;
}

/* The feature degree nfeat[x] of every vertex (at most 255) and the other
 * ends other[2x..2x+1] of its first two feature edges; written: of the
 * feature edges written back only. */
static void feature_ends(rm3d *m, int written, uint8_t *nfeat,
                         pa_idx *other) {
  for (pa_idx r = 0; r < m->edg.n; r++) {
    uint8_t skip = RM3D_REC_DEAD | (written ? RM3D_REC_UNLISTED : 0);
    if (m->edg.flag[r] & skip) continue;
    const pa_idx *ev = m->edg.v + 2 * (size_t)r;
    for (int s = 0; s < 2; s++) {
      pa_idx x = ev[s];
      if (nfeat[x] < 2) other[2 * (size_t)x + nfeat[x]] = ev[1 - s];
      if (nfeat[x] < 255) nfeat[x]++;
    }
  }
}

/* Whether x is a corner for feature_ends' nfeat and other: a feature
 * degree other than 0 or 2, or (use_angle) a sharp turn. */
static int is_corner(const rm3d *m, int use_angle, pa_idx x,
                     const uint8_t *nfeat, const pa_idx *other) {
  if (!nfeat[x]) return 0;
  if (nfeat[x] != 2) return 1;
  if (!use_angle) return 0;
  const double *p = m->x + 3 * (size_t)x;
  const double *a = m->x + 3 * (size_t)other[2 * (size_t)x];
  const double *b = m->x + 3 * (size_t)other[2 * (size_t)x + 1];
  double u[3] = {p[0] - a[0], p[1] - a[1], p[2] - a[2]};
  double w[3] = {b[0] - p[0], b[1] - p[1], b[2] - p[2]};
  rm3d_unit(u);
  rm3d_unit(w);
  return u[0] * w[0] + u[1] * w[1] + u[2] * w[2] < m->ridge_cos;
}

/* Corners (RM3D_V_CORNER, locked) of all feature edges; nfeat receives
 * the feature degrees. A corner of the feature edges written back is
 * written back too (PA_FLAG_CORNER); wdeg and other are scratch. */
static void mark_corners(rm3d *m, int use_angle, uint8_t *nfeat,
                         uint8_t *wdeg, pa_idx *other) {
  feature_ends(m, 0, nfeat, other);
  for (pa_idx x = 0; x < m->nv; x++) {
    if (nfeat[x]) m->vtag[x] |= RM3D_V_FEAT;
    if (is_corner(m, use_angle, x, nfeat, other))
      m->vtag[x] |= RM3D_V_CORNER | RM3D_V_LOCK;
  }
  feature_ends(m, 1, wdeg, other);
  for (pa_idx x = 0; x < m->nv; x++)
    if ((m->vtag[x] & RM3D_V_CORNER) && !(m->vpf[x] & PA_FLAG_REQUIRED) &&
        is_corner(m, use_angle, x, wdeg, other))
      m->vpf[x] |= PA_FLAG_CORNER;
}

/* The normal at x of the quadric height field w = a u^2 + b uv + c v^2 +
 * d u + e v (+ f) fitted by least squares to the points pts[0..np) in the
 * frame of x's normal n (replaced by the fit's when it is well posed, its
 * normal equations positive definite, and within FIT_MAX_TURN of n). */
static void fit_one(const double *x, const double *pts, int np, double *n) {
  double t1[3], t2[3];
  int ax = fabs(n[0]) < fabs(n[1]) ? (fabs(n[0]) < fabs(n[2]) ? 0 : 2)
                                   : (fabs(n[1]) < fabs(n[2]) ? 1 : 2);
  double e[3] = {0, 0, 0};
  e[ax] = 1;
  t1[0] = e[1] * n[2] - e[2] * n[1];
  t1[1] = e[2] * n[0] - e[0] * n[2];
  t1[2] = e[0] * n[1] - e[1] * n[0];
  rm3d_unit(t1);
  t2[0] = n[1] * t1[2] - n[2] * t1[1];
  t2[1] = n[2] * t1[0] - n[0] * t1[2];
  t2[2] = n[0] * t1[1] - n[1] * t1[0];
  double scale = 0;
  for (int i = 0; i < np; i++) {
    const double *p = pts + 3 * i;
    scale += (p[0] - x[0]) * (p[0] - x[0]) + (p[1] - x[1]) * (p[1] - x[1]) +
             (p[2] - x[2]) * (p[2] - x[2]);
  }
  if (np < FIT_NPAR + 1 || !(scale > 0)) return;
  scale = 1.0 / sqrt(scale / np);
  double ata[FIT_NPAR * FIT_NPAR] = {0}, atb[FIT_NPAR] = {0};
  for (int i = 0; i < np; i++) {
    const double *p = pts + 3 * i;
    double d[3] = {(p[0] - x[0]) * scale, (p[1] - x[1]) * scale,
                   (p[2] - x[2]) * scale};
    double u = d[0] * t1[0] + d[1] * t1[1] + d[2] * t1[2];
    double v = d[0] * t2[0] + d[1] * t2[1] + d[2] * t2[2];
    double w = d[0] * n[0] + d[1] * n[1] + d[2] * n[2];
    double row[6] = {u, v, u * u, u * v, v * v, 1};
    for (int r = 0; r < FIT_NPAR; r++) {
      atb[r] += row[r] * w;
      for (int c = 0; c < FIT_NPAR; c++) ata[r * FIT_NPAR + c] += row[r] * row[c];
    }
  }
  if (!pa__cholesky_solve(FIT_NPAR, ata, atb)) return;
  double nf[3];
  for (int j = 0; j < 3; j++) nf[j] = n[j] - atb[0] * t1[j] - atb[1] * t2[j];
  rm3d_unit(nf);
  if (nf[0] * n[0] + nf[1] * n[1] + nf[2] * n[2] < FIT_MAX_TURN) return;
  memcpy(n, nf, sizeof nf);
}

/* 1 when ring[0] has a first-ring neighbour (ring[1..n1)) closer than
 * FIT_CLUSTER times its farthest one: one of a cluster of cut points. */
static int cluster_vertex(const rm3d *m, const pa_idx *ring, int n1) {
  const double *x = m->x + 3 * (size_t)ring[0];
  double dmin = 1e300, dmax = 0;
  for (int i = 1; i < n1; i++) {
    const double *y = m->x + 3 * (size_t)ring[i];
    double d = (y[0] - x[0]) * (y[0] - x[0]) + (y[1] - x[1]) * (y[1] - x[1]) +
               (y[2] - x[2]) * (y[2] - x[2]);
    dmin = fmin(dmin, d);
    dmax = fmax(dmax, d);
  }
  return dmin < FIT_CLUSTER * FIT_CLUSTER * dmax;
}

/* Normals of the smooth boundary vertices (off features, not twisted)
 * refined by fit_one over the vertices of their free boundary triangles
 * and of those of their neighbours off features (two rings). */
static pa_status fit_normals(rm3d *m, const uint8_t *twisted) {
  pa_status st = PA_SUCCESS;
  if (m->voff) return st; /* with a model, its points */
  pa_idx *start = NULL, *list = NULL, *seen = NULL;
  double *pts = NULL;
  PA_CALLOC(start, (size_t)m->nv + 1);
  for (pa_idx r = 0; r < m->tri.n; r++) {
    if (m->tri.flag[r] & (RM3D_REC_DEAD | PA_FLAG_REQUIRED)) continue;
    for (int j = 0; j < 3; j++) start[m->tri.v[3 * (size_t)r + j] + 1]++;
  }
  for (pa_idx x = 0; x < m->nv; x++) start[x + 1] += start[x];
  PA_ALLOC(list, (size_t)start[m->nv] + 1);
  for (pa_idx r = 0; r < m->tri.n; r++) {
    if (m->tri.flag[r] & (RM3D_REC_DEAD | PA_FLAG_REQUIRED)) continue;
    for (int j = 0; j < 3; j++) list[start[m->tri.v[3 * (size_t)r + j]]++] = r;
  }
  for (pa_idx x = m->nv; x > 0; x--) start[x] = start[x - 1];
  start[0] = 0;
  PA_ALLOC(seen, (size_t)m->nv);
  for (pa_idx x = 0; x < m->nv; x++) seen[x] = -1;
  PA_ALLOC(pts, 3 * FIT_MAXPTS);
  for (pa_idx x = 0; x < m->nv; x++) {
    if (twisted[x] || (m->vtag[x] & (RM3D_V_FEAT | RM3D_V_DEAD)) ||
        start[x] == start[x + 1])
      continue;
    pa_idx ring[FIT_MAXPTS];
    int nr = 0;
    seen[x] = x;
    ring[nr++] = x;
    int n1 = 1;
    for (int i = 0; i < n1; i++) {
      pa_idx c = ring[i];
      if (i && (m->vtag[c] & RM3D_V_FEAT)) continue;
      for (pa_idx k = start[c]; k < start[c + 1]; k++)
        for (int j = 0; j < 3; j++) {
          pa_idx y = m->tri.v[3 * (size_t)list[k] + j];
          if (seen[y] == x || nr == FIT_MAXPTS) continue;
          seen[y] = x;
          ring[nr++] = y;
        }
      if (i == 0) n1 = nr; /* the first ring's vertices, then stop */
    }
    if (cluster_vertex(m, ring, n1)) continue;
    for (int i = 0; i < nr; i++)
      memcpy(pts + 3 * i, m->x + 3 * (size_t)ring[i], 3 * sizeof(double));
    fit_one(m->x + 3 * (size_t)x, pts, nr, m->nrm + 3 * (size_t)x);
  }
cleanup:
  pa__free(start);
  pa__free(list);
  pa__free(seen);
  pa__free(pts);
  return st;
}

/* Normals of boundary vertices off features, from their outward free
 * faces. A vertex whose feature edges all border a frozen triangle (the
 * skin of a piece of the parallel loop meeting the boundary: nborder[x] ==
 * nfeat[x]) gets one too: without it every split towards it would take the
 * chord's midpoint, so the input's facets would stay flat along every skin
 * on a curved boundary, their vertices planar in the next iteration, and
 * the junctions with the curved refinement around would make needles and
 * folds. A
 * vertex is curved (RM3D_V_CURVED) when one of its faces deviates from its
 * normal; m->nrm is kept only if one is. */
static pa_status curved_normals(rm3d *m, const uint8_t *nborder,
                                const uint8_t *nfeat, const uint8_t *twisted) {
  pa_status st = PA_SUCCESS;
  PA_CALLOC(m->nrm, 3 * m->capv);
  for (pa_idx k = 0; k < m->ne; k++) {
    if (!(m->tflag[k] & RM3D_T_FACES)) continue;
    for (int f = 0; f < 4; f++) {
      pa_idx fv[3];
      double n[3];
      if (!outer_face(m, k, f, fv, n) || frozen_face(m, fv)) continue;
      for (int j = 0; j < 3; j++)
        for (int c2 = 0; c2 < 3; c2++) m->nrm[3 * (size_t)fv[j] + c2] += n[c2];
    }
  }
  for (pa_idx x = 0; x < m->nv; x++) {
    if (twisted[x]) memset(m->nrm + 3 * (size_t)x, 0, 3 * sizeof(double));
    rm3d_unit(m->nrm + 3 * (size_t)x);
  }
  PA_CALL(fit_normals(m, twisted));
  int ncurved = 0;
  for (pa_idx k = 0; k < m->ne; k++) {
    if (!(m->tflag[k] & RM3D_T_FACES)) continue;
    for (int f = 0; f < 4; f++) {
      pa_idx fv[3];
      double n[3];
      if (!outer_face(m, k, f, fv, n) || frozen_face(m, fv)) continue;
      rm3d_unit(n);
      for (int j = 0; j < 3; j++) {
        pa_idx x = fv[j];
        if ((m->vtag[x] & RM3D_V_CURVED) || twisted[x]) continue;
        if ((m->vtag[x] & RM3D_V_FEAT) && nborder[x] != nfeat[x]) continue;
        const double *nx = m->nrm + 3 * (size_t)x;
        if (n[0] * nx[0] + n[1] * nx[1] + n[2] * nx[2] < 1.0 - 1e-10) {
          m->vtag[x] |= RM3D_V_CURVED;
          ncurved++;
        }
      }
    }
  }
  if (!ncurved) {
    pa__free(m->nrm);
    m->nrm = NULL;
  } else if (!m->voff) { /* with a model, its snaps place the points */
    PA_CALLOC(m->vcur, 3 * m->capv);
  }
cleanup:
  return st;
}

/* The unit normal of the curved surface at the boundary triangle of
 * vertices v: the sum of their normals, oriented along n0 (the triangle's
 * normal), in n; 0 when a vertex has none (off a curved patch). */
static int surface_normal(const rm3d *m, const pa_idx *v, const double *n0,
                          double *n) {
  n[0] = n[1] = n[2] = 0;
  for (int j = 0; j < 3; j++) {
    if (!(m->vtag[v[j]] & RM3D_V_CURVED)) return 0;
    const double *nj = m->nrm + 3 * (size_t)v[j];
    for (int c = 0; c < 3; c++) n[c] += nj[c];
  }
  double d = n[0] * n0[0] + n[1] * n0[1] + n[2] * n0[2];
  if (!(rm3d_unit(n) > 0) || d == 0) return 0;
  if (d < 0) /* the record runs against the normals (an outer surface) */
    for (int c = 0; c < 3; c++) n[c] = -n[c];
  return 1;
}

int pa__rm3d_turn_ok(const rm3d *m, const pa_idx *v, const double *n0,
                     const double *n1) {
  double ns[3];
  if (n0[0] * n1[0] + n0[1] * n1[1] + n0[2] * n1[2] >= RM3D_NORMAL_COS)
    return 1;
  return m->nrm && surface_normal(m, v, n0, ns) &&
         ns[0] * n1[0] + ns[1] * n1[1] + ns[2] * n1[2] >= RM3D_NORMAL_COS;
}

pa_status pa__rm3d_surface_analyze(rm3d *m, int use_angle) {
  pa_status st = PA_SUCCESS;
  bedge *be = NULL;
  uint8_t *nfeat = NULL, *nborder = NULL, *twisted = NULL, *wdeg = NULL;
  pa_idx *other = NULL;
  PA_ALLOC(be, 3 * (size_t)m->tri.n + 1);
  size_t nbe = sorted_edges(m, be);
  PA_CALLOC(nborder, (size_t)m->nv);
  PA_CALLOC(twisted, (size_t)m->nv);
  PA_CALL(add_feature_edges(m, use_angle, be, nbe, nborder, twisted));
  PA_CALLOC(nfeat, (size_t)m->nv);
  PA_ALLOC(other, 2 * (size_t)m->nv);
  PA_CALLOC(wdeg, (size_t)m->nv);
  mark_corners(m, use_angle, nfeat, wdeg, other);
  PA_CALL(curved_normals(m, nborder, nfeat, twisted));
cleanup:
  pa__free(be);
  pa__free(twisted);
  pa__free(nborder);
  pa__free(nfeat);
  pa__free(other);
  pa__free(wdeg);
  return st;
}
