/*
 * Physics of `sh`'s parts:
 *  - the dipole R_d(r) (Jensen et al. 2001) against the flux of the
 *    dipole's fluence computed here by numerical differentiation, its
 *    integral over the plane against the closed-form total, and the
 *    totals against the R_d column Jensen et al. published for the
 *    presets; the sum-of-Gaussians fit reproduces the profile;
 *  - material SH tables: Lambert's is the analytic clamped cosine, every
 *    BRDF's directional albedo (√4π·m_00) stays ≤ 1, Blinn–Phong's
 *    projection matches a direct integral;
 *  - light probes: a sphere light's SH equals the stratified projection
 *    of its cap; a directional light's delta;
 *  - the renderer in a furnace-like limit: an optically thin medium under
 *    a constant environment L emits albedo·c·L per unit opacity (S = 1,
 *    isotropic phase), so `sh` matches `pathtrace` there.
 */
#include <math.h>
#include <string.h>

#include "techniques/sh/dipole.h"
#include "techniques/sh/sh.h"
#include "test_util.h"

/* Fluence of the dipole at (r, z) (z down into the medium): the real
 * source at depth z_r, the negative virtual one at height z_v. */
static double fluence(const sh_dipole_material *m, int c, double r, double z) {
    double eta = m->eta, fdr = -1.44 / (eta * eta) + 0.71 / eta + 0.668 + 0.0636 * eta;
    double A = (1 + fdr) / (1 - fdr), st = m->sigma_s_prime[c] + m->sigma_a[c];
    double ap = m->sigma_s_prime[c] / st, str = sqrt(3 * m->sigma_a[c] * st), D = 1.0 / (3 * st);
    double zr = 1.0 / st, zv = zr + 4.0 * A * D;
    double d1 = sqrt(r * r + (z - zr) * (z - zr)), d2 = sqrt(r * r + (z + zv) * (z + zv));
    return ap / (4 * M_PI * D) * (exp(-str * d1) / d1 - exp(-str * d2) / d2);
}

static void test_dipole_profile(void **state) {
    (void)state;
    for (int i = 0; i < sh_dipole_count(); i++) {
        const sh_dipole_material *m = sh_dipole_at(i);
        for (int c = 0; c < 3; c++) {
            double st = m->sigma_s_prime[c] + m->sigma_a[c], D = 1.0 / (3 * st);
            for (double r = 0.05; r < 8.0; r *= 1.7) {
                /* R_d = D·∂φ/∂z at the surface (the diffusive flux out) */
                double h = 1e-5, flux = D * (fluence(m, c, r, h) - fluence(m, c, r, -h)) / (2 * h);
                double rd = sh_dipole_rd(m, c, r);
                assert_near(rd, flux, 1e-6 + 1e-5 * fabs(flux));
            }
            /* ∫ R_d 2πr dr over [0, 200 mm] (log-spaced midpoint) = closed form */
            double total = 0.0;
            for (int k = 0; k < 20000; k++) {
                double a = 1e-6 * pow(2e8, k / 20000.0), b = 1e-6 * pow(2e8, (k + 1) / 20000.0), r = 0.5 * (a + b);
                total += sh_dipole_rd(m, c, r) * 2 * M_PI * r * (b - a);
            }
            if (m->sigma_a[c] > 0.0) assert_near(total, sh_dipole_rd_total(m, c), 2e-3);
        }
    }
}

/* The totals reproduce Jensen et al.'s R_d column (η = 1.3) to its two
 * digits — except marble and chicken1's blue, where the column differs by
 * 0.03–0.05 from the formula with the same table's σ (their rounding or
 * measurement; we keep the σ's). */
static void test_dipole_published(void **state) {
    (void)state;
    for (int i = 0; i < sh_dipole_count(); i++) {
        const sh_dipole_material *m = sh_dipole_at(i);
        if (!strcmp(m->name, "marble")) continue;
        for (int c = 0; c < 3; c++) {
            if (!strcmp(m->name, "chicken1") && c == 2) continue;
            assert_near(sh_dipole_rd_total(m, c), m->rd_published[c], 0.015);
        }
    }
    assert_null(sh_dipole_find("no such"));
    assert_non_null(sh_dipole_find("skin1"));
}

