/*
 * io/ambient_table_file.c — the ambient preintegration table's description,
 * storage, file format (ambient_table_file.h) and cache entry.
 *
 * The reader and the writer report into a caller's buffer, not the context:
 * the public load/save turn that into the context's message, while the
 * cache uses them quietly, because a cache entry that is missing, stale,
 * corrupt or unwritable is only a reason to build the table in memory and
 * must never touch the caller's error.
 */
#include "ambient_table_file.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "cache_folder.h"
#include "core/context_internal.h"
#include "file_open.h"
#include "output_file.h"

#define TABLE_MAGIC "VXAMBTAB"
#define TABLE_HEADER_BYTES 128
#define TABLE_FLAG_ERRORS 1u
#define PI 3.14159265358979323846

typedef struct why_buf {
    char text[VOLUX_ERROR_MAX];
} why_buf;

static volux_status fail(why_buf *why, volux_status st, const char *fmt, ...) VOLUX_PRINTF(3, 4);
static volux_status fail(why_buf *why, volux_status st, const char *fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(why->text, sizeof why->text, fmt, ap);
    va_end(ap);
    return st;
}

/* ------------------------------------------------------------ description */

void volux_ambient_table_desc_defaults(volux_ambient_table_desc *d) {
    memset(d, 0, sizeof *d);
    d->n_theta = 256;
    d->n_sigma = 256;
    d->n_g = 19;
    d->sigma_max = 20.0;
    d->g_min = -0.9;
    d->g_max = 0.9;
    d->n_albedo = 1;
    d->albedo[0] = 0.9;
    d->paths = 16384;
    d->seed = 1;
}

void volux_ambient_table_desc_albedo_set(volux_ambient_table_desc *d) {
    static const double set[] = {0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 0.95, 1.0};
    memset(d->albedo, 0, sizeof d->albedo);
    d->n_albedo = (int)(sizeof set / sizeof set[0]);
    memcpy(d->albedo, set, sizeof set);
}

void volux_ambient_table_desc_builtin(volux_ambient_table_desc *d) {
    volux_ambient_table_desc_defaults(d);
    d->n_theta = 64;
    d->n_sigma = 64;
    d->n_g = 10;
    d->paths = 4096; /* median relative error per entry ~2 % (the paper's size at 16384: ~1 %) */
    volux_ambient_table_desc_albedo_set(d);
}

static volux_status check_desc(const volux_ambient_table_desc *d, why_buf *why) {
    const char *P = "ambient table";
    int dims[3] = {d->n_theta, d->n_sigma, d->n_g};
    const char *names[3] = {"n_theta", "n_sigma", "n_g"};
    for (int a = 0; a < 3; a++)
        if (dims[a] < 2 || dims[a] > VOLUX_AMBIENT_TABLE_MAX_DIM)
            return fail(why, VOLUX_ERR_INVALID, "%s: %s: must be in [2, %d], got %d", P, names[a],
                        VOLUX_AMBIENT_TABLE_MAX_DIM, dims[a]);
    if (!(d->sigma_max > 0.0) || !(d->sigma_max <= 1e4))
        return fail(why, VOLUX_ERR_INVALID, "%s: sigma_max: must be in (0, 1e4], got %g", P, d->sigma_max);
    if (!(d->g_min > -1.0) || !(d->g_max < 1.0) || !(d->g_min < d->g_max))
        return fail(why, VOLUX_ERR_INVALID, "%s: g range: need -1 < g_min < g_max < 1, got [%g, %g]", P, d->g_min,
                    d->g_max);
    if (d->n_albedo < 1 || d->n_albedo > VOLUX_AMBIENT_TABLE_MAX_ALBEDO)
        return fail(why, VOLUX_ERR_INVALID, "%s: n_albedo: must be in [1, %d], got %d", P,
                    VOLUX_AMBIENT_TABLE_MAX_ALBEDO, d->n_albedo);
    for (int i = 0; i < d->n_albedo; i++) {
        if (!(d->albedo[i] >= 0.0) || !(d->albedo[i] <= 1.0))
            return fail(why, VOLUX_ERR_INVALID, "%s: albedo[%d]: must be in [0, 1], got %g", P, i, d->albedo[i]);
        if (i > 0 && !(d->albedo[i] > d->albedo[i - 1]))
            return fail(why, VOLUX_ERR_INVALID, "%s: albedo[%d]: albedos must increase, got %g after %g", P, i,
                        d->albedo[i], d->albedo[i - 1]);
    }
    if (d->paths < 1 || d->paths > (1ull << 40))
        return fail(why, VOLUX_ERR_INVALID, "%s: paths: must be in [1, 2^40], got %llu", P,
                    (unsigned long long)d->paths);
    return VOLUX_OK;
}

