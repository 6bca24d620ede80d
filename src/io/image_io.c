/* io/image_io.c — volux_image_load / volux_image_save: format by extension,
 * whole-file reads into context memory, atomic writes (temp file + rename). */
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "core/context_internal.h"
#include "file_open.h"
#include "image_formats.h"
#include "output_file.h"
#include "volux/io.h"

typedef enum image_format { FORMAT_UNKNOWN, FORMAT_PNG, FORMAT_PFM, FORMAT_EXR, FORMAT_HDR } image_format;

#define READ_EXTENSIONS ".png .pfm .exr .hdr"
#define WRITE_EXTENSIONS ".png .pfm .exr"

/* Extension of the last path component, compared case-insensitively. */
static image_format format_of(const char *path) {
    const char *slash = strrchr(path, '/');
    const char *base = slash ? slash + 1 : path;
    const char *dot = strrchr(base, '.');
    if (!dot) return FORMAT_UNKNOWN;
    if (!strcasecmp(dot, ".png")) return FORMAT_PNG;
    if (!strcasecmp(dot, ".pfm")) return FORMAT_PFM;
    if (!strcasecmp(dot, ".exr")) return FORMAT_EXR;
    if (!strcasecmp(dot, ".hdr")) return FORMAT_HDR;
    return FORMAT_UNKNOWN;
}

volux_status volux_io_check_image_size(volux_context *ctx, const char *name, const char *format, int64_t width,
                                       int64_t height) {
    if (width < 1 || height < 1)
        return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: %s: declares an empty image (%lldx%lld)", name, format,
                           (long long)width, (long long)height);
    if (width > VOLUX_MAX_IMAGE_DIM || height > VOLUX_MAX_IMAGE_DIM)
        return volux_error(ctx, VOLUX_ERR_LIMIT, "%s: %s: image size %lldx%lld exceeds the limit of %d per side",
                           name, format, (long long)width, (long long)height, VOLUX_MAX_IMAGE_DIM);
    /* Both sides ≤ 2^15, so the product fits easily in 64 bits. */
    uint64_t bytes = (uint64_t)width * (uint64_t)height * 3u * sizeof(float);
    if (bytes > volux_context_max_bytes(ctx))
        return volux_error(ctx, VOLUX_ERR_LIMIT, "%s: %s: a %lldx%lld image needs %llu bytes, over the memory cap of %llu",
                           name, format, (long long)width, (long long)height, (unsigned long long)bytes,
                           (unsigned long long)volux_context_max_bytes(ctx));
    return VOLUX_OK;
}

volux_status volux_io_image_alloc(volux_context *ctx, const char *name, const char *format, int64_t width,
                                  int64_t height, volux_image *out) {
    volux_status st = volux_io_check_image_size(ctx, name, format, width, height);
    if (st) return st;
    st = volux_image_create(ctx, (int)width, (int)height, out);
    if (st) volux_error_prefix(ctx, "%s: %s: ", name, format);
    return st;
}

/* Reads the whole file into context memory: *size bytes were read into a
 * block of *alloc bytes (free with volux_free(ctx, *data, *alloc)). */
static volux_status read_file(volux_context *ctx, const char *path, unsigned char **data, size_t *size,
                              size_t *alloc) {
    int fd;
    uint64_t file_size;
    volux_status status = volux_file_open_read_fd(ctx, path, &fd, &file_size);
    if (status) return status;
    if (file_size > volux_context_max_bytes(ctx) || file_size > SIZE_MAX / 2) {
        close(fd);
        return volux_error(ctx, VOLUX_ERR_LIMIT, "'%s': file of %llu bytes is over the memory cap of %llu", path,
                           (unsigned long long)file_size, (unsigned long long)volux_context_max_bytes(ctx));
    }
    size_t cap = (size_t)file_size, n = 0;
    unsigned char *buf = volux_malloc(ctx, cap + 1);
    if (!buf) {
        close(fd);
        return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory (%zu bytes) reading '%s'", cap, path);
    }
    while (n < cap) {
        ssize_t got = read(fd, buf + n, cap - n);
        if (got < 0 && errno == EINTR) continue;
        if (got < 0) {
            int e = errno;
            close(fd);
            volux_free(ctx, buf, cap + 1);
            return volux_error(ctx, VOLUX_ERR_IO, "cannot read '%s': %s", path, strerror(e));
        }
        if (got == 0) break; /* file shrank while we read: parse what is there */
        n += (size_t)got;
    }
    close(fd);
    *data = buf;
    *size = n;
    *alloc = cap + 1;
    return VOLUX_OK;
}

