/* tools/cli/pending.c — subcommands still being written on other branches.
 * Removed as each lands. */
#include <stdio.h>

#include "cli.h"

static int pending(const char *name) {
    fprintf(stderr, "volux %s: not available in this build yet\n", name);
    return CLI_FAIL;
}
int cli_info(int argc, char **argv) { (void)argc; (void)argv; return pending("info"); }
int cli_compare(int argc, char **argv) { (void)argc; (void)argv; return pending("compare"); }
