/*
 * tests/physics/test_lightvol_env.c — `lightvol`'s environment lights: the
 * env_directions directional lights (the Fibonacci set and cell integration
 * `single` uses) carry exactly the environment's energy through empty space
 * (every node receives Σ_k E_k = ∫ L dω = 4π·L for a constant sky, and the
 * luminance-weighted direction Σ_k lum(E_k)·ω_k); an environment edit is
 * propagated selectively, one entry per direction whose irradiance changed,
 * and ends where a fresh build does; an edit of another light leaves the
 * environment alone; env_directions = 0 drops the sky with one warning.
 * (Its accuracy in a medium: tests/reference, case lightvol_sky.)
 */
#include <stdio.h>

#include "lightvol_fixture.h"
#include "render/lights.h"

#define N 10

static float *filled(int n, float v) {
    float *d = malloc((size_t)n * sizeof(float));
    assert_non_null(d);
    for (int i = 0; i < n; i++) d[i] = v;
    return d;
}

static volux_light_desc sky(float radiance) {
    volux_light_desc d;
    volux_light_desc_defaults(&d, VOLUX_LIGHT_ENVIRONMENT);
    d.radiance = radiance;
    d.color = (volux_vec3){1.0f, 0.5f, 0.25f};
    d.visible = 0;
    return d;
}

/* Empty space under a constant sky: every node gets 4π·L·colour, and
 * D = Σ_k lum(E_k)·(−fibonacci_k) (the travel directions). */
static void test_constant_sky_in_vacuum_keeps_its_energy(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    float *data = filled(N * N * N, 0.0f);
    volux_scene *s = lvf_scene(ctx, N, N, N, data, 0.9f, NULL);
    volux_light_desc l = sky(2.0f);
    assert_int_equal(volux_scene_set_light(s, 0, &l), VOLUX_OK);
    for (int K = 16; K <= 40; K += 24) {
        assert_int_equal(volux_scene_set_param(s, "lightvol", "env_directions", K, NULL), VOLUX_OK);
        volux_technique *t = lvf_create(ctx, s);
        const lightvol_state *st = lvf_state(t);
        double sum[3] = {0, 0, 0}, D[3] = {0, 0, 0};
        for (int k = 0; k < K; k++) {
            volux_vec3 E = st->env_E[k];
            assert_true(E.x > 0.0f); /* every cell of a uniform sky is lit */
            sum[0] += E.x, sum[1] += E.y, sum[2] += E.z;
            volux_vec3 w = volux_fibonacci_dir(k, K);
            double lum = v3_luminance(E);
            D[0] -= lum * w.x, D[1] -= lum * w.y, D[2] -= lum * w.z;
        }
        for (int k = K; k < LV_MAX_ENV_DIRS; k++) assert_true(st->env_E[k].x == 0.0f);
        const double want = 4.0 * M_PI * 2.0;
        assert_near(sum[0], want, 1e-4 * want);
        assert_near(sum[1], want * 0.5, 1e-4 * want);
        assert_near(sum[2], want * 0.25, 1e-4 * want);
        const double lum_sum = 0.2126 * sum[0] + 0.7152 * sum[1] + 0.0722 * sum[2];
        for (int k = 0; k < st->dims[2]; k++)
            for (int j = 0; j < st->dims[1]; j++)
                for (int i = 0; i < st->dims[0]; i++) {
                    const float *e = lvf_at(st, i, j, k);
                    for (int c = 0; c < 3; c++) assert_near(e[c], sum[c], 1e-4 * sum[c]);
                    for (int c = 0; c < 3; c++) assert_near(e[3 + c], D[c], 2e-5 * lum_sum);
                }
        volux_technique_destroy(t);
    }
    volux_scene_destroy(s);
    free(data);
    volux_context_destroy(ctx);
}

/* t updated to the scene against a fresh technique: same volume. */
static void expect_fresh(volux_context *ctx, volux_scene *s, volux_technique *t, const char *what) {
    lvf_update(t, s);
    volux_technique *f = lvf_create(ctx, s);
    size_t n = lvf_count(lvf_state(f));
    float *a = lvf_copy(t), *b = lvf_copy(f);
    double m = 0.0, d = lvf_max_diff(a, b, n, &m);
    free(a);
    free(b);
    assert_true(m > 0.0);
    if (d > 2e-6 * m) fail_msg("%s: selective differs from fresh by %g (max %g)", what, d, m);
    volux_technique_destroy(f);
}

