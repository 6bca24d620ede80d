/*
 * techniques/ambient/tube_simd.h — the tube-marching node update (tube.c's
 * `node`) and directional fast path (fast_run) on 8 nodes at a time with
 * AVX2 (tube_avx2.c) or 16 with AVX-512F (tube_avx512.c), chosen at run
 * time through tube_kernels_avx2 / tube_kernels_avx512; all intrinsics
 * live in those two files, the kernels themselves are written once
 * (tube_simd_impl.h).
 *
 * They evaluate, per node, exactly the scalar arithmetic of tube.c — the
 * same operations in the same order, no FMA contraction, IEEE sqrt and
 * division — so their results are bit-identical to the scalar path
 * (tests/physics/test_tube_marching.c asserts it). What they save is the
 * per-node overhead: the light direction, the box exit, both trilinear
 * reads (gathers) and the κ look-up run 8 or 16 lanes wide, and the three
 * cases of a node (within one step of the chain start, within two,
 * further) are selects instead of branches.
 *
 * Precondition: ρ and D share dims and box (the technique's layout), every
 * dimension ≥ 2, fewer than 2^31 nodes, n_sigma ≥ 2. Reads of D touch only
 * the strict trilinear corners the sweep order guarantees (as
 * sample_strict), and only for lanes that need them (masked gathers).
 */
#ifndef VOLUX_AMBIENT_TUBE_SIMD_H
#define VOLUX_AMBIENT_TUBE_SIMD_H

#include <stddef.h>
#include <stdint.h>

typedef struct tube_lanes {
    const float *rho; /* ρ = r·σ̃t at the cache's nodes                  */
    float *D;         /* the cache being filled                          */
    int dims[3];
    float lo[3], hi[3], h[3], inv_h[3];
    int positional;
    float pos[3];     /* point/spot: light position                      */
    float dir[3];     /* directional: travel direction                   */
    float s;          /* marching step                                   */
    float inv_r;      /* 1/r (0 for r = 0)                               */
    const float *kappa;
    int n_sigma;
    float sigma_max;
    /* the κ arguments (tube.h: tube_geometry), or NULL: written by a march,
     * read instead of sampling ρ by a re-sum (resum = 1) */
    float *g_arg;
    int resum;
    /* vacuum chains (tube.h: tube_geometry), by node index, or NULL: a
     * march writes them and sets *vac_bad when a node breaks their
     * invariant; a re-sum writes +0 for blocks of them */
    unsigned char *vac;
    int *vac_bad;
} tube_lanes;

/* The directional sweep's fast path (tube.c's fast_run): constant corner
 * offsets and weights of both reads for every node of a run. */
typedef struct tube_fast {
    ptrdiff_t off_v[8], off_r[8]; /* corner offsets of the D and ρ reads  */
    float w_v[8], w_r[8];         /* their trilinear weights             */
    float kscale;                 /* ρ → κ-table coordinate              */
    float last;                   /* highest coordinate (n_sigma − 1 − 1e−3) */
    const float *kappa;
    int *vac_bad;                 /* as tube_lanes.vac_bad               */
} tube_fast;

/* One width's kernels. */
typedef struct tube_kernels {
    int lanes;         /* nodes per step: 8 (AVX2), 16 (AVX-512F)           */
    int vacuum_chains; /* records vacuum chains (tube.h) and skips them     */
    /* Fills D at the `count` nodes (i, j, k) + n·e_axis, n ∈ [0, count),
     * and their κ arguments at g_arg[rec0 + n·rec_stride] when g_arg is
     * set (or, when resum, takes them from there). */
    void (*nodes)(const tube_lanes *t, int i, int j, int k, int axis, int count, size_t rec0, ptrdiff_t rec_stride);
    /* The runs (i, j, k, axis, count) of a point sweep (records in node
     * order) in one call. */
    void (*runs)(const tube_lanes *t, const int (*runs)[5], int n_runs);
    /* A directional row along x: [0, c0) and (c1, n) by the node update,
     * [c0, c1] by the fast path; records from rec0. */
    void (*row)(const tube_lanes *t, const tube_fast *fr, int j, int k, int n, int c0, int c1, size_t rec0,
                int resum);
    /* fast_run: out[i] for i < count from D and R at the constant offsets
     * (out and D point into the same grid; every D read lies in an earlier
     * slice); any count (the tail is masked: no element past the run is
     * touched). The κ-table coordinates are stored to u_io (if not NULL)
     * or, when resum, read from it instead of from R; the vacuum chains of
     * out's nodes at vac (NULL unless vacuum_chains): written by a march,
     * skipped by a re-sum. */
    void (*fast_run)(const tube_fast *f, float *out, const float *D, const float *R, float *u_io, unsigned char *vac,
                     int resum, int count);
} tube_kernels;

/* A width's kernels, or NULL when this CPU (or build) does not run them. */
const tube_kernels *tube_kernels_avx2(void);
const tube_kernels *tube_kernels_avx512(void);

/* The kernels tube_march / tube_resum take for `kernel_cap` (tube.h:
 * TUBE_KERNEL_*) on this CPU, NULL for the scalar path (before the grid's
 * own conditions, tube.c: setup_lanes). */
const tube_kernels *tube_kernels_for(int kernel_cap);

#endif
