/*
 * render/denoise.c — the denoiser of volux/denoise.h.
 *
 *   1. Variance of each raw pixel mean's luminance: the accumulation's own
 *      (sample variance / spp) from 4 samples on, else the variance of the
 *      luminance over the 7×7 pixels around it whose features match (SVGF
 *      §4.2's spatial estimate for a short history).
 *   2. Edge-avoiding à-trous levels i = 0 … levels−1 (Dammertz et al.
 *      2010, with 3×3 taps of (1, 2, 1)/4 instead of their 5×5 B3 spline,
 *      spaced 2^i apart), each weighted by
 *        w = h · exp(−|l_p − l_q| / (σ_l·√g(var_p) + ε)       (SVGF Eq. 5)
 *                    − Σ_f |f_p − f_q|² / σ_f²)               (Dammertz Eq. 7)
 *      with l the luminance at this level, g a 3×3 Gaussian of its
 *      variance and f the guides (coverage, depth / depth range, albedo,
 *      normal; depth, albedo and normal only where both rays can collide);
 *      the variance is carried through the levels with the squared weights
 *      (SVGF Eq. 3).
 *   3. Blend by the error: out = raw + α·(filtered − raw), α = var/(var +
 *      b²), var the raw variance after the 3×3 Gaussian (a pixel whose few
 *      samples happened to agree does not claim zero error), b² = (5×5
 *      mean of l_filtered − l_raw)² − (5×5 sum of var)/25² — an estimate
 *      of the filter's squared bias: the bias is smooth and the raw noise
 *      is not, so the window's mean difference keeps the one and has 1/25
 *      of the other's variance, which is taken off (squaring each pixel's
 *      difference first gave a bias estimate as noisy as the image and
 *      cost 1.3–1.7× in rel_mse on bonsai at 4–16 spp) — so each pixel takes the one of the two with the smaller
 *      estimated error, smoothly (inverse-MSE weights); then the change is
 *      scaled to stay within VOLUX_DENOISE_BAND standard errors of raw.
 *
 * Every phase reads the previous one's buffers only (ping-pong), rows are
 * the parallel items, so the result is independent of the thread count.
 */
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "core/context_internal.h"
#include "core/parallel.h"
#include "core/simd.h"
#include "volux/denoise.h"

#define GUIDES 8 /* coverage, depth, albedo ×3, normal ×3 (scaled by 1/σ) */
#define SCRATCH 8 /* per-thread row arrays */

/* Everything in planes (one float per pixel per quantity), so the tap
 * loops run along a row over contiguous memory and vectorise. */
struct dn_tap;

typedef struct dn_job {
    int w, h, levels, spatial, blend;
    float sigma_l;
    float *raw[3];        /* the raw mean                                 */
    const float *var_in;  /* the accumulation's variance (may be < 0)     */
    float *guide[GUIDES]; /* pre-scaled guides                            */
    float *hit;           /* 1: the ray can collide (coverage > 0), else 0 */
    float *col[2][3];     /* ping-pong colour                             */
    float *var[2];        /* ping-pong variance                           */
    float *var0;          /* the raw pixel's variance (after step 1)      */
    float *vb0;           /* its 3×3 Gaussian                             */
    float *bias;          /* max(0, Δl² − vb0) per pixel                  */
    float *scratch;       /* SCRATCH·w per thread                         */
    float *out;           /* 3 per pixel, interleaved                     */
    void (*tap)(const struct dn_tap *, int, int); /* the CPU's tap kernel */
} dn_job;

/* exp(x) for x ≤ 0 within 2e-3 relative (weights need no more): 2^k by the
 * exponent bits, 2^f by a cubic on [0, 1). Branch-free (no floorf: y ≤ 0,
 * so truncation rounds up and one compare corrects it), so the tap loops
 * vectorise with plain SSE2. */
static inline float exp_neg(float x) {
    float y = x * 1.44269504f;
    y = y < -126.0f ? -126.0f : y;
    int32_t k = (int32_t)y;
    k -= (float)k > y;
    float f = y - (float)k;
    float p = 1.0f + f * (0.6958160f + f * (0.2260238f + f * 0.0781026f));
    int32_t bits = (k + 127) * (1 << 23);
    float two_k;
    memcpy(&two_k, &bits, sizeof two_k);
    return p * two_k;
}