/* A medium with a directional light and a sky. Editing the sky (rotation,
 * intensity, off, on) updates selectively: one entry per direction and
 * group, nothing for the directional light, and the volume ends where a
 * fresh build does. Editing the directional light leaves the sky's
 * irradiances and entries alone. */
static void test_sky_edits_are_selective(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    float *data = malloc((size_t)N * N * N * sizeof(float));
    assert_non_null(data);
    for (int i = 0; i < N * N * N; i++) data[i] = 0.05f + 0.3f * (float)((i * 7) % 11) / 11.0f;
    volux_scene *s = lvf_scene(ctx, N, N, N, data, 0.9f, NULL);
    assert_int_equal(volux_scene_set_param(s, "lightvol", "cost_rule", 0, "selective"), VOLUX_OK);
    volux_light_desc key = lvf_directional(-0.3f, -1.0f, 0.2f, 3.0f), env = sky(0.5f);
    assert_int_equal(volux_scene_set_light(s, 0, &key), VOLUX_OK);
    assert_int_equal(volux_scene_set_light(s, 1, &env), VOLUX_OK);
    volux_technique *t = lvf_create(ctx, s);
    const lightvol_state *st = lvf_state(t);
    const int K = st->p.env_dirs;
    assert_int_equal(K, 16);
    int env_entries = 0;
    for (int k = 0; k < K; k++) {
        lv_source src;
        volux_lightvol_env_source(st, k, v3(1, 1, 1), &src);
        env_entries += __builtin_popcount(src.groups);
    }
    /* entire build: the key light's ≤ 2 group entries plus the sky's */
    assert_true(st->stats.entries >= env_entries + 1 && st->stats.entries <= env_entries + 2);
    assert_true(st->stats.passes <= LV_GROUPS);

    env.radiance = 1.5f; /* intensity edit: one difference entry per direction and group */
    assert_int_equal(volux_scene_set_light(s, 1, &env), VOLUX_OK);
    expect_fresh(ctx, s, t, "sky intensity");
    assert_int_equal(st->stats.last, LV_UPDATE_SELECTIVE);
    assert_int_equal(st->stats.entries, env_entries);
    assert_true(st->stats.passes <= LV_GROUPS);

    volux_vec3 before[LV_MAX_ENV_DIRS];
    memcpy(before, st->env_E, sizeof before);
    key.irradiance = 5.0f; /* the key light alone: remove + add, no sky entry */
    assert_int_equal(volux_scene_set_light(s, 0, &key), VOLUX_OK);
    expect_fresh(ctx, s, t, "key light");
    assert_int_equal(st->stats.last, LV_UPDATE_SELECTIVE);
    assert_true(st->stats.entries >= 2 && st->stats.entries <= 4);
    assert_memory_equal(before, st->env_E, sizeof before);

    env.enabled = 0; /* off: the sky's light leaves the volume */
    assert_int_equal(volux_scene_set_light(s, 1, &env), VOLUX_OK);
    expect_fresh(ctx, s, t, "sky off");
    assert_int_equal(st->stats.entries, env_entries);
    for (int k = 0; k < K; k++) assert_true(st->env_E[k].x == 0.0f);
    env.enabled = 1;
    assert_int_equal(volux_scene_set_light(s, 1, &env), VOLUX_OK);
    expect_fresh(ctx, s, t, "sky on");
    volux_technique_destroy(t);
    volux_scene_destroy(s);
    free(data);
    volux_context_destroy(ctx);
}

/* A map rotated about +y: the irradiances move between the cells (Σ kept),
 * the update is selective and matches a fresh build. */
