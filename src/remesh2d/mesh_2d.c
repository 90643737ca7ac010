/*
 * mesh_2d.c -- the 2D remesher's compact working mesh (struct rm2d,
 * see remesh2d.h): construction from a pa_mesh, slot management with free
 * lists, vertex interpolation, the frozen-skin relaxation of the working
 * metric, locality renumbering, invariant check and the compact write-back.
 *
 * Invariants: see remesh2d.h. In addition, write-back renumbers live entities
 * in slot order, so the output depends only on the sequence of operations (the
 * remesher is deterministic), and it never touches the pa_mesh until every new
 * array has been built: a failure leaves the mesh as it was given.
 */
#include "remesh2d/remesh2d.h"

#include <float.h>

/* ---- growth ---- */

static pa_status grow(void **p, size_t n, size_t sz) {
  void *q = pa__realloc(*p, (n ? n : 1) * sz);
  if (!q)
    return pa__error(PA_ERR_MEMORY, __FILE__, __LINE__,
                     "remesher: out of memory growing an array to %zu entries",
                     n);
  *p = q;
  return PA_SUCCESS;
}

static pa_status grow_vertices(rm2d *rm, size_t need) {
  pa_status st = PA_SUCCESS;
  if (need <= rm->capv) return PA_SUCCESS;
  size_t cap = rm->capv + rm->capv / 2 + 64;
  if (cap < need) cap = need;
  PA_CHECK(cap <= INT32_MAX, PA_ERR_ARG, "remesher: too many vertices (%zu)",
           cap);
  PA_CALL(grow((void **)&rm->x, cap * rm->dim, sizeof(double)));
  PA_CALL(grow((void **)&rm->met, cap * rm->mc, sizeof(double)));
  if (rm->met0) PA_CALL(grow((void **)&rm->met0, cap * rm->mc, sizeof(double)));
  if (rm->vcur) PA_CALL(grow((void **)&rm->vcur, cap * 2, sizeof(double)));
  if (rm->fcomp)
    PA_CALL(grow((void **)&rm->fld, cap * rm->fcomp, sizeof(double)));
  PA_CALL(grow((void **)&rm->vref, cap, sizeof(int32_t)));
  PA_CALL(grow((void **)&rm->vpf, cap, 1));
  PA_CALL(grow((void **)&rm->vtag, cap, 1));
  rm->capv = cap;
cleanup:
  return st;
}

static pa_status grow_elems(rm2d *rm, size_t need) {
  pa_status st = PA_SUCCESS;
  if (need <= rm->cape) return PA_SUCCESS;
  size_t cap = rm->cape + rm->cape / 2 + 64;
  if (cap < need) cap = need;
  PA_CHECK(cap * rm->nvpe <= INT32_MAX, PA_ERR_ARG,
           "remesher: too many elements (%zu)", cap);
  PA_CALL(grow((void **)&rm->tv, cap * rm->nvpe, sizeof(pa_idx)));
  PA_CALL(grow((void **)&rm->adj, cap * rm->nvpe, sizeof(pa_idx)));
  PA_CALL(grow((void **)&rm->q, cap, sizeof(float)));
  PA_CALL(grow((void **)&rm->tref, cap, sizeof(int32_t)));
  PA_CALL(grow((void **)&rm->tflag, cap, 1));
  rm->cape = cap;
cleanup:
  return st;
}

static pa_status grow_feats(rm2d *rm, size_t need) {
  pa_status st = PA_SUCCESS;
  if (need <= rm->capb) return PA_SUCCESS;
  size_t cap = rm->capb + rm->capb / 2 + 64;
  if (cap < need) cap = need;
  PA_CHECK(cap <= INT32_MAX / 4, PA_ERR_ARG,
           "remesher: too many boundary edges (%zu)", cap);
  PA_CALL(grow((void **)&rm->bv, cap * 2, sizeof(pa_idx)));
  PA_CALL(grow((void **)&rm->bside, cap * 2, sizeof(pa_idx)));
  PA_CALL(grow((void **)&rm->btan, cap * 4, sizeof(double)));
  PA_CALL(grow((void **)&rm->bref, cap, sizeof(int32_t)));
  PA_CALL(grow((void **)&rm->btag, cap, 1));
  rm->capb = cap;
cleanup:
  return st;
}

pa_status pa__rm2d_reserve(rm2d *rm, pa_idx nvmore, pa_idx nemore,
                           pa_idx nbmore) {
  pa_status st = PA_SUCCESS;
  PA_CALL(grow_vertices(rm, (size_t)rm->nv + nvmore));
  PA_CALL(grow_elems(rm, (size_t)rm->ne + nemore));
  PA_CALL(grow_feats(rm, (size_t)rm->nb + nbmore));
cleanup:
  return st;
}

/* ---- slots ---- */

pa_status pa__rm2d_new_vertex(rm2d *rm, pa_idx *v) {
  pa_status st = PA_SUCCESS;
  pa_idx i;
  if (rm->vfree >= 0) {
    i = rm->vfree;
    rm->vfree = rm->vref[i];
  } else {
    PA_CALL(grow_vertices(rm, (size_t)rm->nv + 1));
    i = rm->nv++;
  }
  rm->vref[i] = 0;
  rm->vpf[i] = 0;
  rm->vtag[i] = 0;
  if (rm->vcur) rm->vcur[2 * (size_t)i] = rm->vcur[2 * (size_t)i + 1] = 0;
  rm->nvlive++;
  *v = i;
cleanup:
  return st;
}

pa_status pa__rm2d_new_elem(rm2d *rm, pa_idx *k) {
  pa_status st = PA_SUCCESS;
  pa_idx i;
  if (rm->efree >= 0) {
    i = rm->efree;
    rm->efree = rm->tv[(size_t)rm->nvpe * i];
  } else {
    PA_CALL(grow_elems(rm, (size_t)rm->ne + 1));
    i = rm->ne++;
  }
  rm->tflag[i] = 0;
  rm->tref[i] = 0;
  rm->nelive++;
  *k = i;
cleanup:
  return st;
}

