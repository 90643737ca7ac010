/*
 * test_lscut.c -- the level-set cut (pa_mesh_levelset_cut, src/metric/
 * lscut.c), judged by tests/lsjudge.h: on jittered boxes in 2D and 3D with
 * a convex interface (circle, sphere) and a non-convex one (an annulus, a
 * torus of genus 1), every output element on one side of the input's P1
 * level set, the faces between the sides exactly the interface entities,
 * their vertices on the discrete zero set (exactly without snapping,
 * within the snapping bound with it), the inside volume that of {phi_h <
 * 0} and within the interpolation error of the exact one; the materials
 * of a parameter table, the removal of a small component, a second cut
 * replacing the first, bad values, the linear interpolation of fields,
 * the quality floor snapping gives, and the 3D remesher's handling of the
 * interface (coarsened and smoothed, still exactly the faces between the
 * sides).
 */
#include "testutil.h"

#include "lsjudge.h"
#include "metric/metric.h"

/* Box of n cells, interior vertices jittered by up to 0.15 of a cell (no
 * element inverted). */
static pa_mesh *jittered_box(int dim, int n, unsigned long long seed) {
  pa_mesh *m = NULL;
  CHECK_OK(pa_mesh_generate_box(dim, n, &m));
  pa_test_seed(seed);
  for (pa_idx v = 0; v < m->nv; v++) {
    double *x = m->coord + (size_t)dim * v;
    int inner = 1;
    for (int k = 0; k < dim; k++) inner &= x[k] > 1e-9 && x[k] < 1 - 1e-9;
    if (!inner) continue;
    for (int k = 0; k < dim; k++) x[k] += pa_test_rand_range(-0.15, 0.15) / n;
  }
  CHECK_OK(pa_mesh_check(m));
  return m;
}

typedef double (*field_fn)(const double *x);

static double circle(const double *x) {
  return hypot(x[0] - 0.51, x[1] - 0.47) - 0.3;
}
static double annulus(const double *x) { /* ring 0.2 < r < 0.35 */
  return fabs(hypot(x[0] - 0.5, x[1] - 0.52) - 0.275) - 0.075;
}
static double sphere(const double *x) {
  return sqrt(pow(x[0] - 0.51, 2) + pow(x[1] - 0.47, 2) + pow(x[2] - 0.5, 2)) -
         0.3;
}
static double torus(const double *x) { /* R 0.28, r 0.12, axis z */
  double q = hypot(x[0] - 0.5, x[1] - 0.49) - 0.28;
  return hypot(q, x[2] - 0.51) - 0.12;
}

static double *sample(const pa_mesh *m, field_fn f) {
  double *phi = malloc(sizeof(double) * (size_t)m->nv);
  for (pa_idx v = 0; v < m->nv; v++) phi[v] = f(m->coord + (size_t)m->dim * v);
  return phi;
}

/* The largest edge of the mesh and the largest change of phi along one. */
static void edge_bounds(const pa_mesh *m, const double *phi, double *hmax,
                        double *dphi) {
  int d = m->dim;
  *hmax = *dphi = 0;
  for (pa_idx e = 0; e < m->ne; e++) {
    const pa_idx *ev = m->elem + (size_t)(d + 1) * e;
    for (int i = 0; i <= d; i++)
      for (int j = i + 1; j <= d; j++) {
        const double *a = m->coord + (size_t)d * ev[i];
        const double *b = m->coord + (size_t)d * ev[j];
        double l = 0;
        for (int k = 0; k < d; k++) l += (a[k] - b[k]) * (a[k] - b[k]);
        *hmax = fmax(*hmax, sqrt(l));
        *dphi = fmax(*dphi, fabs(phi[ev[i]] - phi[ev[j]]));
      }
  }
}

/* The largest |f| at the vertices, edge midpoints and centroids of the
 * interface entities (reference 10) of m. */
static double iface_error(const pa_mesh *m, field_fn f) {
  int d = m->dim;
  double e = 0;
  for (pa_idx b = 0; b < m->nb; b++) {
    if (m->bref[b] != 10) continue;
    const double *x[3];
    for (int k = 0; k < d; k++) x[k] = m->coord + (size_t)d * m->bdry[(size_t)d * b + k];
    double c[3] = {0, 0, 0};
    for (int k = 0; k < d; k++) {
      e = fmax(e, fabs(f(x[k])));
      double mid[3];
      for (int j = 0; j < d; j++) {
        mid[j] = 0.5 * (x[k][j] + x[(k + 1) % d][j]);
        c[j] += x[k][j] / d;
      }
      e = fmax(e, fabs(f(mid)));
    }
    e = fmax(e, fabs(f(c)));
  }
  return e;
}

