/*
 * checkpoint.c -- checkpoints of the parallel adaptation loop
 * (pa_adapt_opts.checkpoint_dir) and the resume from the latest one
 * (pa_dmesh_adapt_resume, through pa__adapt_restore).
 *
 * A checkpoint directory DIR holds, after K iterations:
 *  - the distributed set DIR/iter-K (pa_dmesh_write: DIR/iter-K.<r>.meshb,
 *    DIR/iter-K.manifest and the ParaView files), each rank's owned
 *    elements with their vertices, boundary entities, global ids, owners,
 *    metric, fields and user values -- the element value PA_ADAPT_DONE_VALUE of
 *    the loop among them;
 *  - the text file DIR/checkpoint (format below): the number of ranks, the
 *    set's name and the size and FNV-1a checksum of its manifest, the loop's
 *    state (pa__loop, the report so far included) and the options that can
 *    change the result.
 *
 * Invariants:
 *  - DIR/checkpoint names a complete set: the set is committed on every rank
 *    (one output transaction per rank, pa__output_end) before rank 0 writes
 *    DIR/checkpoint, which is renamed into place (pa__out_commit) before the
 *    files of older sets, and temporaries left by a killed write, are
 *    removed in the same commit. A process killed at any point leaves
 *    DIR/checkpoint naming either the new set or the previous one, intact;
 *  - what a resume reads is what was written: DIR/checkpoint holds the
 *    manifest's size and checksum, the manifest those of every rank file
 *    (pa_dmesh_read checks them), and every line of DIR/checkpoint must be
 *    present and well formed, up to its closing "end" line;
 *  - a set read on as many ranks as wrote it gives each rank its own file,
 *    and the build pipeline numbers the entities canonically (owned ones by
 *    global id, then ghosts: dmesh.h), as the loop's reintegration does; so
 *    each rank gets back the local mesh it had, in the same order, and the
 *    resumed loop continues bit for bit. Doubles are written with 17
 *    significant digits, which read back exactly.
 *
 * Format of DIR/checkpoint (one "key value..." per line):
 *   padapt-checkpoint 1
 *   ranks P / dim D / overlap K / set iter-K / manifest BYTES HASH(hex)
 *   loop.FIELD VALUE           every field of loop_fields
 *   iteration V1 V2 ...        one per recorded iteration (iter_fields)
 *   option NAME VALUE          every option of opt_fields, then the remesher
 *   end
 */
#include "adapt/piece.h"
#include "io/io.h"

#include <dirent.h>
#include <errno.h>
#include <inttypes.h>
#include <stddef.h>
#include <stdio.h>
#include <sys/stat.h>

#define CKPT_VERSION 1
/* Name of the state file in the checkpoint directory. */
#define CKPT_FILE "checkpoint"
/* Prefix of the sets' files: iter-K.<...>. */
#define CKPT_SET_PREFIX "iter-"
/* Longest line of the state file (an iteration line holds 13 numbers). */
#define CKPT_LINE 1024

/* A field of a struct written to the state file: name, type ('i' int, 'u'
 * unsigned, 'l' long, 'g' pa_gid, 'd' double) and offset. */
typedef struct field {
  const char *name;
  char type;
  size_t off;
} field;

