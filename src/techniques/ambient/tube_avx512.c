/*
 * techniques/ambient/tube_avx512.c — tube_avx2.c's kernels on 16 nodes at
 * a time with AVX-512F (see tube_simd.h). Compiled with target attributes
 * and chosen at run time when the CPU has AVX-512F; tube_avx2.c is used
 * otherwise.
 *
 * Why a second width: the node update is bound by instruction throughput
 * (measured: ≈ 10 ns per node with AVX2 on a grid that fits in L2 as on one
 * that does not), and 16 lanes with mask registers (no blend instructions,
 * 32 registers, no spills) do the same work in fewer instructions.
 *
 * BIT-IDENTICAL to the scalar path and to tube_avx2.c, for the same reason
 * as that file: the same operations in the same order, unfused (target
 * "avx512f" with -ffp-contract=off, the ISO C default), IEEE sqrt and
 * division, branches as masked selects. Keep the three in step
 * (tests/physics/test_tube_marching.c compares them bit for bit).
 */
#include "tube_simd.h"

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#include <math.h>

int tube_avx512_available(void) {
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx512f") != 0;
}

#define A5 __attribute__((target("avx512f")))
#define A5I static inline __attribute__((always_inline, target("avx512f")))

typedef __mmask16 m16;

/* a + (b − a)·f, unfused */
A5I __m512 lerp(__m512 a, __m512 b, __m512 f) { return _mm512_add_ps(a, _mm512_mul_ps(_mm512_sub_ps(b, a), f)); }

/* a where m, else b */
A5I __m512 sel(m16 m, __m512 a, __m512 b) { return _mm512_mask_blend_ps(m, b, a); }

typedef struct grid16 {
    __m512 lo[3], inv_h[3], m[3];
    __m512i imax[3], sy, sz;
    int nx, nxy;
} grid16;

A5I void grid_consts(const tube_lanes *t, grid16 *g) {
    for (int a = 0; a < 3; a++) {
        g->lo[a] = _mm512_set1_ps(t->lo[a]);
        g->inv_h[a] = _mm512_set1_ps(t->inv_h[a]);
        g->m[a] = _mm512_set1_ps((float)(t->dims[a] - 1));
        g->imax[a] = _mm512_set1_epi32(t->dims[a] - 2);
    }
    g->nx = t->dims[0], g->nxy = t->dims[0] * t->dims[1];
    g->sy = _mm512_set1_epi32(g->nx);
    g->sz = _mm512_set1_epi32(g->nxy);
}

/* clamped index-space position (see tube_avx2.c: to_index) */
A5I void to_index(const grid16 *g, const __m512 p[3], __m512 u[3]) {
    const __m512 zero = _mm512_setzero_ps();
    for (int a = 0; a < 3; a++)
        u[a] = _mm512_min_ps(_mm512_max_ps(_mm512_mul_ps(_mm512_sub_ps(p[a], g->lo[a]), g->inv_h[a]), zero), g->m[a]);
}

A5I __m512i cell_index(const grid16 *g, const __m512i c[3]) {
    return _mm512_add_epi32(_mm512_add_epi32(_mm512_mullo_epi32(c[2], g->sz), _mm512_mullo_epi32(c[1], g->sy)), c[0]);
}

static const int lanes16[16] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15};

A5I __m512i lane_ids(void) { return _mm512_loadu_si512((const void *)lanes16); }

/* consecutive cell indices (lane 0's + lane): each corner is one plain
 * load (tube_avx2.c), the common case of directional sweeps */
A5I int consecutive(__m512i base) {
    __m512i b0 = _mm512_broadcastd_epi32(_mm512_castsi512_si128(base));
    return _mm512_cmpeq_epi32_mask(base, _mm512_add_epi32(b0, lane_ids())) == 0xffff;
}

/* The 8 corners (trilerp's order) of consecutive cells from r, y and z
 * corner rows oy and oz nodes on. */
A5I void row_corners(const float *r, ptrdiff_t oy, ptrdiff_t oz, __m512 a[8]) {
    const ptrdiff_t o[4] = {0, oy, oz, oy + oz};
    for (int q = 0; q < 4; q++) a[2 * q] = _mm512_loadu_ps(r + o[q]), a[2 * q + 1] = _mm512_loadu_ps(r + o[q] + 1);
}

A5I __m512 trilerp(__m512 a000, __m512 a100, __m512 a010, __m512 a110, __m512 a001, __m512 a101, __m512 a011,
                   __m512 a111, const __m512 f[3]) {
    __m512 c00 = lerp(a000, a100, f[0]), c10 = lerp(a010, a110, f[0]);
    __m512 c01 = lerp(a001, a101, f[0]), c11 = lerp(a011, a111, f[0]);
    __m512 c0 = lerp(c00, c10, f[1]), c1 = lerp(c01, c11, f[1]);
    return lerp(c0, c1, f[2]);
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
    __m512i i0, i1; /* lane → window position of its lower / upper x corner */
    m16 lo, hi;     /* load masks of the window's two halves             */
    ptrdiff_t at;   /* grid index of the window's first node              */
} window16;

