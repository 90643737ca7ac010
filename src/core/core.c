/*
 * core.c -- error messages, the counting allocator, verbosity, timing.
 *
 * The last error message is thread-local, so threads (MPI_THREAD_MULTIPLE)
 * never see each other's errors. The allocator prefixes every block with a
 * 16-byte header holding the size asked for and the block's capacity;
 * counters are C11 atomics and count the sizes asked for. Freed large blocks
 * are kept in a small bounded cache for the next allocations they fit.
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

void pa_clear_error(void) { last_msg[0] = '\0'; }

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
  va_start(ap, fmt);
  vsnprintf(last_msg, sizeof last_msg, fmt, ap);
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

static void count_add(size_t n) {
  size_t cur = atomic_fetch_add(&mem_cur, n) + n;
  size_t peak = atomic_load(&mem_peak);
  while (cur > peak && !atomic_compare_exchange_weak(&mem_peak, &peak, cur))
    ;
  size_t win = atomic_load(&mem_window);
  while (cur > win && !atomic_compare_exchange_weak(&mem_window, &win, cur))
    ;
}

/* Freed blocks of at least CACHE_MIN_BYTES are kept, up to CACHE_SLOTS
 * blocks and CACHE_MAX_BYTES in all, and handed out again to the next
 * allocations they fit (the smallest that does): a fresh page costs a page
 * fault on first touch (20-35 us on a virtual machine), and malloc gives
 * large freed blocks back to the system, so without the cache every phase
 * of a small adaptation touches fresh pages again (box3d 10 -> 0.05 on 2
 * ranks: 640 fewer faults on rank 0). The bound keeps the resident memory
 * it holds small beside a large run's; no cache under AddressSanitizer,
 * whose freed blocks must stay poisoned. */
#define CACHE_MIN_BYTES ((size_t)64 << 10)
#define CACHE_MAX_BYTES ((size_t)32 << 20)
#define CACHE_SLOTS 32
#if defined(__SANITIZE_ADDRESS__)
#define CACHE_ON 0
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define CACHE_ON 0
#endif
#endif
#ifndef CACHE_ON
#define CACHE_ON 1
#endif

static struct {
  atomic_flag lock;
  char *blk[CACHE_SLOTS]; /* block bases, NULL when the slot is free */
  size_t cap[CACHE_SLOTS];
  size_t bytes;
} cache = {ATOMIC_FLAG_INIT, {0}, {0}, 0};

static void cache_lock(void) {
  while (atomic_flag_test_and_set_explicit(&cache.lock, memory_order_acquire))
    ;
}
static void cache_unlock(void) {
  atomic_flag_clear_explicit(&cache.lock, memory_order_release);
}

/* A cached block of at least n bytes (the smallest), removed from the
 * cache, its capacity in *cap; NULL if none. */
static char *cache_take(size_t n, size_t *cap) {
  char *b = NULL;
  if (!CACHE_ON || n < CACHE_MIN_BYTES) return NULL;
  cache_lock();
  int best = -1;
  for (int k = 0; k < CACHE_SLOTS; k++)
    if (cache.blk[k] && cache.cap[k] >= n &&
        (best < 0 || cache.cap[k] < cache.cap[best]))
      best = k;
  if (best >= 0) {
    b = cache.blk[best];
    *cap = cache.cap[best];
    cache.blk[best] = NULL;
    cache.bytes -= *cap;
  }
  cache_unlock();
  return b;
}

/* Keep block b of capacity cap in the cache; 1 if kept. */
static int cache_put(char *b, size_t cap) {
  int kept = 0;
  if (!CACHE_ON || cap < CACHE_MIN_BYTES || cap > CACHE_MAX_BYTES) return 0;
  cache_lock();
  int slot = -1;
  for (int k = 0; k < CACHE_SLOTS && slot < 0; k++)
    if (!cache.blk[k]) slot = k;
  if (slot >= 0 && cache.bytes + cap <= CACHE_MAX_BYTES) {
    cache.blk[slot] = b;
    cache.cap[slot] = cap;
    cache.bytes += cap;
    kept = 1;
  }
  cache_unlock();
  return kept;
}

/* The header: the size asked for, then the capacity of the block. */
static void *finish_block(char *p, size_t size, size_t cap) {
  memcpy(p, &size, sizeof size);
  memcpy(p + sizeof size, &cap, sizeof cap);
  count_add(size);
  return p + HDR_BYTES;
}

void *pa__malloc(size_t size) {
  if (should_fail()) return NULL;
  size_t cap = size + HDR_BYTES;
  char *p = cache_take(cap, &cap);
  if (!p) p = malloc(cap);
  if (!p) return NULL;
  return finish_block(p, size, cap);
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
  size_t old, cap, need = size + HDR_BYTES;
  memcpy(&old, base, sizeof old);
  memcpy(&cap, base + sizeof old, sizeof cap);
  atomic_fetch_sub(&mem_cur, old);
  if (need <= cap && need >= cap / 2) return finish_block(base, size, cap);
  size_t ncap = need;
  char *p = need > cap ? cache_take(need, &ncap) : NULL;
  if (p) {
    memcpy(p + HDR_BYTES, ptr, old);
    if (!cache_put(base, cap)) free(base);
  } else {
    p = realloc(base, need);
    if (!p) {
      atomic_fetch_add(&mem_cur, old);
      return NULL;
    }
    ncap = need;
  }
  return finish_block(p, size, ncap);
}

void pa__free(void *ptr) {
  if (!ptr) return;
  char *base = (char *)ptr - HDR_BYTES;
  size_t old, cap;
  memcpy(&old, base, sizeof old);
  memcpy(&cap, base + sizeof old, sizeof cap);
  atomic_fetch_sub(&mem_cur, old);
  if (!cache_put(base, cap)) free(base);
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

int pa__key64_cmp(const void *a, const void *b) {
  const pa__key64 *p = a, *q = b;
  if (p->key != q->key) return p->key < q->key ? -1 : 1;
  return (p->idx > q->idx) - (p->idx < q->idx);
}
