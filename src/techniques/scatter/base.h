/*
 * techniques/scatter/base.h — state and view-ray marcher shared by the
 * scattering techniques `single`, `ao` and `ambient`.
 *
 * Optical model of all three (Ament et al. 2013, Eqs. 18–20):
 *
 *     L(x_c) = T(x_b, x_c) L_b + J_e + J_i
 *     J_e = ∫ T(x) σa(x) L_e(x) dx,       σa = σt − σs, L_e = emission·c(x)
 *     J_i = ∫ T(x_o) σs(x) L_s(x) dx,     σs = albedo·c(x)·σt(x)  (DESIGN §2)
 *
 * where each technique supplies L_s(x), the radiance scattered towards the
 * camera per unit σs (an in-scattering callback), and x_o = x + lag·ω is
 * the point from which the camera transmittance is taken (`ambient` uses
 * lag = r, Eq. 20; the others lag = 0, i.e. T(x)). Segments of the view
 * ray are integrated with constant σt: a segment of optical depth τ adds
 * T·(1 − e^{−τ})·albedo·c·L_s, the exact integral of T σs L_s over it.
 *
 * Caches here (each technique adds its own):
 *   majorant grid (empty-space skipping) ← volume, extinction, density
 *   prepared lights                      ← lights
 *   camera, step, seed                   ← camera, render settings
 *   albedo, g, material                  ← colour, phase
 */
#ifndef VOLUX_SCATTER_BASE_H
#define VOLUX_SCATTER_BASE_H

#include "core/rng.h"
#include "core/simd.h"
#include "lights.h"
#include "sample/march.h"
#include "sample/primary.h"
#include "sample/segment.h"
#include "volux/technique.h"

/* Parameters every scattering technique has. */
#define SCATTER_COMMON_PARAMS                                                                                    \
    {"early_termination", VOLUX_PARAM_NUMBER, 0.002, 0, 1, NULL,                                                 \
     "stop a ray when its (offset) transmittance falls below this (0 = never)"},                                 \
        {"skip_empty", VOLUX_PARAM_BOOL, 1, 0, 1, NULL,                                                          \
         "skip macrocells whose TF extinction is zero (does not change the image)"},                             \
        {"emission", VOLUX_PARAM_NUMBER, 0, 0, 1e6, NULL,                                                        \
         "emitted radiance L_e = emission·c(s) of the absorbing part σa (Eq. 19); 0 = no emission"}

typedef struct scatter_base {
    volux_context *ctx;
    const volux_technique_class *cls;
    int threads;
    volux_volume *volume;          /* retained */
    const volux_transfer_lut *lut; /* the scene's */
    volux_majorant_grid grid;
    volux_camera camera;
    float step;                    /* world units */
    float min_spacing;
    uint64_t seed;
    float albedo, g;
    float t_min, emission;
    int skip_empty;
    scatter_light lights[SCATTER_MAX_LIGHTS];
    int n_lights;
    volux_vec3 ambient;            /* mean environment radiance */
} scatter_base;

/* Brings the shared state up to date for the change set c. */
volux_status scatter_base_update(scatter_base *b, volux_scene *scene, const volux_change_set *c);
void scatter_base_free(scatter_base *b);
size_t scatter_base_memory(const scatter_base *b);

/* One view-ray sample as the in-scattering callback sees it. */
typedef struct scatter_sample {
    volux_vec3 p;      /* world position                      */
    volux_vec3 q;      /* volume index-space position         */
    volux_vec3 to_eye; /* unit direction towards the camera   */
    float s;           /* scalar value                        */
} scatter_sample;

/* Sets *scattered (radiance scattered towards the camera per unit σs: it
 * is multiplied by albedo·c) and *extra (added as is, e.g. specular
 * highlights); both start at 0. */
typedef void (*scatter_inscatter_fn)(const void *tech, const scatter_sample *smp, volux_vec3 *scattered,
                                     volux_vec3 *extra);

/* Past segments of the ray, for T(x_o) at a lag behind the current point:
 * (t0, t1, T before, T after); T is linear within a segment (one march
 * step). When full, the oldest is folded into the base (T(x_o) is then
 * taken slightly too close to x: conservative). */
#define SCATTER_LAG_RECORDS 2048

