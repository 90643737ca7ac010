/*
 * cli_paths.c -- the check of a command's files before the work starts
 * (pa_cli_check_io): every output can be written (pa_output_check), no two
 * outputs are the same file, and no output is a file the command reads.
 *
 * "The same file" is decided on what the paths resolve to, not on how they
 * are spelt: an existing file by its device and inode (so a hard link, a
 * symbolic link to an input, "./a.mesh" and "dir/../a.mesh" all count), a
 * file still to be created by the device and inode of its directory and its
 * name. The files of a distributed set are expanded by the naming of
 * pa_dmesh_write (OUT.<r>.meshb, OUT.<r>.vtu, OUT.pvtu, OUT.manifest, and
 * the file OUT itself and the rank files beyond the new count, which a write
 * removes); a checkpoint directory owns its state file "checkpoint" and its
 * sets "iter-*"; -restart DIR reads every file in DIR.
 */
#include "cli.h"

#include <dirent.h>
#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* One file as the check sees it: the path as given and what it resolves to.
 * has_file: the file exists (dev, ino); has_name: its directory exists
 * (ddev, dino, and name, the last component). */
typedef struct io_file {
  char *path;
  const char *what; /* for the messages: the set or directory it is of */
  int has_file, has_name;
  dev_t dev, ddev;
  ino_t ino, dino;
  const char *name;
} io_file;

typedef struct io_list {
  io_file *f;
  int n, cap, oom;
} io_list;

/* Append path (copied) with what it belongs to; resolves it. */
static void list_add(io_list *l, const char *path, const char *what) {
  if (l->oom) return;
  if (l->n == l->cap) {
    int cap = l->cap ? 2 * l->cap : 16;
    io_file *f = realloc(l->f, sizeof *f * (size_t)cap);
    if (!f) {
      l->oom = 1;
      return;
    }
    l->f = f;
    l->cap = cap;
  }
  io_file *e = &l->f[l->n];
  memset(e, 0, sizeof *e);
  e->path = strdup(path);
  if (!e->path) {
    l->oom = 1;
    return;
  }
  e->what = what;
  l->n++;
  struct stat sb;
  if (stat(path, &sb) == 0) {
    e->has_file = 1;
    e->dev = sb.st_dev;
    e->ino = sb.st_ino;
  }
  const char *slash = strrchr(e->path, '/');
  e->name = slash ? slash + 1 : e->path;
  char *dir = slash ? strndup(e->path, (size_t)(slash - e->path + 1))
                    : strdup(".");
  if (dir && stat(dir, &sb) == 0) {
    e->has_name = 1;
    e->ddev = sb.st_dev;
    e->dino = sb.st_ino;
  }
  free(dir);
}

static void list_free(io_list *l) {
  for (int i = 0; i < l->n; i++)
    free(l->f[i].path);
  free(l->f);
}

/* 1 if a and b resolve to the same file (existing, or to be created). */
static int same_file(const io_file *a, const io_file *b) {
  if (a->has_file && b->has_file)
    return a->dev == b->dev && a->ino == b->ino;
  return a->has_name && b->has_name && a->ddev == b->ddev &&
         a->dino == b->dino && !strcmp(a->name, b->name);
}

static int exists(const char *path) {
  struct stat sb;
  return lstat(path, &sb) == 0;
}

/* "OUT.meshb" / "OUT.mesh" / "OUT" -> "OUT" (malloc'ed), as pa_dmesh_write
 * names a set's files. */
static char *set_base(const char *path) {
  char *b = strdup(path);
  size_t n = b ? strlen(b) : 0;
  if (n > 6 && !strcmp(b + n - 6, ".meshb"))
    b[n - 6] = '\0';
  else if (n > 5 && !strcmp(b + n - 5, ".mesh"))
    b[n - 5] = '\0';
  return b;
}

/* The files of the distributed set at path: as an input, those that exist;
 * as an output written on nranks ranks, every file the write creates or
 * removes. */
static void add_set(io_list *l, const char *path, int nranks) {
  char *base = set_base(path);
  size_t n = base ? strlen(base) + 32 : 0;
  char *p = base ? malloc(n) : NULL;
  if (!p) {
    l->oom = 1;
    free(base);
    return;
  }
  int out = nranks > 0;
  if (out) list_add(l, path, path);
  snprintf(p, n, "%s.manifest", base);
  if (out || exists(p)) list_add(l, p, path);
  if (out) {
    snprintf(p, n, "%s.pvtu", base);
    list_add(l, p, path);
  }
  for (int r = 0;; r++) {
    int found = 0;
    static const char *const ext[] = {".meshb", ".vtu"};
    for (int k = 0; k < (out ? 2 : 1); k++) {
      snprintf(p, n, "%s.%d%s", base, r, ext[k]);
      if (exists(p)) found = 1;
      if (exists(p) || r < nranks) list_add(l, p, path);
    }
    if (!found && r >= nranks) break;
  }
  free(p);
  free(base);
}

