/*
 * test_dmesh_io.c -- distributed I/O: round trip of a distributed set (same
 * and different numbers of ranks, through sub-communicators), gather from a
 * set, ParaView files, user values in the files, and bad sets (a missing rank file, inconsistent
 * interfaces) that must fail with the same error on every rank, never hang;
 * the manifest (a stale rank file of a write on more ranks or a modified one
 * is refused naming it; a write removes what would shadow the set) and the
 * output transaction (a write failing on one rank writes nothing anywhere;
 * inside a caller's transaction nothing appears before its end).
 */
#include "testutil.h"

#include <mpi.h>
#include <sys/stat.h>
#include <unistd.h>

static int rank, size;

/* 3D box with a metric and a field, on rank 0. */
static pa_mesh *input(void) {
  pa_mesh *m = NULL;
  if (rank != 0) return NULL;
  CHECK_OK(pa_mesh_generate_box(3, 5, &m));
  if (!m) return NULL;
  pa_idx nv = pa_mesh_nvert(m);
  double *h = malloc(sizeof(double) * nv), *f = malloc(sizeof(double) * 2 * nv);
  const double *x = pa_mesh_coords(m);
  for (pa_idx i = 0; i < nv; i++) {
    h[i] = 0.1 + x[3 * i];
    f[2 * i] = x[3 * i + 1];
    f[2 * i + 1] = -x[3 * i + 2];
  }
  CHECK_OK(pa_mesh_set_metric(m, 1, h));
  CHECK_OK(pa_mesh_add_field(m, "f", 2, f));
  pa_mesh_vert_flags(m)[3] |= PA_FLAG_CORNER | PA_FLAG_REQUIRED;
  free(h);
  free(f);
  return m;
}

static uint64_t checksum(pa_dmesh *dm) {
  uint64_t s = 0;
  CHECK_OK(pa_dmesh_checksum(dm, &s));
  return s;
}

static int file_exists(const char *p) { return access(p, F_OK) == 0; }

static void copy_file(const char *from, const char *to) {
  FILE *a = fopen(from, "rb"), *b = fopen(to, "wb");
  char buf[65536];
  size_t n;
  CHECK(a && b);
  if (a && b)
    while ((n = fread(buf, 1, sizeof buf, a)) > 0) fwrite(buf, 1, n, b);
  if (a) fclose(a);
  if (b) fclose(b);
}

