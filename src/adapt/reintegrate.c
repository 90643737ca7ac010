/*
 * reintegrate.c -- steps 4 and 5 of the piece algorithm: remesh the local
 * pieces through the public remesher interface, check each output, and
 * rebuild the distributed mesh with the new entities.
 *
 * Remesh: each piece is copied and remeshed (pa_remesh, hsiz already folded
 * into the metric). An output is used only if the remesher succeeded (or
 * missed its target) and the output is consistent: same metric and fields,
 * every skin vertex back at the same coordinates, bit for bit (that is how
 * output vertices are matched to input ones: a vertex the remesher kept
 * keeps its global id), exactly the skin faces of the input, and (with a
 * plug-in remesher, or opts->check_pieces 1) pa_mesh_check passes.
 * Otherwise the piece is rolled back: it comes back as it was given (with its
 * skin refined by bisect.c, which its neighbours share), its elements not
 * marked done.
 *
 * Rebuild (see piece.h for the invariants): staying elements are the
 * unlabelled ones. An owned vertex, boundary entity or edge is kept by its
 * owner when some staying element contains it, or elements of two labels do
 * (it lies on a skin between two pieces; MAX reductions of per-entity values
 * over the ranks); every other one vanished or comes back through a piece
 * output. From an output, the remeshing rank gives: the vertices that are
 * not skin vertices (matched input vertices keep their global id and user
 * values, gathered with them; the others get fresh ids and zeros) and the
 * skin vertices bisect.c added, when it is their giver (skin_vertex_ids);
 * every element ("done" value PA_ADAPT_DONE, PA_ADAPT_DONE_FREE from a
 * single piece, or PA_ADAPT_DONE_NEAR_SKIN within NEAR_SKIN vertex layers of
 * a hot skin vertex, or 0 for a rolled-back piece; one with the same
 * vertices as an input element keeps its id and other values,
 * output_reuse; the others get fresh ids and zeros); and the boundary
 * entities and edges that do not lie on the skin (this drops the artificial
 * skin faces and the entities inside the domain frozen on a piece's outer
 * surface, pc->bfix, which their owner keeps; an unchanged one keeps its
 * id and values, as elements). Fresh
 * ids are the global maximum + 1 + an exclusive scan of the per-rank counts,
 * pieces in increasing order on each rank, then the added skin vertices:
 * deterministic for a given input and number of ranks. The vertices only this
 * rank's elements will contain (fresh ones of outputs that stay here, kept ones
 * far from every piece and rank interface) go to the rebuild as private
 * (pa__dmesh_build_priv).
 *
 * Splice: when the elements to rebuild are few (SPLICE_MAX_SHARE), with
 * overlap 0 and the numbering a build leaves, the same records are made
 * only for the part of the mesh that changes -- the outputs, the staying
 * elements with a vertex that a labelled element contains on some rank
 * (touched), the touched entities that stay and the other vertices of
 * those elements -- and the part, built on its own, is spliced into dm
 * (pa__dmesh_splice): every element around a touched entity is in the
 * part, so its owners and ghosts are right, and every other entity stays
 * as it is. Same result as the rebuild, array by array.
 */
#include "adapt/piece.h"

#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

/* ---- a set of sorted vertex tuples (faces or edges of an output) ---- */

typedef struct tset {
  size_t cap; /* power of two */
  pa_idx *key; /* 3 per slot; key[3s] = -1: empty */
} tset;

static uint64_t tset_hash(const pa_idx *k) { return pa__hash_idx(k, 3); }

static pa_status tset_init(tset *s, size_t n) {
  pa_status st = PA_SUCCESS;
  s->cap = 16;
  while (s->cap < 2 * n + 2) s->cap *= 2;
  PA_ALLOC(s->key, 3 * s->cap);
  for (size_t i = 0; i < 3 * s->cap; i++) s->key[i] = -1;
cleanup:
  return st;
}

static void tset_free(tset *s) {
  pa__free(s->key);
  s->key = NULL;
  s->cap = 0;
}

/* Sorted 3-key of n (2 or 3) vertices, padded with -1. */
static void tkey(const pa_idx *v, int n, pa_idx *k) {
  k[2] = -1;
  for (int i = 0; i < n; i++) k[i] = v[i];
  pa__sort_small(k, n);
}

static int tset_find(const tset *s, const pa_idx *k, int insert) {
  size_t h = tset_hash(k) & (s->cap - 1);
  for (;;) {
    pa_idx *x = s->key + 3 * h;
    if (x[0] == -1 && x[1] == -1 && x[2] == -1) {
      if (insert) memcpy(x, k, 3 * sizeof *k);
      return 0;
    }
    if (x[0] == k[0] && x[1] == k[1] && x[2] == k[2]) return 1;
    h = (h + 1) & (s->cap - 1);
  }
}

/* ---- step 4: remesh ---- */

/* ---- input vertices by their exact coordinates ---- */

typedef struct cset {
  size_t cap;        /* power of two */
  pa_idx *slot;      /* input vertex index, -1: empty */
  const double *x;   /* coordinates of the input */
  int d;
} cset;

/* Hash of d coordinates, bit for bit (also picks the home rank of the
 * vertices bisect.c added). */
static uint64_t coord_hash(const double *p, int d) {
  uint64_t h = 0x9e3779b97f4a7c15ull;
  for (int k = 0; k < d; k++) {
    uint64_t b;
    memcpy(&b, p + k, sizeof b);
    h = pa__mix64(h ^ b);
  }
  return h;
}

/* Slots of a cset per input vertex: the table of a piece's few thousand
 * input vertices stays in cache, and the million output vertices looked up
 * in it, nearly all absent, then mostly meet an empty slot first. */
#define CSET_SLOTS_PER_VERTEX 8

/* 1 if the d coordinates at a and b are the same bits. */
static inline int same_bits(const double *a, const double *b, int d) {
  for (int k = 0; k < d; k++) {
    uint64_t x, y;
    memcpy(&x, a + k, sizeof x);
    memcpy(&y, b + k, sizeof y);
    if (x != y) return 0;
  }
  return 1;
}

/* Index of the input vertex at exactly p, or -1; insert: add i if absent. */
static pa_idx cset_find(cset *s, const double *p, pa_idx insert) {
  size_t h = coord_hash(p, s->d) & (s->cap - 1);
  for (;;) {
    pa_idx i = s->slot[h];
    if (i < 0) {
      if (insert >= 0) s->slot[h] = insert;
      return -1;
    }
    if (same_bits(s->x + (size_t)s->d * i, p, s->d)) return i;
    h = (h + 1) & (s->cap - 1);
  }
}

/* Check an output against its piece; fills pc->match. Returns 1 if usable.
 * Output vertices are matched to input ones by their coordinates, compared
 * bit for bit: a frozen skin vertex must come back exactly, and two
 * vertices of a valid mesh never coincide; no global id travels through the
 * remesher, which would interpolate it at every vertex move. */
static int output_ok(const pa__iter *it, pa__piece *pc, pa_mesh *out,
                     pa_status *hard) {
  pa_status st = PA_SUCCESS;
  const pa_mesh *in = pc->in;
  int d = in->dim, ok = 0;
  cset map = {16, NULL, in->coord, d};
  uint8_t *seen = NULL;
  tset skin = {0, NULL};
  *hard = PA_SUCCESS;
  if (out->met_ncomp != in->met_ncomp || out->nfield != in->nfield) {
    pa__info(1, "padapt: piece %d: the remesher changed the metric or the "
                "fields\n", pc->id);
    goto cleanup;
  }
  while (map.cap < CSET_SLOTS_PER_VERTEX * (size_t)in->nv + 2) map.cap *= 2;
  PA_ALLOC(map.slot, map.cap);
  for (size_t h = 0; h < map.cap; h++) map.slot[h] = -1;
  for (pa_idx i = 0; i < in->nv; i++)
    if (pc->vgid[i] >= 0) /* -1: added inside the piece by bisect.c */
      cset_find(&map, in->coord + (size_t)d * i, i);
  PA_ALLOC(pc->match, out->nv);
  PA_CALLOC(seen, in->nv);
  for (pa_idx j = 0; j < out->nv; j++) {
    pa_idx i = cset_find(&map, out->coord + (size_t)d * j, -1);
    pc->match[j] = -1;
    if (i < 0) continue;
    if (seen[i]) {
      pa__info(1, "padapt: piece %d: vertex %lld comes back twice\n", pc->id,
               (long long)pc->vgid[i]);
      goto cleanup;
    }
    seen[i] = 1;
    pc->match[j] = i;
  }
  for (pa_idx i = 0; i < in->nv; i++)
    if (pc->skin[i] && !seen[i]) {
      pa__info(1, "padapt: piece %d: skin vertex %lld was moved or removed\n",
               pc->id, (long long)pc->vgid[i]);
      goto cleanup;
    }
  {
    /* the skin faces, as they were given */
    pa_idx nin = 0, nout = 0, found = 0;
    for (pa_idx b = 0; b < in->nb; b++) nin += in->bref[b] == PA_ADAPT_SKIN_REF;
    PA_CALL(tset_init(&skin, (size_t)nin));
    for (pa_idx b = 0; b < in->nb; b++)
      if (in->bref[b] == PA_ADAPT_SKIN_REF) {
        pa_idx k[3];
        tkey(in->bdry + (size_t)d * b, d, k);
        tset_find(&skin, k, 1);
      }
    for (pa_idx b = 0; b < out->nb; b++) {
      if (out->bref[b] != PA_ADAPT_SKIN_REF) continue;
      pa_idx f[3], k[3];
      int all = 1;
      nout++;
      for (int j = 0; j < d; j++) {
        f[j] = pc->match[out->bdry[(size_t)d * b + j]];
        all &= f[j] >= 0;
      }
      if (!all) continue;
      tkey(f, d, k);
      found += tset_find(&skin, k, 0);
    }
    if (nout != nin || found != nin) {
      pa__info(1, "padapt: piece %d: the skin faces changed (%d given, %d "
                  "back, %d of them unchanged)\n", pc->id, (int)nin, (int)nout,
               (int)found);
      goto cleanup;
    }
  }
  if (pa__adapt_checks(it->opts)) {
    pa_status c = pa__mesh_check(out, 0);
    if (c == PA_SUCCESS) c = pa__mesh_check_metric(out);
    if (c == PA_ERR_MEMORY) PA_CALL(c);
    if (c) {
      pa__info(1, "padapt: piece %d: invalid output: %s\n", pc->id,
               pa_last_error());
      pa_clear_error();
      goto cleanup;
    }
  }
  ok = 1;
cleanup:
  *hard = st;
  pa__free(map.slot);
  pa__free(seen);
  tset_free(&skin);
  if (!ok) {
    pa__free(pc->match);
    pc->match = NULL;
  }
  return ok;
}

