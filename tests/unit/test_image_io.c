/* tests/unit/test_image_io.c — image formats: round trips, orientation,
 * sRGB encoding, exposure, hand-built HDR files, EXR variants written by the
 * OpenEXR library itself, and the compare metrics. */
#include <math.h>
#include <png.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "image_fixtures.h"
#include "io/image_formats.h"
#include "test_util.h"

#define W 7
#define H 5

static float at(const volux_image *img, int x, int y, int c) { return img->rgb[((size_t)y * img->width + x) * 3 + c]; }

static void assert_pattern(const volux_image *img, int w, int h) {
    assert_int_equal(img->width, w);
    assert_int_equal(img->height, h);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            for (int c = 0; c < 3; c++)
                if (at(img, x, y, c) != fx_pattern_value(x, y, c))
                    fail_msg("pixel (%d,%d).%d = %.9g, expected %.9g", x, y, c, at(img, x, y, c),
                             fx_pattern_value(x, y, c));
}

static void round_trip_exact(const char *file) {
    volux_context *ctx = tu_context(1);
    volux_image src, back;
    fx_pattern(ctx, W, H, &src);
    /* A value no half float can hold: the float path must keep it. */
    src.rgb[4] = 0.1f;
    const char *path = tu_temp_path(file);
    assert_int_equal(volux_image_save(ctx, path, &src, 0.0f), VOLUX_OK);
    assert_int_equal(volux_image_load(ctx, path, &back), VOLUX_OK);
    assert_int_equal(back.width, W);
    assert_int_equal(back.height, H);
    assert_memory_equal(back.rgb, src.rgb, sizeof(float) * W * H * 3);
    volux_image_free(ctx, &src);
    volux_image_free(ctx, &back);
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

static void test_pfm_round_trip_is_exact(void **state) {
    (void)state;
    round_trip_exact("rt.pfm");
}

static void test_exr_round_trip_is_exact(void **state) {
    (void)state;
    round_trip_exact("rt.exr");
}

static void test_extension_is_case_insensitive(void **state) {
    (void)state;
    round_trip_exact("RT.PfM");
    round_trip_exact("rt.EXR");
}

/* The PFM file itself stores the bottom row first (independent of our reader). */
static void test_pfm_file_stores_rows_bottom_to_top(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_image src;
    fx_pattern(ctx, W, H, &src);
    const char *path = tu_temp_path("order.pfm");
    assert_int_equal(volux_image_save(ctx, path, &src, 0.0f), VOLUX_OK);
    size_t size;
    unsigned char *bytes = fx_read_file(path, &size);
    const char header[] = "PF\n7 5\n-1.0\n";
    assert_memory_equal(bytes, header, sizeof header - 1);
    assert_int_equal(size, sizeof header - 1 + W * H * 12);
    float first; /* little-endian host assumed by this check only */
    memcpy(&first, bytes + sizeof header - 1, 4);
    assert_true(first == fx_pattern_value(0, H - 1, 0));
    free(bytes);
    volux_image_free(ctx, &src);
    volux_context_destroy(ctx);
}

static void test_pfm_gray_big_endian(void **state) {
    (void)state;
    /* 2×2 "Pf", positive scale = big-endian; file rows bottom-to-top. */
    unsigned char file[64];
    const char header[] = "Pf\n2 2\n1.0\n";
    size_t n = sizeof header - 1;
    memcpy(file, header, n);
    const float file_order[4] = {3.0f, 4.0f, 1.0f, 2.0f}; /* bottom row, then top row */
    for (int i = 0; i < 4; i++) {
        uint32_t u;
        memcpy(&u, &file_order[i], 4);
        file[n++] = (unsigned char)(u >> 24);
        file[n++] = (unsigned char)(u >> 16);
        file[n++] = (unsigned char)(u >> 8);
        file[n++] = (unsigned char)u;
    }
    volux_context *ctx = tu_context(1);
    volux_image img;
    assert_int_equal(volux_pfm_read_memory(ctx, "mem", file, n, &img), VOLUX_OK);
    const float expect[4] = {1, 2, 3, 4}; /* top-left first */
    for (int p = 0; p < 4; p++)
        for (int c = 0; c < 3; c++) assert_true(img.rgb[p * 3 + c] == expect[p]);
    volux_image_free(ctx, &img);
    volux_context_destroy(ctx);
}

/* ---- PNG ---- */

/* Reads a PNG with libpng's simplified API: our writer checked independently
 * of our reader. */
static unsigned char *read_png_bytes(const char *path, int *w, int *h) {
    png_image im;
    memset(&im, 0, sizeof im);
    im.version = PNG_IMAGE_VERSION;
    assert_true(png_image_begin_read_from_file(&im, path));
    im.format = PNG_FORMAT_RGB;
    unsigned char *buf = malloc(PNG_IMAGE_SIZE(im));
    assert_non_null(buf);
    assert_true(png_image_finish_read(&im, NULL, buf, 0, NULL));
    *w = (int)im.width;
    *h = (int)im.height;
    return buf;
}

static void test_png_encodes_srgb_known_values(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_image img;
    assert_int_equal(volux_image_create(ctx, 3, 2, &img), VOLUX_OK);
    /* linear: 0.5 → 188 (1.055·0.5^(1/2.4) − 0.055 = 0.7354, ·255 = 187.5),
     * 0.001 → 12.92·0.001·255 = 3.29 → 3, 1 → 255, 4 → clamped 255,
     * −1 → 0, 0.2140 → 0.5 → 128 (127.5 + rounding). */
    const float v[18] = {0.5f, 0.001f, 1.0f, 4.0f, -1.0f, 0.0f, 0.214041144f, 0.5f, 0.5f,
                         0.0f, 0.0f, 0.0f, 1.0f, 1.0f, 1.0f, 0.5f, 0.5f, 0.5f};
    memcpy(img.rgb, v, sizeof v);
    const char *path = tu_temp_path("srgb.png");
    assert_int_equal(volux_image_save(ctx, path, &img, 0.0f), VOLUX_OK);
    int w, h;
    unsigned char *px = read_png_bytes(path, &w, &h);
    assert_int_equal(w, 3);
    assert_int_equal(h, 2);
    const unsigned char expect[18] = {188, 3, 255, 255, 0, 0, 128, 188, 188, 0, 0, 0, 255, 255, 255, 188, 188, 188};
    assert_memory_equal(px, expect, 18);
    free(px);
    volux_image_free(ctx, &img);
    volux_context_destroy(ctx);
}

static void test_png_exposure_scales_by_power_of_two(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_image img;
    assert_int_equal(volux_image_create(ctx, 1, 1, &img), VOLUX_OK);
    img.rgb[0] = 0.25f; /* ×2^1 = 0.5 → 188 */
    img.rgb[1] = 1.0f;  /* ×2 = 2 → clamped 255 */
    img.rgb[2] = 0.125f; /* ×2 = 0.25 → 137 */
    const char *path = tu_temp_path("exposure.png");
    assert_int_equal(volux_image_save(ctx, path, &img, 1.0f), VOLUX_OK);
    int w, h;
    unsigned char *px = read_png_bytes(path, &w, &h);
    assert_int_equal(px[0], 188);
    assert_int_equal(px[1], 255);
    assert_int_equal(px[2], 137);
    free(px);
    volux_image_free(ctx, &img);
    volux_context_destroy(ctx);
}

/* Round trip within quantisation: |decode(encode(v)) − v| ≤ half a step of
 * the sRGB code at v, and exactly the decoded code value. */
static void test_png_round_trip_within_quantisation(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_image src, back;
    fx_pattern(ctx, W, H, &src);
    for (int i = 0; i < W * H * 3; i++) src.rgb[i] = src.rgb[i] / 16.0f; /* into [0, ~0.6] */
    const char *path = tu_temp_path("rt.png");
    assert_int_equal(volux_image_save(ctx, path, &src, 0.0f), VOLUX_OK);
    assert_int_equal(volux_image_load(ctx, path, &back), VOLUX_OK);
    assert_int_equal(back.width, W);
    assert_int_equal(back.height, H);
    for (int i = 0; i < W * H * 3; i++) {
        int code = (int)(volux_srgb_encode(src.rgb[i]) * 255.0f + 0.5f);
        assert_near(back.rgb[i], volux_srgb_decode((float)code / 255.0f), 1e-6);
        float step = volux_srgb_decode((float)(code + 1) / 255.0f) - volux_srgb_decode((float)code / 255.0f);
        assert_near(back.rgb[i], src.rgb[i], step);
    }
    volux_image_free(ctx, &src);
    volux_image_free(ctx, &back);
    volux_context_destroy(ctx);
}

static void test_png_reads_gray_16bit_and_palette(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    /* 16-bit gray 2×1 via the simplified writer: 0 and 65535. */
    png_image im;
    memset(&im, 0, sizeof im);
    im.version = PNG_IMAGE_VERSION;
    im.width = 2;
    im.height = 1;
    im.format = PNG_FORMAT_LINEAR_Y; /* 16-bit linear gray is written as 16-bit gray */
    const uint16_t gray[2] = {0, 65535};
    const char *path = tu_temp_path("gray16.png");
    assert_true(png_image_write_to_file(&im, path, 0, gray, 0, NULL));
    volux_image img;
    assert_int_equal(volux_image_load(ctx, path, &img), VOLUX_OK);
    assert_near(at(&img, 0, 0, 1), 0.0, 1e-6);
    assert_near(at(&img, 1, 0, 0), 1.0, 1e-6);
    assert_near(at(&img, 1, 0, 2), 1.0, 1e-6);
    volux_image_free(ctx, &img);

    /* Palette + alpha (RGBA colormap): alpha is dropped, colour kept. */
    memset(&im, 0, sizeof im);
    im.version = PNG_IMAGE_VERSION;
    im.width = 2;
    im.height = 1;
    im.format = PNG_FORMAT_RGBA_COLORMAP;
    im.colormap_entries = 2;
    const unsigned char cmap[8] = {255, 0, 0, 128, 0, 188, 0, 255};
    const unsigned char idx[2] = {0, 1};
    path = tu_temp_path("palette.png");
    assert_true(png_image_write_to_file(&im, path, 0, idx, 0, cmap));
    assert_int_equal(volux_image_load(ctx, path, &img), VOLUX_OK);
    assert_near(at(&img, 0, 0, 0), 1.0, 1e-6);
    assert_near(at(&img, 0, 0, 1), 0.0, 1e-6);
    assert_near(at(&img, 1, 0, 1), volux_srgb_decode(188.0f / 255.0f), 1e-6);
    volux_image_free(ctx, &img);
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

/* Top-left stays top-left in every format (asymmetric image). */
static void test_orientation_is_kept_by_every_format(void **state) {
    (void)state;
    const char *files[] = {"o.png", "o.pfm", "o.exr"};
    volux_context *ctx = tu_context(1);
    volux_image src;
    assert_int_equal(volux_image_create(ctx, 3, 2, &src), VOLUX_OK);
    src.rgb[0] = 1.0f;                 /* top-left: red */
    src.rgb[(1 * 3 + 2) * 3 + 2] = 1.0f; /* bottom-right: blue */
    for (size_t f = 0; f < sizeof files / sizeof files[0]; f++) {
        volux_image back;
        const char *path = tu_temp_path(files[f]);
        assert_int_equal(volux_image_save(ctx, path, &src, 0.0f), VOLUX_OK);
        assert_int_equal(volux_image_load(ctx, path, &back), VOLUX_OK);
        assert_near(at(&back, 0, 0, 0), 1.0, 1e-6);
        assert_near(at(&back, 2, 1, 2), 1.0, 1e-6);
        assert_near(at(&back, 2, 0, 0), 0.0, 1e-6);
        assert_near(at(&back, 0, 1, 2), 0.0, 1e-6);
        volux_image_free(ctx, &back);
    }
    volux_image_free(ctx, &src);
    volux_context_destroy(ctx);
}

/* ---- EXR written by the library ---- */

static float half_pattern(int x, int y, int c) { return fx_pattern_value(x, y, c); }
/* B,G,R order of channels as Blender writes them: k=0 is B. */
static float bgr_pattern(int x, int y, int k) { return fx_pattern_value(x, y, 2 - k); }

static void load_and_check_pattern(const char *path, int w, int h) {
    volux_context *ctx = tu_context(1);
    volux_image img;
    if (volux_image_load(ctx, path, &img) != VOLUX_OK) fail_msg("%s", volux_context_error(ctx));
    assert_pattern(&img, w, h);
    volux_image_free(ctx, &img);
    assert_int_equal(volux_context_bytes_in_use(ctx), 0);
    volux_context_destroy(ctx);
}

static void test_exr_reads_half_bgr_in_every_lossless_compression(void **state) {
    (void)state;
    const char *bgr[3] = {"B", "G", "R"};
    const exr_compression_t comps[] = {EXR_COMPRESSION_NONE, EXR_COMPRESSION_RLE, EXR_COMPRESSION_ZIPS,
                                       EXR_COMPRESSION_ZIP, EXR_COMPRESSION_PIZ, EXR_COMPRESSION_PXR24};
    for (size_t i = 0; i < sizeof comps / sizeof comps[0]; i++) {
        const char *path = tu_temp_path("half.exr");
        assert_int_equal(fx_write_exr(path, 13, 37, bgr, 3, EXR_PIXEL_HALF, comps[i], 0, 0, bgr_pattern), 0);
        load_and_check_pattern(path, 13, 37);
    }
}

static void test_exr_reads_tiled_float_with_partial_tiles(void **state) {
    (void)state;
    const char *rgb[4] = {"A", "B", "G", "R"}; /* extra alpha channel is skipped */
    const char *path = tu_temp_path("tiled.exr");
    assert_int_equal(fx_write_exr(path, 10, 7, rgb + 1, 3, EXR_PIXEL_FLOAT, EXR_COMPRESSION_ZIP, 4, 3, bgr_pattern), 0);
    load_and_check_pattern(path, 10, 7);
    assert_int_equal(fx_write_exr(path, 10, 7, rgb, 4, EXR_PIXEL_HALF, EXR_COMPRESSION_PIZ, 4, 4, half_pattern) == 0,
                     1);
    volux_context *ctx = tu_context(1);
    volux_image img;
    assert_int_equal(volux_image_load(ctx, path, &img), VOLUX_OK); /* A,B,G,R: B=value(.,.,1) etc. */
    assert_true(at(&img, 9, 6, 0) == fx_pattern_value(9, 6, 3));
    assert_true(at(&img, 9, 6, 2) == fx_pattern_value(9, 6, 1));
    volux_image_free(ctx, &img);
    volux_context_destroy(ctx);
}

static float gray_pattern(int x, int y, int c) {
    (void)c;
    return (float)(x + 10 * y);
}

static void test_exr_reads_uint_luminance_as_gray(void **state) {
    (void)state;
    const char *y[1] = {"Y"};
    const char *path = tu_temp_path("gray.exr");
    /* Sizes chosen so that no chunk of the library-written file hits the
     * 3.1.5 "compressed size == raw size" writer bug (see exr.c). */
    assert_int_equal(fx_write_exr(path, 5, 4, y, 1, EXR_PIXEL_UINT, EXR_COMPRESSION_NONE, 0, 0, gray_pattern), 0);
    volux_context *ctx = tu_context(1);
    volux_image img;
    assert_int_equal(volux_image_load(ctx, path, &img), VOLUX_OK);
    for (int yy = 0; yy < 4; yy++)
        for (int x = 0; x < 5; x++)
            for (int c = 0; c < 3; c++) assert_true(at(&img, x, yy, c) == (float)(x + 10 * yy));
    volux_image_free(ctx, &img);
    volux_context_destroy(ctx);
}

/* A data window away from the origin and decreasing line order: the image
 * is the data window, top row first either way. */
static void test_exr_reads_offset_data_window_and_decreasing_y(void **state) {
    (void)state;
    const char *bgr[3] = {"B", "G", "R"};
    const char *path = tu_temp_path("window.exr");
    fx_exr.origin_x = -3;
    fx_exr.origin_y = 5;
    fx_exr.decreasing_y = 1;
    exr_result_t rv = fx_write_exr(path, 9, 40, bgr, 3, EXR_PIXEL_HALF, EXR_COMPRESSION_PIZ, 0, 0, bgr_pattern);
    memset(&fx_exr, 0, sizeof fx_exr);
    assert_int_equal(rv, 0);
    load_and_check_pattern(path, 9, 40);
}

/* Our writer's file is ZIP-compressed float and the library reads it back. */
static void test_exr_written_by_us_is_zip_float(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_image src;
    fx_pattern(ctx, 40, 33, &src); /* > 16 rows: several ZIP chunks */
    const char *path = tu_temp_path("zip.exr");
    assert_int_equal(volux_image_save(ctx, path, &src, 0.0f), VOLUX_OK);
    exr_context_t exr = NULL;
    assert_int_equal(exr_start_read(&exr, path, NULL), EXR_ERR_SUCCESS);
    exr_compression_t comp;
    assert_int_equal(exr_get_compression(exr, 0, &comp), EXR_ERR_SUCCESS);
    assert_int_equal(comp, EXR_COMPRESSION_ZIP);
    const exr_attr_chlist_t *ch;
    assert_int_equal(exr_get_channels(exr, 0, &ch), EXR_ERR_SUCCESS);
    assert_int_equal(ch->num_channels, 3);
    for (int i = 0; i < 3; i++) assert_int_equal(ch->entries[i].pixel_type, EXR_PIXEL_FLOAT);
    exr_finish(&exr);
    volux_image back;
    assert_int_equal(volux_image_load(ctx, path, &back), VOLUX_OK);
    assert_memory_equal(back.rgb, src.rgb, sizeof(float) * 40 * 33 * 3);
    volux_image_free(ctx, &src);
    volux_image_free(ctx, &back);
    volux_context_destroy(ctx);
}

/* Tiny, compressible images: OpenEXRCore 3.1.5 writes chunks whose ZIP size
 * equals their raw size, which every reader then takes as raw data (see
 * exr.c). Many such sizes occur below; all must round-trip exactly. */
static void test_exr_tiny_compressible_images_round_trip(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    const char *path = tu_temp_path("tiny.exr");
    for (unsigned seed = 0; seed < 200; seed++) {
        int w = 1 + (int)(seed % 5), h = 1 + (int)(seed / 5) % 20;
        volux_image src, back;
        assert_int_equal(volux_image_create(ctx, w, h, &src), VOLUX_OK);
        for (int i = 0; i < w * h * 3; i++) {
            unsigned v = (unsigned)i * 2654435761u ^ seed * 40503u;
            src.rgb[i] = (float)((v >> 7) % 4) * 0.5f;
        }
        assert_int_equal(volux_image_save(ctx, path, &src, 0.0f), VOLUX_OK);
        assert_int_equal(volux_image_load(ctx, path, &back), VOLUX_OK);
        if (memcmp(back.rgb, src.rgb, sizeof(float) * (size_t)(w * h * 3)) != 0)
            fail_msg("%dx%d image (seed %u) did not round-trip", w, h, seed);
        volux_image_free(ctx, &src);
        volux_image_free(ctx, &back);
    }
    volux_context_destroy(ctx);
}

/* ---- Radiance HDR, hand-built ---- */

static size_t hdr_header(unsigned char *buf, const char *resolution) {
    return (size_t)sprintf((char *)buf, "#?RADIANCE\n# made by hand\nFORMAT=32-bit_rle_rgbe\nEXPOSURE=1.0\n\n%s\n",
                           resolution);
}

/* RGBE → float as Radiance: (m + 0.5)·2^(e − 136). */
static float rgbe(int m, int e) { return (float)ldexp(m + 0.5, e - 136); }

static void test_hdr_decodes_flat_and_old_rle(void **state) {
    (void)state;
    unsigned char f[256];
    size_t n = hdr_header(f, "-Y 2 +X 3");
    /* Row 0: three flat pixels. Row 1: one pixel then an old-style run of 2. */
    const unsigned char px[] = {128, 64, 32, 129, 0, 0, 0, 0, 255, 1, 2, 140,
                                10, 20, 30, 128, 1, 1, 1, 2};
    memcpy(f + n, px, sizeof px);
    n += sizeof px;
    volux_context *ctx = tu_context(1);
    volux_image img;
    assert_int_equal(volux_hdr_read_memory(ctx, "mem.hdr", f, n, &img), VOLUX_OK);
    assert_int_equal(img.width, 3);
    assert_int_equal(img.height, 2);
    assert_true(at(&img, 0, 0, 0) == rgbe(128, 129)); /* 128.5/128 = 1.00390625 */
    assert_true(at(&img, 0, 0, 0) == 1.00390625f);
    assert_true(at(&img, 0, 0, 2) == rgbe(32, 129));
    assert_true(at(&img, 1, 0, 1) == 0.0f); /* exponent 0 = black */
    assert_true(at(&img, 2, 0, 0) == rgbe(255, 140));
    for (int x = 0; x < 3; x++) {
        assert_true(at(&img, x, 1, 0) == rgbe(10, 128));
        assert_true(at(&img, x, 1, 2) == rgbe(30, 128));
    }
    volux_image_free(ctx, &img);
    volux_context_destroy(ctx);
}

static void test_hdr_decodes_new_rle_and_flips(void **state) {
    (void)state;
    unsigned char f[512];
    /* +Y: the first scanline is the BOTTOM row; -X: right to left. */
    size_t n = hdr_header(f, "+Y 2 -X 8");
    for (int row = 0; row < 2; row++) {
        const unsigned char start[4] = {2, 2, 0, 8};
        memcpy(f + n, start, 4);
        n += 4;
        /* R: literal 8 values; G: run of 8; B: run 3 + literal 5; E: run 8 of 128+row. */
        f[n++] = 8;
        for (int x = 0; x < 8; x++) f[n++] = (unsigned char)(10 * x + row);
        f[n++] = 128 + 8;
        f[n++] = 77;
        f[n++] = 128 + 3;
        f[n++] = 5;
        f[n++] = 5;
        for (int x = 3; x < 8; x++) f[n++] = (unsigned char)x;
        f[n++] = 128 + 8;
        f[n++] = (unsigned char)(128 + row);
    }
    volux_context *ctx = tu_context(1);
    volux_image img;
    assert_int_equal(volux_hdr_read_memory(ctx, "mem.hdr", f, n, &img), VOLUX_OK);
    for (int row = 0; row < 2; row++) {
        int y = 1 - row; /* +Y flips rows */
        for (int i = 0; i < 8; i++) {
            int x = 7 - i; /* -X mirrors columns */
            assert_true(at(&img, x, y, 0) == rgbe(10 * i + row, 128 + row));
            assert_true(at(&img, x, y, 1) == rgbe(77, 128 + row));
            assert_true(at(&img, x, y, 2) == rgbe(i < 3 ? 5 : i, 128 + row));
        }
    }
    volux_image_free(ctx, &img);
    volux_context_destroy(ctx);
}

/* ---- compare ---- */

static void test_compare_metrics_by_hand(void **state) {
    (void)state;
    volux_context *ctx = tu_context(1);
    volux_image a, b;
    assert_int_equal(volux_image_create(ctx, 2, 1, &a), VOLUX_OK);
    assert_int_equal(volux_image_create(ctx, 2, 1, &b), VOLUX_OK);
    /* reference b = (1,1,1, 0,0,0), a = b + (0.5,0,0, 0,0,-0.1) */
    for (int c = 0; c < 3; c++) b.rgb[c] = a.rgb[c] = 1.0f;
    a.rgb[0] = 1.5f;
    a.rgb[5] = -0.1f;
    volux_image_error e;
    assert_int_equal(volux_image_compare(ctx, &a, &b, &e), VOLUX_OK);
    double se = 0.25 + 0.01;
    assert_near(e.rmse, sqrt(se / 6.0), 1e-7);
    assert_near(e.rel_mse, (0.25 / 1.01 + 0.01 / 0.01) / 6.0, 1e-7);
    assert_near(e.psnr, 20.0 * log10(1.0 / sqrt(se / 6.0)), 1e-6);
    assert_near(e.max_abs, 0.5, 1e-7);
    assert_int_equal(volux_image_compare(ctx, &b, &b, &e), VOLUX_OK);
    assert_true(e.rmse == 0.0 && e.max_abs == 0.0 && isinf(e.psnr));
    volux_image_free(ctx, &a);
    volux_image_free(ctx, &b);
    volux_context_destroy(ctx);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_pfm_round_trip_is_exact),
        cmocka_unit_test(test_exr_round_trip_is_exact),
        cmocka_unit_test(test_extension_is_case_insensitive),
        cmocka_unit_test(test_pfm_file_stores_rows_bottom_to_top),
        cmocka_unit_test(test_pfm_gray_big_endian),
        cmocka_unit_test(test_png_encodes_srgb_known_values),
        cmocka_unit_test(test_png_exposure_scales_by_power_of_two),
        cmocka_unit_test(test_png_round_trip_within_quantisation),
        cmocka_unit_test(test_png_reads_gray_16bit_and_palette),
        cmocka_unit_test(test_orientation_is_kept_by_every_format),
        cmocka_unit_test(test_exr_reads_half_bgr_in_every_lossless_compression),
        cmocka_unit_test(test_exr_reads_tiled_float_with_partial_tiles),
        cmocka_unit_test(test_exr_reads_uint_luminance_as_gray),
        cmocka_unit_test(test_exr_reads_offset_data_window_and_decreasing_y),
        cmocka_unit_test(test_exr_written_by_us_is_zip_float),
        cmocka_unit_test(test_exr_tiny_compressible_images_round_trip),
        cmocka_unit_test(test_hdr_decodes_flat_and_old_rle),
        cmocka_unit_test(test_hdr_decodes_new_rle_and_flips),
        cmocka_unit_test(test_compare_metrics_by_hand),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
