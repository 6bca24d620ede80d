/*
 * techniques/ambient/tube_avx512.c — the tube kernels (tube_simd_impl.h) on
 * 16 nodes at a time with AVX-512F: the lane operations for __m512 and
 * mask registers, the reads in their AVX-512 form, and the vacuum chains.
 * Compiled with target attributes and chosen at run time when the CPU has
 * AVX-512F; tube_avx2.c is used otherwise.
 *
 * Why a second width: the node update is bound by instruction throughput
 * (measured: ≈ 10 ns per node with AVX2 on a grid that fits in L2 as on one
 * that does not), and 16 lanes with mask registers (no blend instructions,
 * 32 registers, no spills) do the same work in fewer instructions.
 *
 * BIT-IDENTICAL to the scalar path and to tube_avx2.c (target "avx512f"
 * with -ffp-contract=off, the ISO C default: see tube_simd_impl.h).
 */
#include "core/simd.h"
#include "tube_simd.h"

#if VOLUX_X86_GNUC
#include <math.h>

#define TUBE_W 16
#define TUBE_VACUUM_CHAINS 1
#define TUBE_TARGET __attribute__((target("avx512f")))
#define TI static inline __attribute__((always_inline, target("avx512f")))

typedef __m512 vf;
typedef __m512i vi;
typedef __mmask16 vm;
#define TUBE_MM(op) _mm512_##op
#define TUBE_CMP(a, b, p) _mm512_cmp_ps_mask(a, b, p)

#include "tube_simd_impl.h"

TI vf f_abs(vf a) { return _mm512_abs_ps(a); }
TI vm f_sign(vf a) { return _mm512_cmplt_epi32_mask(_mm512_castps_si512(a), _mm512_setzero_si512()); }
TI vf f_set_sign(vf a, vm m) {
    vi x = _mm512_castps_si512(a);
    return _mm512_castsi512_ps(_mm512_mask_or_epi32(x, m, x, _mm512_set1_epi32((int)0x80000000u)));
}
TI vf sel(vm m, vf a, vf b) { return _mm512_mask_blend_ps(m, b, a); }
static const int lanes16[16] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15};
TI vi lane_ids(void) { return _mm512_loadu_si512((const void *)lanes16); }
TI int i_lane0(vi a) { return _mm_cvtsi128_si32(_mm512_castsi512_si128(a)); }
TI vm m_first(int n) { return n >= 16 ? (vm)0xffff : (vm)((1u << n) - 1u); }
TI vm m_and(vm a, vm b) { return a & b; }
TI vm m_or(vm a, vm b) { return a | b; }
TI vm m_andnot(vm a, vm b) { return (vm)(~a & b); }
TI int m_any(vm m) { return m != 0; }
TI int m_covers(vm m, vm valid) { return (m & valid) == valid; }

TI vf f_load_first(const float *p, int n) { return _mm512_maskz_loadu_ps(m_first(n), p); }
TI void f_store_first(float *p, vf v, int n) { _mm512_mask_storeu_ps(p, m_first(n), v); }
TI vf f_load_masked(const float *p, vm k, int full) {
    (void)full;
    return _mm512_maskz_loadu_ps(k, p);
}
TI void f_store_masked(float *p, vf v, vm k, int full) {
    (void)full;
    _mm512_mask_storeu_ps(p, k, v);
}

/* consecutive cell indices (lane 0's + lane): each corner is one plain
 * load (tube_avx2.c), the common case of directional sweeps */
TI int consecutive(vi base) {
    vi b0 = _mm512_broadcastd_epi32(_mm512_castsi512_si128(base));
    return _mm512_cmpeq_epi32_mask(base, _mm512_add_epi32(b0, lane_ids())) == 0xffff;
}

/* Row windows. When the wanted lanes' cells lie on one grid row (the same
 * y and z) and the x corners they read span at most 32 nodes [x0, x0 + n),
 * a corner row is two masked loads of exactly those n nodes, and every
 * lane picks its lower and upper x corner with a two-source permute: the
 * values the gathers return, for 2 loads + 2 permutes per row instead of
 * 2 gathers (the gathers were about half of a point sweep; the lanes of a
 * run along x share a row in ≈ 80 % of the blocks on aneurism, against
 * 13–43 % with consecutive indices, which stay the first choice). Every loaded node lies on a row some
 * lane reads, between two nodes lanes read: the Chebyshev distance to the
 * light is convex along the row, so it is in a finished shell too (the
 * strict-read guarantee of tube_simd.h holds). */
typedef struct window16 {
    vi i0, i1;    /* lane → window position of its lower / upper x corner */
    vm lo, hi;    /* load masks of the window's two halves             */
    ptrdiff_t at; /* grid index of the window's first node              */
} window16;

