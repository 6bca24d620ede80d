/*
 * render/features.h — first-hit features of a camera ray (the AOVs of
 * volux_framebuffer_set_features, and the guides of the denoiser,
 * render/denoise.c), shared by the Monte-Carlo techniques (pathtrace,
 * guided).
 *
 * What the path tracer's first real collision would give, as an
 * expectation instead of one random draw: with T(t) the camera ray's
 * transmittance and σt(t) its extinction, the first collision has density
 * p(t) = σt(t)·T(t), so
 *   coverage  W = ∫ p dt = 1 − T(t1)         (the ray collides at all)
 *   depth     z = ∫ t·p dt / W               (E[t | collision])
 *   albedo    A = ∫ ρ(t)·p dt / W            (ρ = albedo · TF colour)
 *   density   σ = ∫ σt(t)·p dt / W
 * by midpoint quadrature at one smallest voxel spacing per step, skipping
 * the macrocells whose majorant is 0 (sample/march.h), with early
 * termination once T < 1e-3 (the rest changes W by < 1e-3). The normal is
 * ±∇s/|∇s| (the sign facing the camera) at the step of largest p — the most likely
 * first hit — not an integral, so it costs one gradient per ray.
 *
 * Why not the tracker's own first collision: it is one random draw, so at
 * 1–16 spp the depth of a semi-transparent pixel jumps by the whole
 * thickness of the medium from sample to sample, and an edge-stopping
 * filter guided by it would see edges everywhere. The expectation varies
 * only with the pixel jitter. The march takes no random number, so the
 * colour image is bit-identical with features on or off.
 *
 * Per sample, VOLUX_FEATURE_FLOATS floats, all weighted by W so that a
 * pixel's sums over samples resolve to conditional means by one division:
 *   [0] W  [1] W·z  [2..4] W·A  [5..7] W·n  [8] W·σ
 */
#ifndef VOLUX_RENDER_FEATURES_H
#define VOLUX_RENDER_FEATURES_H

#include "core/volume_internal.h"
#include "raycaster.h"
#include "sample/tracking.h"

#define VOLUX_FEATURE_FLOATS 9

/* The features of the ray o + t·d (d unit) into f[VOLUX_FEATURE_FLOATS].
 * `tr` supplies the medium and the deadline and counts the lookups; its
 * random stream is not touched. */
static inline void volux_first_hit_features(volux_tracker *tr, const volux_raycaster *rc, volux_vec3 o, volux_vec3 d,
                                            float *f) {
    for (int i = 0; i < VOLUX_FEATURE_FLOATS; i++) f[i] = 0.0f;
    volux_ray r;
    if (!volux_ray_clip(rc->volume, o, d, &r) || !(r.t1 > r.t0)) return;
    const volux_medium *m = tr->m;
    const float h = rc->min_spacing > 0.0f ? rc->min_spacing : 1.0f;
    float T = 1.0f, best = 0.0f, t_best = 0.0f;
    volux_track_iter it;
    volux_interval iv;
    volux_track_iter_init(&it, m, &r, r.t0, r.t1);
    while (T > 1e-3f && !tr->stopped && volux_track_iter_next(&it, &iv)) {
        if (!(iv.sigma_max > 0.0f)) continue; /* empty macrocells: no collision */
        for (float a = iv.t0; a < iv.t1 && T > 1e-3f && !tr->stopped; a += h) {
            float b = fminf(a + h, iv.t1), t = 0.5f * (a + b), c[3];
            float sigma = volux_tracker_sigma(tr, &r, t, c);
            if (!(sigma > 0.0f)) continue;
            float p = T * (1.0f - expf(-sigma * (b - a))); /* P(first collision in [a, b]) */
            f[0] += p;
            f[1] += p * t;
            for (int k = 0; k < 3; k++) f[2 + k] += p * rc->albedo * c[k];
            f[8] += p * sigma;
            if (p > best) best = p, t_best = t;
            T -= p;
        }
    }
    if (!(best > 0.0f)) return;
    volux_vec3 g = volux_volume_gradient(rc->volume, v3_madd(o, d, t_best));
    float len = sqrtf(v3_dot(g, g));
    if (!(len > 0.0f)) return; /* flat: no normal (a zero vector) */
    /* ±∇s/|∇s|, the sign that faces the camera (n·d ≤ 0). */
    float s = (v3_dot(g, d) > 0.0f ? -f[0] : f[0]) / len;
    f[5] = g.x * s;
    f[6] = g.y * s;
    f[7] = g.z * s;
}

/* The features of pixel (x, y) of `tile` (its camera ray o, d) when the
 * frame loop asked for them: a copy of the path's tracker marches, so the
 * path's lookup count — and with it when the deadline is looked at — and
 * its random stream stay as they were without features. */
static inline void volux_tile_features(const volux_tracker *tr, const volux_raycaster *rc, const volux_tile *tile,
                                       int x, int y, volux_vec3 o, volux_vec3 d, volux_tile_stats *stats) {
    if (!tile->features) return;
    volux_tracker ft = *tr;
    ft.samples = 0;
    volux_first_hit_features(&ft, rc, o, d, tile->features + VOLUX_FEATURE_FLOATS * (y * tile->w + x));
    stats->samples += ft.samples;
    stats->features++;
}

#endif