pa_status pa__adapt_remesh(pa__iter *it, int *nfail, double *cpu) {
  pa_status st = PA_SUCCESS;
  pa_remesh_opts ro = it->opts->remesh;
  const pa_remesher *r =
      it->opts->remesher ? it->opts->remesher : pa_remesher_builtin();
  pa_mesh *out = NULL;
  ro.hsiz = 0; /* folded into the metric before the loop */
  ro.trusted = 1; /* built valid by extract.c and bisect.c */
  /* Graded once over the whole mesh before the loop (grade.c), like the
   * sequential remesher grades its input once: grading each piece again
   * would stop at its frozen skin, and on the finer mesh of a later
   * iteration shrink the sizes further (docs/BENCHMARKS.md, "The parallel
   * loop", has what that cost). */
  ro.hgrad = 0;
  ro.hgradreq = 0;
  ro.no_stats = 1; /* pa_dmesh_adapt measures the whole result */
  ro.progress = NULL; /* pa_dmesh_adapt reports per iteration */
  *nfail = 0;
  *cpu = 0;
  for (int q = 0; q < it->npiece_local; q++) {
    pa__piece *pc = &it->pieces[q];
    pc->unchanged = 0;
    if (pc->in->ne == 0) continue; /* Scotch may leave a part empty */
    double t0 = pa_wtime(), t1, t2;
    PA_CALL(pa_mesh_copy(pc->in, &out));
    pa_status s = pa_remesh(r, out, &ro, &pc->rep);
    t1 = pa_wtime();
    *cpu += pc->rep.cpu_s;
    /* the memory bound is an error of the run: a piece given back would
     * meet it again */
    if (s == PA_ERR_MEMORY && pa__memory_bound_error()) PA_CALL(s);
    int ok = s == PA_SUCCESS && pc->rep.outcome != PA_REMESH_FAILED;
    if (!ok)
      pa__info(1, "padapt: piece %d (%d elements): the remesher failed: %s\n",
               pc->id, (int)pc->in->ne,
               s ? pa_last_error() : "outcome FAILED");
    if (ok) {
      pa_status hard;
      ok = output_ok(it, pc, out, &hard);
      PA_CALL(hard);
    }
    t2 = pa_wtime();
    pa__info(2, "padapt: rank %d: piece %d: %d -> %d elements (%d skin "
                "vertices added), remesh %.3f s (CPU %.3f s), check %.3f s%s\n",
             it->rank, pc->id, (int)pc->in->ne, ok ? (int)out->ne : -1,
             (int)pc->nsplit, t1 - t0, pc->rep.cpu_s, t2 - t1,
             ok ? "" : ", rolled back");
    if (ok) {
      pc->unchanged = r == pa_remesher_builtin() && pc->nsplit == 0 &&
                      pc->rep.nsplit + pc->rep.ncollapse + pc->rep.nswap +
                              pc->rep.nmove == 0 &&
                      out->ne == pc->in->ne && out->nv == pc->in->nv;
      pc->out = out;
      out = NULL;
    } else {
      pa_clear_error();
      pa_mesh_destroy(out);
      out = NULL;
      it->piece_failed[pc->id] = 1;
      (*nfail)++;
      /* the piece comes back as it was given (with its refined skin, which
       * its neighbours share), still to adapt */
      PA_CALL(pa_mesh_copy(pc->in, &pc->out));
      pa__free(pc->match);
      PA_ALLOC(pc->match, pc->in->nv);
      for (pa_idx j = 0; j < pc->in->nv; j++)
        pc->match[j] = pc->vgid[j] >= 0 ? j : -1; /* -1: added inside */
    }
  }
cleanup:
  pa_mesh_destroy(out);
  return st;
}

/* ---- step 5: rebuild ---- */

/* Output elements within this many vertex layers of a hot skin vertex (one
 * a tagged element of another piece touches) are marked
 * PA_ADAPT_DONE_NEAR_SKIN: the frozen skin constrained the remesher
 * there (a remesher's choices reach a few layers, e.g. longest-edge
 * propagation), so they may be tagged again. */
#define NEAR_SKIN 2

/* BAD_NEAR_SKIN: an output element within NEAR_SKIN vertex layers of the
 * piece's frozen skin, whose quality is below opts->qual_threshold and below
 * the worst the remesher left in the next NEAR_SKIN layers, is marked
 * PA_ADAPT_DONE_NEAR_SKIN even far from a hot skin vertex: the frozen faces of
 * already remeshed neighbours forced it, so it is tagged again and remeshed
 * inside the next piece, where those faces are free. Without this, box3d 20
 * -> 0.012 ended with a worst quality of 0.199 at 4 ranks and 0.232 at 8
 * (0.361 sequential), box3d 4 -> 0.08 with 0.213 at 3 ranks (0.437).
 * Nothing is marked when the remesher reported neither swaps nor moves (it
 * does not improve shapes: the plug-in bisection of examples/ would make
 * the same shapes next to the new skin, iteration after iteration), and
 * not above the worst quality of the band beyond (shapes the remesher
 * leaves anyway; a piece with no such band marks nothing). */

/* For each of the nd arrays dist[0..nd): dist[a][v] = min(nl, vertex
 * layers from the vertices where it is 0), over the elements of o, given
 * the layers below k0 (the other vertices at nl): layer k is made by one
 * sweep over the elements, which gives k to every vertex above k of an
 * element whose nearest vertex is at k - 1 (an element with a vertex
 * nearer than that has no vertex beyond k - 1). For the NEAR_SKIN layers
 * one pass over the output, cheaper than the vertex balls a breadth-first
 * search would need. front (NULL: none): 1 at the vertices at k - 1 in
 * some array (the sweep does not change them), so that an element far from
 * them is passed over at one read a vertex, not nd. */
static inline void layer_sweep(const pa_mesh *o, int k, const int nd,
                               uint8_t *const *dist, const uint8_t *front,
                               const int nve) {
  for (pa_idx e = 0; e < o->ne; e++) {
    const pa_idx *v = o->elem + (size_t)nve * e;
    if (front) {
      int any = 0;
      for (int i = 0; i < nve; i++) any |= front[v[i]];
      if (!any) continue;
    }
    for (int a = 0; a < nd; a++) {
      uint8_t *x = dist[a];
      int mn = x[v[0]];
      for (int i = 1; i < nve; i++) mn = x[v[i]] < mn ? x[v[i]] : mn;
      if (mn != k - 1) continue;
      for (int i = 0; i < nve; i++)
        if (x[v[i]] > k) x[v[i]] = (uint8_t)k;
    }
  }
}

/* front: scratch of o->nv bytes for nd 2 (NULL: none, or nd 1). */
static void vertex_layers(const pa_mesh *o, int k0, int nl, int nd,
                          uint8_t *const *dist, uint8_t *front) {
  /* (nd and nve constants in each call: the loops unrolled) */
  for (int k = k0; k < nl; k++) {
    if (front && nd == 2)
      for (pa_idx j = 0; j < o->nv; j++)
        front[j] = (uint8_t)(dist[0][j] == k - 1 || dist[1][j] == k - 1);
    if (o->dim == 2 && nd == 1) layer_sweep(o, k, 1, dist, NULL, 3);
    else if (o->dim == 2) layer_sweep(o, k, 2, dist, front, 3);
    else if (nd == 1) layer_sweep(o, k, 1, dist, NULL, 4);
    else layer_sweep(o, k, 2, dist, front, 4);
  }
}

/* Smallest of dist over the vertices of element e of o. */
static inline int elem_layer(const pa_mesh *o, const uint8_t *dist,
                             pa_idx e) {
  const pa_idx *v = o->elem + (size_t)(o->dim + 1) * e;
  int mn = dist[v[0]] < dist[v[1]] ? dist[v[0]] : dist[v[1]];
  mn = dist[v[2]] < mn ? dist[v[2]] : mn;
  if (o->dim == 3) mn = dist[v[3]] < mn ? dist[v[3]] : mn;
  return mn;
}

/* dist[a] over the output of pc for each of the nd marks mark[a] (pc->hot,
 * pc->skin): 0 at the output vertices matching a marked input vertex, else
 * the vertex layers from them, at most nl; front: as in vertex_layers. */
static void layers_from(const pa__piece *pc, int nd,
                        const uint8_t *const *mark, int nl,
                        uint8_t *const *dist, uint8_t *front) {
  const pa_mesh *o = pc->out;
  for (int a = 0; a < nd; a++)
    for (pa_idx j = 0; j < o->nv; j++) {
      pa_idx i = pc->match[j];
      dist[a][j] = (uint8_t)(i >= 0 && mark[a][i] ? 0 : nl);
    }
  vertex_layers(o, 1, nl, nd, dist, front);
}

size_t pa__new_payload(const pa_dmesh *dm, int kind, int32_t ref,
                       const pa_dmesh_value *done, uint8_t doneval,
                       unsigned char *buf) {
  size_t n = 0;
  for (int k = 0; k < dm->nvalue; k++) {
    const pa_dmesh_value *v = dm->value[k];
    if ((int)v->kind != kind || (v->ref >= 0 && v->ref != ref)) continue;
    memset(buf + n, 0, v->unit);
    if (v == done) buf[n] = doneval;
    n += v->unit;
  }
  return n;
}

/* pa__new_payload for a run of records: recomputed only when the kind,
 * reference or "done" value changes (one payload per record cost more than
 * the record itself). */
typedef struct paycache {
  int kind;
  int32_t ref;
  uint8_t doneval;
  size_t len; /* (size_t)-1: empty */
} paycache;

static size_t payload_of(paycache *c, const pa_dmesh *dm, int kind,
                         int32_t ref, const pa_dmesh_value *done,
                         uint8_t doneval, unsigned char *buf) {
  if (c->len == (size_t)-1 || c->kind != kind || c->ref != ref ||
      c->doneval != doneval) {
    c->len = pa__new_payload(dm, kind, ref, done, doneval, buf);
    c->kind = kind;
    c->ref = ref;
    c->doneval = doneval;
  }
  return c->len;
}

/* Per-entity "kept" flags of a kind: 1 if a staying owned element (keep)
 * contains it, MAX-reduced over the ranks; *out receives the owned flags.
 * A boundary entity or edge away from every piece (pa__adapt_near_piece)
 * lies in staying elements only: kept without a look at them. */
