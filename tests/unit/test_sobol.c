/*
 * The low-discrepancy sampler (core/sobol.h, sample/sampler.h): the Sobol
 * matrix, the nested-uniform structure of the scramble, stratification of
 * every slot's points over a pixel's 2^m samples (which independent numbers
 * fail), uniformity and unbiasedness over many scrambles, independence of
 * the padded slots, and the parameter's parsing.
 */
#include <math.h>
#include <string.h>

#include "core/rng.h"
#include "core/sobol.h"
#include "sample/sampler.h"
#include "test_util.h"

/* Sobol dimension 1 by its definition: XOR of the direction numbers
 * v_1 = 2^31, v_k = v_{k−1} ^ (v_{k−1} >> 1) (Joe–Kuo, s = 1, m₁ = 1)
 * selected by the index bits. */
static uint32_t sobol1_reference(uint32_t i) {
    uint32_t v = 0x80000000u, x = 0;
    for (int k = 0; k < 32; k++, v ^= v >> 1)
        if (i >> k & 1u) x ^= v;
    return x;
}

static void test_dimension1_matches_direction_numbers(void **state) {
    (void)state;
    volux_rng r = volux_rng_make(5, 0, 0, 0);
    for (uint32_t n = 0; n < 100000; n++) {
        uint32_t i = n < 4096 ? n : (uint32_t)volux_rng_u64(&r);
        assert_int_equal(volux_reverse32(volux_sobol1_reversed(i)), sobol1_reference(i));
    }
}

/* Unscrambled: the first 2^m points (dimension 0 = bit-reversed index) are
 * a (0, m, 2)-net: one point per elementary interval of every shape. */
static int is_net(const uint32_t *x, const uint32_t *y, int m) {
    static unsigned char seen[1 << 14];
    for (int a = 0; a <= m; a++) { /* 2^a columns × 2^(m−a) rows */
        memset(seen, 0, (size_t)1 << m);
        for (uint32_t i = 0; i < (1u << m); i++) {
            uint32_t cx = a ? x[i] >> (32 - a) : 0, cy = m - a ? y[i] >> (32 - (m - a)) : 0;
            uint32_t cell = (cx << (m - a)) | cy;
            if (seen[cell]++) return 0;
        }
    }
    return 1;
}

static void test_unscrambled_points_are_nets(void **state) {
    (void)state;
    static uint32_t x[1 << 12], y[1 << 12];
    for (uint32_t i = 0; i < (1u << 12); i++) x[i] = volux_reverse32(i), y[i] = sobol1_reference(i);
    for (int m = 0; m <= 12; m++) assert_true(is_net(x, y, m));
}

/* Nested uniform scrambling: values sharing their top k bits map to values
 * sharing their top k bits (the tree of elementary intervals is permuted,
 * never torn), and it is a bijection. */
static void test_scramble_is_nested_uniform(void **state) {
    (void)state;
    volux_rng r = volux_rng_make(9, 0, 0, 0);
    for (int n = 0; n < 20000; n++) {
        uint32_t seed = (uint32_t)volux_rng_u64(&r), a = (uint32_t)volux_rng_u64(&r), b = (uint32_t)volux_rng_u64(&r);
        int k = n % 33;
        uint32_t mask = k ? ~0u << (32 - k) : 0u;
        b = (a & mask) | (b & ~mask); /* shares a's top k bits */
        uint32_t sa = volux_owen_scramble(a, seed), sb = volux_owen_scramble(b, seed);
        assert_int_equal(sa & mask, sb & mask);
        if (a != b) assert_true(sa != sb);
    }
}

/* The stratification a renderer gets: for several pixels and every slot of
 * the first events, the 2^m samples' points are a (0, m, 2)-net, so a χ²
 * over the 16 × 16 strata for 256 samples is exactly 0; independent numbers
 * give χ² ≈ 255 ± 23 (255 degrees of freedom) and never a net. */
static double chi2_strata(const float *u, const float *v, int n, int side) {
    int counts[256] = {0};
    for (int i = 0; i < n; i++) counts[(int)(u[i] * side) * side + (int)(v[i] * side)]++;
    double e = (double)n / (side * side), c = 0.0;
    for (int s = 0; s < side * side; s++) c += (counts[s] - e) * (counts[s] - e) / e;
    return c;
}

