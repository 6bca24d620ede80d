/* techniques/scatter/grid.c — see grid.h. */
#include <math.h>
#include <string.h>

#include "core/parallel.h"
#include "grid.h"

volux_status scatter_grid_alloc(volux_context *ctx, const volux_volume *v, float scale, scatter_grid *g,
                                const char *what) {
    int dims[3];
    volux_vec3 lo, hi;
    volux_volume_bounds(v, &lo, &hi);
    float ext[3] = {hi.x - lo.x, hi.y - lo.y, hi.z - lo.z};
    for (int a = 0; a < 3; a++) {
        int n = v->dims[a];
        dims[a] = n == 1 ? 1 : (int)ceilf((float)(n - 1) * scale - 1e-4f) + 1;
        if (dims[a] < 2 && n > 1) dims[a] = 2;
    }
    size_t count = (size_t)dims[0] * (size_t)dims[1] * (size_t)dims[2], bytes;
    if (!volux_mul_size(count, sizeof(float), &bytes) || bytes > volux_context_max_bytes(ctx))
        return volux_error(ctx, VOLUX_ERR_LIMIT, "%s: %dx%dx%d grid exceeds the memory cap", what, dims[0], dims[1],
                           dims[2]);
    if (!g->v || g->bytes != bytes || memcmp(g->dims, dims, sizeof dims) != 0) {
        scatter_grid_free(ctx, g);
        g->v = volux_alloc_aligned(ctx, bytes);
        if (!g->v) return volux_error(ctx, VOLUX_ERR_NOMEM, "%s: out of memory (%zu bytes)", what, bytes);
        g->bytes = bytes;
    }
    memcpy(g->dims, dims, sizeof dims);
    g->lo = lo;
    for (int a = 0; a < 3; a++) {
        g->h[a] = dims[a] > 1 ? ext[a] / (float)(dims[a] - 1) : 1.0f;
        g->inv_h[a] = 1.0f / g->h[a];
    }
    return VOLUX_OK;
}

void scatter_grid_free(volux_context *ctx, scatter_grid *g) {
    if (g->v) volux_free_aligned(ctx, g->v, g->bytes);
    memset(g, 0, sizeof *g);
}

typedef struct resample_job {
    const scatter_grid *src;
    scatter_grid *dst;
} resample_job;

static void resample_slice(void *user, int64_t k, int thread) {
    (void)thread;
    const resample_job *j = user;
    scatter_grid *d = j->dst;
    for (int y = 0; y < d->dims[1]; y++)
        for (int x = 0; x < d->dims[0]; x++)
            d->v[((size_t)k * (size_t)d->dims[1] + (size_t)y) * (size_t)d->dims[0] + (size_t)x] =
                scatter_grid_sample(j->src, scatter_grid_node(d, x, y, (int)k));
}

void scatter_grid_resample(int threads, const scatter_grid *src, scatter_grid *dst) {
    resample_job job = {src, dst};
    volux_parallel_for(threads, dst->dims[2], resample_slice, &job);
}
