/*
 * techniques/lightvol/propagate_avx2.c — AVX2+FMA (and AVX-512) row kernels
 * of the propagation sweeps. All intrinsics of `lightvol` live in this
 * file; it is compiled with target attributes and chosen at run time
 * (volux_lightvol_simd_available, techniques.lightvol.kernel), so the
 * default build runs on any x86-64 and the portable loops (rows_dir.c,
 * rows_pos.c) stay the reference the tests compare against
 * (tests/invariants/test_lightvol_simd.c).
 *
 * Each kernel evaluates the same formulas as the portable loops it
 * replaces, eight voxels of a row per step (16 in the interior of a
 * directional light's rows with AVX-512F):
 *   - row interiors, where every tap of every voxel lies inside the slice,
 *     with constant bilinear weights (directional lights) or per-lane ones
 *     (point/spot lights: the previous-slice point advances by less than a
 *     column per voxel, so 9-column windows replace gathers);
 *   - row ends by fetch()'s rules per lane (inside the slice: bilinear;
 *     outside: the unoccluded light, or empty medium), on 9-column windows;
 *   - reads of slices stay inside their rows, and stores to slice buffers
 *     are masked past the row; this thread's row scratch (accumulators,
 *     temporaries; ROW_FLOATS·mu + padding) is loaded and stored whole,
 *     the lanes past the row left unchanged or unused: the accumulators are
 *     read back by the next light at once, and a masked store there would
 *     block store-to-load forwarding.
 * Differences to the portable loops are float rounding (FMA contraction,
 * summation order); results do not depend on the thread count (every
 * voxel is computed by the same code whatever the row split).
 *
 * Why fused kernels: the portable code makes one pass over the row per
 * step (fetch, cone, attenuate, store, accumulate colour, accumulate
 * direction), re-reading its row temporaries each time; here one pass reads
 * the light's previous slice once, writes its current slice once and adds
 * into the accumulators while the values are in registers — the per-light
 * work of a coherent pass (docs/techniques/lightvol.md, "Row kernels").
 */
#include <math.h>
#include <string.h>

#include "core/simd.h"
#include "sweep.h"

int volux_lightvol_simd_available(void) { return volux_cpu_has_avx2_fma(); }
int volux_lightvol_avx512_available(void) { return volux_cpu_has_avx2_fma() && volux_cpu_has_avx512f(); }

#if VOLUX_X86_GNUC

#define A2 __attribute__((target("avx2,fma")))
#define A2I static inline __attribute__((always_inline, target("avx2,fma")))

/* Lanes [0, n) of a step (n ≤ 8 for a row's last, partial step). */
A2I __m256i lane_mask(int n) {
    const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    return _mm256_cmpgt_epi32(_mm256_set1_epi32(n), lane);
}

/* Full steps load and store plainly; the partial last step masks (the
 * masked lanes neither fault nor read: they are 0). `full` is a constant
 * after inlining. */
A2I __m256 ld(const float *p, int full, __m256i mk) { return full ? _mm256_loadu_ps(p) : _mm256_maskload_ps(p, mk); }
A2I void st8(float *p, __m256 x, int full, __m256i mk) {
    if (full) _mm256_storeu_ps(p, x);
    else _mm256_maskstore_ps(p, mk, x);
}

/* Bilinear combination of rows r0 (w00, w10 at u, u + 1) and r1 (w01, w11). */
A2I __m256 bil(const float *r0, const float *r1, __m256 w00, __m256 w10, __m256 w01, __m256 w11, int full,
               __m256i mk, __m256i mk1) {
    __m256 x = _mm256_mul_ps(w00, ld(r0, full, mk));
    x = _mm256_fmadd_ps(w10, ld(r0 + 1, full, mk1), x);
    x = _mm256_fmadd_ps(w01, ld(r1, full, mk), x);
    return _mm256_fmadd_ps(w11, ld(r1 + 1, full, mk1), x);
}

/* Transfer-function table position of scalar s: entry i ∈ [0, n − 2] and
 * fraction f, u clamped to [0, n − 1] (NaN → 0) as volux_lut_rgba does. */
A2I void lut_pos(const volux_transfer_lut *lut, __m256 s, __m256i *i, __m256 *f) {
    const float last = (float)(lut->n - 1);
    __m256 u = _mm256_mul_ps(_mm256_sub_ps(s, _mm256_set1_ps(lut->s_min)), _mm256_set1_ps(lut->inv_ds));
    u = _mm256_max_ps(u, _mm256_setzero_ps()); /* NaN → 0 */
    u = _mm256_min_ps(u, _mm256_set1_ps(last));
    __m256i k = _mm256_min_epi32(_mm256_cvttps_epi32(u), _mm256_set1_epi32(lut->n - 2));
    *i = k;
    *f = _mm256_sub_ps(u, _mm256_cvtepi32_ps(k));
}

/* σt(s) (volux_lut_sigma) */
A2I __m256 lut_sigma8(const volux_transfer_lut *lut, __m256 s) {
    __m256i i;
    __m256 f;
    lut_pos(lut, s, &i, &f);
    __m256 a = _mm256_i32gather_ps(lut->sigma_t, i, 4), b = _mm256_i32gather_ps(lut->sigma_t + 1, i, 4);
    return _mm256_fmadd_ps(_mm256_sub_ps(b, a), f, a);
}

/* 8×8 transpose: row k of the input becomes lane k of every output. */
A2I void transpose8(__m256 r[8]) {
    __m256 t0 = _mm256_unpacklo_ps(r[0], r[1]), t1 = _mm256_unpackhi_ps(r[0], r[1]);
    __m256 t2 = _mm256_unpacklo_ps(r[2], r[3]), t3 = _mm256_unpackhi_ps(r[2], r[3]);
    __m256 t4 = _mm256_unpacklo_ps(r[4], r[5]), t5 = _mm256_unpackhi_ps(r[4], r[5]);
    __m256 t6 = _mm256_unpacklo_ps(r[6], r[7]), t7 = _mm256_unpackhi_ps(r[6], r[7]);
    __m256 s0 = _mm256_shuffle_ps(t0, t2, 0x44), s1 = _mm256_shuffle_ps(t0, t2, 0xEE);
    __m256 s2 = _mm256_shuffle_ps(t1, t3, 0x44), s3 = _mm256_shuffle_ps(t1, t3, 0xEE);
    __m256 s4 = _mm256_shuffle_ps(t4, t6, 0x44), s5 = _mm256_shuffle_ps(t4, t6, 0xEE);
    __m256 s6 = _mm256_shuffle_ps(t5, t7, 0x44), s7 = _mm256_shuffle_ps(t5, t7, 0xEE);
    r[0] = _mm256_permute2f128_ps(s0, s4, 0x20);
    r[1] = _mm256_permute2f128_ps(s1, s5, 0x20);
    r[2] = _mm256_permute2f128_ps(s2, s6, 0x20);
    r[3] = _mm256_permute2f128_ps(s3, s7, 0x20);
    r[4] = _mm256_permute2f128_ps(s0, s4, 0x31);
    r[5] = _mm256_permute2f128_ps(s1, s5, 0x31);
    r[6] = _mm256_permute2f128_ps(s2, s6, 0x31);
    r[7] = _mm256_permute2f128_ps(s3, s7, 0x31);
}

/* σt and κ_c = max(σt − f·albedo·σt·c_c, 0) of scalar s (classify_s with
 * forward scattering): each lane reads its two table entries (8 floats,
 * rgba rgba) with one load, transposed into r0 g0 b0 a0 r1 g1 b1 a1. */
