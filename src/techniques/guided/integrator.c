/*
 * techniques/guided/integrator.c — the estimator.
 *
 * A path is the reference path tracer's, through the same loop
 * (render/path.h: delta tracking on the macrocell majorants, scattering
 * with probability max ρ carrying ρ/max ρ, Russian roulette after rr_depth
 * events, NEE with ratio-tracked shadow rays to every light, MIS with phase
 * sampling), with one change, made through the loop's two hooks
 * (direct_hook, environment_escaped below): the environment (all enabled
 * environment lights summed) is sampled at a scattering event x from a
 * density p(x, ω) chosen by the strategy:
 *
 *   uniform      1/(4π)
 *   environment  the environment quadtree from its root: p ∝ L(ω)
 *   visibility   V_x(ω) + ε at the grid's angular resolution, uniform
 *                inside a direction texel
 *   product      (V_x + ε)·L_N, uniform inside a direction texel (§7)
 *   two_step     (V_x + ε)·L_N for the direction texel, then down the
 *                full-resolution environment quadtree inside it (§7)
 *
 * V_x is the trilinear interpolation of the 8 grid positions around x
 * (§10: "constructed on the fly for each scattering event via
 * interpolation of the eight neighboring spatial grid cells"); its N×N
 * values (times L_N, the environment's quadtree level at the same
 * resolution) are the leaves of a small quadtree built per event, and
 * hierarchical warping draws from it (sample/octahedral.h). The density is
 * the product of the conditional probabilities along the quadtree path
 * times the texel count over 4π (the octahedral map is equal-area), the
 * same number whether a direction was sampled or is evaluated, so the
 * estimator is unbiased: V only shapes the density. The same per-event
 * quadtree serves the MIS weight of the phase-sampled continuation ray
 * when it escapes.
 *
 * `guide_depth` bounds the events that use the strategy (1 is the paper's
 * first event; 0 every event, "guided multiple scattering"); later events
 * sample the environment quadtree alone.
 *
 * `guide_continuation` α > 0 also draws the continuation direction from
 * the event's density (continue_hook below; off by default: it raises the
 * variance, docs/techniques/guided.md).
 */
#include <math.h>
#include <string.h>

#include "core/rng.h"
#include "core/vecmath.h"
#include "guided.h"
#include "render/direct.h"
#include "render/features.h"
#include "render/path.h"
#include "sample/octahedral.h"
#include "sample/phase.h"
#include "sample/tracking.h"

typedef struct gd_path {
    const guided_state *st;
    volux_tracker tr;
    uint64_t vertices;
    int n_area;       /* emitters a phase-sampled ray can reach */
    guided_event *ev; /* the density at the path's last scattering event */
} gd_path;

static inline float rnd(gd_path *p) { return volux_tracker_rnd(&p->tr); }

static int uses_grid(int kind) { return kind == GUIDED_VISIBILITY || kind == GUIDED_PRODUCT || kind == GUIDED_TWO_STEP; }

