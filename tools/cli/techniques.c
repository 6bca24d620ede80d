/* tools/cli/techniques.c — `volux techniques`: names, summaries, parameters. */
#include <stdio.h>
#include <string.h>

#include "cli.h"

static const char *kind_name(volux_param_kind k) {
    switch (k) {
    case VOLUX_PARAM_NUMBER: return "number";
    case VOLUX_PARAM_INT: return "integer";
    case VOLUX_PARAM_BOOL: return "bool";
    case VOLUX_PARAM_STRING: return "string";
    }
    return "?";
}

int cli_techniques(int argc, char **argv) {
    int brief = argc > 1 && !strcmp(argv[1], "--brief");
    for (int i = 0; i < volux_technique_count(); i++) {
        const volux_technique_info *c = volux_technique_info_at(i);
        printf("%-12s %s%s\n", c->name, c->summary, c->progressive ? " [progressive]" : "");
        if (brief) continue;
        for (const volux_param_info *p = c->params; p && p->name; p++) {
            if (p->kind == VOLUX_PARAM_STRING)
                printf("    %-20s %-7s default \"%s\"\n", p->name, kind_name(p->kind), p->def_string ? p->def_string : "");
            else if (p->kind == VOLUX_PARAM_BOOL)
                printf("    %-20s %-7s default %s\n", p->name, kind_name(p->kind), p->def != 0 ? "true" : "false");
            else
                printf("    %-20s %-7s default %g, range [%g, %g]\n", p->name, kind_name(p->kind), p->def, p->min,
                       p->max);
            printf("        %s\n", p->doc);
        }
    }
    printf("\nSet parameters in the scene: \"techniques\": {\"<name>\": {\"<param>\": value}}\n"
           "or on the command line: --set techniques.<name>.<param>=value\n");
    return CLI_OK;
}
