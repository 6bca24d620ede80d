/*
 * tests/robustness/test_volume_policies.c — what volux does with volume
 * files that are odd rather than broken (issue 16): raw NRRD data followed
 * by more bytes (loaded with a warning, as Teem does), float data holding
 * NaN/Inf (refused with the count and the first voxel, or mapped to the
 * lowest value when allowed), detached data reached through a symbolic
 * link that leaves the header's folder (refused, naming the field and not
 * the target), error messages that name the header the user passed and
 * escape untrusted bytes.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "io/volume_formats.h"
#include "tu_volume.h"

static void test_raw_nrrd_trailing_bytes_load_with_a_warning(void **state) {
    (void)state;
    unsigned char data[8 + 5] = {1, 2, 3, 4, 5, 6, 7, 8, 99, 99, 99, 99, 99};
    const char *path =
        tu_write_parts("trail.nrrd", "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n\n", data,
                       sizeof data);
    volux_context *ctx = tu_context(1);
    tu_messages w = {0};
    volux_context_set_message(ctx, tu_collect_messages, &w);
    volux_volume *v = NULL;
    assert_int_equal(volux_volume_load(ctx, path, NULL, &v), VOLUX_OK);
    assert_int_equal(w.warnings, 1);
    assert_non_null(strstr(w.last, "trail.nrrd"));
    assert_non_null(strstr(w.last, "5 bytes after"));
    /* The data are the first 8 bytes, not the trailing ones. */
    double lo, hi;
    volux_volume_range(v, &lo, &hi);
    assert_true(lo == 1.0 && hi == 8.0);
    volux_volume_release(v);
    /* Compressed data must still decode to exactly the declared size. */
    volux_context_destroy(ctx);
}

/* A raw float NRRD of 2×2×2 whose voxel 5 is NaN and voxel 6 +Inf. */
static const char *nonfinite_file(void) {
    float f[8] = {0, 1, 2, 3, 4, NAN, INFINITY, 7};
    return tu_write_parts("nan.nrrd", "NRRD0004\ntype: float\ndimension: 3\nsizes: 2 2 2\nendian: little\nencoding: raw\n\n", f,
                          sizeof f);
}

