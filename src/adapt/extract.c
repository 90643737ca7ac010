/*
 * extract.c -- step 3 of the piece algorithm: map the pieces to ranks and
 * gather each piece's fragments onto its rank as one sequential mesh.
 *
 * Mapping: the piece x rank matrix of element counts, the work of every
 * piece and the number of hot tagged elements (tagged, touching a hot skin
 * vertex) are summed over the ranks (every rank then computes the same
 * map).
 * Pieces are taken heaviest first; each goes to the rank holding most of
 * its elements unless that rank would exceed the mean load by 10 %, else to
 * the least loaded rank (ties: lowest rank), so little data moves and the
 * estimated work is balanced.
 *
 * Gathering: each rank sends, for every labelled owned element, the element
 * (aux = piece, with its element fields), and for every (piece, entity)
 * pair the vertices (with coordinates, metric, fields, and transit flag
 * bits: skin, hot, inner for that piece; in 3D the normals and masks of
 * it->vsurf as a temporary field, PA_ADAPT_SURFACE_FIELD), boundary
 * entities (with their boundary fields) and edges of the piece's elements
 * it holds. pa__recs_migrate
 * moves them; the receiver drops duplicates (an entity held by several
 * ranks) and assembles each of its pieces, numbered by increasing global id,
 * so the piece does not depend on how its fragments were spread.
 *
 * A boundary entity inside the domain on the outer surface of a piece (an
 * interface between two references, which the element on its other side,
 * staying or in another piece, shares: it->bside) comes flagged
 * PA_ADAPT_SKIN_TRANSIT and is frozen in the piece (pc->bfix), as its skin.
 *
 * The piece keeps the global id of each of its vertices (pc->vgid; the
 * remesher never sees them: reintegrate.c matches the output's vertices
 * by their coordinates); the faces of its outer surface that are not
 * boundary entities become boundary entities of reference PA_ADAPT_SKIN_REF
 * flagged PA_FLAG_REQUIRED (its skin, frozen), which bisect.c then refines
 * where the piece meets another one. If a skin split onto a curve left an
 * element without a positive volume in a piece on any rank, every rank
 * assembles its pieces again from the same records without such splits
 * (one allreduce): the pieces around that skin cannot decide alone, each
 * sees its own side.
 */
#include "adapt/piece.h"

#include <limits.h>
#include <math.h>
#include <stdio.h>

/* 1 if owned element e contains the k vertices f (local indices). */
static int contains(const pa_mesh *m, pa_idx e, const pa_idx *f, int k) {
  const pa_idx *v = m->elem + (size_t)(m->dim + 1) * e;
  for (int i = 0; i < k; i++) {
    int in = 0;
    for (int j = 0; j <= m->dim; j++) in |= v[j] == f[i];
    if (!in) return 0;
  }
  return 1;
}

/* Face skins: 1 if local vertex v, in a piece of label l, touches a tagged
 * element of another piece (the remesher cannot reach across: elements
 * produced near it may need another pass). */
static int hot_vertex(const pa__iter *it, pa_idx v, int l) {
  const int *x = it->vlab + 4 * (size_t)v;
  return x[2] != PA_ADAPT_NOLABEL && (x[2] != l || x[3] != l);
}

/* Heaviest-first greedy map of pieces to ranks (see the file comment). */
static pa_status map_pieces(pa__iter *it, const double *cnt) {
  pa_status st = PA_SUCCESS;
  int np = it->npieces, P = it->size;
  int *order = NULL;
  double *load = NULL, total = 0;
  PA_ALLOC(order, np);
  PA_CALLOC(load, P);
  for (int p = 0; p < np; p++) {
    order[p] = p;
    total += it->piece_work[p];
  }
  /* insertion sort by work descending, then id: np is small */
  for (int i = 1; i < np; i++) {
    int x = order[i], j = i - 1;
    while (j >= 0 && (it->piece_work[order[j]] < it->piece_work[x] ||
                      (it->piece_work[order[j]] == it->piece_work[x] &&
                       order[j] > x))) {
      order[j + 1] = order[j];
      j--;
    }
    order[j + 1] = x;
  }
  double mean = total / P;
  for (int i = 0; i < np; i++) {
    int p = order[i], best = 0, least = 0;
    for (int r = 1; r < P; r++) {
      if (cnt[(size_t)p * P + r] > cnt[(size_t)p * P + best]) best = r;
      if (load[r] < load[least]) least = r;
    }
    int r = best;
    if (load[best] > 0 && load[best] + it->piece_work[p] > 1.1 * mean) r = least;
    it->piece_rank[p] = r;
    load[r] += it->piece_work[p];
    if (it->rank == 0)
      pa__info(2, "padapt: piece %d: work %.0f, %.0f elements on its rank "
                  "%d (most on %d)\n", p, it->piece_work[p],
               cnt[(size_t)p * P + r], r, best);
  }
  {
    double mx = 0;
    for (int r = 0; r < P; r++) mx = load[r] > mx ? load[r] : mx;
    it->imbalance = mean > 0 ? mx / mean : 1.0;
  }
cleanup:
  pa__free(order);
  pa__free(load);
  return st;
}

