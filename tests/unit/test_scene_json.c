/*
 * tests/unit/test_scene_json.c — the scene file of DESIGN §3 read back
 * through the scene API: every field, relative paths, --set overrides, TF
 * files and ParaView presets.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

#include "io/scene_formats.h"
#include "test_util.h"

#define assert_contains(hay, needle)                                                                   \
    do {                                                                                               \
        const char *h_ = (hay), *n_ = (needle);                                                        \
        if (!strstr(h_, n_)) fail_msg("expected \"%s\" in \"%s\"", n_, h_);                           \
    } while (0)

static const double PI = 3.14159265358979323846;

/* Loads `json` (base dir = the temp folder), failing the test on error. */
static volux_scene *load_ok(volux_context *ctx, const char *json, const char *const *ov, int n_ov) {
    volux_scene *s = NULL;
    volux_status st = volux_scene_load_string(ctx, json, tu_temp_path(""), "t.json", ov, n_ov, &s);
    if (st) fail_msg("load failed (%s): %s", volux_status_name(st), volux_context_error(ctx));
    return s;
}

/* Expects `json` + overrides to fail with `want` and a message containing
 * `part`; checks nothing allocated through the context is left behind. */
static void load_fails(volux_context *ctx, const char *json, const char *const *ov, int n_ov, volux_status want,
                       const char *part) {
    uint64_t before = volux_context_bytes_in_use(ctx);
    volux_scene *s = NULL;
    volux_context_clear_error(ctx);
    volux_status st = volux_scene_load_string(ctx, json, tu_temp_path(""), "t.json", ov, n_ov, &s);
    if (st == VOLUX_OK) {
        volux_scene_destroy(s);
        fail_msg("expected failure '%s', but it loaded", part);
    }
    if (st != want)
        fail_msg("status %s, expected %s (%s)", volux_status_name(st), volux_status_name(want),
                 volux_context_error(ctx));
    assert_null(s);
    assert_contains(volux_context_error(ctx), part);
    assert_contains(volux_context_error(ctx), "t.json");
    assert_int_equal(volux_context_bytes_in_use(ctx), before);
}

/* ------------------------------------------------------------------ every field */

static const char *FULL =
    "{\n"
    " \"comment\": \"every field\",\n"
    " \"volume\": {\"procedural\": \"sphere\", \"dims\": [8, 9, 10], \"seed\": 3, \"comment\": \"c\"},\n"
    " \"transfer_function\": {\n"
    "   \"color\": [[0, 0.1, 0.2, 0.3], [100, 0.4, 0.5, 0.6], [255, 1, 1, 1]],\n"
    "   \"opacity\": [[0, 0], [50, 0.25], [255, 0.75]],\n"
    "   \"opacity_unit_distance\": 2.5, \"density_scale\": 3, \"albedo\": 0.6, \"anisotropy\": -0.3,\n"
    "   \"ambient\": 0.1, \"diffuse\": 0.8, \"specular\": 0.4, \"specular_power\": 12},\n"
    " \"camera\": {\"type\": \"perspective\", \"eye\": [1, 2, 30], \"look_at\": [0, 1, 0], \"up\": [0, 0, 1],"
    "   \"fov_y\": 40},\n"
    " \"lights\": [\n"
    "   {\"type\": \"directional\", \"direction\": [0, -1, 0], \"color\": [1, 0.5, 0.25], \"irradiance\": 3},\n"
    "   {\"type\": \"point\", \"position\": [5, 6, 7], \"intensity\": 80, \"enabled\": false},\n"
    "   {\"type\": \"spot\", \"position\": [0, 10, 0], \"direction\": [0, -1, 0], \"intensity\": 9,\n"
    "    \"cone_angle\": 40, \"falloff_angle\": 20},\n"
    "   {\"type\": \"sphere\", \"position\": [1, 1, 1], \"radius\": 0.5, \"radiance\": 4},\n"
    "   {\"type\": \"environment\", \"color\": [0.2, 0.3, 0.4], \"radiance\": 2, \"rotation_y\": 90,\n"
    "    \"intensity\": 1.5, \"visible\": false}],\n"
    " \"background\": [0.1, 0.2, 0.3],\n"
    " \"render\": {\"technique\": \"shaded\", \"width\": 33, \"height\": 17, \"spp\": 5, \"step\": 0.25,\n"
    "   \"seed\": 9007199254740992, \"max_depth\": 3, \"exposure\": -1.5, \"threads\": 2, \"time_ms\": 250,\n"
    "   \"target_error\": 0.01, \"comment\": \"r\"},\n"
    " \"techniques\": {\"ea\": {\"early_termination\": 0.01, \"preintegrate\": false},\n"
    "                \"shaded\": {\"mode\": \"fancy\"}}\n"
    "}\n";

