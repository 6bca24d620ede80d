/*
 * `guided` against `pathtrace` (docs/techniques/guided.md, "Error against
 * pathtrace"). Both estimators are unbiased for the same scene, so their
 * per-pixel means differ only by noise: for every pixel and channel
 *     z = (m_guided − m_pathtrace) / sqrt(se_g² + se_p²)
 * is standard normal. The scene is where guiding matters — a cloud lit by
 * a sky with a small sun (a 400× brighter patch), multiple scattering
 * (max_depth 2), anisotropic phase, RGB albedo — rendered with every
 * strategy and, for two_step, with and without MIS, with guided
 * multiple scattering and with guided continuation directions
 * (guide_continuation 0.5: the phase/environment-density mixture).
 *
 * Bounds: no pixel channel beyond |z| = 5 (family-wise false alarm < 1e-3
 * over 256 pixels × 3 channels × 14 configurations), the image mean within
 * 4 standard errors of pathtrace's, and that standard error below 2.5 % of
 * the mean (so the bound is tight enough to mean something). The pixel
 * check needs light-tailed estimates: under the sun only the strategies
 * that follow the environment are compared.
 * Measured (seed 1, 1024 spp guided, 2048 spp pathtrace, 16×16, max_depth
 * 2): image-mean differences −1.1 % … +0.6 %, at most 1.4 standard errors
 * (the runs share pathtrace's noise); largest pixel |z| 2.7.
 *
 * The test can fail: with the product density reported 10 % too high in
 * guided_event_sample (a density that no longer matches the samples: the
 * estimator is biased) the product runs fail the image-mean bound in both
 * scenes (−3.6 % and −6.5 %, 4.5 standard errors).
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "pt_util.h"

static void make_sky(volux_context *ctx, volux_image *m, int sun) {
    assert_int_equal(volux_image_create(ctx, 64, 32, m), VOLUX_OK);
    for (int y = 0; y < 32; y++)
        for (int x = 0; x < 64; x++) {
            float *p = &m->rgb[3 * (y * 64 + x)];
            float sky = y < 16 ? 0.3f + 0.7f * (1.0f - (float)y / 16.0f) : 0.05f;
            p[0] = 0.8f * sky, p[1] = 0.9f * sky, p[2] = sky;
            if (sun && x >= 40 && x < 43 && y >= 9 && y < 11) p[0] = p[1] = p[2] = 400.0f;
        }
}

static volux_scene *sky_scene(volux_context *ctx, int sun) {
    volux_scene *s = tu_scene(
        ctx, "{\"volume\": {\"procedural\": \"cloud\", \"dims\": [24, 24, 24], \"seed\": 4},"
             " \"transfer_function\": {\"extinction\": [[0, 0], [30, 0], [255, 0.9]], \"albedo\": 0.9,"
             "   \"anisotropy\": 0.3, \"color\": [[0, 1, 0.9, 0.8], [255, 0.8, 0.9, 1]]},"
             " \"camera\": {\"orbit\": {\"azimuth\": 20, \"elevation\": 10}, \"fov_y\": 30},"
             " \"render\": {\"technique\": \"guided\", \"width\": 16, \"height\": 16, \"max_depth\": 2},"
             " \"techniques\": {\"guided\": {\"env_resolution\": 64, \"cell\": 3}}}");
    volux_image map;
    make_sky(ctx, &map, sun);
    volux_light_desc l;
    volux_light_desc_defaults(&l, VOLUX_LIGHT_ENVIRONMENT);
    l.map = &map;
    l.rotation_y_deg = 30.0f;
    l.visible = 0;
    assert_int_equal(volux_scene_set_light(s, 0, &l), VOLUX_OK);
    volux_image_free(ctx, &map);
    return s;
}

static pt_stats render_stats(volux_context *ctx, volux_scene *s, const char *technique, int spp) {
    volux_technique *t;
    if (volux_technique_create(ctx, technique, s, &t)) fail_msg("%s", volux_context_error(ctx));
    pt_stats st;
    pt_accumulate(t, s, spp, &st);
    volux_technique_destroy(t);
    return st;
}

static void compare(const pt_stats *g, const pt_stats *p, const char *what) {
    int n = g->width * g->height;
    double worst = 0.0;
    for (int c = 0; c < 3; c++) {
        double sg = 0.0, sp = 0.0, var = 0.0;
        for (int i = 0; i < n; i++) {
            double eg = pt_stats_se(g, i, c), ep = pt_stats_se(p, i, c);
            double se = sqrt(eg * eg + ep * ep), d = g->mean[3 * i + c] - p->mean[3 * i + c];
            double z = se > 0.0 ? fabs(d) / se : (d != 0.0 ? INFINITY : 0.0);
            if (z > worst) worst = z;
            if (z > 5.0 && fabs(d) > 1e-6)
                fail_msg("%s: pixel %d channel %d: guided %.5f, pathtrace %.5f (z = %.1f)", what, i, c,
                         g->mean[3 * i + c], p->mean[3 * i + c], z);
            sg += g->mean[3 * i + c];
            sp += p->mean[3 * i + c];
            var += se * se;
        }
        double d = (sg - sp) / n, se = sqrt(var) / n, rel = d / (sp / n);
        if (c == 1)
            printf("  %-30s image mean %.5f vs %.5f: %+.2f%% (%.1f se), largest pixel |z| %.1f\n", what, sg / n, sp / n,
                   100.0 * rel, fabs(d) / se, worst);
        /* the bound means something only if the noise is small */
        if (!(se < 0.025 * (sp / n))) fail_msg("%s: standard error %.2g too large for the check", what, se);
        if (fabs(d) > 4.0 * se)
            fail_msg("%s: channel %d image mean %.5f vs pathtrace %.5f (%+.2f%%, %.1f standard errors)", what, c,
                     sg / n, sp / n, 100.0 * rel, fabs(d) / se);
    }
}

