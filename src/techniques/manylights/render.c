/*
 * techniques/manylights/render.c — the image (W13 §3.3, Eq. 5).
 *
 * Per pixel sample, the camera ray is marched once over the segments of
 * sample/segment.h (the scene's LUT, point-sampled at segment ends, empty
 * macrocells skipped, early termination) to find its opacity α = 1 − T;
 * then S positions x_t are drawn along it, stratified, and at each
 *
 *   L_s(x_t) = Σ_lights f·E·T (single scattering, shadow rays marched)
 *            + Σ_VLs  I_j · f_j · f_t · T(x_t, x_j) / (π r² p(Ω_j))   (Eq. 5)
 *
 * is gathered and weighted by the camera transmittance and σs. Positions
 * are stratified in opacity by default (pdf ∝ T·σt, so the weight is
 * α/S·ρ and dense surfaces get their samples); `view_sampling = uniform`
 * spreads them uniformly over the ray's non-empty extent as W13 does
 * (weight (t_last − t_first)/S · T·σt·ρ).
 *
 * Virtual spherical lights (Hašan et al. 2009): the VL's power is spread
 * over a sphere of radius r; one direction ω_s is drawn uniformly in the
 * cone the sphere subtends from x_t, and the geometry term becomes
 * 1/(π r² p(Ω)) = 2(1 − cos θmax)/r² — 1/d² far away, bounded by 2/r²
 * (the hemisphere) when x_t is inside the sphere: W13's regularisation
 * in place of clamping. ω_s enters both phase functions; the
 * transmittance is looked up towards the VL's centre (`cone`), or for a
 * ball point y on the VL's radial ray through x (`ball`, gather_vls).
 * Pixel sample 0 may gather a strided subset (preview_vls, manylights.c)
 * weighted by the stride. Each VL keeps a fixed
 * 2-D pattern and every view sample rotates all patterns by one random
 * offset (Cranley–Patterson), so a VL's cone sample is uniform per pixel
 * sample at the cost of two random numbers per x_t instead of per VL.
 *
 * The VLs gathered are st->draw: set 0, or the pass set begin_pass built
 * for this pixel sample (manylights.c).
 *
 * Random numbers: stream (seed, pixel, sample index, 1) — independent of
 * the thread and tile order. With sampler = "sobol" (sample/sampler.h) the
 * pixel position (slot 0), the march jitter and, for each of the first
 * VOLUX_LD_DEPTH view samples k, its stratum offset, its first two-number
 * light draw and its VL-pattern offset come from padded Sobol pairs of
 * event k instead.
 */
#include <math.h>

#include "core/rng.h"
#include "avsm.h"
#include "sample/phase.h"
#include "sample/sampler.h"

/* The pair of `use` for view sample k (sampler "sobol", k below
 * VOLUX_LD_DEPTH): 1 and the pair, else 0 and the caller draws from the
 * stream (the independent sampler's draws exactly). */
static inline int ld2(const volux_sampler *ld, int k, int use, float *u, float *v) {
    if (!ld->on || k >= VOLUX_LD_DEPTH) return 0;
    volux_sampler_2d(ld, volux_sampler_slot(k, use), u, v);
    return 1;
}

/* ------------------------------------------------------------------ single scattering */

static inline float shadow_T(const ml_state *st, volux_vec3 x, volux_vec3 w, float dist) {
    if (!(st->xi > 0.0f)) return 1.0f;
    return expf(-st->xi * ml_tau1(st, x, w, dist, 30.0f / st->xi));
}

/* In-scattered radiance per unit σs at x from the real lights, for light
 * leaving towards the camera along −d. */
