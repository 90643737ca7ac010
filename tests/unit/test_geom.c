/*
 * test_geom.c -- remeshing onto a model through the caller's own kernel
 * (pa_geometry_create), without Gmsh: a quarter annulus (2D) and a quarter
 * of a thick cylinder (3D), made by mapping the unit box, classified by
 * hand (pa_mesh_set_vertex_entities), with closest points and curvatures
 * in closed form. Checked: every boundary vertex on its entity after
 * refinement, corners kept, the area or volume at the polyhedral limit
 * (and the same run without the model off it), the classification kept,
 * the fallback when the kernel fails, and the bad inputs.
 */
#include "testutil.h"

#include "mesh/mesh.h"

/* Radii of the quarter annulus (cylinder shell); its height is 1. */
#define R0 0.5
#define R1 1.0

/* Longest edge the remesher leaves, relative to the size asked for: above
 * sqrt 2 (the band it splits above) by the margin of a graded, not
 * uniform, size along a curve. */
#define LEN_HI_BOUND 1.6

/* The model: dim of the mesh; fail_dim/fail_tag an entity the kernel
 * refuses (the fallback test), -1 for none; calls counted. */
typedef struct model {
  int dim, fail_dim, fail_tag;
  long ncall;
} model;

/* The box coordinates (u, v[, w]) of a point of the model. */
static void to_box(int dim, const double *x, double *b) {
  double r = hypot(x[0], x[1]);
  b[0] = (r - R0) / (R1 - R0);
  b[1] = atan2(x[1], x[0]) / (M_PI / 2);
  if (dim == 3) b[2] = x[2];
}

static void from_box(int dim, const double *b, double *x) {
  double r = R0 + (R1 - R0) * b[0], t = b[1] * M_PI / 2;
  x[0] = r * cos(t);
  x[1] = r * sin(t);
  x[2] = dim == 3 ? b[2] : 0;
}

/* Which box coordinates an entity fixes (bit k: coordinate k, at value
 * bit k of *val), from its dimension and tag (the numbering of
 * entity_of). */
static int fixed_of(int mdim, int dim, int tag, int *val) {
  int nfix = mdim - dim;
  if (mdim == 2) {
    if (dim == 0) { /* 1 (0,0) 2 (1,0) 3 (1,1) 4 (0,1) */
      static const int pv[4] = {0, 1, 3, 2};
      *val = pv[(tag - 1) & 3];
      return 3;
    }
    int axis = tag <= 2 ? 0 : 1; /* 1 u=0, 2 u=1, 3 v=0, 4 v=1 */
    *val = ((tag - 1) & 1) << axis;
    return 1 << axis;
  }
  if (nfix == 3) { /* points: 1 + 4u + 2v + w */
    int k = tag - 1;
    *val = ((k >> 2) & 1) | (((k >> 1) & 1) << 1) | ((k & 1) << 2);
    return 7;
  }
  if (nfix == 1) { /* surfaces: 1 u=0, 2 u=1, 3 v=0, 4 v=1, 5 w=0, 6 w=1 */
    int axis = (tag - 1) / 2;
    *val = ((tag - 1) & 1) << axis;
    return 1 << axis;
  }
  /* curves: 1 + 4 pair + 2 a + b, pairs (u,v) (u,w) (v,w) */
  static const int pairs[3][2] = {{0, 1}, {0, 2}, {1, 2}};
  int k = tag - 1, p = k / 4, a = (k >> 1) & 1, b = k & 1;
  *val = (a << pairs[p][0]) | (b << pairs[p][1]);
  return (1 << pairs[p][0]) | (1 << pairs[p][1]);
}

