/* techniques/guided/guided.c — the `guided` class: parameters, and the
 * mapping from edits to the least cache work (README.md):
 *
 *   volume (single)            → every direction swept again
 *   time step of a sequence    → the directions whose source step changes
 *                                (lazy policy, lazy.c), swept on that step
 *   extinction, density        → every direction (on its source step)
 *   visibility parameters      → every direction (grid reallocated when its
 *                                shape changes)
 *   environment lights         → the environment quadtree (the product with
 *                                V is formed per scattering event)
 *   strategy uniform/environment → no visibility work at all (the grid is
 *                                refreshed when a strategy that reads it is
 *                                chosen)
 *   other lights, camera, colour, phase, render settings → nothing
 * The estimator reads the base (albedo, g, lights, camera, majorants).
 */
#include <math.h>
#include <string.h>

#include "core/context_internal.h"
#include "guided.h"
#include "sample/sampler.h"
#include "sweep_kernels.h"

static const volux_param_info guided_params[] = {
    {"strategy", VOLUX_PARAM_STRING, 0, 0, 0, "two_step",
     "how the environment is sampled at a scattering event: uniform, environment (its luminance alone), visibility "
     "(the visibility grid alone), product (visibility x environment at the grid's angular resolution, the paper's "
     "'combined'), two_step (the product, then down the full-resolution environment quadtree)"},
    {"visibility", VOLUX_PARAM_STRING, 0, 0, 0, "sweep",
     "how the visibility grid is computed: sweep (visibility sweeps, Sec. 6) or bruteforce (a ray from every grid "
     "position per direction: the reference)"},
    {"directions", VOLUX_PARAM_INT, 8, 2, 32, NULL,
     "N: the visibility grid stores N x N directions (equal-area octahedral map) per position; a power of two"},
    {"cell", VOLUX_PARAM_INT, 4, 1, 64, NULL, "voxels per visibility grid cell edge (one position per cell^3 voxels)"},
    {"ray_spacing", VOLUX_PARAM_INT, 1, 1, 16, NULL,
     "voxels between the rays of the sweeping kernel (1: one ray per voxel column, as the paper)"},
    {"filter", VOLUX_PARAM_BOOL, 1, 0, 1, NULL, "sweep-space filtering (Sec. 8): box-filter the kernel's visibility "
                                                "over the projected cell widened by t tan(beta)"},
    {"filter_angle", VOLUX_PARAM_NUMBER, 0.5, 0, 1, NULL,
     "beta / alpha of the filter (alpha = pi/N, a direction texel's angular width; the paper's beta = alpha/2)"},
    {"oversample", VOLUX_PARAM_INT, 1, 1, 4, NULL,
     "sub-directions per axis per direction texel, averaged (2 = 4x, 4 = 16x angular oversampling)"},
    {"epsilon", VOLUX_PARAM_NUMBER, 0.01, 1e-6, 1, NULL, "added to the visibility before the product (Sec. 6)"},
    {"env_resolution", VOLUX_PARAM_INT, 0, 0, 4096, NULL,
     "M: the environment is resampled into an M x M equal-area octahedral image (a power of two >= directions); "
     "0 (auto, the default): the largest M with no more texels than the largest environment map (512 for a "
     "1024 x 512 map), the directions N for a constant environment"},
    {"mis", VOLUX_PARAM_BOOL, 1, 0, 1, NULL,
     "combine the environment sample with phase sampling (power heuristic); 0: the environment is lit by its "
     "light sample alone"},
    {"guide_depth", VOLUX_PARAM_INT, 0, 0, 100000, NULL,
     "scattering events per path whose environment sample uses the strategy (1: the first, as in the paper; 0: "
     "every event); later events sample the environment alone"},
    {"guide_continuation", VOLUX_PARAM_NUMBER, 0, 0, 0.95, NULL,
     "alpha: probability that the continuation direction at a scattering event is drawn from the event's "
     "environment density instead of the phase function (one-sample mixture, weighted by phase / mixture: "
     "unbiased); 0: phase sampling alone, as pathtrace"},
    {"rr_depth", VOLUX_PARAM_INT, 5, 0, 100000, NULL,
     "scattering events before Russian roulette on the path throughput"},
    {"lazy", VOLUX_PARAM_STRING, 0, 0, 0, "round_robin",
     "visibility updates over a time-varying volume (Sec. 9): off (every direction from the current step), "
     "round_robin (lazy_budget directions per step, bit-reversed Morton order), environment (lazy_budget "
     "directions per step drawn from the environment), static (all directions every D/lazy_budget steps)"},
    {"lazy_budget", VOLUX_PARAM_INT, 4, 1, 1024, NULL, "directions recomputed per time step by the lazy policies"},
    {"kernel", VOLUX_PARAM_STRING, 0, 0, 0, "auto",
     "sweep row loops: auto (AVX-512 where the CPU has it and ray_spacing is 1), scalar (portable reference) or "
     "simd (AVX-512; an error where unavailable); the same grid up to float rounding"},
    {"sampler", VOLUX_PARAM_STRING, 0, 0, 0, "sobol",
     "\"sobol\": pixel position and the draws of the first 8 path events from padded Owen-scrambled Sobol pairs "
     "(Burley 2020); \"independent\": independent random numbers throughout"},
    {NULL, 0, 0, 0, 0, NULL, NULL}};

