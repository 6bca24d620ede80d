/*
 * io/scene_formats.h — parse-from-memory entry points of the scene loader
 * and the ParaView TF preset reader (private to io, tests and fuzzers), the
 * way volume_formats.h and image_formats.h expose the other readers.
 *
 * Both take a buffer and its length (it need not be NUL-terminated and may
 * contain NUL bytes, which are rejected), so a fuzzer needs no files.
 */
#ifndef VOLUX_SCENE_FORMATS_H
#define VOLUX_SCENE_FORMATS_H

#include <cjson/cJSON.h>

#include "volux/io.h"

/* Flags for volux_scene_parse. */
enum {
    /* Every file reference (volume.file, a transfer_function file name,
     * transfer_function.preset, lights[i].file) fails with
     * VOLUX_ERR_UNSUPPORTED before any path is built or opened: for
     * fuzzing and for scenes from untrusted sources. */
    VOLUX_SCENE_NO_FILES = 1u << 0
};

/* volux_scene_load_string with an explicit length and flags. `name` is used
 * in messages, `base_dir` resolves relative paths ("." if NULL). */
volux_status volux_scene_parse(volux_context *ctx, const char *text, size_t n, const char *base_dir,
                               const char *name, const char *const *overrides, int n_overrides, unsigned flags,
                               volux_scene **out);
/* The same with the caller's volume (NULL: read "volume"); see
 * volux_scene_load_string_with_volume. */
volux_status volux_scene_parse_with_volume(volux_context *ctx, const char *text, size_t n, const char *base_dir,
                                           const char *name, const char *const *overrides, int n_overrides,
                                           unsigned flags, volux_volume *volume, volux_scene **out);

/* The default transfer function of `vol` as a scene's "transfer_function"
 * object (rounded values, a comment saying where they came from). NULL
 * with *status set (NOMEM) on failure. */
cJSON *volux_auto_tf_json(volux_context *ctx, const volux_volume *vol, volux_status *status);

/* A JSON tree as text in context memory (free with volux_scene_json_free):
 * one key per line, arrays of numbers (vectors, TF rows) on one line. */
volux_status volux_json_print(volux_context *ctx, const cJSON *root, char **out);

/* ---- scene documents (scene_doc.c) ---- */

/* A list of resolved (symlink-free, absolute) file names. */
typedef struct volux_path_list {
    char **items;
    int n, cap;
} volux_path_list;

volux_status volux_path_list_add(volux_context *ctx, volux_path_list *l, const char *path);
int volux_path_list_has(const volux_path_list *l, const char *path);
void volux_path_list_free(volux_context *ctx, volux_path_list *l);

/* How the scene reader treats the files a scene names. */
typedef struct volux_scene_files {
    /* non-NULL: every file name resolved by the reader is appended (its
     * realpath; names that do not resolve are left to the loaders). */
    volux_path_list *record;
    /* non-NULL: a file name must resolve (symlinks followed) inside this
     * absolute, symlink-free folder or be in `trusted`; the loaders then
     * open the resolved name. */
    const char *root;
    const volux_path_list *trusted;
} volux_scene_files;

/* 1 if the absolute, symlink-free `path` lies inside `root` (same rules). */
int volux_path_inside(const char *path, const char *root);

/* Reads a whole scene tree into the fresh scene `out` (what volux_scene_parse
 * does after parsing and overrides). */
volux_status volux_scene_read_tree(volux_context *ctx, const cJSON *root, const char *base_dir, const char *name,
                                   const volux_scene_files *files, volux_scene *out);

/* What an edit changed, section by section (see volux_scene_read_edit). */
typedef struct volux_scene_edit_plan {
    int volume, transfer, camera;
    int time_step;                          /* render.time_step of the edit */
    int n_lights;                           /* size of the new "lights" array */
    unsigned char *light;                   /* [n_lights] 1: slot i changed or is new */
} volux_scene_edit_plan;

/* Frees what volux_scene_read_edit allocated in *plan (also after it failed). */
void volux_scene_edit_plan_free(volux_context *ctx, volux_scene_edit_plan *plan);

/* Reads the edited tree `root` into the fresh scene `candidate`, re-reading
 * only the sections that differ from `old_root` (files of unchanged
 * sections are not opened again: their state is copied from `live`).
 * Render settings, background and technique parameters are always read.
 * On success `candidate` is complete and *plan says what differs. A
 * sequence stays with `live` when the volume section is unchanged: the
 * candidate then holds the edit's time step as a single volume (taken from
 * live's sequence) and plan->time_step says which step live must select. */
volux_status volux_scene_read_edit(volux_context *ctx, const cJSON *root, const cJSON *old_root,
                                   const volux_scene *live, const char *base_dir, const char *name,
                                   const volux_scene_files *files, volux_scene *candidate,
                                   volux_scene_edit_plan *plan);

/* volux_tf_preset_load on text of length n; `name` is used in messages
 * (the file name), `preset_name` picks a preset (NULL: the first). */
volux_status volux_tf_preset_parse(volux_context *ctx, const char *text, size_t n, const char *name,
                                   const char *preset_name, double s_min, double s_max, volux_tf_preset *out);

#endif
