/*
 * dlevelset.c -- the level-set cut of a distributed mesh
 * (pa_dmesh_levelset_cut): the steps of src/metric/lscut.c run on each
 * rank's owned entities, their collective parts through the hooks of a
 * pa__ls_ctx, and the distributed mesh is rebuilt from the result.
 *
 *  - Snapping flags and component labels of a vertex are combined over its
 *    copies (reduce MAX / MIN to the owner, halo back); volumes are summed
 *    and the per-component volumes gathered on every rank: the values the
 *    cut uses are the sequential ones, whatever the ranks.
 *  - Each rank cuts its owned elements, boundary entities and edges. An
 *    edge cut on several ranks is cut at the same point by each (the same
 *    ends in key order, the same bits); one global id per edge is agreed at
 *    a home rank (hash of the end ids): the home numbers the edges it
 *    receives (fresh ids above the largest vertex id, by an exclusive scan
 *    of the homes' counts), ORs the sides each copy saw, and names the
 *    lowest requesting rank the giver of the vertex record.
 *  - A face whose vertices are all on the zero set, in an uncut element, is
 *    an interface entity when one element of each side holds it: its
 *    candidates (one per element holding it) meet at a home rank, which
 *    gives the interface entity.
 *  - The rebuild (pa__dmesh_build, the dmesh's overlap): owned vertices by
 *    their owners (the interface's reference from the sides the copies
 *    saw), added vertices by their givers, the output elements, boundary
 *    entities and edges of every rank. An entity kept whole keeps its id
 *    and (when its reference, which may filter values, did not change, or
 *    no value of its kind filters) its values; the others get fresh ids
 *    and zero values.
 * All point-to-point traffic goes through pa__recs_migrate (the exchange
 * layer).
 */
#include "adapt/piece.h"
#include "metric/lscut.h"

#include <stdlib.h>

/* Flag of a reply from the edges' home: this rank gives the vertex. */
#define GIVER 0x80

/* ---- the hooks of the distributed context ------------------------------- */

static pa_status d_sum(void *ctx, double *x, int n) {
  pa_dmesh *dm = ctx;
  return pa__allreduce(dm->comm, x, n, MPI_DOUBLE, MPI_SUM);
}

static pa_status d_max(void *ctx, double *x, int n) {
  pa_dmesh *dm = ctx;
  return pa__allreduce(dm->comm, x, n, MPI_DOUBLE, MPI_MAX);
}

/* Combine n bytes-per-vertex values x of type t over the copies (op), the
 * result on every copy. */
static pa_status vertex_combine(pa_dmesh *dm, void *x, MPI_Datatype t,
                                size_t unit, MPI_Op op) {
  pa_status st = PA_SUCCESS;
  pa_dmesh_value *val = NULL;
  pa_idx n;
  PA_CALL(pa_dmesh_value_add(dm, PA_VERTEX, "pa.ls.combine", t, 1, -1, &val));
  unsigned char *d = pa_dmesh_value_data(val, &n, NULL);
  if (n) memcpy(d, x, unit * (size_t)n);
  PA_CALL(pa_dmesh_reduce(dm, val, op));
  PA_CALL(pa_dmesh_halo(dm, val));
  if (n) memcpy(x, d, unit * (size_t)n);
cleanup:
  return pa__dmesh_value_drop(dm, val, pa__agree_end(dm->comm, st));
}

static pa_status d_vmax(void *ctx, uint8_t *f) {
  return vertex_combine(ctx, f, MPI_UINT8_T, 1, MPI_MAX);
}

static pa_status d_vmin(void *ctx, pa_gid *x) {
  return vertex_combine(ctx, x, MPI_INT64_T, sizeof *x, MPI_MIN);
}

