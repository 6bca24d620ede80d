/*
 * tests/unit/test_quicklook.c — the quick look at a volume (issue 18): the
 * transfer function from the histogram, ParaView's Cool to Warm colours,
 * the default scene (camera up from the file's orientation), a scene
 * without a transfer function, --dump-scene's JSON, --set into a
 * transfer function given by file, and the $VOLUX_DATA root.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "tu_volume.h"

#define N 40

/* A CT-like volume: background 10 ± 1 around a ball whose values rise from
 * 100 at its rim to 200 at its centre (the ball is ~ 11 % of the voxels). */
static unsigned char *ct_like(void) {
    unsigned char *v = malloc(N * N * N);
    for (int z = 0; z < N; z++)
        for (int y = 0; y < N; y++)
            for (int x = 0; x < N; x++) {
                double r = sqrt((x - 19.5) * (x - 19.5) + (y - 19.5) * (y - 19.5) + (z - 19.5) * (z - 19.5));
                int value = 9 + (x + 2 * y + 3 * z) % 3;
                if (r < 12) value = (int)(200 - 100 * r / 12);
                v[(z * N + y) * N + x] = (unsigned char)value;
            }
    return v;
}

static volux_volume *make_volume(volux_context *ctx, const unsigned char *data) {
    volux_volume_desc d;
    memset(&d, 0, sizeof d);
    d.dims[0] = d.dims[1] = d.dims[2] = N;
    d.spacing[0] = d.spacing[1] = d.spacing[2] = 1;
    d.type = VOLUX_UINT8;
    d.data = data;
    volux_volume *v = NULL;
    assert_int_equal(volux_volume_create(ctx, &d, &v), VOLUX_OK);
    return v;
}

static const char *write_nrrd(const char *name, const unsigned char *data, const char *extra) {
    char header[512];
    snprintf(header, sizeof header, "NRRD0005\ntype: uint8\ndimension: 3\nsizes: %d %d %d\nencoding: raw\n%s%s\n", N,
             N, N, extra, *extra ? "\n" : "");
    return tu_write_parts(name, header, data, N * N * N);
}

