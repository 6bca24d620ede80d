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
    /* an intensity edit re-derives the directions through the memo of cell
     * integrals (a hit, no integration), to the bits of a fresh instance */
    long hits = st->env_cells.hits;
    assert_int_equal(volux_edit_apply(volux_edit_find("light_intensity"), s, 0), VOLUX_OK);
    assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_OK);
    assert_int_equal(st->env_cells.hits, hits + 1);
    volux_technique *f = NULL;
    assert_int_equal(volux_technique_create(ctx, "single", s, &f), VOLUX_OK);
    const single_state *fs = volux_technique_state(f);
    assert_memory_equal(fs->env_E, st->env_E, sizeof st->env_E);
    volux_technique_destroy(f);
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

/* ------------------------------------------------------------------ light-space sweep */

static volux_scene *cloud_scene(volux_context *ctx, double sweep) {
    char json[1024];
    snprintf(json, sizeof json,
             "{\"volume\": {\"procedural\": \"cloud\", \"dims\": [48, 40, 36]},"
             " \"transfer_function\": {\"extinction\": [[0, 0], [30, 0], [255, 0.35]], \"albedo\": 0.8},"
             " \"lights\": [{\"type\": \"environment\", \"radiance\": 1}],"
             " \"render\": {\"width\": 16, \"height\": 16},"
             " \"techniques\": {\"single\": {\"cache_scale\": 1, \"env_sweep\": %g}}}",
             sweep);
    volux_scene *s = NULL;
    if (volux_scene_load_string(ctx, json, tu_temp_path(""), "sweep.json", NULL, 0, &s))
        fail_msg("scene: %s", volux_context_error(ctx));
    return s;
}

/* env_sweep > 0 builds the environment caches from parallel shadow rays
 * read back trilinearly in light space; env_sweep 0 marches one shadow ray
 * per node (the reference). Over a cloud whose transmittance spans 0–1
 * the two agree per node to the interpolation the sweep adds: mean |ΔT|
 * below 0.01 and every node within 0.2 at half a cell (measured 0.0032 and
 * 0.133), 0.02 and 0.3 at one cell, the default (measured 0.0100 and 0.278: the
 * largest differences sit at shadow edges, where τ changes fastest across
 * the lattice),
 * for every one of the 16 directions (an axis or sign mistake in the
 * lattice would put the shadows on the wrong side: |ΔT| ~ 0.5). The
 * reference itself spans a wide range, so the comparison is not vacuous. */
static void test_env_sweep_matches_shadow_rays(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    /* spacing (cache cells), bounds on the worst direction's mean and max |ΔT| */
    static const struct {
        double sweep, mean, max;
    } cases[] = {{0.5, 0.01, 0.2}, {1.0, 0.02, 0.3}};
    volux_scene *sr = cloud_scene(ctx, 0), *ss = NULL;
    volux_technique *tr = NULL, *ts = NULL;
    assert_int_equal(volux_technique_create(ctx, "single", sr, &tr), VOLUX_OK);
    const single_state *a = volux_technique_state(tr), *b = NULL;
    assert_int_equal(a->n_env_dirs, 16);
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        if (ts) volux_technique_destroy(ts);
        if (ss) volux_scene_destroy(ss);
        ss = cloud_scene(ctx, cases[c].sweep);
        assert_int_equal(volux_technique_create(ctx, "single", ss, &ts), VOLUX_OK);
        b = volux_technique_state(ts);
        double worst_mean = 0, worst_max = 0, t_min = 1;
        for (int k = 0; k < a->n_env_dirs; k++) {
            const scatter_grid *ga = &a->env_cache[k], *gb = &b->env_cache[k];
            assert_non_null(ga->v);
            assert_non_null(gb->v);
            assert_memory_equal(ga->dims, gb->dims, sizeof ga->dims);
            size_t n = (size_t)ga->dims[0] * ga->dims[1] * ga->dims[2];
            double sum = 0, mx = 0;
            for (size_t i = 0; i < n; i++) {
                double d = fabs((double)ga->v[i] - gb->v[i]);
                sum += d;
                if (d > mx) mx = d;
                if (ga->v[i] < t_min) t_min = ga->v[i];
            }
            if (sum / n > worst_mean) worst_mean = sum / n;
            if (mx > worst_max) worst_max = mx;
        }
        printf("  env_sweep %.1f vs shadow rays: worst mean |dT| %.4f, worst max |dT| %.4f, darkest node T %.3f\n",
               cases[c].sweep, worst_mean, worst_max, t_min);
        assert_true(t_min < 0.3);
        if (worst_mean > cases[c].mean || worst_max > cases[c].max)
            fail_msg("env_sweep %.1f vs shadow rays: mean |dT| %.4f, max %.4f", cases[c].sweep, worst_mean, worst_max);
    }
    /* the parameter rebuilds the caches the other way */
    uint64_t builds = b->env_cache_builds;
    assert_int_equal(volux_scene_set_param(ss, "single", "env_sweep", 0, NULL), VOLUX_OK);
    assert_int_equal(volux_technique_update(ts, ss, NULL), VOLUX_OK);
    assert_int_equal(b->env_cache_builds, builds + 1);
    for (int k = 0; k < a->n_env_dirs; k++)
        assert_memory_equal(a->env_cache[k].v, b->env_cache[k].v, a->env_cache[k].bytes);
    volux_technique_destroy(tr);
    volux_technique_destroy(ts);
    volux_scene_destroy(sr);
    volux_scene_destroy(ss);
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