volux_status volux_ambient_table_desc_validate(volux_context *ctx, const volux_ambient_table_desc *d) {
    why_buf why;
    volux_status st = check_desc(d, &why);
    return st ? volux_error(ctx, st, "%s", why.text) : VOLUX_OK;
}

int volux_ambient_table_desc_equal(const volux_ambient_table_desc *a, const volux_ambient_table_desc *b) {
    if (!(a->n_theta == b->n_theta && a->n_sigma == b->n_sigma && a->n_g == b->n_g && a->sigma_max == b->sigma_max &&
          a->g_min == b->g_min && a->g_max == b->g_max && a->n_albedo == b->n_albedo && a->paths == b->paths &&
          a->seed == b->seed))
        return 0;
    for (int i = 0; i < a->n_albedo; i++)
        if (a->albedo[i] != b->albedo[i]) return 0;
    return 1;
}

/* ------------------------------------------------------------------ storage */

void volux_ambient_table_free(volux_context *ctx, volux_ambient_table *t) {
    if (!t) return;
    size_t n = volux_ambient_table_values(&t->desc) * sizeof(float);
    if (t->data) volux_free(ctx, t->data, n);
    if (t->rel_error) volux_free(ctx, t->rel_error, n);
    t->data = t->rel_error = NULL;
}

int volux_ambient_table_alloc(volux_context *ctx, const volux_ambient_table_desc *d, int with_errors,
                              volux_ambient_table *t) {
    memset(t, 0, sizeof *t);
    t->desc = *d;
    size_t n = volux_ambient_table_values(d) * sizeof(float);
    t->data = volux_malloc(ctx, n);
    if (with_errors) t->rel_error = volux_malloc(ctx, n);
    if (!t->data || (with_errors && !t->rel_error)) {
        volux_ambient_table_free(ctx, t);
        return 0;
    }
    return 1;
}

/* ------------------------------------------------------------------ bytes */

static uint64_t fnv1a(uint64_t h, const unsigned char *p, size_t n) {
    for (size_t i = 0; i < n; i++) {
        h ^= p[i];
        h *= 0x100000001b3ull;
    }
    return h;
}
#define FNV_OFFSET 0xcbf29ce484222325ull

static void put_u32(unsigned char *p, uint32_t v) {
    for (int i = 0; i < 4; i++) p[i] = (unsigned char)(v >> (8 * i));
}
static void put_u64(unsigned char *p, uint64_t v) {
    for (int i = 0; i < 8; i++) p[i] = (unsigned char)(v >> (8 * i));
}
static void put_f64(unsigned char *p, double v) {
    uint64_t u;
    memcpy(&u, &v, sizeof u);
    put_u64(p, u);
}
static uint32_t get_u32(const unsigned char *p) {
    uint32_t v = 0;
    for (int i = 0; i < 4; i++) v |= (uint32_t)p[i] << (8 * i);
    return v;
}
static uint64_t get_u64(const unsigned char *p) {
    uint64_t v = 0;
    for (int i = 0; i < 8; i++) v |= (uint64_t)p[i] << (8 * i);
    return v;
}
static double get_f64(const unsigned char *p) {
    uint64_t u = get_u64(p);
    double v;
    memcpy(&v, &u, sizeof v);
    return v;
}

/* ------------------------------------------------------------------ write */

static int file_version(const volux_ambient_table_desc *d) {
    return d->n_albedo > 1 ? VOLUX_AMBIENT_TABLE_VERSION_ALBEDO : VOLUX_AMBIENT_TABLE_VERSION;
}

