/*
 * sample/tracking.h — free-flight sampling and transmittance estimation in
 * the heterogeneous medium of sample/medium.h, shared by the Monte-Carlo
 * techniques (pathtrace, guided).
 *
 *   delta tracking (Woodcock et al. 1965; Novák et al. 2018, "Monte Carlo
 *   methods for volumetric light transport simulation", §5.1) against the
 *   local majorant σ̄ of each macrocell interval a ray crosses: tentative
 *   distances are exponential with rate σ̄ per interval; by memorylessness a
 *   tentative point past an interval's end restarts at the next interval
 *   with that interval's σ̄. A tentative collision is real with probability
 *   σt(x)/σ̄.
 *
 *   ratio tracking (Cramer 1978; Novák et al. 2014, Eq. 6) on the same
 *   majorants for transmittance, with Russian roulette once the running
 *   weight falls below VOLUX_RATIO_RR (unbiased).
 *
 * Both always advance or end, on media of any density: an interval that
 * needs more than 2^16 expected steps, or a step that cannot move t while
 * the mean step is below an ulp of t, is finished by regular tracking
 * (sample/regular_tracking.h).
 * Both honour the render's time budget: every VOLUX_TRACK_CLOCK_EVERY + 1
 * volume lookups the tracker asks its deadline (core/deadline.h), and once it has
 * expired `stopped` is set, the trackers return at once (no collision,
 * transmittance 0) and the caller ends its path. Neither changes a single
 * random number for ordinary media, so images stay bit-identical.
 *
 * A tracker carries one path's counter-based random stream (core/rng.h)
 * and counts volume lookups; it lives on the caller's stack. The medium
 * may use one global majorant instead of the grid (a benchmark baseline).
 * Everything is static inline: the trackers sit in the inner loops of the
 * estimators.
 */
#ifndef VOLUX_SAMPLE_TRACKING_H
#define VOLUX_SAMPLE_TRACKING_H

#include <math.h>

#include "core/rng.h"
#include "core/vecmath.h"
#include "medium.h"
#include "regular_tracking.h"
#include "sampler.h"
#include "core/deadline.h"

/* Ratio tracking: below this running weight, Russian roulette with survival
 * probability T/VOLUX_RATIO_RR, and T = VOLUX_RATIO_RR on survival (E[T]
 * kept). */
#define VOLUX_RATIO_RR 0.1f

/* Volume lookups between two looks at the render's clock (a mask). */
#define VOLUX_TRACK_CLOCK_EVERY 0x3fffu

/* What a tracker samples: σt (and colour) from volume + LUT, majorants
 * from the grid (or one global majorant). */
typedef struct volux_medium {
    const volux_volume *volume;
    const volux_transfer_lut *lut;
    const volux_majorant_grid *grid;
    int pre;             /* classification: 0 post (DESIGN), 1 pre      */
    int global_majorant; /* 1: one majorant for the whole box          */
    float min_spacing;   /* smallest voxel spacing (world units): the
                            scale of regular tracking's sub-steps      */
} volux_medium;

typedef struct volux_tracker {
    const volux_medium *m;
    volux_rng rng;
    uint64_t samples;        /* volume lookups */
    volux_deadline *deadline; /* the render's (NULL: no time budget)     */
    int stopped;             /* the time budget ran out: end the path    */
    /* Low-discrepancy draws (sample/sampler.h); all zero: independent. */
    volux_sampler ld;
    int ld_event;      /* the path's current event (scattering events so far) */
    unsigned ld_used;  /* uses of that event already drawn (bit per use)      */
    int ld_pending;    /* n > 0: the next n volux_tracker_rnd return
                          ld_next[n − 1], …, ld_next[0]                       */
    float ld_next[2];
    float ld_shadow;   /* ≥ 0: the first step of the event's first shadow ray */
} volux_tracker;

static inline float volux_tracker_rnd(volux_tracker *p) {
    if (__builtin_expect(p->ld_pending, 0)) /* sequence numbers handed to the trackers */
        return p->ld_next[--p->ld_pending];
    return volux_rng_float(&p->rng);
}

/* Starts event k of the path: its uses are fresh. */
static inline void volux_tracker_ld_event(volux_tracker *p, int k) {
    p->ld_event = k;
    p->ld_used = 0;
    p->ld_shadow = -1.0f;
}

/* The pair of `use` at the current event, as 32-bit fixed point: 1 when the
 * sampler is on, the event below VOLUX_LD_DEPTH and the use not yet drawn
 * at this event; else 0 and the caller draws from the stream (exactly the
 * draws of the independent sampler). */
