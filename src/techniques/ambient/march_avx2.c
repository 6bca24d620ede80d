/* techniques/ambient/march_avx2.c — ambient's camera march as 8-lane AVX2+FMA
 * packets (render/packet_impl.h), chosen at run time (render/packet.h).
 * Only for offset 0 (lag 0: no ring of past segments in the packets);
 * the hook calls the scalar per-sample shading (inscatter) per lane, not
 * converted to lanes yet. */
#include <math.h>
#include <string.h>

#include "ambient.h"

#if VOLUX_X86_GNUC
#include "render/lanes_avx2.h"
#include "render/packet_impl.h"

DI void ambient_hook(const void *tech, const pk_lanes *L, vm lit, vf c[3]) {
    pk_shade_per_lane(tech, L, lit, c, volux_ambient_shade_lane);
}

VOLUX_PACKET_TILE(ambient_packet_tile, ambient_hook)

void volux_ambient_march_avx2(const volux_packet_march *pm, const void *tech, const volux_scene *scene,
                             const volux_tile *tile, float *rgb, volux_tile_stats *stats) {
    ambient_packet_tile(pm, tech, scene, tile, rgb, stats);
}
#else
void volux_ambient_march_avx2(const volux_packet_march *pm, const void *tech, const volux_scene *scene,
                             const volux_tile *tile, float *rgb, volux_tile_stats *stats) {
    (void)pm, (void)tech, (void)scene, (void)tile, (void)rgb, (void)stats;
}
#endif
