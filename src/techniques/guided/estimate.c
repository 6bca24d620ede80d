/* techniques/guided/estimate.c — the memory model of `guided`
 * (docs/SCALE.md): the visibility grid, one 16-bit visibility per
 * `cell`³ voxels per direction of the directions² set (2 B/voxel at the
 * defaults, cell 4 and 8² directions), and the environment quadtree —
 * both only with an environment light. */
#include "guided.h"
#include "render/memory_model.h"

uint64_t volux_guided_estimate_bytes(const volux_scene *scene, const volux_technique_class *cls,
                                     uint64_t *volume_added) {
    (void)volume_added;
    int d[3];
    volux_mm_dims(scene, d);
    int cell = (int)volux_technique_param(scene, cls, "cell"), res = (int)volux_technique_param(scene, cls, "directions");
    uint64_t cells = 1, dirs = (uint64_t)res * (uint64_t)res;
    for (int a = 0; a < 3; a++) {
        int c = (d[a] - 1 + cell - 1) / cell;
        cells *= (uint64_t)(c < 1 ? 1 : c);
    }
    volux_mm_lights l = volux_mm_count_lights(scene);
    /* Only the environment's light sample reads the grid: without an
     * environment light it is not built (guided.c). The quadtree over the
     * environment map: 4/3 of its texels in floats. */
    if (!l.env) return 0;
    return cells * dirs * sizeof(uint16_t) + dirs * sizeof(int) + l.env_texels * 4 / 3 * sizeof(float);
}
