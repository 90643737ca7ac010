/*
 * test_adapt_checkpoint.c -- checkpoints of pa_dmesh_adapt and
 * pa_dmesh_adapt_resume through the library API, with a plug-in remesher
 * and a ghost layer: a copy of the checkpoint of iteration 1, taken while
 * the run goes on, resumes to the same mesh (checksum), the same local
 * numbering on every rank and the same report figures; a resume with other options, from
 * a directory without checkpoint, and checkpoints asked for inside an
 * output transaction are refused with no mesh and no leak. Runs at any
 * number of ranks.
 */
#include "testutil.h"
#include "bisect_remesher.h"

#include <dirent.h>
#include <mpi.h>
#include <sys/stat.h>
#include <unistd.h>

/* Iteration at whose progress call the checkpoint of the one before is
 * copied (the run must get there). */
#define COPY_ITER 2

/* A 3D box with one ghost layer (the checkpoint restores the ghosts). */
static pa_dmesh *make(void) {
  pa_mesh *m = NULL;
  pa_dmesh *dm = NULL;
  if (pa_test_rank == 0) CHECK_OK(pa_mesh_generate_box(3, 3, &m));
  CHECK_OK(pa_dmesh_distribute(MPI_COMM_WORLD, 0, m, 1, &dm));
  pa_mesh_destroy(m);
  return dm;
}

/* The example bisection remesher, many pieces: several iterations (8). */
static void opts_small(pa_adapt_opts *o) {
  pa_adapt_opts_default(o);
  o->remesher = bisect_remesher();
  o->remesh.hsiz = 0.2;
  o->pieces_per_rank = 2; /* several pieces on one rank too */
  o->min_piece_work = 20;
  o->min_piece_ratio = 0;
}

/* Rank 0: remove the files of a flat directory, then the directory. */
static void remove_dir(const char *dir) {
  char p[512];
  DIR *d = opendir(dir);
  if (!d) return;
  for (struct dirent *e; (e = readdir(d));) {
    if (e->d_name[0] == '.') continue;
    snprintf(p, sizeof p, "%s/%s", dir, e->d_name);
    unlink(p);
  }
  closedir(d);
  rmdir(dir);
}

/* Copy the files of dir whose name is "checkpoint" or starts with prefix
 * into the new directory to. Returns the number copied. */
static int copy_files(const char *dir, const char *prefix, const char *to) {
  char a[512], b[512], buf[65536];
  int n = 0;
  DIR *d = opendir(dir);
  if (!d) return 0;
  mkdir(to, 0777);
  for (struct dirent *e; (e = readdir(d));) {
    if (strcmp(e->d_name, "checkpoint") &&
        strncmp(e->d_name, prefix, strlen(prefix)))
      continue;
    snprintf(a, sizeof a, "%s/%s", dir, e->d_name);
    snprintf(b, sizeof b, "%s/%s", to, e->d_name);
    FILE *in = fopen(a, "rb"), *out = fopen(b, "wb");
    size_t k;
    while (in && out && (k = fread(buf, 1, sizeof buf, in)) > 0)
      fwrite(buf, 1, k, out);
    n += in && out;
    if (in) fclose(in);
    if (out) fclose(out);
  }
  closedir(d);
  return n;
}

/* The progress callback: at COPY_ITER, before that iteration's checkpoint,
 * rank 0 copies the checkpoint of the iteration before ("ckA" -> "ckB"). */
static void copy_checkpoint(const pa_adapt_iter *it, void *ctx) {
  int *copied = ctx;
  if (it->iter != COPY_ITER || pa_test_rank != 0) return;
  char prefix[32];
  snprintf(prefix, sizeof prefix, "iter-%d.", COPY_ITER - 1);
  *copied = copy_files("ckA", prefix, "ckB");
}

static uint64_t checksum(pa_dmesh *dm) {
  uint64_t c = 0;
  CHECK_OK(pa_dmesh_checksum(dm, &c));
  return c;
}

/* 1 if a and b hold, on this rank, the same entities of every kind in the
 * same local order (owned, then ghosts). */
