/* techniques/ao/march_avx512.c — ao's camera march as 16-lane AVX-512 packets
 * (march_lanes.h over render/packet_impl.h), chosen at run time
 * (render/packet.h). */
#include <math.h>
#include <string.h>

#include "ao.h"

#if VOLUX_X86_GNUC
#include "render/lanes_avx512.h"
#include "march_lanes.h"

void volux_ao_march_avx512(const volux_packet_march *pm, const void *tech, const volux_scene *scene,
                          const volux_tile *tile, float *rgb, volux_tile_stats *stats) {
    ao_packet_tile(pm, tech, scene, tile, rgb, stats);
}

LANE_TARGET void volux_ao_near_slice_avx512(const ao_dir_job *j, int z) { ao_near_lanes(j, z); }
LANE_TARGET void volux_ao_far_slice_avx512(const ao_dir_job *j, int z) { ao_far_lanes(j, z); }
#else
void volux_ao_march_avx512(const volux_packet_march *pm, const void *tech, const volux_scene *scene,
                          const volux_tile *tile, float *rgb, volux_tile_stats *stats) {
    (void)pm, (void)tech, (void)scene, (void)tile, (void)rgb, (void)stats;
}
void volux_ao_near_slice_avx512(const ao_dir_job *j, int z) { (void)j, (void)z; }
void volux_ao_far_slice_avx512(const ao_dir_job *j, int z) { (void)j, (void)z; }
#endif
