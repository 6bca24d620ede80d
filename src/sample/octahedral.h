/*
 * sample/octahedral.h — the equal-area octahedral map between the unit
 * square and the sphere (Clarberg, "Fast equal-area mapping of the
 * (hemi)sphere using SIMD", JGT 13(3), 2008), Morton order on square grids,
 * and quadtrees over Morton-ordered grids with hierarchical sample warping
 * (Clarberg et al., "Wavelet importance sampling", SIGGRAPH 2005, §4) for
 * spherical functions stored as octahedral images.
 *
 * MAP. (u, v) ∈ [0,1]² is scaled to (a, b) ∈ [−1,1]²; the inner diamond
 * |a| + |b| ≤ 1 is the hemisphere z ≥ 0 (the centre is +Z), the four
 * corner triangles are z < 0 (the corners are −Z). With r the distance from
 * the nearest pole measured as r = |a| + |b| (inner) or 2 − |a| − |b|
 * (outer): z = ±(1 − r²), and the azimuth in each quadrant is linear in
 * (|b| − |a|)/r. The area element is constant: dω = 4π du dv, so a density
 * p(u, v) on the square is p(u, v)/(4π) per steradian and every texel of
 * an N×N octahedral image covers the same solid angle 4π/N².
 *
 * QUADTREE. A pyramid over a 2^L × 2^L grid of non-negative values: level l
 * has 4^l nodes in Morton order (node i of level l covers nodes 4i … 4i+3 of
 * level l + 1: child j = x bit | y bit << 1), each the sum of its children;
 * the levels are stored one after another (level l starts at
 * volux_qt_offset(l)). Sampling passes a uniform (u, v) down the tree,
 * choosing the column by the 2×2 tile's column sums and then the row within
 * it, and rescaling (u, v) to the chosen child, so the leaf is drawn with
 * probability leaf/root and (u, v) ends uniform inside the leaf. The
 * probability of a leaf is the product of the conditional probabilities
 * c_child/Σc along the path, computed by one helper for sampling and for
 * evaluation, so a sample's density and the evaluated density are the same
 * number.
 */
#ifndef VOLUX_SAMPLE_OCTAHEDRAL_H
#define VOLUX_SAMPLE_OCTAHEDRAL_H

#include <math.h>
#include <stdint.h>

#include "core/vecmath.h"

/* Unit direction of the point (u, v) ∈ [0,1]² (Clarberg 2008, sec. 3). */
static inline volux_vec3 volux_octa_to_dir(float u, float v) {
    float a = 2.0f * u - 1.0f, b = 2.0f * v - 1.0f;
    float ap = fabsf(a), bp = fabsf(b);
    float sd = 1.0f - (ap + bp); /* > 0 inside the diamond (z > 0) */
    float r = 1.0f - fabsf(sd);
    float phi = (r == 0.0f ? 1.0f : (bp - ap) / r + 1.0f) * (VOLUX_PI / 4.0f);
    float z = copysignf(1.0f - r * r, sd);
    float s = r * sqrtf(fmaxf(0.0f, 2.0f - r * r));
    float x = copysignf(cosf(phi), a) * s, y = copysignf(sinf(phi), b) * s;
    return v3(x, y, z);
}

/* (u, v) ∈ [0,1]² of unit direction d (the inverse of volux_octa_to_dir). */
static inline void volux_octa_from_dir(volux_vec3 d, float *u, float *v) {
    float ax = fabsf(d.x), ay = fabsf(d.y);
    float r = sqrtf(fmaxf(0.0f, 1.0f - fabsf(d.z)));
    float phi = atan2f(ay, ax) * (2.0f / VOLUX_PI); /* azimuth in the quadrant, in [0, 1] */
    float bp = r * phi, ap = r - bp;                 /* inner diamond: |a| + |b| = r */
    if (d.z < 0.0f) {                                /* outer triangle: fold across the diamond's edge */
        float t = 1.0f - bp;
        bp = 1.0f - ap;
        ap = t;
    }
    float a = copysignf(ap, d.x), b = copysignf(bp, d.y);
    *u = fminf(fmaxf(0.5f * (a + 1.0f), 0.0f), 1.0f);
    *v = fminf(fmaxf(0.5f * (b + 1.0f), 0.0f), 1.0f);
}

/* Texel of (u, v) in an n×n image (clamped to the grid). */
static inline int volux_octa_texel(float u, int n) {
    int i = (int)(u * (float)n);
    return i < 0 ? 0 : i >= n ? n - 1 : i;
}

