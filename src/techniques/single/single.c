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
    {"env_sweep", VOLUX_PARAM_NUMBER, 1, 0, 4, NULL,
     "environment transmittance caches from a light-space sweep: parallel shadow rays this many cache cells "
     "apart (laterally and in depth), each marched once through the whole volume, their optical depth read "
     "trilinearly at the cache nodes (bonsai 256^3: 16x less preparation at 1, 4x at 0.5); 0 = one shadow ray "
     "from every node (as before)"},
    {"light_sweep", VOLUX_PARAM_NUMBER, 0.5, 0, 4, NULL,
     "directional lights' transmittance caches from the same light-space sweep as env_sweep (parallel shadow "
     "rays this many cache cells apart); 0 = one shadow ray from every node (as before). Point, spot and "
     "sphere lights always use one ray per node"},
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

/* ------------------------------------------------------------------ progress */

/* Progress of one update ("preparing single", the context's callback):
 * `units` of work in all, each parallel item adds its share; the callback
 * runs on one thread at a time, and a nonzero answer cancels (the builds
 * stop taking items and the update returns VOLUX_ERR_CANCELLED). */
typedef struct prep_progress {
    volux_context *ctx;
    double units, done; /* done: under `busy` */
    int busy, cancelled;
} prep_progress;

static void prep_add(prep_progress *p, double units) {
    if (!p->ctx->progress) return;
    if (__atomic_exchange_n(&p->busy, 1, __ATOMIC_ACQUIRE)) return; /* another thread is reporting: skip */
    p->done += units;
    double f = p->units > 0 ? p->done / p->units : 0;
    if (volux_progress(p->ctx, "preparing single", f < 0.999 ? f : 0.999))
        __atomic_store_n(&p->cancelled, 1, __ATOMIC_RELAXED);
    __atomic_store_n(&p->busy, 0, __ATOMIC_RELEASE);
}

static int prep_cancelled(const prep_progress *p) { return __atomic_load_n(&p->cancelled, __ATOMIC_RELAXED); }

typedef struct cache_job {
    const single_state *st;
    const volux_prepared_light *l;
    scatter_grid *g;
    prep_progress *pr;
} cache_job;

static void cache_slice(void *user, int64_t k, int thread) {
    (void)thread;
    const cache_job *j = user;
    if (prep_cancelled(j->pr)) return;
    scatter_grid *g = j->g;
    for (int y = 0; y < g->dims[1]; y++)
        for (int x = 0; x < g->dims[0]; x++)
            g->v[((size_t)k * (size_t)g->dims[1] + (size_t)y) * (size_t)g->dims[0] + (size_t)x] =
                shadow_transmittance(j->st, scatter_grid_node(g, x, y, (int)k), j->l);
    prep_add(j->pr, 1.0 / g->dims[2]); /* a slice: 1/nz of this cache's unit */
}

/* One unit of progress per cache. */
static volux_status build_grid(single_state *st, const volux_prepared_light *l, scatter_grid *g, float scale,
                               prep_progress *pr) {
    volux_status s = scatter_grid_alloc(st->b.rc.ctx, st->b.rc.volume, scale, g, "single: transmittance cache");
    if (s) return s;
    cache_job job = {st, l, g, pr};
    volux_parallel_for(st->b.rc.threads, g->dims[2], cache_slice, &job);
    if (prep_cancelled(pr)) {
        scatter_grid_free(st->b.rc.ctx, g); /* half built: rebuilt by the next update */
        return volux_error(st->b.rc.ctx, VOLUX_ERR_CANCELLED, "single: preparation cancelled");
    }
    return VOLUX_OK;
}

/* --------------------------------------------- light-space sweep (directional) */

/* The transmittance cache of a directional light from parallel shadow
 * rays instead of one ray per node. The rays start on a plane beyond the
 * volume on the light's side, s apart on a square lattice (U, V), and run
 * along the light's travel; each marches the whole volume once (the same
 * midpoint rule and step as shadow_tau, segments aligned to the plane) and
 * records its optical depth τ at depths j·s from the plane. A node's τ is
 * the trilinear interpolation of that (u, v, depth) table, T = exp(−τ).
 *
 * Why: a node's shadow ray and its neighbours' overlap almost entirely
 * (they are parallel); one ray per node marches the average remaining
 * chord (≈ half the mean chord 4V/S) per node, the sweep marches one
 * whole chord per lattice column: with s one cache cell (the default),
 * ≈ 1/16 of the preparation CPU on bonsai 256³ (a 64³ cache), 1/4 at
 * half a cell. The price is one more interpolation of τ, over s (the
 * cache's trilinear read already blurs T over a whole cell); the image
 * change is far below pathtrace's reference noise (src/techniques/single/
 * README.md). τ, not T, is interpolated: it is linear
 * along a ray through homogeneous matter. */
