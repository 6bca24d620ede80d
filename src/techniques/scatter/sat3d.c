/* techniques/scatter/sat3d.c — see sat3d.h. */
#include <math.h>
#include <string.h>

#include "core/parallel.h"
#include "sample/march.h"
#include "sat3d.h"

typedef struct sat_job {
    const volux_volume *v;
    const volux_transfer_lut *lut;
    const uint64_t *qtab; /* per stored value (u8/u16), else NULL */
    double scale;
    scatter_sat *sat;
    size_t chunk;
} sat_job;

static inline uint64_t quantise(const sat_job *j, size_t idx) {
    const volux_volume *v = j->v;
    if (j->qtab) {
        if (v->storage == VOLUX_STORE_U8) return j->qtab[((const uint8_t *)v->data)[idx]];
        return j->qtab[((const uint16_t *)v->data)[idx]];
    }
    float s = ((const float *)v->data)[idx] + v->value_offset;
    return (uint64_t)llrint((double)volux_lut_sigma(j->lut, s) * j->scale);
}

/* Pass 1: 2-D prefix sums of one z-slice. */
#define SLICE_PASS(NAME, T)                                                                                      \
    static void NAME(void *user, int64_t z, int thread) {                                                       \
        (void)thread;                                                                                            \
        sat_job *j = user;                                                                                       \
        int nx = j->sat->dims[0], ny = j->sat->dims[1];                                                          \
        T *S = (T *)j->sat->data + (size_t)z * (size_t)nx * (size_t)ny;                                          \
        size_t base = (size_t)z * (size_t)nx * (size_t)ny;                                                       \
        for (int y = 0; y < ny; y++) {                                                                           \
            T acc = 0, *row = S + (size_t)y * (size_t)nx;                                                        \
            const T *up = y ? row - nx : NULL;                                                                   \
            for (int x = 0; x < nx; x++) {                                                                       \
                acc += (T)quantise(j, base + (size_t)y * (size_t)nx + (size_t)x);                               \
                row[x] = up ? (T)(acc + up[x]) : acc;                                                            \
            }                                                                                                    \
        }                                                                                                        \
    }
SLICE_PASS(slice_pass32, uint32_t)
SLICE_PASS(slice_pass64, uint64_t)

/* Pass 2: running sum over z, for one chunk of the xy plane. */
#define Z_PASS(NAME, T)                                                                                          \
    static void NAME(void *user, int64_t c, int thread) {                                                       \
        (void)thread;                                                                                            \
        sat_job *j = user;                                                                                       \
        size_t plane = (size_t)j->sat->dims[0] * (size_t)j->sat->dims[1];                                        \
        size_t i0 = (size_t)c * j->chunk, i1 = i0 + j->chunk < plane ? i0 + j->chunk : plane;                    \
        T *S = (T *)j->sat->data;                                                                                \
        for (int z = 1; z < j->sat->dims[2]; z++) {                                                              \
            T *cur = S + (size_t)z * plane, *prev = cur - plane;                                                 \
            for (size_t i = i0; i < i1; i++) cur[i] += prev[i];                                                  \
        }                                                                                                        \
    }
Z_PASS(z_pass32, uint32_t)
Z_PASS(z_pass64, uint64_t)

void scatter_sat_free(volux_context *ctx, scatter_sat *sat) {
    if (sat->data) volux_free_aligned(ctx, sat->data, sat->bytes);
    memset(sat, 0, sizeof *sat);
}

volux_status scatter_sat_build(volux_context *ctx, int threads, const volux_volume *v, const volux_transfer_lut *lut,
                               uint64_t max_box, scatter_sat *sat) {
    size_t n = (size_t)v->dims[0] * (size_t)v->dims[1] * (size_t)v->dims[2];
    if (max_box < 1) max_box = 1;
    int bits_box = 0;
    while (bits_box < 63 && (1ull << bits_box) < max_box) bits_box++;
    int wide = 32 - bits_box < 16;
    size_t bytes;
    if (!volux_mul_size(n, wide ? 8 : 4, &bytes) || bytes > volux_context_max_bytes(ctx))
        return volux_error(ctx, VOLUX_ERR_LIMIT, "summed-area table of %zu voxels exceeds the memory cap", n);
    if (!sat->data || sat->bytes != bytes) {
        scatter_sat_free(ctx, sat);
        sat->data = volux_alloc_aligned(ctx, bytes);
        if (!sat->data) return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory (%zu bytes) for a summed-area table", bytes);
        sat->bytes = bytes;
    }
    memcpy(sat->dims, v->dims, sizeof sat->dims);
    sat->wide = wide;
    sat->max_box = max_box;
    double smax = lut->sigma_t_max;
    /* Per-voxel cap: the sum over max_box voxels stays below 2^B (rounding
     * adds at most 0.5 per voxel, hence the − max_box). */
    double cap = wide ? ldexp(1.0, 40) : (4294967295.0 - (double)max_box) / (double)max_box;
    if (wide) {
        double c64 = (18446744073709551615.0 - (double)max_box) / (double)max_box;
        if (c64 < cap) cap = c64;
    }
    sat->scale = smax > 0.0 ? cap / smax : 0.0;
    sat_job job = {v, lut, NULL, sat->scale, sat, 16384};
    uint64_t qtab_store[256];
    uint64_t *qtab = NULL;
    size_t qn = v->storage == VOLUX_STORE_U8 ? 256 : (v->storage == VOLUX_STORE_U16 ? 65536 : 0);
    if (qn == 256) qtab = qtab_store;
    else if (qn) {
        qtab = volux_malloc(ctx, qn * sizeof *qtab);
        if (!qtab) return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for a summed-area table");
    }
    for (size_t i = 0; i < qn; i++)
        qtab[i] = (uint64_t)llrint((double)volux_lut_sigma(lut, (float)i + v->value_offset) * sat->scale);
    job.qtab = qtab;
    volux_parallel_for(threads, v->dims[2], wide ? slice_pass64 : slice_pass32, &job);
    size_t plane = (size_t)v->dims[0] * (size_t)v->dims[1];
    volux_parallel_for(threads, (int64_t)((plane + job.chunk - 1) / job.chunk), wide ? z_pass64 : z_pass32, &job);
    if (qn > 256) volux_free(ctx, qtab, qn * sizeof *qtab);
    return VOLUX_OK;
}

