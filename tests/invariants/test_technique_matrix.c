/*
 * The technique × edit matrix (STYLE §5.6): every registered technique is
 * checked against every edit of the shared list (volux/edit.h) on one small
 * scene. A new technique gets all of it by registering; a new edit kind by
 * joining the list.
 *
 * For every technique and every edit that applies to it:
 *   1. incremental == fresh: created before the edit and updated renders
 *      what a technique created after the edit renders — bit for bit, or
 *      within the class's declared update_tolerance;
 *   2. a visible edit changes the image exactly when it touches an aspect
 *      the technique does not declare it ignores (image_ignores), so
 *      neither a stale cache nor a claimed dependence goes unnoticed;
 *   3. an allocation failure at every point of the update is reported as
 *      NOMEM without a leak, and the next render recovers: it retries the
 *      update and renders what a fresh technique renders.
 * For every technique:
 *   4. every numeric parameter of its table, moved to a nearby valid value,
 *      is applied by update as a fresh create would apply it;
 *   5. 1 and 2 threads give bit-identical images (cache builds included);
 *   6. an allocation failure at every point of load + create + render is
 *      reported as NOMEM without a leak;
 *   7. accumulating 2 then 3 more samples into one framebuffer gives the
 *      image of 5 at once (waves are sample indices, not render calls);
 *   8. rendering after an edit without calling update, into the framebuffer
 *      of the earlier frame, gives the fresh image: volux_render brings the
 *      technique up to date and drops the stale samples.
 *
 * Deferred work (volux/technique.h, volux_technique_refine): where create
 * and update stop at the same first state (sh's coarse projection) the
 * first states are compared; for every technique that defers work, also
 * the states after all refinement steps (manylights answers an extinction
 * edit at once and replaces its virtual lights over later steps, while a
 * fresh instance is finished at once). Where the class measures its
 * pending work, every step must decrease it, and an allocation failure in
 * a step must leave a state the following steps finish from.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "render/technique_class.h"
#include "techniques/registry.h"
#include "test_util.h"
#include "tu_volume.h"

/* A cloud (asymmetric, so the mirrored time step differs), a coloured TF,
 * three kinds of light (the environment is invisible to camera rays so the
 * background shows), a background, and small caches for every technique. */
static const char *scene_json =
    "{\"volume\": {\"procedural\": \"cloud\", \"dims\": [24, 22, 20]},"
    " \"transfer_function\": {\"opacity\": [[0, 0], [60, 0.05], [160, 0.35], [255, 0.6]],"
    "   \"color\": [[0, 0.9, 0.4, 0.2], [128, 0.3, 0.8, 0.4], [255, 0.2, 0.3, 1.0]],"
    "   \"albedo\": 0.8, \"anisotropy\": 0.3},"
    " \"camera\": {\"orbit\": {\"azimuth\": 35, \"elevation\": 25}, \"fov_y\": 40},"
    " \"lights\": [{\"type\": \"directional\", \"direction\": [-0.4, -1, -0.3], \"irradiance\": 2},"
    "   {\"type\": \"environment\", \"radiance\": 0.3, \"color\": [0.6, 0.7, 1.0], \"visible\": false},"
    "   {\"type\": \"point\", \"position\": [30, 20, 25], \"intensity\": 900, \"color\": [1, 0.8, 0.6]}],"
    " \"background\": [0.2, 0.1, 0.05],"
    " \"render\": {\"width\": 20, \"height\": 18, \"spp\": 2, \"step\": 1, \"max_depth\": 4, \"threads\": 1},"
    " \"techniques\": {\"ambient\": {\"radius\": 2, \"table_theta\": 16, \"table_sigma\": 16, \"table_g\": 3,"
    "                                \"table_paths\": 64, \"table_albedo\": 0.8},"
    "                  \"lightvol\": {\"forward_scattering\": 0.5, \"budget_slices\": 7},"
    "                  \"manylights\": {\"vl_count\": 24, \"avsm_resolution\": 3, \"avsm_nodes\": 4,"
    "                                   \"samples\": 2, \"update_budget\": 7},"
    "                  \"guided\": {\"env_resolution\": 16}}}";

