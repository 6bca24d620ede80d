/*
 * techniques/scatter/lights.h — the scene's lights as the scattering
 * techniques see them (DESIGN §2 units).
 *
 *   directional: irradiance·color along a constant travel direction
 *   point, spot: intensity·color / d², spot cone falloff
 *   sphere:      a point of intensity radiance·π·r²·color (the area is
 *                small against the volume; its soft shadow is not modelled)
 *   environment: not a direct light here; its mean radiance is the ambient
 *                term (used by `ao` and by `ambient`'s optional AO term)
 *
 * Each prepared light remembers its scene slot, so a technique can rebuild
 * the cache of exactly the light that changed.
 */
#ifndef VOLUX_SCATTER_LIGHTS_H
#define VOLUX_SCATTER_LIGHTS_H

#include "core/vecmath.h"
#include "volux/scene.h"

#define SCATTER_MAX_LIGHTS 32

typedef struct scatter_light {
    int slot;
    int positional;      /* 0 directional, 1 point/spot/sphere             */
    volux_vec3 dir;      /* directional: unit travel direction             */
    volux_vec3 pos;
    volux_vec3 power;    /* irradiance·color or intensity·color            */
    int spot;
    volux_vec3 spot_dir;
    volux_light_desc desc; /* for the spot falloff                         */
} scatter_light;

/* Fills out[] with the enabled non-environment lights (at most max, in slot
 * order) and *ambient with the mean radiance of the enabled environment
 * lights (0 if there are none). Returns the count. */
int scatter_lights_prepare(const volux_scene *s, scatter_light *out, int max, volux_vec3 *ambient);

/* Unshadowed irradiance at p and the direction light travels there. */
static inline volux_vec3 scatter_light_irradiance(const scatter_light *l, volux_vec3 p, volux_vec3 *travel) {
    if (!l->positional) {
        *travel = l->dir;
        return l->power;
    }
    volux_vec3 d = v3_sub(p, l->pos);
    float d2 = v3_dot(d, d);
    if (d2 < 1e-12f) d2 = 1e-12f;
    float inv = 1.0f / sqrtf(d2);
    *travel = v3_scale(d, inv);
    float f = 1.0f / d2;
    if (l->spot) f *= volux_spot_falloff(&l->desc, v3_dot(*travel, l->spot_dir));
    return v3_scale(l->power, f);
}

#endif
