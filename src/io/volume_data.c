/*
 * io/volume_data.c — the one data path behind every volume reader:
 * header validation against the limits, byte sources (file or memory),
 * line/byte skips, zlib/gzip decoding, byte order and type conversion into
 * the volume's storage.
 *
 * Data flows in fixed-size chunks from the source (or from inflate) through
 * a converter into the storage, so no full-size temporary is ever made and
 * a gzip stream can never write past the buffer its header paid for.
 */
#include <errno.h>
#include <string.h>
#include <sys/stat.h>
#include <zlib.h>

#include "core/volume_internal.h"
#include "file_open.h"
#include "volume_formats.h"

#define CHUNK (256u << 10) /* decoded bytes per step; a multiple of 8 */

/* ------------------------------------------------------------------ */
/* Header defaults and validation                                      */
/* ------------------------------------------------------------------ */

void volux_volume_header_init(volux_volume_header *h) {
    memset(h, 0, sizeof *h);
    for (int a = 0; a < 3; a++) {
        h->dims[a] = 1;
        h->spacing[a] = 1.0;
    }
    h->type = VOLUX_UINT8;
    h->encoding = VOLUX_ENCODING_RAW;
    h->scale_slope = 1.0;
}

/* The storage type a header leads to (scaled values are float32). */
static volux_scalar_type stored_type(const volux_volume_header *h) {
    return h->apply_scale ? VOLUX_FLOAT32 : h->type;
}

volux_status volux_volume_header_check(volux_context *ctx, const char *name, const volux_volume_header *h) {
    uint64_t voxels = 1;
    for (int a = 0; a < 3; a++) {
        if (h->dims[a] < 1 || h->dims[a] > VOLUX_MAX_DIM)
            return volux_error(ctx, VOLUX_ERR_LIMIT, "%s: axis %d has %d samples, outside [1, %d]", name, a,
                               h->dims[a], VOLUX_MAX_DIM);
        voxels *= (uint64_t)h->dims[a]; /* ≤ 2^42: cannot overflow */
        double s = h->spacing[a];
        if (!isfinite(s) || !(s >= 1e-12 && s <= 1e12))
            return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: spacing of axis %d must be positive and finite, got %g",
                               name, a, s);
        if (h->has_origin && !isfinite(h->origin[a]))
            return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: origin component %d is not finite", name, a);
    }
    if (voxels > VOLUX_MAX_VOXELS)
        return volux_error(ctx, VOLUX_ERR_LIMIT, "%s: %dx%dx%d = %llu voxels, over the limit of %llu", name,
                           h->dims[0], h->dims[1], h->dims[2], (unsigned long long)voxels,
                           (unsigned long long)VOLUX_MAX_VOXELS);
    size_t file_bytes;
    size_t bytes = volux_volume_storage_bytes(h->dims, stored_type(h));
    if (bytes == 0 || !volux_mul_size((size_t)voxels, volux_scalar_type_size(h->type), &file_bytes))
        return volux_error(ctx, VOLUX_ERR_LIMIT, "%s: %dx%dx%d %s does not fit in memory addresses", name,
                           h->dims[0], h->dims[1], h->dims[2], volux_scalar_type_name(h->type));
    uint64_t cap = volux_context_max_bytes(ctx);
    if ((uint64_t)bytes > cap)
        return volux_error(ctx, VOLUX_ERR_LIMIT,
                           "%s: %dx%dx%d %s needs %llu bytes, over the memory cap of %llu bytes", name, h->dims[0],
                           h->dims[1], h->dims[2], volux_scalar_type_name(stored_type(h)),
                           (unsigned long long)bytes, (unsigned long long)cap);
    if (h->byte_skip < -1)
        return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: byte skip: must be >= 0 (or -1 for raw data at the end), got %lld",
                           name, (long long)h->byte_skip);
    if (h->encoding != VOLUX_ENCODING_RAW && h->byte_skip > 0 && (uint64_t)h->byte_skip > cap)
        return volux_error(ctx, VOLUX_ERR_LIMIT,
                           "%s: byte skip: %lld decompressed bytes to skip, over the memory cap of %llu bytes", name,
                           (long long)h->byte_skip, (unsigned long long)cap);
    if (h->byte_skip == -1 && h->encoding != VOLUX_ENCODING_RAW)
        return volux_error(ctx, VOLUX_ERR_FORMAT,
                           "%s: byte skip: -1 (data at the end of the file) needs raw encoding, not compressed data",
                           name);
    if (h->apply_scale && !(isfinite(h->scale_slope) && isfinite(h->scale_inter)))
        return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: value scaling is not finite", name);
    return VOLUX_OK;
}

/* ------------------------------------------------------------------ */
/* Sources                                                             */
/* ------------------------------------------------------------------ */

volux_status volux_source_open(volux_context *ctx, const char *path, volux_source *out) {
    memset(out, 0, sizeof *out);
    out->name = path;
    return volux_file_open_read(ctx, path, &out->file, &out->size);
}

