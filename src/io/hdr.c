/* io/hdr.c — Radiance RGBE pictures (.hdr).
 *
 * Format (Ward, "Real Pixels", Graphics Gems II, and the Radiance file
 * format notes): a text header "#?RADIANCE" (or "#?RGBE") with NAME=value
 * lines up to a blank line, a resolution line "-Y H +X W", then H scanlines
 * of W pixels of 4 bytes (R, G, B mantissas sharing exponent E). A scanline
 * is either new-style RLE (starts 2,2,W>>8,W&255; each of the 4 components
 * run-length coded separately), or flat pixels, possibly with old-style runs
 * (pixel 1,1,1,n repeats the previous pixel n<<shift times, shift growing by
 * 8 for each consecutive run pixel).
 *
 * The pixels are decoded twice: a first pass only validates the stream, so
 * garbage or truncated data is rejected before the image is allocated. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "core/context_internal.h"
#include "image_formats.h"

#define HDR "Radiance HDR"
#define HDR_MAX_LINE 4096
#define HDR_MAX_HEADER (1 << 20)

typedef struct cursor {
    const unsigned char *p, *end;
} cursor;

/* Copies the next line (without '\n') into buf; 0 if there is no '\n'
 * within HDR_MAX_LINE bytes. */
static int next_line(cursor *c, char *buf) {
    size_t n = 0;
    while (c->p < c->end && *c->p != '\n') {
        if (n + 1 >= HDR_MAX_LINE) return 0;
        buf[n++] = (char)*c->p++;
    }
    if (c->p >= c->end) return 0;
    c->p++;
    if (n && buf[n - 1] == '\r') n--; /* tolerate CRLF headers */
    buf[n] = 0;
    return 1;
}

/* "±A N" at *s: sign, axis letter, blanks, decimal number (≤ 9 digits). */
static int parse_axis(const char **s, char *sign, char *axis, long *n) {
    const char *p = *s;
    while (*p == ' ' || *p == '\t') p++;
    if ((p[0] != '-' && p[0] != '+') || (p[1] != 'X' && p[1] != 'Y')) return 0;
    *sign = p[0];
    *axis = p[1];
    p += 2;
    while (*p == ' ' || *p == '\t') p++;
    int digits = 0;
    long v = 0;
    for (; *p >= '0' && *p <= '9' && digits < 9; p++, digits++) v = v * 10 + (*p - '0');
    if (!digits || (*p >= '0' && *p <= '9')) return 0;
    *n = v;
    *s = p;
    return 1;
}

/* Decodes one scanline of w RGBE pixels into scan[4w]; NULL on success or a
 * reason for the rejection. */
static const char *decode_scanline(cursor *c, unsigned char *scan, int w) {
    const unsigned char *p = c->p;
    size_t left = (size_t)(c->end - p);
    if (w >= 8 && w <= 0x7fff && left >= 4 && p[0] == 2 && p[1] == 2 && !(p[2] & 0x80)) {
        if ((p[2] << 8 | p[3]) != w) return "a scanline's width does not match the header";
        c->p += 4;
        for (int k = 0; k < 4; k++) {
            for (int x = 0; x < w;) {
                if (c->p >= c->end) return "truncated RLE scanline";
                int n = *c->p++;
                if (n > 128) {
                    n -= 128;
                    if (n > w - x) return "RLE run past the end of a scanline";
                    if (c->p >= c->end) return "truncated RLE scanline";
                    unsigned char v = *c->p++;
                    for (int i = 0; i < n; i++) scan[(x + i) * 4 + k] = v;
                } else {
                    if (n == 0) return "zero-length RLE literal";
                    if (n > w - x) return "RLE literal past the end of a scanline";
                    if ((size_t)(c->end - c->p) < (size_t)n) return "truncated RLE scanline";
                    for (int i = 0; i < n; i++) scan[(x + i) * 4 + k] = c->p[i];
                    c->p += n;
                }
                x += n;
            }
        }
        return NULL;
    }
    /* Flat pixels with optional old-style runs. */
    int shift = 0;
    for (int x = 0; x < w;) {
        if ((size_t)(c->end - c->p) < 4) return "truncated scanline";
        const unsigned char *px = c->p;
        c->p += 4;
        if (px[0] == 1 && px[1] == 1 && px[2] == 1) {
            if (x == 0) return "old-style run before any pixel of a scanline";
            /* Three run pixels already cover 2^24 > VOLUX_MAX_IMAGE_DIM. */
            if (shift > 16) return "old-style run too long";
            size_t n = (size_t)px[3] << shift;
            if (n > (size_t)(w - x)) return "old-style run past the end of a scanline";
            for (size_t i = 0; i < n; i++) memcpy(scan + (size_t)(x + (int)i) * 4, scan + (size_t)(x - 1) * 4, 4);
            x += (int)n;
            shift += 8;
        } else {
            memcpy(scan + (size_t)x * 4, px, 4);
            x++;
            shift = 0;
        }
    }
    return NULL;
}

