/*
 * sample/gradient.h — a quantised per-voxel gradient cache and the
 * gradient-based local shading (Blinn–Phong) shared by the ray casters.
 *
 * The cache holds central differences (one-sided at the border) in file
 * units per world unit, one 32-bit word per node with three signed 10-bit
 * fields (x bits 0–9, y 10–19, z 20–29) and one global scale, stored in the
 * volume's brick layout (9³ nodes per 8³ cells, see volume_internal.h).
 * Why: 4 bytes per node turn 6 trilinear fetches per sample into one; the 8
 * corners of a lookup are 4 pairs of adjacent words at the same offsets as
 * the bricked scalars, so the SIMD ray caster reuses a sample's brick
 * offset and fetches a corner pair with one 64-bit gather. 10 bits resolve
 * 1/511 of the largest gradient per component: finer than VTK's quantised
 * normals and invisible in shading. It depends on the volume only (rebuild
 * on VOLUME).
 *
 * Shading helpers: volux_shading_normal() turns a gradient into a unit
 * normal facing the viewer plus a fade m ∈ [0,1] (gradient magnitude over a
 * reference), and volux_blinn_phong() adds one light's diffuse and specular
 * terms. Callers decide what "light" is: `shaded` uses the unshadowed scene
 * lights, `lightvol` the propagated (shadowed) illumination.
 *
 * DOES NOT: allocate per sample; read transfer functions.
 */
#ifndef VOLUX_GRADIENT_H
#define VOLUX_GRADIENT_H

#include <math.h>

#include "core/vecmath.h"
#include "core/volume_internal.h"
#include "volux/transfer.h"

#define VOLUX_GRAD_MAX 511 /* largest quantised component (signed 10 bits) */

typedef struct volux_gradient_cache {
    uint32_t *grad; /* one word per node, bricked (VOLUX_BRICK_VOXELS per brick) */
    size_t bytes;
    float scale;    /* world gradient = stored field · scale                  */
} volux_gradient_cache;

/* (Re)builds the cache for v. `who` prefixes error messages ("shaded"). */
volux_status volux_gradient_cache_build(volux_context *ctx, const volux_volume *v, volux_gradient_cache *gc,
                                        const char *who);
void volux_gradient_cache_free(volux_context *ctx, volux_gradient_cache *gc);

/* Signed 10-bit field a of a cache word. */
static inline float volux_gradient_field(uint32_t w, int a) { return (float)((int32_t)(w << (22 - 10 * a)) >> 22); }

/* Offset of node (i,j,k) in the bricked layout (same as the scalars'). */
static inline size_t volux_brick_offset(const volux_volume *v, int i, int j, int k) {
    int bx = (v->dims[0] - 1 + VOLUX_BRICK_CELLS - 1) / VOLUX_BRICK_CELLS,
        by = (v->dims[1] - 1 + VOLUX_BRICK_CELLS - 1) / VOLUX_BRICK_CELLS;
    if (bx < 1) bx = 1;
    if (by < 1) by = 1;
    size_t brick = ((size_t)(k >> 3) * (size_t)by + (size_t)(j >> 3)) * (size_t)bx + (size_t)(i >> 3);
    return brick * VOLUX_BRICK_VOXELS + (size_t)((i & 7) + VOLUX_BRICK_NODES * ((j & 7) + VOLUX_BRICK_NODES * (k & 7)));
}

/* Trilinearly interpolated gradient (file units per world unit) at the
 * index-space position q, which must lie inside the volume. Same clamping,
 * corner order and arithmetic as the SIMD kernel (dvr_avx2.c). */
static inline volux_vec3 volux_gradient_cache_sample(const volux_gradient_cache *gc, const volux_volume *v,
                                                     volux_vec3 q) {
    volux_cell c = volux_volume_cell(v, q.x, q.y, q.z);
    const uint32_t *p = gc->grad + volux_brick_offset(v, c.i, c.j, c.k);
    enum { SY = VOLUX_BRICK_NODES, SZ = VOLUX_BRICK_NODES * VOLUX_BRICK_NODES };
    float g[3];
    for (int a = 0; a < 3; a++) {
        float n[8] = {volux_gradient_field(p[0], a),       volux_gradient_field(p[1], a),
                      volux_gradient_field(p[SY], a),      volux_gradient_field(p[SY + 1], a),
                      volux_gradient_field(p[SZ], a),      volux_gradient_field(p[SZ + 1], a),
                      volux_gradient_field(p[SZ + SY], a), volux_gradient_field(p[SZ + SY + 1], a)};
        g[a] = volux_lerp3(n, c.fx, c.fy, c.fz) * gc->scale;
    }
    return v3(g[0], g[1], g[2]);
}

