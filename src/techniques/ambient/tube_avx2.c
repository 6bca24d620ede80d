/*
 * techniques/ambient/tube_avx2.c — tube.c's node update on 8 nodes at a
 * time with AVX2 (see tube_simd.h). All intrinsics of the tube marcher live
 * here; the file is compiled with target attributes and chosen at run time,
 * so the default build runs on any x86-64.
 *
 * BIT-IDENTICAL to the scalar `node`: every lane performs the scalar
 * operations in the same order (target "avx2" without "fma", so nothing
 * is contracted; sqrt and division are IEEE in both), the branches become
 * blends that select the value the scalar branch computes, and clamped
 * indices are computed as the scalar code computes them. Any change to
 * tube.c's `node`, `chain_start`, `box_exit`, `sample_strict`,
 * `tube_kappa` or scatter_grid_sample must be mirrored here (the test
 * compares the two paths bit for bit).
 */
#include "tube_simd.h"

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#include <math.h>

int tube_simd_available(void) {
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx2") != 0;
}

#define A2 __attribute__((target("avx2")))
#define A2I static inline __attribute__((always_inline, target("avx2")))

/* a where m, else b */
A2I __m256 sel(__m256 m, __m256 a, __m256 b) { return _mm256_blendv_ps(b, a, m); }

/* a + (b − a)·f, unfused (as the scalar code rounds it) */
A2I __m256 lerp(__m256 a, __m256 b, __m256 f) { return _mm256_add_ps(a, _mm256_mul_ps(_mm256_sub_ps(b, a), f)); }

A2I __m256i bcast0(__m256i v) { return _mm256_broadcastd_epi32(_mm256_castsi256_si128(v)); }
A2I int all_lanes(__m256i m) { return _mm256_movemask_epi8(m) == -1; }

/* Grid constants broadcast once per run. */
typedef struct grid8 {
    __m256 lo[3], inv_h[3], m[3]; /* m: highest node index as float */
    __m256i imax[3];              /* n − 2: highest cell index        */
    __m256i sy, sz;               /* strides in nodes                 */
    int nx, nxy;
} grid8;

/* Index-space position of world p, clamped to [0, n − 1] per axis, as
 * scatter_grid_sample / strict_cell compute it. */
A2I void to_index(const grid8 *g, const __m256 p[3], __m256 u[3]) {
    const __m256 zero = _mm256_setzero_ps();
    for (int a = 0; a < 3; a++) {
        __m256 v = _mm256_mul_ps(_mm256_sub_ps(p[a], g->lo[a]), g->inv_h[a]);
        /* u < 0 ? 0 : (u > m ? m : u); max/min differ from it only in the
         * sign of a zero, which no later operation turns into a different
         * value (cell 0, fraction ±0, a + (b − a)·(±0) = a) */
        u[a] = _mm256_min_ps(_mm256_max_ps(v, zero), g->m[a]);
    }
}

A2I __m256i cell_index(const grid8 *g, const __m256i c[3]) {
    return _mm256_add_epi32(_mm256_add_epi32(_mm256_mullo_epi32(c[2], g->sz), _mm256_mullo_epi32(c[1], g->sy)), c[0]);
}

/* Row reads. When the 8 lanes' cells have consecutive indices (lane 0's +
 * lane: along a run in x the read points advance by about one cell per
 * node, so this is the common case of the shells' rows and of the
 * directional sweep's rows), every corner of a trilinear read is at lane
 * 0's address + a common offset + lane: one contiguous 8-float load per
 * corner instead of a gather, and each loaded element is one that some
 * lane reads anyway. */
A2I int consecutive(__m256i base) {
    return all_lanes(_mm256_cmpeq_epi32(base, _mm256_add_epi32(bcast0(base), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7))));
}

/* The trilinear value from 8 corner vectors. */
A2I __m256 trilerp(__m256 a000, __m256 a100, __m256 a010, __m256 a110, __m256 a001, __m256 a101, __m256 a011,
                   __m256 a111, const __m256 f[3]) {
    __m256 c00 = lerp(a000, a100, f[0]), c10 = lerp(a010, a110, f[0]);
    __m256 c01 = lerp(a001, a101, f[0]), c11 = lerp(a011, a111, f[0]);
    __m256 c0 = lerp(c00, c10, f[1]), c1 = lerp(c01, c11, f[1]);
    return lerp(c0, c1, f[2]);
}

