/*
 * tests/unit/test_vti.c — the VTK XML ImageData reader (io/vti.c).
 *
 * Valid files come from VTK's own writer (tests/data/vti/make_vti.py,
 * vtkXMLImageDataWriter of VTK 9.1): ascii, inline base64, appended raw and
 * base64, zlib with several blocks and a partial last one, UInt32/UInt64
 * headers, both byte orders, two arrays with Scalars naming the second.
 * Each must give the exact values, the extent's dims, spacing and the
 * origin of the extent's first node. Malformed variants are made here by
 * editing those files; each must fail with the attribute named and no leak
 * (ASan), and a file that is too short must fail before the volume is
 * allocated.
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "io/volume_formats.h"
#include "test_util.h"
#include "tu_volume.h"

#define NX 7
#define NY 5
#define NZ 3

/* The formulas of make_vti.py. */
static double value_u8(int i, int j, int k) { return (3 * i + 5 * j + 11 * k) % 256; }
static double value_i16(int i, int j, int k) { return 100 * i - 300 * j + 1000 * k; }
static double value_f32(int i, int j, int k) { return 0.25 * i - 1.5 * j + 7.0 * k + 0.125; }
/* beyond float32's exact integers, on its grid there (make_vti.py) */
static double value_u32(int i, int j, int k) { return 4026531840.0 + 256.0 * (i + 7 * j + 35 * k); }
static double value_i64(int i, int j, int k) { return -1099511627776.0 + 131072.0 * (3 * i - 5 * j + 11 * k); }

static const char *fixture(const char *name) {
    static char path[1024];
    snprintf(path, sizeof path, "%s/vti/%s", VOLUX_TEST_DATA, name);
    return path;
}

static char *read_fixture(const char *name, size_t *n) {
    FILE *f = fopen(fixture(name), "rb");
    if (!f) fail_msg("cannot open fixture %s", name);
    fseek(f, 0, SEEK_END);
    long size = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *b = malloc((size_t)size + 1);
    assert_int_equal(fread(b, 1, (size_t)size, f), (size_t)size);
    fclose(f);
    b[size] = 0;
    *n = (size_t)size;
    return b;
}

static void check_volume(const char *name, double (*value)(int, int, int), volux_scalar_type type) {
    volux_context *ctx = tu_context(1);
    volux_volume_load_options o = {0};
    o.use_file_origin = 1;
    volux_volume *v = NULL;
    if (volux_volume_load(ctx, fixture(name), &o, &v) != VOLUX_OK)
        fail_msg("%s: %s", name, volux_context_error(ctx));
    int d[3];
    double s[3];
    volux_volume_dims(v, d);
    volux_volume_spacing(v, s);
    assert_int_equal(d[0], NX);
    assert_int_equal(d[1], NY);
    assert_int_equal(d[2], NZ);
    assert_true(s[0] == 0.5 && s[1] == 1.0 && s[2] == 2.0);
    assert_int_equal(volux_volume_type(v), type);
    /* VTK: node (i, j, k) of extent "2 8 -1 3 0 2" is at Origin + (i, j, k)·Spacing. */
    volux_vec3 org = volux_volume_origin(v);
    assert_true(org.x == 10.0 + 2 * 0.5 && org.y == 20.0 - 1.0 && org.z == 30.0);
    for (int k = 0; k < NZ; k++)
        for (int j = 0; j < NY; j++)
            for (int i = 0; i < NX; i++) {
                float got = volux_volume_value_at(v, i, j, k), want = (float)value(i, j, k);
                if (got != want) fail_msg("%s: value at (%d,%d,%d) = %.9g, expected %.9g", name, i, j, k, got, want);
            }
    volux_volume_release(v);
    volux_context_destroy(ctx);
}

static void test_vtk_written_files(void **state) {
    (void)state;
    static const char *f32[] = {"ascii_f32.vti",     "binary_f32.vti",           "binary_zlib_f32.vti",
                                "appended_f32.vti", "appended_zlib_u64_f32.vti", "appended_b64_zlib_f32.vti"};
    for (size_t i = 0; i < sizeof f32 / sizeof f32[0]; i++) check_volume(f32[i], value_f32, VOLUX_FLOAT32);
    check_volume("big_endian_i16.vti", value_i16, VOLUX_INT16);
    check_volume("ascii_i16.vti", value_i16, VOLUX_INT16);
    check_volume("binary_f64.vti", value_f32, VOLUX_FLOAT64);
    check_volume("two_arrays_u8.vti", value_u8, VOLUX_UINT8); /* Scalars="density", the second array */
    /* the wide integers, stored as float32 */
    check_volume("int32.vti", value_i16, VOLUX_INT32);
    check_volume("ascii_u32.vti", value_u32, VOLUX_UINT32);
    check_volume("appended_zlib_i64.vti", value_i64, VOLUX_INT64);
    check_volume("big_endian_u64.vti", value_u32, VOLUX_UINT64);
}

