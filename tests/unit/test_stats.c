/* test_stats.c -- pa_mesh_stats, its report and JSON, its bin bounds,
 * element quality and the analytic metric fields, against brute-force
 * computations written here independently (unique edges by pairwise search,
 * lengths and qualities by their formulas, bins by plain comparisons).
 * Meshes are built by hand. */
#include "metric/metric.h"
#include "testutil.h"

#include <unistd.h>

/* ---- hand-built meshes --------------------------------------------------- */

static double signed_volume(int dim, const double *c, const pa_idx *v) {
  const double *a = c + dim * v[0];
  double u[3][3];
  for (int i = 0; i < dim; i++)
    for (int k = 0; k < dim; k++)
      u[i][k] = c[dim * v[i + 1] + k] - a[k];
  if (dim == 2) return 0.5 * (u[0][0] * u[1][1] - u[0][1] * u[1][0]);
  return (u[0][0] * (u[1][1] * u[2][2] - u[1][2] * u[2][1]) -
          u[0][1] * (u[1][0] * u[2][2] - u[1][2] * u[2][0]) +
          u[0][2] * (u[1][0] * u[2][1] - u[1][1] * u[2][0])) /
         6.0;
}

/* Add every face that belongs to exactly one element as a boundary entity,
 * oriented outward (brute force over face pairs: for small meshes). */
static void add_boundary_brute(pa_mesh *m) {
  int dim = pa_mesh_dim(m), nve = dim + 1;
  pa_idx ne = pa_mesh_nelem(m);
  const pa_idx *el = pa_mesh_elems(m);
  const double *c = pa_mesh_coords(m);
  int nf = ne * nve;
  pa_idx(*key)[3] = malloc(sizeof *key * nf);
  for (int f = 0; f < nf; f++) {
    int e = f / nve, i = f % nve, n = 0;
    for (int k = 0; k < nve; k++)
      if (k != i) key[f][n++] = el[nve * e + k];
    for (int a = 0; a < dim; a++) /* sort */
      for (int b = a + 1; b < dim; b++)
        if (key[f][b] < key[f][a]) {
          pa_idx t = key[f][a];
          key[f][a] = key[f][b];
          key[f][b] = t;
        }
  }
  for (int f = 0; f < nf; f++) {
    int count = 0;
    for (int g = 0; g < nf; g++)
      if (!memcmp(key[f], key[g], dim * sizeof(pa_idx))) count++;
    if (count != 1) continue;
    /* outward: the face plus the opposite vertex has negative volume */
    pa_idx v[4];
    memcpy(v, key[f], dim * sizeof(pa_idx));
    v[dim] = el[nve * (f / nve) + f % nve];
    if (signed_volume(dim, c, v) > 0) {
      pa_idx t = v[0];
      v[0] = v[1];
      v[1] = t;
    }
    CHECK_OK(pa_mesh_add_bdry(m, v, 1, NULL));
  }
  free(key);
}

/* n x n squares of two triangles, interior vertices jittered by up to
 * jitter/n. */
static pa_mesh *square_mesh(int n, double jitter) {
  pa_mesh *m = NULL;
  CHECK_OK(pa_mesh_create(2, &m));
  for (int j = 0; j <= n; j++)
    for (int i = 0; i <= n; i++) {
      double x[2] = {(double)i / n, (double)j / n};
      if (i > 0 && i < n && j > 0 && j < n) {
        x[0] += jitter / n * pa_test_rand_range(-1, 1);
        x[1] += jitter / n * pa_test_rand_range(-1, 1);
      }
      CHECK_OK(pa_mesh_add_vertex(m, x, 0, NULL));
    }
  for (int j = 0; j < n; j++)
    for (int i = 0; i < n; i++) {
      pa_idx a = j * (n + 1) + i, b = a + 1, c = b + n + 1, d = a + n + 1;
      pa_idx t1[3] = {a, b, c}, t2[3] = {a, c, d};
      CHECK_OK(pa_mesh_add_elem(m, t1, 1, NULL));
      CHECK_OK(pa_mesh_add_elem(m, t2, 1, NULL));
    }
  return m;
}

/* Unit cube, n^3 cubes of 6 tetrahedra around the (0,0,0)-(1,1,1) diagonal
 * (Kuhn), all positively oriented. */
