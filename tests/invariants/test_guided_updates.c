/*
 * `guided`'s edits do the least work (docs/techniques/guided.md,
 * invalidation row), and its lazy visibility updates over a sequence are
 * a function of the time step: an instance stepped through an animation
 * (forwards, backwards, by jumps, with a TF edit on the way) holds exactly
 * the visibility grid — and renders exactly the image — of an instance
 * created at that step, under every lazy policy. The technique × edit
 * matrix checks incremental == fresh for every shared edit on a single
 * volume; this file adds sequences and counts the work.
 */
#include <stdio.h>
#include <string.h>

#include "render/technique_class.h"
#include "techniques/guided/guided.h"
#include "test_util.h"
#include "tu_volume.h"

static const guided_state *state_of(const volux_technique *t) { return volux_technique_state(t); }

typedef struct work {
    uint64_t dirs, env, loads;
} work;

static work work_of(const volux_technique *t) {
    const guided_state *st = state_of(t);
    work w = {st->swept_directions, st->env_builds, st->steps_loaded};
    return w;
}

static void make_sky(volux_context *ctx, volux_image *m) {
    assert_int_equal(volux_image_create(ctx, 32, 16, m), VOLUX_OK);
    for (int y = 0; y < 16; y++)
        for (int x = 0; x < 32; x++) {
            float *p = &m->rgb[3 * (y * 32 + x)];
            p[0] = p[1] = p[2] = y < 8 ? 1.0f + (float)x / 8.0f : 0.1f;
        }
}

static void add_sky(volux_context *ctx, volux_scene *s) {
    volux_image map;
    make_sky(ctx, &map);
    volux_light_desc l;
    volux_light_desc_defaults(&l, VOLUX_LIGHT_ENVIRONMENT);
    l.map = &map;
    assert_int_equal(volux_scene_set_light(s, 0, &l), VOLUX_OK);
    volux_image_free(ctx, &map);
}

/* ------------------------------------------------------------------ least work per edit */

