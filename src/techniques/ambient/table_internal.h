/*
 * techniques/ambient/table_internal.h — pieces of the preintegration table
 * that tests and the technique use beyond the public API.
 */
#ifndef VOLUX_AMBIENT_TABLE_INTERNAL_H
#define VOLUX_AMBIENT_TABLE_INTERNAL_H

#include "volux/ambient_table.h"

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

/* Index of the value at (it, is, ig). */
static inline size_t volux_ambient_table_index(const volux_ambient_table_desc *d, int it, int is, int ig) {
    return ((size_t)ig * (size_t)d->n_sigma + (size_t)is) * (size_t)d->n_theta + (size_t)it;
}

#endif
