/* io/raw.c — a raw file described by the caller (volux_raw_desc): turns the
 * description into a volux_volume_header, so raw data goes through the same
 * size checks and reader as every other format. */
#include <math.h>
#include <string.h>

#include "volume_formats.h"

volux_status volux_raw_header_from_desc(volux_context *ctx, const volux_raw_desc *desc, const char *name,
                                        volux_volume_header *out) {
    volux_volume_header h;
    volux_volume_header_init(&h);
    if ((unsigned)desc->type > VOLUX_SCALAR_TYPE_LAST)
        return volux_error(ctx, VOLUX_ERR_INVALID, "%s: raw type: unknown scalar type %d", name, (int)desc->type);
    h.type = desc->type;
    h.big_endian = desc->big_endian != 0;
    for (int a = 0; a < 3; a++) {
        if (desc->dims[a] < 1)
            return volux_error(ctx, VOLUX_ERR_INVALID, "%s: raw dims: axis %d must be >= 1, got %d", name, a,
                               desc->dims[a]);
        if (desc->dims[a] > VOLUX_MAX_DIM)
            return volux_error(ctx, VOLUX_ERR_LIMIT, "%s: raw dims: axis %d size %d is over the limit of %d", name, a,
                               desc->dims[a], VOLUX_MAX_DIM);
        h.dims[a] = desc->dims[a];
        double s = desc->spacing[a] == 0.0 ? 1.0 : desc->spacing[a];
        if (!isfinite(s) || s <= 0.0)
            return volux_error(ctx, VOLUX_ERR_INVALID, "%s: raw spacing: axis %d must be positive, got %g", name, a, s);
        h.spacing[a] = s;
    }
    if (desc->byte_skip > (uint64_t)INT64_MAX)
        return volux_error(ctx, VOLUX_ERR_INVALID, "%s: raw byte skip %llu is too large", name,
                           (unsigned long long)desc->byte_skip);
    h.byte_skip = (int64_t)desc->byte_skip;
    volux_status st = volux_volume_header_check(ctx, name, &h);
    if (st) return st;
    *out = h;
    return VOLUX_OK;
}