static volux_vec3 single_scatter(const ml_state *st, volux_vec3 x, volux_vec3 d, volux_rng *rng,
                                 const volux_sampler *ld, int k) {
    volux_vec3 L = v3(0, 0, 0);
    int ld_light = 0; /* the first light that draws two numbers takes the pair */
    float g = st->rc.g;
    for (int i = 0; i < st->rc.lights.n_all; i++) {
        const volux_prepared_light *l = &st->rc.lights.all[i];
        switch (l->type) {
        case VOLUX_LIGHT_DIRECTIONAL:
        case VOLUX_LIGHT_POINT:
        case VOLUX_LIGHT_SPOT: {
            volux_vec3 travel;
            volux_vec3 E = volux_light_irradiance(l, x, &travel);
            if (!(v3_max_comp(E) > 0.0f)) break;
            float dist = l->positional ? v3_length(v3_sub(l->pos, x)) : INFINITY;
            float f = volux_hg_eval(g, -v3_dot(travel, d));
            L = v3_madd(L, E, f * shadow_T(st, x, v3_scale(travel, -1.0f), dist));
            break;
        }
        case VOLUX_LIGHT_SPHERE: {
            /* one direction uniform in the cone of the sphere */
            volux_vec3 to = v3_sub(l->pos, x);
            float d2 = v3_dot(to, to), r2 = l->radius * l->radius;
            float u0, u1;
            if (ld_light++ || !ld2(ld, k, VOLUX_LD_LIGHT, &u0, &u1)) u0 = volux_rng_float(rng), u1 = volux_rng_float(rng);
            if (d2 <= r2) break;
            float dc = sqrtf(d2), sin2 = r2 / d2, omc = sin2 / (1.0f + sqrtf(1.0f - sin2));
            volux_vec3 axis = v3_scale(to, 1.0f / dc);
            volux_vec3 w = v3_normalize(volux_sample_cone(axis, omc, u0, u1));
            float b = -dc * v3_dot(axis, w), cc = d2 - r2;
            float dist = -b - sqrtf(fmaxf(b * b - cc, 0.0f));
            float f = volux_hg_eval(g, v3_dot(w, d));
            L = v3_madd(L, l->radiance, f * 2.0f * VOLUX_PI * omc * shadow_T(st, x, w, dist));
            break;
        }
        case VOLUX_LIGHT_ENVIRONMENT: {
            float u0, u1, pdf;
            if (ld_light++ || !ld2(ld, k, VOLUX_LD_LIGHT, &u0, &u1)) u0 = volux_rng_float(rng), u1 = volux_rng_float(rng);
            volux_vec3 w;
            if (l->desc->map) {
                pdf = volux_envmap_sample(&st->env[l->slot], l->desc, u0, u1, &w);
                if (!(pdf > 0.0f)) break;
            } else {
                w = volux_sample_sphere(u0, u1);
                pdf = VOLUX_INV_4PI;
            }
            float f = volux_hg_eval(g, v3_dot(w, d));
            L = v3_madd(L, volux_environment_radiance(l->desc, w), f / pdf * shadow_T(st, x, w, INFINITY));
            break;
        }
        }
    }
    return L;
}

/* ------------------------------------------------------------------ virtual lights (Eq. 5) */

/* The `ball` kernel: the mean of 1/|x − y|² over y uniform in the VSL's
 * ball of radius r at distance d from its centre,
 *   G(d) = 3/(2r³d) · (r·d + ½(r² − d²)·ln|(d + r)/(d − r)|),
 * 1/d² + r²/(5d⁴) + … far away and 3/r² at the centre. Smearing a VL's
 * power over a ball (instead of Eq. 5's 2(1 − cos θmax)/r², which loses
 * the energy the clamp cuts) keeps the total it sends out. Far away the
 * series is used (relative error < 2·10⁻⁴ beyond 3r). */
float ml_ball_geometry(float d, float r) {
    float x = r / d;
    if (x < 1.0f / 3.0f) {
        float x2 = x * x;
        return (1.0f + x2 * (0.2f + x2 * (3.0f / 35.0f))) / (d * d);
    }
    if (d < 1e-6f * r) return 3.0f / (r * r);
    float lg = logf(fabsf((d + r) / (d - r)));
    if (!isfinite(lg)) return 1.5f / (r * r); /* d = r */
    return 1.5f / (r * r * r * d) * (r * d + 0.5f * (r * r - d * d) * lg);
}

typedef struct gather_offset {
    float u, c, s, w; /* pattern rotation of this view sample */
    int first;        /* the first VL gathered (then every st->draw_stride-th) */
} gather_offset;