/* ------------------------------------------------------------------ progress */

typedef struct progress_log {
    int calls, other, backwards, cancel_after;
    double last;
} progress_log;

static int log_progress(void *user, const char *task, double fraction) {
    progress_log *l = user;
    if (strcmp(task, "preparing single")) {
        l->other++;
        return 0;
    }
    if (fraction < l->last) l->backwards++;
    l->last = fraction;
    l->calls++;
    return l->cancel_after > 0 && l->calls >= l->cancel_after;
}

/* The preparation reports "preparing single" from 0 to 1, never going
 * back; a callback that answers nonzero cancels it (VOLUX_ERR_CANCELLED,
 * nothing leaked, no cache left half built: the next update builds them
 * all and equals a fresh instance). */
static void test_preparation_reports_progress_and_cancels(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    progress_log log = {0};
    volux_context_set_progress(ctx, log_progress, &log);
    volux_scene *s = cloud_scene(ctx, 0.5);
    volux_technique *t = NULL;
    assert_int_equal(volux_technique_create(ctx, "single", s, &t), VOLUX_OK);
    printf("  progress: %d reports, last %.3f\n", log.calls, log.last);
    assert_true(log.calls >= 16);
    assert_int_equal(log.backwards, 0);
    assert_true(log.last == 1.0);
    volux_technique_destroy(t);
    /* cancel half-way through the environment caches */
    progress_log cancel = {0};
    cancel.cancel_after = log.calls / 2;
    volux_context_set_progress(ctx, log_progress, &cancel);
    const uint64_t scene_bytes = volux_context_bytes_in_use(ctx);
    assert_int_equal(volux_technique_create(ctx, "single", s, &t), VOLUX_ERR_CANCELLED);
    volux_context_clear_error(ctx);
    assert_int_equal(volux_context_bytes_in_use(ctx), scene_bytes);
    /* an instance cancelled in an update recovers on the next one */
    volux_context_set_progress(ctx, NULL, NULL);
    assert_int_equal(volux_technique_create(ctx, "single", s, &t), VOLUX_OK);
    assert_int_equal(volux_edit_apply(volux_edit_find("tf"), s, 0), VOLUX_OK);
    progress_log again = {0};
    again.cancel_after = 3;
    volux_context_set_progress(ctx, log_progress, &again);
    assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_ERR_CANCELLED);
    volux_context_clear_error(ctx);
    volux_context_set_progress(ctx, NULL, NULL);
    assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_OK);
    volux_technique *f = NULL;
    assert_int_equal(volux_technique_create(ctx, "single", s, &f), VOLUX_OK);
    const single_state *a = volux_technique_state(t), *b = volux_technique_state(f);
    for (int k = 0; k < a->n_env_dirs; k++) {
        assert_non_null(a->env_cache[k].v);
        assert_memory_equal(a->env_cache[k].v, b->env_cache[k].v, a->env_cache[k].bytes);
    }
    volux_technique_destroy(f);
    volux_technique_destroy(t);
    volux_scene_destroy(s);
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

