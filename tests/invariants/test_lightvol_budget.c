/*
 * tests/invariants/test_lightvol_budget.c — §7.3's incremental update
 * (techniques.lightvol.budget_slices / budget_ms): an update propagates at
 * most one budget of slice steps, renders see the partly updated volume, and
 * refine steps (volux_technique_refine) finish it — bit-identical to the same
 * update run at once, with the pending work falling at every step; light
 * edits made while a propagation runs are queued behind it; an entire
 * update (transfer function edit) is budgeted too. Budgets in slices keep
 * the test independent of timing; budget_ms only changes where the steps
 * are cut, never the result.
 */
#include <math.h>
#include <stdio.h>

#include "lightvol_fixture.h"
#include "techniques/lightvol/sweep.h"

enum { NX = 30, NY = 26, NZ = 21 };

static float *medium(void) {
    float *d = malloc((size_t)NX * NY * NZ * sizeof(float));
    assert_non_null(d);
    uint64_t r = 5;
    for (int k = 0; k < NZ; k++)
        for (int j = 0; j < NY; j++)
            for (int i = 0; i < NX; i++) {
                r = r * 6364136223846793005ull + 1442695040888963407ull;
                float x = (float)((r >> 40) & 0xffff) / 65535.0f;
                float dx = (float)i - 14.0f, dy = (float)j - 12.0f, dz = (float)k - 10.0f;
                float blob = dx * dx + dy * dy + 2.0f * dz * dz < 50.0f ? 0.7f : 0.0f;
                d[((size_t)k * NY + (size_t)j) * NX + (size_t)i] = 0.08f * x + blob;
            }
    return d;
}

/* A directional light mostly along −x (x sweeps: staged slices), another
 * along −y, a point light and a spot. */
static volux_scene *scene(volux_context *ctx, const float *data, const char *budget_name, double budget) {
    static const float colour[3] = {0.9f, 0.6f, 0.4f};
    volux_scene *s = lvf_scene(ctx, NX, NY, NZ, data, 0.8f, colour);
    volux_light_desc l[4] = {lvf_directional(-1.0f, -0.3f, 0.2f, 2.0f), lvf_directional(0.2f, -1.0f, -0.4f, 1.0f),
                             lvf_point(40.0f, 10.0f, -30.0f, 8000.0f),
                             lvf_spot(-10.0f, 35.0f, 20.0f, 0.2f, -1.0f, -0.5f, 9000.0f, 30.0f, 20.0f)};
    for (int i = 0; i < 4; i++) assert_int_equal(volux_scene_set_light(s, i, &l[i]), VOLUX_OK);
    assert_int_equal(volux_scene_set_param(s, "lightvol", "forward_scattering", 0.5, NULL), VOLUX_OK);
    assert_int_equal(volux_scene_set_param(s, "lightvol", "scatter_cone", 8.0, NULL), VOLUX_OK);
    if (budget_name) assert_int_equal(volux_scene_set_param(s, "lightvol", budget_name, budget, NULL), VOLUX_OK);
    return s;
}

/* Refines until nothing is pending; every step that changes the volume
 * lowers the pending work. Returns the number of steps. */
static int finish(volux_technique *t, volux_scene *s) {
    int steps = 0;
    for (;;) {
        uint64_t before = volux_technique_pending(t);
        int refined = 0, more = 0;
        assert_int_equal(volux_technique_refine(t, s, &refined, &more), VOLUX_OK);
        uint64_t after = volux_technique_pending(t);
        if (refined && !(after < before))
            fail_msg("a refine step left %llu pending (before %llu)", (unsigned long long)after,
                     (unsigned long long)before);
        assert_int_equal(more, after > 0);
        steps += refined;
        if (!more) return steps;
        assert_true(steps < 100000);
    }
}

