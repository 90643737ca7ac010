/*
 * boundary_2d.c -- feature lines of the 2D remesher: boundary edges and
 * interior curves, their corners, and the smooth curve reconstructed through
 * them.
 *
 * A feature record is a boundary edge (one element side) or an interior-curve
 * edge (two sides: listed in the boundary list although interior, or between
 * elements of different references). Operators never swap a feature edge, a
 * split puts the new vertex on the reconstructed curve, and a collapse along a
 * feature must keep the new chord within hausd of that curve.
 *
 * Curve: on each record, the cubic Hermite arc between its end vertices with
 * the unit tangents stored at its ends (btan), scaled by the chord length.
 * Tangent at a regular feature vertex: t ~ l1 e0 + l0 e1 (e0, e1 unit vectors
 * of the incoming and outgoing edges, l0, l1 their lengths; exact for a circle
 * through the three points to second order). At a corner each record uses its
 * own chord direction. Straight runs give tangents equal to the chord, and then
 * the curve is the chord exactly (see pa__rm2d_curve_point), so straight
 * boundaries stay straight. On interior curves (a level-set cut) the
 * tangents and each vertex's step onto the curve come from a least-squares
 * fit over two rings along the curve (fit_tangents); the smoothing passes
 * make the steps (pa__rm2d_curve_snap_vertex, smooth_2d.c).
 *
 * Corners: input PA_FLAG_CORNER, a vertex with other than two feature edges,
 * two feature edges of different references, or (unless -nr) a turning angle
 * larger than -ar degrees.
 */
#include "remesh2d/remesh2d.h"

/* Unknowns of the quadratic fit of fit_one: the offset, the slope and the
 * curvature term (the offset is the vertex's step onto the fitted curve). */
#define FIT_NPAR 3
/* Two rings along the curve: the vertex and two neighbours on each side. */
#define FIT_MAXPTS 5
/* A fitted tangent turned by more than ~45 degrees from the chord of the
 * first ring is not trusted (as 3D's FIT_MAX_TURN, boundary_3d.c). */
#define FIT_MAX_TURN 0.7
/* A fitted offset longer than this share of the vertex's shorter curve edge
 * is no interpolation error but a fit across a kink or a cluster of cut
 * points (a level set's zero close to an input vertex): the vertex keeps its
 * place. The interpolation errors of bench/levelset_cut.sh's disc are under
 * 0.02 of the edges. */
#define FIT_SNAP_MAX 0.1

/* Element face code holding edge (a, c) found in the ball of a, or -1. */
static pa_idx find_face(const rm2d *rm, const pa_idx *bstart,
                        const pa_idx *ball, pa_idx a, pa_idx c) {
  for (pa_idx s = bstart[a]; s < bstart[a + 1]; s++) {
    pa_idx k = ball[s];
    const pa_idx *v = rm->tv + 3 * (size_t)k;
    for (int i = 0; i < 3; i++) {
      pa_idx e0 = v[(i + 1) % 3], e1 = v[(i + 2) % 3];
      if ((e0 == a && e1 == c) || (e0 == c && e1 == a)) return 3 * k + i;
    }
  }
  return -1;
}

static pa_status add_record(rm2d *rm, pa_idx a, pa_idx c, int32_t ref,
                            uint8_t tag, pa_idx code) {
  pa_status st = PA_SUCCESS;
  pa_idx b, o = rm->adj[code];
  PA_CHECK(o >= 0 || o == RM2D_NOADJ, PA_ERR_MESH,
           "remesher: boundary edge (%d %d) is listed twice", (int)a + 1,
           (int)c + 1);
  PA_CALL(pa__rm2d_new_feat(rm, &b));
  rm->bv[2 * b] = a;
  rm->bv[2 * b + 1] = c;
  rm->bref[b] = ref;
  rm->btag[b] = tag;
  rm->bside[2 * b] = code;
  rm->bside[2 * b + 1] = o >= 0 ? o : -1;
  rm->adj[code] = -b - 1;
  if (o >= 0) rm->adj[o] = -b - 1;
  rm->vtag[a] |= RM2D_V_FEAT;
  rm->vtag[c] |= RM2D_V_FEAT;
  if (tag & RM2D_B_FROZEN) {
    rm->vtag[a] |= RM2D_V_FROZEN;
    rm->vtag[c] |= RM2D_V_FROZEN;
  }
cleanup:
  return st;
}

