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
    size_t data_bytes;      /* bytes of `data`; owned unless `borrowed`    */
    int borrowed;           /* data is the caller's (volux_volume_from_memory) */
    void (*release_data)(void *user);
    void *release_user;
    /* Out of core (volume_map.c): data is a read-only mapping of the file
     * (map_base/map_len: the whole mapping, from a page boundary) and the
     * bricked copy a shared mapping of an unlinked temporary file. */
    int mapped;
    void *map_base;
    size_t map_len;
    double vmin, vmax;
    /* Unit direction of anatomical superior (head) in the volume's world,
     * from the file's orientation (NIfTI qform/sform, NRRD space); used to
     * pick the camera's up. has_superior 0: the file says nothing. */
    volux_vec3 superior;
    int has_superior;
    int cells[3];
    float *cell_min, *cell_max; /* file units, cells[0]·cells[1]·cells[2] */
    size_t cell_bytes;
    /* Bricked copy for fast sampling (built on demand, see below). */
    void *bricks;
    size_t brick_bytes;
    int brick_counts[3];
    /* Data-parallel rendering: this volume is brick `part_index` of
     * `part_count` of a whole grid (volux_brick_info; part_count 0: an
     * ordinary volume). Named "part" because "brick" above is the
     * sampling layout's. */
    int part_count, part_index;
    int whole_dims[3], owned_lo[3], owned_hi[3], stored_lo[3];
    volux_vec3 whole_origin; /* float, computed as a whole load would */
    float whole_gradient_max; /* volux_volume_set_whole_stats; 0: unknown */
};

/* Out-of-core storage (volume_map.c). volux_volume_map_file maps the
 * data of a dims/type volume that starts at byte `offset` of the open file
 * `fd` (values stored exactly as the type's storage, native order); the
 * volume is not finalized. VOLUX_ERR_IO naming `name` when the mapping
 * fails. */
volux_status volux_volume_map_file(volux_context *ctx, const char *name, int fd, uint64_t offset, const int dims[3],
                                   const double spacing[3], volux_scalar_type type, volux_volume **out);
/* A volume header without storage (the caller sets data): volume.c. */
volux_status volux_volume_create_borrowed(volux_context *ctx, const int dims[3], const double spacing[3],
                                          volux_scalar_type type, volux_volume **out);
void volux_volume_unmap(volux_volume *v);
/* Drops the resident pages of bytes [first_byte, first_byte + bytes) of a
 * mapped volume's data (nothing for an ordinary volume); the next touch
 * reads them again. */
void volux_volume_trim(const volux_volume *v, size_t first_byte, size_t bytes);
void volux_map_trim(const void *p, size_t bytes);
/* `bytes` of zeroes in a shared mapping of an unlinked temporary file
 * ($TMPDIR, else /var/tmp), or NULL with the error recorded. */
void *volux_map_scratch(volux_context *ctx, size_t bytes);
void volux_unmap_scratch(void *p, size_t bytes);

/* Bricked layout: 8³-cell bricks stored as 9³ nodes (one-node apron on the
 * high side), so all 8 corners of a trilinear lookup lie in one brick at
 * fixed offsets. Oblique rays touch far fewer cache lines than in the
 * linear layout (~2× for scalar code, measured on oblique views). */
#define VOLUX_BRICK_CELLS 8
#define VOLUX_BRICK_NODES 9
#define VOLUX_BRICK_VOXELS (VOLUX_BRICK_NODES * VOLUX_BRICK_NODES * VOLUX_BRICK_NODES)
#define VOLUX_BRICK_TAIL 64 /* zeroed bytes after the last brick (see build) */

/* Builds the bricked copy if missing (not thread-safe: call from setup code,
 * never from render_tile). Fails only on memory. */
volux_status volux_volume_build_bricks(volux_volume *v);

/* Makes v brick `index` of `count` of a whole grid of whole_dims nodes
 * whose node 0 lies at whole_origin (double, as volux_volume_finalize
 * would be given for the whole): v's node 0 is the whole grid's node
 * stored_lo. Call after volux_volume_finalize with the matching origin
 * (volux_brick_origin). */
void volux_volume_make_part(volux_volume *v, int count, int index, const int whole_dims[3], const int stored_lo[3],
                            const double whole_origin[3]);
/* The origin (world position of node 0) for volux_volume_finalize of the
 * part of a whole grid starting at node stored_lo; whole_origin NULL: the
 * whole grid centred (finalize's default). */
void volux_brick_origin(const int whole_dims[3], const double spacing[3], const double *whole_origin,
                        const int stored_lo[3], double out_whole[3], double out_part[3]);
