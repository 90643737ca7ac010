/*
 * piece.h -- private header of the parallel adaptation (pa_dmesh_adapt):
 * the state of one iteration of the piece algorithm, its marks and labels,
 * and the steps that share it.
 *
 *   tag.c         step 1: tag owned elements, estimate their remeshing work
 *   pieces.c      step 2: partition the tagged elements into pieces, grow the
 *                 labels into a skin, mark skin, hot and inner vertices
 *   extract.c     step 3: map pieces to ranks, ship their fragments, build
 *                 one sequential mesh per piece
 *   bisect.c      (in step 3) refine the skins pieces share, identically on
 *                 both sides (remesh/leb.c)
 *   reintegrate.c steps 4-5: remesh the local pieces, check the outputs,
 *                 rebuild the distributed mesh with the new entities
 *   grade.c       metric gradation of the whole mesh, before the loop
 *   adapt.c       the loop, options, report, the final rebalance
 *   piece.c       the release of an iteration's and a piece's arrays
 *   checkpoint.c  checkpoints of the loop and the resume from one
 *
 * Invariants of an iteration (see docs/design/ADAPT.md for the argument):
 *  - label[e] (owned elements) is a piece in [0, npieces) or -1; every
 *    tagged element is labelled; pieces are disjoint;
 *    user-required elements are never labelled;
 *  - a piece's skin is the set of faces it shares with elements of another
 *    label or of none; every vertex and edge a piece shares with the outside
 *    lies on it. The skin is frozen while the piece is remeshed, after
 *    bisect.c refined, in every piece, the skin faces whose vertices only
 *    pieces touch: that refinement depends only on the face (its vertices'
 *    coordinates, metric, marks and normals, shipped bit for bit), so both
 *    sides of an interface agree and a piece remeshed with its skin
 *    untouched fits back exactly;
 *  - an element stays (same global id, same values) when it is unlabelled;
 *    all labelled elements are replaced by the output of their piece (a
 *    failed piece gives its input back, with its refined skin);
 *  - every vertex, boundary entity and edge is given to the rebuild exactly
 *    once: by its old owner if it lies in a staying element or on the skin
 *    between two pieces, a vertex bisect.c added by the piece with the
 *    smallest id among those sharing it, otherwise by the rank that
 *    remeshed its piece.
 */
#ifndef PA_ADAPT_PIECE_H
#define PA_ADAPT_PIECE_H

#include "dmesh/dmesh.h"
#include "metric/metric.h"

/* Flag bits of vertex records in transit: the vertex lies on the piece's
 * skin; it touches a tagged element of another piece (hot). */
#define PA_ADAPT_SKIN_TRANSIT 0x80
#define PA_ADAPT_HOT_TRANSIT 0x40
/* ... skin edges may be refined there (inner, see pieces.c); only pieces
 * around, but not inner: skin edges towards an inner vertex may be refined;
 * both: labelled, on a smooth curved boundary (pieces.c) */
#define PA_ADAPT_INNER_TRANSIT 0x20
#define PA_ADAPT_LABELLED_TRANSIT 0x10
#define PA_ADAPT_SURFACE_TRANSIT (PA_ADAPT_INNER_TRANSIT | PA_ADAPT_LABELLED_TRANSIT)
/* The temporary vertex field that carries, in 3D, the normal of each
 * vertex on a smooth curved boundary and the Bloom mask of its boundary
 * neighbours (pieces.c) to the pieces (extract.c), removed before the
 * remesher sees them (bisect.c). */
#define PA_ADAPT_SURFACE_FIELD "pa.adapt.surface"
/* Bits of that mask: a double holds an integer below 2^53 exactly. The
 * next bit marks a vertex on a feature edge or a required boundary entity
 * (whose boundary edges stay whole). */
#define PA_ADAPT_BLOOM_BITS 52
#define PA_ADAPT_HARD_BIT ((uint64_t)1 << PA_ADAPT_BLOOM_BITS)
/* Temporary ids of the vertices bisect.c adds to a piece (above every
 * global id; exact as a double) */