static pa_mesh *cube_mesh(int n, double jitter) {
  pa_mesh *m = NULL;
  CHECK_OK(pa_mesh_create(3, &m));
  CHECK_OK(
      pa_mesh_reserve(m, (n + 1) * (n + 1) * (n + 1), 6 * n * n * n, 0, 0));
  for (int k = 0; k <= n; k++)
    for (int j = 0; j <= n; j++)
      for (int i = 0; i <= n; i++) {
        double x[3] = {(double)i / n, (double)j / n, (double)k / n};
        if (i > 0 && i < n && j > 0 && j < n && k > 0 && k < n)
          for (int c = 0; c < 3; c++)
            x[c] += jitter / n * pa_test_rand_range(-1, 1);
        CHECK_OK(pa_mesh_add_vertex(m, x, 0, NULL));
      }
  static const int perm[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2},
                                 {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  const int stride[3] = {1, n + 1, (n + 1) * (n + 1)};
  for (int k = 0; k < n; k++)
    for (int j = 0; j < n; j++)
      for (int i = 0; i < n; i++)
        for (int p = 0; p < 6; p++) {
          pa_idx v[4];
          v[0] = k * stride[2] + j * stride[1] + i;
          for (int s = 0; s < 3; s++)
            v[s + 1] = v[s] + stride[perm[p][s]];
          /* odd permutations are negatively oriented */
          if (p == 1 || p == 2 || p == 5) {
            pa_idx t = v[2];
            v[2] = v[3];
            v[3] = t;
          }
          CHECK_OK(pa_mesh_add_elem(m, v, 1, NULL));
        }
  return m;
}

/* ---- brute-force statistics --------------------------------------------- */

static const double bounds[8] = {0.3, 0.6, 0.7071, 0.9, 1.3, 1.4142, 2, 5};

/* sqrt(e^T M e) with M given as ncomp 0/1/tensor, written independently. */
static double metric_norm(int dim, int nc, const double *m, const double *e) {
  double s = 0;
  if (nc <= 1) {
    for (int k = 0; k < dim; k++)
      s += e[k] * e[k];
    return nc ? sqrt(s) / m[0] : sqrt(s);
  }
  double full[3][3];
  if (dim == 2) {
    double f[3][3] = {{m[0], m[1], 0}, {m[1], m[2], 0}, {0, 0, 0}};
    memcpy(full, f, sizeof f);
  } else {
    double f[3][3] = {
        {m[0], m[1], m[3]}, {m[1], m[2], m[4]}, {m[3], m[4], m[5]}};
    memcpy(full, f, sizeof f);
  }
  for (int i = 0; i < dim; i++)
    for (int j = 0; j < dim; j++)
      s += e[i] * full[i][j] * e[j];
  return sqrt(s);
}

static double ref_length(int dim, int nc, const double *a, const double *b,
                         const double *ma, const double *mb) {
  double e[3];
  for (int k = 0; k < dim; k++)
    e[k] = b[k] - a[k];
  double la = metric_norm(dim, nc, ma, e), lb = metric_norm(dim, nc, mb, e);
  if (fabs(la - lb) < 1e-3 * fmax(la, lb)) return 0.5 * (la + lb);
  return (la - lb) / log(la / lb);
}

static double ref_quality(int dim, int nc, const double *c, const double *met,
                          const pa_idx *v) {
  int nt = dim == 2 ? 3 : 6;
  double mean[6] = {0};
  if (nc > 1)
    for (int i = 0; i <= dim; i++)
      for (int k = 0; k < nt; k++)
        mean[k] += met[nc * v[i] + k] / (dim + 1);
  double s = 0;
  for (int i = 0; i <= dim; i++)
    for (int j = i + 1; j <= dim; j++) {
      double e[3];
      for (int k = 0; k < dim; k++)
        e[k] = c[dim * v[j] + k] - c[dim * v[i] + k];
      double l = metric_norm(dim, nc > 1 ? nc : 0, mean, e);
      s += l * l;
    }
  double det = 1;
  if (nc > 1) {
    if (dim == 2)
      det = mean[0] * mean[2] - mean[1] * mean[1];
    else
      det = mean[0] * (mean[2] * mean[5] - mean[4] * mean[4]) -
            mean[1] * (mean[1] * mean[5] - mean[4] * mean[3]) +
            mean[3] * (mean[1] * mean[4] - mean[2] * mean[3]);
  }
  double vol = signed_volume(dim, c, v) * sqrt(det);
  return dim == 2 ? 4 * sqrt(3) * vol / s : 72 * sqrt(3) * vol / pow(s, 1.5);
}

/* Compare pa_mesh_stats with brute force on a small mesh. */
static void check_stats_brute(pa_mesh *m, int expect_valid) {
  pa_stats s;
  CHECK_OK(pa_mesh_stats(m, &s));
  int dim = pa_mesh_dim(m), nve = dim + 1, nc = pa_mesh_metric_ncomp(m);
  pa_idx nv = pa_mesh_nvert(m), ne = pa_mesh_nelem(m);
  const pa_idx *el = pa_mesh_elems(m);
  const double *c = pa_mesh_coords(m), *met = pa_mesh_metric(m);
  CHECK(s.dim == dim && s.nvert == nv && s.nelem == ne &&
        s.nbdry == pa_mesh_nbdry(m) && s.has_metric == (nc > 0));
  /* unique edges by pairwise search */
  int cap = 6 * ne, n = 0;
  pa_idx(*edges)[2] = malloc(sizeof *edges * (cap + 1));
  double vol = 0;
  long inverted = 0;
  for (int e = 0; e < ne; e++) {
    const pa_idx *v = el + nve * e;
    double ve = signed_volume(dim, c, v);
    vol += ve;
    inverted += ve <= 0;
    for (int i = 0; i < nve; i++)
      for (int j = i + 1; j < nve; j++) {
        pa_idx a = v[i] < v[j] ? v[i] : v[j], b = v[i] < v[j] ? v[j] : v[i];
        int found = 0;
        for (int k = 0; k < n && !found; k++)
          found = edges[k][0] == a && edges[k][1] == b;
        if (!found) edges[n][0] = a, edges[n][1] = b, n++;
      }
  }
  CHECK(s.nedge == n);
  CHECK_NEAR(s.volume, vol, 1e-12 * fabs(vol) + 1e-15);
  CHECK(s.ninverted == inverted);
  long hist[10] = {0};
  double lmin = INFINITY, lmax = -INFINITY, lsum = 0;
  for (int k = 0; k < n; k++) {
    const double *ma = met ? met + nc * edges[k][0] : NULL;
    const double *mb = met ? met + nc * edges[k][1] : NULL;
    double l = ref_length(dim, nc, c + dim * edges[k][0], c + dim * edges[k][1],
                          ma, mb);
    lmin = fmin(lmin, l);
    lmax = fmax(lmax, l);
    lsum += l;
    int b = 0;
    while (b < 8 && l >= bounds[b])
      b++;
    hist[b]++;
    if (l >= 0.7071 && l < 1.4142) hist[9]++;
  }
  CHECK_NEAR(s.edge_min, lmin, 1e-12 * lmin);
  CHECK_NEAR(s.edge_max, lmax, 1e-12 * lmax);
  CHECK_NEAR(s.edge_sum, lsum, 1e-12 * lsum);
  for (int b = 0; b < 10; b++)
    CHECK(s.edge_hist[b] == hist[b]);
  long qhist[5] = {0}, q05 = 0, q012 = 0;
  double qmin = INFINITY, qmax = -INFINITY, qsum = 0;
  for (int e = 0; e < ne; e++) {
    double q = ref_quality(dim, nc, c, met, el + nve * e);
    CHECK_NEAR(pa_mesh_elem_quality(m, e), q, 1e-12);
    qmin = fmin(qmin, q);
    qmax = fmax(qmax, q);
    qsum += q;
    int b = q < 0.2 ? 0 : q < 0.4 ? 1 : q < 0.6 ? 2 : q < 0.8 ? 3 : 4;
    qhist[b]++;
    q05 += q > 0.5;
    q012 += q > 0.12;
  }
  CHECK_NEAR(s.qual_min, qmin, 1e-12);
  CHECK_NEAR(s.qual_max, qmax, 1e-12);
  CHECK_NEAR(s.qual_sum, qsum, 1e-12 * ne);
  for (int b = 0; b < 5; b++)
    CHECK(s.qual_hist[b] == qhist[b]);
  CHECK(s.qual_above_05 == q05 && s.qual_above_012 == q012);
  CHECK(s.valid == expect_valid);
  CHECK(pa_last_error()[0] == '\0' || s.valid); /* check's error cleared */
  free(edges);
}

/* ---- tests --------------------------------------------------------------- */

static void test_stats_2d(void) {
  pa_test_seed(11);
  /* 2 x 2 squares: 9 vertices, 8 triangles, 16 edges */
  pa_mesh *m = square_mesh(2, 0.0);
  add_boundary_brute(m);
  CHECK(pa_mesh_nbdry(m) == 8);
  pa_stats s;
  CHECK_OK(pa_mesh_stats(m, &s));
  CHECK(s.nedge == 16);
  CHECK(s.has_metric == 0);
  /* identity metric: 12 edges of 0.5 and 4 diagonals of 0.7071067...;
   * hand-computed bins: 0.5 in [0.3,0.6), the diagonals in [0.7071,0.9) */
  CHECK(s.edge_hist[1] == 12 && s.edge_hist[3] == 4 && s.edge_hist[9] == 4);
  CHECK_NEAR(s.edge_min, 0.5, 1e-15);
  CHECK_NEAR(s.edge_max, sqrt(0.5), 1e-15);
  /* right isosceles triangles: Q = 4 sqrt(3) (1/2) / (1 + 1 + 2) */
  CHECK_NEAR(s.qual_min, sqrt(3) / 2, 1e-14);
  CHECK_NEAR(s.qual_sum / 8, sqrt(3) / 2, 1e-14);
  CHECK(s.qual_hist[4] == 8 && s.qual_above_05 == 8);
  CHECK_NEAR(s.volume, 1.0, 1e-14);
  check_stats_brute(m, 1);
  /* isotropic sizes varying in space */
  double h[9];
  for (int i = 0; i < 9; i++)
    h[i] = 0.3 + 0.4 * pa_mesh_coords(m)[2 * i] * pa_mesh_coords(m)[2 * i + 1];
  CHECK_OK(pa_mesh_set_metric(m, 1, h));
  check_stats_brute(m, 1);
  pa_mesh_destroy(m);

  /* jittered 6 x 6, with tensor and size fields */
  m = square_mesh(6, 0.3);
  add_boundary_brute(m);
  check_stats_brute(m, 1);
  const char *specs[] = {"uniform:0.2", "layer", "shell:0.3", "iso-shell:0.5"};
  for (int k = 0; k < 4; k++) {
    CHECK_OK(pa_metric_analytic(m, specs[k]));
    check_stats_brute(m, 1);
  }
  /* an inverted element: counted, negative quality in the first bin,
   * invalid mesh */
  pa_idx *el = pa_mesh_elems(m);
  pa_idx t = el[0];
  el[0] = el[1];
  el[1] = t;
  check_stats_brute(m, 0);
  CHECK_OK(pa_mesh_stats(m, &s));
  CHECK(s.ninverted == 1 && s.qual_min < 0 && s.valid == 0);
  long sum = 0;
  for (int b = 0; b < PA_STATS_QUAL_NBIN; b++)
    sum += s.qual_hist[b];
  CHECK(sum == s.nelem);
  pa_mesh_destroy(m);
}

static void test_stats_3d(void) {
  pa_test_seed(12);
  pa_mesh *m = cube_mesh(2, 0.0);
  add_boundary_brute(m);
  CHECK(pa_mesh_nbdry(m) == 6 * 2 * 4);
  pa_stats s;
  CHECK_OK(pa_mesh_stats(m, &s));
  /* 3n(n+1)^2 axis edges + 3n^2(n+1) face diagonals + n^3 body diagonals */
  CHECK(s.nedge == 54 + 36 + 8);
  CHECK(s.ninverted == 0);
  CHECK_NEAR(s.volume, 1.0, 1e-14);
  check_stats_brute(m, 1);
  pa_mesh_destroy(m);

  m = cube_mesh(3, 0.25);
  add_boundary_brute(m);
  check_stats_brute(m, 1);
  const char *specs[] = {"uniform:0.2", "layer:0.5", "shell", "iso-shell"};
  for (int k = 0; k < 4; k++) {
    CHECK_OK(pa_metric_analytic(m, specs[k]));
    check_stats_brute(m, 1);
  }
  pa_mesh_destroy(m);
}

/* A bigger cube: edge count against the closed formula, timing. */
static void test_stats_big(void) {
  int n = 30;
  pa_mesh *m = cube_mesh(n, 0.0);
  CHECK_OK(pa_metric_analytic(m, "shell"));
  pa_stats s;
  double t0 = pa_wtime();
  CHECK_OK(pa_mesh_stats(m, &s));
  double t = pa_wtime() - t0;
  long ne = 6L * n * n * n;
  CHECK(s.nelem == ne);
  CHECK(s.nedge ==
        3L * n * (n + 1) * (n + 1) + 3L * n * n * (n + 1) + (long)n * n * n);
  CHECK_NEAR(s.volume, 1.0, 1e-13);
  CHECK(s.volume == pa_mesh_volume(m));
  CHECK(s.ninverted == 0);
  long sum = 0;
  for (int b = 0; b < PA_STATS_EDGE_NBIN - 1; b++)
    sum += s.edge_hist[b];
  CHECK(sum == s.nedge);
  printf("pa_mesh_stats: %ld tetrahedra, %lld edges in %.3f s\n", ne,
         (long long)s.nedge, t);
  pa_mesh_destroy(m);
}

static void test_stats_errors(void) {
  pa_mesh *m = square_mesh(1, 0);
  pa_stats s;
  CHECK(pa_mesh_stats(NULL, &s) == PA_ERR_ARG);
  pa_mesh_elems(m)[4] = 7; /* element 2, vertex index out of range */
  CHECK(pa_mesh_stats(m, &s) == PA_ERR_MESH);
  CHECK(strstr(pa_last_error(), "element 2") != NULL);
  pa_mesh_elems(m)[4] = 3;
  /* allocation failures propagate, without leaks */
  for (int k = 1; k <= 3; k++) {
    pa_memory_fail_after(k);
    CHECK(pa_mesh_stats(m, &s) == PA_ERR_MEMORY);
    pa_memory_fail_after(0);
  }
  /* empty mesh */
  pa_mesh *e = NULL;
  CHECK_OK(pa_mesh_create(3, &e));
  CHECK_OK(pa_mesh_stats(e, &s));
  CHECK(s.nedge == 0 && s.nelem == 0 && s.edge_min == 0 && s.qual_min == 0);
  pa_mesh_destroy(e);
  pa_mesh_destroy(m);
}

/* The check levels of pa__mesh_stats_met: a folded mesh (a vertex the
 * elements around turn twice) is valid to the output check of the built-in
 * remesher, which leaves the input-only parts out, and not to the full
 * one. */
static void test_stats_check_levels(void) {
  const char *dir = getenv("PADAPT_TESTDATA");
  char path[1024];
  pa_mesh *m = NULL;
  pa_stats s;
  CHECK(dir != NULL);
  if (!dir) return;
  snprintf(path, sizeof path, "%s/bad/check_fold_vertex2d.mesh", dir);
  CHECK_OK(pa_mesh_read(path, &m));
  if (!m) return;
  pa_idx nb = 0;
  CHECK_OK(pa_mesh_build_boundary(m, 1, &nb)); /* as the CLI completes it */
  CHECK_OK(pa__mesh_stats_met(m, 0, NULL, PA_STATS_CHECK_FULL, &s));
  CHECK(!s.valid);
  CHECK_OK(pa__mesh_stats_met(m, 0, NULL, PA_STATS_CHECK_OUTPUT, &s));
  CHECK(s.valid);
  CHECK_OK(pa__mesh_stats_met(m, 0, NULL, PA_STATS_CHECK_NONE, &s));
  CHECK(s.valid);
  pa_mesh_destroy(m);
}

static char *slurp(const char *path) {
  FILE *f = fopen(path, "rb");
  if (!f) return NULL;
  static char buf[8192];
  size_t n = fread(buf, 1, sizeof buf - 1, f);
  buf[n] = '\0';
  fclose(f);
  return buf;
}

static void test_report_json(void) {
  pa_test_seed(13);
  pa_mesh *m = square_mesh(4, 0.2);
  add_boundary_brute(m);
  CHECK_OK(pa_metric_analytic(m, "shell"));
  pa_stats s;
  CHECK_OK(pa_mesh_stats(m, &s));
  CHECK_OK(pa_stats_write_json(&s, "\"time_s\": 1.5", "stats_test.json"));
  char *j = slurp("stats_test.json");
  CHECK(j != NULL);
  if (j) {
    const char *keys[] = {"dim",
                          "vertices",
                          "elements",
                          "boundary",
                          "volume",
                          "inverted",
                          "valid",
                          "edge_min",
                          "edge_max",
                          "edge_mean",
                          "edge_in_range",
                          "quality_worst",
                          "quality_mean",
                          "quality_best",
                          "quality_above_0.5",
                          "quality_above_0.12",
                          "edges",
                          "edge_hist",
                          "quality_hist",
                          "has_metric",
                          "time_s"};
    for (size_t k = 0; k < sizeof keys / sizeof *keys; k++) {
      char q[64];
      snprintf(q, sizeof q, "\"%s\":", keys[k]);
      CHECK(strstr(j, q) != NULL);
    }
    char want[64];
    snprintf(want, sizeof want, "\"edges\": %lld,", (long long)s.nedge);
    CHECK(strstr(j, want) != NULL);
    CHECK(strstr(j, "\"has_metric\": true") != NULL);
    /* edge_min round-trips exactly */
    const char *p = strstr(j, "\"edge_min\": ");
    CHECK(p && strtod(p + 12, NULL) == s.edge_min);
    CHECK(strstr(j, "\"time_s\": 1.5\n}") != NULL);
  }
  char tmp[64];
  snprintf(tmp, sizeof tmp, "stats_test.json.tmp.%ld", (long)getpid());
  CHECK(access(tmp, F_OK) != 0);
  CHECK(pa_stats_write_json(&s, NULL, "no/such/dir/x.json") == PA_ERR_IO);
  remove("stats_test.json");
  FILE *f = tmpfile();
  pa_stats_print(&s, f);
  rewind(f);
  char buf[8192];
  size_t n = fread(buf, 1, sizeof buf - 1, f);
  buf[n] = '\0';
  fclose(f);
  CHECK(strstr(buf, "0.7071 <= L < 1.4142") != NULL);
  CHECK(strstr(buf, "valid") != NULL);
  pa_mesh_destroy(m);
}

static void test_analytic(void) {
  pa_test_seed(14);
  const char *const *names = pa_metric_analytic_names();
  int count = 0;
  while (names[count])
    count++;
  CHECK(count == 7);
  for (int dim = 2; dim <= 3; dim++) {
    int nt = dim == 2 ? 3 : 6;
    pa_mesh *m = NULL;
    CHECK_OK(pa_mesh_create(dim, &m));
    /* special points first: centre, on the plane, on the shell, far */
    double pts[5][3] = {{0.5, 0.5, 0.5},
                        {0.5, 0.2, 0.7},
                        {0.8, 0.5, 0.5},
                        {0.9, 0.1, 0.3},
                        {0.5, 0.5 + 0.3 / sqrt(2), 0.5}};
    if (dim == 3) pts[4][2] = 0.5 + 0.3 / sqrt(2);
    for (int i = 0; i < 5; i++)
      CHECK_OK(pa_mesh_add_vertex(m, pts[i], 0, NULL));
    for (int i = 0; i < 300; i++) {
      double x[3] = {pa_test_rand(), pa_test_rand(), pa_test_rand()};
      CHECK_OK(pa_mesh_add_vertex(m, x, 0, NULL));
    }
    for (int k = 0; k < count; k++) {
      for (int withh = 0; withh < 2; withh++) {
        char spec[64];
        double h = withh ? 0.05 : 0.1;
        snprintf(spec, sizeof spec, withh ? "%s:0.05" : "%s", names[k]);
        CHECK_OK(pa_metric_analytic(m, spec));
        int nc = pa_mesh_metric_ncomp(m);
        int iso =
            !strcmp(names[k], "uniform") || !strcmp(names[k], "iso-shell");
        CHECK(nc == (iso ? 1 : nt));
        const double *met = pa_mesh_metric(m);
        for (pa_idx i = 0; i < pa_mesh_nvert(m); i++)
          CHECK(pa__metric_valid(dim, nc, met + nc * i));
          /* size along unit vector u at vertex i: 1 / sqrt(u^T M u) */
#define SIZE_AT(i, u)                                                          \
  (1.0 / sqrt(pa__metric_sqlen(dim, nc, met + nc * (i), (u))))
        double ex[3] = {1, 0, 0}, ey[3] = {0, 1, 0}, ez[3] = {0, 0, 1};
        double *en = dim == 2 ? ey : ez; /* normal direction at point 4 */
        if (!strcmp(names[k], "uniform")) {
          CHECK_NEAR(met[0], h, 1e-15);
          CHECK_NEAR(met[7], h, 1e-15);
        } else if (!strcmp(names[k], "layer")) {
          CHECK_NEAR(SIZE_AT(1, ex), h / 100, 1e-12 * h); /* on the plane */
          CHECK_NEAR(SIZE_AT(1, ey), h, 1e-12 * h);
          CHECK_NEAR(SIZE_AT(2, ex), h, 1e-12 * h); /* distance 0.3 */
          CHECK_NEAR(SIZE_AT(0, ex), h / 100, 1e-12 * h);
          /* distance 0.125: halfway up the linear ramp */
        } else if (!strcmp(names[k], "shell")) {
          CHECK_NEAR(SIZE_AT(0, ex), h, 1e-12 * h); /* centre */
          CHECK_NEAR(SIZE_AT(0, ey), h, 1e-12 * h);
          CHECK_NEAR(SIZE_AT(2, ex), h / 50, 1e-9 * h); /* on the shell */
          CHECK_NEAR(SIZE_AT(2, ey), h, 1e-9 * h);
          double nd[3] = {0, 1 / sqrt(2), 1 / sqrt(2)};
          double td[3] = {0, 1 / sqrt(2), -1 / sqrt(2)};
          if (dim == 2) nd[0] = 0, nd[1] = 1, td[0] = 1, td[1] = 0;
          (void)en;
          if (dim == 3) {
            CHECK_NEAR(SIZE_AT(4, nd), h / 50, 1e-9 * h);
            CHECK_NEAR(SIZE_AT(4, td), h, 1e-9 * h);
            CHECK_NEAR(SIZE_AT(4, ex), h, 1e-9 * h);
          } else {
            /* point 4 = (0.5, 0.712): distance 0.0879 to the shell */
            double d = fabs(0.3 / sqrt(2) - 0.3);
            double hn = h / 50 + (h - h / 50) * d / 0.2;
            CHECK_NEAR(SIZE_AT(4, ey), hn, 1e-9 * h);
            CHECK_NEAR(SIZE_AT(4, ex), h, 1e-9 * h);
          }
        } else if (!strncmp(names[k], "ugawg-", 6)) {
          /* the published formulas, at every vertex, along the radial,
           * tangential and axial directions (UGAWG benchmark paper) */
          double h0 = h / 100;
          for (pa_idx i = 0; i < pa_mesh_nvert(m); i++) {
            const double *x = pa_mesh_coords(m) + dim * i;
            if (!strcmp(names[k], "ugawg-linear")) {
              double hl = h0 + 2 * (h - h0) * fabs(x[dim - 1] - 0.5);
              CHECK_NEAR(SIZE_AT(i, en), hl, 1e-12 * h);
              CHECK_NEAR(SIZE_AT(i, ex), h, 1e-12 * h);
              continue;
            }
            double r = hypot(x[0], x[1]);
            double ur[3] = {x[0] / r, x[1] / r, 0}, ut[3] = {-ur[1], ur[0], 0};
            double hr = h0 + 2 * (h - h0) * fabs(r - 0.5), ht = h;
            if (!strcmp(names[k], "ugawg-polar2")) {
              double d0 = fmin(10 * fabs(r - 0.5), 1);
              ht = h * d0 + h / 4 * (1 - d0);
            }
            CHECK_NEAR(SIZE_AT(i, ur), hr, 1e-9 * hr);
            CHECK_NEAR(SIZE_AT(i, ut), ht, 1e-9 * ht);
            if (dim == 3) CHECK_NEAR(SIZE_AT(i, ez), h, 1e-9 * h);
          }
        } else { /* iso-shell */
          CHECK_NEAR(met[0], h, 1e-15);
          CHECK_NEAR(met[2], h / 10, 1e-12 * h);
          double r = dim == 2 ? hypot(0.4, 0.4) : sqrt(0.16 + 0.16 + 0.04);
          double d = fmin(fabs(r - 0.3), 0.2);
          CHECK_NEAR(met[3], h / 10 + (h - h / 10) * d / 0.2, 1e-12 * h);
        }
#undef SIZE_AT
      }
    }
    /* a layer point halfway up the ramp: x = 0.625 */
    double mid[3] = {0.625, 0.3, 0.3};
    CHECK_OK(pa_mesh_add_vertex(m, mid, 0, NULL));
    CHECK_OK(pa_metric_analytic(m, "layer:0.2"));
    const double *met = pa_mesh_metric(m);
    pa_idx last = pa_mesh_nvert(m) - 1;
    CHECK_NEAR(1 / sqrt(met[nt * last]), 0.002 + (0.2 - 0.002) * 0.5, 1e-12);
    /* errors */
    const char *bad[] = {
        "foo",        "",           "uniformx",    "uniform:",
        "uniform:0",  "uniform:-1", "uniform:abc", "uniform:1e999",
        "shell:0.1x", "layer:nan",  "Shell",       ":0.1"};
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
      CHECK(pa_metric_analytic(m, bad[i]) == PA_ERR_ARG);
      CHECK(strlen(pa_last_error()) > 0);
    }
    CHECK(pa_metric_analytic(m, "bogus") == PA_ERR_ARG);
    CHECK(strstr(pa_last_error(), "bogus") &&
          strstr(pa_last_error(), "uniform") &&
          strstr(pa_last_error(), "iso-shell"));
    CHECK(pa_metric_analytic(m, NULL) == PA_ERR_ARG);
    CHECK(pa_mesh_metric_ncomp(m) == nt); /* unchanged by the failures */
    pa_mesh_destroy(m);
  }
}