void guided_event_build(const guided_state *st, volux_vec3 x, guided_event *ev) {
    if (!uses_grid(ev->kind)) return;
    const int L = st->dir_levels;
    const guided_grid *g = &st->grid;
    volux_vec3 q = volux_volume_to_index(st->rc.volume, x);
    float qa[3] = {q.x, q.y, q.z};
    int i0[3], i1[3];
    float f[3];
    for (int a = 0; a < 3; a++) {
        float c = g->cell_size[a] > 0.0f ? qa[a] / g->cell_size[a] - 0.5f : 0.0f;
        float top = (float)(g->cells[a] - 1);
        c = c < 0.0f ? 0.0f : c > top ? top : c;
        i0[a] = (int)c;
        if (i0[a] > g->cells[a] - 2) i0[a] = g->cells[a] > 1 ? g->cells[a] - 2 : 0;
        i1[a] = i0[a] + 1 < g->cells[a] ? i0[a] + 1 : i0[a];
        f[a] = c - (float)i0[a];
        f[a] = f[a] < 0.0f ? 0.0f : f[a] > 1.0f ? 1.0f : f[a];
    }
    int D = g->dirs;
    /* The 8 corners are 4 runs of 2·D values (i0 and i1 are neighbours in
     * x) scattered over a grid of tens of MB: a miss each. Ask for all of
     * them before reading any, so the misses overlap instead of following
     * one another (the gather was ~40 % of this function under perf). */
    const uint16_t *rows[8];
    float wts[8];
    for (int corner = 0; corner < 8; corner++) {
        int ci = corner & 1 ? i1[0] : i0[0], cj = corner & 2 ? i1[1] : i0[1], ck = corner & 4 ? i1[2] : i0[2];
        wts[corner] = (corner & 1 ? f[0] : 1.0f - f[0]) * (corner & 2 ? f[1] : 1.0f - f[1]) *
                      (corner & 4 ? f[2] : 1.0f - f[2]);
        rows[corner] =
            g->v + (((size_t)ck * (size_t)g->cells[1] + (size_t)cj) * (size_t)g->cells[0] + (size_t)ci) * (size_t)D;
        if (wts[corner] > 0.0f)
            for (size_t b = 0; b < sizeof(uint16_t) * (size_t)D; b += 64)
                __builtin_prefetch((const char *)rows[corner] + b);
    }
    float acc[1024];
    memset(acc, 0, sizeof(float) * (size_t)D);
    for (int corner = 0; corner < 8; corner++) {
        float w = wts[corner];
        if (!(w > 0.0f)) continue;
        const uint16_t *row = rows[corner];
        for (int d = 0; d < D; d++) acc[d] += w * (float)row[d];
    }
    float *leaves = ev->nodes + volux_qt_offset(L);
    const float scale = 1.0f / 65535.0f, eps = st->epsilon;
    if (ev->kind == GUIDED_VISIBILITY) {
        for (int d = 0; d < D; d++) leaves[d] = acc[d] * scale + eps;
    } else {
        const float *env = st->env.nodes + volux_qt_offset(L);
        for (int d = 0; d < D; d++) leaves[d] = (acc[d] * scale + eps) * env[d];
    }
    volux_qt_build(ev->nodes, L);
}

/* Direction of the point (x + u, y + v) of an n×n octahedral texel grid. */
static inline volux_vec3 texel_dir(uint32_t node, int n, double u, double v) {
    uint32_t x, y;
    volux_morton2_decode(node, &x, &y);
    return volux_octa_to_dir((float)(((double)x + u) / n), (float)(((double)y + v) / n));
}

float guided_event_sample(const guided_state *st, const guided_event *ev, double u, double v, volux_vec3 *w) {
    const guided_env *env = &st->env;
    const int L = st->dir_levels, M = env->res, N = 1 << L;
    float prob = 1.0f;
    switch (ev->kind) {
    case GUIDED_UNIFORM:
        *w = volux_sample_sphere((float)u, (float)v);
        return VOLUX_INV_4PI;
    case GUIDED_ENVIRONMENT: {
        uint32_t leaf = volux_qt_sample(env->nodes, 0, 0, env->levels, &u, &v, &prob);
        *w = texel_dir(leaf, M, u, v);
        return prob * (float)M * (float)M * VOLUX_INV_4PI;
    }
    case GUIDED_VISIBILITY:
    case GUIDED_PRODUCT: {
        uint32_t leaf = volux_qt_sample(ev->nodes, 0, 0, L, &u, &v, &prob);
        *w = texel_dir(leaf, N, u, v);
        return prob * (float)N * (float)N * VOLUX_INV_4PI;
    }
    default: { /* two_step */
        uint32_t node = volux_qt_sample(ev->nodes, 0, 0, L, &u, &v, &prob);
        uint32_t leaf = volux_qt_sample(env->nodes, L, node, env->levels, &u, &v, &prob);
        *w = texel_dir(leaf, M, u, v);
        return prob * (float)M * (float)M * VOLUX_INV_4PI;
    }
    }
}

