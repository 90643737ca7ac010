/* gmsh.c -- STUB, being written: Gmsh MSH 4.1 / 2.2. */
#include "io/io.h"
pa_status pa__gmsh_read(const char *p, pa_mesh **m) { (void)p; (void)m; return pa__error(PA_ERR_UNSUPPORTED, __FILE__, __LINE__, "not yet implemented"); }
pa_status pa__gmsh_write(pa_mesh *m, const char *p, int b) { (void)p; (void)m; (void)b; return pa__error(PA_ERR_UNSUPPORTED, __FILE__, __LINE__, "not yet implemented"); }