typedef struct sweep_job {
    const single_state *st;
    volux_vec3 U, V, D; /* lattice axes, D = travel (into the volume)  */
    volux_vec3 origin;  /* lattice node (0, 0) on the plane            */
    float s;            /* lateral and depth spacing (world)           */
    int nu, nv, nd;
    float *tau;         /* [iv][iu][j]                                  */
    scatter_grid *g;
    prep_progress *pr;
} sweep_job;

static void sweep_row(void *user, int64_t iv, int thread) {
    (void)thread;
    const sweep_job *j = user;
    if (prep_cancelled(j->pr)) return;
    const volux_raycaster *rc = &j->st->b.rc;
    const float h = j->st->shadow_step, s = j->s;
    for (int iu = 0; iu < j->nu; iu++) {
        float *out = j->tau + ((size_t)iv * (size_t)j->nu + (size_t)iu) * (size_t)j->nd;
        volux_vec3 o = v3_add(j->origin, v3_add(v3_scale(j->U, (float)iu * s), v3_scale(j->V, (float)iv * s)));
        volux_ray ray;
        int n = 0;
        float tau = 0.0f;
        if (volux_ray_clip(rc->volume, o, j->D, &ray) && ray.t0 < ray.t1) {
            volux_march_iter it;
            volux_march_init(&it, &rc->grid, &ray, ray.t0, ray.t1);
            volux_interval iv_;
            while (tau <= 11.5f && volux_march_next(&it, &iv_)) {
                if (iv_.sigma_max <= 0.0f) continue; /* τ constant: the depths in it are filled later */
                for (int i = (int)floorf(iv_.t0 / h);; i++) {
                    float a = (float)i * h, e = a + h;
                    if (a >= iv_.t1) break;
                    if (a < iv_.t0) a = iv_.t0;
                    if (e > iv_.t1) e = iv_.t1;
                    if (e <= a) continue;
                    volux_vec3 q = v3_madd(ray.q0, ray.dq, 0.5f * (a + e));
                    float sigma = volux_lut_sigma(rc->lut, volux_volume_sample_index(rc->volume, q.x, q.y, q.z));
                    /* depths up to e: τ is linear over the segment */
                    for (; n < j->nd && (float)n * s <= e; n++) {
                        float t = (float)n * s;
                        out[n] = t > a ? tau + sigma * (t - a) : tau;
                    }
                    tau += sigma * (e - a);
                }
            }
        }
        for (; n < j->nd; n++) out[n] = tau; /* past the volume (or T < 1e-5: about 0) */
    }
    prep_add(j->pr, 0.75 / j->nv); /* the rays: 3/4 of this cache's unit */
}

static void sweep_slice(void *user, int64_t k, int thread) {
    (void)thread;
    const sweep_job *j = user;
    if (prep_cancelled(j->pr)) return;
    scatter_grid *g = j->g;
    const float inv = 1.0f / j->s;
    const size_t su = (size_t)j->nd, sv = (size_t)j->nu * (size_t)j->nd;
    for (int y = 0; y < g->dims[1]; y++)
        for (int x = 0; x < g->dims[0]; x++) {
            volux_vec3 r = v3_sub(scatter_grid_node(g, x, y, (int)k), j->origin);
            float fu = v3_dot(r, j->U) * inv, fv = v3_dot(r, j->V) * inv, fd = v3_dot(r, j->D) * inv;
            /* the lattice has a margin of a spacing around the box: no clamp needed but for rounding */
            int iu = (int)fu, iv = (int)fv, id = (int)fd;
            if (iu > j->nu - 2) iu = j->nu - 2;
            if (iv > j->nv - 2) iv = j->nv - 2;
            if (id > j->nd - 2) id = j->nd - 2;
            if (iu < 0) iu = 0;
            if (iv < 0) iv = 0;
            if (id < 0) id = 0;
            float a = fu - (float)iu, b = fv - (float)iv, c = fd - (float)id;
            const float *p = j->tau + (size_t)iv * sv + (size_t)iu * su + (size_t)id;
            float c00 = p[0] + (p[1] - p[0]) * c, c10 = p[su] + (p[su + 1] - p[su]) * c;
            float c01 = p[sv] + (p[sv + 1] - p[sv]) * c, c11 = p[sv + su] + (p[sv + su + 1] - p[sv + su]) * c;
            float c0 = c00 + (c10 - c00) * a, c1 = c01 + (c11 - c01) * a;
            float tau = c0 + (c1 - c0) * b;
            g->v[((size_t)k * (size_t)g->dims[1] + (size_t)y) * (size_t)g->dims[0] + (size_t)x] =
                tau < 11.5f ? expf(-tau) : 0.0f;
        }
    prep_add(j->pr, 0.25 / g->dims[2]);
}

