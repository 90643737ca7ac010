/*
 * io.h -- internal helpers shared by the file formats of src/io/.
 *
 * Every writer writes to "<path>.tmp.<pid>" and renames it onto path only
 * after a complete, successful write (pa__out_open / pa__out_commit /
 * pa__out_abort), so a failure never leaves a partial or truncated file.
 * Readers report errors as "FILE:LINE: message" (binary files: byte offset).
 */
#ifndef PA_IO_H
#define PA_IO_H

#include "mesh/mesh.h"

#include <stdio.h>

typedef struct pa_outfile {
  FILE *fp;
  char *path;    /* final path */
  char *tmppath; /* temporary path written first */
} pa_outfile;

/* Open a temporary file beside path for writing ("wb"). */
pa_status pa__out_open(pa_outfile *out, const char *path);
/* Flush, close and rename onto the final path; checks every write error. */
pa_status pa__out_commit(pa_outfile *out);
/* Close and remove the temporary file (safe to call after commit or twice). */
void pa__out_abort(pa_outfile *out);

/* Lower-case extension of path including the dot (".mesh"), "" if none. */
const char *pa__path_ext(const char *path, char *buf, size_t len);

/* Format readers/writers, dispatched by pa_mesh_read/pa_mesh_write. */
pa_status pa__medit_read(const char *path, pa_mesh **mesh);
pa_status pa__medit_write(pa_mesh *mesh, const char *path, int binary,
                          int version);
pa_status pa__gmsh_read(const char *path, pa_mesh **mesh);
pa_status pa__gmsh_write(pa_mesh *mesh, const char *path, int binary);
pa_status pa__vtu_write(pa_mesh *mesh, const char *path);

#endif /* PA_IO_H */
