/* io/header_fields.c — field interpretations shared by the NRRD and
 * MetaImage parsers (see volume_formats.h). */
#include <math.h>
#include <string.h>

#include "header_text.h"
#include "volume_formats.h"

volux_status volux_header_sizes(volux_context *ctx, const char *name, const char *field, volux_text value,
                                int count, int64_t *sizes) {
    char q[80];
    volux_text rest = value, tok;
    int i = 0;
    while (volux_text_token(&rest, &tok)) {
        if (i == count)
            return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: %s: expected %d values, got more: '%s'", name, field, count,
                               volux_text_quote(value, q, sizeof q));
        int64_t v;
        if (!volux_text_to_i64(tok, &v)) {
            /* A number too big for int64 is still a size, just too large. */
            int digits = tok.n > 0;
            for (size_t k = 0; k < tok.n; k++) digits &= tok.p[k] >= '0' && tok.p[k] <= '9';
            if (digits)
                return volux_error(ctx, VOLUX_ERR_LIMIT, "%s: %s: size %s is over the limit of %d", name, field,
                                   volux_text_quote(tok, q, sizeof q), VOLUX_MAX_DIM);
            v = 0;
        }
        if (v < 1)
            return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: %s: expected a positive integer, got '%s'", name, field,
                               volux_text_quote(tok, q, sizeof q));
        if (v > VOLUX_MAX_DIM)
            return volux_error(ctx, VOLUX_ERR_LIMIT, "%s: %s: size %lld is over the limit of %d", name, field,
                               (long long)v, VOLUX_MAX_DIM);
        sizes[i++] = v;
    }
    if (i != count)
        return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: %s: expected %d values, got %d", name, field, count, i);
    return VOLUX_OK;
}

volux_status volux_header_numbers(volux_context *ctx, const char *name, const char *field, volux_text value,
                                  int count, double *out) {
    char q[80];
    volux_text rest = value, tok;
    int i = 0;
    while (volux_text_token(&rest, &tok)) {
        if (i == count)
            return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: %s: expected %d values, got more: '%s'", name, field, count,
                               volux_text_quote(value, q, sizeof q));
        if (!volux_text_to_double(tok, &out[i]))
            return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: %s: expected a number, got '%s'", name, field,
                               volux_text_quote(tok, q, sizeof q));
        i++;
    }
    if (i != count)
        return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: %s: expected %d values, got %d", name, field, count, i);
    return VOLUX_OK;
}

volux_status volux_header_axes(volux_context *ctx, const char *name, const char *field, const int64_t *sizes,
                               int ndim, volux_volume_header *h, int axes[3]) {
    int first = 0;
    if (ndim == 4 && sizes[0] == 1) first = 1;
    else if (ndim == 4 && sizes[3] == 1) first = 0;
    else if (ndim == 4)
        return volux_error(ctx, VOLUX_ERR_UNSUPPORTED,
                           "%s: %s: 4-D data (%lld %lld %lld %lld) is not supported; only 3-D volumes, or 4-D with "
                           "a first or last axis of size 1",
                           name, field, (long long)sizes[0], (long long)sizes[1], (long long)sizes[2],
                           (long long)sizes[3]);
    else if (ndim != 3)
        return volux_error(ctx, VOLUX_ERR_UNSUPPORTED, "%s: %s: %d-D data is not supported, need a 3-D volume", name,
                           field, ndim);
    for (int a = 0; a < 3; a++) {
        axes[a] = first + a;
        h->dims[a] = (int)sizes[first + a]; /* ≤ VOLUX_MAX_DIM, checked by volux_header_sizes */
    }
    return VOLUX_OK;
}

volux_status volux_header_data_file(volux_context *ctx, const char *name, const char *field, volux_text value,
                                    volux_volume_header *h) {
    char q[80];
    value = volux_text_trim(value);
    if (value.n == 0) return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: %s: empty file name", name, field);
    if (value.n > VOLUX_MAX_DATA_NAME)
        return volux_error(ctx, VOLUX_ERR_LIMIT, "%s: %s: file name of %zu characters is over the limit of %d", name,
                           field, value.n, VOLUX_MAX_DATA_NAME);
    volux_text rest = value, tok, first = {0};
    int tokens = 0, numeric_tail = 0;
    while (volux_text_token(&rest, &tok)) {
        int64_t ignored;
        if (tokens == 0) first = tok;
        else numeric_tail += volux_text_to_i64(tok, &ignored);
        tokens++;
    }
    if (volux_text_eq(first, "LIST"))
        return volux_error(ctx, VOLUX_ERR_UNSUPPORTED, "%s: %s: LIST (one data file per slice) is not supported",
                           name, field);
    /* "slice%03d.raw 1 100 1 [subdim]": a pattern over several files. */
    if (tokens >= 4 && numeric_tail == tokens - 1)
        return volux_error(ctx, VOLUX_ERR_UNSUPPORTED,
                           "%s: %s: multiple data files ('%s') are not supported, need a single file", name, field,
                           volux_text_quote(value, q, sizeof q));
    memcpy(h->data_file, value.p, value.n);
    h->data_file[value.n] = 0;
    h->data_offset = 0;
    return VOLUX_OK;
}

int volux_header_axes_degenerate(const double a[3], const double b[3], const double c[3]) {
    double la = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]), lb = sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]),
           lc = sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
    if (!(la > 0.0) || !(lb > 0.0) || !(lc > 0.0) || !isfinite(la * lb * lc)) return 1;
    double det = a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
                 a[2] * (b[0] * c[1] - b[1] * c[0]);
    return !(fabs(det) > 1e-6 * la * lb * lc);
}
