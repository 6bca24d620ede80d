/*
 * render/lanes_avx512.h — the lane vocabulary on 16 lanes (AVX-512 F/BW/DQ/VL + FMA, __m512 and mask registers):
 * the operations every packet kernel (techniques/dvr/dvr_simd_impl.h, the
 * shared illuminated march render/packet_impl.h and its technique hooks)
 * is written in, and the reads in their AVX512 form. Moved here from
 * techniques/dvr/dvr_avx512.c so every ray-caster technique can use it.
 *
 * Not a normal header: include it only from a translation unit that is
 * compiled for this width (render/lanes.h lists the contract), and only
 * under VOLUX_X86_GNUC. Every operation is one or a few instructions whose
 * result, lane by lane, is the IEEE operation it names, the same as its
 * 8-lane twin (fused where the other is fused, nowhere else),
 * so kernels written once over this vocabulary give bit-identical images
 * at both widths.
 */
#ifndef VOLUX_LANES_AVX512_H
#define VOLUX_LANES_AVX512_H

#include "core/simd.h"
#include "core/volume_internal.h"

#define LANE_W 16
#define LANE_TARGET __attribute__((target("avx512f,avx512bw,avx512dq,avx512vl,avx2,fma")))
#define DI static inline __attribute__((always_inline, target("avx512f,avx512bw,avx512dq,avx512vl,avx2,fma")))

typedef __m512 vf;
typedef __m512i vi;
typedef __mmask16 vm;

DI vf f_set(float x) { return _mm512_set1_ps(x); }
DI vf f_zero(void) { return _mm512_setzero_ps(); }
DI vf f_add(vf a, vf b) { return _mm512_add_ps(a, b); }
DI vf f_sub(vf a, vf b) { return _mm512_sub_ps(a, b); }
DI vf f_mul(vf a, vf b) { return _mm512_mul_ps(a, b); }
DI vf f_div(vf a, vf b) { return _mm512_div_ps(a, b); }
DI vf f_sqrt(vf a) { return _mm512_sqrt_ps(a); }
DI vf f_min(vf a, vf b) { return _mm512_min_ps(a, b); }
DI vf f_max(vf a, vf b) { return _mm512_max_ps(a, b); }
DI vf f_fmadd(vf a, vf b, vf c) { return _mm512_fmadd_ps(a, b, c); }   /* a·b + c, rounded once */
DI vf f_fnmadd(vf a, vf b, vf c) { return _mm512_fnmadd_ps(a, b, c); } /* c − a·b, rounded once */
DI vf f_floor(vf a) { return _mm512_roundscale_ps(a, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC); }
DI vf f_round(vf a) { return _mm512_roundscale_ps(a, _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC); }
DI vf f_neg(vf a) { return _mm512_castsi512_ps(_mm512_xor_si512(_mm512_castps_si512(a), _mm512_set1_epi32((int)0x80000000u))); }
DI vf f_from_i(vi a) { return _mm512_cvtepi32_ps(a); }
DI vi i_trunc(vf a) { return _mm512_cvttps_epi32(a); }
DI vi i_round(vf a) { return _mm512_cvtps_epi32(a); }
DI vi f_as_i(vf a) { return _mm512_castps_si512(a); }
DI vf i_as_f(vi a) { return _mm512_castsi512_ps(a); }
DI void f_store(float *p, vf a) { _mm512_storeu_ps(p, a); }
DI vm f_lt(vf a, vf b) { return _mm512_cmp_ps_mask(a, b, _CMP_LT_OQ); }
DI vm f_gt(vf a, vf b) { return _mm512_cmp_ps_mask(a, b, _CMP_GT_OQ); }
DI vm f_ge(vf a, vf b) { return _mm512_cmp_ps_mask(a, b, _CMP_GE_OQ); }
DI vm f_eq(vf a, vf b) { return _mm512_cmp_ps_mask(a, b, _CMP_EQ_OQ); }
DI vi i_set(int32_t x) { return _mm512_set1_epi32(x); }
DI vi i_zero(void) { return _mm512_setzero_si512(); }
DI vi i_add(vi a, vi b) { return _mm512_add_epi32(a, b); }
DI vi i_sub(vi a, vi b) { return _mm512_sub_epi32(a, b); }
DI vi i_mullo(vi a, vi b) { return _mm512_mullo_epi32(a, b); }
DI vi i_madd16(vi a, vi b) { return _mm512_madd_epi16(a, b); }
DI vi i_min(vi a, vi b) { return _mm512_min_epi32(a, b); }
DI vi i_max(vi a, vi b) { return _mm512_max_epi32(a, b); }
DI vi i_abs(vi a) { return _mm512_abs_epi32(a); }
DI vi i_and(vi a, vi b) { return _mm512_and_si512(a, b); }
DI vi i_or(vi a, vi b) { return _mm512_or_si512(a, b); }
DI vi i_srli(vi a, int n) { return _mm512_srli_epi32(a, (unsigned)n); }
DI vi i_slli(vi a, int n) { return _mm512_slli_epi32(a, (unsigned)n); }
DI vi i_srai(vi a, int n) { return _mm512_srai_epi32(a, (unsigned)n); }
DI void i_store(int32_t *p, vi a) { _mm512_storeu_si512((void *)p, a); }
DI vm i_gt(vi a, vi b) { return _mm512_cmpgt_epi32_mask(a, b); }
DI vm i_eq(vi a, vi b) { return _mm512_cmpeq_epi32_mask(a, b); }
DI vf sel(vm m, vf a, vf b) { return _mm512_mask_blend_ps(m, b, a); }
DI vi isel(vm m, vi a, vi b) { return _mm512_mask_blend_epi32(m, b, a); }
DI vf f_keep(vf a, vm m) { return _mm512_maskz_mov_ps(m, a); }
DI vm m_none(void) { return (vm)0; }
DI vm m_all(void) { return (vm)0xffff; }
DI vm m_and(vm a, vm b) { return (vm)(a & b); }
DI vm m_or(vm a, vm b) { return (vm)(a | b); }
DI vm m_andnot(vm a, vm b) { return (vm)(~a & b); } /* the lanes of b not in a */
DI int m_bits(vm m) { return (int)m; }
/* The lowest n lanes of m. */
DI vm m_first_of(vm m, int n) {
    unsigned bits = m, keep = 0;
    for (; n > 0 && bits; n--, bits &= bits - 1) keep |= bits & -bits;
    return (vm)keep;
}

