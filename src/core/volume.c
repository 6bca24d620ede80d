/* core/volume.c — scalar grid: creation, conversion, sampling, macrocells. */
#include <float.h>
#include <math.h>
#include <string.h>

#include "parallel.h"
#include "vecmath.h"
#include "volume_internal.h"

static uint64_t next_volume_id = 1;

const char *volux_scalar_type_name(volux_scalar_type t) {
    switch (t) {
    case VOLUX_UINT8: return "uint8";
    case VOLUX_INT8: return "int8";
    case VOLUX_UINT16: return "uint16";
    case VOLUX_INT16: return "int16";
    case VOLUX_FLOAT32: return "float32";
    case VOLUX_FLOAT64: return "float64";
    case VOLUX_INT32: return "int32";
    case VOLUX_UINT32: return "uint32";
    case VOLUX_INT64: return "int64";
    case VOLUX_UINT64: return "uint64";
    }
    return "unknown";
}

size_t volux_scalar_type_size(volux_scalar_type t) {
    switch (t) {
    case VOLUX_UINT8:
    case VOLUX_INT8: return 1;
    case VOLUX_UINT16:
    case VOLUX_INT16: return 2;
    case VOLUX_FLOAT32:
    case VOLUX_INT32:
    case VOLUX_UINT32: return 4;
    case VOLUX_FLOAT64:
    case VOLUX_INT64:
    case VOLUX_UINT64: return 8;
    }
    return 0;
}

int volux_scalar_type_parse(const char *name, volux_scalar_type *out) {
    static const struct {
        const char *name;
        volux_scalar_type type;
    } names[] = {
        {"uint8", VOLUX_UINT8},       {"uchar", VOLUX_UINT8},         {"unsigned char", VOLUX_UINT8},
        {"uint8_t", VOLUX_UINT8},     {"int8", VOLUX_INT8},           {"signed char", VOLUX_INT8},
        {"char", VOLUX_INT8},         {"int8_t", VOLUX_INT8},         {"uint16", VOLUX_UINT16},
        {"ushort", VOLUX_UINT16},     {"unsigned short", VOLUX_UINT16}, {"unsigned short int", VOLUX_UINT16},
        {"uint16_t", VOLUX_UINT16},   {"int16", VOLUX_INT16},         {"short", VOLUX_INT16},
        {"signed short", VOLUX_INT16}, {"short int", VOLUX_INT16},    {"signed short int", VOLUX_INT16},
        {"int16_t", VOLUX_INT16},     {"float", VOLUX_FLOAT32},       {"float32", VOLUX_FLOAT32},
        {"double", VOLUX_FLOAT64},    {"float64", VOLUX_FLOAT64},
        /* Teem's (NRRD) names of the wide integers */
        {"int", VOLUX_INT32},         {"signed int", VOLUX_INT32},    {"int32", VOLUX_INT32},
        {"int32_t", VOLUX_INT32},     {"uint", VOLUX_UINT32},         {"unsigned int", VOLUX_UINT32},
        {"uint32", VOLUX_UINT32},     {"uint32_t", VOLUX_UINT32},     {"longlong", VOLUX_INT64},
        {"long long", VOLUX_INT64},   {"long long int", VOLUX_INT64}, {"signed long long", VOLUX_INT64},
        {"signed long long int", VOLUX_INT64}, {"int64", VOLUX_INT64}, {"int64_t", VOLUX_INT64},
        {"ulonglong", VOLUX_UINT64},  {"unsigned long long", VOLUX_UINT64},
        {"unsigned long long int", VOLUX_UINT64}, {"uint64", VOLUX_UINT64}, {"uint64_t", VOLUX_UINT64},
    };
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++)
        if (strcmp(name, names[i].name) == 0) {
            *out = names[i].type;
            return 0;
        }
    return -1;
}

static volux_storage storage_for(volux_scalar_type t) {
    switch (t) {
    case VOLUX_UINT8:
    case VOLUX_INT8: return VOLUX_STORE_U8;
    case VOLUX_UINT16:
    case VOLUX_INT16: return VOLUX_STORE_U16;
    default: return VOLUX_STORE_F32;
    }
}

static size_t storage_size(volux_storage s) { return s == VOLUX_STORE_U8 ? 1 : s == VOLUX_STORE_U16 ? 2 : 4; }

size_t volux_volume_storage_bytes(const int dims[3], volux_scalar_type type) {
    size_t n = 1;
    for (int a = 0; a < 3; a++) {
        if (dims[a] < 1) return 0;
        if (!volux_mul_size(n, (size_t)dims[a], &n)) return 0;
    }
    if (!volux_mul_size(n, storage_size(storage_for(type)), &n)) return 0;
    return n;
}