static pa_status kept_flags(pa__iter *it, int kind, const uint8_t *keep,
                            const pa_idx *bstart, const pa_idx *belem,
                            uint8_t **out) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = it->dm;
  const pa_mesh *m = dm->mesh;
  pa_dmesh_value *val = NULL;
  int nv = pa__kind_nv(it->dim, kind);
  /* comp 0: in a staying element; comps 1, 2 (face skins): max of -label
   * and of label over the elements containing it (it lies on a skin when
   * they differ) */
  PA_CALL(pa_dmesh_value_add(dm, (pa_entity)kind, "pa.adapt.kept", MPI_INT, 3,
                             -1, &val));
  {
    pa_idx n;
    int *x = pa_dmesh_value_data(val, &n, NULL);
    for (pa_idx b = 0; b < n; b++) {
      x[3 * b] = 0;
      x[3 * b + 1] = x[3 * b + 2] = INT_MIN;
    }
    if (kind == PA_VERTEX) {
      for (pa_idx e = 0; e < it->ne; e++)
        if (keep[e])
          for (int k = 0; k < it->nve; k++) x[3 * m->elem[(size_t)it->nve * e + k]] = 1;
      for (pa_idx v = 0; v < n; v++)
          if (it->vlab[4 * v] != it->vlab[4 * v + 1]) x[3 * v] = 1;
    } else {
      const pa_idx *conn = kind == PA_BOUNDARY ? m->bdry : m->edge;
      for (pa_idx b = 0; b < n; b++) {
        const pa_idx *f = conn + (size_t)nv * b;
        int *y = x + 3 * b;
        if (!pa__adapt_near_piece(it, f, nv)) {
          y[0] = 1;
          continue;
        }
        for (pa_idx q = bstart[f[0]]; q < bstart[f[0] + 1] && !y[0]; q++) {
          pa_idx e = belem[q];
          const pa_idx *ev = m->elem + (size_t)it->nve * e;
          int all = 1;
          for (int i = 1; i < nv && all; i++) {
            int in = 0;
            for (int j = 0; j < it->nve; j++) in |= ev[j] == f[i];
            all = in;
          }
          if (!all) continue;
          if (keep[e]) y[0] = 1;
          int l = it->label[e];
          if (-l > y[1]) y[1] = -l;
          if (l > y[2]) y[2] = l;
        }
      }
    }
  }
  PA_CALL(pa_dmesh_reduce(dm, val, MPI_MAX));
  {
    pa_idx nown = dm->nown[kind];
    const int *x = pa_dmesh_value_data(val, NULL, NULL);
    PA_ALLOC(*out, nown);
    for (pa_idx i = 0; i < nown; i++) {
      const int *y = x + 3 * i;
      (*out)[i] = (uint8_t)(y[0] != 0 || (y[2] != INT_MIN && -y[1] != y[2]));
    }
  }
cleanup:
  st = pa__dmesh_value_drop(dm, val, pa__agree_end(dm->comm, st));
  return st;
}

/* The input entity output entity e is (ru: pc->reuse of its kind), or -1. */
static inline pa_idx reused(const pa_idx *ru, pa_idx e) {
  return ru ? ru[e] : -1;
}

/* 1 if boundary entity b of an output lies on the skin: an artificial skin
 * face, or an input entity frozen on the piece's outer surface (bfix). */
static int on_skin(const pa_mesh *out, const pa_idx *breuse,
                   const uint8_t *bfix, pa_idx b) {
  return out->bref[b] == PA_ADAPT_SKIN_REF ||
         (bfix && reused(breuse, b) >= 0 && bfix[breuse[b]]);
}

/* Which boundary entities / edges of an output to give (not on the skin);
 * counts of those needing fresh ids (breuse, dreuse < 0) in
 * cnt[PA_BOUNDARY], cnt[PA_EDGE]. */
static pa_status output_emit(const pa_mesh *out, const pa_idx *breuse,
                             const pa_idx *dreuse, const uint8_t *bfix,
                             uint8_t **bemit, uint8_t **demit, pa_gid *cnt) {
  pa_status st = PA_SUCCESS;
  tset fs = {0, NULL}, es = {0, NULL};
  int d = out->dim;
  pa_idx nskin = 0;
  for (pa_idx b = 0; b < out->nb; b++) nskin += on_skin(out, breuse, bfix, b);
  PA_CALL(tset_init(&fs, (size_t)nskin));
  PA_CALL(tset_init(&es, (size_t)nskin * 3));
  /* the skin faces and their edges */
  for (pa_idx b = 0; b < out->nb; b++) {
    if (!on_skin(out, breuse, bfix, b)) continue;
    const pa_idx *v = out->bdry + (size_t)d * b;
    pa_idx k[3];
    tkey(v, d, k);
    tset_find(&fs, k, 1);
    for (int i = 0; i < d; i++)
      for (int j = i + 1; j < d; j++) {
        pa_idx ed[2] = {v[i], v[j]};
        tkey(ed, 2, k);
        tset_find(&es, k, 1);
      }
  }
  PA_CALLOC(*bemit, out->nb);
  PA_CALLOC(*demit, out->ned);
  for (pa_idx b = 0; b < out->nb; b++) {
    pa_idx k[3];
    tkey(out->bdry + (size_t)d * b, d, k);
    (*bemit)[b] = !tset_find(&fs, k, 0);
    cnt[PA_BOUNDARY] += (*bemit)[b] && reused(breuse, b) < 0;
  }
  for (pa_idx b = 0; b < out->ned; b++) {
    pa_idx k[3];
    tkey(out->edge + (size_t)2 * b, 2, k);
    (*demit)[b] = !tset_find(&es, k, 0);
    cnt[PA_EDGE] += (*demit)[b] && reused(dreuse, b) < 0;
  }
cleanup:
  tset_free(&fs);
  tset_free(&es);
  return st;
}

/* ---- output elements that are input elements ---- */

/* Entities of a kind of mesh m: connectivity, vertices each, references. */
static const pa_idx *kind_conn(const pa_mesh *m, int kind, int *nvk,
                               const int32_t **ref) {
  *nvk = pa__kind_nv(m->dim, kind);
  *ref = kind == PA_ELEMENT ? m->eref : kind == PA_BOUNDARY ? m->bref : m->edref;
  return kind == PA_ELEMENT ? m->elem : kind == PA_BOUNDARY ? m->bdry : m->edge;
}

/* Sorted vertex numbers (through map, if not NULL) of the nvk vertices at
 * v, padded with -1. */
static void ent_key(const pa_idx *v, int nvk, const pa_idx *map, pa_idx *k) {
  k[3] = k[2] = -1;
  for (int i = 0; i < nvk; i++) k[i] = map ? map[v[i]] : v[i];
  pa__sort_small(k, nvk);
}

/* pc->reuse[kind]: the input entity each output entity of a kind
 * (elements, boundary entities, edges) is (same vertices, none of them
 * added by bisect.c, and same reference), or -1; NULL when none is (most
 * outputs: no array of millions of -1 to write and read). Such an entity
 * keeps its global id and values; with a rolled-back piece, every one
 * bisect.c left whole. *nreuse: how many are. */
static pa_status output_reuse(pa__piece *pc, int kind, pa_idx *nreuse) {
  pa_status st = PA_SUCCESS;
  const pa_mesh *in = pc->in, *o = pc->out;
  int nvk;
  const int32_t *iref, *oref;
  const pa_idx *ic = kind_conn(in, kind, &nvk, &iref);
  const pa_idx *oc = kind_conn(o, kind, &nvk, &oref);
  pa_idx n0 = pc->n0[kind];
  pa_idx no = kind == PA_ELEMENT ? o->ne : kind == PA_BOUNDARY ? o->nb : o->ned;
  size_t cap = 16;
  pa_idx *tab = NULL; /* input entity per slot, keyed by its sorted
                         vertices; -1 empty */
  pa__free(pc->reuse[kind]);
  pc->reuse[kind] = NULL;
  *nreuse = 0;
  while (cap < 2 * (size_t)n0 + 2) cap *= 2;
  PA_ALLOC(tab, cap);
  for (size_t i = 0; i < cap; i++) tab[i] = -1;
  for (pa_idx e = 0; e < n0; e++) {
    pa_idx k[4];
    ent_key(ic + (size_t)nvk * e, nvk, NULL, k);
    if (k[nvk - 1] >= pc->nv0) continue; /* bisected: not the gathered one */
    size_t h = pa__hash_idx(k, 4) & (cap - 1);
    while (tab[h] != -1) h = (h + 1) & (cap - 1);
    tab[h] = e;
  }
  for (pa_idx e = 0; e < no; e++) {
    const pa_idx *v = oc + (size_t)nvk * e;
    pa_idx k[4];
    int ok = 1;
    for (int i = 0; i < nvk && ok; i++) {
      pa_idx j = pc->match[v[i]];
      ok = j >= 0 && j < pc->nv0;
    }
    if (!ok) continue;
    ent_key(v, nvk, pc->match, k);
    size_t h = pa__hash_idx(k, 4) & (cap - 1);
    for (; tab[h] != -1; h = (h + 1) & (cap - 1)) {
      pa_idx q = tab[h], kq[4];
      ent_key(ic + (size_t)nvk * q, nvk, NULL, kq);
      if (!memcmp(kq, k, sizeof k)) {
        if (iref[q] != oref[e]) break;
        if (!pc->reuse[kind]) { /* the first one */
          PA_ALLOC(pc->reuse[kind], no);
          for (pa_idx f = 0; f < no; f++) pc->reuse[kind][f] = -1;
        }
        pc->reuse[kind][e] = q;
        ++*nreuse;
        break;
      }
    }
  }
cleanup:
  pa__free(tab);
  return st;
}

/* Offset of the "done" value in the payload of an element of reference
 * ref (the values of its kind that pass their filter, in order). */
static size_t done_offset(const pa_dmesh *dm, int32_t ref,
                          const pa_dmesh_value *done) {
  size_t n = 0;
  for (int k = 0; k < dm->nvalue; k++) {
    const pa_dmesh_value *v = dm->value[k];
    if ((int)v->kind != PA_ELEMENT || (v->ref >= 0 && v->ref != ref)) continue;
    if (v == done) return n;
    n += v->unit;
  }
  return (size_t)-1;
}

