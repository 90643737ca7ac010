/*
 * io.c -- format dispatch by file extension and atomic output files.
 */
#include "io/io.h"

#include <ctype.h>
#include <errno.h>
#include <stdio.h>
#include <unistd.h>

const char *pa__path_ext(const char *path, char *buf, size_t len) {
  const char *dot = strrchr(path, '.');
  const char *slash = strrchr(path, '/');
  buf[0] = '\0';
  if (!dot || (slash && dot < slash)) return buf;
  size_t i = 0;
  for (; dot[i] && i + 1 < len; i++) buf[i] = (char)tolower((unsigned char)dot[i]);
  buf[i] = '\0';
  return buf;
}

pa_status pa__out_open(pa_outfile *out, const char *path) {
  pa_status st = PA_SUCCESS;
  memset(out, 0, sizeof *out);
  size_t n = strlen(path);
  PA_ALLOC(out->path, n + 1);
  memcpy(out->path, path, n + 1);
  PA_ALLOC(out->tmppath, n + 32);
  snprintf(out->tmppath, n + 32, "%s.tmp.%ld", path, (long)getpid());
  out->fp = fopen(out->tmppath, "wb");
  PA_CHECK(out->fp, PA_ERR_IO, "%s: cannot open for writing: %s", path,
           strerror(errno));
cleanup:
  if (st) pa__out_abort(out);
  return st;
}

pa_status pa__out_commit(pa_outfile *out) {
  pa_status st = PA_SUCCESS;
  PA_CHECK(out->fp, PA_ERR_ARG, "output file is not open");
  int bad = ferror(out->fp);
  bad |= fclose(out->fp) != 0;
  out->fp = NULL;
  PA_CHECK(!bad, PA_ERR_IO, "%s: write error: %s", out->path, strerror(errno));
  PA_CHECK(rename(out->tmppath, out->path) == 0, PA_ERR_IO,
           "%s: cannot rename temporary file: %s", out->path, strerror(errno));
  pa__free(out->tmppath);
  out->tmppath = NULL;
cleanup:
  pa__out_abort(out);
  return st;
}

void pa__out_abort(pa_outfile *out) {
  if (out->fp) fclose(out->fp);
  out->fp = NULL;
  if (out->tmppath) remove(out->tmppath);
  pa__free(out->tmppath);
  pa__free(out->path);
  out->tmppath = out->path = NULL;
}

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
  pa_write_opts def = {0, 0};
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
    PA_CALL(pa__vtu_write(mesh, path));
  else
    PA_FAIL(PA_ERR_UNSUPPORTED,
            "%s: unknown mesh file extension '%s' (expected .mesh, .meshb, "
            ".msh or .vtu)", path, ext);
cleanup:
  return st;
}
