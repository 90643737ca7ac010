/* generate.c -- STUB, being written: structured box generators. */
#include "mesh/mesh.h"
pa_status pa_mesh_generate_box(int dim, int n, pa_mesh **m) { (void)dim; (void)n; (void)m; return pa__error(PA_ERR_UNSUPPORTED, __FILE__, __LINE__, "not yet implemented"); }