/* The first and one-past-last x of a row whose neighbour at x + ox exists. */
static inline void tap_span(int w, int ox, int *xs, int *xe) {
    *xs = ox < 0 ? -ox : 0;
    *xe = ox > 0 ? w - ox : w;
}

/* Squared guide distance of pixels p (row arrays at x) and q: coverage
 * always; depth, albedo, normal only when both rays can collide; a pair
 * where only one can is an edge (+16: weight e^-16). */
#define GUIDE_DIST(j, p, q, x)                                                                                          \
    ({                                                                                                                 \
        float d0_ = (j)->guide[0][(p) + (x)] - (j)->guide[0][(q) + (x)], dg_ = 0.0f;                                   \
        for (int k_ = 1; k_ < GUIDES; k_++) {                                                                          \
            float e_ = (j)->guide[k_][(p) + (x)] - (j)->guide[k_][(q) + (x)];                                          \
            dg_ += e_ * e_;                                                                                            \
        }                                                                                                              \
        float hp_ = (j)->hit[(p) + (x)], hq_ = (j)->hit[(q) + (x)];                                                    \
        d0_ *d0_ + hp_ * hq_ * dg_ + 16.0f * (hp_ - hq_) * (hp_ - hq_);                                                \
    })

/* Phase 0, row y: the raw pixel variances (step 1). */
static void variance_row(dn_job *j, int y, float *sc) {
    int w = j->w;
    size_t row = (size_t)y * (size_t)w;
    float *out = j->var[0] + row;
    if (!j->spatial) {
        for (int x = 0; x < w; x++) out[x] = j->var_in[row + (size_t)x];
        int any_unknown = 0;
        for (int x = 0; x < w; x++) any_unknown |= !(out[x] >= 0.0f);
        if (!any_unknown) return;
    }
    /* The variance of the luminance over the 7×7 neighbours whose guides
     * are within one σ (SVGF §4.2 for a short history). */
    float *s1 = sc, *s2 = sc + w, *cnt = sc + 2 * w;
    for (int x = 0; x < w; x++) s1[x] = s2[x] = cnt[x] = 0.0f;
    for (int dy = -3; dy <= 3; dy++) {
        int yy = y + dy;
        if (yy < 0 || yy >= j->h) continue;
        for (int dx = -3; dx <= 3; dx++) {
            int xs, xe;
            tap_span(w, dx, &xs, &xe);
            size_t q = (size_t)yy * (size_t)w + (size_t)(ptrdiff_t)dx;
            for (int x = xs; x < xe; x++) {
                float d = GUIDE_DIST(j, row, q, (size_t)x);
                float m = d <= 1.0f ? 1.0f : 0.0f;
                float l = 0.2126f * j->raw[0][q + (size_t)x] + 0.7152f * j->raw[1][q + (size_t)x] +
                          0.0722f * j->raw[2][q + (size_t)x];
                s1[x] += m * l, s2[x] += m * l * l, cnt[x] += m;
            }
        }
    }
    for (int x = 0; x < w; x++) {
        if (!j->spatial && out[x] >= 0.0f) continue;
        float n = cnt[x];
        out[x] = n > 1.0f ? fmaxf(0.0f, (s2[x] - s1[x] * s1[x] / n) / (n - 1.0f)) : 0.0f;
    }
}

/* 3×3 Gaussian (1, 2, 1)/4 ⊗ (1, 2, 1)/4 of plane v along row y into out,
 * borders replicated (SVGF's prefilter of the luminance weight). */
static void blur_row(const dn_job *j, const float *v, int y, float *out) {
    int w = j->w;
    const float *r0 = v + (size_t)(y > 0 ? y - 1 : y) * (size_t)w, *r1 = v + (size_t)y * (size_t)w,
                *r2 = v + (size_t)(y < j->h - 1 ? y + 1 : y) * (size_t)w;
    for (int x = 0; x < w; x++) {
        int a = x > 0 ? x - 1 : x, b = x < w - 1 ? x + 1 : x;
        float c0 = r0[a] + 2.0f * r0[x] + r0[b], c1 = r1[a] + 2.0f * r1[x] + r1[b], c2 = r2[a] + 2.0f * r2[x] + r2[b];
        out[x] = (c0 + 2.0f * c1 + c2) * (1.0f / 16.0f);
    }
}

