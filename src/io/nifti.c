/*
 * io/nifti.c — NIfTI-1 and NIfTI-2 header parser, after the format
 * definitions (nifti1.h, 2004, and nifti2.h, 2011, of the NIfTI Data
 * Format Working Group).
 *
 * Reads the 348-byte NIfTI-1 or 540-byte NIfTI-2 header in either byte
 * order (version and order told apart by sizeof_hdr), magic "n+1"/"n+2"
 * (.nii, data at vox_offset) or "ni1"/"ni2" (.hdr with the data in a .img
 * beside it), dim[0] = 3 (or 4 with dim[4] = 1),
 * datatypes uint8/int8/uint16/int16/float32/float64, spacing |pixdim[1..3]|,
 * scl_slope/scl_inter (applied unless slope is 0 or the pair is (1, 0)),
 * and an origin from the qform offset (else the sform translation).
 * Orientation (quaternion, sform rotation) is not representable in a volux
 * volume (its grid axes are the world's) and is dropped, except for one
 * fact: where superior (+z of the scanner's RAS space) points in the grid,
 * which tells the default camera which way is up. Extensions after the header are skipped through
 * vox_offset.
 */
#include <math.h>
#include <string.h>

#include "header_text.h"
#include "volume_formats.h"

typedef struct reader {
    const unsigned char *b;
    int big; /* the file is big-endian (decided by sizeof_hdr) */
} reader;

