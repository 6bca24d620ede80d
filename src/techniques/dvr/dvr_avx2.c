/*
 * techniques/dvr/dvr_avx2.c — the `ea` / `shaded` ray caster on 8-ray
 * packets with AVX2+FMA. All intrinsics of the DVR techniques live in this
 * file; it is compiled with target attributes and chosen at run time
 * (volux_dvr_simd_available), so the default build runs on any x86-64.
 *
 * Layout (bricks and 16×16 tiles measured ~2× faster for oblique rays on
 * the development machines): a 16×16 tile is cut into 4×2-pixel packets, one
 * ray per SIMD lane, 4 packets (a 4×8 block) marched together to hide
 * latencies (march_packets); lanes gather their trilinear corners from the volume's
 * bricked copy (8³ cells as 9³ nodes, so the 8 corners are at 4 fixed
 * offsets: one 32-bit gather returns a corner pair for 8- and 16-bit data)
 * and read their transfer-function records with one 32-byte load each,
 * transposed into 8 vectors (cheaper than 8 gathers).
 *
 * Same image as the scalar kernel in dvr.c, lane by lane:
 *   - the same segment positions (fixed grid t0 + (k−1+jitter)·h, the same
 *     RNG stream for the jitter), the same sample positions and trilinear
 *     arithmetic (no FMA contraction there, so samples are bit-identical);
 *   - the same pre-integration model (see march_packets), evaluated in
 *     float from dvr_state.pre_f instead of double;
 *   - empty-space skipping that only drops segments lying inside skip cells
 *     (4³, finer than the scalar kernel's 8³ macrocells) where σt = 0 on
 *     every table node of the cell's value range: their contribution is
 *     exactly 0, so skipping never changes pixels;
 *   - the same early-termination test.
 * Differences are float rounding (exp approximation ≤ 2 ulp, float
 * integral tables); tests/invariants/test_ea_fastpath.c bounds them.
 *
 * `shaded` runs here too when all its lights are directional: the bricked
 * 10-bit gradient cache (dvr.c) is read at the sample's cell with 64-bit
 * gathers, and Blinn–Phong uses vector log/exp for the specular power.
 *
 * DOES NOT: shade with point, spot or sphere lights (scalar kernel).
 */
#include <math.h>
#include <string.h>

#include "core/rng.h"
#include "core/simd.h"
#include "core/vecmath.h"
#include "dvr.h"
#include "sample/primary.h"

int volux_dvr_simd_available(void) { return volux_cpu_has_avx2_fma(); }

#if VOLUX_X86_GNUC

#define A2 __attribute__((target("avx2,fma")))
#define A2I static inline __attribute__((always_inline, target("avx2,fma")))

/* Packet shape: 4 pixels wide, 2 tall (compact footprint in the volume). */
enum { PW = 4, PH = 2 };

/* Per-lane ray set-up, structure of arrays. */
typedef struct packet_rays {
    float t0[8], t1[8], jit[8];
    float q0[3][8], dq[3][8];
    float d[3][8]; /* world direction (view direction for shading) */
} packet_rays;

/* Volume constants broadcast once per packet. */
typedef struct vol_consts {
    const unsigned char *bricks;
    __m256i imax[3];          /* highest valid cell index per axis (n − 2) */
    __m256i stride_y, stride_z; /* brick strides in nodes (·729)           */
    __m256 offset;            /* file value = stored + offset             */
} vol_consts;

A2I void vol_consts_init(vol_consts *vc, const volux_volume *v) {
    vc->bricks = v->bricks;
    for (int a = 0; a < 3; a++) vc->imax[a] = _mm256_set1_epi32(v->dims[a] > 1 ? v->dims[a] - 2 : 0);
    vc->stride_y = _mm256_set1_epi32(v->brick_counts[0] * VOLUX_BRICK_VOXELS);
    vc->stride_z = _mm256_set1_epi32(v->brick_counts[0] * v->brick_counts[1] * VOLUX_BRICK_VOXELS);
    vc->offset = _mm256_set1_ps(v->value_offset);
}

A2I __m256 lerp(__m256 a, __m256 b, __m256 f) {
    /* a + (b − a)·f, unfused, exactly as the scalar code rounds it */
    return _mm256_add_ps(a, _mm256_mul_ps(_mm256_sub_ps(b, a), f));
}

/* Trilinear samples at index-space (x, y, z) for 8 lanes from the bricked
 * copy; same clamping and arithmetic as volux_volume_sample_bricked. Every
 * lane gets a valid address (indices are clamped), so no masks are needed. */
/* Where a sample fell: brick offset of its cell's low corner and the
 * fractions, for the bricked gradient cache (same layout). */
typedef struct cell8 {
    __m256i b;
    __m256 fx, fy, fz;
} cell8;

