/*
 * techniques/dvr/dvr_avx512.c — the `ea` / `shaded` packet ray caster
 * (dvr_simd_impl.h) on 16 lanes with AVX-512 (F, BW, DQ, VL) and FMA, over
 * the lane vocabulary of render/lanes_avx512.h (__m512 and mask registers,
 * the reads in their AVX-512 form). Compiled with target attributes and chosen at run time
 * (volux_dvr_avx512_available) before the AVX2 kernel; `kernel: "avx2"`
 * forces the 8-lane one.
 *
 * Why a second width: the per-sample work is instruction-throughput bound
 * once four packets hide the latencies (docs/BENCHMARKS.md), and 16 lanes
 * with mask registers do it in fewer instructions (no blends, masked
 * gathers of 16, an expand for the ray-list refill).
 *
 * BIT-IDENTICAL to dvr_avx2.c: every vocabulary operation is the same IEEE
 * operation lane by lane (fused where the AVX2 one is fused, nowhere
 * else; sqrt and division, not the rcp/rsqrt estimates), so the two widths
 * give the same image (tests/invariants/test_ea_fastpath.c).
 *
 * DOES NOT: shade with point, spot or sphere lights (scalar kernel).
 */
#include <math.h>
#include <string.h>

#include "core/camera_rays.h"
#include "core/rng.h"
#include "core/simd.h"
#include "core/vecmath.h"
#include "dvr.h"
#include "sample/primary.h"
#include "volux/render.h"

int volux_dvr_avx512_available(void) {
    return volux_dvr_simd_available() && volux_cpu_has_avx512f() && VOLUX_CPU_HAS("avx512bw") &&
           VOLUX_CPU_HAS("avx512dq") && VOLUX_CPU_HAS("avx512vl");
}

#if VOLUX_X86_GNUC

#include "render/lanes_avx512.h"

#define DVR_W LANE_W
#define DVR_NP 4 /* 4 × 16 lanes: see march_tile (2 packets measured slower) */
#define DVR_TARGET LANE_TARGET

#include "dvr_simd_impl.h"

DVR_TARGET void volux_dvr_render_tile_avx512(const dvr_state *st, const volux_scene *scene, const volux_tile *tile,
                                             float *rgb, volux_tile_stats *stats) {
    /* FTZ | DAZ while this worker renders, as in dvr_avx2.c (MXCSR governs
     * the 512-bit operations too); restored before returning. */
    unsigned int csr = _mm_getcsr();
    _mm_setcsr(csr | 0x8040u);
    pick_tile_fn(st)(st, scene, tile, rgb, stats);
    _mm_setcsr(csr);
}

#else /* no AVX-512 code on this target: volux_dvr_avx512_available() is 0 */

void volux_dvr_render_tile_avx512(const dvr_state *st, const volux_scene *scene, const volux_tile *tile, float *rgb,
                                  volux_tile_stats *stats) {
    (void)st, (void)scene, (void)tile, (void)rgb, (void)stats;
}

#endif
