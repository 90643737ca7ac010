/*
 * distribute.c -- making and moving distributed meshes: scatter from a root
 * (contiguous blocks, one in flight, then PT-Scotch and migration), the
 * distributed dual graph, repartitioning and redistribution, and the gather
 * to one centralized mesh.
 *
 * Invariants: global ids of a distributed root mesh are its 0-based indices;
 * every path ends in pa__dmesh_build (build.c), so the ownership rule and
 * numbering are the same whichever way a pa_dmesh was made; a gathered mesh
 * is numbered by increasing global id.
 */
#include "dmesh/dmesh.h"
#include "partition/partition.h"

#include <limits.h>
#include <stdio.h>

/* ---- scatter from a root ---- */

typedef struct header {
  pa__layout lay;            /* dimension, metric and fields */
  int64_t n[PA_DMESH_NKIND]; /* vertices, elements, boundary, edges */
} header;

/* Check that every connectivity index of the root mesh is in range. */
static pa_status check_indices(pa_mesh *m) {
  pa_status st = PA_SUCCESS;
  int d = m->dim;
  for (size_t k = 0; k < (size_t)m->ne * (d + 1); k++)
    PA_CHECK(m->elem[k] >= 0 && m->elem[k] < m->nv, PA_ERR_MESH,
             "element %zu references vertex %d out of [0, %d)", k / (d + 1),
             (int)m->elem[k], (int)m->nv);
  for (size_t k = 0; k < (size_t)m->nb * d; k++)
    PA_CHECK(m->bdry[k] >= 0 && m->bdry[k] < m->nv, PA_ERR_MESH,
             "boundary entity %zu references vertex %d out of [0, %d)", k / d,
             (int)m->bdry[k], (int)m->nv);
  for (size_t k = 0; k < (size_t)m->ned * 2; k++)
    PA_CHECK(m->edge[k] >= 0 && m->edge[k] < m->nv, PA_ERR_MESH,
             "edge %zu references vertex %d out of [0, %d)", k / 2,
             (int)m->edge[k], (int)m->nv);
cleanup:
  return st;
}

/* Pack block r of P of the root mesh: one record block per kind (vertices,
 * elements, boundary entities, edges), filled array by array straight from
 * the mesh arrays. */
static pa_status pack_block(pa_mesh *m, const pa__layout *lay, int r, int P,
                            pa__buf *b) {
  pa_status st = PA_SUCCESS;
  int d = m->dim, ndbl = pa__layout_ndbl(lay);
  int64_t n[PA_DMESH_NKIND] = {m->nv, m->ne, m->nb, m->ned}, lo[PA_DMESH_NKIND],
          cnt[PA_DMESH_NKIND];
  size_t bytes = 0;
  for (int k = 0; k < PA_DMESH_NKIND; k++) {
    lo[k] = n[k] * r / P;
    cnt[k] = n[k] * (r + 1) / P - lo[k];
    bytes += pa__recblock_bytes(pa__kind_nv(d, k), pa__layout_kind_ndbl(lay, k),
                                (size_t)cnt[k], 0);
  }
  b->n = 0;
  PA_CALL(pa__buf_reserve(b, bytes));
  for (int k = 0; k < PA_DMESH_NKIND; k++) {
    int nv = pa__kind_nv(d, k);
    size_t c = (size_t)cnt[k], l = (size_t)lo[k];
    pa__recblock B;
    int nd = pa__layout_kind_ndbl(lay, k);
    pa__recblock_init(b->p + b->n, nv, nd, c, 0, &B);
    const pa_idx *conn = k == PA_ELEMENT ? m->elem : k == PA_BOUNDARY ? m->bdry : m->edge;
    const int32_t *ref = k == PA_VERTEX ? m->vref : k == PA_ELEMENT ? m->eref
                         : k == PA_BOUNDARY ? m->bref : m->edref;
    const uint8_t *flag = k == PA_VERTEX ? m->vflag : k == PA_ELEMENT ? m->eflag
                          : k == PA_BOUNDARY ? m->bflag : m->edflag;
    for (size_t i = 0; i < c; i++) B.gid[i] = (pa_gid)(l + i);
    for (size_t i = 0; i < c * (size_t)nv; i++)
      B.vgid[i] = conn[(size_t)nv * l + i];
    if (c) {
      memcpy(B.ref, ref + l, c * sizeof *B.ref);
      memcpy(B.flag, flag + l, c);
    }
    for (size_t i = 0; i < c; i++) B.aux[i] = r;
    if (k == PA_VERTEX) {
      int o = 0;
      for (size_t i = 0; i < c; i++)
        memcpy(B.dbl + (size_t)ndbl * i, m->coord + (size_t)d * (l + i),
               d * sizeof(double));
      o = d;
      for (size_t i = 0; m->met_ncomp && i < c; i++)
        memcpy(B.dbl + (size_t)ndbl * i + o,
               m->met + (size_t)m->met_ncomp * (l + i),
               m->met_ncomp * sizeof(double));
      o += m->met_ncomp;
      for (size_t i = 0; m->vgdim && i < c; i++)
        B.dbl[(size_t)ndbl * i + o] =
            pa__entity_pack(m->vgdim[l + i], m->vgtag[l + i]);
      o += m->vgdim != NULL;
      for (int f = 0; f < m->nfield; f++) {
        int nc = m->field[f].ncomp;
        for (size_t i = 0; i < c; i++)
          memcpy(B.dbl + (size_t)ndbl * i + o,
                 m->field[f].val + (size_t)nc * (l + i), nc * sizeof(double));
        o += nc;
      }
    } else if (nd) { /* element or boundary field values */
      for (size_t i = 0; i < c; i++)
        pa__entity_doubles(m, k, (pa_idx)(l + i), B.dbl + (size_t)nd * i);
    }
    b->n += B.bytes;
  }
cleanup:
  return st;
}

/* Append the record blocks of every kind in p[0..n) to R[kind]. */
static pa_status unpack_block(const unsigned char *p, size_t n, pa__recs *R) {
  pa_status st = PA_SUCCESS;
  size_t pos = 0;
  for (int k = 0; k < PA_DMESH_NKIND; k++)
    PA_CALL(pa__recs_get(&R[k], p, &pos));
  PA_CHECK(pos == n, PA_ERR_INTERNAL, "block of %zu bytes, %zu read", n, pos);
cleanup:
  return st;
}

/* The arguments and the root's mesh checked (connectivity in range), and
 * its header (dimension, layout, counts) broadcast. Every rank returns the
 * same status. */
static pa_status bcast_header(MPI_Comm comm, int root, pa_mesh *mesh,
                              int overlap, header *h) {
  pa_status st = PA_SUCCESS;
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  PA_CHECK(root >= 0 && root < size, PA_ERR_ARG, "root %d out of [0, %d)",
           root, size);
  PA_CHECK(overlap >= 0 && overlap <= 8, PA_ERR_ARG,
           "overlap must be in [0, 8], got %d", overlap);
  if (rank == root) {
    PA_CHECK(mesh, PA_ERR_ARG, "pa_dmesh_distribute: NULL mesh on the root");
    PA_CALL(check_indices(mesh));
    pa__mesh_layout(mesh, &h->lay);
    h->n[PA_VERTEX] = mesh->nv;
    h->n[PA_ELEMENT] = mesh->ne;
    h->n[PA_BOUNDARY] = mesh->nb;
    h->n[PA_EDGE] = mesh->ned;
  }
cleanup:
  st = pa__agree_end(comm, st);
  if (st == PA_SUCCESS) MPI_Bcast(h, (int)sizeof *h, MPI_BYTE, root, comm);
  return st;
}

/* Contiguous blocks of the root's mesh, one per rank and one in flight:
 * the root packs block r and sends it to rank r, which appends it to R.
 * Each step is agreed, and so is the end. */
static pa_status scatter_blocks(pa_dmesh *dm, int root, pa_mesh *mesh,
                                const pa__layout *lay, pa__recs *R) {
  pa_status st = PA_SUCCESS;
  int rank = dm->rank, size = dm->size;
  pa__buf b = {0};
  void *rbuf = NULL;
  for (int r = 0; r < size; r++) {
    if (rank == root && !st) st = pack_block(mesh, lay, r, size, &b);
    PA_CALL(pa__agree(dm->comm, st));
    if (r == root) {
      if (rank == root) st = unpack_block(b.p, b.n, R);
    } else if (rank == root) {
      st = pa__xchg_send(dm->comm, r, b.p, b.n);
    } else if (rank == r) {
      size_t n;
      st = pa__xchg_recv(dm->comm, root, &rbuf, &n);
      if (!st) st = unpack_block(rbuf, n, R);
      pa__free(rbuf);
      rbuf = NULL;
    }
    if (rank == root) pa__buf_free(&b);
  }
  PA_CALL(pa__agree(dm->comm, st));
cleanup:
  pa__buf_free(&b);
  pa__free(rbuf);
  return st;
}

