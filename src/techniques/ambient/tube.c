/* techniques/ambient/tube.c — see tube.h. */
#include <math.h>
#include <string.h>

#include "core/context_internal.h"
#include "core/parallel.h"
#include "tube.h"
#include "tube_simd.h"

static volux_vec3 grid_hi(const scatter_grid *g) {
    return v3(g->lo.x + (float)(g->dims[0] - 1) * g->h[0], g->lo.y + (float)(g->dims[1] - 1) * g->h[1],
              g->lo.z + (float)(g->dims[2] - 1) * g->h[2]);
}

/* Distance from x (in the box) along `back` to the box surface. */
static inline float box_exit(volux_vec3 lo, volux_vec3 hi, volux_vec3 x, volux_vec3 back) {
    float t = INFINITY, xv[3] = {x.x, x.y, x.z}, b[3] = {back.x, back.y, back.z};
    float l[3] = {lo.x, lo.y, lo.z}, h[3] = {hi.x, hi.y, hi.z};
    for (int a = 0; a < 3; a++) {
        float ta = INFINITY;
        if (b[a] > 0.0f) ta = (h[a] - xv[a]) / b[a];
        else if (b[a] < 0.0f) ta = (l[a] - xv[a]) / b[a];
        if (ta < t) t = ta;
    }
    return t > 0.0f ? t : 0.0f;
}

/* A trilinear read of the cache that touches only floor(u) and, if u is
 * fractional, floor(u) + 1 per axis: exactly the nodes the sweep order
 * guarantees. strict_cell finds the cell (index of its lower corner) and
 * the fractions; strict_at reads it. The split lets a phase edit keep the
 * cell and fractions (they do not depend on g) and only re-read. */
static inline int64_t strict_cell(const scatter_grid *g, volux_vec3 p, float f[3]) {
    float u[3] = {(p.x - g->lo.x) * g->inv_h[0], (p.y - g->lo.y) * g->inv_h[1], (p.z - g->lo.z) * g->inv_h[2]};
    int i0[3];
    for (int a = 0; a < 3; a++) {
        float m = (float)(g->dims[a] - 1), x = u[a] < 0.0f ? 0.0f : (u[a] > m ? m : u[a]);
        i0[a] = (int)x;
        f[a] = x - (float)i0[a];
    }
    return ((int64_t)i0[2] * g->dims[1] + i0[1]) * g->dims[0] + i0[0];
}

static inline float strict_at(const scatter_grid *g, int64_t base, const float f[3]) {
    /* u ≤ n − 1, so a fraction > 0 means the upper node exists */
    const float *b = g->v + base;
    size_t ox = f[0] > 0.0f ? 1 : 0, oy = f[1] > 0.0f ? (size_t)g->dims[0] : 0,
           oz = f[2] > 0.0f ? (size_t)g->dims[0] * (size_t)g->dims[1] : 0;
    float c00 = b[0] + (b[ox] - b[0]) * f[0];
    float c10 = b[oy] + (b[oy + ox] - b[oy]) * f[0];
    float c01 = b[oz] + (b[oz + ox] - b[oz]) * f[0];
    float c11 = b[oz + oy] + (b[oz + oy + ox] - b[oz + oy]) * f[0];
    float c0 = c00 + (c10 - c00) * f[1], c1 = c01 + (c11 - c01) * f[1];
    return c0 + (c1 - c0) * f[2];
}

/* Travel direction at x and the distance δ back to the chain start. */
static inline volux_vec3 chain_start(const volux_prepared_light *l, volux_vec3 lo, volux_vec3 hi, volux_vec3 x,
                                     float *delta) {
    volux_vec3 w;
    float dl = INFINITY;
    if (l->positional) {
        volux_vec3 d = v3_sub(x, l->pos);
        dl = v3_length(d);
        if (dl < 1e-20f) {
            *delta = 0.0f;
            return v3(0, 0, 1);
        }
        w = v3_scale(d, 1.0f / dl);
    } else {
        w = l->travel;
    }
    float t = box_exit(lo, hi, x, v3_scale(w, -1.0f));
    *delta = t < dl ? t : dl;
    return w;
}

float tube_step(const tube_input *in, const scatter_grid *V, const volux_prepared_light *l) {
    float hmax = fmaxf(V->h[0], fmaxf(V->h[1], V->h[2]));
    float s = 2.0f * in->radius, smin;
    if (l->positional) {
        smin = 2.0f * 1.7320508f * hmax * 1.0001f;
    } else {
        float w[3] = {fabsf(l->travel.x), fabsf(l->travel.y), fabsf(l->travel.z)}, best = 0.0f;
        for (int a = 0; a < 3; a++)
            if (w[a] * V->inv_h[a] > best) best = w[a] * V->inv_h[a];
        smin = 1.0001f / best;
    }
    return s > smin ? s : smin;
}

