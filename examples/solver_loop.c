/*
 * solver_loop.c -- a solver that links padapt and adapts its mesh in a loop
 * (docs/guide/solver-loop.md): solve -> Hessian metric of the solution ->
 * parallel adaptation carrying the solution -> solve again, starting the
 * solver from the carried solution.
 *
 *   mpiexec -n P ./solver_loop [ITERATIONS]       (default 4)
 *
 * The solver is a small P1 finite-element Poisson solver (conjugate
 * gradient, Jacobi preconditioner) on rank 0, as a sequential solver
 * would run beside a parallel remesher: -Lap u = f on the unit square with
 * the exact solution of Mitchell's "wave front" benchmark,
 * u = atan(ALPHA (r - R0)), r the distance to (-0.05, -0.05), a circular
 * front of width about 1/ALPHA. Each iteration: rank 0 solves and attaches
 * the solution as the vertex field "u"; every rank then takes part in
 * distributing the mesh, building the metric from "u"
 * (pa_dmesh_metric_from_hessian) at a complexity doubling from one
 * iteration to the next, adapting (pa_dmesh_adapt carries "u") and
 * gathering the new mesh, with "u" interpolated on it, onto rank 0, whose
 * CG starts from it. Prints per iteration the vertices, the L2 error and
 * the CG iterations from the carried solution and from zero. Exit status
 * 0 when the error fell at every iteration and the carried start saved CG
 * iterations every time; built and run at 1 and 2 processes by the tests
 * (example.solver_loop).
 */
#include <padapt.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define CALL(call)                                                             \
  do {                                                                         \
    st = (call);                                                               \
    if (st != PA_SUCCESS) {                                                    \
      fprintf(stderr, "rank %d: %s: %s (%s)\n", rank, #call, pa_last_error(),  \
              pa_status_string(st));                                           \
      goto cleanup;                                                            \
    }                                                                          \
  } while (0)

/* The wave front: steep (ALPHA) enough that a uniform mesh of the sizes
 * used here misses it, smooth enough to converge at second order. */
#define ALPHA 50.0
#define R0 0.7
#define XC (-0.05)
#define YC (-0.05)
/* The complexity of the first metric, doubled at each iteration. */
#define TARGET0 1000.0
/* CG stops at this relative residual: well below the discretisation
 * error at these sizes. */
#define CG_TOL 1e-10

static double exact(const double *x) {
  double r = hypot(x[0] - XC, x[1] - YC);
  return atan(ALPHA * (r - R0));
}

/* f = -Lap u for the radial u above: -(u'' + u'/r). */
static double source(const double *x) {
  double r = hypot(x[0] - XC, x[1] - YC), s = ALPHA * (r - R0);
  double d = 1 + s * s;
  return -(-2 * ALPHA * ALPHA * ALPHA * (r - R0) / (d * d) + ALPHA / d / r);
}

/* The P1 system of mesh in compressed rows (diagonal included), the load
 * vector with f lumped at the vertices, and the Dirichlet vertices. */
typedef struct p1_system {
  pa_idx n;
  size_t *rowptr;
  pa_idx *col;
  double *val, *rhs;
  char *dirichlet;
} p1_system;

static void p1_free(p1_system *s) {
  free(s->rowptr);
  free(s->col);
  free(s->val);
  free(s->rhs);
  free(s->dirichlet);
  memset(s, 0, sizeof *s);
}

static int cmp_entry(const void *a, const void *b) {
  const pa_idx *p = a, *q = b;
  return p[0] != q[0] ? (p[0] > q[0]) - (p[0] < q[0])
                      : (p[1] > q[1]) - (p[1] < q[1]);
}