/* A volume header with owned storage, or (borrow) none yet: the caller sets
 * v->data. A borrowed grid is not allocated, so the memory cap does not
 * apply to it. */
static volux_status volume_new(volux_context *ctx, const int dims[3], const double spacing[3],
                               volux_scalar_type type, int borrow, volux_volume **out) {
    uint64_t voxels = 1;
    for (int a = 0; a < 3; a++) {
        if (dims[a] < 1 || dims[a] > VOLUX_MAX_DIM)
            return volux_error(ctx, VOLUX_ERR_LIMIT, "dims[%d] = %d is outside [1, %d]", a, dims[a], VOLUX_MAX_DIM);
        double s = spacing ? spacing[a] : 1.0;
        if (!(s > 0.0) || !isfinite(s) || s > 1e12 || s < 1e-12)
            return volux_error(ctx, VOLUX_ERR_INVALID, "spacing[%d] = %g must be a positive finite number", a, s);
        voxels *= (uint64_t)dims[a];
    }
    if (voxels > VOLUX_MAX_VOXELS)
        return volux_error(ctx, VOLUX_ERR_LIMIT, "%llu voxels exceed the limit of %llu",
                           (unsigned long long)voxels, (unsigned long long)VOLUX_MAX_VOXELS);
    size_t bytes = volux_volume_storage_bytes(dims, type);
    if (bytes == 0 || (!borrow && (uint64_t)bytes > ctx->max_bytes))
        return volux_error(ctx, VOLUX_ERR_LIMIT,
                           "volume of %dx%dx%d %s needs %llu bytes, over the memory cap of %llu bytes", dims[0],
                           dims[1], dims[2], volux_scalar_type_name(type), (unsigned long long)bytes,
                           (unsigned long long)ctx->max_bytes);
    volux_volume *v = volux_calloc(ctx, 1, sizeof *v);
    if (!v) return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for a volume");
    v->data = borrow ? NULL : volux_alloc_aligned(ctx, bytes);
    if (!borrow && !v->data) {
        volux_free(ctx, v, sizeof *v);
        return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory (%zu bytes) for volume data", bytes);
    }
    v->borrowed = borrow;
    v->ctx = ctx;
    v->refcount = 1;
    v->id = __atomic_fetch_add(&next_volume_id, 1, __ATOMIC_RELAXED);
    v->data_bytes = bytes;
    v->type = type;
    v->storage = storage_for(type);
    v->value_offset = type == VOLUX_INT8 ? -128.0f : type == VOLUX_INT16 ? -32768.0f : 0.0f;
    for (int a = 0; a < 3; a++) {
        v->dims[a] = dims[a];
        v->spacing[a] = spacing ? spacing[a] : 1.0;
        v->inv_spacing[a] = (float)(1.0 / v->spacing[a]);
    }
    *out = v;
    return VOLUX_OK;
}

volux_status volux_volume_create_storage(volux_context *ctx, const int dims[3], const double spacing[3],
                                         volux_scalar_type type, volux_volume **out) {
    return volume_new(ctx, dims, spacing, type, 0, out);
}

volux_status volux_volume_create_borrowed(volux_context *ctx, const int dims[3], const double spacing[3],
                                          volux_scalar_type type, volux_volume **out) {
    return volume_new(ctx, dims, spacing, type, 1, out);
}

/* One z slab of macrocells: the nodes k ∈ [8·cz, 8·cz + 8] (a cell's
 * closed range). Slabs write disjoint cells, so they run in parallel; a
 * min/max is exact, so the cells are the same for any thread count. */
static void macrocell_slab(void *user, int64_t cz64, int thread) {
    (void)thread;
    volux_volume *v = user;
    const int *nc = v->cells, cz = (int)cz64;
    int k0 = cz << VOLUX_CELL_SHIFT, k1 = k0 + VOLUX_CELL_SIZE;
    if (k1 > v->dims[2] - 1) k1 = v->dims[2] - 1;
    for (int k = k0; k <= k1; k++)
        for (int j = 0; j < v->dims[1]; j++) {
            int cy0 = (j - 1) >> VOLUX_CELL_SHIFT, cy1 = j >> VOLUX_CELL_SHIFT;
            size_t row = volux_volume_index(v, 0, j, k);
            for (int i = 0; i < v->dims[0]; i++) {
                float s = volux_volume_raw_at(v, row + (size_t)i) + v->value_offset;
                int cx0 = (i - 1) >> VOLUX_CELL_SHIFT, cx1 = i >> VOLUX_CELL_SHIFT;
                for (int cy = cy0 < 0 ? 0 : cy0; cy <= cy1 && cy < nc[1]; cy++)
                    for (int cx = cx0 < 0 ? 0 : cx0; cx <= cx1 && cx < nc[0]; cx++) {
                        size_t c = ((size_t)cz * (size_t)nc[1] + (size_t)cy) * (size_t)nc[0] + (size_t)cx;
                        if (s < v->cell_min[c]) v->cell_min[c] = s;
                        if (s > v->cell_max[c]) v->cell_max[c] = s;
                    }
            }
        }
    /* out of core: this slab's slices are done (a neighbour that still
     * needs the shared one reads it again) */
    size_t slice = (size_t)v->dims[0] * (size_t)v->dims[1] * volux_volume_elem_size(v);
    volux_volume_trim(v, (size_t)k0 * slice, (size_t)(k1 + 1 - k0) * slice);
}