static pa_status d_gather(void *ctx, const pa_gid *lab, const double *vol,
                          size_t n, pa_gid **alab, double **avol,
                          size_t *nall) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = ctx;
  int *cnt = NULL, *off = NULL, mine = (int)n;
  *alab = NULL;
  *avol = NULL;
  PA_ALLOC(cnt, dm->size);
  PA_ALLOC(off, dm->size);
  PA_CALL(pa__agree(dm->comm, st));
  PA_CALL_MPI(MPI_Allgather(&mine, 1, MPI_INT, cnt, 1, MPI_INT, dm->comm));
  size_t tot = 0;
  for (int r = 0; r < dm->size; r++) {
    off[r] = (int)tot;
    tot += (size_t)cnt[r];
  }
  PA_CHECK(tot < (size_t)INT32_MAX, PA_ERR_ARG,
           "level set: too many components (%zu) to remove small ones", tot);
  PA_ALLOC(*alab, tot);
  PA_ALLOC(*avol, tot);
  PA_CALL(pa__agree(dm->comm, st));
  PA_CALL_MPI(MPI_Allgatherv(lab, mine, MPI_INT64_T, *alab, cnt, off,
                             MPI_INT64_T, dm->comm));
  PA_CALL_MPI(MPI_Allgatherv(vol, mine, MPI_DOUBLE, *avol, cnt, off,
                             MPI_DOUBLE, dm->comm));
  *nall = tot;
cleanup:
  pa__free(cnt);
  pa__free(off);
  st = pa__agree_end(dm->comm, st);
  if (st) {
    pa__free(*alab);
    pa__free(*avol);
    *alab = NULL;
    *avol = NULL;
  }
  return st;
}

static pa_status d_agree(void *ctx, pa_status st) {
  pa_dmesh *dm = ctx;
  return pa__agree(dm->comm, st);
}

static void ctx_dist(pa_dmesh *dm, pa__ls_ctx *c) {
  memset(c, 0, sizeof *c);
  c->mesh = dm->mesh;
  c->nelem = dm->nown[PA_ELEMENT];
  c->nbdry = dm->nown[PA_BOUNDARY];
  c->nedge = dm->nown[PA_EDGE];
  c->nvert = dm->nown[PA_VERTEX];
  c->vkey = dm->gid[PA_VERTEX];
  c->ekey = dm->gid[PA_ELEMENT];
  c->sum = d_sum;
  c->max = d_max;
  c->vmax = d_vmax;
  c->vmin = d_vmin;
  c->gather = d_gather;
  c->agree = d_agree;
  c->ctx = dm;
}

/* ---- the earlier interface ------------------------------------------------ */

/* drop[b] for the owned boundary entities of reference ref that lie inside
 * the domain (two elements hold them, over every rank); the counts of that
 * reference inside and on the boundary, summed over the ranks. */
static pa_status old_interface(pa_dmesh *dm, int32_t ref, uint8_t *drop,
                               pa_gid *cnt) {
  pa_status st = PA_SUCCESS;
  pa_mesh *m = dm->mesh;
  pa_dmesh_value *val = NULL;
  int d = dm->dim, nve = d + 1;
  double any = 0;
  cnt[0] = cnt[1] = 0;
  for (pa_idx b = 0; b < dm->nown[PA_BOUNDARY] && !any; b++) any = m->bref[b] == ref;
  PA_CALL(pa__allreduce(dm->comm, &any, 1, MPI_DOUBLE, MPI_MAX));
  if (!any) return st;
  PA_CALL(pa_dmesh_value_add(dm, PA_BOUNDARY, "pa.ls.held", MPI_INT, 1, -1,
                             &val));
  {
    int *h = pa_dmesh_value_data(val, NULL, NULL);
    for (pa_idx b = 0; b < dm->nloc[PA_BOUNDARY]; b++) h[b] = 0;
    for (pa_idx e = 0; e < dm->nown[PA_ELEMENT] && st == PA_SUCCESS; e++)
      for (int i = 0; i < nve; i++) {
        pa_idx f[3], b;
        pa__elem_face(m, e, i, f);
        st = pa_mesh_find_bdry(m, f, &b);
        if (st != PA_SUCCESS) break;
        if (b >= 0 && m->bref[b] == ref) h[b]++;
      }
  }
  PA_CALL(pa__agree(dm->comm, st));
  PA_CALL(pa_dmesh_reduce(dm, val, MPI_SUM));
  {
    const int *h = pa_dmesh_value_data(val, NULL, NULL);
    for (pa_idx b = 0; b < dm->nown[PA_BOUNDARY]; b++) {
      if (m->bref[b] != ref) continue;
      drop[b] = h[b] == 2;
      cnt[0] += drop[b];
      cnt[1] += !drop[b];
    }
  }
  PA_CALL(pa__allreduce(dm->comm, cnt, 2, MPI_INT64_T, MPI_SUM));
cleanup:
  return pa__dmesh_value_drop(dm, val, pa__agree_end(dm->comm, st));
}

