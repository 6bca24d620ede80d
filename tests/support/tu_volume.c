/* tests/support/tu_volume.c — see tu_volume.h. */
#include "tu_volume.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

static void put(unsigned char *out, const void *v, size_t size, int big_endian) {
    uint16_t one = 1;
    unsigned char first;
    memcpy(&first, &one, 1);
    int host_big = first == 0;
    const unsigned char *p = v;
    for (size_t i = 0; i < size; i++) out[i] = host_big == big_endian ? p[i] : p[size - 1 - i];
}

size_t tu_encode(volux_scalar_type type, int big_endian, const double *values, size_t n, unsigned char *out) {
    size_t es = volux_scalar_type_size(type);
    for (size_t i = 0; i < n; i++) {
        double x = values[i];
        unsigned char *o = out + i * es;
        switch (type) {
        case VOLUX_UINT8: o[0] = (uint8_t)x; break;
        case VOLUX_INT8: o[0] = (uint8_t)(int8_t)x; break;
        case VOLUX_UINT16: { uint16_t v = (uint16_t)x; put(o, &v, 2, big_endian); break; }
        case VOLUX_INT16: { int16_t v = (int16_t)x; put(o, &v, 2, big_endian); break; }
        case VOLUX_FLOAT32: { float v = (float)x; put(o, &v, 4, big_endian); break; }
        case VOLUX_FLOAT64: put(o, &x, 8, big_endian); break;
        case VOLUX_INT32: { int32_t v = (int32_t)x; put(o, &v, 4, big_endian); break; }
        case VOLUX_UINT32: { uint32_t v = (uint32_t)x; put(o, &v, 4, big_endian); break; }
        case VOLUX_INT64: { int64_t v = (int64_t)x; put(o, &v, 8, big_endian); break; }
        case VOLUX_UINT64: { uint64_t v = (uint64_t)x; put(o, &v, 8, big_endian); break; }
        }
    }
    return n * es;
}

unsigned char *tu_deflate(const void *data, size_t n, int gzip, size_t *out_n) {
    z_stream z;
    memset(&z, 0, sizeof z);
    assert_int_equal(deflateInit2(&z, 6, Z_DEFLATED, gzip ? 31 : 15, 8, Z_DEFAULT_STRATEGY), Z_OK);
    size_t cap = deflateBound(&z, (uLong)n) + 64;
    unsigned char *out = malloc(cap);
    assert_non_null(out);
    z.next_in = (Bytef *)data;
    z.avail_in = (uInt)n;
    z.next_out = out;
    z.avail_out = (uInt)cap;
    assert_int_equal(deflate(&z, Z_FINISH), Z_STREAM_END);
    *out_n = cap - z.avail_out;
    deflateEnd(&z);
    return out;
}

const char *tu_write_parts(const char *name, const char *text, const void *data, size_t n) {
    size_t t = strlen(text);
    unsigned char *all = malloc(t + n + 1);
    assert_non_null(all);
    memcpy(all, text, t);
    if (n) memcpy(all + t, data, n);
    const char *path = tu_write_file(name, all, t + n);
    free(all);
    return path;
}

void tu_put_i16(unsigned char *b, size_t off, int v, int big_endian) {
    int16_t x = (int16_t)v;
    put(b + off, &x, 2, big_endian);
}
void tu_put_i32(unsigned char *b, size_t off, long v, int big_endian) {
    int32_t x = (int32_t)v;
    put(b + off, &x, 4, big_endian);
}
void tu_put_f32(unsigned char *b, size_t off, float v, int big_endian) { put(b + off, &v, 4, big_endian); }

void tu_nifti_header(unsigned char hdr[352], int big_endian, const int dims[3], int datatype, int bitpix) {
    memset(hdr, 0, 352);
    tu_put_i32(hdr, 0, 348, big_endian);
    tu_put_i16(hdr, 40, 3, big_endian);
    for (int a = 0; a < 3; a++) tu_put_i16(hdr, 42 + 2 * (size_t)a, dims[a], big_endian);
    for (int a = 3; a < 7; a++) tu_put_i16(hdr, 42 + 2 * (size_t)a, 1, big_endian);
    tu_put_i16(hdr, 70, datatype, big_endian);
    tu_put_i16(hdr, 72, bitpix, big_endian);
    for (int a = 0; a < 8; a++) tu_put_f32(hdr, 76 + 4 * (size_t)a, 1.0f, big_endian);
    tu_put_f32(hdr, 108, 352.0f, big_endian);
    memcpy(hdr + 344, "n+1", 4);
}

static void *counting_alloc(void *user, void *ptr, size_t old_size, size_t new_size) {
    tu_alloc_stats *s = user;
    if (new_size == 0) {
        s->live -= old_size;
        free(ptr);
        return NULL;
    }
    s->count++;
    if (s->fail_at > 0 && s->count == s->fail_at) return NULL;
    void *p = realloc(ptr, new_size);
    if (!p) return NULL;
    s->live += new_size - (ptr ? old_size : 0);
    if (new_size > s->largest) s->largest = new_size;
    return p;
}

volux_context *tu_context_counting(uint64_t max_bytes, tu_alloc_stats *stats) {
    volux_context_desc d = {0};
    d.threads = 1;
    d.max_bytes = max_bytes;
    d.alloc = counting_alloc;
    d.alloc_user = stats;
    d.cache_dir = tu_temp_path("cache");
    volux_context *ctx = NULL;
    assert_int_equal(volux_context_create(&d, &ctx), VOLUX_OK);
    return ctx;
}

void tu_assert_error_mentions(volux_context *ctx, ...) {
    const char *msg = volux_context_error(ctx);
    va_list ap;
    va_start(ap, ctx);
    const char *want;
    while ((want = va_arg(ap, const char *)))
        if (!strstr(msg, want)) fail_msg("error message '%s' does not mention '%s'", msg, want);
    va_end(ap);
}
