/*
 * cmd_metric.c -- `padapt metric ...` and `padapt levelset ...`: the metric
 * toolbox on the command line.
 *
 *   padapt metric NAME[:h] IN OUT.sol          a built-in analytic metric
 *   padapt metric hessian IN -field U.sol [-comp K] (-target N | -err E)
 *                 [-p P] [-hmin H] [-hmax H] [-hgrad G] [-recovery lsq|l2]
 *                 OUT.sol                      the Lp metric of a field
 *   padapt metric levelset IN -ls PHI.sol -eps E -hmin H -hmax H
 *                 [-band W] [-hgrad G] OUT.sol the metric of a zero set
 *   padapt metric intersect IN A.sol B.sol OUT.sol
 *   padapt metric scale IN M.sol -target N OUT.sol
 *   padapt metric clamp IN M.sol [-hmin H] [-hmax H] OUT.sol
 *   padapt metric grade IN M.sol [-hgrad G] [-hgradreq G] OUT.sol
 *   padapt metric complexity IN M.sol          prints C and the element count
 *   padapt levelset NAME IN OUT.sol            signed distance to a surface
 *
 * Under mpiexec with more than one process (or with a distributed set as
 * IN), hessian, levelset and complexity run on the distributed mesh (overlap
 * 2: the recovery stencils of the owned vertices are complete), with halo
 * exchanges at the partition frontiers; the result is gathered into OUT.sol.
 * The other operations are vertex by vertex and run on rank 0.
 */
#include "cli.h"

#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

/* The parsed arguments of a metric subcommand. The options go straight
 * into the library's options structs, filled first by their
 * *_opts_default: every default is the library's. */
typedef struct metric_args {
  const char *cmd; /* "metric OP", for the messages */
  const char *in, *field, *ls, *files[3], *out;
  const char *pos[6]; /* the positional arguments */
  int npos, nfile;
  int comp; /* -comp K, 1-based (0: a scalar field) */
  pa_metric_hessian_opts hess;  /* hessian */
  pa_metric_levelset_opts lset; /* levelset */
  pa_remesh_opts remesh;        /* clamp: hmin, hmax; grade: hgrad, hgradreq */
  double target;                /* scale */
} metric_args;

#define M(f) offsetof(metric_args, f)
#define POSITIVE "a positive number"

static int opt_recovery(const pa_cli *cli, const pa_cli_spec *s,
                        const char *name, char **val, void *args) {
  metric_args *a = args;
  if (!val[0] || (strcmp(val[0], "lsq") && strcmp(val[0], "l2")))
    return pa_cli_error(cli, "%s: %s needs lsq or l2, got '%s'", s->cmd, name,
                        val[0] ? val[0] : "nothing");
  a->hess.recovery = !strcmp(val[0], "l2") ? PA_RECOVER_L2 : PA_RECOVER_LSQ;
  return 0;
}

/* The help of the subcommands, at the end of every table (the synopsis of
 * -h lists the options). */
#define METRIC_HELP                                                          \
  {.kind = PA_CLI_HELP, .label = "hessian",                                  \
   .help = "the Lp-optimal metric of field U (component K of a vector\n"     \
           "field), scaled to the complexity N (about N/2 vertices in\n"     \
           "2D) or to the interpolation error E; p = "                       \
           PA_CLI_TEXT(PA_DEFAULT_LP) " by default, 0\n"                     \
           "for L-infinity; hgrad " PA_CLI_TEXT(PA_DEFAULT_HGRAD)            \
           " by default (-1: none)"},                                        \
      {.kind = PA_CLI_HELP, .label = "levelset",                             \
       .help = "the metric capturing the zero set of PHI within E:\n"        \
               "size hmin across it, sqrt(8 E / curvature) along it"},       \
      {.kind = PA_CLI_HELP, .label = "complexity",                           \
       .help = "prints the integral of sqrt(det M) and the number of\n"      \
               "unit elements it asks for"},                                 \
  {                                                                          \
    .kind = PA_CLI_END                                                       \
  }

#define OPT_POS(name, field)                                                 \
  {.names = name, .kind = PA_CLI_POS, .at = M(field), .want = POSITIVE}
#define OPT_NUM(name, field)                                                 \
  {.names = name, .kind = PA_CLI_NUM, .at = M(field), .want = "a number",    \
   .lo = -INFINITY, .hi = INFINITY}
#define OPT_COMP                                                             \
  {.names = "-comp", .kind = PA_CLI_INT, .at = M(comp),                      \
   .want = "a component number >= 1", .lo = 1, .hi = 1e9}

