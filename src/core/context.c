/* core/context.c — context, allocator, error messages, progress, cache folder. */
#include <limits.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <sys/mman.h>

#include "context_internal.h"
#include "parallel.h"

static void *default_alloc(void *user, void *ptr, size_t old_size, size_t new_size) {
    (void)user;
    (void)old_size;
    if (new_size == 0) {
        free(ptr);
        return NULL;
    }
    return realloc(ptr, new_size);
}

const char *volux_status_name(volux_status s) {
    switch (s) {
    case VOLUX_OK: return "ok";
    case VOLUX_ERR_INVALID: return "invalid";
    case VOLUX_ERR_IO: return "io";
    case VOLUX_ERR_FORMAT: return "format";
    case VOLUX_ERR_UNSUPPORTED: return "unsupported";
    case VOLUX_ERR_LIMIT: return "limit";
    case VOLUX_ERR_NOMEM: return "nomem";
    case VOLUX_ERR_WRITE: return "write";
    case VOLUX_ERR_CANCELLED: return "cancelled";
    case VOLUX_ERR_INTERNAL: return "internal";
    }
    return "unknown";
}

int volux_status_is_input_error(volux_status s) {
    return s == VOLUX_ERR_INVALID || s == VOLUX_ERR_IO || s == VOLUX_ERR_FORMAT ||
           s == VOLUX_ERR_UNSUPPORTED || s == VOLUX_ERR_LIMIT;
}

/* Copies `dir` (NULL: the default folder, from the environment) into
 * *out through the context's allocator, unaccounted. 0 on out of memory. */
static int copy_cache_dir(volux_context *ctx, const char *dir, char **out) {
    char def[4200] = "";
    if (!dir) {
        /* XDG Base Directory spec: user-specific non-essential data goes to
         * $XDG_CACHE_HOME, which defaults to $HOME/.cache. A name that does
         * not fit is no usable folder: no disk cache then. */
        const char *xdg = getenv("XDG_CACHE_HOME"), *home = getenv("HOME");
        int n = 0;
        if (xdg && *xdg) n = snprintf(def, sizeof def, "%s/volux", xdg);
        else if (home && *home) n = snprintf(def, sizeof def, "%s/.cache/volux", home);
        if (n < 0 || (size_t)n >= sizeof def) def[0] = 0;
        dir = def;
    }
    size_t n = strlen(dir) + 1;
    char *copy = ctx->alloc(ctx->alloc_user, NULL, 0, n);
    if (!copy) return 0;
    memcpy(copy, dir, n);
    *out = copy;
    return 1;
}

static void free_cache_dir(volux_context *ctx, char *dir) {
    if (dir) ctx->alloc(ctx->alloc_user, dir, strlen(dir) + 1, 0);
}

volux_status volux_context_create(const volux_context_desc *desc, volux_context **out) {
    volux_alloc_fn alloc = desc && desc->alloc ? desc->alloc : default_alloc;
    void *user = desc ? desc->alloc_user : NULL;
    volux_context *ctx = alloc(user, NULL, 0, sizeof *ctx);
    if (!ctx) return VOLUX_ERR_NOMEM;
    memset(ctx, 0, sizeof *ctx);
    ctx->alloc = alloc;
    ctx->alloc_user = user;
    ctx->threads = desc && desc->threads > 0 ? desc->threads : 0;
    ctx->max_bytes = desc && desc->max_bytes ? desc->max_bytes : VOLUX_DEFAULT_MAX_BYTES;
    ctx->budget = volux_context_default_memory_limit();
    ctx->progress = desc ? desc->progress : NULL;
    ctx->progress_user = desc ? desc->progress_user : NULL;
    ctx->message = desc ? desc->message : NULL;
    ctx->message_user = desc ? desc->message_user : NULL;
    if (!copy_cache_dir(ctx, desc ? desc->cache_dir : NULL, &ctx->cache_dir)) {
        alloc(user, ctx, sizeof *ctx, 0);
        return VOLUX_ERR_NOMEM;
    }
    *out = ctx;
    return VOLUX_OK;
}

void volux_context_destroy(volux_context *ctx) {
    if (!ctx) return;
    free_cache_dir(ctx, ctx->cache_dir);
    ctx->alloc(ctx->alloc_user, ctx, sizeof *ctx, 0);
}

volux_status volux_context_set_cache_dir(volux_context *ctx, const char *dir) {
    char *copy;
    if (!copy_cache_dir(ctx, dir, &copy))
        return volux_error(ctx, VOLUX_ERR_NOMEM, "cache folder: out of memory for its name");
    free_cache_dir(ctx, ctx->cache_dir);
    ctx->cache_dir = copy;
    return VOLUX_OK;
}
const char *volux_context_cache_dir(const volux_context *ctx) { return ctx->cache_dir; }

