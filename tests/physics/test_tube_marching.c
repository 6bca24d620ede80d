/*
 * tests/physics/test_tube_marching.c — light distribution by tube marching
 * (Ament et al. 2013, §4.2.2) in a homogeneous medium: the parallel sweep
 * against the closed-form product of table look-ups along each chain, and
 * against Beer–Lambert for a purely absorbing table.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "techniques/ambient/table.h"
#include "techniques/ambient/tube.h"
#include "techniques/ambient/tube_simd.h"
#include "test_util.h"

#define NS 4097
#define SMAX 8.0f

typedef struct fixture {
    volux_context *ctx;
    volux_volume *vol;
    scatter_grid rho, V;
    float kappa[NS];
    tube_input in;
} fixture;

static void setup(fixture *f, float rho0, float radius, float cache_scale, int aligned) {
    memset(f, 0, sizeof *f);
    f->ctx = tu_context(2);
    volux_volume_desc d = {{33, 33, 33}, {1, 1, 1}, {0, 0, 0}, 0, VOLUX_UINT8, NULL, 0};
    assert_int_equal(volux_volume_create(f->ctx, &d, &f->vol), VOLUX_OK);
    /* ρ at the cache's nodes (the technique's layout: directional lights
     * take the aligned fast path) or at the volume's (generic path). */
    assert_int_equal(scatter_grid_alloc(f->ctx, f->vol, aligned ? cache_scale : 1.0f, &f->rho, "rho"), VOLUX_OK);
    assert_int_equal(scatter_grid_alloc(f->ctx, f->vol, cache_scale, &f->V, "V"), VOLUX_OK);
    size_t n = (size_t)f->rho.dims[0] * f->rho.dims[1] * f->rho.dims[2];
    for (size_t i = 0; i < n; i++) f->rho.v[i] = rho0;
    /* Purely absorbing sphere: L̃o(0, ρ)/L̃o(0, 0) = e^{−2ρ}. */
    for (int i = 0; i < NS; i++) f->kappa[i] = 2.0f * SMAX * (float)i / (NS - 1);
    tube_input in = {&f->rho, f->kappa, NS, SMAX, radius, 2, 0, NULL};
    f->in = in;
}

static void teardown(fixture *f) {
    scatter_grid_free(f->ctx, &f->rho);
    scatter_grid_free(f->ctx, &f->V);
    volux_volume_release(f->vol);
    volux_context_destroy(f->ctx);
}

static volux_prepared_light directional(float x, float y, float z) {
    volux_prepared_light l;
    memset(&l, 0, sizeof l);
    l.travel = v3_normalize(v3(x, y, z));
    l.power = v3(1, 1, 1);
    return l;
}

static volux_prepared_light point(float x, float y, float z) {
    volux_prepared_light l;
    memset(&l, 0, sizeof l);
    l.positional = 1;
    l.pos = v3(x, y, z);
    l.power = v3(1, 1, 1);
    return l;
}

/* Max relative error of the sweep against `expect` over all nodes. */
typedef float (*expect_fn)(const fixture *f, const volux_prepared_light *l, volux_vec3 x);

static float chain_expect(const fixture *f, const volux_prepared_light *l, volux_vec3 x) {
    return tube_chain(&f->in, l, &f->V, x);
}

/* Beer–Lambert: e^{−σ̃t δ}, δ the path length inside the box. */
static float beer_expect(const fixture *f, const volux_prepared_light *l, volux_vec3 x) {
    float sigma = f->rho.v[0] / f->in.radius;
    volux_vec3 w = l->positional ? v3_normalize(v3_sub(x, l->pos)) : l->travel;
    float t = INFINITY;
    float xv[3] = {x.x, x.y, x.z}, wv[3] = {w.x, w.y, w.z};
    for (int a = 0; a < 3; a++) {
        if (wv[a] < 0.0f) t = fminf(t, (16.0f - xv[a]) / -wv[a]);
        if (wv[a] > 0.0f) t = fminf(t, (xv[a] + 16.0f) / wv[a]);
    }
    if (l->positional) t = fminf(t, v3_length(v3_sub(x, l->pos)));
    return expf(-sigma * t);
}

