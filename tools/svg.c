/*
 * svg.c -- the SVG writer of the CLI's pictures and the histogram picture of
 * `padapt stats -svg` / `padapt adapt -svg` (svg.h).
 *
 * Every coordinate is printed with two decimals (a hundredth of a pixel),
 * through one function, so the output is deterministic. Write errors are
 * caught at the end: pa_output_file_commit checks the stream's error flag,
 * flushes and syncs.
 *
 * The histograms take their counts from pa_stats (edge_hist, qual_hist) and
 * their bin bounds from pa_stats_edge_bin / pa_stats_qual_bin: the bins are
 * the library's, never recomputed here. Bars have equal widths (the last
 * edge bin is unbounded); the bin bounds label the ticks between them.
 */
#include "svg.h"

#include <math.h>
#include <stdarg.h>
#include <string.h>

/* A coordinate with two decimals; -0.00 printed as 0.00. */
static void num(FILE *fp, double x) {
  if (!isfinite(x)) x = 0;
  if (fabs(x) < 0.005) x = 0;
  fprintf(fp, "%.2f", x);
}

/* s with XML's special characters escaped and control characters (not
 * allowed in XML 1.0) as '?'. */
static void xml_escape(FILE *fp, const char *s) {
  for (; *s; s++) {
    switch (*s) {
    case '&':
      fputs("&amp;", fp);
      break;
    case '<':
      fputs("&lt;", fp);
      break;
    case '>':
      fputs("&gt;", fp);
      break;
    case '"':
      fputs("&quot;", fp);
      break;
    default:
      fputc((unsigned char)*s < 0x20 ? '?' : *s, fp);
    }
  }
}