/* Destination rank of each output element: with fewer pieces than ranks
 * (one piece remeshed on one rank while the others wait), the output goes
 * back where its input came from, so that the mesh stays balanced without
 * a repartition: every output vertex takes the rank of the nearest matched
 * input vertex (breadth-first over the output, from the matched vertices
 * in index order), every element the rank of its vertex nearest to them
 * (ties: the smaller rank). Otherwise everything stays on this rank (the
 * pieces were balanced by work): *destp stays NULL. */
static pa_status output_dest(const pa__iter *it, const pa__piece *pc,
                             int **destp) {
  pa_status st = PA_SUCCESS;
  const pa_mesh *o = pc->out;
  int nve = o->dim + 1;
  int *dest = NULL, *vr = NULL, *dist = NULL;
  pa_idx *start = NULL, *ball = NULL, *queue = NULL;
  *destp = NULL;
  if (it->npieces < it->size && o->nv > 0) {
    PA_ALLOC(dest, o->ne ? o->ne : 1);
    for (pa_idx e = 0; e < o->ne; e++) dest[e] = it->rank;
    PA_ALLOC(vr, o->nv);
    PA_ALLOC(dist, o->nv);
    PA_ALLOC(queue, o->nv);
    PA_CALL(pa__balls(o->elem, o->ne, nve, o->nv, &start, &ball));
    pa_idx head = 0, tail = 0;
    for (pa_idx v = 0; v < o->nv; v++) {
      pa_idx i = pc->match[v];
      vr[v] = i >= 0 && pc->vrank[i] != INT_MAX ? pc->vrank[i] : -1;
      dist[v] = vr[v] >= 0 ? 0 : -1;
      if (vr[v] >= 0) queue[tail++] = v;
    }
    while (head < tail) {
      pa_idx v = queue[head++];
      for (pa_idx q = start[v]; q < start[v + 1]; q++) {
        const pa_idx *ev = o->elem + (size_t)nve * ball[q];
        for (int k = 0; k < nve; k++)
          if (dist[ev[k]] < 0) {
            dist[ev[k]] = dist[v] + 1;
            vr[ev[k]] = vr[v];
            queue[tail++] = ev[k];
          }
      }
    }
    for (pa_idx e = 0; e < o->ne; e++) {
      const pa_idx *ev = o->elem + (size_t)nve * e;
      int best = -1, bd = INT_MAX;
      for (int k = 0; k < nve; k++)
        if (dist[ev[k]] >= 0 &&
            (dist[ev[k]] < bd || (dist[ev[k]] == bd && vr[ev[k]] < best))) {
          bd = dist[ev[k]];
          best = vr[ev[k]];
        }
      if (best >= 0) dest[e] = best;
    }
  }
  *destp = dest;
  dest = NULL;
cleanup:
  pa__free(dest);
  pa__free(vr);
  pa__free(dist);
  pa__free(queue);
  pa__free(start);
  pa__free(ball);
  return st;
}

/* What the phases of output_records share: the piece and its output, the
 * global id of each output vertex (vg) and the destination rank of each
 * output element (dest), the vertex layers from the hot skin vertices
 * (dist) and from every skin vertex (dsk, only for BAD_NEAR_SKIN) with the
 * quality below which an element near the skin is poor (qthr; 0: none
 * is), the records to append to (R; Rp: the private vertices, NULL if
 * none), the next fresh ids, the "done" value, and a payload buffer with
 * its cache. */
typedef struct orecs {
  pa__iter *it;
  pa__piece *pc;
  const pa_mesh *o;
  pa_gid *vg, *next;
  const int *dest;
  uint8_t *dist, *dsk;
  double qthr;
  pa__recs *R, *Rp;
  const pa_dmesh_value *done;
  unsigned char *pay;
  paycache pcache;
  double *cdbl; /* the element or boundary field values of one entity */
} orecs;

/* The element or boundary field values of output entity e of a kind into
 * c->cdbl (NULL when the records of that kind carry none). */
static const double *cell_doubles(orecs *c, int kind, pa_idx e) {
  if (!c->R[kind].ndbl) return NULL;
  int n = pa__entity_doubles(c->o, kind, e, c->cdbl);
  PA_ASSERT(n == c->R[kind].ndbl);
  (void)n;
  return c->cdbl;
}

/* The output's vertices: the global id of each (vg) and the records of
 * those this rank gives: not skin vertices (a matched input vertex keeps
 * its id and user values, gathered with it; a new one gets a fresh id and
 * zeros), and the skin vertices bisect.c added that this piece gives. */
static pa_status output_vertices(orecs *c) {
  pa_status st = PA_SUCCESS;
  pa__iter *it = c->it;
  const pa__piece *pc = c->pc;
  const pa_mesh *o = c->o;
  const size_t *vo = pc->kpoff[PA_VERTEX];
  size_t maxpay = pa__kind_unit(it->dm, PA_VERTEX);
  PA_ALLOC(c->vg, o->nv);
  /* room for every vertex in both sets: the records are written straight
   * into their arrays */
  for (int t = 0; t < 2; t++) {
    pa__recs *T = t ? c->Rp : &c->R[PA_VERTEX];
    if (T)
      PA_CALL(pa__recs_reserve(T, T->n + (size_t)o->nv,
                               (T->poff ? T->poff[T->n] : 0) +
                                   (size_t)o->nv * maxpay));
  }
  if (c->Rp) { /* the new vertices, nearly all, are written in bulk there */
    size_t nnew = 0;
    for (pa_idx j = 0; j < o->nv; j++) nnew += pc->match[j] < 0;
    pa__recs_prefault(c->Rp, c->Rp->n, nnew);
  }
  for (pa_idx j = 0; j < o->nv; j++) {
    pa_idx i = pc->match[j];
    if (i >= 0 && pc->skin[i] && pc->vgid[i] >= PA_ADAPT_TEMP_GID) {
      c->vg[j] = pc->ifgid[i]; /* added by bisect.c: one piece gives it */
      if (!pc->ifgive[i]) continue;
    } else if (i >= 0 && pc->skin[i]) {
      c->vg[j] = pc->vgid[i]; /* kept by its owner */
      continue;
    } else {
      c->vg[j] = i >= 0 ? pc->vgid[i] : c->next[PA_VERTEX]++;
    }
    pa__recs *T = i < 0 && c->Rp ? c->Rp : &c->R[PA_VERTEX];
    size_t r = T->n;
    T->gid[r] = c->vg[j];
    T->ref[r] = o->vref[j];
    T->flag[r] = o->vflag[j];
    T->aux[r] = it->rank;
    int nd = pa__vertex_doubles(o, j, o->nfield, T->dbl + (size_t)T->ndbl * r);
    PA_ASSERT(nd == T->ndbl);
    (void)nd;
    /* a vertex the remesher kept keeps its user values (gathered with it),
     * a new one gets zeros */
    const unsigned char *vp;
    size_t pl;
    if (vo && i >= 0 && i < pc->n0[PA_VERTEX] &&
        o->vref[j] == pc->in->vref[i]) {
      vp = pc->kpay[PA_VERTEX] + vo[i];
      pl = vo[i + 1] - vo[i];
    } else {
      vp = c->pay;
      pl = payload_of(&c->pcache, it->dm, PA_VERTEX, o->vref[j], c->done, 0,
                      c->pay);
    }
    if (T->poff) {
      memcpy(T->pay + T->poff[r], vp, pl);
      T->poff[r + 1] = T->poff[r] + pl;
    }
    T->n = r + 1;
  }
cleanup:
  return st;
}

/* The vertex layers from the hot skin vertices (dist) and, for
 * BAD_NEAR_SKIN, from every skin vertex (dsk), in the same sweeps. */
static pa_status near_skin_layers(orecs *c) {
  pa_status st = PA_SUCCESS;
  const pa__piece *pc = c->pc;
  const pa_mesh *o = c->o;
  c->qthr = c->it->piece_failed[pc->id] ||
                    (pc->rep.nswap == 0 && pc->rep.nmove == 0)
                ? 0
                : c->it->opts->qual_threshold;
  uint8_t *front = NULL;
  PA_ALLOC(c->dist, o->nv);
  if (c->qthr > 0) {
    PA_ALLOC(c->dsk, o->nv);
    PA_ALLOC(front, o->nv);
  }
  {
    const uint8_t *mk[2] = {pc->hot, pc->skin};
    uint8_t *const ds[2] = {c->dist, c->dsk};
    layers_from(pc, c->qthr > 0 ? 2 : 1, mk, NEAR_SKIN, ds, front);
  }
cleanup:
  pa__free(front);
  return st;
}

/* 1 if element e of the output lies within NEAR_SKIN vertex layers of the
 * skin (dsk) with a quality below q. */
static int poor_near_skin(const orecs *c, pa_idx e, double q) {
  return elem_layer(c->o, c->dsk, e) < NEAR_SKIN &&
         pa_mesh_elem_quality(c->pc->out, e) < q;
}

/* The "done" value of output element e (see the file comment) from dv0
 * (PA_ADAPT_DONE, 0 for a rolled-back piece) but for BAD_NEAR_SKIN
 * (bad_near_skin), and the global ids of its vertices into ev; *poor |=
 * whether e is poor near the skin (c->qthr); nve a constant once
 * inlined. */
static inline uint8_t elem_done(const orecs *c, const pa_gid *vg,
                                const uint8_t *dist, pa_idx e, uint8_t dv0,
                                const int nve, pa_gid *ev, int *poor) {
  const pa_idx *v = c->o->elem + (size_t)nve * e;
  uint8_t dv = dv0;
  int nhot = 0, near = 0;
  for (int k = 0; k < nve; k++) {
    ev[k] = vg[v[k]];
    near |= dist[v[k]] < NEAR_SKIN;
    nhot += dist[v[k]] == 0;
  }
  if (dv && near) dv = PA_ADAPT_DONE_NEAR_SKIN;
  if (dv && nhot >= 2) dv = PA_ADAPT_DONE_ON_SKIN;
  if (c->qthr > 0 && !*poor) *poor = poor_near_skin(c, e, c->qthr);
  if (dv == PA_ADAPT_DONE && c->it->npieces == 1) dv = PA_ADAPT_DONE_FREE;
  return dv;
}

/* The "done" values of the output's elements (dv) and the global ids of
 * their vertices, written straight into the element records from slot i0
 * on; *poor: whether an element near the skin is poor; nve a constant once
 * inlined. */