static int cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* Absolute errors of V = e^{−D} (a fraction of the unshadowed irradiance)
 * of the sweep against `expect` over all nodes: max, and optionally mean
 * and 90th percentile. */
static double max_error_stats(fixture *f, const volux_prepared_light *l, expect_fn expect, double *mean, double *p90) {
    assert_int_equal(tube_march(f->ctx, &f->in, l, &f->V), VOLUX_OK);
    size_t n = (size_t)f->V.dims[0] * f->V.dims[1] * f->V.dims[2], m = 0;
    double *e = malloc(n * sizeof *e), sum = 0.0;
    for (int k = 0; k < f->V.dims[2]; k++)
        for (int j = 0; j < f->V.dims[1]; j++)
            for (int i = 0; i < f->V.dims[0]; i++) {
                float got = expf(-f->V.v[((size_t)k * f->V.dims[1] + j) * f->V.dims[0] + i]);
                float want = expect(f, l, scatter_grid_node(&f->V, i, j, k));
                e[m] = fabs(got - want); /* V ∈ [0, 1]: absolute error = error in irradiance fraction */
                sum += e[m++];
            }
    qsort(e, m, sizeof *e, cmp_double);
    double worst = e[m - 1];
    if (mean) *mean = sum / (double)m;
    if (p90) *p90 = e[(size_t)(0.9 * (double)(m - 1))];
    free(e);
    return worst;
}

static double max_error(fixture *f, const volux_prepared_light *l, expect_fn expect) {
    return max_error_stats(f, l, expect, NULL, NULL);
}

static void test_axis_aligned_sweep_is_the_closed_form_product(void **state) {
    (void)state;
    fixture f;
    for (int aligned = 0; aligned < 2; aligned++) {
        setup(&f, 0.2f, 2.0f, 0.5f, aligned); /* s = 2r = 4 = two cache cells: chains hit nodes */
        volux_prepared_light l = directional(0, 0, -1);
        assert_true(max_error(&f, &l, chain_expect) < 1e-5);
        assert_true(max_error(&f, &l, beer_expect) < 1e-4);
        l = directional(1, 0, 0);
        assert_true(max_error(&f, &l, chain_expect) < 1e-5);
        teardown(&f);
    }
}

/* Oblique and point lights: chains end between nodes and the sweep
 * interpolates D = −ln V there. D is linear in a homogeneous medium except
 * where the chain start jumps from one face of the box to another (its
 * edges) and around a light inside the box (D ∝ distance, a cone); the
 * sweep evaluates the first step exactly, which removes most of that.
 * Measured (σ̃t = 0.1/voxel up to the box faces, five lights): mean
 * ≤ 0.0011, p90 ≤ 0.0024, max ≤ 0.047 (at box-edge kinks). Thresholds are
 * absolute errors in V. */
static void test_oblique_and_point_lights_follow_beer_lambert(void **state) {
    (void)state;
    fixture f;
    for (int aligned = 0; aligned < 2; aligned++) {
    setup(&f, 0.3f, 3.0f, 0.5f, aligned);
    volux_prepared_light lights[] = {directional(-1, -2, -3), directional(0.3f, 1, -0.2f), point(40, 30, 50),
                              point(3, -2, 5), point(-16, -16, -16)};
    for (size_t i = 0; i < sizeof lights / sizeof lights[0]; i++) {
        double mean, p90;
        double e = max_error_stats(&f, &lights[i], beer_expect, &mean, &p90);
        print_message("light %zu vs Beer-Lambert: mean %.3g p90 %.3g max %.3g\n", i, mean, p90, e);
        if (mean > 0.002 || p90 > 0.004 || e > 0.08) fail_msg("light %zu: sweep deviates from Beer-Lambert", i);
        e = max_error_stats(&f, &lights[i], chain_expect, &mean, &p90);
        if (mean > 0.002 || p90 > 0.004 || e > 0.08) fail_msg("light %zu: sweep deviates from the chain product", i);
    }
    teardown(&f);
    }
}

/* With a real table (multiple scattering, g = 0.6), the sweep still equals
 * the product of table look-ups along the chain. */
