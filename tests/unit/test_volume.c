/* Volume storage, conversion, trilinear sampling, gradients, macrocells. */
#include <math.h>
#include <string.h>

#include "core/volume_internal.h"
#include "test_util.h"

static volux_volume *make(volux_context *ctx, int nx, int ny, int nz, volux_scalar_type type, const void *data) {
    volux_volume_desc d = {{nx, ny, nz}, {1, 1, 1}, {0, 0, 0}, 0, type, data, 0};
    volux_volume *v = NULL;
    assert_int_equal(volux_volume_create(ctx, &d, &v), VOLUX_OK);
    return v;
}

static void test_signed_types_keep_file_values(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    int8_t i8[8] = {-128, -1, 0, 1, 127, 5, -5, 0};
    int16_t i16[8] = {-32768, -1000, 0, 1000, 32767, 7, -7, 0};
    double f64[8] = {-1.5, 0, 2.25, 1e3, -1e3, 0.5, 3, 4};
    volux_volume *a = make(ctx, 2, 2, 2, VOLUX_INT8, i8), *b = make(ctx, 2, 2, 2, VOLUX_INT16, i16),
                 *c = make(ctx, 2, 2, 2, VOLUX_FLOAT64, f64);
    for (int i = 0; i < 8; i++) {
        assert_near(volux_volume_value_at(a, i & 1, (i >> 1) & 1, i >> 2), i8[i], 0);
        assert_near(volux_volume_value_at(b, i & 1, (i >> 1) & 1, i >> 2), i16[i], 0);
        assert_near(volux_volume_value_at(c, i & 1, (i >> 1) & 1, i >> 2), f64[i], 0);
    }
    double lo, hi;
    volux_volume_range(b, &lo, &hi);
    assert_near(lo, -32768, 0);
    assert_near(hi, 32767, 0);
    assert_int_equal(volux_volume_storage_kind(c), VOLUX_STORE_F32);
    volux_volume_release(a);
    volux_volume_release(b);
    volux_volume_release(c);
    volux_context_destroy(ctx);
}

/* Trilinear interpolation reproduces any function linear in x, y, z
 * exactly, and its central-difference gradient is the exact slope. */
static void test_trilinear_reproduces_linear_fields(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    enum { N = 9 };
    float data[N * N * N];
    for (int k = 0; k < N; k++)
        for (int j = 0; j < N; j++)
            for (int i = 0; i < N; i++) data[(k * N + j) * N + i] = 2.0f * i - 3.0f * j + 0.5f * k + 7.0f;
    volux_volume_desc d = {{N, N, N}, {2, 1, 0.5}, {0, 0, 0}, 0, VOLUX_FLOAT32, data, 0};
    volux_volume *v;
    assert_int_equal(volux_volume_create(ctx, &d, &v), VOLUX_OK);
    volux_vec3 o = volux_volume_origin(v);
    assert_near(o.x, -8.0, 1e-6); /* centred: −(dims−1)·spacing/2 */
    assert_near(o.z, -2.0, 1e-6);
    for (int t = 0; t < 200; t++) {
        float fi = (float)(t % 17) * 0.47f, fj = (float)(t % 13) * 0.61f, fk = (float)(t % 11) * 0.73f;
        volux_vec3 p = {o.x + fi * 2.0f, o.y + fj * 1.0f, o.z + fk * 0.5f};
        assert_near(volux_volume_sample(v, p), 2.0f * fi - 3.0f * fj + 0.5f * fk + 7.0f, 1e-4);
        volux_vec3 g = volux_volume_gradient(v, p);
        assert_near(g.x, 2.0 / 2.0, 1e-4); /* per world unit: slope / spacing */
        assert_near(g.y, -3.0 / 1.0, 1e-4);
        assert_near(g.z, 0.5 / 0.5, 1e-4);
    }
    assert_near(volux_volume_sample(v, (volux_vec3){100, 0, 0}), 0, 0); /* outside: empty */
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

/* Every trilinear value inside a macrocell lies within its [min, max]. */
static void test_macrocells_bound_the_field(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    int dims[3] = {37, 21, 18};
    volux_volume *v;
    assert_int_equal(volux_volume_procedural(ctx, "cloud", dims, 3, &v), VOLUX_OK);
    uint64_t x = 12345;
    for (int t = 0; t < 20000; t++) {
        float q[3];
        for (int a = 0; a < 3; a++) {
            x = x * 6364136223846793005ull + 1442695040888963407ull;
            q[a] = (float)((x >> 11) * (1.0 / 9007199254740992.0)) * (float)(dims[a] - 1);
        }
        float s = volux_volume_sample_index(v, q[0], q[1], q[2]);
        int c[3];
        for (int a = 0; a < 3; a++) {
            c[a] = (int)(q[a] / VOLUX_CELL_SIZE);
            if (c[a] >= v->cells[a]) c[a] = v->cells[a] - 1;
        }
        size_t ci = ((size_t)c[2] * (size_t)v->cells[1] + (size_t)c[1]) * (size_t)v->cells[0] + (size_t)c[0];
        assert_true(s >= v->cell_min[ci] - 1e-3f && s <= v->cell_max[ci] + 1e-3f);
    }
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

static void test_limits_are_checked_before_allocating(void **state) {
    (void)state;
    volux_context_desc cd = {0};
    cd.max_bytes = 1 << 20;
    volux_context *ctx;
    assert_int_equal(volux_context_create(&cd, &ctx), VOLUX_OK);
    volux_volume_desc d = {{1024, 1024, 1024}, {1, 1, 1}, {0, 0, 0}, 0, VOLUX_UINT8, NULL, 0};
    volux_volume *v = NULL;
    volux_context_clear_error(ctx);
    assert_int_equal(volux_volume_create(ctx, &d, &v), VOLUX_ERR_LIMIT);
    assert_non_null(strstr(volux_context_error(ctx), "memory cap"));
    assert_true(volux_context_bytes_in_use(ctx) < 4096);
    d.dims[0] = 0;
    assert_int_equal(volux_volume_create(ctx, &d, &v), VOLUX_ERR_LIMIT);
    d.dims[0] = 4;
    d.spacing[1] = -1;
    volux_context_clear_error(ctx);
    assert_int_equal(volux_volume_create(ctx, &d, &v), VOLUX_ERR_INVALID);
    assert_non_null(strstr(volux_context_error(ctx), "spacing[1]"));
    assert_null(v);
    volux_context_destroy(ctx);
}

static void test_histogram_counts_every_voxel(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    int dims[3] = {16, 16, 16};
    volux_volume *v;
    assert_int_equal(volux_volume_procedural(ctx, "sphere", dims, 1, &v), VOLUX_OK);
    uint64_t counts[10], total = 0;
    volux_volume_histogram(v, 10, counts);
    for (int i = 0; i < 10; i++) total += counts[i];
    assert_int_equal(total, 16 * 16 * 16);
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_signed_types_keep_file_values),
        cmocka_unit_test(test_trilinear_reproduces_linear_fields),
        cmocka_unit_test(test_macrocells_bound_the_field),
        cmocka_unit_test(test_limits_are_checked_before_allocating),
        cmocka_unit_test(test_histogram_counts_every_voxel),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
