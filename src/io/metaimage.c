/*
 * io/metaimage.c — MetaImage header parser (.mhd detached, .mha with
 * ElementDataFile = LOCAL), after ITK's MetaIO documentation.
 *
 * Reads: ObjectType (Image), NDims (3, or 4 with a size-1 first or last
 * axis), DimSize, ElementType (MET_UCHAR, MET_CHAR, MET_USHORT, MET_SHORT,
 * MET_FLOAT, MET_DOUBLE), ElementSpacing (else ElementSize), Offset /
 * Origin / Position, BinaryDataByteOrderMSB / ElementByteOrderMSB,
 * CompressedData (zlib), HeaderSize (-1: data at the end of the file),
 * ElementNumberOfChannels (must be 1), BinaryData (must be True) and
 * ElementDataFile, which ends the header. Other keys are ignored, as MetaIO
 * keeps unknown keys as user fields.
 */
#include <math.h>
#include <string.h>

#include "header_text.h"
#include "volume_formats.h"

#define MAX_AXES 16

enum key {
    K_OBJECT_TYPE,
    K_NDIMS,
    K_DIM_SIZE,
    K_ELEMENT_TYPE,
    K_ELEMENT_SPACING,
    K_ELEMENT_SIZE,
    K_OFFSET,
    K_MSB,
    K_COMPRESSED,
    K_HEADER_SIZE,
    K_CHANNELS,
    K_BINARY,
    K_DATA_FILE,
    K_TRANSFORM,
    K_COMPRESSED_SIZE,
    K_COUNT
};

static const struct {
    const char *name;
    int id;
} keys[] = {
    {"ObjectType", K_OBJECT_TYPE},
    {"NDims", K_NDIMS},
    {"DimSize", K_DIM_SIZE},
    {"ElementType", K_ELEMENT_TYPE},
    {"ElementSpacing", K_ELEMENT_SPACING},
    {"ElementSize", K_ELEMENT_SIZE},
    {"Offset", K_OFFSET},
    {"Origin", K_OFFSET},
    {"Position", K_OFFSET},
    {"BinaryDataByteOrderMSB", K_MSB},
    {"ElementByteOrderMSB", K_MSB},
    {"CompressedData", K_COMPRESSED},
    {"HeaderSize", K_HEADER_SIZE},
    {"ElementNumberOfChannels", K_CHANNELS},
    {"BinaryData", K_BINARY},
    {"ElementDataFile", K_DATA_FILE},
    {"TransformMatrix", K_TRANSFORM},
    {"Rotation", K_TRANSFORM},
    {"Orientation", K_TRANSFORM},
    {"CompressedDataSize", K_COMPRESSED_SIZE},
};

static const struct {
    const char *name;
    volux_scalar_type type;
} types[] = {
    {"MET_UCHAR", VOLUX_UINT8}, {"MET_CHAR", VOLUX_INT8},    {"MET_USHORT", VOLUX_UINT16},
    {"MET_SHORT", VOLUX_INT16}, {"MET_FLOAT", VOLUX_FLOAT32}, {"MET_DOUBLE", VOLUX_FLOAT64},
    /* MetaIO's sizes (MET_ValueTypeSize): INT, UINT, LONG, ULONG 4 bytes, LONG_LONG 8 */
    {"MET_INT", VOLUX_INT32},   {"MET_UINT", VOLUX_UINT32},   {"MET_LONG", VOLUX_INT32},
    {"MET_ULONG", VOLUX_UINT32}, {"MET_LONG_LONG", VOLUX_INT64}, {"MET_ULONG_LONG", VOLUX_UINT64},
};

static const char *const unsupported_types[] = {
    "MET_STRING",
    "MET_ASCII_CHAR", "MET_FLOAT_MATRIX", "MET_UCHAR_ARRAY", "MET_CHAR_ARRAY", "MET_USHORT_ARRAY",
    "MET_SHORT_ARRAY", "MET_INT_ARRAY", "MET_UINT_ARRAY", "MET_FLOAT_ARRAY", "MET_DOUBLE_ARRAY",
};

typedef struct parser {
    volux_context *ctx;
    const char *name;
    volux_text value[K_COUNT];
    int present[K_COUNT];
} parser;

static const char *key_name(int id) {
    for (size_t i = 0; i < sizeof keys / sizeof keys[0]; i++)
        if (keys[i].id == id) return keys[i].name;
    return "?";
}

static volux_status parse_bool(parser *p, int id, int *out) {
    char q[80];
    volux_text v = p->value[id];
    if (volux_text_ieq(v, "true") || volux_text_eq(v, "1")) *out = 1;
    else if (volux_text_ieq(v, "false") || volux_text_eq(v, "0")) *out = 0;
    else
        return volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: %s: expected True or False, got '%s'", p->name, key_name(id),
                           volux_text_quote(v, q, sizeof q));
    return VOLUX_OK;
}

