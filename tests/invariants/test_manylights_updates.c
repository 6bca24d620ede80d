/*
 * manylights: every edit does the least work W13 allows, and progressive
 * updates (W13 §4.2) end exactly where a fresh instance starts.
 *
 *   1. least work, from the technique's own counters (AVSMs built, VLs
 *      traced, pending work) per edit kind: camera, light colour/strength,
 *      TF colour, density (Eq. 8 placement), phase (isotropic sampling)
 *      build and trace nothing; a light move rebuilds that light's VLs
 *      only; extinction, phase (HG sampling) and density (placement by the
 *      density in use) trace the new subpaths but build no AVSM at once
 *      (rule 2) and leave work pending;
 *   2. the timeline of an extinction edit (a frame = the front end's
 *      refinement step, then volux_render): the immediate image (Eq. 6)
 *      is closer to the fresh image than the image before the edit; at
 *      most ceil(N/budget) + lights frames; a step builds AVSMs for about
 *      `update_budget` VLs (rule 1); the last frame equals a fresh create
 *      bit for bit;
 *   3. edits during a replacement (extinction again, a light switched off
 *      — a new share of vl_count —, colour) still end at the fresh image;
 *   4. intermediate states are reproducible: 1 and 2 threads agree at every
 *      step.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "techniques/manylights/manylights.h"
#include "test_util.h"

static const char *scene_json =
    "{\"volume\": {\"procedural\": \"cloud\", \"dims\": [24, 22, 20]},"
    " \"transfer_function\": {\"opacity\": [[0, 0], [60, 0.05], [160, 0.35], [255, 0.6]],"
    "   \"color\": [[0, 0.9, 0.4, 0.2], [128, 0.3, 0.8, 0.4], [255, 0.2, 0.3, 1.0]],"
    "   \"albedo\": 0.8, \"anisotropy\": 0.3},"
    " \"camera\": {\"orbit\": {\"azimuth\": 35, \"elevation\": 25}, \"fov_y\": 40},"
    " \"lights\": [{\"type\": \"directional\", \"direction\": [-0.4, -1, -0.3], \"irradiance\": 2},"
    "   {\"type\": \"environment\", \"radiance\": 0.3, \"color\": [0.6, 0.7, 1.0], \"visible\": false},"
    "   {\"type\": \"point\", \"position\": [30, 20, 25], \"intensity\": 900, \"color\": [1, 0.8, 0.6]}],"
    " \"render\": {\"technique\": \"manylights\", \"width\": 20, \"height\": 18, \"spp\": 2, \"step\": 1,"
    "            \"max_depth\": 6, \"threads\": 1},"
    " \"techniques\": {\"manylights\": {\"vl_count\": 90, \"avsm_resolution\": 4, \"avsm_nodes\": 4,"
    "                                 \"samples\": 2, \"update_budget\": 10}}}";

enum { N_VL = 90, BUDGET = 10, LIGHTS = 3 };

static double stat(const volux_technique *t, const char *name) {
    volux_technique_stat s[32];
    int n = volux_technique_stats(t, s, 32);
    for (int i = 0; i < n && i < 32; i++)
        if (!strcmp(s[i].name, name)) return s[i].value;
    fail_msg("no statistic %s", name);
    return 0.0;
}

static volux_image fresh(volux_context *ctx, volux_scene *s) {
    volux_technique *t = NULL;
    assert_int_equal(volux_technique_create(ctx, "manylights", s, &t), VOLUX_OK);
    assert_int_equal(volux_technique_pending(t), 0);
    volux_image img = tu_render_with(ctx, s, t);
    volux_technique_destroy(t);
    return img;
}

/* One refinement step (a frame's worth); returns whether more remain. */
static int step(volux_technique *t, volux_scene *s) {
    int refined = 0, more = 0;
    assert_int_equal(volux_technique_refine(t, s, &refined, &more), VOLUX_OK);
    return more;
}

static void converge(volux_technique *t, volux_scene *s) {
    assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_OK);
    for (uint64_t left = volux_technique_pending(t); left > 0;) {
        int more = step(t, s);
        uint64_t now = volux_technique_pending(t);
        if (now >= left) fail_msg("a step left %llu pending (before %llu)", (unsigned long long)now, (unsigned long long)left);
        assert_int_equal(more, now > 0);
        left = now;
    }
}