/* PT-Scotch on the scattered elements: R[PA_ELEMENT].aux = the rank each
 * element goes to. Agreed. */
static pa_status partition_blocks(pa_dmesh *dm, pa__recs *R) {
  pa_status st = PA_SUCCESS;
  int *part = NULL;
  part = pa__malloc((R[PA_ELEMENT].n ? R[PA_ELEMENT].n : 1) * sizeof *part);
  st = part ? PA_SUCCESS
            : pa__error(PA_ERR_MEMORY, __FILE__, __LINE__, "out of memory");
  PA_CALL(pa__agree(dm->comm, st));
  PA_CALL(pa__dmesh_partition(dm->comm, dm->dim, (pa_idx)R[PA_ELEMENT].n,
                              R[PA_ELEMENT].vgid, NULL, part));
  for (size_t i = 0; i < R[PA_ELEMENT].n; i++) R[PA_ELEMENT].aux[i] = part[i];
cleanup:
  pa__free(part);
  return st;
}

pa_status pa_dmesh_distribute(MPI_Comm comm, int root, pa_mesh *mesh,
                              int overlap, pa_dmesh **dmp) {
  pa_status st = PA_SUCCESS;
  header h;
  pa__layout lay;
  pa_dmesh *dm = NULL;
  pa__recs R[PA_DMESH_NKIND];
  double t0 = pa_wtime(), t1, t2;
  memset(&h, 0, sizeof h);
  memset(&lay, 0, sizeof lay);
  memset(R, 0, sizeof R);
  pa__agree_reset();
  PA_CHECK(dmp, PA_ERR_ARG, "pa_dmesh_distribute: NULL output pointer");
  *dmp = NULL;
  PA_CALL(bcast_header(comm, root, mesh, overlap, &h));
  lay = h.lay;
  PA_CALL(pa__dmesh_create(comm, lay.dim, &dm));
  for (int k = 0; k < PA_DMESH_NKIND; k++)
    pa__recs_init(&R[k], k, pa__kind_nv(lay.dim, k), pa__layout_kind_ndbl(&lay, k));
  /* scatter from the root, partition the blocks, then migrate */
  PA_CALL(scatter_blocks(dm, root, mesh, &lay, R));
  t1 = pa_wtime();
  PA_CALL(partition_blocks(dm, R));
  t2 = pa_wtime();
  PA_CALL(pa__dmesh_build(dm, &lay, overlap, &R[PA_ELEMENT], &R[PA_VERTEX],
                          &R[PA_BOUNDARY], &R[PA_EDGE]));
  pa__info(1, "padapt: rank %d: scatter %.3f s, partition %.3f s, "
              "build %.3f s\n", dm->rank, t1 - t0, t2 - t1, pa_wtime() - t2);
  *dmp = dm;
  dm = NULL;
cleanup:
  for (int k = 0; k < PA_DMESH_NKIND; k++) pa__recs_free(&R[k]);
  pa_dmesh_destroy(dm);
  return st;
}

/* ---- distributed dual graph ---- */

typedef struct face {
  pa_gid key[3];
  pa_gid who; /* local face number e*(d+1)+i, or global graph vertex */
} face;

static uint64_t face_hash(const pa_gid *k, int n) {
  uint64_t h = 0x9E3779B97F4A7C15ull;
  for (int i = 0; i < n; i++) h = pa__mix64(h ^ (uint64_t)k[i]);
  return h;
}

static int face_eq(const pa_gid *a, const pa_gid *b, int n) {
  for (int i = 0; i < n; i++)
    if (a[i] != b[i]) return 0;
  return 1;
}

static void sort_key(pa_gid *k, int n) {
  for (int i = 1; i < n; i++) {
    pa_gid x = k[i];
    int j = i - 1;
    while (j >= 0 && k[j] > x) {
      k[j + 1] = k[j];
      j--;
    }
    k[j + 1] = x;
  }
}

/* Sorted vertex gids of local face i (element i / nf, opposite vertex
 * i % nf) in key[0..nk), -1 after. */
static void face_key(const pa_gid *vgid, int nf, size_t i, pa_gid *key,
                     int nk) {
  size_t e = i / (size_t)nf;
  int fi = (int)(i % (size_t)nf), k = 0;
  for (int j = 0; j < nf; j++)
    if (j != fi) key[k++] = vgid[e * (size_t)nf + (size_t)j];
  for (; k < 3; k++) key[k] = -1;
  sort_key(key, nk);
}

typedef struct fitem {
  uint64_t key; /* the face's other local vertices (b << 32 | c) */
  pa_idx face;  /* local face number e*nf+i */
} fitem;

/* Faces are bucketed by their smallest local vertex (counting sort); in a
 * bucket (a few dozen faces), faces are chained by their second vertex, and
 * equal faces are found along the chains: linear work, memory access
 * following the mesh order. Both passes over the faces sort each element's
 * vertices once and read its faces off the sorted list. */

/* The nf vertices ev of an element in increasing order into sv, and the
 * position in ev of each (pos). */
static void elem_sorted(const pa_idx *ev, int nf, pa_idx *sv, int *pos) {
  for (int j = 0; j < nf; j++) {
    pa_idx x = ev[j];
    int q = j;
    for (; q > 0 && sv[q - 1] > x; q--) {
      sv[q] = sv[q - 1];
      pos[q] = pos[q - 1];
    }
    sv[q] = x;
    pos[q] = j;
  }
}

/* The positions in the sorted vertices of the face opposite sorted vertex
 * p (face_of[dim - 2][p]): smallest first. */
static const int face_of[2][4][3] = {
    {{1, 2}, {0, 2}, {0, 1}}, {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}}};

pa_status pa__match_faces(int dim, pa_idx n, const pa_idx *lv, pa_idx nv,
                          const pa_gid *vgid, pa_gid *mate) {
  pa_status st = PA_SUCCESS;
  int nf = dim + 1;
  size_t nface = (size_t)n * nf, maxb = 0;
  pa_idx *fstart = NULL, *bucket = NULL, *head = NULL, *next = NULL;
  fitem *it = NULL;
  pa_idx sv[4];
  int pos[4];
  const int(*fo)[3] = face_of[dim - 2];
  /* memory: mate (the output, holding each face's key meanwhile: its
   * vertices after the smallest, b << 32 | c), the buckets (4 bytes per
   * face), the chain heads (4 bytes per vertex) and one bucket of keys and
   * chains */
  PA_CALLOC(fstart, (size_t)nv + 1);
  PA_ALLOC(bucket, nface);
  for (size_t e = 0; e < (size_t)n; e++) {
    elem_sorted(lv + e * nf, nf, sv, pos);
    for (int p = 0; p < nf; p++) {
      const int *f = fo[p];
      fstart[sv[f[0]] + 1]++;
      mate[e * nf + (size_t)pos[p]] =
          dim == 3 ? (pa_gid)((uint64_t)sv[f[1]] << 32 | (uint64_t)sv[f[2]])
                   : (pa_gid)sv[f[1]];
    }
  }
  for (pa_idx x = 0; x < nv; x++) {
    if ((size_t)fstart[x + 1] > maxb) maxb = (size_t)fstart[x + 1];
    fstart[x + 1] += fstart[x];
  }
  for (size_t e = 0; e < (size_t)n; e++) {
    const pa_idx *ev = lv + e * nf;
    elem_sorted(ev, nf, sv, pos);
    /* the smallest vertex of a face: the element's, unless opposite it */
    for (int i = 0; i < nf; i++)
      bucket[fstart[ev[i] == sv[0] ? sv[1] : sv[0]]++] = (pa_idx)(e * nf + i);
  }
  for (pa_idx x = nv; x > 0; x--) fstart[x] = fstart[x - 1];
  fstart[0] = 0;
  PA_ALLOC(it, maxb + 1);
  PA_ALLOC(next, maxb + 1);
  PA_ALLOC(head, (size_t)nv + 1);
  for (pa_idx x = 0; x <= nv; x++) head[x] = -1;
  for (pa_idx x = 0; x < nv; x++) {
    pa_idx m = fstart[x + 1] - fstart[x];
    fitem *b = it;
    for (pa_idx p = 0; p < m; p++) {
      pa_idx fe = bucket[fstart[x] + p];
      b[p].key = (uint64_t)mate[fe];
      b[p].face = fe;
      mate[fe] = -1;
    }
    /* each face meets the earlier faces of its chain (same second vertex):
     * an equal one unmatched is its mate, an equal one matched a third */
    for (pa_idx p = 0; p < m; p++) {
      pa_idx second = (pa_idx)(dim == 3 ? b[p].key >> 32 : b[p].key);
      next[p] = head[second];
      head[second] = p;
      for (pa_idx q = next[p]; q >= 0; q = next[q]) {
        if (b[q].key != b[p].key) continue;
        size_t fe = (size_t)b[p].face;
        if (mate[b[q].face] >= 0) {
          size_t e0 = fe / nf * nf, i = fe % nf;
          size_t v0 = e0 + (i == 0), v1 = e0 + (i <= 1) + 1;
          PA_FAIL(PA_ERR_MESH,
                  "non-conforming mesh: a face (vertices %lld %lld%s) is "
                  "shared by more than two elements",
                  (long long)(vgid ? vgid[v0] : lv[v0]),
                  (long long)(vgid ? vgid[v1] : lv[v1]), dim > 2 ? " ..." : "");
        }
        mate[fe] = b[q].face;
        mate[b[q].face] = (pa_gid)fe;
        break;
      }
    }
    for (pa_idx p = 0; p < m; p++)
      head[dim == 3 ? b[p].key >> 32 : b[p].key] = -1;
  }
cleanup:
  pa__free(fstart);
  pa__free(bucket);
  pa__free(it);
  pa__free(head);
  pa__free(next);
  return st;
}