static inline __attribute__((always_inline)) volux_vec3 gather_vls(const ml_state *st, volux_vec3 x, volux_vec3 d,
                                                                   gather_offset off, int tmode, int iso, int ball) {
    float r = st->radius, r2 = r * r, two_inv_r2 = 2.0f / r2, g = st->rc.g;
    float hg_a = VOLUX_INV_4PI * (1.0f - g * g), hg_b = 1.0f + g * g, hg_c = 2.0f * g;
    float acc_r = 0.0f, acc_g = 0.0f, acc_b = 0.0f;
    const float iso_f = VOLUX_INV_4PI * VOLUX_INV_4PI;
    const float clamp = st->clamp_fg;
    const int stride = st->draw_stride;
    for (int j = off.first; j < st->n_draw; j += stride) {
        const ml_rvl *v = &st->draw[j];
        volux_vec3 vj = v3(x.x - v->px, x.y - v->py, x.z - v->pz); /* VL → x */
        float d2 = v3_dot(vj, vj);
        if (!(d2 > 0.0f)) continue;
        float dist = sqrtf(d2);
        float u = v->cone_u + off.u;
        u = u >= 1.0f ? u - 1.0f : u;
        float ct, G, s = 0.0f;
        if (ball) {
            float wv = v->cone_w + off.w;
            wv = wv >= 1.0f ? wv - 1.0f : wv;
            G = ml_vsl_ball(dist, r, u, wv, &ct, &s);
        } else {
            float omc = d2 > r2 ? (r2 / d2) / (1.0f + sqrtf(1.0f - r2 / d2)) : 1.0f;
            ct = 1.0f - u * omc;
            G = omc * two_inv_r2;
        }
        /* ω_s: cosine ct to the axis x → VL, the pattern's azimuth */
        volux_vec3 ws = v3(0, 0, 0);
        if (!iso) {
            volux_vec3 a = v3_scale(vj, -1.0f / dist), t, b;
            v3_basis(a, &t, &b);
            float stt = sqrtf(fmaxf(0.0f, 1.0f - ct * ct));
            float cp = v->cone_c * off.c - v->cone_s * off.s, sp = v->cone_s * off.c + v->cone_c * off.s;
            ws = v3_add(v3_scale(a, ct), v3_add(v3_scale(t, stt * cp), v3_scale(b, stt * sp)));
        }
        float T;
        if (!ball) {
            /* Eq. 5: towards the VL's centre */
            if (tmode == ML_T_AVSM) T = ml_avsm_point(st, v->avsm, vj, dist);
            else if (tmode == ML_T_AVSM_LINEAR) T = ml_avsm_trilinear(st, v->avsm, vj, dist);
            else T = ml_raymarch_T(st, v3(v->px, v->py, v->pz), vj, dist);
        } else {
            /* The ball kernel's transmittance (the model, not an
             * approximation of it): along the VL's radial ray through x,
             * between the depths of x and of y's projection onto that ray
             * — what one texel ray of the VL's AVSM holds, so `raymarch`
             * marches exactly what the cache stores and the AVSM check
             * measures the cache alone. Far from the ball (d ≫ r) this is
             * T(y, x); inside it the projected segment is shorter than
             * |x − y|, and taking T from the centre instead was 0.41–0.69
             * of pathtrace's brightness on the CTs (docs §0). */
            float dy = fmaxf(dist - s * ct, 0.0f), lo = fminf(dist, dy), hi = fmaxf(dist, dy);
            if (tmode == ML_T_RAYMARCH) {
                volux_vec3 a = v3_scale(vj, 1.0f / dist);
                T = ml_raymarch_T(st, v3(v->px + a.x * lo, v->py + a.y * lo, v->pz + a.z * lo), v3_scale(a, hi - lo),
                                  hi - lo);
            } else if (tmode == ML_T_AVSM) {
                T = ml_avsm_between(st, v->avsm, vj, lo, hi);
            } else {
                float th = ml_avsm_trilinear(st, v->avsm, vj, hi);
                float tl = lo > 0.0f ? ml_avsm_trilinear(st, v->avsm, vj, lo) : 1.0f;
                T = tl > 0.0f ? fminf(th / tl, 1.0f) : 0.0f;
            }
        }
        if (!(T > 0.0f)) continue;
        float f;
        if (iso) {
            f = iso_f;
        } else {
            /* light travels VL → x (−ω_s) and then towards the camera (−d) */
            float cos_t = v3_dot(ws, d), cos_j = -(v->wx * ws.x + v->wy * ws.y + v->wz * ws.z);
            float dt = hg_b - hg_c * cos_t, dj = hg_b - hg_c * cos_j;
            dt = dt < 1e-12f ? 1e-12f : dt;
            dj = dj < 1e-12f ? 1e-12f : dj;
            f = hg_a * hg_a / (dt * sqrtf(dt) * dj * sqrtf(dj));
        }
        float fg = f * G;
        fg = fg < clamp ? fg : clamp;
        float w = fg * T;
        acc_r += v->ir * w;
        acc_g += v->ig * w;
        acc_b += v->ib * w;
    }
    return v3_scale(v3(acc_r, acc_g, acc_b), (float)stride);
}