A2I __m256 sample8(const vol_consts *vc, __m256 x, __m256 y, __m256 z, volux_storage storage, cell8 *cell) {
    const __m256i zero = _mm256_setzero_si256(), seven = _mm256_set1_epi32(7);
    __m256i i = _mm256_max_epi32(_mm256_min_epi32(_mm256_cvttps_epi32(x), vc->imax[0]), zero);
    __m256i j = _mm256_max_epi32(_mm256_min_epi32(_mm256_cvttps_epi32(y), vc->imax[1]), zero);
    __m256i k = _mm256_max_epi32(_mm256_min_epi32(_mm256_cvttps_epi32(z), vc->imax[2]), zero);
    __m256 fx = _mm256_sub_ps(x, _mm256_cvtepi32_ps(i));
    __m256 fy = _mm256_sub_ps(y, _mm256_cvtepi32_ps(j));
    __m256 fz = _mm256_sub_ps(z, _mm256_cvtepi32_ps(k));
    __m256i brick = _mm256_add_epi32(
        _mm256_mullo_epi32(_mm256_srli_epi32(i, 3), _mm256_set1_epi32(VOLUX_BRICK_VOXELS)),
        _mm256_add_epi32(_mm256_mullo_epi32(_mm256_srli_epi32(j, 3), vc->stride_y),
                         _mm256_mullo_epi32(_mm256_srli_epi32(k, 3), vc->stride_z)));
    /* 9·(j&7) + 81·(k&7) in one multiply-add of 16-bit pairs */
    __m256i jk = _mm256_or_si256(_mm256_and_si256(j, seven), _mm256_slli_epi32(_mm256_and_si256(k, seven), 16));
    __m256i local = _mm256_add_epi32(_mm256_and_si256(i, seven),
                                     _mm256_madd_epi16(jk, _mm256_set1_epi32((81 << 16) | 9)));
    __m256i b = _mm256_add_epi32(brick, local);
    if (cell) cell->b = b, cell->fx = fx, cell->fy = fy, cell->fz = fz;
    enum { SY = VOLUX_BRICK_NODES, SZ = VOLUX_BRICK_NODES * VOLUX_BRICK_NODES };
    __m256 c000, c100, c010, c110, c001, c101, c011, c111;
    if (storage == VOLUX_STORE_U8 || storage == VOLUX_STORE_U16) {
        /* One 32-bit gather per (y, z) corner row returns the x pair. */
        const int u8 = storage == VOLUX_STORE_U8;
        const int es = u8 ? 1 : 2, shift = u8 ? 8 : 16;
        const __m256i lo = _mm256_set1_epi32(u8 ? 0xff : 0xffff);
        const unsigned char *p = vc->bricks;
        __m256i g0, g1, g2, g3;
        if (u8) {
            g0 = _mm256_i32gather_epi32((const int *)(const void *)p, b, 1);
            g1 = _mm256_i32gather_epi32((const int *)(const void *)(p + SY), b, 1);
            g2 = _mm256_i32gather_epi32((const int *)(const void *)(p + SZ), b, 1);
            g3 = _mm256_i32gather_epi32((const int *)(const void *)(p + SZ + SY), b, 1);
        } else {
            g0 = _mm256_i32gather_epi32((const int *)(const void *)p, b, 2);
            g1 = _mm256_i32gather_epi32((const int *)(const void *)(p + es * SY), b, 2);
            g2 = _mm256_i32gather_epi32((const int *)(const void *)(p + es * SZ), b, 2);
            g3 = _mm256_i32gather_epi32((const int *)(const void *)(p + es * (SZ + SY)), b, 2);
        }
#define VOLUX_PAIR_(g, a, c)                                                                                          \
    a = _mm256_cvtepi32_ps(_mm256_and_si256(g, lo));                                                                  \
    c = _mm256_cvtepi32_ps(_mm256_and_si256(_mm256_srli_epi32(g, shift), lo))
        VOLUX_PAIR_(g0, c000, c100);
        VOLUX_PAIR_(g1, c010, c110);
        VOLUX_PAIR_(g2, c001, c101);
        VOLUX_PAIR_(g3, c011, c111);
#undef VOLUX_PAIR_
    } else {
        const float *p = (const float *)(const void *)vc->bricks;
        c000 = _mm256_i32gather_ps(p, b, 4);
        c100 = _mm256_i32gather_ps(p + 1, b, 4);
        c010 = _mm256_i32gather_ps(p + SY, b, 4);
        c110 = _mm256_i32gather_ps(p + SY + 1, b, 4);
        c001 = _mm256_i32gather_ps(p + SZ, b, 4);
        c101 = _mm256_i32gather_ps(p + SZ + 1, b, 4);
        c011 = _mm256_i32gather_ps(p + SZ + SY, b, 4);
        c111 = _mm256_i32gather_ps(p + SZ + SY + 1, b, 4);
    }
    __m256 c00 = lerp(c000, c100, fx), c10 = lerp(c010, c110, fx);
    __m256 c01 = lerp(c001, c101, fx), c11 = lerp(c011, c111, fx);
    __m256 c0 = lerp(c00, c10, fy), c1 = lerp(c01, c11, fy);
    return _mm256_add_ps(lerp(c0, c1, fz), vc->offset);
}

/* Rows of 8 floats at base + offs[l] (one per lane), transposed: o[e] holds
 * element e of every lane. Each vector pairs the halves of lanes l and l+4
 * (128-bit loads into both halves: load-port work, no shuffle), then two
 * in-lane 4×4 transposes: 16 shuffles instead of 24, and no gathers. */
