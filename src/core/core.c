/*
 * core.c -- error messages, the counting allocator, verbosity, timing.
 *
 * The last error message is thread-local, so threads (MPI_THREAD_MULTIPLE)
 * never see each other's errors. The allocator prefixes every block with a
 * 16-byte header holding its size; counters are C11 atomics.
 */
#include "core/core.h"

#include <stdatomic.h>
#include <stdio.h>
#include <sys/resource.h>
#include <time.h>

#define MSG_LEN 1024

static _Thread_local char last_msg[MSG_LEN];
static atomic_size_t mem_cur;
static atomic_size_t mem_peak;
static atomic_size_t mem_window; /* peak since pa__memory_window_begin */
static atomic_long fail_countdown;
static atomic_size_t mem_limit; /* pa_memory_set_limit; 0: none */
/* The last allocation the bound refused in this thread: the bytes held and
 * the bytes asked for more (0: none since the last pa_clear_error). */
static _Thread_local size_t bound_held, bound_asked;
static _Thread_local int bound_error; /* the last error is the bound's */
static int verbose;

const char *pa_status_string(pa_status status) {
  switch (status) {
  case PA_SUCCESS: return "success";
  case PA_ERR_ARG: return "invalid argument";
  case PA_ERR_MEMORY: return "out of memory";
  case PA_ERR_IO: return "i/o error";
  case PA_ERR_FORMAT: return "format error";
  case PA_ERR_MESH: return "invalid mesh";
  case PA_ERR_METRIC: return "invalid metric";
  case PA_ERR_MPI: return "MPI error";
  case PA_ERR_PARTITION: return "partitioner error";
  case PA_ERR_UNSUPPORTED: return "unsupported";
  case PA_ERR_INTERNAL: return "internal error";
  }
  return "unknown status";
}

const char *pa_last_error(void) { return last_msg; }

void pa_clear_error(void) {
  last_msg[0] = '\0';
  bound_asked = 0;
  bound_error = 0;
}

pa_status pa_set_error(pa_status status, const char *fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(last_msg, sizeof last_msg, fmt ? fmt : "", ap);
  va_end(ap);
  return status;
}

pa_status pa__error(pa_status code, const char *file, int line,
                    const char *fmt, ...) {
  va_list ap;
  int n = 0;
  /* an allocation the bound refused: say so first */
  if (code == PA_ERR_MEMORY && bound_asked)
    n = snprintf(last_msg, sizeof last_msg,
                 "the memory bound of %.1f MB is reached (padapt holds "
                 "%.1f MB and asked for %.1f MB more): ",
                 (double)atomic_load(&mem_limit) / 1e6, (double)bound_held / 1e6,
                 (double)bound_asked / 1e6);
  if (n < 0 || (size_t)n >= sizeof last_msg) n = 0;
  bound_error = code == PA_ERR_MEMORY && bound_asked;
  bound_asked = 0;
  va_start(ap, fmt);
  vsnprintf(last_msg + n, sizeof last_msg - (size_t)n, fmt, ap);
  va_end(ap);
  if (verbose >= 3)
    fprintf(stderr, "padapt: error raised at %s:%d: %s\n", file, line,
            last_msg);
  return code;
}

pa_status pa__error_trace(pa_status code, const char *file, int line) {
  if (verbose >= 3)
    fprintf(stderr, "padapt:   propagated from %s:%d\n", file, line);
  return code;
}

void pa__assert_fail(const char *expr, const char *file, int line) {
  /* An internal invariant is broken: this is a bug in padapt, and continuing
   * would corrupt data. Debug builds only. */
  fprintf(stderr, "padapt: assertion failed at %s:%d: %s\n", file, line, expr);
  fflush(stderr);
  __builtin_trap();
}

/* ---- counting allocator ---- */

#define HDR_BYTES 16

static int should_fail(void) {
  long c = atomic_load(&fail_countdown);
  while (c > 0) {
    if (atomic_compare_exchange_weak(&fail_countdown, &c, c - 1))
      return c == 1;
  }
  return 0;
}

/* 1 if adding n bytes to those held would pass the bound (and note it for
 * the error message). */
static int over_bound(size_t n) {
  size_t lim = atomic_load(&mem_limit);
  if (!lim) return 0;
  size_t cur = atomic_load(&mem_cur);
  if (n <= lim && cur <= lim - n) return 0;
  bound_held = cur;
  bound_asked = n;
  return 1;
}

static void count_add(size_t n) {
  size_t cur = atomic_fetch_add(&mem_cur, n) + n;
  size_t peak = atomic_load(&mem_peak);
  while (cur > peak && !atomic_compare_exchange_weak(&mem_peak, &peak, cur))
    ;
  size_t win = atomic_load(&mem_window);
  while (cur > win && !atomic_compare_exchange_weak(&mem_window, &win, cur))
    ;
}