/* The entity of a box point: the coordinates at 0 or 1 fix it. */
static void entity_of(int mdim, const double *b, int *dim, int32_t *tag) {
  int fix = 0, val = 0;
  for (int k = 0; k < mdim; k++)
    if (b[k] == 0 || b[k] == 1) {
      fix |= 1 << k;
      val |= (b[k] == 1) << k;
    }
  int n = (fix & 1) + ((fix >> 1) & 1) + ((fix >> 2) & 1);
  *dim = mdim - n;
  *tag = 1;
  if (n == 0) return;
  for (int t = 1; t <= 12; t++) {
    int v, f = fixed_of(mdim, *dim, t, &v);
    if (f == fix && v == val) {
      *tag = t;
      return;
    }
  }
}

static int closest(void *ctx, int dim, int tag, const double *x, double *y) {
  model *md = ctx;
  md->ncall++;
  if (dim == md->fail_dim && tag == md->fail_tag) return 1;
  int val, fix = fixed_of(md->dim, dim, tag, &val);
  if (hypot(x[0], x[1]) == 0) return 1;
  double b[3];
  to_box(md->dim, x, b);
  for (int k = 0; k < md->dim; k++)
    if (fix >> k & 1) b[k] = (val >> k) & 1;
  /* the closest point of a line, circle, plane or cylinder of the
   * mapping is the mapped point with the fixed coordinates set */
  from_box(md->dim, b, y);
  return 0;
}

static int curvature(void *ctx, int dim, int tag, const double *y,
                     double *kappa) {
  model *md = ctx;
  (void)y;
  int val, fix = fixed_of(md->dim, dim, tag, &val);
  *kappa = (fix & 1) && !(md->dim == 3 && dim == 1 && (fix & 2))
               ? 1.0 / (val & 1 ? R1 : R0)
               : 0.0;
  return 0;
}

/* The unit box of n cells mapped onto the model and classified. */
static pa_mesh *model_mesh(int dim, int n) {
  pa_mesh *m = NULL;
  CHECK_OK(pa_mesh_generate_box(dim, n, &m));
  if (!m) return NULL;
  pa_idx nv = pa_mesh_nvert(m);
  int *gd = malloc(sizeof *gd * (size_t)nv);
  int32_t *gt = malloc(sizeof *gt * (size_t)nv);
  double *x = pa_mesh_coords(m);
  for (pa_idx v = 0; v < nv; v++) {
    double *p = x + (size_t)dim * v, y[3];
    entity_of(dim, p, &gd[v], &gt[v]);
    from_box(dim, p, y);
    memcpy(p, y, sizeof(double) * dim);
  }
  /* the box's boundary references are the tags of entity_of's curves
   * (2D) or surfaces (3D); the curve edges (3D) are found */
  CHECK_OK(pa_mesh_set_vertex_entities(m, gd, gt));
  free(gd);
  free(gt);
  return m;
}

/* The largest distance of a boundary vertex of m to its entity, and the
 * number of vertices on points. */
static double off_model(pa_mesh *m, int *npoints) {
  int dim = pa_mesh_dim(m);
  model md = {dim, -1, -1, 0};
  const uint8_t *gd = pa_mesh_vert_entity_dims(m);
  const int32_t *gt = pa_mesh_vert_entity_tags(m);
  const double *x = pa_mesh_coords(m);
  double worst = 0;
  *npoints = 0;
  for (pa_idx v = 0; v < pa_mesh_nvert(m); v++) {
    if (gd[v] >= dim) continue;
    double p[3] = {x[dim * v], x[dim * v + 1], dim == 3 ? x[dim * v + 2] : 0},
           y[3];
    CHECK(closest(&md, gd[v], gt[v], p, y) == 0);
    worst = fmax(worst, hypot(hypot(p[0] - y[0], p[1] - y[1]), p[2] - y[2]));
    *npoints += gd[v] == 0;
  }
  return worst;
}

/* The area (2D) or volume (3D) of the model. */
static double model_volume(void) {
  return M_PI / 4 * (R1 * R1 - R0 * R0);
}

/* The area or volume an inscribed polygon or polyhedron of edges h loses on
 * the curved boundary, bounded: sagitta h^2 kappa / 8 over the curved
 * boundary (quarter circles of radius R0 and R1, height 1). */