static void encode_header(const volux_ambient_table *t, unsigned char h[TABLE_HEADER_BYTES]) {
    const volux_ambient_table_desc *d = &t->desc;
    int v2 = file_version(d) == VOLUX_AMBIENT_TABLE_VERSION_ALBEDO;
    memset(h, 0, TABLE_HEADER_BYTES);
    memcpy(h, TABLE_MAGIC, 8);
    put_u32(h + 8, (uint32_t)file_version(d));
    put_u32(h + 12, TABLE_HEADER_BYTES);
    put_u32(h + 16, (uint32_t)d->n_theta);
    put_u32(h + 20, (uint32_t)d->n_sigma);
    put_u32(h + 24, (uint32_t)d->n_g);
    put_u32(h + 28, t->rel_error ? TABLE_FLAG_ERRORS : 0u);
    put_f64(h + 32, 0.0);
    put_f64(h + 40, PI);
    put_f64(h + 48, 0.0);
    put_f64(h + 56, d->sigma_max);
    put_f64(h + 64, d->g_min);
    put_f64(h + 72, d->g_max);
    put_f64(h + 80, v2 ? 0.0 : d->albedo[0]);
    put_u64(h + 88, d->paths);
    put_u64(h + 96, d->seed);
    put_u32(h + 104, VOLUX_AMBIENT_TABLE_ESTIMATOR);
    put_u32(h + 108, v2 ? (uint32_t)d->n_albedo : 0u);
    put_f64(h + 120, t->build_ms);
}

/* Writes n floats little-endian, updating the checksum. */
static int write_floats(FILE *f, const float *v, size_t n, uint64_t *h) {
    unsigned char buf[4096];
    size_t k = 0;
    for (size_t i = 0; i < n; i++) {
        uint32_t u;
        memcpy(&u, &v[i], 4);
        put_u32(buf + k, u);
        k += 4;
        if (k == sizeof buf || i + 1 == n) {
            *h = fnv1a(*h, buf, k);
            if (fwrite(buf, 1, k, f) != k) return 0;
            k = 0;
        }
    }
    return 1;
}

/* Writes the table through io/output_file.h (admitted path, nothing left
 * behind on failure). */
static volux_status write_table(volux_context *ctx, const volux_ambient_table *t, const char *path) {
    volux_output_file out;
    volux_status st = volux_output_begin(ctx, path, &out);
    if (st) return st;
    FILE *f = out.f;
    unsigned char h[TABLE_HEADER_BYTES];
    encode_header(t, h);
    uint64_t sum = fnv1a(FNV_OFFSET, h, sizeof h);
    size_t n = volux_ambient_table_values(&t->desc);
    int ok = fwrite(h, 1, sizeof h, f) == sizeof h;
    if (file_version(&t->desc) == VOLUX_AMBIENT_TABLE_VERSION_ALBEDO) {
        unsigned char a[8 * VOLUX_AMBIENT_TABLE_MAX_ALBEDO];
        size_t na = 8 * (size_t)t->desc.n_albedo;
        for (int i = 0; i < t->desc.n_albedo; i++) put_f64(a + 8 * i, t->desc.albedo[i]);
        sum = fnv1a(sum, a, na);
        ok = ok && fwrite(a, 1, na, f) == na;
    }
    ok = ok && write_floats(f, t->data, n, &sum) &&
             (!t->rel_error || write_floats(f, t->rel_error, n, &sum));
    unsigned char tail[8];
    put_u64(tail, sum);
    ok = ok && fwrite(tail, 1, 8, f) == 8;
    if (!ok) {
        int e = errno;
        volux_output_abort(ctx, &out);
        return volux_error(ctx, VOLUX_ERR_WRITE, "%s: cannot write: %s", path, strerror(e));
    }
    return volux_output_commit(ctx, &out);
}

volux_status volux_ambient_table_save(volux_context *ctx, const volux_ambient_table *t, const char *path) {
    return write_table(ctx, t, path);
}

/* ------------------------------------------------------------------ read */

/* Reads the n floats of `dst` little-endian, updating the checksum. */
static int read_floats(FILE *f, float *dst, size_t n, uint64_t *sum) {
    unsigned char buf[4096];
    size_t i = 0;
    while (i < n) {
        size_t m = n - i < sizeof buf / 4 ? n - i : sizeof buf / 4;
        if (fread(buf, 4, m, f) != m) return 0;
        *sum = fnv1a(*sum, buf, 4 * m);
        for (size_t j = 0; j < m; j++) {
            uint32_t u = get_u32(buf + 4 * j);
            memcpy(&dst[i + j], &u, 4);
        }
        i += m;
    }
    return 1;
}