/* scatter_grid_sample_index on a grid with every dimension ≥ 2 (cells
 * clamped to n − 2: all 8 corners exist). */
A2I __m256 sample_clamped(const float *v, const grid8 *g, const __m256 p[3]) {
    __m256 u[3], f[3];
    __m256i c[3];
    to_index(g, p, u);
    for (int a = 0; a < 3; a++) {
        c[a] = _mm256_min_epi32(_mm256_cvttps_epi32(u[a]), g->imax[a]);
        f[a] = _mm256_sub_ps(u[a], _mm256_cvtepi32_ps(c[a]));
    }
    __m256i b = cell_index(g, c);
    const ptrdiff_t sy = g->nx, sz = g->nxy;
    if (consecutive(b)) {
        const float *r = v + _mm_cvtsi128_si32(_mm256_castsi256_si128(b));
#define L_(o) _mm256_loadu_ps(r + (o))
        return trilerp(L_(0), L_(1), L_(sy), L_(sy + 1), L_(sz), L_(sz + 1), L_(sz + sy), L_(sz + sy + 1), f);
#undef L_
    }
    const __m256i one = _mm256_set1_epi32(1);
    __m256i by = _mm256_add_epi32(b, g->sy), bz = _mm256_add_epi32(b, g->sz), byz = _mm256_add_epi32(by, g->sz);
#define G_(idx) _mm256_i32gather_ps(v, (idx), 4)
    return trilerp(G_(b), G_(_mm256_add_epi32(b, one)), G_(by), G_(_mm256_add_epi32(by, one)), G_(bz),
                   G_(_mm256_add_epi32(bz, one)), G_(byz), G_(_mm256_add_epi32(byz, one)), f);
#undef G_
}

/* The cell of a strict read (tube.c: strict_cell): lower-corner index and
 * fractions. */
A2I __m256i strict_cell8(const grid8 *g, const __m256 p[3], __m256 f[3]) {
    __m256 u[3];
    __m256i c[3];
    to_index(g, p, u);
    for (int a = 0; a < 3; a++) {
        c[a] = _mm256_cvttps_epi32(u[a]);
        f[a] = _mm256_sub_ps(u[a], _mm256_cvtepi32_ps(c[a]));
    }
    return cell_index(g, c);
}

/* tube.c's strict_at for the lanes in `mask` (others: 0, no load): the
 * upper corner of an axis only where the fraction is > 0. */
A2I __m256 strict_at8(const float *v, const grid8 *g, __m256i b, const __m256 f[3], __m256 mask) {
    const __m256 zero = _mm256_setzero_ps();
    __m256i up[3];
    for (int a = 0; a < 3; a++) up[a] = _mm256_castps_si256(_mm256_cmp_ps(f[a], zero, _CMP_GT_OQ));
    /* Row reads when every lane is wanted, the indices are consecutive and
     * the upper y and z corners are the same for all lanes: every loaded
     * element is then a corner some lane reads — lane 7's upper x corner
     * only if its fraction is > 0 (checked); a lane whose x fraction is 0
     * gets lane + 1's lower corner as its upper one, with weight 0: the
     * same result. */
    if (_mm256_movemask_ps(mask) == 0xff && _mm256_extract_epi32(up[0], 7) && consecutive(b) &&
        all_lanes(_mm256_cmpeq_epi32(up[1], bcast0(up[1]))) && all_lanes(_mm256_cmpeq_epi32(up[2], bcast0(up[2])))) {
        const float *r = v + _mm_cvtsi128_si32(_mm256_castsi256_si128(b));
        const ptrdiff_t sy = _mm256_extract_epi32(up[1], 0) ? g->nx : 0;
        const ptrdiff_t sz = _mm256_extract_epi32(up[2], 0) ? g->nxy : 0;
#define L_(o) _mm256_loadu_ps(r + (o))
        return trilerp(L_(0), L_(1), L_(sy), L_(sy + 1), L_(sz), L_(sz + 1), L_(sz + sy), L_(sz + sy + 1), f);
#undef L_
    }
    __m256i ox = _mm256_and_si256(up[0], _mm256_set1_epi32(1));
    __m256i oy = _mm256_and_si256(up[1], g->sy), oz = _mm256_and_si256(up[2], g->sz);
    __m256i by = _mm256_add_epi32(b, oy), bz = _mm256_add_epi32(b, oz), byz = _mm256_add_epi32(by, oz);
#define G_(idx) _mm256_mask_i32gather_ps(zero, v, (idx), mask, 4)
    return trilerp(G_(b), G_(_mm256_add_epi32(b, ox)), G_(by), G_(_mm256_add_epi32(by, ox)), G_(bz),
                   G_(_mm256_add_epi32(bz, ox)), G_(byz), G_(_mm256_add_epi32(byz, ox)), f);
#undef G_
}