static void assert_fresh(volux_context *ctx, volux_scene *s, volux_technique *t, const char *what) {
    converge(t, s);
    volux_image a = tu_render_with(ctx, s, t), b = fresh(ctx, s);
    double d = tu_max_abs_diff(&a, &b);
    if (d != 0.0) fail_msg("%s: converged image differs from fresh by %g", what, d);
    volux_image_free(ctx, &a);
    volux_image_free(ctx, &b);
}

static double mean_abs_diff(const volux_image *a, const volux_image *b) {
    double s = 0.0;
    size_t n = 3 * (size_t)a->width * (size_t)a->height;
    for (size_t i = 0; i < n; i++) s += fabs((double)a->rgb[i] - (double)b->rgb[i]);
    return s / (double)n;
}

typedef struct expect {
    const char *edit;
    const char *param; /* set before creating (NULL: none) */
    double value;
    const char *string;
    int avsms_min, avsms_max; /* AVSMs built by the update */
    int traced_min, traced_max;
    int pending; /* 1: work left after the update */
} expect;

static void test_least_work(void **state) {
    (void)state;
    const expect cases[] = {
        {"camera", NULL, 0, NULL, 0, 0, 0, 0, 0},
        {"background", NULL, 0, NULL, 0, 0, 0, 0, 0},
        {"step", NULL, 0, NULL, 0, 0, 0, 0, 0},
        {"light_color", NULL, 0, NULL, 0, 0, 0, 0, 0},
        {"light_intensity", NULL, 0, NULL, 0, 0, 0, 0, 0},
        {"tf_color", NULL, 0, NULL, 0, 0, 0, 0, 0},
        {"density", NULL, 0, NULL, 0, 0, 0, 0, 0},
        {"phase", "phase_sampling", 0, "isotropic", 0, 0, 0, 0, 0},
        /* the first light's share (30 VLs, whole subpaths: ≤ 30 + max_depth) */
        {"light", NULL, 0, NULL, 30, 36, 30, 36, 0},
        {"tf", NULL, 0, NULL, 0, 0, N_VL, N_VL + 3 * 6, 1},
        {"phase", NULL, 0, NULL, 0, 0, N_VL, N_VL + 3 * 6, 1},
        {"density", "density_min", 0, NULL, 0, 0, N_VL, N_VL + 3 * 6, 1},
        {"time_step", NULL, 0, NULL, N_VL, N_VL + 3 * 6, N_VL, N_VL + 3 * 6, 0},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        const expect *c = &cases[i];
        volux_context *ctx = tu_context(1);
        volux_scene *s = tu_scene(ctx, scene_json);
        if (c->param) assert_int_equal(volux_scene_set_param(s, "manylights", c->param, c->value, c->string), VOLUX_OK);
        volux_technique *t = NULL;
        assert_int_equal(volux_technique_create(ctx, "manylights", s, &t), VOLUX_OK);
        double n_vl = stat(t, "vl_count");
        assert_true(n_vl >= N_VL && n_vl <= N_VL + 3 * 6);
        assert_int_equal(volux_edit_apply(volux_edit_find(c->edit), s, 0), VOLUX_OK);
        assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_OK);
        int avsms = (int)stat(t, "avsm_built"), traced = (int)stat(t, "vl_traced");
        int pending = volux_technique_pending(t) > 0;
        printf("  %-16s %-15s AVSMs %3d  traced %3d  pending %d\n", c->edit, c->param ? c->param : "", avsms, traced,
               pending);
        if (avsms < c->avsms_min || avsms > c->avsms_max || traced < c->traced_min || traced > c->traced_max ||
            pending != c->pending)
            fail_msg("%s (%s): built %d AVSMs, traced %d VLs, pending %d; expected [%d, %d], [%d, %d], %d", c->edit,
                     c->param ? c->param : "-", avsms, traced, pending, c->avsms_min, c->avsms_max, c->traced_min,
                     c->traced_max, c->pending);
        assert_fresh(ctx, s, t, c->edit);
        volux_technique_destroy(t);
        volux_scene_destroy(s);
        volux_context_destroy(ctx);
    }
}