static inline void elems_done(const orecs *c, uint8_t dv0, size_t i0,
                              uint8_t *dv, int *poor, const int nve) {
  const pa_mesh *o = c->o;
  const pa_gid *vg = c->vg;
  const uint8_t *dist = c->dist;
  pa_gid *rv = c->R[PA_ELEMENT].vgid + (size_t)nve * i0;
  *poor = 0;
  for (pa_idx e = 0; e < o->ne; e++)
    dv[e] = elem_done(c, vg, dist, e, dv0, nve, rv + (size_t)nve * e, poor);
}

/* BAD_NEAR_SKIN, when an element near the skin is poor: the layers from
 * the skin go on to 2 NEAR_SKIN, the worst quality of the band beyond
 * (qband) is found, and the elements near the skin below it that would be
 * PA_ADAPT_DONE (PA_ADAPT_DONE_FREE from a single piece) are marked
 * PA_ADAPT_DONE_NEAR_SKIN. */
static void bad_near_skin(orecs *c, uint8_t *dv) {
  const pa_mesh *o = c->o;
  uint8_t *const ds[1] = {c->dsk};
  uint8_t done = c->it->npieces == 1 ? PA_ADAPT_DONE_FREE : PA_ADAPT_DONE;
  /* the layers below NEAR_SKIN are made: the others go on from there */
  for (pa_idx j = 0; j < o->nv; j++)
    if (c->dsk[j] == NEAR_SKIN) c->dsk[j] = 2 * NEAR_SKIN;
  vertex_layers(o, NEAR_SKIN, 2 * NEAR_SKIN, 1, ds, NULL);
  double qband = c->qthr;
  for (pa_idx e = 0; e < o->ne; e++) {
    int l = elem_layer(o, c->dsk, e);
    if (l >= NEAR_SKIN && l < 2 * NEAR_SKIN)
      qband = fmin(qband, pa_mesh_elem_quality(c->pc->out, e));
  }
  for (pa_idx e = 0; qband > 0 && e < o->ne; e++)
    if (dv[e] == done && poor_near_skin(c, e, qband))
      dv[e] = PA_ADAPT_DONE_NEAR_SKIN;
}

/* The output's elements, each with its "done" value (see the file
 * comment); one that is an input element keeps its id and values, with
 * done updated, the others get fresh ids and zeros. The records were
 * reserved for every output element (staying_records, patch_records), so
 * they are written array by array, in output order. */
static pa_status output_elements(orecs *c) {
  pa_status st = PA_SUCCESS;
  pa__iter *it = c->it;
  pa_dmesh *dm = it->dm;
  const pa__piece *pc = c->pc;
  const pa_mesh *o = c->o;
  pa_idx ne = o->ne;
  int nve = o->dim + 1;
  uint8_t dv0 = it->piece_failed[pc->id] ? 0 : PA_ADAPT_DONE, *dv = NULL;
  const pa_idx *reuse = pc->reuse[PA_ELEMENT];
  pa__recs *R = &c->R[PA_ELEMENT];
  size_t maxpay = pa__kind_unit(dm, PA_ELEMENT), i0 = R->n;
  unsigned char *tmpl = NULL; /* a fresh element's payload, done 0 */
  PA_CALL(pa__recs_reserve(R, i0 + (size_t)ne,
                           (R->poff ? R->poff[i0] : 0) + (size_t)ne * maxpay));
  pa__recs_prefault(R, i0, (size_t)ne);
  PA_ALLOC(tmpl, maxpay + 1);
  /* the usual output: no input element given back, one reference, and
   * the done value alone in the payload: ids, offsets and payloads in
   * bulk, the done values written straight as the payloads */
  int bulk = R->poff != NULL && ne > 0 && !reuse;
  for (pa_idx e = 0; bulk && e < ne; e++) bulk = o->eref[e] == o->eref[0];
  if (bulk)
    bulk = pa__new_payload(dm, PA_ELEMENT, o->eref[0], c->done, 0, tmpl) == 1 &&
           done_offset(dm, o->eref[0], c->done) == 0;
  if (bulk) dv = R->pay + R->poff[i0];
  else PA_ALLOC(dv, ne ? ne : 1);
  int poor;
  if (nve == 3) elems_done(c, dv0, i0, dv, &poor, 3);
  else elems_done(c, dv0, i0, dv, &poor, 4);
  if (poor) bad_near_skin(c, dv);
  memcpy(R->ref + i0, o->eref, (size_t)ne * sizeof *R->ref);
  memcpy(R->flag + i0, o->eflag, (size_t)ne * sizeof *R->flag);
  if (c->dest) memcpy(R->aux + i0, c->dest, (size_t)ne * sizeof *R->aux);
  else
    for (pa_idx e = 0; e < ne; e++) R->aux[i0 + (size_t)e] = it->rank;
  for (pa_idx e = 0; R->ndbl && e < ne; e++)
    pa__entity_doubles(o, PA_ELEMENT, e, R->dbl + (size_t)R->ndbl * (i0 + e));
  if (bulk) {
    pa_gid g0 = c->next[PA_ELEMENT];
    size_t p0 = R->poff[i0];
    for (pa_idx e = 0; e < ne; e++) {
      R->gid[i0 + (size_t)e] = g0 + e;
      R->poff[i0 + (size_t)e + 1] = p0 + (size_t)e + 1;
    }
    c->next[PA_ELEMENT] += ne;
    dv = NULL; /* (R's payloads) */
  } else {
    int32_t tref = 0;
    size_t tlen = (size_t)-1, tat = (size_t)-1; /* tlen -1: tmpl empty */
    for (pa_idx e = 0; e < ne; e++) {
      size_t i = i0 + (size_t)e, pl, at;
      const unsigned char *src;
      pa_idx q = reused(reuse, e);
      if (q >= 0) { /* an input element: its id and values, done updated */
        const size_t *po = pc->kpoff[PA_ELEMENT];
        R->gid[i] = pc->kgid[PA_ELEMENT][q];
        src = pc->kpay[PA_ELEMENT] + po[q];
        pl = po[q + 1] - po[q];
        at = done_offset(dm, o->eref[e], c->done);
        PA_CHECK(at != (size_t)-1 && at < pl, PA_ERR_INTERNAL,
                 "element payload without its done value");
      } else {
        R->gid[i] = c->next[PA_ELEMENT]++;
        if (tlen == (size_t)-1 || tref != o->eref[e]) {
          tref = o->eref[e];
          tlen = pa__new_payload(dm, PA_ELEMENT, tref, c->done, 0, tmpl);
          tat = done_offset(dm, tref, c->done);
        }
        src = tmpl;
        pl = tlen;
        at = tat;
      }
      if (!R->poff) continue;
      unsigned char *p = R->pay + R->poff[i];
      if (pl == 1) p[0] = src[0];
      else memcpy(p, src, pl);
      if (at != (size_t)-1) p[at] = dv[e];
      R->poff[i + 1] = R->poff[i] + pl;
    }
  }
  R->n = i0 + (size_t)ne;
cleanup:
  pa__free(dv);
  pa__free(tmpl);
  return st;
}

/* The output's boundary entities and edges not on the skin (bemit, demit);
 * an input one keeps its id and values, the others get fresh ids and
 * zeros. */
static pa_status output_subentities(orecs *c, const uint8_t *bemit,
                                    const uint8_t *demit) {
  pa_status st = PA_SUCCESS;
  pa__iter *it = c->it;
  const pa__piece *pc = c->pc;
  const pa_mesh *o = c->o;
  for (int kind = PA_BOUNDARY; kind <= PA_EDGE; kind++) {
    int nvk;
    const int32_t *ref;
    const pa_idx *conn = kind_conn(o, kind, &nvk, &ref);
    const uint8_t *fl = kind == PA_BOUNDARY ? o->bflag : o->edflag;
    const uint8_t *emit = kind == PA_BOUNDARY ? bemit : demit;
    const size_t *po = pc->kpoff[kind];
    pa_idx n = kind == PA_BOUNDARY ? o->nb : o->ned;
    for (pa_idx b = 0; b < n; b++) {
      if (!emit[b]) continue;
      pa_gid bv[3];
      for (int k = 0; k < nvk; k++) bv[k] = c->vg[conn[(size_t)nvk * b + k]];
      pa_idx q = reused(pc->reuse[kind], b);
      if (q >= 0) { /* an input entity: its id and values */
        PA_CALL(pa__recs_add(&c->R[kind], pc->kgid[kind][q], bv, ref[b], fl[b],
                             it->rank, cell_doubles(c, kind, b),
                             po ? pc->kpay[kind] + po[q] : NULL,
                             po ? po[q + 1] - po[q] : 0));
        continue;
      }
      size_t pl = payload_of(&c->pcache, it->dm, kind, ref[b], c->done, 0,
                             c->pay);
      PA_CALL(pa__recs_add(&c->R[kind], c->next[kind]++, bv, ref[b], fl[b],
                           it->rank, cell_doubles(c, kind, b), c->pay, pl));
    }
  }
cleanup:
  return st;
}

/* Append the records an output gives (see the file comment). next[k]: next
 * fresh id of each kind (advanced). Rp (NULL: none): the private vertices
 * (pa__dmesh_build_priv), the fresh ones of an output whose elements all
 * stay on this rank: only they reference them. */
static pa_status output_records(pa__iter *it, pa__piece *pc, const uint8_t *bemit,
                                const uint8_t *demit, pa_gid *next,
                                const pa_dmesh_value *done, pa__recs *R,
                                pa__recs *Rp, unsigned char *pay) {
  pa_status st = PA_SUCCESS;
  orecs c;
  memset(&c, 0, sizeof c);
  c.it = it;
  c.pc = pc;
  c.o = pc->out;
  c.next = next;
  c.R = R;
  c.done = done;
  c.pay = pay;
  c.pcache.len = (size_t)-1;
  c.dest = pc->dest;
  for (pa_idx e = 0; Rp && c.dest && e < c.o->ne; e++)
    if (c.dest[e] != it->rank) Rp = NULL;
  c.Rp = Rp;
  {
    int nd = R[PA_ELEMENT].ndbl > R[PA_BOUNDARY].ndbl ? R[PA_ELEMENT].ndbl
                                                       : R[PA_BOUNDARY].ndbl;
    PA_ALLOC(c.cdbl, (size_t)nd + 1);
  }
  PA_CALL(output_vertices(&c));
  PA_CALL(near_skin_layers(&c));
  PA_CALL(output_elements(&c));
  PA_CALL(output_subentities(&c, bemit, demit));
cleanup:
  pa__free(c.vg);
  pa__free(c.dist);
  pa__free(c.dsk);
  pa__free(c.cdbl);
  return st;
}

