/*
 * sample/segment.h — the ray segments an emission–absorption ray caster
 * integrates, and their optical depth and colour.
 *
 * Segments: a ray's samples sit at t0 + (k + jitter)·h (k ≥ 0), and segment
 * k is (t_{k−1}, t_k] (segment 0 starts at t0), so the whole ray is covered
 * once. With a majorant grid, intervals whose σt̄ is 0 are skipped
 * (empty-space skipping): the segments that end in them are never visited,
 * and the first segment after such a gap is flagged, because the sample at
 * its front was not taken (pre-integration needs it). Without a grid the
 * ray is one interval. Same segment positions either way, so skipping never
 * changes an image (only which zero-opacity segments are visited).
 *
 * Optics: a segment of length len ending at scalar s has optical depth
 * τ and colour c either point-sampled at s, or pre-integrated with s linear
 * from the previous sample (Engel et al. 2001), from the LUT's running
 * integrals: within one table interval σt and σt·c are that interval's
 * means (τ = len·σ̄, c = (σc)‾/σ̄, no division by a tiny Δs); across
 * intervals τ = len·ΔI/Δs and c = ΔI_c/ΔI, Δs in table units u — the same
 * numbers that chose the intervals.
 *
 * Everything lives on the caller's stack; always inlined, for the
 * per-sample loops of the scalar ray casters (left to GCC's heuristics,
 * the deeper inlining of the shared ray-caster loop kept some out of line:
 * +1.4 % instructions for `shaded`, measured with callgrind).
 */
#ifndef VOLUX_SEGMENT_H
#define VOLUX_SEGMENT_H

#include <math.h>

#include "sample/march.h"

typedef struct volux_segments {
    volux_march_iter *it; /* NULL: no majorant grid. Kept apart from this
                             struct so that only the iterator escapes into
                             volux_march_next and the fields below stay in
                             registers in the caller's loop (3 % of the
                             scalar ray caster's rate, measured) */
    float t0, t1, h, jitter;
    float iv_t1;   /* end of the current interval                        */
    int inside;    /* iv is the current interval                         */
    int done;      /* no grid: the single interval has been handed out   */
    int gap;       /* samples were skipped before the next segment       */
    int k, next_k; /* next segment to try; first segment not yet visited */
} volux_segments;

/* grid NULL: no empty-space skipping (it is not used then); otherwise it
 * is the caller's grid iterator for this ray. */
static inline void volux_segments_init(volux_segments *g, volux_march_iter *it, const volux_majorant_grid *grid,
                                       const volux_ray *ray, float h, float jitter) {
    g->it = grid ? it : NULL;
    g->t0 = ray->t0;
    g->t1 = ray->t1;
    g->h = h;
    g->jitter = jitter;
    g->iv_t1 = ray->t1;
    g->inside = 0;
    g->done = 0;
    g->gap = 1;
    g->k = g->next_k = 0;
    float m0 = ray->t0;
    if (ray->windowed) { /* a brick's share of the ray: segments ending in (w0, w1] */
        if (!(ray->w0 < g->t1)) {
            g->t1 = g->iv_t1 = g->t0; /* nothing of the ray is ours */
        } else if (ray->w0 > g->t0) {
            /* the first segment whose end min(t0 + (k + jitter)·h, t1) is
             * past w0, with the loop's own float expression */
            int k = (int)floorf((ray->w0 - g->t0) / h - jitter);
            if (k < 0) k = 0;
            while (k > 0 && fminf(g->t0 + ((float)(k - 1) + jitter) * h, g->t1) > ray->w0) k--;
            while (fminf(g->t0 + ((float)k + jitter) * h, g->t1) <= ray->w0) k++;
            g->k = g->next_k = k;
            m0 = ray->w0;
        }
        if (ray->w1 < g->t1) {
            /* the last segment ending at or before w1 (here t_k < t1):
             * its end becomes the ray's end, so the next segment's front
             * (the same float) stops the loop */
            int k = (int)floorf((ray->w1 - g->t0) / h - jitter);
            if (k < -1) k = -1;
            while (g->t0 + ((float)(k + 1) + jitter) * h <= ray->w1) k++;
            while (k >= 0 && g->t0 + ((float)k + jitter) * h > ray->w1) k--;
            g->t1 = g->iv_t1 = k >= 0 ? g->t0 + ((float)k + jitter) * h : g->t0;
        }
        if (g->t1 < m0) m0 = g->t1;
    }
    if (grid) volux_march_init(it, grid, ray, m0, g->t1);
}