void volux_source_memory(const void *bytes, size_t n, const char *name, volux_source *out) {
    memset(out, 0, sizeof *out);
    out->name = name;
    out->mem = bytes ? bytes : (const unsigned char *)"";
    out->size = n;
}

void volux_source_close(volux_source *s) {
    if (s->file) fclose(s->file);
    s->file = NULL;
}

volux_status volux_source_read(volux_context *ctx, volux_source *s, uint64_t offset, void *buf, size_t n,
                               size_t *got) {
    *got = 0;
    if (offset >= s->size || n == 0) return VOLUX_OK;
    uint64_t avail = s->size - offset;
    size_t want = avail < n ? (size_t)avail : n;
    if (s->mem) {
        memcpy(buf, s->mem + offset, want);
        *got = want;
        return VOLUX_OK;
    }
    if (offset > (uint64_t)INT64_MAX || fseeko(s->file, (off_t)offset, SEEK_SET) != 0)
        return volux_error(ctx, VOLUX_ERR_IO, "%s: cannot seek to byte %llu", s->name, (unsigned long long)offset);
    *got = fread(buf, 1, want, s->file);
    if (*got < want && ferror(s->file))
        return volux_error(ctx, VOLUX_ERR_IO, "%s: read error at byte %llu", s->name, (unsigned long long)offset);
    return VOLUX_OK;
}

/* ------------------------------------------------------------------ */
/* Decoded byte streams: raw bytes of a source, or inflate of them     */
/* ------------------------------------------------------------------ */

typedef struct stream {
    volux_context *ctx;
    volux_source *src;
    uint64_t pos; /* next source byte to read */
    int zlib, z_open, z_done;
    z_stream z;
    unsigned char *in; /* zlib input buffer (CHUNK bytes) */
} stream;

static voidpf z_alloc(voidpf opaque, uInt items, uInt size) {
    size_t n;
    if (!volux_mul_size(items, size, &n) || !volux_add_size(n, sizeof(size_t), &n)) return Z_NULL;
    /* zlib frees without a size; keep it in front of the block so
     * volux_free can account it. */
    size_t *p = volux_malloc(opaque, n);
    if (!p) return Z_NULL;
    p[0] = n;
    return p + 1;
}

static void z_free(voidpf opaque, voidpf address) {
    if (!address) return;
    size_t *p = (size_t *)address - 1;
    volux_free(opaque, p, p[0]);
}

static volux_status stream_open(volux_context *ctx, volux_source *src, uint64_t offset, int zlib, stream *s) {
    memset(s, 0, sizeof *s);
    s->ctx = ctx;
    s->src = src;
    s->pos = offset;
    s->zlib = zlib;
    if (!zlib) return VOLUX_OK;
    s->in = volux_malloc(ctx, CHUNK);
    if (!s->in) return volux_error(ctx, VOLUX_ERR_NOMEM, "%s: out of memory for decompression", src->name);
    s->z.zalloc = z_alloc;
    s->z.zfree = z_free;
    s->z.opaque = ctx;
    /* 15 + 32: the largest window, and detect a gzip or zlib header. */
    if (inflateInit2(&s->z, 15 + 32) != Z_OK) {
        volux_free(ctx, s->in, CHUNK);
        s->in = NULL;
        return volux_error(ctx, VOLUX_ERR_NOMEM, "%s: cannot start decompression", src->name);
    }
    s->z_open = 1;
    return VOLUX_OK;
}

static void stream_close(stream *s) {
    if (s->z_open) inflateEnd(&s->z);
    if (s->in) volux_free(s->ctx, s->in, CHUNK);
    s->z_open = 0;
    s->in = NULL;
}

/* Reads up to n decoded bytes; *got < n only at the end of the stream. */
static volux_status stream_read(stream *s, unsigned char *buf, size_t n, size_t *got) {
    if (!s->zlib) {
        volux_status st = volux_source_read(s->ctx, s->src, s->pos, buf, n, got);
        s->pos += *got;
        return st;
    }
    *got = 0;
    s->z.next_out = buf;
    s->z.avail_out = (uInt)n; /* n ≤ CHUNK */
    while (s->z.avail_out > 0 && !s->z_done) {
        if (s->z.avail_in == 0) {
            size_t m;
            volux_status st = volux_source_read(s->ctx, s->src, s->pos, s->in, CHUNK, &m);
            if (st) return st;
            if (m == 0)
                return volux_error(s->ctx, VOLUX_ERR_FORMAT, "%s: compressed data is truncated (ends at byte %llu)",
                                   s->src->name, (unsigned long long)s->pos);
            s->pos += m;
            s->z.next_in = s->in;
            s->z.avail_in = (uInt)m;
        }
        int r = inflate(&s->z, Z_NO_FLUSH);
        if (r == Z_STREAM_END) {
            /* Concatenated gzip members (pigz, cat a.gz b.gz) continue the
             * stream; anything else after the end is ignored, as gzip does. */
            if (s->z.avail_in == 0) {
                size_t m;
                volux_status st = volux_source_read(s->ctx, s->src, s->pos, s->in, CHUNK, &m);
                if (st) return st;
                s->pos += m;
                s->z.next_in = s->in;
                s->z.avail_in = (uInt)m;
            }
            int more = s->z.avail_in >= 2 && s->z.next_in[0] == 0x1f && s->z.next_in[1] == 0x8b;
            if (more && inflateReset(&s->z) == Z_OK) continue;
            s->z_done = 1;
        } else if (r == Z_BUF_ERROR && s->z.avail_in == 0) {
            continue; /* needs more input */
        } else if (r != Z_OK) {
            if (r == Z_MEM_ERROR)
                return volux_error(s->ctx, VOLUX_ERR_NOMEM, "%s: out of memory while decompressing", s->src->name);
            return volux_error(s->ctx, VOLUX_ERR_FORMAT, "%s: corrupt compressed data (zlib: %s)", s->src->name,
                               s->z.msg ? s->z.msg : "error");
        }
    }
    *got = n - s->z.avail_out;
    return VOLUX_OK;
}

