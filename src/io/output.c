/*
 * output.c -- output transactions: the one way padapt writes a file.
 *
 * Every writer opens its file with pa__out_open, which creates a temporary
 * "PATH.tmp.PID" in PATH's directory, and ends it with pa__out_commit (flush,
 * fsync, close, every error checked) or pa__out_abort. Outside a transaction
 * a completed file is renamed onto PATH at once. Inside one (pa_output_begin,
 * per thread; a nested begin joins the open transaction and only the
 * outermost end acts) completed files wait as temporaries, and
 * pa_output_commit renames them all, in the order they were completed, then
 * removes the paths registered with pa__out_remove; pa_output_abort removes
 * every temporary instead. pa__out_reopen lets a writer append to a file it
 * completed earlier in the same transaction (the distributed writer adds its
 * keywords after the Medit part). pa_output_file_open/_commit/_abort give
 * the same to a caller writing a file of its own (the CLI's pictures).
 *
 * Invariants:
 *  - a path is only ever replaced by a complete file: renames happen after
 *    the temporary was flushed, synced and closed without error, and only
 *    when no file of the transaction failed (a failed or aborted file marks
 *    its transaction failed; committing it then removes everything);
 *  - SIGINT and SIGTERM are blocked in the committing thread during the
 *    renames, so those signals never stop a commit half-way; the collective
 *    end (pa__output_end, src/dmesh/dio.c) blocks them from its last
 *    agreement on and holds what arrived meanwhile (pa__output_hold_end,
 *    pa_output_held_signal): once every rank agreed to commit, every rank
 *    commits;
 *  - every temporary that may exist is listed in `temps` (listed before it
 *    is created, unlisted once renamed or removed): the handler of
 *    pa_output_handle_signals unlinks them with async-signal-safe calls only;
 *  - an existing output path that is not a regular file (a directory, a
 *    symbolic link, a device, a FIFO) is never written nor removed.
 */
#include "io/output.h"

#include <ctype.h>
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdio.h>
#include <sys/stat.h>
#include <unistd.h>

/* Temporaries that may exist, process-wide (a signal is handled by whichever
 * thread receives it). Fixed so that the handler reads it without locks; a
 * command writes a handful of files, a rank of a distributed writer four. */
#define MAX_TEMPS 256
static _Atomic(char *) temps[MAX_TEMPS];

/* A file of a transaction: a completed temporary waiting for its rename, or
 * (tmppath NULL) a path to remove at commit. */
typedef struct out_entry {
  char *path, *tmppath;
  int slot; /* index in temps, -1 if none */
} out_entry;

struct pa_output {
  int depth; /* open begins; 0: no transaction */
  out_entry *file;
  int nfile, cap;
  pa_status failed; /* first failure of one of its files */
  char failmsg[512];
};

/* The calling thread's transaction. */
static _Thread_local pa_output current;

/* ---- temporaries and signals ---- */

static int temp_list(char *tmppath) {
  for (int i = 0; i < MAX_TEMPS; i++) {
    char *expected = NULL;
    if (atomic_compare_exchange_strong(&temps[i], &expected, tmppath)) return i;
  }
  return -1;
}

static void temp_unlist(int slot) {
  if (slot >= 0) atomic_store(&temps[slot], NULL);
}

/* Runs with SA_RESETHAND: the default action is back when it raises the
 * signal again, which then ends the process as it would have without us.
 * The note says what became of the outputs (write(2): async-signal-safe). */
static void on_signal(int sig) {
  int saved = errno;
  for (int i = 0; i < MAX_TEMPS; i++) {
    char *p = atomic_load(&temps[i]);
    if (p) unlink(p);
  }
  static const char note[] =
      "padapt: interrupted by a signal: the files being written were removed, "
      "the outputs at their paths are as they were\n";
  ssize_t w = write(STDERR_FILENO, note, sizeof note - 1);
  (void)w;
  errno = saved;
  raise(sig);
}

/* ---- the collective end's signals and test hook ---- */

static volatile sig_atomic_t held_signal;
static pa_output_hook out_hook;
static void *out_hook_ctx;

static void term_set(sigset_t *set) {
  sigemptyset(set);
  sigaddset(set, SIGINT);
  sigaddset(set, SIGTERM);
}

void pa__output_hold_begin(sigset_t *old) {
  sigset_t block;
  term_set(&block);
  pthread_sigmask(SIG_BLOCK, &block, old);
}

