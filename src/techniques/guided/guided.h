/*
 * techniques/guided/guided.h — `guided`: environment-lit Monte-Carlo volume
 * rendering whose light sampling knows the visibility inside the volume
 * (von Radziewsky, Kroes, Eisemann & Eisemann, "Efficient stochastic
 * rendering of static and animated volumes using visibility sweeps", IEEE
 * TVCG 23(9), 2017).
 *
 * The estimator is the reference path tracer's (delta tracking on the
 * macrocell majorants, NEE with ratio-tracked shadow rays, MIS with phase
 * sampling; code shared through sample/tracking.h and render/direct.h),
 * except how the environment is sampled at a scattering event x: from the
 * joint density p(x, ω) ∝ (V(x, ω) + ε) · L(ω) (Eq. 5), where V is an
 * approximate visibility stored on a coarse 5-D grid (§5) and computed by
 * visibility sweeps (§6, Eq. 8) with sweep-space filtering (§8), and L is
 * the environment as an equal-area octahedral image with a quadtree (§7).
 * The density is evaluated exactly, so the estimator stays unbiased
 * whatever V is (stale, filtered, coarse).
 *
 * State beyond the ray-caster base and what invalidates it:
 *   visibility grid V[cell][direction] ← volume (all directions, or lazily
 *       some of them for a sequence: §9), extinction, density, visibility
 *       parameters
 *   environment octahedral quadtree    ← environment lights, env_resolution
 *   camera, colour, phase              → nothing (image only)
 * See README.md for the invalidation row and docs/techniques/guided.md.
 */
#ifndef VOLUX_GUIDED_H
#define VOLUX_GUIDED_H

#include "render/raycaster.h"

extern const volux_technique_class volux_guided_class;
/* The memory model (estimate.c, docs/SCALE.md). */
uint64_t volux_guided_estimate_bytes(const volux_scene *scene, const volux_technique_class *cls, uint64_t *volume_added);

/* How the environment is sampled at a scattering event (§10's five
 * strategies). */
typedef enum guided_strategy {
    GUIDED_UNIFORM,     /* uniform sphere                                    */
    GUIDED_ENVIRONMENT, /* the environment quadtree alone                    */
    GUIDED_VISIBILITY,  /* V alone, uniform inside a direction texel         */
    GUIDED_PRODUCT,     /* V·L at the grid's angular resolution ("combined") */
    GUIDED_TWO_STEP     /* V·L, then down the full-resolution L quadtree     */
} guided_strategy;

/* Lazy visibility updates over a sequence (§9). */
typedef enum guided_lazy {
    GUIDED_LAZY_OFF,         /* every direction from the current step      */
    GUIDED_LAZY_ROUND_ROBIN, /* `budget` directions per step, bit-reversed
                                Morton order, cyclic                      */
    GUIDED_LAZY_ENVIRONMENT, /* `budget` directions per step drawn from the
                                environment's luminance                   */
    GUIDED_LAZY_STATIC       /* all directions every D/budget steps        */
} guided_lazy;

/* Parameters that decide the visibility grid's contents. */
typedef struct guided_vis_params {
    int sweep;          /* 1: visibility sweeps, 0: brute-force rays      */
    int dir_res;        /* N: N×N octahedral directions (power of two)    */
    int cell;           /* voxels per grid cell edge                      */
    int ray_spacing;    /* voxels between sweep kernel rays               */
    int filter;         /* sweep-space filtering (§8)                     */
    float filter_angle; /* β/α                                            */
    int oversample;     /* sub-directions per axis per direction texel    */
    int lazy;           /* guided_lazy                                    */
    int budget;         /* directions per time step (lazy policies)       */
    int simd;           /* AVX-512 sweep rows (sweep_avx512.c)            */
} guided_vis_params;

/* The visibility grid: cells[0]·cells[1]·cells[2] positions × D = N²
 * directions, stored cell-major with directions in Morton order (a cell's
 * D values are contiguous and form the leaves of a quadtree), quantised to
 * 16 bits (V·65535). */
typedef struct guided_grid {
    int cells[3];
    float cell_size[3]; /* index units per cell                          */
    int dirs;           /* D                                             */
    uint16_t *v;        /* [cell][direction]                             */
    size_t bytes;
    /* Which time step each direction was computed from (−1: not valid):
     * lazy updates recompute the directions whose step changes. */
    int *src;
    size_t src_bytes;
} guided_grid;

/* The environment as an M×M equal-area octahedral image of luminance
 * (summed over the enabled environment lights, floored so every direction
 * has a positive density), as a quadtree (sample/octahedral.h). */
typedef struct guided_env {
    int res, levels;  /* M = 2^levels                                     */
    float *nodes;     /* concatenated pyramid, (4^(levels+1) − 1)/3 sums  */
    size_t bytes;
    int present;      /* some enabled environment light                   */
} guided_env;