static void test_sweep_with_real_table(void **state) {
    (void)state;
    fixture f;
    setup(&f, 0.5f, 2.0f, 0.5f, 1);
    volux_ambient_table_desc d;
    volux_ambient_table_desc_defaults(&d);
    d.n_theta = 3, d.n_sigma = 33, d.n_g = 3, d.sigma_max = SMAX, d.paths = 400, d.g_min = -0.6, d.g_max = 0.6;
    volux_ambient_table t;
    assert_int_equal(volux_ambient_table_build(f.ctx, &d, &t), VOLUX_OK);
    float kappa[33];
    float vac = t.data[volux_ambient_table_index(&d, 0, 0, 2)];
    for (int i = 0; i < 33; i++) {
        float v = t.data[volux_ambient_table_index(&d, 0, i, 2)] / vac;
        kappa[i] = tube_kappa_of_tau(v > 1.0f ? 1.0f : v);
    }
    f.in.kappa = kappa;
    f.in.n_sigma = 33;
    volux_prepared_light l = directional(0, -1, 0);
    assert_true(max_error(&f, &l, chain_expect) < 1e-5);
    l = point(20, 25, 30);
    double mean, p90;
    double e = max_error_stats(&f, &l, chain_expect, &mean, &p90);
    print_message("real table, point light: mean %.3g p90 %.3g max %.3g\n", mean, p90, e);
    assert_true(mean < 0.002 && p90 < 0.004 && e < 0.08);
    volux_ambient_table_free(f.ctx, &t);
    teardown(&f);
}

/* A heterogeneous ρ: up to beyond the table's range, with exact zeros
 * (and, with empty_half, none in the lower half along x); returns the node
 * count. */
static size_t random_rho(fixture *f, uint64_t seed, int empty_half) {
    size_t n = (size_t)f->rho.dims[0] * f->rho.dims[1] * f->rho.dims[2];
    for (size_t i = 0; i < n; i++) {
        seed = seed * 6364136223846793005ull + 1442695040888963407ull;
        float u = (float)(seed >> 40) / (float)(1u << 24);
        int empty = empty_half && 2 * (int)(i % (size_t)f->rho.dims[0]) < f->rho.dims[0];
        f->rho.v[i] = empty || u < 0.2f ? 0.0f : (u - 0.2f) * 12.0f;
    }
    return n;
}

/* The widths the kernel caps select on this CPU: 16 lanes (AVX-512F) for
 * the best where the CPU has it, else 8 (AVX2), and 8 for the AVX2 cap;
 * so the comparisons below cover both widths where AVX-512F is present. */
static int best_lanes(void) {
    const tube_kernels *k = tube_kernels_for(TUBE_KERNEL_BEST);
    return k ? k->lanes : 1;
}

static void test_kernel_caps_select_widths(void **state) {
    (void)state;
    assert_null(tube_kernels_for(TUBE_KERNEL_SCALAR));
    if (!tube_kernels_avx2()) {
        assert_null(tube_kernels_for(TUBE_KERNEL_BEST));
        skip();
    }
    assert_int_equal(tube_kernels_for(TUBE_KERNEL_AVX2)->lanes, 8);
    assert_false(tube_kernels_for(TUBE_KERNEL_AVX2)->vacuum_chains);
    assert_int_equal(best_lanes(), tube_kernels_avx512() ? 16 : 8);
    print_message("kernel widths on this CPU: best %d, avx2 8\n", best_lanes());
}

/* The 16- and 8-wide node updates (tube_avx512.c, tube_avx2.c) against
 * the scalar one on a heterogeneous medium, for directional lights along
 * and between the axes and point lights outside, inside, on a node and at
 * a corner of the box, with 1 and 2 threads: the caches must be
 * bit-identical (same operations in the same order; see tube_simd_impl.h). */