static void test_round_trip(void) {
  pa_mesh *in = input();
  pa_dmesh *dm = NULL, *back = NULL;
  CHECK_OK(pa_dmesh_distribute(MPI_COMM_WORLD, 0, in, 1, &dm));
  if (!dm) {
    pa_mesh_destroy(in);
    return;
  }
  uint64_t ref = checksum(dm);
  CHECK_OK(pa_dmesh_write(dm, "io_w.meshb"));
  CHECK(pa_dmesh_is_set("io_w.meshb"));
  CHECK(pa_dmesh_is_set("io_w.mesh"));
  CHECK(!pa_dmesh_is_set("nothing.meshb"));
  CHECK(file_exists("io_w.pvtu"));
  char p[64];
  snprintf(p, sizeof p, "io_w.%d.vtu", rank);
  CHECK(file_exists(p));
  snprintf(p, sizeof p, "io_w.%d.meshb", rank);
  CHECK(file_exists(p));
  /* every per-rank file is a valid Medit mesh on its own */
  pa_mesh *part = NULL;
  CHECK_OK(pa_mesh_read(p, &part));
  if (part) CHECK(pa_mesh_nelem(part) == pa_dmesh_nowned(dm, PA_ELEMENT));
  pa_mesh_destroy(part);
  /* same number of ranks, two overlaps */
  for (int ov = 0; ov <= 2; ov += 2) {
    CHECK_OK(pa_dmesh_read(MPI_COMM_WORLD, "io_w.meshb", ov, &back));
    if (back) {
      CHECK_OK(pa_dmesh_check(back));
      CHECK(checksum(back) == ref);
      CHECK(pa_dmesh_nowned(back, PA_ELEMENT) == pa_dmesh_nowned(dm, PA_ELEMENT));
      CHECK(pa_mesh_metric_ncomp(pa_dmesh_mesh(back)) == 1);
      CHECK(pa_mesh_nfield(pa_dmesh_mesh(back)) == 1);
    }
    pa_dmesh_destroy(back);
    back = NULL;
  }
  /* gathered from the set = input */
  pa_mesh *g = NULL;
  CHECK_OK(pa_dmesh_read_gathered(MPI_COMM_WORLD, 0, "io_w.meshb", &g));
  if (rank == 0 && g && in) {
    CHECK(pa_mesh_nvert(g) == pa_mesh_nvert(in) && pa_mesh_nelem(g) == pa_mesh_nelem(in));
    if (pa_mesh_nvert(g) == pa_mesh_nvert(in) && pa_mesh_nelem(g) == pa_mesh_nelem(in)) {
      CHECK(!memcmp(pa_mesh_coords(g), pa_mesh_coords(in), sizeof(double) * 3 * pa_mesh_nvert(in)));
      CHECK(!memcmp(pa_mesh_elems(g), pa_mesh_elems(in), sizeof(pa_idx) * 4 * pa_mesh_nelem(in)));
      CHECK(!memcmp(pa_mesh_metric(g), pa_mesh_metric(in), sizeof(double) * pa_mesh_nvert(in)));
      CHECK(!memcmp(pa_mesh_vert_flags(g), pa_mesh_vert_flags(in), pa_mesh_nvert(in)));
    }
  }
  CHECK((g != NULL) == (rank == 0));
  pa_mesh_destroy(g);
  /* a sequential file through the same entry points */
  if (rank == 0 && in) CHECK_OK(pa_mesh_write(in, "io_seq.meshb", NULL));
  MPI_Barrier(MPI_COMM_WORLD);
  CHECK(!pa_dmesh_is_set("io_seq.meshb"));
  CHECK_OK(pa_dmesh_read(MPI_COMM_WORLD, "io_seq.meshb", 1, &back));
  if (back) {
    CHECK_OK(pa_dmesh_check(back));
    CHECK(checksum(back) == ref);
  }
  pa_dmesh_destroy(back);
  back = NULL;
  /* different numbers of ranks: a sub-communicator of size - 1 ranks */
  if (size >= 2) {
    MPI_Comm sub;
    MPI_Comm_split(MPI_COMM_WORLD, rank < size - 1 ? 0 : MPI_UNDEFINED, rank, &sub);
    if (sub != MPI_COMM_NULL) {
      /* fewer readers than writers */
      CHECK_OK(pa_dmesh_read(sub, "io_w.meshb", 1, &back));
      if (back) {
        CHECK_OK(pa_dmesh_check(back));
        CHECK(checksum(back) == ref);
        CHECK_OK(pa_dmesh_write(back, "io_sub.meshb"));
      }
      pa_dmesh_destroy(back);
      back = NULL;
      MPI_Comm_free(&sub);
    }
    MPI_Barrier(MPI_COMM_WORLD);
    /* more readers than writers */
    CHECK_OK(pa_dmesh_read(MPI_COMM_WORLD, "io_sub.meshb", 1, &back));
    if (back) {
      CHECK_OK(pa_dmesh_check(back));
      CHECK(checksum(back) == ref);
      pa_gid nel = pa_dmesh_nowned(back, PA_ELEMENT);
      MPI_Allreduce(MPI_IN_PLACE, &nel, 1, MPI_INT64_T, MPI_MIN, MPI_COMM_WORLD);
      CHECK(nel > 0); /* repartitioned: no rank left empty */
    }
    pa_dmesh_destroy(back);
    back = NULL;
  }
  pa_dmesh_destroy(dm);
  pa_mesh_destroy(in);
}

