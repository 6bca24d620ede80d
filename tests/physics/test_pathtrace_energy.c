/*
 * Energy bounds and spectral albedo.
 *
 * 1. Spectral furnace: colour c(s) = (1, s, 1 − s) with albedo 1 inside a
 *    constant white environment L. The red channel has σs = σt everywhere,
 *    so it is a white furnace and must equal L; green and blue lose energy
 *    and must stay ≤ L. This checks that RGB albedo is carried per channel
 *    (scatter with probability max ρ, weight ρ/max ρ) without leaking energy
 *    between channels.
 * 2. Energy bound: a non-emitting medium with albedo ≤ 1 lit by an
 *    environment map with a bright spot, a sphere light and (invisible to
 *    the bound) nothing else cannot make any pixel brighter than the
 *    brightest emitted radiance: pixel ≤ max(max map radiance, sphere
 *    radiance) per channel, up to 5 standard errors.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "pt_util.h"

static float noise_fn(int i, int j, int k, void *u) {
    (void)u;
    uint32_t h = (uint32_t)(i * 73856093) ^ (uint32_t)(j * 19349663) ^ (uint32_t)(k * 83492791);
    h ^= h >> 13;
    h *= 0x5bd1e995u;
    h ^= h >> 15;
    return (float)(h & 0xffff) / 65535.0f;
}

static void test_spectral_furnace(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_volume *v = pt_volume_fn(ctx, 17, 17, 17, noise_fn, NULL);
    const volux_tf_scalar_point ext[2] = {{0.0f, 0.2f}, {1.0f, 2.0f}};
    const volux_tf_color_point col[2] = {{0.0f, 1.0f, 0.0f, 1.0f}, {1.0f, 1.0f, 1.0f, 0.0f}};
    const float gs[2] = {-0.3f, 0.6f};
    for (int gi = 0; gi < 2; gi++) {
        volux_scene *s = pt_scene(ctx, v, ext, 2, col, 2, 1.0f, gs[gi], 20.0f, 8, 8, 100000);
        pt_add_constant_env(s, (volux_vec3){1.5f, 1.5f, 1.5f}, 1);
        volux_technique *t;
        assert_int_equal(volux_technique_create(ctx, "pathtrace", s, &t), VOLUX_OK);
        pt_stats st;
        pt_accumulate(t, s, 256, &st);
        int n = st.width * st.height;
        double sum[3] = {0, 0, 0}, var[3] = {0, 0, 0};
        for (int p = 0; p < n; p++)
            for (int c = 0; c < 3; c++) {
                double m = st.mean[3 * p + c], se = pt_stats_se(&st, p, c);
                sum[c] += m;
                var[c] += se * se;
                if (c == 0 && fabs(m - 1.5) > 5.0 * se + 1e-5)
                    fail_msg("g=%.1f pixel %d red = %.5f, expected 1.5 (se %.5f)", gs[gi], p, m, se);
                if (c > 0 && m > 1.5 + 5.0 * se + 1e-5)
                    fail_msg("g=%.1f pixel %d channel %d = %.5f exceeds 1.5 (se %.5f)", gs[gi], p, c, m, se);
            }
        double se0 = sqrt(var[0]) / n;
        printf("  spectral furnace g=%+.1f: mean rgb (%.4f, %.4f, %.4f), red se %.4f\n", gs[gi], sum[0] / n,
               sum[1] / n, sum[2] / n, se0);
        assert_true(fabs(sum[0] / n - 1.5) <= 3.0 * se0 && fabs(sum[0] / n - 1.5) < 0.015 * 1.5);
        assert_true(sum[1] / n < 1.5 && sum[2] / n < 1.5); /* they do absorb */
        pt_stats_free(&st);
        volux_technique_destroy(t);
        volux_scene_destroy(s);
    }
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

static void test_pixels_never_exceed_the_brightest_emitter(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_volume *v = pt_volume_fn(ctx, 17, 17, 17, noise_fn, NULL);
    const volux_tf_scalar_point ext[3] = {{0.0f, 0.0f}, {0.5f, 3.0f}, {1.0f, 0.3f}};
    const volux_tf_color_point col[2] = {{0.0f, 1.0f, 0.9f, 1.0f}, {1.0f, 0.8f, 1.0f, 1.0f}};
    static float px[3 * 16 * 8];
    /* nearly uniform and bright, so lit pixels come close to the bound */
    for (int i = 0; i < 16 * 8; i++) px[3 * i] = 1.0f, px[3 * i + 1] = 0.9f, px[3 * i + 2] = 1.1f;
    px[3 * 20] = 1.3f, px[3 * 20 + 1] = 1.2f, px[3 * 20 + 2] = 1.4f; /* brightest texel */
    volux_image map = {16, 8, px};
    const float bound[3] = {1.3f, 1.25f, 1.4f}; /* max of the map and the sphere (1.25) */
    const float gs[3] = {-0.6f, 0.0f, 0.8f};
    for (int gi = 0; gi < 3; gi++) {
        volux_scene *s = pt_scene(ctx, v, ext, 3, col, 2, 1.0f, gs[gi], 20.0f, 12, 12, 100000);
        volux_light_desc l;
        volux_light_desc_defaults(&l, VOLUX_LIGHT_ENVIRONMENT);
        l.map = &map;
        assert_int_equal(volux_scene_set_light(s, 0, &l), VOLUX_OK);
        volux_light_desc_defaults(&l, VOLUX_LIGHT_SPHERE);
        l.position = (volux_vec3){0, 0, -14};
        l.radius = 4.0f;
        l.radiance = 1.25f;
        assert_int_equal(volux_scene_set_light(s, 1, &l), VOLUX_OK);
        volux_technique *t;
        assert_int_equal(volux_technique_create(ctx, "pathtrace", s, &t), VOLUX_OK);
        pt_stats st;
        pt_accumulate(t, s, 128, &st);
        double peak = 0.0;
        for (int p = 0; p < st.width * st.height; p++)
            for (int c = 0; c < 3; c++) {
                double m = st.mean[3 * p + c], se = pt_stats_se(&st, p, c);
                if (m / bound[c] > peak) peak = m / bound[c];
                if (m > bound[c] + 5.0 * se + 1e-5)
                    fail_msg("g=%.1f pixel %d channel %d = %.5f exceeds %.1f (se %.5f)", gs[gi], p, c, m, bound[c], se);
            }
        printf("  energy bound g=%+.1f: brightest pixel at %.3f of the bound\n", gs[gi], peak);
        pt_stats_free(&st);
        volux_technique_destroy(t);
        volux_scene_destroy(s);
    }
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_spectral_furnace),
        cmocka_unit_test(test_pixels_never_exceed_the_brightest_emitter),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
