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
 * so reverse → hash → reverse is a nested uniform scramble (the constants
 * are those of Burley's laine_karras_permutation). The scrambled
 * point is uniform in [0, 1)² whatever the index (unbiasedness) and the net
 * property survives (stratification).
 *
 * The same scramble applied to the *index* shuffles the sequence (Burley
 * §4): a bit of the result depends on that bit and the bits above it, so
 * indices below 2^m keep one common high part and their low m bits map one
 * to one — the first 2^m shuffled indices are one aligned block, a net, but
 * each pixel (and each pair of dimensions, "padding", §5) sees its own order.
 * That decorrelates the pairs a path uses at its events from one another.
 *
 * Pure functions of their arguments: thread count and render order do not
 * matter (DESIGN §1).
 */
#ifndef VOLUX_SOBOL_H
#define VOLUX_SOBOL_H

#include <stdint.h>

static inline uint32_t volux_reverse32(uint32_t x) {
    x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
    x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
    x = ((x >> 4) & 0x0f0f0f0fu) | ((x & 0x0f0f0f0fu) << 4);
    x = ((x >> 8) & 0x00ff00ffu) | ((x & 0x00ff00ffu) << 8);
    return (x >> 16) | (x << 16);
}

/* Dimension 1 of Sobol's sequence, bit-reversed (bit j holds the digit of
 * 2^−(j+1)). Its generator matrix is Pascal's triangle mod 2: digit j is
 * the XOR of index bits k with C(k, j) odd, i.e. (Lucas) with j ⊆ k as bit
 * sets — a superset sum over the 5-bit positions, five shift-mask-XOR
 * steps instead of a loop over the 32 direction numbers
 * v_k = v_{k−1} ^ (v_{k−1} >> 1) (tests/unit/test_sobol.c checks the two
 * agree). Dimension 0 (van der Corput), bit-reversed, is the index itself. */
static inline uint32_t volux_sobol1_reversed(uint32_t i) {
    i ^= (i >> 1) & 0x55555555u;
    i ^= (i >> 2) & 0x33333333u;
    i ^= (i >> 4) & 0x0f0f0f0fu;
    i ^= (i >> 8) & 0x00ff00ffu;
    i ^= (i >> 16) & 0x0000ffffu;
    return i;
}

/* The Laine–Karras-style hash of Burley 2020 (the constants of its
 * laine_karras_permutation listing) on a
 * bit-reversed value: bit k of the result is bit k of x flipped by a
 * function of the seed and bits 0 … k−1 only. */
static inline uint32_t volux_lk_hash(uint32_t x, uint32_t seed) {
    x += seed;
    x ^= x * 0x6c50b47cu;
    x ^= x * 0xb82f1e52u;
    x ^= x * 0xc7afe638u;
    x ^= x * 0x8d22f6e6u;
    return x;
}

/* Nested uniform scramble of a 32-bit fixed-point value (Burley 2020):
 * reverse, hash, reverse. */
static inline uint32_t volux_owen_scramble(uint32_t x, uint32_t seed) {
    return volux_reverse32(volux_lk_hash(volux_reverse32(x), seed));
}

/* The index-th point of the 2-D Sobol sequence, shuffled and Owen-scrambled
 * under seed (Burley 2020's shuffled_scrambled_sobol, two dimensions): three
 * independent 32-bit seeds derived from it — the index shuffle and one
 * scramble per dimension. Written in the bit-reversed domain, where both
 * Sobol dimensions and the hash live, so only four bit reversals remain.
 * 32-bit fixed point in [0, 1). */
static inline void volux_sobol2d_scrambled(uint32_t index, uint64_t seed, uint32_t *x, uint32_t *y) {
    uint64_t z = (seed ^ (seed >> 29)) * 0xbf58476d1ce4e5b9ull;
    uint32_t s1 = (uint32_t)(seed >> 32), s2 = (uint32_t)(z >> 32);
    uint32_t i = volux_reverse32(volux_lk_hash(volux_reverse32(index), (uint32_t)seed)); /* shuffled index */
    *x = volux_reverse32(volux_lk_hash(i, s1));
    *y = volux_reverse32(volux_lk_hash(volux_sobol1_reversed(i), s2));
}

/* 32-bit fixed point to a float in [0, 1) (24 bits: never rounds up to 1). */
static inline float volux_u32_to_float(uint32_t x) { return (float)(x >> 8) * (1.0f / 16777216.0f); }
static inline double volux_u32_to_double(uint32_t x) { return (double)x * (1.0 / 4294967296.0); }

#endif