static void test_extinction_timeline(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    volux_scene *s = tu_scene(ctx, scene_json);
    volux_technique *t = NULL;
    assert_int_equal(volux_technique_create(ctx, "manylights", s, &t), VOLUX_OK);
    volux_framebuffer *fb;
    assert_int_equal(volux_framebuffer_create(ctx, 20, 18, &fb), VOLUX_OK);
    assert_int_equal(volux_render(t, s, fb, NULL, NULL), VOLUX_OK);
    volux_image before;
    assert_int_equal(volux_framebuffer_resolve(fb, &before), VOLUX_OK);
    /* a strong edit: extinction ×0.4 */
    for (int k = 0; k < 4; k++) assert_int_equal(volux_edit_apply(volux_edit_find("tf"), s, 2 * (k & 1) + 1), VOLUX_OK);
    volux_image ref = fresh(ctx, s);
    int frames = 0;
    double first_err = -1.0;
    do {
        /* a frame: the front end's refinement step (after the first), then
         * volux_render */
        uint64_t left = volux_technique_pending(t);
        if (frames > 0) step(t, s);
        assert_int_equal(volux_render(t, s, fb, NULL, NULL), VOLUX_OK);
        frames++;
        if (frames > 1) {
            assert_true(volux_technique_pending(t) < left);
            int built = (int)stat(t, "avsm_built");
            /* rule 1: about a budget of new AVSMs per frame (whole subpaths) */
            if (built > BUDGET + 6) fail_msg("frame %d built %d AVSMs", frames, built);
        } else {
            assert_int_equal((int)stat(t, "avsm_built"), 0); /* immediate: Eq. 6 only */
        }
        volux_image img;
        assert_int_equal(volux_framebuffer_resolve(fb, &img), VOLUX_OK);
        if (frames == 1) {
            first_err = mean_abs_diff(&img, &ref);
            double old_err = mean_abs_diff(&before, &ref);
            printf("  immediate image: mean |I - fresh| %.4g (before the edit %.4g)\n", first_err, old_err);
            assert_true(first_err < old_err);
            assert_true(first_err > 0.0);
        }
        volux_image_free(ctx, &img);
        assert_true(frames <= (N_VL + 3 * 6) / BUDGET + LIGHTS + 2);
    } while (volux_technique_pending(t) > 0);
    printf("  frames to converge: %d\n", frames);
    assert_true(frames >= N_VL / (BUDGET + 6));
    /* the last frame showed the converged state */
    volux_image last;
    assert_int_equal(volux_framebuffer_resolve(fb, &last), VOLUX_OK);
    assert_true(tu_max_abs_diff(&last, &ref) == 0.0);
    volux_image_free(ctx, &last);
    volux_image_free(ctx, &ref);
    volux_image_free(ctx, &before);
    volux_framebuffer_destroy(fb);
    volux_technique_destroy(t);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

/* Eq. 6 bounded (issue 27): an edit that makes the thin tissue twelve
 * times denser (opacity 0.05 → 0.6 at s = 60) re-weights the VLs sampled
 * there by up to σ_new/σ_old ≈ 12 per segment; unbounded, those few VLs
 * flash and the first frame after the edit is further from the fresh
 * image than the image before the edit was. With eq6_bound (default 4)
 * the first frame is closer, and no later frame of the replacement is
 * worse than the image before the edit. White-box: every stale VL of
 * depth k gains at most 4^k over its weight before the edit (without the
 * bound, eq6_bound 0: up to 10 × 4^k on this edit, the assertion fails).
 * On this small cloud the frames improve with or without the bound (first
 * frame mean |I − fresh| 0.0013 bounded, 0.0023 unbounded, vs 0.0069
 * before the edit); the engine timeline of the docs page is where the
 * unbounded outliers showed. */
static void test_eq6_bounded(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_scene *s = tu_scene(ctx, scene_json);
    volux_render_settings rs = *volux_scene_render(s);
    rs.spp = 1; /* set 0 only: the set the edit re-weights */
    assert_int_equal(volux_scene_set_render(s, &rs), VOLUX_OK);
    volux_technique *t = NULL;
    assert_int_equal(volux_technique_create(ctx, "manylights", s, &t), VOLUX_OK);
    volux_framebuffer *fb;
    assert_int_equal(volux_framebuffer_create(ctx, rs.width, rs.height, &fb), VOLUX_OK);
    assert_int_equal(volux_render(t, s, fb, NULL, NULL), VOLUX_OK);
    volux_image before;
    assert_int_equal(volux_framebuffer_resolve(fb, &before), VOLUX_OK);
    /* every VL's intensity before the edit (set 0, slot order) */
    const ml_state *st = volux_technique_state(t);
    enum { MAXV = 512 };
    float I0[MAXV];
    int n0 = 0;
    for (int slot = 0; slot < st->sets_cap; slot++)
        for (int i = 0; st->sets[slot].active && i < st->sets[slot].cur.n && n0 < MAXV; i++)
            I0[n0++] = st->sets[slot].cur.v[i].I.y;
    volux_transfer_desc tf = *volux_scene_transfer(s);
    const volux_tf_scalar_point op[4] = {{0, 0}, {15, 0.6f}, {160, 0.6f}, {255, 0.6f}};
    tf.opacity = op;
    tf.n_opacity = 4;
    assert_int_equal(volux_scene_set_transfer(s, &tf), VOLUX_OK);
    /* Eq. 6 now (positions kept): a VL of depth k gains at most bound^k */
    assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_OK);
    double worst_ratio = 0.0;
    int n1 = 0;
    for (int slot = 0; slot < st->sets_cap; slot++)
        for (int i = 0; st->sets[slot].active && i < st->sets[slot].cur.n && n1 < MAXV; i++, n1++) {
            const ml_vl *v = &st->sets[slot].cur.v[i];
            if (!(I0[n1] > 0.0f)) continue;
            double r = v->I.y / I0[n1], lim = pow(4.0, v->depth) * (1.0 + 1e-4);
            worst_ratio = fmax(worst_ratio, r / lim);
        }
    assert_int_equal(n1, n0);
    printf("  largest Eq. 6 gain / 4^depth: %.3g\n", worst_ratio);
    assert_true(worst_ratio <= 1.0);
    volux_image ref = fresh(ctx, s);
    double old_err = mean_abs_diff(&before, &ref), first = -1.0, worst = 0.0;
    int frames = 0;
    do {
        if (frames > 0) step(t, s);
        assert_int_equal(volux_render(t, s, fb, NULL, NULL), VOLUX_OK);
        volux_image img;
        assert_int_equal(volux_framebuffer_resolve(fb, &img), VOLUX_OK);
        double e = mean_abs_diff(&img, &ref);
        if (frames == 0) first = e;
        worst = fmax(worst, e);
        volux_image_free(ctx, &img);
        frames++;
    } while (volux_technique_pending(t) > 0);
    printf("  strong extinction edit: mean |I - fresh| before %.4g, first frame %.4g, worst frame %.4g (%d frames)\n",
           old_err, first, worst, frames);
    assert_true(first < old_err);
    assert_true(worst <= old_err);
    volux_image_free(ctx, &before);
    volux_image_free(ctx, &ref);
    volux_framebuffer_destroy(fb);
    volux_technique_destroy(t);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

static void test_edits_during_replacement(void **state) {
    (void)state;
    const char *second[] = {"tf", "light_toggle", "tf_color", "light", "density", "light_add"};
    for (size_t i = 0; i < sizeof second / sizeof second[0]; i++) {
        volux_context *ctx = tu_context(1);
        volux_scene *s = tu_scene(ctx, scene_json);
        volux_technique *t = NULL;
        assert_int_equal(volux_technique_create(ctx, "manylights", s, &t), VOLUX_OK);
        assert_int_equal(volux_edit_apply(volux_edit_find("tf"), s, 0), VOLUX_OK);
        assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_OK);
        for (int k = 0; k < 3; k++) step(t, s);
        assert_true(volux_technique_pending(t) > 0);
        assert_int_equal(volux_edit_apply(volux_edit_find(second[i]), s, 1), VOLUX_OK);
        assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_OK);
        for (int k = 0; k < 2; k++) step(t, s);
        /* and a third edit of the same kind (a slider that keeps moving) */
        assert_int_equal(volux_edit_apply(volux_edit_find(second[i]), s, 2), VOLUX_OK);
        assert_fresh(ctx, s, t, second[i]);
        volux_technique_destroy(t);
        volux_scene_destroy(s);
        volux_context_destroy(ctx);
    }
}

