/*
 * io/volume_load.c — volux_volume_load: picks the reader by extension (or
 * by the first bytes when the extension is unknown), reads the header into
 * memory, parses it, applies the detached-data folder policy, and hands the
 * data to the common reader (volume_data.c).
 */
#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "header_text.h"
#include "scene_formats.h"
#include "volume_formats.h"

#define MAX_PATH_BYTES 4096

typedef enum kind { K_NRRD, K_METAIMAGE, K_NIFTI, K_NIFTI_GZ, K_VTI, K_RAW, K_DICOM, K_UNKNOWN } kind;

static kind kind_from_extension(const char *path) {
    static const struct {
        const char *ext;
        kind k;
    } exts[] = {
        {".nrrd", K_NRRD}, {".nhdr", K_NRRD},   {".mhd", K_METAIMAGE}, {".mha", K_METAIMAGE},
        {".nii.gz", K_NIFTI_GZ}, {".nii", K_NIFTI}, {".hdr", K_NIFTI},  {".vti", K_VTI}, {".raw", K_RAW},
        {".dcm", K_DICOM}, {".dicom", K_DICOM},
    };
    for (size_t i = 0; i < sizeof exts / sizeof exts[0]; i++)
        if (volux_text_ends_with_ci(path, exts[i].ext)) return exts[i].k;
    return K_UNKNOWN;
}

int volux_volume_path_is_known(const char *path) {
    kind k = path ? kind_from_extension(path) : K_UNKNOWN;
    if (k == K_UNKNOWN && path) return volux_dicom_path_is_dicom(path); /* a folder, or the DICM magic */
    return k != K_UNKNOWN && k != K_RAW;
}

/* For unknown extensions: recognise a format by its first bytes. */
static kind kind_from_bytes(const unsigned char *b, size_t n) {
    if (n >= 132 && memcmp(b + 128, "DICM", 4) == 0) return K_DICOM; /* PS3.10 preamble + prefix */
    if (n >= 7 && memcmp(b, "NRRD000", 7) == 0) return K_NRRD;
    if ((n >= 5 && memcmp(b, "<?xml", 5) == 0) || (n >= 8 && memcmp(b, "<VTKFile", 8) == 0)) return K_VTI;
    if (n >= 2 && b[0] == 0x1f && b[1] == 0x8b) return K_NIFTI_GZ;
    if (n >= 4 && ((b[0] == 0x5c && b[1] == 1 && !b[2] && !b[3]) || (!b[0] && !b[1] && b[2] == 1 && b[3] == 0x5c)))
        return K_NIFTI; /* sizeof_hdr 348 */
    if (n >= 4 && ((b[0] == 0x1c && b[1] == 2 && !b[2] && !b[3]) || (!b[0] && !b[1] && b[2] == 2 && b[3] == 0x1c)))
        return K_NIFTI; /* 540: NIfTI-2 */
    volux_text t = {(const char *)b, n};
    volux_text rest = t, tok;
    if (volux_text_token(&rest, &tok) && tok.n >= 5 &&
        (memcmp(tok.p, "ObjectType", tok.n < 10 ? tok.n : 10) == 0 || memcmp(tok.p, "NDims", 5) == 0))
        return K_METAIMAGE;
    return K_UNKNOWN;
}

/* Reads the header bytes and parses them with the format's entry point. */
static volux_status parse_header(volux_context *ctx, kind k, volux_source *src, volux_volume_header *h) {
    const char *name = src->name;
    if (k == K_VTI) return volux_vti_parse_header(ctx, src, h);
    if (k == K_NIFTI || k == K_NIFTI_GZ) {
        unsigned char b[VOLUX_NIFTI2_HEADER_BYTES]; /* a NIfTI-1 file may be shorter: got says */
        size_t got;
        volux_status st = k == K_NIFTI ? volux_source_read(ctx, src, 0, b, sizeof b, &got)
                                       : volux_source_inflate_prefix(ctx, src, 0, b, sizeof b, &got);
        if (st) return st;
        if ((st = volux_nifti_parse_header(ctx, b, got, name, h))) return st;
        if (k == K_NIFTI_GZ) {
            if (h->data_file[0])
                return volux_error(ctx, VOLUX_ERR_FORMAT,
                                   "%s: magic: a .nii.gz must hold a single-file ('n+1') header, not 'ni1'", name);
            /* The header is part of the compressed stream: the data starts
             * vox_offset bytes into the decoded stream. */
            h->encoding = VOLUX_ENCODING_ZLIB;
            h->byte_skip = (int64_t)h->data_offset;
            h->data_offset = 0;
            return volux_volume_header_check(ctx, name, h);
        }
        return VOLUX_OK;
    }
    size_t n = src->size < VOLUX_MAX_HEADER_BYTES ? (size_t)src->size : VOLUX_MAX_HEADER_BYTES, got;
    char *text = volux_malloc(ctx, n);
    if (!text) return volux_error(ctx, VOLUX_ERR_NOMEM, "%s: out of memory for the header", name);
    volux_status st = volux_source_read(ctx, src, 0, text, n, &got);
    if (!st)
        st = k == K_NRRD ? volux_nrrd_parse_header(ctx, text, got, name, h)
                         : volux_metaimage_parse_header(ctx, text, got, name, h);
    volux_free(ctx, text, n);
    return st;
}

