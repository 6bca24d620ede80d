/* Scene versions: each setter bumps only the aspects it really changed. */
#include <string.h>

#include "test_util.h"

static volux_scene *scene_with_volume(volux_context *ctx) {
    volux_scene *s;
    assert_int_equal(volux_scene_create(ctx, &s), VOLUX_OK);
    int dims[3] = {8, 8, 8};
    volux_volume *v;
    assert_int_equal(volux_volume_procedural(ctx, "sphere", dims, 1, &v), VOLUX_OK);
    assert_int_equal(volux_scene_set_volume(s, v), VOLUX_OK);
    volux_volume_release(v);
    return s;
}

static uint32_t changes(volux_scene *s, volux_scene_stamp *seen) {
    volux_change_set c = volux_scene_changes_since(s, seen);
    *seen = volux_scene_stamp_now(s);
    return c.what;
}

static void test_transfer_edits_are_classified(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_scene *s = scene_with_volume(ctx);
    volux_scene_stamp seen = volux_scene_stamp_now(s);
    volux_transfer_desc d = *volux_scene_transfer(s);
    volux_tf_scalar_point op[2] = {{0, 0}, {255, 0.5f}};
    volux_tf_color_point col[2] = {{0, 1, 0, 0}, {255, 0, 0, 1}};
    d.opacity = op, d.n_opacity = 2, d.color = col, d.n_color = 2;
    assert_int_equal(volux_scene_set_transfer(s, &d), VOLUX_OK);
    assert_int_equal(changes(s, &seen), VOLUX_CHANGE_EXTINCTION | VOLUX_CHANGE_COLOR);
    col[1].g = 0.5f; /* colour only */
    assert_int_equal(volux_scene_set_transfer(s, &d), VOLUX_OK);
    assert_int_equal(changes(s, &seen), VOLUX_CHANGE_COLOR);
    d.density_scale = 2;
    assert_int_equal(volux_scene_set_transfer(s, &d), VOLUX_OK);
    assert_int_equal(changes(s, &seen), VOLUX_CHANGE_DENSITY);
    d.anisotropy = 0.5f;
    assert_int_equal(volux_scene_set_transfer(s, &d), VOLUX_OK);
    assert_int_equal(changes(s, &seen), VOLUX_CHANGE_PHASE);
    assert_int_equal(volux_scene_set_transfer(s, &d), VOLUX_OK); /* no change at all */
    assert_int_equal(changes(s, &seen), 0);
    /* an invalid edit leaves the scene untouched */
    op[1].v = 2.0f;
    assert_int_equal(volux_scene_set_transfer(s, &d), VOLUX_ERR_INVALID);
    assert_int_equal(changes(s, &seen), 0);
    assert_near(volux_scene_transfer(s)->opacity[1].v, 0.5, 0);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

static void test_lights_report_their_slot(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_scene *s = scene_with_volume(ctx);
    volux_light_desc l;
    volux_light_desc_defaults(&l, VOLUX_LIGHT_POINT);
    assert_int_equal(volux_scene_set_light(s, 0, &l), VOLUX_OK);
    assert_int_equal(volux_scene_set_light(s, 5, &l), VOLUX_OK);
    assert_int_equal(volux_scene_light_slots(s), 6);
    volux_scene_stamp seen = volux_scene_stamp_now(s);
    assert_int_equal(volux_scene_set_light_enabled(s, 5, 0), VOLUX_OK);
    volux_change_set c = volux_scene_changes_since(s, &seen);
    assert_int_equal(c.what, VOLUX_CHANGE_LIGHTS);
    assert_true(volux_change_light(&c, 5) && !volux_change_light(&c, 0));
    assert_int_equal(volux_scene_remove_light(s, 5), VOLUX_OK);
    assert_int_equal(volux_scene_light_slots(s), 1);
    assert_null(volux_scene_light(s, 5));
    assert_int_equal(volux_scene_remove_light(s, 5), VOLUX_ERR_INVALID);
    l.intensity = -1;
    volux_context_clear_error(ctx);
    assert_int_equal(volux_scene_set_light(s, 1, &l), VOLUX_ERR_INVALID);
    assert_non_null(strstr(volux_context_error(ctx), "lights[1].intensity"));
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

static void test_other_aspects(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_scene *s = scene_with_volume(ctx);
    volux_scene_stamp seen = volux_scene_stamp_now(s);
    volux_camera_desc cam = *volux_scene_camera_desc(s);
    cam.azimuth_deg += 10;
    assert_int_equal(volux_scene_set_camera(s, &cam), VOLUX_OK);
    assert_int_equal(changes(s, &seen), VOLUX_CHANGE_CAMERA);
    volux_render_settings r = *volux_scene_render(s);
    r.threads = 2; /* does not change pixels */
    assert_int_equal(volux_scene_set_render(s, &r), VOLUX_OK);
    assert_int_equal(changes(s, &seen), 0);
    r.width = 17;
    assert_int_equal(volux_scene_set_render(s, &r), VOLUX_OK);
    assert_int_equal(changes(s, &seen), VOLUX_CHANGE_RENDER);
    assert_int_equal(volux_scene_set_param(s, "ea", "preintegrate", 0, NULL), VOLUX_OK);
    assert_int_equal(changes(s, &seen), VOLUX_CHANGE_PARAMS);
    assert_near(volux_scene_param(s, "ea", "preintegrate", 1), 0, 0);
    assert_near(volux_scene_param(s, "ea", "missing", 42), 42, 0);
    volux_scene_set_volume(s, volux_scene_volume(s));
    assert_int_equal(changes(s, &seen), VOLUX_CHANGE_VOLUME);
    /* a stamp from another scene means everything changed */
    volux_scene *other = scene_with_volume(ctx);
    volux_scene_stamp foreign = volux_scene_stamp_now(other);
    assert_int_equal(volux_scene_changes_since(s, &foreign).what, VOLUX_CHANGE_ALL);
    volux_scene_destroy(other);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_transfer_edits_are_classified),
        cmocka_unit_test(test_lights_report_their_slot),
        cmocka_unit_test(test_other_aspects),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