/* ---- ids of the vertices bisect.c added ---- */

/* A request: coordinates, then the piece. */
typedef struct ifreq {
  double x[3];
  int64_t piece;
  int64_t src; /* position in the sender's order (on the home rank) */
} ifreq;

static int ifreq_cmp(const void *p, const void *q) {
  const ifreq *a = p, *b = q;
  for (int k = 0; k < 3; k++)
    if (a->x[k] != b->x[k]) return a->x[k] < b->x[k] ? -1 : 1;
  return (a->piece > b->piece) - (a->piece < b->piece);
}

static int home_rank(const double *x, int d, int P) {
  return (int)(coord_hash(x, d) % (uint64_t)P);
}

/* What the phases of skin_vertex_ids share: the requests this rank sends,
 * one per added vertex of its outputs in (piece, vertex) order (n; home[k]
 * the home rank of the k-th, scnt the bytes to each rank, pos offsets),
 * and the requests it receives as a home rank (rcnt bytes from each rank,
 * rbuf), sorted by coordinates in srt (nr in all, src: arrival order). */
typedef struct ifids {
  pa__iter *it;
  size_t n, nr, *scnt, *rcnt, *pos;
  int *home;
  ifreq *rbuf, *srt;
} ifids;

/* The requests sent to the home ranks, grouped by home rank, in (piece,
 * vertex) order within each. */
static pa_status send_requests(ifids *c) {
  pa_status st = PA_SUCCESS;
  pa__iter *it = c->it;
  int P = it->size, d = it->dim;
  size_t k = 0;
  ifreq *sbuf = NULL;
  for (int q = 0; q < it->npiece_local; q++) {
    pa__piece *pc = &it->pieces[q];
    if (!pc->out) continue;
    for (pa_idx i = 0; i < pc->in->nv; i++)
      c->n += pc->vgid[i] >= PA_ADAPT_TEMP_GID;
    /* (only skin vertices carry temporary ids) */
  }
  PA_CALLOC(c->scnt, P);
  PA_CALLOC(c->pos, (size_t)P + 1);
  PA_ALLOC(c->home, c->n ? c->n : 1);
  PA_ALLOC(sbuf, c->n ? c->n : 1);
  for (int q = 0; q < it->npiece_local; q++) {
    pa__piece *pc = &it->pieces[q];
    if (!pc->out) continue;
    for (pa_idx i = 0; i < pc->in->nv; i++)
      if (pc->vgid[i] >= PA_ADAPT_TEMP_GID) {
        c->home[k] = home_rank(pc->in->coord + (size_t)d * i, d, P);
        c->scnt[c->home[k]]++;
        k++;
      }
  }
  for (int r = 0; r < P; r++) c->pos[r + 1] = c->pos[r] + c->scnt[r];
  k = 0;
  for (int q = 0; q < it->npiece_local; q++) {
    pa__piece *pc = &it->pieces[q];
    if (!pc->out) continue;
    for (pa_idx i = 0; i < pc->in->nv; i++)
      if (pc->vgid[i] >= PA_ADAPT_TEMP_GID) {
        ifreq *r = &sbuf[c->pos[c->home[k]]++];
        memset(r, 0, sizeof *r);
        memcpy(r->x, pc->in->coord + (size_t)d * i, d * sizeof(double));
        r->piece = pc->id;
        k++;
      }
  }
  for (int r = 0; r < P; r++) c->scnt[r] *= sizeof(ifreq);
  PA_CALL(pa__xchg_sparse(it->dm->comm, c->scnt, sbuf, &c->rcnt,
                          (void **)&c->rbuf));
cleanup:
  pa__free(sbuf);
  return st;
}

/* On the home rank: the requests sorted by coordinates (then piece), and
 * the distinct coordinates counted (*ndist); each must be met at least
 * twice. */
static pa_status sort_requests(ifids *c, pa_gid *ndist) {
  pa_status st = PA_SUCCESS;
  size_t nr = 0;
  int bad = 0;
  for (int r = 0; r < c->it->size; r++) nr += c->rcnt[r] / sizeof(ifreq);
  c->nr = nr;
  PA_ALLOC(c->srt, nr ? nr : 1);
  memcpy(c->srt, c->rbuf, nr * sizeof *c->srt);
  for (size_t i = 0; i < nr; i++) c->srt[i].src = (int64_t)i;
  qsort(c->srt, nr, sizeof *c->srt, ifreq_cmp);
  for (size_t i = 0; i < nr;) {
    size_t j = i + 1;
    while (j < nr && memcmp(c->srt[j].x, c->srt[i].x, sizeof c->srt[i].x) == 0) j++;
    bad |= j - i < 2;
    (*ndist)++;
    i = j;
  }
  PA_CHECK(!bad, PA_ERR_INTERNAL, "parallel adaptation: a vertex added to "
           "refine a piece's skin was not added by the piece on the other "
           "side");
cleanup:
  return st;
}

/* On the home rank: the answers, in arrival order: the id of each
 * request's vertex (consecutive from first, in coordinate order) and 1 for
 * the request of the smallest piece, which gives it. *bcnt, *back: the
 * answers to this rank's requests. */
static pa_status answer_requests(ifids *c, pa_gid first, size_t **bcnt,
                                 int64_t **back) {
  pa_status st = PA_SUCCESS;
  const ifreq *srt = c->srt;
  int64_t *ans = NULL;
  pa_gid g = first - 1;
  PA_ALLOC(ans, 2 * (c->nr ? c->nr : 1));
  for (size_t i = 0; i < c->nr; i++) {
    int isnew = i == 0 || memcmp(srt[i].x, srt[i - 1].x, sizeof srt[i].x) != 0;
    if (isnew) g++;
    ans[2 * srt[i].src] = g;
    ans[2 * srt[i].src + 1] = isnew; /* the smallest piece gives it */
  }
  for (int r = 0; r < c->it->size; r++)
    c->rcnt[r] = c->rcnt[r] / sizeof(ifreq) * 2 * sizeof(int64_t);
  PA_CALL(pa__xchg_sparse(c->it->dm->comm, c->rcnt, ans, bcnt, (void **)back));
cleanup:
  pa__free(ans);
  return st;
}

/* The answers come back by home rank in the order of the requests: the id
 * of every added vertex of each output (pc->ifgid) and whether this piece
 * gives it (pc->ifgive). */
static pa_status place_ids(ifids *c, const int64_t *back) {
  pa_status st = PA_SUCCESS;
  pa__iter *it = c->it;
  int P = it->size;
  size_t k = 0;
  for (int r = 0; r < P; r++) c->pos[r] = 0;
  for (int r = 1; r < P; r++) c->pos[r] = c->pos[r - 1] + c->scnt[r - 1] / sizeof(ifreq);
  for (int q = 0; q < it->npiece_local; q++) {
    pa__piece *pc = &it->pieces[q];
    if (!pc->out) continue;
    PA_CALLOC(pc->ifgid, pc->in->nv);
    PA_CALLOC(pc->ifgive, pc->in->nv);
    for (pa_idx i = 0; i < pc->in->nv; i++)
      if (pc->vgid[i] >= PA_ADAPT_TEMP_GID) {
        size_t a = c->pos[c->home[k]]++;
        pc->ifgid[i] = back[2 * a];
        pc->ifgive[i] = (uint8_t)back[2 * a + 1];
        k++;
      }
  }
cleanup:
  return st;
}

/* Every vertex bisect.c added lies on the skins of all the pieces around
 * its edge, each holding an identical copy (same coordinates). The copies
 * meet on a home rank chosen by their coordinates, which numbers the
 * distinct vertices from first (consecutive on each home rank, ranks in
 * order) and names the piece that gives each vertex to the rebuild (the
 * smallest). A vertex met once means the pieces disagree: an internal
 * error, reported. */
static pa_status skin_vertex_ids(pa__iter *it, pa_gid first) {
  pa_status st = PA_SUCCESS;
  MPI_Comm comm = it->dm->comm;
  ifids c;
  size_t *bcnt = NULL;
  int64_t *back = NULL;
  pa_gid ndist = 0, off = 0;
  memset(&c, 0, sizeof c);
  c.it = it;
  PA_CALL(send_requests(&c));
  PA_CALL(sort_requests(&c, &ndist));
  PA_CALL(pa__agree(comm, st));
  MPI_Exscan(&ndist, &off, 1, MPI_INT64_T, MPI_SUM, comm);
  if (it->rank == 0) off = 0;
  PA_CALL(answer_requests(&c, first + off, &bcnt, &back));
  PA_CALL(place_ids(&c, back));
cleanup:
  st = pa__agree_end(comm, st);
  pa__free(c.scnt);
  pa__free(c.rcnt);
  pa__free(c.pos);
  pa__free(c.home);
  pa__free(c.rbuf);
  pa__free(c.srt);
  pa__free(bcnt);
  pa__free(back);
  return st;
}

/* The kept owned vertices that can be private in the rebuild
 * (pa__dmesh_build_priv): no labelled element on any rank around them (no
 * piece has them) and no copy on another rank (only this rank's elements,
 * which stay, contain them). *vpriv stays NULL when the owned vertices are
 * not in global id order (pa_dmesh_reorder), which private records need. */
static pa_status private_kept(const pa__iter *it, const uint8_t *kv,
                              uint8_t **vpriv) {
  pa_status st = PA_SUCCESS;
  const pa_dmesh *dm = it->dm;
  pa_idx nown = dm->nown[PA_VERTEX];
  const pa_gid *g = dm->gid[PA_VERTEX];
  const pa__sf *sf = &dm->sf[PA_VERTEX];
  *vpriv = NULL;
  for (pa_idx v = 1; v < nown; v++)
    if (g[v] <= g[v - 1]) return PA_SUCCESS;
  PA_ALLOC(*vpriv, nown ? nown : 1);
  for (pa_idx v = 0; v < nown; v++)
    (*vpriv)[v] = (uint8_t)(kv[v] && it->vlab[4 * v] == PA_ADAPT_NOLABEL);
  for (pa_idx q = 0; sf->rootoff && q < sf->rootoff[sf->nrootrank]; q++)
    (*vpriv)[sf->rootidx[q]] = 0; /* copies on other ranks */
cleanup:
  return st;
}

