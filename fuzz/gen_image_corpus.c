/* fuzz/gen_image_corpus.c — writes the seed corpora fuzz/corpus/{png,pfm,exr,hdr}.
 *
 * Not part of the build (only fuzz_*.c are harnesses). Regenerate with:
 *   cc -Iinclude -Itests/support fuzz/gen_image_corpus.c build/tests/libvolux_test_support.a \
 *      build/libvolux.a -lcmocka -lpng -lz -lOpenEXRCore-3_1 -lm -fopenmp -o /tmp/gen && /tmp/gen fuzz/corpus
 * Every seed is a small valid file from our writers or the libraries' own,
 * plus hand-made edge cases; crashers found later are added beside them. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>
#include <png.h>

#include "image_fixtures.h"

static char dir[512];

static const char *out(const char *sub, const char *name) {
    static char p[1024];
    snprintf(p, sizeof p, "%s/%s/%s", dir, sub, name);
    return p;
}

static void raw(const char *sub, const char *name, const void *data, size_t n) {
    FILE *f = fopen(out(sub, name), "wb");
    if (!f || fwrite(data, 1, n, f) != n) abort();
    fclose(f);
}

static float v3(int x, int y, int c) { return fx_pattern_value(x, y, c) / 8.0f; }

static void pngs(volux_context *ctx, const volux_image *img) {
    volux_image_save(ctx, out("png", "rgb8_ours.png"), img, 0.0f);
    static const struct {
        const char *name;
        png_uint_32 format;
    } f[] = {{"gray8.png", PNG_FORMAT_GRAY},   {"gray16.png", PNG_FORMAT_LINEAR_Y},
             {"ga8.png", PNG_FORMAT_GA},       {"rgba8.png", PNG_FORMAT_RGBA},
             {"rgba16.png", PNG_FORMAT_LINEAR_RGB_ALPHA}, {"palette.png", PNG_FORMAT_RGB_COLORMAP}};
    unsigned char buf[16 * 16 * 8];
    for (size_t i = 0; i < sizeof buf; i++) buf[i] = (unsigned char)(i * 37 % 251);
    unsigned char cmap[256 * 3];
    for (int i = 0; i < 256 * 3; i++) cmap[i] = (unsigned char)(i * 7);
    for (size_t k = 0; k < sizeof f / sizeof f[0]; k++) {
        png_image im;
        memset(&im, 0, sizeof im);
        im.version = PNG_IMAGE_VERSION;
        im.width = 9;
        im.height = 6;
        im.format = f[k].format;
        if (f[k].format & PNG_FORMAT_FLAG_COLORMAP) im.colormap_entries = 16;
        if (!png_image_write_to_file(&im, out("png", f[k].name), 0, buf, 0, cmap)) abort();
    }
}

/* Adam7-interlaced 8-bit RGB via the full libpng API (the simplified API
 * cannot interlace). */
static void png_interlaced(void) {
    FILE *f = fopen(out("png", "interlaced_rgb8.png"), "wb");
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, NULL, NULL, NULL);
    png_infop info = png_create_info_struct(png);
    if (!f || !png || !info || setjmp(png_jmpbuf(png))) abort();
    png_init_io(png, f);
    png_set_IHDR(png, info, 11, 9, 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_ADAM7, PNG_COMPRESSION_TYPE_DEFAULT,
                 PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    unsigned char rows[9][33];
    png_bytep ptrs[9];
    for (int y = 0; y < 9; y++) {
        for (int i = 0; i < 33; i++) rows[y][i] = (unsigned char)(y * 25 + i * 7);
        ptrs[y] = rows[y];
    }
    png_write_image(png, ptrs);
    png_write_end(png, info);
    png_destroy_write_struct(&png, &info);
    fclose(f);
}