static void test_simd_nodes_equal_scalar_nodes(void **state) {
    (void)state;
    if (!tube_kernels_avx2()) skip();
    fixture f;
    for (int variant = 0; variant < 2; variant++) {
        /* variant 1: a step that is no multiple of the cache spacing, a
         * coarser cache and a smaller κ table */
        setup(&f, 0.0f, variant ? 2.3f : 3.0f, variant ? 0.37f : 0.5f, 1);
        size_t n = random_rho(&f, 12345u, 0);
        if (variant) f.in.n_sigma = 33;
        volux_prepared_light lights[] = {directional(-1, -2, -3), directional(0.3f, 1, -0.2f), directional(0, 0, 1),
                                  directional(1, 0.5f, 0),  point(40, 30, 50),          point(3, -2, 5),
                                  point(-16, -16, -16),     point(0, 0, 0),             point(16, -16, 16.5f),
                                  point(-30, 2, 1)};
        size_t bytes = n * sizeof(float);
        float *ref = malloc(bytes);
        for (size_t li = 0; li < sizeof lights / sizeof lights[0]; li++) {
            f.in.kernel_cap = TUBE_KERNEL_SCALAR;
            f.in.threads = 1;
            assert_int_equal(tube_march(f.ctx, &f.in, &lights[li], &f.V), VOLUX_OK);
            memcpy(ref, f.V.v, bytes);
            /* the widest kernel this CPU has, and AVX2 where that is wider */
            for (int run = 0; run < 4; run++) {
                int threads = 1 + (run & 1), cap = run < 2 ? TUBE_KERNEL_BEST : TUBE_KERNEL_AVX2;
                if (cap == TUBE_KERNEL_AVX2 && best_lanes() == 8) continue;
                f.in.kernel_cap = cap;
                f.in.threads = threads;
                memset(f.V.v, 0xff, bytes); /* NaN: every node must be written */
                assert_int_equal(tube_march(f.ctx, &f.in, &lights[li], &f.V), VOLUX_OK);
                size_t diff = 0, first = n;
                for (size_t i = 0; i < n; i++)
                    if (memcmp(&ref[i], &f.V.v[i], sizeof(float)) != 0 && diff++ == 0) first = i;
                if (diff)
                    fail_msg("variant %d light %zu threads %d kernel %d: %zu nodes differ (first %zu: %.9g vs %.9g)",
                             variant, li, threads, cap, diff, first, ref[first], f.V.v[first]);
            }
        }
        free(ref);
        teardown(&f);
    }
}

/* Records light l's geometry by a march with κ = k_rec (kernel rc, 2
 * threads) and re-sums it with k_new (kernel sc): the cache must be
 * bit-identical to a scalar march with k_new. */
static void check_resum(fixture *f, const volux_prepared_light *l, const float *k_rec, const float *k_new, int rc, int sc,
                        int threads, tube_geometry *geo) {
    size_t n = (size_t)f->V.dims[0] * f->V.dims[1] * f->V.dims[2], bytes = n * sizeof(float);
    float *ref = malloc(bytes);
    f->in.kappa = k_new, f->in.geo = NULL, f->in.kernel_cap = TUBE_KERNEL_SCALAR, f->in.threads = 1;
    assert_int_equal(tube_march(f->ctx, &f->in, l, &f->V), VOLUX_OK);
    memcpy(ref, f->V.v, bytes);
    f->in.kappa = k_rec, f->in.geo = geo, f->in.kernel_cap = rc, f->in.threads = 2;
    assert_int_equal(tube_march(f->ctx, &f->in, l, &f->V), VOLUX_OK);
    memset(f->V.v, 0xff, bytes);
    f->in.kappa = k_new, f->in.kernel_cap = sc, f->in.threads = threads;
    assert_int_equal(tube_resum(f->ctx, &f->in, l, &f->V), VOLUX_OK);
    if (memcmp(ref, f->V.v, bytes) != 0) {
        size_t i = 0;
        while (memcmp(&ref[i], &f->V.v[i], sizeof(float)) == 0) i++;
        fail_msg("record kernel %d, re-sum kernel %d: node %zu %.9g != %.9g", rc, sc, i, f->V.v[i], ref[i]);
    }
    free(ref);
}

/* A phase edit re-sums the cache from its g-independent geometry
 * (tube_geometry) with the new κ: the result must be bit-identical to a
 * march with that κ, whichever path (scalar, 8-wide) recorded the geometry
 * and whichever re-sums, on 1 or 2 threads. */
