/*
 * techniques/guided/integrator.c — the estimator.
 *
 * A path is the reference path tracer's (delta tracking on the macrocell
 * majorants, scattering with probability max ρ carrying ρ/max ρ, Russian
 * roulette after rr_depth events, NEE with ratio-tracked shadow rays to
 * every light, MIS with phase sampling; sample/tracking.h and
 * render/direct.h), with one change: the environment (all enabled
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
 */
#include <math.h>
#include <string.h>

#include "core/rng.h"
#include "core/vecmath.h"
#include "guided.h"
#include "render/direct.h"
#include "sample/octahedral.h"
#include "sample/phase.h"
#include "sample/tracking.h"

typedef struct gd_path {
    const guided_state *st;
    volux_tracker tr;
    uint64_t vertices;
    int n_area; /* emitters a phase-sampled ray can reach */
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
    float acc[1024];
    memset(acc, 0, sizeof(float) * (size_t)D);
    for (int corner = 0; corner < 8; corner++) {
        int ci = corner & 1 ? i1[0] : i0[0], cj = corner & 2 ? i1[1] : i0[1], ck = corner & 4 ? i1[2] : i0[2];
        float w = (corner & 1 ? f[0] : 1.0f - f[0]) * (corner & 2 ? f[1] : 1.0f - f[1]) *
                  (corner & 4 ? f[2] : 1.0f - f[2]);
        if (!(w > 0.0f)) continue;
        const uint16_t *row =
            g->v + (((size_t)ck * (size_t)g->cells[1] + (size_t)cj) * (size_t)g->cells[0] + (size_t)ci) * (size_t)D;
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
        double u = volux_rng_double(&p->tr.rng), v = volux_rng_double(&p->tr.rng);
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

/* One camera path: radiance arriving at the camera along −d from o. */
static volux_vec3 trace(gd_path *p, const volux_scene *scene, volux_vec3 o, volux_vec3 d, guided_event *ev) {
    const guided_state *st = p->st;
    const volux_light_list *lights = &st->rc.lights;
    volux_vec3 L = v3(0, 0, 0), beta = v3(1, 1, 1);
    float pdf_phase = 0.0f;
    int depth = 0;
    p->vertices++;
    for (;;) {
        volux_ray r;
        float t_hit = INFINITY;
        int collided = volux_ray_clip(st->rc.volume, o, d, &r) && volux_delta_track(&p->tr, &r, r.t0, r.t1, &t_hit);
        if (p->tr.stopped) break; /* out of time: the path ends here */
        if (depth == 0) {
            if (!collided) {
                L = v3_add(L, volux_scene_escape_radiance(scene, d));
                break;
            }
        } else if (p->n_area > 0) {
            int nearest = volux_sphere_nearest(lights, o, d, t_hit);
            if (nearest >= 0) {
                L = v3_add(L, v3_mul(beta, volux_sphere_hit_radiance(&lights->all[nearest], o, pdf_phase)));
                break;
            }
            if (!collided && st->env.present && st->mis) {
                float w = volux_mis_power(pdf_phase, guided_event_pdf(st, ev, d));
                L = v3_add(L, v3_mul(beta, v3_scale(guided_env_radiance(lights, d), w)));
            }
        }
        if (!collided || depth >= st->rc.max_depth) break;

        volux_vec3 x = v3_madd(o, d, t_hit);
        float c[3];
        volux_tracker_sigma(&p->tr, &r, t_hit, c);
        volux_vec3 rho = v3(st->rc.albedo * c[0], st->rc.albedo * c[1], st->rc.albedo * c[2]);
        float P = v3_max_comp(rho);
        if (!(P > 0.0f) || (P < 1.0f && rnd(p) >= P)) break;
        beta = v3_mul(beta, v3_scale(rho, 1.0f / P));
        depth++;
        p->vertices++;

        ev->kind = st->guide_depth == 0 || depth <= st->guide_depth ? st->strategy : GUIDED_ENVIRONMENT;
        if (st->env.present) guided_event_build(st, x, ev);
        if (lights->n_all > 0) L = v3_add(L, v3_mul(beta, direct_light(p, ev, x, d)));

        if (depth >= st->rr_depth) {
            float qq = v3_max_comp(beta);
            if (qq < 1.0f) {
                if (rnd(p) >= qq) break;
                beta = v3_scale(beta, 1.0f / qq);
            }
        }
        /* After the last event the continuation only serves MIS. */
        if (depth >= st->rc.max_depth && p->n_area == 0) break;
        d = volux_hg_sample(st->rc.g, d, rnd(p), rnd(p), &pdf_phase);
        o = x;
    }
    return L;
}

void guided_render_tile(const void *state, const volux_scene *scene, const volux_tile *tile, float *rgb,
                        volux_tile_stats *stats) {
    const guided_state *st = state;
    const volux_camera *cam = &st->rc.camera;
    const volux_medium medium = {st->rc.volume, st->rc.lut, &st->rc.grid, 0, 0, st->rc.min_spacing};
    gd_path p = {st, {&medium, {0, 0}, 0, tile->deadline, 0}, 0, 0};
    p.n_area = st->rc.lights.n_sphere + (st->env.present && st->mis ? 1 : 0);
    guided_event ev;
    ev.kind = st->strategy;
    for (int y = 0; y < tile->h; y++)
        for (int x = 0; x < tile->w; x++) {
            int px = tile->x0 + x, py = tile->y0 + y;
            uint64_t pixel = (uint64_t)py * (uint64_t)cam->width + (uint64_t)px;
            p.tr.rng = volux_rng_make(st->rc.seed, pixel, tile->sample_index, 0);
            float jx = rnd(&p), jy = rnd(&p);
            volux_vec3 o, dir;
            volux_camera_ray(cam, (float)px + jx, (float)py + jy, &o, &dir);
            volux_vec3 L = trace(&p, scene, o, dir, &ev);
            float *out = &rgb[3 * (y * tile->w + x)];
            out[0] = L.x, out[1] = L.y, out[2] = L.z;
        }
    stats->samples += p.tr.samples;
    stats->vertices += p.vertices;
}
