/*
 * techniques/guided/sweep.c — the visibility grid's contents: visibility
 * sweeps (§6, Fig. 4) with sweep-space filtering (§8) and angular
 * oversampling, and the brute-force reference (rays from every grid
 * position).
 *
 * V(x, ω) is the transmittance from x to the box along ω (towards the
 * light, Eq. 4). Everything runs in the volume's index space: ω becomes the
 * index-space displacement per world unit wi = ω / spacing.
 *
 * SWEEP (one direction ω). The sweep axis n is the dominant axis of wi
 * (Eq. 6). The sweeping kernel is a 2-D grid of rays parallel to ω, one per
 * `ray_spacing` voxels in the two tangent axes (a, b), starting on the
 * light side of the box (the plane P_d) and covering the box's whole
 * projection along ω. The sweep advances one voxel plane along n at a time,
 * away from the light. On voxel plane k every kernel ray lies at tangent
 * position (h·i + A_k, h·j + B_k) with A_k = off_a − k·s_a, s_a = wi_a/|wi_n|:
 * all rays share the fractional offsets, so the trilinear field on the
 * plane is a bilinear blend of four nodes with one set of weights per
 * plane, read row by row (the x-dominant directions read a transposed copy
 * [x][z][y] so rows stay contiguous). Each ray accumulates the optical
 * depth W += Δt·σt(s) with Δt = 1/|wi_n| the world distance between planes
 * (post-classification: σt of the interpolated value; midpoint rule, each
 * plane sample standing for ±½ plane around it, clipped to where the ray is
 * inside the box and extended to its entry/exit when it crosses a side
 * face between planes, plane_span). This is Eq. 8 with
 * V = exp(−W): V(x(t_i)) = V(x(t_{i−1}))·T_r(x(t_{i−1}), x(t_i)).
 *
 * When the sweep passes the plane of a slice of grid centres (depth d
 * planes from P_d), the kernel's visibility there is
 *     V = exp(−(W_{k−1} + (d − lo_k)·Δt·σ_k)),   (lo_k: plane_span)
 * and each centre is projected along ω onto the kernel and looked up
 * bilinearly (Fig. 4d).
 *
 * FILTER (§8). Before the lookup, V on the kernel is box-filtered, the
 * filter being separable and implemented as a sliding window, with a
 * half-width per tangent axis of half the grid cell's projection onto the
 * plane, (c_a + c_n·|s_a|)/2, plus t·tan β (Eq. 9), t the world distance
 * from P_d to the slice along ω and β = filter_angle · α, α = π/N the
 * angular width of a direction texel of an N×N octahedral map (the paper
 * quotes "π/8 = 11.25°" for 8×8: the two numbers disagree; we take the
 * texel width π/N and β = α/2 by default, docs/techniques/guided.md).
 *
 * OVERSAMPLING. A direction texel's value is the mean over s×s sub-texel
 * directions, each swept (or brute-forced) on its own.
 *
 * BRUTE FORCE. From every grid centre, a ray along ω with world step equal
 * to the smallest spacing, midpoint samples of σt(trilinear value), to the
 * box; it stops once W > 12 (then V < 7·10⁻⁶ rounds to 0 in 16 bits).
 *
 * Both write V quantised to 16 bits into the grid's direction column.
 * Directions are independent work items (volux_parallel_for), each written
 * by one thread, so the grid does not depend on the thread count.
 */
#include <math.h>
#include <string.h>

#include "core/context_internal.h"
#include "core/parallel.h"
#include "core/volume_internal.h"
#include "guided.h"
#include "sample/march.h"
#include "sweep_kernels.h"

/* Quantised V → uint16. */
static inline uint16_t quantise(float v) {
    v = v < 0.0f ? 0.0f : v > 1.0f ? 1.0f : v;
    return (uint16_t)(v * 65535.0f + 0.5f);
}

/* ---------------------------------------------------------------- source slices */

/* The volume as rows of nodes along a tangent axis: row (plane p, row j)
 * starts at base + (p·plane_stride + j·row_stride) elements. */
typedef struct slices {
    const void *base;
    volux_storage storage;
    float offset; /* value offset (int8/int16 storage) */
    size_t plane_stride, row_stride;
    int na, nb, nn; /* nodes along the row, across rows, along n */
} slices;