/* Values of test_values: a function of the global id (and component). */
static double vval(pa_gid g, int c) { return 0.5 * (double)g + c; }
typedef struct sh2 { short a, b; } sh2;

/* Set (fill = 1) or check (fill = 0) the values of test_values on every
 * local entity holding them. */
static void values_fill(pa_dmesh *dm, int fill) {
  pa_dmesh_value *vd = pa_dmesh_value_find(dm, "vd"),
                 *ei = pa_dmesh_value_find(dm, "ei"),
                 *bs = pa_dmesh_value_find(dm, "bsub"),
                 *vs = pa_dmesh_value_find(dm, "vs");
  CHECK(vd && ei && bs && vs);
  if (!vd || !ei || !bs || !vs) return;
  pa_idx n, nown, bad = 0;
  double *d = pa_dmesh_value_data(vd, &n, &nown);
  const pa_gid *g = pa_dmesh_gids(dm, PA_VERTEX);
  for (pa_idx i = 0; i < n; i++)
    for (int c = 0; c < 3; c++) {
      if (fill) d[3 * i + c] = vval(g[i], c);
      else bad += d[3 * i + c] != vval(g[i], c);
    }
  sh2 *h = pa_dmesh_value_data(vs, &n, &nown);
  for (pa_idx i = 0; i < n; i++) {
    if (fill) h[i] = (sh2){(short)(g[i] % 1000), (short)-(g[i] % 777)};
    else bad += h[i].a != (short)(g[i] % 1000) || h[i].b != (short)-(g[i] % 777);
  }
  int64_t *e = pa_dmesh_value_data(ei, &n, &nown);
  g = pa_dmesh_gids(dm, PA_ELEMENT);
  for (pa_idx i = 0; i < n; i++) {
    if (fill) e[i] = 7 * g[i] + 1;
    else bad += e[i] != 7 * g[i] + 1;
  }
  float *b = pa_dmesh_value_data(bs, &n, &nown);
  const pa_idx *ent = pa_dmesh_value_entities(bs);
  g = pa_dmesh_gids(dm, PA_BOUNDARY);
  for (pa_idx i = 0; i < n; i++) {
    if (fill) b[i] = (float)g[ent[i]];
    else bad += b[i] != (float)g[ent[i]];
  }
  if (!fill) CHECK(bad == 0);
}

/* User values (all entities and a sub-class, predefined and derived types)
 * survive a write and a read at the same and at another number of ranks. */
