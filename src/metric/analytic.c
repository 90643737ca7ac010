/* analytic.c -- STUB, being written: built-in analytic metric fields. */
#include "metric/metric.h"
pa_status pa_metric_analytic(pa_mesh *m, const char *spec) { (void)m; (void)spec; return pa__error(PA_ERR_UNSUPPORTED, __FILE__, __LINE__, "not yet implemented"); }
const char *const *pa_metric_analytic_names(void) { static const char *const n[] = {NULL}; return n; }
