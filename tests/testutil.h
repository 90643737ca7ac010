/*
 * testutil.h -- a minimal test harness: CHECK records a failure and goes on,
 * TEST_MAIN runs the listed test functions and returns non-zero if any check
 * failed or if a test function made no check at all (on any rank, for
 * TEST_MPI_MAIN): a test that checks nothing cannot fail, so it is refused.
 * Also small helpers shared by tests (seeded random numbers).
 */
#ifndef PA_TESTUTIL_H
#define PA_TESTUTIL_H

#include "padapt.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

extern int pa_test_failures;
extern int pa_test_checks;

#define CHECK(cond)                                                          \
  do {                                                                       \
    pa_test_checks++;                                                        \
    if (!(cond)) {                                                           \
      pa_test_failures++;                                                    \
      fprintf(stderr, "%s:%d: CHECK failed: %s\n", __FILE__, __LINE__,       \
              #cond);                                                        \
    }                                                                        \
  } while (0)

#define CHECK_NEAR(a, b, tol)                                                \
  do {                                                                       \
    double pa_a_ = (a), pa_b_ = (b);                                         \
    pa_test_checks++;                                                        \
    if (!(fabs(pa_a_ - pa_b_) <= (tol))) {                                   \
      pa_test_failures++;                                                    \
      fprintf(stderr, "%s:%d: CHECK_NEAR failed: %s = %.17g, %s = %.17g\n",  \
              __FILE__, __LINE__, #a, pa_a_, #b, pa_b_);                     \
    }                                                                        \
  } while (0)

/* Check a pa_status is PA_SUCCESS, printing pa_last_error() otherwise. */
#define CHECK_OK(expr)                                                       \
  do {                                                                       \
    pa_status pa_st_ = (expr);                                               \
    pa_test_checks++;                                                        \
    if (pa_st_ != PA_SUCCESS) {                                              \
      pa_test_failures++;                                                    \
      fprintf(stderr, "%s:%d: %s failed: %s: %s\n", __FILE__, __LINE__,      \
              #expr, pa_status_string(pa_st_), pa_last_error());             \
    }                                                                        \
  } while (0)

typedef void (*pa_test_fn)(void);
int pa_test_run(const char *name, const pa_test_fn *tests, const char **names,
                int n);

#define TEST_MAIN(...)                                                       \
  int main(void) {                                                           \
    pa_test_fn fns[] = {__VA_ARGS__};                                        \
    const char *names = #__VA_ARGS__;                                        \
    return pa_test_run(__FILE__, fns, &names, sizeof fns / sizeof *fns);     \
  }

/* MPI tests: MPI_Init_thread(MULTIPLE), pa_test_rank/pa_test_size set, each
 * test run in turn (timed on rank 0), padapt memory checked back to its start
 * on every rank, failures summed over the ranks; returns the exit status. */
extern int pa_test_rank, pa_test_size;
int pa_test_run_mpi(int argc, char **argv, const char *name,
                    const pa_test_fn *tests, const char *names, int n);

#define TEST_MPI_MAIN(...)                                                   \
  int main(int argc, char **argv) {                                          \
    pa_test_fn fns[] = {__VA_ARGS__};                                        \
    return pa_test_run_mpi(argc, argv, __FILE__, fns, #__VA_ARGS__,          \
                           (int)(sizeof fns / sizeof *fns));                 \
  }

/* Deterministic random numbers (xorshift64*), seeded per test. */
/* Number of "*.tmp.*" entries (output temporaries) in the working
 * directory, -1 if it cannot be read. */
int pa_test_ntemps(void);
void pa_test_seed(unsigned long long seed);
double pa_test_rand(void);              /* uniform in [0,1) */
double pa_test_rand_range(double lo, double hi);

#endif
