/*
 * 5 000 point lights (issue 16: "manylights users will have thousands"):
 * manylights and the reference path tracer agree on a tiny image.
 *
 * Scene: a 16³ procedural cloud, albedo 0.9, g = 0.3, 5 000 point lights of
 * equal intensity on a sphere of radius 30 around it (a Fibonacci spiral),
 * single scattering (max_depth 1: every light is sampled at every camera
 * ray step by both techniques; multiple scattering would need ≥ 5 000 VLs,
 * an AVSM each, far too slow for a unit test).
 *
 * The image mean of each technique over 4 seeds gives a mean and its
 * standard error; the two must agree within 4 standard errors and 8 %.
 * Measured (8×8, manylights 16 spp, pathtrace 256 spp per seed): see the
 * printed line; the difference is ~1 standard error.
 * The lights past slot 255 (the old cap) carry 95 % of the power: switching
 * them off must remove most of the image, so a technique that ignored them
 * fails.
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

static void test_5000_point_lights_agree_with_pathtrace(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    char *json = scene_json();
    volux_scene *s = tu_scene(ctx, json);
    free(json);
    assert_int_equal(volux_scene_light_slots(s), N_LIGHTS);
    double m_ml, se_ml, m_pt, se_pt;
    seeded_means(ctx, s, "manylights", 16, &m_ml, &se_ml);
    seeded_means(ctx, s, "pathtrace", 256, &m_pt, &se_pt);
    double z = (m_ml - m_pt) / sqrt(se_ml * se_ml + se_pt * se_pt);
    printf("  %d point lights: manylights %.5g ± %.2g, pathtrace %.5g ± %.2g (z = %.2f, %+.1f%%)\n", N_LIGHTS, m_ml,
           se_ml, m_pt, se_pt, z, 100.0 * (m_ml / m_pt - 1.0));
    assert_true(m_pt > 0.0);
    assert_true(fabs(z) < 4.0);
    assert_true(fabs(m_ml / m_pt - 1.0) < 0.08);
    /* the lights past slot 255 carry 4744/5000 of the power */
    for (int i = 256; i < N_LIGHTS; i++) assert_int_equal(volux_scene_set_light_enabled(s, i, 0), VOLUX_OK);
    volux_image few = tu_render(ctx, s, "manylights");
    double m_few = image_mean(&few);
    printf("  lights 0..255 alone: %.5g (%.1f%% of all)\n", m_few, 100.0 * m_few / m_ml);
    assert_true(m_few < 0.2 * m_ml);
    assert_true(m_few > 0.0);
    volux_image_free(ctx, &few);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_5000_point_lights_agree_with_pathtrace)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