/* Reads "Key = Value" lines up to and including ElementDataFile. */
static volux_status scan_lines(parser *p, const char *bytes, size_t n, uint64_t *header_end) {
    char q[80];
    size_t pos = 0;
    volux_text line = {"", 0};
    int terminated, lineno = 0;
    while (volux_text_line(bytes, n, &pos, &line, &terminated)) {
        lineno++;
        if (volux_text_find_nul(line) >= 0)
            return volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: line %d: NUL byte in the header", p->name, lineno);
        volux_text t = volux_text_trim(line);
        if (t.n == 0) continue;
        const char *eq = memchr(t.p, '=', t.n);
        if (!eq)
            return volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: line %d: expected 'Key = Value', got '%s'", p->name,
                               lineno, volux_text_quote(t, q, sizeof q));
        volux_text key = volux_text_trim((volux_text){t.p, (size_t)(eq - t.p)});
        volux_text value = volux_text_trim((volux_text){eq + 1, t.n - (size_t)(eq - t.p) - 1});
        int id = -1;
        for (size_t i = 0; i < sizeof keys / sizeof keys[0] && id < 0; i++)
            if (volux_text_ieq(key, keys[i].name)) id = keys[i].id;
        if (id < 0) continue; /* user fields, comments, orientation: no effect on the data */
        if (p->present[id])
            return volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: %s: given twice", p->name, key_name(id));
        p->present[id] = 1;
        p->value[id] = value;
        if (id == K_DATA_FILE) {
            if (!terminated && n >= VOLUX_MAX_HEADER_BYTES) break; /* cut by the read limit */
            *header_end = pos;
            return VOLUX_OK;
        }
    }
    if (n >= VOLUX_MAX_HEADER_BYTES)
        return volux_error(p->ctx, VOLUX_ERR_LIMIT, "%s: header is longer than the limit of %u bytes", p->name,
                           (unsigned)VOLUX_MAX_HEADER_BYTES);
    return volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: missing required field 'ElementDataFile'", p->name);
}

static volux_status parse_type(parser *p, volux_volume_header *h) {
    char q[80];
    volux_text v = p->value[K_ELEMENT_TYPE];
    for (size_t i = 0; i < sizeof types / sizeof types[0]; i++)
        if (volux_text_eq(v, types[i].name)) {
            h->type = types[i].type;
            return VOLUX_OK;
        }
    for (size_t i = 0; i < sizeof unsupported_types / sizeof unsupported_types[0]; i++)
        if (volux_text_eq(v, unsupported_types[i]))
            return volux_error(p->ctx, VOLUX_ERR_UNSUPPORTED,
                               "%s: ElementType: %s is not supported (use a scalar integer type, MET_FLOAT or "
                               "MET_DOUBLE)",
                               p->name, unsupported_types[i]);
    return volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: ElementType: unknown type '%s'", p->name,
                       volux_text_quote(v, q, sizeof q));
}

/* Spacing and origin: per-axis number lists of NDims entries. */
static volux_status parse_geometry(parser *p, int ndim, const int axes[3], volux_volume_header *h) {
    double v[MAX_AXES];
    int spacing_key = p->present[K_ELEMENT_SPACING] ? K_ELEMENT_SPACING : K_ELEMENT_SIZE;
    if (p->present[spacing_key]) {
        volux_status st = volux_header_numbers(p->ctx, p->name, key_name(spacing_key), p->value[spacing_key], ndim, v);
        if (st) return st;
        for (int a = 0; a < 3; a++) {
            double s = fabs(v[axes[a]]);
            if (!isfinite(s) || s == 0.0)
                return volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: %s: axis %d must be nonzero and finite, got %g",
                                   p->name, key_name(spacing_key), axes[a], v[axes[a]]);
            h->spacing[a] = s;
        }
    }
    if (p->present[K_TRANSFORM]) {
        /* The direction cosines (NDims × NDims, row-major). volux renders
         * axis-aligned, but a matrix that is not finite or is singular
         * (all zero, two parallel axes) says the header is broken: a
         * silent identity would hide it. */
        double m[MAX_AXES * MAX_AXES];
        volux_status st = volux_header_numbers(p->ctx, p->name, "TransformMatrix", p->value[K_TRANSFORM],
                                               ndim * ndim, m);
        if (st) return st;
        for (int i = 0; i < ndim * ndim; i++)
            if (!isfinite(m[i]))
                return volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: TransformMatrix: entry %d is not finite", p->name, i);
        if (ndim == 3 && volux_header_axes_degenerate(m, m + 3, m + 6))
            return volux_error(p->ctx, VOLUX_ERR_FORMAT,
                               "%s: TransformMatrix: singular (a zero row or parallel axes), not a direction matrix",
                               p->name);
    }
    if (p->present[K_OFFSET]) {
        volux_status st = volux_header_numbers(p->ctx, p->name, "Offset", p->value[K_OFFSET], ndim, v);
        if (st) return st;
        for (int a = 0; a < 3; a++) {
            if (!isfinite(v[axes[a]]))
                return volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: Offset: component %d is not finite", p->name, axes[a]);
            h->origin[a] = v[axes[a]];
        }
        h->has_origin = 1;
    }
    return VOLUX_OK;
}