/* tube_kappa for 8 arguments. */
A2I __m256 kappa8(const tube_lanes *t, __m256 rho) {
    const __m256 zero = _mm256_setzero_ps(), last = _mm256_set1_ps((float)(t->n_sigma - 1));
    __m256 u = _mm256_div_ps(_mm256_mul_ps(rho, last), _mm256_set1_ps(t->sigma_max));
    __m256 above = _mm256_cmp_ps(u, last, _CMP_GE_OQ);
    /* u ≤ 0 gives cell 0 and fraction 0: κ[0] + (κ[1] − κ[0])·0 = κ[0] */
    __m256 uc = _mm256_min_ps(_mm256_max_ps(u, zero), last);
    __m256i i = _mm256_min_epi32(_mm256_cvttps_epi32(uc), _mm256_set1_epi32(t->n_sigma - 2));
    __m256 f = _mm256_sub_ps(uc, _mm256_cvtepi32_ps(i));
    __m256 k0 = _mm256_i32gather_ps(t->kappa, i, 4);
    __m256 k1 = _mm256_i32gather_ps(t->kappa, _mm256_add_epi32(i, _mm256_set1_epi32(1)), 4);
    return sel(above, _mm256_set1_ps(t->kappa[t->n_sigma - 1]), lerp(k0, k1, f));
}

A2I void grid_consts(const tube_lanes *t, grid8 *g) {
    for (int a = 0; a < 3; a++) {
        g->lo[a] = _mm256_set1_ps(t->lo[a]);
        g->inv_h[a] = _mm256_set1_ps(t->inv_h[a]);
        g->m[a] = _mm256_set1_ps((float)(t->dims[a] - 1));
        g->imax[a] = _mm256_set1_epi32(t->dims[a] - 2);
    }
    g->nx = t->dims[0], g->nxy = t->dims[0] * t->dims[1];
    g->sy = _mm256_set1_epi32(g->nx);
    g->sz = _mm256_set1_epi32(g->nxy);
}

/* Stores lanes [0, n) of v at p + l·stride. */
A2I void store_ps(float *p, ptrdiff_t stride, __m256 v, int n) {
    if (stride == 1 && n == 8) {
        _mm256_storeu_ps(p, v);
        return;
    }
    float tmp[8];
    _mm256_storeu_ps(tmp, v);
    for (int l = 0; l < n; l++) p[(ptrdiff_t)l * stride] = tmp[l];
}

/* Loads lanes [0, n) from p + l·stride (others 0). */
A2I __m256 load_ps(const float *p, ptrdiff_t stride, int n) {
    if (stride == 1 && n == 8) return _mm256_loadu_ps(p);
    float tmp[8] = {0, 0, 0, 0, 0, 0, 0, 0};
    for (int l = 0; l < n; l++) tmp[l] = p[(ptrdiff_t)l * stride];
    return _mm256_loadu_ps(tmp);
}

