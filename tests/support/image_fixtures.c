/* tests/support/image_fixtures.c — see image_fixtures.h. */
#include "image_fixtures.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "test_util.h"

float fx_pattern_value(int x, int y, int c) { return 0.125f * (float)(1 + c) + 0.25f * (float)x + 2.0f * (float)y; }

void fx_pattern(volux_context *ctx, int w, int h, volux_image *out) {
    assert_int_equal(volux_image_create(ctx, w, h, out), VOLUX_OK);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            for (int c = 0; c < 3; c++) out->rgb[((size_t)y * w + x) * 3 + c] = fx_pattern_value(x, y, c);
}

unsigned char *fx_read_file(const char *path, size_t *size) {
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    unsigned char *buf = malloc((size_t)n + 1);
    assert_non_null(buf);
    assert_int_equal(fread(buf, 1, (size_t)n, f), (size_t)n);
    fclose(f);
    *size = (size_t)n;
    return buf;
}

fx_exr_options fx_exr;

static void quiet(exr_const_context_t c, exr_result_t code, const char *msg) {
    (void)c;
    (void)code;
    (void)msg;
}

/* Encodes one chunk from planar float data (plane k = channel k). */
static exr_result_t encode_chunk(exr_context_t exr, exr_chunk_info_t *ci, exr_encode_pipeline_t *enc, int *init,
                                 const float *planes, int w, int h, int x0, int y0, const char *const *channels,
                                 int n_channels) {
    exr_result_t rv = *init ? exr_encoding_update(exr, 0, ci, enc) : exr_encoding_initialize(exr, 0, ci, enc);
    if (rv) return rv;
    *init = 1;
    for (int c = 0; c < enc->channel_count; c++) {
        exr_coding_channel_info_t *ch = &enc->channels[c];
        for (int k = 0; k < n_channels; k++)
            if (!strcmp(ch->channel_name, channels[k]))
                ch->encode_from_ptr = (const uint8_t *)(planes + (size_t)k * w * h + (size_t)y0 * w + x0);
        ch->user_pixel_stride = 4;
        ch->user_line_stride = 4 * w;
        ch->user_bytes_per_element = 4;
        ch->user_data_type = EXR_PIXEL_FLOAT;
    }
    rv = exr_encoding_choose_default_routines(exr, 0, enc);
    return rv ? rv : exr_encoding_run(exr, 0, enc);
}

exr_result_t fx_write_exr(const char *path, int w, int h, const char *const *channels, int n_channels,
                          exr_pixel_type_t type, exr_compression_t compression, int tile_w, int tile_h,
                          fx_value_fn value) {
    float *planes = malloc(sizeof(float) * (size_t)w * h * n_channels);
    assert_non_null(planes);
    for (int k = 0; k < n_channels; k++)
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++) planes[(size_t)k * w * h + (size_t)y * w + x] = value(x, y, k);
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = quiet;
    exr_context_t exr = NULL;
    int part = 0, enc_init = 0;
    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    exr_result_t rv = exr_start_write(&exr, path, EXR_WRITE_FILE_DIRECTLY, &init);
    if (!rv) rv = exr_add_part(exr, NULL, tile_w ? EXR_STORAGE_TILED : EXR_STORAGE_SCANLINE, &part);
    if (!rv) {
        exr_attr_box2i_t dw = {{{{fx_exr.origin_x, fx_exr.origin_y}}},
                               {{{fx_exr.origin_x + w - 1, fx_exr.origin_y + h - 1}}}};
        exr_attr_v2f_t center = {{{0.0f, 0.0f}}};
        rv = exr_initialize_required_attr(exr, part, &dw, &dw, 1.0f, &center, 1.0f,
                                          fx_exr.decreasing_y ? EXR_LINEORDER_DECREASING_Y
                                                              : EXR_LINEORDER_INCREASING_Y,
                                          compression);
    }
    if (!rv && tile_w)
        rv = exr_set_tile_descriptor(exr, part, (uint32_t)tile_w, (uint32_t)tile_h, EXR_TILE_ONE_LEVEL,
                                     EXR_TILE_ROUND_DOWN);
    for (int k = 0; k < n_channels && !rv; k++)
        rv = exr_add_channel(exr, part, channels[k], type, EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1);
    if (!rv) rv = exr_write_header(exr);
    if (!rv && tile_w) {
        for (int ty = 0; ty * tile_h < h && !rv; ty++)
            for (int tx = 0; tx * tile_w < w && !rv; tx++) {
                exr_chunk_info_t ci;
                rv = exr_write_tile_chunk_info(exr, part, tx, ty, 0, 0, &ci);
                if (!rv)
                    rv = encode_chunk(exr, &ci, &enc, &enc_init, planes, w, h, tx * tile_w, ty * tile_h, channels,
                                      n_channels);
            }
    } else if (!rv) {
        int32_t lines = 1;
        rv = exr_get_scanlines_per_chunk(exr, part, &lines);
        /* Chunks go in increasing y even for DECREASING_Y files: the
         * library orders them in the file itself. */
        for (int y = 0; y < h && !rv; y += lines) {
            exr_chunk_info_t ci;
            rv = exr_write_scanline_chunk_info(exr, part, fx_exr.origin_y + y, &ci);
            if (!rv) rv = encode_chunk(exr, &ci, &enc, &enc_init, planes, w, h, 0, y, channels, n_channels);
        }
    }
    if (enc_init) exr_encoding_destroy(exr, &enc);
    exr_result_t fin = exr ? exr_finish(&exr) : EXR_ERR_SUCCESS;
    free(planes);
    return rv ? rv : fin;
}

static void *counting_alloc(void *user, void *ptr, size_t old_size, size_t new_size) {
    fx_alloc_stats *s = user;
    (void)old_size;
    if (new_size == 0) {
        free(ptr);
        return NULL;
    }
    s->count++;
    if (s->fail_at && s->count == s->fail_at) return NULL;
    if (new_size > s->largest) s->largest = new_size;
    return realloc(ptr, new_size);
}

volux_context *fx_counting_context(fx_alloc_stats *stats, uint64_t max_bytes) {
    volux_context_desc d = {0};
    d.threads = 1;
    d.max_bytes = max_bytes;
    d.alloc = counting_alloc;
    d.alloc_user = stats;
    volux_context *ctx = NULL;
    assert_int_equal(volux_context_create(&d, &ctx), VOLUX_OK);
    return ctx;
}
