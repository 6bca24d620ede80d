/*
 * tests/unit/test_procedural.c — procedural volumes against their formulas:
 * Marschner–Lobb at sample nodes, sphere centre/corner, phantom bands,
 * constant, and determinism of the seeded cloud.
 */
#include <math.h>
#include <string.h>

#include "core/volume_internal.h"
#include "io/volume_formats.h"
#include "test_util.h"

static volux_volume *make(volux_context *ctx, const char *name, int nx, int ny, int nz, uint64_t seed) {
    int dims[3] = {nx, ny, nz};
    volux_volume *v = NULL;
    if (volux_volume_procedural(ctx, name, dims, seed, &v) != VOLUX_OK)
        fail_msg("procedural %s: %s", name, volux_context_error(ctx));
    return v;
}

/* Marschner & Lobb 1994, f_M = 6, α = 0.25, written independently of the
 * library's version. */
static double ml(double x, double y, double z) {
    double r = hypot(x, y);
    double rho = cos(2.0 * M_PI * 6.0 * cos(M_PI * r / 2.0));
    return (1.0 - sin(M_PI * z / 2.0) + 0.25 * (1.0 + rho)) / 2.5;
}

static void test_marschner_lobb_matches_the_formula(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    const int n = 41;
    volux_volume *v = make(ctx, "marschner_lobb", n, n, n, 1);
    assert_int_equal(volux_volume_type(v), VOLUX_UINT8);
    const int pts[][3] = {{0, 0, 0}, {20, 20, 20}, {40, 40, 40}, {7, 33, 12}, {40, 0, 20}, {13, 29, 39}, {20, 5, 0}};
    for (size_t p = 0; p < sizeof pts / sizeof pts[0]; p++) {
        double x = -1.0 + 2.0 * pts[p][0] / (n - 1), y = -1.0 + 2.0 * pts[p][1] / (n - 1),
               z = -1.0 + 2.0 * pts[p][2] / (n - 1);
        assert_near(volux_volume_value_at(v, pts[p][0], pts[p][1], pts[p][2]), 255.0 * ml(x, y, z), 0.5 + 1e-9);
    }
    /* The signal spans its whole range: z = −1 gives values near 255, z = 1 near 0. */
    double lo, hi;
    volux_volume_range(v, &lo, &hi);
    assert_true(lo <= 5 && hi >= 250);
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

static void test_sphere_centre_and_corners(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_volume *v = make(ctx, "sphere", 33, 33, 33, 1);
    assert_near(volux_volume_value_at(v, 16, 16, 16), 255, 0);
    assert_near(volux_volume_value_at(v, 0, 0, 0), 0, 0);
    assert_near(volux_volume_value_at(v, 32, 32, 0), 0, 0);
    assert_near(volux_volume_value_at(v, 0, 16, 16), 0, 0); /* radius 1: on the surface */
    /* half radius: 255 · (1 − smoothstep(0.5)) = 127.5 → 128 */
    assert_near(volux_volume_value_at(v, 24, 16, 16), 128, 0);
    /* symmetric */
    assert_true(volux_volume_value_at(v, 5, 9, 20) == volux_volume_value_at(v, 27, 23, 12));
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

static void test_phantom_value_bands(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    const int n = 51; /* node spacing 0.04: 0.72 is node 43 */
    volux_volume *v = make(ctx, "phantom", n, n, n, 1);
    assert_near(volux_volume_value_at(v, 43, 25, 25), 170, 0); /* +X sphere centre */
    assert_near(volux_volume_value_at(v, 25, 43, 25), 220, 0); /* +Y sphere centre */
    assert_near(volux_volume_value_at(v, 25, 25, 43), 255, 0); /* +Z cube centre */
    assert_near(volux_volume_value_at(v, 25, 25, 25), 0, 0);   /* inside the torus hole */
    assert_near(volux_volume_value_at(v, 0, 0, 0), 0, 0);
    float torus = volux_volume_value_at(v, 25, 25, 36); /* z = 0.44: 0.01 from the torus core */
    assert_true(torus >= 60 && torus <= 120);
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

static void test_cloud_is_deterministic_per_seed(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_volume *a = make(ctx, "cloud", 24, 20, 16, 7), *b = make(ctx, "cloud", 24, 20, 16, 7),
                 *c = make(ctx, "cloud", 24, 20, 16, 8);
    int differ = 0;
    for (int k = 0; k < 16; k++)
        for (int j = 0; j < 20; j++)
            for (int i = 0; i < 24; i++) {
                assert_true(volux_volume_value_at(a, i, j, k) == volux_volume_value_at(b, i, j, k));
                differ += volux_volume_value_at(a, i, j, k) != volux_volume_value_at(c, i, j, k);
            }
    assert_true(differ > 100);
    double lo, hi;
    volux_volume_range(a, &lo, &hi);
    assert_true(lo == 0 && hi > 100 && hi <= 255);
    volux_volume_release(a);
    volux_volume_release(b);
    volux_volume_release(c);
    volux_context_destroy(ctx);
}

static void test_constant_is_float_one(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_volume *v = make(ctx, "constant", 5, 1, 3, 1);
    assert_int_equal(volux_volume_type(v), VOLUX_FLOAT32);
    double lo, hi;
    volux_volume_range(v, &lo, &hi);
    assert_true(lo == 1.0 && hi == 1.0);
    double s[3];
    volux_volume_spacing(v, s);
    assert_true(s[0] == 1.0 && s[1] == 1.0 && s[2] == 1.0);
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

static void test_bad_names_and_dims(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    int dims[3] = {8, 8, 8};
    volux_volume *v = NULL;
    volux_context_clear_error(ctx);
    assert_int_equal(volux_volume_procedural(ctx, "teapot", dims, 1, &v), VOLUX_ERR_INVALID);
    assert_non_null(strstr(volux_context_error(ctx), "teapot"));
    assert_non_null(strstr(volux_context_error(ctx), "marschner_lobb"));
    dims[1] = 0;
    assert_int_equal(volux_volume_procedural(ctx, "sphere", dims, 1, &v), VOLUX_ERR_LIMIT);
    assert_null(v);
    assert_non_null(strstr(volux_procedural_names(), "phantom"));
    volux_context_destroy(ctx);
}

/* The threaded generator with its row intervals (the phantom's objects,
 * the cloud's envelope) writes exactly the bytes of evaluating every node
 * on one thread — the generator before either existed — for any thread
 * count, odd and non-cubic dims, and for bricks of a region. */
static void same_bytes(const volux_volume *a, const volux_volume *b, const char *what) {
    int da[3], db[3];
    volux_volume_dims(a, da);
    volux_volume_dims(b, db);
    assert_memory_equal(da, db, sizeof da);
    for (int k = 0; k < da[2]; k++)
        for (int j = 0; j < da[1]; j++)
            for (int i = 0; i < da[0]; i++)
                if (volux_volume_value_at(a, i, j, k) != volux_volume_value_at(b, i, j, k))
                    fail_msg("%s: node (%d, %d, %d): %g vs %g", what, i, j, k, volux_volume_value_at(a, i, j, k),
                             volux_volume_value_at(b, i, j, k));
}

static void test_threads_and_intervals_change_no_byte(void **state) {
    (void)state;
    static const char *names[] = {"phantom", "cloud", "sphere"};
    static const int shapes[][3] = {{97, 97, 97}, {61, 44, 53}, {128, 3, 40}, {2, 70, 70}};
    volux_context *one = tu_context(1);
    for (size_t f = 0; f < sizeof names / sizeof names[0]; f++)
        for (size_t s = 0; s < sizeof shapes / sizeof shapes[0]; s++) {
            volux_volume *ref = NULL;
            assert_int_equal(volux_procedural_exhaustive(one, names[f], shapes[s], 5, NULL, &ref), VOLUX_OK);
            for (int threads = 1; threads <= 3; threads++) {
                volux_context *ctx = tu_context(threads);
                volux_volume *v = NULL;
                assert_int_equal(volux_volume_procedural(ctx, names[f], shapes[s], 5, &v), VOLUX_OK);
                char what[96];
                snprintf(what, sizeof what, "%s %dx%dx%d, %d threads", names[f], shapes[s][0], shapes[s][1],
                         shapes[s][2], threads);
                same_bytes(v, ref, what);
                /* the macrocells (built in parallel slabs) too */
                assert_int_equal(v->cell_bytes, ref->cell_bytes);
                assert_memory_equal(v->cell_min, ref->cell_min, ref->cell_bytes);
                assert_memory_equal(v->cell_max, ref->cell_max, ref->cell_bytes);
                volux_volume_release(v);
                volux_context_destroy(ctx);
            }
            volux_volume_release(ref);
        }
    /* a brick: the intervals are in whole-grid coordinates */
    int dims[3] = {90, 90, 90};
    for (int index = 0; index < 4; index++) {
        volux_volume_region r = {4, index, 0};
        volux_volume *a = NULL, *b = NULL;
        assert_int_equal(volux_volume_procedural_region(one, "phantom", dims, 1, &r, &a), VOLUX_OK);
        assert_int_equal(volux_procedural_exhaustive(one, "phantom", dims, 1, &r, &b), VOLUX_OK);
        same_bytes(a, b, "phantom brick");
        volux_volume_release(a);
        volux_volume_release(b);
    }
    volux_context_destroy(one);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_marschner_lobb_matches_the_formula),
        cmocka_unit_test(test_sphere_centre_and_corners),
        cmocka_unit_test(test_phantom_value_bands),
        cmocka_unit_test(test_cloud_is_deterministic_per_seed),
        cmocka_unit_test(test_constant_is_float_one),
        cmocka_unit_test(test_bad_names_and_dims),
        cmocka_unit_test(test_threads_and_intervals_change_no_byte),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