static double polyhedral_bound(double h) {
  return (M_PI / 2 * (R0 + R1)) * h * h / 8 * (1 / R0);
}

static void refine(int dim, int n, double h) {
  model md = {dim, -1, -1, 0};
  pa_geometry *g = NULL;
  pa_geometry_ops ops = {closest, curvature};
  CHECK_OK(pa_geometry_create(&ops, &md, 2.0, &g));
  pa_mesh *m = model_mesh(dim, n), *plain = NULL;
  CHECK(m && pa_mesh_classified(m));
  if (!m || !g) return;
  CHECK_OK(pa_mesh_copy(m, &plain));
  int npoints;
  CHECK(off_model(m, &npoints) < 1e-14);
  CHECK(npoints == (dim == 2 ? 4 : 8));

  pa_remesh_opts o;
  pa_remesh_report r;
  pa_remesh_opts_default(&o);
  o.hsiz = h;
  o.geometry = g;
  CHECK_OK(pa_remesh(pa_remesher_builtin(), m, &o, &r));
  CHECK(r.outcome == PA_REMESH_SUCCESS);
  CHECK(r.nproject > 0 && r.nproject_failed == 0);
  CHECK_OK(pa_mesh_check(m));
  CHECK(pa_mesh_classified(m));
  double off = off_model(m, &npoints);
  CHECK(off <= 1e-12);
  CHECK(npoints == (dim == 2 ? 4 : 8)); /* the corners stayed */
  double err = fabs(pa_mesh_volume(m) - model_volume());
  CHECK(err <= polyhedral_bound(h));

  /* the same without the model: the boundary stays on the coarse facets */
  o.geometry = NULL;
  CHECK_OK(pa_remesh(pa_remesher_builtin(), plain, &o, &r));
  double err0 = fabs(pa_mesh_volume(plain) - model_volume());
  CHECK(off_model(plain, &npoints) > 1e-3);
  CHECK(err0 > 4 * polyhedral_bound(h));
  printf("  %dD n %d h %g: %ld elements, off the model %.2g (without: %.2g), "
         "volume error %.2e (without: %.2e, bound %.2e)\n",
         dim, n, h, (long)pa_mesh_nelem(m), off,
         off_model(plain, &npoints), err, err0, polyhedral_bound(h));
  pa_mesh_destroy(m);
  pa_mesh_destroy(plain);
  pa_geometry_destroy(g);
}

static void test_refine_2d(void) { refine(2, 3, 0.04); }
static void test_refine_3d(void) { refine(3, 2, 0.12); }

/* The classification goes through a copy, and the vertices' entities agree
 * with the cells' after a remesh. */
static void test_classification(void) {
  pa_mesh *m = model_mesh(3, 2), *c = NULL;
  if (!m) return;
  CHECK(pa_mesh_nedge(m) == 12 * 2); /* every curve listed, 2 edges each */
  CHECK_OK(pa_mesh_copy(m, &c));
  CHECK(pa_mesh_classified(c));
  CHECK(!memcmp(pa_mesh_vert_entity_tags(m), pa_mesh_vert_entity_tags(c),
                sizeof(int32_t) * (size_t)pa_mesh_nvert(m)));
  const uint8_t *gd = pa_mesh_vert_entity_dims(m);
  const uint8_t *fl = pa_mesh_vert_flags(m);
  for (pa_idx v = 0; v < pa_mesh_nvert(m); v++)
    CHECK((gd[v] == 0) == ((fl[v] & PA_FLAG_CORNER) != 0));
  /* unclassified again */
  CHECK_OK(pa_mesh_set_vertex_entities(c, NULL, NULL));
  CHECK(!pa_mesh_classified(c));
  pa_mesh_destroy(c);
  pa_mesh_destroy(m);
}