pa_status pa__rm2d_new_feat(rm2d *rm, pa_idx *b) {
  pa_status st = PA_SUCCESS;
  pa_idx i;
  if (rm->bfree >= 0) {
    i = rm->bfree;
    rm->bfree = rm->bv[2 * (size_t)i];
  } else {
    PA_CALL(grow_feats(rm, (size_t)rm->nb + 1));
    i = rm->nb++;
  }
  rm->btag[i] = 0;
  rm->bref[i] = 0;
  rm->bside[2 * (size_t)i] = rm->bside[2 * (size_t)i + 1] = -1;
  rm->nblive++;
  *b = i;
cleanup:
  return st;
}

void pa__rm2d_kill_vertex(rm2d *rm, pa_idx v) {
  rm->vtag[v] = RM2D_V_DEAD;
  rm->vref[v] = rm->vfree;
  rm->vfree = v;
  rm->nvlive--;
}

void pa__rm2d_kill_elem(rm2d *rm, pa_idx k) {
  rm->tflag[k] = RM2D_E_DEAD;
  rm->tv[(size_t)rm->nvpe * k] = rm->efree;
  rm->efree = k;
  rm->nelive--;
}

void pa__rm2d_kill_feat(rm2d *rm, pa_idx b) {
  rm->btag[b] = RM2D_B_DEAD;
  rm->bv[2 * (size_t)b] = rm->bfree;
  rm->bfree = b;
  rm->nblive--;
}

/* ---- interpolation ---- */

/* Interpolation of the metric array met (rm->met or rm->met0): the metric
 * kernel's. */
static void interp_metric(const rm2d *rm, double *met, pa_idx v, int n,
                          const pa_idx *src, const double *w) {
  int mc = rm->mc;
  const double *ms[8] = {NULL};
  double out[6];
  for (int i = 0; i < n && i < 8; i++) ms[i] = met + (size_t)mc * src[i];
  pa__metric_interp(rm->dim, mc, n < 8 ? n : 8, ms, w, out);
  memcpy(met + (size_t)mc * v, out, sizeof(double) * mc); /* v may be a src */
}

void pa__rm2d_interp(rm2d *rm, pa_idx v, int n, const pa_idx *src,
                     const double *w) {
  interp_metric(rm, rm->met, v, n, src, w);
  if (rm->met0) interp_metric(rm, rm->met0, v, n, src, w);
  int fc = rm->fcomp, off = 0;
  for (int k = 0; k < rm->nfield; k++) {
    const double *vs[8] = {NULL};
    for (int i = 0; i < n && i < 8; i++)
      vs[i] = rm->fld + (size_t)fc * src[i] + off;
    pa__field_interp(rm->dim, rm->fncomp[k], rm->fmetric[k], n < 8 ? n : 8,
                     vs, w, rm->fld + (size_t)fc * v + off);
    off += rm->fncomp[k];
  }
}

/* ---- construction ---- */

/* Expected number of elements of the adapted mesh (unit elements in the
 * metric), from the input mesh. */
static double expected_elems(pa_mesh *mesh) {
  double sum = 0;
  int d = mesh->dim, nvpe = d + 1, mc = mesh->met_ncomp;
  if (d != 2 || !mc) return mesh->ne;
  for (pa_idx k = 0; k < mesh->ne; k++) {
    const pa_idx *v = mesh->elem + (size_t)nvpe * k;
    const double *a = mesh->coord + 2 * (size_t)v[0];
    const double *b = mesh->coord + 2 * (size_t)v[1];
    const double *c = mesh->coord + 2 * (size_t)v[2];
    double area = 0.5 * ((b[0] - a[0]) * (c[1] - a[1]) -
                         (b[1] - a[1]) * (c[0] - a[0]));
    double t[3] = {0, 0, 0}, ti[3];
    for (int i = 0; i < 3; i++) {
      rm2d_tensor2(mc, mesh->met + (size_t)mc * v[i], ti);
      for (int j = 0; j < 3; j++) t[j] += ti[j] / 3;
    }
    double det = t[0] * t[2] - t[1] * t[1];
    if (det > 0 && area > 0) sum += area * sqrt(det);
  }
  return sum / pa__unit_simplex_volume(2);
}

/*
 * Frozen skins (2D). The edges of frozen elements and frozen feature records
 * cannot change, so where their length in the metric is far from 1 (a piece
 * of the parallel loop whose frozen skin is the coarse input, refined to a
 * much smaller size, or the reverse) the free elements next to them must
 * bridge the difference. Left to the target metric, longest-edge bisection
 * of the triangle on a long frozen edge flattens it towards the quality
 * floor, and the pass loop ping-pongs there without converging.
 *
 * The working metric is therefore relaxed at the skin: a frozen vertex whose
 * frozen edges have a mean length lambda outside [PA_METRIC_LEN_LO,
 * PA_METRIC_LEN_HI] gets its size scaled by f = lambda / PA_METRIC_LEN_HI (or
 * lambda / PA_METRIC_LEN_LO), the least change that puts that mean in range;
 * the size then varies linearly (interpolation) to the target over the first
 * ring of input elements (ParMmg #74: grade the metric away from frozen
 * entities). Relaxing further (to length 1) widens the band of elements left
 * coarser than the target, which the parallel loop must adapt again: its
 * iterations then stop converging (test_adapt_props at 3-4 ranks); relaxing
 * less (to 2) brings the slivers back. The target metric is kept in met0,
 * interpolated alongside, and it is what the write-back returns: frozen
 * vertices come back bit for bit and new vertices carry the target, so a
 * later pass (the next iteration of the parallel loop) sees the elements
 * near the old skin as still to adapt. met0 stays NULL when nothing changed.
 */
