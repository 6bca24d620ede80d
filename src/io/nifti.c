/*
 * io/nifti.c — NIfTI-1 header parser, after the NIfTI-1 format definition
 * (nifti1.h of the NIfTI Data Format Working Group, 2004).
 *
 * Reads the 348-byte header in either byte order (told apart by
 * sizeof_hdr), magic "n+1" (.nii, data at vox_offset) or "ni1" (.hdr with
 * the data in a .img beside it), dim[0] = 3 (or 4 with dim[4] = 1),
 * datatypes uint8/int8/uint16/int16/float32/float64, spacing |pixdim[1..3]|,
 * scl_slope/scl_inter (applied unless slope is 0 or the pair is (1, 0)),
 * and an origin from the qform offset (else the sform translation).
 * Orientation (quaternion, sform rotation) is not representable in a volux
 * volume and is dropped. Extensions after the header are skipped through
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
    case 1: case 8: case 32: case 128: case 768: case 1024: case 1280: case 1536: case 1792: case 2048: case 2304:
        return volux_error(ctx, VOLUX_ERR_UNSUPPORTED,
                           "%s: datatype: code %d is not supported (use uint8, int8, uint16, int16, float32 or float64)",
                           name, code);
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

volux_status volux_nifti_parse_header(volux_context *ctx, const unsigned char *bytes, size_t n, const char *name,
                                      volux_volume_header *out) {
    if (n < VOLUX_NIFTI_HEADER_BYTES)
        return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: file of %zu bytes is shorter than the 348-byte NIfTI-1 header",
                           name, n);
    reader r = {bytes, 0};
    if (u32(&r, 0) != 348) {
        r.big = 1;
        if (u32(&r, 0) != 348) {
            r.big = 0;
            uint32_t le = u32(&r, 0);
            r.big = 1;
            if (le == 540 || u32(&r, 0) == 540)
                return volux_error(ctx, VOLUX_ERR_UNSUPPORTED, "%s: NIfTI-2 files are not supported", name);
            return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: sizeof_hdr: not a NIfTI-1 file (expected 348, got %u)", name,
                               (unsigned)le);
        }
    }
    volux_volume_header h;
    volux_volume_header_init(&h);
    h.big_endian = r.big;

    const unsigned char *magic = bytes + O_MAGIC;
    int single = memcmp(magic, "n+1", 4) == 0, pair = memcmp(magic, "ni1", 4) == 0;
    if (!single && !pair)
        return volux_error(ctx, VOLUX_ERR_UNSUPPORTED,
                           "%s: magic: no NIfTI-1 magic ('n+1' or 'ni1'); Analyze 7.5 files are not supported", name);

    int ndim = i16(&r, O_DIM);
    if (ndim == 4 && i16(&r, O_DIM + 8) != 1)
        return volux_error(ctx, VOLUX_ERR_UNSUPPORTED,
                           "%s: dim: 4-D data with %d time points is not supported, need a 3-D volume", name,
                           i16(&r, O_DIM + 8));
    if (ndim != 3 && ndim != 4) {
        if (ndim < 1 || ndim > 7)
            return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: dim[0]: expected 1..7, got %d", name, ndim);
        return volux_error(ctx, VOLUX_ERR_UNSUPPORTED, "%s: dim[0]: %d-D data is not supported, need 3", name, ndim);
    }
    for (int a = 0; a < 3; a++) {
        int d = i16(&r, O_DIM + 2 * (size_t)(a + 1));
        if (d < 1)
            return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: dim[%d]: expected a positive size, got %d", name, a + 1, d);
        if (d > VOLUX_MAX_DIM)
            return volux_error(ctx, VOLUX_ERR_LIMIT, "%s: dim[%d]: size %d is over the limit of %d", name, a + 1, d,
                               VOLUX_MAX_DIM);
        h.dims[a] = d;
    }
    int code = i16(&r, O_DATATYPE);
    volux_status st = datatype(ctx, name, code, &h.type);
    if (st) return st;
    int bitpix = i16(&r, O_BITPIX);
    if ((size_t)bitpix != 8 * volux_scalar_type_size(h.type))
        return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: bitpix: %d does not match datatype %s", name, bitpix,
                           volux_scalar_type_name(h.type));

    int sform = i16(&r, O_SFORM_CODE) > 0;
    for (int a = 0; a < 3; a++) {
        double s = f32(&r, O_PIXDIM + 4 * (size_t)(a + 1));
        if (!isfinite(s))
            return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: pixdim[%d]: not finite", name, a + 1);
        if (s == 0.0) {
            /* A zero spacing is only readable through the sform: the
             * length of its column a is the voxel size along axis a. */
            double c[3];
            for (int k = 0; k < 3; k++) c[k] = f32(&r, O_SROW + 16 * (size_t)k + 4 * (size_t)a);
            s = sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
            if (!sform || !isfinite(s) || s == 0.0)
                return volux_error(ctx, VOLUX_ERR_FORMAT,
                                   "%s: pixdim[%d]: zero, and no sform (sform_code > 0, nonzero column %d) to take "
                                   "the voxel size from",
                                   name, a + 1, a);
        }
        h.spacing[a] = fabs(s);
    }

    double vox = f32(&r, O_VOX_OFFSET);
    if (!isfinite(vox) || vox < 0.0 || vox != floor(vox) || vox > 9007199254740992.0)
        return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: vox_offset: expected a non-negative integer, got %g", name, vox);
    if (single && vox < VOLUX_NIFTI_HEADER_BYTES)
        return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: vox_offset: %g points inside the 348-byte header", name, vox);
    h.data_offset = (uint64_t)vox;
    if (pair && (st = pair_data_file(ctx, name, &h))) return st;

    double slope = f32(&r, O_SCL_SLOPE), inter = f32(&r, O_SCL_INTER);
    /* NIfTI-1: slope 0 means "no scaling"; NaN slope or intercept are read
     * as unset (nibabel). An infinite one would turn every value into ±Inf
     * or NaN: a broken header. */
    if (isinf(slope)) return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: scl_slope: infinite", name);
    if (isinf(inter) && isfinite(slope) && slope != 0.0)
        return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: scl_inter: infinite", name);
    if (isnan(inter)) inter = 0.0;
    if (isfinite(slope) && slope != 0.0 && !(slope == 1.0 && inter == 0.0)) {
        h.apply_scale = 1;
        h.scale_slope = slope;
        h.scale_inter = inter;
    }

    size_t origin_at = 0, stride = 0;
    if (i16(&r, O_QFORM_CODE) > 0) origin_at = O_QOFFSET, stride = 4;
    else if (i16(&r, O_SFORM_CODE) > 0) origin_at = O_SROW + 12, stride = 16; /* srow_x[3], srow_y[3], srow_z[3] */
    if (origin_at) {
        for (int a = 0; a < 3; a++) {
            h.origin[a] = f32(&r, origin_at + stride * (size_t)a);
            if (!isfinite(h.origin[a]))
                return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: origin component %d is not finite", name, a);
        }
        h.has_origin = 1;
    }
    if ((st = volux_volume_header_check(ctx, name, &h))) return st;
    *out = h;
    return VOLUX_OK;
}