/* What the phases of pa__adapt_reintegrate share: the staying owned
 * elements (keep), the kept owned vertices, boundary entities and edges
 * (kv, kb, kd) and the kept vertices that can be private (vpriv); per local
 * piece, the boundary entities and edges its output gives (bemit, demit);
 * the records of the rebuild (R; Rp: the private vertices) and their
 * layout; per kind, the largest id in use (base), the fresh ids this rank
 * needs (cnt) and its first one (off); a payload buffer; whether the mesh
 * is spliced rather than rebuilt (splice) and then what changes
 * (patch_marks). */
typedef struct reint {
  uint8_t *keep, *kv, *kb, *kd, *vpriv;
  uint8_t **bemit, **demit;
  pa__recs R[PA_DMESH_NKIND], Rp;
  pa__layout lay;
  pa_gid base[PA_DMESH_NKIND], cnt[PA_DMESH_NKIND], off[PA_DMESH_NKIND];
  unsigned char *pay;
  uint8_t *vtouch, *collar, *ugive, *btouch, *dtouch;
  int splice;
} reint;

/* Free the flags and the payload buffer (before the rebuild, which they
 * would only make heavier, and on failure). */
static void reint_free_flags(reint *r) {
  pa__free(r->keep);
  pa__free(r->vpriv);
  pa__free(r->kv);
  pa__free(r->kb);
  pa__free(r->kd);
  pa__free(r->pay);
  pa__free(r->vtouch);
  pa__free(r->collar);
  pa__free(r->ugive);
  pa__free(r->btouch);
  pa__free(r->dtouch);
  r->keep = r->vpriv = r->kv = r->kb = r->kd = NULL;
  r->vtouch = r->collar = r->ugive = r->btouch = r->dtouch = NULL;
  r->pay = NULL;
}

/* Step 1: which pieces failed (over every rank), which owned elements stay
 * (the unlabelled ones). */
static pa_status staying_elements(pa__iter *it, reint *r) {
  pa_status st = PA_SUCCESS;
  PA_CALL(pa__allreduce(it->dm->comm, it->piece_failed, it->npieces, MPI_INT,
                        MPI_MAX));
  PA_ALLOC(r->keep, it->ne);
  for (pa_idx e = 0; e < it->ne; e++)
    r->keep[e] = it->label[e] < 0;
cleanup:
  return st;
}

/* Step 2: the kept vertices, boundary entities and edges (kept_flags).
 * The balls (pa__adapt_entity_balls) go after: they describe the mesh
 * about to be rebuilt. */
static pa_status kept_entities(pa__iter *it, reint *r) {
  pa_status st = PA_SUCCESS;
  PA_CALL(pa__adapt_entity_balls(it));
  PA_CALL(kept_flags(it, PA_VERTEX, r->keep, it->bstart, it->belem, &r->kv));
  PA_CALL(kept_flags(it, PA_BOUNDARY, r->keep, it->bstart, it->belem, &r->kb));
  PA_CALL(kept_flags(it, PA_EDGE, r->keep, it->bstart, it->belem, &r->kd));
  pa__free(it->bstart);
  pa__free(it->belem);
  it->bstart = it->belem = NULL;
cleanup:
  return st;
}


/* Step 3: the largest id in use here (base), and per output the entities
 * that keep their id, the boundary entities and edges it gives and the
 * rank of each element (output_dest): the count of fresh ids this rank
 * needs of each kind (cnt). Then the inputs keep only their vertices
 * (coordinates, references: all the rest of the reintegration reads), so
 * that the records of step 4 do not stack on their cells. */
static pa_status count_fresh(pa__iter *it, reint *r) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = it->dm;
  for (int k = 0; k < PA_DMESH_NKIND; k++)
    for (pa_idx i = 0; i < dm->nown[k]; i++)
      if (dm->gid[k][i] > r->base[k]) r->base[k] = dm->gid[k][i];
  PA_CALLOC(r->bemit, it->npiece_local);
  PA_CALLOC(r->demit, it->npiece_local);
  for (int q = 0; q < it->npiece_local; q++) {
    pa__piece *pc = &it->pieces[q];
    if (!pc->out) continue;
    for (pa_idx j = 0; j < pc->out->nv; j++) r->cnt[PA_VERTEX] += pc->match[j] < 0;
    /* entities given back unchanged keep their ids (one that is given is
     * not on the skin, so its owner does not keep it: an element, boundary
     * entity or edge that a piece shares with the outside lies on a skin
     * face) */
    pa_idx nreuse[PA_DMESH_NKIND] = {0};
    for (int k = PA_ELEMENT; k <= PA_EDGE; k++)
      PA_CALL(output_reuse(pc, k, &nreuse[k]));
    r->cnt[PA_ELEMENT] += pc->out->ne - nreuse[PA_ELEMENT];
    PA_CALL(output_emit(pc->out, pc->reuse[PA_BOUNDARY], pc->reuse[PA_EDGE],
                        pc->bfix, &r->bemit[q], &r->demit[q], r->cnt));
    PA_CALL(output_dest(it, pc, &pc->dest));
    pa__mesh_drop_cells(pc->in); /* only its vertices are read from now */
  }
cleanup:
  return st;
}

/* The elements of every local output (added to *n). */
static void output_counts_elements(const pa__iter *it, pa_gid *n) {
  for (int q = 0; q < it->npiece_local; q++)
    if (it->pieces[q].out) *n += it->pieces[q].out->ne;
}

/* The entities of every local output, per kind (room for their
 * records). */
static void output_counts(const pa__iter *it, size_t *add) {
  for (int k = 0; k < PA_DMESH_NKIND; k++) add[k] = 0;
  for (int q = 0; q < it->npiece_local; q++) {
    const pa_mesh *o = it->pieces[q].out;
    if (!o) continue;
    add[PA_VERTEX] += (size_t)o->nv;
    add[PA_ELEMENT] += (size_t)o->ne;
    add[PA_BOUNDARY] += (size_t)o->nb;
    add[PA_EDGE] += (size_t)o->ned;
  }
}

/* Step 4 (rebuild): the records of the staying owned entities, straight
 * from the local arrays, with room for every output record (no regrowth);
 * the kept vertices that can be private go to Rp. */
static pa_status staying_records(pa__iter *it, reint *r) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = it->dm;
  size_t add[PA_DMESH_NKIND];
  const uint8_t *kk[PA_DMESH_NKIND];
  pa__dmesh_layout(dm, &r->lay);
  kk[PA_VERTEX] = r->kv;
  kk[PA_ELEMENT] = r->keep;
  kk[PA_BOUNDARY] = r->kb;
  kk[PA_EDGE] = r->kd;
  output_counts(it, add);
  PA_CALL(private_kept(it, r->kv, &r->vpriv));
  PA_CALL(pa__dmesh_kept_recs(dm, kk, add, &r->R[PA_ELEMENT], &r->R[PA_VERTEX],
                              &r->R[PA_BOUNDARY], &r->R[PA_EDGE], r->vpriv,
                              &r->Rp));
cleanup:
  return st;
}

/* The debug switch of the reintegration, read here only: the environment
 * variable PADAPT_REINTEGRATE=rebuild forces the rebuild from records,
 * =splice the splice wherever it applies, whatever the share of the mesh
 * that changes (tests compare the two on the same runs). Returns -1, 1 or
 * 0 (unset). */
static int reintegrate_switch(void) {
  const char *e = getenv("PADAPT_REINTEGRATE");
  if (e && !strcmp(e, "rebuild")) return -1;
  if (e && !strcmp(e, "splice")) return 1;
  return 0;
}

/* The splice is chosen when the elements rebuilt (the outputs and the
 * collar) are at most this share of all the elements: its part build then
 * holds fewer records than the whole rebuild would, while the old mesh
 * stays (the peak stays below the rebuild's), and the copy of the kept
 * arrays costs less than their records. */
#define SPLICE_MAX_SHARE 0.25

/* Step 4 (splice): what changes (see splice.c): the vertices in a
 * labelled element on any rank (vtouch, every local one: it->vlab), the
 * staying owned elements with such a vertex (collar), the local boundary
 * entities and edges with such a vertex (btouch, dtouch), and the owned
 * vertices not touched that a collar element contains on some rank
 * (ugive: MAX reduction). *npatch: the elements the part will hold here
 * (the collar and the elements of the local outputs). touch_marks makes
 * the local marks, and incollar[v] for the local vertices (1: in a collar
 * element here). */
static pa_status touch_marks(pa__iter *it, reint *r, int *incollar,
                             pa_gid *npatch) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = it->dm;
  const pa_mesh *m = dm->mesh;
  pa_idx nv = dm->nloc[PA_VERTEX];
  PA_ALLOC(r->vtouch, nv);
  for (pa_idx v = 0; v < nv; v++) {
    r->vtouch[v] = it->vlab[4 * v] != PA_ADAPT_NOLABEL;
    incollar[v] = 0;
  }
  PA_CALLOC(r->collar, it->ne);
  *npatch = 0;
  for (pa_idx e = 0; e < it->ne; e++) {
    const pa_idx *ev = m->elem + (size_t)it->nve * e;
    for (int k = 0; r->keep[e] && k < it->nve; k++)
      r->collar[e] |= r->vtouch[ev[k]];
    for (int k = 0; r->collar[e] && k < it->nve; k++) incollar[ev[k]] = 1;
    *npatch += r->collar[e];
  }
  output_counts_elements(it, npatch);
  for (int t = 0; t < 2; t++) {
    int kind = t ? PA_EDGE : PA_BOUNDARY, nvk = pa__kind_nv(it->dim, kind);
    const pa_idx *conn = t ? m->edge : m->bdry;
    uint8_t **out = t ? &r->dtouch : &r->btouch;
    PA_CALLOC(*out, dm->nloc[kind]);
    for (pa_idx b = 0; b < dm->nloc[kind]; b++)
      for (int k = 0; k < nvk; k++)
        (*out)[b] |= r->vtouch[conn[(size_t)nvk * b + k]];
  }
cleanup:
  return st;
}

static pa_status patch_marks(pa__iter *it, reint *r, pa_gid *npatch) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = it->dm;
  pa_dmesh_value *val = NULL;
  PA_CALL(pa_dmesh_value_add(dm, PA_VERTEX, "pa.adapt.collar", MPI_INT, 1, -1,
                             &val));
  st = touch_marks(it, r, pa_dmesh_value_data(val, NULL, NULL), npatch);
  PA_CALL(pa__agree(dm->comm, st));
  PA_CALL(pa_dmesh_reduce(dm, val, MPI_MAX));
  {
    const int *x = pa_dmesh_value_data(val, NULL, NULL);
    PA_ALLOC(r->ugive, dm->nown[PA_VERTEX]);
    for (pa_idx v = 0; v < dm->nown[PA_VERTEX]; v++)
      r->ugive[v] = (uint8_t)(!r->vtouch[v] && x[v]);
  }
