/*
 * techniques/single/single.h — `single` state, for tests that check which
 * caches an edit rebuilt.
 */
#ifndef VOLUX_SINGLE_H
#define VOLUX_SINGLE_H

#include "techniques/scatter/base.h"
#include "techniques/scatter/grid.h"

extern const volux_technique_class volux_single_class;

#define SINGLE_MAX_ENV_DIRS 256

/* What single keeps per light slot. */
typedef struct single_slot {
    scatter_grid cache;    /* transmittance to the light */
    uint64_t cache_builds; /* times `cache` was built (tests, stats) */
} single_slot;

/* The memory model (estimate.c, docs/SCALE.md). */
uint64_t volux_single_estimate_bytes(const volux_scene *scene, const volux_technique_class *cls,
                                     uint64_t *volume_added);

typedef struct single_state {
    scatter_base b;
    int use_cache;
    float cache_scale;
    float shadow_step;                      /* world units */
    float near_field;                       /* cache cells marched before the cache is read */
    float light_sweep;                      /* light_sweep parameter: directional lights' caches by
                                               the light-space sweep at this spacing (0: rays) */
    single_slot *slot;                      /* per light slot [slot_cap] */
    int slot_cap;
    /* environment lights: n_env_dirs directions, each a shadowed directional
     * light carrying the environments' radiance over its cell (single.c) */
    int n_env_dirs;                         /* env_directions parameter    */
    int env_active;                         /* n_env_dirs > 0 and an environment is on */
    float env_sweep;                        /* env_sweep parameter: light-space lattice spacing in
                                               cache cells, 0 = one shadow ray per node */
    volux_vec3 env_travel[SINGLE_MAX_ENV_DIRS]; /* unit travel direction   */
    volux_vec3 env_E[SINGLE_MAX_ENV_DIRS];  /* irradiance of the cell     */
    scatter_grid env_cache[SINGLE_MAX_ENV_DIRS];
    volux_env_cells_cache env_cells;        /* memo of the cell integrals (render/lights.h) */
    uint64_t env_cache_builds;
} single_state;

/* The camera march as packets (march_avx2.c, march_avx512.c over
 * render/packet_impl.h); the per-sample shading stays scalar, called per
 * lane through volux_single_shade_lane. */
void volux_single_march_avx2(const volux_packet_march *pm, const void *tech, const volux_scene *scene,
                             const volux_tile *tile, float *rgb, volux_tile_stats *stats);
void volux_single_march_avx512(const volux_packet_march *pm, const void *tech, const volux_scene *scene,
                               const volux_tile *tile, float *rgb, volux_tile_stats *stats);
void volux_single_shade_lane(const void *tech, const volux_packet_lane *in, float c[3]);

#endif