#define LOOP(t, f)                                                             \
  { #f, t, offsetof(pa__loop, f) }
static const field loop_fields[] = {LOOP('i', iter),
                                    LOOP('d', least),
                                    LOOP('i', nostep),
                                    LOOP('i', lastpieces),
                                    LOOP('i', lastfailed),
                                    LOOP('u', changed),
                                    LOOP('d', time),
                                    LOOP('i', rep.nranks),
                                    LOOP('i', rep.niter),
                                    LOOP('g', rep.nelem_initial),
                                    LOOP('g', rep.nvert_initial),
                                    LOOP('g', rep.ntagged_left),
                                    LOOP('l', rep.npieces),
                                    LOOP('l', rep.nfailed),
                                    LOOP('d', rep.t_tag),
                                    LOOP('d', rep.t_pieces),
                                    LOOP('d', rep.t_gather),
                                    LOOP('d', rep.t_remesh),
                                    LOOP('d', rep.t_reintegrate),
                                    LOOP('d', rep.remesh_busy),
                                    LOOP('d', rep.remesh_cpu),
                                    LOOP('l', rep.nsplit),
                                    LOOP('l', rep.ncollapse),
                                    LOOP('l', rep.nswap),
                                    LOOP('l', rep.nmove),
                                    LOOP('d', rep.bytes_moved),
                                    LOOP('i', rep.transfer.nfield),
                                    LOOP('l', rep.transfer.nfast),
                                    LOOP('l', rep.transfer.nclip),
                                    LOOP('l', rep.transfer.nout),
                                    LOOP('d', rep.transfer.defect),
                                    LOOP('d', rep.transfer.uncovered),
                                    LOOP('d', rep.transfer.lost),
                                    LOOP('d', rep.transfer.time_s),
                                    LOOP('d', rep.transfer.cpu_s),
                                    LOOP('i', rep.niter_recorded)};
#define NLOOP (int)(sizeof loop_fields / sizeof *loop_fields)

#define ITER(t, f)                                                             \
  { #f, t, offsetof(pa_adapt_iter, f) }
static const field iter_fields[] = {
    ITER('i', iter),       ITER('g', ntagged),       ITER('g', nelem),
    ITER('i', npieces),    ITER('i', nfailed),       ITER('d', imbalance),
    ITER('d', t_tag),      ITER('d', t_pieces),      ITER('d', t_gather),
    ITER('d', t_remesh),   ITER('d', t_reintegrate), ITER('d', remesh_busy),
    ITER('d', remesh_cpu), ITER('d', bytes_moved),    ITER('d', mem_tag),     ITER('d', mem_pieces),
    ITER('d', mem_gather),     ITER('d', mem_remesh),  ITER('d', mem_reintegrate),
    ITER('d', mem_after),      ITER('l', nsplit),      ITER('l', ncollapse),
    ITER('l', nswap),          ITER('l', nmove)};
#define NITER (int)(sizeof iter_fields / sizeof *iter_fields)

/* The options that can change the result (not the callbacks, the
 * checkpoint directory nor the verbosity). */
#define OPT(t, f)                                                              \
  { #f, t, offsetof(pa_adapt_opts, f) }
static const field opt_fields[] = {OPT('d', remesh.hmin),
                                   OPT('d', remesh.hmax),
                                   OPT('d', remesh.hsiz),
                                   OPT('d', remesh.hgrad),
                                   OPT('d', remesh.hgradreq),
                                   OPT('d', remesh.hausd),
                                   OPT('d', remesh.angle),
                                   OPT('i', remesh.no_angle),
                                   OPT('i', remesh.no_insert),
                                   OPT('i', remesh.no_swap),
                                   OPT('i', remesh.no_move),
                                   OPT('i', remesh.no_surf),
                                   OPT('i', remesh.trusted),
                                   OPT('i', remesh.no_stats),
                                   OPT('d', mem_mb),
                                   OPT('d', qual_threshold),
                                   OPT('i', user_tags_only),
                                   OPT('i', max_iter),
                                   OPT('i', pieces_per_rank),
                                   OPT('i', skin_layers),
                                   OPT('i', skin_layers_later),
                                   OPT('d', min_piece_work),
                                   OPT('d', min_piece_ratio),
                                   OPT('d', rebalance_tol),
                                   OPT('i', rebalance),
                                   OPT('i', check_pieces)};
#define NOPT (int)(sizeof opt_fields / sizeof *opt_fields)

/* The value of field f of the struct at base, as written ("%.17g" for
 * doubles: they read back exactly). */
static void format_value(const field *f, const void *base, char *buf,
                         size_t len) {
  const char *p = (const char *)base + f->off;
  switch (f->type) {
  case 'i':
    snprintf(buf, len, "%d", *(const int *)p);
    break;
  case 'u':
    snprintf(buf, len, "%u", *(const unsigned *)p);
    break;
  case 'l':
    snprintf(buf, len, "%ld", *(const long *)p);
    break;
  case 'g':
    snprintf(buf, len, "%lld", (long long)*(const pa_gid *)p);
    break;
  default:
    snprintf(buf, len, "%.17g", *(const double *)p);
    break;
  }
}

/* Parse the number at s into field f of the struct at base; *end: after
 * it. Returns 1 if s starts with a number of the field's type. */
static int parse_value(const field *f, void *base, const char *s, char **end) {
  char *p = (char *)base + f->off;
  errno = 0;
  if (f->type == 'd') {
    double x = strtod(s, end);
    if (*end == s || errno) return 0;
    *(double *)p = x;
    return 1;
  }
  long long x = strtoll(s, end, 10);
  if (*end == s || errno) return 0;
  switch (f->type) {
  case 'i':
    *(int *)p = (int)x;
    return x >= INT32_MIN && x <= INT32_MAX;
  case 'u':
    *(unsigned *)p = (unsigned)x;
    return x >= 0 && x <= UINT32_MAX;
  case 'l':
    *(long *)p = (long)x;
    return 1;
  default:
    *(pa_gid *)p = (pa_gid)x;
    return 1;
  }
}

static const char *remesher_name(const pa_adapt_opts *o) {
  const pa_remesher *r = o->remesher ? o->remesher : pa_remesher_builtin();
  return r->name ? r->name : "?";
}

/* ---- writing ---- */

/* Rank 0: write dir/checkpoint for set (its manifest's bytes and hash). */
static pa_status write_state(const char *path, const pa_dmesh *dm,
                             const pa_adapt_opts *o, const pa__loop *L,
                             const char *set, int64_t mbytes, uint64_t mhash) {
  pa_status st = PA_SUCCESS;
  pa__outfile out;
  char v[64];
  memset(&out, 0, sizeof out);
  PA_CALL(pa__out_open(&out, path));
  FILE *fp = out.fp;
  fprintf(fp,
          "padapt-checkpoint %d\nranks %d\ndim %d\noverlap %d\nset %s\n"
          "manifest %" PRId64 " %016" PRIx64 "\n",
          CKPT_VERSION, dm->size, dm->dim, dm->overlap, set, mbytes, mhash);
  for (int k = 0; k < NLOOP; k++) {
    format_value(&loop_fields[k], L, v, sizeof v);
    fprintf(fp, "loop.%s %s\n", loop_fields[k].name, v);
  }
  for (int i = 0; i < L->rep.niter_recorded; i++) {
    fputs("iteration", fp);
    for (int k = 0; k < NITER; k++) {
      format_value(&iter_fields[k], &L->rep.iters[i], v, sizeof v);
      fprintf(fp, " %s", v);
    }
    fputc('\n', fp);
  }
  for (int k = 0; k < NOPT; k++) {
    format_value(&opt_fields[k], o, v, sizeof v);
    fprintf(fp, "option %s %s\n", opt_fields[k].name, v);
  }
  fprintf(fp, "option remesher %s\nend\n", remesher_name(o));
  PA_CALL(pa__out_commit(&out));
cleanup:
  pa__out_abort(&out);
  return st;
}

/* Rank 0, in the open output transaction: remove the files of the sets
 * other than `set` and the temporaries left by killed writes (iter-*,
 * checkpoint.tmp.*) except the state file's own temporary. Only regular
 * files: anything else of those names is left alone. */
static pa_status remove_older(const char *dir, const char *set,
                              const char *statepath) {
  pa_status st = PA_SUCCESS;
  char keep[128], p[4200];
  const char *mine = pa__out_tmppath(statepath);
  DIR *d = opendir(dir);
  PA_CHECK(d, PA_ERR_IO, "%s: cannot list the checkpoint directory: %s", dir,
           strerror(errno));
  snprintf(keep, sizeof keep, "%s.", set);
  for (struct dirent *e; (e = readdir(d));) {
    const char *n = e->d_name;
    int ours = !strncmp(n, CKPT_SET_PREFIX, strlen(CKPT_SET_PREFIX)) &&
               (strncmp(n, keep, strlen(keep)) || strstr(n, ".tmp."));
    ours |= !strncmp(n, CKPT_FILE ".tmp.", strlen(CKPT_FILE ".tmp."));
    struct stat sb;
    snprintf(p, sizeof p, "%s/%s", dir, n);
    if (ours && !(mine && !strcmp(p, mine)) && lstat(p, &sb) == 0 &&
        S_ISREG(sb.st_mode))
      PA_CALL(pa__out_remove(p));
  }
cleanup:
  if (d) closedir(d);
  return st;
}

pa_status pa__adapt_checkpoint(pa_dmesh *dm, const pa_adapt_opts *o,
                               const pa__loop *L, double elapsed) {
  pa_status st = PA_SUCCESS;
  const char *dir = o->checkpoint_dir;
  char set[64], setpath[4200], mpath[4200], statepath[4200];
  pa__loop S = *L;
  pa_output *tx = NULL;
  S.time = elapsed;
  snprintf(set, sizeof set, CKPT_SET_PREFIX "%d", L->iter);
  snprintf(setpath, sizeof setpath, "%s/%s.meshb", dir, set);
  snprintf(mpath, sizeof mpath, "%s/%s.manifest", dir, set);
  snprintf(statepath, sizeof statepath, "%s/" CKPT_FILE, dir);
  if (dm->rank == 0 && mkdir(dir, 0777) != 0 && errno != EEXIST)
    st = pa__error(PA_ERR_IO, __FILE__, __LINE__,
                   "%s: cannot create the checkpoint directory: %s", dir,
                   strerror(errno));
  PA_CALL(pa__agree(dm->comm, st));
  PA_CALL(pa_dmesh_write(dm, setpath));
  if (dm->rank == 0) {
    int64_t mbytes = 0;
    uint64_t mhash = 0;
    PA_CALL(pa__file_fnv1a64(mpath, &mbytes, &mhash));
    PA_CALL(pa_output_begin(&tx));
    PA_CALL(write_state(statepath, dm, o, &S, set, mbytes, mhash));
    PA_CALL(remove_older(dir, set, statepath));
    st = pa_output_commit(tx);
    tx = NULL;
    PA_CALL(st);
    pa__info(2, "padapt: checkpoint %s after iteration %d\n", setpath, L->iter);
  }
cleanup:
  if (tx) pa_output_abort(tx);
  return pa__agree_end(dm->comm, st);
}

/* ---- reading ---- */

/* What rank 0 reads from dir/checkpoint. */
typedef struct state {
  pa__loop L;
  int ranks, dim, overlap;
  char set[64];
  int64_t mbytes;
  uint64_t mhash;
} state;

/* The next line of fp into line (without its newline); 0 at the end. */
static int next_line(FILE *fp, char *line, int *lineno) {
  if (!fgets(line, CKPT_LINE, fp)) return 0;
  (*lineno)++;
  line[strcspn(line, "\n")] = '\0';
  return 1;
}

/* Rank 0: read and check path (the state file), options against o and the
 * number of ranks against size. */
static pa_status read_state(const char *path, const pa_adapt_opts *o, int size,
                            state *S) {
  pa_status st = PA_SUCCESS;
  char line[CKPT_LINE], key[64], *p;
  int ln = 0, ver = 0, nseen = 0, nopt = 0, niter = 0, end = 0, have = 0;
  uint8_t seen[NLOOP];
  FILE *fp = fopen(path, "r");
  memset(seen, 0, sizeof seen);
  memset(S, 0, sizeof *S);
  PA_CHECK(fp, PA_ERR_IO, "%s: cannot open the checkpoint: %s", path,
           strerror(errno));
  PA_CHECK(next_line(fp, line, &ln) &&
               sscanf(line, "padapt-checkpoint %d", &ver) == 1,
           PA_ERR_FORMAT, "%s:1: not a padapt checkpoint", path);
  PA_CHECK(ver == CKPT_VERSION, PA_ERR_UNSUPPORTED,
           "%s:1: checkpoint version %d, expected %d", path, ver, CKPT_VERSION);
  while (!end && next_line(fp, line, &ln)) {
    int n = 0;
    PA_CHECK(sscanf(line, "%63s %n", key, &n) == 1, PA_ERR_FORMAT,
             "%s:%d: empty line", path, ln);
    const char *val = line + n;
    if (!strcmp(key, "end")) {
      end = 1;
    } else if (!strcmp(key, "ranks")) {
      have |= sscanf(val, "%d", &S->ranks) == 1;
    } else if (!strcmp(key, "dim")) {
      have |= (sscanf(val, "%d", &S->dim) == 1) << 1;
    } else if (!strcmp(key, "overlap")) {
      have |= (sscanf(val, "%d", &S->overlap) == 1 && S->overlap >= 0) << 2;
    } else if (!strcmp(key, "set")) {
      have |= (sscanf(val, "%63s", S->set) == 1 &&
               !strncmp(S->set, CKPT_SET_PREFIX, strlen(CKPT_SET_PREFIX)) &&
               !strchr(S->set, '/'))
              << 3;
    } else if (!strcmp(key, "manifest")) {
      have |= (sscanf(val, "%" SCNd64 " %" SCNx64, &S->mbytes, &S->mhash) == 2)
              << 4;
    } else if (!strncmp(key, "loop.", 5)) {
      int k = 0;
      while (k < NLOOP && strcmp(key + 5, loop_fields[k].name))
        k++;
      PA_CHECK(k < NLOOP && parse_value(&loop_fields[k], &S->L, val, &p) && !*p,
               PA_ERR_FORMAT, "%s:%d: bad line '%s'", path, ln, line);
      nseen += !seen[k];
      seen[k] = 1;
    } else if (!strcmp(key, "iteration")) {
      PA_CHECK(niter < PA_ADAPT_MAX_ITERS, PA_ERR_FORMAT,
               "%s:%d: more than %d iterations", path, ln, PA_ADAPT_MAX_ITERS);
      p = (char *)val;
      for (int k = 0; k < NITER; k++)
        PA_CHECK(parse_value(&iter_fields[k], &S->L.rep.iters[niter], p, &p),
                 PA_ERR_FORMAT, "%s:%d: bad iteration line", path, ln);
      PA_CHECK(!*p, PA_ERR_FORMAT, "%s:%d: bad iteration line", path, ln);
      niter++;
    } else if (!strcmp(key, "option")) {
      char name[64], want[64], mine[64];
      int m = 0;
      PA_CHECK(sscanf(val, "%63s %63s%n", name, want, &m) == 2 && !val[m],
               PA_ERR_FORMAT, "%s:%d: bad option line", path, ln);
      if (!strcmp(name, "remesher")) {
        snprintf(mine, sizeof mine, "%s", remesher_name(o));
      } else {
        int k = 0;
        while (k < NOPT && strcmp(name, opt_fields[k].name))
          k++;
        PA_CHECK(k < NOPT, PA_ERR_FORMAT, "%s:%d: unknown option '%s'", path,
                 ln, name);
        format_value(&opt_fields[k], o, mine, sizeof mine);
      }
      PA_CHECK(!strcmp(want, mine), PA_ERR_ARG,
               "%s: the checkpointed run had %s %s, this one has %s: resume "
               "with the options of that run",
               path, name, want, mine);
      nopt++;
    } else {
      PA_FAIL(PA_ERR_FORMAT, "%s:%d: unknown line '%s'", path, ln, line);
    }
  }
  PA_CHECK(end, PA_ERR_FORMAT, "%s: truncated (no end line)", path);
  PA_CHECK(have == 31 && nseen == NLOOP && nopt == NOPT + 1, PA_ERR_FORMAT,
           "%s: incomplete checkpoint (a line is missing or bad)", path);
  PA_CHECK(niter == S->L.rep.niter_recorded && S->L.iter >= 1 &&
               S->L.iter == S->L.rep.niter && (S->dim == 2 || S->dim == 3),
           PA_ERR_FORMAT, "%s: inconsistent loop state", path);
  PA_CHECK(S->ranks == size, PA_ERR_ARG,
           "%s: written by a run on %d processes, this one has %d: resume on "
           "%d processes",
           path, S->ranks, size, S->ranks);
cleanup:
  if (fp) fclose(fp);
  return st;
}

/* Rank 0: read dir/checkpoint into *S and check it (options, ranks) and
 * the manifest it names. */
static pa_status load_state(const char *dir, const pa_adapt_opts *o, int size,
                            state *S) {
  pa_status st = PA_SUCCESS;
  char path[4200];
  int64_t bytes = 0;
  uint64_t hash = 0;
  snprintf(path, sizeof path, "%s/" CKPT_FILE, dir);
  PA_CALL(read_state(path, o, size, S));
  snprintf(path, sizeof path, "%s/%s.manifest", dir, S->set);
  PA_CALL(pa__file_fnv1a64(path, &bytes, &hash));
  PA_CHECK(bytes == S->mbytes && hash == S->mhash, PA_ERR_FORMAT,
           "%s: not the manifest %s/" CKPT_FILE " names (size or checksum "
           "differ)",
           path, dir);
cleanup:
  return st;
}

pa_status pa__adapt_restore(MPI_Comm comm, const char *dir,
                            const pa_adapt_opts *o, pa_dmesh **dmp,
                            pa__loop *L) {
  pa_status st = PA_SUCCESS;
  int rank, size;
  char path[4200];
  state S;
  pa_dmesh *dm = NULL;
  memset(&S, 0, sizeof S);
  *dmp = NULL;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  if (rank == 0) st = load_state(dir, o, size, &S);
  PA_CALL(pa__agree(comm, st));
  MPI_Bcast(&S, (int)sizeof S, MPI_BYTE, 0, comm);
  snprintf(path, sizeof path, "%s/%s.meshb", dir, S.set);
  PA_CALL(pa_dmesh_read(comm, path, S.overlap, &dm));
  PA_CHECK(dm->dim == S.dim && pa_dmesh_value_find(dm, PA_ADAPT_DONE_VALUE),
           PA_ERR_FORMAT,
           "%s: not the set of a checkpoint (dimension, or no element value "
           "'%s')",
           path, PA_ADAPT_DONE_VALUE);
  *L = S.L;
cleanup:
  st = pa__agree_end(comm, st);
  if (st)
    pa_dmesh_destroy(dm);
  else
    *dmp = dm;
  return st;
}