static inline int volux_tracker_ld2_u32(volux_tracker *p, int use, uint32_t *x, uint32_t *y) {
    if (!p->ld.on || p->ld_event >= VOLUX_LD_DEPTH || (p->ld_used & (1u << use))) return 0;
    p->ld_used |= 1u << use;
    volux_sampler_2d_u32(&p->ld, volux_sampler_slot(p->ld_event, use), x, y);
    return 1;
}

static inline int volux_tracker_ld2(volux_tracker *p, int use, float *u, float *v) {
    uint32_t x, y;
    if (!volux_tracker_ld2_u32(p, use, &x, &y)) return 0;
    *u = volux_u32_to_float(x);
    *v = volux_u32_to_float(y);
    return 1;
}

/* Hands the event's shadow-ray number (from its VOLUX_LD_FLIGHT pair) to
 * the next draw of the trackers (volux_tracker_rnd) — the first step of a
 * ratio-tracking walk — once per event. The caller clears ld_pending after
 * the walk, so a number it did not take goes nowhere else. */
static inline void volux_tracker_ld_shadow(volux_tracker *p) {
    if (!(p->ld_shadow >= 0.0f)) return;
    p->ld_next[0] = p->ld_shadow;
    p->ld_pending = 1;
    p->ld_shadow = -1.0f;
}

/* Exponential step with rate sigma_max: −ln(1 − u)/σ̄, u ∈ [0,1). */
static inline float volux_exp_step(volux_tracker *p, float inv_sigma_max) {
    return -logf(1.0f - volux_tracker_rnd(p)) * inv_sigma_max;
}

/* Interval iteration over the macrocell majorants, or one interval with the
 * global maximum. */
typedef struct volux_track_iter {
    volux_march_iter it;
    int global, done;
    float t0, t1, sigma;
} volux_track_iter;

static inline void volux_track_iter_init(volux_track_iter *i, const volux_medium *m, const volux_ray *r, float ta,
                                         float tb) {
    i->global = m->global_majorant;
    if (i->global) {
        i->done = !(tb > ta);
        i->t0 = ta;
        i->t1 = tb;
        i->sigma = m->grid->global_max;
    } else {
        volux_march_init(&i->it, m->grid, r, ta, tb);
    }
}

static inline int volux_track_iter_next(volux_track_iter *i, volux_interval *iv) {
    if (!i->global) return volux_march_next(&i->it, iv);
    if (i->done) return 0;
    i->done = 1;
    iv->t0 = i->t0;
    iv->t1 = i->t1;
    iv->sigma_max = i->sigma;
    return 1;
}

/* σt at ray parameter t (and the colour into rgb when non-NULL). */
static inline float volux_tracker_sigma(volux_tracker *p, const volux_ray *r, float t, float *rgb) {
    const volux_medium *m = p->m;
    /* Long paths honour the render's time budget (--time-ms). */
    if ((++p->samples & VOLUX_TRACK_CLOCK_EVERY) == 0 && volux_deadline_expired(p->deadline)) p->stopped = 1;
    return volux_medium_eval(m->volume, m->lut, m->pre, v3_madd(r->q0, r->dq, t), rgb);
}

/* Regular tracking over [t, t1] (sample/regular_tracking.h), for intervals
 * where delta tracking would take too many steps or cannot advance t: the
 * first collision with optical depth −ln(1 − u). */
static inline int volux_delta_track_regular(volux_tracker *p, const volux_ray *r, float t, float t1, float *t_hit) {
    volux_track_steps steps;
    volux_track_steps_init(&steps, t, t1, p->m->min_spacing);
    float target = -logf(1.0f - volux_tracker_rnd(p)), a, b, mid;
    while (volux_track_steps_next(&steps, &a, &b, &mid) && !p->stopped) {
        float sigma = volux_tracker_sigma(p, r, mid, NULL), tau = sigma * (b - a);
        if (tau >= target) {
            *t_hit = volux_track_hit(a, b, sigma, target);
            return 1;
        }
        target -= tau;
    }
    return 0;
}

/* volux_track_carry — with the "sobol" sampler (p->ld.on) a tentative step
 * that crosses an interval's end is not redrawn in the next interval: its
 * optical depth beyond the end, σ̄₁·(t − t₁), is Exp(1) given the crossing
 * and independent of the past (memorylessness), so (t − t₁)·σ̄₁/σ̄₂ is the
 * next interval's Exp(σ̄₂) step. Same distribution as a fresh draw, but one
 * stratified number then places the first tentative collision along the
 * whole ray instead of only inside the first macrocell. The independent
 * sampler keeps its draws (and images) as they were. */

/* Delta tracking over [ta, tb] of the clipped ray r: returns 1 and the
 * distance of the first real collision, or 0 if the ray gets through (or
 * the time budget ended the path: p->stopped). Every loop advances t or
 * ends: see sample/regular_tracking.h. */
