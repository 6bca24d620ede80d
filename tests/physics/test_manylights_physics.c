/*
 * manylights: the math of its pieces against closed forms.
 *
 *   1. τ1 codes (IEEE half bits) round-trip within half precision and keep
 *      order;
 *   2. the mean of 1/|x − y|² over a VSL's ball (closed form) equals its
 *      numerical integral from ray–sphere chord lengths, inside and
 *      outside, and tends to 1/d²; the `ball` kernel's one-point estimate
 *      (cone direction, chord distance) has that mean and stays inside the
 *      ball; the `cone` kernel (Eq. 5) tends to 1/d² too;
 *   3. AVSMs in a homogeneous box reproduce exp(−σd) (the compressed
 *      polyline within a bound that shrinks with the node count) and a
 *      slab's step exactly away from the step; the ray-marched reference is
 *      exact there;
 *   4. virtual-light weights are unbiased: the first-collision weights of a
 *      light's subpaths sum to the flux the medium intercepts, known in
 *      closed form for a thick or homogeneous box — for directional, point,
 *      environment and (as a far point) sphere lights, for placement by the
 *      current density and by the Eq. 8 mixture at densities inside and
 *      outside [S_min, S_max], and after an extinction edit re-weights the
 *      old subpaths by Eq. 6;
 *   5. Russian roulette only changes the variance: second-collision weights
 *      agree for survival 1 and 0.5.
 * Tolerances are stated per check (4 standard errors of the per-path
 * estimate for the Monte-Carlo ones).
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "pt_util.h"
#include "render/technique_class.h"
#include "techniques/manylights/avsm.h"

#define PI 3.14159265358979323846

/* ------------------------------------------------------------------ 1. codes */

static void test_tau_codes(void **state) {
    (void)state;
    assert_int_equal(ml_tau_code(0.0f), 0);
    assert_int_equal(ml_tau_code(-1.0f), 0);
    float prev = -1.0f;
    for (float tau = 1e-7f; tau < 60000.0f; tau *= 1.013f) {
        uint16_t c = ml_tau_code(tau);
        float back = ml_tau_decode(c);
        /* half precision: 11 significant bits (normals), 2^-24 absolute (subnormals) */
        if (fabsf(back - tau) > fmaxf(tau * 4.9e-4f, 3.0e-8f)) fail_msg("tau %g -> code %u -> %g", tau, c, back);
        assert_true(back >= prev);
        prev = back;
    }
    assert_true(ml_tau_code(1e9f) < ML_TAU_CODES);
    float table[ML_TAU_CODES];
    ml_decode_fill(table, 0.5f);
    assert_near(table[ml_tau_code(2.0f)], exp(-1.0), 1e-6);
}

/* ------------------------------------------------------------------ 2. kernels */

/* Mean of 1/|x−y|² over the ball (radius r, centre at distance d from x):
 * (1/V)∫dΩ L(ω), L the length of the ray from x inside the ball, by the
 * midpoint rule in cos θ (θ from the direction towards the centre). */
static double ball_mean_numeric(double d, double r) {
    const int n = 200000;
    double sum = 0.0;
    for (int i = 0; i < n; i++) {
        double u = -1.0 + (i + 0.5) * 2.0 / n; /* cos θ */
        /* ray x + t·w, |x − c| = d, w·(c − x)/d = u: |x + t w − c|² = r² */
        double b = -d * u, cc = d * d - r * r, disc = b * b - cc;
        if (disc < 0.0) continue;
        double s = sqrt(disc), t0 = -b - s, t1 = -b + s;
        if (t1 <= 0.0) continue;
        if (t0 < 0.0) t0 = 0.0;
        sum += (t1 - t0) * 2.0 / n;
    }
    return 2.0 * PI * sum / (4.0 / 3.0 * PI * r * r * r);
}