/* Raise the eigenvalues of a 2D tensor to at least lam (intersection with
 * the isotropic metric lam I). */
static void tensor_floor(double *m, double lam) {
  double a = m[0], b = m[1], c = m[2];
  double hm = 0.5 * (a + c), hd = 0.5 * (a - c);
  double r = sqrt(hd * hd + b * b);
  double l1 = hm + r, l2 = hm - r;
  if (l2 >= lam) return;
  if (l1 <= lam) {
    m[0] = m[2] = lam;
    m[1] = 0;
    return;
  }
  /* m = l2 I + (l1 - l2) P1, P1 = (m - l2 I)/(l1 - l2): replace l2 by lam */
  m[0] = lam + (a - l2);
  m[1] = b;
  m[2] = lam + (c - l2);
}

/* The feature records: the boundary list's, then the unlisted boundary
 * edges (listed on output) and the interfaces between element references. */
static pa_status add_records(rm2d *rm, pa_mesh *mesh, const pa_idx *bstart,
                             const pa_idx *ball) {
  pa_status st = PA_SUCCESS;
  pa_idx nv = rm->nv;
  for (pa_idx b = 0; b < mesh->nb; b++) {
    pa_idx a = mesh->bdry[2 * (size_t)b], c = mesh->bdry[2 * (size_t)b + 1];
    PA_CHECK(a >= 0 && a < nv && c >= 0 && c < nv && a != c, PA_ERR_MESH,
             "remesher: boundary edge %d has invalid vertices", (int)b + 1);
    pa_idx code = find_face(rm, bstart, ball, a, c);
    PA_CHECK(code >= 0, PA_ERR_MESH,
             "remesher: boundary edge %d (%d %d) is not an element edge",
             (int)b + 1, (int)a + 1, (int)c + 1);
    PA_CALL(add_record(rm, a, c, mesh->bref[b],
                       (mesh->bflag[b] & 0x0F) | RM2D_B_LISTED, code));
  }
  pa_idx ne = rm->ne;
  for (pa_idx k = 0; k < ne; k++)
    for (int i = 0; i < 3; i++) {
      pa_idx code = 3 * k + i, ob = rm->adj[code];
      pa_idx a = rm->tv[3 * k + (i + 1) % 3], c = rm->tv[3 * k + (i + 2) % 3];
      if (ob == RM2D_NOADJ)
        PA_CALL(add_record(rm, a, c, 0, RM2D_B_LISTED, code));
      else if (ob > code && rm->tref[ob / 3] != rm->tref[k])
        PA_CALL(add_record(rm, a, c, 0, 0, code));
    }
cleanup:
  return st;
}

/* The feature records at each vertex: cnt[v] of them (at most 255), the
 * first two r0[v], r1[v]. */
typedef struct feat_ends {
  uint8_t *cnt;
  pa_idx *r0, *r1;
} feat_ends;

/* The other end of record b, from its end v. */
static pa_idx other_end(const rm2d *rm, pa_idx b, pa_idx v) {
  return rm->bv[2 * b] == v ? rm->bv[2 * b + 1] : rm->bv[2 * b];
}

static pa_status count_ends(const rm2d *rm, feat_ends *fe) {
  pa_status st = PA_SUCCESS;
  pa_idx nv = rm->nv;
  PA_CALLOC(fe->cnt, nv);
  PA_ALLOC(fe->r0, nv);
  PA_ALLOC(fe->r1, nv);
  for (pa_idx b = 0; b < rm->nb; b++)
    for (int e = 0; e < 2; e++) {
      pa_idx v = rm->bv[2 * b + e];
      if (fe->cnt[v] == 0) fe->r0[v] = b;
      else if (fe->cnt[v] == 1) fe->r1[v] = b;
      if (fe->cnt[v] < 255) fe->cnt[v]++;
    }
cleanup:
  return st;
}

/* Corners (RM2D_V_CORNER): other than two feature edges, two of different
 * references, or (unless -nr) a turn larger than -ar degrees. */
