/*
 * tests/physics/test_single_env.c — `single`'s environment lights: the
 * env_directions directional lights carry exactly the environment's energy
 * (Σ_k E_k = ∫ L dω: 4π·L for a constant sky, the texel sum for a map, a
 * one-texel map landing whole in the direction nearest to that texel), and
 * env_directions = 0 warns once about the ignored light.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "techniques/single/single.h"
#include "test_util.h"

static const char *SCENE_FMT =
    "{\"volume\": {\"procedural\": \"sphere\", \"dims\": [12, 12, 12]},"
    " \"transfer_function\": {\"extinction\": [[0, 0], [255, 0.2]], \"albedo\": 0.8},"
    " \"lights\": [{\"type\": \"directional\", \"direction\": [0, -1, 0], \"irradiance\": 1}, %s],"
    " \"render\": {\"width\": 8, \"height\": 8}, \"techniques\": {\"single\": {\"env_directions\": %d}}}";

static volux_scene *load(volux_context *ctx, const char *env, int dirs) {
    char json[1024];
    snprintf(json, sizeof json, SCENE_FMT, env, dirs);
    volux_scene *s = NULL;
    if (volux_scene_load_string(ctx, json, tu_temp_path(""), "env.json", NULL, 0, &s))
        fail_msg("scene: %s", volux_context_error(ctx));
    return s;
}

static void test_constant_sky_energy(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_scene *s = load(ctx, "{\"type\": \"environment\", \"radiance\": 2, \"color\": [1, 0.5, 0.25]}", 16);
    volux_technique *t = NULL;
    assert_int_equal(volux_technique_create(ctx, "single", s, &t), VOLUX_OK);
    const single_state *st = volux_technique_state(t);
    assert_int_equal(st->env_active, 1);
    double sum[3] = {0, 0, 0};
    for (int k = 0; k < 16; k++) {
        sum[0] += st->env_E[k].x, sum[1] += st->env_E[k].y, sum[2] += st->env_E[k].z;
        assert_true(st->env_E[k].x > 0.0f); /* every cell of a uniform sky is lit */
        assert_near(v3_length(st->env_travel[k]), 1.0, 1e-6);
    }
    const double want = 4.0 * M_PI * 2.0;
    assert_near(sum[0], want, 1e-4 * want);
    assert_near(sum[1], want * 0.5, 1e-4 * want);
    assert_near(sum[2], want * 0.25, 1e-4 * want);
    volux_technique_destroy(t);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

/* An 8 × 4 map, black but for one texel: its radiance × solid angle, all
 * in the direction nearest to the texel's centre. */
static void test_one_texel_map_energy(void **state) {
    (void)state;
    const int W = 8, H = 4;
    char pfm[64 + 8 * 4 * 12];
    int n = snprintf(pfm, 64, "PF\n%d %d\n-1.0\n", W, H);
    float px[8 * 4 * 3] = {0};
    px[3 * (1 * W + 5) + 0] = px[3 * (1 * W + 5) + 1] = px[3 * (1 * W + 5) + 2] = 7.0f;
    memcpy(pfm + n, px, sizeof px);
    tu_write_file("onetexel.pfm", pfm, (size_t)n + sizeof px);
    volux_context *ctx = tu_context(1);
    volux_scene *s =
        load(ctx, "{\"type\": \"environment\", \"file\": \"onetexel.pfm\", \"intensity\": 2, \"rotation_y\": 30}", 16);
    volux_technique *t = NULL;
    assert_int_equal(volux_technique_create(ctx, "single", s, &t), VOLUX_OK);
    const single_state *st = volux_technique_state(t);
    const volux_light_desc *d = NULL;
    for (int i = 0; i < st->b.rc.lights.n_all; i++)
        if (st->b.rc.lights.all[i].type == VOLUX_LIGHT_ENVIRONMENT) d = st->b.rc.lights.all[i].desc;
    assert_non_null(d);
    assert_non_null(d->map);
    /* where the loader put the texel (PFM rows are stored bottom-up) */
    int ti = -1, tj = -1;
    for (int j = 0; j < H; j++)
        for (int i = 0; i < W; i++)
            if (d->map->rgb[3 * ((size_t)j * W + (size_t)i)] > 0.0f) ti = i, tj = j;
    assert_true(ti >= 0);
    volux_vec3 dir = volux_environment_direction(d, (ti + 0.5f) / W, (tj + 0.5f) / H);
    int best = 0, lit = 0;
    for (int k = 0; k < 16; k++) {
        if (v3_dot(st->env_travel[k], dir) < v3_dot(st->env_travel[best], dir)) best = k; /* travel = −from */
        lit += st->env_E[k].x > 0.0f;
    }
    assert_int_equal(lit, 1);
    double want = 7.0 * 2.0 * (2.0 * M_PI / W) * (M_PI / H) * sin((tj + 0.5) * M_PI / H);
    assert_near(st->env_E[best].x, want, 1e-5 * want);
    assert_near(st->env_E[best].z, want, 1e-5 * want);
    volux_technique_destroy(t);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

/* env_directions = 0: the sky is dropped, with one warning that names it;
 * an edit of another light does not repeat it; the image is the
 * directional light's alone. */
static void test_ignored_sky_warns_once(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    tu_messages w = {0};
    volux_context_set_message(ctx, tu_collect_messages, &w);
    const char *sky = "{\"type\": \"environment\", \"radiance\": 3, \"visible\": false}";
    volux_scene *s = load(ctx, sky, 0);
    volux_technique *t = NULL;
    assert_int_equal(volux_technique_create(ctx, "single", s, &t), VOLUX_OK);
    assert_int_equal(w.warnings, 1);
    assert_int_equal(w.notes, 0);
    assert_non_null(strstr(w.last, "single: ignores lights[1] (environment)"));
    assert_non_null(strstr(w.last, "env_directions"));
    const volux_edit *e = volux_edit_find("light");
    assert_int_equal(volux_edit_apply(e, s, 0), VOLUX_OK);
    assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_OK);
    assert_int_equal(w.warnings, 1);
    volux_technique_destroy(t);
    volux_scene_destroy(s);
    /* with the sky used, no warning */
    s = load(ctx, sky, 16);
    assert_int_equal(volux_technique_create(ctx, "single", s, &t), VOLUX_OK);
    assert_int_equal(w.warnings, 1);
    volux_technique_destroy(t);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_constant_sky_energy),
        cmocka_unit_test(test_one_texel_map_energy),
        cmocka_unit_test(test_ignored_sky_warns_once),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