/* pa__match_faces on elements given by vertex gids (numbered locally with a
 * hash map). */
static pa_status match_local(int dim, pa_idx n, const pa_gid *vgid,
                             pa_gid *mate) {
  pa_status st = PA_SUCCESS;
  size_t nc = (size_t)n * (dim + 1);
  pa__gidmap vm = {0};
  pa_idx *lv = NULL, nv = 0;
  PA_ALLOC(lv, nc);
  PA_CALL(pa__gidmap_init(&vm, (size_t)n / (dim == 3 ? 5 : 2) + 16));
  for (size_t k = 0; k < nc; k++) {
    int found;
    pa_idx old;
    PA_CALL(pa__gidmap_put(&vm, vgid[k], nv, &found, &old));
    lv[k] = found ? old : nv++;
  }
  pa__gidmap_free(&vm);
  PA_CALL(pa__match_faces(dim, n, lv, nv, vgid, mate));
cleanup:
  pa__gidmap_free(&vm);
  pa__free(lv);
  return st;
}

/* Match faces pairwise with a hash table: mate[i] = j for faces sharing a
 * key, -1 for faces seen once. A key seen three times is an error. */
static pa_status match_faces(const face *f, size_t n, int nk, pa_gid *mate) {
  pa_status st = PA_SUCCESS;
  size_t cap = 16;
  int64_t *tab = NULL;
  while (cap < 2 * n + 2) cap *= 2;
  PA_ALLOC(tab, cap);
  for (size_t s = 0; s < cap; s++) tab[s] = -1;
  for (size_t i = 0; i < n; i++) {
    mate[i] = -1;
    size_t s = face_hash(f[i].key, nk) & (cap - 1);
    for (;;) {
      if (tab[s] < 0) {
        tab[s] = (int64_t)i;
        break;
      }
      if (face_eq(f[tab[s]].key, f[i].key, nk)) {
        size_t j = (size_t)tab[s];
        PA_CHECK(mate[j] < 0, PA_ERR_MESH,
                 "non-conforming mesh: a face (vertices %lld %lld%s) is shared "
                 "by more than two elements", (long long)f[i].key[0],
                 (long long)f[i].key[1], nk > 2 ? " ..." : "");
        mate[j] = (pa_gid)i;
        mate[i] = (pa_gid)j;
        break;
      }
      s = (s + 1) & (cap - 1);
    }
  }
cleanup:
  pa__free(tab);
  return st;
}

/* Sorted vertex gids (vglob per local vertex) of local face i of the
 * elements lv, and its meeting rank hash % size. */
static int face_key_rank(const pa_idx *lv, const pa_gid *vglob, int nf,
                         size_t i, int size, pa_gid *key) {
  const pa_idx *ev = lv + i / (size_t)nf * (size_t)nf;
  int k = 0;
  key[0] = key[1] = key[2] = -1;
  for (int j = 0; j < nf; j++)
    if (j != (int)(i % (size_t)nf)) key[k++] = vglob[ev[j]];
  sort_key(key, nf - 1);
  return (int)(face_hash(key, nf - 1) % (uint64_t)size);
}

/* The parity of face i (opposite local vertex i % nf of its element, in its
 * outward order) against the order of its vertices' global ids: two
 * positive elements on opposite sides of a face see it with opposite
 * parities, two on the same side (an element listed twice, or folded onto
 * its neighbour) with the same. */
static int face_parity(const pa_idx *lv, const pa_gid *vglob, int nf,
                       size_t i) {
  static const int out[2][4][3] = {
      {{1, 2, -1}, {2, 0, -1}, {0, 1, -1}, {-1, -1, -1}},
      {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}}};
  const pa_idx *ev = lv + i / (size_t)nf * (size_t)nf;
  const int *o = out[nf - 3][i % (size_t)nf];
  pa_gid g[3];
  int inv = 0;
  for (int k = 0; k < nf - 1; k++) g[k] = vglob[ev[o[k]]];
  for (int a = 0; a < nf - 1; a++)
    for (int b = a + 1; b < nf - 1; b++) inv += g[a] > g[b];
  return inv & 1;
}

pa_status pa__faces_conform(MPI_Comm comm, int dim, pa_idx n,
                            const pa_idx *lv, pa_idx nv, const pa_gid *vglob,
                            const pa_gid *egid) {
  pa_status st = PA_SUCCESS;
  int size, nf = dim + 1;
  size_t nface = (size_t)n * nf, nr = 0;
  pa_gid *mate = NULL, *rmate = NULL;
  face *sendf = NULL;
  size_t *cnt = NULL, *pos = NULL, *rcnt = NULL;
  void *recv = NULL;
  MPI_Comm_size(comm, &size);
  /* faces matched here; the unmatched ones, by meeting rank */
  mate = pa__malloc((nface ? nface : 1) * sizeof *mate);
  cnt = pa__calloc((size_t)size, sizeof *cnt);
  pos = pa__calloc((size_t)size + 1, sizeof *pos);
  st = mate && cnt && pos
           ? pa__match_faces(dim, n, lv, nv, NULL, mate)
           : pa__error(PA_ERR_MEMORY, __FILE__, __LINE__, "out of memory");
  for (size_t i = 0; i < nface && st == PA_SUCCESS; i++)
    if (mate[i] > (pa_gid)i &&
        face_parity(lv, vglob, nf, i) == face_parity(lv, vglob, nf, (size_t)mate[i]))
      st = pa__error(PA_ERR_MESH, __FILE__, __LINE__,
                     "elements %lld and %lld (global numbers) lie on the "
                     "same side of their common face: one element listed "
                     "twice, or a folded mesh",
                     (long long)egid[i / (size_t)nf] + 1,
                     (long long)egid[(size_t)mate[i] / (size_t)nf] + 1);
  if (st == PA_SUCCESS) {
    pa_gid key[3];
    for (size_t i = 0; i < nface; i++)
      if (mate[i] < 0) cnt[face_key_rank(lv, vglob, nf, i, size, key)]++;
    for (int r = 0; r < size; r++) pos[r + 1] = pos[r] + cnt[r];
    sendf = pa__malloc((pos[size] ? pos[size] : 1) * sizeof *sendf);
    if (!sendf) st = pa__error(PA_ERR_MEMORY, __FILE__, __LINE__, "out of memory");
  }
  PA_CALL(pa__agree(comm, st));
  for (size_t i = 0; i < nface; i++) {
    if (mate[i] >= 0) continue;
    pa_gid key[3];
    face *f = sendf + pos[face_key_rank(lv, vglob, nf, i, size, key)]++;
    memcpy(f->key, key, sizeof key);
    /* the element and, in the lowest bit, the face's parity */
    f->who = 2 * egid[i / (size_t)nf] + face_parity(lv, vglob, nf, i);
  }
  pa__free(mate);
  mate = NULL;
  for (int r = 0; r < size; r++) cnt[r] *= sizeof(face);
  PA_CALL(pa__xchg_sparse(comm, cnt, sendf, &rcnt, &recv));
  pa__free(sendf);
  sendf = NULL;
  for (int r = 0; r < size; r++) nr += rcnt[r] / sizeof(face);
  rmate = pa__malloc((nr ? nr : 1) * sizeof *rmate);
  st = rmate ? match_faces(recv, nr, dim, rmate)
             : pa__error(PA_ERR_MEMORY, __FILE__, __LINE__, "out of memory");
  for (size_t i = 0; i < nr && st == PA_SUCCESS; i++) {
    const face *fr = recv;
    pa_gid j = rmate[i];
    if (j > (pa_gid)i && !((fr[i].who ^ fr[j].who) & 1))
      st = pa__error(PA_ERR_MESH, __FILE__, __LINE__,
                     "elements %lld and %lld (global numbers) lie on the "
                     "same side of their common face: one element listed "
                     "twice, or a folded mesh",
                     (long long)(fr[i].who >> 1) + 1,
                     (long long)(fr[j].who >> 1) + 1);
  }
cleanup:
  pa__free(mate);
  pa__free(rmate);
  pa__free(sendf);
  pa__free(cnt);
  pa__free(pos);
  pa__free(rcnt);
  pa__free(recv);
  return pa__agree(comm, st);
}