/* A directional light's cache (travel: unit) by the light-space sweep at
 * lattice spacing `cells` cache cells. One unit of progress. */
static volux_status build_grid_sweep(single_state *st, volux_vec3 travel, scatter_grid *g, float scale, float cells,
                                     prep_progress *pr) {
    volux_context *ctx = st->b.rc.ctx;
    volux_status s = scatter_grid_alloc(ctx, st->b.rc.volume, scale, g, "single: transmittance cache");
    if (s) return s;
    sweep_job j;
    memset(&j, 0, sizeof j);
    j.st = st, j.g = g, j.pr = pr;
    j.D = travel;
    /* U, V ⊥ D: the axis least aligned with D, made orthogonal */
    volux_vec3 a = fabsf(travel.x) < fabsf(travel.y) ? (fabsf(travel.x) < fabsf(travel.z) ? v3(1, 0, 0) : v3(0, 0, 1))
                                                     : (fabsf(travel.y) < fabsf(travel.z) ? v3(0, 1, 0) : v3(0, 0, 1));
    j.U = v3_normalize(v3_cross(travel, a));
    j.V = v3_cross(travel, j.U);
    float cell = fmaxf(g->h[0], fmaxf(g->h[1], g->h[2]));
    j.s = cells * cell;
    if (j.s < st->shadow_step) j.s = st->shadow_step;
    /* the box's extent along U, V, D, with a spacing of margin */
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int c = 0; c < 8; c++) {
        volux_vec3 p = scatter_grid_node(g, c & 1 ? g->dims[0] - 1 : 0, c & 2 ? g->dims[1] - 1 : 0,
                                         c & 4 ? g->dims[2] - 1 : 0);
        float w[3] = {v3_dot(p, j.U), v3_dot(p, j.V), v3_dot(p, j.D)};
        for (int i = 0; i < 3; i++) lo[i] = fminf(lo[i], w[i]), hi[i] = fmaxf(hi[i], w[i]);
    }
    for (int i = 0; i < 3; i++) lo[i] -= j.s, hi[i] += j.s;
    j.nu = (int)ceilf((hi[0] - lo[0]) / j.s) + 1;
    j.nv = (int)ceilf((hi[1] - lo[1]) / j.s) + 1;
    j.nd = (int)ceilf((hi[2] - lo[2]) / j.s) + 1;
    j.origin = v3_add(v3_scale(j.U, lo[0]), v3_add(v3_scale(j.V, lo[1]), v3_scale(j.D, lo[2])));
    size_t n = (size_t)j.nu * (size_t)j.nv * (size_t)j.nd, bytes = n * sizeof(float);
    j.tau = volux_malloc(ctx, bytes);
    if (!j.tau) {
        scatter_grid_free(ctx, g);
        return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for single's light-space sweep (%zu MiB)",
                           bytes >> 20);
    }
    volux_parallel_for(st->b.rc.threads, j.nv, sweep_row, &j);
    if (!prep_cancelled(pr)) volux_parallel_for(st->b.rc.threads, g->dims[2], sweep_slice, &j);
    volux_free(ctx, j.tau, bytes);
    if (prep_cancelled(pr)) {
        scatter_grid_free(ctx, g);
        return volux_error(ctx, VOLUX_ERR_CANCELLED, "single: preparation cancelled");
    }
    return VOLUX_OK;
}

