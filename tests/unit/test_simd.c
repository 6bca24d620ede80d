/*
 * tests/unit/test_simd.c — core/simd.h: each fast exponential and acos
 * within its stated error of libm's (in double) and with its stated edge
 * values, the vector forms against the scalar ones they follow, and the
 * CPU-feature checks against what the kernel reports in /proc/cpuinfo.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "core/simd.h"
#include "test_util.h"

static float from_bits(uint32_t b) {
    float f;
    memcpy(&f, &b, sizeof f);
    return f;
}

static uint32_t bits_of(float f) {
    uint32_t b;
    memcpy(&b, &f, sizeof b);
    return b;
}

/* Sampled floats in [−87, −0], decreasing: bit patterns of negative floats
 * grow with the magnitude. */
enum { STRIDE = 61 };

static void test_exp_nonpos_t6(void **state) {
    (void)state;
    assert_true(volux_exp_nonpos_t6(0.0f) == 1.0f);
    assert_true(volux_exp_nonpos_t6(-0.0f) == 1.0f);
    /* clamped at −87: a tiny normal, not 0 */
    assert_true(volux_exp_nonpos_t6(-1000.0f) == volux_exp_nonpos_t6(-87.0f));
    assert_true(volux_exp_nonpos_t6(-87.0f) > 0.0f);
    float prev = 1.0f;
    double worst_near = 0.0, worst = 0.0;
    for (uint32_t b = bits_of(-0.0f); b <= bits_of(-87.0f); b += STRIDE) {
        float x = from_bits(b);
        double want = exp((double)x), err = fabs(volux_exp_nonpos_t6(x) - want) / want;
        if (x >= -41.0f && err > worst_near) worst_near = err;
        if (err > worst) worst = err;
        /* non-increasing as x decreases */
        assert_true(volux_exp_nonpos_t6(x) <= prev);
        prev = volux_exp_nonpos_t6(x);
    }
    print_message("t6: max relative error %.3g above -41, %.3g down to -87\n", worst_near, worst);
    assert_true(worst_near <= 4.1e-6);
    assert_true(worst <= 8e-6);
}

static void test_exp_neg_cw7(void **state) {
    (void)state;
    assert_true(volux_exp_neg_cw7(0.0f) == 1.0f);
    assert_true(volux_exp_neg_cw7(1000.0f) == 0.0f);
    assert_true(volux_exp_neg_cw7(INFINITY) == 0.0f);
    assert_true(volux_exp_neg_cw7(NAN) == 0.0f);
    float prev = 1.0f;
    for (int i = 0; i <= 200000; i++) {
        float x = (float)i * 4e-4f;
        float e = volux_exp_neg_cw7(x), want = expf(-x);
        assert_true(e <= 1.0f && e >= 0.0f);
        assert_true(fabsf(e - want) <= 4e-7f * want + 1e-38f);
        assert_true(e <= prev);
        prev = e;
    }
}

static void test_acos(void **state) {
    (void)state;
    for (int i = -10000; i <= 10000; i++) {
        float x = (float)i / 10000.0f;
        assert_near(volux_acos_deg3(x), acos((double)x), 6.8e-5);
        if (x >= 0.0f) assert_near(volux_acos01_deg7(x), acos((double)x), 3e-7);
    }
    /* both clamp outside their domain */
    assert_true(volux_acos_deg3(1.5f) == volux_acos_deg3(1.0f));
    assert_true(volux_acos_deg3(-1.5f) == volux_acos_deg3(-1.0f));
    assert_true(volux_acos01_deg7(2.0f) == 0.0f);
    assert_true(volux_acos01_deg7(-0.5f) == volux_acos01_deg7(0.0f));
}

#if VOLUX_X86_GNUC
#define LANES_FN static __attribute__((target("avx2,fma")))

LANES_FN float exp_nonpos_cephes(float x) {
    float y[8];
    _mm256_storeu_ps(y, volux_exp_nonpos_cephes_avx2(_mm256_set1_ps(x)));
    return y[0];
}