/* Morton code of (x, y) < 2^16 (x in the even bits) and its inverse. */
static inline uint32_t volux_morton_spread(uint32_t x) {
    x &= 0xffffu;
    x = (x | (x << 8)) & 0x00ff00ffu;
    x = (x | (x << 4)) & 0x0f0f0f0fu;
    x = (x | (x << 2)) & 0x33333333u;
    x = (x | (x << 1)) & 0x55555555u;
    return x;
}
static inline uint32_t volux_morton_compact(uint32_t x) {
    x &= 0x55555555u;
    x = (x | (x >> 1)) & 0x33333333u;
    x = (x | (x >> 2)) & 0x0f0f0f0fu;
    x = (x | (x >> 4)) & 0x00ff00ffu;
    x = (x | (x >> 8)) & 0x0000ffffu;
    return x;
}
static inline uint32_t volux_morton2(uint32_t x, uint32_t y) {
    return volux_morton_spread(x) | (volux_morton_spread(y) << 1);
}
static inline void volux_morton2_decode(uint32_t m, uint32_t *x, uint32_t *y) {
    *x = volux_morton_compact(m);
    *y = volux_morton_compact(m >> 1);
}

/* First node of level l in a concatenated pyramid: (4^l − 1)/3. */
static inline uint32_t volux_qt_offset(int level) { return ((1u << (2 * level)) - 1u) / 3u; }

/* Fills levels L−1 … 0 of `nodes` from level L (the leaves, in Morton
 * order at volux_qt_offset(L)). */
static inline void volux_qt_build(float *nodes, int L) {
    for (int l = L - 1; l >= 0; l--) {
        float *up = nodes + volux_qt_offset(l);
        const float *down = nodes + volux_qt_offset(l + 1);
        uint32_t n = 1u << (2 * l);
        for (uint32_t i = 0; i < n; i++) up[i] = down[4 * i] + down[4 * i + 1] + down[4 * i + 2] + down[4 * i + 3];
    }
}

/* The conditional probability of child j of the 2×2 tile c: one
 * expression, shared by sampling and evaluation. */
static inline float volux_qt_child_prob(const float *c, uint32_t j) {
    float sum = c[0] + c[1] + c[2] + c[3];
    return sum > 0.0f ? c[j] / sum : 0.0f;
}

/* Passes (u, v) ∈ [0,1)² down from node `node` of level `from` to level
 * `to`: returns the node reached at level `to` (its Morton index within the
 * level), leaves (u, v) uniform inside it, and multiplies *prob by the
 * probability of the path. A tile whose children sum to 0 stops the
 * descent with *prob = 0. */
static inline uint32_t volux_qt_sample(const float *nodes, int from, uint32_t node, int to, double *u, double *v,
                                       float *prob) {
    for (int l = from; l < to; l++) {
        const float *c = nodes + volux_qt_offset(l + 1) + 4 * node;
        /* The next step reads one of c's 4 children's tiles: 16 floats,
         * one cache line. Fetching it now overlaps its miss (the deep
         * levels of a 512² environment are MBs) with this step's work. */
        if (l + 2 <= to) __builtin_prefetch(nodes + volux_qt_offset(l + 2) + 16 * node);
        double left = (double)c[0] + (double)c[2], right = (double)c[1] + (double)c[3];
        if (!(left + right > 0.0)) {
            *prob = 0.0f;
            return node;
        }
        /* column: x bit */
        double px = left / (left + right);
        uint32_t xb = *u < px ? 0u : 1u;
        *u = xb ? (*u - px) / (1.0 - px) : *u / px;
        /* row within the column: y bit */
        double lo = xb ? c[1] : c[0], hi = xb ? c[3] : c[2];
        double py = lo / (lo + hi);
        uint32_t yb = *v < py ? 0u : 1u;
        *v = yb ? (*v - py) / (1.0 - py) : *v / py;
        /* rounding can leave u, v a hair outside [0, 1) */
        if (*u >= 1.0) *u = 0x1.fffffffffffffp-1;
        if (*v >= 1.0) *v = 0x1.fffffffffffffp-1;
        if (*u < 0.0) *u = 0.0;
        if (*v < 0.0) *v = 0.0;
        uint32_t j = xb | (yb << 1);
        *prob *= volux_qt_child_prob(c, j);
        node = 4 * node + j;
    }
    return node;
}

/* The probability of reaching `leaf` (a node of level `to` below `node` of
 * level `from`) by volux_qt_sample from `node`: the product of the same
 * conditional probabilities. */
static inline float volux_qt_prob(const float *nodes, int from, uint32_t node, int to, uint32_t leaf) {
    /* The path is known: fetch every tile on it first, so the misses
     * overlap (same products, same order). */
    uint32_t n = node;
    for (int l = from; l < to; l++) {
        __builtin_prefetch(nodes + volux_qt_offset(l + 1) + 4 * n);
        n = 4 * n + ((leaf >> (2 * (to - l - 1))) & 3u);
    }
    float prob = 1.0f;
    for (int l = from; l < to; l++) {
        uint32_t j = (leaf >> (2 * (to - l - 1))) & 3u;
        prob *= volux_qt_child_prob(nodes + volux_qt_offset(l + 1) + 4 * node, j);
        node = 4 * node + j;
    }
    return prob;
}

#endif
