/* render/raycaster.c — see raycaster.h. */
#include <math.h>
#include <string.h>

#include "core/context_internal.h"
#include "core/scene_internal.h"
#include "raycaster.h"

volux_status volux_raycaster_update(volux_raycaster *rc, const volux_scene *scene, const volux_change_set *c) {
    const uint32_t w = c->what;
    volux_status s;
    const volux_render_settings *rs = volux_scene_render(scene);
    rc->threads = rs->threads > 0 ? rs->threads : volux_context_threads(rc->ctx);
    if (w & VOLUX_CHANGE_VOLUME) {
        volux_volume *v = volux_scene_render_volume(scene); /* clipped (core/clip.c) */
        volux_volume_retain(v);
        volux_volume_release(rc->volume);
        rc->volume = v;
        double sp[3];
        volux_volume_spacing(v, sp);
        rc->min_spacing = (float)fmin(sp[0], fmin(sp[1], sp[2]));
    }
    if (w & (VOLUX_CHANGE_VOLUME | VOLUX_CHANGE_EXTINCTION | VOLUX_CHANGE_DENSITY | VOLUX_CHANGE_COLOR)) {
        rc->lut = volux_scene_transfer_lut(scene);
        if (!rc->lut)
            return volux_error(rc->ctx, VOLUX_ERR_INVALID, "%s: the scene has no baked transfer function",
                               rc->cls->info.name);
    }
    if (w & (VOLUX_CHANGE_VOLUME | VOLUX_CHANGE_EXTINCTION | VOLUX_CHANGE_DENSITY))
        if ((s = volux_majorant_grid_build(rc->ctx, rc->volume, rc->lut, &rc->grid))) return s;
    if (w & (VOLUX_CHANGE_CAMERA | VOLUX_CHANGE_RENDER | VOLUX_CHANGE_VOLUME))
        if ((s = volux_scene_camera(scene, &rc->camera))) return s;
    if (w & (VOLUX_CHANGE_RENDER | VOLUX_CHANGE_VOLUME)) {
        rc->step = volux_scene_step_world(scene);
        rc->seed = rs->seed;
        rc->max_depth = rs->max_depth;
    }
    if (w & (VOLUX_CHANGE_COLOR | VOLUX_CHANGE_ALBEDO | VOLUX_CHANGE_PHASE | VOLUX_CHANGE_VOLUME)) {
        const volux_transfer_desc *tf = volux_scene_transfer(scene);
        rc->albedo = tf->albedo;
        rc->g = tf->anisotropy;
        rc->material = tf->material;
    }
    if ((w & VOLUX_CHANGE_LIGHTS) && (s = volux_light_list_prepare(scene, &rc->lights))) return s;
    return VOLUX_OK;
}

volux_status volux_raycaster_warn_unused_lights(volux_raycaster *rc, unsigned types, const char *why) {
    const volux_light_list *ls = &rc->lights;
    int slots = ls->n_all ? ls->all[ls->n_all - 1].slot + 1 : 0; /* slot order */
    volux_status s = volux_grow_slots(rc->ctx, &rc->ignored_in, &rc->ignored_cap, slots, sizeof *rc->ignored_in,
                                      "the ignored-light warnings");
    if (s) return s;
    /* call numbers start at 2, so a zeroed entry never reads as "ignored in
     * the previous call" */
    const uint32_t call = ++rc->warn_calls + 1;
    for (int i = 0; i < ls->n_all; i++) {
        const volux_prepared_light *l = &ls->all[i];
        if (!(types & (1u << l->type))) continue;
        if (rc->ignored_in[l->slot] != call - 1)
            volux_message(rc->ctx, VOLUX_MESSAGE_WARNING, "%s: ignores lights[%d] (%s): %s", rc->cls->info.name,
                          l->slot, volux_light_type_name(l->type), why);
        rc->ignored_in[l->slot] = call;
    }
    return VOLUX_OK;
}

void volux_raycaster_release(volux_raycaster *rc) {
    volux_majorant_grid_free(rc->ctx, &rc->grid);
    volux_light_list_free(rc->ctx, &rc->lights);
    volux_free(rc->ctx, rc->ignored_in, sizeof *rc->ignored_in * (size_t)rc->ignored_cap);
    rc->ignored_in = NULL;
    rc->ignored_cap = 0;
    volux_volume_release(rc->volume);
    rc->volume = NULL;
}

size_t volux_raycaster_memory_bytes(const volux_raycaster *rc) {
    return rc->grid.bytes + 2 * sizeof(volux_prepared_light) * (size_t)rc->lights.cap +
           sizeof(uint32_t) * (size_t)rc->ignored_cap;
}