int pa__output_signal_pending(void) {
  sigset_t pend;
  if (sigpending(&pend) != 0) return 0;
  return sigismember(&pend, SIGINT) ? SIGINT
         : sigismember(&pend, SIGTERM) ? SIGTERM
                                       : 0;
}

void pa__output_hold_end(const sigset_t *old, int hold) {
  if (hold) { /* take the signals that arrived: the outputs are committed */
    sigset_t set;
    term_set(&set);
    const struct timespec now = {0, 0};
    int sig;
    while ((sig = sigtimedwait(&set, NULL, &now)) > 0)
      if (!held_signal) held_signal = sig;
  }
  pthread_sigmask(SIG_SETMASK, old, NULL);
}

int pa_output_held_signal(void) {
  int sig = held_signal;
  held_signal = 0;
  return sig;
}

void pa_output_set_hook(pa_output_hook hook, void *ctx) {
  out_hook = hook;
  out_hook_ctx = ctx;
}

void pa__output_hook(const char *step) {
  if (out_hook) out_hook(step, out_hook_ctx);
}

pa_status pa_output_handle_signals(void) {
  pa_status st = PA_SUCCESS;
  static const int sigs[] = {SIGINT, SIGTERM};
  for (size_t k = 0; k < sizeof sigs / sizeof *sigs; k++) {
    struct sigaction old, sa;
    PA_CHECK(sigaction(sigs[k], NULL, &old) == 0, PA_ERR_INTERNAL,
             "sigaction: %s", strerror(errno));
    /* an ignored signal stays ignored, a handler of the caller stays */
    if ((old.sa_flags & SA_SIGINFO) || old.sa_handler != SIG_DFL) continue;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    for (size_t j = 0; j < sizeof sigs / sizeof *sigs; j++)
      sigaddset(&sa.sa_mask, sigs[j]);
    sa.sa_flags = SA_RESETHAND;
    PA_CHECK(sigaction(sigs[k], &sa, NULL) == 0, PA_ERR_INTERNAL,
             "sigaction: %s", strerror(errno));
  }
cleanup:
  return st;
}

/* ---- paths ---- */

static const char *file_kind(mode_t m) {
  return S_ISDIR(m)    ? "a directory"
         : S_ISLNK(m)  ? "a symbolic link"
         : S_ISCHR(m)  ? "a character device"
         : S_ISBLK(m)  ? "a block device"
         : S_ISFIFO(m) ? "a FIFO"
         : S_ISSOCK(m) ? "a socket"
                       : "not a regular file";
}

/* Refuse a path that exists and is not a regular file. */
static pa_status check_target(const char *path) {
  pa_status st = PA_SUCCESS;
  struct stat sb;
  if (lstat(path, &sb) != 0) return PA_SUCCESS; /* absent: fine */
  PA_CHECK(S_ISREG(sb.st_mode), PA_ERR_IO,
           "%s: exists and is %s, not a regular file: refusing to write it",
           path, file_kind(sb.st_mode));
cleanup:
  return st;
}

pa_status pa_output_check(const char *path) {
  pa_status st = PA_SUCCESS;
  char *dir = NULL;
  struct stat sb;
  PA_CHECK(path && path[0], PA_ERR_ARG, "pa_output_check: no path");
  PA_CALL(check_target(path));
  const char *slash = strrchr(path, '/');
  size_t n = slash ? (size_t)(slash - path) : 1;
  PA_ALLOC(dir, n + 1);
  if (!slash)
    memcpy(dir, ".", 2);
  else if (n == 0)
    memcpy(dir, "/", 2);
  else {
    memcpy(dir, path, n);
    dir[n] = '\0';
  }
  PA_CHECK(stat(dir, &sb) == 0, PA_ERR_IO, "%s: cannot write: directory %s: %s",
           path, dir, strerror(errno));
  PA_CHECK(S_ISDIR(sb.st_mode), PA_ERR_IO,
           "%s: cannot write: %s is not a directory", path, dir);
  PA_CHECK(access(dir, W_OK | X_OK) == 0, PA_ERR_IO,
           "%s: cannot write: directory %s: %s", path, dir, strerror(errno));
cleanup:
  pa__free(dir);
  return st;
}

/* fsync the directory holding path, so that its renames are on disk too;
 * best effort (some file systems refuse it). */
