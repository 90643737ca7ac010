/* stats.c -- STUB, being written: quality and mesh statistics. */
#include "metric/metric.h"
#define STUB return pa__error(PA_ERR_UNSUPPORTED, __FILE__, __LINE__, "not yet implemented")
double pa_mesh_elem_quality(pa_mesh *m, pa_idx e) { (void)m; (void)e; return 0; }
pa_status pa_mesh_stats(pa_mesh *m, pa_stats *s) { (void)m; (void)s; STUB; }
void pa_stats_print(const pa_stats *s, FILE *out) { (void)s; (void)out; }
pa_status pa_stats_write_json(const pa_stats *s, const char *extra, const char *path) { (void)s; (void)extra; (void)path; STUB; }