static void test_values(void) {
  pa_mesh *in = input();
  pa_dmesh *dm = NULL, *back = NULL;
  pa_dmesh_value *v;
  MPI_Datatype t2;
  MPI_Type_contiguous(2, MPI_SHORT, &t2);
  MPI_Type_commit(&t2);
  CHECK_OK(pa_dmesh_distribute(MPI_COMM_WORLD, 0, in, 1, &dm));
  pa_mesh_destroy(in);
  if (!dm) {
    MPI_Type_free(&t2);
    return;
  }
  int32_t bref = pa_mesh_bdry_refs(pa_dmesh_mesh(dm))[0];
  MPI_Allreduce(MPI_IN_PLACE, &bref, 1, MPI_INT32_T, MPI_MIN, MPI_COMM_WORLD);
  CHECK_OK(pa_dmesh_value_add(dm, PA_VERTEX, "vd", MPI_DOUBLE, 3, -1, &v));
  CHECK_OK(pa_dmesh_value_add(dm, PA_ELEMENT, "ei", MPI_INT64_T, 1, -1, &v));
  CHECK_OK(pa_dmesh_value_add(dm, PA_BOUNDARY, "bsub", MPI_FLOAT, 1, bref, &v));
  CHECK_OK(pa_dmesh_value_add(dm, PA_VERTEX, "vs", t2, 1, -1, &v));
  values_fill(dm, 1);
  uint64_t ref = checksum(dm);
  CHECK_OK(pa_dmesh_write(dm, "io_v.meshb"));
  CHECK_OK(pa_dmesh_read(MPI_COMM_WORLD, "io_v.meshb", 1, &back));
  if (back) {
    CHECK_OK(pa_dmesh_check(back));
    values_fill(back, 0);
    pa_dmesh_value *w = pa_dmesh_value_find(back, "vs");
    if (w) {
      pa_entity kind;
      const char *name;
      MPI_Datatype type;
      int ncomp;
      int32_t r;
      pa_dmesh_value_info(w, &kind, &name, &type, &ncomp, &r);
      CHECK(type == MPI_BYTE && ncomp == 4); /* a derived type comes back as bytes */
    }
    CHECK(checksum(back) == ref);
  }
  pa_dmesh_destroy(back);
  back = NULL;
  if (size >= 2) { /* fewer readers: repartitioned, values follow */
    MPI_Comm sub;
    MPI_Comm_split(MPI_COMM_WORLD, rank < size - 1 ? 0 : MPI_UNDEFINED, rank, &sub);
    if (sub != MPI_COMM_NULL) {
      CHECK_OK(pa_dmesh_read(sub, "io_v.meshb", 1, &back));
      if (back) {
        CHECK_OK(pa_dmesh_check(back));
        values_fill(back, 0);
        CHECK(checksum(back) == ref);
      }
      pa_dmesh_destroy(back);
      MPI_Comm_free(&sub);
    }
  }
  pa_dmesh_destroy(dm);
  MPI_Type_free(&t2);
}

/* The number of cells the ParaView file path declares (0 if unreadable). */
static long long vtu_cells(const char *path) {
  char buf[4096];
  FILE *fp = fopen(path, "rb");
  if (!fp) return 0;
  size_t n = fread(buf, 1, sizeof buf - 1, fp);
  fclose(fp);
  buf[n] = '\0';
  const char *p = strstr(buf, "NumberOfCells=\"");
  return p ? atoll(p + strlen("NumberOfCells=\"")) : 0;
}

/* The ParaView files of a set show every entity once: the feature edges on
 * the interfaces between ranks (in owned elements of several ranks, so in
 * several rank files, which need them) were in several .vtu pieces. The
 * cube's edges as feature edges, the elements dealt to the ranks in a
 * scattered order so that many of them cross interfaces. */
