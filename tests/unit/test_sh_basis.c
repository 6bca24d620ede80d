/*
 * The SH basis of `sh` (techniques/sh/shbasis.h): the polynomial forms
 * agree with the general definition, the basis is orthonormal, the zonal
 * kernels (clamped cosine, HG, cap) are the projections of their
 * functions, rotation matrices rotate projections exactly and keep
 * product integrals, Funk–Hecke convolution equals the integral, and the
 * triple-product table projects the product of two functions.
 * Integrals are midpoint quadrature in (cos θ, φ): exact enough (1e-5)
 * for the smooth integrands used here.
 */
#include <math.h>

#include "techniques/sh/shbasis.h"
#include "test_util.h"

#define NQ 400 /* quadrature: NQ × 2NQ cells */

typedef double (*sphere_fn)(const double d[3], const void *user);

/* ∫ f(ω) dω by the midpoint rule in (u = cos θ, φ). */
static double integrate(sphere_fn f, const void *user) {
    double sum = 0.0, cell = (2.0 / NQ) * (2.0 * M_PI / (2 * NQ));
    for (int i = 0; i < NQ; i++) {
        double u = -1.0 + (i + 0.5) * 2.0 / NQ, s = sqrt(1.0 - u * u);
        for (int k = 0; k < 2 * NQ; k++) {
            double phi = (k + 0.5) * 2.0 * M_PI / (2 * NQ);
            double d[3] = {s * cos(phi), s * sin(phi), u};
            sum += f(d, user);
        }
    }
    return sum * cell;
}

static float y_of(int j, const double d[3]) {
    float y[16];
    sh_eval(4, v3((float)d[0], (float)d[1], (float)d[2]), y);
    return y[j];
}

static void test_polynomials_match_definition(void **state) {
    (void)state;
    for (int t = 0; t < 50; t++) {
        double th = 0.37 + 0.06 * t, ph = 0.91 * t;
        double d[3] = {sin(th) * cos(ph), sin(th) * sin(ph), cos(th)};
        for (int l = 0; l < 4; l++)
            for (int m = -l; m <= l; m++)
                assert_near(y_of(l * (l + 1) + m, d), sh_eval_reference(l, m, d[0], d[1], d[2]), 2e-6);
    }
}

typedef struct pair { int i, j; } pair;
static double yy(const double d[3], const void *u) {
    const pair *p = u;
    return (double)y_of(p->i, d) * y_of(p->j, d);
}

static void test_orthonormal(void **state) {
    (void)state;
    for (int i = 0; i < 16; i++)
        for (int j = i; j < 16; j++) {
            pair p = {i, j};
            assert_near(integrate(yy, &p), i == j ? 1.0 : 0.0, 1e-4);
        }
}

static void clamped_cos(void *user, volux_vec3 d, float *v) { (void)user, v[0] = d.z > 0 ? d.z : 0.0f; }

static void test_clamped_cosine_zonal(void **state) {
    (void)state;
    /* analytic: √π/2, √(π/3), √(5π)/8, 0 (Ramamoorthi & Hanrahan 2001) */
    const double expect[4] = {sqrt(M_PI) / 2.0, sqrt(M_PI / 3.0), sqrt(5.0 * M_PI) / 8.0, 0.0};
    double c[16];
    sh_project_stratified(4, 1, 256, 512, 7, clamped_cos, NULL, c);
    for (int l = 0; l < 4; l++) {
        assert_near(sh_clamped_cosine_zonal(l), expect[l], 1e-12);
        for (int m = -l; m <= l; m++) assert_near(c[l * (l + 1) + m], m == 0 ? expect[l] : 0.0, 2e-4);
    }
    assert_near(sh_clamped_cosine_zonal(4), -sqrt(9.0 / (4 * M_PI)) * M_PI / 24.0, 1e-12);
}

typedef struct zonal_case { int l; double g, half; } zonal_case;
static double hg_times_p(const double d[3], const void *u) {
    const zonal_case *z = u;
    double g = z->g, p = (1 - g * g) / (4 * M_PI * pow(1 + g * g - 2 * g * d[2], 1.5));
    return p * sh_eval_reference(z->l, 0, d[0], d[1], d[2]);
}
static double cap_times_p(const double d[3], const void *u) {
    const zonal_case *z = u;
    return d[2] >= cos(z->half) ? sh_eval_reference(z->l, 0, d[0], d[1], d[2]) : 0.0;
}