volux_status volux_source_inflate_prefix(volux_context *ctx, volux_source *src, uint64_t offset, void *buf,
                                         size_t n, size_t *got) {
    stream s;
    volux_status st = stream_open(ctx, src, offset, 1, &s);
    if (st) return st;
    size_t total = 0;
    while (!st && total < n) {
        size_t m, want = n - total < CHUNK ? n - total : CHUNK;
        st = stream_read(&s, (unsigned char *)buf + total, want, &m);
        total += m;
        if (m < want) break;
    }
    stream_close(&s);
    *got = total;
    return st;
}

/* ------------------------------------------------------------------ */
/* Conversion of decoded chunks into storage                            */
/* ------------------------------------------------------------------ */

int volux_host_big_endian(void) {
    uint16_t one = 1;
    unsigned char b;
    memcpy(&b, &one, 1);
    return b == 0;
}

static void swap_bytes(unsigned char *p, size_t count, size_t size) {
    for (size_t i = 0; i < count; i++, p += size)
        for (size_t a = 0, b = size - 1; a < b; a++, b--) {
            unsigned char t = p[a];
            p[a] = p[b];
            p[b] = t;
        }
}

/* Value of element i of a native-order chunk, in file units. */
static double element(const unsigned char *p, volux_scalar_type t, size_t i) {
    switch (t) {
    case VOLUX_UINT8: return p[i];
    case VOLUX_INT8: return (int8_t)p[i];
    case VOLUX_UINT16: {
        uint16_t v;
        memcpy(&v, p + 2 * i, 2);
        return v;
    }
    case VOLUX_INT16: {
        int16_t v;
        memcpy(&v, p + 2 * i, 2);
        return v;
    }
    case VOLUX_FLOAT32: {
        float v;
        memcpy(&v, p + 4 * i, 4);
        return v;
    }
    case VOLUX_FLOAT64: {
        double v;
        memcpy(&v, p + 8 * i, 8);
        return v;
    }
    case VOLUX_INT32: {
        int32_t v;
        memcpy(&v, p + 4 * i, 4);
        return v;
    }
    case VOLUX_UINT32: {
        uint32_t v;
        memcpy(&v, p + 4 * i, 4);
        return v;
    }
    case VOLUX_INT64: {
        int64_t v;
        memcpy(&v, p + 8 * i, 8);
        return (double)v;
    }
    case VOLUX_UINT64: {
        uint64_t v;
        memcpy(&v, p + 8 * i, 8);
        return (double)v;
    }
    }
    return 0.0;
}

/* Converts `count` elements (file type, already native byte order) into
 * storage starting at element `first`. Signed integers take the storage
 * offset of volume_internal.h (int8 + 128, int16 + 32768). */
static void convert_chunk(const volux_volume_header *h, volux_volume *v, size_t first, unsigned char *chunk,
                          size_t count) {
    if (h->apply_scale) {
        float *d = (float *)v->data + first;
        for (size_t i = 0; i < count; i++)
            d[i] = (float)(h->scale_slope * element(chunk, h->type, i) + h->scale_inter);
        return;
    }
    switch (h->type) {
    case VOLUX_UINT8: memcpy((uint8_t *)v->data + first, chunk, count); break;
    case VOLUX_UINT16: memcpy((uint16_t *)v->data + first, chunk, count * 2); break;
    case VOLUX_FLOAT32: memcpy((float *)v->data + first, chunk, count * 4); break;
    case VOLUX_INT8: {
        uint8_t *d = (uint8_t *)v->data + first;
        for (size_t i = 0; i < count; i++) d[i] = (uint8_t)(chunk[i] ^ 0x80u); /* two's complement + 128 */
        break;
    }
    case VOLUX_INT16: {
        uint16_t *d = (uint16_t *)v->data + first;
        for (size_t i = 0; i < count; i++) {
            uint16_t u;
            memcpy(&u, chunk + 2 * i, 2);
            d[i] = (uint16_t)(u ^ 0x8000u);
        }
        break;
    }
    case VOLUX_FLOAT64:
    case VOLUX_INT32:
    case VOLUX_UINT32:
    case VOLUX_INT64:
    case VOLUX_UINT64: {
        /* stored as float32 (volux/volume.h); a 64-bit integer goes through
         * double first, which rounds only where float32 would anyway */
        float *d = (float *)v->data + first;
        for (size_t i = 0; i < count; i++) d[i] = (float)element(chunk, h->type, i);
        break;
    }
    }
}