volux_status volux_image_load(volux_context *ctx, const char *path, volux_image *out) {
    image_format fmt = format_of(path);
    if (fmt == FORMAT_UNKNOWN)
        return volux_error(ctx, VOLUX_ERR_INVALID, "'%s': unknown image extension (supported: " READ_EXTENSIONS ")",
                           path);
    unsigned char *data = NULL;
    size_t size = 0, alloc = 0;
    volux_status st = read_file(ctx, path, &data, &size, &alloc);
    if (st) return st;
    switch (fmt) {
    case FORMAT_PNG: st = volux_png_read_memory(ctx, path, data, size, out); break;
    case FORMAT_PFM: st = volux_pfm_read_memory(ctx, path, data, size, out); break;
    case FORMAT_EXR: st = volux_exr_read_memory(ctx, path, data, size, out); break;
    case FORMAT_HDR: st = volux_hdr_read_memory(ctx, path, data, size, out); break;
    case FORMAT_UNKNOWN: break;
    }
    volux_free(ctx, data, alloc);
    return st;
}

/* ---- save: io/output_file.h ---- */

static volux_status write_format(volux_context *ctx, image_format fmt, const char *path, FILE *f,
                                 const volux_image *img, float exposure, const volux_image_meta *meta) {
    switch (fmt) {
    case FORMAT_PNG: return volux_png_write_stream(ctx, path, f, img, exposure, meta);
    case FORMAT_PFM: return volux_pfm_write_stream(ctx, path, f, img);
    case FORMAT_EXR: return volux_exr_write_stream(ctx, path, f, img, meta);
    default: break;
    }
    return volux_error(ctx, VOLUX_ERR_INTERNAL, "'%s': no writer for this format", path);
}

volux_status volux_image_save(volux_context *ctx, const char *path, const volux_image *img, float exposure) {
    return volux_image_save_meta(ctx, path, img, exposure, NULL);
}

void volux_image_meta_set(volux_image_meta *m, const char *key, const char *value) {
    if (!key || !value || !*key || strlen(key) >= sizeof m->key[0]) return;
    int i = 0;
    while (i < m->count && strcmp(m->key[i], key)) i++;
    if (i == m->count) {
        if (m->count >= VOLUX_IMAGE_MAX_META) return;
        m->count++;
        snprintf(m->key[i], sizeof m->key[i], "%s", key);
    }
    snprintf(m->value[i], sizeof m->value[i], "%s", value);
}

const char *volux_image_meta_get(const volux_image_meta *m, const char *key) {
    for (int i = 0; i < m->count; i++)
        if (!strcmp(m->key[i], key)) return m->value[i];
    return NULL;
}

volux_status volux_image_load_meta(volux_context *ctx, const char *path, volux_image *out, volux_image_meta *meta) {
    memset(meta, 0, sizeof *meta);
    image_format fmt = format_of(path);
    if (fmt != FORMAT_PNG && fmt != FORMAT_EXR) return volux_image_load(ctx, path, out);
    unsigned char *data = NULL;
    size_t size = 0, alloc = 0;
    volux_status st = read_file(ctx, path, &data, &size, &alloc);
    if (st) return st;
    st = fmt == FORMAT_PNG ? volux_png_read_memory_meta(ctx, path, data, size, out, meta)
                           : volux_exr_read_memory_meta(ctx, path, data, size, out, meta);
    volux_free(ctx, data, alloc);
    return st;
}

volux_status volux_image_check_output(volux_context *ctx, const char *path) {
    image_format fmt = format_of(path);
    if (fmt == FORMAT_UNKNOWN || fmt == FORMAT_HDR)
        return volux_error(ctx, VOLUX_ERR_INVALID, "'%s': cannot write this extension (supported: " WRITE_EXTENSIONS ")",
                           path);
    volux_status st = volux_file_check_output(ctx, path);
    if (st) return st;
    /* Permission bits do not tell everything (root passes access() on
     * /proc, a read-only mount, a full quota): open the file the save
     * would write, and drop it (unnamed: nothing is left, even if killed). */
    volux_output_file probe;
    if ((st = volux_output_begin(ctx, path, &probe))) {
        volux_context_clear_error(ctx);
        return volux_error(ctx, VOLUX_ERR_IO, "cannot write '%s': %s", path,
                           "the folder does not take new files here (read-only or a special file system)");
    }
    volux_output_abort(ctx, &probe);
    return VOLUX_OK;
}

volux_status volux_image_save_meta(volux_context *ctx, const char *path, const volux_image *img, float exposure,
                                   const volux_image_meta *meta) {
    return volux_image_save_layers(ctx, path, img, exposure, meta, NULL, 0);
}

