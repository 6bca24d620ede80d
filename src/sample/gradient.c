/* sample/gradient.c — the bricked, quantised gradient cache (see gradient.h). */
#include <math.h>

#include "gradient.h"

volux_status volux_gradient_cache_build(volux_context *ctx, const volux_volume *v, volux_gradient_cache *gc,
                                        const char *who) {
    int n[3];
    size_t nb = 1, bytes;
    for (int a = 0; a < 3; a++) {
        n[a] = (v->dims[a] - 1 + VOLUX_BRICK_CELLS - 1) / VOLUX_BRICK_CELLS;
        if (n[a] < 1) n[a] = 1;
        nb *= (size_t)n[a];
    }
    if (!volux_mul_size(nb, (size_t)VOLUX_BRICK_VOXELS * sizeof(uint32_t), &bytes) ||
        bytes > volux_context_max_bytes(ctx))
        return volux_error(ctx, VOLUX_ERR_LIMIT, "%s: gradient cache of %zu bricks exceeds the memory cap", who, nb);
    volux_gradient_cache_free(ctx, gc);
    gc->grad = volux_alloc_aligned(ctx, bytes);
    if (!gc->grad) return volux_error(ctx, VOLUX_ERR_NOMEM, "%s: out of memory for the gradient cache", who);
    gc->bytes = bytes;
    /* Pass 1: the largest component sets the scale — the whole grid's for
     * a brick (volux_volume_set_whole_stats), so every brick quantises as
     * the whole volume would. */
    float gmax = v->whole_gradient_max, g[3];
    if (!(gmax > 0.0f)) {
        int lo[3] = {0, 0, 0};
        gmax = volux_volume_gradient_max(v, lo, v->dims);
    }
    float q = gmax > 0.0f ? (float)VOLUX_GRAD_MAX / gmax : 0.0f;
    /* Pass 2: quantise into bricks (node 8b + l, replicated at the far border). */
    for (int bz = 0; bz < n[2]; bz++)
        for (int by = 0; by < n[1]; by++)
            for (int bx = 0; bx < n[0]; bx++) {
                uint32_t *dst = gc->grad + (((size_t)bz * (size_t)n[1] + (size_t)by) * (size_t)n[0] + (size_t)bx) *
                                               VOLUX_BRICK_VOXELS;
                for (int lz = 0; lz < VOLUX_BRICK_NODES; lz++)
                    for (int ly = 0; ly < VOLUX_BRICK_NODES; ly++)
                        for (int lx = 0; lx < VOLUX_BRICK_NODES; lx++) {
                            int i = bx * VOLUX_BRICK_CELLS + lx, j = by * VOLUX_BRICK_CELLS + ly,
                                k = bz * VOLUX_BRICK_CELLS + lz;
                            volux_volume_node_gradient(v, i < v->dims[0] ? i : v->dims[0] - 1, j < v->dims[1] ? j : v->dims[1] - 1,
                                          k < v->dims[2] ? k : v->dims[2] - 1, g);
                            uint32_t w = 0;
                            for (int a = 0; a < 3; a++) {
                                /* a brick's one-sided ghost border may exceed the whole's scale */
                                long f = lrintf(g[a] * q);
                                if (f > VOLUX_GRAD_MAX) f = VOLUX_GRAD_MAX;
                                if (f < -VOLUX_GRAD_MAX) f = -VOLUX_GRAD_MAX;
                                w |= ((uint32_t)(int32_t)f & 0x3ffu) << (10 * a);
                            }
                            dst[lx + VOLUX_BRICK_NODES * (ly + VOLUX_BRICK_NODES * lz)] = w;
                        }
            }
    gc->scale = gmax > 0.0f ? gmax / (float)VOLUX_GRAD_MAX : 0.0f;
    return VOLUX_OK;
}

void volux_gradient_cache_free(volux_context *ctx, volux_gradient_cache *gc) {
    if (gc->grad) volux_free_aligned(ctx, gc->grad, gc->bytes);
    gc->grad = NULL;
    gc->bytes = 0;
    gc->scale = 0.0f;
}