/* The header's description, checked. */
static volux_status decode_header(const unsigned char h[TABLE_HEADER_BYTES], const char *path,
                                  volux_ambient_table_desc *d, uint32_t *flags, why_buf *why) {
    if (memcmp(h, TABLE_MAGIC, 8) != 0)
        return fail(why, VOLUX_ERR_FORMAT, "%s: not an ambient table (bad magic)", path);
    uint32_t version = get_u32(h + 8);
    if ((version != VOLUX_AMBIENT_TABLE_VERSION && version != VOLUX_AMBIENT_TABLE_VERSION_ALBEDO) ||
        get_u32(h + 12) != TABLE_HEADER_BYTES)
        return fail(why, VOLUX_ERR_FORMAT, "%s: unsupported ambient table version %u", path, version);
    memset(d, 0, sizeof *d);
    uint32_t dims[3] = {get_u32(h + 16), get_u32(h + 20), get_u32(h + 24)};
    for (int a = 0; a < 3; a++)
        if (dims[a] < 2 || dims[a] > VOLUX_AMBIENT_TABLE_MAX_DIM)
            return fail(why, VOLUX_ERR_FORMAT, "%s: table size %u is outside [2, %d]", path, dims[a],
                        VOLUX_AMBIENT_TABLE_MAX_DIM);
    d->n_theta = (int)dims[0], d->n_sigma = (int)dims[1], d->n_g = (int)dims[2];
    *flags = get_u32(h + 28);
    double th0 = get_f64(h + 32), th1 = get_f64(h + 40), s0 = get_f64(h + 48);
    d->sigma_max = get_f64(h + 56);
    d->g_min = get_f64(h + 64);
    d->g_max = get_f64(h + 72);
    d->paths = get_u64(h + 88);
    d->seed = get_u64(h + 96);
    uint32_t n_albedo = get_u32(h + 108);
    if ((*flags & ~TABLE_FLAG_ERRORS) || th0 != 0.0 || fabs(th1 - PI) > 1e-12 || s0 != 0.0 ||
        get_u32(h + 104) != VOLUX_AMBIENT_TABLE_ESTIMATOR ||
        (version == VOLUX_AMBIENT_TABLE_VERSION ? n_albedo != 0 : (n_albedo < 2 || get_f64(h + 80) != 0.0)))
        return fail(why, VOLUX_ERR_FORMAT, "%s: unsupported ambient table layout", path);
    if (n_albedo > VOLUX_AMBIENT_TABLE_MAX_ALBEDO)
        return fail(why, VOLUX_ERR_FORMAT, "%s: %u albedos (at most %d)", path, n_albedo,
                    VOLUX_AMBIENT_TABLE_MAX_ALBEDO);
    /* v2: the albedos follow the header (read and checked by the caller) */
    d->n_albedo = version == VOLUX_AMBIENT_TABLE_VERSION ? 1 : (int)n_albedo;
    d->albedo[0] = version == VOLUX_AMBIENT_TABLE_VERSION ? get_f64(h + 80) : 0.0;
    return VOLUX_OK;
}

static volux_status check_header_desc(const volux_ambient_table_desc *d, const char *path, why_buf *why) {
    why_buf bad;
    if (check_desc(d, &bad)) return fail(why, VOLUX_ERR_FORMAT, "%s: invalid header: %s", path, bad.text);
    return VOLUX_OK;
}

