/*
 * core/volume_internal.h — the volume's layout, for io (which fills it) and
 * techniques (which sample it in tight loops).
 *
 * Storage is linear, x fastest. A file value is `stored + value_offset`.
 * Macrocells: cell (cx,cy,cz) covers index-space [8c, 8c+8] on each axis
 * (nodes inclusive), so the trilinear field inside a cell lies within the
 * cell's [min,max]; these ranges are TF-independent and built once.
 */
#ifndef VOLUX_VOLUME_INTERNAL_H
#define VOLUX_VOLUME_INTERNAL_H

#include <math.h>

#include "context_internal.h"
#include "volux/volume.h"

#define VOLUX_CELL_SHIFT 3
#define VOLUX_CELL_SIZE (1 << VOLUX_CELL_SHIFT)

struct volux_volume {
    volux_context *ctx;
    int refcount;
    uint64_t id;            /* unique per process: identifies a time step */
    int dims[3];
    double spacing[3];
    volux_vec3 origin;
    float inv_spacing[3];
    volux_scalar_type type;
    volux_storage storage;
    float value_offset;
    void *data;
    size_t data_bytes;
    double vmin, vmax;
    int cells[3];
    float *cell_min, *cell_max; /* file units, cells[0]·cells[1]·cells[2] */
    size_t cell_bytes;
    /* Bricked copy for fast sampling (built on demand, see below). */
    void *bricks;
    size_t brick_bytes;
    int brick_counts[3];
};

/* Bricked layout: 8³-cell bricks stored as 9³ nodes (one-node apron on the
 * high side), so all 8 corners of a trilinear lookup lie in one brick at
 * fixed offsets. Oblique rays touch far fewer cache lines than in the
 * linear layout (perf/LIMITS.md: ~2× for scalar code). */
#define VOLUX_BRICK_CELLS 8
#define VOLUX_BRICK_NODES 9
#define VOLUX_BRICK_VOXELS (VOLUX_BRICK_NODES * VOLUX_BRICK_NODES * VOLUX_BRICK_NODES)
#define VOLUX_BRICK_TAIL 64 /* zeroed bytes after the last brick (see build) */

/* Builds the bricked copy if missing (not thread-safe: call from setup code,
 * never from render_tile). Fails only on memory. */
volux_status volux_volume_build_bricks(volux_volume *v);

/* Allocates a volume whose storage the caller fills (io readers), after
 * validating dims/spacing and the byte size against the context's cap. */
volux_status volux_volume_create_storage(volux_context *ctx, const int dims[3], const double spacing[3],
                                         volux_scalar_type type, volux_volume **out);
/* Storage byte size a volume of this shape/type would need (0 on overflow). */
size_t volux_volume_storage_bytes(const int dims[3], volux_scalar_type type);
/* Centres the volume (or sets an explicit origin), computes the value range
 * and the macrocells. Call once after filling storage. */
volux_status volux_volume_finalize(volux_volume *v, const double *origin /* NULL: centred */);

static inline size_t volux_volume_index(const volux_volume *v, int i, int j, int k) {
    return ((size_t)k * (size_t)v->dims[1] + (size_t)j) * (size_t)v->dims[0] + (size_t)i;
}

static inline __attribute__((always_inline)) float volux_volume_raw_as(const volux_volume *v, size_t idx,
                                                                         volux_storage storage) {
    switch (storage) {
    case VOLUX_STORE_U8: return (float)((const uint8_t *)v->data)[idx];
    case VOLUX_STORE_U16: return (float)((const uint16_t *)v->data)[idx];
    default: return ((const float *)v->data)[idx];
    }
}

static inline float volux_volume_raw_at(const volux_volume *v, size_t idx) {
    return volux_volume_raw_as(v, idx, v->storage);
}

/* Trilinear sample at index-space position (x,y,z), which must lie in
 * [0, n−1] per axis (callers clip rays to the box). File units. Hot loops
 * pass a compile-time `storage` so the type switch disappears. */
static inline __attribute__((always_inline)) float volux_volume_sample_index_as(const volux_volume *v, float x,
                                                                                float y, float z,
                                                                                volux_storage storage) {
    int nx = v->dims[0], ny = v->dims[1], nz = v->dims[2];
    int i = (int)x, j = (int)y, k = (int)z;
    if (i > nx - 2) i = nx > 1 ? nx - 2 : 0;
    if (j > ny - 2) j = ny > 1 ? ny - 2 : 0;
    if (k > nz - 2) k = nz > 1 ? nz - 2 : 0;
    if (i < 0) i = 0;
    if (j < 0) j = 0;
    if (k < 0) k = 0;
    float fx = x - (float)i, fy = y - (float)j, fz = z - (float)k;
    size_t sx = nx > 1 ? 1 : 0, sy = ny > 1 ? (size_t)nx : 0, sz = nz > 1 ? (size_t)nx * (size_t)ny : 0;
    size_t b = volux_volume_index(v, i, j, k);
#define VOLUX_AT_(o) volux_volume_raw_as(v, b + (o), storage)
    float c000 = VOLUX_AT_(0), c100 = VOLUX_AT_(sx), c010 = VOLUX_AT_(sy), c110 = VOLUX_AT_(sx + sy);
    float c001 = VOLUX_AT_(sz), c101 = VOLUX_AT_(sx + sz), c011 = VOLUX_AT_(sy + sz), c111 = VOLUX_AT_(sx + sy + sz);
#undef VOLUX_AT_
    float c00 = c000 + (c100 - c000) * fx, c10 = c010 + (c110 - c010) * fx;
    float c01 = c001 + (c101 - c001) * fx, c11 = c011 + (c111 - c011) * fx;
    float c0 = c00 + (c10 - c00) * fy, c1 = c01 + (c11 - c01) * fy;
    return c0 + (c1 - c0) * fz + v->value_offset;
}