/* What the phases of pa__dual_graph share: the local elements (n, by
 * vertex gids vgid; nf faces each, nk vertices per face), the first global
 * graph vertex of this rank (offset), and the neighbour of every local face
 * e*nf+i: its global graph vertex nbr and rank nbrrank, -1 while unknown.
 * The nun faces unmatched here meet at rank hash(key) % size: cnt[r] bytes
 * of faces go to rank r (pos: their offsets, in faces), rcnt/recv are the
 * faces this rank meets, bcnt/brecv the answers to the faces it sent. */
typedef struct dgraph {
  MPI_Comm comm;
  int rank, size, nk, nf, dim;
  pa_idx n;
  size_t nface, nun;
  const pa_gid *vgid;
  pa_gid offset, *nbr;
  int *nbrrank;
  size_t *cnt, *pos, *rcnt, *bcnt;
  void *recv, *brecv;
} dgraph;

/* Faces matched on this rank (by local vertex numbers lv of nv vertices,
 * or by gids): nbr and nbrrank of the matched ones; counts the others. */
static pa_status match_local_faces(dgraph *g, const pa_idx *lv, pa_idx nv) {
  pa_status st = PA_SUCCESS;
  PA_ALLOC(g->nbr, g->nface);
  if (lv)
    PA_CALL(pa__match_faces(g->dim, g->n, lv, nv, g->vgid, g->nbr));
  else
    PA_CALL(match_local(g->dim, g->n, g->vgid, g->nbr));
  /* the local mate of each face becomes its global graph vertex */
  PA_ALLOC(g->nbrrank, g->nface);
  g->nun = 0;
  for (size_t i = 0; i < g->nface; i++) {
    g->nbrrank[i] = g->nbr[i] >= 0 ? g->rank : -1;
    g->nun += g->nbr[i] < 0;
    if (g->nbr[i] >= 0) g->nbr[i] = g->offset + g->nbr[i] / g->nf;
  }
cleanup:
  return st;
}

/* Every unmatched face (its sorted vertex gids and its graph vertex) to
 * its meeting rank hash(key) % size, in local face order within a rank. */
static pa_status send_unmatched(dgraph *g) {
  pa_status st = PA_SUCCESS;
  int size = g->size, nf = g->nf, nk = g->nk;
  size_t nun = 0;
  face *sendf = NULL;
  int *dest = NULL;
  PA_ALLOC(sendf, g->nun);
  PA_ALLOC(dest, g->nun);
  for (size_t i = 0; i < g->nface; i++)
    if (g->nbr[i] < 0) {
      face_key(g->vgid, nf, i, sendf[nun].key, nk);
      sendf[nun].who = g->offset + (pa_gid)(i / nf); /* graph vertex */
      dest[nun] = (int)(face_hash(sendf[nun].key, nk) % (uint64_t)size);
      nun++;
    }
  PA_CALLOC(g->cnt, size);
  PA_CALLOC(g->pos, (size_t)size + 1);
  for (size_t i = 0; i < nun; i++) g->cnt[dest[i]]++;
  for (int r = 0; r < size; r++) g->pos[r + 1] = g->pos[r] + g->cnt[r];
  {
    face *tmp;
    PA_ALLOC(tmp, nun);
    /* remember where each unmatched face went: order within a rank kept */
    for (size_t i = 0; i < nun; i++) tmp[g->pos[dest[i]]++] = sendf[i];
    pa__free(sendf);
    sendf = tmp;
    for (int r = 0; r < size; r++) g->cnt[r] *= sizeof(face);
  }
  PA_CALL(pa__xchg_sparse(g->comm, g->cnt, sendf, &g->rcnt, &g->recv));
cleanup:
  pa__free(sendf);
  pa__free(dest);
  return st;
}

/* At the meeting rank: match the faces received and answer every one, in
 * the order received, with its neighbour's graph vertex and rank (-1: a
 * boundary face). */
static pa_status answer_faces(dgraph *g) {
  pa_status st = PA_SUCCESS;
  int size = g->size;
  size_t nr = 0, j = 0;
  pa_gid *rmate = NULL, *ans = NULL;
  int *rdest = NULL;
  size_t *acnt = NULL;
  const face *rf = g->recv;
  for (int r = 0; r < size; r++) nr += g->rcnt[r] / sizeof(face);
  PA_ALLOC(rmate, nr);
  PA_CALL(match_faces(rf, nr, g->nk, rmate));
  PA_ALLOC(ans, 2 * nr);
  rdest = pa__malloc((nr ? nr : 1) * sizeof *rdest);
  PA_CHECK(rdest, PA_ERR_MEMORY, "out of memory");
  for (int r = 0; r < size; r++)
    for (size_t q = 0; q < g->rcnt[r] / sizeof(face); q++, j++) rdest[j] = r;
  for (size_t i = 0; i < nr; i++) {
    pa_gid m = rmate[i];
    ans[2 * i] = m >= 0 ? rf[m].who : -1;
    ans[2 * i + 1] = m >= 0 ? rdest[m] : -1;
  }
  acnt = pa__calloc((size_t)size, sizeof *acnt);
  PA_CHECK(acnt, PA_ERR_MEMORY, "out of memory");
  for (int r = 0; r < size; r++) acnt[r] = g->rcnt[r] / sizeof(face) * 2 * sizeof(pa_gid);
  PA_CALL(pa__xchg_sparse(g->comm, acnt, ans, &g->bcnt, &g->brecv));
cleanup:
  pa__free(rmate);
  pa__free(ans);
  pa__free(rdest);
  pa__free(acnt);
  return st;
}

/* The answers arrive by meeting rank in the order sent: walk the unmatched
 * faces again, recomputing each one's meeting rank, and take the next
 * answer from that rank. */
static void place_answers(dgraph *g) {
  const pa_gid *a = g->brecv;
  size_t *cur = g->pos;
  cur[0] = 0;
  for (int r = 0; r < g->size; r++) cur[r + 1] = cur[r] + g->cnt[r] / sizeof(face);
  for (size_t i = 0; i < g->nface; i++)
    if (g->nbrrank[i] < 0) {
      pa_gid key[3];
      face_key(g->vgid, g->nf, i, key, g->nk);
      int r = (int)(face_hash(key, g->nk) % (uint64_t)g->size);
      size_t q = cur[r]++;
      g->nbr[i] = a[2 * q];
      g->nbrrank[i] = (int)a[2 * q + 1];
    }
}

/* The graph in CSR form: the neighbours of each element (graph vertex and
 * rank) in face order, boundary faces skipped. */
