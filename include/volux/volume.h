/*
 * volux/volume.h — an immutable, refcounted scalar grid.
 *
 * A volume of dims (nx,ny,nz) and spacing (sx,sy,sz) is node-centred:
 * sample (i,j,k) lies at origin + (i·sx, j·sy, k·sz) (DESIGN §2). Values are
 * kept in file units: int8/int16 are stored as uint8/uint16 with a value
 * offset; float64 and the 32/64-bit integers are converted to float32
 * (exact for integers up to 2^24 in magnitude, rounded to float32's 24-bit
 * precision beyond: label ids above 16 777 216 may merge). Outside the box the value is 0
 * and the medium is empty. Trilinear interpolation; gradients by central
 * differences of the interpolated field.
 *
 * DOES NOT: read files (see io.h), know transfer functions.
 *
 * STEP BY STEP
 *     volux_volume_desc d = {.dims = {64,64,64}, .spacing = {1,1,1},
 *                            .type = VOLUX_UINT8, .data = bytes};
 *     volux_volume *v;
 *     volux_volume_create(ctx, &d, &v);        // copies bytes
 *     // or without a copy, from a caller's (numpy, simulation) buffer:
 *     // volux_volume_from_memory(ctx, &(volux_volume_memory_desc){
 *     //     .dims = {64,64,64}, .type = VOLUX_FLOAT32, .data = field,
 *     //     .mode = VOLUX_MEMORY_BORROW}, &v);
 *     float s = volux_volume_sample(v, (volux_vec3){0,0,0});
 *     volux_volume_release(v);
 */
#ifndef VOLUX_VOLUME_H
#define VOLUX_VOLUME_H

#include "base.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Scalar types of input data. */
typedef enum volux_scalar_type {
    VOLUX_UINT8,
    VOLUX_INT8,
    VOLUX_UINT16,
    VOLUX_INT16,
    VOLUX_FLOAT32,
    VOLUX_FLOAT64,
    /* wide integers, stored as float32 (see above) */
    VOLUX_INT32,
    VOLUX_UINT32,
    VOLUX_INT64,
    VOLUX_UINT64
} volux_scalar_type;
/* The last scalar type (types are 0 … VOLUX_SCALAR_TYPE_LAST). */
#define VOLUX_SCALAR_TYPE_LAST VOLUX_UINT64

/* Storage kinds: what the grid keeps in memory. */
typedef enum volux_storage { VOLUX_STORE_U8, VOLUX_STORE_U16, VOLUX_STORE_F32 } volux_storage;

VOLUX_API const char *volux_scalar_type_name(volux_scalar_type t);
VOLUX_API size_t volux_scalar_type_size(volux_scalar_type t);
/* Parses "uint8", "uchar", "int16", "short", "float", "float32", "double"...;
 * returns 0 on success, -1 if unknown. */
VOLUX_API int volux_scalar_type_parse(const char *name, volux_scalar_type *out);

/* Largest accepted dimension per axis and total voxel count. */
#define VOLUX_MAX_DIM 16384
#define VOLUX_MAX_VOXELS (1ull << 34)

typedef struct volux_volume_desc {
    int dims[3];            /* nodes per axis, each in [1, VOLUX_MAX_DIM]   */
    double spacing[3];      /* world units between nodes, > 0 (0 = 1.0)     */
    double origin[3];       /* world position of node (0,0,0)...            */
    int use_origin;         /* ...used only if nonzero; else centred        */
    volux_scalar_type type; /* type of data                                 */
    const void *data;       /* borrowed; native byte order, x fastest;
                               NULL = all zeros                             */
    int allow_nonfinite;    /* 0: NaN/Inf in float data is VOLUX_ERR_INVALID;
                               1: they become the lowest finite value       */
} volux_volume_desc;

typedef struct volux_volume volux_volume;

/* Creates a volume, copying and converting desc->data. Fails with
 * VOLUX_ERR_INVALID (bad dims/spacing, NaN/Inf values unless allowed; the
 * message gives their count and the first voxel) or VOLUX_ERR_LIMIT (over
 * the context's max_bytes, or values spanning more than FLT_MAX). The new volume has one reference. */