A2I void nodes_body(const tube_lanes *t, int i, int j, int k, int axis, int count, size_t rec0, ptrdiff_t rec_stride) {
    const int nx = t->dims[0], ny = t->dims[1];
    grid8 g;
    grid_consts(t, &g);
    const __m256 zero = _mm256_setzero_ps(), inf = _mm256_set1_ps(INFINITY);
    const float s = t->s, half = 0.5f * s;
    const __m256 vs = _mm256_set1_ps(s), vhalf = _mm256_set1_ps(half), s_tol = _mm256_set1_ps(s * 1.0001f);
    const __m256 inv_r = _mm256_set1_ps(t->inv_r), neg_s = _mm256_set1_ps(-s), neg_half = _mm256_set1_ps(-half);
    const __m256 m_half = _mm256_set1_ps(-0.5f), p_half = _mm256_set1_ps(0.5f);
    const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    const int start[3] = {i, j, k};
    const ptrdiff_t stride = axis == 0 ? 1 : axis == 1 ? (ptrdiff_t)nx : (ptrdiff_t)nx * ny;
    const size_t at0 = ((size_t)k * (size_t)ny + (size_t)j) * (size_t)nx + (size_t)i;
    float *out = t->D + at0;
    /* Stages over chunks of up to 64 nodes (8 blocks of 8), with the
     * intermediate vectors in small arrays: one block's work is a long
     * dependency chain (sqrt → divisions → gather → κ index → κ gather →
     * gather) that no core can overlap with the next block's when both sit
     * in one loop iteration (hundreds of instructions each); as separate
     * short loops, the blocks of a stage are independent iterations and
     * their latencies overlap. */
    enum { CHUNK = 64, BLOCKS = CHUNK / 8 };
    __m256 c_w[3][BLOCKS], c_m[3][BLOCKS], c_delta[BLOCKS], c_arg[BLOCKS], c_k[BLOCKS];
    const __m256 hv[3] = {_mm256_set1_ps(t->h[0]), _mm256_set1_ps(t->h[1]), _mm256_set1_ps(t->h[2])};
    for (int c0 = 0; c0 < count; c0 += CHUNK) {
        int nb = (count - c0 + 7) / 8;
        if (nb > BLOCKS) nb = BLOCKS;
        /* ρ at the nodes being written is read by the nodes half a step
         * further from the light, a few slices/shells later; touching it
         * now brings its lines into the cache before those reads (which
         * otherwise miss: ρ, unlike D, was not written recently). */
        for (int bi = 0; bi < nb; bi += 2)
            _mm_prefetch((const char *)(t->rho + at0 + (ptrdiff_t)(c0 + 8 * bi) * stride), _MM_HINT_T0);
        /* 1. chain geometry: ω, δ and the centre of the sphere towards
         *    the light */
        for (int bi = 0; bi < nb; bi++) {
            __m256i ln = _mm256_add_epi32(_mm256_set1_epi32(c0 + 8 * bi), lane);
            /* the node: lo + (float)i·h (scatter_grid_node) */
            __m256 x[3], w[3], dl = inf, tiny = zero;
            for (int a = 0; a < 3; a++) {
                __m256i idx = _mm256_set1_epi32(start[a]);
                if (a == axis) idx = _mm256_add_epi32(idx, ln);
                x[a] = _mm256_add_ps(g.lo[a], _mm256_mul_ps(_mm256_cvtepi32_ps(idx), hv[a]));
            }
            /* chain_start: travel direction and the distance to the light */
            if (t->positional) {
                __m256 d[3];
                for (int a = 0; a < 3; a++) d[a] = _mm256_sub_ps(x[a], _mm256_set1_ps(t->pos[a]));
                __m256 d2 = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(d[0], d[0]), _mm256_mul_ps(d[1], d[1])),
                                          _mm256_mul_ps(d[2], d[2]));
                dl = _mm256_sqrt_ps(d2);
                tiny = _mm256_cmp_ps(dl, _mm256_set1_ps(1e-20f), _CMP_LT_OQ);
                __m256 inv = _mm256_div_ps(_mm256_set1_ps(1.0f), dl);
                for (int a = 0; a < 3; a++) w[a] = _mm256_mul_ps(d[a], inv);
            } else {
                for (int a = 0; a < 3; a++) w[a] = _mm256_set1_ps(t->dir[a]);
            }
            /* A re-sum whose recorded nodes are all deep (sign bit of the
             * record, see tube.h) skips the box exit: a deep node uses no
             * δ. */
            int skip_exit = 0;
            if (t->resum) {
                int n0 = c0 + 8 * bi, left = count - n0 < 8 ? count - n0 : 8;
                __m256 rec = load_ps(t->g_arg + rec0 + (size_t)((ptrdiff_t)n0 * rec_stride), rec_stride, left);
                skip_exit = _mm256_movemask_ps(rec) == 0xff;
                c_arg[bi] = _mm256_and_ps(rec, _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff)));
            }
            __m256 delta = inf;
            if (!skip_exit) {
                /* box_exit along back = −ω */
                __m256 texit = inf;
                for (int a = 0; a < 3; a++) {
                    __m256 b = _mm256_mul_ps(w[a], _mm256_set1_ps(-1.0f));
                    __m256 pos = _mm256_cmp_ps(b, zero, _CMP_GT_OQ), neg = _mm256_cmp_ps(b, zero, _CMP_LT_OQ);
                    __m256 bound = sel(pos, _mm256_set1_ps(t->hi[a]), _mm256_set1_ps(t->lo[a]));
                    __m256 ta = _mm256_div_ps(_mm256_sub_ps(bound, x[a]), b);
                    ta = sel(_mm256_or_ps(pos, neg), ta, inf);
                    texit = sel(_mm256_cmp_ps(ta, texit, _CMP_LT_OQ), ta, texit);
                }
                texit = sel(_mm256_cmp_ps(texit, zero, _CMP_GT_OQ), texit, zero);
                delta = sel(_mm256_cmp_ps(texit, dl, _CMP_LT_OQ), texit, dl);
            }
            /* a node at the light: δ = 0, ω = +z */
            delta = sel(tiny, zero, delta);
            w[0] = sel(tiny, zero, w[0]);
            w[1] = sel(tiny, zero, w[1]);
            w[2] = sel(tiny, _mm256_set1_ps(1.0f), w[2]);
            /* the sphere between the node and the chain start (Eq. 17) or
             * s back (Eq. 16) */
            __m256 near = _mm256_cmp_ps(delta, s_tol, _CMP_LE_OQ);
            __m256 cA = sel(near, _mm256_mul_ps(m_half, delta), neg_half);
            for (int a = 0; a < 3; a++) {
                c_w[a][bi] = w[a];
                c_m[a][bi] = _mm256_add_ps(x[a], _mm256_mul_ps(w[a], cA));
            }
            c_delta[bi] = delta;
        }
        /* 2. ρ there, as the table argument (a re-sum: the recorded one) */
        for (int bi = 0; bi < nb; bi++) {
            int n0 = c0 + 8 * bi, left = count - n0 < 8 ? count - n0 : 8;
            size_t at = rec0 + (size_t)((ptrdiff_t)n0 * rec_stride);
            if (t->resum) continue; /* loaded in stage 1 */
            __m256 m[3] = {c_m[0][bi], c_m[1][bi], c_m[2][bi]};
            __m256 rhoA = sample_clamped(t->rho, &g, m);
            __m256 near = _mm256_cmp_ps(c_delta[bi], s_tol, _CMP_LE_OQ);
            c_arg[bi] = sel(near, _mm256_mul_ps(_mm256_mul_ps(_mm256_mul_ps(rhoA, p_half), vs), inv_r),
                            _mm256_mul_ps(_mm256_mul_ps(rhoA, vhalf), inv_r));
            if (t->g_arg) {
                /* deep nodes (δ > 2s) carry the sign bit */
                __m256 deep = _mm256_andnot_ps(near, _mm256_cmp_ps(_mm256_sub_ps(c_delta[bi], vs), vs, _CMP_NLE_UQ));
                __m256 sign = _mm256_and_ps(deep, _mm256_castsi256_ps(_mm256_set1_epi32((int)0x80000000u)));
                store_ps(t->g_arg + at, rec_stride, _mm256_or_ps(c_arg[bi], sign), left);
            }
        }
        /* 3. κ of that sphere */
        for (int bi = 0; bi < nb; bi++) c_k[bi] = kappa8(t, c_arg[bi]);
        /* 4. the front s back (or the exact first step), the sum, the
         *    records */
        for (int bi = 0; bi < nb; bi++) {
            int n0 = c0 + 8 * bi, left = count - n0 < 8 ? count - n0 : 8;
            __m256i ln = _mm256_add_epi32(_mm256_set1_epi32(n0), lane);
            __m256 valid = _mm256_castsi256_ps(_mm256_cmpgt_epi32(_mm256_set1_epi32(count), ln));
            __m256 w[3] = {c_w[0][bi], c_w[1][bi], c_w[2][bi]}, delta = c_delta[bi], kA = c_k[bi], y[3];
            for (int a = 0; a < 3; a++) {
                __m256i idx = _mm256_set1_epi32(start[a]);
                if (a == axis) idx = _mm256_add_epi32(idx, ln);
                __m256 x = _mm256_add_ps(g.lo[a], _mm256_mul_ps(_mm256_cvtepi32_ps(idx), hv[a]));
                y[a] = _mm256_add_ps(x, _mm256_mul_ps(w[a], neg_s));
            }
            __m256 near = _mm256_cmp_ps(delta, s_tol, _CMP_LE_OQ);
            __m256 v_near = _mm256_mul_ps(_mm256_div_ps(delta, vs), kA);
            __m256 dy = _mm256_sub_ps(delta, vs);
            __m256 mid = _mm256_andnot_ps(near, _mm256_cmp_ps(dy, vs, _CMP_LE_OQ));
            __m256 deep = _mm256_andnot_ps(_mm256_or_ps(near, mid), valid);
            __m256 back = zero;
            if (_mm256_movemask_ps(_mm256_and_ps(mid, valid))) {
                /* y within the first step: its D exactly (Eq. 17) */
                __m256 cB = _mm256_mul_ps(m_half, dy), mB[3];
                for (int a = 0; a < 3; a++) mB[a] = _mm256_add_ps(y[a], _mm256_mul_ps(w[a], cB));
                __m256 rhoB = sample_clamped(t->rho, &g, mB);
                __m256 kB = kappa8(t, _mm256_mul_ps(_mm256_mul_ps(rhoB, vhalf), inv_r));
                back = sel(mid, _mm256_mul_ps(_mm256_div_ps(dy, vs), kB), back);
            }
            if (_mm256_movemask_ps(deep)) {
                __m256 f[3];
                __m256i cell = strict_cell8(&g, y, f);
                back = sel(deep, strict_at8(t->D, &g, cell, f, deep), back);
            }
            store_ps(out + (ptrdiff_t)n0 * stride, stride, sel(near, v_near, _mm256_add_ps(back, kA)), left);
        }
    }
}