/* The lanes in `mask` read x corners c[0] and c[0] + ox: 1 if they share
 * one row and fit in a window (filled in), else 0. */
A5I int lane0(__m512i v) { return _mm_cvtsi128_si32(_mm512_castsi512_si128(v)); }

A5I int row_window(const grid16 *g, const __m512i c[3], __m512i ox, m16 mask, window16 *w) {
    const __m512i first = _mm512_set1_epi32(__builtin_ctz(mask));
    __m512i x0 = _mm512_permutexvar_epi32(first, c[0]), y0 = _mm512_permutexvar_epi32(first, c[1]),
            z0 = _mm512_permutexvar_epi32(first, c[2]);
    if (_mm512_mask_cmpneq_epi32_mask(mask, c[1], y0) | _mm512_mask_cmpneq_epi32_mask(mask, c[2], z0) |
        _mm512_mask_cmplt_epi32_mask(mask, c[0], x0))
        return 0;
    w->i0 = _mm512_sub_epi32(c[0], x0);
    w->i1 = _mm512_add_epi32(w->i0, ox);
    /* the window's end: the last lane's upper corner when the lanes run
     * along x in order (a run of nodes), else the largest */
    __m512i end = _mm512_permutexvar_epi32(_mm512_set1_epi32(31 - __builtin_clz(mask)), w->i1);
    if (_mm512_mask_cmpgt_epi32_mask(mask, w->i1, end)) end = _mm512_set1_epi32(_mm512_mask_reduce_max_epi32(mask, w->i1));
    int n = lane0(end) + 1;
    if (n > 32) return 0;
    w->lo = n >= 16 ? (m16)0xffff : (m16)((1u << n) - 1u);
    w->hi = n > 16 ? (m16)((1u << (n - 16)) - 1u) : 0;
    w->at = (ptrdiff_t)lane0(z0) * g->nxy + (ptrdiff_t)lane0(y0) * g->nx + lane0(x0);
    return 1;
}

/* One corner row of a window, `off` nodes from its first row: each lane's
 * lower (*a0) and upper (*a1) x corner. */
A5I void window_row(const float *v, const window16 *w, ptrdiff_t off, __m512 *a0, __m512 *a1) {
    const float *r = v + w->at + off;
    __m512 lo = _mm512_maskz_loadu_ps(w->lo, r), hi = _mm512_maskz_loadu_ps(w->hi, r + 16);
    *a0 = _mm512_permutex2var_ps(lo, w->i0, hi);
    *a1 = _mm512_permutex2var_ps(lo, w->i1, hi);
}

/* The 8 corners (trilerp's order) from a window whose y and z corner rows
 * are oy and oz nodes from its first row (0: the lanes' upper corner is
 * the lower). */
A5I void window_corners(const float *v, const window16 *w, ptrdiff_t oy, ptrdiff_t oz, __m512 a[8]) {
    window_row(v, w, 0, &a[0], &a[1]);
    window_row(v, w, oy, &a[2], &a[3]);
    window_row(v, w, oz, &a[4], &a[5]);
    window_row(v, w, oy + oz, &a[6], &a[7]);
}

A5I __m512 trilerp8(const __m512 a[8], const __m512 f[3]) {
    return trilerp(a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], f);
}

/* Lanes whose 8 corners are all +0 (bit pattern 0): the read of a vacuum
 * chain (tube.h: tube_geometry). */
A5I m16 corners_zero(const __m512 a[8]) {
#define I_(q) _mm512_castps_si512(a[q])
    /* 0xfe: a | b | c */
    __m512i o = _mm512_ternarylogic_epi32(I_(0), I_(1), I_(2), 0xfe);
    o = _mm512_ternarylogic_epi32(o, I_(3), I_(4), 0xfe);
    o = _mm512_ternarylogic_epi32(o, I_(5), I_(6), 0xfe);
    return _mm512_testn_epi32_mask(_mm512_or_si512(o, I_(7)), _mm512_or_si512(o, I_(7)));
#undef I_
}