pa_status pa__rm2d_skin_relax(rm2d *rm, pa_idx *nrelaxed) {
  pa_status st = PA_SUCCESS;
  int mc = rm->mc;
  double *acc = NULL;
  int32_t *cnt = NULL;
  pa_idx nv = rm->nv;
  int any = 0;
  *nrelaxed = 0;
  for (pa_idx k = 0; k < rm->ne && !any; k++)
    any = rm->tflag[k] & RM2D_E_FROZEN;
  for (pa_idx b = 0; b < rm->nb && !any; b++)
    any = rm->btag[b] & RM2D_B_FROZEN;
  if (!any) return PA_SUCCESS;
  PA_CALLOC(acc, nv);
  PA_CALLOC(cnt, nv);
  /* mean length of the frozen edges at each vertex (edges shared by two
   * frozen elements count twice: a weighting, not a fault) */
  for (pa_idx k = 0; k < rm->ne; k++) {
    if (!(rm->tflag[k] & RM2D_E_FROZEN)) continue;
    const pa_idx *v = rm->tv + 3 * (size_t)k;
    for (int i = 0; i < 3; i++) {
      pa_idx a = v[i], c = v[i == 2 ? 0 : i + 1];
      double l = pa__len2(mc, rm->x + 2 * (size_t)a, rm->x + 2 * (size_t)c,
                          rm->met + (size_t)mc * a, rm->met + (size_t)mc * c);
      acc[a] += l;
      acc[c] += l;
      cnt[a]++;
      cnt[c]++;
    }
  }
  for (pa_idx b = 0; b < rm->nb; b++) {
    if ((rm->btag[b] & RM2D_B_DEAD) || !(rm->btag[b] & RM2D_B_FROZEN)) continue;
    pa_idx a = rm->bv[2 * b], c = rm->bv[2 * b + 1];
    double l = pa__len2(mc, rm->x + 2 * (size_t)a, rm->x + 2 * (size_t)c,
                        rm->met + (size_t)mc * a, rm->met + (size_t)mc * c);
    acc[a] += l;
    acc[c] += l;
    cnt[a]++;
    cnt[c]++;
  }
  const pa__skin_relax r = {PA_METRIC_LEN_LO, PA_METRIC_LEN_HI,
                             PA_METRIC_LEN_HI};
  PA_CALL(pa__remesh_skin_relax(&r, mc, nv, rm->capv, rm->met, &rm->met0, acc,
                                cnt, nrelaxed));
  if (rm->met0)
    for (pa_idx k = 0; k < rm->ne; k++) {
      const pa_idx *v = rm->tv + 3 * (size_t)k;
      rm->q[k] = (float)pa__qual2(
          mc, rm->x + 2 * (size_t)v[0], rm->x + 2 * (size_t)v[1],
          rm->x + 2 * (size_t)v[2], rm->met + (size_t)mc * v[0],
          rm->met + (size_t)mc * v[1], rm->met + (size_t)mc * v[2]);
    }
cleanup:
  pa__free(acc);
  pa__free(cnt);
  return st;
}

/* Face adjacency of the working mesh's elements, by scanning the ball
 * (bstart, ball: CSR) of each face's first vertex; RM2D_NOADJ where no
 * element is on the other side. */
static pa_status build_adjacency(rm2d *rm, const pa_idx *bstart,
                                 const pa_idx *ball) {
  pa_status st = PA_SUCCESS;
  int nvpe = rm->nvpe;
  for (pa_idx k = 0; k < rm->ne; k++) {
    const pa_idx *vk = rm->tv + (size_t)nvpe * k;
    for (int i = 0; i < nvpe; i++) {
      pa_idx face[3];
      int nf = 0;
      for (int j = 0; j < nvpe; j++)
        if (j != i) face[nf++] = vk[j];
      pa_idx nb = RM2D_NOADJ;
      int cnt = 0;
      for (pa_idx s = bstart[face[0]]; s < bstart[face[0] + 1]; s++) {
        pa_idx f = ball[s];
        if (f == k) continue;
        const pa_idx *vf = rm->tv + (size_t)nvpe * f;
        int found = 0, jo = -1;
        for (int j = 0; j < nvpe; j++) {
          int in = 0;
          for (int l = 0; l < nf; l++) in |= vf[j] == face[l];
          if (in) found++;
          else jo = j;
        }
        if (found == nf) {
          nb = (pa_idx)nvpe * f + jo;
          cnt++;
        }
      }
      PA_CHECK(cnt <= 1, PA_ERR_MESH,
               "remesher: a face of element %d is shared by more than two "
               "elements", (int)k + 1);
      rm->adj[(size_t)nvpe * k + i] = nb;
    }
  }
cleanup:
  return st;
}

