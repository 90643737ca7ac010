/* test_core.c -- counting allocator, failure hook, error messages, mesh storage,
 * the sort of (key, index) records. */
#include "testutil.h"
#include "core/core.h"
#include "dmesh/util.h"

static void test_allocator(void) {
  size_t before = pa_memory_current();
  void *p = pa__malloc(1000);
  CHECK(p != NULL);
  CHECK(pa_memory_current() == before + 1000);
  CHECK(pa_memory_peak() >= before + 1000);
  p = pa__realloc(p, 4000);
  CHECK(pa_memory_current() == before + 4000);
  pa__free(p);
  CHECK(pa_memory_current() == before);
}

/* pa__sort_by_gid against a stable insertion sort: keys spanning little
 * more than their number (sorted by counting), with repeats, and keys
 * spread wide (radix sort). */
static void test_sort_by_gid(void) {
  size_t n = 5000;
  pa_gid *key = malloc(n * sizeof *key);
  pa_idx *idx = malloc(n * sizeof *idx), *ref = malloc(n * sizeof *ref);
  CHECK(key && idx && ref);
  if (!key || !idx || !ref) goto done;
  for (int kind = 0; kind < 3; kind++) {
    for (size_t i = 0; i < n; i++) {
      double r = pa_test_rand();
      key[i] = kind == 0   ? 1000 + (pa_gid)(r * 2 * (double)n)
               : kind == 1 ? (pa_gid)(r * 50) - 20
                           : (pa_gid)(r * 1e15);
      idx[i] = ref[i] = (pa_idx)(n - 1 - i);
    }
    for (size_t i = 1; i < n; i++) {
      pa_idx x = ref[i];
      size_t j = i;
      while (j > 0 && key[ref[j - 1]] > key[x]) {
        ref[j] = ref[j - 1];
        j--;
      }
      ref[j] = x;
    }
    CHECK_OK(pa__sort_by_gid(idx, n, key));
    size_t bad = 0;
    for (size_t i = 0; i < n; i++) bad += idx[i] != ref[i];
    CHECK(bad == 0);
  }
done:
  free(key);
  free(idx);
  free(ref);
}

static void test_fail_hook(void) {
  pa_memory_fail_after(2);
  void *a = pa__malloc(8), *b = pa__malloc(8), *c = pa__malloc(8);
  CHECK(a != NULL);
  CHECK(b == NULL);
  CHECK(c != NULL);
  pa__free(a);
  pa__free(c);
  /* A failing allocation inside a library call gives PA_ERR_MEMORY and no leak. */
  pa_mesh *m = NULL;
  pa_memory_fail_after(1);
  CHECK(pa_mesh_create(2, &m) == PA_ERR_MEMORY);
  CHECK(m == NULL);
  CHECK(strstr(pa_last_error(), "out of memory") != NULL);
  pa_memory_fail_after(0);
}

/* pa_memory_set_limit: an allocation past the bound fails, and the error
 * of the call that made it says the bound is reached. */
static void test_memory_bound(void) {
  size_t cur = pa_memory_current();
  CHECK(pa_memory_set_limit(cur + 1000) == 0);
  CHECK(pa_memory_limit() == cur + 1000);
  void *a = pa__malloc(600);
  CHECK(a != NULL);
  CHECK(pa__malloc(600) == NULL);
  CHECK(pa__realloc(a, 1200) == NULL); /* a kept as it was */
  void *b = pa__realloc(a, 900);
  CHECK(b != NULL);
  pa__free(b);
  CHECK(pa_memory_set_limit(0) == cur + 1000);
  pa_mesh *m = NULL;
  pa_idx v;
  double x[2] = {0, 0};
  CHECK_OK(pa_mesh_create(2, &m));
  pa_memory_set_limit(pa_memory_current() + 1000);
  pa_status st = PA_SUCCESS;
  for (int i = 0; i < 1000 && st == PA_SUCCESS; i++)
    st = pa_mesh_add_vertex(m, x, 0, &v);
  CHECK(st == PA_ERR_MEMORY);
  CHECK(strstr(pa_last_error(), "memory bound") != NULL);
  pa_mesh_destroy(m);
  pa_memory_set_limit(0);
  CHECK(pa_memory_current() == cur);
  pa_clear_error();
}