/* The options of each subcommand. */
static const pa_cli_opt hessian_opts[] = {
    {.names = "-field", .kind = PA_CLI_STR, .at = M(field),
     .want = "a .sol file"},
    OPT_COMP,
    {.names = "-recovery", .kind = PA_CLI_FN, .fn = opt_recovery, .nval = 1},
    OPT_POS("-target", hess.target),
    OPT_POS("-err", hess.err),
    OPT_NUM("-p", hess.p),
    OPT_POS("-hmin", hess.hmin),
    OPT_POS("-hmax", hess.hmax),
    OPT_NUM("-hgrad", hess.hgrad),
    METRIC_HELP};
static const pa_cli_opt levelset_opts[] = {
    {.names = "-ls", .kind = PA_CLI_STR, .at = M(ls), .want = "a .sol file"},
    OPT_COMP,
    OPT_POS("-eps", lset.eps),
    OPT_POS("-hmin", lset.hmin),
    OPT_POS("-hmax", lset.hmax),
    OPT_NUM("-band", lset.band),
    OPT_NUM("-hgrad", lset.hgrad),
    METRIC_HELP};
static const pa_cli_opt scale_opts[] = {OPT_POS("-target", target),
                                        METRIC_HELP};
static const pa_cli_opt clamp_opts[] = {OPT_POS("-hmin", remesh.hmin),
                                        OPT_POS("-hmax", remesh.hmax),
                                        METRIC_HELP};
static const pa_cli_opt grade_opts[] = {OPT_NUM("-hgrad", remesh.hgrad),
                                        OPT_NUM("-hgradreq", remesh.hgradreq),
                                        METRIC_HELP};
static const pa_cli_opt no_opts[] = {METRIC_HELP};

/* The subcommands: positional .sol files before OUT, whether OUT comes,
 * the options. */
typedef struct metric_op {
  const char *name;
  int nfiles, out;
  const pa_cli_opt *opt;
} metric_op;
static const metric_op metric_ops[] = {
    {"hessian", 0, 1, hessian_opts}, {"levelset", 0, 1, levelset_opts},
    {"intersect", 2, 1, no_opts},    {"scale", 1, 1, scale_opts},
    {"clamp", 1, 1, clamp_opts},     {"grade", 1, 1, grade_opts},
    {"complexity", 1, 0, no_opts}};

static int metric_positional(const pa_cli *cli, const char *arg,
                             void *args) {
  metric_args *a = args;
  if (a->npos == 6) return pa_cli_error(cli, "%s: too many arguments", a->cmd);
  a->pos[a->npos++] = arg;
  return 0;
}

static const pa_cli_spec metric_spec = {
    .cmd = "metric",
    .usage =
        "usage: padapt metric NAME[:h] IN OUT.sol\n"
        "       padapt metric hessian IN -field U.sol [-comp K] (-target N | "
        "-err E)\n"
        "                     [-p P] [-hmin H] [-hmax H] [-hgrad G]\n"
        "                     [-recovery lsq|l2] OUT.sol\n"
        "       padapt metric levelset IN -ls PHI.sol -eps E -hmin H -hmax H\n"
        "                     [-band W] [-hgrad G] OUT.sol\n"
        "       padapt metric intersect IN A.sol B.sol OUT.sol\n"
        "       padapt metric scale IN M.sol -target N OUT.sol\n"
        "       padapt metric clamp IN M.sol [-hmin H] [-hmax H] OUT.sol\n"
        "       padapt metric grade IN M.sol [-hgrad G] [-hgradreq G] "
        "OUT.sol\n"
        "       padapt metric complexity IN M.sol\n",
    .width = 10,
    .opt = no_opts,
    .positional = metric_positional};

/* Parse argv[1..] of subcommand op (argv[0] its name) into a. Returns 0, 1
 * after an error, -1 after the help. */