/* ---- rendezvous at home ranks ---------------------------------------------- */

/* The home rank of n sorted ids. */
static int home(const pa_gid *k, int n, int size) {
  uint64_t h = 0x9e3779b97f4a7c15ull;
  for (int i = 0; i < n; i++) h = pa__mix64(h ^ (uint64_t)k[i]);
  return (int)(h % (uint64_t)size);
}

/* Record indices ordered by their sorted vertex ids (then aux). */
typedef struct rkey {
  pa_gid k[3];
  int aux;
  size_t i;
} rkey;

static int rkey_cmp(const void *a, const void *b) {
  const rkey *x = a, *y = b;
  for (int j = 0; j < 3; j++)
    if (x->k[j] != y->k[j]) return (x->k[j] > y->k[j]) - (x->k[j] < y->k[j]);
  if (x->aux != y->aux) return (x->aux > y->aux) - (x->aux < y->aux);
  return (x->i > y->i) - (x->i < y->i);
}

static pa_status sorted_keys(const pa__recs *R, rkey **out) {
  pa_status st = PA_SUCCESS;
  rkey *k = NULL;
  PA_ALLOC(k, R->n);
  for (size_t i = 0; i < R->n; i++) {
    k[i].k[0] = k[i].k[1] = k[i].k[2] = -1;
    for (int j = 0; j < R->nv; j++) k[i].k[j] = R->vgid[(size_t)R->nv * i + j];
    for (int a = 1; a < R->nv; a++)
      for (int b = a; b > 0 && k[i].k[b] < k[i].k[b - 1]; b--) {
        pa_gid t = k[i].k[b];
        k[i].k[b] = k[i].k[b - 1];
        k[i].k[b - 1] = t;
      }
    k[i].aux = R->aux[i];
    k[i].i = i;
  }
  qsort(k, R->n, sizeof *k, rkey_cmp);
  *out = k;
cleanup:
  return st;
}

static int same_key(const rkey *a, const rkey *b) {
  return a->k[0] == b->k[0] && a->k[1] == b->k[1] && a->k[2] == b->k[2];
}

/* The global ids of the added vertices (gid[k]), the sides their copies saw
 * (o->addtouch, ORed over the ranks) and whether this rank gives each
 * (give[k]); *ncut: the edges cut over every rank. */
