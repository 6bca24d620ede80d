/* Allocation-failure injection (Lua's memerr, SQLite's OOM tests): fail the
 * k-th allocation for k = 1, 2, ... until the whole pipeline succeeds; every
 * failure must be reported as an error, never crash, and leave no memory
 * behind (the context's byte count returns to zero). */
#include <stdlib.h>
#include <string.h>

#include "test_util.h"

typedef struct failing {
    long countdown; /* fail when it reaches 0; < 0 = never */
    long calls;
} failing;

static void *failing_alloc(void *user, void *ptr, size_t old_size, size_t new_size) {
    failing *f = user;
    (void)old_size;
    if (new_size == 0) {
        free(ptr);
        return NULL;
    }
    f->calls++;
    if (f->countdown >= 0 && f->countdown-- == 0) return NULL;
    return realloc(ptr, new_size);
}

static const char *scene_json =
    "{\"volume\": {\"procedural\": \"cloud\", \"dims\": [20, 18, 16]},"
    " \"transfer_function\": {\"opacity\": [[0, 0], [100, 0.2], [255, 0.8]], \"color\": [[0, 1, 0, 0], [255, 0, 0, 1]]},"
    " \"lights\": [{\"type\": \"directional\", \"direction\": [0, -1, 0]}],"
    " \"render\": {\"width\": 20, \"height\": 20, \"spp\": 2}}";

/* Returns the status of the first failing step (VOLUX_OK if all passed). */
static volux_status pipeline(volux_context *ctx, const char *technique) {
    volux_scene *s = NULL;
    volux_technique *t = NULL;
    volux_framebuffer *fb = NULL;
    volux_image img = {0};
    volux_status st = volux_scene_load_string(ctx, scene_json, ".", "oom", NULL, 0, &s);
    if (!st) st = volux_technique_create(ctx, technique, s, &t);
    if (!st) st = volux_framebuffer_create(ctx, 20, 20, &fb);
    if (!st) st = volux_render(t, s, fb, NULL, NULL);
    if (!st) st = volux_framebuffer_resolve(fb, &img);
    if (!st) {
        volux_transfer_desc d = *volux_scene_transfer(s); /* an edit + update under OOM too */
        d.density_scale = 2;
        st = volux_scene_set_transfer(s, &d);
        if (!st) st = volux_technique_update(t, s, NULL);
    }
    volux_image_free(ctx, &img);
    volux_framebuffer_destroy(fb);
    volux_technique_destroy(t);
    volux_scene_destroy(s);
    return st;
}

static void run_oom(const char *technique) {
    int failures_seen = 0;
    for (long k = 0;; k++) {
        failing f = {k, 0};
        volux_context_desc d = {0};
        d.threads = 1;
        d.alloc = failing_alloc;
        d.alloc_user = &f;
        volux_context *ctx = NULL;
        if (volux_context_create(&d, &ctx) != VOLUX_OK) continue; /* the context itself failed */
        volux_status st = pipeline(ctx, technique);
        if (volux_context_bytes_in_use(ctx) != 0)
            fail_msg("%s: failing allocation %ld leaked %llu bytes (status %s: %s)", technique, k,
                     (unsigned long long)volux_context_bytes_in_use(ctx), volux_status_name(st),
                     volux_context_error(ctx));
        volux_context_destroy(ctx);
        if (st == VOLUX_OK) {
            assert_true(f.countdown >= 0); /* ran past every allocation: done */
            break;
        }
        assert_int_equal(st, VOLUX_ERR_NOMEM);
        failures_seen++;
        assert_true(k < 100000);
    }
    assert_true(failures_seen > 10);
}

static void test_ea_pipeline_survives_every_allocation_failure(void **state) {
    (void)state;
    run_oom("ea");
}

static void test_shaded_pipeline_survives_every_allocation_failure(void **state) {
    (void)state;
    run_oom("shaded");
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_ea_pipeline_survives_every_allocation_failure),
        cmocka_unit_test(test_shaded_pipeline_survives_every_allocation_failure),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
