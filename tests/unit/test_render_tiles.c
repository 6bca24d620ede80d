/* Tile-range rendering and tile sums (render.h, the distributed front
 * end's building blocks): a frame assembled from tile ranges rendered into
 * separate framebuffers, in any order, is
 * bit-identical to one volux_render; bad ranges are refused. */
#include <string.h>

#include "test_util.h"

static const char *scene_json =
    "{\"volume\": {\"procedural\": \"phantom\", \"dims\": [20, 20, 20]},"
    " \"transfer_function\": {\"color\": [[0, 0.2, 0.3, 0.6], [255, 1, 0.9, 0.8]],"
    "   \"opacity\": [[0, 0], [60, 0.1], [255, 0.9]], \"albedo\": 0.8},"
    " \"lights\": [{\"type\": \"directional\", \"direction\": [-0.5, -0.7, -0.5], \"irradiance\": 1}],"
    " \"render\": {\"technique\": \"pathtrace\", \"width\": 45, \"height\": 37, \"spp\": 3, \"threads\": 1}}";

static volux_image whole_frame(volux_context *ctx, volux_scene *s) {
    volux_technique *t = NULL;
    assert_int_equal(volux_technique_create(ctx, "pathtrace", s, &t), VOLUX_OK);
    volux_image img = tu_render_with(ctx, s, t);
    volux_technique_destroy(t);
    return img;
}

static void test_assembled_tiles_equal_the_whole_frame(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    volux_scene *s = tu_scene(ctx, scene_json);
    volux_image ref = whole_frame(ctx, s);

    volux_technique *t = NULL;
    volux_framebuffer *worker = NULL, *collector = NULL;
    assert_int_equal(volux_technique_create(ctx, "pathtrace", s, &t), VOLUX_OK);
    assert_int_equal(volux_framebuffer_create(ctx, 45, 37, &worker), VOLUX_OK);
    assert_int_equal(volux_framebuffer_create(ctx, 45, 37, &collector), VOLUX_OK);
    int tiles = volux_framebuffer_tile_count(worker);
    assert_int_equal(tiles, 3 * 3);
    /* Uneven chunks, taken back to front, each through a packed buffer. */
    const int chunks[][2] = {{7, 2}, {4, 3}, {3, 1}, {0, 3}};
    double buf[VOLUX_TILE_SUMS * 3 * VOLUX_TILE_SIZE * VOLUX_TILE_SIZE];
    size_t pixels = 0;
    for (int c = 0; c < 4; c++) {
        int first = chunks[c][0], count = chunks[c][1];
        assert_int_equal(volux_render_tiles(t, s, worker, first, count, 3, NULL), VOLUX_OK);
        assert_int_equal(volux_framebuffer_spp(worker), 3);
        size_t px = volux_framebuffer_read_tiles(worker, first, count, buf);
        assert_int_equal(px, volux_framebuffer_tile_pixels(worker, first, count));
        assert_int_equal(volux_framebuffer_write_tiles(collector, first, count, buf, 3), px);
        pixels += px;
    }
    assert_int_equal(pixels, 45 * 37);
    volux_image img = {0};
    assert_int_equal(volux_framebuffer_resolve(collector, &img), VOLUX_OK);
    assert_memory_equal(img.rgb, ref.rgb, 3 * 45 * 37 * sizeof(float));
    volux_image_free(ctx, &img);

    /* Re-rendering a range starts it from zero: still the same pixels. */
    assert_int_equal(volux_render_tiles(t, s, worker, 0, tiles, 3, NULL), VOLUX_OK);
    assert_int_equal(volux_framebuffer_resolve(worker, &img), VOLUX_OK);
    assert_memory_equal(img.rgb, ref.rgb, 3 * 45 * 37 * sizeof(float));
    volux_image_free(ctx, &img);

    volux_framebuffer_destroy(worker);
    volux_framebuffer_destroy(collector);
    volux_technique_destroy(t);
    volux_image_free(ctx, &ref);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

static void test_bad_tile_ranges_are_refused(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_scene *s = tu_scene(ctx, scene_json);
    volux_technique *t = NULL;
    volux_framebuffer *fb = NULL;
    assert_int_equal(volux_technique_create(ctx, "pathtrace", s, &t), VOLUX_OK);
    assert_int_equal(volux_framebuffer_create(ctx, 45, 37, &fb), VOLUX_OK);
    const int bad[][2] = {{-1, 1}, {0, 0}, {8, 2}, {9, 1}, {0, 10}};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        volux_context_clear_error(ctx);
        assert_int_equal(volux_render_tiles(t, s, fb, bad[i][0], bad[i][1], 1, NULL), VOLUX_ERR_INVALID);
        assert_non_null(strstr(volux_context_error(ctx), "tiles"));
    }
    double buf[VOLUX_TILE_SUMS];
    assert_int_equal(volux_framebuffer_read_tiles(fb, 9, 1, buf), 0);
    assert_int_equal(volux_framebuffer_write_tiles(fb, -1, 1, buf, 1), 0);
    assert_int_equal(volux_framebuffer_tile_pixels(fb, 5, 5), 0);
    assert_int_equal(volux_framebuffer_spp(fb), 0);
    volux_framebuffer_destroy(fb);
    volux_technique_destroy(t);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_assembled_tiles_equal_the_whole_frame),
        cmocka_unit_test(test_bad_tile_ranges_are_refused),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