static void sync_dir(const char *path) {
  const char *slash = strrchr(path, '/');
  char dir[4096];
  if (!slash)
    snprintf(dir, sizeof dir, ".");
  else if (slash == path)
    snprintf(dir, sizeof dir, "/");
  else
    snprintf(dir, sizeof dir, "%.*s", (int)(slash - path), path);
  int fd = open(dir, O_RDONLY | O_CLOEXEC);
  if (fd < 0) return;
  (void)fsync(fd);
  close(fd);
}

/* 1 if paths a and b name files of the same directory (as spelled). */
static int same_dir(const char *a, const char *b) {
  const char *sa = strrchr(a, '/'), *sb = strrchr(b, '/');
  size_t na = sa ? (size_t)(sa - a) : 0, nb = sb ? (size_t)(sb - b) : 0;
  return na == nb && !strncmp(a, b, na);
}

/* ---- one transaction's files ---- */

static void entry_discard(out_entry *e) {
  if (e->tmppath) unlink(e->tmppath);
  temp_unlist(e->slot);
  pa__free(e->tmppath);
  pa__free(e->path);
  memset(e, 0, sizeof *e);
  e->slot = -1;
}

/* Rename the completed temporaries onto their paths, then remove the paths
 * listed for removal; every entry is consumed. SIGINT/SIGTERM wait until the
 * renames are done. After a failed rename the later temporaries are
 * removed, the earlier renames stay. */
static pa_status commit_entries(out_entry *e, int n) {
  pa_status st = PA_SUCCESS;
  sigset_t block, old;
  int nrenamed = 0;
  sigemptyset(&block);
  sigaddset(&block, SIGINT);
  sigaddset(&block, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &block, &old);
  for (int i = 0; i < n; i++) {
    if (st == PA_SUCCESS && e[i].tmppath) {
      if (rename(e[i].tmppath, e[i].path) == 0) {
        temp_unlist(e[i].slot);
        e[i].slot = -1;
        pa__free(e[i].tmppath);
        e[i].tmppath = NULL;
        if (nrenamed++ == 0) pa__output_hook("renamed");
      } else {
        st = pa__error(PA_ERR_IO, __FILE__, __LINE__,
                       "%s: cannot rename the completed temporary onto it: "
                       "%s (%d output%s of the same command already "
                       "replaced)",
                       e[i].path, strerror(errno), nrenamed,
                       nrenamed == 1 ? "" : "s");
      }
    } else if (st == PA_SUCCESS && unlink(e[i].path) != 0 && errno != ENOENT) {
      st = pa__error(PA_ERR_IO, __FILE__, __LINE__,
                     "%s: cannot remove this stale file: %s", e[i].path,
                     strerror(errno));
    }
  }
  pthread_sigmask(SIG_SETMASK, &old, NULL);
  for (int i = 0; i < n && st == PA_SUCCESS; i++)
    if (i == 0 || !same_dir(e[i].path, e[i - 1].path)) sync_dir(e[i].path);
  for (int i = 0; i < n; i++)
    entry_discard(&e[i]);
  return st;
}

static void tx_reset(void) {
  for (int i = 0; i < current.nfile; i++)
    entry_discard(&current.file[i]);
  pa__free(current.file);
  memset(&current, 0, sizeof current);
}

/* Mark the open transaction failed (first failure wins). */
static void tx_fail(pa_status st, const char *path) {
  if (current.depth == 0 || current.failed) return;
  const char *msg = pa_last_error();
  current.failed = st ? st : PA_ERR_IO;
  if (strstr(msg, path)) /* the message names the file already */
    snprintf(current.failmsg, sizeof current.failmsg, "%s", msg);
  else
    snprintf(current.failmsg, sizeof current.failmsg, "%s: %s", path,
             msg[0] ? msg : "not written");
}

static pa_status tx_add(out_entry *e) {
  pa_status st = PA_SUCCESS;
  PA_GROW(current.file, current.cap, current.nfile + 1);
  current.file[current.nfile++] = *e;
cleanup:
  return st;
}

static int tx_find(const char *path) {
  for (int i = 0; i < current.nfile; i++)
    if (!strcmp(current.file[i].path, path)) return i;
  return -1;
}

pa_status pa_output_begin(pa_output **tx) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(tx, PA_ERR_ARG, "pa_output_begin: NULL argument");
  current.depth++;
  *tx = &current;
cleanup:
  return st;
}