static void mark_corners(rm2d *rm, const feat_ends *fe) {
  const pa_remesh_opts *o = rm->opts;
  double cosar = cos((o->angle > 0 ? o->angle : 45.0) * M_PI / 180.0);
  for (pa_idx v = 0; v < rm->nv; v++) {
    if (!fe->cnt[v]) continue;
    if (fe->cnt[v] != 2) {
      rm->vtag[v] |= RM2D_V_CORNER;
      continue;
    }
    if (rm->bref[fe->r0[v]] != rm->bref[fe->r1[v]])
      rm->vtag[v] |= RM2D_V_CORNER;
    if (o->no_angle) continue;
    pa_idx u = other_end(rm, fe->r0[v], v), w = other_end(rm, fe->r1[v], v);
    const double *xu = rm->x + 2 * (size_t)u, *xv = rm->x + 2 * (size_t)v,
                 *xw = rm->x + 2 * (size_t)w;
    double e0x = xv[0] - xu[0], e0y = xv[1] - xu[1];
    double e1x = xw[0] - xv[0], e1y = xw[1] - xv[1];
    double c = (e0x * e1x + e0y * e1y) /
               (sqrt(e0x * e0x + e0y * e0y) * sqrt(e1x * e1x + e1y * e1y));
    if (c < cosar) rm->vtag[v] |= RM2D_V_CORNER;
  }
}

/* The unit tangents at both ends of every record (see the opening
 * comment): the chord's at a corner, l1 e0 + l0 e1 elsewhere. */
static void set_tangents(rm2d *rm, const feat_ends *fe) {
  for (pa_idx b = 0; b < rm->nb; b++)
    for (int e = 0; e < 2; e++) {
      pa_idx v = rm->bv[2 * b + e];
      const double *xv = rm->x + 2 * (size_t)v;
      double dx = rm->x[2 * (size_t)rm->bv[2 * b + 1]] - rm->x[2 * (size_t)rm->bv[2 * b]];
      double dy = rm->x[2 * (size_t)rm->bv[2 * b + 1] + 1] -
                  rm->x[2 * (size_t)rm->bv[2 * b] + 1];
      double dl = sqrt(dx * dx + dy * dy);
      double tx = dx / dl, ty = dy / dl;
      if (!(rm->vtag[v] & RM2D_V_CORNER)) {
        pa_idx u = other_end(rm, fe->r0[v], v), w = other_end(rm, fe->r1[v], v);
        const double *xu = rm->x + 2 * (size_t)u, *xw = rm->x + 2 * (size_t)w;
        double e0x = xv[0] - xu[0], e0y = xv[1] - xu[1];
        double e1x = xw[0] - xv[0], e1y = xw[1] - xv[1];
        double l0 = sqrt(e0x * e0x + e0y * e0y), l1 = sqrt(e1x * e1x + e1y * e1y);
        double cx = l1 * e0x / l0 + l0 * e1x / l1, cy = l1 * e0y / l0 + l0 * e1y / l1;
        double cl = sqrt(cx * cx + cy * cy);
        if (cl > 1e-12 * (l0 + l1)) {
          cx /= cl;
          cy /= cl;
          if (cx * tx + cy * ty < 0) {
            cx = -cx;
            cy = -cy;
          }
          tx = cx;
          ty = cy;
        }
      }
      rm->btan[4 * b + 2 * e] = tx;
      rm->btan[4 * b + 2 * e + 1] = ty;
    }
}

/* The quadratic height field w = c + a u + b u^2 fitted by least squares to
 * the points pts[0..np) in the frame of x's unit tangent t (u along t, w
 * along its normal n = (-t1, t0)). When it is well posed (normal equations
 * positive definite) and turns the tangent by less than FIT_MAX_TURN: 1,
 * with t replaced by the fit's (t + a n, normalised) and off = c n, the
 * step from x onto the fitted curve. */
