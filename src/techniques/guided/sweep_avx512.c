/*
 * techniques/guided/sweep_avx512.c — the sweep's row loop 16 kernel rays at
 * a time (ray spacing 1): the two rows' nodes c and c + 1 as 16-lane
 * vectors (consecutive kernel rays read consecutive columns), the bilinear
 * blend with FMA, the LUT's σt by two gathers, W += wdt·σ. All intrinsics
 * of `guided` live in this file; it is compiled with target attributes and
 * chosen at run time (techniques.guided.kernel), so the default build runs
 * on any x86-64 and sweep.c's portable loop stays the reference. The tail
 * of a row is done with masked loads and stores, so no lane reads past the
 * row. Differences to the portable loop are float rounding (FMA).
 */
#include "sweep_kernels.h"

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>

int guided_sweep_avx512_available(void) {
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
           __builtin_cpu_supports("avx512vl");
}

#define A5 __attribute__((target("avx512f,avx512bw,avx512vl,fma")))
#define A5I static inline __attribute__((always_inline, target("avx512f,avx512bw,avx512vl,fma")))

/* σt of 16 interpolated values s and W += wdt·σ (masked lanes untouched). */
A5I void finish(__m512 s, const sweep_lut *L, __mmask16 m, float *W, const float *wdt, float *sig) {
    __m512 u = _mm512_mul_ps(_mm512_sub_ps(s, _mm512_set1_ps(L->s_min)), _mm512_set1_ps(L->inv_ds));
    u = _mm512_min_ps(_mm512_max_ps(u, _mm512_setzero_ps()), _mm512_set1_ps(L->last));
    __m512i idx = _mm512_cvttps_epi32(u);
    __m512 f = _mm512_sub_ps(u, _mm512_cvtepi32_ps(idx));
    __m512 t0 = _mm512_mask_i32gather_ps(_mm512_setzero_ps(), m, idx, L->t, 4);
    __m512 t1 = _mm512_mask_i32gather_ps(_mm512_setzero_ps(), m, idx, L->t + 1, 4);
    __m512 sg = _mm512_fmadd_ps(f, _mm512_sub_ps(t1, t0), t0);
    if (sig) _mm512_mask_storeu_ps(sig, m, sg);
    __m512 w = _mm512_maskz_loadu_ps(m, W);
    _mm512_mask_storeu_ps(W, m, _mm512_fmadd_ps(_mm512_maskz_loadu_ps(m, wdt), sg, w));
}

A5I __m512 blend(__m512 a0, __m512 a1, __m512 b0, __m512 b1, __m512 fa, __m512 fb, __m512 off) {
    __m512 top = _mm512_fmadd_ps(fa, _mm512_sub_ps(a1, a0), a0);
    __m512 bot = _mm512_fmadd_ps(fa, _mm512_sub_ps(b1, b0), b0);
    return _mm512_add_ps(_mm512_fmadd_ps(fb, _mm512_sub_ps(bot, top), top), off);
}

/* Loads 16 nodes starting at p (masked lanes read nothing). */
A5I __m512 load_u8(const uint8_t *p, __mmask16 m) {
    return _mm512_cvtepi32_ps(_mm512_cvtepu8_epi32(_mm_maskz_loadu_epi8(m, p)));
}
A5I __m512 load_u16(const uint16_t *p, __mmask16 m) {
    return _mm512_cvtepi32_ps(_mm512_cvtepu16_epi32(_mm256_maskz_loadu_epi16(m, p)));
}
A5I __m512 load_f32(const float *p, __mmask16 m) { return _mm512_maskz_loadu_ps(m, p); }

#define ROW_AVX512(NAME, T, LOAD)                                                                                  \
    A5 static void NAME(const void *r0v, const void *r1v, int h, float fa_, float fb_, float offset,              \
                        const sweep_lut *L, int n, float *W, const float *wdt, float *sig) {                      \
        (void)h;                                                                                                  \
        const T *R0 = r0v, *R1 = r1v;                                                                             \
        __m512 fa = _mm512_set1_ps(fa_), fb = _mm512_set1_ps(fb_), off = _mm512_set1_ps(offset);                  \
        for (int i = 0; i < n; i += 16) {                                                                         \
            int left = n - i;                                                                                     \
            __mmask16 m = left >= 16 ? (__mmask16)0xffff : (__mmask16)((1u << left) - 1u);                        \
            __m512 s = blend(LOAD(R0 + i, m), LOAD(R0 + i + 1, m), LOAD(R1 + i, m), LOAD(R1 + i + 1, m), fa, fb,   \
                             off);                                                                                \
            finish(s, L, m, W + i, wdt + i, sig ? sig + i : NULL);                                               \
        }                                                                                                         \
    }
ROW_AVX512(row_u8_avx512, uint8_t, load_u8)
ROW_AVX512(row_u16_avx512, uint16_t, load_u16)
ROW_AVX512(row_f32_avx512, float, load_f32)

sweep_row_fn guided_sweep_row_avx512(volux_storage storage) {
    switch (storage) {
    case VOLUX_STORE_U8: return row_u8_avx512;
    case VOLUX_STORE_U16: return row_u16_avx512;
    default: return row_f32_avx512;
    }
}

#else /* not x86-64 GCC/Clang: the portable loop only */

int guided_sweep_avx512_available(void) { return 0; }
sweep_row_fn guided_sweep_row_avx512(volux_storage storage) {
    (void)storage;
    return NULL;
}

#endif