static void test_dipole_fit(void **state) {
    (void)state;
    sh_gauss_fit fit;
    /* the default setting at 256³ (neighbourhood 25.6 units, grid spacing 3,
     * 0.5 mm per unit): softened by half the grid spacing, s from 0.75 */
    for (int i = 0; i < sh_dipole_count(); i++) {
        sh_dipole_fit(sh_dipole_at(i), 0.5, 25.6, 1.5, 0.75, 12.8, &fit);
        for (int c = 0; c < 3; c++) {
            if (sh_dipole_at(i)->sigma_a[c] == 0.0) continue;
            for (int k = 0; k < SH_DIPOLE_GAUSSIANS; k++) assert_true(fit.w[c][k] >= 0.0);
            /* measured: ≤ 0.17 (ketchup blue); a single Gaussian is ≥ 0.4 off */
            if (fit.rel_error[c] > 0.2)
                fail_msg("%s channel %d: Gaussian fit error %g", sh_dipole_at(i)->name, c, fit.rel_error[c]);
        }
    }
}

/* ------------------------------------------------------------------ materials */

static void test_lambert_table(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_tf_material t;
    volux_tf_material_defaults(&t, VOLUX_MATERIAL_LAMBERT);
    t.diffuse = 0.6f;
    sh_material m;
    assert_int_equal(sh_material_prepare(ctx, &t, &m), VOLUX_OK);
    /* (kd/π)·cos⁺: zonal about the normal, independent of ω_o */
    for (int k = 0; k < SH_TABLE_THETA; k += 7)
        for (int l = 0; l < 4; l++)
            for (int mm = -l; mm <= l; mm++) {
                double expect = mm == 0 ? 0.6 / M_PI * sh_clamped_cosine_zonal(l) : 0.0;
                assert_near(m.table[k][0][l * (l + 1) + mm], expect, 2e-4);
                assert_near(m.table[k][1][l * (l + 1) + mm], 0.0, 1e-9);
            }
    sh_material_free(ctx, &m);
    volux_context_destroy(ctx);
}

static void test_brdf_albedo_bounded(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_material_kind kinds[] = {VOLUX_MATERIAL_BLINN_PHONG, VOLUX_MATERIAL_ASHIKHMIN_SHIRLEY,
                                   VOLUX_MATERIAL_COOK_TORRANCE};
    for (int i = 0; i < 3; i++) {
        volux_tf_material t;
        volux_tf_material_defaults(&t, kinds[i]);
        t.diffuse = 0.5f, t.specular = 0.5f;
        sh_material m;
        assert_int_equal(sh_material_prepare(ctx, &t, &m), VOLUX_OK);
        for (int k = 0; k < SH_TABLE_THETA - 1; k++) {
            double a = sqrt(4 * M_PI) * (m.table[k][0][0] + m.table[k][1][0]);
            /* (n+8)/(8π) normalises Blinn–Phong only approximately: ≤ 1.03 */
            if (!(a > 0.05 && a <= 1.03))
                fail_msg("%s: directional albedo %g at θ_o index %d", volux_material_kind_name(kinds[i]), a, k);
        }
        sh_material_free(ctx, &m);
    }
    volux_context_destroy(ctx);
}

/* Blinn–Phong's table equals a direct stratified projection of M(·, ω_o). */
typedef struct bp_case { const volux_tf_material *t; double wo[3]; } bp_case;
static void bp_spec(void *user, volux_vec3 d, float *v) {
    const bp_case *b = user;
    double wi[3] = {d.x, d.y, d.z}, dif, sp[3];
    sh_material_eval(b->t, NULL, wi, b->wo, &dif, sp);
    v[0] = (float)dif, v[1] = (float)sp[0];
}

static void test_blinn_phong_projection(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_tf_material t;
    volux_tf_material_defaults(&t, VOLUX_MATERIAL_BLINN_PHONG);
    t.shininess = 8.0f;
    sh_material m;
    assert_int_equal(sh_material_prepare(ctx, &t, &m), VOLUX_OK);
    int k = 10;
    double th = 0.5 * M_PI * k / (SH_TABLE_THETA - 1);
    bp_case b = {&t, {sin(th), 0, cos(th)}};
    double ref[2 * 16];
    sh_project_stratified(4, 2, 256, 512, 3, bp_spec, &b, ref);
    for (int j = 0; j < 16; j++) {
        assert_near(m.table[k][0][j], ref[j], 2e-3);
        assert_near(m.table[k][1][j], ref[16 + j], 4e-3);
    }
    sh_material_free(ctx, &m);
    volux_context_destroy(ctx);
}

