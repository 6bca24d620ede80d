/*
 * Extreme but valid inputs through every registered technique: no hang, no
 * non-finite pixel (issue 16, items 1 and 3).
 *
 * For every technique of the registry (a technique added later is covered
 * by registering) and every case below, the image must be finite in every
 * channel of every pixel:
 *   - TF extinction 1e30 (the free path is far below one ulp of the ray
 *     distance: delta and ratio tracking must still advance or terminate),
 *     and 1e30 × density_scale 1e30 (σt beyond float range),
 *   - TF extinction 1e-30 (a vacuum that is not quite one),
 *   - an environment map of 65504-valued texels (half's largest value)
 *     beside an almost black one,
 *   - Henyey–Greenstein g = ±0.999 in a scattering medium,
 *   - a float volume whose values span ±1.7e38 (just inside what float
 *     differences hold; a wider span is refused, see the last test).
 * The 1e30 cases also check that the dense medium is opaque (the camera
 * sees no background through it), and every case prints its time per
 * technique: a hang shows up as this test's ctest timeout, speed figures go
 * to docs/ROBUSTNESS.md, never into an assertion.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "test_util.h"
#include "tu_volume.h"

static double now_ms(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

/* A small equirectangular PFM: every texel `value`, except a 2×1 "sun" of
 * `sun` (importance sampling then sees a very peaked distribution). */
static void write_env(const char *name, float value, float sun) {
    enum { W = 16, H = 8 };
    char head[64];
    int hn = snprintf(head, sizeof head, "PF\n%d %d\n-1.0\n", W, H);
    static unsigned char buf[64 + W * H * 12];
    memcpy(buf, head, (size_t)hn);
    float *px = (float *)(void *)(buf + hn);
    for (int i = 0; i < W * H; i++) {
        float v = (i == 3 * W + 5 || i == 3 * W + 6) ? sun : value;
        float rgb[3] = {v, v, v};
        memcpy((unsigned char *)px + 12 * (size_t)i, rgb, 12);
    }
    tu_write_file(name, buf, (size_t)hn + W * H * 12);
}

/* A 12³ float volume holding values across ±m. */
static void write_huge_volume(const char *name, float m) {
    enum { N = 12 };
    static float v[N * N * N];
    for (int i = 0; i < N * N * N; i++) v[i] = (i % 3 == 0) ? -m : (i % 3 == 1 ? m : (float)i);
    tu_write_file(name, v, sizeof v);
}

typedef struct extreme_case {
    const char *name;
    const char *json;
    int opaque; /* the medium is so dense that no background shows through */
} extreme_case;

#define LIGHTS                                                                                              \
    " \"lights\": [{\"type\": \"directional\", \"direction\": [-0.4, -1, -0.3], \"irradiance\": 2},"       \
    "   {\"type\": \"point\", \"position\": [30, 20, 25], \"intensity\": 900},"                            \
    "   {\"type\": \"sphere\", \"position\": [0, 40, 0], \"radius\": 4, \"radiance\": 5},"                 \
    "   {\"type\": \"environment\", \"radiance\": 0.3, \"visible\": false}],"
#define RENDER                                                                                              \
    " \"background\": [0.5, 0.25, 0.125],"                                                                  \
    " \"camera\": {\"orbit\": {\"azimuth\": 35, \"elevation\": 25}, \"fov_y\": 40},"                       \
    " \"render\": {\"width\": 12, \"height\": 10, \"spp\": 2, \"step\": 1, \"max_depth\": 16, \"threads\": 1}," \
    " \"techniques\": {\"ambient\": {\"radius\": 2, \"table_theta\": 16, \"table_sigma\": 16, \"table_g\": 3,"   \
    "                                \"table_paths\": 64, \"table_albedo\": 0.8},"                        \
    "                 \"manylights\": {\"vl_count\": 32, \"avsm_resolution\": 8}}}"

