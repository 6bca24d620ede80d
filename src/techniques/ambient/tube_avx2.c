/*
 * techniques/ambient/tube_avx2.c — the tube kernels (tube_simd_impl.h) on
 * 8 nodes at a time with AVX2: the lane operations for __m256 and the
 * reads in their AVX2 form. Compiled with target attributes and chosen at
 * run time, so the default build runs on any x86-64.
 *
 * Target "avx2" without "fma", so nothing can be contracted: the kernels
 * must stay BIT-IDENTICAL to the scalar path (see tube_simd_impl.h).
 * Masks are vectors with all bits of a lane set (what blendv, movemask and
 * the masked loads and gathers read is the sign bit).
 */
#include "core/simd.h"
#include "tube_simd.h"

#if VOLUX_X86_GNUC
#include <math.h>

#define TUBE_W 8
#define TUBE_VACUUM_CHAINS 0 /* AVX-512 only (tube.h: tube_geometry) */
#define TUBE_TARGET __attribute__((target("avx2")))
#define TI static inline __attribute__((always_inline, target("avx2")))

typedef __m256 vf;
typedef __m256i vi;
typedef __m256 vm;
#define TUBE_MM(op) _mm256_##op
#define TUBE_CMP(a, b, p) _mm256_cmp_ps(a, b, p)

#include "tube_simd_impl.h"

TI vf f_abs(vf a) { return _mm256_and_ps(a, _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff))); }
TI vm f_sign(vf a) { return _mm256_castsi256_ps(_mm256_srai_epi32(_mm256_castps_si256(a), 31)); }
TI vf f_set_sign(vf a, vm m) { return _mm256_or_ps(a, _mm256_and_ps(m, _mm256_set1_ps(-0.0f))); }
TI vf sel(vm m, vf a, vf b) { return _mm256_blendv_ps(b, a, m); }
TI vi lane_ids(void) { return _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7); }
TI int i_lane0(vi a) { return _mm_cvtsi128_si32(_mm256_castsi256_si128(a)); }
TI int i_all(vi m) { return _mm256_movemask_epi8(m) == -1; }
TI vi i_bcast0(vi a) { return _mm256_broadcastd_epi32(_mm256_castsi256_si128(a)); }
TI vm m_first(int n) { return _mm256_castsi256_ps(_mm256_cmpgt_epi32(_mm256_set1_epi32(n), lane_ids())); }
TI vm m_and(vm a, vm b) { return _mm256_and_ps(a, b); }
TI vm m_or(vm a, vm b) { return _mm256_or_ps(a, b); }
TI vm m_andnot(vm a, vm b) { return _mm256_andnot_ps(a, b); }
TI int m_any(vm m) { return _mm256_movemask_ps(m) != 0; }
TI int m_covers(vm m, vm valid) { return _mm256_movemask_ps(_mm256_andnot_ps(m, valid)) == 0; }

/* Full vectors load and store plainly (AVX2's masked moves are slower). */
TI vf f_load_first(const float *p, int n) {
    if (n == 8) return _mm256_loadu_ps(p);
    float tmp[8] = {0, 0, 0, 0, 0, 0, 0, 0};
    for (int l = 0; l < n; l++) tmp[l] = p[l];
    return _mm256_loadu_ps(tmp);
}
TI void f_store_first(float *p, vf v, int n) {
    if (n == 8) {
        _mm256_storeu_ps(p, v);
        return;
    }
    float tmp[8];
    _mm256_storeu_ps(tmp, v);
    for (int l = 0; l < n; l++) p[l] = tmp[l];
}
TI vf f_load_masked(const float *p, vm k, int full) {
    return full ? _mm256_loadu_ps(p) : _mm256_maskload_ps(p, _mm256_castps_si256(k));
}
TI void f_store_masked(float *p, vf v, vm k, int full) {
    if (full) _mm256_storeu_ps(p, v);
    else _mm256_maskstore_ps(p, _mm256_castps_si256(k), v);
}