static void test_steps_thread_independent(void **state) {
    (void)state;
    volux_context *ctx[2];
    volux_scene *s[2];
    volux_technique *t[2];
    for (int n = 0; n < 2; n++) {
        ctx[n] = tu_context(n + 1);
        s[n] = tu_scene(ctx[n], scene_json);
        volux_render_settings rs = *volux_scene_render(s[n]);
        rs.threads = n + 1;
        assert_int_equal(volux_scene_set_render(s[n], &rs), VOLUX_OK);
        assert_int_equal(volux_technique_create(ctx[n], "manylights", s[n], &t[n]), VOLUX_OK);
        assert_int_equal(volux_edit_apply(volux_edit_find("tf"), s[n], 0), VOLUX_OK);
        assert_int_equal(volux_technique_update(t[n], s[n], NULL), VOLUX_OK);
    }
    for (int k = 0; k < 20; k++) {
        volux_image a = tu_render_with(ctx[0], s[0], t[0]), b = tu_render_with(ctx[1], s[1], t[1]);
        assert_true(tu_max_abs_diff(&a, &b) == 0.0);
        volux_image_free(ctx[0], &a);
        volux_image_free(ctx[1], &b);
        assert_int_equal(volux_technique_pending(t[0]), volux_technique_pending(t[1]));
        if (!volux_technique_pending(t[0])) break;
        for (int n = 0; n < 2; n++) step(t[n], s[n]);
    }
    for (int n = 0; n < 2; n++) {
        volux_technique_destroy(t[n]);
        volux_scene_destroy(s[n]);
        volux_context_destroy(ctx[n]);
    }
}