/* Every file in directory dir (the checkpoint a -restart reads). */
static void add_dir(io_list *l, const char *dir) {
  DIR *d = opendir(dir);
  if (!d) return; /* the restart names the missing directory itself */
  struct dirent *e;
  while ((e = readdir(d))) {
    if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, "..")) continue;
    size_t n = strlen(dir) + strlen(e->d_name) + 2;
    char *p = malloc(n);
    if (!p) {
      l->oom = 1;
      break;
    }
    snprintf(p, n, "%s/%s", dir, e->d_name);
    list_add(l, p, dir);
    free(p);
  }
  closedir(d);
}

/* 1 if f is a file a checkpoint in directory ck (resolved as f's directory
 * would be) writes or removes: "checkpoint" or "iter-*" in it. */
static int in_checkpoint(const io_file *f, const io_file *ck) {
  return f->has_name && ck->has_file && f->ddev == ck->dev &&
         f->dino == ck->ino &&
         (!strcmp(f->name, "checkpoint") || !strncmp(f->name, "iter-", 5));
}

/* The message part "PATH" or "PATH (of the set S)". */
static void describe(const io_file *f, char *buf, size_t len) {
  if (f->what && strcmp(f->what, f->path))
    snprintf(buf, len, "%s (of %s)", f->path, f->what);
  else
    snprintf(buf, len, "%s", f->path);
}

/* The first conflict of the lists on rank 0, printed; 0 if none. */
static int find_conflict(const pa_cli *cli, const char *cmd, const io_list *in,
                         const io_list *out, const io_file *ck, int ck_read) {
  char a[1200], b[1200];
  for (int i = 0; i < out->n; i++) {
    const io_file *o = &out->f[i];
    describe(o, a, sizeof a);
    for (int j = 0; j < in->n; j++)
      if (same_file(o, &in->f[j])) {
        describe(&in->f[j], b, sizeof b);
        return pa_cli_error(cli,
                            "%s: the output %s is the input %s (the same "
                            "file): refusing to overwrite an input; give the "
                            "output another path",
                            cmd, a, b);
      }
    for (int j = 0; j < i; j++)
      if (same_file(o, &out->f[j])) {
        describe(&out->f[j], b, sizeof b);
        return pa_cli_error(cli,
                            "%s: %s and %s are the same file: give each "
                            "output its own path",
                            cmd, b, a);
      }
    if (ck && in_checkpoint(o, ck))
      return pa_cli_error(cli,
                          "%s: the output %s is in the checkpoint directory "
                          "%s, whose files the checkpoints replace",
                          cmd, a, ck->path);
  }
  for (int j = 0; ck && !ck_read && j < in->n; j++)
    if (in_checkpoint(&in->f[j], ck)) {
      describe(&in->f[j], b, sizeof b);
      return pa_cli_error(cli,
                          "%s: the input %s is in the checkpoint directory "
                          "%s, whose files the checkpoints replace",
                          cmd, b, ck->path);
    }
  return 0;
}

int pa_cli_check_io(const pa_cli *cli, const char *cmd, const pa_cli_io *io) {
  int bad = 0;
  if (cli->rank == 0) {
    io_list in = {0}, out = {0}, ck = {0};
    for (int i = 0; i < PA_CLI_IO_MAX; i++) {
      const char *p = io->in[i];
      if (!p) continue;
      if (pa_dmesh_is_set(p))
        add_set(&in, p, 0);
      else
        list_add(&in, p, NULL);
    }
    if (io->restart) add_dir(&in, io->restart);
    for (int i = 0; i < PA_CLI_IO_MAX; i++)
      if (io->out[i]) list_add(&out, io->out[i], NULL);
    if (io->set) add_set(&out, io->set, cli->size);
    if (io->ckpt) list_add(&ck, io->ckpt, NULL);
    if (in.oom || out.oom || ck.oom)
      bad = pa_cli_error(cli, "%s: out of memory", cmd);
    for (int i = 0; i < out.n && !bad; i++) {
      pa_status st = pa_output_check(out.f[i].path);
      if (st) bad = pa_cli_fail(cli, st);
    }
    if (!bad) {
      /* the checkpoint's own files are what -restart reads from it */
      int ck_read = io->ckpt && io->restart && ck.n && ck.f[0].has_file;
      if (ck_read) {
        io_list r = {0};
        list_add(&r, io->restart, NULL);
        ck_read = r.n && same_file(&r.f[0], &ck.f[0]);
        list_free(&r);
      }
      bad = find_conflict(cli, cmd, &in, &out, ck.n ? &ck.f[0] : NULL,
                          ck_read);
    }
    list_free(&in);
    list_free(&out);
    list_free(&ck);
  }
  MPI_Bcast(&bad, 1, MPI_INT, 0, cli->comm);
  return bad;
}
