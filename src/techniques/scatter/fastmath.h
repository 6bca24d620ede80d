/*
 * techniques/scatter/fastmath.h — branch-free elementary functions for the
 * scattering techniques' inner loops (vectorisable; no libm call).
 */
#ifndef VOLUX_SCATTER_FASTMATH_H
#define VOLUX_SCATTER_FASTMATH_H

#include <math.h>
#include <stdint.h>
#include <string.h>

/* e^x for x ≤ 0 (clamped at −87): 2^n through the exponent bits and a
 * degree-6 Taylor polynomial on |r| ≤ ln2/2 (relative error < 3e-7). The
 * max uses fabs so the loop stays branch-free. */
static inline float scatter_exp_neg(float x) {
    x = 0.5f * (x - 87.0f + fabsf(x + 87.0f)); /* max(x, −87) */
    float t = x * 1.44269504f;
    int n = (int)(t - 0.5f); /* round to nearest for t ≤ 0 */
    float r = x - (float)n * 0.693145752f - (float)n * 1.42860677e-6f;
    float p = 1.0f + r * (1.0f + r * (0.5f + r * (0.166666667f + r * (0.0416666667f + r * (0.00833333333f +
                                                                                         r * 0.00138888889f)))));
    int32_t bits = (n + 127) << 23;
    float scale;
    memcpy(&scale, &bits, sizeof scale);
    return p * scale;
}

/* acos with |error| ≤ 6.7e-5 rad (Abramowitz & Stegun 4.4.45). */
static inline float scatter_fast_acos(float x) {
    float ax = fabsf(x);
    if (ax > 1.0f) ax = 1.0f;
    float r = sqrtf(1.0f - ax) * (1.5707288f + ax * (-0.2121144f + ax * (0.0742610f - 0.0187293f * ax)));
    return x < 0.0f ? 3.14159265f - r : r;
}

#endif
