/*
 * core.h -- internal services shared by every component: error reporting,
 * the counting allocator, small utilities.
 *
 * Error handling pattern (one cleanup label per function):
 *
 *   pa_status st = PA_SUCCESS;
 *   PA_CHECK(n > 0, PA_ERR_ARG, "n must be positive, got %d", n);
 *   PA_CALL(pa_mesh_build_adjacency(mesh, &adja));
 *   PA_ALLOC(buf, n);
 * cleanup:
 *   pa__free(buf);
 *   return st;
 *
 * PA_CHECK and PA_CALL are always on; PA_ASSERT checks internal invariants and
 * compiles to nothing in release builds (NDEBUG).
 */
#ifndef PA_CORE_H
#define PA_CORE_H

#include "padapt.h"

#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* Record an error message "msg" for the calling thread and return code. */
pa_status pa__error(pa_status code, const char *file, int line,
                    const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));
/* Append a propagation frame ("  from file:line") to the error message in
 * debug builds; returns code unchanged. */
pa_status pa__error_trace(pa_status code, const char *file, int line);

/* Raise an error and jump to cleanup (needs a local `pa_status st`). */
#define PA_FAIL(code, ...)                                                   \
  do {                                                                       \
    st = pa__error((code), __FILE__, __LINE__, __VA_ARGS__);                 \
    goto cleanup;                                                            \
  } while (0)

/* Check a condition on caller input or data read; always on. */
#define PA_CHECK(cond, code, ...)                                            \
  do {                                                                       \
    if (!(cond)) PA_FAIL((code), __VA_ARGS__);                               \
  } while (0)

/* Call a function returning pa_status and propagate its failure. */
#define PA_CALL(expr)                                                        \
  do {                                                                       \
    st = (expr);                                                             \
    if (st != PA_SUCCESS) {                                                  \
      st = pa__error_trace(st, __FILE__, __LINE__);                          \
      goto cleanup;                                                          \
    }                                                                        \
  } while (0)

/* Call an MPI function: a return other than MPI_SUCCESS becomes PA_ERR_MPI
 * naming the function and MPI's message, and jumps to cleanup (needs a
 * local `pa_status st`), as PETSc's PetscCallMPI. MPI returns an error only
 * where the communicator's error handler is MPI_ERRORS_RETURN (the
 * communicators padapt duplicates keep the caller's handler); under the
 * default MPI_ERRORS_ARE_FATAL it ends the job itself. */
