/* render/memory_model.c — see memory_model.h. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "core/context_internal.h"
#include "core/volume_internal.h"
#include "lights.h"
#include "memory_model.h"
#include "packet.h"
#include "volux/render.h"

void volux_mm_dims(const volux_scene *scene, int dims[3]) {
    const volux_volume *v = volux_scene_volume(scene);
    for (int a = 0; a < 3; a++) dims[a] = v ? v->dims[a] : 1;
}

uint64_t volux_mm_voxels(const volux_scene *scene) {
    int d[3];
    volux_mm_dims(scene, d);
    return (uint64_t)d[0] * (uint64_t)d[1] * (uint64_t)d[2];
}

uint64_t volux_mm_gradient_bytes(const int dims[3]) {
    uint64_t nb = 1;
    for (int a = 0; a < 3; a++) {
        int n = (dims[a] - 1 + VOLUX_BRICK_CELLS - 1) / VOLUX_BRICK_CELLS;
        nb *= (uint64_t)(n < 1 ? 1 : n);
    }
    return nb * VOLUX_BRICK_VOXELS * sizeof(uint32_t);
}

uint64_t volux_mm_grid_nodes(const int dims[3], double scale) {
    uint64_t n = 1;
    for (int a = 0; a < 3; a++) {
        int m = dims[a] == 1 ? 1 : (int)ceil((double)(dims[a] - 1) * scale - 1e-4) + 1;
        if (m < 2 && dims[a] > 1) m = 2;
        n *= (uint64_t)m;
    }
    return n;
}

volux_mm_lights volux_mm_count_lights(const volux_scene *scene) {
    volux_mm_lights n = {0, 0, 0, 0};
    n.slots = volux_scene_light_slots(scene);
    for (int s = 0; s < n.slots; s++) {
        const volux_light_desc *d = volux_scene_light(scene, s);
        if (!d || !d->enabled) continue;
        if (d->type == VOLUX_LIGHT_ENVIRONMENT) {
            n.env++;
            if (d->map) n.env_texels += (uint64_t)d->map->width * (uint64_t)d->map->height;
        } else {
            n.direct++;
        }
    }
    return n;
}

uint64_t volux_mm_bricks_to_build(const volux_scene *scene) {
    const volux_volume *v = volux_scene_volume(scene);
    /* out of core: the bricked copy is a file mapping, not memory */
    return v && !v->bricks && !v->mapped ? v->brick_bytes : 0;
}

uint64_t volux_mm_packet_tables_bytes(const volux_scene *scene) {
    int d[3];
    volux_mm_dims(scene, d);
    uint64_t cells = 1;
    for (int a = 0; a < 3; a++) {
        int c = (d[a] - 1 + VOLUX_PACKET_SKIP_CELL - 1) / VOLUX_PACKET_SKIP_CELL;
        cells *= (uint64_t)(c < 1 ? 1 : c);
    }
    return (uint64_t)volux_mm_lut_entries(scene) * 8 * sizeof(float) + cells * 2 * sizeof(float) + cells + 3;
}

uint64_t volux_mm_packet_march_bytes(const volux_scene *scene, const volux_technique_class *cls, int usable,
                                     uint64_t *volume_added) {
    /* volux_packet_kernel_choose's rule, without a context to report to */
    if (!usable || !volux_packet_avx2_available() ||
        !strcmp(volux_technique_param_string(scene, cls, "march_kernel"), "scalar"))
        return 0;
    if (volume_added) *volume_added += volux_mm_bricks_to_build(scene);
    return volux_mm_packet_tables_bytes(scene);
}

int volux_mm_lut_entries(const volux_scene *scene) {
    const volux_transfer_lut *lut = volux_scene_transfer_lut(scene);
    return lut ? lut->n : 0;
}

uint64_t volux_mm_macrocells(const int dims[3]) {
    uint64_t n = 1;
    for (int a = 0; a < 3; a++) {
        int c = (dims[a] - 1 + VOLUX_CELL_SIZE - 1) / VOLUX_CELL_SIZE;
        n *= (uint64_t)(c < 1 ? 1 : c);
    }
    return n;
}

void volux_memory_estimate_class(const volux_technique_class *cls, const volux_scene *scene,
                                 volux_memory_estimate *out) {
    const volux_volume *v = volux_scene_volume(scene);
    const volux_render_settings *rs = volux_scene_render(scene);
    int dims[3];
    volux_mm_dims(scene, dims);
    uint64_t px = (uint64_t)(rs->width > 0 ? rs->width : 0) * (uint64_t)(rs->height > 0 ? rs->height : 0);
    uint64_t slots = (uint64_t)volux_scene_light_slots(scene);
    out->volume = v ? volux_volume_memory_bytes(v) : 0;
    /* the state block, the majorant grid (one float per macrocell), the
     * prepared lights (two lists) and the per-slot warning stamps; the
     * instance header is a few dozen bytes */
    out->instance = cls->state_size + volux_mm_macrocells(dims) * sizeof(float) +
                    slots * (2 * sizeof(volux_prepared_light) + sizeof(uint32_t)) + 64;
    uint64_t added = 0;
    out->technique = cls->estimate_bytes ? cls->estimate_bytes(scene, cls, &added) : 0;
    out->volume += added;
    uint64_t tiles = ((uint64_t)(rs->width > 0 ? rs->width : 0) + VOLUX_TILE_SIZE - 1) / VOLUX_TILE_SIZE *
                     (((uint64_t)(rs->height > 0 ? rs->height : 0) + VOLUX_TILE_SIZE - 1) / VOLUX_TILE_SIZE);
    out->framebuffer = px * VOLUX_MM_FRAMEBUFFER_PER_PIXEL + tiles * sizeof(uint32_t);
    out->image = px * VOLUX_MM_IMAGE_PER_PIXEL;
    out->total = out->volume + out->instance + out->technique + out->framebuffer + out->image;
}

int volux_context_memory_limit_is_default(const volux_context *ctx) { return ctx->memory_limit == 0; }

volux_status volux_memory_check(volux_context *ctx, const char *who, const volux_memory_estimate *e) {
    uint64_t limit = volux_context_memory_limit(ctx);
    if (e->total <= limit) return VOLUX_OK;
    char t[32], l[32], vol[32], tech[32], fb[32];
    volux_format_bytes(e->total, t, sizeof t);
    volux_format_bytes(limit, l, sizeof l);
    volux_format_bytes(e->volume, vol, sizeof vol);
    volux_format_bytes(e->instance + e->technique, tech, sizeof tech);
    volux_format_bytes(e->framebuffer + e->image, fb, sizeof fb);
    return volux_error(ctx, VOLUX_ERR_LIMIT,
                       "%s: the render needs an estimated %s (%llu bytes: volume %s, technique caches %s, "
                       "framebuffer and image %s), more than the memory limit of %s (%llu bytes%s); lower the "
                       "image size or the technique's cache resolution, or raise the limit",
                       who, t, (unsigned long long)e->total, vol, tech, fb, l, (unsigned long long)limit,
                       volux_context_memory_limit_is_default(ctx) ? ", 80% of physical memory" : "");
}
