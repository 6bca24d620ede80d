/*
 * techniques/lightvol/rows.h — what the portable row loops share: the
 * per-voxel helpers (bilinear light and medium fetches, post-classification,
 * the empty-footprint test, accumulation) as static inline functions, so
 * every row loop inlines them (rows_dir.c, rows_pos.c, sweep.c), and the
 * row entry points sweep.c calls per row and light.
 *
 * Internal to the technique.
 */
#ifndef VOLUX_LIGHTVOL_ROWS_H
#define VOLUX_LIGHTVOL_ROWS_H

#include <math.h>
#include <stddef.h>

#include "sweep.h"

/* World position of slice coordinates (x, y) on plane k. */
static inline volux_vec3 lv_slice_world(const lv_sweep *J, float x, float y, int k) {
    const lightvol_state *st = J->st;
    float p[3];
    p[J->a] = (float)k * st->spacing[J->a];
    p[J->au] = x * st->spacing[J->au];
    p[J->av] = y * st->spacing[J->av];
    return v3(st->lo.x + p[0], st->lo.y + p[1], st->lo.z + p[2]);
}

/* Bilinear fetch of entry e's previous slice at (x, y). A point outside the
 * slice lies outside the volume box: the light there crossed only empty
 * space (the box is convex), so it is the light's unoccluded ray value. */
static inline __attribute__((always_inline)) void lv_fetch(const lv_sweep *J, const lv_entry *e, float x, float y,
                                                          float out[3]) {
    int mu = J->mu, mv = J->mv;
    if (x >= 0.0f && y >= 0.0f && x <= (float)(mu - 1) && y <= (float)(mv - 1)) {
        int i = (int)x, j = (int)y;
        if (i > mu - 2) i = mu - 2;
        if (j > mv - 2) j = mv - 2;
        float ax = x - (float)i, ay = y - (float)j;
        size_t b = (size_t)j * (size_t)mu + (size_t)i;
        for (int c = 0; c < 3; c++) {
            const float *p = e->rd[c] + b;
            float t0 = p[0] + (p[1] - p[0]) * ax, t1 = p[mu] + (p[mu + 1] - p[mu]) * ax;
            out[c] = t0 + (t1 - t0) * ay;
        }
        return;
    }
    lv_ray_value(e->s, lv_slice_world(J, x, y, J->kp), out);
}

/* σt and κ_c = σt − f·σs_c (first np of them) of scalar value s. */
static inline __attribute__((always_inline)) void lv_classify_s(const lv_sweep *J, float s, float m[4]) {
    if (!J->forward) {
        m[0] = volux_lut_sigma(J->lut, s);
        return;
    }
    float rgba[4];
    volux_lut_rgba(J->lut, s, rgba);
    float sg = rgba[3], k = J->fwd * J->albedo * sg;
    m[0] = sg;
    for (int c = 0; c < 3; c++) {
        float kc = sg - k * rgba[c];
        m[1 + c] = kc > 0.0f ? kc : 0.0f;
    }
}

/* Adds wp·M_prev(x, y) + wc·M_cur(x, y) of the first np medium planes to
 * tau[] (one bilinear footprint for all planes and both slices; outside
 * the slice the medium is empty). Post-classified slices: the scalar is
 * interpolated to the point ((1 − t)·prev + t·cur, t = wc/(wp + wc)) and
 * classified there, adding (wp + wc)·M(s). */
static inline __attribute__((always_inline)) void lv_med_accumulate(const lv_sweep *J, float x, float y, float wp,
                                                                    float wc, int np, float tau[4]) {
    const int mu = J->mu, mv = J->mv;
    const size_t area = J->area;
    if (x >= 0.0f && y >= 0.0f && x <= (float)(mu - 1) && y <= (float)(mv - 1)) {
        int i = (int)x, j = (int)y;
        if (i > mu - 2) i = mu - 2;
        if (j > mv - 2) j = mv - 2;
        float ax = x - (float)i, ay = y - (float)j;
        float w00 = (1.0f - ax) * (1.0f - ay), w10 = ax * (1.0f - ay), w01 = (1.0f - ax) * ay, w11 = ax * ay;
        size_t b = (size_t)j * (size_t)mu + (size_t)i;
        if (J->post) {
            const float *P = J->mp + b, *C = J->mc + b;
            float sp = w00 * P[0] + w10 * P[1] + w01 * P[mu] + w11 * P[mu + 1];
            float sc = w00 * C[0] + w10 * C[1] + w01 * C[mu] + w11 * C[mu + 1];
            float l = wp + wc;
            if (!(l > 0.0f)) return;
            float m[4];
            lv_classify_s(J, sp + (sc - sp) * (wc / l), m);
            for (int q = 0; q < np; q++) tau[q] += l * m[q];
            return;
        }
        for (int q = 0; q < np; q++) {
            const float *P = J->mp + (size_t)q * area + b, *C = J->mc + (size_t)q * area + b;
            tau[q] += wp * (w00 * P[0] + w10 * P[1] + w01 * P[mu] + w11 * P[mu + 1]) +
                      wc * (w00 * C[0] + w10 * C[1] + w01 * C[mu] + w11 * C[mu + 1]);
        }
        return;
    }
    (void)area; /* outside the box: empty */
}