static void test_sky_map_rotation(void **state) {
    (void)state;
    const int W = 16, H = 8;
    char pfm[64 + 16 * 8 * 12];
    int n = snprintf(pfm, 64, "PF\n%d %d\n-1.0\n", W, H);
    float px[16 * 8 * 3];
    for (int i = 0; i < W * H * 3; i++) px[i] = 0.2f + (float)((i * 5) % 13); /* a lumpy sky */
    memcpy(pfm + n, px, sizeof px);
    tu_write_file("lumpy.pfm", pfm, (size_t)n + sizeof px);
    volux_context *ctx = tu_context(1);
    float *data = filled(N * N * N, 0.1f);
    volux_scene *s = lvf_scene(ctx, N, N, N, data, 0.9f, NULL);
    assert_int_equal(volux_scene_set_param(s, "lightvol", "cost_rule", 0, "selective"), VOLUX_OK);
    volux_image map;
    assert_int_equal(volux_image_load(ctx, tu_temp_path("lumpy.pfm"), &map), VOLUX_OK);
    volux_light_desc env = sky(0.0f);
    env.map = &map;
    env.intensity = 0.1f;
    assert_int_equal(volux_scene_set_light(s, 0, &env), VOLUX_OK);
    volux_technique *t = lvf_create(ctx, s);
    const lightvol_state *st = lvf_state(t);
    double sum0 = 0.0;
    for (int k = 0; k < st->p.env_dirs; k++) sum0 += st->env_E[k].x;
    volux_vec3 before[LV_MAX_ENV_DIRS];
    memcpy(before, st->env_E, sizeof before);
    env.rotation_y_deg = 70.0f;
    assert_int_equal(volux_scene_set_light(s, 0, &env), VOLUX_OK);
    expect_fresh(ctx, s, t, "sky rotation");
    assert_int_equal(st->stats.last, LV_UPDATE_SELECTIVE);
    assert_true(memcmp(before, st->env_E, sizeof before) != 0);
    double sum1 = 0.0;
    for (int k = 0; k < st->p.env_dirs; k++) sum1 += st->env_E[k].x;
    assert_near(sum1, sum0, 1e-4 * sum0);
    /* an intensity edit re-derives the environment from the memo (no new
     * integration), and the applied irradiances are a fresh integration's */
    long misses = st->env_cells.misses, hits = st->env_cells.hits;
    env.intensity = 0.25f;
    assert_int_equal(volux_scene_set_light(s, 0, &env), VOLUX_OK);
    expect_fresh(ctx, s, t, "sky intensity after rotation");
    assert_int_equal(st->env_cells.misses, misses);
    assert_true(st->env_cells.hits > hits);
    volux_vec3 from[LV_MAX_ENV_DIRS], fresh[LV_MAX_ENV_DIRS];
    const int K = st->p.env_dirs;
    for (int k = 0; k < K; k++) from[k] = volux_fibonacci_dir(k, K), fresh[k] = v3(0, 0, 0);
    volux_environment_cells(volux_scene_light(s, 0), K, from, fresh);
    assert_memory_equal(fresh, st->env_E, (size_t)K * sizeof *fresh);
    volux_technique_destroy(t);
    volux_scene_destroy(s);
    volux_image_free(ctx, &map);
    free(data);
    volux_context_destroy(ctx);
}

/* The memo of cell integrals (render/lights.h) against a fresh
 * integration after every kind of environment edit: the same bits, and a
 * hit exactly where only colour or intensity changed (or a map came back
 * with the same texels), a miss where the map, its rotation or K changed. */
static void cells_match(volux_env_cells_cache *c, const volux_light_desc *d, int K, int expect_hit, const char *what) {
    volux_vec3 from[64], E[64], F[64];
    for (int k = 0; k < K; k++) from[k] = volux_fibonacci_dir(k, K), E[k] = F[k] = v3(0.25f, 0.0f, 1.0f);
    long hits = c->hits, misses = c->misses;
    volux_environment_cells_cached(c, d, K, E);
    volux_environment_cells(d, K, from, F);
    if (memcmp(E, F, (size_t)K * sizeof *E) != 0) fail_msg("%s: cached cells differ from a fresh integration", what);
    if (c->hits - hits != (expect_hit ? 1 : 0) || c->misses - misses != (expect_hit ? 0 : 1))
        fail_msg("%s: expected a %s", what, expect_hit ? "hit" : "miss");
}