A2I void fast_body(const tube_fast *fr, float *out, const float *D, const float *R, float *u_io, int resum, int count) {
    const ptrdiff_t *ov = fr->off_v, *orr = fr->off_r;
    __m256 a[8], b[8];
    for (int c = 0; c < 8; c++) a[c] = _mm256_set1_ps(fr->w_v[c]), b[c] = _mm256_set1_ps(fr->w_r[c]);
    const __m256 kscale = _mm256_set1_ps(fr->kscale), last = _mm256_set1_ps(fr->last), half = _mm256_set1_ps(0.5f);
    const __m256 abs_mask = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
    const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    for (int i = 0; i < count; i += 8) {
        /* the scalar loop's sums, left to right, unfused */
        const float *d = D + i, *r = R + i;
        /* the run's tail: masked loads touch no element past the run */
        const int full = count - i >= 8;
        const __m256i k = _mm256_cmpgt_epi32(_mm256_set1_epi32(count - i), lane);
#define LD_(p) (full ? _mm256_loadu_ps(p) : _mm256_maskload_ps((p), k))
        /* ρ (or the recorded coordinates) was not touched since the last
         * sweep: the rows' lines come from memory. Prefetch them a few
         * hundred nodes ahead (the four corner rows of the read; the
         * hardware prefetcher does not keep up with 9 concurrent streams). */
        if (!(i & 15)) {
            if (resum) {
                _mm_prefetch((const char *)(u_io + i + 256), _MM_HINT_T0);
            } else {
                _mm_prefetch((const char *)(r + orr[0] + 256), _MM_HINT_T0);
                _mm_prefetch((const char *)(r + orr[2] + 256), _MM_HINT_T0);
                _mm_prefetch((const char *)(r + orr[4] + 256), _MM_HINT_T0);
                _mm_prefetch((const char *)(r + orr[6] + 256), _MM_HINT_T0);
            }
        }
        __m256 back = _mm256_mul_ps(a[0], LD_(d + ov[0]));
        for (int c = 1; c < 8; c++) back = _mm256_add_ps(back, _mm256_mul_ps(a[c], LD_(d + ov[c])));
        __m256 u;
        if (resum) {
            u = LD_(u_io + i);
        } else {
            __m256 x = _mm256_mul_ps(b[0], LD_(r + orr[0]));
            for (int c = 1; c < 8; c++) x = _mm256_add_ps(x, _mm256_mul_ps(b[c], LD_(r + orr[c])));
            x = _mm256_mul_ps(x, kscale);
            /* min(x, last) as the scalar code writes it: 0.5 (x + last − |x − last|) */
            u = _mm256_mul_ps(half, _mm256_sub_ps(_mm256_add_ps(x, last),
                                                  _mm256_and_ps(_mm256_sub_ps(x, last), abs_mask)));
            if (u_io) {
                if (full) _mm256_storeu_ps(u_io + i, u);
                else _mm256_maskstore_ps(u_io + i, k, u);
            }
        }
        __m256i j = _mm256_cvttps_epi32(u);
        __m256 f = _mm256_sub_ps(u, _mm256_cvtepi32_ps(j));
        const __m256 kf = _mm256_castsi256_ps(k), z = _mm256_setzero_ps();
        __m256 k0 = _mm256_mask_i32gather_ps(z, fr->kappa, j, kf, 4);
        __m256 k1 = _mm256_mask_i32gather_ps(z, fr->kappa, _mm256_add_epi32(j, _mm256_set1_epi32(1)), kf, 4);
        __m256 v = _mm256_add_ps(_mm256_add_ps(back, k0), _mm256_mul_ps(_mm256_sub_ps(k1, k0), f));
        if (full) _mm256_storeu_ps(out + i, v);
        else _mm256_maskstore_ps(out + i, k, v);
#undef LD_
    }
}