A2I void lut_kappa8(const lv_sweep *J, __m256 s, __m256 m[4]) {
    const volux_transfer_lut *lut = J->lut;
    __m256i i;
    __m256 f;
    lut_pos(lut, s, &i, &f);
    int idx[8];
    _mm256_storeu_si256((__m256i *)idx, i);
    __m256 r[8];
    for (int l = 0; l < 8; l++) r[l] = _mm256_loadu_ps(lut->rgba + 4 * (size_t)idx[l]);
    transpose8(r);
    __m256 c[4];
    for (int q = 0; q < 4; q++) c[q] = _mm256_fmadd_ps(_mm256_sub_ps(r[4 + q], r[q]), f, r[q]);
    __m256 sg = c[3], k = _mm256_mul_ps(_mm256_set1_ps(J->fwd * J->albedo), sg);
    m[0] = sg;
    for (int q = 0; q < 3; q++) m[1 + q] = _mm256_max_ps(_mm256_fnmadd_ps(k, c[q], sg), _mm256_setzero_ps());
}

/* A tap at a constant offset (du, row y) for the eight voxels u … u + 7 of
 * a row end, where some lanes fall outside the slice: fetch()'s rules per
 * lane (inside iff 0 ≤ x ≤ mu − 1 and 0 ≤ y ≤ mv − 1; cell min((int)x,
 * mu − 2); outside: a given value). The lanes' cells lie in a window of 9
 * columns starting at s, read with two loads per row and permuted into
 * place (masked gathers in the rare case they do not). */
typedef struct edge_tap {
    int rowin, gather;
    ptrdiff_t o0;          /* plane offset of the window: j·mu + s */
    __m256i rel, idx;      /* lane → window column; lane → plane index */
    __m256 in;             /* lanes inside the slice (and the row)     */
    __m256 w00, w10, w01, w11;
} edge_tap;

A2I void edge_tap_init(edge_tap *E, int u, float du, int di, float y, int mu, int mv) {
    E->rowin = y >= 0.0f && y <= (float)(mv - 1);
    if (!E->rowin) return;
    int j = (int)y;
    if (j > mv - 2) j = mv - 2;
    const __m256 ay = _mm256_set1_ps(y - (float)j), one = _mm256_set1_ps(1.0f);
    const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    __m256 x = _mm256_add_ps(_mm256_cvtepi32_ps(_mm256_add_epi32(_mm256_set1_epi32(u), lane)), _mm256_set1_ps(du));
    __m256 in = _mm256_and_ps(_mm256_cmp_ps(x, _mm256_setzero_ps(), _CMP_GE_OQ),
                              _mm256_cmp_ps(x, _mm256_set1_ps((float)(mu - 1)), _CMP_LE_OQ));
    E->in = _mm256_and_ps(in, _mm256_castsi256_ps(lane_mask(mu - u)));
    __m256i ix = _mm256_min_epi32(_mm256_cvttps_epi32(x), _mm256_set1_epi32(mu - 2));
    ix = _mm256_and_si256(ix, _mm256_castps_si256(E->in)); /* outside lanes: column 0 */
    __m256 ax = _mm256_sub_ps(x, _mm256_cvtepi32_ps(ix)), bx = _mm256_sub_ps(one, ax), by = _mm256_sub_ps(one, ay);
    E->w00 = _mm256_mul_ps(bx, by);
    E->w10 = _mm256_mul_ps(ax, by);
    E->w01 = _mm256_mul_ps(bx, ay);
    E->w11 = _mm256_mul_ps(ax, ay);
    int s = u + di;
    s = s < 0 ? 0 : (s > mu - 9 ? mu - 9 : s);
    __m256i rel = _mm256_sub_epi32(ix, _mm256_set1_epi32(s));
    __m256i bad = _mm256_or_si256(_mm256_cmpgt_epi32(_mm256_setzero_si256(), rel),
                                  _mm256_cmpgt_epi32(rel, _mm256_set1_epi32(7)));
    E->gather = !_mm256_testz_si256(bad, _mm256_castps_si256(E->in));
    E->rel = rel;
    E->o0 = (ptrdiff_t)j * mu + s;
    E->idx = _mm256_add_epi32(ix, _mm256_set1_epi32(j * mu));
}

/* The tap's bilinear value on `plane`, `outside` where a lane is outside. */
A2I __m256 edge_val(const edge_tap *E, const float *plane, int mu, __m256 outside) {
    if (!E->rowin) return outside;
    __m256 a, b, c, d;
    if (!E->gather) {
        const float *p = plane + E->o0;
        a = _mm256_permutevar8x32_ps(_mm256_loadu_ps(p), E->rel);
        b = _mm256_permutevar8x32_ps(_mm256_loadu_ps(p + 1), E->rel);
        c = _mm256_permutevar8x32_ps(_mm256_loadu_ps(p + mu), E->rel);
        d = _mm256_permutevar8x32_ps(_mm256_loadu_ps(p + mu + 1), E->rel);
    } else {
        const __m256i one = _mm256_set1_epi32(1), row = _mm256_set1_epi32(mu);
        const __m256 z = _mm256_setzero_ps();
        a = _mm256_mask_i32gather_ps(z, plane, E->idx, E->in, 4);
        b = _mm256_mask_i32gather_ps(z, plane, _mm256_add_epi32(E->idx, one), E->in, 4);
        c = _mm256_mask_i32gather_ps(z, plane, _mm256_add_epi32(E->idx, row), E->in, 4);
        d = _mm256_mask_i32gather_ps(z, plane, _mm256_add_epi32(_mm256_add_epi32(E->idx, row), one), E->in, 4);
    }
    __m256 x = _mm256_mul_ps(E->w00, a);
    x = _mm256_fmadd_ps(E->w10, b, x);
    x = _mm256_fmadd_ps(E->w01, c, x);
    x = _mm256_fmadd_ps(E->w11, d, x);
    return _mm256_blendv_ps(outside, x, E->in);
}

/* a[0..8) += x on the lanes of mk, all 8 lanes loaded and stored (see
 * acc_add: lanes past the row are this thread's scratch, stored back
 * unchanged). */
A2I void add_blend(float *a, __m256 x, __m256 mk) {
    __m256 old = _mm256_loadu_ps(a);
    _mm256_storeu_ps(a, _mm256_blendv_ps(old, _mm256_add_ps(old, x), mk));
}

/* One step of dir_tau: sub-sample tap t of rows P0/P1 (previous slice) and
 * C0/C1 (current), lanes u … u + 7. */
A2I void tau_step(const lv_sweep *J, const float *P0, const float *P1, const float *C0, const float *C1, lv_tap t,
                  float wp, float wc, float *const tau[4], int u, int full, __m256i mk, __m256i mk1) {
    const int np = J->nplanes;
    const size_t area = J->area;
    const __m256 w00 = _mm256_set1_ps(t.w00), w10 = _mm256_set1_ps(t.w10), w01 = _mm256_set1_ps(t.w01),
                 w11 = _mm256_set1_ps(t.w11);
    if (J->post) {
        /* interpolate the scalar between the slices, then classify */
        const float l = wp + wc;
        __m256 sp = bil(P0 + u, P1 + u, w00, w10, w01, w11, full, mk, mk1);
        __m256 sc = bil(C0 + u, C1 + u, w00, w10, w01, w11, full, mk, mk1);
        __m256 s = _mm256_fmadd_ps(_mm256_sub_ps(sc, sp), _mm256_set1_ps(wc / l), sp);
        __m256 m[4];
        if (J->forward) lut_kappa8(J, s, m);
        else m[0] = lut_sigma8(J->lut, s);
        const __m256 vl = _mm256_set1_ps(l);
        for (int q = 0; q < np; q++) st8(tau[q] + u, _mm256_fmadd_ps(vl, m[q], ld(tau[q] + u, full, mk)), full, mk);
        return;
    }
    const __m256 vp = _mm256_set1_ps(wp), vc = _mm256_set1_ps(wc);
    for (int q = 0; q < np; q++) {
        const size_t o = (size_t)q * area;
        __m256 a = bil(P0 + o + u, P1 + o + u, w00, w10, w01, w11, full, mk, mk1);
        __m256 b = bil(C0 + o + u, C1 + o + u, w00, w10, w01, w11, full, mk, mk1);
        __m256 x = _mm256_fmadd_ps(vp, a, _mm256_mul_ps(vc, b));
        st8(tau[q] + u, _mm256_add_ps(ld(tau[q] + u, full, mk), x), full, mk);
    }
}

