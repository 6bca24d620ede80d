/* tests/robustness/test_image_malformed.c — malformed, truncated and huge
 * image files; allocation failures; writes that fail half-way.
 *
 * Every failing call must: return the documented status, leave no context
 * memory allocated, and never make a large allocation for a file that cannot
 * hold the pixels it declares (checked with a counting allocator). */
#include <dirent.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include "image_fixtures.h"
#include "tu_volume.h"
#include "io/image_formats.h"
#include "test_util.h"

#define SMALL_ALLOC (1u << 20) /* "no big allocation" means below 1 MiB here */

typedef volux_status (*reader_fn)(volux_context *, const char *, const void *, size_t, volux_image *);

typedef struct format_case {
    const char *ext;
    reader_fn read;
} format_case;

static const format_case formats[] = {{"png", volux_png_read_memory},
                                      {"pfm", volux_pfm_read_memory},
                                      {"exr", volux_exr_read_memory},
                                      {"hdr", volux_hdr_read_memory}};

/* A valid Radiance file (new-style RLE, 16×6) built by hand. */
static unsigned char *hdr_file(size_t *size) {
    unsigned char *b = malloc(4096);
    assert_non_null(b);
    size_t n = (size_t)sprintf((char *)b, "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 6 +X 16\n");
    for (int row = 0; row < 6; row++) {
        const unsigned char start[4] = {2, 2, 0, 16};
        memcpy(b + n, start, 4);
        n += 4;
        for (int k = 0; k < 4; k++) {
            b[n++] = 128 + 10;
            b[n++] = (unsigned char)(100 + k + row);
            b[n++] = 6;
            for (int i = 0; i < 6; i++) b[n++] = (unsigned char)(120 + i + k);
        }
    }
    *size = n;
    return b;
}

/* A valid file of each format (20×12 pattern through our writers). */
static unsigned char *valid_file(const char *ext, size_t *size) {
    if (!strcmp(ext, "hdr")) return hdr_file(size);
    volux_context *ctx = tu_context(1);
    volux_image img;
    fx_pattern(ctx, 20, 12, &img);
    char name[32];
    snprintf(name, sizeof name, "valid.%s", ext);
    const char *path = tu_temp_path(name);
    assert_int_equal(volux_image_save(ctx, path, &img, -3.0f), VOLUX_OK);
    volux_image_free(ctx, &img);
    volux_context_destroy(ctx);
    return fx_read_file(path, size);
}

/* Runs a reader on bytes with a counting context and checks the invariants
 * of a call: no leak, *out untouched on failure. Returns the status. */
static volux_status read_counted(reader_fn read, const void *data, size_t size, uint64_t max_bytes,
                                 fx_alloc_stats *stats, char *message, size_t message_size) {
    fx_alloc_stats local = {0};
    if (!stats) stats = &local;
    volux_context *ctx = fx_counting_context(stats, max_bytes);
    stats->largest = 0;
    volux_image img = {0};
    volux_status st = read(ctx, "test-input", data, size, &img);
    if (st == VOLUX_OK)
        volux_image_free(ctx, &img);
    else
        assert_null(img.rgb);
    if (message) snprintf(message, message_size, "%s", volux_context_error(ctx));
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
    return st;
}

static void test_truncated_files_are_rejected_without_leaks(void **state) {
    (void)state;
    for (size_t f = 0; f < sizeof formats / sizeof formats[0]; f++) {
        size_t size;
        unsigned char *full = valid_file(formats[f].ext, &size);
        assert_int_equal(read_counted(formats[f].read, full, size, 0, NULL, NULL, 0), VOLUX_OK);
        for (size_t len = 0; len < size; len++) {
            unsigned char *cut = malloc(len ? len : 1); /* exact size: ASan sees any over-read */
            memcpy(cut, full, len);
            fx_alloc_stats stats = {0};
            volux_status st = read_counted(formats[f].read, cut, len, 0, &stats, NULL, 0);
            /* PNG: we stop after the last row, so a cut in the final
             * checksum or IEND chunk still yields every pixel. */
            int tail_ok = !strcmp(formats[f].ext, "png") && len + 16 >= size;
            if (!(st == VOLUX_ERR_FORMAT || (tail_ok && st == VOLUX_OK)))
                fail_msg("%s cut to %zu of %zu bytes: status %s", formats[f].ext, len, size, volux_status_name(st));
            free(cut);
        }
        free(full);
    }
}

/* A string literal and its length, NUL bytes included. */
#define LIT(s) s, sizeof(s) - 1