typedef struct sweep {
    const tube_input *in;
    const volux_prepared_light *l;
    scatter_grid *V;
    volux_vec3 lo, hi;
    float s, inv_r;
    /* directional: slices along axis a (phase p: the `group` consecutive
     * slices from p·group on, in light order), rows along b2, runs along b1 */
    int a, b1, b2, slice_step, group;
    /* point: phase p's group of shells as runs of nodes (i, j, k, axis,
     * count): (i, j, k) + n·e_axis for n < count, in runs[p & 1] (the next
     * phase's runs are built while this one's finish) */
    int (*runs[2])[5];
    int64_t n_runs[2];
    /* point: the light in grid index units, the first shell that can hold
     * a node (k0 > 0: the light is outside the grid) and the last */
    float P[3];
    int k0, K;
    /* the vector node update and fast path (tube_simd.h), when usable */
    const tube_kernels *simd;
    tube_lanes lanes;
    tube_fast fr;
    /* the g-independent records (tube_geometry): written by a march when
     * present, read back by a re-sum (resum = 1) */
    tube_geometry *geo;
    int resum;
    int vac_bad; /* a march broke the vacuum-chain invariant (tube.h) */
    /* directional fast path (ρ grid aligned with V): constant corner offsets
     * and weights of the two reads, and the box-exit reciprocals */
    int fast;
    ptrdiff_t off_v[8], off_r[8];
    float w_v[8], w_r[8];
    float exit_inv[3], exit_bound[3];
    int exit_use[3];
    int valid_lo[3], valid_hi[3]; /* node indices whose fast-path reads stay in the grid */
    unsigned char *fast_ok[3];    /* per axis and index: its box-exit term of y passes */
    int fast_lo, fast_hi;         /* the b1 indices (within the valid range) that pass */
} sweep;

/* D at node (i, j, k). The κ argument of the sphere towards the light is
 * computed (and stored to *arg_out if given), or taken from *arg_in (a
 * re-sum). */
static inline float node_value(const sweep *sw, int i, int j, int k, const float *arg_in, float *arg_out) {
    const tube_input *in = sw->in;
    float arg_in_abs;
    volux_vec3 x = scatter_grid_node(sw->V, i, j, k);
    float delta, arg, v;
    int deep = 0;
    volux_vec3 w = chain_start(sw->l, sw->lo, sw->hi, x, &delta);
    if (arg_in) arg_in_abs = fabsf(*arg_in), arg_in = &arg_in_abs;
    if (delta <= sw->s * 1.0001f) {
        /* Eq. 17 between the chain start (D = 0) and the first node a full
         * step on (D = κ of a sphere of radius s/2): D = (δ/s)·κ. Linear
         * in δ, so a homogeneous medium gives D exactly linear along every
         * chain and the sweep's interpolation exact. */
        arg = arg_in ? *arg_in : scatter_grid_sample(in->rho, v3_madd(x, w, -0.5f * delta)) * 0.5f * sw->s * sw->inv_r;
        v = delta / sw->s * tube_kappa(in, arg);
    } else {
        /* Eq. 16 (as D = −ln V): the front from s back, through the
         * sphere between. */
        float half = 0.5f * sw->s, dy = delta - sw->s, back;
        arg = arg_in ? *arg_in : scatter_grid_sample(in->rho, v3_madd(x, w, -half)) * half * sw->inv_r;
        volux_vec3 y = v3_madd(x, w, -sw->s);
        if (dy <= sw->s) {
            /* y is within the first step: evaluate it exactly rather than
             * interpolate the kink at the chain start (a cone around a
             * point light inside the volume). */
            float rho_y = scatter_grid_sample(in->rho, v3_madd(y, w, -0.5f * dy));
            back = dy / sw->s * tube_kappa(in, rho_y * half * sw->inv_r);
        } else {
            float f[3];
            int64_t cell = strict_cell(sw->V, y, f);
            back = strict_at(sw->V, cell, f);
            deep = 1;
        }
        v = back + tube_kappa(in, arg);
    }
    /* deep nodes carry the sign bit (tube.h) */
    if (arg_out) *arg_out = deep ? copysignf(arg, -1.0f) : arg;
    return v;
}

/* Where node (i, j, k)'s record is kept. Directional sweeps keep them in
 * sweep order (slice, row, node along the row), so that a re-sum streams
 * them: the rows of a slice normal to y or x are far apart in the cache's
 * own layout, and a re-sum (which reads little else from memory) then
 * waited on a cache miss at every row. Point sweeps walk rows of x or y
 * in memory order already. */