static volux_vec3 gather(const ml_state *st, volux_vec3 x, volux_vec3 d, gather_offset off) {
    int iso = fabsf(st->rc.g) < VOLUX_HG_ISOTROPIC_EPS, ball = st->ball;
#define ML_GATHER_CASE(T)                                                                                      \
    case T * 4: return gather_vls(st, x, d, off, T, 0, 0);                                                     \
    case T * 4 + 1: return gather_vls(st, x, d, off, T, 1, 0);                                                 \
    case T * 4 + 2: return gather_vls(st, x, d, off, T, 0, 1);                                                 \
    case T * 4 + 3: return gather_vls(st, x, d, off, T, 1, 1);
    switch (st->tmode * 4 + ball * 2 + iso) {
        ML_GATHER_CASE(ML_T_AVSM)
        ML_GATHER_CASE(ML_T_AVSM_LINEAR)
        ML_GATHER_CASE(ML_T_RAYMARCH)
    }
#undef ML_GATHER_CASE
    return v3(0, 0, 0);
}

/* ------------------------------------------------------------------ the camera ray */

#define ML_MAX_SAMPLES 1024

typedef struct march_state {
    volux_segments seg;
    volux_march_iter it;
} march_state;

/* Next non-empty segment (a, b] with its extinction (point-sampled at b). */
static inline int next_segment(const ml_state *st, march_state *m, const volux_ray *ray, float *a, float *b,
                               float *sigma, uint64_t *samples) {
    int gap;
    while (volux_segments_next(&m->seg, a, b, &gap)) {
        volux_vec3 q = v3_madd(ray->q0, ray->dq, *b);
        float s = volux_volume_sample_index(st->rc.volume, q.x, q.y, q.z);
        (*samples)++;
        *sigma = volux_lut_sigma(st->rc.lut, s);
        if (*sigma > 0.0f) return 1;
    }
    return 0;
}

/* Radiance scattered towards the camera along the clipped ray; *T_out is
 * the camera ray's transmittance (for the escape radiance). */