#define PA_CALL_MPI(call)                                                    \
  do {                                                                       \
    int pa_mpierr_ = (call);                                                 \
    if (pa_mpierr_ != MPI_SUCCESS) {                                         \
      st = pa__mpi_error(pa_mpierr_, #call, __FILE__, __LINE__);             \
      goto cleanup;                                                          \
    }                                                                        \
  } while (0)
/* Record "MPI_Xxx failed: <MPI's message>" for the MPI error code err of
 * the call whose source text is call (the function's name is taken from
 * it); returns PA_ERR_MPI. */
pa_status pa__mpi_error(int err, const char *call, const char *file,
                        int line);

/* Internal invariant, debug builds only. */
#ifdef NDEBUG
#define PA_ASSERT(cond) ((void)0)
#else
#define PA_ASSERT(cond)                                                      \
  do {                                                                       \
    if (!(cond)) pa__assert_fail(#cond, __FILE__, __LINE__);                 \
  } while (0)
#endif
void pa__assert_fail(const char *expr, const char *file, int line);

/* Counting allocator. Every allocation of the library goes through these, so
 * that pa_memory_current()/pa_memory_peak() are exact and the test hook
 * pa_memory_fail_after() can make any allocation fail. pa__free(NULL) is a
 * no-op; pa__realloc(NULL, n) allocates. Sizes in bytes. */
void *pa__malloc(size_t size);
void *pa__calloc(size_t nmemb, size_t size);
void *pa__realloc(void *ptr, size_t size);
void pa__free(void *ptr);
/* Size in bytes of a block returned by the allocator (0 for NULL). */
size_t pa__alloc_size(const void *ptr);

/* Allocate n elements of *ptr's type or fail with PA_ERR_MEMORY. */
#define PA_ALLOC(ptr, n)                                                     \
  do {                                                                       \
    size_t pa_n_ = (size_t)(n);                                              \
    (ptr) = pa__malloc((pa_n_ ? pa_n_ : 1) * sizeof(*(ptr)));                \
    if (!(ptr))                                                              \
      PA_FAIL(PA_ERR_MEMORY, "out of memory allocating %zu bytes",           \
              pa_n_ * sizeof(*(ptr)));                                       \
  } while (0)
#define PA_CALLOC(ptr, n)                                                    \
  do {                                                                       \
    size_t pa_n_ = (size_t)(n);                                              \
    (ptr) = pa__calloc(pa_n_ ? pa_n_ : 1, sizeof(*(ptr)));                   \
    if (!(ptr))                                                              \
      PA_FAIL(PA_ERR_MEMORY, "out of memory allocating %zu bytes",           \
              pa_n_ * sizeof(*(ptr)));                                       \
  } while (0)
/* Grow an array to hold at least `need` elements (factor 1.5 growth). */
#define PA_GROW(ptr, cap, need)                                              \
  do {                                                                       \
    if ((size_t)(need) > (size_t)(cap)) {                                    \
      size_t pa_nc_ = (size_t)(cap) + (size_t)(cap) / 2 + 16;                \
      if (pa_nc_ < (size_t)(need)) pa_nc_ = (size_t)(need);                  \
      void *pa_np_ = pa__realloc((ptr), pa_nc_ * sizeof(*(ptr)));            \
      if (!pa_np_)                                                           \
        PA_FAIL(PA_ERR_MEMORY, "out of memory growing an array to %zu",      \
                pa_nc_);                                                     \
      (ptr) = pa_np_;                                                        \
      (cap) = pa_nc_;                                                        \
    }                                                                        \
  } while (0)

/* Verbose message on stderr when pa_verbosity() >= level. */
void pa__info(int level, const char *fmt, ...)
    __attribute__((format(printf, 2, 3)));

/* Sort n pa_idx keys ascending (insertion sort, for tiny arrays). */
static inline void pa__sort_small(pa_idx *a, int n) {
  for (int i = 1; i < n; i++) {
    pa_idx x = a[i];
    int j = i - 1;
    while (j >= 0 && a[j] > x) {
      a[j + 1] = a[j];
      j--;
    }
    a[j + 1] = x;
  }
}

/* A 64-bit sort key and the index it belongs to; pa__key64_cmp (for qsort)
 * orders by key, then index: the remeshers' spatial (Morton) orders. */
typedef struct pa__key64 {
  uint64_t key;
  pa_idx idx;
} pa__key64;
int pa__key64_cmp(const void *a, const void *b);
/* Sort the n records a[] in place by key, records of equal keys in their
 * given order (keysort.c): given by increasing index, they come out as qsort
 * with pa__key64_cmp puts them. PA_ERR_MEMORY. Not collective. */
pa_status pa__key64_sort(pa__key64 *a, size_t n);

/* 64-bit mix of a value (splitmix64 finaliser). */
static inline uint64_t pa__mix64(uint64_t x) {
  x ^= x >> 30;
  x *= 0xBF58476D1CE4E5B9ull;
  x ^= x >> 27;
  x *= 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

/* Hash of a small sorted key of pa_idx. */
static inline uint64_t pa__hash_idx(const pa_idx *k, int n) {
  uint64_t h = 0x9E3779B97F4A7C15ull;
  for (int i = 0; i < n; i++) {
    h ^= (uint64_t)(uint32_t)k[i] + 0x9E3779B97F4A7C15ull + (h << 6) + (h >> 2);
    h *= 0xBF58476D1CE4E5B9ull;
  }
  return h ^ (h >> 31);
}

/* Neumaier's compensated sum: a total that does not drift with the count.
 * Add with pa__ksum_add, read s + c. */
typedef struct pa__ksum {
  double s, c;
} pa__ksum;

static inline void pa__ksum_add(pa__ksum *k, double x) {
  double t = k->s + x;
  k->c += fabs(k->s) >= fabs(x) ? (k->s - t) + x : (x - t) + k->s;
  k->s = t;
}

/* CPU seconds the calling thread has used (CLOCK_THREAD_CPUTIME_ID; 0 if
 * the clock is unavailable): the work of a step, which unlike wall-clock
 * time does not grow when more ranks than cores share the machine. */
double pa__thread_cputime(void);

/* Bytes of memory this process may still use: MemAvailable of
 * /proc/meminfo, lowered to a cgroup v2 limit; 0 if unknown. */
size_t pa__mem_available(void);

/* A second high-water mark of the counting allocator, for the figures of
 * one step: pa__memory_window_begin sets it to the current bytes, and
 * pa__memory_window_peak returns the largest count since (process-wide, as
 * pa_memory_peak, which it leaves alone). */
void pa__memory_window_begin(void);
size_t pa__memory_window_peak(void);

/* 1 if the last error raised in this thread (pa__error) is an allocation
 * the memory bound refused (pa_memory_set_limit): a hard error, which
 * rolling back and trying again would only meet again. */
int pa__memory_bound_error(void);

/* ---- agreement of collective routines (agree.c) ---- */

/* Collective: combine the local status st of every rank. Returns PA_SUCCESS if
 * every rank succeeded; otherwise, on every rank, the status of the lowest
 * failing rank, whose error message is copied to every rank (prefixed with
 * "rank R: " on the others). */
pa_status pa__agree(MPI_Comm comm, pa_status st);
/* Collective end of a collective routine: agree on st unless st is an error
 * that was already agreed on by every rank (returned by pa__agree). */
pa_status pa__agree_end(MPI_Comm comm, pa_status st);
/* Forget any earlier agreed failure: public collective functions call it on
 * entry, so that a failure of an earlier call is never taken as agreed. */
void pa__agree_reset(void);

#endif /* PA_CORE_H */