static int is_pow2(int x) { return x > 0 && (x & (x - 1)) == 0; }

static volux_status read_params(guided_state *st, const volux_scene *scene) {
    const volux_technique_class *cls = &volux_guided_class;
    volux_context *ctx = st->rc.ctx;
    static const char *const strategies[] = {"uniform", "environment", "visibility", "product", "two_step"};
    static const char *const lazies[] = {"off", "round_robin", "environment", "static"};
    const char *s = volux_technique_param_string(scene, cls, "strategy");
    int strategy = -1, lazy = -1, sweep = -1;
    for (int i = 0; i < 5; i++)
        if (!strcmp(s, strategies[i])) strategy = i;
    if (strategy < 0)
        return volux_error(ctx, VOLUX_ERR_INVALID,
                           "techniques.guided.strategy: expected uniform, environment, visibility, product or "
                           "two_step, got \"%s\"",
                           s);
    s = volux_technique_param_string(scene, cls, "visibility");
    if (!strcmp(s, "sweep")) sweep = 1;
    else if (!strcmp(s, "bruteforce")) sweep = 0;
    else
        return volux_error(ctx, VOLUX_ERR_INVALID,
                           "techniques.guided.visibility: expected sweep or bruteforce, got \"%s\"", s);
    s = volux_technique_param_string(scene, cls, "lazy");
    for (int i = 0; i < 4; i++)
        if (!strcmp(s, lazies[i])) lazy = i;
    if (lazy < 0)
        return volux_error(ctx, VOLUX_ERR_INVALID,
                           "techniques.guided.lazy: expected off, round_robin, environment or static, got \"%s\"", s);
    s = volux_technique_param_string(scene, cls, "kernel");
    int simd = -1;
    if (!strcmp(s, "auto")) simd = guided_sweep_avx512_available();
    else if (!strcmp(s, "scalar")) simd = 0;
    else if (!strcmp(s, "simd")) {
        if (!guided_sweep_avx512_available())
            return volux_error(ctx, VOLUX_ERR_UNSUPPORTED,
                               "techniques.guided.kernel: simd needs AVX-512 (F, BW, VL), which this CPU lacks");
        simd = 1;
    } else
        return volux_error(ctx, VOLUX_ERR_INVALID, "techniques.guided.kernel: expected auto, scalar or simd, got \"%s\"",
                           s);
    s = volux_technique_param_string(scene, cls, "sampler");
    int sampler = volux_sampler_parse(s);
    if (sampler < 0)
        return volux_error(ctx, VOLUX_ERR_INVALID,
                           "techniques.guided.sampler: expected \"sobol\" or \"independent\", got \"%s\"", s);
    int n = (int)volux_technique_param(scene, cls, "directions");
    if (!is_pow2(n))
        return volux_error(ctx, VOLUX_ERR_INVALID, "techniques.guided.directions: %d is not a power of two", n);
    int m = (int)volux_technique_param(scene, cls, "env_resolution");
    if (m != 0 && (!is_pow2(m) || m < n))
        return volux_error(ctx, VOLUX_ERR_INVALID,
                           "techniques.guided.env_resolution: %d must be 0 (auto) or a power of two and at least "
                           "directions (%d)",
                           m, n);
    guided_vis_params v;
    memset(&v, 0, sizeof v);
    v.sweep = sweep;
    v.dir_res = n;
    v.cell = (int)volux_technique_param(scene, cls, "cell");
    v.ray_spacing = (int)volux_technique_param(scene, cls, "ray_spacing");
    v.filter = (int)volux_technique_param(scene, cls, "filter");
    v.filter_angle = (float)volux_technique_param(scene, cls, "filter_angle");
    v.oversample = (int)volux_technique_param(scene, cls, "oversample");
    v.lazy = lazy;
    v.budget = (int)volux_technique_param(scene, cls, "lazy_budget");
    v.simd = simd;
    st->vis = v;
    st->dir_levels = 0;
    while ((1 << st->dir_levels) < n) st->dir_levels++;
    st->strategy = strategy;
    st->env_res_param = m;
    st->epsilon = (float)volux_technique_param(scene, cls, "epsilon");
    st->mis = (int)volux_technique_param(scene, cls, "mis");
    st->guide_depth = (int)volux_technique_param(scene, cls, "guide_depth");
    st->rr_depth = (int)volux_technique_param(scene, cls, "rr_depth");
    st->sampler = sampler;
    st->continuation = (float)volux_technique_param(scene, cls, "guide_continuation");
    return VOLUX_OK;
}