/* Sort and deduplicate keys piece * n + entity; returns the count. */
static size_t pairs_unique(pa_gid *key, size_t n) {
  return pa__gid_sort_unique(key, n);
}

/* Records of the (piece, entity) pairs of a kind held by this rank. */
static pa_status pair_records(pa__iter *it, int kind, const pa_idx *bstart,
                              const pa_idx *belem, pa__recs *R, int **dest) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = it->dm;
  const pa_mesh *m = dm->mesh;
  int d = it->dim, nv = pa__kind_nv(d, kind);
  pa_idx nloc = dm->nloc[kind];
  size_t n = 0, cap = 0;
  pa_gid *key = NULL, N = nloc > 0 ? nloc : 1;
  double *dbl = NULL;
  size_t punit = 0;
  unsigned char *pay = NULL;
  pa__layout lay;
  pa__dmesh_layout(dm, &lay);
  if (kind == PA_VERTEX) {
    size_t nlab = 0; /* the pieces' elements only: a later piece is small */
    for (pa_idx e = 0; e < it->ne; e++) nlab += it->label[e] >= 0;
    PA_ALLOC(key, (nlab ? nlab : 1) * it->nve);
    for (pa_idx e = 0; e < it->ne; e++)
      if (it->label[e] >= 0)
        for (int k = 0; k < it->nve; k++)
          key[n++] = (pa_gid)it->label[e] * N + m->elem[(size_t)it->nve * e + k];
  } else {
    const pa_idx *conn = kind == PA_BOUNDARY ? m->bdry : m->edge;
    for (pa_idx b = 0; b < nloc; b++) {
      const pa_idx *f = conn + (size_t)nv * b;
      if (!pa__adapt_near_piece(it, f, nv)) continue;
      for (pa_idx q = bstart[f[0]]; q < bstart[f[0] + 1]; q++) {
        pa_idx e = belem[q];
        if (it->label[e] < 0 || !contains(m, e, f, nv)) continue;
        PA_GROW(key, cap, n + 1);
        key[n++] = (pa_gid)it->label[e] * N + b;
      }
    }
  }
  n = pairs_unique(key, n);
  PA_ALLOC(*dest, n);
  if (R->ndbl) PA_ALLOC(dbl, R->ndbl);
  /* their user values go as payloads (vertices, boundary entities and
   * edges the remesher keeps keep them) */
  for (int k = 0; k < dm->nvalue; k++)
    if ((int)dm->value[k]->kind == kind) punit += dm->value[k]->unit;
  if (punit) PA_ALLOC(pay, punit);
  for (size_t i = 0; i < n; i++) {
    int p = (int)(key[i] / N);
    pa_idx x = (pa_idx)(key[i] % N);
    pa_gid vg[4];
    int32_t ref;
    uint8_t flag;
    if (kind == PA_VERTEX) {
      pa__vertex_doubles(m, x, m->nfield, dbl);
      ref = m->vref[x];
      flag = m->vflag[x];
      {
        const int *l = it->vlab + 4 * (size_t)x;
        if (l[0] != l[1]) flag |= PA_ADAPT_SKIN_TRANSIT;
        if (hot_vertex(it, x, p)) flag |= PA_ADAPT_HOT_TRANSIT;
        flag |= it->vinner[x];
      }
    } else {
      const pa_idx *conn = kind == PA_BOUNDARY ? m->bdry : m->edge;
      for (int j = 0; j < nv; j++)
        vg[j] = dm->gid[PA_VERTEX][conn[(size_t)nv * x + j]];
      ref = kind == PA_BOUNDARY ? m->bref[x] : m->edref[x];
      flag = kind == PA_BOUNDARY ? m->bflag[x] : m->edflag[x];
      if (kind == PA_BOUNDARY &&
          it->bside[x] == (PA_ADAPT_B_INTERIOR | PA_ADAPT_B_CUT))
        flag |= PA_ADAPT_SKIN_TRANSIT; /* on the piece's outer surface */
      if (dbl) pa__entity_doubles(m, kind, x, dbl); /* boundary fields */
    }
    size_t pl = punit ? pa__entity_payload(dm, kind, x, pay) : 0;
    PA_CALL(pa__recs_add(R, dm->gid[kind][x], vg, ref, flag, p, dbl, pay, pl));
    (*dest)[i] = it->piece_rank[p];
  }