static pa_status graph_csr(const dgraph *g, pa_idx **xadjp, pa_gid **adjp,
                           int **adjrankp) {
  pa_status st = PA_SUCCESS;
  pa_idx n = g->n, *xadj = NULL;
  pa_gid *adj = NULL;
  int *adjrank = NULL, nf = g->nf;
  PA_ALLOC(xadj, n + 1);
  xadj[0] = 0;
  for (pa_idx e = 0; e < n; e++) {
    pa_idx c = 0;
    const pa_gid *nb = g->nbr + (size_t)e * nf;
    for (int i = 0; i < nf; i++) {
      c += nb[i] >= 0;
      /* two distinct simplices share one face at most: more is one element
       * listed twice (the partitioner would take it for a broken graph) */
      for (int j = 0; j < i; j++)
        PA_CHECK(nb[i] < 0 || nb[i] != nb[j], PA_ERR_MESH,
                 "element %lld shares %s faces with element %lld: the same "
                 "element listed twice",
                 (long long)(g->offset + e) + 1, "several",
                 (long long)nb[i] + 1);
    }
    xadj[e + 1] = xadj[e] + c;
  }
  PA_ALLOC(adj, xadj[n]);
  PA_ALLOC(adjrank, xadj[n]);
  for (pa_idx e = 0, k = 0; e < n; e++)
    for (int i = 0; i < nf; i++)
      if (g->nbr[(size_t)e * nf + i] >= 0) {
        adj[k] = g->nbr[(size_t)e * nf + i];
        adjrank[k++] = g->nbrrank[(size_t)e * nf + i];
      }
  *xadjp = xadj;
  *adjp = adj;
  if (adjrankp) *adjrankp = adjrank; else pa__free(adjrank);
  xadj = NULL;
  adj = NULL;
  adjrank = NULL;
cleanup:
  pa__free(xadj);
  pa__free(adj);
  pa__free(adjrank);
  return st;
}

pa_status pa__dual_graph(MPI_Comm comm, int dim, pa_idx n, const pa_gid *vgid,
                         const pa_idx *lv, pa_idx nv, pa_idx **xadjp,
                         pa_gid **adjp, int **adjrankp, pa_gid *offsetp) {
  pa_status st = PA_SUCCESS;
  dgraph g;
  memset(&g, 0, sizeof g);
  g.comm = comm;
  g.dim = dim;
  g.nk = dim;
  g.nf = dim + 1;
  g.n = n;
  g.nface = (size_t)n * g.nf;
  g.vgid = vgid;
  MPI_Comm_rank(comm, &g.rank);
  MPI_Comm_size(comm, &g.size);
  {
    pa_gid nn = n;
    PA_CALL(pa__agree(comm, PA_SUCCESS));
    MPI_Exscan(&nn, &g.offset, 1, MPI_INT64_T, MPI_SUM, comm);
    if (g.rank == 0) g.offset = 0;
  }
  PA_CALL(match_local_faces(&g, lv, nv));
  PA_CALL(send_unmatched(&g));
  PA_CALL(answer_faces(&g));
  place_answers(&g);
  PA_CALL(graph_csr(&g, xadjp, adjp, adjrankp));
  if (offsetp) *offsetp = g.offset;
cleanup:
  st = pa__agree_end(comm, st);
  pa__free(g.nbr);
  pa__free(g.nbrrank);
  pa__free(g.cnt);
  pa__free(g.pos);
  pa__free(g.rcnt);
  pa__free(g.recv);
  pa__free(g.bcnt);
  pa__free(g.brecv);
  return st;
}

pa_status pa__dmesh_partition(MPI_Comm comm, int dim, pa_idx n,
                              const pa_gid *vgid, const double *weights,
                              int *part) {
  pa_status st = PA_SUCCESS;
  int size;
  pa_idx *xadj = NULL;
  pa_gid *adj = NULL;
  MPI_Comm_size(comm, &size);
  if (size == 1) {
    for (pa_idx i = 0; i < n; i++) part[i] = 0;
    return pa__agree(comm, PA_SUCCESS);
  }
  double t0 = pa_wtime(), t1, t2;
  PA_CALL(pa__dual_graph(comm, dim, n, vgid, NULL, 0, &xadj, &adj, NULL, NULL));
  PA_CALL(pa__agree(comm, PA_SUCCESS));
  t1 = pa_wtime();
  st = pa__partition_dgraph(comm, n, xadj, adj, weights, size, 0, part);
  PA_CALL(pa__agree(comm, st));
  t2 = pa_wtime();
  st = pa__partition_remap(comm, n, part, weights);
  PA_CALL(pa__agree(comm, st));
  pa__info(2, "padapt: partition: dual graph %.3f s, PT-Scotch %.3f s, "
              "remap %.3f s\n", t1 - t0, t2 - t1, pa_wtime() - t2);
cleanup:
  st = pa__agree_end(comm, st);
  pa__free(xadj);
  pa__free(adj);
  return st;
}

/* ---- redistribution ---- */

pa_status pa_dmesh_redistribute(pa_dmesh *dm, const int *newpart,
                                const double *weights) {
  pa_status st = PA_SUCCESS;
  int *part = NULL;
  pa_gid *vg = NULL;
  pa__recs R[PA_DMESH_NKIND];
  pa__layout lay;
  memset(R, 0, sizeof R);
  PA_CHECK(dm, PA_ERR_ARG, "pa_dmesh_redistribute: NULL dmesh");
  pa__agree_reset();
  pa_idx ne = dm->nown[PA_ELEMENT];
  int d = dm->dim;
  for (int k = 0; k < dm->nvalue; k++)
    PA_CHECK(!dm->value[k]->op.active, PA_ERR_ARG,
             "value '%s' has an exchange in flight", dm->value[k]->name);
  PA_ALLOC(part, ne);
  if (newpart) {
    for (pa_idx e = 0; e < ne; e++) {
      PA_CHECK(newpart[e] >= 0 && newpart[e] < dm->size, PA_ERR_ARG,
               "new part %d of element %d out of [0, %d)", newpart[e], (int)e,
               dm->size);
      part[e] = newpart[e];
    }
  } else {
    PA_ALLOC(vg, (size_t)ne * (d + 1));
    for (size_t k = 0; k < (size_t)ne * (d + 1); k++)
      vg[k] = dm->gid[PA_VERTEX][dm->mesh->elem[k]];
    PA_CALL(pa__agree(dm->comm, st));
    PA_CALL(pa__dmesh_partition(dm->comm, d, ne, vg, weights, part));
    pa__free(vg);
    vg = NULL;
  }
  pa__dmesh_layout(dm, &lay);
  PA_CALL(pa__dmesh_owned_recs(dm, part, &R[PA_ELEMENT], &R[PA_VERTEX],
                               &R[PA_BOUNDARY], &R[PA_EDGE]));
  pa__free(part);
  part = NULL;
  PA_CALL(pa__agree(dm->comm, st));
  pa__dmesh_clear(dm);
  PA_CALL(pa__dmesh_build(dm, &lay, dm->overlap, &R[PA_ELEMENT], &R[PA_VERTEX],
                          &R[PA_BOUNDARY], &R[PA_EDGE]));
cleanup:
  if (dm) st = pa__agree_end(dm->comm, st);
  for (int k = 0; k < PA_DMESH_NKIND; k++) pa__recs_free(&R[k]);
  pa__free(part);
  pa__free(vg);
  return st;
}

/* ---- gather ---- */

/* Vertex values gathered as mesh fields: MPI_DOUBLE on every vertex. */
static int gather_value(const pa_dmesh_value *v) {
  return v->kind == PA_VERTEX && v->ref < 0 && v->double_type;
}

/* The layout of the gathered mesh: the distributed mesh's, plus the vertex
 * values gathered as fields (their indices in vals[0..*nvals)). */
static void gather_layout(pa_dmesh *dm, pa__layout *lay, int *vals,
                          int *nvals) {
  pa__dmesh_layout(dm, lay);
  *nvals = 0;
  for (int k = 0; k < dm->nvalue && lay->nfield < PA_MESH_MAX_FIELDS; k++)
    if (gather_value(dm->value[k])) {
      snprintf(lay->fieldname[lay->nfield], PA_MESH_FIELD_NAME_LEN, "%s",
               dm->value[k]->name);
      lay->fieldncomp[lay->nfield++] = dm->value[k]->ncomp;
      vals[(*nvals)++] = k;
    }
}

