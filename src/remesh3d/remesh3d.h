/*
 * remesh3d.h -- padapt's sequential 3D tetrahedral remesher.
 *
 * Entry point: pa__remesh3d() (driver_3d.c), declared with the driver in
 * remesh/remesh.h: same contract as pa_remesher.remesh (the builtin
 * remesher calls it for dim 3). This header is the private working
 * structure shared by the files of src/remesh3d/ and the inline kernels of
 * their inner loops (metric edge length, element quality).
 *
 * Working structure (struct rm3d), structure of arrays, 32-bit indices:
 *  - tetrahedra: tv[4k..4k+3] positively oriented; adj[4k+i] = 4*l+j when
 *    face i of k (opposite its vertex i) is face j of l, -1 on the domain
 *    boundary; q[k] the cached quality; tflag[k] internal bits (RM3D_T_*: bits
 *    0..3 say that face i is a boundary triangle), tpf[k] the caller's
 *    PA_FLAG_* byte, tref[k] the reference;
 *  - vertices: x[3i..], met[mc*i..] (mc = 1 size or 6 tensor), vref, vpf (the
 *    caller's PA_FLAG_* byte), vtag (internal RM3D_V_* bits), vtet[i] one live
 *    tetrahedron holding i;
 *  - boundary triangles and feature edges: keyed tables (rm3d_table) holding
 *    each entity's own vertex order, reference and flags; the tetrahedron
 *    faces that are boundary triangles carry the face bit in tflag.
 * Dead tetrahedra/vertices keep their slots (RM3D_T_DEAD / RM3D_V_DEAD) until a
 * compaction; nothing points at a dead slot.
 */
#ifndef PA_REMESH3D_H
#define PA_REMESH3D_H

#include "metric/metric.h"
#include "metric/metric3d.h"
#include "remesh/remesh.h"

#include <math.h>

/* ---- private working structure ----------------------------------------- */

enum {
  RM3D_T_FACES = 0x0f,  /* face i is a boundary triangle (bit i) */
  RM3D_T_FROZEN = 0x10, /* caller's PA_FLAG_REQUIRED: never touched */
  RM3D_T_DEAD = 0x20,
  RM3D_T_MARK = 0x40, /* transient visit mark (always cleared after use) */
  /* Clean: its six edges were in [PA_METRIC_LEN_LO_EXACT,
   * PA_METRIC_LEN_HI_EXACT] when last measured and neither its vertices nor
   * their positions or metrics changed since. The split and collapse passes at
   * the final thresholds skip it: on a mostly adapted mesh they measured every
   * tet again for nothing. Every change of a tet clears it (where its cached
   * quality q is set). */
  RM3D_T_CLEAN = 0x80
};

enum {
  RM3D_V_BDRY = 1,   /* on a boundary triangle */
  RM3D_V_LOCK = 2,   /* never moved nor removed (frozen entity, corner) */
  RM3D_V_FEAT = 4,   /* on a feature (ridge) edge */
  RM3D_V_CORNER = 8, /* corner: never moved nor removed */
  RM3D_V_DEAD = 16,
  RM3D_V_MARK = 32, /* transient */
  RM3D_V_CURVED = 64, /* on a curved surface patch (has a normal) */
  RM3D_V_TODO = 128   /* pass scratch: vertex to visit / not tried yet */
};

/* Boundary triangles (nk = 3) or feature edges (nk = 2): records in an array
 * (kept in creation order, dead ones flagged) with an open-addressing hash
 * on the sorted vertex tuple. */
typedef struct rm3d_table {
  int nk;
  pa_idx n;     /* records used (live + dead) */
  size_t cap;
  pa_idx *v;    /* nk * cap, the entity's own vertex order */
  int32_t *ref;
  uint8_t *flag; /* PA_FLAG_* of the entity, RM3D_REC_* */
  pa_idx *slot;  /* hash slots: record index, -1 empty, -2 deleted */
  size_t nslot;  /* power of two */
  size_t nfull;  /* slots not empty (live + deleted) */
} rm3d_table;
#define RM3D_REC_DEAD 0x80
/* A face between two element references that the input did not list:
 * remeshed as a surface like a listed interface (so every reference keeps
 * its volume and the operators may work on both sides of it), never written
 * back (the caller's mesh did not hold it); so are the feature edges of
 * such faces only (boundary_3d.c). */