cleanup:
  pa__free(key);
  pa__free(dbl);
  pa__free(pay);
  return st;
}

/* Wire bytes of the records going to other ranks. */
static double bytes_out(const pa__recs *R, const int *dest, int rank) {
  double b = 0;
  for (size_t i = 0; i < R->n; i++)
    if (dest[i] != rank) b += (double)pa__recs_wire(R, i);
  return b;
}

/* Record indices of R grouped by piece (aux), by gid within a piece,
 * without duplicate gids: piece p's are idx[start[p] .. start[p+1]). */
static pa_status group_by_piece(const pa__recs *R, int npieces, pa_idx **idxp,
                                pa_idx **startp) {
  pa_status st = PA_SUCCESS;
  pa_idx *idx = NULL, *start = NULL;
  PA_CALLOC(start, (size_t)npieces + 1);
  PA_ALLOC(idx, R->n);
  for (size_t i = 0; i < R->n; i++) start[R->aux[i] + 1]++;
  for (int p = 0; p < npieces; p++) start[p + 1] += start[p];
  for (size_t i = 0; i < R->n; i++) idx[start[R->aux[i]]++] = (pa_idx)i;
  for (int p = npieces; p > 0; p--) start[p] = start[p - 1];
  start[0] = 0;
  /* R is sorted by gid, so each group is too: drop repeated gids */
  {
    pa_idx w = 0;
    for (int p = 0; p < npieces; p++) {
      pa_idx s = start[p], e = start[p + 1];
      start[p] = w;
      for (pa_idx q = s; q < e; q++)
        if (q == s || R->gid[idx[q]] != R->gid[idx[q - 1]]) idx[w++] = idx[q];
    }
    start[npieces] = w;
  }
  *idxp = idx;
  *startp = start;
  idx = start = NULL;
cleanup:
  pa__free(idx);
  pa__free(start);
  return st;
}

/* The global ids (not of vertices: pc->vgid has them) and value bytes (the
 * payloads after skip bytes; kpoff NULL when none) of the entities of a
 * kind as gathered for piece p: an entity the remesher gives back
 * unchanged keeps them (reintegrate.c). */
static pa_status keep_ids(pa__piece *pc, int kind, const pa__recs *R,
                          pa_idx *const *idx, pa_idx *const *start, int p,
                          size_t skip) {
  pa_status st = PA_SUCCESS;
  pa_idx n = start[kind][p + 1] - start[kind][p];
  const pa_idx *sel = idx[kind] + start[kind][p];
  size_t tot = 0;
  pc->n0[kind] = n;
  if (kind != PA_VERTEX) {
    PA_ALLOC(pc->kgid[kind], n ? n : 1);
    for (pa_idx k = 0; k < n; k++) pc->kgid[kind][k] = R->gid[sel[k]];
  }
  if (!R->poff) goto cleanup;
  for (pa_idx k = 0; k < n; k++)
    tot += R->poff[sel[k] + 1] - R->poff[sel[k]] - skip;
  PA_ALLOC(pc->kpoff[kind], (size_t)n + 1);
  PA_ALLOC(pc->kpay[kind], tot ? tot : 1);
  pc->kpoff[kind][0] = 0;
  for (pa_idx k = 0; k < n; k++) {
    size_t i = (size_t)sel[k], len = R->poff[i + 1] - R->poff[i] - skip;
    memcpy(pc->kpay[kind] + pc->kpoff[kind][k], R->pay + R->poff[i] + skip,
           len);
    pc->kpoff[kind][k + 1] = pc->kpoff[kind][k] + len;
  }
cleanup:
  return st;
}