/* The lanes in `mask` read x corners c[0] and c[0] + ox: 1 if they share
 * one row and fit in a window (filled in), else 0. */
TI int row_window(const lane_grid *g, const vi c[3], vi ox, vm mask, window16 *w) {
    const vi first = _mm512_set1_epi32(__builtin_ctz(mask));
    vi x0 = _mm512_permutexvar_epi32(first, c[0]), y0 = _mm512_permutexvar_epi32(first, c[1]),
       z0 = _mm512_permutexvar_epi32(first, c[2]);
    if (_mm512_mask_cmpneq_epi32_mask(mask, c[1], y0) | _mm512_mask_cmpneq_epi32_mask(mask, c[2], z0) |
        _mm512_mask_cmplt_epi32_mask(mask, c[0], x0))
        return 0;
    w->i0 = _mm512_sub_epi32(c[0], x0);
    w->i1 = _mm512_add_epi32(w->i0, ox);
    /* the window's end: the last lane's upper corner when the lanes run
     * along x in order (a run of nodes), else the largest */
    vi end = _mm512_permutexvar_epi32(_mm512_set1_epi32(31 - __builtin_clz(mask)), w->i1);
    if (_mm512_mask_cmpgt_epi32_mask(mask, w->i1, end)) end = _mm512_set1_epi32(_mm512_mask_reduce_max_epi32(mask, w->i1));
    int n = i_lane0(end) + 1;
    if (n > 32) return 0;
    w->lo = n >= 16 ? (vm)0xffff : (vm)((1u << n) - 1u);
    w->hi = n > 16 ? (vm)((1u << (n - 16)) - 1u) : 0;
    w->at = (ptrdiff_t)i_lane0(z0) * g->nxy + (ptrdiff_t)i_lane0(y0) * g->nx + i_lane0(x0);
    return 1;
}

/* One corner row of a window, `off` nodes from its first row: each lane's
 * lower (*a0) and upper (*a1) x corner. */
TI void window_row(const float *v, const window16 *w, ptrdiff_t off, vf *a0, vf *a1) {
    const float *r = v + w->at + off;
    vf lo = _mm512_maskz_loadu_ps(w->lo, r), hi = _mm512_maskz_loadu_ps(w->hi, r + 16);
    *a0 = _mm512_permutex2var_ps(lo, w->i0, hi);
    *a1 = _mm512_permutex2var_ps(lo, w->i1, hi);
}

/* The 8 corners (trilerp's order) from a window whose y and z corner rows
 * are oy and oz nodes from its first row (0: the lanes' upper corner is
 * the lower). */
TI void window_corners(const float *v, const window16 *w, ptrdiff_t oy, ptrdiff_t oz, vf a[8]) {
    window_row(v, w, 0, &a[0], &a[1]);
    window_row(v, w, oy, &a[2], &a[3]);
    window_row(v, w, oz, &a[4], &a[5]);
    window_row(v, w, oy + oz, &a[6], &a[7]);
}

/* κ pairs: one broadcast pair when every lane has lane 0's j — a block of
 * vacuum (ρ = 0, j = 0) or of one medium — else two gathers: the same
 * values. */
TI void kappa_pair(const float *kappa, vi j, vm k, vf *k0, vf *k1) {
    int j0 = i_lane0(j);
    if ((_mm512_cmpeq_epi32_mask(j, _mm512_set1_epi32(j0)) & k) == k) {
        *k0 = _mm512_set1_ps(kappa[j0]);
        *k1 = _mm512_set1_ps(kappa[j0 + 1]);
        return;
    }
    *k0 = _mm512_mask_i32gather_ps(_mm512_setzero_ps(), k, j, kappa, 4);
    *k1 = _mm512_mask_i32gather_ps(_mm512_setzero_ps(), k, _mm512_add_epi32(j, _mm512_set1_epi32(1)), kappa, 4);
}

/* vacuum chains (tube.h: tube_geometry) */
TI vm corners_zero(const vf a[8]) {
#define I_(q) _mm512_castps_si512(a[q])
    /* 0xfe: a | b | c */
    vi o = _mm512_ternarylogic_epi32(I_(0), I_(1), I_(2), 0xfe);
    o = _mm512_ternarylogic_epi32(o, I_(3), I_(4), 0xfe);
    o = _mm512_ternarylogic_epi32(o, I_(5), I_(6), 0xfe);
    return _mm512_testn_epi32_mask(_mm512_or_si512(o, I_(7)), _mm512_or_si512(o, I_(7)));
#undef I_
}