#define BOX_SUM(T, S, nx, ny, x0, y0, z0, x1, y1, z1)                                                          \
    do {                                                                                                         \
        const T *s_ = (const T *)(S);                                                                            \
        size_t nx_ = (size_t)(nx), pl_ = nx_ * (size_t)(ny);                                                     \
        T acc_ = 0;                                                                                              \
        for (int cz_ = 0; cz_ < 2; cz_++) {                                                                      \
            int zz_ = cz_ ? (z1) : (z0) - 1;                                                                     \
            if (zz_ < 0) continue;                                                                               \
            for (int cy_ = 0; cy_ < 2; cy_++) {                                                                  \
                int yy_ = cy_ ? (y1) : (y0) - 1;                                                                 \
                if (yy_ < 0) continue;                                                                           \
                const T *row_ = s_ + (size_t)zz_ * pl_ + (size_t)yy_ * nx_;                                      \
                T r_ = row_[(x1)];                                                                               \
                if ((x0) > 0) r_ -= row_[(x0) - 1];                                                              \
                if (cz_ ^ cy_) acc_ -= r_;                                                                       \
                else acc_ += r_;                                                                                 \
            }                                                                                                    \
        }                                                                                                        \
        result = (double)acc_;                                                                                   \
    } while (0)

double scatter_sat_box(const scatter_sat *sat, int x0, int y0, int z0, int x1, int y1, int z1) {
    if (x1 < x0 || y1 < y0 || z1 < z0 || sat->scale <= 0.0) return 0.0;
    double result;
    if (sat->wide) BOX_SUM(uint64_t, sat->data, sat->dims[0], sat->dims[1], x0, y0, z0, x1, y1, z1);
    else BOX_SUM(uint32_t, sat->data, sat->dims[0], sat->dims[1], x0, y0, z0, x1, y1, z1);
    return result / sat->scale;
}

typedef struct filter_job {
    const scatter_sat *sat;
    int n_boxes;
    int half[8][3];
    double weight[8]; /* divided by the SAT scale */
    int exponentiate;
    float *out;
    double *scratch; /* one row of nx doubles per thread */
} filter_job;

/* Adds w·(box sum of half-width h around x) to acc[x] for one row: the four
 * (y, z) corner rows are fixed for the row, so the x loop is 8 loads and
 * modular adds — vectorisable in the interior where no x clipping occurs. */
