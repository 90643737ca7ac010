/*
 * stats.c -- element quality and mesh statistics (pa_mesh_stats), their
 * human-readable report (the JSON form: io/json.c).
 *
 * pa_mesh_stats makes two streaming passes and never builds the mesh's
 * derived structures itself:
 *  1. over elements: index check, signed volume, quality;
 *  2. over the unique edges of pa__edges_csr (mesh/topo.c: the instances
 *     filed under their smaller vertex, deduplicated with a marker array),
 *     each measured once with pa__edge_length.
 * Time O(nelem + nvert), memory 4 bytes per edge instance plus 12 bytes per
 * vertex, all freed before returning. The validity check (pa_mesh_check)
 * runs last, after that memory is released.
 *
 * Both passes count through the accumulator pa__stats_acc, which
 * pa_dmesh_stats (dmesh/dstats.c) uses too: the bins, shares, extremes and
 * compensated sums are written once, here (the volume is then
 * pa_mesh_volume's, which sums in the same order).
 *
 * Conventions: edge lengths use the vertex metrics (identity when the mesh
 * has none) and the geometric formula of metric.c; an element whose two
 * vertices coincide contributes no edge. Quality bins take floor(Q / 0.2)
 * clamped to [0, 4], so inverted elements (Q < 0) count in the first bin and
 * every element in exactly one bin. When there are no edges (elements),
 * their min/max/sum are 0.
 */
#include "metric/metric.h"

#include <math.h>

/* Upper bounds of the edge-length bins 0..7 (bin 8 is [5, inf)): Mmg's,
 * with the in-range band (PA_METRIC_LEN_LO, PA_METRIC_LEN_HI) as it prints
 * it. */
static const double edge_bounds[PA_STATS_EDGE_NBIN - 2] = {
    0.3, 0.6, PA_METRIC_LEN_LO, 0.9, 1.3, PA_METRIC_LEN_HI, 2.0, 5.0};

double pa_mesh_elem_quality(pa_mesh *mesh, pa_idx e) {
  if (!mesh || e < 0 || e >= mesh->ne) return NAN;
  int dim = mesh->dim, nc = mesh->met_ncomp;
  const pa_idx *v = mesh->elem + (size_t)(dim + 1) * e;
  const double *x[4], *m[4];
  for (int k = 0; k <= dim; k++) {
    if (v[k] < 0 || v[k] >= mesh->nv) return NAN;
    x[k] = mesh->coord + (size_t)dim * v[k];
    m[k] = nc ? mesh->met + (size_t)nc * v[k] : NULL;
  }
  return pa__quality(dim, nc, x, m);
}

void pa__stats_acc_init(pa__stats_acc *a) { memset(a, 0, sizeof *a); }

void pa__stats_add_edge(pa__stats_acc *a, double len) {
  pa_stats *s = &a->s;
  int b = 0;
  while (b < PA_STATS_EDGE_NBIN - 2 && len >= edge_bounds[b])
    b++;
  s->edge_hist[b]++;
  if (len >= PA_METRIC_LEN_LO && len < PA_METRIC_LEN_HI)
    s->edge_hist[PA_STATS_EDGE_NBIN - 1]++;
  if (s->nedge == 0 || len < s->edge_min) s->edge_min = len;
  if (s->nedge == 0 || len > s->edge_max) s->edge_max = len;
  pa__ksum_add(&a->edge_sum, len);
  s->nedge++;
}

void pa__stats_add_elem(pa__stats_acc *a, double vol, double q) {
  pa_stats *s = &a->s;
  pa__ksum_add(&a->volume, vol);
  if (vol <= 0.0) s->ninverted++;
  int b = (int)floor(q / 0.2);
  if (!(b >= 0)) b = 0; /* also NaN */
  if (b >= PA_STATS_QUAL_NBIN) b = PA_STATS_QUAL_NBIN - 1;
  s->qual_hist[b]++;
  if (q > 0.5) s->qual_above_05++;
  if (q > 0.12) s->qual_above_012++;
  if (a->nelem == 0 || q < s->qual_min) s->qual_min = q;
  if (a->nelem == 0 || q > s->qual_max) s->qual_max = q;
  pa__ksum_add(&a->qual_sum, q);
  a->nelem++;
}

