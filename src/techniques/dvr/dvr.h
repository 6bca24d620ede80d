/*
 * techniques/dvr/dvr.h — classical direct volume rendering, shared by the
 * `ea` (emission–absorption) and `shaded` (plus gradient Blinn–Phong)
 * techniques.
 *
 * Caches and what invalidates them:
 *   majorant grid (empty-space skipping) ← volume, extinction, density
 *   gradient cache (shaded only)         ← volume
 *   prepared lights (shaded only)        ← lights
 *   resolved camera                      ← camera, image size
 * Colour/albedo/material edits re-read the scene's LUT only.
 */
#ifndef VOLUX_DVR_H
#define VOLUX_DVR_H

#include "sample/gradient.h"
#include "sample/march.h"
#include "volux/technique.h"

#define DVR_MAX_LIGHTS 64

extern const volux_technique_class volux_ea_class;
extern const volux_technique_class volux_shaded_class;

typedef struct dvr_light {
    int kind;           /* 0 directional, 1 point/spot/sphere (positional) */
    volux_vec3 dir_to;  /* directional: unit vector towards the light      */
    volux_vec3 pos;
    volux_vec3 power;   /* directional: irradiance·color; positional: I·color
                           (sphere: radiance·π·r²·color)                  */
    int spot;
    volux_light_desc desc; /* for spot falloff */
    volux_vec3 spot_dir;
} dvr_light;

typedef struct dvr_state {
    volux_context *ctx;
    const volux_technique_class *cls;
    int shaded;
    volux_volume *volume;          /* retained */
    const volux_transfer_lut *lut; /* the scene's */
    volux_majorant_grid grid;
    volux_camera camera;
    float step;                    /* world units */
    uint64_t seed;
    /* parameters */
    int preintegrate, skip_empty;
    float t_min;                   /* early termination when T < t_min   */
    /* shading */
    volux_gradient_cache grad;     /* shared helper (sample/gradient.h)  */
    float grad_ref;                /* |∇s| at which shading is fully on    */
    volux_material material;
    volux_vec3 ambient;
    dvr_light lights[DVR_MAX_LIGHTS];
    int n_lights;
} dvr_state;

volux_status volux_dvr_create(volux_context *ctx, volux_scene *scene, const volux_technique_class *cls, int shaded,
                              void **out);
volux_status volux_dvr_update(void *state, volux_scene *scene, const volux_change_set *c);
void volux_dvr_render_tile(const void *state, const volux_scene *scene, const volux_tile *tile, float *rgb,
                           volux_tile_stats *stats);
size_t volux_dvr_memory_bytes(const void *state);
void volux_dvr_destroy(void *state);

#endif
