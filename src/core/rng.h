/*
 * core/rng.h — counter-based random numbers (DESIGN §1 determinism).
 *
 * A stream is keyed by (seed, pixel, sample index); the n-th number of the
 * stream is a pure hash of (key, n), so results never depend on which thread
 * drew them or in which order pixels were rendered. The mixer is a
 * 64-bit finaliser in the style of SplitMix64/Murmur3 (strong avalanche;
 * passes the statistical tests that matter for Monte-Carlo integration).
 */
#ifndef VOLUX_RNG_H
#define VOLUX_RNG_H

#include <stdint.h>

typedef struct volux_rng {
    uint64_t key;
    uint64_t counter;
} volux_rng;

static inline uint64_t volux_mix64(uint64_t z) {
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

/* Stream for (seed, pixel index, sample index, stream id). */
static inline volux_rng volux_rng_make(uint64_t seed, uint64_t pixel, uint64_t sample, uint64_t stream) {
    uint64_t k = volux_mix64(seed + 0x9e3779b97f4a7c15ull);
    k = volux_mix64(k ^ (pixel + 0x632be59bd9b4e019ull));
    k = volux_mix64(k ^ (sample * 0x9e3779b97f4a7c15ull + 0x85157af5ull));
    k = volux_mix64(k ^ (stream + 0xd1b54a32d192ed03ull));
    volux_rng r = {k, 0};
    return r;
}

static inline uint64_t volux_rng_u64(volux_rng *r) {
    return volux_mix64(r->key ^ ((r->counter++) * 0x9e3779b97f4a7c15ull));
}

/* Uniform in [0, 1): 24 random mantissa bits. */
static inline float volux_rng_float(volux_rng *r) {
    return (float)(volux_rng_u64(r) >> 40) * (1.0f / 16777216.0f);
}

static inline double volux_rng_double(volux_rng *r) {
    return (double)(volux_rng_u64(r) >> 11) * (1.0 / 9007199254740992.0);
}

#endif
