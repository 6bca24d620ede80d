/* `ea` and `shaded`: empty-space skipping never changes the image (the
 * technique × edit matrix covers update, threads and accumulation). */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "test_util.h"

static const char *scene_json =
    "{\"volume\": {\"procedural\": \"cloud\", \"dims\": [40, 32, 36]},"
    " \"transfer_function\": {\"opacity\": [[0, 0], [90, 0], [140, 0.4], [255, 0.9]],"
    "   \"color\": [[0, 0.2, 0.4, 1], [140, 1, 0.8, 0.3], [255, 1, 1, 1]]},"
    " \"camera\": {\"orbit\": {\"azimuth\": 35, \"elevation\": 25}},"
    " \"lights\": [{\"type\": \"directional\", \"direction\": [-1, -1, -0.5], \"irradiance\": 2},"
    "              {\"type\": \"spot\", \"position\": [40, 30, 40], \"direction\": [-1, -0.7, -1],"
    "               \"intensity\": 3000, \"cone_angle\": 25, \"color\": [1, 0.6, 0.3]},"
    "              {\"type\": \"environment\", \"radiance\": 0.3, \"visible\": false}],"
    " \"background\": [0.1, 0.1, 0.1], \"render\": {\"width\": 37, \"height\": 29, \"spp\": 2}}";

static const char *techniques[] = {"ea", "shaded"};

/* Segments lie at fixed positions, so skipping empty macrocells must give
 * the very same pixels. */
static void test_empty_space_skipping_is_exact(void **state) {
    (void)state;
    for (int t = 0; t < 2; t++)
        for (int preint = 0; preint < 2; preint++) {
            volux_context *ctx = tu_context(2);
            volux_scene *s = tu_scene(ctx, scene_json);
            volux_scene_set_param(s, techniques[t], "preintegrate", preint, NULL);
            volux_image a = tu_render(ctx, s, techniques[t]);
            volux_scene_set_param(s, techniques[t], "skip_empty", 0, NULL);
            volux_image b = tu_render(ctx, s, techniques[t]);
            double d = tu_max_abs_diff(&a, &b);
            if (d > 1e-6) fail_msg("%s preint=%d: skipping changed pixels by %g", techniques[t], preint, d);
            volux_image_free(ctx, &a);
            volux_image_free(ctx, &b);
            volux_scene_destroy(s);
            volux_context_destroy(ctx);
        }
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_empty_space_skipping_is_exact),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
