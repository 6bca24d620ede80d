/* techniques/sh/shbasis.c — see shbasis.h. */
#include "shbasis.h"

#include <math.h>
#include <string.h>

#include "core/rng.h"

#define PI_D 3.14159265358979323846

void sh_eval(int bands, volux_vec3 d, float *y) {
    const float x = d.x, yy = d.y, z = d.z;
    y[0] = 0.282094792f;
    if (bands < 2) return;
    y[1] = 0.488602512f * yy;
    y[2] = 0.488602512f * z;
    y[3] = 0.488602512f * x;
    if (bands < 3) return;
    const float x2 = x * x, y2 = yy * yy, z2 = z * z;
    y[4] = 1.092548431f * x * yy;
    y[5] = 1.092548431f * yy * z;
    y[6] = 0.315391565f * (3.0f * z2 - 1.0f);
    y[7] = 1.092548431f * x * z;
    y[8] = 0.546274215f * (x2 - y2);
    if (bands < 4) return;
    y[9] = 0.590043589f * yy * (3.0f * x2 - y2);
    y[10] = 2.890611442f * x * yy * z;
    y[11] = 0.457045799f * yy * (5.0f * z2 - 1.0f);
    y[12] = 0.373176333f * z * (5.0f * z2 - 3.0f);
    y[13] = 0.457045799f * x * (5.0f * z2 - 1.0f);
    y[14] = 1.445305721f * z * (x2 - y2);
    y[15] = 0.590043589f * x * (x2 - 3.0f * y2);
}

void sh_triple_init(sh_triple *t) {
    /* Y_i Y_j Y_k is a polynomial of degree ≤ 9 in (x, y, z): 8
     * Gauss–Legendre nodes in z = cos θ (exact to degree 15) times 24
     * uniform φ (exact for frequencies below 24). Nodes by Newton's method
     * on P_8. */
    enum { NZ = 8, NPHI = 24 };
    double zn[NZ], zw[NZ];
    for (int a = 0; a < NZ; a++) {
        double z = cos(PI_D * (a + 0.75) / (NZ + 0.5)), dp = 1.0;
        for (int it = 0; it < 100; it++) {
            double p0 = 1.0, p1 = z;
            for (int l = 2; l <= NZ; l++) {
                double p2 = ((2.0 * l - 1.0) * z * p1 - (l - 1.0) * p0) / l;
                p0 = p1, p1 = p2;
            }
            dp = NZ * (z * p1 - p0) / (z * z - 1.0);
            double dz = p1 / dp;
            z -= dz;
            if (fabs(dz) < 1e-15) break;
        }
        zn[a] = z;
        zw[a] = 2.0 / ((1.0 - z * z) * dp * dp);
    }
    double acc[SH_MAX_COEFFS][SH_MAX_COEFFS][SH_MAX_COEFFS]; /* 32 KB */
    memset(acc, 0, sizeof acc);
    for (int a = 0; a < NZ; a++)
        for (int b = 0; b < NPHI; b++) {
            double phi = 2.0 * PI_D * (b + 0.5) / NPHI, s = sqrt(fmax(0.0, 1.0 - zn[a] * zn[a]));
            float y[SH_MAX_COEFFS];
            sh_eval(SH_MAX_BANDS, v3((float)(s * cos(phi)), (float)(s * sin(phi)), (float)zn[a]), y);
            double w = zw[a] * 2.0 * PI_D / NPHI;
            for (int i = 0; i < SH_MAX_COEFFS; i++)
                for (int j = 0; j < SH_MAX_COEFFS; j++)
                    for (int k = 0; k < SH_MAX_COEFFS; k++) acc[i][j][k] += w * y[i] * y[j] * y[k];
        }
    t->n = 0;
    for (int i = 0; i < SH_MAX_COEFFS; i++)
        for (int j = 0; j < SH_MAX_COEFFS; j++)
            for (int k = 0; k < SH_MAX_COEFFS; k++)
                if (fabs(acc[i][j][k]) > 1e-6) { /* float Y: the zeros come out ≈ 1e-8 */
                    t->i[t->n] = (uint8_t)i, t->j[t->n] = (uint8_t)j, t->k[t->n] = (uint8_t)k;
                    t->v[t->n++] = (float)acc[i][j][k];
                }
}

void sh_triple_product(const sh_triple *t, const float *f, const float *g, float *out) {
    for (int k = 0; k < SH_MAX_COEFFS; k++) out[k] = 0.0f;
    for (int n = 0; n < t->n; n++) out[t->k[n]] += t->v[n] * f[t->i[n]] * g[t->j[n]];
}

/* Associated Legendre P_l^m(t), m ≥ 0, without the Condon–Shortley phase
 * (upward recurrence in l). */
