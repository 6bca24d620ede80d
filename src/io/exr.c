/* io/exr.c — OpenEXR through the library's C core API (OpenEXR/openexr.h).
 *
 * Reading goes through the library's own decode pipeline: for every chunk
 * (scanline block or tile) exr_decoding_initialize/update, the channel
 * decode pointers aimed straight into our interleaved float image (the
 * library converts half/uint/float to float), then exr_decoding_run.
 *
 * The library's allocation and error callbacks carry no user pointer, so
 * the job of the call in progress is found through a thread-local pointer;
 * the callbacks only ever run on the thread that called the library. */
#include <errno.h>
#include <OpenEXR/openexr.h>
#include <stdio.h>
#include <string.h>

#include "core/context_internal.h"
#include "image_formats.h"

#define EXR "OpenEXR"

typedef struct exr_job {
    volux_context *ctx;
    const char *name;
    char message[256];   /* the library's first error message */
    size_t failed_alloc; /* size of an allocation that failed, or 0 */
    const unsigned char *data; /* read source */
    size_t size;
    FILE *f; /* write sink */
    int64_t pos;
    int write_errno;
    volux_image_meta *meta; /* attributes, when asked */
} exr_job;

static _Thread_local exr_job *current_job;

static void *on_alloc(size_t n) {
    exr_job *job = current_job;
    void *p = job ? volux_io_lib_alloc(job->ctx, n) : NULL;
    if (!p && job) job->failed_alloc = n ? n : 1;
    return p;
}

static void on_free(void *p) { volux_io_lib_free(p); }

static void on_error(exr_const_context_t exr, exr_result_t code, const char *msg) {
    (void)exr;
    exr_job *job = current_job;
    if (job && !job->message[0]) snprintf(job->message, sizeof job->message, "%s", msg ? msg : "");
    (void)code;
}

static int64_t read_memory(exr_const_context_t exr, void *user, void *buffer, uint64_t sz, uint64_t offset,
                           exr_stream_error_func_ptr_t error_cb) {
    (void)exr;
    (void)error_cb;
    exr_job *job = user;
    if (offset >= job->size) return 0; /* a short read: the library reports truncation */
    size_t n = sz < job->size - offset ? (size_t)sz : job->size - (size_t)offset;
    memcpy(buffer, job->data + offset, n);
    return (int64_t)n;
}

static int64_t query_size(exr_const_context_t exr, void *user) {
    (void)exr;
    return (int64_t)((exr_job *)user)->size;
}

static int64_t write_stream(exr_const_context_t exr, void *user, const void *buffer, uint64_t sz, uint64_t offset,
                            exr_stream_error_func_ptr_t error_cb) {
    (void)exr;
    (void)error_cb;
    exr_job *job = user;
    /* The library writes sequentially, then seeks back for the offset table. */
    if ((int64_t)offset != job->pos) {
        if (fseeko(job->f, (off_t)offset, SEEK_SET) != 0) goto failed;
        job->pos = (int64_t)offset;
    }
    if (fwrite(buffer, 1, (size_t)sz, job->f) != sz) goto failed;
    job->pos += (int64_t)sz;
    return (int64_t)sz;
failed:
    job->write_errno = errno ? errno : EIO;
    return -1;
}

static exr_context_initializer_t initializer(exr_job *job) {
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = on_error;
    init.alloc_fn = on_alloc;
    init.free_fn = on_free;
    init.user_data = job;
    return init;
}

/* Status and message for a failed library call while reading. */
static volux_status read_error(exr_job *job, exr_result_t rv, const char *what) {
    const char *why = job->message[0] ? job->message : exr_get_default_error_message(rv);
    if (rv == EXR_ERR_OUT_OF_MEMORY && job->failed_alloc > volux_context_max_bytes(job->ctx))
        return volux_error(job->ctx, VOLUX_ERR_LIMIT, "%s: " EXR ": %s: the library asked for %zu bytes, over the memory cap",
                           job->name, what, job->failed_alloc);
    if (rv == EXR_ERR_OUT_OF_MEMORY)
        return volux_error(job->ctx, VOLUX_ERR_NOMEM, "%s: " EXR ": %s: out of memory", job->name, what);
    if (rv == EXR_ERR_FEATURE_NOT_IMPLEMENTED)
        return volux_error(job->ctx, VOLUX_ERR_UNSUPPORTED, "%s: " EXR ": %s: %s", job->name, what, why);
    return volux_error(job->ctx, VOLUX_ERR_FORMAT, "%s: " EXR ": %s: %s", job->name, what, why);
}

