/*
 * techniques/manylights/vl.c — light subpaths and their virtual lights
 * (W13 §3.1–3.2, §4.1, §5).
 *
 * A light's subpaths form a stream: path p draws its random numbers from
 * the counter-based generator keyed by (seed, light slot, p), so the VLs of
 * a light depend on nothing but the scene and the path index — not on the
 * thread count, not on the other lights, not on how many paths came
 * before. A light traces paths 0, 1, … until it holds its share (`quota`)
 * of the VLs; paths that leave the volume without a collision count as
 * started paths (the estimator divides by paths, W13 Eq. 4's N being the
 * number of light subpaths) but leave no VL.
 *
 * Per path (W13 §3.1):
 *   1. an origin and direction on the light (per type, below) and the
 *      emission weight w0 = (geometry · map radiance)/pdf per unit of the
 *      light's strength, so colour/strength edits only rescale;
 *   2. the segment length by delta tracking (Woodcock et al. 1965, W13
 *      Alg. 1 in its exact form) against the unscaled macrocell majorants
 *      times a scale S: S = the scene's density scale ξ, or, with the Eq. 8
 *      placement, S_min or S_max with probability ½ each — a sample of the
 *      density −dT̄/dt of the mean transmittance T̄ = ½(T^Smin + T^Smax);
 *   3. a VL at the collision;
 *   4. Russian roulette with a fixed survival probability (not the
 *      throughput: see docs, "deviations" — this keeps VL positions
 *      independent of colour, albedo, light strength and density);
 *   5. a new direction by HG importance sampling (or uniform, §5.2).
 *
 * Weights (Eq. 6, with the pdf the vertex was actually sampled with):
 *   β_1 = L_e·w0,  β_in,k = β_k · ξσ1(x_k)·e^{−ξ τ1,k} / p_k(t),
 *   I_k = ρ(x_k)·β_in,k / P,  β_{k+1} = β_in,k·ρ(x_k)·f_g(cos θ_k)/(p_ω·q),
 * ρ = albedo·c(s) (DESIGN §2). With the stored sampling density p_k the
 * re-weighted set stays an unbiased estimate wherever the old density
 * covers the new medium (W13 writes p_new; see docs).
 */
#include <math.h>
#include <string.h>

#include "core/context_internal.h"
#include "core/rng.h"
#include "manylights.h"
#include "sample/phase.h"
#include "sample/regular_tracking.h"

#define ML_SEED_SALT 0x6d616e796c696768ull /* "manyligh" */

/* Paths a light may start before giving up on its quota (a TF without
 * extinction, a light that misses the volume). */
static int path_cap(int quota) { return quota > 1000000 ? 64000000 : 64 * quota + 1024; }

volux_vec3 ml_light_scale(const volux_light_desc *d) {
    switch (d->type) {
    case VOLUX_LIGHT_DIRECTIONAL: return v3_scale(d->color, d->irradiance);
    case VOLUX_LIGHT_SPHERE: return v3_scale(d->color, d->radiance);
    case VOLUX_LIGHT_ENVIRONMENT: return v3_scale(d->color, d->map ? d->intensity : d->radiance);
    default: return v3_scale(d->color, d->intensity);
    }
}

/* σ1 at an index-space point (clamped into the node box) and its scalar. */
static inline float sigma1_index(const ml_state *st, volux_vec3 q, float *s_out) {
    const volux_volume *v = st->rc.volume;
    float mx = (float)(v->dims[0] - 1), my = (float)(v->dims[1] - 1), mz = (float)(v->dims[2] - 1);
    q.x = q.x < 0.0f ? 0.0f : (q.x > mx ? mx : q.x);
    q.y = q.y < 0.0f ? 0.0f : (q.y > my ? my : q.y);
    q.z = q.z < 0.0f ? 0.0f : (q.z > mz ? mz : q.z);
    float s = volux_volume_sample_index(v, q.x, q.y, q.z);
    if (s_out) *s_out = s;
    return volux_lut_sigma(&st->lut1, s);
}

float ml_sigma1_at(const ml_state *st, volux_vec3 p, float *s_out) {
    volux_vec3 q = volux_volume_to_index(st->rc.volume, p);
    if (!volux_volume_inside_index(st->rc.volume, q)) {
        if (s_out) *s_out = 0.0f;
        return 0.0f;
    }
    return sigma1_index(st, q, s_out);
}