/* Detached data: the data file's path, relative to the header's folder.
 * Unless allowed, names that could leave that folder are refused: an
 * absolute path or any ".." component (a header from an untrusted source
 * must not make us read arbitrary files). */
static volux_status resolve_data_path(volux_context *ctx, const char *header_path, const char *data_file,
                                      int allow_outside, char *out, size_t cap) {
    if (!allow_outside) {
        if (data_file[0] == '/')
            return volux_error(ctx, VOLUX_ERR_FORMAT,
                               "%s: data file: absolute path '%s' is outside the header's folder (not allowed unless "
                               "the scene's volume says \"allow_outside_dir\": true)",
                               header_path, data_file);
        for (const char *p = data_file; *p;) {
            const char *slash = strchr(p, '/');
            size_t len = slash ? (size_t)(slash - p) : strlen(p);
            if (len == 2 && p[0] == '.' && p[1] == '.')
                return volux_error(ctx, VOLUX_ERR_FORMAT,
                                   "%s: data file: '%s' leads outside the header's folder ('..' is not allowed unless "
                                   "the scene's volume says \"allow_outside_dir\": true)",
                                   header_path, data_file);
            p += len + (slash ? 1 : 0);
        }
    }
    const char *slash = strrchr(header_path, '/');
    size_t dir = data_file[0] == '/' || !slash ? 0 : (size_t)(slash - header_path) + 1;
    size_t len = strlen(data_file);
    if (dir + len + 1 > cap)
        return volux_error(ctx, VOLUX_ERR_LIMIT, "%s: data file: path is longer than %zu bytes", header_path, cap - 1);
    memcpy(out, header_path, dir);
    memcpy(out + dir, data_file, len + 1);
    return VOLUX_OK;
}

/* The data file `path` (already free of ".." and absolute names) must
 * still lie inside the header's folder once symbolic links are resolved:
 * a link in the folder may point anywhere (/etc/passwd). Compares the
 * realpath of both. A missing file is left to the open that follows. The
 * message names the field, never the link's target or its size. */
static volux_status check_containment(volux_context *ctx, const char *header_path, const char *data_file,
                                      const char *path) {
    char dir[MAX_PATH_BYTES], real_dir[PATH_MAX], real_file[PATH_MAX];
    const char *slash = strrchr(header_path, '/');
    size_t n = slash ? (size_t)(slash - header_path) : 0;
    if (!slash) snprintf(dir, sizeof dir, ".");
    else if (n == 0) snprintf(dir, sizeof dir, "/");
    else snprintf(dir, sizeof dir, "%.*s", (int)n, header_path);
    if (!realpath(dir, real_dir))
        return volux_error(ctx, VOLUX_ERR_IO, "%s: cannot resolve the header's folder: %s", header_path,
                           strerror(errno));
    if (!realpath(path, real_file)) return VOLUX_OK; /* missing: reported by the open */
    size_t d = strlen(real_dir);
    int inside = strncmp(real_file, real_dir, d) == 0 && (real_file[d] == '/' || (d == 1 && real_dir[0] == '/'));
    if (!inside)
        return volux_error(ctx, VOLUX_ERR_FORMAT,
                           "%s: data file: '%s' is a symbolic link (or lies under one) that leads outside the "
                           "header's folder (not allowed)",
                           header_path, data_file);
    return VOLUX_OK;
}

/* A volume split over h->file_count data files. Names are made (pattern)
 * or found (LIST lines, indexed once) when a part is opened; each is
 * resolved and contained like a single data file. */
/* With a data root (volux_volume_load_options.data_root), the data file
 * must lie inside it once symbolic links are resolved: the textual checks
 * cannot see a link that leaves the folder, the resolved name can. On
 * success `path` holds the resolved name. */