pa_status pa__rm2d_build(pa_mesh *mesh, const pa_remesh_opts *opts,
                         rm2d **out) {
  pa_status st = PA_SUCCESS;
  rm2d *rm = NULL;
  pa_idx *bstart = NULL, *ball = NULL;
  int d = mesh->dim, nvpe = d + 1;
  *out = NULL;
  PA_CHECK(d == 2, PA_ERR_INTERNAL, "the 2D remesher was given a %dD mesh", d);
  PA_CHECK(mesh->met_ncomp == 1 || mesh->met_ncomp == pa__tensor_ncomp(d),
           PA_ERR_ARG, "remesher: the mesh has no metric");
  PA_CALLOC(rm, 1);
  rm->dim = d;
  rm->nvpe = nvpe;
  rm->mc = mesh->met_ncomp;
  rm->opts = opts;
  rm->hausd = opts->hausd > 0 ? opts->hausd : 0.01;
  rm->lguard = PA_METRIC_LEN_HI;
  rm->lset_hi = PA_METRIC_LEN_HI;
  rm->vfree = rm->efree = rm->bfree = -1;
  rm->nfield = mesh->nfield;
  for (int k = 0; k < mesh->nfield; k++) {
    rm->fncomp[k] = mesh->field[k].ncomp;
    rm->fmetric[k] = (uint8_t)pa__field_is_metric(
        d, mesh->field[k].name, mesh->field[k].ncomp);
    rm->fcomp += mesh->field[k].ncomp;
  }

  /* Reserve for the expected output, so that refinement rarely reallocates. */
  double nexp = expected_elems(mesh) * 1.15 + 64;
  if (nexp > 1.5e9 / nvpe) nexp = 1.5e9 / nvpe;
  size_t cape = (size_t)nexp > (size_t)mesh->ne ? (size_t)nexp : (size_t)mesh->ne;
  size_t capv = cape / (d == 2 ? 2 : 5) + 4 * (size_t)mesh->nb + 64;
  if (capv < (size_t)mesh->nv) capv = (size_t)mesh->nv;
  PA_CALL(grow_vertices(rm, capv));
  PA_CALL(grow_elems(rm, cape));
  PA_CALL(grow_feats(rm, (size_t)mesh->nb * 2 + 64));

  /* vertices */
  pa_idx nv = mesh->nv, ne = mesh->ne;
  memcpy(rm->x, mesh->coord, sizeof(double) * d * nv);
  memcpy(rm->met, mesh->met, sizeof(double) * rm->mc * nv);
  memcpy(rm->vref, mesh->vref, sizeof(int32_t) * nv);
  memcpy(rm->vpf, mesh->vflag, nv);
  for (pa_idx v = 0; v < nv; v++) {
    uint8_t f = mesh->vflag[v];
    rm->vtag[v] = (f & PA_FLAG_REQUIRED ? RM2D_V_FROZEN : 0) |
                  (f & PA_FLAG_CORNER ? RM2D_V_CORNER : 0);
  }
  if (rm->fcomp) {
    int off = 0;
    for (int k = 0; k < mesh->nfield; k++) {
      int nc = mesh->field[k].ncomp;
      for (pa_idx v = 0; v < nv; v++)
        for (int c = 0; c < nc; c++)
          rm->fld[(size_t)rm->fcomp * v + off + c] =
              mesh->field[k].val[(size_t)nc * v + c];
      off += nc;
    }
  }
  rm->nv = rm->nvlive = nv;

  /* elements; vertices of frozen elements are frozen */
  memcpy(rm->tv, mesh->elem, sizeof(pa_idx) * nvpe * ne);
  memcpy(rm->tref, mesh->eref, sizeof(int32_t) * ne);
  for (pa_idx k = 0; k < ne; k++) {
    rm->tflag[k] = mesh->eflag[k] & 0x0F;
    if (mesh->eflag[k] & PA_FLAG_REQUIRED)
      for (int i = 0; i < nvpe; i++)
        rm->vtag[rm->tv[(size_t)nvpe * k + i]] |= RM2D_V_FROZEN;
  }
  rm->ne = rm->nelive = ne;

  /* Vertex balls (CSR), then face adjacency. */
  PA_CALL(pa__balls(rm->tv, ne, nvpe, nv, &bstart, &ball));
  PA_CALL(build_adjacency(rm, bstart, ball));
  *out = rm;
  rm = NULL;
cleanup:
  pa__free(bstart);
  pa__free(ball);
  pa__rm2d_free(rm);
  return st;
}

void pa__rm2d_free(rm2d *rm) {
  if (!rm) return;
  pa__free(rm->x);
  pa__free(rm->met);
  pa__free(rm->met0);
  pa__free(rm->vcur);
  pa__free(rm->fld);
  pa__free(rm->vref);
  pa__free(rm->vpf);
  pa__free(rm->vtag);
  pa__free(rm->tv);
  pa__free(rm->adj);
  pa__free(rm->q);
  pa__free(rm->tref);
  pa__free(rm->tflag);
  pa__free(rm->bv);
  pa__free(rm->bside);
  pa__free(rm->btan);
  pa__free(rm->bref);
  pa__free(rm->btag);
  pa__free(rm);
}

/* ---- spatial reordering ---- */

/* The low 32 bits of x spread to the even bits of a 64-bit word. */
static uint64_t spread2(uint64_t x) {
  x &= 0xffffffffull;
  x = (x | x << 16) & 0x0000ffff0000ffffull;
  x = (x | x << 8) & 0x00ff00ff00ff00ffull;
  x = (x | x << 4) & 0x0f0f0f0f0f0f0f0full;
  x = (x | x << 2) & 0x3333333333333333ull;
  x = (x | x << 1) & 0x5555555555555555ull;
  return x;
}

/* Copy records old[0..n) of a to q, sz bytes each: the record sizes of the
 * working mesh (1 to 24 bytes) get a copy of constant size, which the
 * compiler inlines, where a size known only at run time costs a call of
 * memcpy per record. */
#define GATHER_CASE(S)                                                         \
  case S:                                                                      \
    for (pa_idx i = 0; i < n; i++)                                             \
      memcpy(q + (size_t)(S) * i, a + (size_t)(S) * old[i], S);               \
    break
static void gather(unsigned char *q, const unsigned char *a, size_t sz,
                   const pa_idx *old, pa_idx n) {
  switch (sz) {
    GATHER_CASE(1);
    GATHER_CASE(4);
    GATHER_CASE(8);
    GATHER_CASE(12);
    GATHER_CASE(16);
    GATHER_CASE(24);
  default:
    for (pa_idx i = 0; i < n; i++) memcpy(q + sz * i, a + sz * old[i], sz);
  }
}
#undef GATHER_CASE

/* Replace the array *p (cap records of sz bytes; NULL: nothing) by its
 * records old[0..n) in that order. */
static pa_status regather(void **p, size_t cap, size_t sz, const pa_idx *old,
                          pa_idx n) {
  if (!*p || !sz) return PA_SUCCESS;
  unsigned char *q = pa__malloc((cap ? cap : 1) * sz);
  if (!q)
    return pa__error(PA_ERR_MEMORY, __FILE__, __LINE__,
                     "remesher: out of memory reordering");
  const unsigned char *a = *p;
  gather(q, a, sz, old, n);
  pa__free(*p);
  *p = q;
  return PA_SUCCESS;
}

/* posv[v]: the new slot of vertex v, the live vertices along the Morton
 * curve of their bounding box, then the dead slots (dropped); key: nvlive
 * records of scratch. */