#define RM3D_REC_UNLISTED 0x40

typedef struct rm3d {
  int mc; /* metric components: 1 (size) or 6 (tensor) */
  pa_idx nv, ne;
  size_t capv, cape;
  double *x;
  double *met;  /* working metric (relaxed at frozen skins, see met0) */
  double *met0; /* mc * capv or NULL: the target metric, written back, when
                   the working one was relaxed at frozen vertices */
  int32_t *vref;
  uint8_t *vpf, *vtag;
  pa_idx *vtet;
  pa_idx *tv, *adj;
  float *q;
  uint8_t *tflag, *tpf;
  int32_t *tref;
  double *nrm; /* 3 * capv: unit normal of curved surface vertices */
  /* 3 * capv (with nrm): a curved-patch vertex's offset to the point of
   * its curve, where its split put it closer to the chord (0 when on it);
   * the curve snaps (pa__rm3d_curve_snap_vertex) take it on */
  double *vcur;
  /* capv or NULL (no model): 1 for a boundary vertex off the model, left
   * on the reconstruction because the model's point of its split was
   * refused; the snap moves (pa__rm3d_snap_vertex) retry it */
  uint8_t *voff;
  int nfield;
  int fcomp[PA_MESH_MAX_FIELDS];
  uint8_t fmetric[PA_MESH_MAX_FIELDS]; /* field holds a metric (metric.h) */
  double *fval[PA_MESH_MAX_FIELDS];
  rm3d_table tri, edg;
  /* options */
  int surf;  /* remesh the boundary surface */
  int swap;  /* swaps allowed (not -noswap) */
  /* A lattice crowd was found before the last refinement band (see
   * driver_3d.c): the split passes at sqrt 2 spread their splits, as
   * RM3D_SPREAD_TIGHT or RM3D_SPREAD_WIDE says (0: they do not). */
  int spread;
  double hausd, ridge_cos;
  int verbosity;
  const pa_remesh_opts *opts; /* the caller's (local parameters) */
  /* During a swap pass (else NULL): bit e of swapfail[t], t < nswapfail,
   * says that the removal of local edge e of t failed in this pass on a
   * closed shell none of whose tets changed since (pa__rm3d_swap_edge). */
  uint8_t *swapfail;
  pa_idx nswapfail;
  /* The quality no operator goes below (rm3d_q_min): RM3D_QABS, or less
   * when the input's worst free tet is already poorer (set by build). */
  double qabs;
  /* counters */
  long nsplit, ncollapse, nswap, nmove;
  pa_idx ndead_t, ndead_v;
} rm3d;

/* Local edges of a tetrahedron and, for an ordered pair (i,j) of local
 * vertices, the other two (k,l) such that (i,j,k,l) is an even permutation:
 * then (v_i, v_j, v_k, v_l) is positively oriented. */
extern const int pa__rm3d_edge[6][2];
extern const int pa__rm3d_compl[4][4][2];
/* Face i as in mesh.h: local vertices in outward order. */
extern const int pa__rm3d_face[4][3];

#define RM3D_LRELAX 1.2 /* mean frozen edge length at a relaxed vertex */
/* The two ways the split passes at sqrt 2 spread their splits (m->spread).
 * Tight: an edge shorter than RM3D_LSPREAD (halves under 0.8) waits for
 * the next pass when one of its ends is an end or a ring vertex of a split
 * of this pass (the crowd is the last class split: every split's
 * neighbourhood is left alone). Wide: an edge shorter than
 * RM3D_LSPREAD_WIDE (halves under 1) waits when splits of this pass touched
 * both its ends (longer classes are still split with it: each pass refines
 * the lattice by a share of its vertices, and the moves of the rounds relax
 * it in between). */