A2 void tube_nodes_avx2(const tube_lanes *t, int i, int j, int k, int axis, int count, size_t rec0,
                     ptrdiff_t rec_stride) {
    nodes_body(t, i, j, k, axis, count, rec0, rec_stride);
}

/* Runs (i, j, k, axis, count) of a point sweep in one call: the records
 * are in node order. One call per batch keeps the switches between this
 * code and the scalar caller rare (measured with AVX-512: a tenth of a
 * re-sum's time went to them with one call per run). */
A2 void tube_runs_avx2(const tube_lanes *t, const int (*runs)[5], int n_runs) {
    const size_t nx = (size_t)t->dims[0], nxy = nx * (size_t)t->dims[1];
    for (int r = 0; r < n_runs; r++) {
        const int *q = runs[r];
        ptrdiff_t stride = q[3] == 0 ? 1 : q[3] == 1 ? (ptrdiff_t)nx : (ptrdiff_t)nxy;
        nodes_body(t, q[0], q[1], q[2], q[3], q[4], (size_t)q[2] * nxy + (size_t)q[1] * nx + (size_t)q[0], stride);
    }
}

A2 void tube_fast_run_avx2(const tube_fast *fr, float *out, const float *D, const float *R, float *u_io, int resum,
                        int count) {
    fast_body(fr, out, D, R, u_io, resum, count);
}

