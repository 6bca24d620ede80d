/*
 * render/technique_class.h — what a technique implements, and the generic
 * instance machinery every technique reuses (pbrt's Integrator interface).
 *
 * A technique is a class: a state size, an update that maps a change set to
 * the least cache work, a tile renderer, and a release for its caches. The
 * generic code in render/technique.c allocates the state block, builds the
 * shared ray-caster base (render/raycaster.h, the first member of every
 * state) before each update, and frees both; a technique only writes what
 * differs. The one table of classes is src/techniques/registry.c.
 *
 * Internal: techniques, the frame loop and white-box tests include it.
 */
#ifndef VOLUX_TECHNIQUE_CLASS_H
#define VOLUX_TECHNIQUE_CLASS_H

#include "volux/technique.h"

/* The time budget of a render (render.time_ms), shared by every tile of
 * a wave: core/deadline.h. */
#include "core/deadline.h"
#include "core/name_guess.h"

/* A rectangle of pixels for one sample index. */
typedef struct volux_tile {
    int x0, y0, w, h;        /* pixel rectangle                             */
    uint32_t sample_index;   /* which sample of the pixel (0, 1, ...)       */
    volux_deadline *deadline; /* NULL: no time budget                       */
    void *wave;               /* the frame loop's wave (volux_tile_cancelled);
                                 NULL: never cancelled                       */
    /* Non-NULL: the frame loop wants first-hit features too
     * (volux_framebuffer_set_features): VOLUX_FEATURE_FLOATS per pixel at
     * features[(y·w + x)·VOLUX_FEATURE_FLOATS] (render/features.h); a
     * technique that writes them sets stats->features. */
    float *features;
} volux_tile;

/* 1 once the render's time budget is spent. A technique whose per-pixel
 * work has no fixed bound (path tracing: long paths in dense, bright
 * media) asks every few thousand volume samples and then ends its paths at
 * once; the frame loop drops such a wave (or, for the first wave, keeps it
 * and reports it as cut short: volux_render_report.truncated). The clock
 * is read on each call until it has expired, so do not call it per sample. */
int volux_tile_expired(const volux_tile *t);

/* 1 once the caller asked to cancel the render (the context's progress
 * callback returned nonzero). The frame loop asks between tiles; a
 * technique whose per-pixel work can be long (one light loop per sample:
 * `shaded` with 70 000 point lights takes ~4 ms a pixel) asks between
 * rays, so a cancel lands within ~10 ms instead of a tile's seconds. The
 * callback is polled at most every 10 ms (one clock read per call
 * otherwise); the tile is then dropped, like one of a cancelled wave. */
int volux_tile_cancelled(const volux_tile *t);

/* Per-tile statistics a technique may report (for benchmarks). */
typedef struct volux_tile_stats {
    uint64_t samples;   /* volume samples taken (ray-march steps)            */
    uint64_t vertices;  /* path vertices (stochastic techniques)             */
    uint64_t features;  /* pixels whose tile->features were written          */
} volux_tile_stats;