static pa_status agree_added(pa_dmesh *dm, pa__ls_out *o, pa_gid *gid,
                             uint8_t *give, pa_gid *ncut) {
  pa_status st = PA_SUCCESS;
  pa__recs Q, H, A;
  int *dest = NULL;
  rkey *hk = NULL, *mk = NULL;
  const pa_gid *vg = dm->gid[PA_VERTEX];
  pa__recs_init(&Q, PA_EDGE, 2, 0);
  pa__recs_init(&H, PA_EDGE, 2, 0);
  pa__recs_init(&A, PA_EDGE, 2, 0);
  PA_ALLOC(dest, o->nadd);
  for (pa_idx k = 0; k < o->nadd; k++) {
    pa_gid e[2] = {vg[o->end[2 * (size_t)k]], vg[o->end[2 * (size_t)k + 1]]};
    PA_CALL(pa__recs_add(&Q, 0, e, 0, o->addtouch[k], dm->rank, NULL, NULL, 0));
    dest[k] = home(e, 2, dm->size); /* e[0] < e[1]: key order */
  }
  PA_CALL(pa__agree(dm->comm, st));
  PA_CALL(pa__recs_migrate(dm->comm, &Q, dest, &H));
  pa__free(dest);
  dest = NULL;
  /* at home: number the distinct edges, OR the sides, name the giver */
  PA_CALL(sorted_keys(&H, &hk));
  pa_gid nd = 0, first = 0, maxg = -1, off = 0;
  for (size_t i = 0; i < H.n; i++) nd += i == 0 || !same_key(&hk[i], &hk[i - 1]);
  for (pa_idx v = 0; v < dm->nloc[PA_VERTEX]; v++)
    if (vg[v] > maxg) maxg = vg[v];
  PA_CALL(pa__allreduce(dm->comm, &maxg, 1, MPI_INT64_T, MPI_MAX));
  PA_CALL_MPI(MPI_Exscan(&nd, &off, 1, MPI_INT64_T, MPI_SUM, dm->comm));
  if (dm->rank == 0) off = 0;
  *ncut = nd;
  PA_CALL(pa__allreduce(dm->comm, ncut, 1, MPI_INT64_T, MPI_SUM));
  first = maxg + 1 + off;
  PA_ALLOC(dest, H.n);
  for (size_t i = 0, j; i < H.n; i = j) {
    uint8_t sides = 0;
    for (j = i; j < H.n && same_key(&hk[j], &hk[i]); j++) sides |= H.flag[hk[j].i];
    for (size_t q = i; q < j; q++) {
      size_t r = hk[q].i;
      uint8_t f = (uint8_t)(sides | (q == i ? GIVER : 0));
      PA_CALL(pa__recs_add(&A, first, H.vgid + 2 * r, 0, f, H.aux[r], NULL,
                           NULL, 0));
      dest[A.n - 1] = H.aux[r];
    }
    first++;
  }
  pa__recs_free(&H);
  PA_CALL(pa__agree(dm->comm, st));
  PA_CALL(pa__recs_migrate(dm->comm, &A, dest, &H));
  /* back home: match the answers to the added vertices by their ends */
  pa__free(hk);
  hk = NULL;
  PA_CALL(sorted_keys(&Q, &mk));
  PA_CALL(sorted_keys(&H, &hk));
  PA_CHECK(H.n == Q.n, PA_ERR_INTERNAL, "level set: %zu answers for %zu edges",
           H.n, Q.n);
  for (size_t i = 0; i < H.n; i++) {
    PA_CHECK(same_key(&hk[i], &mk[i]), PA_ERR_INTERNAL,
             "level set: the answer for edge %lld-%lld is missing",
             (long long)mk[i].k[0], (long long)mk[i].k[1]);
    size_t k = mk[i].i, r = hk[i].i;
    gid[k] = H.gid[r];
    give[k] = (H.flag[r] & GIVER) != 0;
    o->addtouch[k] = (uint8_t)(H.flag[r] & ~GIVER);
  }
cleanup:
  pa__recs_free(&Q);
  pa__recs_free(&H);
  pa__recs_free(&A);
  pa__free(dest);
  pa__free(hk);
  pa__free(mk);
  return pa__agree_end(dm->comm, st);
}

/* The interface entities among the faces on the zero set (o->zero), found
 * at their home ranks (pa__ls_zero_faces on the candidates received, their
 * vertices numbered by position in the records' ids): records appended to
 * B (ids set by the caller), *nface their count on this rank. */