static void test_each_edit_does_the_least_work(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    volux_scene *s = tu_scene(ctx, "{\"volume\": {\"procedural\": \"cloud\", \"dims\": [20, 18, 16]},"
                                   " \"transfer_function\": {\"extinction\": [[0, 0], [40, 0], [255, 0.5]],"
                                   "   \"color\": [[0, 1, 0.5, 0.2], [255, 0.2, 0.5, 1]]},"
                                   " \"lights\": [{\"type\": \"environment\", \"radiance\": 1},"
                                   "   {\"type\": \"directional\", \"direction\": [0, -1, 0], \"irradiance\": 1}],"
                                   " \"render\": {\"technique\": \"guided\", \"width\": 8, \"height\": 8, \"spp\": 1},"
                                   " \"techniques\": {\"guided\": {\"env_resolution\": 16}}}");
    add_sky(ctx, s);
    volux_technique *t;
    assert_int_equal(volux_technique_create(ctx, "guided", s, &t), VOLUX_OK);
    const int D = state_of(t)->grid.dirs;
    /* edit, directions swept, environment builds */
    static const struct {
        const char *edit;
        int dirs, env;
    } expect[] = {
        {"camera", 0, 0},   {"background", 0, 0}, {"step", 0, 0},     {"phase", 0, 0},
        {"tf_color", 0, 0}, {"light", 0, 1},
        /* environment rotation and colour: the product pdf's environment only
         * (the least-work row; before light_toggle switches the
         * environment off); the material channel: nothing */
        {"light_rotate_env", 0, 1}, {"light_color", 0, 1}, {"material", 0, 0},
        {"light_last", 0, 0}, {"light_toggle", 0, 1},
        /* ... and back on (without an environment light nothing reads the
         * grid: see test_no_environment_no_sweep) */
        {"light_toggle", 0, 1},
        {"light_add", 0, 0}, {"tf", -1, 0},       {"density", -1, 0}, {"time_step", -1, 0},
    };
    for (size_t i = 0; i < sizeof expect / sizeof expect[0]; i++) {
        work before = work_of(t);
        assert_int_equal(volux_edit_apply(volux_edit_find(expect[i].edit), s, 0), VOLUX_OK);
        if (volux_technique_update(t, s, NULL)) fail_msg("%s: %s", expect[i].edit, volux_context_error(ctx));
        work after = work_of(t);
        int dirs = (int)(after.dirs - before.dirs), env = (int)(after.env - before.env);
        int want = expect[i].dirs < 0 ? D : expect[i].dirs;
        printf("  %-12s directions swept %2d, environment builds %d\n", expect[i].edit, dirs, env);
        if (dirs != want || env != expect[i].env)
            fail_msg("%s: swept %d directions and built the environment %d times, expected %d and %d", expect[i].edit,
                     dirs, env, want, expect[i].env);
    }
    /* parameters: only those that change the grid's values sweep */
    static const struct {
        const char *name;
        double value;
        const char *string;
        int dirs, env;
    } params[] = {
        {"strategy", 0, "product", 0, 0}, {"mis", 0, NULL, 0, 0},       {"guide_depth", 3, NULL, 0, 0},
        {"epsilon", 0.05, NULL, 0, 0},   {"lazy", 0, "static", 0, 0},   {"env_resolution", 32, NULL, 0, 1},
        {"filter_angle", 0.3, NULL, -1, 0}, {"oversample", 2, NULL, -1, 0}, {"cell", 3, NULL, -1, 0},
    };
    for (size_t i = 0; i < sizeof params / sizeof params[0]; i++) {
        work before = work_of(t);
        assert_int_equal(volux_scene_set_param(s, "guided", params[i].name, params[i].value, params[i].string), 0);
        assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_OK);
        work after = work_of(t);
        int dirs = (int)(after.dirs - before.dirs), env = (int)(after.env - before.env);
        int want = params[i].dirs < 0 ? D : params[i].dirs;
        printf("  %-14s directions swept %2d, environment builds %d\n", params[i].name, dirs, env);
        if (dirs != want || env != params[i].env)
            fail_msg("techniques.guided.%s: swept %d directions, built the environment %d times", params[i].name, dirs,
                     env);
    }
    /* a strategy that does not read the grid skips visibility work; the
     * grid catches up when one that reads it comes back */
    assert_int_equal(volux_scene_set_param(s, "guided", "strategy", 0, "environment"), 0);
    assert_int_equal(volux_edit_apply(volux_edit_find("tf"), s, 1), VOLUX_OK);
    work before = work_of(t);
    assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_OK);
    assert_int_equal(work_of(t).dirs - before.dirs, 0);
    assert_int_equal(volux_scene_set_param(s, "guided", "strategy", 0, "two_step"), 0);
    assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_OK);
    assert_int_equal(work_of(t).dirs - before.dirs, (uint64_t)D);
    volux_technique_destroy(t);
    volux_scene_destroy(s);
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

/* ------------------------------------------------------------------ no environment light */

/* Without an environment light nothing reads the visibility grid (only the
 * environment's light sample does): `guided` neither allocates nor sweeps
 * it, and renders exactly `pathtrace`'s image. The grid is swept when an
 * environment light appears, and an edit made while it was not needed
 * still reaches it (a volume edit between removing and re-adding the
 * environment sweeps every direction again: no stale grid). */
