/* metric.c -- STUB, being written: metric algebra, lengths, quality. */
#include "metric/metric.h"
#define STUB return pa__error(PA_ERR_UNSUPPORTED, __FILE__, __LINE__, "not yet implemented")
int pa__metric_valid(int dim, int ncomp, const double *m) { (void)dim; (void)ncomp; (void)m; return 1; }
void pa__metric_tensor(int dim, int ncomp, const double *m, double *t) { (void)dim; (void)ncomp; (void)m; (void)t; }
void pa__sym_eigen(int dim, const double *m, double *l, double *v) { (void)dim; (void)m; (void)l; (void)v; }
void pa__sym_from_eigen(int dim, const double *l, const double *v, double *m) { (void)dim; (void)m; (void)l; (void)v; }
double pa__sym_det(int dim, const double *m) { (void)dim; (void)m; return 0; }
int pa__sym_inverse(int dim, const double *m, double *inv) { (void)dim; (void)m; (void)inv; return 0; }
void pa__metric_log(int dim, const double *m, double *l) { (void)dim; (void)m; (void)l; }
void pa__metric_exp(int dim, const double *l, double *m) { (void)dim; (void)m; (void)l; }
void pa__metric_interp(int dim, int ncomp, int n, const double *const *m, const double *w, double *out) { (void)dim; (void)ncomp; (void)n; (void)m; (void)w; (void)out; }
void pa__metric_intersect(int dim, int ncomp, const double *a, const double *b, double *out) { (void)dim; (void)ncomp; (void)a; (void)b; (void)out; }
void pa__metric_clamp(int dim, int ncomp, double *m, double hmin, double hmax) { (void)dim; (void)ncomp; (void)m; (void)hmin; (void)hmax; }
double pa__metric_sqlen(int dim, int ncomp, const double *m, const double *e) { (void)dim; (void)ncomp; (void)m; (void)e; return 0; }
double pa__edge_length(int dim, int ncomp, const double *a, const double *b, const double *ma, const double *mb) { (void)dim; (void)ncomp; (void)a; (void)b; (void)ma; (void)mb; return 0; }
double pa__quality(int dim, int ncomp, const double *const *x, const double *const *m) { (void)dim; (void)ncomp; (void)x; (void)m; return 0; }
double pa_metric_edge_length(int dim, int ncomp, const double *a, const double *b, const double *ma, const double *mb) { return pa__edge_length(dim, ncomp, a, b, ma, mb); }
pa_status pa_mesh_metric_clamp(pa_mesh *m, double hmin, double hmax) { (void)m; (void)hmin; (void)hmax; STUB; }