/* Trilinear sample from the bricked copy (same contract and result as
 * volux_volume_sample_index_as; volux_volume_build_bricks must have run). */
static inline __attribute__((always_inline)) float volux_volume_sample_bricked(const volux_volume *v, float x, float y,
                                                                               float z, volux_storage storage) {
    int nx = v->dims[0], ny = v->dims[1], nz = v->dims[2];
    int i = (int)x, j = (int)y, k = (int)z;
    if (i > nx - 2) i = nx > 1 ? nx - 2 : 0;
    if (j > ny - 2) j = ny > 1 ? ny - 2 : 0;
    if (k > nz - 2) k = nz > 1 ? nz - 2 : 0;
    if (i < 0) i = 0;
    if (j < 0) j = 0;
    if (k < 0) k = 0;
    float fx = x - (float)i, fy = y - (float)j, fz = z - (float)k;
    size_t brick = ((size_t)(k >> 3) * (size_t)v->brick_counts[1] + (size_t)(j >> 3)) * (size_t)v->brick_counts[0] +
                   (size_t)(i >> 3);
    size_t b = brick * VOLUX_BRICK_VOXELS + (size_t)((i & 7) + VOLUX_BRICK_NODES * (j & 7) +
                                                     VOLUX_BRICK_NODES * VOLUX_BRICK_NODES * (k & 7));
    enum { SY = VOLUX_BRICK_NODES, SZ = VOLUX_BRICK_NODES * VOLUX_BRICK_NODES };
    float c000, c100, c010, c110, c001, c101, c011, c111;
    if (storage == VOLUX_STORE_U8) {
        const uint8_t *p = (const uint8_t *)v->bricks + b;
        c000 = p[0], c100 = p[1], c010 = p[SY], c110 = p[SY + 1];
        c001 = p[SZ], c101 = p[SZ + 1], c011 = p[SZ + SY], c111 = p[SZ + SY + 1];
    } else if (storage == VOLUX_STORE_U16) {
        const uint16_t *p = (const uint16_t *)v->bricks + b;
        c000 = p[0], c100 = p[1], c010 = p[SY], c110 = p[SY + 1];
        c001 = p[SZ], c101 = p[SZ + 1], c011 = p[SZ + SY], c111 = p[SZ + SY + 1];
    } else {
        const float *p = (const float *)v->bricks + b;
        c000 = p[0], c100 = p[1], c010 = p[SY], c110 = p[SY + 1];
        c001 = p[SZ], c101 = p[SZ + 1], c011 = p[SZ + SY], c111 = p[SZ + SY + 1];
    }
    float c00 = c000 + (c100 - c000) * fx, c10 = c010 + (c110 - c010) * fx;
    float c01 = c001 + (c101 - c001) * fx, c11 = c011 + (c111 - c011) * fx;
    float c0 = c00 + (c10 - c00) * fy, c1 = c01 + (c11 - c01) * fy;
    return c0 + (c1 - c0) * fz + v->value_offset;
}

static inline float volux_volume_sample_index(const volux_volume *v, float x, float y, float z) {
    return volux_volume_sample_index_as(v, x, y, z, v->storage);
}

/* World → index space. */
static inline volux_vec3 volux_volume_to_index(const volux_volume *v, volux_vec3 p) {
    volux_vec3 r = {(p.x - v->origin.x) * v->inv_spacing[0], (p.y - v->origin.y) * v->inv_spacing[1],
                    (p.z - v->origin.z) * v->inv_spacing[2]};
    return r;
}

static inline int volux_volume_inside_index(const volux_volume *v, volux_vec3 q) {
    return q.x >= 0.0f && q.y >= 0.0f && q.z >= 0.0f && q.x <= (float)(v->dims[0] - 1) &&
           q.y <= (float)(v->dims[1] - 1) && q.z <= (float)(v->dims[2] - 1);
}

/* Gradient at index-space q in file units per *index* unit (central
 * differences of the trilinear field, clamped at the border). */
volux_vec3 volux_volume_gradient_index(const volux_volume *v, volux_vec3 q);

#endif
