/* techniques/single/estimate.c — the memory model of `single`
 * (docs/SCALE.md): with the transmittance cache, one float grid at
 * cache_scale per enabled non-environment light (4·scale³ B/voxel each)
 * and, when an environment is lit, env_directions grids at half that
 * scale; the per-slot records; the packet march's tables (and bricked
 * copy) when it marches packets. */
#include "render/memory_model.h"
#include "single.h"

uint64_t volux_single_estimate_bytes(const volux_scene *scene, const volux_technique_class *cls,
                                     uint64_t *volume_added) {
    int d[3];
    volux_mm_dims(scene, d);
    volux_mm_lights l = volux_mm_count_lights(scene);
    uint64_t n = (uint64_t)l.slots * sizeof(single_slot) + volux_mm_packet_march_bytes(scene, cls, 1, volume_added);
    if (!(int)volux_technique_param(scene, cls, "transmittance_cache")) return n;
    double scale = volux_technique_param(scene, cls, "cache_scale");
    n += (uint64_t)l.direct * volux_mm_grid_nodes(d, (float)scale) * sizeof(float);
    int dirs = (int)volux_technique_param(scene, cls, "env_directions");
    double env_scale = scale * 0.5 < 0.05 ? 0.05 : scale * 0.5;
    if (l.env && dirs > 0) n += (uint64_t)dirs * volux_mm_grid_nodes(d, (float)env_scale) * sizeof(float);
    return n;
}