/* The kernel fails on the outer arc (2D): its new vertices stay on the
 * remesher's reconstruction, the others go onto the model, and the remesh
 * succeeds. */
static void test_fallback(void) {
  model md = {2, 1, 2, 0};
  pa_geometry *g = NULL;
  pa_geometry_ops ops = {closest, NULL};
  CHECK_OK(pa_geometry_create(&ops, &md, 2.0, &g));
  pa_mesh *m = model_mesh(2, 3);
  if (!m || !g) return;
  pa_remesh_opts o;
  pa_remesh_report r;
  pa_remesh_opts_default(&o);
  o.hsiz = 0.05;
  o.geometry = g;
  CHECK_OK(pa_remesh(pa_remesher_builtin(), m, &o, &r));
  CHECK(r.outcome == PA_REMESH_SUCCESS);
  CHECK(r.nproject_failed > 0 && r.nproject > r.nproject_failed);
  const uint8_t *gd = pa_mesh_vert_entity_dims(m);
  const int32_t *gt = pa_mesh_vert_entity_tags(m);
  const double *x = pa_mesh_coords(m);
  double off_outer = 0, off_inner = 0;
  for (pa_idx v = 0; v < pa_mesh_nvert(m); v++) {
    if (gd[v] != 1) continue;
    double d = fabs(hypot(x[2 * v], x[2 * v + 1]) - (gt[v] == 2 ? R1 : R0));
    if (gt[v] == 2) off_outer = fmax(off_outer, d);
    if (gt[v] == 1) off_inner = fmax(off_inner, d);
  }
  CHECK(off_inner < 1e-14);
  /* the reconstruction's, within the sagitta of the input's chords (3
   * cells over a quarter circle) */
  printf("  kernel failing on the outer arc: %.2g off it (the inner %.2g)\n",
         off_outer, off_inner);
  CHECK(off_outer > 1e-6 && off_outer < R1 * (1 - cos(M_PI / 12)));
  pa_mesh_destroy(m);
  pa_geometry_destroy(g);
}