/* One tap of an à-trous level along a row: the pixels p of the row and
 * their neighbours q (pointers already offset by the tap). */
typedef struct dn_tap {
    const float *p[GUIDES], *hp, *lp, *inv;        /* this row             */
    const float *g[GUIDES], *hq, *q0, *q1, *q2, *qv; /* the neighbours      */
    float *sw, *sv, *s0, *s1, *s2;                  /* the sums (distinct)  */
    float hw;                                       /* the tap's weight     */
} dn_tap;

/* Pixels xs … xe−1 of one tap, one at a time. Every kernel computes each
 * pixel with exactly these operations in this order (no FMA), so all give
 * the same bits. */
static inline __attribute__((always_inline)) void tap_pixels(const dn_tap *t, int xs, int xe) {
    const float *restrict p0 = t->p[0], *restrict p1 = t->p[1], *restrict p2 = t->p[2], *restrict p3 = t->p[3],
                          *restrict p4 = t->p[4], *restrict p5 = t->p[5], *restrict p6 = t->p[6],
                          *restrict p7 = t->p[7], *restrict hp = t->hp, *restrict lp = t->lp,
                          *restrict inv = t->inv;
    const float *restrict g0 = t->g[0], *restrict g1 = t->g[1], *restrict g2 = t->g[2], *restrict g3 = t->g[3],
                          *restrict g4 = t->g[4], *restrict g5 = t->g[5], *restrict g6 = t->g[6],
                          *restrict g7 = t->g[7], *restrict hq = t->hq, *restrict q0 = t->q0,
                          *restrict q1 = t->q1, *restrict q2 = t->q2, *restrict qv = t->qv;
    float *restrict sw = t->sw, *restrict sv = t->sv, *restrict s0 = t->s0, *restrict s1 = t->s1,
                    *restrict s2 = t->s2;
    float hw = t->hw;
    /* the sums are distinct scratch rows (GCC's alias versioning gives up
     * on this many streams) */
#pragma GCC ivdep
    for (int x = xs; x < xe; x++) {
        float lq = 0.2126f * q0[x] + 0.7152f * q1[x] + 0.0722f * q2[x];
        float e0 = p0[x] - g0[x], e1 = p1[x] - g1[x], e2 = p2[x] - g2[x], e3 = p3[x] - g3[x], e4 = p4[x] - g4[x],
              e5 = p5[x] - g5[x], e6 = p6[x] - g6[x], e7 = p7[x] - g7[x];
        float dg = e1 * e1 + e2 * e2 + e3 * e3 + e4 * e4 + e5 * e5 + e6 * e6 + e7 * e7;
        float hm = hp[x] - hq[x];
        /* the guide distance: coverage always; depth, albedo, normal where
         * both rays can collide; +16 where only one can (an edge) */
        float e = fabsf(lp[x] - lq) * inv[x] + e0 * e0 + hp[x] * hq[x] * dg + 16.0f * hm * hm;
        float wq = hw * exp_neg(-e);
        sw[x] += wq;
        sv[x] += wq * wq * qv[x];
        s0[x] += wq * q0[x], s1[x] += wq * q1[x], s2[x] += wq * q2[x];
    }
}

/* Baseline x86-64: GCC vectorises tap_pixels with SSE2 here (4 lanes). */
static void tap_portable(const dn_tap *t, int xs, int xe) { tap_pixels(t, xs, xe); }

#if VOLUX_X86_GNUC
/* Eight lanes by hand: GCC 12 does not vectorise the loop for AVX2 ("no
 * vectype"). The same operations as tap_pixels, lane by lane. */
