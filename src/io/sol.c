/* sol.c -- STUB, being written: .sol/.solb solutions. */
#include "io/io.h"
#define STUB return pa__error(PA_ERR_UNSUPPORTED, __FILE__, __LINE__, "not yet implemented")
pa_status pa_sol_create(int dim, pa_idx n, pa_sol **s) { (void)dim; (void)n; (void)s; STUB; }
void pa_sol_destroy(pa_sol *s) { (void)s; }
int pa_sol_dim(const pa_sol *s) { (void)s; return 0; }
pa_idx pa_sol_nvert(const pa_sol *s) { (void)s; return 0; }
int pa_sol_nfield(const pa_sol *s) { (void)s; return 0; }
pa_status pa_sol_add_field(pa_sol *s, pa_sol_kind k, const double *v) { (void)s; (void)k; (void)v; STUB; }
pa_status pa_sol_field(pa_sol *s, int k, pa_sol_kind *kind, int *nc, double **v) { (void)s; (void)k; (void)kind; (void)nc; (void)v; STUB; }
pa_status pa_sol_read(const char *p, pa_sol **s) { (void)p; (void)s; STUB; }
pa_status pa_sol_write(const pa_sol *s, const char *p) { (void)s; (void)p; STUB; }
pa_status pa_mesh_metric_from_sol(pa_mesh *m, const pa_sol *s, int k) { (void)m; (void)s; (void)k; STUB; }
pa_status pa_mesh_metric_to_sol(pa_mesh *m, int w, pa_sol **s) { (void)m; (void)w; (void)s; STUB; }