static volux_scene *load(volux_context *ctx, const char *technique) {
    char override[96];
    snprintf(override, sizeof override, "render.technique=\"%s\"", technique);
    const char *ov[1] = {override};
    volux_scene *s = NULL;
    volux_status st = volux_scene_load_string(ctx, scene_json, tu_temp_path(""), "matrix.json", ov, 1, &s);
    if (st) fail_msg("scene: %s", volux_context_error(ctx));
    /* The point light lives in slot 511: past the old cap of 256, and the
     * light_add edit (the slot after the last light) then grows the slot
     * table and every technique's per-slot state inside the update (so
     * the OOM runs fail each of those allocations too). */
    volux_light_desc point = *volux_scene_light(s, 2);
    if (volux_scene_set_light(s, 511, &point) || volux_scene_remove_light(s, 2))
        fail_msg("scene: %s", volux_context_error(ctx));
    return s;
}

static int applies(const volux_edit *e, const char *technique) {
    return !e->technique || !strcmp(e->technique, technique);
}

static double image_max(const volux_image *img) {
    double m = 0.0;
    for (size_t i = 0; i < 3 * (size_t)img->width * (size_t)img->height; i++)
        if (img->rgb[i] > m) m = img->rgb[i];
    return m;
}

/* Finishes the work a progressive technique deferred (refine until no
 * step remains); where the class measures its pending work, every step
 * that changes the instance must decrease it. */
static void converge(volux_technique *t, volux_scene *s, const char *what) {
    for (long steps = 0;; steps++) {
        uint64_t left = volux_technique_pending(t);
        int refined = 0, more = 0;
        if (volux_technique_refine(t, s, &refined, &more))
            fail_msg("%s: refine: %s", what, volux_context_error(volux_scene_context(s)));
        uint64_t now = volux_technique_pending(t);
        if (refined && left > 0 && now >= left)
            fail_msg("%s: a refinement step left %llu units of work pending (before: %llu)", what,
                     (unsigned long long)now, (unsigned long long)left);
        if (!more) break;
        if (steps > 100000) fail_msg("%s: the deferred work never finishes", what);
    }
}

/* Fresh technique for the scene as it is now: its first state, or with
 * `finished` the state after its deferred work. */
static volux_image fresh(volux_context *ctx, volux_scene *s, const char *technique, int finished) {
    volux_technique *t = NULL;
    if (volux_technique_create(ctx, technique, s, &t)) fail_msg("%s: %s", technique, volux_context_error(ctx));
    if (finished) converge(t, s, technique);
    volux_image img = tu_render_with(ctx, s, t);
    volux_technique_destroy(t);
    return img;
}

/* The updated instance t against a fresh one. Where create and update stop
 * at the same state (no pending-work measure, e.g. sh's coarse
 * projection), the first states; for every technique with deferred work
 * also the finished states (manylights: a fresh instance is finished at
 * once, an updated one after its replacement steps). Returns t's last
 * image (caller frees). */
static volux_image against_fresh(const volux_technique_class *cls, volux_context *ctx, volux_scene *s,
                                 volux_technique *t, const char *what) {
    const char *name = cls->info.name;
    volux_image img = {0};
    for (int finished = cls->pending ? 1 : 0; finished <= (cls->refine ? 1 : 0); finished++) {
        volux_image_free(ctx, &img);
        if (finished) converge(t, s, what);
        img = tu_render_with(ctx, s, t);
        volux_image ref = fresh(ctx, s, name, finished);
        double diff = tu_max_abs_diff(&img, &ref), tol = cls->update_tolerance * image_max(&ref);
        if (!(diff <= tol))
            fail_msg("%s: incremental differs from fresh%s by %g (allowed %g)", what,
                     finished ? " (deferred work finished)" : "", diff, tol);
        volux_image_free(ctx, &ref);
    }
    return img;
}