VOLUX_API volux_status volux_volume_create(volux_context *ctx, const volux_volume_desc *desc,
                                           volux_volume **out);

/* How volux_volume_from_memory treats the caller's buffer. */
typedef enum volux_memory_mode {
    VOLUX_MEMORY_COPY = 0,  /* copy (and convert) now; the buffer may go      */
    VOLUX_MEMORY_BORROW = 1 /* read the buffer in place for the volume's life */
} volux_memory_mode;

/* A volume in the caller's memory, e.g. a numpy array or a simulation's
 * field. Element (i,j,k) is at (const char *)data + i·strides[0] +
 * j·strides[1] + k·strides[2] (bytes; may be negative, as for a flipped
 * numpy view); strides all 0 = packed, x fastest (C order of a [z][y][x]
 * array). Native byte order. */
typedef struct volux_volume_memory_desc {
    int dims[3];              /* nodes per axis, each in [1, VOLUX_MAX_DIM]  */
    volux_scalar_type type;
    double spacing[3];        /* world units between nodes, > 0 (0 = 1.0)   */
    double origin[3];         /* world position of node (0,0,0)...          */
    int use_origin;           /* ...used only if nonzero; else centred      */
    const void *data;         /* required                                   */
    int64_t strides[3];       /* bytes; all 0 = packed                      */
    volux_memory_mode mode;
    /* BORROW only: called once when the volume stops reading `data` (its
     * last reference is released), so the owner may free or reuse it. May
     * be NULL. Not called when the create call fails. */
    void (*release)(void *user);
    void *release_user;
} volux_volume_memory_desc;

/* Creates a volume from the caller's buffer.
 * COPY: any type and strides; the data is copied and converted as by
 *   volux_volume_create, except that NaN/inf become the lowest value
 *   with a warning (volux_volume_create refuses them unless
 *   allow_nonfinite). Counts against max_bytes.
 * BORROW: no copy of the grid. The buffer must stay valid and unchanged
 *   until `release` is called (volumes are immutable: writing into it
 *   afterwards gives undefined images, never a crash). Only the storage
 *   types are accepted as is — uint8, uint16, float32 — packed (strides 0
 *   or exactly packed), aligned to the element size, and float32 values
 *   must be finite; anything else is VOLUX_ERR_UNSUPPORTED naming the
 *   reason (copy instead). Techniques may still build derived copies (the
 *   bricked grid) through the context's allocator.
 * Errors: VOLUX_ERR_INVALID (NULL data, bad mode/type/spacing/strides),
 * VOLUX_ERR_LIMIT (dims), VOLUX_ERR_UNSUPPORTED, VOLUX_ERR_NOMEM. On error
 * nothing is kept and `release` is not called. Thread-safe for distinct
 * contexts; the new volume has one reference. */
VOLUX_API volux_status volux_volume_from_memory(volux_context *ctx, const volux_volume_memory_desc *desc,
                                                volux_volume **out);

VOLUX_API void volux_volume_retain(volux_volume *v);
/* Drops one reference; the last one frees. NULL is ignored. */
VOLUX_API void volux_volume_release(volux_volume *v);

VOLUX_API void volux_volume_dims(const volux_volume *v, int dims[3]);
VOLUX_API void volux_volume_spacing(const volux_volume *v, double spacing[3]);
VOLUX_API volux_vec3 volux_volume_origin(const volux_volume *v);
VOLUX_API volux_scalar_type volux_volume_type(const volux_volume *v);
VOLUX_API volux_storage volux_volume_storage_kind(const volux_volume *v);
/* The direction of anatomical superior (the patient's head) in world
 * coordinates, as the file's orientation gives it (NIfTI qform/sform,
 * NRRD "space" + "space directions"; the grid's axes are the world's, so
 * this is where "up" is for medical data). Returns 0 and leaves *dir
 * alone when the file has no anatomical orientation. */
