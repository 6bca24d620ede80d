/* Majorant grid and DDA: intervals tile the ray, majorants bound σt. */
#include <math.h>

#include "core/vecmath.h"
#include "sample/march.h"
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

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_intervals_cover_the_ray_and_bound_sigma),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