static void test_vsl_kernels(void **state) {
    (void)state;
    const float r = 2.0f;
    const float ds[] = {0.01f, 0.5f, 1.0f, 1.9f, 2.0f, 2.1f, 3.0f, 5.9f, 6.1f, 10.0f, 40.0f};
    for (size_t i = 0; i < sizeof ds / sizeof ds[0]; i++) {
        double num = ball_mean_numeric(ds[i], r), got = ml_ball_geometry(ds[i], r);
        if (fabs(got - num) > 2e-3 * num) fail_msg("ball kernel at d = %g: %g, numeric %g", ds[i], got, num);
    }
    assert_near(ml_ball_geometry(1e-9f, r), 3.0 / (r * r), 1e-6);
    /* the ball kernel's one-sample estimate (direction in the cone, distance
     * along the chord) has that mean: midpoint rule over (u, w) */
    for (size_t i = 0; i < sizeof ds / sizeof ds[0]; i++) {
        const int n = 2000;
        double sum = 0.0;
        for (int a = 0; a < n; a++) {
            float ct, sdist;
            float wgt = ml_vsl_ball(ds[i], r, ((float)a + 0.5f) / (float)n, 0.5f, &ct, &sdist);
            sum += wgt;
            /* y = x + s·ω lies in the ball: |y − c|² ≤ r² */
            float yc2 = ds[i] * ds[i] - 2.0f * ds[i] * sdist * ct + sdist * sdist;
            if (yc2 > r * r * 1.0001f + 1e-5f) fail_msg("ball sample outside the ball (d %g)", ds[i]);
        }
        double mean = sum / n, want = ml_ball_geometry(ds[i], r);
        if (fabs(mean - want) > 2e-3 * want) fail_msg("ball estimate at d = %g: mean %g, expected %g", ds[i], mean, want);
    }
    assert_near(ml_ball_geometry(1000.0f, r) * 1e6, 1.0, 1e-5);
    /* Eq. 5 with the cone pdf: 2(1 − cos θmax)/r² → 1/d² */
    float d = 200.0f, sin2 = r * r / (d * d), omc = sin2 / (1.0f + sqrtf(1.0f - sin2));
    assert_near(2.0f * omc / (r * r) * d * d, 1.0, 1e-4);
}

/* ------------------------------------------------------------------ scenes */

static volux_scene *box_scene(volux_context *ctx, volux_volume *v, float sigma, float density, int max_depth) {
    volux_tf_scalar_point ext[1] = {{0.0f, sigma}};
    volux_scene *s = pt_scene(ctx, v, ext, 1, NULL, 0, 1.0f, 0.0f, 10.0f, 8, 8, max_depth);
    volux_transfer_desc tf = *volux_scene_transfer(s);
    tf.density_scale = density;
    assert_int_equal(volux_scene_set_transfer(s, &tf), VOLUX_OK);
    assert_int_equal(volux_scene_set_param(s, "manylights", "avsm_resolution", 1, NULL), VOLUX_OK);
    assert_int_equal(volux_scene_set_param(s, "manylights", "avsm_nodes", 2, NULL), VOLUX_OK);
    return s;
}

static void set_placement(volux_scene *s, float smin, float smax) {
    assert_int_equal(volux_scene_set_param(s, "manylights", "density_min", smin, NULL), VOLUX_OK);
    assert_int_equal(volux_scene_set_param(s, "manylights", "density_max", smax, NULL), VOLUX_OK);
}

/* Σ over subpaths of the green weight of their depth-k vertex, per path:
 * mean and its standard error (paths without one count as 0). */
static void depth_sum(const ml_state *st, int depth, double *mean, double *se) {
    double sum = 0.0, sq = 0.0;
    long paths = 0;
    for (int slot = 0; slot < st->sets_cap; slot++) {
        const ml_set *set = &st->sets[slot];
        if (!set->active) continue;
        paths += set->paths;
        for (int i = 0; i < set->cur.n; i++) {
            const ml_vl *v = &set->cur.v[i];
            if (v->depth != depth) continue;
            double x = v->I.y / v->inv_paths; /* the path's own estimate */
            sum += x;
            sq += x * x;
        }
    }
    assert_true(paths > 1);
    *mean = sum / paths;
    double var = (sq / paths - *mean * *mean) * paths / (paths - 1.0);
    *se = sqrt(var > 0.0 ? var / paths : 0.0);
}