static inline size_t rec_index(const sweep *sw, int i, int j, int k, ptrdiff_t *stride_b1) {
    const int *d = sw->V->dims;
    if (sw->l->positional) {
        if (stride_b1) *stride_b1 = 1;
        return ((size_t)k * (size_t)d[1] + (size_t)j) * (size_t)d[0] + (size_t)i;
    }
    int idx[3] = {i, j, k}, t = sw->slice_step > 0 ? idx[sw->a] : d[sw->a] - 1 - idx[sw->a];
    if (stride_b1) *stride_b1 = 1;
    return ((size_t)t * (size_t)d[sw->b2] + (size_t)idx[sw->b2]) * (size_t)d[sw->b1] + (size_t)idx[sw->b1];
}

static inline void node(const sweep *sw, int i, int j, int k) {
    scatter_grid *V = sw->V;
    size_t at = ((size_t)k * (size_t)V->dims[1] + (size_t)j) * (size_t)V->dims[0] + (size_t)i;
    float *rec = sw->geo ? sw->geo->arg + rec_index(sw, i, j, k, NULL) : NULL;
    V->v[at] = node_value(sw, i, j, k, sw->resum ? rec : NULL, sw->resum ? NULL : rec);
}

/* The nodes start + n·e_axis, n ∈ [0, count): 16 or 8 at a time where the
 * CPU allows (bit-identical to `node`, tube_simd.h), else one by one. */
static void nodes(const sweep *sw, const int start[3], int axis, int count) {
    if (count <= 0) return;
    if (sw->simd) {
        /* record stride along the run: 1 along a directional row (b1) or
         * along x; a point sweep's columns along y: n_x */
        ptrdiff_t rs = 1;
        size_t r0 = rec_index(sw, start[0], start[1], start[2], &rs);
        if (sw->l->positional && axis != 0) rs = axis == 1 ? sw->V->dims[0] : (ptrdiff_t)sw->V->dims[0] * sw->V->dims[1];
        sw->simd->nodes(&sw->lanes, start[0], start[1], start[2], axis, count, r0, rs);
        return;
    }
    int idx[3] = {start[0], start[1], start[2]};
    for (int n = 0; n < count; n++, idx[axis]++) node(sw, idx[0], idx[1], idx[2]);
}

/* The fast path over a run of `count` nodes of one row that are contiguous
 * in memory (stride 1), from node index `at`: loads at constant offsets,
 * vectorisable. The written slice and the read slices of D are disjoint
 * (every read lies in an earlier slice). The κ-table coordinate u of each
 * node is its g-independent record (tube_geometry): stored by a march, read by
 * a re-sum. */
static void fast_run(const sweep *sw, size_t at, int count) {
    float *out = sw->V->v + at;
    const float *D = sw->V->v + at, *R = sw->in->rho->v + at;
    int idx[3] = {(int)(at % (size_t)sw->V->dims[0]), (int)(at / (size_t)sw->V->dims[0] % (size_t)sw->V->dims[1]),
                  (int)(at / ((size_t)sw->V->dims[0] * (size_t)sw->V->dims[1]))};
    float *geo_u = sw->geo ? sw->geo->arg + rec_index(sw, idx[0], idx[1], idx[2], NULL) : NULL;
    /* locals, so the loop does not reload them through `sw` (which could alias out) */
    const ptrdiff_t v0 = sw->off_v[0], v1 = sw->off_v[1], v2 = sw->off_v[2], v3 = sw->off_v[3], v4 = sw->off_v[4],
                    v5 = sw->off_v[5], v6 = sw->off_v[6], v7 = sw->off_v[7];
    const ptrdiff_t r0 = sw->off_r[0], r1 = sw->off_r[1], r2 = sw->off_r[2], r3 = sw->off_r[3], r4 = sw->off_r[4],
                    r5 = sw->off_r[5], r6 = sw->off_r[6], r7 = sw->off_r[7];
    const float a0 = sw->w_v[0], a1 = sw->w_v[1], a2 = sw->w_v[2], a3 = sw->w_v[3], a4 = sw->w_v[4],
                a5 = sw->w_v[5], a6 = sw->w_v[6], a7 = sw->w_v[7];
    const float b0 = sw->w_r[0], b1 = sw->w_r[1], b2 = sw->w_r[2], b3 = sw->w_r[3], b4 = sw->w_r[4],
                b5 = sw->w_r[5], b6 = sw->w_r[6], b7 = sw->w_r[7];
    const float *restrict kappa = sw->in->kappa;
    const float kscale = sw->fr.kscale, last = sw->fr.last;
    float back[256], u[256];
    int done = 0;
    if (sw->simd) {
        done = count; /* masked tail */
        sw->simd->fast_run(&sw->fr, out, D, R, geo_u, sw->lanes.vac ? sw->lanes.vac + at : NULL, sw->resum, done);
    }
    for (int i0 = done; i0 < count; i0 += 256) {
        int m = count - i0 < 256 ? count - i0 : 256;
        const float *d = D + i0, *r = R + i0;
        /* vectorisable part: 16 loads at constant offsets */
        for (int i = 0; i < m; i++)
            back[i] = a0 * d[i + v0] + a1 * d[i + v1] + a2 * d[i + v2] + a3 * d[i + v3] + a4 * d[i + v4] +
                      a5 * d[i + v5] + a6 * d[i + v6] + a7 * d[i + v7];
        if (sw->resum) {
            memcpy(u, geo_u + i0, (size_t)m * sizeof *u);
        } else {
            for (int i = 0; i < m; i++) {
                float x = (b0 * r[i + r0] + b1 * r[i + r1] + b2 * r[i + r2] + b3 * r[i + r3] + b4 * r[i + r4] +
                           b5 * r[i + r5] + b6 * r[i + r6] + b7 * r[i + r7]) *
                          kscale;
                u[i] = 0.5f * (x + last - fabsf(x - last)); /* min(x, last); ρ ≥ 0 */
            }
            if (geo_u) memcpy(geo_u + i0, u, (size_t)m * sizeof *u);
        }
        /* the κ table look-up is a gather: scalar */
        for (int i = 0; i < m; i++) {
            int j = (int)u[i];
            float f = u[i] - (float)j;
            out[i0 + i] = back[i] + kappa[j] + (kappa[j + 1] - kappa[j]) * f;
        }
    }
}

