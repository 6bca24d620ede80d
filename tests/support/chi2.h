/*
 * tests/support/chi2.h — chi-square goodness of fit of a sampler against
 * its integrated density over bins (pbrt bsdfs_test style).
 *
 * Bins with an expected count < 5 are pooled; a sample in a bin whose
 * probability is exactly 0 fails at once. The p-value comes from the
 * Wilson–Hilferty normal approximation of the chi-square distribution; the
 * check fails below p = 1e-4 (seeded streams make a pass reproducible) and
 * when the expected probabilities do not sum to 1 within 2e-3.
 */
#ifndef VOLUX_TEST_CHI2_H
#define VOLUX_TEST_CHI2_H

#include "test_util.h"

/* p-value of a chi-square statistic x with k degrees of freedom. */
double chi2_pvalue(double x, int k);
/* observed[i]: counts out of n samples; expected[i]: probabilities. */
void chi2_check(const double *observed, const double *expected, int bins, double n, const char *what);

#endif
