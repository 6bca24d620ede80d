/* Majorant grid and DDA: intervals tile the ray, majorants bound σt; the
 * ray caster segments (sample/segment.h) with and without skipping. */
#include <math.h>

#include "core/vecmath.h"
#include "sample/march.h"
#include "sample/segment.h"
#include "test_util.h"

static void test_intervals_cover_the_ray_and_bound_sigma(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    int dims[3] = {40, 33, 27};
    volux_volume *v;
    assert_int_equal(volux_volume_procedural(ctx, "cloud", dims, 9, &v), VOLUX_OK);
    volux_transfer_desc d;
    volux_transfer_desc_defaults(&d);
    volux_tf_scalar_point op[4] = {{0, 0}, {60, 0}, {120, 0.8f}, {255, 0.1f}};
    d.opacity = op, d.n_opacity = 4;
    volux_transfer_lut lut;
    assert_int_equal(volux_transfer_bake(ctx, &d, 0, 255, 0, 1, &lut), VOLUX_OK);
    volux_majorant_grid grid = {0};
    assert_int_equal(volux_majorant_grid_build(ctx, v, &lut, &grid), VOLUX_OK);
    uint64_t x = 99;
    int empty = 0;
    for (int r = 0; r < 300; r++) {
        float u[6];
        for (int i = 0; i < 6; i++) {
            x = x * 6364136223846793005ull + 1442695040888963407ull;
            u[i] = (float)((x >> 11) * (1.0 / 9007199254740992.0));
        }
        volux_vec3 o = v3(60 * (u[0] - 0.5f), 60 * (u[1] - 0.5f), 60 * (u[2] - 0.5f));
        volux_vec3 dir = v3_normalize(v3(u[3] - 0.5f, u[4] - 0.5f, u[5] - 0.5f));
        volux_ray ray;
        if (!volux_ray_clip(v, o, dir, &ray)) continue;
        volux_march_iter it;
        volux_march_init(&it, &grid, &ray, ray.t0, ray.t1);
        volux_interval iv;
        float t = ray.t0;
        while (volux_march_next(&it, &iv)) {
            assert_near(iv.t0, t, 1e-4); /* contiguous */
            assert_true(iv.t1 >= iv.t0);
            for (int k = 1; k < 8; k++) { /* σt inside the interval ≤ its majorant */
                float tt = iv.t0 + (iv.t1 - iv.t0) * (float)k / 8.0f;
                volux_vec3 q = v3_madd(ray.q0, ray.dq, tt);
                float s = volux_volume_sample_index(v, q.x, q.y, q.z);
                assert_true(volux_lut_sigma(&lut, s) <= iv.sigma_max * 1.0001f + 1e-6f);
            }
            empty += iv.sigma_max == 0.0f;
            t = iv.t1;
        }
        assert_near(t, ray.t1, 1e-3); /* and complete */
    }
    assert_true(empty > 0); /* the TF leaves some cells empty: skipping has work to do */
    volux_majorant_grid_free(ctx, &grid);
    volux_transfer_lut_free(ctx, &lut);
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

/* Segments without a grid tile [t0, t1] at t0 + (k + jitter)·h; with a
 * grid they are a subset at the same positions, every segment left out has
 * zero extinction along it, and *gap marks exactly the segments whose front
 * was not the previous segment's end. */
static void test_segments_skip_only_empty_ones(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    int dims[3] = {40, 33, 27};
    volux_volume *v;
    assert_int_equal(volux_volume_procedural(ctx, "cloud", dims, 9, &v), VOLUX_OK);
    volux_transfer_desc d;
    volux_transfer_desc_defaults(&d);
    volux_tf_scalar_point op[4] = {{0, 0}, {90, 0}, {140, 0.8f}, {255, 0.1f}};
    d.opacity = op, d.n_opacity = 4;
    volux_transfer_lut lut;
    assert_int_equal(volux_transfer_bake(ctx, &d, 0, 255, 0, 1, &lut), VOLUX_OK);
    volux_majorant_grid grid = {0};
    assert_int_equal(volux_majorant_grid_build(ctx, v, &lut, &grid), VOLUX_OK);
    enum { MAXSEG = 512 };
    float a0[MAXSEG], b0[MAXSEG];
    uint64_t x = 7;
    int skipped = 0, gaps = 0;
    for (int r = 0; r < 200; r++) {
        float u[7];
        for (int i = 0; i < 7; i++) {
            x = x * 6364136223846793005ull + 1442695040888963407ull;
            u[i] = (float)((x >> 11) * (1.0 / 9007199254740992.0));
        }
        volux_vec3 o = v3(60 * (u[0] - 0.5f), 60 * (u[1] - 0.5f), 60 * (u[2] - 0.5f));
        volux_vec3 dir = v3_normalize(v3(u[3] - 0.5f, u[4] - 0.5f, u[5] - 0.5f));
        volux_ray ray;
        if (!volux_ray_clip(v, o, dir, &ray)) continue;
        const float h = 0.7f, jitter = u[6];
        volux_segments seg;
        volux_march_iter it;
        float a, b;
        int gap, n = 0;
        volux_segments_init(&seg, &it, NULL, &ray, h, jitter);
        float t = ray.t0;
        while (volux_segments_next(&seg, &a, &b, &gap)) {
            assert_true(n < MAXSEG);
            assert_float_equal(a, t, 0.0f); /* contiguous from t0 */
            assert_int_equal(gap, n == 0);
            assert_true(b > a && b <= ray.t1);
            a0[n] = a, b0[n] = b, n++;
            t = b;
        }
        assert_float_equal(t, ray.t1, 1e-4f); /* complete */
        /* with skipping: an ordered subset; what is left out is empty */
        volux_segments_init(&seg, &it, &grid, &ray, h, jitter);
        int i = 0;
        float prev_b = -1.0f;
        while (volux_segments_next(&seg, &a, &b, &gap)) {
            for (; i < n && a0[i] != a; i++) { /* left out: σt = 0 along it */
                for (int q = 0; q <= 8; q++) {
                    volux_vec3 p = v3_madd(ray.q0, ray.dq, a0[i] + (b0[i] - a0[i]) * (float)q / 8.0f);
                    assert_true(volux_lut_sigma(&lut, volux_volume_sample_index(v, p.x, p.y, p.z)) == 0.0f);
                }
                skipped++;
            }
            assert_true(i < n);
            assert_float_equal(b, b0[i], 0.0f);
            assert_int_equal(gap, a != prev_b);
            gaps += gap && prev_b >= 0.0f;
            prev_b = b;
            i++;
        }
    }
    assert_true(skipped > 0 && gaps > 0); /* the test exercised skipping */
    volux_majorant_grid_free(ctx, &grid);
    volux_transfer_lut_free(ctx, &lut);
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_intervals_cover_the_ray_and_bound_sigma),
        cmocka_unit_test(test_segments_skip_only_empty_ones),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