const char *volux_context_error(const volux_context *ctx) { return ctx->error; }
volux_status volux_context_error_status(const volux_context *ctx) { return ctx->error_status; }
void volux_context_clear_error(volux_context *ctx) {
    ctx->error[0] = 0;
    ctx->error_status = VOLUX_OK;
    __atomic_store_n(&ctx->budget_refused, 0, __ATOMIC_RELAXED); /* the next refusal is said again */
}
void volux_context_set_threads(volux_context *ctx, int threads) { ctx->threads = threads > 0 ? threads : 0; }
int volux_context_threads(const volux_context *ctx) {
    return ctx->threads > 0 ? ctx->threads : volux_parallel_max_threads();
}
void volux_context_set_progress(volux_context *ctx, volux_progress_fn fn, void *user) {
    ctx->progress = fn;
    ctx->progress_user = user;
}
void volux_context_set_message(volux_context *ctx, volux_message_fn fn, void *user) {
    ctx->message = fn;
    ctx->message_user = user;
}
uint64_t volux_context_max_bytes(const volux_context *ctx) { return ctx->max_bytes; }
void volux_context_set_memory_limit(volux_context *ctx, uint64_t bytes) {
    ctx->memory_limit = bytes;
    ctx->budget = volux_context_memory_limit(ctx);
    __atomic_store_n(&ctx->budget_refused, 0, __ATOMIC_RELAXED);
}

void volux_context_set_out_of_core(volux_context *ctx, int on) { ctx->out_of_core = on != 0; }
int volux_context_out_of_core(const volux_context *ctx) { return ctx->out_of_core; }

uint64_t volux_context_default_memory_limit(void) {
    /* 80 % of physical memory: the rest is the OS, the page cache the
     * volume file was read through, and allocator slack the model does not
     * count (docs/SCALE.md). MemAvailable is not used: it moves with every
     * other process, so the same render would pass or fail by chance. */
    long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
    if (pages <= 0 || page <= 0) return UINT64_MAX;
    return (uint64_t)((double)pages * (double)page * 0.8);
}

uint64_t volux_context_memory_limit(const volux_context *ctx) {
    return ctx->memory_limit ? ctx->memory_limit : volux_context_default_memory_limit();
}

uint64_t volux_context_bytes_in_use(const volux_context *ctx) {
    return __atomic_load_n(&ctx->bytes_in_use, __ATOMIC_RELAXED);
}

static void account(volux_context *ctx, size_t added, size_t removed) {
    if (added) __atomic_add_fetch(&ctx->bytes_in_use, (uint64_t)added, __ATOMIC_RELAXED);
    if (removed) __atomic_sub_fetch(&ctx->bytes_in_use, (uint64_t)removed, __ATOMIC_RELAXED);
}

/* "12.3 GB" (decimal units, as `free -h` and file managers print). */
void volux_format_bytes(uint64_t b, char *out, size_t n) {
    double x = (double)b;
    if (x >= 1e9) snprintf(out, n, "%.1f GB", x / 1e9);
    else if (x >= 1e6) snprintf(out, n, "%.1f MB", x / 1e6);
    else if (x >= 1e3) snprintf(out, n, "%.1f kB", x / 1e3);
    else snprintf(out, n, "%llu bytes", (unsigned long long)b);
}

/* The memory limit is a budget over everything the context holds (issue
 * 34 D5), not only the estimate volux_technique_create checks up front: a
 * cache an edit grows, a volume an edit loads, a frame buffer all count.
 * Concurrent allocations can overshoot by what they ask at the same time;
 * the refusal happens before the allocator is called. */
static int over_budget(volux_context *ctx, size_t added) {
    uint64_t in_use = __atomic_load_n(&ctx->bytes_in_use, __ATOMIC_RELAXED);
    if (ctx->budget == UINT64_MAX || (added <= ctx->budget && in_use <= ctx->budget - added)) return 0;
    if (!__atomic_exchange_n(&ctx->budget_refused, 1, __ATOMIC_RELAXED)) {
        char want[32], have[32], lim[32];
        volux_format_bytes((uint64_t)added, want, sizeof want);
        volux_format_bytes(in_use, have, sizeof have);
        volux_format_bytes(ctx->budget, lim, sizeof lim);
        volux_error(ctx, VOLUX_ERR_LIMIT,
                    "memory limit reached: %s more (%zu bytes) on top of the %s in use would pass the limit of %s "
                    "(%llu bytes%s); lower the volume, image or cache sizes, or raise the limit",
                    want, added, have, lim, (unsigned long long)ctx->budget,
                    ctx->memory_limit ? "" : ", 80% of physical memory");
    }
    return 1;
}