void pa__stats_acc_sums(pa__stats_acc *a) {
  a->s.volume = a->volume.s + a->volume.c;
  a->s.edge_sum = a->edge_sum.s + a->edge_sum.c;
  a->s.qual_sum = a->qual_sum.s + a->qual_sum.c;
}

pa_status pa_mesh_stats(pa_mesh *mesh, pa_stats *stats) {
  if (!mesh)
    return pa__error(PA_ERR_ARG, __FILE__, __LINE__,
                     "pa_mesh_stats: NULL argument");
  return pa__mesh_stats_met(mesh, mesh->met_ncomp, mesh->met,
                            PA_STATS_CHECK_FULL, stats);
}

pa_status pa__mesh_stats_met(pa_mesh *mesh, int nc, const double *met,
                             int check, pa_stats *stats) {
  pa_status st = PA_SUCCESS;
  size_t *pos = NULL;
  pa_idx *other = NULL;
  PA_CHECK(mesh && stats && (nc == 0 || met), PA_ERR_ARG,
           "pa_mesh_stats: NULL argument");
  pa__stats_acc acc;
  pa_stats *s = &acc.s;
  pa__stats_acc_init(&acc);
  int dim = mesh->dim, nve = dim + 1;
  pa_idx nv = mesh->nv, ne = mesh->ne;
  s->dim = dim;
  s->has_metric = nc > 0;
  s->nvert = nv;
  s->nelem = ne;
  s->nbdry = mesh->nb;

  /* Pass 1: volumes, qualities (and the index check). */
  for (pa_idx e = 0; e < ne; e++) {
    const pa_idx *v = mesh->elem + (size_t)nve * e;
    const double *x[4], *m[4];
    for (int k = 0; k < nve; k++) {
      PA_CHECK(v[k] >= 0 && v[k] < nv, PA_ERR_MESH,
               "element %ld: vertex index %ld out of range (the mesh has %ld "
               "vertices)",
               (long)e + 1, (long)v[k] + 1, (long)nv);
      x[k] = mesh->coord + (size_t)dim * v[k];
      m[k] = nc ? met + (size_t)nc * v[k] : NULL;
    }
    pa__stats_add_elem(&acc, pa__simplex_volume(dim, x),
                       pa__quality(dim, nc, x, m));
  }

  /* Pass 2: unique edges (filed under their smaller vertex) and lengths. */
  PA_CALL(pa__edges_csr(mesh->elem, ne, nve, nv, NULL, &pos, &other));
  for (pa_idx v = 0; v < nv; v++) {
    const double *xv = mesh->coord + (size_t)dim * v;
    const double *mv = nc ? met + (size_t)nc * v : NULL;
    for (size_t k = pos[v]; k < pos[v + 1]; k++) {
      pa_idx w = other[k];
      const double *xw = mesh->coord + (size_t)dim * w;
      const double *mw = nc ? met + (size_t)nc * w : NULL;
      pa__stats_add_edge(&acc, pa__edge_length(dim, nc, xv, xw, mv, mw));
    }
  }
  pa__stats_acc_sums(&acc);
  pa__free(pos);
  pa__free(other);
  pos = NULL;
  other = NULL;

  /* Validity last: it may build adjacency, so our arrays are gone by now. */
  pa_status chk = PA_SUCCESS;
  if (check == PA_STATS_CHECK_FULL) chk = pa_mesh_check(mesh);
  if (check == PA_STATS_CHECK_OUTPUT) {
    chk = pa__mesh_check(mesh, 0);
    if (chk == PA_SUCCESS) chk = pa__mesh_check_metric(mesh);
  }
  if (chk == PA_ERR_MEMORY) PA_CALL(chk);
  s->valid = chk == PA_SUCCESS;
  if (!s->valid) {
    pa__info(1, "pa_mesh_stats: mesh check failed: %s", pa_last_error());
    pa_clear_error();
  }
  *stats = *s;
cleanup:
  pa__free(pos);
  pa__free(other);
  return st;
}

