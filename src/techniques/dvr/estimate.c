/* techniques/dvr/estimate.c — the memory model of `ea` and `shaded`
 * (docs/SCALE.md): the bricked copy of the volume (1.42 B per voxel of
 * uint8 data), 9 B per 4³ skip cell (value range + distance), the float
 * pre-integration table (32 B per TF entry); `shaded` with
 * gradient "cached" adds the gradient cache (5.7 B/voxel) and
 * volume_layout "corner_words" 8 B per cell of uint8 data. */
#include <string.h>

#include "core/volume_internal.h"
#include "dvr.h"
#include "render/memory_model.h"

uint64_t volux_dvr_estimate_bytes(const volux_scene *scene, const volux_technique_class *cls, uint64_t *volume_added) {
    int d[3];
    volux_mm_dims(scene, d);
    *volume_added += volux_mm_bricks_to_build(scene);
    uint64_t bricks = 1;
    for (int a = 0; a < 3; a++) {
        int b = (d[a] - 1 + VOLUX_BRICK_CELLS - 1) / VOLUX_BRICK_CELLS;
        bricks *= (uint64_t)(b < 1 ? 1 : b);
    }
    uint64_t n = volux_mm_packet_tables_bytes(scene);
    if (cls == &volux_shaded_class && !strcmp(volux_technique_param_string(scene, cls, "gradient"), "cached"))
        n += volux_mm_gradient_bytes(d);
    const volux_volume *v = volux_scene_volume(scene);
    uint64_t corners = bricks * VOLUX_BRICK_CELLS * VOLUX_BRICK_CELLS * VOLUX_BRICK_CELLS * sizeof(uint64_t);
    if (!strcmp(volux_technique_param_string(scene, cls, "volume_layout"), "corner_words") && v &&
        v->storage == VOLUX_STORE_U8 && corners <= DVR_CORNER_WORDS_MAX_BYTES)
        n += corners;
    return n;
}