cleanup:
  st = pa__dmesh_value_drop(dm, val, pa__agree_end(dm->comm, st));
  return st;
}

/* Whether the mesh is spliced (pa__dmesh_splice) rather than rebuilt,
 * agreed over the ranks: with no ghost elements and the numbering a build
 * leaves, when the elements rebuilt are at most SPLICE_MAX_SHARE of all
 * (or the switch says so); the patch marks are made then. */
static pa_status choose_splice(pa__iter *it, reint *r) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = it->dm;
  int sw = reintegrate_switch();
  /* ok, then the elements of the outputs (a lower bound of the part's,
   * which saves the marks when already too many) and before */
  pa_gid cnt[3] = {sw >= 0 && dm->overlap == 0 && pa__dmesh_canonical(dm), 0,
                   dm->nown[PA_ELEMENT]};
  output_counts_elements(it, &cnt[1]);
  PA_CALL(pa__allreduce(dm->comm, cnt, 3, MPI_INT64_T, MPI_SUM));
  int ok = cnt[0] == it->size &&
           (sw > 0 || (double)cnt[1] <= SPLICE_MAX_SHARE * (double)cnt[2]);
  if (ok) {
    PA_CALL(patch_marks(it, r, &cnt[1]));
    PA_CALL(pa__allreduce(dm->comm, &cnt[1], 1, MPI_INT64_T, MPI_SUM));
    ok = sw > 0 || (double)cnt[1] <= SPLICE_MAX_SHARE * (double)cnt[2];
  }
  r->splice = ok;
  if (it->rank == 0 && cnt[0] == it->size)
    pa__info(2, "padapt: reintegrate: %s (a part of %s%lld elements, %lld "
                "before)\n", ok ? "splice" : "rebuild", r->collar ? "" : "over ",
             (long long)cnt[1], (long long)cnt[2]);
cleanup:
  return st;
}

/* Step 4 (splice): the records of the part: the collar elements, the
 * touched vertices, boundary entities and edges that stay and the vertices
 * of the collar that are not touched (ugive; private when no other rank
 * has them), with room for every output record. */
static pa_status patch_records(pa__iter *it, reint *r) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = it->dm;
  size_t add[PA_DMESH_NKIND];
  const uint8_t *kk[PA_DMESH_NKIND];
  const pa__sf *sf = &dm->sf[PA_VERTEX];
  pa__dmesh_layout(dm, &r->lay);
  output_counts(it, add);
  /* the kept flags narrowed to the part */
  for (pa_idx v = 0; v < dm->nown[PA_VERTEX]; v++)
    r->kv[v] = (uint8_t)((r->kv[v] && r->vtouch[v]) || r->ugive[v]);
  for (pa_idx b = 0; b < dm->nown[PA_BOUNDARY]; b++)
    r->kb[b] = (uint8_t)(r->kb[b] && r->btouch[b]);
  for (pa_idx b = 0; b < dm->nown[PA_EDGE]; b++)
    r->kd[b] = (uint8_t)(r->kd[b] && r->dtouch[b]);
  PA_ALLOC(r->vpriv, dm->nown[PA_VERTEX]);
  memcpy(r->vpriv, r->ugive, dm->nown[PA_VERTEX]);
  for (pa_idx q = 0; sf->rootoff && q < sf->rootoff[sf->nrootrank]; q++)
    r->vpriv[sf->rootidx[q]] = 0; /* copies on other ranks */
  kk[PA_VERTEX] = r->kv;
  kk[PA_ELEMENT] = r->collar;
  kk[PA_BOUNDARY] = r->kb;
  kk[PA_EDGE] = r->kd;
  PA_CALL(pa__dmesh_kept_recs(dm, kk, add, &r->R[PA_ELEMENT], &r->R[PA_VERTEX],
                              &r->R[PA_BOUNDARY], &r->R[PA_EDGE], r->vpriv,
                              &r->Rp));
cleanup:
  return st;
}

/* Step 7 (splice): the part built from the records, then spliced in: what
 * stays of dm is the vertices, boundary entities and edges not touched and
 * the staying elements out of the collar. */
static pa_status splice_part(pa__iter *it, reint *r) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = it->dm, *part = NULL;
  const uint8_t *keep[PA_DMESH_NKIND];
  PA_CALL(pa__dmesh_create(dm->comm, dm->dim, &part));
  st = pa__dmesh_values_like(part, dm);
  PA_CALL(pa__agree(dm->comm, st));
  PA_CALL(pa__dmesh_build_priv(part, &r->lay, 0, &r->R[PA_ELEMENT],
                               &r->R[PA_VERTEX], &r->R[PA_BOUNDARY],
                               &r->R[PA_EDGE], &r->Rp));
  /* the marks turn into what stays of dm */
  for (pa_idx v = 0; v < dm->nloc[PA_VERTEX]; v++) r->vtouch[v] = !r->vtouch[v];
  for (pa_idx e = 0; e < dm->nown[PA_ELEMENT]; e++)
    r->collar[e] = (uint8_t)(r->keep[e] && !r->collar[e]);
  for (pa_idx b = 0; b < dm->nloc[PA_BOUNDARY]; b++) r->btouch[b] = !r->btouch[b];
  for (pa_idx b = 0; b < dm->nloc[PA_EDGE]; b++) r->dtouch[b] = !r->dtouch[b];
  keep[PA_VERTEX] = r->vtouch;
  keep[PA_ELEMENT] = r->collar;
  keep[PA_BOUNDARY] = r->btouch;
  keep[PA_EDGE] = r->dtouch;
  PA_CALL(pa__dmesh_splice(dm, keep, part));
cleanup:
  pa_dmesh_destroy(part);
  return st;
}

/* Step 5: this rank's first fresh id of each kind (off): after the largest
 * id in use on any rank, an exclusive scan of the counts; the vertices
 * bisect.c added take ids after every other new vertex. */
static pa_status fresh_ids(pa__iter *it, reint *r) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = it->dm;
  pa_gid tot = r->cnt[PA_VERTEX];
  PA_CALL(
      pa__allreduce(dm->comm, r->base, PA_DMESH_NKIND, MPI_INT64_T, MPI_MAX));
  PA_CALL(pa__agree(dm->comm, st));
  MPI_Exscan(r->cnt, r->off, PA_DMESH_NKIND, MPI_INT64_T, MPI_SUM, dm->comm);
  if (it->rank == 0)
    for (int k = 0; k < PA_DMESH_NKIND; k++) r->off[k] = 0;
  for (int k = 0; k < PA_DMESH_NKIND; k++) r->off[k] += r->base[k] + 1;
  PA_CALL(pa__allreduce(dm->comm, &tot, 1, MPI_INT64_T, MPI_SUM));
  PA_CALL(skin_vertex_ids(it, r->base[PA_VERTEX] + 1 + tot));
cleanup:
  return st;
}

/* Step 6: the records of the outputs, each piece released once done, and
 * the wire bytes of every record (a fixed part each, plus the payloads). */
static pa_status outputs_to_records(pa__iter *it, reint *r,
                                    const pa_dmesh_value *done) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = it->dm;
  size_t maxpay = 0;
  for (int k = 0; k < dm->nvalue; k++) maxpay += dm->value[k]->unit;
  PA_ALLOC(r->pay, maxpay);
  for (int q = 0; q < it->npiece_local; q++) {
    pa__piece *pc = &it->pieces[q];
    if (!pc->out) continue;
    PA_CALL(output_records(it, pc, r->bemit[q], r->demit[q], r->off, done,
                           r->R, &r->Rp, r->pay));
    pa__piece_release(pc);
    pa__free(r->bemit[q]);
    pa__free(r->demit[q]);
    r->bemit[q] = r->demit[q] = NULL;
  }
  for (int k = 0; k < PA_DMESH_NKIND; k++)
    if (r->R[k].n) {
      const size_t *po = r->R[k].poff;
      size_t fixed = pa__recs_wire(&r->R[k], 0) - (po ? po[1] - po[0] : 0);
      it->bytes_moved +=
          (double)(r->R[k].n * fixed + (po ? po[r->R[k].n] - po[0] : 0));
    }
cleanup:
  return st;
}

pa_status pa__adapt_reintegrate(pa__iter *it, pa_dmesh_value *done) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = it->dm;
  reint r;
  double t0 = pa_wtime(), t1;
  memset(&r, 0, sizeof r);
  for (int k = 0; k < PA_DMESH_NKIND; k++) r.base[k] = -1;
  PA_CALL(staying_elements(it, &r));
  PA_CALL(kept_entities(it, &r));
  PA_CALL(count_fresh(it, &r));
  PA_CALL(fresh_ids(it, &r));
  PA_CALL(choose_splice(it, &r));
  PA_CALL(r.splice ? patch_records(it, &r) : staying_records(it, &r));
  PA_CALL(outputs_to_records(it, &r, done));
  PA_CALL(pa__agree(dm->comm, st));
  pa__iter_release_elements(it);
  if (r.splice) {
    /* 7. splice: a part rebuilt from the records, put in place */
    t1 = pa_wtime();
    PA_CALL(splice_part(it, &r));
  } else {
    /* 7. rebuild: what the records replace goes first */
    reint_free_flags(&r);
    pa__dmesh_clear(dm);
    t1 = pa_wtime();
    PA_CALL(pa__dmesh_build_priv(dm, &r.lay, dm->overlap, &r.R[PA_ELEMENT],
                                 &r.R[PA_VERTEX], &r.R[PA_BOUNDARY],
                                 &r.R[PA_EDGE], &r.Rp));
  }
  pa__info(2, "padapt: rank %d: reintegrate: records %.3f s, %s %.3f s\n",
           it->rank, t1 - t0, r.splice ? "splice" : "build", pa_wtime() - t1);
cleanup:
  st = pa__agree_end(dm->comm, st);
  for (int k = 0; k < PA_DMESH_NKIND; k++) pa__recs_free(&r.R[k]);
  pa__recs_free(&r.Rp);
  reint_free_flags(&r);
  for (int q = 0; r.bemit && q < it->npiece_local; q++) pa__free(r.bemit[q]);
  for (int q = 0; r.demit && q < it->npiece_local; q++) pa__free(r.demit[q]);
  pa__free(r.bemit);
  pa__free(r.demit);
  return st;
}