A5I __m512 sample_clamped(const float *v, const grid16 *g, const __m512 p[3]) {
    __m512 u[3], f[3];
    __m512i c[3];
    to_index(g, p, u);
    for (int a = 0; a < 3; a++) {
        c[a] = _mm512_min_epi32(_mm512_cvttps_epi32(u[a]), g->imax[a]);
        f[a] = _mm512_sub_ps(u[a], _mm512_cvtepi32_ps(c[a]));
    }
    const __m512i one = _mm512_set1_epi32(1);
    __m512i b = cell_index(g, c);
    window16 w;
    __m512 a[8];
    if (consecutive(b)) {
        row_corners(v + lane0(b), g->nx, g->nxy, a);
        return trilerp8(a, f);
    }
    if (row_window(g, c, one, 0xffff, &w)) {
        window_corners(v, &w, g->nx, g->nxy, a);
        return trilerp8(a, f);
    }
    __m512i by = _mm512_add_epi32(b, g->sy), bz = _mm512_add_epi32(b, g->sz), byz = _mm512_add_epi32(by, g->sz);
#define G_(idx) _mm512_i32gather_ps((idx), v, 4)
    return trilerp(G_(b), G_(_mm512_add_epi32(b, one)), G_(by), G_(_mm512_add_epi32(by, one)), G_(bz),
                   G_(_mm512_add_epi32(bz, one)), G_(byz), G_(_mm512_add_epi32(byz, one)), f);
#undef G_
}

A5I void strict_cell16(const grid16 *g, const __m512 p[3], __m512i c[3], __m512 f[3]) {
    __m512 u[3];
    to_index(g, p, u);
    for (int a = 0; a < 3; a++) {
        c[a] = _mm512_cvttps_epi32(u[a]);
        f[a] = _mm512_sub_ps(u[a], _mm512_cvtepi32_ps(c[a]));
    }
}

/* strict read for the lanes in `mask` (others: any value, no load of
 * theirs); see tube_avx2.c. A window needs the upper y (z) corner to be
 * read by all wanted lanes or by none. *zc (if not NULL): the lanes whose
 * corners are all +0. */
A5I __m512 strict_at16(const float *v, const grid16 *g, const __m512i c[3], const __m512 f[3], m16 mask, m16 *zc) {
    const __m512 zero = _mm512_setzero_ps();
    m16 up[3];
    for (int a = 0; a < 3; a++) up[a] = _mm512_cmp_ps_mask(f[a], zero, _CMP_GT_OQ) & mask;
    const __m512i zi = _mm512_setzero_si512();
    __m512i ox = _mm512_mask_mov_epi32(zi, up[0], _mm512_set1_epi32(1));
    window16 w;
    __m512 a[8];
    __m512i b = cell_index(g, c);
    int rows = (up[1] == 0 || up[1] == mask) && (up[2] == 0 || up[2] == mask);
    /* consecutive cells, every lane wanted, lane 15's upper x corner read:
     * every loaded element is a corner some lane reads (a lane whose x
     * fraction is 0 gets lane + 1's lower corner as its upper one, with
     * weight 0: the same result) */
    if (rows && mask == 0xffff && (up[0] & 0x8000) && consecutive(b)) {
        row_corners(v + lane0(b), up[1] ? g->nx : 0, up[2] ? g->nxy : 0, a);
    } else if (rows && row_window(g, c, ox, mask, &w)) {
        window_corners(v, &w, up[1] ? g->nx : 0, up[2] ? g->nxy : 0, a);
    } else {
        __m512i oy = _mm512_mask_mov_epi32(zi, up[1], g->sy), oz = _mm512_mask_mov_epi32(zi, up[2], g->sz);
        __m512i by = _mm512_add_epi32(b, oy), bz = _mm512_add_epi32(b, oz), byz = _mm512_add_epi32(by, oz);
        __m512i idx[8] = {b,  _mm512_add_epi32(b, ox),  by,  _mm512_add_epi32(by, ox),
                          bz, _mm512_add_epi32(bz, ox), byz, _mm512_add_epi32(byz, ox)};
        for (int q = 0; q < 8; q++) a[q] = _mm512_mask_i32gather_ps(zero, mask, idx[q], v, 4);
    }
    if (zc) {
        /* the true corners only: an upper x corner with fraction 0 may be
         * the next lane's node (consecutive rows) and is not read */
        __m512 t[8];
        for (int q = 0; q < 8; q++) t[q] = (q & 1) ? _mm512_maskz_mov_ps(up[0], a[q]) : a[q];
        *zc = corners_zero(t);
    }
    return trilerp8(a, f);
}

/* κ[j] and κ[j + 1] for the lanes in k (k includes lane 0; others: any
 * value). One broadcast pair when every lane has lane 0's j — a block of
 * vacuum (ρ = 0, j = 0) or of one medium — else two gathers: the same
 * values. */
A5I void kappa_pair(const float *kappa, __m512i j, m16 k, __m512 *k0, __m512 *k1) {
    int j0 = lane0(j);
    if ((_mm512_cmpeq_epi32_mask(j, _mm512_set1_epi32(j0)) & k) == k) {
        *k0 = _mm512_set1_ps(kappa[j0]);
        *k1 = _mm512_set1_ps(kappa[j0 + 1]);
        return;
    }
    *k0 = _mm512_mask_i32gather_ps(_mm512_setzero_ps(), k, j, kappa, 4);
    *k1 = _mm512_mask_i32gather_ps(_mm512_setzero_ps(), k, _mm512_add_epi32(j, _mm512_set1_epi32(1)), kappa, 4);
}