static const extreme_case cases[] = {
    {"extinction 1e30",
     "{\"volume\": {\"procedural\": \"constant\", \"dims\": [16, 14, 12]},"
     " \"transfer_function\": {\"extinction\": [[0, 1e30], [2, 1e30]], \"albedo\": 0.9}," LIGHTS RENDER,
     1},
    {"extinction 1e30 x density 1e30",
     "{\"volume\": {\"procedural\": \"cloud\", \"dims\": [16, 14, 12]},"
     " \"transfer_function\": {\"extinction\": [[0, 1e30], [255, 1e30]], \"density_scale\": 1e30,"
     "   \"albedo\": 1}," LIGHTS RENDER,
     1},
    {"extinction 1e30 peak",
     "{\"volume\": {\"procedural\": \"cloud\", \"dims\": [16, 14, 12]},"
     " \"transfer_function\": {\"extinction\": [[0, 0], [100, 0], [101, 1e30], [255, 1e30]], \"albedo\": 0.9}," LIGHTS
     RENDER,
     0},
    {"extinction 1e-30",
     "{\"volume\": {\"procedural\": \"cloud\", \"dims\": [16, 14, 12]},"
     " \"transfer_function\": {\"extinction\": [[0, 1e-30], [255, 1e-30]], \"albedo\": 0.9}," LIGHTS RENDER,
     0},
    {"environment 65504",
     "{\"volume\": {\"procedural\": \"cloud\", \"dims\": [16, 14, 12]},"
     " \"transfer_function\": {\"opacity\": [[0, 0], [255, 0.3]], \"albedo\": 0.9},"
     " \"lights\": [{\"type\": \"environment\", \"file\": \"env65504.pfm\"},"
     "   {\"type\": \"environment\", \"file\": \"envsun.pfm\", \"intensity\": 2}]," RENDER,
     0},
    {"environment 3e38 (clamped)",
     "{\"volume\": {\"procedural\": \"cloud\", \"dims\": [16, 14, 12]},"
     " \"transfer_function\": {\"opacity\": [[0, 0], [255, 0.3]], \"albedo\": 0.9},"
     " \"lights\": [{\"type\": \"environment\", \"file\": \"envhuge.pfm\", \"intensity\": 1000}]," RENDER,
     0},
    {"anisotropy 0.999",
     "{\"volume\": {\"procedural\": \"cloud\", \"dims\": [16, 14, 12]},"
     " \"transfer_function\": {\"opacity\": [[0, 0], [255, 0.5]], \"albedo\": 1, \"anisotropy\": 0.999}," LIGHTS
     RENDER,
     0},
    {"anisotropy -0.999",
     "{\"volume\": {\"procedural\": \"cloud\", \"dims\": [16, 14, 12]},"
     " \"transfer_function\": {\"opacity\": [[0, 0], [255, 0.5]], \"albedo\": 1, \"anisotropy\": -0.999}," LIGHTS
     RENDER,
     0},
    {"values +-1.7e38",
     "{\"volume\": {\"file\": \"huge.raw\", \"dims\": [12, 12, 12], \"type\": \"float32\"},"
     " \"transfer_function\": {\"opacity\": [[-1e30, 0.2], [1e30, 0.8]], \"albedo\": 0.9}," LIGHTS RENDER,
     0},
};

/* Techniques not yet hardened for these inputs are skipped with a visible
 * message, so a gap stays visible; none at the moment (manylights was until
 * its tracker got the regular-tracking fallback and its ξ·σ1 the σt cap). */
static const char *const not_yet_hardened[] = {NULL};

static int skipped(const char *name) {
    for (size_t i = 0; i < sizeof not_yet_hardened / sizeof not_yet_hardened[0]; i++)
        if (not_yet_hardened[i] && !strcmp(name, not_yet_hardened[i])) return 1;
    return 0;
}