#define PA_ADAPT_TEMP_GID ((pa_gid)1 << 52)
/* bisect.c: skin edges are bisected while longer than PA_ADAPT_LEB_SKIN,
 * edges inside the piece while longer than PA_ADAPT_LEB_INNER (in the
 * metric). 1.5, not sqrt 2: bisecting a skin face's edge of 1.47 cuts the
 * obtuse faces of a bisected Kuhn cube with a median half the shortest edge
 * (0.52), frozen until another iteration tags its elements again
 * (docs/BENCHMARKS.md, "The parallel loop", has the measurement). */
#define PA_ADAPT_LEB_SKIN 1.5
#define PA_ADAPT_LEB_INNER 2.0
/* ... and, for the built-in 2D remesher, while longer than this, only in
 * the input elements with a vertex on the skin. Its refinement takes all
 * the elements of a piece to the size in about as many passes as the
 * sequential one: the elements on the piece's boundary, which bisection
 * leaves alone, set the count. Elsewhere bisection only puts elements
 * ahead, to sit at full size through those passes (plate2d.mesh -hsiz
 * 0.0005 at 2 ranks, every element bisected: 40.6 M element visits of the
 * refinement rounds against 31.0 M sequentially; near the skin only: 34.3
 * M, 4 % less remesher CPU time). Near the skin it keeps the fans of
 * needles a skin refined to 1.5 makes on the input vertex across short
 * (at 95, none bisected: 20 % more remesher CPU time, the fans' remains
 * slowing the optimisation). */
#define PA_ADAPT_LEB_INNER_2D 24.0
/* No label (pieces.c, extract.c). */
#define PA_ADAPT_NOLABEL 2147483647
/* Values of the "done" element value (tag.c gives the criteria each is
 * tagged again with): 0 never remeshed; 1 remeshed; 2 remeshed near a hot
 * skin vertex; 3 with two vertices or more on a hot skin (the remesher was
 * constrained there); 4 remeshed by an iteration with a single piece, away
 * from its skin: what the sequential remesher makes with its whole
 * neighbourhood free. */
#define PA_ADAPT_DONE 1
#define PA_ADAPT_DONE_NEAR_SKIN 2
#define PA_ADAPT_DONE_ON_SKIN 3
#define PA_ADAPT_DONE_FREE 4
/* The values above sit in the low bits of the done value (PA_ADAPT_DONE_KIND);
 * the high bit PA_ADAPT_DONE_PASSED marks an element that passed the last tag
 * and has not changed since: the tag skips it. Only the remesh of a piece
 * changes an element (the skin edges bisect.c refines lie in no staying
 * element), and reintegrate.c gives every element of a piece a fresh value,
 * without the bit. */
#define PA_ADAPT_DONE_KIND 0x7f
#define PA_ADAPT_DONE_PASSED 0x80
/* Name of the element value marking elements produced in this run. */
#define PA_ADAPT_DONE_VALUE "pa.adapt.done"
/* Bits of it->bside (pieces.c). A boundary entity with both lies inside
 * the domain on the outer surface of a piece: the piece gets it frozen
 * (extract.c), since the element on its other side stays or goes to
 * another piece, and its vertices are not inner (no bisection of its
 * edges). */
#define PA_ADAPT_B_INTERIOR 1
#define PA_ADAPT_B_CUT 2
/* Reference of the artificial boundary entities of a piece's outer surface. */
#define PA_ADAPT_SKIN_REF (-2000000001)
/* Estimated bytes of remesher memory per unit of work (one output element). */
#define PA_ADAPT_BYTES_PER_WORK 1000.0

/* The bit of vertex global id g in a Bloom mask (a mix of its bits, so
 * that neighbours' consecutive ids spread). */
static inline uint64_t pa__adapt_bloom_bit(pa_gid g) {
  uint64_t x = (uint64_t)g + 0x9e3779b97f4a7c15u;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9u;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebu;
  x ^= x >> 31;
  return (uint64_t)1 << (x % PA_ADAPT_BLOOM_BITS);
}

/* 1 if pieces and the result are checked (opts->check_pieces: -1 means
 * with a plug-in remesher only). */