float ml_tau1(const ml_state *st, volux_vec3 o, volux_vec3 d, float len, float tau_stop) {
    volux_ray ray;
    if (!volux_ray_clip(st->rc.volume, o, d, &ray)) return 0.0f;
    float t1 = ray.t1 < len ? ray.t1 : len, h = st->h;
    if (!(t1 > ray.t0)) return 0.0f;
    volux_march_iter it;
    volux_march_init(&it, &st->grid1, &ray, ray.t0, t1);
    volux_interval iv;
    float tau = 0.0f;
    while (volux_march_next(&it, &iv)) {
        if (!(iv.sigma_max > 0.0f)) continue;
        /* midpoint rule on the fixed segments [i·h, (i+1)·h] from o */
        for (int i = (int)floorf(iv.t0 / h);; i++) {
            float a = (float)i * h, e = a + h;
            if (a >= iv.t1) break;
            if (a < iv.t0) a = iv.t0;
            if (e > iv.t1) e = iv.t1;
            if (!(e > a)) continue;
            tau += sigma1_index(st, v3_madd(ray.q0, ray.dq, 0.5f * (a + e)), NULL) * (e - a);
        }
        if (tau > tau_stop) break;
    }
    return tau;
}

/* ------------------------------------------------------------------ emission (step 1) */

/* Uniform point on a disk of radius R perpendicular to unit n. */
static volux_vec3 disk_point(volux_vec3 n, float R, float u0, float u1) {
    volux_vec3 t, b;
    v3_basis(n, &t, &b);
    float r = R * sqrtf(u0), phi = 2.0f * VOLUX_PI * u1;
    return v3_add(v3_scale(t, r * cosf(phi)), v3_scale(b, r * sinf(phi)));
}

/* 1 − cos of the half-angle of the cone from p that holds the bounding
 * sphere (0: p is inside it). */
static float bound_cone(const ml_state *st, volux_vec3 p, volux_vec3 *axis) {
    volux_vec3 to = v3_sub(st->center, p);
    float d2 = v3_dot(to, to), r2 = st->bound_r * st->bound_r;
    if (d2 <= r2) return 0.0f;
    float d = sqrtf(d2), sin2 = r2 / d2;
    *axis = v3_scale(to, 1.0f / d);
    return sin2 / (1.0f + sqrtf(1.0f - sin2));
}

/* Origin o, unit travel direction d and emission weight w0 per unit light
 * strength of a new subpath; returns 0 if the sample carries nothing. */