static void slice_row(void *user, int phase, int64_t item, int thread) {
    (void)thread;
    const sweep *sw = user;
    scatter_grid *V = sw->V;
    int idx[3], n = V->dims[sw->b1], rows = V->dims[sw->b2];
    /* item → (slice of the group, row); slices run in light order */
    int g = (int)(item / rows), r = (int)(item % rows), t = phase * sw->group + g;
    idx[sw->a] = sw->slice_step > 0 ? t : V->dims[sw->a] - 1 - t;
    idx[sw->b2] = r;
    int c0 = n, c1 = -1;
    /* Nodes whose y = x − sω is more than a step from the chain start
     * (the generic path would interpolate there too) and whose reads stay
     * inside the grids: δ of y > s is a min over the axes of box-exit
     * terms that each depend on one index (fast_ok, per axis), so the
     * fast nodes of a row are the b1 interval [fast_lo, fast_hi] if the
     * row's own a and b2 terms pass. */
    if (sw->fast && idx[sw->a] >= sw->valid_lo[sw->a] && idx[sw->a] <= sw->valid_hi[sw->a] &&
        idx[sw->b2] >= sw->valid_lo[sw->b2] && idx[sw->b2] <= sw->valid_hi[sw->b2] && sw->fast_ok[sw->a][idx[sw->a]] &&
        sw->fast_ok[sw->b2][idx[sw->b2]])
        c0 = sw->fast_lo, c1 = sw->fast_hi;
    if (sw->simd && sw->b1 == 0) {
        /* the whole row in one call of the vector code */
        size_t rec0 = sw->geo ? rec_index(sw, 0, idx[1], idx[2], NULL) : 0;
        sw->simd->row(&sw->lanes, &sw->fr, idx[1], idx[2], n, c0, c1, rec0, sw->resum);
        return;
    }
    /* nodes before the fast run, the fast run, nodes after it */
    int f0 = c1 >= c0 ? c0 : n, f1 = c1 >= c0 ? c1 + 1 : n;
    idx[sw->b1] = 0;
    nodes(sw, idx, sw->b1, f0);
    if (f1 > f0) {
        idx[sw->b1] = c0;
        size_t at = ((size_t)idx[2] * (size_t)V->dims[1] + (size_t)idx[1]) * (size_t)V->dims[0] + (size_t)idx[0];
        if (sw->b1 == 0) {
            fast_run(sw, at, c1 - c0 + 1);
        } else {
            for (int cc = c0; cc <= c1; cc++) {
                idx[sw->b1] = cc;
                fast_run(sw, ((size_t)idx[2] * (size_t)V->dims[1] + (size_t)idx[1]) * (size_t)V->dims[0] + (size_t)idx[0],
                         1);
            }
        }
    }
    idx[sw->b1] = f1;
    nodes(sw, idx, sw->b1, n - f1);
}

/* Corner offsets/weights of a trilinear read displaced by `d` (world) from
 * any node of grid g; a zero fraction reads one corner only (never the node
 * beyond, which may be in the slice being written). Narrows [lo, hi] to the
 * node indices whose corners stay inside the grid. */