/* What the phases of build_piece share: the received records (R; piece
 * p's of kind k are idx[k][start[k][p] .. start[k][p + 1])), the piece and
 * its mesh being filled (m), its vertices by global id (map) and their
 * marks for bisect.c (inner: 1 inner, 2 labelled, see pieces.c). */
typedef struct pbuild {
  pa__iter *it;
  int p;
  const pa__recs *R;
  pa_idx *const *idx, *const *start;
  pa__piece *pc;
  pa_mesh *m;
  pa__gidmap map;
  uint8_t *inner;
} pbuild;

/* The piece's mesh, with the distributed mesh's metric and fields and room
 * for its entities, and its per-vertex arrays. */
static pa_status piece_create(pbuild *b) {
  pa_status st = PA_SUCCESS;
  const pa_mesh *dmm = b->it->dm->mesh;
  pa__piece *pc = b->pc;
  int p = b->p;
  pa_idx *const *start = b->start;
  pa_idx nv = start[PA_VERTEX][p + 1] - start[PA_VERTEX][p];
  pa_idx ne = start[PA_ELEMENT][p + 1] - start[PA_ELEMENT][p];
  pa_idx nb = start[PA_BOUNDARY][p + 1] - start[PA_BOUNDARY][p];
  pa_idx nd = start[PA_EDGE][p + 1] - start[PA_EDGE][p];
  PA_CALL(pa_mesh_create(b->it->dim, &b->m));
  pa_mesh *m = b->m;
  m->met_ncomp = dmm->met_ncomp;
  m->nfield = dmm->nfield;
  if (dmm->vgdim) PA_CALL(pa__mesh_enable_entities(m));
  for (int f = 0; f < dmm->nfield; f++) {
    snprintf(m->field[f].name, PA_MESH_FIELD_NAME_LEN, "%s",
             dmm->field[f].name);
    m->field[f].ncomp = dmm->field[f].ncomp;
  }
  PA_CALL(pa_mesh_reserve(m, nv, ne, nb, nd));
  {
    pa__layout lay;
    pa__mesh_layout(dmm, &lay);
    PA_CALL(pa__layout_cell_fields(&lay, m));
  }
  PA_ALLOC(pc->vgid, nv);
  PA_CALLOC(pc->skin, nv);
  PA_CALLOC(pc->hot, nv);
  PA_ALLOC(pc->vrank, nv);
  PA_CALLOC(b->inner, nv);
  PA_CALL(pa__gidmap_init(&b->map, (size_t)nv));
cleanup:
  return st;
}

/* The piece's vertices in gid order: coordinates, metric, fields, and the
 * transit flag bits turned into pc->skin, pc->hot and inner; their user
 * values kept for those the remesher keeps. */
static pa_status piece_vertices(pbuild *b) {
  pa_status st = PA_SUCCESS;
  const pa__recs *V = &b->R[PA_VERTEX];
  pa__piece *pc = b->pc;
  pa_mesh *m = b->m;
  int p = b->p;
  pa_idx nv = b->start[PA_VERTEX][p + 1] - b->start[PA_VERTEX][p];
  for (pa_idx k = 0; k < nv; k++) {
    size_t i = (size_t)b->idx[PA_VERTEX][b->start[PA_VERTEX][p] + k];
    pa__vertex_set_doubles(m, k, V->dbl + (size_t)V->ndbl * i);
    m->vref[k] = V->ref[i];
    m->vflag[k] = V->flag[i];
    pc->vrank[k] = INT_MAX;
    pc->skin[k] = (V->flag[i] & PA_ADAPT_SKIN_TRANSIT) != 0;
    pc->hot[k] = (V->flag[i] & PA_ADAPT_HOT_TRANSIT) != 0;
    b->inner[k] = (uint8_t)(((V->flag[i] & PA_ADAPT_INNER_TRANSIT) ? 1 : 0) |
                            ((V->flag[i] & PA_ADAPT_LABELLED_TRANSIT) ? 2 : 0));
    m->vflag[k] &=
        (uint8_t) ~(PA_ADAPT_SKIN_TRANSIT | PA_ADAPT_HOT_TRANSIT |
                    PA_ADAPT_INNER_TRANSIT | PA_ADAPT_LABELLED_TRANSIT);
    pc->vgid[k] = V->gid[i];
    PA_CALL(pa__gidmap_put(&b->map, V->gid[i], k, NULL, NULL));
  }
  m->nv = nv;
  /* the vertices' user values, for those the remesher keeps */
  PA_CALL(keep_ids(pc, PA_VERTEX, V, b->idx, b->start, p, 0));
cleanup:
  return st;
}

