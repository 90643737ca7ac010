/* padapt.c -- command-line entry point (being written). */
#include "cli.h"
#include <stdarg.h>
int pa_cli_generate(const pa_cli *c, int a, char **v) { (void)a; (void)v; return pa_cli_error(c, "not yet"); }
int pa_cli_metric(const pa_cli *c, int a, char **v) { (void)a; (void)v; return pa_cli_error(c, "not yet"); }
int pa_cli_stats(const pa_cli *c, int a, char **v) { (void)a; (void)v; return pa_cli_error(c, "not yet"); }
int pa_cli_convert(const pa_cli *c, int a, char **v) { (void)a; (void)v; return pa_cli_error(c, "not yet"); }
int pa_cli_error(const pa_cli *cli, const char *fmt, ...) { (void)cli; va_list ap; va_start(ap, fmt); fprintf(stderr, "padapt: "); vfprintf(stderr, fmt, ap); fprintf(stderr, "\n"); va_end(ap); return 1; }
int pa_cli_fail(const pa_cli *cli, pa_status st) { return st ? pa_cli_error(cli, "%s", pa_last_error()) : 0; }
pa_status pa_cli_read_mesh(const pa_cli *cli, const char *path, pa_mesh **mesh) { (void)cli; return pa_mesh_read(path, mesh); }
int main(void) { return 0; }
