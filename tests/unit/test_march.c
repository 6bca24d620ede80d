/* Majorant grid and DDA: intervals tile the ray, majorants bound σt; the
 * ray caster segments (sample/segment.h) with and without skipping. */
#include <math.h>
#include <string.h>

#include "core/camera_rays.h"
#include "core/vecmath.h"
#include "sample/march.h"
#include "sample/primary.h"
#include "sample/segment.h"
#include "test_util.h"

/* A 40×33×27 procedural cloud, a TF that is zero below `empty_below`
 * (so some macrocells are empty) and peaks at `peak`, and its majorant grid. */
typedef struct cloud {
    volux_context *ctx;
    volux_volume *v;
    volux_transfer_lut lut;
    volux_majorant_grid grid;
} cloud;

static void cloud_setup(cloud *f, float empty_below, float peak) {
    f->ctx = tu_context(1);
    int dims[3] = {40, 33, 27};
    assert_int_equal(volux_volume_procedural(f->ctx, "cloud", dims, 9, &f->v), VOLUX_OK);
    volux_transfer_desc d;
    volux_transfer_desc_defaults(&d);
    volux_tf_scalar_point op[4] = {{0, 0}, {empty_below, 0}, {peak, 0.8f}, {255, 0.1f}};
    d.opacity = op, d.n_opacity = 4;
    assert_int_equal(volux_transfer_bake(f->ctx, &d, 0, 255, 0, 1, &f->lut), VOLUX_OK);
    memset(&f->grid, 0, sizeof f->grid);
    assert_int_equal(volux_majorant_grid_build(f->ctx, f->v, &f->lut, &f->grid), VOLUX_OK);
}

static void cloud_teardown(cloud *f) {
    volux_majorant_grid_free(f->ctx, &f->grid);
    volux_transfer_lut_free(f->ctx, &f->lut);
    volux_volume_release(f->v);
    volux_context_destroy(f->ctx);
}

/* A ray from a random point around the volume in a random direction,
 * clipped to it (0: it misses); *extra (if not NULL) gets one more uniform
 * number in [0, 1). */
static int random_ray(const volux_volume *v, uint64_t *x, volux_ray *ray, float *extra) {
    float u[7];
    for (int i = 0; i < 7; i++) {
        *x = *x * 6364136223846793005ull + 1442695040888963407ull;
        u[i] = (float)((*x >> 11) * (1.0 / 9007199254740992.0));
    }
    if (extra) *extra = u[6];
    volux_vec3 o = v3(60 * (u[0] - 0.5f), 60 * (u[1] - 0.5f), 60 * (u[2] - 0.5f));
    volux_vec3 dir = v3_normalize(v3(u[3] - 0.5f, u[4] - 0.5f, u[5] - 0.5f));
    return volux_ray_clip(v, o, dir, ray);
}

static void test_intervals_cover_the_ray_and_bound_sigma(void **state) {
    (void)state;
    cloud f;
    cloud_setup(&f, 60.0f, 120.0f);
    const volux_volume *v = f.v;
    const volux_transfer_lut *lut = &f.lut;
    uint64_t x = 99;
    int empty = 0;
    for (int r = 0; r < 300; r++) {
        volux_ray ray;
        if (!random_ray(v, &x, &ray, NULL)) continue;
        volux_march_iter it;
        volux_march_init(&it, &f.grid, &ray, ray.t0, ray.t1);
        volux_interval iv;
        float t = ray.t0;
        while (volux_march_next(&it, &iv)) {
            assert_near(iv.t0, t, 1e-4); /* contiguous */
            assert_true(iv.t1 >= iv.t0);
            for (int k = 1; k < 8; k++) { /* σt inside the interval ≤ its majorant */
                float tt = iv.t0 + (iv.t1 - iv.t0) * (float)k / 8.0f;
                volux_vec3 q = v3_madd(ray.q0, ray.dq, tt);
                float s = volux_volume_sample_index(v, q.x, q.y, q.z);
                assert_true(volux_lut_sigma(lut, s) <= iv.sigma_max * 1.0001f + 1e-6f);
            }
            empty += iv.sigma_max == 0.0f;
            t = iv.t1;
        }
        assert_near(t, ray.t1, 1e-3); /* and complete */
    }
    assert_true(empty > 0); /* the TF leaves some cells empty: skipping has work to do */
    cloud_teardown(&f);
}

/* Segments without a grid tile [t0, t1] at t0 + (k + jitter)·h; with a
 * grid they are a subset at the same positions, every segment left out has
 * zero extinction along it, and *gap marks exactly the segments whose front
 * was not the previous segment's end. */
