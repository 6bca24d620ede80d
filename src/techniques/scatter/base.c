/* techniques/scatter/base.c — see base.h. */
#include "base.h"

void scatter_base_update(scatter_base *b, const volux_scene *scene, const volux_change_set *c) {
    if (!(c->what & (VOLUX_CHANGE_PARAMS | VOLUX_CHANGE_VOLUME))) return;
    const volux_technique_class *cls = b->rc.cls;
    b->t_min = (float)volux_technique_param(scene, cls, "early_termination");
    b->skip_empty = (int)volux_technique_param(scene, cls, "skip_empty");
    b->emission = (float)volux_technique_param(scene, cls, "emission");
}