pa_status pa_output_commit(pa_output *tx) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(tx == &current && current.depth > 0, PA_ERR_ARG,
           "pa_output_commit: no output transaction open in this thread");
  if (--current.depth > 0) { /* nested: the outermost end decides */
    if (current.failed) PA_FAIL(current.failed, "%s", current.failmsg);
    return PA_SUCCESS;
  }
  if (current.failed) {
    st = pa__error(current.failed, __FILE__, __LINE__, "nothing written: %s",
                   current.failmsg);
    tx_reset();
    return st;
  }
  st = commit_entries(current.file, current.nfile);
  current.nfile = 0;
  tx_reset();
cleanup:
  return st;
}

void pa_output_abort(pa_output *tx) {
  if (tx != &current || current.depth == 0) return;
  if (--current.depth > 0) {
    if (!current.failed) {
      current.failed = PA_ERR_IO;
      snprintf(current.failmsg, sizeof current.failmsg,
               "an output was abandoned");
    }
    return;
  }
  tx_reset();
}

/* ---- files ---- */

/* The public handle of a file the caller writes itself. */
struct pa_output_file {
  pa__outfile out;
};

pa_status pa__out_open(pa__outfile *out, const char *path) {
  pa_status st = PA_SUCCESS;
  int fd = -1;
  memset(out, 0, sizeof *out);
  out->slot = -1;
  out->joined = current.depth > 0;
  size_t n = strlen(path);
  PA_ALLOC(out->path, n + 1);
  memcpy(out->path, path, n + 1);
  PA_CALL(check_target(path));
  PA_CHECK(tx_find(path) < 0, PA_ERR_ARG,
           "%s: written twice by one command (give the outputs different "
           "names)",
           path);
  PA_ALLOC(out->tmppath, n + 32);
  snprintf(out->tmppath, n + 32, "%s.tmp.%ld", path, (long)getpid());
  out->slot = temp_list(out->tmppath);
  PA_CHECK(out->slot >= 0, PA_ERR_IO,
           "%s: more than %d files being written at once", path,
           MAX_TEMPS);
  /* O_EXCL: never write through a file (or link) that is already there */
  fd = open(out->tmppath, O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC,
            0666);
  if (fd < 0) {
    int err = errno;
    temp_unlist(out->slot); /* at once: what is there is not ours */
    out->slot = -1;
    PA_CHECK(err != EEXIST, PA_ERR_IO,
             "%s: cannot create the temporary %s: it already exists (left by "
             "a killed process? remove it)",
             path, out->tmppath);
    PA_FAIL(PA_ERR_IO, "%s: cannot open for writing: %s", path, strerror(err));
  }
  out->fp = fdopen(fd, "wb");
  if (!out->fp) {
    close(fd);
    PA_FAIL(PA_ERR_IO, "%s: cannot open for writing: %s", path,
            strerror(errno));
  }
cleanup:
  if (st) {
    if (fd < 0) { /* nothing of ours exists: never remove what is there */
      temp_unlist(out->slot);
      out->slot = -1;
      pa__free(out->tmppath);
      out->tmppath = NULL;
    }
    if (!out->path) tx_fail(st, path);
    pa__out_abort(out);
  }
  return st;
}

pa_status pa__out_reopen(pa__outfile *out, const char *path) {
  pa_status st = PA_SUCCESS;
  memset(out, 0, sizeof *out);
  out->slot = -1;
  int k = current.depth > 0 ? tx_find(path) : -1;
  PA_CHECK(k >= 0 && current.file[k].tmppath, PA_ERR_INTERNAL,
           "%s: not a file completed in the open output transaction", path);
  out_entry e = current.file[k];
  memmove(current.file + k, current.file + k + 1,
          (size_t)(current.nfile - k - 1) * sizeof *current.file);
  current.nfile--;
  out->path = e.path;
  out->tmppath = e.tmppath;
  out->slot = e.slot;
  out->joined = 1;
  out->fp = fopen(out->tmppath, "r+b");
  PA_CHECK(out->fp, PA_ERR_IO, "%s: cannot reopen %s: %s", path, out->tmppath,
           strerror(errno));
cleanup:
  if (st) pa__out_abort(out);
  return st;
}