/* ------------------------------------------------------------------ light probes */

typedef struct cap_case { volux_vec3 axis; float cos_half; } cap_case;
static void cap_fn(void *user, volux_vec3 d, float *v) {
    const cap_case *c = user;
    v[0] = v3_dot(d, c->axis) >= c->cos_half ? 2.0f : 0.0f;
}

static void test_sphere_light(void **state) {
    (void)state;
    volux_light_desc d;
    volux_light_desc_defaults(&d, VOLUX_LIGHT_SPHERE);
    d.position = v3(3, 4, 0);
    d.radius = 2.0f;
    d.radiance = 2.0f;
    float out[3][16];
    assert_int_equal(sh_light_project(NULL, &d, v3(0, 0, 0), out), VOLUX_OK);
    cap_case cc = {v3(0.6f, 0.8f, 0.0f), cosf(asinf(2.0f / 5.0f))};
    double ref[16];
    sh_project_stratified(4, 1, 512, 1024, 9, cap_fn, &cc, ref);
    for (int j = 0; j < 16; j++) assert_near(out[1][j], ref[j], 3e-3);
    /* directional: E·Y_j(−direction) */
    volux_light_desc dl;
    volux_light_desc_defaults(&dl, VOLUX_LIGHT_DIRECTIONAL);
    dl.direction = v3(0, -1, 0);
    dl.irradiance = 3.0f;
    assert_int_equal(sh_light_project(NULL, &dl, v3(0, 0, 0), out), VOLUX_OK);
    float y[16];
    sh_eval(4, v3(0, 1, 0), y);
    for (int j = 0; j < 16; j++) assert_near(out[0][j], 3.0f * y[j], 1e-6);
}

/* ------------------------------------------------------------------ renderer limit */

/* A thin homogeneous box (σt·size ≪ 1) in a constant white environment,
 * isotropic phase: both estimate single scattering of uniform light
 * (pathtrace adds a little multiple scattering, O(τ) smaller). */
static void test_thin_medium_matches_pathtrace(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    const char *json =
        "{\"volume\": {\"procedural\": \"sphere\", \"dims\": [24, 24, 24]},"
        " \"transfer_function\": {\"extinction\": [[0, 0.004], [255, 0.004]], \"color\": [[0, 0.8, 0.6, 0.4], [255, 0.8, 0.6, 0.4]],"
        "   \"albedo\": 0.9, \"anisotropy\": 0},"
        " \"camera\": {\"orbit\": {\"azimuth\": 20, \"elevation\": 10}, \"fov_y\": 35},"
        " \"lights\": [{\"type\": \"environment\", \"radiance\": 1.0, \"visible\": false}],"
        " \"render\": {\"width\": 24, \"height\": 24, \"spp\": 1, \"max_depth\": 8}}";
    volux_scene *s = tu_scene(ctx, json);
    volux_image a = tu_render(ctx, s, "sh");
    volux_render_settings rs = *volux_scene_render(s);
    rs.spp = 2048;
    assert_int_equal(volux_scene_set_render(s, &rs), VOLUX_OK);
    volux_image b = tu_render(ctx, s, "pathtrace");
    double sa = 0, sb = 0;
    for (size_t i = 0; i < 3 * 24 * 24; i++) sa += a.rgb[i], sb += b.rgb[i];
    /* measured: ratio 0.99; the bound allows pathtrace's multiple scattering (τ ≈ 0.1) and its noise */
    assert_true(sb > 0.0);
    assert_near(sa / sb, 1.0, 0.06);
    volux_image_free(ctx, &a);
    volux_image_free(ctx, &b);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_dipole_profile),        cmocka_unit_test(test_dipole_published),
        cmocka_unit_test(test_dipole_fit),            cmocka_unit_test(test_lambert_table),
        cmocka_unit_test(test_brdf_albedo_bounded),   cmocka_unit_test(test_blinn_phong_projection),
        cmocka_unit_test(test_sphere_light),          cmocka_unit_test(test_thin_medium_matches_pathtrace),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
