/*
 * sample/medium.h — the medium the Monte-Carlo techniques (pathtrace,
 * guided) see: extinction σt(x) and colour c(x) at an index-space point,
 * for the two classification orders.
 *
 *   post (DESIGN §2, default): s(x) is the trilinear interpolation of the
 *        node values and σt(x) = TF(s(x)), c(x) = TF_c(s(x)). This is what
 *        every volux technique integrates.
 *   pre: TF applied at the eight nodes of the voxel first, then σt and c
 *        interpolated trilinearly — what an independent renderer sees when it
 *        is given a grid of σt (and a separate albedo/colour grid), e.g. a
 *        Mitsuba `gridvolume`. Both agree where the TF is linear over the
 *        voxel's value range; they differ across sharp TF features (pre
 *        smears a thin iso-shell over the voxel).
 *
 * Both are bounded by the same macrocell majorant: post because the
 * trilinear s lies within the cell's node range and the LUT is linear
 * between its entries (volux_majorant_grid_build takes the max over the
 * bracketing entries); pre because a trilinear blend of node σt values is at
 * most the largest node σt, each of which is TF(node value) ≤ that max.
 *
 * Scattering: σs = albedo·c(x)·σt(x) per channel (DESIGN §2), so the
 * single-scattering albedo is ρ(x) = albedo·c(x) ∈ [0,1]³.
 */
#ifndef VOLUX_SAMPLE_MEDIUM_H
#define VOLUX_SAMPLE_MEDIUM_H

#include "core/volume_internal.h"
#include "march.h"

/* Clamps an index-space point into the node box (rays are clipped to the
 * box, but t·dq rounding can leave it by an ulp). */
static inline volux_vec3 volux_medium_clamp_index(const volux_volume *v, volux_vec3 q) {
    float mx = (float)(v->dims[0] - 1), my = (float)(v->dims[1] - 1), mz = (float)(v->dims[2] - 1);
    q.x = q.x < 0.0f ? 0.0f : (q.x > mx ? mx : q.x);
    q.y = q.y < 0.0f ? 0.0f : (q.y > my ? my : q.y);
    q.z = q.z < 0.0f ? 0.0f : (q.z > mz ? mz : q.z);
    return q;
}

/* Pre-classified σt (and colour into rgb when non-NULL) at index-space q. */
static inline float volux_medium_sigma_pre(const volux_volume *v, const volux_transfer_lut *lut, volux_vec3 q, float *rgb) {
    volux_cell cell = volux_volume_cell(v, q.x, q.y, q.z);
    float fx = cell.fx, fy = cell.fy, fz = cell.fz;
    size_t b = cell.base, sx = cell.sx, sy = cell.sy, sz = cell.sz;
    size_t idx[8] = {b, b + sx, b + sy, b + sx + sy, b + sz, b + sx + sz, b + sy + sz, b + sx + sy + sz};
    float w[8] = {(1 - fx) * (1 - fy) * (1 - fz), fx * (1 - fy) * (1 - fz), (1 - fx) * fy * (1 - fz),
                  fx * fy * (1 - fz),           (1 - fx) * (1 - fy) * fz, fx * (1 - fy) * fz,
                  (1 - fx) * fy * fz,           fx * fy * fz};
    float sigma = 0.0f;
    if (rgb) {
        float c[3] = {0, 0, 0};
        for (int n = 0; n < 8; n++) {
            float rgba[4];
            volux_lut_rgba(lut, volux_volume_raw_at(v, idx[n]) + v->value_offset, rgba);
            c[0] += w[n] * rgba[0];
            c[1] += w[n] * rgba[1];
            c[2] += w[n] * rgba[2];
            sigma += w[n] * rgba[3];
        }
        rgb[0] = c[0], rgb[1] = c[1], rgb[2] = c[2];
    } else {
        for (int n = 0; n < 8; n++) sigma += w[n] * volux_lut_sigma(lut, volux_volume_raw_at(v, idx[n]) + v->value_offset);
    }
    return sigma;
}

/* σt at index-space q (and colour into rgb when non-NULL). */
static inline float volux_medium_eval(const volux_volume *v, const volux_transfer_lut *lut, int pre, volux_vec3 q,
                                   float *rgb) {
    q = volux_medium_clamp_index(v, q);
    if (pre) return volux_medium_sigma_pre(v, lut, q, rgb);
    float s = volux_volume_sample_index(v, q.x, q.y, q.z);
    if (!rgb) return volux_lut_sigma(lut, s);
    float rgba[4];
    volux_lut_rgba(lut, s, rgba);
    rgb[0] = rgba[0], rgb[1] = rgba[1], rgb[2] = rgba[2];
    return rgba[3];
}

#endif
