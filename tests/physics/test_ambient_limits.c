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

static volux_image render(volux_context *ctx, volux_scene *s, const char *name) {
    volux_technique *t;
    if (volux_technique_create(ctx, name, s, &t) != VOLUX_OK) fail_msg("%s: %s", name, volux_context_error(ctx));
    volux_framebuffer *fb;
    assert_int_equal(volux_framebuffer_create(ctx, 32, 32, &fb), VOLUX_OK);
    assert_int_equal(volux_render(t, s, fb, NULL, NULL), VOLUX_OK);
    volux_image img;
    assert_int_equal(volux_framebuffer_resolve(fb, &img), VOLUX_OK);
    volux_framebuffer_destroy(fb);
    volux_technique_destroy(t);
    return img;
}

static void test_small_radius_tends_to_single_scattering(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    volux_scene *s;
    assert_int_equal(volux_scene_load_string(ctx, SCENE, ".", "test", NULL, 0, &s), VOLUX_OK);
    volux_image a = render(ctx, s, "ambient"), b = render(ctx, s, "single");
    volux_image_error err;
    assert_int_equal(volux_image_compare(ctx, &a, &b, &err), VOLUX_OK);
    print_message("ambient (r = 0.5 voxel) vs single: rel_mse %.4g\n", err.rel_mse);
    assert_true(err.rel_mse < 0.01);
    double small = err.rel_mse;
    /* A larger radius scatters more light around: the images part (by
     * 0.033 with the adaptive x_o, 50x the small radius's 0.00066; by 0.05
     * with the paper's constant one, which over-counts dense parts). */
    assert_int_equal(volux_scene_set_param(s, "ambient", "radius", 6, NULL), VOLUX_OK);
    volux_image c = render(ctx, s, "ambient");
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
    volux_image ref = render(ctx, s, "ea");
    double sum = 0.0;
    for (int i = 0; i < 32 * 32 * 3; i++) sum += ref.rgb[i];
    assert_true(sum > 1.0);
    for (int k = 0; k < 3; k++) {
        volux_image img = render(ctx, s, names[k]);
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

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_small_radius_tends_to_single_scattering),
        cmocka_unit_test(test_emission_only_is_emission_absorption),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
