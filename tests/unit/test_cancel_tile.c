/* A cancel inside a tile (volux_tile_cancelled, render/technique_class.h):
 * `shaded` asks between ray pairs, so the progress callback is polled while
 * the only tile of a 16² frame is being rendered — before any tile is done
 * (fraction 0) — and a nonzero answer ends the render with
 * VOLUX_ERR_CANCELLED, no sample accumulated. Without the in-tile poll the
 * first "render" report came after the tile (fraction ~1): a 70 000-light
 * `shaded` tile took seconds to notice a cancel (issue 34 D6). A render
 * that is not cancelled is unchanged by the polls (same bits as without a
 * callback). */
#include <string.h>

#include "test_util.h"

static const char *scene_json =
    "{\"volume\": {\"procedural\": \"phantom\", \"dims\": [20, 20, 20]},"
    " \"transfer_function\": {\"color\": [[0, 0.2, 0.3, 0.6], [255, 1, 0.9, 0.8]],"
    "   \"opacity\": [[0, 0], [60, 0.1], [255, 0.9]]},"
    " \"lights\": [{\"type\": \"point\", \"position\": [0.5, 0.5, 0.5], \"intensity\": 1},"
    "              {\"type\": \"point\", \"position\": [-0.5, 0.5, 0.5], \"intensity\": 1}],"
    " \"render\": {\"technique\": \"shaded\", \"width\": 16, \"height\": 16, \"spp\": 1, \"threads\": 1}}";

typedef struct probe {
    int calls;
    double first_fraction;
    int cancel;
} probe;

static int on_progress(void *user, const char *task, double fraction) {
    probe *p = user;
    if (strcmp(task, "render")) return 0;
    if (p->calls++ == 0) p->first_fraction = fraction;
    return p->cancel;
}

static void test_cancel_inside_the_tile(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_scene *s = tu_scene(ctx, scene_json);
    volux_technique *t = NULL;
    volux_framebuffer *fb = NULL;
    assert_int_equal(volux_technique_create(ctx, "shaded", s, &t), VOLUX_OK);
    assert_int_equal(volux_framebuffer_create(ctx, 16, 16, &fb), VOLUX_OK);
    assert_int_equal(volux_framebuffer_tile_count(fb), 1);
    probe p = {0, -1.0, 1};
    volux_context_set_progress(ctx, on_progress, &p);
    volux_render_limits one = {1, 0, 0};
    volux_render_report rep;
    memset(&rep, 0, sizeof rep);
    assert_int_equal(volux_render(t, s, fb, &one, &rep), VOLUX_ERR_CANCELLED);
    assert_true(p.calls >= 1);
    assert_true(p.first_fraction == 0.0); /* asked inside the only tile */
    assert_int_equal(volux_framebuffer_spp(fb), 0);

    /* Not cancelled: the polls change no pixel. */
    volux_context_set_progress(ctx, NULL, NULL);
    volux_image plain = tu_render_with(ctx, s, t);
    probe q = {0, -1.0, 0};
    volux_context_set_progress(ctx, on_progress, &q);
    volux_image polled = tu_render_with(ctx, s, t);
    assert_true(q.calls >= 1);
    assert_memory_equal(plain.rgb, polled.rgb, 3 * 16 * 16 * sizeof(float));
    volux_image_free(ctx, &plain);
    volux_image_free(ctx, &polled);
    volux_framebuffer_destroy(fb);
    volux_technique_destroy(t);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_cancel_inside_the_tile),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
