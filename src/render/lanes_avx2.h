/*
 * render/lanes_avx2.h — the lane vocabulary on 8 lanes (AVX2+FMA, __m256 and vector masks):
 * the operations every packet kernel (techniques/dvr/dvr_simd_impl.h, the
 * shared illuminated march render/packet_impl.h and its technique hooks)
 * is written in, and the reads in their AVX2 form. Moved here from
 * techniques/dvr/dvr_avx2.c so every ray-caster technique can use it.
 *
 * Not a normal header: include it only from a translation unit that is
 * compiled for this width (render/lanes.h lists the contract), and only
 * under VOLUX_X86_GNUC. Every operation is one or a few instructions whose
 * result, lane by lane, is the IEEE operation it names, the same as its
 * 16-lane twin (fused where the other is fused, nowhere else),
 * so kernels written once over this vocabulary give bit-identical images
 * at both widths.
 */
#ifndef VOLUX_LANES_AVX2_H
#define VOLUX_LANES_AVX2_H

#include "core/simd.h"
#include "core/volume_internal.h"

#define LANE_W 8
#define LANE_TARGET __attribute__((target("avx2,fma")))
#define DI static inline __attribute__((always_inline, target("avx2,fma")))

typedef __m256 vf;
typedef __m256i vi;
typedef __m256 vm; /* all ones / all zeros per lane */

DI vf f_set(float x) { return _mm256_set1_ps(x); }
DI vf f_zero(void) { return _mm256_setzero_ps(); }
DI vf f_add(vf a, vf b) { return _mm256_add_ps(a, b); }
DI vf f_sub(vf a, vf b) { return _mm256_sub_ps(a, b); }
DI vf f_mul(vf a, vf b) { return _mm256_mul_ps(a, b); }
DI vf f_div(vf a, vf b) { return _mm256_div_ps(a, b); }
DI vf f_sqrt(vf a) { return _mm256_sqrt_ps(a); }
DI vf f_min(vf a, vf b) { return _mm256_min_ps(a, b); }
DI vf f_max(vf a, vf b) { return _mm256_max_ps(a, b); }
DI vf f_fmadd(vf a, vf b, vf c) { return _mm256_fmadd_ps(a, b, c); }   /* a·b + c, rounded once */
DI vf f_fnmadd(vf a, vf b, vf c) { return _mm256_fnmadd_ps(a, b, c); } /* c − a·b, rounded once */
DI vf f_floor(vf a) { return _mm256_floor_ps(a); }
DI vf f_round(vf a) { return _mm256_round_ps(a, _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC); }
DI vf f_neg(vf a) { return _mm256_xor_ps(a, _mm256_set1_ps(-0.0f)); }
DI vf f_from_i(vi a) { return _mm256_cvtepi32_ps(a); }
DI vi i_trunc(vf a) { return _mm256_cvttps_epi32(a); }
DI vi i_round(vf a) { return _mm256_cvtps_epi32(a); }
DI vi f_as_i(vf a) { return _mm256_castps_si256(a); }
DI vf i_as_f(vi a) { return _mm256_castsi256_ps(a); }
DI void f_store(float *p, vf a) { _mm256_storeu_ps(p, a); }
DI vm f_lt(vf a, vf b) { return _mm256_cmp_ps(a, b, _CMP_LT_OQ); }
DI vm f_gt(vf a, vf b) { return _mm256_cmp_ps(a, b, _CMP_GT_OQ); }
DI vm f_ge(vf a, vf b) { return _mm256_cmp_ps(a, b, _CMP_GE_OQ); }
DI vm f_eq(vf a, vf b) { return _mm256_cmp_ps(a, b, _CMP_EQ_OQ); }
DI vi i_set(int32_t x) { return _mm256_set1_epi32(x); }
DI vi i_zero(void) { return _mm256_setzero_si256(); }
DI vi i_add(vi a, vi b) { return _mm256_add_epi32(a, b); }
DI vi i_sub(vi a, vi b) { return _mm256_sub_epi32(a, b); }
DI vi i_mullo(vi a, vi b) { return _mm256_mullo_epi32(a, b); }
DI vi i_madd16(vi a, vi b) { return _mm256_madd_epi16(a, b); }
DI vi i_min(vi a, vi b) { return _mm256_min_epi32(a, b); }
DI vi i_max(vi a, vi b) { return _mm256_max_epi32(a, b); }
DI vi i_abs(vi a) { return _mm256_abs_epi32(a); }
DI vi i_and(vi a, vi b) { return _mm256_and_si256(a, b); }
DI vi i_or(vi a, vi b) { return _mm256_or_si256(a, b); }
DI vi i_srli(vi a, int n) { return _mm256_srli_epi32(a, n); }
DI vi i_slli(vi a, int n) { return _mm256_slli_epi32(a, n); }
DI vi i_srai(vi a, int n) { return _mm256_srai_epi32(a, n); }
DI void i_store(int32_t *p, vi a) { _mm256_storeu_si256((__m256i *)(void *)p, a); }
DI vm i_gt(vi a, vi b) { return _mm256_castsi256_ps(_mm256_cmpgt_epi32(a, b)); }
DI vm i_eq(vi a, vi b) { return _mm256_castsi256_ps(_mm256_cmpeq_epi32(a, b)); }
DI vf sel(vm m, vf a, vf b) { return _mm256_blendv_ps(b, a, m); }
DI vi isel(vm m, vi a, vi b) { return _mm256_castps_si256(_mm256_blendv_ps(_mm256_castsi256_ps(b), _mm256_castsi256_ps(a), m)); }
DI vf f_keep(vf a, vm m) { return _mm256_and_ps(a, m); }
DI vm m_none(void) { return _mm256_setzero_ps(); }
DI vm m_all(void) { return _mm256_castsi256_ps(_mm256_set1_epi32(-1)); }
DI vm m_and(vm a, vm b) { return _mm256_and_ps(a, b); }
DI vm m_or(vm a, vm b) { return _mm256_or_ps(a, b); }
DI vm m_andnot(vm a, vm b) { return _mm256_andnot_ps(a, b); } /* the lanes of b not in a */
DI int m_bits(vm m) { return _mm256_movemask_ps(m); }
DI vm m_from_bits(unsigned bits) {
    const __m256i lane = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
    return _mm256_castsi256_ps(_mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32((int)bits), lane), lane));
}
/* The lowest n lanes of m. */
DI vm m_first_of(vm m, int n) {
    unsigned bits = (unsigned)m_bits(m), keep = 0;
    for (; n > 0 && bits; n--, bits &= bits - 1) keep |= bits & -bits;
    return m_from_bits(keep);
}

