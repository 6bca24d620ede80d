/*
 * `guided`'s sampling math (docs/techniques/guided.md):
 *   - the equal-area octahedral map: round trip, and uniform points on the
 *     square are uniform on the sphere (chi-square over equal-area bands);
 *   - quadtree warping: leaves drawn with probability leaf/root, and the
 *     probability a sample reports equals the evaluated one bit for bit;
 *   - the per-event sampler of every strategy against its density
 *     (chi-square over 32×32 equal-area bins at several positions of a
 *     cloud lit by a map with a sun), the density integrating to 1, and the
 *     density a sample reports equal to the evaluated one;
 *   - the white furnace for every strategy (every pixel's expected value is
 *     the environment's radiance, whatever the guiding density);
 *   - visibility sweeps and brute-force rays against the analytic
 *     transmittance of a homogeneous box, and against each other on a
 *     cloud.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "chi2.h"
#include "core/rng.h"
#include "pt_util.h"
#include "render/technique_class.h"
#include "core/volume_internal.h"
#include "sample/march.h"
#include "sample/octahedral.h"
#include "sample/phase.h"
#include "techniques/guided/guided.h"
#include "techniques/guided/sweep_kernels.h"

#define PI_D 3.14159265358979323846

/* ------------------------------------------------------------------ octahedral map */

static void test_octahedral_map_round_trip_and_equal_area(void **state) {
    (void)state;
    volux_rng rng = volux_rng_make(3, 0, 0, 0);
    double worst = 0.0;
    for (int i = 0; i < 200000; i++) {
        volux_vec3 d = volux_sample_sphere(volux_rng_float(&rng), volux_rng_float(&rng));
        float u, v;
        volux_octa_from_dir(d, &u, &v);
        volux_vec3 e = volux_octa_to_dir(u, v);
        double err = fabs(d.x - e.x) + fabs(d.y - e.y) + fabs(d.z - e.z);
        if (err > worst) worst = err;
        assert_near(v3_length(volux_octa_to_dir(volux_rng_float(&rng), volux_rng_float(&rng))), 1.0, 1e-5);
    }
    printf("  octahedral round trip: largest |d - map(map^-1(d))|_1 = %.2g\n", worst);
    assert_true(worst < 2e-5);
    /* uniform on the square → uniform on the sphere: 20 z bands × 16
     * azimuth sectors, all of equal area */
    enum { NZ = 20, NP = 16, N = 400000 };
    double obs[NZ * NP] = {0}, exp_[NZ * NP];
    for (int i = 0; i < NZ * NP; i++) exp_[i] = 1.0 / (NZ * NP);
    for (int i = 0; i < N; i++) {
        volux_vec3 d = volux_octa_to_dir(volux_rng_float(&rng), volux_rng_float(&rng));
        int bz = (int)((d.z + 1.0f) * 0.5f * NZ), bp = (int)((atan2(d.y, d.x) + PI_D) / (2 * PI_D) * NP);
        bz = bz < 0 ? 0 : bz >= NZ ? NZ - 1 : bz;
        bp = bp < 0 ? 0 : bp >= NP ? NP - 1 : bp;
        obs[bz * NP + bp] += 1.0;
    }
    chi2_check(obs, exp_, NZ * NP, N, "octahedral map equal area");
}

static void test_quadtree_warping_matches_its_probabilities(void **state) {
    (void)state;
    enum { L = 3, LEAVES = 64, N = 300000 };
    float nodes[85];
    volux_rng rng = volux_rng_make(5, 0, 0, 0);
    for (int i = 0; i < LEAVES; i++)
        nodes[volux_qt_offset(L) + i] = i % 7 == 0 ? 0.0f : volux_rng_float(&rng) * (float)(1 + i % 5);
    volux_qt_build(nodes, L);
    double obs[LEAVES] = {0}, exp_[LEAVES];
    for (int i = 0; i < LEAVES; i++) exp_[i] = nodes[volux_qt_offset(L) + i] / nodes[0];
    int mismatch = 0;
    double in_leaf[2] = {0, 0};
    for (int i = 0; i < N; i++) {
        double u = volux_rng_double(&rng), v = volux_rng_double(&rng);
        float prob = 1.0f;
        uint32_t leaf = volux_qt_sample(nodes, 0, 0, L, &u, &v, &prob);
        obs[leaf] += 1.0;
        mismatch += prob != volux_qt_prob(nodes, 0, 0, L, leaf);
        in_leaf[0] += u, in_leaf[1] += v;
        assert_true(u >= 0.0 && u < 1.0 && v >= 0.0 && v < 1.0);
    }
    chi2_check(obs, exp_, LEAVES, N, "quadtree warping 8x8");
    assert_int_equal(mismatch, 0);
    /* the position inside the leaf is uniform */
    assert_near(in_leaf[0] / N, 0.5, 0.005);
    assert_near(in_leaf[1] / N, 0.5, 0.005);
}

