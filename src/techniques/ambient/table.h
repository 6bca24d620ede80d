/*
 * techniques/ambient/table.h — the Monte-Carlo estimator of the ambient
 * preintegration table (Ament et al. 2013, §4.1) and its lookup. The table
 * type, file format and cache entry are io's (io/ambient_table_file.h).
 */
#ifndef VOLUX_AMBIENT_TABLE_H
#define VOLUX_AMBIENT_TABLE_H

#include "io/ambient_table_file.h"

/* Builds the table by Monte-Carlo path tracing on the context's threads.
 * Deterministic: the result is bit-identical for any thread count (random
 * numbers are keyed by column and walk index). Reports progress as task
 * "ambient table"; a cancel returns VOLUX_ERR_CANCELLED. Caller frees. */
volux_status volux_ambient_table_build(volux_context *ctx, const volux_ambient_table_desc *d,
                                       volux_ambient_table *out);

/* The bytes of the table built into the library (a table file; NULL and
 * *size = 0 in a build without it). builtin.c. */
const unsigned char *volux_ambient_builtin_table(size_t *size);

/* The table for d: the built-in one if d describes it, else from the
 * context's cache folder, else built (with a note through the context's
 * message callback saying what is built, how large, and where it will be
 * kept) and stored there (a stale or corrupt entry is rebuilt; a folder
 * that cannot be written, or the disk cache turned off, only means the
 * table lives in memory; neither records an error). *built (may be NULL)
 * tells whether it was built. */
volux_status volux_ambient_table_get(volux_context *ctx, const volux_ambient_table_desc *d, volux_ambient_table *out,
                                     int *built);

/* Lookup at (θ radians, σ̃t, g, albedo), clamped to the ranges; linear in
 * θ, σ̃t and albedo, log-linear in g. A table of one albedo ignores it. */
double volux_ambient_table_eval(const volux_ambient_table *t, double theta, double sigma, double g, double albedo);
/* The albedo block ia ≤ n_albedo − 2 whose interval holds `albedo` (clamped
 * to the axis) and the weight *frac of block ia + 1; 0 and 0 for a table
 * of one albedo. */
int volux_ambient_table_albedo_bracket(const volux_ambient_table_desc *d, double albedo, double *frac);

/* Summary of the per-entry relative standard errors (entries whose value is
 * at most `floor` are skipped). Returns 0 if the table has none. */
int volux_ambient_table_noise_summary(volux_context *ctx, const volux_ambient_table *t, double floor,
                                      volux_ambient_table_noise *out);

/* The uncollided term (exact): a radial walk from x_o(θ) that crosses the
 * sphere without scattering reaches the antipode, where the front has
 * travelled d = 2·max(0, −cos θ):  L0 = e^{−σ̃t (2 + d)} p_g(cos θ). */
double volux_ambient_uncollided(double theta, double sigma, double g);

/* The table between two g nodes (weight f of the second): the uncollided
 * term, exact at any g (uncollided_g = volux_ambient_uncollided at g), plus
 * the collided part (entry a or b minus its node's uncollided ua or ub)
 * log-linear in g (linear where either part is not positive). The
 * uncollided term carries the phase function's peak, which log-linear
 * interpolation between nodes 0.2 apart misses by up to a third at
 * |g| = 0.8 (docs/techniques/ambient.md §2, Fig. 5). */
double volux_ambient_g_interp(double uncollided_g, double a, double ua, double b, double ub, double f);

/* The paper's estimator, literally (§4.1.2): `paths` walks started at
 * x_o(θ) towards the centre, free paths −ln ξ/σ̃t, Russian roulette with the
 * albedo, HG sampling, the boundary condition scored at the exit. Slow;
 * for tests and for the noise comparison in the docs. Returns the mean and
 * its standard error. */
double volux_ambient_reference_entry(double theta, double sigma, double g, double albedo, uint64_t paths,
                                     uint64_t seed, double *std_error);

#endif