A2 void volux_lightvol_dir_tau_avx2(const lv_sweep *J, const lv_entry *e, int v, int u0, int u1, float *const tau[4]) {
    const int mu = J->mu, mv = J->mv, np = J->nplanes;
    const size_t area = J->area;
    const __m256i all = _mm256_set1_epi32(-1);
    const __m256 zero = _mm256_setzero_ps();
    for (int i = 0; i < e->nsub; i++) {
        const lv_tap t = e->ts[i];
        const float wp = e->wp[i], wc = e->wc[i], l = wp + wc;
        if (!(l > 0.0f)) continue;
        const float *P0 = J->mp + (ptrdiff_t)(v + t.dj) * mu + t.di, *P1 = P0 + mu;
        const float *C0 = J->mc + (ptrdiff_t)(v + t.dj) * mu + t.di, *C1 = C0 + mu;
        for (int u = 0; u < mu; u += 8) {
            if (u >= u0 && u + 8 <= u1) { /* interior: constant weights, plain loads */
                tau_step(J, P0, P1, C0, C1, t, wp, wc, tau, u, 1, all, all);
                continue;
            }
            /* row ends: per-lane fetch rules, outside the slice the medium is empty */
            edge_tap E;
            edge_tap_init(&E, u, e->su[i], t.di, (float)v + e->sv[i], mu, mv);
            if (!E.rowin) continue;
            if (J->post) {
                __m256 sp = edge_val(&E, J->mp, mu, zero), sc = edge_val(&E, J->mc, mu, zero);
                __m256 s = _mm256_fmadd_ps(_mm256_sub_ps(sc, sp), _mm256_set1_ps(wc / l), sp), m[4];
                if (J->forward) lut_kappa8(J, s, m);
                else m[0] = lut_sigma8(J->lut, s);
                for (int q = 0; q < np; q++) add_blend(tau[q] + u, _mm256_mul_ps(_mm256_set1_ps(l), m[q]), E.in);
                continue;
            }
            for (int q = 0; q < np; q++) {
                __m256 x = edge_val(&E, J->mp + (size_t)q * area, mu, zero);
                __m256 y = edge_val(&E, J->mc + (size_t)q * area, mu, zero);
                add_blend(tau[q] + u, _mm256_fmadd_ps(_mm256_set1_ps(wp), x, _mm256_mul_ps(_mm256_set1_ps(wc), y)),
                          E.in);
            }
        }
    }
}

A2 void volux_lightvol_exp_avx2(float *T, const float *tau, int n) {
    int u = 0;
    for (; u + 8 <= n; u += 8) _mm256_storeu_ps(T + u, volux_exp_neg_cw7_avx2(_mm256_loadu_ps(tau + u)));
    for (; u < n; u++) T[u] = volux_exp_neg_cw7(tau[u]); /* the row ends read these right away: no masked store */
}

/* a[0..8) += w·x on the lanes of mk. The row accumulators are read back
 * by the next light's row ends at once, and a masked store would block
 * store-to-load forwarding there (a stall per row and light): the partial
 * step loads all 8 lanes, blends and stores all 8 — lanes past the
 * interior hold this thread's row-end values or the next accumulator
 * row's (row scratch, ROW_FLOATS·mu + padding per thread), stored back
 * unchanged. */
A2I void acc_add(float *a, __m256 w, __m256 x, int full, __m256i mk) {
    __m256 old = _mm256_loadu_ps(a), sum = _mm256_fmadd_ps(w, x, old);
    _mm256_storeu_ps(a, full ? sum : _mm256_blendv_ps(old, sum, _mm256_castsi256_ps(mk)));
}

/* Constants of the fused directional light kernel for one row, broadcast
 * once (the loop stores through pointers the compiler cannot tell apart
 * from the entry, so it would reload them every step). */
typedef struct light_consts {
    __m256 w[5][4];          /* centre tap, then the 4 cone taps: w00 w10 w01 w11 */
    const float *r[5][3];    /* their upper rows per channel (+ mu: lower)         */
    __m256 sw, d[3], q4;
    __m256 g[3], d1[3];      /* one channel: sw·gain_c, dsw_i·lum(gain)          */
    int cone, empty, forward;
    int nst;                 /* the centre + cone stencil (lv_entry): its nodes */
    float *S;                /* run sum of sw·lum (sweep_row), or NULL: D here  */
    __m256 swl, swl1;        /* sw, sw·lum(gain) (one channel)                  */
    const float *sr[3][9];   /* its nodes' rows per channel (+ si)              */
    __m256 swc[4], swk[9];
} light_consts;

/* One channel (no forward scattering): the light's scalar, attenuated,
 * stored, and accumulated as gain·scalar. */
A2I void light_step1(const light_consts *K, ptrdiff_t mu, const float *T, float *out0, float *acc, size_t m, int ch,
                     int u, int full, __m256i mk) {
    __m256 o = bil(K->r[0][0] + u, K->r[0][0] + mu + u, K->w[0][0], K->w[0][1], K->w[0][2], K->w[0][3], full, mk, mk);
    if (!K->empty) o = _mm256_mul_ps(ld(T + u, full, mk), o);
    st8(out0 + u, o, full, mk);
    for (int c = 0; c < 3; c++) acc_add(acc + (size_t)c * m + (size_t)u, K->g[c], o, full, mk);
    if (ch == 6 && K->S) acc_add(K->S + u, K->swl1, o, full, mk);
    else if (ch == 6)
        for (int i = 0; i < 3; i++) acc_add(acc + (size_t)(3 + i) * m + (size_t)u, K->d1[i], o, full, mk);
}

A2I void light_step(const light_consts *K, ptrdiff_t mu, const float *T, float *const Tc[3], float *const out[3],
                    float *acc, size_t m, int ch, int u, int full, __m256i mk) {
    __m256 o[3];
    for (int c = 0; c < 3; c++)
        o[c] = bil(K->r[0][c] + u, K->r[0][c] + mu + u, K->w[0][0], K->w[0][1], K->w[0][2], K->w[0][3], full, mk, mk);
    if (!K->empty) {
        __m256 Tv = ld(T + u, full, mk);
        if (!K->forward) {
            for (int c = 0; c < 3; c++) o[c] = _mm256_mul_ps(Tv, o[c]);
        } else if (!K->cone) {
            for (int c = 0; c < 3; c++) o[c] = _mm256_mul_ps(ld(Tc[c] + u, full, mk), o[c]);
        } else if (K->nst) {
            /* direct part sharp, forward-scattered part from the cone: both
             * from one read of the stencil's 9 nodes */
            for (int c = 0; c < 3; c++) {
                __m256 cen = _mm256_setzero_ps(), cn = _mm256_setzero_ps();
                for (int p = 0; p < 4; p++) {
                    __m256 x = ld(K->sr[c][p] + u, full, mk);
                    cen = _mm256_fmadd_ps(K->swc[p], x, cen);
                    cn = _mm256_fmadd_ps(K->swk[p], x, cn);
                }
                for (int p = 4; p < K->nst; p++) cn = _mm256_fmadd_ps(K->swk[p], ld(K->sr[c][p] + u, full, mk), cn);
                o[c] = _mm256_fmadd_ps(Tv, cen, _mm256_mul_ps(_mm256_sub_ps(ld(Tc[c] + u, full, mk), Tv), cn));
            }
        } else {
            /* direct part sharp, forward-scattered part from the cone's 4 taps */
            for (int c = 0; c < 3; c++) {
                __m256 cn = bil(K->r[1][c] + u, K->r[1][c] + mu + u, K->w[1][0], K->w[1][1], K->w[1][2], K->w[1][3],
                                full, mk, mk);
                for (int q = 2; q < 5; q++)
                    cn = _mm256_add_ps(cn, bil(K->r[q][c] + u, K->r[q][c] + mu + u, K->w[q][0], K->w[q][1],
                                               K->w[q][2], K->w[q][3], full, mk, mk));
                cn = _mm256_mul_ps(K->q4, cn);
                o[c] = _mm256_fmadd_ps(Tv, o[c], _mm256_mul_ps(_mm256_sub_ps(ld(Tc[c] + u, full, mk), Tv), cn));
            }
        }
    }
    for (int c = 0; c < 3; c++) {
        st8(out[c] + u, o[c], full, mk);
        acc_add(acc + (size_t)c * m + (size_t)u, K->sw, o[c], full, mk);
    }
    if (ch == 6) {
        __m256 lum = _mm256_mul_ps(_mm256_set1_ps(0.2126f), o[0]);
        lum = _mm256_fmadd_ps(_mm256_set1_ps(0.7152f), o[1], lum);
        lum = _mm256_fmadd_ps(_mm256_set1_ps(0.0722f), o[2], lum);
        if (K->S) acc_add(K->S + u, K->swl, lum, full, mk);
        else
            for (int i = 0; i < 3; i++) acc_add(acc + (size_t)(3 + i) * m + (size_t)u, K->d[i], lum, full, mk);
    }
}

