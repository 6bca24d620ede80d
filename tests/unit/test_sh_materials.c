/*
 * The transfer function's material channel (scene JSON → volux_tf_material
 * → `sh`'s tables) and the MERL .binary reader:
 *  - every material type parses with its own keys; a key of another type,
 *    a bad range, an unknown type or a missing MERL file is an error
 *    naming transfer_function.materials[i];
 *  - set_transfer copies the channel and bumps COLOR only when it changes;
 *  - a MERL file with constant reflectance ρ/π projects exactly like a
 *    Lambert material of albedo ρ (per channel, with the database's
 *    channel scales), and malformed files are rejected with the file name.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "io/merl.h"
#include "techniques/sh/sh.h"
#include "test_util.h"

static const char *head =
    "{\"volume\": {\"procedural\": \"sphere\", \"dims\": [8, 8, 8]},"
    " \"transfer_function\": {\"opacity\": [[0, 0], [255, 0.5]], \"materials\": ";

static volux_status load(volux_context *ctx, const char *materials, volux_scene **out) {
    char json[4096];
    snprintf(json, sizeof json, "%s%s}}", head, materials);
    volux_context_clear_error(ctx);
    return volux_scene_load_string(ctx, json, tu_temp_path(""), "m.json", NULL, 0, out);
}

static void expect_error(volux_context *ctx, const char *materials, const char *part) {
    volux_scene *s = NULL;
    if (load(ctx, materials, &s) == VOLUX_OK) fail_msg("accepted: %s", materials);
    if (!strstr(volux_context_error(ctx), part)) fail_msg("message '%s' lacks '%s'", volux_context_error(ctx), part);
}

/* A MERL file of constant value v (before the channel scales). */
static const char *write_merl(const char *name, int d0, int d1, int d2, double v) {
    size_t n = (size_t)d0 * d1 * d2, bytes = 12 + 24 * n;
    unsigned char *buf = calloc(1, bytes);
    int32_t dims[3] = {d0, d1, d2};
    memcpy(buf, dims, 12);
    for (size_t i = 0; i < 3 * n; i++) memcpy(buf + 12 + 8 * i, &v, 8);
    const char *p = tu_write_file(name, buf, bytes);
    free(buf);
    return p;
}