static void displaced_corners(const scatter_grid *g, volux_vec3 d, ptrdiff_t off[8], float w[8], int lo[3],
                              int hi[3]) {
    float u[3] = {d.x * g->inv_h[0], d.y * g->inv_h[1], d.z * g->inv_h[2]}, f[3];
    ptrdiff_t base[3], step[3] = {1, g->dims[0], (ptrdiff_t)g->dims[0] * g->dims[1]};
    for (int a = 0; a < 3; a++) {
        float fl = floorf(u[a]);
        base[a] = (ptrdiff_t)fl;
        f[a] = u[a] - fl;
        int l = (int)-base[a], h = g->dims[a] - 1 - (int)base[a] - (f[a] > 0.0f ? 1 : 0);
        if (l > lo[a]) lo[a] = l;
        if (h < hi[a]) hi[a] = h;
    }
    for (int c = 0; c < 8; c++) {
        ptrdiff_t o = 0;
        float wc = 1.0f;
        for (int a = 0; a < 3; a++) {
            int up = (c >> a) & 1;
            wc *= up ? f[a] : 1.0f - f[a];
            o += (base[a] + (up && f[a] > 0.0f ? 1 : 0)) * step[a];
        }
        off[c] = o;
        w[c] = wc;
    }
}

/* Runs per parallel item of a point sweep: the vector kernels take a batch
 * in one call (tube_kernels.runs). */
enum { RUNS_PER_ITEM = 8 };

static void shell_run(void *user, int phase, int64_t item, int thread) {
    (void)thread;
    const sweep *sw = user;
    int (*runs)[5] = sw->runs[phase & 1];
    int64_t n_runs = sw->n_runs[phase & 1];
    int64_t r0 = item * RUNS_PER_ITEM, r1 = r0 + RUNS_PER_ITEM < n_runs ? r0 + RUNS_PER_ITEM : n_runs;
    if (sw->simd) {
        sw->simd->runs(&sw->lanes, (const int(*)[5])runs + r0, (int)(r1 - r0));
    } else {
        for (int64_t r = r0; r < r1; r++) nodes(sw, runs[r], runs[r][3], runs[r][4]);
    }
}

/* Appends the runs of shell k (nodes with k ≤ max_a |i_a − P_a| < k + 1)
 * to sw->runs[buf]: the outer box minus the inner box. Rows along x cover the
 * faces normal to z and y; the faces normal to x (one node thick) are
 * cut into columns along y, so no run is a single node and the 8-wide
 * update stays busy. */
static void shell_runs(sweep *sw, int buf, const float P[3], int k) {
    int olo[3], ohi[3], ilo[3], ihi[3];
    for (int a = 0; a < 3; a++) {
        int m = sw->V->dims[a] - 1;
        int lo = (int)floorf(P[a] - (float)k - 1.0f) + 1, hi = (int)ceilf(P[a] + (float)k + 1.0f) - 1;
        int il = (int)floorf(P[a] - (float)k) + 1, ih = (int)ceilf(P[a] + (float)k) - 1;
        olo[a] = lo < 0 ? 0 : lo;
        ohi[a] = hi > m ? m : hi;
        ilo[a] = il < 0 ? 0 : il;
        ihi[a] = ih > m ? m : ih;
        if (olo[a] > ohi[a]) return;
    }
    int (*r)[5] = sw->runs[buf] + sw->n_runs[buf];
#define RUN_(X, Y, Z, AXIS, N) (r[0][0] = (X), r[0][1] = (Y), r[0][2] = (Z), r[0][3] = (AXIS), r[0][4] = (N), r++)
    for (int z = olo[2]; z <= ohi[2]; z++) {
        int hollow = z >= ilo[2] && z <= ihi[2] && ilo[0] <= ihi[0] && ilo[1] <= ihi[1];
        /* rows: all of them, or (hollow) those below and above the inner
         * box — not a test per row: a shell of a light outside the grid
         * spans the grid, and testing every row of every shell was 5 % of
         * a sweep */
        int y_skip = hollow ? ilo[1] : ohi[1] + 1, y_resume = hollow ? ihi[1] + 1 : ohi[1] + 1;
        for (int y = olo[1]; y < y_skip; y++) RUN_(olo[0], y, z, 0, ohi[0] - olo[0] + 1);
        for (int y = y_resume; y <= ohi[1]; y++) RUN_(olo[0], y, z, 0, ohi[0] - olo[0] + 1);
        if (hollow) {
            for (int x = olo[0]; x < ilo[0]; x++) RUN_(x, ilo[1], z, 1, ihi[1] - ilo[1] + 1);
            for (int x = ihi[0] + 1; x <= ohi[0]; x++) RUN_(x, ilo[1], z, 1, ihi[1] - ilo[1] + 1);
        }
    }
#undef RUN_
    sw->n_runs[buf] = r - sw->runs[buf];
}

const tube_kernels *tube_kernels_for(int kernel_cap) {
    /* AVX2, or AVX-512F where the CPU has both (all three paths are
     * bit-identical) */
    const tube_kernels *k = kernel_cap != TUBE_KERNEL_SCALAR ? tube_kernels_avx2() : NULL;
    if (k && kernel_cap == TUBE_KERNEL_BEST && tube_kernels_avx512()) k = tube_kernels_avx512();
    return k;
}

