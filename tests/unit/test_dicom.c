/*
 * tests/unit/test_dicom.c — DICOM series through GDCM (src/io/dicom.c and
 * the adapter src/io/dicom_gdcm.cxx), on series that GDCM's own writer
 * made from a known volume (tests/dicom/dicom_gen.cxx, see its header for
 * the volume): exact voxel values after the rescale to HU, spacing from
 * positions, slice order from positions (not names, not InstanceNumber),
 * the superior direction, compressed transfer syntaxes, multi-frame,
 * series choice, and malformed series refused with a named message (also
 * through the CLI: exit 2). Built without GDCM it checks that a DICOM
 * input is refused with a message saying so.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "test_util.h"

#ifdef VOLUX_HAVE_GDCM

/* Writes case `kase` into a fresh folder and returns its path. */
static const char *make_case(const char *kase) {
    static char dir[4][1024];
    static int slot;
    char *d = dir[slot++ % 4];
    char name[64];
    snprintf(name, sizeof name, "dicom_%s", kase);
    snprintf(d, 1024, "%s", tu_temp_path(name));
    char cmd[3000];
    snprintf(cmd, sizeof cmd, "rm -rf '%s' && mkdir -p '%s' && '%s' %s '%s'", d, d, VOLUX_DICOM_GEN, kase, d);
    if (system(cmd) != 0) fail_msg("cannot generate DICOM case %s", kase);
    return d;
}

static int stored(int i, int j, int k) { return (7 * i + 13 * j + 101 * k) % 4000; }

static volux_volume *load(volux_context *ctx, const char *path) {
    volux_volume *v = NULL;
    volux_volume_load_options o = {0};
    o.use_file_origin = 1;
    if (volux_volume_load(ctx, path, &o, &v) != VOLUX_OK) fail_msg("%s: %s", path, volux_context_error(ctx));
    return v;
}

/* The test volume: 20x16x12, x 0.7, y 0.8, z 2.5, HU = stored − 1024. */
static void check_ct(volux_volume *v, double slope, double inter, int is_signed) {
    int d[3];
    double sp[3];
    volux_volume_dims(v, d);
    volux_volume_spacing(v, sp);
    assert_int_equal(d[0], 20);
    assert_int_equal(d[1], 16);
    assert_int_equal(d[2], 12);
    assert_near(sp[0], 0.7, 1e-9);
    assert_near(sp[1], 0.8, 1e-9);
    assert_near(sp[2], 2.5, 1e-6);
    for (int k = 0; k < 12; k++)
        for (int j = 0; j < 16; j++)
            for (int i = 0; i < 20; i++) {
                double want = slope * (stored(i, j, k) - (is_signed ? 1500 : 0)) + inter;
                float got = volux_volume_value_at(v, i, j, k);
                if (got != (float)want) fail_msg("voxel (%d,%d,%d) = %g, expected %g", i, j, k, got, want);
            }
}

static void axial_ct(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_volume *v = load(ctx, make_case("ct"));
    check_ct(v, 1, -1024, 0);
    assert_int_equal(volux_volume_type(v), VOLUX_INT16); /* 12 bits − 1024 fits int16 */
    volux_vec3 up;
    assert_true(volux_volume_superior(v, &up));
    assert_near(up.z, 1.0, 1e-6); /* axial slices stacked foot to head along +z */
    volux_vec3 o = volux_volume_origin(v);
    assert_near(o.x, -10, 1e-4);
    assert_near(o.y, -20, 1e-4);
    assert_near(o.z, 30, 1e-4);
    volux_volume_release(v);
    /* One file of the series opens the whole series. */
    char one[1200];
    snprintf(one, sizeof one, "%s/s05.dcm", make_case("ct"));
    v = load(ctx, one);
    check_ct(v, 1, -1024, 0);
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

static void compressed(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    static const char *cases[] = {"ct-rle", "ct-jpegls", "ct-j2k", "ct-jpeg"};
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        volux_volume *v = load(ctx, make_case(cases[c]));
        check_ct(v, 1, -1024, 0); /* lossless: exact */
        volux_volume_release(v);
    }
    volux_context_destroy(ctx);
}

