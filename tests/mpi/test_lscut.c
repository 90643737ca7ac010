/*
 * test_lscut.c -- the level-set cut of a distributed mesh
 * (pa_dmesh_levelset_cut, src/adapt/dlevelset.c) at any number of ranks:
 *  - on jittered boxes with a circle, an annulus, a sphere and a torus (of
 *    genus 1), the distributed cut is the sequential cut of the same mesh:
 *    the same checksum (coordinates, references, fields, whatever the
 *    numbering), the same report; the gathered result passes the judge of
 *    tests/lsjudge.h (sides, interface faces, zero set, volume of
 *    {phi_h < 0});
 *  - with materials, and with a planted bubble that rmc removes (2D and
 *    3D: no inside element left there), the same;
 *  - adapted after the cut (pa_dmesh_adapt), the interface is kept: a
 *    valid, conforming mesh whose faces between the sides are exactly the
 *    interface entities, every element on its side of the input's level
 *    set and every interface vertex on its zero set within the Hausdorff
 *    distance, the inside volume within that distance times the interface
 *    area of the cut's.
 */
#include "adapt/piece.h"
#include "lsjudge.h"
#include "testutil.h"

#include <mpi.h>

typedef double (*field_fn)(const double *x);

static double circle(const double *x) {
  return hypot(x[0] - 0.51, x[1] - 0.47) - 0.3;
}
static double annulus(const double *x) {
  return fabs(hypot(x[0] - 0.5, x[1] - 0.52) - 0.275) - 0.075;
}
static double sphere(const double *x) {
  return sqrt(pow(x[0] - 0.51, 2) + pow(x[1] - 0.47, 2) + pow(x[2] - 0.5, 2)) -
         0.3;
}
static double torus(const double *x) {
  double q = hypot(x[0] - 0.5, x[1] - 0.49) - 0.28;
  return hypot(q, x[2] - 0.51) - 0.12;
}
static double two_circles(const double *x) {
  return fmin(hypot(x[0] - 0.4, x[1] - 0.45) - 0.25,
              hypot(x[0] - 0.83, x[1] - 0.82) - 0.04);
}
static double two_spheres(const double *x) {
  double b[3] = {x[0] - 0.83, x[1] - 0.82, x[2] - 0.8};
  return fmin(sphere(x) + 0.05, sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]) - 0.07);
}

/* Rank 0: a box of n cells, its interior vertices jittered (seeded), with
 * the level set f as the vertex field "phi" and element references 1 (x <
 * 0.5) and 4 when two_refs. */
static pa_mesh *make_mesh(int dim, int n, field_fn f, int two_refs) {
  pa_mesh *m = NULL;
  CHECK_OK(pa_mesh_generate_box(dim, n, &m));
  pa_test_seed(41 + (unsigned long long)n);
  for (pa_idx v = 0; v < m->nv; v++) {
    double *x = m->coord + (size_t)dim * v;
    int inner = 1;
    for (int k = 0; k < dim; k++) inner &= x[k] > 1e-9 && x[k] < 1 - 1e-9;
    if (inner)
      for (int k = 0; k < dim; k++) x[k] += pa_test_rand_range(-0.15, 0.15) / n;
  }
  double *phi = malloc(sizeof(double) * (size_t)m->nv);
  for (pa_idx v = 0; v < m->nv; v++) phi[v] = f(m->coord + (size_t)dim * v);
  CHECK_OK(pa_mesh_add_field(m, "phi", 1, phi));
  free(phi);
  if (two_refs)
    for (pa_idx e = 0; e < m->ne; e++) {
      double c = 0;
      for (int i = 0; i <= dim; i++)
        c += m->coord[(size_t)dim * m->elem[(size_t)(dim + 1) * e + i]];
      m->eref[e] = c / (dim + 1) < 0.5 ? 1 : 4;
    }
  return m;
}

/* The checksum of a sequential mesh held by rank 0, distributed. */
static uint64_t checksum_of(pa_mesh *m) {
  pa_dmesh *dm = NULL;
  uint64_t h = 0;
  CHECK_OK(pa_dmesh_distribute(MPI_COMM_WORLD, 0, m, 0, &dm));
  CHECK_OK(pa_dmesh_checksum(dm, &h));
  pa_dmesh_destroy(dm);
  return h;
}

/* Cut the distributed mesh and the sequential one by f (options o) and
 * compare them; returns the distributed mesh (cut) and, on rank 0, the
 * input (*in). */
