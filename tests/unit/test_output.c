/*
 * test_output.c -- output transactions (src/io/output.c): several files
 * appear together or not at all, a failure leaves the previous files and no
 * temporary, nesting, refused paths (symbolic link, directory, device), a
 * temporary name taken by someone else, pa_output_check, the SIGTERM
 * handler removing the temporaries of a process killed mid-transaction, and
 * a file the caller writes itself (pa_output_file_*).
 */
#include "testutil.h"

#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>


static int exists(const char *p) {
  struct stat sb;
  return lstat(p, &sb) == 0;
}

static void write_text(const char *path, const char *text) {
  FILE *fp = fopen(path, "w");
  CHECK(fp != NULL);
  if (!fp) return;
  fputs(text, fp);
  fclose(fp);
}

/* The whole content of a small file ("" if absent), in buf. */
static const char *content(const char *path, char *buf, size_t n) {
  FILE *fp = fopen(path, "r");
  buf[0] = '\0';
  if (!fp) return buf;
  size_t k = fread(buf, 1, n - 1, fp);
  buf[k] = '\0';
  fclose(fp);
  return buf;
}

static pa_mesh *square(void) {
  pa_mesh *m = NULL;
  CHECK_OK(pa_mesh_generate_box(2, 3, &m));
  return m;
}

static pa_stats stats_of(pa_mesh *m) {
  pa_stats s;
  memset(&s, 0, sizeof s);
  if (m) CHECK_OK(pa_mesh_stats(m, &s));
  return s;
}

static int msg_has(const char *s) {
  if (strstr(pa_last_error(), s)) return 1;
  fprintf(stderr, "  message '%s' lacks '%s'\n", pa_last_error(), s);
  return 0;
}

/* Files wait as temporaries until the commit, then all appear. */
static void test_commit(void) {
  pa_mesh *m = square();
  pa_stats s = stats_of(m);
  pa_output *tx = NULL;
  remove("c.mesh");
  remove("c.json");
  CHECK_OK(pa_output_begin(&tx));
  CHECK_OK(pa_mesh_write(m, "c.mesh", NULL));
  CHECK_OK(pa_stats_write_json(&s, NULL, "c.json"));
  CHECK(!exists("c.mesh") && !exists("c.json"));
  CHECK(pa_test_ntemps() == 2);
  CHECK_OK(pa_output_commit(tx));
  CHECK(exists("c.mesh") && exists("c.json"));
  CHECK(pa_test_ntemps() == 0);
  /* outside a transaction a file is renamed at once */
  CHECK_OK(pa_mesh_write(m, "c2.mesh", NULL));
  CHECK(exists("c2.mesh") && pa_test_ntemps() == 0);
  pa_mesh_destroy(m);
}

/* A failed output: nothing renamed, previous files untouched, no temporary,
 * whether the caller aborts or (wrongly) commits. */
static void test_failure(void) {
  pa_mesh *m = square();
  pa_stats s = stats_of(m);
  pa_output *tx = NULL;
  char buf[64];
  for (int commit = 0; commit < 2; commit++) {
    write_text("f.mesh", "old mesh");
    write_text("f.json", "old json");
    CHECK_OK(pa_output_begin(&tx));
    CHECK_OK(pa_mesh_write(m, "f.mesh", NULL));
    CHECK(pa_stats_write_json(&s, NULL, "no_such_dir/f.json") == PA_ERR_IO);
    CHECK(msg_has("no_such_dir/f.json"));
    CHECK_OK(pa_stats_write_json(&s, NULL, "f.json"));
    if (commit) {
      CHECK(pa_output_commit(tx) == PA_ERR_IO);
      CHECK(msg_has("nothing written") && msg_has("no_such_dir/f.json"));
    } else {
      pa_output_abort(tx);
    }
    CHECK(!strcmp(content("f.mesh", buf, sizeof buf), "old mesh"));
    CHECK(!strcmp(content("f.json", buf, sizeof buf), "old json"));
    CHECK(pa_test_ntemps() == 0);
  }
  /* the next transaction starts clean */
  CHECK_OK(pa_output_begin(&tx));
  CHECK_OK(pa_stats_write_json(&s, NULL, "f.json"));
  CHECK_OK(pa_output_commit(tx));
  CHECK(strcmp(content("f.json", buf, sizeof buf), "old json") != 0);
  pa_mesh_destroy(m);
}