static void check_update(const volux_technique_class *cls, const volux_edit *e) {
    const char *name = cls->info.name;
    volux_context *ctx = tu_context(1);
    volux_scene *s = load(ctx, name);
    volux_technique *t = NULL;
    if (volux_technique_create(ctx, name, s, &t)) fail_msg("%s: %s", name, volux_context_error(ctx));
    volux_image before = tu_render_with(ctx, s, t);
    if (volux_edit_apply(e, s, 0)) fail_msg("%s × %s: %s", name, e->name, volux_context_error(ctx));
    volux_change_set applied;
    if (volux_technique_update(t, s, &applied)) fail_msg("%s × %s: update: %s", name, e->name, volux_context_error(ctx));
    if ((applied.what & e->touches) != e->touches)
        fail_msg("%s × %s: the scene reported changes 0x%x, the edit declares 0x%x", name, e->name, applied.what,
                 e->touches);
    char what[128];
    snprintf(what, sizeof what, "%s × %s", name, e->name);
    volux_image after = against_fresh(cls, ctx, s, t, what);
    int changed = tu_max_abs_diff(&before, &after) > 0.0;
    int must = (e->touches & ~cls->image_ignores) != 0;
    if (e->visible && changed != must)
        fail_msg("%s × %s: the edit %s the image, but the class says it %s", name, e->name,
                 changed ? "changed" : "did not change", must ? "must" : "cannot");
    volux_image_free(ctx, &before);
    volux_image_free(ctx, &after);
    volux_technique_destroy(t);
    volux_scene_destroy(s);
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

/* Fails allocation k of the update for k = 1, 2, ... until the update
 * succeeds; after each failure the next render must recover. */
static void check_update_oom(const volux_technique_class *cls, const volux_edit *e) {
    const char *name = cls->info.name;
    for (long k = 1;; k++) {
        tu_alloc_stats stats = {0};
        volux_context *ctx = tu_context_counting(0, &stats);
        volux_scene *s = load(ctx, name);
        volux_technique *t = NULL;
        if (volux_technique_create(ctx, name, s, &t)) fail_msg("%s: %s", name, volux_context_error(ctx));
        if (volux_edit_apply(e, s, 0)) fail_msg("%s × %s: %s", name, e->name, volux_context_error(ctx));
        stats.fail_at = stats.count + k;
        volux_status st = volux_technique_update(t, s, NULL);
        stats.fail_at = 0;
        if (st != VOLUX_OK) {
            if (st != VOLUX_ERR_NOMEM)
                fail_msg("%s × %s: failing allocation %ld of the update gave %s: %s", name, e->name, k,
                         volux_status_name(st), volux_context_error(ctx));
            volux_context_clear_error(ctx);
            volux_image retried = tu_render_with(ctx, s, t); /* retries the update */
            volux_image_free(ctx, &retried);
            char what[160];
            snprintf(what, sizeof what, "%s × %s, after failing allocation %ld of the update", name, e->name, k);
            volux_image after = against_fresh(cls, ctx, s, t, what);
            volux_image_free(ctx, &after);
        }
        volux_technique_destroy(t);
        volux_scene_destroy(s);
        if (volux_context_bytes_in_use(ctx) != 0)
            fail_msg("%s × %s: failing allocation %ld leaked %llu bytes", name, e->name, k,
                     (unsigned long long)volux_context_bytes_in_use(ctx));
        volux_context_destroy(ctx);
        assert_int_equal(stats.live, 0);
        if (st == VOLUX_OK) break;
        assert_true(k < 100000);
    }
}

/* Classes that measure their deferred work: an allocation failure at every
 * point of the first refinement step after the edit is NOMEM without a
 * leak, leaves the pending work as it was, and the steps that follow still
 * end at the fresh image. */
static void check_refine_oom(const volux_technique_class *cls, const volux_edit *e) {
    const char *name = cls->info.name;
    if (!cls->refine || !cls->pending) return;
    for (long k = 1;; k++) {
        tu_alloc_stats stats = {0};
        volux_context *ctx = tu_context_counting(0, &stats);
        volux_scene *s = load(ctx, name);
        volux_technique *t = NULL;
        if (volux_technique_create(ctx, name, s, &t)) fail_msg("%s: %s", name, volux_context_error(ctx));
        if (volux_edit_apply(e, s, 0)) fail_msg("%s × %s: %s", name, e->name, volux_context_error(ctx));
        if (volux_technique_update(t, s, NULL)) fail_msg("%s × %s: %s", name, e->name, volux_context_error(ctx));
        uint64_t before = volux_technique_pending(t);
        volux_status st = VOLUX_OK;
        if (before > 0) {
            stats.fail_at = stats.count + k;
            st = volux_technique_refine(t, s, NULL, NULL);
            stats.fail_at = 0;
            if (st != VOLUX_OK) {
                if (st != VOLUX_ERR_NOMEM)
                    fail_msg("%s × %s: failing allocation %ld of a refinement step gave %s", name, e->name, k,
                             volux_status_name(st));
                if (volux_technique_pending(t) != before)
                    fail_msg("%s × %s: a failed refinement step changed the pending work", name, e->name);
                volux_context_clear_error(ctx);
            }
            char what[160];
            snprintf(what, sizeof what, "%s × %s, after failing allocation %ld of a step", name, e->name, k);
            volux_image after = against_fresh(cls, ctx, s, t, what);
            volux_image_free(ctx, &after);
        }
        volux_technique_destroy(t);
        volux_scene_destroy(s);
        if (volux_context_bytes_in_use(ctx) != 0)
            fail_msg("%s × %s: failing allocation %ld of a step leaked", name, e->name, k);
        volux_context_destroy(ctx);
        if (st == VOLUX_OK) break;
        assert_true(k < 100000);
    }
}

/* A valid value near v: the next integer, a bool flipped, a number 10 %
 * away (inside [min, max]); small steps keep the caches cheap. */
static double nearby(const volux_param_info *p, double v) {
    if (p->kind == VOLUX_PARAM_BOOL) return v != 0.0 ? 0.0 : 1.0;
    double up = p->kind == VOLUX_PARAM_INT ? v + 1.0 : (v != 0.0 ? v * 1.1 : 0.1 * (p->max - p->min));
    double down = p->kind == VOLUX_PARAM_INT ? v - 1.0 : v * 0.9;
    return up <= p->max ? up : down;
}

static void check_params(const volux_technique_class *cls) {
    const char *name = cls->info.name;
    for (const volux_param_info *p = cls->info.params; p && p->name; p++) {
        /* The scene reader resolves (and confines to the data root) the
         * parameters whose names end in "_file": that must be exactly the
         * VOLUX_PARAM_FILE ones. */
        size_t len = strlen(p->name);
        int named_file = len >= 5 && !strcmp(p->name + len - 5, "_file");
        if (named_file != (p->kind == VOLUX_PARAM_FILE))
            fail_msg("techniques.%s.%s: a file parameter is VOLUX_PARAM_FILE and named *_file (both or neither)",
                     name, p->name);
        if (p->kind == VOLUX_PARAM_STRING || p->kind == VOLUX_PARAM_FILE) continue; /* technique-specific */
        volux_context *ctx = tu_context(1);
        volux_scene *s = load(ctx, name);
        volux_technique *t = NULL;
        if (volux_technique_create(ctx, name, s, &t)) fail_msg("%s: %s", name, volux_context_error(ctx));
        double v = nearby(p, volux_scene_param(s, name, p->name, p->def));
        if (volux_scene_set_param(s, name, p->name, v, NULL)) fail_msg("%s.%s: %s", name, p->name, volux_context_error(ctx));
        volux_status st = volux_technique_update(t, s, NULL);
        if (st == VOLUX_OK) {
            char what[160];
            snprintf(what, sizeof what, "%s: techniques.%s.%s = %g", name, name, p->name, v);
            volux_image after = against_fresh(cls, ctx, s, t, what);
            volux_image_free(ctx, &after);
        } else {
            /* a value the table allows but the technique refuses in this
             * scene must be refused by a fresh create too, with its name */
            volux_technique *f = NULL;
            volux_context_clear_error(ctx);
            if (volux_technique_create(ctx, name, s, &f) == VOLUX_OK)
                fail_msg("%s.%s = %g: update refused it, create accepted it", name, p->name, v);
            if (!strstr(volux_context_error(ctx), p->name))
                fail_msg("%s.%s = %g: the error does not name it: %s", name, p->name, v, volux_context_error(ctx));
        }
        volux_technique_destroy(t);
        volux_scene_destroy(s);
        volux_context_destroy(ctx);
    }
}

static void check_threads(const volux_technique_class *cls) {
    const char *name = cls->info.name;
    volux_context *ctx[2];
    volux_image img[2];
    for (int n = 1; n <= 2; n++) {
        ctx[n - 1] = tu_context(n);
        volux_scene *s = load(ctx[n - 1], name);
        volux_render_settings rs = *volux_scene_render(s);
        rs.threads = n;
        assert_int_equal(volux_scene_set_render(s, &rs), VOLUX_OK);
        img[n - 1] = fresh(ctx[n - 1], s, name, cls->refine != NULL);
        volux_scene_destroy(s);
    }
    double d = tu_max_abs_diff(&img[0], &img[1]);
    if (d != 0.0) fail_msg("%s: 1 and 2 threads differ by %g", name, d);
    for (int i = 0; i < 2; i++) {
        volux_image_free(ctx[i], &img[i]);
        volux_context_destroy(ctx[i]);
    }
}

static void check_create_oom(const volux_technique_class *cls) {
    const char *name = cls->info.name;
    int failures = 0;
    for (long k = 1;; k++) {
        tu_alloc_stats stats = {0};
        volux_context *ctx = tu_context_counting(0, &stats);
        stats.fail_at = stats.count + k; /* after the context's own blocks */
        char override[96];
        snprintf(override, sizeof override, "render.technique=\"%s\"", name);
        const char *ov[1] = {override};
        volux_scene *s = NULL;
        volux_technique *t = NULL;
        volux_framebuffer *fb = NULL;
        volux_status st = volux_scene_load_string(ctx, scene_json, tu_temp_path(""), "matrix.json", ov, 1, &s);
        if (!st) st = volux_technique_create(ctx, name, s, &t);
        if (!st) st = volux_framebuffer_create(ctx, 20, 18, &fb);
        if (!st) st = volux_render(t, s, fb, NULL, NULL);
        volux_framebuffer_destroy(fb);
        volux_technique_destroy(t);
        volux_scene_destroy(s);
        if (volux_context_bytes_in_use(ctx) != 0)
            fail_msg("%s: failing allocation %ld leaked %llu bytes (%s: %s)", name, k,
                     (unsigned long long)volux_context_bytes_in_use(ctx), volux_status_name(st),
                     volux_context_error(ctx));
        if (st && st != VOLUX_ERR_NOMEM)
            fail_msg("%s: failing allocation %ld gave %s: %s", name, k, volux_status_name(st), volux_context_error(ctx));
        if (st && !volux_context_error(ctx)[0]) fail_msg("%s: allocation %ld failed without a message", name, k);
        volux_context_destroy(ctx);
        assert_int_equal(stats.live, 0);
        if (!st) break;
        failures++;
        assert_true(k < 100000);
    }
    assert_true(failures > 10);
}

static void check_accumulation(const volux_technique_class *cls) {
    const char *name = cls->info.name;
    volux_context *ctx = tu_context(2);
    volux_scene *s = load(ctx, name);
    volux_technique *t = NULL;
    if (volux_technique_create(ctx, name, s, &t)) fail_msg("%s: %s", name, volux_context_error(ctx));
    volux_framebuffer *once, *twice;
    assert_int_equal(volux_framebuffer_create(ctx, 20, 18, &once), VOLUX_OK);
    assert_int_equal(volux_framebuffer_create(ctx, 20, 18, &twice), VOLUX_OK);
    volux_render_limits five = {5, 0, 0}, two = {2, 0, 0};
    assert_int_equal(volux_render(t, s, once, &five, NULL), VOLUX_OK);
    assert_int_equal(volux_render(t, s, twice, &two, NULL), VOLUX_OK);
    assert_int_equal(volux_render(t, s, twice, &five, NULL), VOLUX_OK);
    assert_int_equal(volux_framebuffer_spp(twice), 5);
    volux_image a, b;
    assert_int_equal(volux_framebuffer_resolve(once, &a), VOLUX_OK);
    assert_int_equal(volux_framebuffer_resolve(twice, &b), VOLUX_OK);
    if (tu_max_abs_diff(&a, &b) != 0.0) fail_msg("%s: 2 + 3 samples differ from 5", name);
    volux_image_free(ctx, &a);
    volux_image_free(ctx, &b);
    volux_framebuffer_destroy(once);
    volux_framebuffer_destroy(twice);
    volux_technique_destroy(t);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

static void check_stale_render(const volux_technique_class *cls) {
    const char *name = cls->info.name;
    volux_context *ctx = tu_context(2);
    volux_scene *s = load(ctx, name);
    volux_technique *t = NULL;
    if (volux_technique_create(ctx, name, s, &t)) fail_msg("%s: %s", name, volux_context_error(ctx));
    volux_framebuffer *fb;
    assert_int_equal(volux_framebuffer_create(ctx, 20, 18, &fb), VOLUX_OK);
    assert_int_equal(volux_render(t, s, fb, NULL, NULL), VOLUX_OK);
    assert_int_equal(volux_edit_apply(volux_edit_find("tf"), s, 0), VOLUX_OK);
    assert_false(volux_technique_is_current(t, s));
    assert_int_equal(volux_render(t, s, fb, NULL, NULL), VOLUX_OK);
    assert_true(volux_technique_is_current(t, s));
    assert_int_equal(volux_framebuffer_spp(fb), (uint32_t)volux_scene_render(s)->spp);
    /* first states where create and update stop at the same one; finished
     * states (the front end refines between frames) where work is deferred */
    for (int finished = cls->pending ? 1 : 0; finished <= (cls->refine ? 1 : 0); finished++) {
        if (finished) {
            converge(t, s, name);
            assert_int_equal(volux_render(t, s, fb, NULL, NULL), VOLUX_OK);
            assert_int_equal(volux_framebuffer_spp(fb), (uint32_t)volux_scene_render(s)->spp);
        }
        volux_image got, ref = fresh(ctx, s, name, finished);
        assert_int_equal(volux_framebuffer_resolve(fb, &got), VOLUX_OK);
        double diff = tu_max_abs_diff(&got, &ref);
        if (!(diff <= cls->update_tolerance * image_max(&ref)))
            fail_msg("%s: render after an edit without update differs from fresh%s by %g", name,
                     finished ? " (deferred work finished)" : "", diff);
        volux_image_free(ctx, &got);
        volux_image_free(ctx, &ref);
    }
    volux_framebuffer_destroy(fb);
    volux_technique_destroy(t);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

/* One cmocka test per technique (so a failure names it). */
static void run_technique(void **state) {
    const volux_technique_class *cls = *state;
    for (int i = 0; i < volux_edit_count(); i++) {
        const volux_edit *e = volux_edit_at(i);
        if (!applies(e, cls->info.name)) continue;
        check_update(cls, e);
        check_update_oom(cls, e);
        check_refine_oom(cls, e);
    }
    check_params(cls);
    check_threads(cls);
    check_create_oom(cls);
    check_accumulation(cls);
    check_stale_render(cls);
}


int main(void) {
    enum { MAX = 32 };
    struct CMUnitTest tests[MAX];
    const volux_technique_class *classes[MAX];
    int n = volux_technique_count();
    assert_true(n <= MAX);
    for (int i = 0; i < n; i++) {
        classes[i] = volux_technique_class_find(volux_technique_info_at(i)->name);
        struct CMUnitTest t = {volux_technique_info_at(i)->name, run_technique, NULL, NULL, (void *)classes[i]};
        tests[i] = t;
    }
    return _cmocka_run_group_tests("technique_matrix", tests, (size_t)n, NULL, NULL);
}