/* 1 if the grid's values would differ under parameters a and b. */
static int vis_content_differs(const guided_vis_params *a, const guided_vis_params *b) {
    if (a->sweep != b->sweep || a->dir_res != b->dir_res || a->cell != b->cell || a->oversample != b->oversample)
        return 1;
    if (a->sweep && (a->ray_spacing != b->ray_spacing || a->filter != b->filter || a->simd != b->simd ||
                     (a->filter && a->filter_angle != b->filter_angle)))
        return 1;
    return 0;
}

/* env_resolution 0 ("auto"): the largest power of two M whose M×M
 * octahedral image has no more texels than the largest environment map
 * (finer would only interpolate the map; a 1024×512 map gives 512, a
 * 256×128 one 128), at least the grid's N (a constant environment is
 * uniform within every direction texel, so N is all it needs). */
static int env_resolution_auto(const volux_light_list *lights, int n) {
    int m = n;
    for (int i = 0; i < lights->n_all; i++) {
        const volux_prepared_light *l = &lights->all[i];
        if (l->type != VOLUX_LIGHT_ENVIRONMENT || !l->desc || !l->desc->map) continue;
        double texels = (double)l->desc->map->width * (double)l->desc->map->height;
        while (m < 4096 && (double)(2 * m) * (double)(2 * m) <= texels) m *= 2;
    }
    return m;
}

/* 1 if an environment light of `lights` or of the last build (`slots`)
 * changed in c. */
static int env_touched(const volux_light_list *lights, const int *slots, int n_slots, const volux_change_set *c) {
    for (int i = 0; i < lights->n_all; i++)
        if (lights->all[i].type == VOLUX_LIGHT_ENVIRONMENT && volux_change_light(c, lights->all[i].slot)) return 1;
    for (int i = 0; i < n_slots; i++)
        if (volux_change_light(c, slots[i])) return 1;
    return 0;
}

/* Seed of the environment-guided lazy schedule (fixed: the schedule must
 * not change with render settings). */
#define LAZY_SEED 0x6775696465644c5aull

/* Recomputes every direction whose source step differs from `want`,
 * grouped by source step, each step's volume acquired from the sequence
 * (the current one is the base's) with its own LUT (so a direction's
 * values depend only on its step, not on which step is current). */