/* Row-end step of the directional light kernel: every tap per lane by
 * fetch()'s rules (edge_tap), outside the slice the unoccluded value. */
A2I void light_edge_step(const lv_sweep *J, const lv_entry *e, const light_consts *K, int v, int u, const float *T,
                         float *const Tc[3], float *const out[3], float *acc, size_t m, int ch) {
    const int mu = J->mu, mv = J->mv;
    const int ntap = K->cone && !K->empty ? 5 : 1;
    edge_tap E[5];
    edge_tap_init(&E[0], u, e->du, e->tc.di, (float)v + e->dv, mu, mv);
    for (int q = 1; q < ntap; q++) edge_tap_init(&E[q], u, e->cu[q - 1], e->tcone[q - 1].di, (float)v + e->cv[q - 1], mu, mv);
    const float pw[3] = {e->s->power.x, e->s->power.y, e->s->power.z};
    const __m256i mk = lane_mask(mu - u);
    const int full = u + 8 <= mu;
    __m256 Tv = _mm256_loadu_ps(T + u);
    if (e->nch == 1) {
        __m256 o = edge_val(&E[0], e->rd[0], mu, _mm256_set1_ps(pw[0]));
        if (!K->empty) o = _mm256_mul_ps(Tv, o);
        st8(out[0] + u, o, full, mk);
        for (int c = 0; c < 3; c++) acc_add(acc + (size_t)c * m + (size_t)u, K->g[c], o, 0, mk);
        if (ch == 6 && K->S) acc_add(K->S + u, K->swl1, o, 0, mk);
        else if (ch == 6)
            for (int i = 0; i < 3; i++) acc_add(acc + (size_t)(3 + i) * m + (size_t)u, K->d1[i], o, 0, mk);
        return;
    }
    __m256 o[3];
    for (int c = 0; c < 3; c++) {
        const __m256 outside = _mm256_set1_ps(pw[c]);
        o[c] = edge_val(&E[0], e->rd[c], mu, outside);
        if (K->empty) continue;
        if (!K->forward) {
            o[c] = _mm256_mul_ps(Tv, o[c]);
        } else if (!K->cone) {
            o[c] = _mm256_mul_ps(_mm256_loadu_ps(Tc[c] + u), o[c]);
        } else {
            __m256 cn = edge_val(&E[1], e->rd[c], mu, outside);
            for (int q = 2; q < 5; q++) cn = _mm256_add_ps(cn, edge_val(&E[q], e->rd[c], mu, outside));
            cn = _mm256_mul_ps(K->q4, cn);
            o[c] = _mm256_fmadd_ps(Tv, o[c], _mm256_mul_ps(_mm256_sub_ps(_mm256_loadu_ps(Tc[c] + u), Tv), cn));
        }
    }
    for (int c = 0; c < 3; c++) {
        st8(out[c] + u, o[c], full, mk);
        acc_add(acc + (size_t)c * m + (size_t)u, K->sw, o[c], 0, mk);
    }
    if (ch == 6) {
        __m256 lum = _mm256_mul_ps(_mm256_set1_ps(0.2126f), o[0]);
        lum = _mm256_fmadd_ps(_mm256_set1_ps(0.7152f), o[1], lum);
        lum = _mm256_fmadd_ps(_mm256_set1_ps(0.0722f), o[2], lum);
        if (K->S) acc_add(K->S + u, K->swl, lum, 0, mk);
        else
            for (int i = 0; i < 3; i++) acc_add(acc + (size_t)(3 + i) * m + (size_t)u, K->d[i], lum, 0, mk);
    }
}

/* The row's constants of entry e (see light_consts). */
A2I void light_consts_init(light_consts *K, const lv_sweep *J, const lv_entry *e, int v, int u0, int u1, int empty,
                           float *S) {
    const ptrdiff_t mu = J->mu;
    K->cone = J->cone;
    K->empty = empty;
    K->forward = J->forward;
    K->nst = u1 > u0 && e->nch == 3 && J->cone && !empty ? e->nst : 0;
    /* only what this row's steps read: the centre tap; the cone's taps one
     * by one only without a stencil (the row ends read the entry) */
    const int ntap = e->nch == 3 && J->cone && !empty && !K->nst ? 5 : 1;
    const lv_tap *taps[5] = {&e->tc, &e->tcone[0], &e->tcone[1], &e->tcone[2], &e->tcone[3]};
    for (int q = 0; q < ntap; q++) {
        const lv_tap *t = taps[q];
        K->w[q][0] = _mm256_set1_ps(t->w00);
        K->w[q][1] = _mm256_set1_ps(t->w10);
        K->w[q][2] = _mm256_set1_ps(t->w01);
        K->w[q][3] = _mm256_set1_ps(t->w11);
        /* (only dereferenced for interior steps, where they are in the slice) */
        for (int c = 0; c < e->nch; c++) K->r[q][c] = e->rd[c] + (u1 > u0 ? (v + t->dj) * mu + t->di : 0);
    }
    for (int p = 0; p < K->nst; p++) {
        if (p < 4) K->swc[p] = _mm256_set1_ps(e->swc[p]);
        K->swk[p] = _mm256_set1_ps(e->swk[p]);
        for (int c = 0; c < 3; c++) K->sr[c][p] = e->rd[c] + (v + e->sj[p]) * mu + e->si[p];
    }
    K->S = S;
    if (e->nch == 1) {
        const float lg = 0.2126f * e->gain[0] + 0.7152f * e->gain[1] + 0.0722f * e->gain[2];
        const float d[3] = {e->dsw.x, e->dsw.y, e->dsw.z};
        for (int c = 0; c < 3; c++) K->g[c] = _mm256_set1_ps(e->sw * e->gain[c]), K->d1[c] = _mm256_set1_ps(d[c] * lg);
        K->swl1 = _mm256_set1_ps(e->sw * lg);
    } else {
        K->sw = K->swl = _mm256_set1_ps(e->sw);
        K->d[0] = _mm256_set1_ps(e->dsw.x);
        K->d[1] = _mm256_set1_ps(e->dsw.y);
        K->d[2] = _mm256_set1_ps(e->dsw.z);
        K->q4 = _mm256_set1_ps(0.25f);
    }
    /* The row the next row of this light will read first (its lowest new
     * previous-slice row): requested now, it arrives from L3 while the
     * pass's other lights run (a large pass's slice buffers exceed L2). */
    const int jn = v + 1 + e->dj_max + 1;
    if (jn <= J->mv - 1)
        for (int c = 0; c < e->nch; c++)
            for (ptrdiff_t x = 0; x < mu; x += 16) _mm_prefetch((const char *)(e->rd[c] + jn * mu + x), _MM_HINT_T1);
}

