/* sample/gradient.c — the quantised gradient cache (see gradient.h). */
#include <math.h>

#include "gradient.h"

volux_status volux_gradient_cache_build(volux_context *ctx, const volux_volume *v, volux_gradient_cache *gc,
                                        const char *who) {
    size_t n = (size_t)v->dims[0] * (size_t)v->dims[1] * (size_t)v->dims[2];
    size_t bytes;
    if (!volux_mul_size(n, 3 * sizeof(int16_t), &bytes) || bytes > volux_context_max_bytes(ctx))
        return volux_error(ctx, VOLUX_ERR_LIMIT, "%s: gradient cache of %zu voxels exceeds the memory cap", who, n);
    volux_gradient_cache_free(ctx, gc);
    gc->grad = volux_alloc_aligned(ctx, bytes);
    if (!gc->grad) return volux_error(ctx, VOLUX_ERR_NOMEM, "%s: out of memory for the gradient cache", who);
    gc->bytes = bytes;
    float *tmp = volux_malloc(ctx, (size_t)v->dims[0] * 3 * sizeof(float));
    if (!tmp) {
        volux_gradient_cache_free(ctx, gc);
        return volux_error(ctx, VOLUX_ERR_NOMEM, "%s: out of memory", who);
    }
    /* Two passes: find the largest magnitude for the scale, then quantise. */
    float gmax = 0.0f;
    for (int pass = 0; pass < 2; pass++) {
        float q = pass ? (gmax > 0.0f ? 32767.0f / gmax : 0.0f) : 0.0f;
        for (int k = 0; k < v->dims[2]; k++)
            for (int j = 0; j < v->dims[1]; j++) {
                for (int i = 0; i < v->dims[0]; i++) {
                    int c[3] = {i, j, k};
                    for (int a = 0; a < 3; a++) {
                        int lo[3] = {i, j, k}, hi[3] = {i, j, k};
                        if (c[a] > 0) lo[a]--;
                        if (c[a] < v->dims[a] - 1) hi[a]++;
                        int h = hi[a] - lo[a];
                        float d = h ? (volux_volume_value_at(v, hi[0], hi[1], hi[2]) -
                                       volux_volume_value_at(v, lo[0], lo[1], lo[2])) /
                                          ((float)h * (float)v->spacing[a])
                                    : 0.0f;
                        tmp[3 * i + a] = d;
                    }
                }
                if (!pass) {
                    for (int i = 0; i < 3 * v->dims[0]; i++)
                        if (fabsf(tmp[i]) > gmax) gmax = fabsf(tmp[i]);
                } else {
                    int16_t *row = gc->grad + 3 * volux_volume_index(v, 0, j, k);
                    for (int i = 0; i < 3 * v->dims[0]; i++) row[i] = (int16_t)lrintf(tmp[i] * q);
                }
            }
    }
    volux_free(ctx, tmp, (size_t)v->dims[0] * 3 * sizeof(float));
    gc->scale = gmax > 0.0f ? gmax / 32767.0f : 0.0f;
    return VOLUX_OK;
}

void volux_gradient_cache_free(volux_context *ctx, volux_gradient_cache *gc) {
    if (gc->grad) volux_free_aligned(ctx, gc->grad, gc->bytes);
    gc->grad = NULL;
    gc->bytes = 0;
    gc->scale = 0.0f;
}
