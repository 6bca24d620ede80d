/*
 * render/direct.h — direct lighting from the non-environment lights for the
 * Monte-Carlo techniques (pathtrace, guided): next-event estimation at a
 * scattering vertex and the sphere lights a phase-sampled ray reaches.
 * Environments are sampled by each technique its own way (pathtrace: the
 * equirectangular table; guided: visibility × environment), then shadowed
 * with the same volux_direct_shadowed.
 *
 * Delta lights (directional, point, spot) are light-sampled only. Sphere
 * lights: the cone of the visible cap, uniform in solid angle, combined with
 * phase sampling by the power heuristic (Veach 1997, §9.2). Sphere lights
 * are opaque, one-sided emitters seen from outside: a shadow ray that
 * reaches one stops there (it occludes other lights and the environment).
 *
 * HG convention: sample/phase.h (cos θ between light travel directions). A
 * path arrives at x travelling along d; ω points from x towards the light.
 */
#ifndef VOLUX_RENDER_DIRECT_H
#define VOLUX_RENDER_DIRECT_H

#include "lights.h"
#include "sample/phase.h"
#include "sample/tracking.h"

/* One light sample at a vertex: the direction towards the light, the
 * distance to it (INFINITY for directional and environment lights), its
 * radiance (or intensity/irradiance for delta lights) and the weight
 * phase·geometry/pdf·MIS. */
typedef struct volux_light_sample {
    volux_vec3 w;
    float dist;
    volux_vec3 le;
    float weight;
} volux_light_sample;

/* Distance along unit d from o to the outside of a sphere, or −1 if the ray
 * misses it or starts inside it (one-sided emitter). */
static inline float volux_sphere_hit(volux_vec3 o, volux_vec3 d, volux_vec3 c, float radius) {
    volux_vec3 oc = v3_sub(o, c);
    float b = v3_dot(oc, d), cc = v3_dot(oc, oc) - radius * radius;
    if (cc <= 0.0f) return -1.0f;
    float disc = b * b - cc;
    if (disc < 0.0f) return -1.0f;
    float t = -b - sqrtf(disc);
    return t > 0.0f ? t : -1.0f;
}

/* 1 − cos θmax of the cone a sphere light subtends from x (0 if x is
 * inside). Computed as sin²/(1 + cos) to keep precision for small, far
 * spheres. */
static inline float volux_sphere_cone(volux_vec3 x, const volux_prepared_light *l, volux_vec3 *axis, float *dist_c) {
    volux_vec3 to = v3_sub(l->pos, x);
    float d2 = v3_dot(to, to), r2 = l->radius * l->radius;
    if (d2 <= r2) return 0.0f;
    float dc = sqrtf(d2);
    float sin2 = r2 / d2, cos_max = sqrtf(1.0f - sin2);
    if (axis) *axis = v3_scale(to, 1.0f / dc);
    if (dist_c) *dist_c = dc;
    return sin2 / (1.0f + cos_max);
}

static inline float volux_sphere_pdf(float one_minus_cos_max) {
    return one_minus_cos_max > 0.0f ? 1.0f / (2.0f * VOLUX_PI * one_minus_cos_max) : 0.0f;
}

/* Samples light l (directional, point, spot or sphere; not an environment)
 * from x for a path arriving along d, with HG anisotropy g. Returns 0 when
 * the light cannot contribute from x (then *s is undefined). Draws two
 * numbers for a sphere light, none for delta lights. */
