/* Counter-based RNG: determinism, independence of streams, uniformity. */
#include <math.h>

#include "core/rng.h"
#include "test_util.h"

static void test_same_key_same_numbers(void **state) {
    (void)state;
    volux_rng a = volux_rng_make(7, 1234, 5, 0), b = volux_rng_make(7, 1234, 5, 0);
    for (int i = 0; i < 100; i++) assert_int_equal(volux_rng_u64(&a), volux_rng_u64(&b));
    /* any key component changes the stream */
    volux_rng c = volux_rng_make(7, 1235, 5, 0), d = volux_rng_make(7, 1234, 6, 0), e = volux_rng_make(8, 1234, 5, 0);
    volux_rng f = volux_rng_make(7, 1234, 5, 1);
    a = volux_rng_make(7, 1234, 5, 0);
    uint64_t x = volux_rng_u64(&a);
    assert_true(x != volux_rng_u64(&c) && x != volux_rng_u64(&d) && x != volux_rng_u64(&e) && x != volux_rng_u64(&f));
}

/* Chi-square over 64 bins of 2^18 floats drawn across many pixel streams
 * (what a renderer does); 63 dof: the 99.9% quantile is ≈ 103.4. */
static void test_floats_are_uniform(void **state) {
    (void)state;
    enum { BINS = 64, N = 1 << 18 };
    int counts[BINS] = {0};
    for (int p = 0; p < N / 8; p++) {
        volux_rng r = volux_rng_make(1, (uint64_t)p, 0, 0);
        for (int i = 0; i < 8; i++) {
            float u = volux_rng_float(&r);
            assert_true(u >= 0.0f && u < 1.0f);
            counts[(int)(u * BINS)]++;
        }
    }
    double chi2 = 0.0, expect = (double)N / BINS;
    for (int b = 0; b < BINS; b++) chi2 += (counts[b] - expect) * (counts[b] - expect) / expect;
    assert_true(chi2 < 103.4);
}

/* Neighbouring pixels' first numbers are uncorrelated (lag-1 correlation). */
static void test_neighbouring_streams_are_uncorrelated(void **state) {
    (void)state;
    enum { N = 100000 };
    double sxy = 0, sx = 0, sy = 0, sxx = 0, syy = 0;
    for (int p = 0; p < N; p++) {
        volux_rng a = volux_rng_make(3, (uint64_t)p, 0, 0), b = volux_rng_make(3, (uint64_t)p + 1, 0, 0);
        double x = volux_rng_double(&a), y = volux_rng_double(&b);
        sx += x, sy += y, sxy += x * y, sxx += x * x, syy += y * y;
    }
    double cov = sxy / N - sx / N * sy / N;
    double corr = cov / sqrt((sxx / N - sx * sx / N / N) * (syy / N - sy * sy / N / N));
    assert_true(fabs(corr) < 0.02); /* ≈ 6 standard errors at N = 1e5 */
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_same_key_same_numbers),
        cmocka_unit_test(test_floats_are_uniform),
        cmocka_unit_test(test_neighbouring_streams_are_uncorrelated),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
