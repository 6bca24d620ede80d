/*
 * tests/unit/test_sat3d.c — the exact integer summed-area table of σt and
 * its box filters (techniques/scatter/sat3d.h, occlusion.h).
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/rng.h"
#include "sample/march.h"
#include "techniques/scatter/occlusion.h"
#include "techniques/scatter/sat3d.h"
#include "test_util.h"

typedef struct fixture {
    volux_context *ctx;
    volux_volume *vol;
    volux_transfer_lut lut;
} fixture;

static fixture make(int nx, int ny, int nz, int constant, float value_scale) {
    fixture f;
    f.ctx = tu_context(2);
    size_t n = (size_t)nx * ny * nz;
    uint8_t *data = malloc(n);
    volux_rng r = volux_rng_make(11, 0, 0, 0);
    for (size_t i = 0; i < n; i++) data[i] = constant >= 0 ? (uint8_t)constant : (uint8_t)(volux_rng_u64(&r) >> 56);
    volux_volume_desc d = {{nx, ny, nz}, {1, 1, 1}, {0, 0, 0}, 0, VOLUX_UINT8, data, 0};
    assert_int_equal(volux_volume_create(f.ctx, &d, &f.vol), VOLUX_OK);
    free(data);
    volux_tf_scalar_point ext[3] = {{0, 0}, {100, 0.5f * value_scale}, {255, 2.0f * value_scale}};
    volux_transfer_desc tf;
    volux_transfer_desc_defaults(&tf);
    tf.opacity = ext;
    tf.n_opacity = 3;
    tf.extinction = 1;
    assert_int_equal(volux_transfer_bake(f.ctx, &tf, 0, 255, 256, 1.0f, &f.lut), VOLUX_OK);
    return f;
}

static void destroy(fixture *f) {
    volux_transfer_lut_free(f->ctx, &f->lut);
    volux_volume_release(f->vol);
    volux_context_destroy(f->ctx);
}

static double brute(const fixture *f, int x0, int y0, int z0, int x1, int y1, int z1) {
    double s = 0.0;
    for (int z = z0; z <= z1; z++)
        for (int y = y0; y <= y1; y++)
            for (int x = x0; x <= x1; x++)
                s += volux_lut_sigma(&f->lut, volux_volume_value_at(f->vol, x, y, z));
    return s;
}

static void check_random_boxes(uint64_t max_box, int expect_wide) {
    fixture f = make(23, 17, 19, -1, 1.0f);
    scatter_sat sat = {0};
    assert_int_equal(scatter_sat_build(f.ctx, 2, f.vol, &f.lut, max_box, &sat), VOLUX_OK);
    assert_int_equal(sat.wide, expect_wide);
    volux_rng r = volux_rng_make(5, 1, 2, 3);
    int dims[3] = {23, 17, 19};
    for (int k = 0; k < 300; k++) {
        int lo[3], hi[3];
        for (int a = 0; a < 3; a++) {
            int p = (int)(volux_rng_u64(&r) % (uint64_t)dims[a]), q = (int)(volux_rng_u64(&r) % (uint64_t)dims[a]);
            lo[a] = p < q ? p : q;
            hi[a] = p < q ? q : p;
        }
        double want = brute(&f, lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]);
        double got = scatter_sat_box(&sat, lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]);
        double n = (double)(hi[0] - lo[0] + 1) * (hi[1] - lo[1] + 1) * (hi[2] - lo[2] + 1);
        /* quantisation only: ≤ 0.5/scale per voxel */
        assert_near(got, want, n * 0.5 / sat.scale + 1e-9 * want);
    }
    /* empty range */
    assert_true(scatter_sat_box(&sat, 5, 5, 5, 4, 9, 9) == 0.0);
    scatter_sat_free(f.ctx, &sat);
    destroy(&f);
}

static void test_random_boxes_match_brute_force_u32(void **state) {
    (void)state;
    check_random_boxes(23 * 17 * 19, 0);
}

static void test_random_boxes_match_brute_force_u64(void **state) {
    (void)state;
    check_random_boxes(1u << 20, 1); /* a box this large forces 64-bit sums */
}