A2 void volux_lightvol_dir_light_avx2(const lv_sweep *J, const lv_entry *e, int v, int u0, int u1, const float *T,
                                      float *const Tc[3], int empty, float *const out[3], float *acc, size_t m, int ch,
                                      float *S) {
    const ptrdiff_t mu = J->mu;
    light_consts K;
    light_consts_init(&K, J, e, v, u0, u1, empty, S);
    const __m256i all = _mm256_set1_epi32(-1);
    for (int u = 0; u < mu; u += 8) {
        if (u >= u0 && u + 8 <= u1) {
            if (e->nch == 1) light_step1(&K, mu, T, out[0], acc, m, ch, u, 1, all);
            else light_step(&K, mu, T, Tc, out, acc, m, ch, u, 1, all);
        } else {
            light_edge_step(J, e, &K, v, u, T, Tc, out, acc, m, ch);
        }
    }
}

/* ------------------------------------------- AVX-512: 16 voxels a step
 * The interior steps of the directional light kernel again, 16 lanes wide
 * where the CPU has AVX-512F (the per-light work of a pass is bound by its
 * FMAs and loads: twice the lanes per instruction); the same formulas as
 * light_step/light_step1, the row ends and short rests by them. */
#define A5 __attribute__((target("avx512f,avx2,fma")))
#define A5I static inline __attribute__((always_inline, target("avx512f,avx2,fma")))

typedef struct light_consts16 {
    __m512 w[4], swc[4], swk[9], sw, g[3], d[3], d1[3], swl, swl1;
} light_consts16;

A5I void light_consts16_init(light_consts16 *Z, const lv_entry *e) {
    const float w[4] = {e->tc.w00, e->tc.w10, e->tc.w01, e->tc.w11};
    for (int i = 0; i < 4; i++) Z->w[i] = _mm512_set1_ps(w[i]), Z->swc[i] = _mm512_set1_ps(e->swc[i]);
    for (int p = 0; p < 9; p++) Z->swk[p] = _mm512_set1_ps(p < e->nst ? e->swk[p] : 0.0f);
    const float lg = 0.2126f * e->gain[0] + 0.7152f * e->gain[1] + 0.0722f * e->gain[2];
    const float d[3] = {e->dsw.x, e->dsw.y, e->dsw.z};
    Z->sw = _mm512_set1_ps(e->sw);
    for (int c = 0; c < 3; c++) {
        Z->g[c] = _mm512_set1_ps(e->sw * e->gain[c]);
        Z->d[c] = _mm512_set1_ps(d[c]);
        Z->d1[c] = _mm512_set1_ps(d[c] * lg);
    }
    Z->swl = Z->sw;
    Z->swl1 = _mm512_set1_ps(e->sw * lg);
}

A5I void acc_add16(float *a, __m512 w, __m512 x) { _mm512_storeu_ps(a, _mm512_fmadd_ps(w, x, _mm512_loadu_ps(a))); }

A5I __m512 bil16(const float *r0, const float *r1, const __m512 w[4]) {
    __m512 x = _mm512_mul_ps(w[0], _mm512_loadu_ps(r0));
    x = _mm512_fmadd_ps(w[1], _mm512_loadu_ps(r0 + 1), x);
    x = _mm512_fmadd_ps(w[2], _mm512_loadu_ps(r1), x);
    return _mm512_fmadd_ps(w[3], _mm512_loadu_ps(r1 + 1), x);
}

/* One interior step of 16 voxels (light_step1 / light_step; the cone only
 * through the stencil — the caller takes 8-wide steps otherwise). */
A5I void light_step16(const light_consts *K, const light_consts16 *Z, int nch, ptrdiff_t mu, const float *T,
                      float *const Tc[3], float *const out[3], float *acc, size_t m, int ch, int u) {
    const __m512 Tv = _mm512_loadu_ps(T + u);
    if (nch == 1) {
        __m512 o = bil16(K->r[0][0] + u, K->r[0][0] + mu + u, Z->w);
        if (!K->empty) o = _mm512_mul_ps(Tv, o);
        _mm512_storeu_ps(out[0] + u, o);
        for (int c = 0; c < 3; c++) acc_add16(acc + (size_t)c * m + (size_t)u, Z->g[c], o);
        if (ch == 6 && K->S) acc_add16(K->S + u, Z->swl1, o);
        else if (ch == 6)
            for (int i = 0; i < 3; i++) acc_add16(acc + (size_t)(3 + i) * m + (size_t)u, Z->d1[i], o);
        return;
    }
    __m512 o[3];
    for (int c = 0; c < 3; c++) {
        if (K->empty || !K->cone) {
            o[c] = bil16(K->r[0][c] + u, K->r[0][c] + mu + u, Z->w);
            if (K->empty) continue;
            o[c] = _mm512_mul_ps(K->forward ? _mm512_loadu_ps(Tc[c] + u) : Tv, o[c]);
            continue;
        }
        __m512 cen = _mm512_setzero_ps(), cn = _mm512_setzero_ps();
        for (int p = 0; p < 4; p++) {
            __m512 x = _mm512_loadu_ps(K->sr[c][p] + u);
            cen = _mm512_fmadd_ps(Z->swc[p], x, cen);
            cn = _mm512_fmadd_ps(Z->swk[p], x, cn);
        }
        for (int p = 4; p < K->nst; p++) cn = _mm512_fmadd_ps(Z->swk[p], _mm512_loadu_ps(K->sr[c][p] + u), cn);
        o[c] = _mm512_fmadd_ps(Tv, cen, _mm512_mul_ps(_mm512_sub_ps(_mm512_loadu_ps(Tc[c] + u), Tv), cn));
    }
    for (int c = 0; c < 3; c++) {
        _mm512_storeu_ps(out[c] + u, o[c]);
        acc_add16(acc + (size_t)c * m + (size_t)u, Z->sw, o[c]);
    }
    if (ch == 6) {
        __m512 lum = _mm512_mul_ps(_mm512_set1_ps(0.2126f), o[0]);
        lum = _mm512_fmadd_ps(_mm512_set1_ps(0.7152f), o[1], lum);
        lum = _mm512_fmadd_ps(_mm512_set1_ps(0.0722f), o[2], lum);
        if (K->S) acc_add16(K->S + u, Z->swl, lum);
        else
            for (int i = 0; i < 3; i++) acc_add16(acc + (size_t)(3 + i) * m + (size_t)u, Z->d[i], lum);
    }
}

A5 void volux_lightvol_dir_light_avx512(const lv_sweep *J, const lv_entry *e, int v, int u0, int u1, const float *T,
                                        float *const Tc[3], int empty, float *const out[3], float *acc, size_t m,
                                        int ch, float *S) {
    const ptrdiff_t mu = J->mu;
    light_consts K;
    light_consts_init(&K, J, e, v, u0, u1, empty, S);
    light_consts16 Z;
    light_consts16_init(&Z, e);
    /* 16 wide unless the cone is read tap by tap (no stencil) */
    const int wide = e->nch == 1 || empty || !J->cone || K.nst > 0;
    const __m256i all = _mm256_set1_epi32(-1);
    for (int u = 0; u < mu;) {
        if (wide && u >= u0 && u + 16 <= u1) {
            light_step16(&K, &Z, e->nch, mu, T, Tc, out, acc, m, ch, u);
            u += 16;
            continue;
        }
        if (u >= u0 && u + 8 <= u1) {
            if (e->nch == 1) light_step1(&K, mu, T, out[0], acc, m, ch, u, 1, all);
            else light_step(&K, mu, T, Tc, out, acc, m, ch, u, 1, all);
        } else {
            light_edge_step(J, e, &K, v, u, T, Tc, out, acc, m, ch);
        }
        u += 8;
    }
}

