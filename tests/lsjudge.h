/*
 * lsjudge.h -- an independent judge of level-set cuts, shared by
 * tests/unit/test_lscut.c and tests/mpi/test_lscut.c (static inline; the
 * including file provides CHECK from testutil.h).
 *
 * It evaluates the P1 interpolant phi_h of the input level set (on the
 * input mesh) at every vertex of the output by locating the vertex in an
 * input element (a bucket grid of the elements' boxes, barycentric
 * coordinates), and checks:
 *  - every output element lies on one side: the values of phi_h at its
 *    vertices are all <= tol (inside reference) or all >= -tol (outside);
 *  - the faces between an inside and an outside element are exactly the
 *    boundary entities of the interface reference, and phi_h is within tol
 *    of 0 at each of their vertices;
 *  - the inside volume against the volume of {phi_h < 0} computed element
 *    by element from the closed form of the distribution of a linear
 *    function over a simplex (a B-spline: the share of simplex T where
 *    s < 0 is sum_i (-s_i)_+^d / prod_{j != i} (s_j - s_i)), an algorithm
 *    the cut does not use.
 */
#ifndef PA_LSJUDGE_H
#define PA_LSJUDGE_H

#include "mesh/mesh.h"

/* Share of the simplex with vertex values s[0..d] where s < 0. Ties between
 * negative values are moved apart by a relative 1e-9 (the closed form
 * needs distinct values; the share is continuous in them). */
static inline double lsj_share_below(int d, const double *s0) {
  double s[4];
  int neg = 0, pos = 0;
  for (int i = 0; i <= d; i++) {
    s[i] = s0[i];
    neg += s[i] < 0;
    pos += s[i] > 0;
  }
  if (!neg) return 0;
  if (!pos) return 1;
  for (int i = 0; i <= d; i++)
    for (int j = 0; j < i; j++)
      if (s[i] == s[j]) s[i] += 1e-9 * (fabs(s[i]) + 1e-300) * (i + 1);
  double f = 0;
  for (int i = 0; i <= d; i++) {
    if (!(s[i] < 0)) continue;
    double num = pow(-s[i], d), den = 1;
    for (int j = 0; j <= d; j++)
      if (j != i) den *= s[j] - s[i];
    f += num / den;
  }
  return f;
}

/* Volume of {phi_h < 0} over the mesh (phi: one value per vertex). */
static inline double lsj_volume_below(const pa_mesh *m, const double *phi) {
  int d = m->dim;
  double v = 0;
  for (pa_idx e = 0; e < m->ne; e++) {
    const pa_idx *ev = m->elem + (size_t)(d + 1) * e;
    double s[4];
    for (int i = 0; i <= d; i++) s[i] = phi[ev[i]];
    v += fabs(pa_mesh_elem_volume(m, e)) * lsj_share_below(d, s);
  }
  return v;
}

/* A bucket grid over the input's elements (their bounding boxes), to find
 * the elements that may hold a point. */
typedef struct lsj_grid {
  const pa_mesh *m;
  int g;                 /* cells per axis */
  double lo[3], step[3];
  pa_idx *start, *elem;  /* CSR: the elements of each cell */
} lsj_grid;

static inline int lsj_cell(const lsj_grid *G, const double *x, int k) {
  int c = (int)floor((x[k] - G->lo[k]) / G->step[k]);
  return c < 0 ? 0 : c >= G->g ? G->g - 1 : c;
}

static inline void lsj_grid_init(lsj_grid *G, const pa_mesh *m) {
  int d = m->dim;
  G->m = m;
  G->g = (int)ceil(pow((double)m->ne / 4.0, 1.0 / d));
  if (G->g < 1) G->g = 1;
  double hi[3] = {-1e300, -1e300, -1e300};
  for (int k = 0; k < 3; k++) G->lo[k] = 1e300;
  for (pa_idx v = 0; v < m->nv; v++)
    for (int k = 0; k < d; k++) {
      G->lo[k] = fmin(G->lo[k], m->coord[(size_t)d * v + k]);
      hi[k] = fmax(hi[k], m->coord[(size_t)d * v + k]);
    }
  for (int k = 0; k < d; k++) {
    G->lo[k] -= 1e-9;
    G->step[k] = (hi[k] + 1e-9 - G->lo[k]) / G->g;
  }
  size_t ncell = 1;
  for (int k = 0; k < d; k++) ncell *= (size_t)G->g;
  G->start = calloc(ncell + 1, sizeof *G->start);
  for (int pass = 0; pass < 2; pass++) {
    size_t *fill = pass ? calloc(ncell, sizeof *fill) : NULL;
    for (pa_idx e = 0; e < m->ne; e++) {
      int clo[3] = {0, 0, 0}, chi[3] = {0, 0, 0};
      for (int k = 0; k < d; k++) {
        double l = 1e300, h = -1e300;
        for (int i = 0; i <= d; i++) {
          double c = m->coord[(size_t)d * m->elem[(size_t)(d + 1) * e + i] + k];
          l = fmin(l, c - 1e-9);
          h = fmax(h, c + 1e-9);
        }
        double pl[3] = {0, 0, 0}, ph[3] = {0, 0, 0};
        pl[k] = l;
        ph[k] = h;
        clo[k] = lsj_cell(G, pl, k);
        chi[k] = lsj_cell(G, ph, k);
      }
      for (int i = clo[0]; i <= chi[0]; i++)
        for (int j = clo[1]; j <= chi[1]; j++)
          for (int l = clo[2]; l <= chi[2]; l++) {
            size_t c = ((size_t)l * G->g + j) * G->g + i;
            if (!pass) G->start[c + 1]++;
            else G->elem[G->start[c] + fill[c]++] = e;
          }
    }
    if (!pass) {
      for (size_t c = 0; c < ncell; c++) G->start[c + 1] += G->start[c];
      G->elem = malloc(sizeof *G->elem * (G->start[ncell] ? G->start[ncell] : 1));
    }
    free(fill);
  }
}