static pa_dmesh *cut_both(int dim, int n, field_fn f, int overlap,
                          const pa_levelset_opts *o, int two_refs,
                          pa_mesh **in, pa_levelset_report *rep) {
  pa_mesh *m = NULL, *seq = NULL;
  pa_dmesh *dm = NULL;
  pa_levelset_report srep;
  *in = NULL;
  if (pa_test_rank == 0) {
    m = make_mesh(dim, n, f, two_refs);
    CHECK_OK(pa_mesh_copy(m, &seq));
    CHECK_OK(pa_mesh_copy(m, in));
    double *phi = malloc(sizeof(double) * (size_t)m->nv);
    memcpy(phi, m->field[0].val, sizeof(double) * (size_t)m->nv);
    CHECK_OK(pa_mesh_levelset_cut(seq, phi, o, &srep));
    free(phi);
  }
  CHECK_OK(pa_dmesh_distribute(MPI_COMM_WORLD, 0, m, overlap, &dm));
  pa_mesh_destroy(m);
  CHECK_OK(pa_dmesh_levelset_cut(dm, 0, o, rep));
  CHECK_OK(pa_dmesh_check(dm));
  CHECK(pa_dmesh_overlap(dm) == overlap);
  uint64_t hd = 0, hs = checksum_of(seq);
  CHECK_OK(pa_dmesh_checksum(dm, &hd));
  CHECK(hd == hs);
  if (pa_test_rank == 0) {
    CHECK(rep->ncut == srep.ncut && rep->niface == srep.niface);
    CHECK(rep->nelem_cut == srep.nelem_cut && rep->nsnapped == srep.nsnapped);
    CHECK(rep->nremoved_in == srep.nremoved_in);
    CHECK(fabs(rep->vol_in - srep.vol_in) <= 1e-12);
    if (hd != hs)
      fprintf(stderr, "  %dD n=%d: the distributed cut differs: %lld/%lld "
                      "cut, %lld/%lld interface\n",
              dim, n, (long long)rep->ncut, (long long)srep.ncut,
              (long long)rep->niface, (long long)srep.niface);
  }
  pa_mesh_destroy(seq);
  return dm;
}

static void judge(const pa_mesh *in, pa_mesh *g, double tol, int32_t rin,
                  int32_t rex, lsj_result *r) {
  lsj_judge(in, in->field[0].val, g, rin, rex, 10, tol, r);
  CHECK(r->lost == 0);
  CHECK(r->bad_side == 0);
  CHECK(r->bad_iface == 0);
  CHECK(r->off_zero == 0);
  CHECK(r->niface > 0);
}

static void test_cut(void) {
  struct {
    int dim, n, overlap;
    field_fn f;
  } c[] = {{2, 24, 0, circle}, {2, 24, 1, annulus}, {3, 8, 0, sphere},
           {3, 10, 0, torus}};
  for (int k = 0; k < 4; k++) {
    pa_mesh *in = NULL, *g = NULL;
    pa_levelset_report rep;
    pa_dmesh *dm = cut_both(c[k].dim, c[k].n, c[k].f, c[k].overlap, NULL, 0,
                            &in, &rep);
    CHECK_OK(pa_dmesh_gather(dm, 0, &g));
    if (pa_test_rank == 0) {
      lsj_result r;
      CHECK_OK(pa_mesh_check(g));
      judge(in, g, 0.011, 3, 2, &r);
      CHECK(r.niface == rep.niface);
      CHECK_NEAR(r.vol_in, rep.vol_in, 1e-12);
    }
    pa_mesh_destroy(g);
    pa_mesh_destroy(in);
    pa_dmesh_destroy(dm);
  }
}

