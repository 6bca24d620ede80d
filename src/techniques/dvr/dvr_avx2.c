/*
 * techniques/dvr/dvr_avx2.c — the `ea` / `shaded` packet ray caster
 * (dvr_simd_impl.h) on 8 lanes with AVX2+FMA, over the lane vocabulary of
 * render/lanes_avx2.h (__m256 and vector masks, the reads in their AVX2
 * form; shared with the illuminated techniques' packet march). Compiled
 * with target attributes and chosen at run time (volux_dvr_simd_available),
 * so the default build runs on any x86-64.
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

int volux_dvr_simd_available(void) { return volux_cpu_has_avx2_fma(); }

#if VOLUX_X86_GNUC

#include "render/lanes_avx2.h"

#define DVR_W LANE_W
#define DVR_NP 4 /* 4 × 8 lanes: see march_tile */
#define DVR_TARGET LANE_TARGET

#include "dvr_simd_impl.h"

DVR_TARGET void volux_dvr_render_tile_avx2(const dvr_state *st, const volux_scene *scene, const volux_tile *tile,
                                           float *rgb, volux_tile_stats *stats) {
    /* Flush denormals to zero while this worker renders: transmittance
     * products underflow on long opaque rays, and denormal arithmetic costs
     * ~100 cycles per operation. Restored before returning, so the caller's
     * floating-point environment is unchanged. */
    unsigned int csr = _mm_getcsr();
    _mm_setcsr(csr | 0x8040u); /* FTZ | DAZ */
    pick_tile_fn(st)(st, scene, tile, rgb, stats);
    _mm_setcsr(csr);
}

#else /* no AVX2 code on this target: the scalar kernel is used */

void volux_dvr_render_tile_avx2(const dvr_state *st, const volux_scene *scene, const volux_tile *tile, float *rgb,
                                volux_tile_stats *stats) {
    (void)st, (void)scene, (void)tile, (void)rgb, (void)stats;
}

#endif
