/*
 * Majorant correctness: delta and ratio tracking are unbiased only if the
 * majorant bounds σt everywhere it is used. For random volumes (uint8 and
 * float, sizes not multiples of 8) and random transfer functions with sharp
 * peaks, for both classifications:
 *   - every macrocell's σ̄ bounds σt at random points inside the cell;
 *   - along random rays, every DDA interval's σ̄ bounds σt at random points
 *     of the interval (this also checks the cell the walk assigns);
 *   - the global maximum bounds every cell.
 * Tolerance: relative 1e-5 (float rounding of the LUT interpolation).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/rng.h"
#include "core/vecmath.h"
#include "pt_util.h"
#include "sample/march.h"
#include "sample/medium.h"

static volux_volume *random_volume(volux_context *ctx, volux_scalar_type type, const int dims[3], uint64_t seed) {
    size_t n = (size_t)dims[0] * dims[1] * dims[2];
    void *data = malloc(n * 4);
    assert_non_null(data);
    volux_rng rng = volux_rng_make(seed, 0, 0, 0);
    for (size_t i = 0; i < n; i++) {
        /* smooth blobs plus noise: a realistic spread of cell ranges */
        size_t x = i % dims[0], y = (i / dims[0]) % dims[1], z = i / ((size_t)dims[0] * dims[1]);
        float smooth = 0.5f + 0.5f * sinf(0.3f * x) * cosf(0.2f * y + 0.1f * z);
        float v = 0.7f * smooth + 0.3f * volux_rng_float(&rng);
        if (type == VOLUX_UINT8) ((uint8_t *)data)[i] = (uint8_t)(v * 255.0f);
        else ((float *)data)[i] = v * 1000.0f - 200.0f;
    }
    volux_volume_desc d;
    memset(&d, 0, sizeof d);
    memcpy(d.dims, dims, sizeof d.dims);
    d.spacing[0] = 1.0, d.spacing[1] = 0.7, d.spacing[2] = 1.3;
    d.type = type;
    d.data = data;
    volux_volume *v = NULL;
    assert_int_equal(volux_volume_create(ctx, &d, &v), VOLUX_OK);
    free(data);
    return v;
}