/* The header parse (volux_volume_probe, used for sequences) reads only up
 * to the array and agrees with the load. */
static void test_probe(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_volume_shape sh;
    assert_int_equal(volux_volume_probe(ctx, fixture("appended_zlib_u64_f32.vti"), NULL, &sh), VOLUX_OK);
    assert_int_equal(sh.dims[0], NX);
    assert_int_equal(sh.dims[2], NZ);
    assert_int_equal(sh.type, VOLUX_FLOAT32);
    assert_true(sh.spacing[2] == 2.0);
    volux_context_destroy(ctx);
}

/* Loading from memory (the fuzz entry) and by content sniffing (no .vti
 * extension) reach the same reader. */
static void test_memory_and_sniffing(void **state) {
    (void)state;
    size_t n;
    char *b = read_fixture("binary_zlib_f32.vti", &n);
    volux_context *ctx = tu_context(1);
    volux_volume *v = NULL;
    assert_int_equal(volux_volume_load_memory(ctx, b, n, "mem.vti", VOLUX_FORMAT_VTI, NULL, &v), VOLUX_OK);
    assert_true(volux_volume_value_at(v, 6, 4, 2) == (float)value_f32(6, 4, 2));
    volux_volume_release(v);
    const char *path = tu_write_file("no_extension.dat", b, n);
    assert_int_equal(volux_volume_load(ctx, path, NULL, &v), VOLUX_OK);
    volux_volume_release(v);
    volux_context_destroy(ctx);
    free(b);
}

/* `b` (n bytes) with the first occurrence of `from` replaced by `to`
 * (malloc'd, *out_n its length). */
static char *replaced(const char *b, size_t n, const char *from, const char *to, size_t *out_n) {
    const char *at = strstr(b, from);
    if (!at) fail_msg("'%s' not found", from);
    size_t lf = strlen(from), lt = strlen(to), pre = (size_t)(at - b);
    char *e = malloc(n - lf + lt + 1);
    memcpy(e, b, pre);
    memcpy(e + pre, to, lt);
    memcpy(e + pre + lt, at + lf, n - pre - lf + 1);
    *out_n = n - lf + lt;
    return e;
}

static char *edited(const char *name, const char *from, const char *to, size_t *n) {
    size_t fn;
    char *b = read_fixture(name, &fn);
    char *e = replaced(b, fn, from, to, n);
    free(b);
    return e;
}

/* Loads `bytes` from a temporary file: must fail with `status`, a message
 * naming `mention`, no leak and (largest_cap > 0) no allocation over it. */
static void expect_load_fails(const char *what, const char *bytes, size_t n, volux_status status, const char *mention,
                              size_t largest_cap) {
    const char *path = tu_write_file("case.vti", bytes, n);
    tu_alloc_stats stats = {0};
    volux_context *ctx = tu_context_counting(1ull << 34, &stats);
    size_t live = stats.live;
    stats.largest = 0;
    volux_volume *v = NULL;
    volux_status st = volux_volume_load(ctx, path, NULL, &v);
    if (st != status || !strstr(volux_context_error(ctx), mention))
        fail_msg("%s: status %d '%s', expected %d mentioning '%s'", what, st, volux_context_error(ctx), status,
                 mention);
    assert_null(v);
    if (stats.live != live) fail_msg("%s: %zd bytes leaked", what, (ssize_t)(stats.live - live));
    if (largest_cap && stats.largest > largest_cap)
        fail_msg("%s: allocated %zu bytes before refusing", what, stats.largest);
    volux_context_destroy(ctx);
}

static void expect_edit_fails(const char *name, const char *from, const char *to, volux_status status,
                              const char *mention) {
    size_t n;
    char *e = edited(name, from, to, &n);
    char what[256];
    snprintf(what, sizeof what, "%s with '%s' -> '%s'", name, from, to);
    expect_load_fails(what, e, n, status, mention, 0);
    free(e);
}