void volux_volume_store_elements(const volux_volume_header *h, volux_volume *v, size_t first, unsigned char *bytes,
                                 size_t count) {
    size_t esize = volux_scalar_type_size(h->type);
    if (esize > 1 && h->big_endian != volux_host_big_endian()) swap_bytes(bytes, count, esize);
    convert_chunk(h, v, first, bytes, count);
}


/* ------------------------------------------------------------------ */
/* The data reader                                                     */
/* ------------------------------------------------------------------ */

/* Offset just past `lines` newlines counted from `offset`. */
static volux_status skip_lines(volux_context *ctx, volux_source *src, uint64_t offset, uint64_t lines,
                               unsigned char *buf, uint64_t *out) {
    uint64_t seen = 0;
    while (seen < lines) {
        size_t got;
        volux_status st = volux_source_read(ctx, src, offset, buf, CHUNK, &got);
        if (st) return st;
        if (got == 0)
            return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: line skip: %llu lines requested, the file has only %llu",
                               src->name, (unsigned long long)lines, (unsigned long long)seen);
        size_t i = 0;
        for (; i < got && seen < lines; i++)
            if (buf[i] == '\n') seen++;
        offset += i;
    }
    *out = offset;
    return VOLUX_OK;
}

/* Start offset of raw data, after checking that exactly `need` bytes are
 * present from there to the end of the source. */
static volux_status raw_start(volux_context *ctx, const volux_volume_header *h, volux_source *src, uint64_t begin,
                              uint64_t need, const char *dims, uint64_t *start) {
    const char *name = src->name;
    if (begin > src->size)
        return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: data offset %llu is past the end of the file (%llu bytes)",
                           name, (unsigned long long)begin, (unsigned long long)src->size);
    uint64_t avail = src->size - begin;
    if (h->byte_skip == -1) {
        if (avail < need)
            return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: data is truncated: %s needs %llu bytes, the file has %llu",
                               name, dims, (unsigned long long)need, (unsigned long long)avail);
        *start = src->size - need;
        return VOLUX_OK;
    }
    uint64_t skip = (uint64_t)h->byte_skip;
    if (skip > avail)
        return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: byte skip: %llu is past the end of the file (%llu bytes left)",
                           name, (unsigned long long)skip, (unsigned long long)avail);
    avail -= skip;
    if (avail < need)
        return volux_error(ctx, VOLUX_ERR_FORMAT,
                           "%s: data is truncated: %s needs %llu bytes, only %llu are present", name, dims,
                           (unsigned long long)need, (unsigned long long)avail);
    if (avail > need && h->trailing_ok) {
        /* Teem reads such a file and warns; so do we. */
        volux_warn(ctx, "%s: %llu bytes after the %llu bytes of %s data are ignored", name,
                   (unsigned long long)(avail - need), (unsigned long long)need, dims);
    } else if (avail > need)
        return volux_error(ctx, VOLUX_ERR_FORMAT,
                           "%s: size mismatch: %s needs %llu bytes, but %llu are present (byte skip -1 reads "
                           "the data at the end of the file)",
                           name, dims, (unsigned long long)need, (unsigned long long)avail);
    *start = begin + skip;
    return VOLUX_OK;
}

static volux_status discard(stream *s, unsigned char *buf, uint64_t n) {
    while (n > 0) {
        size_t got, want = n < CHUNK ? (size_t)n : CHUNK;
        volux_status st = stream_read(s, buf, want, &got);
        if (st) return st;
        if (got < want)
            return volux_error(s->ctx, VOLUX_ERR_FORMAT, "%s: byte skip: the decompressed data ends before the skip",
                               s->src->name);
        n -= got;
    }
    return VOLUX_OK;
}

/* NaN/Inf in float data: refused with their count and the first voxel,
 * or (allowed) replaced by the lowest value with a warning. */
static volux_status check_nonfinite(volux_context *ctx, const char *name, const volux_volume *v, int allow) {
    size_t first = 0, bad = volux_volume_count_nonfinite(v, &first);
    if (!bad) return VOLUX_OK;
    size_t nx = (size_t)v->dims[0], ny = (size_t)v->dims[1];
    size_t x = first % nx, y = first / nx % ny, z = first / (nx * ny);
    if (!allow)
        return volux_error(ctx, VOLUX_ERR_FORMAT,
                           "%s: %zu non-finite values (NaN/Inf) in the data, the first at voxel (%zu, %zu, %zu); "
                           "\"allow_nonfinite\": true maps them to the lowest value",
                           name, bad, x, y, z);
    volux_warn(ctx, "%s: %zu non-finite values (NaN/Inf), the first at voxel (%zu, %zu, %zu), mapped to the lowest value",
               name, bad, x, y, z);
    return VOLUX_OK;
}

