/*
 * params.c -- Mmg's parameter file (-f FILE, or IN.padapt beside the
 * mesh): local sizes and Hausdorff distances per reference, and the
 * materials of the level-set cut (-ls), in sections of any order, each at
 * most once:
 *
 *   Parameters
 *   N
 *   REF TYPE HMIN HMAX HAUSD     (N lines)
 *
 *   LSReferences
 *   N
 *   REF REF_IN REF_OUT           (elements of REF split into these two)
 *   REF nosplit                  (elements of REF kept whole)
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
#include <stdint.h>
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

/* A whole integer word into *v; 1 on success. */
static int parse_int(const char *w, long *v) {
  char *end;
  *v = strtol(w, &end, 10);
  return *w && !*end && *v >= INT32_MIN && *v <= INT32_MAX;
}

/* The count line after a section keyword into *k; 0 after writing msg. */
static int section_count(FILE *fp, int *line, const char *path, long *k,
                         char *msg, size_t n) {
  char buf[512], *w[6];
  int nw = next_words(fp, line, buf, w);
  if (nw != 1 || !parse_int(w[0], k) || *k < 0 || *k > 100000) {
    snprintf(msg, n, "%s:%d: expected the number of entries", path, *line);
    return 0;
  }
  return 1;
}

/* The N lines of a Parameters section into p (count entries). */
static int read_local(FILE *fp, int *line, const char *path, int dim,
                      pa_local_param *p, int count, char *msg, size_t nmsg) {
  char buf[512], *w[6];
  for (int i = 0; i < count; i++) {
    double h[3];
    long ref;
    int n = next_words(fp, line, buf, w);
    if (n == 0) {
      snprintf(msg, nmsg, "%s:%d: %d parameters announced, %d found", path,
               *line, count, i);
      return 0;
    }
    int ok = n == 5 && parse_int(w[0], &ref);
    for (int j = 0; j < 3 && ok; j++) ok = pa_cli_parse_num(w[2 + j], &h[j]);
    if (!ok) {
      snprintf(msg, nmsg, "%s:%d: expected REF TYPE HMIN HMAX HAUSD", path,
               *line);
      return 0;
    }
    if (!(h[0] > 0) || !(h[1] > 0) || !(h[2] > 0) || h[0] > h[1]) {
      snprintf(msg, nmsg,
               "%s:%d: hmin, hmax, hausd must be positive, hmin <= hmax "
               "(got %g %g %g)", path, *line, h[0], h[1], h[2]);
      return 0;
    }
    const char *t = w[1];
    int kind = -1;
    if (!strcasecmp(t, "Tetrahedra") && dim == 3) kind = PA_ELEMENT;
    if (!strcasecmp(t, "Triangles")) kind = dim == 3 ? PA_BOUNDARY : PA_ELEMENT;
    if (!strcasecmp(t, "Edges") && dim == 2) kind = PA_BOUNDARY;
    if (kind < 0) {
      snprintf(msg, nmsg, "%s:%d: '%s' in a %dD mesh (expected %s)", path,
               *line, t, dim,
               dim == 3 ? "Triangles or Tetrahedra" : "Edges or Triangles");
      return 0;
    }
    p[i] = (pa_local_param){kind, (int)ref, h[0], h[1], h[2]};
  }
  return 1;
}

/* The N lines of an LSReferences section into mat (count entries). */
static int read_materials(FILE *fp, int *line, const char *path,
                          pa_ls_material *mat, int count, char *msg,
                          size_t nmsg) {
  char buf[512], *w[6];
  for (int i = 0; i < count; i++) {
    long r[3] = {0, 0, 0};
    int n = next_words(fp, line, buf, w);
    if (n == 0) {
      snprintf(msg, nmsg, "%s:%d: %d materials announced, %d found", path,
               *line, count, i);
      return 0;
    }
    int nosplit = n == 2 && !strcasecmp(w[1], "nosplit");
    int ok = parse_int(w[0], &r[0]) &&
             (nosplit || (n == 3 && parse_int(w[1], &r[1]) &&
                          parse_int(w[2], &r[2])));
    if (!ok) {
      snprintf(msg, nmsg, "%s:%d: expected REF REF_IN REF_OUT or REF nosplit",
               path, *line);
      return 0;
    }
    for (int j = 0; j < i; j++)
      if (mat[j].ref == (int32_t)r[0]) {
        snprintf(msg, nmsg, "%s:%d: material %ld listed twice", path, *line,
                 r[0]);
        return 0;
      }
    mat[i] = (pa_ls_material){(int32_t)r[0], !nosplit, (int32_t)r[1],
                              (int32_t)r[2]};
  }
  return 1;
}

int pa_cli_read_params(const pa_cli *cli, const char *path, int dim,
                       pa_local_param **out, int *nout, pa_ls_material **mat,
                       int *nmat) {
  char buf[512], *w[6], msg[700];
  int line = 0, n, nsec = 0, seen[2] = {0, 0};
  FILE *fp = fopen(path, "r");
  *out = NULL;
  *nout = 0;
  if (mat) {
    *mat = NULL;
    *nmat = 0;
  }
  if (!fp) {
    snprintf(msg, sizeof msg, "%s: cannot open the parameter file", path);
    return cli->rank == 0 ? pa_cli_error(cli, "%s", msg) : 1;
  }
  while ((n = next_words(fp, &line, buf, w)) > 0) {
    int local = n == 1 && !strcasecmp(w[0], "Parameters");
    int lsref = n == 1 && !strcasecmp(w[0], "LSReferences");
    if ((!local && !lsref) || seen[lsref]) {
      snprintf(msg, sizeof msg, "%s:%d: expected the keyword %s", path, line,
               seen[0] ? "LSReferences"
               : seen[1] ? "Parameters"
                         : "Parameters or LSReferences");
      goto fail;
    }
    seen[lsref] = 1;
    nsec++;
    long k;
    if (!section_count(fp, &line, path, &k, msg, sizeof msg)) goto fail;
    if (local) {
      *out = calloc(k ? (size_t)k : 1, sizeof **out);
      if (!*out) goto nomem;
      *nout = (int)k;
      if (!read_local(fp, &line, path, dim, *out, (int)k, msg, sizeof msg))
        goto fail;
    } else {
      pa_ls_material *m = calloc(k ? (size_t)k : 1, sizeof *m);
      if (!m) goto nomem;
      int ok = read_materials(fp, &line, path, m, (int)k, msg, sizeof msg);
      if (mat && ok) {
        *mat = m;
        *nmat = (int)k;
      } else {
        free(m);
      }
      if (!ok) goto fail;
    }
  }
  if (!nsec) {
    snprintf(msg, sizeof msg, "%s:%d: expected the keyword Parameters or "
             "LSReferences", path, line);
    goto fail;
  }
  fclose(fp);
  return 0;
nomem:
  snprintf(msg, sizeof msg, "%s: out of memory", path);
fail:
  fclose(fp);
  free(*out);
  *out = NULL;
  *nout = 0;
  if (mat) {
    free(*mat);
    *mat = NULL;
    *nmat = 0;
  }
  return cli->rank == 0 ? pa_cli_error(cli, "%s", msg) : 1; /* all read it */
}