/* A file of the caller's own: its temporary waits for the transaction;
 * one it drops fails the transaction, the previous files untouched. */
static void test_own_file(void) {
  pa_mesh *m = square();
  pa_output *tx = NULL;
  pa_output_file *f = NULL;
  FILE *fp = NULL;
  char buf[64];
  remove("own.txt");
  CHECK_OK(pa_output_begin(&tx));
  CHECK_OK(pa_output_file_open("own.txt", &f, &fp));
  CHECK(f != NULL && fp != NULL);
  if (fp) fputs("mine", fp);
  CHECK_OK(pa_output_file_commit(f));
  CHECK_OK(pa_mesh_write(m, "own.mesh", NULL));
  CHECK(!exists("own.txt") && pa_test_ntemps() == 2);
  CHECK_OK(pa_output_commit(tx));
  CHECK(!strcmp(content("own.txt", buf, sizeof buf), "mine"));
  /* dropped: the transaction fails, nothing moves */
  write_text("own.mesh", "old mesh");
  CHECK_OK(pa_output_begin(&tx));
  CHECK_OK(pa_mesh_write(m, "own.mesh", NULL));
  CHECK_OK(pa_output_file_open("own.txt", &f, &fp));
  if (fp) fputs("not mine", fp);
  pa_output_file_abort(f);
  CHECK(pa_output_commit(tx) == PA_ERR_IO);
  CHECK(!strcmp(content("own.txt", buf, sizeof buf), "mine"));
  CHECK(!strcmp(content("own.mesh", buf, sizeof buf), "old mesh"));
  CHECK(pa_test_ntemps() == 0);
  /* refused: a directory, and no handle comes back */
  CHECK(pa_output_file_open(".", &f, &fp) == PA_ERR_IO);
  CHECK(f == NULL && fp == NULL);
  pa_output_file_abort(NULL);
  CHECK(pa_output_file_commit(NULL) == PA_ERR_ARG);
  pa_mesh_destroy(m);
}

/* Nested transactions: only the outermost end acts. */
static void test_nested(void) {
  pa_mesh *m = square();
  pa_output *outer = NULL, *inner = NULL;
  remove("n1.mesh");
  remove("n2.mesh");
  CHECK_OK(pa_output_begin(&outer));
  CHECK_OK(pa_mesh_write(m, "n1.mesh", NULL));
  CHECK_OK(pa_output_begin(&inner));
  CHECK(inner == outer);
  CHECK_OK(pa_mesh_write(m, "n2.mesh", NULL));
  CHECK_OK(pa_output_commit(inner));
  CHECK(!exists("n1.mesh") && !exists("n2.mesh"));
  CHECK_OK(pa_output_commit(outer));
  CHECK(exists("n1.mesh") && exists("n2.mesh"));
  /* an inner abort fails the outer transaction */
  remove("n1.mesh");
  CHECK_OK(pa_output_begin(&outer));
  CHECK_OK(pa_mesh_write(m, "n1.mesh", NULL));
  CHECK_OK(pa_output_begin(&inner));
  pa_output_abort(inner);
  CHECK(pa_output_commit(outer) != PA_SUCCESS);
  CHECK(!exists("n1.mesh") && pa_test_ntemps() == 0);
  /* a commit with none open is a caller mistake */
  CHECK(pa_output_commit(outer) == PA_ERR_ARG);
  pa_mesh_destroy(m);
}

/* Paths that exist and are not regular files are refused, naming them,
 * and nothing is created. */