/* The records of one kind from one rank, where they lie (not copied into
 * records nor end to end: their fresh pages cost more than the reads):
 * the arrays received from another rank, or the root's own mesh, whose
 * owned entities come first. Connectivities are the sending rank's local
 * vertex numbers: its n owned vertices (global ids of its vertex records),
 * then its nghost ghosts (global ids ghost, in the vertex view alone). The
 * records' global ids: gid, or gid0 + i when gid is NULL (consecutive ids,
 * sent as the first). dm, vals, nvals (the root's own): its mesh, whose
 * doubles are read in place, and the values appended to its vertices'
 * doubles; otherwise dbl holds them packed. */
typedef struct gview {
  size_t n;
  int nv, ndbl; /* vertex ids and doubles per record */
  const pa_gid *gid;
  pa_gid gid0;
  const pa_idx *conn;
  const pa_gid *ghost;
  size_t nghost;
  const double *dbl;
  const int32_t *ref;
  const uint8_t *flag;
  const pa_dmesh *dm;
  const int *vals;
  int nvals;
} gview;

/* Vertex ids and doubles per record of kind k (the layout lay). */
static void kind_shape(int d, const pa__layout *lay, int k, int *nv,
                       int *ndbl) {
  *nv = k == PA_VERTEX ? 0 : pa__kind_nv(d, k);
  *ndbl = pa__layout_kind_ndbl(lay, k);
}

/* The view of a rank's own owned entities of kind k (its mesh in place). */
static gview own_view(const pa_dmesh *dm, const pa__layout *lay, int k,
                      const int *vals, int nvals) {
  const pa_mesh *m = dm->mesh;
  gview v;
  memset(&v, 0, sizeof v);
  kind_shape(dm->dim, lay, k, &v.nv, &v.ndbl);
  v.dm = dm;
  v.vals = vals;
  v.nvals = nvals;
  if (!m) return v;
  v.n = (size_t)dm->nown[k];
  v.gid = dm->gid[k];
  v.ref = k == PA_VERTEX ? m->vref : k == PA_ELEMENT ? m->eref
          : k == PA_BOUNDARY ? m->bref : m->edref;
  v.flag = k == PA_VERTEX ? m->vflag : k == PA_ELEMENT ? m->eflag
           : k == PA_BOUNDARY ? m->bflag : m->edflag;
  v.conn = k == PA_VERTEX ? NULL : k == PA_ELEMENT ? m->elem
           : k == PA_BOUNDARY ? m->bdry : m->edge;
  if (k == PA_VERTEX) {
    v.ghost = dm->gid[PA_VERTEX] + v.n;
    v.nghost = (size_t)m->nv - v.n;
  }
  return v;
}

/* The doubles of record i of kind k of Q into x (Q->ndbl of them). */
static void view_doubles(const gview *Q, int k, size_t i, double *x) {
  if (!Q->dm) {
    memcpy(x, Q->dbl + (size_t)Q->ndbl * i, (size_t)Q->ndbl * sizeof *x);
    return;
  }
  const pa_mesh *m = Q->dm->mesh;
  if (k != PA_VERTEX) {
    pa__entity_doubles(m, k, (pa_idx)i, x);
    return;
  }
  int o = pa__vertex_doubles(m, (pa_idx)i, m->nfield, x);
  for (int q = 0; q < Q->nvals; q++) {
    const pa_dmesh_value *v = Q->dm->value[Q->vals[q]];
    memcpy(x + o, v->data + v->unit * i, v->unit);
    o += v->ncomp;
  }
}

/* The doubles of record i of kind k of Q: where they lie when packed,
 * otherwise gathered into x. */
static const double *record_doubles(const gview *Q, int k, size_t i,
                                    double *x) {
  if (!Q->dm) return Q->dbl + (size_t)Q->ndbl * i;
  view_doubles(Q, k, i, x);
  return x;
}

/* The doubles of a view of a rank's own mesh, packed record after record:
 * the mesh's coordinates when the records hold nothing else, otherwise
 * *dbl (allocated; NULL when the records have none). */
static pa_status pack_doubles(const gview *Q, int k, const double **packed,
                              double **dbl) {
  pa_status st = PA_SUCCESS;
  *packed = *dbl = NULL;
  if (!Q->ndbl || !Q->n) return PA_SUCCESS;
  if (k == PA_VERTEX && Q->ndbl == Q->dm->dim) { /* no metric, field, value */
    *packed = Q->dm->mesh->coord;
    return PA_SUCCESS;
  }
  PA_ALLOC(*dbl, Q->n * (size_t)Q->ndbl);
  for (size_t i = 0; i < Q->n; i++)
    view_doubles(Q, k, i, *dbl + (size_t)Q->ndbl * i);
  *packed = *dbl;
cleanup:
  return st;
}

/* The global id of record i of Q. */
static inline pa_gid view_gid(const gview *Q, size_t i) {
  return Q->gid ? Q->gid[i] : Q->gid0 + (pa_gid)i;
}

/* Whether the n global ids g are consecutive (g[0] + i). */
static int gids_consecutive(const pa_gid *g, size_t n) {
  for (size_t i = 1; i < n; i++)
    if (g[i] != g[0] + (pa_gid)i) return 0;
  return 1;
}

/* The arrays of a kind's records that go to the root, in this order
 * (G_GHOST: the vertex kind's alone; G_GID: the first id alone when more
 * than one are consecutive, which the build's numbering makes common). */
enum { G_GID, G_CONN, G_GHOST, G_DBL, G_REF, G_FLAG, G_NARRAY };

/* Array a of the view Q of kind k: its address and bytes. */
static const void *view_array(const gview *Q, int k, int a, size_t *bytes) {
  size_t n = Q->n;
  switch (a) {
  case G_GID:
    *bytes = (Q->gid || !n ? n : 1) * sizeof *Q->gid;
    return Q->gid ? (const void *)Q->gid : &Q->gid0;
  case G_CONN: *bytes = n * (size_t)Q->nv * sizeof *Q->conn; return Q->conn;
  case G_GHOST:
    *bytes = k == PA_VERTEX ? Q->nghost * sizeof *Q->ghost : 0;
    return Q->ghost;
  case G_DBL: *bytes = n * (size_t)Q->ndbl * sizeof *Q->dbl; return Q->dbl;
  case G_REF: *bytes = n * sizeof *Q->ref; return Q->ref;
  default: *bytes = n * sizeof *Q->flag; return Q->flag;
  }
}

/* Every other rank's owned entities to the root, one rank at a time, array
 * by array from where they lie in its mesh (only the doubles are packed),
 * kept on the root as received: array a of kind k from rank r in
 * buf[(r * PA_DMESH_NKIND + k) * G_NARRAY + a] (n[...] bytes). Each step
 * is agreed before it starts, the first on st (the status so far); the
 * status of the last one is the caller's to agree. */
static pa_status records_to_root(pa_dmesh *dm, int root, const pa__layout *lay,
                                 const int *vals, int nvals, void **buf,
                                 size_t *n, pa_status st) {
  double *dbl = NULL;
  for (int r = 0; r < dm->size; r++) {
    PA_CALL(pa__agree(dm->comm, st));
    if (r == root || (dm->rank != r && dm->rank != root)) continue;
    for (int k = 0; k < PA_DMESH_NKIND && !st; k++) {
      gview Q = own_view(dm, lay, k, vals, nvals);
      if (dm->rank == r) st = pack_doubles(&Q, k, &Q.dbl, &dbl);
      if (dm->rank == r && Q.n > 1 && gids_consecutive(Q.gid, Q.n)) {
        Q.gid0 = Q.gid[0];
        Q.gid = NULL;
      }
      for (int a = 0; a < G_NARRAY && !st; a++) {
        size_t i = ((size_t)r * PA_DMESH_NKIND + k) * G_NARRAY + a, bytes;
        const void *p = view_array(&Q, k, a, &bytes);
        st = dm->rank == r ? pa__xchg_send(dm->comm, root, p, bytes)
                           : pa__xchg_recv(dm->comm, r, &buf[i], &n[i]);
      }
      pa__free(dbl);
      dbl = NULL;
    }
  }
cleanup:
  pa__free(dbl);
  return st;
}

/* On the root: V[k * size + r], the records of kind k from rank r: the
 * root's own (own_view) and the arrays buf, n of the others (see
 * records_to_root), whose sizes are checked. */