/* ------------------------------------------------------------ positional */

A2I __m256 sel(__m256 mask, __m256 t, __m256 f) { return _mm256_blendv_ps(f, t, mask); }

/* lv_axis_weight for the face of axis a, magnitudes ma (axis a), mb and mc
 * (the other two axes b < c: here always au, av); same selects. */
A2I __m256 axis_weight8(__m256 ma, __m256 mb, __m256 mc, int a) {
    const __m256 zero = _mm256_setzero_ps();
    const int b_lt_a = a >= 1, c_lt_a = a == 2;
    __m256 gb = _mm256_cmp_ps(mb, ma, _CMP_GT_OQ), gc = _mm256_cmp_ps(mc, ma, _CMP_GT_OQ);
    if (b_lt_a) gb = _mm256_or_ps(gb, _mm256_cmp_ps(mb, ma, _CMP_EQ_OQ));
    if (c_lt_a) gc = _mm256_or_ps(gc, _mm256_cmp_ps(mc, ma, _CMP_EQ_OQ));
    __m256 rank0 = _mm256_andnot_ps(_mm256_or_ps(gb, gc), _mm256_castsi256_ps(_mm256_set1_epi32(-1)));
    __m256 rank2 = _mm256_and_ps(gb, gc);
    __m256 cm = _mm256_cmp_ps(mc, mb, _CMP_GT_OQ);
    __m256 hi = sel(cm, mc, mb), lo = sel(cm, mb, mc);
    __m256 ba = volux_acos01_deg7_avx2(ma), bh = volux_acos01_deg7_avx2(hi), bl = volux_acos01_deg7_avx2(lo);
    __m256 b1 = sel(rank0, ba, bh), b2 = sel(rank0, bh, ba);
    __m256 den = _mm256_sub_ps(_mm256_sub_ps(_mm256_mul_ps(_mm256_set1_ps(2.0f), bl), b1), b2);
    __m256 big = _mm256_cmp_ps(den, _mm256_set1_ps(1e-6f), _CMP_GT_OQ);
    __m256 q = _mm256_div_ps(_mm256_sub_ps(bl, b2), sel(big, den, _mm256_set1_ps(1.0f)));
    __m256 w2 = sel(big, q, _mm256_set1_ps(0.5f));
    w2 = sel(_mm256_andnot_ps(_mm256_cmp_ps(hi, zero, _CMP_GT_OQ), rank0), zero, w2);
    const float eps = LV_MIN_FACTOR;
    __m256 rem = _mm256_div_ps(_mm256_mul_ps(_mm256_set1_ps(0.5f), _mm256_sub_ps(w2, _mm256_set1_ps(eps))),
                               _mm256_set1_ps(0.5f - eps));
    w2 = sel(_mm256_cmp_ps(w2, _mm256_set1_ps(eps), _CMP_LE_OQ), zero, rem);
    __m256 w = sel(rank0, _mm256_sub_ps(_mm256_set1_ps(1.0f), w2), w2);
    __m256 off = _mm256_or_ps(rank2, _mm256_cmp_ps(ma, zero, _CMP_NGT_UQ)); /* rank 2 or !(ma > 0) */
    return sel(off, zero, w);
}

A2 void volux_lightvol_pos_geometry_avx2(const lv_sweep *J, const lv_entry *e, lv_pos_row *R) {
    const lightvol_state *st = J->st;
    const int a = J->a, au = J->au, av = J->av;
    const float su = st->spacing[au], sv = st->spacing[av];
    const float la = e->lidx[a], lu = e->lidx[au], lv = e->lidx[av];
    const float da = ((float)J->k - la) * st->spacing[a], dvw = ((float)R->v - lv) * sv;
    const float f = e->f, rm2 = J->rmin2, sign = e->sign;
    const __m256 vda2 = _mm256_set1_ps(da * da), vdv2 = _mm256_set1_ps(dvw * dvw);
    const __m256 vada = _mm256_set1_ps(fabsf(da)), vadv = _mm256_set1_ps(fabsf(dvw));
    const __m256 vda = _mm256_set1_ps(da), vdvw = _mm256_set1_ps(dvw), vlu = _mm256_set1_ps(lu),
                 vsu = _mm256_set1_ps(su), vf = _mm256_set1_ps(f), vrm2 = _mm256_set1_ps(rm2),
                 vsign = _mm256_set1_ps(sign), one = _mm256_set1_ps(1.0f);
    const __m256 absmask = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
    const __m256 lane = _mm256_setr_ps(0, 1, 2, 3, 4, 5, 6, 7);
    /* centre grouping: a constant factor per row unless the other group's
     * axis is u (then per lane, as lv_center_weight) */
    const int center = e->s->center, center_u = center && e->oax == 1;
    const __m256 vcw = _mm256_set1_ps(e->cw), vosg = _mm256_set1_ps((float)e->osg), vol = _mm256_set1_ps(e->ol);
    const __m256 vcw_row = _mm256_set1_ps(center && !center_u ? lv_center_weight(e, 0, R->v) : 0.0f);
    for (size_t u = 0; u < R->ms; u += 8) {
        __m256 uf = _mm256_add_ps(_mm256_set1_ps((float)u), lane);
        __m256 du = _mm256_mul_ps(_mm256_sub_ps(uf, vlu), vsu), du2 = _mm256_mul_ps(du, du);
        /* r² summed in x, y, z order like pos_voxels */
        __m256 r2 = a == 0   ? _mm256_add_ps(_mm256_add_ps(vda2, du2), vdv2)
                    : a == 1 ? _mm256_add_ps(_mm256_add_ps(du2, vda2), vdv2)
                             : _mm256_add_ps(_mm256_add_ps(du2, vdv2), vda2);
        __m256 r = _mm256_sqrt_ps(r2), ir = _mm256_div_ps(one, r);
        __m256 wg;
        if (center_u) /* lv_center_weight per lane: the other group's reach along u */
            wg = _mm256_blendv_ps(one, vcw, _mm256_cmp_ps(_mm256_mul_ps(vosg, _mm256_sub_ps(uf, vol)),
                                                          _mm256_setzero_ps(), _CMP_GT_OQ));
        else if (center) wg = vcw_row;
        else
            wg = axis_weight8(_mm256_mul_ps(vada, ir), _mm256_mul_ps(_mm256_and_ps(du, absmask), ir),
                              _mm256_mul_ps(vadv, ir), a);
        __m256 r2c = _mm256_blendv_ps(vrm2, r2, _mm256_cmp_ps(r2, vrm2, _CMP_GT_OQ));
        _mm256_storeu_ps(R->K + u, _mm256_div_ps(_mm256_mul_ps(vsign, wg), r2c));
        _mm256_storeu_ps(R->WA + u, _mm256_mul_ps(vda, ir));
        _mm256_storeu_ps(R->WU + u, _mm256_mul_ps(du, ir));
        _mm256_storeu_ps(R->WV + u, _mm256_mul_ps(vdvw, ir));
        _mm256_storeu_ps(R->X + u, _mm256_sub_ps(uf, _mm256_mul_ps(_mm256_sub_ps(uf, vlu), vf)));
        _mm256_storeu_ps(R->LEN + u, _mm256_mul_ps(r, vf));
    }
}

/* A light tap of a positional entry for 8 voxels: per-lane position x
 * (inside the slice), row j and fraction ay per lane. The lanes' x advance
 * by at most one column per voxel (x' = u − (u − l_u)·f, 0 < f ≤ 1, plus a
 * slowly varying cone offset), so when they share their row and span at
 * most 8 cells, a 9-column window read with two loads per row and
 * permuted into place replaces the 4 gathers (else: gathers). Inactive
 * lanes (mk) copy lane 0. */
