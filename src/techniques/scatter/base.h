/*
 * techniques/scatter/base.h — state and view-ray marcher shared by the
 * scattering techniques `single`, `ao` and `ambient`.
 *
 * Optical model of all three (Ament et al. 2013, Eqs. 18–20):
 *
 *     L(x_c) = T(x_b, x_c) L_b + J_e + J_i
 *     J_e = ∫ T(x) σa(x) L_e(x) dx,       σa = σt − σs, L_e = emission·c(x)
 *     J_i = ∫ T(x_o) σs(x) L_s(x) dx,     σs = albedo·c(x)·σt(x)  (DESIGN §2)
 *
 * where each technique supplies L_s(x), the radiance scattered towards the
 * camera per unit σs (an in-scattering callback), and x_o = x + lag·ω is
 * the point from which the camera transmittance is taken (`ambient` uses
 * lag = r, Eq. 20; the others lag = 0, i.e. T(x)). Segments of the view
 * ray are integrated with constant σt: a segment of optical depth τ adds
 * T·(1 − e^{−τ})·albedo·c·L_s, the exact integral of T σs L_s over it.
 *
 * Beyond the ray-caster base (render/raycaster.h) the three share only
 * their common parameters; each technique adds its own caches.
 */
#ifndef VOLUX_SCATTER_BASE_H
#define VOLUX_SCATTER_BASE_H

#include "core/simd.h"
#include "render/packet.h"
#include "render/raycaster.h"

/* Parameters every scattering technique has. */
#define SCATTER_COMMON_PARAMS                                                                                    \
    VOLUX_PARAM_EARLY_TERMINATION, VOLUX_PARAM_SKIP_EMPTY, VOLUX_PARAM_PACKET_KERNEL,                            \
        {"emission", VOLUX_PARAM_NUMBER, 0, 0, 1e6, NULL,                                                        \
         "emitted radiance L_e = emission·c(s) of the absorbing part σa (Eq. 19); 0 = no emission"}

typedef struct scatter_base {
    volux_raycaster rc;            /* base: volume, LUT, grid, camera, lights, albedo, g */
    float t_min, emission;         /* SCATTER_COMMON_PARAMS               */
    int skip_empty;
    int lag_window;                /* 1: weight ∫σt T(t − lag) dt over the
                                      segment; 0: T(e − lag)·α (see march) */
    /* march_kernel: 0 the scalar scatter_march, else the lanes (8/16) of
     * the packet march (render/packet_impl.h) and its tables */
    int march_lanes;
    volux_packet_tables pk;
} scatter_base;

/* The packet march of a scattering technique at one width (its
 * march_avx2.c / march_avx512.c; the contract of a tile renderer). */
typedef void (*scatter_packet_fn)(const volux_packet_march *pm, const void *tech, const volux_scene *scene,
                                  const volux_tile *tile, float *rgb, volux_tile_stats *stats);

/* Resolves march_kernel (`usable` 0: the technique's settings have no
 * packet path, `why` says what it needs) and keeps the packet tables up to
 * date; call from the technique's update after the base's. */
volux_status scatter_base_packet_update(scatter_base *b, const volux_scene *scene, const volux_change_set *c,
                                        int usable, const char *why);
void scatter_base_packet_release(scatter_base *b);

/* The packet march of a scattering technique with lag 0: volux_ea_march
 * point-sampled (scatter_march has no pre-integration) with the hook
 * turning c into scatter_emit's radiance. */
static inline void scatter_packet_tile(const scatter_base *b, const void *tech, const volux_scene *scene,
                                       const volux_tile *tile, float *rgb, volux_tile_stats *stats,
                                       scatter_packet_fn avx2, scatter_packet_fn avx512) {
    const volux_packet_march pm = {&b->rc, b->rc.lut, &b->pk, b->t_min, b->skip_empty, 0};
    (b->march_lanes == 16 ? avx512 : avx2)(&pm, tech, scene, tile, rgb, stats);
}