__attribute__((target("avx2"))) static void tap_avx2(const dn_tap *t, int xs, int xe) {
    const __m256 cr = _mm256_set1_ps(0.2126f), cg = _mm256_set1_ps(0.7152f), cb = _mm256_set1_ps(0.0722f);
    const __m256 sign = _mm256_set1_ps(-0.0f), sixteen = _mm256_set1_ps(16.0f), hw = _mm256_set1_ps(t->hw);
    const __m256 log2e = _mm256_set1_ps(1.44269504f), lo = _mm256_set1_ps(-126.0f), one = _mm256_set1_ps(1.0f);
    const __m256 k1 = _mm256_set1_ps(0.6958160f), k2 = _mm256_set1_ps(0.2260238f), k3 = _mm256_set1_ps(0.0781026f);
    int x = xs;
    for (; x + 8 <= xe; x += 8) {
        __m256 q0 = _mm256_loadu_ps(t->q0 + x), q1 = _mm256_loadu_ps(t->q1 + x), q2 = _mm256_loadu_ps(t->q2 + x);
        __m256 lq = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(cr, q0), _mm256_mul_ps(cg, q1)), _mm256_mul_ps(cb, q2));
        __m256 e0 = _mm256_sub_ps(_mm256_loadu_ps(t->p[0] + x), _mm256_loadu_ps(t->g[0] + x)), dg = _mm256_setzero_ps();
        for (int k = 1; k < GUIDES; k++) {
            __m256 ek = _mm256_sub_ps(_mm256_loadu_ps(t->p[k] + x), _mm256_loadu_ps(t->g[k] + x));
            dg = k == 1 ? _mm256_mul_ps(ek, ek) : _mm256_add_ps(dg, _mm256_mul_ps(ek, ek));
        }
        __m256 hp = _mm256_loadu_ps(t->hp + x), hq = _mm256_loadu_ps(t->hq + x), hm = _mm256_sub_ps(hp, hq);
        __m256 dl = _mm256_andnot_ps(sign, _mm256_sub_ps(_mm256_loadu_ps(t->lp + x), lq));
        __m256 e = _mm256_add_ps(_mm256_mul_ps(dl, _mm256_loadu_ps(t->inv + x)), _mm256_mul_ps(e0, e0));
        e = _mm256_add_ps(e, _mm256_mul_ps(_mm256_mul_ps(hp, hq), dg));
        e = _mm256_add_ps(e, _mm256_mul_ps(_mm256_mul_ps(sixteen, hm), hm));
        /* exp_neg(−e), step by step */
        __m256 y = _mm256_mul_ps(_mm256_xor_ps(e, sign), log2e);
        y = _mm256_blendv_ps(y, lo, _mm256_cmp_ps(y, lo, _CMP_LT_OQ));
        __m256i k = _mm256_cvttps_epi32(y);
        k = _mm256_add_epi32(k, _mm256_castps_si256(_mm256_cmp_ps(_mm256_cvtepi32_ps(k), y, _CMP_GT_OQ)));
        __m256 f = _mm256_sub_ps(y, _mm256_cvtepi32_ps(k));
        __m256 poly = _mm256_add_ps(k2, _mm256_mul_ps(f, k3));
        poly = _mm256_add_ps(k1, _mm256_mul_ps(f, poly));
        poly = _mm256_add_ps(one, _mm256_mul_ps(f, poly));
        __m256 two_k = _mm256_castsi256_ps(_mm256_slli_epi32(_mm256_add_epi32(k, _mm256_set1_epi32(127)), 23));
        __m256 wq = _mm256_mul_ps(hw, _mm256_mul_ps(poly, two_k));
        _mm256_storeu_ps(t->sw + x, _mm256_add_ps(_mm256_loadu_ps(t->sw + x), wq));
        __m256 vq = _mm256_mul_ps(_mm256_mul_ps(wq, wq), _mm256_loadu_ps(t->qv + x));
        _mm256_storeu_ps(t->sv + x, _mm256_add_ps(_mm256_loadu_ps(t->sv + x), vq));
        _mm256_storeu_ps(t->s0 + x, _mm256_add_ps(_mm256_loadu_ps(t->s0 + x), _mm256_mul_ps(wq, q0)));
        _mm256_storeu_ps(t->s1 + x, _mm256_add_ps(_mm256_loadu_ps(t->s1 + x), _mm256_mul_ps(wq, q1)));
        _mm256_storeu_ps(t->s2 + x, _mm256_add_ps(_mm256_loadu_ps(t->s2 + x), _mm256_mul_ps(wq, q2)));
    }
    tap_pixels(t, x, xe);
}
#endif

