/*
 * tests/physics/test_ambient_table.c — the preintegration table of ambient
 * scattering (Ament et al. 2013, §4.1): limits, invariants, agreement with
 * the paper's literal estimator, determinism and the file format.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "techniques/ambient/table_internal.h"
#include "techniques/scatter/hg.h"
#include "test_util.h"

static volux_ambient_table_desc small_desc(void) {
    volux_ambient_table_desc d;
    volux_ambient_table_desc_defaults(&d);
    d.n_theta = 33;
    d.n_sigma = 9;
    d.n_g = 5; /* −0.9, −0.45, 0, 0.45, 0.9 */
    d.sigma_max = 8.0;
    d.paths = 400;
    return d;
}

static double theta_at(const volux_ambient_table_desc *d, int it) { return M_PI * it / (d->n_theta - 1); }
static double sigma_at(const volux_ambient_table_desc *d, int is) { return d->sigma_max * is / (d->n_sigma - 1); }
static double g_at(const volux_ambient_table_desc *d, int ig) {
    return d->g_min + (d->g_max - d->g_min) * ig / (d->n_g - 1);
}
static double at(const volux_ambient_table *t, int it, int is, int ig) {
    return t->data[volux_ambient_table_index(&t->desc, it, is, ig)];
}

static volux_ambient_table build(volux_context *ctx, const volux_ambient_table_desc *d) {
    volux_ambient_table t;
    assert_int_equal(volux_ambient_table_build(ctx, d, &t), VOLUX_OK);
    return t;
}

/* σ̃t → 0: the unattenuated boundary term of Eq. 11, p_g(cos θ), exactly. */
static void test_empty_sphere_gives_boundary_term(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    volux_ambient_table_desc d = small_desc();
    volux_ambient_table t = build(ctx, &d);
    for (int ig = 0; ig < d.n_g; ig++)
        for (int it = 0; it < d.n_theta; it++) {
            double want = scatter_hg_d(g_at(&d, ig), cos(theta_at(&d, it)));
            assert_near(at(&t, it, 0, ig), want, 1e-6 * want);
        }
    /* g = 0: isotropic, 1/(4π) in every direction. */
    for (int it = 0; it < d.n_theta; it++) assert_near(at(&t, it, 0, 2), 1.0 / (4.0 * M_PI), 1e-7);
    volux_ambient_table_free(ctx, &t);
    volux_context_destroy(ctx);
}

/* Albedo 0: no scattering, so every entry is the analytic uncollided term. */
static void test_black_medium_is_uncollided_term(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    volux_ambient_table_desc d = small_desc();
    d.albedo = 0.0;
    volux_ambient_table t = build(ctx, &d);
    for (int ig = 0; ig < d.n_g; ig++)
        for (int is = 0; is < d.n_sigma; is++)
            for (int it = 0; it < d.n_theta; it++) {
                double want = volux_ambient_uncollided(theta_at(&d, it), sigma_at(&d, is), g_at(&d, ig));
                assert_near(at(&t, it, is, ig), want, 1e-6 * want + 1e-30);
            }
    volux_ambient_table_free(ctx, &t);
    volux_context_destroy(ctx);
}

/* g ↔ −g mirrors θ ↔ π − θ in the empty sphere (the phase lobe flips). */
static void test_g_mirror_symmetry_at_zero_extinction(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_ambient_table_desc d = small_desc();
    volux_ambient_table t = build(ctx, &d);
    for (int ig = 0; ig < d.n_g; ig++)
        for (int it = 0; it < d.n_theta; it++) {
            double a = at(&t, it, 0, ig), b = at(&t, d.n_theta - 1 - it, 0, d.n_g - 1 - ig);
            assert_near(a, b, 1e-5 * a);
        }
    volux_ambient_table_free(ctx, &t);
    volux_context_destroy(ctx);
}

/* Energy: the exitant radiance integrated over the sphere of exit points,
 * 2π ∫ L̃o sin θ dθ, never exceeds that of the empty sphere (which is 1),
 * and no entry exceeds the largest boundary radiance p_g(1). */
