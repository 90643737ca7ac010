/* testutil.c -- see testutil.h. */
#include "testutil.h"

#include <dirent.h>

#include <mpi.h>

int pa_test_failures;
int pa_test_checks;
static unsigned long long pa_rng = 88172645463325252ull;

/* The name of test i in names, TEST_MAIN's list "test_a, test_b, ...", into
 * buf (at most n bytes). */
static const char *test_name(const char *names, int i, char *buf, size_t n) {
  const char *p = names;
  for (int k = 0; k < i && p; k++) {
    p = strchr(p, ',');
    if (p) p++;
  }
  if (!p) return "?";
  p += strspn(p, " \t\n");
  size_t len = strcspn(p, ", \t\n");
  snprintf(buf, n, "%.*s", (int)(len < n ? len : n - 1), p);
  return buf;
}

int pa_test_run(const char *name, const pa_test_fn *tests, const char **names,
                int n) {
  char tn[128];
  for (int i = 0; i < n; i++) {
    int before = pa_test_failures, checks = pa_test_checks;
    tests[i]();
    if (pa_test_checks == checks) { /* a test that checks nothing passes nothing */
      fprintf(stderr, "%s: %s made no check\n", name,
              test_name(*names, i, tn, sizeof tn));
      pa_test_failures++;
    }
    if (pa_test_failures != before)
      fprintf(stderr, "%s: test %d (%s) failed\n", name, i + 1,
              test_name(*names, i, tn, sizeof tn));
  }
  size_t leaked = pa_memory_current();
  if (leaked) {
    fprintf(stderr, "%s: %zu bytes still allocated by padapt at exit\n", name,
            leaked);
    pa_test_failures++;
  }
  printf("%s: %d checks, %d failed\n", name, pa_test_checks, pa_test_failures);
  return pa_test_failures ? 1 : 0;
}

void pa_test_seed(unsigned long long seed) {
  pa_rng = seed ? seed : 88172645463325252ull;
}

double pa_test_rand(void) {
  pa_rng ^= pa_rng >> 12;
  pa_rng ^= pa_rng << 25;
  pa_rng ^= pa_rng >> 27;
  return (double)((pa_rng * 2685821657736338717ull) >> 11) * 0x1.0p-53;
}

double pa_test_rand_range(double lo, double hi) {
  return lo + (hi - lo) * pa_test_rand();
}

int pa_test_rank, pa_test_size = 1;

int pa_test_run_mpi(int argc, char **argv, const char *name,
                    const pa_test_fn *tests, const char *names, int n) {
  int provided;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_MULTIPLE, &provided);
  MPI_Comm_rank(MPI_COMM_WORLD, &pa_test_rank);
  MPI_Comm_size(MPI_COMM_WORLD, &pa_test_size);
  if (getenv("PA_TEST_VERBOSE")) pa_set_verbosity(atoi(getenv("PA_TEST_VERBOSE")));
  size_t mem0 = pa_memory_current();
  char tn[128];
  for (int i = 0; i < n; i++) {
    int before = pa_test_failures, checks = pa_test_checks;
    double t0 = MPI_Wtime();
    tests[i]();
    /* a test may check on some ranks only (the root of a gather), but on
     * one at least */
    int made = pa_test_checks - checks;
    MPI_Allreduce(MPI_IN_PLACE, &made, 1, MPI_INT, MPI_SUM, MPI_COMM_WORLD);
    if (made == 0) {
      if (pa_test_rank == 0)
        fprintf(stderr, "%s: %s made no check\n", name,
                test_name(names, i, tn, sizeof tn));
      pa_test_failures++;
    }
    if (pa_test_failures != before)
      fprintf(stderr, "%s: rank %d: test %d (%s) failed\n", name,
              pa_test_rank, i + 1, test_name(names, i, tn, sizeof tn));
    if (pa_test_rank == 0)
      printf("%s: test %d done in %.2f s\n", name, i + 1, MPI_Wtime() - t0);
  }
  if (pa_memory_current() != mem0) {
    fprintf(stderr, "%s: rank %d: %zu bytes of padapt memory leaked\n", name,
            pa_test_rank, pa_memory_current() - mem0);
    pa_test_failures++;
  }
  int fails = pa_test_failures;
  MPI_Allreduce(MPI_IN_PLACE, &fails, 1, MPI_INT, MPI_SUM, MPI_COMM_WORLD);
  if (pa_test_rank == 0)
    printf("%s: %d ranks, %d checks on rank 0, %d failed\n", name,
           pa_test_size, pa_test_checks, fails);
  MPI_Finalize();
  return fails ? 1 : 0;
}

int pa_test_ntemps(void) {
  DIR *d = opendir(".");
  struct dirent *e;
  int n = 0;
  if (!d) return -1;
  while ((e = readdir(d)))
    if (strstr(e->d_name, ".tmp.")) n++;
  closedir(d);
  return n;
}
