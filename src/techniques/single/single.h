/*
 * techniques/single/single.h — `single` state, for tests that check which
 * caches an edit rebuilt.
 */
#ifndef VOLUX_SINGLE_H
#define VOLUX_SINGLE_H

#include "techniques/scatter/base.h"
#include "techniques/scatter/grid.h"

extern const volux_technique_class volux_single_class;

typedef struct single_state {
    scatter_base b;
    int use_cache;
    float cache_scale;
    float shadow_step;                      /* world units */
    scatter_grid cache[VOLUX_MAX_LIGHTS];   /* per scene slot */
    uint64_t cache_builds[VOLUX_MAX_LIGHTS];
} single_state;

#endif
