/* core/vecmath.h — small inline vector helpers shared by all modules. */
#ifndef VOLUX_VECMATH_H
#define VOLUX_VECMATH_H

#include <math.h>

#include "volux/base.h"

#define VOLUX_PI 3.14159265358979323846f
#define VOLUX_INV_PI 0.31830988618379067154f
#define VOLUX_INV_4PI 0.07957747154594766788f

static inline volux_vec3 v3(float x, float y, float z) { return (volux_vec3){x, y, z}; }
static inline volux_vec3 v3_add(volux_vec3 a, volux_vec3 b) { return v3(a.x + b.x, a.y + b.y, a.z + b.z); }
static inline volux_vec3 v3_sub(volux_vec3 a, volux_vec3 b) { return v3(a.x - b.x, a.y - b.y, a.z - b.z); }
static inline volux_vec3 v3_mul(volux_vec3 a, volux_vec3 b) { return v3(a.x * b.x, a.y * b.y, a.z * b.z); }
static inline volux_vec3 v3_scale(volux_vec3 a, float s) { return v3(a.x * s, a.y * s, a.z * s); }
static inline volux_vec3 v3_madd(volux_vec3 a, volux_vec3 b, float s) {
    return v3(a.x + b.x * s, a.y + b.y * s, a.z + b.z * s);
}
static inline float v3_dot(volux_vec3 a, volux_vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline volux_vec3 v3_cross(volux_vec3 a, volux_vec3 b) {
    return v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
static inline float v3_length(volux_vec3 a) { return sqrtf(v3_dot(a, a)); }
static inline volux_vec3 v3_normalize(volux_vec3 a) {
    float l = v3_length(a);
    return l > 0.0f ? v3_scale(a, 1.0f / l) : a;
}
static inline float v3_max_comp(volux_vec3 a) { return fmaxf(a.x, fmaxf(a.y, a.z)); }
static inline float v3_luminance(volux_vec3 c) { return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z; }
static inline int v3_finite(volux_vec3 a) { return isfinite(a.x) && isfinite(a.y) && isfinite(a.z); }
static inline float clampf(float x, float lo, float hi) { return x < lo ? lo : (x > hi ? hi : x); }

/* Orthonormal basis around unit n (Duff et al. 2017, "Building an
 * Orthonormal Basis, Revisited"). */
static inline void v3_basis(volux_vec3 n, volux_vec3 *t, volux_vec3 *b) {
    float sign = copysignf(1.0f, n.z);
    float a = -1.0f / (sign + n.z);
    float c = n.x * n.y * a;
    *t = v3(1.0f + sign * n.x * n.x * a, sign * c, -sign * n.x);
    *b = v3(c, sign + n.y * n.y * a, -n.y);
}

/* Slab test of the ray o + t·d against the box [lo,hi] given inv = 1/d per
 * component (hoisted by callers whose rays share a direction); returns 1
 * and the parametric interval if it hits with t1 > max(t0, 0). */
static inline int v3_ray_box_inv(volux_vec3 o, volux_vec3 inv_d, volux_vec3 lo, volux_vec3 hi, float *t0, float *t1) {
    float inv[3] = {inv_d.x, inv_d.y, inv_d.z};
    float ov[3] = {o.x, o.y, o.z}, l[3] = {lo.x, lo.y, lo.z}, h[3] = {hi.x, hi.y, hi.z};
    float tn = -INFINITY, tf = INFINITY;
    for (int a = 0; a < 3; a++) {
        float ta = (l[a] - ov[a]) * inv[a], tb = (h[a] - ov[a]) * inv[a];
        if (isnan(ta) || isnan(tb)) { /* d[a] == 0 and o on a slab plane */
            if (ov[a] < l[a] || ov[a] > h[a]) return 0;
            continue;
        }
        if (ta > tb) { float x = ta; ta = tb; tb = x; }
        if (ta > tn) tn = ta;
        if (tb < tf) tf = tb;
    }
    if (tn < 0.0f) tn = 0.0f;
    if (tf <= tn) return 0;
    *t0 = tn;
    *t1 = tf;
    return 1;
}

static inline volux_vec3 v3_inverse(volux_vec3 d) { return v3(1.0f / d.x, 1.0f / d.y, 1.0f / d.z); }

/* Slab test of the ray o + t·d against the box [lo,hi]; returns 1 and the
 * parametric interval if it hits with t1 > max(t0, 0). */
static inline int v3_ray_box(volux_vec3 o, volux_vec3 d, volux_vec3 lo, volux_vec3 hi, float *t0, float *t1) {
    return v3_ray_box_inv(o, v3_inverse(d), lo, hi, t0, t1);
}

#endif
