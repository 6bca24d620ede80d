/*
 * volux/scene.h — volume + transfer function + camera + lights + settings,
 * with per-aspect versions so techniques recompute only what an edit
 * invalidated.
 *
 * Setters validate first, then mutate, then bump the version of each aspect
 * they really changed (a TF edit that only moves colours bumps COLOR, not
 * EXTINCTION). Techniques remember the stamp they were built from and ask
 * volux_scene_changes_since(); N edits between two frames cost one update.
 *
 * Lights live in slots [0, VOLUX_MAX_LIGHTS): a slot is empty or holds a
 * light; removing a light empties its slot without moving the others, so a
 * slot index identifies a light for its whole life. The slot table grows
 * with the highest slot used (memory from the context's allocator), so a
 * scene pays for the lights it has, not for the cap.
 *
 * DOES NOT: read files (io.h), render (render.h). Not thread-safe for
 * mutation; read-only sharing during a render is safe.
 *
 * STEP BY STEP
 *     volux_scene *s;
 *     volux_scene_create(ctx, &s);
 *     volux_scene_set_volume(s, vol);             // retains vol
 *     volux_scene_set_transfer(s, &tf_desc);      // copies points
 *     volux_scene_set_light(s, 0, &light);
 *     ... render ...
 *     volux_scene_destroy(s);
 */
#ifndef VOLUX_SCENE_H
#define VOLUX_SCENE_H

#include "base.h"
#include "camera.h"
#include "light.h"
#include "sequence.h"
#include "transfer.h"
#include "volume.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Hard cap on light slots (VOLUX_ERR_LIMIT beyond): 2^20 slots of a few
 * hundred bytes each is a few hundred MB of scene before any technique
 * state, the most a scene should take without the user noticing. */
#define VOLUX_MAX_LIGHTS (1 << 20)
/* Largest environment-map texel value kept (larger ones are clamped with a
 * warning; NaN/Inf are refused): sums over a map and radiance × intensity
 * stay finite in float. */
#define VOLUX_ENV_TEXEL_MAX 1e30f
#define VOLUX_MAX_PARAMS 64

/* What an edit touched (bits of volux_change_set.what). */
typedef enum volux_change {
    VOLUX_CHANGE_VOLUME = 1u << 0,     /* volume / time step              */
    VOLUX_CHANGE_EXTINCTION = 1u << 1, /* opacity/extinction curve, unit  */
    VOLUX_CHANGE_COLOR = 1u << 2,      /* colour curve, materials         */
    VOLUX_CHANGE_DENSITY = 1u << 3,    /* global density scale only       */
    VOLUX_CHANGE_PHASE = 1u << 4,      /* HG anisotropy                   */
    VOLUX_CHANGE_LIGHTS = 1u << 5,     /* some light: see lights bitset   */
    VOLUX_CHANGE_CAMERA = 1u << 6,
    VOLUX_CHANGE_PARAMS = 1u << 7,     /* technique parameters            */
    VOLUX_CHANGE_RENDER = 1u << 8,     /* step, size, seed, max_depth, background */
    VOLUX_CHANGE_ALBEDO = 1u << 9,     /* scattering albedo only (σs/σt; emission–
                                          absorption images do not depend on it) */
    VOLUX_CHANGE_ALL = 0x3ffu
} volux_change;

typedef struct volux_scene volux_scene;

/* What changed between a stamp and the scene (volux_scene_changes_since).
 * Lights: the scene keeps one edit counter and, per slot, the counter's
 * value at the slot's last change (set, enable, remove); a slot changed
 * when that value is above `since`. The set therefore stays small however
 * many lights there are, and it reads the scene: it is valid until the
 * scene's next light edit (or its destruction). since = 0 means every
 * slot (volux_change_all, a stamp of another scene). */
typedef struct volux_change_set {
    uint32_t what;              /* volux_change bits                        */
    uint64_t since;             /* the stamp's light edit counter; 0: all    */
    const volux_scene *scene;   /* the scene asked (NULL with since = 0)     */
} volux_change_set;

/* 1 if the light in `slot` (or its removal) changed since the stamp. */
VOLUX_API int volux_change_light(const volux_change_set *c, int slot);
/* How many slots changed (O(slots); -1 for since = 0: all of them). */
VOLUX_API int volux_change_light_count(const volux_change_set *c);

/* Everything changed (what a technique's create() applies). */
static inline volux_change_set volux_change_all(void) {
    volux_change_set c;
    c.what = VOLUX_CHANGE_ALL;
    c.since = 0;
    c.scene = NULL;
    return c;
}

/* The versions a consumer saw (opaque contents, copyable, fixed size). */
typedef struct volux_scene_stamp {
    uint64_t scene_id;
    uint32_t aspect[10];
    uint64_t light_edits; /* the scene's light edit counter */
} volux_scene_stamp;