/* Bad inputs: clear errors naming the vertex or entity. */
static void test_errors(void) {
  model md = {3, -1, -1, 0};
  pa_geometry *g = NULL;
  pa_geometry_ops ops = {closest, curvature}, none = {NULL, NULL};
  CHECK(pa_geometry_create(&none, &md, 1, &g) == PA_ERR_ARG);
  CHECK(pa_geometry_create(&ops, &md, 0, &g) == PA_ERR_ARG);
  CHECK(pa_geometry_create(&ops, &md, NAN, &g) == PA_ERR_ARG);
  CHECK_OK(pa_geometry_create(&ops, &md, 2.0, &g));
  pa_mesh *m = model_mesh(3, 2), *plain = NULL;
  if (!m || !g) return;
  /* a vertex moved off its surface */
  pa_geometry_report rep;
  CHECK_OK(pa_geometry_check(g, m, 1e-9, &rep));
  CHECK(rep.nvert > 0 && rep.dist_max < 1e-14);
  const uint8_t *gd = pa_mesh_vert_entity_dims(m);
  const int32_t *gt = pa_mesh_vert_entity_tags(m);
  pa_idx v = 0;
  while (gd[v] != 2 || gt[v] != 2) v++; /* on the outer cylinder */
  double *x = pa_mesh_coords(m), keep = x[3 * v + 2];
  x[3 * v] *= 1.01;
  x[3 * v + 1] *= 1.01;
  CHECK(pa_geometry_check(g, m, 1e-3, &rep) == PA_ERR_MESH);
  char want[64];
  snprintf(want, sizeof want, "vertex %ld ", (long)v + 1);
  CHECK(strstr(pa_last_error(), want) != NULL);
  CHECK(strstr(pa_last_error(), "does not match the model") != NULL);
  x[3 * v] /= 1.01;
  x[3 * v + 1] /= 1.01;
  x[3 * v + 2] = keep;
  /* an entity the kernel does not know */
  md.fail_dim = 2;
  md.fail_tag = 6;
  CHECK(pa_geometry_check(g, m, 1e-3, &rep) == PA_ERR_MESH);
  CHECK(strstr(pa_last_error(), "(2, 6)") != NULL);
  CHECK(pa_geometry_closest(g, 2, 6, x, x) == PA_ERR_ARG);
  CHECK(pa_geometry_closest(g, 3, 1, x, x) == PA_ERR_ARG);
  /* a geometry needs a classified mesh */
  CHECK_OK(pa_mesh_generate_box(3, 2, &plain));
  pa_remesh_opts o;
  pa_remesh_opts_default(&o);
  o.hsiz = 0.3;
  o.geometry = g;
  if (plain) {
    CHECK(pa_remesh(pa_remesher_builtin(), plain, &o, NULL) == PA_ERR_ARG);
    CHECK(strstr(pa_last_error(), "classified") != NULL);
    CHECK(pa_geometry_check(g, plain, 1e-3, NULL) == PA_ERR_ARG);
    CHECK(pa_mesh_classify(plain) == PA_ERR_ARG);
    /* entities out of range */
    int *bad = calloc((size_t)pa_mesh_nvert(plain), sizeof *bad);
    int32_t *tags = calloc((size_t)pa_mesh_nvert(plain), sizeof *tags);
    bad[0] = 4;
    CHECK(pa_mesh_set_vertex_entities(plain, bad, tags) == PA_ERR_ARG);
    bad[0] = 1; /* on a curve, tag 0 */
    CHECK(pa_mesh_set_vertex_entities(plain, bad, tags) == PA_ERR_ARG);
    CHECK(!pa_mesh_classified(plain));
    /* every vertex on one curve: the box's faces lie on no curve */
    for (pa_idx k = 0; k < pa_mesh_nvert(plain); k++) {
      bad[k] = 3;
      tags[k] = 1;
    }
    bad[0] = 2;
    CHECK(pa_mesh_set_vertex_entities(plain, bad, tags) == PA_ERR_MESH);
    CHECK(!pa_mesh_classified(plain));
    free(bad);
    free(tags);
  }
  /* without Gmsh's library, or a model file it cannot read */
  const char *why;
  pa_geometry *gm = NULL;
  int have = pa_geometry_available(&why);
  CHECK(have || strstr(why, "Gmsh") != NULL);
  CHECK(pa_geometry_read("no-such-model.step", &gm) ==
        (have ? PA_ERR_IO : PA_ERR_UNSUPPORTED));
  CHECK(strstr(pa_last_error(), "no-such-model.step") != NULL);
  CHECK(pa_geometry_read("model.txt", &gm) == PA_ERR_UNSUPPORTED);
  CHECK(gm == NULL);
  pa_mesh_destroy(plain);
  pa_mesh_destroy(m);
  pa_geometry_destroy(g);
}

/* -hausd against the model's curvature: on the arcs of the annulus the
 * edges are bounded by sqrt(8 hausd R) (to the remesher's length band),
 * on the straight sides only by hsiz. */