/* Gradient of the trilinear interpolant itself (file units per world
 * unit) at the index-space position q: the derivative of volux_lerp3 along
 * each axis, from the same 8 corners of the bricked copy that the sample
 * at q reads (so no cache and no extra cache lines). Constant along its own
 * axis inside a cell, so it is continuous only across the cell faces that
 * axis does not cross: sharper and a little blockier than the cached
 * central differences, 38 dB apart on bonsai (docs/BENCHMARKS.md). The
 * same clamping, corner order and arithmetic as gradient_cell_v in
 * techniques/dvr/dvr_simd_impl.h (unfused lerps of corner differences, then
 * one multiply by 1/spacing), so both kernels get the same bits. */
static inline volux_vec3 volux_cell_gradient_bricked(const volux_volume *v, volux_vec3 q) {
    volux_cell c = volux_volume_cell(v, q.x, q.y, q.z);
    const size_t b = volux_brick_offset(v, c.i, c.j, c.k);
    enum { SY = VOLUX_BRICK_NODES, SZ = VOLUX_BRICK_NODES * VOLUX_BRICK_NODES };
    static const int at[8] = {0, 1, SY, SY + 1, SZ, SZ + 1, SZ + SY, SZ + SY + 1};
    float n[8];
    for (int e = 0; e < 8; e++) {
        size_t o = b + (size_t)at[e];
        n[e] = v->storage == VOLUX_STORE_U8    ? (float)((const uint8_t *)v->bricks)[o]
               : v->storage == VOLUX_STORE_U16 ? (float)((const uint16_t *)v->bricks)[o]
                                               : ((const float *)v->bricks)[o];
    }
#define VOLUX_LERP_(a, b, f) ((a) + ((b) - (a)) * (f))
    float gx = VOLUX_LERP_(VOLUX_LERP_(n[1] - n[0], n[3] - n[2], c.fy), VOLUX_LERP_(n[5] - n[4], n[7] - n[6], c.fy),
                           c.fz);
    float gy = VOLUX_LERP_(VOLUX_LERP_(n[2] - n[0], n[3] - n[1], c.fx), VOLUX_LERP_(n[6] - n[4], n[7] - n[5], c.fx),
                           c.fz);
    float gz = VOLUX_LERP_(VOLUX_LERP_(n[4] - n[0], n[5] - n[1], c.fx), VOLUX_LERP_(n[6] - n[2], n[7] - n[3], c.fx),
                           c.fy);
#undef VOLUX_LERP_
    return v3(gx * v->inv_spacing[0], gy * v->inv_spacing[1], gz * v->inv_spacing[2]);
}

/* Unit normal from gradient g, flipped towards the viewer (as VTK's CPU ray
 * caster does), into *n; returns the shading fade m = |g|/grad_ref clamped
 * to [0,1] (1 when grad_ref ≤ 0), or 0 (and *n untouched) for |g| = 0. */
static inline float volux_shading_normal(volux_vec3 g, float grad_ref, volux_vec3 view_dir, volux_vec3 *n) {
    float gl = v3_length(g);
    float m = grad_ref > 0.0f ? gl / grad_ref : 1.0f;
    if (m <= 0.0f) return 0.0f;
    if (m > 1.0f) m = 1.0f;
    volux_vec3 nn = v3_scale(g, 1.0f / gl);
    if (v3_dot(nn, view_dir) > 0.0f) nn = v3_scale(nn, -1.0f);
    *n = nn;
    return m;
}

/* Blinn–Phong terms of one light: unit direction L towards the light,
 * power E arriving at the point. Adds E·kd·(n·L) to *diff and
 * E·ks·(n·h)^p to *spec when n·L > 0. */
static inline void volux_blinn_phong(const volux_material *mat, volux_vec3 n, volux_vec3 L, volux_vec3 view_dir,
                                     volux_vec3 E, volux_vec3 *diff, volux_vec3 *spec) {
    float ndl = v3_dot(n, L);
    if (ndl <= 0.0f) return;
    *diff = v3_add(*diff, v3_scale(E, mat->diffuse * ndl));
    volux_vec3 h = v3_normalize(v3_sub(L, view_dir));
    float ndh = v3_dot(n, h);
    if (ndh > 0.0f) *spec = v3_add(*spec, v3_scale(E, mat->specular * powf(ndh, mat->specular_power)));
}

#endif
