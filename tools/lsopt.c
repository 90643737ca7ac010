/*
 * lsopt.c -- the level-set cut of `padapt adapt -ls PHI.sol` (Mmg's -ls):
 * its options from the command line and the LSReferences section of the
 * parameter file, reading the level set, the sequential cut, and what the
 * cut did, printed and as JSON. The parallel run cuts the distributed mesh
 * (tools/cmd_padapt.c, pa_dmesh_levelset_cut) with the same options.
 */
#include "cli.h"

#include <stdlib.h>
#include <string.h>

int pa_cli_ls_opts(const pa_cli *cli, const pa_cli_adapt_args *a, int dim,
                   pa_levelset_opts *o, pa_ls_material **mat) {
  pa_levelset_opts_default(o);
  *mat = NULL;
  o->value = a->lsval;
  o->ref_in = a->lsref[0];
  o->ref_out = a->lsref[1];
  o->ref_iface = a->isoref;
  o->rmc = a->rmc;
  if (a->params) {
    pa_local_param *local = NULL;
    int nlocal = 0, nmat = 0;
    int bad = pa_cli_read_params(cli, a->params, dim, &local, &nlocal, mat,
                                 &nmat);
    free(local);
    if (bad) return 1;
    o->mat = *mat;
    o->nmat = nmat;
  }
  return 0;
}

int pa_cli_ls_read(const pa_cli *cli, const pa_cli_adapt_args *a,
                   pa_mesh *mesh, double **phi) {
  pa_sol *sol = NULL;
  pa_sol_kind kind;
  int nc;
  double *val;
  *phi = NULL;
  pa_status st = pa_sol_read(a->ls, &sol);
  if (st) return pa_cli_fail(cli, st);
  int rc = 0;
  pa_idx nv = pa_mesh_nvert(mesh);
  if (pa_sol_nvert(sol) != nv)
    rc = pa_cli_error(cli, "adapt: -ls %s: %d values, but %s has %d vertices",
                      a->ls, (int)pa_sol_nvert(sol), a->in, (int)nv);
  else if (pa_sol_field(sol, 0, &kind, &nc, &val) != PA_SUCCESS || nc != 1)
    rc = pa_cli_error(cli, "adapt: -ls %s: the level set must be a scalar "
                           "field (its first field has %d components)",
                      a->ls, nc);
  else if (!(*phi = malloc(sizeof(double) * (nv ? (size_t)nv : 1))))
    rc = pa_cli_error(cli, "adapt: out of memory");
  else
    memcpy(*phi, val, sizeof(double) * (size_t)nv);
  pa_sol_destroy(sol);
  return rc;
}

void pa_cli_ls_report(const pa_cli_adapt_args *a, const pa_levelset_opts *o,
                      const pa_levelset_report *r) {
  if (a->remesh.verbosity >= 0) {
    printf(" -- LEVEL SET %s, iso-value %g\n", a->ls, o->value);
    printf("    values in [%g, %g], %lld snapped to the iso-value\n",
           r->phi_min, r->phi_max, (long long)r->nsnapped);
    if (o->rmc > 0)
      printf("    components removed (below %g of the volume): %lld inside, "
             "%lld outside\n",
             o->rmc, (long long)r->nremoved_in, (long long)r->nremoved_out);
    printf("    %lld edges and %lld elements cut, %lld interface entities "
           "(reference %d)\n",
           (long long)r->ncut, (long long)r->nelem_cut, (long long)r->niface,
           (int)o->ref_iface);
    printf("    volume inside %.10g, outside %.10g\n", r->vol_in, r->vol_out);
    if (r->ndropped)
      printf("    %lld entities of reference %d inside the domain (an earlier "
             "interface) removed before the cut\n",
             (long long)r->ndropped, (int)o->ref_iface);
    fflush(stdout);
  }
  if (!r->niface)
    fprintf(stderr, "padapt: warning: adapt: the level set %s does not cross "
                    "the mesh (values in [%g, %g], iso-value %g): no interface "
                    "(reference %d) in the output\n",
            a->ls, r->phi_min, r->phi_max, o->value, (int)o->ref_iface);
  if (r->nbdry_iface)
    fprintf(stderr, "padapt: warning: adapt: %lld boundary entities of %s "
                    "already have the interface's reference %d: the output "
                    "does not tell them from the interface (choose another "
                    "with -isoref)\n",
            (long long)r->nbdry_iface, a->in, (int)o->ref_iface);
}

char *pa_cli_ls_json(const pa_levelset_report *r) {
  pa_cli_sbuf b = {NULL, 0, 0, 0};
  pa_cli_sb_printf(&b,
                   "\"levelset\": {\"phi_min\": %.17g, \"phi_max\": %.17g, "
                   "\"snapped\": %lld, \"removed_in\": %lld, "
                   "\"removed_out\": %lld, \"edges_cut\": %lld, "
                   "\"elements_cut\": %lld, \"interface\": %lld, "
                   "\"dropped\": %lld, \"boundary_with_interface_ref\": %lld, "
                   "\"volume_in\": %.17g, \"volume_out\": %.17g}, ",
                   r->phi_min, r->phi_max, (long long)r->nsnapped,
                   (long long)r->nremoved_in, (long long)r->nremoved_out,
                   (long long)r->ncut, (long long)r->nelem_cut,
                   (long long)r->niface, (long long)r->ndropped,
                   (long long)r->nbdry_iface, r->vol_in, r->vol_out);
  if (b.fail) {
    free(b.p);
    return NULL;
  }
  return b.p;
}

int pa_cli_ls_cut(const pa_cli *cli, const pa_cli_adapt_args *a,
                  pa_mesh *mesh, pa_levelset_report *rep) {
  pa_levelset_opts o;
  pa_ls_material *mat = NULL;
  double *phi = NULL;
  int rc = pa_cli_ls_opts(cli, a, pa_mesh_dim(mesh), &o, &mat);
  if (!rc) rc = pa_cli_ls_read(cli, a, mesh, &phi);
  if (!rc && pa_mesh_levelset_cut(mesh, phi, &o, rep) != PA_SUCCESS)
    rc = pa_cli_error(cli, "adapt: -ls %s: %s", a->ls, pa_last_error());
  if (!rc) pa_cli_ls_report(a, &o, rep);
  free(phi);
  free(mat);
  return rc;
}
