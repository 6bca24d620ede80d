/*
 * core/name_guess.c — the nearest valid name to a typo (name_guess.h).
 */
#include <string.h>

#include "name_guess.h"
#include "volux/base.h"

/* Levenshtein distance (capped at 99 for long names), for "did you mean". */
static int edit_distance(const char *a, const char *b) {
    size_t n = strlen(a), m = strlen(b);
    if (n > 63 || m > 63) return 99;
    int row[64];
    for (size_t j = 0; j <= m; j++) row[j] = (int)j;
    for (size_t i = 1; i <= n; i++) {
        int diag = row[0];
        row[0] = (int)i;
        for (size_t j = 1; j <= m; j++) {
            int above = row[j], best = diag + (a[i - 1] != b[j - 1]);
            if (above + 1 < best) best = above + 1;
            if (row[j - 1] + 1 < best) best = row[j - 1] + 1;
            row[j] = best;
            diag = above;
        }
    }
    return row[m];
}

void volux_name_guess_try(volux_name_guess *g, const char *name, const char *candidate) {
    size_t len = strlen(name);
    int d = !strcmp(candidate, name)                   ? 0
            : len >= 2 && !strncmp(candidate, name, len) ? 1
                                                         : edit_distance(name, candidate);
    if (!g->best || d < g->distance) g->best = candidate, g->distance = d;
}

const char *volux_name_guess_best(const volux_name_guess *g, const char *name) {
    int len = (int)strlen(name);
    return len > 0 && g->best && g->distance <= (len < 6 ? 2 : len / 3 + 1) ? g->best : NULL;
}


const char *volux_name_closest(const char *name, const char *const *candidates) {
    volux_name_guess g = {NULL, 0};
    for (const char *const *c = candidates; *c; c++) volux_name_guess_try(&g, name, *c);
    return volux_name_guess_best(&g, name);
}