/* A directional row along x in one call: nodes [0, c0) and (c1, n) by the
 * node update, [c0, c1] by the fast path (c1 < c0: none). */
A2 void tube_row_avx2(const tube_lanes *t, const tube_fast *fr, int j, int k, int n, int c0, int c1, size_t rec0,
                   int resum) {
    const size_t at = ((size_t)k * (size_t)t->dims[1] + (size_t)j) * (size_t)t->dims[0];
    int f0 = c1 >= c0 ? c0 : n, f1 = c1 >= c0 ? c1 + 1 : n;
    if (f0 > 0) nodes_body(t, 0, j, k, 0, f0, rec0, 1);
    if (f1 > f0)
        fast_body(fr, t->D + at + f0, t->D + at + f0, t->rho + at + f0, t->g_arg ? t->g_arg + rec0 + f0 : NULL, resum,
                  f1 - f0);
    if (n > f1) nodes_body(t, f1, j, k, 0, n - f1, rec0 + (size_t)f1, 1);
}

#else /* no AVX2 on this target: tube.c uses its scalar node update */

int tube_simd_available(void) { return 0; }

void tube_nodes_avx2(const tube_lanes *t, int i, int j, int k, int axis, int count, size_t rec0,
                          ptrdiff_t rec_stride) {
    (void)t, (void)i, (void)j, (void)k, (void)axis, (void)count, (void)rec0, (void)rec_stride;
}

void tube_fast_run_avx2(const tube_fast *f, float *out, const float *D, const float *R, float *u_io, int resum,
                        int count) {
    (void)f, (void)out, (void)D, (void)R, (void)u_io, (void)resum, (void)count;
}

void tube_runs_avx2(const tube_lanes *t, const int (*runs)[5], int n_runs) { (void)t, (void)runs, (void)n_runs; }

void tube_row_avx2(const tube_lanes *t, const tube_fast *fr, int j, int k, int n, int c0, int c1, size_t rec0,
                   int resum) {
    (void)t, (void)fr, (void)j, (void)k, (void)n, (void)c0, (void)c1, (void)rec0, (void)resum;
}

#endif
