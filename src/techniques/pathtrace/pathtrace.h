/*
 * techniques/pathtrace/pathtrace.h — `pathtrace`, the unbiased reference
 * volumetric path tracer every other technique is measured against.
 *
 * Deliberately simple (STYLE §11.9): no caches beyond what sampling needs,
 * no approximations; every estimator is unbiased for the scene of DESIGN §2
 * (see docs/techniques/pathtrace.md for the estimator and its conventions).
 *
 * State beyond the ray-caster base (render/raycaster.h: volume, LUT,
 * majorant grid, camera, seed, max_depth, albedo, g, prepared lights) and
 * what invalidates it:
 *   environment sampling table of slot i   ← light i only
 *   parameters                             ← params
 * Any edit changes the image, so the caller resets accumulation.
 */
#ifndef VOLUX_PATHTRACE_H
#define VOLUX_PATHTRACE_H

#include "render/raycaster.h"
#include "sample/envmap.h"

extern const volux_technique_class volux_pathtrace_class;
/* The memory model (estimate.c, docs/SCALE.md). */
uint64_t volux_pathtrace_estimate_bytes(const volux_scene *scene, const volux_technique_class *cls, uint64_t *volume_added);

typedef struct pt_state {
    volux_raycaster rc;  /* base: volume, LUT, majorant grid, camera, seed,
                            max_depth, albedo, g, lights (all enabled, slot
                            order: next-event estimation visits each)      */
    /* parameters */
    int rr_depth;
    int pre;             /* classification: 0 post (DESIGN), 1 pre          */
    int global_majorant; /* 1: one majorant for the whole box (benchmark)   */
    int sampler;         /* enum volux_sampler_kind (sample/sampler.h)      */
    int n_area;          /* lights a phase-sampled ray can reach (sphere,
                            environment)                                    */
    volux_envmap_sampler *env; /* per light slot [env_cap] */
    int env_cap;
} pt_state;

/* integrator.c */
void volux_pathtrace_render_tile(const void *state, const volux_scene *scene, const volux_tile *tile, float *rgb,
                                 volux_tile_stats *stats);

#endif