static void test_hausd(void) {
  model md = {2, -1, -1, 0};
  pa_geometry *g = NULL;
  pa_geometry_ops ops = {closest, curvature};
  CHECK_OK(pa_geometry_create(&ops, &md, 2.0, &g));
  pa_mesh *m = model_mesh(2, 2);
  if (!m || !g) return;
  pa_remesh_opts o;
  pa_remesh_opts_default(&o);
  o.hsiz = 0.2;
  o.hausd = 5e-4;
  o.geometry = g;
  CHECK_OK(pa_remesh(pa_remesher_builtin(), m, &o, NULL));
  double lmax[5] = {0, 0, 0, 0, 0};
  const double *x = pa_mesh_coords(m);
  for (pa_idx b = 0; b < pa_mesh_nbdry(m); b++) {
    const pa_idx *e = pa_mesh_bdrys(m) + 2 * b;
    int32_t r = pa_mesh_bdry_refs(m)[b];
    double l = hypot(x[2 * e[0]] - x[2 * e[1]], x[2 * e[0] + 1] - x[2 * e[1] + 1]);
    if (r >= 1 && r <= 4) lmax[r] = fmax(lmax[r], l);
  }
  printf("  hausd %g: longest edge on the inner arc %.3f (bound %.3f), outer "
         "%.3f (%.3f), sides %.3f %.3f\n",
         o.hausd, lmax[1], sqrt(8 * o.hausd * R0), lmax[2],
         sqrt(8 * o.hausd * R1), lmax[3], lmax[4]);
  CHECK(lmax[1] <= LEN_HI_BOUND * sqrt(8 * o.hausd * R0));
  CHECK(lmax[2] <= LEN_HI_BOUND * sqrt(8 * o.hausd * R1));
  /* the straight sides are held to the arcs' sizes only near them */
  CHECK(lmax[3] > 2 * fmax(lmax[1], lmax[2]) &&
        lmax[4] > 2 * fmax(lmax[1], lmax[2]));
  pa_mesh_destroy(m);
  pa_geometry_destroy(g);
}

/* Out of memory at each allocation in turn of a remesh on a model (the
 * classification held aside and derived again, the off-model marks, 3D:
 * the bisection first): an error with the mesh as given (its
 * classification too), or a result on the model; no leak. */
static void alloc_failures(int dim, int n, double h) {
  model md = {dim, -1, -1, 0};
  pa_geometry *g = NULL;
  pa_geometry_ops ops = {closest, curvature};
  CHECK_OK(pa_geometry_create(&ops, &md, 2.0, &g));
  pa_mesh *ref = model_mesh(dim, n);
  if (!ref || !g) return;
  size_t nv = (size_t)pa_mesh_nvert(ref);
  pa_remesh_opts o;
  pa_remesh_opts_default(&o);
  o.hsiz = h;
  o.geometry = g;
  int nok = 0, nbad = 0;
  long k;
  for (k = 1; k < 100000 && nok < 1; k++) {
    pa_mesh *w = NULL;
    CHECK_OK(pa_mesh_copy(ref, &w));
    if (!w) break;
    pa_memory_fail_after(k);
    pa_status st = pa_remesh(pa_remesher_builtin(), w, &o, NULL);
    pa_memory_fail_after(0);
    if (st == PA_SUCCESS) {
      int np;
      nok++;
      nbad += !pa_mesh_classified(w) || off_model(w, &np) > 1e-12 ||
              np != (dim == 2 ? 4 : 8);
    } else {
      nbad += st != PA_ERR_MEMORY || !pa_mesh_classified(w) ||
              pa_mesh_nvert(w) != pa_mesh_nvert(ref) ||
              memcmp(pa_mesh_vert_entity_dims(w), pa_mesh_vert_entity_dims(ref),
                     nv) ||
              memcmp(pa_mesh_vert_entity_tags(w), pa_mesh_vert_entity_tags(ref),
                     sizeof(int32_t) * nv);
    }
    pa_mesh_destroy(w);
  }
  printf("  %dD: out of memory at each of the first %ld allocations: %d "
         "wrong\n", dim, k - 2, nbad);
  CHECK(nok == 1 && nbad == 0);
  pa_mesh_destroy(ref);
  pa_geometry_destroy(g);
}

static void test_alloc_failures(void) {
  alloc_failures(2, 2, 0.3);
  alloc_failures(3, 2, 0.4);
}

/* Out of memory at each allocation in turn of classifying a mesh
 * (pa_mesh_set_vertex_entities: the entities completed and checked) and
 * copying it: an error with the mesh unclassified as given, or the copy
 * classified alike; no leak. */
