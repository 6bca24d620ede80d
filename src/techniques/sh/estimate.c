/* techniques/sh/estimate.c — the memory model of `sh` (docs/SCALE.md):
 * on the coefficient grid (every `downsample`-th node per axis, 1/27 of
 * the voxels by default) the projection (bands² floats per channel: 64 B
 * for 4 bands, grey) and the baked shade (16 B); with env_product and an
 * environment light the product matrices (3·16 floats); the bricked copy
 * of the volume; with delta_shadows (shadows only) one float per node and
 * direct light (the delta lights' transmittance). The BRDF tables (a few hundred kB per material) and the
 * gradient cache of BRDF materials are not modelled. */
#include "render/memory_model.h"
#include "sh.h"

uint64_t volux_sh_estimate_bytes(const volux_scene *scene, const volux_technique_class *cls, uint64_t *volume_added) {
    int d[3];
    volux_mm_dims(scene, d);
    *volume_added += volux_mm_bricks_to_build(scene);
    int r = (int)volux_technique_param(scene, cls, "downsample");
    uint64_t nodes = 1;
    for (int a = 0; a < 3; a++) nodes *= (uint64_t)((d[a] - 1 + r - 1) / r + 1);
    int bands = (int)volux_technique_param(scene, cls, "bands"),
        chroma = (int)volux_technique_param(scene, cls, "chroma_bands");
    int rgb = (int)volux_technique_param(scene, cls, "bleeding") || (int)volux_technique_param(scene, cls, "scattering");
    int cb = chroma > 0 ? (chroma < bands ? chroma : bands) : bands;
    uint64_t stride = rgb ? (uint64_t)(bands * bands + 2 * cb * cb) : (uint64_t)(bands * bands);
    uint64_t per_node = stride * sizeof(float) + 4 * sizeof(float);
    volux_mm_lights l = volux_mm_count_lights(scene);
    if (l.env && (int)volux_technique_param(scene, cls, "env_product")) per_node += 3 * SH_MAX_COEFFS * sizeof(float);
    if (!rgb && (int)volux_technique_param(scene, cls, "delta_shadows")) per_node += (uint64_t)l.direct * sizeof(float);
    return nodes * per_node;
}
