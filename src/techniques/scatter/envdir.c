/* techniques/scatter/envdir.c — see envdir.h. */
#include <math.h>
#include <string.h>

#include "core/context_internal.h"
#include "core/parallel.h"
#include "envdir.h"

void scatter_env_prepare(scatter_env *e, const volux_light_list *ls, int K) {
    if (K > SCATTER_ENV_MAX_DIRS) K = SCATTER_ENV_MAX_DIRS;
    for (int k = 0; k < K; k++) { /* the directions even without an environment (ao's direct lights) */
        e->from[k] = volux_fibonacci_dir(k, K);
        e->E[k] = v3(0, 0, 0);
    }
    e->K = K > 0 && ls->n_env > 0 ? K : 0;
    for (int i = 0; i < ls->n_all && e->K; i++)
        if (ls->all[i].type == VOLUX_LIGHT_ENVIRONMENT) volux_environment_cells_cached(&e->memo, ls->all[i].desc, K, e->E);
}

volux_status scatter_dirvis_alloc(volux_context *ctx, const volux_volume *v, float scale, scatter_dirvis *vis) {
    for (int c = 0; c < 4; c++) {
        volux_status s = scatter_grid_alloc(ctx, v, scale, &vis->c[c], "directional occlusion");
        if (s) return s;
    }
    return VOLUX_OK;
}

void scatter_dirvis_free(volux_context *ctx, scatter_dirvis *vis) {
    for (int c = 0; c < 4; c++) scatter_grid_free(ctx, &vis->c[c]);
}

size_t scatter_dirvis_bytes(const scatter_dirvis *vis) {
    return vis->c[0].bytes + vis->c[1].bytes + vis->c[2].bytes + vis->c[3].bytes;
}

typedef struct add_job {
    scatter_dirvis *vis;
    int K, zero;
    volux_vec3 dir;
    scatter_dirvis_fn fn;
    const void *user;
} add_job;

static void add_slice(void *user, int64_t k, int thread) {
    (void)thread;
    const add_job *j = user;
    const scatter_grid *g = &j->vis->c[0];
    size_t row = (size_t)g->dims[0], base = (size_t)k * (size_t)g->dims[1] * row;
    const float w0 = 1.0f / (float)j->K, w1 = 3.0f / (float)j->K;
    const float f[4] = {w0, w1 * j->dir.x, w1 * j->dir.y, w1 * j->dir.z};
    for (int y = 0; y < g->dims[1]; y++)
        for (int x = 0; x < g->dims[0]; x++) {
            size_t o = base + (size_t)y * row + (size_t)x;
            if (j->zero) {
                for (int c = 0; c < 4; c++) j->vis->c[c].v[o] = 0.0f;
                continue;
            }
            float W = j->fn(j->user, scatter_grid_node(g, x, y, (int)k), j->dir);
            if (W == 0.0f) continue;
            for (int c = 0; c < 4; c++) j->vis->c[c].v[o] += W * f[c];
        }
}

void scatter_dirvis_zero(int threads, scatter_dirvis *vis) {
    add_job job = {vis, 1, 1, v3(0, 0, 0), NULL, NULL};
    volux_parallel_for(threads, vis->c[0].dims[2], add_slice, &job);
}

void scatter_dirvis_add(int threads, scatter_dirvis *vis, int K, volux_vec3 dir, scatter_dirvis_fn fn,
                        const void *user) {
    add_job job = {vis, K, 0, dir, fn, user};
    volux_parallel_for(threads, vis->c[0].dims[2], add_slice, &job);
}

volux_status scatter_dirw_alloc(volux_context *ctx, const volux_volume *v, float scale, int K, scatter_dirw *g) {
    int dims[3];
    volux_vec3 lo, hi;
    volux_volume_bounds(v, &lo, &hi);
    float ext[3] = {hi.x - lo.x, hi.y - lo.y, hi.z - lo.z};
    for (int a = 0; a < 3; a++) { /* as scatter_grid_alloc */
        int n = v->dims[a];
        dims[a] = n == 1 ? 1 : (int)ceilf((float)(n - 1) * scale - 1e-4f) + 1;
        if (dims[a] < 2 && n > 1) dims[a] = 2;
    }
    int stride = (K + 15) / 16 * 16;
    size_t count = (size_t)dims[0] * (size_t)dims[1] * (size_t)dims[2], bytes;
    if (!volux_mul_size(count, (size_t)stride, &bytes) || bytes > volux_context_max_bytes(ctx))
        return volux_error(ctx, VOLUX_ERR_LIMIT, "directional occlusion: %dx%dx%d x %d grid exceeds the memory cap",
                           dims[0], dims[1], dims[2], K);
    if (!g->v || g->bytes != bytes) {
        scatter_dirw_free(ctx, g);
        g->v = volux_alloc_aligned(ctx, bytes);
        if (!g->v) return volux_error(ctx, VOLUX_ERR_NOMEM, "directional occlusion: out of memory (%zu bytes)", bytes);
        g->bytes = bytes;
    }
    memcpy(g->dims, dims, sizeof dims);
    g->lo = lo;
    g->K = K, g->stride = stride;
    for (int a = 0; a < 3; a++) {
        g->h[a] = dims[a] > 1 ? ext[a] / (float)(dims[a] - 1) : 1.0f;
        g->inv_h[a] = 1.0f / g->h[a];
    }
    return VOLUX_OK;
}

void scatter_dirw_free(volux_context *ctx, scatter_dirw *g) {
    if (g->v) volux_free_aligned(ctx, g->v, g->bytes);
    memset(g, 0, sizeof *g);
}