static void test_vtu_once(void) {
  pa_mesh *in = NULL;
  pa_dmesh *dm = NULL;
  if (rank == 0) {
    CHECK_OK(pa_mesh_generate_box(3, 4, &in));
    if (!in) return;
    const double *x = pa_mesh_coords(in);
    const pa_idx *b = pa_mesh_bdrys(in);
    pa_idx nb = pa_mesh_nbdry(in), *seen = malloc(sizeof(pa_idx) * 2 * 6 * nb);
    int nseen = 0;
    for (pa_idx f = 0; f < nb; f++)
      for (int i = 0; i < 3; i++) {
        pa_idx e[2] = {b[3 * f + i], b[3 * f + (i + 1) % 3]};
        int onedge = 1; /* both ends on one edge of the cube */
        for (int j = 0; j < 2; j++) {
          int nx = 0;
          for (int c = 0; c < 3; c++) nx += x[3 * e[j] + c] == 0 || x[3 * e[j] + c] == 1;
          onedge &= nx >= 2;
        }
        int k = 0, dup = 0;
        for (int c = 0; c < 3; c++) /* the same two extreme coordinates */
          k += (x[3 * e[0] + c] == 0 || x[3 * e[0] + c] == 1) &&
               x[3 * e[0] + c] == x[3 * e[1] + c];
        for (int q = 0; q < nseen && !dup; q++)
          dup = (seen[2 * q] == e[0] && seen[2 * q + 1] == e[1]) ||
                (seen[2 * q] == e[1] && seen[2 * q + 1] == e[0]);
        if (!onedge || k < 2 || dup) continue;
        seen[2 * nseen] = e[0];
        seen[2 * nseen + 1] = e[1];
        nseen++;
        CHECK_OK(pa_mesh_add_edge(in, e, 1, NULL));
      }
    free(seen);
    CHECK(nseen == 12 * 4);
  }
  CHECK_OK(pa_dmesh_distribute(MPI_COMM_WORLD, 0, in, 0, &dm));
  pa_mesh_destroy(in);
  if (!dm) return;
  pa_idx ne = pa_dmesh_nowned(dm, PA_ELEMENT);
  int *part = malloc(sizeof(int) * (ne + 1));
  const pa_gid *eg = pa_dmesh_gids(dm, PA_ELEMENT);
  for (pa_idx e = 0; e < ne; e++) part[e] = (int)((eg[e] * 7919) % size);
  CHECK_OK(pa_dmesh_redistribute(dm, part, NULL));
  free(part);
  CHECK_OK(pa_dmesh_write(dm, "once.meshb"));
  long long cells = 0, want = pa_dmesh_nglobal(dm, PA_ELEMENT) +
                              pa_dmesh_nglobal(dm, PA_BOUNDARY) +
                              pa_dmesh_nglobal(dm, PA_EDGE);
  for (int r = 0; r < size; r++) {
    char p[64];
    snprintf(p, sizeof p, "once.%d.vtu", r);
    cells += vtu_cells(p);
  }
  CHECK(cells == want);
  if (cells != want && rank == 0)
    fprintf(stderr, "the pieces hold %lld cells, the set %lld\n", cells, want);
  pa_dmesh_destroy(dm);
}

