/*
 * techniques/lightvol/sweep.h — the state of one propagation pass (group,
 * lights, slice buffers, medium slices), shared by the portable propagation
 * files and the AVX2 kernels (propagate_avx2.c); and what the propagation
 * files share among themselves: the light values, the scratch layout, the
 * pass plan and the functions one file calls in another.
 *
 * The propagation files, one concern each:
 *   buffers.c   illumination volume and propagation scratch (allocation, free)
 *   medium.c    the medium the sweeps see (classification, box means)
 *   sources.c   lv_source from a light, unoccluded value, positional groups
 *   plan.c      pass planning and the cost model of §5 (work weights)
 *   rows.h      the per-voxel helpers of the row loops (static inline)
 *   rows_dir.c  one directional light's row
 *   rows_pos.c  one positional (point, spot, sphere) light's row
 *   sweep.c     the sweep driver: pass setup, slice phases, rows → volume
 *   update.c    selective / entire light updates (cost rule, re-baseline)
 *
 * Internal to the technique.
 */
#ifndef VOLUX_LIGHTVOL_SWEEP_H
#define VOLUX_LIGHTVOL_SWEEP_H

#include <math.h>

#include "core/vecmath.h"
#include "lightvol.h"

enum { E_SKIP, E_INIT, E_INIT_ATT, E_PROP };

/* Sub-samples of the medium along one propagation segment: one per voxel of
 * sideways travel, so an oblique sweep (a light's second-closest group)
 * cannot step over a thin wall. */
#define LV_MAX_SUB 16
/* ... and along the segment light → voxel of the first slice after a light
 * that lies between two slices (integrated once per pass). */
#define LV_MAX_INIT_SUB 256

typedef struct lv_tap {
    int di, dj;
    float w00, w10, w01, w11;
} lv_tap;

typedef struct lv_entry {
    const lv_source *s;
    /* Channels its slice buffers carry. Without forward scattering the
     * attenuation is achromatic, so a light's value is its power times a
     * scalar: the AVX2 path then propagates that scalar alone (nch = 1,
     * s → `norm`, a copy with unit power) and scales by `gain` = the power
     * when accumulating; otherwise nch = 3 and gain = 1. */
    int nch;
    float gain[3];
    lv_source norm;
    float sign;
    float sw;           /* directional: sign·factor                       */
    volux_vec3 dsw;     /* directional: sign·factor·direction             */
    float *rd[3], *wr[3];
    int mode;
    /* directional, fixed for the pass */
    float du, dv, len;  /* previous-slice offset (index units), length    */
    float cu[4], cv[4]; /* cone tap offsets                               */
    lv_tap tc, tcone[4];
    int nsub;
    float su[LV_MAX_SUB], sv[LV_MAX_SUB]; /* medium sample offsets       */
    float wp[LV_MAX_SUB], wc[LV_MAX_SUB]; /* their weights (prev / current
                                             slice) × len / nsub          */
    lv_tap ts[LV_MAX_SUB];
    int di_min, di_max, dj_min, dj_max;   /* tap extents (interior test)   */
    /* the centre and cone taps as one stencil on the previous slice (their
     * footprints overlap: ≤ 3×3 nodes when the cone is narrower than a
     * voxel): nst nodes (sj, si) relative to the voxel, the first 4 with
     * the centre's weights swc, all with the cone's (¼ Σ of its taps) swk;
     * nst = 0: no such stencil (the AVX2 kernel reads the taps one by one) */
    int nst;
    int sj[9], si[9];
    float swc[4], swk[9];
    /* positional */
    float lidx[3];      /* light position in illumination index space     */
    float f;            /* 1/dist for the current slice                   */
    /* positional grouped by the centre direction (lv_source.center): the
     * factor of this pass's group, and the other group's axis among the
     * slice's (1: u, 2: v, 0: none), sign and light coordinate, so that a
     * voxel the other group cannot reach takes the whole light here */
    float cw;
    int oax, osg;
    float ol;
} lv_entry;

typedef struct lv_sweep {
    lightvol_state *st;
    int g, a, au, av, s;
    int mu, mv, ma;
    int k, kp, step;
    size_t vs[3];       /* illumination strides (voxels) per axis         */
    lv_entry *e;
    int ne;
    const float *mp;    /* medium of the previous slice: σt, κr, κg, κb planes */
    float *mc;          /* medium of the current slice                     */
    float *mn;          /* medium of the next slice (classified meanwhile) */
    int kn;             /* next slice, or −1                               */
    float *med[3];      /* the three rotating medium slice buffers          */
    int chunks;         /* work items (row chunks) per slice               */
    int rows_per_item, sweep_items, class_items;
    int defer;          /* x sweeps: slices staged before a flush (0: none) */
    int first, last;    /* the steps of this call (a budget, §7.3)         */
    int phase0;         /* phase of the call's first step's classification */
    size_t area;
    int overwrite;
    int forward, cone;
    int nplanes;        /* medium planes propagation reads: 1 (σt) or 4    */
    int post;           /* slices hold scalars (post-classification)       */
    const volux_transfer_lut *lut;
    float albedo;
    float fwd, tan_c;   /* f, tan(cone)/√2                                 */
    float rmin2;
    int simd;           /* run the AVX2 kernels (propagate_avx2.c)        */
    int avx512;         /* ... with the 16-wide directional light steps   */
} lv_sweep;