A2I void load_transpose8(const float *base, const int32_t offs[8], __m256 o[8]) {
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

/* Table coordinate u, interval i and fraction f of 8 samples (as
 * volux_lut_coord / volux_lut_interval). */
A2I void lut_coord8(const volux_transfer_lut *lut, __m256 s, __m256 *u, __m256i *i, __m256 *f) {
    __m256 x = _mm256_mul_ps(_mm256_sub_ps(s, _mm256_set1_ps(lut->s_min)), _mm256_set1_ps(lut->inv_ds));
    x = _mm256_min_ps(_mm256_max_ps(x, _mm256_setzero_ps()), _mm256_set1_ps((float)(lut->n - 1)));
    __m256i k = _mm256_min_epi32(_mm256_cvttps_epi32(x), _mm256_set1_epi32(lut->n - 2));
    *u = x;
    *i = k;
    *f = _mm256_sub_ps(x, _mm256_cvtepi32_ps(k));
}

/* Pre-integration record (P[4], D[4]) of interval i for 8 lanes. */
A2I void pre_record8(const float *pre_f, __m256i i, __m256 P[4], __m256 D[4]) {
    _Alignas(32) int32_t offs[8];
    _mm256_store_si256((__m256i *)(void *)offs, _mm256_slli_epi32(i, 3));
    __m256 o[8];
    load_transpose8(pre_f, offs, o);
    for (int c = 0; c < 4; c++) P[c] = o[c], D[c] = o[4 + c];
}

/* Skipping state and constants of one packet. */
typedef struct skip8 {
    const int *dist;     /* dvr_state.skip_dist                         */
    __m256i cells_max[3], ncx, ncy;
    __m256i up[3];       /* all ones where the ray moves up the axis    */
    __m256 inv_dq[3];    /* 1/dq (inf where dq = 0, masked below)        */
    __m256 flat[3];      /* dq == 0                                      */
} skip8;

/* Empty-space check at world t for the lanes in `need`. One lookup of the
 * signed skip distance d of the skip cell holding q(t) (dvr.c,
 * build_skip_distance) gives a cube of r = |d| − 1 rings of cells around
 * it that are all empty (d > 0) or all non-empty (d < 0); *t_exit is where
 * the ray leaves that cube. Returns the lanes in an empty cube, which may
 * skip to *m, the last segment index whose start is ≤ *t_exit (with a
 * margin of 10⁻³ h, so rounding never skips into a non-empty cell); lanes
 * in a non-empty cube need not check again before *t_exit. */
A2I __m256 check_cells(const skip8 *sk, const __m256 q0[3], const __m256 dq[3], __m256 t0, __m256 jit, __m256 inv_h,
                       __m256 t, __m256 need, __m256 *t_exit, __m256 *m) {
    const __m256i zero_i = _mm256_setzero_si256(), one_i = _mm256_set1_epi32(1);
    __m256 q[3];
    __m256i c[3];
    for (int ax = 0; ax < 3; ax++) {
        q[ax] = _mm256_add_ps(q0[ax], _mm256_mul_ps(dq[ax], t));
        c[ax] = _mm256_cvttps_epi32(_mm256_mul_ps(q[ax], _mm256_set1_ps(1.0f / DVR_SKIP_CELL)));
        c[ax] = _mm256_max_epi32(_mm256_min_epi32(c[ax], sk->cells_max[ax]), zero_i);
    }
    __m256i cell =
        _mm256_add_epi32(_mm256_mullo_epi32(_mm256_add_epi32(_mm256_mullo_epi32(c[2], sk->ncy), c[1]), sk->ncx), c[0]);
    __m256i d = _mm256_mask_i32gather_epi32(zero_i, sk->dist, cell, _mm256_castps_si256(need), 4);
    __m256i r = _mm256_max_epi32(_mm256_sub_epi32(_mm256_abs_epi32(d), one_i), zero_i);
    __m256 tmin = _mm256_set1_ps(INFINITY);
    for (int ax = 0; ax < 3; ax++) {
        /* the cube's far face along the ray: cell c + r + 1 going up, c − r going down */
        __m256i face = _mm256_blendv_epi8(_mm256_sub_epi32(c[ax], r),
                                          _mm256_add_epi32(_mm256_add_epi32(c[ax], r), one_i), sk->up[ax]);
        __m256 bound = _mm256_mul_ps(_mm256_cvtepi32_ps(face), _mm256_set1_ps((float)DVR_SKIP_CELL));
        __m256 ta = _mm256_mul_ps(_mm256_sub_ps(bound, q[ax]), sk->inv_dq[ax]);
        tmin = _mm256_min_ps(tmin, _mm256_blendv_ps(ta, _mm256_set1_ps(INFINITY), sk->flat[ax]));
    }
    *t_exit = _mm256_add_ps(t, tmin);
    *m = _mm256_add_ps(_mm256_floor_ps(_mm256_sub_ps(_mm256_mul_ps(_mm256_sub_ps(*t_exit, t0), inv_h),
                                                     _mm256_add_ps(jit, _mm256_set1_ps(1e-3f)))),
                       _mm256_set1_ps(1.0f));
    return _mm256_and_ps(need, _mm256_castsi256_ps(_mm256_cmpgt_epi32(d, zero_i)));
}

/* ln x for x > 0 (Cephes logf: mantissa in [√½, √2), degree-8
 * polynomial); ≤ 2 ulp from libm. With DAZ, denormal x reads as 0: callers
 * mask x ≤ 0. */
A2I __m256 log_pos(__m256 x) {
    __m256i xi = _mm256_castps_si256(x);
    __m256 e = _mm256_cvtepi32_ps(_mm256_sub_epi32(_mm256_srli_epi32(xi, 23), _mm256_set1_epi32(126)));
    __m256 m = _mm256_castsi256_ps(
        _mm256_or_si256(_mm256_and_si256(xi, _mm256_set1_epi32(0x807fffff)), _mm256_set1_epi32(0x3f000000)));
    __m256 small = _mm256_cmp_ps(m, _mm256_set1_ps(0.707106781186547524f), _CMP_LT_OQ);
    e = _mm256_sub_ps(e, _mm256_and_ps(small, _mm256_set1_ps(1.0f)));
    __m256 t = _mm256_sub_ps(_mm256_add_ps(m, _mm256_and_ps(small, m)), _mm256_set1_ps(1.0f));
    __m256 z = _mm256_mul_ps(t, t);
    __m256 y = _mm256_set1_ps(7.0376836292e-2f);
    y = _mm256_fmadd_ps(y, t, _mm256_set1_ps(-1.1514610310e-1f));
    y = _mm256_fmadd_ps(y, t, _mm256_set1_ps(1.1676998740e-1f));
    y = _mm256_fmadd_ps(y, t, _mm256_set1_ps(-1.2420140846e-1f));
    y = _mm256_fmadd_ps(y, t, _mm256_set1_ps(1.4249322787e-1f));
    y = _mm256_fmadd_ps(y, t, _mm256_set1_ps(-1.6668057665e-1f));
    y = _mm256_fmadd_ps(y, t, _mm256_set1_ps(2.0000714765e-1f));
    y = _mm256_fmadd_ps(y, t, _mm256_set1_ps(-2.4999993993e-1f));
    y = _mm256_fmadd_ps(y, t, _mm256_set1_ps(3.3333331174e-1f));
    y = _mm256_mul_ps(_mm256_mul_ps(y, t), z);
    y = _mm256_fmadd_ps(e, _mm256_set1_ps(-2.12194440e-4f), y);
    y = _mm256_fnmadd_ps(z, _mm256_set1_ps(0.5f), y);
    return _mm256_fmadd_ps(e, _mm256_set1_ps(0.693359375f), _mm256_add_ps(t, y));
}

/* Interpolated gradient (world units) from the bricked 10-bit cache at the
 * sample's cell: each corner pair (x, x+1) is one 64-bit gather, 4 rows;
 * the same corner order and arithmetic as volux_gradient_cache_sample. */
A2I void gradient8(const dvr_state *st, const cell8 *cell, __m256 g[3]) {
    enum { SY = VOLUX_BRICK_NODES, SZ = VOLUX_BRICK_NODES * VOLUX_BRICK_NODES };
    static const int rows[4] = {0, SY, SZ, SZ + SY};
    __m128i b_lo = _mm256_castsi256_si128(cell->b), b_hi = _mm256_extracti128_si256(cell->b, 1);
    __m256i w0[4], w1[4]; /* node x and x+1 of each row, lanes 0..7 */
    for (int r = 0; r < 4; r++) {
        const long long *base = (const long long *)(const void *)(st->grad.grad + rows[r]);
        __m256 lo = _mm256_castsi256_ps(_mm256_i32gather_epi64(base, b_lo, 4));
        __m256 hi = _mm256_castsi256_ps(_mm256_i32gather_epi64(base, b_hi, 4));
        /* even dwords are node x, odd ones node x+1; the shuffle leaves the
         * lanes in order 0 1 4 5 2 3 6 7, the permute restores it */
        w0[r] = _mm256_permute4x64_epi64(_mm256_castps_si256(_mm256_shuffle_ps(lo, hi, 0x88)), 0xD8);
        w1[r] = _mm256_permute4x64_epi64(_mm256_castps_si256(_mm256_shuffle_ps(lo, hi, 0xDD)), 0xD8);
    }
    const __m256 scale = _mm256_set1_ps(st->grad.scale);
    for (int a = 0; a < 3; a++) {
        const int up = 22 - 10 * a;
#define VOLUX_FIELD_(w) _mm256_cvtepi32_ps(_mm256_srai_epi32(_mm256_slli_epi32(w, up), 22))
        __m256 c00 = lerp(VOLUX_FIELD_(w0[0]), VOLUX_FIELD_(w1[0]), cell->fx);
        __m256 c10 = lerp(VOLUX_FIELD_(w0[1]), VOLUX_FIELD_(w1[1]), cell->fx);
        __m256 c01 = lerp(VOLUX_FIELD_(w0[2]), VOLUX_FIELD_(w1[2]), cell->fx);
        __m256 c11 = lerp(VOLUX_FIELD_(w0[3]), VOLUX_FIELD_(w1[3]), cell->fx);
#undef VOLUX_FIELD_
        __m256 c0 = lerp(c00, c10, cell->fy), c1 = lerp(c01, c11, cell->fy);
        g[a] = _mm256_mul_ps(lerp(c0, c1, cell->fz), scale);
    }
}

A2I __m256 dot3(const __m256 a[3], const __m256 b[3]) {
    return _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(a[0], b[0]), _mm256_mul_ps(a[1], b[1])),
                         _mm256_mul_ps(a[2], b[2]));
}