static pa_status vertex_positions(const rm2d *rm, pa__key64 *key,
                                  pa_idx *posv) {
  pa_status st = PA_SUCCESS;
  const pa_idx nv = rm->nv, n = rm->nvlive;
  double lo[2] = {DBL_MAX, DBL_MAX}, hi[2] = {-DBL_MAX, -DBL_MAX};
  for (pa_idx v = 0; v < nv; v++)
    if (!(rm->vtag[v] & RM2D_V_DEAD))
      for (int j = 0; j < 2; j++) {
        const double c = rm->x[2 * (size_t)v + j]; /* finite */
        if (c < lo[j]) lo[j] = c;
        if (c > hi[j]) hi[j] = c;
      }
  double ext = fmax(hi[0] - lo[0], hi[1] - lo[1]);
  double sc = ext > 0 ? 4294967295.0 / ext : 0;
  pa_idx k = 0, dead = n;
  for (pa_idx v = 0; v < nv; v++) {
    if (rm->vtag[v] & RM2D_V_DEAD) {
      posv[v] = dead++;
      continue;
    }
    const double *x = rm->x + 2 * (size_t)v;
    key[k].key = spread2((uint64_t)((x[0] - lo[0]) * sc)) |
                 spread2((uint64_t)((x[1] - lo[1]) * sc)) << 1;
    key[k++].idx = v;
  }
  PA_CHECK(k == n, PA_ERR_INTERNAL, "remesher: live vertex count is off");
  PA_CALL(pa__key64_sort(key, (size_t)n));
  for (pa_idx i = 0; i < n; i++) posv[key[i].idx] = i;
cleanup:
  return st;
}

/* pose[e]: the new slot of element e, the live elements by their smallest
 * new vertex (stable counting sort; cnt: nvlive + 1 zeroed counters), then
 * the dead slots. The elements' vertices are renumbered by posv here,
 * before they move. */
static pa_status elem_positions(rm2d *rm, const pa_idx *posv, pa_idx *pose,
                                pa_idx *cnt) {
  pa_status st = PA_SUCCESS;
  const int nvpe = rm->nvpe;
  const pa_idx ne = rm->ne, n = rm->nvlive;
  for (pa_idx e = 0; e < ne; e++) {
    if (rm->tflag[e] & RM2D_E_DEAD) continue;
    pa_idx *v = rm->tv + (size_t)nvpe * e, m = n;
    for (int i = 0; i < nvpe; i++) {
      v[i] = posv[v[i]];
      if (v[i] < m) m = v[i];
    }
    pose[e] = m; /* the sort key until the positions are known */
    cnt[m + 1]++;
  }
  for (pa_idx i = 0; i < n; i++) cnt[i + 1] += cnt[i];
  PA_CHECK(cnt[n] == rm->nelive, PA_ERR_INTERNAL,
           "remesher: live element count is off");
  pa_idx dead = rm->nelive;
  for (pa_idx e = 0; e < ne; e++)
    pose[e] = rm->tflag[e] & RM2D_E_DEAD ? dead++ : cnt[pose[e]]++;
cleanup:
  return st;
}

/* Renumber the adjacency and the feature records (which keep their slots)
 * to the new vertex and element slots. */
static void renumber_links(rm2d *rm, const pa_idx *posv, const pa_idx *pose) {
  const int nvpe = 3; /* triangles (pa__rm2d_reorder): no division at run time */
  for (pa_idx e = 0; e < rm->ne; e++) {
    if (rm->tflag[e] & RM2D_E_DEAD) continue;
    for (int i = 0; i < nvpe; i++) {
      pa_idx a = rm->adj[(size_t)nvpe * e + i];
      if (a >= 0) rm->adj[(size_t)nvpe * e + i] = nvpe * pose[a / nvpe] + a % nvpe;
    }
  }
  for (pa_idx b = 0; b < rm->nb; b++) {
    if (rm->btag[b] & RM2D_B_DEAD) continue;
    for (int s = 0; s < 2; s++) {
      rm->bv[2 * b + s] = posv[rm->bv[2 * b + s]];
      pa_idx c = rm->bside[2 * b + s];
      if (c >= 0) rm->bside[2 * b + s] = nvpe * pose[c / nvpe] + c % nvpe;
    }
  }
}

/* Move the element records to their new slots: inv[i], the old slot of
 * new slot i. */
static pa_status regather_elems(rm2d *rm, const pa_idx *inv) {
  pa_status st = PA_SUCCESS;
  const int nvpe = rm->nvpe;
  const pa_idx ne = rm->ne;
  PA_CALL(regather((void **)&rm->tv, rm->cape, nvpe * sizeof(pa_idx), inv, ne));
  PA_CALL(regather((void **)&rm->adj, rm->cape, nvpe * sizeof(pa_idx), inv, ne));
  PA_CALL(regather((void **)&rm->q, rm->cape, sizeof *rm->q, inv, ne));
  PA_CALL(regather((void **)&rm->tref, rm->cape, sizeof *rm->tref, inv, ne));
  PA_CALL(regather((void **)&rm->tflag, rm->cape, sizeof *rm->tflag, inv, ne));
cleanup:
  return st;
}

/* Move the vertex records to their new slots: inv[i], the old slot of new
 * slot i. */
static pa_status regather_vertices(rm2d *rm, const pa_idx *inv) {
  pa_status st = PA_SUCCESS;
  const pa_idx nv = rm->nv;
  PA_CALL(regather((void **)&rm->x, rm->capv, 2 * sizeof(double), inv, nv));
  PA_CALL(
      regather((void **)&rm->met, rm->capv, rm->mc * sizeof(double), inv, nv));
  PA_CALL(
      regather((void **)&rm->met0, rm->capv, rm->mc * sizeof(double), inv, nv));
  PA_CALL(regather((void **)&rm->fld, rm->capv, rm->fcomp * sizeof(double), inv, nv));
  PA_CALL(regather((void **)&rm->vcur, rm->capv, 2 * sizeof(double), inv, nv));
  PA_CALL(regather((void **)&rm->vref, rm->capv, sizeof *rm->vref, inv, nv));
  PA_CALL(regather((void **)&rm->vpf, rm->capv, sizeof *rm->vpf, inv, nv));
  PA_CALL(regather((void **)&rm->vtag, rm->capv, sizeof *rm->vtag, inv, nv));
cleanup:
  return st;
}

