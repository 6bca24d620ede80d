/*
 * tests/invariants/test_lightvol_updates.c — selective light updates equal
 * an entire rebuild; toggles restore; drift after many edits stays bounded
 * and the re-baseline policy holds; the cost rules of §5 pick what they
 * should; every other edit leaves an image equal to a fresh render; results
 * do not depend on the thread count.
 */
#include <stdio.h>

#include "lightvol_fixture.h"
#include "techniques/lightvol/sweep.h"

#define N 16

/* n³ voxels: a blob of radius √20·n/16 voxels at the centre plus noise,
 * so there are shadows. */
static float *random_medium_n(uint64_t seed, float scale, int n) {
    float *d = malloc((size_t)n * n * n * sizeof(float));
    assert_non_null(d);
    uint64_t r = seed;
    float c = 0.5f * (float)(n - 1), r2 = 20.0f * (float)(n * n) / (float)(N * N);
    for (int k = 0; k < n; k++)
        for (int j = 0; j < n; j++)
            for (int i = 0; i < n; i++) {
                r = r * 6364136223846793005ull + 1442695040888963407ull;
                float x = (float)((r >> 40) & 0xffff) / 65535.0f;
                float dx = (float)i - c, dy = (float)j - c, dz = (float)k - c;
                float blob = dx * dx + dy * dy + dz * dz < r2 ? 1.0f : 0.0f;
                d[((size_t)k * n + j) * n + i] = scale * (0.15f * x + blob);
            }
    return d;
}

static float *random_medium(uint64_t seed, float scale) { return random_medium_n(seed, scale, N); }

typedef struct fixture {
    volux_context *ctx;
    float *data;
    volux_scene *s;
} fixture;

static const float COLOR[3] = {0.9f, 0.7f, 0.5f};

static void fx_setup_n(fixture *f, int threads, int n) {
    f->ctx = tu_context(threads);
    f->data = random_medium_n(7, 0.8f, n);
    f->s = lvf_scene(f->ctx, n, n, n, f->data, 0.8f, COLOR);
    volux_light_desc l[4] = {lvf_directional(-0.4f, -0.8f, -0.45f, 2.0f), lvf_directional(0.6f, -0.3f, -0.7f, 1.0f),
                             lvf_point(-25, 14, 18, 3000.0f), lvf_spot(20, 20, -20, -1, -1, 1, 4000.0f, 30, 20)};
    l[1].color = (volux_vec3){0.4f, 0.6f, 1.0f};
    l[2].color = (volux_vec3){1.0f, 0.6f, 0.3f};
    for (int i = 0; i < 4; i++) assert_int_equal(volux_scene_set_light(f->s, i, &l[i]), VOLUX_OK);
    assert_int_equal(volux_scene_set_param(f->s, "lightvol", "forward_scattering", 0.5, NULL), VOLUX_OK);
    assert_int_equal(volux_scene_set_param(f->s, "lightvol", "scatter_cone", 15.0, NULL), VOLUX_OK);
}

static void fx_setup(fixture *f, int threads) { fx_setup_n(f, threads, N); }

static void fx_teardown(fixture *f) {
    volux_scene_destroy(f->s);
    free(f->data);
    volux_context_destroy(f->ctx);
}

/* Illumination volume of a freshly created technique (entire update). */
static float *fresh_volume(volux_context *ctx, volux_scene *s) {
    volux_technique *t = lvf_create(ctx, s);
    assert_int_equal(lvf_state(t)->stats.last, LV_UPDATE_FULL);
    float *v = lvf_copy(t);
    volux_technique_destroy(t);
    return v;
}

static void assert_same_volume(const float *a, const float *b, size_t n, double rel, const char *what) {
    double bmax;
    double d = lvf_max_diff(a, b, n, &bmax);
    if (d > rel * bmax) fail_msg("%s: max |diff| %g > %g × max %g", what, d, rel, bmax);
}

/* Selective tolerance: float sums in another order (≈ a few ulps of the
 * largest value). */
#define SEL_TOL 2e-6

typedef void (*edit_fn)(volux_scene *s);

static void edit_move_small(volux_scene *s) {
    volux_light_desc d = *volux_scene_light(s, 0);
    d.direction.x += 0.05f;
    assert_int_equal(volux_scene_set_light(s, 0, &d), VOLUX_OK);
}
static void edit_move_across_groups(volux_scene *s) { /* −y/−z → −x/−z */
    volux_light_desc d = *volux_scene_light(s, 0);
    d.direction = (volux_vec3){-0.9f, -0.2f, -0.4f};
    assert_int_equal(volux_scene_set_light(s, 0, &d), VOLUX_OK);
}
static void edit_colour(volux_scene *s) {
    volux_light_desc d = *volux_scene_light(s, 1);
    d.color = (volux_vec3){1.0f, 0.2f, 0.1f};
    d.irradiance = 3.0f;
    assert_int_equal(volux_scene_set_light(s, 1, &d), VOLUX_OK);
}
static void edit_move_point(volux_scene *s) {
    volux_light_desc d = *volux_scene_light(s, 2);
    d.position.y -= 9.0f;
    d.position.x += 3.0f;
    assert_int_equal(volux_scene_set_light(s, 2, &d), VOLUX_OK);
}
static void edit_type(volux_scene *s) { /* point → spot */
    volux_light_desc d = *volux_scene_light(s, 2);
    d.type = VOLUX_LIGHT_SPOT;
    d.direction = (volux_vec3){1, -0.5f, -0.7f};
    d.cone_angle_deg = 25;
    d.falloff_angle_deg = 15;
    assert_int_equal(volux_scene_set_light(s, 2, &d), VOLUX_OK);
}
static void edit_add(volux_scene *s) {
    volux_light_desc d = lvf_point(2, -30, 1, 2000.0f);
    assert_int_equal(volux_scene_set_light(s, 5, &d), VOLUX_OK);
}
static void edit_remove(volux_scene *s) { assert_int_equal(volux_scene_remove_light(s, 3), VOLUX_OK); }
static void edit_toggle(volux_scene *s) { assert_int_equal(volux_scene_set_light_enabled(s, 1, 0), VOLUX_OK); }
static void edit_inside(volux_scene *s) { /* a point light moves into the volume: six groups */
    volux_light_desc d = *volux_scene_light(s, 2);
    d.position = (volux_vec3){1.2f, -2.3f, 0.7f};
    assert_int_equal(volux_scene_set_light(s, 2, &d), VOLUX_OK);
}