static pa_status map_views(const pa_dmesh *dm, int root, const pa__layout *lay,
                           const int *vals, int nvals, void *const *buf,
                           const size_t *n, gview *V) {
  pa_status st = PA_SUCCESS;
  int size = dm->size;
  for (int r = 0; r < size; r++)
    for (int k = 0; k < PA_DMESH_NKIND; k++) {
      gview *v = &V[k * size + r];
      if (r == root) {
        *v = own_view(dm, lay, k, vals, nvals);
        continue;
      }
      void *const *b = buf + ((size_t)r * PA_DMESH_NKIND + k) * G_NARRAY;
      const size_t *nb = n + ((size_t)r * PA_DMESH_NKIND + k) * G_NARRAY;
      memset(v, 0, sizeof *v);
      kind_shape(dm->dim, lay, k, &v->nv, &v->ndbl);
      v->n = nb[G_REF] / sizeof(int32_t); /* the sender's count */
      v->nghost = k == PA_VERTEX ? nb[G_GHOST] / sizeof(pa_gid) : 0;
      v->gid = b[G_GID]; /* NULL or 8 bytes: consecutive */
      if (v->n > 1 && nb[G_GID] == sizeof(pa_gid)) {
        v->gid0 = v->gid[0];
        v->gid = NULL;
      }
      for (int a = 0; a < G_NARRAY; a++) {
        size_t bytes;
        view_array(v, k, a, &bytes);
        PA_CHECK(nb[a] == bytes, PA_ERR_INTERNAL,
                 "gather: %zu bytes of array %d of kind %d from rank %d, "
                 "%zu expected", nb[a], a, k, r, bytes);
      }
      v->conn = b[G_CONN];
      v->ghost = b[G_GHOST];
      v->dbl = b[G_DBL];
      v->ref = b[G_REF];
      v->flag = b[G_FLAG];
    }
cleanup:
  return st;
}

/* The records of one kind of every rank in increasing global id, chunk by
 * chunk (records of one rank in a row). When every rank's records come by
 * increasing global id (the build numbers owned entities so), a merge of
 * those runs; otherwise a stable sort of all global ids end to end (key,
 * off: rank r's from off[r]) into ord. Equal global ids come by rank
 * either way. */
typedef struct gorder {
  const gview *V; /* the kind's views of every rank */
  int size;
  size_t *pos;    /* merge: the next record of each rank */
  pa_idx *ord;    /* sort: the order of the records end to end, or NULL */
  size_t *off, j, n;
} gorder;

/* Up to this many ranks, the merge scans every rank's next record where
 * the runs interleave: a scan of a handful of heads costs less than the
 * sort's passes; above, the sort. */
#define GATHER_MERGE_MAX_RANKS 16

/* Whether the n global ids g come in non-decreasing order. */
static int gids_sorted(const pa_gid *g, size_t n) {
  for (size_t i = 1; i < n; i++)
    if (g[i] < g[i - 1]) return 0;
  return 1;
}

/* The order of the n records of views V (size ranks), with their range of
 * global ids [*lo, *hi) (0, 0 when there are none). */
static pa_status gorder_init(gorder *o, const gview *V, int size, size_t n,
                             pa_gid *lo, pa_gid *hi) {
  pa_status st = PA_SUCCESS;
  pa_gid *key = NULL;
  int merge = size <= GATHER_MERGE_MAX_RANKS;
  memset(o, 0, sizeof *o);
  o->V = V;
  o->size = size;
  o->n = n;
  for (int r = 0; r < size && merge; r++)
    merge = !V[r].gid || gids_sorted(V[r].gid, V[r].n);
  *lo = INT64_MAX;
  *hi = -1;
  PA_CALLOC(o->pos, (size_t)size);
  PA_ALLOC(o->off, (size_t)size + 1);
  o->off[0] = 0;
  for (int r = 0; r < size; r++) o->off[r + 1] = o->off[r] + V[r].n;
  if (merge) {
    for (int r = 0; r < size; r++) {
      if (!V[r].n) continue;
      if (view_gid(&V[r], 0) < *lo) *lo = view_gid(&V[r], 0);
      pa_gid last = view_gid(&V[r], V[r].n - 1);
      if (last > *hi) *hi = last;
    }
  } else {
    PA_ALLOC(key, n ? n : 1);
    PA_ALLOC(o->ord, n ? n : 1);
    for (int r = 0; r < size; r++)
      for (size_t i = 0; i < V[r].n; i++)
        key[o->off[r] + i] = view_gid(&V[r], i);
    for (size_t i = 0; i < n; i++) {
      o->ord[i] = (pa_idx)i;
      if (key[i] < *lo) *lo = key[i];
      if (key[i] > *hi) *hi = key[i];
    }
    PA_CALL(pa__sort_by_gid(o->ord, n, key));
  }
  if (!n) *lo = 0;
  *hi += 1;
cleanup:
  pa__free(key);
  return st;
}

static void gorder_free(gorder *o) {
  pa__free(o->pos);
  pa__free(o->ord);
  pa__free(o->off);
}

/* The rank whose records hold position g of the records end to end. */
static int rank_of(const size_t *off, int size, size_t g) {
  int lo = 0, hi = size - 1;
  while (lo < hi) {
    int mid = (lo + hi + 1) / 2;
    if (off[mid] <= g) lo = mid;
    else hi = mid - 1;
  }
  return lo;
}

/* The next chunk of o: records [*i, *i + count) of rank *r; returns the
 * count, 0 at the end. */
static size_t gorder_next(gorder *o, int *r, size_t *i) {
  if (o->ord) {
    if (o->j >= o->n) return 0;
    size_t g = (size_t)o->ord[o->j], c = 1;
    *r = rank_of(o->off, o->size, g);
    *i = g - o->off[*r];
    while (o->j + c < o->n && (size_t)o->ord[o->j + c] == g + c &&
           g + c < o->off[*r + 1])
      c++;
    o->j += c;
    return c;
  }
  int best = -1;
  pa_gid bg = 0, bound = INT64_MAX;
  for (int q = 0; q < o->size; q++) {
    if (o->pos[q] >= o->V[q].n) continue;
    pa_gid g = view_gid(&o->V[q], o->pos[q]);
    if (best < 0 || g < bg) {
      if (best >= 0) bound = bg;
      best = q;
      bg = g;
    } else if (g < bound) {
      bound = g;
    }
  }
  if (best < 0) return 0;
  const gview *Q = &o->V[best];
  size_t p = o->pos[best], c = 1, step = 1, hi;
  /* the first of the run's next records not below bound, found by
   * doubling then halving (runs are long where ranks own ranges) */
  while (p + c + step <= Q->n && view_gid(Q, p + c + step - 1) < bound) {
    c += step;
    step *= 2;
  }
  hi = p + c + step <= Q->n ? c + step - 1 : Q->n - p; /* it is in [c, hi] */
  while (c < hi) {
    size_t mid = c + (hi - c) / 2;
    if (view_gid(Q, p + mid) < bound) c = mid + 1;
    else hi = mid;
  }
  *r = best;
  *i = p;
  o->pos[best] = p + c;
  return c;
}

/* The global id of local vertex c of the rank of vertex view Q. */
static pa_gid local_gid(const gview *Q, size_t c) {
  return c < Q->n ? view_gid(Q, c) : Q->ghost[c - Q->n];
}

/* The position of global id g among the sorted ids of the records of Q,
 * or -1. */
static ptrdiff_t find_gid(const gview *Q, pa_gid g) {
  if (!Q->gid) /* consecutive */
    return g >= Q->gid0 && g < Q->gid0 + (pa_gid)Q->n ? (ptrdiff_t)(g - Q->gid0)
                                                      : -1;
  size_t k = pa__gid_lower_bound(Q->gid, Q->n, g);
  return k < Q->n && Q->gid[k] == g ? (ptrdiff_t)k : -1;
}

/* The output vertices of every rank's local vertices: rank r's in
 * loc[off[r] .. off[r + 1]) (V: the vertex views), its owned ones set as
 * they were assembled, its ghosts here (-1: owned by no rank): found by
 * bisection in the owning rank's records when every rank's come sorted,
 * otherwise through an index of the owned global ids, in [lo, hi). */