typedef struct pos_tap {
    int win;
    ptrdiff_t off;        /* window: plane offset of (j, s)        */
    __m256i rel, idx;     /* window column per lane; gather index */
    __m256 w00, w10, w01, w11;
} pos_tap;

A2I int hmin_epi32(__m256i v) {
    __m256i m = _mm256_min_epi32(v, _mm256_permute2x128_si256(v, v, 1));
    m = _mm256_min_epi32(m, _mm256_shuffle_epi32(m, 0x4E));
    m = _mm256_min_epi32(m, _mm256_shuffle_epi32(m, 0xB1));
    return _mm256_cvtsi256_si32(m);
}
A2I int hmax_epi32(__m256i v) {
    __m256i m = _mm256_max_epi32(v, _mm256_permute2x128_si256(v, v, 1));
    m = _mm256_max_epi32(m, _mm256_shuffle_epi32(m, 0x4E));
    m = _mm256_max_epi32(m, _mm256_shuffle_epi32(m, 0xB1));
    return _mm256_cvtsi256_si32(m);
}

A2I void pos_tap_init(pos_tap *P, __m256 x, __m256i j, __m256 ay, int mu, __m256i mk) {
    __m256i ix = _mm256_min_epi32(_mm256_cvttps_epi32(x), _mm256_set1_epi32(mu - 2));
    const __m256i zero = _mm256_setzero_si256();
    ix = _mm256_blendv_epi8(_mm256_permutevar8x32_epi32(ix, zero), ix, mk);
    j = _mm256_blendv_epi8(_mm256_permutevar8x32_epi32(j, zero), j, mk);
    x = _mm256_blendv_ps(_mm256_permutevar8x32_ps(x, zero), x, _mm256_castsi256_ps(mk));
    ay = _mm256_blendv_ps(_mm256_permutevar8x32_ps(ay, zero), ay, _mm256_castsi256_ps(mk));
    const __m256 one = _mm256_set1_ps(1.0f);
    __m256 ax = _mm256_sub_ps(x, _mm256_cvtepi32_ps(ix)), bx = _mm256_sub_ps(one, ax), by = _mm256_sub_ps(one, ay);
    P->w00 = _mm256_mul_ps(bx, by);
    P->w10 = _mm256_mul_ps(ax, by);
    P->w01 = _mm256_mul_ps(bx, ay);
    P->w11 = _mm256_mul_ps(ax, ay);
    P->idx = _mm256_add_epi32(_mm256_mullo_epi32(j, _mm256_set1_epi32(mu)), ix);
    const int j0 = _mm256_cvtsi256_si32(j);
    const int same_row = _mm256_movemask_epi8(_mm256_cmpeq_epi32(j, _mm256_set1_epi32(j0))) == -1;
    const int lo = hmin_epi32(ix), hi = hmax_epi32(ix);
    P->win = same_row && hi - lo <= 7 && mu >= 9;
    if (!P->win) {
        P->off = 0, P->rel = zero; /* unused by the gathers */
        return;
    }
    int s = lo > mu - 9 ? mu - 9 : lo;
    P->rel = _mm256_sub_epi32(ix, _mm256_set1_epi32(s));
    P->off = (ptrdiff_t)j0 * mu + s;
}

A2I __m256 pos_tap_val(const pos_tap *P, const float *plane, int mu) {
    __m256 a, b, c, d;
    if (P->win) {
        const float *p = plane + P->off;
        a = _mm256_permutevar8x32_ps(_mm256_loadu_ps(p), P->rel);
        b = _mm256_permutevar8x32_ps(_mm256_loadu_ps(p + 1), P->rel);
        c = _mm256_permutevar8x32_ps(_mm256_loadu_ps(p + mu), P->rel);
        d = _mm256_permutevar8x32_ps(_mm256_loadu_ps(p + mu + 1), P->rel);
    } else {
        const __m256i one = _mm256_set1_epi32(1), row = _mm256_set1_epi32(mu);
        a = _mm256_i32gather_ps(plane, P->idx, 4);
        b = _mm256_i32gather_ps(plane, _mm256_add_epi32(P->idx, one), 4);
        c = _mm256_i32gather_ps(plane, _mm256_add_epi32(P->idx, row), 4);
        d = _mm256_i32gather_ps(plane, _mm256_add_epi32(_mm256_add_epi32(P->idx, row), one), 4);
    }
    __m256 x = _mm256_mul_ps(P->w00, a);
    x = _mm256_fmadd_ps(P->w10, b, x);
    x = _mm256_fmadd_ps(P->w01, c, x);
    return _mm256_fmadd_ps(P->w11, d, x);
}

/* The medium taps of a segment's sub-sample for 8 voxels share their row
 * (jrow) and advance by at most one column per voxel (px = u − (u −
 * l_u)·f·(1 − t)), so they take pos_tap's 9-column windows instead of 4
 * gathers per plane and slice (the same nodes and weights, combined in the
 * same order as gbil: bit-identical). */
A2 void volux_lightvol_pos_tau_avx2(const lv_sweep *J, const lv_pos_row *R) {
    const int mu = J->mu, np = J->nplanes;
    const size_t area = J->area, ms = R->ms;
    const __m256 lane = _mm256_setr_ps(0, 1, 2, 3, 4, 5, 6, 7);
    for (int i = 0; i < R->n; i++) {
        const float t = R->tt[i], om = 1.0f - t;
        const __m256 vom = _mm256_set1_ps(om), vt = _mm256_set1_ps(t), ayi = _mm256_set1_ps(R->ay[i]),
                     winv = _mm256_set1_ps(R->inv_n);
        const __m256i jv = _mm256_set1_epi32(R->jrow[i]);
        for (int u = R->u0; u < R->u1; u += 8) {
            /* lanes past the interior copy lane 0 (their results are not used) */
            const __m256i mki = lane_mask(R->u1 - u);
            __m256 uf = _mm256_add_ps(_mm256_set1_ps((float)u), lane);
            __m256 Xv = _mm256_loadu_ps(R->X + u), Lv = _mm256_loadu_ps(R->LEN + u);
            __m256 px = _mm256_add_ps(uf, _mm256_mul_ps(_mm256_sub_ps(Xv, uf), vom));
            pos_tap P;
            pos_tap_init(&P, px, jv, ayi, mu, mki);
            __m256 wp = _mm256_mul_ps(_mm256_mul_ps(vom, Lv), winv), wc = _mm256_mul_ps(_mm256_mul_ps(vt, Lv), winv);
            if (J->post) {
                __m256 sp = pos_tap_val(&P, J->mp, mu), sc = pos_tap_val(&P, J->mc, mu);
                __m256 s = _mm256_fmadd_ps(_mm256_sub_ps(sc, sp), vt, sp), m[4];
                if (J->forward) lut_kappa8(J, s, m);
                else m[0] = lut_sigma8(J->lut, s);
                __m256 l = _mm256_add_ps(wp, wc);
                for (int q = 0; q < np; q++) {
                    float *d = R->TAU + (size_t)q * ms + (size_t)u;
                    _mm256_storeu_ps(d, _mm256_fmadd_ps(l, m[q], _mm256_loadu_ps(d)));
                }
                continue;
            }
            for (int q = 0; q < np; q++) {
                __m256 x = pos_tap_val(&P, J->mp + (size_t)q * area, mu);
                __m256 y = pos_tap_val(&P, J->mc + (size_t)q * area, mu);
                float *d = R->TAU + (size_t)q * ms + (size_t)u;
                _mm256_storeu_ps(d, _mm256_add_ps(_mm256_loadu_ps(d), _mm256_fmadd_ps(wp, x, _mm256_mul_ps(wc, y))));
            }
        }
    }
}

