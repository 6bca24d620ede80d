/*
 * Single scattering (max_depth = 1) against numerically integrated values.
 *
 * Scene: a homogeneous slab 32 × 32 × 4 (σt = 0.5, albedo 0.8, white) seen
 * from +Z by an orthographic camera whose footprint (4 × 4) sits in the
 * middle of the slab, so every pixel has the same expected value and no
 * light path used by the estimate reaches a side face within a significant
 * transmittance.
 *
 * Directional light E (travel direction ℓ, ω_l = −ℓ towards the light):
 *     L = ∫_0^D e^{−σt t} · σs · p_HG(cos θ) · E · e^{−σt s(x(t))} dt,
 * cos θ = dot(ω_l, d) with d the view direction (HG convention of
 * sample/phase.h: g > 0 forward, so a light *behind* the slab looks
 * brighter through it), s(x) the distance from x to the box along ω_l
 * (ray–box, analytic transmittance), integrated with composite Simpson.
 * Both geometries — light from behind (forward scattering, cos θ = 0.866)
 * and from the front (backward, cos θ = −0.866) — for g ∈ {−0.5, 0, 0.5}.
 *
 * Constant environment L_e (visible), max_depth = 1: the light-sampled
 * and phase-sampled (MIS) strategies of the single scattering vertex plus
 * the unscattered camera ray:
 *     L = e^{−σt D} L_e + ∫_0^D e^{−σt t} σs ∫_{S²} p_HG(ω·d) L_e e^{−σt s(x,ω)} dω dt
 * by a midpoint rule in (t, cos, φ).
 *
 * max_depth = 1 means: at most one scattering event per path. The
 * estimator's NEE at that vertex and the continuation ray's MIS hit of an
 * area light/environment are both "single scattering"; the continuation
 * ray's next real collision ends the path. max_depth = 2 must add energy.
 *
 * Tolerances: image mean within 3 standard errors and 2 % of the integral;
 * each pixel within 5 standard errors.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "core/vecmath.h"
#include "pt_util.h"

#define SIGMA 0.5
#define ALBEDO 0.8
#define HALF_XY 16.0
#define HALF_Z 2.0
#define PI_D 3.14159265358979323846

static double hg(double g, double c) {
    double d = 1.0 + g * g - 2.0 * g * c;
    return (1.0 - g * g) / (4.0 * PI_D * d * sqrt(d));
}

/* Distance from p (inside the box) along unit w to the box boundary. */
static double exit_dist(const double p[3], const double w[3]) {
    const double half[3] = {HALF_XY, HALF_XY, HALF_Z};
    double t = INFINITY;
    for (int a = 0; a < 3; a++) {
        if (w[a] > 0) t = fmin(t, (half[a] - p[a]) / w[a]);
        else if (w[a] < 0) t = fmin(t, (-half[a] - p[a]) / w[a]);
    }
    return t;
}

static double directional_integral(double g, const double travel[3], double E) {
    double wl[3] = {-travel[0], -travel[1], -travel[2]};
    double cos_theta = -wl[2]; /* dot(ω_l, d), d = (0,0,−1) */
    const int N = 4000;        /* Simpson, even */
    double D = 2 * HALF_Z, h = D / N, sum = 0.0;
    for (int i = 0; i <= N; i++) {
        double t = i * h, p[3] = {0.0, 0.0, HALF_Z - t};
        double f = exp(-SIGMA * t) * SIGMA * ALBEDO * hg(g, cos_theta) * E * exp(-SIGMA * exit_dist(p, wl));
        sum += f * (i == 0 || i == N ? 1 : (i % 2 ? 4 : 2));
    }
    return sum * h / 3.0;
}

static double environment_integral(double g, double Le) {
    const int NT = 200, NMU = 400, NPHI = 32;
    double D = 2 * HALF_Z, sum = 0.0;
    for (int i = 0; i < NT; i++) {
        double t = (i + 0.5) * D / NT, p[3] = {0.0, 0.0, HALF_Z - t};
        double inner = 0.0;
        for (int j = 0; j < NMU; j++) {
            double mu = -1.0 + (j + 0.5) * 2.0 / NMU, s = sqrt(1 - mu * mu);
            double ph = hg(g, -mu); /* ω·d with d = (0,0,−1) */
            for (int k = 0; k < NPHI; k++) {
                double phi = (k + 0.5) * 2 * PI_D / NPHI, w[3] = {s * cos(phi), s * sin(phi), mu};
                inner += ph * Le * exp(-SIGMA * exit_dist(p, w));
            }
        }
        inner *= (2.0 / NMU) * (2 * PI_D / NPHI);
        sum += exp(-SIGMA * t) * SIGMA * ALBEDO * inner;
    }
    return exp(-SIGMA * D) * Le + sum * D / NT;
}