typedef struct bad_case {
    reader_fn read;
    const char *bytes;
    size_t size;
    volux_status expect;
    const char *message; /* substring of the error message */
} bad_case;

#define HDR_HEAD "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n"

static void test_bad_headers_name_the_problem(void **state) {
    (void)state;
    static const bad_case cases[] = {
        {volux_pfm_read_memory, LIT("PX\n1 1\n-1\n"), VOLUX_ERR_FORMAT, "not a PFM"},
        {volux_pfm_read_memory, LIT("PF\n-3 2\n-1\n"), VOLUX_ERR_FORMAT, "width/height"},
        {volux_pfm_read_memory, LIT("PF\n3\n"), VOLUX_ERR_FORMAT, "width/height"},
        {volux_pfm_read_memory, LIT("PF\n0 2\n-1\n"), VOLUX_ERR_FORMAT, "empty"},
        {volux_pfm_read_memory, LIT("PF\n3 2\n0.0\n"), VOLUX_ERR_FORMAT, "scale"},
        {volux_pfm_read_memory, LIT("PF\n3 2\n-1x\n"), VOLUX_ERR_FORMAT, "scale"},
        {volux_pfm_read_memory, LIT("PF\n1 1\n-1.0"), VOLUX_ERR_FORMAT, "separator"},
        {volux_pfm_read_memory, LIT("PF\n1 1\n-1\n\1\2\3\4\5\6\7"), VOLUX_ERR_FORMAT, "truncated"},
        {volux_hdr_read_memory, LIT("#?NOTRADIANCE\n\n-Y 1 +X 1\n"), VOLUX_ERR_FORMAT, "not a Radiance"},
        {volux_hdr_read_memory, LIT("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n"), VOLUX_ERR_FORMAT, "no end"},
        {volux_hdr_read_memory, LIT("#?RADIANCE\nFORMAT=32-bit_rle_xyze\n\n-Y 1 +X 1\n\1\1\1\1"),
         VOLUX_ERR_UNSUPPORTED, "32-bit_rle_xyze"},
        {volux_hdr_read_memory, LIT(HDR_HEAD "+X 1 -Y 1\n\1\1\1\1"), VOLUX_ERR_UNSUPPORTED, "column-major"},
        {volux_hdr_read_memory, LIT(HDR_HEAD "-Y 1 -Y 1\n\1\1\1\1"), VOLUX_ERR_FORMAT, "resolution"},
        {volux_hdr_read_memory, LIT(HDR_HEAD "-Y 1 +X\n"), VOLUX_ERR_FORMAT, "resolution"},
        {volux_hdr_read_memory, LIT(HDR_HEAD "-Y 1 +X 2\n\1\1\1\5\0\0\0\0"), VOLUX_ERR_FORMAT, "before any pixel"},
        {volux_hdr_read_memory, LIT(HDR_HEAD "-Y 1 +X 2\n\7\7\7\7\1\1\1\5"), VOLUX_ERR_FORMAT, "past the end"},
        {volux_hdr_read_memory, LIT(HDR_HEAD "-Y 1 +X 8\n\2\2\0\11"), VOLUX_ERR_FORMAT, "width does not match"},
        {volux_hdr_read_memory, LIT(HDR_HEAD "-Y 1 +X 8\n\2\2\0\10\0\1"), VOLUX_ERR_FORMAT, "zero-length"},
        {volux_hdr_read_memory, LIT(HDR_HEAD "-Y 1 +X 8\n\2\2\0\10\211\1"), VOLUX_ERR_FORMAT, "run past"},
        {volux_png_read_memory, LIT("\211PNX\r\n\032\n"), VOLUX_ERR_FORMAT, "not a PNG"},
        {volux_png_read_memory, LIT("\211PNG\r\n\032\n\0\0\0\15IHDX"), VOLUX_ERR_FORMAT, "IHDR"},
        {volux_exr_read_memory, LIT("v/1\2\2\0\0\0"), VOLUX_ERR_FORMAT, "magic"},
        {volux_exr_read_memory, LIT("v/1\1\2\0\0\0garbage\0garbage\0"), VOLUX_ERR_FORMAT, "OpenEXR"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char msg[1024];
        size_t n = cases[i].size;
        unsigned char *copy = malloc(n);
        memcpy(copy, cases[i].bytes, n);
        volux_status st = read_counted(cases[i].read, copy, n, 0, NULL, msg, sizeof msg);
        free(copy);
        if (st != cases[i].expect || !strstr(msg, cases[i].message) || !strstr(msg, "test-input"))
            fail_msg("case %zu: status %s, message '%s'; expected %s with '%s'", i, volux_status_name(st), msg,
                     volux_status_name(cases[i].expect), cases[i].message);
    }
}

/* Puts a big-endian 32-bit value. */
static void put32(unsigned char *p, uint32_t v) {
    p[0] = (unsigned char)(v >> 24);
    p[1] = (unsigned char)(v >> 16);
    p[2] = (unsigned char)(v >> 8);
    p[3] = (unsigned char)v;
}

/* A PNG signature + IHDR (valid CRC) declaring w×h RGB8, plus `extra` bytes. */
static unsigned char *png_header(uint32_t w, uint32_t h, size_t extra, size_t *size) {
    unsigned char *b = calloc(1, 33 + extra);
    memcpy(b, "\211PNG\r\n\032\n", 8);
    put32(b + 8, 13);
    memcpy(b + 12, "IHDR", 4);
    put32(b + 16, w);
    put32(b + 20, h);
    b[24] = 8; /* depth */
    b[25] = 2; /* RGB */
    put32(b + 29, (uint32_t)crc32(0, b + 12, 17));
    *size = 33 + extra;
    return b;
}

static void expect_small(const char *what, reader_fn read, const void *data, size_t size, volux_status expect) {
    fx_alloc_stats stats = {0};
    char msg[1024];
    volux_status st = read_counted(read, data, size, 0, &stats, msg, sizeof msg);
    if (st != expect) fail_msg("%s: status %s (%s), expected %s", what, volux_status_name(st), msg, volux_status_name(expect));
    if (stats.largest >= SMALL_ALLOC) fail_msg("%s: allocated %zu bytes at once", what, stats.largest);
}

static void test_huge_declared_sizes_fail_without_big_allocations(void **state) {
    (void)state;
    char pfm[256];
    snprintf(pfm, sizeof pfm, "PF\n40000 40000\n-1\n");
    expect_small("PFM over the side limit", volux_pfm_read_memory, pfm, strlen(pfm), VOLUX_ERR_LIMIT);
    /* 25000² floats (7.5 GB) are under the default 8 GiB cap: only the
     * missing pixel data can reject it. */
    size_t n = (size_t)snprintf(pfm, sizeof pfm, "PF\n25000 25000\n-1\n") + 100;
    expect_small("PFM 25000² with 100 bytes", volux_pfm_read_memory, pfm, n, VOLUX_ERR_FORMAT);
    /* Under a 1 MiB cap a 1000² float image (12 MB) is over the limit. */
    snprintf(pfm, sizeof pfm, "PF\n1000 1000\n-1\n");
    assert_int_equal(read_counted(volux_pfm_read_memory, pfm, strlen(pfm), 1u << 20, NULL, NULL, 0), VOLUX_ERR_LIMIT);

    char hdr[256];
    n = (size_t)snprintf(hdr, sizeof hdr, HDR_HEAD "-Y 40000 +X 10\n");
    expect_small("HDR over the side limit", volux_hdr_read_memory, hdr, n, VOLUX_ERR_LIMIT);
    n = (size_t)snprintf(hdr, sizeof hdr, HDR_HEAD "-Y 25000 +X 25000\n\2\2\141\250\201\1");
    expect_small("HDR 25000² with a few bytes", volux_hdr_read_memory, hdr, n, VOLUX_ERR_FORMAT);

    size_t size;
    unsigned char *png = png_header(40000, 40000, 64, &size);
    expect_small("PNG over the side limit", volux_png_read_memory, png, size, VOLUX_ERR_LIMIT);
    free(png);
    png = png_header(25000, 25000, 4096, &size);
    expect_small("PNG 25000² with 4 KB", volux_png_read_memory, png, size, VOLUX_ERR_FORMAT);
    free(png);

    /* EXR: patch the data window of a valid file. */
    unsigned char *exr = valid_file("exr", &size);
    unsigned char *dw = NULL;
    for (size_t i = 0; i + 20 < size && !dw; i++)
        if (!memcmp(exr + i, "dataWindow\0box2i\0", 17)) dw = exr + i + 17 + 4;
    assert_non_null(dw);
    const int32_t sizes[2] = {24999, 39999};
    const volux_status expect[2] = {VOLUX_ERR_FORMAT, VOLUX_ERR_FORMAT};
    for (int k = 0; k < 2; k++) {
        int32_t max[2] = {sizes[k], sizes[k]};
        memcpy(dw + 8, max, 8); /* little-endian host */
        expect_small("EXR with a huge data window", volux_exr_read_memory, exr, size, expect[k]);
    }
    free(exr);
}

static void test_wrong_magic_is_a_format_error(void **state) {
    (void)state;
    for (size_t f = 0; f < sizeof formats / sizeof formats[0]; f++) {
        size_t size;
        unsigned char *data = valid_file(formats[f].ext, &size);
        for (size_t g = 0; g < sizeof formats / sizeof formats[0]; g++) {
            if (g == f) continue;
            char msg[1024];
            volux_status st = read_counted(formats[g].read, data, size, 0, NULL, msg, sizeof msg);
            if (st != VOLUX_ERR_FORMAT)
                fail_msg("%s file read as %s: %s (%s)", formats[f].ext, formats[g].ext, volux_status_name(st), msg);
        }
        free(data);
    }
}

/* Fails allocation k = 1, 2, ... until the read succeeds: each failure must
 * be NOMEM and leak nothing (Lua's memerr.lua / SQLite's OOM loops). */
static void test_allocation_failures_never_leak(void **state) {
    (void)state;
    for (size_t f = 0; f < sizeof formats / sizeof formats[0]; f++) {
        size_t size;
        unsigned char *data = valid_file(formats[f].ext, &size);
        for (size_t k = 1;; k++) {
            fx_alloc_stats stats = {0};
            volux_context *ctx = fx_counting_context(&stats, 0);
            stats.count = 0;
            stats.fail_at = k;
            volux_image img = {0};
            volux_status st = formats[f].read(ctx, "oom", data, size, &img);
            if (st == VOLUX_OK) volux_image_free(ctx, &img);
            assert_int_equal(volux_context_bytes_in_use(ctx), 0);
            volux_context_destroy(ctx);
            if (st == VOLUX_OK) break;
            if (st != VOLUX_ERR_NOMEM) fail_msg("%s, allocation %zu failed: status %s", formats[f].ext, k, volux_status_name(st));
            assert_true(k < 10000);
        }
        free(data);
    }
}

/* ---- writing ---- */

static int dir_has_temp_files(const char *dir) {
    DIR *d = opendir(dir);
    assert_non_null(d);
    struct dirent *e;
    int found = 0;
    while ((e = readdir(d)))
        if (strstr(e->d_name, ".tmp-")) found = 1;
    closedir(d);
    return found;
}

static void temp_dir_of(const char *path, char *dir, size_t n) {
    snprintf(dir, n, "%s", path);
    char *slash = strrchr(dir, '/');
    assert_non_null(slash);
    *slash = 0;
}

static void test_unwritable_output_leaves_no_file(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_image img;
    fx_pattern(ctx, 64, 64, &img);
    struct stat sb;

    volux_context_clear_error(ctx);
    assert_int_equal(volux_image_save(ctx, "/nonexistent-volux-dir/out.png", &img, 0.0f), VOLUX_ERR_WRITE);
    assert_non_null(strstr(volux_context_error(ctx), "/nonexistent-volux-dir/out.png"));
    assert_int_equal(stat("/nonexistent-volux-dir", &sb), -1);

    /* The target is a directory: the rename fails, the temp file goes. */
    const char *dir_target = tu_temp_path("adir.pfm");
    mkdir(dir_target, 0700);
    assert_int_equal(volux_image_save(ctx, dir_target, &img, 0.0f), VOLUX_ERR_WRITE);
    char dir[512];
    temp_dir_of(dir_target, dir, sizeof dir);
    assert_false(dir_has_temp_files(dir));
    rmdir(dir_target);

    /* A write that fails half-way (file size limit, like a full disk):
     * no file, no temp file, and an existing file is left as it was. */
    const char *names[3] = {"full.png", "full.pfm", "full.exr"};
    void (*old_handler)(int) = signal(SIGXFSZ, SIG_IGN);
    struct rlimit old_limit;
    getrlimit(RLIMIT_FSIZE, &old_limit);
    for (int i = 0; i < 3; i++) {
        const char *path = tu_temp_path(names[i]);
        const char *target = i == 2 ? tu_write_file(names[i], "old", 3) : path;
        struct rlimit small = old_limit;
        small.rlim_cur = 64;
        setrlimit(RLIMIT_FSIZE, &small);
        volux_status st = volux_image_save(ctx, target, &img, 0.0f);
        setrlimit(RLIMIT_FSIZE, &old_limit);
        if (st != VOLUX_ERR_WRITE) fail_msg("%s: %s (%s)", names[i], volux_status_name(st), volux_context_error(ctx));
        if (i == 2) {
            size_t n;
            unsigned char *kept = fx_read_file(target, &n);
            assert_int_equal(n, 3);
            assert_memory_equal(kept, "old", 3);
            free(kept);
            unlink(target);
        } else {
            assert_int_equal(stat(path, &sb), -1);
        }
        assert_false(dir_has_temp_files(dir));
    }
    signal(SIGXFSZ, old_handler);
    volux_image_free(ctx, &img);
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

static void test_unknown_extensions_list_the_supported_ones(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_image img;
    fx_pattern(ctx, 2, 2, &img);
    volux_context_clear_error(ctx);
    assert_int_equal(volux_image_save(ctx, tu_temp_path("x.jpg"), &img, 0.0f), VOLUX_ERR_INVALID);
    assert_non_null(strstr(volux_context_error(ctx), ".png .pfm .exr"));
    assert_int_equal(volux_image_save(ctx, tu_temp_path("x.hdr"), &img, 0.0f), VOLUX_ERR_INVALID);
    assert_int_equal(volux_image_save(ctx, tu_temp_path("noext"), &img, 0.0f), VOLUX_ERR_INVALID);
    volux_image out;
    volux_context_clear_error(ctx);
    assert_int_equal(volux_image_load(ctx, tu_temp_path("x.tiff"), &out), VOLUX_ERR_INVALID);
    assert_non_null(strstr(volux_context_error(ctx), ".png .pfm .exr .hdr"));
    volux_context_clear_error(ctx);
    assert_int_equal(volux_image_load(ctx, tu_temp_path("missing.pfm"), &out), VOLUX_ERR_IO);
    assert_non_null(strstr(volux_context_error(ctx), "missing.pfm"));
    volux_image_free(ctx, &img);
    volux_context_destroy(ctx);
}

/* Allocation failures while saving: an error, no leak, no file. */
static void test_allocation_failures_while_saving(void **state) {
    (void)state;
    const char *names[3] = {"oom.png", "oom.pfm", "oom.exr"};
    for (int i = 0; i < 3; i++) {
        for (size_t k = 1;; k++) {
            fx_alloc_stats stats = {0};
            volux_context *ctx = fx_counting_context(&stats, 0);
            volux_image img;
            fx_pattern(ctx, 30, 20, &img);
            stats.count = 0;
            stats.fail_at = k;
            const char *path = tu_temp_path(names[i]);
            unlink(path);
            volux_status st = volux_image_save(ctx, path, &img, 0.0f);
            stats.fail_at = 0;
            volux_image_free(ctx, &img);
            assert_int_equal(volux_context_bytes_in_use(ctx), 0);
            volux_context_destroy(ctx);
            struct stat sb;
            if (st == VOLUX_OK) {
                assert_int_equal(stat(path, &sb), 0);
                break;
            }
            if (st != VOLUX_ERR_NOMEM) fail_msg("%s, allocation %zu failed: %s", names[i], k, volux_status_name(st));
            assert_int_equal(stat(path, &sb), -1);
            assert_true(k < 10000);
        }
    }
}

/* An uncompressed scanline EXR of w×h float RGB pixels (value x + 10·y
 * in R, G, B), written by hand after the OpenEXR file layout document:
 * magic, version 2, the required attributes, the offset table, one chunk
 * per line (int32 y, int32 size, B G R lines). */
static unsigned char *exr_uncompressed(int w, int h, size_t *size) {
    unsigned char *b = calloc(1, 4096 + (size_t)w * (size_t)h * 12 + (size_t)h * 16);
    assert_non_null(b);
    size_t n = 0;
#define PUT(p, len) (memcpy(b + n, (p), (len)), n += (len))
#define PUT_I32(v) do { int32_t v_ = (v); PUT(&v_, 4); } while (0)
#define ATTR(name, type, len) do { PUT(name, strlen(name) + 1); PUT(type, strlen(type) + 1); PUT_I32(len); } while (0)
    const unsigned char magic[8] = {0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0};
    PUT(magic, 8);
    ATTR("channels", "chlist", 3 * (2 + 16) + 1);
    const char *ch[3] = {"B", "G", "R"};
    for (int c = 0; c < 3; c++) {
        PUT(ch[c], 2);
        PUT_I32(2); /* FLOAT */
        const unsigned char linear[4] = {0, 0, 0, 0};
        PUT(linear, 4);
        PUT_I32(1);
        PUT_I32(1);
    }
    b[n++] = 0;
    ATTR("compression", "compression", 1);
    b[n++] = 0; /* NO_COMPRESSION */
    ATTR("dataWindow", "box2i", 16);
    PUT_I32(0); PUT_I32(0); PUT_I32(w - 1); PUT_I32(h - 1);
    ATTR("displayWindow", "box2i", 16);
    PUT_I32(0); PUT_I32(0); PUT_I32(w - 1); PUT_I32(h - 1);
    ATTR("lineOrder", "lineOrder", 1);
    b[n++] = 0;
    float one = 1.0f, zero[2] = {0, 0};
    ATTR("pixelAspectRatio", "float", 4);
    PUT(&one, 4);
    ATTR("screenWindowCenter", "v2f", 8);
    PUT(zero, 8);
    ATTR("screenWindowWidth", "float", 4);
    PUT(&one, 4);
    b[n++] = 0;
    size_t table = n;
    n += 8 * (size_t)h;
    for (int y = 0; y < h; y++) {
        uint64_t at = n;
        memcpy(b + table + 8 * (size_t)y, &at, 8);
        PUT_I32(y);
        PUT_I32(w * 12);
        for (int c = 0; c < 3; c++)
            for (int x = 0; x < w; x++) {
                float v = (float)(x + 10 * y);
                PUT(&v, 4);
            }
    }
#undef ATTR
#undef PUT_I32
#undef PUT
    *size = n;
    return b;
}

/* Issue 16: an uncompressed chunk smaller than its pixels, and an
 * attribute with a negative or oversized size, are format errors naming
 * the chunk / attribute (the library filled the rest with garbage or
 * accepted the size). The intact file reads exactly. */
static void test_exr_chunk_and_attribute_sizes(void **state) {
    (void)state;
    size_t size;
    unsigned char *exr = exr_uncompressed(4, 3, &size);
    volux_context *ctx = tu_context(1);
    volux_image img;
    assert_int_equal(volux_exr_read_memory(ctx, "ok.exr", exr, size, &img), VOLUX_OK);
    assert_true(img.width == 4 && img.height == 3);
    assert_true(img.rgb[3 * (2 * 4 + 3) + 0] == 23.0f && img.rgb[3 * (2 * 4 + 3) + 2] == 23.0f);
    volux_image_free(ctx, &img);

    /* The last chunk declares 12 bytes fewer (the file ends there). */
    size_t last = size - 4 * 12 - 8;
    int32_t shorter = 4 * 12 - 12;
    memcpy(exr + last + 4, &shorter, 4);
    volux_context_clear_error(ctx);
    assert_int_equal(volux_exr_read_memory(ctx, "short.exr", exr, size - 12, &img), VOLUX_ERR_FORMAT);
    tu_assert_error_mentions(ctx, "short.exr", "chunk 2", "36", "48", (const char *)NULL);
    free(exr);

    /* pixelAspectRatio with size -4, then with a size past the end */
    const int32_t bad[2] = {-4, 1 << 30};
    for (int k = 0; k < 2; k++) {
        exr = exr_uncompressed(4, 3, &size);
        unsigned char *a = NULL;
        for (size_t i = 0; i + 24 < size && !a; i++)
            if (!memcmp(exr + i, "pixelAspectRatio\0float\0", 23)) a = exr + i + 23;
        assert_non_null(a);
        memcpy(a, &bad[k], 4);
        volux_context_clear_error(ctx);
        assert_int_equal(volux_exr_read_memory(ctx, "attr.exr", exr, size, &img), VOLUX_ERR_FORMAT);
        tu_assert_error_mentions(ctx, "attr.exr", "pixelAspectRatio", k ? "past the end" : "negative size",
                                 (const char *)NULL);
        free(exr);
    }
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_exr_chunk_and_attribute_sizes),
        cmocka_unit_test(test_truncated_files_are_rejected_without_leaks),
        cmocka_unit_test(test_bad_headers_name_the_problem),
        cmocka_unit_test(test_huge_declared_sizes_fail_without_big_allocations),
        cmocka_unit_test(test_wrong_magic_is_a_format_error),
        cmocka_unit_test(test_allocation_failures_never_leak),
        cmocka_unit_test(test_unwritable_output_leaves_no_file),
        cmocka_unit_test(test_unknown_extensions_list_the_supported_ones),
        cmocka_unit_test(test_allocation_failures_while_saving),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
