/* cmd_adapt.c -- `padapt adapt` (being written). */
#include "cli.h"
int pa_cli_adapt(const pa_cli *cli, int argc, char **argv) { (void)argc; (void)argv; return pa_cli_error(cli, "adapt: not yet implemented"); }
