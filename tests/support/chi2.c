/* tests/support/chi2.c — see chi2.h. */
#include <math.h>
#include <stdio.h>

#include "chi2.h"

/* Wilson & Hilferty 1931: (x/k)^{1/3} is nearly normal. */
double chi2_pvalue(double x, int k) {
    double m = 1.0 - 2.0 / (9.0 * k), s = sqrt(2.0 / (9.0 * k));
    double z = (cbrt(x / k) - m) / s;
    return 0.5 * erfc(z / sqrt(2.0));
}

void chi2_check(const double *observed, const double *expected, int bins, double n, const char *what) {
    double chi2 = 0.0, pool_o = 0.0, pool_e = 0.0, total_e = 0.0;
    int dof = 0;
    for (int i = 0; i < bins; i++) {
        total_e += expected[i];
        if (expected[i] * n < 5.0) {
            pool_o += observed[i];
            pool_e += expected[i] * n;
            /* a sample where the pdf says (almost) none may land is a bug */
            if (expected[i] == 0.0 && observed[i] > 0)
                fail_msg("%s: %g samples in bin %d whose probability is 0", what, observed[i], i);
            continue;
        }
        double e = expected[i] * n, d = observed[i] - e;
        chi2 += d * d / e;
        dof++;
    }
    if (pool_e >= 5.0) {
        chi2 += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
        dof++;
    }
    dof -= 1;
    double p = chi2_pvalue(chi2, dof);
    printf("  %-36s chi2 %.1f, dof %d, p %.3f, total probability %.6f\n", what, chi2, dof, p, total_e);
    assert_true(fabs(total_e - 1.0) < 2e-3);
    if (p < 1e-4) fail_msg("%s: chi-square %.1f with %d dof, p = %.2g", what, chi2, dof, p);
}
