/*
 * Sampling routines against their densities (pbrt bsdfs_test/media_test
 * style): chi-square goodness of fit of samples against the integrated pdf
 * over bins, pdf normalisation, and "the pdf a sampler returns equals the
 * pdf evaluated for the same direction".
 *
 * The chi-square check is tests/support/chi2.h (bins with an expected
 * count ≥ 5, smaller ones pooled; Wilson–Hilferty p-value; fails below
 * p = 1e-4, seeded streams make a pass reproducible).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/rng.h"
#include "chi2.h"
#include "pt_util.h"
#include "sample/distribution2d.h"
#include "sample/envmap.h"
#include "sample/phase.h"

#define PI_D 3.14159265358979323846

/* ------------------------------------------------------------------ HG */

static void test_hg_sampling_matches_pdf(void **state) {
    (void)state;
    const float gs[5] = {-0.7f, -0.2f, 0.0f, 0.5f, 0.9f};
    enum { NC = 40, NP = 12, N = 400000 };
    volux_vec3 d = v3_normalize(v3(0.3f, -0.5f, 0.8f)), t, b;
    v3_basis(d, &t, &b);
    for (int gi = 0; gi < 5; gi++) {
        float g = gs[gi];
        /* normalisation and mean cosine: 2π ∫ p(μ) dμ = 1, 2π ∫ μ p dμ = g */
        double norm = 0.0, mean_cos = 0.0;
        const int M = 200000;
        for (int i = 0; i < M; i++) {
            double mu = -1.0 + (i + 0.5) * 2.0 / M;
            double p = volux_hg_eval(g, (float)mu);
            norm += 2 * PI_D * p * 2.0 / M;
            mean_cos += 2 * PI_D * mu * p * 2.0 / M;
        }
        assert_near(norm, 1.0, 1e-4);
        assert_near(mean_cos, g, 1e-4);

        static double obs[NC * NP], expct[NC * NP];
        memset(obs, 0, sizeof obs);
        for (int i = 0; i < NC; i++) {
            double a = -1.0 + 2.0 * i / NC, h = (2.0 / NC) / 1024, e = 0.0;
            for (int k = 0; k < 1024; k++) e += volux_hg_eval(g, (float)(a + (k + 0.5) * h)) * h;
            for (int j = 0; j < NP; j++) expct[i * NP + j] = e * 2 * PI_D / NP;
        }
        volux_rng rng = volux_rng_make(42, (uint64_t)gi, 0, 0);
        int mismatch = 0;
        for (int s = 0; s < N; s++) {
            float pdf;
            volux_vec3 w = volux_hg_sample(g, d, volux_rng_float(&rng), volux_rng_float(&rng), &pdf);
            assert_near(v3_length(w), 1.0, 1e-4);
            float c = v3_dot(w, d);
            if (fabsf(pdf - volux_hg_eval(g, c)) > 1e-3f * pdf) mismatch++;
            int ci = (int)((c + 1.0f) * 0.5f * NC);
            if (ci < 0) ci = 0;
            if (ci > NC - 1) ci = NC - 1;
            double phi = atan2(v3_dot(w, b), v3_dot(w, t));
            int pj = (int)((phi + PI_D) / (2 * PI_D) * NP);
            if (pj < 0) pj = 0;
            if (pj > NP - 1) pj = NP - 1;
            obs[ci * NP + pj] += 1.0;
        }
        /* float rounding of cos near ±1 may move a few pdfs by > 0.1 % */
        assert_true(mismatch < N / 1000);
        char what[64];
        snprintf(what, sizeof what, "HG g=%+.1f", g);
        chi2_check(obs, expct, NC * NP, N, what);
    }
}

/* ---------------------------------------------------------- distribution2d */

