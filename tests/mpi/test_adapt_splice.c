/*
 * test_adapt_splice.c -- the two ways the parallel adaptation puts its
 * outputs back give the same distributed mesh: the splice of a rebuilt part
 * (src/dmesh/splice.c, forced with PADAPT_REINTEGRATE=splice) and the
 * rebuild of the whole mesh from records (PADAPT_REINTEGRATE=rebuild), and
 * by default the choice between them. The same input is adapted each way on
 * the same ranks and the results are compared array by array on every rank
 * (counts, global ids, owners, the local mesh, the star forests, the
 * neighbour ranks, the user values with their slots), 2D and 3D, with user
 * values on every kind (one restricted to a reference). Where the splice
 * does not apply it must fall back: ghost layers (overlap 1) and a mesh
 * renumbered by pa_dmesh_reorder (its first iteration). And the rebuild
 * from records gives the same mesh whether or not some vertices are handed
 * apart as private (pa__dmesh_build_priv, which the rebuild uses: the
 * fetched vertices are merged into the private ones, in place without
 * payloads), with and without user values. Runs at any number of ranks.
 */
#include "testutil.h"
#include "dmesh/dmesh.h"

#include <mpi.h>
#include <stdlib.h>

/* The input: a box (2D: with the anisotropic metric "layer"), user
 * elements flagged here and there (they stay), distributed with the given overlap, and user values on
 * every kind set to a function of the global id. */
static pa_dmesh *make(int dim, int overlap, int reorder) {
  static const pa_entity kinds[4] = {PA_VERTEX, PA_ELEMENT, PA_BOUNDARY,
                                     PA_EDGE};
  pa_mesh *m = NULL;
  pa_dmesh *dm = NULL;
  if (pa_test_rank == 0) {
    CHECK_OK(pa_mesh_generate_box(dim, dim == 3 ? 4 : 16, &m));
    if (dim == 2) CHECK_OK(pa_metric_analytic(m, "layer:0.1"));
    for (pa_idx e = 5; e < pa_mesh_nelem(m); e += 97)
      pa_mesh_elem_flags(m)[e] |= PA_FLAG_USER;
  }
  CHECK_OK(pa_dmesh_distribute(MPI_COMM_WORLD, 0, m, overlap, &dm));
  pa_mesh_destroy(m);
  if (reorder) CHECK_OK(pa_dmesh_reorder(dm));
  for (int k = 0; k < (dim == 3 ? 4 : 3); k++) {
    char name[32];
    pa_dmesh_value *v;
    pa_idx n;
    snprintf(name, sizeof name, "test.v%d", k);
    CHECK_OK(pa_dmesh_value_add(dm, kinds[k], name, MPI_INT64_T, 1,
                                kinds[k] == PA_BOUNDARY ? 1 : -1, &v));
    int64_t *x = pa_dmesh_value_data(v, &n, NULL);
    const pa_idx *ent = pa_dmesh_value_entities(v);
    const pa_gid *g = pa_dmesh_gids(dm, kinds[k]);
    for (pa_idx i = 0; i < n; i++) x[i] = 7 * g[ent ? ent[i] : i] + k + 1;
  }
  return dm;
}

/* Adapt a fresh input (3D: to a uniform size) with the reintegration
 * switch set to how (NULL: unset, the default choice): several iterations
 * on several ranks. */
static pa_dmesh *adapted(int dim, int overlap, int reorder, const char *how) {
  pa_dmesh *dm = make(dim, overlap, reorder);
  pa_adapt_opts o;
  pa_adapt_report rep;
  pa_adapt_opts_default(&o);
  if (dim == 3) o.remesh.hsiz = 0.08;
  o.min_piece_work = 30; /* several pieces, several iterations */
  o.min_piece_ratio = 0;
  if (how) setenv("PADAPT_REINTEGRATE", how, 1);
  else unsetenv("PADAPT_REINTEGRATE");
  CHECK_OK(pa_dmesh_adapt(dm, &o, &rep));
  unsetenv("PADAPT_REINTEGRATE");
  CHECK(overlap > 0 || pa_test_size == 1 || rep.niter >= 2);
  CHECK_OK(pa_dmesh_check(dm));
  return dm;
}

