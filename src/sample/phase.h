/*
 * sample/phase.h — the Henyey–Greenstein phase function: evaluation and
 * exact importance sampling.
 *
 * CONVENTION. cos_theta is the cosine of the *scattering angle*: the angle
 * between the direction the light travels before the scattering event and
 * the direction it travels after it. g > 0 is forward scattering (light
 * keeps going roughly the way it went), g < 0 backward, g = 0 isotropic:
 *
 *     p(cos θ) = (1 − g²) / (4π (1 + g² − 2g cos θ)^{3/2})     [1/sr]
 *
 * (Henyey & Greenstein 1941; pbrt 4th ed. Eq. 11.12 with their cos θ taken
 * between the travel directions.) ∫ p dω = 1 and the mean cosine is g.
 *
 * In a path tracer that follows camera paths backwards, a path arriving at
 * x along d (from the camera) and continuing towards the light along ω has
 * light travelling −ω then −d, so cos θ = dot(−ω, −d) = dot(ω, d):
 * volux_hg_sample(g, d, ...) returns ω with dot(ω, d) distributed by p.
 */
#ifndef VOLUX_PHASE_H
#define VOLUX_PHASE_H

#include <math.h>

#include "core/vecmath.h"

/* Below this |g| the function is treated as isotropic (the sampling formula
 * divides by g). */
#define VOLUX_HG_ISOTROPIC_EPS 1e-3f

static inline float volux_hg_eval(float g, float cos_theta) {
    float denom = 1.0f + g * g - 2.0f * g * cos_theta;
    if (denom < 1e-12f) denom = 1e-12f;
    return VOLUX_INV_4PI * (1.0f - g * g) / (denom * sqrtf(denom));
}

/* cos θ distributed by p: the inverse of the HG cumulative distribution in
 * cos θ, P(cos θ ≤ μ) = (1 − g²)/(2g)·[(1 + g² − 2gμ)^{-1/2} − 1/(1 + g)],
 * solved for μ at P = u. */
static inline float volux_hg_sample_cos(float g, float u) {
    if (fabsf(g) < VOLUX_HG_ISOTROPIC_EPS) return 1.0f - 2.0f * u;
    float s = (1.0f - g * g) / (1.0f - g + 2.0f * g * u);
    float c = (1.0f + g * g - s * s) / (2.0f * g);
    return clampf(c, -1.0f, 1.0f);
}

/* Samples a direction ω around the unit vector d with dot(ω, d) = cos θ
 * drawn from p and a uniform azimuth. Writes the density (solid angle) to
 * *pdf; it equals volux_hg_eval(g, dot(ω, d)). */
static inline volux_vec3 volux_hg_sample(float g, volux_vec3 d, float u0, float u1, float *pdf) {
    float ct = volux_hg_sample_cos(g, u0);
    float st = sqrtf(fmaxf(0.0f, 1.0f - ct * ct));
    float phi = 2.0f * VOLUX_PI * u1;
    volux_vec3 t, b;
    v3_basis(d, &t, &b);
    volux_vec3 w = v3_add(v3_scale(d, ct), v3_add(v3_scale(t, st * cosf(phi)), v3_scale(b, st * sinf(phi))));
    *pdf = volux_hg_eval(g, ct);
    /* renormalise: paths chain hundreds of these, and tracking measures
     * distance in units of |w| */
    return v3_normalize(w);
}

/* Uniform direction on the unit sphere (pdf 1/(4π)). */
static inline volux_vec3 volux_sample_sphere(float u0, float u1) {
    float z = 1.0f - 2.0f * u0;
    float r = sqrtf(fmaxf(0.0f, 1.0f - z * z));
    float phi = 2.0f * VOLUX_PI * u1;
    return v3(r * cosf(phi), r * sinf(phi), z);
}

/* Uniform direction in the cone of half-angle θmax around unit axis a, given
 * one_minus_cos_max = 1 − cos θmax (passed in this form because for small,
 * distant spheres it is computed stably as sin²/(1 + cos)). pdf is
 * 1/(2π (1 − cos θmax)). */
static inline volux_vec3 volux_sample_cone(volux_vec3 a, float one_minus_cos_max, float u0, float u1) {
    float omc = u0 * one_minus_cos_max; /* 1 − cos θ, uniform in [0, 1 − cos θmax] */
    float ct = 1.0f - omc;
    float st = sqrtf(fmaxf(0.0f, omc * (2.0f - omc)));
    float phi = 2.0f * VOLUX_PI * u1;
    volux_vec3 t, b;
    v3_basis(a, &t, &b);
    return v3_add(v3_scale(a, ct), v3_add(v3_scale(t, st * cosf(phi)), v3_scale(b, st * sinf(phi))));
}

/* Power heuristic with β = 2 (Veach 1997, Eq. 9.13) for strategy a against b,
 * one sample each. */
static inline float volux_mis_power(float pdf_a, float pdf_b) {
    float a = pdf_a * pdf_a, b = pdf_b * pdf_b;
    return a > 0.0f ? a / (a + b) : 0.0f;
}

#endif
