/* testutil.c -- see testutil.h. */
#include "testutil.h"

int pa_test_failures;
int pa_test_checks;
static unsigned long long pa_rng = 88172645463325252ull;

int pa_test_run(const char *name, const pa_test_fn *tests, const char **names,
                int n) {
  for (int i = 0; i < n; i++) {
    int before = pa_test_failures;
    tests[i]();
    if (pa_test_failures != before)
      fprintf(stderr, "%s: test %d of (%s) failed\n", name, i + 1, *names);
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
