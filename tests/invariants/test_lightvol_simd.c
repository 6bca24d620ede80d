/*
 * tests/invariants/test_lightvol_simd.c — the AVX2 propagation kernels
 * (techniques.lightvol.kernel = "avx2"; "simd" adds 16-wide AVX-512 steps
 * where the CPU has them) give the portable kernel's
 * illumination volume up to float rounding, for every light type, with and
 * without forward scattering and its cone, on the data grid
 * (post-classified) and coarser (box-averaged medium), including rows whose
 * length is not a multiple of the vector width; the vector exp matches
 * volux_exp_neg_cw7; selective updates with the SIMD kernel equal its entire
 * rebuild. Skipped where the CPU has no AVX2+FMA.
 */
#include <stdio.h>

#include "lightvol_fixture.h"
#include "techniques/lightvol/sweep.h"

enum { NX = 37, NY = 29, NZ = 23 };

static float *medium(void) {
    float *d = malloc((size_t)NX * NY * NZ * sizeof(float));
    assert_non_null(d);
    uint64_t r = 11;
    for (int k = 0; k < NZ; k++)
        for (int j = 0; j < NY; j++)
            for (int i = 0; i < NX; i++) {
                r = r * 6364136223846793005ull + 1442695040888963407ull;
                float x = (float)((r >> 40) & 0xffff) / 65535.0f;
                float dx = (float)i - 18.0f, dy = (float)j - 14.0f, dz = (float)k - 11.0f;
                float blob = dx * dx + 2.0f * dy * dy + dz * dz < 60.0f ? 0.9f : 0.0f;
                float wall = i == 25 ? 2.0f : 0.0f; /* a thin wall: sharp shadows */
                d[((size_t)k * NY + (size_t)j) * NX + (size_t)i] = 0.1f * x + blob + wall;
            }
    return d;
}

static int simd_or_skip(void) {
    if (volux_lightvol_simd_available()) return 1;
    fprintf(stderr, "  (no AVX2+FMA on this CPU: skipped)\n");
    return 0;
}

static volux_scene *scene(volux_context *ctx, const float *data, int which) {
    static const float colour[3] = {0.9f, 0.6f, 0.4f};
    volux_scene *s = lvf_scene(ctx, NX, NY, NZ, data, 0.8f, colour);
    volux_light_desc l[6];
    int n = 0;
    if (which == 0 || which == 2) {
        l[n++] = lvf_directional(-0.35f, -1.0f, -0.1f, 2.0f);     /* −y, second −x */
        l[n++] = lvf_directional(0.7f, -0.2f, 0.45f, 1.0f);       /* +x, second +z: long oblique steps */
        l[n] = lvf_directional(-0.35f, -1.0f, -0.1f, 0.5f);       /* same direction as the first: shared T */
        l[n++].color = (volux_vec3){0.3f, 0.5f, 1.0f};
    }
    if (which == 1 || which == 2) {
        l[n] = lvf_point(60.0f, 45.0f, 20.0f, 9000.0f);
        l[n++].color = (volux_vec3){1.0f, 0.7f, 0.3f};
        /* beside the box within the y and z slabs: with the centre grouping
         * (+x, −z) the −z group reaches only z < 8 (lv_center_weight per row
         * in +x sweeps, per column in −z sweeps) */
        l[n++] = lvf_point(-40.0f, 3.0f, 8.0f, 7000.0f);
        if (which == 1) {
            l[n++] = lvf_spot(-30.0f, 20.0f, -25.0f, 1.0f, -0.3f, 0.8f, 12000.0f, 30.0f, 20.0f);
            l[n++] = lvf_point(3.0f, -4.0f, 2.0f, 500.0f); /* inside the box: six groups */
        }
    }
    for (int i = 0; i < n; i++) assert_int_equal(volux_scene_set_light(s, i, &l[i]), VOLUX_OK);
    return s;
}

static float *volume_with(volux_context *ctx, volux_scene *s, const char *kernel) {
    assert_int_equal(volux_scene_set_param(s, "lightvol", "kernel", 0, kernel), VOLUX_OK);
    volux_technique *t = lvf_create(ctx, s);
    float *v = lvf_copy(t);
    volux_technique_destroy(t);
    return v;
}

/* Rounding (FMA, summation order) compounds along the sweep but stays far
 * below the technique's stated tolerances (selective 2e-6 of the maximum is
 * for one kernel against itself). */
#define SIMD_TOL 2e-5
#define SIMD_REL 1e-5