pa_status pa__out_commit(pa__outfile *out) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(out->fp, PA_ERR_ARG, "output file is not open");
  int err = 0, bad = fflush(out->fp) != 0 || ferror(out->fp);
  if (bad) err = errno;
  if (!bad && fsync(fileno(out->fp)) != 0) bad = 1, err = errno;
  if (fclose(out->fp) != 0 && !bad) bad = 1, err = errno;
  out->fp = NULL;
  PA_CHECK(!bad, PA_ERR_IO, "%s: write error: %s", out->path,
           strerror(err ? err : EIO));
  out_entry e = {out->path, out->tmppath, out->slot};
  if (out->joined) {
    PA_CALL(tx_add(&e));
  } else {
    st = commit_entries(&e, 1);
  }
  /* the entry owns the names now */
  out->path = out->tmppath = NULL;
  out->slot = -1;
cleanup:
  pa__out_abort(out);
  return st;
}

void pa__out_abort(pa__outfile *out) {
  if (!out->path) return; /* never opened, or committed */
  if (out->fp) fclose(out->fp);
  out->fp = NULL;
  if (out->tmppath) unlink(out->tmppath);
  temp_unlist(out->slot);
  if (out->joined) tx_fail(PA_ERR_IO, out->path);
  pa__free(out->tmppath);
  pa__free(out->path);
  out->tmppath = out->path = NULL;
  out->slot = -1;
}

pa_status pa_output_file_open(const char *path, pa_output_file **file,
                              FILE **fp) {
  pa_status st = PA_SUCCESS;
  pa_output_file *f = NULL;
  PA_CHECK(path && file && fp, PA_ERR_ARG,
           "pa_output_file_open: NULL argument");
  *file = NULL;
  *fp = NULL;
  PA_CALLOC(f, 1);
  PA_CALL(pa__out_open(&f->out, path));
  *fp = f->out.fp;
  *file = f;
  f = NULL;
cleanup:
  pa__free(f);
  return st;
}

pa_status pa_output_file_commit(pa_output_file *file) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(file, PA_ERR_ARG, "pa_output_file_commit: NULL file");
  st = pa__out_commit(&file->out);
cleanup:
  pa__free(file);
  return st;
}

void pa_output_file_abort(pa_output_file *file) {
  if (!file) return;
  pa__out_abort(&file->out);
  pa__free(file);
}

pa_status pa__out_remove(const char *path) {
  pa_status st = PA_SUCCESS;
  out_entry e = {NULL, NULL, -1};
  PA_CHECK(current.depth > 0, PA_ERR_INTERNAL,
           "%s: removal outside an output transaction", path);
  PA_CALL(check_target(path));
  if (tx_find(path) >= 0) return PA_SUCCESS;
  size_t n = strlen(path);
  PA_ALLOC(e.path, n + 1);
  memcpy(e.path, path, n + 1);
  PA_CALL(tx_add(&e));
  e.path = NULL;
cleanup:
  pa__free(e.path);
  if (st) tx_fail(st, path);
  return st;
}

const char *pa__out_tmppath(const char *path) {
  int k = current.depth > 0 ? tx_find(path) : -1;
  return k >= 0 ? current.file[k].tmppath : NULL;
}

int pa__output_depth(void) { return current.depth; }

pa_status pa__file_fnv1a64(const char *path, int64_t *bytes, uint64_t *hash) {
  pa_status st = PA_SUCCESS;
  unsigned char *buf = NULL;
  uint64_t h = PA_IO_FNV1A64_INIT;
  int64_t total = 0;
  size_t n;
  /* large enough to read at disk speed, small beside a mesh */
  const size_t chunk = (size_t)1 << 20;
  FILE *fp = fopen(path, "rb");
  PA_CHECK(fp, PA_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
  PA_ALLOC(buf, chunk);
  while ((n = fread(buf, 1, chunk, fp)) > 0) {
    h = pa__fnv1a64(h, buf, n);
    total += (int64_t)n;
  }
  PA_CHECK(!ferror(fp), PA_ERR_IO, "%s: read error: %s", path, strerror(errno));
  *bytes = total;
  *hash = h;
cleanup:
  if (fp) fclose(fp);
  pa__free(buf);
  return st;
}

const char *pa__path_ext(const char *path, char *buf, size_t len) {
  const char *dot = strrchr(path, '.');
  const char *slash = strrchr(path, '/');
  buf[0] = '\0';
  if (!dot || (slash && dot < slash)) return buf;
  size_t i = 0;
  for (; dot[i] && i + 1 < len; i++) buf[i] = (char)tolower((unsigned char)dot[i]);
  buf[i] = '\0';
  return buf;
}
