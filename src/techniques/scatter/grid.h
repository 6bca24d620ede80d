/*
 * techniques/scatter/grid.h — scalar cache grids over the volume box
 * (radiance caches, transmittance caches, ambient extinction, occlusion).
 *
 * A grid of dims m (per axis) spans exactly the volume's node box: node i
 * lies at lo + i·h with h = (box size)/(m − 1), so a grid at scale 1 has
 * the volume's nodes and one at scale 0.5 about every other one. Values are
 * float, linear, x fastest; trilinear lookups clamp to the box.
 */
#ifndef VOLUX_SCATTER_GRID_H
#define VOLUX_SCATTER_GRID_H

#include "core/vecmath.h"
#include "core/volume_internal.h"

typedef struct scatter_grid {
    int dims[3];
    volux_vec3 lo;   /* world position of node 0                        */
    float h[3];      /* world spacing                                    */
    float inv_h[3];
    float *v;
    size_t bytes;
} scatter_grid;

/* Allocates (or keeps, if the shape is unchanged) a grid over v's box at
 * `scale` of its resolution (m = max(2, ceil((n − 1)·scale) + 1), or 1
 * where n is 1). */
volux_status scatter_grid_alloc(volux_context *ctx, const volux_volume *v, float scale, scatter_grid *g, const char *what);
void scatter_grid_free(volux_context *ctx, scatter_grid *g);

static inline volux_vec3 scatter_grid_node(const scatter_grid *g, int i, int j, int k) {
    return v3(g->lo.x + (float)i * g->h[0], g->lo.y + (float)j * g->h[1], g->lo.z + (float)k * g->h[2]);
}

/* Trilinear value at grid-index position (x, y, z), clamped into the grid. */
static inline float scatter_grid_sample_index(const scatter_grid *g, float x, float y, float z) {
    int nx = g->dims[0], ny = g->dims[1], nz = g->dims[2];
    float mx = (float)(nx - 1), my = (float)(ny - 1), mz = (float)(nz - 1);
    x = x < 0.0f ? 0.0f : (x > mx ? mx : x);
    y = y < 0.0f ? 0.0f : (y > my ? my : y);
    z = z < 0.0f ? 0.0f : (z > mz ? mz : z);
    int i = (int)x, j = (int)y, k = (int)z;
    if (i > nx - 2) i = nx > 1 ? nx - 2 : 0;
    if (j > ny - 2) j = ny > 1 ? ny - 2 : 0;
    if (k > nz - 2) k = nz > 1 ? nz - 2 : 0;
    float fx = x - (float)i, fy = y - (float)j, fz = z - (float)k;
    size_t sx = nx > 1 ? 1 : 0, sy = ny > 1 ? (size_t)nx : 0, sz = nz > 1 ? (size_t)nx * (size_t)ny : 0;
    const float *b = g->v + ((size_t)k * (size_t)ny + (size_t)j) * (size_t)nx + (size_t)i;
    float c00 = b[0] + (b[sx] - b[0]) * fx, c10 = b[sy] + (b[sy + sx] - b[sy]) * fx;
    float c01 = b[sz] + (b[sz + sx] - b[sz]) * fx, c11 = b[sz + sy] + (b[sz + sy + sx] - b[sz + sy]) * fx;
    float c0 = c00 + (c10 - c00) * fy, c1 = c01 + (c11 - c01) * fy;
    return c0 + (c1 - c0) * fz;
}

/* dst (allocated) ← src sampled trilinearly at dst's nodes, on `threads`. */
void scatter_grid_resample(int threads, const scatter_grid *src, scatter_grid *dst);

/* Trilinear value at a world position (clamped into the box). */
static inline float scatter_grid_sample(const scatter_grid *g, volux_vec3 p) {
    return scatter_grid_sample_index(g, (p.x - g->lo.x) * g->inv_h[0], (p.y - g->lo.y) * g->inv_h[1],
                                     (p.z - g->lo.z) * g->inv_h[2]);
}

#endif