/* ---------------------------------------------------------------- reading */

/* What to decode: the image rectangle and the channel feeding R, G, B. */
typedef struct layout {
    exr_attr_box2i_t dw;
    int64_t width, height;
    int tiled;
    uint32_t tile_w, tile_h;
    int64_t tiles_x, tiles_y; /* tiled: level-0 tile grid */
    int32_t lines_per_chunk;  /* scanline */
    const char *channel[3];   /* R, G, B names; gray: all three the same */
} layout;

static volux_status choose_channels(exr_job *job, exr_context_t exr, layout *lay) {
    const exr_attr_chlist_t *list = NULL;
    exr_result_t rv = exr_get_channels(exr, 0, &list);
    if (rv || !list || list->num_channels < 1) return read_error(job, rv ? rv : EXR_ERR_MISSING_REQ_ATTR, "channels");
    const exr_attr_chlist_entry_t *rgb[3] = {NULL, NULL, NULL}, *y = NULL;
    for (int i = 0; i < list->num_channels; i++) {
        const exr_attr_chlist_entry_t *e = &list->entries[i];
        const char *n = e->name.str;
        if (!n) continue;
        if (!strcmp(n, "R")) rgb[0] = e;
        if (!strcmp(n, "G")) rgb[1] = e;
        if (!strcmp(n, "B")) rgb[2] = e;
        if (!strcmp(n, "Y")) y = e;
    }
    /* Colour if R, G and B exist; else luminance (or a lone channel) as gray. */
    if (!(rgb[0] && rgb[1] && rgb[2])) {
        if (!y && list->num_channels == 1) y = &list->entries[0];
        if (!y)
            return volux_error(job->ctx, VOLUX_ERR_UNSUPPORTED,
                               "%s: " EXR ": no R,G,B or Y channels (first channel: '%.64s')", job->name,
                               list->entries[0].name.str ? list->entries[0].name.str : "");
        rgb[0] = rgb[1] = rgb[2] = y;
    }
    for (int c = 0; c < 3; c++) {
        if (rgb[c]->x_sampling != 1 || rgb[c]->y_sampling != 1)
            return volux_error(job->ctx, VOLUX_ERR_UNSUPPORTED, "%s: " EXR ": channel '%.64s' is subsampled",
                               job->name, rgb[c]->name.str);
        if ((int)rgb[c]->pixel_type < 0 || rgb[c]->pixel_type >= EXR_PIXEL_LAST_TYPE)
            return volux_error(job->ctx, VOLUX_ERR_FORMAT, "%s: " EXR ": channel '%.64s' has an unknown pixel type",
                               job->name, rgb[c]->name.str);
        lay->channel[c] = rgb[c]->name.str;
    }
    return VOLUX_OK;
}

