/* remesh.c -- STUB, being written: remesher interface and driver. */
#include "mesh/mesh.h"
void pa_remesh_opts_default(pa_remesh_opts *o) { memset(o, 0, sizeof *o); o->hgrad = 1.3; o->hausd = 0.01; o->angle = 45; }
const pa_remesher *pa_remesher_builtin(void) { return NULL; }
pa_status pa_remesh(const pa_remesher *r, pa_mesh *m, const pa_remesh_opts *o, pa_remesh_report *rep) { (void)r; (void)m; (void)o; (void)rep; return pa__error(PA_ERR_UNSUPPORTED, __FILE__, __LINE__, "not yet implemented"); }