static void test_resum_equals_march(void **state) {
    (void)state;
    fixture f;
    setup(&f, 0.0f, 2.3f, 0.5f, 1);
    size_t n = random_rho(&f, 777u, 0);
    /* a second κ: a different, non-linear curve (as another g gives) */
    static float kappa2[NS];
    for (int i = 0; i < NS; i++) {
        float r = SMAX * (float)i / (NS - 1);
        kappa2[i] = 1.3f * r / (1.0f + 0.05f * r);
    }
    volux_prepared_light lights[] = {directional(-1, -2, -3), directional(0, 0, 1), point(40, 30, 50), point(3, -2, 5),
                              point(-16, -16, -16)};
    tube_geometry geo = {0};
    assert_int_equal(tube_geometry_alloc(f.ctx, n, &geo), VOLUX_OK);
    /* kernels: scalar, and AVX2 / the best one where the CPU has them */
    int caps[3] = {TUBE_KERNEL_SCALAR, TUBE_KERNEL_AVX2, TUBE_KERNEL_BEST}, n_caps = tube_kernels_avx2() ? 3 : 1;
    for (size_t li = 0; li < sizeof lights / sizeof lights[0]; li++)
        for (int rc = 0; rc < n_caps; rc++)
            for (int sc = 0; sc < n_caps; sc++) {
                check_resum(&f, &lights[li], f.kappa, kappa2, caps[rc], caps[sc], 1 + (int)(li & 1), &geo);
            }
    f.in.geo = NULL;
    f.in.kappa = f.kappa;
    /* a re-sum needs recorded geometry of the grid's size */
    tube_geometry none = {0};
    f.in.geo = &none;
    assert_int_equal(tube_resum(f.ctx, &f.in, &lights[0], &f.V), VOLUX_ERR_INVALID);
    f.in.geo = NULL;
    tube_geometry_free(f.ctx, &geo);
    teardown(&f);
}

/* Vacuum chains (tube.h: tube_geometry): a medium whose lower half in x is
 * empty, lit through it and from the other side. The AVX-512 march must
 * find them (vac_ok, some vacuum nodes) and the re-sum that stores +0 for
 * them must still equal a march. A κ that is 0 above ρ = 0 (τ clamped to
 * 1) breaks their invariant: the march must notice, and the re-sum then
 * computes every node. */
static void test_resum_vacuum_chains(void **state) {
    (void)state;
    fixture f;
    setup(&f, 0.0f, 2.3f, 0.5f, 1);
    size_t n = random_rho(&f, 4242u, 1);
    static float kappa2[NS], clamped[NS];
    for (int i = 0; i < NS; i++) {
        float r = SMAX * (float)i / (NS - 1);
        kappa2[i] = 1.3f * r / (1.0f + 0.05f * r);
        clamped[i] = r < 1.0f ? 0.0f : r - 1.0f;
    }
    volux_prepared_light lights[] = {directional(1, 0.2f, 0.3f), directional(-1, 0.1f, 0), point(-40, 3, 5), point(2, 1, -1),
                              point(40, -30, 20)};
    tube_geometry geo = {0};
    assert_int_equal(tube_geometry_alloc(f.ctx, n, &geo), VOLUX_OK);
    int best = best_lanes() == 16 ? TUBE_KERNEL_BEST : TUBE_KERNEL_SCALAR;
    for (size_t li = 0; li < sizeof lights / sizeof lights[0]; li++) {
        check_resum(&f, &lights[li], f.kappa, kappa2, best, best, 2, &geo);
        if (best_lanes() == 16) {
            size_t vac = 0;
            for (size_t i = 0; i < n; i++) vac += geo.vac[i];
            /* light 0 reaches most of the box through the empty half */
            assert_true(geo.vac_ok && vac > (li == 0 ? n / 2 : 0));
        }
        check_resum(&f, &lights[li], clamped, kappa2, best, best, 1, &geo);
        assert_false(geo.vac_ok);
    }
    f.in.geo = NULL;
    tube_geometry_free(f.ctx, &geo);
    teardown(&f);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_axis_aligned_sweep_is_the_closed_form_product),
        cmocka_unit_test(test_oblique_and_point_lights_follow_beer_lambert),
        cmocka_unit_test(test_sweep_with_real_table),
        cmocka_unit_test(test_kernel_caps_select_widths),
        cmocka_unit_test(test_simd_nodes_equal_scalar_nodes),
        cmocka_unit_test(test_resum_equals_march),
        cmocka_unit_test(test_resum_vacuum_chains),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
