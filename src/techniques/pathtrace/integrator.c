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
 *      running transmittance weight falls below PT_RATIO_RR (unbiased).
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
 * Random numbers: one counter-based stream per (seed, pixel, sample index),
 * so images are bit-identical for any thread count. No allocation.
 */
#include <math.h>
#include <string.h>

#include "core/context_internal.h"
#include "core/rng.h"
#include "core/vecmath.h"
#include "medium.h"
#include "pathtrace.h"
#include "sample/phase.h"
#include "sample/regular_tracking.h"

/* Ratio tracking: below this running weight, Russian roulette with survival
 * probability T/PT_RATIO_RR, and T = PT_RATIO_RR on survival (E[T] kept). */
#define PT_RATIO_RR 0.1f

typedef struct pt_path {
    const pt_state *st;
    const volux_tile *tile;
    volux_rng rng;
    uint64_t samples;  /* volume lookups */
    uint64_t vertices; /* path vertices */
    int stopped;       /* the render's time budget ran out: end the path */
} pt_path;

/* Volume samples between two looks at the render's clock. */
#define PT_CLOCK_EVERY 0x3fffu

static inline float rnd(pt_path *p) { return volux_rng_float(&p->rng); }

/* Exponential step with rate sigma_max: −ln(1 − u)/σ̄, u ∈ [0,1). */
static inline float exp_step(pt_path *p, float inv_sigma_max) { return -logf(1.0f - rnd(p)) * inv_sigma_max; }

/* Interval iteration over the macrocell majorants, or one interval with the
 * global maximum (the `majorant: global` baseline). */
typedef struct pt_iter {
    volux_march_iter it;
    int global, done;
    float t0, t1, sigma;
} pt_iter;

static inline void iter_init(pt_iter *i, const pt_state *st, const volux_ray *r, float ta, float tb) {
    i->global = st->global_majorant;
    if (i->global) {
        i->done = !(tb > ta);
        i->t0 = ta;
        i->t1 = tb;
        i->sigma = st->rc.grid.global_max;
    } else {
        volux_march_init(&i->it, &st->rc.grid, r, ta, tb);
    }
}

static inline int iter_next(pt_iter *i, volux_interval *iv) {
    if (!i->global) return volux_march_next(&i->it, iv);
    if (i->done) return 0;
    i->done = 1;
    iv->t0 = i->t0;
    iv->t1 = i->t1;
    iv->sigma_max = i->sigma;
    return 1;
}

static inline float sigma_at(pt_path *p, const volux_ray *r, float t, float *rgb) {
    const pt_state *st = p->st;
    /* Long paths honour the render's time budget (--time-ms). */
    if ((++p->samples & PT_CLOCK_EVERY) == 0 && volux_tile_expired(p->tile)) p->stopped = 1;
    return pt_medium_eval(st->rc.volume, st->rc.lut, st->pre, v3_madd(r->q0, r->dq, t), rgb);
}

/* Regular tracking over [t, t1] (sample/regular_tracking.h), for intervals where
 * delta tracking would take too many steps or cannot advance t: the first
 * collision with optical depth −ln(1 − u). */
static int delta_track_regular(pt_path *p, const volux_ray *r, float t, float t1, float *t_hit) {
    volux_track_steps steps;
    volux_track_steps_init(&steps, t, t1, p->st->rc.min_spacing);
    float target = -logf(1.0f - rnd(p)), a, b, m;
    while (volux_track_steps_next(&steps, &a, &b, &m) && !p->stopped) {
        float sigma = sigma_at(p, r, m, NULL), tau = sigma * (b - a);
        if (tau >= target) {
            *t_hit = volux_track_hit(a, b, sigma, target);
            return 1;
        }
        target -= tau;
    }
    return 0;
}

/* Delta tracking over [ta, tb] of the clipped ray r: returns 1 and the
 * distance of the first real collision, or 0 if the ray gets through (or
 * the time budget ended the path: p->stopped). Every loop advances t or
 * ends: see sample/regular_tracking.h. */
static int delta_track(pt_path *p, const volux_ray *r, float ta, float tb, float *t_hit) {
    pt_iter it;
    volux_interval iv;
    iter_init(&it, p->st, r, ta, tb);
    while (iter_next(&it, &iv) && !p->stopped) {
        if (!(iv.sigma_max > 0.0f)) continue; /* empty space: no collisions */
        if (volux_track_needs_regular(iv.sigma_max, iv.t0, iv.t1)) {
            if (delta_track_regular(p, r, iv.t0, iv.t1, t_hit)) return 1;
            continue;
        }
        float inv = 1.0f / iv.sigma_max, t = iv.t0;
        while (!p->stopped) {
            float tn = t + exp_step(p, inv);
            if (tn >= iv.t1) break; /* memoryless: restart at the next interval */
            if (!(tn > t)) {        /* a step below half an ulp of t */
                if (delta_track_regular(p, r, t, iv.t1, t_hit)) return 1;
                break;
            }
            t = tn;
            float sigma = sigma_at(p, r, t, NULL);
            if (rnd(p) * iv.sigma_max < sigma) {
                *t_hit = t;
                return 1;
            }
        }
    }
    return 0;
}

