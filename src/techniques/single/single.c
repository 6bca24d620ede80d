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
    {"near_field", VOLUX_PARAM_NUMBER, 2, 0, 16, NULL,
     "with transmittance_cache: march the first near_field cache cells of each shadow ray and read the cache "
     "there, so the cache's blur does not light thin structures through themselves; 0 = read the cache at the "
     "sample"},
    {"env_directions", VOLUX_PARAM_INT, 16, 0, SINGLE_MAX_ENV_DIRS, NULL,
     "environment lights as this many shadowed directional lights (a Fibonacci set; each carries the "
     "environment's radiance over its cell and has a transmittance cache at half cache_scale); 0 = ignore "
     "environment lights (with a warning)"},
    {NULL, 0, 0, 0, 0, NULL, NULL}};

/* Optical depth from p along unit dir over [0, t_max) through the volume:
 * midpoint rule on fixed segments [i·h, (i+1)·h] of the ray from p,
 * skipping empty macrocells; stops above 11.5 (T < 1e-5). *t_exit: where
 * the ray leaves the volume (0 if it misses it). */
static float shadow_tau(const single_state *st, volux_vec3 p, volux_vec3 dir, float t_max, float *t_exit) {
    const volux_raycaster *rc = &st->b.rc;
    volux_ray ray;
    *t_exit = 0.0f;
    if (!volux_ray_clip(rc->volume, p, dir, &ray)) return 0.0f;
    *t_exit = ray.t1;
    float t1 = ray.t1 < t_max ? ray.t1 : t_max, h = st->shadow_step;
    if (ray.t0 >= t1) return 0.0f;
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
        if (tau > 11.5f) return INFINITY;
    }
    return tau;
}

/* Direction from p towards light l (unit) and the distance to it
 * (INFINITY for a directional light); 0 if p is at the light. */
static float towards_light(volux_vec3 p, const volux_prepared_light *l, volux_vec3 *dir) {
    if (!l->positional) {
        *dir = v3_scale(l->travel, -1.0f);
        return INFINITY;
    }
    volux_vec3 to = v3_sub(l->pos, p);
    float d = v3_length(to);
    if (d > 0.0f) *dir = v3_scale(to, 1.0f / d);
    return d;
}

/* Transmittance from p towards light l through the volume. */
static float shadow_transmittance(const single_state *st, volux_vec3 p, const volux_prepared_light *l) {
    volux_vec3 dir;
    float dist = towards_light(p, l, &dir), exit;
    if (dist <= 0.0f) return 1.0f;
    return expf(-shadow_tau(st, p, dir, dist, &exit));
}

/* Transmittance towards l read from its cache g. With near_field > 0 the
 * first near_field cache cells of the way are marched and the cache is read
 * there: T = exp(−τ(p, q))·T_cache(q), q = p + d·ω. A trilinear read at p
 * itself mixes in nodes up to a cell away, whose shadow rays miss the thin
 * structure p sits in (a vessel wall, an engine fin): the blurred cache
 * lights such structures up to 2× too brightly (docs/lights.md); at q the
 * neighbours' rays run beside the part of the way already marched. */