/* The radiance a lag-0 sample of colour c emits per unit opacity (what
 * scatter_march adds divided by T·α): albedo·c·L_s + L_x + L_e with
 * L_e = emission·(1 − albedo·c)·c (Eqs. 18–19). In place. */
static inline void scatter_emit(const scatter_base *b, float c[3], volux_vec3 Ls, volux_vec3 Lx) {
    const float a = b->rc.albedo, e = b->emission, ls[3] = {Ls.x, Ls.y, Ls.z}, lx[3] = {Lx.x, Lx.y, Lx.z};
    for (int k = 0; k < 3; k++) {
        float out = a * c[k] * ls[k] + lx[k];
        if (e > 0.0f) out += e * (1.0f - a * c[k]) * c[k];
        c[k] = out;
    }
}


/* Reads the common parameters (on a PARAMS or VOLUME change). */
void scatter_base_update(scatter_base *b, const volux_scene *scene, const volux_change_set *c);

/* One view-ray sample as the in-scattering callback sees it. */
typedef struct scatter_sample {
    volux_vec3 p;      /* world position                      */
    volux_vec3 q;      /* volume index-space position         */
    volux_vec3 to_eye; /* unit direction towards the camera   */
    float s;           /* scalar value                        */
    float sigma_t;     /* extinction at the sample (1/world unit) */
    float rgb[3];      /* colour c at the sample                  */
} scatter_sample;

/* Sets *scattered (radiance scattered towards the camera per unit σs: it
 * is multiplied by albedo·c) and *extra (added as is, e.g. specular
 * highlights); both start at 0. */
typedef void (*scatter_inscatter_fn)(const void *tech, const scatter_sample *smp, volux_vec3 *scattered,
                                     volux_vec3 *extra);
/* The camera-transmittance lag of a sample, in [0, max_lag] (world units;
 * x_o = x + lag·ω). Called only for samples that scatter. */
typedef float (*scatter_lag_fn)(const void *tech, const scatter_sample *smp);

/* One packet lane as scatter_sample (σt: the segment's τ/len, the point
 * value scatter_march passes). */
static inline void scatter_sample_of_lane(const volux_packet_lane *in, const float c[3], scatter_sample *smp) {
    smp->p = in->p;
    smp->q = in->q;
    smp->to_eye = v3_scale(in->d, -1.0f);
    smp->s = in->s;
    smp->sigma_t = in->len > 0.0f ? in->tau / in->len : 0.0f;
    smp->rgb[0] = c[0], smp->rgb[1] = c[1], smp->rgb[2] = c[2];
}

/* Past segments of the ray, for T(x_o) at a lag behind the current point:
 * (t0, t1, T before, T after); T is linear within a segment (one march
 * step). Records end more than max_lag behind the current sample are
 * folded into the base; when the ring is full the oldest is folded too
 * (T(x_o) is then taken slightly too close to x: conservative). */
#define SCATTER_LAG_RECORDS 2048

/* T at ray parameter tq from the records [tail, head) (sorted by t; gaps
 * between them are empty, T constant) and T_base before the first. The
 * first record that ends after tq is found by bisection: lags vary per
 * sample, so the records cannot simply be consumed in order. */
static inline __attribute__((always_inline)) float scatter_lag_T(const float (*rec)[4], int tail, int head,
                                                                 float T_base, float T_now, float tq) {
    if (tail == head || rec[(head - 1) % SCATTER_LAG_RECORDS][1] <= tq) return T_now;
    int lo = tail, hi = head - 1; /* rec[hi] ends after tq */
    while (lo < hi) {
        int mid = lo + (hi - lo) / 2;
        if (rec[mid % SCATTER_LAG_RECORDS][1] <= tq) lo = mid + 1;
        else hi = mid;
    }
    const float *r0 = rec[lo % SCATTER_LAG_RECORDS];
    if (tq > r0[0]) return r0[2] + (r0[3] - r0[2]) * (tq - r0[0]) / (r0[1] - r0[0]);
    return lo == tail ? T_base : rec[(lo - 1) % SCATTER_LAG_RECORDS][3];
}

