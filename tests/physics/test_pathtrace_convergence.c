/*
 * Convergence and the frame loop's error estimate, on a heterogeneous
 * white furnace whose exact image is known (L everywhere):
 *   - the measured relative RMS error of the image against L matches the
 *     frame loop's rel_error estimate (within a factor 0.7…1.4), at 16, 64
 *     and 256 spp accumulated in one framebuffer;
 *   - rel_error falls like 1/√spp (16 → 256 spp: a factor 4, accepted in
 *     [3, 5.3]);
 *   - a render bounded by target_error stops once the estimate is below it,
 *     and the true error is then of that size too;
 *   - on an env-lit object that fills an eighth of the frame (the rest is
 *     background seen straight, with no variance), a target_error stop
 *     lands within 2x of the error measured against a 16x-spp render: the
 *     estimate leaves out the pixels with nothing to converge (issue 18;
 *     averaged over the whole frame it read ~5x too low);
 *   - below 4 spp the estimate is "not available" (-1), and a frame with
 *     no varying pixel reports 0.
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

/* A ball of noisy density: empty space around it inside the box. */
static float ball_fn(int i, int j, int k, void *u) {
    double x = i - 8.0, y = j - 8.0, z = k - 8.0;
    return x * x + y * y + z * z < 7.5 * 7.5 ? 0.3f + 0.7f * noise_fn(i, j, k, u) : 0.0f;
}

/* Luminance of pixel p. */
static double lum_at(const volux_image *img, int p) {
    const float *c = &img->rgb[3 * p];
    return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
}

static void test_target_error_is_honest_on_an_env_lit_object(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    volux_volume *v = pt_volume_fn(ctx, 17, 17, 17, ball_fn, NULL);
    const volux_tf_scalar_point ext[2] = {{0.0f, 0.0f}, {1.0f, 0.6f}};
    /* View height 48 around a 16-wide box: the object covers ~8 % of the
     * frame; albedo 0.6 so it is darker than the background. */
    volux_scene *s = pt_scene(ctx, v, ext, 2, NULL, 0, 0.6f, 0.0f, 48.0f, 32, 32, 100000);
    pt_add_constant_env(s, (volux_vec3){1, 1, 1}, 1);
    volux_technique *t;
    assert_int_equal(volux_technique_create(ctx, "pathtrace", s, &t), VOLUX_OK);
    volux_framebuffer *fb;
    assert_int_equal(volux_framebuffer_create(ctx, 32, 32, &fb), VOLUX_OK);

    volux_render_limits few = {3, 0, 0};
    volux_render_report rep;
    assert_int_equal(volux_render(t, s, fb, &few, &rep), VOLUX_OK);
    assert_true(rep.rel_error == -1.0); /* n/a below 4 spp */

    const double target = 0.05;
    volux_framebuffer_reset(fb);
    volux_render_limits lim = {100000, 0, target};
    assert_int_equal(volux_render(t, s, fb, &lim, &rep), VOLUX_OK);
    uint32_t stop_spp = rep.spp;
    volux_image img;
    assert_int_equal(volux_framebuffer_resolve(fb, &img), VOLUX_OK);

    /* Reference: 16x the samples (its own error is then a quarter). */
    volux_framebuffer *ref_fb;
    assert_int_equal(volux_framebuffer_create(ctx, 32, 32, &ref_fb), VOLUX_OK);
    volux_render_limits ref_lim = {16 * stop_spp, 0, 0};
    assert_int_equal(volux_render(t, s, ref_fb, &ref_lim, NULL), VOLUX_OK);
    volux_image ref;
    assert_int_equal(volux_framebuffer_resolve(ref_fb, &ref), VOLUX_OK);

    /* The measured error on the object's pixels (those whose reference is
     * not the background's exact value), as the estimate defines it; and
     * over the whole frame, as it used to be averaged. */
    double se = 0.0, ref_sum = 0.0, se_all = 0.0, ref_all = 0.0;
    int n = 0, n_all = 32 * 32;
    for (int p = 0; p < n_all; p++) {
        double a = lum_at(&img, p), b = lum_at(&ref, p);
        se_all += (a - b) * (a - b);
        ref_all += b;
        if (fabs(b - 1.0) < 1e-6) continue;
        se += (a - b) * (a - b);
        ref_sum += b;
        n++;
    }
    double measured = sqrt(se / n) / (ref_sum / n), whole = sqrt(se_all / n_all) / (ref_all / n_all);
    printf("  target %.3f: stopped at %u spp, estimate %.4f; measured against %u spp: %.4f on the %d object "
           "pixels (%.4f averaged over the frame)\n",
           target, stop_spp, rep.rel_error, 16 * stop_spp, measured, n, whole);
    assert_true(n > 40 && n < n_all / 4);
    assert_true(rep.rel_error <= target);
    assert_true(measured <= 2.0 * target && measured >= 0.5 * target);
    /* Averaged over the frame the same image would look converged well
     * before it is: the old estimate's failure. */
    assert_true(whole < 0.5 * measured);

    volux_image_free(ctx, &img);
    volux_image_free(ctx, &ref);
    volux_framebuffer_destroy(ref_fb);
    volux_framebuffer_destroy(fb);
    volux_technique_destroy(t);
    volux_scene_destroy(s);
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

static float zero_fn(int i, int j, int k, void *u) {
    (void)i, (void)j, (void)k, (void)u;
    return 0.0f;
}

static void test_nothing_to_converge_reports_zero(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_volume *v = pt_volume_fn(ctx, 5, 5, 5, zero_fn, NULL);
    const volux_tf_scalar_point ext[2] = {{0.0f, 0.0f}, {1.0f, 1.0f}};
    volux_scene *s = pt_scene(ctx, v, ext, 2, NULL, 0, 0.5f, 0.0f, 8.0f, 8, 8, 16);
    pt_add_constant_env(s, (volux_vec3){0.5f, 0.7f, 1.0f}, 1);
    volux_technique *t;
    assert_int_equal(volux_technique_create(ctx, "pathtrace", s, &t), VOLUX_OK);
    volux_framebuffer *fb;
    assert_int_equal(volux_framebuffer_create(ctx, 8, 8, &fb), VOLUX_OK);
    volux_render_limits lim = {8, 0, 0};
    volux_render_report rep;
    assert_int_equal(volux_render(t, s, fb, &lim, &rep), VOLUX_OK);
    assert_true(rep.rel_error == 0.0);
    volux_framebuffer_destroy(fb);
    volux_technique_destroy(t);
    volux_scene_destroy(s);
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_rel_error_tracks_the_true_error),
        cmocka_unit_test(test_target_error_is_honest_on_an_env_lit_object),
        cmocka_unit_test(test_nothing_to_converge_reports_zero),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
