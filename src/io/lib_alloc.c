/* io/lib_alloc.c — routes libpng/OpenEXR allocations through the context.
 *
 * Their free callbacks pass only the pointer, while volux_free needs the size
 * (for accounting) and the context. So every block starts with a header
 * holding both; the header is 16 bytes, which keeps the payload aligned for
 * any type the libraries store (max_align_t on x86-64/aarch64). */
#include <stdalign.h>
#include <stddef.h>

#include "core/context_internal.h"
#include "image_formats.h"

typedef struct lib_block {
    alignas(16) volux_context *ctx;
    size_t size; /* payload bytes */
} lib_block;

_Static_assert(sizeof(lib_block) % 16 == 0, "payload must stay 16-byte aligned");

void *volux_io_lib_alloc(volux_context *ctx, size_t n) {
    size_t total;
    /* One library block never exceeds the cap on one image allocation. */
    if (!ctx || (uint64_t)n > volux_context_max_bytes(ctx) || !volux_add_size(n, sizeof(lib_block), &total))
        return NULL;
    lib_block *b = volux_malloc(ctx, total);
    if (!b) return NULL;
    b->ctx = ctx;
    b->size = n;
    return b + 1;
}

void volux_io_lib_free(void *p) {
    if (!p) return;
    lib_block *b = (lib_block *)p - 1;
    volux_free(b->ctx, b, b->size + sizeof(lib_block));
}
