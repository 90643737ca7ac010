/*
 * cli_opts.c -- the option tables of the commands (cli.h): one table per
 * command declares each option once, with the kind of its value, where the
 * value goes and its line of -h; pa_cli_parse reads argv by it and
 * pa_cli_help prints the -h text from it, so the two cannot disagree.
 *
 * An optional number (PA_CLI_OPTNUM) takes the next argument only when it
 * is a number, else its default.
 *
 * Messages: "CMD: OPT needs WANT, got 'VALUE'" for a value that is not what
 * the option takes (VALUE "nothing" when argv ran out), "CMD: OPT needs
 * WANT" for a missing string, "CMD: unknown option 'OPT' (see padapt CMD
 * -h)". The help: each table line is "  LABEL" padded to the spec's width
 * (two spaces after a longer label), then the first line of its help; the
 * other lines of its help start at the same column.
 */
#include "cli.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* 1 if name is one of the space-separated names of o. */
static int has_name(const pa_cli_opt *o, const char *name) {
  size_t n = strlen(name);
  for (const char *p = o->names; p && *p;) {
    size_t k = strcspn(p, " ");
    if (k == n && !strncmp(p, name, n)) return 1;
    p += k;
    while (*p == ' ') p++;
  }
  return 0;
}

static int need(const pa_cli *cli, const pa_cli_spec *s, const char *name,
                const char *want, const char *val) {
  return pa_cli_error(cli, "%s: %s needs %s, got '%s'", s->cmd, name, want,
                      val ? val : "nothing");
}

/* Parse the value(s) of option o, given as name at argv[*i], into args;
 * moves *i past them. Returns 0, or 1 after printing an error. */
static int take(const pa_cli *cli, const pa_cli_spec *s, const pa_cli_opt *o,
                const char *name, int argc, char **argv, int *i, void *args) {
  char *at = (char *)args + o->at;
  const char *val = *i + 1 < argc ? argv[*i + 1] : NULL;
  double x = 0;
  switch (o->kind) {
  case PA_CLI_FLAG:
    *(int *)at = 1;
    return 0;
  case PA_CLI_STR:
    if (!val) return pa_cli_error(cli, "%s: %s needs %s", s->cmd, name, o->want);
    *(const char **)at = val;
    break;
  case PA_CLI_POS:
    if (!pa_cli_parse_num(val, &x) || !(x > 0))
      return need(cli, s, name, o->want, val);
    *(double *)at = x;
    break;
  case PA_CLI_NUM:
    if (!pa_cli_parse_num(val, &x) || x < o->lo || x > o->hi)
      return need(cli, s, name, o->want, val);
    *(double *)at = x;
    break;
  case PA_CLI_OPTNUM:
    if (!pa_cli_parse_num(val, &x)) { /* no value: the default */
      *(double *)at = o->dflt;
      return 0;
    }
    if (x < o->lo || x > o->hi) return need(cli, s, name, o->want, val);
    *(double *)at = x;
    break;
  case PA_CLI_INT:
    if (!pa_cli_parse_num(val, &x) || x < o->lo || x > o->hi || x != floor(x))
      return need(cli, s, name, o->want, val);
    *(int *)at = (int)x;
    break;
  case PA_CLI_FN: {
    char *v[PA_CLI_MAX_VALUES] = {NULL};
    for (int k = 0; k < o->nval && *i + 1 + k < argc; k++) v[k] = argv[*i + 1 + k];
    if (o->fn(cli, s, name, v, args)) return 1;
    *i += o->nval;
    return 0;
  }
  default:
    return pa_cli_error(cli, "%s: %s: not an option", s->cmd, name);
  }
  (*i)++;
  return 0;
}

int pa_cli_parse(const pa_cli *cli, const pa_cli_spec *s, int argc,
                 char **argv, void *args) {
  for (int i = 1; i < argc; i++) {
    const char *a = argv[i];
    if (!strcmp(a, "-h") || !strcmp(a, "--help")) {
      if (cli->rank == 0) pa_cli_help(s, stdout);
      return -1;
    }
    if (a[0] != '-' || !a[1]) { /* a positional argument ("-" too) */
      if (s->positional(cli, a, args)) return 1;
      continue;
    }
    const pa_cli_opt *o = s->opt;
    while (o->kind != PA_CLI_END && !(o->names && has_name(o, a))) o++;
    if (o->kind == PA_CLI_END)
      return pa_cli_error(cli, "%s: unknown option '%s' (see padapt %s -h)",
                          s->cmd, a, s->help_cmd ? s->help_cmd : s->cmd);
    if (take(cli, s, o, a, argc, argv, &i, args)) return 1;
  }
  return 0;
}

void pa_cli_help(const pa_cli_spec *s, FILE *out) {
  fputs(s->usage, out);
  for (const pa_cli_opt *o = s->opt; o->kind != PA_CLI_END; o++) {
    if (!o->label) { /* listed by another line, or a line of its own */
      if (!o->names && o->help) fputs(o->help, out);
      continue;
    }
    int n = (int)strlen(o->label);
    fprintf(out, "  %s%*s", o->label, n < s->width ? s->width - n : 2, "");
    for (const char *h = o->help; *h;) {
      size_t k = strcspn(h, "\n");
      fprintf(out, "%.*s\n", (int)k, h);
      h += k;
      if (*h == '\n') h++;
      if (*h) fprintf(out, "  %*s", s->width, "");
    }
  }
  if (s->tail) fputs(s->tail, out);
}