static void slices_for_axis(const volux_volume *v, const void *xt, int n, slices *s) {
    int nx = v->dims[0], ny = v->dims[1], nz = v->dims[2];
    s->storage = v->storage;
    s->offset = v->value_offset;
    if (n == 2) { /* planes z, rows y, along x */
        s->base = v->data;
        s->plane_stride = (size_t)nx * (size_t)ny;
        s->row_stride = (size_t)nx;
        s->na = nx, s->nb = ny, s->nn = nz;
    } else if (n == 1) { /* planes y, rows z, along x */
        s->base = v->data;
        s->plane_stride = (size_t)nx;
        s->row_stride = (size_t)nx * (size_t)ny;
        s->na = nx, s->nb = nz, s->nn = ny;
    } else { /* planes x, rows z, along y: the transposed copy [x][z][y] */
        s->base = xt;
        s->plane_stride = (size_t)ny * (size_t)nz;
        s->row_stride = (size_t)ny;
        s->na = ny, s->nb = nz, s->nn = nx;
    }
}

static size_t storage_bytes(volux_storage s) { return s == VOLUX_STORE_U8 ? 1 : s == VOLUX_STORE_U16 ? 2 : 4; }

/* The [x][z][y] copy of the volume's nodes (x-dominant sweeps). */
static void *transpose_x(volux_context *ctx, const volux_volume *v, size_t *bytes) {
    int nx = v->dims[0], ny = v->dims[1], nz = v->dims[2];
    size_t e = storage_bytes(v->storage);
    *bytes = (size_t)nx * (size_t)ny * (size_t)nz * e;
    unsigned char *t = volux_alloc_aligned(ctx, *bytes);
    if (!t) return NULL;
    const unsigned char *src = v->data;
    for (int z = 0; z < nz; z++)
        for (int y = 0; y < ny; y++) {
            const unsigned char *row = src + ((size_t)z * (size_t)ny + (size_t)y) * (size_t)nx * e;
            for (int x = 0; x < nx; x++)
                memcpy(t + (((size_t)x * (size_t)nz + (size_t)z) * (size_t)ny + (size_t)y) * e, row + (size_t)x * e, e);
        }
    return t;
}

static inline float node(const slices *s, const void *row, int i) {
    switch (s->storage) {
    case VOLUX_STORE_U8: return (float)((const uint8_t *)row)[i];
    case VOLUX_STORE_U16: return (float)((const uint16_t *)row)[i];
    default: return ((const float *)row)[i];
    }
}

static inline const void *row_ptr(const slices *s, int plane, int j) {
    return (const unsigned char *)s->base + ((size_t)plane * s->plane_stride + (size_t)j * s->row_stride) *
                                                storage_bytes(s->storage);
}

/* ---------------------------------------------------------------- sweep */

typedef struct sweep_buffers {
    float *W;     /* optical depth per kernel ray, Ka·Kb                  */
    float *sig;   /* σt on the current plane, Ka·Kb                       */
    float *T;     /* visibility on the kernel at a grid slice, Ka·Kb      */
    float *tmp;   /* filter pass, Ka·Kb                                   */
    float *acc;   /* the direction's value per grid cell                  */
    float *edges; /* depths where each kernel column / row is inside the
                     box: entry, exit per column (2·Ka), per row (2·Kb)   */
    float *cols;  /* Δt·weight per column, per ray of one row, filter sums
                     (3·Ka + 1)                                           */
} sweep_buffers;

/* The depth interval (in planes) where a kernel ray whose tangent position
 * at depth 0 is p0, shifting by −s per plane, lies inside [0, n − 1]. */
static void inside_depths(float p0, float s, int n, float *entry, float *exit) {
    float top = (float)(n - 1);
    if (s > 0.0f) {
        *entry = (p0 - top) / s;
        *exit = p0 / s;
    } else if (s < 0.0f) {
        *entry = p0 / s;
        *exit = (p0 - top) / s;
    } else if (p0 >= 0.0f && p0 <= top) {
        *entry = -INFINITY;
        *exit = INFINITY;
    } else {
        *entry = INFINITY;
        *exit = -INFINITY;
    }
}

/* The depths plane k's sample stands for on a ray inside the box over
 * [entry, exit]: (k − ½, k + ½], extended to the entry (exit) when plane
 * k − 1 (k + 1) is outside, so a ray that enters or leaves through a side
 * face between two planes is integrated from where it enters to where it
 * leaves. */
static inline float maxf(float a, float b) { return a > b ? a : b; }
static inline float minf(float a, float b) { return a < b ? a : b; }

