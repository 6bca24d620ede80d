/* fuzz/fuzz_image_common.h — the shared body of the image reader harnesses.
 *
 * Each harness feeds the input to one from-memory reader with a small
 * memory cap (so absurd sizes fail fast instead of allocating) and aborts if
 * any context memory is left allocated afterwards: a leak on an error path
 * is a finding even in the replay build, which has no LeakSanitizer. */
#ifndef VOLUX_FUZZ_IMAGE_COMMON_H
#define VOLUX_FUZZ_IMAGE_COMMON_H

#include <stdint.h>
#include <stdlib.h>

#include "io/image_formats.h"

#define FUZZ_MAX_BYTES (16u << 20)

typedef volux_status (*fuzz_reader)(volux_context *, const char *, const void *, size_t, volux_image *);

static inline int fuzz_image_reader(fuzz_reader read, const uint8_t *data, size_t size) {
    static volux_context *ctx;
    if (!ctx) {
        volux_context_desc d = {0};
        d.threads = 1;
        d.max_bytes = FUZZ_MAX_BYTES;
        if (volux_context_create(&d, &ctx) != VOLUX_OK) abort();
    }
    volux_image img = {0};
    volux_status st = read(ctx, "fuzz-input", data, size, &img);
    if (st == VOLUX_OK) {
        /* Touch every pixel so a short buffer shows up under ASan. */
        volatile float sum = 0.0f;
        for (size_t i = 0; i < (size_t)img.width * (size_t)img.height * 3; i++) sum += img.rgb[i];
        (void)sum;
        volux_image_free(ctx, &img);
    } else if (img.rgb) {
        abort(); /* a failed read must leave *out untouched */
    }
    if (volux_context_bytes_in_use(ctx) != 0) abort();
    return 0;
}

#endif