static void build_macrocells(volux_volume *v) {
    int nc[3];
    for (int a = 0; a < 3; a++) {
        nc[a] = (v->dims[a] - 1 + VOLUX_CELL_SIZE - 1) / VOLUX_CELL_SIZE;
        if (nc[a] < 1) nc[a] = 1;
        v->cells[a] = nc[a];
    }
    size_t n = (size_t)nc[0] * (size_t)nc[1] * (size_t)nc[2];
    for (size_t c = 0; c < n; c++) {
        v->cell_min[c] = FLT_MAX;
        v->cell_max[c] = -FLT_MAX;
    }
    /* Each node belongs to every cell whose closed range contains it. */
    volux_parallel_for(volux_context_threads(v->ctx), nc[2], macrocell_slab, v);
}

/* The bricked layout's shape, fixed at creation so that concurrent
 * builders agree on it without writing it (see volux_volume_build_bricks). */
static void brick_shape(volux_volume *v) {
    size_t count = 1;
    for (int a = 0; a < 3; a++) {
        int nb = (v->dims[a] - 1 + VOLUX_BRICK_CELLS - 1) / VOLUX_BRICK_CELLS;
        v->brick_counts[a] = nb < 1 ? 1 : nb;
        count *= (size_t)v->brick_counts[a];
    }
    size_t elem = volux_volume_elem_size(v), bytes;
    /* SIMD gathers read whole 32-bit words, i.e. up to 3 bytes past the last
     * node they need: a zeroed tail keeps them inside the allocation. */
    v->brick_bytes = volux_mul_size(count, (size_t)VOLUX_BRICK_VOXELS * elem, &bytes) &&
                             volux_add_size(bytes, VOLUX_BRICK_TAIL, &bytes)
                         ? bytes
                         : SIZE_MAX;
}

