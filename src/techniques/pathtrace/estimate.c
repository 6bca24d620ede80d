/* techniques/pathtrace/estimate.c — the memory model of `pathtrace`
 * (docs/SCALE.md): nothing per voxel beyond the shared majorant grid; an
 * importance sampler per environment map (a 2-D distribution: its
 * conditional and marginal CDFs, ≈ 8 B per texel). */
#include "pathtrace.h"
#include "render/memory_model.h"

uint64_t volux_pathtrace_estimate_bytes(const volux_scene *scene, const volux_technique_class *cls,
                                        uint64_t *volume_added) {
    (void)cls;
    (void)volume_added;
    volux_mm_lights l = volux_mm_count_lights(scene);
    return l.env_texels * 8 + (uint64_t)l.slots * 64;
}
