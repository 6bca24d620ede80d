/*
 * sample/sampler.h — which numbers a Monte-Carlo path draws: independent
 * (core/rng.h) or low-discrepancy ("sobol": padded, shuffled, Owen-scrambled
 * 2-D Sobol points, core/sobol.h after Burley 2020).
 *
 * Dimensions are assigned per path event, two at a time (a "slot"):
 *   slot 0                     the pixel position (box filter jitter)
 *   slot 1 + 5·k + use         event k (k scattering events so far, k below
 *                              VOLUX_LD_DEPTH), use one of volux_ld_use.
 * Each slot has its own index shuffle and scrambles (Burley §5, padding), so
 * the pairs of a path are independent of one another while each pair is
 * stratified over the pixel's samples: with N = 2^m samples per pixel the N
 * points of a slot form a (0, m, 2)-net. Draws that have no slot (deeper
 * events, the variable-length steps of ratio tracking, the tracking steps
 * after the first, a second light at one vertex) come from the independent
 * stream, as before. Every number is still uniform on [0, 1) and the
 * numbers of different slots and the stream are independent, so every
 * estimator stays unbiased (tests/unit/test_sobol.c).
 *
 * The point of slot s for (seed, pixel, sample index) is a pure function of
 * those: images are the same for any thread count, tile order or MPI split
 * (the sample index is global per pixel).
 */
#ifndef VOLUX_SAMPLE_SAMPLER_H
#define VOLUX_SAMPLE_SAMPLER_H

#include <stdint.h>
#include <string.h>

#include "core/rng.h"
#include "core/sobol.h"

/* Events of a path (scattering events 0 … VOLUX_LD_DEPTH − 1) that draw
 * from the sequence; deeper ones carry little of the image's variance. */
#define VOLUX_LD_DEPTH 8

/* What an event's pair of dimensions is for. */
enum volux_ld_use {
    VOLUX_LD_FLIGHT,   /* (first free-flight step, first step of the first shadow
                          ray at the vertex it reaches): jointly stratified, as
                          single scattering's integrand depends on both      */
    VOLUX_LD_LIGHT,    /* next-event direction (the first light that needs two) */
    VOLUX_LD_PHASE,    /* continuation direction */
    VOLUX_LD_ROULETTE, /* (scatter/absorb at the vertex, Russian roulette) */
    VOLUX_LD_CHOICE,   /* a technique's strategy choice (guided's mixture) */
    VOLUX_LD_USES
};

enum volux_sampler_kind { VOLUX_SAMPLER_INDEPENDENT = 0, VOLUX_SAMPLER_SOBOL = 1 };

typedef struct volux_sampler {
    uint64_t key;   /* hash of (seed, pixel) */
    uint32_t index; /* the pixel's sample index */
    int on;         /* 0: independent (no slot draws) */
} volux_sampler;

static inline volux_sampler volux_sampler_make(int kind, uint64_t seed, uint64_t pixel, uint32_t sample_index) {
    volux_sampler s;
    s.key = volux_mix64(volux_mix64(seed ^ 0x50626f6c53616d70ull) ^ (pixel * 0xd6e8feb86659fd93ull));
    s.index = sample_index;
    s.on = kind == VOLUX_SAMPLER_SOBOL;
    return s;
}

static inline uint32_t volux_sampler_slot(int event, int use) {
    return 1u + (uint32_t)event * VOLUX_LD_USES + (uint32_t)use;
}

/* The pair of slot `slot` for this pixel sample, 32-bit fixed point. */
static inline void volux_sampler_2d_u32(const volux_sampler *s, uint32_t slot, uint32_t *x, uint32_t *y) {
    volux_sobol2d_scrambled(s->index, volux_mix64(s->key + (uint64_t)slot * 0x9e3779b97f4a7c15ull), x, y);
}

static inline void volux_sampler_2d(const volux_sampler *s, uint32_t slot, float *u, float *v) {
    uint32_t x, y;
    volux_sampler_2d_u32(s, slot, &x, &y);
    *u = volux_u32_to_float(x);
    *v = volux_u32_to_float(y);
}

/* A technique's `sampler` parameter: the kind, or -1 for an unknown name. */
static inline int volux_sampler_parse(const char *name) {
    if (name && !strcmp(name, "sobol")) return VOLUX_SAMPLER_SOBOL;
    if (name && !strcmp(name, "independent")) return VOLUX_SAMPLER_INDEPENDENT;
    return -1;
}

#endif