volux_status volux_volume_read_finish(volux_context *ctx, const volux_volume_header *h, const char *name,
                                      const volux_volume_load_options *options, volux_volume *v) {
    volux_status st = check_nonfinite(ctx, name, v, options && options->allow_nonfinite);
    if (st) return st;
    st = volux_volume_finalize(v, options && options->use_file_origin && h->has_origin ? h->origin : NULL);
    if (st) {
        volux_error_prefix(ctx, "%s: ", name);
        return st;
    }
    volux_volume_set_superior(v, h->has_superior ? h->superior : NULL);
    return VOLUX_OK;
}

/* Where part `k` of `parts` starts in its source, checking its size (raw:
 * exactly `need` bytes; compressed: enough to hold them) before anything
 * is allocated. */
static volux_status locate_part(volux_context *ctx, const volux_volume_header *h, volux_source *src, int k, int parts,
                                uint64_t need, unsigned char *buf, uint64_t *start) {
    const char *name = src->name;
    int zlib = h->encoding == VOLUX_ENCODING_ZLIB;
    char dims[128];
    if (parts == 1)
        snprintf(dims, sizeof dims, "%dx%dx%d %s", h->dims[0], h->dims[1], h->dims[2], volux_scalar_type_name(h->type));
    else
        snprintf(dims, sizeof dims, "data file %d of %d (1/%d of %dx%dx%d %s)", k + 1, parts, parts, h->dims[0],
                 h->dims[1], h->dims[2], volux_scalar_type_name(h->type));
    uint64_t begin = h->data_offset;
    if (begin > src->size)
        return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: data offset %llu is past the end of the file (%llu bytes)", name,
                           (unsigned long long)begin, (unsigned long long)src->size);
    volux_status st;
    if (h->line_skip && (st = skip_lines(ctx, src, begin, h->line_skip, buf, &begin))) return st;
    if (!zlib) return raw_start(ctx, h, src, begin, need, dims, start);
    if (begin >= src->size)
        return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: compressed data is missing (file ends at byte %llu)", name,
                           (unsigned long long)src->size);
    if (h->compressed_size && h->compressed_size > src->size - begin)
        return volux_error(ctx, VOLUX_ERR_FORMAT,
                           "%s: CompressedDataSize: %llu bytes declared, but only %llu follow the header", name,
                           (unsigned long long)h->compressed_size, (unsigned long long)(src->size - begin));
    /* Deflate expands at most 1032:1 (zlib's technical notes), so a short
     * stream cannot hold a big volume: refuse before allocating what the
     * header claims rather than after inflating. The slack covers stored
     * blocks and member headers of tiny streams. */
    uint64_t packed = src->size - begin, decoded = need + (uint64_t)(h->byte_skip > 0 ? h->byte_skip : 0);
    if (packed < (UINT64_MAX - 4096) / 1032 && decoded > packed * 1032 + 4096)
        return volux_error(ctx, VOLUX_ERR_FORMAT,
                           "%s: data is truncated: %llu bytes of compressed data cannot hold the %llu bytes of %s",
                           name, (unsigned long long)packed, (unsigned long long)need, dims);
    *start = begin;
    return VOLUX_OK;
}

/* Decodes part `k` (voxels [first, first + count)) from src into v. */
/* A file named by a client under a data root (the viewer) gets no message
 * that states its size or where its data stops: the sizes would tell a
 * browser about files it cannot read (issue 34 D8). The header's own
 * dimensions are the client's to know. */
static volux_status withhold_sizes(volux_context *ctx, const char *name, const volux_volume_header *h,
                                   int had_error) {
    if (had_error) return VOLUX_ERR_FORMAT; /* an earlier message stands (the first wins) */
    volux_context_clear_error(ctx);
    return volux_error(ctx, VOLUX_ERR_FORMAT,
                       "%s: the data does not match the %dx%dx%d %s the header describes (sizes are not reported "
                       "for files named under a data root)",
                       name, h->dims[0], h->dims[1], h->dims[2], volux_scalar_type_name(h->type));
}

