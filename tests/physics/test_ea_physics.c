/* Emission–absorption against closed forms (DESIGN §2):
 * L = ∫ T σt c dx + T·background, T = exp(−σt·d) in a homogeneous box. */
#include <math.h>
#include <stdio.h>

#include "core/vecmath.h"
#include "test_util.h"

/* A 33³ box of constant density (float 1.0) → world box [−16, 16]³. */
static volux_scene *homogeneous(volux_context *ctx, double sigma, const char *color, const char *bg, double az,
                                int preint, double step) {
    char json[2048];
    snprintf(json, sizeof json,
             "{\"volume\": {\"procedural\": \"constant\", \"dims\": [33, 33, 33]},"
             " \"transfer_function\": {\"extinction\": [[0, %g], [2, %g]], \"color\": [[0, %s], [2, %s]]},"
             " \"camera\": {\"type\": \"orthographic\", \"orbit\": {\"azimuth\": %g, \"elevation\": 0}},"
             " \"background\": %s,"
             " \"render\": {\"width\": 9, \"height\": 9, \"step\": %g},"
             " \"techniques\": {\"ea\": {\"early_termination\": 0, \"preintegrate\": %s}}}",
             sigma, sigma, color, color, az, bg, step, preint ? "true" : "false");
    return tu_scene(ctx, json);
}

/* Length of the centre ray (through the box centre) at azimuth az. */
static double chord(double az_deg) {
    double a = fabs(az_deg) * M_PI / 180.0;
    return 32.0 / fmax(fabs(cos(a)), fabs(sin(a)));
}

static void test_beer_lambert_transmittance(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    const double sigmas[] = {0.01, 0.05, 0.2};
    const double azimuths[] = {0.0, 30.0};
    for (int p = 0; p < 2; p++)
        for (size_t i = 0; i < 3; i++)
            for (size_t a = 0; a < 2; a++) {
                /* black medium in front of a white background: pixel = T */
                volux_scene *s = homogeneous(ctx, sigmas[i], "0, 0, 0", "[1, 1, 1]", azimuths[a], p, 0.37);
                volux_image img = tu_render(ctx, s, "ea");
                double expect = exp(-sigmas[i] * chord(azimuths[a]));
                double got = tu_pixel(&img, 4, 4, 0);
                if (fabs(got - expect) > 0.005 * expect)
                    fail_msg("sigma %g az %g preint %d: T = %.6f, expected %.6f", sigmas[i], azimuths[a], p, got,
                             expect);
                volux_image_free(ctx, &img);
                volux_scene_destroy(s);
            }
    volux_context_destroy(ctx);
}

/* White emitting medium over black: pixel = 1 − T (the emission integral). */
static void test_emission_integral(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_scene *s = homogeneous(ctx, 0.03, "1, 0.5, 0.25", "[0, 0, 0]", 0.0, 1, 0.5);
    volux_image img = tu_render(ctx, s, "ea");
    double a = 1.0 - exp(-0.03 * 32.0);
    assert_near(tu_pixel(&img, 4, 4, 0), a, 0.005 * a);
    assert_near(tu_pixel(&img, 4, 4, 1), 0.5 * a, 0.005 * a);
    assert_near(tu_pixel(&img, 4, 4, 2), 0.25 * a, 0.005 * a);
    volux_image_free(ctx, &img);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

/* A fully transparent TF shows exactly the background, for both techniques. */
static void test_transparent_tf_gives_background(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    const char *json =
        "{\"volume\": {\"procedural\": \"cloud\", \"dims\": [24, 24, 24]},"
        " \"transfer_function\": {\"opacity\": [[0, 0], [255, 0]], \"color\": [[0, 1, 0, 0], [255, 0, 1, 0]]},"
        " \"lights\": [{\"type\": \"directional\", \"direction\": [0, -1, 0], \"irradiance\": 3}],"
        " \"background\": [0.25, 0.5, 0.75], \"render\": {\"width\": 16, \"height\": 12}}";
    volux_scene *s = tu_scene(ctx, json);
    const char *techniques[] = {"ea", "shaded"};
    for (int t = 0; t < 2; t++) {
        volux_image img = tu_render(ctx, s, techniques[t]);
        for (int y = 0; y < 12; y++)
            for (int x = 0; x < 16; x++) {
                assert_true(tu_pixel(&img, x, y, 0) == 0.25f);
                assert_true(tu_pixel(&img, x, y, 1) == 0.5f);
                assert_true(tu_pixel(&img, x, y, 2) == 0.75f);
            }
        volux_image_free(ctx, &img);
    }
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

/* A visible environment replaces the background for escaping rays. */
static void test_environment_is_seen_by_camera_rays(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    const char *json =
        "{\"volume\": {\"procedural\": \"constant\", \"dims\": [8, 8, 8]},"
        " \"transfer_function\": {\"opacity\": [[0, 0], [2, 0]]},"
        " \"lights\": [{\"type\": \"environment\", \"radiance\": 2, \"color\": [1, 0.5, 0.25]}],"
        " \"background\": [9, 9, 9], \"render\": {\"width\": 4, \"height\": 4}}";
    volux_scene *s = tu_scene(ctx, json);
    volux_image img = tu_render(ctx, s, "ea");
    assert_near(tu_pixel(&img, 0, 0, 0), 2.0, 1e-6);
    assert_near(tu_pixel(&img, 3, 3, 2), 0.5, 1e-6);
    volux_image_free(ctx, &img);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_beer_lambert_transmittance),
        cmocka_unit_test(test_emission_integral),
        cmocka_unit_test(test_transparent_tf_gives_background),
        cmocka_unit_test(test_environment_is_seen_by_camera_rays),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
