/*
 * cmd_plot.c -- `padapt plot`: an SVG picture of a 2D mesh, or of the cut of
 * a 3D mesh by a plane.
 *
 *   padapt plot IN OUT.svg [-met SOL] [-field F.sol] [-color quality|ref|FIELD]
 *       [-window XMIN YMIN XMAX YMAX] [-cut x=V|y=V|z=V | -plane A B C D]
 *       [-width PX]
 *
 * Each element (2D) or each intersection polygon of a tetrahedron with the
 * plane (3D) is filled by its quality (in the metric of -met, else
 * Euclidean; a colour ramp with its legend), by its reference, or by the
 * value of an element field (IN's, or one of -field's: its first component,
 * on the ramp from the field's smallest to its largest value); the
 * boundary (boundary edges in 2D, the cut of the boundary triangles in 3D)
 * is drawn thicker. In 3D the picture is in the plane's own axes: (x, y) for
 * a cut z = V, (y, z) for x = V, (x, z) for y = V, and for -plane the
 * projection onto it of the two axes closest to it. Without -cut or -plane
 * the cut is z = the middle of the mesh's z range.
 *
 * Size: an element whose bounding box misses the window is not written
 * (culled); one smaller than PLOT_SUBPIXEL_PX (2) pixels in both directions
 * on screen is not drawn alone but merged into a square cell of
 * PLOT_CELL_PX (2) pixels, drawn once with the worst quality (or the
 * smallest reference or field value) of the elements merged into it; the cells of one
 * colour form one SVG path, a run of them along a row one rectangle
 * (about 16 bytes). So the elements drawn are at least 2 pixels across,
 * and a million triangles at 800 pixels give a file of at most about
 * 2.5 MB. Elements smaller than PLOT_EDGE_PX
 * are drawn without their edges, which would hide their colour.
 *
 * A 3D vertex exactly on the plane counts on the positive side, so a face
 * lying in the plane is drawn once (from the tetrahedron on the negative
 * side), and a tetrahedron touching the plane at one edge or vertex (its
 * cut has fewer than 3 distinct points) not at all. The output is written
 * through the output transactions (svg.h): on any error nothing is written.
 */
#include "svg.h"

#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

/* Default size of the longer side of the plot area, pixels. */
#define PLOT_WIDTH 800
/* Bounds of -width: below, the legend dwarfs the mesh; above, the merge
 * grid of sub-pixel elements (16 bytes per cell) reaches tens of MB. */
#define PLOT_MIN_WIDTH 100
#define PLOT_MAX_WIDTH 4000
/* Side of the merge cells, pixels: 2 keeps the file at a quarter of one
 * polygon per pixel while the picture still shows where the small elements
 * are. */
#define PLOT_CELL_PX 2.0
/* An element smaller than this on screen (both directions, pixels) is merged
 * into a cell: drawn alone it would show as a speck of its edges' colour. */
#define PLOT_SUBPIXEL_PX PLOT_CELL_PX
/* Elements smaller than this (longer side, pixels) are drawn without edges. */
#define PLOT_EDGE_PX 6.0
/* Margin around the mesh when no window is given, relative to its size. */
#define PLOT_MARGIN 0.02
/* Narrowest picture, pixels: the title and the counts line fit. */
#define PLOT_MIN_PICTURE_W 720
/* Distinct references listed in the legend of -color ref. */
#define PLOT_MAX_REFS 24

typedef struct plot {
  pa_mesh *mesh;
  int dim;
  const double *coord;
  const pa_idx *elem, *bdry;
  double n[3], d;    /* 3D: the plane n.x = d */
  double u[3], v[3]; /* 3D: the picture's axes in the plane */
  char uname[16], vname[16];
  /* the window and the screen frame: its origin (x0, y0) and size (pw, ph)
   * in pixels */
  double win[4]; /* xmin ymin xmax ymax */
  double scale, x0, y0, pw, ph;
  /* -color FIELD: its values (fnc per element) and their range */
  const double *fval;
  int fnc;
  double flo, fhi;
} plot;