TI void kappa_pair(const float *kappa, vi j, vm k, vf *k0, vf *k1) {
    *k0 = _mm256_mask_i32gather_ps(_mm256_setzero_ps(), kappa, j, k, 4);
    *k1 = _mm256_mask_i32gather_ps(_mm256_setzero_ps(), kappa, i_add(j, i_set(1)), k, 4);
}

/* Row reads. When the 8 lanes' cells have consecutive indices (lane 0's +
 * lane: along a run in x the read points advance by about one cell per
 * node, so this is the common case of the shells' rows and of the
 * directional sweep's rows), every corner of a trilinear read is at lane
 * 0's address + a common offset + lane: one contiguous 8-float load per
 * corner instead of a gather, and each loaded element is one that some
 * lane reads anyway. */
TI int consecutive(vi base) { return i_all(_mm256_cmpeq_epi32(base, i_add(i_bcast0(base), lane_ids()))); }

/* the clamped read: row loads for consecutive cells, else gathers */
TI vf sample_clamped(const float *v, const lane_grid *g, const vf p[3]) {
    vf f[3], a[8];
    vi c[3];
    clamped_cell(g, p, c, f);
    vi b = cell_index(g, c);
    if (consecutive(b)) {
        row_corners(v + i_lane0(b), g->nx, g->nxy, a);
        return trilerp(a, f);
    }
    const vi one = i_set(1), by = i_add(b, g->sy), bz = i_add(b, g->sz), byz = i_add(by, g->sz);
    const vi idx[8] = {b, i_add(b, one), by, i_add(by, one), bz, i_add(bz, one), byz, i_add(byz, one)};
    for (int q = 0; q < 8; q++) a[q] = _mm256_i32gather_ps(v, idx[q], 4);
    return trilerp(a, f);
}

/* the strict corners (others 0, no load) */
TI vf strict_at(const float *v, const lane_grid *g, const vi c[3], const vf f[3], vm mask) {
    vi up[3], b = cell_index(g, c);
    vf a[8];
    for (int ax = 0; ax < 3; ax++) up[ax] = _mm256_castps_si256(f_gt(f[ax], f_zero()));
    /* Row reads when every lane is wanted, the indices are consecutive and
     * the upper y and z corners are the same for all lanes: every loaded
     * element is then a corner some lane reads — lane 7's upper x corner
     * only if its fraction is > 0 (checked); a lane whose x fraction is 0
     * gets lane + 1's lower corner as its upper one, with weight 0: the
     * same result. */
    if (_mm256_movemask_ps(mask) == 0xff && _mm256_extract_epi32(up[0], 7) && consecutive(b) &&
        i_all(_mm256_cmpeq_epi32(up[1], i_bcast0(up[1]))) && i_all(_mm256_cmpeq_epi32(up[2], i_bcast0(up[2])))) {
        row_corners(v + i_lane0(b), i_lane0(up[1]) ? g->nx : 0, i_lane0(up[2]) ? g->nxy : 0, a);
        return trilerp(a, f);
    }
    vi ox = _mm256_and_si256(up[0], i_set(1));
    vi oy = _mm256_and_si256(up[1], g->sy), oz = _mm256_and_si256(up[2], g->sz);
    vi by = i_add(b, oy), bz = i_add(b, oz), byz = i_add(by, oz);
    const vi idx[8] = {b, i_add(b, ox), by, i_add(by, ox), bz, i_add(bz, ox), byz, i_add(byz, ox)};
    for (int q = 0; q < 8; q++) a[q] = _mm256_mask_i32gather_ps(f_zero(), v, idx[q], mask, 4);
    return trilerp(a, f);
}

const tube_kernels *tube_kernels_avx2(void) { return volux_cpu_has_avx2() ? &kernels : NULL; }

#else /* no AVX2 on this target: tube.c uses its scalar node update */

const tube_kernels *tube_kernels_avx2(void) { return NULL; }

#endif