/* Number of differing bytes-arrays: n items of unit bytes. */
static int differ(const void *a, const void *b, size_t n, size_t unit) {
  if (!n) return 0;
  if (!a || !b) return 1;
  return memcmp(a, b, n * unit) != 0;
}

static int same_sf(const pa__sf *a, const pa__sf *b) {
  if (a->nrootrank != b->nrootrank || a->nleafrank != b->nleafrank) return 0;
  if (differ(a->rootrank, b->rootrank, a->nrootrank, sizeof(int)) ||
      differ(a->rootoff, b->rootoff, a->nrootrank + 1, sizeof(pa_idx)) ||
      differ(a->leafrank, b->leafrank, a->nleafrank, sizeof(int)) ||
      differ(a->leafoff, b->leafoff, a->nleafrank + 1, sizeof(pa_idx)))
    return 0;
  return !differ(a->rootidx, b->rootidx,
                 a->nrootrank ? a->rootoff[a->nrootrank] : 0, sizeof(pa_idx)) &&
         !differ(a->leafidx, b->leafidx,
                 a->nleafrank ? a->leafoff[a->nleafrank] : 0, sizeof(pa_idx));
}

/* The local parts of a and b are the same, array by array; names what
 * differs first. */
static void same_dmesh(const pa_dmesh *a, const pa_dmesh *b, const char *what) {
  const pa_mesh *ma = a->mesh, *mb = b->mesh;
  int d = a->dim;
  const char *bad = NULL;
  for (int k = 0; k < PA_DMESH_NKIND && !bad; k++) {
    if (a->nown[k] != b->nown[k] || a->nloc[k] != b->nloc[k] ||
        a->nglob[k] != b->nglob[k])
      bad = "counts";
    else if (differ(a->gid[k], b->gid[k], a->nloc[k], sizeof(pa_gid)))
      bad = "global ids";
    else if (differ(a->owner[k], b->owner[k], a->nloc[k], sizeof(int)))
      bad = "owners";
    else if (!same_sf(&a->sf[k], &b->sf[k]))
      bad = "star forests";
  }
  if (!bad && (ma->nv != mb->nv || ma->ne != mb->ne || ma->nb != mb->nb ||
               ma->ned != mb->ned || ma->met_ncomp != mb->met_ncomp ||
               ma->nfield != mb->nfield))
    bad = "mesh counts";
  if (!bad &&
      (differ(ma->coord, mb->coord, (size_t)d * ma->nv, sizeof(double)) ||
       differ(ma->vref, mb->vref, ma->nv, sizeof(int32_t)) ||
       differ(ma->vflag, mb->vflag, ma->nv, 1) ||
       differ(ma->met, mb->met, (size_t)ma->met_ncomp * ma->nv,
              sizeof(double))))
    bad = "vertices";
  for (int f = 0; !bad && f < ma->nfield; f++)
    if (differ(ma->field[f].val, mb->field[f].val,
               (size_t)ma->field[f].ncomp * ma->nv, sizeof(double)))
      bad = "vertex fields";
  if (!bad &&
      (differ(ma->elem, mb->elem, (size_t)(d + 1) * ma->ne, sizeof(pa_idx)) ||
       differ(ma->eref, mb->eref, ma->ne, sizeof(int32_t)) ||
       differ(ma->eflag, mb->eflag, ma->ne, 1) ||
       differ(a->layer, b->layer, ma->ne, 1)))
    bad = "elements";
  if (!bad &&
      (differ(ma->bdry, mb->bdry, (size_t)d * ma->nb, sizeof(pa_idx)) ||
       differ(ma->bref, mb->bref, ma->nb, sizeof(int32_t)) ||
       differ(ma->bflag, mb->bflag, ma->nb, 1) ||
       differ(ma->edge, mb->edge, (size_t)2 * ma->ned, sizeof(pa_idx)) ||
       differ(ma->edref, mb->edref, ma->ned, sizeof(int32_t)) ||
       differ(ma->edflag, mb->edflag, ma->ned, 1)))
    bad = "boundary entities or edges";
  if (!bad && (a->nneigh != b->nneigh ||
               differ(a->neigh, b->neigh, a->nneigh, sizeof(int))))
    bad = "neighbour ranks";
  if (!bad && a->nvalue != b->nvalue) bad = "value count";
  for (int k = 0; !bad && k < a->nvalue; k++) {
    const pa_dmesh_value *va = a->value[k], *vb = b->value[k];
    if (strcmp(va->name, vb->name) || va->nslot != vb->nslot ||
        va->nslotown != vb->nslotown ||
        differ(va->data, vb->data, va->nslot, va->unit) ||
        (va->slot &&
         differ(va->slot, vb->slot, a->nloc[va->kind], sizeof(pa_idx))))
      bad = va->name;
  }
  if (bad)
    fprintf(stderr, "rank %d: %s: the %s differ\n", pa_test_rank, what, bad);
  CHECK(bad == NULL);
}