static volux_scene *slab_scene(volux_context *ctx, volux_volume *v, float g, int max_depth) {
    static const volux_tf_scalar_point ext[1] = {{0.0f, (float)SIGMA}};
    return pt_scene(ctx, v, ext, 1, NULL, 0, (float)ALBEDO, g, 4.0f, 8, 8, max_depth);
}

static double measure(volux_context *ctx, volux_scene *s, int spp, double expect, const char *what) {
    volux_technique *t = NULL;
    assert_int_equal(volux_technique_create(ctx, "pathtrace", s, &t), VOLUX_OK);
    pt_stats st;
    pt_accumulate(t, s, spp, &st);
    int n = st.width * st.height;
    double sum = 0.0, var_sum = 0.0;
    for (int p = 0; p < n; p++) {
        double m = st.mean[3 * p + 1], se = pt_stats_se(&st, p, 1);
        sum += m;
        var_sum += se * se;
        if (expect > 0 && fabs(m - expect) > 5.0 * se)
            fail_msg("%s: pixel %d = %.6f, expected %.6f (se %.6f)", what, p, m, expect, se);
    }
    double mean = sum / n, se = sqrt(var_sum) / n;
    printf("  %-40s integral %.6f  measured %.6f ± %.6f\n", what, expect, mean, se);
    if (expect > 0 && (fabs(mean - expect) > 3.0 * se || fabs(mean - expect) > 0.02 * expect))
        fail_msg("%s: image mean %.6f, expected %.6f (se %.6f)", what, mean, expect, se);
    pt_stats_free(&st);
    volux_technique_destroy(t);
    return mean;
}

