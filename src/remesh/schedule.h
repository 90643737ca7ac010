/*
 * schedule.h -- when the refinement rounds of the built-in remeshers stop
 * (schedule.c): one rule for the 2D (remesh2d/driver_2d.c) and the 3D
 * (remesh3d/driver_3d.c) remesher, each giving its own bounds.
 *
 * A round splits the long edges, collapses the short ones, swaps and moves;
 * the rounds repeat until the mesh settles. After each round the remesher
 * hands its counts of splits and collapses to pa__rounds_stop, which says
 * stop when
 *  - at least `min` rounds ran and the count is at most `settled` times
 *    the live elements (settled), or
 *  - at least `min` rounds ran and the last PA__ROUNDS_STALL rounds were a
 *    ping-pong without the count falling below PA__ROUNDS_DROP times its
 *    value when it last did (stalled). A round is a ping-pong, operations
 *    undoing each other (next to frozen entities whose edges cannot reach
 *    the size, mostly), when its count is at most `tiny` times the live
 *    elements, or (with `balanced`) when splits and collapses are within a
 *    factor PA__ROUNDS_BALANCE of each other. A refinement or coarsening
 *    front is one-sided and never stalls this way, and a count that keeps
 *    falling, however slowly, keeps the rounds going.
 * The caller bounds the number of rounds.
 */
#ifndef PA_REMESH_SCHEDULE_H
#define PA_REMESH_SCHEDULE_H

typedef struct pa__rounds {
  /* the remesher's bounds */
  int min;         /* rounds that run whatever their counts */
  double settled;  /* share of the live elements: settled at or below */
  double tiny;     /* share of the live elements: a ping-pong at or below
                      (0: no such share) */
  int balanced;    /* balanced splits and collapses are a ping-pong */
  /* state */
  int done;        /* rounds done */
  long ref;        /* splits + collapses when they last fell below
                      PA__ROUNDS_DROP times this value (-1: no round yet) */
  int stall;       /* ping-pong rounds in a row since */
} pa__rounds;

/* Start the rounds of a remesh with the remesher's bounds. */
void pa__rounds_start(pa__rounds *r, int min, double settled, double tiny,
                      int balanced);

/* After a round of nsplit splits and ncollapse collapses, on a mesh of nlive
 * live elements: 1 when the rounds stop. */
int pa__rounds_stop(pa__rounds *r, long nsplit, long ncollapse, double nlive);

#endif /* PA_REMESH_SCHEDULE_H */
