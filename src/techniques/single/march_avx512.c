/* techniques/single/march_avx512.c — single's camera march as 16-lane AVX-512
 * packets (render/packet_impl.h), chosen at run time (render/packet.h).
 * The hook calls the scalar per-sample shading per lane: its transmittance
 * lookups march a near field first (cached_transmittance, over the
 * majorant grid), which has no lane form yet. */
#include <math.h>
#include <string.h>

#include "single.h"

#if VOLUX_X86_GNUC
#include "render/lanes_avx512.h"
#include "render/packet_impl.h"

DI void single_hook(const void *tech, const pk_lanes *L, vm lit, vf c[3]) {
    pk_shade_per_lane(tech, L, lit, c, volux_single_shade_lane);
}

VOLUX_PACKET_TILE(single_packet_tile, single_hook)

void volux_single_march_avx512(const volux_packet_march *pm, const void *tech, const volux_scene *scene,
                             const volux_tile *tile, float *rgb, volux_tile_stats *stats) {
    single_packet_tile(pm, tech, scene, tile, rgb, stats);
}
#else
void volux_single_march_avx512(const volux_packet_march *pm, const void *tech, const volux_scene *scene,
                             const volux_tile *tile, float *rgb, volux_tile_stats *stats) {
    (void)pm, (void)tech, (void)scene, (void)tile, (void)rgb, (void)stats;
}
#endif
