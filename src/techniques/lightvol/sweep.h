/*
 * techniques/lightvol/sweep.h — the state of one propagation pass (group,
 * lights, slice buffers, medium slices), shared by the portable sweep code
 * (propagate.c) and the AVX2 kernels (propagate_avx2.c).
 *
 * Internal to the technique.
 */
#ifndef VOLUX_LIGHTVOL_SWEEP_H
#define VOLUX_LIGHTVOL_SWEEP_H

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

/* One row of a positional light's propagation (pos_row): per-voxel arrays
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
 * [0, R->ms), bit-identical to pos_row's loop (no FMA there, so the Eq. 5
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

#endif