static double legendre(int l, int m, double t) {
    double pmm = 1.0, s = sqrt(fmax(0.0, 1.0 - t * t));
    for (int i = 1; i <= m; i++) pmm *= (2.0 * i - 1.0) * s;
    if (l == m) return pmm;
    double pm1 = t * (2.0 * m + 1.0) * pmm;
    if (l == m + 1) return pm1;
    double pl = 0.0;
    for (int ll = m + 2; ll <= l; ll++) {
        pl = ((2.0 * ll - 1.0) * t * pm1 - (ll + m - 1.0) * pmm) / (ll - m);
        pmm = pm1;
        pm1 = pl;
    }
    return pl;
}

static double factorial(int n) {
    double f = 1.0;
    for (int i = 2; i <= n; i++) f *= i;
    return f;
}

double sh_eval_reference(int l, int m, double x, double y, double z) {
    int am = m < 0 ? -m : m;
    double k = sqrt((2.0 * l + 1.0) / (4.0 * PI_D) * factorial(l - am) / factorial(l + am));
    double phi = atan2(y, x), p = legendre(l, am, z);
    if (m == 0) return k * p;
    return sqrt(2.0) * k * p * (m > 0 ? cos(am * phi) : sin(am * phi));
}

/* ------------------------------------------------------------------ rotation */

/* Ivanic & Ruedenberg (1996, errata 1998): band l from band 1 (r1, indices
 * −1…1 stored at +1) and band l − 1 (prev, indices −(l−1)…l−1). */
static double ir_p(int i, int l, int a, int b, const double r1[3][3], const double *prev) {
    const int lp = l - 1, n = 2 * lp + 1;
#define PREV(m_, n_) prev[((m_) + lp) * n + ((n_) + lp)]
    if (b == l) return r1[i + 1][2] * PREV(a, lp) - r1[i + 1][0] * PREV(a, -lp);
    if (b == -l) return r1[i + 1][2] * PREV(a, -lp) + r1[i + 1][0] * PREV(a, lp);
    return r1[i + 1][1] * PREV(a, b);
#undef PREV
}

static void ir_band(int l, const double r1[3][3], const double *prev, double *out) {
    const int n = 2 * l + 1;
    for (int m = -l; m <= l; m++)
        for (int k = -l; k <= l; k++) {
            int am = m < 0 ? -m : m, d = m == 0;
            double denom = (k == l || k == -l) ? (2.0 * l) * (2.0 * l - 1.0) : (double)(l + k) * (double)(l - k);
            double u = sqrt((double)(l + m) * (double)(l - m) / denom);
            double v = 0.5 * sqrt((1.0 + d) * (double)(l + am - 1) * (double)(l + am) / denom) * (1.0 - 2.0 * d);
            double w = -0.5 * sqrt((double)(l - am - 1) * (double)(l - am) / denom) * (1.0 - d);
            double r = 0.0;
            if (u != 0.0) r += u * ir_p(0, l, m, k, r1, prev);
            if (v != 0.0) {
                double V;
                if (m == 0) V = ir_p(1, l, 1, k, r1, prev) + ir_p(-1, l, -1, k, r1, prev);
                else if (m > 0) {
                    int d1 = m == 1;
                    V = ir_p(1, l, m - 1, k, r1, prev) * sqrt(1.0 + d1) - (d1 ? 0.0 : ir_p(-1, l, -m + 1, k, r1, prev));
                } else {
                    int d1 = m == -1;
                    V = (d1 ? 0.0 : ir_p(1, l, m + 1, k, r1, prev)) + ir_p(-1, l, -m - 1, k, r1, prev) * sqrt(1.0 + d1);
                }
                r += v * V;
            }
            if (w != 0.0) {
                double W = m > 0 ? ir_p(1, l, m + 1, k, r1, prev) + ir_p(-1, l, -m - 1, k, r1, prev)
                                 : ir_p(1, l, m - 1, k, r1, prev) - ir_p(-1, l, -m + 1, k, r1, prev);
                r += w * W;
            }
            out[(m + l) * n + (k + l)] = r;
        }
}

void sh_rotation_from_matrix(const double r[9], int bands, sh_rotation *out) {
    memset(out, 0, sizeof *out);
    out->bands = bands;
    out->band[0][0] = 1.0;
    if (bands < 2) return;
    /* Band 1 is (y, z, x): permute the rotation's rows and columns. */
    static const int p[3] = {1, 2, 0};
    double r1[3][3];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) r1[i][j] = r[3 * p[i] + p[j]];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) out->band[1][3 * i + j] = r1[i][j];
    for (int l = 2; l < bands; l++) ir_band(l, r1, out->band[l - 1], out->band[l]);
}