/* A light's cache: a directional light's parallel shadow rays make the
 * light-space sweep exact up to its interpolation (see above); positional
 * lights' rays fan out, so they keep one ray per node. */
static volux_status build_cache(single_state *st, const volux_prepared_light *l, prep_progress *pr) {
    scatter_grid *g = &st->slot[l->slot].cache;
    volux_status s = l->type == VOLUX_LIGHT_DIRECTIONAL && st->light_sweep > 0.0f
                         ? build_grid_sweep(st, l->travel, g, st->cache_scale, st->light_sweep, pr)
                         : build_grid(st, l, g, st->cache_scale, pr);
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
    /* through the memo shared with lightvol's code (render/lights.h): a
     * light edit that keeps the map's texels, rotation and K costs a hash
     * of the map, not its texel-by-texel integration; the same bits */
    for (int e = 0; e < ls->n_all; e++)
        if (ls->all[e].type == VOLUX_LIGHT_ENVIRONMENT)
            volux_environment_cells_cached(&st->env_cells, ls->all[e].desc, K, st->env_E);
}

static void env_free_caches(single_state *st) {
    for (int k = 0; k < SINGLE_MAX_ENV_DIRS; k++)
        if (st->env_cache[k].v) scatter_grid_free(st->b.rc.ctx, &st->env_cache[k]);
}

/* Environment transmittance caches (resolution: half cache_scale; the
 * environment's light is smooth over the volume), by the light-space sweep
 * (env_sweep > 0) or one shadow ray per node. One unit of progress each. */
static volux_status env_build_caches(single_state *st, prep_progress *pr) {
    float scale = st->cache_scale * 0.5f < 0.05f ? 0.05f : st->cache_scale * 0.5f;
    for (int k = 0; k < st->n_env_dirs; k++) {
        volux_status s;
        if (st->env_sweep > 0.0f) {
            s = build_grid_sweep(st, st->env_travel[k], &st->env_cache[k], scale, st->env_sweep, pr);
        } else {
            volux_prepared_light l;
            memset(&l, 0, sizeof l);
            l.type = VOLUX_LIGHT_DIRECTIONAL;
            l.travel = st->env_travel[k];
            s = build_grid(st, &l, &st->env_cache[k], scale, pr);
        }
        if (s) {
            env_free_caches(st); /* all or none: the next update builds them all */
            return s;
        }
    }
    st->env_cache_builds++;
    return VOLUX_OK;
}


static volux_status single_update(void *state, const volux_scene *scene, const volux_change_set *c) {
    single_state *st = state;
    volux_raycaster *rc = &st->b.rc;
    scatter_base_update(&st->b, scene, c);
    volux_status s;
    if ((s = scatter_base_packet_update(&st->b, scene, c, 1, ""))) return s;
    int all = (c->what & (VOLUX_CHANGE_VOLUME | VOLUX_CHANGE_EXTINCTION | VOLUX_CHANGE_DENSITY)) != 0;
    int env = (c->what & VOLUX_CHANGE_LIGHTS) != 0;
    if (c->what & (VOLUX_CHANGE_PARAMS | VOLUX_CHANGE_VOLUME)) {
        int use = (int)volux_technique_param(scene, rc->cls, "transmittance_cache");
        float scale = (float)volux_technique_param(scene, rc->cls, "cache_scale");
        float step = (float)volux_technique_param(scene, rc->cls, "shadow_step") * rc->min_spacing;
        int dirs = (int)volux_technique_param(scene, rc->cls, "env_directions");
        float sweep = (float)volux_technique_param(scene, rc->cls, "env_sweep");
        if (sweep != st->env_sweep) env_free_caches(st); /* built the other way: again */
        st->env_sweep = sweep;
        st->near_field = (float)volux_technique_param(scene, rc->cls, "near_field");
        float light_sweep = (float)volux_technique_param(scene, rc->cls, "light_sweep");
        if (light_sweep != st->light_sweep) all = 1; /* the lights' caches, built the other way */
        st->light_sweep = light_sweep;
        if (use != st->use_cache || scale != st->cache_scale || step != st->shadow_step) all = 1;
        if (dirs != st->n_env_dirs) {
            env_free_caches(st); /* other directions */
            env = 1;
        }
        st->use_cache = use, st->cache_scale = scale, st->shadow_step = step, st->n_env_dirs = dirs;
    }
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
    /* the work ahead, for the progress report: one unit per cache */
    prep_progress pr = {rc->ctx, 0, 0, 0, 0};
    for (int i = 0; i < ls->n_direct; i++) {
        const volux_prepared_light *l = &ls->direct[i];
        if (all || volux_change_light(c, l->slot) || !st->slot[l->slot].cache.v) pr.units += 1;
    }
    /* The directions are fixed: an environment edit only changes env_E. */
    const int env_build = st->env_active && (all || !st->env_cache[st->n_env_dirs - 1].v);
    if (env_build) pr.units += st->n_env_dirs;
    s = VOLUX_OK;
    for (int i = 0; i < ls->n_direct && !s; i++) {
        const volux_prepared_light *l = &ls->direct[i];
        if (all || volux_change_light(c, l->slot) || !st->slot[l->slot].cache.v) s = build_cache(st, l, &pr);
    }
    if (!s && env_build) s = env_build_caches(st, &pr);
    if (s) { /* cancelled or out of memory: no cache may stay stale, the next update builds them all */
        for (int slot = 0; slot < st->slot_cap; slot++) scatter_grid_free(rc->ctx, &st->slot[slot].cache);
        env_free_caches(st);
        return s;
    }
    if (pr.units > 0) volux_progress(rc->ctx, "preparing single", 1.0);
    return VOLUX_OK;
}