static inline int pa__adapt_checks(const pa_adapt_opts *o) {
  return o->check_pieces > 0 ||
         (o->check_pieces < 0 && o->remesher &&
          o->remesher != pa_remesher_builtin());
}

/* A piece received by this rank and its remeshed output. */
typedef struct pa__piece {
  int id;              /* piece number */
  pa_mesh *in;         /* the piece as extracted (kept for checks; only
                          its vertices once the reintegration has examined
                          the output) */
  pa_mesh *out;        /* remeshed copy, NULL if it failed */
  pa_gid *vgid;        /* in->nv: global id of each input vertex */
  uint8_t *skin;       /* in->nv: vertex on the skin (frozen) */
  uint8_t *hot;        /* in->nv: skin vertex a tagged element of another
                          piece touches */
  int *vrank;          /* in->nv: a rank that sent an element containing it
                          (the smallest) */
  uint8_t *bfix;       /* n0[PA_BOUNDARY]: the input boundary entity lies
                          inside the domain on the piece's outer surface
                          (it->bside), frozen in the piece; its old owner
                          gives it back, not the piece */
  pa_idx nsplit;       /* vertices added on the skin (bisect.c) */
  pa_idx ncurved;      /* of which on a curved boundary, off the chord */
  pa_idx curve_bad;    /* elements those left without a positive volume */
  int unchanged;       /* the built-in remesher changed nothing (its counts
                          are 0) and no skin vertex was added */
  pa_gid *ifgid;       /* in->nv (with skin refinement): global id agreed
                          for each vertex added by bisect.c, else unused */
  uint8_t *ifgive;     /* in->nv: 1 if this piece gives that vertex */
  pa_idx *match;       /* out->nv: input vertex it is (same gid and
                          coordinates), or -1 for a new vertex */
  pa_idx nv0;          /* vertices as gathered (bisect.c appends more) */
  /* per kind, as gathered (bisect.c and the skin faces append more): */
  pa_idx n0[4];        /* entities */
  pa_gid *kgid[4];     /* n0: global id of each (not vertices: vgid) */
  size_t *kpoff[4];    /* n0 + 1 offsets into kpay, or NULL (no values):
                          the bytes of each one's values
                          (pa__entity_payload) */
  unsigned char *kpay[4];
  pa_idx *reuse[4];    /* per output element, boundary entity or edge: the
                          input one it is (same vertices, none added by
                          bisect.c, same reference: it keeps its id and
                          values), or -1; NULL: none is */
  int *dest;           /* out->ne: the rank each output element goes to
                        * (NULL: this rank, all of them) */
  pa_remesh_report rep;
} pa__piece;

/* The state of one iteration. Arrays over owned elements have ne entries. */
typedef struct pa__iter {
  pa_dmesh *dm;
  const pa_adapt_opts *opts;
  int rank, size, dim, nve;
  int iter;            /* 1-based iteration number */
  pa_idx ne;           /* owned elements */
  uint8_t *tag;        /* tagged for remeshing */
  double *work;        /* estimated work of each tagged owned element
                          (pa__elem_work); the others' entries are not set */
  int *label;          /* piece or -1 */
  int npieces;
  double *piece_work;  /* npieces: estimated work */
  int *piece_rank;     /* npieces: destination rank */
  int *piece_failed;   /* npieces: 1 if the piece was rolled back */
  pa_idx *bstart, *belem; /* owned balls of the entities near a piece
                             (pa__adapt_entity_balls), built by pieces.c,
                             reused by extract.c and reintegrate.c */
  int npiece_local;
  pa__piece *pieces;   /* the pieces remeshed by this rank */
  double bytes_moved;  /* record bytes this rank sent to other ranks */
  double imbalance;    /* estimated work: max over ranks / mean */
  uint8_t *vinner;     /* nloc: PA_ADAPT_INNER_TRANSIT (inner vertex),
                          PA_ADAPT_SURFACE_TRANSIT (only pieces around, on a
                          smooth curved boundary), PA_ADAPT_LABELLED_TRANSIT
                          (only pieces around, neither) or 0 */
  double *vsurf;       /* 3D (else NULL), from pieces.c to the extraction
                          (which releases it): nloc x 4, the unit outward
                          normal of the vertices on a smooth curved boundary
                          (0 for the others) and the Bloom mask of every
                          vertex's boundary neighbours */
  int nocurve;         /* the extraction found a split onto a curve that
                          left an element without a positive volume: the
                          pieces were made again without (extract.c) */
  uint8_t *bside;      /* nloc boundary entities: PA_ADAPT_B_INTERIOR (two
                          elements hold it: an interface inside the
                          domain), PA_ADAPT_B_CUT (elements of two labels,
                          or a labelled and an unlabelled one, hold it) */
  int *vlab;           /* 4 x nloc: smallest and largest label of the
                          elements around each local vertex (PA_ADAPT_NOLABEL
                          for unlabelled ones), then of the tagged ones
                          (PA_ADAPT_NOLABEL, -PA_ADAPT_NOLABEL if none) */
  pa_gid ntagged;      /* global */
  double tagwork;      /* global work of the tagged elements */
} pa__iter;

