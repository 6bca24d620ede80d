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
static inline void plane_span(int k, float entry, float exit, float *lo, float *hi) {
    *lo = entry > (float)k - 1.0f ? entry : (float)k - 0.5f;
    *hi = exit < (float)k + 1.0f ? exit : (float)k + 0.5f;
}

/* One-dimensional box filter of radius r over n values with stride
 * `stride`, edge-clamped (the mean over the values that exist). */
static void box_1d(const float *in, float *out, int n, size_t stride, int r) {
    if (r <= 0) {
        for (int i = 0; i < n; i++) out[(size_t)i * stride] = in[(size_t)i * stride];
        return;
    }
    double sum = 0.0;
    int lo = 0, hi = -1; /* window [lo, hi] */
    for (int i = 0; i < n; i++) {
        int want_hi = i + r < n - 1 ? i + r : n - 1, want_lo = i - r > 0 ? i - r : 0;
        while (hi < want_hi) sum += in[(size_t)(++hi) * stride];
        while (lo < want_lo) sum -= in[(size_t)(lo++) * stride];
        out[(size_t)i * stride] = (float)(sum / (double)(hi - lo + 1));
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
static void plane_sigma(const slices *s, const volux_transfer_lut *lut, const sweep_geom *g, int k, float *sig,
                        int *ia0, int *ia1, int *ib0, int *ib1) {
    int plane = g->forward ? s->nn - 1 - k : k;
    float A = g->off_a - (float)k * g->sa, B = g->off_b - (float)k * g->sb, h = (float)g->h;
    /* h·i + A ∈ [0, na − 1] */
    int i0 = (int)ceilf(-A / h), i1 = (int)floorf(((float)(s->na - 1) - A) / h);
    int j0 = (int)ceilf(-B / h), j1 = (int)floorf(((float)(s->nb - 1) - B) / h);
    if (i0 < 0) i0 = 0;
    if (j0 < 0) j0 = 0;
    if (i1 > g->Ka - 1) i1 = g->Ka - 1;
    if (j1 > g->Kb - 1) j1 = g->Kb - 1;
    *ia0 = i0, *ia1 = i1, *ib0 = j0, *ib1 = j1;
    if (i0 > i1 || j0 > j1) return;
    float fa = A - floorf(A);
    int ishift = (int)floorf(A);
    for (int jb = j0; jb <= j1; jb++) {
        float pb = h * (float)jb + B;
        int r0 = (int)pb;
        if (r0 > s->nb - 1) r0 = s->nb - 1;
        float fb = pb - (float)r0;
        int r1 = r0 + 1 < s->nb ? r0 + 1 : r0;
        const void *R0 = row_ptr(s, plane, r0), *R1 = row_ptr(s, plane, r1);
        float *out = sig + (size_t)jb * (size_t)g->Ka;
        for (int ia = i0; ia <= i1; ia++) {
            int c0 = g->h * ia + ishift;
            if (c0 < 0) c0 = 0;
            if (c0 > s->na - 1) c0 = s->na - 1;
            int c1 = c0 + 1 < s->na ? c0 + 1 : c0;
            float top = node(s, R0, c0) + fa * (node(s, R0, c1) - node(s, R0, c0));
            float bot = node(s, R1, c0) + fa * (node(s, R1, c1) - node(s, R1, c0));
            out[ia] = volux_lut_sigma(lut, top + fb * (bot - top) + s->offset);
        }
    }
}

/* Sweeps direction w (unit, towards the light) and adds weight·V at every
 * grid centre to b->acc. */
static void sweep_direction(const volux_volume *v, const void *xt, const volux_transfer_lut *lut,
                            const guided_grid *grid, const guided_vis_params *p, volux_vec3 w, float weight,
                            sweep_buffers *b) {
    sweep_geom g;
    sweep_setup(v, w, p->ray_spacing, &g);
    slices s;
    slices_for_axis(v, xt, g.n, &s);
    size_t K = (size_t)g.Ka * (size_t)g.Kb;
    memset(b->W, 0, K * sizeof(float));
    float *ent_a = b->edges, *ext_a = ent_a + g.Ka, *ent_b = ext_a + g.Ka, *ext_b = ent_b + g.Kb;
    for (int i = 0; i < g.Ka; i++) {
        inside_depths((float)(g.h * i) + g.off_a, g.sa, s.na, &ent_a[i], &ext_a[i]);
        ent_a[i] = fmaxf(ent_a[i], 0.0f);
        ext_a[i] = fminf(ext_a[i], (float)(s.nn - 1));
    }
    for (int j = 0; j < g.Kb; j++) inside_depths((float)(g.h * j) + g.off_b, g.sb, s.nb, &ent_b[j], &ext_b[j]);
    int gn = grid->cells[g.n], ga = grid->cells[g.a], gb = grid->cells[g.b];
    float cn = grid->cell_size[g.n], ca = grid->cell_size[g.a], cb = grid->cell_size[g.b];
    float tan_beta = tanf(p->filter_angle * VOLUX_PI / (float)p->dir_res);
    float inv_h = 1.0f / (float)g.h;
    float spa = (float)v->spacing[g.a], spb = (float)v->spacing[g.b];
    /* grid slices in sweep order: depth (planes from P_d) increasing */
    int next = 0;
    for (int k = 0; k < s.nn && next < gn; k++) {
        int ia0, ia1, ib0, ib1;
        plane_sigma(&s, lut, &g, k, b->sig, &ia0, &ia1, &ib0, &ib1);
        for (; next < gn; next++) {
            int sl = g.forward ? gn - 1 - next : next;
            float zc = guided_cell_center(grid, g.n, sl);
            float depth = g.forward ? (float)(s.nn - 1) - zc : zc;
            if (depth > (float)k + 0.5f && k < s.nn - 1) break;
            /* kernel coordinates of the slice's centres */
            float A = g.off_a - depth * g.sa, B = g.off_b - depth * g.sb;
            float ka_lo = (0.5f * ca - A) * inv_h, ka_hi = ((float)(ga - 0.5f) * ca - A) * inv_h;
            float kb_lo = (0.5f * cb - B) * inv_h, kb_hi = ((float)(gb - 0.5f) * cb - B) * inv_h;
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
            /* V on the window at this depth */
            for (int jb = wb0; jb <= wb1; jb++) {
                const float *Wr = b->W + (size_t)jb * (size_t)g.Ka, *Sr = b->sig + (size_t)jb * (size_t)g.Ka;
                float *Tr = b->T + (size_t)jb * (size_t)g.Ka;
                int inside = jb >= ib0 && jb <= ib1;
                for (int ia = wa0; ia <= wa1; ia++) {
                    float tau = Wr[ia];
                    if (inside && ia >= ia0 && ia <= ia1) {
                        float lo, hi;
                        plane_span(k, fmaxf(ent_a[ia], ent_b[jb]), fminf(ext_a[ia], ext_b[jb]), &lo, &hi);
                        float part = fminf(fmaxf(depth - lo, 0.0f), hi - lo);
                        tau += part * g.dt * Sr[ia];
                    }
                    Tr[ia] = expf(-tau);
                }
            }
            if (p->filter && (ra > 0 || rb > 0)) {
                int na_w = wa1 - wa0 + 1;
                for (int jb = wb0; jb <= wb1; jb++) {
                    size_t o = (size_t)jb * (size_t)g.Ka + (size_t)wa0;
                    box_1d(b->T + o, b->tmp + o, na_w, 1, ra);
                }
                for (int ia = wa0; ia <= wa1; ia++) {
                    size_t o = (size_t)wb0 * (size_t)g.Ka + (size_t)ia;
                    box_1d(b->tmp + o, b->T + o, wb1 - wb0 + 1, (size_t)g.Ka, rb);
                }
            }
            /* bilinear lookup at the projected centres (Fig. 4d) */
            for (int jb = 0; jb < gb; jb++) {
                float kb = (((float)jb + 0.5f) * cb - B) * inv_h;
                int y0 = (int)floorf(kb);
                float fy = kb - (float)y0;
                if (y0 < wb0) y0 = wb0, fy = 0.0f;
                if (y0 > wb1) y0 = wb1, fy = 0.0f;
                int y1 = y0 + 1 <= wb1 ? y0 + 1 : y0;
                for (int ja = 0; ja < ga; ja++) {
                    float ka = (((float)ja + 0.5f) * ca - A) * inv_h;
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
        /* W += Δt·σ over the depths plane k stands for */
        for (int jb = ib0; jb <= ib1 && ia0 <= ia1; jb++) {
            float *Wr = b->W + (size_t)jb * (size_t)g.Ka;
            const float *Sr = b->sig + (size_t)jb * (size_t)g.Ka;
            float eb = ent_b[jb], xb = ext_b[jb];
            for (int ia = ia0; ia <= ia1; ia++) {
                float lo, hi;
                plane_span(k, fmaxf(ent_a[ia], eb), fminf(ext_a[ia], xb), &lo, &hi);
                Wr[ia] += g.dt * fmaxf(hi - lo, 0.0f) * Sr[ia];
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
    const guided_vis_params *p;
    const int *dirs;
    size_t ncells, K, side; /* grid cells, largest kernel Ka·Kb and Ka or Kb */
    float *scratch; /* per thread: 4·K + ncells floats */
} job;

static void do_direction(void *user, int64_t index, int thread) {
    job *J = user;
    const guided_vis_params *p = J->p;
    size_t per = 4 * J->K + J->ncells + 4 * J->side;
    float *base = J->scratch + (size_t)thread * per;
    sweep_buffers b = {base, base + J->K, base + 2 * J->K, base + 3 * J->K, base + 4 * J->K,
                       base + 4 * J->K + J->ncells};
    memset(b.acc, 0, J->ncells * sizeof(float));
    int d = J->dirs[index], s = p->oversample;
    float weight = 1.0f / (float)(s * s);
    for (int sv = 0; sv < s; sv++)
        for (int su = 0; su < s; su++) {
            volux_vec3 w = guided_direction(p->dir_res, d, s, su, sv);
            if (p->sweep) sweep_direction(J->v, J->xt, J->lut, J->g, p, w, weight, &b);
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
    job J = {g, v, NULL, lut, p, dirs, (size_t)g->cells[0] * (size_t)g->cells[1] * (size_t)g->cells[2], 0, 0, NULL};
    J.K = p->sweep ? max_kernel(v, p->ray_spacing, &J.side) : 0;
    size_t per = 4 * J.K + J.ncells + 4 * J.side, bytes;
    if (!volux_mul_size(per, (size_t)threads * sizeof(float), &bytes))
        return volux_error(ctx, VOLUX_ERR_LIMIT, "techniques.guided: sweep buffers too large");
    J.scratch = volux_alloc_aligned(ctx, bytes);
    if (!J.scratch) return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory (%zu bytes) for sweep buffers", bytes);
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
            return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for a transposed volume copy");
        }
    }
    J.xt = xt;
    volux_parallel_for(threads, n_dirs, do_direction, &J);
    if (xt) volux_free_aligned(ctx, xt, xt_bytes);
    volux_free_aligned(ctx, J.scratch, bytes);
    return VOLUX_OK;
}
