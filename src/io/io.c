/*
 * io.c -- format dispatch by file extension (the output files themselves:
 * output.c). Only this file of src/io/ calls the others' readers and
 * writers; none calls it.
 */
#include "io/io.h"

#include <stdio.h>

pa_status pa_mesh_read(const char *path, pa_mesh **mesh) {
  pa_status st = PA_SUCCESS;
  char ext[16];
  PA_CHECK(path && mesh, PA_ERR_ARG, "pa_mesh_read: NULL argument");
  *mesh = NULL;
  pa__path_ext(path, ext, sizeof ext);
  if (!strcmp(ext, ".mesh") || !strcmp(ext, ".meshb"))
    PA_CALL(pa__medit_read(path, mesh));
  else if (!strcmp(ext, ".msh"))
    PA_CALL(pa__gmsh_read(path, mesh));
  else
    PA_FAIL(PA_ERR_UNSUPPORTED,
            "%s: unknown mesh file extension '%s' (expected .mesh, .meshb or "
            ".msh)", path, ext);
cleanup:
  return st;
}

pa_status pa_mesh_write(pa_mesh *mesh, const char *path,
                        const pa_write_opts *opts) {
  pa_status st = PA_SUCCESS;
  char ext[16];
  pa_write_opts def = {0, 0, 0};
  PA_CHECK(path && mesh, PA_ERR_ARG, "pa_mesh_write: NULL argument");
  if (!opts) opts = &def;
  pa__path_ext(path, ext, sizeof ext);
  if (!strcmp(ext, ".mesh"))
    PA_CALL(pa__medit_write(mesh, path, 0, 0));
  else if (!strcmp(ext, ".meshb"))
    PA_CALL(pa__medit_write(mesh, path, 1, opts->version));
  else if (!strcmp(ext, ".msh"))
    PA_CALL(pa__gmsh_write(mesh, path, opts->binary));
  else if (!strcmp(ext, ".vtu"))
    PA_CALL(pa__vtu_write(mesh, path, opts->diagnostics, NULL));
  else
    PA_FAIL(PA_ERR_UNSUPPORTED,
            "%s: unknown mesh file extension '%s' (expected .mesh, .meshb, "
            ".msh or .vtu)", path, ext);
cleanup:
  return st;
}