/* The vector update needs ρ on V's nodes, every dimension ≥ 2 and
 * 32-bit node indices. */
static void setup_lanes(sweep *sw) {
    const tube_input *in = sw->in;
    const scatter_grid *V = sw->V, *R = in->rho;
    sw->simd = in->n_sigma >= 2 ? tube_kernels_for(in->kernel_cap) : NULL;
    for (int a = 0; a < 3; a++)
        if (R->dims[a] != V->dims[a] || V->dims[a] < 2 || R->inv_h[a] != V->inv_h[a]) sw->simd = NULL;
    if (R->lo.x != V->lo.x || R->lo.y != V->lo.y || R->lo.z != V->lo.z) sw->simd = NULL;
    if ((double)V->dims[0] * V->dims[1] * V->dims[2] >= 2147483647.0) sw->simd = NULL;
    if (!sw->simd) return;
    tube_lanes *t = &sw->lanes;
    t->rho = R->v, t->D = V->v;
    float lo[3] = {sw->lo.x, sw->lo.y, sw->lo.z}, hi[3] = {sw->hi.x, sw->hi.y, sw->hi.z};
    for (int a = 0; a < 3; a++) {
        t->dims[a] = V->dims[a];
        t->lo[a] = lo[a], t->hi[a] = hi[a], t->h[a] = V->h[a], t->inv_h[a] = V->inv_h[a];
    }
    t->positional = sw->l->positional;
    t->pos[0] = sw->l->pos.x, t->pos[1] = sw->l->pos.y, t->pos[2] = sw->l->pos.z;
    t->dir[0] = sw->l->travel.x, t->dir[1] = sw->l->travel.y, t->dir[2] = sw->l->travel.z;
    t->s = sw->s, t->inv_r = sw->inv_r;
    t->kappa = in->kappa, t->n_sigma = in->n_sigma, t->sigma_max = in->sigma_max;
    t->g_arg = sw->geo ? sw->geo->arg : NULL;
    t->resum = sw->resum;
    /* vacuum chains: AVX-512 only (tube_geometry); a re-sum needs κ(0) =
     * +0, as the march's invariant assumes */
    uint32_t k0;
    memcpy(&k0, in->kappa, sizeof k0);
    int use_vac = sw->simd->vacuum_chains && sw->geo && (!sw->resum || (sw->geo->vac_ok && k0 == 0));
    t->vac = use_vac ? sw->geo->vac : NULL;
    t->vac_bad = &sw->vac_bad;
    sw->fr.vac_bad = &sw->vac_bad;
}

/* After a march that recorded geometry: are its vacuum chains usable? */
static void vac_finish(sweep *sw) {
    if (sw->geo && !sw->resum) sw->geo->vac_ok = sw->lanes.vac != NULL && !__atomic_load_n(&sw->vac_bad, __ATOMIC_RELAXED);
}

/* Phase p of the directional sweep: `group` slices from p·group on. */
static int64_t slice_group(void *user, int p) {
    const sweep *sw = user;
    int n = sw->V->dims[sw->a], t = p * sw->group, m = n - t < sw->group ? n - t : sw->group;
    return (int64_t)m * sw->V->dims[sw->b2];
}

/* Phase p of the point sweep: the runs of `group` shells from k0 + p·group
 * on, into runs[p & 1] (volux_parallel_phases_overlapped builds them while phase
 * p − 1's last items run). */
static int64_t shell_group(void *user, int p) {
    sweep *sw = user;
    int k = sw->k0 + p * sw->group, buf = p & 1;
    sw->n_runs[buf] = 0;
    for (int j = k; j < k + sw->group && j <= sw->K; j++) shell_runs(sw, buf, sw->P, j);
    return (sw->n_runs[buf] + RUNS_PER_ITEM - 1) / RUNS_PER_ITEM;
}

/* A march (resum = 0: records into geo if given) or a re-sum (resum = 1:
 * from geo) of light l into V. */
