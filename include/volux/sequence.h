/*
 * volux/sequence.h — a time-varying volume: a sequence of time steps, each
 * an immutable, refcounted volux_volume, loaded on demand through a loader
 * callback and kept in a cache bounded by memory.
 *
 * A scene holds at most one sequence (volux_scene_set_sequence); selecting
 * a time step (volux_scene_set_time_step) makes that step the scene's
 * volume and bumps VOLUME, so every technique handles a time step like any
 * other volume edit. Techniques that want to read other steps than the
 * current one (lazy cache updates over an animation) acquire them from the
 * scene's sequence.
 *
 * Every step must have the shape of the first step loaded: the same dims,
 * scalar type and spacing. A step that differs is VOLUX_ERR_FORMAT naming
 * the step (io's loaders also check every frame's header up front).
 *
 * The cache keeps recently used steps (least recently used dropped first)
 * as long as their bytes stay within the limit; a step that alone exceeds
 * the limit is loaded but not kept. Volumes handed out are retained, so
 * dropping a step from the cache never frees a volume someone still uses.
 *
 * DOES NOT: read files (io.h has loaders for file lists, printf patterns
 * and the animated procedural cloud). Not thread-safe: acquire loads and
 * changes the cache, so call it from setup and update code, never during
 * a render.
 *
 * STEP BY STEP
 *     volux_sequence_desc d = {.steps = 20, .load = my_loader, .user = me};
 *     volux_sequence *q;
 *     volux_sequence_create(ctx, &d, &q);
 *     volux_scene_set_sequence(scene, q, 0);    // keeps q, loads step 0
 *     volux_scene_set_time_step(scene, 5);     // step 5 becomes the volume
 *     volux_volume *v;
 *     volux_sequence_acquire(q, 4, &v);         // another step, retained
 *     volux_volume_release(v);
 */
#ifndef VOLUX_SEQUENCE_H
#define VOLUX_SEQUENCE_H

#include "base.h"
#include "volume.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Largest number of time steps in one sequence. */
#define VOLUX_MAX_STEPS 1000000
/* Default bound on the bytes of cached steps. */
#define VOLUX_SEQUENCE_CACHE_DEFAULT (512ull << 20)

/* Loads step `step` ∈ [0, steps) into a new volume with one reference
 * (the sequence releases it). Errors are recorded in ctx and returned. */
typedef volux_status (*volux_step_load_fn)(void *user, volux_context *ctx, int step, volux_volume **out);

typedef struct volux_sequence_desc {
    int steps;                /* in [1, VOLUX_MAX_STEPS]                      */
    volux_step_load_fn load;  /* required                                     */
    void *user;               /* for load; owned by the sequence on success   */
    /* Frees `user` when the sequence is destroyed (may be NULL). Not called
     * when volux_sequence_create fails: the caller still owns user then. */
    void (*release_user)(volux_context *ctx, void *user);
    const char *name;         /* for messages, e.g. the pattern (copied)      */
    uint64_t cache_bytes;     /* bound on cached steps; 0 = the default       */
} volux_sequence_desc;

typedef struct volux_sequence volux_sequence;

/* Creates a sequence (loads nothing yet). VOLUX_ERR_INVALID for a bad
 * description; NOMEM. Caller destroys, unless a scene keeps it. */
VOLUX_API volux_status volux_sequence_create(volux_context *ctx, const volux_sequence_desc *d, volux_sequence **out);
/* Releases the cached steps and frees the sequence (and its user data).
 * NULL is ignored. */
VOLUX_API void volux_sequence_destroy(volux_sequence *q);
VOLUX_API int volux_sequence_steps(const volux_sequence *q);
/* Unique per sequence created in this process (never reused), so a cache
 * keyed by (sequence, step) can tell sequences apart. */
VOLUX_API uint64_t volux_sequence_id(const volux_sequence *q);
VOLUX_API const char *volux_sequence_name(const volux_sequence *q);
/* The volume of step `step`, retained (caller releases): from the cache, or
 * loaded and checked against the shape of the first step loaded.
 * VOLUX_ERR_INVALID for a step out of range, VOLUX_ERR_FORMAT for a step of
 * another shape, the loader's status otherwise (the sequence is unchanged). */
VOLUX_API volux_status volux_sequence_acquire(volux_sequence *q, int step, volux_volume **out);
/* Bytes of the cached steps (≤ the limit) and how many steps have been
 * loaded so far (cache misses), for tests and reports. */
VOLUX_API uint64_t volux_sequence_cached_bytes(const volux_sequence *q);
VOLUX_API uint64_t volux_sequence_loads(const volux_sequence *q);
/* Changes the bound (0 = the default) and drops steps over it. */
VOLUX_API void volux_sequence_set_cache_limit(volux_sequence *q, uint64_t bytes);

#ifdef __cplusplus
}
#endif
#endif