static int sample_emission(const ml_state *st, const volux_prepared_light *l, volux_rng *rng, volux_vec3 *o,
                           volux_vec3 *d, volux_vec3 *w0) {
    float R = st->bound_r;
    float u0 = volux_rng_float(rng), u1 = volux_rng_float(rng), u2 = volux_rng_float(rng),
          u3 = volux_rng_float(rng);
    switch (l->type) {
    case VOLUX_LIGHT_DIRECTIONAL: {
        /* Uniform over the disk that covers the bounding sphere: flux
         * E·πR² per path. */
        *d = l->travel;
        *o = v3_add(v3_madd(st->center, l->travel, -1.01f * R), disk_point(l->travel, R, u0, u1));
        *w0 = v3(VOLUX_PI * R * R, VOLUX_PI * R * R, VOLUX_PI * R * R);
        return 1;
    }
    case VOLUX_LIGHT_POINT:
    case VOLUX_LIGHT_SPOT: {
        /* Uniform in the narrower of the cone towards the bounding sphere
         * and the spot cone (both hold every direction that can reach the
         * volume with non-zero intensity): I·Ω·falloff per path. */
        volux_vec3 axis;
        float omc = bound_cone(st, l->pos, &axis);
        if (omc <= 0.0f) {
            omc = 2.0f; /* inside the sphere: all directions */
            axis = v3(0, 0, 1);
        }
        if (l->spot) {
            float spot_omc = 1.0f - cosf(l->desc->cone_angle_deg * VOLUX_PI / 180.0f);
            if (spot_omc < omc) {
                omc = spot_omc;
                axis = l->axis;
            }
        }
        *d = v3_normalize(volux_sample_cone(axis, omc, u0, u1));
        float f = 2.0f * VOLUX_PI * omc;
        if (l->spot) f *= volux_spot_falloff(l->desc, v3_dot(*d, l->axis));
        if (!(f > 0.0f)) return 0;
        *o = l->pos;
        *w0 = v3(f, f, f);
        return 1;
    }
    case VOLUX_LIGHT_SPHERE: {
        /* Uniform point on the surface, cosine-weighted outward direction:
         * flux L·π·4πr² per path. */
        volux_vec3 n = volux_sample_sphere(u0, u1), t, b;
        v3_basis(n, &t, &b);
        float r = sqrtf(u2), phi = 2.0f * VOLUX_PI * u3, z = sqrtf(fmaxf(0.0f, 1.0f - u2));
        *d = v3_normalize(v3_add(v3_scale(n, z), v3_add(v3_scale(t, r * cosf(phi)), v3_scale(b, r * sinf(phi)))));
        *o = v3_madd(l->pos, n, l->radius);
        float f = 4.0f * VOLUX_PI * VOLUX_PI * l->radius * l->radius;
        *w0 = v3(f, f, f);
        return 1;
    }
    case VOLUX_LIGHT_ENVIRONMENT: {
        /* A direction towards the environment by its sampling table (the
         * map's own texels, not colour or intensity), then the disk across
         * the bounding sphere: L(ω)·πR²/p(ω) per path. */
        volux_vec3 w;
        float pdf;
        if (l->desc->map) {
            pdf = volux_envmap_sample(&st->env[l->slot], l->desc, u0, u1, &w);
            if (!(pdf > 0.0f)) return 0;
        } else {
            w = volux_sample_sphere(u0, u1);
            pdf = VOLUX_INV_4PI;
        }
        volux_light_desc unit = *l->desc;
        unit.color = v3(1, 1, 1);
        unit.intensity = unit.radiance = 1.0f;
        volux_vec3 L = volux_environment_radiance(&unit, w);
        if (!(v3_max_comp(L) > 0.0f)) return 0;
        *d = v3_scale(w, -1.0f);
        *o = v3_add(v3_madd(st->center, w, 1.01f * R), disk_point(w, R, u2, u3));
        *w0 = v3_scale(L, VOLUX_PI * R * R / pdf);
        return 1;
    }
    }
    return 0;
}

/* ------------------------------------------------------------------ distance (step 2) */

/* Regular tracking over [t, t1] (sample/regular_tracking.h) where delta
 * tracking would take too many steps or cannot move t: the first collision
 * with optical depth −ln(1 − u). */
static int track_regular(const ml_state *st, const volux_ray *r, float scale, volux_rng *rng, float t, float t1,
                         float *t_hit) {
    volux_track_steps steps;
    volux_track_steps_init(&steps, t, t1, st->rc.min_spacing);
    float target = -logf(1.0f - volux_rng_float(rng)), a, b, mid;
    while (volux_track_steps_next(&steps, &a, &b, &mid)) {
        float sigma = scale * sigma1_index(st, v3_madd(r->q0, r->dq, mid), NULL), tau = sigma * (b - a);
        if (tau >= target) {
            *t_hit = volux_track_hit(a, b, sigma, target);
            return 1;
        }
        target -= tau;
    }
    return 0;
}

/* Delta tracking along the clipped ray r against the unscaled majorants
 * times `scale`: returns 1 and the collision distance, 0 if the particle
 * leaves the volume. Always advances or ends on media of any density (the
 * regular-tracking fallback of sample/tracking.h). */
