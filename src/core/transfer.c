/* core/transfer.c — TF validation, evaluation and baking (DESIGN §2). */
#include <math.h>
#include <string.h>

#include "context_internal.h"
#include "volux/transfer.h"

void volux_transfer_desc_defaults(volux_transfer_desc *d) {
    memset(d, 0, sizeof *d);
    d->density_scale = 1.0f;
    d->albedo = 0.9f;
    d->anisotropy = 0.0f;
    d->material = (volux_material){0.2f, 0.7f, 0.3f, 30.0f};
}

volux_status volux_transfer_desc_validate(volux_context *ctx, const volux_transfer_desc *d) {
    const char *which = d->extinction ? "extinction" : "opacity";
    if (d->n_opacity < 1 || d->n_opacity > VOLUX_TF_MAX_POINTS)
        return volux_error(ctx, VOLUX_ERR_INVALID, "transfer_function.%s: needs 1..%d points, got %d", which,
                           VOLUX_TF_MAX_POINTS, d->n_opacity);
    if (d->n_color < 0 || d->n_color > VOLUX_TF_MAX_POINTS)
        return volux_error(ctx, VOLUX_ERR_INVALID, "transfer_function.color: needs 0..%d points, got %d",
                           VOLUX_TF_MAX_POINTS, d->n_color);
    for (int i = 0; i < d->n_opacity; i++) {
        float s = d->opacity[i].s, v = d->opacity[i].v;
        if (!isfinite(s) || !isfinite(v))
            return volux_error(ctx, VOLUX_ERR_INVALID, "transfer_function.%s[%d]: values must be finite", which, i);
        if (i > 0 && s < d->opacity[i - 1].s)
            return volux_error(ctx, VOLUX_ERR_INVALID, "transfer_function.%s[%d]: s = %g must not decrease", which,
                               i, s);
        if (v < 0.0f || (!d->extinction && v > 1.0f))
            return volux_error(ctx, VOLUX_ERR_INVALID, "transfer_function.%s[%d]: %g is outside %s", which, i, v,
                               d->extinction ? "[0, inf)" : "[0, 1]");
    }
    for (int i = 0; i < d->n_color; i++) {
        const volux_tf_color_point *p = &d->color[i];
        if (!isfinite(p->s) || !isfinite(p->r) || !isfinite(p->g) || !isfinite(p->b))
            return volux_error(ctx, VOLUX_ERR_INVALID, "transfer_function.color[%d]: values must be finite", i);
        if (i > 0 && p->s < d->color[i - 1].s)
            return volux_error(ctx, VOLUX_ERR_INVALID, "transfer_function.color[%d]: s = %g must not decrease", i,
                               p->s);
        if (p->r < 0 || p->g < 0 || p->b < 0 || p->r > 1 || p->g > 1 || p->b > 1)
            return volux_error(ctx, VOLUX_ERR_INVALID, "transfer_function.color[%d]: r,g,b must be in [0, 1]", i);
    }
    if (!(d->opacity_unit_distance >= 0.0f) || !isfinite(d->opacity_unit_distance))
        return volux_error(ctx, VOLUX_ERR_INVALID, "transfer_function.opacity_unit_distance: must be > 0, got %g",
                           d->opacity_unit_distance);
    if (!(d->density_scale >= 0.0f) || !isfinite(d->density_scale))
        return volux_error(ctx, VOLUX_ERR_INVALID, "transfer_function.density_scale: must be >= 0, got %g",
                           d->density_scale);
    if (!(d->albedo >= 0.0f && d->albedo <= 1.0f))
        return volux_error(ctx, VOLUX_ERR_INVALID, "transfer_function.albedo: must be in [0, 1], got %g", d->albedo);
    if (!(d->anisotropy > -1.0f && d->anisotropy < 1.0f))
        return volux_error(ctx, VOLUX_ERR_INVALID, "transfer_function.anisotropy: must be in (-1, 1), got %g",
                           d->anisotropy);
    if (d->n_materials < 0 || d->n_materials > VOLUX_TF_MAX_MATERIALS || (d->n_materials && !d->materials))
        return volux_error(ctx, VOLUX_ERR_INVALID, "transfer_function.materials: needs 0..%d entries, got %d",
                           VOLUX_TF_MAX_MATERIALS, d->n_materials);
    for (int i = 0; i < d->n_materials; i++) {
        const volux_tf_material *t = &d->materials[i];
        const char *why = NULL;
        if (!isfinite(t->s0) || !isfinite(t->s1) || t->s0 > t->s1) why = "range must be finite with s0 <= s1";
        else if ((unsigned)t->kind > VOLUX_MATERIAL_MERL) why = "unknown type";
        else if (!(t->g > -1.0f && t->g < 1.0f)) why = "anisotropy must be in (-1, 1)";
        else if (!(t->diffuse >= 0.0f && t->diffuse <= 1.0f) || !(t->specular >= 0.0f && t->specular <= 1.0f))
            why = "diffuse and specular must be in [0, 1]";
        else if (!(t->shininess >= 0.0f && t->shininess <= 1e4f)) why = "shininess must be in [0, 10000]";
        else if (!(t->roughness > 0.0f && t->roughness <= 1.0f)) why = "roughness must be in (0, 1]";
        else if (!(t->f0 >= 0.0f && t->f0 <= 1.0f)) why = "f0 must be in [0, 1]";
        else if (t->kind == VOLUX_MATERIAL_MERL && (!t->file[0] || !memchr(t->file, 0, sizeof t->file)))
            why = "a merl material needs a file";
        if (why) return volux_error(ctx, VOLUX_ERR_INVALID, "transfer_function.materials[%d]: %s", i, why);
    }
    const volux_material *m = &d->material;
    if (!(m->ambient >= 0 && m->diffuse >= 0 && m->specular >= 0 && m->specular_power >= 0) ||
        !isfinite(m->ambient + m->diffuse + m->specular + m->specular_power))
        return volux_error(ctx, VOLUX_ERR_INVALID,
                           "transfer_function: ambient, diffuse, specular and specular_power must be >= 0");
    return VOLUX_OK;
}