/* At 192³ a float SAT cannot resolve a 3³ box far from the origin (prefix
 * sums ~ 10^7, ulp ~ 1); the integer SAT is exact up to quantisation. */
static void test_large_volume_small_box_is_exact(void **state) {
    (void)state;
    fixture f = make(192, 192, 192, 180, 1.0f);
    scatter_sat sat = {0};
    assert_int_equal(scatter_sat_build(f.ctx, 2, f.vol, &f.lut, 27, &sat), VOLUX_OK);
    double sigma = volux_lut_sigma(&f.lut, 180.0f);
    double got = scatter_sat_box(&sat, 189, 189, 189, 191, 191, 191);
    assert_near(got, 27.0 * sigma, 27.0 * 0.5 / sat.scale);
    assert_near(got / (27.0 * sigma), 1.0, 1e-6);
    scatter_sat_free(f.ctx, &sat);
    destroy(&f);
}

/* Box filters: a homogeneous interior gives the medium's σt (and the
 * occlusion the Beer–Lambert transmittance over the radius); the border
 * sees the empty space outside. */
static void test_filter_and_occlusion_in_homogeneous_medium(void **state) {
    (void)state;
    fixture f = make(32, 32, 32, 100, 0.2f); /* σt = 0.1 */
    double sigma = volux_lut_sigma(&f.lut, 100.0f), sp[3] = {1, 1, 1};
    scatter_sat sat = {0};
    assert_int_equal(scatter_sat_build(f.ctx, 2, f.vol, &f.lut, 4096, &sat), VOLUX_OK);
    float *out = calloc(32 * 32 * 32, sizeof(float));
    int half[1][3] = {{3, 3, 3}};
    double w[1] = {1.0 / 343.0};
    assert_int_equal(scatter_sat_filter(f.ctx, 2, &sat, 1, half, w, 0, out), VOLUX_OK);
    assert_near(out[(16 * 32 + 16) * 32 + 16], sigma, 1e-5);
    assert_near(out[0], sigma * 64.0 / 343.0, 1e-5); /* corner: 4³ of 7³ inside */
    scatter_grid g = {0};
    assert_int_equal(scatter_grid_alloc(f.ctx, f.vol, 1.0f, &g, "test"), VOLUX_OK);
    assert_int_equal(scatter_occlusion_build(f.ctx, 2, &sat, 6.0, 3, sp, &g), VOLUX_OK);
    int h[3];
    scatter_equal_volume_cube(6.0, sp, h);
    double r_eff = cbrt(3.0 * (double)scatter_cube_voxels(h) / (4.0 * M_PI));
    assert_near(g.v[(16 * 32 + 16) * 32 + 16], exp(-sigma * r_eff), 1e-4);
    assert_true(g.v[0] > g.v[(16 * 32 + 16) * 32 + 16]); /* less occluded at the border */
    scatter_grid_free(f.ctx, &g);
    free(out);
    scatter_sat_free(f.ctx, &sat);
    destroy(&f);
}

static void test_equal_volume_cube(void **state) {
    (void)state;
    double sp[3] = {1, 1, 1}, sp2[3] = {1, 1, 2};
    int h[3];
    scatter_equal_volume_cube(14.0, sp, h); /* side 22.6 → 23 */
    assert_int_equal(h[0], 11);
    assert_int_equal(h[2], 11);
    scatter_equal_volume_cube(14.0, sp2, h); /* z: side 11.3 → 11 */
    assert_int_equal(h[0], 11);
    assert_int_equal(h[2], 5);
    scatter_equal_volume_cube(0.2, sp, h);
    assert_int_equal(h[0], 0);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_random_boxes_match_brute_force_u32),
        cmocka_unit_test(test_random_boxes_match_brute_force_u64),
        cmocka_unit_test(test_large_volume_small_box_is_exact),
        cmocka_unit_test(test_filter_and_occlusion_in_homogeneous_medium),
        cmocka_unit_test(test_equal_volume_cube),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