/* À-trous level `level`, row y: col/var[level & 1] → [(level + 1) & 1].
 * 3×3 taps of (1, 2, 1)/4 per axis, 2^level apart: the B3 spline's 5×5
 * of Dammertz et al. costs 25/9 as much for a footprint that, over five
 * levels, is as wide (±31 pixels). */
static void atrous_row(dn_job *j, int level, int y, float *sc) {
    static const float hk[3] = {0.25f, 0.5f, 0.25f};
    int w = j->w, step = 1 << level, in = level & 1, ou = (level + 1) & 1;
    size_t row = (size_t)y * (size_t)w;
    float *lp = sc, *inv = sc + w;
    const float *c0 = j->col[in][0], *c1 = j->col[in][1], *c2 = j->col[in][2], *vin = j->var[in];
    dn_tap t = {.hp = j->hit + row, .lp = lp, .inv = inv, .sw = sc + 2 * w, .sv = sc + 3 * w,
                .s0 = sc + 4 * w, .s1 = sc + 5 * w, .s2 = sc + 6 * w};
    blur_row(j, vin, y, inv);
    for (int x = 0; x < w; x++) {
        size_t p = row + (size_t)x;
        lp[x] = 0.2126f * c0[p] + 0.7152f * c1[p] + 0.0722f * c2[p];
        /* ε: 1e-4 of the pixel's luminance keeps converged and noise-free
         * pixels (background) from dividing by zero while still stopping
         * at any visible difference. */
        inv[x] = 1.0f / (j->sigma_l * sqrtf(inv[x]) + 1e-4f * fabsf(lp[x]) + 1e-12f);
        t.sw[x] = t.sv[x] = t.s0[x] = t.s1[x] = t.s2[x] = 0.0f;
    }
    for (int k = 0; k < GUIDES; k++) t.p[k] = j->guide[k] + row;
    for (int dy = -1; dy <= 1; dy++) {
        int yy = y + dy * step;
        if (yy < 0 || yy >= j->h) continue;
        for (int dx = -1; dx <= 1; dx++) {
            int ox = dx * step, xs, xe;
            tap_span(w, ox, &xs, &xe);
            size_t q = (size_t)yy * (size_t)w + (size_t)(ptrdiff_t)ox;
            t.hw = hk[dx + 1] * hk[dy + 1];
            t.q0 = c0 + q, t.q1 = c1 + q, t.q2 = c2 + q, t.qv = vin + q, t.hq = j->hit + q;
            for (int k = 0; k < GUIDES; k++) t.g[k] = j->guide[k] + q;
            j->tap(&t, xs, xe);
        }
    }
    float *o0 = j->col[ou][0] + row, *o1 = j->col[ou][1] + row, *o2 = j->col[ou][2] + row, *ov = j->var[ou] + row;
    for (int x = 0; x < w; x++) {
        /* sw ≥ 1/4 · exp(0): the centre tap is always in. */
        float r = 1.0f / t.sw[x];
        o0[x] = t.s0[x] * r, o1[x] = t.s1[x] * r, o2[x] = t.s2[x] * r;
        ov[x] = t.sv[x] * r * r;
    }
}

/* Blend phase 1, row y: the raw variance's blur and the bias estimate. */
static void bias_row(dn_job *j, int y) {
    int w = j->w, f = j->levels & 1;
    size_t row = (size_t)y * (size_t)w;
    blur_row(j, j->var0, y, j->vb0 + row);
    for (int x = 0; x < w; x++) {
        size_t p = row + (size_t)x;
        float d = 0.2126f * (j->col[f][0][p] - j->raw[0][p]) + 0.7152f * (j->col[f][1][p] - j->raw[1][p]) +
                  0.0722f * (j->col[f][2][p] - j->raw[2][p]);
        j->bias[p] = d; /* signed: averaged over 5×5 before squaring */
    }
}