static volux_status sweep_run(volux_context *ctx, const tube_input *in, const volux_prepared_light *l, scatter_grid *V,
                              tube_geometry *geo, int resum) {
    sweep sw;
    memset(&sw, 0, sizeof sw);
    sw.in = in, sw.l = l, sw.V = V;
    sw.geo = geo, sw.resum = resum;
    size_t ok_bytes = 0;
    sw.lo = V->lo, sw.hi = grid_hi(V);
    sw.s = tube_step(in, V, l);
    sw.inv_r = in->radius > 0.0f ? 1.0f / in->radius : 0.0f;
    setup_lanes(&sw);
    if (!l->positional) {
        float w[3] = {l->travel.x, l->travel.y, l->travel.z}, best = -1.0f;
        for (int a = 0; a < 3; a++)
            if (fabsf(w[a]) * V->inv_h[a] > best) best = fabsf(w[a]) * V->inv_h[a], sw.a = a;
        sw.b1 = sw.a == 0 ? 1 : 0;
        sw.b2 = sw.a == 2 ? 1 : 2;
        const scatter_grid *R = in->rho;
        sw.fast = R->dims[0] == V->dims[0] && R->dims[1] == V->dims[1] && R->dims[2] == V->dims[2] &&
                  R->lo.x == V->lo.x && R->lo.y == V->lo.y && R->lo.z == V->lo.z;
        if (sw.fast) {
            for (int a = 0; a < 3; a++) sw.valid_lo[a] = 0, sw.valid_hi[a] = V->dims[a] - 1;
            displaced_corners(V, v3_scale(l->travel, -sw.s), sw.off_v, sw.w_v, sw.valid_lo, sw.valid_hi);
            displaced_corners(R, v3_scale(l->travel, -0.5f * sw.s), sw.off_r, sw.w_r, sw.valid_lo, sw.valid_hi);
            memcpy(sw.fr.off_v, sw.off_v, sizeof sw.off_v);
            memcpy(sw.fr.off_r, sw.off_r, sizeof sw.off_r);
            memcpy(sw.fr.w_v, sw.w_v, sizeof sw.w_v);
            memcpy(sw.fr.w_r, sw.w_r, sizeof sw.w_r);
            /* as fast_run computes them */
            sw.fr.kscale = 0.5f * sw.s * sw.inv_r * (float)(in->n_sigma - 1) / in->sigma_max;
            sw.fr.last = (float)(in->n_sigma - 1) - 1e-3f;
            sw.fr.kappa = in->kappa;
            float lo[3] = {sw.lo.x, sw.lo.y, sw.lo.z}, hi[3] = {sw.hi.x, sw.hi.y, sw.hi.z};
            for (int a = 0; a < 3; a++) {
                /* walking back along −ω towards the light */
                sw.exit_use[a] = w[a] != 0.0f;
                sw.exit_inv[a] = w[a] != 0.0f ? -1.0f / w[a] : 0.0f;
                sw.exit_bound[a] = w[a] < 0.0f ? hi[a] : lo[a];
            }
            /* δ of y > s ⟺ every axis' term (exit_bound − x)·exit_inv > 2s
             * (a min of terms, each of one index) */
            ok_bytes = (size_t)V->dims[0] + (size_t)V->dims[1] + (size_t)V->dims[2];
            unsigned char *ok = volux_malloc(ctx, ok_bytes);
            if (!ok) return volux_error(ctx, VOLUX_ERR_NOMEM, "ambient: out of memory for tube marching");
            float need = 2.0f * sw.s * 1.0001f, vlo[3] = {V->lo.x, V->lo.y, V->lo.z};
            for (int a = 0; a < 3; a++) {
                sw.fast_ok[a] = ok;
                for (int i = 0; i < V->dims[a]; i++)
                    ok[i] = !sw.exit_use[a] || (sw.exit_bound[a] - (vlo[a] + (float)i * V->h[a])) * sw.exit_inv[a] > need;
                ok += V->dims[a];
            }
            sw.fast_lo = V->dims[sw.b1], sw.fast_hi = -1;
            for (int c = sw.valid_lo[sw.b1]; c <= sw.valid_hi[sw.b1]; c++)
                if (sw.fast_ok[sw.b1][c]) {
                    if (c < sw.fast_lo) sw.fast_lo = c;
                    sw.fast_hi = c;
                }
        }
        /* Every read lies ≥ s·|ω_a|/h_a slices back, so that many
         * consecutive slices are independent: one parallel region (one
         * barrier) per group instead of per slice. */
        int n = V->dims[sw.a], group = (int)floorf(sw.s * fabsf(w[sw.a]) * V->inv_h[sw.a] * 0.9999f);
        if (group < 1) group = 1;
        sw.slice_step = w[sw.a] >= 0.0f ? 1 : -1;
        sw.group = group;
        volux_parallel_phases_overlapped(in->threads, (n + group - 1) / group, slice_group, slice_row, &sw);
        if (sw.fast) volux_free(ctx, sw.fast_ok[0], ok_bytes);
        vac_finish(&sw);
        return VOLUX_OK;
    }
    float P[3] = {(l->pos.x - V->lo.x) * V->inv_h[0], (l->pos.y - V->lo.y) * V->inv_h[1],
                  (l->pos.z - V->lo.z) * V->inv_h[2]};
    /* a node's shell is floor of its Chebyshev distance to P, which is at
     * least the largest per-axis distance from P to the grid, dmin */
    float dmax = 0.0f, dmin = 0.0f;
    for (int a = 0; a < 3; a++) {
        float m = (float)(V->dims[a] - 1);
        float d = fmaxf(fabsf(P[a]), fabsf(m - P[a])), e = fmaxf(fmaxf(-P[a], P[a] - m), 0.0f);
        if (d > dmax) dmax = d;
        if (e > dmin) dmin = e;
    }
    int K = (int)floorf(dmax), k0 = (int)floorf(dmin) - 1;
    if (k0 < 0) k0 = 0;
    /* Reads lie ≥ s/(√3 h_max) − 1 shells back (see tube_step), so that
     * many consecutive shells are independent: one parallel region per
     * group. The runs of a group (rows of the shells' faces and rings)
     * balance across threads. */
    float hmax = fmaxf(V->h[0], fmaxf(V->h[1], V->h[2]));
    int group = (int)floorf(sw.s / (1.7320508f * hmax) * 0.9999f) - 1;
    if (group < 1) group = 1;
    /* per shell at most one row per (z, y) and two columns per z; two
     * buffers (shell_group) */
    size_t bytes = sizeof *sw.runs[0] * ((size_t)V->dims[1] + 2) * (size_t)V->dims[2] * (size_t)group;
    sw.runs[0] = volux_malloc(ctx, 2 * bytes);
    if (!sw.runs[0]) return volux_error(ctx, VOLUX_ERR_NOMEM, "ambient: out of memory for tube marching");
    sw.runs[1] = sw.runs[0] + bytes / sizeof *sw.runs[0];
    memcpy(sw.P, P, sizeof P);
    sw.k0 = k0, sw.K = K;
    sw.group = group;
    volux_parallel_phases_overlapped(in->threads, (K - k0) / group + 1, shell_group, shell_run, &sw);
    volux_free(ctx, sw.runs[0], 2 * bytes);
    vac_finish(&sw);
    return VOLUX_OK;
}