/* Cut a jittered box by f, judge it; exact: the interface area (perimeter),
 * the exact inside volume, the smallest radius of curvature. */
static void cut_and_judge(int dim, int n, field_fn f, double snap,
                          double area, double exact, double rho) {
  pa_mesh *in = jittered_box(dim, n, 17 + (unsigned long long)n);
  pa_mesh *out = NULL;
  double *phi = sample(in, f), hmax, dphi;
  edge_bounds(in, phi, &hmax, &dphi);
  CHECK_OK(pa_mesh_copy(in, &out));
  pa_levelset_opts o;
  pa_levelset_opts_default(&o);
  o.snap = snap;
  pa_levelset_report rep;
  CHECK_OK(pa_mesh_levelset_cut(out, phi, &o, &rep));
  CHECK_OK(pa_mesh_check(out));
  /* snapping moves phi by at most snap times its change along an edge */
  double tol = snap > 0 ? snap * dphi * 1.0001 : 1e-12;
  lsj_result r;
  lsj_judge(in, phi, out, 3, 2, 10, tol, &r);
  CHECK(r.lost == 0);
  CHECK(r.bad_side == 0);
  CHECK(r.bad_iface == 0);
  CHECK(r.off_zero == 0);
  CHECK(r.niface > 0 && r.niface == rep.niface);
  CHECK_NEAR(r.vol_all, 1.0, 1e-12);
  CHECK_NEAR(r.vol_in, rep.vol_in, 1e-12);
  /* the inside is {phi_h < 0}: exactly without snapping; with it, the
   * interface moves by at most snap times an edge */
  double below = lsj_volume_below(in, phi);
  CHECK_NEAR(r.vol_in, below, snap > 0 ? area * snap * hmax : 1e-11);
  /* the interpolation error of the level set: phi is a distance, so the
   * discrete interface lies within e = max |phi| over it (sampled at its
   * vertices, edge midpoints and centroids, where phi_h is 0 but for the
   * snapping) of the exact one, and the inside volume moves by at most
   * the interface area times e */
  double e = iface_error(out, f);
  double bound = 1.05 * area * e;
  (void)rho;
  CHECK(fabs(r.vol_in - exact) <= bound);
  if (pa_verbosity() > 0 || fabs(r.vol_in - exact) > bound)
    fprintf(stderr, "  %dD n=%d: %lld cut, %lld snapped, %lld interface, "
                    "volume %.6g (exact %.6g, bound %.3g)\n",
            dim, n, (long long)rep.ncut, (long long)rep.nsnapped,
            (long long)rep.niface, r.vol_in, exact, bound);
  free(phi);
  pa_mesh_destroy(in);
  pa_mesh_destroy(out);
}

static void test_circle(void) {
  double R = 0.3;
  cut_and_judge(2, 16, circle, 0, 2 * M_PI * R, M_PI * R * R, R);
  cut_and_judge(2, 16, circle, PA_LS_SNAP, 2 * M_PI * R, M_PI * R * R, R);
}

static void test_annulus(void) {
  double a = 0.2, b = 0.35;
  cut_and_judge(2, 24, annulus, 0, 2 * M_PI * (a + b), M_PI * (b * b - a * a),
                a);
  cut_and_judge(2, 24, annulus, PA_LS_SNAP, 2 * M_PI * (a + b),
                M_PI * (b * b - a * a), a);
}

static void test_sphere(void) {
  double R = 0.3;
  cut_and_judge(3, 8, sphere, 0, 4 * M_PI * R * R, 4 * M_PI * R * R * R / 3, R);
  cut_and_judge(3, 8, sphere, PA_LS_SNAP, 4 * M_PI * R * R,
                4 * M_PI * R * R * R / 3, R);
}

static void test_torus(void) {
  double R = 0.28, r = 0.12;
  cut_and_judge(3, 10, torus, 0, 4 * M_PI * M_PI * R * r,
                2 * M_PI * M_PI * R * r * r, r);
  cut_and_judge(3, 10, torus, PA_LS_SNAP, 4 * M_PI * M_PI * R * r,
                2 * M_PI * M_PI * R * r * r, r);
}

/* Two materials: 1 (x < 0.5) split into 5 and 6, 4 (x > 0.5) not split; a
 * reference the table does not list is refused, naming the element. */