static void check_case(const extreme_case *c) {
    write_env("env65504.pfm", 65504.0f, 65504.0f);
    write_env("envsun.pfm", 1e-6f, 65504.0f);
    write_env("envhuge.pfm", 3e38f, 3e38f);
    write_huge_volume("huge.raw", 1.7e38f);
    for (int k = 0; k < volux_technique_count(); k++) {
        const char *name = volux_technique_info_at(k)->name;
        if (skipped(name)) {
            printf("  %-32s %-10s SKIPPED: not yet hardened (issue 16 follow-up)\n", c->name, name);
            continue;
        }
        volux_context *ctx = tu_context(1);
        char override[96];
        snprintf(override, sizeof override, "render.technique=\"%s\"", name);
        const char *ov[1] = {override};
        volux_scene *s = NULL;
        if (volux_scene_load_string(ctx, c->json, tu_temp_path(""), "extreme.json", ov, 1, &s))
            fail_msg("%s / %s: scene: %s", c->name, name, volux_context_error(ctx));
        double t0 = now_ms();
        volux_technique *t = NULL;
        if (volux_technique_create(ctx, name, s, &t))
            fail_msg("%s / %s: create: %s", c->name, name, volux_context_error(ctx));
        volux_image img = tu_render_with(ctx, s, t);
        double ms = now_ms() - t0;
        size_t n = 3 * (size_t)img.width * (size_t)img.height, bad = 0, first = 0;
        double background_seen = 0.0;
        for (size_t i = 0; i < n; i++) {
            if (!isfinite(img.rgb[i]) && !bad++) first = i;
        }
        if (bad)
            fail_msg("%s / %s: %zu non-finite channel values, the first at pixel %zu (value %g)", c->name, name, bad,
                     first / 3, img.rgb[first]);
        /* Corner pixels miss the volume and show the background; the
         * centre pixel looks through the box. In an opaque medium it sees
         * no background (the camera ray cannot pass). */
        if (c->opaque) {
            int cx = img.width / 2, cy = img.height / 2;
            background_seen = fabs(tu_pixel(&img, cx, cy, 0) - 0.5) < 1e-6 &&
                              fabs(tu_pixel(&img, cx, cy, 1) - 0.25) < 1e-6;
            if (background_seen) fail_msg("%s / %s: the background shows through an opaque medium", c->name, name);
        }
        printf("  %-32s %-10s %8.1f ms\n", c->name, name, ms);
        volux_image_free(ctx, &img);
        volux_technique_destroy(t);
        volux_scene_destroy(s);
        assert_int_equal(volux_context_bytes_in_use(ctx), 0);
        volux_context_destroy(ctx);
    }
}

#define CASE(i)                                                                                            \
    static void test_case_##i(void **state) {                                                              \
        (void)state;                                                                                       \
        check_case(&cases[i]);                                                                             \
    }
CASE(0)
CASE(1)
CASE(2)
CASE(3)
CASE(4)
CASE(5)
CASE(6)
CASE(7)
CASE(8)

/* --time-ms is honoured inside a path: the camera sits at the centre of a
 * white (albedo 1), dense medium (optical depth 2000·32 to the boundary),
 * so no path can escape and every one scatters max_depth = 1e5 times (no
 * roulette at throughput 1): seconds of work per wave, far more than the
 * budget on any machine. (A camera outside let most paths escape within a
 * few hundred events: a quiet machine finished the wave in the budget.)
 * The render returns with the first wave kept and reported as cut short,
 * with a warning; the ctest timeout would catch a render that ignores the
 * budget. */
