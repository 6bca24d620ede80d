/*
 * tests/physics/test_ambient_limits.c — ambient scattering tends to single
 * scattering as the ambient radius shrinks: the table's thin-sphere limit is
 * the phase function (L̃o(θ, 0, g) = p_g(cos θ)) and the tube-marched
 * radiance cache tends to the shadow-ray transmittance.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "test_util.h"

static const char *SCENE =
    "{\"volume\": {\"procedural\": \"phantom\", \"dims\": [32, 32, 32]},"
    " \"transfer_function\": {\"color\": [[0, 0.9, 0.6, 0.4], [255, 1, 1, 1]],"
    "   \"opacity\": [[0, 0], [30, 0], [60, 0.05], [255, 0.5]], \"albedo\": 0.9, \"anisotropy\": 0.2},"
    " \"camera\": {\"orbit\": {\"azimuth\": 30, \"elevation\": 20}, \"fov_y\": 30},"
    " \"lights\": [{\"type\": \"directional\", \"direction\": [-0.5, -0.7, -0.5], \"irradiance\": 2},"
    "   {\"type\": \"point\", \"position\": [20, 10, 30], \"intensity\": 800}],"
    " \"render\": {\"width\": 32, \"height\": 32, \"spp\": 1, \"step\": 0.25},"
    " \"techniques\": {\"ambient\": {\"table_theta\": 64, \"table_sigma\": 64, \"table_g\": 5, \"table_paths\": 256,"
    "   \"radius\": 0.5, \"cache_scale\": 1}, \"single\": {\"cache_scale\": 1}}}";

static void test_small_radius_tends_to_single_scattering(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    volux_scene *s;
    assert_int_equal(volux_scene_load_string(ctx, SCENE, ".", "test", NULL, 0, &s), VOLUX_OK);
    volux_image a = tu_render(ctx, s, "ambient"), b = tu_render(ctx, s, "single");
    volux_image_error err;
    assert_int_equal(volux_image_compare(ctx, &a, &b, &err), VOLUX_OK);
    print_message("ambient (r = 0.5 voxel) vs single: rel_mse %.4g\n", err.rel_mse);
    assert_true(err.rel_mse < 0.01);
    double small = err.rel_mse;
    /* A larger radius scatters more light around: the images part (by
     * 0.033 with the adaptive x_o, 50x the small radius's 0.00066; by 0.05
     * with the paper's constant one, which over-counts dense parts). */
    assert_int_equal(volux_scene_set_param(s, "ambient", "radius", 6, NULL), VOLUX_OK);
    volux_image c = tu_render(ctx, s, "ambient");
    assert_int_equal(volux_image_compare(ctx, &c, &b, &err), VOLUX_OK);
    print_message("ambient (r = 6 voxels) vs single: rel_mse %.4g\n", err.rel_mse);
    assert_true(err.rel_mse > 5.0 * small && err.rel_mse > 0.003);
    volux_image_free(ctx, &a);
    volux_image_free(ctx, &b);
    volux_image_free(ctx, &c);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

/* With albedo 0 nothing scatters and the emission term (Eq. 19) with
 * L_e = c is exactly emission–absorption: single, ao and ambient (with its
 * AO term on) must reproduce `ea` without pre-integration. */
