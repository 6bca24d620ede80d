/*
 * tests/invariants/test_scatter_edits.c — `single`, `ao` and `ambient` do
 * the least work per edit (Ament et al. 2013, Table 1: a phase or light
 * edit touches only the radiance caches, a camera edit nothing), asserted
 * by their build counters; bad parameters are named. Incremental == fresh
 * and thread independence: tests/invariants/test_technique_matrix.c.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "render/technique_class.h"
#include "techniques/ambient/ambient.h"
#include "techniques/ao/ao.h"
#include "techniques/single/single.h"
#include "test_util.h"

static const char *SCENE =
    "{\"volume\": {\"procedural\": \"phantom\", \"dims\": [24, 24, 24]},"
    " \"transfer_function\": {\"color\": [[0, 0.9, 0.6, 0.4], [255, 1, 1, 1]],"
    "   \"opacity\": [[0, 0], [40, 0], [80, 0.1], [255, 0.6]], \"albedo\": 0.9, \"anisotropy\": 0.3},"
    " \"camera\": {\"orbit\": {\"azimuth\": 30, \"elevation\": 20}, \"fov_y\": 30},"
    " \"lights\": [{\"type\": \"directional\", \"direction\": [-0.5, -0.7, -0.5], \"irradiance\": 2},"
    "   {\"type\": \"point\", \"position\": [20, 10, 30], \"intensity\": 500},"
    "   {\"type\": \"spot\", \"position\": [-20, 15, 10], \"direction\": [1, -0.5, -0.3], \"intensity\": 400}],"
    " \"render\": {\"width\": 20, \"height\": 20, \"spp\": 1},"
    " \"techniques\": {\"ambient\": {\"table_theta\": 16, \"table_sigma\": 16, \"table_g\": 5, \"table_paths\": 64,"
    "   \"radius\": 3, \"specular\": true},"
    "   \"ao\": {\"radius\": 4}, \"single\": {\"cache_scale\": 0.5}}}";

static volux_scene *load(volux_context *ctx) {
    volux_scene *s;
    if (volux_scene_load_string(ctx, SCENE, ".", "test", NULL, 0, &s) != VOLUX_OK)
        fail_msg("scene: %s", volux_context_error(ctx));
    return s;
}

static void edit_opacity(volux_scene *s, float f) {
    const volux_transfer_desc *cur = volux_scene_transfer(s);
    volux_transfer_desc d = *cur;
    volux_tf_scalar_point op[16];
    memcpy(op, cur->opacity, sizeof *op * (size_t)cur->n_opacity);
    for (int i = 0; i < d.n_opacity; i++) op[i].v *= f;
    d.opacity = op;
    assert_int_equal(volux_scene_set_transfer(s, &d), VOLUX_OK);
}

static void edit_tf_field(volux_scene *s, int which) {
    volux_transfer_desc d = *volux_scene_transfer(s);
    volux_tf_color_point col[16];
    memcpy(col, d.color, sizeof *col * (size_t)d.n_color);
    d.color = col;
    if (which == 0) col[0].r = 0.2f;        /* colour only */
    else if (which == 1) d.density_scale = 1.7f;
    else if (which == 2) d.anisotropy = -0.4f; /* phase */
    else d.albedo = 0.8f;
    assert_int_equal(volux_scene_set_transfer(s, &d), VOLUX_OK);
}

/* The per-slot counters of ambient's first three light slots. */
typedef struct slot_counts {
    uint64_t builds[3], resums[3];
} slot_counts;

static slot_counts counts_of(const ambient_state *st) {
    slot_counts c;
    assert_true(st->slot_cap >= 3);
    for (int i = 0; i < 3; i++) c.builds[i] = st->slot[i].cache_builds, c.resums[i] = st->slot[i].cache_resums;
    return c;
}