static void test_segments_skip_only_empty_ones(void **state) {
    (void)state;
    cloud f;
    cloud_setup(&f, 90.0f, 140.0f);
    const volux_volume *v = f.v;
    const volux_transfer_lut *lut = &f.lut;
    enum { MAXSEG = 512 };
    float a0[MAXSEG], b0[MAXSEG];
    uint64_t x = 7;
    int skipped = 0, gaps = 0;
    for (int r = 0; r < 200; r++) {
        volux_ray ray;
        float jitter;
        if (!random_ray(v, &x, &ray, &jitter)) continue;
        const float h = 0.7f;
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
        volux_segments_init(&seg, &it, &f.grid, &ray, h, jitter);
        int i = 0;
        float prev_b = -1.0f;
        while (volux_segments_next(&seg, &a, &b, &gap)) {
            for (; i < n && a0[i] != a; i++) { /* left out: σt = 0 along it */
                for (int q = 0; q <= 8; q++) {
                    volux_vec3 p = v3_madd(ray.q0, ray.dq, a0[i] + (b0[i] - a0[i]) * (float)q / 8.0f);
                    assert_true(volux_lut_sigma(lut, volux_volume_sample_index(v, p.x, p.y, p.z)) == 0.0f);
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
    cloud_teardown(&f);
}

/* The packet ray caster sets up a tile's rays from per-column and per-row
 * camera offsets, one box and (orthographic) one 1/d per tile
 * (dvr_simd_impl.h, build_ray_list); its images are bit-identical to the
 * scalar kernel's only if every ray is the same bits as the per-pixel
 * volux_primary_ray + volux_ray_clip. Checked over whole images for
 * orthographic and perspective orbits, including axis-aligned views where
 * two components of d are 0 (1/d infinite: the slab test's NaN branch). */
static void test_hoisted_ray_setup_is_bit_identical(void **state) {
    (void)state;
    cloud f;
    cloud_setup(&f, 40, 120);
    volux_vec3 lo, hi;
    volux_volume_bounds(f.v, &lo, &hi);
    const volux_vec3 centre = v3_scale(v3_add(lo, hi), 0.5f);
    const float radius = 0.5f * v3_length(v3_sub(hi, lo));
    const float views[][2] = {{30, 20}, {0, 0}, {90, 0}, {-47.5f, 63}};
    const int w = 37, h = 29;
    int hits = 0, misses = 0;
    for (int proj = 0; proj < 2; proj++)
        for (size_t vi = 0; vi < sizeof views / sizeof views[0]; vi++) {
            volux_camera_desc d;
            volux_camera_desc_defaults(&d);
            d.projection = proj ? VOLUX_ORTHOGRAPHIC : VOLUX_PERSPECTIVE;
            d.azimuth_deg = views[vi][0];
            d.elevation_deg = views[vi][1];
            volux_camera cam;
            assert_int_equal(volux_camera_resolve(f.ctx, &d, centre, radius, w, h, &cam), VOLUX_OK);
            const volux_vec3 inv_fwd = v3_inverse(cam.forward);
            for (int y = 0; y < h; y++)
                for (int x = 0; x < w; x++) {
                    volux_primary pr = volux_primary_ray(&cam, 7, x, y, 0);
                    volux_ray ref, got;
                    memset(&ref, 0, sizeof ref);
                    memset(&got, 0, sizeof got);
                    int hit_ref = volux_ray_clip(f.v, pr.o, pr.d, &ref);
                    volux_vec3 o, dir;
                    volux_camera_ray_offsets(&cam, volux_camera_offset_x(&cam, (float)x + 0.5f),
                                             volux_camera_offset_y(&cam, (float)y + 0.5f), &o, &dir);
                    assert_memory_equal(&o, &pr.o, sizeof o);
                    assert_memory_equal(&dir, &pr.d, sizeof dir);
                    int hit = volux_ray_clip_hoisted(f.v, lo, hi, o, dir, proj ? inv_fwd : v3_inverse(dir), &got);
                    assert_int_equal(hit, hit_ref);
                    if (hit) assert_memory_equal(&got, &ref, sizeof got);
                    hits += hit, misses += !hit;
                }
        }
    assert_true(hits > 0 && misses > 0); /* both branches of the set-up ran */
    cloud_teardown(&f);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_intervals_cover_the_ray_and_bound_sigma),
        cmocka_unit_test(test_segments_skip_only_empty_ones),
        cmocka_unit_test(test_hoisted_ray_setup_is_bit_identical),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