static double dot3(const double *a, const double *b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* The picture's axes for the plane of normal n: the two coordinate axes
 * closest to the plane, projected onto it and orthonormalised. */
static void plane_axes(plot *p) {
  double *n = p->n, len = sqrt(dot3(n, n));
  for (int k = 0; k < 3; k++)
    n[k] /= len;
  p->d /= len;
  int big = 0; /* the axis closest to the normal */
  for (int k = 1; k < 3; k++)
    if (fabs(n[k]) > fabs(n[big])) big = k;
  int ua = big == 0 ? 1 : 0, va = big == 2 ? 1 : 2;
  const char *names = "xyz";
  double e[3] = {0, 0, 0};
  e[ua] = 1;
  double c = dot3(e, n);
  for (int k = 0; k < 3; k++)
    p->u[k] = e[k] - c * n[k];
  len = sqrt(dot3(p->u, p->u));
  for (int k = 0; k < 3; k++)
    p->u[k] /= len;
  /* v: orthogonal to n and u, pointing along axis va */
  p->v[0] = n[1] * p->u[2] - n[2] * p->u[1];
  p->v[1] = n[2] * p->u[0] - n[0] * p->u[2];
  p->v[2] = n[0] * p->u[1] - n[1] * p->u[0];
  if (p->v[va] < 0)
    for (int k = 0; k < 3; k++)
      p->v[k] = -p->v[k];
  snprintf(p->uname, sizeof p->uname, "%c", names[ua]);
  snprintf(p->vname, sizeof p->vname, "%c", names[va]);
}

/* "z = 0.5" for a plane normal to an axis, else "A x + B y + C z = D"
 * (normalised); a static buffer. */
static const char *plane_name(const plot *p) {
  static char buf[128];
  for (int k = 0; k < 3; k++)
    if (p->n[k] == 1 && p->n[(k + 1) % 3] == 0 && p->n[(k + 2) % 3] == 0) {
      snprintf(buf, sizeof buf, "%c = %g", "xyz"[k], p -> d);
      return buf;
    }
  snprintf(buf, sizeof buf, "%.4g x + %.4g y + %.4g z = %.4g", p->n[0], p->n[1],
           p->n[2], p->d);
  return buf;
}

/* The intersection of points a (side sa) and b (sb) with the plane,
 * projected on the picture's axes. */
static void cut_point(const plot *p, const double *a, const double *b,
                      double sa, double sb, double *xy) {
  double t = sa / (sa - sb), x[3];
  for (int k = 0; k < 3; k++)
    x[k] = a[k] + t * (b[k] - a[k]);
  xy[0] = dot3(x, p->u);
  xy[1] = dot3(x, p->v);
}

/* The polygon of the n vertices vtx (3 or 4) cut by the plane, in xy;
 * returns its number of points (0: not cut). */
static int cut_simplex(const plot *p, const pa_idx *vtx, int n, double *xy) {
  const double *x[4];
  double s[4];
  int npos = 0, m = 0;
  for (int k = 0; k < n; k++) {
    x[k] = p->coord + 3 * (size_t)vtx[k];
    s[k] = dot3(x[k], p->n) - p->d;
    npos += s[k] >= 0;
  }
  if (npos == 0 || npos == n) return 0;
  for (int i = 0; i < n; i++)
    for (int j = i + 1; j < n; j++)
      if ((s[i] >= 0) != (s[j] >= 0)) {
        /* from the end on the positive side: exactly it when on the plane */
        int a = s[i] >= 0 ? i : j, b = s[i] >= 0 ? j : i;
        cut_point(p, x[a], x[b], s[a], s[b], xy + 2 * m);
        /* a vertex on the plane ends several crossing edges: keep it once */
        int dup = 0;
        for (int k = 0; k < m && !dup; k++)
          dup = xy[2 * k] == xy[2 * m] && xy[2 * k + 1] == xy[2 * m + 1];
        m += !dup;
      }
  /* a simplex touching the plane at a vertex or an edge (from below) */
  if (m < n - 1) return 0;
  if (m == 4) { /* order the quadrilateral around its centre */
    double cx = 0, cy = 0, ang[4];
    for (int k = 0; k < 4; k++)
      cx += xy[2 * k] / 4, cy += xy[2 * k + 1] / 4;
    for (int k = 0; k < 4; k++)
      ang[k] = atan2(xy[2 * k + 1] - cy, xy[2 * k] - cx);
    for (int i = 1; i < 4; i++)
      for (int j = i; j > 0 && ang[j] < ang[j - 1]; j--) {
        double t = ang[j];
        ang[j] = ang[j - 1], ang[j - 1] = t;
        for (int k = 0; k < 2; k++) {
          t = xy[2 * j + k];
          xy[2 * j + k] = xy[2 * (j - 1) + k], xy[2 * (j - 1) + k] = t;
        }
      }
  }
  return m;
}

/* Element e as a polygon in the picture's coordinates; returns its number of
 * points (0: not in the picture). */
static int elem_polygon(const plot *p, pa_idx e, double *xy) {
  const pa_idx *v = p->elem + (size_t)(p->dim + 1) * e;
  if (p->dim == 3) return cut_simplex(p, v, 4, xy);
  for (int k = 0; k < 3; k++) {
    xy[2 * k] = p->coord[2 * (size_t)v[k]];
    xy[2 * k + 1] = p->coord[2 * (size_t)v[k] + 1];
  }
  return 3;
}

/* Boundary entity b as a segment; returns 2, or 0 when not in the picture. */
static int bdry_segment(const plot *p, pa_idx b, double *xy) {
  const pa_idx *v = p->bdry + (size_t)p->dim * b;
  if (p->dim == 3) return cut_simplex(p, v, 3, xy) == 2 ? 2 : 0;
  for (int k = 0; k < 2; k++) {
    xy[2 * k] = p->coord[2 * (size_t)v[k]];
    xy[2 * k + 1] = p->coord[2 * (size_t)v[k] + 1];
  }
  return 2;
}

static void bbox(int n, const double *xy, double *box) {
  box[0] = box[2] = xy[0];
  box[1] = box[3] = xy[1];
  for (int k = 1; k < n; k++) {
    box[0] = fmin(box[0], xy[2 * k]);
    box[2] = fmax(box[2], xy[2 * k]);
    box[1] = fmin(box[1], xy[2 * k + 1]);
    box[3] = fmax(box[3], xy[2 * k + 1]);
  }
}

static int in_window(const plot *p, const double *box) {
  return box[2] >= p->win[0] && box[0] <= p->win[2] && box[3] >= p->win[1] &&
         box[1] <= p->win[3];
}

/* To screen coordinates, in place. */
static void to_screen(const plot *p, int n, double *xy) {
  for (int k = 0; k < n; k++) {
    xy[2 * k] = p->x0 + (xy[2 * k] - p->win[0]) * p->scale;
    xy[2 * k + 1] = p->y0 + (p->win[3] - xy[2 * k + 1]) * p->scale;
  }
}

/* Element e as a polygon on screen, its screen box in box; returns its
 * number of points (0: not in the picture, or outside the window). */
static int screen_polygon(const plot *p, pa_idx e, double *xy, double *box) {
  int n = elem_polygon(p, e, xy);
  if (!n) return 0;
  bbox(n, xy, box);
  if (!in_window(p, box)) return 0;
  to_screen(p, n, xy);
  bbox(n, xy, box);
  return n;
}

static int cmp_ref(const void *a, const void *b) {
  int32_t x = *(const int32_t *)a, y = *(const int32_t *)b;
  return (x > y) - (x < y);
}

/* The arguments of `padapt plot`. */
typedef struct plot_args {
  const char *in, *out, *met, *fieldsol;
  const char *color; /* an element field's name, or NULL */
  int by_ref, has_window, has_plane;
  double win[4], plane[4];
  double width;
} plot_args;

#define STR_(x) #x
#define STR(x) STR_(x)
#define PL(f) offsetof(plot_args, f)

static int opt_color(const pa_cli *cli, const pa_cli_spec *s,
                     const char *name, char **val, void *args) {
  plot_args *a = args;
  const char *c = val[0] ? val[0] : "nothing";
  if (!val[0])
    return pa_cli_error(cli, "%s: %s needs quality, ref or an element field's "
                             "name", s->cmd, name);
  if (!strcmp(c, "ref"))
    a->by_ref = 1;
  else if (strcmp(c, "quality"))
    a->color = c; /* an element field, checked once the mesh is read */
  return 0;
}

static int opt_window(const pa_cli *cli, const pa_cli_spec *s,
                      const char *name, char **val, void *args) {
  plot_args *a = args;
  int ok = 1;
  for (int k = 0; ok && k < 4; k++) ok = pa_cli_parse_num(val[k], &a->win[k]);
  if (!ok || a->win[0] >= a->win[2] || a->win[1] >= a->win[3])
    return pa_cli_error(cli, "%s: %s needs XMIN YMIN XMAX YMAX, numbers with "
                             "XMIN < XMAX and YMIN < YMAX",
                        s->cmd, name);
  a->has_window = 1;
  return 0;
}

static int opt_cut(const pa_cli *cli, const pa_cli_spec *s, const char *name,
                   char **val, void *args) {
  plot_args *a = args;
  const char *c = val[0] ? val[0] : "";
  double v;
  int axis = c[0] == 'x' ? 0 : c[0] == 'y' ? 1 : c[0] == 'z' ? 2 : -1;
  if (axis < 0 || c[1] != '=' || !pa_cli_parse_num(c + 2, &v))
    return pa_cli_error(cli, "%s: %s needs x=V, y=V or z=V, got '%s'", s->cmd,
                        name, val[0] ? c : "nothing");
  memset(a->plane, 0, sizeof a->plane);
  a->plane[axis] = 1;
  a->plane[3] = v;
  a->has_plane = 1;
  return 0;
}

static int opt_plane(const pa_cli *cli, const pa_cli_spec *s,
                     const char *name, char **val, void *args) {
  plot_args *a = args;
  int ok = 1;
  for (int k = 0; ok && k < 4; k++) ok = pa_cli_parse_num(val[k], &a->plane[k]);
  if (!ok || (a->plane[0] == 0 && a->plane[1] == 0 && a->plane[2] == 0))
    return pa_cli_error(cli, "%s: %s needs A B C D (numbers, A B C not all 0) "
                             "for the plane A x + B y + C z = D",
                        s->cmd, name);
  a->has_plane = 1;
  return 0;
}

static const pa_cli_opt plot_opts[] = {
    {.names = "-met -sol", .kind = PA_CLI_STR, .at = PL(met),
     .want = "a .sol file", .label = "-met SOL",
     .help = "quality in this metric (default: Euclidean)"},
    {.names = "-color -colour", .kind = PA_CLI_FN, .fn = opt_color, .nval = 1,
     .label = "-color C",
     .help = "fill by element quality (default), reference, or the\n"
             "element field of this name (its first component)"},
    {.names = "-field", .kind = PA_CLI_STR, .at = PL(fieldsol),
     .want = "a .sol file", .label = "-field F.sol",
     .help = "element fields to colour by (cell1, cell2, ...)"},
    {.names = "-window", .kind = PA_CLI_FN, .fn = opt_window, .nval = 4,
     .label = "-window ...",
     .help = "zoom: draw only what lies in this rectangle (in 3D, in\n"
             "the coordinates of the cut plane)"},
    {.names = "-cut", .kind = PA_CLI_FN, .fn = opt_cut, .nval = 1,
     .label = "-cut AXIS=V",
     .help = "3D: cut by the plane x=V, y=V or z=V (default: z at the\n"
             "middle of the mesh)"},
    {.names = "-plane", .kind = PA_CLI_FN, .fn = opt_plane, .nval = 4,
     .label = "-plane A B C D",
     .help = "3D: cut by the plane A x + B y + C z = D"},
    {.names = "-width", .kind = PA_CLI_NUM, .at = PL(width),
     .want = "a number of pixels in [" STR(PLOT_MIN_WIDTH) ", " STR(
         PLOT_MAX_WIDTH) "]",
     .lo = PLOT_MIN_WIDTH, .hi = PLOT_MAX_WIDTH, .label = "-width PX",
     .help = "size of the plot's longer side (default " STR(PLOT_WIDTH) ")"},
    {.kind = PA_CLI_END}};

static int plot_positional(const pa_cli *cli, const char *arg, void *args) {
  plot_args *a = args;
  if (a->in && a->out)
    return pa_cli_error(cli, "plot: too many arguments ('%s')", arg);
  *(a->in ? &a->out : &a->in) = arg;
  return 0;
}

static const pa_cli_spec plot_spec = {
    .cmd = "plot",
    .usage = "usage: padapt plot IN OUT.svg [-met SOL] [-field F.sol]\n"
             "                   [-color quality|ref|FIELD]\n"
             "                   [-window XMIN YMIN XMAX YMAX] [-cut "
             "x=V|y=V|z=V |\n"
             "                   -plane A B C D] [-width PX]\n",
    .width = 16,
    .opt = plot_opts,
    .tail = "Only SVG is written; convert to PNG with e.g. `rsvg-convert -o "
            "OUT.png\n"
            "OUT.svg` or `inkscape OUT.svg -o OUT.png`.\n",
    .positional = plot_positional};

static int parse_args(const pa_cli *cli, int argc, char **argv, plot_args *a) {
  memset(a, 0, sizeof *a);
  a->width = PLOT_WIDTH;
  int rc = pa_cli_parse(cli, &plot_spec, argc, argv, a);
  if (rc) return rc;
  if (!a->in || !a->out) {
    pa_cli_error(cli, "plot: needs IN and OUT.svg");
    if (cli->rank == 0) pa_cli_help(&plot_spec, stderr);
    return 1;
  }
  if (!pa_cli_is_svg(a->out))
    return pa_cli_error(cli,
                        "plot: %s: only SVG output is written (.svg); "
                        "convert it to PNG with e.g. rsvg-convert or "
                        "inkscape",
                        a->out);
  return 0;
}

/* What element e is coloured by: its reference, its field's value or its
 * quality. */
static double elem_value(const plot *p, const plot_args *a, pa_idx e) {
  if (a->by_ref) return (double)pa_mesh_elem_refs(p->mesh)[e];
  if (p->fval) return p->fval[(size_t)p->fnc * e];
  return pa_mesh_elem_quality(p->mesh, e);
}

/* The colour of value v (elem_value's) into col. */
static void value_colour(const plot *p, const plot_args *a, double v, char *col) {
  if (a->by_ref)
    pa_cli_svg_ref_colour((int32_t)v, col);
  else if (p->fval)
    pa_cli_svg_quality_colour(p->fhi > p->flo ? (v - p->flo) / (p->fhi - p->flo) : 0.5,
                              col);
  else
    pa_cli_svg_quality_colour(v, col);
}

/* A merge cell drawn: its colour (0xrrggbb) and its index in the grid. */
typedef struct plot_cell {
  uint32_t rgb, k;
} plot_cell;

static int cmp_cell(const void *a, const void *b) {
  const plot_cell *x = a, *y = b;
  if (x->rgb != y->rgb) return x->rgb < y->rgb ? -1 : 1;
  return (x->k > y->k) - (x->k < y->k);
}

/* Counts of one drawing, for the title and the summary line. */
typedef struct plot_counts {
  pa_idx ncut;    /* elements in the picture (2D: all; 3D: cut) */
  pa_idx ninside; /* ... in the window */
  pa_idx ndrawn;  /* ... drawn as polygons */
  pa_idx nmerged; /* ... merged into cells */
  pa_idx ncells;  /* cells drawn */
  int32_t refs[PLOT_MAX_REFS];
  int nrefs, more_refs;
} plot_counts;

/* The grid of merge cells over the frame: the value of each cell (the worst
 * quality or the smallest reference merged into it; NaN: empty), and room
 * to sort the cells by colour. */
typedef struct plot_grid {
  int gw, gh;
  double *val;
  plot_cell *bycol;
} plot_grid;

static void grid_destroy(plot_grid *g) {
  free(g->val);
  free(g->bycol);
}

static pa_status grid_create(plot_grid *g, const plot *p) {
  g->gw = (int)ceil(p->pw / PLOT_CELL_PX);
  g->gh = (int)ceil(p->ph / PLOT_CELL_PX);
  size_t n = (size_t)g->gw * (size_t)g->gh;
  g->val = malloc(sizeof(double) * n);
  g->bycol = malloc(sizeof(plot_cell) * n);
  if (!g->val || !g->bycol) {
    grid_destroy(g);
    return pa_set_error(PA_ERR_MEMORY, "plot: out of memory");
  }
  for (size_t k = 0; k < n; k++)
    g->val[k] = NAN;
  return PA_SUCCESS;
}

/* Merge the elements smaller than PLOT_SUBPIXEL_PX on screen into the cells
 * of g under their centres, counting them and the cells in c. */
static void merge_cells(const plot *p, const plot_args *a, plot_counts *c,
                        plot_grid *g) {
  pa_idx ne = pa_mesh_nelem(p->mesh);
  double xy[8], box[4];
  for (pa_idx e = 0; e < ne; e++) {
    if (!screen_polygon(p, e, xy, box)) continue;
    if (box[2] - box[0] >= PLOT_SUBPIXEL_PX ||
        box[3] - box[1] >= PLOT_SUBPIXEL_PX)
      continue;
    int i = (int)floor(((box[0] + box[2]) / 2 - p->x0) / PLOT_CELL_PX);
    int j = (int)floor(((box[1] + box[3]) / 2 - p->y0) / PLOT_CELL_PX);
    /* an element straddling the window's side goes to the cell inside */
    i = i < 0 ? 0 : i >= g->gw ? g->gw - 1 : i;
    j = j < 0 ? 0 : j >= g->gh ? g->gh - 1 : j;
    double val = elem_value(p, a, e);
    double *cv = &g->val[(size_t)j * g->gw + i];
    if (isnan(*cv)) c->ncells++;
    if (isnan(*cv) || val < *cv) *cv = val;
    c->nmerged++;
  }
}

/* Open the picture, with room for the legend on the right and the title
 * above, and write the title, the counts line, the window's clip path and
 * the frame's background. */
static pa_status begin_picture(pa_cli_svg *svg, const plot *p,
                               const plot_args *a, const plot_counts *c,
                               const char *title) {
  double W = fmax(16 + p->pw + 170, PLOT_MIN_PICTURE_W),
         H = 64 + fmax(p->ph, 330) + 30;
  pa_status st = pa_cli_svg_begin(svg, a->out, W, H);
  if (st) return st;
  pa_cli_svg_text(svg, 16, 22, "start", 14, "%s", title);
  pa_cli_svg_text(svg, 16, 42, "start", 11,
                  "%lld polygons drawn, %lld sub-pixel elements merged into "
                  "%lld cells; %s in [%g, %g], %s in [%g, %g]",
                  (long long)c->ndrawn, (long long)c->nmerged,
                  (long long)c->ncells, p->uname, p->win[0], p->win[2],
                  p->vname, p->win[1], p->win[3]);
  pa_cli_svg_raw(svg,
                 "<clipPath id=\"window\"><rect x=\"%.2f\" y=\"%.2f\" "
                 "width=\"%.2f\" height=\"%.2f\"/></clipPath>\n",
                 p->x0, p->y0, p->pw, p->ph);
  pa_cli_svg_rect(svg, p->x0, p->y0, p->pw, p->ph, "#f7f7f7", "frame");
  return PA_SUCCESS;
}

/* The cells of g, one path per colour, a run of cells along a row one
 * rectangle. */
static void draw_cells(pa_cli_svg *svg, const plot *p, const plot_args *a,
                       plot_grid *g) {
  int gw = g->gw;
  plot_cell *bycol = g->bycol;
  char col[8];
  size_t nc = 0;
  pa_cli_svg_raw(svg, "<g clip-path=\"url(#window)\" class=\"cells\">\n");
  for (size_t k = 0; k < (size_t)gw * (size_t)g->gh; k++) {
    if (isnan(g->val[k])) continue;
    value_colour(p, a, g->val[k], col);
    bycol[nc].rgb = (uint32_t)strtoul(col + 1, NULL, 16);
    bycol[nc++].k = (uint32_t)k;
  }
  qsort(bycol, nc, sizeof *bycol, cmp_cell);
  for (size_t k = 0, run; k < nc; k += run) {
    if (k == 0 || bycol[k].rgb != bycol[k - 1].rgb)
      pa_cli_svg_raw(svg, "%s<path fill=\"#%06x\" d=\"", k ? "\"/>\n" : "",
                     (unsigned)bycol[k].rgb);
    long i = (long)(bycol[k].k % (uint32_t)gw),
         j = (long)(bycol[k].k / (uint32_t)gw);
    for (run = 1; k + run < nc && bycol[k + run].rgb == bycol[k].rgb &&
                  bycol[k + run].k == bycol[k].k + run && i + (long)run < gw;
         run++)
      ;
    /* the frame's origin is a whole pixel and cells are PLOT_CELL_PX wide */
    double w = (double)run * PLOT_CELL_PX;
    pa_cli_svg_raw(
        svg, "M%ld %ldh%gv%gh-%gz", lround(p->x0 + (double)i * PLOT_CELL_PX),
        lround(p->y0 + (double)j * PLOT_CELL_PX), w, PLOT_CELL_PX, w);
  }
  if (nc) pa_cli_svg_raw(svg, "\"/>\n");
  pa_cli_svg_raw(svg, "</g>\n");
}

/* The elements in the window not merged into cells, one polygon each. */
static void draw_elements(pa_cli_svg *svg, const plot *p, const plot_args *a) {
  pa_idx ne = pa_mesh_nelem(p->mesh);
  double xy[8], box[4];
  char col[8];
  pa_cli_svg_raw(svg, "<g clip-path=\"url(#window)\" class=\"elements\" "
                      "stroke=\"#303030\" stroke-width=\"0.5\" "
                      "stroke-linejoin=\"round\">\n");
  for (pa_idx e = 0; e < ne; e++) {
    int n = screen_polygon(p, e, xy, box);
    if (!n) continue;
    double sx = box[2] - box[0], sy = box[3] - box[1];
    if (sx < PLOT_SUBPIXEL_PX && sy < PLOT_SUBPIXEL_PX) continue;
    value_colour(p, a, elem_value(p, a, e), col);
    /* small ones: stroked with their own colour, so that no seam shows */
    pa_cli_svg_polygon(svg, n, xy, col,
                       fmax(sx, sy) < PLOT_EDGE_PX ? col : NULL);
  }
  pa_cli_svg_raw(svg, "</g>\n");
}

/* The boundary in the window, thick, and the frame's border. */
static void draw_boundary(pa_cli_svg *svg, const plot *p) {
  pa_idx nb = pa_mesh_nbdry(p->mesh);
  double xy[8], box[4];
  pa_cli_svg_raw(svg, "<g clip-path=\"url(#window)\" class=\"boundary\" "
                      "stroke=\"#000000\" stroke-width=\"1.6\" "
                      "stroke-linecap=\"round\">\n");
  for (pa_idx b = 0; b < nb; b++) {
    if (!bdry_segment(p, b, xy)) continue;
    bbox(2, xy, box);
    if (!in_window(p, box)) continue;
    to_screen(p, 2, xy);
    pa_cli_svg_line(svg, xy[0], xy[1], xy[2], xy[3], NULL, 0);
  }
  pa_cli_svg_raw(svg, "</g>\n");
  pa_cli_svg_raw(svg,
                 "<rect x=\"%.2f\" y=\"%.2f\" width=\"%.2f\" height=\"%.2f\" "
                 "fill=\"none\" stroke=\"#666666\"/>\n",
                 p->x0, p->y0, p->pw, p->ph);
}

/* The legend right of the frame: the references shown (-color ref), or the
 * quality ramp. */
static void draw_legend(pa_cli_svg *svg, const plot *p, const plot_args *a,
                        const plot_counts *c) {
  double lx = p->x0 + p->pw + 24, ly = p->y0;
  char col[8];
  if (a->by_ref) {
    pa_cli_svg_text(svg, lx, ly + 12, "start", 13, "reference");
    for (int k = 0; k < c->nrefs; k++) {
      pa_cli_svg_ref_colour(c->refs[k], col);
      pa_cli_svg_rect(svg, lx, ly + 24 + 20 * k, 14, 14, col, "legend");
      pa_cli_svg_text(svg, lx + 20, ly + 36 + 20 * k, "start", 12, "%ld",
                      (long)c->refs[k]);
    }
    if (c->more_refs)
      pa_cli_svg_text(svg, lx, ly + 36 + 20 * c->nrefs, "start", 12,
                      "and more (colours repeat every 10)");
    return;
  }
  const int nstep = 50;
  const double bh = 240;
  if (p->fval) { /* the field's ramp, its largest value on top */
    pa_cli_svg_text(svg, lx, ly + 12, "start", 13, "%s", a->color);
    for (int k = 0; k < nstep; k++) {
      pa_cli_svg_quality_colour(1.0 - (k + 0.5) / nstep, col);
      pa_cli_svg_rect(svg, lx, ly + 24 + bh * k / nstep, 18,
                      bh / nstep + (k < nstep - 1 ? 1 : 0), col, "legend");
    }
    for (int k = 0; k <= 5; k++)
      pa_cli_svg_text(svg, lx + 24, ly + 28 + bh * k / 5, "start", 11, "%.4g",
                      p->fhi - (p->fhi - p->flo) * k / 5.0);
    pa_cli_svg_text(svg, lx, ly + 24 + bh + 22, "start", 11,
                    p->fnc > 1 ? "first component" : "element field");
    return;
  }
  pa_cli_svg_text(svg, lx, ly + 12, "start", 13, "quality");
  for (int k = 0; k < nstep; k++) {
    double q = 1.0 - (k + 0.5) / nstep;
    pa_cli_svg_quality_colour(q, col);
    /* each step overlaps the next by a pixel, so that no seam shows */
    pa_cli_svg_rect(svg, lx, ly + 24 + bh * k / nstep, 18,
                    bh / nstep + (k < nstep - 1 ? 1 : 0), col, "legend");
  }
  for (int k = 0; k <= 5; k++)
    pa_cli_svg_text(svg, lx + 24, ly + 28 + bh * k / 5, "start", 11, "%.1f",
                    1.0 - k / 5.0);
  pa_cli_svg_text(svg, lx, ly + 24 + bh + 22, "start", 11,
                  pa_mesh_metric_ncomp(p->mesh) ? "in the metric"
                                                : "Euclidean");
}

/* Write the picture: the sub-pixel elements merged into cells, then the
 * cells, the other elements in the window, the boundary and the legend. */
static pa_status draw(const plot *p, const plot_args *a, plot_counts *c,
                      const char *title) {
  plot_grid g;
  pa_cli_svg svg;
  pa_status st = grid_create(&g, p);
  if (st) return st;
  merge_cells(p, a, c, &g);
  c->ndrawn = c->ninside - c->nmerged;
  st = begin_picture(&svg, p, a, c, title);
  if (st == PA_SUCCESS) {
    draw_cells(&svg, p, a, &g);
    draw_elements(&svg, p, a);
    draw_boundary(&svg, p);
    draw_legend(&svg, p, a, c);
    st = pa_cli_svg_end(&svg);
    if (st) pa_cli_svg_abort(&svg);
  }
  grid_destroy(&g);
  return st;
}

/* The plane of a 3D plot (-cut, -plane, or z = the middle of the mesh's z
 * range) and the picture's axes in it; x and y in 2D. */
static void choose_plane(plot *p, const plot_args *a) {
  if (p->dim == 2) {
    snprintf(p->uname, sizeof p->uname, "x");
    snprintf(p->vname, sizeof p->vname, "y");
    return;
  }
  if (a->has_plane) {
    for (int k = 0; k < 3; k++)
      p->n[k] = a->plane[k];
    p->d = a->plane[3];
  } else {
    pa_idx nv = pa_mesh_nvert(p->mesh);
    double zmin = p->coord[2], zmax = p->coord[2];
    for (pa_idx v = 1; v < nv; v++) {
      zmin = fmin(zmin, p->coord[3 * v + 2]);
      zmax = fmax(zmax, p->coord[3 * v + 2]);
    }
    p->n[2] = 1;
    p->d = 0.5 * (zmin + zmax);
  }
  plane_axes(p);
}

/* The plot of mesh by a: its arrays, its metric (-met) and its plane.
 * Returns 0, or 1 after printing the error. */
static int setup(const pa_cli *cli, const plot_args *a, pa_mesh *mesh,
                 plot *p) {
  memset(p, 0, sizeof *p);
  p->mesh = mesh;
  p->dim = pa_mesh_dim(mesh);
  p->coord = pa_mesh_coords(mesh);
  p->elem = pa_mesh_elems(mesh);
  p->bdry = pa_mesh_bdrys(mesh);
  if (a->met) {
    pa_status st = pa_cli_attach_metric(mesh, a->met);
    if (st) return pa_cli_fail(cli, st);
  }
  if (a->fieldsol) {
    pa_sol *sol = NULL;
    pa_status st = pa_sol_read(a->fieldsol, &sol);
    if (st == PA_SUCCESS) st = pa_mesh_fields_from_sol(mesh, sol);
    pa_sol_destroy(sol);
    if (st) return pa_cli_fail(cli, st);
  }
  if (a->color) {
    int k = pa_mesh_field_index(mesh, PA_ELEMENT, a->color);
    double *val;
    if (k < 0) {
      char list[1024] = "";
      size_t len = 0;
      for (int j = 0; j < pa_mesh_nfield_at(mesh, PA_ELEMENT) && len < sizeof list; j++) {
        const char *name = "";
        pa_mesh_field_at(mesh, PA_ELEMENT, j, &name, NULL, NULL);
        len += (size_t)snprintf(list + len, sizeof list - len, "%s%s", j ? ", " : "", name);
      }
      return pa_cli_error(cli, "plot: -color %s: not quality, ref nor an element "
                               "field of %s (element fields: %s)",
                          a->color, a->in, list[0] ? list : "none");
    }
    pa_mesh_field_at(mesh, PA_ELEMENT, k, NULL, &p->fnc, &val);
    p->fval = val;
    p->flo = INFINITY;
    p->fhi = -INFINITY;
    for (pa_idx e = 0; e < pa_mesh_nelem(mesh); e++) {
      p->flo = fmin(p->flo, val[(size_t)p->fnc * e]);
      p->fhi = fmax(p->fhi, val[(size_t)p->fnc * e]);
    }
  }
  if (p->dim == 2 && a->has_plane)
    return pa_cli_error(cli, "plot: -cut and -plane need a 3D mesh; %s is 2D",
                        a->in);
  if (pa_mesh_nelem(mesh) == 0)
    return pa_cli_error(cli, "plot: %s has no element", a->in);
  choose_plane(p, a);
  return 0;
}

/* The extent of the picture (the elements in 2D, their cuts in 3D) into
 * ext (xmin ymin xmax ymax; empty when nothing is cut) and the elements in
 * it into c->ncut. */
static void picture_extent(const plot *p, plot_counts *c, double *ext) {
  pa_idx ne = pa_mesh_nelem(p->mesh);
  double xy[8], box[4];
  ext[0] = ext[1] = INFINITY;
  ext[2] = ext[3] = -INFINITY;
  for (pa_idx e = 0; e < ne; e++) {
    int n = elem_polygon(p, e, xy);
    if (!n) continue;
    c->ncut++;
    bbox(n, xy, box);
    for (int k = 0; k < 2; k++) {
      ext[k] = fmin(ext[k], box[k]);
      ext[k + 2] = fmax(ext[k + 2], box[k + 2]);
    }
  }
}

/* The elements in the window into c->ninside and, for -color ref, their
 * first PLOT_MAX_REFS references, sorted, into c->refs. */
static void count_inside(const plot *p, const plot_args *a, plot_counts *c) {
  pa_idx ne = pa_mesh_nelem(p->mesh);
  int32_t *eref = pa_mesh_elem_refs(p->mesh);
  double xy[8], box[4];
  for (pa_idx e = 0; e < ne; e++) {
    int n = elem_polygon(p, e, xy);
    if (!n) continue;
    bbox(n, xy, box);
    if (!in_window(p, box)) continue;
    c->ninside++;
    if (a->by_ref) {
      int k = 0;
      while (k < c->nrefs && c->refs[k] != eref[e])
        k++;
      if (k == c->nrefs && c->nrefs < PLOT_MAX_REFS)
        c->refs[c->nrefs++] = eref[e];
      else if (k == c->nrefs)
        c->more_refs = 1;
    }
  }
  qsort(c->refs, (size_t)c->nrefs, sizeof *c->refs, cmp_ref);
}

/* The window (-window, or the picture's extent plus a margin) and the
 * counts of what it holds, and the screen frame: the window's longer side
 * is a->width pixels. Returns 0, or 1 after printing the error of a plane
 * that cuts nothing or of an empty window. */
static int frame(const pa_cli *cli, const plot_args *a, plot *p,
                 plot_counts *c) {
  double ext[4];
  memset(c, 0, sizeof *c);
  picture_extent(p, c, ext);
  for (int k = 0; k < 4; k++)
    p->win[k] = a->has_window ? a->win[k] : ext[k];
  if (!a->has_window && c->ncut > 0) {
    double m = PLOT_MARGIN * fmax(ext[2] - ext[0], ext[3] - ext[1]);
    if (!(m > 0)) m = 1;
    p->win[0] = ext[0] - m, p->win[1] = ext[1] - m;
    p->win[2] = ext[2] + m, p->win[3] = ext[3] + m;
  }
  count_inside(p, a, c);
  if (c->ncut == 0)
    return pa_cli_error(cli, "plot: the plane %s does not cut %s",
                        plane_name(p), a->in);
  if (c->ninside == 0)
    return pa_cli_error(cli,
                        "plot: the window [%g, %g] x [%g, %g] holds no "
                        "element of %s (its extent: [%g, %g] x [%g, %g])",
                        p->win[0], p->win[2], p->win[1], p->win[3], a->in,
                        ext[0], ext[2], ext[1], ext[3]);
  double dx = p->win[2] - p->win[0], dy = p->win[3] - p->win[1];
  p->scale = a->width / fmax(dx, dy);
  p->x0 = 16;
  p->y0 = 64;
  p->pw = dx * p->scale;
  p->ph = dy * p->scale;
  return 0;
}

/* Draw the picture under its title and print the summary line. Returns 0,
 * or 1 after printing the error. */
static int write_picture(const pa_cli *cli, const plot_args *a, const plot *p,
                         plot_counts *c) {
  char title[1200];
  long long ne = (long long)pa_mesh_nelem(p->mesh);
  const char *colour = a->by_ref ? "reference" : a->color ? a->color : "quality";
  if (p->dim == 2)
    snprintf(title, sizeof title, "%s: %lld triangles, coloured by %s", a->in,
             ne, colour);
  else
    snprintf(title, sizeof title,
             "%s: %lld of %lld tetrahedra cut by the plane %s, coloured by %s",
             a->in, (long long)c->ncut, ne, plane_name(p), colour);
  pa_status st = draw(p, a, c, title);
  if (st) return pa_cli_fail(cli, st);
  printf("plot: %s: %lld polygons, %lld sub-pixel elements merged into %lld "
         "cells, %lld elements outside the window\n",
         a->out, (long long)c->ndrawn, (long long)c->nmerged,
         (long long)c->ncells, (long long)(c->ncut - c->ninside));
  return 0;
}

int pa_cli_plot(const pa_cli *cli, int argc, char **argv) {
  plot_args a;
  int prc = parse_args(cli, argc, argv, &a);
  if (prc) return prc > 0 ? 1 : 0;
  const char *out = a.out;
  pa_cli_io io = {.in = {a.in, a.met}, .out = {out}};
  if (pa_cli_check_io(cli, "plot", &io)) return 1;
  pa_mesh *mesh = NULL;
  pa_status st = pa_cli_read_mesh(cli, a.in, &mesh); /* collective */
  if (cli->rank != 0) return st ? 1 : 0;
  if (st) return pa_cli_fail(cli, st);
  plot p;
  plot_counts c;
  int rc = setup(cli, &a, mesh, &p);
  if (!rc) rc = frame(cli, &a, &p, &c);
  if (!rc) rc = write_picture(cli, &a, &p, &c);
  pa_mesh_destroy(mesh);
  return rc;
}