/* ------------------------------------------------------------ reads */

enum { SY_ = VOLUX_BRICK_NODES, SZ_ = VOLUX_BRICK_NODES * VOLUX_BRICK_NODES };

/* The 4 corner rows (y, z) of the cells at brick offsets b: 32 bits each,
 * so the x pair comes in one element. */
DI void gather_rows_u8(const unsigned char *p, vi b, vi g[4]) {
    g[0] = _mm256_i32gather_epi32((const int *)(const void *)p, b, 1);
    g[1] = _mm256_i32gather_epi32((const int *)(const void *)(p + SY_), b, 1);
    g[2] = _mm256_i32gather_epi32((const int *)(const void *)(p + SZ_), b, 1);
    g[3] = _mm256_i32gather_epi32((const int *)(const void *)(p + SZ_ + SY_), b, 1);
}
DI void gather_rows_u16(const unsigned char *p, vi b, vi g[4]) {
    g[0] = _mm256_i32gather_epi32((const int *)(const void *)p, b, 2);
    g[1] = _mm256_i32gather_epi32((const int *)(const void *)(p + 2 * SY_), b, 2);
    g[2] = _mm256_i32gather_epi32((const int *)(const void *)(p + 2 * SZ_), b, 2);
    g[3] = _mm256_i32gather_epi32((const int *)(const void *)(p + 2 * (SZ_ + SY_)), b, 2);
}
DI void gather_corners_f32(const float *p, vi b, vf c[8]) {
    c[0] = _mm256_i32gather_ps(p, b, 4);
    c[1] = _mm256_i32gather_ps(p + 1, b, 4);
    c[2] = _mm256_i32gather_ps(p + SY_, b, 4);
    c[3] = _mm256_i32gather_ps(p + SY_ + 1, b, 4);
    c[4] = _mm256_i32gather_ps(p + SZ_, b, 4);
    c[5] = _mm256_i32gather_ps(p + SZ_ + 1, b, 4);
    c[6] = _mm256_i32gather_ps(p + SZ_ + SY_, b, 4);
    c[7] = _mm256_i32gather_ps(p + SZ_ + SY_ + 1, b, 4);
}

