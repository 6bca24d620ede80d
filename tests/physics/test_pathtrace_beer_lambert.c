/*
 * Beer–Lambert: a purely absorbing medium (albedo 0) in front of a constant
 * environment L. A camera ray crossing it sees L·exp(−∫σt dz); with
 * albedo 0 nothing scatters, so max_depth is irrelevant (the images for
 * max_depth 1 and 64 must be bit-identical).
 *
 * Geometry: an orthographic camera looking down −Z at a box (7 or 32 units
 * deep, spacing 1), every pixel's footprint inside the box's face, so every
 * ray crosses the full depth of medium.
 *
 * Tolerances: each pixel within 5 standard errors (binomial: the tracker's
 * estimate is L or 0), the image mean within 3 standard errors and 3 %.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "pt_util.h"

static const volux_vec3 L_ENV = {2.0f, 1.0f, 0.25f};

static float ramp_z(int i, int j, int k, void *u) {
    (void)i, (void)j, (void)u;
    return (float)k;
}

static void check(volux_context *ctx, volux_volume *v, const volux_tf_scalar_point *ext, int n_ext, double T_expect,
                  const char *classification, const char *majorant, int spp, const char *what) {
    volux_image img[2];
    for (int run = 0; run < 2; run++) {
        volux_scene *s = pt_scene(ctx, v, ext, n_ext, NULL, 0, 0.0f, 0.3f, 5.0f, 8, 8, run ? 64 : 1);
        pt_add_constant_env(s, L_ENV, 1);
        assert_int_equal(volux_scene_set_param(s, "pathtrace", "classification", 0, classification), 0);
        assert_int_equal(volux_scene_set_param(s, "pathtrace", "majorant", 0, majorant), 0);
        volux_technique *t = NULL;
        assert_int_equal(volux_technique_create(ctx, "pathtrace", s, &t), VOLUX_OK);
        pt_stats st;
        pt_accumulate(t, s, spp, &st);
        int n = st.width * st.height;
        const float Lc[3] = {L_ENV.x, L_ENV.y, L_ENV.z};
        for (int c = 0; c < 3; c++) {
            double expect = Lc[c] * T_expect, sum = 0.0, var_sum = 0.0;
            for (int p = 0; p < n; p++) {
                double m = st.mean[3 * p + c], se = pt_stats_se(&st, p, c);
                sum += m;
                var_sum += se * se;
                /* a pixel with no variance must be exact; use the binomial
                 * standard error of the expected value as a floor */
                double se_floor = Lc[c] * sqrt(T_expect * (1 - T_expect) / spp);
                if (fabs(m - expect) > 5.0 * fmax(se, se_floor))
                    fail_msg("%s: pixel %d channel %d = %.5f, expected %.5f (se %.5f)", what, p, c, m, expect, se);
            }
            double mean = sum / n, se = sqrt(var_sum) / n;
            if (fabs(mean - expect) > 3.0 * se || fabs(mean - expect) > 0.03 * expect)
                fail_msg("%s: image mean channel %d = %.5f, expected %.5f (se %.5f)", what, c, mean, expect, se);
            if (c == 0 && run == 0)
                printf("  %-34s T %.5f  measured %.5f ± %.5f\n", what, T_expect, mean / Lc[c], se / Lc[c]);
        }
        pt_stats_free(&st);
        volux_render_limits lim = {4, 0, 0};
        volux_framebuffer *fb;
        assert_int_equal(volux_framebuffer_create(ctx, 8, 8, &fb), VOLUX_OK);
        assert_int_equal(volux_render(t, s, fb, &lim, NULL), VOLUX_OK);
        assert_int_equal(volux_framebuffer_resolve(fb, &img[run]), VOLUX_OK);
        volux_framebuffer_destroy(fb);
        volux_technique_destroy(t);
        volux_scene_destroy(s);
    }
    /* max_depth cannot matter when nothing scatters */
    assert_memory_equal(img[0].rgb, img[1].rgb, sizeof(float) * 3 * 64);
    volux_image_free(ctx, &img[0]);
    volux_image_free(ctx, &img[1]);
}

static void test_beer_lambert_homogeneous_box(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_volume *v = pt_volume_constant(ctx, 8, 8, 8, 1.0f);
    const float sigmas[3] = {0.02f, 0.2f, 0.6f};
    for (int i = 0; i < 3; i++) {
        volux_tf_scalar_point ext[1] = {{0.0f, sigmas[i]}};
        char what[64];
        snprintf(what, sizeof what, "homogeneous sigma_t=%.2f", sigmas[i]);
        check(ctx, v, ext, 1, exp(-sigmas[i] * 7.0), "post", "grid", 1024, what);
    }
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

/* σt(z) linear in depth over 32 units (4 macrocells along the ray):
 * τ = ∫σt dz = mean σt × 32, with null collisions (each cell's majorant is
 * its maximum) and both classifications (a linear TF over a linear field:
 * pre == post). */
static void test_beer_lambert_linear_ramp(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_volume *v = pt_volume_fn(ctx, 8, 8, 33, ramp_z, NULL);
    const volux_tf_scalar_point ext[2] = {{0.0f, 0.0f}, {32.0f, 0.1f}};
    double T = exp(-0.05 * 32.0);
    check(ctx, v, ext, 2, T, "post", "grid", 1024, "ramp post grid");
    check(ctx, v, ext, 2, T, "pre", "grid", 1024, "ramp pre grid");
    check(ctx, v, ext, 2, T, "post", "global", 1024, "ramp post global");
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_beer_lambert_homogeneous_box),
        cmocka_unit_test(test_beer_lambert_linear_ramp),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