static void test_no_environment_no_sweep(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    tu_messages m = {0};
    volux_context_set_message(ctx, tu_collect_messages, &m);
    volux_scene *s = tu_scene(ctx, "{\"volume\": {\"procedural\": \"cloud\", \"dims\": [20, 18, 16]},"
                                   " \"transfer_function\": {\"extinction\": [[0, 0], [40, 0], [255, 0.5]]},"
                                   " \"lights\": [{\"type\": \"directional\", \"direction\": [0, -1, 0.3], "
                                   "\"irradiance\": 2}],"
                                   " \"render\": {\"technique\": \"guided\", \"width\": 12, \"height\": 12, "
                                   "\"spp\": 4}}");
    volux_technique *t;
    assert_int_equal(volux_technique_create(ctx, "guided", s, &t), VOLUX_OK);
    assert_int_equal(work_of(t).dirs, 0);
    assert_null(state_of(t)->grid.v);
    /* said once, as a note (not a warning: nothing is wrong) */
    assert_int_equal(m.notes, 1);
    assert_int_equal(m.warnings, 0);
    assert_non_null(strstr(m.last, "no visibility sweep"));
    volux_image g = tu_render_with(ctx, s, t);
    volux_image p = tu_render(ctx, s, "pathtrace");
    double d = tu_max_abs_diff(&g, &p);
    if (d != 0.0) fail_msg("guided without an environment differs from pathtrace by %g", d);
    volux_image_free(ctx, &g);
    volux_image_free(ctx, &p);
    /* a TF edit: still nothing to sweep */
    assert_int_equal(volux_edit_apply(volux_edit_find("tf"), s, 0), VOLUX_OK);
    assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_OK);
    assert_int_equal(work_of(t).dirs, 0);
    /* an environment light: every direction swept, once */
    volux_light_desc l;
    volux_light_desc_defaults(&l, VOLUX_LIGHT_ENVIRONMENT);
    l.radiance = 1.0f;
    assert_int_equal(volux_scene_set_light(s, 1, &l), VOLUX_OK);
    assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_OK);
    const uint64_t D = (uint64_t)state_of(t)->grid.dirs;
    assert_true(D > 0);
    assert_int_equal(work_of(t).dirs, D);
    /* off, a density edit, on again: the grid is swept again */
    assert_int_equal(volux_scene_set_light_enabled(s, 1, 0), VOLUX_OK);
    assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_OK);
    assert_int_equal(volux_edit_apply(volux_edit_find("density"), s, 0), VOLUX_OK);
    assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_OK);
    assert_int_equal(work_of(t).dirs, D);
    assert_int_equal(volux_scene_set_light_enabled(s, 1, 1), VOLUX_OK);
    assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_OK);
    assert_int_equal(work_of(t).dirs, 2 * D);
    /* ... to what a fresh instance computes */
    volux_technique *f;
    assert_int_equal(volux_technique_create(ctx, "guided", s, &f), VOLUX_OK);
    const guided_grid *a = &state_of(t)->grid, *b = &state_of(f)->grid;
    assert_int_equal(a->bytes, b->bytes);
    if (memcmp(a->v, b->v, a->bytes) != 0) fail_msg("the grid swept after the environment came back is stale");
    volux_technique_destroy(f);
    volux_technique_destroy(t);
    volux_scene_destroy(s);
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

/* ------------------------------------------------------------------ env_resolution 0: auto */

/* env_resolution 0 picks the largest power of two M with M² no more than
 * the map's texels (at least the directions N), follows the map when it is
 * edited (rebuilding the environment quadtree, nothing else), and renders
 * exactly what the explicit M renders. */
