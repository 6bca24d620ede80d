/*
 * volux/denoise.h — a denoiser for progressive Monte-Carlo frames.
 *
 * An edge-avoiding à-trous wavelet filter (Dammertz et al. 2010, "Edge-
 * Avoiding À-Trous Wavelet Transform for fast Global Illumination
 * Filtering") with the variance-guided luminance weight of SVGF (Schied et
 * al. 2017, "Spatiotemporal Variance-Guided Filtering", Eqs. 3–5, spatial
 * part only), guided by the first-hit features of volux/render.h
 * (coverage, depth, albedo, normal), then blended back towards the raw
 * accumulation by each pixel's estimated error: the filtered value is
 * weighted by var / (var + bias²), with var the variance of the raw pixel
 * mean and bias² the filter's estimated squared bias (the square of the
 * 5×5 mean of filtered − raw, less that mean's variance), and the result never leaves the raw value's
 * band of VOLUX_DENOISE_BAND standard errors. As samples accumulate, var
 * falls as 1/spp and the output converges to the unbiased raw image.
 *
 * DOES NOT: keep state between frames (no temporal reprojection), change
 * the framebuffer.
 */
#ifndef VOLUX_DENOISE_H
#define VOLUX_DENOISE_H

#include "base.h"
#include "image.h"
#include "render.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The output stays within raw ± this many standard errors of the raw
 * pixel mean's luminance (the colour is scaled along). */
#define VOLUX_DENOISE_BAND 3.0f

typedef struct volux_denoise_settings {
    int levels;          /* à-trous levels, step 2^i (0 = 5)                 */
    float sigma_color;   /* σ_l of SVGF's luminance weight (0 = 4)           */
    float sigma_depth;   /* depth difference, fraction of the image's depth
                            range (0 = 0.1)                                 */
    float sigma_albedo;  /* albedo difference (0 = 0.3)                      */
    float sigma_normal;  /* normal difference |Δn| (0 = 2: the normals from
                            a noisy CT gradient guide only loosely)          */
    float sigma_coverage;/* coverage difference (0 = 0.1)                    */
    /* (The defaults: the best of a few on bonsai at 16 spp, 256², against a
     * 1024-spp reference; docs/techniques/pathtrace.md, "Denoising".) */
    int no_blend;        /* 1: the filtered image as it is (for studies)     */
    int threads;         /* 0 = the context's                                */
    int portable;        /* 1: the baseline x86-64 kernel even where AVX2
                            runs (the same bits; for tests and timing)      */
} volux_denoise_settings;

/* Denoises `color` (the per-pixel mean) into *out (allocated by the call;
 * volux_image_free). `guide` must have the image's size and a variance
 * array (variance of each pixel mean's luminance, < 0 where unknown: one
 * sample); its feature arrays may be NULL (then only colour and variance
 * guide the filter). `spp`: samples per pixel of `color` (below 4 the
 * variance is estimated from each pixel's neighbourhood instead, as SVGF
 * does for a short history). settings NULL = defaults. VOLUX_ERR_INVALID
 * for mismatched sizes or a missing variance. Threaded; the result does
 * not depend on the thread count. */
VOLUX_API volux_status volux_denoise(volux_context *ctx, const volux_image *color, const volux_features *guide,
                                     uint32_t spp, const volux_denoise_settings *settings, volux_image *out);

/* volux_framebuffer_resolve, denoised with the framebuffer's features
 * (when it holds any) and variance. */
VOLUX_API volux_status volux_framebuffer_denoise(const volux_framebuffer *fb, const volux_denoise_settings *settings,
                                                 volux_image *out);

#ifdef __cplusplus
}
#endif
#endif
