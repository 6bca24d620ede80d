/*
 * render/raycaster.h — the base every technique builds on (pbrt's
 * RayIntegrator): the derived state all of them need, the per-pixel loop
 * of a ray caster, and the emission–absorption march with a per-segment
 * hook.
 *
 * STATE. A technique's state block starts with a volux_raycaster. The
 * generic instance code (render/technique.c) brings it up to date for a
 * change set before the technique's own update runs:
 *
 *   volume (retained), min_spacing     ← volume
 *   lut (the scene's baked LUT)        ← volume, extinction, density, colour
 *   majorant grid (8³ macrocells)      ← volume, extinction, density
 *   camera                             ← camera, render settings, volume
 *   step, seed, max_depth              ← render settings, volume
 *   albedo, g, material                ← colour, phase, volume
 *   lights (render/lights.h)           ← lights
 *   threads (for cache builds)         ← every update (render.threads or the context's)
 *
 * PIXEL LOOP. volux_raycaster_tile() generates each pixel's primary ray
 * (sample/primary.h), clips it to the volume box, asks the technique to
 * integrate it (radiance C and transmittance T) and composites the escape
 * radiance behind: L = C + T·L_escape. Misses see L_escape directly.
 *
 * EA MARCH. volux_ea_march() integrates L = ∫ T σt c dx over the segments
 * of sample/segment.h (empty-space skipping, pre-integration or point
 * sampling, early termination); a technique changes what a segment emits
 * through its `shade` hook (gradient shading, scattered light, ...).
 *
 * The hooks are called through function pointers that are compile-time
 * constants inside always_inline functions, so each technique gets its own
 * specialised loop (no indirect call per sample). `variant` is an integer
 * constant the loops pass through untouched, so one hook can serve several
 * specialisations (e.g. storage type × shading × pre-integration).
 */
#ifndef VOLUX_RAYCASTER_H
#define VOLUX_RAYCASTER_H

#include "lights.h"
#include "sample/march.h"
#include "sample/primary.h"
#include "sample/segment.h"
#include "technique_class.h"

typedef struct volux_raycaster {
    volux_context *ctx;
    const volux_technique_class *cls;
    volux_volume *volume;          /* retained                                 */
    const volux_transfer_lut *lut; /* the scene's baked LUT                    */
    volux_majorant_grid grid;
    volux_camera camera;
    float step;                    /* march step, world units                  */
    float min_spacing;             /* smallest voxel spacing, world units      */
    uint64_t seed;
    int max_depth;                 /* scattering events                        */
    int threads;                   /* for cache builds                         */
    float albedo, g;               /* scattering albedo, HG anisotropy         */
    volux_material material;
    volux_light_list lights;
    /* volux_raycaster_warn_unused_lights: per slot, the call that last
     * found the slot's light ignored (a light ignored in the previous call
     * was reported already) */
    uint32_t *ignored_in;
    int ignored_cap;
    uint32_t warn_calls;
} volux_raycaster;

/* Parameters most ray casters share (same names, ranges and meaning). */
#define VOLUX_PARAM_PREINTEGRATE                                                                                 \
    {"preintegrate", VOLUX_PARAM_BOOL, 1, 0, 1, NULL,                                                            \
     "integrate the TF exactly between samples (Engel et al. 2001), so narrow peaks are not missed"}
#define VOLUX_PARAM_EARLY_TERMINATION                                                                            \
    {"early_termination", VOLUX_PARAM_NUMBER, 0.002, 0, 1, NULL,                                                 \
     "stop a ray when its transmittance (ambient: taken at the offset point) falls below this (0 = never)"}
#define VOLUX_PARAM_SKIP_EMPTY                                                                                   \
    {"skip_empty", VOLUX_PARAM_BOOL, 1, 0, 1, NULL,                                                              \
     "skip macrocells whose TF extinction is zero (does not change the image)"}
/* WHAT: what is fully on at the threshold ("shading is", ...). */
#define VOLUX_PARAM_GRADIENT_THRESHOLD(WHAT)                                                                     \
    {"gradient_threshold", VOLUX_PARAM_NUMBER, 0.02, 0, 10, NULL,                                                \
     "gradient magnitude (fraction of the value range per smallest voxel spacing) at which " WHAT " fully on"}

/* |∇s| (file units per world unit) for a gradient_threshold parameter. */
static inline float volux_raycaster_gradient_ref(const volux_raycaster *rc, double threshold) {
    double lo, hi, sp[3];
    volux_volume_range(rc->volume, &lo, &hi);
    volux_volume_spacing(rc->volume, sp);
    return (float)(threshold * (hi > lo ? hi - lo : 1.0) / fmin(sp[0], fmin(sp[1], sp[2])));
}

/* Brings the base up to date for change set c (see the table above). */
volux_status volux_raycaster_update(volux_raycaster *rc, const volux_scene *scene, const volux_change_set *c);
void volux_raycaster_release(volux_raycaster *rc);
/* Tells the user (a context warning, see volux_message_fn) about every
 * enabled light of a type in `types` (bits 1u << volux_light_type) that the
 * technique renders without, and why. Call it when the lights changed
 * (VOLUX_CHANGE_LIGHTS): the image then differs from the scene's lighting
 * by design, never silently. A light is reported once while it stays
 * ignored (an edit of another light does not repeat the warning). */
volux_status volux_raycaster_warn_unused_lights(volux_raycaster *rc, unsigned types, const char *why);
size_t volux_raycaster_memory_bytes(const volux_raycaster *rc);