static void test_env_resolution_auto_follows_the_map(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    volux_scene *s = tu_scene(ctx, "{\"volume\": {\"procedural\": \"cloud\", \"dims\": [20, 18, 16]},"
                                   " \"transfer_function\": {\"extinction\": [[0, 0], [40, 0], [255, 0.5]]},"
                                   " \"render\": {\"technique\": \"guided\", \"width\": 8, \"height\": 8, \"spp\": 2},"
                                   " \"techniques\": {\"guided\": {\"env_resolution\": 0}}}");
    add_sky(ctx, s); /* 32 × 16 = 512 texels: 16² ≤ 512 < 32² */
    volux_technique *t, *f;
    assert_int_equal(volux_technique_create(ctx, "guided", s, &t), VOLUX_OK);
    assert_int_equal(state_of(t)->env_res, 16);
    volux_image auto_img = tu_render_with(ctx, s, t);
    assert_int_equal(volux_scene_set_param(s, "guided", "env_resolution", 16, NULL), VOLUX_OK);
    assert_int_equal(volux_technique_create(ctx, "guided", s, &f), VOLUX_OK);
    volux_image explicit_img = tu_render_with(ctx, s, f);
    if (tu_max_abs_diff(&auto_img, &explicit_img) != 0.0) fail_msg("auto (16) and 16 render different images");
    volux_image_free(ctx, &auto_img);
    volux_image_free(ctx, &explicit_img);
    volux_technique_destroy(f);
    assert_int_equal(volux_scene_set_param(s, "guided", "env_resolution", 0, NULL), VOLUX_OK);
    assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_OK);
    assert_int_equal(state_of(t)->env_res, 16);

    /* a 64 × 32 map (2048 texels): 32; the visibility grid is not swept */
    volux_image map;
    assert_int_equal(volux_image_create(ctx, 64, 32, &map), VOLUX_OK);
    for (int i = 0; i < 3 * 64 * 32; i++) map.rgb[i] = 1.0f + (float)(i % 7);
    volux_light_desc l;
    volux_light_desc_defaults(&l, VOLUX_LIGHT_ENVIRONMENT);
    l.map = &map;
    assert_int_equal(volux_scene_set_light(s, 0, &l), VOLUX_OK);
    volux_image_free(ctx, &map);
    work before = work_of(t);
    assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_OK);
    assert_int_equal(state_of(t)->env_res, 32);
    assert_int_equal(work_of(t).dirs - before.dirs, 0);
    assert_int_equal(work_of(t).env - before.env, 1);

    /* a constant environment: the grid's N (8 by default) */
    volux_light_desc_defaults(&l, VOLUX_LIGHT_ENVIRONMENT);
    l.radiance = 2.0f;
    assert_int_equal(volux_scene_set_light(s, 0, &l), VOLUX_OK);
    assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_OK);
    assert_int_equal(state_of(t)->env_res, 8);
    /* ... which follows N: directions 16 */
    assert_int_equal(volux_scene_set_param(s, "guided", "directions", 16, NULL), VOLUX_OK);
    assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_OK);
    assert_int_equal(state_of(t)->env_res, 16);
    /* not a power of two: a clear error */
    assert_int_equal(volux_scene_set_param(s, "guided", "env_resolution", 48, NULL), VOLUX_OK);
    assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_ERR_INVALID);
    assert_non_null(strstr(volux_context_error(ctx), "env_resolution"));
    volux_context_clear_error(ctx);
    volux_technique_destroy(t);
    volux_scene_destroy(s);
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

/* ------------------------------------------------------------------ lazy updates over a sequence */

static volux_scene *sequence_scene(volux_context *ctx, const char *lazy) {
    volux_scene *s = tu_scene(ctx, "{\"volume\": {\"procedural\": \"cloud\", \"dims\": [18, 16, 14], \"steps\": 40,"
                                   "   \"time_per_step\": 0.1},"
                                   " \"transfer_function\": {\"extinction\": [[0, 0], [40, 0], [255, 0.5]]},"
                                   " \"render\": {\"technique\": \"guided\", \"width\": 8, \"height\": 8, \"spp\": 1},"
                                   " \"techniques\": {\"guided\": {\"env_resolution\": 16}}}");
    add_sky(ctx, s);
    assert_int_equal(volux_scene_set_param(s, "guided", "lazy", 0, lazy), VOLUX_OK);
    return s;
}

/* The grid and image of an instance that was updated step by step equal a
 * fresh instance's at the same step. */
static void check_fresh(volux_context *ctx, volux_scene *s, volux_technique *t, const char *what) {
    volux_technique *f;
    assert_int_equal(volux_technique_create(ctx, "guided", s, &f), VOLUX_OK);
    const guided_grid *a = &state_of(t)->grid, *b = &state_of(f)->grid;
    assert_int_equal(a->bytes, b->bytes);
    for (int d = 0; d < a->dirs; d++)
        if (a->src[d] != b->src[d])
            fail_msg("%s: direction %d from step %d, fresh from %d", what, d, a->src[d], b->src[d]);
    if (memcmp(a->v, b->v, a->bytes)) fail_msg("%s: the visibility grid differs from a fresh instance's", what);
    volux_image ia = tu_render_with(ctx, s, t), ib = tu_render_with(ctx, s, f);
    if (tu_max_abs_diff(&ia, &ib) != 0.0) fail_msg("%s: the image differs from a fresh instance's", what);
    volux_image_free(ctx, &ia);
    volux_image_free(ctx, &ib);
    volux_technique_destroy(f);
}

