/*
 * techniques/guided/env.c — the environment as an equal-area octahedral
 * image with a quadtree (§7: "we assume that the environment map is given
 * as an octahedral map, otherwise we convert it first").
 *
 * Texel (x, y) of the M×M image holds the luminance of the summed enabled
 * environment lights averaged over 2×2 directions inside the texel (the
 * radiance itself is always looked up exactly, volux_environment_radiance;
 * the image only shapes the density). Every texel is floored at 10⁻³ of the
 * mean, so every direction has a positive density and sampling the
 * environment alone is unbiased even where the average misses a small
 * bright spot; the floor costs at most 0.1 % of the samples. The quadtree
 * sums are in Morton order (sample/octahedral.h): level l of the pyramid is
 * the image at 2^l × 2^l, so the level whose resolution matches the
 * visibility grid's directions is read directly for the product (§7).
 */
#include <math.h>
#include <string.h>

#include "core/context_internal.h"
#include "core/parallel.h"
#include "guided.h"
#include "sample/octahedral.h"

volux_vec3 guided_env_radiance(const volux_light_list *lights, volux_vec3 dir) {
    volux_vec3 sum = v3(0, 0, 0);
    for (int i = 0; i < lights->n_all; i++)
        if (lights->all[i].type == VOLUX_LIGHT_ENVIRONMENT)
            sum = v3_add(sum, volux_environment_radiance(lights->all[i].desc, dir));
    return sum;
}

void guided_env_free(volux_context *ctx, guided_env *e) {
    volux_free(ctx, e->nodes, e->bytes);
    memset(e, 0, sizeof *e);
}

typedef struct env_job {
    const volux_light_list *lights;
    float *leaves;
    int res;
    double *row_sums;
} env_job;

static void env_row(void *user, int64_t y, int thread) {
    (void)thread;
    env_job *J = user;
    int M = J->res;
    double sum = 0.0;
    for (int x = 0; x < M; x++) {
        float l = 0.0f;
        for (int sy = 0; sy < 2; sy++)
            for (int sx = 0; sx < 2; sx++) {
                volux_vec3 d = volux_octa_to_dir(((float)x + 0.25f + 0.5f * (float)sx) / (float)M,
                                                 ((float)y + 0.25f + 0.5f * (float)sy) / (float)M);
                volux_vec3 L = guided_env_radiance(J->lights, d);
                float lum = v3_luminance(v3(fmaxf(L.x, 0.0f), fmaxf(L.y, 0.0f), fmaxf(L.z, 0.0f)));
                l += isfinite(lum) ? lum : 0.0f;
            }
        l *= 0.25f;
        J->leaves[volux_morton2((uint32_t)x, (uint32_t)y)] = l;
        sum += l;
    }
    J->row_sums[y] = sum;
}

volux_status guided_env_build(volux_context *ctx, int threads, guided_env *e, const volux_light_list *lights,
                              int res) {
    int n_env = 0;
    for (int i = 0; i < lights->n_all; i++) n_env += lights->all[i].type == VOLUX_LIGHT_ENVIRONMENT;
    int levels = 0;
    while ((1 << levels) < res) levels++;
    size_t count = (size_t)volux_qt_offset(levels + 1), bytes = count * sizeof(float);
    if (!n_env) {
        guided_env_free(ctx, e);
        return VOLUX_OK;
    }
    if (!e->nodes || e->bytes != bytes) {
        guided_env_free(ctx, e);
        e->nodes = volux_malloc(ctx, bytes);
        if (!e->nodes) return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory (%zu bytes) for the environment", bytes);
        e->bytes = bytes;
    }
    e->res = res;
    e->levels = levels;
    e->present = 0;
    size_t rs_bytes = sizeof(double) * (size_t)res;
    double *row_sums = volux_malloc(ctx, rs_bytes);
    if (!row_sums) return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for the environment");
    env_job J = {lights, e->nodes + volux_qt_offset(levels), res, row_sums};
    volux_parallel_for(threads, res, env_row, &J);
    double total = 0.0;
    for (int y = 0; y < res; y++) total += row_sums[y]; /* in order: thread-count independent */
    volux_free(ctx, row_sums, rs_bytes);
    if (!(total > 0.0) || !isfinite(total)) return VOLUX_OK; /* a black environment: nothing to sample */
    float floor_value = (float)(1e-3 * total / ((double)res * (double)res));
    size_t leaves = (size_t)res * (size_t)res;
    for (size_t i = 0; i < leaves; i++)
        if (J.leaves[i] < floor_value) J.leaves[i] = floor_value;
    volux_qt_build(e->nodes, levels);
    e->present = 1;
    return VOLUX_OK;
}