static inline void plane_span(int k, float entry, float exit, float *lo, float *hi) {
    *lo = entry > (float)k - 1.0f ? entry : (float)k - 0.5f;
    *hi = exit < (float)k + 1.0f ? exit : (float)k + 0.5f;
}

/* Box filter of radius r along each row of the window (rows of n values
 * at `stride`), edge-clamped: the mean over the values that exist. Prefix
 * sums (in `prefix`, n + 1 floats), so the cost does not depend on r (§8:
 * "a sliding window") and the output pass vectorises. */
static void box_rows(const float *in, float *out, int rows, int n, size_t stride, int r, float *prefix) {
    float inv = 1.0f / (float)(2 * r + 1);
    for (int j = 0; j < rows; j++) {
        const float *x = in + (size_t)j * stride;
        float *y = out + (size_t)j * stride;
        prefix[0] = 0.0f;
        for (int i = 0; i < n; i++) prefix[i + 1] = prefix[i] + x[i];
        int a = r < n ? r : n, b = n - r > a ? n - r : a; /* [a, b): full windows */
        for (int i = 0; i < a; i++) {
            int top = i + r < n - 1 ? i + r : n - 1;
            y[i] = prefix[top + 1] / (float)(top + 1);
        }
        for (int i = a; i < b; i++) y[i] = (prefix[i + r + 1] - prefix[i - r]) * inv;
        for (int i = b; i < n; i++) {
            int lo = i - r > 0 ? i - r : 0;
            y[i] = (prefix[n] - prefix[lo]) / (float)(n - lo);
        }
    }
}

/* The same across rows: one running sum per column, updated a whole row at
 * a time (contiguous, vectorisable). `sums` holds n floats. */
static void box_cols(const float *in, float *out, int rows, int n, size_t stride, int r, float *sums) {
    memset(sums, 0, sizeof(float) * (size_t)n);
    int hi = r < rows - 1 ? r : rows - 1;
    for (int j = 0; j <= hi; j++)
        for (int i = 0; i < n; i++) sums[i] += in[(size_t)j * stride + (size_t)i];
    for (int j = 0; j < rows; j++) {
        int lo = j - r > 0 ? j - r : 0, top = j + r < rows - 1 ? j + r : rows - 1;
        float inv = 1.0f / (float)(top - lo + 1);
        float *y = out + (size_t)j * stride;
        for (int i = 0; i < n; i++) y[i] = sums[i] * inv;
        if (j + r + 1 < rows) {
            const float *add = in + (size_t)(j + r + 1) * stride;
            for (int i = 0; i < n; i++) sums[i] += add[i];
        }
        if (j - r >= 0) {
            const float *sub = in + (size_t)(j - r) * stride;
            for (int i = 0; i < n; i++) sums[i] -= sub[i];
        }
    }
}

/* Sweep geometry of one direction. */
typedef struct sweep_geom {
    int n, a, b;        /* sweep axis and tangent axes                  */
    float sa, sb;       /* tangent shift per plane                      */
    float dt;           /* world distance between planes                */
    int forward;        /* 1: the light is on the high side of n        */
    float off_a, off_b; /* kernel origin (tangent index units)          */
    int Ka, Kb, h;      /* kernel rays per tangent axis, spacing         */
} sweep_geom;

static void sweep_setup(const volux_volume *v, volux_vec3 w, int h, sweep_geom *g) {
    float wi[3] = {w.x * v->inv_spacing[0], w.y * v->inv_spacing[1], w.z * v->inv_spacing[2]};
    int n = 0;
    for (int a = 1; a < 3; a++)
        if (fabsf(wi[a]) > fabsf(wi[n])) n = a;
    g->n = n;
    g->a = n == 0 ? 1 : 0;
    g->b = n == 2 ? 1 : 2;
    float wn = fabsf(wi[n]);
    g->sa = wi[g->a] / wn;
    g->sb = wi[g->b] / wn;
    g->dt = 1.0f / wn;
    g->forward = wi[n] > 0.0f;
    g->h = h;
    int nn = v->dims[n], na = v->dims[g->a], nb = v->dims[g->b];
    float ext_a = (float)(nn - 1) * g->sa, ext_b = (float)(nn - 1) * g->sb;
    g->off_a = floorf(fminf(0.0f, ext_a));
    g->off_b = floorf(fminf(0.0f, ext_b));
    g->Ka = (int)ceilf(((float)(na - 1) - g->off_a + fmaxf(0.0f, ext_a)) / (float)h) + 2;
    g->Kb = (int)ceilf(((float)(nb - 1) - g->off_b + fmaxf(0.0f, ext_b)) / (float)h) + 2;
}