static volux_status refresh(guided_state *st, const volux_scene *scene, const int *want) {
    volux_context *ctx = st->rc.ctx;
    guided_grid *g = &st->grid;
    int D = g->dirs;
    size_t list_bytes = sizeof(int) * (size_t)D;
    int *list = volux_malloc(ctx, list_bytes);
    if (!list) return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for the visibility update");
    volux_sequence *seq = volux_scene_sequence(scene);
    int current = volux_scene_time_step(scene);
    volux_status s = VOLUX_OK;
    int total = 0, swept = 0;
    for (int d = 0; d < D; d++) total += g->src[d] != want[d];
    for (;;) {
        /* the smallest source step still to do */
        int step = -1;
        for (int d = 0; d < D; d++)
            if (g->src[d] != want[d] && (step < 0 || want[d] < step)) step = want[d];
        if (step < 0) break;
        int n = 0;
        for (int d = 0; d < D; d++)
            if (g->src[d] != want[d] && want[d] == step) list[n++] = d;
        volux_volume *v = st->rc.volume;
        if (step != current) {
            if (!seq) {
                s = volux_error(ctx, VOLUX_ERR_INTERNAL, "guided: step %d without a sequence", step);
                break;
            }
            if ((s = volux_sequence_acquire(seq, step, &v))) break;
            st->steps_loaded++;
        } else {
            volux_volume_retain(v);
        }
        double lo, hi, sp[3];
        volux_volume_range(v, &lo, &hi);
        volux_volume_spacing(v, sp);
        volux_transfer_lut lut;
        s = volux_transfer_bake(ctx, volux_scene_transfer(scene), lo, hi, 0,
                                (float)fmin(sp[0], fmin(sp[1], sp[2])), &lut);
        if (!s) {
            for (int i = 0; i < n; i++) g->src[list[i]] = -1;
            /* in chunks of about 1/16 of the directions, with progress
             * ("preparing guided") and cancellation between them; a
             * cancelled chunk stays invalid (src −1) and is swept next time */
            int chunk = (n + 15) / 16;
            for (int i = 0; i < n && !s; i += chunk) {
                int m = n - i < chunk ? n - i : chunk;
                s = guided_compute_directions(ctx, st->rc.threads, g, v, &lut, &st->vis, list + i, m);
                if (s) break;
                for (int k = i; k < i + m; k++) g->src[list[k]] = step;
                st->swept_directions += (uint64_t)m;
                swept += m;
                if (volux_progress(ctx, "preparing guided", fmin(0.999, (double)swept / (double)total)))
                    s = volux_error(ctx, VOLUX_ERR_CANCELLED, "guided: visibility sweep cancelled");
            }
            volux_transfer_lut_free(ctx, &lut);
        }
        volux_volume_release(v);
        if (s) break;
    }
    volux_free(ctx, list, list_bytes);
    if (!s && total > 0) volux_progress(ctx, "preparing guided", 1.0);
    return s;
}

