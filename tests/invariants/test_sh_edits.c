/*
 * `sh` maps edits to the least work (Lindemann & Ropinski 2010, §6: light
 * and camera changes need no new projection): white-box counters of the
 * state show which passes ran, and every incremental result equals a
 * fresh technique bit for bit (the matrix checks the latter for the
 * shared edit list on its own scene; here with an environment map, where
 * a probe rotation really changes the light).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "render/technique_class.h"
#include "techniques/sh/sh.h"
#include "test_util.h"

static const char *scene_json =
    "{\"volume\": {\"procedural\": \"cloud\", \"dims\": [28, 26, 24]},"
    " \"transfer_function\": {\"opacity\": [[0, 0], [60, 0.05], [160, 0.5], [255, 0.8]],"
    "   \"color\": [[0, 0.9, 0.4, 0.2], [128, 0.3, 0.8, 0.4], [255, 0.2, 0.3, 1.0]],"
    "   \"albedo\": 0.8, \"anisotropy\": 0.3},"
    " \"camera\": {\"orbit\": {\"azimuth\": 35, \"elevation\": 25}, \"fov_y\": 40},"
    " \"render\": {\"width\": 24, \"height\": 22, \"spp\": 1, \"technique\": \"sh\", \"threads\": 2}}";

/* An environment map with a warm bright patch off-axis and a blue sky. */
static void add_env(volux_context *ctx, volux_scene *s) {
    volux_image map;
    assert_int_equal(volux_image_create(ctx, 32, 16, &map), VOLUX_OK);
    for (int y = 0; y < 16; y++)
        for (int x = 0; x < 32; x++) {
            float *p = &map.rgb[3 * (y * 32 + x)];
            int spot = abs(x - 9) < 3 && abs(y - 5) < 3;
            p[0] = spot ? 8.0f : 0.2f, p[1] = spot ? 6.0f : 0.3f, p[2] = spot ? 3.0f : 0.6f * (16 - y) / 16.0f;
        }
    volux_light_desc d;
    volux_light_desc_defaults(&d, VOLUX_LIGHT_ENVIRONMENT);
    d.map = &map;
    d.visible = 0;
    assert_int_equal(volux_scene_set_light(s, 0, &d), VOLUX_OK);
    volux_image_free(ctx, &map);
}

static volux_scene *load(volux_context *ctx, const char *params) {
    char json[2048];
    snprintf(json, sizeof json, "%.*s, \"techniques\": {\"sh\": {%s}}}", (int)strlen(scene_json) - 1, scene_json,
             params);
    volux_scene *s = tu_scene(ctx, json);
    add_env(ctx, s);
    return s;
}

static const sh_state *state_of(const volux_technique *t) { return volux_technique_state(t); }

typedef struct counts { uint64_t projections, bakes, lights; } counts;
static counts count(const volux_technique *t) {
    const sh_state *st = state_of(t);
    counts c = {st->projections, st->bakes, st->light_projections};
    return c;
}

/* Applies edit `name` and checks: projections/bakes ran as expected, the
 * image changed (when `visible`), and incremental == fresh. */
static void check_edit(const char *params, const char *name, int reprojects, int bakes, int visible) {
    volux_context *ctx = tu_context(2);
    volux_scene *s = load(ctx, params);
    volux_technique *t;
    assert_int_equal(volux_technique_create(ctx, "sh", s, &t), VOLUX_OK);
    volux_image before = tu_render_with(ctx, s, t);
    counts c0 = count(t);
    assert_int_equal(volux_edit_apply(volux_edit_find(name), s, 0), VOLUX_OK);
    assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_OK);
    counts c1 = count(t);
    if ((int)(c1.projections - c0.projections) != reprojects)
        fail_msg("%s: %d projections, expected %d", name, (int)(c1.projections - c0.projections), reprojects);
    if ((int)(c1.bakes - c0.bakes) != bakes)
        fail_msg("%s: %d bakes, expected %d", name, (int)(c1.bakes - c0.bakes), bakes);
    volux_image after = tu_render_with(ctx, s, t), ref = tu_render(ctx, s, "sh");
    assert_true(tu_max_abs_diff(&after, &ref) == 0.0);
    if (visible && !(tu_max_abs_diff(&before, &after) > 0.0)) fail_msg("%s: the image did not change", name);
    volux_image_free(ctx, &before);
    volux_image_free(ctx, &after);
    volux_image_free(ctx, &ref);
    volux_technique_destroy(t);
    volux_scene_destroy(s);
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