static void test_energy_bounds(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    volux_ambient_table_desc d = small_desc();
    d.n_theta = 257; /* fine enough for the g = 0.9 lobe quadrature */
    d.n_sigma = 5;
    d.albedo = 1.0;  /* the hardest case: nothing absorbed */
    d.paths = 6000;  /* g = 0.9 near σ̃t = 1 sits at 0.997: keep the noise below the 3 % margin */
    volux_ambient_table t = build(ctx, &d);
    for (int ig = 0; ig < d.n_g; ig++) {
        double g = g_at(&d, ig), pmax = fmax(scatter_hg_d(g, 1.0), scatter_hg_d(g, -1.0)), e0 = 0.0;
        for (int is = 0; is < d.n_sigma; is++) {
            double e = 0.0;
            for (int it = 0; it + 1 < d.n_theta; it++) {
                double t0 = theta_at(&d, it), t1 = theta_at(&d, it + 1);
                e += 0.5 * (at(&t, it, is, ig) * sin(t0) + at(&t, it + 1, is, ig) * sin(t1)) * (t1 - t0);
            }
            e *= 2.0 * M_PI;
            if (is == 0) {
                e0 = e;
                assert_near(e0, 1.0, 0.02);
            }
            if (e > e0 * 1.03) fail_msg("g=%g sigma=%g: energy %g > empty sphere %g", g, sigma_at(&d, is), e, e0);
            for (int it = 0; it < d.n_theta; it++)
                if (at(&t, it, is, ig) > pmax * 1.05) fail_msg("entry above p_g(1) at g=%g", g);
        }
    }
    volux_ambient_table_free(ctx, &t);
    volux_context_destroy(ctx);
}

/* The fast estimator (all-θ symmetry, analytic uncollided term, escape
 * scoring) agrees with the paper's literal estimator within their combined
 * statistical errors. */
static void test_fast_estimator_matches_paper_estimator(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    volux_ambient_table_desc d = small_desc();
    d.paths = 20000;
    volux_ambient_table t = build(ctx, &d);
    const int cases[][3] = {{0, 1, 2}, {16, 2, 3}, {32, 4, 1}, {8, 6, 4}, {24, 3, 0}, {16, 8, 2}, {0, 3, 4}};
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        int it = cases[c][0], is = cases[c][1], ig = cases[c][2];
        double se_ref;
        double ref = volux_ambient_reference_entry(theta_at(&d, it), sigma_at(&d, is), g_at(&d, ig), d.albedo, 40000,
                                                   7, &se_ref);
        double v = at(&t, it, is, ig), se = v * t.rel_error[volux_ambient_table_index(&d, it, is, ig)];
        double tol = 4.5 * sqrt(se * se + se_ref * se_ref) + 1e-9;
        if (fabs(v - ref) > tol)
            fail_msg("theta=%g sigma=%g g=%g: fast %g ± %g vs paper %g ± %g", theta_at(&d, it), sigma_at(&d, is),
                     g_at(&d, ig), v, se, ref, se_ref);
        /* and the fast one is the less noisy per walk */
        assert_true(se < se_ref * 2.0);
    }
    volux_ambient_table_free(ctx, &t);
    volux_context_destroy(ctx);
}

static void test_build_is_thread_count_independent(void **state) {
    (void)state;
    volux_ambient_table_desc d = small_desc();
    volux_context *c1 = tu_context(1), *c2 = tu_context(2);
    volux_ambient_table a = build(c1, &d), b = build(c2, &d);
    size_t n = (size_t)d.n_theta * d.n_sigma * d.n_g * sizeof(float);
    assert_memory_equal(a.data, b.data, n);
    assert_memory_equal(a.rel_error, b.rel_error, n);
    volux_ambient_table_free(c1, &a);
    volux_ambient_table_free(c2, &b);
    volux_context_destroy(c1);
    volux_context_destroy(c2);
}

static long file_size(const char *path) {
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fclose(f);
    return n;
}

static void flip_byte(const char *path, long at_byte) {
    FILE *f = fopen(path, "r+b");
    assert_non_null(f);
    fseek(f, at_byte, SEEK_SET);
    int c = fgetc(f);
    fseek(f, at_byte, SEEK_SET);
    fputc(c ^ 0x5a, f);
    fclose(f);
}

static void test_file_roundtrip_and_corruption(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    volux_ambient_table_desc d = small_desc();
    d.paths = 50;
    volux_ambient_table t = build(ctx, &d), u;
    const char *path = tu_temp_path("table.vxat");
    assert_int_equal(volux_ambient_table_save(ctx, &t, path), VOLUX_OK);
    size_t n = (size_t)d.n_theta * d.n_sigma * d.n_g;
    assert_int_equal(file_size(path), 128 + 2 * 4 * (long)n + 8);
    assert_int_equal(volux_ambient_table_load(ctx, path, &u), VOLUX_OK);
    assert_memory_equal(t.data, u.data, n * sizeof(float));
    assert_int_equal(u.desc.n_theta, d.n_theta);
    assert_true(u.desc.albedo == d.albedo && u.desc.paths == d.paths && u.desc.sigma_max == d.sigma_max);
    volux_ambient_table_free(ctx, &u);
    /* A flipped data byte fails the checksum. */
    flip_byte(path, 128 + 40);
    volux_context_clear_error(ctx); /* the first error wins: start afresh */
    assert_int_equal(volux_ambient_table_load(ctx, path, &u), VOLUX_ERR_FORMAT);
    assert_non_null(strstr(volux_context_error(ctx), "checksum"));
    /* Bad magic, truncation, missing file. */
    assert_int_equal(volux_ambient_table_save(ctx, &t, path), VOLUX_OK);
    flip_byte(path, 0);
    volux_context_clear_error(ctx); /* the first error wins: start afresh */
    assert_int_equal(volux_ambient_table_load(ctx, path, &u), VOLUX_ERR_FORMAT);
    assert_non_null(strstr(volux_context_error(ctx), "magic"));
    const char *tiny = tu_write_file("short.vxat", "VXAMBTAB\1\0\0\0", 12);
    assert_int_equal(volux_ambient_table_load(ctx, tiny, &u), VOLUX_ERR_FORMAT);
    assert_int_equal(volux_ambient_table_load(ctx, tu_temp_path("missing.vxat"), &u), VOLUX_ERR_IO);
    volux_ambient_table_free(ctx, &t);
    volux_context_destroy(ctx);
}

