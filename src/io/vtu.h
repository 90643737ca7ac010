/*
 * vtu.h -- VTK XML unstructured grids, written only (vtu.c).
 */
#ifndef PA_IO_VTU_H
#define PA_IO_VTU_H

#include "mesh/mesh.h"

#include <stdint.h>

/* The arrays a distributed set's rank file adds (src/dmesh/dio.c); NULL
 * members are not written. */
typedef struct pa__vtu_extra {
  int rank;              /* cell data "rank" of every cell */
  const int64_t *vgid;   /* point data "gid", the points' GlobalIds */
  const uint8_t *vghost; /* point data "vtkGhostType": 1 (a duplicate) on
                            the vertices another rank owns */
  const int64_t *cgid;   /* cell data "gid": each cell's global id among
                            the entities of its kind (elements, boundary
                            entities, edges: the "entity" array) */
} pa__vtu_extra;
pa_status pa__vtu_write(pa_mesh *mesh, const char *path, int diagnostics,
                        const pa__vtu_extra *extra);

#endif /* PA_IO_VTU_H */