/* 1 if rows [j0, j1] (clamped) of the previous and current slices hold no
 * medium: every transmittance there is exactly 1. */
static inline int lv_rows_empty(const lv_sweep *J, int j0, int j1) {
    if (j0 < 0) j0 = 0;
    if (j1 > J->mv - 1) j1 = J->mv - 1;
    const float *rp = J->mp + 4 * J->area, *rc = J->mc + 4 * J->area;
    float lo = INFINITY, hi = -INFINITY;
    for (int j = j0; j <= j1; j++) { /* (no NaN here: ranges come from comparisons) */
        float l = rp[2 * j] < rc[2 * j] ? rp[2 * j] : rc[2 * j], h = rp[2 * j + 1] > rc[2 * j + 1] ? rp[2 * j + 1] : rc[2 * j + 1];
        lo = l < lo ? l : lo;
        hi = h > hi ? h : hi;
    }
    if (!J->post) return !(hi > 0.0f);
    /* every value interpolated there lies in [lo, hi]: is σt zero on it?
     * (the table is linear between entries: look at the bracketing ones) */
    const volux_transfer_lut *lut = J->lut;
    const int last = lut->n - 1;
    float u0 = (lo - lut->s_min) * lut->inv_ds, u1 = (hi - lut->s_min) * lut->inv_ds;
    int i0 = (int)floorf(u0), i1 = (int)ceilf(u1);
    i0 = i0 < 0 ? 0 : (i0 > last ? last : i0);
    i1 = i1 < 0 ? 0 : (i1 > last ? last : i1);
    return J->st->lut_nz[i1 + 1] - J->st->lut_nz[i0] == 0;
}

/* a += w·o */
static inline void lv_accumulate(float *restrict a, const float *restrict o, float w, int n) {
    for (int u = 0; u < n; u++) a[u] += w * o[u];
}

/* D += lum(value)·(sign·factor·direction) */
static inline void lv_accumulate_dir(float *a, size_t m, float *const out[3], volux_vec3 d, int n) {
    float *restrict ax = a, *restrict ay = a + m, *restrict az = a + 2 * m;
    const float *restrict o0 = out[0], *restrict o1 = out[1], *restrict o2 = out[2];
    for (int u = 0; u < n; u++) {
        float lum = 0.2126f * o0[u] + 0.7152f * o1[u] + 0.0722f * o2[u];
        ax[u] += d.x * lum;
        ay[u] += d.y * lum;
        az[u] += d.z * lum;
    }
}

/* ------------------------------------------------------- row entry points */

/* What the previous directional entry of a row left in the row scratch. */
typedef struct lv_row_geom {
    const lv_entry *e; /* its geometry (offsets, taps)          */
    int empty;         /* its footprint holds no medium         */
    int have_T;        /* T, Tc hold its transmittances          */
} lv_row_geom;

/* rows_dir.c — directional light e, row v, portable loops: values into
 * out[c][0..mu) (T, Tc, cone, cen, tau: row scratch); the transmittances
 * are shared with *last when it has the same geometry. */
void volux_lightvol_dir_row(const lv_sweep *J, const lv_entry *e, int v, float *out[3], float *T, float *Tc[3],
                            float *cone[3], float *cen[3], float *tau[4], const lv_entry **last);

/* rows_dir.c — the same with the AVX2 kernels, fused with the accumulation
 * into acc (and into S for a run of same-direction lights, see sweep.c). */
void volux_lightvol_dir_row_simd(const lv_sweep *J, const lv_entry *e, int v, float *out[3], float *T, float *Tc[3],
                                 float *tau[4], lv_row_geom *G, float *acc, int ch, float *S);

/* rows_pos.c — positional light e, row v: ray values into out, the weighted
 * 1/r² contribution into acc (scr: 16·mu floats of row scratch). */
void volux_lightvol_pos_row(const lv_sweep *J, const lv_entry *e, int v, float *out[3], float *acc, int ch,
                            float *scr);

#endif
