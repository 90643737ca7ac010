/* medit.c -- STUB, being written: Medit .mesh/.meshb. */
#include "io/io.h"
pa_status pa__medit_read(const char *p, pa_mesh **m) { (void)p; (void)m; return pa__error(PA_ERR_UNSUPPORTED, __FILE__, __LINE__, "not yet implemented"); }
pa_status pa__medit_write(pa_mesh *m, const char *p, int b, int v) { (void)p; (void)m; (void)b; (void)v; return pa__error(PA_ERR_UNSUPPORTED, __FILE__, __LINE__, "not yet implemented"); }