static volux_status check_data_root(volux_context *ctx, const char *header, const char *data_file, const char *root,
                                    char *path, size_t cap) {
    /* Missing and outside read the same: no existence oracle. */
    char real[PATH_MAX];
    if (!realpath(path, real) || !volux_path_inside(real, root))
        return volux_error(ctx, VOLUX_ERR_INVALID, "%s: data file: '%s' is not available in the data root", header,
                           data_file);
    if (strlen(real) >= cap) return volux_error(ctx, VOLUX_ERR_LIMIT, "%s: data file: path is too long", header);
    strcpy(path, real);
    return VOLUX_OK;
}

typedef struct split_files {
    volux_context *ctx;
    const volux_volume_header *h;
    const char *header;
    int allow_outside;
    const char *data_root; /* NULL: none */
    const char *list;    /* LIST: the header file's bytes after the LIST line */
    size_t *line_start;  /* LIST: where entry i starts / its length */
    size_t *line_len;
    char path[MAX_PATH_BYTES];
} split_files;

static volux_status split_open(void *user, int k, volux_source *out) {
    split_files *f = user;
    volux_context *ctx = f->ctx;
    char name[VOLUX_MAX_DATA_NAME + 1];
    if (f->h->file_list) {
        memcpy(name, f->list + f->line_start[k], f->line_len[k]);
        name[f->line_len[k]] = 0;
    } else {
        int64_t number = f->h->file_first + (int64_t)k * f->h->file_step;
        if (number < -2147483647 - 1 || number > 2147483647)
            return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: data file: number %lld does not fit the format", f->header,
                               (long long)number);
        /* The format was checked to hold exactly one int conversion. */
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wformat-nonliteral"
        int n = snprintf(name, sizeof name, f->h->data_file, (int)number);
#pragma GCC diagnostic pop
        if (n < 0 || (size_t)n >= sizeof name)
            return volux_error(ctx, VOLUX_ERR_LIMIT, "%s: data file: name %d is too long", f->header, k + 1);
    }
    volux_status st = resolve_data_path(ctx, f->header, name, f->allow_outside, f->path, sizeof f->path);
    if (!st && f->data_root) st = check_data_root(ctx, f->header, name, f->data_root, f->path, sizeof f->path);
    if (!st && !f->allow_outside) st = check_containment(ctx, f->header, name, f->path);
    if (!st && (st = volux_source_open(ctx, f->path, out)))
        volux_error_prefix(ctx, "%s: data file %d of %d: ", f->header, k + 1, f->h->file_count);
    return st;
}

static void split_close(void *user, volux_source *s) {
    (void)user;
    volux_source_close(s);
}

static volux_status load_files(volux_context *ctx, const volux_volume_header *h, volux_source *src,
                               const volux_volume_load_options *options, volux_volume **out) {
    int n = h->file_count;
    split_files f;
    memset(&f, 0, sizeof f);
    f.ctx = ctx;
    f.h = h;
    f.header = src->name;
    f.allow_outside = options && options->allow_outside_dir;
    f.data_root = options ? options->data_root : NULL;
    char *list = NULL;
    size_t list_cap = 0, list_n = 0;
    volux_status st = VOLUX_OK;
    if (h->file_list) {
        uint64_t avail = src->size > h->list_offset ? src->size - h->list_offset : 0;
        uint64_t cap = (uint64_t)n * (VOLUX_MAX_DATA_NAME + 2) + 4096;
        list_cap = (size_t)(avail < cap ? avail : cap); /* more: reported as extra entries below */
        list = volux_malloc(ctx, list_cap + 1);
        f.line_start = volux_calloc(ctx, (size_t)n, sizeof *f.line_start);
        f.line_len = volux_calloc(ctx, (size_t)n, sizeof *f.line_len);
        if (!list || !f.line_start || !f.line_len) {
            st = volux_error(ctx, VOLUX_ERR_NOMEM, "%s: out of memory for the data file list", src->name);
            goto done;
        }
        if ((st = volux_source_read(ctx, src, h->list_offset, list, list_cap, &list_n))) goto done;
        /* One name per line; blank lines name nothing. */
        size_t pos = 0;
        int i = 0;
        while (pos < list_n) {
            const char *line = list + pos, *nl = memchr(line, '\n', list_n - pos);
            size_t len = nl ? (size_t)(nl - line) : list_n - pos;
            volux_text t = volux_text_trim((volux_text){line, len});
            pos += len + (nl ? 1 : 0);
            if (t.n == 0) continue;
            if (i == n) {
                st = volux_error(ctx, VOLUX_ERR_FORMAT, "%s: data file: LIST names more than the %d files the sizes need",
                                 src->name, n);
                goto done;
            }
            if (t.n > VOLUX_MAX_DATA_NAME || memchr(t.p, 0, t.n)) {
                st = volux_error(ctx, VOLUX_ERR_FORMAT, "%s: data file: LIST entry %d is too long or holds a NUL byte",
                                 src->name, i + 1);
                goto done;
            }
            f.line_start[i] = (size_t)(t.p - list);
            f.line_len[i++] = t.n;
        }
        if (i < n) {
            st = volux_error(ctx, VOLUX_ERR_FORMAT, "%s: data file: LIST names %d files, the sizes need %d", src->name,
                             i, n);
            goto done;
        }
        f.list = list;
    }
    volux_part_source ps = {split_open, split_close, &f, src->name};
    st = volux_volume_read_parts(ctx, h, n, &ps, options, out);
done:
    volux_free(ctx, list, list_cap + 1);
    volux_free(ctx, f.line_start, (size_t)n * sizeof *f.line_start);
    volux_free(ctx, f.line_len, (size_t)n * sizeof *f.line_len);
    return st;
}

