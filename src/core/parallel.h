/*
 * core/parallel.h — the one place that knows about OpenMP.
 *
 * volux_parallel_for runs fn(user, i, thread) for i in [0, n) on `threads`
 * threads with dynamic scheduling. Work items must be independent; results
 * must not depend on which thread ran an item (determinism rule).
 */
#ifndef VOLUX_PARALLEL_H
#define VOLUX_PARALLEL_H

#include <stdint.h>

typedef void (*volux_parallel_fn)(void *user, int64_t index, int thread);

void volux_parallel_for(int threads, int64_t n, volux_parallel_fn fn, void *user);
int volux_parallel_max_threads(void);

#endif
