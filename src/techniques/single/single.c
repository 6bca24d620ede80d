/*
 * techniques/single/single.c — `single`: single scattering with shadow
 * rays, the baseline of Ament et al. 2013 (§5, Table 1):
 *
 *     L_s(x) = Σ_j p_g(ω_j·ω) E_j(x) T_j(x)
 *
 * with T_j(x) the transmittance from x to light j by ray marching, either
 * per view sample (transmittance_cache = false: exact, slow) or read from a
 * per-light transmittance cache whose every node is one shadow ray
 * (transmittance_cache = true, as the paper's baseline; §5 "For the single
 * scattering model, we also cache the transmittance T in a 3D texture").
 *
 * Caches and what invalidates them:
 *   transmittance cache of light j ← volume, extinction, density, light j,
 *                                    cache parameters
 * Phase, colour and camera edits need no cache work.
 */
#include <math.h>
#include <string.h>

#include "core/context_internal.h"
#include "core/parallel.h"
#include "single.h"
#include "sample/phase.h"

static const volux_param_info single_params[] = {
    SCATTER_COMMON_PARAMS,
    {"transmittance_cache", VOLUX_PARAM_BOOL, 1, 0, 1, NULL,
     "cache the transmittance to each light in a grid (one shadow ray per node); false: one shadow ray per view "
     "sample"},
    {"cache_scale", VOLUX_PARAM_NUMBER, 0.5, 0.05, 1, NULL,
     "transmittance cache resolution relative to the volume (1 = one node per voxel; 0.5 = the resolution of "
     "ambient's radiance cache)"},
    {"shadow_step", VOLUX_PARAM_NUMBER, 1.0, 0.05, 16, NULL, "shadow-ray step in units of the smallest voxel spacing"},
    {NULL, 0, 0, 0, 0, NULL, NULL}};

/* Transmittance from p towards light l through the volume: midpoint rule on
 * fixed segments [i·h, (i+1)·h] of the ray from p, skipping empty
 * macrocells; stops below 1e-5. */
static float shadow_transmittance(const single_state *st, volux_vec3 p, const scatter_light *l) {
    const scatter_base *b = &st->b;
    volux_vec3 dir;
    float t_max = INFINITY;
    if (l->positional) {
        volux_vec3 to = v3_sub(l->pos, p);
        t_max = v3_length(to);
        if (t_max <= 0.0f) return 1.0f;
        dir = v3_scale(to, 1.0f / t_max);
    } else {
        dir = v3_scale(l->dir, -1.0f);
    }
    volux_ray ray;
    if (!volux_ray_clip(b->volume, p, dir, &ray)) return 1.0f;
    float t1 = ray.t1 < t_max ? ray.t1 : t_max, h = st->shadow_step;
    if (ray.t0 >= t1) return 1.0f;
    volux_march_iter it;
    volux_march_init(&it, &b->grid, &ray, ray.t0, t1);
    volux_interval iv;
    float tau = 0.0f;
    while (volux_march_next(&it, &iv)) {
        if (iv.sigma_max <= 0.0f) continue;
        for (int i = (int)floorf(iv.t0 / h);; i++) {
            float a = (float)i * h, e = a + h;
            if (a >= iv.t1) break;
            if (a < iv.t0) a = iv.t0;
            if (e > iv.t1) e = iv.t1;
            if (e <= a) continue;
            volux_vec3 q = v3_madd(ray.q0, ray.dq, 0.5f * (a + e));
            tau += volux_lut_sigma(b->lut, volux_volume_sample_index(b->volume, q.x, q.y, q.z)) * (e - a);
        }
        if (tau > 11.5f) return 0.0f;
    }
    return expf(-tau);
}

typedef struct cache_job {
    const single_state *st;
    const scatter_light *l;
    scatter_grid *g;
} cache_job;

static void cache_slice(void *user, int64_t k, int thread) {
    (void)thread;
    const cache_job *j = user;
    scatter_grid *g = j->g;
    for (int y = 0; y < g->dims[1]; y++)
        for (int x = 0; x < g->dims[0]; x++)
            g->v[((size_t)k * (size_t)g->dims[1] + (size_t)y) * (size_t)g->dims[0] + (size_t)x] =
                shadow_transmittance(j->st, scatter_grid_node(g, x, y, (int)k), j->l);
}

static volux_status build_cache(single_state *st, const scatter_light *l) {
    scatter_grid *g = &st->cache[l->slot];
    volux_status s = scatter_grid_alloc(st->b.ctx, st->b.volume, st->cache_scale, g, "single: transmittance cache");
    if (s) return s;
    cache_job job = {st, l, g};
    volux_parallel_for(st->b.threads, g->dims[2], cache_slice, &job);
    st->cache_builds[l->slot]++;
    return VOLUX_OK;
}

