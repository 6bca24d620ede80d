/*
 * core/simd.h — the CPU-feature checks of the run-time kernel choice and
 * the branch-free elementary functions of the techniques' inner loops
 * (no libm call, so loops vectorise), scalar and eight AVX2 lanes.
 *
 * Several approximations of one function live side by side on purpose:
 * each technique's images are pinned bit for bit by its tests and by the
 * before/after comparisons of the bench scenes, and no two of them give the
 * same result for every input they see (checked over every float in
 * [−88, 0] for the exponentials, every float in [0, 1] for acos: they
 * differ in most of them). Merging two would change images. Each is named
 * for its contract; where one is used is said at it.
 *
 * Naming: exp_nonpos(x) = e^x for x ≤ 0; exp_neg(x) = e^−x for x ≥ 0.
 */
#ifndef VOLUX_CORE_SIMD_H
#define VOLUX_CORE_SIMD_H

#include <math.h>
#include <stdint.h>
#include <string.h>

#if defined(__x86_64__) && defined(__GNUC__)
#define VOLUX_X86_GNUC 1
#include <immintrin.h>
#else
#define VOLUX_X86_GNUC 0
#endif

/* ------------------------------------------------------------ CPU features
 * Kernels with intrinsics are compiled with target attributes and chosen
 * at run time by these, so the default build runs on any x86-64 (and
 * elsewhere every check is 0: the portable kernels run). */

#if VOLUX_X86_GNUC
#define VOLUX_CPU_HAS(feature) (__builtin_cpu_init(), __builtin_cpu_supports(feature) != 0)
#else
#define VOLUX_CPU_HAS(feature) 0
#endif

/* AVX2 alone: the ambient tube kernels, which must not contract a·b + c
 * (bit-identical to their scalar path). */
static inline int volux_cpu_has_avx2(void) { return VOLUX_CPU_HAS("avx2"); }

/* AVX2 and FMA: the `ea`/`shaded` packets and lightvol's row kernels. */
static inline int volux_cpu_has_avx2_fma(void) { return VOLUX_CPU_HAS("avx2") && VOLUX_CPU_HAS("fma"); }

/* AVX-512F (callers combine it with the AVX2 checks they need). */
static inline int volux_cpu_has_avx512f(void) { return VOLUX_CPU_HAS("avx512f"); }

/* ------------------------------------------------------------ exponentials */

/* e^x for x ≤ 0 (clamped at −87): 2^n through the exponent bits and a
 * degree-6 Taylor polynomial on |r| ≤ ln2/2 (< 3e-7 on its own). The max
 * uses fabs so the loop stays branch-free, at a price: x − 87 rounds x to
 * that sum's float grid, so the relative error is ≤ 4.1e-6 above −41 and
 * ≤ 8e-6 down to −87 (measured). Used by the scattering
 * techniques (`single`, `ao`, `ambient`: segment opacity, cache reads) and
 * the ambient table's estimator. */
static inline float volux_exp_nonpos_t6(float x) {
    /* max(x, −87), branch-free (maxss); also −87 for −inf and NaN. The
     * former 0.5·(x − 87 + |x + 87|) lost the 87 for |x| ≳ 1e9 and gave
     * e^0 = 1 for an optical depth of 1e30 (issue 16). */
    x = x > -87.0f ? x : -87.0f;
    float t = x * 1.44269504f;
    int n = (int)(t - 0.5f); /* round to nearest for t ≤ 0 */
    float r = x - (float)n * 0.693145752f - (float)n * 1.42860677e-6f;
    float p = 1.0f + r * (1.0f + r * (0.5f + r * (0.166666667f + r * (0.0416666667f + r * (0.00833333333f +
                                                                                         r * 0.00138888889f)))));
    int32_t bits = (n + 127) << 23;
    float scale;
    memcpy(&scale, &bits, sizeof scale);
    return p * scale;
}

/* e^−x for x ≥ 0 (x may be +inf), branch-free so loops vectorise:
 * Cody–Waite reduction x = n·ln2 + r (ln2 split in two), |r| ≤ ½ln2, then
 * the degree-7 Taylor polynomial of e^−r (relative error < 3e-7); exactly 1
 * at 0, never above 1, 0 beyond 2^−126. Used by lightvol's portable sweeps
 * (and the row ends of its AVX2 kernels). */