static int same_local(const pa_dmesh *a, const pa_dmesh *b) {
  for (int k = 0; k < 4; k++) {
    pa_entity kind = (pa_entity)k;
    pa_idx n = pa_dmesh_nlocal(a, kind);
    if (n != pa_dmesh_nlocal(b, kind) ||
        pa_dmesh_nowned(a, kind) != pa_dmesh_nowned(b, kind) ||
        (n && memcmp(pa_dmesh_gids(a, kind), pa_dmesh_gids(b, kind),
                     sizeof(pa_gid) * (size_t)n)))
      return 0;
  }
  return 1;
}

static void test_resume_same_result(void) {
  pa_dmesh *dm = make(), *res = NULL;
  pa_adapt_opts o;
  pa_adapt_report r1, r2;
  int copied = 0;
  if (pa_test_rank == 0) {
    remove_dir("ckA");
    remove_dir("ckB");
  }
  MPI_Barrier(MPI_COMM_WORLD);
  opts_small(&o);
  o.checkpoint_dir = "ckA";
  o.progress = copy_checkpoint;
  o.progress_ctx = &copied;
  CHECK_OK(pa_dmesh_adapt(dm, &o, &r1));
  MPI_Bcast(&copied, 1, MPI_INT, 0, MPI_COMM_WORLD);
  CHECK(r1.niter >= COPY_ITER);
  CHECK(copied >= 3); /* checkpoint, manifest, a rank file at least */

  o.progress = NULL;
  o.checkpoint_dir = NULL;
  CHECK_OK(pa_dmesh_adapt_resume(MPI_COMM_WORLD, "ckB", &o, &res, &r2));
  CHECK(res != NULL);
  if (res) {
    CHECK_OK(pa_dmesh_check(res));
    CHECK(checksum(res) == checksum(dm));
    CHECK(same_local(res, dm));
  }
  CHECK(r2.niter == r1.niter && r2.npieces == r1.npieces &&
        r2.converged == r1.converged && r2.nelem_final == r1.nelem_final &&
        r2.nelem_initial == r1.nelem_initial &&
        r2.niter_recorded == r1.niter_recorded);
  for (int k = 0; k < r1.niter_recorded && k < r2.niter_recorded; k++)
    CHECK(r2.iters[k].ntagged == r1.iters[k].ntagged &&
          r2.iters[k].nelem == r1.iters[k].nelem &&
          r2.iters[k].npieces == r1.iters[k].npieces);
  if (pa_test_rank == 0)
    printf("checkpoint: %lld -> %lld elements, %d iterations, resumed from "
           "iteration %d\n",
           (long long)r1.nelem_initial, (long long)r1.nelem_final, r1.niter,
           COPY_ITER - 1);
  pa_dmesh_destroy(res);
  pa_dmesh_destroy(dm);
}

static void test_refused(void) {
  pa_dmesh *dm = NULL;
  pa_adapt_opts o;
  pa_output *tx = NULL;
  opts_small(&o);
  o.qual_threshold = 0.25; /* not the checkpointed run's */
  CHECK(pa_dmesh_adapt_resume(MPI_COMM_WORLD, "ckA", &o, &dm, NULL) ==
        PA_ERR_ARG);
  CHECK(dm == NULL && strstr(pa_last_error(), "qual_threshold"));
  opts_small(&o);
  CHECK(pa_dmesh_adapt_resume(MPI_COMM_WORLD, "no-such-dir", &o, &dm, NULL) ==
        PA_ERR_IO);
  CHECK(dm == NULL && strstr(pa_last_error(), "no-such-dir/checkpoint"));
  dm = make();
  o.checkpoint_dir = "ckC";
  CHECK_OK(pa_output_begin(&tx));
  CHECK(pa_dmesh_adapt(dm, &o, NULL) == PA_ERR_ARG);
  pa_output_abort(tx);
  pa_dmesh_destroy(dm);
}

TEST_MPI_MAIN(test_resume_same_result, test_refused)