/* Free everything of the iteration (pa__iter_free), only the data of one
 * piece (pa__piece_release: once its records are made, its meshes and
 * arrays are no longer needed; its id and report stay), or only the arrays
 * over the local elements and vertices (pa__iter_release_elements: before
 * the rebuild, which changes the local numbering). */
void pa__iter_free(pa__iter *it);
void pa__piece_release(pa__piece *pc);
void pa__iter_release_elements(pa__iter *it);

/* What the loop carries from one iteration to the next besides the
 * distributed mesh (whose element value PA_ADAPT_DONE_VALUE is part of the
 * state): what a checkpoint holds with the mesh. */
typedef struct pa__loop {
  int iter;            /* iterations done */
  double least;        /* least estimated work of the tagged elements seen at
                          a tag, -1 before the first */
  int nostep;          /* iterations in a row without progress */
  int lastpieces;      /* pieces of the last iteration */
  int lastfailed;      /* 1 if the last iteration rolled a piece back */
  unsigned changed;    /* PA_CHANGED_* bits of the metric preparation */
  double time;         /* seconds spent before this call (a resumed run) */
  pa_adapt_report rep; /* the report so far */
  /* for the progress callback, set by each call (not checkpointed) */
  double t0;           /* when this call started */
  double expected;     /* the metric's estimate of the final element count */
  int tagged;          /* 1 once this call has tagged: the done values'
                          PA_ADAPT_DONE_PASSED bits are this call's */
} pa__loop;

/* Collective: write the checkpoint of the loop after L->iter iterations in
 * opts->checkpoint_dir (created if missing) and remove the older one;
 * elapsed: seconds of the run so far. checkpoint.c. */
pa_status pa__adapt_checkpoint(pa_dmesh *dm, const pa_adapt_opts *opts,
                               const pa__loop *L, double elapsed);
/* Collective: read the latest checkpoint in dir into *dm (created on comm,
 * which must have as many ranks as the run that wrote it) and *L, after
 * checking it against opts (the options that change the result must be the
 * checkpoint's). Errors name the file; *dm is NULL on failure. */
pa_status pa__adapt_restore(MPI_Comm comm, const char *dir,
                            const pa_adapt_opts *opts, pa_dmesh **dm,
                            pa__loop *L);

/* 1 if one of the n vertices v of an entity lies in a labelled element
 * on some rank (it->vlab); only such entities can belong to a piece or
 * touch one. */
static inline int pa__adapt_near_piece(const pa__iter *it, const pa_idx *v,
                                       int n) {
  for (int k = 0; k < n; k++)
    if (it->vlab[4 * (size_t)v[k]] != PA_ADAPT_NOLABEL) return 1;
  return 0;
}

/* it->bstart, it->belem (unless built already): vertex -> owned elements
 * (CSR) for the first vertex of every boundary entity and edge near a
 * piece (pa__adapt_near_piece), the only balls pieces.c, extract.c and
 * reintegrate.c look up; the others are empty. Needs it->vlab. */
pa_status pa__adapt_entity_balls(pa__iter *it);

/* Estimated work of local element e: expected output elements + 1. */
double pa__elem_work(const pa_mesh *m, pa_idx e);