/* The same status on every rank. */
static int same_everywhere(pa_status st) {
  int v = (int)st, mn, mx;
  MPI_Allreduce(&v, &mn, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
  MPI_Allreduce(&v, &mx, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
  return mn == mx;
}

static void test_bad_sets(void) {
  pa_mesh *in = input();
  pa_dmesh *dm = NULL, *back = NULL;
  char p[64];
  CHECK_OK(pa_dmesh_distribute(MPI_COMM_WORLD, 0, in, 0, &dm));
  pa_mesh_destroy(in);
  if (!dm) return;
  CHECK_OK(pa_dmesh_write(dm, "bad_a.meshb"));
  /* a missing rank file */
  MPI_Barrier(MPI_COMM_WORLD);
  if (rank == 0) {
    snprintf(p, sizeof p, "bad_a.%d.meshb", size - 1);
    CHECK(remove(p) == 0);
  }
  MPI_Barrier(MPI_COMM_WORLD);
  pa_status st = pa_dmesh_read(MPI_COMM_WORLD, "bad_a.meshb", 1, &back);
  CHECK(st == PA_ERR_IO);
  CHECK(back == NULL);
  if (size > 1) CHECK(strstr(pa_last_error(), "missing") != NULL);
  /* inconsistent interfaces: rank file 1 from another distribution */
  if (size >= 2) {
    int *part = malloc(sizeof(int) * (pa_dmesh_nowned(dm, PA_ELEMENT) + 1));
    for (pa_idx e = 0; e < pa_dmesh_nowned(dm, PA_ELEMENT); e++)
      part[e] = (rank + 1) % size;
    CHECK_OK(pa_dmesh_write(dm, "bad_b.meshb"));
    CHECK_OK(pa_dmesh_redistribute(dm, part, NULL));
    CHECK_OK(pa_dmesh_write(dm, "bad_c.meshb"));
    free(part);
    MPI_Barrier(MPI_COMM_WORLD);
    if (rank == 0) copy_file("bad_c.1.meshb", "bad_b.1.meshb");
    MPI_Barrier(MPI_COMM_WORLD);
    st = pa_dmesh_read(MPI_COMM_WORLD, "bad_b.meshb", 1, &back);
    CHECK(st == PA_ERR_FORMAT || st == PA_ERR_MESH);
    CHECK(back == NULL);
    /* a truncated file */
    if (rank == 0) {
      copy_file("bad_c.0.meshb", "bad_d.0.meshb");
      for (int r = 1; r < size; r++) {
        char a[64], b[64];
        snprintf(a, sizeof a, "bad_c.%d.meshb", r);
        snprintf(b, sizeof b, "bad_d.%d.meshb", r);
        copy_file(a, b);
      }
      CHECK(truncate("bad_d.0.meshb", 300) == 0);
    }
    MPI_Barrier(MPI_COMM_WORLD);
    st = pa_dmesh_read(MPI_COMM_WORLD, "bad_d.meshb", 1, &back);
    CHECK(st == PA_ERR_FORMAT);
    CHECK(back == NULL);
    int same = st, mn, mx;
    MPI_Allreduce(&same, &mn, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    MPI_Allreduce(&same, &mx, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
    CHECK(mn == mx);
  }
  pa_dmesh_destroy(dm);
  dm = NULL;
  /* one tetrahedron listed twice (the 3D remesher crashed on it), in a set
   * written by hand: the read refuses it on every rank, whether the two
   * copies are on one rank or on two */
  pa_mesh *two = NULL;
  if (rank == 0) {
    double x[4][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    pa_idx t[2][4] = {{0, 1, 2, 3}, {1, 0, 3, 2}};
    CHECK_OK(pa_mesh_create(3, &two));
    for (int i = 0; i < 4; i++) CHECK_OK(pa_mesh_add_vertex(two, x[i], 0, NULL));
    for (int i = 0; i < 2; i++) CHECK_OK(pa_mesh_add_elem(two, t[i], 1, NULL));
  }
  /* written on one rank: the partitioner's own check (debug builds)
   * refuses the dual graph of such a mesh */
  if (rank == 0) {
    CHECK_OK(pa_dmesh_distribute(MPI_COMM_SELF, 0, two, 0, &dm));
    if (dm) CHECK_OK(pa_dmesh_write(dm, "dup.meshb"));
    pa_dmesh_destroy(dm);
  }
  pa_mesh_destroy(two);
  MPI_Barrier(MPI_COMM_WORLD);
  for (int overlap = 0; overlap < 2; overlap++) {
    st = pa_dmesh_read(MPI_COMM_WORLD, "dup.meshb", overlap, &back);
    CHECK(st == PA_ERR_MESH);
    CHECK(back == NULL);
    CHECK(same_everywhere(st));
    CHECK(strstr(pa_last_error(), "dup.meshb") != NULL);
    CHECK(strstr(pa_last_error(), "same") != NULL);
    pa_dmesh_destroy(back);
  }
}


/* Reading path fails with a format error naming file on every rank (the
 * message of the rank that found it travels to all). */
static void check_refused(const char *path, const char *file) {
  pa_dmesh *back = NULL;
  pa_status st = pa_dmesh_read(MPI_COMM_WORLD, path, 1, &back);
  CHECK(st == PA_ERR_FORMAT);
  CHECK(back == NULL);
  CHECK(same_everywhere(st));
  CHECK(strstr(pa_last_error(), file) != NULL);
  if (!strstr(pa_last_error(), file))
    fprintf(stderr, "rank %d: '%s' does not name %s\n", rank, pa_last_error(), file);
  pa_dmesh_destroy(back);
}

static void test_manifest(void) {
  pa_mesh *in = input();
  pa_dmesh *dm = NULL, *back = NULL;
  char p[64];
  CHECK_OK(pa_dmesh_distribute(MPI_COMM_WORLD, 0, in, 1, &dm));
  pa_mesh_destroy(in);
  if (!dm) return;
  uint64_t ref = checksum(dm);
  /* an older sequential file at the set's name, rank files of a write on
   * more ranks: the write removes both */
  if (rank == 0) {
    FILE *fp = fopen("io_m.meshb", "w");
    if (fp) fclose(fp);
    for (int r = size; r < size + 2; r++) {
      snprintf(p, sizeof p, "io_m.%d.meshb", r);
      copy_file("io_w.0.meshb", p);
      snprintf(p, sizeof p, "io_m.%d.vtu", r);
      copy_file("io_w.0.vtu", p);
    }
  }
  MPI_Barrier(MPI_COMM_WORLD);
  CHECK(!pa_dmesh_is_set("io_m.meshb"));
  CHECK_OK(pa_dmesh_write(dm, "io_m.meshb"));
  CHECK(file_exists("io_m.manifest"));
  CHECK(!file_exists("io_m.meshb"));
  for (int r = size; r < size + 2; r++) {
    snprintf(p, sizeof p, "io_m.%d.meshb", r);
    CHECK(!file_exists(p));
    snprintf(p, sizeof p, "io_m.%d.vtu", r);
    CHECK(!file_exists(p));
  }
  CHECK(pa_dmesh_is_set("io_m.meshb"));
  CHECK_OK(pa_dmesh_read(MPI_COMM_WORLD, "io_m.meshb", 1, &back));
  if (back) CHECK(checksum(back) == ref);
  pa_dmesh_destroy(back);
  back = NULL;
  /* the last rank's file of the set written on all ranks, put into a set
   * written on one rank fewer (same name, same rank number) */
  if (size >= 2) {
    snprintf(p, sizeof p, "io_m.%d.meshb", size - 2);
    if (rank == 0) copy_file(p, "io_m_stale.meshb");
    MPI_Comm sub;
    MPI_Comm_split(MPI_COMM_WORLD, rank < size - 1 ? 0 : MPI_UNDEFINED, rank, &sub);
    if (sub != MPI_COMM_NULL) {
      CHECK_OK(pa_dmesh_read(sub, "io_m.meshb", 1, &back));
      if (back) CHECK_OK(pa_dmesh_write(back, "io_m.meshb"));
      pa_dmesh_destroy(back);
      back = NULL;
      MPI_Comm_free(&sub);
    }
    MPI_Barrier(MPI_COMM_WORLD);
    snprintf(p, sizeof p, "io_m.%d.meshb", size - 1);
    CHECK(!file_exists(p)); /* the file of the removed rank is gone */
    CHECK_OK(pa_dmesh_read(MPI_COMM_WORLD, "io_m.meshb", 1, &back));
    if (back) CHECK(checksum(back) == ref);
    pa_dmesh_destroy(back);
    back = NULL;
    snprintf(p, sizeof p, "io_m.%d.meshb", size - 2);
    if (rank == 0) {
      copy_file(p, "io_m_good.meshb");
      copy_file("io_m_stale.meshb", p);
    }
    MPI_Barrier(MPI_COMM_WORLD);
    check_refused("io_m.meshb", p);
    if (rank == 0) copy_file("io_m_good.meshb", p);
    MPI_Barrier(MPI_COMM_WORLD);
  }
  /* one byte changed in the last rank file */
  snprintf(p, sizeof p, "io_m.%d.meshb", size >= 2 ? size - 2 : 0);
  if (rank == 0) {
    FILE *fp = fopen(p, "r+b");
    CHECK(fp != NULL);
    if (fp) {
      fseek(fp, 100, SEEK_SET);
      int c = fgetc(fp);
      fseek(fp, 100, SEEK_SET);
      fputc(c ^ 1, fp);
      fclose(fp);
    }
  }
  MPI_Barrier(MPI_COMM_WORLD);
  check_refused("io_m.meshb", p);
  CHECK(strstr(pa_last_error(), "checksum") != NULL);
  /* a write failing on one rank writes nothing on any rank */
  if (rank == size - 1) {
    snprintf(p, sizeof p, "io_f.%d.vtu", rank);
    CHECK(mkdir(p, 0755) == 0);
  }
  MPI_Barrier(MPI_COMM_WORLD);
  pa_status st = pa_dmesh_write(dm, "io_f.meshb");
  CHECK(st == PA_ERR_IO);
  CHECK(same_everywhere(st));
  MPI_Barrier(MPI_COMM_WORLD);
  snprintf(p, sizeof p, "io_f.%d.meshb", rank);
  CHECK(!file_exists(p));
  CHECK(!file_exists("io_f.manifest") && !file_exists("io_f.pvtu"));
  CHECK(pa_test_ntemps() == 0);
  if (rank == size - 1) {
    snprintf(p, sizeof p, "io_f.%d.vtu", rank);
    rmdir(p);
  }
  /* a set without manifest reads (header checks only) */
  CHECK_OK(pa_dmesh_write(dm, "io_l.meshb"));
  MPI_Barrier(MPI_COMM_WORLD);
  if (rank == 0) CHECK(remove("io_l.manifest") == 0);
  MPI_Barrier(MPI_COMM_WORLD);
  CHECK(pa_dmesh_is_set("io_l.meshb"));
  CHECK_OK(pa_dmesh_read(MPI_COMM_WORLD, "io_l.meshb", 1, &back));
  if (back) CHECK(checksum(back) == ref);
  pa_dmesh_destroy(back);
  back = NULL;
  /* inside the caller's transaction: nothing before its end */
  snprintf(p, sizeof p, "io_t.%d.meshb", rank);
  remove(p); /* from an earlier run in this directory */
  if (rank == 0) remove("io_t.manifest");
  MPI_Barrier(MPI_COMM_WORLD);
  pa_output *tx = NULL;
  CHECK_OK(pa_output_begin(&tx));
  CHECK_OK(pa_dmesh_write(dm, "io_t.meshb"));
  MPI_Barrier(MPI_COMM_WORLD);
  snprintf(p, sizeof p, "io_t.%d.meshb", rank);
  CHECK(!file_exists(p) && !file_exists("io_t.manifest"));
  CHECK_OK(pa_output_end(MPI_COMM_WORLD, tx, PA_SUCCESS));
  MPI_Barrier(MPI_COMM_WORLD);
  CHECK(file_exists(p) && file_exists("io_t.manifest"));
  CHECK(pa_test_ntemps() == 0);
  pa_dmesh_destroy(dm);
}

int main(int argc, char **argv) {
  int provided;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_MULTIPLE, &provided);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  size_t mem0 = pa_memory_current();
  test_round_trip();
  if (pa_test_failures) fprintf(stderr, "rank %d: round trip failed\n", rank);
  int before = pa_test_failures;
  test_values();
  if (pa_test_failures != before) fprintf(stderr, "rank %d: values failed\n", rank);
  before = pa_test_failures;
  test_bad_sets();
  if (pa_test_failures != before) fprintf(stderr, "rank %d: bad sets failed\n", rank);
  before = pa_test_failures;
  test_manifest();
  if (pa_test_failures != before) fprintf(stderr, "rank %d: manifest failed\n", rank);
  before = pa_test_failures;
  test_vtu_once();
  if (pa_test_failures != before) fprintf(stderr, "rank %d: vtu pieces failed\n", rank);
  if (pa_memory_current() != mem0) {
    fprintf(stderr, "rank %d: %zu bytes leaked\n", rank, pa_memory_current() - mem0);
    pa_test_failures++;
  }
  int fails = pa_test_failures;
  MPI_Allreduce(MPI_IN_PLACE, &fails, 1, MPI_INT, MPI_SUM, MPI_COMM_WORLD);
  if (rank == 0)
    printf("test_dmesh_io: %d ranks, %d checks on rank 0, %d failures\n", size,
           pa_test_checks, fails);
  MPI_Finalize();
  return fails ? 1 : 0;
}
