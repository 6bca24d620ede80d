/* tools/cli/bench_edits.h — scene edits timed by `volux bench --edit`. */
#ifndef VOLUX_CLI_BENCH_EDITS_H
#define VOLUX_CLI_BENCH_EDITS_H

#include "cli.h"

typedef struct bench_edit {
    const char *name;
    const char *doc;
    volux_status (*apply)(volux_scene *s, int k); /* k-th repetition */
} bench_edit;

const bench_edit *bench_edit_find(const char *name);
const bench_edit *bench_edit_at(int i); /* NULL past the end */

#endif
