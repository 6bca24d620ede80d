/* tools/cli/main.c — `volux` entry point: dispatches to subcommands. */
#include <stdio.h>
#include <string.h>

#include "cli.h"

static const cli_command commands[] = {
    {"render", "render a scene to PNG/PFM/EXR", cli_render},
    {"info", "print a volume's dims, type, spacing, range, histogram", cli_info},
    {"compare", "error metrics between two images", cli_compare},
    {"bench", "timings of a technique on a scene (one JSON object per line)", cli_bench},
    {"techniques", "list techniques and their parameters", cli_techniques},
    {"ambient-table", "build or inspect the ambient-scattering preintegration table", cli_ambient_table},
    {"serve", "interactive web viewer of a scene (HTTP on 127.0.0.1)", cli_serve},
    {"view", "a volume's quick look (or a scene) in the web viewer", cli_view},
};

static void usage(FILE *f) {
    fprintf(f, "usage: volux COMMAND [ARGS]\n\ncommands:\n");
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
        fprintf(f, "  %-12s %s\n", commands[i].name, commands[i].summary);
    fprintf(f, "\n`volux COMMAND --help` describes a command's options.\n");
}

int main(int argc, char **argv) {
    if (argc < 2) {
        usage(stderr);
        return CLI_USAGE;
    }
    if (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h") || !strcmp(argv[1], "help")) {
        usage(stdout);
        return 0;
    }
    if (!strcmp(argv[1], "--version")) {
        printf("volux %s\n", VOLUX_VERSION);
        return 0;
    }
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
        if (!strcmp(argv[1], commands[i].name)) return commands[i].run(argc - 1, argv + 1);
    fprintf(stderr, "volux: unknown command '%s'\n", argv[1]);
    usage(stderr);
    return CLI_USAGE;
}
