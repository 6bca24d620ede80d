/* techniques/sh/dipole.c — see dipole.h. */
#include "dipole.h"

#include <math.h>
#include <string.h>

#define PI_D 3.14159265358979323846

/* Jensen et al. 2001, Fig. 5 (σ_s', σ_a in 1/mm; R_d; η = 1.3). */
static const sh_dipole_material presets[] = {
    {"apple", {2.29, 2.39, 1.97}, {0.0030, 0.0034, 0.046}, 1.3, {0.85, 0.84, 0.53}},
    {"chicken1", {0.15, 0.21, 0.38}, {0.015, 0.077, 0.19}, 1.3, {0.31, 0.15, 0.10}},
    {"chicken2", {0.19, 0.25, 0.32}, {0.018, 0.088, 0.20}, 1.3, {0.32, 0.16, 0.10}},
    {"cream", {7.38, 5.47, 3.15}, {0.0002, 0.0028, 0.0163}, 1.3, {0.98, 0.90, 0.73}},
    {"ketchup", {0.18, 0.07, 0.03}, {0.061, 0.97, 1.45}, 1.3, {0.16, 0.01, 0.00}},
    {"marble", {2.19, 2.62, 3.00}, {0.0021, 0.0041, 0.0071}, 1.3, {0.83, 0.79, 0.75}},
    {"potato", {0.68, 0.70, 0.55}, {0.0024, 0.0090, 0.12}, 1.3, {0.77, 0.62, 0.21}},
    {"skimmilk", {0.70, 1.22, 1.90}, {0.0014, 0.0025, 0.0142}, 1.3, {0.81, 0.81, 0.69}},
    {"skin1", {0.74, 0.88, 1.01}, {0.032, 0.17, 0.48}, 1.3, {0.44, 0.22, 0.13}},
    {"skin2", {1.09, 1.59, 1.79}, {0.013, 0.070, 0.145}, 1.3, {0.63, 0.44, 0.34}},
    {"spectralon", {11.6, 20.4, 14.9}, {0.0, 0.0, 0.0}, 1.3, {1.00, 1.00, 1.00}},
    {"wholemilk", {2.55, 3.21, 3.77}, {0.0011, 0.0024, 0.014}, 1.3, {0.91, 0.88, 0.76}},
};

int sh_dipole_count(void) { return (int)(sizeof presets / sizeof presets[0]); }
const sh_dipole_material *sh_dipole_at(int i) { return i >= 0 && i < sh_dipole_count() ? &presets[i] : NULL; }
const sh_dipole_material *sh_dipole_find(const char *name) {
    for (int i = 0; i < sh_dipole_count(); i++)
        if (!strcmp(presets[i].name, name)) return &presets[i];
    return NULL;
}

/* The dipole's constants for one channel. */
typedef struct dipole { double alpha_p, sigma_tr, zr, zv; } dipole;

static dipole setup(const sh_dipole_material *m, int c) {
    double eta = m->eta;
    double fdr = -1.440 / (eta * eta) + 0.710 / eta + 0.668 + 0.0636 * eta; /* diffuse Fresnel (Egan & Hilgeman) */
    double A = (1.0 + fdr) / (1.0 - fdr);
    double st = m->sigma_s_prime[c] + m->sigma_a[c];
    dipole d;
    d.alpha_p = m->sigma_s_prime[c] / st;
    d.sigma_tr = sqrt(3.0 * m->sigma_a[c] * st);
    d.zr = 1.0 / st;
    d.zv = d.zr * (1.0 + 4.0 * A / 3.0);
    return d;
}

double sh_dipole_rd(const sh_dipole_material *m, int c, double r) {
    dipole d = setup(m, c);
    double dr = sqrt(r * r + d.zr * d.zr), dv = sqrt(r * r + d.zv * d.zv);
    double real = d.zr * (d.sigma_tr * dr + 1.0) * exp(-d.sigma_tr * dr) / (dr * dr * dr);
    double virt = d.zv * (d.sigma_tr * dv + 1.0) * exp(-d.sigma_tr * dv) / (dv * dv * dv);
    return d.alpha_p / (4.0 * PI_D) * (real + virt);
}