/* For each kind of light edit: the selective update equals an entire
 * rebuild, in both propagation modes and at a coarser scale. */
static void test_selective_update_equals_full_rebuild(void **state) {
    (void)state;
    static const struct {
        const char *name;
        edit_fn fn;
    } edits[] = {{"move", edit_move_small},   {"move across groups", edit_move_across_groups},
                 {"colour", edit_colour},      {"move point", edit_move_point},
                 {"type", edit_type},          {"add", edit_add},
                 {"remove", edit_remove},      {"toggle", edit_toggle},
                 {"into the volume", edit_inside}};
    for (int mode = 0; mode < 3; mode++)
        for (size_t e = 0; e < sizeof edits / sizeof edits[0]; e++) {
            fixture f;
            fx_setup(&f, 2);
            assert_int_equal(volux_scene_set_param(f.s, "lightvol", "cost_rule", 0, "selective"), VOLUX_OK);
            if (mode == 1) assert_int_equal(volux_scene_set_param(f.s, "lightvol", "propagation", 0, "sequential"), VOLUX_OK);
            if (mode == 2) assert_int_equal(volux_scene_set_param(f.s, "lightvol", "scale", 0.5, NULL), VOLUX_OK);
            volux_technique *t = lvf_create(f.ctx, f.s);
            edits[e].fn(f.s);
            lvf_update(t, f.s);
            const lightvol_state *st = lvf_state(t);
            assert_int_equal(st->stats.last, LV_UPDATE_SELECTIVE);
            assert_true(st->stats.changed == 1);
            float *fresh = fresh_volume(f.ctx, f.s);
            char what[96];
            snprintf(what, sizeof what, "%s (mode %d)", edits[e].name, mode);
            float *cur = lvf_copy(t);
            assert_same_volume(cur, fresh, lvf_count(st), SEL_TOL, what);
            free(cur);
            free(fresh);
            volux_technique_destroy(t);
            fx_teardown(&f);
        }
}

/* A state change whose old and new groups coincide runs remove and add in
 * the same passes: as many passes as the light has groups. */
static void test_state_change_shares_passes_when_groups_coincide(void **state) {
    (void)state;
    fixture f;
    fx_setup(&f, 2);
    volux_technique *t = lvf_create(f.ctx, f.s);
    const lightvol_state *st = lvf_state(t);
    unsigned g = st->applied[0].src.groups;
    int ng = __builtin_popcount(g);
    edit_move_small(f.s);
    lvf_update(t, f.s);
    assert_int_equal(st->applied[0].src.groups, g);
    assert_int_equal(st->stats.last, LV_UPDATE_SELECTIVE);
    assert_int_equal(st->stats.passes, ng);
    assert_int_equal(st->stats.entries, 2 * ng);
    /* sequential: remove and add in separate passes */
    assert_int_equal(volux_scene_set_param(f.s, "lightvol", "propagation", 0, "sequential"), VOLUX_OK);
    edit_move_small(f.s);
    lvf_update(t, f.s);
    assert_int_equal(st->stats.passes, 2 * ng);
    volux_technique_destroy(t);
    fx_teardown(&f);
}

/* Toggling a light off and on again restores the volume; each toggle is a
 * single signed pass set (selective). */
static void test_toggle_off_then_on_restores_the_volume(void **state) {
    (void)state;
    fixture f;
    fx_setup(&f, 2);
    volux_technique *t = lvf_create(f.ctx, f.s);
    const lightvol_state *st = lvf_state(t);
    float *before = lvf_copy(t);
    for (int slot = 0; slot < 4; slot++) {
        int ng = __builtin_popcount(st->applied[slot].src.groups);
        assert_int_equal(volux_scene_set_light_enabled(f.s, slot, 0), VOLUX_OK);
        lvf_update(t, f.s);
        assert_int_equal(st->stats.last, LV_UPDATE_SELECTIVE);
        assert_int_equal(st->stats.entries, ng);
        assert_int_equal(volux_scene_set_light_enabled(f.s, slot, 1), VOLUX_OK);
        lvf_update(t, f.s);
        assert_int_equal(st->stats.last, LV_UPDATE_SELECTIVE);
        float *cur = lvf_copy(t);
        assert_same_volume(cur, before, lvf_count(st), SEL_TOL, "toggle off/on");
        free(cur);
    }
    /* off and on between two updates: nothing to do */
    assert_int_equal(volux_scene_set_light_enabled(f.s, 0, 0), VOLUX_OK);
    assert_int_equal(volux_scene_set_light_enabled(f.s, 0, 1), VOLUX_OK);
    lvf_update(t, f.s);
    assert_int_equal(st->stats.last, LV_UPDATE_NONE);
    free(before);
    volux_technique_destroy(t);
    fx_teardown(&f);
}