A5I __m512 kappa16(const tube_lanes *t, __m512 rho) {
    const __m512 zero = _mm512_setzero_ps(), last = _mm512_set1_ps((float)(t->n_sigma - 1));
    __m512 u = _mm512_div_ps(_mm512_mul_ps(rho, last), _mm512_set1_ps(t->sigma_max));
    m16 above = _mm512_cmp_ps_mask(u, last, _CMP_GE_OQ);
    __m512 uc = _mm512_min_ps(_mm512_max_ps(u, zero), last);
    __m512i i = _mm512_min_epi32(_mm512_cvttps_epi32(uc), _mm512_set1_epi32(t->n_sigma - 2));
    __m512 f = _mm512_sub_ps(uc, _mm512_cvtepi32_ps(i));
    __m512 k0, k1;
    kappa_pair(t->kappa, i, 0xffff, &k0, &k1);
    return sel(above, _mm512_set1_ps(t->kappa[t->n_sigma - 1]), lerp(k0, k1, f));
}

A5I void store_ps(float *p, ptrdiff_t stride, __m512 v, int n) {
    if (stride == 1) {
        _mm512_mask_storeu_ps(p, (m16)((1u << n) - 1u), v);
        return;
    }
    float tmp[16];
    _mm512_storeu_ps(tmp, v);
    for (int l = 0; l < n; l++) p[(ptrdiff_t)l * stride] = tmp[l];
}

A5I __m512 load_ps(const float *p, ptrdiff_t stride, int n) {
    if (stride == 1) return _mm512_maskz_loadu_ps((m16)((1u << n) - 1u), p);
    float tmp[16] = {0};
    for (int l = 0; l < n; l++) tmp[l] = p[(ptrdiff_t)l * stride];
    return _mm512_loadu_ps(tmp);
}

/* 1 when every node in `valid` is provably more than two steps (2s) from
 * its chain start, without computing the box exit: along axis a the exit
 * distance (bound_a − x_a)/b_a, b = −ω, |b_a| ≤ 1, is at least
 * |bound_a − x_a|, so δ = min(dl, exit) ≥ min(dl, min_a |bound_a − x_a|).
 * The margin (2.002 s) exceeds the rounding of the exact computation by
 * far: those nodes take the deep branch either way, bit-identical. Saves
 * the three divisions of the box exit for most blocks of a march. */
A5I int beyond_two_steps(const tube_lanes *t, const __m512 x[3], const __m512 w[3], __m512 dl, m16 valid) {
    const __m512 zero = _mm512_setzero_ps(), inf = _mm512_set1_ps(INFINITY);
    __m512 lb = dl;
    for (int a = 0; a < 3; a++) {
        m16 to_hi = _mm512_cmp_ps_mask(w[a], zero, _CMP_LT_OQ), to_lo = _mm512_cmp_ps_mask(w[a], zero, _CMP_GT_OQ);
        __m512 gap = sel(to_hi, _mm512_sub_ps(_mm512_set1_ps(t->hi[a]), x[a]),
                         sel(to_lo, _mm512_sub_ps(x[a], _mm512_set1_ps(t->lo[a])), inf));
        lb = _mm512_min_ps(lb, gap);
    }
    return (_mm512_cmp_ps_mask(lb, _mm512_set1_ps(2.002f * t->s), _CMP_GT_OQ) & valid) == valid;
}

/* A march: the vacuum-chain bytes (tube.h: tube_geometry) of a block of
 * nodes (vac[l·stride] for lane l), D = res. `ok`: the lanes whose D is +0
 * for every κ with κ(0) = +0 if every node they read is; a +0 elsewhere
 * breaks the invariant (*bad). */
A5I void vac_record(unsigned char *vac, ptrdiff_t stride, int *bad, __m512 res, m16 ok, m16 valid) {
    m16 z = _mm512_cmpeq_epi32_mask(_mm512_castps_si512(res), _mm512_setzero_si512()) & valid;
    if (z & ~ok) __atomic_store_n(bad, 1, __ATOMIC_RELAXED);
    if (stride == 1) {
        _mm512_mask_cvtepi32_storeu_epi8(vac, valid, _mm512_maskz_mov_epi32(z, _mm512_set1_epi32(1)));
        return;
    }
    for (int l = 0; l < 16 && ((valid >> l) & 1); l++) vac[(ptrdiff_t)l * stride] = (z >> l) & 1;
}

/* A re-sum: 1 when every node of the block in `valid` (consecutive in
 * memory) is a vacuum chain; their D (+0) is then stored to out. */