/* σt on plane k for the kernel rays that lie inside the box there; their
 * range is returned in [*ia0, *ia1] × [*ib0, *ib1] (empty if ia0 > ia1). */
/* exp(x) for x ≤ 0 without a library call or a branch, so the slice loops
 * vectorise: 2^(x·log2 e) split into 2^n (exponent bits; n rounded to
 * nearest by the 1.5·2²³ trick) times a degree-6 polynomial for 2^f,
 * f ∈ [−½, ½] (relative error < 2·10⁻⁷); x below −87 is taken as −87. */
static inline float fast_exp(float x) {
    x = x > -87.0f ? x : -87.0f;
    float y = x * 1.44269504f;
    float n = (y + 12582912.0f) - 12582912.0f;
    float f = y - n;
    float p = 1.5353362e-4f;
    p = p * f + 1.3398874e-3f;
    p = p * f + 9.6180636e-3f;
    p = p * f + 5.5503342e-2f;
    p = p * f + 2.4022652e-1f;
    p = p * f + 6.9314718e-1f;
    p = p * f + 1.0f;
    int32_t bits = ((int32_t)n + 127) << 23;
    float scale;
    memcpy(&scale, &bits, sizeof scale);
    return p * scale;
}

/* The portable row loop (sweep_kernels.h). */
#define SWEEP_ROW(NAME, T)                                                                                        \
    static void NAME(const void *r0v, const void *r1v, int h, float fa, float fb, float offset,                    \
                     const sweep_lut *L, int n, float *W, const float *wdt, float *sig) {                         \
        const T *R0 = r0v, *R1 = r1v;                                                                             \
        for (int i = 0; i < n; i++) {                                                                             \
            int c = h * i;                                                                                        \
            float a0 = (float)R0[c], a1 = (float)R0[c + 1], b0 = (float)R1[c], b1 = (float)R1[c + 1];             \
            float top = a0 + fa * (a1 - a0), bot = b0 + fa * (b1 - b0);                                          \
            float sg = sweep_lut_sigma(L, top + fb * (bot - top) + offset);                                       \
            if (sig) sig[i] = sg;                                                                                 \
            W[i] += wdt[i] * sg;                                                                                  \
        }                                                                                                         \
    }
SWEEP_ROW(row_u8, uint8_t)
SWEEP_ROW(row_u16, uint16_t)
SWEEP_ROW(row_f32, float)

/* Sweeps direction w (unit, towards the light) and adds weight·V at every
 * grid centre to b->acc. */