static void test_parse_all_types(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    write_merl("flat.binary", 4, 4, 8, 300.0);
    volux_scene *s = NULL;
    const char *m =
        "[{\"range\": [0, 40], \"type\": \"phase\", \"anisotropy\": 0.6},"
        " {\"range\": [40, 80], \"type\": \"lambert\", \"diffuse\": 0.5},"
        " {\"range\": [80, 120], \"type\": \"blinn_phong\", \"diffuse\": 0.4, \"specular\": 0.5, \"shininess\": 60},"
        " {\"range\": [120, 160], \"type\": \"ashikhmin_shirley\", \"shininess\": 100, \"f0\": 0.2},"
        " {\"range\": [160, 200], \"type\": \"cook_torrance\", \"roughness\": 0.2, \"f0\": 0.9, \"comment\": \"metal\"},"
        " {\"range\": [200, 255], \"type\": \"merl\", \"file\": \"flat.binary\"}]";
    if (load(ctx, m, &s)) fail_msg("%s", volux_context_error(ctx));
    const volux_transfer_desc *tf = volux_scene_transfer(s);
    assert_int_equal(tf->n_materials, 6);
    assert_int_equal(tf->materials[0].kind, VOLUX_MATERIAL_PHASE);
    assert_near(tf->materials[0].g, 0.6, 1e-6);
    assert_near(tf->materials[2].shininess, 60, 1e-6);
    assert_near(tf->materials[4].roughness, 0.2, 1e-6);
    assert_near(tf->materials[5].s0, 200, 1e-6);
    assert_non_null(strstr(tf->materials[5].file, "flat.binary"));
    /* an unchanged channel does not bump COLOR; a changed one does */
    volux_scene_stamp before = volux_scene_stamp_now(s);
    volux_transfer_desc d = *tf;
    assert_int_equal(volux_scene_set_transfer(s, &d), VOLUX_OK);
    assert_int_equal(volux_scene_changes_since(s, &before).what, 0u);
    volux_tf_material copy[6];
    tf = volux_scene_transfer(s); /* the setter replaced the arrays d pointed to */
    d = *tf;
    memcpy(copy, tf->materials, sizeof copy);
    copy[1].diffuse = 0.25f;
    d.materials = copy;
    assert_int_equal(volux_scene_set_transfer(s, &d), VOLUX_OK);
    assert_int_equal(volux_scene_changes_since(s, &before).what, (uint32_t)VOLUX_CHANGE_COLOR);
    /* sh renders it (every kind, BRDFs with normals) */
    volux_technique *t;
    if (volux_technique_create(ctx, "sh", s, &t)) fail_msg("%s", volux_context_error(ctx));
    volux_technique_destroy(t);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

static void test_bad_materials(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    expect_error(ctx, "[{\"range\": [0, 1], \"type\": \"lambert\", \"shininess\": 3}]",
                 "transfer_function.materials[0].shininess: unknown key");
    expect_error(ctx, "[{\"range\": [5, 1], \"type\": \"lambert\"}]", "transfer_function.materials[0].range");
    expect_error(ctx, "[{\"range\": [0], \"type\": \"lambert\"}]", "transfer_function.materials[0].range");
    expect_error(ctx, "[{\"range\": [0, 1], \"type\": \"velvet\"}]", "transfer_function.materials[0]: type must be");
    expect_error(ctx, "[{\"range\": [0, 1], \"type\": \"cook_torrance\", \"roughness\": 0}]",
                 "transfer_function.materials[0].roughness");
    expect_error(ctx, "[{\"range\": [0, 1], \"type\": \"merl\"}]", "transfer_function.materials[0].file: missing");
    expect_error(ctx, "[{\"range\": [0, 1], \"type\": \"merl\", \"file\": \"nope.binary\"}]", "nope.binary");
    write_merl("bad.binary", 4, 4, 8, 1.0);
    FILE *f = fopen(tu_temp_path("bad.binary"), "ab");
    fputc(0, f);
    fclose(f);
    expect_error(ctx, "[{\"range\": [0, 1], \"type\": \"merl\", \"file\": \"bad.binary\"}]", "bad.binary");
    expect_error(ctx, "{\"range\": [0, 1]}", "transfer_function.materials");
    volux_context_destroy(ctx);
}

static void test_merl_constant_is_lambert(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    const double raw = 150.0; /* ρ/π per channel = raw·scale_c */
    const double scale[3] = {1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0};
    volux_tf_material t;
    volux_tf_material_defaults(&t, VOLUX_MATERIAL_MERL);
    snprintf(t.file, sizeof t.file, "%s", write_merl("const.binary", 90, 90, 180, raw));
    volux_merl merl;
    assert_int_equal(volux_merl_load(ctx, t.file, &merl), VOLUX_OK);
    double wi[3] = {0.3, 0.2, 0.932738}, wo[3] = {-0.5, 0.1, 0.860233}, rgb[3];
    volux_merl_eval(&merl, wi, wo, rgb);
    for (int c = 0; c < 3; c++) assert_near(rgb[c], raw * scale[c], 1e-7);
    wi[2] = -0.1;
    volux_merl_eval(&merl, wi, wo, rgb);
    assert_true(rgb[0] == 0.0);
    volux_merl_free(ctx, &merl);
    sh_material m;
    assert_int_equal(sh_material_prepare(ctx, &t, &m), VOLUX_OK);
    for (int k = 0; k < SH_TABLE_THETA; k += 5)
        for (int c = 0; c < 3; c++)
            for (int l = 0; l < 4; l++)
                assert_near(m.table[k][1 + c][l * (l + 1)], raw * scale[c] * sh_clamped_cosine_zonal(l),
                            2e-3 * raw * scale[c]); /* the 48×96 quadrature */
    sh_material_free(ctx, &m);
    volux_context_destroy(ctx);
}

static void test_merl_malformed(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    unsigned char buf[12 + 24] = {0};
    int32_t dims[3] = {1, 1, 1};
    memcpy(buf, dims, 12);
    volux_merl m = {{0, 0, 0}, NULL, 0};
    assert_int_equal(volux_merl_parse(ctx, buf, sizeof buf, "ok.binary", &m), VOLUX_OK);
    volux_merl_free(ctx, &m);
    const struct { size_t size; int32_t d0; const char *part; } cases[] = {
        {sizeof buf - 1, 1, "expected 12 + 24"}, {8, 1, "too short"}, {sizeof buf, 0, "outside [1, 1024]"},
        {sizeof buf, -7, "outside [1, 1024]"}, {sizeof buf, 2000, "outside [1, 1024]"}};
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        memcpy(buf, &cases[i].d0, 4);
        volux_context_clear_error(ctx);
        assert_int_equal(volux_merl_parse(ctx, buf, cases[i].size, "x.binary", &m), VOLUX_ERR_FORMAT);
        assert_null(m.rgb);
        if (!strstr(volux_context_error(ctx), cases[i].part) || !strstr(volux_context_error(ctx), "x.binary"))
            fail_msg("case %zu: %s", i, volux_context_error(ctx));
    }
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_parse_all_types), cmocka_unit_test(test_bad_materials),
        cmocka_unit_test(test_merl_constant_is_lambert), cmocka_unit_test(test_merl_malformed)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