pa_status pa_cli_svg_begin(pa_cli_svg *svg, const char *path, double width,
                           double height) {
  memset(svg, 0, sizeof *svg);
  pa_status st = pa_output_file_open(path, &svg->out, &svg->fp);
  if (st) return st;
  fprintf(svg->fp, "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
                   "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"");
  num(svg->fp, width);
  fprintf(svg->fp, "\" height=\"");
  num(svg->fp, height);
  fprintf(svg->fp, "\" viewBox=\"0 0 ");
  num(svg->fp, width);
  fputc(' ', svg->fp);
  num(svg->fp, height);
  fprintf(svg->fp, "\" font-family=\"sans-serif\">\n"
                   "<rect width=\"100%%\" height=\"100%%\" fill=\"white\"/>\n");
  return PA_SUCCESS;
}

pa_status pa_cli_svg_end(pa_cli_svg *svg) {
  if (!svg->fp) return PA_SUCCESS;
  fprintf(svg->fp, "</svg>\n");
  svg->fp = NULL;
  pa_output_file *out = svg->out;
  svg->out = NULL;
  return pa_output_file_commit(out);
}

void pa_cli_svg_abort(pa_cli_svg *svg) {
  svg->fp = NULL;
  pa_output_file_abort(svg->out);
  svg->out = NULL;
}

void pa_cli_svg_rect(pa_cli_svg *svg, double x, double y, double w, double h,
                     const char *fill, const char *cls) {
  FILE *fp = svg->fp;
  fprintf(fp, "<rect");
  if (cls) fprintf(fp, " class=\"%s\"", cls);
  fprintf(fp, " x=\"");
  num(fp, x);
  fprintf(fp, "\" y=\"");
  num(fp, y);
  fprintf(fp, "\" width=\"");
  num(fp, w > 0 ? w : 0);
  fprintf(fp, "\" height=\"");
  num(fp, h > 0 ? h : 0);
  fprintf(fp, "\" fill=\"%s\"/>\n", fill);
}

void pa_cli_svg_line(pa_cli_svg *svg, double x0, double y0, double x1,
                     double y1, const char *stroke, double width) {
  FILE *fp = svg->fp;
  fprintf(fp, "<line x1=\"");
  num(fp, x0);
  fprintf(fp, "\" y1=\"");
  num(fp, y0);
  fprintf(fp, "\" x2=\"");
  num(fp, x1);
  fprintf(fp, "\" y2=\"");
  num(fp, y1);
  fprintf(fp, "\"");
  if (stroke) {
    fprintf(fp, " stroke=\"%s\" stroke-width=\"", stroke);
    num(fp, width);
    fprintf(fp, "\"");
  }
  fprintf(fp, "/>\n");
}

void pa_cli_svg_polygon(pa_cli_svg *svg, int n, const double *xy,
                        const char *fill, const char *stroke) {
  FILE *fp = svg->fp;
  fprintf(fp, "<polygon points=\"");
  for (int i = 0; i < n; i++) {
    if (i) fputc(' ', fp);
    num(fp, xy[2 * i]);
    fputc(',', fp);
    num(fp, xy[2 * i + 1]);
  }
  fprintf(fp, "\" fill=\"%s\"", fill);
  if (stroke) fprintf(fp, " stroke=\"%s\"", stroke);
  fprintf(fp, "/>\n");
}

void pa_cli_svg_text(pa_cli_svg *svg, double x, double y, const char *anchor,
                     double size, const char *fmt, ...) {
  FILE *fp = svg->fp;
  char buf[1024];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(buf, sizeof buf, fmt, ap);
  va_end(ap);
  fprintf(fp, "<text x=\"");
  num(fp, x);
  fprintf(fp, "\" y=\"");
  num(fp, y);
  fprintf(fp, "\" font-size=\"");
  num(fp, size);
  fprintf(fp, "\" text-anchor=\"%s\">", anchor);
  xml_escape(fp, buf);
  fprintf(fp, "</text>\n");
}

void pa_cli_svg_raw(pa_cli_svg *svg, const char *fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  vfprintf(svg->fp, fmt, ap);
  va_end(ap);
}

/* The colour stops of the quality ramp: dark red (flat) through yellow to
 * dark blue (regular), so that the few poor elements of an adapted mesh
 * stand out among the many good ones. */
static const struct {
  double q;
  int r, g, b;
} stops[] = {{0.0, 0xa5, 0x00, 0x26},
             {0.25, 0xf4, 0x6d, 0x43},
             {0.5, 0xfe, 0xe0, 0x90},
             {0.75, 0x74, 0xad, 0xd1},
             {1.0, 0x31, 0x36, 0x95}};

void pa_cli_svg_quality_colour(double q, char buf[8]) {
  if (isnan(q)) {
    snprintf(buf, 8, "#808080");
    return;
  }
  if (q < 0) q = 0;
  if (q > 1) q = 1;
  int k = 0, nk = (int)(sizeof stops / sizeof *stops);
  while (k < nk - 2 && q > stops[k + 1].q)
    k++;
  double t = (q - stops[k].q) / (stops[k + 1].q - stops[k].q);
  int r = (int)lround(stops[k].r + t * (stops[k + 1].r - stops[k].r));
  int g = (int)lround(stops[k].g + t * (stops[k + 1].g - stops[k].g));
  int b = (int)lround(stops[k].b + t * (stops[k + 1].b - stops[k].b));
  snprintf(buf, 8, "#%02x%02x%02x", r & 255, g & 255, b & 255);
}

void pa_cli_svg_ref_colour(int32_t ref, char buf[8]) {
  /* Tableau 10: distinct hues, readable on white */
  static const char *palette[10] = {"#4e79a7", "#f28e2b", "#e15759", "#76b7b2",
                                    "#59a14f", "#edc948", "#b07aa1", "#ff9da7",
                                    "#9c755f", "#bab0ac"};
  int k = (int)(((int64_t)ref % 10 + 10) % 10);
  snprintf(buf, 8, "%s", palette[k]);
}

/* ------------------------------------------------------------------------ */
/* Histograms                                                               */
/* ------------------------------------------------------------------------ */

/* Picture size and the layout of the two charts (pixels). */
#define HIST_W 960.0
#define HIST_H 400.0
#define HIST_TOP 96.0    /* title and legend above the charts */
#define HIST_BOTTOM 56.0 /* tick labels and axis title below */
#define HIST_LEFT 56.0   /* percentage labels left of each chart */
#define HIST_GAP 72.0    /* between the two charts */

static const char *series_fill[2][2] = {{"#4c72b0", NULL},
                                        {"#a8b3bf", "#2f6db5"}};

static double share(pa_gid n, pa_gid total) {
  return total > 0 ? 100.0 * (double)n / (double)total : 0.0;
}

/* One bar chart at (x0, y0), w x h: nbin bins of nser series, counts
 * hist[s][b] out of total[s], ticks labelled bound[0..nbin]; bins
 * band0..band1 (inclusive, band0 < 0: none) shaded as the in-range band.
 * kind names the chart in the class attributes ("edge" or "quality"). */
static void chart(pa_cli_svg *svg, double x0, double y0, double w, double h,
                  const char *kind, const char *xtitle, const char *ytitle,
                  int nbin, int nser, const pa_gid *const *hist,
                  const pa_gid *total, const double *bound, int band0,
                  int band1) {
  double top = 0; /* the largest share, rounded up to 10 % */
  for (int s = 0; s < nser; s++)
    for (int b = 0; b < nbin; b++)
      top = fmax(top, share(hist[s][b], total[s]));
  top = fmin(100.0, 10.0 * ceil(top / 10.0 + 1e-9));
  if (top <= 0) top = 10;
  double bw = w / nbin, y1 = y0 + h;
  char cls[64];

  if (band0 >= 0) {
    snprintf(cls, sizeof cls, "inrange %s", kind);
    pa_cli_svg_rect(svg, x0 + band0 * bw, y0, (band1 - band0 + 1) * bw, h,
                    "#dff0d8", cls);
    pa_cli_svg_text(svg, x0 + (band0 + band1 + 1) * bw / 2, y0 - 6, "middle",
                    11, "in range");
  }
  /* grid and percentage labels */
  double step = top > 50 ? 20 : top > 20 ? 10 : 5;
  for (double p = 0; p <= top + 1e-9; p += step) {
    double y = y1 - h * p / top;
    pa_cli_svg_line(svg, x0, y, x0 + w, y, "#dddddd", 1);
    pa_cli_svg_text(svg, x0 - 6, y + 4, "end", 11, "%.0f %%", p);
  }
  /* bars, grouped by bin */
  double gw = bw * 0.76, sw = gw / nser;
  for (int b = 0; b < nbin; b++) {
    for (int s = 0; s < nser; s++) {
      double p = share(hist[s][b], total[s]);
      double bh = h * p / top, x = x0 + b * bw + (bw - gw) / 2 + s * sw;
      snprintf(cls, sizeof cls, "bar %s s%d", kind, s);
      pa_cli_svg_rect(svg, x, y1 - bh, sw, bh, series_fill[nser - 1][s], cls);
      if (hist[s][b] > 0)
        pa_cli_svg_text(svg, x + sw / 2, y1 - bh - 3, "middle",
                        nser > 1 ? 9 : 11, "%.*f", p < 10 ? 1 : 0, p);
    }
  }
  /* axes, ticks between bins labelled with the bounds */
  pa_cli_svg_line(svg, x0, y1, x0 + w, y1, "#333333", 1);
  pa_cli_svg_line(svg, x0, y0, x0, y1, "#333333", 1);
  for (int b = 0; b <= nbin; b++) {
    double x = x0 + b * bw;
    pa_cli_svg_line(svg, x, y1, x, y1 + 5, "#333333", 1);
    if (isinf(bound[b]))
      pa_cli_svg_text(svg, x, y1 + 18, "middle", 11, "inf");
    else
      pa_cli_svg_text(svg, x, y1 + 18, "middle", 11, "%g", bound[b]);
  }
  pa_cli_svg_text(svg, x0 + w / 2, y1 + 40, "middle", 13, "%s", xtitle);
  pa_cli_svg_raw(
      svg,
      "<text x=\"0\" y=\"0\" font-size=\"12\" text-anchor=\"middle\" "
      "transform=\"translate(%.2f %.2f) rotate(-90)\">%s</text>\n",
      x0 - 44, y0 + h / 2, ytitle);
}

pa_status pa_cli_svg_histograms(const char *path, const char *title,
                                const pa_stats *stats, int nser,
                                const char *const *names) {
  pa_cli_svg svg;
  double eb[PA_STATS_EDGE_NBIN], qb[PA_STATS_QUAL_NBIN + 1], lo, hi;
  const int ne = PA_STATS_EDGE_NBIN - 1, nq = PA_STATS_QUAL_NBIN;
  const pa_gid *eh[2], *qh[2];
  pa_gid et[2], qt[2];
  int band0 = -1, band1 = -1;
  pa_status st = PA_SUCCESS;
  if (nser < 1 || nser > 2)
    return pa_set_error(PA_ERR_ARG, "histograms: 1 or 2 series");
  /* the bins and the in-range band, as the library defines them */
  for (int b = 0; b < ne && st == PA_SUCCESS; b++) {
    st = pa_stats_edge_bin(b, &eb[b], &hi);
    eb[b + 1] = hi;
  }
  for (int b = 0; b < nq && st == PA_SUCCESS; b++) {
    st = pa_stats_qual_bin(b, &qb[b], &hi);
    qb[b + 1] = hi;
  }
  if (st == PA_SUCCESS) st = pa_stats_edge_bin(ne, &lo, &hi);
  if (st) return st;
  for (int b = 0; b < ne; b++) {
    if (eb[b] == lo) band0 = b;
    if (eb[b + 1] == hi) band1 = b;
  }
  if (band0 < 0 || band1 < band0) band0 = band1 = -1;
  for (int s = 0; s < nser; s++) {
    eh[s] = stats[s].edge_hist;
    qh[s] = stats[s].qual_hist;
    et[s] = stats[s].nedge;
    qt[s] = stats[s].nelem;
  }

  st = pa_cli_svg_begin(&svg, path, HIST_W, HIST_H);
  if (st) return st;
  pa_cli_svg_text(&svg, HIST_W / 2, 24, "middle", 15, "%s", title);
  /* one legend line per series: the figures Table 1 of the seed paper
   * reports (share of edges in range, worst and mean quality) */
  for (int s = 0; s < nser; s++) {
    const pa_stats *t = &stats[s];
    double y = 48 + 20 * s;
    pa_cli_svg_rect(&svg, HIST_LEFT, y - 11, 14, 14, series_fill[nser - 1][s],
                    "legend");
    if (t->nelem > 0 && t->nedge > 0) /* 0 edges: not measured */
      pa_cli_svg_text(
          &svg, HIST_LEFT + 20, y, "start", 12,
          "%s%s%lld %s, %lld edges (%s): %.2f %% in [%g, %g); quality worst "
          "%.3g, mean %.3f",
          names && names[s] ? names[s] : "", names && names[s] ? ": " : "",
          (long long)t->nelem, t->dim == 2 ? "triangles" : "tetrahedra",
          (long long)t->nedge, t->has_metric ? "in the metric" : "Euclidean",
          share(t->edge_hist[ne], t->nedge), lo, hi, t->qual_min,
          t->qual_sum / (double)t->nelem);
    else
      pa_cli_svg_text(&svg, HIST_LEFT + 20, y, "start", 12, "%s%snot measured",
                      names && names[s] ? names[s] : "",
                      names && names[s] ? ": " : "");
  }
  double ch = HIST_H - HIST_TOP - HIST_BOTTOM;
  double cw = HIST_W - 2 * HIST_LEFT - HIST_GAP - 16;
  double ew = cw * 0.62, qw = cw - ew;
  pa_cli_svg_raw(&svg, "<g id=\"edge-lengths\">\n");
  chart(&svg, HIST_LEFT, HIST_TOP, ew, ch, "edge",
        stats[nser - 1].has_metric ? "edge length in the metric"
                                   : "edge length (no metric: Euclidean)",
        "% of edges", ne, nser, eh, et, eb, band0, band1);
  pa_cli_svg_raw(&svg, "</g>\n<g id=\"qualities\">\n");
  chart(&svg, HIST_LEFT + ew + HIST_GAP + 16, HIST_TOP, qw, ch, "quality",
        "element quality", "% of elements", nq, nser, qh, qt, qb, -1, -1);
  pa_cli_svg_raw(&svg, "</g>\n");
  st = pa_cli_svg_end(&svg);
  if (st) pa_cli_svg_abort(&svg);
  return st;
}