static void assert_same_volume(const volux_technique *a, const volux_technique *b, const char *what) {
    size_t n = lvf_count(lvf_state(a));
    assert_int_equal(n, lvf_count(lvf_state(b)));
    if (memcmp(lvf_state(a)->volf, lvf_state(b)->volf, n * sizeof(float)) != 0) { /* precision float */
        float *x = lvf_copy(a), *y = lvf_copy(b);
        double bmax, d = lvf_max_diff(x, y, n, &bmax);
        free(x);
        free(y);
        fail_msg("%s: budgeted volume differs from the update at once by %g (max %g)", what, d, bmax);
    }
}

typedef void (*edit_fn)(volux_scene *s, int round);

static void rotate_light(volux_scene *s, int round) {
    volux_light_desc d = *volux_scene_light(s, round % 2);
    d.direction.z += 0.15f;
    assert_int_equal(volux_scene_set_light(s, round % 2, &d), VOLUX_OK);
}

static void move_point(volux_scene *s, int round) {
    volux_light_desc d = *volux_scene_light(s, 2);
    d.position.y += 6.0f * (float)(round + 1);
    assert_int_equal(volux_scene_set_light(s, 2, &d), VOLUX_OK);
}

static void tf_edit(volux_scene *s, int round) {
    (void)round;
    assert_int_equal(volux_edit_apply(volux_edit_find("tf"), s, 0), VOLUX_OK);
}

/* The two instances render the same image, bit for bit. */
static void assert_same_images(volux_context *ctx, volux_scene *sa, volux_technique *a, volux_scene *sb,
                               volux_technique *b) {
    volux_image ia = tu_render_with(ctx, sa, a), ib = tu_render_with(ctx, sb, b);
    assert_true(tu_max_abs_diff(&ia, &ib) == 0.0);
    volux_image_free(ctx, &ia);
    volux_image_free(ctx, &ib);
}

/* One refine step propagates exactly `slices` slice steps (or what is
 * left, if less). */
static void assert_refine_spends(volux_technique *t, volux_scene *s, uint64_t slices) {
    uint64_t before = volux_technique_pending(t);
    int refined = 0, more = 0;
    assert_int_equal(volux_technique_refine(t, s, &refined, &more), VOLUX_OK);
    assert_true(refined);
    assert_true(more == (volux_technique_pending(t) > 0));
    assert_int_equal(before - volux_technique_pending(t), before < slices ? before : slices);
}

/* a light edit, then a transfer function edit while it propagates (the
 * entire update replaces the job) */
static void light_then_tf(volux_scene *s, int round) {
    if (round == 0) move_point(s, 0);
    else tf_edit(s, round);
}

/* One edit (or several in a row, the later ones while the first still
 * propagates: they are queued and propagated as one update) applied to an
 * instance updating at once and to a budgeted one: after its refine steps
 * the budgeted volume is bit for bit the other. */