VOLUX_API int volux_volume_superior(const volux_volume *v, volux_vec3 *dir);
/* Smallest and largest value (file units). */
VOLUX_API void volux_volume_range(const volux_volume *v, double *min, double *max);
/* World-space bounding box corners. */
VOLUX_API void volux_volume_bounds(const volux_volume *v, volux_vec3 *lo, volux_vec3 *hi);
VOLUX_API size_t volux_volume_memory_bytes(const volux_volume *v);
/* Node value in file units; (i,j,k) must be inside. */
VOLUX_API float volux_volume_value_at(const volux_volume *v, int i, int j, int k);
/* Trilinear value at a world position; 0 outside the box. */
VOLUX_API float volux_volume_sample(const volux_volume *v, volux_vec3 p_world);
/* Gradient (file units per world unit) by central differences of the
 * trilinear field, offset one voxel along each axis. */
VOLUX_API volux_vec3 volux_volume_gradient(const volux_volume *v, volux_vec3 p_world);
/* Counts values into `bins` equal bins over [min,max]. */
VOLUX_API void volux_volume_histogram(const volux_volume *v, int bins, uint64_t *counts);

/* ---- Bricks (data-parallel rendering, docs/DISTRIBUTED.md) ------------
 *
 * A whole grid of dims (nx,ny,nz) nodes is split into `count` bricks by a
 * k-d tree over its cells: the box of cells is halved (in proportion to
 * the bricks on each side) across its longest axis, recursively; bricks
 * [0, count/2) lie on the low side of the first split. Brick b owns the
 * cells between nodes owned_lo and owned_hi (inclusive; neighbours share
 * the face nodes), so the owned boxes tile the whole box exactly once.
 * A brick volume (io.h: volux_volume_load_options.region) holds the owned
 * nodes plus `ghost` layers on every side inside the grid, enough for the
 * trilinear samples, the pre-integration front sample and the
 * central-difference gradients a ray inside the owned box takes. */
typedef struct volux_brick_info {
    int count, index;     /* bricks of the whole grid; this one            */
    int whole_dims[3];    /* nodes of the whole grid                        */
    int owned_lo[3];      /* whole-grid node indices of the owned box ...   */
    int owned_hi[3];      /* ... (inclusive)                                */
    int stored_lo[3];     /* whole-grid index of this volume's node (0,0,0) */
    volux_vec3 whole_lo, whole_hi; /* world box of the whole grid           */
} volux_brick_info;

/* The owned nodes [lo, hi] (inclusive) of brick `index` of `count` for a
 * whole grid of `dims` nodes. VOLUX_ERR_INVALID when count < 1, index is
 * out of range, or the grid has too few cells to give every brick one
 * (a brick is at least one cell thick on every axis). Pure function. */
VOLUX_API volux_status volux_brick_split(const int dims[3], int count, int index, int lo[3], int hi[3]);
/* Fills *out and returns 1 when v is a brick of a larger grid; returns 0
 * (and leaves *out alone) for an ordinary volume. */
VOLUX_API int volux_volume_brick(const volux_volume *v, volux_brick_info *out);
/* What depends on the whole grid rather than on a brick: the value range
 * (the transfer function's table, the gradient threshold) and the largest
 * gradient component (the scale of the quantised gradient cache). */
typedef struct volux_volume_stats {
    double value_min, value_max;
    double gradient_max; /* largest |component| of the node gradients
                            (central differences, one-sided at the grid's
                            border), file units per world unit */
} volux_volume_stats;
/* This volume's statistics: its value range, and the largest gradient
 * component over the nodes it owns (a brick: its owned box, whose central
 * differences its ghost layers supply; else every node). Combined over the
 * bricks (min of value_min, max of the others) they are exactly the whole
 * grid's. After volux_volume_set_whole_stats: the whole's. */
VOLUX_API void volux_volume_stats_of(const volux_volume *v, volux_volume_stats *out);
/* Declares the whole grid's statistics for a brick (every rank agrees on
 * them, e.g. with an MPI reduction of volux_volume_stats_of), so that a
 * brick classifies and shades as the whole volume would. The only change a
 * volume accepts after creation: call it before the volume is used by a
 * technique, and give the volume to its scene again
 * (volux_scene_set_volume) so the transfer function's table is baked over
 * the new range. VOLUX_ERR_INVALID when the range does not contain the
 * volume's own or a value is not finite (gradient_max ≥ 0). */
VOLUX_API volux_status volux_volume_set_whole_stats(volux_volume *v, const volux_volume_stats *whole);

#ifdef __cplusplus
}
#endif
#endif