/* Assemble the stiffness matrix (triplets sorted and merged). */
static int p1_assemble(pa_mesh *mesh, p1_system *s) {
  pa_idx nv = pa_mesh_nvert(mesh), ne = pa_mesh_nelem(mesh);
  const pa_idx *tri = pa_mesh_elems(mesh), *edge = pa_mesh_bdrys(mesh);
  const double *x = pa_mesh_coords(mesh);
  size_t nt = 9 * (size_t)ne;
  pa_idx *ij = malloc(sizeof(pa_idx) * 3 * nt); /* i, j, index of value */
  double *kv = malloc(sizeof(double) * nt);
  memset(s, 0, sizeof *s);
  s->n = nv;
  s->rowptr = calloc((size_t)nv + 1, sizeof(size_t));
  s->col = malloc(sizeof(pa_idx) * nt);
  s->val = malloc(sizeof(double) * nt);
  s->rhs = calloc((size_t)nv, sizeof(double));
  s->dirichlet = calloc((size_t)nv, 1);
  if (!ij || !kv || !s->rowptr || !s->col || !s->val || !s->rhs ||
      !s->dirichlet) {
    free(ij);
    free(kv);
    return 1;
  }
  for (pa_idx e = 0; e < ne; e++) {
    const pa_idx *v = tri + 3 * (size_t)e;
    double g[3][2]; /* gradients of the hat functions, times 2 area */
    for (int k = 0; k < 3; k++) {
      const double *a = x + 2 * (size_t)v[(k + 1) % 3],
                   *b = x + 2 * (size_t)v[(k + 2) % 3];
      g[k][0] = a[1] - b[1];
      g[k][1] = b[0] - a[0];
    }
    double area = 0.5 * (g[2][1] * g[1][0] - g[2][0] * g[1][1]);
    area = fabs(area);
    for (int k = 0; k < 3; k++) {
      s->rhs[v[k]] += area / 3 * source(x + 2 * (size_t)v[k]);
      for (int l = 0; l < 3; l++) {
        size_t t = 9 * (size_t)e + 3 * k + l;
        ij[3 * t] = v[k];
        ij[3 * t + 1] = v[l];
        ij[3 * t + 2] = (pa_idx)t;
        kv[t] = (g[k][0] * g[l][0] + g[k][1] * g[l][1]) / (4 * area);
      }
    }
  }
  qsort(ij, nt, 3 * sizeof(pa_idx), cmp_entry);
  size_t m = 0;
  for (size_t t = 0; t < nt; t++) {
    const pa_idx *p = ij + 3 * t;
    if (t && p[0] == p[-3] && p[1] == p[-2]) {
      s->val[m - 1] += kv[p[2]];
    } else {
      s->col[m] = p[1];
      s->val[m++] = kv[p[2]];
      s->rowptr[p[0] + 1]++;
    }
  }
  for (pa_idx i = 0; i < nv; i++)
    s->rowptr[i + 1] += s->rowptr[i];
  for (pa_idx b = 0; b < pa_mesh_nbdry(mesh); b++)
    s->dirichlet[edge[2 * (size_t)b]] = s->dirichlet[edge[2 * (size_t)b + 1]] =
        1;
  free(ij);
  free(kv);
  return 0;
}

/* y = A x on the free vertices (Dirichlet rows and columns removed). */
static void p1_apply(const p1_system *s, const double *x, double *y) {
  for (pa_idx i = 0; i < s->n; i++) {
    double a = 0;
    if (!s->dirichlet[i])
      for (size_t k = s->rowptr[i]; k < s->rowptr[i + 1]; k++)
        if (!s->dirichlet[s->col[k]]) a += s->val[k] * x[s->col[k]];
    y[i] = a;
  }
}

/* Solve for u (in: the start, with the boundary values; out: the
 * solution) by Jacobi-preconditioned CG on the free vertices; returns the
 * iterations, -1 on failure. */
static int p1_solve(const p1_system *s, double *u) {
  pa_idx n = s->n;
  double *r = malloc(sizeof(double) * n), *z = malloc(sizeof(double) * n),
         *p = malloc(sizeof(double) * n), *q = malloc(sizeof(double) * n),
         *dinv = malloc(sizeof(double) * n);
  int it = -1;
  if (!r || !z || !p || !q || !dinv) goto done;
  /* r = b - A u, the Dirichlet values moved to the right-hand side */
  for (pa_idx i = 0; i < n; i++) {
    double a = s->rhs[i], d = 1;
    for (size_t k = s->rowptr[i]; k < s->rowptr[i + 1]; k++) {
      a -= s->val[k] * u[s->col[k]];
      if (s->col[k] == i) d = s->val[k];
    }
    r[i] = s->dirichlet[i] ? 0 : a;
    dinv[i] = 1 / d;
  }
  double bnorm = 0, rz = 0;
  for (pa_idx i = 0; i < n; i++)
    if (!s->dirichlet[i]) bnorm += s->rhs[i] * s->rhs[i];
  bnorm = sqrt(bnorm);
  for (pa_idx i = 0; i < n; i++) {
    z[i] = dinv[i] * r[i];
    p[i] = z[i];
    rz += r[i] * z[i];
  }
  for (it = 0; it < 100 * n; it++) {
    double rr = 0;
    for (pa_idx i = 0; i < n; i++)
      rr += r[i] * r[i];
    if (sqrt(rr) <= CG_TOL * bnorm) break;
    p1_apply(s, p, q);
    double pq = 0;
    for (pa_idx i = 0; i < n; i++)
      pq += p[i] * q[i];
    double alpha = rz / pq, rz1 = 0;
    for (pa_idx i = 0; i < n; i++) {
      u[i] += alpha * p[i];
      r[i] -= alpha * q[i];
      z[i] = dinv[i] * r[i];
      rz1 += r[i] * z[i];
    }
    for (pa_idx i = 0; i < n; i++)
      p[i] = z[i] + rz1 / rz * p[i];
    rz = rz1;
  }
done:
  free(r);
  free(z);
  free(p);
  free(q);
  free(dinv);
  return it;
}

/* The L2 error of u (vertex-lumped quadrature). */
static double l2_error(pa_mesh *mesh, const double *u) {
  const pa_idx *tri = pa_mesh_elems(mesh);
  const double *x = pa_mesh_coords(mesh);
  double e2 = 0;
  for (pa_idx e = 0; e < pa_mesh_nelem(mesh); e++) {
    double area = pa_mesh_elem_volume(mesh, e), s = 0;
    for (int k = 0; k < 3; k++) {
      pa_idx v = tri[3 * (size_t)e + k];
      double d = u[v] - exact(x + 2 * (size_t)v);
      s += d * d;
    }
    e2 += area * s / 3;
  }
  return sqrt(e2);
}