/* The piece's elements, and the rank each vertex came from (pc->vrank:
 * the smallest sender of an element around it, in the payload's first
 * bytes); their ids and values kept for those the remesher keeps. */
static pa_status piece_elements(pbuild *b) {
  pa_status st = PA_SUCCESS;
  const pa__recs *E = &b->R[PA_ELEMENT];
  pa__piece *pc = b->pc;
  pa_mesh *m = b->m;
  int d = m->dim, p = b->p;
  pa_idx ne = b->start[PA_ELEMENT][p + 1] - b->start[PA_ELEMENT][p];
  for (pa_idx k = 0; k < ne; k++) {
    size_t i = (size_t)b->idx[PA_ELEMENT][b->start[PA_ELEMENT][p] + k];
    for (int j = 0; j <= d; j++) {
      pa_idx v = pa__gidmap_get(&b->map, E->vgid[(size_t)(d + 1) * i + j]);
      PA_CHECK(v >= 0, PA_ERR_INTERNAL, "piece %d: vertex %lld of element "
               "%lld was not gathered", p,
               (long long)E->vgid[(size_t)(d + 1) * i + j], (long long)E->gid[i]);
      m->elem[(size_t)(d + 1) * k + j] = v;
      int32_t from;
      memcpy(&from, E->pay + E->poff[i], sizeof from);
      if (from < pc->vrank[v]) pc->vrank[v] = from;
    }
    m->eref[k] = E->ref[i];
    m->eflag[k] = E->flag[i];
    if (E->ndbl) pa__entity_set_doubles(m, PA_ELEMENT, k, E->dbl + (size_t)E->ndbl * i);
  }
  m->ne = ne;
  pc->nv0 = m->nv;
  PA_CALL(keep_ids(pc, PA_ELEMENT, E, b->idx, b->start, p, sizeof(int32_t)));
cleanup:
  return st;
}

/* The piece's boundary entities and edges, their ids and values kept. */
static pa_status piece_subentities(pbuild *b) {
  pa_status st = PA_SUCCESS;
  pa_mesh *m = b->m;
  int d = m->dim, p = b->p;
  for (int kind = PA_BOUNDARY; kind <= PA_EDGE; kind++) {
    const pa__recs *B = &b->R[kind];
    int nvk = pa__kind_nv(d, kind);
    pa_idx n = b->start[kind][p + 1] - b->start[kind][p];
    pa_idx *conn = kind == PA_BOUNDARY ? m->bdry : m->edge;
    for (pa_idx k = 0; k < n; k++) {
      size_t i = (size_t)b->idx[kind][b->start[kind][p] + k];
      for (int j = 0; j < nvk; j++) {
        pa_idx v = pa__gidmap_get(&b->map, B->vgid[(size_t)nvk * i + j]);
        PA_CHECK(v >= 0, PA_ERR_INTERNAL, "piece %d: a vertex of %s %lld was "
                 "not gathered", p, kind == PA_BOUNDARY ? "boundary entity" : "edge",
                 (long long)B->gid[i]);
        conn[(size_t)nvk * k + j] = v;
      }
      if (kind == PA_BOUNDARY) {
        m->bref[k] = B->ref[i];
        m->bflag[k] = B->flag[i] & (uint8_t)~PA_ADAPT_SKIN_TRANSIT;
        if (B->flag[i] & PA_ADAPT_SKIN_TRANSIT) {
          if (!b->pc->bfix) PA_CALLOC(b->pc->bfix, n);
          b->pc->bfix[k] = 1;
          m->bflag[k] |= PA_FLAG_REQUIRED;
        }
        if (B->ndbl)
          pa__entity_set_doubles(m, PA_BOUNDARY, k, B->dbl + (size_t)B->ndbl * i);
      } else {
        m->edref[k] = B->ref[i];
        m->edflag[k] = B->flag[i];
      }
    }
    if (kind == PA_BOUNDARY) m->nb = n;
    else m->ned = n;
    PA_CALL(keep_ids(b->pc, kind, B, b->idx, b->start, p, 0));
  }
cleanup:
  return st;
}

