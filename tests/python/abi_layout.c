/*
 * abi_layout.c -- prints the size of every public structure the Python
 * package mirrors with ctypes (python/padapt/_lib.py, mesh.py), and the
 * offset of every field of the option structures Python fills in, as
 * "NAME SIZE" and "NAME.FIELD OFFSET" lines; tests/python/test_abi.py
 * compares them with ctypes' layout, so a field added to padapt.h and not
 * to the package fails the tests instead of corrupting memory.
 */
#include <padapt.h>
#include <stddef.h>
#include <stdio.h>

#define SIZE(T) printf("%s %zu\n", #T, sizeof(T))
#define OFF(T, f) printf("%s.%s %zu\n", #T, #f, offsetof(T, f))

int main(void) {
  SIZE(pa_stats);
  SIZE(pa_fidelity);
  SIZE(pa_write_opts);
  SIZE(pa_remesh_opts);
  SIZE(pa_transfer_report);
  SIZE(pa_remesh_report);
  SIZE(pa_metric_hessian_opts);
  SIZE(pa_metric_levelset_opts);
  SIZE(pa_dmesh_iter);
  SIZE(pa_adapt_iter);
  SIZE(pa_adapt_opts);
  SIZE(pa_adapt_report);
  SIZE(pa_ls_material);
  SIZE(pa_levelset_opts);
  SIZE(pa_levelset_report);
  OFF(pa_levelset_opts, mat);
  OFF(pa_levelset_opts, snap);
  OFF(pa_levelset_report, vol_out);
  OFF(pa_write_opts, diagnostics);
  OFF(pa_remesh_opts, hausd);
  OFF(pa_remesh_opts, no_stats);
  OFF(pa_remesh_opts, progress);
  OFF(pa_remesh_opts, nlocal);
  OFF(pa_adapt_opts, remesher);
  OFF(pa_adapt_opts, check_pieces);
  OFF(pa_adapt_opts, progress);
  OFF(pa_adapt_opts, checkpoint_dir);
  return 0;
}
