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

/* Sequential phases of parallel items in one parallel region (sweeps:
 * phase p may read what phase p − 1 wrote). For p = 0 … n_phases − 1:
 * fn(user, p, i, thread) for i in [0, n_p) on all threads, n_p =
 * begin(user, p). The threads meet at one barrier per phase that spins
 * briefly, then sleeps, instead of a fork/join per phase: with
 * OMP_WAIT_POLICY=passive a parallel_for costs ≈ 50 µs to wake the
 * sleeping workers, which for a radiance-cache sweep of 20–70 phases was a
 * fifth of its time. begin(user, p + 1) runs on one thread once that thread
 * has no item of phase p left to take, while the others may still run
 * theirs: it must not change what items of phase p read (keep two copies
 * of per-phase state, by p & 1), and must not read what they write. This
 * overlaps the serial part with the tail of the previous phase and halves
 * the barriers (a sweep on a shared, oversubscribed machine waits at each
 * one for a descheduled thread). Same determinism rule as
 * volux_parallel_for. */
typedef int64_t (*volux_phase_fn)(void *user, int phase);
typedef void (*volux_phase_item_fn)(void *user, int phase, int64_t index, int thread);
void volux_parallel_phases(int threads, int n_phases, volux_phase_fn begin, volux_phase_item_fn fn, void *user);
int volux_parallel_max_threads(void);

#endif
