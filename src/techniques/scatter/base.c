/* techniques/scatter/base.c — see base.h. */
#include "base.h"

void scatter_base_update(scatter_base *b, const volux_scene *scene, const volux_change_set *c) {
    if (!(c->what & (VOLUX_CHANGE_PARAMS | VOLUX_CHANGE_VOLUME))) return;
    const volux_technique_class *cls = b->rc.cls;
    b->t_min = (float)volux_technique_param(scene, cls, "early_termination");
    b->skip_empty = (int)volux_technique_param(scene, cls, "skip_empty");
    b->emission = (float)volux_technique_param(scene, cls, "emission");
}

volux_status scatter_base_packet_update(scatter_base *b, const volux_scene *scene, const volux_change_set *c,
                                        int usable, const char *why) {
    volux_raycaster *rc = &b->rc;
    volux_status s;
    if (c->what & (VOLUX_CHANGE_PARAMS | VOLUX_CHANGE_VOLUME))
        if ((s = volux_packet_kernel_choose(rc->ctx, scene, rc->cls, usable, why, &b->march_lanes))) return s;
    if (!b->march_lanes) {
        volux_packet_tables_free(rc->ctx, &b->pk);
        return VOLUX_OK;
    }
    return volux_packet_tables_update(rc->ctx, rc->volume, rc->lut, c->what, &b->pk);
}

void scatter_base_packet_release(scatter_base *b) { volux_packet_tables_free(b->rc.ctx, &b->pk); }