static volux_status read_layout(exr_job *job, exr_context_t exr, layout *lay) {
    int parts = 0;
    exr_storage_t storage;
    exr_result_t rv = exr_get_count(exr, &parts);
    if (!rv && parts < 1) rv = EXR_ERR_MISSING_REQ_ATTR;
    if (!rv) rv = exr_get_storage(exr, 0, &storage);
    if (!rv) rv = exr_get_data_window(exr, 0, &lay->dw);
    if (rv) return read_error(job, rv, "header");
    if (storage != EXR_STORAGE_SCANLINE && storage != EXR_STORAGE_TILED)
        return volux_error(job->ctx, VOLUX_ERR_UNSUPPORTED, "%s: " EXR ": deep images are not supported", job->name);
    lay->width = (int64_t)lay->dw.max.x - lay->dw.min.x + 1;
    lay->height = (int64_t)lay->dw.max.y - lay->dw.min.y + 1;
    volux_status st = volux_io_check_image_size(job->ctx, job->name, EXR, lay->width, lay->height);
    if (st) return st;
    st = choose_channels(job, exr, lay);
    if (st) return st;

    /* Every chunk needs an 8-byte entry in the offset table: a file too
     * small for the table is truncated (checked before the library reads
     * and allocates the table). */
    int32_t chunks = 0;
    rv = exr_get_chunk_count(exr, 0, &chunks);
    if (rv) return read_error(job, rv, "chunk count");
    if (chunks < 1 || (uint64_t)chunks * 8u > job->size)
        return volux_error(job->ctx, VOLUX_ERR_FORMAT, "%s: " EXR ": truncated: %d chunks do not fit in %zu bytes",
                           job->name, chunks, job->size);

    lay->tiled = storage == EXR_STORAGE_TILED;
    if (lay->tiled) {
        exr_tile_level_mode_t mode;
        exr_tile_round_mode_t round;
        int32_t lw = 0, lh = 0;
        rv = exr_get_tile_descriptor(exr, 0, &lay->tile_w, &lay->tile_h, &mode, &round);
        if (!rv) rv = exr_get_level_sizes(exr, 0, 0, 0, &lw, &lh);
        if (rv) return read_error(job, rv, "tile description");
        if (lay->tile_w < 1 || lay->tile_h < 1 || lw != lay->width || lh != lay->height)
            return volux_error(job->ctx, VOLUX_ERR_FORMAT, "%s: " EXR ": inconsistent tile description", job->name);
        lay->tiles_x = (lay->width + lay->tile_w - 1) / lay->tile_w;
        lay->tiles_y = (lay->height + lay->tile_h - 1) / lay->tile_h;
    } else {
        rv = exr_get_scanlines_per_chunk(exr, 0, &lay->lines_per_chunk);
        if (rv) return read_error(job, rv, "scanlines per chunk");
        if (lay->lines_per_chunk < 1)
            return volux_error(job->ctx, VOLUX_ERR_FORMAT, "%s: " EXR ": bad scanlines per chunk", job->name);
    }
    return VOLUX_OK;
}

static int64_t chunk_total(const layout *lay) {
    return lay->tiled ? lay->tiles_x * lay->tiles_y : (lay->height + lay->lines_per_chunk - 1) / lay->lines_per_chunk;
}

/* Chunk i's info and its top-left corner relative to the data window. */
static volux_status chunk_info(exr_job *job, exr_context_t exr, const layout *lay, int64_t i, exr_chunk_info_t *ci,
                               int64_t *x0, int64_t *y0) {
    exr_result_t rv;
    if (lay->tiled) {
        int64_t tx = i % lay->tiles_x, ty = i / lay->tiles_x;
        rv = exr_read_tile_chunk_info(exr, 0, (int)tx, (int)ty, 0, 0, ci);
        *x0 = tx * lay->tile_w;
        *y0 = ty * lay->tile_h;
    } else {
        int64_t y = (int64_t)lay->dw.min.y + i * lay->lines_per_chunk;
        rv = exr_read_scanline_chunk_info(exr, 0, (int)y, ci);
        *x0 = 0;
        *y0 = y - lay->dw.min.y;
    }
    if (rv) return read_error(job, rv, "chunk table");
    /* Never trust the library's idea of the chunk rectangle blindly: the
     * decode writes through pointers into our image. */
    if (ci->width < 1 || ci->height < 1 || *x0 + ci->width > lay->width || *y0 + ci->height > lay->height)
        return volux_error(job->ctx, VOLUX_ERR_FORMAT, "%s: " EXR ": chunk %lld lies outside the data window",
                           job->name, (long long)i);
    if (ci->data_offset > job->size || ci->packed_size > job->size - ci->data_offset)
        return volux_error(job->ctx, VOLUX_ERR_FORMAT, "%s: " EXR ": chunk %lld is truncated", job->name,
                           (long long)i);
    return VOLUX_OK;
}