static pa_status zero_faces(pa_dmesh *dm, const pa__ls_out *o, int32_t ref,
                            pa__recs *B, pa_gid *nface) {
  pa_status st = PA_SUCCESS;
  pa__recs Q, H;
  pa__ls_cells z, f;
  int *dest = NULL, d = dm->dim;
  double *zero = NULL; /* B's boundary fields: zeros on the interface */
  const pa_gid *vg = dm->gid[PA_VERTEX];
  pa__recs_init(&Q, PA_BOUNDARY, d, 0);
  pa__recs_init(&H, PA_BOUNDARY, d, 0);
  memset(&z, 0, sizeof z);
  memset(&f, 0, sizeof f);
  *nface = 0;
  PA_ALLOC(dest, o->zero.n);
  for (pa_idx i = 0; i < o->zero.n; i++) {
    pa_gid g[3], s[3];
    for (int j = 0; j < d; j++) s[j] = g[j] = vg[o->zero.v[(size_t)d * i + j]];
    pa__gid_sort_unique(s, (size_t)d);
    PA_CALL(pa__recs_add(&Q, 0, g, o->zero.ref[i], 0, dm->rank, NULL, NULL, 0));
    dest[i] = home(s, d, dm->size);
  }
  PA_CALL(pa__agree(dm->comm, st));
  PA_CALL(pa__recs_migrate(dm->comm, &Q, dest, &H));
  z.nvc = f.nvc = d;
  z.n = (pa_idx)H.n;
  PA_ALLOC(z.v, (size_t)d * H.n);
  for (size_t k = 0; k < (size_t)d * H.n; k++) z.v[k] = (pa_idx)k;
  z.ref = H.ref;
  PA_CALL(pa__ls_zero_faces(&z, H.vgid, ref, &f));
  if (B->ndbl) PA_CALLOC(zero, B->ndbl);
  for (pa_idx i = 0; i < f.n; i++) {
    pa_gid g[3];
    for (int j = 0; j < d; j++) g[j] = H.vgid[f.v[(size_t)d * i + j]];
    PA_CALL(pa__recs_add(B, -1, g, ref, 0, dm->rank, zero, NULL, 0));
  }
  *nface = f.n;
cleanup:
  z.ref = NULL; /* H's */
  pa__free(z.v);
  pa__free(f.v);
  pa__free(f.ref);
  pa__free(f.flag);
  pa__free(f.parent);
  pa__free(zero);
  pa__recs_free(&Q);
  pa__recs_free(&H);
  pa__free(dest);
  return pa__agree_end(dm->comm, st);
}

/* ---- the records of the rebuild ---------------------------------------- */

/* 1 if a value of dm attached to entities of a kind filters by reference:
 * the payload of an entity then depends on its reference. */
static int kind_filters(const pa_dmesh *dm, int kind) {
  for (int k = 0; k < dm->nvalue; k++)
    if ((int)dm->value[k]->kind == kind && dm->value[k]->ref >= 0) return 1;
  return 0;
}

/* Bytes of the values of an entity of a kind and reference ref (those
 * whose reference filter it passes). */
static size_t value_paylen(const pa_dmesh *dm, int kind, int32_t ref) {
  size_t n = 0;
  for (int k = 0; k < dm->nvalue; k++) {
    const pa_dmesh_value *v = dm->value[k];
    if ((int)v->kind == kind && (v->ref < 0 || v->ref == ref)) n += v->unit;
  }
  return n;
}

/* The payload of an output cell of a kind: its parent's values when it is
 * kept whole (parent >= 0; with its reference, when values filter by it),
 * else zeros. Returns its length in buf (room: the largest payload). */
static size_t cell_payload(const pa_dmesh *dm, int kind, pa_idx parent,
                           int32_t ref, unsigned char *buf) {
  if (parent >= 0 &&
      (!kind_filters(dm, kind) || pa__dmesh_ref(dm, kind, parent) == ref))
    return pa__entity_payload(dm, kind, parent, buf);
  size_t n = value_paylen(dm, kind, ref);
  memset(buf, 0, n);
  return n;
}

/* The largest payload of any entity of a kind (every value). */
static size_t max_payload(const pa_dmesh *dm, int kind) {
  size_t n = 0;
  for (int k = 0; k < dm->nvalue; k++)
    if ((int)dm->value[k]->kind == kind) n += dm->value[k]->unit;
  return n;
}

/* The records of the cells of a kind (elements, boundary entities, edges):
 * kept ones with their ids, the others with fresh ids from *next, each with
 * the element or boundary fields of the cell it comes from (kept whole or a
 * part of it, as pa_mesh_levelset_cut; zeros for a new interface entity).
 * vg: the global id of each output vertex (local, then added). */