A5I int vac_skip(const unsigned char *vac, float *out, m16 valid) {
    __m512i v = _mm512_cvtepu8_epi32(_mm_loadu_si128((const __m128i *)(const void *)vac));
    if ((_mm512_cmpeq_epi32_mask(v, _mm512_set1_epi32(1)) & valid) != valid) return 0;
    _mm512_mask_storeu_ps(out, valid, _mm512_setzero_ps());
    return 1;
}

A5I void nodes_body(const tube_lanes *t, int i, int j, int k, int axis, int count, size_t rec0, ptrdiff_t rec_stride) {
    const int nx = t->dims[0], ny = t->dims[1];
    grid16 g;
    grid_consts(t, &g);
    const __m512 zero = _mm512_setzero_ps(), inf = _mm512_set1_ps(INFINITY);
    const float s = t->s, half = 0.5f * s;
    const __m512 vs = _mm512_set1_ps(s), vhalf = _mm512_set1_ps(half), s_tol = _mm512_set1_ps(s * 1.0001f);
    const __m512 inv_r = _mm512_set1_ps(t->inv_r), neg_s = _mm512_set1_ps(-s), neg_half = _mm512_set1_ps(-half);
    const __m512 m_half = _mm512_set1_ps(-0.5f), p_half = _mm512_set1_ps(0.5f);
    const __m512i lane = lane_ids();
    const int start[3] = {i, j, k};
    const ptrdiff_t stride = axis == 0 ? 1 : axis == 1 ? (ptrdiff_t)nx : (ptrdiff_t)nx * ny;
    const size_t at0 = ((size_t)k * (size_t)ny + (size_t)j) * (size_t)nx + (size_t)i;
    float *out = t->D + at0;
    const __m512 hv[3] = {_mm512_set1_ps(t->h[0]), _mm512_set1_ps(t->h[1]), _mm512_set1_ps(t->h[2])};
    /* stages over chunks, as in tube_avx2.c */
    enum { CHUNK = 64, BLOCKS = CHUNK / 16 };
    __m512 c_w[3][BLOCKS], c_m[3][BLOCKS], c_y[3][BLOCKS], c_delta[BLOCKS], c_arg[BLOCKS], c_k[BLOCKS];
    const int record_vac = t->vac && !t->resum, skip_vac = t->vac && t->resum && stride == 1;
    for (int c0 = 0; c0 < count; c0 += CHUNK) {
        int nb = (count - c0 + 15) / 16;
        if (nb > BLOCKS) nb = BLOCKS;
        /* a re-sum's blocks of vacuum chains: D = +0, nothing else */
        int skip[BLOCKS] = {0};
        for (int bi = 0; bi < nb && skip_vac; bi++) {
            int n0 = c0 + 16 * bi, left = count - n0 < 16 ? count - n0 : 16;
            skip[bi] = vac_skip(t->vac + at0 + n0, out + n0, (m16)((1u << left) - 1u));
        }
        for (int bi = 0; bi < nb; bi++)
            _mm_prefetch((const char *)(t->rho + at0 + (ptrdiff_t)(c0 + 16 * bi) * stride), _MM_HINT_T0);
        /* 1. chain geometry */
        for (int bi = 0; bi < nb; bi++) {
            if (skip[bi]) continue;
            __m512i ln = _mm512_add_epi32(_mm512_set1_epi32(c0 + 16 * bi), lane);
            __m512 x[3], w[3], dl = inf;
            m16 tiny = 0;
            for (int a = 0; a < 3; a++) {
                __m512i idx = _mm512_set1_epi32(start[a]);
                if (a == axis) idx = _mm512_add_epi32(idx, ln);
                x[a] = _mm512_add_ps(g.lo[a], _mm512_mul_ps(_mm512_cvtepi32_ps(idx), hv[a]));
            }
            if (t->positional) {
                __m512 d[3];
                for (int a = 0; a < 3; a++) d[a] = _mm512_sub_ps(x[a], _mm512_set1_ps(t->pos[a]));
                __m512 d2 = _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(d[0], d[0]), _mm512_mul_ps(d[1], d[1])),
                                          _mm512_mul_ps(d[2], d[2]));
                dl = _mm512_sqrt_ps(d2);
                tiny = _mm512_cmp_ps_mask(dl, _mm512_set1_ps(1e-20f), _CMP_LT_OQ);
                __m512 inv = _mm512_div_ps(_mm512_set1_ps(1.0f), dl);
                for (int a = 0; a < 3; a++) w[a] = _mm512_mul_ps(d[a], inv);
            } else {
                for (int a = 0; a < 3; a++) w[a] = _mm512_set1_ps(t->dir[a]);
            }
            /* A block whose nodes are all deep (more than two steps from
             * their chain start) skips the box exit: a deep node uses no
             * δ. A re-sum knows them from the sign bit of the records (see
             * tube.h), a march from a lower bound of δ. */
            int n0 = c0 + 16 * bi, left = count - n0 < 16 ? count - n0 : 16;
            m16 valid = (m16)((1u << left) - 1u);
            int skip_exit;
            if (t->resum) {
                __m512 rec = load_ps(t->g_arg + rec0 + (size_t)((ptrdiff_t)n0 * rec_stride), rec_stride, left);
                skip_exit = (_mm512_cmplt_epi32_mask(_mm512_castps_si512(rec), _mm512_setzero_si512()) & valid) == valid;
                c_arg[bi] = _mm512_castsi512_ps(_mm512_and_si512(_mm512_castps_si512(rec), _mm512_set1_epi32(0x7fffffff)));
            } else {
                /* directional nodes here are near their chain start (the
                 * others take the fast path): not worth the test */
                skip_exit = t->positional && beyond_two_steps(t, x, w, dl, valid);
            }
            __m512 delta = inf;
            if (!skip_exit) {
                __m512 texit = inf;
                for (int a = 0; a < 3; a++) {
                    __m512 b = _mm512_mul_ps(w[a], _mm512_set1_ps(-1.0f));
                    m16 pos = _mm512_cmp_ps_mask(b, zero, _CMP_GT_OQ), neg = _mm512_cmp_ps_mask(b, zero, _CMP_LT_OQ);
                    __m512 bound = sel(pos, _mm512_set1_ps(t->hi[a]), _mm512_set1_ps(t->lo[a]));
                    __m512 ta = _mm512_div_ps(_mm512_sub_ps(bound, x[a]), b);
                    ta = sel(pos | neg, ta, inf);
                    texit = sel(_mm512_cmp_ps_mask(ta, texit, _CMP_LT_OQ), ta, texit);
                }
                texit = sel(_mm512_cmp_ps_mask(texit, zero, _CMP_GT_OQ), texit, zero);
                delta = sel(_mm512_cmp_ps_mask(texit, dl, _CMP_LT_OQ), texit, dl);
            }
            delta = sel(tiny, zero, delta);
            w[0] = sel(tiny, zero, w[0]);
            w[1] = sel(tiny, zero, w[1]);
            w[2] = sel(tiny, _mm512_set1_ps(1.0f), w[2]);
            m16 near = _mm512_cmp_ps_mask(delta, s_tol, _CMP_LE_OQ);
            __m512 cA = sel(near, _mm512_mul_ps(m_half, delta), neg_half);
            for (int a = 0; a < 3; a++) {
                c_w[a][bi] = w[a];
                c_m[a][bi] = _mm512_add_ps(x[a], _mm512_mul_ps(w[a], cA));
                c_y[a][bi] = _mm512_add_ps(x[a], _mm512_mul_ps(w[a], neg_s)); /* the node s back */
            }
            c_delta[bi] = delta;
        }
        /* 2. ρ at the sphere's centre as the table argument (or recorded) */
        for (int bi = 0; bi < nb; bi++) {
            if (skip[bi]) continue;
            int n0 = c0 + 16 * bi, left = count - n0 < 16 ? count - n0 : 16;
            size_t at = rec0 + (size_t)((ptrdiff_t)n0 * rec_stride);
            if (t->resum) continue; /* loaded in stage 1 */
            __m512 m[3] = {c_m[0][bi], c_m[1][bi], c_m[2][bi]};
            __m512 rhoA = sample_clamped(t->rho, &g, m);
            m16 near = _mm512_cmp_ps_mask(c_delta[bi], s_tol, _CMP_LE_OQ);
            c_arg[bi] = sel(near, _mm512_mul_ps(_mm512_mul_ps(_mm512_mul_ps(rhoA, p_half), vs), inv_r),
                            _mm512_mul_ps(_mm512_mul_ps(rhoA, vhalf), inv_r));
            if (t->g_arg) {
                /* deep nodes (δ > 2s) carry the sign bit */
                m16 deep = _mm512_cmp_ps_mask(_mm512_sub_ps(c_delta[bi], vs), vs, _CMP_NLE_UQ) & (m16)~near;
                __m512i rec = _mm512_mask_or_epi32(_mm512_castps_si512(c_arg[bi]), deep, _mm512_castps_si512(c_arg[bi]),
                                                   _mm512_set1_epi32((int)0x80000000u));
                store_ps(t->g_arg + at, rec_stride, _mm512_castsi512_ps(rec), left);
            }
        }
        /* 3. κ */
        for (int bi = 0; bi < nb; bi++)
            if (!skip[bi]) c_k[bi] = kappa16(t, c_arg[bi]);
        /* 4. the front s back, the sum */
        for (int bi = 0; bi < nb; bi++) {
            if (skip[bi]) continue;
            int n0 = c0 + 16 * bi, left = count - n0 < 16 ? count - n0 : 16;
            m16 valid = (m16)((1u << left) - 1u);
            __m512 w[3] = {c_w[0][bi], c_w[1][bi], c_w[2][bi]}, delta = c_delta[bi], kA = c_k[bi];
            __m512 y[3] = {c_y[0][bi], c_y[1][bi], c_y[2][bi]};
            m16 near = _mm512_cmp_ps_mask(delta, s_tol, _CMP_LE_OQ);
            __m512 v_near = (near & valid) ? _mm512_mul_ps(_mm512_div_ps(delta, vs), kA) : zero;
            __m512 dy = _mm512_sub_ps(delta, vs);
            m16 mid = (m16)(~near & _mm512_cmp_ps_mask(dy, vs, _CMP_LE_OQ));
            m16 deep = (m16)(~(near | mid) & valid);
            __m512 back = zero;
            /* a march's vacuum-chain invariant (vac_record): the lanes
             * that are +0 for every κ whose reads are */
            m16 argz = _mm512_cmp_ps_mask(c_arg[bi], zero, _CMP_EQ_OQ), ok = 0;
            if (record_vac) ok = near & (argz | _mm512_cmp_ps_mask(delta, zero, _CMP_EQ_OQ));
            if (mid & valid) {
                __m512 cB = _mm512_mul_ps(m_half, dy), mB[3];
                for (int a = 0; a < 3; a++) mB[a] = _mm512_add_ps(y[a], _mm512_mul_ps(w[a], cB));
                __m512 rhoB = sample_clamped(t->rho, &g, mB);
                __m512 argB = _mm512_mul_ps(_mm512_mul_ps(rhoB, vhalf), inv_r);
                __m512 kB = kappa16(t, argB);
                if (record_vac)
                    ok |= mid & argz &
                          (_mm512_cmp_ps_mask(argB, zero, _CMP_EQ_OQ) | _mm512_cmp_ps_mask(dy, zero, _CMP_EQ_OQ));
                back = sel(mid, _mm512_mul_ps(_mm512_div_ps(dy, vs), kB), back);
            }
            if (deep) {
                __m512 f[3];
                __m512i cell[3];
                strict_cell16(&g, y, cell, f);
                m16 zc = 0;
                back = sel(deep, strict_at16(t->D, &g, cell, f, deep, record_vac && (deep & argz) ? &zc : NULL), back);
                ok |= deep & argz & zc;
            }
            __m512 res = sel(near, v_near, _mm512_add_ps(back, kA));
            store_ps(out + (ptrdiff_t)n0 * stride, stride, res, left);
            if (record_vac) vac_record(t->vac + at0 + (ptrdiff_t)n0 * stride, stride, t->vac_bad, res, ok, valid);
        }
    }
}