/* Blend phase 2, row y: the output. */
static void blend_row(dn_job *j, int y, float *sc) {
    int w = j->w, f = j->levels & 1;
    size_t row = (size_t)y * (size_t)w;
    float *b2 = sc, *cnt = sc + w, *mv = sc + 2 * w;
    for (int x = 0; x < w; x++) b2[x] = cnt[x] = mv[x] = 0.0f;
    for (int dy = -2; dy <= 2; dy++) {
        int yy = y + dy;
        if (yy < 0 || yy >= j->h) continue;
        for (int dx = -2; dx <= 2; dx++) {
            int xs, xe;
            tap_span(w, dx, &xs, &xe);
            const float *bq = j->bias + (size_t)yy * (size_t)w + (size_t)(ptrdiff_t)dx,
                        *vq = j->var0 + (size_t)yy * (size_t)w + (size_t)(ptrdiff_t)dx;
            for (int x = xs; x < xe; x++) b2[x] += bq[x], mv[x] += vq[x], cnt[x] += 1.0f;
        }
    }
    for (int x = 0; x < w; x++) {
        size_t p = row + (size_t)x;
        float r[3] = {j->raw[0][p], j->raw[1][p], j->raw[2][p]};
        float fl[3] = {j->col[f][0][p], j->col[f][1][p], j->col[f][2][p]};
        float *o = &j->out[3 * p];
        if (!j->blend) {
            o[0] = fl[0], o[1] = fl[1], o[2] = fl[2];
            continue;
        }
        /* The bias is smooth, the raw noise is not: the mean difference
         * over the 5×5 window keeps the bias and has 1/n of the variance,
         * which is taken off its square. */
        float md = b2[x] / cnt[x], v = j->vb0[p], bb = fmaxf(0.0f, md * md - mv[x] / (cnt[x] * cnt[x]));
        float a = v > 0.0f ? v / (v + bb) : 0.0f;
        float d[3] = {a * (fl[0] - r[0]), a * (fl[1] - r[1]), a * (fl[2] - r[2])};
        /* Within VOLUX_DENOISE_BAND standard errors of the raw mean. */
        float dl = fabsf(0.2126f * d[0] + 0.7152f * d[1] + 0.0722f * d[2]), band = VOLUX_DENOISE_BAND * sqrtf(v);
        float sc2 = dl > band ? band / dl : 1.0f;
        for (int c = 0; c < 3; c++) o[c] = r[c] + sc2 * d[c];
    }
}

/* Phases: 0 variance; 1 … levels à-trous; levels + 1 bias; levels + 2 blend. */
typedef struct dn_phase {
    dn_job *j;
    int phase;
} dn_phase;

static int64_t phase_begin(void *user, int phase) {
    dn_phase *ph = user;
    dn_job *j = ph->j;
    ph->phase = phase;
    if (phase == 1) memcpy(j->var0, j->var[0], (size_t)j->w * (size_t)j->h * sizeof(float));
    return j->h;
}

static void phase_item(void *user, int64_t index, int thread) {
    dn_phase *ph = user;
    dn_job *j = ph->j;
    int y = (int)index, phase = ph->phase;
    float *sc = j->scratch + (size_t)thread * SCRATCH * (size_t)j->w;
    if (phase == 0) variance_row(j, y, sc);
    else if (phase <= j->levels) atrous_row(j, phase - 1, y, sc);
    else if (phase == j->levels + 1) bias_row(j, y);
    else blend_row(j, y, sc);
}