enum { RM3D_SPREAD_TIGHT = 1, RM3D_SPREAD_WIDE = 2 };
#define RM3D_LSPREAD 1.6
#define RM3D_LSPREAD_WIDE 2.0
#define RM3D_QFLOOR 1e-3 /* operators create no worse element... */
#define RM3D_QABS 1e-9   /* ...unless replacing worse ones, and never this */
/* ...nor this share of the input's worst free tet, when that is poorer than
 * RM3D_QABS (m->qabs). A strongly anisotropic metric measures valid,
 * well-shaped tets of a mesh not aligned with it far below RM3D_QABS (box3d
 * 6 in sizes 10, 10, 1e-4: 2.6e-10, a size ratio r = 1e5 lowers the metric
 * quality of a Euclidean-regular tet to about r^-2); the operators must work
 * there, and 1e-3 of the input's worst keeps the tets they make about as far
 * from flat as the input's in Euclidean terms. */
#define RM3D_QABS_INPUT 1e-3
/* Least cosine between a boundary triangle's normal before and after an
 * operation (about 11 degrees): a collapse's renamed triangles, a boundary
 * swap's new ones against the old pair's mean, a split's halves, a move's
 * triangles. The tets of a ball or shell may all stay valid while a
 * triangle stands up across a curved patch whose vertices are nearly
 * aligned: a fold, whose slivers no later operation removes. */
#define RM3D_NORMAL_COS 0.98
/* The same bound for a split whose point is the model's
 * (pa_remesh_opts.geometry; about 60 degrees): the halves then turn by the
 * true surface's curvature over the edge (a chord of a quarter circle
 * turns them by about 20 degrees), not by a reconstruction's error, and
 * the tets' quality still refuses an inverted one. */
#define RM3D_NORMAL_COS_MODEL 0.5

/* The Hausdorff distance bounding surface triangle record r: its
 * reference's local parameter (pa_local_param) or m->hausd. */
static inline double rm3d_tri_hausd(const rm3d *m, pa_idx r) {
  return m->opts && m->opts->nlocal > 0
             ? pa__local_hausd(m->opts, m->tri.ref[r], m->hausd)
             : m->hausd;
}

/* The lowest quality an operator may create where the worst element it
 * replaces had quality qref, and whether q is acceptable there. */
static inline double rm3d_q_min(const rm3d *m, double qref) {
  return fmax(m->qabs, fmin(RM3D_QFLOOR, 0.5 * qref));
}
static inline int rm3d_q_ok(const rm3d *m, double q, double qref) {
  return q >= rm3d_q_min(m, qref);
}
/* A length move may lower the ball's worst quality down to this (never
 * below the old worst if that is lower): the lengths are the target, a
 * quality of 0.5 is a good tet. */
#define RM3D_QLEN 0.5
/* A length move that leaves as many edges out of range must cut their sum
 * of ln^2 L by 3 %. */
#define RM3D_LGAIN 0.97
#define RM3D_LNB 128 /* neighbours of a vertex a length move handles */
#define RM3D_MAXSHELL 64
#define RM3D_MAXBALL 512

/* Local index of vertex x in tet vertices v, -1 if absent. */
static inline int rm3d_loc(const pa_idx *v, pa_idx x) {
  return v[0] == x ? 0 : v[1] == x ? 1 : v[2] == x ? 2 : v[3] == x ? 3 : -1;
}

/* Lengths and qualities are metric/metric3d.h's kernels: the statistics
 * measure with the same lengths, and the band the passes aim at is
 * PA_METRIC_LEN_LO_EXACT..PA_METRIC_LEN_HI_EXACT. */
static inline double rm3d_len(const rm3d *m, pa_idx a, pa_idx b) {
  return pa__len3(m->mc, m->x + 3 * (size_t)a, m->x + 3 * (size_t)b,
                  m->met + (size_t)m->mc * a, m->met + (size_t)m->mc * b);
}