static void test_slots_are_stratified_and_independent_is_not(void **state) {
    (void)state;
    enum { N = 256 };
    float u[N], v[N];
    for (uint64_t pixel = 0; pixel < 40; pixel += 13)
        for (uint32_t slot = 0; slot < 1 + VOLUX_LD_DEPTH * VOLUX_LD_USES; slot++) {
            for (uint32_t s = 0; s < N; s++) {
                volux_sampler ld = volux_sampler_make(VOLUX_SAMPLER_SOBOL, 1, pixel, s);
                volux_sampler_2d(&ld, slot, &u[s], &v[s]);
                assert_true(u[s] >= 0.0f && u[s] < 1.0f && v[s] >= 0.0f && v[s] < 1.0f);
            }
            assert_true(chi2_strata(u, v, N, 16) == 0.0);
            /* and every elementary-interval shape, prefix by prefix */
            for (int m = 0; m <= 8; m++) {
                uint32_t x[N], y[N];
                for (uint32_t s = 0; s < (1u << m); s++) {
                    volux_sampler ld = volux_sampler_make(VOLUX_SAMPLER_SOBOL, 1, pixel, s);
                    volux_sampler_2d_u32(&ld, slot, &x[s], &y[s]);
                }
                assert_true(is_net(x, y, m));
            }
        }
    /* the independent stream, drawn as the renderer draws it */
    for (uint64_t pixel = 0; pixel < 40; pixel += 13) {
        for (uint32_t s = 0; s < N; s++) {
            volux_rng r = volux_rng_make(1, pixel, s, 0);
            u[s] = volux_rng_float(&r), v[s] = volux_rng_float(&r);
        }
        assert_true(chi2_strata(u, v, N, 16) > 150.0); /* 4.6 sd below the mean */
    }
}

/* Unbiasedness: averaged over many pixels (independent scrambles), the
 * estimate of ∫∫ f over [0,1)² with 16 samples per pixel matches the
 * integral within 4 standard errors, for a smooth and a discontinuous f;
 * and for the smooth one the per-pixel variance is far below independent
 * sampling's (Owen scrambling: O(N^−3) vs O(N^−1)). */
static double f_smooth(double u, double v) { return u * v * v + exp(-u); } /* 1/6 + 1 − 1/e */
static double f_step(double u, double v) { return u + v < 1.0 ? 1.0 : 0.0; } /* 1/2 */

static void test_estimates_are_unbiased(void **state) {
    (void)state;
    enum { P = 20000, N = 16 };
    const double truth[2] = {1.0 / 6.0 + 1.0 - exp(-1.0), 0.5};
    for (int fi = 0; fi < 2; fi++)
        for (uint32_t slot = 0; slot < 3; slot++) {
            double s1 = 0, s2 = 0, i1 = 0, i2 = 0;
            for (uint64_t p = 0; p < P; p++) {
                double est = 0, ind = 0;
                volux_rng r = volux_rng_make(3, p, 0, 1);
                for (uint32_t s = 0; s < N; s++) {
                    volux_sampler ld = volux_sampler_make(VOLUX_SAMPLER_SOBOL, 3, p, s);
                    float u, v;
                    volux_sampler_2d(&ld, slot * 7, &u, &v);
                    est += fi ? f_step(u, v) : f_smooth(u, v);
                    double a = volux_rng_double(&r), b = volux_rng_double(&r);
                    ind += fi ? f_step(a, b) : f_smooth(a, b);
                }
                est /= N, ind /= N;
                s1 += est, s2 += est * est, i1 += ind, i2 += ind * ind;
            }
            double mean = s1 / P, var = s2 / P - mean * mean, var_ind = i2 / P - (i1 / P) * (i1 / P);
            double se = sqrt(var / P);
            if (fabs(mean - truth[fi]) > 4.0 * se + 1e-7)
                fail_msg("f%d slot %u: mean %.7f, integral %.7f, se %.2g", fi, slot, mean, truth[fi], se);
            assert_true(var < var_ind); /* stratification only helps */
            if (fi == 0) assert_true(var < var_ind / 20.0);
        }
}

/* Padding: the pairs of different slots at one sample are independent —
 * no correlation between any of their coordinates across pixels and
 * samples (also not between a slot and the same slot of the next event). */