static int fit_one(const double *x, const double *pts, int np, double *t,
                   double *off) {
  double n[2] = {-t[1], t[0]}, scale = 0;
  for (int i = 0; i < np; i++) {
    const double *p = pts + 2 * i;
    scale += (p[0] - x[0]) * (p[0] - x[0]) + (p[1] - x[1]) * (p[1] - x[1]);
  }
  if (np < FIT_NPAR + 1 || !(scale > 0)) return 0;
  scale = 1.0 / sqrt(scale / np);
  double ata[FIT_NPAR * FIT_NPAR] = {0}, atb[FIT_NPAR] = {0};
  for (int i = 0; i < np; i++) {
    const double *p = pts + 2 * i;
    double d[2] = {(p[0] - x[0]) * scale, (p[1] - x[1]) * scale};
    double u = d[0] * t[0] + d[1] * t[1], w = d[0] * n[0] + d[1] * n[1];
    double row[FIT_NPAR] = {1, u, u * u};
    for (int r = 0; r < FIT_NPAR; r++) {
      atb[r] += row[r] * w;
      for (int c = 0; c < FIT_NPAR; c++)
        ata[r * FIT_NPAR + c] += row[r] * row[c];
    }
  }
  if (!pa__cholesky_solve(FIT_NPAR, ata, atb)) return 0;
  double tf[2] = {t[0] + atb[1] * n[0], t[1] + atb[1] * n[1]};
  double l = sqrt(tf[0] * tf[0] + tf[1] * tf[1]);
  if (!(l > 0) || (tf[0] * t[0] + tf[1] * t[1]) / l < FIT_MAX_TURN) return 0;
  t[0] = tf[0] / l;
  t[1] = tf[1] / l;
  off[0] = atb[0] / scale * n[0];
  off[1] = atb[0] / scale * n[1];
  return 1;
}

/* Whether record b lies inside the domain (an element on each side). */
static int interior_record(const rm2d *rm, pa_idx b) {
  return rm->bside[2 * b + 1] >= 0;
}

/* The vertices of interior curves carry the interpolation error of what
 * put them there (a level set's zero set cut into the mesh: bench/
 * levelset_cut.sh's disc has its cut points up to 0.03 of the size inside
 * the circle, and the chords' tangents turn with that noise). At a
 * regular vertex of an interior curve, not frozen, fit_one over the
 * vertex and the next two along the curve on each side (up to a corner)
 * gives the tangents of its records and its step onto the fitted curve
 * (rm2d.vcur, allocated here when a step is kept; FIT_SNAP_MAX). The
 * domain's boundary and curves between frozen input are the input's, kept
 * as they are. */
static pa_status fit_tangents(rm2d *rm, const feat_ends *fe) {
  pa_status st = PA_SUCCESS;
  long nfit = 0, nstep = 0, nfar = 0;
  for (pa_idx v = 0; v < rm->nv; v++) {
    if (fe->cnt[v] != 2 || (rm->vtag[v] & (RM2D_V_CORNER | RM2D_V_FROZEN)))
      continue;
    pa_idx r[2] = {fe->r0[v], fe->r1[v]};
    if (!interior_record(rm, r[0]) || !interior_record(rm, r[1])) continue;
    double pts[2 * FIT_MAXPTS];
    int np = 0;
    const double *xv = rm->x + 2 * (size_t)v;
    memcpy(pts, xv, 2 * sizeof(double));
    np++;
    pa_idx nb1[2];
    for (int side = 0; side < 2; side++) {
      pa_idx u = nb1[side] = other_end(rm, r[side], v);
      memcpy(pts + 2 * np++, rm->x + 2 * (size_t)u, 2 * sizeof(double));
      if (fe->cnt[u] != 2 || (rm->vtag[u] & RM2D_V_CORNER)) continue;
      pa_idx ru = fe->r0[u] == r[side] ? fe->r1[u] : fe->r0[u];
      pa_idx u2 = other_end(rm, ru, u);
      if (u2 != v && u2 != nb1[0])
        memcpy(pts + 2 * np++, rm->x + 2 * (size_t)u2, 2 * sizeof(double));
    }
    const double *x0 = rm->x + 2 * (size_t)nb1[0],
                 *x1 = rm->x + 2 * (size_t)nb1[1];
    double t[2] = {x1[0] - x0[0], x1[1] - x0[1]}, off[2];
    double tl = sqrt(t[0] * t[0] + t[1] * t[1]);
    double l0 = hypot(x0[0] - xv[0], x0[1] - xv[1]),
           l1 = hypot(x1[0] - xv[0], x1[1] - xv[1]);
    if (!(tl > 0)) continue;
    t[0] /= tl;
    t[1] /= tl;
    if (!fit_one(xv, pts, np, t, off)) continue;
    nfit++;
    for (int side = 0; side < 2; side++) { /* along each record's own run */
      double *bt = rm->btan + 4 * (size_t)r[side] +
                   (rm->bv[2 * r[side]] == v ? 0 : 2);
      double sg = bt[0] * t[0] + bt[1] * t[1] < 0 ? -1 : 1;
      bt[0] = sg * t[0];
      bt[1] = sg * t[1];
    }
    if (hypot(off[0], off[1]) > FIT_SNAP_MAX * fmin(l0, l1)) {
      nfar++;
      continue;
    }
    nstep++;
    if (!rm->vcur) PA_CALLOC(rm->vcur, 2 * rm->capv);
    rm->vcur[2 * (size_t)v] = off[0];
    rm->vcur[2 * (size_t)v + 1] = off[1];
  }
  if (nfit)
    pa__info(2, "remesh: %ld interior-curve vertices fitted, %ld with a step "
                "onto the fit, %ld too far\n", nfit, nstep, nfar);
cleanup:
  return st;
}