/* Parses the header in `src` and reads the data, from `src` itself or from
 * the detached file (which a memory source cannot reach). Errors about the
 * detached data name the header the caller passed first. */
static volux_status load_from(volux_context *ctx, kind k, volux_source *src, int from_memory,
                              const volux_volume_load_options *options, volux_volume **out) {
    if (k == K_VTI && options && options->region) /* its own framing has no sub-box reader */
        return volux_error(ctx, VOLUX_ERR_UNSUPPORTED, "%s: region: one brick of a VTK ImageData file", src->name);
    if (k == K_VTI) return volux_vti_read(ctx, src, options, out); /* always attached, own framing */
    volux_volume_header h;
    /* A brick is 1/count of the grid: the header's whole size may be up to
     * count × the cap (the brick itself is checked against the cap). */
    uint64_t cap = ctx->max_bytes;
    if (options && options->region && options->region->count > 1)
        ctx->max_bytes = cap > UINT64_MAX / (uint64_t)options->region->count
                             ? UINT64_MAX
                             : cap * (uint64_t)options->region->count;
    volux_status st = parse_header(ctx, k, src, &h);
    ctx->max_bytes = cap;
    if (st) return st;
    if (h.file_count > 0) {
        if (from_memory)
            return volux_error(ctx, VOLUX_ERR_IO, "%s: data file: %d data files cannot be read when loading from memory",
                               src->name, h.file_count);
        return load_files(ctx, &h, src, options, out);
    }
    if (!h.data_file[0]) return volux_volume_read_data(ctx, &h, src, options, out);

    char path[MAX_PATH_BYTES];
    int allow_outside = options && options->allow_outside_dir;
    st = resolve_data_path(ctx, src->name, h.data_file, allow_outside, path, sizeof path);
    if (st) return st;
    if (options && options->data_root && !from_memory &&
        (st = check_data_root(ctx, src->name, h.data_file, options->data_root, path, sizeof path)))
        return st;
    if (from_memory)
        return volux_error(ctx, VOLUX_ERR_IO, "%s: data file: '%s' cannot be read when loading from memory",
                           src->name, h.data_file);
    if (!allow_outside && (st = check_containment(ctx, src->name, h.data_file, path))) return st;
    volux_source data;
    st = volux_source_open(ctx, path, &data);
    if (!st) {
        st = volux_volume_read_data(ctx, &h, &data, options, out);
        volux_source_close(&data);
    }
    if (st) volux_error_prefix(ctx, "%s: data file: ", src->name);
    return st;
}

/* Opens `path` and decides its format (by extension, else by its first
 * bytes). On success the caller closes *src. */
static volux_status open_volume(volux_context *ctx, const char *path, volux_source *src, kind *k_out) {
    if (!path || !*path) return volux_error(ctx, VOLUX_ERR_INVALID, "volume path is empty");
    kind k = kind_from_extension(path);
    if (k == K_RAW)
        return volux_error(ctx, VOLUX_ERR_INVALID,
                           "%s: a .raw file needs a description of its layout (dims, type, byte order)", path);
    volux_status st = volux_source_open(ctx, path, src);
    if (st) return st;
    if (k == K_UNKNOWN) {
        unsigned char b[132];
        size_t got;
        if (!(st = volux_source_read(ctx, src, 0, b, sizeof b, &got))) {
            k = kind_from_bytes(b, got);
            if (k == K_UNKNOWN)
                st = volux_error(ctx, VOLUX_ERR_UNSUPPORTED,
                                 "%s: unknown volume format (expected " VOLUX_VOLUME_EXTENSIONS ", or .raw "
                                 "with a description)",
                                 path);
        }
    }
    if (st) {
        volux_source_close(src);
        return st;
    }
    *k_out = k;
    return VOLUX_OK;
}

