/*
 * 5 000 point lights (issue 16: "manylights users will have thousands").
 *
 * Scene: a 16³ procedural cloud, albedo 0.9, g = 0.3, 5 000 point lights of
 * equal intensity on a sphere of radius 30 around it (a Fibonacci spiral),
 * single scattering (max_depth 1: both techniques sample every light at
 * every scattering point; multiple scattering would need ≥ 5 000 VLs, an
 * AVSM each, far too slow for a unit test). Image means over 4 seeds give
 * a mean and its standard error.
 *
 * 1. Sum of its parts: manylights with all lights equals manylights with
 *    slots 0..2499 plus manylights with slots 2500..4999 (the part far past
 *    the old cap of 256 alone). Its single scattering loops over every
 *    light at the same samples (same seeds), so the sum holds to float
 *    rounding (bound 1e-4 relative; measured 1.5e-9); each half carries
 *    30–70 % of the whole. A slot that is dropped, counted twice or mixed
 *    up with another moves the sum.
 * 2. Against pathtrace: within 10 %. Measured +6.5 % (z = 3.2); before
 *    the midpoint fix of render.c (x was placed half a step in front of
 *    the extinction sample that weights it) +8.1 %. The rest is not
 *    manylights' direct term: `single` is as bright on this 8 x 8 image
 *    (+6.3 % at 16 spp), and the same scene gives −0.4 % with `single` at
 *    24² — 64 pixels of a cloud's silhouette sample its mean poorly.
 * 3. One light (directional, then point) on a 32² image with 64 spp, the
 *    direct term alone: within 3 % of pathtrace (2048 spp). Measured
 *    +0.9 % / +0.9 % (the rest is the shadow march's midpoint rule:
 *    +0.3 % with shadow_step 0.1); the directional case was +8.0 %
 *    before the midpoint fix.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "test_util.h"

#define N_LIGHTS 5000
#define SEEDS 4

static char *scene_json(void) {
    char *s = malloc((size_t)N_LIGHTS * 128 + 1024), *p = s;
    assert_non_null(s);
    p += sprintf(p, "{\"volume\": {\"procedural\": \"cloud\", \"dims\": [16, 16, 16]},"
                    " \"transfer_function\": {\"extinction\": [[0, 0], [40, 0.0], [255, 0.8]],"
                    "   \"color\": [[0, 1, 1, 1], [255, 0.9, 0.8, 0.7]], \"albedo\": 0.9, \"anisotropy\": 0.3},"
                    " \"camera\": {\"orbit\": {\"azimuth\": 30, \"elevation\": 20}, \"fov_y\": 30},"
                    " \"render\": {\"width\": 8, \"height\": 8, \"spp\": 16, \"max_depth\": 1, \"threads\": 2},"
                    " \"lights\": [");
    const double golden = 3.14159265358979 * (3.0 - sqrt(5.0));
    for (int i = 0; i < N_LIGHTS; i++) {
        double z = 1.0 - 2.0 * (i + 0.5) / N_LIGHTS, r = sqrt(1.0 - z * z);
        p += sprintf(p, "%s{\"type\": \"point\", \"position\": [%.4f, %.4f, %.4f], \"intensity\": %.6f,"
                        " \"color\": [1, 0.9, 0.8]}",
                     i ? "," : "", 30.0 * r * cos(golden * i), 30.0 * r * sin(golden * i), 30.0 * z,
                     2000.0 / N_LIGHTS);
    }
    sprintf(p, "]}");
    return s;
}

static double image_mean(const volux_image *img) {
    double s = 0.0;
    size_t n = 3 * (size_t)img->width * (size_t)img->height;
    for (size_t i = 0; i < n; i++) s += img->rgb[i];
    return s / (double)n;
}

/* Mean and standard error of the image mean over SEEDS seeds. */
static void seeded_means(volux_context *ctx, volux_scene *s, const char *technique, int spp, double *mean,
                         double *se) {
    double m[SEEDS], sum = 0.0, sq = 0.0;
    volux_render_settings rs = *volux_scene_render(s);
    for (int k = 0; k < SEEDS; k++) {
        rs.seed = 101 + (uint64_t)k;
        rs.spp = spp;
        assert_int_equal(volux_scene_set_render(s, &rs), VOLUX_OK);
        volux_image img = tu_render(ctx, s, technique);
        m[k] = image_mean(&img);
        sum += m[k];
        volux_image_free(ctx, &img);
    }
    *mean = sum / SEEDS;
    for (int k = 0; k < SEEDS; k++) sq += (m[k] - *mean) * (m[k] - *mean);
    *se = sqrt(sq / (SEEDS - 1) / SEEDS);
}