static void test_full_scene_reads_every_field(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_scene *s = load_ok(ctx, FULL, NULL, 0);

    int dims[3];
    volux_volume_dims(volux_scene_volume(s), dims);
    assert_int_equal(dims[0], 8);
    assert_int_equal(dims[1], 9);
    assert_int_equal(dims[2], 10);

    const volux_transfer_desc *tf = volux_scene_transfer(s);
    assert_int_equal(tf->n_color, 3);
    assert_near(tf->color[1].s, 100, 0);
    assert_near(tf->color[1].g, 0.5, 1e-6);
    assert_int_equal(tf->n_opacity, 3);
    assert_near(tf->opacity[1].s, 50, 0);
    assert_near(tf->opacity[1].v, 0.25, 0);
    assert_int_equal(tf->extinction, 0);
    assert_near(tf->opacity_unit_distance, 2.5, 0);
    assert_near(tf->density_scale, 3, 0);
    assert_near(tf->albedo, 0.6, 1e-6);
    assert_near(tf->anisotropy, -0.3, 1e-6);
    assert_near(tf->material.ambient, 0.1, 1e-6);
    assert_near(tf->material.diffuse, 0.8, 1e-6);
    assert_near(tf->material.specular, 0.4, 1e-6);
    assert_near(tf->material.specular_power, 12, 0);

    const volux_camera_desc *cam = volux_scene_camera_desc(s);
    assert_int_equal(cam->projection, VOLUX_PERSPECTIVE);
    assert_int_equal(cam->use_orbit, 0);
    assert_near(cam->eye.z, 30, 0);
    assert_near(cam->look_at.y, 1, 0);
    assert_near(cam->up.z, 1, 0);
    assert_near(cam->fov_y_deg, 40, 0);

    assert_int_equal(volux_scene_light_slots(s), 5);
    const volux_light_desc *l = volux_scene_light(s, 0);
    assert_int_equal(l->type, VOLUX_LIGHT_DIRECTIONAL);
    assert_near(l->direction.y, -1, 0);
    assert_near(l->color.y, 0.5, 0);
    assert_near(l->irradiance, 3, 0);
    assert_int_equal(l->enabled, 1);
    l = volux_scene_light(s, 1);
    assert_int_equal(l->type, VOLUX_LIGHT_POINT);
    assert_near(l->position.x, 5, 0);
    assert_near(l->intensity, 80, 0);
    assert_int_equal(l->enabled, 0);
    l = volux_scene_light(s, 2);
    assert_int_equal(l->type, VOLUX_LIGHT_SPOT);
    assert_near(l->cone_angle_deg, 40, 0);
    assert_near(l->falloff_angle_deg, 20, 0);
    assert_near(l->intensity, 9, 0);
    l = volux_scene_light(s, 3);
    assert_int_equal(l->type, VOLUX_LIGHT_SPHERE);
    assert_near(l->radius, 0.5, 0);
    assert_near(l->radiance, 4, 0);
    l = volux_scene_light(s, 4);
    assert_int_equal(l->type, VOLUX_LIGHT_ENVIRONMENT);
    assert_near(l->radiance, 2, 0);
    assert_near(l->rotation_y_deg, 90, 0);
    assert_near(l->intensity, 1.5, 0);
    assert_int_equal(l->visible, 0);
    assert_null(l->map);

    volux_vec3 bg = volux_scene_background(s);
    assert_near(bg.z, 0.3, 1e-6);

    const volux_render_settings *rs = volux_scene_render(s);
    assert_string_equal(rs->technique, "shaded");
    assert_int_equal(rs->width, 33);
    assert_int_equal(rs->height, 17);
    assert_int_equal(rs->spp, 5);
    assert_near(rs->step, 0.25, 0);
    assert_true(rs->seed == 9007199254740992ull);
    assert_int_equal(rs->max_depth, 3);
    assert_near(rs->exposure, -1.5, 0);
    assert_int_equal(rs->threads, 2);
    assert_near(rs->time_ms, 250, 0);
    assert_near(rs->target_error, 0.01, 0);

    assert_near(volux_scene_param(s, "ea", "early_termination", -1), 0.01, 0);
    assert_near(volux_scene_param(s, "ea", "preintegrate", -1), 0, 0);
    assert_string_equal(volux_scene_param_string(s, "shaded", "mode", ""), "fancy");
    assert_near(volux_scene_param(s, "ea", "skip_empty", -1), -1, 0);

    volux_scene_destroy(s);
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

static void test_defaults_when_optional_sections_are_absent(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_scene *s = load_ok(ctx,
                             "{\"volume\": {\"procedural\": \"constant\", \"dims\": [4, 4, 4]},"
                             " \"transfer_function\": {\"extinction\": [[0, 2]]}}",
                             NULL, 0);
    const volux_transfer_desc *tf = volux_scene_transfer(s);
    assert_int_equal(tf->extinction, 1);
    assert_int_equal(tf->n_color, 0);
    assert_near(tf->albedo, 0.9, 1e-6);
    const volux_render_settings *rs = volux_scene_render(s);
    assert_string_equal(rs->technique, "ea");
    assert_int_equal(rs->width, 512);
    assert_int_equal(volux_scene_light_slots(s), 0);
    const volux_camera_desc *cam = volux_scene_camera_desc(s);
    assert_int_equal(cam->use_orbit, 1);
    assert_near(cam->distance, 1.0 / sin(15.0 * PI / 180.0), 1e-5);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

static void test_spot_default_falloff_stays_inside_a_narrow_cone(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_scene *s = load_ok(ctx,
                             "{\"volume\": {\"procedural\": \"sphere\", \"dims\": [4, 4, 4]},"
                             " \"transfer_function\": {\"opacity\": [[0, 0.5]]},"
                             " \"lights\": [{\"type\": \"spot\", \"cone_angle\": 10}]}",
                             NULL, 0);
    assert_near(volux_scene_light(s, 0)->falloff_angle_deg, 8, 1e-5);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

/* ------------------------------------------------------------------ camera */

static void test_orbit_camera_distance_follows_fov(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    const char *base = "{\"volume\": {\"procedural\": \"sphere\", \"dims\": [16, 16, 16]},"
                       " \"transfer_function\": {\"opacity\": [[0, 0.5]]}, \"camera\": %s}";
    char json[512];
    /* An orbit without distance fits the bounding sphere: 1/sin(fov/2). */
    snprintf(json, sizeof json, base, "{\"orbit\": {\"azimuth\": 90, \"elevation\": 0}, \"fov_y\": 60}");
    volux_scene *s = load_ok(ctx, json, NULL, 0);
    const volux_camera_desc *d = volux_scene_camera_desc(s);
    assert_int_equal(d->use_orbit, 1);
    assert_near(d->distance, 2.0, 1e-5);
    assert_near(d->azimuth_deg, 90, 0);
    /* DESIGN §3: eye = C + distance·R·(cos el·sin az, sin el, cos el·cos az). */
    volux_camera cam;
    assert_int_equal(volux_scene_camera(s, &cam), VOLUX_OK);
    volux_vec3 c;
    float r;
    volux_scene_bounds_sphere(s, &c, &r);
    assert_near(cam.eye.x, c.x + 2.0 * r, 1e-3);
    assert_near(cam.eye.y, c.y, 1e-3);
    assert_near(cam.forward.x, -1, 1e-5);
    volux_scene_destroy(s);

    /* Same without an orbit object: the default orbit, fitted to fov_y. */
    snprintf(json, sizeof json, base, "{\"fov_y\": 60}");
    s = load_ok(ctx, json, NULL, 0);
    assert_near(volux_scene_camera_desc(s)->distance, 2.0, 1e-5);
    volux_scene_destroy(s);

    snprintf(json, sizeof json, base, "{\"orbit\": {\"distance\": 5}}");
    s = load_ok(ctx, json, NULL, 0);
    assert_near(volux_scene_camera_desc(s)->distance, 5, 0);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

static void test_orthographic_height_given_or_from_orbit_framing(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    const char *base = "{\"volume\": {\"procedural\": \"sphere\", \"dims\": [16, 16, 16]},"
                       " \"transfer_function\": {\"opacity\": [[0, 0.5]]}, \"camera\": %s,"
                       " \"render\": {\"width\": 8, \"height\": 8}}";
    char json[512];
    snprintf(json, sizeof json, base, "{\"type\": \"orthographic\", \"height\": 3.5}");
    volux_scene *s = load_ok(ctx, json, NULL, 0);
    assert_int_equal(volux_scene_camera_desc(s)->projection, VOLUX_ORTHOGRAPHIC);
    assert_near(volux_scene_camera_desc(s)->height, 3.5, 0);
    volux_camera cam;
    assert_int_equal(volux_scene_camera(s, &cam), VOLUX_OK);
    assert_near(cam.half_height, 1.75, 1e-6);
    volux_scene_destroy(s);

    /* Without a height: 2·distance·R·tan(fov_y/2), the perspective framing. */
    snprintf(json, sizeof json, base, "{\"type\": \"orthographic\", \"orbit\": {\"azimuth\": 0}, \"fov_y\": 40}");
    s = load_ok(ctx, json, NULL, 0);
    assert_near(volux_scene_camera_desc(s)->height, 0, 0);
    assert_int_equal(volux_scene_camera(s, &cam), VOLUX_OK);
    volux_vec3 c;
    float r;
    volux_scene_bounds_sphere(s, &c, &r);
    double dist = 1.0 / sin(20.0 * PI / 180.0);
    assert_near(cam.half_height, dist * r * tan(20.0 * PI / 180.0), 1e-3);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

/* ------------------------------------------------------------------ files */

static void write_text(const char *path, const char *text) {
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(text, 1, strlen(text), f), strlen(text));
    fclose(f);
}

/* A folder "<tmp>/<name>" with a raw volume, a TF file referencing a
 * preset in its own sub-folder, and an environment map. */
static void make_scene_folder(volux_context *ctx, const char *name) {
    char dir[512], p[600];
    snprintf(dir, sizeof dir, "%s", tu_temp_path(name));
    mkdir(dir, 0700);
    snprintf(p, sizeof p, "%s/tfs", dir);
    mkdir(p, 0700);
    unsigned char vox[4 * 3 * 2];
    for (int i = 0; i < 24; i++) vox[i] = (unsigned char)(10 * i);
    snprintf(p, sizeof p, "%s/vol.raw", dir);
    FILE *f = fopen(p, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(vox, 1, sizeof vox, f), sizeof vox);
    fclose(f);
    snprintf(p, sizeof p, "%s/tfs/tf.json", dir);
    write_text(p, "{\"comment\": \"peers style\", \"opacity_unit_distance\": 1.0,\n"
                  " \"opacity\": [[0, 0.0], [230, 0.5]], \"preset\": \"cool.json\",\n"
                  " \"ambient\": 0.2, \"diffuse\": 0.7, \"specular\": 0.3, \"specular_power\": 30}\n");
    snprintf(p, sizeof p, "%s/tfs/cool.json", dir);
    write_text(p, "[{\"Name\": \"Cool\", \"ColorSpace\": \"Diverging\",\n"
                  "  \"RGBPoints\": [0, 0, 0, 1, 1, 1, 0, 0]}]\n");
    volux_image env;
    assert_int_equal(volux_image_create(ctx, 4, 2, &env), VOLUX_OK);
    for (int i = 0; i < 4 * 2 * 3; i++) env.rgb[i] = 0.5f;
    snprintf(p, sizeof p, "%s/env.pfm", dir);
    assert_int_equal(volux_image_save(ctx, p, &env, 0), VOLUX_OK);
    volux_image_free(ctx, &env);
}

static void test_relative_paths_resolve_against_the_scene_folder(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    make_scene_folder(ctx, "rel");
    char scene_path[600];
    snprintf(scene_path, sizeof scene_path, "%s/scene.json", tu_temp_path("rel"));
    write_text(scene_path,
               "{\"volume\": {\"file\": \"vol.raw\", \"dims\": [4, 3, 2], \"type\": \"uint8\",\n"
               "             \"spacing\": [1, 2, 3], \"endian\": \"little\"},\n"
               " \"transfer_function\": \"tfs/tf.json\",\n"
               " \"lights\": [{\"type\": \"environment\", \"file\": \"env.pfm\", \"intensity\": 2}]}\n");
    /* The process's working directory is not the scene's folder. */
    volux_scene *s = NULL;
    volux_status st = volux_scene_load(ctx, scene_path, NULL, 0, &s);
    if (st) fail_msg("%s", volux_context_error(ctx));
    int dims[3];
    double sp[3], lo, hi;
    volux_volume_dims(volux_scene_volume(s), dims);
    volux_volume_spacing(volux_scene_volume(s), sp);
    volux_volume_range(volux_scene_volume(s), &lo, &hi);
    assert_int_equal(dims[0] * dims[1] * dims[2], 24);
    assert_near(sp[2], 3, 0);
    assert_near(lo, 0, 0);
    assert_near(hi, 230, 0);
    /* TF from the file; its preset resolved against the TF file's folder
     * (tfs/) and rescaled to the volume's range [0, 230]. */
    const volux_transfer_desc *tf = volux_scene_transfer(s);
    assert_int_equal(tf->n_opacity, 2);
    assert_near(tf->opacity[1].v, 0.5, 0);
    assert_near(tf->material.specular_power, 30, 0);
    assert_int_equal(tf->n_color, 2);
    assert_near(tf->color[0].s, 0, 0);
    assert_near(tf->color[0].b, 1, 0);
    assert_near(tf->color[1].s, 230, 1e-4);
    assert_near(tf->color[1].r, 1, 0);
    const volux_light_desc *env = volux_scene_light(s, 0);
    assert_non_null(env->map);
    assert_int_equal(env->map->width, 4);
    assert_near(env->map->rgb[0], 0.5, 0);
    assert_near(env->intensity, 2, 0);
    volux_scene_destroy(s);

    /* The same scene as a string with base_dir = that folder. */
    s = NULL;
    st = volux_scene_load_string(ctx,
                                 "{\"volume\": {\"file\": \"vol.raw\", \"dims\": [4, 3, 2], \"type\": \"uint8\"},"
                                 " \"transfer_function\": \"tfs/tf.json\"}",
                                 tu_temp_path("rel"), "mem.json", NULL, 0, &s);
    if (st) fail_msg("%s", volux_context_error(ctx));
    assert_int_equal(volux_scene_transfer(s)->n_color, 2);
    volux_scene_destroy(s);
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

static void test_raw_layout_keys_and_nrrd_origin(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    /* Raw: 8 bytes to skip, then big-endian uint16 values. */
    const unsigned char raw[] = {9, 9, 9, 9, 9, 9, 9, 9, 0, 1, 1, 0, 2, 1, 255, 255};
    tu_write_file("be16.raw", raw, sizeof raw);
    volux_scene *s = load_ok(ctx,
                             "{\"volume\": {\"file\": \"be16.raw\", \"dims\": [2, 2, 1], \"type\": \"uint16\","
                             "  \"endian\": \"big\", \"byte_skip\": 8},"
                             " \"transfer_function\": {\"opacity\": [[0, 1]]}}",
                             NULL, 0);
    const volux_volume *v = volux_scene_volume(s);
    assert_near(volux_volume_value_at(v, 0, 0, 0), 1, 0);
    assert_near(volux_volume_value_at(v, 1, 0, 0), 256, 0);
    assert_near(volux_volume_value_at(v, 0, 1, 0), 513, 0);
    assert_near(volux_volume_value_at(v, 1, 1, 0), 65535, 0);
    volux_scene_destroy(s);

    /* A detached NRRD in vols/ whose data lies one folder up: refused
     * unless allow_outside_dir; its origin used only with use_file_origin. */
    char dir[512], p[600];
    snprintf(dir, sizeof dir, "%s", tu_temp_path("vols"));
    mkdir(dir, 0700);
    snprintf(p, sizeof p, "%s/h.nhdr", dir);
    write_text(p, "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nspace: right-anterior-superior\n"
                  "space directions: (1,0,0) (0,1,0) (0,0,1)\nspace origin: (10,20,30)\nencoding: raw\n"
                  "data file: ../up.raw\n\n");
    const unsigned char vox[8] = {0, 1, 2, 3, 4, 5, 6, 7};
    tu_write_file("up.raw", vox, sizeof vox);
    const char *base = "{\"volume\": {\"file\": \"vols/h.nhdr\" %s},"
                       " \"transfer_function\": {\"opacity\": [[0, 1]]}}";
    char json[512];
    snprintf(json, sizeof json, base, "");
    load_fails(ctx, json, NULL, 0, VOLUX_ERR_FORMAT, "volume.file: ");
    assert_contains(volux_context_error(ctx), "outside the header's folder");
    assert_contains(volux_context_error(ctx), "\"allow_outside_dir\": true"); /* the message names the way out */
    snprintf(json, sizeof json, base, ", \"allow_outside_dir\": true");
    s = load_ok(ctx, json, NULL, 0);
    volux_vec3 o = volux_volume_origin(volux_scene_volume(s));
    assert_near(o.x, -0.5, 0); /* centred: −(dims−1)·spacing/2 */
    volux_scene_destroy(s);
    snprintf(json, sizeof json, base, ", \"allow_outside_dir\": true, \"use_file_origin\": true");
    s = load_ok(ctx, json, NULL, 0);
    o = volux_volume_origin(volux_scene_volume(s));
    assert_near(o.x, 10, 0);
    assert_near(o.z, 30, 0);
    assert_near(volux_volume_value_at(volux_scene_volume(s), 1, 1, 1), 7, 0);
    volux_scene_destroy(s);
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

static void test_tf_file_errors_name_scene_and_tf_file(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    const char *bad = tu_write_file("bad_tf.json", "{\"opacity\": [[0, 0], [1, 2]]}", 29);
    (void)bad;
    const char *scene = "{\"volume\": {\"procedural\": \"sphere\", \"dims\": [4, 4, 4]},"
                        " \"transfer_function\": \"bad_tf.json\"}";
    load_fails(ctx, scene, NULL, 0, VOLUX_ERR_INVALID, "transfer_function.opacity[1]");
    assert_contains(volux_context_error(ctx), "bad_tf.json");
    tu_write_file("bad_tf2.json", "{\"opacity\": [[0, 0]], \"colour\": []}", 35);
    const char *ov[] = {"transfer_function=bad_tf2.json"}; /* a bare file name via --set */
    load_fails(ctx, scene, ov, 1, VOLUX_ERR_INVALID, "transfer_function.colour: unknown key");
    const char *ov2[] = {"transfer_function=\"no_such_tf.json\""};
    load_fails(ctx, scene, ov2, 1, VOLUX_ERR_IO, "no_such_tf.json");
    volux_context_destroy(ctx);
}

/* ------------------------------------------------------------------ presets */

static const char *PRESETS = "[\n"
                             " {\"Name\": \"Gray\", \"RGBPoints\": [0, 0, 0, 0, 1, 1, 1, 1]},\n"
                             " \"not a preset\",\n"
                             " {\"Name\": \"Ramp\", \"ColorSpace\": \"RGB\", \"NanColor\": [1, 0, 0],\n"
                             "  \"RGBPoints\": [-1, 1, 0, 0,  0, 0, 1, 0,  1, 0, 0, 1],\n"
                             "  \"Points\": [-1, 0, 0.5, 0,  0, 0.2, 0.5, 0,  1, 0.8, 0.5, 0]}\n"
                             "]\n";

static void test_paraview_preset_named_rescaled_with_opacity_points(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    tu_write_file("presets.json", PRESETS, strlen(PRESETS));
    const char *base = "{\"volume\": {\"procedural\": \"sphere\", \"dims\": [16, 16, 16]},"
                       " \"transfer_function\": {\"preset\": \"presets.json\" %s}}";
    char json[512];
    snprintf(json, sizeof json, base, ", \"preset_name\": \"Ramp\"");
    volux_scene *s = load_ok(ctx, json, NULL, 0);
    double lo, hi;
    volux_volume_range(volux_scene_volume(s), &lo, &hi);
    assert_true(hi > lo);
    const volux_transfer_desc *tf = volux_scene_transfer(s);
    assert_int_equal(tf->n_color, 3);
    /* [-1, 1] maps onto the volume's range, as ParaView applies presets. */
    assert_near(tf->color[0].s, lo, 1e-3);
    assert_near(tf->color[1].s, 0.5 * (lo + hi), 1e-3);
    assert_near(tf->color[2].s, hi, 1e-3);
    assert_near(tf->color[1].g, 1, 0);
    /* No scene opacity: the preset's "Points" (x, alpha, midpoint, sharpness). */
    assert_int_equal(tf->extinction, 0);
    assert_int_equal(tf->n_opacity, 3);
    assert_near(tf->opacity[1].s, 0.5 * (lo + hi), 1e-3);
    assert_near(tf->opacity[1].v, 0.2, 1e-6);
    assert_near(tf->opacity[2].v, 0.8, 1e-6);
    volux_scene_destroy(s);

    /* preset_rescale false keeps the preset's own x. */
    snprintf(json, sizeof json, base, ", \"preset_name\": \"Ramp\", \"preset_rescale\": false");
    s = load_ok(ctx, json, NULL, 0);
    assert_near(volux_scene_transfer(s)->color[0].s, -1, 0);
    assert_near(volux_scene_transfer(s)->opacity[2].s, 1, 0);
    volux_scene_destroy(s);

    /* No name: the first preset; it has no Points, so opacity is required. */
    snprintf(json, sizeof json, base, "");
    load_fails(ctx, json, NULL, 0, VOLUX_ERR_INVALID, "needs opacity or extinction");
    snprintf(json, sizeof json, base, ", \"opacity\": [[0, 0], [255, 1]]");
    s = load_ok(ctx, json, NULL, 0);
    assert_int_equal(volux_scene_transfer(s)->n_color, 2);
    assert_near(volux_scene_transfer(s)->color[1].s, hi, 1e-3);
    assert_int_equal(volux_scene_transfer(s)->n_opacity, 2);
    volux_scene_destroy(s);

    /* Scene opacity wins over the preset's Points. */
    snprintf(json, sizeof json, base, ", \"preset_name\": \"Ramp\", \"opacity\": [[0, 0.125]]");
    s = load_ok(ctx, json, NULL, 0);
    assert_int_equal(volux_scene_transfer(s)->n_opacity, 1);
    assert_near(volux_scene_transfer(s)->opacity[0].v, 0.125, 0);
    volux_scene_destroy(s);

    snprintf(json, sizeof json, base, ", \"preset_name\": \"Nope\"");
    load_fails(ctx, json, NULL, 0, VOLUX_ERR_INVALID, "no preset named 'Nope'");
    assert_contains(volux_context_error(ctx), "transfer_function.preset");
    snprintf(json, sizeof json, base, ", \"color\": [[0, 1, 1, 1]], \"opacity\": [[0, 1]]");
    load_fails(ctx, json, NULL, 0, VOLUX_ERR_INVALID, "color points or a preset, not both");
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

/* ParaView's midpoint: where a segment reaches the mean of its ends (an
 * extra point); a sharpness > 0 is not modelled and the loader says so. */
static void test_preset_midpoint_and_sharpness(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    const char *text = "{\"Name\": \"M\", \"RGBPoints\": [0, 1, 1, 1, 100, 1, 1, 1],"
                       " \"Points\": [0, 0, 0.25, 0,  100, 0.8, 0.5, 0]}";
    volux_tf_preset p = {0};
    assert_int_equal(volux_tf_preset_parse(ctx, text, strlen(text), "m.json", NULL, 0, 0, &p), VOLUX_OK);
    assert_int_equal(p.n_opacity, 3);
    assert_near(p.opacity[1].s, 25, 0);
    assert_near(p.opacity[1].v, 0.4, 1e-6);
    assert_int_equal(p.n_sharp, 0);
    volux_tf_preset_free(ctx, &p);

    const char *sharp = "{\"Name\": \"S\", \"RGBPoints\": [0, 1, 1, 1, 1, 1, 1, 1],"
                        " \"Points\": [0, 0, 0.5, 0.7,  1, 0.8, 0.5, 0]}";
    tu_write_file("sharp.json", sharp, strlen(sharp));
    const char *json = "{\"volume\": {\"procedural\": \"sphere\", \"dims\": [8, 8, 8]},"
                       " \"transfer_function\": {\"preset\": \"sharp.json\"}}";
    volux_scene *s = load_ok(ctx, json, NULL, 0);
    assert_int_equal(volux_scene_transfer(s)->n_opacity, 2); /* midpoint 0.5: no extra point */
    assert_contains(volux_scene_notes(s), "1 opacity segment of 'sharp.json' has a sharpness > 0");
    volux_scene_destroy(s);
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

static void test_preset_parse_from_memory(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_tf_preset p = {0};
    const char *one = "{\"Name\": \"Solo\", \"RGBPoints\": [10, 1, 0, 0, 20, 0, 1, 0]}";
    /* s_min >= s_max: points kept as they are. */
    assert_int_equal(volux_tf_preset_parse(ctx, one, strlen(one), "solo.json", NULL, 0, 0, &p), VOLUX_OK);
    assert_int_equal(p.n_color, 2);
    assert_near(p.color[1].s, 20, 0);
    assert_null(p.opacity);
    volux_tf_preset_free(ctx, &p);
    assert_int_equal(volux_tf_preset_parse(ctx, one, strlen(one), "solo.json", "Solo", 0, 1, &p), VOLUX_OK);
    assert_near(p.color[0].s, 0, 0);
    assert_near(p.color[1].s, 1, 0);
    volux_tf_preset_free(ctx, &p);
    /* A single object must carry the requested name. */
    assert_int_equal(volux_tf_preset_parse(ctx, one, strlen(one), "solo.json", "Other", 0, 1, &p),
                     VOLUX_ERR_INVALID);
    assert_contains(volux_context_error(ctx), "solo.json: no preset named 'Other'");
    /* The buffer need not be NUL-terminated: parse a prefix of a longer text. */
    char buf[128];
    snprintf(buf, sizeof buf, "%sGARBAGE", one);
    assert_int_equal(volux_tf_preset_parse(ctx, buf, strlen(one), "prefix", NULL, 0, 0, &p), VOLUX_OK);
    volux_tf_preset_free(ctx, &p);
    volux_context_clear_error(ctx);
    assert_int_equal(volux_tf_preset_parse(ctx, buf, strlen(buf), "prefix", NULL, 0, 0, &p), VOLUX_ERR_FORMAT);
    assert_contains(volux_context_error(ctx), "unexpected text after the JSON value");
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

/* ------------------------------------------------------------------ --set */

static const char *SMALL = "{\"volume\": {\"procedural\": \"sphere\", \"dims\": [8, 8, 8]},"
                           " \"transfer_function\": {\"opacity\": [[0, 0], [255, 0.5]]},"
                           " \"lights\": [{\"type\": \"directional\", \"direction\": [0, 0, -1]},"
                           "              {\"type\": \"point\", \"position\": [0, 0, 20]}],"
                           " \"render\": {\"technique\": \"ea\", \"width\": 16, \"height\": 16}}";

static void test_overrides_set_numbers_strings_and_bare_words(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    const char *ov[] = {
        "render.width=64",
        "render.height=48.0",              /* an integral number is an integer */
        "render.technique=shaded",         /* bare word */
        "render.spp=3",
        "render.spp=4",                    /* later overrides win */
        "lights.0.irradiance=2.5",         /* array index */
        "lights.1.color=[0.5, 0.25, 1]",   /* JSON array */
        "lights.1.color.2=0.75",           /* index into a value's array */
        "volume.dims.1=5",
        "transfer_function.albedo=0.5",
        "techniques.ea.early_termination=0.05", /* creates both objects */
        "techniques.x.label=hello world",  /* bare words with a space */
        "techniques.x.quoted=\"7\"",       /* a JSON string, not a number */
        "camera.orbit.azimuth=45",         /* creates camera and orbit */
        "background=[0.5, 0.5, 0.5]",
    };
    volux_scene *s = load_ok(ctx, SMALL, ov, (int)(sizeof ov / sizeof ov[0]));
    const volux_render_settings *rs = volux_scene_render(s);
    assert_int_equal(rs->width, 64);
    assert_int_equal(rs->height, 48);
    assert_string_equal(rs->technique, "shaded");
    assert_int_equal(rs->spp, 4);
    assert_near(volux_scene_light(s, 0)->irradiance, 2.5, 0);
    assert_near(volux_scene_light(s, 1)->color.z, 0.75, 0);
    assert_near(volux_scene_light(s, 1)->color.x, 0.5, 0);
    assert_near(volux_scene_light(s, 1)->color.y, 0.25, 0);
    int dims[3];
    volux_volume_dims(volux_scene_volume(s), dims);
    assert_int_equal(dims[1], 5);
    assert_near(volux_scene_transfer(s)->albedo, 0.5, 0);
    assert_near(volux_scene_param(s, "ea", "early_termination", -1), 0.05, 0);
    assert_string_equal(volux_scene_param_string(s, "x", "label", ""), "hello world");
    assert_string_equal(volux_scene_param_string(s, "x", "quoted", ""), "7");
    assert_near(volux_scene_camera_desc(s)->azimuth_deg, 45, 0);
    assert_near(volux_scene_background(s).y, 0.5, 0);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

static void test_overrides_replace_append_and_create_arrays(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    /* Index == length appends; a whole object replaces a light. */
    const char *ov[] = {"lights.2.type=spot", "lights.2.cone_angle=20", "lights.0={\"type\": \"point\", \"intensity\": 3}",
                        "lights.3={\"type\": \"sphere\", \"radius\": 2}"};
    volux_scene *s = load_ok(ctx, SMALL, ov, 4);
    assert_int_equal(volux_scene_light_slots(s), 4);
    assert_int_equal(volux_scene_light(s, 0)->type, VOLUX_LIGHT_POINT);
    assert_near(volux_scene_light(s, 0)->intensity, 3, 0);
    assert_int_equal(volux_scene_light(s, 2)->type, VOLUX_LIGHT_SPOT);
    assert_near(volux_scene_light(s, 2)->cone_angle_deg, 20, 0);
    assert_int_equal(volux_scene_light(s, 3)->type, VOLUX_LIGHT_SPHERE);
    volux_scene_destroy(s);

    /* A scene without lights: "lights.0.type" creates the array. */
    const char *ov2[] = {"lights.0.type=directional", "lights.0.irradiance=4"};
    s = load_ok(ctx,
                "{\"volume\": {\"procedural\": \"sphere\", \"dims\": [4, 4, 4]},"
                " \"transfer_function\": {\"opacity\": [[0, 1]]}}",
                ov2, 2);
    assert_int_equal(volux_scene_light_slots(s), 1);
    assert_near(volux_scene_light(s, 0)->irradiance, 4, 0);
    volux_scene_destroy(s);

    /* Removing all lights, switching the volume kind. */
    const char *ov3[] = {"lights=[]", "volume={\"procedural\": \"cloud\", \"dims\": [6, 6, 6], \"seed\": 2}"};
    s = load_ok(ctx, SMALL, ov3, 2);
    assert_int_equal(volux_scene_light_slots(s), 0);
    int dims[3];
    volux_volume_dims(volux_scene_volume(s), dims);
    assert_int_equal(dims[0], 6);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

static void test_override_errors_name_the_assignment(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    char long_path[700];
    memset(long_path, 'a', sizeof long_path);
    strcpy(long_path + 600, "=1");
    const struct {
        const char *set;
        volux_status st;
        const char *part;
    } cases[] = {
        {"render.width", VOLUX_ERR_INVALID, "--set render.width: expected dotted.path=value"},
        {"=3", VOLUX_ERR_INVALID, "expected dotted.path=value"},
        {"render..width=3", VOLUX_ERR_INVALID, "--set render..width: empty key in the path"},
        {".render=3", VOLUX_ERR_INVALID, "empty key"},
        {"render.=3", VOLUX_ERR_INVALID, "empty key"},
        {"lights.7.type=point", VOLUX_ERR_INVALID, "--set lights.7: '7' is not an index of the array"},
        {"lights.x.type=point", VOLUX_ERR_INVALID, "'x' is not an index"},
        {"lights.0.color.2=0.5", VOLUX_ERR_INVALID, "--set lights.0.color.2: '2' is not an index of the array (empty; 0 appends)"},
        {"lights.-1.type=point", VOLUX_ERR_INVALID, "'-1' is not an index"},
        {"lights.+1.type=point", VOLUX_ERR_INVALID, "'+1' is not an index"},
        {"render.width.x=1", VOLUX_ERR_INVALID, "'render.width' is a value, not an object or array"},
        {"lights.0.color=[1,2", VOLUX_ERR_INVALID, "--set lights.0.color=[1,2: invalid JSON"},
        {"render={\"width\": 3", VOLUX_ERR_INVALID, "invalid JSON"},
        {"render.technique=\"ea", VOLUX_ERR_INVALID, "invalid JSON"},
        {"render.technique=\"e\\u0000a\"", VOLUX_ERR_INVALID, "\\u0000"},
        {"render.width=64abc", VOLUX_ERR_INVALID, "render.width: expected a number"},
        {"render.width=1 2", VOLUX_ERR_INVALID, "render.width: expected a number"},
        {"render.technique=true", VOLUX_ERR_INVALID, "render.technique: expected a string"},
        {"render.technique=\"a-technique-name-longer-than-31-chars\"", VOLUX_ERR_INVALID,
         "render.technique: name too long"},
        {"render.width=0", VOLUX_ERR_INVALID, "render.width: 0 is outside [1, 32768]"},
        {"render.width=1e999", VOLUX_ERR_INVALID, "render.width: inf is outside"},
        {"render.widht=3", VOLUX_ERR_INVALID, "render.widht: unknown key; did you mean 'width'?"},
        {"lights.0.cone_angle=10", VOLUX_ERR_INVALID, "lights[0].cone_angle: unknown key"},
        {"lights.1.intensity=-1", VOLUX_ERR_INVALID, "lights[1].intensity: -1 is outside"},
        {"transfer_function.opacity.1.1=2", VOLUX_ERR_INVALID, "transfer_function.opacity[1]: 2 is outside [0, 1]"},
        {"volume.dims.2=0", VOLUX_ERR_INVALID, "volume.dims[2]: must be an integer"},
        {"volume.file=x.nrrd", VOLUX_ERR_INVALID, "give exactly one of file, files, pattern, procedural"},
        {"techniques.ea=3", VOLUX_ERR_INVALID, "techniques.ea: expected an object of parameters"},
        {"techniques.ea.mode=[1]", VOLUX_ERR_INVALID, "techniques.ea.mode: expected a number, boolean or string"},
        {long_path, VOLUX_ERR_INVALID, "path longer than 511"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        const char *ov[] = {cases[i].set};
        load_fails(ctx, SMALL, ov, 1, cases[i].st, cases[i].part);
    }
    /* A bare word after a failed JSON parse leaves no stale message behind. */
    volux_context_clear_error(ctx);
    const char *ok[] = {"render.technique=shaded"};
    volux_scene *s = load_ok(ctx, SMALL, ok, 1);
    assert_string_equal(volux_context_error(ctx), "");
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

static void test_no_files_flag_refuses_every_file_reference(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    static const char *const scenes[][2] = {
        {"{\"volume\": {\"file\": \"/etc/hostname\"}, \"transfer_function\": {\"opacity\": [[0, 1]]}}",
         "volume.file: file references are disabled"},
        {"{\"volume\": {\"procedural\": \"sphere\", \"dims\": [4, 4, 4]}, \"transfer_function\": \"tf.json\"}",
         "transfer_function: file references are disabled"},
        {"{\"volume\": {\"procedural\": \"sphere\", \"dims\": [4, 4, 4]},"
         " \"transfer_function\": {\"preset\": \"p.json\", \"opacity\": [[0, 1]]}}",
         "transfer_function.preset: file references are disabled"},
        {"{\"volume\": {\"procedural\": \"sphere\", \"dims\": [4, 4, 4]}, \"transfer_function\": {\"opacity\": [[0, "
         "1]]}, \"lights\": [{\"type\": \"environment\", \"file\": \"../env.hdr\"}]}",
         "lights[0].file: file references are disabled"},
    };
    for (size_t i = 0; i < sizeof scenes / sizeof scenes[0]; i++) {
        volux_scene *s = NULL;
        volux_context_clear_error(ctx);
        assert_int_equal(volux_scene_parse(ctx, scenes[i][0], strlen(scenes[i][0]), "/nonexistent", "nf.json", NULL, 0,
                                           VOLUX_SCENE_NO_FILES, &s),
                         VOLUX_ERR_UNSUPPORTED);
        assert_contains(volux_context_error(ctx), scenes[i][1]);
    }
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_full_scene_reads_every_field),
        cmocka_unit_test(test_defaults_when_optional_sections_are_absent),
        cmocka_unit_test(test_spot_default_falloff_stays_inside_a_narrow_cone),
        cmocka_unit_test(test_orbit_camera_distance_follows_fov),
        cmocka_unit_test(test_orthographic_height_given_or_from_orbit_framing),
        cmocka_unit_test(test_relative_paths_resolve_against_the_scene_folder),
        cmocka_unit_test(test_raw_layout_keys_and_nrrd_origin),
        cmocka_unit_test(test_tf_file_errors_name_scene_and_tf_file),
        cmocka_unit_test(test_paraview_preset_named_rescaled_with_opacity_points),
        cmocka_unit_test(test_preset_parse_from_memory),
        cmocka_unit_test(test_preset_midpoint_and_sharpness),
        cmocka_unit_test(test_overrides_set_numbers_strings_and_bare_words),
        cmocka_unit_test(test_overrides_replace_append_and_create_arrays),
        cmocka_unit_test(test_override_errors_name_the_assignment),
        cmocka_unit_test(test_no_files_flag_refuses_every_file_reference),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