static void float_rescale(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_volume *v = load(ctx, make_case("scale"));
    check_ct(v, 0.5, 10, 1);
    assert_int_equal(volux_volume_type(v), VOLUX_FLOAT32);
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

static void sagittal(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_volume *v = load(ctx, make_case("sag"));
    check_ct(v, 1, -1024, 0);
    /* rows run along +y (anterior→posterior in LPS), columns along −z
     * (down): superior is −y in the grid; the normal (−1,0,0) has none. */
    volux_vec3 up;
    assert_true(volux_volume_superior(v, &up));
    assert_near(up.x, 0, 1e-6);
    assert_near(up.y, -1, 1e-6);
    assert_near(up.z, 0, 1e-6);
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

static void multiframe(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    char path[1200];
    snprintf(path, sizeof path, "%s/multi.dcm", make_case("multi"));
    volux_volume *v = load(ctx, path);
    check_ct(v, 1, -1024, 0);
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

static void two_series(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    tu_messages m = {0};
    volux_context_set_message(ctx, tu_collect_messages, &m);
    const char *dir = make_case("two");
    volux_volume *v = load(ctx, dir);
    check_ct(v, 1, -1024, 0); /* the largest */
    assert_int_equal(m.warnings, 1);
    assert_non_null(strstr(m.last, "2 DICOM series"));
    assert_non_null(strstr(m.last, "MR #7 'second series' 8x8x3")); /* the other one, with a file to pass */
    volux_volume_release(v);
    char one[1200];
    snprintf(one, sizeof one, "%s/mr00.dcm", dir);
    v = load(ctx, one);
    int d[3];
    volux_volume_dims(v, d);
    assert_int_equal(d[0], 8);
    assert_int_equal(d[2], 3);
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

static void expect_refused(const char *kase, volux_status want, const char *needle) {
    volux_context *ctx = tu_context(1);
    const char *dir = make_case(kase);
    volux_volume *v = NULL;
    volux_status st = volux_volume_load(ctx, dir, NULL, &v);
    if (st != want || !strstr(volux_context_error(ctx), needle))
        fail_msg("%s: status %d, message '%s'; expected %d and '%s'", kase, st, volux_context_error(ctx), want,
                 needle);
    assert_null(v);
    assert_non_null(strstr(volux_context_error(ctx), dir)); /* names the folder */
    volux_context_destroy(ctx);
    /* The CLI: exit 2, the same message, no output file. */
    char args[1400];
    const char *out = tu_temp_path("dicom_refused.png");
    remove(out);
    snprintf(args, sizeof args, "render '%s' -o '%s' --width 16 --height 16", dir, out);
    const char *err;
    assert_int_equal(tu_run_cli(args, &err), 2);
    if (!strstr(err, needle)) fail_msg("CLI stderr for %s: %s", kase, err);
    struct stat sb;
    assert_int_not_equal(stat(out, &sb), 0);
}

static void malformed(void **state) {
    (void)state;
    expect_refused("missing", VOLUX_ERR_FORMAT, "missing slices: a gap of 5 mm");
    expect_refused("mixed", VOLUX_ERR_FORMAT, "mixed sizes in one series");
    expect_refused("tilt", VOLUX_ERR_UNSUPPORTED, "gantry tilt");
    expect_refused("dup", VOLUX_ERR_FORMAT, "two slices at the same position");
    expect_refused("truncated", VOLUX_ERR_FORMAT, "s06.dcm: pixel data is truncated"); /* slice 6 is file 7·6 mod 12 */
}

/* A folder with no DICOM at all, and a file that only claims to be one. */
static void not_dicom(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    const char *f = tu_write_file("fake.dcm", "not dicom at all", 16);
    volux_volume *v = NULL;
    assert_int_equal(volux_volume_load(ctx, f, NULL, &v), VOLUX_ERR_FORMAT);
    assert_non_null(strstr(volux_context_error(ctx), "fake.dcm"));
    char cmd[2100];
    const char *empty = tu_temp_path("dicom_empty");
    snprintf(cmd, sizeof cmd, "rm -rf '%s' && mkdir -p '%s' && echo hello > '%s/readme.txt'", empty, empty, empty);
    assert_int_equal(system(cmd), 0);
    volux_context_clear_error(ctx);
    assert_int_equal(volux_volume_load(ctx, empty, NULL, &v), VOLUX_ERR_FORMAT);
    if (!strstr(volux_context_error(ctx), "no DICOM image in the folder (1 files)"))
        fail_msg("empty folder: %s", volux_context_error(ctx));
    volux_context_destroy(ctx);
}

/* The CLI opens a folder like any volume: info and a quick look. */
static void cli_folder(void **state) {
    (void)state;
    const char *dir = make_case("ct");
    char args[1400];
    const char *err;
    snprintf(args, sizeof args, "info '%s'", dir);
    assert_int_equal(tu_run_cli(args, &err), 0);
    snprintf(args, sizeof args, "render '%s' -o '%s' --width 24 --height 24", dir, tu_temp_path("dicom_ql.png"));
    if (tu_run_cli(args, &err) != 0) fail_msg("render: %s", err);
    struct stat sb;
    assert_int_equal(stat(tu_temp_path("dicom_ql.png"), &sb), 0);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(axial_ct),   cmocka_unit_test(compressed), cmocka_unit_test(float_rescale),
        cmocka_unit_test(sagittal),   cmocka_unit_test(multiframe), cmocka_unit_test(two_series),
        cmocka_unit_test(malformed),  cmocka_unit_test(not_dicom),  cmocka_unit_test(cli_folder),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

#else

/* Built without GDCM: a DICOM input is refused with a message that says so. */
static void not_built(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    static const unsigned char head[132] = {[128] = 'D', 'I', 'C', 'M'};
    const char *f = tu_write_file("nodicom.dcm", head, sizeof head);
    volux_volume *v = NULL;
    assert_int_equal(volux_volume_load(ctx, f, NULL, &v), VOLUX_ERR_UNSUPPORTED);
    assert_non_null(strstr(volux_context_error(ctx), "without DICOM support"));
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {cmocka_unit_test(not_built)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}

#endif
