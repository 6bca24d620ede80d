/*
 * render/path.h — the camera-path loop of the Monte-Carlo techniques
 * (pathtrace, guided): one loop, with the two places where they differ —
 * how the environment is sampled at a scattering vertex, and how an
 * escaping phase-sampled ray is weighted against that sampling — as hooks.
 *
 * The estimator (pbrt's SimpleVolPath / VolPath structure, Pharr et al.
 * 4th ed. §14.2, for a medium without surfaces; the full description is in
 * techniques/pathtrace/integrator.c):
 *   1. free flight by delta tracking on the macrocell majorants
 *      (sample/tracking.h);
 *   2. at a real collision, scatter with probability P = max_c ρ_c(x),
 *      carrying ρ/P (ρ = albedo·c(x));
 *   3. next-event estimation at the vertex: the `direct` hook;
 *   4. the phase-sampled continuation ray is MIS's second strategy: a
 *      sphere light it reaches (render/direct.h) ends the path, an escape
 *      adds the `escaped` hook's MIS-weighted environment radiance;
 *   5. Russian roulette on max_c throughput after rr_depth events; at most
 *      max_depth events.
 * Camera rays that leave the volume unscattered see the escape radiance
 * (visible environments or the background).
 *
 * Random numbers come from the tracker: its stream, or with the "sobol"
 * sampler (sample/sampler.h) one padded Sobol pair per use at each of the
 * first VOLUX_LD_DEPTH events (event k: the flight from the k-th scattering
 * vertex and the draws at the vertex it ends in). The hooks draw through
 * the same tracker (volux_tracker_ld2 at the current event).
 *
 * The hooks are static functions of the caller, passed as constants into
 * this always-inline function, so the compiler calls (or inlines) them
 * directly: no indirect call per vertex (pathtrace's instruction count is
 * unchanged, checked with callgrind).
 */
#ifndef VOLUX_RENDER_PATH_H
#define VOLUX_RENDER_PATH_H

#include "direct.h"
#include "raycaster.h"

/* Next-event estimate at the depth-th scattering vertex x of a path
 * arriving along d (phase · L · T / pdf, MIS-weighted where it applies). */
typedef volux_vec3 (*volux_path_direct_fn)(void *self, volux_vec3 x, volux_vec3 d, int depth);
/* Environment radiance seen by a phase-sampled ray that escaped the volume
 * along d, times its MIS weight against the environment sampling of the
 * last vertex (pdf_phase: the phase function's density of d). */
typedef volux_vec3 (*volux_path_escaped_fn)(void *self, volux_vec3 d, float pdf_phase);
/* Optional: the continuation direction at the depth-th vertex (path
 * arriving along d) drawn from another density than the phase function's.
 * Returns it, sets *pdf_phase to the phase function's density of it (what
 * MIS weighs against light sampling) and *weight to phase / actual density
 * (multiplies the throughput; 0 ends the path). NULL: phase sampling. */
typedef volux_vec3 (*volux_path_continue_fn)(void *self, volux_vec3 d, int depth, float *pdf_phase, float *weight);

/* One camera path from o along d: the radiance arriving at the camera.
 * n_area: emitters a phase-sampled ray can reach (sphere lights, and the
 * environments when `escaped` weighs them); 0 skips the continuation ray
 * after the last vertex. Adds the path's vertices to *vertices. */
