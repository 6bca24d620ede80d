/* fuzz/fuzz_ambient_table.c — libFuzzer harness for the ambient
 * preintegration table reader (volux_ambient_table_load_memory; the same
 * code reads `techniques.ambient.table_file` and the cache folder). An
 * accepted table holds only finite, non-negative radiance; nothing larger
 * than the input can have been allocated for it (the header's claims are
 * checked against the bytes present first, issue 34 C9); and any context
 * memory left afterwards is a finding (leak on an error path). */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>

#include "io/ambient_table_file.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

typedef struct largest {
    size_t bytes;
} largest;

static void *tracking_alloc(void *user, void *ptr, size_t old_size, size_t new_size) {
    (void)old_size;
    largest *l = user;
    if (!new_size) {
        free(ptr);
        return NULL;
    }
    if (new_size > l->bytes) l->bytes = new_size;
    return realloc(ptr, new_size);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    static volux_context *ctx;
    static largest seen;
    if (!ctx) {
        volux_context_desc d = {0};
        d.threads = 1;
        d.max_bytes = 1u << 20;
        d.cache_dir = "";
        d.alloc = tracking_alloc;
        d.alloc_user = &seen;
        if (volux_context_create(&d, &ctx) != VOLUX_OK) abort();
    }
    seen.bytes = 0;
    volux_ambient_table t;
    if (volux_ambient_table_load_memory(ctx, data, size, "fuzz-input", &t) == VOLUX_OK) {
        size_t n = volux_ambient_table_values(&t.desc);
        for (size_t i = 0; i < n; i++)
            if (!(t.data[i] >= 0.0f) || !isfinite(t.data[i])) abort();
        volux_ambient_table_free(ctx, &t);
    }
    /* every value comes from four bytes of the input (plus small buffers) */
    if (seen.bytes > size + 4096) abort();
    volux_context_clear_error(ctx);
    if (volux_context_bytes_in_use(ctx) != 0) abort();
    return 0;
}