static volux_status read_part(volux_context *ctx, const volux_volume_header *h, volux_source *src, uint64_t begin,
                              volux_volume *v, size_t first, size_t count, size_t total, unsigned char *buf) {
    const char *name = src->name;
    size_t esize = volux_scalar_type_size(h->type);
    uint64_t need = (uint64_t)count * esize;
    int zlib = h->encoding == VOLUX_ENCODING_ZLIB;
    stream s;
    memset(&s, 0, sizeof s);
    volux_status st = stream_open(ctx, src, begin, zlib, &s);
    if (st) return st;
    if (zlib && h->byte_skip > 0 && (st = discard(&s, buf, (uint64_t)h->byte_skip))) goto done;
    int swap = esize > 1 && (h->big_endian != volux_host_big_endian());
    size_t per_chunk = CHUNK / esize, done = 0;
    while (done < count) {
        size_t n = count - done < per_chunk ? count - done : per_chunk, got;
        if ((st = stream_read(&s, buf, n * esize, &got))) goto done;
        if (got < n * esize) {
            st = volux_error(ctx, VOLUX_ERR_FORMAT, "%s: data is truncated: got %llu of the %llu bytes needed", name,
                             (unsigned long long)(done * esize + got), (unsigned long long)need);
            goto done;
        }
        if (swap) swap_bytes(buf, n, esize);
        convert_chunk(h, v, first + done, buf, n);
        done += n;
        if (volux_progress(ctx, "load volume", (double)(first + done) / (double)total)) {
            st = volux_error(ctx, VOLUX_ERR_CANCELLED, "%s: loading cancelled", name);
            goto done;
        }
    }
    if (zlib) {
        /* The header's size must be the whole stream: one more byte means
         * the header and the data disagree. */
        size_t got;
        if ((st = stream_read(&s, buf, 1, &got))) goto done;
        if (got)
            st = volux_error(ctx, VOLUX_ERR_FORMAT,
                             "%s: size mismatch: data decompresses to more than the %llu bytes expected", name,
                             (unsigned long long)need);
    }
done:
    stream_close(&s);
    return st;
}

/* Out of core (volux_context_set_out_of_core): NULL when the data of this
 * one-file volume is stored in the file exactly as the volume stores it,
 * so that it can be mapped; else why not, for the warning. */
static const char *why_not_mapped(const volux_volume_header *h, const volux_source *src, uint64_t begin) {
    size_t esize = volux_scalar_type_size(h->type);
    if (!src->file) return "the file is held in memory";
    if (h->encoding != VOLUX_ENCODING_RAW) return "the data is compressed";
    if (h->apply_scale) return "the values are scaled (stored as float32)";
    if (h->type != VOLUX_UINT8 && h->type != VOLUX_UINT16 && h->type != VOLUX_FLOAT32)
        return "only uint8, uint16 and float32 data is stored as the file holds it";
    if (esize > 1 && h->big_endian != volux_host_big_endian()) return "the data is not in this machine's byte order";
    if (begin % esize) /* an attached header of odd length; a detached one starts at 0 */
        return "the data does not start at a multiple of its element size";
    return NULL;
}

/* Maps the data at `begin` of a one-file volume (see why_not_mapped), then
 * the common last step (non-finite values: refused even when allowed, since
 * a read-only mapping cannot replace them: volux_volume_finalize). */
static volux_status map_data(volux_context *ctx, const volux_volume_header *h, volux_source *src, uint64_t begin,
                             const volux_volume_load_options *options, volux_volume **out) {
    volux_volume *v;
    volux_status st =
        volux_volume_map_file(ctx, src->name, fileno(src->file), begin, h->dims, h->spacing, h->type, &v);
    if (st) return st;
    if (volux_progress(ctx, "load volume", 1.0)) {
        volux_volume_release(v);
        return volux_error(ctx, VOLUX_ERR_CANCELLED, "%s: loading cancelled", src->name);
    }
    if ((st = volux_volume_read_finish(ctx, h, src->name, options, v))) {
        volux_volume_release(v);
        return st;
    }
    *out = v;
    return VOLUX_OK;
}