static volux_status guided_update(void *state, const volux_scene *scene, const volux_change_set *c) {
    guided_state *st = state;
    volux_context *ctx = st->rc.ctx;
    const uint32_t w = c->what;
    volux_status s;
    guided_vis_params old = st->vis;
    int old_env_res = st->env_res;
    if ((w & VOLUX_CHANGE_PARAMS) && (s = read_params(st, scene))) return s;

    /* environment quadtree: when an environment light (now or before)
     * changed, or its resolution */
    if (w & (VOLUX_CHANGE_LIGHTS | VOLUX_CHANGE_PARAMS)) {
        const volux_light_list *ls = &st->rc.lights;
        int res = st->env_res_param ? st->env_res_param : env_resolution_auto(ls, st->vis.dir_res);
        int touched = !st->env_built || res != old_env_res || env_touched(ls, st->env_slots, st->n_env_slots, c);
        if (touched) {
            st->env_built = 0;
            st->env_res = res;
            if ((s = volux_grow_slots(ctx, &st->env_slots, &st->env_slots_cap, ls->n_env, sizeof *st->env_slots,
                                      "guided: environment slots")))
                return s;
            if ((s = guided_env_build(ctx, st->rc.threads, &st->env, ls, res))) return s;
            st->n_env_slots = 0;
            for (int i = 0; i < ls->n_all; i++)
                if (ls->all[i].type == VOLUX_LIGHT_ENVIRONMENT) st->env_slots[st->n_env_slots++] = ls->all[i].slot;
            st->env_built = 1;
            st->env_builds++;
        }
        st->n_env = st->rc.lights.n_env;
    }

    /* visibility grid. Only an environment light's sample reads it
     * (integrator.c: guided_event_build runs when env.present): without
     * one, `guided` is `pathtrace` (same estimator, same images) and a
     * sweep would cost seconds for nothing — the grid is neither allocated
     * nor swept until an environment light appears (a grid that exists is
     * still invalidated below, so it cannot come back stale). uniform and
     * environment sampling never read the grid either. */
    int needed = st->strategy != GUIDED_UNIFORM && st->strategy != GUIDED_ENVIRONMENT && st->env.present;
    if (st->env.present) st->noted_no_env = 0;
    else if (!st->noted_no_env) {
        volux_message(ctx, VOLUX_MESSAGE_NOTE,
                      "guided: no environment light: no visibility sweep, renders as pathtrace would (same "
                      "images); the sweep is built when an environment light is added");
        st->noted_no_env = 1;
    }
    if (!needed && !st->grid.v) return VOLUX_OK; /* allocated and swept when needed */
    volux_sequence *seq = volux_scene_sequence(scene);
    uint64_t seq_id = seq ? volux_sequence_id(seq) : 0;
    int dims[3];
    volux_volume_dims(st->rc.volume, dims);
    int reshape = !st->grid.v || memcmp(dims, st->grid_dims, sizeof dims) != 0 || old.dir_res != st->vis.dir_res ||
                  old.cell != st->vis.cell;
    if (reshape) {
        if ((s = guided_grid_alloc(ctx, &st->grid, st->rc.volume, &st->vis))) return s;
        memcpy(st->grid_dims, dims, sizeof dims);
    }
    int all = (w & (VOLUX_CHANGE_EXTINCTION | VOLUX_CHANGE_DENSITY)) || vis_content_differs(&old, &st->vis) ||
              ((w & VOLUX_CHANGE_VOLUME) && (!seq_id || seq_id != st->seq_id));
    if (all)
        for (int d = 0; d < st->grid.dirs; d++) st->grid.src[d] = -1;
    st->seq_id = seq_id;
    size_t want_bytes = sizeof(int) * (size_t)st->grid.dirs;
    int *want = volux_malloc(ctx, want_bytes);
    if (!want) return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for the visibility update");
    guided_vis_params sched = st->vis;
    if (!seq) sched.lazy = GUIDED_LAZY_OFF;
    s = guided_lazy_sources(ctx, &sched, st->grid.dirs, &st->env, LAZY_SEED, volux_scene_time_step(scene), want);
    /* not read now: leave it stale (brought up to date when a strategy
     * that reads it is chosen or an environment light appears) */
    if (!s && needed) s = refresh(st, scene, want);
    volux_free(ctx, want, want_bytes);
    return s;
}

static void guided_release(void *state) {
    guided_state *st = state;
    guided_grid_free(st->rc.ctx, &st->grid);
    guided_env_free(st->rc.ctx, &st->env);
    volux_free(st->rc.ctx, st->env_slots, sizeof *st->env_slots * (size_t)st->env_slots_cap);
    st->env_slots = NULL;
    st->env_slots_cap = st->n_env_slots = 0;
}

static size_t guided_memory_bytes(const void *state) {
    const guided_state *st = state;
    return st->grid.bytes + st->grid.src_bytes + st->env.bytes + sizeof *st->env_slots * (size_t)st->env_slots_cap;
}

const volux_technique_class volux_guided_class = {
    {"guided",
     "environment-lit Monte Carlo with visibility sweeps and joint importance sampling (von Radziewsky et al. "
     "2017), unbiased, lazy visibility updates for sequences",
     guided_params, 1},
    sizeof(guided_state),
    0,
    0,
    NULL,
    guided_update,
    guided_render_tile,
    guided_memory_bytes,
    guided_release,
    NULL, /* no deferred work to refine */
    NULL,
    NULL, /* no pending-work measure, no statistics */
    NULL, /* no bricks: its light leaves the camera ray (scattering, shadows) */
    NULL, /* no per-frame budget (volux_technique_set_budget) */
    volux_guided_estimate_bytes,
    NULL, /* nothing per pass */
};
