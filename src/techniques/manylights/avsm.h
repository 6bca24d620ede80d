/*
 * techniques/manylights/avsm.h — AVSM look-ups (inline: the renderer calls
 * them once per view sample and VL). Layout and build: avsm.c.
 *
 * Cube faces: 0 +X, 1 −X, 2 +Y, 3 −Y, 4 +Z, 5 −Z; texel coordinates run
 * along axes (a+1)%3 and (a+2)%3 of the face's axis a.
 */
#ifndef VOLUX_ML_AVSM_H
#define VOLUX_ML_AVSM_H

#include <math.h>

#include "manylights.h"

static inline float ml_comp(volux_vec3 v, int a) { return a == 0 ? v.x : (a == 1 ? v.y : v.z); }

/* Transmittance at depth dd (depth-code units) along one texel's nodes:
 * the polyline through (0, 1) and the nodes, constant after the last. The
 * scan reads only depth codes; two nodes are decoded. */
static inline float ml_eval_nodes(const float *decode, const uint32_t *nodes, int m, float dd) {
    int k = 0;
    while (k < m && (float)(nodes[k] >> 16) < dd) k++;
    if (k == m) return decode[nodes[m - 1] & 0xffffu];
    float dk = (float)(nodes[k] >> 16), Tk = decode[nodes[k] & 0xffffu];
    float d_prev = 0.0f, T_prev = 1.0f;
    if (k > 0) {
        d_prev = (float)(nodes[k - 1] >> 16);
        T_prev = decode[nodes[k - 1] & 0xffffu];
    }
    float span = dk - d_prev;
    return span > 0.0f ? T_prev + (Tk - T_prev) * ((dd - d_prev) / span) : Tk;
}

/* Face of direction v and its face coordinates in [0, R]. */
static inline int ml_face_of(volux_vec3 v, int R, float *fu, float *fv) {
    float ax = fabsf(v.x), ay = fabsf(v.y), az = fabsf(v.z);
    int a = ax >= ay ? (ax >= az ? 0 : 2) : (ay >= az ? 1 : 2);
    float major = a == 0 ? ax : (a == 1 ? ay : az);
    int face = 2 * a + (ml_comp(v, a) < 0.0f);
    float inv = 0.5f * (float)R / major;
    *fu = (ml_comp(v, (a + 1) % 3) + major) * inv;
    *fv = (ml_comp(v, (a + 2) % 3) + major) * inv;
    return face;
}

/* Transmittance from a VL's AVSM towards v (= x − VL position, |v| = dist):
 * the texel v falls in. */
static inline float ml_avsm_point(const ml_state *st, const uint32_t *avsm, volux_vec3 v, float dist) {
    const ml_layout *lay = &st->layout;
    int R = lay->res, m = lay->nodes;
    float fu, fv;
    int face = ml_face_of(v, R, &fu, &fv);
    int i = (int)fu, j = (int)fv;
    if (i > R - 1) i = R - 1;
    if (j > R - 1) j = R - 1;
    const uint32_t *nodes = avsm + (((size_t)face * (size_t)R + (size_t)j) * (size_t)R + (size_t)i) * (size_t)m;
    return ml_eval_nodes(st->decode, nodes, m, dist * lay->inv_d_unit);
}

/* Transmittance between the points at depths d0 ≤ d1 of the texel ray v
 * falls in: T(d1)/T(d0) (both on the same ray from the VL). */
static inline float ml_avsm_between(const ml_state *st, const uint32_t *avsm, volux_vec3 v, float d0, float d1) {
    const ml_layout *lay = &st->layout;
    int R = lay->res, m = lay->nodes;
    float fu, fv;
    int face = ml_face_of(v, R, &fu, &fv);
    int i = (int)fu, j = (int)fv;
    if (i > R - 1) i = R - 1;
    if (j > R - 1) j = R - 1;
    const uint32_t *nodes = avsm + (((size_t)face * (size_t)R + (size_t)j) * (size_t)R + (size_t)i) * (size_t)m;
    float t1 = ml_eval_nodes(st->decode, nodes, m, d1 * lay->inv_d_unit);
    if (!(d0 > 0.0f)) return t1;
    float t0 = ml_eval_nodes(st->decode, nodes, m, d0 * lay->inv_d_unit);
    return t0 > 0.0f ? fminf(t1 / t0, 1.0f) : 0.0f;
}

/* The same blended bilinearly over the four nearest texels of the face
 * (clamped at its edge): W13's trilinear look-up. */
static inline float ml_avsm_trilinear(const ml_state *st, const uint32_t *avsm, volux_vec3 v, float dist) {
    const ml_layout *lay = &st->layout;
    int R = lay->res, m = lay->nodes;
    float fu, fv;
    int face = ml_face_of(v, R, &fu, &fv);
    fu -= 0.5f;
    fv -= 0.5f;
    float x0f = floorf(fu), y0f = floorf(fv), fx = fu - x0f, fy = fv - y0f;
    int x0 = (int)x0f, y0 = (int)y0f, x1 = x0 + 1, y1 = y0 + 1;
    x0 = x0 < 0 ? 0 : x0;
    y0 = y0 < 0 ? 0 : y0;
    x1 = x1 > R - 1 ? R - 1 : x1;
    y1 = y1 > R - 1 ? R - 1 : y1;
    const uint32_t *f = avsm + (size_t)face * (size_t)R * (size_t)R * (size_t)m;
    float dd = dist * lay->inv_d_unit;
    float t00 = ml_eval_nodes(st->decode, f + ((size_t)y0 * (size_t)R + (size_t)x0) * (size_t)m, m, dd);
    float t10 = ml_eval_nodes(st->decode, f + ((size_t)y0 * (size_t)R + (size_t)x1) * (size_t)m, m, dd);
    float t01 = ml_eval_nodes(st->decode, f + ((size_t)y1 * (size_t)R + (size_t)x0) * (size_t)m, m, dd);
    float t11 = ml_eval_nodes(st->decode, f + ((size_t)y1 * (size_t)R + (size_t)x1) * (size_t)m, m, dd);
    float t0 = t00 + (t10 - t00) * fx, t1 = t01 + (t11 - t01) * fx;
    return t0 + (t1 - t0) * fy;
}

#endif