/* The stored nodes [lo, hi) of brick `index` of `count` with `ghost`
 * layers (clamped to the grid), and its owned nodes. */
volux_status volux_brick_region(const int dims[3], int count, int index, int ghost, int stored_lo[3],
                                int stored_hi[3]);
/* World box the scene frames (camera) and whose ray entry anchors the
 * sample lattice: the whole grid's for a part, else the volume's own. */
void volux_volume_domain_bounds(const volux_volume *v, volux_vec3 *lo, volux_vec3 *hi);
/* The owned box of a part in world units (the volume's own box if not a
 * part). */
void volux_volume_owned_bounds(const volux_volume *v, volux_vec3 *lo, volux_vec3 *hi);
/* Visibility order of the bricks of a k-d split seen from `eye` (world;
 * perspective) or along `dir` (orthographic, eye ignored): order[0] is
 * the front brick. Index space of the whole grid = (world − origin)/spacing
 * preserves the side of every split plane. */
void volux_brick_visibility_order(const int dims[3], int count, const double whole_origin[3],
                                  const double spacing[3], int orthographic, volux_vec3 eye, volux_vec3 dir,
                                  int *order);

/* Records the superior direction (normalised; NULL, zero or non-finite:
 * unknown). */
void volux_volume_set_superior(volux_volume *v, const double dir[3]);

/* Allocates a volume whose storage the caller fills (io readers), after
 * validating dims/spacing and the byte size against the context's cap. */
volux_status volux_volume_create_storage(volux_context *ctx, const int dims[3], const double spacing[3],
                                         volux_scalar_type type, volux_volume **out);
/* Storage byte size a volume of this shape/type would need (0 on overflow). */
size_t volux_volume_storage_bytes(const int dims[3], volux_scalar_type type);
/* Centres the volume (or sets an explicit origin), computes the value range
 * and the macrocells. Call once after filling storage. Non-finite float
 * values are replaced by the lowest finite value (callers that must refuse
 * them count them first: volux_volume_count_nonfinite); a value range wider
 * than float arithmetic holds (max − min > FLT_MAX) is VOLUX_ERR_LIMIT. */
volux_status volux_volume_finalize(volux_volume *v, const double *origin /* NULL: centred */);
/* Number of NaN/±Inf values in float storage (0 for integer storage) and
 * the index of the first (x fastest). */
size_t volux_volume_count_nonfinite(const volux_volume *v, size_t *first);

/* Bytes of one stored value. */
static inline size_t volux_volume_elem_size(const volux_volume *v) {
    return v->storage == VOLUX_STORE_U8 ? 1 : v->storage == VOLUX_STORE_U16 ? 2 : 4;
}

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

/* The trilinear cell containing index-space q (clamped to the grid):
 * the linear index of its low corner, the strides to the other corners
 * (0 along an axis of size 1) and the fractional position. Shared by every
 * trilinear lookup over the linear layout (values, gradients, classified
 * nodes). */
typedef struct volux_cell {
    int i, j, k;
    size_t base, sx, sy, sz;
    float fx, fy, fz;
} volux_cell;

static inline __attribute__((always_inline)) volux_cell volux_volume_cell(const volux_volume *v, float x, float y,
                                                                          float z) {
    int nx = v->dims[0], ny = v->dims[1], nz = v->dims[2];
    volux_cell c;
    c.i = (int)x, c.j = (int)y, c.k = (int)z;
    if (c.i > nx - 2) c.i = nx > 1 ? nx - 2 : 0;
    if (c.j > ny - 2) c.j = ny > 1 ? ny - 2 : 0;
    if (c.k > nz - 2) c.k = nz > 1 ? nz - 2 : 0;
    if (c.i < 0) c.i = 0;
    if (c.j < 0) c.j = 0;
    if (c.k < 0) c.k = 0;
    c.fx = x - (float)c.i, c.fy = y - (float)c.j, c.fz = z - (float)c.k;
    c.sx = nx > 1 ? 1 : 0;
    c.sy = ny > 1 ? (size_t)nx : 0;
    c.sz = nz > 1 ? (size_t)nx * (size_t)ny : 0;
    c.base = volux_volume_index(v, c.i, c.j, c.k);
    return c;
}

static inline float volux_lerp3(const float c[8], float fx, float fy, float fz) {
    float c00 = c[0] + (c[1] - c[0]) * fx, c10 = c[2] + (c[3] - c[2]) * fx;
    float c01 = c[4] + (c[5] - c[4]) * fx, c11 = c[6] + (c[7] - c[6]) * fx;
    float c0 = c00 + (c10 - c00) * fy, c1 = c01 + (c11 - c01) * fy;
    return c0 + (c1 - c0) * fz;
}

