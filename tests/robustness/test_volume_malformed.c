/*
 * tests/robustness/test_volume_malformed.c — malformed and hostile volume
 * files: each must fail with the right status and a message naming the
 * file and the problem, without allocating what the header claims and
 * without leaking.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "io/volume_formats.h"
#include "tu_volume.h"

/* Loads `path`, expects `status`, a message naming the file's basename and
 * `what`; no volume, nothing left allocated afterwards. */
static void expect_failure(const char *path, const volux_volume_load_options *o, volux_status status,
                           const char *what) {
    tu_alloc_stats stats = {0};
    volux_context *ctx = tu_context_counting(64u << 20, &stats);
    size_t baseline = stats.live;
    volux_volume *v = NULL;
    volux_status st = volux_volume_load(ctx, path, o, &v);
    if (st != status)
        fail_msg("%s: expected status %s, got %s (%s)", path, volux_status_name(status), volux_status_name(st),
                 volux_context_error(ctx));
    assert_null(v);
    const char *base = strrchr(path, '/');
    tu_assert_error_mentions(ctx, base ? base + 1 : path, what, (const char *)NULL);
    assert_int_equal(stats.live, baseline);
    volux_context_destroy(ctx);
}

/* An attached NRRD with `header` (which must end in a blank line for
 * attached data) followed by `n` data bytes. */
static const char *nrrd_file(const char *name, const char *header, size_t n) {
    unsigned char *data = calloc(n + 1, 1);
    const char *path = tu_write_parts(name, header, data, n);
    free(data);
    return path;
}

#define HEAD "NRRD0004\ntype: uint8\ndimension: 3\n"

