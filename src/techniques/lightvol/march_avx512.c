/* techniques/lightvol/march_avx512.c — lightvol's camera march as 16-lane
 * AVX-512 packets (march_lanes.h over render/packet_impl.h), chosen at
 * run time (render/packet.h). */
#include <math.h>
#include <string.h>

#include "lightvol.h"

#if VOLUX_X86_GNUC
#include "render/lanes_avx512.h"
#include "march_lanes.h"

void volux_lightvol_march_avx512(const volux_packet_march *pm, const void *tech, const volux_scene *scene,
                               const volux_tile *tile, float *rgb, volux_tile_stats *stats) {
    lv_packet_tile(pm, tech, scene, tile, rgb, stats);
}
#else
void volux_lightvol_march_avx512(const volux_packet_march *pm, const void *tech, const volux_scene *scene,
                               const volux_tile *tile, float *rgb, volux_tile_stats *stats) {
    (void)pm, (void)tech, (void)scene, (void)tile, (void)rgb, (void)stats;
}
#endif