static pa_status ghost_vertices(const gview *V, int size, const size_t *off,
                                int sorted, pa_gid lo, pa_gid hi,
                                pa_idx *loc) {
  pa_status st = PA_SUCCESS;
  pa__gidindex vmap = {0};
  if (!sorted) {
    PA_CALL(pa__gidindex_init(&vmap, lo, hi, off[size]));
    for (int r = 0; r < size; r++)
      for (size_t i = 0; i < V[r].n; i++)
        PA_CALL(pa__gidindex_put(&vmap, view_gid(&V[r], i), loc[off[r] + i],
                                 NULL, NULL));
  }
  for (int r = 0; r < size; r++)
    for (size_t i = 0; i < V[r].nghost; i++) {
      pa_gid g = V[r].ghost[i];
      pa_idx v = -1;
      if (!sorted) v = pa__gidindex_get(&vmap, g);
      for (int q = 0; q < size && sorted && v < 0; q++) {
        ptrdiff_t p = q == r ? -1 : find_gid(&V[q], g);
        if (p >= 0) v = loc[off[q] + (size_t)p];
      }
      loc[off[r] + V[r].n + i] = v;
    }
cleanup:
  pa__gidindex_free(&vmap);
  return st;
}

/* On the root: the mesh of the gathered records V (see map_views), every
 * kind by increasing global id (whatever the ranks' order), element
 * vertices found by global id. */
static pa_status assemble_by_gid(int d, const pa__layout *lay, int size,
                                 const gview *V, pa_mesh **mp) {
  pa_status st = PA_SUCCESS;
  pa_mesh *m = NULL;
  gorder o;
  double *xbuf = NULL;
  pa_idx *loc = NULL; /* see ghost_vertices */
  size_t nk[PA_DMESH_NKIND] = {0}, *loff = NULL;
  memset(&o, 0, sizeof o);
  for (int k = 0; k < PA_DMESH_NKIND; k++)
    for (int r = 0; r < size; r++) nk[k] += V[k * size + r].n;
  PA_ALLOC(loff, (size_t)size + 1);
  loff[0] = 0;
  for (int r = 0; r < size; r++)
    loff[r + 1] = loff[r] + V[PA_VERTEX * size + r].n +
                  V[PA_VERTEX * size + r].nghost;
  PA_ALLOC(loc, loff[size] ? loff[size] : 1);
  PA_CALL(pa_mesh_create(d, &m));
  m->met_ncomp = lay->met_ncomp;
  m->nfield = lay->nfield;
  for (int f = 0; f < lay->nfield; f++) {
    snprintf(m->field[f].name, PA_MESH_FIELD_NAME_LEN, "%s", lay->fieldname[f]);
    m->field[f].ncomp = lay->fieldncomp[f];
  }
  if (lay->geo) PA_CALL(pa__mesh_enable_entities(m));
  PA_CALL(pa_mesh_reserve(m, (pa_idx)nk[PA_VERTEX], (pa_idx)nk[PA_ELEMENT],
                          (pa_idx)nk[PA_BOUNDARY], (pa_idx)nk[PA_EDGE]));
  PA_CALL(pa__layout_cell_fields(lay, m));
  {
    int nd = 1;
    for (int k = 0; k < PA_DMESH_NKIND; k++)
      if (V[k * size].ndbl >= nd) nd = V[k * size].ndbl + 1;
    PA_ALLOC(xbuf, (size_t)nd);
  }
  for (int k = 0; k < PA_DMESH_NKIND; k++) {
    const gview *Vk = V + (size_t)k * size;
    pa_gid lo, hi, last = -1;
    int r;
    size_t i0, c, j = 0;
    PA_CALL(gorder_init(&o, Vk, size, nk[k], &lo, &hi));
    pa_idx *conn = k == PA_ELEMENT ? m->elem
                   : k == PA_BOUNDARY ? m->bdry : m->edge;
    int32_t *ref = k == PA_VERTEX ? m->vref : k == PA_ELEMENT ? m->eref
                   : k == PA_BOUNDARY ? m->bref : m->edref;
    uint8_t *flag = k == PA_VERTEX ? m->vflag : k == PA_ELEMENT ? m->eflag
                    : k == PA_BOUNDARY ? m->bflag : m->edflag;
    while ((c = gorder_next(&o, &r, &i0)) > 0) {
      const gview *Q = &Vk[r];
      for (size_t i = i0; i < i0 + c; i++, j++) {
        ref[j] = Q->ref[i];
        flag[j] = Q->flag[i];
        if (k == PA_VERTEX) {
          pa__vertex_set_doubles(m, (pa_idx)j, record_doubles(Q, k, i, xbuf));
          pa_gid g = view_gid(Q, i);
          PA_CHECK(j == 0 || g != last, PA_ERR_MESH,
                   "vertex global id %lld owned twice", (long long)last);
          last = g;
          loc[loff[r] + i] = (pa_idx)j;
          continue;
        }
        int nv = Q->nv;
        const pa_idx *lr = loc + loff[r], *cq = Q->conn + (size_t)nv * i;
        size_t nl = loff[r + 1] - loff[r];
        for (int q = 0; q < nv; q++) {
          pa_idx lv = cq[q];
          PA_CHECK(lv >= 0 && (size_t)lv < nl, PA_ERR_INTERNAL,
                   "gather: local vertex %lld of rank %d out of range",
                   (long long)lv, r);
          PA_CHECK(lr[lv] >= 0, PA_ERR_MESH,
                   "gather: vertex %lld is owned by no rank",
                   (long long)local_gid(&V[PA_VERTEX * size + r], (size_t)lv));
          conn[(size_t)nv * j + q] = lr[lv];
        }
        if (Q->ndbl)
          pa__entity_set_doubles(m, k, (pa_idx)j,
                                 record_doubles(Q, k, i, xbuf));
      }
    }
    int sorted = o.ord == NULL;
    gorder_free(&o);
    memset(&o, 0, sizeof o);
    if (k == PA_VERTEX)
      PA_CALL(ghost_vertices(Vk, size, loff, sorted, lo, hi, loc));
  }
  m->nv = (pa_idx)nk[PA_VERTEX];
  m->ne = (pa_idx)nk[PA_ELEMENT];
  m->nb = (pa_idx)nk[PA_BOUNDARY];
  m->ned = (pa_idx)nk[PA_EDGE];
  *mp = m;
  m = NULL;
cleanup:
  pa_mesh_destroy(m);
  gorder_free(&o);
  pa__free(xbuf);
  pa__free(loc);
  pa__free(loff);
  return st;
}

pa_status pa_dmesh_gather(pa_dmesh *dm, int root, pa_mesh **meshp) {
  pa_status st = PA_SUCCESS;
  pa__layout lay;
  void **buf = NULL;
  size_t *nbuf = NULL, nb = 0;
  gview *V = NULL;
  int vals[PA_MESH_MAX_FIELDS], nvals = 0;
  double t1, t2;
  PA_CHECK(dm && meshp, PA_ERR_ARG, "pa_dmesh_gather: NULL argument");
  pa__agree_reset();
  *meshp = NULL;
  PA_CHECK(root >= 0 && root < dm->size, PA_ERR_ARG, "root %d out of range",
           root);
  gather_layout(dm, &lay, vals, &nvals);
  if (dm->rank == root) {
    nb = (size_t)dm->size * PA_DMESH_NKIND * G_NARRAY;
    buf = pa__calloc(nb, sizeof *buf);
    nbuf = pa__calloc(nb, sizeof *nbuf);
    V = pa__malloc((size_t)dm->size * PA_DMESH_NKIND * sizeof *V);
    if (!buf || !nbuf || !V)
      st = pa__error(PA_ERR_MEMORY, __FILE__, __LINE__, "out of memory");
  }
  t1 = pa_wtime();
  st = records_to_root(dm, root, &lay, vals, nvals, buf, nbuf, st);
  t2 = pa_wtime();
  if (st || dm->rank != root) goto cleanup;
  PA_CALL(map_views(dm, root, &lay, vals, nvals, buf, nbuf, V));
  PA_CALL(assemble_by_gid(dm->dim, &lay, dm->size, V, meshp));
  pa__info(2, "padapt: rank %d: gather: to the root %.3f s, assembly %.3f s\n",
           dm->rank, t2 - t1, pa_wtime() - t2);
cleanup:
  if (dm) st = pa__agree_end(dm->comm, st);
  if (st && meshp && *meshp) {
    pa_mesh_destroy(*meshp);
    *meshp = NULL;
  }
  for (size_t i = 0; buf && i < nb; i++) pa__free(buf[i]);
  pa__free(buf);
  pa__free(nbuf);
  pa__free(V);
  return st;
}