static float frand(uint64_t *r) {
    *r = *r * 6364136223846793005ull + 1442695040888963407ull;
    return (float)((*r >> 40) & 0xffffff) / 16777216.0f;
}

static void random_edit(volux_scene *s, uint64_t *r) {
    int slot = (int)(frand(r) * 6.0f);
    const volux_light_desc *cur = volux_scene_light(s, slot);
    float kind = frand(r);
    if (!cur || kind < 0.1f) {
        volux_light_desc d;
        float t = frand(r);
        if (t < 0.4f) d = lvf_directional(frand(r) - 0.5f, -0.2f - frand(r), frand(r) - 0.5f, 0.5f + 3.0f * frand(r));
        else if (t < 0.75f) d = lvf_point(60 * frand(r) - 30, 10 + 30 * frand(r), 60 * frand(r) - 30, 5000 * frand(r) + 100);
        else
            d = lvf_spot(60 * frand(r) - 30, 20 + 10 * frand(r), 60 * frand(r) - 30, frand(r) - 0.5f, -1, frand(r) - 0.5f,
                         6000 * frand(r) + 100, 40, 30);
        d.color = (volux_vec3){0.2f + frand(r), 0.2f + frand(r), 0.2f + frand(r)};
        assert_int_equal(volux_scene_set_light(s, slot, &d), VOLUX_OK);
    } else if (kind < 0.2f) {
        assert_int_equal(volux_scene_remove_light(s, slot), VOLUX_OK);
    } else if (kind < 0.45f) {
        assert_int_equal(volux_scene_set_light_enabled(s, slot, !cur->enabled), VOLUX_OK);
    } else {
        volux_light_desc d = *cur;
        float a = (frand(r) - 0.5f) * 0.6f, c = cosf(a), sn = sinf(a);
        volux_vec3 v = d.direction, p = d.position;
        d.direction = (volux_vec3){c * v.x + sn * v.z, v.y, -sn * v.x + c * v.z};
        d.position = (volux_vec3){c * p.x + sn * p.z, p.y, -sn * p.x + c * p.z};
        if (frand(r) < 0.3f) d.color.x = 0.2f + frand(r);
        assert_int_equal(volux_scene_set_light(s, slot, &d), VOLUX_OK);
    }
}

/* Precision (deliverable 4): 1000 random light edits applied selectively,
 * never re-baselined, against a fresh rebuild. The stated tolerance is
 * 1e-4 of the largest illumination value (measured: see the message). */
static void test_thousand_random_edits_stay_within_tolerance(void **state) {
    (void)state;
    fixture f;
    fx_setup(&f, 2);
    assert_int_equal(volux_scene_set_param(f.s, "lightvol", "cost_rule", 0, "selective"), VOLUX_OK);
    assert_int_equal(volux_scene_set_param(f.s, "lightvol", "rebaseline_interval", 0, NULL), VOLUX_OK);
    assert_int_equal(volux_scene_set_param(f.s, "lightvol", "scale", 0.5, NULL), VOLUX_OK);
    volux_technique *t = lvf_create(f.ctx, f.s);
    const lightvol_state *st = lvf_state(t);
    uint64_t r = 99;
    int selective = 0, full = 0;
    double worst = 0.0;
    for (int e = 0; e < 1000; e++) {
        random_edit(f.s, &r);
        lvf_update(t, f.s);
        selective += st->stats.last == LV_UPDATE_SELECTIVE;
        full += st->stats.last == LV_UPDATE_FULL;
        if ((e + 1) % 250 == 0) {
            float *fresh = fresh_volume(f.ctx, f.s);
            float *cur = lvf_copy(t);
            double bmax, d = lvf_max_diff(cur, fresh, lvf_count(st), &bmax);
            free(cur);
            if (d / bmax > worst) worst = d / bmax;
            print_message("after %d edits: max |selective - fresh| = %.3g (%.3g of max %.3g)\n", e + 1, d, d / bmax,
                          bmax);
            assert_true(d <= 1e-4 * bmax);
            free(fresh);
        }
    }
    assert_int_equal(full, 0); /* edits that change nothing (e.g. a spot aimed away) cost nothing */
    print_message("%d selective updates, %d without change\n", selective, 1000 - selective);
    assert_true(selective > 500);
    assert_true(worst < 1e-4);
    volux_technique_destroy(t);
    fx_teardown(&f);
}

/* Re-baseline policy: after `rebaseline_interval` selective updates the next
 * light edit runs an entire update, which resets the drift. */