static void test_hg_and_cap_zonal(void **state) {
    (void)state;
    for (int l = 0; l < 4; l++) {
        zonal_case z = {l, 0.5, 0.0};
        assert_near(sh_hg_zonal(l, 0.5), integrate(hg_times_p, &z), 1e-4);
        zonal_case c = {l, 0.0, 0.6};
        /* the cap's edge is a discontinuity: midpoint error ~1/NQ */
        assert_near(sh_cap_zonal(l, 0.6), integrate(cap_times_p, &c), 5e-3);
    }
}

/* A smooth, asymmetric test function and its rotated copy. */
static double smooth(const double d[3]) { return exp(0.8 * d[0] - 0.5 * d[1] + 0.3 * d[2]) + d[0] * d[1] * d[2]; }
typedef struct rot_case { const double *r; int j; } rot_case;
static double rotated_times_y(const double d[3], const void *u) {
    const rot_case *rc = u;
    const double *r = rc->r; /* f'(ω) = f(R⁻¹ω) = f(Rᵀω) */
    double q[3] = {r[0] * d[0] + r[3] * d[1] + r[6] * d[2], r[1] * d[0] + r[4] * d[1] + r[7] * d[2],
                   r[2] * d[0] + r[5] * d[1] + r[8] * d[2]};
    return smooth(q) * y_of(rc->j, d);
}
static double plain_times_y(const double d[3], const void *u) { return smooth(d) * y_of(*(const int *)u, d); }

static void rotation_matrix(double a, double b, double c, double r[9]) {
    /* R = Rz(c)·Ry(b)·Rz(a), a general rotation */
    double ca = cos(a), sa = sin(a), cb = cos(b), sb = sin(b), cc = cos(c), sc = sin(c);
    double rz1[9] = {ca, -sa, 0, sa, ca, 0, 0, 0, 1}, ry[9] = {cb, 0, sb, 0, 1, 0, -sb, 0, cb},
           rz2[9] = {cc, -sc, 0, sc, cc, 0, 0, 0, 1}, t[9];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            t[3 * i + j] = 0;
            for (int k = 0; k < 3; k++) t[3 * i + j] += ry[3 * i + k] * rz1[3 * k + j];
        }
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            r[3 * i + j] = 0;
            for (int k = 0; k < 3; k++) r[3 * i + j] += rz2[3 * i + k] * t[3 * k + j];
        }
}

static void test_rotation_rotates_projections(void **state) {
    (void)state;
    double r[9];
    rotation_matrix(0.7, 1.1, -2.3, r);
    sh_rotation rot;
    sh_rotation_from_matrix(r, 4, &rot);
    /* each band's matrix is orthogonal */
    for (int l = 0; l < 4; l++) {
        int n = 2 * l + 1;
        for (int i = 0; i < n; i++)
            for (int j = 0; j < n; j++) {
                double s = 0;
                for (int k = 0; k < n; k++) s += rot.band[l][i * n + k] * rot.band[l][j * n + k];
                assert_near(s, i == j ? 1.0 : 0.0, 1e-9);
            }
    }
    float c[16], rc[16];
    for (int j = 0; j < 16; j++) c[j] = (float)integrate(plain_times_y, &j);
    sh_rotate(&rot, c, rc);
    for (int j = 0; j < 16; j++) {
        rot_case k = {r, j};
        assert_near(rc[j], integrate(rotated_times_y, &k), 2e-4);
    }
}

static void test_rotation_keeps_product(void **state) {
    (void)state;
    double r[9];
    rotation_matrix(-0.4, 2.0, 0.9, r);
    sh_rotation rot;
    sh_rotation_from_matrix(r, 4, &rot);
    float a[16], b[16], ra[16], rb[16];
    for (int j = 0; j < 16; j++) a[j] = sinf(1.3f * j + 0.2f), b[j] = cosf(0.7f * j * j);
    sh_rotate(&rot, a, ra);
    sh_rotate(&rot, b, rb);
    assert_near(sh_dot(4, ra, rb), sh_dot(4, a, b), 1e-5);
    /* rotating back is the inverse (the transpose) */
    double rt[9] = {r[0], r[3], r[6], r[1], r[4], r[7], r[2], r[5], r[8]};
    sh_rotation back;
    sh_rotation_from_matrix(rt, 4, &back);
    sh_rotate(&back, ra, ra);
    for (int j = 0; j < 16; j++) assert_near(ra[j], a[j], 1e-5);
}

/* sh_rotation_y turns directions the way the environment map's rotation_y
 * does (volux_environment_direction). */