static void test_refused(void) {
  pa_mesh *m = square();
  pa_stats s = stats_of(m);
  char buf[64];
  write_text("target.mesh", "target");
  remove("link.mesh");
  CHECK(symlink("target.mesh", "link.mesh") == 0);
  CHECK(pa_mesh_write(m, "link.mesh", NULL) == PA_ERR_IO);
  CHECK(msg_has("link.mesh") && msg_has("symbolic link"));
  CHECK(!strcmp(content("target.mesh", buf, sizeof buf), "target"));
  rmdir("dir.mesh");
  CHECK(mkdir("dir.mesh", 0755) == 0);
  CHECK(pa_mesh_write(m, "dir.mesh", NULL) == PA_ERR_IO);
  CHECK(msg_has("dir.mesh") && msg_has("directory"));
  CHECK(pa_stats_write_json(&s, NULL, "/dev/null") == PA_ERR_IO);
  CHECK(msg_has("/dev/null") && msg_has("device"));
  CHECK(pa_test_ntemps() == 0);
  /* pa_output_check: the same, plus the directory */
  CHECK(pa_output_check("link.mesh") == PA_ERR_IO);
  CHECK(pa_output_check("/dev/null") == PA_ERR_IO);
  CHECK(pa_output_check("no_such_dir/x.mesh") == PA_ERR_IO);
  CHECK(msg_has("no_such_dir"));
  CHECK(pa_output_check("target.mesh/x.mesh") == PA_ERR_IO);
  CHECK_OK(pa_output_check("target.mesh"));
  CHECK_OK(pa_output_check("new.mesh"));
  CHECK(!exists("new.mesh"));
  /* one path twice in a transaction */
  pa_output *tx = NULL;
  CHECK_OK(pa_output_begin(&tx));
  CHECK_OK(pa_stats_write_json(&s, NULL, "twice.json"));
  CHECK(pa_stats_write_json(&s, NULL, "twice.json") == PA_ERR_ARG);
  CHECK(msg_has("twice.json"));
  CHECK(pa_output_commit(tx) != PA_SUCCESS);
  CHECK(!exists("twice.json") && pa_test_ntemps() == 0);
  /* a temporary name already taken is never written through nor removed */
  char tmp[64];
  snprintf(tmp, sizeof tmp, "taken.json.tmp.%ld", (long)getpid());
  CHECK(mkdir(tmp, 0755) == 0);
  CHECK(pa_stats_write_json(&s, NULL, "taken.json") == PA_ERR_IO);
  CHECK(msg_has("already exists"));
  CHECK(exists(tmp) && !exists("taken.json"));
  rmdir(tmp);
  remove("link.mesh");
  rmdir("dir.mesh");
  pa_mesh_destroy(m);
}

/* A process killed by SIGTERM while its temporaries exist leaves none, and
 * dies by the signal. */
static void test_signal(void) {
  char buf[64];
  write_text("sig.json", "old json");
  fflush(NULL);
  pid_t pid = fork();
  CHECK(pid >= 0);
  if (pid == 0) {
    pa_mesh *m = NULL;
    pa_stats s;
    pa_output *tx = NULL;
    if (pa_output_handle_signals() || pa_mesh_generate_box(2, 3, &m) ||
        pa_mesh_stats(m, &s) || pa_output_begin(&tx) ||
        pa_mesh_write(m, "sig.mesh", NULL) ||
        pa_stats_write_json(&s, NULL, "sig.json") || pa_test_ntemps() != 2)
      _exit(3);
    raise(SIGTERM);
    _exit(4); /* not reached */
  }
  int status = 0;
  CHECK(waitpid(pid, &status, 0) == pid);
  CHECK(WIFSIGNALED(status) && WTERMSIG(status) == SIGTERM);
  CHECK(pa_test_ntemps() == 0);
  CHECK(!exists("sig.mesh"));
  CHECK(!strcmp(content("sig.json", buf, sizeof buf), "old json"));
}

TEST_MAIN(test_commit, test_failure, test_own_file, test_nested, test_refused,
          test_signal)