/* Hausdorff bound: at a regular vertex of curvature kappa (turning angle
 * over the mean edge length), a chord of length h deviates from the curve
 * by about h^2 kappa / 8, so the size is limited to sqrt(8 hausd / kappa).
 * Returns 1 if it lowered a size. */
static int hausdorff_bound(rm2d *rm, const feat_ends *fe) {
  const pa_remesh_opts *o = rm->opts;
  int limited = 0;
  for (pa_idx v = 0; v < rm->nv; v++) {
    if (fe->cnt[v] != 2 || (rm->vtag[v] & (RM2D_V_CORNER | RM2D_V_FROZEN)))
      continue;
    pa_idx u = other_end(rm, fe->r0[v], v), w = other_end(rm, fe->r1[v], v);
    const double *xu = rm->x + 2 * (size_t)u, *xv = rm->x + 2 * (size_t)v,
                 *xw = rm->x + 2 * (size_t)w;
    double e0x = xv[0] - xu[0], e0y = xv[1] - xu[1];
    double e1x = xw[0] - xv[0], e1y = xw[1] - xv[1];
    double l0 = sqrt(e0x * e0x + e0y * e0y), l1 = sqrt(e1x * e1x + e1y * e1y);
    double ang = fabs(atan2(e0x * e1y - e0y * e1x, e0x * e1x + e0y * e1y));
    double kappa = ang / (0.5 * (l0 + l1));
    if (kappa <= 1e-12) continue;
    double hv = pa__local_hausd(o, rm->bref[fe->r0[v]], rm->hausd);
    double hw = pa__local_hausd(o, rm->bref[fe->r1[v]], rm->hausd);
    double hb = sqrt(8.0 * (hv < hw ? hv : hw) / kappa);
    if (o->hmin > 0 && hb < o->hmin) hb = o->hmin;
    double *m = rm->met + (size_t)rm->mc * v;
    if (rm->mc == 1) {
      if (m[0] > hb) {
        m[0] = hb;
        limited = 1;
      }
    } else {
      double old[3] = {m[0], m[1], m[2]};
      tensor_floor(m, 1.0 / (hb * hb));
      if (old[0] != m[0] || old[2] != m[2]) limited = 1;
    }
  }
  return limited;
}

/* Spread the sizes the Hausdorff bound lowered into the interior with the
 * caller's gradation rates. This grades no metric twice: the working metric
 * is pa_remesh's, already graded with these rates and frozen vertices, a
 * fixed point of pa__metric_gradation (run again before the bound, it
 * changes no vertex), so only the new bounds and what they reach change.
 * Without it the bounded sizes meet the interior ones ungraded (plate2d
 * -hsiz 0.05 -hausd 0.0002: 685 triangles instead of 962).
 * The parallel loop's pieces get no rates (graded once over the whole
 * mesh), so it does not run there. */