/* Trilinear sample at index-space position (x,y,z), which must lie in
 * [0, n−1] per axis (callers clip rays to the box). File units. Hot loops
 * pass a compile-time `storage` so the type switch disappears. */
static inline __attribute__((always_inline)) float volux_volume_sample_index_as(const volux_volume *v, float x,
                                                                                float y, float z,
                                                                                volux_storage storage) {
    volux_cell c = volux_volume_cell(v, x, y, z);
    size_t b = c.base;
    float n[8] = {volux_volume_raw_as(v, b, storage),
                  volux_volume_raw_as(v, b + c.sx, storage),
                  volux_volume_raw_as(v, b + c.sy, storage),
                  volux_volume_raw_as(v, b + c.sx + c.sy, storage),
                  volux_volume_raw_as(v, b + c.sz, storage),
                  volux_volume_raw_as(v, b + c.sx + c.sz, storage),
                  volux_volume_raw_as(v, b + c.sy + c.sz, storage),
                  volux_volume_raw_as(v, b + c.sx + c.sy + c.sz, storage)};
    return volux_lerp3(n, c.fx, c.fy, c.fz) + v->value_offset;
}

/* Trilinear sample from the bricked copy (same contract and result as
 * volux_volume_sample_index_as; volux_volume_build_bricks must have run). */
static inline __attribute__((always_inline)) float volux_volume_sample_bricked(const volux_volume *v, float x, float y,
                                                                               float z, volux_storage storage) {
    volux_cell c = volux_volume_cell(v, x, y, z);
    size_t brick = ((size_t)(c.k >> 3) * (size_t)v->brick_counts[1] + (size_t)(c.j >> 3)) *
                       (size_t)v->brick_counts[0] +
                   (size_t)(c.i >> 3);
    size_t b = brick * VOLUX_BRICK_VOXELS + (size_t)((c.i & 7) + VOLUX_BRICK_NODES * (c.j & 7) +
                                                     VOLUX_BRICK_NODES * VOLUX_BRICK_NODES * (c.k & 7));
    enum { SY = VOLUX_BRICK_NODES, SZ = VOLUX_BRICK_NODES * VOLUX_BRICK_NODES };
    float n[8];
#define VOLUX_BRICK_FETCH_(T)                                                                                     \
    do {                                                                                                          \
        const T *p = (const T *)v->bricks + b;                                                                    \
        n[0] = p[0], n[1] = p[1], n[2] = p[SY], n[3] = p[SY + 1];                                                 \
        n[4] = p[SZ], n[5] = p[SZ + 1], n[6] = p[SZ + SY], n[7] = p[SZ + SY + 1];                                 \
    } while (0)
    if (storage == VOLUX_STORE_U8) VOLUX_BRICK_FETCH_(uint8_t);
    else if (storage == VOLUX_STORE_U16) VOLUX_BRICK_FETCH_(uint16_t);
    else VOLUX_BRICK_FETCH_(float);
#undef VOLUX_BRICK_FETCH_
    return volux_lerp3(n, c.fx, c.fy, c.fz) + v->value_offset;
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

/* Central-difference gradient at node (i,j,k) (one-sided at the border), in
 * file units per world unit. */
static inline void volux_volume_node_gradient(const volux_volume *v, int i, int j, int k, float g[3]) {
    int c[3] = {i, j, k};
    for (int a = 0; a < 3; a++) {
        int lo[3] = {i, j, k}, hi[3] = {i, j, k};
        if (c[a] > 0) lo[a]--;
        if (c[a] < v->dims[a] - 1) hi[a]++;
        int h = hi[a] - lo[a];
        g[a] = h ? ((volux_volume_raw_at(v, volux_volume_index(v, hi[0], hi[1], hi[2])) + v->value_offset) -
                    (volux_volume_raw_at(v, volux_volume_index(v, lo[0], lo[1], lo[2])) + v->value_offset)) /
                       ((float)h * (float)v->spacing[a])
                 : 0.0f;
    }
}
/* Largest |component| of volux_volume_node_gradient over the nodes [lo, hi)
 * (the scale of the quantised gradient cache). */
float volux_volume_gradient_max(const volux_volume *v, const int lo[3], const int hi[3]);

/* Gradient at index-space q in file units per *index* unit (central
 * differences of the trilinear field, clamped at the border). */
volux_vec3 volux_volume_gradient_index(const volux_volume *v, volux_vec3 q);

#endif
