/*
 * tests/unit/test_lightvol_groups.c — propagation groups and the Eq. 5
 * contribution factors: the paper's values in the principal planes, the
 * closest face by the largest h_d = l_dir·n, two groups per light, factors
 * continuous across every group boundary, and an illumination volume that
 * does not pop when a light crosses a boundary.
 */
#include <stdio.h>

#include "lightvol_fixture.h"

#define PI 3.14159265358979323846

static volux_vec3 unit(double x, double y, double z) {
    double l = sqrt(x * x + y * y + z * z);
    return (volux_vec3){(float)(x / l), (float)(y / l), (float)(z / l)};
}

/* In a principal plane our factors are exactly Eq. 5a/5b:
 * α_cA = 1 − 2β/π, α_scA = 1 − α_cA, β the angle to the closest axis; the
 * propagated factors (dead zone ε = LV_MIN_FACTOR) differ by less than ε. */
static void test_factors_are_eq5_in_principal_planes(void **state) {
    (void)state;
    for (int i = 0; i <= 90; i++) {
        double beta = (double)i * (PI / 4.0) / 90.0; /* [0°, 45°] */
        const int planes[3][2] = {{0, 1}, {1, 2}, {2, 0}};
        for (int p = 0; p < 3; p++)
            for (int sgn = 0; sgn < 4; sgn++) {
                double c[3] = {0, 0, 0};
                int a1 = planes[p][0], a2 = planes[p][1];
                double s1 = (sgn & 1) ? -1 : 1, s2 = (sgn & 2) ? -1 : 1;
                c[a1] = s1 * cos(beta);
                c[a2] = s2 * sin(beta);
                float w[LV_GROUPS], wd[LV_GROUPS];
                int r1, r2;
                unsigned m = lv_face_weights_raw(unit(c[0], c[1], c[2]), w, &r1, &r2);
                double want = 1.0 - 2.0 * beta / PI;
                int g1 = lv_group(a1, (int)s1), g2 = lv_group(a2, (int)s2);
                if (i < 90) {
                    assert_near(w[g1], want, 2e-6);
                    assert_int_equal(r1, g1);
                }
                assert_near(w[g1] + w[g2], 1.0, 1e-6);
                if (i == 0) assert_int_equal(m, 1u << g1);
                else assert_int_equal(m, (1u << g1) | (1u << g2));
                unsigned md = lv_face_weights(unit(c[0], c[1], c[2]), wd);
                assert_near(wd[g1], w[g1], LV_MIN_FACTOR);
                assert_near(wd[g1] + wd[g2], 1.0, 1e-6);
                if (w[g2] > LV_MIN_FACTOR + 1e-6f) assert_int_equal(md, m);
                if (w[g2] <= LV_MIN_FACTOR) assert_int_equal(md, 1u << g1);
            }
    }
}

/* Every direction: factors ≥ 0, sum 1, at most two groups, only faces the
 * light travels towards (positive component), and the closest face (largest
 * h_d = l_dir·n_d, Sec. 4) gets the larger factor. */
