/*
 * fuzz_readers.c -- a dependency-free, AFL-style mutation fuzzer for the file
 * readers (no libFuzzer needed).
 *
 *   fuzz_readers READER CORPUS_DIR ITERATIONS SEED
 *
 * READER is medit-mesh (.mesh/.meshb through pa_mesh_read), medit-sol
 * (.sol/.solb through pa_sol_read) or gmsh (.msh through pa_mesh_read); there
 * is no .vtu reader. Each iteration takes a seed file of CORPUS_DIR (files
 * with another extension are ignored), applies 1 to 4 random mutations and
 * reads the result. The reader must either succeed, and then the result is
 * walked (pa_mesh_check on a mesh, any status; every value of every field of
 * a solution), or fail with a non-empty message and no object returned. A
 * mesh that passes the check (its missing boundary completed, as the CLI
 * does) is then remeshed (pa_remesh, a uniform size of a fraction of its
 * bounding box, under a memory bound): the remesher must never crash on
 * what the check accepts, and must return a valid mesh or a clean error.
 * Anything else is counted as a violation and makes the exit status 1; a
 * memory error aborts the run under the sanitizers. The last line printed
 * counts the runs, the inputs read (of which valid: a mesh that passes
 * pa_mesh_check, a solution consistent with itself; of which remeshed), the
 * inputs refused, the violations and the bytes left allocated by padapt.
 *
 * Invariants: the run depends only on SEED and on the corpus (files are taken
 * in name order), so a failure is replayed by the same command line. Before
 * each read the input is written to fuzz-last.<ext> in the working directory,
 * which is also the file read: after an abort it is the reproducer; after a
 * clean run it is removed. Everything the readers allocate is freed, and the
 * counting allocator must be back to zero at exit.
 */
#include "padapt.h"

#include <dirent.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Seeds above this size are skipped: the corpus is meant to be small, and a
 * large seed makes every iteration slow. */
#define FUZZ_MAX_SEED (1 << 20)
/* Longest run inserted or deleted by one mutation, in bytes. */
#define FUZZ_MAX_RUN 64
/* Most mutations applied to one input. */
#define FUZZ_MAX_MUTATIONS 4
/* The size a valid mesh is remeshed to: its bounding box's diagonal over
 * this, a few hundred elements at most, so that a remesh costs what a read
 * does. */
#define FUZZ_REMESH_DIV 6.0
/* Memory bound of that remesh in MB: far above what such a mesh needs,
 * low enough that a runaway remesh is stopped (and reported) quickly. */
#define FUZZ_REMESH_MB 256.0

typedef struct fuzz_buf {
  unsigned char *data;
  size_t len, cap;
} fuzz_buf;

typedef struct fuzz_seed {
  char *name;
  char ext[8];
  unsigned char *data;
  size_t len;
} fuzz_seed;

/* xorshift64*: fast, and the same stream on every platform. */
static uint64_t rng_state;

static uint64_t rng_next(void) {
  rng_state ^= rng_state >> 12;
  rng_state ^= rng_state << 25;
  rng_state ^= rng_state >> 27;
  return rng_state * 2685821657736338717ull;
}

/* Uniform in [0, n), n > 0 (the modulo bias is irrelevant here). */
static size_t rng_below(size_t n) { return (size_t)(rng_next() % n); }

static void *xrealloc(void *p, size_t n) {
  void *q = realloc(p, n ? n : 1);
  if (!q) {
    fprintf(stderr, "fuzz_readers: out of memory\n");
    exit(2);
  }
  return q;
}

static void buf_reserve(fuzz_buf *b, size_t len) {
  if (len <= b->cap) return;
  b->cap = len + len / 2 + 64;
  b->data = xrealloc(b->data, b->cap);
}