static int track(const ml_state *st, const volux_ray *r, float scale, volux_rng *rng, float *t_hit) {
    volux_march_iter it;
    volux_interval iv;
    volux_march_init(&it, &st->grid1, r, r->t0, r->t1);
    while (volux_march_next(&it, &iv)) {
        float smax = iv.sigma_max * scale;
        if (!(smax > 0.0f)) continue;
        if (volux_track_needs_regular(smax, iv.t0, iv.t1)) {
            if (track_regular(st, r, scale, rng, iv.t0, iv.t1, t_hit)) return 1;
            continue;
        }
        float inv = 1.0f / smax, t = iv.t0;
        for (;;) {
            float tn = t + -logf(1.0f - volux_rng_float(rng)) * inv;
            if (tn >= iv.t1) break; /* memoryless: go on in the next cell */
            if (!(tn > t) && volux_track_stalled(t, inv)) { /* steps below half an ulp of t */
                if (track_regular(st, r, scale, rng, t, iv.t1, t_hit)) return 1;
                break;
            }
            t = tn;
            float sigma = scale * sigma1_index(st, v3_madd(r->q0, r->dq, t), NULL);
            if (volux_rng_float(rng) * smax < sigma) {
                *t_hit = t;
                return 1;
            }
        }
    }
    return 0;
}

/* log of the density a distance was sampled with: scale·σ1·e^{−scale·τ1},
 * or the Eq. 8 mixture ½Σ_{S∈{Smin,Smax}} S·σ1·e^{−S·τ1} (in logs, so long
 * dense segments do not underflow). */
static double log_pdf_t(const ml_state *st, const ml_vl *v) {
    double sig = v->sigma1_s, tau = v->tau1_s;
    if (v->scale_s > 0.0f) return log((double)v->scale_s * sig) - (double)v->scale_s * tau;
    double a = st->dmin, b = st->dmax;
    return log(sig) - a * tau + log(0.5 * (a + b * exp(-(b - a) * tau)));
}

/* ------------------------------------------------------------------ paths */

static volux_status grow(volux_context *ctx, ml_list *l, int need) {
    if (need <= l->cap) return VOLUX_OK;
    int cap = l->cap ? l->cap : 64;
    while (cap < need) cap *= 2;
    ml_vl *v = volux_realloc(ctx, l->v, sizeof *v * (size_t)l->cap, sizeof *v * (size_t)cap);
    if (!v) return volux_error(ctx, VOLUX_ERR_NOMEM, "manylights: out of memory for %d virtual lights", cap);
    l->v = v;
    l->cap = cap;
    return VOLUX_OK;
}

/* Appends the VLs of stream path p (at most max_len; room is reserved). */
static void trace_path(const ml_state *st, const volux_prepared_light *l, int set_index, int p, int max_len,
                       ml_list *list) {
    /* stream 3 for set 0 (the interactive set), 3 + 256·k for pass set k */
    volux_rng rng = volux_rng_make(st->rc.seed ^ ML_SEED_SALT, (uint64_t)l->slot, (uint64_t)p,
                                   3 + ((uint64_t)set_index << 8));
    volux_vec3 o, d, w0;
    if (!sample_emission(st, l, &rng, &o, &d, &w0)) return;
    float cos_prev = 1.0f, pdf_w = 1.0f, rr = 1.0f;
    for (int depth = 1; depth <= max_len; depth++) {
        volux_ray r;
        if (!volux_ray_clip(st->rc.volume, o, d, &r)) return;
        float scale = st->place_by_xi ? st->xi : (volux_rng_float(&rng) < 0.5f ? st->dmin : st->dmax);
        float t;
        if (!(scale > 0.0f) || !track(st, &r, scale, &rng, &t)) return;
        ml_vl *v = &list->v[list->n];
        memset(v, 0, sizeof *v);
        v->from = o;
        v->w = d;
        v->pos = v3_madd(o, d, t);
        v->sigma1 = v->sigma1_s = sigma1_index(st, v3_madd(r.q0, r.dq, t), &v->s);
        if (!(v->sigma1 > 0.0f)) return; /* unreachable: a collision needs σ1 > 0 */
        v->tau1 = v->tau1_s = ml_tau1(st, o, d, v3_length(v3_sub(v->pos, o)), INFINITY);
        v->scale_s = st->place_by_xi ? st->xi : 0.0f;
        v->w0 = w0;
        v->cos_prev = cos_prev;
        v->pdf_w = pdf_w;
        v->rr = rr;
        v->depth = depth;
        v->path = p;
        v->slot = -1;
        list->n++;
        if (depth == max_len) return;
        /* Step 4: Russian roulette. */
        rr = st->rr_survival;
        if (rr < 1.0f && volux_rng_float(&rng) >= rr) return;
        /* Step 5: importance-sample the phase function (light travels d,
         * then dn: cos θ = d·dn, sample/phase.h). */
        float u0 = volux_rng_float(&rng), u1 = volux_rng_float(&rng);
        volux_vec3 dn;
        if (st->iso_phase) {
            dn = volux_sample_sphere(u0, u1);
            pdf_w = VOLUX_INV_4PI;
        } else {
            dn = volux_hg_sample(st->rc.g, d, u0, u1, &pdf_w);
        }
        cos_prev = v3_dot(d, dn);
        o = v->pos;
        d = dn;
    }
}