static inline __attribute__((always_inline)) void
scatter_render_tile(const scatter_base *b, const void *tech, const volux_scene *scene, const volux_tile *tile,
                    float *rgb, volux_tile_stats *stats, float lag, scatter_inscatter_fn inscatter) {
    const volux_camera *cam = &b->camera;
    const volux_volume *v = b->volume;
    const volux_transfer_lut *lut = b->lut;
    const float h = b->step, albedo = b->albedo, emission = b->emission;
    uint64_t count = 0;
    float rec[SCATTER_LAG_RECORDS][4];
    for (int y = 0; y < tile->h; y++)
        for (int x = 0; x < tile->w; x++) {
            volux_primary pr = volux_primary_ray(cam, b->seed, tile->x0 + x, tile->y0 + y, tile->sample_index);
            const volux_vec3 d = pr.d;
            const float jitter = pr.jitter;
            volux_vec3 bg = volux_scene_escape_radiance(scene, d);
            float *out = &rgb[3 * (y * tile->w + x)];
            volux_ray ray;
            if (!volux_ray_clip(v, pr.o, d, &ray)) {
                out[0] = bg.x, out[1] = bg.y, out[2] = bg.z;
                continue;
            }
            scatter_sample smp;
            smp.to_eye = v3_scale(d, -1.0f);
            float T = 1.0f, C[3] = {0, 0, 0};
            int head = 0, tail = 0; /* records [tail, head) */
            float T_base = 1.0f;
            volux_segments seg;
            volux_march_iter it;
            volux_segments_init(&seg, &it, b->skip_empty ? &b->grid : NULL, &ray, h, jitter);
            float a, e;
            int gap;
            while (volux_segments_next(&seg, &a, &e, &gap)) {
                float len = e - a;
                smp.q = v3_madd(ray.q0, ray.dq, e);
                smp.s = volux_volume_sample_index(v, smp.q.x, smp.q.y, smp.q.z);
                count++;
                float rgba[4];
                volux_lut_rgba(lut, smp.s, rgba);
                float tau = rgba[3] * len;
                if (tau <= 0.0f) continue;
                float alpha = 1.0f - volux_exp_nonpos_t6(-tau);
                /* T(x_o), x_o = x + lag·ω: the transmittance at t = e − lag,
                 * linear within the recorded segment that contains it. */
                float T_o = T;
                if (lag > 0.0f) {
                    float tq = e - lag;
                    while (tail != head && rec[tail % SCATTER_LAG_RECORDS][1] <= tq) {
                        T_base = rec[tail % SCATTER_LAG_RECORDS][3];
                        tail++;
                    }
                    T_o = T_base;
                    if (tail != head) {
                        const float *r0 = rec[tail % SCATTER_LAG_RECORDS];
                        if (tq > r0[0]) T_o = r0[2] + (r0[3] - r0[2]) * (tq - r0[0]) / (r0[1] - r0[0]);
                    }
                }
                float ac = albedo * alpha;
                if (ac > 0.0f && (rgba[0] > 0.0f || rgba[1] > 0.0f || rgba[2] > 0.0f)) {
                    smp.p = v3_madd(ray.o, ray.d, e);
                    volux_vec3 Ls = v3(0, 0, 0), Lx = v3(0, 0, 0);
                    inscatter(tech, &smp, &Ls, &Lx);
                    float w = T_o * ac, wx = T_o * alpha;
                    C[0] += w * rgba[0] * Ls.x + wx * Lx.x;
                    C[1] += w * rgba[1] * Ls.y + wx * Lx.y;
                    C[2] += w * rgba[2] * Ls.z + wx * Lx.z;
                }
                if (emission > 0.0f) {
                    float w = T * alpha * emission;
                    for (int ch = 0; ch < 3; ch++) C[ch] += w * (1.0f - albedo * rgba[ch]) * rgba[ch];
                }
                if (lag > 0.0f) {
                    if (head - tail == SCATTER_LAG_RECORDS) T_base = rec[tail++ % SCATTER_LAG_RECORDS][3];
                    float *r = rec[head++ % SCATTER_LAG_RECORDS];
                    r[0] = a, r[1] = e, r[2] = T, r[3] = T * (1.0f - alpha);
                }
                T *= 1.0f - alpha;
                if ((lag > 0.0f ? T_o : T) < b->t_min) break;
            }
            out[0] = C[0] + T * bg.x;
            out[1] = C[1] + T * bg.y;
            out[2] = C[2] + T * bg.z;
        }
    stats->samples += count;
}

#endif