/* ------------------------------------------------------------ reads */

enum { SY_ = VOLUX_BRICK_NODES, SZ_ = VOLUX_BRICK_NODES * VOLUX_BRICK_NODES };

/* The 4 corner rows (y, z) of the cells at brick offsets b: 32 bits each,
 * so the x pair comes in one element. */
DI void gather_rows_u8(const unsigned char *p, vi b, vi g[4]) {
    g[0] = _mm512_i32gather_epi32(b, (const void *)p, 1);
    g[1] = _mm512_i32gather_epi32(b, (const void *)(p + SY_), 1);
    g[2] = _mm512_i32gather_epi32(b, (const void *)(p + SZ_), 1);
    g[3] = _mm512_i32gather_epi32(b, (const void *)(p + SZ_ + SY_), 1);
}
DI void gather_rows_u16(const unsigned char *p, vi b, vi g[4]) {
    g[0] = _mm512_i32gather_epi32(b, (const void *)p, 2);
    g[1] = _mm512_i32gather_epi32(b, (const void *)(p + 2 * SY_), 2);
    g[2] = _mm512_i32gather_epi32(b, (const void *)(p + 2 * SZ_), 2);
    g[3] = _mm512_i32gather_epi32(b, (const void *)(p + 2 * (SZ_ + SY_)), 2);
}
DI void gather_corners_f32(const float *p, vi b, vf c[8]) {
    c[0] = _mm512_i32gather_ps(b, p, 4);
    c[1] = _mm512_i32gather_ps(b, p + 1, 4);
    c[2] = _mm512_i32gather_ps(b, p + SY_, 4);
    c[3] = _mm512_i32gather_ps(b, p + SY_ + 1, 4);
    c[4] = _mm512_i32gather_ps(b, p + SZ_, 4);
    c[5] = _mm512_i32gather_ps(b, p + SZ_ + 1, 4);
    c[6] = _mm512_i32gather_ps(b, p + SZ_ + SY_, 4);
    c[7] = _mm512_i32gather_ps(b, p + SZ_ + SY_ + 1, 4);
}

/* Corner words (dvr_corners.c) at word indices w: w[0] the low dwords
 * (the z corner row), w[1] the high ones (z+1); two gathers of 8 64-bit
 * elements, 16 gathered elements per 16 samples against 64 from the
 * bricks, split by two-source permutes. */
DI void gather_corner_words(const uint64_t *p, vi idx, vi w[2]) {
    const vi even = _mm512_setr_epi32(0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20, 22, 24, 26, 28, 30);
    const vi odd = _mm512_add_epi32(even, _mm512_set1_epi32(1));
    vi lo = _mm512_i32gather_epi64(_mm512_castsi512_si256(idx), (const void *)p, 8);
    vi hi = _mm512_i32gather_epi64(_mm512_extracti64x4_epi64(idx, 1), (const void *)p, 8);
    w[0] = _mm512_permutex2var_epi32(lo, even, hi);
    w[1] = _mm512_permutex2var_epi32(lo, odd, hi);
}

/* gather_rows_u8/u16 for the lanes of m only (0 elsewhere) */
DI void gather_rows_masked(const unsigned char *p, vi b, vm m, int size, vi g[4]) {
    static const int rows[4] = {0, SY_, SZ_, SZ_ + SY_};
    for (int r = 0; r < 4; r++)
        g[r] = size == 1 ? _mm512_mask_i32gather_epi32(_mm512_setzero_si512(), m, b, (const void *)(p + rows[r]), 1)
                         : _mm512_mask_i32gather_epi32(_mm512_setzero_si512(), m, b,
                                                       (const void *)(p + 2 * rows[r]), 2);
}