static void test_time_budget_ends_long_paths(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    tu_messages messages = {0};
    volux_context_set_message(ctx, tu_collect_messages, &messages);
    volux_scene *s = tu_scene(ctx, "{\"volume\": {\"procedural\": \"constant\", \"dims\": [32, 32, 32]},"
                                   " \"transfer_function\": {\"extinction\": [[0, 2000], [2, 2000]], \"albedo\": 1},"
                                   " \"camera\": {\"eye\": [0, 0, 0], \"look_at\": [0, 0, 1]},"
                                   " \"lights\": [{\"type\": \"environment\", \"radiance\": 1}],"
                                   " \"render\": {\"technique\": \"pathtrace\", \"width\": 32, \"height\": 32,"
                                   "   \"spp\": 64, \"max_depth\": 100000, \"threads\": 2}}");
    volux_technique *t = NULL;
    assert_int_equal(volux_technique_create(ctx, "pathtrace", s, &t), VOLUX_OK);
    volux_framebuffer *fb = NULL;
    assert_int_equal(volux_framebuffer_create(ctx, 32, 32, &fb), VOLUX_OK);
    volux_render_limits lim = {64, 100.0, 0.0};
    volux_render_report rep;
    memset(&rep, 0, sizeof rep);
    double t0 = now_ms();
    assert_int_equal(volux_render(t, s, fb, &lim, &rep), VOLUX_OK);
    printf("  time budget 100 ms: returned after %.1f ms, %u spp, truncated %d\n", now_ms() - t0, rep.spp,
           rep.truncated);
    assert_int_equal(rep.spp, 1);
    assert_int_equal(rep.truncated, 1);
    assert_int_equal(messages.warnings, 1);
    volux_image img = {0};
    assert_int_equal(volux_framebuffer_resolve(fb, &img), VOLUX_OK);
    for (int i = 0; i < 3 * img.width * img.height; i++) assert_true(isfinite(img.rgb[i]));
    volux_image_free(ctx, &img);
    volux_framebuffer_destroy(fb);
    volux_technique_destroy(t);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

/* A map holding Inf or NaN is refused, naming the light and the texel. */
static void test_nonfinite_environment_texels_are_refused(void **state) {
    (void)state;
    write_env("envinf.pfm", 1.0f, INFINITY);
    volux_context *ctx = tu_context(1);
    volux_scene *s = NULL;
    const char *json = "{\"volume\": {\"procedural\": \"cloud\", \"dims\": [8, 8, 8]},"
                       " \"transfer_function\": {\"opacity\": [[0, 0], [255, 0.3]]},"
                       " \"lights\": [{\"type\": \"environment\", \"file\": \"envinf.pfm\"}]}";
    assert_int_equal(volux_scene_load_string(ctx, json, tu_temp_path(""), "inf.json", NULL, 0, &s), VOLUX_ERR_INVALID);
    tu_assert_error_mentions(ctx, "inf.json", "lights[0].file", "6 non-finite", "texel (5, 4)", (const char *)NULL); /* PFM rows go bottom-up */
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

/* Values whose span max − min exceeds FLT_MAX cannot be mapped onto a
 * table in float (inf·0 = NaN): refused with the range named. */
static void test_value_span_beyond_float_is_refused(void **state) {
    (void)state;
    write_huge_volume("wider.raw", 3e38f);
    volux_context *ctx = tu_context(1);
    volux_raw_desc raw = {{12, 12, 12}, VOLUX_FLOAT32, 0, {1, 1, 1}, 0};
    volux_volume_load_options o;
    memset(&o, 0, sizeof o);
    o.raw = &raw;
    volux_volume *v = NULL;
    assert_int_equal(volux_volume_load(ctx, tu_temp_path("wider.raw"), &o, &v), VOLUX_ERR_LIMIT);
    tu_assert_error_mentions(ctx, "wider.raw", "values span", "rescale", (const char *)NULL);
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

int main(void) {
    _Static_assert(sizeof cases / sizeof cases[0] == 9, "one test per case");
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_case_0), cmocka_unit_test(test_case_1), cmocka_unit_test(test_case_2),
        cmocka_unit_test(test_case_3), cmocka_unit_test(test_case_4), cmocka_unit_test(test_case_5),
        cmocka_unit_test(test_case_6), cmocka_unit_test(test_case_7), cmocka_unit_test(test_case_8),
        cmocka_unit_test(test_value_span_beyond_float_is_refused),
        cmocka_unit_test(test_nonfinite_environment_texels_are_refused),
        cmocka_unit_test(test_time_budget_ends_long_paths),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