pa_status pa_stats_edge_bin(int b, double *lo, double *hi) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(b >= 0 && b < PA_STATS_EDGE_NBIN && lo && hi, PA_ERR_ARG,
           "pa_stats_edge_bin: bin %d out of [0, %d) or NULL argument", b,
           PA_STATS_EDGE_NBIN);
  if (b == PA_STATS_EDGE_NBIN - 1) {
    *lo = PA_METRIC_LEN_LO;
    *hi = PA_METRIC_LEN_HI;
  } else {
    *lo = b > 0 ? edge_bounds[b - 1] : 0.0;
    *hi = b < PA_STATS_EDGE_NBIN - 2 ? edge_bounds[b] : INFINITY;
  }
cleanup:
  return st;
}

pa_status pa_stats_qual_bin(int b, double *lo, double *hi) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(b >= 0 && b < PA_STATS_QUAL_NBIN && lo && hi, PA_ERR_ARG,
           "pa_stats_qual_bin: bin %d out of [0, %d) or NULL argument", b,
           PA_STATS_QUAL_NBIN);
  *lo = (double)b / PA_STATS_QUAL_NBIN;
  *hi = (double)(b + 1) / PA_STATS_QUAL_NBIN;
cleanup:
  return st;
}

static double pct(pa_gid n, pa_gid total) { return 100 * pa__share(n, total); }

void pa_stats_print(const pa_stats *s, FILE *out) {
  if (!s || !out) return;
  /* the bins of edge_bounds, aligned */
  static const char *edge_labels[PA_STATS_EDGE_NBIN - 1] = {
      "0      <= L < 0.3   ", "0.3    <= L < 0.6   ", "0.6    <= L < 0.7071",
      "0.7071 <= L < 0.9   ", "0.9    <= L < 1.3   ", "1.3    <= L < 1.4142",
      "1.4142 <= L < 2     ", "2      <= L < 5     ", "5      <= L         "};
  static const char *qual_labels[PA_STATS_QUAL_NBIN] = {
      "       Q < 0.2", "0.2 <= Q < 0.4", "0.4 <= Q < 0.6", "0.6 <= Q < 0.8",
      "0.8 <= Q      "};
  int d2 = s->dim == 2;
  fprintf(out, " -- MESH STATISTICS (%dD)\n", s->dim);
  fprintf(out, "    %-22s%lld\n", "vertices", (long long)s->nvert);
  fprintf(out, "    %-22s%lld\n", d2 ? "triangles" : "tetrahedra",
          (long long)s->nelem);
  fprintf(out, "    %-22s%lld\n", d2 ? "boundary edges" : "boundary triangles",
          (long long)s->nbdry);
  fprintf(out, "    %-22s%.10g\n", d2 ? "area" : "volume", s->volume);
  fprintf(out, "    %-22s%lld\n", "inverted elements", (long long)s->ninverted);
  fprintf(out, "    %-22s%s\n", "mesh check", s->valid ? "valid" : "INVALID");

  fprintf(out, " -- EDGE LENGTHS (%s)   %lld edges\n",
          s->has_metric ? "in the metric" : "no metric: Euclidean",
          (long long)s->nedge);
  if (s->nedge > 0) {
    fprintf(out, "    average length        %.6f\n",
            s->edge_sum / (double)s->nedge);
    fprintf(out, "    smallest length       %.6f\n", s->edge_min);
    fprintf(out, "    largest length        %.6f\n", s->edge_max);
    pa_gid inr = s->edge_hist[PA_STATS_EDGE_NBIN - 1];
    fprintf(out, "    %.4f <= L < %.4f  %12lld   %6.2f %%\n", PA_METRIC_LEN_LO,
            PA_METRIC_LEN_HI, (long long)inr, pct(inr, s->nedge));
    for (int b = 0; b < PA_STATS_EDGE_NBIN - 1; b++)
      if (s->edge_hist[b] > 0)
        fprintf(out, "      %s  %12lld   %6.2f %%\n", edge_labels[b],
                (long long)s->edge_hist[b], pct(s->edge_hist[b], s->nedge));
  }

  fprintf(out, " -- ELEMENT QUALITY   %lld elements\n", (long long)s->nelem);
  if (s->nelem > 0) {
    fprintf(out, "    best                  %.6f\n", s->qual_max);
    fprintf(out, "    average               %.6f\n",
            s->qual_sum / (double)s->nelem);
    fprintf(out, "    worst                 %.6g\n", s->qual_min);
    for (int b = PA_STATS_QUAL_NBIN - 1; b >= 0; b--)
      if (s->qual_hist[b] > 0)
        fprintf(out, "      %s        %12lld   %6.2f %%\n", qual_labels[b],
                (long long)s->qual_hist[b], pct(s->qual_hist[b], s->nelem));
    fprintf(out, "    Q > 0.5               %12lld   %6.2f %%\n",
            (long long)s->qual_above_05, pct(s->qual_above_05, s->nelem));
    fprintf(out, "    Q > 0.12              %12lld   %6.2f %%\n",
            (long long)s->qual_above_012, pct(s->qual_above_012, s->nelem));
  }
}