/* Ratio tracking's regular-tracking fallback over [t, t1]: multiplies *T by
 * the closed-form transmittance of each sub-step; 0 when the path's weight
 * was rouletted away. */
static int ratio_track_regular(pt_path *p, const volux_ray *r, float t, float t1, float *T) {
    volux_track_steps steps;
    volux_track_steps_init(&steps, t, t1, p->st->rc.min_spacing);
    float a, b, m;
    while (volux_track_steps_next(&steps, &a, &b, &m) && !p->stopped) {
        *T *= expf(-sigma_at(p, r, m, NULL) * (b - a));
        if (*T < PT_RATIO_RR) {
            if (!(*T > 0.0f) || rnd(p) * PT_RATIO_RR >= *T) return 0;
            *T = PT_RATIO_RR;
        }
    }
    return 1;
}

/* Ratio tracking estimate of the transmittance from o along unit d over
 * distance dist (INFINITY: to the volume's exit). */
static float transmittance(pt_path *p, volux_vec3 o, volux_vec3 d, float dist) {
    const pt_state *st = p->st;
    volux_ray r;
    if (!volux_ray_clip(st->rc.volume, o, d, &r)) return 1.0f;
    float tb = r.t1 < dist ? r.t1 : dist;
    if (!(tb > r.t0)) return 1.0f;
    float T = 1.0f;
    pt_iter it;
    volux_interval iv;
    iter_init(&it, st, &r, r.t0, tb);
    while (iter_next(&it, &iv) && !p->stopped) {
        if (!(iv.sigma_max > 0.0f)) continue;
        if (volux_track_needs_regular(iv.sigma_max, iv.t0, iv.t1)) {
            if (!ratio_track_regular(p, &r, iv.t0, iv.t1, &T)) return 0.0f;
            continue;
        }
        float inv = 1.0f / iv.sigma_max, t = iv.t0;
        while (!p->stopped) {
            float tn = t + exp_step(p, inv);
            if (tn >= iv.t1) break;
            if (!(tn > t)) { /* a step below half an ulp of t */
                if (!ratio_track_regular(p, &r, t, iv.t1, &T)) return 0.0f;
                break;
            }
            t = tn;
            T *= 1.0f - sigma_at(p, &r, t, NULL) * inv; /* Novák et al. 2014, Eq. 6 */
            if (T < PT_RATIO_RR) {
                if (!(T > 0.0f) || rnd(p) * PT_RATIO_RR >= T) return 0.0f;
                T = PT_RATIO_RR;
            }
        }
    }
    return p->stopped ? 0.0f : T;
}

/* Distance along unit d from o to the outside of a sphere light, or −1 if
 * the ray misses it or starts inside it (one-sided emitter). */
static inline float sphere_hit(volux_vec3 o, volux_vec3 d, volux_vec3 c, float radius) {
    volux_vec3 oc = v3_sub(o, c);
    float b = v3_dot(oc, d), cc = v3_dot(oc, oc) - radius * radius;
    if (cc <= 0.0f) return -1.0f;
    float disc = b * b - cc;
    if (disc < 0.0f) return -1.0f;
    float t = -b - sqrtf(disc);
    return t > 0.0f ? t : -1.0f;
}

/* 1 − cos θmax of the cone a sphere subtends from x (0 if x is inside).
 * Computed as sin²/(1 + cos) to keep precision for small, far spheres. */
static inline float sphere_cone(volux_vec3 x, const volux_prepared_light *l, volux_vec3 *axis, float *dist_c) {
    volux_vec3 to = v3_sub(l->pos, x);
    float d2 = v3_dot(to, to), r2 = l->radius * l->radius;
    if (d2 <= r2) return 0.0f;
    float dc = sqrtf(d2);
    float sin2 = r2 / d2, cos_max = sqrtf(1.0f - sin2);
    if (axis) *axis = v3_scale(to, 1.0f / dc);
    if (dist_c) *dist_c = dc;
    return sin2 / (1.0f + cos_max);
}

static inline float sphere_pdf(float one_minus_cos_max) {
    return one_minus_cos_max > 0.0f ? 1.0f / (2.0f * VOLUX_PI * one_minus_cos_max) : 0.0f;
}

