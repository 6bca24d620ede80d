/*
 * tests/unit/test_scene_doc.c — scene documents (volux_scene_doc_*): edits
 * in the --set form applied to a live scene through its setters. An edit
 * bumps exactly the versions it changes (techniques see incremental change
 * sets), a failed edit leaves document and scene unchanged with the message
 * `volux_scene_load` prints for the same --set, the JSON after edits loads
 * to the same scene, files named by edits stay inside the data root
 * (symbolic links too), and the JSON edit list is read strictly.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/context_internal.h"
#include "io/image_formats.h"
#include "io/scene_formats.h"
#include "test_util.h"

#define assert_contains(hay, needle)                                                                   \
    do {                                                                                               \
        const char *h_ = (hay), *n_ = (needle);                                                        \
        if (!strstr(h_, n_)) fail_msg("expected \"%s\" in \"%s\"", n_, h_);                           \
    } while (0)

static const char *SCENE =
    "{\n"
    " \"volume\": {\"procedural\": \"sphere\", \"dims\": [16, 16, 16]},\n"
    " \"transfer_function\": {\"color\": [[0, 1, 0.5, 0.2], [255, 1, 1, 1]],\n"
    "                       \"opacity\": [[0, 0], [255, 0.5]], \"albedo\": 0.8},\n"
    " \"camera\": {\"orbit\": {\"azimuth\": 30, \"elevation\": 20}, \"fov_y\": 30},\n"
    " \"lights\": [{\"type\": \"directional\", \"direction\": [-1, -1, -1], \"irradiance\": 2},\n"
    "              {\"type\": \"point\", \"position\": [20, 20, 20], \"intensity\": 100}],\n"
    " \"render\": {\"technique\": \"shaded\", \"width\": 24, \"height\": 16},\n"
    " \"techniques\": {\"ea\": {\"preintegrate\": false}}\n"
    "}\n";

/* A scene file in a fresh folder of the temp dir; returns its path. */
static const char *scene_file(const char *folder, const char *json) {
    static char path[1100];
    char dir[512];
    snprintf(dir, sizeof dir, "%s", tu_temp_path(folder));
    mkdir(dir, 0755);
    snprintf(path, sizeof path, "%s/scene.json", dir);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(json, f);
    fclose(f);
    return path;
}

static volux_scene_doc *doc_ok(volux_context *ctx, const char *path, const volux_scene_doc_options *opt) {
    volux_scene_doc *doc = NULL;
    volux_status st = volux_scene_doc_load(ctx, path, NULL, 0, opt, &doc);
    if (st) fail_msg("doc load failed: %s", volux_context_error(ctx));
    return doc;
}

static void edit_ok(volux_scene_doc *doc, const char *assignment, uint32_t *changed) {
    volux_context *ctx = volux_scene_context(volux_scene_doc_scene(doc));
    volux_context_clear_error(ctx);
    volux_status st = volux_scene_doc_edit(doc, &assignment, 1, changed);
    if (st) fail_msg("edit '%s' failed: %s", assignment, volux_context_error(ctx));
}

static char *doc_text(volux_scene_doc *doc, unsigned flags, size_t *n) {
    char *t = NULL;
    assert_int_equal(volux_scene_doc_json(doc, flags, &t, n), VOLUX_OK);
    return t;
}

/* ------------------------------------------------------------------ change sets */