/* Render settings (scene "render" object). */
typedef struct volux_render_settings {
    int width, height;
    int spp;             /* samples per pixel to accumulate                 */
    float step;          /* march step in units of the smallest spacing     */
    uint64_t seed;
    int max_depth;       /* scattering events; 1 = single scattering        */
    float exposure;      /* PNG: multiply by 2^exposure                     */
    int threads;         /* 0 = all cores                                   */
    double time_ms;      /* progressive budget; 0 = none                    */
    double target_error; /* stop at this relative standard error; 0 = none  */
    char technique[32];
} volux_render_settings;

VOLUX_API void volux_render_settings_defaults(volux_render_settings *r);

VOLUX_API volux_status volux_scene_create(volux_context *ctx, volux_scene **out);
VOLUX_API void volux_scene_destroy(volux_scene *s);
VOLUX_API volux_context *volux_scene_context(const volux_scene *s);

/* Retains v and releases the previous volume (and sequence: v is a single
 * volume, time step 0 of 1). Bumps VOLUME. */
VOLUX_API volux_status volux_scene_set_volume(volux_scene *s, volux_volume *v);
VOLUX_API volux_volume *volux_scene_volume(const volux_scene *s); /* borrowed */

/* Crop box and clipping planes (world coordinates). A point p is kept when
 * it lies inside the box (if has_box) and, for every plane,
 * dot(p − origin, normal) ≤ 0: the side the normal points to is removed
 * (ParaView's Clip with "Invert"). Clipped material is empty space for
 * every technique and every ray (camera, shadow, cache builds): the scene
 * renders from a copy of the volume whose clipped voxels hold a value the
 * transfer function makes transparent (docs/CLIP.md). */
#define VOLUX_CLIP_MAX_PLANES 6
typedef struct volux_clip_plane {
    double origin[3];
    double normal[3]; /* any non-zero length */
} volux_clip_plane;
typedef struct volux_clip_desc {
    int has_box;
    double box_min[3], box_max[3];
    int n_planes; /* [0, VOLUX_CLIP_MAX_PLANES] */
    volux_clip_plane planes[VOLUX_CLIP_MAX_PLANES];
} volux_clip_desc;
/* VOLUX_ERR_INVALID naming the field ("clip.box: min[0] = 2 > max[0] = 1",
 * "clip.planes[1].normal: is zero", non-finite numbers, too many planes). */
VOLUX_API volux_status volux_clip_desc_validate(volux_context *ctx, const volux_clip_desc *d);
/* 1 if the clip keeps world point p (a NULL clip keeps everything). */
VOLUX_API int volux_clip_keeps(const volux_clip_desc *d, const double p[3]);
/* Copies d (NULL or nothing set: no clipping). When the clip changes (and
 * there is a volume) the clipped copy is rebuilt and VOLUME bumps.
 * VOLUX_ERR_UNSUPPORTED when the transfer function has no transparent
 * value in the volume's range to fill clipped voxels with. */
VOLUX_API volux_status volux_scene_set_clip(volux_scene *s, const volux_clip_desc *d);
VOLUX_API const volux_clip_desc *volux_scene_clip(const volux_scene *s);

/* Time-varying volumes (volux/sequence.h). set_sequence KEEPS q on
 * success (the scene destroys it, and any earlier sequence or volume is
 * replaced) and selects `step`; on failure the caller still owns q and the
 * scene is unchanged. set_time_step makes step `step` the volume (loaded
 * through the sequence's cache, LUT baked) and bumps VOLUME when the step
 * changes; a single volume has the one step 0. VOLUX_ERR_INVALID for a step
 * out of range, VOLUX_ERR_FORMAT for a step whose shape differs, the
 * loader's status otherwise; on failure the scene is unchanged. */
VOLUX_API volux_status volux_scene_set_sequence(volux_scene *s, volux_sequence *q, int step);
VOLUX_API volux_status volux_scene_set_time_step(volux_scene *s, int step);
VOLUX_API int volux_scene_time_step(const volux_scene *s);  /* 0 for a single volume */
VOLUX_API int volux_scene_time_steps(const volux_scene *s); /* 1 for a single volume */
/* The scene's sequence (owned by the scene), NULL for a single volume.
 * Techniques that read other steps than the current one acquire them here
 * from update code (acquiring may load and changes the cache). */
VOLUX_API volux_sequence *volux_scene_sequence(const volux_scene *s);
/* Copies d (and its points). Compares with the current TF and bumps only
 * what changed: EXTINCTION (opacity/extinction curve, unit distance),
 * DENSITY, COLOR (colour curve, albedo, Blinn–Phong material, material
 * channel), PHASE. */
VOLUX_API volux_status volux_scene_set_transfer(volux_scene *s, const volux_transfer_desc *d);
/* The current description; its arrays are owned by the scene. */
VOLUX_API const volux_transfer_desc *volux_scene_transfer(const volux_scene *s);
/* The baked LUT over the volume's value range, NULL without a volume. The
 * setters that change it (volume, transfer function) bake it before they
 * return, reporting failures (NOMEM) through their status; this getter
 * never changes the scene. */
