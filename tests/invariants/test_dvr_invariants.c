/* `ea` and `shaded`: thread-count independence, incremental == fresh,
 * empty-space skipping never changes the image, progressive accumulation. */
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

static void test_thread_count_does_not_change_pixels(void **state) {
    (void)state;
    for (int t = 0; t < 2; t++) {
        volux_context *c1 = tu_context(1), *c2 = tu_context(2);
        volux_scene *s1 = tu_scene(c1, scene_json), *s2 = tu_scene(c2, scene_json);
        volux_image a = tu_render(c1, s1, techniques[t]), b = tu_render(c2, s2, techniques[t]);
        assert_memory_equal(a.rgb, b.rgb, sizeof(float) * 3 * 37 * 29);
        volux_image_free(c1, &a);
        volux_image_free(c2, &b);
        volux_scene_destroy(s1);
        volux_scene_destroy(s2);
        volux_context_destroy(c1);
        volux_context_destroy(c2);
    }
}

typedef void (*edit_fn)(volux_scene *s);

static void edit_tf(volux_scene *s) {
    volux_transfer_desc d = *volux_scene_transfer(s);
    volux_tf_scalar_point op[2] = {{0, 0}, {255, 0.3f}};
    d.opacity = op, d.n_opacity = 2;
    assert_int_equal(volux_scene_set_transfer(s, &d), VOLUX_OK);
}
static void edit_color(volux_scene *s) {
    volux_transfer_desc d = *volux_scene_transfer(s);
    volux_tf_color_point c[2] = {{0, 0, 1, 0}, {255, 1, 0, 1}};
    d.color = c, d.n_color = 2;
    d.material.specular = 0.8f;
    assert_int_equal(volux_scene_set_transfer(s, &d), VOLUX_OK);
}
static void edit_density(volux_scene *s) {
    volux_transfer_desc d = *volux_scene_transfer(s);
    d.density_scale = 0.4f;
    assert_int_equal(volux_scene_set_transfer(s, &d), VOLUX_OK);
}
static void edit_camera(volux_scene *s) {
    volux_camera_desc d = *volux_scene_camera_desc(s);
    d.azimuth_deg = -60;
    d.projection = VOLUX_ORTHOGRAPHIC;
    assert_int_equal(volux_scene_set_camera(s, &d), VOLUX_OK);
}
static void edit_light(volux_scene *s) {
    volux_light_desc d = *volux_scene_light(s, 0);
    d.direction = (volux_vec3){1, -0.2f, 0.3f};
    assert_int_equal(volux_scene_set_light(s, 0, &d), VOLUX_OK);
    assert_int_equal(volux_scene_set_light_enabled(s, 1, 0), VOLUX_OK);
}
static void edit_params(volux_scene *s) {
    assert_int_equal(volux_scene_set_param(s, "ea", "preintegrate", 0, NULL), VOLUX_OK);
    assert_int_equal(volux_scene_set_param(s, "shaded", "preintegrate", 0, NULL), VOLUX_OK);
    assert_int_equal(volux_scene_set_param(s, "shaded", "gradient_threshold", 0.1, NULL), VOLUX_OK);
}
static void edit_render(volux_scene *s) {
    volux_render_settings r = *volux_scene_render(s);
    r.step = 0.8f;
    r.width = 20;
    r.seed = 9;
    assert_int_equal(volux_scene_set_render(s, &r), VOLUX_OK);
}
static void edit_volume(volux_scene *s) {
    int dims[3] = {30, 30, 30};
    volux_volume *v;
    assert_int_equal(volux_volume_procedural(volux_scene_context(s), "phantom", dims, 1, &v), VOLUX_OK);
    assert_int_equal(volux_scene_set_volume(s, v), VOLUX_OK);
    volux_volume_release(v);
}

/* Built before the edit and updated == built after the edit (STYLE §5.6). */
static void test_incremental_update_equals_fresh_build(void **state) {
    (void)state;
    static const struct {
        const char *name;
        edit_fn fn;
    } edits[] = {{"tf", edit_tf},         {"color", edit_color},   {"density", edit_density},
                 {"camera", edit_camera}, {"light", edit_light},   {"params", edit_params},
                 {"render", edit_render}, {"volume", edit_volume}};
    for (int t = 0; t < 2; t++)
        for (size_t e = 0; e < sizeof edits / sizeof edits[0]; e++) {
            volux_context *ctx = tu_context(2);
            volux_scene *s = tu_scene(ctx, scene_json);
            volux_technique *tech;
            assert_int_equal(volux_technique_create(ctx, techniques[t], s, &tech), VOLUX_OK);
            volux_image before = tu_render_with(ctx, s, tech);
            edits[e].fn(s);
            assert_int_equal(volux_technique_update(tech, s, NULL), VOLUX_OK);
            volux_image inc = tu_render_with(ctx, s, tech);
            volux_image fresh = tu_render(ctx, s, techniques[t]);
            if (tu_max_abs_diff(&inc, &fresh) != 0.0)
                fail_msg("%s after edit %s differs from a fresh build by %g", techniques[t], edits[e].name,
                         tu_max_abs_diff(&inc, &fresh));
            /* and the edit did change something (the test is not vacuous);
             * `ea` ignores lights by definition */
            int lights_only = !strcmp(edits[e].name, "light");
            if (before.width == inc.width && !(t == 0 && lights_only) && tu_max_abs_diff(&before, &inc) == 0.0)
                fail_msg("%s: edit %s changed nothing", techniques[t], edits[e].name);
            volux_image_free(ctx, &before);
            volux_image_free(ctx, &inc);
            volux_image_free(ctx, &fresh);
            volux_technique_destroy(tech);
            volux_scene_destroy(s);
            volux_context_destroy(ctx);
        }
}

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

/* Two calls of 2 spp accumulate exactly like one call of 4 spp. */
static void test_progressive_accumulation_is_order_free(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    volux_scene *s = tu_scene(ctx, scene_json);
    volux_technique *t;
    assert_int_equal(volux_technique_create(ctx, "ea", s, &t), VOLUX_OK);
    volux_framebuffer *a, *b;
    assert_int_equal(volux_framebuffer_create(ctx, 37, 29, &a), VOLUX_OK);
    assert_int_equal(volux_framebuffer_create(ctx, 37, 29, &b), VOLUX_OK);
    volux_render_limits two = {2, 0, 0}, four = {4, 0, 0};
    assert_int_equal(volux_render(t, s, a, &two, NULL), VOLUX_OK);
    assert_int_equal(volux_render(t, s, a, &four, NULL), VOLUX_OK);
    assert_int_equal(volux_render(t, s, b, &four, NULL), VOLUX_OK);
    assert_int_equal(volux_framebuffer_spp(a), 4);
    volux_image ia, ib;
    assert_int_equal(volux_framebuffer_resolve(a, &ia), VOLUX_OK);
    assert_int_equal(volux_framebuffer_resolve(b, &ib), VOLUX_OK);
    assert_memory_equal(ia.rgb, ib.rgb, sizeof(float) * 3 * 37 * 29);
    volux_image_free(ctx, &ia);
    volux_image_free(ctx, &ib);
    volux_framebuffer_destroy(a);
    volux_framebuffer_destroy(b);
    volux_technique_destroy(t);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_thread_count_does_not_change_pixels),
        cmocka_unit_test(test_incremental_update_equals_fresh_build),
        cmocka_unit_test(test_empty_space_skipping_is_exact),
        cmocka_unit_test(test_progressive_accumulation_is_order_free),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