static inline void lsj_grid_free(lsj_grid *G) {
  free(G->start);
  free(G->elem);
}

/* phi_h at point x: the interpolant in the input element holding it (the
 * largest smallest barycentric coordinate over the candidates); NAN if x
 * lies in none (within 1e-9). */
static inline double lsj_eval_grid(const lsj_grid *G, const double *phi,
                                   const double *x) {
  const pa_mesh *in = G->m;
  int d = in->dim;
  size_t c = 0;
  for (int k = d - 1; k >= 0; k--) c = c * G->g + (size_t)lsj_cell(G, x, k);
  double best = -1, val = NAN;
  for (pa_idx q = G->start[c]; q < G->start[c + 1]; q++) {
    pa_idx e = G->elem[q];
    const pa_idx *ev = in->elem + (size_t)(d + 1) * e;
    const double *p[4];
    for (int i = 0; i <= d; i++) p[i] = in->coord + (size_t)d * ev[i];
    double w[4], vol = pa__simplex_volume(d, p), wmin = 1e300;
    for (int i = 0; i <= d; i++) {
      const double *r[4] = {p[0], p[1], p[2], d == 3 ? p[3] : NULL};
      r[i] = x;
      w[i] = pa__simplex_volume(d, r) / vol;
      wmin = fmin(wmin, w[i]);
    }
    if (wmin > best) {
      best = wmin;
      val = 0;
      for (int i = 0; i <= d; i++) val += w[i] * phi[ev[i]];
    }
  }
  return best > -1e-9 ? val : NAN;
}

typedef struct lsj_result {
  int bad_side;    /* elements with vertices on both sides */
  int bad_iface;   /* faces between the sides that are not interface
                      entities, or interface entities that are not such */
  int off_zero;    /* interface vertices with |phi_h| > tol */
  int lost;        /* output vertices outside the input */
  pa_idx niface;
  double vol_in;   /* inside elements */
  double vol_all;
} lsj_result;

/* Judge out (the cut of in by phi, references rin, rex, riface) with
 * tolerance tol on phi_h. */
static inline void lsj_judge(const pa_mesh *in, const double *phi, pa_mesh *out,
                      int32_t rin, int32_t rex, int32_t riface, double tol,
                      lsj_result *r) {
  int d = out->dim, nve = d + 1;
  memset(r, 0, sizeof *r);
  double *ph = malloc(sizeof(double) * (size_t)(out->nv ? out->nv : 1));
  lsj_grid G;
  lsj_grid_init(&G, in);
  for (pa_idx v = 0; v < out->nv; v++) {
    ph[v] = lsj_eval_grid(&G, phi, out->coord + (size_t)d * v);
    r->lost += isnan(ph[v]);
  }
  lsj_grid_free(&G);
  for (pa_idx e = 0; e < out->ne; e++) {
    const pa_idx *ev = out->elem + (size_t)nve * e;
    double lo = 1e300, hi = -1e300;
    for (int i = 0; i < nve; i++) {
      lo = fmin(lo, ph[ev[i]]);
      hi = fmax(hi, ph[ev[i]]);
    }
    double vol = fabs(pa_mesh_elem_volume(out, e));
    r->vol_all += vol;
    if (out->eref[e] == rin) {
      r->vol_in += vol;
      r->bad_side += !(hi <= tol);
    } else if (out->eref[e] == rex) {
      r->bad_side += !(lo >= -tol);
    }
  }
  /* faces between the sides against the interface entities */
  const pa_idx *adja;
  if (pa_mesh_build_adjacency(out, &adja) != PA_SUCCESS) {
    r->bad_iface = -1;
    free(ph);
    return;
  }
  pa_idx nfaces = 0;
  for (pa_idx e = 0; e < out->ne; e++)
    for (int i = 0; i < nve; i++) {
      pa_idx o = adja[(size_t)nve * e + i];
      if (o < 0) continue;
      pa_idx f = o / nve;
      int32_t a = out->eref[e], b = out->eref[f];
      if (!((a == rin && b == rex) || (a == rex && b == rin))) continue;
      if (a != rin) continue; /* each face once, from its inside element */
      nfaces++;
      pa_idx fv[3], bi;
      pa__elem_face(out, e, i, fv);
      if (pa_mesh_find_bdry(out, fv, &bi) != PA_SUCCESS || bi < 0 ||
          out->bref[bi] != riface)
        r->bad_iface++;
    }
  for (pa_idx b = 0; b < out->nb; b++) {
    if (out->bref[b] != riface) continue;
    r->niface++;
    for (int k = 0; k < d; k++)
      r->off_zero += !(fabs(ph[out->bdry[(size_t)d * b + k]]) <= tol);
  }
  if (r->niface != nfaces) r->bad_iface += (int)labs((long)(r->niface - nfaces));
  free(ph);
}

#endif /* PA_LSJUDGE_H */