static void check_volume(volux_context *ctx, volux_volume *v, uint64_t seed) {
    double lo, hi;
    volux_volume_range(v, &lo, &hi);
    volux_rng rng = volux_rng_make(seed, 1, 0, 0);
    for (int trial = 0; trial < 10; trial++) {
        /* random TF: a few points, some narrow peaks */
        volux_tf_scalar_point pts[8];
        int n = 2 + (int)(volux_rng_float(&rng) * 6);
        for (int i = 0; i < n; i++) {
            pts[i].s = (float)(lo + (hi - lo) * volux_rng_float(&rng));
            pts[i].v = volux_rng_float(&rng) < 0.4f ? 0.0f : 5.0f * volux_rng_float(&rng);
        }
        for (int i = 1; i < n; i++) /* sort by s */
            for (int j = i; j > 0 && pts[j].s < pts[j - 1].s; j--) {
                volux_tf_scalar_point t = pts[j];
                pts[j] = pts[j - 1];
                pts[j - 1] = t;
            }
        volux_transfer_desc tf;
        volux_transfer_desc_defaults(&tf);
        tf.opacity = pts;
        tf.n_opacity = n;
        tf.extinction = 1;
        tf.density_scale = 0.5f + volux_rng_float(&rng);
        volux_transfer_lut lut;
        assert_int_equal(volux_transfer_bake(ctx, &tf, lo, hi, trial % 2 ? 0 : 256, 1.0f, &lut), VOLUX_OK);
        volux_majorant_grid grid;
        memset(&grid, 0, sizeof grid);
        assert_int_equal(volux_majorant_grid_build(ctx, v, &lut, &grid), VOLUX_OK);

        for (int pre = 0; pre < 2; pre++) {
            /* every cell at random points */
            for (int cz = 0; cz < grid.cells[2]; cz++)
                for (int cy = 0; cy < grid.cells[1]; cy++)
                    for (int cx = 0; cx < grid.cells[0]; cx++) {
                        size_t c = ((size_t)cz * grid.cells[1] + cy) * grid.cells[0] + cx;
                        float m = grid.sigma_max[c];
                        assert_true(m <= grid.global_max);
                        int cc[3] = {cx, cy, cz};
                        for (int s = 0; s < 24; s++) {
                            float q[3];
                            for (int a = 0; a < 3; a++) {
                                float a0 = (float)(8 * cc[a]), a1 = fminf((float)(8 * cc[a] + 8), (float)(v->dims[a] - 1));
                                q[a] = a0 + (a1 - a0) * volux_rng_float(&rng);
                            }
                            float sigma = volux_medium_eval(v, &lut, pre, v3(q[0], q[1], q[2]), NULL);
                            if (sigma > m * (1.0f + 1e-5f) + 1e-7f)
                                fail_msg("cell (%d,%d,%d) %s: sigma %.7g > majorant %.7g at (%g,%g,%g)", cx, cy, cz,
                                         pre ? "pre" : "post", sigma, m, q[0], q[1], q[2]);
                        }
                    }
            /* random rays through the box, every DDA interval */
            volux_vec3 blo, bhi;
            volux_volume_bounds(v, &blo, &bhi);
            volux_vec3 centre = v3_scale(v3_add(blo, bhi), 0.5f);
            for (int r = 0; r < 1500; r++) {
                volux_vec3 dir = v3_normalize(v3(volux_rng_float(&rng) - 0.5f, volux_rng_float(&rng) - 0.5f,
                                                 volux_rng_float(&rng) - 0.5f));
                /* aim at a random point of the box from outside; every 10th ray axis-aligned */
                if (r % 10 == 0) dir = (r / 10) % 3 == 0 ? v3(1, 0, 0) : (r / 10) % 3 == 1 ? v3(0, -1, 0) : v3(0, 0, 1);
                volux_vec3 target = v3(blo.x + (bhi.x - blo.x) * volux_rng_float(&rng),
                                       blo.y + (bhi.y - blo.y) * volux_rng_float(&rng),
                                       blo.z + (bhi.z - blo.z) * volux_rng_float(&rng));
                if (r % 7 == 0) target = centre;
                volux_vec3 o = v3_madd(target, dir, -100.0f);
                volux_ray ray;
                if (!volux_ray_clip(v, o, dir, &ray)) continue;
                volux_march_iter it;
                volux_interval iv;
                volux_march_init(&it, &grid, &ray, ray.t0, ray.t1);
                float covered = ray.t0;
                while (volux_march_next(&it, &iv)) {
                    assert_true(iv.t0 == covered); /* consecutive intervals */
                    covered = iv.t1;
                    for (int s = 0; s < 8; s++) {
                        float t = iv.t0 + (iv.t1 - iv.t0) * volux_rng_float(&rng);
                        float sigma = volux_medium_eval(v, &lut, pre, v3_madd(ray.q0, ray.dq, t), NULL);
                        if (sigma > iv.sigma_max * (1.0f + 1e-5f) + 1e-7f)
                            fail_msg("ray %d %s: sigma %.7g > interval majorant %.7g at t %.7g in [%.7g, %.7g]", r,
                                     pre ? "pre" : "post", sigma, iv.sigma_max, t, iv.t0, iv.t1);
                    }
                }
                assert_true(fabsf(covered - ray.t1) <= 1e-4f * fmaxf(1.0f, ray.t1)); /* covers the whole ray */
            }
        }
        volux_majorant_grid_free(ctx, &grid);
        volux_transfer_lut_free(ctx, &lut);
    }
}

static void test_macrocell_majorants_bound_sigma_t(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    const int dims_a[3] = {21, 13, 9}, dims_b[3] = {32, 17, 40};
    volux_volume *a = random_volume(ctx, VOLUX_UINT8, dims_a, 1);
    volux_volume *b = random_volume(ctx, VOLUX_FLOAT32, dims_b, 2);
    check_volume(ctx, a, 11);
    check_volume(ctx, b, 12);
    volux_volume_release(a);
    volux_volume_release(b);
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_macrocell_majorants_bound_sigma_t),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