volux_status volux_image_save_layers(volux_context *ctx, const char *path, const volux_image *img, float exposure,
                                     const volux_image_meta *meta, const volux_image_layer *layers, int n) {
    image_format fmt = format_of(path);
    if (n > 0 && fmt != FORMAT_EXR)
        return volux_error(ctx, VOLUX_ERR_INVALID, "'%s': extra image layers (AOVs) need an .exr file", path);
    if (n < 0 || n > VOLUX_IMAGE_MAX_LAYERS || (n > 0 && !layers))
        return volux_error(ctx, VOLUX_ERR_INVALID, "'%s': %d extra layers (at most %d)", path, n,
                           VOLUX_IMAGE_MAX_LAYERS);
    if (fmt == FORMAT_UNKNOWN || fmt == FORMAT_HDR)
        return volux_error(ctx, VOLUX_ERR_INVALID, "'%s': cannot write this extension (supported: " WRITE_EXTENSIONS ")",
                           path);
    if (!img || !img->rgb || img->width < 1 || img->height < 1 || img->width > VOLUX_MAX_IMAGE_DIM ||
        img->height > VOLUX_MAX_IMAGE_DIM)
        return volux_error(ctx, VOLUX_ERR_INVALID, "'%s': no image to write", path);
    if (fmt == FORMAT_PNG && !isfinite(exposure))
        return volux_error(ctx, VOLUX_ERR_INVALID, "'%s': exposure must be finite", path);

    volux_output_file out;
    volux_status st = volux_output_begin(ctx, path, &out);
    if (st) return st;
    st = n > 0 ? volux_exr_write_stream_layers(ctx, path, out.f, img, meta, layers, n)
               : write_format(ctx, fmt, path, out.f, img, exposure, meta);
    if (st) {
        volux_output_abort(ctx, &out);
        return st;
    }
    return volux_output_commit(ctx, &out);
}

/* ---- in memory ---- */

volux_status volux_image_encode(volux_context *ctx, const volux_image *img, const char *format, float exposure,
                                unsigned char **out, size_t *size) {
    return volux_image_encode_meta(ctx, img, format, exposure, NULL, out, size);
}

volux_status volux_image_encode_meta(volux_context *ctx, const volux_image *img, const char *format, float exposure,
                                     const volux_image_meta *meta, unsigned char **out, size_t *size) {
    image_format fmt = FORMAT_UNKNOWN;
    if (format && !strcasecmp(format, "png")) fmt = FORMAT_PNG;
    else if (format && !strcasecmp(format, "pfm")) fmt = FORMAT_PFM;
    else if (format && !strcasecmp(format, "exr")) fmt = FORMAT_EXR;
    if (fmt == FORMAT_UNKNOWN)
        return volux_error(ctx, VOLUX_ERR_INVALID, "image encoding '%s': expected png, pfm or exr",
                           format ? format : "(null)");
    if (!img || !img->rgb || img->width < 1 || img->height < 1 || img->width > VOLUX_MAX_IMAGE_DIM ||
        img->height > VOLUX_MAX_IMAGE_DIM)
        return volux_error(ctx, VOLUX_ERR_INVALID, "image encoding: no image");
    if (fmt == FORMAT_PNG && !isfinite(exposure))
        return volux_error(ctx, VOLUX_ERR_INVALID, "image encoding: exposure must be finite");
    /* The writers stream into a FILE; a memory stream reuses them as they
     * are, so the bytes are those of the file volux_image_save writes. */
    char *buf = NULL;
    size_t len = 0;
    FILE *f = open_memstream(&buf, &len);
    if (!f) return volux_error(ctx, VOLUX_ERR_NOMEM, "image encoding: out of memory");
    char name[16];
    snprintf(name, sizeof name, "(%s)", format);
    volux_status st = write_format(ctx, fmt, name, f, img, exposure, meta);
    if (fclose(f) != 0 && !st) st = volux_error(ctx, VOLUX_ERR_NOMEM, "image encoding: out of memory");
    if (!st) {
        unsigned char *copy = volux_alloc_or_error(ctx, len ? len : 1, "an encoded image");
        if (!copy) st = VOLUX_ERR_NOMEM;
        else {
            memcpy(copy, buf, len);
            *out = copy;
            *size = len;
        }
    }
    free(buf);
    return st;
}

void volux_encoded_free(volux_context *ctx, unsigned char *data, size_t size) {
    if (data) volux_free(ctx, data, size ? size : 1);
}