/* Replace b[pos, pos + del) by ins[0, nins). */
static void buf_splice(fuzz_buf *b, size_t pos, size_t del,
                       const unsigned char *ins, size_t nins) {
  buf_reserve(b, b->len - del + nins);
  memmove(b->data + pos + nins, b->data + pos + del, b->len - pos - del);
  if (nins) memcpy(b->data + pos, ins, nins);
  b->len = b->len - del + nins;
}

/* Start of the line containing pos and the end of that line, newline
 * included. */
static void line_bounds(const fuzz_buf *b, size_t pos, size_t *start,
                        size_t *end) {
  size_t s = pos, e = pos;
  while (s > 0 && b->data[s - 1] != '\n')
    s--;
  while (e < b->len && b->data[e] != '\n')
    e++;
  if (e < b->len) e++;
  *start = s;
  *end = e;
}

static int is_num_char(unsigned char c) {
  return (c >= '0' && c <= '9') || c == '-' || c == '+' || c == '.' ||
         c == 'e' || c == 'E';
}

/* Text values that break counts, indices and coordinates. */
static const char *const extreme_text[] = {"0",
                                           "-1",
                                           "1",
                                           "2147483647",
                                           "-2147483648",
                                           "2147483648",
                                           "4294967296",
                                           "9223372036854775807",
                                           "1e308",
                                           "-1e308",
                                           "1e-320",
                                           "nan",
                                           "inf",
                                           "-0",
                                           "99999999999999999999999",
                                           "1.5",
                                           "0x10",
                                           ""};

/* Binary values (native byte order, as the files are written): counts,
 * versions, codes, positions and doubles. */
static void extreme_binary(unsigned char *out, size_t *n) {
  static const uint32_t u32[] = {
      0,           1,           2,           3,  4,  0xffffffffu,
      0x7fffffffu, 0x80000000u, 0x01000000u, 54, 256};
  static const uint64_t u64[] = {0,
                                 1,
                                 0xffffffffffffffffull,
                                 0x7fffffffffffffffull,
                                 0x0000000100000000ull,
                                 0x7ff8000000000000ull,  /* nan */
                                 0x7ff0000000000000ull,  /* inf */
                                 0x7fefffffffffffffull,  /* DBL_MAX */
                                 0x0000000000000001ull}; /* denormal */
  if (rng_below(2)) {
    uint32_t v = u32[rng_below(sizeof u32 / sizeof *u32)];
    memcpy(out, &v, 4);
    *n = 4;
  } else {
    uint64_t v = u64[rng_below(sizeof u64 / sizeof *u64)];
    memcpy(out, &v, 8);
    *n = 8;
  }
}