LANES_FN float exp_neg_cw7_lanes(float x) {
    float y[8];
    _mm256_storeu_ps(y, volux_exp_neg_cw7_avx2(_mm256_set1_ps(x)));
    return y[0];
}

LANES_FN float acos01_deg7_lanes(float x) {
    float y[8];
    _mm256_storeu_ps(y, volux_acos01_deg7_avx2(_mm256_set1_ps(x)));
    return y[0];
}

/* The eight-lane forms: the Cephes exp within 2 ulp of e^x, the fused cw7
 * within a few ulp of the scalar one with its edge values, and acos
 * bit-identical to the scalar one (plain mul/add, same order). */
static void test_lanes(void **state) {
    (void)state;
    if (!volux_cpu_has_avx2_fma()) skip();
    for (uint32_t b = bits_of(-0.0f); b <= bits_of(-87.0f); b += STRIDE) {
        float x = from_bits(b);
        float want = (float)exp((double)x), ulp = nextafterf(want, INFINITY) - want;
        if (fabsf(exp_nonpos_cephes(x) - want) > 2.0f * ulp) fail_msg("cephes exp(%.9g) = %.9g", x, exp_nonpos_cephes(x));
        float r = volux_exp_neg_cw7(-x);
        if (fabsf(exp_neg_cw7_lanes(-x) - r) > 4e-7f * r + 1e-38f) fail_msg("cw7 lanes e^-%.9g", -x);
    }
    assert_true(exp_nonpos_cephes(0.0f) == 1.0f);
    assert_true(exp_neg_cw7_lanes(0.0f) == 1.0f);
    assert_true(exp_neg_cw7_lanes(INFINITY) == 0.0f);
    assert_true(exp_neg_cw7_lanes(NAN) == 0.0f);
    assert_true(exp_neg_cw7_lanes(88.0f) == 0.0f);
    for (uint32_t b = 0; b <= bits_of(1.25f); b += 97) {
        float x = from_bits(b);
        if (bits_of(acos01_deg7_lanes(x)) != bits_of(volux_acos01_deg7(x))) fail_msg("acos01 lanes at %.9g", x);
    }
}
#else
static void test_lanes(void **state) {
    (void)state;
    skip();
}
#endif

/* 1 if the first "flags" line of /proc/cpuinfo lists `flag`, 0 if not, −1
 * if there is no such file or line (not Linux). */
static int cpuinfo_flag(const char *flag) {
    FILE *f = fopen("/proc/cpuinfo", "r");
    if (!f) return -1;
    static char line[16384];
    int found = -1;
    while (found < 0 && fgets(line, sizeof line, f)) {
        if (strncmp(line, "flags", 5) != 0) continue;
        found = 0;
        for (char *tok = strtok(strchr(line, ':') + 1, " \t\n"); tok; tok = strtok(NULL, " \t\n"))
            if (strcmp(tok, flag) == 0) found = 1;
    }
    fclose(f);
    return found;
}

static void test_cpu_features_match_cpuinfo(void **state) {
    (void)state;
    int avx2 = cpuinfo_flag("avx2"), fma = cpuinfo_flag("fma"), avx512f = cpuinfo_flag("avx512f");
    if (avx2 < 0) skip();
    print_message("cpuinfo: avx2 %d fma %d avx512f %d\n", avx2, fma, avx512f);
#if VOLUX_X86_GNUC
    assert_int_equal(volux_cpu_has_avx2(), avx2);
    assert_int_equal(volux_cpu_has_avx2_fma(), avx2 && fma);
    assert_int_equal(volux_cpu_has_avx512f(), avx512f);
#else
    assert_int_equal(volux_cpu_has_avx2() + volux_cpu_has_avx2_fma() + volux_cpu_has_avx512f(), 0);
#endif
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_exp_nonpos_t6), cmocka_unit_test(test_exp_neg_cw7),
        cmocka_unit_test(test_acos),          cmocka_unit_test(test_lanes),
        cmocka_unit_test(test_cpu_features_match_cpuinfo),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