static void test_materials(void) {
  for (int dim = 2; dim <= 3; dim++) {
    pa_mesh *in = jittered_box(dim, dim == 2 ? 16 : 6, 5), *out = NULL;
    for (pa_idx e = 0; e < in->ne; e++) {
      double c = 0;
      for (int i = 0; i <= dim; i++)
        c += in->coord[(size_t)dim * in->elem[(size_t)(dim + 1) * e + i]];
      in->eref[e] = c / (dim + 1) < 0.5 ? 1 : 4;
    }
    double *phi = sample(in, dim == 2 ? circle : sphere);
    pa_ls_material mat[2] = {{1, 1, 5, 6}, {4, 0, 0, 0}};
    pa_levelset_opts o;
    pa_levelset_opts_default(&o);
    o.mat = mat;
    o.nmat = 2;
    CHECK_OK(pa_mesh_copy(in, &out));
    pa_levelset_report rep;
    CHECK_OK(pa_mesh_levelset_cut(out, phi, &o, &rep));
    CHECK_OK(pa_mesh_check(out));
    int n[7] = {0};
    for (pa_idx e = 0; e < out->ne; e++)
      if (out->eref[e] >= 0 && out->eref[e] < 7) n[out->eref[e]]++;
    CHECK(n[5] > 0 && n[6] > 0 && n[4] > 0 && n[1] == 0);
    CHECK(n[4] + n[5] + n[6] == out->ne);
    /* the interface only between 5 and 6, judged as a two-sided cut of
     * the x < 0.5 half */
    lsj_result r;
    lsj_judge(in, phi, out, 5, 6, 10, dim == 2 ? 0.011 : 0.02, &r);
    CHECK(r.bad_side == 0);
    CHECK(r.bad_iface == 0);
    CHECK(r.niface == rep.niface && r.niface > 0);
    /* the ref-4 side is cut (conforming) but keeps its reference */
    pa_gid n4 = 0;
    for (pa_idx e = 0; e < in->ne; e++) n4 += in->eref[e] == 4;
    CHECK(n[4] > n4);
    /* cut again by the same (interpolated) level set with the same table:
     * sides 5 and 6 are material 1, the old interface goes, the same one
     * comes back */
    double *phi2 = malloc(sizeof(double) * (size_t)out->nv);
    lsj_grid G;
    lsj_grid_init(&G, in);
    for (pa_idx v = 0; v < out->nv; v++)
      phi2[v] = lsj_eval_grid(&G, phi, out->coord + (size_t)dim * v);
    lsj_grid_free(&G);
    pa_levelset_report rep2;
    CHECK_OK(pa_mesh_levelset_cut(out, phi2, &o, &rep2));
    free(phi2);
    CHECK(rep2.ndropped == rep.niface);
    CHECK(rep2.niface == rep.niface);
    /* a reference outside the table */
    mat[1].ref = 7;
    pa_mesh_destroy(out);
    CHECK_OK(pa_mesh_copy(in, &out));
    pa_status st = pa_mesh_levelset_cut(out, phi, &o, NULL);
    CHECK(st == PA_ERR_ARG);
    CHECK(strstr(pa_last_error(), "reference 4") != NULL);
    CHECK(strstr(pa_last_error(), "LSReferences") != NULL);
    CHECK(out->ne == in->ne);
    pa_clear_error();
    free(phi);
    pa_mesh_destroy(in);
    pa_mesh_destroy(out);
  }
}

/* A planted bubble (2D: 0.5 %, 3D: 0.42 % of the domain) is removed by
 * rmc 1e-2, and kept without it. */
static double two_circles(const double *x) {
  double a = hypot(x[0] - 0.4, x[1] - 0.45) - 0.25;
  double b = hypot(x[0] - 0.83, x[1] - 0.82) - 0.04;
  return fmin(a, b);
}
static double two_spheres(const double *x) {
  double a = sqrt(pow(x[0] - 0.4, 2) + pow(x[1] - 0.45, 2) +
                  pow(x[2] - 0.42, 2)) - 0.25;
  double b = sqrt(pow(x[0] - 0.82, 2) + pow(x[1] - 0.83, 2) +
                  pow(x[2] - 0.8, 2)) - 0.1;
  return fmin(a, b);
}

static double one_circle(const double *x) {
  return hypot(x[0] - 0.4, x[1] - 0.45) - 0.25;
}
static double one_sphere(const double *x) {
  return sqrt(pow(x[0] - 0.4, 2) + pow(x[1] - 0.45, 2) + pow(x[2] - 0.42, 2)) -
         0.25;
}