float guided_event_pdf(const guided_state *st, const guided_event *ev, volux_vec3 w) {
    const guided_env *env = &st->env;
    if (ev->kind == GUIDED_UNIFORM) return VOLUX_INV_4PI;
    float u, v;
    volux_octa_from_dir(w, &u, &v);
    const int L = st->dir_levels, M = env->res, N = 1 << L;
    uint32_t leaf = volux_morton2((uint32_t)volux_octa_texel(u, M), (uint32_t)volux_octa_texel(v, M));
    uint32_t node = leaf >> (2 * (env->levels - L));
    switch (ev->kind) {
    case GUIDED_ENVIRONMENT: return volux_qt_prob(env->nodes, 0, 0, env->levels, leaf) * (float)M * (float)M * VOLUX_INV_4PI;
    case GUIDED_VISIBILITY:
    case GUIDED_PRODUCT: return volux_qt_prob(ev->nodes, 0, 0, L, node) * (float)N * (float)N * VOLUX_INV_4PI;
    default:
        return volux_qt_prob(ev->nodes, 0, 0, L, node) * volux_qt_prob(env->nodes, L, node, env->levels, leaf) *
               (float)M * (float)M * VOLUX_INV_4PI;
    }
}

/* Next-event estimate at x (path arriving along d): every direct light as
 * the reference does, and the environment from the event's density. */
static volux_vec3 direct_light(gd_path *p, const guided_event *ev, volux_vec3 x, volux_vec3 d) {
    const guided_state *st = p->st;
    const volux_light_list *lights = &st->rc.lights;
    volux_vec3 sum = v3(0, 0, 0);
    for (int i = 0; i < lights->n_all; i++) {
        const volux_prepared_light *l = &lights->all[i];
        volux_light_sample s;
        if (l->type == VOLUX_LIGHT_ENVIRONMENT || !volux_direct_sample(&p->tr, l, st->rc.g, x, d, &s)) continue;
        sum = v3_add(sum, volux_direct_shadowed(&p->tr, lights, i, x, &s));
    }
    if (st->env.present) {
        volux_light_sample s;
        double u, v;
        uint32_t ux, uy;
        if (volux_tracker_ld2_u32(&p->tr, VOLUX_LD_LIGHT, &ux, &uy))
            u = volux_u32_to_double(ux), v = volux_u32_to_double(uy);
        else
            u = volux_rng_double(&p->tr.rng), v = volux_rng_double(&p->tr.rng);
        float pdf = guided_event_sample(st, ev, u, v, &s.w);
        if (pdf > 0.0f) {
            s.dist = INFINITY;
            s.le = guided_env_radiance(lights, s.w);
            float f = volux_hg_eval(st->rc.g, v3_dot(s.w, d));
            s.weight = (st->mis ? f * volux_mis_power(pdf, f) : f) / pdf;
            sum = v3_add(sum, volux_direct_shadowed(&p->tr, lights, -1, x, &s));
        }
    }
    return sum;
}

/* The render/path.h `direct` hook: sets up the event's environment density
 * (the strategy in effect at this depth; kept in p->ev for the MIS weight
 * of the continuation ray), then next-event estimation. */
static volux_vec3 direct_hook(void *self, volux_vec3 x, volux_vec3 d, int depth) {
    gd_path *p = self;
    const guided_state *st = p->st;
    p->ev->kind = st->guide_depth == 0 || depth <= st->guide_depth ? st->strategy : GUIDED_ENVIRONMENT;
    if (st->env.present) guided_event_build(st, x, p->ev);
    return direct_light(p, p->ev, x, d);
}

/* The render/path.h `escaped` hook: the environment seen by a phase-sampled
 * ray that escaped, MIS-weighted against the last event's density. */
static volux_vec3 environment_escaped(void *self, volux_vec3 d, float pdf_phase) {
    const gd_path *p = self;
    const guided_state *st = p->st;
    if (!st->env.present || !st->mis) return v3(0, 0, 0);
    float w = volux_mis_power(pdf_phase, guided_event_pdf(st, p->ev, d));
    return v3_scale(guided_env_radiance(&st->rc.lights, d), w);
}

/* The render/path.h `next` hook (guide_continuation α > 0): the
 * continuation direction from the one-sample mixture
 *     q(ω) = (1 − α)·f(ω) + α·p_x(ω)
 * of the phase function f and the event's environment density p_x (the
 * visibility × environment product of the strategy), weight f/q: unbiased
 * for any α < 1 (q ≥ (1 − α) f > 0 wherever f > 0). MIS against light
 * sampling keeps weighing with f, the density the next-event estimate
 * assumes: the two weights of a direction still sum to one. Paths are
 * steered towards what x sees of the bright environment, so the next
 * vertex tends to be better lit (the indirect light of a fog lit through
 * an opening). */