#define FILTER_ROW(NAME, T)                                                                                      \
    static inline T NAME##_edge(const T *const rr[4], const int sign[4], int nx, int x, int h) {                \
        int x1 = x + h > nx - 1 ? nx - 1 : x + h, x0 = x - h - 1;                                                \
        T v = 0;                                                                                                 \
        for (int c = 0; c < 4; c++) {                                                                            \
            if (!rr[c]) continue;                                                                                \
            T d = (T)(rr[c][x1] - (x0 >= 0 ? rr[c][x0] : 0));                                                    \
            v = sign[c] > 0 ? (T)(v + d) : (T)(v - d);                                                           \
        }                                                                                                        \
        return v;                                                                                                \
    }                                                                                                            \
    static void NAME(const scatter_sat *sat, const T *const rows[4], const int sign[4], int h, double w,         \
                     double *acc) {                                                                              \
        int nx = sat->dims[0], xa = h + 1, xb = nx - 1 - h; /* interior: no clipping in x */                    \
        if (xa > xb) {                                                                                           \
            for (int x = 0; x < nx; x++) acc[x] += w * (double)NAME##_edge(rows, sign, nx, x, h);                 \
            return;                                                                                              \
        }                                                                                                        \
        for (int x = 0; x < xa; x++) acc[x] += w * (double)NAME##_edge(rows, sign, nx, x, h);                     \
        /* absent rows (index −1) contribute 0: point them at a row of the SAT and zero the sign */             \
        const T *r[4];                                                                                           \
        T sg[4];                                                                                                 \
        for (int c = 0; c < 4; c++) {                                                                            \
            r[c] = rows[c] ? rows[c] : (const T *)sat->data;                                                     \
            sg[c] = rows[c] ? (T)(sign[c] > 0 ? 1 : (T)-1) : 0;                                                  \
        }                                                                                                        \
        for (int x = xa; x <= xb; x++) {                                                                         \
            T v = (T)(sg[0] * (T)(r[0][x + h] - r[0][x - h - 1]) + sg[1] * (T)(r[1][x + h] - r[1][x - h - 1]) + \
                      sg[2] * (T)(r[2][x + h] - r[2][x - h - 1]) + sg[3] * (T)(r[3][x + h] - r[3][x - h - 1])); \
            acc[x] += w * (double)v;                                                                             \
        }                                                                                                        \
        for (int x = xb + 1; x < nx; x++) acc[x] += w * (double)NAME##_edge(rows, sign, nx, x, h);                \
    }
FILTER_ROW(filter_row32, uint32_t)
FILTER_ROW(filter_row64, uint64_t)

static void filter_slice(void *user, int64_t zi, int thread) {
    (void)thread;
    const filter_job *j = user;
    const scatter_sat *sat = j->sat;
    int nx = sat->dims[0], ny = sat->dims[1], nz = sat->dims[2], z = (int)zi;
    size_t plane = (size_t)nx * (size_t)ny;
    double *acc = j->scratch + (size_t)thread * (size_t)nx;
    for (int y = 0; y < ny; y++) {
        float *out = j->out + ((size_t)z * (size_t)ny + (size_t)y) * (size_t)nx;
        memset(acc, 0, sizeof(double) * (size_t)nx);
        for (int k = 0; k < j->n_boxes; k++) {
            const int *h = j->half[k];
            int y1 = y + h[1] > ny - 1 ? ny - 1 : y + h[1], y0 = y - h[1] - 1;
            int z1 = z + h[2] > nz - 1 ? nz - 1 : z + h[2], z0 = z - h[2] - 1;
            /* corner rows (y1,z1) + , (y0,z1) − , (y1,z0) − , (y0,z0) + */
            int ys[4] = {y1, y0, y1, y0}, zs[4] = {z1, z1, z0, z0}, sign[4] = {1, -1, -1, 1};
            if (sat->wide) {
                const uint64_t *rows[4];
                for (int c = 0; c < 4; c++)
                    rows[c] = ys[c] < 0 || zs[c] < 0 ? NULL
                                                     : (const uint64_t *)sat->data + (size_t)zs[c] * plane +
                                                           (size_t)ys[c] * (size_t)nx;
                filter_row64(sat, rows, sign, h[0], j->weight[k], acc);
            } else {
                const uint32_t *rows[4];
                for (int c = 0; c < 4; c++)
                    rows[c] = ys[c] < 0 || zs[c] < 0 ? NULL
                                                     : (const uint32_t *)sat->data + (size_t)zs[c] * plane +
                                                           (size_t)ys[c] * (size_t)nx;
                filter_row32(sat, rows, sign, h[0], j->weight[k], acc);
            }
        }
        if (j->exponentiate)
            for (int x = 0; x < nx; x++) out[x] = (float)exp(-acc[x]);
        else
            for (int x = 0; x < nx; x++) out[x] = (float)acc[x];
    }
}

volux_status scatter_sat_filter(volux_context *ctx, int threads, const scatter_sat *sat, int n_boxes,
                                const int half[][3], const double *weight, int exponentiate, float *out) {
    if (n_boxes < 1 || n_boxes > 8) return volux_error(ctx, VOLUX_ERR_INTERNAL, "sat filter: %d boxes", n_boxes);
    filter_job job;
    memset(&job, 0, sizeof job);
    job.sat = sat;
    job.n_boxes = n_boxes;
    job.exponentiate = exponentiate;
    job.out = out;
    for (int k = 0; k < n_boxes; k++) {
        memcpy(job.half[k], half[k], sizeof job.half[k]);
        job.weight[k] = sat->scale > 0.0 ? weight[k] / sat->scale : 0.0;
    }
    int nt = threads > 0 ? threads : volux_parallel_max_threads();
    size_t bytes = sizeof(double) * (size_t)sat->dims[0] * (size_t)nt;
    job.scratch = volux_malloc(ctx, bytes);
    if (!job.scratch) return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for a box filter");
    volux_parallel_for(nt, sat->dims[2], filter_slice, &job);
    volux_free(ctx, job.scratch, bytes);
    return VOLUX_OK;
}