/* The outer surface: artificial, frozen boundary entities (the skin),
 * refined by bisect.c where the piece meets another; the mesh becomes the
 * piece's input. */
static pa_status piece_skin(pbuild *b) {
  pa_status st = PA_SUCCESS;
  pa_mesh *m = b->m;
  pa_idx nb0 = m->nb;
  double *surf = NULL;
  PA_CALL(pa_mesh_build_boundary(m, PA_ADAPT_SKIN_REF, NULL));
  for (pa_idx k = nb0; k < m->nb; k++) m->bflag[k] |= PA_FLAG_REQUIRED;
  b->pc->in = m;
  b->m = NULL;
  /* the normals of the vertices on curved boundaries (pieces.c) leave the
   * piece's fields */
  for (int k = 0; k < m->nfield; k++)
    if (!strcmp(m->field[k].name, PA_ADAPT_SURFACE_FIELD)) {
      PA_ALLOC(surf, (size_t)4 * m->nv);
      memcpy(surf, m->field[k].val, (size_t)4 * m->nv * sizeof *surf);
      PA_CALL(pa_mesh_remove_field(m, k));
      break;
    }
  {
    /* the built-in 2D remesher refines the inside itself, but for long
     * fans on the skin (PA_ADAPT_LEB_INNER_2D) */
    const pa_remesher *r = b->it->opts->remesher;
    int builtin2d = m->dim == 2 && (!r || r == pa_remesher_builtin());
    PA_CALL(pa__piece_refine_skin(
        b->pc, b->inner, builtin2d ? PA_ADAPT_LEB_INNER_2D : PA_ADAPT_LEB_INNER,
        builtin2d, surf, !b->it->nocurve));
  }
cleanup:
  pa__free(surf);
  return st;
}

/* Assemble piece p from the received records. */
static pa_status build_piece(pa__iter *it, int p, const pa__recs *R,
                             pa_idx *const *idx, pa_idx *const *start,
                             pa__piece *pc) {
  pa_status st = PA_SUCCESS;
  pbuild b;
  memset(&b, 0, sizeof b);
  b.it = it;
  b.p = p;
  b.R = R;
  b.idx = idx;
  b.start = start;
  b.pc = pc;
  memset(pc, 0, sizeof *pc);
  pc->id = p;
  PA_CALL(piece_create(&b));
  PA_CALL(piece_vertices(&b));
  PA_CALL(piece_elements(&b));
  PA_CALL(piece_subentities(&b));
  PA_CALL(piece_skin(&b));
cleanup:
  pa_mesh_destroy(b.m);
  pa__gidmap_free(&b.map);
  pa__free(b.inner);
  return st;
}

/* Step 1: the piece x rank matrix of element counts and the work of every
 * piece, summed over the ranks, and the map of the pieces to ranks. */
static pa_status map_to_ranks(pa__iter *it) {
  pa_status st = PA_SUCCESS;
  const pa_mesh *m = it->dm->mesh;
  int np = it->npieces, P = it->size;
  double *buf = NULL;
  PA_ALLOC(it->piece_work, np);
  PA_ALLOC(it->piece_rank, np);
  PA_CALLOC(it->piece_failed, np);
  PA_CALLOC(buf, (size_t)np * P + np);
  for (pa_idx e = 0; e < it->ne; e++)
    if (it->label[e] >= 0) {
      buf[(size_t)it->label[e] * P + it->rank] += 1;
      buf[(size_t)np * P + it->label[e]] +=
          it->tag[e] ? it->work[e] : pa__elem_work(m, e);
    }
  PA_CALL(pa__allreduce(it->dm->comm, buf, np * P + np, MPI_DOUBLE, MPI_SUM));
  memcpy(it->piece_work, buf + (size_t)np * P, np * sizeof *buf);
  PA_CALL(map_pieces(it, buf));
cleanup:
  pa__free(buf);
  return st;
}

/* Step 2a: the records of the labelled owned elements (aux = piece), to
 * their piece's rank (*dest); payload: the sender, then the element's
 * values (an element the remesher gives back unchanged keeps them). */