static void test_rebaseline_after_interval(void **state) {
    (void)state;
    fixture f;
    fx_setup(&f, 1);
    assert_int_equal(volux_scene_set_param(f.s, "lightvol", "cost_rule", 0, "selective"), VOLUX_OK);
    assert_int_equal(volux_scene_set_param(f.s, "lightvol", "rebaseline_interval", 3, NULL), VOLUX_OK);
    volux_technique *t = lvf_create(f.ctx, f.s);
    const lightvol_state *st = lvf_state(t);
    const lv_update_kind want[8] = {LV_UPDATE_SELECTIVE, LV_UPDATE_SELECTIVE, LV_UPDATE_SELECTIVE, LV_UPDATE_FULL,
                                    LV_UPDATE_SELECTIVE, LV_UPDATE_SELECTIVE, LV_UPDATE_SELECTIVE, LV_UPDATE_FULL};
    for (int e = 0; e < 8; e++) {
        assert_int_equal(volux_scene_set_light_enabled(f.s, 1, e & 1), VOLUX_OK);
        lvf_update(t, f.s);
        assert_int_equal(st->stats.last, want[e]);
    }
    assert_int_equal(st->stats.selective_since_full, 0);
    volux_technique_destroy(t);
    fx_teardown(&f);
}

/* §5 cost rules. Rule 1 (lights): selective iff at most half of the lights
 * changed. Rule 2 (passes): selective iff fewer passes than an entire
 * update, ties decided by rule 1. Work (default): rule 2 with the passes
 * weighted by the lights they carry. */
static void test_cost_rules_choose_as_the_paper_says(void **state) {
    (void)state;
    fixture f;
    fx_setup(&f, 2);
    volux_technique *t = lvf_create(f.ctx, f.s);
    const lightvol_state *st = lvf_state(t);
    /* lights rule: 1 of 4, then 2 of 4 (exactly half: selective), then 3 of 4 */
    assert_int_equal(volux_scene_set_param(f.s, "lightvol", "cost_rule", 0, "lights"), VOLUX_OK);
    for (int n = 1; n <= 3; n++) {
        for (int i = 0; i < n; i++) {
            volux_light_desc d = *volux_scene_light(f.s, i);
            d.color.y *= 0.9f;
            assert_int_equal(volux_scene_set_light(f.s, i, &d), VOLUX_OK);
        }
        lvf_update(t, f.s);
        assert_int_equal(st->stats.changed, n);
        assert_int_equal(st->stats.last, n <= 2 ? LV_UPDATE_SELECTIVE : LV_UPDATE_FULL);
    }
    /* passes rule: the same 3-of-4 change; selective needs every pass of the
     * changed lights twice over, compare with the estimate it recorded */
    assert_int_equal(volux_scene_set_param(f.s, "lightvol", "cost_rule", 0, "passes"), VOLUX_OK);
    for (int i = 0; i < 3; i++) {
        volux_light_desc d = *volux_scene_light(f.s, i);
        d.color.y *= 0.9f;
        assert_int_equal(volux_scene_set_light(f.s, i, &d), VOLUX_OK);
    }
    lvf_update(t, f.s);
    int ps = st->stats.passes_selective, pf = st->stats.passes_full;
    assert_int_equal(st->stats.last, ps < pf ? LV_UPDATE_SELECTIVE : LV_UPDATE_FULL);
    /* four lights all from one direction, one more from another: changing
     * three of the four coherent ones is > 50 % but needs fewer passes than
     * an entire update (which must also sweep the fifth light's groups) */
    for (int i = 0; i < 4; i++) {
        volux_light_desc d = lvf_directional(0.3f, -1, 0.05f, 1.0f + 0.1f * (float)i);
        assert_int_equal(volux_scene_set_light(f.s, i, &d), VOLUX_OK);
    }
    volux_light_desc other = lvf_directional(-0.3f, 0.2f, 1, 1.0f);
    assert_int_equal(volux_scene_set_light(f.s, 4, &other), VOLUX_OK);
    lvf_update(t, f.s);
    for (int i = 0; i < 3; i++) {
        volux_light_desc d = *volux_scene_light(f.s, i);
        d.irradiance = 2.0f;
        assert_int_equal(volux_scene_set_light(f.s, i, &d), VOLUX_OK);
    }
    lvf_update(t, f.s);
    assert_int_equal(st->stats.changed, 3);
    assert_true(st->stats.passes_selective < st->stats.passes_full);
    assert_int_equal(st->stats.last, LV_UPDATE_SELECTIVE);
    /* work rule (default): a point light's state change propagates it twice
     * (remove + add), which can cost more than an entire update carrying it
     * once beside cheap directional lights — the pass count alone does not
     * see that. A directional light's change stays selective. */
    for (int i = 0; i < 5; i++) assert_int_equal(volux_scene_remove_light(f.s, i), VOLUX_OK);
    volux_light_desc pt = lvf_point(-30, 20, 25, 4000.0f), d1 = lvf_directional(0.2f, -1, -0.3f, 1.0f),
                     d2 = lvf_directional(-0.7f, -0.4f, 0.5f, 1.0f);
    assert_int_equal(volux_scene_set_light(f.s, 0, &pt), VOLUX_OK);
    assert_int_equal(volux_scene_set_light(f.s, 1, &d1), VOLUX_OK);
    assert_int_equal(volux_scene_set_light(f.s, 2, &d2), VOLUX_OK);
    assert_int_equal(volux_scene_set_param(f.s, "lightvol", "cost_rule", 0, "work"), VOLUX_OK);
    /* (the weights are the portable kernel's; with the AVX2 kernels a point
     * light costs ~3x a directional one, not ~13x: below) */
    assert_int_equal(volux_scene_set_param(f.s, "lightvol", "kernel", 0, "scalar"), VOLUX_OK);
    lvf_update(t, f.s);
    pt.position.x -= 2.0f;
    assert_int_equal(volux_scene_set_light(f.s, 0, &pt), VOLUX_OK);
    lvf_update(t, f.s);
    assert_true(st->stats.work_selective >= st->stats.work_full);
    assert_int_equal(st->stats.last, LV_UPDATE_FULL);
    assert_true(st->stats.passes_selective <= st->stats.passes_full); /* rule 2 alone would go selective */
    d1.direction.x += 0.1f;
    assert_int_equal(volux_scene_set_light(f.s, 1, &d1), VOLUX_OK);
    lvf_update(t, f.s);
    assert_int_equal(st->stats.last, LV_UPDATE_SELECTIVE);
    if (volux_lightvol_simd_available()) {
        /* the AVX2 kernels' weights: the decision follows their estimate */
        assert_int_equal(volux_scene_set_param(f.s, "lightvol", "kernel", 0, "simd"), VOLUX_OK);
        lvf_update(t, f.s);
        pt.position.x += 2.0f;
        assert_int_equal(volux_scene_set_light(f.s, 0, &pt), VOLUX_OK);
        lvf_update(t, f.s);
        assert_int_equal(st->stats.last, st->stats.work_selective < st->stats.work_full ? LV_UPDATE_SELECTIVE
                                                                                         : LV_UPDATE_FULL);
    }
    /* all lights removed: an entire update (a clear) */
    for (int i = 0; i < 3; i++) assert_int_equal(volux_scene_remove_light(f.s, i), VOLUX_OK);
    lvf_update(t, f.s);
    assert_int_equal(st->stats.last, LV_UPDATE_FULL);
    for (size_t i = 0; i < lvf_count(st); i++) assert_true(lvf_value(st, i) == 0.0f);
    volux_technique_destroy(t);
    fx_teardown(&f);
}

