/*
 * core/context_internal.h — allocation and error reporting for library code.
 *
 * All heap memory goes through the context's allocator so that memory can be
 * accounted and allocation failures injected in tests. Errors are recorded
 * with volux_error(), which formats the message into the context and returns
 * the status, so a failing path reads `return volux_error(ctx, ...)`.
 */
#ifndef VOLUX_CONTEXT_INTERNAL_H
#define VOLUX_CONTEXT_INTERNAL_H

#include <stdarg.h>

#include "volux/base.h"

#define VOLUX_ERROR_MAX 1024

struct volux_context {
    int threads;
    uint64_t max_bytes;
    volux_alloc_fn alloc;
    void *alloc_user;
    volux_progress_fn progress;
    void *progress_user;
    volux_message_fn message;
    void *message_user;
    volux_status error_status;
    char error[VOLUX_ERROR_MAX];
    uint64_t bytes_in_use; /* updated atomically */
    char *cache_dir;       /* never NULL; "" = no disk cache. Allocated with
                              `alloc` but not counted in bytes_in_use, like
                              the context itself */
    uint64_t memory_limit; /* 0: the default (volux_context_memory_limit) */
    uint64_t budget;       /* memory_limit resolved: what volux_malloc holds
                              bytes_in_use under (UINT64_MAX: no limit) */
    int budget_refused;    /* set atomically by the first refusal */
    int out_of_core;       /* volux_context_set_out_of_core */
};

/* "12.3 GB" (decimal units, as `free -h` and file managers print). */
void volux_format_bytes(uint64_t bytes, char *out, size_t n);

/* Allocations (NULL on failure). Out of memory sets no message: callers
 * report. An allocation that would take the context's bytes in use past
 * its memory limit is refused before it is made; that refusal records
 * VOLUX_ERR_LIMIT naming the limit (once; the first error wins), so the
 * caller's "out of memory" report follows the real reason. */
void *volux_malloc(volux_context *ctx, size_t n);
void *volux_calloc(volux_context *ctx, size_t count, size_t size);
void *volux_realloc(volux_context *ctx, void *p, size_t old_n, size_t new_n);
void volux_free(volux_context *ctx, void *p, size_t n);
char *volux_strdup(volux_context *ctx, const char *s);
void volux_strfree(volux_context *ctx, char *s);

/* Per-slot arrays (one element per light slot): makes the array at `arr`
 * (the address of a T *) of *cap elements of `elem` bytes hold at least
 * `need`, new elements zeroed, doubling so that n slots added one by one
 * cost O(n) in all. On failure the array is unchanged and the error says
 * "out of memory for WHAT". Free with volux_free(ctx, p, *cap * elem). */
volux_status volux_grow_slots(volux_context *ctx, void *arr, int *cap, int need, size_t elem, const char *what);

/* Like the above, but sets "out of memory (N bytes) for WHAT" on failure. */
void *volux_alloc_or_error(volux_context *ctx, size_t n, const char *what);

/* 64-byte aligned, zeroed, for large arrays (volumes, caches); huge pages
 * are requested for allocations ≥ 2 MiB. Free with volux_free_aligned. */
void *volux_alloc_aligned(volux_context *ctx, size_t n);
void volux_free_aligned(volux_context *ctx, void *p, size_t n);

/* Records an error unless one is already recorded (the first error since
 * the caller last cleared wins; the library never clears) and returns
 * `status`. */
volux_status volux_error(volux_context *ctx, volux_status status, const char *fmt, ...) VOLUX_PRINTF(3, 4);
/* Prepends "prefix" to the recorded message (keeps the status). */
void volux_error_prefix(volux_context *ctx, const char *fmt, ...) VOLUX_PRINTF(2, 3);
/* Reports something the caller should know about a call that succeeded
 * (data repaired or ignored): volux_message at VOLUX_MESSAGE_WARNING. */
void volux_warn(volux_context *ctx, const char *fmt, ...) VOLUX_PRINTF(2, 3);

/* Length of the valid UTF-8 sequence at p (n bytes available), 0 if the
 * bytes there are not one (RFC 3629: no overlongs, surrogates or values
 * above U+10FFFF). */
size_t volux_utf8_sequence(const unsigned char *p, size_t n);
/* volux_escape_text: volux/base.h. */

/* Reports progress; returns nonzero if the caller asked to cancel. */
int volux_progress(volux_context *ctx, const char *task, double fraction);
/* Passes a warning or note to the caller's message callback (none: dropped),
 * escaped like error messages (\\xHH for control bytes and invalid UTF-8). */
void volux_message(volux_context *ctx, volux_message_level level, const char *fmt, ...) VOLUX_PRINTF(3, 4);

/* Checked size arithmetic: return 0 on overflow. */
static inline int volux_mul_size(size_t a, size_t b, size_t *out) {
    if (a != 0 && b > SIZE_MAX / a) return 0;
    *out = a * b;
    return 1;
}
static inline int volux_add_size(size_t a, size_t b, size_t *out) {
    if (b > SIZE_MAX - a) return 0;
    *out = a + b;
    return 1;
}

#endif