static inline int volux_delta_track(volux_tracker *p, const volux_ray *r, float ta, float tb, float *t_hit) {
    volux_track_iter it;
    volux_interval iv;
    float carry = -1.0f; /* optical depth left of a step that crossed an interval's end */
    volux_track_iter_init(&it, p->m, r, ta, tb);
    while (volux_track_iter_next(&it, &iv) && !p->stopped) {
        if (!(iv.sigma_max > 0.0f)) continue; /* empty space: no collisions */
        if (volux_track_needs_regular(iv.sigma_max, iv.t0, iv.t1)) {
            carry = -1.0f;
            if (volux_delta_track_regular(p, r, iv.t0, iv.t1, t_hit)) return 1;
            continue;
        }
        float inv = 1.0f / iv.sigma_max, t = iv.t0;
        while (!p->stopped) {
            float tn = t + (carry >= 0.0f ? carry * inv : volux_exp_step(p, inv));
            carry = -1.0f;
            if (tn >= iv.t1) { /* memoryless: restart at the next interval */
                if (p->ld.on) carry = (tn - iv.t1) * iv.sigma_max; /* see volux_track_carry */
                break;
            }
            if (!(tn > t) && volux_track_stalled(t, inv)) { /* steps below half an ulp of t */
                if (volux_delta_track_regular(p, r, t, iv.t1, t_hit)) return 1;
                break;
            }
            t = tn;
            float sigma = volux_tracker_sigma(p, r, t, NULL);
            if (volux_tracker_rnd(p) * iv.sigma_max < sigma) {
                *t_hit = t;
                return 1;
            }
        }
    }
    return 0;
}

/* Ratio tracking's regular-tracking fallback over [t, t1]: multiplies *T by
 * the closed-form transmittance of each sub-step; 0 when the path's weight
 * was rouletted away. */
static inline int volux_ratio_track_regular(volux_tracker *p, const volux_ray *r, float t, float t1, float *T) {
    volux_track_steps steps;
    volux_track_steps_init(&steps, t, t1, p->m->min_spacing);
    float a, b, mid;
    while (volux_track_steps_next(&steps, &a, &b, &mid) && !p->stopped) {
        *T *= expf(-volux_tracker_sigma(p, r, mid, NULL) * (b - a));
        if (*T < VOLUX_RATIO_RR) {
            if (!(*T > 0.0f) || volux_tracker_rnd(p) * VOLUX_RATIO_RR >= *T) return 0;
            *T = VOLUX_RATIO_RR;
        }
    }
    return 1;
}

/* Ratio tracking estimate of the transmittance from o along unit d over
 * distance dist (INFINITY: to the volume's exit); 0 once the time budget
 * ended the path. */
static inline float volux_ratio_track(volux_tracker *p, volux_vec3 o, volux_vec3 d, float dist) {
    const volux_medium *m = p->m;
    volux_ray r;
    if (!volux_ray_clip(m->volume, o, d, &r)) return 1.0f;
    float tb = r.t1 < dist ? r.t1 : dist;
    if (!(tb > r.t0)) return 1.0f;
    float T = 1.0f;
    volux_track_iter it;
    volux_interval iv;
    float carry = -1.0f; /* as in volux_delta_track */
    volux_track_iter_init(&it, m, &r, r.t0, tb);
    while (volux_track_iter_next(&it, &iv) && !p->stopped) {
        if (!(iv.sigma_max > 0.0f)) continue;
        if (volux_track_needs_regular(iv.sigma_max, iv.t0, iv.t1)) {
            carry = -1.0f;
            if (!volux_ratio_track_regular(p, &r, iv.t0, iv.t1, &T)) return 0.0f;
            continue;
        }
        float inv = 1.0f / iv.sigma_max, t = iv.t0;
        while (!p->stopped) {
            float tn = t + (carry >= 0.0f ? carry * inv : volux_exp_step(p, inv));
            carry = -1.0f;
            if (tn >= iv.t1) {
                if (p->ld.on) carry = (tn - iv.t1) * iv.sigma_max;
                break;
            }
            if (!(tn > t) && volux_track_stalled(t, inv)) { /* steps below half an ulp of t */
                if (!volux_ratio_track_regular(p, &r, t, iv.t1, &T)) return 0.0f;
                break;
            }
            t = tn;
            T *= 1.0f - volux_tracker_sigma(p, &r, t, NULL) * inv; /* Novák et al. 2014, Eq. 6 */
            if (T < VOLUX_RATIO_RR) {
                if (!(T > 0.0f) || volux_tracker_rnd(p) * VOLUX_RATIO_RR >= T) return 0.0f;
                T = VOLUX_RATIO_RR;
            }
        }
    }
    return p->stopped ? 0.0f : T;
}

#endif
