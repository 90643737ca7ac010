/*
 * svg.h -- a small SVG writer for the pictures of the padapt CLI (histograms
 * of `stats -svg` and `adapt -svg`, meshes of `plot`), and the pictures
 * themselves.
 *
 * The file goes through the library's output files (pa_output_file_open): a
 * temporary beside the path, renamed when complete, and part of the open
 * output transaction if there is one. Elements are streamed, never held in
 * memory.
 * Every number is printed with a fixed precision (2 decimals, "-0.00"
 * printed as "0.00"), so that the same input gives the same bytes.
 */
#ifndef PA_CLI_SVG_H
#define PA_CLI_SVG_H

#include "cli.h"

typedef struct pa_cli_svg {
  pa_output_file *out;
  FILE *fp; /* out's stream, NULL once closed */
} pa_cli_svg;

/* Open path and write the header of a width x height picture (pixels) on a
 * white background. Not collective. */
pa_status pa_cli_svg_begin(pa_cli_svg *svg, const char *path, double width,
                           double height);
/* Write the closing tag and complete the file (renamed onto its path, or
 * left for the open transaction's commit). */
pa_status pa_cli_svg_end(pa_cli_svg *svg);
/* Drop the file (safe after pa_cli_svg_end and on a zeroed svg). */
void pa_cli_svg_abort(pa_cli_svg *svg);

/* The elements. fill/stroke: colours ("#rrggbb", "none"); cls: an SVG class
 * attribute (NULL for none), which the tests use to count elements. */
void pa_cli_svg_rect(pa_cli_svg *svg, double x, double y, double w, double h,
                     const char *fill, const char *cls);
void pa_cli_svg_line(pa_cli_svg *svg, double x0, double y0, double x1,
                     double y1, const char *stroke, double width);
/* A closed polygon of n points xy[2i], xy[2i+1]; stroke NULL: inherited. */
void pa_cli_svg_polygon(pa_cli_svg *svg, int n, const double *xy,
                        const char *fill, const char *stroke);
/* Text at (x, y); anchor "start", "middle" or "end"; XML-escaped. */
void pa_cli_svg_text(pa_cli_svg *svg, double x, double y, const char *anchor,
                     double size, const char *fmt, ...)
    __attribute__((format(printf, 6, 7)));
/* Raw markup (group tags, clip paths, gradients), written as given. */
void pa_cli_svg_raw(pa_cli_svg *svg, const char *fmt, ...)
    __attribute__((format(printf, 2, 3)));

/* "#rrggbb" of quality q on the colour ramp of the pictures (q clamped to
 * [0, 1]; NaN gives grey), into buf (8 bytes). */
void pa_cli_svg_quality_colour(double q, char buf[8]);
/* "#rrggbb" of reference ref (a categorical palette of 10), into buf. */
void pa_cli_svg_ref_colour(int32_t ref, char buf[8]);

/* The histogram picture of `stats -svg` (one series: stats[0], nser = 1)
 * or of `adapt -svg` (before stats[0] and after stats[1], nser = 2, grouped
 * bars): the edge lengths in the Mmg bins with the in-range band shaded,
 * and the element qualities. title is printed on top. Writes path (through
 * the open output transaction, if any). Not collective. */
pa_status pa_cli_svg_histograms(const char *path, const char *title,
                                const pa_stats *stats, int nser,
                                const char *const *names);

#endif