static void sweep_direction(const volux_volume *v, const void *xt, const sweep_lut *lut, const guided_grid *grid,
                            const guided_vis_params *p, volux_vec3 w, float weight, sweep_buffers *b) {
    sweep_geom g;
    sweep_setup(v, w, p->ray_spacing, &g);
    slices s;
    slices_for_axis(v, xt, g.n, &s);
    sweep_row_fn row = s.storage == VOLUX_STORE_U8 ? row_u8 : s.storage == VOLUX_STORE_U16 ? row_u16 : row_f32;
    if (p->simd && g.h == 1) row = guided_sweep_row_avx512(s.storage);
    size_t esize = storage_bytes(s.storage);
    size_t K = (size_t)g.Ka * (size_t)g.Kb;
    memset(b->W, 0, K * sizeof(float));
    float *ent_a = b->edges, *ext_a = ent_a + g.Ka, *ent_b = ext_a + g.Ka, *ext_b = ent_b + g.Kb;
    float *wcol = b->cols, *wray = wcol + g.Ka;
    for (int i = 0; i < g.Ka; i++) {
        inside_depths((float)(g.h * i) + g.off_a, g.sa, s.na, &ent_a[i], &ext_a[i]);
        ent_a[i] = maxf(ent_a[i], 0.0f);
        ext_a[i] = minf(ext_a[i], (float)(s.nn - 1));
    }
    for (int j = 0; j < g.Kb; j++) inside_depths((float)(g.h * j) + g.off_b, g.sb, s.nb, &ent_b[j], &ext_b[j]);
    int gn = grid->cells[g.n], ga = grid->cells[g.a], gb = grid->cells[g.b];
    float cn = grid->cell_size[g.n], ca = grid->cell_size[g.a], cb = grid->cell_size[g.b];
    float tan_beta = tanf(p->filter_angle * VOLUX_PI / (float)p->dir_res);
    float inv_h = 1.0f / (float)g.h, hf = (float)g.h;
    float spa = (float)v->spacing[g.a], spb = (float)v->spacing[g.b];
    int next = 0; /* grid slices in sweep order: depth (planes from P_d) increasing */
    for (int k = 0; k < s.nn && next < gn; k++) {
        /* does a slice of grid centres lie in the depths this plane stands for? */
        int sl0 = g.forward ? gn - 1 - next : next;
        float d0 = g.forward ? (float)(s.nn - 1) - guided_cell_center(grid, g.n, sl0) : guided_cell_center(grid, g.n, sl0);
        int slice_plane = d0 <= (float)k + 0.5f || k == s.nn - 1;
        float *sig = slice_plane ? b->sig : NULL;

        /* ---- the plane: W += Δt·w·σt over the rays inside the box */
        int plane = g.forward ? s.nn - 1 - k : k;
        float A = g.off_a - (float)k * g.sa, B = g.off_b - (float)k * g.sb;
        int ia0 = (int)ceilf(-A * inv_h), ia1 = (int)floorf(((float)(s.na - 1) - A) * inv_h);
        int ib0 = (int)ceilf(-B * inv_h), ib1 = (int)floorf(((float)(s.nb - 1) - B) * inv_h);
        if (ia0 < 0) ia0 = 0;
        if (ib0 < 0) ib0 = 0;
        if (ia1 > g.Ka - 1) ia1 = g.Ka - 1;
        if (ib1 > g.Kb - 1) ib1 = g.Kb - 1;
        float fa = A - floorf(A);
        int ishift = (int)floorf(A);
        /* columns whose rays all read c + 1 inside the row */
        int ia_fast = ia1;
        while (ia_fast >= ia0 && g.h * ia_fast + ishift + 1 > s.na - 1) ia_fast--;
        for (int ia = ia0; ia <= ia1; ia++) {
            float lo, hi;
            plane_span(k, ent_a[ia], ext_a[ia], &lo, &hi);
            wcol[ia] = g.dt * maxf(hi - lo, 0.0f);
        }
        for (int jb = ib0; jb <= ib1 && ia0 <= ia1; jb++) {
            float pb = hf * (float)jb + B;
            int r0 = (int)pb;
            if (r0 > s.nb - 1) r0 = s.nb - 1;
            if (r0 < 0) r0 = 0;
            float fb = pb - (float)r0;
            int r1 = r0 + 1 < s.nb ? r0 + 1 : r0;
            const unsigned char *R0 = row_ptr(&s, plane, r0), *R1 = row_ptr(&s, plane, r1);
            /* a row entering or leaving through a b-face on this plane needs
             * per-ray weights; other rows take the columns' */
            const float *wr = wcol;
            if (ent_b[jb] > (float)k - 1.0f || ext_b[jb] < (float)k + 1.0f) {
                for (int ia = ia0; ia <= ia1; ia++) {
                    float lo, hi;
                    plane_span(k, maxf(ent_a[ia], ent_b[jb]), minf(ext_a[ia], ext_b[jb]), &lo, &hi);
                    wray[ia] = g.dt * maxf(hi - lo, 0.0f);
                }
                wr = wray;
            }
            size_t o = (size_t)jb * (size_t)g.Ka;
            int c0 = g.h * ia0 + ishift;
            if (ia_fast >= ia0)
                row(R0 + (size_t)c0 * esize, R1 + (size_t)c0 * esize, g.h, fa, fb, s.offset, lut, ia_fast - ia0 + 1,
                    b->W + o + ia0, wr + ia0, sig ? sig + o + ia0 : NULL);
            for (int ia = ia_fast + 1; ia <= ia1; ia++) { /* the last column: its c + 1 is the row's end */
                int c = g.h * ia + ishift;
                if (c > s.na - 1) c = s.na - 1;
                float top = node(&s, R0, c), bot = node(&s, R1, c);
                float sg = sweep_lut_sigma(lut, top + fb * (bot - top) + s.offset);
                if (sig) sig[o + ia] = sg;
                b->W[o + ia] += wr[ia] * sg;
            }
        }
        if (!slice_plane) continue;

        /* ---- the slices of grid centres in this plane's depths */
        for (; next < gn; next++) {
            int sl = g.forward ? gn - 1 - next : next;
            float zc = guided_cell_center(grid, g.n, sl);
            float depth = g.forward ? (float)(s.nn - 1) - zc : zc;
            if (depth > (float)k + 0.5f && k < s.nn - 1) break;
            /* kernel coordinates of the slice's centres */
            float As = g.off_a - depth * g.sa, Bs = g.off_b - depth * g.sb;
            float ka_lo = (0.5f * ca - As) * inv_h, ka_hi = (((float)ga - 0.5f) * ca - As) * inv_h;
            float kb_lo = (0.5f * cb - Bs) * inv_h, kb_hi = (((float)gb - 0.5f) * cb - Bs) * inv_h;
            int ra = 0, rb = 0;
            if (p->filter) {
                float t = depth * g.dt; /* world distance from P_d */
                ra = (int)floorf((0.5f * (ca + cn * fabsf(g.sa)) + t * tan_beta / spa) * inv_h + 0.5f);
                rb = (int)floorf((0.5f * (cb + cn * fabsf(g.sb)) + t * tan_beta / spb) * inv_h + 0.5f);
            }
            int wa0 = (int)floorf(ka_lo) - ra, wa1 = (int)floorf(ka_hi) + 1 + ra;
            int wb0 = (int)floorf(kb_lo) - rb, wb1 = (int)floorf(kb_hi) + 1 + rb;
            if (wa0 < 0) wa0 = 0;
            if (wb0 < 0) wb0 = 0;
            if (wa1 > g.Ka - 1) wa1 = g.Ka - 1;
            if (wb1 > g.Kb - 1) wb1 = g.Kb - 1;
            /* V on the window at this depth: W now holds plane k's whole
             * span; take back the part beyond the slice (per column for
             * rows that neither enter nor leave on this plane, per ray for
             * those that do) */
            int ta0 = wa0 > ia0 ? wa0 : ia0, ta1 = wa1 < ia1 ? wa1 : ia1;
            for (int ia = ta0; ia <= ta1; ia++) {
                float lo, hi;
                plane_span(k, ent_a[ia], ext_a[ia], &lo, &hi);
                float span = maxf(hi - lo, 0.0f), part = minf(maxf(depth - lo, 0.0f), span);
                wcol[ia] = (span - part) * g.dt;
            }
            for (int jb = wb0; jb <= wb1; jb++) {
                const float *Wr = b->W + (size_t)jb * (size_t)g.Ka, *Sr = b->sig + (size_t)jb * (size_t)g.Ka;
                float *Tr = b->T + (size_t)jb * (size_t)g.Ka;
                for (int ia = wa0; ia <= wa1; ia++) Tr[ia] = Wr[ia];
                if (jb >= ib0 && jb <= ib1) {
                    if (ent_b[jb] > (float)k - 1.0f || ext_b[jb] < (float)k + 1.0f) {
                        for (int ia = ta0; ia <= ta1; ia++) {
                            float lo, hi;
                            plane_span(k, maxf(ent_a[ia], ent_b[jb]), minf(ext_a[ia], ext_b[jb]), &lo, &hi);
                            float span = maxf(hi - lo, 0.0f), part = minf(maxf(depth - lo, 0.0f), span);
                            Tr[ia] -= (span - part) * g.dt * Sr[ia];
                        }
                    } else {
                        for (int ia = ta0; ia <= ta1; ia++) Tr[ia] -= wcol[ia] * Sr[ia];
                    }
                }
                for (int ia = wa0; ia <= wa1; ia++) Tr[ia] = fast_exp(-Tr[ia]);
            }
            if (p->filter && (ra > 0 || rb > 0)) {
                size_t o = (size_t)wb0 * (size_t)g.Ka + (size_t)wa0;
                int na_w = wa1 - wa0 + 1, nb_w = wb1 - wb0 + 1;
                box_rows(b->T + o, b->tmp + o, nb_w, na_w, (size_t)g.Ka, ra, wray);
                box_cols(b->tmp + o, b->T + o, nb_w, na_w, (size_t)g.Ka, rb, wray);
            }
            /* bilinear lookup at the projected centres (Fig. 4d) */
            for (int jb = 0; jb < gb; jb++) {
                float kb = (((float)jb + 0.5f) * cb - Bs) * inv_h;
                int y0 = (int)floorf(kb);
                float fy = kb - (float)y0;
                if (y0 < wb0) y0 = wb0, fy = 0.0f;
                if (y0 > wb1) y0 = wb1, fy = 0.0f;
                int y1 = y0 + 1 <= wb1 ? y0 + 1 : y0;
                for (int ja = 0; ja < ga; ja++) {
                    float ka = (((float)ja + 0.5f) * ca - As) * inv_h;
                    int x0 = (int)floorf(ka);
                    float fx = ka - (float)x0;
                    if (x0 < wa0) x0 = wa0, fx = 0.0f;
                    if (x0 > wa1) x0 = wa1, fx = 0.0f;
                    int x1 = x0 + 1 <= wa1 ? x0 + 1 : x0;
                    const float *T0 = b->T + (size_t)y0 * (size_t)g.Ka, *T1 = b->T + (size_t)y1 * (size_t)g.Ka;
                    float top = T0[x0] + fx * (T0[x1] - T0[x0]), bot = T1[x0] + fx * (T1[x1] - T1[x0]);
                    int c[3];
                    c[g.n] = sl, c[g.a] = ja, c[g.b] = jb;
                    size_t cell = ((size_t)c[2] * (size_t)grid->cells[1] + (size_t)c[1]) * (size_t)grid->cells[0] +
                                  (size_t)c[0];
                    b->acc[cell] += weight * (top + fy * (bot - top));
                }
            }
        }
    }
}