/* One random mutation of b. */
static void mutate(fuzz_buf *b) {
  static const unsigned char special[] = {0, 0xff, '-', '9', ' ', '\n'};
  unsigned char run[FUZZ_MAX_RUN];
  size_t pos = b->len ? rng_below(b->len) : 0;
  switch (rng_below(10)) {
  case 0: /* flip a bit */
    if (b->len) b->data[pos] ^= (unsigned char)(1u << rng_below(8));
    break;
  case 1: /* set a byte to a special value */
    if (b->len) b->data[pos] = special[rng_below(sizeof special)];
    break;
  case 2: { /* insert a random byte or a run of one byte */
    size_t n = rng_below(4) ? 1 : 1 + rng_below(FUZZ_MAX_RUN);
    unsigned char c = rng_below(2) ? (unsigned char)rng_below(256)
                                   : special[rng_below(sizeof special)];
    memset(run, c, n);
    buf_splice(b, pos, 0, run, n);
    break;
  }
  case 3: { /* delete a byte or a run */
    size_t n = rng_below(4) ? 1 : 1 + rng_below(FUZZ_MAX_RUN);
    if (n > b->len - pos) n = b->len - pos;
    buf_splice(b, pos, n, NULL, 0);
    break;
  }
  case 4: { /* duplicate a line */
    size_t s, e;
    if (!b->len) break;
    line_bounds(b, pos, &s, &e);
    if (e - s > FUZZ_MAX_RUN * 16) break;
    unsigned char *copy = xrealloc(NULL, e - s);
    memcpy(copy, b->data + s, e - s);
    buf_splice(b, e, 0, copy, e - s);
    free(copy);
    break;
  }
  case 5: { /* delete a line */
    size_t s, e;
    if (!b->len) break;
    line_bounds(b, pos, &s, &e);
    buf_splice(b, s, e - s, NULL, 0);
    break;
  }
  case 6: /* truncate */
    b->len = pos;
    break;
  case 7:
  case 8: { /* replace the next number token by an extreme value */
    size_t s = pos, e;
    while (s < b->len && !(b->data[s] >= '0' && b->data[s] <= '9'))
      s++;
    if (s == b->len) break;
    while (s > 0 && is_num_char(b->data[s - 1]))
      s--;
    e = s;
    while (e < b->len && is_num_char(b->data[e]))
      e++;
    const char *v =
        extreme_text[rng_below(sizeof extreme_text / sizeof *extreme_text)];
    buf_splice(b, s, e - s, (const unsigned char *)v, strlen(v));
    break;
  }
  default: { /* overwrite 4 or 8 bytes by an extreme binary value */
    size_t n;
    extreme_binary(run, &n);
    pos &= ~(size_t)3; /* binary fields are 4-byte aligned in these formats */
    if (pos + n > b->len) break;
    memcpy(b->data + pos, run, n);
    break;
  }
  }
}

static int ext_accepted(const char *reader, const char *ext) {
  if (!strcmp(reader, "medit-mesh"))
    return !strcmp(ext, ".mesh") || !strcmp(ext, ".meshb");
  if (!strcmp(reader, "medit-sol"))
    return !strcmp(ext, ".sol") || !strcmp(ext, ".solb");
  if (!strcmp(reader, "gmsh")) return !strcmp(ext, ".msh");
  return 0;
}

static int cmp_seed(const void *a, const void *b) {
  return strcmp(((const fuzz_seed *)a)->name, ((const fuzz_seed *)b)->name);
}

/* The seeds of dir that reader accepts, in name order; returns their number. */
static int load_corpus(const char *reader, const char *dir, fuzz_seed **seeds) {
  DIR *d = opendir(dir);
  struct dirent *ent;
  int n = 0;
  *seeds = NULL;
  if (!d) {
    fprintf(stderr, "fuzz_readers: cannot open corpus directory %s\n", dir);
    return 0;
  }
  while ((ent = readdir(d))) {
    const char *dot = strrchr(ent->d_name, '.');
    if (!dot || strlen(dot) >= sizeof((fuzz_seed *)0)->ext ||
        !ext_accepted(reader, dot))
      continue;
    size_t plen = strlen(dir) + strlen(ent->d_name) + 2;
    char *path = xrealloc(NULL, plen);
    snprintf(path, plen, "%s/%s", dir, ent->d_name);
    FILE *f = fopen(path, "rb");
    free(path);
    if (!f) continue;
    unsigned char *data = xrealloc(NULL, FUZZ_MAX_SEED);
    size_t len = fread(data, 1, FUZZ_MAX_SEED, f);
    int too_big = fgetc(f) != EOF;
    fclose(f);
    if (too_big) {
      fprintf(stderr, "fuzz_readers: skipping %s (over %d bytes)\n",
              ent->d_name, FUZZ_MAX_SEED);
      free(data);
      continue;
    }
    *seeds = xrealloc(*seeds, (size_t)(n + 1) * sizeof **seeds);
    fuzz_seed *s = &(*seeds)[n++];
    s->name = strdup(ent->d_name);
    strcpy(s->ext, dot);
    s->data = data;
    s->len = len;
  }
  closedir(d);
  if (n) qsort(*seeds, (size_t)n, sizeof **seeds, cmp_seed);
  return n;
}