static volux_status decode_chunks(exr_job *job, exr_context_t exr, const layout *lay, volux_image *img) {
    exr_decode_pipeline_t dec = EXR_DECODE_PIPELINE_INITIALIZER;
    int initialized = 0;
    volux_status st = VOLUX_OK;
    /* Channels we do not keep are decoded into scratch: OpenEXR 3.1's
     * specialised unpackers write through a NULL decode_to_ptr (a crafted
     * B/G/Y half image crashed `volux info`; found by fuzz_exr). */
    unsigned char *scratch = NULL;
    size_t scratch_bytes = 0;
    int64_t n = chunk_total(lay);
    for (int64_t i = 0; i < n && !st; i++) {
        exr_chunk_info_t ci;
        int64_t x0, y0;
        st = chunk_info(job, exr, lay, i, &ci, &x0, &y0);
        if (st) break;
        exr_result_t rv = initialized ? exr_decoding_update(exr, 0, &ci, &dec)
                                      : exr_decoding_initialize(exr, 0, &ci, &dec);
        if (rv) {
            st = read_error(job, rv, "decoder");
            break;
        }
        initialized = 1;
        uint8_t *base = (uint8_t *)(img->rgb + ((size_t)y0 * (size_t)img->width + (size_t)x0) * 3);
        for (int c = 0; c < dec.channel_count; c++) {
            exr_coding_channel_info_t *ch = &dec.channels[c];
            ch->decode_to_ptr = NULL;
            /* In gray images only the first slot (R) is decoded. */
            int slot = -1;
            for (int k = 0; k < 3 && slot < 0; k++)
                if (!strcmp(ch->channel_name, lay->channel[k])) slot = k;
            if (slot < 0) {
                size_t need = (size_t)(ch->width > 0 ? ch->width : 0) * (size_t)(ch->height > 0 ? ch->height : 0) *
                              sizeof(float);
                if (need > scratch_bytes) {
                    volux_free(job->ctx, scratch, scratch_bytes);
                    scratch_bytes = 0;
                    if (!(scratch = volux_malloc(job->ctx, need))) {
                        st = volux_error(job->ctx, VOLUX_ERR_NOMEM, "%s: " EXR ": out of memory for a chunk",
                                         job->name);
                        break;
                    }
                    scratch_bytes = need;
                }
                ch->decode_to_ptr = scratch;
                ch->user_pixel_stride = sizeof(float);
                ch->user_line_stride = (int32_t)(sizeof(float) * (size_t)(ch->width > 0 ? ch->width : 0));
                ch->user_bytes_per_element = sizeof(float);
                ch->user_data_type = EXR_PIXEL_FLOAT;
                continue;
            }
            if (ch->width != ci.width || ch->height != ci.height) {
                st = volux_error(job->ctx, VOLUX_ERR_FORMAT, "%s: " EXR ": chunk %lld: channel size mismatch",
                                 job->name, (long long)i);
                break;
            }
            ch->decode_to_ptr = base + slot * sizeof(float);
            ch->user_pixel_stride = 3 * sizeof(float);
            ch->user_line_stride = (int32_t)(3 * sizeof(float) * (size_t)img->width);
            ch->user_bytes_per_element = sizeof(float);
            ch->user_data_type = EXR_PIXEL_FLOAT;
        }
        if (st) break;
        /* The chunk's bytes must be what its rectangle holds: the library
         * decodes a short uncompressed chunk into garbage (issue 16). */
        uint64_t expect = 0;
        for (int c = 0; c < dec.channel_count; c++)
            expect += (uint64_t)(dec.channels[c].width > 0 ? dec.channels[c].width : 0) *
                      (uint64_t)(dec.channels[c].height > 0 ? dec.channels[c].height : 0) *
                      (uint64_t)dec.channels[c].bytes_per_element;
        if (ci.unpacked_size != expect ||
            (ci.compression == EXR_COMPRESSION_NONE && ci.packed_size != ci.unpacked_size)) {
            st = volux_error(job->ctx, VOLUX_ERR_FORMAT,
                             "%s: " EXR ": chunk %lld holds %llu bytes, but its %dx%d pixels need %llu%s", job->name,
                             (long long)i, (unsigned long long)ci.packed_size, ci.width, ci.height,
                             (unsigned long long)expect,
                             ci.compression == EXR_COMPRESSION_NONE ? " (uncompressed)" : "");
            break;
        }
        rv = exr_decoding_choose_default_routines(exr, 0, &dec);
        if (!rv) rv = exr_decoding_run(exr, 0, &dec);
        if (rv) st = read_error(job, rv, "pixel data");
    }
    if (initialized) exr_decoding_destroy(exr, &dec);
    volux_free(job->ctx, scratch, scratch_bytes);
    if (!st && !strcmp(lay->channel[0], lay->channel[1])) {
        size_t pixels = (size_t)img->width * (size_t)img->height;
        for (size_t p = 0; p < pixels; p++) img->rgb[p * 3 + 1] = img->rgb[p * 3 + 2] = img->rgb[p * 3];
    }
    return st;
}