/* Per-lane half vectors h = normalize(L − view) of the directional lights:
 * constant along a ray, so computed once per packet, not per sample. */
A2I void half_vectors(const dvr_state *st, const __m256 view[3], __m256 hn[DVR_SIMD_MAX_LIGHTS][3]) {
    const __m256 one = _mm256_set1_ps(1.0f), zero = _mm256_setzero_ps();
    for (int i = 0; i < st->rc.lights.n_direct && i < DVR_SIMD_MAX_LIGHTS; i++) {
        const volux_prepared_light *l = &st->rc.lights.direct[i];
        __m256 hv[3] = {_mm256_sub_ps(_mm256_set1_ps(-l->travel.x), view[0]),
                        _mm256_sub_ps(_mm256_set1_ps(-l->travel.y), view[1]),
                        _mm256_sub_ps(_mm256_set1_ps(-l->travel.z), view[2])};
        __m256 hl = _mm256_sqrt_ps(dot3(hv, hv));
        __m256 hinv = _mm256_div_ps(one, hl), hpos = _mm256_cmp_ps(hl, zero, _CMP_GT_OQ);
        for (int a = 0; a < 3; a++) hn[i][a] = _mm256_blendv_ps(hv[a], _mm256_mul_ps(hv[a], hinv), hpos);
    }
}

/* Blinn–Phong for directional lights, as shade() in dvr.c: normal flipped
 * towards the viewer, faded by gradient magnitude; c: colour in/out.
 * 1/|g| comes from rsqrt with one Newton step (≈ 1 ulp from sqrt+div, and
 * no 12-cycle sqrt/div on the per-sample path). */
A2I void shade8(const dvr_state *st, const __m256 g[3], const __m256 view[3],
                const __m256 hn[DVR_SIMD_MAX_LIGHTS][3], __m256 c[3]) {
    const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f), sign = _mm256_set1_ps(-0.0f);
    const volux_material *mat = &st->rc.material;
    __m256 g2 = dot3(g, g);
    __m256 y = _mm256_rsqrt_ps(g2);
    __m256 inv = _mm256_mul_ps(y, _mm256_fnmadd_ps(_mm256_mul_ps(_mm256_mul_ps(g2, _mm256_set1_ps(0.5f)), y), y,
                                                   _mm256_set1_ps(1.5f)));
    __m256 gl = _mm256_mul_ps(g2, inv);
    __m256 m = st->grad_ref > 0.0f ? _mm256_mul_ps(gl, _mm256_set1_ps(1.0f / st->grad_ref)) : one;
    __m256 on = _mm256_cmp_ps(m, zero, _CMP_GT_OQ);
    if (!_mm256_movemask_ps(on)) return;
    m = _mm256_min_ps(m, one);
    __m256 n[3];
    for (int a = 0; a < 3; a++) n[a] = _mm256_mul_ps(g[a], inv);
    __m256 flip = _mm256_and_ps(_mm256_cmp_ps(dot3(n, view), zero, _CMP_GT_OQ), sign);
    for (int a = 0; a < 3; a++) n[a] = _mm256_xor_ps(n[a], flip);
    const float amb[3] = {st->ambient.x, st->ambient.y, st->ambient.z};
    __m256 diff[3], spec[3] = {zero, zero, zero};
    for (int a = 0; a < 3; a++) diff[a] = _mm256_set1_ps(amb[a] * mat->ambient);
    for (int i = 0; i < st->rc.lights.n_direct && i < DVR_SIMD_MAX_LIGHTS; i++) {
        const volux_prepared_light *l = &st->rc.lights.direct[i];
        const __m256 L[3] = {_mm256_set1_ps(-l->travel.x), _mm256_set1_ps(-l->travel.y), _mm256_set1_ps(-l->travel.z)};
        const float E[3] = {l->power.x, l->power.y, l->power.z};
        __m256 ndl = dot3(n, L);
        __m256 lit = _mm256_cmp_ps(ndl, zero, _CMP_GT_OQ);
        __m256 kd = _mm256_and_ps(_mm256_mul_ps(_mm256_set1_ps(mat->diffuse), ndl), lit);
        __m256 ndh = dot3(n, hn[i]);
        __m256 sp = _mm256_and_ps(lit, _mm256_cmp_ps(ndh, zero, _CMP_GT_OQ));
        __m256 pw = volux_exp_nonpos_cephes_avx2(_mm256_mul_ps(_mm256_set1_ps(mat->specular_power),
                                             log_pos(_mm256_blendv_ps(one, ndh, sp))));
        __m256 ks = _mm256_and_ps(_mm256_mul_ps(_mm256_set1_ps(mat->specular), pw), sp);
        for (int a = 0; a < 3; a++) {
            diff[a] = _mm256_add_ps(diff[a], _mm256_mul_ps(_mm256_set1_ps(E[a]), kd));
            spec[a] = _mm256_add_ps(spec[a], _mm256_mul_ps(_mm256_set1_ps(E[a]), ks));
        }
    }
    for (int a = 0; a < 3; a++) {
        __m256 lit_c = _mm256_add_ps(_mm256_mul_ps(c[a], diff[a]), spec[a]);
        c[a] = _mm256_blendv_ps(c[a], _mm256_add_ps(c[a], _mm256_mul_ps(_mm256_sub_ps(lit_c, c[a]), m)), on);
    }
}