static void test_cache_builds_once(void **state) {
    (void)state;
    char dir[600];
    snprintf(dir, sizeof dir, "%s", tu_temp_path("xdg-cache"));
    setenv("XDG_CACHE_HOME", dir, 1);
    volux_context *ctx = tu_context(2);
    volux_ambient_table_desc d = small_desc();
    d.paths = 20;
    volux_ambient_table a, b;
    int built = -1;
    assert_int_equal(volux_ambient_table_get(ctx, &d, &a, &built), VOLUX_OK);
    assert_int_equal(built, 1);
    assert_int_equal(volux_ambient_table_get(ctx, &d, &b, &built), VOLUX_OK);
    assert_int_equal(built, 0);
    assert_memory_equal(a.data, b.data, (size_t)d.n_theta * d.n_sigma * d.n_g * sizeof(float));
    volux_ambient_table_free(ctx, &a);
    volux_ambient_table_free(ctx, &b);
    /* Another albedo is another table. */
    d.albedo = 0.5;
    assert_int_equal(volux_ambient_table_get(ctx, &d, &a, &built), VOLUX_OK);
    assert_int_equal(built, 1);
    volux_ambient_table_free(ctx, &a);
    volux_context_destroy(ctx);
}

static void test_bad_descriptions_name_the_field(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_ambient_table_desc d = small_desc();
    volux_ambient_table t;
    d.n_theta = 1;
    volux_context_clear_error(ctx); /* the first error wins: start afresh */
    assert_int_equal(volux_ambient_table_build(ctx, &d, &t), VOLUX_ERR_INVALID);
    assert_non_null(strstr(volux_context_error(ctx), "n_theta"));
    d = small_desc();
    d.albedo = 1.5;
    volux_context_clear_error(ctx); /* the first error wins: start afresh */
    assert_int_equal(volux_ambient_table_build(ctx, &d, &t), VOLUX_ERR_INVALID);
    assert_non_null(strstr(volux_context_error(ctx), "albedo"));
    d = small_desc();
    d.g_max = 1.0;
    volux_context_clear_error(ctx); /* the first error wins: start afresh */
    assert_int_equal(volux_ambient_table_build(ctx, &d, &t), VOLUX_ERR_INVALID);
    assert_non_null(strstr(volux_context_error(ctx), "g range"));
    volux_context_destroy(ctx);
}

/* The CLI builds a table file that loads back. */
static void test_cli_builds_a_table(void **state) {
    (void)state;
    const char *path = tu_temp_path("cli.vxat"), *err;
    char args[1024];
    snprintf(args, sizeof args, "ambient-table -o %s --theta 8 --sigma 4 --g 3 --paths 10 --albedo 0.7", path);
    assert_int_equal(tu_run_cli(args, &err), 0);
    volux_context *ctx = tu_context(1);
    volux_ambient_table t;
    assert_int_equal(volux_ambient_table_load(ctx, path, &t), VOLUX_OK);
    assert_int_equal(t.desc.n_theta, 8);
    assert_true(t.desc.albedo == 0.7);
    volux_ambient_table_free(ctx, &t);
    volux_context_destroy(ctx);
    assert_int_equal(tu_run_cli("ambient-table -o x.vxat --albedo 2", &err), 2);
    assert_non_null(strstr(err, "albedo"));
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_empty_sphere_gives_boundary_term),
        cmocka_unit_test(test_black_medium_is_uncollided_term),
        cmocka_unit_test(test_g_mirror_symmetry_at_zero_extinction),
        cmocka_unit_test(test_energy_bounds),
        cmocka_unit_test(test_fast_estimator_matches_paper_estimator),
        cmocka_unit_test(test_build_is_thread_count_independent),
        cmocka_unit_test(test_file_roundtrip_and_corruption),
        cmocka_unit_test(test_cache_builds_once),
        cmocka_unit_test(test_bad_descriptions_name_the_field),
        cmocka_unit_test(test_cli_builds_a_table),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