static void test_distribution2d_pdf_integrates_to_one_and_matches_samples(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    enum { NU = 7, NV = 5, N = 300000 };
    float f[NU * NV];
    volux_rng rng = volux_rng_make(7, 0, 0, 0);
    for (int i = 0; i < NU * NV; i++) f[i] = volux_rng_float(&rng) < 0.3f ? 0.0f : 10.0f * volux_rng_float(&rng);
    f[3] = -2.0f;      /* negative: counts as 0 */
    f[4] = NAN;        /* not finite: counts as 0 */
    for (int u = 0; u < NU; u++) f[2 * NU + u] = 0.0f; /* an empty row */
    volux_distribution2d d;
    memset(&d, 0, sizeof d);
    assert_int_equal(volux_distribution2d_build(ctx, f, NU, NV, &d), VOLUX_OK);
    /* ∫∫ p du dv = 1 (midpoint, 4× finer than the cells) */
    double integral = 0.0;
    for (int j = 0; j < 4 * NV; j++)
        for (int i = 0; i < 4 * NU; i++)
            integral += volux_distribution2d_pdf(&d, (i + 0.5f) / (4 * NU), (j + 0.5f) / (4 * NV)) /
                        (16.0 * NU * NV);
    assert_near(integral, 1.0, 1e-5);
    /* samples: chi-square over half-cells (tests the placement inside a cell) */
    static double obs[4 * NU * NV], expct[4 * NU * NV];
    memset(obs, 0, sizeof obs);
    for (int j = 0; j < 2 * NV; j++)
        for (int i = 0; i < 2 * NU; i++)
            expct[j * 2 * NU + i] = volux_distribution2d_pdf(&d, (i + 0.5f) / (2 * NU), (j + 0.5f) / (2 * NV)) /
                                    (4.0 * NU * NV);
    for (int s = 0; s < N; s++) {
        float uv[2];
        float pdf = volux_distribution2d_sample(&d, volux_rng_float(&rng), volux_rng_float(&rng), uv);
        assert_true(uv[0] >= 0.0f && uv[0] < 1.0f && uv[1] >= 0.0f && uv[1] < 1.0f);
        assert_true(pdf > 0.0f);
        assert_true(pdf == volux_distribution2d_pdf(&d, uv[0], uv[1]));
        int i = (int)(uv[0] * 2 * NU), j = (int)(uv[1] * 2 * NV);
        obs[j * 2 * NU + i] += 1.0;
    }
    chi2_check(obs, expct, 4 * NU * NV, N, "distribution2d 7x5");
    /* an all-zero table: no samples, pdf 0 */
    float zero[6] = {0, 0, 0, 0, 0, 0};
    assert_int_equal(volux_distribution2d_build(ctx, zero, 3, 2, &d), VOLUX_OK);
    float uv[2];
    assert_true(volux_distribution2d_sample(&d, 0.3f, 0.6f, uv) == 0.0f);
    assert_true(volux_distribution2d_pdf(&d, 0.3f, 0.6f) == 0.0f);
    volux_distribution2d_free(ctx, &d);
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

/* ---------------------------------------------------------- environment */

enum { MAP_W = 16, MAP_H = 8 };

static void make_map(volux_image *m, float *px) {
    for (int y = 0; y < MAP_H; y++)
        for (int x = 0; x < MAP_W; x++) {
            float *p = &px[3 * (y * MAP_W + x)];
            float base = 0.05f + 0.02f * (float)x; /* a gradient */
            p[0] = base, p[1] = 0.5f * base, p[2] = 0.2f * base;
        }
    for (int x = 6; x <= 9; x++) /* an empty band, one negative texel */
        for (int c = 0; c < 3; c++) px[3 * (5 * MAP_W + x) + c] = x == 7 ? -1.0f : 0.0f;
    float *spot = &px[3 * (2 * MAP_W + 11)]; /* a bright spot (a "sun") */
    spot[0] = 400.0f, spot[1] = 300.0f, spot[2] = 200.0f;
    m->width = MAP_W;
    m->height = MAP_H;
    m->rgb = px;
}

static void world_angles(volux_vec3 w, double *theta, double *phi) {
    *theta = acos(fmax(-1.0, fmin(1.0, w.y)));
    double ph = atan2(w.x, -w.z); /* the map's u measure, in world space */
    if (ph < 0) ph += 2 * PI_D;
    *phi = ph;
}

static volux_vec3 world_dir(double theta, double phi) {
    return v3((float)(sin(theta) * sin(phi)), (float)cos(theta), (float)(-sin(theta) * cos(phi)));
}

static void test_environment_sampling_matches_pdf(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    static float px[3 * MAP_W * MAP_H];
    volux_image map;
    make_map(&map, px);
    volux_light_desc l;
    volux_light_desc_defaults(&l, VOLUX_LIGHT_ENVIRONMENT);
    l.map = &map;
    l.intensity = 1.5f;
    l.color = v3(1.0f, 0.8f, 0.6f);
    l.rotation_y_deg = 67.5f; /* three texels: keeps texel edges on the bin edges below */
    volux_envmap_sampler es;
    memset(&es, 0, sizeof es);
    assert_int_equal(volux_envmap_sampler_build(ctx, &l, &es), VOLUX_OK);

    /* World-space bins: 32 in φ × 16 in θ, aligned with half texels, so
     * p(ω)·sin θ is constant in each and the midpoint rule is exact. */
    enum { BP = 32, BT = 16, SUB = 8, N = 400000 };
    static double obs[BP * BT], expct[BP * BT];
    memset(obs, 0, sizeof obs);
    double total = 0.0;
    for (int j = 0; j < BT; j++)
        for (int i = 0; i < BP; i++) {
            double e = 0.0, dth = PI_D / BT / SUB, dph = 2 * PI_D / BP / SUB;
            for (int a = 0; a < SUB; a++)
                for (int c = 0; c < SUB; c++) {
                    double th = (j + (a + 0.5) / SUB) * PI_D / BT, ph = (i + (c + 0.5) / SUB) * 2 * PI_D / BP;
                    e += volux_envmap_pdf(&es, &l, world_dir(th, ph)) * sin(th) * dth * dph;
                }
            expct[j * BP + i] = e;
            total += e;
        }
    assert_near(total, 1.0, 1e-4); /* the solid-angle pdf integrates to 1 */

    volux_rng rng = volux_rng_make(9, 0, 0, 0);
    int mismatch = 0;
    double est[3] = {0, 0, 0};
    for (int s = 0; s < N; s++) {
        volux_vec3 w;
        float pdf = volux_envmap_sample(&es, &l, volux_rng_float(&rng), volux_rng_float(&rng), &w);
        assert_true(pdf > 0.0f);
        assert_near(v3_length(w), 1.0, 1e-4);
        float pe = volux_envmap_pdf(&es, &l, w);
        if (fabsf(pe - pdf) > 1e-3f * pdf) mismatch++; /* only at texel edges, by rounding */
        double th, ph;
        world_angles(w, &th, &ph);
        int j = (int)(th / PI_D * BT), i = (int)(ph / (2 * PI_D) * BP);
        if (j > BT - 1) j = BT - 1;
        if (i > BP - 1) i = BP - 1;
        obs[j * BP + i] += 1.0;
        volux_vec3 L = volux_environment_radiance(&l, w);
        est[0] += L.x / pdf / N, est[1] += L.y / pdf / N, est[2] += L.z / pdf / N;
    }
    if (mismatch > N / 1000) fail_msg("%d of %d sampled pdfs differ from pdf(direction)", mismatch, N);
    chi2_check(obs, expct, BP * BT, N, "environment map 16x8, rotated");

    /* Importance-sampled ∫ L dω equals the quadrature of the bilinear lookup
     * (so the pdf is > 0 wherever the map is lit, with the rotation right). */
    double ref[3] = {0, 0, 0};
    const int RT = 512, RP = 1024;
    for (int j = 0; j < RT; j++)
        for (int i = 0; i < RP; i++) {
            double th = (j + 0.5) * PI_D / RT, ph = (i + 0.5) * 2 * PI_D / RP;
            volux_vec3 L = volux_environment_radiance(&l, world_dir(th, ph));
            double dw = sin(th) * (PI_D / RT) * (2 * PI_D / RP);
            ref[0] += L.x * dw, ref[1] += L.y * dw, ref[2] += L.z * dw;
        }
    for (int c = 0; c < 3; c++) {
        printf("  environment integral channel %d: sampled %.5f, quadrature %.5f\n", c, est[c], ref[c]);
        assert_near(est[c], ref[c], 0.01 * ref[c]);
    }

    /* constant environment: uniform sphere, pdf 1/(4π) */
    volux_light_desc lc;
    volux_light_desc_defaults(&lc, VOLUX_LIGHT_ENVIRONMENT);
    assert_int_equal(volux_envmap_sampler_build(ctx, &lc, &es), VOLUX_OK);
    volux_vec3 w;
    assert_near(volux_envmap_sample(&es, &lc, 0.3f, 0.7f, &w), 1.0 / (4 * PI_D), 1e-7);
    assert_near(volux_envmap_pdf(&es, &lc, w), 1.0 / (4 * PI_D), 1e-7);
    volux_envmap_sampler_free(ctx, &es);
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_hg_sampling_matches_pdf),
        cmocka_unit_test(test_distribution2d_pdf_integrates_to_one_and_matches_samples),
        cmocka_unit_test(test_environment_sampling_matches_pdf),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
