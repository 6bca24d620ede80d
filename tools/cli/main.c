/* tools/cli/main.c — `volux` entry point: dispatches to subcommands. */
#include <stdio.h>
#include <stdlib.h>
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

/* POSIX utility syntax guideline 10: "--" ends the options; what follows
 * is an operand even if it starts with '-'. Every subcommand gets this at
 * once: the first "--" is dropped and each later argument that starts
 * with '-' is passed as "./ARG" (operands are file paths, and "./-x" is
 * the same file as "-x" without looking like an option). Returns a
 * NULL-terminated copy of argv[0..argc). */
static int borrowed(const char *arg, char **argv, int argc) {
    for (int i = 0; i < argc; i++)
        if (arg == argv[i]) return 1;
    return 0;
}

/* Frees what end_of_options allocated (the "./ARG" copies). */
static void free_args(char **args, char **argv, int argc) {
    for (int k = 0; args[k]; k++)
        if (!borrowed(args[k], argv, argc)) free(args[k]);
    free(args);
}

static char **end_of_options(int argc, char **argv) {
    char **out = calloc((size_t)argc + 1, sizeof *out);
    if (!out) return NULL;
    int n = 0, operands = 0;
    for (int i = 0; i < argc; i++) {
        if (!operands && i > 0 && !strcmp(argv[i], "--")) {
            operands = 1;
            continue;
        }
        if (!operands || argv[i][0] != '-') {
            out[n++] = argv[i];
            continue;
        }
        size_t len = strlen(argv[i]);
        char *q = malloc(len + 3);
        if (!q) {
            free_args(out, argv, argc);
            return NULL;
        }
        memcpy(q, "./", 2);
        memcpy(q + 2, argv[i], len + 1);
        out[n++] = q;
    }
    return out;
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
        if (!strcmp(argv[1], commands[i].name)) {
            char **args = end_of_options(argc - 1, argv + 1);
            if (!args) {
                cli_eprintf("volux: out of memory\n");
                return CLI_FAIL;
            }
            int n = 0;
            while (args[n]) n++;
            int rc = commands[i].run(n, args);
            free_args(args, argv + 1, argc - 1);
            return rc;
        }
    cli_eprintf("volux: unknown command '%s'\n", argv[1]);
    usage(stderr);
    return CLI_USAGE;
}