static void test_simd_matches_scalar(void **state) {
    (void)state;
    if (!simd_or_skip()) skip();
    volux_context *ctx = tu_context(1);
    float *data = medium();
    static const struct {
        float f, cone, scale;
    } cfg[] = {{0.0f, 0.0f, 1.0f}, {0.5f, 0.0f, 1.0f}, {0.5f, 12.0f, 1.0f},
               {0.0f, 0.0f, 0.5f}, {0.7f, 12.0f, 0.5f}, {1.0f, 30.0f, 1.0f}};
    /* the positional setups also with the centre grouping (§4) */
    for (int which = 0; which < 5; which++)
        for (size_t c = 0; c < sizeof cfg / sizeof cfg[0]; c++)
            for (int dir = 0; dir < 2; dir++) {
                volux_scene *s = scene(ctx, data, which < 3 ? which : which - 2);
                assert_int_equal(
                    volux_scene_set_param(s, "lightvol", "positional_grouping", 0, which >= 3 ? "center" : "voxel"),
                    VOLUX_OK);
                assert_int_equal(volux_scene_set_param(s, "lightvol", "forward_scattering", cfg[c].f, NULL), VOLUX_OK);
                assert_int_equal(volux_scene_set_param(s, "lightvol", "scatter_cone", cfg[c].cone, NULL), VOLUX_OK);
                assert_int_equal(volux_scene_set_param(s, "lightvol", "scale", cfg[c].scale, NULL), VOLUX_OK);
                assert_int_equal(volux_scene_set_param(s, "lightvol", "directional", dir, NULL), VOLUX_OK);
                float *a = volume_with(ctx, s, "scalar");
                volux_technique *t = lvf_create(ctx, s);
                size_t n = lvf_count(lvf_state(t));
                volux_technique_destroy(t);
                /* "simd" takes AVX-512 steps where the CPU has them, "avx2" never */
                for (int k = 0; k < 2; k++) {
                float *b = volume_with(ctx, s, k ? "avx2" : "simd");
                double bmax, d = lvf_max_diff(b, a, n, &bmax);
                /* and per voxel, relative, in the rgb channels where the light is not
                 * negligible */
                double rel = 0.0;
                const int ch = dir ? 6 : 3;
                for (size_t i = 0; i < n; i++) {
                    double x = fabs((double)a[i]);
                    if ((int)(i % (size_t)ch) >= 3) continue; /* direction sums cancel: max |diff| above */
                    if (x > 1e-4 * bmax) {
                        double r = fabs((double)b[i] - (double)a[i]) / x;
                        if (r > rel) rel = r;
                    }
                }
                if (rel > SIMD_REL)
                    fail_msg("lights %d, f %g, cone %g, scale %g, directional %d, %s: max relative |simd − scalar| %g",
                             which, cfg[c].f, cfg[c].cone, cfg[c].scale, dir, k ? "avx2" : "simd", rel);
                if (!(bmax > 0.0) || d > SIMD_TOL * bmax)
                    fail_msg("lights %d, f %g, cone %g, scale %g, directional %d, %s: max |simd − scalar| %g vs max %g",
                             which, cfg[c].f, cfg[c].cone, cfg[c].scale, dir, k ? "avx2" : "simd", d, bmax);
                free(b);
                }
                free(a);
                volux_scene_destroy(s);
            }
    free(data);
    volux_context_destroy(ctx);
}

/* Selective updates with the SIMD kernels equal their entire rebuild. */
static void test_simd_selective_equals_full(void **state) {
    (void)state;
    if (!simd_or_skip()) skip();
    volux_context *ctx = tu_context(2);
    float *data = medium();
    volux_scene *s = scene(ctx, data, 2);
    assert_int_equal(volux_scene_set_param(s, "lightvol", "forward_scattering", 0.5, NULL), VOLUX_OK);
    assert_int_equal(volux_scene_set_param(s, "lightvol", "scatter_cone", 10.0, NULL), VOLUX_OK);
    assert_int_equal(volux_scene_set_param(s, "lightvol", "kernel", 0, "simd"), VOLUX_OK);
    assert_int_equal(volux_scene_set_param(s, "lightvol", "cost_rule", 0, "selective"), VOLUX_OK);
    volux_technique *t = lvf_create(ctx, s);
    for (int slot = 0; slot < 4; slot++) {
        volux_light_desc d = *volux_scene_light(s, slot);
        d.direction.x += 0.1f;
        d.position.y -= 7.0f;
        assert_int_equal(volux_scene_set_light(s, slot, &d), VOLUX_OK);
        lvf_update(t, s);
        assert_int_equal(lvf_state(t)->stats.last, LV_UPDATE_SELECTIVE);
        float *sel = lvf_copy(t);
        volux_technique *f = lvf_create(ctx, s);
        float *full = lvf_copy(f);
        double bmax, diff = lvf_max_diff(sel, full, lvf_count(lvf_state(t)), &bmax);
        if (diff > 2e-6 * bmax) fail_msg("slot %d: selective vs entire %g (max %g)", slot, diff, bmax);
        free(sel);
        free(full);
        volux_technique_destroy(f);
    }
    volux_technique_destroy(t);
    volux_scene_destroy(s);
    free(data);
    volux_context_destroy(ctx);
}

/* The vector exp: volux_exp_neg_cw7's reduction and polynomial, so within a few
 * ulps of it; exactly 1 at 0, 0 for +inf and NaN and beyond 2^−126. */
static void test_simd_exp(void **state) {
    (void)state;
    if (!simd_or_skip()) skip();
    enum { M = 1003 };
    static float x[M], y[M];
    for (int i = 0; i < M; i++) x[i] = (float)i * 0.093f;
    x[0] = 0.0f;
    x[1] = INFINITY;
    x[2] = NAN;
    x[3] = 87.0f;
    x[4] = 88.0f;
    x[5] = 1e-8f;
    volux_lightvol_exp_avx2(y, x, M);
    assert_true(y[0] == 1.0f);
    assert_true(y[1] == 0.0f);
    assert_true(y[2] == 0.0f);
    for (int i = 3; i < M; i++) {
        float r = volux_exp_neg_cw7(x[i]);
        if (fabsf(y[i] - r) > 4e-7f * r + 1e-38f) fail_msg("exp(−%g): simd %g, scalar %g", x[i], y[i], r);
        assert_true(y[i] <= 1.0f && y[i] >= 0.0f);
    }
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_simd_matches_scalar),
        cmocka_unit_test(test_simd_selective_equals_full),
        cmocka_unit_test(test_simd_exp),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