static void test_malformed_attributes(void **state) {
    (void)state;
    expect_edit_fails("binary_f32.vti", "type=\"ImageData\"", "type=\"PolyData\"", VOLUX_ERR_UNSUPPORTED, "VTKFile type");
    expect_edit_fails("binary_f32.vti", "WholeExtent=\"2 8", "WholeExtent=\"9 8", VOLUX_ERR_FORMAT, "WholeExtent");
    expect_edit_fails("binary_f32.vti", "WholeExtent=\"2 8 -1 3 0 2\"", "WholeExtent=\"2 8 -1 3 0\"",
                      VOLUX_ERR_FORMAT, "WholeExtent");
    expect_edit_fails("binary_f32.vti", "WholeExtent=\"2 8", "WholeExtent=\"0 99999", VOLUX_ERR_LIMIT, "WholeExtent");
    expect_edit_fails("binary_f32.vti", "Spacing=\"0.5 1 2\"", "Spacing=\"0.5 -1 2\"", VOLUX_ERR_FORMAT, "spacing");
    expect_edit_fails("binary_f32.vti", "Spacing=\"0.5 1 2\"", "Spacing=\"0.5 nan 2\"", VOLUX_ERR_FORMAT, "Spacing");
    expect_edit_fails("binary_f32.vti", "Direction=\"1 0 0", "Direction=\"0 1 0", VOLUX_ERR_UNSUPPORTED, "Direction");
    expect_edit_fails("binary_f32.vti", "<Piece Extent=\"2 8", "<Piece Extent=\"3 8", VOLUX_ERR_UNSUPPORTED,
                      "Piece Extent");
    expect_edit_fails("binary_f32.vti", "type=\"Float32\"", "type=\"Bit\"", VOLUX_ERR_UNSUPPORTED, "Bit");
    /* a type the data does not fill: Float32 bytes read as Int64 are half the count */
    expect_edit_fails("binary_f32.vti", "type=\"Float32\"", "type=\"Int64\"", VOLUX_ERR_FORMAT, "need");
    expect_edit_fails("binary_f32.vti", "format=\"binary\"", "format=\"hex\"", VOLUX_ERR_FORMAT, "format");
    expect_edit_fails("binary_f32.vti", "Name=\"density\"", "Name=\"density\" NumberOfComponents=\"3\"",
                      VOLUX_ERR_UNSUPPORTED, "NumberOfComponents");
    expect_edit_fails("binary_f32.vti", "Scalars=\"density\"", "Scalars=\"pressure\"", VOLUX_ERR_FORMAT,
                      "'pressure'");
    expect_edit_fails("binary_zlib_f32.vti", "vtkZLibDataCompressor", "vtkLZ4DataCompressor", VOLUX_ERR_UNSUPPORTED,
                      "compressor");
    expect_edit_fails("binary_f32.vti", "header_type=\"UInt32\"", "header_type=\"UInt16\"", VOLUX_ERR_FORMAT,
                      "header_type");
    expect_edit_fails("binary_f32.vti", "<VTKFile", "<!DOCTYPE x [<!ENTITY a \"b\">]><VTKFile", VOLUX_ERR_FORMAT,
                      "DOCTYPE");
    expect_edit_fails("binary_f32.vti", "<VTKFile", "<Other", VOLUX_ERR_FORMAT, "not a VTK XML file");
    expect_edit_fails("binary_f32.vti", "</PointData>", "</PointDota>", VOLUX_ERR_FORMAT, "XML error at line");
}

static void test_malformed_data(void **state) {
    (void)state;
    /* ascii: a value too many, a word, a value outside the type, one short */
    expect_edit_fails("ascii_f32.vti", "</DataArray>", " 1.5 </DataArray>", VOLUX_ERR_FORMAT, "more than");
    expect_edit_fails("ascii_f32.vti", "0.125", "zero", VOLUX_ERR_FORMAT, "'zero' is not a number");
    expect_edit_fails("ascii_i16.vti", "-300", "-40000", VOLUX_ERR_FORMAT, "does not fit");
    expect_edit_fails("ascii_u32.vti", "4026531840 ", "4294967296 ", VOLUX_ERR_FORMAT, "does not fit type uint32");
    expect_edit_fails("ascii_u32.vti", "4026531840 ", "-1 ", VOLUX_ERR_FORMAT, "does not fit type uint32");
    expect_edit_fails("ascii_u32.vti", "4026531840 ", "2.5 ", VOLUX_ERR_FORMAT, "does not fit type uint32");
    expect_edit_fails("ascii_f32.vti", "0.125", "", VOLUX_ERR_FORMAT, "104 values");
    /* NaN follows the volume policy of every reader (issue 16) */
    expect_edit_fails("ascii_f32.vti", "0.125", "nan", VOLUX_ERR_FORMAT, "non-finite");
    /* base64: a bad character; text cut short (the last 8 characters) */
    expect_edit_fails("binary_f32.vti", "\n        ", "\n        *", VOLUX_ERR_FORMAT, "base64");
    size_t n;
    char *b = read_fixture("binary_f32.vti", &n);
    char *end = strstr(b, "</DataArray>");
    while (end[-1] == ' ' || end[-1] == '\n') end--;
    memmove(end - 8, end, n - (size_t)(end - b) + 1);
    expect_load_fails("binary_f32.vti cut short", b, n - 8, VOLUX_ERR_FORMAT, "truncated", 0);
    free(b);
}