typedef struct volux_technique_class volux_technique_class;
struct volux_technique_class {
    volux_technique_info info;      /* name, summary, params, progressive  */
    /* Bytes of the state block; it starts with a volux_raycaster. */
    size_t state_size;
    /* Change bits that can never change this technique's image (e.g. `ea`
     * ignores lights and the phase function). The technique × edit test
     * matrix asserts that these edits leave the image unchanged and that
     * every other edit kind changes it. */
    uint32_t image_ignores;
    /* Largest |incremental − fresh| difference of a rendered image after
     * any edit, relative to the image's maximum: 0 = bit-identical (the
     * technique recomputes invalidated caches exactly); > 0 where an update
     * is incremental arithmetic (lightvol subtracts and adds light). */
    float update_tolerance;
    /* Optional: values the state needs before its first update that are
     * not zero (e.g. "no cache yet" markers). May not fail. */
    void (*init)(void *state);
    /* Brings the technique's caches up to date for `changes`; the base
     * (volume, LUT, majorant grid, camera, step, seed, lights, ...) is
     * already up to date. create applies volux_change_all(). */
    volux_status (*update)(void *state, const volux_scene *scene, const volux_change_set *changes);
    /* Radiance of every pixel of `tile` into rgb[(y·w + x)·3]. May add
     * counts to `stats` (never NULL). Called concurrently for different
     * tiles; must not write to the state, and must be a pure function of
     * (state, scene, tile) so images do not depend on the thread count. */
    void (*render_tile)(const void *state, const volux_scene *scene, const volux_tile *tile, float *rgb,
                        volux_tile_stats *stats);
    /* Bytes of the technique's own caches (the state block and the base
     * are counted by the caller). May be NULL. */
    size_t (*memory_bytes)(const void *state);
    /* Frees the technique's own caches (not the base, not the block); must
     * accept a state whose update failed half-way. May be NULL. */
    void (*release)(void *state);
    /* Optional (progressive techniques): the next step of cache work an
     * update deferred, e.g. the full projection after a coarse one, or
     * `manylights`' next virtual lights and shadow maps of a replacement.
     * Sets *changed when the image may change and *more while steps
     * remain; after a failure the state must still render (the next call
     * retries). NULL: nothing is ever deferred. */
    volux_status (*refine)(void *state, const volux_scene *scene, int *changed, int *more);
    /* Optional: the deferred work left, in the technique's own units (0 =
     * none); every refine step that changes the state must decrease it
     * (the test matrix checks). NULL: not measured. */
    uint64_t (*pending)(const void *state);
    /* Optional statistics for benchmarks (volux_technique_stats). */
    int (*stats)(const void *state, volux_technique_stat *out, int max);
    /* Optional (data-parallel rendering, volux_render_part): the radiance
     * gathered inside the scene volume's owned box (a brick,
     * volux_ray_clip_part) and the transmittance through it, for every
     * pixel of `tile`, into rgbt[(y·w + x)·4] (R, G, B premultiplied, T);
     * with `background` the escape radiance is added behind (C + T·L_bg).
     * Same purity rules as render_tile. NULL: the technique's light does
     * not stay inside a brick (scattering), so it cannot render one. */
    void (*render_tile_part)(const void *state, const volux_scene *scene, const volux_tile *tile, int background,
                             float *rgbt, volux_tile_stats *stats);
    /* Optional (volux_technique_set_budget): the front end's per-frame
     * budget for updates and refine steps in ms (0 = the scene's setting).
     * NULL: the technique never defers work. */
    void (*set_budget)(void *state, double ms);
    /* Optional (the memory budget, docs/SCALE.md): the bytes memory_bytes
     * will report once an instance is created for `scene`, from the scene
     * alone (dims, parameters, lights), before anything is allocated; the
     * frame loop's and the base's memory are counted by the caller
     * (render/memory_model.h has helpers for the shared caches). Adds to
     * *volume_added what the technique makes the volume hold (its bricked
     * copy, volux_mm_bricks_to_build). NULL: 0. */
    uint64_t (*estimate_bytes)(const volux_scene *scene, const volux_technique_class *cls, uint64_t *volume_added);
    /* Optional (progressive techniques whose estimator changes per pixel
     * sample, e.g. `manylights`' fresh virtual-light set per pass): called
     * by the frame loop before every wave with that wave's sample index,
     * never concurrently with render_tile. The state it leaves must be a
     * pure function of (scene, sample_index) so images stay independent of
     * how waves are split between calls; it must not change what update
     * made of the scene (no generation change). NULL: nothing per pass. */
    volux_status (*begin_pass)(void *state, const volux_scene *scene, uint32_t sample_index);
};

/* Creates an instance of `cls` for the scene (registry.c resolves names). */
volux_status volux_technique_create_class(volux_context *ctx, const volux_technique_class *cls,
                                          const volux_scene *scene, volux_technique **out);
const volux_technique_class *volux_technique_class_of(const volux_technique *t);
/* The class's state, read-only (for the frame loop and white-box tests). */
const void *volux_technique_state(const volux_technique *t);
/* Calls the class's begin_pass hook (if any) before a wave of `sample_index`. */
volux_status volux_technique_begin_pass(volux_technique *t, const volux_scene *scene, uint32_t sample_index);
/* Increases whenever an update or a refinement step applied a change (the
 * frame loop compares it with what a framebuffer's samples were rendered
 * from). */
uint64_t volux_technique_generation(const volux_technique *t);

/* Checks one stored parameter against its technique's table
 * (VOLUX_ERR_INVALID naming "techniques.<tech>.<name>"). */
volux_status volux_technique_check_param(volux_context *ctx, const volux_technique_info *info, const char *name,
                                         double number, const char *string);
/* "Did you mean": volux_name_guess (core/name_guess.h). */

/* Value of a parameter from the scene, or the class default. */
double volux_technique_param(const volux_scene *scene, const volux_technique_class *cls, const char *name);
const char *volux_technique_param_string(const volux_scene *scene, const volux_technique_class *cls,
                                         const char *name);

#endif
