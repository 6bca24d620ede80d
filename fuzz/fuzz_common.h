/*
 * fuzz/fuzz_common.h — the body shared by the volume-reader harnesses:
 * run the format's parse-from-memory entry point, then the whole load path
 * on the input as an attached file held in memory, under a 1 MiB memory
 * cap, and treat any byte still allocated afterwards as a crash (leak).
 */
#ifndef VOLUX_FUZZ_COMMON_H
#define VOLUX_FUZZ_COMMON_H

#include <stdint.h>
#include <stdlib.h>

#include "core/volume_internal.h"
#include "io/volume_formats.h"

typedef volux_status (*fuzz_parse_fn)(volux_context *ctx, const uint8_t *data, size_t size,
                                      volux_volume_header *out);

static inline void fuzz_volume_input(const uint8_t *data, size_t size, fuzz_parse_fn parse, volux_volume_format format,
                                     const char *name) {
    volux_context_desc d = {0};
    d.threads = 1;
    d.max_bytes = 1u << 20;
    volux_context *ctx;
    if (volux_context_create(&d, &ctx) != VOLUX_OK) return;

    volux_volume_header h;
    if (parse(ctx, data, size, &h) == VOLUX_OK) {
        /* An accepted header must describe something we can afford. */
        size_t bytes = volux_volume_storage_bytes(h.dims, h.apply_scale ? VOLUX_FLOAT32 : h.type);
        if (bytes == 0 || (uint64_t)bytes > d.max_bytes) abort();
    }

    volux_volume_load_options o = {0};
    o.use_file_origin = size & 1; /* exercise both origin paths */
    volux_volume *v = NULL;
    if (volux_volume_load_memory(ctx, data, size, name, format, &o, &v) == VOLUX_OK) {
        double lo, hi;
        volux_volume_range(v, &lo, &hi);
        if (!(lo <= hi)) abort();
        volux_volume_release(v);
    } else if (v) {
        abort(); /* out-params are written only on success */
    }
    if (volux_context_bytes_in_use(ctx) != 0) abort(); /* a leak through the context */
    volux_context_destroy(ctx);
}

#endif