static int parse(const pa_cli *cli, int argc, char **argv, const metric_op *op,
                 metric_args *a) {
  memset(a, 0, sizeof *a);
  pa_metric_hessian_opts_default(&a->hess);
  pa_metric_levelset_opts_default(&a->lset);
  pa_remesh_opts_default(&a->remesh);
  char cmd[64];
  snprintf(cmd, sizeof cmd, "metric %s", argv[0]);
  pa_cli_spec spec = metric_spec;
  spec.cmd = a->cmd = cmd;
  spec.help_cmd = "metric";
  spec.opt = op->opt;
  int rc = pa_cli_parse(cli, &spec, argc, argv, a);
  if (rc) return rc;
  int npos = a->npos, nfiles = op->nfiles, has_out = op->out;
  if (npos != 1 + nfiles + has_out) {
    pa_cli_error(cli, "%s: expected %d file arguments, got %d", cmd,
                 1 + nfiles + has_out, npos);
    if (cli->rank == 0) pa_cli_help(&metric_spec, stderr);
    return 1;
  }
  a->in = a->pos[0];
  for (int k = 0; k < nfiles; k++)
    a->files[k] = a->pos[1 + k];
  a->nfile = nfiles;
  a->out = has_out ? a->pos[npos - 1] : NULL;
  pa_cli_io io = {.in = {a->in, a->files[0], a->files[1], a->field, a->ls},
                  .out = {a->out}};
  if (pa_cli_check_io(cli, cmd, &io)) return 1;
  double hmin = op->opt == hessian_opts    ? a->hess.hmin
                : op->opt == levelset_opts ? a->lset.hmin
                                           : a->remesh.hmin;
  double hmax = op->opt == hessian_opts    ? a->hess.hmax
                : op->opt == levelset_opts ? a->lset.hmax
                                           : a->remesh.hmax;
  if (hmin > 0 && hmax > 0 && hmin > hmax)
    return pa_cli_error(cli, "%s: -hmin (%g) is larger than -hmax (%g)", cmd,
                        hmin, hmax);
  return 0;
}

/* One scalar field of a .sol file on a mesh of nv vertices: field 1 (its
 * component comp, 1-based, of a vector or tensor field). *vals malloc'ed;
 * *stride 1. The error names the file. */
static pa_status read_scalar(const char *path, pa_idx nv, int comp,
                             double **vals) {
  pa_sol *sol = NULL;
  char msg[700];
  pa_status st = pa_sol_read(path, &sol);
  if (st) return st;
  pa_sol_kind kind;
  int nc = 0;
  double *v = NULL;
  st = pa_sol_field(sol, 0, &kind, &nc, &v);
  if (st == PA_SUCCESS && pa_sol_nvert(sol) != nv) {
    snprintf(msg, sizeof msg, "%s: %d values, but the mesh has %d vertices",
             pa_sol_origin(sol), (int)pa_sol_nvert(sol), (int)nv);
    st = pa_set_error(PA_ERR_FORMAT, "%s", msg);
  } else if (st == PA_SUCCESS && (comp > nc || (nc > 1 && comp == 0))) {
    snprintf(msg, sizeof msg,
             "%s: its first field has %d components; choose one with -comp "
             "(1 to %d)",
             path, nc, nc);
    st = pa_set_error(PA_ERR_ARG, "%s", msg);
  }
  if (st == PA_SUCCESS) {
    *vals = malloc(sizeof(double) * (nv ? (size_t)nv : 1));
    if (!*vals) st = pa_set_error(PA_ERR_MEMORY, "out of memory");
    for (pa_idx i = 0; i < nv && *vals && st == PA_SUCCESS; i++) {
      (*vals)[i] = v[(size_t)nc * i + (comp ? comp - 1 : 0)];
      if (!isfinite((*vals)[i])) {
        snprintf(msg, sizeof msg, "%s: the value at vertex %d is not a number",
                 path, (int)i + 1);
        st = pa_set_error(PA_ERR_FORMAT, "%s", msg);
      }
    }
    if (st) {
      free(*vals);
      *vals = NULL;
    }
  }
  pa_sol_destroy(sol);
  return st;
}

/* A metric value as a full tensor (a size h: I / h^2). */
static void as_tensor(int dim, int nc, const double *m, double *t) {
  int nt = dim == 2 ? 3 : 6;
  if (nc == nt) {
    memcpy(t, m, sizeof(double) * nt);
    return;
  }
  for (int k = 0; k < nt; k++)
    t[k] = 0;
  t[0] = t[2] = 1.0 / (m[0] * m[0]);
  if (dim == 3) t[5] = t[0];
}

/* Attach met (ncomp per vertex) as the mesh's metric and write it to path. */
static pa_status write_metric(pa_mesh *mesh, int ncomp, const double *met,
                              const char *path) {
  pa_sol *sol = NULL;
  pa_status st = pa_mesh_set_metric(mesh, ncomp, met);
  if (st == PA_SUCCESS) st = pa_mesh_metric_to_sol(mesh, 0, &sol);
  if (st == PA_SUCCESS) st = pa_sol_write(sol, path);
  pa_sol_destroy(sol);
  return st;
}