static void check_edit(const char *what, edit_fn edit, int edits, const char *budget_name, double budget,
                       int threads) {
    volux_context *ctx = tu_context(threads);
    float *data = medium();
    volux_scene *sa = scene(ctx, data, NULL, 0), *sb = scene(ctx, data, budget_name, budget);
    volux_technique *a = lvf_create(ctx, sa), *b = lvf_create(ctx, sb);
    assert_int_equal(volux_technique_pending(b), 0); /* a new volume is built at once */
    assert_same_volume(a, b, "create");
    float *before = lvf_copy(b);
    for (int e = 0; e < edits; e++) {
        edit(sa, e);
        edit(sb, e);
        /* edits made while b propagates the first wait in one queued
         * update: a makes the same two updates */
        if (e == 0 || e == edits - 1) lvf_update(a, sa);
        lvf_update(b, sb);
        assert_int_equal(volux_technique_pending(a), 0);
    }
    if (budget_name && !strcmp(budget_name, "budget_slices")) {
        /* one budget done, the rest pending: the render sees a volume between
         * the old and the new one */
        assert_true(volux_technique_pending(b) > 0);
        size_t n = lvf_count(lvf_state(b));
        assert_true(memcmp(lvf_state(b)->volf, before, n * sizeof(float)) != 0);
        assert_true(memcmp(lvf_state(b)->volf, lvf_state(a)->volf, n * sizeof(float)) != 0);
        volux_image img = tu_render_with(ctx, sb, b);
        volux_image_free(ctx, &img);
    }
    free(before);
    int steps = finish(b, sb);
    if (budget_name && !strcmp(budget_name, "budget_slices")) assert_true(steps >= 2);
    assert_same_volume(a, b, what);
    assert_same_images(ctx, sa, a, sb, b);
    volux_technique_destroy(a);
    volux_technique_destroy(b);
    volux_scene_destroy(sa);
    volux_scene_destroy(sb);
    free(data);
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

static void test_light_edit_converges_bit_identically(void **state) {
    (void)state;
    check_edit("directional light rotated", rotate_light, 1, "budget_slices", 5, 1);
    check_edit("point light moved", move_point, 1, "budget_slices", 7, 1);
    check_edit("point light moved, 2 threads", move_point, 1, "budget_slices", 9, 2);
}

static void test_entire_update_converges_bit_identically(void **state) {
    (void)state;
    check_edit("transfer function edit", tf_edit, 1, "budget_slices", 11, 1);
}

static void test_edits_during_propagation_are_queued(void **state) {
    (void)state;
    check_edit("two rotations in a row", rotate_light, 2, "budget_slices", 6, 1);
    check_edit("three point moves in a row", move_point, 3, "budget_slices", 13, 1);
    check_edit("light edit then tf edit", light_then_tf, 2, "budget_slices", 4, 1);
}

/* An edit between the end of a job and the start of the plan queued behind
 * it joins that plan (the plan then covers both edits). */
static void test_edit_after_a_job_joins_the_queue(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    float *data = medium();
    volux_scene *sa = scene(ctx, data, NULL, 0), *sb = scene(ctx, data, "budget_slices", 10);
    volux_technique *a = lvf_create(ctx, sa), *b = lvf_create(ctx, sb);
    for (int e = 0; e < 3; e++) {
        move_point(sa, e);
        move_point(sb, e);
        rotate_light(sa, e); /* slot 0 or 1 as well: the later plan has two lights */
        rotate_light(sb, e);
        if (e != 1) lvf_update(a, sa); /* edits 2 and 3 reach a in one update */
        lvf_update(b, sb);
        if (e == 1) {
            /* finish the first job: the second waits, not started */
            while (lvf_state(b)->job.active) assert_int_equal(volux_technique_refine(b, sb, NULL, NULL), VOLUX_OK);
            assert_true(lvf_state(b)->job.queued > 0);
        }
    }
    finish(b, sb);
    assert_same_volume(a, b, "edit after a job, before its queued plan");
    volux_technique_destroy(a);
    volux_technique_destroy(b);
    volux_scene_destroy(sa);
    volux_scene_destroy(sb);
    free(data);
    volux_context_destroy(ctx);
}

/* budget_ms only changes where the steps are cut. */
static void test_budget_ms_converges_bit_identically(void **state) {
    (void)state;
    check_edit("point light moved, budget_ms", move_point, 2, "budget_ms", 0.05, 1);
    check_edit("tf edit, budget_ms", tf_edit, 1, "budget_ms", 0.05, 1);
}

/* Each step propagates at most budget_slices slice steps: the pending work
 * falls by exactly the budget until the last step. */
static void test_each_step_spends_the_budget(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    float *data = medium();
    volux_scene *s = scene(ctx, data, "budget_slices", 6);
    volux_technique *t = lvf_create(ctx, s);
    move_point(s, 0);
    lvf_update(t, s);
    const lightvol_state *st = lvf_state(t);
    assert_int_equal(st->stats.last, LV_UPDATE_SELECTIVE);
    uint64_t total = 0;
    for (int p = 0; p < st->job.np; p++) total += (uint64_t)st->dims[st->job.passes[p].g / 2];
    assert_int_equal(volux_technique_pending(t) + 6, total);
    while (volux_technique_pending(t) > 0) assert_refine_spends(t, s, 6);
    /* switching the budget off finishes a propagation at the next update */
    move_point(s, 1);
    lvf_update(t, s);
    assert_true(volux_technique_pending(t) > 0);
    assert_int_equal(volux_scene_set_param(s, "lightvol", "budget_slices", 0, NULL), VOLUX_OK);
    lvf_update(t, s);
    assert_int_equal(volux_technique_pending(t), 0);
    volux_technique_destroy(t);
    volux_scene_destroy(s);
    free(data);
    volux_context_destroy(ctx);
}

/* volux_technique_set_budget (the viewer's per-frame budget): it wins over
 * the scene's budget, leaves the scene alone, converges bit for bit to the
 * update at once, and 0 (or NaN) gives the scene's own budget back. A
 * budget below one step's measured time is exactly one slice step per call
 * ("at least one step"), which keeps the test independent of timing. */
static void test_front_end_budget(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    float *data = medium();
    volux_scene *sa = scene(ctx, data, NULL, 0), *sb = scene(ctx, data, "budget_slices", 6);
    volux_technique *a = lvf_create(ctx, sa), *b = lvf_create(ctx, sb);
    assert_int_equal(volux_technique_set_budget(b, 1e-9), 1);
    move_point(sa, 0);
    move_point(sb, 0);
    lvf_update(a, sa);
    lvf_update(b, sb);
    uint64_t total = volux_technique_pending(b) + 1; /* the update ran one step */
    assert_true(total > 8);
    for (int i = 0; i < 3; i++) assert_refine_spends(b, sb, 1); /* not the scene's 6 */
    /* the scene's budget again: 6 slice steps per call */
    assert_int_equal(volux_technique_set_budget(b, 0), 1);
    assert_refine_spends(b, sb, 6);
    assert_int_equal(volux_technique_set_budget(b, NAN), 1); /* NaN: the scene's */
    assert_refine_spends(b, sb, 6);
    assert_int_equal(volux_technique_set_budget(b, 1e-9), 1);
    finish(b, sb);
    assert_same_volume(a, b, "front-end budget");
    assert_same_images(ctx, sa, a, sb, b);
    /* the scene was not touched; a new instance (what `volux render` of it
     * builds) differs from any selectively updated one by the class's
     * update tolerance only (incremental arithmetic), budget or not */
    assert_int_equal((int)volux_scene_param(sb, "lightvol", "budget_ms", -1), -1);
    assert_int_equal((int)volux_scene_param(sb, "lightvol", "budget_slices", -1), 6);
    volux_technique *fresh = lvf_create(ctx, sb);
    size_t n = lvf_count(lvf_state(b));
    float *x = lvf_copy(fresh), *y = lvf_copy(b);
    double bmax, d = lvf_max_diff(x, y, n, &bmax);
    assert_true(d <= 1e-4 * bmax);
    free(x);
    free(y);
    /* a technique that defers nothing does not take a budget */
    volux_technique *ea = NULL;
    assert_int_equal(volux_technique_create(ctx, "ea", sb, &ea), VOLUX_OK);
    assert_int_equal(volux_technique_set_budget(ea, 10), 0);
    volux_technique_destroy(ea);
    volux_technique_destroy(fresh);
    volux_technique_destroy(a);
    volux_technique_destroy(b);
    volux_scene_destroy(sa);
    volux_scene_destroy(sb);
    free(data);
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_light_edit_converges_bit_identically),
        cmocka_unit_test(test_entire_update_converges_bit_identically),
        cmocka_unit_test(test_edits_during_propagation_are_queued),
        cmocka_unit_test(test_edit_after_a_job_joins_the_queue),
        cmocka_unit_test(test_budget_ms_converges_bit_identically),
        cmocka_unit_test(test_each_step_spends_the_budget),
        cmocka_unit_test(test_front_end_budget),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