volux_status volux_volume_finalize(volux_volume *v, const double *origin) {
    volux_context *ctx = v->ctx;
    for (int a = 0; a < 3; a++) {
        double o = origin ? origin[a] : -(double)(v->dims[a] - 1) * v->spacing[a] / 2.0;
        if (!isfinite(o)) return volux_error(ctx, VOLUX_ERR_INVALID, "origin[%d] is not finite", a);
        (&v->origin.x)[a] = (float)o;
    }
    size_t n = (size_t)v->dims[0] * (size_t)v->dims[1] * (size_t)v->dims[2];
    double lo = DBL_MAX, hi = -DBL_MAX;
    /* in blocks, so that an out-of-core volume drops each one behind it */
    const size_t block = (size_t)1 << 22, esize = volux_volume_elem_size(v);
    if (v->storage == VOLUX_STORE_F32) {
        float *f = v->data;
        size_t bad = 0;
        for (size_t b = 0; b < n; b += block) {
            size_t e = n - b < block ? n : b + block;
            for (size_t i = b; i < e; i++) {
                if (!isfinite(f[i])) {
                    bad++;
                    continue;
                }
                if (f[i] < lo) lo = f[i];
                if (f[i] > hi) hi = f[i];
            }
            volux_volume_trim(v, b * esize, (e - b) * esize);
            if (volux_progress(ctx, "scan volume", (double)e / (double)n))
                return volux_error(ctx, VOLUX_ERR_CANCELLED, "scanning the volume: cancelled");
        }
        if (lo > hi) lo = hi = 0.0; /* nothing finite */
        if (bad && v->mapped) /* the loader refuses these first; a guard for any other caller */
            return volux_error(ctx, VOLUX_ERR_UNSUPPORTED,
                               "%zu non-finite values (NaN/Inf) in an out-of-core volume cannot be replaced (its "
                               "data is a read-only mapping of the file); load it without out-of-core",
                               bad);
        /* NaN/inf would poison every sum downstream; they take the lowest
         * value, where the TF's table starts. */
        for (size_t i = 0; bad && i < n; i++)
            if (!isfinite(f[i])) f[i] = (float)lo;
        /* Every table lookup computes (s − s_min)·(n−1)/(s_max − s_min) in
         * float: a wider span overflows to inf·0 = NaN there. */
        if (hi - lo > FLT_MAX)
            return volux_error(ctx, VOLUX_ERR_LIMIT,
                               "values span [%g, %g], wider than float arithmetic holds (%g); rescale the data", lo,
                               hi, (double)FLT_MAX);
    } else {
        for (size_t b = 0; b < n; b += block) {
            size_t e = n - b < block ? n : b + block;
            for (size_t i = b; i < e; i++) {
                double s = volux_volume_raw_at(v, i);
                if (s < lo) lo = s;
                if (s > hi) hi = s;
            }
            volux_volume_trim(v, b * esize, (e - b) * esize);
            /* the value range of a large volume is a pass of its own: the
             * loader's progress ends with the read */
            if (volux_progress(ctx, "scan volume", (double)e / (double)n))
                return volux_error(ctx, VOLUX_ERR_CANCELLED, "scanning the volume: cancelled");
        }
        lo += v->value_offset;
        hi += v->value_offset;
    }
    v->vmin = lo;
    v->vmax = hi;
    size_t cells = 1;
    for (int a = 0; a < 3; a++) {
        int c = (v->dims[a] - 1 + VOLUX_CELL_SIZE - 1) / VOLUX_CELL_SIZE;
        cells *= (size_t)(c < 1 ? 1 : c);
    }
    v->cell_bytes = cells * sizeof(float);
    v->cell_min = volux_malloc(ctx, v->cell_bytes);
    v->cell_max = volux_malloc(ctx, v->cell_bytes);
    if (!v->cell_min || !v->cell_max) return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for macrocells");
    build_macrocells(v);
    brick_shape(v);
    return VOLUX_OK;
}

/* One float64 or wide-integer element at p (native order) as the float32
 * it is stored as. */
static float converted_element(const unsigned char *p, volux_scalar_type t) {
    switch (t) {
    case VOLUX_INT32: {
        int32_t x;
        memcpy(&x, p, 4);
        return (float)x;
    }
    case VOLUX_UINT32: {
        uint32_t x;
        memcpy(&x, p, 4);
        return (float)x;
    }
    case VOLUX_INT64: {
        int64_t x;
        memcpy(&x, p, 8);
        return (float)x;
    }
    case VOLUX_UINT64: {
        uint64_t x;
        memcpy(&x, p, 8);
        return (float)x;
    }
    default: {
        double x;
        memcpy(&x, p, 8);
        return (float)x;
    }
    }
}

static void convert_into(volux_volume *v, const void *src) {
    size_t n = (size_t)v->dims[0] * (size_t)v->dims[1] * (size_t)v->dims[2];
    switch (v->type) {
    case VOLUX_UINT8: memcpy(v->data, src, n); break;
    case VOLUX_UINT16: memcpy(v->data, src, n * 2); break;
    case VOLUX_FLOAT32: memcpy(v->data, src, n * 4); break;
    case VOLUX_INT8: {
        const int8_t *s = src;
        uint8_t *d = v->data;
        for (size_t i = 0; i < n; i++) d[i] = (uint8_t)(s[i] + 128);
        break;
    }
    case VOLUX_INT16: {
        const int16_t *s = src;
        uint16_t *d = v->data;
        for (size_t i = 0; i < n; i++) d[i] = (uint16_t)(s[i] + 32768);
        break;
    }
    case VOLUX_FLOAT64:
    case VOLUX_INT32:
    case VOLUX_UINT32:
    case VOLUX_INT64:
    case VOLUX_UINT64: {
        const unsigned char *s = src;
        size_t size = volux_scalar_type_size(v->type);
        float *d = v->data;
        for (size_t i = 0; i < n; i++) d[i] = converted_element(s + i * size, v->type);
        break;
    }
    }
}

size_t volux_volume_count_nonfinite(const volux_volume *v, size_t *first) {
    if (v->storage != VOLUX_STORE_F32) return 0;
    size_t n = (size_t)v->dims[0] * (size_t)v->dims[1] * (size_t)v->dims[2], bad = 0;
    const float *f = v->data;
    const size_t block = (size_t)1 << 22; /* out of core: each block dropped behind the scan */
    for (size_t b = 0; b < n; b += block) {
        size_t e = n - b < block ? n : b + block;
        for (size_t i = b; i < e; i++)
            if (!isfinite(f[i]) && !bad++ && first) *first = i;
        volux_volume_trim(v, b * sizeof *f, (e - b) * sizeof *f);
    }
    return bad;
}