static void test_alloc_classify(void) {
  pa_mesh *ref = model_mesh(3, 2), *plain = NULL;
  if (!ref) return;
  pa_idx nv = pa_mesh_nvert(ref);
  int *gd = malloc(sizeof *gd * (size_t)nv);
  int32_t *gt = malloc(sizeof *gt * (size_t)nv);
  for (pa_idx v = 0; v < nv; v++) {
    gd[v] = pa_mesh_vert_entity_dims(ref)[v];
    gt[v] = pa_mesh_vert_entity_tags(ref)[v];
  }
  CHECK_OK(pa_mesh_copy(ref, &plain));
  CHECK_OK(pa_mesh_set_vertex_entities(plain, NULL, NULL));
  int nok = 0, nbad = 0;
  long k;
  for (k = 1; k < 10000 && nok < 1 && plain; k++) {
    pa_mesh *w = NULL, *c = NULL;
    CHECK_OK(pa_mesh_copy(plain, &w));
    if (!w) break;
    pa_memory_fail_after(k);
    pa_status st = pa_mesh_set_vertex_entities(w, gd, gt), st2 = st;
    if (st == PA_SUCCESS) st2 = pa_mesh_copy(w, &c);
    pa_memory_fail_after(0);
    if (st2 == PA_SUCCESS) {
      nok++;
      nbad += !pa_mesh_classified(c) || pa_mesh_nedge(c) != pa_mesh_nedge(ref) ||
              memcmp(pa_mesh_vert_entity_tags(c), pa_mesh_vert_entity_tags(ref),
                     sizeof(int32_t) * (size_t)nv);
    } else {
      nbad += st2 != PA_ERR_MEMORY || c != NULL ||
              (st != PA_SUCCESS) == pa_mesh_classified(w);
    }
    pa_mesh_destroy(c);
    pa_mesh_destroy(w);
  }
  printf("  classify and copy: out of memory at each of the first %ld "
         "allocations: %d wrong\n", k - 2, nbad);
  CHECK(nok == 1 && nbad == 0);
  free(gd);
  free(gt);
  pa_mesh_destroy(plain);
  pa_mesh_destroy(ref);
}

/* Out of memory at each allocation in turn of loading a model through
 * Gmsh's library (its entities listed, the handle): an error and no
 * handle, Gmsh's model released (the next load works); no leak. */
static void test_alloc_model(void) {
  const char *why = NULL;
  if (!pa_geometry_available(&why)) { /* it says why */
    CHECK(why && strstr(why, "Gmsh") != NULL);
    printf("  no Gmsh library: the model load is not swept\n");
    return;
  }
  FILE *f = fopen("sweep.geo", "w");
  CHECK(f != NULL);
  if (!f) return;
  fputs("SetFactory(\"OpenCASCADE\");\nRectangle(1) = {0, 0, 0, 1, 1};\n"
        "Disk(2) = {0.5, 0.5, 0, 0.25};\n"
        "BooleanDifference{ Surface{1}; Delete; }{ Surface{2}; Delete; }\n",
        f);
  fclose(f);
  int nok = 0, nbad = 0;
  long k;
  for (k = 1; k < 1000 && nok < 1; k++) {
    pa_geometry *g = NULL;
    pa_memory_fail_after(k);
    pa_status st = pa_geometry_read("sweep.geo", &g);
    pa_memory_fail_after(0);
    if (st == PA_SUCCESS) {
      nok++;
      nbad += !g || !(fabs(pa_geometry_size(g) - sqrt(2.0)) < 1e-6);
    } else {
      nbad += st != PA_ERR_MEMORY || g != NULL;
    }
    pa_geometry_destroy(g);
  }
  printf("  model load: out of memory at each of the first %ld allocations: "
         "%d wrong\n", k - 2, nbad);
  CHECK(nok == 1 && nbad == 0 && k > 3);
  remove("sweep.geo");
}

TEST_MAIN(test_refine_2d, test_refine_3d, test_classification, test_fallback,
          test_errors, test_hausd, test_alloc_failures, test_alloc_classify,
          test_alloc_model)
