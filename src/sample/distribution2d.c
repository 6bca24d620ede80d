/* sample/distribution2d.c — see distribution2d.h. */
#include <math.h>
#include <string.h>

#include "distribution2d.h"

/* Builds cdf[0..n] from n non-negative values; returns ∫ = Σ f / n. An empty
 * row gets a uniform CDF (it is never chosen by the marginal). */
static double build_cdf(const float *f, int n, float *cdf) {
    double sum = 0.0;
    cdf[0] = 0.0f;
    for (int i = 0; i < n; i++) sum += (double)f[i];
    if (sum <= 0.0) {
        for (int i = 1; i <= n; i++) cdf[i] = (float)((double)i / (double)n);
        return 0.0;
    }
    double run = 0.0;
    for (int i = 0; i < n; i++) {
        run += (double)f[i];
        cdf[i + 1] = (float)(run / sum);
    }
    cdf[n] = 1.0f;
    return sum / (double)n;
}

volux_status volux_distribution2d_build(volux_context *ctx, const float *f, int nu, int nv,
                                        volux_distribution2d *d) {
    if (nu < 1 || nv < 1 || nu > (1 << 16) || nv > (1 << 16))
        return volux_error(ctx, VOLUX_ERR_INVALID, "distribution of %dx%d cells is outside [1, 65536]^2", nu, nv);
    size_t cells = (size_t)nu * (size_t)nv;
    size_t n_floats = cells + (size_t)nv * (size_t)(nu + 1) + (size_t)nv + (size_t)nv + 1;
    size_t bytes = n_floats * sizeof(float);
    if (!d->block || d->bytes != bytes) {
        volux_distribution2d_free(ctx, d);
        d->block = volux_malloc(ctx, bytes);
        if (!d->block) return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for a %dx%d sampling table", nu, nv);
        d->bytes = bytes;
    }
    float *p = d->block;
    d->nu = nu;
    d->nv = nv;
    d->func = p;
    d->cdf = p + cells;
    d->row_int = d->cdf + (size_t)nv * (size_t)(nu + 1);
    d->marg_cdf = d->row_int + nv;
    for (size_t i = 0; i < cells; i++) d->func[i] = isfinite(f[i]) && f[i] > 0.0f ? f[i] : 0.0f;
    for (int v = 0; v < nv; v++)
        d->row_int[v] = (float)build_cdf(d->func + (size_t)v * (size_t)nu, nu, d->cdf + (size_t)v * (size_t)(nu + 1));
    d->integral = (float)build_cdf(d->row_int, nv, d->marg_cdf);
    return VOLUX_OK;
}

void volux_distribution2d_free(volux_context *ctx, volux_distribution2d *d) {
    if (d->block) volux_free(ctx, d->block, d->bytes);
    memset(d, 0, sizeof *d);
}

int volux_piecewise_sample(const float *cdf, int n, float u, float *x) {
    /* Largest i with cdf[i] <= u. Since cdf[n] = 1 > u, that cell has
     * cdf[i+1] > u >= cdf[i], i.e. non-zero width: empty cells are skipped. */
    int lo = 0, hi = n - 1;
    while (lo < hi) {
        int mid = (lo + hi + 1) >> 1;
        if (cdf[mid] <= u) lo = mid;
        else hi = mid - 1;
    }
    float w = cdf[lo + 1] - cdf[lo];
    float du = w > 0.0f ? (u - cdf[lo]) / w : 0.5f;
    /* Keep the point inside its cell so that pdf(x) sees the same cell. */
    if (!(du < 1.0f)) du = 0x1.fffffep-1f;
    if (du < 0.0f) du = 0.0f;
    float xx = ((float)lo + du) / (float)n;
    if (!(xx < 1.0f)) xx = 0x1.fffffep-1f;
    *x = xx;
    return lo;
}

float volux_distribution2d_sample(const volux_distribution2d *d, float u0, float u1, float uv[2]) {
    if (!(d->integral > 0.0f)) {
        uv[0] = u0;
        uv[1] = u1;
        return 0.0f;
    }
    int iv = volux_piecewise_sample(d->marg_cdf, d->nv, u1, &uv[1]);
    int iu = volux_piecewise_sample(d->cdf + (size_t)iv * (size_t)(d->nu + 1), d->nu, u0, &uv[0]);
    /* p(u,v) = p(v)·p(u|v) = (row_int/I)·(f/row_int) = f/I */
    return d->func[(size_t)iv * (size_t)d->nu + (size_t)iu] / d->integral;
}

float volux_distribution2d_pdf(const volux_distribution2d *d, float u, float v) {
    if (!(d->integral > 0.0f)) return 0.0f;
    int iu = (int)(u * (float)d->nu), iv = (int)(v * (float)d->nv);
    if (iu < 0) iu = 0;
    if (iu > d->nu - 1) iu = d->nu - 1;
    if (iv < 0) iv = 0;
    if (iv > d->nv - 1) iv = d->nv - 1;
    return d->func[(size_t)iv * (size_t)d->nu + (size_t)iu] / d->integral;
}