volux_status volux_volume_create(volux_context *ctx, const volux_volume_desc *desc, volux_volume **out) {
    double spacing[3];
    for (int a = 0; a < 3; a++) spacing[a] = desc->spacing[a] == 0.0 ? 1.0 : desc->spacing[a];
    if ((unsigned)desc->type > VOLUX_SCALAR_TYPE_LAST)
        return volux_error(ctx, VOLUX_ERR_INVALID, "unknown scalar type %d", (int)desc->type);
    volux_volume *v;
    volux_status st = volux_volume_create_storage(ctx, desc->dims, spacing, desc->type, &v);
    if (st) return st;
    if (desc->data) convert_into(v, desc->data);
    else if (desc->type == VOLUX_INT8 || desc->type == VOLUX_INT16) {
        /* zero in file units is the offset value in storage */
        size_t n = (size_t)v->dims[0] * (size_t)v->dims[1] * (size_t)v->dims[2];
        if (desc->type == VOLUX_INT8) memset(v->data, 128, n);
        else
            for (size_t i = 0; i < n; i++) ((uint16_t *)v->data)[i] = 32768;
    }
    size_t first = 0, bad = volux_volume_count_nonfinite(v, &first);
    if (bad && !desc->allow_nonfinite) {
        int d0 = v->dims[0], d1 = v->dims[1];
        volux_volume_release(v);
        return volux_error(ctx, VOLUX_ERR_INVALID,
                           "volume data: %zu non-finite values (NaN/Inf), the first at index %zu = voxel (%zu, %zu, "
                           "%zu); allow_nonfinite maps them to the lowest value",
                           bad, first, first % (size_t)d0, first / (size_t)d0 % (size_t)d1,
                           first / ((size_t)d0 * (size_t)d1));
    }
    st = volux_volume_finalize(v, desc->use_origin ? desc->origin : NULL);
    if (st) {
        volux_volume_release(v);
        return st;
    }
    *out = v;
    return VOLUX_OK;
}

/* One element of `type` at p, in storage units (what convert_into stores). */
static void store_element(volux_volume *v, size_t idx, const unsigned char *p) {
    switch (v->type) {
    case VOLUX_UINT8: ((uint8_t *)v->data)[idx] = *p; break;
    case VOLUX_INT8: {
        int8_t x;
        memcpy(&x, p, 1);
        ((uint8_t *)v->data)[idx] = (uint8_t)(x + 128);
        break;
    }
    case VOLUX_UINT16: memcpy((uint16_t *)v->data + idx, p, 2); break;
    case VOLUX_INT16: {
        int16_t x;
        memcpy(&x, p, 2);
        ((uint16_t *)v->data)[idx] = (uint16_t)(x + 32768);
        break;
    }
    case VOLUX_FLOAT32: memcpy((float *)v->data + idx, p, 4); break;
    case VOLUX_FLOAT64:
    case VOLUX_INT32:
    case VOLUX_UINT32:
    case VOLUX_INT64:
    case VOLUX_UINT64: ((float *)v->data)[idx] = converted_element(p, v->type); break;
    }
}