static void test_ramp_starts_after_the_background_peak(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    unsigned char *data = ct_like();
    volux_volume *v = make_volume(ctx, data);
    volux_transfer_auto a;
    assert_int_equal(volux_transfer_auto_from_volume(ctx, v, &a), VOLUX_OK);
    assert_true(a.has_background);
    /* The background (9..11) is transparent, the ball's values are not. */
    assert_true(a.ramp_start >= 11 && a.ramp_start < 100);
    assert_true(a.ramp_end > 150 && a.ramp_end <= 200);
    assert_int_equal(a.n_opacity, 2);
    assert_true(a.opacity[0].v == 0.0f && a.opacity[1].v == 0.5f);
    assert_true(volux_tf_eval_scalar(a.opacity, a.n_opacity, 10) == 0.0f);
    assert_true(volux_tf_eval_scalar(a.opacity, a.n_opacity, 150) > 0.1f);
    /* Colours span the ramp. */
    assert_int_equal(a.n_color, VOLUX_TF_AUTO_COLORS);
    assert_near(a.color[0].s, a.ramp_start, 1e-3);
    assert_near(a.color[VOLUX_TF_AUTO_COLORS - 1].s, a.ramp_end, 1e-3);
    volux_volume_release(v);
    free(data);

    /* A broad distribution (a field, not a scan) has no background: the
     * ramp covers the whole range, as ParaView's default. */
    int dims[3] = {48, 48, 48};
    assert_int_equal(volux_volume_procedural(ctx, "marschner_lobb", dims, 1, &v), VOLUX_OK);
    assert_int_equal(volux_transfer_auto_from_volume(ctx, v, &a), VOLUX_OK);
    double lo, hi;
    volux_volume_range(v, &lo, &hi);
    assert_false(a.has_background);
    assert_near(a.ramp_start, lo, 1e-6);
    assert_true(a.ramp_end > lo + 0.9 * (hi - lo));
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

/* Moreland 2009's cool-warm map: its sRGB endpoints (59, 76, 192) and
 * (180, 4, 38), a near-white grey in the middle (ParaView's 0.865), blue
 * on the low half, red on the high half. Stored linear. */
static void test_cool_to_warm_colours(void **state) {
    (void)state;
    volux_tf_color_point c[VOLUX_TF_AUTO_COLORS];
    volux_transfer_auto_colors(0, 1, c);
    const volux_tf_color_point *lo = &c[0], *mid = &c[VOLUX_TF_AUTO_COLORS / 2], *hi = &c[VOLUX_TF_AUTO_COLORS - 1];
    assert_near(volux_srgb_encode(lo->r) * 255, 59, 1.0);
    assert_near(volux_srgb_encode(lo->g) * 255, 76, 1.0);
    assert_near(volux_srgb_encode(lo->b) * 255, 192, 1.0);
    assert_near(volux_srgb_encode(hi->r) * 255, 180, 1.0);
    assert_near(volux_srgb_encode(hi->g) * 255, 4, 1.0);
    assert_near(volux_srgb_encode(hi->b) * 255, 38, 1.0);
    assert_near(mid->s, 0.5, 1e-6);
    assert_near(volux_srgb_encode(mid->r), 0.865, 0.02);
    assert_near(volux_srgb_encode(mid->g), 0.865, 0.02);
    assert_near(volux_srgb_encode(mid->b), 0.865, 0.02);
    for (int i = 0; i < VOLUX_TF_AUTO_COLORS; i++) {
        if (i < VOLUX_TF_AUTO_COLORS / 2) assert_true(c[i].b > c[i].r);
        if (i > VOLUX_TF_AUTO_COLORS / 2) assert_true(c[i].r > c[i].b);
        if (i) assert_true(c[i].s > c[i - 1].s);
    }
}

static volux_scene *load(volux_context *ctx, const volux_scene_load_options *o) {
    volux_scene *s = NULL;
    volux_status st = volux_scene_load_ex(ctx, o, &s);
    if (st) fail_msg("load: %s", volux_context_error(ctx));
    return s;
}

/* A scene without a TF gets the default, says so, and --dump-scene's JSON
 * holds exactly the TF that was used. */
static void test_missing_tf_gets_the_default_and_a_note(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    unsigned char *data = ct_like();
    write_nrrd("ql_ct.nrrd", data, "");
    free(data);
    volux_scene_load_options o;
    memset(&o, 0, sizeof o);
    o.json = "{\"volume\": {\"file\": \"ql_ct.nrrd\"}, \"render\": {\"width\": 16, \"height\": 16}}";
    o.base_dir = tu_temp_path("");
    o.name = "no_tf.json";
    char *dump = NULL;
    o.effective_json = &dump;
    o.effective_dir = tu_temp_path("");
    volux_scene *s = load(ctx, &o);
    assert_non_null(strstr(volux_scene_notes(s), "no_tf.json: no transfer_function"));
    const volux_transfer_desc *tf = volux_scene_transfer(s);
    assert_int_equal(tf->n_color, VOLUX_TF_AUTO_COLORS);
    assert_int_equal(tf->n_opacity, 2);
    assert_true(tf->opacity[0].v == 0.0f && tf->opacity[0].s >= 11 && tf->opacity[0].s < 100);
    assert_non_null(dump);
    assert_non_null(strstr(dump, "\"transfer_function\": {"));
    assert_non_null(strstr(dump, "\"file\": \"ql_ct.nrrd\""));

    /* The dump, loaded as a scene, is the same scene. */
    const char *path = tu_write_file("ql_dump.json", dump, strlen(dump));
    volux_scene *t = NULL;
    assert_int_equal(volux_scene_load(ctx, path, NULL, 0, &t), VOLUX_OK);
    assert_string_equal(volux_scene_notes(t), "");
    const volux_transfer_desc *tf2 = volux_scene_transfer(t);
    assert_int_equal(tf2->n_color, tf->n_color);
    assert_int_equal(tf2->n_opacity, tf->n_opacity);
    assert_memory_equal(tf2->color, tf->color, sizeof *tf->color * (size_t)tf->n_color);
    assert_memory_equal(tf2->opacity, tf->opacity, sizeof *tf->opacity * (size_t)tf->n_opacity);
    volux_scene_json_free(ctx, dump);
    volux_scene_destroy(t);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

/* The default scene of a volume whose file says superior is +z (an NRRD
 * in an anatomical space): "z_up": true and a camera whose up is +z. */
static void test_default_scene_uses_the_files_up(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    unsigned char *data = ct_like();
    const char *plain = write_nrrd("ql_plain.nrrd", data, "");
    const char *lps = write_nrrd("ql_lps.nrrd", data,
                                 "space: left-posterior-superior\nspace directions: (1,0,0) (0,1,0) (0,0,1)");
    const char *flipped = write_nrrd("ql_flip.nrrd", data,
                                     "space: RAS\nspace directions: (1,0,0) (0,0,-2) (0,1,0)");
    free(data);
    const char *paths[3] = {plain, lps, flipped};
    const char *expect[3] = {NULL, "\"z_up\": true", "\"up\": [0, -1, 0]"};
    for (int i = 0; i < 3; i++) {
        volux_volume *v = NULL;
        assert_int_equal(volux_volume_load(ctx, paths[i], NULL, &v), VOLUX_OK);
        char vjson[600], *json = NULL;
        snprintf(vjson, sizeof vjson, "{\"file\": \"%s\"}", paths[i]);
        assert_int_equal(volux_scene_default_json(ctx, vjson, v, &json), VOLUX_OK);
        if (expect[i]) assert_non_null(strstr(json, expect[i]));
        else assert_null(strstr(json, "\"up\"")), assert_null(strstr(json, "z_up"));
        assert_non_null(strstr(json, "\"technique\": \"shaded\""));
        volux_scene_load_options o;
        memset(&o, 0, sizeof o);
        o.json = json;
        o.name = "default";
        o.volume = v;
        o.volume_file = paths[i];
        volux_scene *s = load(ctx, &o);
        assert_true(volux_scene_volume(s) == v); /* the preloaded volume, not a second load */
        volux_camera cam;
        assert_int_equal(volux_scene_camera(s, &cam), VOLUX_OK);
        float want_up[3][3] = {{0, 1, 0}, {0, 0, 1}, {0, -1, 0}};
        volux_vec3 sup;
        assert_int_equal(volux_volume_superior(v, &sup), i > 0);
        float dot = cam.up.x * want_up[i][0] + cam.up.y * want_up[i][1] + cam.up.z * want_up[i][2];
        assert_true(dot > 0.9f); /* el = 20°: cos 20° = 0.94 */
        /* The key light comes from above, in the same frame. */
        const volux_light_desc *key = volux_scene_light(s, 0);
        assert_non_null(key);
        float down = key->direction.x * want_up[i][0] + key->direction.y * want_up[i][1] +
                     key->direction.z * want_up[i][2];
        assert_true(down < -0.5f);
        volux_scene_destroy(s);
        volux_scene_json_free(ctx, json);
        volux_volume_release(v);
    }
    volux_context_destroy(ctx);
}

/* --set reaches into a TF given by file name (the bonsai scene's style);
 * the TF's own relative names still resolve against its folder. */
static void test_set_reaches_into_a_tf_file(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    mkdir(tu_temp_path("ql_tfdir"), 0700);
    const char *preset = "[{\"Name\": \"two\", \"RGBPoints\": [0, 1, 0, 0, 1, 0, 0, 1]}]";
    tu_write_file("ql_tfdir/preset.json", preset, strlen(preset));
    const char *tf = "{\"preset\": \"preset.json\", \"opacity\": [[0, 0], [1, 0.5]], \"albedo\": 0.9}";
    tu_write_file("ql_tfdir/tf.json", tf, strlen(tf));
    const char *scene = "{\"volume\": {\"procedural\": \"sphere\", \"dims\": [8, 8, 8]},"
                        " \"transfer_function\": \"ql_tfdir/tf.json\"}";
    const char *path = tu_write_file("ql_tf_scene.json", scene, strlen(scene));
    const char *set[] = {"transfer_function.albedo=0.25", "transfer_function.anisotropy=0.5"};
    volux_scene *s = NULL;
    assert_int_equal(volux_scene_load(ctx, path, set, 2, &s), VOLUX_OK);
    assert_near(volux_scene_transfer(s)->albedo, 0.25, 1e-7);
    assert_near(volux_scene_transfer(s)->anisotropy, 0.5, 1e-7);
    assert_int_equal(volux_scene_transfer(s)->n_color, 2); /* the preset, found beside tf.json */
    volux_scene_destroy(s);
    /* A mistake inside names the TF file and the key. */
    const char *bad[] = {"transfer_function.albedoo=0.25"};
    assert_int_equal(volux_scene_load(ctx, path, bad, 1, &s), VOLUX_ERR_INVALID);
    tu_assert_error_mentions(ctx, "ql_tf_scene.json", "tf.json", "transfer_function.albedoo", NULL);
    volux_context_clear_error(ctx);
    /* Replacing the whole reference still works, as before. */
    const char *whole[] = {"transfer_function={\"opacity\": [[0, 0], [1, 1]]}"};
    assert_int_equal(volux_scene_load(ctx, path, whole, 1, &s), VOLUX_OK);
    assert_int_equal(volux_scene_transfer(s)->n_color, 0);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

/* "$VOLUX_DATA/..." names the shared data root given by the caller (the
 * CLI: the environment, else ../shared/data); without one the message
 * says what to set. */
static void test_data_root(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    mkdir(tu_temp_path("ql_data"), 0700);
    mkdir(tu_temp_path("ql_data/volumes"), 0700);
    unsigned char *data = ct_like();
    write_nrrd("ql_data/volumes/ct.nrrd", data, "");
    free(data);
    volux_scene_load_options o;
    memset(&o, 0, sizeof o);
    o.json = "{\"volume\": {\"file\": \"$VOLUX_DATA/volumes/ct.nrrd\"}}";
    o.name = "data.json";
    o.data_dir = tu_temp_path("ql_data");
    volux_scene *s = load(ctx, &o);
    volux_scene_destroy(s);
    o.data_dir = NULL;
    unsetenv("VOLUX_DATA");
    assert_int_equal(volux_scene_load_ex(ctx, &o, &s), VOLUX_ERR_IO);
    tu_assert_error_mentions(ctx, "data.json", "volume.file", "VOLUX_DATA is not set", NULL);
    volux_context_clear_error(ctx);
    setenv("VOLUX_DATA", tu_temp_path("ql_data"), 1);
    s = load(ctx, &o);
    volux_scene_destroy(s);
    unsetenv("VOLUX_DATA");
    volux_context_destroy(ctx);
}

/* The dump's file names work from the folder the dump is written to. */
static void test_dump_rebases_file_names(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    mkdir(tu_temp_path("ql_a"), 0700);
    mkdir(tu_temp_path("ql_b"), 0700);
    mkdir(tu_temp_path("ql_b/deeper"), 0700);
    unsigned char *data = ct_like();
    write_nrrd("ql_a/vol.nrrd", data, "");
    free(data);
    const char *scene = "{\"volume\": {\"file\": \"vol.nrrd\"},"
                        " \"transfer_function\": {\"opacity\": [[0, 0], [255, 0.5]]}}";
    const char *path = tu_write_file("ql_a/scene.json", scene, strlen(scene));
    volux_scene_load_options o;
    memset(&o, 0, sizeof o);
    o.path = path;
    char *dump = NULL;
    o.effective_json = &dump;
    o.effective_dir = tu_temp_path("ql_b/deeper");
    volux_scene *s = load(ctx, &o);
    volux_scene_destroy(s);
    assert_non_null(strstr(dump, "\"file\": \"../../ql_a/vol.nrrd\""));
    const char *moved = tu_write_file("ql_b/deeper/scene.json", dump, strlen(dump));
    volux_scene_json_free(ctx, dump);
    assert_int_equal(volux_scene_load(ctx, moved, NULL, 0, &s), VOLUX_OK);
    volux_scene_destroy(s);
    /* A file under the data root is written as "$VOLUX_DATA/...": the dump
     * then works on any machine that has the data. */
    o.data_dir = tu_temp_path("ql_a");
    s = load(ctx, &o);
    volux_scene_destroy(s);
    assert_non_null(strstr(dump, "\"file\": \"$VOLUX_DATA/vol.nrrd\""));
    volux_scene_json_free(ctx, dump);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_ramp_starts_after_the_background_peak),
        cmocka_unit_test(test_cool_to_warm_colours),
        cmocka_unit_test(test_missing_tf_gets_the_default_and_a_note),
        cmocka_unit_test(test_default_scene_uses_the_files_up),
        cmocka_unit_test(test_set_reaches_into_a_tf_file),
        cmocka_unit_test(test_data_root),
        cmocka_unit_test(test_dump_rebases_file_names),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