static volux_vec3 continue_hook(void *self, volux_vec3 d, int depth, float *pdf_phase, float *weight) {
    (void)depth;
    gd_path *p = self;
    const guided_state *st = p->st;
    const float g = st->rc.g, a = st->continuation;
    volux_vec3 w;
    float choice, unused;
    if (!volux_tracker_ld2(&p->tr, VOLUX_LD_CHOICE, &choice, &unused)) choice = rnd(p);
    uint32_t ux, uy;
    int ld = volux_tracker_ld2_u32(&p->tr, VOLUX_LD_PHASE, &ux, &uy);
    if (choice < a) {
        double u, v;
        if (ld) u = volux_u32_to_double(ux), v = volux_u32_to_double(uy);
        else u = volux_rng_double(&p->tr.rng), v = volux_rng_double(&p->tr.rng);
        if (!(guided_event_sample(st, p->ev, u, v, &w) > 0.0f)) {
            *weight = 0.0f;
            return d;
        }
    } else {
        float u1, u2, pdf;
        if (ld) u1 = volux_u32_to_float(ux), u2 = volux_u32_to_float(uy);
        else u1 = rnd(p), u2 = rnd(p);
        w = volux_hg_sample(g, d, u1, u2, &pdf);
    }
    float f = volux_hg_eval(g, v3_dot(w, d));
    float q = (1.0f - a) * f + a * guided_event_pdf(st, p->ev, w);
    *pdf_phase = f;
    *weight = q > 0.0f ? f / q : 0.0f;
    return w;
}

void guided_render_tile(const void *state, const volux_scene *scene, const volux_tile *tile, float *rgb,
                        volux_tile_stats *stats) {
    const guided_state *st = state;
    const volux_camera *cam = &st->rc.camera;
    const volux_medium medium = {st->rc.volume, st->rc.lut, &st->rc.grid, 0, 0, st->rc.min_spacing};
    guided_event ev;
    gd_path p = {st, {.m = &medium, .deadline = tile->deadline}, 0, 0, &ev};
    p.n_area = st->rc.lights.n_sphere + (st->env.present && st->mis ? 1 : 0);
    ev.kind = st->strategy;
    const int guided = st->continuation > 0.0f && st->env.present;
    for (int y = 0; y < tile->h; y++)
        for (int x = 0; x < tile->w; x++) {
            int px = tile->x0 + x, py = tile->y0 + y;
            uint64_t pixel = (uint64_t)py * (uint64_t)cam->width + (uint64_t)px;
            p.tr.rng = volux_rng_make(st->rc.seed, pixel, tile->sample_index, 0);
            p.tr.ld = volux_sampler_make(st->sampler, st->rc.seed, pixel, tile->sample_index);
            float jx, jy;
            if (p.tr.ld.on) volux_sampler_2d(&p.tr.ld, 0, &jx, &jy);
            else jx = rnd(&p), jy = rnd(&p);
            volux_vec3 o, dir;
            volux_camera_ray(cam, (float)px + jx, (float)py + jy, &o, &dir);
            /* two inlined copies of the loop: without the mixture it is
             * exactly the phase sampling (and the images) of before */
            volux_vec3 L = guided
                               ? volux_path_trace(&p.tr, &st->rc, scene, st->rr_depth, p.n_area, o, dir,
                                                  &p.vertices, direct_hook, environment_escaped, continue_hook, &p)
                               : volux_path_trace(&p.tr, &st->rc, scene, st->rr_depth, p.n_area, o, dir,
                                                  &p.vertices, direct_hook, environment_escaped, NULL, &p);
            float *out = &rgb[3 * (y * tile->w + x)];
            out[0] = L.x, out[1] = L.y, out[2] = L.z;
            volux_tile_features(&p.tr, &st->rc, tile, x, y, o, dir, stats); /* AOVs, when asked */
        }
    stats->samples += p.tr.samples;
    stats->vertices += p.vertices;
}
