/*
 * output.h -- the output files of src/io/ and of every writer of padapt
 * (output.c): a temporary "<path>.tmp.<pid>" renamed onto path only after a
 * complete, successful write and, inside an output transaction
 * (pa_output_begin), only when every file of the transaction is complete;
 * so a failure never leaves a partial or truncated file, nor some outputs
 * of a command without the others. Also the checksum of the distributed
 * files and the extension of a path.
 */
#ifndef PA_IO_OUTPUT_H
#define PA_IO_OUTPUT_H

#include "mesh/mesh.h"

#include <signal.h>
#include <stdio.h>

/* A file being written. Zero-initialised, pa__out_abort does nothing. */
typedef struct pa__outfile {
  FILE *fp;
  char *path;    /* final path */
  char *tmppath; /* temporary path written first */
  int slot;      /* its place in the list the signal handler reads */
  int joined;    /* 1: part of an open transaction, renamed at its commit */
} pa__outfile;

/* Open a temporary file beside path for writing ("wb"). Refuses a path that
 * exists and is not a regular file, and a path already written in the open
 * transaction. */
pa_status pa__out_open(pa__outfile *out, const char *path);
/* Flush, fsync and close, checking every write error; then rename onto the
 * final path, or, inside a transaction, leave it for pa_output_commit. */
pa_status pa__out_commit(pa__outfile *out);
/* Close and remove the temporary file; inside a transaction, mark it failed
 * (safe to call after commit or twice). */
void pa__out_abort(pa__outfile *out);
/* Open for update ("r+b") the temporary of path, completed earlier in the
 * open transaction; end it with pa__out_commit or pa__out_abort again. */
pa_status pa__out_reopen(pa__outfile *out, const char *path);
/* Remove path (a regular file, or nothing) when the open transaction
 * commits. */
pa_status pa__out_remove(const char *path);
/* The temporary of path, completed in the open transaction, or NULL. */
const char *pa__out_tmppath(const char *path);
/* Open begins of the calling thread's output transaction (0: none). */
int pa__output_depth(void);
/* The signals of the collective end of a transaction (pa__output_end):
 * block SIGINT and SIGTERM in the calling thread (*old: the mask before);
 * whether one of them is pending (its number, 0 if none); restore *old,
 * with hold 1 first taking the pending ones, which pa_output_held_signal
 * then reports (the outputs were committed: the signal came too late to
 * stop them), with hold 0 letting them act. */
void pa__output_hold_begin(sigset_t *old);
int pa__output_signal_pending(void);
void pa__output_hold_end(const sigset_t *old, int hold);
/* Call the test hook of pa_output_set_hook, if any, at step. */
void pa__output_hook(const char *step);

/* FNV-1a 64 of n bytes, continuing from h (start with PA_IO_FNV1A64_INIT). */
#define PA_IO_FNV1A64_INIT 0xcbf29ce484222325ull
static inline uint64_t pa__fnv1a64(uint64_t h, const void *p, size_t n) {
  const unsigned char *b = p;
  for (size_t i = 0; i < n; i++) {
    h ^= b[i];
    h *= 0x100000001b3ull;
  }
  return h;
}
/* Size and FNV-1a 64 of the bytes of a file. */
pa_status pa__file_fnv1a64(const char *path, int64_t *bytes, uint64_t *hash);

/* Lower-case extension of path including the dot (".mesh"), "" if none. */
const char *pa__path_ext(const char *path, char *buf, size_t len);

#endif /* PA_IO_OUTPUT_H */