volux_status ml_trace(const ml_state *st, const volux_prepared_light *l, int set_index, int quota, ml_list *list,
                      int *paths) {
    int max_len = st->rc.max_depth - 1;
    if (max_len > ML_MAX_PATH) max_len = ML_MAX_PATH;
    if (max_len < 1 || quota <= 0) return VOLUX_OK;
    int cap = path_cap(quota);
    for (int p = *paths; list->n < quota && p < cap; p++) {
        volux_status s = grow(st->rc.ctx, list, list->n + max_len);
        if (s) return s;
        trace_path(st, l, set_index, p, max_len, list);
        *paths = p + 1;
    }
    ml_set_paths(list, *paths);
    return VOLUX_OK;
}

void ml_set_paths(ml_list *list, int paths) {
    float inv = paths > 0 ? 1.0f / (float)paths : 0.0f;
    for (int i = 0; i < list->n; i++) list->v[i].inv_paths = inv;
}

void ml_retrace(const ml_state *st, ml_list *list) {
    for (int i = 0; i < list->n; i++) {
        ml_vl *v = &list->v[i];
        v->sigma1 = sigma1_index(st, volux_volume_to_index(st->rc.volume, v->pos), NULL);
        v->tau1 = ml_tau1(st, v->from, v->w, v3_length(v3_sub(v->pos, v->from)), INFINITY);
    }
}

void ml_weights(const ml_state *st, const volux_prepared_light *l, ml_list *list) {
    volux_vec3 le = ml_light_scale(l->desc), beta = v3(0, 0, 0);
    double log_xi = log((double)st->xi);
    for (int i = 0; i < list->n; i++) {
        ml_vl *v = &list->v[i];
        if (v->depth == 1) {
            beta = v3_mul(le, v->w0);
        } else {
            float f = st->rc.g == 0.0f ? VOLUX_INV_4PI : volux_hg_eval(st->rc.g, v->cos_prev);
            beta = v3_scale(beta, f / (v->pdf_w * v->rr));
        }
        /* ξσ1·e^{−ξτ1}/p(t), in logs (σ1 or ξ = 0 gives 0) */
        double lp = log_pdf_t(st, v);
        double lw = log_xi + log((double)v->sigma1) - (double)st->xi * (double)v->tau1 - lp;
        /* Eq. 6 bound: a segment re-weighted for an edited extinction
         * (σ1, τ1 no longer those it was sampled with) gets at most
         * eq6_bound times the weight it had for the medium it was sampled
         * in. A VL placed where the old medium was thin but the new one is
         * dense otherwise carries σ1_new/σ1_old ≫ 1 — the outliers that made
         * the first frames after a strong edit worse than the image before
         * the edit. Only stale segments are bounded: a fresh set is exact. */
        if (st->eq6_log_bound < INFINITY && (v->sigma1 != v->sigma1_s || v->tau1 != v->tau1_s)) {
            double lw_s = log_xi + log((double)v->sigma1_s) - (double)st->xi * (double)v->tau1_s - lp;
            if (lw > lw_s + st->eq6_log_bound) lw = lw_s + st->eq6_log_bound;
        }
        float w = (float)exp(lw);
        volux_vec3 beta_in = v3_scale(beta, isfinite(w) ? w : 0.0f);
        float rgba[4];
        volux_lut_rgba(st->rc.lut, v->s, rgba);
        volux_vec3 rho = v3_scale(v3(rgba[0], rgba[1], rgba[2]), st->rc.albedo);
        volux_vec3 out = v3_mul(beta_in, rho);
        v->I = v3_scale(out, v->inv_paths);
        beta = out;
    }
}
