/* core/parallel.c — OpenMP behind one function (STYLE §8). */
#include "parallel.h"

#include <pthread.h>
#include <stdatomic.h>

#ifdef _OPENMP
#include <omp.h>
#endif

int volux_parallel_max_threads(void) {
#ifdef _OPENMP
    return omp_get_num_procs();
#else
    return 1;
#endif
}

/* libgomp ends the process with its own message (exit 1) when it cannot
 * create a thread, e.g. under a small `ulimit -v`. So before OpenMP is
 * asked for a team, that many threads are started once with the default
 * attributes (libgomp's, unless OMP_STACKSIZE says otherwise) and joined;
 * a team is never larger than what was shown to start. Images do not
 * depend on the thread count, so fewer threads only take longer. */
#define MAX_TEAM 1024
static atomic_int team_proven = 1; /* a team of this size starts        */
static atomic_int team_limit = MAX_TEAM; /* one of this size did not     */

static void *idle_thread(void *arg) { return arg; }

int volux_parallel_usable_threads(int want) {
    if (want > MAX_TEAM) want = MAX_TEAM;
    if (want <= atomic_load(&team_proven)) return want;
    static pthread_mutex_t lock = PTHREAD_MUTEX_INITIALIZER;
    pthread_mutex_lock(&lock);
    int limit = atomic_load(&team_limit), proven = atomic_load(&team_proven);
    if (want > limit) want = limit;
    if (want > proven) {
        pthread_t t[MAX_TEAM];
        int started = 0;
        while (started < want - 1 && pthread_create(&t[started], NULL, idle_thread, NULL) == 0) started++;
        for (int i = 0; i < started; i++) pthread_join(t[i], NULL);
        int ok = started + 1;
        if (ok < want) {
            atomic_store(&team_limit, ok);
            want = ok;
        }
        if (ok > proven) atomic_store(&team_proven, ok);
    }
    pthread_mutex_unlock(&lock);
    return want;
}

void volux_parallel_for(int threads, int64_t n, volux_parallel_fn fn, void *user) {
    if (threads <= 0) threads = volux_parallel_max_threads();
    threads = volux_parallel_usable_threads(threads);
    if (threads == 1 || n <= 1) {
        for (int64_t i = 0; i < n; i++) fn(user, i, 0);
        return;
    }
#ifdef _OPENMP
    /* Consecutive indices are neighbouring tiles: handing them out in runs
     * keeps each thread's recent tiles adjacent, so the volume bricks they
     * share stay in its L2 (ea, 512², 2 threads: −5…10 % wall and CPU
     * against runs of 1). Runs stay short enough (≤ n / 32 per thread) for
     * dynamic balancing at the end of a frame. */
    int64_t run = n / ((int64_t)threads * 32);
    int chunk = run < 1 ? 1 : run > 8 ? 8 : (int)run;
#pragma omp parallel for schedule(dynamic, chunk) num_threads(threads)
    for (int64_t i = 0; i < n; i++) fn(user, i, omp_get_thread_num());
#else
    for (int64_t i = 0; i < n; i++) fn(user, i, 0);
#endif
}

/* Sense-reversing barrier for the threads of one region. Waiters spin for
 * a short, bounded time (a phase's stragglers finish within microseconds
 * when every thread has a core), then sleep on a condition variable, so an
 * oversubscribed machine is not slowed by spinning or yielding threads
 * (the reason for OMP_WAIT_POLICY=passive). */
typedef struct spin_barrier {
    atomic_int count, sense;
    int n;
    pthread_mutex_t lock;
    pthread_cond_t cond;
} spin_barrier;

static void spin_pause(void) {
#if defined(__x86_64__) || defined(__i386__)
    __builtin_ia32_pause();
#endif
}

static void barrier_wait(spin_barrier *b, int *local_sense) {
    int s = !*local_sense;
    *local_sense = s;
    if (atomic_fetch_add(&b->count, 1) == b->n - 1) {
        atomic_store(&b->count, 0);
        pthread_mutex_lock(&b->lock);
        atomic_store(&b->sense, s);
        pthread_cond_broadcast(&b->cond);
        pthread_mutex_unlock(&b->lock);
        return;
    }
    for (int i = 0; i < 500; i++) { /* ≈ 5–20 µs, by CPU */
        if (atomic_load(&b->sense) == s) return;
        spin_pause();
    }
    pthread_mutex_lock(&b->lock);
    while (atomic_load(&b->sense) != s) pthread_cond_wait(&b->cond, &b->lock);
    pthread_mutex_unlock(&b->lock);
}

