/*
 * agree.c -- the agreement of collective routines on a status: every rank
 * passes its own, every rank gets back the status and message of the lowest
 * failing rank (the rule and its use: src/dmesh/exchange.h); and the error
 * of a failed MPI call (PA_CALL_MPI). Here, below every component, so that
 * the partitioner and the distributed mesh share them.
 */
#include "core/core.h"

#include <stdio.h>
#include <string.h>

static _Thread_local int agreed_fail;                 /* last agree failed */
static _Thread_local char agreed_msg[256];            /* its message prefix */

pa_status pa__mpi_error(int err, const char *call, const char *file,
                        int line) {
  char msg[MPI_MAX_ERROR_STRING];
  int len = 0;
  if (MPI_Error_string(err, msg, &len) != MPI_SUCCESS) len = 0;
  msg[len < MPI_MAX_ERROR_STRING ? len : MPI_MAX_ERROR_STRING - 1] = '\0';
  return pa__error(PA_ERR_MPI, file, line, "%.*s failed: %s",
                   (int)strcspn(call, "( "), call,
                   len ? msg : "unknown MPI error");
}

void pa__agree_reset(void) { agreed_fail = 0; }

pa_status pa__agree(MPI_Comm comm, pa_status st) {
  int rank, size, first;
  struct {
    int code;
    char msg[1000];
  } m;
  PA_CALL_MPI(MPI_Comm_rank(comm, &rank));
  PA_CALL_MPI(MPI_Comm_size(comm, &size));
  int mine = st != PA_SUCCESS ? rank : size;
  PA_CALL_MPI(MPI_Allreduce(&mine, &first, 1, MPI_INT, MPI_MIN, comm));
  if (first == size) {
    agreed_fail = 0;
    return PA_SUCCESS;
  }
  /* Broadcast the status and message of the lowest failing rank. */
  memset(&m, 0, sizeof m);
  if (rank == first) {
    m.code = (int)st;
    snprintf(m.msg, sizeof m.msg, "%s", pa_last_error());
  }
  PA_CALL_MPI(MPI_Bcast(&m, (int)sizeof m, MPI_BYTE, first, comm));
  st = (pa_status)m.code;
  if (rank != first)
    pa__error(st, __FILE__, __LINE__, "rank %d: %s", first, m.msg);
  agreed_fail = 1;
  snprintf(agreed_msg, sizeof agreed_msg, "%s", pa_last_error());
cleanup:
  return st;
}

pa_status pa__agree_end(MPI_Comm comm, pa_status st) {
  if (st != PA_SUCCESS && agreed_fail &&
      !strncmp(agreed_msg, pa_last_error(), sizeof agreed_msg - 1))
    return st;
  return pa__agree(comm, st);
}