/* Integrates one clipped ray: returns the radiance gathered inside the
 * volume and sets *T to the transmittance through it; adds the volume
 * samples it took to *samples. */
typedef volux_vec3 (*volux_ray_integrate_fn)(const void *tech, const volux_ray *ray, float jitter, float *T,
                                             uint64_t *samples, int variant);

static inline __attribute__((always_inline)) void
volux_raycaster_tile(const volux_raycaster *rc, const void *tech, const volux_scene *scene, const volux_tile *tile,
                     float *rgb, volux_tile_stats *stats, volux_ray_integrate_fn integrate, int variant) {
    uint64_t samples = 0;
    for (int y = 0; y < tile->h; y++)
        for (int x = 0; x < tile->w; x++) {
            volux_primary pr = volux_primary_ray(&rc->camera, rc->seed, tile->x0 + x, tile->y0 + y, tile->sample_index);
            volux_vec3 bg = volux_scene_escape_radiance(scene, pr.d);
            float *out = &rgb[3 * (y * tile->w + x)];
            volux_ray ray;
            if (!volux_ray_clip(rc->volume, pr.o, pr.d, &ray)) {
                out[0] = bg.x, out[1] = bg.y, out[2] = bg.z;
                continue;
            }
            float T;
            volux_vec3 c = integrate(tech, &ray, pr.jitter, &T, &samples, variant);
            out[0] = c.x + T * bg.x;
            out[1] = c.y + T * bg.y;
            out[2] = c.z + T * bg.z;
        }
    stats->samples += samples;
}

/* The pixel loop of a brick (render_tile_part): rays from the scene's
 * camera clipped to the brick's owned box on the whole box's sample
 * lattice (volux_ray_clip_part); writes premultiplied C and T per pixel,
 * C + T·L_escape when `background`. */
static inline __attribute__((always_inline)) void
volux_raycaster_tile_part(const volux_raycaster *rc, const void *tech, const volux_scene *scene,
                          const volux_tile *tile, int background, float *rgbt, volux_tile_stats *stats,
                          volux_ray_integrate_fn integrate, int variant) {
    uint64_t samples = 0;
    for (int y = 0; y < tile->h; y++)
        for (int x = 0; x < tile->w; x++) {
            volux_primary pr = volux_primary_ray(&rc->camera, rc->seed, tile->x0 + x, tile->y0 + y, tile->sample_index);
            volux_vec3 bg = background ? volux_scene_escape_radiance(scene, pr.d) : v3(0, 0, 0);
            float *out = &rgbt[4 * (y * tile->w + x)];
            volux_ray ray;
            float T = 1.0f;
            volux_vec3 c = v3(0, 0, 0);
            if (volux_ray_clip_part(rc->volume, pr.o, pr.d, &ray)) c = integrate(tech, &ray, pr.jitter, &T, &samples, variant);
            out[0] = c.x + T * bg.x;
            out[1] = c.y + T * bg.y;
            out[2] = c.z + T * bg.z;
            out[3] = T;
        }
    stats->samples += samples;
}

/* Scalar value at ray parameter t. */
typedef float (*volux_ea_sample_fn)(const void *tech, const volux_ray *ray, float t, int variant);
/* Turns the TF colour c of the segment ending at ray parameter t into the
 * radiance it emits per unit opacity (in place). NULL: emit c as is. */
typedef void (*volux_ea_shade_fn)(const void *tech, const volux_ray *ray, float t, float c[3], int variant);

typedef struct volux_ea_march_desc {
    const volux_transfer_lut *lut;
    const volux_majorant_grid *grid; /* NULL: no empty-space skipping      */
    float step;                      /* world units                        */
    float t_min;                     /* stop when T falls below            */
} volux_ea_march_desc;

/* Front-to-back emission–absorption over the segments of one ray: a
 * segment of optical depth τ and emitted colour c adds T·(1 − e^{−τ})·c.
 * Pre-integrated (Engel et al. 2001) when `preint`, else point-sampled at
 * the segment's end. Skipping empty intervals never changes the image
 * (segment positions are fixed, sample/segment.h). */
static inline __attribute__((always_inline)) volux_vec3
volux_ea_march(const volux_ea_march_desc *m, const void *tech, const volux_ray *ray, float jitter, float *T_out,
               uint64_t *samples, int preint, volux_ea_sample_fn sample, volux_ea_shade_fn shade, int variant) {
    const volux_transfer_lut *lut = m->lut;
    float T = 1.0f, C[3] = {0, 0, 0};
    uint64_t count = 0;
    volux_segments seg;
    volux_march_iter it;
    volux_segments_init(&seg, &it, m->grid, ray, m->step, jitter);
    volux_preint pi = {0.0f, 0.0, {0.0, 0.0, 0.0}};
    float a, b;
    int gap;
    while (volux_segments_next(&seg, &a, &b, &gap)) {
        if (preint && gap) {
            volux_preint_front(lut, sample(tech, ray, a, variant), &pi);
            count++;
        }
        float s = sample(tech, ray, b, variant), c[3];
        float tau = preint ? volux_preint_segment(lut, &pi, s, b - a, c) : volux_point_segment(lut, s, b - a, c);
        count++;
        if (tau <= 0.0f) continue;
        if (shade) shade(tech, ray, b, c, variant);
        float alpha = 1.0f - expf(-tau);
        float w = T * alpha;
        C[0] += w * c[0];
        C[1] += w * c[1];
        C[2] += w * c[2];
        T -= w;
        if (T < m->t_min) break;
    }
    *samples += count;
    *T_out = T;
    return v3(C[0], C[1], C[2]);
}

#endif
