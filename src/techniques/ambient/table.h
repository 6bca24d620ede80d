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

/* Loads the table for d from the context's cache folder, or builds it and
 * tries to store it there (a stale or corrupt entry is rebuilt; a folder
 * that cannot be written, or the disk cache turned off, only means the
 * table lives in memory; neither records an error). *built (may be NULL)
 * tells which happened. */
volux_status volux_ambient_table_get(volux_context *ctx, const volux_ambient_table_desc *d, volux_ambient_table *out,
                                     int *built);

/* Trilinear lookup at (θ radians, σ̃t, g), clamped to the ranges; linear in
 * θ and σ̃t, log-linear in g. */
double volux_ambient_table_eval(const volux_ambient_table *t, double theta, double sigma, double g);

/* Summary of the per-entry relative standard errors (entries whose value is
 * at most `floor` are skipped). Returns 0 if the table has none. */
int volux_ambient_table_noise_summary(volux_context *ctx, const volux_ambient_table *t, double floor,
                                      volux_ambient_table_noise *out);

/* The uncollided term (exact): a radial walk from x_o(θ) that crosses the
 * sphere without scattering reaches the antipode, where the front has
 * travelled d = 2·max(0, −cos θ):  L0 = e^{−σ̃t (2 + d)} p_g(cos θ). */
double volux_ambient_uncollided(double theta, double sigma, double g);

/* The paper's estimator, literally (§4.1.2): `paths` walks started at
 * x_o(θ) towards the centre, free paths −ln ξ/σ̃t, Russian roulette with the
 * albedo, HG sampling, the boundary condition scored at the exit. Slow;
 * for tests and for the noise comparison in the docs. Returns the mean and
 * its standard error. */
double volux_ambient_reference_entry(double theta, double sigma, double g, double albedo, uint64_t paths,
                                     uint64_t seed, double *std_error);

#endif
