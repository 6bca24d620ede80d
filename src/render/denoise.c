/*
 * render/denoise.c — the denoiser of volux/denoise.h.
 *
 *   1. Variance of each raw pixel mean's luminance: the accumulation's own
 *      (sample variance / spp) from 4 samples on, else the variance of the
 *      luminance over the 7×7 pixels around it whose features match (SVGF
 *      §4.2's spatial estimate for a short history).
 *   2. Edge-avoiding à-trous levels i = 0 … levels−1 (Dammertz et al.
 *      2010): 5×5 taps of the B3 spline h = (1, 4, 6, 4, 1)/16 spaced 2^i
 *      apart, each weighted by
 *        w = h · exp(−|l_p − l_q| / (σ_l·√g(var_p) + ε)       (SVGF Eq. 5)
 *                    − Σ_f |f_p − f_q|² / σ_f²)               (Dammertz Eq. 7)
 *      with l the luminance at this level, g a 3×3 Gaussian of its
 *      variance and f the guides (coverage, depth / depth range, albedo,
 *      normal; depth, albedo and normal only where both rays can collide);
 *      the variance is carried through the levels with the squared weights
 *      (SVGF Eq. 3).
 *   3. Blend by the error: out = raw + α·(filtered − raw), α = var/(var +
 *      b²), var the raw variance after the 3×3 Gaussian (a pixel whose few
 *      samples happened to agree does not claim zero error), b² the 5×5 mean of max(0, (l_filtered − l_raw)² − var) — an
 *      estimate of the filter's squared bias (the expected squared
 *      difference is bias² + var when the filtered value's own noise is
 *      small) — so each pixel takes the one of the two with the smaller
 *      estimated error, smoothly (inverse-MSE weights); then the change is
 *      scaled to stay within VOLUX_DENOISE_BAND standard errors of raw.
 *
 * Every phase reads the previous one's buffers only (ping-pong), rows are
 * the parallel items, so the result is independent of the thread count.
 */
#include <math.h>
#include <string.h>

#include "core/context_internal.h"
#include "core/parallel.h"
#include "volux/denoise.h"

#define GUIDES 8 /* coverage, depth, albedo ×3, normal ×3 (scaled by 1/σ) */

typedef struct dn_job {
    int w, h, levels, spatial;
    float sigma_l;
    const float *raw;    /* 3 per pixel                                  */
    const float *var_in; /* the accumulation's variance (may be < 0)      */
    float *guide;        /* GUIDES per pixel, pre-scaled                  */
    unsigned char *hit;  /* 1: the ray can collide (coverage > 0)        */
    float *col[2];       /* ping-pong colour, 3 per pixel                */
    float *var[2];       /* ping-pong variance                           */
    float *var0;         /* the raw pixel's variance (after step 1)      */
    float *bias;         /* max(0, Δl² − var) per pixel                  */
    float *out;          /* 3 per pixel                                  */
    int blend;
} dn_job;

static inline float lum3(const float *c) { return 0.2126f * c[0] + 0.7152f * c[1] + 0.0722f * c[2]; }

/* exp(x) for x ≤ 0 within 2e-3 relative (weights need no more): 2^k by the
 * exponent bits, 2^f by a cubic on [0, 1). Branch-free, so the tap loops
 * vectorise. */
static inline float exp_neg(float x) {
    float y = fmaxf(x * 1.44269504f, -126.0f), k = floorf(y), f = y - k;
    float p = 1.0f + f * (0.6958160f + f * (0.2260238f + f * 0.0781026f));
    union {
        float f;
        int32_t i;
    } u = {p};
    u.i += (int32_t)k << 23;
    return u.f;
}

static inline float guide_dist(const dn_job *j, size_t p, size_t q) {
    const float *a = &j->guide[GUIDES * p], *b = &j->guide[GUIDES * q];
    float d = (a[0] - b[0]) * (a[0] - b[0]);
    if (j->hit[p] && j->hit[q])
        for (int k = 1; k < GUIDES; k++) d += (a[k] - b[k]) * (a[k] - b[k]);
    else if (j->hit[p] != j->hit[q])
        d += 16.0f; /* one ray can collide, the other cannot: an edge */
    return d;
}

/* Phase 0, row y: the raw pixel variances (step 1). */
static void variance_row(dn_job *j, int y) {
    for (int x = 0; x < j->w; x++) {
        size_t p = (size_t)y * (size_t)j->w + (size_t)x;
        float v = j->var_in[p];
        if (j->spatial || !(v >= 0.0f)) {
            double s = 0.0, s2 = 0.0, n = 0.0;
            for (int dy = -3; dy <= 3; dy++)
                for (int dx = -3; dx <= 3; dx++) {
                    int xx = x + dx, yy = y + dy;
                    if (xx < 0 || yy < 0 || xx >= j->w || yy >= j->h) continue;
                    size_t q = (size_t)yy * (size_t)j->w + (size_t)xx;
                    if (guide_dist(j, p, q) > 1.0f) continue;
                    double l = lum3(&j->raw[3 * q]);
                    s += l, s2 += l * l, n += 1.0;
                }
            v = n > 1.0 ? (float)fmax(0.0, (s2 - s * s / n) / (n - 1.0)) : 0.0f;
        }
        j->var[0][p] = v;
    }
}

