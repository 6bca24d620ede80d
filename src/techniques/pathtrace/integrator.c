/*
 * techniques/pathtrace/integrator.c — the reference estimator.
 *
 * One camera path per pixel sample (pbrt's SimpleVolPath / VolPath
 * structure, Pharr et al. 4th ed. §14.2, simplified to a medium without
 * surfaces):
 *
 *   1. Free flight by delta tracking (Woodcock et al. 1965; Novák et al.
 *      2018 "Monte Carlo methods for volumetric light transport simulation",
 *      §5.1) against the *local* majorant σ̄ of each macrocell interval the
 *      ray crosses. Tentative distances are exponential with rate σ̄ per
 *      interval; by memorylessness a tentative point past an interval's end
 *      restarts at the next interval with that interval's σ̄. A tentative
 *      collision is real with probability σt(x)/σ̄, else null and tracking
 *      continues. The medium does not emit.
 *   2. At a real collision the path scatters with probability
 *      P = max_c ρ_c(x), ρ = albedo·c(x) (DESIGN: σs = albedo·c·σt per
 *      channel, σt scalar), and carries the colour as the weight ρ/P ≤ 1;
 *      otherwise it is absorbed. For grey albedo this is analog absorption;
 *      E[weight] = ρ per channel, so the estimator is unbiased for RGB σs
 *      with a scalar σt.
 *   3. Next-event estimation at each scattering vertex to every enabled
 *      light: transmittance by ratio tracking (Cramer 1978; Novák et al.
 *      2014) on the same local majorants, with Russian roulette once the
 *      running transmittance weight falls below VOLUX_RATIO_RR (unbiased).
 *      Delta lights (directional, point, spot) are light-sampled only. Sphere
 *      lights (cone of the visible cap, uniform in solid angle) and
 *      environments (map: 2-D piecewise-constant by luminance·sin θ;
 *      constant: uniform sphere) are combined with phase sampling by the
 *      power heuristic (Veach 1997, §9.2).
 *   4. The phase-sampled continuation ray is also the second MIS strategy:
 *      emitters it reaches before its next real collision (delta tracking is
 *      a binary transmittance estimator) add their radiance times the MIS
 *      weight of the phase pdf against that light's sampling pdf.
 *   5. Russian roulette on max_c throughput after `rr_depth` scattering
 *      events; at most `max_depth` scattering events per path.
 *
 * Camera rays see the escape radiance (visible environments or the
 * background, volux_scene_escape_radiance) when they leave the volume
 * unscattered — the tracker's estimate of T·L_escape. Scattered rays that
 * escape see the enabled environment lights (visible or not); the
 * background is a backdrop, not a light. Sphere lights are opaque black
 * emitters seen from outside: a scattered or shadow ray that reaches one
 * stops there (it occludes other lights and the environment), and their
 * outer surface radiates `radiance` outwards (a point inside one neither
 * sees nor is shadowed by it; place them outside the volume). Like an
 * environment with visible = false, they are not seen by camera rays, so
 * images stay comparable with techniques that do not draw lights; that does
 * not change the light they cast.
 *
 * HG convention: see sample/phase.h (cos θ between light travel directions;
 * g > 0 forward).
 *
 * The loop itself (steps 1, 2, 4, 5) is render/path.h, shared with
 * `guided`; this file supplies the light sampling (step 3) and the MIS
 * weight of an escaping continuation ray as its hooks.
 *
 * Random numbers: one counter-based stream per (seed, pixel, sample index),
 * so images are bit-identical for any thread count; with the parameter
 * sampler = "sobol" the pixel position and each of the first path events'
 * draws come from padded Owen-scrambled Sobol pairs instead
 * (sample/sampler.h). No allocation.
 */
#include <math.h>
#include <string.h>

#include "core/context_internal.h"
#include "core/rng.h"
#include "core/vecmath.h"
#include "pathtrace.h"
#include "render/direct.h"
#include "render/features.h"
#include "render/path.h"
#include "sample/phase.h"
#include "sample/tracking.h"

typedef struct pt_path {
    const pt_state *st;
    volux_tracker tr;  /* medium, random stream, volume lookups */
    uint64_t vertices; /* path vertices */
} pt_path;

static inline float rnd(pt_path *p) { return volux_tracker_rnd(&p->tr); }

/* Next-event estimate at x for a path that arrived along d: Σ over lights of
 * phase · L · T / pdf (MIS-weighted for sphere and environment lights). */