/* pa_stats_edge_bin / pa_stats_qual_bin: the bounds the counting uses
 * (bounds[] here), contiguous from 0 to inf, and the in-range band. */
static void test_bins(void) {
  double lo, hi, prev = 0;
  for (int b = 0; b < PA_STATS_EDGE_NBIN - 1; b++) {
    CHECK_OK(pa_stats_edge_bin(b, &lo, &hi));
    CHECK(lo == prev && lo < hi);
    CHECK(b < 8 ? hi == bounds[b] : isinf(hi));
    prev = hi;
  }
  CHECK_OK(pa_stats_edge_bin(PA_STATS_EDGE_NBIN - 1, &lo, &hi));
  CHECK(lo == 0.7071 && hi == 1.4142);
  prev = 0;
  for (int b = 0; b < PA_STATS_QUAL_NBIN; b++) {
    CHECK_OK(pa_stats_qual_bin(b, &lo, &hi));
    CHECK_NEAR(lo, prev, 1e-15);
    CHECK_NEAR(hi, 0.2 * (b + 1), 1e-15);
    prev = hi;
  }
  CHECK(prev == 1.0);
  CHECK(pa_stats_edge_bin(-1, &lo, &hi) == PA_ERR_ARG);
  CHECK(pa_stats_edge_bin(PA_STATS_EDGE_NBIN, &lo, &hi) == PA_ERR_ARG);
  CHECK(pa_stats_edge_bin(0, NULL, &hi) == PA_ERR_ARG);
  CHECK(pa_stats_qual_bin(PA_STATS_QUAL_NBIN, &lo, &hi) == PA_ERR_ARG);
  CHECK(pa_stats_qual_bin(0, &lo, NULL) == PA_ERR_ARG);
  pa_clear_error();
}

TEST_MAIN(test_stats_2d, test_stats_3d, test_stats_big, test_stats_errors,
          test_stats_check_levels,
          test_report_json, test_analytic, test_bins)
