/*
 * sample/primary.h — the camera ray of a pixel sample, shared by every ray
 * caster so their images line up pixel for pixel.
 *
 * Sample 0 goes through the pixel centre; later samples are spread uniformly
 * over the pixel's square footprint (box filter). Each ray also gets a march
 * jitter in [0, 1) (the offset of its first segment, in steps). All three
 * numbers come from the counter-based stream (seed, pixel, sample, 0), so a
 * pixel's ray never depends on the thread that renders it.
 */
#ifndef VOLUX_PRIMARY_H
#define VOLUX_PRIMARY_H

#include "core/rng.h"
#include "volux/camera.h"

typedef struct volux_primary {
    volux_vec3 o, d; /* world origin and unit direction */
    float jitter;    /* first-segment offset in [0, 1) */
} volux_primary;

/* The random numbers of a pixel sample: the position (*jx, *jy) inside
 * the pixel and the returned march jitter. */
static inline __attribute__((always_inline)) float volux_primary_numbers(const volux_camera *cam, uint64_t seed,
                                                                        int px, int py, uint32_t sample_index,
                                                                        float *jx, float *jy) {
    uint64_t pixel = (uint64_t)py * (uint64_t)cam->width + (uint64_t)px;
    volux_rng rng = volux_rng_make(seed, pixel, sample_index, 0);
    *jx = 0.5f, *jy = 0.5f;
    if (sample_index > 0) {
        *jx = volux_rng_float(&rng);
        *jy = volux_rng_float(&rng);
    }
    return volux_rng_float(&rng);
}

/* Always inlined into the pixel loops (called once per pixel sample). */
static inline __attribute__((always_inline)) volux_primary volux_primary_ray(const volux_camera *cam, uint64_t seed,
                                                                             int px, int py, uint32_t sample_index) {
    float jx, jy;
    volux_primary r;
    r.jitter = volux_primary_numbers(cam, seed, px, py, sample_index, &jx, &jy);
    volux_camera_ray(cam, (float)px + jx, (float)py + jy, &r.o, &r.d);
    return r;
}

#endif
