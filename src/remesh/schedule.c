/*
 * schedule.c -- the stopping rule of the built-in remeshers' refinement
 * rounds (schedule.h), shared by the 2D and the 3D remesher.
 *
 * Invariant: the rule depends only on the counts and the live elements
 * handed to it, so the rounds stop at the same round from run to run.
 */
#include "remesh/schedule.h"

/* Splits and collapses within this factor of each other undo each other
 * (2D: a steady ~47 + 47 next to tiny frozen triangles in a 1 500-element
 * piece ran all 80 rounds before this test); a refinement or coarsening
 * front does one of them many times more. */
#define ROUNDS_BALANCE 3
/* A count below this share of the last reference (a 5 % drop) is progress:
 * the reference then moves, so a slow steady fall never stalls. */
#define ROUNDS_DROP 0.95
/* Ping-pong rounds in a row without such a drop that stop the rounds:
 * three, so that a count falling by 1.7 % a round (5 % in three) goes on. */
#define ROUNDS_STALL 3

void pa__rounds_start(pa__rounds *r, int min, double settled, double tiny,
                      int balanced) {
  r->min = min;
  r->settled = settled;
  r->tiny = tiny;
  r->balanced = balanced;
  r->done = 0;
  r->ref = -1;
  r->stall = 0;
}

int pa__rounds_stop(pa__rounds *r, long nsplit, long ncollapse, double nlive) {
  long n = nsplit + ncollapse;
  int may_stop = ++r->done >= r->min;
  if (may_stop && n <= r->settled * nlive) return 1;
  int pingpong = (r->tiny > 0 && n <= r->tiny * nlive) ||
                 (r->balanced && ROUNDS_BALANCE * nsplit >= ncollapse &&
                  ROUNDS_BALANCE * ncollapse >= nsplit);
  if (r->ref < 0 || n < ROUNDS_DROP * r->ref || !pingpong) {
    r->ref = n;
    r->stall = 0;
    return 0;
  }
  return may_stop && ++r->stall >= ROUNDS_STALL;
}