static void test_materials(void) {
  pa_ls_material mat[2] = {{1, 1, 5, 6}, {4, 0, 0, 0}};
  pa_levelset_opts o;
  pa_levelset_opts_default(&o);
  o.mat = mat;
  o.nmat = 2;
  for (int dim = 2; dim <= 3; dim++) {
    pa_mesh *in = NULL, *g = NULL;
    pa_levelset_report rep;
    pa_dmesh *dm = cut_both(dim, dim == 2 ? 16 : 6, dim == 2 ? circle : sphere,
                            0, &o, 1, &in, &rep);
    CHECK(rep.niface > 0);
    CHECK_OK(pa_dmesh_gather(dm, 0, &g));
    if (pa_test_rank == 0) {
      lsj_result r;
      lsj_judge(in, in->field[0].val, g, 5, 6, 10, 0.02, &r);
      CHECK(r.bad_side == 0 && r.bad_iface == 0);
    }
    pa_mesh_destroy(g);
    pa_mesh_destroy(in);
    pa_dmesh_destroy(dm);
  }
  /* a reference the table does not list: the same error on every rank */
  mat[1].ref = 7;
  pa_mesh *m = pa_test_rank == 0 ? make_mesh(2, 8, circle, 1) : NULL;
  pa_dmesh *dm = NULL;
  CHECK_OK(pa_dmesh_distribute(MPI_COMM_WORLD, 0, m, 0, &dm));
  pa_mesh_destroy(m);
  CHECK(pa_dmesh_levelset_cut(dm, 0, &o, NULL) == PA_ERR_ARG);
  CHECK(strstr(pa_last_error(), "reference 4") != NULL);
  pa_clear_error();
  pa_dmesh_destroy(dm);
}

static void test_rmc(void) {
  pa_levelset_opts o;
  pa_levelset_opts_default(&o);
  o.rmc = 1e-2;
  for (int dim = 2; dim <= 3; dim++) {
    pa_mesh *in = NULL, *g = NULL;
    pa_levelset_report rep;
    pa_dmesh *dm = cut_both(dim, dim == 2 ? 40 : 12,
                            dim == 2 ? two_circles : two_spheres, 0, &o, 0,
                            &in, &rep);
    CHECK(rep.nremoved_in == 1 && rep.nremoved_out == 0);
    /* no inside element is left near the bubble's centre */
    CHECK_OK(pa_dmesh_gather(dm, 0, &g));
    if (pa_test_rank == 0) {
      const double b[3] = {0.83, 0.82, 0.8};
      pa_idx near = 0;
      for (pa_idx e = 0; e < g->ne; e++) {
        if (g->eref[e] != 3) continue;
        double d2 = 0;
        for (int k = 0; k < dim; k++) {
          double cx = 0;
          for (int i = 0; i <= dim; i++)
            cx += g->coord[(size_t)dim * g->elem[(size_t)(dim + 1) * e + i] + k];
          d2 += pow(cx / (dim + 1) - b[k], 2);
        }
        near += d2 < 0.1 * 0.1;
      }
      CHECK(near == 0);
    }
    pa_mesh_destroy(g);
    pa_mesh_destroy(in);
    pa_dmesh_destroy(dm);
  }
}

/* Cut, then adapt to size h on every rank; the interface survives. */
static void adapt_after_cut(int dim, int n, field_fn f, double h) {
  pa_mesh *in = NULL, *g = NULL;
  pa_levelset_report rep;
  pa_dmesh *dm = cut_both(dim, n, f, 0, NULL, 0, &in, &rep);
  pa_adapt_opts o;
  pa_adapt_opts_default(&o);
  o.remesh.hsiz = h;
  o.min_piece_work = 50; /* several pieces on a small mesh */
  o.check_pieces = 1;
  pa_adapt_report ar;
  CHECK_OK(pa_dmesh_adapt(dm, &o, &ar));
  CHECK_OK(pa_dmesh_check(dm));
  CHECK_OK(pa_dmesh_gather(dm, 0, &g));
  if (pa_test_rank == 0) {
    lsj_result r;
    CHECK_OK(pa_mesh_check(g));
    /* the interface moves within hausd (0.01) of the cut's, which lies on
     * the zero set within the snapping */
    double hausd = o.remesh.hausd;
    judge(in, g, 2 * hausd + 0.011, 3, 2, &r);
    double area = dim == 2 ? 2 * M_PI * 0.3 : 4 * M_PI * 0.09;
    CHECK(fabs(r.vol_in - rep.vol_in) <= area * hausd);
    printf("  %dD: cut %lld interface entities, volume %.6f; adapted: %lld "
           "elements, %lld interface entities, volume %.6f\n",
           dim, (long long)rep.niface, rep.vol_in, (long long)g->ne,
           (long long)r.niface, r.vol_in);
  }
  pa_mesh_destroy(g);
  pa_mesh_destroy(in);
  pa_dmesh_destroy(dm);
}

static void test_adapt(void) {
  adapt_after_cut(2, 16, circle, 0.03);
  adapt_after_cut(3, 6, sphere, 0.08);
}

TEST_MPI_MAIN(test_cut, test_materials, test_rmc, test_adapt)