pa_status pa__rm2d_reorder(rm2d *rm) {
  pa_status st = PA_SUCCESS;
  pa__key64 *key = NULL;
  pa_idx *posv = NULL, *pose = NULL, *cnt = NULL, *inv = NULL;
  const pa_idx nv = rm->nv, ne = rm->ne, n = rm->nvlive;
  PA_CHECK(rm->dim == 2, PA_ERR_INTERNAL, "remesher reorder: 2D only");
  PA_ALLOC(key, (size_t)n + 1);
  PA_ALLOC(posv, (size_t)nv + 1);
  PA_CALL(vertex_positions(rm, key, posv));
  pa__free(key);
  key = NULL;
  PA_ALLOC(pose, (size_t)ne + 1);
  PA_CALLOC(cnt, (size_t)n + 1);
  PA_CALL(elem_positions(rm, posv, pose, cnt));
  renumber_links(rm, posv, pose);
  /* Move the records out of place, one array at a time: the reads are
   * independent, so the memory system overlaps them, where following the
   * permutation's cycles in place is slower (figures: docs/BENCHMARKS.md,
   * "The 2D remesher"); the peak grows by one array. */
  pa__free(cnt);
  cnt = NULL;
  PA_ALLOC(inv, (size_t)(nv > ne ? nv : ne) + 1);
  for (pa_idx e = 0; e < ne; e++) inv[pose[e]] = e;
  pa__free(pose);
  pose = NULL;
  PA_CALL(regather_elems(rm, inv));
  for (pa_idx v = 0; v < nv; v++) inv[posv[v]] = v;
  pa__free(posv);
  posv = NULL;
  PA_CALL(regather_vertices(rm, inv));
  rm->nv = n; /* the dead slots, now last, are dropped */
  rm->vfree = -1;
  rm->ne = rm->nelive;
  rm->efree = -1;
cleanup:
  pa__free(key);
  pa__free(posv);
  pa__free(pose);
  pa__free(cnt);
  pa__free(inv);
  return st;
}

/* ---- write-back ---- */

#define FREE_NULL(p)                                                         \
  do {                                                                       \
    pa__free(p);                                                             \
    (p) = NULL;                                                              \
  } while (0)

/* The arrays pa__rm2d_write builds for the mesh, with their counts. */
typedef struct out_arrays {
  double *coord, *met, *fval[PA_MESH_MAX_FIELDS];
  int32_t *vref, *eref, *bref;
  uint8_t *vflag, *eflag, *bflag;
  pa_idx *elem, *bdry;
  /* the vertices' model entities, when the mesh is classified: their room
   * only, which pa_remesh fills from the cells (remesher.c) */
  uint8_t *vgdim;
  int32_t *vgtag;
  pa_idx nv, ne, nb;
} out_arrays;

static void out_free(out_arrays *o) {
  pa__free(o->coord);
  pa__free(o->met);
  for (int k = 0; k < PA_MESH_MAX_FIELDS; k++) pa__free(o->fval[k]);
  pa__free(o->vref);
  pa__free(o->vflag);
  pa__free(o->elem);
  pa__free(o->eref);
  pa__free(o->eflag);
  pa__free(o->bdry);
  pa__free(o->bref);
  pa__free(o->bflag);
  pa__free(o->vgdim);
  pa__free(o->vgtag);
}

/* The live vertices' arrays, at their new indices map[v], freeing the
 * working ones as they are copied. */
static pa_status copy_vertices(rm2d *rm, const pa_idx *map, out_arrays *o) {
  pa_status st = PA_SUCCESS;
  int d = rm->dim, mc = rm->mc;
  pa_idx nvl = o->nv;
  PA_ALLOC(o->coord, (size_t)d * nvl);
  for (pa_idx v = 0; v < rm->nv; v++)
    if (map[v] >= 0)
      memcpy(o->coord + (size_t)d * map[v], rm->x + (size_t)d * v,
             d * sizeof(double));
  FREE_NULL(rm->x);
  /* the target metric goes back, not the working one relaxed at skins */
  const double *mtarget = rm->met0 ? rm->met0 : rm->met;
  PA_ALLOC(o->met, (size_t)mc * nvl);
  for (pa_idx v = 0; v < rm->nv; v++)
    if (map[v] >= 0)
      memcpy(o->met + (size_t)mc * map[v], mtarget + (size_t)mc * v,
             mc * sizeof(double));
  FREE_NULL(rm->met);
  FREE_NULL(rm->met0);
  int off = 0;
  for (int k = 0; k < rm->nfield; k++) {
    int nc = rm->fncomp[k];
    PA_ALLOC(o->fval[k], (size_t)nc * nvl);
    for (pa_idx v = 0; v < rm->nv; v++)
      if (map[v] >= 0)
        for (int c = 0; c < nc; c++)
          o->fval[k][(size_t)nc * map[v] + c] =
              rm->fld[(size_t)rm->fcomp * v + off + c];
    off += nc;
  }
  FREE_NULL(rm->fld);
  PA_ALLOC(o->vref, nvl);
  PA_ALLOC(o->vflag, nvl);
  for (pa_idx v = 0; v < rm->nv; v++)
    if (map[v] >= 0) {
      o->vref[map[v]] = rm->vref[v];
      o->vflag[map[v]] = rm->vpf[v];
    }
  FREE_NULL(rm->vref);
  FREE_NULL(rm->vpf);
  FREE_NULL(rm->vtag);
cleanup:
  return st;
}

