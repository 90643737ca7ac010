/*
 * test_harness.c -- the test harness itself (testutil.c): a test function
 * that makes no check fails the run, one that makes a passing check passes
 * it, one whose check fails fails it. Each case runs pa_test_run on a list
 * of its own, with the counters of this run saved around it.
 */
#include "testutil.h"

static void no_check(void) {}

static void passing_check(void) { CHECK(1 + 1 == 2); }

static void failing_check(void) { CHECK(1 + 1 == 3); }

/* pa_test_run's exit status and the failures it counted for one list, run
 * from counters at zero. */
static int run_inner(pa_test_fn fn, const char *name, int *failures) {
  int f0 = pa_test_failures, c0 = pa_test_checks;
  pa_test_failures = pa_test_checks = 0;
  pa_test_fn fns[] = {fn};
  int rc = pa_test_run("test_harness (inner run)", fns, &name, 1);
  *failures = pa_test_failures;
  pa_test_failures = f0;
  pa_test_checks = c0;
  return rc;
}

static void test_no_check_fails(void) {
  int failures = 0;
  int rc = run_inner(no_check, "no_check", &failures);
  CHECK(rc == 1);
  CHECK(failures == 1);
}

static void test_checks_count(void) {
  int failures = 0;
  CHECK(run_inner(passing_check, "passing_check", &failures) == 0);
  CHECK(failures == 0);
  CHECK(run_inner(failing_check, "failing_check", &failures) == 1);
  CHECK(failures == 1);
}

TEST_MAIN(test_no_check_fails, test_checks_count)