/* The preview (issue 27: a fast first image): pixel sample 0 gathers every
 * k-th VL from a random offset per view sample, weighted k, with
 * preview_samples view samples — an unbiased estimate of the same set's
 * full gather. Multiple scattering only, stride 10 (9 of 90 VLs), mean
 * luminance over 8 seeds (one VL set each) against the full first sample.
 * Measured 1.075 (8 sets, 360 pixels: noise); without the weight k 0.098. */
static void test_preview_unbiased(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_scene *s = tu_scene(ctx, scene_json);
    volux_render_settings rs = *volux_scene_render(s);
    rs.spp = 1;
    assert_int_equal(volux_scene_set_param(s, "manylights", "single_scattering", 0, NULL), VOLUX_OK);
    double full = 0.0, preview = 0.0, diff = 0.0;
    for (int seed = 1; seed <= 8; seed++) {
        rs.seed = (uint64_t)seed;
        assert_int_equal(volux_scene_set_render(s, &rs), VOLUX_OK);
        assert_int_equal(volux_scene_set_param(s, "manylights", "preview_vls", 0, NULL), VOLUX_OK);
        volux_image a = tu_render(ctx, s, "manylights");
        assert_int_equal(volux_scene_set_param(s, "manylights", "preview_vls", 9, NULL), VOLUX_OK);
        volux_image b = tu_render(ctx, s, "manylights");
        full += tu_mean_luminance(&a);
        preview += tu_mean_luminance(&b);
        diff += tu_max_abs_diff(&a, &b);
        volux_image_free(ctx, &a);
        volux_image_free(ctx, &b);
    }
    printf("  preview (9 of 90 VLs, S 1) / full first sample, mean luminance over 8 sets: %.3f\n", preview / full);
    assert_true(full > 0.0);
    assert_true(diff > 0.0); /* the preview is a different estimate */
    assert_true(fabs(preview / full - 1.0) < 0.15);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_least_work),
        cmocka_unit_test(test_extinction_timeline),
        cmocka_unit_test(test_eq6_bounded),
        cmocka_unit_test(test_edits_during_replacement),
        cmocka_unit_test(test_steps_thread_independent),
        cmocka_unit_test(test_preview_unbiased),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