/* Part 0's own attributes as text: the format's required and standard
 * ones (channels, compression, windows, ...) are the reader's business;
 * strings and numbers a writer added are metadata. */
static void read_meta(exr_context_t exr, volux_image_meta *meta) {
    static const char *const skip[] = {"channels", "compression", "dataWindow", "displayWindow", "lineOrder",
                                       "pixelAspectRatio", "screenWindowCenter", "screenWindowWidth", "tiles",
                                       "type", "name", "version", "chunkCount", NULL};
    int32_t count = 0;
    if (exr_get_attribute_count(exr, 0, &count) != EXR_ERR_SUCCESS) return;
    for (int32_t i = 0; i < count; i++) {
        const exr_attribute_t *a = NULL;
        if (exr_get_attribute_by_index(exr, 0, EXR_ATTR_LIST_FILE_ORDER, i, &a) != EXR_ERR_SUCCESS || !a || !a->name)
            continue;
        int standard = 0;
        for (const char *const *s = skip; *s && !standard; s++) standard = !strcmp(a->name, *s);
        if (standard) continue;
        char value[256];
        if (a->type == EXR_ATTR_STRING && a->string && a->string->str)
            snprintf(value, sizeof value, "%.*s", (int)(a->string->length > 255 ? 255 : a->string->length),
                     a->string->str);
        else if (a->type == EXR_ATTR_INT) snprintf(value, sizeof value, "%d", (int)a->i);
        else if (a->type == EXR_ATTR_FLOAT) snprintf(value, sizeof value, "%.9g", (double)a->f);
        else if (a->type == EXR_ATTR_DOUBLE) snprintf(value, sizeof value, "%.17g", a->d);
        else continue;
        volux_image_meta_set(meta, a->name, value);
    }
}

static volux_status read_image(exr_job *job, exr_context_t exr, volux_image *out) {
    layout lay;
    memset(&lay, 0, sizeof lay);
    volux_status st = read_layout(job, exr, &lay);
    if (st) return st;
    /* Validate the whole chunk table before allocating the image. */
    int64_t n = chunk_total(&lay);
    for (int64_t i = 0; i < n; i++) {
        exr_chunk_info_t ci;
        int64_t x0, y0;
        st = chunk_info(job, exr, &lay, i, &ci, &x0, &y0);
        if (st) return st;
    }
    volux_image img;
    st = volux_io_image_alloc(job->ctx, job->name, EXR, lay.width, lay.height, &img);
    if (st) return st;
    st = decode_chunks(job, exr, &lay, &img);
    if (st) {
        volux_image_free(job->ctx, &img);
        return st;
    }
    *out = img;
    return VOLUX_OK;
}