/* ---------------------------------------------------------------- brute force */

static void brute_direction(const volux_volume *v, const volux_transfer_lut *lut, const guided_grid *grid,
                            volux_vec3 w, float weight, float *acc) {
    float wi[3] = {w.x * v->inv_spacing[0], w.y * v->inv_spacing[1], w.z * v->inv_spacing[2]};
    float dt = (float)fmin(v->spacing[0], fmin(v->spacing[1], v->spacing[2]));
    size_t cell = 0;
    for (int k = 0; k < grid->cells[2]; k++)
        for (int j = 0; j < grid->cells[1]; j++)
            for (int i = 0; i < grid->cells[0]; i++, cell++) {
                float c[3] = {guided_cell_center(grid, 0, i), guided_cell_center(grid, 1, j),
                              guided_cell_center(grid, 2, k)};
                /* distance to the box along w */
                float t_exit = INFINITY;
                for (int a = 0; a < 3; a++) {
                    if (wi[a] > 0.0f) t_exit = fminf(t_exit, ((float)(v->dims[a] - 1) - c[a]) / wi[a]);
                    else if (wi[a] < 0.0f) t_exit = fminf(t_exit, -c[a] / wi[a]);
                }
                float tau = 0.0f;
                for (float t0 = 0.0f; t0 < t_exit && tau <= 12.0f; t0 += dt) {
                    float seg = fminf(dt, t_exit - t0), tm = t0 + 0.5f * seg;
                    float x = c[0] + tm * wi[0], y = c[1] + tm * wi[1], z = c[2] + tm * wi[2];
                    tau += seg * volux_lut_sigma(lut, volux_volume_sample_index(v, x, y, z));
                }
                acc[cell] += weight * expf(-tau);
            }
}