/* Sequential and coherent propagation give the same volume. */
static void test_sequential_equals_coherent(void **state) {
    (void)state;
    fixture f;
    fx_setup(&f, 2);
    float *coh = fresh_volume(f.ctx, f.s);
    assert_int_equal(volux_scene_set_param(f.s, "lightvol", "propagation", 0, "sequential"), VOLUX_OK);
    volux_technique *t = lvf_create(f.ctx, f.s);
    const lightvol_state *st = lvf_state(t);
    assert_true(st->stats.passes > 4);
    float *cur = lvf_copy(t);
    assert_same_volume(cur, coh, lvf_count(st), SEL_TOL, "sequential vs coherent");
    free(cur);
    free(coh);
    volux_technique_destroy(t);
    fx_teardown(&f);
}

/* Bit-identical volumes and images for 1 and 2 threads. 96³ voxels: the
 * sweeps run slices of fewer than 16384 voxel·lights on one thread, so a
 * smaller volume would not exercise the parallel sweep at all. */
static void test_thread_count_independence(void **state) {
    (void)state;
    float *vol[2] = {NULL, NULL};
    volux_image img[2];
    memset(img, 0, sizeof img);
    size_t n = 0;
    for (int th = 0; th < 2; th++) {
        fixture f;
        fx_setup_n(&f, th + 1, 96);
        assert_int_equal(volux_scene_set_param(f.s, "lightvol", "local_shading", 0.5, NULL), VOLUX_OK);
        volux_technique *t = lvf_create(f.ctx, f.s);
        edit_move_point(f.s);
        lvf_update(t, f.s);
        vol[th] = lvf_copy(t);
        n = lvf_count(lvf_state(t));
        volux_framebuffer *fb;
        assert_int_equal(volux_framebuffer_create(f.ctx, 24, 24, &fb), VOLUX_OK);
        volux_render_limits lim = {3, 0, 0};
        assert_int_equal(volux_render(t, f.s, fb, &lim, NULL), VOLUX_OK);
        volux_image tmp;
        assert_int_equal(volux_framebuffer_resolve(fb, &tmp), VOLUX_OK);
        img[th].width = tmp.width;
        img[th].height = tmp.height;
        img[th].rgb = malloc(3 * (size_t)tmp.width * (size_t)tmp.height * sizeof(float));
        memcpy(img[th].rgb, tmp.rgb, 3 * (size_t)tmp.width * (size_t)tmp.height * sizeof(float));
        volux_image_free(f.ctx, &tmp);
        volux_framebuffer_destroy(fb);
        volux_technique_destroy(t);
        fx_teardown(&f);
    }
    assert_memory_equal(vol[0], vol[1], n * sizeof(float));
    assert_memory_equal(img[0].rgb, img[1].rgb, 3 * 24 * 24 * sizeof(float));
    double sum = 0;
    for (int i = 0; i < 3 * 24 * 24; i++) sum += img[0].rgb[i];
    assert_true(sum > 0.0);
    for (int th = 0; th < 2; th++) {
        free(vol[th]);
        free(img[th].rgb);
    }
}