static void single_init(void *state) {
    single_state *st = state;
    st->use_cache = -1;
    st->n_env_dirs = -1;
    st->light_sweep = -1.0f;
}

static size_t single_memory_bytes(const void *state) {
    const single_state *st = state;
    size_t n = sizeof *st->slot * (size_t)st->slot_cap;
    for (int i = 0; i < st->slot_cap; i++) n += st->slot[i].cache.bytes;
    for (int k = 0; k < SINGLE_MAX_ENV_DIRS; k++) n += st->env_cache[k].bytes;
    return n + volux_packet_tables_bytes(&st->b.pk);
}

static void single_release(void *state) {
    single_state *st = state;
    for (int i = 0; i < st->slot_cap; i++) scatter_grid_free(st->b.rc.ctx, &st->slot[i].cache);
    volux_free(st->b.rc.ctx, st->slot, sizeof *st->slot * (size_t)st->slot_cap);
    st->slot = NULL;
    st->slot_cap = 0;
    env_free_caches(st);
    scatter_base_packet_release(&st->b);
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

SCATTER_RENDER_TILE(single_render_tile_scalar, single_state, 0.0f, NULL, inscatter)

void volux_single_shade_lane(const void *tech, const volux_packet_lane *in, float c[3]) {
    const single_state *st = tech;
    scatter_sample smp;
    scatter_sample_of_lane(in, c, &smp);
    volux_vec3 Ls = v3(0, 0, 0), Lx = v3(0, 0, 0);
    /* scatter_march's test: no shadow lookups where nothing scatters */
    if (st->b.rc.albedo > 0.0f && (c[0] > 0.0f || c[1] > 0.0f || c[2] > 0.0f)) inscatter(tech, &smp, &Ls, &Lx);
    scatter_emit(&st->b, c, Ls, Lx);
}

/* The packet march when march_kernel resolved to SIMD (march_avx2.c,
 * march_avx512.c), else scatter_march. */
static void single_render_tile(const void *state, const volux_scene *scene, const volux_tile *tile, float *rgb,
                               volux_tile_stats *stats) {
    const single_state *st = state;
    if (st->b.march_lanes)
        scatter_packet_tile(&st->b, st, scene, tile, rgb, stats, volux_single_march_avx2, volux_single_march_avx512);
    else single_render_tile_scalar(state, scene, tile, rgb, stats);
}

const volux_technique_class volux_single_class = {
    {"single", "single scattering with shadow rays and an optional transmittance cache (Ament 2013 baseline)",
     single_params, 0},
    sizeof(single_state), 0, 0,
    single_init, single_update, single_render_tile, single_memory_bytes, single_release,
    NULL, NULL, NULL, /* no refine, pending work or statistics */
    NULL, /* no bricks: its light leaves the camera ray (scattering, shadows) */
    NULL, /* no per-frame budget (volux_technique_set_budget) */
    volux_single_estimate_bytes,
    NULL, /* nothing per pass */
};