/* One row of a positional light's propagation (volux_lightvol_pos_row): per-voxel arrays
 * (stride ms) and the row's constants. */
typedef struct lv_pos_row {
    int v, u0, u1;          /* row; interior [u0, u1) (every tap inside)    */
    size_t ms;              /* array stride (≥ mu, a multiple of 8 for SIMD) */
    float *X, *LEN, *K;     /* previous-slice u, segment length, sign·factor/r² */
    float *WA, *WU, *WV;    /* unit direction along a, au, av                */
    float *TAU;             /* optical depths: σt, κr, κg, κb (stride ms)    */
    float y;                /* previous-slice row (the same for the row)     */
    int n;                  /* medium sub-samples along the segments         */
    float inv_n, tt[LV_MAX_SUB], ay[LV_MAX_SUB];
    int jrow[LV_MAX_SUB];
    int jc;                 /* light fetch: row jc, weight ayc               */
    float ayc;
    int empty;              /* no medium in the footprint: T = 1             */
} lv_pos_row;

/* ------------------------------------------------------- AVX2 kernels
 * propagate_avx2.c; chosen at run time (techniques.lightvol.kernel). Each
 * computes the same quantity as the portable loop it replaces, over the
 * interior range [u0, u1) of a row where every tap lies inside the slice
 * (the row ends stay on the portable path); results differ from it by
 * float rounding only (FMA, polynomial order), bounded by the tests. */

/* 1 if this CPU runs the AVX2+FMA kernels; ... and AVX-512F as well (the
 * directional light kernel then takes 16 voxels a step in row interiors). */
int volux_lightvol_simd_available(void);
int volux_lightvol_avx512_available(void);

/* Directional entry e, row v: optical depths over its segments (σt into
 * tau[0], κ_c into tau[1..3] when forward scattering), added to tau[q][u]
 * over the whole row (zeroed by the caller; [u0, u1) is the interior). */
void volux_lightvol_dir_tau_avx2(const lv_sweep *J, const lv_entry *e, int v, int u0, int u1, float *const tau[4]);

/* T[u] = exp(−tau[u]) for u in [0, n). */
void volux_lightvol_exp_avx2(float *T, const float *tau, int n);

/* Directional entry e, row v, the whole row ([u0, u1): interior, every
 * tap inside the slice; the row ends by fetch()'s rules, 9-column windows):
 * the light fetched from the previous slice (and the forward-scattering
 * cone unless `empty`), attenuated by T (and Tc_c with forward scattering)
 * into out[c][u], and accumulated: acc[c][u] += sw·gain_c·out and, when
 * ch = 6, acc[3 + i][u] += dsw_i·lum(out) — or S[u] += sw·lum(out) when S
 * is given (a run of same-direction lights, added as ω·S at its end). */
void volux_lightvol_dir_light_avx2(const lv_sweep *J, const lv_entry *e, int v, int u0, int u1, const float *T,
                                   float *const Tc[3], int empty, float *const out[3], float *acc, size_t m, int ch,
                                   float *S);
void volux_lightvol_dir_light_avx512(const lv_sweep *J, const lv_entry *e, int v, int u0, int u1, const float *T,
                                     float *const Tc[3], int empty, float *const out[3], float *acc, size_t m, int ch,
                                     float *S);

/* Positional entry e, row R->v: geometry (X, LEN, K, WA, WU, WV) for u in
 * [0, R->ms), bit-identical to volux_lightvol_pos_row's loop (no FMA there, so the Eq. 5
 * factors of a voxel's groups still sum to 1 exactly). */
void volux_lightvol_pos_geometry_avx2(const lv_sweep *J, const lv_entry *e, lv_pos_row *R);

/* Optical depths of the segments of u in [R->u0, R->u1) into R->TAU
 * (zeroed by the caller; the medium is gathered per voxel). */
void volux_lightvol_pos_tau_avx2(const lv_sweep *J, const lv_pos_row *R);

/* u in [R->u0, R->u1): the light gathered from the previous slice (and the
 * cone unless R->empty), attenuated, into out[c][u]; weighted by K into
 * acc (and the direction channels when ch = 6). */
void volux_lightvol_pos_light_avx2(const lv_sweep *J, const lv_entry *e, const lv_pos_row *R, float *const out[3],
                                   float *acc, size_t m, int ch);

/* ------------------------------------------------------- light values
 * sources.c; the row loops use them where a fetch falls outside the slice
 * (the box) and for a spot's cone. */

static inline float lv_spot_factor(const lv_source *s, float cos_angle) {
    /* volux_spot_falloff with the cosines precomputed */
    if (cos_angle >= s->cos_fall) return 1.0f;
    if (cos_angle <= s->cos_cone) return 0.0f;
    float t = (cos_angle - s->cos_cone) / (s->cos_fall - s->cos_cone);
    return t * t * (3.0f - 2.0f * t);
}