/* The live elements, freeing the working ones. */
static pa_status copy_elements(rm2d *rm, const pa_idx *map, out_arrays *o) {
  pa_status st = PA_SUCCESS;
  int nvpe = rm->nvpe;
  FREE_NULL(rm->adj);
  FREE_NULL(rm->q);
  PA_ALLOC(o->elem, (size_t)nvpe * rm->nelive);
  PA_ALLOC(o->eref, rm->nelive);
  PA_ALLOC(o->eflag, rm->nelive);
  for (pa_idx k = 0; k < rm->ne; k++) {
    if (rm->tflag[k] & RM2D_E_DEAD) continue;
    for (int i = 0; i < nvpe; i++)
      o->elem[(size_t)nvpe * o->ne + i] = map[rm->tv[(size_t)nvpe * k + i]];
    o->eref[o->ne] = rm->tref[k];
    o->eflag[o->ne] = rm->tflag[k] & 0x0F;
    o->ne++;
  }
  FREE_NULL(rm->tv);
  FREE_NULL(rm->tref);
  FREE_NULL(rm->tflag);
cleanup:
  return st;
}

/* The live boundary entities (2D: listed feature edges). */
static pa_status copy_boundary(const rm2d *rm, const pa_idx *map,
                               out_arrays *o) {
  pa_status st = PA_SUCCESS;
  PA_ALLOC(o->bdry, (size_t)rm->dim * rm->nblive);
  PA_ALLOC(o->bref, rm->nblive);
  PA_ALLOC(o->bflag, rm->nblive);
  for (pa_idx b = 0; b < rm->nb; b++) {
    if ((rm->btag[b] & RM2D_B_DEAD) || !(rm->btag[b] & RM2D_B_LISTED)) continue;
    o->bdry[2 * (size_t)o->nb] = map[rm->bv[2 * (size_t)b]];
    o->bdry[2 * (size_t)o->nb + 1] = map[rm->bv[2 * (size_t)b + 1]];
    o->bref[o->nb] = rm->bref[b];
    o->bflag[o->nb] = rm->btag[b] & 0x0F;
    o->nb++;
  }
cleanup:
  return st;
}

/* Replace the arrays of mesh with those of o, which keeps none. */
static void install(const rm2d *rm, pa_mesh *mesh, out_arrays *o) {
  pa__mesh_invalidate(mesh);
  pa__free(mesh->coord);
  pa__free(mesh->vref);
  pa__free(mesh->vflag);
  pa__free(mesh->met);
  pa__free(mesh->elem);
  pa__free(mesh->eref);
  pa__free(mesh->eflag);
  pa__free(mesh->bdry);
  pa__free(mesh->bref);
  pa__free(mesh->bflag);
  if (o->vgdim) {
    pa__free(mesh->vgdim);
    pa__free(mesh->vgtag);
    mesh->vgdim = o->vgdim;
    mesh->vgtag = o->vgtag;
    o->vgdim = NULL;
    o->vgtag = NULL;
  }
  mesh->coord = o->coord;
  mesh->vref = o->vref;
  mesh->vflag = o->vflag;
  mesh->met = o->met;
  mesh->met_ncomp = rm->mc;
  for (int k = 0; k < rm->nfield; k++) {
    pa__free(mesh->field[k].val);
    mesh->field[k].val = o->fval[k];
    o->fval[k] = NULL;
  }
  mesh->nv = o->nv;
  mesh->capv = (size_t)o->nv;
  mesh->elem = o->elem;
  mesh->eref = o->eref;
  mesh->eflag = o->eflag;
  mesh->ne = o->ne;
  mesh->cape = (size_t)rm->nelive;
  mesh->bdry = o->bdry;
  mesh->bref = o->bref;
  mesh->bflag = o->bflag;
  mesh->nb = o->nb;
  mesh->capb = (size_t)rm->nblive;
  o->coord = o->met = NULL;
  o->vref = o->eref = o->bref = NULL;
  o->vflag = o->eflag = o->bflag = NULL;
  o->elem = o->bdry = NULL;
}

pa_status pa__rm2d_write(rm2d *rm, pa_mesh *mesh) {
  pa_status st = PA_SUCCESS;
  pa_idx *map = NULL;
  out_arrays o = {0};
  PA_ALLOC(map, rm->nv);
  for (pa_idx v = 0; v < rm->nv; v++)
    map[v] = (rm->vtag[v] & RM2D_V_DEAD) ? -1 : o.nv++;
  PA_CALL(copy_vertices(rm, map, &o));
  PA_CALL(copy_elements(rm, map, &o));
  PA_CALL(copy_boundary(rm, map, &o));
  if (mesh->vgdim) {
    PA_ALLOC(o.vgdim, o.nv ? o.nv : 1);
    PA_CALLOC(o.vgtag, o.nv ? o.nv : 1);
    memset(o.vgdim, mesh->dim, (size_t)(o.nv ? o.nv : 1));
  }
  /* Everything is built: install into the mesh. */
  install(rm, mesh, &o);
cleanup:
  pa__free(map);
  out_free(&o);
  return st;
}

/* ---- check ---- */

