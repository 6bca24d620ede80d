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

/* volux_tf_preset_load on text of length n; `name` is used in messages
 * (the file name), `preset_name` picks a preset (NULL: the first). */
volux_status volux_tf_preset_parse(volux_context *ctx, const char *text, size_t n, const char *name,
                                   const char *preset_name, double s_min, double s_max, volux_tf_preset *out);

#endif