/* scatter_lag_T at tq = e − max_lag right after the records that end at or
 * before tq were folded into T_base (scatter_march): the first record that
 * ends after tq is then the oldest one, so the bisection would return it —
 * the same value without the search, once per sample. */
static inline __attribute__((always_inline)) float scatter_lag_T_oldest(const float (*rec)[4], int tail, int head,
                                                                        float T_base, float T_now, float tq) {
    if (tail == head || rec[(head - 1) % SCATTER_LAG_RECORDS][1] <= tq) return T_now;
    const float *r0 = rec[tail % SCATTER_LAG_RECORDS];
    if (tq > r0[0]) return r0[2] + (r0[3] - r0[2]) * (tq - r0[0]) / (r0[1] - r0[0]);
    return T_base;
}

/* Integrates one view ray (the per-ray half of Eqs. 18–20; the pixel loop
 * is volux_raycaster_tile): segments of sample/segment.h, each adding
 * T(x_o)·(1 − e^{−τ})·albedo·c·L_s + emission, with x_o = x + lag·ω, the
 * lag given per sample by `lag_fn` (NULL: 0) and at most `max_lag`. Early
 * termination tests T at max_lag behind the sample: no later sample can
 * need a larger T(x_o). */
static inline __attribute__((always_inline)) volux_vec3
scatter_march(const scatter_base *b, const void *tech, const volux_ray *ray, float jitter, float *T_out,
              uint64_t *samples, float max_lag, scatter_lag_fn lag_fn, scatter_inscatter_fn inscatter) {
    const volux_volume *v = b->rc.volume;
    const volux_transfer_lut *lut = b->rc.lut;
    const float h = b->rc.step, albedo = b->rc.albedo, emission = b->emission;
    const int lagged = lag_fn != NULL && max_lag > 0.0f;
    uint64_t count = 0;
    float rec[SCATTER_LAG_RECORDS][4];
    scatter_sample smp;
    smp.to_eye = v3_scale(ray->d, -1.0f);
    float T = 1.0f, C[3] = {0, 0, 0};
    int head = 0, tail = 0; /* records [tail, head) */
    float T_base = 1.0f;
    volux_segments seg;
    volux_march_iter it;
    volux_segments_init(&seg, &it, b->skip_empty ? &b->rc.grid : NULL, ray, h, jitter);
    float a, e;
    int gap;
    while (volux_segments_next(&seg, &a, &e, &gap)) {
        float len = e - a;
        smp.q = v3_madd(ray->q0, ray->dq, e);
        /* the bricked copy where the technique built one (ambient): the
         * same value, better locality along oblique rays */
        smp.s = v->bricks ? volux_volume_sample_bricked(v, smp.q.x, smp.q.y, smp.q.z, v->storage)
                          : volux_volume_sample_index(v, smp.q.x, smp.q.y, smp.q.z);
        count++;
        float rgba[4];
        volux_lut_rgba(lut, smp.s, rgba);
        float tau = rgba[3] * len;
        if (tau <= 0.0f) continue;
        float alpha = 1.0f - volux_exp_nonpos_t6(-tau);
        if (lagged) /* records that no sample can reach any more */
            while (tail != head && rec[tail % SCATTER_LAG_RECORDS][1] <= (b->lag_window ? a : e) - max_lag)
                T_base = rec[tail++ % SCATTER_LAG_RECORDS][3];
        float ac = albedo * alpha;
        if (ac > 0.0f && (rgba[0] > 0.0f || rgba[1] > 0.0f || rgba[2] > 0.0f)) {
            /* The segment's weight. lag_window: ∫_a^e σt T(t − lag) dt
             * (Eq. 20 with x_o = x + lag·ω), T·α for lag 0; the part of
             * the lagged window [a − lag, e − lag] inside this segment
             * decays from T(a), the part before a is read from the
             * records (trapezoid of its ends). Otherwise T(x_o) at
             * t = e − lag times α, which shortens every lag by up to one
             * step (no lag at all where lag < step: the result depends on
             * render.step in dense media; docs/techniques/ambient.md §8). */
            float w = T * ac, wx = T * alpha; /* weights of albedo·c·L_s and of the extra term */
            smp.sigma_t = rgba[3];
            smp.rgb[0] = rgba[0], smp.rgb[1] = rgba[1], smp.rgb[2] = rgba[2];
            smp.p = v3_madd(ray->o, ray->d, e);
            if (lagged) {
                float lag = lag_fn(tech, &smp);
                const float(*rc4)[4] = (const float(*)[4])rec;
                if (lag > 0.0f && b->lag_window) {
                    float past = lag < len ? lag : len; /* window length before a */
                    float T0 = scatter_lag_T(rc4, tail, head, T_base, T, a - lag);
                    float T1 = scatter_lag_T(rc4, tail, head, T_base, T, a - lag + past);
                    float here = lag < len ? T * (1.0f - volux_exp_nonpos_t6(-rgba[3] * (len - lag))) : 0.0f;
                    wx = here + rgba[3] * past * 0.5f * (T0 + T1);
                    w = wx * albedo;
                } else if (lag > 0.0f) {
                    float T_o = scatter_lag_T(rc4, tail, head, T_base, T, e - lag);
                    w = T_o * ac, wx = T_o * alpha;
                }
            }
            volux_vec3 Ls = v3(0, 0, 0), Lx = v3(0, 0, 0);
            inscatter(tech, &smp, &Ls, &Lx);
            C[0] += w * rgba[0] * Ls.x + wx * Lx.x;
            C[1] += w * rgba[1] * Ls.y + wx * Lx.y;
            C[2] += w * rgba[2] * Ls.z + wx * Lx.z;
        }
        if (emission > 0.0f) {
            float w = T * alpha * emission;
            for (int ch = 0; ch < 3; ch++) C[ch] += w * (1.0f - albedo * rgba[ch]) * rgba[ch];
        }
        float T_far = T; /* T at max_lag behind this sample (before it) */
        if (lagged) {
            T_far = scatter_lag_T_oldest((const float(*)[4])rec, tail, head, T_base, T, e - max_lag);
            if (head - tail == SCATTER_LAG_RECORDS) T_base = rec[tail++ % SCATTER_LAG_RECORDS][3];
            float *r = rec[head++ % SCATTER_LAG_RECORDS];
            r[0] = a, r[1] = e, r[2] = T, r[3] = T * (1.0f - alpha);
        }
        T *= 1.0f - alpha;
        if ((lagged ? T_far : T) < b->t_min) break;
    }
    *samples += count;
    *T_out = T;
    return v3(C[0], C[1], C[2]);
}

