/* cmd_partition.c -- `padapt partition` (being written). */
#include "cli.h"
int pa_cli_partition(const pa_cli *cli, int argc, char **argv) { (void)argc; (void)argv; return pa_cli_error(cli, "partition: not yet implemented"); }