/* ------------------------------------------------------------------ the per-event sampler */

/* A 64×32 map: a dim sky brightening to the zenith, a dark ground and a
 * small bright sun. */
static void make_sky(volux_context *ctx, volux_image *m) {
    assert_int_equal(volux_image_create(ctx, 64, 32, m), VOLUX_OK);
    for (int y = 0; y < 32; y++)
        for (int x = 0; x < 64; x++) {
            float *p = &m->rgb[3 * (y * 64 + x)];
            float sky = y < 16 ? 0.3f + 0.7f * (1.0f - (float)y / 16.0f) : 0.02f;
            p[0] = 0.8f * sky, p[1] = 0.9f * sky, p[2] = sky;
            if (x >= 40 && x < 43 && y >= 9 && y < 11) p[0] = p[1] = p[2] = 400.0f;
        }
}

static volux_scene *sky_scene(volux_context *ctx, const char *strategy) {
    volux_scene *s = tu_scene(
        ctx, "{\"volume\": {\"procedural\": \"cloud\", \"dims\": [24, 24, 24], \"seed\": 4},"
             " \"transfer_function\": {\"extinction\": [[0, 0], [30, 0], [255, 0.8]], \"albedo\": 0.9},"
             " \"render\": {\"technique\": \"guided\", \"width\": 4, \"height\": 4},"
             " \"techniques\": {\"guided\": {\"env_resolution\": 64, \"cell\": 3}}}");
    volux_image map;
    make_sky(ctx, &map);
    volux_light_desc l;
    volux_light_desc_defaults(&l, VOLUX_LIGHT_ENVIRONMENT);
    l.map = &map;
    l.rotation_y_deg = 30.0f;
    assert_int_equal(volux_scene_set_light(s, 0, &l), VOLUX_OK);
    volux_image_free(ctx, &map);
    assert_int_equal(volux_scene_set_param(s, "guided", "strategy", 0, strategy), VOLUX_OK);
    return s;
}

static void check_strategy(volux_context *ctx, const char *strategy) {
    volux_scene *s = sky_scene(ctx, strategy);
    volux_technique *t;
    if (volux_technique_create(ctx, "guided", s, &t)) fail_msg("%s", volux_context_error(ctx));
    const guided_state *st = volux_technique_state(t);
    assert_true(st->env.present);
    const volux_vec3 xs[4] = {{0, 0, 0}, {-10.5f, -9, 8}, {6, 4, -3}, {11.4f, 11.4f, 11.4f}};
    enum { B = 32, N = 200000 };
    int M = st->env.res;
    static guided_event ev;
    for (int i = 0; i < 4; i++) {
        ev.kind = st->strategy;
        guided_event_build(st, xs[i], &ev);
        /* expected bin probabilities: the density is constant on every
         * M×M texel, and M×M texels nest in the B×B bins */
        static double exp_[B * B], obs[B * B];
        memset(exp_, 0, sizeof exp_);
        memset(obs, 0, sizeof obs);
        for (int y = 0; y < M; y++)
            for (int x = 0; x < M; x++) {
                volux_vec3 c = volux_octa_to_dir(((float)x + 0.5f) / (float)M, ((float)y + 0.5f) / (float)M);
                double p = guided_event_pdf(st, &ev, c) * 4.0 * PI_D / ((double)M * M);
                exp_[(y * B / M) * B + x * B / M] += p;
            }
        if (ev.kind == GUIDED_UNIFORM) /* not constant on texels, but uniform */
            for (int b = 0; b < B * B; b++) exp_[b] = 1.0 / (B * B);
        volux_rng rng = volux_rng_make(11, (uint64_t)i, 0, 0);
        int mismatch = 0;
        for (int k = 0; k < N; k++) {
            volux_vec3 w;
            float pdf = guided_event_sample(st, &ev, volux_rng_double(&rng), volux_rng_double(&rng), &w);
            assert_true(pdf > 0.0f);
            assert_near(v3_length(w), 1.0, 1e-4);
            float u, v;
            volux_octa_from_dir(w, &u, &v);
            obs[volux_octa_texel(v, B) * B + volux_octa_texel(u, B)] += 1.0;
            float back = guided_event_pdf(st, &ev, w);
            if (fabsf(back - pdf) > 1e-5f * pdf) mismatch++;
        }
        char what[64];
        snprintf(what, sizeof what, "guided %s at x%d", strategy, i);
        chi2_check(obs, exp_, B * B, N, what);
        /* a sample near a texel edge may map back into the neighbour */
        if (mismatch > N / 1000) fail_msg("%s: %d of %d samples report another density than evaluated", what, mismatch, N);
    }
    volux_technique_destroy(t);
    volux_scene_destroy(s);
}

