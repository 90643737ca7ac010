/*
 * params.c -- Mmg's parameter file (-f FILE, or IN.padapt beside the
 * mesh): local sizes and Hausdorff distances per reference.
 *
 *   Parameters
 *   N
 *   REF TYPE HMIN HMAX HAUSD     (N lines)
 *
 * TYPE names the entities with reference REF: Triangles and Tetrahedra
 * (3D: boundary triangles and elements), Edges and Triangles (2D: boundary
 * edges and elements). Blank lines and lines starting with # are skipped;
 * keywords are case-insensitive. Errors name the file and the line; every
 * rank reads the file, rank 0 reports.
 */
#include "cli.h"

#include <ctype.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

/* The next line that is not blank nor a comment, split into at most 6
 * words; returns the word count, 0 at the end of the file. */
static int next_words(FILE *fp, int *line, char buf[512], char *w[6]) {
  while (fgets(buf, 512, fp)) {
    (*line)++;
    int n = 0;
    for (char *t = strtok(buf, " \t\r\n"); t && n < 6; t = strtok(NULL, " \t\r\n"))
      w[n++] = t;
    if (n && w[0][0] != '#') return n;
  }
  return 0;
}

int pa_cli_read_params(const pa_cli *cli, const char *path, int dim,
                       pa_local_param **out, int *nout) {
  char buf[512], *w[6], msg[700];
  int line = 0, n, count = 0;
  pa_local_param *p = NULL;
  FILE *fp = fopen(path, "r");
  *out = NULL;
  *nout = 0;
  if (!fp) {
    snprintf(msg, sizeof msg, "%s: cannot open the parameter file", path);
    return cli->rank == 0 ? pa_cli_error(cli, "%s", msg) : 1;
  }
  n = next_words(fp, &line, buf, w);
  if (n != 1 || strcasecmp(w[0], "Parameters")) {
    snprintf(msg, sizeof msg, "%s:%d: expected the keyword Parameters", path,
             line);
    goto fail;
  }
  n = next_words(fp, &line, buf, w);
  char *end;
  long k = n == 1 ? strtol(w[0], &end, 10) : -1;
  if (n != 1 || *end || k < 0 || k > 100000) {
    snprintf(msg, sizeof msg, "%s:%d: expected the number of parameters", path,
             line);
    goto fail;
  }
  count = (int)k;
  p = calloc(count ? (size_t)count : 1, sizeof *p);
  if (!p) {
    snprintf(msg, sizeof msg, "%s: out of memory", path);
    goto fail;
  }
  for (int i = 0; i < count; i++) {
    double h[3];
    n = next_words(fp, &line, buf, w);
    if (n == 0) {
      snprintf(msg, sizeof msg, "%s:%d: %d parameters announced, %d found",
               path, line, count, i);
      goto fail;
    }
    long ref = n == 5 ? strtol(w[0], &end, 10) : 0;
    int ok = n == 5 && !*end;
    for (int j = 0; j < 3 && ok; j++) ok = pa_cli_parse_num(w[2 + j], &h[j]);
    if (!ok) {
      snprintf(msg, sizeof msg, "%s:%d: expected REF TYPE HMIN HMAX HAUSD",
               path, line);
      goto fail;
    }
    if (!(h[0] > 0) || !(h[1] > 0) || !(h[2] > 0) || h[0] > h[1]) {
      snprintf(msg, sizeof msg,
               "%s:%d: hmin, hmax, hausd must be positive, hmin <= hmax "
               "(got %g %g %g)", path, line, h[0], h[1], h[2]);
      goto fail;
    }
    const char *t = w[1];
    int kind = -1;
    if (!strcasecmp(t, "Tetrahedra") && dim == 3) kind = PA_ELEMENT;
    if (!strcasecmp(t, "Triangles")) kind = dim == 3 ? PA_BOUNDARY : PA_ELEMENT;
    if (!strcasecmp(t, "Edges") && dim == 2) kind = PA_BOUNDARY;
    if (kind < 0) {
      snprintf(msg, sizeof msg, "%s:%d: '%s' in a %dD mesh (expected %s)",
               path, line, t, dim,
               dim == 3 ? "Triangles or Tetrahedra" : "Edges or Triangles");
      goto fail;
    }
    p[i] = (pa_local_param){kind, (int)ref, h[0], h[1], h[2]};
  }
  if (next_words(fp, &line, buf, w)) {
    snprintf(msg, sizeof msg, "%s:%d: more lines than the %d parameters "
             "announced", path, line, count);
    goto fail;
  }
  fclose(fp);
  *out = p;
  *nout = count;
  return 0;
fail:
  fclose(fp);
  free(p);
  return cli->rank == 0 ? pa_cli_error(cli, "%s", msg) : 1; /* all read it */
}