/* Our own walk over the header attributes before the library parses them
 * (OpenEXR file layout: name\0 type\0 int32 size, then size bytes; a
 * header ends with an empty name; multi-part files have one header per
 * part and an empty header after the last). The library accepts a
 * negative size (issue 16); here every size must be ≥ 0 and end inside
 * the file, names at most 255 bytes (31 without the long-names flag). */
static volux_status check_attributes(volux_context *ctx, const char *name, const unsigned char *d, size_t size) {
    uint32_t version = (uint32_t)d[4] | (uint32_t)d[5] << 8 | (uint32_t)d[6] << 16 | (uint32_t)d[7] << 24;
    int multipart = (version & 0x1000) != 0;
    size_t max_name = (version & 0x400) ? 255 : 31, at = 8;
    for (int header = 0;; header++) {
        int attrs = 0;
        for (;;) {
            if (at >= size)
                return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: " EXR ": truncated header (attribute list never ends)",
                                   name);
            if (d[at] == 0) {
                at++;
                break;
            }
            const char *fields[2];
            size_t lens[2];
            for (int k = 0; k < 2; k++) {
                fields[k] = (const char *)d + at;
                const unsigned char *z = memchr(d + at, 0, size - at);
                if (!z) return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: " EXR ": truncated attribute name", name);
                lens[k] = (size_t)(z - (d + at));
                if (lens[k] == 0 || lens[k] > max_name)
                    return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: " EXR ": attribute %s of %zu bytes (1..%zu allowed)",
                                       name, k ? "type name" : "name", lens[k], max_name);
                at += lens[k] + 1;
            }
            if (size - at < 4)
                return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: " EXR ": attribute '%.*s': truncated size", name,
                                   (int)lens[0], fields[0]);
            int32_t n = (int32_t)((uint32_t)d[at] | (uint32_t)d[at + 1] << 8 | (uint32_t)d[at + 2] << 16 |
                                  (uint32_t)d[at + 3] << 24);
            at += 4;
            if (n < 0)
                return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: " EXR ": attribute '%.*s': negative size %d", name,
                                   (int)lens[0], fields[0], (int)n);
            if ((size_t)n > size - at)
                return volux_error(ctx, VOLUX_ERR_FORMAT,
                                   "%s: " EXR ": attribute '%.*s': size %d runs past the end of the file", name,
                                   (int)lens[0], fields[0], (int)n);
            at += (size_t)n;
            attrs++;
        }
        if (!multipart || attrs == 0) return VOLUX_OK;
        if (header > 1024) return VOLUX_OK; /* the library's part limits take over */
    }
}

volux_status volux_exr_read_memory(volux_context *ctx, const char *name, const void *data, size_t size,
                                   volux_image *out) {
    return volux_exr_read_memory_meta(ctx, name, data, size, out, NULL);
}

volux_status volux_exr_read_memory_meta(volux_context *ctx, const char *name, const void *data, size_t size,
                                        volux_image *out, volux_image_meta *meta) {
    static const unsigned char magic[4] = {0x76, 0x2f, 0x31, 0x01};
    if (size < 8 || memcmp(data, magic, 4) != 0)
        return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: " EXR ": not an OpenEXR file (bad magic number)", name);
    volux_status checked = check_attributes(ctx, name, data, size);
    if (checked) return checked;
    exr_job job;
    memset(&job, 0, sizeof job);
    job.ctx = ctx;
    job.name = name;
    job.data = data;
    job.size = size;
    exr_job *outer = current_job;
    current_job = &job;
    exr_context_initializer_t init = initializer(&job);
    init.read_fn = read_memory;
    init.size_fn = query_size;
    init.max_image_width = init.max_image_height = VOLUX_MAX_IMAGE_DIM;
    init.max_tile_width = init.max_tile_height = VOLUX_MAX_IMAGE_DIM;
    /* A damaged offset table is an error, not a reason to scan the file. */
    init.flags = EXR_CONTEXT_FLAG_DISABLE_CHUNK_RECONSTRUCTION;
    exr_context_t exr = NULL;
    exr_result_t rv = exr_start_read(&exr, name, &init);
    volux_status st = rv ? read_error(&job, rv, "header") : read_image(&job, exr, out);
    if (!st && meta) read_meta(exr, meta);
    exr_finish(&exr);
    current_job = outer;
    return st;
}