/* ---------------------------------------------------------------- driver */

typedef struct job {
    guided_grid *g;
    const volux_volume *v;
    const void *xt;
    const volux_transfer_lut *lut;
    sweep_lut slut; /* the LUT's σt padded by one node */
    const guided_vis_params *p;
    const int *dirs;
    size_t ncells, K, side; /* grid cells, largest kernel Ka·Kb and Ka or Kb */
    float *scratch; /* per thread: 4·K + ncells floats */
} job;

static void do_direction(void *user, int64_t index, int thread) {
    job *J = user;
    const guided_vis_params *p = J->p;
    size_t per = 4 * J->K + J->ncells + 7 * J->side + 1;
    float *base = J->scratch + (size_t)thread * per;
    sweep_buffers b = {base, base + J->K, base + 2 * J->K, base + 3 * J->K, base + 4 * J->K,
                       base + 4 * J->K + J->ncells, base + 4 * J->K + J->ncells + 4 * J->side};
    memset(b.acc, 0, J->ncells * sizeof(float));
    int d = J->dirs[index], s = p->oversample;
    float weight = 1.0f / (float)(s * s);
    for (int sv = 0; sv < s; sv++)
        for (int su = 0; su < s; su++) {
            volux_vec3 w = guided_direction(p->dir_res, d, s, su, sv);
            if (p->sweep) sweep_direction(J->v, J->xt, &J->slut, J->g, p, w, weight, &b);
            else brute_direction(J->v, J->lut, J->g, w, weight, b.acc);
        }
    int D = J->g->dirs;
    uint16_t *col = J->g->v + d;
    for (size_t c = 0; c < J->ncells; c++) col[c * (size_t)D] = quantise(b.acc[c]);
}