/* Marches NP packets together. out: colour and transmittance per lane.
 *
 * Why NP = 4 packets in one loop: one sample is a ~200-cycle dependency
 * chain (position → brick index → gather → trilinear → table coordinate →
 * record loads → pre-integration → exp → compositing) but only ~80 cycles
 * of execution-port work, so a single packet leaves the core idle waiting
 * on latencies. Independent packets, advanced phase by phase, give the
 * out-of-order core other chains to work on: measured (ML 256³, dense,
 * pre-integrated) 120 M samples/s with 1 packet, 158 with 2, 171 with 4;
 * more lanes per loop cost a little divergence (docs/BENCHMARKS.md).
 *
 * Pre-integration model (shared with dvr.c): the running integrals
 * I(u) = P[i] + f·D[i] are linear inside a table interval, so a segment
 * whose ends fall in one interval has τ = len·D/Δs_node and c = D_c/D, and
 * otherwise τ = len·ΔI/Δs, c = ΔI_c/ΔI. In float, ΔI for ends in different
 * intervals is evaluated as (P_c − P_p) − f_p·D_p + f_c·D_c, fused in the
 * order that makes the cancelling pair exact: for adjacent intervals
 * P_c − P_p is exactly D of the lower one (D is the float difference of the
 * float P, dvr.c), so e.g. going up fma(−f_p, D_p, D_p) = D_p·(1 − f_p)
 * rounds once and the rest adds positive terms; only relative rounding
 * remains. So the absolute error of τ per segment is at most
 * ≈ 3·2⁻²⁴·len·(n−1)·σ̄ (σ̄ = mean σt over the value range; ≈ 4e-4·len·σ̄
 * for n = 4096) and vanishes where σt = 0; c inherits the same bound in
 * w·c. No division by a tiny Δs ever happens. */
enum { NP = 4 };

typedef struct packet_state {
    __m256 t0, t1, jit, q0[3], dq[3], d[3];
    __m256 active, kf, T, C[3], t_check, need_prev, warm;
    __m256 u_p, f_p, P_p[4], D_p[4]; /* previous segment end (pre-integration) */
    __m256i i_p;
    skip8 sk;
    __m256 hn[DVR_SIMD_MAX_LIGHTS][3]; /* shaded: half vectors per light */
} packet_state;

A2I __m256 seg_start(const packet_state *ps, __m256 kf, __m256 h) {
    /* segment k: [max(t0, t0+(k−1+j)·h), min(t0+(k+j)·h, t1)] */
    __m256 k1 = _mm256_add_ps(_mm256_sub_ps(kf, _mm256_set1_ps(1.0f)), ps->jit);
    return _mm256_max_ps(ps->t0, _mm256_add_ps(ps->t0, _mm256_mul_ps(k1, h)));
}

A2I __m256 sample_at_t(const vol_consts *vc, const packet_state *ps, __m256 t, volux_storage storage, cell8 *cell) {
    return sample8(vc, _mm256_add_ps(ps->q0[0], _mm256_mul_ps(ps->dq[0], t)),
                   _mm256_add_ps(ps->q0[1], _mm256_mul_ps(ps->dq[1], t)),
                   _mm256_add_ps(ps->q0[2], _mm256_mul_ps(ps->dq[2], t)), storage, cell);
}

