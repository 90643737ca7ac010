/*
 * json.c -- the statistics of a mesh as a JSON report (pa_stats_write_json),
 * written through an output file (output.c): all or nothing.
 */
#include "io/output.h"
#include "metric/metric.h"

#include <math.h>

/* A JSON number (%.17g round-trips), or null when not finite. */
static void json_double(FILE *fp, const char *key, double x) {
  if (isfinite(x))
    fprintf(fp, "  \"%s\": %.17g,\n", key, x);
  else
    fprintf(fp, "  \"%s\": null,\n", key);
}

pa_status pa_stats_write_json(const pa_stats *s, const char *extra,
                              const char *path) {
  pa_status st = PA_SUCCESS;
  pa__outfile out = {0};
  PA_CHECK(s && path, PA_ERR_ARG, "pa_stats_write_json: NULL argument");
  PA_CALL(pa__out_open(&out, path));
  FILE *fp = out.fp;
  fprintf(fp, "{\n");
  fprintf(fp, "  \"padapt_version\": \"%s\",\n", pa_version());
  fprintf(fp, "  \"dim\": %d,\n", s->dim);
  fprintf(fp, "  \"vertices\": %lld,\n", (long long)s->nvert);
  fprintf(fp, "  \"elements\": %lld,\n", (long long)s->nelem);
  fprintf(fp, "  \"boundary\": %lld,\n", (long long)s->nbdry);
  json_double(fp, "volume", s->volume);
  fprintf(fp, "  \"inverted\": %lld,\n", (long long)s->ninverted);
  fprintf(fp, "  \"valid\": %s,\n", s->valid ? "true" : "false");
  fprintf(fp, "  \"has_metric\": %s,\n", s->has_metric ? "true" : "false");
  fprintf(fp, "  \"edges\": %lld,\n", (long long)s->nedge);
  json_double(fp, "edge_min", s->edge_min);
  json_double(fp, "edge_max", s->edge_max);
  json_double(fp, "edge_mean",
              s->nedge > 0 ? s->edge_sum / (double)s->nedge : 0.0);
  json_double(fp, "edge_in_range",
              pa__share(s->edge_hist[PA_STATS_EDGE_NBIN - 1], s->nedge));
  fprintf(fp, "  \"edge_hist\": [");
  for (int b = 0; b < PA_STATS_EDGE_NBIN; b++)
    fprintf(fp, "%s%lld", b ? ", " : "", (long long)s->edge_hist[b]);
  fprintf(fp, "],\n");
  json_double(fp, "quality_worst", s->qual_min);
  json_double(fp, "quality_mean",
              s->nelem > 0 ? s->qual_sum / (double)s->nelem : 0.0);
  json_double(fp, "quality_best", s->qual_max);
  json_double(fp, "quality_above_0.5", pa__share(s->qual_above_05, s->nelem));
  json_double(fp, "quality_above_0.12", pa__share(s->qual_above_012, s->nelem));
  fprintf(fp, "  \"quality_hist\": [");
  for (int b = 0; b < PA_STATS_QUAL_NBIN; b++)
    fprintf(fp, "%s%lld", b ? ", " : "", (long long)s->qual_hist[b]);
  fprintf(fp, "]");
  if (extra && extra[0]) fprintf(fp, ",\n  %s", extra);
  fprintf(fp, "\n}\n");
  PA_CALL(pa__out_commit(&out));
cleanup:
  pa__out_abort(&out);
  return st;
}
