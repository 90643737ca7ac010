/*
 * gmsh.h -- Gmsh MSH 4.1 and 2.2 meshes (gmsh.c).
 */
#ifndef PA_IO_GMSH_H
#define PA_IO_GMSH_H

#include "mesh/mesh.h"

pa_status pa__gmsh_read(const char *path, pa_mesh **mesh);
pa_status pa__gmsh_write(pa_mesh *mesh, const char *path, int binary);

#endif /* PA_IO_GMSH_H */