A5I void fast_body(const tube_fast *fr, float *out, const float *D, const float *R, float *u_io, unsigned char *vac,
                   int resum, int count) {
    const ptrdiff_t *ov = fr->off_v, *orr = fr->off_r;
    __m512 a[8], b[8];
    for (int c = 0; c < 8; c++) a[c] = _mm512_set1_ps(fr->w_v[c]), b[c] = _mm512_set1_ps(fr->w_r[c]);
    const __m512 kscale = _mm512_set1_ps(fr->kscale), last = _mm512_set1_ps(fr->last), half = _mm512_set1_ps(0.5f);
    for (int i = 0; i < count; i += 16) {
        const float *d = D + i, *r = R + i;
        /* the run's tail: masked loads touch no element past the run */
        m16 k = count - i >= 16 ? (m16)0xffff : (m16)((1u << (count - i)) - 1u);
        if (vac && resum && vac_skip(vac + i, out + i, k)) continue;
        if (resum) {
            _mm_prefetch((const char *)(u_io + i + 256), _MM_HINT_T0);
        } else {
            _mm_prefetch((const char *)(r + orr[0] + 256), _MM_HINT_T0);
            _mm_prefetch((const char *)(r + orr[2] + 256), _MM_HINT_T0);
            _mm_prefetch((const char *)(r + orr[4] + 256), _MM_HINT_T0);
            _mm_prefetch((const char *)(r + orr[6] + 256), _MM_HINT_T0);
        }
        __m512 dv[8];
        for (int c = 0; c < 8; c++) dv[c] = _mm512_maskz_loadu_ps(k, d + ov[c]);
        __m512 back = _mm512_mul_ps(a[0], dv[0]);
        for (int c = 1; c < 8; c++) back = _mm512_add_ps(back, _mm512_mul_ps(a[c], dv[c]));
        __m512 u;
        if (resum) {
            u = _mm512_maskz_loadu_ps(k, u_io + i);
        } else {
            __m512 x = _mm512_mul_ps(b[0], _mm512_maskz_loadu_ps(k, r + orr[0]));
            for (int c = 1; c < 8; c++) x = _mm512_add_ps(x, _mm512_mul_ps(b[c], _mm512_maskz_loadu_ps(k, r + orr[c])));
            x = _mm512_mul_ps(x, kscale);
            u = _mm512_mul_ps(half, _mm512_sub_ps(_mm512_add_ps(x, last), _mm512_abs_ps(_mm512_sub_ps(x, last))));
            if (u_io) _mm512_mask_storeu_ps(u_io + i, k, u);
        }
        __m512i j = _mm512_cvttps_epi32(u);
        __m512 f = _mm512_sub_ps(u, _mm512_cvtepi32_ps(j));
        __m512 k0, k1;
        kappa_pair(fr->kappa, j, k, &k0, &k1);
        __m512 res = _mm512_add_ps(_mm512_add_ps(back, k0), _mm512_mul_ps(_mm512_sub_ps(k1, k0), f));
        _mm512_mask_storeu_ps(out + i, k, res);
        if (vac && !resum) {
            /* +0 for every κ with κ(0) = +0: u = 0 and every node read +0 */
            m16 uz = _mm512_cmp_ps_mask(u, _mm512_setzero_ps(), _CMP_EQ_OQ);
            vac_record(vac + i, 1, fr->vac_bad, res, uz ? uz & corners_zero(dv) : 0, k);
        }
    }
}


