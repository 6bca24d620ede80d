/*
 * techniques/registry.h — the table of technique classes (registry.c), for
 * code that needs a class itself rather than its public info: white-box
 * tests (the technique × edit matrix). Resolving a name for users is the
 * public volux_technique_create / volux_technique_info_find.
 */
#ifndef VOLUX_REGISTRY_H
#define VOLUX_REGISTRY_H

#include "render/technique_class.h"

/* The class registered as `name`, or NULL. */
const volux_technique_class *volux_technique_class_find(const char *name);

#endif