A2I void march_packets(const dvr_state *st, const packet_rays pr[NP], const int lanes[NP], __m256 C[NP][3],
                       __m256 T_out[NP], uint64_t *samples, int shaded, int preint, volux_storage storage) {
    const volux_transfer_lut *lut = st->rc.lut;
    vol_consts vc;
    vol_consts_init(&vc, st->rc.volume);
    const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f);
    const __m256 h = _mm256_set1_ps(st->rc.step), inv_h = _mm256_set1_ps(1.0f / st->rc.step);
    const __m256 t_min = _mm256_set1_ps(st->t_min);
    const __m256 len_scale = _mm256_set1_ps(lut->inv_ds);
    const __m256 sign = _mm256_set1_ps(-0.0f);
    const __m256i lane_bits = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
    const int skip = st->skip_empty;
    packet_state P[NP];
    for (int p = 0; p < NP; p++) {
        packet_state *ps = &P[p];
        ps->t0 = _mm256_loadu_ps(pr[p].t0);
        ps->t1 = _mm256_loadu_ps(pr[p].t1);
        ps->jit = _mm256_loadu_ps(pr[p].jit);
        for (int a = 0; a < 3; a++) {
            ps->q0[a] = _mm256_loadu_ps(pr[p].q0[a]), ps->dq[a] = _mm256_loadu_ps(pr[p].dq[a]);
            ps->d[a] = _mm256_loadu_ps(pr[p].d[a]);
        }
        if (shaded) half_vectors(st, ps->d, ps->hn);
        ps->active = _mm256_castsi256_ps(
            _mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(lanes[p]), lane_bits), lane_bits));
        ps->active = _mm256_and_ps(ps->active, _mm256_cmp_ps(ps->t0, ps->t1, _CMP_LT_OQ));
        ps->kf = zero, ps->T = one;
        ps->C[0] = ps->C[1] = ps->C[2] = zero;
        ps->t_check = _mm256_set1_ps(skip ? -INFINITY : INFINITY);
        ps->need_prev = _mm256_castsi256_ps(_mm256_set1_epi32(-1));
        ps->warm = zero;
        ps->u_p = ps->f_p = zero;
        for (int c = 0; c < 4; c++) ps->P_p[c] = ps->D_p[c] = zero;
        ps->i_p = _mm256_setzero_si256();
        if (skip) {
            const int *cells = st->skip_cells;
            skip8 *sk = &ps->sk;
            sk->dist = st->skip_dist;
            for (int a = 0; a < 3; a++) {
                sk->cells_max[a] = _mm256_set1_epi32(cells[a] - 1);
                sk->up[a] = _mm256_castps_si256(_mm256_cmp_ps(ps->dq[a], zero, _CMP_GT_OQ));
                sk->flat[a] = _mm256_cmp_ps(ps->dq[a], zero, _CMP_EQ_OQ);
                sk->inv_dq[a] = _mm256_div_ps(one, ps->dq[a]);
            }
            sk->ncx = _mm256_set1_epi32(cells[0]);
            sk->ncy = _mm256_set1_epi32(cells[1]);
            /* Empty-space skipping. A lane whose next segment start has
             * left the cube of cells it last checked (t ≥ t_check) looks up
             * the skip distance there. In an empty cube it jumps to the last
             * segment m that starts inside it (m may reach into the next
             * cell, so it is still evaluated) and re-samples its start; in a
             * non-empty cube it marches on unchecked until the cube's exit.
             * The check for segment k+1 is issued while segment k is
             * sampled, so the gather's latency is hidden. This is the check
             * of segment 0. */
            __m256 t_exit, m;
            __m256 empty = check_cells(sk, ps->q0, ps->dq, ps->t0, ps->jit, inv_h, ps->t0, ps->active, &t_exit, &m);
            __m256 jump = _mm256_and_ps(empty, _mm256_cmp_ps(m, ps->kf, _CMP_GT_OQ));
            ps->kf = _mm256_blendv_ps(ps->kf, m, jump);
            ps->t_check = _mm256_blendv_ps(ps->t_check, t_exit, ps->active);
        }
    }
    uint64_t count = 0;
    for (;;) {
        __m256 a[NP], b[NP], len[NP], seg[NP], kf_next[NP], jump[NP], s[NP] = {zero, zero, zero, zero};
        cell8 cells[NP];
        int seg_bits[NP], any = 0;
        /* Phase 1: segment bounds, activity, the pipelined skip check. */
        for (int p = 0; p < NP; p++) {
            packet_state *ps = &P[p];
            a[p] = seg_start(ps, ps->kf, h);
            ps->active = _mm256_and_ps(ps->active, _mm256_cmp_ps(a[p], ps->t1, _CMP_LT_OQ));
            b[p] = _mm256_min_ps(_mm256_add_ps(ps->t0, _mm256_mul_ps(_mm256_add_ps(ps->kf, ps->jit), h)), ps->t1);
            len[p] = _mm256_sub_ps(b[p], a[p]);
            seg[p] = _mm256_and_ps(ps->active, _mm256_cmp_ps(len[p], zero, _CMP_GT_OQ));
            seg_bits[p] = _mm256_movemask_ps(seg[p]);
            any |= _mm256_movemask_ps(ps->active);
            kf_next[p] = _mm256_add_ps(ps->kf, one);
            jump[p] = zero;
            if (skip) {
                __m256 need = _mm256_and_ps(ps->active, _mm256_cmp_ps(b[p], ps->t_check, _CMP_GE_OQ));
                if (_mm256_movemask_ps(need)) {
                    __m256 t_exit, m;
                    __m256 empty =
                        check_cells(&ps->sk, ps->q0, ps->dq, ps->t0, ps->jit, inv_h, b[p], need, &t_exit, &m);
                    /* With pre-integration the lane lands one segment early,
                     * on m − 1 (inside the empty cube, contribution 0), and
                     * spends that iteration "warm": it samples the end of
                     * m − 1 = the start of m and composites nothing. Cheaper
                     * than an extra sampling pass for the whole packet
                     * whenever one lane jumps. */
                    if (preint) m = _mm256_sub_ps(m, one);
                    jump[p] = _mm256_and_ps(empty, _mm256_cmp_ps(m, kf_next[p], _CMP_GT_OQ));
                    kf_next[p] = _mm256_blendv_ps(kf_next[p], m, jump[p]);
                    ps->t_check = _mm256_blendv_ps(ps->t_check, t_exit, need);
                }
            }
        }
        if (!any) break;
        /* Phase 2: segment starts that must be sampled first (pre-integration:
         * the first segment, and after the first check at t0). Every lane
         * of the packet re-samples: for lanes that did not need it this is
         * the previous end at the same t, i.e. the identical value. */
        if (preint)
            for (int p = 0; p < NP; p++) {
                packet_state *ps = &P[p];
                int np = _mm256_movemask_ps(_mm256_and_ps(seg[p], ps->need_prev));
                if (!np) continue;
                lut_coord8(lut, sample_at_t(&vc, ps, a[p], storage, NULL), &ps->u_p, &ps->i_p, &ps->f_p);
                pre_record8(st->pre_f, ps->i_p, ps->P_p, ps->D_p);
                count += (uint64_t)__builtin_popcount((unsigned)np);
            }
        /* Phase 3: the samples at the segment ends. */
        for (int p = 0; p < NP; p++)
            if (seg_bits[p]) {
                s[p] = sample_at_t(&vc, &P[p], b[p], storage, shaded ? &cells[p] : NULL);
                count += (uint64_t)__builtin_popcount((unsigned)seg_bits[p]);
            }
        /* Phase 4: classification, pre-integration and compositing. */
        for (int p = 0; p < NP; p++) {
            packet_state *ps = &P[p];
            if (seg_bits[p]) {
                __m256 tau, cr, cg, cb, u, f;
                __m256i i;
                lut_coord8(lut, s[p], &u, &i, &f);
                if (preint) {
                    __m256 Pr[4], D[4], num[4];
                    pre_record8(st->pre_f, i, Pr, D);
                    __m256 same = _mm256_castsi256_ps(_mm256_cmpeq_epi32(i, ps->i_p));
                    __m256 fwd = _mm256_castsi256_ps(_mm256_cmpgt_epi32(i, ps->i_p));
                    for (int ch = 0; ch < 4; ch++) {
                        /* ΔI = (P_c − P_p) − f_p·D_p + f_c·D_c, summed so the
                         * cancelling pair goes first: P_c − P_p is exactly
                         * D_p (one interval up) or −D_c (one down), and the
                         * fused step with the lower end's f leaves only the
                         * exact tail, e.g. D_p − f_p·D_p, rounded once. */
                        __m256 x = _mm256_sub_ps(Pr[ch], ps->P_p[ch]);
                        __m256 up = _mm256_fmadd_ps(f, D[ch], _mm256_fnmadd_ps(ps->f_p, ps->D_p[ch], x));
                        __m256 down = _mm256_fnmadd_ps(ps->f_p, ps->D_p[ch], _mm256_fmadd_ps(f, D[ch], x));
                        num[ch] = _mm256_blendv_ps(_mm256_blendv_ps(down, up, fwd), D[ch], same);
                    }
                    /* ΔI and Δu share their sign; one interval: Δu := 1 */
                    __m256 du = _mm256_blendv_ps(_mm256_sub_ps(u, ps->u_p), one, same);
                    __m256 per_u = _mm256_div_ps(one, du);
                    tau = _mm256_mul_ps(_mm256_mul_ps(len[p], len_scale), _mm256_mul_ps(num[0], per_u));
                    __m256 ok = _mm256_cmp_ps(tau, zero, _CMP_GT_OQ);
                    __m256 inv = _mm256_and_ps(_mm256_div_ps(one, num[0]), ok);
                    cr = _mm256_mul_ps(num[1], inv);
                    cg = _mm256_mul_ps(num[2], inv);
                    cb = _mm256_mul_ps(num[3], inv);
                    ps->u_p = u, ps->f_p = f, ps->i_p = i;
                    for (int ch = 0; ch < 4; ch++) ps->P_p[ch] = Pr[ch], ps->D_p[ch] = D[ch];
                    ps->need_prev = _mm256_andnot_ps(seg[p], ps->need_prev);
                } else {
                    /* Colour and σt at s, linear between table nodes i, i+1
                     * (the 32 bytes at rgba[4i] hold both nodes). */
                    _Alignas(32) int32_t offs[8];
                    _mm256_store_si256((__m256i *)(void *)offs, _mm256_slli_epi32(i, 2));
                    __m256 o[8];
                    load_transpose8(lut->rgba, offs, o);
                    cr = lerp(o[0], o[4], f);
                    cg = lerp(o[1], o[5], f);
                    cb = lerp(o[2], o[6], f);
                    tau = _mm256_mul_ps(lerp(o[3], o[7], f), len[p]);
                }
                __m256 lit = _mm256_andnot_ps(ps->warm, _mm256_and_ps(seg[p], _mm256_cmp_ps(tau, zero, _CMP_GT_OQ)));
                if (shaded && _mm256_movemask_ps(lit)) {
                    __m256 g[3], c3[3] = {cr, cg, cb};
                    gradient8(st, &cells[p], g);
                    shade8(st, g, ps->d, (const __m256(*)[3])ps->hn, c3);
                    cr = c3[0], cg = c3[1], cb = c3[2];
                }
                __m256 alpha = _mm256_sub_ps(one, volux_exp_nonpos_cephes_avx2(_mm256_xor_ps(tau, sign)));
                __m256 w = _mm256_and_ps(_mm256_mul_ps(ps->T, alpha), lit);
                ps->C[0] = _mm256_add_ps(ps->C[0], _mm256_mul_ps(w, cr));
                ps->C[1] = _mm256_add_ps(ps->C[1], _mm256_mul_ps(w, cg));
                ps->C[2] = _mm256_add_ps(ps->C[2], _mm256_mul_ps(w, cb));
                ps->T = _mm256_sub_ps(ps->T, w);
                /* early termination: the scalar kernel stops when T < t_min */
                ps->active = _mm256_andnot_ps(_mm256_cmp_ps(ps->T, t_min, _CMP_LT_OQ), ps->active);
            }
            ps->warm = jump[p];
            ps->kf = kf_next[p];
        }
    }
    for (int p = 0; p < NP; p++) {
        for (int c = 0; c < 3; c++) C[p][c] = P[p].C[c];
        T_out[p] = P[p].T;
    }
    *samples += count;
}