static float cached_transmittance(const single_state *st, const scatter_grid *g, volux_vec3 p,
                                  const volux_prepared_light *l) {
    if (st->near_field <= 0.0f) return scatter_grid_sample(g, p);
    volux_vec3 dir;
    float dist = towards_light(p, l, &dir), exit;
    if (dist <= 0.0f) return 1.0f;
    float cell = fmaxf(g->h[0], fmaxf(g->h[1], g->h[2])), d = st->near_field * cell;
    if (d > dist) d = dist;
    float tau = shadow_tau(st, p, dir, d, &exit);
    if (!(tau < 11.5f)) return 0.0f;
    if (exit <= d || d >= dist) return expf(-tau); /* the light or the volume's edge is nearer */
    return expf(-tau) * scatter_grid_sample(g, v3_madd(p, dir, d));
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

static volux_status build_grid(single_state *st, const volux_prepared_light *l, scatter_grid *g, float scale) {
    volux_status s = scatter_grid_alloc(st->b.rc.ctx, st->b.rc.volume, scale, g, "single: transmittance cache");
    if (s) return s;
    cache_job job = {st, l, g};
    volux_parallel_for(st->b.rc.threads, g->dims[2], cache_slice, &job);
    return VOLUX_OK;
}

static volux_status build_cache(single_state *st, const volux_prepared_light *l) {
    volux_status s = build_grid(st, l, &st->slot[l->slot].cache, st->cache_scale);
    if (!s) st->slot[l->slot].cache_builds++;
    return s;
}

/* ------------------------------------------------------------------ environment */

/* The environment as n_env_dirs directional lights: direction k is point k
 * of a Fibonacci set; its irradiance is the environments' radiance
 * integrated over its cell (the directions nearer to it than to any
 * other; volux_environment_cells, shared with `lightvol`): a map texel by
 * texel, so its energy is kept exactly — a sun lands in its nearest
 * direction instead of falling between point samples (on the Venice sunset
 * map the images barely changed: that map's sun is wide). Light travels
 * opposite to the direction it comes from. */
static void env_prepare(single_state *st) {
    const volux_light_list *ls = &st->b.rc.lights;
    int K = st->n_env_dirs;
    st->env_active = K > 0 && ls->n_env > 0;
    if (!st->env_active) return;
    volux_vec3 from[SINGLE_MAX_ENV_DIRS];
    for (int k = 0; k < K; k++) {
        from[k] = volux_fibonacci_dir(k, K);
        st->env_travel[k] = v3_scale(from[k], -1.0f);
        st->env_E[k] = v3(0, 0, 0);
    }
    for (int e = 0; e < ls->n_all; e++)
        if (ls->all[e].type == VOLUX_LIGHT_ENVIRONMENT) volux_environment_cells(ls->all[e].desc, K, from, st->env_E);
}

/* Environment transmittance caches (resolution: half cache_scale; the
 * environment's light is smooth over the volume). */
static volux_status env_build_caches(single_state *st) {
    float scale = st->cache_scale * 0.5f < 0.05f ? 0.05f : st->cache_scale * 0.5f;
    for (int k = 0; k < st->n_env_dirs; k++) {
        volux_prepared_light l;
        memset(&l, 0, sizeof l);
        l.type = VOLUX_LIGHT_DIRECTIONAL;
        l.travel = st->env_travel[k];
        volux_status s = build_grid(st, &l, &st->env_cache[k], scale);
        if (s) return s;
    }
    st->env_cache_builds++;
    return VOLUX_OK;
}

static void env_free_caches(single_state *st) {
    for (int k = 0; k < SINGLE_MAX_ENV_DIRS; k++)
        if (st->env_cache[k].v) scatter_grid_free(st->b.rc.ctx, &st->env_cache[k]);
}

static volux_status single_update(void *state, const volux_scene *scene, const volux_change_set *c) {
    single_state *st = state;
    volux_raycaster *rc = &st->b.rc;
    scatter_base_update(&st->b, scene, c);
    int all = (c->what & (VOLUX_CHANGE_VOLUME | VOLUX_CHANGE_EXTINCTION | VOLUX_CHANGE_DENSITY)) != 0;
    int env = (c->what & VOLUX_CHANGE_LIGHTS) != 0;
    if (c->what & (VOLUX_CHANGE_PARAMS | VOLUX_CHANGE_VOLUME)) {
        int use = (int)volux_technique_param(scene, rc->cls, "transmittance_cache");
        float scale = (float)volux_technique_param(scene, rc->cls, "cache_scale");
        float step = (float)volux_technique_param(scene, rc->cls, "shadow_step") * rc->min_spacing;
        int dirs = (int)volux_technique_param(scene, rc->cls, "env_directions");
        st->near_field = (float)volux_technique_param(scene, rc->cls, "near_field");
        if (use != st->use_cache || scale != st->cache_scale || step != st->shadow_step) all = 1;
        if (dirs != st->n_env_dirs) {
            env_free_caches(st); /* other directions */
            env = 1;
        }
        st->use_cache = use, st->cache_scale = scale, st->shadow_step = step, st->n_env_dirs = dirs;
    }
    volux_status s;
    if (env) {
        env_prepare(st);
        if ((s = volux_raycaster_warn_unused_lights(rc, st->n_env_dirs ? 0u : 1u << VOLUX_LIGHT_ENVIRONMENT,
                                                    "techniques.single.env_directions is 0")))
            return s;
    }
    const volux_light_list *ls = &rc->lights;
    if ((s = volux_grow_slots(rc->ctx, &st->slot, &st->slot_cap, volux_scene_light_slots(scene), sizeof *st->slot,
                              "single: per-light caches")))
        return s;
    /* Drop caches of slots that no longer hold an enabled light (the
     * direct lights are in slot order: one merge pass). */
    for (int slot = 0, i = 0; slot < st->slot_cap; slot++) {
        while (i < ls->n_direct && ls->direct[i].slot < slot) i++;
        int live = i < ls->n_direct && ls->direct[i].slot == slot;
        if (st->slot[slot].cache.v && (!live || !st->use_cache)) scatter_grid_free(rc->ctx, &st->slot[slot].cache);
    }
    if (!st->env_active || !st->use_cache) env_free_caches(st);
    if (!st->use_cache) return VOLUX_OK;
    for (int i = 0; i < ls->n_direct; i++) {
        const volux_prepared_light *l = &ls->direct[i];
        if (all || volux_change_light(c, l->slot) || !st->slot[l->slot].cache.v)
            if ((s = build_cache(st, l))) return s;
    }
    /* The directions are fixed: an environment edit only changes env_E. */
    if (st->env_active && (all || !st->env_cache[st->n_env_dirs - 1].v)) return env_build_caches(st);
    return VOLUX_OK;
}

static void single_init(void *state) {
    single_state *st = state;
    st->use_cache = -1;
    st->n_env_dirs = -1;
}

static size_t single_memory_bytes(const void *state) {
    const single_state *st = state;
    size_t n = sizeof *st->slot * (size_t)st->slot_cap;
    for (int i = 0; i < st->slot_cap; i++) n += st->slot[i].cache.bytes;
    for (int k = 0; k < SINGLE_MAX_ENV_DIRS; k++) n += st->env_cache[k].bytes;
    return n;
}

static void single_release(void *state) {
    single_state *st = state;
    for (int i = 0; i < st->slot_cap; i++) scatter_grid_free(st->b.rc.ctx, &st->slot[i].cache);
    volux_free(st->b.rc.ctx, st->slot, sizeof *st->slot * (size_t)st->slot_cap);
    st->slot = NULL;
    st->slot_cap = 0;
    env_free_caches(st);
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
        float T = st->use_cache ? cached_transmittance(st, &st->slot[l->slot].cache, smp->p, l)
                                : shadow_transmittance(st, smp->p, l);
        L = v3_add(L, v3_scale(E, T * volux_hg_eval(st->b.rc.g, v3_dot(travel, smp->to_eye))));
    }
    if (st->env_active)
        for (int k = 0; k < st->n_env_dirs; k++) {
            volux_vec3 E = st->env_E[k];
            if (E.x <= 0.0f && E.y <= 0.0f && E.z <= 0.0f) continue;
            volux_prepared_light l;
            memset(&l, 0, sizeof l);
            l.travel = st->env_travel[k];
            float T = st->use_cache ? cached_transmittance(st, &st->env_cache[k], smp->p, &l)
                                    : shadow_transmittance(st, smp->p, &l);
            L = v3_add(L, v3_scale(E, T * volux_hg_eval(st->b.rc.g, v3_dot(st->env_travel[k], smp->to_eye))));
        }
    *Ls = L;
}

SCATTER_RENDER_TILE(single_render_tile, single_state, 0.0f, NULL, inscatter)

const volux_technique_class volux_single_class = {
    {"single", "single scattering with shadow rays and an optional transmittance cache (Ament 2013 baseline)",
     single_params, 0},
    sizeof(single_state), 0, 0,
    single_init, single_update, single_render_tile, single_memory_bytes, single_release,
    NULL, NULL, NULL, /* no refine, pending work or statistics */
    NULL, /* no bricks: its light leaves the camera ray (scattering, shadows) */
    NULL, /* no per-frame budget (volux_technique_set_budget) */
    NULL, /* nothing per pass */
};