volux_status volux_volume_from_memory(volux_context *ctx, const volux_volume_memory_desc *desc,
                                      volux_volume **out) {
    if (!desc->data) return volux_error(ctx, VOLUX_ERR_INVALID, "volume from memory: data is NULL");
    if ((unsigned)desc->type > VOLUX_SCALAR_TYPE_LAST)
        return volux_error(ctx, VOLUX_ERR_INVALID, "volume from memory: unknown scalar type %d", (int)desc->type);
    if (desc->mode != VOLUX_MEMORY_COPY && desc->mode != VOLUX_MEMORY_BORROW)
        return volux_error(ctx, VOLUX_ERR_INVALID, "volume from memory: mode %d is neither COPY nor BORROW",
                           (int)desc->mode);
    for (int a = 0; a < 3; a++)
        if (desc->dims[a] < 1 || desc->dims[a] > VOLUX_MAX_DIM)
            return volux_error(ctx, VOLUX_ERR_LIMIT, "volume from memory: dims[%d] = %d is outside [1, %d]", a,
                               desc->dims[a], VOLUX_MAX_DIM);
    size_t elem = volux_scalar_type_size(desc->type);
    int64_t packed[3] = {(int64_t)elem, (int64_t)elem * desc->dims[0],
                         (int64_t)elem * desc->dims[0] * desc->dims[1]};
    int64_t strides[3];
    int all_zero = desc->strides[0] == 0 && desc->strides[1] == 0 && desc->strides[2] == 0;
    for (int a = 0; a < 3; a++) {
        strides[a] = all_zero ? packed[a] : desc->strides[a];
        /* A zero stride on an axis of more than one node would repeat one
         * plane: allowed only where the axis has a single node. */
        if (strides[a] == 0 && desc->dims[a] > 1)
            return volux_error(ctx, VOLUX_ERR_INVALID,
                               "volume from memory: strides[%d] is 0 but dims[%d] = %d (all three 0 = packed)", a,
                               a, desc->dims[a]);
        if (strides[a] > (INT64_C(1) << 46) || strides[a] < -(INT64_C(1) << 46))
            return volux_error(ctx, VOLUX_ERR_INVALID, "volume from memory: strides[%d] = %lld is implausible", a,
                               (long long)strides[a]);
    }
    int borrow = desc->mode == VOLUX_MEMORY_BORROW;
    if (borrow) {
        const char *why = NULL;
        if (desc->type != VOLUX_UINT8 && desc->type != VOLUX_UINT16 && desc->type != VOLUX_FLOAT32)
            why = "only uint8, uint16 and float32 are stored as given";
        else
            for (int a = 0; a < 3; a++)
                if (strides[a] != packed[a] && desc->dims[a] > 1) why = "the data is not packed (x fastest)";
        if (!why && ((uintptr_t)desc->data % elem) != 0) why = "the data is not aligned to its element size";
        if (why)
            return volux_error(ctx, VOLUX_ERR_UNSUPPORTED, "volume from memory: cannot borrow %s data: %s; copy it",
                               volux_scalar_type_name(desc->type), why);
    }
    double spacing[3];
    for (int a = 0; a < 3; a++) spacing[a] = desc->spacing[a] == 0.0 ? 1.0 : desc->spacing[a];
    volux_volume *v;
    volux_status st = volume_new(ctx, desc->dims, spacing, desc->type, borrow, &v);
    if (st) return st;
    if (borrow) {
        if (desc->type == VOLUX_FLOAT32) {
            /* finalize() would overwrite NaN/inf: not in a buffer we borrow. */
            const float *f = desc->data;
            size_t n = (size_t)desc->dims[0] * (size_t)desc->dims[1] * (size_t)desc->dims[2];
            for (size_t i = 0; i < n; i++)
                if (!isfinite(f[i])) {
                    size_t nx = (size_t)desc->dims[0], nxy = nx * (size_t)desc->dims[1];
                    volux_free(ctx, v, sizeof *v);
                    return volux_error(ctx, VOLUX_ERR_UNSUPPORTED,
                                       "volume from memory: cannot borrow float32 data with a non-finite value "
                                       "at (%zu, %zu, %zu); copy it (non-finite values become the lowest value)",
                                       i % nx, i / nx % (size_t)desc->dims[1], i / nxy);
                }
        }
        v->data = (void *)desc->data; /* never written: volumes are immutable */
    } else if (all_zero || (strides[0] == packed[0] && strides[1] == packed[1] && strides[2] == packed[2])) {
        convert_into(v, desc->data);
    } else {
        const unsigned char *base = desc->data;
        size_t idx = 0;
        for (int k = 0; k < desc->dims[2]; k++)
            for (int j = 0; j < desc->dims[1]; j++)
                for (int i = 0; i < desc->dims[0]; i++, idx++)
                    store_element(v, idx, base + (int64_t)i * strides[0] + (int64_t)j * strides[1] +
                                              (int64_t)k * strides[2]);
    }
    /* A copy is ours to repair (finalize maps NaN/Inf to the lowest value);
     * the caller hears about it. */
    size_t first = 0, bad = borrow ? 0 : volux_volume_count_nonfinite(v, &first);
    if (bad) {
        size_t nx = (size_t)desc->dims[0], nxy = nx * (size_t)desc->dims[1];
        volux_warn(ctx,
                   "volume from memory: %zu non-finite values (NaN/Inf), the first at (%zu, %zu, %zu), mapped to "
                   "the lowest value",
                   bad, first % nx, first / nx % (size_t)desc->dims[1], first / nxy);
    }
    st = volux_volume_finalize(v, desc->use_origin ? desc->origin : NULL);
    if (st) {
        v->release_data = NULL; /* a failed create keeps nothing and calls nothing */
        volux_volume_release(v);
        return st;
    }
    v->release_data = borrow ? desc->release : NULL;
    v->release_user = desc->release_user;
    *out = v;
    return VOLUX_OK;
}

