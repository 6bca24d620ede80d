/* render/technique.c — technique instances: create, stamp-based update,
 * parameter validation. */
#include <math.h>
#include <string.h>

#include "core/context_internal.h"
#include "technique_internal.h"
#include "volux/technique.h"

struct volux_technique {
    volux_context *ctx;
    const volux_technique_class *cls;
    void *state;
    volux_scene_stamp stamp;
};

const void *volux_technique_state(const volux_technique *t) { return t->state; }

static const volux_param_info *find_param(const volux_technique_class *cls, const char *name) {
    for (const volux_param_info *p = cls->params; p && p->name; p++)
        if (!strcmp(p->name, name)) return p;
    return NULL;
}

volux_status volux_technique_validate_params(volux_context *ctx, const volux_scene *scene) {
    const char *tech, *name, *string;
    double number;
    for (int i = 0; volux_scene_param_at(scene, i, &tech, &name, &number, &string); i++) {
        const volux_technique_class *cls = volux_technique_find(tech);
        if (!cls) return volux_error(ctx, VOLUX_ERR_INVALID, "techniques.%s: unknown technique", tech);
        const volux_param_info *p = find_param(cls, name);
        if (!p) return volux_error(ctx, VOLUX_ERR_INVALID, "techniques.%s.%s: unknown parameter", tech, name);
        if ((p->kind == VOLUX_PARAM_STRING) != (string != NULL))
            return volux_error(ctx, VOLUX_ERR_INVALID, "techniques.%s.%s: expected a %s", tech, name,
                               p->kind == VOLUX_PARAM_STRING ? "string" : "number");
        if (p->kind == VOLUX_PARAM_STRING) continue;
        if ((p->kind == VOLUX_PARAM_INT || p->kind == VOLUX_PARAM_BOOL) && number != floor(number))
            return volux_error(ctx, VOLUX_ERR_INVALID, "techniques.%s.%s: expected an integer, got %g", tech, name,
                               number);
        if (number < p->min || number > p->max)
            return volux_error(ctx, VOLUX_ERR_INVALID, "techniques.%s.%s: %g is outside [%g, %g]", tech, name, number,
                               p->min, p->max);
    }
    return VOLUX_OK;
}

double volux_technique_param(const volux_scene *scene, const volux_technique_class *cls, const char *name) {
    const volux_param_info *p = find_param(cls, name);
    return volux_scene_param(scene, cls->name, name, p ? p->def : 0.0);
}

volux_status volux_technique_create(volux_context *ctx, const char *name, volux_scene *scene, volux_technique **out) {
    const volux_technique_class *cls = volux_technique_find(name);
    if (!cls) return volux_error(ctx, VOLUX_ERR_INVALID, "render.technique: unknown technique '%s'", name);
    if (!volux_scene_volume(scene)) return volux_error(ctx, VOLUX_ERR_INVALID, "scene has no volume");
    volux_status st = volux_technique_validate_params(ctx, scene);
    if (st) return st;
    volux_technique *t = volux_calloc(ctx, 1, sizeof *t);
    if (!t) return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for technique '%s'", name);
    t->ctx = ctx;
    t->cls = cls;
    t->stamp = volux_scene_stamp_now(scene);
    st = cls->create(ctx, scene, &t->state);
    if (st) {
        volux_free(ctx, t, sizeof *t);
        return st;
    }
    *out = t;
    return VOLUX_OK;
}

volux_status volux_technique_update(volux_technique *t, volux_scene *scene, volux_change_set *changed) {
    volux_change_set c = volux_scene_changes_since(scene, &t->stamp);
    if (changed) *changed = c;
    int any = c.what != 0;
    for (int i = 0; i < VOLUX_MAX_LIGHTS / 64; i++) any |= c.lights[i] != 0;
    if (!any) return VOLUX_OK;
    if (c.what & VOLUX_CHANGE_PARAMS) {
        volux_status st = volux_technique_validate_params(t->ctx, scene);
        if (st) return st;
    }
    volux_status st = t->cls->update(t->state, scene, &c);
    if (st) return st;
    t->stamp = volux_scene_stamp_now(scene);
    return VOLUX_OK;
}

const volux_technique_class *volux_technique_class_of(const volux_technique *t) { return t->cls; }

size_t volux_technique_memory_bytes(const volux_technique *t) {
    return t->cls->memory_bytes ? t->cls->memory_bytes(t->state) : 0;
}

void volux_technique_destroy(volux_technique *t) {
    if (!t) return;
    t->cls->destroy(t->state);
    volux_free(t->ctx, t, sizeof *t);
}