/* 1 if a sphere light other than `skip` blocks the segment (x, x + dist·w). */
static int sphere_blocks(const pt_state *st, volux_vec3 x, volux_vec3 w, float dist, int skip) {
    for (int i = 0; i < st->rc.lights.n_all; i++) {
        const volux_prepared_light *l = &st->rc.lights.all[i];
        if (i == skip || l->type != VOLUX_LIGHT_SPHERE) continue;
        float t = sphere_hit(x, w, l->pos, l->radius);
        if (t > 0.0f && t < dist) return 1;
    }
    return 0;
}

/* Next-event estimate at x for a path that arrived along d: Σ over lights of
 * phase · L · T / pdf (MIS-weighted for sphere and environment lights). */
static volux_vec3 direct_light(pt_path *p, volux_vec3 x, volux_vec3 d) {
    const pt_state *st = p->st;
    volux_vec3 sum = v3(0, 0, 0);
    for (int i = 0; i < st->rc.lights.n_all; i++) {
        const volux_prepared_light *l = &st->rc.lights.all[i];
        volux_vec3 w, le;
        float dist, weight; /* phase × geometry / pdf × MIS */
        switch (l->type) {
        case VOLUX_LIGHT_DIRECTIONAL:
            w = v3_scale(l->travel, -1.0f);
            dist = INFINITY;
            le = l->power;
            weight = volux_hg_eval(st->rc.g, v3_dot(w, d));
            break;
        case VOLUX_LIGHT_POINT:
        case VOLUX_LIGHT_SPOT: {
            volux_vec3 to = v3_sub(l->pos, x);
            float d2 = v3_dot(to, to);
            if (!(d2 > 0.0f)) continue;
            dist = sqrtf(d2);
            w = v3_scale(to, 1.0f / dist);
            le = l->power;
            float f = 1.0f / d2; /* E = I/r² */
            if (l->type == VOLUX_LIGHT_SPOT) {
                f *= volux_spot_falloff(l->desc, -v3_dot(w, l->axis)); /* cos(axis, light→x) */
                if (!(f > 0.0f)) continue;
            }
            weight = volux_hg_eval(st->rc.g, v3_dot(w, d)) * f;
            break;
        }
        case VOLUX_LIGHT_SPHERE: {
            volux_vec3 axis;
            float dc;
            float omc = sphere_cone(x, l, &axis, &dc);
            if (!(omc > 0.0f)) continue;
            w = volux_sample_cone(axis, omc, rnd(p), rnd(p));
            /* Distance to the near surface; the sampled direction is inside
             * the cone, so clamp the discriminant against rounding. */
            float b = -v3_dot(v3_scale(axis, dc), w);
            float cc = dc * dc - l->radius * l->radius;
            dist = -b - sqrtf(fmaxf(b * b - cc, 0.0f));
            float pdf_l = sphere_pdf(omc), f = volux_hg_eval(st->rc.g, v3_dot(w, d));
            le = l->radiance;
            weight = f * volux_mis_power(pdf_l, f) / pdf_l;
            break;
        }
        case VOLUX_LIGHT_ENVIRONMENT: {
            float pdf_l = volux_envmap_sample(&st->env[l->slot], l->desc, rnd(p), rnd(p), &w);
            if (!(pdf_l > 0.0f)) continue;
            dist = INFINITY;
            le = volux_environment_radiance(l->desc, w);
            float f = volux_hg_eval(st->rc.g, v3_dot(w, d));
            weight = f * volux_mis_power(pdf_l, f) / pdf_l;
            break;
        }
        default: continue;
        }
        if (!(weight > 0.0f) || !(v3_max_comp(le) > 0.0f)) continue;
        if (st->rc.lights.n_sphere > 0 && sphere_blocks(st, x, w, dist, i)) continue;
        float T = transmittance(p, x, w, dist);
        if (T != 0.0f) sum = v3_madd(sum, le, weight * T);
    }
    return sum;
}

/* Radiance from the emitter that the phase-sampled ray (o, d) reaches before
 * distance t_end (its next real collision, or INFINITY when it escapes the
 * volume): the nearest sphere light, else — if it escaped — the
 * environments; MIS-weighted against light sampling from o. Sets *blocked
 * when a sphere light ends the path. */