static void test_rotation_y_convention(void **state) {
    (void)state;
    double r[9];
    sh_rotation_y(0.5, r);
    volux_light_desc d;
    volux_light_desc_defaults(&d, VOLUX_LIGHT_ENVIRONMENT);
    volux_vec3 a = volux_environment_direction(&d, 0.3f, 0.4f);
    d.rotation_y_deg = (float)(0.5 * 180.0 / M_PI);
    volux_vec3 b = volux_environment_direction(&d, 0.3f, 0.4f);
    assert_near(b.x, r[0] * a.x + r[1] * a.y + r[2] * a.z, 1e-5);
    assert_near(b.y, r[3] * a.x + r[4] * a.y + r[5] * a.z, 1e-5);
    assert_near(b.z, r[6] * a.x + r[7] * a.y + r[8] * a.z, 1e-5);
}

/* ∫ p_HG(ω·a) f(ω) dω = Σ √(4π/(2l+1)) k_l c_lm Y_lm(a) for band-limited f. */
typedef struct fh_case { volux_vec3 a; const float *c; double g; } fh_case;
static double hg_times_f(const double d[3], const void *u) {
    const fh_case *k = u;
    double cs = d[0] * k->a.x + d[1] * k->a.y + d[2] * k->a.z, g = k->g;
    double p = (1 - g * g) / (4 * M_PI * pow(1 + g * g - 2 * g * cs, 1.5));
    double f = 0.0;
    for (int j = 0; j < 16; j++) f += k->c[j] * y_of(j, d);
    return p * f;
}

static void test_funk_hecke(void **state) {
    (void)state;
    float c[16];
    for (int j = 0; j < 16; j++) c[j] = 0.3f * sinf(2.1f * j + 0.5f);
    c[0] = 2.0f;
    double k[4];
    for (int l = 0; l < 4; l++) k[l] = sh_hg_zonal(l, 0.4);
    volux_vec3 a = v3_normalize(v3(0.3f, -0.5f, 0.8f));
    fh_case fc = {a, c, 0.4};
    assert_near(sh_zonal_apply(4, k, c, a), integrate(hg_times_f, &fc), 1e-4);
    /* sh_zonal_add projects the rotated kernel: its product with c is the same */
    float kc[16] = {0};
    sh_zonal_add(4, k, a, 1.0f, kc);
    assert_near(sh_dot(4, kc, c), integrate(hg_times_f, &fc), 1e-4);
}

typedef struct triple_case {
    const float *f, *g;
    int k;
} triple_case;

static double fgy(const double d[3], const void *user) {
    const triple_case *t = user;
    double f = 0.0, g = 0.0;
    for (int j = 0; j < 16; j++) f += t->f[j] * y_of(j, d), g += t->g[j] * y_of(j, d);
    return f * g * y_of(t->k, d);
}

/* (f·g)_k = Σ Γ_ijk f_i g_j is ∫ f g Y_k for band-limited f, g (the
 * product has bands up to 6; its projection onto 0…3 is what the table
 * gives). Γ_0jk = δ_jk/√(4π); a wrong sign or a missing entry in any band
 * moves some k. */
static void test_triple_product(void **state) {
    (void)state;
    static sh_triple t;
    sh_triple_init(&t);
    assert_true(t.n > 16 && t.n < 4096);
    float f[16], g[16], out[16];
    for (int j = 0; j < 16; j++) f[j] = 0.4f * sinf(1.3f * j + 0.2f), g[j] = 0.5f * cosf(0.7f * j - 0.4f);
    f[0] = 1.5f;
    sh_triple_product(&t, f, g, out);
    for (int k = 0; k < 16; k++) {
        triple_case tc = {f, g, k};
        assert_near(out[k], integrate(fgy, &tc), 2e-4);
    }
    float one[16] = {3.5449077f}; /* the constant 1 */
    sh_triple_product(&t, one, g, out);
    for (int k = 0; k < 16; k++) assert_near(out[k], g[k], 1e-5);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_triple_product),
        cmocka_unit_test(test_polynomials_match_definition), cmocka_unit_test(test_orthonormal),
        cmocka_unit_test(test_clamped_cosine_zonal),          cmocka_unit_test(test_hg_and_cap_zonal),
        cmocka_unit_test(test_rotation_rotates_projections),   cmocka_unit_test(test_rotation_keeps_product),
        cmocka_unit_test(test_rotation_y_convention),          cmocka_unit_test(test_funk_hecke),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