static void test_padded_slots_are_uncorrelated(void **state) {
    (void)state;
    enum { P = 4000, N = 16 };
    const uint32_t pairs[][2] = {{0, 1}, {1, 2}, {1, 1 + VOLUX_LD_USES}, {3, 4}};
    for (size_t q = 0; q < sizeof pairs / sizeof pairs[0]; q++)
        for (int ca = 0; ca < 2; ca++)
            for (int cb = 0; cb < 2; cb++) {
                double sx = 0, sy = 0, sxy = 0, sxx = 0, syy = 0, n = (double)P * N;
                for (uint64_t p = 0; p < P; p++)
                    for (uint32_t s = 0; s < N; s++) {
                        volux_sampler ld = volux_sampler_make(VOLUX_SAMPLER_SOBOL, 11, p, s);
                        float a[2], b[2];
                        volux_sampler_2d(&ld, pairs[q][0], &a[0], &a[1]);
                        volux_sampler_2d(&ld, pairs[q][1], &b[0], &b[1]);
                        double x = a[ca], y = b[cb];
                        sx += x, sy += y, sxy += x * y, sxx += x * x, syy += y * y;
                    }
                double cov = sxy / n - sx / n * sy / n;
                double corr = cov / sqrt((sxx / n - sx * sx / n / n) * (syy / n - sy * sy / n / n));
                if (fabs(corr) > 0.02) /* ≈ 5 standard errors at n = 64000 */
                    fail_msg("slots %u, %u (coords %d, %d): correlation %.4f", pairs[q][0], pairs[q][1], ca, cb,
                             corr);
            }
}

/* Padding within a pixel: two slots' coordinates over the pixel's 256
 * samples fill the 16 × 16 strata of their joint square about as
 * independent points do (χ² mean 255, sd 23; the index shuffles of
 * Burley §4 pair the two sets with a little more spread than a uniformly
 * random pairing would: mean ≈ 241, sd ≈ 50, largest of 2400 ≈ 500).
 * Without a shuffle of its own per slot, one slot's coordinate would be a
 * fixed nested permutation of the other's and every row's 16 points would
 * share one cell (χ² ≈ 3840). */
static void test_padded_slots_pair_randomly_within_a_pixel(void **state) {
    (void)state;
    enum { N = 256 };
    float a[2][N], b[2][N];
    double sum = 0.0;
    int n = 0;
    for (uint64_t pixel = 0; pixel < 6; pixel++)
        for (uint32_t slot = 0; slot < 12; slot++) {
            for (uint32_t s = 0; s < N; s++) {
                volux_sampler ld = volux_sampler_make(VOLUX_SAMPLER_SOBOL, 5, pixel, s);
                volux_sampler_2d(&ld, slot, &a[0][s], &a[1][s]);
                volux_sampler_2d(&ld, slot + 1, &b[0][s], &b[1][s]);
            }
            for (int ca = 0; ca < 2; ca++)
                for (int cb = 0; cb < 2; cb++) {
                    double c = chi2_strata(a[ca], b[cb], N, 16);
                    sum += c, n++;
                    if (!(c < 800.0))
                        fail_msg("pixel %u slots %u/%u coords %d/%d: chi2 %.0f", (unsigned)pixel, slot, slot + 1, ca,
                                 cb, c);
                }
        }
    if (!(sum / n < 270.0)) fail_msg("mean chi2 of slot pairs %.1f (independent points: 255)", sum / n);
}

static void test_parameter_names(void **state) {
    (void)state;
    assert_int_equal(volux_sampler_parse("sobol"), VOLUX_SAMPLER_SOBOL);
    assert_int_equal(volux_sampler_parse("independent"), VOLUX_SAMPLER_INDEPENDENT);
    assert_int_equal(volux_sampler_parse("Sobol"), -1);
    assert_int_equal(volux_sampler_parse("sobol "), -1);
    assert_int_equal(volux_sampler_parse(""), -1);
    assert_int_equal(volux_sampler_parse(NULL), -1);
    /* the independent kind draws nothing from the sequence */
    volux_sampler off = volux_sampler_make(VOLUX_SAMPLER_INDEPENDENT, 1, 2, 3);
    assert_int_equal(off.on, 0);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_dimension1_matches_direction_numbers),
        cmocka_unit_test(test_unscrambled_points_are_nets),
        cmocka_unit_test(test_scramble_is_nested_uniform),
        cmocka_unit_test(test_slots_are_stratified_and_independent_is_not),
        cmocka_unit_test(test_estimates_are_unbiased),
        cmocka_unit_test(test_padded_slots_are_uncorrelated),
        cmocka_unit_test(test_padded_slots_pair_randomly_within_a_pixel),
        cmocka_unit_test(test_parameter_names),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