/* Next non-empty segment (a, b]; returns 0 at the end of the ray. *gap is 1
 * when the previous segment did not end at a (first segment, or samples
 * skipped in between). */
static inline __attribute__((always_inline)) int volux_segments_next(volux_segments *g, float *a_out, float *b_out,
                                                                    int *gap) {
    for (;;) {
        /* the common case first: the next segment of the current interval */
        while (g->inside) {
            int k = g->k;
            float a = k == 0 ? g->t0 : g->t0 + ((float)k - 1.0f + g->jitter) * g->h;
            if (a >= g->iv_t1 || a >= g->t1) {
                g->inside = 0;
                break;
            }
            float b = g->t0 + ((float)k + g->jitter) * g->h;
            if (b > g->t1) b = g->t1;
            g->k = g->next_k = k + 1;
            if (b - a <= 0.0f) continue;
            *a_out = a;
            *b_out = b;
            *gap = g->gap;
            g->gap = 0;
            return 1;
        }
        volux_interval iv = {g->t0, g->t1, 1.0f};
        if (g->it) {
            if (!volux_march_next(g->it, &iv)) return 0;
            if (iv.sigma_max <= 0.0f) continue;
        } else {
            if (g->done) return 0;
            g->done = 1;
        }
        g->iv_t1 = iv.t1;
        /* first segment that ends after iv.t0 */
        int k = (int)floorf((iv.t0 - g->t0) / g->h - g->jitter);
        if (k < g->next_k) k = g->next_k;
        if (k > g->next_k) g->gap = 1;
        g->k = k;
        g->inside = 1;
    }
}

/* Pre-integration state: the previous sample's table coordinate and
 * running integrals. */
typedef struct volux_preint {
    float u;
    double I, Ic[3];
} volux_preint;

/* Sets the previous sample to s (the front of a segment after a gap). */
static inline __attribute__((always_inline)) void volux_preint_front(const volux_transfer_lut *lut, float s,
                                                                   volux_preint *p) {
    p->u = volux_lut_coord(lut, s);
    p->I = volux_lut_int_at(lut, p->u, p->Ic);
}

/* τ and colour c of the segment of length len from the previous sample to
 * s; s becomes the previous sample. */
static inline __attribute__((always_inline)) float volux_preint_segment(const volux_transfer_lut *lut,
                                                                      volux_preint *p, float s, float len,
                                                                      float c[3]) {
    float u = volux_lut_coord(lut, s), tau;
    double Ic[3], I = volux_lut_int_at(lut, u, Ic);
    int i = volux_lut_interval(lut, u);
    if (i == volux_lut_interval(lut, p->u)) {
        const double *P = lut->int_sigma + i, *Pc = lut->int_sigma_c + 3 * i;
        double D = P[1] - P[0];
        tau = (float)((double)len * (double)lut->inv_ds * D);
        for (int q = 0; q < 3; q++) c[q] = D > 0.0 ? (float)((Pc[3 + q] - Pc[q]) / D) : 0.0f;
    } else {
        double dI = I - p->I;
        tau = (float)((double)len * (double)lut->inv_ds * dI / (double)(u - p->u));
        for (int q = 0; q < 3; q++) c[q] = dI != 0.0 ? (float)((Ic[q] - p->Ic[q]) / dI) : 0.0f;
    }
    p->u = u;
    p->I = I;
    for (int q = 0; q < 3; q++) p->Ic[q] = Ic[q];
    return tau;
}

/* τ and colour of a segment of length len point-sampled at s. */
static inline __attribute__((always_inline)) float volux_point_segment(const volux_transfer_lut *lut, float s,
                                                                     float len, float c[3]) {
    float rgba[4];
    volux_lut_rgba(lut, s, rgba);
    c[0] = rgba[0], c[1] = rgba[1], c[2] = rgba[2];
    return rgba[3] * len;
}

#endif