/* Print a metric's complexity and the unit elements it asks for. */
static void print_complexity(int dim, double c, const char *what) {
  /* unit simplices: area sqrt(3)/4, volume sqrt(2)/12 */
  double ne = dim == 2 ? c * 4 / sqrt(3.0) : c * 12 / sqrt(2.0);
  printf("%s: complexity %.6g (about %.0f unit %s, %.0f vertices)\n", what, c,
         ne, dim == 2 ? "triangles" : "tetrahedra",
         dim == 2 ? c * 4 / sqrt(3.0) / 2 : ne / 5.5);
}

/* The operations on a metric read from files (vertex by vertex, rank 0). */
static pa_status run_ops(const pa_cli *cli, const char *op, pa_mesh *mesh,
                         const metric_args *a) {
  pa_status st = PA_SUCCESS;
  double *out = NULL;
  int d = pa_mesh_dim(mesh);
  pa_idx nv = pa_mesh_nvert(mesh);
  (void)cli;
  st = pa_cli_attach_metric(mesh, a->files[0]);
  if (st) return st;
  int nc = pa_mesh_metric_ncomp(mesh);
  if (!strcmp(op, "intersect")) {
    pa_mesh *m2 = NULL;
    st = pa_mesh_copy(mesh, &m2);
    if (st == PA_SUCCESS) st = pa_cli_attach_metric(m2, a->files[1]);
    if (st == PA_SUCCESS) {
      /* a size and a tensor: both as tensors */
      int n1 = pa_mesh_metric_ncomp(mesh), n2 = pa_mesh_metric_ncomp(m2);
      int nt = n1 == n2 ? n1 : (d == 2 ? 3 : 6);
      double *ta = malloc(sizeof(double) * nt * (nv ? nv : 1));
      double *tb = malloc(sizeof(double) * nt * (nv ? nv : 1));
      out = malloc(sizeof(double) * nt * (nv ? nv : 1));
      if (!ta || !tb || !out)
        st = pa_set_error(PA_ERR_MEMORY, "out of memory");
      for (pa_idx v = 0; st == PA_SUCCESS && v < nv; v++) {
        const double *x = pa_mesh_metric(mesh) + (size_t)n1 * v;
        const double *y = pa_mesh_metric(m2) + (size_t)n2 * v;
        if (nt == 1) {
          ta[v] = x[0];
          tb[v] = y[0];
          continue;
        }
        as_tensor(d, n1, x, ta + (size_t)nt * v);
        as_tensor(d, n2, y, tb + (size_t)nt * v);
      }
      if (st == PA_SUCCESS)
        st = pa_metric_intersect_all(d, nt, nv, ta, tb, out);
      if (st == PA_SUCCESS) st = write_metric(mesh, nt, out, a->out);
      free(ta);
      free(tb);
    }
    pa_mesh_destroy(m2);
  } else if (!strcmp(op, "scale")) {
    st = pa_metric_scale_complexity(mesh, nc, pa_mesh_metric(mesh), a->target);
    if (st == PA_SUCCESS)
      st = write_metric(mesh, nc, pa_mesh_metric(mesh), a->out);
  } else if (!strcmp(op, "clamp")) {
    st = pa_mesh_metric_clamp(mesh, a->remesh.hmin, a->remesh.hmax);
    if (st == PA_SUCCESS)
      st = write_metric(mesh, nc, pa_mesh_metric(mesh), a->out);
  } else if (!strcmp(op, "grade")) {
    st = pa_mesh_metric_grade(mesh, a->remesh.hgrad, a->remesh.hgradreq);
    if (st == PA_SUCCESS)
      st = write_metric(mesh, nc, pa_mesh_metric(mesh), a->out);
  } else { /* complexity */
    double c = 0;
    st = pa_metric_complexity(mesh, nc, pa_mesh_metric(mesh), &c);
    if (st == PA_SUCCESS) print_complexity(d, c, a->files[0]);
  }
  free(out);
  return st;
}