/* ---------------------------------------------------------------- writing */

static volux_status write_error(exr_job *job, exr_result_t rv) {
    if (rv == EXR_ERR_OUT_OF_MEMORY)
        return volux_error(job->ctx, VOLUX_ERR_NOMEM, "%s: " EXR ": out of memory while writing", job->name);
    if (job->write_errno)
        return volux_error(job->ctx, VOLUX_ERR_WRITE, "cannot write '%s': %s", job->name, strerror(job->write_errno));
    return volux_error(job->ctx, VOLUX_ERR_WRITE, "cannot write '%s': " EXR ": %s", job->name,
                       job->message[0] ? job->message : exr_get_default_error_message(rv));
}

/* OpenEXRCore 3.1.5 keeps a compressed chunk whose size EQUALS the raw size,
 * but readers (the spec, the C++ library and the core itself) take a chunk
 * with packed size == unpacked size as uncompressed, so such a chunk reads
 * back as garbage. Found by our tests (a 5×4 uint Y image, ZIPS). We wrap
 * the library's compressor and store the raw bytes whenever compression
 * does not make the chunk strictly smaller, as the format intends. */
typedef struct compress_wrap {
    exr_result_t (*library_compress)(exr_encode_pipeline_t *enc);
} compress_wrap;

static exr_result_t compress_or_store_raw(exr_encode_pipeline_t *enc) {
    const compress_wrap *w = enc->encoding_user_data;
    exr_result_t rv = w->library_compress(enc);
    if (rv || enc->compressed_bytes < enc->packed_bytes || enc->compressed_buffer == enc->packed_buffer) return rv;
    if (!enc->compressed_buffer || enc->compressed_alloc_size < enc->packed_bytes) return EXR_ERR_CORRUPT_CHUNK;
    memcpy(enc->compressed_buffer, enc->packed_buffer, (size_t)enc->packed_bytes);
    enc->compressed_bytes = (size_t)enc->packed_bytes;
    return EXR_ERR_SUCCESS;
}

/* One written channel: its name and where its float of pixel (0, 0) is,
 * `stride` floats between pixels. */
typedef struct out_channel {
    char name[64];
    const float *base;
    int stride;
} out_channel;

static exr_result_t write_chunks(exr_context_t exr, int part, int width, int height, const out_channel *chans,
                                 int n_chans) {
    int32_t lines = 0;
    exr_result_t rv = exr_get_scanlines_per_chunk(exr, part, &lines);
    if (rv) return rv;
    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    compress_wrap wrap = {NULL};
    int initialized = 0;
    for (int y = 0; y < height && !rv; y += lines) {
        exr_chunk_info_t ci;
        rv = exr_write_scanline_chunk_info(exr, part, y, &ci);
        if (rv) break;
        rv = initialized ? exr_encoding_update(exr, part, &ci, &enc) : exr_encoding_initialize(exr, part, &ci, &enc);
        if (rv) break;
        initialized = 1;
        for (int c = 0; c < enc.channel_count; c++) {
            exr_coding_channel_info_t *ch = &enc.channels[c];
            for (int k = 0; k < n_chans; k++) {
                if (strcmp(ch->channel_name, chans[k].name)) continue;
                ch->encode_from_ptr = (const uint8_t *)(chans[k].base + (size_t)y * (size_t)width * (size_t)chans[k].stride);
                ch->user_pixel_stride = (int32_t)((size_t)chans[k].stride * sizeof(float));
                ch->user_line_stride = (int32_t)((size_t)chans[k].stride * sizeof(float) * (size_t)width);
            }
            ch->user_bytes_per_element = sizeof(float);
            ch->user_data_type = EXR_PIXEL_FLOAT;
        }
        rv = exr_encoding_choose_default_routines(exr, part, &enc);
        if (!rv && enc.compress_fn) {
            wrap.library_compress = enc.compress_fn;
            enc.encoding_user_data = &wrap;
            enc.compress_fn = compress_or_store_raw;
        }
        if (!rv) rv = exr_encoding_run(exr, part, &enc);
    }
    if (initialized) exr_encoding_destroy(exr, &enc);
    return rv;
}

