/*
 * Scenes with many lights (issue 16 item 6): the slot table grows with
 * the scene up to VOLUX_MAX_LIGHTS (2^20), stamps and change sets stay
 * fixed-size (one light edit counter), and every path that grows per-slot
 * memory reports NOMEM without a leak or a half-changed scene.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "test_util.h"
#include "tu_volume.h"

#define MANY 65536

/* A scene JSON of n point lights on a ring; light i sits at x = i. */
static char *many_lights_json(int n) {
    size_t cap = (size_t)n * 96 + 512;
    char *s = malloc(cap), *p = s;
    assert_non_null(s);
    p += sprintf(p, "{\"volume\": {\"procedural\": \"sphere\", \"dims\": [8, 8, 8]},"
                    " \"transfer_function\": {\"opacity\": [[0, 0], [1, 0.5]]}, \"lights\": [");
    for (int i = 0; i < n; i++)
        p += sprintf(p, "%s{\"type\": \"point\", \"position\": [%d, 40, 3], \"intensity\": 0.5}", i ? "," : "", i);
    sprintf(p, "]}");
    return s;
}

static void test_65536_point_lights_load(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    char *json = many_lights_json(MANY);
    volux_scene *s = NULL;
    assert_int_equal(volux_scene_load_string(ctx, json, NULL, "many.json", NULL, 0, &s), VOLUX_OK);
    free(json);
    assert_int_equal(volux_scene_light_slots(s), MANY);
    for (int i = 0; i < MANY; i += 4099) {
        const volux_light_desc *d = volux_scene_light(s, i);
        assert_non_null(d);
        assert_int_equal(d->type, VOLUX_LIGHT_POINT);
        assert_true(d->position.x == (float)i && d->position.y == 40.0f && d->intensity == 0.5f);
    }
    assert_null(volux_scene_light(s, MANY));
    /* a technique prepares all of them (shaded's update reads every light) */
    volux_technique *t = NULL;
    assert_int_equal(volux_technique_create(ctx, "shaded", s, &t), VOLUX_OK);
    volux_technique_destroy(t);
    volux_scene_destroy(s);
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

/* Counts the slots the change set marks, over the whole table and a bit past it. */
static int marked(const volux_change_set *c, int slots) {
    int n = 0;
    for (int i = 0; i < slots + 64; i++) n += volux_change_light(c, i);
    return n;
}

static void test_an_edit_marks_exactly_its_slot(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    char *json = many_lights_json(MANY);
    volux_scene *s = NULL, *other = NULL;
    assert_int_equal(volux_scene_load_string(ctx, json, NULL, "many.json", NULL, 0, &s), VOLUX_OK);
    free(json);
    /* nothing changed since now */
    volux_scene_stamp seen = volux_scene_stamp_now(s);
    volux_change_set c = volux_scene_changes_since(s, &seen);
    assert_int_equal(c.what, 0);
    assert_int_equal(marked(&c, MANY), 0);
    assert_int_equal(volux_change_light_count(&c), 0);
    /* light 40 000: that slot only */
    volux_light_desc d = *volux_scene_light(s, 40000);
    d.intensity *= 2.0f;
    assert_int_equal(volux_scene_set_light(s, 40000, &d), VOLUX_OK);
    c = volux_scene_changes_since(s, &seen);
    assert_int_equal(c.what, VOLUX_CHANGE_LIGHTS);
    assert_true(volux_change_light(&c, 40000));
    assert_false(volux_change_light(&c, 39999) || volux_change_light(&c, 40001));
    assert_int_equal(marked(&c, MANY), 1);
    assert_int_equal(volux_change_light_count(&c), 1);
    /* N edits of the same slot are still one slot; a second slot adds one */
    for (int k = 0; k < 5; k++) assert_int_equal(volux_scene_set_light_enabled(s, 40000, k & 1), VOLUX_OK);
    assert_int_equal(volux_scene_set_light_enabled(s, 7, 0), VOLUX_OK);
    c = volux_scene_changes_since(s, &seen);
    assert_int_equal(marked(&c, MANY), 2);
    /* removing the top light: its slot changed, the table ends below it */
    seen = volux_scene_stamp_now(s);
    assert_int_equal(volux_scene_remove_light(s, MANY - 1), VOLUX_OK);
    assert_int_equal(volux_scene_light_slots(s), MANY - 1);
    c = volux_scene_changes_since(s, &seen);
    assert_true(volux_change_light(&c, MANY - 1));
    assert_int_equal(marked(&c, MANY), 1);
    /* a slot far past the table: added, marked, the table grows to it */
    seen = volux_scene_stamp_now(s);
    assert_int_equal(volux_scene_set_light(s, 300000, &d), VOLUX_OK);
    assert_int_equal(volux_scene_light_slots(s), 300001);
    c = volux_scene_changes_since(s, &seen);
    assert_int_equal(marked(&c, 300001), 1);
    assert_true(volux_change_light(&c, 300000));
    /* a stamp of another scene, and change_all: every slot */
    assert_int_equal(volux_scene_create(ctx, &other), VOLUX_OK);
    volux_scene_stamp foreign = volux_scene_stamp_now(other);
    c = volux_scene_changes_since(s, &foreign);
    assert_int_equal(c.what, VOLUX_CHANGE_ALL);
    assert_true(volux_change_light(&c, 0) && volux_change_light(&c, 123456) && volux_change_light(&c, 300000));
    assert_int_equal(volux_change_light_count(&c), -1);
    volux_change_set all = volux_change_all();
    assert_true(volux_change_light(&all, VOLUX_MAX_LIGHTS - 1));
    /* stamps stay small whatever the light count */
    assert_true(sizeof(volux_scene_stamp) <= 64 && sizeof(volux_change_set) <= 32);
    volux_scene_destroy(other);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

static void test_slot_cap_and_highest_slot(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_scene *s;
    assert_int_equal(volux_scene_create(ctx, &s), VOLUX_OK);
    volux_light_desc d;
    volux_light_desc_defaults(&d, VOLUX_LIGHT_POINT);
    assert_int_equal(volux_scene_set_light(s, VOLUX_MAX_LIGHTS, &d), VOLUX_ERR_LIMIT);
    tu_assert_error_mentions(ctx, "lights[1048576]", "at most 1048576", (const char *)NULL);
    assert_int_equal(volux_scene_set_light(s, -1, &d), VOLUX_ERR_INVALID);
    assert_int_equal(volux_scene_light_slots(s), 0);
    assert_int_equal(volux_scene_remove_light(s, 5), VOLUX_ERR_INVALID); /* past the table */
    /* one past the highest occupied slot, through sets and removals */
    const int set[] = {0, 5, 9};
    for (int i = 0; i < 3; i++) assert_int_equal(volux_scene_set_light(s, set[i], &d), VOLUX_OK);
    assert_int_equal(volux_scene_light_slots(s), 10);
    assert_int_equal(volux_scene_remove_light(s, 9), VOLUX_OK);
    assert_int_equal(volux_scene_light_slots(s), 6);
    assert_int_equal(volux_scene_remove_light(s, 0), VOLUX_OK);
    assert_int_equal(volux_scene_light_slots(s), 6);
    assert_int_equal(volux_scene_remove_light(s, 5), VOLUX_OK);
    assert_int_equal(volux_scene_light_slots(s), 0);
    /* an environment map survives the table moving under it, and a light
     * copied from the scene's own table into a slot that grows it */
    volux_image map;
    assert_int_equal(volux_image_create(ctx, 4, 2, &map), VOLUX_OK);
    for (int i = 0; i < 24; i++) map.rgb[i] = 0.25f * (float)i;
    volux_light_desc env;
    volux_light_desc_defaults(&env, VOLUX_LIGHT_ENVIRONMENT);
    env.map = &map;
    assert_int_equal(volux_scene_set_light(s, 1, &env), VOLUX_OK);
    volux_image_free(ctx, &map);
    assert_int_equal(volux_scene_set_light(s, 5000, volux_scene_light(s, 1)), VOLUX_OK);
    for (int slot = 1; slot <= 5000; slot += 4999) {
        const volux_image *m = volux_scene_light(s, slot)->map;
        assert_non_null(m);
        assert_int_equal(m->width, 4);
        for (int i = 0; i < 24; i++) assert_true(m->rgb[i] == 0.25f * (float)i);
    }
    volux_scene_destroy(s);
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

/* Every allocation of growing the slot table (set_light, assign, a JSON
 * load with 40 lights) fails once in turn: NOMEM with a message, the
 * lights set before intact, no leak. */
static void test_allocation_failures(void **state) {
    (void)state;
    volux_light_desc d;
    volux_light_desc_defaults(&d, VOLUX_LIGHT_POINT);
    int done = 0;
    long k;
    for (k = 1; !done; k++) {
        tu_alloc_stats stats = {0};
        volux_context *ctx = tu_context_counting(0, &stats);
        volux_scene *s, *copy;
        assert_int_equal(volux_scene_create(ctx, &s), VOLUX_OK);
        assert_int_equal(volux_scene_create(ctx, &copy), VOLUX_OK);
        stats.fail_at = stats.count + k;
        volux_status st = VOLUX_OK;
        int i;
        for (i = 0; i < 100 && !st; i++) {
            d.intensity = (float)(i + 1);
            st = volux_scene_set_light(s, 3 * i, &d);
        }
        int in_assign = !st;
        if (!st) st = volux_scene_assign(copy, s, 1);
        stats.fail_at = 0;
        if (st) {
            assert_int_equal(st, VOLUX_ERR_NOMEM);
            assert_true(volux_context_error(ctx)[0] != 0);
            /* what was set before the failure is intact, nothing after:
             * set_light i-1 failed (lights 0 .. i-2 are there), or assign
             * stopped at a light (a prefix of s's lights in copy) */
            volux_scene *check = in_assign ? copy : s;
            int n = in_assign ? (volux_scene_light_slots(copy) + 2) / 3 : i - 1;
            for (int j = 0; j < n; j++) {
                const volux_light_desc *l = volux_scene_light(check, 3 * j);
                assert_non_null(l);
                assert_true(l->intensity == (float)(j + 1));
                assert_null(volux_scene_light(check, 3 * j + 1));
            }
            assert_null(volux_scene_light(check, 3 * n));
            assert_int_equal(volux_scene_light_slots(check), n ? 3 * (n - 1) + 1 : 0);
        } else {
            done = 1;
            assert_int_equal(volux_scene_light_slots(copy), 298);
            volux_scene_stamp seen = volux_scene_stamp_now(copy);
            assert_int_equal(volux_scene_assign(copy, s, 1), VOLUX_OK); /* nothing differs: no change */
            volux_change_set c = volux_scene_changes_since(copy, &seen);
            assert_int_equal(c.what, 0);
        }
        volux_scene_destroy(copy);
        volux_scene_destroy(s);
        assert_int_equal(volux_context_bytes_in_use(ctx), 0);
        volux_context_destroy(ctx);
        assert_int_equal(stats.live, 0);
        assert_true(k < 1000);
    }
    print_message("set_light/assign survived %ld injected allocation failures\n", k - 2);

    char *json = many_lights_json(40);
    done = 0;
    for (k = 1; !done; k++) {
        tu_alloc_stats stats = {0};
        volux_context *ctx = tu_context_counting(0, &stats);
        stats.fail_at = stats.count + k;
        volux_scene *s = NULL;
        volux_status st = volux_scene_load_string(ctx, json, NULL, "many.json", NULL, 0, &s);
        stats.fail_at = 0;
        if (st) {
            assert_int_equal(st, VOLUX_ERR_NOMEM);
            assert_null(s);
            assert_true(volux_context_error(ctx)[0] != 0);
        } else {
            done = 1;
            assert_int_equal(volux_scene_light_slots(s), 40);
            volux_scene_destroy(s);
        }
        assert_int_equal(volux_context_bytes_in_use(ctx), 0);
        volux_context_destroy(ctx);
        assert_int_equal(stats.live, 0);
        assert_true(k < 10000);
    }
    free(json);
    print_message("a 40-light load survived %ld injected allocation failures\n", k - 2);
}

/* The CLI: a scene file one light over the cap is exit 2 naming the field,
 * before any light is read, and writes no image. */
static void test_cli_refuses_one_light_over_the_cap(void **state) {
    (void)state;
    size_t n = (size_t)VOLUX_MAX_LIGHTS + 1;
    char *json = malloc(3 * n + 128), *p = json;
    assert_non_null(json);
    p += sprintf(p, "{\"volume\": {\"procedural\": \"sphere\", \"dims\": [8, 8, 8]}, \"lights\": [");
    for (size_t i = 0; i < n; i++) p += sprintf(p, "%s{}", i ? "," : "");
    p += sprintf(p, "]}");
    const char *path = tu_write_file("over_cap.json", json, (size_t)(p - json));
    free(json);
    const char *out = tu_temp_path("over_cap.pfm");
    char cmd[2048];
    snprintf(cmd, sizeof cmd, "render '%s' -o '%s'", path, out);
    const char *err = NULL;
    int rc = tu_run_cli(cmd, &err);
    if (rc != 2 || !strstr(err, "lights: at most 1048576 lights, got 1048577"))
        fail_msg("volux %s: exit %d; stderr: %s", cmd, rc, err);
    FILE *f = fopen(out, "rb");
    assert_null(f);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_cli_refuses_one_light_over_the_cap),
        cmocka_unit_test(test_65536_point_lights_load),
        cmocka_unit_test(test_an_edit_marks_exactly_its_slot),
        cmocka_unit_test(test_slot_cap_and_highest_slot),
        cmocka_unit_test(test_allocation_failures),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
