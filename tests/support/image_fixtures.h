/*
 * tests/support/image_fixtures.h — images and files for the image I/O tests.
 *
 * Everything is generated: tests use no data from outside the repository.
 */
#ifndef VOLUX_IMAGE_FIXTURES_H
#define VOLUX_IMAGE_FIXTURES_H

#include <OpenEXR/openexr.h>
#include <stddef.h>

#include "volux/volux.h"

/* An asymmetric w×h image whose every value is distinct and exactly
 * representable as a half float (so EXR half files can be compared
 * exactly): value(x, y, c) = 1 + x/4 + y + c/8 ... scaled into [0.125, ~h]. */
void fx_pattern(volux_context *ctx, int w, int h, volux_image *out);
float fx_pattern_value(int x, int y, int c);

/* Reads a whole file (malloc'd; caller frees). Fails the test if missing. */
unsigned char *fx_read_file(const char *path, size_t *size);

/* Writes an EXR with the OpenEXR library itself (not our writer), so our
 * reader is checked against the library's idea of the format. Channels are
 * given by name; channel k of pixel (x, y) holds value(x, y, k). tile_w = 0
 * means scanline storage. Returns the result of the library calls. */
typedef float (*fx_value_fn)(int x, int y, int c);
exr_result_t fx_write_exr(const char *path, int w, int h, const char *const *channels, int n_channels,
                          exr_pixel_type_t type, exr_compression_t compression, int tile_w, int tile_h,
                          fx_value_fn value);

/* Layout knobs for fx_write_exr (zero = defaults: origin 0,0, increasing Y). */
typedef struct fx_exr_options {
    int origin_x, origin_y;   /* data window minimum */
    int decreasing_y;         /* line order DECREASING_Y (scanline files) */
} fx_exr_options;
extern fx_exr_options fx_exr;

/* An allocator that counts: the largest single request, and it can fail the
 * fail_at-th allocation (0 = never). */
typedef struct fx_alloc_stats {
    size_t largest;
    size_t count;
    size_t fail_at;
} fx_alloc_stats;
volux_context *fx_counting_context(fx_alloc_stats *stats, uint64_t max_bytes);

#endif