/* 3×3 Gaussian of the variance at p (SVGF's prefilter of the luminance
 * weight's denominator). */
static inline float var_blur(const dn_job *j, const float *var, int x, int y) {
    static const float k[3] = {0.25f, 0.5f, 0.25f};
    float s = 0.0f, ws = 0.0f;
    for (int dy = -1; dy <= 1; dy++)
        for (int dx = -1; dx <= 1; dx++) {
            int xx = x + dx, yy = y + dy;
            if (xx < 0 || yy < 0 || xx >= j->w || yy >= j->h) continue;
            float wk = k[dx + 1] * k[dy + 1];
            s += wk * var[(size_t)yy * (size_t)j->w + (size_t)xx];
            ws += wk;
        }
    return s / ws;
}

/* À-trous level `level`, row y: col/var[level & 1] → [(level + 1) & 1]. */
static void atrous_row(dn_job *j, int level, int y) {
    static const float hk[5] = {1.0f / 16, 1.0f / 4, 3.0f / 8, 1.0f / 4, 1.0f / 16};
    const float *cin = j->col[level & 1], *vin = j->var[level & 1];
    float *cout = j->col[(level + 1) & 1], *vout = j->var[(level + 1) & 1];
    int step = 1 << level;
    for (int x = 0; x < j->w; x++) {
        size_t p = (size_t)y * (size_t)j->w + (size_t)x;
        float lp = lum3(&cin[3 * p]);
        float g = var_blur(j, vin, x, y);
        /* ε: a floor of 1e-4 of the pixel's luminance keeps converged and
         * noise-free pixels (background) from dividing by zero while still
         * stopping at any visible difference. */
        float inv = 1.0f / (j->sigma_l * sqrtf(g) + 1e-4f * fabsf(lp) + 1e-12f);
        float sw = 0.0f, sw2v = 0.0f, s[3] = {0, 0, 0};
        for (int dy = -2; dy <= 2; dy++) {
            int yy = y + dy * step;
            if (yy < 0 || yy >= j->h) continue;
            for (int dx = -2; dx <= 2; dx++) {
                int xx = x + dx * step;
                if (xx < 0 || xx >= j->w) continue;
                size_t q = (size_t)yy * (size_t)j->w + (size_t)xx;
                const float *cq = &cin[3 * q];
                float e = fabsf(lp - lum3(cq)) * inv + guide_dist(j, p, q);
                float wq = hk[dx + 2] * hk[dy + 2] * exp_neg(-e);
                sw += wq;
                sw2v += wq * wq * vin[q];
                s[0] += wq * cq[0], s[1] += wq * cq[1], s[2] += wq * cq[2];
            }
        }
        /* sw ≥ h(0,0)² · 1 > 0: the centre tap always weighs exp(0). */
        float r = 1.0f / sw;
        for (int c = 0; c < 3; c++) cout[3 * p + (size_t)c] = s[c] * r;
        vout[p] = sw2v * r * r;
    }
}

/* Blend phase 1, row y: the per-pixel bias estimate. */
static void bias_row(dn_job *j, const float *filt, int y) {
    for (int x = 0; x < j->w; x++) {
        size_t p = (size_t)y * (size_t)j->w + (size_t)x;
        float d = lum3(&filt[3 * p]) - lum3(&j->raw[3 * p]);
        j->bias[p] = fmaxf(0.0f, d * d - var_blur(j, j->var0, x, y));
    }
}

/* Blend phase 2, row y: the output. */
static void blend_row(dn_job *j, const float *filt, int y) {
    for (int x = 0; x < j->w; x++) {
        size_t p = (size_t)y * (size_t)j->w + (size_t)x;
        const float *r = &j->raw[3 * p], *f = &filt[3 * p];
        float *o = &j->out[3 * p];
        if (!j->blend) {
            memcpy(o, f, 3 * sizeof(float));
            continue;
        }
        float b2 = 0.0f, n = 0.0f;
        for (int dy = -2; dy <= 2; dy++)
            for (int dx = -2; dx <= 2; dx++) {
                int xx = x + dx, yy = y + dy;
                if (xx < 0 || yy < 0 || xx >= j->w || yy >= j->h) continue;
                b2 += j->bias[(size_t)yy * (size_t)j->w + (size_t)xx];
                n += 1.0f;
            }
        b2 /= n;
        float v = var_blur(j, j->var0, x, y);
        float a = v > 0.0f ? v / (v + b2) : 0.0f;
        float d[3] = {a * (f[0] - r[0]), a * (f[1] - r[1]), a * (f[2] - r[2])};
        /* Within VOLUX_DENOISE_BAND standard errors of the raw mean. */
        float dl = fabsf(lum3(d)), band = VOLUX_DENOISE_BAND * sqrtf(v);
        float s = dl > band ? band / dl : 1.0f;
        for (int c = 0; c < 3; c++) o[c] = r[c] + s * d[c];
    }
}