volux_status tube_march(volux_context *ctx, const tube_input *in, const volux_prepared_light *l, scatter_grid *V) {
    return sweep_run(ctx, in, l, V, in->geo, 0);
}


volux_status tube_resum(volux_context *ctx, const tube_input *in, const volux_prepared_light *l, scatter_grid *V) {
    if (!in->geo || in->geo->n != (size_t)V->dims[0] * (size_t)V->dims[1] * (size_t)V->dims[2])
        return volux_error(ctx, VOLUX_ERR_INVALID, "ambient: re-sum of a radiance cache without its geometry");
    return sweep_run(ctx, in, l, V, in->geo, 1);
}

/* vac is read 16 bytes at a time (the AVX-512 re-sum): padding past the
 * last node */
enum { VAC_PAD = 16 };

volux_status tube_geometry_alloc(volux_context *ctx, size_t n, tube_geometry *g) {
    if (g->arg && g->n == n) return VOLUX_OK;
    tube_geometry_free(ctx, g);
    size_t bytes;
    if (!volux_mul_size(n, sizeof(float) + 1, &bytes) || (bytes += VAC_PAD) > volux_context_max_bytes(ctx))
        return volux_error(ctx, VOLUX_ERR_LIMIT, "ambient: radiance cache geometry of %zu nodes exceeds the limits", n);
    g->arg = volux_alloc_aligned(ctx, n * sizeof(float));
    g->vac = g->arg ? volux_alloc_aligned(ctx, n + VAC_PAD) : NULL;
    if (!g->vac) {
        if (g->arg) volux_free_aligned(ctx, g->arg, n * sizeof(float));
        g->arg = NULL;
        return volux_error(ctx, VOLUX_ERR_NOMEM, "ambient: out of memory for the radiance cache geometry");
    }
    g->n = n, g->bytes = bytes, g->vac_ok = 0;
    return VOLUX_OK;
}

void tube_geometry_free(volux_context *ctx, tube_geometry *g) {
    if (g->arg) volux_free_aligned(ctx, g->arg, g->n * sizeof(float));
    if (g->vac) volux_free_aligned(ctx, g->vac, g->n + VAC_PAD);
    memset(g, 0, sizeof *g);
}

float tube_chain(const tube_input *in, const volux_prepared_light *l, const scatter_grid *V, volux_vec3 x) {
    volux_vec3 lo = V->lo, hi = grid_hi(V);
    float s = tube_step(in, V, l), inv_r = in->radius > 0.0f ? 1.0f / in->radius : 0.0f, delta;
    volux_vec3 w = chain_start(l, lo, hi, x, &delta);
    float sum = 0.0f;
    while (delta > s * 1.0001f) {
        float rho = scatter_grid_sample(in->rho, v3_madd(x, w, -0.5f * s));
        sum += tube_kappa(in, rho * 0.5f * s * inv_r);
        x = v3_madd(x, w, -s);
        delta -= s;
    }
    float rho = scatter_grid_sample(in->rho, v3_madd(x, w, -0.5f * delta));
    return expf(-(sum + delta / s * tube_kappa(in, rho * 0.5f * s * inv_r)));
}
