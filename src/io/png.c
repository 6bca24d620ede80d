/* io/png.c — PNG through libpng.
 *
 * libpng reports errors by longjmp. Everything a failed call must release
 * lives in a png_job reached through a pointer (never in locals changed
 * after setjmp, whose values a longjmp leaves indeterminate), so one cleanup
 * path serves both the normal return and the error jump. All of libpng's
 * memory comes from the context (volux_io_lib_alloc). */
#include <errno.h>
#include <math.h>
#include <png.h>
#include <string.h>

#include "core/context_internal.h"
#include "image_formats.h"
#include "volux/io.h"

#define PNG "PNG"

/* Deflate never expands data by more than 1032:1 (zlib technical details:
 * a 258-byte match costs at least 2 bits), so a file smaller than the
 * filtered image / 1032 must be truncated: rejected before allocating. */
#define DEFLATE_MAX_RATIO 1032u

typedef struct png_job {
    volux_context *ctx;
    const char *name;
    char message[192];     /* libpng's error message */
    size_t failed_alloc;   /* size of an allocation that failed, or 0 */
    const unsigned char *data; /* read source */
    size_t size, pos;
    FILE *f;               /* write sink */
    int write_errno;
    unsigned char *rows;   /* row buffer(s) */
    size_t rows_bytes;
    volux_image image;     /* output being decoded */
    volux_image_meta *meta; /* text chunks, when asked */
} png_job;

static void on_error(png_structp png, png_const_charp msg) {
    png_job *job = png_get_error_ptr(png);
    snprintf(job->message, sizeof job->message, "%s", msg);
    png_longjmp(png, 1);
}

static void on_warning(png_structp png, png_const_charp msg) {
    (void)png; /* the library never prints; warnings change nothing we return */
    (void)msg;
}

static png_voidp on_malloc(png_structp png, png_alloc_size_t n) {
    png_job *job = png_get_mem_ptr(png);
    void *p = volux_io_lib_alloc(job->ctx, n);
    if (!p) job->failed_alloc = n ? n : 1;
    return p;
}

static void on_free(png_structp png, png_voidp p) {
    (void)png;
    volux_io_lib_free(p);
}

static void read_memory(png_structp png, png_bytep dst, size_t n) {
    png_job *job = png_get_io_ptr(png);
    if (n > job->size - job->pos) png_error(png, "truncated file");
    memcpy(dst, job->data + job->pos, n);
    job->pos += n;
}

static void write_stream(png_structp png, png_bytep src, size_t n) {
    png_job *job = png_get_io_ptr(png);
    if (fwrite(src, 1, n, job->f) != n) {
        job->write_errno = errno;
        png_error(png, "write failed");
    }
}

static void flush_stream(png_structp png) { (void)png; /* image_io.c flushes and syncs */ }

/* Status for a libpng failure: our allocator or sink failing, else bad data. */
static volux_status job_error(png_job *job, int writing) {
    volux_context *ctx = job->ctx;
    if (job->failed_alloc > volux_context_max_bytes(ctx))
        return volux_error(ctx, VOLUX_ERR_LIMIT, "%s: " PNG ": libpng asked for %zu bytes, over the memory cap",
                           job->name, job->failed_alloc);
    if (job->failed_alloc)
        return volux_error(ctx, VOLUX_ERR_NOMEM, "%s: " PNG ": out of memory (%zu bytes)", job->name,
                           job->failed_alloc);
    if (writing)
        return volux_error(ctx, VOLUX_ERR_WRITE, "cannot write '%s': %s", job->name,
                           job->write_errno ? strerror(job->write_errno) : job->message);
    return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: " PNG ": %s", job->name, job->message);
}

static uint32_t be32(const unsigned char *p) {
    return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | p[3];
}

/* Signature and declared size straight from the IHDR bytes, so an absurd
 * size is VOLUX_ERR_LIMIT and a too-short file VOLUX_ERR_FORMAT before
 * libpng allocates anything. libpng re-validates IHDR itself. */
