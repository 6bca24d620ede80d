/* techniques/manylights/estimate.c — the memory model of `manylights`
 * (docs/SCALE.md): independent of the volume but for its majorant grid,
 * it is dominated by the virtual lights' adaptive volumetric shadow maps,
 * 6 faces × avsm_resolution² texels × avsm_nodes 32-bit nodes per VL
 * (307 kB at the defaults, 307 MB for vl_count 1000), plus the VL records,
 * the render list and the τ decode table; the bricked copy of the volume. */
#include "manylights.h"
#include "render/memory_model.h"

uint64_t volux_manylights_estimate_bytes(const volux_scene *scene, const volux_technique_class *cls,
                                         uint64_t *volume_added) {
    *volume_added += volux_mm_bricks_to_build(scene); /* AVSM rays read the bricked copy */
    int d[3];
    volux_mm_dims(scene, d);
    uint64_t vl = (uint64_t)volux_technique_param(scene, cls, "vl_count");
    uint64_t res = (uint64_t)volux_technique_param(scene, cls, "avsm_resolution"),
             nodes = (uint64_t)volux_technique_param(scene, cls, "avsm_nodes");
    volux_mm_lights l = volux_mm_count_lights(scene);
    /* vl_count is shared among the lights; a set ends on a whole subpath,
     * about two VLs past its share */
    int sets = l.direct + l.env;
    vl = sets ? vl + 2 * (uint64_t)sets : 0;
    uint64_t bytes = volux_mm_macrocells(d) * sizeof(float) + (uint64_t)volux_mm_lut_entries(scene) * 52 +
                     vl * (sizeof(ml_vl) + sizeof(ml_rvl) + sizeof(int)) + (uint64_t)l.slots * sizeof(ml_set);
    /* the maps are built whatever `transmittance` reads */
    bytes += vl * 6 * res * res * nodes * sizeof(uint32_t) + ML_TAU_CODES * sizeof(float);
    return bytes;
}