void volux_tf_material_defaults(volux_tf_material *m, volux_material_kind kind) {
    memset(m, 0, sizeof *m);
    m->kind = kind;
    m->diffuse = 0.7f;
    m->specular = 0.3f;
    m->shininess = 32.0f;
    m->roughness = 0.3f;
    m->f0 = 0.04f;
}

const char *volux_material_kind_name(volux_material_kind k) {
    static const char *const names[] = {"phase", "lambert", "blinn_phong", "ashikhmin_shirley", "cook_torrance",
                                        "merl"};
    return (unsigned)k <= VOLUX_MATERIAL_MERL ? names[k] : "unknown";
}

int volux_tf_material_equal(const volux_tf_material *a, const volux_tf_material *b) {
    return a->s0 == b->s0 && a->s1 == b->s1 && a->kind == b->kind && a->g == b->g && a->diffuse == b->diffuse &&
           a->specular == b->specular && a->shininess == b->shininess && a->roughness == b->roughness &&
           a->f0 == b->f0 && strncmp(a->file, b->file, sizeof a->file) == 0;
}

/* Index of the segment containing s: largest i with p[i].s <= s. */
#define SEGMENT_SEARCH(p, n, s, i)                                                                     \
    do {                                                                                               \
        int lo_ = 0, hi_ = (n) - 1;                                                                    \
        while (lo_ < hi_) {                                                                            \
            int mid_ = (lo_ + hi_ + 1) / 2;                                                            \
            if ((p)[mid_].s <= (s)) lo_ = mid_;                                                        \
            else hi_ = mid_ - 1;                                                                       \
        }                                                                                              \
        (i) = lo_;                                                                                     \
    } while (0)

float volux_tf_eval_scalar(const volux_tf_scalar_point *p, int n, float s) {
    if (n <= 0) return 0.0f;
    if (s <= p[0].s) return p[0].v;
    if (s >= p[n - 1].s) return p[n - 1].v;
    int i;
    SEGMENT_SEARCH(p, n, s, i);
    float ds = p[i + 1].s - p[i].s;
    float t = ds > 0.0f ? (s - p[i].s) / ds : 1.0f;
    return p[i].v + (p[i + 1].v - p[i].v) * t;
}

void volux_tf_eval_color(const volux_tf_color_point *p, int n, float s, float rgb[3]) {
    if (n <= 0) {
        rgb[0] = rgb[1] = rgb[2] = 1.0f;
        return;
    }
    int i;
    if (s <= p[0].s) i = 0, s = p[0].s;
    else if (s >= p[n - 1].s) i = n - 1, s = p[n - 1].s;
    else SEGMENT_SEARCH(p, n, s, i);
    if (i == n - 1) {
        rgb[0] = p[i].r, rgb[1] = p[i].g, rgb[2] = p[i].b;
        return;
    }
    float ds = p[i + 1].s - p[i].s;
    float t = ds > 0.0f ? (s - p[i].s) / ds : 1.0f;
    rgb[0] = p[i].r + (p[i + 1].r - p[i].r) * t;
    rgb[1] = p[i].g + (p[i + 1].g - p[i].g) * t;
    rgb[2] = p[i].b + (p[i + 1].b - p[i].b) * t;
}

/* σt for an opacity α per unit distance u (DESIGN §2). */
static float sigma_from_opacity(float alpha, float unit) {
    float a = alpha < 0.9999f ? alpha : 0.9999f;
    return -logf(1.0f - a) / unit;
}

static float sigma_at(const volux_transfer_desc *d, float s, float unit) {
    float v = volux_tf_eval_scalar(d->opacity, d->n_opacity, s);
    float sigma = (d->extinction ? v : sigma_from_opacity(v, unit)) * d->density_scale;
    return sigma < VOLUX_SIGMA_T_MAX ? sigma : VOLUX_SIGMA_T_MAX; /* also 1e30 × 1e30 = inf */
}