/* hessian or levelset on rank 0's whole mesh. */
static pa_status run_field(const char *op, pa_mesh *mesh,
                           const metric_args *a) {
  pa_status st;
  int d = pa_mesh_dim(mesh), nt = d == 2 ? 3 : 6;
  pa_idx nv = pa_mesh_nvert(mesh);
  double *u = NULL, *met = malloc(sizeof(double) * nt * (nv ? nv : 1));
  if (!met) return pa_set_error(PA_ERR_MEMORY, "out of memory");
  if (!strcmp(op, "hessian")) {
    st = read_scalar(a->field, nv, a->comp, &u);
    if (st == PA_SUCCESS) st = pa_metric_from_hessian(mesh, u, 1, &a->hess, met);
  } else {
    st = read_scalar(a->ls, nv, a->comp, &u);
    if (st == PA_SUCCESS) st = pa_metric_from_levelset(mesh, u, &a->lset, met);
  }
  if (st == PA_SUCCESS) st = write_metric(mesh, nt, met, a->out);
  if (st == PA_SUCCESS) {
    double c = 0;
    st = pa_metric_complexity(mesh, nt, met, &c);
    if (st == PA_SUCCESS) print_complexity(d, c, a->out);
  }
  free(u);
  free(met);
  return st;
}

/* The name of the field the distributed path carries. */
#define CLI_FIELD "pa.cli.field"

/* hessian or levelset on the distributed mesh (more than one rank): rank 0
 * reads the field and distributes the mesh with it (overlap 2), every rank
 * computes its part, rank 0 gathers the metric and writes it. Collective. */
static pa_status run_field_dist(const pa_cli *cli, const char *op,
                                pa_mesh *mesh, const metric_args *a) {
  pa_status st = PA_SUCCESS;
  pa_dmesh *dm = NULL;
  pa_mesh *g = NULL;
  double *u = NULL, c = 0;
  if (cli->rank == 0) {
    st = read_scalar(!strcmp(op, "hessian") ? a->field : a->ls,
                     pa_mesh_nvert(mesh), a->comp, &u);
    if (st == PA_SUCCESS) st = pa_mesh_add_field(mesh, CLI_FIELD, 1, u);
  }
  int bad = st != PA_SUCCESS;
  MPI_Bcast(&bad, 1, MPI_INT, 0, cli->comm);
  if (bad) goto done;
  st = pa_dmesh_distribute(cli->comm, 0, mesh, 2, &dm);
  if (st) goto done;
  pa_mesh *lm = pa_dmesh_mesh(dm);
  int field = pa_mesh_nfield(lm) - 1; /* the one added last */
  if (!strcmp(op, "hessian")) {
    st = pa_dmesh_metric_from_hessian(dm, field, 0, &a->hess);
  } else {
    st = pa_dmesh_metric_from_levelset(dm, field, &a->lset);
  }
  if (st == PA_SUCCESS) st = pa_dmesh_metric_complexity(dm, &c);
  if (st == PA_SUCCESS) st = pa_dmesh_gather(dm, 0, &g);
  if (st == PA_SUCCESS && cli->rank == 0) {
    pa_sol *sol = NULL;
    st = pa_mesh_metric_to_sol(g, 0, &sol);
    if (st == PA_SUCCESS) st = pa_sol_write(sol, a->out);
    pa_sol_destroy(sol);
    if (st == PA_SUCCESS) print_complexity(pa_mesh_dim(g), c, a->out);
  }
  {
    int ok = st == PA_SUCCESS;
    MPI_Bcast(&ok, 1, MPI_INT, 0, cli->comm);
    if (!ok && st == PA_SUCCESS) st = PA_ERR_IO;
  }
done:
  free(u);
  pa_mesh_destroy(g);
  pa_dmesh_destroy(dm);
  return st;
}