/* Value a light sends along the ray through world point p, before 1/r²:
 * directional E0, positional I·cone(θ). */
static inline void lv_ray_value(const lv_source *s, volux_vec3 p, float out[3]) {
    float f = 1.0f;
    if (s->kind == LV_POSITIONAL && s->spot) {
        volux_vec3 d = v3_sub(p, s->pos);
        float r2 = v3_dot(d, d);
        f = lv_spot_factor(s, r2 > 0.0f ? v3_dot(d, s->dir) / sqrtf(r2) : 1.0f);
    }
    out[0] = s->power.x * f;
    out[1] = s->power.y * f;
    out[2] = s->power.z * f;
}

/* Smallest r² a positional light's 1/r² is evaluated at: half the smallest
 * illumination spacing, squared. */
static inline float lv_rmin2(const lightvol_state *st) {
    float h = 0.5f * fminf(st->spacing[0], fminf(st->spacing[1], st->spacing[2]));
    return h * h;
}

/* Eq. 5 factor of a centre-grouped positional light (lv_source.center) for
 * the voxel at column u, row v of the pass: the group's constant factor
 * where the light's other group also reaches the voxel (it lies ahead of
 * the light along that group's axis, as the sweep's E_SKIP test decides),
 * else 1 — the factors of a voxel's groups always sum to 1. */
static inline float lv_center_weight(const lv_entry *e, int u, int v) {
    if (!e->oax) return e->cw;
    float c = e->oax == 1 ? (float)u : (float)v;
    return (float)e->osg * (c - e->ol) > 0.0f ? e->cw : 1.0f;
}

/* ------------------------------------------------------- scratch layout
 * Allocated by buffers.c (volux_lightvol_ensure_scratch), used by sweep.c
 * and the row files. */

/* Row scratch layout (floats, per thread): acc[6·mu] T[mu] Tc[3·mu]
 * cone[3·mu] cen[3·mu] tau[4·mu], then 16·mu for volux_lightvol_pos_row. */
#define ROW_FLOATS 36

/* Slices an x sweep stages before writing them to the volume as runs. */
#define LV_DEFER 8

/* A medium slice buffer: σt, κr, κg, κb planes (or the scalar in plane 0
 * when post-classified), then per row a (min, max) pair — of the scalar, or
 * 0 and the largest σt — so rows with an empty footprint skip the
 * transmittance work. Floats per buffer: */
static inline size_t lv_med_stride(const lightvol_state *st) {
    int mmax = st->dims[0] > st->dims[1] ? st->dims[0] : st->dims[1];
    if (st->dims[2] > mmax) mmax = st->dims[2];
    return 4 * st->area + 2 * (size_t)mmax;
}

/* Grows the propagation scratch (slice buffers for `entries` lights per
 * pass, medium slices, per-thread rows, x-sweep staging) on demand. */
volux_status volux_lightvol_ensure_scratch(lightvol_state *st, int entries);

/* ------------------------------------------------------- pass plan (plan.c) */

struct lv_pass {
    int g, first, n; /* group, range in the index list */
};

/* Plans the passes for `items` (coherent or one light per pass); returns
 * their number and fills passes/idx when non-NULL (idx: up to n·LV_GROUPS
 * indices into items). */
int volux_lightvol_plan(const lv_item *items, int n, int coherent, int max_per_pass, lv_pass *passes, int *idx);

/* Cost of one light entry of a pass by kind, in units of a pass's fixed
 * per-voxel cost (the calibration is in plan.c). */
typedef struct lv_work_weights {
    double dir, pos;
} lv_work_weights;

/* The weights of the row kernels and medium st propagates with. */
lv_work_weights volux_lightvol_work_weights(const lightvol_state *st);

/* Estimated work of the plan volux_lightvol_plan would make for `items`. */
double volux_lightvol_plan_work(const lv_item *items, int n, int coherent, int max_per_pass, lv_work_weights w);

/* ------------------------------------------------------- sweeps */

/* Medium of rows [v0, v1) of slice k into `dst` (a medium slice buffer, see
 * lv_med_stride): σt and κ_c = σt − f·σs_c, or the scalar values when
 * post-classified, and each row's range (medium.c). */
void volux_lightvol_classify_rows(const lv_sweep *J, float *dst, int k, int v0, int v1);

/* Slice steps s0 ≤ step < s1 of pass p of the job (sweep.c); the first
 * pass of an entire update overwrites the volume. Steps of a pass may be
 * run in any number of calls in order, with nothing else using the
 * propagation scratch in between: the result is the same. E: scratch for
 * the pass's entries. */
void volux_lightvol_sweep_steps(lightvol_state *st, const lv_job *job, int p, int s0, int s1, lv_entry *E);
/* Slice steps of pass p (the size of its sweep axis). */
int volux_lightvol_pass_steps(const lightvol_state *st, const lv_pass *p);
/* Modelled work of one slice step of pass p (voxels × (1 + its entries'
 * weights)), for the budget in milliseconds. */
double volux_lightvol_step_work(const lightvol_state *st, const lv_job *job, int p);

#endif