static uint32_t u32(const reader *r, size_t off) {
    const unsigned char *p = r->b + off;
    return r->big ? (uint32_t)p[3] | (uint32_t)p[2] << 8 | (uint32_t)p[1] << 16 | (uint32_t)p[0] << 24
                   : (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}
static int16_t i16(const reader *r, size_t off) {
    const unsigned char *p = r->b + off;
    return (int16_t)(r->big ? (uint16_t)(p[1] | p[0] << 8) : (uint16_t)(p[0] | p[1] << 8));
}
static double f32(const reader *r, size_t off) {
    uint32_t u = u32(r, off);
    float f;
    memcpy(&f, &u, 4);
    return f;
}

/* Header field offsets (nifti1.h). */
enum {
    O_DIM = 40,
    O_DATATYPE = 70,
    O_BITPIX = 72,
    O_PIXDIM = 76,
    O_VOX_OFFSET = 108,
    O_SCL_SLOPE = 112,
    O_SCL_INTER = 116,
    O_QFORM_CODE = 252,
    O_SFORM_CODE = 254,
    O_QUATERN_B = 256, /* then c, d */
    O_QOFFSET = 268,
    O_SROW = 280,
    O_MAGIC = 344
};

static volux_status datatype(volux_context *ctx, const char *name, int code, volux_scalar_type *t) {
    switch (code) {
    case 2: *t = VOLUX_UINT8; return VOLUX_OK;
    case 256: *t = VOLUX_INT8; return VOLUX_OK;
    case 4: *t = VOLUX_INT16; return VOLUX_OK;
    case 512: *t = VOLUX_UINT16; return VOLUX_OK;
    case 16: *t = VOLUX_FLOAT32; return VOLUX_OK;
    case 64: *t = VOLUX_FLOAT64; return VOLUX_OK;
    case 8: *t = VOLUX_INT32; return VOLUX_OK;
    case 768: *t = VOLUX_UINT32; return VOLUX_OK;
    case 1024: *t = VOLUX_INT64; return VOLUX_OK;
    case 1280: *t = VOLUX_UINT64; return VOLUX_OK;
    /* binary, complex, RGB(A) and float128: not scalar data we can render */
    case 1: case 32: case 128: case 1536: case 1792: case 2048: case 2304:
        return volux_error(ctx, VOLUX_ERR_UNSUPPORTED,
                           "%s: datatype: code %d is not supported (use an integer or a float32/float64 type)", name,
                           code);
    }
    return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: datatype: unknown code %d", name, code);
}

/* "dir/x.hdr" → "x.img": the pair's data file, relative to the header. */
static volux_status pair_data_file(volux_context *ctx, const char *name, volux_volume_header *h) {
    if (!volux_text_ends_with_ci(name, ".hdr"))
        return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: a 'ni1' header (a .hdr/.img pair) must be named *.hdr", name);
    const char *base = strrchr(name, '/');
    base = base ? base + 1 : name;
    size_t n = strlen(base);
    if (n > VOLUX_MAX_DATA_NAME)
        return volux_error(ctx, VOLUX_ERR_LIMIT, "%s: file name is over the limit of %d characters", name,
                           VOLUX_MAX_DATA_NAME);
    memcpy(h->data_file, base, n - 4);
    memcpy(h->data_file + n - 4, base[n - 3] == 'H' ? ".IMG" : ".img", 5);
    return VOLUX_OK;
}

/* NIfTI-2 (nifti2.h, 2011): the same fields, 64-bit integers and doubles,
 * in a 540-byte header. Offsets of the fields we read. */
enum {
    O2_MAGIC = 4,
    O2_DATATYPE = 12,
    O2_BITPIX = 14,
    O2_DIM = 16,
    O2_PIXDIM = 104,
    O2_VOX_OFFSET = 168,
    O2_SCL_SLOPE = 176,
    O2_SCL_INTER = 184,
    O2_QFORM_CODE = 344,
    O2_SFORM_CODE = 348,
    O2_QOFFSET = 376,
    O2_SROW = 400
};

static uint64_t u64(const reader *r, size_t off) {
    uint64_t lo = u32(r, off), hi = u32(r, off + 4);
    return r->big ? (lo << 32 | hi) : (hi << 32 | lo);
}
static int32_t i32(const reader *r, size_t off) { return (int32_t)u32(r, off); }
static double f64(const reader *r, size_t off) {
    uint64_t u = u64(r, off);
    double d;
    memcpy(&d, &u, 8);
    return d;
}

/* What both versions say, in the wider types of NIfTI-2. */
typedef struct nifti_fields {
    int version;     /* 1 or 2 */
    int single;      /* "n+1"/"n+2": data in this file; else a .hdr/.img pair */
    int64_t dim[8];
    int datatype, bitpix;
    double pixdim[4];
    double vox_offset;
    double slope, inter;
    int qform_code, sform_code;
    double qoffset[3];
    double srow[3][4];
} nifti_fields;

static void read_v1(const reader *r, nifti_fields *f) {
    for (int i = 0; i < 8; i++) f->dim[i] = i16(r, O_DIM + 2 * (size_t)i);
    f->datatype = i16(r, O_DATATYPE);
    f->bitpix = i16(r, O_BITPIX);
    for (int i = 0; i < 4; i++) f->pixdim[i] = f32(r, O_PIXDIM + 4 * (size_t)i);
    f->vox_offset = f32(r, O_VOX_OFFSET);
    f->slope = f32(r, O_SCL_SLOPE);
    f->inter = f32(r, O_SCL_INTER);
    f->qform_code = i16(r, O_QFORM_CODE);
    f->sform_code = i16(r, O_SFORM_CODE);
    for (int a = 0; a < 3; a++) f->qoffset[a] = f32(r, O_QOFFSET + 4 * (size_t)a);
    for (int k = 0; k < 3; k++)
        for (int c = 0; c < 4; c++) f->srow[k][c] = f32(r, O_SROW + 16 * (size_t)k + 4 * (size_t)c);
}

static void read_v2(const reader *r, nifti_fields *f) {
    for (int i = 0; i < 8; i++) f->dim[i] = (int64_t)u64(r, O2_DIM + 8 * (size_t)i);
    f->datatype = i16(r, O2_DATATYPE);
    f->bitpix = i16(r, O2_BITPIX);
    for (int i = 0; i < 4; i++) f->pixdim[i] = f64(r, O2_PIXDIM + 8 * (size_t)i);
    int64_t vox = (int64_t)u64(r, O2_VOX_OFFSET);
    f->vox_offset = (double)vox; /* checked as a double like NIfTI-1's float field */
    if (vox < 0) f->vox_offset = -1.0;
    f->slope = f64(r, O2_SCL_SLOPE);
    f->inter = f64(r, O2_SCL_INTER);
    f->qform_code = i32(r, O2_QFORM_CODE);
    f->sform_code = i32(r, O2_SFORM_CODE);
    for (int a = 0; a < 3; a++) f->qoffset[a] = f64(r, O2_QOFFSET + 8 * (size_t)a);
    for (int k = 0; k < 3; k++)
        for (int c = 0; c < 4; c++) f->srow[k][c] = f64(r, O2_SROW + 32 * (size_t)k + 8 * (size_t)c);
}

volux_status volux_nifti_parse_header(volux_context *ctx, const unsigned char *bytes, size_t n, const char *name,
                                      volux_volume_header *out) {
    if (n < 4)
        return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: file of %zu bytes is shorter than the 348-byte NIfTI-1 header",
                           name, n);
    /* sizeof_hdr tells the version and the byte order. */
    reader r = {bytes, 0};
    uint32_t le = u32(&r, 0);
    r.big = 1;
    uint32_t be = u32(&r, 0);
    int version = 0;
    if (le == 348 || le == 540) r.big = 0, version = le == 348 ? 1 : 2;
    else if (be == 348 || be == 540) r.big = 1, version = be == 348 ? 1 : 2;
    else
        return volux_error(ctx, VOLUX_ERR_FORMAT,
                           "%s: sizeof_hdr: not a NIfTI file (expected 348 or 540, got %u)", name, (unsigned)le);
    size_t header_bytes = version == 1 ? VOLUX_NIFTI_HEADER_BYTES : VOLUX_NIFTI2_HEADER_BYTES;
    if (n < header_bytes)
        return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: file of %zu bytes is shorter than the %zu-byte NIfTI-%d header",
                           name, n, header_bytes, version);
    volux_volume_header h;
    volux_volume_header_init(&h);
    h.big_endian = r.big;

    nifti_fields f;
    memset(&f, 0, sizeof f);
    f.version = version;
    int pair;
    if (version == 1) {
        const unsigned char *magic = bytes + O_MAGIC;
        f.single = memcmp(magic, "n+1", 4) == 0;
        pair = memcmp(magic, "ni1", 4) == 0;
        if (!f.single && !pair)
            return volux_error(ctx, VOLUX_ERR_UNSUPPORTED,
                               "%s: magic: no NIfTI-1 magic ('n+1' or 'ni1'); Analyze 7.5 files are not supported", name);
        read_v1(&r, &f);
    } else {
        /* "n+2\0\r\n\032\n": the tail catches text-mode transfers. */
        const unsigned char *magic = bytes + O2_MAGIC;
        f.single = memcmp(magic, "n+2\0\r\n\032\n", 8) == 0;
        pair = memcmp(magic, "ni2\0\r\n\032\n", 8) == 0;
        if (!f.single && !pair)
            return volux_error(ctx, VOLUX_ERR_FORMAT,
                               "%s: magic: not 'n+2' or 'ni2' followed by \\r\\n\\032\\n (a NIfTI-2 header damaged "
                               "by a text-mode transfer?)",
                               name);
        read_v2(&r, &f);
    }

    int64_t ndim = f.dim[0];
    if (ndim == 4 && f.dim[4] != 1)
        return volux_error(ctx, VOLUX_ERR_UNSUPPORTED,
                           "%s: dim: 4-D data with %lld time points is not supported, need a 3-D volume", name,
                           (long long)f.dim[4]);
    if (ndim != 3 && ndim != 4) {
        if (ndim < 1 || ndim > 7)
            return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: dim[0]: expected 1..7, got %lld", name, (long long)ndim);
        return volux_error(ctx, VOLUX_ERR_UNSUPPORTED, "%s: dim[0]: %lld-D data is not supported, need 3", name,
                           (long long)ndim);
    }
    for (int a = 0; a < 3; a++) {
        int64_t d = f.dim[a + 1];
        if (d < 1)
            return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: dim[%d]: expected a positive size, got %lld", name, a + 1,
                               (long long)d);
        if (d > VOLUX_MAX_DIM)
            return volux_error(ctx, VOLUX_ERR_LIMIT, "%s: dim[%d]: size %lld is over the limit of %d", name, a + 1,
                               (long long)d, VOLUX_MAX_DIM);
        h.dims[a] = (int)d;
    }
    volux_status st = datatype(ctx, name, f.datatype, &h.type);
    if (st) return st;
    if ((size_t)f.bitpix != 8 * volux_scalar_type_size(h.type))
        return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: bitpix: %d does not match datatype %s", name, f.bitpix,
                           volux_scalar_type_name(h.type));

    int sform = f.sform_code > 0;
    if (sform) {
        /* A declared sform that is not a transform (a NaN, or an all-zero
         * matrix) is ignored, and said so, rather than read as one. */
        int finite = 1, nonzero = 0;
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 4; j++) {
                finite &= isfinite(f.srow[i][j]) != 0;
                nonzero |= j < 3 && f.srow[i][j] != 0.0;
            }
        if (!finite || !nonzero) {
            volux_warn(ctx, "%s: sform_code %d but the sform is %s: ignored (orientation and origin from the qform "
                            "or pixdim)",
                       name, f.sform_code, finite ? "all zero" : "not finite");
            sform = 0;
        }
    }
    for (int a = 0; a < 3; a++) {
        double s = f.pixdim[a + 1];
        if (!isfinite(s))
            return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: pixdim[%d]: not finite", name, a + 1);
        if (s == 0.0) {
            /* A zero spacing is only readable through the sform: the
             * length of its column a is the voxel size along axis a. */
            s = sqrt(f.srow[0][a] * f.srow[0][a] + f.srow[1][a] * f.srow[1][a] + f.srow[2][a] * f.srow[2][a]);
            if (!sform || !isfinite(s) || s == 0.0)
                return volux_error(ctx, VOLUX_ERR_FORMAT,
                                   "%s: pixdim[%d]: zero, and no sform (sform_code > 0, nonzero column %d) to take "
                                   "the voxel size from",
                                   name, a + 1, a);
        }
        h.spacing[a] = fabs(s);
    }

    double vox = f.vox_offset;
    size_t min_offset = header_bytes;
    if (!isfinite(vox) || vox < 0.0 || vox != floor(vox) || vox > 9007199254740992.0)
        return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: vox_offset: expected a non-negative integer, got %g", name, vox);
    if (f.single && vox < (double)min_offset)
        return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: vox_offset: %g points inside the %zu-byte header", name, vox,
                           min_offset);
    h.data_offset = (uint64_t)vox;
    if (pair && (st = pair_data_file(ctx, name, &h))) return st;

    double slope = f.slope, inter = f.inter;
    /* slope 0 means "no scaling"; NaN slope or intercept are read as unset
     * (nibabel). An infinite one would turn every value into ±Inf or NaN:
     * a broken header. */
    if (isinf(slope)) return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: scl_slope: infinite", name);
    if (isinf(inter) && isfinite(slope) && slope != 0.0)
        return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: scl_inter: infinite", name);
    if (isnan(inter)) inter = 0.0;
    if (isfinite(slope) && slope != 0.0 && !(slope == 1.0 && inter == 0.0)) {
        h.apply_scale = 1;
        h.scale_slope = slope;
        h.scale_inter = inter;
    }

    if (f.qform_code > 0 || sform) {
        for (int a = 0; a < 3; a++) {
            h.origin[a] = f.qform_code > 0 ? f.qoffset[a] : f.srow[a][3];
            if (!isfinite(h.origin[a]))
                return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: origin component %d is not finite", name, a);
        }
        h.has_origin = 1;
    }
    /* Superior in the grid: the z (superior) component of each axis' unit
     * direction. qform: row 3 of the quaternion's rotation matrix
     * (nifti1.h), its third column times qfac = pixdim[0] (−1 or 1); sform:
     * srow_z over each column's length. */
    double up[3] = {0, 0, 0};
    if (i16(&r, O_QFORM_CODE) > 0) {
        double b = f32(&r, O_QUATERN_B), c = f32(&r, O_QUATERN_B + 4), d = f32(&r, O_QUATERN_B + 8);
        double a2 = 1.0 - (b * b + c * c + d * d);
        double a = a2 > 0.0 ? sqrt(a2) : 0.0;
        double qfac = f32(&r, O_PIXDIM) < 0.0 ? -1.0 : 1.0;
        up[0] = 2.0 * (b * d - a * c);
        up[1] = 2.0 * (c * d + a * b);
        up[2] = qfac * (a * a + d * d - b * b - c * c);
    } else if (sform && i16(&r, O_SFORM_CODE) > 0) {
        for (int col = 0; col < 3; col++) {
            double x = f.srow[0][col], y = f.srow[1][col], z = f.srow[2][col];
            double len = sqrt(x * x + y * y + z * z);
            up[col] = len > 0.0 ? z / len : 0.0;
        }
    }
    if (isfinite(up[0]) && isfinite(up[1]) && isfinite(up[2]) && up[0] * up[0] + up[1] * up[1] + up[2] * up[2] > 1e-12) {
        memcpy(h.superior, up, sizeof up);
        h.has_superior = 1;
    }
    if ((st = volux_volume_header_check(ctx, name, &h))) return st;
    *out = h;
    return VOLUX_OK;
}