/* Reads a table from the stream f (closed here); `path` names it. */
static volux_status read_stream(volux_context *ctx, FILE *f, const char *path, volux_ambient_table *out,
                                why_buf *why) {
    unsigned char h[TABLE_HEADER_BYTES];
    volux_status st = VOLUX_OK;
    volux_ambient_table t;
    memset(&t, 0, sizeof t);
    volux_ambient_table_desc d;
    uint32_t flags = 0;
    if (fread(h, 1, sizeof h, f) != sizeof h) {
        /* too short for a header: report it as the magic check would */
        st = fail(why, VOLUX_ERR_FORMAT, "%s: not an ambient table (bad magic)", path);
        goto done;
    }
    if ((st = decode_header(h, path, &d, &flags, why))) goto done;
    uint64_t sum = fnv1a(FNV_OFFSET, h, sizeof h);
    if (d.n_albedo > 1) {
        unsigned char a[8 * VOLUX_AMBIENT_TABLE_MAX_ALBEDO];
        size_t na = 8 * (size_t)d.n_albedo;
        if (fread(a, 1, na, f) != na) {
            st = fail(why, VOLUX_ERR_FORMAT, "%s: truncated ambient table (albedo list)", path);
            goto done;
        }
        sum = fnv1a(sum, a, na);
        for (int i = 0; i < d.n_albedo; i++) d.albedo[i] = get_f64(a + 8 * i);
    }
    if ((st = check_header_desc(&d, path, why))) goto done;
    /* The bytes the header promises must be there before anything is
     * allocated for them: a 128-byte header can claim gigabytes. */
    uint64_t values = volux_ambient_table_values(&d), remaining = 0;
    uint64_t promised = values * 4u * ((flags & TABLE_FLAG_ERRORS) ? 2u : 1u) + 8u;
    long here = ftell(f), end = -1;
    if (here >= 0 && fseek(f, 0, SEEK_END) == 0) end = ftell(f);
    if (here < 0 || end < here || fseek(f, here, SEEK_SET) != 0) {
        st = fail(why, VOLUX_ERR_IO, "%s: cannot determine the ambient table's size", path);
        goto done;
    }
    remaining = (uint64_t)(end - here);
    if (remaining < promised) {
        st = fail(why, VOLUX_ERR_FORMAT, "%s: truncated ambient table (the header promises %llu more bytes, %llu left)",
                  path, (unsigned long long)promised, (unsigned long long)remaining);
        goto done;
    }
    if (!volux_ambient_table_alloc(ctx, &d, (flags & TABLE_FLAG_ERRORS) != 0, &t)) {
        st = fail(why, VOLUX_ERR_NOMEM, "%s: out of memory for the ambient table (%zu values)", path,
                  volux_ambient_table_values(&d));
        goto done;
    }
    t.build_ms = get_f64(h + 120);
    size_t n = volux_ambient_table_values(&d);
    if (!read_floats(f, t.data, n, &sum) || (t.rel_error && !read_floats(f, t.rel_error, n, &sum))) {
        st = fail(why, VOLUX_ERR_FORMAT, "%s: truncated ambient table", path);
        goto done;
    }
    unsigned char tail[8];
    if (fread(tail, 1, 8, f) != 8) {
        st = fail(why, VOLUX_ERR_FORMAT, "%s: truncated ambient table (no checksum)", path);
        goto done;
    }
    if (get_u64(tail) != sum) {
        st = fail(why, VOLUX_ERR_FORMAT, "%s: ambient table checksum mismatch (corrupt file)", path);
        goto done;
    }
    if (fgetc(f) != EOF) {
        st = fail(why, VOLUX_ERR_FORMAT, "%s: trailing bytes after the ambient table", path);
        goto done;
    }
    for (size_t i = 0; i < n; i++)
        if (!(t.data[i] >= 0.0f) || !isfinite(t.data[i])) {
            st = fail(why, VOLUX_ERR_FORMAT, "%s: ambient table value %zu is not a finite radiance", path, i);
            goto done;
        }
done:
    fclose(f);
    if (st) {
        volux_ambient_table_free(ctx, &t);
        return st;
    }
    *out = t;
    return VOLUX_OK;
}

static volux_status read_table(volux_context *ctx, const char *path, volux_ambient_table *out, why_buf *why) {
    int fd, code = volux_file_open_regular(path, &fd, NULL);
    if (code) return fail(why, VOLUX_ERR_IO, "%s: cannot open: %s", path, volux_file_open_why(code));
    FILE *f = fdopen(fd, "rb");
    if (!f) {
        close(fd);
        return fail(why, VOLUX_ERR_NOMEM, "%s: cannot open: out of memory", path);
    }
    return read_stream(ctx, f, path, out, why);
}