static void test_factors_sum_to_one_on_the_closest_faces(void **state) {
    (void)state;
    uint64_t r = 5;
    for (int it = 0; it < 20000; it++) {
        double c[3];
        for (int a = 0; a < 3; a++) {
            r = r * 6364136223846793005ull + 1442695040888963407ull;
            c[a] = (double)((r >> 11) & 0xfffff) / 1048575.0 * 2.0 - 1.0;
        }
        volux_vec3 w = unit(c[0], c[1], c[2]);
        float f[LV_GROUPS];
        unsigned m = lv_face_weights(w, f);
        double sum = 0;
        int count = 0, best = -1;
        float wc[3] = {w.x, w.y, w.z}, bestdot = -2;
        for (int g = 0; g < LV_GROUPS; g++) {
            float dot = (g & 1 ? -1.0f : 1.0f) * wc[g / 2];
            if (dot > bestdot) bestdot = dot, best = g;
            assert_true(f[g] >= 0.0f);
            if (f[g] > 0.0f) {
                count++;
                assert_true(m & (1u << g));
                assert_true(dot > 0.0f);
            }
            sum += f[g];
        }
        assert_near(sum, 1.0, 1e-6);
        assert_true(count >= 1 && count <= 2);
        /* the per-voxel form used by point lights agrees */
        const float mag[3] = {fabsf(w.x), fabsf(w.y), fabsf(w.z)};
        for (int g = 0; g < LV_GROUPS; g++)
            if (f[g] > 0.0f) assert_true(lv_axis_weight(mag, g / 2) == f[g]);
            else if (mag[g / 2] > 0.0f && (g & 1 ? -1.0f : 1.0f) * wc[g / 2] > 0.0f) assert_true(lv_axis_weight(mag, g / 2) == 0.0f);
        for (int g = 0; g < LV_GROUPS; g++) assert_true(f[best] >= f[g]);
    }
}

/* Continuity at both kinds of group boundaries, for directions approaching
 * the boundary from either side: |a| = |b| (closest and second-closest faces
 * swap: both factors → ½) and |b| = |c| (the second-closest face changes:
 * its factor → 0). */
static void test_factors_are_continuous_at_group_boundaries(void **state) {
    (void)state;
    const double eps[3] = {1e-2, 1e-3, 1e-4};
    for (int it = 0; it < 200; it++) {
        double t = (double)it / 199.0;
        /* |x| = |y| > |z|, z from 0 to almost |x| */
        double x = 1.0, z = 0.98 * t;
        double prev = 1e9;
        for (int e = 0; e < 3; e++) {
            float fa[LV_GROUPS], fb[LV_GROUPS];
            lv_face_weights(unit(x, x + eps[e], z), fa);
            lv_face_weights(unit(x, x - eps[e], z), fb);
            double d = 0;
            for (int g = 0; g < LV_GROUPS; g++) d = fmax(d, fabs(fa[g] - fb[g]));
            assert_true(d < 60.0 * eps[e] + 1e-5);
            assert_true(d <= prev + 1e-6);
            prev = d;
        }
        /* |y| = |z| < |x| */
        double y = 0.02 + 0.96 * t;
        prev = 1e9;
        for (int e = 0; e < 3; e++) {
            float fa[LV_GROUPS], fb[LV_GROUPS];
            lv_face_weights(unit(1.0, y, y + eps[e]), fa);
            lv_face_weights(unit(1.0, y + eps[e], y), fb);
            double d = 0;
            for (int g = 0; g < LV_GROUPS; g++) d = fmax(d, fabs(fa[g] - fb[g]));
            assert_true(d < 60.0 * eps[e] + 1e-5);
            prev = d;
        }
        /* sign change of the smallest component: a face with 0 has factor 0 */
        float fa[LV_GROUPS], fb[LV_GROUPS];
        lv_face_weights(unit(1.0, 0.3, 1e-5), fa);
        lv_face_weights(unit(1.0, 0.3, -1e-5), fb);
        for (int g = 0; g < LV_GROUPS; g++) assert_near(fa[g], fb[g], 1e-4);
    }
}

/* Point lights: grouped by the main direction (light → volume centre) and
 * any group the local directions need; a light straight above needs −y only
 * when far, more when close. */