A2 void volux_lightvol_pos_light_avx2(const lv_sweep *J, const lv_entry *e, const lv_pos_row *R, float *const out[3],
                                      float *acc, size_t m, int ch) {
    const lightvol_state *st = J->st;
    const int mu = J->mu, mv = J->mv, a = J->a, au = J->au, av = J->av;
    const size_t ms = R->ms;
    const int forward = J->forward && !R->empty, cone = J->cone && !R->empty;
    const __m256 ayc = _mm256_set1_ps(R->ayc), yv = _mm256_set1_ps(R->y), q4 = _mm256_set1_ps(0.25f),
                 tanc = _mm256_set1_ps(J->tan_c), isu = _mm256_set1_ps(1.0f / st->spacing[au]),
                 isv = _mm256_set1_ps(1.0f / st->spacing[av]);
    const float *Rd[3] = {e->rd[0], e->rd[1], e->rd[2]};
    float *ad[3] = {acc + 3 * m, acc + 4 * m, acc + 5 * m};
    float *dx = ad[a], *dy = ad[au], *dz = ad[av];
    const int one = e->nch == 1;
    const __m256 g[3] = {_mm256_set1_ps(e->gain[0]), _mm256_set1_ps(e->gain[1]), _mm256_set1_ps(e->gain[2])};
    const __m256 lg = _mm256_set1_ps(0.2126f * e->gain[0] + 0.7152f * e->gain[1] + 0.0722f * e->gain[2]);
    for (int u = R->u0; u < R->u1; u += 8) {
        const int full = u + 8 <= R->u1;
        const __m256i mki = lane_mask(R->u1 - u);
        const __m256 mk = _mm256_castsi256_ps(mki);
        __m256 Xv = _mm256_and_ps(_mm256_loadu_ps(R->X + u), mk); /* masked lanes: cell 0 */
        const __m256i jcv = _mm256_set1_epi32(R->jc);
        pos_tap P;
        pos_tap_init(&P, Xv, jcv, ayc, mu, mki);
        __m256 T = volux_exp_neg_cw7_avx2(_mm256_loadu_ps(R->TAU + u)), K = _mm256_loadu_ps(R->K + u);
        if (one) {
            /* no forward scattering: one channel, accumulated as gain·value */
            __m256 o = _mm256_mul_ps(T, pos_tap_val(&P, Rd[0], mu)), ok = _mm256_mul_ps(o, K);
            st8(out[0] + u, o, full, mki);
            for (int c = 0; c < 3; c++) acc_add(acc + (size_t)c * m + (size_t)u, g[c], ok, full, mki);
            if (ch == 6) {
                __m256 lum = _mm256_mul_ps(lg, ok);
                acc_add(dx + u, _mm256_loadu_ps(R->WA + u), lum, full, mki);
                acc_add(dy + u, _mm256_loadu_ps(R->WU + u), lum, full, mki);
                acc_add(dz + u, _mm256_loadu_ps(R->WV + u), lum, full, mki);
            }
            continue;
        }
        __m256 o[3];
        for (int c = 0; c < 3; c++) o[c] = pos_tap_val(&P, Rd[c], mu);
        if (forward) {
            __m256 Tc[3];
            for (int c = 0; c < 3; c++) Tc[c] = volux_exp_neg_cw7_avx2(_mm256_loadu_ps(R->TAU + (size_t)(1 + c) * ms + u));
            if (cone) {
                /* 4 taps at ±ρ/√2 along u and v, ρ = len·tan(cone) (fetch() inside the slice) */
                __m256 rho = _mm256_mul_ps(_mm256_loadu_ps(R->LEN + u), tanc);
                __m256 ru = _mm256_and_ps(_mm256_mul_ps(rho, isu), mk), rv = _mm256_and_ps(_mm256_mul_ps(rho, isv), mk);
                __m256 s3[3] = {_mm256_setzero_ps(), _mm256_setzero_ps(), _mm256_setzero_ps()};
                for (int q = 0; q < 4; q++) {
                    __m256 x = q == 0 ? _mm256_add_ps(Xv, ru) : q == 1 ? _mm256_sub_ps(Xv, ru) : Xv;
                    __m256 yq = q == 2 ? _mm256_add_ps(yv, rv) : q == 3 ? _mm256_sub_ps(yv, rv) : yv;
                    /* per-lane row: j = min((int)y, mv − 2) */
                    __m256i jq = _mm256_min_epi32(_mm256_cvttps_epi32(yq), _mm256_set1_epi32(mv - 2));
                    __m256 ay = _mm256_sub_ps(yq, _mm256_cvtepi32_ps(jq));
                    pos_tap Q;
                    pos_tap_init(&Q, x, jq, ay, mu, mki);
                    for (int c = 0; c < 3; c++) s3[c] = _mm256_fmadd_ps(q4, pos_tap_val(&Q, Rd[c], mu), s3[c]);
                }
                for (int c = 0; c < 3; c++)
                    o[c] = _mm256_fmadd_ps(T, o[c], _mm256_mul_ps(_mm256_sub_ps(Tc[c], T), s3[c]));
            } else {
                for (int c = 0; c < 3; c++) o[c] = _mm256_mul_ps(Tc[c], o[c]);
            }
        } else {
            for (int c = 0; c < 3; c++) o[c] = _mm256_mul_ps(T, o[c]);
        }
        for (int c = 0; c < 3; c++) {
            st8(out[c] + u, o[c], full, mki);
            acc_add(acc + (size_t)c * m + (size_t)u, K, o[c], full, mki);
        }
        if (ch == 6) {
            __m256 lum = _mm256_mul_ps(_mm256_set1_ps(0.2126f), o[0]);
            lum = _mm256_fmadd_ps(_mm256_set1_ps(0.7152f), o[1], lum);
            lum = _mm256_mul_ps(_mm256_fmadd_ps(_mm256_set1_ps(0.0722f), o[2], lum), K);
            acc_add(dx + u, _mm256_loadu_ps(R->WA + u), lum, full, mki);
            acc_add(dy + u, _mm256_loadu_ps(R->WU + u), lum, full, mki);
            acc_add(dz + u, _mm256_loadu_ps(R->WV + u), lum, full, mki);
        }
    }
}

#else /* not x86-64 GCC/Clang: the portable loops only */

void volux_lightvol_dir_light_avx512(const lv_sweep *J, const lv_entry *e, int v, int u0, int u1, const float *T,
                                     float *const Tc[3], int empty, float *const out[3], float *acc, size_t m, int ch,
                                     float *S) {
    (void)J, (void)e, (void)v, (void)u0, (void)u1, (void)T, (void)Tc, (void)empty, (void)out, (void)acc, (void)m,
        (void)ch, (void)S;
}
void volux_lightvol_dir_tau_avx2(const lv_sweep *J, const lv_entry *e, int v, int u0, int u1, float *const tau[4]) {
    (void)J, (void)e, (void)v, (void)u0, (void)u1, (void)tau;
}
void volux_lightvol_exp_avx2(float *T, const float *tau, int n) { (void)T, (void)tau, (void)n; }
void volux_lightvol_dir_light_avx2(const lv_sweep *J, const lv_entry *e, int v, int u0, int u1, const float *T,
                                   float *const Tc[3], int empty, float *const out[3], float *acc, size_t m, int ch,
                                   float *S) {
    (void)J, (void)e, (void)v, (void)u0, (void)u1, (void)T, (void)Tc, (void)empty, (void)out, (void)acc, (void)m,
        (void)ch, (void)S;
}
void volux_lightvol_pos_geometry_avx2(const lv_sweep *J, const lv_entry *e, lv_pos_row *R) { (void)J, (void)e, (void)R; }
void volux_lightvol_pos_tau_avx2(const lv_sweep *J, const lv_pos_row *R) { (void)J, (void)R; }
void volux_lightvol_pos_light_avx2(const lv_sweep *J, const lv_entry *e, const lv_pos_row *R, float *const out[3],
                                   float *acc, size_t m, int ch) {
    (void)J, (void)e, (void)R, (void)out, (void)acc, (void)m, (void)ch;
}

#endif