/* Gradient cache nodes x and x+1 of the 4 corner rows for the lanes of m
 * (0 elsewhere): each pair is one 64-bit element (two gathers of 8 per
 * row), split into the even (node x) and odd (node x+1) dwords by
 * two-source permutes. */
DI void gather_gradient_rows(const uint32_t *grad, vi b, vm m, vi w0[4], vi w1[4]) {
    static const int rows[4] = {0, SY_, SZ_, SZ_ + SY_};
    const vi even = _mm512_setr_epi32(0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20, 22, 24, 26, 28, 30);
    const vi odd = _mm512_add_epi32(even, _mm512_set1_epi32(1));
    __m256i b_lo = _mm512_castsi512_si256(b), b_hi = _mm512_extracti64x4_epi64(b, 1);
    for (int r = 0; r < 4; r++) {
        const void *base = (const void *)(grad + rows[r]);
        vi lo = _mm512_mask_i32gather_epi64(_mm512_setzero_si512(), (__mmask8)(m & 0xff), b_lo, base, 4);
        vi hi = _mm512_mask_i32gather_epi64(_mm512_setzero_si512(), (__mmask8)(m >> 8), b_hi, base, 4);
        w0[r] = _mm512_permutex2var_epi32(lo, even, hi);
        w1[r] = _mm512_permutex2var_epi32(lo, odd, hi);
    }
}

/* Signed bytes p[idx] of the lanes in `need` (0 elsewhere): a 32-bit
 * gather at the byte (the array has 3 bytes of padding), the low byte
 * sign-extended. */
DI vi gather_i8_masked(const int8_t *p, vi idx, vm need) {
    vi w = _mm512_mask_i32gather_epi32(_mm512_setzero_si512(), need, idx, (const void *)p, 1);
    return _mm512_srai_epi32(_mm512_slli_epi32(w, 24), 24);
}

/* Rows of 8 floats at base + offs[l] (one per lane), transposed: o[e] holds
 * element e of every lane. For each half of the rows (elements 0–3, 4–7)
 * four vectors take the 128-bit pieces of lanes k, k+4, k+8, k+12 (load-
 * port work), then one in-lane 4×4 transpose leaves every lane in order:
 * 32 loads and 16 shuffles for 16 rows, against 128 gathered elements. */
DI void load_rows8(const float *base, vi offs_v, vf o[8]) {
    _Alignas(64) int32_t offs[16];
    _mm512_store_si512((void *)offs, offs_v);
    for (int h = 0; h < 2; h++) {
        vf r[4];
        for (int k = 0; k < 4; k++) {
            vf v = _mm512_castps128_ps512(_mm_loadu_ps(base + offs[k] + 4 * h));
            v = _mm512_insertf32x4(v, _mm_loadu_ps(base + offs[k + 4] + 4 * h), 1);
            v = _mm512_insertf32x4(v, _mm_loadu_ps(base + offs[k + 8] + 4 * h), 2);
            r[k] = _mm512_insertf32x4(v, _mm_loadu_ps(base + offs[k + 12] + 4 * h), 3);
        }
        vf t0 = _mm512_unpacklo_ps(r[0], r[1]), t1 = _mm512_unpackhi_ps(r[0], r[1]);
        vf t2 = _mm512_unpacklo_ps(r[2], r[3]), t3 = _mm512_unpackhi_ps(r[2], r[3]);
        o[4 * h + 0] = _mm512_shuffle_ps(t0, t2, 0x44);
        o[4 * h + 1] = _mm512_shuffle_ps(t0, t2, 0xEE);
        o[4 * h + 2] = _mm512_shuffle_ps(t1, t3, 0x44);
        o[4 * h + 3] = _mm512_shuffle_ps(t1, t3, 0xEE);
    }
}

/* Ray-list refill: the lanes of `fill` take consecutive list entries in
 * lane order, i.e. an expand; rank[l] = how many lanes of fill lie below l. */
DI vi lane_ranks(vm fill) {
    return _mm512_maskz_expand_epi32(fill, _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15));
}
DI vf f_pick(vf src, vm fill, const float *p, vi rank) {
    (void)rank;
    return _mm512_mask_expand_ps(src, fill, _mm512_loadu_ps(p));
}

/* Loads and plain float gathers (the technique hooks' cache volumes). */
DI vf f_load(const float *p) { return _mm512_loadu_ps(p); }
DI vf gather_f32(const float *p, vi idx) { return _mm512_i32gather_ps(idx, p, 4); }
DI vf gather_f32_masked(const float *p, vi idx, vm m) {
    return _mm512_mask_i32gather_ps(_mm512_setzero_ps(), m, idx, p, 4);
}
/* bfloat16 values p[idx] as floats (see lanes_avx2.h). */
DI vf gather_bf16_masked(const uint16_t *p, vi idx, vm m) {
    vi w = _mm512_mask_i32gather_epi32(_mm512_setzero_si512(), m, idx, p, 2);
    return _mm512_castsi512_ps(_mm512_slli_epi32(w, 16));
}

#endif