A5 void tube_nodes_avx512(const tube_lanes *t, int i, int j, int k, int axis, int count, size_t rec0,
                     ptrdiff_t rec_stride) {
    nodes_body(t, i, j, k, axis, count, rec0, rec_stride);
}

/* Runs (i, j, k, axis, count) of a point sweep in one call: the records
 * are in node order. One call per batch keeps the switches between this
 * code and the scalar caller rare (measured with AVX-512: a tenth of a
 * re-sum's time went to them with one call per run). */
A5 void tube_runs_avx512(const tube_lanes *t, const int (*runs)[5], int n_runs) {
    const size_t nx = (size_t)t->dims[0], nxy = nx * (size_t)t->dims[1];
    for (int r = 0; r < n_runs; r++) {
        const int *q = runs[r];
        ptrdiff_t stride = q[3] == 0 ? 1 : q[3] == 1 ? (ptrdiff_t)nx : (ptrdiff_t)nxy;
        nodes_body(t, q[0], q[1], q[2], q[3], q[4], (size_t)q[2] * nxy + (size_t)q[1] * nx + (size_t)q[0], stride);
    }
}

A5 void tube_fast_run_avx512(const tube_fast *fr, float *out, const float *D, const float *R, float *u_io,
                          unsigned char *vac, int resum, int count) {
    fast_body(fr, out, D, R, u_io, vac, resum, count);
}