void *volux_malloc(volux_context *ctx, size_t n) {
    if (n == 0) n = 1;
    if (over_budget(ctx, n)) return NULL;
    void *p = ctx->alloc(ctx->alloc_user, NULL, 0, n);
    if (p) account(ctx, n, 0);
    return p;
}

void *volux_calloc(volux_context *ctx, size_t count, size_t size) {
    size_t n;
    if (!volux_mul_size(count, size, &n)) return NULL;
    void *p = volux_malloc(ctx, n);
    if (p) memset(p, 0, n);
    return p;
}

void *volux_realloc(volux_context *ctx, void *p, size_t old_n, size_t new_n) {
    if (!p) return volux_malloc(ctx, new_n);
    if (new_n == 0) new_n = 1;
    if (new_n > old_n && over_budget(ctx, new_n - old_n)) return NULL;
    void *q = ctx->alloc(ctx->alloc_user, p, old_n, new_n);
    if (q) account(ctx, new_n, old_n);
    return q;
}

void volux_free(volux_context *ctx, void *p, size_t n) {
    if (!p) return;
    if (n == 0) n = 1;
    ctx->alloc(ctx->alloc_user, p, n, 0);
    account(ctx, 0, n);
}

char *volux_strdup(volux_context *ctx, const char *s) {
    size_t n = strlen(s) + 1;
    char *d = volux_malloc(ctx, n);
    if (d) memcpy(d, s, n);
    return d;
}

void volux_strfree(volux_context *ctx, char *s) {
    if (s) volux_free(ctx, s, strlen(s) + 1);
}

void *volux_alloc_or_error(volux_context *ctx, size_t n, const char *what) {
    void *p = volux_malloc(ctx, n);
    if (!p) volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory (%zu bytes) for %s", n, what);
    return p;
}

/* Aligned blocks: over-allocate by the alignment and keep the offset to the
 * real start just before the returned pointer. */
#define ALIGN 64u
void *volux_alloc_aligned(volux_context *ctx, size_t n) {
    size_t total;
    if (!volux_add_size(n, ALIGN + sizeof(size_t), &total)) return NULL;
    unsigned char *raw = volux_malloc(ctx, total);
    if (!raw) return NULL;
    uintptr_t start = ((uintptr_t)raw + sizeof(size_t) + ALIGN - 1) & ~(uintptr_t)(ALIGN - 1);
    unsigned char *p = (unsigned char *)start;
    size_t offset = (size_t)(p - raw);
    memcpy(p - sizeof(size_t), &offset, sizeof offset);
#ifdef MADV_HUGEPAGE
    if (n >= (2u << 20)) {
        /* Huge pages help random access in large volumes (fewer TLB misses);
         * advisory only, failures are harmless. Advise before the memset
         * below touches the pages, so they are faulted in as huge pages. */
        uintptr_t a = (start + (2u << 20) - 1) & ~(uintptr_t)((2u << 20) - 1);
        uintptr_t e = (start + n) & ~(uintptr_t)((2u << 20) - 1);
        if (e > a) madvise((void *)a, e - a, MADV_HUGEPAGE);
    }
#endif
    memset(p, 0, n);
    return p;
}

void volux_free_aligned(volux_context *ctx, void *p, size_t n) {
    if (!p) return;
    unsigned char *q = p;
    size_t offset;
    memcpy(&offset, q - sizeof(size_t), sizeof offset);
    volux_free(ctx, q - offset, n + ALIGN + sizeof(size_t));
}

/* Length of the valid UTF-8 sequence at p (at most n bytes), 0 if none:
 * no overlong forms, no UTF-16 surrogates, nothing above U+10FFFF
 * (RFC 3629 §4). */
size_t volux_utf8_sequence(const unsigned char *p, size_t n) {
    if (n == 0) return 0;
    unsigned c = p[0];
    if (c < 0x80) return 1;
    size_t len;
    unsigned lo = 0x80, hi = 0xbf; /* range of the second byte */
    if (c >= 0xc2 && c <= 0xdf) len = 2;
    else if (c == 0xe0) len = 3, lo = 0xa0;
    else if (c >= 0xe1 && c <= 0xec) len = 3;
    else if (c == 0xed) len = 3, hi = 0x9f; /* no surrogates */
    else if (c >= 0xee && c <= 0xef) len = 3;
    else if (c == 0xf0) len = 4, lo = 0x90;
    else if (c >= 0xf1 && c <= 0xf3) len = 4;
    else if (c == 0xf4) len = 4, hi = 0x8f; /* ≤ U+10FFFF */
    else return 0;
    if (n < len || p[1] < lo || p[1] > hi) return 0;
    for (size_t i = 2; i < len; i++)
        if (p[i] < 0x80 || p[i] > 0xbf) return 0;
    return len;
}

