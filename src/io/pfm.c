/* io/pfm.c — Portable Float Map, binary "PF" (RGB) and "Pf" (gray).
 *
 * Layout (Netpbm PFM spec): "PF" or "Pf", whitespace, width, whitespace,
 * height, whitespace, scale as text, ONE whitespace byte, then 32-bit floats.
 * A negative scale means little-endian, positive big-endian; its magnitude
 * is a scale factor that every reader we know ignores, and so do we. Rows are
 * stored bottom-to-top, so the first row in the file is our last. */
#include <errno.h>
#include <string.h>

#include "core/context_internal.h"
#include "image_formats.h"

#define PFM "PFM"

static int is_space(unsigned char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; }

typedef struct cursor {
    const unsigned char *p, *end;
} cursor;

/* Skips whitespace, then copies one token (≤ cap−1 bytes) into buf. Returns
 * 0 for a missing or overlong token. Whitespace after it is left unread. */
static int next_token(cursor *c, char *buf, size_t cap) {
    while (c->p < c->end && is_space(*c->p)) c->p++;
    size_t n = 0;
    while (c->p < c->end && !is_space(*c->p)) {
        if (n + 1 >= cap) return 0;
        buf[n++] = (char)*c->p++;
    }
    buf[n] = 0;
    return n > 0;
}

/* A decimal dimension: digits only, at most 9 of them (so it fits in int64
 * without strtol's overflow rules; values over the limit are caught later). */
static int parse_dim(const char *s, int64_t *out) {
    size_t n = strlen(s);
    if (n == 0 || n > 9) return 0;
    int64_t v = 0;
    for (size_t i = 0; i < n; i++) {
        if (s[i] < '0' || s[i] > '9') return 0;
        v = v * 10 + (s[i] - '0');
    }
    *out = v;
    return 1;
}

/* The scale: [+-]digits[.digits][(e|E)[+-]digits] with a nonzero mantissa.
 * Parsed by hand rather than strtod, which follows the C locale (a decimal
 * comma would reject "-1.0"). Only the sign matters: *little = negative. */
static int parse_scale_sign(const char *s, int *little) {
    *little = *s == '-';
    if (*s == '-' || *s == '+') s++;
    int digits = 0, nonzero = 0;
    for (; *s >= '0' && *s <= '9'; s++, digits++) nonzero |= *s != '0';
    if (*s == '.')
        for (s++; *s >= '0' && *s <= '9'; s++, digits++) nonzero |= *s != '0';
    if (!digits) return 0;
    if (*s == 'e' || *s == 'E') {
        s++;
        if (*s == '-' || *s == '+') s++;
        if (*s < '0' || *s > '9') return 0;
        while (*s >= '0' && *s <= '9') s++;
    }
    return *s == 0 && nonzero;
}

volux_status volux_pfm_read_memory(volux_context *ctx, const char *name, const void *data, size_t size,
                                   volux_image *out) {
    const unsigned char *bytes = data;
    if (size < 3 || bytes[0] != 'P' || (bytes[1] != 'F' && bytes[1] != 'f') || !is_space(bytes[2]))
        return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: " PFM ": not a PFM file (expected 'PF' or 'Pf')", name);
    int channels = bytes[1] == 'F' ? 3 : 1;
    cursor c = {bytes + 2, bytes + size};
    char tok[64];
    int64_t width, height;
    if (!next_token(&c, tok, sizeof tok) || !parse_dim(tok, &width) || !next_token(&c, tok, sizeof tok) ||
        !parse_dim(tok, &height))
        return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: " PFM ": bad or missing width/height in the header", name);
    if (!next_token(&c, tok, sizeof tok))
        return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: " PFM ": missing scale/endianness in the header", name);
    int little;
    if (!parse_scale_sign(tok, &little))
        return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: " PFM ": scale '%s' must be a nonzero number", name, tok);
    if (c.p >= c.end || !is_space(*c.p))
        return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: " PFM ": header ends without the separator byte", name);
    c.p++; /* exactly one whitespace byte before the binary data */

    volux_status st = volux_io_check_image_size(ctx, name, PFM, width, height);
    if (st) return st;
    size_t row_values = (size_t)width * (size_t)channels;
    size_t need = row_values * (size_t)height * 4; /* ≤ 2^15·2^15·12: no overflow */
    size_t have = (size_t)(c.end - c.p);
    if (have < need)
        return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: " PFM ": truncated pixel data (needs %zu bytes, has %zu)", name,
                           need, have);
    st = volux_io_image_alloc(ctx, name, PFM, width, height, out);
    if (st) return st;

    const unsigned char *src = c.p;
    for (int64_t r = 0; r < height; r++) {
        float *row = out->rgb + (size_t)(height - 1 - r) * (size_t)width * 3;
        for (int64_t x = 0; x < width; x++) {
            for (int k = 0; k < channels; k++, src += 4) {
                uint32_t u = little ? (uint32_t)src[0] | (uint32_t)src[1] << 8 | (uint32_t)src[2] << 16 |
                                          (uint32_t)src[3] << 24
                                    : (uint32_t)src[3] | (uint32_t)src[2] << 8 | (uint32_t)src[1] << 16 |
                                          (uint32_t)src[0] << 24;
                float v;
                memcpy(&v, &u, sizeof v);
                row[x * 3 + k] = v;
            }
            if (channels == 1) row[x * 3 + 1] = row[x * 3 + 2] = row[x * 3];
        }
    }
    return VOLUX_OK;
}

volux_status volux_pfm_write_stream(volux_context *ctx, const char *name, FILE *f, const volux_image *img) {
    size_t w = (size_t)img->width, row_bytes = w * 3 * 4;
    unsigned char *buf = volux_alloc_or_error(ctx, row_bytes, "a PFM row");
    if (!buf) return VOLUX_ERR_NOMEM;
    volux_status st = VOLUX_OK;
    /* Little-endian (scale −1) on every host: bytes are assembled by shifts. */
    if (fprintf(f, "PF\n%d %d\n-1.0\n", img->width, img->height) < 0) goto write_failed;
    for (int y = img->height - 1; y >= 0; y--) {
        const float *row = img->rgb + (size_t)y * w * 3;
        for (size_t i = 0; i < w * 3; i++) {
            uint32_t u;
            memcpy(&u, &row[i], sizeof u);
            buf[i * 4 + 0] = (unsigned char)(u & 0xff);
            buf[i * 4 + 1] = (unsigned char)(u >> 8 & 0xff);
            buf[i * 4 + 2] = (unsigned char)(u >> 16 & 0xff);
            buf[i * 4 + 3] = (unsigned char)(u >> 24);
        }
        if (fwrite(buf, 1, row_bytes, f) != row_bytes) goto write_failed;
    }
    goto done;
write_failed:
    st = volux_error(ctx, VOLUX_ERR_WRITE, "cannot write '%s': %s", name, strerror(errno));
done:
    volux_free(ctx, buf, row_bytes);
    return st;
}