typedef struct run {
    const char *strategy;
    int mis, guide_depth;
    double continuation; /* guide_continuation: the mixture for the continuation ray */
} run;

static void check_runs(int sun, const run *runs, int n_runs) {
    volux_context *ctx = tu_context(1);
    volux_scene *s = sky_scene(ctx, sun);
    pt_stats ref = render_stats(ctx, s, "pathtrace", 2048);
    for (int i = 0; i < n_runs; i++) {
        assert_int_equal(volux_scene_set_param(s, "guided", "strategy", 0, runs[i].strategy), VOLUX_OK);
        assert_int_equal(volux_scene_set_param(s, "guided", "mis", runs[i].mis, NULL), VOLUX_OK);
        assert_int_equal(volux_scene_set_param(s, "guided", "guide_depth", runs[i].guide_depth, NULL), VOLUX_OK);
        assert_int_equal(volux_scene_set_param(s, "guided", "guide_continuation", runs[i].continuation, NULL),
                         VOLUX_OK);
        pt_stats g = render_stats(ctx, s, "guided", 1024);
        char what[128];
        snprintf(what, sizeof what, "%s%s, mis %d, guide_depth %d, cont %.1f", sun ? "sun: " : "sky: ",
                 runs[i].strategy, runs[i].mis, runs[i].guide_depth, runs[i].continuation);
        compare(&g, &ref, what);
        pt_stats_free(&g);
    }
    pt_stats_free(&ref);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

/* A smooth sky: every strategy has light tails there. */
static void test_every_strategy_agrees_under_a_smooth_sky(void **state) {
    (void)state;
    static const run runs[] = {{"uniform", 1, 1, 0},  {"environment", 1, 1, 0}, {"visibility", 1, 1, 0},
                               {"product", 1, 1, 0}, {"two_step", 1, 1, 0},    {"two_step", 0, 0, 0},
                               {"two_step", 1, 0, 0.5}};
    check_runs(0, runs, (int)(sizeof runs / sizeof runs[0]));
}

/* A small sun: only the strategies that follow the environment have light
 * tails (uniform and visibility-only sampling find the sun so rarely that
 * a pixel's sample variance says nothing about its error at this spp). */
static void test_environment_following_strategies_agree_under_a_sun(void **state) {
    (void)state;
    static const run runs[] = {{"environment", 1, 1, 0}, {"product", 1, 1, 0}, {"two_step", 1, 1, 0},
                               {"two_step", 0, 1, 0},    {"two_step", 1, 0, 0},  {"two_step", 1, 0, 0.5},
                               {"two_step", 0, 0, 0.5}};
    check_runs(1, runs, (int)(sizeof runs / sizeof runs[0]));
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_every_strategy_agrees_under_a_smooth_sky),
        cmocka_unit_test(test_environment_following_strategies_agree_under_a_sun),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
