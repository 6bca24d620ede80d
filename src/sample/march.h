/*
 * sample/march.h — majorant grids and interval iteration along rays.
 *
 * The volume's 8³ macrocells carry TF-independent [min, max] value ranges;
 * a majorant grid turns them into the largest extinction σt̄ per cell for the
 * current transfer function (rebuilt only when extinction, density or the
 * volume change). Rays walk the grid cell by cell (3-D DDA, Amanatides & Woo
 * 1987) and get intervals {t0, t1, σt̄}: ray casters skip intervals with
 * σt̄ = 0 (empty-space skipping), trackers use σt̄ as a local majorant
 * (delta/ratio tracking).
 *
 * The iterator lives on the caller's stack (Open VKL style); no allocation
 * per ray.
 */
#ifndef VOLUX_MARCH_H
#define VOLUX_MARCH_H

#include "core/vecmath.h"
#include "core/volume_internal.h"
#include "volux/transfer.h"

typedef struct volux_majorant_grid {
    int cells[3];
    float *sigma_max;  /* per cell, density scale applied               */
    size_t bytes;
    float global_max;
} volux_majorant_grid;

/* Builds (or rebuilds in place) the grid for volume v and LUT lut. */
volux_status volux_majorant_grid_build(volux_context *ctx, const volux_volume *v, const volux_transfer_lut *lut,
                                       volux_majorant_grid *grid);
void volux_majorant_grid_free(volux_context *ctx, volux_majorant_grid *grid);

/* A ray in a volume's index space, parameterised by world distance t:
 * q(t) = q0 + t·dq. Produced by volux_ray_clip. */
typedef struct volux_ray {
    volux_vec3 o, d;      /* world origin and unit direction              */
    volux_vec3 q0, dq;    /* index-space origin and direction per world t */
    float t0, t1;         /* world-t interval inside the volume box       */
    /* Data-parallel bricks (volux_ray_clip_part): the samples stay on the
     * whole box's lattice t0 + (k + jitter)·h, and only the segments whose
     * end lies in (w0, w1] — inside this brick's owned box — are
     * integrated, so the bricks along a ray share its segments exactly
     * once. windowed 0: the whole ray (volux_ray_clip). */
    int windowed;
    float w0, w1;
} volux_ray;

/* Clips the world ray (o, d unit) to the volume's box; returns 0 if it
 * misses. */
int volux_ray_clip(const volux_volume *v, volux_vec3 o, volux_vec3 d, volux_ray *ray);
/* volux_ray_clip with the box (volux_volume_bounds) and 1/d (v3_inverse)
 * computed by the caller: the same result, for loops over many rays (the
 * packet ray caster's ray list: one box per tile, one 1/d per tile for an
 * orthographic camera). */
/* Fills *ray for o + t·d over (t0, t1] with the march window (w0, w1]. */
static inline void volux_ray_fill(const volux_volume *v, volux_vec3 o, volux_vec3 d, float t0, float t1, int windowed,
                                  float w0, float w1, volux_ray *ray) {
    ray->o = o;
    ray->d = d;
    ray->q0 = volux_volume_to_index(v, o);
    ray->dq = v3(d.x * v->inv_spacing[0], d.y * v->inv_spacing[1], d.z * v->inv_spacing[2]);
    ray->t0 = t0;
    ray->t1 = t1;
    ray->windowed = windowed;
    ray->w0 = w0;
    ray->w1 = w1;
}
static inline int volux_ray_clip_hoisted(const volux_volume *v, volux_vec3 lo, volux_vec3 hi, volux_vec3 o,
                                         volux_vec3 d, volux_vec3 inv_d, volux_ray *ray) {
    float t0, t1;
    if (!v3_ray_box_inv(o, inv_d, lo, hi, &t0, &t1)) return 0;
    volux_ray_fill(v, o, d, t0, t1, 0, t0, t1, ray);
    return 1;
}
/* For a brick of a whole grid (volux_volume_brick): t0, t1 from the whole
 * box (the lattice of a single-process render), the window (w0, w1] from
 * the brick's owned box. Returns 0 if the ray misses the owned box. For an
 * ordinary volume it is volux_ray_clip. */
int volux_ray_clip_part(const volux_volume *v, volux_vec3 o, volux_vec3 d, volux_ray *ray);

typedef struct volux_interval {
    float t0, t1, sigma_max;
} volux_interval;

typedef struct volux_march_iter {
    const volux_majorant_grid *grid;
    int cell[3], step[3];
    float t_next[3], t_delta[3];
    float t, t_end;
} volux_march_iter;

void volux_march_init(volux_march_iter *it, const volux_majorant_grid *grid, const volux_ray *ray, float t_start,
                      float t_end);
/* Next interval along the ray (consecutive, covering [t_start, t_end]);
 * returns 0 when done. */
int volux_march_next(volux_march_iter *it, volux_interval *out);

/* Baked-LUT lookups with linear interpolation between table nodes. */
static inline float volux_lut_sigma(const volux_transfer_lut *lut, float s) {
    float u = (s - lut->s_min) * lut->inv_ds;
    if (u <= 0.0f) return lut->sigma_t[0];
    int last = lut->n - 1;
    if (u >= (float)last) return lut->sigma_t[last];
    int i = (int)u;
    float f = u - (float)i;
    return lut->sigma_t[i] + (lut->sigma_t[i + 1] - lut->sigma_t[i]) * f;
}

/* Colour (rgb) and σt (a) at s. */
static inline void volux_lut_rgba(const volux_transfer_lut *lut, float s, float out[4]) {
    float u = (s - lut->s_min) * lut->inv_ds;
    int last = lut->n - 1;
    if (u < 0.0f) u = 0.0f;
    if (u > (float)last) u = (float)last;
    int i = (int)u;
    if (i >= last) i = last - 1;
    float f = u - (float)i;
    const float *a = &lut->rgba[4 * i], *b = a + 4;
    for (int c = 0; c < 4; c++) out[c] = a[c] + (b[c] - a[c]) * f;
}

/* Table coordinate u ∈ [0, n−1] of s (clamped), and the table interval
 * [i, i+1] holding it (i ∈ [0, n−2]). Both kernels (scalar and SIMD) derive
 * every pre-integration quantity from u, so they agree on which interval a
 * sample falls in. */
static inline float volux_lut_coord(const volux_transfer_lut *lut, float s) {
    float u = (s - lut->s_min) * lut->inv_ds;
    float last = (float)(lut->n - 1);
    if (u < 0.0f) u = 0.0f;
    if (u > last) u = last;
    return u;
}

static inline int volux_lut_interval(const volux_transfer_lut *lut, float u) {
    int i = (int)u;
    return i > lut->n - 2 ? lut->n - 2 : i;
}

/* Running integrals at table coordinate u (linear between nodes). */
static inline double volux_lut_int_at(const volux_transfer_lut *lut, float u, double rgb[3]) {
    int i = volux_lut_interval(lut, u);
    double f = (double)(u - (float)i);
    for (int c = 0; c < 3; c++)
        rgb[c] = lut->int_sigma_c[3 * i + c] + (lut->int_sigma_c[3 * (i + 1) + c] - lut->int_sigma_c[3 * i + c]) * f;
    return lut->int_sigma[i] + (lut->int_sigma[i + 1] - lut->int_sigma[i]) * f;
}

/* Running integrals at s (linear between nodes). */
static inline double volux_lut_int_sigma(const volux_transfer_lut *lut, float s, double rgb[3]) {
    return volux_lut_int_at(lut, volux_lut_coord(lut, s), rgb);
}

#endif