void sh_rotate(const sh_rotation *rot, const float *c_in, float *c_out) {
    float tmp[SH_MAX_COEFFS];
    for (int l = 0; l < rot->bands; l++) {
        const int n = 2 * l + 1, o = l * l;
        const double *m = rot->band[l];
        for (int i = 0; i < n; i++) {
            double s = 0.0;
            for (int k = 0; k < n; k++) s += m[i * n + k] * c_in[o + k];
            tmp[o + i] = (float)s;
        }
    }
    memcpy(c_out, tmp, sizeof(float) * (size_t)(rot->bands * rot->bands));
}

void sh_rotation_y(double radians, double r[9]) {
    double c = cos(radians), s = sin(radians);
    double m[9] = {c, 0, s, 0, 1, 0, -s, 0, c};
    memcpy(r, m, sizeof m);
}

/* ------------------------------------------------------------------ zonal kernels */

double sh_clamped_cosine_zonal(int l) {
    /* Â_0 = π, Â_1 = 2π/3, odd l > 1: 0, even l: 2π(−1)^{l/2−1}/((l+2)(l−1))·l!/(2^l ((l/2)!)²). */
    double a;
    if (l == 0) a = PI_D;
    else if (l == 1) a = 2.0 * PI_D / 3.0;
    else if (l & 1) a = 0.0;
    else {
        double h = factorial(l / 2);
        a = 2.0 * PI_D * ((l / 2 - 1) & 1 ? -1.0 : 1.0) / ((l + 2.0) * (l - 1.0)) * factorial(l) /
            (pow(2.0, l) * h * h);
    }
    return sqrt((2.0 * l + 1.0) / (4.0 * PI_D)) * a;
}

double sh_hg_zonal(int l, double g) { return sqrt((2.0 * l + 1.0) / (4.0 * PI_D)) * pow(g, l); }

/* Legendre polynomial P_l(t). */
static double legendre0(int l, double t) { return l < 0 ? 1.0 : legendre(l, 0, t); }

double sh_cap_zonal(int l, double half_angle) {
    double t = cos(half_angle);
    /* ∫_t^1 P_l = (P_{l−1}(t) − P_{l+1}(t))/(2l+1) for l ≥ 1; 1 − t for l = 0 */
    double integral = l == 0 ? 1.0 - t : (legendre0(l - 1, t) - legendre0(l + 1, t)) / (2.0 * l + 1.0);
    return 2.0 * PI_D * sqrt((2.0 * l + 1.0) / (4.0 * PI_D)) * integral;
}

float sh_zonal_apply(int bands, const double *k, const float *c, volux_vec3 a) {
    float y[SH_MAX_COEFFS];
    sh_eval(bands, a, y);
    double s = 0.0;
    for (int l = 0; l < bands; l++) {
        double f = sqrt(4.0 * PI_D / (2.0 * l + 1.0)) * k[l];
        double b = 0.0;
        for (int j = l * l; j < (l + 1) * (l + 1); j++) b += (double)c[j] * y[j];
        s += f * b;
    }
    return (float)s;
}

void sh_zonal_add(int bands, const double *k, volux_vec3 a, float w, float *out) {
    float y[SH_MAX_COEFFS];
    sh_eval(bands, a, y);
    for (int l = 0; l < bands; l++) {
        float f = (float)(sqrt(4.0 * PI_D / (2.0 * l + 1.0)) * k[l]) * w;
        for (int j = l * l; j < (l + 1) * (l + 1); j++) out[j] += f * y[j];
    }
}

/* ------------------------------------------------------------------ projection */

void sh_project_stratified(int bands, int channels, int n_theta, int n_phi, uint64_t seed, sh_fn f, void *user,
                           double *out) {
    const int nc = bands * bands;
    memset(out, 0, sizeof(double) * (size_t)(channels * nc));
    volux_rng rng = volux_rng_make(seed, 0x5348, 0, 0);
    double w = 4.0 * PI_D / ((double)n_theta * n_phi);
    float values[16], y[SH_MAX_COEFFS];
    for (int i = 0; i < n_theta; i++)
        for (int k = 0; k < n_phi; k++) {
            double u = 1.0 - 2.0 * (i + volux_rng_double(&rng)) / n_theta;
            double phi = 2.0 * PI_D * (k + volux_rng_double(&rng)) / n_phi;
            double s = sqrt(fmax(0.0, 1.0 - u * u));
            volux_vec3 d = v3((float)(s * cos(phi)), (float)(s * sin(phi)), (float)u);
            f(user, d, values);
            sh_eval(bands, d, y);
            for (int c = 0; c < channels; c++)
                for (int j = 0; j < nc; j++) out[c * nc + j] += w * values[c] * y[j];
        }
}