static pa_status grade_hausdorff_bound(rm2d *rm) {
  pa_status st = PA_SUCCESS;
  const pa_remesh_opts *o = rm->opts;
  uint8_t *frz = NULL;
  pa_idx nv = rm->nv;
  PA_ALLOC(frz, nv);
  for (pa_idx v = 0; v < nv; v++)
    frz[v] = (rm->vtag[v] & RM2D_V_FROZEN) != 0;
  PA_CALL(pa__metric_gradation(2, rm->mc, nv, rm->x, rm->met, rm->ne, rm->tv,
                               frz, o->hgrad, o->hgradreq, NULL));
cleanup:
  pa__free(frz);
  return st;
}

pa_status pa__rm2d_feature_analyze(rm2d *rm, pa_mesh *mesh) {
  pa_status st = PA_SUCCESS;
  feat_ends fe = {NULL, NULL, NULL};
  pa_idx *bstart = NULL, *ball = NULL;
  PA_CALL(pa__balls(rm->tv, rm->ne, 3, rm->nv, &bstart, &ball));
  PA_CALL(add_records(rm, mesh, bstart, ball));
  PA_CALL(count_ends(rm, &fe));
  mark_corners(rm, &fe);
  set_tangents(rm, &fe);
  PA_CALL(fit_tangents(rm, &fe));
  /* a model's curvature bounds the sizes already (pa__metric_prepare) */
  if (!pa__remesh_model_curvature(rm->opts) && hausdorff_bound(rm, &fe) &&
      rm->opts->hgrad > 1)
    PA_CALL(grade_hausdorff_bound(rm));
  int mc = rm->mc;
  for (pa_idx k = 0; k < rm->ne; k++) { /* element qualities */
    const pa_idx *v = rm->tv + 3 * (size_t)k;
    rm->q[k] = (float)pa__qual2(
        mc, rm->x + 2 * (size_t)v[0], rm->x + 2 * (size_t)v[1],
        rm->x + 2 * (size_t)v[2], rm->met + (size_t)mc * v[0],
        rm->met + (size_t)mc * v[1], rm->met + (size_t)mc * v[2]);
  }
cleanup:
  pa__free(bstart);
  pa__free(ball);
  pa__free(fe.r0);
  pa__free(fe.r1);
  pa__free(fe.cnt);
  return st;
}

void pa__rm2d_curve_point(const rm2d *rm, pa_idx b, double s, double *p,
                          double *t) {
  const double *a = rm->x + 2 * (size_t)rm->bv[2 * b];
  const double *c = rm->x + 2 * (size_t)rm->bv[2 * b + 1];
  const double *ta = rm->btan + 4 * (size_t)b, *tc = ta + 2;
  double dx = c[0] - a[0], dy = c[1] - a[1];
  double l = sqrt(dx * dx + dy * dy);
  double ux = dx / l, uy = dy / l;
  /* straight: both tangents along the chord */
  double ca = fabs(ta[0] * uy - ta[1] * ux), cc = fabs(tc[0] * uy - tc[1] * ux);
  if (ca < 1e-10 && cc < 1e-10) {
    p[0] = a[0] + s * dx;
    p[1] = a[1] + s * dy;
    if (s == 0.5) {
      p[0] = 0.5 * (a[0] + c[0]);
      p[1] = 0.5 * (a[1] + c[1]);
    }
    t[0] = ux;
    t[1] = uy;
    return;
  }
  double s2 = s * s, s3 = s2 * s;
  double h00 = 2 * s3 - 3 * s2 + 1, h10 = s3 - 2 * s2 + s;
  double h01 = -2 * s3 + 3 * s2, h11 = s3 - s2;
  double d00 = 6 * s2 - 6 * s, d10 = 3 * s2 - 4 * s + 1;
  double d01 = -6 * s2 + 6 * s, d11 = 3 * s2 - 2 * s;
  for (int k = 0; k < 2; k++) {
    p[k] = h00 * a[k] + h10 * l * ta[k] + h01 * c[k] + h11 * l * tc[k];
    t[k] = d00 * a[k] + d10 * l * ta[k] + d01 * c[k] + d11 * l * tc[k];
  }
  double tl = sqrt(t[0] * t[0] + t[1] * t[1]);
  if (tl > 0) {
    t[0] /= tl;
    t[1] /= tl;
  } else {
    t[0] = ux;
    t[1] = uy;
  }
}