/* Thread-safe: a volume is immutable and may be shared by scenes that set up
 * techniques in different threads at once, so each builder fills its own
 * copy and publishes it with one compare-and-swap; a loser frees its copy. */
volux_status volux_volume_build_bricks(volux_volume *v) {
    if (__atomic_load_n(&v->bricks, __ATOMIC_ACQUIRE)) return VOLUX_OK;
    const int *nb = v->brick_counts;
    size_t elem = volux_volume_elem_size(v);
    size_t bytes = v->brick_bytes;
    if (bytes == SIZE_MAX || (!v->mapped && bytes - VOLUX_BRICK_TAIL > v->ctx->max_bytes))
        return volux_error(v->ctx, VOLUX_ERR_LIMIT, "bricked volume copy exceeds the memory cap");
    /* out of core: the copy is a file too (pageable), not anonymous memory */
    unsigned char *dst = v->mapped ? volux_map_scratch(v->ctx, bytes) : volux_alloc_aligned(v->ctx, bytes);
    if (!dst)
        return v->mapped ? VOLUX_ERR_IO
                         : volux_error(v->ctx, VOLUX_ERR_NOMEM, "out of memory (%zu bytes) for the bricked volume",
                                       bytes);
    const size_t slice = (size_t)v->dims[0] * (size_t)v->dims[1] * elem,
                 brick_row = (size_t)nb[0] * (size_t)nb[1] * VOLUX_BRICK_VOXELS * elem;
    /* Node (8b + l) of each axis, replicated at the far border. */
    for (int bz = 0; bz < nb[2]; bz++) {
        for (int by = 0; by < nb[1]; by++)
            for (int bx = 0; bx < nb[0]; bx++) {
                size_t base = (((size_t)bz * (size_t)nb[1] + (size_t)by) * (size_t)nb[0] + (size_t)bx) *
                              VOLUX_BRICK_VOXELS;
                for (int lz = 0; lz < VOLUX_BRICK_NODES; lz++) {
                    int k = bz * VOLUX_BRICK_CELLS + lz;
                    if (k > v->dims[2] - 1) k = v->dims[2] - 1;
                    for (int ly = 0; ly < VOLUX_BRICK_NODES; ly++) {
                        int j = by * VOLUX_BRICK_CELLS + ly;
                        if (j > v->dims[1] - 1) j = v->dims[1] - 1;
                        for (int lx = 0; lx < VOLUX_BRICK_NODES; lx++) {
                            int i = bx * VOLUX_BRICK_CELLS + lx;
                            if (i > v->dims[0] - 1) i = v->dims[0] - 1;
                            size_t d = base + (size_t)(lx + VOLUX_BRICK_NODES * (ly + VOLUX_BRICK_NODES * lz));
                            memcpy(dst + d * elem, (const unsigned char *)v->data + volux_volume_index(v, i, j, k) * elem,
                                   elem);
                        }
                    }
                }
            }
        if (v->mapped) { /* this z row of bricks is written: drop it and the slices it read */
            volux_map_trim(dst + (size_t)bz * brick_row, brick_row);
            volux_volume_trim(v, (size_t)bz * VOLUX_BRICK_CELLS * slice, (size_t)VOLUX_BRICK_NODES * slice);
        }
    }
    void *expected = NULL;
    if (!__atomic_compare_exchange_n(&v->bricks, &expected, dst, 0, __ATOMIC_ACQ_REL, __ATOMIC_ACQUIRE)) {
        /* another thread published the same bricks first */
        if (v->mapped) volux_unmap_scratch(dst, bytes);
        else volux_free_aligned(v->ctx, dst, bytes);
    }
    return VOLUX_OK;
}

void volux_volume_retain(volux_volume *v) { __atomic_add_fetch(&v->refcount, 1, __ATOMIC_RELAXED); }

void volux_volume_release(volux_volume *v) {
    if (!v) return;
    if (__atomic_sub_fetch(&v->refcount, 1, __ATOMIC_ACQ_REL) != 0) return;
    volux_context *ctx = v->ctx;
    if (v->mapped) volux_volume_unmap(v);
    else if (!v->borrowed) volux_free_aligned(ctx, v->data, v->data_bytes);
    else if (v->release_data) v->release_data(v->release_user);
    if (v->bricks && v->mapped) volux_unmap_scratch(v->bricks, v->brick_bytes);
    else if (v->bricks) volux_free_aligned(ctx, v->bricks, v->brick_bytes);
    volux_free(ctx, v->cell_min, v->cell_bytes);
    volux_free(ctx, v->cell_max, v->cell_bytes);
    volux_free(ctx, v, sizeof *v);
}