static inline float volux_exp_neg_cw7(float x) {
    float y = x * 1.44269504088896341f;
    if (!(y < 126.0f)) y = 126.0f; /* also catches NaN */
    int n = (int)(y + 0.5f);
    float r = (x - (float)n * 0.693145752f) - (float)n * 1.42860677e-6f;
    float p = -1.0f / 5040.0f;
    p = p * r + 1.0f / 720.0f;
    p = p * r - 1.0f / 120.0f;
    p = p * r + 1.0f / 24.0f;
    p = p * r - 1.0f / 6.0f;
    p = p * r + 0.5f;
    p = p * r - 1.0f;
    p = p * r + 1.0f;
    int32_t bits = (127 - n) << 23; /* 2^−n */
    float scale;
    memcpy(&scale, &bits, sizeof scale);
    float e = p * scale;
    e = e > 1.0f ? 1.0f : e;
    return y >= 126.0f ? 0.0f : e;
}

/* ------------------------------------------------------------------- acos */

/* acos on [−1, 1] with |error| ≤ 6.8e-5 rad (Abramowitz & Stegun 4.4.45,
 * degree 3: 6.7e-5, plus float rounding). Used by `ambient` for the
 * scattering angle of its table look-up (the table's θ resolution is far
 * coarser). */
static inline float volux_acos_deg3(float x) {
    float ax = fabsf(x);
    if (ax > 1.0f) ax = 1.0f;
    float r = sqrtf(1.0f - ax) * (1.5707288f + ax * (-0.2121144f + ax * (0.0742610f - 0.0187293f * ax)));
    return x < 0.0f ? 3.14159265f - r : r;
}

/* acos on [0, 1] (clamped), |error| ≤ 3e-7 rad (Abramowitz & Stegun
 * 4.4.46, degree 7: 2e-8, plus float rounding). Used by lightvol's face
 * factors (Eq. 5); volux_acos01_deg7_avx2 is its vector form. */
static inline float volux_acos01_deg7(float x) {
    x = x > 1.0f ? 1.0f : x;
    x = x < 0.0f ? 0.0f : x;
    float p = -0.0012624911f;
    p = p * x + 0.0066700901f;
    p = p * x - 0.0170881256f;
    p = p * x + 0.0308918810f;
    p = p * x - 0.0501743046f;
    p = p * x + 0.0889789874f;
    p = p * x - 0.2145988016f;
    p = p * x + 1.5707963050f;
    return sqrtf(1.0f - x) * p;
}

/* ------------------------------------------------- eight lanes (AVX2+FMA)
 * Inlined into callers compiled with target("avx2,fma") or a superset. */
#if VOLUX_X86_GNUC
#define VOLUX_AVX2_FMA_INLINE static inline __attribute__((always_inline, target("avx2,fma")))

/* e^x for x ≤ 0 (Cephes expf: round to the nearest power of two, degree-6
 * polynomial on [−ln2/2, ln2/2]); ≤ 2 ulp from libm's expf, and
 * e^x = 0 below −87.3 is not needed (the result stays a tiny normal).
 * The `ea`/`shaded` packet kernels (opacity, specular power) use the same
 * operations written over their lane vocabulary at 8 and 16 lanes
 * (exp_nonpos in techniques/dvr/dvr_simd_impl.h, which core cannot host);
 * this 8-lane form is what test_simd checks the ulp error of. */
