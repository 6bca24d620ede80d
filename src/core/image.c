/* core/image.c — the plain RGB float image and error metrics. */
#include <math.h>
#include <string.h>

#include "context_internal.h"
#include "volux/image.h"

volux_status volux_image_create(volux_context *ctx, int width, int height, volux_image *out) {
    if (width < 1 || height < 1 || width > VOLUX_MAX_IMAGE_DIM || height > VOLUX_MAX_IMAGE_DIM)
        return volux_error(ctx, VOLUX_ERR_LIMIT, "image size %dx%d is outside [1, %d]", width, height,
                           VOLUX_MAX_IMAGE_DIM);
    size_t n = (size_t)width * (size_t)height * 3 * sizeof(float);
    if ((uint64_t)n > volux_context_max_bytes(ctx))
        return volux_error(ctx, VOLUX_ERR_LIMIT, "image of %dx%d needs %zu bytes, over the memory cap", width,
                           height, n);
    float *p = volux_calloc(ctx, 1, n);
    if (!p) return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for a %dx%d image", width, height);
    out->width = width;
    out->height = height;
    out->rgb = p;
    return VOLUX_OK;
}

void volux_image_free(volux_context *ctx, volux_image *img) {
    if (!img || !img->rgb) return;
    volux_free(ctx, img->rgb, (size_t)img->width * (size_t)img->height * 3 * sizeof(float));
    img->rgb = NULL;
    img->width = img->height = 0;
}

volux_status volux_image_copy(volux_context *ctx, const volux_image *src, volux_image *out) {
    volux_status st = volux_image_create(ctx, src->width, src->height, out);
    if (st) return st;
    memcpy(out->rgb, src->rgb, (size_t)src->width * (size_t)src->height * 3 * sizeof(float));
    return VOLUX_OK;
}

volux_status volux_image_compare(volux_context *ctx, const volux_image *a, const volux_image *ref,
                                 volux_image_error *out) {
    if (a->width != ref->width || a->height != ref->height)
        return volux_error(ctx, VOLUX_ERR_INVALID, "image sizes differ: %dx%d vs %dx%d", a->width, a->height,
                           ref->width, ref->height);
    size_t n = (size_t)a->width * (size_t)a->height * 3;
    /* A NaN or an infinity makes every metric meaningless (NaN fails each
     * comparison below, so a NaN pixel would otherwise read as a perfect
     * match): refuse, naming the image and the first such pixel. */
    for (int which = 0; which < 2; which++) {
        const volux_image *img = which ? ref : a;
        size_t bad = 0, first = 0;
        for (size_t i = 0; i < n; i++)
            if (!isfinite(img->rgb[i]) && bad++ == 0) first = i;
        if (bad) {
            size_t px = first / 3;
            return volux_error(ctx, VOLUX_ERR_INVALID,
                               "%s image has %zu non-finite value%s (first at pixel %zu,%zu): no error metric is "
                               "defined",
                               which ? "the reference" : "the test", bad, bad == 1 ? "" : "s",
                               px % (size_t)a->width, px / (size_t)a->width);
        }
    }
    double se = 0.0, rel = 0.0, max_abs = 0.0, peak = 0.0;
    for (size_t i = 0; i < n; i++) {
        double x = a->rgb[i], r = ref->rgb[i], d = x - r;
        se += d * d;
        /* relMSE with the usual small epsilon so black pixels do not explode */
        rel += d * d / (r * r + 1e-2);
        if (fabs(d) > max_abs) max_abs = fabs(d);
        if (r > peak) peak = r;
    }
    if (!(peak > 0.0)) peak = 1.0;
    out->rmse = sqrt(se / (double)n);
    out->rel_mse = rel / (double)n;
    out->max_abs = max_abs;
    out->psnr = out->rmse > 0.0 ? 20.0 * log10(peak / out->rmse) : INFINITY;
    return VOLUX_OK;
}
