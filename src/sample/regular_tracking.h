/*
 * sample/regular_tracking.h — the guard that keeps free-path trackers (delta
 * tracking, ratio tracking) finite on media of any density.
 *
 * Delta and ratio tracking (Woodcock et al. 1965; Novák et al. 2014) take
 * exponential steps of mean 1/σ̄ through an interval with majorant σ̄, so
 * their work is σ̄·L tentative collisions for an interval of length L. Two
 * things break that in float arithmetic:
 *
 *   - an extreme majorant (a TF extinction of 1e30: σ̄·L ≈ 1e31 steps), and
 *   - a step below half an ulp of t: `t += step` leaves t where it was, and
 *     where σt(t) = 0 the loop never ends (the issue-16 hang: once 1/σ̄ is
 *     under ulp(t)/2, which at t ≈ 100 is σ̄ ≳ 1.3e5).
 *
 * When either happens (volux_track_needs_regular before an interval, or a
 * step that does not move t while the mean step is below an ulp of t:
 * volux_track_stalled), the rest of the interval is integrated by
 * *regular tracking*: fixed sub-steps of at most 1/16 of the smallest voxel
 * spacing (and at least VOLUX_TRACK_MIN_ULPS ulps of t, so every step
 * advances), σt taken at each sub-step's midpoint, optical depth in closed
 * form. That is exact for σt constant over a sub-step and otherwise a
 * midpoint-rule quadrature of a function that is trilinear × piecewise
 * linear at 1/16 voxel: it is only ever used where delta tracking would
 * need more than VOLUX_TRACK_MAX_EVENTS steps in one macrocell interval,
 * i.e. media opaque far below the voxel scale. The work is at most
 * VOLUX_TRACK_MAX_SUBSTEPS evaluations per interval.
 *
 * DOES NOT: sample (callers pass their own random numbers) or know the
 * medium (callers pass σt evaluated at the midpoints).
 */
#ifndef VOLUX_REGULAR_TRACKING_H
#define VOLUX_REGULAR_TRACKING_H

#include <math.h>

/* Above this many expected tentative collisions in one interval (σ̄·L),
 * a tracker switches to regular tracking for the interval. 2^16: no medium
 * a transfer function written in opacities can reach (σt ≤ 9.2 per unit
 * distance) comes near it; an extinction TF needs σt > 8192 per voxel. */
#define VOLUX_TRACK_MAX_EVENTS 65536.0f
/* Regular tracking: sub-steps per smallest voxel spacing, the cap of
 * sub-steps per interval (a macrocell diagonal is ≤ 14 voxels: 224), and
 * the least sub-step in ulps of t. */
#define VOLUX_TRACK_SUBSTEPS_PER_VOXEL 16.0f
#define VOLUX_TRACK_MAX_SUBSTEPS 256
#define VOLUX_TRACK_MIN_ULPS 4.0f

/* 1 if delta/ratio tracking over [t0, t1] with majorant sigma_max would take
 * more than VOLUX_TRACK_MAX_EVENTS steps on average. */
static inline int volux_track_needs_regular(float sigma_max, float t0, float t1) {
    return sigma_max * (t1 - t0) > VOLUX_TRACK_MAX_EVENTS;
}

/* 1 if a tentative step that did not move t (tn == t) means the tracker is
 * stalled: the mean step 1/σ̄ is below one ulp of t, so most steps cannot
 * move it. A step that did not move t with a larger mean step is only a
 * short draw (u near 0): the next one moves t, and the tracker goes on
 * exactly as before (no random number changes for ordinary media). */
static inline int volux_track_stalled(float t, float inv_sigma_max) {
    float at = fabsf(t);
    return !(inv_sigma_max >= nextafterf(at, INFINITY) - at);
}

/* Regular tracking over [t0, t1]: the sub-steps. */
typedef struct volux_track_steps {
    float t0, t1, h; /* h: sub-step length                     */
    int n, i;        /* sub-steps, next one                    */
} volux_track_steps;

/* Sub-steps of at most min_spacing/16 and at least a few ulps of t1, at
 * most VOLUX_TRACK_MAX_SUBSTEPS (a longer interval gets longer steps). */
static inline void volux_track_steps_init(volux_track_steps *s, float t0, float t1, float min_spacing) {
    float len = t1 - t0;
    float ulp = nextafterf(fabsf(t1), INFINITY) - fabsf(t1);
    float h = min_spacing / VOLUX_TRACK_SUBSTEPS_PER_VOXEL;
    if (!(h >= VOLUX_TRACK_MIN_ULPS * ulp)) h = VOLUX_TRACK_MIN_ULPS * ulp;
    float n = len > 0.0f ? ceilf(len / h) : 0.0f;
    if (!(n <= (float)VOLUX_TRACK_MAX_SUBSTEPS)) n = (float)VOLUX_TRACK_MAX_SUBSTEPS;
    s->t0 = t0;
    s->t1 = t1;
    s->n = (int)n;
    s->h = n > 0.0f ? len / n : 0.0f;
    s->i = 0;
}

/* Next sub-step [a, b] and its midpoint m; 0 when done. Consecutive
 * sub-steps share their ends; the last ends exactly at t1. */
static inline int volux_track_steps_next(volux_track_steps *s, float *a, float *b, float *m) {
    if (s->i >= s->n) return 0;
    *a = s->i == 0 ? s->t0 : s->t0 + (float)s->i * s->h;
    s->i++;
    *b = s->i == s->n ? s->t1 : s->t0 + (float)s->i * s->h;
    if (*b > s->t1) *b = s->t1;
    if (*a > *b) *a = *b;
    *m = *a + 0.5f * (*b - *a);
    return 1;
}

/* Where, inside a sub-step [a, b] of constant σt, the optical depth
 * `remaining` (≤ σt·(b − a)) is reached. */
static inline float volux_track_hit(float a, float b, float sigma, float remaining) {
    float t = a + remaining / sigma;
    return t < a ? a : (t > b ? b : t);
}

#endif