static void test_single_scattering_directional(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_volume *v = pt_volume_constant(ctx, 33, 33, 5, 1.0f);
    const float gs[3] = {-0.5f, 0.0f, 0.5f};
    const double a = 30.0 * PI_D / 180.0;
    const double travels[2][3] = {{sin(a), 0.0, cos(a)},   /* from behind: forward scattering */
                                  {sin(a), 0.0, -cos(a)}}; /* from the front: backward */
    for (int gi = 0; gi < 3; gi++)
        for (int k = 0; k < 2; k++) {
            volux_scene *s = slab_scene(ctx, v, gs[gi], 1);
            volux_light_desc l;
            volux_light_desc_defaults(&l, VOLUX_LIGHT_DIRECTIONAL);
            l.direction = (volux_vec3){(float)travels[k][0], (float)travels[k][1], (float)travels[k][2]};
            l.irradiance = 2.0f;
            assert_int_equal(volux_scene_set_light(s, 3, &l), VOLUX_OK);
            char what[80];
            snprintf(what, sizeof what, "directional %s g=%+.1f", k ? "front" : "behind", gs[gi]);
            measure(ctx, s, 1024, directional_integral(gs[gi], travels[k], 2.0), what);
            volux_scene_destroy(s);
        }
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

static void test_single_scattering_environment_and_depth(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_volume *v = pt_volume_constant(ctx, 33, 33, 5, 1.0f);
    const float gs[2] = {-0.5f, 0.5f};
    for (int gi = 0; gi < 2; gi++) {
        volux_scene *s = slab_scene(ctx, v, gs[gi], 1);
        pt_add_constant_env(s, (volux_vec3){1, 1, 1}, 1);
        char what[80];
        snprintf(what, sizeof what, "environment g=%+.1f max_depth=1", gs[gi]);
        double one = measure(ctx, s, 1024, environment_integral(gs[gi], 1.0), what);
        volux_render_settings rs = *volux_scene_render(s);
        rs.max_depth = 2;
        assert_int_equal(volux_scene_set_render(s, &rs), VOLUX_OK);
        snprintf(what, sizeof what, "environment g=%+.1f max_depth=2", gs[gi]);
        double two = measure(ctx, s, 1024, -1.0, what);
        /* double scattering adds a clearly measurable amount */
        assert_true(two > one * 1.02);
        volux_scene_destroy(s);
    }
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

/* Point, spot and sphere lights: the image mean against
 *   (1/A) ∫_footprint ∫_0^D e^{−σt t} σs · E_light(x) dt dA,
 * E_light = p(ω·d) I/r² e^{−σt s(x,ω)} [× spot falloff] for point/spot and
 * ∫_cone p(ω·d) L e^{−σt s(x,ω)} dω for the sphere (midpoint rules). The
 * lights are outside the slab, so s(x,ω) is the distance to the slab's
 * boundary. */
enum { LT_POINT, LT_SPOT, LT_SPHERE };

static double footprint_integral(int type, const volux_light_desc *l, double g) {
    const int NA = type == LT_SPOT ? 64 : 16, NT = 160, NC = 24;
    double D = 2 * HALF_Z, sum = 0.0;
    for (int a = 0; a < NA; a++)
        for (int b = 0; b < NA; b++)
            for (int i = 0; i < NT; i++) {
                double t = (i + 0.5) * D / NT;
                double p[3] = {-2.0 + 4.0 * (a + 0.5) / NA, -2.0 + 4.0 * (b + 0.5) / NA, HALF_Z - t};
                double to[3] = {l->position.x - p[0], l->position.y - p[1], l->position.z - p[2]};
                double r = sqrt(to[0] * to[0] + to[1] * to[1] + to[2] * to[2]);
                double w[3] = {to[0] / r, to[1] / r, to[2] / r}, E = 0.0;
                if (type != LT_SPHERE) {
                    E = hg(g, -w[2]) * l->intensity / (r * r) * exp(-SIGMA * exit_dist(p, w));
                    if (type == LT_SPOT) {
                        volux_vec3 ax = v3_normalize(l->direction);
                        E *= volux_spot_falloff(l, (float)-(w[0] * ax.x + w[1] * ax.y + w[2] * ax.z));
                    }
                } else {
                    /* cone around w with cos θmax = sqrt(1 − R²/r²) */
                    double cmax = sqrt(1.0 - (double)l->radius * l->radius / (r * r));
                    volux_vec3 t1, t2;
                    v3_basis(v3((float)w[0], (float)w[1], (float)w[2]), &t1, &t2);
                    double dOmega = 2 * PI_D * (1 - cmax) / (NC * NC);
                    for (int u = 0; u < NC; u++) {
                        double ct = 1.0 - (u + 0.5) / NC * (1 - cmax), st = sqrt(1 - ct * ct);
                        for (int v = 0; v < NC; v++) {
                            double ph = (v + 0.5) * 2 * PI_D / NC;
                            double o[3];
                            for (int k = 0; k < 3; k++)
                                o[k] = ct * w[k] + st * cos(ph) * (&t1.x)[k] + st * sin(ph) * (&t2.x)[k];
                            E += hg(g, -o[2]) * l->radiance * exp(-SIGMA * exit_dist(p, o)) * dOmega;
                        }
                    }
                }
                sum += exp(-SIGMA * t) * SIGMA * ALBEDO * E * (D / NT);
            }
    return sum / (NA * NA);
}

static double image_mean(volux_context *ctx, volux_scene *s, int spp, double *se_out) {
    volux_technique *t = NULL;
    assert_int_equal(volux_technique_create(ctx, "pathtrace", s, &t), VOLUX_OK);
    pt_stats st;
    pt_accumulate(t, s, spp, &st);
    int n = st.width * st.height;
    double sum = 0.0, var_sum = 0.0;
    for (int p = 0; p < n; p++) {
        double se = pt_stats_se(&st, p, 1);
        sum += st.mean[3 * p + 1];
        var_sum += se * se;
    }
    *se_out = sqrt(var_sum) / n;
    pt_stats_free(&st);
    volux_technique_destroy(t);
    return sum / n;
}

static void test_single_scattering_point_spot_sphere(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_volume *v = pt_volume_constant(ctx, 33, 33, 5, 1.0f);
    const char *names[3] = {"point (behind)", "spot (front, partly outside the cone)", "sphere (behind, MIS)"};
    const float gs[2] = {-0.4f, 0.6f};
    for (int type = 0; type < 3; type++)
        for (int gi = 0; gi < 2; gi++) {
            volux_light_desc l;
            if (type == LT_POINT) {
                volux_light_desc_defaults(&l, VOLUX_LIGHT_POINT);
                l.position = (volux_vec3){3, 1, -9};
                l.intensity = 40.0f;
            } else if (type == LT_SPOT) {
                volux_light_desc_defaults(&l, VOLUX_LIGHT_SPOT);
                l.position = (volux_vec3){1, 0, 8};
                l.direction = (volux_vec3){-0.1f, 0.0f, -1.0f};
                l.cone_angle_deg = 12.0f;
                l.falloff_angle_deg = 6.0f;
                l.intensity = 40.0f;
            } else {
                volux_light_desc_defaults(&l, VOLUX_LIGHT_SPHERE);
                l.position = (volux_vec3){0, 3, -25};
                l.radius = 4.0f;
                l.radiance = 2.0f;
            }
            volux_scene *s = slab_scene(ctx, v, gs[gi], 1);
            assert_int_equal(volux_scene_set_light(s, 7, &l), VOLUX_OK);
            double expect = footprint_integral(type, &l, gs[gi]), se;
            double mean = image_mean(ctx, s, 1024, &se);
            printf("  %-40s g=%+.1f integral %.6f  measured %.6f ± %.6f\n", names[type], gs[gi], expect, mean, se);
            if (fabs(mean - expect) > 3.0 * se || fabs(mean - expect) > 0.02 * expect)
                fail_msg("%s g=%.1f: image mean %.6f, expected %.6f (se %.6f)", names[type], gs[gi], mean, expect, se);
            volux_scene_destroy(s);
        }
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_single_scattering_directional),
        cmocka_unit_test(test_single_scattering_environment_and_depth),
        cmocka_unit_test(test_single_scattering_point_spot_sphere),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