/* Ray set-up for the lanes of one packet, exactly as the scalar kernel does
 * it per pixel (same RNG stream, camera ray and clip). Lanes outside the
 * tile or missing the volume are left inactive; the latter get the
 * background written here. Returns the active-lane bits. */
static A2 int setup_packet(const dvr_state *st, const volux_scene *scene, const volux_tile *tile, int x0, int y0,
                           float *rgb, packet_rays *pr, float bg[3][8]) {
    const volux_camera *cam = &st->rc.camera;
    memset(pr, 0, sizeof *pr);
    int lanes = 0;
    for (int l = 0; l < 8; l++) {
        int x = x0 + (l & (PW - 1)), y = y0 + l / PW;
        if (x >= tile->w || y >= tile->h) continue;
        volux_primary prim = volux_primary_ray(cam, st->rc.seed, tile->x0 + x, tile->y0 + y, tile->sample_index);
        const volux_vec3 d = prim.d;
        const float jitter = prim.jitter;
        volux_vec3 e = volux_scene_escape_radiance(scene, d);
        volux_ray ray;
        if (!volux_ray_clip(st->rc.volume, prim.o, d, &ray)) {
            float *out = &rgb[3 * (y * tile->w + x)];
            out[0] = e.x, out[1] = e.y, out[2] = e.z;
            continue;
        }
        bg[0][l] = e.x, bg[1][l] = e.y, bg[2][l] = e.z;
        pr->t0[l] = ray.t0;
        pr->t1[l] = ray.t1;
        pr->jit[l] = jitter;
        pr->q0[0][l] = ray.q0.x, pr->q0[1][l] = ray.q0.y, pr->q0[2][l] = ray.q0.z;
        pr->dq[0][l] = ray.dq.x, pr->dq[1][l] = ray.dq.y, pr->dq[2][l] = ray.dq.z;
        pr->d[0][l] = d.x, pr->d[1][l] = d.y, pr->d[2][l] = d.z;
        lanes |= 1 << l;
    }
    return lanes;
}