static void test_nonfinite_values_refused_by_default(void **state) {
    (void)state;
    const char *path = nonfinite_file();
    volux_context *ctx = tu_context(1);
    volux_volume *v = NULL;
    assert_int_equal(volux_volume_load(ctx, path, NULL, &v), VOLUX_ERR_FORMAT);
    assert_null(v);
    /* voxel 5 = (1, 0, 1) */
    tu_assert_error_mentions(ctx, "nan.nrrd", "2 non-finite values", "(1, 0, 1)", "allow_nonfinite",
                             (const char *)NULL);
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

static void test_nonfinite_values_mapped_when_allowed(void **state) {
    (void)state;
    const char *path = nonfinite_file();
    volux_context *ctx = tu_context(1);
    tu_messages w = {0};
    volux_context_set_message(ctx, tu_collect_messages, &w);
    volux_volume_load_options o;
    memset(&o, 0, sizeof o);
    o.allow_nonfinite = 1;
    volux_volume *v = NULL;
    assert_int_equal(volux_volume_load(ctx, path, &o, &v), VOLUX_OK);
    assert_int_equal(w.warnings, 1);
    assert_non_null(strstr(w.last, "2 non-finite"));
    double lo, hi;
    volux_volume_range(v, &lo, &hi);
    assert_true(lo == 0.0 && hi == 7.0); /* NaN/Inf took the lowest value */
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

/* The same through the scene: refused (the message names the volume file,
 * not a preset), and "allow_nonfinite": true renders a finite image. */
static void test_nonfinite_through_the_scene(void **state) {
    (void)state;
    nonfinite_file();
    const char *json = "{\"volume\": {\"file\": \"nan.nrrd\"%s},"
                       " \"transfer_function\": {\"opacity\": [[0, 0], [7, 0.8]]},"
                       " \"render\": {\"technique\": \"ea\", \"width\": 8, \"height\": 8}}";
    char text[512];
    volux_context *ctx = tu_context(1);
    volux_scene *s = NULL;
    snprintf(text, sizeof text, json, "");
    assert_int_equal(volux_scene_load_string(ctx, text, tu_temp_path(""), "nan.json", NULL, 0, &s),
                     VOLUX_ERR_FORMAT);
    tu_assert_error_mentions(ctx, "nan.nrrd", "non-finite", (const char *)NULL);
    volux_context_clear_error(ctx);
    snprintf(text, sizeof text, json, ", \"allow_nonfinite\": true");
    assert_int_equal(volux_scene_load_string(ctx, text, tu_temp_path(""), "nan.json", NULL, 0, &s), VOLUX_OK);
    volux_image img = tu_render(ctx, s, "ea");
    for (int i = 0; i < 3 * img.width * img.height; i++) assert_true(isfinite(img.rgb[i]));
    volux_image_free(ctx, &img);
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
}

/* Library callers creating volumes from memory get the same rule. */
static void test_volume_create_refuses_nonfinite(void **state) {
    (void)state;
    float f[8] = {0, 1, 2, 3, 4, 5, -INFINITY, 7};
    volux_context *ctx = tu_context(1);
    volux_volume_desc d = {{2, 2, 2}, {1, 1, 1}, {0, 0, 0}, 0, VOLUX_FLOAT32, f, 0};
    volux_volume *v = NULL;
    assert_int_equal(volux_volume_create(ctx, &d, &v), VOLUX_ERR_INVALID);
    tu_assert_error_mentions(ctx, "1 non-finite", "(0, 1, 1)", (const char *)NULL);
    volux_context_clear_error(ctx);
    d.allow_nonfinite = 1;
    assert_int_equal(volux_volume_create(ctx, &d, &v), VOLUX_OK);
    double lo, hi;
    volux_volume_range(v, &lo, &hi);
    assert_true(lo == 0.0 && hi == 7.0);
    volux_volume_release(v);
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

/* A detached header in dir/ whose data file is a link to a file outside
 * dir/: refused with the field named and nothing about the target (not
 * its name, not its size). A link that stays inside is followed. */
static void test_symlinked_data_must_stay_inside(void **state) {
    (void)state;
    char dir[256], outside[512], link[512], inside_link[512], data[512];
    snprintf(dir, sizeof dir, "%s", tu_temp_path("hdrdir"));
    if (access(dir, F_OK) != 0) assert_int_equal(mkdir(dir, 0700), 0);
    unsigned char bytes[8] = {0};
    snprintf(outside, sizeof outside, "%s", tu_write_file("secret-outside.raw", "0123456789abcdef", 16));
    snprintf(link, sizeof link, "%s/link.raw", dir);
    snprintf(inside_link, sizeof inside_link, "%s/inner.raw", dir);
    snprintf(data, sizeof data, "%s/real.raw", dir);
    unlink(link);
    unlink(inside_link);
    assert_int_equal(symlink(outside, link), 0);
    FILE *f = fopen(data, "wb");
    assert_non_null(f);
    fwrite(bytes, 1, sizeof bytes, f);
    fclose(f);
    assert_int_equal(symlink("real.raw", inside_link), 0);

    char hdr[512];
    snprintf(hdr, sizeof hdr, "%s/evil.nhdr", dir);
    f = fopen(hdr, "wb");
    assert_non_null(f);
    fputs("NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\ndata file: link.raw\n", f);
    fclose(f);
    volux_context *ctx = tu_context(1);
    volux_volume *v = NULL;
    assert_int_equal(volux_volume_load(ctx, hdr, NULL, &v), VOLUX_ERR_FORMAT);
    tu_assert_error_mentions(ctx, "evil.nhdr", "data file", "link.raw", "outside the header's folder",
                             (const char *)NULL);
    assert_null(strstr(volux_context_error(ctx), "secret-outside"));
    assert_null(strstr(volux_context_error(ctx), "16"));
    volux_context_clear_error(ctx);
    /* allowed explicitly: followed (16 bytes for 8: the rest ignored) */
    volux_volume_load_options o;
    memset(&o, 0, sizeof o);
    o.allow_outside_dir = 1;
    assert_int_equal(volux_volume_load(ctx, hdr, &o, &v), VOLUX_OK);
    volux_volume_release(v);

    f = fopen(hdr, "wb");
    assert_non_null(f);
    fputs("NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\ndata file: inner.raw\n", f);
    fclose(f);
    assert_int_equal(volux_volume_load(ctx, hdr, NULL, &v), VOLUX_OK);
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

/* A detached data file that is too short: the message names the header
 * first, then the data file. */
static void test_detached_messages_name_the_header(void **state) {
    (void)state;
    tu_write_file("short.raw", "abc", 3);
    const char *hdr = tu_write_file(
        "named.nhdr", "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\ndata file: short.raw\n",
        strlen("NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\ndata file: short.raw\n"));
    volux_context *ctx = tu_context(1);
    volux_volume *v = NULL;
    assert_int_equal(volux_volume_load(ctx, hdr, NULL, &v), VOLUX_ERR_FORMAT);
    const char *msg = volux_context_error(ctx);
    const char *h = strstr(msg, "named.nhdr"), *d = strstr(msg, "short.raw");
    assert_non_null(h);
    assert_non_null(d);
    assert_true(h < d);
    volux_context_destroy(ctx);
}

/* Untrusted bytes in a message (a file name holding an escape sequence and
 * invalid UTF-8) come out as \xHH, valid UTF-8 passes. */
static void test_messages_escape_untrusted_bytes(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_volume *v = NULL;
    const char *name = tu_temp_path("evil\x1b[31m\xff\xc3\xa9.nrrd");
    assert_int_not_equal(volux_volume_load(ctx, name, NULL, &v), VOLUX_OK);
    const char *msg = volux_context_error(ctx);
    assert_null(strchr(msg, 0x1b));
    assert_null(strchr(msg, (char)0xff));
    assert_non_null(strstr(msg, "evil\\x1b[31m\\xff\xc3\xa9.nrrd"));
    volux_context_destroy(ctx);
}

/* A folder of its own for a split volume's files. */
static const char *stack_dir(const char *name) {
    static char dir[256];
    snprintf(dir, sizeof dir, "%s", tu_temp_path(name));
    if (access(dir, F_OK) != 0) assert_int_equal(mkdir(dir, 0700), 0);
    return dir;
}

static void put(const char *dir, const char *name, const void *data, size_t n) {
    char path[512];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(data, 1, n, f), n);
    fclose(f);
}

static volux_status load_in(const char *dir, const char *header, volux_context *ctx, volux_volume **v) {
    char path[512];
    snprintf(path, sizeof path, "%s/h.nhdr", dir);
    put(dir, "h.nhdr", header, strlen(header));
    return volux_volume_load(ctx, path, NULL, v);
}

/* NRRD data over several files (issue 16): "FMT MIN MAX STEP [subdim]" and
 * "LIST [subdim]", raw or gzip, skips applied to every file. A 3×2×4
 * uint8 volume whose value at (x, y, z) is 50·z + 10·y + x, one slice per
 * file. */
static void test_nrrd_slice_stacks(void **state) {
    (void)state;
    const char *dir = stack_dir("stack");
    for (int z = 0; z < 4; z++) {
        unsigned char slice[2 + 6];
        slice[0] = slice[1] = 0xee; /* 2 bytes skipped in every file */
        for (int i = 0; i < 6; i++) slice[2 + i] = (unsigned char)(50 * z + 10 * (i / 3) + i % 3);
        char name[32];
        snprintf(name, sizeof name, "s%03d.raw", 10 - 2 * z); /* 10, 8, 6, 4: a descending pattern */
        put(dir, name, slice, sizeof slice);
        size_t zn;
        unsigned char *gz = tu_deflate(slice + 2, 6, 1, &zn);
        snprintf(name, sizeof name, "z%d.gz", z);
        put(dir, name, gz, zn);
        free(gz);
    }
#define H "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 3 2 4\n"
    volux_context *ctx = tu_context(1);
    volux_volume *v = NULL;
    const char *ok[] = {
        H "encoding: raw\nbyte skip: 2\ndata file: s%03d.raw 10 4 -2\n",
        H "encoding: raw\nbyte skip: 2\ndata file: s%03d.raw 10 4 -2 2\n",
        H "encoding: gzip\ndata file: LIST\nz0.gz\n  z1.gz\nz2.gz\n\nz3.gz\n\n",
    };
    for (size_t c = 0; c < sizeof ok / sizeof ok[0]; c++) {
        if (load_in(dir, ok[c], ctx, &v)) fail_msg("case %zu: %s", c, volux_context_error(ctx));
        double lo, hi;
        volux_volume_range(v, &lo, &hi);
        assert_true(lo == 0 && hi == 162);
        /* every voxel: the range alone would not catch swapped slices */
        for (int z = 0; z < 4; z++)
            for (int y = 0; y < 2; y++)
                for (int x = 0; x < 3; x++)
                    if (volux_volume_value_at(v, x, y, z) != 50 * z + 10 * y + x)
                        fail_msg("case %zu: voxel (%d, %d, %d) = %g", c, x, y, z, volux_volume_value_at(v, x, y, z));
        volux_volume_release(v);
        v = NULL;
    }
    static const struct {
        const char *header;
        volux_status status;
        const char *what;
    } bad[] = {
        {H "encoding: raw\nbyte skip: 2\ndata file: s%03d.raw 10 6 -2\n", VOLUX_ERR_FORMAT, "names 3 files, the sizes need 4"},
        {H "encoding: raw\ndata file: s%03d.raw 10 4 2\n", VOLUX_ERR_FORMAT, "never goes from 10 to 4"},
        {H "encoding: raw\ndata file: s%s.raw 1 4 1\n", VOLUX_ERR_FORMAT, "one integer conversion"},
        {H "encoding: raw\ndata file: s%d%d.raw 1 4 1\n", VOLUX_ERR_FORMAT, "one integer conversion"},
        {H "encoding: raw\ndata file: s%n.raw 1 4 1\n", VOLUX_ERR_FORMAT, "one integer conversion"},
        {H "encoding: raw\ndata file: ../s%03d.raw 1 4 1\n", VOLUX_ERR_FORMAT, "outside"},
        {H "encoding: raw\nbyte skip: 2\ndata file: s%03d.raw 12 6 -2\n", VOLUX_ERR_IO, "data file 1 of 4"},
        {H "encoding: raw\nbyte skip: 3\ndata file: s%03d.raw 10 4 -2\n", VOLUX_ERR_FORMAT, "data file 1 of 4"}, /* 5 for 6 */
        {H "encoding: gzip\ndata file: LIST\nz0.gz\nz1.gz\nz2.gz\n", VOLUX_ERR_FORMAT, "LIST names 3 files, the sizes need 4"},
        {H "encoding: gzip\ndata file: LIST\nz0.gz\nz1.gz\nz2.gz\nz3.gz\nz3.gz\n", VOLUX_ERR_FORMAT, "more than the 4"},
        {H "encoding: gzip\ndata file: LIST\nz0.gz\n/etc/passwd\nz2.gz\nz3.gz\n", VOLUX_ERR_FORMAT, "/etc/passwd"},
        {H "encoding: gzip\ndata file: LIST 4\nz0.gz\n", VOLUX_ERR_FORMAT, "subdim must be in [1, 3]"},
        {"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 16384 2\nencoding: raw\ndata file: LIST 1\n", VOLUX_ERR_LIMIT,
         "over the limit"},
    };
    for (size_t c = 0; c < sizeof bad / sizeof bad[0]; c++) {
        volux_context_clear_error(ctx);
        volux_status st = load_in(dir, bad[c].header, ctx, &v);
        if (st != bad[c].status || !strstr(volux_context_error(ctx), bad[c].what) ||
            !strstr(volux_context_error(ctx), "h.nhdr"))
            fail_msg("bad case %zu: got %s '%s', expected %s '%s'", c, volux_status_name(st), volux_context_error(ctx),
                     volux_status_name(bad[c].status), bad[c].what);
        assert_null(v);
    }
#undef H
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_raw_nrrd_trailing_bytes_load_with_a_warning),
        cmocka_unit_test(test_nonfinite_values_refused_by_default),
        cmocka_unit_test(test_nonfinite_values_mapped_when_allowed),
        cmocka_unit_test(test_nonfinite_through_the_scene),
        cmocka_unit_test(test_volume_create_refuses_nonfinite),
        cmocka_unit_test(test_symlinked_data_must_stay_inside),
        cmocka_unit_test(test_detached_messages_name_the_header),
        cmocka_unit_test(test_messages_escape_untrusted_bytes),
        cmocka_unit_test(test_nrrd_slice_stacks),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