static void render_image(volux_context *ctx, volux_technique *t, volux_scene *s, float *out) {
    volux_framebuffer *fb;
    assert_int_equal(volux_framebuffer_create(ctx, 24, 24, &fb), VOLUX_OK);
    volux_render_limits lim = {2, 0, 0};
    assert_int_equal(volux_render(t, s, fb, &lim, NULL), VOLUX_OK);
    volux_image img;
    assert_int_equal(volux_framebuffer_resolve(fb, &img), VOLUX_OK);
    memcpy(out, img.rgb, 3 * 24 * 24 * sizeof(float));
    volux_image_free(ctx, &img);
    volux_framebuffer_destroy(fb);
}

static void edit_tf(volux_scene *s) {
    volux_transfer_desc d = *volux_scene_transfer(s);
    d.density_scale = 1.7f;
    assert_int_equal(volux_scene_set_transfer(s, &d), VOLUX_OK);
}
static void edit_tf_color(volux_scene *s) {
    volux_transfer_desc d = *volux_scene_transfer(s);
    d.albedo = 0.5f;
    assert_int_equal(volux_scene_set_transfer(s, &d), VOLUX_OK);
}
static void edit_tf_curve(volux_scene *s) {
    volux_transfer_desc d = *volux_scene_transfer(s);
    static const volux_tf_scalar_point p[3] = {{0, 0}, {0.3f, 0}, {1000, 1500}};
    d.opacity = p;
    d.n_opacity = 3;
    assert_int_equal(volux_scene_set_transfer(s, &d), VOLUX_OK);
}
static void edit_phase(volux_scene *s) {
    volux_transfer_desc d = *volux_scene_transfer(s);
    d.anisotropy = 0.6f;
    assert_int_equal(volux_scene_set_transfer(s, &d), VOLUX_OK);
}
static void edit_camera(volux_scene *s) {
    volux_camera_desc d = *volux_scene_camera_desc(s);
    d.azimuth_deg += 40;
    assert_int_equal(volux_scene_set_camera(s, &d), VOLUX_OK);
}
static void edit_params(volux_scene *s) {
    assert_int_equal(volux_scene_set_param(s, "lightvol", "scatter_cone", 5.0, NULL), VOLUX_OK);
    assert_int_equal(volux_scene_set_param(s, "lightvol", "local_shading", 0.7, NULL), VOLUX_OK);
}
static void edit_scale(volux_scene *s) { assert_int_equal(volux_scene_set_param(s, "lightvol", "scale_y", 0.5, NULL), VOLUX_OK); }
static void edit_volume(volux_scene *s) {
    /* a new time step: same dims, other data */
    volux_volume *old = volux_scene_volume(s);
    int dims[3];
    volux_volume_dims(old, dims);
    float *d = random_medium(11, 0.6f);
    volux_volume_desc vd;
    memset(&vd, 0, sizeof vd);
    memcpy(vd.dims, dims, sizeof dims);
    vd.spacing[0] = vd.spacing[1] = vd.spacing[2] = 1.0;
    vd.type = VOLUX_FLOAT32;
    vd.data = d;
    volux_volume *v;
    assert_int_equal(volux_volume_create(volux_scene_context(s), &vd, &v), VOLUX_OK);
    assert_int_equal(volux_scene_set_volume(s, v), VOLUX_OK);
    volux_volume_release(v);
    free(d);
}

/* Incremental update == fresh render, for every edit kind. Light edits go
 * through selective updates (float sums in another order: tiny tolerance);
 * everything else must be bit-identical. */
static void test_incremental_render_equals_fresh_render(void **state) {
    (void)state;
    static const struct {
        const char *name;
        edit_fn fn;
        int exact;
    } edits[] = {{"tf", edit_tf, 1},           {"tf_curve", edit_tf_curve, 1}, {"tf_color", edit_tf_color, 1},
                 {"phase", edit_phase, 1},     {"camera", edit_camera, 1},     {"params", edit_params, 1},
                 {"scale", edit_scale, 1},     {"time_step", edit_volume, 1},  {"light", edit_move_small, 0},
                 {"light_add", edit_add, 0},   {"light_toggle", edit_toggle, 0}, {"light type", edit_type, 0}};
    float a[3 * 24 * 24], b[3 * 24 * 24];
    for (size_t e = 0; e < sizeof edits / sizeof edits[0]; e++) {
        fixture f;
        fx_setup(&f, 2);
        assert_int_equal(volux_scene_set_param(f.s, "lightvol", "cost_rule", 0, "selective"), VOLUX_OK);
        volux_technique *t = lvf_create(f.ctx, f.s);
        render_image(f.ctx, t, f.s, a); /* caches warm */
        edits[e].fn(f.s);
        lvf_update(t, f.s);
        render_image(f.ctx, t, f.s, a);
        volux_technique *fresh = lvf_create(f.ctx, f.s);
        render_image(f.ctx, fresh, f.s, b);
        double m = 0, d = 0;
        for (int i = 0; i < 3 * 24 * 24; i++) {
            if (fabs(b[i]) > m) m = fabs(b[i]);
            if (fabs(a[i] - b[i]) > d) d = fabs(a[i] - b[i]);
        }
        assert_true(m > 0.0);
        if (edits[e].exact ? d != 0.0 : d > 1e-5 * m)
            fail_msg("%s: incremental image differs from a fresh render by %g (max %g)", edits[e].name, d, m);
        volux_technique_destroy(fresh);
        volux_technique_destroy(t);
        fx_teardown(&f);
    }
}