static pa_status element_records(pa__iter *it, pa__recs *S, int **dest) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = it->dm;
  const pa_mesh *m = dm->mesh;
  unsigned char *epay = NULL;
  double *dbl = NULL;
  pa_idx n = 0;
  size_t unit = sizeof(int32_t);
  for (pa_idx e = 0; e < it->ne; e++) n += it->label[e] >= 0;
  PA_ALLOC(*dest, n);
  if (S->ndbl) PA_ALLOC(dbl, S->ndbl);
  for (int k = 0; k < dm->nvalue; k++)
    if ((int)dm->value[k]->kind == PA_ELEMENT) unit += dm->value[k]->unit;
  PA_ALLOC(epay, unit);
  n = 0;
  for (pa_idx e = 0; e < it->ne; e++) {
    if (it->label[e] < 0) continue;
    pa_gid vg[4];
    for (int j = 0; j < it->nve; j++)
      vg[j] = dm->gid[PA_VERTEX][m->elem[(size_t)it->nve * e + j]];
    int32_t from = it->rank;
    memcpy(epay, &from, sizeof from);
    size_t pl = sizeof from +
                pa__entity_payload(dm, PA_ELEMENT, e, epay + sizeof from);
    if (dbl) pa__entity_doubles(m, PA_ELEMENT, e, dbl);
    PA_CALL(pa__recs_add(S, dm->gid[PA_ELEMENT][e], vg, m->eref[e],
                         m->eflag[e], it->label[e], dbl, epay, pl));
    (*dest)[n++] = it->piece_rank[it->label[e]];
  }
cleanup:
  pa__free(epay);
  pa__free(dbl);
  return st;
}

/* Step 2b: the records of the (piece, vertex / boundary entity / edge)
 * pairs this rank holds. The user's values travel with the entities (one
 * the remesher keeps keeps them); an entity may be sent from a ghost copy,
 * which first takes its owner's values. */
static pa_status pair_records_all(pa__iter *it, pa__recs *S, int **dest) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = it->dm;
  PA_CALL(pa__adapt_entity_balls(it));
  for (int k = 0; k < dm->nvalue; k++)
    if ((int)dm->value[k]->kind != PA_ELEMENT)
      PA_CALL(pa_dmesh_halo(dm, dm->value[k]));
  PA_CALL(pair_records(it, PA_VERTEX, NULL, NULL, &S[PA_VERTEX], &dest[PA_VERTEX]));
  PA_CALL(pair_records(it, PA_BOUNDARY, it->bstart, it->belem, &S[PA_BOUNDARY],
                       &dest[PA_BOUNDARY]));
  PA_CALL(pair_records(it, PA_EDGE, it->bstart, it->belem, &S[PA_EDGE],
                       &dest[PA_EDGE]));
cleanup:
  return st;
}

/* Step 4: group the received records by piece and build the pieces mapped
 * to this rank (it->pieces). */
static pa_status assemble_local_pieces(pa__iter *it, const pa__recs *R) {
  pa_status st = PA_SUCCESS;
  int np = it->npieces;
  pa_idx *idx[PA_DMESH_NKIND] = {NULL, NULL, NULL, NULL};
  pa_idx *start[PA_DMESH_NKIND] = {NULL, NULL, NULL, NULL};
  for (int k = 0; k < PA_DMESH_NKIND; k++)
    PA_CALL(group_by_piece(&R[k], np, &idx[k], &start[k]));
  it->npiece_local = 0;
  for (int p = 0; p < np; p++) it->npiece_local += it->piece_rank[p] == it->rank;
  PA_CALLOC(it->pieces, it->npiece_local);
  for (int p = 0, q = 0; p < np; p++)
    if (it->piece_rank[p] == it->rank)
      PA_CALL(build_piece(it, p, R, idx, start, &it->pieces[q++]));
cleanup:
  for (int k = 0; k < PA_DMESH_NKIND; k++) {
    pa__free(idx[k]);
    pa__free(start[k]);
  }
  return st;
}

/* Step 5, with it->vsurf: if a split onto a curve left an element without a
 * positive volume in some piece (the pieces around it cannot know: each
 * sees its own side), the pieces are assembled again without such splits,
 * from the same records. Collective. */