int pa_cli_metric(const pa_cli *cli, int argc, char **argv) {
  if (argc < 2) {
    pa_cli_error(cli, "metric: no operation");
    if (cli->rank == 0) pa_cli_help(&metric_spec, stderr);
    return 1;
  }
  const char *op = argv[1];
  if (!strcmp(op, "-h") || !strcmp(op, "--help")) {
    if (cli->rank == 0) pa_cli_help(&metric_spec, stdout);
    return 0;
  }
  int k = 0, nops = sizeof metric_ops / sizeof *metric_ops;
  while (k < nops && strcmp(op, metric_ops[k].name))
    k++;
  if (k == nops) { /* a built-in analytic field */
    if (argc != 4)
      return pa_cli_error(cli, "usage: padapt metric NAME[:h] IN OUT.sol "
                               "(or a subcommand: padapt metric -h)");
    pa_cli_io io = {.in = {argv[2]}, .out = {argv[3]}};
    if (pa_cli_check_io(cli, "metric", &io)) return 1;
    pa_mesh *mesh = NULL;
    pa_sol *sol = NULL;
    pa_status st = pa_cli_read_mesh(cli, argv[2], &mesh);
    if (cli->rank != 0) return st ? 1 : 0;
    if (st == PA_SUCCESS) st = pa_metric_analytic(mesh, op);
    if (st == PA_SUCCESS) st = pa_mesh_metric_to_sol(mesh, 0, &sol);
    if (st == PA_SUCCESS) st = pa_sol_write(sol, argv[3]);
    pa_sol_destroy(sol);
    pa_mesh_destroy(mesh);
    return pa_cli_fail(cli, st);
  }
  metric_args a;
  int prc = parse(cli, argc - 1, argv + 1, &metric_ops[k], &a);
  if (prc) return prc > 0 ? 1 : 0;
  if (!strcmp(op, "hessian") &&
      (!a.field || (a.hess.target > 0) == (a.hess.err > 0)))
    return pa_cli_error(cli, "metric hessian: give -field U.sol and either "
                             "-target N or -err E");
  if (!strcmp(op, "levelset") &&
      (!a.ls || !(a.lset.eps > 0) || !(a.lset.hmin > 0) || !(a.lset.hmax > 0)))
    return pa_cli_error(cli, "metric levelset: give -ls PHI.sol, -eps E, "
                             "-hmin H and -hmax H");
  if (!strcmp(op, "scale") && !(a.target > 0))
    return pa_cli_error(cli, "metric scale: give -target N");
  pa_mesh *mesh = NULL;
  pa_status st = pa_cli_read_mesh(cli, a.in, &mesh);
  if (k < 2 && cli->size > 1) { /* distributed */
    int bad = cli->rank == 0 && st != PA_SUCCESS;
    MPI_Bcast(&bad, 1, MPI_INT, 0, cli->comm);
    if (bad) {
      pa_mesh_destroy(mesh);
      return pa_cli_fail(cli, st);
    }
    st = run_field_dist(cli, op, mesh, &a);
    pa_mesh_destroy(mesh);
    return cli->rank == 0 ? pa_cli_fail(cli, st) : (st ? 1 : 0);
  }
  if (cli->rank != 0) return st ? 1 : 0;
  if (st == PA_SUCCESS)
    st = k < 2 ? run_field(op, mesh, &a) : run_ops(cli, op, mesh, &a);
  pa_mesh_destroy(mesh);
  return pa_cli_fail(cli, st);
}

static const char *const levelset_usage =
    "usage: padapt levelset NAME IN OUT.sol\n"
    "  NAME: sphere:R[:cx,cy,cz] ellipsoid:a,b,c[:cx,cy,cz]\n"
    "        box:lx,ly,lz[:cx,cy,cz] plane:nx,ny,nz,d\n"
    "        (2D: circle as sphere:R[:cx,cy], ellipse:a,b,\n"
    "        box:lx,ly, plane:nx,ny,d)\n"
    "  writes the signed distance (negative inside) at IN's vertices\n";

int pa_cli_levelset(const pa_cli *cli, int argc, char **argv) {
  if (argc == 2 && (!strcmp(argv[1], "-h") || !strcmp(argv[1], "--help"))) {
    if (cli->rank == 0) fputs(levelset_usage, stdout);
    return 0;
  }
  if (argc != 4) return pa_cli_error(cli, "%s", levelset_usage);
  pa_cli_io io = {.in = {argv[2]}, .out = {argv[3]}};
  if (pa_cli_check_io(cli, "levelset", &io)) return 1;
  pa_mesh *mesh = NULL;
  pa_sol *sol = NULL;
  double *phi = NULL;
  pa_status st = pa_cli_read_mesh(cli, argv[2], &mesh);
  if (cli->rank != 0) return st ? 1 : 0;
  if (st == PA_SUCCESS) {
    pa_idx nv = pa_mesh_nvert(mesh);
    phi = malloc(sizeof(double) * (nv ? nv : 1));
    if (!phi) st = pa_set_error(PA_ERR_MEMORY, "out of memory");
    if (st == PA_SUCCESS) st = pa_levelset_analytic(mesh, argv[1], phi);
    if (st == PA_SUCCESS) st = pa_sol_create(pa_mesh_dim(mesh), nv, &sol);
    if (st == PA_SUCCESS) st = pa_sol_add_field(sol, PA_SOL_SCALAR, phi);
    if (st == PA_SUCCESS) st = pa_sol_write(sol, argv[3]);
  }
  pa_sol_destroy(sol);
  free(phi);
  pa_mesh_destroy(mesh);
  return pa_cli_fail(cli, st);
}