/* The illumination volume's size does not depend on the number of lights;
 * slice buffers grow with the lights of one pass only up to
 * max_lights_per_pass. What grows is the record of the applied light per
 * slot (a few hundred bytes each). */
static void test_memory_is_independent_of_the_number_of_lights(void **state) {
    (void)state;
    fixture f;
    fx_setup(&f, 1);
    assert_int_equal(volux_scene_set_param(f.s, "lightvol", "max_lights_per_pass", 2, NULL), VOLUX_OK);
    volux_technique *t = lvf_create(f.ctx, f.s);
    /* per slot: the applied record, the two prepared-light entries and the
     * ignored-light warning mark */
    const lightvol_state *st = lvf_state(t);
#define PER_SLOT()                                                                                            \
    (sizeof(lv_applied) * (size_t)st->applied_cap + 2 * sizeof(volux_prepared_light) * (size_t)st->rc.lights.cap + \
     sizeof(uint32_t) * (size_t)st->rc.ignored_cap)
    size_t vol4 = st->vol_bytes, mem4 = volux_technique_memory_bytes(t) - PER_SLOT();
    for (int i = 4; i < 40; i++) {
        volux_light_desc d = lvf_directional(0.1f, -1, 0.02f * (float)i, 0.1f);
        assert_int_equal(volux_scene_set_light(f.s, i, &d), VOLUX_OK);
    }
    lvf_update(t, f.s);
    assert_int_equal(lvf_state(t)->vol_bytes, vol4);
    assert_true(lvf_state(t)->applied_cap >= 40);
    assert_int_equal(volux_technique_memory_bytes(t) - PER_SLOT(), mem4);
#undef PER_SLOT
    assert_int_equal(vol4, ((size_t)N * N * N * 6 + LV_VOL_PAD) * sizeof(float)); /* precision float */
    volux_technique_destroy(t);
    fx_teardown(&f);
}

/* Lights that do not take part: environment with env_directions = 0
 * (ignored; tests/physics/test_lightvol_env.c), disabled, zero power, a
 * spot aimed away from the volume. */
static void test_lights_that_do_not_propagate(void **state) {
    (void)state;
    fixture f;
    fx_setup(&f, 1);
    for (int i = 0; i < 4; i++) assert_int_equal(volux_scene_remove_light(f.s, i), VOLUX_OK);
    volux_light_desc env, off = lvf_directional(0, -1, 0, 1.0f), zero = lvf_point(0, 30, 0, 0.0f),
                          away = lvf_spot(0, 30, 0, 0, 1, 0, 1000.0f, 20, 10);
    volux_light_desc_defaults(&env, VOLUX_LIGHT_ENVIRONMENT);
    off.enabled = 0;
    assert_int_equal(volux_scene_set_light(f.s, 0, &env), VOLUX_OK);
    assert_int_equal(volux_scene_set_light(f.s, 1, &off), VOLUX_OK);
    assert_int_equal(volux_scene_set_light(f.s, 2, &zero), VOLUX_OK);
    assert_int_equal(volux_scene_set_light(f.s, 3, &away), VOLUX_OK);
    assert_int_equal(volux_scene_set_param(f.s, "lightvol", "env_directions", 0, NULL), VOLUX_OK);
    volux_technique *t = lvf_create(f.ctx, f.s);
    const lightvol_state *st = lvf_state(t);
    assert_int_equal(st->stats.passes, 0);
    for (size_t i = 0; i < lvf_count(st); i++) assert_true(lvf_value(st, i) == 0.0f);
    volux_technique_destroy(t);
    fx_teardown(&f);
}

/* Bad parameters: clear errors naming the parameter. */
static void test_bad_parameters_are_named(void **state) {
    (void)state;
    fixture f;
    fx_setup(&f, 1);
    static const struct {
        const char *name;
        double number;
        const char *string;
        const char *expect;
    } bad[] = {{"propagation", 0, "diagonal", "techniques.lightvol.propagation"},
               {"cost_rule", 0, "cheap", "techniques.lightvol.cost_rule"},
               {"scale_x", 0.01, NULL, "techniques.lightvol.scale_x"},
               {"scale", 2.0, NULL, "techniques.lightvol.scale"},
               {"forward_scattering", 1.5, NULL, "techniques.lightvol.forward_scattering"},
               {"max_lights_per_pass", 0, NULL, "techniques.lightvol.max_lights_per_pass"},
               {"kernel", 0, "gpu", "techniques.lightvol.kernel"},
               {"positional_grouping", 0, "corner", "techniques.lightvol.positional_grouping"},
               {"budget_ms", -1.0, NULL, "techniques.lightvol.budget_ms"},
               {"budget_slices", -2, NULL, "techniques.lightvol.budget_slices"},
               {"env_directions", 257, NULL, "techniques.lightvol.env_directions"}};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        fixture g;
        fx_setup(&g, 1);
        assert_int_equal(volux_scene_set_param(g.s, "lightvol", bad[i].name, bad[i].number, bad[i].string), VOLUX_OK);
        volux_technique *t = NULL;
        assert_int_equal(volux_technique_create(g.ctx, "lightvol", g.s, &t), VOLUX_ERR_INVALID);
        if (!strstr(volux_context_error(g.ctx), bad[i].expect))
            fail_msg("'%s' does not name %s", volux_context_error(g.ctx), bad[i].expect);
        fx_teardown(&g);
    }
    /* local shading needs the direction channel */
    assert_int_equal(volux_scene_set_param(f.s, "lightvol", "directional", 0, NULL), VOLUX_OK);
    assert_int_equal(volux_scene_set_param(f.s, "lightvol", "local_shading", 0.5, NULL), VOLUX_OK);
    volux_technique *t = NULL;
    assert_int_equal(volux_technique_create(f.ctx, "lightvol", f.s, &t), VOLUX_ERR_INVALID);
    assert_non_null(strstr(volux_context_error(f.ctx), "techniques.lightvol.local_shading"));
    fx_teardown(&f);
}