static void test_lazy_updates_equal_a_fresh_instance(void **state) {
    (void)state;
    const char *policies[4] = {"round_robin", "environment", "static", "off"};
    for (int p = 0; p < 4; p++) {
        volux_context *ctx = tu_context(2);
        volux_scene *s = sequence_scene(ctx, policies[p]);
        volux_technique *t;
        assert_int_equal(volux_technique_create(ctx, "guided", s, &t), VOLUX_OK);
        const int D = state_of(t)->grid.dirs, budget = 4, K = D / budget;
        uint64_t total = 0;
        /* play 1 … 33 forwards */
        for (int step = 1; step <= 33; step++) {
            work before = work_of(t);
            assert_int_equal(volux_scene_set_time_step(s, step), VOLUX_OK);
            assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_OK);
            int dirs = (int)(work_of(t).dirs - before.dirs);
            total += (uint64_t)dirs;
            switch (p) {
            case 0: assert_int_equal(dirs, budget); break;                 /* every step: the budget */
            case 1: assert_true(dirs >= 1 && dirs <= budget); break;       /* draws may repeat */
            case 2: assert_int_equal(dirs, step % K == 0 ? D : 0); break; /* all every K steps */
            default: assert_int_equal(dirs, D);
            }
            if (step == 7 || step == 16 || step == 33) {
                char what[64];
                snprintf(what, sizeof what, "%s at step %d", policies[p], step);
                check_fresh(ctx, s, t, what);
            }
        }
        printf("  %-12s %llu directions over 33 steps (%.2f of a full update per step)\n", policies[p],
               (unsigned long long)total, (double)total / (33.0 * D));
        /* backwards, a jump, and a TF edit in between */
        static const int moves[3] = {30, 5, 21};
        for (int i = 0; i < 3; i++) {
            assert_int_equal(volux_scene_set_time_step(s, moves[i]), VOLUX_OK);
            if (i == 1) assert_int_equal(volux_edit_apply(volux_edit_find("tf"), s, 0), VOLUX_OK);
            assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_OK);
            char what[64];
            snprintf(what, sizeof what, "%s after moving to step %d", policies[p], moves[i]);
            check_fresh(ctx, s, t, what);
        }
        volux_technique_destroy(t);
        volux_scene_destroy(s);
        assert_int_equal(volux_context_bytes_in_use(ctx), 0);
        volux_context_destroy(ctx);
    }
}

/* An allocation failure at any point of a lazy update (steps loaded from
 * the sequence, LUTs, sweep buffers) is reported as NOMEM without a leak,
 * and the next update finishes the job: the instance then equals a fresh
 * one. */
static void test_failed_lazy_update_recovers(void **state) {
    (void)state;
    for (long k = 1;; k++) {
        tu_alloc_stats stats = {0};
        volux_context *ctx = tu_context_counting(0, &stats);
        volux_scene *s = sequence_scene(ctx, "round_robin");
        /* 16 directions per step: 4 source steps (keeps the loop short) */
        assert_int_equal(volux_scene_set_param(s, "guided", "lazy_budget", 16, NULL), VOLUX_OK);
        volux_technique *t;
        assert_int_equal(volux_technique_create(ctx, "guided", s, &t), VOLUX_OK);
        /* keep no steps cached, so the update has to load its sources */
        volux_sequence_set_cache_limit(volux_scene_sequence(s), 1);
        assert_int_equal(volux_scene_set_time_step(s, 23), VOLUX_OK);
        stats.fail_at = stats.count + k;
        volux_status st = volux_technique_update(t, s, NULL);
        stats.fail_at = 0;
        if (st) {
            if (st != VOLUX_ERR_NOMEM) fail_msg("allocation %ld: %s", k, volux_context_error(ctx));
            volux_context_clear_error(ctx);
            assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_OK);
        }
        if (k % 4 == 1 || !st) check_fresh(ctx, s, t, "round_robin after a failed update");
        volux_technique_destroy(t);
        volux_scene_destroy(s);
        if (volux_context_bytes_in_use(ctx) != 0) fail_msg("allocation %ld: leaked", k);
        volux_context_destroy(ctx);
        if (!st) break;
        assert_true(k < 10000);
    }
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_each_edit_does_the_least_work),
        cmocka_unit_test(test_no_environment_no_sweep),
        cmocka_unit_test(test_env_resolution_auto_follows_the_map),
        cmocka_unit_test(test_lazy_updates_equal_a_fresh_instance),
        cmocka_unit_test(test_failed_lazy_update_recovers),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