/* The largest kernel (Ka·Kb) any direction of this volume can need, and
 * its largest side. */
static size_t max_kernel(const volux_volume *v, int h, size_t *side) {
    size_t m = 0;
    *side = 0;
    for (int n = 0; n < 3; n++) {
        int a = n == 0 ? 1 : 0, b = n == 2 ? 1 : 2;
        int nn = v->dims[n];
        /* n is dominant in index space, so the shifts per plane are ≤ 1 */
        size_t Ka = (size_t)ceilf(((float)(v->dims[a] - 1) + (float)(nn - 1) + 1.0f) / (float)h) + 3;
        size_t Kb = (size_t)ceilf(((float)(v->dims[b] - 1) + (float)(nn - 1) + 1.0f) / (float)h) + 3;
        if (Ka * Kb > m) m = Ka * Kb;
        if (Ka > *side) *side = Ka;
        if (Kb > *side) *side = Kb;
    }
    return m;
}

volux_status guided_compute_directions(volux_context *ctx, int threads, guided_grid *g, const volux_volume *v,
                                       const volux_transfer_lut *lut, const guided_vis_params *p, const int *dirs,
                                       int n_dirs) {
    if (n_dirs <= 0) return VOLUX_OK;
    if (threads < 1) threads = 1;
    if (threads > n_dirs) threads = n_dirs;
    job J = {g, v, NULL, lut, {NULL, 0, 0, 0}, p, dirs, (size_t)g->cells[0] * (size_t)g->cells[1] * (size_t)g->cells[2],
             0, 0, NULL};
    J.K = p->sweep ? max_kernel(v, p->ray_spacing, &J.side) : 0;
    size_t per = 4 * J.K + J.ncells + 7 * J.side + 1, bytes;
    if (!volux_mul_size(per, (size_t)threads * sizeof(float), &bytes))
        return volux_error(ctx, VOLUX_ERR_LIMIT, "techniques.guided: sweep buffers too large");
    size_t lut_bytes = sizeof(float) * (size_t)(lut->n + 1);
    float *pad = volux_malloc(ctx, lut_bytes);
    if (!pad) return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for sweep buffers");
    memcpy(pad, lut->sigma_t, sizeof(float) * (size_t)lut->n);
    pad[lut->n] = lut->sigma_t[lut->n - 1];
    J.slut.t = pad;
    J.slut.s_min = lut->s_min;
    J.slut.inv_ds = lut->inv_ds;
    J.slut.last = (float)(lut->n - 1);
    J.scratch = volux_alloc_aligned(ctx, bytes);
    if (!J.scratch) {
        volux_free(ctx, pad, lut_bytes);
        return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory (%zu bytes) for sweep buffers", bytes);
    }
    size_t xt_bytes = 0;
    void *xt = NULL;
    if (p->sweep) {
        int need_x = 0;
        for (int i = 0; i < n_dirs && !need_x; i++)
            for (int sv = 0; sv < p->oversample; sv++)
                for (int su = 0; su < p->oversample; su++) {
                    sweep_geom sg;
                    sweep_setup(v, guided_direction(p->dir_res, dirs[i], p->oversample, su, sv), 1, &sg);
                    need_x |= sg.n == 0;
                }
        if (need_x && !(xt = transpose_x(ctx, v, &xt_bytes))) {
            volux_free_aligned(ctx, J.scratch, bytes);
            volux_free(ctx, pad, lut_bytes);
            return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for a transposed volume copy");
        }
    }
    J.xt = xt;
    volux_parallel_for(threads, n_dirs, do_direction, &J);
    if (xt) volux_free_aligned(ctx, xt, xt_bytes);
    volux_free_aligned(ctx, J.scratch, bytes);
    volux_free(ctx, pad, lut_bytes);
    return VOLUX_OK;
}