volux_status volux_single_update(void *state, volux_scene *scene, const volux_change_set *c) {
    single_state *st = state;
    volux_status s = scatter_base_update(&st->b, scene, c);
    if (s) return s;
    int all = (c->what & (VOLUX_CHANGE_VOLUME | VOLUX_CHANGE_EXTINCTION | VOLUX_CHANGE_DENSITY)) != 0;
    if (c->what & (VOLUX_CHANGE_PARAMS | VOLUX_CHANGE_VOLUME)) {
        const volux_technique_class *cls = st->b.cls;
        int use = (int)volux_technique_param(scene, cls, "transmittance_cache");
        float scale = (float)volux_technique_param(scene, cls, "cache_scale");
        float step = (float)volux_technique_param(scene, cls, "shadow_step") * st->b.min_spacing;
        if (use != st->use_cache || scale != st->cache_scale || step != st->shadow_step) all = 1;
        st->use_cache = use, st->cache_scale = scale, st->shadow_step = step;
    }
    /* Drop caches of slots that no longer hold an enabled light. */
    int live[VOLUX_MAX_LIGHTS] = {0};
    for (int i = 0; i < st->b.n_lights; i++) live[st->b.lights[i].slot] = 1;
    for (int slot = 0; slot < VOLUX_MAX_LIGHTS; slot++)
        if (st->cache[slot].v && (!live[slot] || !st->use_cache)) scatter_grid_free(st->b.ctx, &st->cache[slot]);
    if (!st->use_cache) return VOLUX_OK;
    for (int i = 0; i < st->b.n_lights; i++) {
        const scatter_light *l = &st->b.lights[i];
        if (all || volux_change_light(c, l->slot) || !st->cache[l->slot].v)
            if ((s = build_cache(st, l))) return s;
    }
    return VOLUX_OK;
}

static volux_status single_create(volux_context *ctx, volux_scene *scene, void **out) {
    single_state *st = volux_calloc(ctx, 1, sizeof *st);
    if (!st) return volux_error(ctx, VOLUX_ERR_NOMEM, "single: out of memory for technique state");
    st->b.ctx = ctx;
    st->b.cls = &volux_single_class;
    st->use_cache = -1;
    volux_change_set all = volux_change_all();
    volux_status s = volux_single_update(st, scene, &all);
    if (s) {
        volux_single_destroy(st);
        return s;
    }
    *out = st;
    return VOLUX_OK;
}

size_t volux_single_memory_bytes(const void *state) {
    const single_state *st = state;
    size_t n = sizeof *st + scatter_base_memory(&st->b);
    for (int i = 0; i < VOLUX_MAX_LIGHTS; i++) n += st->cache[i].bytes;
    return n;
}

void volux_single_destroy(void *state) {
    single_state *st = state;
    if (!st) return;
    for (int i = 0; i < VOLUX_MAX_LIGHTS; i++) scatter_grid_free(st->b.ctx, &st->cache[i]);
    scatter_base_free(&st->b);
    volux_free(st->b.ctx, st, sizeof *st);
}

/* ------------------------------------------------------------------ render */

static inline __attribute__((always_inline)) void inscatter(const void *tech, const scatter_sample *smp,
                                                            volux_vec3 *Ls, volux_vec3 *extra) {
    (void)extra;
    const single_state *st = tech;
    const scatter_base *b = &st->b;
    volux_vec3 L = v3(0, 0, 0);
    for (int i = 0; i < b->n_lights; i++) {
        const scatter_light *l = &b->lights[i];
        volux_vec3 travel;
        volux_vec3 E = scatter_light_irradiance(l, smp->p, &travel);
        if (E.x <= 0.0f && E.y <= 0.0f && E.z <= 0.0f) continue;
        float T = st->use_cache ? scatter_grid_sample(&st->cache[l->slot], smp->p)
                                : shadow_transmittance(st, smp->p, l);
        L = v3_add(L, v3_scale(E, T * volux_hg_eval(b->g, v3_dot(travel, smp->to_eye))));
    }
    *Ls = L;
}

static void single_render_tile(const void *state, const volux_scene *scene, const volux_tile *tile, float *rgb,
                               volux_tile_stats *stats) {
    const single_state *st = state;
    scatter_render_tile(&st->b, st, scene, tile, rgb, stats, 0.0f, inscatter);
}

const volux_technique_class volux_single_class = {
    "single", "single scattering with shadow rays and an optional transmittance cache (Ament 2013 baseline)",
    single_params, 0, single_create, volux_single_update, single_render_tile, volux_single_memory_bytes,
    volux_single_destroy,
};