static int write_input(const char *path, const fuzz_buf *b) {
  FILE *f = fopen(path, "wb");
  if (!f) return 0;
  int ok = fwrite(b->data, 1, b->len, f) == b->len;
  return fclose(f) == 0 && ok;
}

/* Walk every value of every field of a solution that was read; 0 if the
 * solution contradicts itself. */
static int walk_sol(pa_sol *sol) {
  int dim = pa_sol_dim(sol), nfield = pa_sol_nfield(sol);
  pa_idx nvert = pa_sol_nvert(sol);
  volatile double sum = 0;
  if ((dim != 2 && dim != 3) || nvert < 0 || nfield < 0) return 0;
  if (!pa_sol_origin(sol)) return 0;
  for (int k = 0; k < nfield; k++) {
    pa_sol_kind kind;
    int ncomp;
    double *v;
    if (pa_sol_field(sol, k, &kind, &ncomp, &v) != PA_SUCCESS) return 0;
    int want = kind == PA_SOL_SCALAR   ? 1
               : kind == PA_SOL_VECTOR ? dim
               : kind == PA_SOL_TENSOR ? dim * (dim + 1) / 2
                                       : -1;
    pa_sol_at at;
    pa_idx n;
    if (pa_sol_field_where(sol, k, &at, &n, NULL) != PA_SUCCESS || n < 0 ||
        (at == PA_SOL_AT_VERTICES && n != nvert))
      return 0;
    if (ncomp != want || (n && !v)) return 0;
    for (size_t i = 0; i < (size_t)n * (size_t)ncomp; i++)
      sum += v[i];
  }
  (void)sum;
  return 1;
}

/* Remesh a mesh that passed pa_mesh_check to a uniform size (see
 * FUZZ_REMESH_DIV): 1 when remeshed, 0 when the size is not a number (a
 * bounding box out of range: nothing to ask), -1 when the contract broke
 * (an internal error, an error without a message, or a result that fails
 * the check). */
static int remesh_valid(pa_mesh *mesh) {
  int dim = pa_mesh_dim(mesh);
  pa_idx nv = pa_mesh_nvert(mesh);
  const double *x = pa_mesh_coords(mesh);
  double lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0}, d2 = 0;
  for (pa_idx i = 0; i < nv; i++)
    for (int c = 0; c < dim; c++) {
      double v = x[(size_t)dim * i + c];
      if (i == 0 || v < lo[c]) lo[c] = v;
      if (i == 0 || v > hi[c]) hi[c] = v;
    }
  for (int c = 0; c < dim; c++)
    d2 += (hi[c] - lo[c]) * (hi[c] - lo[c]);
  double h = sqrt(d2) / FUZZ_REMESH_DIV;
  if (!(h > 0) || !isfinite(h) || !isnormal(h)) return 0;
  pa_remesh_opts opts;
  pa_remesh_opts_default(&opts);
  opts.hsiz = h;
  opts.mem_mb = FUZZ_REMESH_MB;
  opts.verbosity = -1;
  pa_remesh_report rep;
  pa_clear_error();
  pa_status st = pa_remesh(pa_remesher_builtin(), mesh, &opts, &rep);
  if (st != PA_SUCCESS) return st == PA_ERR_INTERNAL || !pa_last_error()[0] ? -1 : 1;
  return pa_mesh_check(mesh) == PA_SUCCESS ? 1 : -1;
}