/* Radiance's colr_color(): mantissa + 0.5 scaled by 2^(E−136); E = 0 is black. */
static void rgbe_to_float(const unsigned char *rgbe, float *rgb) {
    if (rgbe[3] == 0) {
        rgb[0] = rgb[1] = rgb[2] = 0.0f;
        return;
    }
    double f = ldexp(1.0, (int)rgbe[3] - (128 + 8));
    for (int k = 0; k < 3; k++) rgb[k] = (float)((rgbe[k] + 0.5) * f);
}

volux_status volux_hdr_read_memory(volux_context *ctx, const char *name, const void *data, size_t size,
                                   volux_image *out) {
    cursor c = {data, (const unsigned char *)data + size};
    char line[HDR_MAX_LINE];
    if (!next_line(&c, line) || (strncmp(line, "#?RADIANCE", 10) != 0 && strncmp(line, "#?RGBE", 6) != 0))
        return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: " HDR ": not a Radiance picture (expected '#?RADIANCE')",
                           name);
    /* Header lines up to the blank line. */
    for (;;) {
        if ((size_t)(c.p - (const unsigned char *)data) > HDR_MAX_HEADER || !next_line(&c, line))
            return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: " HDR ": header has no end (blank line)", name);
        if (!line[0]) break;
        if (!strncmp(line, "FORMAT=", 7) && strcmp(line + 7, "32-bit_rle_rgbe") != 0)
            return volux_error(ctx, VOLUX_ERR_UNSUPPORTED, "%s: " HDR ": pixel format '%.64s' (only 32-bit_rle_rgbe)",
                               name, line + 7);
    }
    char sy, ay, sx, ax;
    long h, w;
    const char *s = line;
    if (!next_line(&c, line) || !parse_axis(&s, &sy, &ay, &h) || !parse_axis(&s, &sx, &ax, &w))
        return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: " HDR ": bad resolution line (expected '-Y H +X W')", name);
    while (*s == ' ' || *s == '\t') s++;
    if (*s || ay == ax)
        return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: " HDR ": bad resolution line '%.64s'", name, line);
    if (ay != 'Y')
        return volux_error(ctx, VOLUX_ERR_UNSUPPORTED,
                           "%s: " HDR ": orientation '%.64s' is column-major; only '±Y H ±X W' is supported", name,
                           line);
    volux_status st = volux_io_check_image_size(ctx, name, HDR, w, h);
    if (st) return st;

    size_t scan_bytes = (size_t)w * 4;
    unsigned char *scan = volux_alloc_or_error(ctx, scan_bytes, "a Radiance scanline");
    if (!scan) return VOLUX_ERR_NOMEM;
    const unsigned char *pixels = c.p;
    /* Pass 1: validate every scanline without the image. */
    for (long y = 0; y < h; y++) {
        const char *why = decode_scanline(&c, scan, (int)w);
        if (why) {
            st = volux_error(ctx, VOLUX_ERR_FORMAT, "%s: " HDR ": scanline %ld: %s", name, y, why);
            goto done;
        }
    }
    /* Pass 2: decode into the image. "-Y" stores the top row first, "+Y"
     * the bottom row; "+X" stores left to right, "-X" right to left. */
    st = volux_io_image_alloc(ctx, name, HDR, w, h, out);
    if (st) goto done;
    c.p = pixels;
    for (long y = 0; y < h; y++) {
        decode_scanline(&c, scan, (int)w);
        long row = sy == '-' ? y : h - 1 - y;
        for (long x = 0; x < w; x++) {
            long col = sx == '+' ? x : w - 1 - x;
            rgbe_to_float(scan + x * 4, out->rgb + ((size_t)row * (size_t)w + (size_t)col) * 3);
        }
    }
done:
    volux_free(ctx, scan, scan_bytes);
    return st;
}