static void enable_range(volux_scene *s, int from, int to, int on) {
    for (int i = from; i < to; i++) assert_int_equal(volux_scene_set_light_enabled(s, i, on), VOLUX_OK);
}

static void test_5000_point_lights(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    char *json = scene_json();
    volux_scene *s = tu_scene(ctx, json);
    free(json);
    assert_int_equal(volux_scene_light_slots(s), N_LIGHTS);
    double m_all, se_all, m_a, se_a, m_b, se_b, m_pt, se_pt;
    seeded_means(ctx, s, "manylights", 16, &m_all, &se_all);
    seeded_means(ctx, s, "pathtrace", 256, &m_pt, &se_pt);
    enable_range(s, N_LIGHTS / 2, N_LIGHTS, 0);
    seeded_means(ctx, s, "manylights", 16, &m_a, &se_a);
    enable_range(s, N_LIGHTS / 2, N_LIGHTS, 1);
    enable_range(s, 0, N_LIGHTS / 2, 0);
    seeded_means(ctx, s, "manylights", 16, &m_b, &se_b);
    double rel_sum = (m_a + m_b) / m_all - 1.0;
    double z_pt = (m_all - m_pt) / sqrt(se_all * se_all + se_pt * se_pt);
    printf("  %d point lights, manylights: all %.5g ± %.2g, slots < 2500 %.5g ± %.2g, slots >= 2500 %.5g ± %.2g"
           " (sum of the halves %+.2g relative)\n",
           N_LIGHTS, m_all, se_all, m_a, se_a, m_b, se_b, rel_sum);
    printf("  pathtrace %.5g ± %.2g: manylights %+.1f%% (z = %.1f)\n", m_pt, se_pt, 100.0 * (m_all / m_pt - 1.0),
           z_pt);
    assert_true(m_pt > 0.0 && m_a > 0.0 && m_b > 0.0);
    assert_true(fabs(rel_sum) < 1e-4);
    assert_true(m_b > 0.3 * m_all && m_b < 0.7 * m_all);
    assert_true(fabs(m_all / m_pt - 1.0) < 0.10);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

static void one_light(const char *light, double *ml, double *pt) {
    char json[1024];
    snprintf(json, sizeof json,
             "{\"volume\": {\"procedural\": \"cloud\", \"dims\": [16, 16, 16]},"
             " \"transfer_function\": {\"extinction\": [[0, 0], [40, 0.0], [255, 0.8]],"
             "   \"color\": [[0, 1, 1, 1], [255, 0.9, 0.8, 0.7]], \"albedo\": 0.9, \"anisotropy\": 0.3},"
             " \"camera\": {\"orbit\": {\"azimuth\": 30, \"elevation\": 20}, \"fov_y\": 30},"
             " \"render\": {\"width\": 32, \"height\": 32, \"spp\": 64, \"max_depth\": 1, \"threads\": 2},"
             " \"lights\": [%s]}",
             light);
    volux_context *ctx = tu_context(2);
    volux_scene *s = tu_scene(ctx, json);
    volux_image a = tu_render(ctx, s, "manylights");
    volux_render_settings rs = *volux_scene_render(s);
    rs.spp = 2048;
    assert_int_equal(volux_scene_set_render(s, &rs), VOLUX_OK);
    volux_image b = tu_render(ctx, s, "pathtrace");
    *ml = image_mean(&a);
    *pt = image_mean(&b);
    volux_image_free(ctx, &a);
    volux_image_free(ctx, &b);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

/* The direct term with one light: the light, the shadow ray, the phase
 * function and the camera transmittance each enter once. */
static void test_one_light(void **state) {
    (void)state;
    static const char *const lights[2] = {
        "{\"type\": \"directional\", \"direction\": [-0.5, -0.7, -0.5], \"irradiance\": 3.0}",
        "{\"type\": \"point\", \"position\": [0, 0, 30], \"intensity\": 2000, \"color\": [1, 0.9, 0.8]}"};
    for (int i = 0; i < 2; i++) {
        double ml, pt;
        one_light(lights[i], &ml, &pt);
        printf("  one %s light: manylights %.5g, pathtrace %.5g (%+.1f%%)\n", i ? "point" : "directional", ml, pt,
               100.0 * (ml / pt - 1.0));
        assert_true(pt > 0.0);
        assert_true(fabs(ml / pt - 1.0) < 0.03);
    }
}

int main(void) {
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_one_light), cmocka_unit_test(test_5000_point_lights)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
