/*
 * core/deadline.h — a render's time budget (render.time_ms) as the inner
 * loops see it: a point on CLOCK_MONOTONIC and a flag set once it has
 * passed. Shared by every tile of a wave (render/frame.c) and read by the
 * trackers of sample/tracking.h, which is why it lives in core.
 */
#ifndef VOLUX_CORE_DEADLINE_H
#define VOLUX_CORE_DEADLINE_H

#include <time.h>

typedef struct volux_deadline {
    double at_ms; /* CLOCK_MONOTONIC, milliseconds                  */
    int expired;  /* set (atomically) once at_ms has passed          */
} volux_deadline;

/* 1 once the budget is spent (d NULL: no budget, never). Reads the clock
 * until it has expired, so callers ask every few thousand samples. */
static inline int volux_deadline_expired(volux_deadline *d) {
    if (!d) return 0;
    if (__atomic_load_n(&d->expired, __ATOMIC_RELAXED)) return 1;
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    if ((double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6 < d->at_ms) return 0;
    __atomic_store_n(&d->expired, 1, __ATOMIC_RELAXED);
    return 1;
}

#endif
