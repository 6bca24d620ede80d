/*
 * tests/unit/test_parallel.c — the phase loops of core/parallel.c: every
 * item of every phase runs once, after every item of the phase before
 * (the sweeps' dependency), with the item count its begin returned; the
 * overlapped loop's begin(p + 1) may run during phase p but must find
 * phase p − 1 finished and leave phase p's state (kept by parity) alone.
 */
#include <stdatomic.h>
#include <string.h>

#include "core/parallel.h"
#include "test_util.h"

enum { PHASES = 40, MAX_ITEMS = 300 };

typedef struct phases {
    atomic_int done[PHASES];   /* items of phase p finished            */
    atomic_int runs[PHASES][MAX_ITEMS];
    int n[2];                  /* items of the phase, by parity (begin) */
    int phase_of[2];           /* which phase begin set up, by parity   */
    atomic_int bad;
} phases;

static int64_t n_of(int p) { return (p * 37) % MAX_ITEMS; } /* includes empty phases */

static int64_t begin(void *user, int p) {
    phases *ph = user;
    /* the phase before last is over (the overlapped loop may still run
     * items of p − 1) */
    if (p >= 2 && atomic_load(&ph->done[p - 2]) != n_of(p - 2)) atomic_store(&ph->bad, 1);
    ph->n[p & 1] = (int)n_of(p);
    ph->phase_of[p & 1] = p;
    return n_of(p);
}

static void item(phases *ph, int p, int64_t i) {
    if (p >= 1 && atomic_load(&ph->done[p - 1]) != n_of(p - 1)) atomic_store(&ph->bad, 1);
    if (ph->phase_of[p & 1] != p || i >= ph->n[p & 1]) atomic_store(&ph->bad, 1);
    atomic_fetch_add(&ph->runs[p][i], 1);
    atomic_fetch_add(&ph->done[p], 1);
}

static void item_overlapped(void *user, int p, int64_t i, int thread) {
    (void)thread;
    item(user, p, i);
}

/* volux_parallel_phases: its items learn the phase from begin's state */
static int plain_phase;
static int64_t plain_begin(void *user, int p) {
    plain_phase = p;
    return begin(user, p);
}
static void plain_item(void *user, int64_t i, int thread) {
    (void)thread;
    item(user, plain_phase, i);
}

static void check(phases *ph) {
    assert_int_equal(atomic_load(&ph->bad), 0);
    for (int p = 0; p < PHASES; p++)
        for (int i = 0; i < MAX_ITEMS; i++) assert_int_equal(atomic_load(&ph->runs[p][i]), i < n_of(p) ? 1 : 0);
}

static void test_phases_run_every_item_once_in_order(void **state) {
    (void)state;
    static phases ph;
    for (int threads = 1; threads <= 3; threads++) {
        memset(&ph, 0, sizeof ph);
        volux_parallel_phases_overlapped(threads, PHASES, begin, item_overlapped, &ph);
        check(&ph);
        memset(&ph, 0, sizeof ph);
        volux_parallel_phases(threads, PHASES, plain_begin, plain_item, &ph);
        check(&ph);
    }
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_phases_run_every_item_once_in_order),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