volux_status volux_volume_load(volux_context *ctx, const char *path, const volux_volume_load_options *options,
                               volux_volume **out) {
    if (!path || !*path) return volux_error(ctx, VOLUX_ERR_INVALID, "volume path is empty");
    volux_source src;
    volux_status st;
    if (options && options->raw) {
        volux_volume_header h;
        uint64_t cap = ctx->max_bytes; /* as in load_from, for a brick */
        if (options->region && options->region->count > 1)
            ctx->max_bytes = cap > UINT64_MAX / (uint64_t)options->region->count
                                 ? UINT64_MAX
                                 : cap * (uint64_t)options->region->count;
        st = volux_raw_header_from_desc(ctx, options->raw, path, &h);
        ctx->max_bytes = cap;
        if (st) return st;
        if ((st = volux_source_open(ctx, path, &src))) return st;
        st = volux_volume_read_data(ctx, &h, &src, options, out);
        volux_source_close(&src);
        return st;
    }
    /* DICOM: a folder, a .dcm file or a file with the PS3.10 prefix
     * (dicom.c reads the whole series). */
    kind ke = kind_from_extension(path);
    if (ke == K_DICOM || (ke == K_UNKNOWN && volux_dicom_path_is_dicom(path)))
        return volux_dicom_load(ctx, path, options, out);
    kind k = K_UNKNOWN; /* set by open_volume on success */
    if ((st = open_volume(ctx, path, &src, &k))) return st;
    if (k == K_DICOM) {
        volux_source_close(&src);
        return volux_dicom_load(ctx, path, options, out);
    }
    st = load_from(ctx, k, &src, 0, options, out);
    volux_source_close(&src);
    return st;
}

volux_status volux_volume_probe(volux_context *ctx, const char *path, const volux_volume_load_options *options,
                                volux_volume_shape *out) {
    volux_volume_header h;
    volux_status st;
    if (options && options->raw) {
        if ((st = volux_raw_header_from_desc(ctx, options->raw, path, &h))) return st;
        /* the file must exist and be readable like every other frame */
        volux_source src;
        if ((st = volux_source_open(ctx, path, &src))) return st;
        volux_source_close(&src);
    } else {
        volux_source src;
        kind k = K_UNKNOWN;
        kind ke = kind_from_extension(path);
        if (ke == K_DICOM || (ke == K_UNKNOWN && volux_dicom_path_is_dicom(path)))
            return volux_error(ctx, VOLUX_ERR_UNSUPPORTED, "%s: a DICOM series as a frame of a sequence", path);
        if ((st = open_volume(ctx, path, &src, &k))) return st;
        if (k == K_DICOM) {
            volux_source_close(&src);
            return volux_error(ctx, VOLUX_ERR_UNSUPPORTED, "%s: a DICOM series as a frame of a sequence", path);
        }
        st = parse_header(ctx, k, &src, &h);
        volux_source_close(&src);
        if (st) return st;
        if (h.data_file[0] && h.file_count == 0) {
            /* A frame's detached data follows the same policy as a load
             * (folder, data root) now, not when its time step is shown. */
            char data[MAX_PATH_BYTES];
            int allow_outside = options && options->allow_outside_dir;
            if ((st = resolve_data_path(ctx, path, h.data_file, allow_outside, data, sizeof data)) ||
                (options && options->data_root &&
                 (st = check_data_root(ctx, path, h.data_file, options->data_root, data, sizeof data))) ||
                (!allow_outside && (st = check_containment(ctx, path, h.data_file, data))))
                return st;
        }
    }
    memcpy(out->dims, h.dims, sizeof out->dims);
    memcpy(out->spacing, h.spacing, sizeof out->spacing);
    out->type = h.apply_scale ? VOLUX_FLOAT32 : h.type;
    return VOLUX_OK;
}

volux_status volux_volume_load_memory(volux_context *ctx, const void *bytes, size_t n, const char *name,
                                      volux_volume_format format, const volux_volume_load_options *options,
                                      volux_volume **out) {
    static const kind kinds[] = {K_NRRD, K_METAIMAGE, K_NIFTI, K_NIFTI_GZ, K_VTI};
    volux_source src;
    volux_source_memory(bytes, n, name, &src);
    return load_from(ctx, kinds[format], &src, 1, options, out);
}
