/* Transfer functions: evaluation, validation, baking, pre-integration. */
#include <math.h>
#include <string.h>

#include "sample/march.h"
#include "test_util.h"

static void test_piecewise_linear_and_clamped(void **state) {
    (void)state;
    volux_tf_scalar_point p[3] = {{10, 0.0f}, {20, 1.0f}, {40, 0.5f}};
    assert_near(volux_tf_eval_scalar(p, 3, 0), 0.0, 0);
    assert_near(volux_tf_eval_scalar(p, 3, 15), 0.5, 1e-6);
    assert_near(volux_tf_eval_scalar(p, 3, 30), 0.75, 1e-6);
    assert_near(volux_tf_eval_scalar(p, 3, 99), 0.5, 0);
    volux_tf_color_point c[2] = {{0, 1, 0, 0}, {10, 0, 0, 1}};
    float rgb[3];
    volux_tf_eval_color(c, 2, 2.5f, rgb);
    assert_near(rgb[0], 0.75, 1e-6);
    assert_near(rgb[2], 0.25, 1e-6);
    volux_tf_eval_color(NULL, 0, 3, rgb); /* no colour points: white */
    assert_near(rgb[1], 1.0, 0);
}

static void test_validation_names_the_field(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_transfer_desc d;
    volux_transfer_desc_defaults(&d);
    volux_tf_scalar_point p[3] = {{0, 0.1f}, {5, 0.2f}, {4, 0.3f}};
    d.opacity = p;
    d.n_opacity = 3;
    volux_context_clear_error(ctx);
    assert_int_equal(volux_transfer_desc_validate(ctx, &d), VOLUX_ERR_INVALID);
    assert_non_null(strstr(volux_context_error(ctx), "opacity[2]"));
    p[2].s = 6;
    p[1].v = 1.5f;
    volux_context_clear_error(ctx);
    assert_int_equal(volux_transfer_desc_validate(ctx, &d), VOLUX_ERR_INVALID);
    assert_non_null(strstr(volux_context_error(ctx), "opacity[1]"));
    d.extinction = 1; /* 1.5 is a fine extinction */
    assert_int_equal(volux_transfer_desc_validate(ctx, &d), VOLUX_OK);
    d.anisotropy = 1.0f;
    volux_context_clear_error(ctx);
    assert_int_equal(volux_transfer_desc_validate(ctx, &d), VOLUX_ERR_INVALID);
    assert_non_null(strstr(volux_context_error(ctx), "anisotropy"));
    volux_context_destroy(ctx);
}

/* σt = −ln(1 − α)/u · density_scale (DESIGN §2). */
static void test_bake_converts_opacity_to_extinction(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_transfer_desc d;
    volux_transfer_desc_defaults(&d);
    volux_tf_scalar_point p[2] = {{0, 0.0f}, {100, 0.5f}};
    d.opacity = p;
    d.n_opacity = 2;
    d.opacity_unit_distance = 2.0f;
    d.density_scale = 3.0f;
    volux_transfer_lut lut;
    assert_int_equal(volux_transfer_bake(ctx, &d, 0, 100, 101, 1.0f, &lut), VOLUX_OK);
    assert_near(lut.sigma_t[100], -log(0.5) / 2.0 * 3.0, 1e-5);
    assert_near(lut.sigma_t[50], -log(0.75) / 2.0 * 3.0, 1e-5);
    assert_near(volux_lut_sigma(&lut, 100.0f), lut.sigma_t_max, 1e-6);
    /* the integral table matches a fine numerical integral of σt */
    double num = 0.0;
    for (int i = 0; i < 100000; i++) num += volux_lut_sigma(&lut, 30.0f + 40.0f * (i + 0.5f) / 100000.0f);
    num *= 40.0 / 100000.0;
    double rgb0[3], rgb1[3];
    double ana = volux_lut_int_sigma(&lut, 70.0f, rgb1) - volux_lut_int_sigma(&lut, 30.0f, rgb0);
    assert_near(ana, num, 1e-4 * num);
    /* max over a value range is exact on the node grid */
    assert_near(volux_transfer_lut_max_sigma(&lut, 10, 50), lut.sigma_t[50], 1e-7);
    volux_transfer_lut_free(ctx, &lut);
    volux_context_destroy(ctx);
}

/* A narrow opacity peak crossed between two samples: point sampling misses
 * it entirely, pre-integration integrates it exactly (up to table
 * resolution). This is the "does a narrow peak vanish" measurement. */
static void test_preintegration_catches_a_narrow_peak(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_transfer_desc d;
    volux_transfer_desc_defaults(&d);
    volux_tf_scalar_point p[4] = {{0, 0}, {127, 0}, {128, 2.0f}, {129, 0}};
    d.opacity = p;
    d.n_opacity = 4;
    d.extinction = 1;
    volux_transfer_lut lut;
    assert_int_equal(volux_transfer_bake(ctx, &d, 0, 255, 0, 1.0f, &lut), VOLUX_OK);
    /* Segment of length 1 with s going linearly from 100 to 160: the exact
     * optical depth is ∫σt ds · len/Δs = 2.0 · 1 / 60. */
    float s0 = 100, s1 = 160, len = 1.0f;
    double c0[3], c1[3];
    double tau_pre = len * (volux_lut_int_sigma(&lut, s1, c1) - volux_lut_int_sigma(&lut, s0, c0)) / (s1 - s0);
    double tau_point = len * volux_lut_sigma(&lut, s1); /* what a point sample at the segment end sees */
    assert_near(tau_pre, 2.0 / 60.0, 2e-3 * 2.0 / 60.0);
    assert_near(tau_point, 0.0, 0);
    volux_transfer_lut_free(ctx, &lut);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_piecewise_linear_and_clamped),
        cmocka_unit_test(test_validation_names_the_field),
        cmocka_unit_test(test_bake_converts_opacity_to_extinction),
        cmocka_unit_test(test_preintegration_catches_a_narrow_peak),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
