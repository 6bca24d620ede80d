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
static float shadow_transmittance(const single_state *st, volux_vec3 p, const volux_prepared_light *l) {
    const volux_raycaster *rc = &st->b.rc;
    volux_vec3 dir;
    float t_max = INFINITY;
    if (l->positional) {
        volux_vec3 to = v3_sub(l->pos, p);
        t_max = v3_length(to);
        if (t_max <= 0.0f) return 1.0f;
        dir = v3_scale(to, 1.0f / t_max);
    } else {
        dir = v3_scale(l->travel, -1.0f);
    }
    volux_ray ray;
    if (!volux_ray_clip(rc->volume, p, dir, &ray)) return 1.0f;
    float t1 = ray.t1 < t_max ? ray.t1 : t_max, h = st->shadow_step;
    if (ray.t0 >= t1) return 1.0f;
    volux_march_iter it;
    volux_march_init(&it, &rc->grid, &ray, ray.t0, t1);
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
            tau += volux_lut_sigma(rc->lut, volux_volume_sample_index(rc->volume, q.x, q.y, q.z)) * (e - a);
        }
        if (tau > 11.5f) return 0.0f;
    }
    return expf(-tau);
}

typedef struct cache_job {
    const single_state *st;
    const volux_prepared_light *l;
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

static volux_status build_cache(single_state *st, const volux_prepared_light *l) {
    scatter_grid *g = &st->cache[l->slot];
    volux_status s = scatter_grid_alloc(st->b.rc.ctx, st->b.rc.volume, st->cache_scale, g, "single: transmittance cache");
    if (s) return s;
    cache_job job = {st, l, g};
    volux_parallel_for(st->b.rc.threads, g->dims[2], cache_slice, &job);
    st->cache_builds[l->slot]++;
    return VOLUX_OK;
}

static volux_status single_update(void *state, const volux_scene *scene, const volux_change_set *c) {
    single_state *st = state;
    volux_raycaster *rc = &st->b.rc;
    scatter_base_update(&st->b, scene, c);
    int all = (c->what & (VOLUX_CHANGE_VOLUME | VOLUX_CHANGE_EXTINCTION | VOLUX_CHANGE_DENSITY)) != 0;
    if (c->what & (VOLUX_CHANGE_PARAMS | VOLUX_CHANGE_VOLUME)) {
        int use = (int)volux_technique_param(scene, rc->cls, "transmittance_cache");
        float scale = (float)volux_technique_param(scene, rc->cls, "cache_scale");
        float step = (float)volux_technique_param(scene, rc->cls, "shadow_step") * rc->min_spacing;
        if (use != st->use_cache || scale != st->cache_scale || step != st->shadow_step) all = 1;
        st->use_cache = use, st->cache_scale = scale, st->shadow_step = step;
    }
    /* Drop caches of slots that no longer hold an enabled light. */
    const volux_light_list *ls = &rc->lights;
    int live[VOLUX_MAX_LIGHTS] = {0};
    for (int i = 0; i < ls->n_direct; i++) live[ls->direct[i].slot] = 1;
    for (int slot = 0; slot < VOLUX_MAX_LIGHTS; slot++)
        if (st->cache[slot].v && (!live[slot] || !st->use_cache)) scatter_grid_free(rc->ctx, &st->cache[slot]);
    if (!st->use_cache) return VOLUX_OK;
    for (int i = 0; i < ls->n_direct; i++) {
        const volux_prepared_light *l = &ls->direct[i];
        volux_status s;
        if (all || volux_change_light(c, l->slot) || !st->cache[l->slot].v)
            if ((s = build_cache(st, l))) return s;
    }
    return VOLUX_OK;
}

static void single_init(void *state) { ((single_state *)state)->use_cache = -1; }

static size_t single_memory_bytes(const void *state) {
    const single_state *st = state;
    size_t n = 0;
    for (int i = 0; i < VOLUX_MAX_LIGHTS; i++) n += st->cache[i].bytes;
    return n;
}

static void single_release(void *state) {
    single_state *st = state;
    for (int i = 0; i < VOLUX_MAX_LIGHTS; i++) scatter_grid_free(st->b.rc.ctx, &st->cache[i]);
}

/* ------------------------------------------------------------------ render */

static inline __attribute__((always_inline)) void inscatter(const void *tech, const scatter_sample *smp,
                                                            volux_vec3 *Ls, volux_vec3 *extra) {
    (void)extra;
    const single_state *st = tech;
    const volux_light_list *ls = &st->b.rc.lights;
    volux_vec3 L = v3(0, 0, 0);
    for (int i = 0; i < ls->n_direct; i++) {
        const volux_prepared_light *l = &ls->direct[i];
        volux_vec3 travel;
        volux_vec3 E = volux_light_irradiance(l, smp->p, &travel);
        if (E.x <= 0.0f && E.y <= 0.0f && E.z <= 0.0f) continue;
        float T = st->use_cache ? scatter_grid_sample(&st->cache[l->slot], smp->p)
                                : shadow_transmittance(st, smp->p, l);
        L = v3_add(L, v3_scale(E, T * volux_hg_eval(st->b.rc.g, v3_dot(travel, smp->to_eye))));
    }
    *Ls = L;
}

SCATTER_RENDER_TILE(single_render_tile, single_state, 0.0f, inscatter)

const volux_technique_class volux_single_class = {
    {"single", "single scattering with shadow rays and an optional transmittance cache (Ament 2013 baseline)",
     single_params, 0},
    sizeof(single_state), 0, 0,
    single_init, single_update, single_render_tile, single_memory_bytes, single_release,
    NULL, NULL, NULL, /* no refine, pending work or statistics */
};
