/*
 * remesh.h -- private header of the remesher driver (remesh.c): the
 * built-in remesher's entries, one per dimension, which the driver calls
 * and the remeshers define.
 *
 * Layering (scripts/check-layers.sh): src/remesh2d/ and src/remesh3d/
 * include the headers of this folder (this one for their entry, schedule.h
 * for the pass schedule they share), never the reverse, and neither
 * includes the other. The driver reaches the two remeshers only through the
 * declarations below; the linker joins them.
 */
#ifndef PA_REMESH_H
#define PA_REMESH_H

#include "metric/metric.h"

/*
 * Adapt the triangle mesh (pa__remesh2d, src/remesh2d/driver_2d.c) or the
 * tetrahedral mesh (pa__remesh3d, src/remesh3d/driver_3d.c) in place to its
 * metric; the 3D one also takes opts->hsiz when the mesh has none. Contract
 * of pa_remesher.remesh: entities flagged PA_FLAG_REQUIRED come back bit for
 * bit, report->outcome is set on PA_SUCCESS, and on any error or
 * PA_REMESH_FAILED the mesh is as given. The driver prepares the metric
 * (pa_remesh) and, in 3D, bisects the mesh first (leb.c). Not collective.
 */
pa_status pa__remesh2d(pa_mesh *mesh, const pa_remesh_opts *opts,
                       pa_remesh_report *report);
pa_status pa__remesh3d(pa_mesh *mesh, const pa_remesh_opts *opts,
                       pa_remesh_report *report);

/*
 * The element and boundary fields of the old mesh o (the remesher's input,
 * with those fields) carried onto the new mesh m (the output, without them;
 * transfer.c): each field is added to m with the values its transfer mode
 * gives (pa_transfer), and *rep says what it took. o is in/out only for its
 * cached adjacency. On failure m gets none of them. Not collective.
 */
pa_status pa__transfer_fields(pa_mesh *o, pa_mesh *m, pa_transfer_report *rep);

#endif /* PA_REMESH_H */