/* precision "auto" (the default): an entire update stores the volume in
 * bfloat16 (half the bytes of float) within the rounding of its passes of
 * the float volume; the first selective update moves it to float through
 * an entire update (no bfloat16 rounding left), the next ones are
 * selective and equal a float rebuild as before. */
static void test_default_precision_is_bfloat16_until_light_edits(void **state) {
    (void)state;
    fixture f;
    fx_setup(&f, 2);
    assert_int_equal(volux_scene_set_param(f.s, "lightvol", "cost_rule", 0, "selective"), VOLUX_OK);
    float *ref = fresh_volume(f.ctx, f.s); /* precision float (lvf_create) */
    assert_int_equal(volux_scene_set_param(f.s, "lightvol", "precision", 0, "auto"), VOLUX_OK);
    volux_technique *t = NULL;
    assert_int_equal(volux_technique_create(f.ctx, "lightvol", f.s, &t), VOLUX_OK);
    const lightvol_state *st = lvf_state(t);
    size_t n = lvf_count(st);
    assert_non_null(st->vol);
    assert_null(st->volf);
    assert_int_equal(st->vol_bytes, (n + LV_VOL_PAD) * sizeof(uint16_t));
    /* each value: the float sums of at most six group passes, each rounded
     * to 8 significant bits (≤ 2⁻⁸ of the partial sum, all light ≥ 0 but
     * the direction channels, which cancel: checked against the maximum) */
    double bmax = 0.0, worst = 0.0;
    for (size_t i = 0; i < n; i++) bmax = fmax(bmax, fabs((double)ref[i]));
    for (size_t i = 0; i < n; i++) {
        double d = fabs((double)lvf_value(st, i) - (double)ref[i]);
        double lim = (i % 6 < 3 ? fabs((double)ref[i]) : bmax) * 6.0 * VOLUX_BF16_REL_ERROR + 1e-6 * bmax;
        if (d > lim) fail_msg("value %zu: bfloat16 %g vs float %g", i, (double)lvf_value(st, i), (double)ref[i]);
        if (i % 6 < 3 && ref[i] > 1e-3 * bmax) worst = fmax(worst, d / fabs((double)ref[i]));
    }
    print_message("bfloat16 vs float volume: worst relative error %.3g (rgb, above 1e-3 of the max)\n", worst);
    assert_true(worst > 0.0); /* it is stored rounded */
    size_t mem_bf16 = volux_technique_memory_bytes(t);
    /* first light edit: entire, into a float volume */
    edit_colour(f.s);
    lvf_update(t, f.s);
    assert_int_equal(st->stats.last, LV_UPDATE_FULL);
    assert_string_equal(st->stats.reason, "float volume for selective updates");
    assert_null(st->vol);
    assert_non_null(st->volf);
    assert_int_equal(volux_technique_memory_bytes(t) - mem_bf16, (n + LV_VOL_PAD) * sizeof(uint16_t));
    float *fresh = fresh_volume(f.ctx, f.s), *cur = lvf_copy(t);
    assert_same_volume(cur, fresh, n, SEL_TOL, "after the switch to float");
    free(cur);
    free(fresh);
    /* the next ones are selective */
    edit_move_small(f.s);
    lvf_update(t, f.s);
    assert_int_equal(st->stats.last, LV_UPDATE_SELECTIVE);
    fresh = fresh_volume(f.ctx, f.s), cur = lvf_copy(t);
    assert_same_volume(cur, fresh, n, SEL_TOL, "selective on the float volume");
    free(cur);
    free(fresh);
    free(ref);
    volux_technique_destroy(t);
    fx_teardown(&f);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_selective_update_equals_full_rebuild),
        cmocka_unit_test(test_default_precision_is_bfloat16_until_light_edits),
        cmocka_unit_test(test_state_change_shares_passes_when_groups_coincide),
        cmocka_unit_test(test_toggle_off_then_on_restores_the_volume),
        cmocka_unit_test(test_thousand_random_edits_stay_within_tolerance),
        cmocka_unit_test(test_rebaseline_after_interval),
        cmocka_unit_test(test_cost_rules_choose_as_the_paper_says),
        cmocka_unit_test(test_sequential_equals_coherent),
        cmocka_unit_test(test_thread_count_independence),
        cmocka_unit_test(test_incremental_render_equals_fresh_render),
        cmocka_unit_test(test_memory_is_independent_of_the_number_of_lights),
        cmocka_unit_test(test_lights_that_do_not_propagate),
        cmocka_unit_test(test_bad_parameters_are_named),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