volux_status volux_ambient_table_load(volux_context *ctx, const char *path, volux_ambient_table *out) {
    why_buf why;
    volux_status st = read_table(ctx, path, out, &why);
    return st ? volux_error(ctx, st, "%s", why.text) : VOLUX_OK;
}

volux_status volux_ambient_table_load_memory(volux_context *ctx, const void *bytes, size_t size, const char *name,
                                             volux_ambient_table *out) {
    why_buf why;
    /* fmemopen needs a non-empty buffer; an empty one is a file without a header */
    FILE *f = size ? fmemopen((void *)bytes, size, "rb") : NULL;
    volux_status st = f ? read_stream(ctx, f, name, out, &why)
                        : size ? fail(&why, VOLUX_ERR_NOMEM, "%s: cannot open the table in memory", name)
                               : fail(&why, VOLUX_ERR_FORMAT, "%s: not an ambient table (bad magic)", name);
    return st ? volux_error(ctx, st, "%s", why.text) : VOLUX_OK;
}

int volux_ambient_table_builtin_load(volux_context *ctx, const void *bytes, size_t size, volux_ambient_table *out) {
    why_buf ignored;
    FILE *f = size ? fmemopen((void *)bytes, size, "rb") : NULL;
    return f && read_stream(ctx, f, "built-in ambient table", out, &ignored) == VOLUX_OK;
}

/* ------------------------------------------------------------------ cache */

int volux_ambient_table_cache_path(const volux_context *ctx, const volux_ambient_table_desc *d, char *buf,
                                   size_t size) {
    char name[1024], albedos[16 * VOLUX_AMBIENT_TABLE_MAX_ALBEDO + 1] = "";
    for (int i = 0, at = 0; i < d->n_albedo && i < VOLUX_AMBIENT_TABLE_MAX_ALBEDO; i++)
        at += snprintf(albedos + at, sizeof albedos - (size_t)at, "%s%.9g", i ? "_" : "", d->albedo[i]);
    int n = snprintf(name, sizeof name, "ambient-v%d-e%u-t%d-s%d-g%d-S%.9g-G%.9g_%.9g-a%s-p%llu-r%llu.vxat",
                     file_version(d), VOLUX_AMBIENT_TABLE_ESTIMATOR, d->n_theta, d->n_sigma, d->n_g, d->sigma_max,
                     d->g_min, d->g_max, albedos, (unsigned long long)d->paths, (unsigned long long)d->seed);
    return n > 0 && (size_t)n < sizeof name && volux_cache_file_path(ctx, name, buf, size);
}

int volux_ambient_table_cache_load(volux_context *ctx, const volux_ambient_table_desc *d, volux_ambient_table *out) {
    char path[4400];
    if (!volux_ambient_table_cache_path(ctx, d, path, sizeof path)) return 0;
    why_buf ignored; /* missing, corrupt or unreadable: the caller builds it */
    volux_ambient_table t;
    if (read_table(ctx, path, &t, &ignored) != VOLUX_OK) return 0;
    if (!volux_ambient_table_desc_equal(&t.desc, d)) { /* a stale entry: rebuilt and overwritten */
        volux_ambient_table_free(ctx, &t);
        return 0;
    }
    volux_cache_file_touch(path); /* recently used: evicted last */
    *out = t;
    return 1;
}

int volux_ambient_table_cache_store(volux_context *ctx, const volux_ambient_table *t) {
    char path[4400];
    /* The folder is capped (cache_folder.h): the least recently used
     * tables make room, and a table larger than the cap is not stored. */
    uint64_t bytes = (uint64_t)volux_ambient_table_values(&t->desc) * 4u * (t->rel_error ? 2u : 1u) + 4096u;
    if (!volux_ambient_table_cache_path(ctx, &t->desc, path, sizeof path) || !volux_cache_folder_create(ctx) ||
        !volux_cache_folder_make_room(ctx, bytes))
        return 0;
    /* An unwritable cache folder is not an error: keep the context's
     * error state as it was. */
    volux_status saved_status = ctx->error_status;
    char saved[VOLUX_ERROR_MAX];
    memcpy(saved, ctx->error, sizeof saved);
    int ok = write_table(ctx, t, path) == VOLUX_OK;
    ctx->error_status = saved_status;
    memcpy(ctx->error, saved, sizeof saved);
    return ok;
}