A2I void render_tile_impl(const dvr_state *st, const volux_scene *scene, const volux_tile *tile, float *rgb,
                          volux_tile_stats *stats, int shaded, int preint, volux_storage storage) {
    uint64_t samples = 0;
    /* NP packets stacked vertically: a PW × (NP·PH) = 4×8 pixel block */
    for (int y0 = 0; y0 < tile->h; y0 += NP * PH)
        for (int x0 = 0; x0 < tile->w; x0 += PW) {
            packet_rays pr[NP];
            float bg[NP][3][8];
            int lanes[NP], any = 0;
            for (int p = 0; p < NP; p++)
                any |= lanes[p] = setup_packet(st, scene, tile, x0, y0 + p * PH, rgb, &pr[p], bg[p]);
            if (!any) continue;
            __m256 C[NP][3], T[NP];
            march_packets(st, pr, lanes, C, T, &samples, shaded, preint, storage);
            for (int p = 0; p < NP; p++) {
                float c[3][8], t[8];
                for (int a = 0; a < 3; a++) _mm256_storeu_ps(c[a], C[p][a]);
                _mm256_storeu_ps(t, T[p]);
                for (int l = 0; l < 8; l++) {
                    if (!(lanes[p] >> l & 1)) continue;
                    float *out = &rgb[3 * ((y0 + p * PH + l / PW) * tile->w + x0 + (l & (PW - 1)))];
                    /* same expression as the scalar kernel: c + T·background */
                    out[0] = c[0][l] + t[l] * bg[p][0][l];
                    out[1] = c[1][l] + t[l] * bg[p][1][l];
                    out[2] = c[2][l] + t[l] * bg[p][2][l];
                }
            }
        }
    stats->samples += samples;
}

#define VOLUX_INSTANCE_(NAME, SH, PRE, STORE)                                                                         \
    static A2 __attribute__((noinline)) void NAME(const dvr_state *st, const volux_scene *scene,                      \
                                                  const volux_tile *tile, float *rgb, volux_tile_stats *stats) {      \
        render_tile_impl(st, scene, tile, rgb, stats, SH, PRE, STORE);                                                \
    }
VOLUX_INSTANCE_(ea_u8_pre, 0, 1, VOLUX_STORE_U8)
VOLUX_INSTANCE_(ea_u8, 0, 0, VOLUX_STORE_U8)
VOLUX_INSTANCE_(ea_u16_pre, 0, 1, VOLUX_STORE_U16)
VOLUX_INSTANCE_(ea_u16, 0, 0, VOLUX_STORE_U16)
VOLUX_INSTANCE_(ea_f32_pre, 0, 1, VOLUX_STORE_F32)
VOLUX_INSTANCE_(ea_f32, 0, 0, VOLUX_STORE_F32)
VOLUX_INSTANCE_(sh_u8_pre, 1, 1, VOLUX_STORE_U8)
VOLUX_INSTANCE_(sh_u8, 1, 0, VOLUX_STORE_U8)
VOLUX_INSTANCE_(sh_u16_pre, 1, 1, VOLUX_STORE_U16)
VOLUX_INSTANCE_(sh_u16, 1, 0, VOLUX_STORE_U16)
VOLUX_INSTANCE_(sh_f32_pre, 1, 1, VOLUX_STORE_F32)
VOLUX_INSTANCE_(sh_f32, 1, 0, VOLUX_STORE_F32)
#undef VOLUX_INSTANCE_

typedef void (*tile_fn)(const dvr_state *, const volux_scene *, const volux_tile *, float *, volux_tile_stats *);

A2 void volux_dvr_render_tile_avx2(const dvr_state *st, const volux_scene *scene, const volux_tile *tile, float *rgb,
                                   volux_tile_stats *stats) {
    static const tile_fn table[2][2][3] = {
        {{ea_u8, ea_u16, ea_f32}, {ea_u8_pre, ea_u16_pre, ea_f32_pre}},
        {{sh_u8, sh_u16, sh_f32}, {sh_u8_pre, sh_u16_pre, sh_f32_pre}},
    };
    int storage = st->rc.volume->storage == VOLUX_STORE_U8 ? 0 : st->rc.volume->storage == VOLUX_STORE_U16 ? 1 : 2;
    /* Flush denormals to zero while this worker renders: transmittance
     * products underflow on long opaque rays, and denormal arithmetic costs
     * ~100 cycles per operation. Restored before returning, so the caller's
     * floating-point environment is unchanged. */
    unsigned int csr = _mm_getcsr();
    _mm_setcsr(csr | 0x8040u); /* FTZ | DAZ */
    table[st->shaded ? 1 : 0][st->preintegrate ? 1 : 0][storage](st, scene, tile, rgb, stats);
    _mm_setcsr(csr);
}

#else /* no AVX2 code on this target: the scalar kernel is used */

void volux_dvr_render_tile_avx2(const dvr_state *st, const volux_scene *scene, const volux_tile *tile, float *rgb,
                                volux_tile_stats *stats) {
    (void)st, (void)scene, (void)tile, (void)rgb, (void)stats;
}

#endif