VOLUX_AVX2_FMA_INLINE __m256 volux_exp_nonpos_cephes_avx2(__m256 x) {
    x = _mm256_max_ps(x, _mm256_set1_ps(-87.3f));
    __m256 n = _mm256_round_ps(_mm256_mul_ps(x, _mm256_set1_ps(1.44269504088896341f)),
                               _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
    __m256 r = _mm256_fnmadd_ps(n, _mm256_set1_ps(0.693359375f), x);
    r = _mm256_fnmadd_ps(n, _mm256_set1_ps(-2.12194440e-4f), r);
    __m256 y = _mm256_set1_ps(1.9875691500e-4f);
    y = _mm256_fmadd_ps(y, r, _mm256_set1_ps(1.3981999507e-3f));
    y = _mm256_fmadd_ps(y, r, _mm256_set1_ps(8.3334519073e-3f));
    y = _mm256_fmadd_ps(y, r, _mm256_set1_ps(4.1665795894e-2f));
    y = _mm256_fmadd_ps(y, r, _mm256_set1_ps(1.6666665459e-1f));
    y = _mm256_fmadd_ps(y, r, _mm256_set1_ps(5.0000001201e-1f));
    y = _mm256_fmadd_ps(y, _mm256_mul_ps(r, r), r);
    y = _mm256_add_ps(y, _mm256_set1_ps(1.0f));
    __m256i e = _mm256_slli_epi32(_mm256_add_epi32(_mm256_cvtps_epi32(n), _mm256_set1_epi32(127)), 23);
    return _mm256_mul_ps(y, _mm256_castsi256_ps(e));
}

/* volux_exp_neg_cw7 on eight lanes: the same reduction and polynomial,
 * fused (so not bit-identical to the scalar one: lightvol's tests bound
 * the difference). Used by lightvol's AVX2 row kernels. */
VOLUX_AVX2_FMA_INLINE __m256 volux_exp_neg_cw7_avx2(__m256 x) {
    const __m256 lim = _mm256_set1_ps(126.0f);
    __m256 y = _mm256_mul_ps(x, _mm256_set1_ps(1.44269504088896341f));
    __m256 ok = _mm256_cmp_ps(y, lim, _CMP_LT_OQ); /* false for NaN and beyond 2^−126 */
    y = _mm256_blendv_ps(lim, y, ok);
    __m256i n = _mm256_cvttps_epi32(_mm256_add_ps(y, _mm256_set1_ps(0.5f)));
    __m256 nf = _mm256_cvtepi32_ps(n);
    __m256 r = _mm256_fnmadd_ps(nf, _mm256_set1_ps(0.693145752f), x);
    r = _mm256_fnmadd_ps(nf, _mm256_set1_ps(1.42860677e-6f), r);
    __m256 p = _mm256_set1_ps(-1.0f / 5040.0f);
    p = _mm256_fmadd_ps(p, r, _mm256_set1_ps(1.0f / 720.0f));
    p = _mm256_fmadd_ps(p, r, _mm256_set1_ps(-1.0f / 120.0f));
    p = _mm256_fmadd_ps(p, r, _mm256_set1_ps(1.0f / 24.0f));
    p = _mm256_fmadd_ps(p, r, _mm256_set1_ps(-1.0f / 6.0f));
    p = _mm256_fmadd_ps(p, r, _mm256_set1_ps(0.5f));
    p = _mm256_fmadd_ps(p, r, _mm256_set1_ps(-1.0f));
    p = _mm256_fmadd_ps(p, r, _mm256_set1_ps(1.0f));
    __m256 scale = _mm256_castsi256_ps(_mm256_slli_epi32(_mm256_sub_epi32(_mm256_set1_epi32(127), n), 23));
    __m256 e = _mm256_min_ps(_mm256_mul_ps(p, scale), _mm256_set1_ps(1.0f));
    return _mm256_and_ps(e, ok);
}

/* volux_acos01_deg7 on eight lanes with plain mul/add (no FMA):
 * bit-identical to the scalar one. */
VOLUX_AVX2_FMA_INLINE __m256 volux_acos01_deg7_avx2(__m256 x) {
    x = _mm256_min_ps(_mm256_max_ps(x, _mm256_setzero_ps()), _mm256_set1_ps(1.0f));
    static const float c[8] = {-0.0012624911f, 0.0066700901f, -0.0170881256f, 0.0308918810f,
                               -0.0501743046f, 0.0889789874f, -0.2145988016f, 1.5707963050f};
    __m256 p = _mm256_set1_ps(c[0]);
    for (int i = 1; i < 8; i++) p = _mm256_add_ps(_mm256_mul_ps(p, x), _mm256_set1_ps(c[i]));
    return _mm256_mul_ps(_mm256_sqrt_ps(_mm256_sub_ps(_mm256_set1_ps(1.0f), x)), p);
}

#undef VOLUX_AVX2_FMA_INLINE
#endif /* VOLUX_X86_GNUC */

#endif