double sh_dipole_rd_total(const sh_dipole_material *m, int c) {
    /* ∫ z(1+σd)e^{−σd}/d³ · r dr / 2 = e^{−σz}/2 per source */
    dipole d = setup(m, c);
    return 0.5 * d.alpha_p * (exp(-d.sigma_tr * d.zr) + exp(-d.sigma_tr * d.zv));
}

/* Solves the k×k system a·x = b in place (Gaussian elimination with
 * partial pivoting); returns 0 if singular. */
static int solve(int k, double a[SH_DIPOLE_GAUSSIANS][SH_DIPOLE_GAUSSIANS], double b[SH_DIPOLE_GAUSSIANS]) {
    for (int i = 0; i < k; i++) {
        int p = i;
        for (int r = i + 1; r < k; r++)
            if (fabs(a[r][i]) > fabs(a[p][i])) p = r;
        if (fabs(a[p][i]) < 1e-300) return 0;
        for (int c = 0; c < k; c++) {
            double t = a[i][c];
            a[i][c] = a[p][c];
            a[p][c] = t;
        }
        double t = b[i];
        b[i] = b[p];
        b[p] = t;
        for (int r = i + 1; r < k; r++) {
            double f = a[r][i] / a[i][i];
            for (int c = i; c < k; c++) a[r][c] -= f * a[i][c];
            b[r] -= f * b[i];
        }
    }
    for (int i = k - 1; i >= 0; i--) {
        for (int c = i + 1; c < k; c++) b[i] -= a[i][c] * b[c];
        b[i] /= a[i][i];
    }
    return 1;
}

void sh_dipole_fit(const sh_dipole_material *m, double mm_per_unit, double radius, double soften, double s_min,
                   double s_max, sh_gauss_fit *out) {
    enum { K = SH_DIPOLE_GAUSSIANS, M = 256 };
    memset(out, 0, sizeof *out);
    for (int k = 0; k < K; k++) out->s[k] = s_min * pow(s_max / s_min, (double)k / (K - 1));
    for (int c = 0; c < 3; c++) {
        /* Active-set non-negative least squares: drop the most negative
         * weight and refit until all are ≥ 0. */
        int active[K] = {1, 1, 1, 1};
        double w[K] = {0};
        for (int round = 0; round < K; round++) {
            int idx[K], n = 0;
            for (int k = 0; k < K; k++)
                if (active[k]) idx[n++] = k;
            double a[K][K] = {{0}}, b[K] = {0};
            for (int i = 0; i < M; i++) {
                double r = radius * (i + 0.5) / M, wt = r * r;
                double f = sh_dipole_rd(m, c, sqrt(r * r + soften * soften) * mm_per_unit), g[K];
                for (int j = 0; j < n; j++) g[j] = exp(-r * r / (2.0 * out->s[idx[j]] * out->s[idx[j]]));
                for (int j = 0; j < n; j++) {
                    b[j] += wt * f * g[j];
                    for (int l = 0; l < n; l++) a[j][l] += wt * g[j] * g[l];
                }
            }
            for (int k = 0; k < K; k++) w[k] = 0.0;
            if (!solve(n, a, b)) break;
            int worst = -1;
            for (int j = 0; j < n; j++) {
                w[idx[j]] = b[j];
                if (b[j] < 0.0 && (worst < 0 || b[j] < w[worst])) worst = idx[j];
            }
            if (worst < 0) break;
            active[worst] = 0;
            w[worst] = 0.0;
        }
        for (int k = 0; k < K; k++) out->w[c][k] = w[k] > 0.0 ? w[k] : 0.0;
        double num = 0.0, den = 0.0;
        for (int i = 0; i < M; i++) {
            double r = radius * (i + 0.5) / M, wt = r * r, g = 0.0;
            double f = sh_dipole_rd(m, c, sqrt(r * r + soften * soften) * mm_per_unit);
            for (int k = 0; k < K; k++) g += out->w[c][k] * exp(-r * r / (2.0 * out->s[k] * out->s[k]));
            num += wt * (f - g) * (f - g);
            den += wt * f * f;
        }
        out->rel_error[c] = den > 0.0 ? sqrt(num / den) : 0.0;
    }
}