static void exrs(volux_context *ctx, const volux_image *img) {
    volux_image_save(ctx, out("exr", "rgb_float_zip_ours.exr"), img, 0.0f);
    const char *bgr[3] = {"B", "G", "R"}, *y[1] = {"Y"}, *abgr[4] = {"A", "B", "G", "R"};
    static const struct {
        const char *name;
        exr_compression_t comp;
    } c[] = {{"half_none.exr", EXR_COMPRESSION_NONE}, {"half_rle.exr", EXR_COMPRESSION_RLE},
             {"half_zips.exr", EXR_COMPRESSION_ZIPS}, {"half_zip.exr", EXR_COMPRESSION_ZIP},
             {"half_piz.exr", EXR_COMPRESSION_PIZ},   {"half_pxr24.exr", EXR_COMPRESSION_PXR24},
             {"half_b44.exr", EXR_COMPRESSION_B44},   {"half_b44a.exr", EXR_COMPRESSION_B44A},
             {"half_dwaa.exr", EXR_COMPRESSION_DWAA}, {"half_dwab.exr", EXR_COMPRESSION_DWAB}};
    for (size_t k = 0; k < sizeof c / sizeof c[0]; k++)
        fx_write_exr(out("exr", c[k].name), 11, 9, bgr, 3, EXR_PIXEL_HALF, c[k].comp, 0, 0, v3);
    fx_write_exr(out("exr", "tiled_float_zip.exr"), 10, 7, bgr, 3, EXR_PIXEL_FLOAT, EXR_COMPRESSION_ZIP, 4, 3, v3);
    fx_write_exr(out("exr", "tiled_abgr_piz.exr"), 9, 9, abgr, 4, EXR_PIXEL_HALF, EXR_COMPRESSION_PIZ, 4, 4, v3);
    fx_write_exr(out("exr", "y_uint_none.exr"), 6, 5, y, 1, EXR_PIXEL_UINT, EXR_COMPRESSION_NONE, 0, 0, v3);
    fx_write_exr(out("exr", "y_float_rle.exr"), 6, 5, y, 1, EXR_PIXEL_FLOAT, EXR_COMPRESSION_RLE, 0, 0, v3);
    fx_exr.origin_x = -3;
    fx_exr.origin_y = 5;
    fx_exr.decreasing_y = 1;
    fx_write_exr(out("exr", "window_decreasing_piz.exr"), 9, 40, bgr, 3, EXR_PIXEL_HALF, EXR_COMPRESSION_PIZ, 0, 0, v3);
    memset(&fx_exr, 0, sizeof fx_exr);
}

static size_t hdr_header(unsigned char *b, const char *res) {
    return (size_t)sprintf((char *)b, "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n%s\n", res);
}

static void hdrs(void) {
    unsigned char b[4096];
    size_t n = hdr_header(b, "-Y 3 +X 4");
    for (int i = 0; i < 12; i++) {
        b[n++] = (unsigned char)(i * 20);
        b[n++] = 100;
        b[n++] = 7;
        b[n++] = (unsigned char)(120 + i);
    }
    raw("hdr", "flat.hdr", b, n);
    n = hdr_header(b, "-Y 2 +X 5");
    const unsigned char old[] = {9, 9, 9, 130, 1, 1, 1, 4, 5, 5, 5, 129, 1, 1, 1, 2, 1, 1, 1, 0, 7, 7, 7, 128, 6, 6, 6, 128};
    memcpy(b + n, old, sizeof old);
    raw("hdr", "old_rle.hdr", b, n + sizeof old);
    n = hdr_header(b, "+Y 2 -X 10");
    for (int row = 0; row < 2; row++) {
        const unsigned char start[4] = {2, 2, 0, 10};
        memcpy(b + n, start, 4);
        n += 4;
        for (int k = 0; k < 4; k++) {
            b[n++] = 128 + 6;
            b[n++] = (unsigned char)(k * 50 + row);
            b[n++] = 4;
            for (int i = 0; i < 4; i++) b[n++] = (unsigned char)(120 + i);
        }
    }
    raw("hdr", "new_rle_flipped.hdr", b, n);
}

int main(int argc, char **argv) {
    snprintf(dir, sizeof dir, "%s", argc > 1 ? argv[1] : "fuzz/corpus");
    volux_context *ctx = NULL;
    volux_context_create(NULL, &ctx);
    volux_image img;
    volux_image_create(ctx, 9, 6, &img);
    for (int y = 0; y < 6; y++)
        for (int x = 0; x < 9; x++)
            for (int c = 0; c < 3; c++) img.rgb[(y * 9 + x) * 3 + c] = v3(x, y, c);
    pngs(ctx, &img);
    png_interlaced();
    volux_image_save(ctx, out("pfm", "rgb_le_ours.pfm"), &img, 0.0f);
    exrs(ctx, &img);
    hdrs();
    /* Hand-made PFM edge cases. */
    raw("pfm", "gray_be.pfm", "Pf\n2 1\n1\n\x3f\x80\x00\x00\x40\x00\x00\x00", 17);
    raw("pfm", "exp_scale.pfm", "PF 1 1 -1e0\n\0\0\x80\x3f\0\0\0\x40\0\0\x40\x40", 24);
    volux_image_free(ctx, &img);
    volux_context_destroy(ctx);
    return 0;
}