/* Least work, read from the techniques' own counters. */
static void test_ambient_edits_do_least_work(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    volux_scene *s = load(ctx);
    volux_technique *t;
    assert_int_equal(volux_technique_create(ctx, "ambient", s, &t), VOLUX_OK);
    const ambient_state *st = volux_technique_state(t);
    ambient_stats before = st->stats;
    slot_counts was = counts_of(st), now;
    /* camera: nothing */
    volux_camera_desc cam = *volux_scene_camera_desc(s);
    cam.elevation_deg += 10.0f;
    assert_int_equal(volux_scene_set_camera(s, &cam), VOLUX_OK);
    assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_OK);
    assert_memory_equal(&before, &st->stats, sizeof before);
    /* colour only: nothing */
    edit_tf_field(s, 0);
    assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_OK);
    assert_memory_equal(&before, &st->stats, sizeof before);
    /* light 1: its radiance cache only */
    volux_light_desc l = *volux_scene_light(s, 1);
    l.position.y += 3.0f;
    assert_int_equal(volux_scene_set_light(s, 1, &l), VOLUX_OK);
    assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_OK);
    now = counts_of(st);
    assert_true(now.builds[1] == was.builds[1] + 1);
    assert_true(now.builds[0] == was.builds[0]);
    assert_true(now.builds[2] == was.builds[2]);
    assert_true(st->stats.cache_builds == before.cache_builds + 1);
    assert_true(st->stats.sat_builds == before.sat_builds && st->stats.rho_builds == before.rho_builds);
    before = st->stats;
    was = now;
    /* phase: slice + every radiance cache re-summed from its kept geometry
     * (no march), no SAT / ambient extinction */
    edit_tf_field(s, 2);
    assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_OK);
    assert_true(st->stats.slice_builds == before.slice_builds + 1);
    now = counts_of(st);
    for (int i = 0; i < 3; i++) {
        assert_true(now.resums[i] == was.resums[i] + 1);
        assert_true(now.builds[i] == was.builds[i]);
    }
    assert_true(st->stats.cache_resums == before.cache_resums + 3);
    assert_true(st->stats.sat_builds == before.sat_builds && st->stats.rho_builds == before.rho_builds);
    assert_true(st->stats.table_loads == before.table_loads);
    before = st->stats;
    was = now;
    /* without the kept geometry a phase edit marches every cache */
    assert_int_equal(volux_scene_set_param(s, "ambient", "phase_cache", 0, NULL), VOLUX_OK);
    assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_OK);
    volux_transfer_desc td = *volux_scene_transfer(s);
    td.anisotropy = 0.3f;
    assert_int_equal(volux_scene_set_transfer(s, &td), VOLUX_OK);
    assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_OK);
    now = counts_of(st);
    for (int i = 0; i < 3; i++) {
        assert_true(now.builds[i] == was.builds[i] + 1);
        assert_true(now.resums[i] == was.resums[i]);
    }
    assert_int_equal(volux_scene_set_param(s, "ambient", "phase_cache", 1, NULL), VOLUX_OK);
    assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_OK);
    before = st->stats;
    was = counts_of(st);
    /* TF extinction: SAT, ambient extinction, all radiance caches */
    edit_opacity(s, 0.5f);
    assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_OK);
    assert_true(st->stats.sat_builds == before.sat_builds + 1 && st->stats.rho_builds == before.rho_builds + 1);
    now = counts_of(st);
    for (int i = 0; i < 3; i++) assert_true(now.builds[i] == was.builds[i] + 1);
    assert_true(st->stats.slice_builds == before.slice_builds);
    volux_technique_destroy(t);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

static void test_single_and_ao_edits_do_least_work(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    volux_scene *s = load(ctx);
    volux_technique *ts, *ta;
    assert_int_equal(volux_technique_create(ctx, "single", s, &ts), VOLUX_OK);
    assert_int_equal(volux_technique_create(ctx, "ao", s, &ta), VOLUX_OK);
    const single_state *ss = volux_technique_state(ts);
    const ao_state *as = volux_technique_state(ta);
    uint64_t c0 = ss->slot[0].cache_builds, c1 = ss->slot[1].cache_builds, sat = as->sat_builds;
    edit_tf_field(s, 2); /* phase: no cache work for either */
    volux_light_desc l = *volux_scene_light(s, 1);
    l.position.z += 2.0f;
    assert_int_equal(volux_scene_set_light(s, 1, &l), VOLUX_OK); /* light 1: single rebuilds its cache only */
    assert_int_equal(volux_technique_update(ts, s, NULL), VOLUX_OK);
    assert_int_equal(volux_technique_update(ta, s, NULL), VOLUX_OK);
    assert_true(ss->slot[0].cache_builds == c0 && ss->slot[1].cache_builds == c1 + 1);
    assert_true(as->sat_builds == sat);
    volux_technique_destroy(ts);
    volux_technique_destroy(ta);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

/* Bad parameters are refused with the parameter's name. */
static void test_bad_parameters_name_the_parameter(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_scene *s = load(ctx);
    volux_technique *t;
    assert_int_equal(volux_scene_set_param(s, "ambient", "radius", 0.1, NULL), VOLUX_OK);
    volux_context_clear_error(ctx);
    assert_int_equal(volux_technique_create(ctx, "ambient", s, &t), VOLUX_ERR_INVALID);
    assert_non_null(strstr(volux_context_error(ctx), "techniques.ambient.radius"));
    assert_int_equal(volux_scene_set_param(s, "ambient", "radius", 3, NULL), VOLUX_OK);
    assert_int_equal(volux_scene_set_param(s, "ambient", "table_file", 0, tu_temp_path("nope.vxat")), VOLUX_OK);
    volux_context_clear_error(ctx);
    assert_int_equal(volux_technique_create(ctx, "ambient", s, &t), VOLUX_ERR_IO);
    assert_non_null(strstr(volux_context_error(ctx), "nope.vxat"));
    assert_int_equal(volux_scene_set_param(s, "single", "cache_scale", 2, NULL), VOLUX_OK);
    volux_context_clear_error(ctx);
    assert_int_equal(volux_technique_create(ctx, "single", s, &t), VOLUX_ERR_INVALID);
    assert_non_null(strstr(volux_context_error(ctx), "techniques.single.cache_scale"));
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_ambient_edits_do_least_work),
        cmocka_unit_test(test_single_and_ao_edits_do_least_work),
        cmocka_unit_test(test_bad_parameters_name_the_parameter),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