static void test_every_strategy_samples_its_density(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    const char *names[5] = {"uniform", "environment", "visibility", "product", "two_step"};
    for (int i = 0; i < 5; i++) check_strategy(ctx, names[i]);
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

/* The product really follows visibility: from a point deep in a slab the
 * density towards the thick side is far below the thin side's. */
static void test_product_prefers_visible_directions(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    /* a 32×32×8 slab (thin along z) in a uniform environment */
    volux_scene *s = tu_scene(ctx, "{\"volume\": {\"procedural\": \"constant\", \"dims\": [33, 33, 9]},"
                                   " \"transfer_function\": {\"extinction\": [[0, 0.5], [1, 0.5]]},"
                                   " \"lights\": [{\"type\": \"environment\", \"radiance\": 1}],"
                                   " \"render\": {\"technique\": \"guided\", \"width\": 4, \"height\": 4},"
                                   " \"techniques\": {\"guided\": {\"strategy\": \"product\", \"env_resolution\": 8,"
                                   " \"cell\": 2, \"filter\": false}}}");
    volux_technique *t;
    assert_int_equal(volux_technique_create(ctx, "guided", s, &t), VOLUX_OK);
    const guided_state *st = volux_technique_state(t);
    static guided_event ev;
    ev.kind = st->strategy;
    guided_event_build(st, v3(0, 0, 0), &ev);
    float up = guided_event_pdf(st, &ev, v3(0, 0, 1)), side = guided_event_pdf(st, &ev, v3(1, 0, 0));
    printf("  slab centre: density towards +z %.4f, towards +x %.4f\n", up, side);
    /* +z: ~4 units of σ = 0.5 (V ≈ e^-2); +x: ~16 units (V ≈ e^-8 → ε) */
    assert_true(up > 5.0f * side);
    volux_technique_destroy(t);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

/* ------------------------------------------------------------------ white furnace */

static float noise_fn(int i, int j, int k, void *u) {
    (void)u;
    uint32_t h = (uint32_t)(i * 73856093) ^ (uint32_t)(j * 19349663) ^ (uint32_t)(k * 83492791);
    h ^= h >> 13;
    h *= 0x5bd1e995u;
    h ^= h >> 15;
    return (i + j + k) % 5 == 0 ? 0.0f : (float)(h & 0xffff) / 65535.0f;
}

static void test_white_furnace_for_every_strategy(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_volume *v = pt_volume_fn(ctx, 17, 17, 17, noise_fn, NULL);
    const volux_tf_scalar_point ext[4] = {{0.0f, 0.0f}, {0.3f, 0.0f}, {0.6f, 3.0f}, {1.0f, 0.5f}};
    const char *names[5] = {"uniform", "environment", "visibility", "product", "two_step"};
    const volux_vec3 Lenv = {0.5f, 1.0f, 2.0f};
    for (int i = 0; i < 5; i++)
        for (int mis = 0; mis < 2; mis++) {
            volux_scene *s = pt_scene(ctx, v, ext, 4, NULL, 0, 1.0f, 0.4f, 12.0f, 8, 8, 100000);
            pt_add_constant_env(s, Lenv, 1);
            assert_int_equal(volux_scene_set_param(s, "guided", "strategy", 0, names[i]), VOLUX_OK);
            assert_int_equal(volux_scene_set_param(s, "guided", "mis", mis, NULL), VOLUX_OK);
            assert_int_equal(volux_scene_set_param(s, "guided", "env_resolution", 16, NULL), VOLUX_OK);
            assert_int_equal(volux_scene_set_param(s, "guided", "cell", 2, NULL), VOLUX_OK);
            volux_technique *t;
            assert_int_equal(volux_technique_create(ctx, "guided", s, &t), VOLUX_OK);
            pt_stats pst;
            pt_accumulate(t, s, mis ? 192 : 512, &pst);
            int n = pst.width * pst.height;
            const float Lc[3] = {Lenv.x, Lenv.y, Lenv.z};
            for (int c = 0; c < 3; c++) {
                double sum = 0.0, var_sum = 0.0;
                for (int p = 0; p < n; p++) {
                    double m = pst.mean[3 * p + c], se = pt_stats_se(&pst, p, c);
                    sum += m;
                    var_sum += se * se;
                    if (fabs(m - Lc[c]) > 5.0 * se + 1e-5 * Lc[c])
                        fail_msg("%s mis %d: pixel %d channel %d = %.5f, expected %.5f (se %.5f)", names[i], mis, p, c,
                                 m, Lc[c], se);
                }
                double mean = sum / n, se = sqrt(var_sum) / n;
                assert_true(se < 0.01 * Lc[c]); /* tight enough to see a 3 % bias */
                if (fabs(mean - Lc[c]) > 4.0 * se + 1e-6)
                    fail_msg("%s mis %d: image mean channel %d = %.5f, expected %.5f (se %.5f)", names[i], mis, c, mean,
                             Lc[c], se);
                if (c == 1) printf("  furnace %-12s mis %d  mean %.5f  (L %.3f, se %.5f)\n", names[i], mis, mean, Lc[c], se);
            }
            pt_stats_free(&pst);
            volux_technique_destroy(t);
            volux_scene_destroy(s);
        }
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

/* ------------------------------------------------------------------ visibility */

/* Mean and largest |V − reference| over the grid for the scene's settings;
 * the reference is analytic (homogeneous box of σ) or another grid. */
static void grid_of(volux_context *ctx, const char *json, const char *visibility, int filter, uint16_t **out,
                    size_t *n, int *dirs, int *cells) {
    volux_scene *s = tu_scene(ctx, json);
    assert_int_equal(volux_scene_set_param(s, "guided", "visibility", 0, visibility), VOLUX_OK);
    assert_int_equal(volux_scene_set_param(s, "guided", "filter", filter, NULL), VOLUX_OK);
    volux_technique *t;
    assert_int_equal(volux_technique_create(ctx, "guided", s, &t), VOLUX_OK);
    const guided_state *st = volux_technique_state(t);
    *dirs = st->grid.dirs;
    memcpy(cells, st->grid.cells, sizeof st->grid.cells);
    *n = (size_t)cells[0] * (size_t)cells[1] * (size_t)cells[2] * (size_t)*dirs;
    *out = malloc(*n * sizeof **out);
    memcpy(*out, st->grid.v, *n * sizeof **out);
    volux_technique_destroy(t);
    volux_scene_destroy(s);
}

static void test_sweeps_and_rays_match_analytic_transmittance(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    /* a 32³-node box of σ = 0.08, spacing 1: V(x, ω) = exp(−σ·dist(x, ω)) */
    const char *json = "{\"volume\": {\"procedural\": \"constant\", \"dims\": [32, 32, 32]},"
                       " \"transfer_function\": {\"extinction\": [[0, 0.08], [1, 0.08]]},"
                       " \"lights\": [{\"type\": \"environment\", \"radiance\": 1}],"
                       " \"render\": {\"technique\": \"guided\", \"width\": 4, \"height\": 4},"
                       " \"techniques\": {\"guided\": {\"env_resolution\": 8}}}";
    const char *modes[2] = {"sweep", "bruteforce"};
    uint16_t *grids[2];
    for (int m = 0; m < 2; m++) {
        size_t n;
        int dirs, cells[3];
        grid_of(ctx, json, modes[m], 0, &grids[m], &n, &dirs, cells);
        double sum = 0.0, worst = 0.0;
        float cs = 31.0f / (float)cells[0];
        for (int k = 0; k < cells[2]; k++)
            for (int j = 0; j < cells[1]; j++)
                for (int i = 0; i < cells[0]; i++)
                    for (int d = 0; d < dirs; d++) {
                        float c[3] = {((float)i + 0.5f) * cs, ((float)j + 0.5f) * cs, ((float)k + 0.5f) * cs};
                        volux_vec3 w = guided_direction(8, d, 1, 0, 0);
                        float wv[3] = {w.x, w.y, w.z}, dist = INFINITY;
                        for (int a = 0; a < 3; a++)
                            if (wv[a] > 0) dist = fminf(dist, (31.0f - c[a]) / wv[a]);
                            else if (wv[a] < 0) dist = fminf(dist, -c[a] / wv[a]);
                        double V = exp(-0.08 * dist);
                        size_t cell = ((size_t)k * cells[1] + j) * cells[0] + i;
                        double got = grids[m][cell * dirs + d] / 65535.0, e = fabs(got - V);
                        sum += e;
                        if (e > worst) worst = e;
                    }
        double mean = sum / (double)n;
        printf("  %-10s vs analytic: mean |dV| %.4f, max %.4f\n", modes[m], mean, worst);
        /* brute force: midpoint rule along the exact ray; sweeps: plus the
         * plane quadrature and the bilinear lookup on the kernel, whose four
         * rays leave a corner of the box at different depths */
        assert_true(mean < (m ? 0.001 : 0.005));
        assert_true(worst < (m ? 0.005 : 0.05));
    }
    free(grids[0]);
    free(grids[1]);
    volux_context_destroy(ctx);
}

static void test_sweeps_agree_with_rays_on_a_cloud(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    const char *json = "{\"volume\": {\"procedural\": \"cloud\", \"dims\": [24, 22, 20], \"seed\": 2},"
                       " \"transfer_function\": {\"extinction\": [[0, 0], [40, 0], [255, 0.6]]},"
                       " \"lights\": [{\"type\": \"environment\", \"radiance\": 1}],"
                       " \"render\": {\"technique\": \"guided\", \"width\": 4, \"height\": 4},"
                       " \"techniques\": {\"guided\": {\"env_resolution\": 8}}}";
    uint16_t *a, *b, *f;
    size_t n;
    int dirs, cells[3];
    grid_of(ctx, json, "sweep", 0, &a, &n, &dirs, cells);
    grid_of(ctx, json, "bruteforce", 0, &b, &n, &dirs, cells);
    grid_of(ctx, json, "sweep", 1, &f, &n, &dirs, cells);
    /* the filter over the projected cell alone (β = 0) */
    char js[2048];
    snprintf(js, sizeof js, "%.*s, \"filter_angle\": 0}}}", (int)(strlen(json) - 3), json);
    uint16_t *f0;
    grid_of(ctx, js, "sweep", 1, &f0, &n, &dirs, cells);
    /* V averaged over each cell (2×2×2 positions) and its direction
     * texel (2×2 directions), by brute force on the scene's medium: what a
     * grid entry stands for (§5: "the average probability to hit the
     * environmental light source for all rays originating in the cube ...
     * whose directional components are in the corresponding interval") */
    volux_scene *s = tu_scene(ctx, json);
    const volux_volume *vol = volux_scene_volume(s);
    const volux_transfer_lut *lut = volux_scene_transfer_lut(s);
    int vd[3];
    volux_volume_dims(vol, vd);
    double *ref = malloc(n * sizeof *ref);
    float cs[3];
    for (int a3 = 0; a3 < 3; a3++) cs[a3] = (float)(vd[a3] - 1) / (float)cells[a3];
    size_t idx = 0;
    for (int k = 0; k < cells[2]; k++)
        for (int j = 0; j < cells[1]; j++)
            for (int i = 0; i < cells[0]; i++)
                for (int d = 0; d < dirs; d++, idx++) {
                    double sum = 0.0;
                    for (int sub = 0; sub < 8 * 4; sub++) {
                        int p = sub & 7, q = sub >> 3;
                        float c[3] = {((float)i + 0.25f + 0.5f * (float)(p & 1)) * cs[0],
                                      ((float)j + 0.25f + 0.5f * (float)((p >> 1) & 1)) * cs[1],
                                      ((float)k + 0.25f + 0.5f * (float)(p >> 2)) * cs[2]};
                        volux_vec3 w = guided_direction(8, d, 2, q & 1, q >> 1);
                        float wv[3] = {w.x, w.y, w.z}, dist = INFINITY;
                        for (int a3 = 0; a3 < 3; a3++)
                            if (wv[a3] > 0) dist = fminf(dist, ((float)(vd[a3] - 1) - c[a3]) / wv[a3]);
                            else if (wv[a3] < 0) dist = fminf(dist, -c[a3] / wv[a3]);
                        double tau = 0.0;
                        for (float t = 0.25f; t < dist; t += 0.5f)
                            tau += 0.5 * volux_lut_sigma(lut, volux_volume_sample_index(vol, c[0] + t * wv[0],
                                                                                        c[1] + t * wv[1],
                                                                                        c[2] + t * wv[2]));
                        sum += exp(-tau);
                    }
                    ref[idx] = sum / 32.0;
                }
    double d_ab = 0.0, d_ar = 0.0, d_fr = 0.0, d_br = 0.0, d_0r = 0.0, mean_v = 0.0;
    for (size_t i = 0; i < n; i++) {
        d_ab += fabs((double)a[i] - b[i]) / 65535.0;
        d_ar += fabs(a[i] / 65535.0 - ref[i]);
        d_br += fabs(b[i] / 65535.0 - ref[i]);
        d_fr += fabs(f[i] / 65535.0 - ref[i]);
        d_0r += fabs(f0[i] / 65535.0 - ref[i]);
        mean_v += ref[i];
    }
    printf("  cloud: mean V %.3f; sweep vs rays %.4f; against the cell/texel average: rays %.4f, sweep %.4f, "
           "sweep filtered over the cell %.4f, and widened by t tan(beta) %.4f\n",
           mean_v / n, d_ab / n, d_br / n, d_ar / n, d_0r / n, d_fr / n);
    assert_true(d_ab / n < 0.01);
    /* §8: filtering over the projected cell approximates the cell's mean
     * visibility better than the ray through its centre; the widening by
     * t tan β (a beam of directions) moves away from this reference, which
     * averages only a few directions, but stays close */
    assert_true(d_0r / n < d_ar / n);
    assert_true(d_fr / n < 0.12);
    free(f0);
    free(ref);
    volux_scene_destroy(s);
    free(a);
    free(b);
    free(f);
    volux_context_destroy(ctx);
}

/* The AVX-512 row loop computes the portable loop's grid up to float
 * rounding (FMA), on every storage kind. */
static void test_simd_sweeps_match_the_portable_loop(void **state) {
    (void)state;
    if (!guided_sweep_avx512_available()) {
        printf("  no AVX-512 on this CPU: nothing to compare\n");
        return;
    }
    volux_context *ctx = tu_context(2);
    static const char *const volumes[3] = {"{\"procedural\": \"cloud\", \"dims\": [37, 30, 26], \"seed\": 5}",
                                           "{\"procedural\": \"constant\", \"dims\": [21, 19, 33]}",
                                           "{\"procedural\": \"sphere\", \"dims\": [25, 40, 18]}"};
    for (int i = 0; i < 3; i++) {
        char json[1024], js[1100];
        snprintf(json, sizeof json,
                 "{\"volume\": %s, \"transfer_function\": {\"extinction\": [[0, 0], [0.5, 0.2], [60, 0.1], [255, 0.4]]},"
                 " \"lights\": [{\"type\": \"environment\", \"radiance\": 1}],"
                 " \"render\": {\"technique\": \"guided\", \"width\": 4, \"height\": 4},"
                 " \"techniques\": {\"guided\": {\"env_resolution\": 8, \"kernel\": \"scalar\"}}}",
                 volumes[i]);
        uint16_t *a, *b;
        size_t n;
        int dirs, cells[3];
        grid_of(ctx, json, "sweep", 1, &a, &n, &dirs, cells);
        snprintf(js, sizeof js, "%s", json);
        char *k = strstr(js, "\"scalar\"");
        memcpy(k, "\"simd\"  ", 8);
        grid_of(ctx, js, "sweep", 1, &b, &n, &dirs, cells);
        int worst = 0;
        for (size_t j = 0; j < n; j++) {
            int d = abs((int)a[j] - (int)b[j]);
            if (d > worst) worst = d;
        }
        printf("  volume %d: largest |V_scalar - V_simd| = %d / 65535\n", i, worst);
        assert_true(worst <= 8); /* 1.2e-4: rounding, not a different value */
        free(a);
        free(b);
    }
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_octahedral_map_round_trip_and_equal_area),
        cmocka_unit_test(test_quadtree_warping_matches_its_probabilities),
        cmocka_unit_test(test_every_strategy_samples_its_density),
        cmocka_unit_test(test_product_prefers_visible_directions),
        cmocka_unit_test(test_white_furnace_for_every_strategy),
        cmocka_unit_test(test_sweeps_and_rays_match_analytic_transmittance),
        cmocka_unit_test(test_sweeps_agree_with_rays_on_a_cloud),
        cmocka_unit_test(test_simd_sweeps_match_the_portable_loop),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