VOLUX_API const volux_transfer_lut *volux_scene_transfer_lut(const volux_scene *s);
VOLUX_API volux_status volux_scene_set_camera(volux_scene *s, const volux_camera_desc *d);
VOLUX_API const volux_camera_desc *volux_scene_camera_desc(const volux_scene *s);
/* Resolves the camera for the render settings' image size. */
VOLUX_API volux_status volux_scene_camera(const volux_scene *s, volux_camera *out);

/* Sets (adds or replaces) the light in `slot`. Copies d, including an
 * environment map. Bumps LIGHTS and the slot. A slot past the table grows
 * it (geometrically: n lights added in slot order cost O(n)); NOMEM when
 * that fails, VOLUX_ERR_LIMIT for slot >= VOLUX_MAX_LIGHTS. */
VOLUX_API volux_status volux_scene_set_light(volux_scene *s, int slot, const volux_light_desc *d);
VOLUX_API volux_status volux_scene_remove_light(volux_scene *s, int slot);
VOLUX_API volux_status volux_scene_set_light_enabled(volux_scene *s, int slot, int enabled);
/* The light in `slot`, or NULL if the slot is empty. Owned by the scene. */
VOLUX_API const volux_light_desc *volux_scene_light(const volux_scene *s, int slot);
/* One past the highest occupied slot (loops over lights stop here). */
VOLUX_API int volux_scene_light_slots(const volux_scene *s);

/* Notes the loader left for the user (e.g. "no transfer_function: using
 * the default ..."), one per line; "" when none. The library never prints
 * them; the CLI does. */
VOLUX_API const char *volux_scene_notes(const volux_scene *s);
VOLUX_API void volux_scene_add_note(volux_scene *s, const char *note);

VOLUX_API void volux_scene_set_background(volux_scene *s, volux_vec3 rgb);
VOLUX_API volux_vec3 volux_scene_background(const volux_scene *s);
VOLUX_API volux_status volux_scene_set_render(volux_scene *s, const volux_render_settings *r);
VOLUX_API const volux_render_settings *volux_scene_render(const volux_scene *s);

/* Technique parameters ("techniques": {"<name>": {...}}), numbers or
 * strings. Validation against a technique's parameter table happens in
 * volux_technique_validate_params(). Bumps PARAMS. */
VOLUX_API volux_status volux_scene_set_param(volux_scene *s, const char *technique, const char *name,
                                             double number, const char *string /* NULL: number */);
/* Removes a parameter (the technique then uses its default); bumps PARAMS
 * if it was set, does nothing otherwise. Never fails today (a status for
 * symmetry with the setters). */
VOLUX_API volux_status volux_scene_remove_param(volux_scene *s, const char *technique, const char *name);
/* Number value, or `fallback` when unset. */
VOLUX_API double volux_scene_param(const volux_scene *s, const char *technique, const char *name,
                                   double fallback);
/* String value (owned by the scene), or `fallback` when unset. */
VOLUX_API const char *volux_scene_param_string(const volux_scene *s, const char *technique,
                                               const char *name, const char *fallback);
/* Enumerates parameters: returns 0 past the end. */
VOLUX_API int volux_scene_param_at(const volux_scene *s, int index, const char **technique,
                                   const char **name, double *number, const char **string);

/* What a ray leaving the volume in direction `dir` sees: the sum of the
 * enabled, visible environment lights, or the background if there is none. */
VOLUX_API volux_vec3 volux_scene_escape_radiance(const volux_scene *s, volux_vec3 dir);

/* World-space centre and bounding-sphere radius of the volume box. */
VOLUX_API void volux_scene_bounds_sphere(const volux_scene *s, volux_vec3 *center, float *radius);
/* Ray-march step in world units (render.step × smallest spacing). */
VOLUX_API float volux_scene_step_world(const volux_scene *s);

/* Makes dst describe what src describes, aspect by aspect, through the
 * setters above, so only what really differs is bumped (an edit applied to
 * a copy of a scene — e.g. a reloaded JSON with one --set path changed —
 * then costs the techniques exactly that edit). Volume (unless keep_volume;
 * dst retains src's volume), transfer function, camera, every light slot
 * (set, replaced or removed), background, render settings, and every
 * technique parameter of src (parameters only dst has are kept). Both
 * scenes must come from contexts used by this thread. On failure dst holds
 * the aspects assigned so far (each one consistent) and the error is in
 * dst's context. */
VOLUX_API volux_status volux_scene_assign(volux_scene *dst, const volux_scene *src, int keep_volume);

VOLUX_API volux_scene_stamp volux_scene_stamp_now(const volux_scene *s);
/* What changed since `seen`. A stamp from another scene (or zeroed) yields
 * VOLUX_CHANGE_ALL with every light slot changed. O(1): the light slots
 * are asked one by one through volux_change_light. */
VOLUX_API volux_change_set volux_scene_changes_since(const volux_scene *s, const volux_scene_stamp *seen);

#ifdef __cplusplus
}
#endif
#endif
