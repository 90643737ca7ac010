/*
 * piece.c -- the release of the arrays of an iteration of the piece
 * algorithm (pa__iter) and of one piece (pa__piece), which the steps free
 * as they finish with them (piece.h).
 */
#include "adapt/piece.h"

void pa__piece_release(pa__piece *pc) {
  pa_mesh_destroy(pc->in);
  pa_mesh_destroy(pc->out);
  pc->in = pc->out = NULL;
  pa__free(pc->vgid);
  pa__free(pc->skin);
  pa__free(pc->hot);
  pa__free(pc->vrank);
  pa__free(pc->match);
  pa__free(pc->ifgid);
  pa__free(pc->ifgive);
  pa__free(pc->dest);
  pa__free(pc->bfix);
  pc->dest = NULL;
  pc->bfix = NULL;
  pc->vgid = pc->ifgid = NULL;
  pc->skin = pc->hot = pc->ifgive = NULL;
  pc->vrank = NULL;
  pc->match = NULL;
  for (int k = 0; k < 4; k++) {
    pa__free(pc->kgid[k]);
    pa__free(pc->kpoff[k]);
    pa__free(pc->kpay[k]);
    pa__free(pc->reuse[k]);
    pc->kgid[k] = NULL;
    pc->kpoff[k] = NULL;
    pc->kpay[k] = NULL;
    pc->reuse[k] = NULL;
  }
}

void pa__iter_release_elements(pa__iter *it) {
  pa__free(it->tag);
  pa__free(it->work);
  pa__free(it->label);
  pa__free(it->vlab);
  pa__free(it->vinner);
  pa__free(it->vsurf);
  pa__free(it->bside);
  pa__free(it->bstart);
  pa__free(it->belem);
  it->tag = NULL;
  it->work = NULL;
  it->label = NULL;
  it->vlab = NULL;
  it->vinner = NULL;
  it->vsurf = NULL;
  it->bside = NULL;
  it->bstart = it->belem = NULL;
}

void pa__iter_free(pa__iter *it) {
  pa__iter_release_elements(it);
  pa__free(it->piece_work);
  pa__free(it->piece_rank);
  pa__free(it->piece_failed);
  for (int q = 0; it->pieces && q < it->npiece_local; q++)
    pa__piece_release(&it->pieces[q]);
  pa__free(it->pieces);
  memset(it, 0, sizeof *it);
}
