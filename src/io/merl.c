/* io/merl.c — see merl.h. */
#include "merl.h"

#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "core/context_internal.h"
#include "file_open.h"

#define MERL_MAX_BINS 1024
#define PI_D 3.14159265358979323846

static int32_t read_i32(const uint8_t *p) {
    return (int32_t)((uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24);
}

static double read_f64(const uint8_t *p) {
    uint64_t u = 0;
    for (int i = 7; i >= 0; i--) u = u << 8 | p[i];
    double d;
    memcpy(&d, &u, sizeof d);
    return d;
}

volux_status volux_merl_parse(volux_context *ctx, const uint8_t *data, size_t size, const char *name,
                              volux_merl *out) {
    if (!name) name = "MERL BRDF";
    if (size < 12) return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: %zu bytes is too short for a MERL header", name, size);
    int dims[3];
    size_t n = 1;
    for (int a = 0; a < 3; a++) {
        int32_t v = read_i32(data + 4 * a);
        if (v < 1 || v > MERL_MAX_BINS)
            return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: bin count %d of axis %d is outside [1, %d]", name, (int)v, a,
                               MERL_MAX_BINS);
        dims[a] = v;
        n *= (size_t)v; /* ≤ 2^30: no overflow */
    }
    if ((size - 12) / 24 != n || (size - 12) % 24 != 0)
        return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: %zu bytes, expected 12 + 24·%zu for %d×%d×%d bins", name, size,
                           n, dims[0], dims[1], dims[2]);
    size_t bytes = 3 * n * sizeof(float);
    if (ctx->max_bytes && (uint64_t)bytes > ctx->max_bytes)
        return volux_error(ctx, VOLUX_ERR_LIMIT, "%s: %zu bytes of BRDF data exceed the memory cap", name, bytes);
    float *rgb = volux_malloc(ctx, bytes);
    if (!rgb) return volux_error(ctx, VOLUX_ERR_NOMEM, "%s: out of memory (%zu bytes)", name, bytes);
    static const double scale[3] = {1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0};
    const uint8_t *p = data + 12;
    for (int c = 0; c < 3; c++)
        for (size_t i = 0; i < n; i++, p += 8) {
            /* missing (negative), not finite, or beyond any float: 0 */
            double v = read_f64(p) * scale[c];
            rgb[c * n + i] = isfinite(v) && v > 0.0 && v <= 1e30 ? (float)v : 0.0f;
        }
    memcpy(out->dims, dims, sizeof dims);
    out->rgb = rgb;
    out->bytes = bytes;
    return VOLUX_OK;
}

volux_status volux_merl_load(volux_context *ctx, const char *path, volux_merl *out) {
    FILE *f;
    uint64_t file_size;
    volux_status st = volux_file_open_read(ctx, path, &f, &file_size);
    if (st) return st;
    uint8_t *buf = NULL;
    if (file_size > (uint64_t)LONG_MAX) {
        fclose(f);
        return volux_error(ctx, VOLUX_ERR_LIMIT, "%s: file too large", path);
    }
    long len = (long)file_size;
    /* The float copy is half the doubles: a file over twice the cap cannot fit. */
    if (ctx->max_bytes && (uint64_t)len / 2 > ctx->max_bytes) {
        fclose(f);
        return volux_error(ctx, VOLUX_ERR_LIMIT, "%s: %ld bytes exceed the memory cap", path, len);
    }
    buf = volux_malloc(ctx, (size_t)len + 1);
    if (!buf) {
        fclose(f);
        return volux_error(ctx, VOLUX_ERR_NOMEM, "%s: out of memory (%ld bytes)", path, len);
    }
    if (fread(buf, 1, (size_t)len, f) != (size_t)len) st = volux_error(ctx, VOLUX_ERR_IO, "%s: read failed", path);
    fclose(f);
    if (!st) st = volux_merl_parse(ctx, buf, (size_t)len, path, out);
    volux_free(ctx, buf, (size_t)len + 1);
    return st;
}

void volux_merl_free(volux_context *ctx, volux_merl *m) {
    if (m->rgb) volux_free(ctx, m->rgb, m->bytes);
    memset(m, 0, sizeof *m);
}

static int clamp_index(double x, int n) {
    int i = (int)x;
    return i < 0 ? 0 : i >= n ? n - 1 : i;
}

void volux_merl_eval(const volux_merl *m, const double wi[3], const double wo[3], double rgb[3]) {
    rgb[0] = rgb[1] = rgb[2] = 0.0;
    if (wi[2] <= 0.0 || wo[2] <= 0.0) return;
    /* Rusinkiewicz 1998: half vector h, and ω_i seen from h's frame. */
    double h[3] = {wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]};
    double hl = sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]);
    for (int a = 0; a < 3; a++) h[a] /= hl;
    double theta_h = acos(fmin(1.0, fmax(-1.0, h[2]))), phi_h = atan2(h[1], h[0]);
    double cp = cos(-phi_h), sp = sin(-phi_h), ct = cos(-theta_h), st = sin(-theta_h);
    double t[3] = {wi[0] * cp - wi[1] * sp, wi[0] * sp + wi[1] * cp, wi[2]};   /* about z by −φ_h */
    double d[3] = {t[0] * ct + t[2] * st, t[1], -t[0] * st + t[2] * ct};       /* about y by −θ_h */
    double theta_d = acos(fmin(1.0, fmax(-1.0, d[2]))), phi_d = atan2(d[1], d[0]);
    if (phi_d < 0.0) phi_d += PI_D;
    int ih = theta_h <= 0.0 ? 0 : clamp_index(sqrt(theta_h / (0.5 * PI_D)) * m->dims[0], m->dims[0]);
    int id = clamp_index(theta_d / (0.5 * PI_D) * m->dims[1], m->dims[1]);
    int ip = clamp_index(phi_d / PI_D * m->dims[2], m->dims[2]);
    size_t n = (size_t)m->dims[0] * (size_t)m->dims[1] * (size_t)m->dims[2];
    size_t at = ((size_t)ih * (size_t)m->dims[1] + (size_t)id) * (size_t)m->dims[2] + (size_t)ip;
    for (int c = 0; c < 3; c++) rgb[c] = m->rgb[c * n + at];
}
