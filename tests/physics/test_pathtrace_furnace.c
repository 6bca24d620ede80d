/*
 * White furnace (pbrt integrators_test "should have radiance of 1"): a
 * non-emitting medium of albedo 1 (white colour) inside a uniform
 * environment of radiance L scatters exactly as much light into every
 * direction as it removes, so every pixel's expected value is L — for any
 * density, any phase function and any heterogeneity. A bias in free-flight
 * sampling, transmittance, NEE, MIS weights or the HG sampler shows up as a
 * departure from L.
 *
 * Tolerances: each pixel within 5 standard errors of its own mean (from the
 * measured per-pixel variance; 5σ keeps the family-wise false-alarm rate
 * below 1e-3 over all pixels × configurations), the image mean within 3
 * standard errors and within 1.5 % of L.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "pt_util.h"

static const volux_vec3 L_ENV = {0.5f, 1.0f, 2.0f};

static float noise_fn(int i, int j, int k, void *u) {
    (void)u;
    /* deterministic hash noise in [0,1] with empty corners */
    uint32_t h = (uint32_t)(i * 73856093) ^ (uint32_t)(j * 19349663) ^ (uint32_t)(k * 83492791);
    h ^= h >> 13;
    h *= 0x5bd1e995u;
    h ^= h >> 15;
    float v = (float)(h & 0xffff) / 65535.0f;
    return (i + j + k) % 5 == 0 ? 0.0f : v;
}

static void check_furnace(volux_context *ctx, volux_volume *v, const volux_tf_scalar_point *ext, int n_ext, float g,
                          int spp, const char *classification, const char *majorant, const char *what) {
    volux_scene *s = pt_scene(ctx, v, ext, n_ext, NULL, 0, 1.0f, g, 12.0f, 8, 8, 100000);
    pt_add_constant_env(s, L_ENV, 1);
    if (classification) assert_int_equal(volux_scene_set_param(s, "pathtrace", "classification", 0, classification), 0);
    if (majorant) assert_int_equal(volux_scene_set_param(s, "pathtrace", "majorant", 0, majorant), 0);
    /* a perspective view too: rays at many angles */
    volux_technique *t = NULL;
    assert_int_equal(volux_technique_create(ctx, "pathtrace", s, &t), VOLUX_OK);
    pt_stats st;
    pt_accumulate(t, s, spp, &st);
    int n = st.width * st.height;
    const float Lc[3] = {L_ENV.x, L_ENV.y, L_ENV.z};
    for (int c = 0; c < 3; c++) {
        double sum = 0.0, var_sum = 0.0;
        for (int p = 0; p < n; p++) {
            double m = st.mean[3 * p + c], se = pt_stats_se(&st, p, c);
            sum += m;
            var_sum += se * se;
            if (fabs(m - Lc[c]) > 5.0 * se + 1e-5 * Lc[c])
                fail_msg("%s g=%.1f: pixel %d channel %d = %.5f, expected %.5f (se %.5f)", what, g, p, c, m, Lc[c], se);
        }
        double mean = sum / n, se = sqrt(var_sum) / n;
        if (fabs(mean - Lc[c]) > 3.0 * se + 1e-6 || fabs(mean - Lc[c]) > 0.015 * Lc[c])
            fail_msg("%s g=%.1f: image mean channel %d = %.5f, expected %.5f (se %.5f)", what, g, c, mean, Lc[c], se);
        if (c == 1) printf("  %-28s g=%+.1f  mean %.5f  (L %.3f, se %.5f, %d spp)\n", what, g, mean, Lc[c], se, spp);
    }
    pt_stats_free(&st);
    volux_technique_destroy(t);
    volux_scene_destroy(s);
}

static void test_furnace_homogeneous_densities_and_anisotropies(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_volume *v = pt_volume_constant(ctx, 8, 8, 8, 1.0f); /* a 7³ box */
    const float sigmas[3] = {0.05f, 1.0f, 5.0f};                /* optical depth 0.35 … 35 across */
    const float gs[3] = {-0.7f, 0.0f, 0.7f};
    const int spps[3] = {256, 256, 96};
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            volux_tf_scalar_point ext[1] = {{0.0f, sigmas[i]}};
            char what[64];
            snprintf(what, sizeof what, "homogeneous sigma=%.2f", sigmas[i]);
            check_furnace(ctx, v, ext, 1, gs[j], spps[i], NULL, NULL, what);
        }
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

/* Heterogeneous medium with empty cells and a non-linear TF: null collisions
 * against local majorants, both classifications, grid and global majorant. */
static void test_furnace_heterogeneous(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_volume *v = pt_volume_fn(ctx, 17, 17, 17, noise_fn, NULL);
    const volux_tf_scalar_point ext[4] = {{0.0f, 0.0f}, {0.3f, 0.0f}, {0.6f, 3.0f}, {1.0f, 0.5f}};
    check_furnace(ctx, v, ext, 4, 0.3f, 256, "post", "grid", "noise post grid");
    check_furnace(ctx, v, ext, 4, -0.5f, 256, "pre", "grid", "noise pre grid");
    check_furnace(ctx, v, ext, 4, 0.8f, 256, "post", "global", "noise post global");
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_furnace_homogeneous_densities_and_anisotropies),
        cmocka_unit_test(test_furnace_heterogeneous),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