/* (b - a) x (c - a): the normal of triangle abc, twice its area long. */
static inline void rm3d_tri_cross(const double *a, const double *b,
                                  const double *c, double *n) {
  double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
  double w[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
  n[0] = u[1] * w[2] - u[2] * w[1];
  n[1] = u[2] * w[0] - u[0] * w[2];
  n[2] = u[0] * w[1] - u[1] * w[0];
}

/* Scale n to unit length (left as is if zero); returns its old length. */
static inline double rm3d_unit(double *n) {
  double s = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
  if (s > 0)
    for (int i = 0; i < 3; i++) n[i] /= s;
  return s;
}

/* Unit normal of triangle abc; returns twice its area (0: degenerate). */
static inline double rm3d_tri_normal(const double *a, const double *b,
                                     const double *c, double *n) {
  rm3d_tri_cross(a, b, c, n);
  return rm3d_unit(n);
}

/* Quality of tet t with its local vertex ip moved to x, with metric met
 * (the operators' trial of a move, a collapse or a midpoint). With sizes
 * the quality is Euclidean (pa__qual3) and the metrics are not gathered. */
static inline double rm3d_qual_moved(const rm3d *m, pa_idx t, int ip,
                                     const double *x, const double *met) {
  const pa_idx *v = m->tv + 4 * (size_t)t;
  const double *px[4], *pm[4];
  for (int j = 0; j < 4; j++) px[j] = m->x + 3 * (size_t)v[j];
  px[ip] = x;
  if (m->mc <= 1) return pa__qual3_iso(px[0], px[1], px[2], px[3]);
  for (int j = 0; j < 4; j++) pm[j] = m->met + (size_t)m->mc * v[j];
  pm[ip] = met;
  return pa__qual3(m->mc, px[0], px[1], px[2], px[3], pm[0], pm[1], pm[2],
                   pm[3]);
}

/* Quality of the tetrahedron with vertices v[0..3]. */
static inline double rm3d_qual_v(const rm3d *m, const pa_idx *v) {
  const double *x = m->x, *mt = m->met;
  int mc = m->mc;
  if (mc <= 1)
    return pa__qual3_iso(x + 3 * (size_t)v[0], x + 3 * (size_t)v[1],
                         x + 3 * (size_t)v[2], x + 3 * (size_t)v[3]);
  return pa__qual3(mc, x + 3 * (size_t)v[0], x + 3 * (size_t)v[1],
                   x + 3 * (size_t)v[2], x + 3 * (size_t)v[3],
                   mt + (size_t)mc * v[0], mt + (size_t)mc * v[1],
                   mt + (size_t)mc * v[2], mt + (size_t)mc * v[3]);
}

/* ---- mesh_3d.c: structure, tables, build, write back, check --------- */

pa_status pa__rm3d_build(rm3d *m, pa_mesh *mesh, const pa_remesh_opts *opts);
/* Relax the working metric at frozen vertices whose frozen edges are on
 * average far from unit length (target kept in met0); *nrelaxed vertices. */
pa_status pa__rm3d_skin_relax(rm3d *m, pa_idx *nrelaxed);
/* met0[dst] = log-mean of met0[a] and met0[b] (no-op without met0). */
void pa__rm3d_met0_mid(rm3d *m, pa_idx dst, pa_idx a, pa_idx b);
void pa__rm3d_free(rm3d *m);
/* Make room for nv vertices and ne tetrahedra in total. */
pa_status pa__rm3d_reserve(rm3d *m, size_t nv, size_t ne);
/* Append a vertex (coordinates, metric given; fields zeroed). */
pa_status pa__rm3d_new_vertex(rm3d *m, const double *x, const double *met,
                              pa_idx *index);
/* Renumber vertices along a Morton curve and tets by their first vertex,
 * for memory locality (compacts first). */
pa_status pa__rm3d_reorder(rm3d *m);
/* Drop dead slots, renumbering tetrahedra and vertices in order; the quality
 * cache is rebuilt when keep_q, freed otherwise. */
pa_status pa__rm3d_compact(rm3d *m, int keep_q);
/* Write the working mesh back into `mesh` (replacing its content only when
 * everything succeeded). */
pa_status pa__rm3d_write(rm3d *m, pa_mesh *mesh);
/* Check adjacency symmetry, orientation, vtet, face tags. PA_ERR_INTERNAL
 * naming the first violation. */
pa_status pa__rm3d_check(rm3d *m);

pa_idx pa__rm3d_table_find(const rm3d_table *t, const pa_idx *v);
pa_status pa__rm3d_table_add(rm3d_table *t, const pa_idx *v, int32_t ref,
                             uint8_t flag, pa_idx *index);
void pa__rm3d_table_remove(rm3d_table *t, pa_idx i);

/* ---- operators --------------------------------------------------------- */

/* Shell of the edge (a,b) of tet k: tets[0..n) in rotation order and ring
 * vertices such that tets[i] = (a, b, ring[i], ring[i+1]) is positive
 * (ring[n] = ring[0] when closed); unless NULL, edge[i] the local index
 * (pa__rm3d_edge) of ab in tets[i]. Returns n, or -1 when longer than max.
 * *info: bit 0 closed, bit 1 a face containing ab is a boundary triangle,
 * bit 2 a frozen tet, bit 3 tets of different references. */
enum {
  RM3D_SH_CLOSED = 1,
  RM3D_SH_BDRY = 2,
  RM3D_SH_FROZEN = 4,
  RM3D_SH_REFS = 8
};
int pa__rm3d_shell(const rm3d *m, pa_idx k, pa_idx a, pa_idx b, pa_idx *tets,
                   pa_idx *ring, signed char *edge, int max, int *info);
/* Ball of vertex p (from vtet[p]): entries 4*t + local index of p. Returns
 * the count, or -1 when larger than max. */
int pa__rm3d_ball(rm3d *m, pa_idx p, pa_idx *ball, int max);
/* Every vertex's ball at once, for the move passes, which change no tet's
 * vertices and would otherwise walk a ball per vertex they try:
 * ent[start[p]..start[p+1]) holds 4*t + the local index of p for each live
 * tet t holding p, in the order of t. Valid until a tet changes its
 * vertices (a split, collapse or swap). */
typedef struct rm3d_balls {
  pa_idx *start, *ent; /* NULL: not built */
} rm3d_balls;
pa_status pa__rm3d_balls_build(const rm3d *m, rm3d_balls *b);
void pa__rm3d_balls_free(rm3d_balls *b);
/* The ball of p in *ball; its count, -1 if larger than RM3D_MAXBALL or
 * empty (a dead vertex), as pa__rm3d_ball counts. */
static inline int rm3d_balls_get(const rm3d_balls *b, pa_idx p,
                                 const pa_idx **ball) {
  pa_idx s = b->start[p], n = b->start[p + 1] - s;
  *ball = b->ent + s;
  return n > 0 && n <= RM3D_MAXBALL ? (int)n : -1;
}

/* Split the edge (a,b) of tet k at its midpoint if allowed and acceptable.
 * *done = 1 when split. */
pa_status pa__rm3d_split_edge(rm3d *m, pa_idx k, pa_idx a, pa_idx b,
                              int *done);
/* Collapse the edge (p,q): p removed, q kept, p's ball given (ball[0..n),
 * as pa__rm3d_ball gives it). *done = 1 when collapsed. */
pa_status pa__rm3d_collapse_ball(rm3d *m, pa_idx p, pa_idx q,
                                 const pa_idx *ball, int n, double lguard,
                                 int *done);
/* Contract the edge (p,q) to its midpoint: q moves there (only where it
 * stays on its entity: interior, plane, straight ridge), then p collapses
 * onto it with every check of pa__rm3d_collapse_ball; q moves back
 * otherwise.
 * The balls of p and q are given (bp[0..np), bq[0..nb), as pa__rm3d_ball
 * gives them; a count of -1, a ball too large, refuses). */
pa_status pa__rm3d_collapse_mid(rm3d *m, pa_idx p, pa_idx q,
                                const pa_idx *bp, int np, const pa_idx *bq,
                                int nb, double lguard, int *done);
/* May p move onto q at all: p free, and a boundary p only onto a boundary
 * q in surface mode. */
static inline int rm3d_collapse_allowed(const rm3d *m, pa_idx p, pa_idx q) {
  uint8_t tp = m->vtag[p];
  if (tp & (RM3D_V_LOCK | RM3D_V_CORNER | RM3D_V_DEAD)) return 0;
  return !(tp & RM3D_V_BDRY) || (m->surf && (m->vtag[q] & RM3D_V_BDRY));
}
/* Replace tets old[0..nold) by nnew tets (vertex quadruples, positive),
 * matching faces to rebuild adjacency; new tets take reference ref and PA
 * flags pf. Face tags follow the cavity's outer faces. nbswap > 0 for a
 * boundary swap: that many old domain-boundary faces disappear and as many
 * unmatched new faces become boundary faces (the caller updates the
 * triangle table). */
pa_status pa__rm3d_replace(rm3d *m, const pa_idx *old, int nold,
                           const pa_idx *nv4, int nnew, int32_t ref,
                           uint8_t pf, int nbswap);
/* Try to improve the worst quality around edge (a,b) of tet k by edge
 * removal (best triangulation of the ring, closed shells of 3..7 tets) or,
 * for a boundary edge in surface mode (open shell of 2..7 tets), by the
 * boundary swap of its two surface triangles. Accept if the new worst
 * quality exceeds gain * the old one. gain < 1 removes a short interior
 * edge: the new worst may drop to gain * the old one (never under the
 * rm3d_q_ok floor), and no new edge may be longer than sqrt 2. */
pa_status pa__rm3d_swap_edge(rm3d *m, pa_idx k, pa_idx a, pa_idx b,
                             double gain, int *done);
/* 2-3 swap of face f of tet k. */
pa_status pa__rm3d_swap_face(rm3d *m, pa_idx k, int f, double gain,
                             int *done);
/* How the boundary vertex p (ball[0..n)) may move and keep the surface
 * exactly: 2 in the plane of its coplanar triangles (dir = unit normal), 1
 * along a straight ridge (two collinear feature edges; dir = unit tangent),
 * 0 not at all (curved patch, corner, required ridge, -nosurf). */
int pa__rm3d_bdry_freedom(rm3d *m, pa_idx p, const pa_idx *ball, int n,
                          double *dir);
/* The metric at the midpoint of edge ab (geometric mean of the sizes, or
 * the interpolated tensor), as the split uses it (split_3d.c). */
void pa__rm3d_mid_metric(const rm3d *m, pa_idx a, pa_idx b, double *mp);
/* Relocate vertex p (its ball[0..n) as pa__rm3d_ball gives it, in any
 * order; n = -1, a ball too large, refuses) to bring the lengths of its
 * edges into range: a Gauss-Newton step on sum ln^2 L_i over its edges,
 * halved up to three times, kept when fewer of its edges are out of range
 * (or as many, with the sum down by RM3D_LGAIN) and the ball's worst
 * quality stays at least min(its old worst, RM3D_QLEN). n when moved, 0
 * otherwise. */
int pa__rm3d_length_vertex(rm3d *m, pa_idx p, const pa_idx *ball, int n);
/* Relocate vertex p (its ball[0..n), as above) to raise the worst quality
 * of its ball. 1 when moved. */
int pa__rm3d_smooth_vertex(rm3d *m, pa_idx p, const pa_idx *ball, int n);
/* Move the free interior vertex p by delta (metric length) in a direction
 * drawn from the bits of its coordinates, if no tet of its ball falls under
 * half the ball's worst quality (nor under RM3D_QFLOOR). 1 when moved. */
int pa__rm3d_jiggle_vertex(rm3d *m, pa_idx p, double delta, pa_idx *ball);

/* Feature edges, corners and normals of the boundary surface
 * (boundary_3d.c); use_angle = 0 for -nr. */
pa_status pa__rm3d_surface_analyze(rm3d *m, int use_angle);

/* Passes (driver_3d.c). Split edges longer than thr; collapse edges
 * shorter than thr creating no edge longer than guard; swap around tets of
 * quality < qthr (new worst > gain * old); smooth the vertices of tets of
 * quality < qthr. */
pa_status pa__rm3d_split_pass(rm3d *m, double thr, long *count);
pa_status pa__rm3d_collapse_pass(rm3d *m, double thr, double guard,
                                 long *count);
pa_status pa__rm3d_swap_pass(rm3d *m, double qthr, double gain, long *count);
/* The move passes take the balls b of every vertex (rm3d_balls), built by
 * the first that finds them unbuilt: a smoothing pass and the length
 * pass after it share them. The caller frees them. */
pa_status pa__rm3d_smooth_pass(rm3d *m, double qthr, rm3d_balls *b,
                               long *count);
pa_status pa__rm3d_length_pass(rm3d *m, int sweeps, rm3d_balls *b,
                               long *count);

/* Interpolation of a new vertex's metric and fields as a weighted mean of
 * vertices src[0..n) (pa__metric_interp for the metric). */
void pa__rm3d_interp(rm3d *m, pa_idx dst, int n, const pa_idx *src,
                     const double *w);

/* ---- model_3d.c: onto the model (pa_remesh_opts.geometry) ------------- */

/* Put x, a new position of boundary vertex p (its ball[0..n)), on p's
 * entity (the curve of its feature edges, else the surface of its boundary
 * triangles): pa__remesh_project's 1 (x on the model), 0 (no model, or p
 * is no boundary vertex: x untouched) or -1 (the kernel failed: refuse the
 * move). */
int pa__rm3d_project_vertex(const rm3d *m, pa_idx p, const pa_idx *ball,
                            int n, double *x);
/* Move the boundary vertex p, off the model (voff), onto it when its ball
 * stays valid (no tet under rm3d_q_min of its old quality), else part of
 * the way (smooth_3d.c). 1 when moved. */
int pa__rm3d_snap_vertex(rm3d *m, pa_idx p, pa_idx *ball);
/* Move the curved-patch vertex p by its offset vcur[p] (or half or a
 * quarter of it, keeping the rest) when its ball stays valid (no tet under
 * rm3d_q_min of its old quality) and its boundary triangles keep their
 * normal or follow the surface's (pa__rm3d_turn_ok) (smooth_3d.c). 1 when
 * moved. */
int pa__rm3d_curve_snap_vertex(rm3d *m, pa_idx p, pa_idx *ball);
/* 1 if the boundary triangle of vertices v and unit normal n1, which had
 * the normal n0, stays within RM3D_NORMAL_COS of n0 or of the surface's
 * normal at its vertices (the sum of their normals; all on a curved
 * patch): a vertex moved onto the curve turns its coarse triangles away
 * from their flat selves towards the surface, a fold turns them away from
 * both (boundary_3d.c). */
int pa__rm3d_turn_ok(const rm3d *m, const pa_idx *v, const double *n0,
                     const double *n1);
/* Mark (voff) the free boundary vertices of the input that lie off their
 * entity by more than PA_GEOM_SNAP_TOL of the model's size: those the
 * snap moves of an earlier remesh could not place (a piece's frozen skin
 * was in the way). */
void pa__rm3d_mark_off_model(rm3d *m);
/* The same for the point x of a split of the boundary edge (a,b): on the
 * curve of its feature edge erec (>= 0), else on the surface of its
 * boundary triangle trec[0] (ntri > 0). */
int pa__rm3d_project_split(const rm3d *m, pa_idx erec, const pa_idx *trec,
                           int ntri, pa_idx a, pa_idx b, double *x);

#endif /* PA_REMESH3D_H */