pa_status pa__rm2d_check(const rm2d *rm) {
  pa_status st = PA_SUCCESS;
  int nvpe = rm->nvpe;
  pa_idx nlive = 0;
  PA_CHECK(rm->dim == 2, PA_ERR_INTERNAL, "remesher check: 2D only");
  for (pa_idx k = 0; k < rm->ne; k++) {
    if (rm->tflag[k] & RM2D_E_DEAD) continue;
    nlive++;
    const pa_idx *v = rm->tv + (size_t)nvpe * k;
    for (int i = 0; i < nvpe; i++)
      PA_CHECK(v[i] >= 0 && v[i] < rm->nv && !(rm->vtag[v[i]] & RM2D_V_DEAD),
               PA_ERR_INTERNAL, "remesher: element %d has a dead vertex",
               (int)k);
    const double *a = rm->x + 2 * (size_t)v[0], *b = rm->x + 2 * (size_t)v[1],
                 *c = rm->x + 2 * (size_t)v[2];
    double area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
    PA_CHECK(area > 0, PA_ERR_INTERNAL,
             "remesher: element %d is not positively oriented", (int)k);
#ifndef NDEBUG
    /* the in-range mark is a cache: a stale one costs operations, never
     * validity, so only debug builds check it (it is most of this check's
     * time: three metric lengths per element) */
    if (rm->tflag[k] & RM2D_E_INRANGE) { /* the cache is still true */
      int mc = rm->mc;
      for (int i = 0; i < 3; i++) {
        pa_idx p = v[i], q = v[i == 2 ? 0 : i + 1];
        double l = pa__len2(mc, rm->x + 2 * (size_t)p, rm->x + 2 * (size_t)q,
                            rm->met + (size_t)mc * p, rm->met + (size_t)mc * q);
        PA_CHECK(rm2d_len_settled(rm, l), PA_ERR_INTERNAL,
                 "remesher: element %d is marked in range, edge %d has "
                 "length %g",
                 (int)k, i, l);
      }
    }
#endif
    for (int i = 0; i < 3; i++) {
      pa_idx code = 3 * k + i, o = rm->adj[code];
      pa_idx e0 = v[(i + 1) % 3], e1 = v[(i + 2) % 3];
      if (o >= 0) {
        pa_idx f = o / 3;
        int j = o % 3;
        PA_CHECK(!(rm->tflag[f] & RM2D_E_DEAD) && rm->adj[o] == code,
                 PA_ERR_INTERNAL,
                 "remesher: adjacency of element %d face %d "
                 "is not symmetric",
                 (int)k, i);
        PA_CHECK(rm->tv[3 * f + (j + 1) % 3] == e1 &&
                     rm->tv[3 * f + (j + 2) % 3] == e0,
                 PA_ERR_INTERNAL,
                 "remesher: element %d face %d does not match "
                 "its neighbour",
                 (int)k, i);
      } else {
        pa_idx bi = -o - 1;
        PA_CHECK(bi < rm->nb && !(rm->btag[bi] & RM2D_B_DEAD), PA_ERR_INTERNAL,
                 "remesher: element %d face %d points to a dead feature",
                 (int)k, i);
        PA_CHECK(rm->bside[2 * bi] == code || rm->bside[2 * bi + 1] == code,
                 PA_ERR_INTERNAL, "remesher: feature %d does not know element "
                 "%d", (int)bi, (int)k);
        pa_idx b0 = rm->bv[2 * bi], b1 = rm->bv[2 * bi + 1];
        PA_CHECK((b0 == e0 && b1 == e1) || (b0 == e1 && b1 == e0),
                 PA_ERR_INTERNAL, "remesher: feature %d vertices do not match "
                 "element %d", (int)bi, (int)k);
      }
    }
  }
  PA_CHECK(nlive == rm->nelive, PA_ERR_INTERNAL,
           "remesher: live element count is off");
  for (pa_idx b = 0; b < rm->nb; b++) {
    if (rm->btag[b] & RM2D_B_DEAD) continue;
    PA_CHECK(rm->bside[2 * b] >= 0, PA_ERR_INTERNAL,
             "remesher: feature %d has no element", (int)b);
    for (int s = 0; s < 2; s++) {
      pa_idx code = rm->bside[2 * b + s];
      if (code < 0) continue;
      PA_CHECK(!(rm->tflag[code / 3] & RM2D_E_DEAD) && rm->adj[code] == -b - 1,
               PA_ERR_INTERNAL, "remesher: feature %d side %d is stale", (int)b,
               s);
    }
  }
cleanup:
  return st;
}

/* ---- figures ---- */

void pa__rm2d_figures(const rm2d *rm, rm2d_figures *f) {
  memset(f, 0, sizeof *f);
  f->lmin = DBL_MAX;
  f->qmin = DBL_MAX;
  int mc = rm->mc;
  long nq = 0;
  double qs = 0;
  for (pa_idx k = 0; k < rm->ne; k++) {
    uint8_t t = rm->tflag[k];
    if (t & RM2D_E_DEAD) continue;
    if (!(t & RM2D_E_FROZEN)) {
      double q = rm->q[k];
      if (q < f->qmin) f->qmin = q;
      qs += q;
      nq++;
    }
    for (int i = 0; i < 3; i++) {
      pa_idx code = 3 * k + i, o = rm->adj[code];
      int frozen = t & RM2D_E_FROZEN;
      if (o >= 0) {
        if (o < code) continue; /* count each edge once */
        frozen |= rm->tflag[o / 3] & RM2D_E_FROZEN;
      } else {
        pa_idx b = -o - 1;
        if (rm->bside[2 * b] != code) continue;
        frozen |= rm->btag[b] & RM2D_B_FROZEN;
        pa_idx s = rm->bside[2 * b + 1];
        if (s >= 0) frozen |= rm->tflag[s / 3] & RM2D_E_FROZEN;
      }
      if (frozen) continue;
      pa_idx a = rm->tv[3 * k + (i + 1) % 3], c = rm->tv[3 * k + (i + 2) % 3];
      double l = pa__len2(mc, rm->x + 2 * (size_t)a, rm->x + 2 * (size_t)c,
                          rm->met + (size_t)mc * a, rm->met + (size_t)mc * c);
      f->nedge++;
      if (l < f->lmin) f->lmin = l;
      if (l > f->lmax) f->lmax = l;
      if (l >= PA_METRIC_LEN_LO && l < PA_METRIC_LEN_HI)
        f->nin++;
      else if (l >= PA_METRIC_LEN_HI)
        f->nlong++;
      else {
        f->nshort++;
        if (pa_verbosity() >= 4)
          pa__info(4, "short edge %d-%d L=%.3f tags %d %d q=%.3f\n", (int)a, (int)c, l,
                   rm->vtag[a], rm->vtag[c], rm->q[k]);
      }
    }
  }
  if (!f->nedge) f->lmin = 0;
  if (!nq) f->qmin = 1;
  f->qmean = nq ? qs / nq : 1;
}