static inline __attribute__((always_inline)) volux_vec3
volux_path_trace(volux_tracker *tr, const volux_raycaster *rc, const volux_scene *scene, int rr_depth, int n_area,
                 volux_vec3 o, volux_vec3 d, uint64_t *vertices, volux_path_direct_fn direct,
                 volux_path_escaped_fn escaped, volux_path_continue_fn next, void *self) {
    const volux_light_list *lights = &rc->lights;
    volux_vec3 L = v3(0, 0, 0), beta = v3(1, 1, 1);
    float pdf_phase = 0.0f;
    int depth = 0; /* scattering events so far */
    (*vertices)++; /* the camera vertex */
    for (;;) {
        /* Free flight to the next real collision (or out of the volume). */
        volux_ray r;
        float t_hit = INFINITY, u_roulette[2] = {-1.0f, -1.0f};
        /* Sampler "sobol": this event's flight pair stratifies the first
         * tracking step (handed to the tracker) jointly with the first step
         * of the first shadow ray from the vertex it reaches. */
        volux_tracker_ld_event(tr, depth);
        tr->ld_pending = volux_tracker_ld2(tr, VOLUX_LD_FLIGHT, &tr->ld_next[0], &tr->ld_shadow);
        int collided = volux_ray_clip(rc->volume, o, d, &r) && volux_delta_track(tr, &r, r.t0, r.t1, &t_hit);
        tr->ld_pending = 0;
        if (tr->stopped) break; /* out of time: the path ends here */
        if (depth == 0) {
            if (!collided) {
                /* Unscattered camera ray: T·L_escape, T estimated by the
                 * tracker (this branch runs with probability T). */
                L = v3_add(L, volux_scene_escape_radiance(scene, d));
                break;
            }
        } else if (n_area > 0) {
            int nearest = volux_sphere_nearest(lights, o, d, t_hit);
            if (nearest >= 0) {
                L = v3_add(L, v3_mul(beta, volux_sphere_hit_radiance(&lights->all[nearest], o, pdf_phase)));
                break;
            }
            if (!collided) L = v3_add(L, v3_mul(beta, escaped(self, d, pdf_phase)));
        }
        if (!collided || depth >= rc->max_depth) break;

        /* Real collision: scatter with probability max ρ, carry ρ/max ρ. */
        volux_vec3 x = v3_madd(o, d, t_hit);
        float c[3];
        volux_tracker_sigma(tr, &r, t_hit, c);
        volux_vec3 rho = v3(rc->albedo * c[0], rc->albedo * c[1], rc->albedo * c[2]);
        float P = v3_max_comp(rho);
        volux_tracker_ld2(tr, VOLUX_LD_ROULETTE, &u_roulette[0], &u_roulette[1]); /* (scatter, RR) */
        if (!(P > 0.0f) || (P < 1.0f && (u_roulette[0] >= 0.0f ? u_roulette[0] : volux_tracker_rnd(tr)) >= P)) break;
        beta = v3_mul(beta, v3_scale(rho, 1.0f / P));
        depth++;
        (*vertices)++;

        /* Next-event estimation (light-sampling strategy). */
        if (lights->n_all > 0) L = v3_add(L, v3_mul(beta, direct(self, x, d, depth)));

        /* Russian roulette on the throughput. */
        if (depth >= rr_depth) {
            float q = v3_max_comp(beta);
            if (q < 1.0f) {
                if ((u_roulette[1] >= 0.0f ? u_roulette[1] : volux_tracker_rnd(tr)) >= q) break;
                beta = v3_scale(beta, 1.0f / q);
            }
        }
        /* After the last scattering event the continuation ray only
         * serves MIS for sphere/environment lights. */
        if (depth >= rc->max_depth && n_area == 0) break;

        /* Phase sampling: f/pdf = 1 for HG sampled exactly. (The two
         * draws as arguments, in the compiler's order, as the loop has
         * always had them: images stay bit-identical.) */
        if (next) {
            float weight = 0.0f;
            d = next(self, d, depth, &pdf_phase, &weight);
            if (!(weight > 0.0f)) break;
            beta = v3_scale(beta, weight);
        } else {
            float u1, u2;
            if (volux_tracker_ld2(tr, VOLUX_LD_PHASE, &u1, &u2)) d = volux_hg_sample(rc->g, d, u1, u2, &pdf_phase);
            else d = volux_hg_sample(rc->g, d, volux_tracker_rnd(tr), volux_tracker_rnd(tr), &pdf_phase);
        }
        o = x;
    }
    return L;
}

#endif