static pa_status cell_records(pa_dmesh *dm, int kind, const pa__ls_cells *c,
                              const pa_gid *vg, pa_gid *next, pa__recs *R) {
  pa_status st = PA_SUCCESS;
  unsigned char *pay = NULL;
  double *dbl = NULL;
  size_t maxp = max_payload(dm, kind);
  pa_gid v[4];
  if (maxp) PA_ALLOC(pay, maxp);
  if (R->ndbl) PA_ALLOC(dbl, R->ndbl);
  for (pa_idx i = 0; i < c->n; i++) {
    for (int j = 0; j < c->nvc; j++) v[j] = vg[c->v[(size_t)c->nvc * i + j]];
    pa_idx p = c->parent[i], o = pa__ls_origin(p);
    size_t pl = maxp ? cell_payload(dm, kind, p, c->ref[i], pay) : 0;
    pa_gid g = p >= 0 ? dm->gid[kind][p] : (*next)++;
    if (dbl && o >= 0) pa__entity_doubles(dm->mesh, kind, o, dbl);
    else if (dbl) memset(dbl, 0, (size_t)R->ndbl * sizeof *dbl);
    PA_CALL(pa__recs_add(R, g, v, c->ref[i], c->flag[i], dm->rank, dbl, pay,
                         pl));
  }
cleanup:
  pa__free(dbl);
  pa__free(pay);
  return st;
}

/* The vertex records: the owned vertices (reference from the sides their
 * copies touch) and the added ones this rank gives (appended to the local
 * mesh first: their coordinates, metric and fields). */
static pa_status vertex_records(pa_dmesh *dm, const pa__ls_out *o,
                                const pa_levelset_opts *opts,
                                const pa_gid *agid, const uint8_t *give,
                                pa__recs *V) {
  pa_status st = PA_SUCCESS;
  pa_mesh *m = dm->mesh;
  double *dbl = NULL;
  unsigned char *pay = NULL;
  size_t maxp = max_payload(dm, PA_VERTEX);
  pa_idx nv0 = m->nv;
  PA_CALL(pa__ls_add_vertices(m, o->nadd, o->end, o->t, m));
  PA_ALLOC(dbl, V->ndbl);
  if (maxp) PA_ALLOC(pay, maxp);
  for (pa_idx v = 0; v < dm->nown[PA_VERTEX]; v++) {
    int32_t ref = m->vref[v];
    if (o->touch[v] == (PA_LS_TOUCH_IN | PA_LS_TOUCH_OUT)) ref = opts->ref_iface;
    else if (ref == opts->ref_iface) ref = 0;
    pa__vertex_doubles(m, v, m->nfield, dbl);
    size_t pl = maxp ? cell_payload(dm, PA_VERTEX, v, ref, pay) : 0;
    PA_CALL(pa__recs_add(V, dm->gid[PA_VERTEX][v], NULL, ref, m->vflag[v],
                         dm->rank, dbl, pay, pl));
  }
  for (pa_idx k = 0; k < o->nadd; k++) {
    if (!give[k]) continue;
    int32_t ref = o->addtouch[k] == (PA_LS_TOUCH_IN | PA_LS_TOUCH_OUT)
                      ? opts->ref_iface
                      : 0;
    pa__vertex_doubles(m, nv0 + k, m->nfield, dbl);
    size_t pl = maxp ? cell_payload(dm, PA_VERTEX, -1, ref, pay) : 0;
    PA_CALL(pa__recs_add(V, agid[k], NULL, ref, 0, dm->rank, dbl, pay, pl));
  }
cleanup:
  pa__free(dbl);
  pa__free(pay);
  return st;
}

/* Fresh ids of each kind: above the largest one, after those of the lower
 * ranks (an exclusive scan of the counts cnt), into next. */
static pa_status fresh_ids(pa_dmesh *dm, const pa_gid *cnt, pa_gid *next) {
  pa_status st = PA_SUCCESS;
  pa_gid maxg[PA_DMESH_NKIND], off[PA_DMESH_NKIND] = {0, 0, 0, 0};
  for (int k = 0; k < PA_DMESH_NKIND; k++) {
    maxg[k] = -1;
    for (pa_idx i = 0; i < dm->nloc[k]; i++)
      if (dm->gid[k][i] > maxg[k]) maxg[k] = dm->gid[k][i];
  }
  PA_CALL(pa__allreduce(dm->comm, maxg, PA_DMESH_NKIND, MPI_INT64_T, MPI_MAX));
  PA_CALL(pa__agree(dm->comm, st));
  PA_CALL_MPI(MPI_Exscan((void *)cnt, off, PA_DMESH_NKIND, MPI_INT64_T,
                         MPI_SUM, dm->comm));
  if (dm->rank == 0) memset(off, 0, sizeof off);
  for (int k = 0; k < PA_DMESH_NKIND; k++) next[k] = maxg[k] + 1 + off[k];
cleanup:
  return st;
}

