/* techniques/registry.c — the one table of technique classes (STYLE §11.8). */
#include <string.h>

#include "volux/technique.h"

extern const volux_technique_class volux_ea_class;
extern const volux_technique_class volux_shaded_class;
extern const volux_technique_class volux_pathtrace_class;
extern const volux_technique_class volux_single_class;
extern const volux_technique_class volux_ao_class;
extern const volux_technique_class volux_ambient_class;
extern const volux_technique_class volux_lightvol_class;

static const volux_technique_class *const classes[] = {
    &volux_ea_class,
    &volux_shaded_class,
    &volux_pathtrace_class,
    &volux_single_class,
    &volux_ao_class,
    &volux_ambient_class,
    &volux_lightvol_class,
};

int volux_technique_count(void) { return (int)(sizeof classes / sizeof classes[0]); }

const volux_technique_class *volux_technique_class_at(int index) {
    return index >= 0 && index < volux_technique_count() ? classes[index] : NULL;
}

const volux_technique_class *volux_technique_find(const char *name) {
    for (int i = 0; i < volux_technique_count(); i++)
        if (!strcmp(classes[i]->name, name)) return classes[i];
    return NULL;
}