static volux_vec3 direct_light(pt_path *p, volux_vec3 x, volux_vec3 d) {
    const pt_state *st = p->st;
    volux_vec3 sum = v3(0, 0, 0);
    for (int i = 0; i < st->rc.lights.n_all; i++) {
        const volux_prepared_light *l = &st->rc.lights.all[i];
        volux_light_sample s;
        if (l->type == VOLUX_LIGHT_ENVIRONMENT) {
            float pdf_l, u0, u1;
            if (volux_tracker_ld2(&p->tr, VOLUX_LD_LIGHT, &u0, &u1))
                pdf_l = volux_envmap_sample(&st->env[l->slot], l->desc, u0, u1, &s.w);
            else
                pdf_l = volux_envmap_sample(&st->env[l->slot], l->desc, rnd(p), rnd(p), &s.w);
            if (!(pdf_l > 0.0f)) continue;
            s.dist = INFINITY;
            s.le = volux_environment_radiance(l->desc, s.w);
            float f = volux_hg_eval(st->rc.g, v3_dot(s.w, d));
            s.weight = f * volux_mis_power(pdf_l, f) / pdf_l;
        } else if (!volux_direct_sample(&p->tr, l, st->rc.g, x, d, &s)) {
            continue;
        }
        sum = v3_add(sum, volux_direct_shadowed(&p->tr, &st->rc.lights, i, x, &s));
    }
    return sum;
}

/* The environments seen by a phase-sampled ray that escaped along d,
 * MIS-weighted against light sampling from its origin (the
 * render/path.h `escaped` hook). */
static volux_vec3 environment_escaped(void *self, volux_vec3 d, float pdf_phase) {
    const pt_state *st = ((const pt_path *)self)->st;
    volux_vec3 sum = v3(0, 0, 0);
    for (int i = 0; i < st->rc.lights.n_all; i++) {
        const volux_prepared_light *l = &st->rc.lights.all[i];
        if (l->type != VOLUX_LIGHT_ENVIRONMENT) continue;
        float pdf_l = volux_envmap_pdf(&st->env[l->slot], l->desc, d);
        sum = v3_madd(sum, volux_environment_radiance(l->desc, d), volux_mis_power(pdf_phase, pdf_l));
    }
    return sum;
}

/* The render/path.h `direct` hook. */
static volux_vec3 direct_hook(void *self, volux_vec3 x, volux_vec3 d, int depth) {
    (void)depth;
    return direct_light(self, x, d);
}

/* One camera path: radiance arriving at the camera along -d from o (the
 * loop shared with `guided`, render/path.h). */
static volux_vec3 trace(pt_path *p, const volux_scene *scene, volux_vec3 o, volux_vec3 d) {
    const pt_state *st = p->st;
    return volux_path_trace(&p->tr, &st->rc, scene, st->rr_depth, st->n_area, o, d, &p->vertices, direct_hook,
                            environment_escaped, NULL, p);
}

void volux_pathtrace_render_tile(const void *state, const volux_scene *scene, const volux_tile *tile, float *rgb,
                                 volux_tile_stats *stats) {
    const pt_state *st = state;
    const volux_camera *cam = &st->rc.camera;
    const volux_medium medium = {st->rc.volume,  st->rc.lut, &st->rc.grid, st->pre, st->global_majorant,
                                 st->rc.min_spacing};
    pt_path p = {st, {.m = &medium, .deadline = tile->deadline}, 0};
    for (int y = 0; y < tile->h; y++)
        for (int x = 0; x < tile->w; x++) {
            int px = tile->x0 + x, py = tile->y0 + y;
            uint64_t pixel = (uint64_t)py * (uint64_t)cam->width + (uint64_t)px;
            p.tr.rng = volux_rng_make(st->rc.seed, pixel, tile->sample_index, 0);
            p.tr.ld = volux_sampler_make(st->sampler, st->rc.seed, pixel, tile->sample_index);
            /* Box filter: uniform over the pixel square, for every sample. */
            float jx, jy;
            if (p.tr.ld.on) volux_sampler_2d(&p.tr.ld, 0, &jx, &jy);
            else jx = rnd(&p), jy = rnd(&p);
            volux_vec3 o, d;
            volux_camera_ray(cam, (float)px + jx, (float)py + jy, &o, &d);
            volux_vec3 L = trace(&p, scene, o, d);
            float *out = &rgb[3 * (y * tile->w + x)];
            out[0] = L.x, out[1] = L.y, out[2] = L.z;
            volux_tile_features(&p.tr, &st->rc, tile, x, y, o, d, stats); /* AOVs, when asked */
        }
    stats->samples += p.tr.samples;
    stats->vertices += p.vertices;
}