static void test_emission_only_is_emission_absorption(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    volux_scene *s;
    assert_int_equal(volux_scene_load_string(ctx, SCENE, ".", "test", NULL, 0, &s), VOLUX_OK);
    volux_transfer_desc tf = *volux_scene_transfer(s);
    tf.albedo = 0.0f;
    assert_int_equal(volux_scene_set_transfer(s, &tf), VOLUX_OK);
    assert_int_equal(volux_scene_set_param(s, "ea", "preintegrate", 0, NULL), VOLUX_OK);
    assert_int_equal(volux_scene_set_param(s, "ambient", "ao", 0.5, NULL), VOLUX_OK);
    assert_int_equal(volux_scene_set_param(s, "ambient", "table_albedo", 0.5, NULL), VOLUX_OK);
    const char *names[] = {"single", "ao", "ambient"};
    for (int k = 0; k < 3; k++) assert_int_equal(volux_scene_set_param(s, names[k], "emission", 1, NULL), VOLUX_OK);
    volux_image ref = tu_render(ctx, s, "ea");
    double sum = 0.0;
    for (int i = 0; i < 32 * 32 * 3; i++) sum += ref.rgb[i];
    assert_true(sum > 1.0);
    for (int k = 0; k < 3; k++) {
        volux_image img = tu_render(ctx, s, names[k]);
        double worst = 0.0;
        for (int i = 0; i < 32 * 32 * 3; i++) worst = fmax(worst, fabs(img.rgb[i] - ref.rgb[i]));
        print_message("%s vs ea, emission only: max |diff| %.3g\n", names[k], worst);
        assert_true(worst < 1e-4);
        volux_image_free(ctx, &img);
    }
    volux_image_free(ctx, &ref);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

/* offset_mode "fill" integrates the lagged camera transmittance over each
 * step, ∫σt T(t − lag) dt: the image does not depend on the march step
 * even where the lag (≈ 0.75 mean free paths here) is shorter than a step.
 * Reading T(e − lag)·α instead (the other modes) loses up to a step of lag:
 * 0.5 → 0.25 voxel changes that image by a third in this medium (printed). */
static void test_fill_lag_does_not_depend_on_the_step(void **state) {
    (void)state;
    static const char dense[] =
        "{\"volume\": {\"procedural\": \"phantom\", \"dims\": [32, 32, 32]},"
        " \"transfer_function\": {\"extinction\": [[0, 0], [50, 0], [60, 2.3], [255, 2.3]],"
        "   \"color\": [[0, 0.9, 0.8, 0.7], [255, 0.9, 0.8, 0.7]], \"albedo\": 0.9},"
        " \"camera\": {\"orbit\": {\"azimuth\": 30, \"elevation\": 25}, \"fov_y\": 30},"
        " \"lights\": [{\"type\": \"directional\", \"direction\": [-0.5, -0.7, -0.5], \"irradiance\": 3}],"
        " \"render\": {\"width\": 32, \"height\": 32, \"spp\": 1, \"step\": 0.5},"
        " \"techniques\": {\"ambient\": {\"radius\": 4, \"offset_mode\": \"fill\"}}}";
    volux_context *ctx = tu_context(2);
    volux_scene *s;
    assert_int_equal(volux_scene_load_string(ctx, dense, ".", "test", NULL, 0, &s), VOLUX_OK);
    double m[2][2];
    for (int mode = 0; mode < 2; mode++) {
        assert_int_equal(volux_scene_set_param(s, "ambient", "offset_mode", 0, mode ? "adaptive" : "fill"), VOLUX_OK);
        for (int k = 0; k < 2; k++) {
            volux_render_settings r = *volux_scene_render(s);
            r.step = k ? 0.25f : 0.5f;
            assert_int_equal(volux_scene_set_render(s, &r), VOLUX_OK);
            volux_image im = tu_render(ctx, s, "ambient");
            m[mode][k] = tu_mean_luminance(&im);
            volux_image_free(ctx, &im);
        }
    }
    print_message("mean luminance at step 0.5 / 0.25: fill %.4g / %.4g, adaptive %.4g / %.4g\n", m[0][0], m[0][1],
                  m[1][0], m[1][1]);
    assert_true(m[0][0] > 0.0);
    assert_true(fabs(m[0][0] / m[0][1] - 1.0) < 0.04);
    assert_int_equal(volux_scene_set_param(s, "ambient", "offset_mode", 0, "lagged"), VOLUX_OK);
    volux_technique *t;
    volux_context_clear_error(ctx);
    assert_int_equal(volux_technique_create(ctx, "ambient", s, &t), VOLUX_ERR_INVALID);
    assert_non_null(strstr(volux_context_error(ctx), "techniques.ambient.offset_mode"));
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_small_radius_tends_to_single_scattering),
        cmocka_unit_test(test_emission_only_is_emission_absorption),
        cmocka_unit_test(test_fill_lag_does_not_depend_on_the_step),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