int pa_stats_target_met(const pa_stats *s) {
  if (!s) return 0;
  return pa__share(s->edge_hist[PA_STATS_EDGE_NBIN - 1], s->nedge) >=
             PA_TARGET_IN_RANGE &&
         (s->nelem == 0 || s->qual_min >= PA_TARGET_QUALITY);
}

void pa_fidelity_describe(const pa_fidelity *f, char *buf, size_t n) {
  if (!buf || n == 0) return;
  buf[0] = '\0';
  if (!f) return;
  double in = pct(f->user.edge_hist[PA_STATS_EDGE_NBIN - 1], f->user.nedge);
  double inu = pct(f->used.edge_hist[PA_STATS_EDGE_NBIN - 1], f->used.nedge);
  if (f->target_met) {
    snprintf(buf, n,
             "the given metric is met: %.2f %% of the edges in range, worst "
             "quality %.3g",
             in, f->user.qual_min);
    return;
  }
  char why[160] = "";
  if (pa_stats_target_met(&f->used) && f->changed)
    snprintf(why, sizeof why, "limited by %s%s%s%s%s (the metric used: %.2f %% "
             "in range)",
             f->changed & PA_CHANGED_HMIN ? "-hmin" : "",
             (f->changed & PA_CHANGED_HMIN) && (f->changed & ~PA_CHANGED_HMIN)
                 ? ", " : "",
             f->changed & PA_CHANGED_HMAX ? "-hmax" : "",
             (f->changed & PA_CHANGED_HMAX) && (f->changed & PA_CHANGED_GRADATION)
                 ? ", " : "",
             f->changed & PA_CHANGED_GRADATION ? "the gradation (-hgrad)" : "",
             inu);
  else
    snprintf(why, sizeof why,
             "the remesher did not reach the metric it used either (%.2f %% "
             "in range, worst quality %.3g)",
             inu, f->used.qual_min);
  snprintf(buf, n,
           "the given metric is not met: %.2f %% of the edges in range "
           "(target %.0f %%), worst quality %.3g (target %g); %s",
           in, 100 * PA_TARGET_IN_RANGE, f->user.qual_min, PA_TARGET_QUALITY,
           why);
}