/* Corner words (dvr_corners.c) at word indices w: w[0] the low dwords
 * (the z corner row), w[1] the high ones (z+1); two gathers of 4 64-bit
 * elements, 8 gathered elements per 8 samples against 32 from the bricks. */
DI void gather_corner_words(const uint64_t *p, vi idx, vi w[2]) {
    const long long *base = (const long long *)(const void *)p;
    __m256 lo = _mm256_castsi256_ps(_mm256_i32gather_epi64(base, _mm256_castsi256_si128(idx), 8));
    __m256 hi = _mm256_castsi256_ps(_mm256_i32gather_epi64(base, _mm256_extracti128_si256(idx, 1), 8));
    /* the shuffle leaves the lanes in order 0 1 4 5 2 3 6 7, the permute restores it */
    w[0] = _mm256_permute4x64_epi64(_mm256_castps_si256(_mm256_shuffle_ps(lo, hi, 0x88)), 0xD8);
    w[1] = _mm256_permute4x64_epi64(_mm256_castps_si256(_mm256_shuffle_ps(lo, hi, 0xDD)), 0xD8);
}

/* gather_rows_u8/u16 for the lanes of m only (0 elsewhere) */
DI void gather_rows_masked(const unsigned char *p, vi b, vm m, int size, vi g[4]) {
    static const int rows[4] = {0, SY_, SZ_, SZ_ + SY_};
    const __m256i mi = _mm256_castps_si256(m), zero = _mm256_setzero_si256();
    for (int r = 0; r < 4; r++)
        g[r] = size == 1 ? _mm256_mask_i32gather_epi32(zero, (const int *)(const void *)(p + rows[r]), b, mi, 1)
                         : _mm256_mask_i32gather_epi32(zero, (const int *)(const void *)(p + 2 * rows[r]), b, mi, 2);
}

/* Gradient cache nodes x and x+1 of the 4 corner rows for the lanes of m
 * (0 elsewhere): each pair is one 64-bit element (two gathers of 4 per
 * row). */
DI void gather_gradient_rows(const uint32_t *grad, vi b, vm m, vi w0[4], vi w1[4]) {
    static const int rows[4] = {0, SY_, SZ_, SZ_ + SY_};
    __m128i b_lo = _mm256_castsi256_si128(b), b_hi = _mm256_extracti128_si256(b, 1);
    const __m256i mi = _mm256_castps_si256(m), zero = _mm256_setzero_si256();
    const __m256i m_lo = _mm256_cvtepi32_epi64(_mm256_castsi256_si128(mi));
    const __m256i m_hi = _mm256_cvtepi32_epi64(_mm256_extracti128_si256(mi, 1));
    for (int r = 0; r < 4; r++) {
        const long long *base = (const long long *)(const void *)(grad + rows[r]);
        __m256 lo = _mm256_castsi256_ps(_mm256_mask_i32gather_epi64(zero, base, b_lo, m_lo, 4));
        __m256 hi = _mm256_castsi256_ps(_mm256_mask_i32gather_epi64(zero, base, b_hi, m_hi, 4));
        /* even dwords are node x, odd ones node x+1; the shuffle leaves the
         * lanes in order 0 1 4 5 2 3 6 7, the permute restores it */
        w0[r] = _mm256_permute4x64_epi64(_mm256_castps_si256(_mm256_shuffle_ps(lo, hi, 0x88)), 0xD8);
        w1[r] = _mm256_permute4x64_epi64(_mm256_castps_si256(_mm256_shuffle_ps(lo, hi, 0xDD)), 0xD8);
    }
}