volux_status volux_exr_write_stream(volux_context *ctx, const char *name, FILE *f, const volux_image *img,
                                    const volux_image_meta *meta) {
    return volux_exr_write_stream_layers(ctx, name, f, img, meta, NULL, 0);
}

volux_status volux_exr_write_stream_layers(volux_context *ctx, const char *name, FILE *f, const volux_image *img,
                                           const volux_image_meta *meta, const volux_image_layer *layers, int n) {
    out_channel chans[3 + 4 * VOLUX_IMAGE_MAX_LAYERS];
    int nc = 0;
    for (int k = 0; k < 3; k++, nc++) {
        snprintf(chans[nc].name, sizeof chans[nc].name, "%s", (const char *[]){"R", "G", "B"}[k]);
        chans[nc].base = img->rgb + k;
        chans[nc].stride = 3;
    }
    for (int i = 0; i < n; i++) {
        const volux_image_layer *l = &layers[i];
        if (l->channels < 1 || l->channels > 4 || !l->data)
            return volux_error(ctx, VOLUX_ERR_INVALID, "'%s': layer %d: %d channels (1 to 4, with data)", name, i,
                               l->channels);
        for (int k = 0; k < l->channels; k++, nc++) {
            const char *cn = l->names[k];
            int w = !cn || !*cn ? -1
                    : l->layer && *l->layer ? snprintf(chans[nc].name, sizeof chans[nc].name, "%s.%s", l->layer, cn)
                                            : snprintf(chans[nc].name, sizeof chans[nc].name, "%s", cn);
            if (w < 0 || (size_t)w >= sizeof chans[nc].name)
                return volux_error(ctx, VOLUX_ERR_INVALID, "'%s': layer %d: channel %d has no name or a name over 63 "
                                   "bytes", name, i, k);
            for (int j = 0; j < nc; j++)
                if (!strcmp(chans[j].name, chans[nc].name))
                    return volux_error(ctx, VOLUX_ERR_INVALID, "'%s': channel '%s' given twice", name, chans[nc].name);
            chans[nc].base = l->data + k;
            chans[nc].stride = l->channels;
        }
    }
    exr_job job;
    memset(&job, 0, sizeof job);
    job.ctx = ctx;
    job.name = name;
    job.f = f;
    exr_job *outer = current_job;
    current_job = &job;
    exr_context_initializer_t init = initializer(&job);
    init.write_fn = write_stream;
    exr_context_t exr = NULL;
    int part = 0;
    exr_result_t rv = exr_start_write(&exr, name, EXR_WRITE_FILE_DIRECTLY, &init);
    if (!rv) rv = exr_add_part(exr, NULL, EXR_STORAGE_SCANLINE, &part);
    if (!rv) rv = exr_initialize_required_attr_simple(exr, part, img->width, img->height, EXR_COMPRESSION_ZIP);
    /* 32-bit float, not half: PFM and EXR must round-trip our radiance exactly. */
    for (int k = 0; k < nc && !rv; k++)
        rv = exr_add_channel(exr, part, chans[k].name, EXR_PIXEL_FLOAT, EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1);
    for (int i = 0; meta && i < meta->count && !rv; i++) rv = exr_attr_set_string(exr, part, meta->key[i], meta->value[i]);
    if (!rv) rv = exr_write_header(exr);
    if (!rv) rv = write_chunks(exr, part, img->width, img->height, chans, nc);
    /* exr_finish writes the chunk offset table, so its result matters too. */
    exr_result_t fin = exr ? exr_finish(&exr) : EXR_ERR_SUCCESS;
    if (!rv) rv = fin;
    volux_status st = rv ? write_error(&job, rv) : VOLUX_OK;
    current_job = outer;
    return st;
}