size_t volux_escape_text(const char *in, char *out, size_t cap) {
    static const char hex[] = "0123456789abcdef";
    const unsigned char *p = (const unsigned char *)in;
    size_t n = strlen(in), o = 0;
    if (cap == 0) return 0;
    for (size_t i = 0; i < n;) {
        int plain = (p[i] >= 0x20 && p[i] != 0x7f) || p[i] == '\n' || p[i] == '\t';
        size_t len = plain ? volux_utf8_sequence(p + i, n - i) : 0;
        if (len) {
            if (o + len >= cap) break;
            memcpy(out + o, p + i, len);
            o += len;
            i += len;
        } else {
            if (o + 4 >= cap) break;
            out[o++] = '\\';
            out[o++] = 'x';
            out[o++] = hex[p[i] >> 4];
            out[o++] = hex[p[i] & 15];
            i++;
        }
    }
    out[o] = 0;
    return o;
}

/* Messages quote file names and header contents from untrusted files: a
 * terminal escape sequence or invalid UTF-8 in them must not reach the
 * caller's terminal or logs as is. Idempotent. */
static void sanitize_message(char *msg, size_t cap) {
    char tmp[VOLUX_ERROR_MAX];
    volux_escape_text(msg, tmp, sizeof tmp < cap ? sizeof tmp : cap);
    memcpy(msg, tmp, strlen(tmp) + 1);
}

volux_status volux_error(volux_context *ctx, volux_status status, const char *fmt, ...) {
    /* The first error wins (VolPack, SQLite): a later failure caused by the
     * first one must not hide it. The caller clears. */
    if (ctx->error_status != VOLUX_OK) return status;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(ctx->error, sizeof ctx->error, fmt, ap);
    va_end(ap);
    sanitize_message(ctx->error, sizeof ctx->error);
    ctx->error_status = status;
    return status;
}

volux_status volux_context_set_error(volux_context *ctx, volux_status status, const char *fmt, ...) {
    if (ctx->error_status != VOLUX_OK || status == VOLUX_OK) return status;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(ctx->error, sizeof ctx->error, fmt, ap);
    va_end(ap);
    sanitize_message(ctx->error, sizeof ctx->error);
    ctx->error_status = status;
    return status;
}

void volux_error_prefix(volux_context *ctx, const char *fmt, ...) {
    char prefix[VOLUX_ERROR_MAX], old[VOLUX_ERROR_MAX];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(prefix, sizeof prefix, fmt, ap);
    va_end(ap);
    memcpy(old, ctx->error, sizeof old);
    size_t n = strlen(prefix);
    if (n >= sizeof ctx->error) n = sizeof ctx->error - 1;
    memcpy(ctx->error, prefix, n);
    size_t m = strlen(old);
    if (m > sizeof ctx->error - 1 - n) m = sizeof ctx->error - 1 - n;
    memcpy(ctx->error + n, old, m);
    ctx->error[n + m] = 0;
    sanitize_message(ctx->error, sizeof ctx->error);
}

static void emit_message(volux_context *ctx, volux_message_level level, const char *fmt, va_list ap) {
    char text[VOLUX_ERROR_MAX];
    vsnprintf(text, sizeof text, fmt, ap);
    sanitize_message(text, sizeof text);
    ctx->message(ctx->message_user, level, text);
}

void volux_message(volux_context *ctx, volux_message_level level, const char *fmt, ...) {
    if (!ctx->message) return;
    va_list ap;
    va_start(ap, fmt);
    emit_message(ctx, level, fmt, ap);
    va_end(ap);
}

void volux_warn(volux_context *ctx, const char *fmt, ...) {
    if (!ctx->message) return;
    va_list ap;
    va_start(ap, fmt);
    emit_message(ctx, VOLUX_MESSAGE_WARNING, fmt, ap);
    va_end(ap);
}

int volux_progress(volux_context *ctx, const char *task, double fraction) {
    if (!ctx->progress) return 0;
    return ctx->progress(ctx->progress_user, task, fraction);
}

volux_status volux_grow_slots(volux_context *ctx, void *arr, int *cap, int need, size_t elem, const char *what) {
    if (need <= *cap) return VOLUX_OK;
    int n = *cap > 0 ? *cap : 8;
    while (n < need) n = n > INT_MAX / 2 ? need : 2 * n;
    void *p;
    memcpy(&p, arr, sizeof p); /* arr is a T **: read the pointer without type punning */
    if ((size_t)n > SIZE_MAX / elem) return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for %s", what);
    void *q = volux_realloc(ctx, p, elem * (size_t)*cap, elem * (size_t)n);
    if (!q) return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for %s (%d slots)", what, n);
    memset((char *)q + elem * (size_t)*cap, 0, elem * (size_t)(n - *cap));
    memcpy(arr, &q, sizeof q);
    *cap = n;
    return VOLUX_OK;
}
