/*
 * Convergence and the frame loop's error estimate, on a heterogeneous
 * white furnace whose exact image is known (L everywhere):
 *   - the measured relative RMS error of the image against L matches the
 *     frame loop's rel_error estimate (within a factor 0.7…1.4), at 16, 64
 *     and 256 spp accumulated in one framebuffer;
 *   - rel_error falls like 1/√spp (16 → 256 spp: a factor 4, accepted in
 *     [3, 5.3]);
 *   - a render bounded by target_error stops once the estimate is below it,
 *     and the true error is then of that size too.
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

static double true_rel_error(volux_context *ctx, volux_framebuffer *fb, double L) {
    volux_image img;
    assert_int_equal(volux_framebuffer_resolve(fb, &img), VOLUX_OK);
    double se = 0.0;
    int n = img.width * img.height;
    for (int p = 0; p < n; p++) {
        const float *c = &img.rgb[3 * p];
        double lum = 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
        se += (lum - L) * (lum - L);
    }
    volux_image_free(ctx, &img);
    return sqrt(se / n) / L;
}

static void test_rel_error_tracks_the_true_error(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    volux_volume *v = pt_volume_fn(ctx, 17, 17, 17, noise_fn, NULL);
    const volux_tf_scalar_point ext[2] = {{0.0f, 0.0f}, {1.0f, 1.5f}};
    volux_scene *s = pt_scene(ctx, v, ext, 2, NULL, 0, 1.0f, 0.5f, 14.0f, 16, 16, 100000);
    pt_add_constant_env(s, (volux_vec3){1, 1, 1}, 1);
    volux_technique *t;
    assert_int_equal(volux_technique_create(ctx, "pathtrace", s, &t), VOLUX_OK);
    volux_framebuffer *fb;
    assert_int_equal(volux_framebuffer_create(ctx, 16, 16, &fb), VOLUX_OK);
    const uint32_t spps[3] = {16, 64, 256};
    double est[3];
    for (int i = 0; i < 3; i++) {
        volux_render_limits lim = {spps[i], 0, 0};
        volux_render_report rep;
        assert_int_equal(volux_render(t, s, fb, &lim, &rep), VOLUX_OK);
        assert_int_equal(rep.spp, spps[i]);
        assert_true(rep.vertices > 0 && rep.samples > 0);
        est[i] = rep.rel_error;
        double act = true_rel_error(ctx, fb, 1.0);
        printf("  %3u spp: rel_error estimate %.4f, true %.4f\n", spps[i], est[i], act);
        assert_true(act / est[i] > 0.7 && act / est[i] < 1.4);
    }
    assert_true(est[0] / est[2] > 3.0 && est[0] / est[2] < 5.3);

    volux_framebuffer_reset(fb);
    volux_render_limits lim = {100000, 0, 0.02};
    volux_render_report rep;
    assert_int_equal(volux_render(t, s, fb, &lim, &rep), VOLUX_OK);
    double act = true_rel_error(ctx, fb, 1.0);
    printf("  target 0.02: stopped at %u spp, estimate %.4f, true %.4f\n", rep.spp, rep.rel_error, act);
    assert_true(rep.rel_error <= 0.02 && rep.spp < 100000);
    assert_true(act < 0.03);
    volux_framebuffer_destroy(fb);
    volux_technique_destroy(t);
    volux_scene_destroy(s);
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_rel_error_tracks_the_true_error),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
