/*
 * render/lights.h — the scene's lights prepared once per light edit, in the
 * one form every technique reads (DESIGN §2 units).
 *
 *   directional: irradiance·colour along a constant travel direction
 *   point, spot: intensity·colour / d², spot cone falloff about the axis
 *   sphere:      radiance·colour on a sphere; `power` is the intensity of
 *                the point light of the same flux (radiance·π·r²·colour),
 *                for techniques that treat a small sphere as a point
 *   environment: radiance from every direction (constant or a map); its
 *                solid-angle mean is summed into `env_mean`
 *
 * Each prepared light remembers its scene slot, so a technique can rebuild
 * the cache of exactly the light that changed.
 */
#ifndef VOLUX_RENDER_LIGHTS_H
#define VOLUX_RENDER_LIGHTS_H

#include <stdint.h>
#include "core/vecmath.h"
#include "volux/scene.h"

typedef struct volux_prepared_light {
    int slot;
    volux_light_type type;
    int positional;      /* point, spot, sphere: 1/d² falloff               */
    int spot;
    volux_vec3 travel;   /* directional: unit travel direction              */
    volux_vec3 pos;      /* point, spot: position; sphere: centre           */
    volux_vec3 axis;     /* spot (and point): unit cone axis, travel sense  */
    volux_vec3 power;    /* directional: irradiance·colour (W/m²); point,
                            spot: intensity·colour (W/sr); sphere: the
                            equivalent point intensity radiance·π·r²·colour */
    volux_vec3 radiance; /* sphere: radiance·colour                         */
    float radius;        /* sphere                                          */
    const volux_light_desc *desc; /* the scene's (spot falloff, environment
                                     map); valid until the next scene edit  */
} volux_prepared_light;

typedef struct volux_light_list {
    volux_prepared_light *all;    /* enabled lights, slot order     */
    int n_all;
    volux_prepared_light *direct; /* the same without environments  */
    int n_direct;
    int cap;                      /* elements allocated in each     */
    int n_env, n_sphere;
    volux_vec3 env_mean; /* Σ of the enabled environments' mean radiance (0 if none) */
} volux_light_list;

/* One light in the prepared form (slot recorded; `desc` borrowed). */
void volux_light_prepare(const volux_light_desc *d, int slot, volux_prepared_light *l);
/* Fills `out` from the scene's enabled lights, growing its arrays (from
 * the scene's context) to the scene's slot count; NOMEM leaves `out`
 * empty but valid. */
volux_status volux_light_list_prepare(const volux_scene *s, volux_light_list *out);
void volux_light_list_free(volux_context *ctx, volux_light_list *l);

/* Solid-angle mean radiance of an environment light (rows of a map are
 * weighted by the sine of their polar angle). */
volux_vec3 volux_environment_mean(const volux_light_desc *d);

/* Point i of the Fibonacci set of n points on the unit sphere (equal-area
 * bands in z, golden-angle steps in φ: near-uniform, deterministic). */
volux_vec3 volux_fibonacci_dir(int i, int n);

/* An environment as K directional lights (the `env_directions` of `single`
 * and `lightvol`): adds to E[k] the radiance of environment light d
 * integrated over the cell of from[k] — the directions nearer to from[k]
 * than to any other of the K unit vectors `from` (in practice
 * volux_fibonacci_dir(k, K)). A map is integrated texel by texel, so the
 * energy is kept exactly: Σ_k E_k = ∫ L dω. */
void volux_environment_cells(const volux_light_desc *d, int K, const volux_vec3 *from, volux_vec3 *E);

/* The cell integrals without the environment's scale (map: colour ×
 * intensity; constant: colour × radiance): S[k] = ∫_cell L dω of the bare
 * map (or of 1), overwritten. volux_environment_cells adds scale ⊙ S[k]. */
void volux_environment_cell_integrals(const volux_light_desc *d, int K, const volux_vec3 *from, volux_vec3 *S);
volux_vec3 volux_environment_cells_scale(const volux_light_desc *d);

/* A memo of cell integrals (issue 17): the texel-by-texel integration of a
 * map (a direction, trigonometry and K dot products per texel: tens of ms
 * for a 1k map) depends only on the map's texels, its rotation and K — not
 * on colour or intensity, which scale the result. An update that re-derives
 * the environment (any light edit, a transfer-function edit, a queued
 * budget plan) then costs a hash of the map. Keyed on K, rotation, the map's
 * size and a 64-bit hash of its texels (the scene copies a map on every
 * light edit, so its address says nothing); the least recently used of
 * VOLUX_ENV_CELLS_SLOTS entries is replaced. */
#define VOLUX_ENV_CELLS_MAX 256
#define VOLUX_ENV_CELLS_SLOTS 4
typedef struct volux_env_cells_cache {
    struct {
        int used, K, has_map, width, height;
        float rotation_y_deg;
        uint64_t hash;
        unsigned long long last_use;
        volux_vec3 S[VOLUX_ENV_CELLS_MAX];
    } e[VOLUX_ENV_CELLS_SLOTS];
    unsigned long long clock;
    long hits, misses; /* for tests and statistics */
} volux_env_cells_cache;

/* volux_environment_cells with from[k] = volux_fibonacci_dir(k, K) (K ≤
 * VOLUX_ENV_CELLS_MAX) through the memo: the same arithmetic as a fresh
 * call, so the same bits. */
void volux_environment_cells_cached(volux_env_cells_cache *c, const volux_light_desc *d, int K, volux_vec3 *E);

/* Unshadowed irradiance at p from a direct light and the direction the
 * light travels there (unit). */
static inline volux_vec3 volux_light_irradiance(const volux_prepared_light *l, volux_vec3 p, volux_vec3 *travel) {
    if (!l->positional) {
        *travel = l->travel;
        return l->power;
    }
    volux_vec3 d = v3_sub(p, l->pos);
    float d2 = v3_dot(d, d);
    if (d2 < 1e-12f) d2 = 1e-12f;
    float inv = 1.0f / sqrtf(d2);
    *travel = v3_scale(d, inv);
    float f = 1.0f / d2;
    if (l->spot) f *= volux_spot_falloff(l->desc, v3_dot(*travel, l->axis));
    return v3_scale(l->power, f);
}

#endif