/* light_sweep does for a directional light's cache what env_sweep does for
 * the environment's: parallel rays read back in light space. Against one
 * shadow ray per node, at the default spacing (one cache cell), for three
 * oblique directions: the same bounds as the environment's (the same
 * interpolation), and switching the parameter off rebuilds the cache
 * bit-identical to the rays. */
static void test_light_sweep_matches_shadow_rays(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    static const double dirs[][3] = {{-0.5, -0.7, -0.5}, {0.9, -0.2, 0.1}, {0.1, 0.3, 0.95}};
    for (size_t d = 0; d < sizeof dirs / sizeof dirs[0]; d++) {
        volux_scene *sc[2] = {NULL, NULL};
        volux_technique *t[2] = {NULL, NULL};
        for (int k = 0; k < 2; k++) {
            char json[1024];
            snprintf(json, sizeof json,
                     "{\"volume\": {\"procedural\": \"cloud\", \"dims\": [48, 40, 36]},"
                     " \"transfer_function\": {\"extinction\": [[0, 0], [30, 0], [255, 0.35]], \"albedo\": 0.8},"
                     " \"lights\": [{\"type\": \"directional\", \"direction\": [%g, %g, %g]}],"
                     " \"render\": {\"width\": 16, \"height\": 16},"
                     " \"techniques\": {\"single\": {\"cache_scale\": 1, \"light_sweep\": %d}}}",
                     dirs[d][0], dirs[d][1], dirs[d][2], k);
            if (volux_scene_load_string(ctx, json, tu_temp_path(""), "sweep.json", NULL, 0, &sc[k]))
                fail_msg("scene: %s", volux_context_error(ctx));
            assert_int_equal(volux_technique_create(ctx, "single", sc[k], &t[k]), VOLUX_OK);
        }
        const single_state *a = volux_technique_state(t[0]), *b = volux_technique_state(t[1]);
        const scatter_grid *ga = &a->slot[0].cache, *gb = &b->slot[0].cache;
        assert_non_null(ga->v);
        assert_non_null(gb->v);
        assert_memory_equal(ga->dims, gb->dims, sizeof ga->dims);
        size_t n = (size_t)ga->dims[0] * ga->dims[1] * ga->dims[2];
        double sum = 0, mx = 0, t_min = 1;
        for (size_t i = 0; i < n; i++) {
            double e = fabs((double)ga->v[i] - gb->v[i]);
            sum += e;
            if (e > mx) mx = e;
            if (ga->v[i] < t_min) t_min = ga->v[i];
        }
        printf("  light_sweep 1 vs shadow rays, direction %zu: mean |dT| %.4f, max |dT| %.4f, darkest node T %.3f\n", d,
               sum / n, mx, t_min);
        assert_true(t_min < 0.5);
        if (sum / n > 0.02 || mx > 0.3) fail_msg("light_sweep 1 vs shadow rays: mean |dT| %.4f, max %.4f", sum / n, mx);
        if (d == 0) { /* back to rays: the same cache as the rays' instance */
            assert_int_equal(volux_scene_set_param(sc[1], "single", "light_sweep", 0, NULL), VOLUX_OK);
            assert_int_equal(volux_technique_update(t[1], sc[1], NULL), VOLUX_OK);
            assert_memory_equal(ga->v, b->slot[0].cache.v, ga->bytes);
        }
        for (int k = 0; k < 2; k++) {
            volux_technique_destroy(t[k]);
            volux_scene_destroy(sc[k]);
        }
    }
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_constant_sky_energy),
        cmocka_unit_test(test_one_texel_map_energy),
        cmocka_unit_test(test_ignored_sky_warns_once),
        cmocka_unit_test(test_env_sweep_matches_shadow_rays),
        cmocka_unit_test(test_light_sweep_matches_shadow_rays),
        cmocka_unit_test(test_preparation_reports_progress_and_cancels),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