/* Collective: the vertices that keep their metric (required, or on a
 * required element or boundary entity on any rank), agreed by every copy:
 * *frozen (pa__malloc'ed, local vertices) 1 for them (grade.c). */
pa_status pa__adapt_frozen(pa_dmesh *dm, uint8_t **frozen);

/* Collective: grade the metric of the whole distributed mesh (grade.c),
 * the vertices with frozen[v] (pa__adapt_frozen) keeping theirs; *nrounds
 * (may be NULL) receives the rounds (1 when the first changed nothing). */
pa_status pa__adapt_grade(pa_dmesh *dm, const uint8_t *frozen, double hgrad,
                          double hgradreq, int *nrounds);

/* The distributed context of the whole-field metric operations on dm
 * (pa__metric_ctx; dmetric.c): the owned elements as the domain, sums over
 * the ranks, the frozen vertices and local-parameter bounds merged over
 * every copy of a vertex, the gradation pa__adapt_grade. */
void pa__adapt_metric_ctx(pa_dmesh *dm, pa__metric_ctx *c);

/* Step 1. Collective: tag the owned elements (it->tag), count them
 * (it->ntagged, global) and estimate their work (it->work). done: the
 * element value marking elements produced in this run; the elements that
 * pass get its PA_ADAPT_DONE_PASSED bit, and those that have it are skipped
 * unless fresh (the first tag of a call: the bits of a checkpoint are not
 * trusted). */
pa_status pa__adapt_tag(pa__iter *it, pa_dmesh_value *done, int fresh);
/* *missed (all ranks): the tagged elements clearly off (an edge of 2.5 or
 * more, a quality below 0.05; tag.c), or with strict, those the sequential
 * remesher's verdict calls missed (an edge of 2 or more, a quality below
 * 0.05). Collective; after pa__adapt_tag. */
pa_status pa__adapt_count_missed(pa__iter *it, int strict, pa_gid *missed);

/* Step 2. Collective: pieces, labels, vertex label ranges and inner marks
 * (it->vlab, it->vinner). npieces_max is
 * the number of pieces wanted (reduced when the work is small). */
pa_status pa__adapt_pieces(pa__iter *it, int npieces_max);

/* Step 3. Collective: map pieces to ranks, ship their fragments and build
 * the local pieces (it->pieces). */
pa_status pa__adapt_extract(pa__iter *it);

/* Refine the skin faces pc shares with other pieces (bisect.c); inner[v]:
 * 1 the vertex is inner, 2 labelled, 3 on a smooth curved boundary (see
 * pieces.c); edges inside the piece are bisected while longer than
 * inner_lmax (HUGE_VAL: none), with near_skin only in the input elements
 * with a vertex on the skin; surf (3D): 4
 * per input vertex, it->vsurf's, or NULL (no two labelled vertices are
 * then known to make a chord); curves: skin edges may be split onto a
 * curve (else the vertices marked 3 are labelled ones). */
pa_status pa__piece_refine_skin(pa__piece *pc, const uint8_t *inner,
                                double inner_lmax, int near_skin,
                                const double *surf, int curves);

/* Step 4. Local: remesh the local pieces; failures are recorded, not
 * returned (only hard internal errors are). *nfail receives the number of
 * local pieces rolled back, *cpu the CPU seconds spent in the remesher. */
pa_status pa__adapt_remesh(pa__iter *it, int *nfail, double *cpu);

/* Step 5. Collective: rebuild dm from the staying entities and the outputs
 * (or, when little changes, splice in a part rebuilt from the outputs and
 * what touches them: the same result). done: the element value marking
 * produced elements (set to 1 on them). */
pa_status pa__adapt_reintegrate(pa__iter *it, pa_dmesh_value *done);

/* Bytes of the payload of a new entity of a kind and reference: zero for
 * every value but `done`, which gets doneval. buf has room for every
 * value. */
size_t pa__new_payload(const pa_dmesh *dm, int kind, int32_t ref,
                       const pa_dmesh_value *done, uint8_t doneval,
                       unsigned char *buf);

#endif /* PA_ADAPT_PIECE_H */