/* Edits at byte level: the first byte of the data header (the byte count,
 * or the block count when compressed), a corrupt zlib block, a truncated
 * appended section. */
static void expect_bytes_fail(const char *name, long at_from_marker, int value, volux_status status,
                              const char *mention) {
    size_t n;
    char *b = read_fixture(name, &n);
    char *u = strstr(b, "_");
    while (u && u[-1] != '\n' && u[-1] != ' ') u = strstr(u + 1, "_"); /* not header_type's */
    assert_non_null(u);
    size_t off = (size_t)(u + 1 - b) + (size_t)at_from_marker;
    assert_true(off < n);
    if (value < 0) n = off; /* cut the file there */
    else b[off] = (char)value;
    char what[256];
    snprintf(what, sizeof what, "%s byte %ld = %d", name, at_from_marker, value);
    expect_load_fails(what, b, n, status, mention, 0);
    free(b);
}

static void test_malformed_binary(void **state) {
    (void)state;
    /* uncompressed: byte count 420 (0x1a4) → 0x1ff */
    expect_bytes_fail("appended_f32.vti", 0, 0xff, VOLUX_ERR_FORMAT, "data header gives");
    /* compressed: block count changed */
    expect_bytes_fail("appended_zlib_u64_f32.vti", 0, 0x09, VOLUX_ERR_FORMAT, "compression header");
    /* a byte inside the first zlib block (after 3 + 5 UInt64 header words) */
    expect_bytes_fail("appended_zlib_u64_f32.vti", 8 * 8 + 6, 0x00, VOLUX_ERR_FORMAT, "block 0");
    /* truncated */
    expect_bytes_fail("appended_f32.vti", 100, -1, VOLUX_ERR_FORMAT, "truncated");
    expect_bytes_fail("appended_zlib_u64_f32.vti", 100, -1, VOLUX_ERR_FORMAT, "truncated");
}

/* A header that claims a big volume in a small file is refused before the
 * volume is allocated. */
static void test_no_big_allocation(void **state) {
    (void)state;
    static const char *names[] = {"binary_f32.vti", "binary_zlib_f32.vti", "ascii_f32.vti", "appended_f32.vti"};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++) {
        /* extent x 2..16000, z 0..2000: 15999·5·2001 floats = 640 MB, more
         * than the ~1 KB file (or 1032× it, compressed) can hold */
        size_t n1, n2;
        char *e1 = edited(names[i], "WholeExtent=\"2 8 -1 3 0 2\"", "WholeExtent=\"2 16000 -1 3 0 2000\"", &n1);
        char *e2 = replaced(e1, n1, "<Piece Extent=\"2 8 -1 3 0 2\"", "<Piece Extent=\"2 16000 -1 3 0 2000\"", &n2);
        expect_load_fails(names[i], e2, n2, VOLUX_ERR_FORMAT, "cannot hold", 1u << 20);
        free(e1);
        free(e2);
    }
}

/* An allocation failure anywhere while loading is a clean error. */
static void test_out_of_memory(void **state) {
    (void)state;
    static const char *names[] = {"ascii_f32.vti", "binary_zlib_f32.vti", "appended_b64_zlib_f32.vti"};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++)
        for (long k = 1;; k++) {
            tu_alloc_stats stats = {0};
            volux_context *ctx = tu_context_counting(1ull << 30, &stats);
            size_t live = stats.live;
            stats.fail_at = stats.count + k;
            volux_volume *v = NULL;
            volux_status st = volux_volume_load(ctx, fixture(names[i]), NULL, &v);
            stats.fail_at = 0;
            if (st == VOLUX_OK) { /* fewer allocations than k: all were tried */
                assert_true(k > 2);
                volux_volume_release(v);
                volux_context_destroy(ctx);
                break;
            }
            if (st != VOLUX_ERR_NOMEM) fail_msg("%s, allocation %ld failing: %s", names[i], k, volux_context_error(ctx));
            assert_int_equal(stats.live, live);
            volux_context_destroy(ctx);
        }
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_vtk_written_files), cmocka_unit_test(test_probe),
        cmocka_unit_test(test_memory_and_sniffing), cmocka_unit_test(test_malformed_attributes),
        cmocka_unit_test(test_malformed_data),     cmocka_unit_test(test_malformed_binary),
        cmocka_unit_test(test_no_big_allocation),  cmocka_unit_test(test_out_of_memory),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
