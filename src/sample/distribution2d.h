/*
 * sample/distribution2d.h — piecewise-constant 1-D and 2-D distributions on
 * [0,1) and [0,1)², for importance sampling tabulated functions (environment
 * maps, later light grids).
 *
 * A 2-D distribution of an nu × nv table f (row-major, v rows of u columns)
 * has the density p(u,v) = f[iv][iu] / ∫∫f, constant in each cell. Sampling
 * draws a row from the marginal density of the row integrals, then a column
 * from that row's conditional density, and places the point continuously
 * inside the cell (Pharr, Jakob & Humphreys, "Physically Based Rendering",
 * 3rd ed., §13.6.7 / 4th ed. §A.5.6: PiecewiseConstant2D). Negative or
 * non-finite table entries count as 0. Cells with f = 0 are never sampled and
 * have density 0.
 *
 * A table that is 0 everywhere has `integral` 0: sampling then returns pdf 0
 * and callers must treat the strategy as unavailable.
 *
 * Memory: one block through the context; read-only after build, so it may be
 * shared between threads. No allocation when sampling.
 */
#ifndef VOLUX_DISTRIBUTION2D_H
#define VOLUX_DISTRIBUTION2D_H

#include "core/context_internal.h"

typedef struct volux_distribution2d {
    int nu, nv;
    float *func;     /* nv·nu cell values (clamped ≥ 0)                        */
    float *cdf;      /* nv·(nu+1) conditional CDFs, each from 0 to 1            */
    float *row_int;  /* nv row integrals ∫ f(u, v_row) du = marginal density·I  */
    float *marg_cdf; /* nv+1 marginal CDF                                       */
    float integral;  /* ∫∫ f du dv                                              */
    void *block;
    size_t bytes;
} volux_distribution2d;

/* Builds (or rebuilds in place) the distribution of `f` (nu·nv floats,
 * borrowed). nu, nv in [1, 1<<16]. VOLUX_ERR_NOMEM / VOLUX_ERR_INVALID. */
volux_status volux_distribution2d_build(volux_context *ctx, const float *f, int nu, int nv,
                                        volux_distribution2d *d);
void volux_distribution2d_free(volux_context *ctx, volux_distribution2d *d);

/* Maps (u0, u1) ∈ [0,1)² to a point uv ∈ [0,1)² distributed with density
 * p(uv); returns p(uv), or 0 if the table is empty. */
float volux_distribution2d_sample(const volux_distribution2d *d, float u0, float u1, float uv[2]);
/* The density p(u, v) for (u, v) ∈ [0,1]² (clamped to the table). */
float volux_distribution2d_pdf(const volux_distribution2d *d, float u, float v);

/* One-dimensional piecewise-constant sampling over n cells with CDF
 * cdf[0..n] (cdf[0] = 0, cdf[n] = 1): returns the cell index and the
 * continuous position x ∈ [0,1) (in cell units of 1/n) for u ∈ [0,1). */
int volux_piecewise_sample(const float *cdf, int n, float u, float *x);

#endif
