/* vtu.c -- STUB, being written: VTK XML .vtu writer. */
#include "io/io.h"
pa_status pa__vtu_write(pa_mesh *m, const char *p) { (void)p; (void)m; return pa__error(PA_ERR_UNSUPPORTED, __FILE__, __LINE__, "not yet implemented"); }
