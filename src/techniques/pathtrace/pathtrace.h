/*
 * techniques/pathtrace/pathtrace.h — `pathtrace`, the unbiased reference
 * volumetric path tracer every other technique is measured against.
 *
 * Deliberately simple (STYLE §11.9): no caches beyond what sampling needs,
 * no approximations; every estimator is unbiased for the scene of DESIGN §2
 * (see docs/techniques/pathtrace.md for the estimator and its conventions).
 *
 * State and what invalidates it:
 *   volume (retained), baked LUT pointer   ← volume, extinction, density, colour
 *   majorant grid (8³ macrocells × TF)     ← volume, extinction, density
 *   albedo                                 ← colour
 *   g (HG anisotropy)                      ← phase
 *   prepared light list                    ← lights (any slot)
 *   environment sampling table of slot i   ← light i only
 *   resolved camera                        ← camera, render (image size), volume
 *   seed, max_depth                        ← render
 *   parameters                             ← params
 * Any edit changes the image, so the caller resets accumulation.
 */
#ifndef VOLUX_PATHTRACE_H
#define VOLUX_PATHTRACE_H

#include "sample/envmap.h"
#include "sample/march.h"
#include "volux/technique.h"

extern const volux_technique_class volux_pathtrace_class;

typedef struct pt_light {
    volux_light_type type;
    int slot;
    volux_vec3 le;       /* directional: irradiance·color [W/m²]; point/spot:
                            intensity·color [W/sr]; sphere: radiance·color   */
    volux_vec3 dir_to;   /* directional: unit vector towards the light       */
    volux_vec3 pos;      /* point, spot, sphere centre                       */
    volux_vec3 axis;     /* spot: unit travel direction of the cone axis     */
    float radius;        /* sphere                                           */
    const volux_light_desc *desc;      /* the scene's (spot falloff, env map) */
    const volux_envmap_sampler *env;   /* environment: its sampling table    */
} pt_light;

typedef struct pt_state {
    volux_context *ctx;
    volux_volume *volume;          /* retained */
    const volux_transfer_lut *lut; /* the scene's baked LUT */
    volux_majorant_grid grid;
    volux_camera camera;
    float albedo, g;
    uint64_t seed;
    int max_depth;
    /* parameters */
    int rr_depth;
    int pre;             /* classification: 0 post (DESIGN), 1 pre          */
    int global_majorant; /* 1: one majorant for the whole box (benchmark)   */
    /* lights: delta ones first is not required; n_area counts the ones the
     * phase-sampled continuation ray can reach (sphere, environment) */
    pt_light lights[VOLUX_MAX_LIGHTS];
    int n_lights, n_area, n_sphere, n_env;
    volux_envmap_sampler env[VOLUX_MAX_LIGHTS]; /* per slot */
} pt_state;

/* integrator.c */
void volux_pathtrace_render_tile(const void *state, const volux_scene *scene, const volux_tile *tile, float *rgb,
                                 volux_tile_stats *stats);

#endif