static void test_point_light_groups_follow_local_directions(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    float *data = calloc(16 * 16 * 16, sizeof(float));
    volux_scene *s = lvf_scene(ctx, 16, 16, 16, data, 0.9f, NULL);
    assert_int_equal(volux_scene_set_param(s, "lightvol", "positional_grouping", 0, "voxel"), VOLUX_OK);
    volux_light_desc p = lvf_point(0, 1e5f, 0, 1.0f);
    assert_int_equal(volux_scene_set_light(s, 0, &p), VOLUX_OK);
    volux_technique *t = lvf_create(ctx, s);
    const lightvol_state *st = lvf_state(t);
    assert_int_equal(st->applied[0].src.groups, 1u << lv_group(1, -1));
    p.position = (volux_vec3){0, 20, 0}; /* close: local directions fan out */
    assert_int_equal(volux_scene_set_light(s, 0, &p), VOLUX_OK);
    lvf_update(t, s);
    unsigned g = st->applied[0].src.groups;
    assert_true(g & (1u << lv_group(1, -1)));
    assert_int_equal(__builtin_popcount(g), 5); /* all but +y */
    p.position = (volux_vec3){0.5f, 0.2f, -0.3f}; /* inside: all six (§7.3) */
    assert_int_equal(volux_scene_set_light(s, 0, &p), VOLUX_OK);
    lvf_update(t, s);
    assert_int_equal(st->applied[0].src.groups, 0x3fu);
    /* main direction of an off-axis light: its closest face is among the groups */
    p.position = (volux_vec3){-60, 25, 10};
    assert_int_equal(volux_scene_set_light(s, 0, &p), VOLUX_OK);
    lvf_update(t, s);
    float f[LV_GROUPS];
    lv_face_weights(unit(60, -25, -10), f);
    assert_true(st->applied[0].src.groups & (1u << lv_group(0, 1)));
    volux_technique_destroy(t);
    volux_scene_destroy(s);
    free(data);
    volux_context_destroy(ctx);
}

/* §4's grouping (techniques.lightvol.positional_grouping = "center"): a
 * point light outside the box joins the two closest faces of its
 * light-to-centre direction with that direction's constant Eq. 5 factors —
 * one pass where the per-voxel grouping needs five for a close light; a
 * light inside the box, or beside it within both groups' slabs (the two
 * groups cannot reach every voxel), keeps the per-voxel groups. */
static void test_center_grouping_uses_the_main_direction(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    float *data = calloc(16 * 16 * 16, sizeof(float));
    volux_scene *s = lvf_scene(ctx, 16, 16, 16, data, 0.9f, NULL);
    assert_int_equal(volux_scene_set_param(s, "lightvol", "positional_grouping", 0, "center"), VOLUX_OK);
    volux_light_desc p = lvf_point(0, 20, 0, 1.0f); /* close above: five groups per voxel */
    assert_int_equal(volux_scene_set_light(s, 0, &p), VOLUX_OK);
    volux_technique *t = lvf_create(ctx, s);
    const lightvol_state *st = lvf_state(t);
    assert_int_equal(st->applied[0].src.groups, 1u << lv_group(1, -1));
    assert_int_equal(st->applied[0].src.center, 1);
    assert_true(st->applied[0].src.weight[lv_group(1, -1)] == 1.0f);
    /* off-axis, beside the z slab: +x and −z with the centre direction's factors */
    p.position = (volux_vec3){-30, 2, 6};
    assert_int_equal(volux_scene_set_light(s, 0, &p), VOLUX_OK);
    lvf_update(t, s);
    float f[LV_GROUPS];
    unsigned want = lv_face_weights(unit(30, -2, -6), f);
    assert_int_equal(want, (1u << lv_group(0, 1)) | (1u << lv_group(2, -1)));
    assert_int_equal(st->applied[0].src.groups, want);
    assert_int_equal(st->applied[0].src.center, 1);
    for (int g = 0; g < LV_GROUPS; g++) assert_true(fabsf(st->applied[0].src.weight[g] - f[g]) < 1e-5f);
    assert_true(f[lv_group(2, -1)] > 0.05f); /* a real second group */
    /* inside: the per-voxel grouping, all six (§7.3) */
    p.position = (volux_vec3){0.5f, 0.2f, -0.3f};
    assert_int_equal(volux_scene_set_light(s, 0, &p), VOLUX_OK);
    lvf_update(t, s);
    assert_int_equal(st->applied[0].src.center, 0);
    assert_int_equal(st->applied[0].src.groups, 0x3fu);
    volux_technique_destroy(t);
    volux_scene_destroy(s);
    free(data);
    /* a flat box (16×16×4): a light above a corner within the x and y slabs
     * has the main faces −x, −y, which cannot reach the voxels beyond it */
    data = calloc(16 * 16 * 4, sizeof(float));
    s = lvf_scene(ctx, 16, 16, 4, data, 0.9f, NULL);
    assert_int_equal(volux_scene_set_param(s, "lightvol", "positional_grouping", 0, "center"), VOLUX_OK);
    p.position = (volux_vec3){6, 6, 5};
    assert_int_equal(volux_scene_set_light(s, 0, &p), VOLUX_OK);
    t = lvf_create(ctx, s);
    st = lvf_state(t);
    assert_int_equal(st->applied[0].src.center, 0);
    assert_true(__builtin_popcount(st->applied[0].src.groups) > 2);
    volux_technique_destroy(t);
    volux_scene_destroy(s);
    free(data);
    volux_context_destroy(ctx);
}