/* Rank 0: solve on mesh from the start u0 (NULL: zero inside), report, and
 * leave the solution as the mesh's only vertex field "u". Returns the CG
 * iterations (and *it0 those from zero, *err the error), -1 on failure. */
static int solve(pa_mesh *mesh, const double *u0, int *it0, double *err) {
  p1_system s = {0};
  pa_idx nv = pa_mesh_nvert(mesh);
  double *u = malloc(sizeof(double) * nv), *z = malloc(sizeof(double) * nv);
  const double *x = pa_mesh_coords(mesh);
  int it = -1;
  if (!u || !z || p1_assemble(mesh, &s)) goto done;
  for (pa_idx i = 0; i < nv; i++) {
    double g = exact(x + 2 * (size_t)i);
    z[i] = s.dirichlet[i] ? g : 0;
    u[i] = s.dirichlet[i] ? g : u0 ? u0[i] : 0;
  }
  it = p1_solve(&s, u);
  *it0 = u0 ? p1_solve(&s, z) : it;
  *err = l2_error(mesh, u);
  while (pa_mesh_nfield(mesh) > 0)
    pa_mesh_remove_field(mesh, 0);
  if (pa_mesh_add_field(mesh, "u", 1, u) != PA_SUCCESS) it = -1;
done:
  p1_free(&s);
  free(u);
  free(z);
  return it;
}

int main(int argc, char **argv) {
  int rank = 0, rc = 1, niter = argc > 1 ? atoi(argv[1]) : 4;
  pa_status st = PA_SUCCESS;
  pa_mesh *mesh = NULL;
  pa_dmesh *dm = NULL;
  double prev_err = INFINITY;
  int ok = 1;
  MPI_Init(&argc, &argv);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);

  if (rank == 0) {
    CALL(pa_mesh_generate_box(2, 16, &mesh));
    int it0;
    double err;
    if (solve(mesh, NULL, &it0, &err) < 0) ok = 0;
    printf("start: %d vertices, L2 error %.3e\n", (int)pa_mesh_nvert(mesh),
           err);
    prev_err = err;
  }
  MPI_Bcast(&ok, 1, MPI_INT, 0, MPI_COMM_WORLD);
  if (!ok) goto cleanup;

  double target = TARGET0;
  for (int k = 1; k <= niter; k++, target *= 2) {
    /* Collective from here: the mesh and its field "u" spread over the
     * ranks with two ghost layers (the Hessian recovery needs the 2-ring
     * of every owned vertex), the metric from "u" (field 0, component 0),
     * the adaptation, which interpolates "u" at the new vertices. */
    pa_metric_hessian_opts mo;
    pa_metric_hessian_opts_default(&mo); /* L2 norm, hgrad 1.3 */
    mo.target = target;
    pa_adapt_opts ao;
    pa_adapt_report ar;
    pa_adapt_opts_default(&ao);
    CALL(pa_dmesh_distribute(MPI_COMM_WORLD, 0, mesh, 2, &dm));
    CALL(pa_dmesh_metric_from_hessian(dm, 0, 0, &mo));
    CALL(pa_dmesh_adapt(dm, &ao, &ar));
    pa_mesh_destroy(mesh);
    mesh = NULL;
    CALL(pa_dmesh_gather(dm, 0, &mesh)); /* metric and "u" come along */
    pa_dmesh_destroy(dm);
    dm = NULL;

    if (rank == 0) {
      double *carried = NULL;
      int it0 = 0, it;
      double err = 0;
      pa_mesh_field(mesh, 0, NULL, NULL, &carried);
      double *start = malloc(sizeof(double) * pa_mesh_nvert(mesh));
      if (start) memcpy(start, carried, sizeof(double) * pa_mesh_nvert(mesh));
      it = start ? solve(mesh, start, &it0, &err) : -1;
      free(start);
      printf("iteration %d: complexity %.0f, %d vertices, L2 error %.3e, CG "
             "%d iterations from the carried solution, %d from zero\n",
             k, target, (int)pa_mesh_nvert(mesh), err, it, it0);
      if (it < 0 || !(err < prev_err) || !(it < it0)) ok = 0;
      prev_err = err;
    }
    MPI_Bcast(&ok, 1, MPI_INT, 0, MPI_COMM_WORLD);
    if (!ok) goto cleanup;
  }
  rc = 0;

cleanup:
  pa_dmesh_destroy(dm);
  pa_mesh_destroy(mesh);
  if (pa_memory_current() != 0) {
    fprintf(stderr, "rank %d: %zu bytes still allocated by padapt\n", rank,
            pa_memory_current());
    rc = 1;
  }
  MPI_Allreduce(MPI_IN_PLACE, &rc, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
  MPI_Finalize();
  return rc;
}