void volux_transfer_lut_free(volux_context *ctx, volux_transfer_lut *lut) {
    if (!lut || lut->n == 0) return;
    size_t n = (size_t)lut->n;
    volux_free(ctx, lut->sigma_t, n * sizeof(float));
    volux_free(ctx, lut->rgba, 4 * n * sizeof(float));
    volux_free(ctx, lut->int_sigma, n * sizeof(double));
    volux_free(ctx, lut->int_sigma_c, 3 * n * sizeof(double));
    memset(lut, 0, sizeof *lut);
}

volux_status volux_transfer_bake(volux_context *ctx, const volux_transfer_desc *d, double s_min, double s_max,
                                 int n, float unit_default, volux_transfer_lut *out) {
    volux_status st = volux_transfer_desc_validate(ctx, d);
    if (st) return st;
    if (n == 0) n = 4096;
    if (n < 2 || n > (1 << 20)) return volux_error(ctx, VOLUX_ERR_INVALID, "TF table size %d is outside [2, 2^20]", n);
    if (!(s_max > s_min)) s_max = s_min + 1.0; /* constant volume: any non-empty domain */
    float unit = d->opacity_unit_distance > 0.0f ? d->opacity_unit_distance : unit_default;
    if (!(unit > 0.0f)) unit = 1.0f;
    volux_transfer_lut lut = {0};
    lut.n = n;
    lut.s_min = (float)s_min;
    lut.s_max = (float)s_max;
    lut.inv_ds = (float)((double)(n - 1) / (s_max - s_min));
    lut.sigma_t = volux_malloc(ctx, (size_t)n * sizeof(float));
    lut.rgba = volux_malloc(ctx, 4 * (size_t)n * sizeof(float));
    lut.int_sigma = volux_malloc(ctx, (size_t)n * sizeof(double));
    lut.int_sigma_c = volux_malloc(ctx, 3 * (size_t)n * sizeof(double));
    if (!lut.sigma_t || !lut.rgba || !lut.int_sigma || !lut.int_sigma_c) {
        volux_transfer_lut_free(ctx, &lut);
        return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for a TF table of %d entries", n);
    }
    double ds = (s_max - s_min) / (double)(n - 1);
    for (int i = 0; i < n; i++) {
        float s = (float)(s_min + ds * i);
        float rgb[3];
        volux_tf_eval_color(d->color, d->n_color, s, rgb);
        float sigma = sigma_at(d, s, unit);
        lut.sigma_t[i] = sigma;
        lut.rgba[4 * i + 0] = rgb[0];
        lut.rgba[4 * i + 1] = rgb[1];
        lut.rgba[4 * i + 2] = rgb[2];
        lut.rgba[4 * i + 3] = sigma;
        if (sigma > lut.sigma_t_max) lut.sigma_t_max = sigma;
    }
    /* Running integrals over s of σt and σt·c for pre-integration (Engel et
     * al. 2001; 1-D tables after Lum et al. 2004). Between table nodes σt and
     * c are linear, so σt·c is quadratic: Simpson's rule is exact per
     * segment. Control points between nodes are resolved by the table's
     * resolution (4096 entries by default). */
    lut.int_sigma[0] = 0.0;
    lut.int_sigma_c[0] = lut.int_sigma_c[1] = lut.int_sigma_c[2] = 0.0;
    for (int i = 1; i < n; i++) {
        const float *a = &lut.rgba[4 * (i - 1)], *b = &lut.rgba[4 * i];
        lut.int_sigma[i] = lut.int_sigma[i - 1] + 0.5 * ds * ((double)a[3] + b[3]);
        for (int c = 0; c < 3; c++) {
            double fa = (double)a[3] * a[c], fb = (double)b[3] * b[c];
            double fm = 0.25 * ((double)a[3] + b[3]) * ((double)a[c] + b[c]);
            lut.int_sigma_c[3 * i + c] = lut.int_sigma_c[3 * (i - 1) + c] + ds / 6.0 * (fa + 4.0 * fm + fb);
        }
    }
    *out = lut;
    return VOLUX_OK;
}

float volux_transfer_lut_max_sigma(const volux_transfer_lut *lut, float s0, float s1) {
    float u0 = (s0 - lut->s_min) * lut->inv_ds, u1 = (s1 - lut->s_min) * lut->inv_ds;
    if (u0 > u1) { float t = u0; u0 = u1; u1 = t; }
    int last = lut->n - 1;
    int i0 = (int)floorf(u0), i1 = (int)ceilf(u1);
    if (i0 < 0) i0 = 0;
    if (i1 > last) i1 = last;
    if (i0 > last) i0 = last;
    if (i1 < 0) i1 = 0;
    float m = 0.0f;
    for (int i = i0; i <= i1; i++)
        if (lut->sigma_t[i] > m) m = lut->sigma_t[i];
    return m;
}
