/*
 * core/sobol.h — Owen-scrambled 2-D Sobol points by hashing (Burley 2020,
 * "Practical Hash-based Owen Scrambling", JCGT 9(4)).
 *
 * The sequence: the first two dimensions of Sobol's base-2 sequence.
 * Dimension 0 is the van der Corput sequence (the generator matrix is the
 * identity, so the point is the bit-reversed index); dimension 1 has the
 * Joe–Kuo direction numbers of the primitive polynomial x + 1 (s = 1,
 * m₁ = 1): m_k = 2·m_{k−1} XOR m_{k−1}, i.e. v_k = v_{k−1} XOR (v_{k−1} >> 1)
 * in 32-bit fixed point (the Pascal matrix mod 2). The points of any aligned
 * block of 2^m indices (j·2^m … j·2^m + 2^m − 1) form a (0, m, 2)-net: one
 * point in each elementary interval of area 2^−m.
 *
 * Nested uniform (Owen) scrambling by a hash (Burley 2020 §3): a bit of the
 * point is flipped by a random function of the bits above it. Reversing the
 * bits turns "above" into "below", and any chain of x += seed and
 * x ^= x·c with even c flips each bit by a function of the lower bits only
 * (carries and products with an even constant move information upwards),
 * so reverse → hash → reverse is a nested uniform scramble; the constants
 * are the improved Laine–Karras hash of Burley's Listing 2. The scrambled
 * point is uniform in [0, 1)² whatever the index (unbiasedness) and the net
 * property survives (stratification).
 *
 * The same scramble applied to the *index* shuffles the sequence (Burley
 * §4): a bit of the result depends on that bit and the bits above it, so
 * indices below 2^m keep one common high part and their low m bits map one
 * to one — the first 2^m shuffled indices are one aligned block, a net, but
 * each
 * pixel (and each pair of dimensions, "padding", §5) sees its own order.
 * That decorrelates the pairs a path uses at its events from one another.
 *
 * Pure functions of their arguments: thread count and render order do not
 * matter (DESIGN §1).
 */
#ifndef VOLUX_SOBOL_H
#define VOLUX_SOBOL_H

#include <stdint.h>

/* Dimension 1's direction numbers v_1 … v_32 (v_1 = 2^31,
 * v_k = v_{k−1} ^ (v_{k−1} >> 1)); tests/unit/test_sobol.c rebuilds them
 * from the recurrence. */
static const uint32_t volux_sobol_v1[32] = {
    0x80000000u, 0xc0000000u, 0xa0000000u, 0xf0000000u, 0x88000000u, 0xcc000000u, 0xaa000000u, 0xff000000u,
    0x80800000u, 0xc0c00000u, 0xa0a00000u, 0xf0f00000u, 0x88880000u, 0xcccc0000u, 0xaaaa0000u, 0xffff0000u,
    0x80008000u, 0xc000c000u, 0xa000a000u, 0xf000f000u, 0x88008800u, 0xcc00cc00u, 0xaa00aa00u, 0xff00ff00u,
    0x80808080u, 0xc0c0c0c0u, 0xa0a0a0a0u, 0xf0f0f0f0u, 0x88888888u, 0xccccccccu, 0xaaaaaaaau, 0xffffffffu};

static inline uint32_t volux_reverse32(uint32_t x) {
    x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
    x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
    x = ((x >> 4) & 0x0f0f0f0fu) | ((x & 0x0f0f0f0fu) << 4);
    x = ((x >> 8) & 0x00ff00ffu) | ((x & 0x00ff00ffu) << 8);
    return (x >> 16) | (x << 16);
}

/* Dimension 0 (van der Corput) and 1 of Sobol's sequence, 32-bit fixed
 * point in [0, 1). */
static inline uint32_t volux_sobol0(uint32_t i) { return volux_reverse32(i); }

static inline uint32_t volux_sobol1(uint32_t i) {
    uint32_t x = 0;
    for (int k = 0; i; i >>= 1, k++) x ^= (0u - (i & 1u)) & volux_sobol_v1[k];
    return x;
}

/* Nested uniform scramble of a 32-bit fixed-point value (Burley 2020,
 * Listings 1–2): reverse, the Laine–Karras-style hash, reverse. */
static inline uint32_t volux_owen_scramble(uint32_t x, uint32_t seed) {
    x = volux_reverse32(x);
    x += seed;
    x ^= x * 0x6c50b47cu;
    x ^= x * 0xb82f1e52u;
    x ^= x * 0xc7afe638u;
    x ^= x * 0x8d22f6e6u;
    return volux_reverse32(x);
}

/* 32-bit hash of a 64-bit key (for deriving scrambling seeds). */
static inline uint32_t volux_sobol_hash(uint64_t z) {
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return (uint32_t)((z ^ (z >> 31)) >> 32);
}

/* The index-th point of the 2-D Sobol sequence shuffled and Owen-scrambled
 * under key (Burley 2020, shuffled_scrambled_sobol2d): three independent
 * seeds from the key — the index shuffle and one scramble per dimension. */
static inline void volux_sobol2d_scrambled(uint32_t index, uint64_t key, uint32_t *x, uint32_t *y) {
    uint32_t i = volux_owen_scramble(index, volux_sobol_hash(key ^ 0x5bd1e995a1b2c3d4ull));
    *x = volux_owen_scramble(volux_sobol0(i), volux_sobol_hash(key + 0x9e3779b97f4a7c15ull));
    *y = volux_owen_scramble(volux_sobol1(i), volux_sobol_hash(key + 0x3c6ef372fe94f82aull));
}

/* 32-bit fixed point to a float in [0, 1) (24 bits: never rounds up to 1). */
static inline float volux_u32_to_float(uint32_t x) { return (float)(x >> 8) * (1.0f / 16777216.0f); }
static inline double volux_u32_to_double(uint32_t x) { return (double)x * (1.0 / 4294967296.0); }

#endif