/* dm rebuilt from the records of its owned entities (every element stays
 * on its rank); with priv, the owned vertices with no copy on another rank
 * and a global id not a multiple of 3 go apart as private, so that the
 * others, fetched, fall between them. */
static pa_dmesh *rebuilt(pa_dmesh *dm, int priv) {
  pa__recs E, V, B, D, P;
  pa__layout lay;
  pa_dmesh *out = NULL;
  uint8_t *vp = NULL;
  pa_idx nown = dm->nown[PA_VERTEX];
  const pa__sf *sf = &dm->sf[PA_VERTEX];
  if (priv) {
    vp = calloc((size_t)nown + 1, 1);
    CHECK(vp != NULL);
    for (pa_idx v = 0; v < nown; v++) vp[v] = dm->gid[PA_VERTEX][v] % 3 != 0;
    for (pa_idx q = 0; sf->rootoff && q < sf->rootoff[sf->nrootrank]; q++)
      vp[sf->rootidx[q]] = 0;
  }
  CHECK_OK(pa__dmesh_kept_recs(dm, NULL, NULL, &E, &V, &B, &D, vp, &P));
  free(vp);
  pa__dmesh_layout(dm, &lay);
  CHECK_OK(pa__dmesh_create(dm->comm, dm->dim, &out));
  CHECK_OK(pa__dmesh_values_like(out, dm));
  CHECK_OK(pa__dmesh_build_priv(out, &lay, 0, &E, &V, &B, &D, &P));
  CHECK_OK(pa_dmesh_check(out));
  return out;
}

/* The private vertices change nothing in a rebuild, with user values on
 * every kind (payloads) and without (the in-place merge). */
static void test_private_vertices(void) {
  for (int dim = 2; dim <= 3; dim++)
    for (int values = 0; values < 2; values++) {
      pa_dmesh *dm = NULL;
      if (values) {
        dm = make(dim, 0, 0);
      } else {
        pa_mesh *m = NULL;
        if (pa_test_rank == 0)
          CHECK_OK(pa_mesh_generate_box(dim, dim == 3 ? 4 : 16, &m));
        CHECK_OK(pa_dmesh_distribute(MPI_COMM_WORLD, 0, m, 0, &dm));
        pa_mesh_destroy(m);
      }
      pa_dmesh *a = rebuilt(dm, 0), *b = rebuilt(dm, 1);
      same_dmesh(dm, a, values ? "rebuild with values" : "rebuild");
      same_dmesh(a, b, values ? "private vertices with values"
                              : "private vertices");
      pa_dmesh_destroy(a);
      pa_dmesh_destroy(b);
      pa_dmesh_destroy(dm);
    }
}

/* Forced splice, default choice and forced rebuild give the same mesh. */
static void compare(int dim, int overlap, int reorder, const char *what) {
  pa_dmesh *r = adapted(dim, overlap, reorder, "rebuild");
  pa_dmesh *s = adapted(dim, overlap, reorder, "splice");
  pa_dmesh *x = adapted(dim, overlap, reorder, NULL);
  same_dmesh(r, s, what);
  same_dmesh(r, x, what);
  pa_dmesh_destroy(r);
  pa_dmesh_destroy(s);
  pa_dmesh_destroy(x);
}

static void test_splice_2d(void) { compare(2, 0, 0, "2D"); }
static void test_splice_3d(void) { compare(3, 0, 0, "3D"); }
/* the splice does not apply: the rebuild's result all the same */
static void test_fallback_overlap(void) { compare(2, 1, 0, "2D overlap 1"); }
static void test_fallback_reordered(void) {
  compare(3, 0, 1, "3D reordered");
}

TEST_MPI_MAIN(test_splice_2d, test_splice_3d, test_fallback_overlap,
              test_fallback_reordered, test_private_vertices)