static volux_vec3 integrate(const ml_state *st, const volux_ray *ray, float jitter, volux_rng *rng,
                            const volux_sampler *ld, float *T_out, uint64_t *samples) {
    const volux_majorant_grid *grid = &st->rc.grid;
    march_state m;
    float a, b, sigma, T = 1.0f, t_first = -1.0f, t_last = 0.0f;
    /* Pass 1: opacity and non-empty extent up to early termination. */
    volux_segments_init(&m.seg, &m.it, grid, ray, st->rc.step, jitter);
    while (next_segment(st, &m, ray, &a, &b, &sigma, samples)) {
        if (t_first < 0.0f) t_first = a;
        t_last = b;
        T *= expf(-sigma * (b - a));
        if (T < st->t_min) break;
    }
    *T_out = T;
    float alpha = 1.0f - T;
    if (!(alpha > 0.0f)) return v3(0, 0, 0);

    /* Stratified targets (opacity or distance), ascending. */
    int S = st->samples_now;
    float target[ML_MAX_SAMPLES];
    float span = st->view_uniform ? t_last - t_first : alpha;
    for (int k = 0; k < S; k++) {
        float u, unused;
        if (!ld2(ld, k, VOLUX_LD_FLIGHT, &u, &unused)) u = volux_rng_float(rng);
        target[k] = span * ((float)k + u) / (float)S;
    }

    /* Pass 2: the same segments; each target lands in one of them. */
    volux_vec3 C = v3(0, 0, 0);
    int k = 0;
    float Ta = 1.0f;
    volux_segments_init(&m.seg, &m.it, grid, ray, st->rc.step, jitter);
    while (k < S && next_segment(st, &m, ray, &a, &b, &sigma, samples)) {
        float len = b - a, Tb = Ta * expf(-sigma * len);
        for (; k < S; k++) {
            float t, weight;
            if (st->view_uniform) {
                float tk = t_first + target[k];
                if (tk < a) continue; /* in an empty gap: σt = 0 there */
                if (tk > b) break;
                t = tk;
                weight = span / (float)S * Ta * expf(-sigma * (t - a)) * sigma;
            } else {
                float ok = target[k];
                if (ok > 1.0f - Tb) break;
                /* 1 − Ta·e^{−σ(t−a)} = ok */
                float fr = -logf((1.0f - ok) / Ta) / (sigma * len);
                t = a + clampf(fr, 0.0f, 1.0f) * len;
                weight = alpha / (float)S;
            }
            /* σt was read at b, so the segment stands for the midpoint
             * cell (b − len/2, b + len/2] of that sample (the ray casters
             * light and colour a segment at b too). Placing x in (a, b]
             * instead put the light half a step in front of the medium it
             * weights: +8 % (step 0.5) … +2 % (0.05) against pathtrace on
             * a lit cloud, gone with this shift. */
            t = fminf(t + 0.5f * len, ray->t1); /* the last cell stops at the box */
            volux_vec3 x = v3_madd(ray->o, ray->d, t);
            volux_vec3 q = v3_madd(ray->q0, ray->dq, t);
            float rgba[4];
            volux_lut_rgba(st->rc.lut, volux_volume_sample_index(st->rc.volume, q.x, q.y, q.z), rgba);
            volux_vec3 rho = v3_scale(v3(rgba[0], rgba[1], rgba[2]), st->rc.albedo * weight);
            volux_vec3 Ls = v3(0, 0, 0);
            float u, phi, uw, unused;
            if (ld2(ld, k, VOLUX_LD_PHASE, &u, &phi) && ld2(ld, k, VOLUX_LD_ROULETTE, &uw, &unused)) {
                phi *= 2.0f * VOLUX_PI;
            } else {
                u = volux_rng_float(rng), phi = 2.0f * VOLUX_PI * volux_rng_float(rng), uw = volux_rng_float(rng);
            }
            if (st->single_on) Ls = single_scatter(st, x, ray->d, rng, ld, k);
            if (st->multi_on && st->n_draw > 0) {
                int first = st->draw_stride > 1 ? (int)(volux_rng_float(rng) * (float)st->draw_stride) : 0;
                gather_offset off = {u, cosf(phi), sinf(phi), uw, first < st->draw_stride ? first : 0};
                Ls = v3_add(Ls, gather(st, x, ray->d, off));
            }
            C = v3_add(C, v3_mul(rho, Ls));
        }
        Ta = Tb;
        if (Ta < st->t_min) break;
    }
    return C;
}

void ml_render_tile(const void *state, const volux_scene *scene, const volux_tile *tile, float *rgb,
                    volux_tile_stats *stats) {
    const ml_state *st = state;
    const volux_camera *cam = &st->rc.camera;
    uint64_t samples = 0;
    for (int y = 0; y < tile->h; y++)
        for (int x = 0; x < tile->w; x++) {
            int px = tile->x0 + x, py = tile->y0 + y;
            uint64_t pixel = (uint64_t)py * (uint64_t)cam->width + (uint64_t)px;
            volux_sampler ld = volux_sampler_make(st->sampler, st->rc.seed, pixel, tile->sample_index);
            volux_primary pr;
            if (ld.on) { /* every sample uniform over the pixel, sample 0 too */
                float jx, jy, unused;
                volux_sampler_2d(&ld, 0, &jx, &jy);
                volux_camera_ray(cam, (float)px + jx, (float)py + jy, &pr.o, &pr.d);
                ld2(&ld, 0, VOLUX_LD_CHOICE, &pr.jitter, &unused);
            } else {
                pr = volux_primary_ray(cam, st->rc.seed, px, py, tile->sample_index);
            }
            volux_vec3 bg = volux_scene_escape_radiance(scene, pr.d);
            float *out = &rgb[3 * (y * tile->w + x)];
            volux_ray ray;
            if (!volux_ray_clip(st->rc.volume, pr.o, pr.d, &ray)) {
                out[0] = bg.x, out[1] = bg.y, out[2] = bg.z;
                continue;
            }
            volux_rng rng = volux_rng_make(st->rc.seed, pixel, tile->sample_index, 1);
            float T;
            volux_vec3 c = integrate(st, &ray, pr.jitter, &rng, &ld, &T, &samples);
            out[0] = c.x + T * bg.x;
            out[1] = c.y + T * bg.y;
            out[2] = c.z + T * bg.z;
        }
    stats->samples += samples;
}