/* Phases: 0 variance; 1 … levels à-trous; levels+1 the raw variance kept;
 * then bias, blend. */
static int64_t dn_begin(void *user, int phase) {
    dn_job *j = user;
    if (phase == 1) memcpy(j->var0, j->var[0], (size_t)j->w * (size_t)j->h * sizeof(float));
    return j->h;
}

typedef struct dn_phase {
    dn_job *j;
    int phase;
} dn_phase;

static int64_t phase_begin(void *user, int phase) {
    dn_phase *ph = user;
    ph->phase = phase;
    return dn_begin(ph->j, phase);
}

static void phase_item(void *user, int64_t index, int thread) {
    (void)thread;
    dn_phase *ph = user;
    dn_job *j = ph->j;
    int y = (int)index, phase = ph->phase;
    const float *filt = j->col[j->levels & 1];
    if (phase == 0) variance_row(j, y);
    else if (phase <= j->levels) atrous_row(j, phase - 1, y);
    else if (phase == j->levels + 1) bias_row(j, filt, y);
    else blend_row(j, filt, y);
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
    if (!(s.sigma_depth > 0.0f)) s.sigma_depth = 0.03f;
    if (!(s.sigma_albedo > 0.0f)) s.sigma_albedo = 0.1f;
    if (!(s.sigma_normal > 0.0f)) s.sigma_normal = 0.5f;
    if (!(s.sigma_coverage > 0.0f)) s.sigma_coverage = 0.1f;
    int w = color->width, h = color->height;
    size_t n = (size_t)w * (size_t)h;
    volux_status st = volux_image_create(ctx, w, h, out);
    if (st) return st;
    dn_job j;
    memset(&j, 0, sizeof j);
    j.w = w, j.h = h, j.levels = s.levels, j.spatial = spp < 4, j.sigma_l = s.sigma_color, j.blend = !s.no_blend;
    j.raw = color->rgb;
    j.var_in = guide->variance;
    j.out = out->rgb;
    size_t fbytes = n * sizeof(float);
    j.guide = volux_calloc(ctx, GUIDES * n, sizeof(float));
    j.hit = volux_calloc(ctx, n, 1);
    j.col[0] = volux_malloc(ctx, 3 * fbytes);
    j.col[1] = volux_malloc(ctx, 3 * fbytes);
    j.var[0] = volux_malloc(ctx, fbytes);
    j.var[1] = volux_malloc(ctx, fbytes);
    j.var0 = volux_malloc(ctx, fbytes);
    j.bias = volux_malloc(ctx, fbytes);
    if (!j.guide || !j.hit || !j.col[0] || !j.col[1] || !j.var[0] || !j.var[1] || !j.var0 || !j.bias) {
        st = volux_error(ctx, VOLUX_ERR_NOMEM, "denoise: out of memory for a %dx%d image", w, h);
        goto done;
    }
    memcpy(j.col[0], color->rgb, 3 * fbytes);
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
            float *g = &j.guide[GUIDES * p];
            g[0] = guide->coverage[p] / s.sigma_coverage;
            if (!(guide->coverage[p] > 0.0f) || !isfinite(guide->depth[p])) continue;
            j.hit[p] = 1;
            g[1] = (guide->depth[p] - zmin) * zs;
            for (int k = 0; k < 3; k++) {
                g[2 + k] = guide->albedo[3 * p + (size_t)k] / s.sigma_albedo;
                g[5 + k] = guide->normal[3 * p + (size_t)k] / s.sigma_normal;
            }
        }
    }
    int threads = s.threads > 0 ? s.threads : volux_context_threads(ctx);
    dn_phase ph = {&j, 0};
    volux_parallel_phases(threads, s.levels + 3, phase_begin, phase_item, &ph);
done:
    volux_free(ctx, j.guide, GUIDES * fbytes);
    volux_free(ctx, j.hit, n);
    volux_free(ctx, j.col[0], 3 * fbytes);
    volux_free(ctx, j.col[1], 3 * fbytes);
    volux_free(ctx, j.var[0], fbytes);
    volux_free(ctx, j.var[1], fbytes);
    volux_free(ctx, j.var0, fbytes);
    volux_free(ctx, j.bias, fbytes);
    if (st) volux_image_free(ctx, out);
    return st;
}
