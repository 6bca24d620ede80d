/*
 * pathtrace invariants beyond the technique × edit matrix: the edits of
 * pathtrace's own state — an environment map's sampling table (per slot),
 * removed slots among sphere/spot/point lights, its string parameters
 * (classification, majorant, sampler), seed and max_depth — keep incremental ==
 * fresh, bit for bit. The scene exercises every light type, an environment
 * map, a colour TF and a heterogeneous volume spanning several macrocells
 * and tiles.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "pt_util.h"

enum { W = 20, H = 18 };

static float blob(int i, int j, int k, void *u) {
    (void)u;
    float x = (i - 8.0f) / 8.0f, y = (j - 8.0f) / 8.0f, z = (k - 8.0f) / 8.0f;
    float r = sqrtf(x * x + y * y + z * z);
    return fmaxf(0.0f, 1.0f - r) + 0.1f * (float)((i * 7 + j * 13 + k * 3) % 5) / 5.0f;
}

static float env_px[3 * 8 * 4];
static volux_image env_map = {8, 4, env_px};

static volux_scene *make_scene(volux_context *ctx, volux_volume *v) {
    static const volux_tf_scalar_point ext[3] = {{0.0f, 0.0f}, {0.3f, 0.2f}, {1.0f, 2.0f}};
    static const volux_tf_color_point col[2] = {{0.0f, 1.0f, 0.4f, 0.2f}, {1.0f, 0.3f, 0.6f, 1.0f}};
    volux_scene *s = pt_scene(ctx, v, ext, 3, col, 2, 0.9f, 0.4f, 20.0f, W, H, 8);
    for (int i = 0; i < 8 * 4; i++) {
        env_px[3 * i] = 0.2f + 0.1f * (float)(i % 8);
        env_px[3 * i + 1] = 0.3f;
        env_px[3 * i + 2] = i == 10 ? 30.0f : 0.5f;
    }
    volux_light_desc l;
    volux_light_desc_defaults(&l, VOLUX_LIGHT_ENVIRONMENT);
    l.map = &env_map;
    l.rotation_y_deg = 20.0f;
    assert_int_equal(volux_scene_set_light(s, 0, &l), VOLUX_OK);
    volux_light_desc_defaults(&l, VOLUX_LIGHT_DIRECTIONAL);
    l.direction = (volux_vec3){0.3f, -1.0f, -0.2f};
    l.irradiance = 2.0f;
    assert_int_equal(volux_scene_set_light(s, 1, &l), VOLUX_OK);
    volux_light_desc_defaults(&l, VOLUX_LIGHT_POINT);
    l.position = (volux_vec3){12, 3, 4};
    l.intensity = 50.0f;
    assert_int_equal(volux_scene_set_light(s, 2, &l), VOLUX_OK);
    volux_light_desc_defaults(&l, VOLUX_LIGHT_SPOT);
    l.position = (volux_vec3){-12, 0, 6};
    l.direction = (volux_vec3){1, 0, -0.4f};
    l.intensity = 80.0f;
    assert_int_equal(volux_scene_set_light(s, 4, &l), VOLUX_OK);
    volux_light_desc_defaults(&l, VOLUX_LIGHT_SPHERE);
    l.position = (volux_vec3){0, 14, 0};
    l.radius = 3.0f;
    l.radiance = 4.0f;
    assert_int_equal(volux_scene_set_light(s, 5, &l), VOLUX_OK);
    return s;
}

static void render(volux_context *ctx, volux_technique *t, volux_scene *s, uint32_t spp, volux_image *out) {
    volux_framebuffer *fb;
    assert_int_equal(volux_framebuffer_create(ctx, W, H, &fb), VOLUX_OK);
    volux_render_limits lim = {spp, 0, 0};
    assert_int_equal(volux_render(t, s, fb, &lim, NULL), VOLUX_OK);
    assert_int_equal(volux_framebuffer_resolve(fb, out), VOLUX_OK);
    volux_framebuffer_destroy(fb);
}

static void assert_same(const volux_image *a, const volux_image *b, const char *what) {
    if (memcmp(a->rgb, b->rgb, sizeof(float) * 3 * W * H) != 0) fail_msg("%s: images differ", what);
}

typedef void (*edit_fn)(volux_context *ctx, volux_scene *s);

static void edit_env_map(volux_context *ctx, volux_scene *s) {
    (void)ctx;
    volux_light_desc l = *volux_scene_light(s, 0);
    static float px[3 * 4 * 2] = {1, 1, 1, 5, 0, 0, 0, 0, 0, 1, 2, 3, 0, 0, 0, 9, 9, 9, 0, 0, 1, 0, 1, 0};
    static volux_image m = {4, 2, px};
    l.map = &m;
    assert_int_equal(volux_scene_set_light(s, 0, &l), VOLUX_OK);
}
static void edit_light_toggle_and_remove(volux_context *ctx, volux_scene *s) {
    (void)ctx;
    assert_int_equal(volux_scene_set_light_enabled(s, 1, 0), VOLUX_OK);
    assert_int_equal(volux_scene_remove_light(s, 5), VOLUX_OK);
}
static void edit_params(volux_context *ctx, volux_scene *s) {
    (void)ctx;
    assert_int_equal(volux_scene_set_param(s, "pathtrace", "classification", 0, "pre"), VOLUX_OK);
    assert_int_equal(volux_scene_set_param(s, "pathtrace", "rr_depth", 1, NULL), VOLUX_OK);
    assert_int_equal(volux_scene_set_param(s, "pathtrace", "majorant", 0, "global"), VOLUX_OK);
}
static void edit_sampler(volux_context *ctx, volux_scene *s) {
    (void)ctx;
    assert_int_equal(volux_scene_set_param(s, "pathtrace", "sampler", 0, "independent"), VOLUX_OK);
}
static void edit_render(volux_context *ctx, volux_scene *s) {
    (void)ctx;
    volux_render_settings rs = *volux_scene_render(s);
    rs.seed = 99;
    rs.max_depth = 2;
    assert_int_equal(volux_scene_set_render(s, &rs), VOLUX_OK);
    volux_scene_set_background((volux_scene *)s, (volux_vec3){0.1f, 0.2f, 0.3f});
}

static void test_incremental_update_equals_fresh_create(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    volux_volume *v = pt_volume_fn(ctx, 17, 17, 17, blob, NULL);
    volux_scene *s = make_scene(ctx, v);
    volux_technique *t;
    assert_int_equal(volux_technique_create(ctx, "pathtrace", s, &t), VOLUX_OK);
    const struct {
        const char *name;
        edit_fn fn;
    } edits[] = {{"env map", edit_env_map}, {"light toggle/remove", edit_light_toggle_and_remove},
                 {"params", edit_params},   {"sampler", edit_sampler},
                 {"render", edit_render}};
    volux_image before, inc, fresh;
    render(ctx, t, s, 2, &before);
    for (size_t e = 0; e < sizeof edits / sizeof edits[0]; e++) {
        edits[e].fn(ctx, s);
        volux_change_set c;
        assert_int_equal(volux_technique_update(t, s, &c), VOLUX_OK);
        assert_true(c.what != 0);
        render(ctx, t, s, 2, &inc);
        volux_technique *f;
        assert_int_equal(volux_technique_create(ctx, "pathtrace", s, &f), VOLUX_OK);
        render(ctx, f, s, 2, &fresh);
        assert_same(&inc, &fresh, edits[e].name);
        if (!memcmp(inc.rgb, before.rgb, sizeof(float) * 3 * W * H)) fail_msg("%s: the edit changed nothing", edits[e].name);
        volux_image_free(ctx, &before);
        before = inc;
        volux_image_free(ctx, &fresh);
        volux_technique_destroy(f);
    }
    volux_image_free(ctx, &before);
    /* a bad string parameter is an error naming it */
    assert_int_equal(volux_scene_set_param(s, "pathtrace", "classification", 0, "sideways"), VOLUX_OK);
    volux_context_clear_error(ctx);
    assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_ERR_INVALID);
    assert_non_null(strstr(volux_context_error(ctx), "techniques.pathtrace.classification"));
    assert_int_equal(volux_scene_set_param(s, "pathtrace", "classification", 0, "post"), VOLUX_OK);
    assert_int_equal(volux_scene_set_param(s, "pathtrace", "sampler", 0, "halton"), VOLUX_OK);
    volux_context_clear_error(ctx);
    assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_ERR_INVALID);
    assert_non_null(strstr(volux_context_error(ctx), "techniques.pathtrace.sampler"));
    volux_technique_destroy(t);
    volux_scene_destroy(s);
    volux_volume_release(v);
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_incremental_update_equals_fresh_create),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
