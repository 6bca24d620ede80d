/*
 * techniques/guided/sweep_kernels.h — the inner loop of a visibility sweep
 * (one kernel row on one voxel plane), shared by the portable loop in
 * sweep.c and the AVX-512 loop in sweep_avx512.c, which the tests compare
 * (tests/physics/test_guided_sampling.c: same grid within float rounding).
 */
#ifndef VOLUX_GUIDED_SWEEP_KERNELS_H
#define VOLUX_GUIDED_SWEEP_KERNELS_H

#include "core/volume_internal.h"

/* The LUT's σt for the inner loops: n nodes plus the last one repeated,
 * so the interpolation may read node i + 1 for every i ≤ n − 1 (the same
 * values as volux_lut_sigma). */
typedef struct sweep_lut {
    const float *t;
    float s_min, inv_ds, last;
} sweep_lut;

static inline float sweep_lut_sigma(const sweep_lut *L, float s) {
    float u = (s - L->s_min) * L->inv_ds;
    u = u < 0.0f ? 0.0f : u > L->last ? L->last : u;
    int i = (int)u;
    float f = u - (float)i;
    return L->t[i] + f * (L->t[i + 1] - L->t[i]);
}

/* One kernel row on one plane: for kernel rays i = 0 … n − 1 (columns
 * c = h·i of the rows R0, R1, already offset to the first column), σt of
 * the bilinear blend (fa along the row, fb across, plus the volume's value
 * offset) → W[i] += wdt[i]·σ, and σ into sig[i] when sig is not NULL.
 * Every column c + 1 must lie inside the row. */
typedef void (*sweep_row_fn)(const void *R0, const void *R1, int h, float fa, float fb, float offset,
                             const sweep_lut *L, int n, float *W, const float *wdt, float *sig);

/* 1 if the CPU has AVX-512 F, BW and VL (the 16-wide row kernels). */
int guided_sweep_avx512_available(void);
/* The AVX-512 row kernels (ray spacing 1 only); NULL for a storage kind
 * without one. */
sweep_row_fn guided_sweep_row_avx512(volux_storage storage);

#endif