/* Each edit bumps only its own aspect: what a technique's update sees. */
static void test_edits_bump_only_what_changed(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_scene_doc *doc = doc_ok(ctx, scene_file("doc_bump", SCENE), NULL);
    volux_scene *s = volux_scene_doc_scene(doc);
    const volux_volume *vol = volux_scene_volume(s);
    volux_scene_stamp seen = volux_scene_stamp_now(s);
    uint32_t changed = 0;

    edit_ok(doc, "lights.1.intensity=250", &changed);
    volux_change_set c = volux_scene_changes_since(s, &seen);
    assert_int_equal(c.what, VOLUX_CHANGE_LIGHTS);
    assert_false(volux_change_light(&c, 0));
    assert_true(volux_change_light(&c, 1));
    assert_int_equal(changed, VOLUX_DOC_LIGHTS);
    assert_near(volux_scene_light(s, 1)->intensity, 250, 0);
    assert_ptr_equal(volux_scene_volume(s), vol); /* not loaded again */

    seen = volux_scene_stamp_now(s);
    edit_ok(doc, "transfer_function.color.0.2=0.25", &changed); /* [s, r, g, b] */
    c = volux_scene_changes_since(s, &seen);
    assert_int_equal(c.what, VOLUX_CHANGE_COLOR);
    assert_int_equal(changed, VOLUX_DOC_TRANSFER);
    assert_near(volux_scene_transfer(s)->color[0].g, 0.25, 0);

    seen = volux_scene_stamp_now(s);
    edit_ok(doc, "transfer_function.opacity=[[0,0],[128,0.2],[255,0.9]]", NULL);
    assert_int_equal(volux_scene_changes_since(s, &seen).what, VOLUX_CHANGE_EXTINCTION);
    assert_int_equal(volux_scene_transfer(s)->n_opacity, 3);

    seen = volux_scene_stamp_now(s);
    edit_ok(doc, "transfer_function.anisotropy=0.4", NULL);
    assert_int_equal(volux_scene_changes_since(s, &seen).what, VOLUX_CHANGE_PHASE);
    seen = volux_scene_stamp_now(s);
    edit_ok(doc, "transfer_function.density_scale=2", NULL);
    assert_int_equal(volux_scene_changes_since(s, &seen).what, VOLUX_CHANGE_DENSITY);

    seen = volux_scene_stamp_now(s);
    edit_ok(doc, "camera.orbit.azimuth=75", &changed);
    assert_int_equal(volux_scene_changes_since(s, &seen).what, VOLUX_CHANGE_CAMERA);
    assert_int_equal(changed, VOLUX_DOC_CAMERA);
    assert_near(volux_scene_camera_desc(s)->azimuth_deg, 75, 0);

    seen = volux_scene_stamp_now(s);
    edit_ok(doc, "lights.0.enabled=false", NULL);
    c = volux_scene_changes_since(s, &seen);
    assert_int_equal(c.what, VOLUX_CHANGE_LIGHTS);
    assert_true(volux_change_light(&c, 0));
    assert_false(volux_change_light(&c, 1));
    assert_int_equal(volux_scene_light(s, 0)->enabled, 0);

    seen = volux_scene_stamp_now(s);
    edit_ok(doc, "techniques.shaded.specular_power_scale=2", NULL); /* io does not know parameters */
    assert_int_equal(volux_scene_changes_since(s, &seen).what, VOLUX_CHANGE_PARAMS);
    assert_near(volux_scene_param(s, "shaded", "specular_power_scale", 0), 2, 0);

    /* Threads change no pixel: stored, nothing bumped. */
    seen = volux_scene_stamp_now(s);
    edit_ok(doc, "render.threads=1", NULL);
    assert_int_equal(volux_scene_changes_since(s, &seen).what, 0);
    assert_int_equal(volux_scene_render(s)->threads, 1);

    seen = volux_scene_stamp_now(s);
    edit_ok(doc, "render.technique=ea", NULL);
    assert_int_equal(volux_scene_changes_since(s, &seen).what, VOLUX_CHANGE_RENDER);

    /* An edit that sets what is already there changes nothing. */
    seen = volux_scene_stamp_now(s);
    edit_ok(doc, "lights.1.intensity=250", &changed);
    assert_int_equal(volux_scene_changes_since(s, &seen).what, 0);
    assert_int_equal(changed, 0);

    /* A new volume: VOLUME, and the TF is baked for it. */
    seen = volux_scene_stamp_now(s);
    edit_ok(doc, "volume.dims=[12,12,12]", &changed);
    assert_true(volux_scene_changes_since(s, &seen).what & VOLUX_CHANGE_VOLUME);
    assert_true(changed & VOLUX_DOC_VOLUME);
    int dims[3];
    volux_volume_dims(volux_scene_volume(s), dims);
    assert_int_equal(dims[0], 12);
    assert_int_equal(volux_scene_doc_version(doc), 12); /* no-op edits count too */
    volux_scene_doc_destroy(doc);
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

/* Lights added, removed (a shorter array) and replaced; parameters removed. */
static void test_lights_and_params_come_and_go(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_scene_doc *doc = doc_ok(ctx, scene_file("doc_lights", SCENE), NULL);
    volux_scene *s = volux_scene_doc_scene(doc);
    volux_scene_stamp seen = volux_scene_stamp_now(s);
    edit_ok(doc, "lights.2={\"type\":\"sphere\",\"position\":[0,30,0],\"radius\":3,\"radiance\":4}", NULL);
    volux_change_set c = volux_scene_changes_since(s, &seen);
    assert_true(volux_change_light(&c, 2));
    assert_false(volux_change_light(&c, 0) || volux_change_light(&c, 1));
    assert_int_equal(volux_scene_light_slots(s), 3);
    assert_int_equal(volux_scene_light(s, 2)->type, VOLUX_LIGHT_SPHERE);

    /* Remove the middle light: later slots move down one. */
    seen = volux_scene_stamp_now(s);
    edit_ok(doc,
            "lights=[{\"type\":\"directional\",\"direction\":[-1,-1,-1],\"irradiance\":2},"
            "{\"type\":\"sphere\",\"position\":[0,30,0],\"radius\":3,\"radiance\":4}]",
            NULL);
    c = volux_scene_changes_since(s, &seen);
    assert_false(volux_change_light(&c, 0));
    assert_true(volux_change_light(&c, 1) && volux_change_light(&c, 2));
    assert_int_equal(volux_scene_light_slots(s), 2);
    assert_int_equal(volux_scene_light(s, 1)->type, VOLUX_LIGHT_SPHERE);
    assert_null(volux_scene_light(s, 2));

    edit_ok(doc, "lights=[]", NULL);
    assert_int_equal(volux_scene_light_slots(s), 0);

    assert_near(volux_scene_param(s, "ea", "preintegrate", 7), 0, 0);
    seen = volux_scene_stamp_now(s);
    edit_ok(doc, "techniques={}", NULL);
    assert_int_equal(volux_scene_changes_since(s, &seen).what, VOLUX_CHANGE_PARAMS);
    assert_near(volux_scene_param(s, "ea", "preintegrate", 7), 7, 0);
    volux_scene_doc_destroy(doc);
    volux_context_destroy(ctx);
}

/* ------------------------------------------------------------------ failures */

/* A failed edit: the message of `volux_scene_load` with the same --set,
 * nothing changed (versions, JSON), no memory left behind. */
static void expect_rejected(volux_context *ctx, volux_scene_doc *doc, const char *path, const char *assignment,
                            const char *part) {
    volux_scene *s = volux_scene_doc_scene(doc);
    volux_scene_stamp before = volux_scene_stamp_now(s);
    size_t n0, n1;
    uint64_t bytes = volux_context_bytes_in_use(ctx), version = volux_scene_doc_version(doc);
    char *json0 = doc_text(doc, 0, &n0);
    volux_context_clear_error(ctx);
    volux_status st = volux_scene_doc_edit(doc, &assignment, 1, NULL);
    if (!st) fail_msg("edit '%s' was accepted", assignment);
    char msg[1024];
    snprintf(msg, sizeof msg, "%s", volux_context_error(ctx));
    assert_contains(msg, part);
    assert_int_equal(volux_scene_changes_since(s, &before).what, 0);
    assert_int_equal(volux_scene_doc_version(doc), version);
    char *json1 = doc_text(doc, 0, &n1);
    assert_string_equal(json0, json1);
    volux_scene_doc_json_free(doc, json0, n0);
    volux_scene_doc_json_free(doc, json1, n1);
    assert_int_equal(volux_context_bytes_in_use(ctx), bytes);
    if (path) {
        /* The CLI's loader says the same about the same --set. */
        volux_scene *other = NULL;
        volux_context_clear_error(ctx);
        assert_int_equal(volux_scene_load(ctx, path, &assignment, 1, &other), st);
        assert_string_equal(volux_context_error(ctx), msg);
    }
}

static void test_bad_edits_change_nothing(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    const char *path = scene_file("doc_bad", SCENE);
    volux_scene_doc *doc = doc_ok(ctx, path, NULL);
    expect_rejected(ctx, doc, path, "lights.0.irradiance=-1", "lights[0].irradiance");
    expect_rejected(ctx, doc, path, "lights.0.colour=[1,1,1]", "lights[0].colour");
    expect_rejected(ctx, doc, path, "lights.7.irradiance=1", "is not an index");
    expect_rejected(ctx, doc, path, "transfer_function.albedo=2", "transfer_function.albedo");
    expect_rejected(ctx, doc, path, "transfer_function.opacity=[[10,0],[5,1]]", "opacity");
    expect_rejected(ctx, doc, path, "camera.orbit.elevation=95", "camera.orbit.elevation");
    expect_rejected(ctx, doc, path, "render.width=0", "render.width");
    expect_rejected(ctx, doc, path, "render.width.x=1", "is a value");
    expect_rejected(ctx, doc, path, "volume.procedural=nothing", "volume.procedural");
    expect_rejected(ctx, doc, path, "nonsense=1", "nonsense");
    expect_rejected(ctx, doc, path, "lights.0={\"type\":\"directional\"", "--set");
    expect_rejected(ctx, doc, path, "lights..x=1", "empty key");
    /* several edits: all or none */
    const char *two[] = {"lights.0.irradiance=5", "lights.1.intensity=-3"};
    volux_scene_stamp before = volux_scene_stamp_now(volux_scene_doc_scene(doc));
    assert_int_not_equal(volux_scene_doc_edit(doc, two, 2, NULL), VOLUX_OK);
    assert_int_equal(volux_scene_changes_since(volux_scene_doc_scene(doc), &before).what, 0);
    assert_near(volux_scene_light(volux_scene_doc_scene(doc), 0)->irradiance, 2, 0);
    volux_scene_doc_destroy(doc);
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

/* The validate hook (technique names, size limits) rejects like the reader. */
static volux_status no_wide_images(void *user, volux_context *ctx, const volux_scene *cand) {
    int *calls = user;
    ++*calls;
    if (volux_scene_render(cand)->width > 100)
        return volux_context_set_error(ctx, VOLUX_ERR_LIMIT, "render.width: at most 100 here");
    return VOLUX_OK;
}

static void test_validate_hook(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    int calls = 0;
    volux_scene_doc_options opt = {NULL, no_wide_images, &calls};
    volux_scene_doc *doc = doc_ok(ctx, scene_file("doc_validate", SCENE), &opt);
    assert_int_equal(calls, 1);
    expect_rejected(ctx, doc, NULL, "render.width=101", "at most 100 here");
    edit_ok(doc, "render.width=100", NULL);
    assert_int_equal(volux_scene_render(volux_scene_doc_scene(doc))->width, 100);
    volux_scene_doc_destroy(doc);
    volux_context_destroy(ctx);
}

/* ------------------------------------------------------------------ JSON */

static void test_edit_json(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_scene_doc *doc = doc_ok(ctx, scene_file("doc_json", SCENE), NULL);
    volux_scene *s = volux_scene_doc_scene(doc);
    const char *ok = "[{\"path\": \"lights.0.irradiance\", \"value\": 3.5},"
                     " {\"path\": \"render.technique\", \"value\": \"ea\"},"
                     " {\"path\": \"transfer_function.color\", \"value\": [[0, 0, 0, 1], [255, 1, 0, 0]]}]";
    uint32_t changed = 0;
    assert_int_equal(volux_scene_doc_edit_json(doc, ok, strlen(ok), &changed), VOLUX_OK);
    assert_near(volux_scene_light(s, 0)->irradiance, 3.5, 0);
    assert_string_equal(volux_scene_render(s)->technique, "ea");
    assert_int_equal(changed, VOLUX_DOC_LIGHTS | VOLUX_DOC_TRANSFER | VOLUX_DOC_OTHER);
    static const struct {
        const char *text, *part;
    } bad[] = {
        {"{\"path\": \"a\", \"value\": 1}", "expected an array"},
        {"[{\"path\": \"lights.0.irradiance\"}]", "edit[0]: missing value"},
        {"[{\"path\": \"lights.0.irradiance\", \"value\": 1, \"x\": 2}]", "edit[0].x"},
        {"[{\"path\": 3, \"value\": 1}]", "edit[0].path"},
        {"[{\"path\": \"a=b\", \"value\": 1}]", "edit[0].path"},
        {"[1]", "edit[0]"},
        {"[{\"path\": \"lights.0.irradiance\", \"value\": 1}", "invalid JSON"},
        {"[{\"path\": \"lights.0.irradiance\", \"value\": -1}]", "lights[0].irradiance"},
        {"[{\"path\": \"lights.0.irradiance\", \"path\": \"x\", \"value\": 1}]", "duplicate"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        volux_scene_stamp before = volux_scene_stamp_now(s);
        uint64_t bytes = volux_context_bytes_in_use(ctx);
        volux_context_clear_error(ctx);
        assert_int_not_equal(volux_scene_doc_edit_json(doc, bad[i].text, strlen(bad[i].text), NULL), VOLUX_OK);
        assert_contains(volux_context_error(ctx), bad[i].part);
        assert_int_equal(volux_scene_changes_since(s, &before).what, 0);
        assert_int_equal(volux_context_bytes_in_use(ctx), bytes);
    }
    /* Bounded: 257 entries are refused before anything is applied. */
    size_t cap = 257 * 48 + 8, len = 0;
    char *many = malloc(cap);
    len += (size_t)snprintf(many + len, cap - len, "[");
    for (int i = 0; i < 257; i++)
        len += (size_t)snprintf(many + len, cap - len, "%s{\"path\":\"render.spp\",\"value\":2}", i ? "," : "");
    snprintf(many + len, cap - len, "]");
    volux_context_clear_error(ctx);
    assert_int_equal(volux_scene_doc_edit_json(doc, many, strlen(many), NULL), VOLUX_ERR_LIMIT);
    free(many);
    volux_scene_doc_destroy(doc);
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

/* Loads `text` the way the CLI would and checks it equals the live scene. */
static void assert_same_scene(volux_context *ctx, const volux_scene *a, const volux_scene *b) {
    const volux_transfer_desc *ta = volux_scene_transfer(a), *tb = volux_scene_transfer(b);
    assert_int_equal(ta->n_color, tb->n_color);
    assert_memory_equal(ta->color, tb->color, sizeof *ta->color * (size_t)ta->n_color);
    assert_int_equal(ta->n_opacity, tb->n_opacity);
    assert_memory_equal(ta->opacity, tb->opacity, sizeof *ta->opacity * (size_t)ta->n_opacity);
    assert_true(ta->albedo == tb->albedo && ta->anisotropy == tb->anisotropy && ta->density_scale == tb->density_scale);
    assert_memory_equal(volux_scene_camera_desc(a), volux_scene_camera_desc(b), sizeof(volux_camera_desc));
    assert_memory_equal(volux_scene_render(a), volux_scene_render(b), sizeof(volux_render_settings));
    assert_int_equal(volux_scene_light_slots(a), volux_scene_light_slots(b));
    for (int i = 0; i < volux_scene_light_slots(a); i++)
        assert_memory_equal(volux_scene_light(a, i), volux_scene_light(b, i), offsetof(volux_light_desc, map));
    int da[3], db[3];
    volux_volume_dims(volux_scene_volume(a), da);
    volux_volume_dims(volux_scene_volume(b), db);
    assert_memory_equal(da, db, sizeof da);
    (void)ctx;
}

/* The JSON after edits is the live scene; with absolute paths it loads
 * from any folder (what the viewer's "save scene" downloads). */
static void test_json_reproduces_the_scene(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    /* A scene that names a file: the TF lives beside it. */
    const char *tf = "{\"color\": [[0, 0, 0, 1], [255, 1, 1, 0]], \"opacity\": [[0, 0], [255, 0.3]]}";
    const char *path = scene_file("doc_save", "{\"volume\": {\"procedural\": \"phantom\", \"dims\": [10, 10, 10]},"
                                              " \"transfer_function\": \"tf.json\","
                                              " \"lights\": [{\"type\": \"directional\", \"direction\": [0, -1, 0]}]}");
    char tf_path[512];
    snprintf(tf_path, sizeof tf_path, "%s/tf.json", tu_temp_path("doc_save"));
    FILE *f = fopen(tf_path, "w");
    fputs(tf, f);
    fclose(f);
    volux_scene_doc *doc = doc_ok(ctx, path, NULL);
    edit_ok(doc, "lights.0.irradiance=0.1", NULL);
    edit_ok(doc, "camera={\"eye\":[30,10,40],\"look_at\":[1,2,3],\"fov_y\":40}", NULL);
    edit_ok(doc, "render.width=33", NULL);
    edit_ok(doc, "lights.1={\"type\":\"environment\",\"radiance\":0.3}", NULL);
    size_t n;
    char *text = doc_text(doc, VOLUX_DOC_JSON_PRETTY, &n);
    volux_scene *again = NULL;
    assert_int_equal(volux_scene_load_string(ctx, text, tu_temp_path("doc_save"), "saved", NULL, 0, &again),
                     VOLUX_OK);
    assert_same_scene(ctx, volux_scene_doc_scene(doc), again);
    volux_scene_destroy(again);
    volux_scene_doc_json_free(doc, text, n);
    /* Relative names resolve against the scene's folder only; absolute
     * ones from anywhere. */
    text = doc_text(doc, VOLUX_DOC_JSON_ABSOLUTE_PATHS, &n);
    assert_contains(text, "/doc_save/tf.json");
    assert_int_equal(volux_scene_load_string(ctx, text, "/", "saved", NULL, 0, &again), VOLUX_OK);
    assert_same_scene(ctx, volux_scene_doc_scene(doc), again);
    volux_scene_destroy(again);
    volux_scene_doc_json_free(doc, text, n);
    volux_scene_doc_destroy(doc);
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

/* ------------------------------------------------------------------ time steps */

static const char *SEQ_SCENE =
    "{\"volume\": {\"procedural\": \"cloud\", \"dims\": [12, 12, 12], \"steps\": 4},\n"
    " \"transfer_function\": {\"color\": [[0, 1, 1, 1], [255, 1, 0.5, 0.2]],\n"
    "                       \"opacity\": [[0, 0], [255, 0.5]]},\n"
    " \"lights\": [{\"type\": \"directional\", \"direction\": [-1, -1, -1]}],\n"
    " \"render\": {\"width\": 16, \"height\": 16}}\n";

/* 1 if the two volumes hold the same voxels. */
static int same_voxels(const volux_volume *a, const volux_volume *b) {
    int da[3], db[3];
    volux_volume_dims(a, da);
    volux_volume_dims(b, db);
    if (memcmp(da, db, sizeof da)) return 0;
    for (int k = 0; k < da[2]; k++)
        for (int j = 0; j < da[1]; j++)
            for (int i = 0; i < da[0]; i++)
                if (volux_volume_value_at(a, i, j, k) != volux_volume_value_at(b, i, j, k)) return 0;
    return 1;
}

/* The scene volux_scene_load makes of `path` with one --set. */
static volux_scene *loaded_with(volux_context *ctx, const char *path, const char *assignment) {
    volux_scene *s = NULL;
    if (volux_scene_load(ctx, path, &assignment, assignment ? 1 : 0, &s)) fail_msg("%s", volux_context_error(ctx));
    return s;
}

/* render.time_step edits a kept sequence in place (the sequence is not read
 * again; only VOLUME changes), a new volume section brings a new sequence to
 * the live scene at the edit's step, a step out of range is rejected with
 * the loader's message, and the document's JSON reproduces the step. */
static void test_time_step_edits(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    const char *path = scene_file("doc_steps", SEQ_SCENE);
    volux_scene_doc *doc = doc_ok(ctx, path, NULL);
    volux_scene *s = volux_scene_doc_scene(doc);
    volux_sequence *q = volux_scene_sequence(s);
    assert_non_null(q);
    assert_int_equal(volux_scene_time_steps(s), 4);
    assert_int_equal(volux_scene_time_step(s), 0);
    uint64_t loads = volux_sequence_loads(q);

    volux_scene_stamp seen = volux_scene_stamp_now(s);
    uint32_t changed = 0;
    edit_ok(doc, "render.time_step=2", &changed);
    assert_int_equal(changed, VOLUX_DOC_VOLUME);
    assert_int_equal(volux_scene_changes_since(s, &seen).what, VOLUX_CHANGE_VOLUME);
    assert_ptr_equal(volux_scene_sequence(s), q); /* kept, not read again */
    assert_int_equal(volux_scene_time_step(s), 2);
    assert_int_equal(volux_sequence_loads(q), loads + 1); /* step 2 only */
    volux_scene *ref = loaded_with(ctx, path, "render.time_step=2");
    assert_true(same_voxels(volux_scene_volume(s), volux_scene_volume(ref)));
    volux_scene *first = loaded_with(ctx, path, NULL);
    assert_false(same_voxels(volux_scene_volume(s), volux_scene_volume(first))); /* the cloud moved */

    /* Other edits keep the step and the sequence. */
    seen = volux_scene_stamp_now(s);
    edit_ok(doc, "lights.0.irradiance=3", &changed);
    assert_int_equal(changed, VOLUX_DOC_LIGHTS);
    assert_int_equal(volux_scene_changes_since(s, &seen).what, VOLUX_CHANGE_LIGHTS);
    assert_int_equal(volux_scene_time_step(s), 2);
    assert_ptr_equal(volux_scene_sequence(s), q);
    /* A TF edit at step 2 reads the TF as the loader does (against step 0)
     * and leaves the volume alone. */
    seen = volux_scene_stamp_now(s);
    edit_ok(doc, "transfer_function.opacity.1.1=0.7", &changed);
    assert_int_equal(changed, VOLUX_DOC_TRANSFER);
    assert_int_equal(volux_scene_changes_since(s, &seen).what, VOLUX_CHANGE_EXTINCTION);
    assert_int_equal(volux_scene_time_step(s), 2);
    assert_true(same_voxels(volux_scene_volume(s), volux_scene_volume(ref)));

    /* Out of range: the loader's message, nothing changes. */
    expect_rejected(ctx, doc, path, "render.time_step=4", "time step 4 is outside [0, 4)");
    expect_rejected(ctx, doc, path, "render.time_step=-1", "render.time_step");
    expect_rejected(ctx, doc, path, "render.time_step=\"two\"", "render.time_step");
    assert_int_equal(volux_scene_time_step(s), 2);

    /* The saved JSON loads to the same step. */
    size_t n;
    char *text = doc_text(doc, VOLUX_DOC_JSON_ABSOLUTE_PATHS, &n);
    assert_contains(text, "\"time_step\":2");
    volux_scene *again = NULL;
    assert_int_equal(volux_scene_load_string(ctx, text, "/", "saved", NULL, 0, &again), VOLUX_OK);
    assert_same_scene(ctx, s, again);
    assert_int_equal(volux_scene_time_step(again), 2);
    assert_true(same_voxels(volux_scene_volume(s), volux_scene_volume(again)));
    volux_scene_destroy(again);
    volux_scene_doc_json_free(doc, text, n);

    /* A new volume section: a new sequence moves to the live scene, at the
     * step of the edit. */
    const char *two[] = {"volume.time_per_step=0.1", "render.time_step=3"};
    assert_int_equal(volux_scene_doc_edit(doc, two, 2, &changed), VOLUX_OK);
    assert_true(changed & VOLUX_DOC_VOLUME);
    assert_non_null(volux_scene_sequence(s));
    assert_int_equal(volux_scene_time_steps(s), 4);
    assert_int_equal(volux_scene_time_step(s), 3);
    volux_scene_destroy(ref);
    assert_int_equal(volux_scene_load(ctx, path, two, 2, &ref), VOLUX_OK);
    assert_true(same_voxels(volux_scene_volume(s), volux_scene_volume(ref)));
    /* and further steps come from it */
    edit_ok(doc, "render.time_step=1", NULL);
    assert_int_equal(volux_scene_time_step(s), 1);
    /* A single volume has only step 0 (the document is at step 1 now). */
    expect_rejected(ctx, doc, NULL, "volume={\"procedural\": \"phantom\", \"dims\": [12, 12, 12]}",
                    "time step 1 is outside [0, 1)");
    const char *single[] = {"volume={\"procedural\": \"phantom\", \"dims\": [12, 12, 12]}", "render.time_step=0"};
    assert_int_equal(volux_scene_doc_edit(doc, single, 2, NULL), VOLUX_OK);
    assert_null(volux_scene_sequence(s));
    assert_int_equal(volux_scene_time_steps(s), 1);
    volux_scene_destroy(ref);
    volux_scene_destroy(first);
    volux_scene_doc_destroy(doc);
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

/* ------------------------------------------------------------------ data root */

static void write_text(const char *path, const char *text) {
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
}

/* A 4³ uint8 NRRD with detached data `data_name` (written beside it unless
 * it is a symlink made by the caller). */
static void write_nrrd(const char *dir, const char *name, const char *data_name, int write_data) {
    char p[1200];
    snprintf(p, sizeof p, "%s/%s", dir, name);
    char hdr[256];
    snprintf(hdr, sizeof hdr,
             "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 4 4 4\nencoding: raw\ndata file: %s\n", data_name);
    write_text(p, hdr);
    if (write_data) {
        unsigned char bytes[64];
        for (int i = 0; i < 64; i++) bytes[i] = (unsigned char)(i * 4);
        snprintf(p, sizeof p, "%s/%s", dir, data_name);
        FILE *f = fopen(p, "wb");
        fwrite(bytes, 1, sizeof bytes, f);
        fclose(f);
    }
}

static void test_data_root_contains_files(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    char root[512], outside[512], p[2048], q[2048];
    snprintf(root, sizeof root, "%s", tu_temp_path("doc_root"));
    snprintf(outside, sizeof outside, "%s", tu_temp_path("doc_outside"));
    mkdir(root, 0755);
    mkdir(outside, 0755);
    /* The scene names a volume outside the root: trusted (it was loaded). */
    write_nrrd(outside, "trusted.nhdr", "trusted.raw", 1);
    write_nrrd(outside, "other.nhdr", "other.raw", 1);
    write_nrrd(root, "inside.nhdr", "inside.raw", 1);
    /* inside the root: a header whose data file is a symlink leaving it */
    write_nrrd(root, "sneaky.nhdr", "sneaky.raw", 0);
    snprintf(p, sizeof p, "%s/other.raw", outside);
    snprintf(q, sizeof q, "%s/sneaky.raw", root);
    unlink(q);
    assert_int_equal(symlink(p, q), 0);
    /* and a header symlink leaving it */
    snprintf(p, sizeof p, "%s/other.nhdr", outside);
    snprintf(q, sizeof q, "%s/link.nhdr", root);
    unlink(q);
    assert_int_equal(symlink(p, q), 0);
    snprintf(p, sizeof p,
             "{\"volume\": {\"file\": \"../doc_outside/trusted.nhdr\"},"
             " \"transfer_function\": {\"opacity\": [[0, 0], [255, 1]]}}");
    const char *path = scene_file("doc_root", p);
    volux_scene_doc_options opt = {root, NULL, NULL};
    volux_scene_doc *doc = doc_ok(ctx, path, &opt);
    char real_root[4096];
    assert_non_null(realpath(root, real_root));
    assert_string_equal(volux_scene_doc_data_root(doc), real_root);

    edit_ok(doc, "volume.file=inside.nhdr", NULL);
    edit_ok(doc, "volume.file=../doc_outside/trusted.nhdr", NULL); /* named by the loaded scene */
    expect_rejected(ctx, doc, NULL, "volume.file=../doc_outside/other.nhdr", "not available in the data root");
    snprintf(p, sizeof p, "volume.file=%s/other.nhdr", outside);
    expect_rejected(ctx, doc, NULL, p, "not available in the data root");
    expect_rejected(ctx, doc, NULL, "volume.file=link.nhdr", "not available in the data root");
    expect_rejected(ctx, doc, NULL, "volume.file=sneaky.nhdr", "not available in the data root");
    expect_rejected(ctx, doc, NULL, "volume={\"file\":\"inside.nhdr\",\"allow_outside_dir\":true}",
                    "volume.allow_outside_dir");
    expect_rejected(ctx, doc, NULL, "volume.file=/etc/passwd", "not available in the data root");
    /* missing and outside read the same (no existence oracle) */
    expect_rejected(ctx, doc, NULL, "volume.file=missing.nhdr", "'missing.nhdr' is not available in the data root");
    expect_rejected(ctx, doc, NULL, "volume.file=/etc/shadow-missing", "not available in the data root");
    /* a time sequence is confined like one file (its detached data too) */
    expect_rejected(ctx, doc, NULL, "volume={\"files\":[\"sneaky.nhdr\"],\"allow_outside_dir\":true}",
                    "volume.allow_outside_dir");
    expect_rejected(ctx, doc, NULL, "volume={\"files\":[\"inside.nhdr\",\"sneaky.nhdr\"]}", "not available in the data root");
    /* a technique's file parameter too */
    expect_rejected(ctx, doc, NULL, "techniques.ambient.table_file=\"/etc/passwd\"", "not available in the data root");
    expect_rejected(ctx, doc, NULL, "techniques.ambient.table_file=\"../doc_outside/other.raw\"",
                    "not available in the data root");
    expect_rejected(ctx, doc, NULL, "lights.0={\"type\":\"environment\",\"file\":\"/etc/hostname\"}",
                    "not available in the data root");
    expect_rejected(ctx, doc, NULL, "transfer_function=\"../doc_outside/other.nhdr\"", "not available in the data root");
    expect_rejected(ctx, doc, NULL, "transfer_function.preset=\"/etc/passwd\"", "not available in the data root");
    volux_scene_doc_destroy(doc);
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

/* ------------------------------------------------------------------ tone mapping */

/* The threshold search gives exactly the defined 8-bit code, for a dense
 * sweep of floats, the thresholds' neighbours and special values; and the
 * encoded PNG decodes to the code's value. */
static void test_srgb8_is_exact(void **state) {
    (void)state;
    volux_srgb8_init();
    for (uint32_t bits = 0; bits < 0x40400000u; bits += 4099) { /* 0 … 3.0 */
        float v;
        memcpy(&v, &bits, sizeof v);
        if (volux_srgb8(v) != volux_srgb8_reference(v)) fail_msg("code of %.9g differs", v);
    }
    for (int k = 0; k < 256; k++) {
        float v = (k + 0.5f) / 255.0f;
        v = volux_srgb_decode(v);
        for (int d = -3; d <= 3; d++) {
            float w = nextafterf(v, d < 0 ? 0.0f : 10.0f);
            for (int j = 1; j < (d < 0 ? -d : d); j++) w = nextafterf(w, d < 0 ? 0.0f : 10.0f);
            assert_int_equal(volux_srgb8(w), volux_srgb8_reference(w));
        }
    }
    float special[] = {NAN, -NAN, INFINITY, -INFINITY, -0.0f, 0.0f, 1e-45f, 1.0f, 1e30f, -1.0f};
    for (size_t i = 0; i < sizeof special / sizeof special[0]; i++)
        assert_int_equal(volux_srgb8(special[i]), volux_srgb8_reference(special[i]));

    volux_context *ctx = tu_context(1);
    volux_image img;
    assert_int_equal(volux_image_create(ctx, 7, 3, &img), VOLUX_OK);
    for (int i = 0; i < 7 * 3 * 3; i++) img.rgb[i] = (float)i / 40.0f;
    unsigned char px[7 * 3 * 3], *png = NULL;
    size_t n = 0;
    volux_image_to_srgb8(&img, 0.5f, px);
    assert_int_equal(volux_image_encode(ctx, &img, "png", 0.5f, &png, &n), VOLUX_OK);
    volux_image back;
    assert_int_equal(volux_png_read_memory(ctx, "mem", png, n, &back), VOLUX_OK);
    for (int i = 0; i < 7 * 3 * 3; i++) {
        assert_int_equal(px[i], volux_srgb8_reference(img.rgb[i] * exp2f(0.5f)));
        assert_near(back.rgb[i], volux_srgb_decode(px[i] / 255.0f), 1e-6);
    }
    volux_encoded_free(ctx, png, n);
    volux_image_free(ctx, &back);
    assert_int_equal(volux_image_encode(ctx, &img, "pfm", 0, &png, &n), VOLUX_OK);
    assert_int_equal(volux_pfm_read_memory(ctx, "mem", png, n, &back), VOLUX_OK);
    assert_memory_equal(back.rgb, img.rgb, sizeof(float) * 7 * 3 * 3);
    volux_encoded_free(ctx, png, n);
    volux_image_free(ctx, &back);
    assert_int_equal(volux_image_encode(ctx, &img, "gif", 0, &png, &n), VOLUX_ERR_INVALID);
    volux_image_free(ctx, &img);
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_edits_bump_only_what_changed),
        cmocka_unit_test(test_lights_and_params_come_and_go),
        cmocka_unit_test(test_bad_edits_change_nothing),
        cmocka_unit_test(test_validate_hook),
        cmocka_unit_test(test_edit_json),
        cmocka_unit_test(test_json_reproduces_the_scene),
        cmocka_unit_test(test_time_step_edits),
        cmocka_unit_test(test_data_root_contains_files),
        cmocka_unit_test(test_srgb8_is_exact),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
