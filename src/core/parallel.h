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
 * n = begin(user, p) runs on one thread once every item of phase p − 1 has
 * finished, then fn(user, i, thread) for i in [0, n) on all threads. The
 * threads meet at a barrier that spins briefly, then sleeps, instead
 * of a fork/join per phase: with OMP_WAIT_POLICY=passive a parallel_for
 * costs ≈ 50 µs to wake the sleeping workers, which for a radiance-cache
 * sweep of 20–70 phases was a fifth of its time. Same determinism rule as
 * volux_parallel_for. */
typedef int64_t (*volux_phase_fn)(void *user, int phase);
void volux_parallel_phases(int threads, int n_phases, volux_phase_fn begin, volux_parallel_fn fn, void *user);

/* The same with one barrier per phase instead of two: begin(user, p + 1)
 * runs on one thread once that thread has no item of phase p left to take,
 * while the others may still run theirs, so begin must neither change what
 * items of phase p read (keep two copies of per-phase state, by p & 1) nor
 * read what they write; fn gets the phase. The serial part overlaps the
 * previous phase's last items, and a sweep on a shared, oversubscribed
 * machine waits half as often for a descheduled thread. */
typedef void (*volux_phase_item_fn)(void *user, int phase, int64_t index, int thread);
void volux_parallel_phases_overlapped(int threads, int n_phases, volux_phase_fn begin, volux_phase_item_fn fn,
                                      void *user);
int volux_parallel_max_threads(void);
/* `want` clamped to a team size that is known to start (tried once with
 * pthreads, cached): OpenMP ends the process when it cannot create one. */
int volux_parallel_usable_threads(int want);

#endif
