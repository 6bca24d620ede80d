/*
 * render.max_depth = 0 means "no scattering" (issue 16): the path tracer's
 * camera paths end at their first real collision, so the medium only
 * absorbs. That is the same estimator as albedo 0 (every collision
 * absorbs) with the same random numbers up to the collision, so the two
 * images must be bit-identical; and with scattering allowed (max_depth 1,
 * albedo 0.9) the image must be brighter somewhere (the test can fail).
 */
#include <stdio.h>
#include <string.h>

#include "test_util.h"

static volux_image render(volux_context *ctx, int max_depth, double albedo) {
    char json[1024];
    snprintf(json, sizeof json,
             "{\"volume\": {\"procedural\": \"cloud\", \"dims\": [20, 20, 20]},"
             " \"transfer_function\": {\"opacity\": [[0, 0], [255, 0.6]], \"albedo\": %g},"
             " \"lights\": [{\"type\": \"directional\", \"direction\": [-0.3, -1, -0.2], \"irradiance\": 3},"
             "   {\"type\": \"environment\", \"radiance\": 0.4}],"
             " \"camera\": {\"orbit\": {\"azimuth\": 30, \"elevation\": 20}, \"fov_y\": 35},"
             " \"render\": {\"technique\": \"pathtrace\", \"width\": 24, \"height\": 20, \"spp\": 4,"
             "   \"max_depth\": %d, \"threads\": 2}}",
             albedo, max_depth);
    volux_scene *s = tu_scene(ctx, json);
    volux_image img = tu_render(ctx, s, NULL);
    volux_scene_destroy(s);
    return img;
}

static void test_max_depth_zero_is_absorption_only(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    volux_image none = render(ctx, 0, 0.9), black = render(ctx, 64, 0.0), one = render(ctx, 1, 0.9);
    assert_int_equal(memcmp(none.rgb, black.rgb, sizeof(float) * 3 * (size_t)none.width * (size_t)none.height), 0);
    double gain = 0.0;
    for (int i = 0; i < 3 * one.width * one.height; i++)
        if (one.rgb[i] - none.rgb[i] > gain) gain = one.rgb[i] - none.rgb[i];
    printf("  largest gain of single scattering over max_depth 0: %g\n", gain);
    assert_true(gain > 1e-3);
    volux_image_free(ctx, &none);
    volux_image_free(ctx, &black);
    volux_image_free(ctx, &one);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_max_depth_zero_is_absorption_only)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