static pa_status check_curves(pa__iter *it, const pa__recs *R) {
  pa_status st = PA_SUCCESS;
  double bad = 0, ncurved = 0;
  for (int q = 0; q < it->npiece_local; q++) {
    bad += it->pieces[q].curve_bad;
    ncurved += it->pieces[q].ncurved;
  }
  double x[2] = {bad, ncurved};
  PA_CALL(pa__allreduce(it->dm->comm, x, 2, MPI_DOUBLE, MPI_SUM));
  if (x[0] == 0) {
    if (it->rank == 0 && x[1] > 0)
      pa__info(2, "padapt: iteration %d: %.0f skin vertices placed on curved "
                  "boundaries\n", it->iter, x[1]);
    goto cleanup;
  }
  if (it->rank == 0)
    pa__info(1, "padapt: iteration %d: %.0f elements without a positive "
                "volume next to %.0f skin vertices placed on curved "
                "boundaries: pieces made again with chords\n",
             it->iter, x[0], x[1]);
  for (int q = 0; q < it->npiece_local; q++) pa__piece_release(&it->pieces[q]);
  pa__free(it->pieces);
  it->pieces = NULL;
  it->npiece_local = 0;
  it->nocurve = 1;
  st = assemble_local_pieces(it, R);
cleanup:
  return st;
}

/* The temporary field PA_ADAPT_SURFACE_FIELD on the local mesh from
 * it->vsurf (added = 1), unless the mesh holds the most fields already
 * (then no split goes onto a curve: every rank has the same fields);
 * it->vsurf is released. */
static pa_status add_surface_field(pa__iter *it, int *added) {
  pa_status st = PA_SUCCESS;
  pa_mesh *m = it->dm->mesh;
  *added = 0;
  if (!it->vsurf || m->nfield >= PA_MESH_MAX_FIELDS) goto cleanup;
  PA_CALL(pa_mesh_add_field(m, PA_ADAPT_SURFACE_FIELD, 4, it->vsurf));
  *added = 1;
cleanup:
  pa__free(it->vsurf);
  it->vsurf = NULL;
  return st;
}

pa_status pa__adapt_extract(pa__iter *it) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = it->dm;
  pa__recs S[PA_DMESH_NKIND], R[PA_DMESH_NKIND];
  int *dest[PA_DMESH_NKIND] = {NULL, NULL, NULL, NULL}, surf = 0;
  pa__layout lay;
  memset(S, 0, sizeof S);
  memset(R, 0, sizeof R);
  st = add_surface_field(it, &surf);
  PA_CALL(pa__agree(dm->comm, st));
  pa__dmesh_layout(dm, &lay);
  for (int k = 0; k < PA_DMESH_NKIND; k++) {
    pa__recs_init(&S[k], k, pa__kind_nv(it->dim, k), pa__layout_kind_ndbl(&lay, k));
    pa__recs_init(&R[k], k, pa__kind_nv(it->dim, k), pa__layout_kind_ndbl(&lay, k));
  }
  /* 1. map the pieces to ranks; 2. the records to ship */
  PA_CALL(map_to_ranks(it));
  PA_CALL(element_records(it, &S[PA_ELEMENT], &dest[PA_ELEMENT]));
  PA_CALL(pair_records_all(it, S, dest));
  /* 3. ship */
  for (int k = 0; k < PA_DMESH_NKIND; k++) {
    it->bytes_moved += bytes_out(&S[k], dest[k], it->rank);
    PA_CALL(pa__recs_migrate(dm->comm, &S[k], dest[k], &R[k]));
    pa__recs_free(&S[k]);
    pa__free(dest[k]);
    dest[k] = NULL;
  }
  /* 4. assemble the local pieces; 5. check their curves */
  st = assemble_local_pieces(it, R);
  PA_CALL(pa__agree(dm->comm, st));
  if (surf) PA_CALL(check_curves(it, R));
cleanup:
  if (surf) {
    pa_status s2 = pa_mesh_remove_field(dm->mesh, dm->mesh->nfield - 1);
    if (!st) st = s2;
  }
  st = pa__agree_end(dm->comm, st);
  for (int k = 0; k < PA_DMESH_NKIND; k++) {
    pa__recs_free(&S[k]);
    pa__recs_free(&R[k]);
    pa__free(dest[k]);
  }
  return st;
}