static void test_rmc(void) {
  for (int dim = 2; dim <= 3; dim++) {
    pa_mesh *in = jittered_box(dim, dim == 2 ? 40 : 12, 9), *out = NULL;
    double *phi = sample(in, dim == 2 ? two_circles : two_spheres);
    pa_levelset_opts o;
    pa_levelset_opts_default(&o);
    pa_levelset_report keep, rm;
    CHECK_OK(pa_mesh_copy(in, &out));
    CHECK_OK(pa_mesh_levelset_cut(out, phi, &o, &keep));
    CHECK(keep.nremoved_in == 0 && keep.nremoved_out == 0);
    pa_mesh_destroy(out);
    o.rmc = 1e-2; /* the bubble: 5e-3 (2D), 4.2e-3 (3D) of the domain */
    CHECK_OK(pa_mesh_copy(in, &out));
    CHECK_OK(pa_mesh_levelset_cut(out, phi, &o, &rm));
    CHECK_OK(pa_mesh_check(out));
    CHECK(rm.nremoved_in == 1 && rm.nremoved_out == 0);
    /* the inside is the main body's, which the bubble does not touch */
    pa_mesh *one = NULL;
    double *phi1 = sample(in, dim == 2 ? one_circle : one_sphere);
    pa_levelset_report main;
    CHECK_OK(pa_mesh_copy(in, &one));
    CHECK_OK(pa_mesh_levelset_cut(one, phi1, NULL, &main));
    CHECK_NEAR(rm.vol_in, main.vol_in, 1e-12);
    CHECK(rm.niface == main.niface);
    double small = dim == 2 ? M_PI * 0.04 * 0.04 : 4 * M_PI * pow(0.1, 3) / 3;
    CHECK(keep.vol_in - main.vol_in > 0.5 * small);
    free(phi1);
    pa_mesh_destroy(one);
    CHECK(rm.niface < keep.niface);
    /* no interface entity near the bubble any more */
    int near = 0;
    for (pa_idx b = 0; b < out->nb; b++)
      if (out->bref[b] == 10)
        near += out->coord[(size_t)dim * out->bdry[(size_t)dim * b]] > 0.72;
    CHECK(near == 0);
    free(phi);
    pa_mesh_destroy(in);
    pa_mesh_destroy(out);
  }
}

/* A value that is not a number is refused naming its vertex; the mesh is
 * left as given. No crossing: no interface, every element outside. */
static void test_bad_values(void) {
  pa_mesh *m = jittered_box(2, 6, 3);
  double *phi = sample(m, circle);
  pa_idx nv = m->nv, ne = m->ne;
  phi[6] = NAN;
  CHECK(pa_mesh_levelset_cut(m, phi, NULL, NULL) == PA_ERR_ARG);
  CHECK(strstr(pa_last_error(), "vertex 7 ") != NULL);
  CHECK(m->nv == nv && m->ne == ne);
  pa_clear_error();
  for (pa_idx v = 0; v < nv; v++) phi[v] = 1 + m->coord[2 * v];
  pa_levelset_report rep;
  CHECK_OK(pa_mesh_levelset_cut(m, phi, NULL, &rep));
  CHECK(rep.niface == 0 && rep.ncut == 0 && rep.vol_in == 0);
  int all2 = 1;
  for (pa_idx e = 0; e < m->ne; e++) all2 &= m->eref[e] == 2;
  CHECK(all2);
  pa_levelset_opts o;
  pa_levelset_opts_default(&o);
  o.snap = 0.5;
  CHECK(pa_mesh_levelset_cut(m, phi, &o, NULL) == PA_ERR_ARG);
  pa_clear_error();
  free(phi);
  pa_mesh_destroy(m);
}

/* A linear field and the metric are interpolated at the added vertices; a
 * linear field stays exact. */
static void test_fields(void) {
  pa_mesh *m = jittered_box(3, 5, 21);
  double *phi = sample(m, sphere), *u = malloc(sizeof(double) * (size_t)m->nv);
  for (pa_idx v = 0; v < m->nv; v++) {
    const double *x = m->coord + 3 * (size_t)v;
    u[v] = 1 + 2 * x[0] - x[1] + 3 * x[2];
  }
  CHECK_OK(pa_mesh_add_field(m, "u", 1, u));
  CHECK_OK(pa_metric_analytic(m, "uniform:0.2"));
  CHECK_OK(pa_mesh_levelset_cut(m, phi, NULL, NULL));
  double err = 0;
  for (pa_idx v = 0; v < m->nv; v++) {
    const double *x = m->coord + 3 * (size_t)v;
    err = fmax(err, fabs(m->field[0].val[v] - (1 + 2 * x[0] - x[1] + 3 * x[2])));
  }
  CHECK(err < 1e-12);
  CHECK_OK(pa_mesh_check(m));
  free(u);
  free(phi);
  pa_mesh_destroy(m);
}

