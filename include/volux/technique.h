/*
 * volux/technique.h — illumination methods behind one small interface.
 *
 * A technique class (one per method, listed in src/techniques/registry.c)
 * creates per-scene state that owns the method's caches; update() maps the
 * scene's change set to the least cache work; render_tile() computes the
 * radiance of one tile for one sample index and must be a pure function of
 * (state, scene, tile) so images do not depend on the thread count.
 *
 * DOES NOT: schedule tiles or accumulate samples (render.h does).
 *
 * STEP BY STEP
 *     volux_technique *t;
 *     volux_technique_create(ctx, "shaded", scene, &t);   // builds caches
 *     volux_scene_set_camera(scene, &cam);                // an edit
 *     volux_technique_update(t, scene);                   // least work
 *     volux_render(t, scene, fb, NULL);
 *     volux_technique_destroy(t);
 */
#ifndef VOLUX_TECHNIQUE_H
#define VOLUX_TECHNIQUE_H

#include "base.h"
#include "scene.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum volux_param_kind { VOLUX_PARAM_NUMBER, VOLUX_PARAM_INT, VOLUX_PARAM_BOOL, VOLUX_PARAM_STRING } volux_param_kind;

/* One documented technique parameter (scene "techniques": {"<name>": {...}}). */
typedef struct volux_param_info {
    const char *name;
    volux_param_kind kind;
    double def, min, max;   /* numbers; bools are 0/1                       */
    const char *def_string; /* strings                                      */
    const char *doc;
} volux_param_info;

/* A rectangle of pixels for one sample index. */
typedef struct volux_tile {
    int x0, y0, w, h;        /* pixel rectangle                             */
    uint32_t sample_index;   /* which sample of the pixel (0, 1, ...)       */
} volux_tile;

/* Optional per-tile statistics a technique may report (for benchmarks). */
typedef struct volux_tile_stats {
    uint64_t samples;   /* volume samples taken (ray-march steps)            */
    uint64_t vertices;  /* path vertices (stochastic techniques)             */
} volux_tile_stats;

typedef struct volux_technique_class {
    const char *name;
    const char *summary;            /* one line, for `volux techniques`    */
    const volux_param_info *params; /* terminated by name == NULL          */
    int progressive;                /* 1: more samples refine the image    */
    /* Creates state for `scene` and builds every cache (as if all changed). */
    volux_status (*create)(volux_context *ctx, volux_scene *scene, void **state);
    /* Brings caches up to date for the changes in `changes`. */
    volux_status (*update)(void *state, volux_scene *scene, const volux_change_set *changes);
    /* Radiance of every pixel of `tile` into rgb[(y·w + x)·3]. May add
     * counts to `stats` (never NULL). Called concurrently for different
     * tiles; must not write to state. */
    void (*render_tile)(const void *state, const volux_scene *scene, const volux_tile *tile, float *rgb,
                        volux_tile_stats *stats);
    size_t (*memory_bytes)(const void *state);
    void (*destroy)(void *state);
} volux_technique_class;

/* Registered classes. */
VOLUX_API int volux_technique_count(void);
VOLUX_API const volux_technique_class *volux_technique_class_at(int index);
VOLUX_API const volux_technique_class *volux_technique_find(const char *name);

/* Checks every "techniques" parameter stored in the scene against the
 * classes' tables: unknown technique or parameter, wrong kind, out of range
 * → VOLUX_ERR_INVALID naming "techniques.<name>.<param>". */
VOLUX_API volux_status volux_technique_validate_params(volux_context *ctx, const volux_scene *scene);

/* Value of a technique parameter from the scene, or the class default. */
VOLUX_API double volux_technique_param(const volux_scene *scene, const volux_technique_class *cls,
                                       const char *name);

typedef struct volux_technique volux_technique;

/* Creates the technique `name` for `scene` and builds its caches. */
VOLUX_API volux_status volux_technique_create(volux_context *ctx, const char *name, volux_scene *scene,
                                              volux_technique **out);
/* Applies everything that changed in the scene since the last create/update.
 * Sets *changed (may be NULL) to the change set it applied. */
VOLUX_API volux_status volux_technique_update(volux_technique *t, volux_scene *scene,
                                              volux_change_set *changed);
VOLUX_API const volux_technique_class *volux_technique_class_of(const volux_technique *t);
VOLUX_API size_t volux_technique_memory_bytes(const volux_technique *t);
VOLUX_API void volux_technique_destroy(volux_technique *t);

#ifdef __cplusplus
}
#endif
#endif