void *pa__malloc(size_t size) {
  if (should_fail() || over_bound(size)) return NULL;
  char *p = malloc(size + HDR_BYTES);
  if (!p) return NULL;
  if (bound_asked) bound_asked = 0; /* a refusal the caller got over */
  memcpy(p, &size, sizeof size);
  count_add(size);
  return p + HDR_BYTES;
}

void *pa__calloc(size_t nmemb, size_t size) {
  if (size && nmemb > SIZE_MAX / size - HDR_BYTES) return NULL;
  size_t n = nmemb * size;
  void *p = pa__malloc(n);
  if (p) memset(p, 0, n);
  return p;
}

void *pa__realloc(void *ptr, size_t size) {
  if (!ptr) return pa__malloc(size);
  if (should_fail()) return NULL;
  char *base = (char *)ptr - HDR_BYTES;
  size_t old;
  memcpy(&old, base, sizeof old);
  if (size > old && over_bound(size - old)) return NULL;
  char *p = realloc(base, size + HDR_BYTES);
  if (!p) return NULL;
  memcpy(p, &size, sizeof size);
  atomic_fetch_sub(&mem_cur, old);
  count_add(size);
  return p + HDR_BYTES;
}

void pa__free(void *ptr) {
  if (!ptr) return;
  char *base = (char *)ptr - HDR_BYTES;
  size_t old;
  memcpy(&old, base, sizeof old);
  atomic_fetch_sub(&mem_cur, old);
  free(base);
}

size_t pa__alloc_size(const void *ptr) {
  if (!ptr) return 0;
  size_t n;
  memcpy(&n, (const char *)ptr - HDR_BYTES, sizeof n);
  return n;
}

size_t pa_memory_current(void) { return atomic_load(&mem_cur); }
size_t pa_memory_peak(void) { return atomic_load(&mem_peak); }
void pa_memory_reset_peak(void) {
  atomic_store(&mem_peak, atomic_load(&mem_cur));
}
void pa__memory_window_begin(void) {
  atomic_store(&mem_window, atomic_load(&mem_cur));
}
size_t pa__memory_window_peak(void) { return atomic_load(&mem_window); }
size_t pa_memory_set_limit(size_t bytes) {
  return atomic_exchange(&mem_limit, bytes);
}
size_t pa_memory_limit(void) { return atomic_load(&mem_limit); }
int pa__memory_bound_error(void) { return bound_error; }
void pa_memory_fail_after(long n) {
  atomic_store(&fail_countdown, n > 0 ? n : 0);
}

size_t pa_peak_rss(void) {
  struct rusage ru;
  if (getrusage(RUSAGE_SELF, &ru) != 0) return 0;
  return (size_t)ru.ru_maxrss * 1024; /* Linux reports KiB */
}

/* A number in a one-line file such as /sys/fs/cgroup/memory.max (0 if
 * absent or not a number, e.g. "max"). */
static double file_number(const char *path) {
  FILE *f = fopen(path, "r");
  double x = 0;
  if (!f) return 0;
  if (fscanf(f, "%lf", &x) != 1) x = 0;
  fclose(f);
  return x;
}

size_t pa__mem_available(void) {
  double avail = 0;
  FILE *f = fopen("/proc/meminfo", "r");
  if (f) {
    char line[256];
    while (fgets(line, sizeof line, f)) {
      double kb;
      if (sscanf(line, "MemAvailable: %lf kB", &kb) == 1) {
        avail = kb * 1024;
        break;
      }
    }
    fclose(f);
  }
  /* a container's limit (cgroup v2) counts too */
  double lim = file_number("/sys/fs/cgroup/memory.max");
  double cur = file_number("/sys/fs/cgroup/memory.current");
  if (lim > 0 && (avail <= 0 || lim - cur < avail))
    avail = lim > cur ? lim - cur : 0;
  return avail > 0 ? (size_t)avail : 0;
}

/* ---- verbosity and time ---- */

#define STR_(x) #x
#define STR(x) STR_(x)
const char *pa_version(void) {
  return STR(PADAPT_VERSION_MAJOR) "." STR(PADAPT_VERSION_MINOR) "."
      STR(PADAPT_VERSION_PATCH);
}

void pa_set_verbosity(int level) { verbose = level; }
int pa_verbosity(void) { return verbose; }

void pa__info(int level, const char *fmt, ...) {
  if (verbose < level) return;
  va_list ap;
  va_start(ap, fmt);
  vfprintf(stderr, fmt, ap);
  va_end(ap);
}

double pa_wtime(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

double pa__thread_cputime(void) {
  struct timespec ts;
  if (clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts) != 0) return 0;
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

int pa__key64_cmp(const void *a, const void *b) {
  const pa__key64 *p = a, *q = b;
  if (p->key != q->key) return p->key < q->key ? -1 : 1;
  return (p->idx > q->idx) - (p->idx < q->idx);
}