int main(int argc, char **argv) {
  if (argc != 5) {
    fprintf(stderr, "usage: fuzz_readers medit-mesh|medit-sol|gmsh CORPUS_DIR "
                    "ITERATIONS SEED\n");
    return 2;
  }
  const char *reader = argv[1];
  long niter = atol(argv[3]);
  unsigned long long seed = strtoull(argv[4], NULL, 10);
  if (!ext_accepted(reader, ".mesh") && !ext_accepted(reader, ".sol") &&
      !ext_accepted(reader, ".msh")) {
    fprintf(stderr, "fuzz_readers: unknown reader '%s'\n", reader);
    return 2;
  }
  fuzz_seed *seeds;
  int nseed = load_corpus(reader, argv[2], &seeds);
  if (!nseed) {
    fprintf(stderr, "fuzz_readers: no %s seed in %s\n", reader, argv[2]);
    return 2;
  }
  /* Mix the seed so that seeds 0, 1, 2 give unrelated streams (0 would stop
   * xorshift). */
  rng_state = (seed + 1) * 0x9e3779b97f4a7c15ull;
  if (!rng_state) rng_state = 88172645463325252ull;

  fuzz_buf b = {NULL, 0, 0};
  char path[32] = "", prev[32] = "";
  long nok = 0, nerr = 0, nvalid = 0, nremeshed = 0, nbad = 0;
  for (long it = 0; it < niter; it++) {
    const fuzz_seed *s = &seeds[rng_below((size_t)nseed)];
    b.len = 0;
    buf_splice(&b, 0, 0, s->data, s->len);
    int nmut = 1 + (int)rng_below(FUZZ_MAX_MUTATIONS);
    for (int m = 0; m < nmut; m++)
      mutate(&b);

    snprintf(path, sizeof path, "fuzz-last%s", s->ext);
    if (prev[0] && strcmp(prev, path)) remove(prev);
    strcpy(prev, path);
    if (!write_input(path, &b)) {
      fprintf(stderr, "fuzz_readers: cannot write %s\n", path);
      return 2;
    }

    pa_clear_error();
    pa_status st;
    int violation = 0;
    if (!strcmp(reader, "medit-sol")) {
      pa_sol *sol = NULL;
      st = pa_sol_read(path, &sol);
      if (st == PA_SUCCESS) {
        if (sol && walk_sol(sol))
          nvalid++;
        else
          violation = 1;
      } else if (sol) {
        violation = 1;
      }
      pa_sol_destroy(sol);
    } else {
      pa_mesh *mesh = NULL;
      st = pa_mesh_read(path, &mesh);
      if (st == PA_SUCCESS) {
        if (!mesh) {
          violation = 1;
        } else {
          /* as the CLI reads a mesh: the missing boundary completed */
          pa_clear_error();
          pa_status cst = pa_mesh_build_boundary(mesh, 0, NULL);
          if (cst == PA_SUCCESS) cst = pa_mesh_check(mesh);
          if (cst == PA_SUCCESS) {
            nvalid++;
            int r = remesh_valid(mesh);
            if (r < 0) violation = 1;
            nremeshed += r > 0;
          } else if (!pa_last_error()[0]) {
            violation = 1;
          }
        }
      } else if (mesh) {
        violation = 1;
      }
      pa_mesh_destroy(mesh);
    }
    if (st == PA_SUCCESS) {
      nok++;
    } else {
      nerr++;
      if (!pa_last_error()[0] || st == PA_ERR_INTERNAL) violation = 1;
    }
    if (violation) {
      char keep[64];
      snprintf(keep, sizeof keep, "fuzz-violation-%ld%s", it, s->ext);
      write_input(keep, &b);
      fprintf(stderr,
              "fuzz_readers: iteration %ld (seed file %s): status '%s', "
              "message '%s': contract broken, input kept as %s\n",
              it, s->name, pa_status_string(st), pa_last_error(), keep);
      nbad++;
    }
  }
  if (prev[0]) remove(prev);

  size_t leaked = pa_memory_current();
  printf("fuzz_readers %s: %ld runs, %ld read (%ld valid, %ld remeshed), "
         "%ld errors, %ld violations, %zu bytes leaked\n",
         reader, niter, nok, nvalid, nremeshed, nerr, nbad, leaked);
  for (int i = 0; i < nseed; i++) {
    free(seeds[i].name);
    free(seeds[i].data);
  }
  free(seeds);
  free(b.data);
  return nbad || leaked ? 1 : 0;
}