static volux_vec3 emitters_hit(const pt_state *st, volux_vec3 o, volux_vec3 d, float t_end, float pdf_phase,
                               int escaped, int *blocked) {
    volux_vec3 sum = v3(0, 0, 0);
    int nearest = -1;
    float t_near = t_end;
    for (int i = 0; i < st->rc.lights.n_all && st->rc.lights.n_sphere > 0; i++) {
        const volux_prepared_light *l = &st->rc.lights.all[i];
        if (l->type != VOLUX_LIGHT_SPHERE) continue;
        float t = sphere_hit(o, d, l->pos, l->radius);
        if (t > 0.0f && t < t_near) {
            t_near = t;
            nearest = i;
        }
    }
    *blocked = nearest >= 0;
    if (nearest >= 0) {
        const volux_prepared_light *l = &st->rc.lights.all[nearest];
        float pdf_l = sphere_pdf(sphere_cone(o, l, NULL, NULL));
        return v3_scale(l->radiance, volux_mis_power(pdf_phase, pdf_l));
    }
    if (!escaped) return sum;
    for (int i = 0; i < st->rc.lights.n_all; i++) {
        const volux_prepared_light *l = &st->rc.lights.all[i];
        if (l->type != VOLUX_LIGHT_ENVIRONMENT) continue;
        float pdf_l = volux_envmap_pdf(&st->env[l->slot], l->desc, d);
        sum = v3_madd(sum, volux_environment_radiance(l->desc, d), volux_mis_power(pdf_phase, pdf_l));
    }
    return sum;
}

/* One camera path: radiance arriving at the camera along -d from o. */
static volux_vec3 trace(pt_path *p, const volux_scene *scene, volux_vec3 o, volux_vec3 d) {
    const pt_state *st = p->st;
    volux_vec3 L = v3(0, 0, 0), beta = v3(1, 1, 1);
    float pdf_phase = 0.0f;
    int depth = 0; /* scattering events so far */
    p->vertices++; /* the camera vertex */
    for (;;) {
        /* Free flight to the next real collision (or out of the volume). */
        volux_ray r;
        float t_hit = INFINITY;
        int collided = volux_ray_clip(st->rc.volume, o, d, &r) && delta_track(p, &r, r.t0, r.t1, &t_hit);
        if (p->stopped) break; /* out of time: the path ends here */
        if (depth == 0) {
            if (!collided) {
                /* Unscattered camera ray: T·L_escape, T estimated by the
                 * tracker (this branch runs with probability T). */
                L = v3_add(L, volux_scene_escape_radiance(scene, d));
                break;
            }
        } else if (st->n_area > 0) {
            int blocked;
            L = v3_add(L, v3_mul(beta, emitters_hit(st, o, d, t_hit, pdf_phase, !collided, &blocked)));
            if (blocked) break;
        }
        if (!collided || depth >= st->rc.max_depth) break;

        /* Real collision: scatter with probability max ρ, carry ρ/max ρ. */
        volux_vec3 x = v3_madd(o, d, t_hit);
        float c[3];
        sigma_at(p, &r, t_hit, c);
        volux_vec3 rho = v3(st->rc.albedo * c[0], st->rc.albedo * c[1], st->rc.albedo * c[2]);
        float P = v3_max_comp(rho);
        if (!(P > 0.0f) || (P < 1.0f && rnd(p) >= P)) break;
        beta = v3_mul(beta, v3_scale(rho, 1.0f / P));
        depth++;
        p->vertices++;

        /* Next-event estimation (light-sampling strategy). */
        if (st->rc.lights.n_all > 0) L = v3_add(L, v3_mul(beta, direct_light(p, x, d)));

        /* Russian roulette on the throughput. */
        if (depth >= st->rr_depth) {
            float q = v3_max_comp(beta);
            if (q < 1.0f) {
                if (rnd(p) >= q) break;
                beta = v3_scale(beta, 1.0f / q);
            }
        }
        /* After the last scattering event the continuation ray only
         * serves MIS for sphere/environment lights. */
        if (depth >= st->rc.max_depth && st->n_area == 0) break;

        /* Phase sampling: f/pdf = 1 for HG sampled exactly. */
        d = volux_hg_sample(st->rc.g, d, rnd(p), rnd(p), &pdf_phase);
        o = x;
    }
    return L;
}

void volux_pathtrace_render_tile(const void *state, const volux_scene *scene, const volux_tile *tile, float *rgb,
                                 volux_tile_stats *stats) {
    const pt_state *st = state;
    const volux_camera *cam = &st->rc.camera;
    pt_path p = {st, tile, {0, 0}, 0, 0, 0};
    for (int y = 0; y < tile->h; y++)
        for (int x = 0; x < tile->w; x++) {
            int px = tile->x0 + x, py = tile->y0 + y;
            uint64_t pixel = (uint64_t)py * (uint64_t)cam->width + (uint64_t)px;
            p.rng = volux_rng_make(st->rc.seed, pixel, tile->sample_index, 0);
            /* Box filter: uniform over the pixel square, for every sample. */
            float jx = rnd(&p), jy = rnd(&p);
            volux_vec3 o, d;
            volux_camera_ray(cam, (float)px + jx, (float)py + jy, &o, &d);
            volux_vec3 L = trace(&p, scene, o, d);
            float *out = &rgb[3 * (y * tile->w + x)];
            out[0] = L.x, out[1] = L.y, out[2] = L.z;
        }
    stats->samples += p.samples;
    stats->vertices += p.vertices;
}
