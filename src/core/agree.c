/*
 * agree.c -- the agreement of collective routines on a status: every rank
 * passes its own, every rank gets back the status and message of the lowest
 * failing rank (the rule and its use: src/dmesh/exchange.h). Here, below
 * every component, so that the partitioner and the distributed mesh share
 * it.
 */
#include "core/core.h"

#include <stdio.h>
#include <string.h>

static _Thread_local int agreed_fail;                 /* last agree failed */
static _Thread_local char agreed_msg[256];            /* its message prefix */

void pa__agree_reset(void) { agreed_fail = 0; }

pa_status pa__agree(MPI_Comm comm, pa_status st) {
  int rank, size, first;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  int mine = st != PA_SUCCESS ? rank : size;
  MPI_Allreduce(&mine, &first, 1, MPI_INT, MPI_MIN, comm);
  if (first == size) {
    agreed_fail = 0;
    return PA_SUCCESS;
  }
  /* Broadcast the status and message of the lowest failing rank. */
  struct {
    int code;
    char msg[1000];
  } m;
  memset(&m, 0, sizeof m);
  if (rank == first) {
    m.code = (int)st;
    snprintf(m.msg, sizeof m.msg, "%s", pa_last_error());
  }
  MPI_Bcast(&m, (int)sizeof m, MPI_BYTE, first, comm);
  pa_status code = (pa_status)m.code;
  if (rank != first)
    pa__error(code, __FILE__, __LINE__, "rank %d: %s", first, m.msg);
  agreed_fail = 1;
  snprintf(agreed_msg, sizeof agreed_msg, "%s", pa_last_error());
  return code;
}

pa_status pa__agree_end(MPI_Comm comm, pa_status st) {
  if (st != PA_SUCCESS && agreed_fail &&
      !strncmp(agreed_msg, pa_last_error(), sizeof agreed_msg - 1))
    return st;
  return pa__agree(comm, st);
}