static volux_status precheck(volux_context *ctx, const char *name, const unsigned char *d, size_t size) {
    if (size < 8 || png_sig_cmp(d, 0, 8) != 0)
        return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: " PNG ": not a PNG file (bad signature)", name);
    if (size < 33 || be32(d + 8) != 13 || memcmp(d + 12, "IHDR", 4) != 0)
        return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: " PNG ": missing or bad IHDR chunk", name);
    uint32_t w = be32(d + 16), h = be32(d + 20);
    volux_status st = volux_io_check_image_size(ctx, name, PNG, w, h);
    if (st) return st;
    /* Worst case 8 bytes per pixel (RGBA16) plus a filter byte per row. */
    unsigned bit_depth = d[24], color_type = d[25];
    unsigned channels = color_type == 2 ? 3 : color_type == 4 ? 2 : color_type == 6 ? 4 : 1;
    uint64_t row_bits = (uint64_t)w * channels * (bit_depth ? bit_depth : 1);
    uint64_t raw = (uint64_t)h * ((row_bits + 7) / 8 + 1);
    if ((uint64_t)size * DEFLATE_MAX_RATIO < raw)
        return volux_error(ctx, VOLUX_ERR_FORMAT,
                           "%s: " PNG ": truncated: %zu bytes cannot hold a %ux%u image (%llu bytes unpacked)", name,
                           size, w, h, (unsigned long long)raw);
    return VOLUX_OK;
}

/* Converts one decoded row (RGB, 8 or 16 bits) to linear floats. */
static void convert_row(const unsigned char *src, float *dst, size_t n_values, int depth, const float *lut8) {
    if (depth == 8) {
        for (size_t i = 0; i < n_values; i++) dst[i] = lut8[src[i]];
    } else {
        for (size_t i = 0; i < n_values; i++)
            dst[i] = volux_srgb_decode((float)(src[2 * i] << 8 | src[2 * i + 1]) / 65535.0f);
    }
}

