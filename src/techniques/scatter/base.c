/* techniques/scatter/base.c — see base.h. */
#include <math.h>
#include <string.h>

#include "base.h"
#include "core/context_internal.h"

volux_status scatter_base_update(scatter_base *b, volux_scene *scene, const volux_change_set *c) {
    volux_status s;
    b->threads = volux_context_threads(b->ctx);
    if (c->what & VOLUX_CHANGE_VOLUME) {
        volux_volume *v = volux_scene_volume(scene);
        volux_volume_retain(v);
        volux_volume_release(b->volume);
        b->volume = v;
        double sp[3];
        volux_volume_spacing(v, sp);
        b->min_spacing = (float)fmin(sp[0], fmin(sp[1], sp[2]));
    }
    if (c->what & (VOLUX_CHANGE_VOLUME | VOLUX_CHANGE_EXTINCTION | VOLUX_CHANGE_DENSITY | VOLUX_CHANGE_COLOR)) {
        b->lut = volux_scene_transfer_lut(scene);
        if (!b->lut) {
            s = volux_context_error_status(b->ctx);
            return s ? s : volux_error(b->ctx, VOLUX_ERR_INVALID, "%s: no transfer function", b->cls->name);
        }
    }
    if (c->what & (VOLUX_CHANGE_VOLUME | VOLUX_CHANGE_EXTINCTION | VOLUX_CHANGE_DENSITY))
        if ((s = volux_majorant_grid_build(b->ctx, b->volume, b->lut, &b->grid))) return s;
    if (c->what & (VOLUX_CHANGE_CAMERA | VOLUX_CHANGE_RENDER | VOLUX_CHANGE_VOLUME))
        if ((s = volux_scene_camera(scene, &b->camera))) return s;
    if (c->what & (VOLUX_CHANGE_RENDER | VOLUX_CHANGE_VOLUME)) {
        b->step = volux_scene_step_world(scene);
        b->seed = volux_scene_render(scene)->seed;
    }
    if (c->what & (VOLUX_CHANGE_COLOR | VOLUX_CHANGE_PHASE | VOLUX_CHANGE_VOLUME)) {
        const volux_transfer_desc *tf = volux_scene_transfer(scene);
        b->albedo = tf->albedo;
        b->g = tf->anisotropy;
    }
    if (c->what & (VOLUX_CHANGE_PARAMS | VOLUX_CHANGE_VOLUME)) {
        b->t_min = (float)volux_technique_param(scene, b->cls, "early_termination");
        b->skip_empty = (int)volux_technique_param(scene, b->cls, "skip_empty");
        b->emission = (float)volux_technique_param(scene, b->cls, "emission");
    }
    if (c->what & VOLUX_CHANGE_LIGHTS)
        b->n_lights = scatter_lights_prepare(scene, b->lights, SCATTER_MAX_LIGHTS, &b->ambient);
    return VOLUX_OK;
}

void scatter_base_free(scatter_base *b) {
    volux_majorant_grid_free(b->ctx, &b->grid);
    volux_volume_release(b->volume);
    b->volume = NULL;
}

size_t scatter_base_memory(const scatter_base *b) { return b->grid.bytes; }