static void test_light_edits_are_image_only(void **state) {
    (void)state;
    check_edit("", "light_rotate_env", 0, 1, 1);
    check_edit("", "light", 0, 1, 1);
    check_edit("", "light_color", 0, 1, 1);
    check_edit("\"bleeding\": 1, \"scattering\": 1", "light_rotate_env", 0, 1, 1);
}

static void test_camera_and_phase_cost_nothing(void **state) {
    (void)state;
    check_edit("", "camera", 0, 0, 1);
    check_edit("", "phase", 0, 0, 1);
}

static void test_tf_edits(void **state) {
    (void)state;
    check_edit("", "tf", 1, 1, 1);
    check_edit("", "density", 1, 1, 1);
    /* colour only reaches the projection through bleeding */
    check_edit("", "tf_color", 0, 0, 1);
    check_edit("\"bleeding\": 1", "tf_color", 1, 1, 1);
    /* the material channel is not baked: image only */
    check_edit("", "material", 0, 0, 1);
    check_edit("\"bleeding\": 1", "material", 0, 0, 1);
}

/* The render seed is not an input of the projection (a RENDER edit does
 * not re-project): after a seed change incremental == fresh. */
static void test_seed_edit(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    volux_scene *s = load(ctx, "");
    volux_technique *t;
    assert_int_equal(volux_technique_create(ctx, "sh", s, &t), VOLUX_OK);
    volux_render_settings rs = *volux_scene_render(s);
    rs.seed = 12345;
    assert_int_equal(volux_scene_set_render(s, &rs), VOLUX_OK);
    volux_image a = tu_render_with(ctx, s, t), b = tu_render(ctx, s, "sh");
    assert_true(tu_max_abs_diff(&a, &b) == 0.0);
    volux_image_free(ctx, &a);
    volux_image_free(ctx, &b);
    volux_technique_destroy(t);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

/* Rotating the probe by the SH rotation equals projecting the rotated map. */
static void test_probe_rotation_is_exact(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_scene *s = load(ctx, "");
    volux_light_desc d = *volux_scene_light(s, 0);
    d.rotation_y_deg = 37.0f;
    float rotated[3][16];
    assert_int_equal(sh_light_project(ctx, &d, v3(0, 0, 0), rotated), VOLUX_OK);
    /* direct: every texel at its rotated direction */
    double ref[3][16] = {{0}};
    const volux_image *m = d.map;
    for (int y = 0; y < m->height; y++)
        for (int x = 0; x < m->width; x++) {
            double th0 = M_PI * y / m->height, th1 = M_PI * (y + 1) / m->height;
            double dw = 2 * M_PI / m->width * (cos(th0) - cos(th1));
            volux_vec3 dir = volux_environment_direction(&d, (x + 0.5f) / m->width, (float)(0.5 * (th0 + th1) / M_PI));
            float yv[16];
            sh_eval(4, dir, yv);
            for (int c = 0; c < 3; c++)
                for (int j = 0; j < 16; j++) ref[c][j] += dw * m->rgb[3 * (y * m->width + x) + c] * yv[j];
        }
    for (int c = 0; c < 3; c++)
        for (int j = 0; j < 16; j++) assert_near(rotated[c][j], ref[c][j], 1e-3 * (1 + fabs(ref[c][0])));
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

/* Luma at 4 bands + chroma at 2 (§5): half the memory of RGB, close image. */
static void test_luma_chroma(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    volux_scene *a = load(ctx, "\"bleeding\": 1"), *b = load(ctx, "\"bleeding\": 1, \"chroma_bands\": 2");
    volux_technique *ta, *tb;
    assert_int_equal(volux_technique_create(ctx, "sh", a, &ta), VOLUX_OK);
    assert_int_equal(volux_technique_create(ctx, "sh", b, &tb), VOLUX_OK);
    const sh_state *sa = state_of(ta), *sb = state_of(tb);
    assert_int_equal(sa->layout.stride, 48);
    assert_int_equal(sb->layout.stride, 16 + 4 + 4);
    assert_true(sb->coef_bytes * 2 == sa->coef_bytes);
    volux_image ia = tu_render_with(ctx, a, ta), ib = tu_render_with(ctx, b, tb);
    double m = 0.0;
    for (size_t i = 0; i < 3 * (size_t)ia.width * ia.height; i++) m = fmax(m, ia.rgb[i]);
    double d = tu_max_abs_diff(&ia, &ib);
    print_message("luma/chroma: max difference %.4f of the image maximum\n", d / m);
    assert_true(d > 0.0);      /* the option does something */
    assert_true(d < 0.05 * m); /* and stays close: chroma varies slowly */
    volux_image_free(ctx, &ia);
    volux_image_free(ctx, &ib);
    volux_technique_destroy(ta);
    volux_technique_destroy(tb);
    volux_scene_destroy(a);
    volux_scene_destroy(b);
    volux_context_destroy(ctx);
}

/* Progressive projection: a TF edit first costs under a tenth of the full
 * projection's rays (the coarse level), refine then yields exactly the
 * non-progressive image, and framebuffers restart when it does. */
static void test_progressive(void **state) {
    (void)state;
    volux_context *ctx = tu_context(2);
    volux_scene *s = load(ctx, "\"progressive\": 1"), *full = load(ctx, "");
    volux_technique *t, *f;
    assert_int_equal(volux_technique_create(ctx, "sh", s, &t), VOLUX_OK);
    assert_int_equal(volux_technique_create(ctx, "sh", full, &f), VOLUX_OK);
    const sh_state *st = state_of(t), *sf = state_of(f);
    assert_true(st->coarse);
    assert_int_equal(st->grid.ratio, 2 * sf->grid.ratio);
    int refined, more;
    assert_int_equal(volux_technique_refine(t, s, &refined, &more), VOLUX_OK);
    assert_true(refined && !more);
    assert_false(st->coarse);
    assert_int_equal(volux_technique_refine(t, s, &refined, &more), VOLUX_OK);
    assert_true(!refined && !more);
    /* a TF edit: the coarse level first */
    volux_framebuffer *fb;
    assert_int_equal(volux_framebuffer_create(ctx, 24, 22, &fb), VOLUX_OK);
    assert_int_equal(volux_edit_apply(volux_edit_find("tf"), s, 0), VOLUX_OK);
    assert_int_equal(volux_edit_apply(volux_edit_find("tf"), full, 0), VOLUX_OK);
    uint64_t r0 = st->rays_cast, rf0 = sf->rays_cast;
    assert_int_equal(volux_technique_update(t, s, NULL), VOLUX_OK);
    assert_int_equal(volux_technique_update(f, full, NULL), VOLUX_OK);
    uint64_t coarse = st->rays_cast - r0, all = sf->rays_cast - rf0;
    print_message("progressive: coarse %llu rays, full %llu\n", (unsigned long long)coarse, (unsigned long long)all);
    assert_true(coarse > 0 && coarse * 10 <= all);
    assert_int_equal(volux_render(t, s, fb, NULL, NULL), VOLUX_OK);
    assert_int_equal(volux_framebuffer_spp(fb), 1);
    assert_int_equal(volux_technique_refine(t, s, &refined, &more), VOLUX_OK);
    assert_true(refined);
    assert_int_equal(volux_render(t, s, fb, NULL, NULL), VOLUX_OK);
    assert_int_equal(volux_framebuffer_spp(fb), 1); /* restarted, not 2 */
    volux_image a, b = tu_render_with(ctx, full, f);
    assert_int_equal(volux_framebuffer_resolve(fb, &a), VOLUX_OK);
    assert_true(tu_max_abs_diff(&a, &b) == 0.0);
    volux_image_free(ctx, &a);
    volux_image_free(ctx, &b);
    volux_framebuffer_destroy(fb);
    volux_technique_destroy(t);
    volux_technique_destroy(f);
    volux_scene_destroy(s);
    volux_scene_destroy(full);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_light_edits_are_image_only), cmocka_unit_test(test_camera_and_phase_cost_nothing),
        cmocka_unit_test(test_tf_edits),                   cmocka_unit_test(test_probe_rotation_is_exact),
        cmocka_unit_test(test_luma_chroma),                cmocka_unit_test(test_progressive),
        cmocka_unit_test(test_seed_edit),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
