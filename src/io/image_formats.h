/*
 * io/image_formats.h — private API of the image readers and writers.
 *
 * Each format lives in its own file (png.c, pfm.c, exr.c, hdr.c); the public
 * entry points volux_image_load/volux_image_save in image_io.c pick one by
 * extension. Readers parse a whole file held in memory, so the fuzzers in
 * fuzz/ drive exactly the code that loads real files without touching the
 * file system. Writers stream into an open FILE that image_io.c created as a
 * temporary file; it renames the file only when the writer succeeded.
 *
 * Reader contract (all four):
 *   - `name` only labels messages ("<name>: PFM: truncated pixel data ...").
 *   - Sizes are validated with checked arithmetic against VOLUX_MAX_IMAGE_DIM,
 *     the context's max_bytes and the bytes actually present BEFORE the pixel
 *     buffer is allocated: VOLUX_ERR_LIMIT for sizes over a limit,
 *     VOLUX_ERR_FORMAT for malformed/truncated data, VOLUX_ERR_UNSUPPORTED for
 *     well-formed files using a feature we do not read, VOLUX_ERR_NOMEM.
 *   - On success *out is a new image (caller frees with volux_image_free); on
 *     failure *out is untouched and nothing is leaked.
 *   - `data` is borrowed for the call only.
 *
 * DOES NOT: open files, print, or keep state between calls.
 */
#ifndef VOLUX_IO_IMAGE_FORMATS_H
#define VOLUX_IO_IMAGE_FORMATS_H

#include <stdio.h>

#include "volux/image.h"
#include "volux/io.h"

/* PNG (libpng): 1/2/4/8/16-bit gray, gray+alpha, RGB, RGBA, palette;
 * interlaced or not. Samples are decoded as sRGB (whatever gAMA/iCCP say,
 * since our writer always writes sRGB) to linear floats. Alpha is DROPPED:
 * colour channels are kept as stored (not premultiplied, not composited). */
volux_status volux_png_read_memory(volux_context *ctx, const char *name, const void *data, size_t size,
                                   volux_image *out);

/* PFM: "PF" (RGB) or "Pf" (gray → R=G=B), either endianness (sign of the
 * scale), rows stored bottom-to-top. The magnitude of the scale is ignored. */
volux_status volux_pfm_read_memory(volux_context *ctx, const char *name, const void *data, size_t size,
                                   volux_image *out);

/* OpenEXR (C core API): part 0 of the file, scanline or tiled (level 0),
 * half/float/uint channels, any compression the library decodes. Channels
 * R,G,B → colour; else Y (or a lone channel) → gray. The data window becomes
 * the image; the display window is ignored. Deep data is UNSUPPORTED. */
volux_status volux_exr_read_memory(volux_context *ctx, const char *name, const void *data, size_t size,
                                   volux_image *out);

/* Radiance RGBE (.hdr/.pic): "#?RADIANCE" or "#?RGBE", FORMAT=32-bit_rle_rgbe,
 * resolution "±Y H ±X W" (X-major orientations are UNSUPPORTED), new-style RLE,
 * old-style RLE and flat scanlines. EXPOSURE= lines are ignored. */
volux_status volux_hdr_read_memory(volux_context *ctx, const char *name, const void *data, size_t size,
                                   volux_image *out);

/* 8-bit sRGB code of a linear value (after exposure): exactly
 * volux_srgb8_reference (sRGB curve, clamp, ×255 + 0.5, truncate; NaN and
 * negatives → 0), by a threshold search. volux_srgb8_init() must have run
 * (it is idempotent and thread-safe). */
void volux_srgb8_init(void);
unsigned char volux_srgb8(float v);
unsigned char volux_srgb8_reference(float v);

/* Writers. `f` is an open binary stream positioned at 0; `name` labels
 * messages. They report VOLUX_ERR_WRITE for stream failures and leave
 * closing, syncing and renaming to the caller. */
/* 8-bit RGB, tone-mapped: ×2^exposure, sRGB transfer function, clamp. */
volux_status volux_png_write_stream(volux_context *ctx, const char *name, FILE *f, const volux_image *img,
                                    float exposure, const volux_image_meta *meta);
/* "PF", little-endian (scale −1), rows bottom-to-top as the format wants. */
volux_status volux_pfm_write_stream(volux_context *ctx, const char *name, FILE *f, const volux_image *img);
/* Scanline, channels B,G,R as 32-bit float (exact round trip), ZIP. */
volux_status volux_exr_write_stream(volux_context *ctx, const char *name, FILE *f, const volux_image *img,
                                    const volux_image_meta *meta);
/* The same with extra layers (volux_image_save_layers; n may be 0). */
volux_status volux_exr_write_stream_layers(volux_context *ctx, const char *name, FILE *f, const volux_image *img,
                                           const volux_image_meta *meta, const volux_image_layer *layers, int n);
/* The readers above with metadata (meta may be NULL; see io.h). */
volux_status volux_png_read_memory_meta(volux_context *ctx, const char *name, const void *data, size_t size,
                                        volux_image *out, volux_image_meta *meta);
volux_status volux_exr_read_memory_meta(volux_context *ctx, const char *name, const void *data, size_t size,
                                        volux_image *out, volux_image_meta *meta);

/* ---- shared helpers (image_io.c / lib_alloc.c) ---- */

/* Validates a declared width×height without allocating: VOLUX_ERR_FORMAT
 * for an empty image, VOLUX_ERR_LIMIT beyond VOLUX_MAX_IMAGE_DIM or the
 * context's max_bytes; messages name `name` and `format`. */
volux_status volux_io_check_image_size(volux_context *ctx, const char *name, const char *format, int64_t width,
                                       int64_t height);
/* Same checks, then allocates the (zeroed) image. Readers call this only
 * after they have checked that the file can hold the pixels it declares. */
volux_status volux_io_image_alloc(volux_context *ctx, const char *name, const char *format, int64_t width,
                                  int64_t height, volux_image *out);

/* Allocator bridge for libpng and OpenEXR, whose free callbacks get no size:
 * each block carries a small header with its size and context, so library
 * memory is accounted in volux_context_bytes_in_use and one block can never
 * exceed the context's max_bytes (a corrupt header cannot make a library
 * allocate gigabytes on our behalf). */
void *volux_io_lib_alloc(volux_context *ctx, size_t n);
void volux_io_lib_free(void *p);

#endif