static void test_cell_integrals_memo_matches_fresh(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_image m1, m2, m3;
    assert_int_equal(volux_image_create(ctx, 16, 8, &m1), VOLUX_OK);
    for (int i = 0; i < 16 * 8 * 3; i++) m1.rgb[i] = 0.2f + (float)((i * 5) % 13);
    m1.rgb[3 * 20 + 1] = 400.0f; /* a sun */
    assert_int_equal(volux_image_copy(ctx, &m1, &m2), VOLUX_OK);
    assert_int_equal(volux_image_copy(ctx, &m1, &m3), VOLUX_OK);
    m3.rgb[3 * 77] += 1.0f;
    volux_env_cells_cache *c = calloc(1, sizeof *c);
    assert_non_null(c);
    volux_light_desc d = sky(0.0f);
    d.map = &m1;
    d.intensity = 0.1f;
    cells_match(c, &d, 16, 0, "first use");
    cells_match(c, &d, 16, 1, "unchanged");
    d.intensity = 0.3f;
    cells_match(c, &d, 16, 1, "intensity");
    d.color = v3(0.2f, 1.0f, 3.0f);
    cells_match(c, &d, 16, 1, "colour");
    d.rotation_y_deg = 70.0f;
    cells_match(c, &d, 16, 0, "rotation");
    d.rotation_y_deg = 0.0f;
    cells_match(c, &d, 16, 1, "rotation back");
    d.map = &m2;
    cells_match(c, &d, 16, 1, "the same texels in another copy");
    d.map = &m3;
    cells_match(c, &d, 16, 0, "one texel changed");
    d.map = &m1;
    cells_match(c, &d, 40, 0, "env_directions");
    d.map = NULL;
    d.radiance = 0.5f;
    cells_match(c, &d, 16, 0, "constant sky");
    d.radiance = 2.0f;
    d.rotation_y_deg = 30.0f;
    cells_match(c, &d, 16, 1, "constant sky radiance and rotation");
    /* four entries, the least recently used replaced: the constant sky
     * took the place of the rotated map (last used before the others) */
    d.map = &m1;
    d.rotation_y_deg = 70.0f;
    cells_match(c, &d, 16, 0, "evicted");
    d.rotation_y_deg = 0.0f;
    cells_match(c, &d, 40, 1, "kept");
    free(c);
    volux_image_free(ctx, &m1);
    volux_image_free(ctx, &m2);
    volux_image_free(ctx, &m3);
    volux_context_destroy(ctx);
}

/* env_directions = 0: the sky is dropped with one warning naming it, and
 * nothing is propagated; set back to 16, it lights the volume and no
 * warning follows. */
static void test_no_directions_warns(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    tu_messages w = {0};
    volux_context_set_message(ctx, tu_collect_messages, &w);
    float *data = filled(N * N * N, 0.1f);
    volux_scene *s = lvf_scene(ctx, N, N, N, data, 0.9f, NULL);
    volux_light_desc env = sky(1.0f);
    assert_int_equal(volux_scene_set_light(s, 2, &env), VOLUX_OK);
    assert_int_equal(volux_scene_set_param(s, "lightvol", "env_directions", 0, NULL), VOLUX_OK);
    volux_technique *t = lvf_create(ctx, s);
    assert_int_equal(w.warnings, 1);
    assert_int_equal(w.notes, 0);
    assert_non_null(strstr(w.last, "lightvol: ignores lights[2] (environment)"));
    assert_non_null(strstr(w.last, "env_directions"));
    const lightvol_state *st = lvf_state(t);
    for (size_t i = 0; i < lvf_count(st); i++) assert_true(lvf_value(st, i) == 0.0f);
    assert_int_equal(volux_scene_set_param(s, "lightvol", "env_directions", 16, NULL), VOLUX_OK);
    lvf_update(t, s);
    assert_int_equal(w.warnings, 1);
    assert_true(lvf_at(st, N / 2, N / 2, N / 2)[0] > 0.0f);
    volux_technique_destroy(t);
    volux_scene_destroy(s);
    free(data);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_constant_sky_in_vacuum_keeps_its_energy),
        cmocka_unit_test(test_sky_edits_are_selective),
        cmocka_unit_test(test_sky_map_rotation),
        cmocka_unit_test(test_cell_integrals_memo_matches_fresh),
        cmocka_unit_test(test_no_directions_warns),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
