/* techniques/registry.c — the one table of technique classes (STYLE §11.8),
 * and the public entry points that resolve a technique by name. Adding a
 * technique: its folder under src/techniques/ plus one line here. */
#include <string.h>

#include "core/context_internal.h"
#include "registry.h"
#include "render/memory_model.h"

extern const volux_technique_class volux_ea_class;
extern const volux_technique_class volux_shaded_class;
extern const volux_technique_class volux_pathtrace_class;
extern const volux_technique_class volux_single_class;
extern const volux_technique_class volux_ao_class;
extern const volux_technique_class volux_ambient_class;
extern const volux_technique_class volux_lightvol_class;
extern const volux_technique_class volux_sh_class;
extern const volux_technique_class volux_manylights_class;
extern const volux_technique_class volux_guided_class;

static const volux_technique_class *const classes[] = {
    &volux_ea_class,     &volux_shaded_class,  &volux_pathtrace_class, &volux_single_class,
    &volux_ao_class,     &volux_ambient_class, &volux_lightvol_class,  &volux_sh_class,
    &volux_manylights_class,
    &volux_guided_class,
};

const volux_technique_class *volux_technique_class_find(const char *name) {
    for (int i = 0; i < volux_technique_count(); i++)
        if (!strcmp(classes[i]->info.name, name)) return classes[i];
    return NULL;
}

int volux_technique_count(void) { return (int)(sizeof classes / sizeof classes[0]); }

const volux_technique_info *volux_technique_info_at(int index) {
    return index >= 0 && index < volux_technique_count() ? &classes[index]->info : NULL;
}

const volux_technique_info *volux_technique_info_find(const char *name) {
    const volux_technique_class *cls = volux_technique_class_find(name);
    return cls ? &cls->info : NULL;
}

const char *volux_technique_closest(const char *name) {
    if (!name) return NULL;
    volux_name_guess g = {0};
    for (int i = 0; i < volux_technique_count(); i++) volux_name_guess_try(&g, name, classes[i]->info.name);
    return volux_name_guess_best(&g, name);
}

volux_status volux_technique_validate_params(volux_context *ctx, const volux_scene *scene) {
    const char *tech, *name, *string;
    double number;
    for (int i = 0; volux_scene_param_at(scene, i, &tech, &name, &number, &string); i++) {
        const volux_technique_class *cls = volux_technique_class_find(tech);
        if (!cls) {
            const char *guess = volux_technique_closest(tech);
            return volux_error(ctx, VOLUX_ERR_INVALID, "techniques.%s: unknown technique%s%s%s", tech,
                               guess ? " (did you mean '" : "", guess ? guess : "", guess ? "'?)" : "");
        }
        volux_status st = volux_technique_check_param(ctx, &cls->info, name, number, string);
        if (st) return st;
    }
    return VOLUX_OK;
}

volux_status volux_technique_estimate_memory(volux_context *ctx, const char *name, const volux_scene *scene,
                                             volux_memory_estimate *out) {
    if (!name) name = volux_scene_render(scene)->technique;
    const volux_technique_class *cls = volux_technique_class_find(name);
    if (!cls) return volux_error(ctx, VOLUX_ERR_INVALID, "render.technique: unknown technique '%s'", name);
    volux_memory_estimate_class(cls, scene, out);
    return VOLUX_OK;
}

volux_status volux_technique_create(volux_context *ctx, const char *name, const volux_scene *scene,
                                    volux_technique **out) {
    const volux_technique_class *cls = volux_technique_class_find(name);
    if (!cls) {
        const char *guess = volux_technique_closest(name);
        return volux_error(ctx, VOLUX_ERR_INVALID, "render.technique: unknown technique '%s'%s%s%s", name,
                           guess ? " (did you mean '" : "", guess ? guess : "", guess ? "'?)" : "");
    }
    volux_status st = volux_technique_validate_params(ctx, scene);
    return st ? st : volux_technique_create_class(ctx, cls, scene, out);
}
