/*
 * volux/technique.h — illumination methods behind one small interface.
 *
 * A technique instance owns one method's caches for one scene. It is
 * created for a scene (building every cache), brought up to date after
 * scene edits (volux_technique_update maps the scene's change set to the
 * least cache work), and rendered by volux_render (render.h).
 *
 * The registered techniques are listed by name with their parameters
 * (volux_technique_info); their implementations are internal
 * (src/techniques/, one folder per method, listed in registry.c).
 *
 * DOES NOT: schedule tiles or accumulate samples (render.h does); modify
 * the scene (it is only read).
 *
 * STEP BY STEP
 *     volux_technique *t;
 *     volux_technique_create(ctx, "shaded", scene, &t);   // builds caches
 *     volux_scene_set_camera(scene, &cam);                // an edit
 *     volux_technique_update(t, scene, NULL);             // least work
 *     volux_render(t, scene, fb, NULL, NULL);              // (would also update)
 *     volux_technique_destroy(t);
 */
#ifndef VOLUX_TECHNIQUE_H
#define VOLUX_TECHNIQUE_H

#include "base.h"
#include "scene.h"

#ifdef __cplusplus
extern "C" {
#endif

/* VOLUX_PARAM_FILE is a string that names a file: a scene resolves it like
 * every other file it names (against the scene's folder, "$VOLUX_DATA/",
 * and inside the viewer's data root), so the technique gets a path it may
 * open. Appended last: the values of the others are ABI. */
typedef enum volux_param_kind {
    VOLUX_PARAM_NUMBER,
    VOLUX_PARAM_INT,
    VOLUX_PARAM_BOOL,
    VOLUX_PARAM_STRING,
    VOLUX_PARAM_FILE
} volux_param_kind;

/* One documented technique parameter (scene "techniques": {"<name>": {...}}). */
typedef struct volux_param_info {
    const char *name;
    volux_param_kind kind;
    double def, min, max;   /* numbers; bools are 0/1                       */
    const char *def_string; /* strings                                      */
    const char *doc;
} volux_param_info;

/* What a registered technique is, for listings and validation. */
typedef struct volux_technique_info {
    const char *name;               /* "ea", "pathtrace", ...               */
    const char *summary;            /* one line, for `volux techniques`    */
    const volux_param_info *params; /* terminated by name == NULL          */
    int progressive;                /* 1: more samples refine the image    */
} volux_technique_info;

/* Registered techniques, in registry order. Pointers are static. */
VOLUX_API int volux_technique_count(void);
VOLUX_API const volux_technique_info *volux_technique_info_at(int index);  /* NULL past the end */
VOLUX_API const volux_technique_info *volux_technique_info_find(const char *name); /* NULL if unknown */
/* For "did you mean": the registered name closest to a misspelt `name`
 * (a few letters off, or a prefix such as "path"), NULL when none is
 * close. Static string. */
VOLUX_API const char *volux_technique_closest(const char *name);

/* Checks every "techniques" parameter stored in the scene against the
 * registered techniques: unknown technique or parameter, wrong kind, out
 * of range → VOLUX_ERR_INVALID naming "techniques.<name>.<param>". */
VOLUX_API volux_status volux_technique_validate_params(volux_context *ctx, const volux_scene *scene);

typedef struct volux_technique volux_technique;

/* Creates the technique `name` for `scene` and builds its caches. Borrows
 * the scene for the call (the instance keeps no pointer that outlives a
 * scene edit without an update). VOLUX_ERR_INVALID for an unknown name, a
 * scene without a volume or bad parameters; NOMEM; technique-specific
 * statuses (e.g. UNSUPPORTED for a kernel this CPU lacks). Caller destroys. */
VOLUX_API volux_status volux_technique_create(volux_context *ctx, const char *name, const volux_scene *scene,
                                              volux_technique **out);
/* Applies everything that changed in the scene since the last create or
 * update (N edits cost one update). Sets *changed (may be NULL) to the
 * change set it applied. On failure the instance must not be rendered
 * until an update succeeds (volux_render retries it). */
VOLUX_API volux_status volux_technique_update(volux_technique *t, const volux_scene *scene,
                                              volux_change_set *changed);
/* Does the next step of work a progressive technique deferred after an
 * update (`sh` with techniques.sh.progressive: the coarse projection a TF
 * edit shows first is replaced by the full one). Brings the instance up
 * to date first. *refined (may be NULL) is 1 when this call changed the
 * instance (a framebuffer then restarts at the next render), *more (may
 * be NULL) while steps remain. A technique that defers nothing returns
 * VOLUX_OK with both 0. */
VOLUX_API volux_status volux_technique_refine(volux_technique *t, const volux_scene *scene, int *refined,
                                              int *more);
/* 1 if the instance is up to date with the scene (nothing to update). */
VOLUX_API int volux_technique_is_current(const volux_technique *t, const volux_scene *scene);

/* Deferred work left in a progressive update, in the technique's own units
 * (manylights: virtual lights still to be replaced after an extinction
 * edit, W13 §4.2); 0 when nothing is deferred or the technique does not
 * measure it. Each refine step that changes the instance decreases it. */
VOLUX_API uint64_t volux_technique_pending(const volux_technique *t);

/* For interactive front ends (`volux serve`): a per-frame budget, in
 * milliseconds of wall time, for the cache work of this instance's later
 * updates and refine steps, where the technique can spread an update over
 * frames (lightvol: §7.3's propagation per frame — it then replaces the
 * scene's techniques.lightvol.budget_ms and budget_slices for this
 * instance). An update does about one budget of the work (at least one
 * step), renders in between see the partly updated caches, and each
 * volux_technique_refine call does the next budget; once refine reports no
 * more steps the instance is exactly what an update without a budget gives.
 * The scene is not touched, so `volux render` of it is unaffected. 0 (or a
 * negative or NaN value) restores the scene's own setting. Returns 1 if the
 * technique honours a budget, 0 if it never defers work (nothing changes). */
VOLUX_API int volux_technique_set_budget(volux_technique *t, double ms);

/* Technique-specific statistics of the current state, for benchmarks
 * (e.g. manylights: "vl_count", "avsm_build_ms"). name and unit are static
 * strings. Writes at most `max` and returns how many the technique has. */
typedef struct volux_technique_stat {
    const char *name;
    double value;
    const char *unit;
} volux_technique_stat;
VOLUX_API int volux_technique_stats(const volux_technique *t, volux_technique_stat *out, int max);
VOLUX_API const volux_technique_info *volux_technique_info_of(const volux_technique *t);
/* Bytes held by the instance's state and caches. */
VOLUX_API size_t volux_technique_memory_bytes(const volux_technique *t);

/* What a render of `scene` with technique `name` (NULL: the scene's
 * render.technique) will hold, estimated from the scene before anything
 * is allocated (docs/SCALE.md): the volume as stored, the instance (state
 * and shared base), the technique's own caches, the framebuffer and the
 * resolved image at render.width × height. instance + technique is the
 * model of volux_technique_memory_bytes after creation. volux_technique_create
 * refuses (VOLUX_ERR_LIMIT) a render whose total exceeds the context's
 * memory limit (volux_context_set_memory_limit). */
typedef struct volux_memory_estimate {
    uint64_t volume, instance, technique, framebuffer, image;
    uint64_t total; /* their sum */
} volux_memory_estimate;
VOLUX_API volux_status volux_technique_estimate_memory(volux_context *ctx, const char *name, const volux_scene *scene,
                                                       volux_memory_estimate *out);
VOLUX_API void volux_technique_destroy(volux_technique *t);

#ifdef __cplusplus
}
#endif
#endif
