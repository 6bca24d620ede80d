/* tools/cli/techniques.c — `volux techniques`: names, summaries, parameters. */
#include <stdio.h>
#include <string.h>

#include "cli.h"
#include "scene_args.h"

static const char *kind_name(volux_param_kind k) {
    switch (k) {
    case VOLUX_PARAM_NUMBER: return "number";
    case VOLUX_PARAM_INT: return "integer";
    case VOLUX_PARAM_BOOL: return "bool";
    case VOLUX_PARAM_STRING: return "string";
    case VOLUX_PARAM_FILE: return "file";
    }
    return "?";
}

static void print_technique(const volux_technique_info *c, int brief) {
    printf("%-12s %s%s\n", c->name, c->summary, c->progressive ? " [progressive]" : "");
    if (brief) return;
    for (const volux_param_info *p = c->params; p && p->name; p++) {
        if (p->kind == VOLUX_PARAM_STRING || p->kind == VOLUX_PARAM_FILE)
            printf("    %-20s %-7s default \"%s\"\n", p->name, kind_name(p->kind), p->def_string ? p->def_string : "");
        else if (p->kind == VOLUX_PARAM_BOOL)
            printf("    %-20s %-7s default %s\n", p->name, kind_name(p->kind), p->def != 0 ? "true" : "false");
        else
            printf("    %-20s %-7s default %g, range [%g, %g]\n", p->name, kind_name(p->kind), p->def, p->min, p->max);
        printf("        %s\n", p->doc);
    }
}

/* volux techniques [--brief] [NAME...]: all techniques, or the named ones. */
int cli_techniques(int argc, char **argv) {
    int brief = 0, n_names = 0;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--brief")) brief = 1;
        else if (!strcmp(argv[i], "-h") || !strcmp(argv[i], "--help")) {
            printf("usage: volux techniques [--brief] [NAME...]\n"
                   "lists the techniques (or the named ones) and their parameters\n");
            return CLI_OK;
        } else if (argv[i][0] == '-') {
            cli_eprintf("volux techniques: unknown option '%s' (usage: volux techniques [--brief] [NAME...])\n",
                    argv[i]);
            return CLI_USAGE;
        } else {
            /* Every name is checked before anything is printed. */
            if (!volux_technique_info_find(argv[i])) {
                char names[256];
                cli_technique_names(names, sizeof names);
                const char *guess = volux_technique_closest(argv[i]);
                cli_eprintf("volux techniques: unknown technique '%s'%s%s%s (techniques: %s)\n", argv[i],
                        guess ? "; did you mean '" : "", guess ? guess : "", guess ? "'?" : "", names);
                return CLI_USAGE;
            }
            n_names++;
        }
    }
    if (n_names) {
        for (int i = 1; i < argc; i++)
            if (argv[i][0] != '-') print_technique(volux_technique_info_find(argv[i]), brief);
    } else {
        for (int i = 0; i < volux_technique_count(); i++) print_technique(volux_technique_info_at(i), brief);
    }
    printf("\nSet parameters in the scene: \"techniques\": {\"<name>\": {\"<param>\": value}}\n"
           "or on the command line: --set techniques.<name>.<param>=value\n");
    return CLI_OK;
}