typedef struct guided_state {
    volux_raycaster rc;
    /* parameters */
    int strategy;       /* guided_strategy                                */
    int mis;            /* combine with phase sampling (power heuristic)  */
    int guide_depth;    /* scattering events guided (0 = all)             */
    float continuation; /* α: continuation drawn from the event's density  */
    int rr_depth;
    int sampler;        /* enum volux_sampler_kind (sample/sampler.h)      */
    float epsilon;      /* ε added to V before the product (§6)           */
    int env_res_param;  /* env_resolution as set (0: auto)                */
    int env_res;        /* M of the environment quadtree built            */
    int dir_levels;     /* log2 N                                         */
    guided_vis_params vis;
    /* caches */
    guided_grid grid;
    int grid_dims[3];   /* volume dims the grid was shaped for            */
    uint64_t seq_id;    /* sequence the grid's sources refer to (0: none) */
    guided_env env;
    int env_built;
    int *env_slots;      /* the environment lights' slots in `env`     */
    int n_env_slots, env_slots_cap;
    int n_env;          /* enabled environment lights                     */
    /* work done by updates so far (tests and benchmarks check that an edit
     * does the least work) */
    uint64_t swept_directions; /* directions computed (sweeps or rays)    */
    int noted_no_env;          /* the "renders as pathtrace" note was given */
    uint64_t env_builds;       /* environment quadtree builds              */
    uint64_t steps_loaded;     /* other time steps acquired for lazy updates */
} guided_state;

/* ---------------------------------------------------------------- grid (visgrid.c) */

/* Index-space position of cell (i, j, k)'s centre. */
static inline float guided_cell_center(const guided_grid *g, int axis, int i) {
    return ((float)i + 0.5f) * g->cell_size[axis];
}

/* (Re)allocates the grid for the volume and parameters; contents and
 * sources invalid. */
volux_status guided_grid_alloc(volux_context *ctx, guided_grid *g, const volux_volume *v, const guided_vis_params *p);
void guided_grid_free(volux_context *ctx, guided_grid *g);

/* Unit world direction of direction texel `d` (Morton index) of an N×N
 * octahedral map, at sub-texel (su, sv) of an s×s subdivision. */
volux_vec3 guided_direction(int n, int d, int s, int su, int sv);

/* ---------------------------------------------------------------- sweeps (sweep.c) */

/* Computes the visibility of the listed directions from volume `v` (with
 * the scene's LUT) into the grid: visibility sweeps or brute-force rays per
 * p->sweep, with p's filter and oversampling. Parallel over directions;
 * the result does not depend on the thread count. */
volux_status guided_compute_directions(volux_context *ctx, int threads, guided_grid *g, const volux_volume *v,
                                       const volux_transfer_lut *lut, const guided_vis_params *p, const int *dirs,
                                       int n_dirs);

/* ---------------------------------------------------------------- environment (env.c) */

volux_status guided_env_build(volux_context *ctx, int threads, guided_env *e, const volux_light_list *lights,
                              int res);
void guided_env_free(volux_context *ctx, guided_env *e);
/* Sum of the enabled environments' radiance seen looking along dir. */
volux_vec3 guided_env_radiance(const volux_light_list *lights, volux_vec3 dir);

/* ---------------------------------------------------------------- lazy updates (lazy.c) */

/* The time step each direction's visibility comes from at step t of a
 * sequence under policy p (the policy is a function of t alone, so an
 * instance updated step by step and a fresh one agree). */
volux_status guided_lazy_sources(volux_context *ctx, const guided_vis_params *p, int dirs, const guided_env *env,
                                 uint64_t seed, int t, int *src);

/* ---------------------------------------------------------------- rendering (integrator.c) */

/* The environment's sampling density at one scattering event: for the
 * strategies that read the grid, the quadtree of (V_x + ε)·L_N (product,
 * two_step) or V_x + ε (visibility) over the N×N direction texels, built
 * from the 8 grid positions around x. Directions up to 32×32 (levels
 * 0 … 5 of a pyramid). */
#define GUIDED_EVENT_NODES 1365
typedef struct guided_event {
    int kind; /* guided_strategy in effect */
    float nodes[GUIDED_EVENT_NODES];
} guided_event;

/* Fills ev at world position x for ev->kind (nothing to do for uniform and
 * environment). */
void guided_event_build(const guided_state *st, volux_vec3 x, guided_event *ev);
/* Maps (u, v) ∈ [0,1)² to a direction; returns its solid-angle density
 * (0: none). */
float guided_event_sample(const guided_state *st, const guided_event *ev, double u, double v, volux_vec3 *w);
/* The density guided_event_sample has for direction w. */
float guided_event_pdf(const guided_state *st, const guided_event *ev, volux_vec3 w);

void guided_render_tile(const void *state, const volux_scene *scene, const volux_tile *tile, float *rgb,
                        volux_tile_stats *stats);

#endif