pa_status pa_dmesh_levelset_cut(pa_dmesh *dm, int field,
                                const pa_levelset_opts *opts,
                                pa_levelset_report *report) {
  pa_status st = PA_SUCCESS;
  pa_levelset_opts def;
  pa_levelset_report rep;
  pa__ls_ctx c;
  pa__ls_out out;
  pa__recs R[PA_DMESH_NKIND];
  pa__layout lay;
  double *s = NULL;
  uint8_t *split = NULL, *drop = NULL, *give = NULL;
  int32_t *rin = NULL, *rex = NULL;
  pa_gid *vg = NULL, *agid = NULL;
  memset(&out, 0, sizeof out);
  memset(&rep, 0, sizeof rep);
  memset(R, 0, sizeof R);
  PA_CHECK(dm, PA_ERR_ARG, "pa_dmesh_levelset_cut: NULL dmesh");
  pa__agree_reset();
  if (!opts) {
    pa_levelset_opts_default(&def);
    opts = &def;
  }
  pa_mesh *m = dm->mesh;
  int d = dm->dim;
  PA_CALL(pa__ls_check_opts(opts));
  PA_CHECK(field >= 0 && field < m->nfield && m->field[field].ncomp == 1,
           PA_ERR_ARG, "level set: field %d is not a scalar field of the mesh",
           field);
  for (int k = 0; k < dm->nvalue; k++)
    PA_CHECK(!dm->value[k]->op.active, PA_ERR_ARG,
             "value '%s' has an exchange in flight", dm->value[k]->name);
  ctx_dist(dm, &c);
  pa_idx nv = m->nv, ne = dm->nown[PA_ELEMENT];
  PA_ALLOC(s, nv);
  memcpy(s, m->field[field].val, (size_t)nv * sizeof *s);
  PA_CALL(pa__agree(dm->comm, st));
  PA_CALL(pa__ls_prepare(&c, opts, s, &rep));
  PA_ALLOC(split, ne);
  PA_ALLOC(rin, ne);
  PA_ALLOC(rex, ne);
  st = pa__ls_materials(&c, opts, split, rin, rex);
  PA_CALL(pa__agree(dm->comm, st));
  PA_CALLOC(drop, dm->nown[PA_BOUNDARY]);
  {
    pa_gid cnt[2];
    PA_CALL(old_interface(dm, opts->ref_iface, drop, cnt));
    rep.ndropped = cnt[0];
    rep.nbdry_iface = cnt[1];
  }
  st = pa__ls_cut(&c, opts, s, split, rin, rex, drop, &out);
  PA_CALL(pa__agree(dm->comm, st));
  PA_CALL(vertex_combine(dm, out.touch, MPI_UINT8_T, 1, MPI_MAX));
  /* the added vertices' ids, the interface faces on the zero set */
  PA_ALLOC(agid, out.nadd);
  PA_ALLOC(give, out.nadd);
  PA_CALL(agree_added(dm, &out, agid, give, &rep.ncut));
  pa__dmesh_layout(dm, &lay);
  int bdbl = pa__layout_kind_ndbl(&lay, PA_BOUNDARY);
  pa__recs_init(&R[PA_BOUNDARY], PA_BOUNDARY, d, bdbl);
  pa_gid nzero = 0;
  PA_CALL(zero_faces(dm, &out, opts->ref_iface, &R[PA_BOUNDARY], &nzero));
  {
    double sums[6] = {(double)out.nelem_cut, out.vol[0], out.vol[1], (double)nzero,
                      0, 0};
    for (pa_idx b = 0; b < out.bdry.n; b++) sums[4] += out.bdry.parent[b] == -1;
    PA_CALL(d_sum(dm, sums, 6));
    rep.nelem_cut = (pa_gid)sums[0];
    rep.vol_in = sums[1];
    rep.vol_out = sums[2];
    rep.niface = (pa_gid)(sums[3] + sums[4]);
  }
  /* fresh ids */
  pa_gid cnt[PA_DMESH_NKIND] = {0, 0, (pa_gid)R[PA_BOUNDARY].n, 0}, next[4];
  for (pa_idx i = 0; i < out.elem.n; i++) cnt[PA_ELEMENT] += out.elem.parent[i] < 0;
  for (pa_idx i = 0; i < out.bdry.n; i++) cnt[PA_BOUNDARY] += out.bdry.parent[i] < 0;
  for (pa_idx i = 0; i < out.edge.n; i++) cnt[PA_EDGE] += out.edge.parent[i] < 0;
  PA_CALL(fresh_ids(dm, cnt, next));
  for (size_t i = 0; i < R[PA_BOUNDARY].n; i++)
    R[PA_BOUNDARY].gid[i] = next[PA_BOUNDARY]++;
  if (dm->nvalue && R[PA_BOUNDARY].n) { /* zero payloads for those */
    pa__recs Z;
    unsigned char *pay = NULL;
    size_t pl = value_paylen(dm, PA_BOUNDARY, opts->ref_iface);
    pa__recs_init(&Z, PA_BOUNDARY, d, bdbl);
    if (pl) PA_CALLOC(pay, pl);
    for (size_t i = 0; i < R[PA_BOUNDARY].n && !st; i++)
      st = pa__recs_add(&Z, R[PA_BOUNDARY].gid[i],
                        R[PA_BOUNDARY].vgid + (size_t)d * i, R[PA_BOUNDARY].ref[i],
                        0, dm->rank, R[PA_BOUNDARY].dbl + (size_t)bdbl * i, pay,
                        pl);
    pa__free(pay);
    pa__recs_free(&R[PA_BOUNDARY]);
    R[PA_BOUNDARY] = Z;
    PA_CALL(st);
  }
  /* the records: vertex ids of the output's vertices first */
  PA_ALLOC(vg, (size_t)nv + (size_t)out.nadd);
  memcpy(vg, dm->gid[PA_VERTEX], (size_t)nv * sizeof *vg);
  if (out.nadd) memcpy(vg + nv, agid, (size_t)out.nadd * sizeof *vg);
  pa__recs_init(&R[PA_VERTEX], PA_VERTEX, 0, pa__layout_ndbl(&lay));
  pa__recs_init(&R[PA_ELEMENT], PA_ELEMENT, d + 1,
                pa__layout_kind_ndbl(&lay, PA_ELEMENT));
  pa__recs_init(&R[PA_EDGE], PA_EDGE, 2, 0);
  PA_CALL(vertex_records(dm, &out, opts, agid, give, &R[PA_VERTEX]));
  PA_CALL(cell_records(dm, PA_ELEMENT, &out.elem, vg, &next[PA_ELEMENT],
                       &R[PA_ELEMENT]));
  PA_CALL(cell_records(dm, PA_BOUNDARY, &out.bdry, vg, &next[PA_BOUNDARY],
                       &R[PA_BOUNDARY]));
  PA_CALL(cell_records(dm, PA_EDGE, &out.edge, vg, &next[PA_EDGE],
                       &R[PA_EDGE]));
  pa__ls_out_free(&out);
  pa__free(s);
  s = NULL;
  PA_CALL(pa__agree(dm->comm, st));
  pa__dmesh_clear(dm);
  PA_CALL(pa__dmesh_build(dm, &lay, dm->overlap, &R[PA_ELEMENT], &R[PA_VERTEX],
                          &R[PA_BOUNDARY], &R[PA_EDGE]));
  if (report) *report = rep;
cleanup:
  if (dm) st = pa__agree_end(dm->comm, st);
  for (int k = 0; k < PA_DMESH_NKIND; k++) pa__recs_free(&R[k]);
  pa__ls_out_free(&out);
  pa__free(s);
  pa__free(split);
  pa__free(rin);
  pa__free(rex);
  pa__free(drop);
  pa__free(give);
  pa__free(vg);
  pa__free(agid);
  return st;
}