void volux_volume_dims(const volux_volume *v, int dims[3]) { memcpy(dims, v->dims, sizeof v->dims); }
void volux_volume_spacing(const volux_volume *v, double spacing[3]) { memcpy(spacing, v->spacing, sizeof v->spacing); }
volux_vec3 volux_volume_origin(const volux_volume *v) { return v->origin; }
void volux_volume_set_superior(volux_volume *v, const double dir[3]) {
    v->has_superior = 0;
    if (!dir) return;
    double len = sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
    if (!(len > 0.0) || !isfinite(len)) return;
    v->superior = (volux_vec3){(float)(dir[0] / len), (float)(dir[1] / len), (float)(dir[2] / len)};
    v->has_superior = 1;
}

int volux_volume_superior(const volux_volume *v, volux_vec3 *dir) {
    if (!v->has_superior) return 0;
    *dir = v->superior;
    return 1;
}
volux_scalar_type volux_volume_type(const volux_volume *v) { return v->type; }
volux_storage volux_volume_storage_kind(const volux_volume *v) { return v->storage; }
void volux_volume_range(const volux_volume *v, double *min, double *max) {
    *min = v->vmin;
    *max = v->vmax;
}
void volux_volume_bounds(const volux_volume *v, volux_vec3 *lo, volux_vec3 *hi) {
    *lo = v->origin;
    *hi = v3(v->origin.x + (float)((v->dims[0] - 1) * v->spacing[0]),
             v->origin.y + (float)((v->dims[1] - 1) * v->spacing[1]),
             v->origin.z + (float)((v->dims[2] - 1) * v->spacing[2]));
}
size_t volux_volume_memory_bytes(const volux_volume *v) {
    return (v->borrowed ? 0 : v->data_bytes) + (v->bricks ? v->brick_bytes : 0) + 2 * v->cell_bytes + sizeof *v;
}

float volux_volume_value_at(const volux_volume *v, int i, int j, int k) {
    return volux_volume_raw_at(v, volux_volume_index(v, i, j, k)) + v->value_offset;
}

float volux_volume_sample(const volux_volume *v, volux_vec3 p) {
    volux_vec3 q = volux_volume_to_index(v, p);
    if (!volux_volume_inside_index(v, q)) return 0.0f;
    return volux_volume_sample_index(v, q.x, q.y, q.z);
}

volux_vec3 volux_volume_gradient_index(const volux_volume *v, volux_vec3 q) {
    float n[3] = {(float)(v->dims[0] - 1), (float)(v->dims[1] - 1), (float)(v->dims[2] - 1)};
    float p[3] = {q.x, q.y, q.z}, g[3];
    for (int a = 0; a < 3; a++) {
        float lo[3] = {p[0], p[1], p[2]}, hi[3] = {p[0], p[1], p[2]};
        lo[a] = fmaxf(p[a] - 1.0f, 0.0f);
        hi[a] = fminf(p[a] + 1.0f, n[a]);
        float h = hi[a] - lo[a];
        g[a] = h > 0.0f ? (volux_volume_sample_index(v, hi[0], hi[1], hi[2]) -
                           volux_volume_sample_index(v, lo[0], lo[1], lo[2])) / h
                        : 0.0f;
    }
    return v3(g[0], g[1], g[2]);
}

volux_vec3 volux_volume_gradient(const volux_volume *v, volux_vec3 p) {
    volux_vec3 q = volux_volume_to_index(v, p);
    if (!volux_volume_inside_index(v, q)) return v3(0, 0, 0);
    volux_vec3 g = volux_volume_gradient_index(v, q);
    return v3(g.x * v->inv_spacing[0], g.y * v->inv_spacing[1], g.z * v->inv_spacing[2]);
}

void volux_volume_histogram(const volux_volume *v, int bins, uint64_t *counts) {
    memset(counts, 0, sizeof *counts * (size_t)bins);
    double range = v->vmax - v->vmin;
    size_t n = (size_t)v->dims[0] * (size_t)v->dims[1] * (size_t)v->dims[2];
    const size_t block = (size_t)1 << 22, esize = volux_volume_elem_size(v);
    for (size_t first = 0; first < n; first += block) {
        size_t end = n - first < block ? n : first + block;
        for (size_t i = first; i < end; i++) {
            double s = volux_volume_raw_at(v, i) + v->value_offset;
            int b = range > 0 ? (int)((s - v->vmin) / range * bins) : 0;
            if (b >= bins) b = bins - 1;
            if (b < 0) b = 0;
            counts[b]++;
        }
        volux_volume_trim(v, first * esize, (end - first) * esize); /* out of core: behind the sweep */
    }
}
