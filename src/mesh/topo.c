/* topo.c -- STUB, being written: adjacency, balls, boundary lookup, volumes, check. */
#include "mesh/mesh.h"
#define STUB return pa__error(PA_ERR_UNSUPPORTED, __FILE__, __LINE__, "not yet implemented")
pa_status pa_mesh_build_adjacency(pa_mesh *m, const pa_idx **a) { (void)m; (void)a; STUB; }
pa_status pa_mesh_build_balls(pa_mesh *m, const pa_idx **s, const pa_idx **b) { (void)m; (void)s; (void)b; STUB; }
pa_status pa_mesh_find_bdry(pa_mesh *m, const pa_idx *v, pa_idx *i) { (void)m; (void)v; (void)i; STUB; }
double pa_mesh_elem_volume(const pa_mesh *m, pa_idx e) { (void)m; (void)e; return 0; }
double pa_mesh_volume(const pa_mesh *m) { (void)m; return 0; }
pa_status pa_mesh_check(pa_mesh *m) { (void)m; STUB; }
void pa__elem_face(const pa_mesh *m, pa_idx e, int i, pa_idx *f) { (void)m; (void)e; (void)i; (void)f; }
double pa__simplex_volume(int dim, const double *const *x) { (void)dim; (void)x; return 0; }
pa_status pa_mesh_build_boundary(pa_mesh *m, int32_t r, pa_idx *n) { (void)m; (void)r; (void)n; STUB; }
