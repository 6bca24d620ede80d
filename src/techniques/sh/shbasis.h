/*
 * techniques/sh/shbasis.h — real spherical harmonics up to band 3 (16
 * coefficients), the representation `sh` shares between light, visibility
 * and material (Lindemann & Ropinski 2010, §3.1).
 *
 * CONVENTION. Real SH Y_j, j = l(l+1) + m, l = 0…3, m = −l…l, of a unit
 * direction (x, y, z) with z as the polar axis, orthonormal over the
 * sphere, WITHOUT the Condon–Shortley phase (Green 2003, "Spherical
 * Harmonic Lighting: The Gritty Details"): band 1 is 0.488603·(y, z, x),
 * m > 0 terms go with cos(mφ), m < 0 with sin(|m|φ). "bands" counts l = 0
 * … bands−1, so 4 bands are (bands)² = 16 coefficients.
 *
 *   projection     c_j = ∫ f(ω) Y_j(ω) dω                   (Eq. 2)
 *   product        ∫ f g dω = Σ_j c_j d_j  for band-limited f, g   (Eq. 3)
 *   rotation       f'(ω) = f(R⁻¹ω)  ⇔  c' = D(R) c, D block-diagonal per
 *                  band (Ivanic & Ruedenberg 1996, with their 1998 errata)
 *   zonal (Funk–Hecke)  ∫ k(ω·a) f(ω) dω = Σ_lm √(4π/(2l+1)) k_l c_lm Y_lm(a)
 *                  for a kernel with zonal coefficients k_l about +z.
 *
 * DOES NOT: allocate; know lights or volumes.
 */
#ifndef VOLUX_SH_BASIS_H
#define VOLUX_SH_BASIS_H

#include <stdint.h>

#include "core/vecmath.h"

#define SH_MAX_BANDS 4
#define SH_MAX_COEFFS (SH_MAX_BANDS * SH_MAX_BANDS)

/* Y_j(d) for j < bands², d unit (fast polynomial forms). */
void sh_eval(int bands, volux_vec3 d, float *y);
/* The same from the general definition (associated Legendre functions),
 * in double precision, for any l ≤ 8: the reference the tests compare the
 * polynomial forms with. */
double sh_eval_reference(int l, int m, double x, double y, double z);

/* Rotation matrices for bands 0…bands−1 of the rotation `r` (3×3, row
 * major, acting on column vectors): out[l] is (2l+1)² doubles, row m, column
 * n, and c'_lm = Σ_n out[l][m][n] c_ln rotates a function by r. */
typedef struct sh_rotation {
    int bands;
    double band[SH_MAX_BANDS][7 * 7];
} sh_rotation;
void sh_rotation_from_matrix(const double r[9], int bands, sh_rotation *out);
/* c_out = D(r) c_in (may alias). */
void sh_rotate(const sh_rotation *rot, const float *c_in, float *c_out);
/* Rotation about +Y by `radians` (right-handed: x → −z for +90°). */
void sh_rotation_y(double radians, double r[9]);

/* Σ_j a_j b_j over bands² coefficients (Eq. 3). */
static inline float sh_dot(int bands, const float *a, const float *b) {
    float s = 0.0f;
    for (int j = 0; j < bands * bands; j++) s += a[j] * b[j];
    return s;
}

/* Triple products Γ_ijk = ∫ Y_i Y_j Y_k dω of the 16 coefficients (the
 * non-zero ones, |Γ| > 1e-6): the projection of a product f·g of two
 * band-limited functions onto bands 0…3 is (fg)_k = Σ Γ_ijk f_i g_j
 * (Snyder 2006, "Code generation and factoring for fast evaluation of
 * low-order spherical harmonic products and squares" — the triple product
 * Lindemann & Ropinski §4.3 name and leave out). Computed by quadrature
 * exact for these polynomials (Gauss–Legendre in cos θ, uniform in φ). */
#define SH_TRIPLE_MAX (SH_MAX_COEFFS * SH_MAX_COEFFS * SH_MAX_COEFFS)
typedef struct sh_triple {
    int n;
    uint8_t i[SH_TRIPLE_MAX], j[SH_TRIPLE_MAX], k[SH_TRIPLE_MAX];
    float v[SH_TRIPLE_MAX];
} sh_triple;
void sh_triple_init(sh_triple *t);
/* out_k = Σ Γ_ijk f_i g_j for k < 16 (f, g: 16 coefficients each). */
void sh_triple_product(const sh_triple *t, const float *f, const float *g, float *out);

/* Zonal coefficients (about +z) of max(cos θ, 0): Ramamoorthi & Hanrahan
 * 2001's Â_l times √((2l+1)/4π). */
double sh_clamped_cosine_zonal(int l);
/* Zonal coefficients of the Henyey–Greenstein phase function p(cos θ):
 * √((2l+1)/4π)·g^l. */
double sh_hg_zonal(int l, double g);
/* Zonal coefficients of a cap of angular radius `half_angle` holding 1
 * inside (the projection of a sphere light seen from outside). */
double sh_cap_zonal(int l, double half_angle);

/* Adds the Funk–Hecke convolution of the zonal kernel k (per band) with
 * c, evaluated in direction a: Σ_lm √(4π/(2l+1)) k_l c_lm Y_lm(a). */
float sh_zonal_apply(int bands, const double *k, const float *c, volux_vec3 a);
/* Coefficients of the zonal kernel k rotated so that its axis is a:
 * c_lm = √(4π/(2l+1)) k_l Y_lm(a), scaled by `w` (added to out). */
void sh_zonal_add(int bands, const double *k, volux_vec3 a, float w, float *out);

/* Stratified Monte-Carlo projection of f over the sphere: n_theta × n_phi
 * strata uniform in (cos θ, φ), one jittered sample each (counter-based
 * RNG keyed by seed), out[j] = Σ f(ω) Y_j(ω)·4π/N. f writes `channels`
 * values; out is channels × bands² (channel-major). */
typedef void (*sh_fn)(void *user, volux_vec3 d, float *values);
void sh_project_stratified(int bands, int channels, int n_theta, int n_phi, uint64_t seed, sh_fn f, void *user,
                           double *out);

#endif