static void test_mesh_storage(void) {
  pa_mesh *m = NULL;
  CHECK(pa_mesh_create(4, &m) == PA_ERR_ARG);
  CHECK_OK(pa_mesh_create(2, &m));
  for (int i = 0; i < 100; i++) {
    double x[2] = {i, 2.0 * i};
    pa_idx k;
    CHECK_OK(pa_mesh_add_vertex(m, x, i % 3, &k));
    CHECK(k == i);
  }
  pa_idx t[3] = {0, 1, 2};
  CHECK_OK(pa_mesh_add_elem(m, t, 7, NULL));
  CHECK(pa_mesh_nvert(m) == 100);
  CHECK(pa_mesh_nelem(m) == 1);
  CHECK(pa_mesh_coords(m)[2 * 50 + 1] == 100.0);
  CHECK(pa_mesh_elem_refs(m)[0] == 7);
  CHECK(pa_mesh_add_edge(m, t, 0, NULL) == PA_ERR_ARG); /* 3D only */
  double *h = malloc(100 * sizeof *h);
  for (int i = 0; i < 100; i++) h[i] = 0.1;
  CHECK_OK(pa_mesh_set_metric(m, 1, h));
  CHECK(pa_mesh_set_metric(m, 2, h) == PA_ERR_ARG);
  double f[100];
  for (int i = 0; i < 100; i++) f[i] = i;
  CHECK_OK(pa_mesh_add_field(m, "u", 1, f));
  pa_mesh *c = NULL;
  CHECK_OK(pa_mesh_copy(m, &c));
  CHECK(pa_mesh_nvert(c) == 100 && pa_mesh_metric_ncomp(c) == 1);
  double *cv;
  CHECK_OK(pa_mesh_field(c, 0, NULL, NULL, &cv));
  CHECK(cv[42] == 42.0);
  CHECK(pa_mesh_memory_used(c) > 100 * (2 * sizeof(double)));
  pa_mesh_destroy(c);
  pa_mesh_destroy(m);
  free(h);
}

/* pa__key64_sort gives qsort's order (pa__key64_cmp) on records
 * given by increasing index: small and large counts, keys with many ties,
 * keys whose high digits are all equal, full 64-bit keys, all keys equal. */
static void test_sort_keys(void) {
  const size_t ns[] = {0, 1, 5, 63, 64, 65, 1000, 20000};
  const uint64_t ranges[] = {7, 1u << 20, 0, 1};
  pa_test_seed(38);
  for (size_t a = 0; a < sizeof ns / sizeof *ns; a++)
    for (size_t b = 0; b < sizeof ranges / sizeof *ranges; b++) {
      size_t n = ns[a];
      pa__key64 *k = malloc(sizeof *k * (n + 1)), *q = malloc(sizeof *q * (n + 1));
      for (size_t i = 0; i < n; i++) {
        uint64_t r = (uint64_t)(pa_test_rand() * 4294967296.0) << 32 |
                     (uint64_t)(pa_test_rand() * 4294967296.0);
        k[i].key = ranges[b] ? r % ranges[b] : r; /* 0: the full range */
        k[i].idx = (pa_idx)i;
      }
      memcpy(q, k, sizeof *k * n);
      qsort(q, n, sizeof *q, pa__key64_cmp);
      CHECK_OK(pa__key64_sort(k, n));
      int same = 1;
      for (size_t i = 0; i < n; i++)
        same &= k[i].key == q[i].key && k[i].idx == q[i].idx;
      if (!same) fprintf(stderr, "sort_keys: n %zu range %zu differs\n", n, b);
      CHECK(same);
      free(k);
      free(q);
    }
}

TEST_MAIN(test_allocator, test_sort_by_gid, test_fail_hook, test_memory_bound,
          test_mesh_storage, test_sort_keys)