/* The libpng part of reading; may longjmp back into itself only. */
static volux_status decode(png_job *job, png_structp png, png_infop info) {
    if (setjmp(png_jmpbuf(png))) return job_error(job, 0);
    png_set_read_fn(png, job, read_memory);
    png_set_user_limits(png, VOLUX_MAX_IMAGE_DIM, VOLUX_MAX_IMAGE_DIM);
    /* Ancillary chunks (text, ICC profiles) are not ours to keep: bound how
     * many libpng caches and how large one may inflate to. */
    png_set_chunk_cache_max(png, 128);
    png_set_chunk_malloc_max(png, 4u << 20);
    png_read_info(png, info);
    if (job->meta) {
        png_textp text = NULL;
        int n = png_get_text(png, info, &text, NULL);
        for (int i = 0; i < n; i++)
            if (text[i].key && text[i].text) volux_image_meta_set(job->meta, text[i].key, text[i].text);
    }

    png_uint_32 w, h;
    int depth, color, interlace;
    png_get_IHDR(png, info, &w, &h, &depth, &color, &interlace, NULL, NULL);
    if (color == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
    if (color == PNG_COLOR_TYPE_GRAY && depth < 8) png_set_expand_gray_1_2_4_to_8(png);
    if (color == PNG_COLOR_TYPE_GRAY || color == PNG_COLOR_TYPE_GRAY_ALPHA) png_set_gray_to_rgb(png);
    png_set_strip_alpha(png); /* alpha is dropped, see image_formats.h */
    int passes = png_set_interlace_handling(png);
    png_read_update_info(png, info);
    depth = png_get_bit_depth(png, info);
    size_t row_bytes = png_get_rowbytes(png, info);
    if (png_get_channels(png, info) != 3 || (depth != 8 && depth != 16) || row_bytes != (size_t)w * 3 * (size_t)depth / 8)
        png_error(png, "unexpected layout after transformations");

    /* Interlaced images need every row at once (each pass fills some). */
    size_t n_rows = passes > 1 ? h : 1;
    if ((uint64_t)row_bytes * n_rows > volux_context_max_bytes(job->ctx))
        return volux_error(job->ctx, VOLUX_ERR_LIMIT, "%s: " PNG ": interlaced %ux%u image needs too much memory",
                           job->name, (unsigned)w, (unsigned)h);
    volux_status st = volux_io_image_alloc(job->ctx, job->name, PNG, w, h, &job->image);
    if (st) return st;
    job->rows_bytes = row_bytes * n_rows;
    job->rows = volux_malloc(job->ctx, job->rows_bytes);
    if (!job->rows) return volux_error(job->ctx, VOLUX_ERR_NOMEM, "%s: " PNG ": out of memory for rows", job->name);

    float lut8[256];
    for (int i = 0; i < 256; i++) lut8[i] = volux_srgb_decode((float)i / 255.0f);
    size_t n_values = (size_t)w * 3;
    for (int pass = 0; pass < passes; pass++) {
        for (png_uint_32 y = 0; y < h; y++) {
            unsigned char *row = job->rows + (passes > 1 ? (size_t)y * row_bytes : 0);
            png_read_row(png, row, NULL);
            if (passes == 1) convert_row(row, job->image.rgb + (size_t)y * n_values, n_values, depth, lut8);
        }
    }
    if (passes > 1)
        for (png_uint_32 y = 0; y < h; y++)
            convert_row(job->rows + (size_t)y * row_bytes, job->image.rgb + (size_t)y * n_values, n_values, depth,
                        lut8);
    /* Trailing chunks are not read: a damaged tail after the last row does
     * not make the pixels wrong. */
    return VOLUX_OK;
}

volux_status volux_png_read_memory(volux_context *ctx, const char *name, const void *data, size_t size,
                                   volux_image *out) {
    return volux_png_read_memory_meta(ctx, name, data, size, out, NULL);
}

volux_status volux_png_read_memory_meta(volux_context *ctx, const char *name, const void *data, size_t size,
                                        volux_image *out, volux_image_meta *meta) {
    volux_status st = precheck(ctx, name, data, size);
    if (st) return st;
    png_job job = {0};
    job.meta = meta;
    job.ctx = ctx;
    job.name = name;
    job.data = data;
    job.size = size;
    png_structp png = png_create_read_struct_2(PNG_LIBPNG_VER_STRING, &job, on_error, on_warning, &job, on_malloc,
                                               on_free);
    if (!png) return volux_error(ctx, VOLUX_ERR_NOMEM, "%s: " PNG ": out of memory", name);
    png_infop info = png_create_info_struct(png);
    if (!info) {
        png_destroy_read_struct(&png, NULL, NULL);
        return volux_error(ctx, VOLUX_ERR_NOMEM, "%s: " PNG ": out of memory", name);
    }
    st = decode(&job, png, info);
    png_destroy_read_struct(&png, &info, NULL);
    if (job.rows) volux_free(ctx, job.rows, job.rows_bytes);
    if (st) {
        volux_image_free(ctx, &job.image);
        return st;
    }
    *out = job.image;
    return VOLUX_OK;
}

/* The libpng part of writing; job->rows holds one 8-bit RGB row. */
static volux_status encode(png_job *job, png_structp png, png_infop info, const volux_image *img, float exposure,
                           const volux_image_meta *meta) {
    if (setjmp(png_jmpbuf(png))) return job_error(job, 1);
    png_set_write_fn(png, job, write_stream, flush_stream);
    png_set_IHDR(png, info, (png_uint_32)img->width, (png_uint_32)img->height, 8, PNG_COLOR_TYPE_RGB,
                 PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    /* Tag the pixels as sRGB so viewers do not apply another curve. */
    png_set_sRGB_gAMA_and_cHRM(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
    /* Text before the pixels, where readers that stop at IDAT see it. */
    png_text text[VOLUX_IMAGE_MAX_META];
    int n_text = 0;
    for (int i = 0; meta && i < meta->count && i < VOLUX_IMAGE_MAX_META; i++) {
        memset(&text[n_text], 0, sizeof text[n_text]);
        text[n_text].compression = PNG_TEXT_COMPRESSION_NONE;
        text[n_text].key = (png_charp)meta->key[i];
        text[n_text].text = (png_charp)meta->value[i];
        text[n_text].text_length = strlen(meta->value[i]);
        n_text++;
    }
    if (n_text) png_set_text(png, info, text, n_text);
    png_write_info(png, info);
    float scale = exp2f(exposure);
    size_t n_values = (size_t)img->width * 3;
    volux_srgb8_init();
    for (int y = 0; y < img->height; y++) {
        const float *src = img->rgb + (size_t)y * n_values;
        for (size_t i = 0; i < n_values; i++) job->rows[i] = volux_srgb8(src[i] * scale);
        png_write_row(png, job->rows);
    }
    png_write_end(png, info);
    return VOLUX_OK;
}

volux_status volux_png_write_stream(volux_context *ctx, const char *name, FILE *f, const volux_image *img,
                                    float exposure, const volux_image_meta *meta) {
    png_job job = {0};
    job.ctx = ctx;
    job.name = name;
    job.f = f;
    job.rows_bytes = (size_t)img->width * 3;
    job.rows = volux_alloc_or_error(ctx, job.rows_bytes, "a PNG row");
    if (!job.rows) return VOLUX_ERR_NOMEM;
    volux_status st = VOLUX_ERR_NOMEM;
    png_structp png = png_create_write_struct_2(PNG_LIBPNG_VER_STRING, &job, on_error, on_warning, &job, on_malloc,
                                                on_free);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    if (info)
        st = encode(&job, png, info, img, exposure, meta);
    else
        volux_error(ctx, st, "%s: " PNG ": out of memory", name);
    png_destroy_write_struct(&png, info ? &info : NULL);
    volux_free(ctx, job.rows, job.rows_bytes);
    return st;
}