TI void vac_record(unsigned char *vac, ptrdiff_t stride, int *bad, vf res, vm ok, vm valid) {
    vm z = _mm512_cmpeq_epi32_mask(_mm512_castps_si512(res), _mm512_setzero_si512()) & valid;
    if (z & ~ok) __atomic_store_n(bad, 1, __ATOMIC_RELAXED);
    if (stride == 1) {
        _mm512_mask_cvtepi32_storeu_epi8(vac, valid, _mm512_maskz_mov_epi32(z, _mm512_set1_epi32(1)));
        return;
    }
    for (int l = 0; l < 16 && ((valid >> l) & 1); l++) vac[(ptrdiff_t)l * stride] = (z >> l) & 1;
}

TI int vac_skip(const unsigned char *vac, float *out, vm valid) {
    vi v = _mm512_cvtepu8_epi32(_mm_loadu_si128((const __m128i *)(const void *)vac));
    if ((_mm512_cmpeq_epi32_mask(v, _mm512_set1_epi32(1)) & valid) != valid) return 0;
    _mm512_mask_storeu_ps(out, valid, _mm512_setzero_ps());
    return 1;
}

/* the clamped read: row loads for consecutive cells, else a row window,
 * else gathers */
TI vf sample_clamped(const float *v, const lane_grid *g, const vf p[3]) {
    vf f[3], a[8];
    vi c[3];
    clamped_cell(g, p, c, f);
    const vi one = i_set(1), b = cell_index(g, c);
    window16 w;
    if (consecutive(b)) {
        row_corners(v + i_lane0(b), g->nx, g->nxy, a);
        return trilerp(a, f);
    }
    if (row_window(g, c, one, 0xffff, &w)) {
        window_corners(v, &w, g->nx, g->nxy, a);
        return trilerp(a, f);
    }
    const vi by = i_add(b, g->sy), bz = i_add(b, g->sz), byz = i_add(by, g->sz);
    const vi idx[8] = {b, i_add(b, one), by, i_add(by, one), bz, i_add(bz, one), byz, i_add(byz, one)};
    for (int q = 0; q < 8; q++) a[q] = _mm512_i32gather_ps(idx[q], v, 4);
    return trilerp(a, f);
}

/* the strict corners; a window needs the upper y (z) corner to be read by
 * all wanted lanes or by none */
TI vf strict_at(const float *v, const lane_grid *g, const vi c[3], const vf f[3], vm mask, vm *zc) {
    vm up[3];
    for (int a = 0; a < 3; a++) up[a] = f_gt(f[a], f_zero()) & mask;
    const vi zi = _mm512_setzero_si512();
    vi ox = _mm512_mask_mov_epi32(zi, up[0], i_set(1));
    window16 w;
    vf a[8];
    vi b = cell_index(g, c);
    int rows = (up[1] == 0 || up[1] == mask) && (up[2] == 0 || up[2] == mask);
    /* consecutive cells, every lane wanted, lane 15's upper x corner read:
     * every loaded element is a corner some lane reads (a lane whose x
     * fraction is 0 gets lane + 1's lower corner as its upper one, with
     * weight 0: the same result) */
    if (rows && mask == 0xffff && (up[0] & 0x8000) && consecutive(b)) {
        row_corners(v + i_lane0(b), up[1] ? g->nx : 0, up[2] ? g->nxy : 0, a);
    } else if (rows && row_window(g, c, ox, mask, &w)) {
        window_corners(v, &w, up[1] ? g->nx : 0, up[2] ? g->nxy : 0, a);
    } else {
        vi oy = _mm512_mask_mov_epi32(zi, up[1], g->sy), oz = _mm512_mask_mov_epi32(zi, up[2], g->sz);
        vi by = i_add(b, oy), bz = i_add(b, oz), byz = i_add(by, oz);
        const vi idx[8] = {b, i_add(b, ox), by, i_add(by, ox), bz, i_add(bz, ox), byz, i_add(byz, ox)};
        for (int q = 0; q < 8; q++) a[q] = _mm512_mask_i32gather_ps(f_zero(), mask, idx[q], v, 4);
    }
    if (zc) {
        /* the true corners only: an upper x corner with fraction 0 may be
         * the next lane's node (consecutive rows) and is not read */
        vf t[8];
        for (int q = 0; q < 8; q++) t[q] = (q & 1) ? _mm512_maskz_mov_ps(up[0], a[q]) : a[q];
        *zc = corners_zero(t);
    }
    return trilerp(a, f);
}

const tube_kernels *tube_kernels_avx512(void) { return volux_cpu_has_avx512f() ? &kernels : NULL; }

#else /* no AVX-512 on this target */

const tube_kernels *tube_kernels_avx512(void) { return NULL; }

#endif