volux_status volux_denoise(volux_context *ctx, const volux_image *color, const volux_features *guide, uint32_t spp,
                           const volux_denoise_settings *settings, volux_image *out) {
    memset(out, 0, sizeof *out);
    if (!color || !color->rgb || !guide || !guide->variance)
        return volux_error(ctx, VOLUX_ERR_INVALID, "denoise: the colour image and the variance are required");
    if (guide->width != color->width || guide->height != color->height)
        return volux_error(ctx, VOLUX_ERR_INVALID, "denoise: the guides are %dx%d but the image is %dx%d",
                           guide->width, guide->height, color->width, color->height);
    volux_denoise_settings s = {0};
    if (settings) s = *settings;
    if (s.levels <= 0) s.levels = 5;
    if (s.levels > 10) s.levels = 10;
    if (!(s.sigma_color > 0.0f)) s.sigma_color = 4.0f;
    if (!(s.sigma_depth > 0.0f)) s.sigma_depth = 0.1f;
    if (!(s.sigma_albedo > 0.0f)) s.sigma_albedo = 0.3f;
    if (!(s.sigma_normal > 0.0f)) s.sigma_normal = 2.0f;
    if (!(s.sigma_coverage > 0.0f)) s.sigma_coverage = 0.1f;
    int w = color->width, h = color->height;
    size_t n = (size_t)w * (size_t)h;
    int threads = s.threads > 0 ? s.threads : volux_context_threads(ctx);
    if (threads <= 0) threads = volux_parallel_max_threads();
    volux_status st = volux_image_create(ctx, w, h, out);
    if (st) return st;
    dn_job j;
    memset(&j, 0, sizeof j);
    j.w = w, j.h = h, j.levels = s.levels, j.spatial = spp < 4, j.sigma_l = s.sigma_color, j.blend = !s.no_blend;
    j.var_in = guide->variance;
    j.tap = tap_portable;
#if VOLUX_X86_GNUC
    if (!s.portable && volux_cpu_has_avx2()) j.tap = tap_avx2;
#endif
    j.out = out->rgb;
    /* One block: 3 raw + 8 guides + hit + 6 colour + 2 variance + var0,
     * vb0, bias = 23 planes, then the threads' scratch rows. */
    enum { PLANES = 23 };
    size_t total = PLANES * n + (size_t)threads * SCRATCH * (size_t)w;
    float *block = volux_calloc(ctx, total, sizeof(float));
    if (!block) {
        volux_image_free(ctx, out);
        return volux_error(ctx, VOLUX_ERR_NOMEM, "denoise: out of memory for a %dx%d image", w, h);
    }
    float *b = block;
    for (int c = 0; c < 3; c++, b += n) j.raw[c] = b;
    for (int k = 0; k < GUIDES; k++, b += n) j.guide[k] = b;
    j.hit = b, b += n;
    for (int i = 0; i < 2; i++)
        for (int c = 0; c < 3; c++, b += n) j.col[i][c] = b;
    j.var[0] = b, b += n;
    j.var[1] = b, b += n;
    j.var0 = b, b += n;
    j.vb0 = b, b += n;
    j.bias = b, b += n;
    j.scratch = b;
    for (size_t p = 0; p < n; p++)
        for (int c = 0; c < 3; c++) j.raw[c][p] = j.col[0][c][p] = color->rgb[3 * p + (size_t)c];
    /* The guides, scaled by 1/σ so a squared distance of 1 is "one σ". */
    if (guide->coverage && guide->depth && guide->albedo && guide->normal) {
        float zmin = INFINITY, zmax = -INFINITY;
        for (size_t p = 0; p < n; p++)
            if (guide->coverage[p] > 0.0f && isfinite(guide->depth[p])) {
                zmin = fminf(zmin, guide->depth[p]);
                zmax = fmaxf(zmax, guide->depth[p]);
            }
        float zs = zmax > zmin ? 1.0f / ((zmax - zmin) * s.sigma_depth) : 0.0f;
        for (size_t p = 0; p < n; p++) {
            j.guide[0][p] = guide->coverage[p] / s.sigma_coverage;
            if (!(guide->coverage[p] > 0.0f) || !isfinite(guide->depth[p])) continue;
            j.hit[p] = 1.0f;
            j.guide[1][p] = (guide->depth[p] - zmin) * zs;
            for (int k = 0; k < 3; k++) {
                j.guide[2 + k][p] = guide->albedo[3 * p + (size_t)k] / s.sigma_albedo;
                j.guide[5 + k][p] = guide->normal[3 * p + (size_t)k] / s.sigma_normal;
            }
        }
    }
    dn_phase ph = {&j, 0};
    volux_parallel_phases(threads, s.levels + 3, phase_begin, phase_item, &ph);
    volux_free(ctx, block, total * sizeof(float));
    return VOLUX_OK;
}
