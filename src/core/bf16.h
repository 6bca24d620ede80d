/*
 * core/bf16.h — 16-bit storage of float caches as bfloat16: the upper
 * half of an IEEE binary32 (sign, the full 8-bit exponent, 7 mantissa
 * bits), rounded to nearest even.
 *
 * Why bfloat16 and not binary16: the caches stored this way hold physical
 * quantities with no fixed range (irradiance in W/m² from lights of any
 * intensity, sums over any number of lights), and binary16 overflows at
 * 65504 and loses precision below 6.1e-5, which would need a per-cache
 * scale kept in step with every light edit. bfloat16 has float's range,
 * so any float a float cache held is stored with a relative error
 * ≤ 2⁻⁸ (0.4 %), and decoding is a 16-bit shift — exact, branch-free and
 * the same in the scalar code and every SIMD lane (gathers read the
 * 16 bits and shift), so the kernels stay interchangeable.
 */
#ifndef VOLUX_CORE_BF16_H
#define VOLUX_CORE_BF16_H

#include <stdint.h>
#include <string.h>

/* Relative rounding error bound of volux_bf16_from_float (half an ulp of
 * the 8-bit significand). */
#define VOLUX_BF16_REL_ERROR (1.0 / 256.0)

static inline float volux_bf16_to_float(uint16_t h) {
    uint32_t u = (uint32_t)h << 16;
    float f;
    memcpy(&f, &u, sizeof f);
    return f;
}

/* Round to nearest, ties to even; a NaN stays a (quiet) NaN. */
static inline uint16_t volux_bf16_from_float(float f) {
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    uint32_t r = (u + 0x7fffu + ((u >> 16) & 1u)) >> 16;
    return (uint16_t)((u & 0x7fffffffu) > 0x7f800000u ? (u >> 16) | 0x40u : r); /* a select: loops vectorise */
}

#endif
