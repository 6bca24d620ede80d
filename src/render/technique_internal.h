/*
 * render/technique_internal.h — what the frame loop (and white-box tests)
 * may see of a technique instance: its class state. Instances are created
 * and updated in render/technique.c; classes live in src/techniques/.
 */
#ifndef VOLUX_TECHNIQUE_INTERNAL_H
#define VOLUX_TECHNIQUE_INTERNAL_H

#include "volux/technique.h"

/* The class's state (the `void *` its create() returned), read-only. */
const void *volux_technique_state(const volux_technique *t);

#endif