/* No popping: rotating a light by a small angle across a group boundary
 * changes the illumination volume no more than the same rotation away from
 * any boundary (relative to the volume's maximum). */
static void test_volume_does_not_pop_across_group_boundaries(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    const int n = 20;
    float *data = malloc((size_t)n * n * n * sizeof(float));
    uint64_t r = 3;
    for (int i = 0; i < n * n * n; i++) {
        r = r * 6364136223846793005ull + 1442695040888963407ull;
        data[i] = (float)((r >> 40) & 0xffff) / 65535.0f * 0.3f;
    }
    volux_scene *s = lvf_scene(ctx, n, n, n, data, 0.9f, NULL);
    assert_int_equal(volux_scene_set_param(s, "lightvol", "directional", 0, NULL), VOLUX_OK);
    const double da = 0.2 * PI / 180.0;
    /* boundary between −y and −x at azimuth 45° in the xy plane (tilted in z),
     * and the swap of the second face at |x| = |z| */
    const double centres[2] = {45.0, 30.0}; /* degrees: boundary, reference */
    double jump[2][2];
    for (int kind = 0; kind < 2; kind++)
        for (int c = 0; c < 2; c++) {
            float *v[2];
            for (int side = 0; side < 2; side++) {
                double a = centres[c] * PI / 180.0 + (side ? da : -da);
                volux_light_desc l = kind == 0 ? lvf_directional((float)-sin(a), (float)-cos(a), 0.3f, 1.0f)
                                               : lvf_directional((float)(-0.3 * sin(a)), -1.0f, (float)(-0.3 * cos(a)), 1.0f);
                assert_int_equal(volux_scene_set_light(s, 0, &l), VOLUX_OK);
                volux_technique *t = lvf_create(ctx, s);
                v[side] = lvf_copy(t);
                volux_technique_destroy(t);
            }
            double bmax, d = lvf_max_diff(v[0], v[1], (size_t)n * n * n * 3, &bmax);
            jump[kind][c] = d / bmax;
            free(v[0]);
            free(v[1]);
        }
    print_message("0.4 deg rotation: across -y/-x boundary %.3g (away %.3g); across 2nd-face swap %.3g (away %.3g)\n",
                  jump[0][0], jump[0][1], jump[1][0], jump[1][1]);
    for (int kind = 0; kind < 2; kind++) assert_true(jump[kind][0] < 3.0 * jump[kind][1] + 1e-3);
    volux_scene_destroy(s);
    free(data);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_factors_are_eq5_in_principal_planes),
        cmocka_unit_test(test_factors_sum_to_one_on_the_closest_faces),
        cmocka_unit_test(test_factors_are_continuous_at_group_boundaries),
        cmocka_unit_test(test_point_light_groups_follow_local_directions),
        cmocka_unit_test(test_center_grouping_uses_the_main_direction),
        cmocka_unit_test(test_volume_does_not_pop_across_group_boundaries),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
