/*
 * progress.c -- the live progress line of long CLI runs on stderr.
 *
 * Nothing is printed during the first PA_CLI_PROGRESS_QUIET_S seconds (short
 * runs stay quiet; the environment variable PADAPT_PROGRESS_AFTER=S changes
 * it, e.g. 0 in the tests). On a terminal one line rewrites itself (at most every
 * 0.2 s); into a file or a pipe, plain lines, at most one per second (each
 * iteration of the parallel loop gets its line). The estimate of the time
 * left extrapolates the elapsed time over the share of the way done: the
 * share of elements that meet their target (parallel iterations) or of
 * edges in range (a remesher's passes, measured on a sample), or else the
 * share of the way from the initial element count to the count the metric
 * asks for; it is shown while that share is between 5 % and 100 %.
 */
#include "cli.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define PA_CLI_PROGRESS_QUIET_S 2.0

void pa_cli_progress_init(pa_cli_progress *pr, int enabled) {
  memset(pr, 0, sizeof *pr);
  pr->enabled = enabled;
  pr->tty = isatty(STDERR_FILENO);
  pr->last = -1;
  pr->after = PA_CLI_PROGRESS_QUIET_S;
  const char *e = getenv("PADAPT_PROGRESS_AFTER");
  double x;
  if (e && pa_cli_parse_num(e, &x) && x >= 0) pr->after = x;
}

/* 1.23 M, 45.6 k or 789 */
static void count(char *buf, size_t n, double x) {
  if (x >= 1e6)
    snprintf(buf, n, "%.2f M", x / 1e6);
  else if (x >= 1e4)
    snprintf(buf, n, "%.1f k", x / 1e3);
  else
    snprintf(buf, n, "%.0f", x);
}

void pa_cli_progress_cb(const pa_progress *p, void *ctx) {
  pa_cli_progress *pr = ctx;
  int iteration = !strcmp(p->stage, "iteration");
  if (!pr->enabled || p->elapsed < pr->after) return;
  double gap = pr->tty ? 0.2 : iteration ? 0 : 1.0;
  if (pr->last >= 0 && p->elapsed - pr->last < gap) return;
  pr->last = p->elapsed;
  char now[32], want[32], line[256];
  count(now, sizeof now, p->nelem);
  int k = snprintf(line, sizeof line, "padapt: %s %d: %s elements", p->stage,
                   p->step, now);
  if (p->nelem_expected > 0) {
    count(want, sizeof want, p->nelem_expected);
    k += snprintf(line + k, sizeof line - (size_t)k, " (metric: ~%s)", want);
  }
  if (p->done >= 0) /* iterations: elements meeting their criterion */
    k += snprintf(line + k, sizeof line - (size_t)k, ", %.1f %% %s",
                  100 * p->done, iteration ? "done" : "of edges in range");
  k += snprintf(line + k, sizeof line - (size_t)k, ", %.1f s", p->elapsed);
  /* the share of the way: measured (done) when known, else by elements */
  double f = p->done, way = p->nelem_expected - p->nelem_initial;
  if (f < 0 && p->nelem_expected > 0 && fabs(way) > 0.05 * p->nelem_expected)
    f = (p->nelem - p->nelem_initial) / way;
  if (f > 0.05 && f < 1) {
    double left = p->elapsed * (1 - f) / f;
    snprintf(line + k, sizeof line - (size_t)k, ", ~%.*f s left",
             left < 10 ? 1 : 0, left);
  }
  if (pr->tty)
    fprintf(stderr, "\r%s\033[K", line);
  else
    fprintf(stderr, "%s\n", line);
  fflush(stderr);
  pr->printed = 1;
}

void pa_cli_progress_end(pa_cli_progress *pr) {
  if (pr->enabled && pr->tty && pr->printed) fputc('\n', stderr);
  pr->printed = 0;
}