static void test_nrrd_bad_fields(void **state) {
    (void)state;
    static const struct {
        const char *header;
        size_t data;
        volux_status status;
        const char *what;
    } cases[] = {
        {"", 0, VOLUX_ERR_FORMAT, "not a NRRD"},
        {"NRRD9\n\n", 0, VOLUX_ERR_FORMAT, "not a NRRD"},
        {"P5 2 2\n\n", 0, VOLUX_ERR_FORMAT, "not a NRRD"},
        {"NRRD0004\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n\n", 8, VOLUX_ERR_FORMAT, "'type'"},
        {HEAD "encoding: raw\n\n", 8, VOLUX_ERR_FORMAT, "'sizes'"},
        {HEAD "sizes: 2 2 2\n\n", 8, VOLUX_ERR_FORMAT, "'encoding'"},
        {HEAD "sizes: 2 2 2\nencoding: raw\nfrobnicate: 3\n\n", 8, VOLUX_ERR_FORMAT, "unknown field 'frobnicate'"},
        {HEAD "sizes: 2 2 2\nencoding: raw\nno colon here\n\n", 8, VOLUX_ERR_FORMAT, "line 6"},
        {HEAD "sizes: 2 2 2\nencoding: raw\nsizes: 2 2 2\n\n", 8, VOLUX_ERR_FORMAT, "given twice"},
        {"NRRD0004\ntype: complex\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n\n", 8, VOLUX_ERR_FORMAT,
         "unknown type 'complex'"},
        {"NRRD0004\ntype: block\nblock size: 4\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n\n", 32,
         VOLUX_ERR_UNSUPPORTED, "type: 'block'"},
        {HEAD "sizes: 2 2 2\nencoding: bzip2\n\n", 8, VOLUX_ERR_UNSUPPORTED, "encoding: 'bzip2'"},
        {HEAD "sizes: 2 2 2\nencoding: zip\n\n", 8, VOLUX_ERR_FORMAT, "encoding"},
        {"NRRD0004\ntype: uint8\ndimension: 2\nsizes: 2 2\nencoding: raw\n\n", 4, VOLUX_ERR_UNSUPPORTED, "2-D"},
        {"NRRD0004\ntype: uint8\ndimension: 4\nsizes: 3 2 2 2\nencoding: raw\n\n", 24, VOLUX_ERR_UNSUPPORTED, "4-D"},
        {"NRRD0004\ntype: uint8\ndimension: 99\nsizes: 2 2 2\nencoding: raw\n\n", 8, VOLUX_ERR_FORMAT, "dimension"},
        {HEAD "sizes: 2 2\nencoding: raw\n\n", 8, VOLUX_ERR_FORMAT, "sizes: expected 3 values, got 2"},
        {HEAD "sizes: 2 2 2 2\nencoding: raw\n\n", 8, VOLUX_ERR_FORMAT, "sizes: expected 3 values"},
        {HEAD "sizes: 2 0 2\nencoding: raw\n\n", 8, VOLUX_ERR_FORMAT, "sizes: expected a positive integer, got '0'"},
        {HEAD "sizes: 2 -3 2\nencoding: raw\n\n", 8, VOLUX_ERR_FORMAT, "got '-3'"},
        {HEAD "sizes: 2 2x 2\nencoding: raw\n\n", 8, VOLUX_ERR_FORMAT, "got '2x'"},
        {HEAD "sizes: 4294967296 2 2\nencoding: raw\n\n", 8, VOLUX_ERR_LIMIT, "size 4294967296"},
        {HEAD "sizes: 2 99999999999999999999999999 2\nencoding: raw\n\n", 8, VOLUX_ERR_LIMIT, "over the limit"},
        {HEAD "sizes: 16384 16384 16384\nencoding: raw\n\n", 8, VOLUX_ERR_LIMIT, "voxels"},
        {HEAD "sizes: 16385 1 1\nencoding: raw\n\n", 8, VOLUX_ERR_LIMIT, "16385"},
        {"NRRD0004\ntype: short\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n\n", 16, VOLUX_ERR_FORMAT,
         "endian: missing"},
        {"NRRD0004\ntype: short\ndimension: 3\nsizes: 2 2 2\nendian: middle\nencoding: raw\n\n", 16, VOLUX_ERR_FORMAT,
         "endian"},
        {HEAD "sizes: 2 2 2\nencoding: raw\nbyte skip: -5\n\n", 8, VOLUX_ERR_FORMAT, "byte skip: negative value -5"},
        {HEAD "sizes: 2 2 2\nencoding: gzip\nbyte skip: -1\n\n", 8, VOLUX_ERR_FORMAT, "byte skip: -1"},
        {HEAD "sizes: 2 2 2\nencoding: raw\nbyte skip: lots\n\n", 8, VOLUX_ERR_FORMAT, "byte skip"},
        {HEAD "sizes: 2 2 2\nencoding: raw\nbyte skip: 100\n\n", 8, VOLUX_ERR_FORMAT, "byte skip: 100"},
        {HEAD "sizes: 2 2 2\nencoding: raw\nline skip: -1\n\n", 8, VOLUX_ERR_FORMAT, "line skip"},
        {HEAD "sizes: 2 2 2\nencoding: raw\nline skip: 1000\n\n", 8, VOLUX_ERR_FORMAT, "line skip: 1000"},
        {HEAD "sizes: 2 2 2\nencoding: raw\nspacings: 1 0 1\n\n", 8, VOLUX_ERR_FORMAT, "spacings"},
        {HEAD "sizes: 2 2 2\nencoding: raw\nspacings: 1 1\n\n", 8, VOLUX_ERR_FORMAT, "spacings"},
        {HEAD "sizes: 2 2 2\nencoding: raw\nspacings: 1 inf 1\n\n", 8, VOLUX_ERR_FORMAT, "spacings"},
        {HEAD "sizes: 2 2 2\nencoding: raw\nspacings: 1 1 1\nspace directions: (1,0,0) (0,1,0) (0,0,1)\n\n", 8,
         VOLUX_ERR_FORMAT, "together"},
        {HEAD "sizes: 2 2 2\nencoding: raw\nspace directions: (1,0,0) (0,1) (0,0,1)\n\n", 8, VOLUX_ERR_FORMAT,
         "different lengths"},
        {HEAD "sizes: 2 2 2\nencoding: raw\nspace directions: (1,0,0) none (0,0,1)\n\n", 8, VOLUX_ERR_FORMAT,
         "'none'"},
        {HEAD "sizes: 2 2 2\nencoding: raw\nspace directions: (1,0,0) (0,0,0) (0,0,1)\n\n", 8, VOLUX_ERR_FORMAT,
         "zero"},
        {HEAD "sizes: 2 2 2\nencoding: raw\nspace directions: (1,0,0 (0,1,0) (0,0,1)\n\n", 8, VOLUX_ERR_FORMAT,
         "space directions"},
        {HEAD "sizes: 2 2 2\nencoding: raw\nspace origin: (1,2)\n\n", 8, VOLUX_ERR_FORMAT, "space origin"},
        {HEAD "sizes: 2 2 2\nencoding: raw\nspace origin: (1,nan,2)\n\n", 8, VOLUX_ERR_FORMAT, "space origin"},
        {HEAD "sizes: 2 2 2\nencoding: raw\n", 0, VOLUX_ERR_FORMAT, "no data"},
        /* axes that do not span space (issue 16) */
        {HEAD "sizes: 2 2 2\nencoding: raw\nspace dimension: 3\nspace directions: (1,0,0) (2,0,0) (0,0,1)\n\n", 8,
         VOLUX_ERR_FORMAT, "space directions: the vectors of axes 0, 1, 2 are parallel"},
        {HEAD "sizes: 2 2 2\nencoding: raw\nspace dimension: 3\nspace directions: (1,0,0) (0,1,0) (1,1,0)\n\n", 8,
         VOLUX_ERR_FORMAT, "coplanar"},
        {HEAD "sizes: 2 2 2\nencoding: raw\nspace dimension: 3\nspace directions: (1,0,0) (0,0,0) (0,0,1)\n\n", 8,
         VOLUX_ERR_FORMAT, "zero"},
        /* data size vs. header */
        {HEAD "sizes: 2 2 2\nencoding: raw\n\n", 7, VOLUX_ERR_FORMAT, "truncated"},
        /* (raw data followed by more bytes loads with a warning: test_volume_policies.c) */
        {HEAD "sizes: 2 2 2\nencoding: gzip\n\n", 0, VOLUX_ERR_FORMAT, "compressed data is missing"},
        {HEAD "sizes: 2 2 2\nencoding: gzip\n\n", 20, VOLUX_ERR_FORMAT, "corrupt compressed data"},
        /* detached data file names */
        {HEAD "sizes: 2 2 2\nencoding: raw\ndata file: ../secret.raw\n", 0, VOLUX_ERR_FORMAT, "outside"},
        {HEAD "sizes: 2 2 2\nencoding: raw\ndata file: a/../../secret.raw\n", 0, VOLUX_ERR_FORMAT, "outside"},
        {HEAD "sizes: 2 2 2\nencoding: raw\ndata file: /etc/passwd\n", 0, VOLUX_ERR_FORMAT, "absolute path"},
        /* split data (read by test_volume_policies.c): missing files name their number */
        {HEAD "sizes: 2 2 2\nencoding: raw\ndata file: LIST\nnone-a.raw\nnone-b.raw\n", 0, VOLUX_ERR_IO,
         "data file 1 of 2"},
        {HEAD "sizes: 2 2 2\nencoding: raw\ndata file: none%03d.raw 1 2 1\n", 0, VOLUX_ERR_IO, "data file 1 of 2"},
        {HEAD "sizes: 2 2 2\nencoding: raw\ndata file: nothere.raw\n", 0, VOLUX_ERR_IO, "nothere.raw"},
        {HEAD "sizes: 2 2 2\nencoding: raw\ndata file:\n", 0, VOLUX_ERR_FORMAT, "empty file name"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char name[32];
        snprintf(name, sizeof name, "bad%02zu.nrrd", i);
        const char *path = nrrd_file(name, cases[i].header, cases[i].data);
        print_message("case %zu: %s\n", i, cases[i].what);
        expect_failure(path, NULL, cases[i].status, cases[i].what);
    }
}

static void test_nrrd_nul_byte_and_long_name(void **state) {
    (void)state;
    const char nul[] = HEAD "sizes: 2\0 2 2\nencoding: raw\n\n";
    expect_failure(tu_write_file("nul.nrrd", nul, sizeof nul - 1), NULL, VOLUX_ERR_FORMAT, "NUL");

    /* Teem 1.12 aborts on a long detached file name (DESIGN §5). */
    size_t n = 5000;
    char *h = malloc(n + 200);
    int t = snprintf(h, 200, HEAD "sizes: 2 2 2\nencoding: raw\ndata file: ");
    memset(h + t, 'a', n);
    strcpy(h + t + n, "\n");
    expect_failure(tu_write_parts("long.nhdr", h, NULL, 0), NULL, VOLUX_ERR_LIMIT, "file name of 5000 characters");
    free(h);
}

/* A header over the memory cap fails before any allocation of its size. */
static void test_memory_cap_checked_before_allocating(void **state) {
    (void)state;
    tu_alloc_stats stats = {0};
    volux_context *ctx = tu_context_counting(1u << 20, &stats); /* 1 MiB cap */
    const char *path = nrrd_file("cap.nrrd", HEAD "sizes: 256 256 256\nencoding: raw\n\n", 16);
    volux_volume *v = NULL;
    assert_int_equal(volux_volume_load(ctx, path, NULL, &v), VOLUX_ERR_LIMIT);
    tu_assert_error_mentions(ctx, "cap.nrrd", "16777216 bytes", "memory cap of 1048576", (const char *)NULL);
    assert_true(stats.largest < 64 * 1024);
    assert_true(volux_context_bytes_in_use(ctx) == 0);

    /* Same for compressed data: the cap is checked before inflating. */
    path = nrrd_file("capgz.nrrd", HEAD "sizes: 1024 1024 2\nencoding: gzip\n\n", 16);
    assert_int_equal(volux_volume_load(ctx, path, NULL, &v), VOLUX_ERR_LIMIT);
    assert_true(stats.largest < 64 * 1024);

    /* And for the procedural volumes. */
    int dims[3] = {512, 512, 512};
    assert_int_equal(volux_volume_procedural(ctx, "sphere", dims, 1, &v), VOLUX_ERR_LIMIT);
    assert_true(stats.largest < 64 * 1024);
    volux_context_destroy(ctx);
}

/* 64 MiB of zeros compress to ~64 KiB; the header says 2x2x2. */
static void test_gzip_bomb_stops_at_the_expected_size(void **state) {
    (void)state;
    size_t big = 64u << 20, zn;
    unsigned char *zeros = calloc(big, 1);
    unsigned char *z = tu_deflate(zeros, big, 1, &zn);
    free(zeros);
    const char *path = tu_write_parts("bomb.nrrd", HEAD "sizes: 2 2 2\nencoding: gzip\n\n", z, zn);
    tu_alloc_stats stats = {0};
    volux_context *ctx = tu_context_counting(0, &stats);
    volux_volume *v = NULL;
    assert_int_equal(volux_volume_load(ctx, path, NULL, &v), VOLUX_ERR_FORMAT);
    tu_assert_error_mentions(ctx, "bomb.nrrd", "size mismatch", "more than the 8 bytes", (const char *)NULL);
    assert_true(stats.largest < (1u << 20));
    volux_context_destroy(ctx);

    /* Truncated stream: the first half of a valid one. */
    unsigned char data[4096];
    for (size_t i = 0; i < sizeof data; i++) data[i] = (unsigned char)(i * 7);
    free(z);
    z = tu_deflate(data, sizeof data, 1, &zn);
    path = tu_write_parts("half.nrrd", HEAD "sizes: 16 16 16\nencoding: gzip\n\n", z, zn / 2);
    expect_failure(path, NULL, VOLUX_ERR_FORMAT, "truncated");
    /* A tiny stream cannot inflate to a big volume (deflate's ratio is at
     * most 1032:1): refused before the volume is allocated. */
    path = tu_write_parts("thin.nrrd", HEAD "sizes: 256 256 256\nencoding: gzip\n\n", z, zn);
    tu_alloc_stats thin = {0};
    ctx = tu_context_counting(0, &thin);
    assert_int_equal(volux_volume_load(ctx, path, NULL, &v), VOLUX_ERR_FORMAT);
    tu_assert_error_mentions(ctx, "thin.nrrd", "cannot hold", (const char *)NULL);
    assert_true(thin.largest < (1u << 20));
    volux_context_destroy(ctx);
    /* A complete stream that is too short for the sizes. */
    path = tu_write_parts("short.nrrd", HEAD "sizes: 16 16 17\nencoding: gzip\n\n", z, zn);
    expect_failure(path, NULL, VOLUX_ERR_FORMAT, "got 4096 of the 4352 bytes");
    free(z);
}

static void test_metaimage_bad_fields(void **state) {
    (void)state;
#define MI "NDims = 3\nDimSize = 2 2 2\n"
    static const struct {
        const char *header;
        size_t data;
        volux_status status;
        const char *what;
    } cases[] = {
        {MI "ElementType = MET_UCHAR\n", 0, VOLUX_ERR_FORMAT, "'ElementDataFile'"},
        {"DimSize = 2 2 2\nElementType = MET_UCHAR\nElementDataFile = LOCAL\n", 8, VOLUX_ERR_FORMAT, "'NDims'"},
        {MI "ElementDataFile = LOCAL\n", 8, VOLUX_ERR_FORMAT, "'ElementType'"},
        {MI "ElementType = MET_STRING\nElementDataFile = LOCAL\n", 32, VOLUX_ERR_UNSUPPORTED, "MET_STRING"},
        {MI "ElementType = MET_FOO\nElementDataFile = LOCAL\n", 8, VOLUX_ERR_FORMAT, "unknown type 'MET_FOO'"},
        {"NDims = 2\nDimSize = 2 2\nElementType = MET_UCHAR\nElementDataFile = LOCAL\n", 4, VOLUX_ERR_UNSUPPORTED,
         "2-D"},
        {"NDims = 3\nDimSize = 2 2\nElementType = MET_UCHAR\nElementDataFile = LOCAL\n", 8, VOLUX_ERR_FORMAT,
         "DimSize: expected 3 values, got 2"},
        {"NDims = 3\nDimSize = 2 2 4294967297\nElementType = MET_UCHAR\nElementDataFile = LOCAL\n", 8,
         VOLUX_ERR_LIMIT, "DimSize"},
        {MI "ElementType = MET_UCHAR\nElementNumberOfChannels = 3\nElementDataFile = LOCAL\n", 24,
         VOLUX_ERR_UNSUPPORTED, "channels"},
        {MI "ElementType = MET_UCHAR\nBinaryData = False\nElementDataFile = LOCAL\n", 8, VOLUX_ERR_UNSUPPORTED,
         "ASCII"},
        {MI "ElementType = MET_UCHAR\nObjectType = Mesh\nElementDataFile = LOCAL\n", 8, VOLUX_ERR_UNSUPPORTED,
         "Mesh"},
        {MI "ElementType = MET_UCHAR\nHeaderSize = -2\nElementDataFile = x.raw\n", 0, VOLUX_ERR_FORMAT, "HeaderSize"},
        {MI "ElementType = MET_UCHAR\nCompressedData = True\nHeaderSize = -1\nElementDataFile = x.raw\n", 0,
         VOLUX_ERR_FORMAT, "HeaderSize: -1"},
        {MI "ElementType = MET_UCHAR\nCompressedData = Maybe\nElementDataFile = LOCAL\n", 8, VOLUX_ERR_FORMAT,
         "CompressedData"},
        {MI "ElementType = MET_UCHAR\nElementSpacing = 1 0 1\nElementDataFile = LOCAL\n", 8, VOLUX_ERR_FORMAT,
         "ElementSpacing"},
        {MI "ElementType = MET_UCHAR\nOffset = 1 2\nElementDataFile = LOCAL\n", 8, VOLUX_ERR_FORMAT, "Offset"},
        {MI "ElementType = MET_UCHAR\nElementDataFile = LOCAL\n", 5, VOLUX_ERR_FORMAT, "truncated"},
        {MI "ElementType = MET_UCHAR\nCompressedData = True\nElementDataFile = LOCAL\n", 30, VOLUX_ERR_FORMAT,
         "corrupt"},
        {MI "ElementType = MET_UCHAR\nElementDataFile = ../x.raw\n", 0, VOLUX_ERR_FORMAT, "outside"},
        {MI "ElementType = MET_UCHAR\nElementDataFile = LIST\n", 0, VOLUX_ERR_UNSUPPORTED, "LIST"},
        {MI "ElementType = MET_UCHAR\nElementDataFile = s%02d.raw 1 2 1\n", 0, VOLUX_ERR_UNSUPPORTED, "multiple"},
        {MI "ElementType = MET_UCHAR\nElementType = MET_UCHAR\nElementDataFile = LOCAL\n", 8, VOLUX_ERR_FORMAT,
         "twice"},
        {MI "ElementType = MET_UCHAR\njunk line\nElementDataFile = LOCAL\n", 8, VOLUX_ERR_FORMAT, "line 4"},
        /* issue 16: a singular direction matrix, compressed sizes that cannot be */
        {MI "ElementType = MET_UCHAR\nTransformMatrix = 0 0 0 0 0 0 0 0 0\nElementDataFile = LOCAL\n", 8,
         VOLUX_ERR_FORMAT, "TransformMatrix: singular"},
        {MI "ElementType = MET_UCHAR\nTransformMatrix = 1 0 0 1 0 0 0 0 1\nElementDataFile = LOCAL\n", 8,
         VOLUX_ERR_FORMAT, "TransformMatrix: singular"},
        {MI "ElementType = MET_UCHAR\nTransformMatrix = 1 0 0 0 1 0 0 0 nan\nElementDataFile = LOCAL\n", 8,
         VOLUX_ERR_FORMAT, "TransformMatrix"},
        {MI "ElementType = MET_UCHAR\nTransformMatrix = 1 0 0 0 1 0\nElementDataFile = LOCAL\n", 8,
         VOLUX_ERR_FORMAT, "TransformMatrix"},
        {MI "ElementType = MET_UCHAR\nCompressedData = True\nCompressedDataSize = -5\nElementDataFile = LOCAL\n", 30,
         VOLUX_ERR_FORMAT, "CompressedDataSize: expected a positive integer, got '-5'"},
        {MI "ElementType = MET_UCHAR\nCompressedData = True\nCompressedDataSize = 100000\nElementDataFile = LOCAL\n",
         30, VOLUX_ERR_FORMAT, "CompressedDataSize: 100000 bytes declared, but only 30"},
        {MI "ElementType = MET_UCHAR\nCompressedDataSize = 8\nElementDataFile = LOCAL\n", 8, VOLUX_ERR_FORMAT,
         "CompressedData is not True"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char name[32];
        snprintf(name, sizeof name, "bad%02zu.mha", i);
        print_message("case %zu: %s\n", i, cases[i].what);
        expect_failure(nrrd_file(name, cases[i].header, cases[i].data), NULL, cases[i].status, cases[i].what);
    }
#undef MI
}

static void test_nifti_bad_fields(void **state) {
    (void)state;
    static const int dims[3] = {2, 2, 2};
    unsigned char h[352 + 64];
    struct {
        size_t off;
        int kind; /* 0: i16, 1: i32, 2: f32, 3: magic */
        double value;
        volux_status status;
        const char *what;
    } cases[] = {
        {0, 1, 349, VOLUX_ERR_FORMAT, "sizeof_hdr"},
        {0, 1, 540, VOLUX_ERR_FORMAT, "shorter than the 540-byte NIfTI-2 header"}, /* 360 bytes */
        {344, 3, 0, VOLUX_ERR_UNSUPPORTED, "Analyze"},
        {40, 0, 2, VOLUX_ERR_UNSUPPORTED, "2-D"},
        {40, 0, 9, VOLUX_ERR_FORMAT, "dim[0]"},
        {40, 0, 4, VOLUX_ERR_UNSUPPORTED, "time points"}, /* dim[4] set to 3 below */
        {44, 0, 0, VOLUX_ERR_FORMAT, "dim[2]"},
        {44, 0, -5, VOLUX_ERR_FORMAT, "dim[2]"},
        {44, 0, 20000, VOLUX_ERR_LIMIT, "dim[2]"},
        {70, 0, 32, VOLUX_ERR_UNSUPPORTED, "datatype: code 32"}, /* complex64 */
        {70, 0, 3, VOLUX_ERR_FORMAT, "datatype: unknown code 3"},
        {72, 0, 16, VOLUX_ERR_FORMAT, "bitpix"},
        {80, 2, INFINITY, VOLUX_ERR_FORMAT, "pixdim[1]"},
        {108, 2, 100, VOLUX_ERR_FORMAT, "vox_offset"},
        {108, 2, 352.5, VOLUX_ERR_FORMAT, "vox_offset"},
        {108, 2, -1, VOLUX_ERR_FORMAT, "vox_offset"},
        {108, 2, 4000, VOLUX_ERR_FORMAT, "past the end"},
        {108, 2, 340, VOLUX_ERR_FORMAT, "vox_offset"},
        /* issue 16: zero pixdim without an sform, infinite scaling */
        {84, 2, 0, VOLUX_ERR_FORMAT, "pixdim[2]: zero, and no sform"},
        {112, 2, INFINITY, VOLUX_ERR_FORMAT, "scl_slope: infinite"},
        {116, 4, INFINITY, VOLUX_ERR_FORMAT, "scl_inter: infinite"}, /* with scl_slope 2 */
        {116, 4, -INFINITY, VOLUX_ERR_FORMAT, "scl_inter: infinite"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++)
        for (int big = 0; big < 2; big++) {
            tu_nifti_header(h, big, dims, 2, 8);
            memset(h + 352, 1, 8);
            switch (cases[i].kind) {
            case 0: tu_put_i16(h, cases[i].off, (int)cases[i].value, big); break;
            case 1: tu_put_i32(h, cases[i].off, (long)cases[i].value, big); break;
            case 2: tu_put_f32(h, cases[i].off, (float)cases[i].value, big); break;
            case 3: memcpy(h + cases[i].off, "\0\0\0\0", 4); break;
            case 4:
                tu_put_f32(h, 112, 2.0f, big);
                tu_put_f32(h, cases[i].off, (float)cases[i].value, big);
                break;
            }
            if (cases[i].kind == 0 && cases[i].off == 40 && cases[i].value == 4) tu_put_i16(h, 48, 3, big);
            char name[32];
            snprintf(name, sizeof name, "bad%02zu_%d.nii", i, big);
            print_message("case %zu (%s): %s\n", i, big ? "big" : "little", cases[i].what);
            expect_failure(tu_write_file(name, h, 352 + 8), NULL, cases[i].status, cases[i].what);
        }
    /* A zero pixdim with an sform takes the voxel size from the sform's
     * column (srow_y[1] = 2.5 here). */
    tu_nifti_header(h, 0, dims, 2, 8);
    memset(h + 352, 1, 8);
    tu_put_f32(h, 84, 0.0f, 0);
    tu_put_i16(h, 254, 1, 0);
    tu_put_f32(h, 300, 2.5f, 0);
    {
        volux_context *ctx = tu_context(1);
        volux_volume *v = NULL;
        assert_int_equal(volux_volume_load(ctx, tu_write_file("sform.nii", h, 352 + 8), NULL, &v), VOLUX_OK);
        double sp[3];
        volux_volume_spacing(v, sp);
        assert_true(sp[0] == 1.0 && sp[1] == 2.5 && sp[2] == 1.0);
        volux_volume_release(v);
        volux_context_destroy(ctx);
    }
    /* too short, truncated data, trailing bytes, truncated .nii.gz */
    tu_nifti_header(h, 0, dims, 2, 8);
    expect_failure(tu_write_file("short.nii", h, 200), NULL, VOLUX_ERR_FORMAT, "shorter than the 348-byte");
    expect_failure(tu_write_file("trunc.nii", h, 352 + 7), NULL, VOLUX_ERR_FORMAT, "truncated");
    expect_failure(tu_write_file("long.nii", h, 352 + 9), NULL, VOLUX_ERR_FORMAT, "size mismatch");
    size_t zn;
    unsigned char *z = tu_deflate(h, 352 + 8, 1, &zn);
    expect_failure(tu_write_file("trunc.nii.gz", z, zn - 12), NULL, VOLUX_ERR_FORMAT, "truncated");
    expect_failure(tu_write_file("tiny.nii.gz", z, 12), NULL, VOLUX_ERR_FORMAT, "truncated");
    free(z);
    /* A pair whose .img is missing names the data file. */
    memcpy(h + 344, "ni1", 4);
    tu_put_f32(h, 108, 0.0f, 0);
    expect_failure(tu_write_file("lonely.hdr", h, 348), NULL, VOLUX_ERR_IO, "lonely.img");
}

static void test_raw_and_dispatch_errors(void **state) {
    (void)state;
    unsigned char data[8] = {0};
    const char *path = tu_write_file("d.raw", data, sizeof data);
    expect_failure(path, NULL, VOLUX_ERR_INVALID, "description");
    volux_raw_desc d = {{2, 2, 3}, VOLUX_UINT8, 0, {0, 0, 0}, 0};
    volux_volume_load_options o = {0};
    o.raw = &d;
    expect_failure(path, &o, VOLUX_ERR_FORMAT, "truncated");
    d.dims[2] = 1;
    expect_failure(path, &o, VOLUX_ERR_FORMAT, "size mismatch");
    d.dims[2] = 0;
    expect_failure(path, &o, VOLUX_ERR_INVALID, "raw dims");
    d.dims[2] = 2;
    d.byte_skip = 9;
    expect_failure(path, &o, VOLUX_ERR_FORMAT, "byte skip: 9");
    d.byte_skip = 0;
    d.type = (volux_scalar_type)42;
    expect_failure(path, &o, VOLUX_ERR_INVALID, "raw type");

    expect_failure(tu_temp_path("missing.nrrd"), NULL, VOLUX_ERR_IO, "missing.nrrd");
    expect_failure(tu_write_file("what.xyz", "hello world", 11), NULL, VOLUX_ERR_UNSUPPORTED, "unknown volume format");
    /* a folder is read as a DICOM series: one without DICOM images is a
     * format error naming it (without DICOM support: unsupported) */
    {
        volux_context *ctx = tu_context(1);
        volux_volume *v = NULL;
        volux_status st = volux_volume_load(ctx, tu_temp_path(""), NULL, &v);
        assert_true(st == VOLUX_ERR_FORMAT || st == VOLUX_ERR_UNSUPPORTED);
        assert_null(v);
        tu_assert_error_mentions(ctx, "volux-test", (const char *)NULL);
        volux_context_destroy(ctx);
    }
}

/* Every allocation failure inside a gzip load is reported as NOMEM and
 * leaves nothing allocated. */
static void test_allocation_failures_do_not_leak(void **state) {
    (void)state;
    unsigned char data[512];
    for (size_t i = 0; i < sizeof data; i++) data[i] = (unsigned char)i;
    size_t zn;
    unsigned char *z = tu_deflate(data, sizeof data, 1, &zn);
    const char *path = tu_write_parts("oom.nrrd", HEAD "sizes: 8 8 8\nencoding: gzip\n\n", z, zn);
    free(z);
    int saw_ok = 0;
    for (long k = 1; k < 40 && !saw_ok; k++) {
        tu_alloc_stats stats = {0};
        volux_context *ctx = tu_context_counting(0, &stats);
        stats.count = 0; /* count the loader's allocations, not the context's own */
        stats.fail_at = k;
        volux_volume *v = NULL;
        volux_status st = volux_volume_load(ctx, path, NULL, &v);
        if (st == VOLUX_OK) {
            saw_ok = 1;
            volux_volume_release(v);
        } else {
            assert_int_equal(st, VOLUX_ERR_NOMEM);
            assert_non_null(strstr(volux_context_error(ctx), "oom.nrrd"));
        }
        assert_int_equal(volux_context_bytes_in_use(ctx), 0);
        volux_context_destroy(ctx);
        assert_int_equal(stats.live, 0);
    }
    assert_true(saw_ok);
}

/* A NIfTI-2 file (nifti2.h layout) of 3×2×2 int16 values i − 5 with
 * scl_slope 0.5, scl_inter 10, pixdim 1.5 2 2.5 and a qform origin. */
static size_t nifti2_file(unsigned char *b, int big, int64_t vox_offset) {
    memset(b, 0, 1024);
    tu_put_i32(b, 0, 540, big);
    memcpy(b + 4, "n+2\0\r\n\032\n", 8);
    tu_put_i16(b, 12, 4, big);  /* int16 */
    tu_put_i16(b, 14, 16, big); /* bitpix */
    const int64_t dim[4] = {3, 3, 2, 2};
    const double pix[4] = {1, 1.5, 2, 2.5}, origin[3] = {-7, 8.25, 1e6};
    for (int i = 0; i < 8; i++) {
        int64_t v = i < 4 ? dim[i] : 1;
        for (int k = 0; k < 8; k++) b[16 + 8 * i + (big ? 7 - k : k)] = (unsigned char)((uint64_t)v >> (8 * k));
    }
    for (int i = 0; i < 4; i++) {
        uint64_t u;
        memcpy(&u, &pix[i], 8);
        for (int k = 0; k < 8; k++) b[104 + 8 * i + (big ? 7 - k : k)] = (unsigned char)(u >> (8 * k));
    }
    const double slope = 0.5, inter = 10;
    for (int k = 0; k < 8; k++) b[168 + (big ? 7 - k : k)] = (unsigned char)((uint64_t)vox_offset >> (8 * k));
    uint64_t u;
    memcpy(&u, &slope, 8);
    for (int k = 0; k < 8; k++) b[176 + (big ? 7 - k : k)] = (unsigned char)(u >> (8 * k));
    memcpy(&u, &inter, 8);
    for (int k = 0; k < 8; k++) b[184 + (big ? 7 - k : k)] = (unsigned char)(u >> (8 * k));
    tu_put_i32(b, 344, 1, big); /* qform_code */
    for (int a = 0; a < 3; a++) {
        memcpy(&u, &origin[a], 8);
        for (int k = 0; k < 8; k++) b[376 + 8 * a + (big ? 7 - k : k)] = (unsigned char)(u >> (8 * k));
    }
    for (int i = 0; i < 12; i++) tu_put_i16(b, (size_t)vox_offset + 2 * (size_t)i, i - 5, big);
    return (size_t)vox_offset + 24;
}

static void test_nifti2_reads_and_rejects(void **state) {
    (void)state;
    unsigned char b[1024];
    for (int big = 0; big < 2; big++) {
        size_t n = nifti2_file(b, big, 544);
        volux_context *ctx = tu_context(1);
        volux_volume *v = NULL;
        volux_volume_load_options o;
        memset(&o, 0, sizeof o);
        o.use_file_origin = 1;
        const char *path = tu_write_file(big ? "n2big.nii" : "n2.nii", b, n);
        if (volux_volume_load(ctx, path, &o, &v)) fail_msg("%s", volux_context_error(ctx));
        int d[3];
        double sp[3], lo, hi;
        volux_volume_dims(v, d);
        volux_volume_spacing(v, sp);
        volux_volume_range(v, &lo, &hi);
        assert_true(d[0] == 3 && d[1] == 2 && d[2] == 2);
        assert_true(sp[0] == 1.5 && sp[1] == 2.0 && sp[2] == 2.5);
        assert_true(lo == 0.5 * -5 + 10 && hi == 0.5 * 6 + 10);
        volux_volume_release(v);
        /* gzip'd, and under an unknown extension (found by its first bytes) */
        size_t zn;
        unsigned char *z = tu_deflate(b, n, 1, &zn);
        assert_int_equal(volux_volume_load(ctx, tu_write_file("n2.nii.gz", z, zn), NULL, &v), VOLUX_OK);
        volux_volume_release(v);
        free(z);
        assert_int_equal(volux_volume_load(ctx, tu_write_file("n2.vol", b, n), NULL, &v), VOLUX_OK);
        volux_volume_release(v);
        volux_context_destroy(ctx);
    }
    /* broken ones name the field */
    nifti2_file(b, 0, 544);
    b[10] = '\n'; /* "\r\n" → "\n\n": a text-mode transfer */
    expect_failure(tu_write_file("n2magic.nii", b, 568), NULL, VOLUX_ERR_FORMAT, "magic");
    nifti2_file(b, 0, 500);
    expect_failure(tu_write_file("n2vox.nii", b, 568), NULL, VOLUX_ERR_FORMAT, "inside the 540-byte header");
    nifti2_file(b, 0, 544);
    b[16 + 8 + 4] = 1; /* dim[1] = 3 + 2^32 */
    expect_failure(tu_write_file("n2dim.nii", b, 568), NULL, VOLUX_ERR_LIMIT, "dim[1]");
    nifti2_file(b, 0, 544);
    b[168 + 7] = 0x80; /* vox_offset negative */
    expect_failure(tu_write_file("n2neg.nii", b, 568), NULL, VOLUX_ERR_FORMAT, "vox_offset");
    nifti2_file(b, 0, 544);
    expect_failure(tu_write_file("n2short.nii", b, 560), NULL, VOLUX_ERR_FORMAT, "truncated");
    expect_failure(tu_write_file("n2hdr.nii", b, 500), NULL, VOLUX_ERR_FORMAT, "540-byte");
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_nifti2_reads_and_rejects),
        cmocka_unit_test(test_nrrd_bad_fields),
        cmocka_unit_test(test_nrrd_nul_byte_and_long_name),
        cmocka_unit_test(test_memory_cap_checked_before_allocating),
        cmocka_unit_test(test_gzip_bomb_stops_at_the_expected_size),
        cmocka_unit_test(test_metaimage_bad_fields),
        cmocka_unit_test(test_nifti_bad_fields),
        cmocka_unit_test(test_raw_and_dispatch_errors),
        cmocka_unit_test(test_allocation_failures_do_not_leak),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