volux_status volux_volume_read_parts(volux_context *ctx, const volux_volume_header *h, int parts,
                                     const volux_part_source *ps, const volux_volume_load_options *options,
                                     volux_volume **out) {
    const char *name = ps->name;
    if (options && options->region && parts > 1)
        return volux_error(ctx, VOLUX_ERR_UNSUPPORTED, "%s: region: one brick of data split over %d files", name,
                           parts);
    volux_status st = volux_volume_header_check(ctx, name, h);
    if (st) return st;
    size_t esize = volux_scalar_type_size(h->type);
    size_t count = (size_t)h->dims[0] * (size_t)h->dims[1] * (size_t)h->dims[2]; /* checked above */
    if (parts < 1 || count % (size_t)parts)
        return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: %d data files do not split %zu values evenly", name, parts, count);
    size_t per = count / (size_t)parts;
    uint64_t need = (uint64_t)per * esize;

    unsigned char *buf = volux_malloc(ctx, CHUNK);
    uint64_t *begin = volux_malloc(ctx, sizeof *begin * (size_t)parts);
    volux_volume *v = NULL;
    volux_source src;
    int open = 0;
    if (!buf || !begin) {
        st = volux_error(ctx, VOLUX_ERR_NOMEM, "%s: out of memory for a read buffer", name);
        goto fail;
    }
    /* Every part's size is checked before the volume is allocated; one
     * file is open at a time (a stack may have thousands). */
    int had_error = volux_context_error_status(ctx) != VOLUX_OK;
    for (int k = 0; k < parts; k++) {
        if ((st = ps->open(ps->user, k, &src))) goto fail;
        open = 1;
        st = locate_part(ctx, h, &src, k, parts, need, buf, &begin[k]);
        ps->close(ps->user, &src);
        open = 0;
        if (st && options && options->data_root) st = withhold_sizes(ctx, name, h, had_error);
        if (st && parts > 1) volux_error_prefix(ctx, "%s: data file %d of %d: ", name, k + 1, parts);
        if (st) goto fail;
    }
    if (volux_context_out_of_core(ctx)) {
        const char *why = parts > 1 ? "the data is split over several files" : NULL;
        if (!why) {
            if ((st = ps->open(ps->user, 0, &src))) goto fail;
            open = 1;
            why = why_not_mapped(h, &src, begin[0]);
            if (!why) {
                st = map_data(ctx, h, &src, begin[0], options, out);
                ps->close(ps->user, &src);
                open = 0;
                volux_free(ctx, buf, CHUNK);
                volux_free(ctx, begin, sizeof *begin * (size_t)parts);
                return st;
            }
            ps->close(ps->user, &src);
            open = 0;
        }
        volux_warn(ctx, "%s: out of core: not mapped (%s); read into memory", name, why);
    }
    st = volux_volume_create_storage(ctx, h->dims, h->spacing, stored_type(h), &v);
    if (st) {
        volux_error_prefix(ctx, "%s: ", name);
        goto fail;
    }
    for (int k = 0; k < parts; k++) {
        if ((st = ps->open(ps->user, k, &src))) goto fail;
        open = 1;
        st = read_part(ctx, h, &src, begin[k], v, (size_t)k * per, per, count, buf);
        ps->close(ps->user, &src);
        open = 0;
        if (st && parts > 1) volux_error_prefix(ctx, "%s: data file %d of %d: ", name, k + 1, parts);
        if (st) goto fail;
    }
    volux_free(ctx, buf, CHUNK);
    volux_free(ctx, begin, sizeof *begin * (size_t)parts);
    buf = NULL;
    begin = NULL;
    if ((st = volux_volume_read_finish(ctx, h, name, options, v))) goto fail;
    *out = v;
    return VOLUX_OK;

fail:
    if (open) ps->close(ps->user, &src);
    volux_free(ctx, buf, CHUNK);
    volux_free(ctx, begin, sizeof *begin * (size_t)parts);
    volux_volume_release(v);
    return st;
}

static volux_status read_region(volux_context *ctx, const volux_volume_header *h, volux_source *src,
                                const volux_volume_load_options *options, volux_volume **out);

/* The caller's one source, neither reopened nor closed. */
static volux_status single_open(void *user, int k, volux_source *out) {
    (void)k;
    *out = *(volux_source *)user;
    return VOLUX_OK;
}
static void single_close(void *user, volux_source *s) {
    (void)user;
    (void)s;
}

volux_status volux_volume_read_data(volux_context *ctx, const volux_volume_header *h, volux_source *src,
                                    const volux_volume_load_options *options, volux_volume **out) {
    if (options && options->region) return read_region(ctx, h, src, options, out);
    volux_part_source ps = {single_open, single_close, src, src->name};
    return volux_volume_read_parts(ctx, h, 1, &ps, options, out);
}

/* ------------------------------------------------------------------ */
/* One brick of the grid (data-parallel rendering)                      */
/* ------------------------------------------------------------------ */

/* Validates a region against the grid: the brick's stored box. */
volux_status volux_region_box(volux_context *ctx, const char *name, const int dims[3],
                              const volux_volume_region *r, int lo[3], int hi[3]) {
    if (r->count < 1 || r->index < 0 || r->index >= r->count || r->ghost < 0)
        return volux_error(ctx, VOLUX_ERR_INVALID, "%s: region: brick %d of %d (ghost %d) is not a brick", name,
                           r->index, r->count, r->ghost);
    int ghost = r->ghost ? r->ghost : VOLUX_BRICK_GHOST;
    if (volux_brick_region(dims, r->count, r->index, ghost, lo, hi))
        return volux_error(ctx, VOLUX_ERR_INVALID,
                           "%s: region: the %dx%dx%d grid cannot be split into %d bricks of at least one cell each",
                           name, dims[0], dims[1], dims[2], r->count);
    return VOLUX_OK;
}

static volux_status read_rows(const volux_volume_header *h, stream *s, unsigned char *buf, volux_volume *v,
                              size_t first, size_t rows, size_t row_elems, int swap) {
    size_t esize = volux_scalar_type_size(h->type), got;
    volux_status st = stream_read(s, buf, rows * row_elems * esize, &got);
    if (st) return st;
    if (got < rows * row_elems * esize)
        return volux_error(s->ctx, VOLUX_ERR_FORMAT, "%s: data is truncated (in the rows of the brick)", s->src->name);
    if (swap) swap_bytes(buf, rows * row_elems, esize);
    convert_chunk(h, v, first, buf, rows * row_elems);
    return VOLUX_OK;
}