volux_status volux_metaimage_parse_header(volux_context *ctx, const char *bytes, size_t n, const char *name,
                                          volux_volume_header *out) {
    char q[80];
    parser p;
    memset(&p, 0, sizeof p);
    p.ctx = ctx;
    p.name = name;
    volux_volume_header h;
    volux_volume_header_init(&h);
    uint64_t header_end = 0;
    volux_status st = scan_lines(&p, bytes, n, &header_end);
    if (st) return st;

    static const int required[] = {K_NDIMS, K_DIM_SIZE, K_ELEMENT_TYPE};
    for (size_t i = 0; i < sizeof required / sizeof required[0]; i++)
        if (!p.present[required[i]])
            return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: missing required field '%s'", name, key_name(required[i]));
    if (p.present[K_OBJECT_TYPE] && !volux_text_ieq(p.value[K_OBJECT_TYPE], "Image"))
        return volux_error(ctx, VOLUX_ERR_UNSUPPORTED, "%s: ObjectType: '%s' is not supported, need Image", name,
                           volux_text_quote(p.value[K_OBJECT_TYPE], q, sizeof q));
    int flag;
    if (p.present[K_BINARY]) {
        if ((st = parse_bool(&p, K_BINARY, &flag))) return st;
        if (!flag)
            return volux_error(ctx, VOLUX_ERR_UNSUPPORTED, "%s: BinaryData: ASCII data is not supported", name);
    }
    if (p.present[K_CHANNELS]) {
        int64_t c;
        if (!volux_text_to_i64(p.value[K_CHANNELS], &c) || c < 1)
            return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: ElementNumberOfChannels: expected a positive integer, got '%s'",
                               name, volux_text_quote(p.value[K_CHANNELS], q, sizeof q));
        if (c != 1)
            return volux_error(ctx, VOLUX_ERR_UNSUPPORTED,
                               "%s: ElementNumberOfChannels: %lld channels per voxel are not supported, need 1", name,
                               (long long)c);
    }

    int64_t ndim;
    if (!volux_text_to_i64(p.value[K_NDIMS], &ndim) || ndim < 1 || ndim > MAX_AXES)
        return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: NDims: expected an integer in [1, %d], got '%s'", name, MAX_AXES,
                           volux_text_quote(p.value[K_NDIMS], q, sizeof q));
    int64_t sizes[MAX_AXES];
    int axes[3];
    if ((st = volux_header_sizes(ctx, name, "DimSize", p.value[K_DIM_SIZE], (int)ndim, sizes))) return st;
    if ((st = volux_header_axes(ctx, name, "DimSize", sizes, (int)ndim, &h, axes))) return st;
    if ((st = parse_type(&p, &h))) return st;
    if ((st = parse_geometry(&p, (int)ndim, axes, &h))) return st;
    if (p.present[K_MSB] && (st = parse_bool(&p, K_MSB, &h.big_endian))) return st;
    if (p.present[K_COMPRESSED]) {
        if ((st = parse_bool(&p, K_COMPRESSED, &flag))) return st;
        h.encoding = flag ? VOLUX_ENCODING_ZLIB : VOLUX_ENCODING_RAW;
    }

    if (p.present[K_COMPRESSED_SIZE]) {
        int64_t cs;
        if (!volux_text_to_i64(p.value[K_COMPRESSED_SIZE], &cs) || cs < 1)
            return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: CompressedDataSize: expected a positive integer, got '%s'",
                               name, volux_text_quote(p.value[K_COMPRESSED_SIZE], q, sizeof q));
        if (h.encoding != VOLUX_ENCODING_ZLIB)
            return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: CompressedDataSize: given, but CompressedData is not True",
                               name);
        h.compressed_size = (uint64_t)cs;
    }

    volux_text file = p.value[K_DATA_FILE];
    if (volux_text_ieq(file, "LOCAL")) h.data_offset = header_end;
    else if ((st = volux_header_data_file(ctx, name, "ElementDataFile", file, &h))) return st;

    if (p.present[K_HEADER_SIZE]) {
        int64_t skip;
        if (!volux_text_to_i64(p.value[K_HEADER_SIZE], &skip) || skip < -1)
            return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: HeaderSize: expected an integer >= -1, got '%s'", name,
                               volux_text_quote(p.value[K_HEADER_SIZE], q, sizeof q));
        if (skip == -1) {
            if (h.encoding != VOLUX_ENCODING_RAW)
                return volux_error(ctx, VOLUX_ERR_FORMAT,
                                   "%s: HeaderSize: -1 (data at the end) is not allowed with CompressedData", name);
            h.byte_skip = -1;
        } else if (!h.data_file[0]) {
            /* LOCAL data starts right after the ElementDataFile line; a
             * HeaderSize there would contradict that, so we do not apply it. */
        } else {
            /* Bytes of the data file before the (possibly compressed) data. */
            h.data_offset = (uint64_t)skip;
        }
    }
    if ((st = volux_volume_header_check(ctx, name, &h))) return st;
    *out = h;
    return VOLUX_OK;
}