static void expect_flux(volux_context *ctx, volux_scene *s, double expected, double rel_floor, const char *what) {
    volux_technique *t = NULL;
    if (volux_technique_create(ctx, "manylights", s, &t)) fail_msg("%s: %s", what, volux_context_error(ctx));
    double mean, se;
    depth_sum(volux_technique_state(t), 1, &mean, &se);
    printf("  %-44s %.5g (expected %.5g, se %.2g)\n", what, mean, expected, se);
    if (fabs(mean - expected) > 4.0 * se + rel_floor * expected)
        fail_msg("%s: first-collision flux %g, expected %g (se %g)", what, mean, expected, se);
    volux_technique_destroy(t);
}

static void add_light(volux_scene *s, int slot, const volux_light_desc *l) {
    assert_int_equal(volux_scene_set_light(s, slot, l), VOLUX_OK);
}

/* ------------------------------------------------------------------ 4. weights */

static void test_directional_flux_placements(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    volux_volume *v = pt_volume_constant(ctx, 8, 8, 8, 1.0f); /* a 7³ box */
    const double a = 7.0, E = 2.0, sigma = 0.2;
    struct {
        float density, smin, smax;
        const char *what;
    } cases[] = {
        {1.0f, 0.0f, 0.0f, "placement by the density in use"},
        {1.0f, 0.5f, 2.0f, "Eq. 8 mixture, density inside"},
        {3.0f, 0.5f, 2.0f, "Eq. 8 mixture, density above S_max"},
        {0.3f, 0.5f, 2.0f, "Eq. 8 mixture, density below S_min"},
        {1.0f, 1.5f, 1.5f, "one fixed scale, not the one in use"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        volux_scene *s = box_scene(ctx, v, (float)sigma, cases[i].density, 2);
        set_placement(s, cases[i].smin, cases[i].smax);
        assert_int_equal(volux_scene_set_param(s, "manylights", "vl_count", 12000, NULL), VOLUX_OK);
        volux_light_desc l;
        volux_light_desc_defaults(&l, VOLUX_LIGHT_DIRECTIONAL);
        l.direction = (volux_vec3){0, 0, -1};
        l.irradiance = (float)E;
        add_light(s, 0, &l);
        /* every ray crosses the full depth a: E·a²·(1 − e^{−ξσa}) */
        double expected = E * a * a * (1.0 - exp(-cases[i].density * sigma * a));
        expect_flux(ctx, s, expected, 0.002, cases[i].what);
        volux_scene_destroy(s);
    }
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

static void test_light_types_flux(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    volux_volume *v = pt_volume_constant(ctx, 8, 8, 8, 1.0f);
    const double a = 7.0, sigma = 400.0; /* optically thick: a ray that enters collides within 1/400 */
    {
        /* point light on the +z axis: the +z face subtends
         * Ω = 4·asin(p²/(p² + D²)), p = a/2, D its distance to the face */
        volux_scene *s = box_scene(ctx, v, (float)sigma, 1.0f, 2);
        assert_int_equal(volux_scene_set_param(s, "manylights", "vl_count", 8000, NULL), VOLUX_OK);
        volux_light_desc l;
        volux_light_desc_defaults(&l, VOLUX_LIGHT_POINT);
        double D = 6.0, p = a / 2;
        l.position = (volux_vec3){0, 0, (float)(p + D)};
        l.intensity = 30.0f;
        add_light(s, 0, &l);
        expect_flux(ctx, s, 30.0 * 4.0 * asin(p * p / (p * p + D * D)), 0.002, "point light, thick box");
        /* the same as a spot whose cone holds the face */
        volux_light_desc_defaults(&l, VOLUX_LIGHT_SPOT);
        l.position = (volux_vec3){0, 0, (float)(p + D)};
        l.direction = (volux_vec3){0, 0, -1};
        l.intensity = 30.0f;
        l.cone_angle_deg = 60.0f;
        l.falloff_angle_deg = 50.0f;
        add_light(s, 0, &l);
        expect_flux(ctx, s, 30.0 * 4.0 * asin(p * p / (p * p + D * D)), 0.002, "spot light holding the face");
        /* a small sphere far away = a point of intensity L·π·r² */
        volux_light_desc_defaults(&l, VOLUX_LIGHT_SPHERE);
        double far = 60.0;
        l.position = (volux_vec3){0, 0, (float)(p + far)};
        l.radius = 0.5f;
        l.radiance = 20.0f;
        add_light(s, 0, &l);
        assert_int_equal(volux_scene_set_param(s, "manylights", "vl_count", 3000, NULL), VOLUX_OK);
        double I = 20.0 * PI * 0.25;
        expect_flux(ctx, s, I * 4.0 * asin(p * p / (p * p + far * far)), 0.01, "small far sphere light");
        volux_scene_destroy(s);
    }
    {
        /* constant environment L around a thick convex body: L·π·S
         * (Cauchy: the mean projected area of a convex body is S/4) */
        volux_scene *s = box_scene(ctx, v, (float)sigma, 1.0f, 2);
        assert_int_equal(volux_scene_set_param(s, "manylights", "vl_count", 12000, NULL), VOLUX_OK);
        pt_add_constant_env(s, (volux_vec3){0.7f, 0.7f, 0.7f}, 0);
        expect_flux(ctx, s, 0.7 * PI * 6.0 * a * a, 0.002, "constant environment, thick box");
        volux_scene_destroy(s);
    }
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

/* Eq. 6: the subpaths stay, their weights follow the new extinction. */
static void test_eq6_reweighting(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    volux_volume *v = pt_volume_constant(ctx, 8, 8, 8, 1.0f);
    const double a = 7.0, E = 1.5;
    volux_scene *s = box_scene(ctx, v, 0.3f, 1.0f, 2);
    set_placement(s, 0.0f, 0.0f);
    assert_int_equal(volux_scene_set_param(s, "manylights", "vl_count", 12000, NULL), VOLUX_OK);
    volux_light_desc l;
    volux_light_desc_defaults(&l, VOLUX_LIGHT_DIRECTIONAL);
    l.direction = (volux_vec3){0, 0, -1};
    l.irradiance = (float)E;
    add_light(s, 0, &l);
    volux_technique *t = NULL;
    assert_int_equal(volux_technique_create(ctx, "manylights", s, &t), VOLUX_OK);
    /* thinner medium: the old (denser) sampling density covers it */
    volux_tf_scalar_point ext[1] = {{0.0f, 0.12f}};
    volux_transfer_desc tf = *volux_scene_transfer(s);
    tf.opacity = ext;
    assert_int_equal(volux_scene_set_transfer(s, &tf), VOLUX_OK);
    assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_OK);
    assert_true(volux_technique_pending(t) > 0); /* the replacement is still to come */
    double mean, se, expected = E * a * a * (1.0 - exp(-0.12 * a));
    depth_sum(volux_technique_state(t), 1, &mean, &se);
    printf("  %-44s %.5g (expected %.5g, se %.2g)\n", "Eq. 6 after sigma 0.3 -> 0.12", mean, expected, se);
    if (fabs(mean - expected) > 4.0 * se + 0.002 * expected)
        fail_msg("Eq. 6 weights: %g, expected %g (se %g)", mean, expected, se);
    volux_technique_destroy(t);
    volux_scene_destroy(s);
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

/* ------------------------------------------------------------------ 5. roulette */

static void test_roulette_unbiased(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    volux_volume *v = pt_volume_constant(ctx, 8, 8, 8, 1.0f);
    double m[2], se[2];
    const float survival[2] = {1.0f, 0.5f};
    for (int k = 0; k < 2; k++) {
        volux_scene *s = box_scene(ctx, v, 0.3f, 1.0f, 3);
        assert_int_equal(volux_scene_set_param(s, "manylights", "vl_count", 16000, NULL), VOLUX_OK);
        assert_int_equal(volux_scene_set_param(s, "manylights", "rr_survival", survival[k], NULL), VOLUX_OK);
        volux_light_desc l;
        volux_light_desc_defaults(&l, VOLUX_LIGHT_DIRECTIONAL);
        l.direction = (volux_vec3){0.3f, -0.2f, -1};
        add_light(s, 0, &l);
        volux_technique *t = NULL;
        assert_int_equal(volux_technique_create(ctx, "manylights", s, &t), VOLUX_OK);
        depth_sum(volux_technique_state(t), 2, &m[k], &se[k]);
        printf("  second-collision flux, survival %.1f: %.5g (se %.2g)\n", survival[k], m[k], se[k]);
        volux_technique_destroy(t);
        volux_scene_destroy(s);
    }
    double tol = 4.0 * sqrt(se[0] * se[0] + se[1] * se[1]);
    if (fabs(m[0] - m[1]) > tol) fail_msg("roulette changed the expected weight: %g vs %g (tol %g)", m[0], m[1], tol);
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

/* ------------------------------------------------------------------ 3. AVSMs */

/* The VL nearest to the volume's centre (the world origin). */
static const ml_vl *central_vl(const ml_state *st, const ml_set **set_out) {
    const ml_vl *best = NULL;
    for (int slot = 0; slot < st->sets_cap; slot++)
        for (int i = 0; st->sets[slot].active && i < st->sets[slot].cur.n; i++) {
            const ml_vl *v = &st->sets[slot].cur.v[i];
            if (!best || v3_dot(v->pos, v->pos) < v3_dot(best->pos, best->pos)) {
                best = v;
                *set_out = &st->sets[slot];
            }
        }
    if (!best) fail_msg("no virtual light");
    return best;
}

/* Max |AVSM − exp(−σd)| over directions and depths from one VL, over the
 * first half of each ray (where the texel's ray has not left the box
 * either, so only the compression is measured). */
static double avsm_error(const ml_state *st, const ml_vl *vl, const uint32_t *avsm, double sigma, int trilinear,
                         double *rm_err) {
    double worst = 0.0, worst_rm = 0.0;
    volux_rng rng = volux_rng_make(5, 6, 7, 8);
    for (int k = 0; k < 4000; k++) {
        volux_vec3 w = v3_normalize(v3(volux_rng_float(&rng) - 0.5f, volux_rng_float(&rng) - 0.5f,
                                       volux_rng_float(&rng) - 0.5f));
        volux_ray ray;
        if (!volux_ray_clip(st->rc.volume, vl->pos, w, &ray)) continue;
        float dist = 0.5f * volux_rng_float(&rng) * ray.t1;
        volux_vec3 vv = v3_scale(w, dist);
        double exact = exp(-sigma * dist);
        double got = trilinear ? ml_avsm_trilinear(st, avsm, vv, dist) : ml_avsm_point(st, avsm, vv, dist);
        double rm = ml_raymarch_T(st, vl->pos, vv, dist);
        worst = fmax(worst, fabs(got - exact));
        worst_rm = fmax(worst_rm, fabs(rm - exact));
    }
    *rm_err = worst_rm;
    return worst;
}

static void test_avsm_homogeneous(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_volume *v = pt_volume_constant(ctx, 17, 17, 17, 1.0f);
    const double sigma = 0.25;
    const int nodes[3] = {4, 8, 32};
    double err[3];
    for (int i = 0; i < 3; i++) {
        volux_scene *s = box_scene(ctx, v, (float)sigma, 1.0f, 2);
        assert_int_equal(volux_scene_set_param(s, "manylights", "vl_count", 300, NULL), VOLUX_OK);
        assert_int_equal(volux_scene_set_param(s, "manylights", "avsm_resolution", 8, NULL), VOLUX_OK);
        assert_int_equal(volux_scene_set_param(s, "manylights", "avsm_nodes", nodes[i], NULL), VOLUX_OK);
        assert_int_equal(volux_scene_set_param(s, "manylights", "shadow_step", 0.25, NULL), VOLUX_OK);
        /* the compression of a finely sampled curve (footprint steps would
         * give the compressor fewer points to choose from) */
        assert_int_equal(volux_scene_set_param(s, "manylights", "avsm_cone", 0, NULL), VOLUX_OK);
        pt_add_constant_env(s, (volux_vec3){1, 1, 1}, 0);
        volux_technique *t = NULL;
        assert_int_equal(volux_technique_create(ctx, "manylights", s, &t), VOLUX_OK);
        const ml_state *st = volux_technique_state(t);
        const ml_set *set;
        const ml_vl *vl = central_vl(st, &set);
        const uint32_t *avsm = set->pool + (size_t)vl->slot * st->layout.stride;
        double rm;
        err[i] = avsm_error(st, vl, avsm, sigma, 0, &rm);
        double err_tri = avsm_error(st, vl, avsm, sigma, 1, &rm);
        printf("  homogeneous, %2d nodes: max |T - exp(-sigma d)| point %.4f, trilinear %.4f, raymarch %.2g\n",
               nodes[i], err[i], err_tri, rm);
        assert_true(err_tri < err[i] + 0.005); /* blending neighbours does not make it worse */
        assert_true(rm < 2e-5);                 /* midpoint rule is exact for constant σ */
        volux_technique_destroy(t);
        volux_scene_destroy(s);
    }
    /* greedy area-based compression of e^{−σd} (measured 0.062, 0.0105,
     * 0.0007 at 4, 8, 32 nodes; bounds with margin) */
    assert_true(err[0] < 0.08);
    assert_true(err[1] < 0.015);
    assert_true(err[2] < 0.0015);
    assert_true(err[2] < err[1] && err[1] < err[0]);
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

/* A thin dense slab in an empty box: T is 1 before it, e^{−τ} after it. */
static float slab_fn(int i, int j, int k, void *u) {
    (void)i, (void)j, (void)u;
    return k >= 12 && k <= 13 ? 1.0f : 0.0f;
}

static void test_avsm_slab(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_volume *v = pt_volume_fn(ctx, 17, 17, 17, slab_fn, NULL);
    volux_tf_scalar_point ext[2] = {{0.0f, 0.0f}, {1.0f, 0.8f}};
    volux_scene *s = pt_scene(ctx, v, ext, 2, NULL, 0, 1.0f, 0.0f, 10.0f, 8, 8, 2);
    assert_int_equal(volux_scene_set_param(s, "manylights", "avsm_resolution", 16, NULL), VOLUX_OK);
    assert_int_equal(volux_scene_set_param(s, "manylights", "avsm_nodes", 4, NULL), VOLUX_OK);
    volux_technique *t = NULL;
    volux_light_desc l;
    volux_light_desc_defaults(&l, VOLUX_LIGHT_DIRECTIONAL);
    l.direction = (volux_vec3){0, 0, 1};
    assert_int_equal(volux_scene_set_light(s, 0, &l), VOLUX_OK);
    assert_int_equal(volux_scene_set_param(s, "manylights", "vl_count", 4, NULL), VOLUX_OK);
    assert_int_equal(volux_technique_create(ctx, "manylights", s, &t), VOLUX_OK);
    const ml_state *st = volux_technique_state(t);
    const ml_set *set;
    const ml_vl *vl = central_vl(st, &set);
    const uint32_t *avsm = set->pool + (size_t)vl->slot * st->layout.stride;
    /* towards −z from a VL inside the slab region: compare with the march
     * far from the slab's edges (the polyline only bends at the edges) */
    for (int k = 0; k < 200; k++) {
        volux_vec3 w = v3_normalize(v3(0.05f * sinf((float)k), 0.05f * cosf((float)k), -1.0f));
        volux_ray ray;
        assert_true(volux_ray_clip(st->rc.volume, vl->pos, w, &ray));
        float dist = ray.t1 * (0.3f + 0.7f * (float)k / 200.0f);
        volux_vec3 vv = v3_scale(w, dist);
        float rm = ml_raymarch_T(st, vl->pos, vv, dist), got = ml_avsm_point(st, avsm, vv, dist);
        /* a ray of the texel differs from vv by ≤ half a texel (0.06 rad at
         * 16²): the slab's optical depth changes by a few percent */
        if (fabsf(got - rm) > 0.02f + 0.05f * (1.0f - rm)) fail_msg("slab: AVSM %g, raymarch %g at %g", got, rm, dist);
    }
    volux_technique_destroy(t);
    volux_scene_destroy(s);
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_tau_codes),
        cmocka_unit_test(test_vsl_kernels),
        cmocka_unit_test(test_avsm_homogeneous),
        cmocka_unit_test(test_avsm_slab),
        cmocka_unit_test(test_directional_flux_placements),
        cmocka_unit_test(test_light_types_flux),
        cmocka_unit_test(test_eq6_reweighting),
        cmocka_unit_test(test_roulette_unbiased),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
