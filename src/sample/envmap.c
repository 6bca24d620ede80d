/* sample/envmap.c — see envmap.h. */
#include <math.h>
#include <string.h>

#include "core/vecmath.h"
#include "envmap.h"

static float texel_lum(const volux_image *m, int x, int y) {
    x = ((x % m->width) + m->width) % m->width; /* wrap in u */
    if (y < 0) y = 0;                           /* clamp in v */
    if (y > m->height - 1) y = m->height - 1;
    const float *p = &m->rgb[3 * ((size_t)y * (size_t)m->width + (size_t)x)];
    float r = p[0] > 0.0f ? p[0] : 0.0f, g = p[1] > 0.0f ? p[1] : 0.0f, b = p[2] > 0.0f ? p[2] : 0.0f;
    float l = v3_luminance(v3(r, g, b));
    return isfinite(l) ? l : 0.0f;
}

volux_status volux_envmap_sampler_build(volux_context *ctx, const volux_light_desc *d, volux_envmap_sampler *s) {
    if (!d->map) {
        volux_distribution2d_free(ctx, &s->dist);
        s->has_map = 0;
        return VOLUX_OK;
    }
    const volux_image *m = d->map;
    int w = m->width, h = m->height;
    size_t n;
    if (!volux_mul_size((size_t)w, (size_t)h, &n) || !volux_mul_size(n, sizeof(float), &n))
        return volux_error(ctx, VOLUX_ERR_LIMIT, "environment map %dx%d is too large", w, h);
    float *f = volux_malloc(ctx, n);
    if (!f) return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for an environment sampling table");
    static const float k[3] = {0.125f, 0.75f, 0.125f}; /* ∫ of the hat functions over a texel cell */
    for (int y = 0; y < h; y++) {
        float sin_theta = sinf(VOLUX_PI * ((float)y + 0.5f) / (float)h);
        for (int x = 0; x < w; x++) {
            float sum = 0.0f;
            for (int dy = -1; dy <= 1; dy++)
                for (int dx = -1; dx <= 1; dx++) sum += k[dy + 1] * k[dx + 1] * texel_lum(m, x + dx, y + dy);
            f[(size_t)y * (size_t)w + (size_t)x] = sum * sin_theta;
        }
    }
    volux_status st = volux_distribution2d_build(ctx, f, w, h, &s->dist);
    volux_free(ctx, f, n);
    if (st) return st;
    s->has_map = 1;
    return VOLUX_OK;
}

void volux_envmap_sampler_free(volux_context *ctx, volux_envmap_sampler *s) {
    volux_distribution2d_free(ctx, &s->dist);
    s->has_map = 0;
}

size_t volux_envmap_sampler_bytes(const volux_envmap_sampler *s) { return s->has_map ? s->dist.bytes : 0; }

float volux_envmap_sample(const volux_envmap_sampler *s, const volux_light_desc *d, float u0, float u1,
                          volux_vec3 *dir) {
    if (!s->has_map) {
        float z = 1.0f - 2.0f * u0, r = sqrtf(fmaxf(0.0f, 1.0f - z * z)), phi = 2.0f * VOLUX_PI * u1;
        *dir = v3(r * cosf(phi), r * sinf(phi), z);
        return VOLUX_INV_4PI;
    }
    float uv[2];
    float pdf_uv = volux_distribution2d_sample(&s->dist, u0, u1, uv);
    if (!(pdf_uv > 0.0f)) return 0.0f;
    float sin_theta = sinf(VOLUX_PI * uv[1]);
    if (!(sin_theta > 0.0f)) return 0.0f;
    *dir = volux_environment_direction(d, uv[0], uv[1]);
    /* dω = sin θ dθ dφ = 2π² sin θ du dv */
    return pdf_uv / (2.0f * VOLUX_PI * VOLUX_PI * sin_theta);
}

float volux_envmap_pdf(const volux_envmap_sampler *s, const volux_light_desc *d, volux_vec3 dir) {
    if (!s->has_map) return VOLUX_INV_4PI;
    float u, v;
    volux_environment_uv(d, dir, &u, &v);
    float sin_theta = sinf(VOLUX_PI * v);
    if (!(sin_theta > 0.0f)) return 0.0f;
    return volux_distribution2d_pdf(&s->dist, u, v) / (2.0f * VOLUX_PI * VOLUX_PI * sin_theta);
}