/* Runs of items per take, as in volux_parallel_for. */
static int phase_chunk(int64_t n_items, int threads) {
    int64_t run = n_items / ((int64_t)threads * 32);
    return run < 1 ? 1 : run > 8 ? 8 : (int)run;
}

/* Both phase loops. Per-phase state by parity: with `overlap`, phase p + 1
 * is set up during phase p (one barrier per phase), else between two
 * barriers once phase p has finished. */
static void run_phases(int threads, int n_phases, volux_phase_fn begin, volux_phase_item_fn fn, void *user,
                       int overlap) {
    if (threads <= 0) threads = volux_parallel_max_threads();
    threads = volux_parallel_usable_threads(threads);
#ifdef _OPENMP
    if (threads > 1 && n_phases > 0) {
        spin_barrier bar;
        atomic_init(&bar.count, 0);
        atomic_init(&bar.sense, 0);
        bar.n = 0;
        pthread_mutex_init(&bar.lock, NULL);
        pthread_cond_init(&bar.cond, NULL);
        atomic_llong next[2];
        int64_t n_items[2] = {overlap ? begin(user, 0) : 0, 0};
        int chunk[2] = {0, 0};
        atomic_init(&next[0], 0);
        atomic_init(&next[1], 0);
#pragma omp parallel num_threads(threads)
        {
            int tid = omp_get_thread_num(), sense = 0;
#pragma omp single
            {
                bar.n = omp_get_num_threads(); /* implicit (one-off) barrier: everyone sees n */
                chunk[0] = phase_chunk(n_items[0], bar.n);
            }
            for (int p = 0; p < n_phases; p++) {
                int cur = p & 1;
                if (!overlap) {
                    if (tid == 0) {
                        n_items[cur] = begin(user, p);
                        chunk[cur] = phase_chunk(n_items[cur], bar.n);
                        atomic_store(&next[cur], 0);
                    }
                    barrier_wait(&bar, &sense);
                }
                for (;;) {
                    int64_t i0 = atomic_fetch_add(&next[cur], (long long)chunk[cur]);
                    if (i0 >= n_items[cur]) break;
                    int64_t i1 = i0 + chunk[cur] < n_items[cur] ? i0 + chunk[cur] : n_items[cur];
                    for (int64_t i = i0; i < i1; i++) fn(user, p, i, tid);
                }
                if (overlap && tid == 0 && p + 1 < n_phases) {
                    /* phase p − 1 used these; everyone left it at the last barrier */
                    n_items[!cur] = begin(user, p + 1);
                    chunk[!cur] = phase_chunk(n_items[!cur], bar.n);
                    atomic_store(&next[!cur], 0);
                }
                barrier_wait(&bar, &sense);
            }
        }
        pthread_cond_destroy(&bar.cond);
        pthread_mutex_destroy(&bar.lock);
        return;
    }
#else
    (void)overlap;
#endif
    for (int p = 0; p < n_phases; p++) {
        int64_t n = begin(user, p);
        for (int64_t i = 0; i < n; i++) fn(user, p, i, 0);
    }
}

void volux_parallel_phases_overlapped(int threads, int n_phases, volux_phase_fn begin, volux_phase_item_fn fn,
                                      void *user) {
    run_phases(threads, n_phases, begin, fn, user, 1);
}

/* volux_parallel_phases through run_phases: its callbacks without the phase */
typedef struct plain_phases {
    volux_phase_fn begin;
    volux_parallel_fn fn;
    void *user;
} plain_phases;

static int64_t plain_begin(void *user, int phase) {
    const plain_phases *pp = user;
    return pp->begin(pp->user, phase);
}

static void plain_item(void *user, int phase, int64_t index, int thread) {
    (void)phase;
    const plain_phases *pp = user;
    pp->fn(pp->user, index, thread);
}

void volux_parallel_phases(int threads, int n_phases, volux_phase_fn begin, volux_parallel_fn fn, void *user) {
    plain_phases pp = {begin, fn, user};
    run_phases(threads, n_phases, plain_begin, plain_item, &pp, 0);
}