/* Snapping keeps the cut's elements away from flat: the worst of them has
 * a volume share of its parent's at least about snap^3. */
static void test_snap_floor(void) {
  for (int dim = 2; dim <= 3; dim++) {
    pa_mesh *in = jittered_box(dim, dim == 2 ? 20 : 7, 33), *out = NULL;
    double *phi = sample(in, dim == 2 ? circle : sphere);
    /* a vertex next to the zero set, far closer than the snapping share */
    pa_idx close = 0;
    for (pa_idx v = 1; v < in->nv; v++)
      if (fabs(phi[v]) < fabs(phi[close])) close = v;
    phi[close] = 1e-9;
    pa_levelset_report rep;
    CHECK_OK(pa_mesh_copy(in, &out));
    CHECK_OK(pa_mesh_levelset_cut(out, phi, NULL, &rep));
    double qmin = 1;
    for (pa_idx e = 0; e < out->ne; e++)
      qmin = fmin(qmin, pa_mesh_elem_quality(out, e));
    double floor = pow(PA_LS_SNAP, dim) * 1e-2;
    CHECK(qmin > floor);
    if (qmin <= floor || pa_verbosity() > 0)
      fprintf(stderr, "  %dD: worst quality after the cut %.3g (%lld snapped)\n",
              dim, qmin, (long long)rep.nsnapped);
    CHECK(rep.nsnapped > 0);
    free(phi);
    pa_mesh_destroy(in);
    pa_mesh_destroy(out);
  }
}

/* The 3D remesher keeps an interface and remeshes it: a plane through
 * the box's grid vertices (the interface made of whole faces on the zero
 * set) coarsened, a sphere refined; the interface stays exactly the faces
 * between the sides, its vertices collapse and move (the worst quality
 * stays that of a mesh without interface). */
static void remesh_interface(const char *shape, int n, double h,
                             int max_iface_vertices, double qmin) {
  pa_mesh *m = NULL;
  CHECK_OK(pa_mesh_generate_box(3, n, &m));
  double *phi = malloc(sizeof(double) * (size_t)m->nv);
  CHECK_OK(pa_levelset_analytic(m, shape, phi));
  pa_mesh *in = NULL;
  CHECK_OK(pa_mesh_copy(m, &in));
  pa_levelset_report rep;
  CHECK_OK(pa_mesh_levelset_cut(m, phi, NULL, &rep));
  pa_remesh_opts o;
  pa_remesh_opts_default(&o);
  o.hsiz = h;
  pa_remesh_report rr;
  CHECK_OK(pa_remesh(pa_remesher_builtin(), m, &o, &rr));
  CHECK_OK(pa_mesh_check(m));
  lsj_result r;
  lsj_judge(in, phi, m, 3, 2, 10, o.hausd + 1e-9, &r);
  CHECK(r.bad_iface == 0 && r.bad_side == 0 && r.niface > 0);
  pa_idx nifv = 0;
  for (pa_idx v = 0; v < m->nv; v++) nifv += m->vref[v] == 10;
  double q = 1;
  for (pa_idx e = 0; e < m->ne; e++) q = fmin(q, pa_mesh_elem_quality(m, e));
  CHECK(nifv <= max_iface_vertices);
  CHECK(q >= qmin);
  if (nifv > max_iface_vertices || q < qmin || pa_verbosity() > 0)
    fprintf(stderr, "  %s: %lld interface vertices, worst quality %.3f\n",
            shape, (long long)nifv, q);
  free(phi);
  pa_mesh_destroy(in);
  pa_mesh_destroy(m);
}

static void test_remesh_interface(void) {
  /* 81 interface vertices in the input: without collapses on the
   * interface they all stayed */
  remesh_interface("plane:1,0,0,0.5", 8, 0.3, 40, 0.3);
  /* without normals on the interface its vertices did not move and the
   * tets on its poor triangles stayed below 0.3 */
  remesh_interface("sphere:0.3:0.5,0.5,0.5", 12, 0.08, 1 << 30, 0.3);
}

TEST_MAIN(test_circle, test_annulus, test_sphere, test_torus, test_materials,
          test_rmc, test_bad_values, test_fields, test_snap_floor,
          test_remesh_interface)