static inline int volux_direct_sample(volux_tracker *p, const volux_prepared_light *l, float g, volux_vec3 x,
                                      volux_vec3 d, volux_light_sample *s) {
    switch (l->type) {
    case VOLUX_LIGHT_DIRECTIONAL:
        s->w = v3_scale(l->travel, -1.0f);
        s->dist = INFINITY;
        s->le = l->power;
        s->weight = volux_hg_eval(g, v3_dot(s->w, d));
        return 1;
    case VOLUX_LIGHT_POINT:
    case VOLUX_LIGHT_SPOT: {
        volux_vec3 to = v3_sub(l->pos, x);
        float d2 = v3_dot(to, to);
        if (!(d2 > 0.0f)) return 0;
        s->dist = sqrtf(d2);
        s->w = v3_scale(to, 1.0f / s->dist);
        s->le = l->power;
        float f = 1.0f / d2; /* E = I/r² */
        if (l->type == VOLUX_LIGHT_SPOT) {
            f *= volux_spot_falloff(l->desc, -v3_dot(s->w, l->axis)); /* cos(axis, light→x) */
            if (!(f > 0.0f)) return 0;
        }
        s->weight = volux_hg_eval(g, v3_dot(s->w, d)) * f;
        return 1;
    }
    case VOLUX_LIGHT_SPHERE: {
        volux_vec3 axis;
        float dc;
        float omc = volux_sphere_cone(x, l, &axis, &dc);
        if (!(omc > 0.0f)) return 0;
        float u0, u1;
        if (volux_tracker_ld2(p, VOLUX_LD_LIGHT, &u0, &u1)) s->w = volux_sample_cone(axis, omc, u0, u1);
        else s->w = volux_sample_cone(axis, omc, volux_tracker_rnd(p), volux_tracker_rnd(p));
        /* Distance to the near surface; the sampled direction is inside the
         * cone, so clamp the discriminant against rounding. */
        float b = -v3_dot(v3_scale(axis, dc), s->w);
        float cc = dc * dc - l->radius * l->radius;
        s->dist = -b - sqrtf(fmaxf(b * b - cc, 0.0f));
        float pdf_l = volux_sphere_pdf(omc), f = volux_hg_eval(g, v3_dot(s->w, d));
        s->le = l->radiance;
        s->weight = f * volux_mis_power(pdf_l, f) / pdf_l;
        return 1;
    }
    default: return 0;
    }
}

/* 1 if a sphere light other than lights->all[skip] blocks the segment
 * (x, x + dist·w). */
static inline int volux_sphere_blocks(const volux_light_list *lights, volux_vec3 x, volux_vec3 w, float dist,
                                      int skip) {
    for (int i = 0; i < lights->n_all; i++) {
        const volux_prepared_light *l = &lights->all[i];
        if (i == skip || l->type != VOLUX_LIGHT_SPHERE) continue;
        float t = volux_sphere_hit(x, w, l->pos, l->radius);
        if (t > 0.0f && t < dist) return 1;
    }
    return 0;
}

/* The sample's contribution le·weight·T, with T by ratio tracking (zero if
 * the weight or radiance is zero, or a sphere light other than
 * lights->all[skip] is in the way). */
static inline volux_vec3 volux_direct_shadowed(volux_tracker *p, const volux_light_list *lights, int skip,
                                               volux_vec3 x, const volux_light_sample *s) {
    if (!(s->weight > 0.0f) || !(v3_max_comp(s->le) > 0.0f)) return v3(0, 0, 0);
    if (lights->n_sphere > 0 && volux_sphere_blocks(lights, x, s->w, s->dist, skip)) return v3(0, 0, 0);
    volux_tracker_ld_shadow(p); /* sampler "sobol": the first shadow ray's first step */
    float T = volux_ratio_track(p, x, s->w, s->dist);
    p->ld_pending = 0;
    return T != 0.0f ? v3_scale(s->le, s->weight * T) : v3(0, 0, 0);
}

/* The nearest sphere light (index into lights->all) the ray (o, d) hits
 * before distance t_end, or −1. */
static inline int volux_sphere_nearest(const volux_light_list *lights, volux_vec3 o, volux_vec3 d, float t_end) {
    int nearest = -1;
    float t_near = t_end;
    for (int i = 0; i < lights->n_all && lights->n_sphere > 0; i++) {
        const volux_prepared_light *l = &lights->all[i];
        if (l->type != VOLUX_LIGHT_SPHERE) continue;
        float t = volux_sphere_hit(o, d, l->pos, l->radius);
        if (t > 0.0f && t < t_near) {
            t_near = t;
            nearest = i;
        }
    }
    return nearest;
}

/* Radiance of sphere light l reached from o by a phase-sampled ray of
 * density pdf_phase, MIS-weighted against sampling l's cone from o. */
static inline volux_vec3 volux_sphere_hit_radiance(const volux_prepared_light *l, volux_vec3 o, float pdf_phase) {
    float pdf_l = volux_sphere_pdf(volux_sphere_cone(o, l, NULL, NULL));
    return v3_scale(l->radiance, volux_mis_power(pdf_phase, pdf_l));
}

#endif