/* A directional row along x in one call: nodes [0, c0) and (c1, n) by the
 * node update, [c0, c1] by the fast path (c1 < c0: none). */
A5 void tube_row_avx512(const tube_lanes *t, const tube_fast *fr, int j, int k, int n, int c0, int c1, size_t rec0,
                   int resum) {
    const size_t at = ((size_t)k * (size_t)t->dims[1] + (size_t)j) * (size_t)t->dims[0];
    int f0 = c1 >= c0 ? c0 : n, f1 = c1 >= c0 ? c1 + 1 : n;
    if (f0 > 0) nodes_body(t, 0, j, k, 0, f0, rec0, 1);
    if (f1 > f0)
        fast_body(fr, t->D + at + f0, t->D + at + f0, t->rho + at + f0, t->g_arg ? t->g_arg + rec0 + f0 : NULL,
                  t->vac ? t->vac + at + f0 : NULL, resum, f1 - f0);
    if (n > f1) nodes_body(t, f1, j, k, 0, n - f1, rec0 + (size_t)f1, 1);
}

#else /* no AVX-512 on this target */

int tube_avx512_available(void) { return 0; }

void tube_nodes_avx512(const tube_lanes *t, int i, int j, int k, int axis, int count, size_t rec0,
                            ptrdiff_t rec_stride) {
    (void)t, (void)i, (void)j, (void)k, (void)axis, (void)count, (void)rec0, (void)rec_stride;
}

void tube_fast_run_avx512(const tube_fast *f, float *out, const float *D, const float *R, float *u_io,
                          unsigned char *vac, int resum, int count) {
    (void)f, (void)out, (void)D, (void)R, (void)u_io, (void)vac, (void)resum, (void)count;
}

void tube_runs_avx512(const tube_lanes *t, const int (*runs)[5], int n_runs) { (void)t, (void)runs, (void)n_runs; }

void tube_row_avx512(const tube_lanes *t, const tube_fast *fr, int j, int k, int n, int c0, int c1, size_t rec0,
                   int resum) {
    (void)t, (void)fr, (void)j, (void)k, (void)n, (void)c0, (void)c1, (void)rec0, (void)resum;
}

#endif