/* Defines `static void NAME(state, scene, tile, rgb, stats)`, the tile
 * renderer of a scattering technique whose state type STATE starts with a
 * scatter_base `b`: the shared pixel loop around scatter_march with the
 * technique's in-scattering hook INSCATTER, its lag hook LAG_FN (NULL: T
 * at the sample) and the largest lag MAX_LAG (an expression of `st`, the
 * state), all inlined into the loop. */
#define SCATTER_RENDER_TILE(NAME, STATE, MAX_LAG, LAG_FN, INSCATTER)                                             \
    static inline __attribute__((always_inline)) volux_vec3 NAME##_ray(                                         \
        const void *tech, const volux_ray *ray, float jitter, float *T, uint64_t *samples, int variant) {       \
        (void)variant;                                                                                           \
        const STATE *st = tech;                                                                                  \
        return scatter_march(&st->b, tech, ray, jitter, T, samples, (MAX_LAG), LAG_FN, INSCATTER);              \
    }                                                                                                            \
    static void NAME(const void *state, const volux_scene *scene, const volux_tile *tile, float *rgb,           \
                     volux_tile_stats *stats) {                                                                  \
        const STATE *st = state;                                                                                 \
        volux_raycaster_tile(&st->b.rc, st, scene, tile, rgb, stats, NAME##_ray, 0);                            \
    }

#endif