/* Signed bytes p[idx] of the lanes in `need` (0 elsewhere): a 32-bit gather
 * at the byte (the array has 3 bytes of padding), low byte sign-extended. */
DI vi gather_i8_masked(const int8_t *p, vi idx, vm need) {
    vi w = _mm256_mask_i32gather_epi32(_mm256_setzero_si256(), (const int *)(const void *)p, idx,
                                       _mm256_castps_si256(need), 1);
    return _mm256_srai_epi32(_mm256_slli_epi32(w, 24), 24);
}

/* Rows of 8 floats at base + offs[l] (one per lane), transposed: o[e] holds
 * element e of every lane. Each vector pairs the halves of lanes l and l+4
 * (128-bit loads into both halves: load-port work, no shuffle), then two
 * in-lane 4×4 transposes: 16 shuffles instead of 24, and no gathers. */
DI void load_rows8(const float *base, vi offs_v, vf o[8]) {
    _Alignas(32) int32_t offs[8];
    _mm256_store_si256((__m256i *)(void *)offs, offs_v);
    for (int h = 0; h < 2; h++) { /* h = 0: elements 0–3, h = 1: elements 4–7 */
        __m256 r[4];
        for (int l = 0; l < 4; l++)
            r[l] = _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_loadu_ps(base + offs[l] + 4 * h)),
                                        _mm_loadu_ps(base + offs[l + 4] + 4 * h), 1);
        __m256 t0 = _mm256_unpacklo_ps(r[0], r[1]), t1 = _mm256_unpackhi_ps(r[0], r[1]);
        __m256 t2 = _mm256_unpacklo_ps(r[2], r[3]), t3 = _mm256_unpackhi_ps(r[2], r[3]);
        o[4 * h + 0] = _mm256_shuffle_ps(t0, t2, 0x44);
        o[4 * h + 1] = _mm256_shuffle_ps(t0, t2, 0xEE);
        o[4 * h + 2] = _mm256_shuffle_ps(t1, t3, 0x44);
        o[4 * h + 3] = _mm256_shuffle_ps(t1, t3, 0xEE);
    }
}

/* Ray-list refill: rank[l] = how many lanes of `fill` lie below lane l, so
 * f_pick puts list entry p[rank] into each lane of fill (an expand). */
DI vi lane_ranks(vm fill) {
    _Alignas(32) int32_t r[8];
    unsigned bits = (unsigned)m_bits(fill);
    for (int l = 0, k = 0; l < 8; l++) {
        r[l] = k;
        k += (int)(bits >> l & 1u);
    }
    return _mm256_load_si256((const __m256i *)(const void *)r);
}
DI vf f_pick(vf src, vm fill, const float *p, vi rank) {
    return sel(fill, _mm256_permutevar8x32_ps(_mm256_loadu_ps(p), rank), src);
}

/* Loads and plain float gathers (the technique hooks' cache volumes). */
DI vf f_load(const float *p) { return _mm256_loadu_ps(p); }
DI vf gather_f32(const float *p, vi idx) { return _mm256_i32gather_ps(p, idx, 4); }
DI vf gather_f32_masked(const float *p, vi idx, vm m) {
    return _mm256_mask_i32gather_ps(_mm256_setzero_ps(), p, idx, m, 4);
}
/* bfloat16 values p[idx] as floats (core/bf16.h): the 32-bit word at each
 * value, shifted so the value is its upper half (reads one value past
 * p[idx]: the caller's array is padded). */
DI vf gather_bf16_masked(const uint16_t *p, vi idx, vm m) {
    vi w = _mm256_mask_i32gather_epi32(_mm256_setzero_si256(), (const int *)(const void *)p, idx,
                                       _mm256_castps_si256(m), 2);
    return _mm256_castsi256_ps(_mm256_slli_epi32(w, 16));
}

#endif