static volux_status read_region(volux_context *ctx, const volux_volume_header *h, volux_source *src,
                                const volux_volume_load_options *options, volux_volume **out) {
    const volux_volume_region *region = options->region;
    int use_file_origin = options->use_file_origin;
    const char *name = src->name;
    uint64_t cap = ctx->max_bytes; /* the whole may be count × the cap */
    if (region->count > 1)
        ctx->max_bytes = cap > UINT64_MAX / (uint64_t)region->count ? UINT64_MAX : cap * (uint64_t)region->count;
    volux_status st = volux_volume_header_check(ctx, name, h);
    ctx->max_bytes = cap;
    if (st) return st;
    int lo[3], hi[3], sub[3];
    if ((st = volux_region_box(ctx, name, h->dims, region, lo, hi))) return st;
    for (int a = 0; a < 3; a++) sub[a] = hi[a] - lo[a];
    size_t esize = volux_scalar_type_size(h->type);
    const size_t nx = (size_t)h->dims[0], ny = (size_t)h->dims[1];
    size_t count = nx * ny * (size_t)h->dims[2]; /* checked above */
    uint64_t need = (uint64_t)count * esize;
    int zlib = h->encoding == VOLUX_ENCODING_ZLIB;
    /* a whole row must fit the buffer: 16384 × 8 bytes ≤ CHUNK */
    unsigned char *buf = volux_malloc(ctx, CHUNK);
    if (!buf) return volux_error(ctx, VOLUX_ERR_NOMEM, "%s: out of memory for a read buffer", name);
    volux_volume *v = NULL;
    stream s;
    memset(&s, 0, sizeof s);
    uint64_t begin;
    /* the whole file's size is checked, as for a whole load */
    int had_error = volux_context_error_status(ctx) != VOLUX_OK;
    if ((st = locate_part(ctx, h, src, 0, 1, need, buf, &begin))) {
        if (options->data_root) st = withhold_sizes(ctx, src->name, h, had_error);
        goto fail;
    }
    /* Only the brick's storage is allocated (and checked against the cap). */
    st = volux_volume_create_storage(ctx, sub, h->spacing, stored_type(h), &v);
    if (st) {
        volux_error_prefix(ctx, "%s: ", name);
        goto fail;
    }
    int swap = esize > 1 && (h->big_endian != volux_host_big_endian());
    size_t row_elems = (size_t)sub[0], dest = 0;
    if (!zlib) {
        /* Raw: seek to each run of rows. When the brick spans whole rows,
         * consecutive rows of a slab are one read. */
        size_t per_read = sub[0] == h->dims[0] ? CHUNK / (nx * esize) : 1;
        if (per_read < 1) per_read = 1;
        for (int k = lo[2]; k < hi[2]; k++)
            for (int j = lo[1]; j < hi[1];) {
                size_t rows = (size_t)(hi[1] - j) < per_read ? (size_t)(hi[1] - j) : per_read;
                uint64_t at = begin + (((uint64_t)k * ny + (uint64_t)j) * nx + (uint64_t)lo[0]) * esize;
                if ((st = stream_open(ctx, src, at, 0, &s)) ||
                    (st = read_rows(h, &s, buf, v, dest, rows, row_elems, swap)))
                    goto fail;
                dest += rows * row_elems;
                j += (int)rows;
            }
    } else {
        /* Compressed: one pass over the stream up to the brick's last row,
         * dropping what lies outside. */
        if ((st = stream_open(ctx, src, begin, 1, &s))) goto fail;
        uint64_t skip = (uint64_t)(h->byte_skip > 0 ? h->byte_skip : 0) + (uint64_t)lo[2] * ny * nx * esize;
        if ((st = discard(&s, buf, skip))) goto fail;
        for (int k = lo[2]; k < hi[2]; k++) {
            if ((st = discard(&s, buf, (uint64_t)lo[1] * nx * esize))) goto fail;
            for (int j = lo[1]; j < hi[1]; j++) {
                size_t got;
                if ((st = stream_read(&s, buf, nx * esize, &got))) goto fail;
                if (got < nx * esize) {
                    st = volux_error(ctx, VOLUX_ERR_FORMAT, "%s: data is truncated (in the rows of the brick)", name);
                    goto fail;
                }
                unsigned char *part = buf + (size_t)lo[0] * esize;
                if (swap) swap_bytes(part, row_elems, esize);
                convert_chunk(h, v, dest, part, row_elems);
                dest += row_elems;
            }
            if (k + 1 < hi[2] && (st = discard(&s, buf, (uint64_t)(h->dims[1] - hi[1]) * nx * esize))) goto fail;
        }
    }
    stream_close(&s);
    volux_free(ctx, buf, CHUNK);
    buf = NULL;
    if ((st = check_nonfinite(ctx, name, v, options->allow_nonfinite))) goto fail;
    double whole_origin[3], part_origin[3];
    volux_brick_origin(h->dims, h->spacing, use_file_origin && h->has_origin ? h->origin : NULL, lo, whole_origin,
                       part_origin);
    if ((st = volux_volume_finalize(v, part_origin))) {
        volux_error_prefix(ctx, "%s: ", name);
        goto fail;
    }
    volux_volume_make_part(v, region->count, region->index, h->dims, lo, whole_origin);
    volux_volume_set_superior(v, h->has_superior ? h->superior : NULL);
    *out = v;
    return VOLUX_OK;

fail:
    stream_close(&s);
    if (buf) volux_free(ctx, buf, CHUNK);
    volux_volume_release(v);
    return st;
}
