/*
 * io/scene_json.c — the scene file of DESIGN §3.
 *
 * Loading is two-phase: parse + apply --set overrides to the JSON tree, then
 * read it strictly into a fresh scene (unknown keys are errors naming their
 * path). Relative file names resolve against the scene file's folder.
 */
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "json_reader.h"
#include "merl.h"
#include "scene_formats.h"
#include "core/scene_internal.h"

#define BIG 1e30
/* Positions and directions: the core squares float lengths, so a
 * coordinate near 1e19 already overflows to inf (a degenerate camera that
 * renders black, or a misleading "up is parallel" error). 1e15 world
 * units is far beyond any volume and keeps squared distances finite. */
#define COORD 1e15

typedef struct scene_reader {
    volux_json_reader json;
    const char *base_dir;
    volux_scene *scene;
    unsigned flags; /* VOLUX_SCENE_* */
    const volux_scene_load_options *opt; /* data folder, preloaded volume (may be NULL) */
    /* A transfer function given as a file name that --set reached into:
     * the file was read into the tree, and its relative names still
     * resolve against its own folder ("" when none). */
    char tf_file[4096];
    volux_volume *supplied; /* the caller's volume: "volume" is not read */
    const volux_scene_files *files; /* NULL: names are used as given */
    int untrusted_volume;           /* set by resolve_path: a volume file (file,
                                       files[i], pattern) the loaded document
                                       did not name */
} scene_reader;

#define DATA_PREFIX "$VOLUX_DATA/"

/* dir + "/" + name unless name is absolute. `key` is the scene path of the
 * name, for messages. Every file the scene names passes through here, so
 * this is where VOLUX_SCENE_NO_FILES stops them. */
/* The folder "$VOLUX_DATA/" names: the caller's, else the environment's. */
static const char *data_dir(const scene_reader *sr) {
    if (sr->opt && sr->opt->data_dir && *sr->opt->data_dir) return sr->opt->data_dir;
    const char *env = getenv("VOLUX_DATA");
    return env && *env ? env : NULL;
}

static volux_status resolve_path(scene_reader *sr, const char *base_dir, const char *name, const char *key,
                                 char *out, size_t n) {
    if (sr->flags & VOLUX_SCENE_NO_FILES)
        return volux_json_error(&sr->json, VOLUX_ERR_UNSUPPORTED, key, "file references are disabled here");
    if (!*name) return volux_json_error(&sr->json, VOLUX_ERR_INVALID, key, "empty file name");
    int w;
    if (!strncmp(name, DATA_PREFIX, strlen(DATA_PREFIX))) {
        /* The shared data (docs/CONVENTIONS.md): one root for every scene. */
        const char *root = data_dir(sr);
        if (!root)
            return volux_json_error(&sr->json, VOLUX_ERR_IO, key,
                                    "%.200s: VOLUX_DATA is not set (the folder holding volumes/ and envmaps/; the "
                                    "volux command defaults it to ../shared/data beside the repository)",
                                    name);
        w = snprintf(out, n, "%s/%s", root, name + strlen(DATA_PREFIX));
    } else {
        w = name[0] == '/' || !base_dir || !*base_dir ? snprintf(out, n, "%s", name)
                                                      : snprintf(out, n, "%s/%s", base_dir, name);
    }
    if (w < 0 || (size_t)w >= n) return volux_json_error(&sr->json, VOLUX_ERR_INVALID, key, "path too long");
    const volux_scene_files *f = sr->files;
    if (!f || (!f->record && !f->root)) return VOLUX_OK;
    char real[PATH_MAX];
    /* Under a data root (the viewer) a missing file and one outside the
     * root get the same message: a client must not learn which names
     * exist outside it. The root itself is not named: `volux view`'s is a
     * private temporary folder (the server shows the root at start-up). */
    if (!realpath(out, real)) {
        if (!f->root) return VOLUX_OK; /* recording: the loader reports it */
        return volux_json_error(&sr->json, VOLUX_ERR_INVALID, key, "'%s' is not available in the data root", name);
    }
    if (f->record && volux_path_list_add(sr->json.ctx, f->record, real))
        return volux_json_error(&sr->json, VOLUX_ERR_NOMEM, key, "out of memory");
    if (!f->root) return VOLUX_OK;
    int trusted = f->trusted && volux_path_list_has(f->trusted, real);
    if (!trusted && !volux_path_inside(real, f->root))
        return volux_json_error(&sr->json, VOLUX_ERR_INVALID, key, "'%s' is not available in the data root", name);
    if (!strncmp(key, "volume.", 7) && !trusted) sr->untrusted_volume = 1;
    /* Open the name that was checked (no symlink left to swap). */
    if (strlen(real) >= n) return volux_json_error(&sr->json, VOLUX_ERR_INVALID, key, "path too long");
    strcpy(out, real);
    return VOLUX_OK;
}

static void dir_of(const char *path, char *out, size_t n) {
    const char *slash = strrchr(path, '/');
    if (!slash) snprintf(out, n, ".");
    else if (slash == path) snprintf(out, n, "/");
    else snprintf(out, n, "%.*s", (int)(slash - path), path);
}

/* ------------------------------------------------------------------ volume */

/* The files of a file-based volume, resolved against the scene's folder:
 * one "file" or a "files" list (allocated through ctx; *n of them). */
typedef struct frame_list {
    char **paths;
    int n, cap;
} frame_list;

static void free_frame_list(volux_context *ctx, frame_list *f) {
    for (int i = 0; i < f->n; i++) volux_strfree(ctx, f->paths[i]);
    volux_free(ctx, f->paths, sizeof *f->paths * (size_t)f->cap);
    f->paths = NULL;
    f->n = f->cap = 0;
}

static volux_status add_frame(scene_reader *sr, frame_list *f, const char *name, const char *key) {
    char path[4096];
    volux_status st = resolve_path(sr, sr->base_dir, name, key, path, sizeof path);
    if (st) return st;
    if (!(f->paths[f->n] = volux_strdup(sr->json.ctx, path)))
        return volux_json_error(&sr->json, VOLUX_ERR_NOMEM, key, "out of memory");
    f->n++;
    return VOLUX_OK;
}

static volux_status read_frames(scene_reader *sr, const cJSON *obj, frame_list *f) {
    volux_json_reader *r = &sr->json;
    const cJSON *files = cJSON_GetObjectItemCaseSensitive(obj, "files");
    const char *file = NULL;
    volux_status st = volux_json_string(r, obj, "volume", "file", &file);
    if (st) return st;
    int n = 1;
    if (files) {
        if (!cJSON_IsArray(files) || cJSON_GetArraySize(files) < 1)
            return volux_json_error(r, VOLUX_ERR_INVALID, "volume.files", "expected a non-empty array of file names");
        n = cJSON_GetArraySize(files);
        if (n > VOLUX_MAX_STEPS)
            return volux_json_error(r, VOLUX_ERR_LIMIT, "volume.files", "more than %d files", VOLUX_MAX_STEPS);
    }
    f->paths = volux_calloc(r->ctx, (size_t)n, sizeof *f->paths);
    if (!f->paths) return volux_json_error(r, VOLUX_ERR_NOMEM, "volume", "out of memory");
    f->cap = n;
    if (!files) return add_frame(sr, f, file, "volume.file");
    int i = 0;
    for (const cJSON *c = files->child; c; c = c->next, i++) {
        char p[48];
        snprintf(p, sizeof p, "volume.files[%d]", i);
        if (!cJSON_IsString(c)) return volux_json_error(r, VOLUX_ERR_INVALID, p, "expected a file name");
        if ((st = add_frame(sr, f, c->valuestring, p))) return st;
    }
    return VOLUX_OK;
}

/* A volume file the loaded document did not name (an edit): its detached
 * data must stay in the data root too, whether it is one file, a list of
 * time steps or a pattern. */
static volux_status confine_untrusted_volume(scene_reader *sr, int allow_outside, volux_volume_load_options *opt) {
    if (!sr->untrusted_volume) return VOLUX_OK;
    if (allow_outside)
        return volux_json_error(&sr->json, VOLUX_ERR_INVALID, "volume.allow_outside_dir",
                                "not allowed for a file outside the loaded scene (data root %s)", sr->files->root);
    opt->data_root = sr->files->root;
    return VOLUX_OK;
}

/* "pattern" + "range": [first, last] or [first, last, step]. */
static volux_status read_range(scene_reader *sr, const cJSON *obj, int range[3]) {
    volux_json_reader *r = &sr->json;
    const cJSON *jr = cJSON_GetObjectItemCaseSensitive(obj, "range");
    if (!jr || !cJSON_IsArray(jr) || (cJSON_GetArraySize(jr) != 2 && cJSON_GetArraySize(jr) != 3))
        return volux_json_error(r, VOLUX_ERR_INVALID, "volume.range",
                                "a pattern needs \"range\": [first, last] or [first, last, step]");
    range[2] = 1;
    int i = 0;
    for (const cJSON *c = jr->child; c; c = c->next, i++) {
        if (!cJSON_IsNumber(c) || c->valuedouble != floor(c->valuedouble) || fabs(c->valuedouble) > 1e9) {
            char p[32];
            snprintf(p, sizeof p, "volume.range[%d]", i);
            return volux_json_error(r, VOLUX_ERR_INVALID, p, "expected an integer in [-1e9, 1e9]");
        }
        range[i] = (int)c->valuedouble;
    }
    if (range[1] < range[0] || range[2] < 1)
        return volux_json_error(r, VOLUX_ERR_INVALID, "volume.range",
                                "[%d, %d] step %d is empty (need first <= last, step >= 1)", range[0], range[1],
                                range[2]);
    return VOLUX_OK;
}

static volux_status read_volume(scene_reader *sr, const cJSON *obj) {
    volux_json_reader *r = &sr->json;
    /* Keys per kind: a raw-file key on a procedural volume (or a seed on a
     * file) would otherwise be silently ignored. */
    static const char *const file_keys[] = {"file",      "files",          "pattern", "range", "dims",
                                            "type",      "endian",         "spacing", "byte_skip",
                                            "use_file_origin", "allow_outside_dir", "allow_nonfinite", "cache_mb",
                                            "comment", NULL};
    static const char *const proc_keys[] = {"procedural", "dims", "seed", "time", "steps", "time_per_step",
                                            "cache_mb", "comment", NULL};
    volux_status st;
    if (!obj) return volux_json_error(r, VOLUX_ERR_INVALID, "volume", "missing (a file or a procedural volume)");
    if (!cJSON_IsObject(obj)) return volux_json_error(r, VOLUX_ERR_INVALID, "volume", "expected an object");
    static const char *const kinds[] = {"file", "files", "pattern", "procedural"};
    int n_kinds = 0;
    for (int i = 0; i < 4; i++) n_kinds += cJSON_GetObjectItemCaseSensitive(obj, kinds[i]) != NULL;
    if (n_kinds != 1)
        return volux_json_error(r, VOLUX_ERR_INVALID, "volume", "give exactly one of file, files, pattern, procedural");
    int has_file = cJSON_GetObjectItemCaseSensitive(obj, "procedural") == NULL;
    if ((st = volux_json_check_keys(r, obj, "volume", has_file ? file_keys : proc_keys))) return st;
    const char *proc = NULL, *type = NULL, *endian = NULL;
    if ((st = volux_json_string(r, obj, "volume", "procedural", &proc)) ||
        (st = volux_json_string(r, obj, "volume", "type", &type)) ||
        (st = volux_json_string(r, obj, "volume", "endian", &endian)))
        return st;
    int dims[3] = {0, 0, 0}, use_file_origin = 0, allow_outside = 0, allow_nonfinite = 0, steps = 1;
    float spacing[3] = {1, 1, 1};
    double seed = 1, byte_skip = 0, time0 = 0, time_per_step = 0.05, cache_mb = 0;
    const cJSON *jd = cJSON_GetObjectItemCaseSensitive(obj, "dims");
    if (jd) {
        if (!cJSON_IsArray(jd) || cJSON_GetArraySize(jd) != 3)
            return volux_json_error(r, VOLUX_ERR_INVALID, "volume.dims", "expected 3 integers");
        int i = 0;
        for (const cJSON *c = jd->child; c; c = c->next, i++) {
            if (!cJSON_IsNumber(c) || c->valuedouble != floor(c->valuedouble) || c->valuedouble < 1 ||
                c->valuedouble > VOLUX_MAX_DIM) {
                char p[32];
                snprintf(p, sizeof p, "volume.dims[%d]", i);
                return volux_json_error(r, VOLUX_ERR_INVALID, p, "must be an integer in [1, %d]", VOLUX_MAX_DIM);
            }
            dims[i] = (int)c->valuedouble;
        }
    }
    if ((st = volux_json_vec3(r, obj, "volume", "spacing", 1e-12, 1e12, spacing)) ||
        (st = volux_json_number(r, obj, "volume", "seed", 0, 9007199254740992.0, &seed)) ||
        (st = volux_json_number(r, obj, "volume", "byte_skip", 0, 9007199254740992.0, &byte_skip)) ||
        (st = volux_json_bool(r, obj, "volume", "use_file_origin", &use_file_origin)) ||
        (st = volux_json_bool(r, obj, "volume", "allow_outside_dir", &allow_outside)) ||
        (st = volux_json_bool(r, obj, "volume", "allow_nonfinite", &allow_nonfinite)) ||
        (st = volux_json_number(r, obj, "volume", "time", -1e6, 1e6, &time0)) ||
        (st = volux_json_number(r, obj, "volume", "time_per_step", -1e3, 1e3, &time_per_step)) ||
        (st = volux_json_int(r, obj, "volume", "steps", 1, VOLUX_MAX_STEPS, &steps)) ||
        (st = volux_json_number(r, obj, "volume", "cache_mb", 1, 1e9, &cache_mb)))
        return st;
    if (seed != floor(seed)) return volux_json_error(r, VOLUX_ERR_INVALID, "volume.seed", "expected an integer");
    if (byte_skip != floor(byte_skip))
        return volux_json_error(r, VOLUX_ERR_INVALID, "volume.byte_skip", "expected an integer");
    uint64_t cache_bytes = (uint64_t)(cache_mb * 1048576.0);

    volux_volume *vol = NULL;
    volux_sequence *seq = NULL;
    const volux_volume_region *region = sr->opt ? sr->opt->region : NULL;
    if (region && (steps > 1 || cJSON_GetObjectItemCaseSensitive(obj, "files") ||
                   cJSON_GetObjectItemCaseSensitive(obj, "pattern") ||
                   (proc && cJSON_GetObjectItemCaseSensitive(obj, "time"))))
        return volux_json_error(r, VOLUX_ERR_UNSUPPORTED, "volume",
                                "a data-parallel render loads one brick of one volume, not a time series");
    if (proc) {
        if (!jd) dims[0] = dims[1] = dims[2] = 64;
        int animated = volux_procedural_is_animated(proc);
        if (!animated && (cJSON_GetObjectItemCaseSensitive(obj, "time") || steps > 1 ||
                          cJSON_GetObjectItemCaseSensitive(obj, "time_per_step")))
            return volux_json_error(r, VOLUX_ERR_INVALID, "volume", "procedural '%.32s' is not animated (time, steps "
                                    "and time_per_step are for \"cloud\")", proc);
        if (steps == 1 && (cJSON_GetObjectItemCaseSensitive(obj, "time_per_step") ||
                           cJSON_GetObjectItemCaseSensitive(obj, "cache_mb")))
            return volux_json_error(r, VOLUX_ERR_INVALID, "volume", "time_per_step and cache_mb need steps > 1");
        st = steps > 1 ? volux_sequence_procedural(r->ctx, proc, dims, (uint64_t)seed, time0, time_per_step, steps,
                                                   cache_bytes, &seq)
                       : region ? volux_volume_procedural_region(r->ctx, proc, dims, (uint64_t)seed, region, &vol)
                                : volux_volume_procedural_at(r->ctx, proc, dims, (uint64_t)seed, time0, &vol);
        if (st) {
            volux_error_prefix(r->ctx, "%s: volume.procedural: ", r->file);
            return st;
        }
    } else {
        /* Layout keys describe a raw file; with a self-describing header
         * they would be silently ignored. */
        static const char *const raw_only[] = {"endian", "spacing", "byte_skip"};
        if (!jd && !type)
            for (int k = 0; k < 3; k++)
                if (cJSON_GetObjectItemCaseSensitive(obj, raw_only[k])) {
                    char p[32];
                    snprintf(p, sizeof p, "volume.%s", raw_only[k]);
                    return volux_json_error(r, VOLUX_ERR_INVALID, p,
                                            "only for a raw file (give dims and type too)");
                }
        volux_volume_load_options opt = {0};
        volux_raw_desc raw;
        opt.use_file_origin = use_file_origin;
        opt.allow_outside_dir = allow_outside;
        opt.allow_nonfinite = allow_nonfinite;
        opt.region = region;
        if (jd || type) { /* an explicit layout means a raw file */
            memset(&raw, 0, sizeof raw);
            if (!jd || !type)
                return volux_json_error(r, VOLUX_ERR_INVALID, "volume", "a raw file needs both dims and type");
            memcpy(raw.dims, dims, sizeof dims);
            if (volux_scalar_type_parse(type, &raw.type))
                return volux_json_error(r, VOLUX_ERR_INVALID, "volume.type",
                                        "unknown type '%s' (uint8, int8, uint16, int16, float32, float64)", type);
            if (endian && strcmp(endian, "little") && strcmp(endian, "big"))
                return volux_json_error(r, VOLUX_ERR_INVALID, "volume.endian", "expected \"little\" or \"big\"");
            raw.big_endian = endian && !strcmp(endian, "big");
            for (int a = 0; a < 3; a++) raw.spacing[a] = spacing[a];
            raw.byte_skip = (uint64_t)byte_skip;
            opt.raw = &raw;
        }
        int single = cJSON_GetObjectItemCaseSensitive(obj, "file") != NULL;
        const char *pattern = NULL;
        if ((st = volux_json_string(r, obj, "volume", "pattern", &pattern))) return st;
        if (single && cJSON_GetObjectItemCaseSensitive(obj, "cache_mb"))
            return volux_json_error(r, VOLUX_ERR_INVALID, "volume.cache_mb", "only for files or a pattern");
        if (!pattern && cJSON_GetObjectItemCaseSensitive(obj, "range"))
            return volux_json_error(r, VOLUX_ERR_INVALID, "volume.range", "only with a pattern");
        /* The layout is checked first: its errors do not depend on the file. */
        if (pattern) {
            int range[3];
            char resolved[4096], dir[4096];
            /* The scene's folder goes in front of the pattern, so any % in
             * it must become a literal %%. */
            size_t o = 0;
            for (const char *c = sr->base_dir; *c && o + 2 < sizeof dir; c++) {
                if (*c == '%') dir[o++] = '%';
                dir[o++] = *c;
            }
            dir[o] = 0;
            if ((st = read_range(sr, obj, range)) ||
                (st = resolve_path(sr, dir, pattern, "volume.pattern", resolved, sizeof resolved)) ||
                (st = confine_untrusted_volume(sr, allow_outside, &opt)))
                return st;
            st = volux_sequence_load_pattern(r->ctx, resolved, range[0], range[1], range[2], &opt, cache_bytes, &seq);
            if (st) volux_error_prefix(r->ctx, "%s: volume.pattern: ", r->file);
        } else {
            frame_list frames = {NULL, 0, 0};
            st = read_frames(sr, obj, &frames);
            const volux_scene_load_options *o = sr->opt;
            const cJSON *file_item = cJSON_GetObjectItemCaseSensitive(obj, "file");
            if (!st && single && o && o->volume && o->volume_file && !region && cJSON_IsString(file_item) &&
                !strcmp(file_item->valuestring, o->volume_file) && !opt.raw && !use_file_origin && !allow_outside &&
                !allow_nonfinite) {
                /* The caller already loaded this file the same way (a quick
                 * look at a volume: the default scene names it). */
                free_frame_list(r->ctx, &frames);
                return volux_scene_set_volume(sr->scene, o->volume);
            }
            if (!st) st = confine_untrusted_volume(sr, allow_outside, &opt);
            if (!st && single) {
                st = volux_volume_load(r->ctx, frames.paths[0], &opt, &vol);
                if (st) volux_error_prefix(r->ctx, "%s: volume.file: ", r->file); /* the loader names the file */
            } else if (!st) {
                st = volux_sequence_load_files(r->ctx, (const char *const *)frames.paths, frames.n, &opt, cache_bytes,
                                               &seq);
                if (st) volux_error_prefix(r->ctx, "%s: volume.files: ", r->file);
            }
            free_frame_list(r->ctx, &frames);
        }
        if (st) return st;
    }
    if (seq) {
        /* Step 0 for now; render.time_step is applied after the volume. */
        st = volux_scene_set_sequence(sr->scene, seq, 0);
        if (st) {
            volux_sequence_destroy(seq);
            volux_error_prefix(r->ctx, "%s: volume: ", r->file);
        }
        return st;
    }
    st = volux_scene_set_volume(sr->scene, vol);
    volux_volume_release(vol);
    return st;
}

/* ------------------------------------------------------------------ TF */

static volux_status read_tf_object(scene_reader *sr, const cJSON *obj, const char *tf_dir);

/* Reads the JSON file `name` (a scene key's value, e.g. a transfer function
 * file) into a tree; *path gets its resolved name. Messages name the scene,
 * the key and the file. */
static volux_status load_tree(scene_reader *sr, const char *name, const char *key, char *path, size_t n,
                              cJSON **tree) {
    volux_json_reader *r = &sr->json;
    volux_status st = resolve_path(sr, sr->base_dir, name, key, path, n);
    if (st) return st;
    char *text;
    size_t len;
    if ((st = volux_json_read_file(r->ctx, path, &text, &len))) {
        volux_error_prefix(r->ctx, "%s: %s: ", r->file, key);
        return st;
    }
    volux_json_reader sub = {r->ctx, path};
    st = volux_json_parse(&sub, text, len, tree);
    volux_free(r->ctx, text, len + 1);
    if (st) volux_error_prefix(r->ctx, "%s: %s: ", r->file, key);
    return st;
}

static volux_status read_transfer(scene_reader *sr, cJSON *root) {
    volux_json_reader *r = &sr->json;
    cJSON *obj = cJSON_GetObjectItemCaseSensitive(root, "transfer_function");
    if (!obj && sr->opt && sr->opt->region)
        /* every brick would make its own from its own histogram */
        return volux_json_error(r, VOLUX_ERR_UNSUPPORTED, "transfer_function",
                                "missing: a data-parallel render needs one (the quick-look default comes from the "
                                "whole volume's histogram)");
    if (!obj) {
        /* No TF: the quick-look default from the volume's histogram, put
         * into the tree so a dump of the scene shows exactly what is used. */
        volux_status st = VOLUX_OK;
        cJSON *tf = volux_auto_tf_json(r->ctx, volux_scene_volume(sr->scene), &st);
        if (!tf) return st ? st : volux_json_error(r, VOLUX_ERR_NOMEM, "transfer_function", "out of memory");
        if (!cJSON_AddItemToObject(root, "transfer_function", tf)) {
            cJSON_Delete(tf);
            return volux_json_error(r, VOLUX_ERR_NOMEM, "transfer_function", "out of memory");
        }
        const cJSON *op = cJSON_GetObjectItemCaseSensitive(tf, "opacity");
        double s0 = cJSON_GetArrayItem(cJSON_GetArrayItem(op, 0), 0)->valuedouble;
        double s1 = cJSON_GetArrayItem(cJSON_GetArrayItem(op, 1), 0)->valuedouble;
        char note[320];
        snprintf(note, sizeof note,
                 "%s: no transfer_function: using the default (opacity ramp over %g..%g from the histogram, "
                 "Cool to Warm colours; --dump-scene writes it out)",
                 r->file, s0, s1);
        volux_scene_add_note(sr->scene, note);
        obj = tf;
    }
    if (cJSON_IsString(obj) || sr->tf_file[0]) {
        /* "transfer_function": "tf.json" — the same TF file the peers read
         * (or such a file that --set reached into, already in the tree). */
        char path[4096];
        cJSON *tree = NULL;
        volux_status st = VOLUX_OK;
        if (cJSON_IsString(obj)) {
            if ((st = load_tree(sr, obj->valuestring, "transfer_function", path, sizeof path, &tree))) return st;
        } else {
            snprintf(path, sizeof path, "%s", sr->tf_file);
        }
        /* Messages from inside the TF file name that file (keys are read
         * under the same "transfer_function." paths), after the scene. */
        volux_json_reader sub = {r->ctx, path};
        char dir[4096];
        dir_of(path, dir, sizeof dir);
        scene_reader sub_sr = *sr;
        sub_sr.json = sub;
        st = read_tf_object(&sub_sr, tree ? tree : obj, dir);
        cJSON_Delete(tree);
        if (st) volux_error_prefix(r->ctx, "%s: transfer_function: ", r->file);
        return st;
    }
    return read_tf_object(sr, obj, sr->base_dir);
}

/* transfer_function.materials: the material channel (volux_tf_material).
 * Keys per type, so a parameter the type does not have is an error. A MERL
 * file is resolved against the TF's folder and read once here, so a bad
 * file fails the load with its path. */
static volux_status read_materials(scene_reader *sr, const cJSON *obj, const char *tf_dir, volux_tf_material *out,
                                   int *count) {
    volux_json_reader *r = &sr->json;
    const cJSON *arr = cJSON_GetObjectItemCaseSensitive(obj, "materials");
    *count = 0;
    if (!arr) return VOLUX_OK;
    if (!cJSON_IsArray(arr) || cJSON_GetArraySize(arr) > VOLUX_TF_MAX_MATERIALS)
        return volux_json_error(r, VOLUX_ERR_INVALID, "transfer_function.materials", "expected an array of at most %d objects",
                                VOLUX_TF_MAX_MATERIALS);
    static const char *const phase[] = {"range", "type", "anisotropy", "comment", NULL};
    static const char *const lambert[] = {"range", "type", "diffuse", "comment", NULL};
    static const char *const blinn[] = {"range", "type", "diffuse", "specular", "shininess", "comment", NULL};
    static const char *const ashikhmin[] = {"range", "type", "diffuse", "specular", "shininess", "f0", "comment", NULL};
    static const char *const cook[] = {"range", "type", "diffuse", "specular", "roughness", "f0", "comment", NULL};
    static const char *const merl[] = {"range", "type", "file", "comment", NULL};
    static const char *const *const keys[] = {phase, lambert, blinn, ashikhmin, cook, merl};
    int i = 0;
    for (const cJSON *m = arr->child; m; m = m->next, i++) {
        char P[48];
        snprintf(P, sizeof P, "transfer_function.materials[%d]", i);
        if (!cJSON_IsObject(m)) return volux_json_error(r, VOLUX_ERR_INVALID, P, "expected an object");
        const char *type = NULL;
        volux_status st = volux_json_string(r, m, P, "type", &type);
        if (st) return st;
        int kind = -1;
        for (int k = 0; type && k <= VOLUX_MATERIAL_MERL; k++)
            if (!strcmp(type, volux_material_kind_name((volux_material_kind)k))) kind = k;
        if (kind < 0)
            return volux_json_error(r, VOLUX_ERR_INVALID, P,
                                    "type must be one of phase, lambert, blinn_phong, ashikhmin_shirley, "
                                    "cook_torrance, merl");
        if ((st = volux_json_check_keys(r, m, P, keys[kind]))) return st;
        volux_tf_material *t = &out[i];
        volux_tf_material_defaults(t, (volux_material_kind)kind);
        const cJSON *range = cJSON_GetObjectItemCaseSensitive(m, "range");
        int ok = cJSON_IsArray(range) && cJSON_GetArraySize(range) == 2 && cJSON_IsNumber(range->child) &&
                 cJSON_IsNumber(range->child->next);
        if (ok) {
            double a = range->child->valuedouble, b = range->child->next->valuedouble;
            ok = isfinite(a) && isfinite(b) && fabs(a) <= 1e30 && fabs(b) <= 1e30 && a <= b;
            t->s0 = (float)a, t->s1 = (float)b;
        }
        if (!ok) {
            char q[64];
            snprintf(q, sizeof q, "%s.range", P);
            return volux_json_error(r, VOLUX_ERR_INVALID, q, "expected [s0, s1] with s0 <= s1 (file units)");
        }
        const char *file = NULL;
        if ((st = volux_json_float(r, m, P, "anisotropy", -0.999, 0.999, &t->g)) ||
            (st = volux_json_float(r, m, P, "diffuse", 0, 1, &t->diffuse)) ||
            (st = volux_json_float(r, m, P, "specular", 0, 1, &t->specular)) ||
            (st = volux_json_float(r, m, P, "shininess", 0, 1e4, &t->shininess)) ||
            (st = volux_json_float(r, m, P, "roughness", 1e-3, 1, &t->roughness)) ||
            (st = volux_json_float(r, m, P, "f0", 0, 1, &t->f0)) || (st = volux_json_string(r, m, P, "file", &file)))
            return st;
        if (kind == VOLUX_MATERIAL_MERL) {
            char q[64];
            snprintf(q, sizeof q, "%s.file", P);
            if (!file) return volux_json_error(r, VOLUX_ERR_INVALID, q, "missing (a MERL .binary file)");
            if ((st = resolve_path(sr, tf_dir, file, q, t->file, sizeof t->file))) return st;
            volux_merl probe;
            if ((st = volux_merl_load(r->ctx, t->file, &probe))) {
                volux_error_prefix(r->ctx, "%s: %s: ", r->file, q);
                return st;
            }
            volux_merl_free(r->ctx, &probe);
        }
    }
    *count = i;
    return VOLUX_OK;
}

static volux_status read_tf_object(scene_reader *sr, const cJSON *obj, const char *tf_dir) {
    volux_json_reader *r = &sr->json;
    static const char *const keys[] = {"color",   "opacity",  "extinction",    "opacity_unit_distance",
                                       "density_scale", "albedo", "anisotropy", "preset", "preset_name",
                                       "preset_rescale", "ambient", "diffuse", "specular", "specular_power",
                                       "materials", "comment", NULL};
    const char *P = "transfer_function";
    volux_status st = volux_json_check_keys(r, obj, P, keys);
    if (st) return st;
    volux_transfer_desc d;
    volux_transfer_desc_defaults(&d);
    float *color = NULL, *opacity = NULL, *ext = NULL;
    int n_color = 0, n_opacity = 0, n_ext = 0, n_pts = 0;
    volux_tf_preset preset = {0};
    volux_tf_color_point *cp = NULL;
    const char *preset_file = NULL, *preset_name = NULL;
    int rescale = 1;
    volux_tf_scalar_point *op = NULL;
    volux_tf_material *mats = NULL;
    if ((st = volux_json_rows(r, obj, P, "color", 4, VOLUX_TF_MAX_POINTS, &color, &n_color))) goto done;
    if ((st = volux_json_rows(r, obj, P, "opacity", 2, VOLUX_TF_MAX_POINTS, &opacity, &n_opacity))) goto done;
    if ((st = volux_json_rows(r, obj, P, "extinction", 2, VOLUX_TF_MAX_POINTS, &ext, &n_ext))) goto done;
    if (n_opacity && n_ext) {
        st = volux_json_error(r, VOLUX_ERR_INVALID, P, "give opacity or extinction, not both");
        goto done;
    }
    if ((st = volux_json_float(r, obj, P, "opacity_unit_distance", 1e-9, BIG, &d.opacity_unit_distance)) ||
        (st = volux_json_float(r, obj, P, "density_scale", 0, BIG, &d.density_scale)) ||
        (st = volux_json_float(r, obj, P, "albedo", 0, 1, &d.albedo)) ||
        (st = volux_json_float(r, obj, P, "anisotropy", -0.999, 0.999, &d.anisotropy)) ||
        (st = volux_json_float(r, obj, P, "ambient", 0, BIG, &d.material.ambient)) ||
        (st = volux_json_float(r, obj, P, "diffuse", 0, BIG, &d.material.diffuse)) ||
        (st = volux_json_float(r, obj, P, "specular", 0, BIG, &d.material.specular)) ||
        (st = volux_json_float(r, obj, P, "specular_power", 0, 1e4, &d.material.specular_power)))
        goto done;
    if ((st = volux_json_string(r, obj, P, "preset", &preset_file)) ||
        (st = volux_json_string(r, obj, P, "preset_name", &preset_name)) ||
        (st = volux_json_bool(r, obj, P, "preset_rescale", &rescale)))
        goto done;
    if (preset_file && n_color) {
        st = volux_json_error(r, VOLUX_ERR_INVALID, P, "give color points or a preset, not both");
        goto done;
    }
    if (!preset_file && (preset_name || cJSON_GetObjectItemCaseSensitive(obj, "preset_rescale"))) {
        st = volux_json_error(r, VOLUX_ERR_INVALID, P, "preset_name and preset_rescale need a preset");
        goto done;
    }
    if (n_ext && cJSON_GetObjectItemCaseSensitive(obj, "opacity_unit_distance")) {
        /* σt is given directly; a unit distance would be silently ignored. */
        st = volux_json_error(r, VOLUX_ERR_INVALID, "transfer_function.opacity_unit_distance",
                              "only applies to opacity, not extinction");
        goto done;
    }
    if (preset_file) {
        char path[4096];
        if ((st = resolve_path(sr, tf_dir, preset_file, "transfer_function.preset", path, sizeof path))) goto done;
        double lo = 0, hi = 0;
        volux_volume *vol = volux_scene_volume(sr->scene);
        if (rescale && vol && sr->opt && sr->opt->region) {
            /* the brick's range is not the whole volume's */
            st = volux_json_error(r, VOLUX_ERR_UNSUPPORTED, "transfer_function.preset_rescale",
                                  "a data-parallel render cannot rescale a preset to the volume's range (each rank "
                                  "holds one brick): give \"preset_rescale\": false and the preset's own values");
            goto done;
        }
        if (rescale && vol) volux_volume_range(vol, &lo, &hi);
        if ((st = volux_tf_preset_load(r->ctx, path, preset_name, lo, hi, &preset))) {
            volux_error_prefix(r->ctx, "%s: transfer_function.preset: ", r->file);
            goto done;
        }
    }
    if (n_color) {
        cp = volux_malloc(r->ctx, sizeof *cp * (size_t)n_color);
        if (!cp) {
            st = volux_json_error(r, VOLUX_ERR_NOMEM, P, "out of memory");
            goto done;
        }
        for (int i = 0; i < n_color; i++)
            cp[i] = (volux_tf_color_point){color[4 * i], color[4 * i + 1], color[4 * i + 2], color[4 * i + 3]};
        d.color = cp;
        d.n_color = n_color;
    } else if (preset.n_color) {
        d.color = preset.color;
        d.n_color = preset.n_color;
    }
    n_pts = n_opacity ? n_opacity : n_ext;
    if (n_pts) {
        const float *pts = n_opacity ? opacity : ext;
        op = volux_malloc(r->ctx, sizeof *op * (size_t)n_pts);
        if (!op) {
            st = volux_json_error(r, VOLUX_ERR_NOMEM, P, "out of memory");
            goto done;
        }
        for (int i = 0; i < n_pts; i++) op[i] = (volux_tf_scalar_point){pts[2 * i], pts[2 * i + 1]};
        d.opacity = op;
        d.n_opacity = n_pts;
    } else if (preset.n_opacity) { /* the preset's opacity ("Points") */
        d.opacity = preset.opacity;
        d.n_opacity = preset.n_opacity;
        if (preset.n_sharp) {
            char note[512];
            snprintf(note, sizeof note,
                     "%s: transfer_function.preset: %d opacity segment%s of '%.200s' %s a sharpness > 0; drawn "
                     "piecewise-linear through the midpoint (give \"opacity\" points to shape the curve)",
                     r->file, preset.n_sharp, preset.n_sharp == 1 ? "" : "s", preset_file,
                     preset.n_sharp == 1 ? "has" : "have");
            volux_scene_add_note(sr->scene, note);
        }
    } else {
        st = volux_json_error(r, VOLUX_ERR_INVALID, P, "needs opacity or extinction points");
        goto done;
    }
    d.extinction = n_ext > 0;
    if (cJSON_GetObjectItemCaseSensitive(obj, "materials")) {
        mats = volux_malloc(r->ctx, sizeof *mats * VOLUX_TF_MAX_MATERIALS);
        if (!mats) {
            st = volux_json_error(r, VOLUX_ERR_NOMEM, P, "out of memory");
            goto done;
        }
        if ((st = read_materials(sr, obj, tf_dir, mats, &d.n_materials))) goto done;
        d.materials = mats;
    }
    st = volux_scene_set_transfer(sr->scene, &d);
    if (st) volux_error_prefix(r->ctx, "%s: ", r->file);
done:
    volux_free(r->ctx, color, sizeof(float) * 4 * (size_t)n_color);
    volux_free(r->ctx, opacity, sizeof(float) * 2 * (size_t)n_opacity);
    volux_free(r->ctx, ext, sizeof(float) * 2 * (size_t)n_ext);
    volux_free(r->ctx, cp, sizeof *cp * (size_t)n_color);
    volux_free(r->ctx, op, sizeof *op * (size_t)n_pts);
    volux_free(r->ctx, mats, sizeof *mats * VOLUX_TF_MAX_MATERIALS);
    volux_tf_preset_free(r->ctx, &preset);
    return st;
}

/* ------------------------------------------------------------------ camera */

static volux_status read_camera(scene_reader *sr, const cJSON *obj) {
    volux_json_reader *r = &sr->json;
    volux_camera_desc d;
    volux_camera_desc_defaults(&d);
    if (!obj) return volux_scene_set_camera(sr->scene, &d);
    static const char *const keys[] = {"type", "eye", "look_at", "up", "z_up", "fov_y", "height", "orbit", "comment", NULL};
    static const char *const orbit_keys[] = {"azimuth", "elevation", "distance", NULL};
    volux_status st = volux_json_check_keys(r, obj, "camera", keys);
    if (st) return st;
    const char *type = NULL;
    if ((st = volux_json_string(r, obj, "camera", "type", &type))) return st;
    if (type && strcmp(type, "perspective") && strcmp(type, "orthographic"))
        return volux_json_error(r, VOLUX_ERR_INVALID, "camera.type", "expected \"perspective\" or \"orthographic\"");
    d.projection = type && !strcmp(type, "orthographic") ? VOLUX_ORTHOGRAPHIC : VOLUX_PERSPECTIVE;
    const cJSON *orbit = cJSON_GetObjectItemCaseSensitive(obj, "orbit");
    const cJSON *eye = cJSON_GetObjectItemCaseSensitive(obj, "eye");
    if (orbit && eye) return volux_json_error(r, VOLUX_ERR_INVALID, "camera", "give eye/look_at or orbit, not both");
    if (d.projection == VOLUX_PERSPECTIVE && cJSON_GetObjectItemCaseSensitive(obj, "height"))
        return volux_json_error(r, VOLUX_ERR_INVALID, "camera.height", "only for \"type\": \"orthographic\"");
    if ((st = volux_json_float(r, obj, "camera", "fov_y", 1e-3, 179.999, &d.fov_y_deg)) ||
        (st = volux_json_float(r, obj, "camera", "height", 1e-9, BIG, &d.height)))
        return st;
    /* up: the view's up for eye/look_at, the orbit's axis for an orbit
     * (default +Y); "z_up": true is the shortcut for [0, 0, 1] (medical
     * data, whose slices stack along z). */
    float up[3] = {0, 1, 0};
    int z_up = 0;
    if ((st = volux_json_vec3(r, obj, "camera", "up", -COORD, COORD, up)) ||
        (st = volux_json_bool(r, obj, "camera", "z_up", &z_up)))
        return st;
    if (cJSON_GetObjectItemCaseSensitive(obj, "z_up") && cJSON_GetObjectItemCaseSensitive(obj, "up"))
        return volux_json_error(r, VOLUX_ERR_INVALID, "camera", "give up or z_up, not both");
    if (z_up) up[0] = 0, up[1] = 0, up[2] = 1;
    if (!(up[0] * up[0] + up[1] * up[1] + up[2] * up[2] > 0.0f))
        return volux_json_error(r, VOLUX_ERR_INVALID, "camera.up", "must not be the zero vector");
    d.up = (volux_vec3){up[0], up[1], up[2]};
    if (eye) {
        float e[3], at[3] = {0, 0, 0};
        d.use_orbit = 0;
        if ((st = volux_json_vec3(r, obj, "camera", "eye", -COORD, COORD, e)) ||
            (st = volux_json_vec3(r, obj, "camera", "look_at", -COORD, COORD, at)))
            return st;
        d.eye = (volux_vec3){e[0], e[1], e[2]};
        d.look_at = (volux_vec3){at[0], at[1], at[2]};
    } else {
        if (cJSON_GetObjectItemCaseSensitive(obj, "look_at"))
            return volux_json_error(r, VOLUX_ERR_INVALID, "camera.look_at",
                                    "needs an eye (an orbit always looks at the volume's centre)");
        /* DESIGN §3: the default distance fits the bounding sphere for this
         * fov_y (also without an "orbit" object, where the defaults'
         * distance would only fit their own 30°). */
        d.distance = 1.0f / sinf(0.5f * d.fov_y_deg * 3.14159265f / 180.0f);
        if (orbit) {
            if ((st = volux_json_check_keys(r, orbit, "camera.orbit", orbit_keys)) ||
                (st = volux_json_float(r, orbit, "camera.orbit", "azimuth", -1e6, 1e6, &d.azimuth_deg)) ||
                (st = volux_json_float(r, orbit, "camera.orbit", "elevation", -90, 90, &d.elevation_deg)) ||
                (st = volux_json_float(r, orbit, "camera.orbit", "distance", 1e-6, 1e6, &d.distance)))
                return st;
        }
    }
    st = volux_scene_set_camera(sr->scene, &d);
    if (st) {
        volux_error_prefix(r->ctx, "%s: ", r->file);
        return st;
    }
    /* set_camera checks the frame against a unit sphere; an orbit scales
     * with the volume's radius, so resolve it for the real volume too. */
    volux_camera cam;
    if ((st = volux_scene_camera(sr->scene, &cam))) {
        volux_error_prefix(r->ctx, "%s: ", r->file);
        return st;
    }
    float sum = cam.eye.x + cam.eye.y + cam.eye.z + cam.forward.x + cam.forward.y + cam.forward.z + cam.right.x +
                cam.right.y + cam.right.z + cam.up.x + cam.up.y + cam.up.z + cam.tan_half_fov + cam.half_height;
    if (!isfinite(sum))
        return volux_json_error(r, VOLUX_ERR_INVALID, "camera",
                                "the view is not finite for this volume (eye too far away?)");
    return VOLUX_OK;
}

/* ------------------------------------------------------------------ lights */

static volux_status read_light(scene_reader *sr, const cJSON *obj, int index) {
    volux_json_reader *r = &sr->json;
    char P[32];
    snprintf(P, sizeof P, "lights[%d]", index);
    if (!cJSON_IsObject(obj)) return volux_json_error(r, VOLUX_ERR_INVALID, P, "expected an object");
    const char *type = NULL;
    volux_status st = volux_json_string(r, obj, P, "type", &type);
    if (st) return st;
    if (!type) return volux_json_error(r, VOLUX_ERR_INVALID, P, "missing type");
    /* Keys per type: a parameter of another light type is a mistake. */
    static const char *const directional[] = {"type", "direction", "color", "irradiance", "enabled", "comment", NULL};
    static const char *const point[] = {"type", "position", "color", "intensity", "enabled", "comment", NULL};
    static const char *const spot[] = {"type",          "position",      "direction", "color", "intensity",
                                       "cone_angle",    "falloff_angle", "enabled",   "comment", NULL};
    static const char *const sphere[] = {"type", "position", "radius", "color", "radiance", "enabled", "comment", NULL};
    static const char *const env[] = {"type",       "color",   "radiance", "file",    "intensity",
                                      "rotation_y", "visible", "enabled",  "comment", NULL};
    static const struct {
        const char *name;
        volux_light_type type;
        const char *const *keys;
    } types[] = {{"directional", VOLUX_LIGHT_DIRECTIONAL, directional},
                 {"point", VOLUX_LIGHT_POINT, point},
                 {"spot", VOLUX_LIGHT_SPOT, spot},
                 {"sphere", VOLUX_LIGHT_SPHERE, sphere},
                 {"environment", VOLUX_LIGHT_ENVIRONMENT, env}};
    int t = -1;
    for (int i = 0; i < 5; i++)
        if (!strcmp(type, types[i].name)) t = i;
    if (t < 0) {
        char pt[48];
        snprintf(pt, sizeof pt, "%s.type", P);
        return volux_json_error(r, VOLUX_ERR_INVALID, pt,
                                "unknown light type '%.64s' (directional, point, spot, sphere, environment)", type);
    }
    if ((st = volux_json_check_keys(r, obj, P, types[t].keys))) return st;
    volux_light_desc d;
    volux_light_desc_defaults(&d, types[t].type);
    float color[3] = {1, 1, 1}, dir[3] = {0, 0, -1}, pos[3] = {0, 0, 0};
    if ((st = volux_json_vec3(r, obj, P, "color", 0, BIG, color)) ||
        (st = volux_json_vec3(r, obj, P, "direction", -COORD, COORD, dir)) ||
        (st = volux_json_vec3(r, obj, P, "position", -COORD, COORD, pos)) ||
        (st = volux_json_float(r, obj, P, "irradiance", 0, BIG, &d.irradiance)) ||
        (st = volux_json_float(r, obj, P, "intensity", 0, BIG, &d.intensity)) ||
        (st = volux_json_float(r, obj, P, "radiance", 0, BIG, &d.radiance)) ||
        (st = volux_json_float(r, obj, P, "radius", 1e-9, COORD, &d.radius)) ||
        (st = volux_json_float(r, obj, P, "cone_angle", 1e-6, 90, &d.cone_angle_deg)) ||
        (st = volux_json_float(r, obj, P, "falloff_angle", 0, 90, &d.falloff_angle_deg)) ||
        (st = volux_json_float(r, obj, P, "rotation_y", -1e6, 1e6, &d.rotation_y_deg)) ||
        (st = volux_json_bool(r, obj, P, "visible", &d.visible)) ||
        (st = volux_json_bool(r, obj, P, "enabled", &d.enabled)))
        return st;
    if (d.type == VOLUX_LIGHT_SPOT && !cJSON_GetObjectItemCaseSensitive(obj, "falloff_angle") &&
        d.falloff_angle_deg > d.cone_angle_deg)
        d.falloff_angle_deg = 0.8f * d.cone_angle_deg; /* default: soft edge over the outer fifth */
    d.color = (volux_vec3){color[0], color[1], color[2]};
    d.direction = (volux_vec3){dir[0], dir[1], dir[2]};
    d.position = (volux_vec3){pos[0], pos[1], pos[2]};
    const char *file = NULL;
    if ((st = volux_json_string(r, obj, P, "file", &file))) return st;
    volux_image map = {0};
    if (file) {
        if (cJSON_GetObjectItemCaseSensitive(obj, "radiance"))
            return volux_json_error(r, VOLUX_ERR_INVALID, P, "give radiance (constant) or file (map), not both");
        char path[4096], pf[48];
        snprintf(pf, sizeof pf, "%s.file", P);
        if ((st = resolve_path(sr, sr->base_dir, file, pf, path, sizeof path))) return st;
        if ((st = volux_image_load(r->ctx, path, &map))) {
            volux_error_prefix(r->ctx, "%s: %s.file: ", r->file, P);
            return st;
        }
        d.map = &map;
    }
    st = volux_scene_set_light(sr->scene, index, &d);
    volux_image_free(r->ctx, &map);
    if (st) volux_error_prefix(r->ctx, "%s: ", r->file);
    return st;
}

static volux_status read_lights(scene_reader *sr, const cJSON *arr) {
    volux_json_reader *r = &sr->json;
    if (!arr) return VOLUX_OK;
    if (!cJSON_IsArray(arr)) return volux_json_error(r, VOLUX_ERR_INVALID, "lights", "expected an array");
    int n = cJSON_GetArraySize(arr);
    if (n > VOLUX_MAX_LIGHTS)
        return volux_json_error(r, VOLUX_ERR_LIMIT, "lights", "at most %d lights, got %d", VOLUX_MAX_LIGHTS, n);
    int i = 0;
    for (const cJSON *l = arr->child; l; l = l->next, i++) {
        volux_status st = read_light(sr, l, i);
        if (st) return st;
    }
    return VOLUX_OK;
}

/* ------------------------------------------------------------------ render, techniques */

static volux_status read_render(scene_reader *sr, const cJSON *obj) {
    volux_json_reader *r = &sr->json;
    volux_render_settings rs;
    volux_render_settings_defaults(&rs);
    if (obj) {
        static const char *const keys[] = {"technique", "width",   "height",  "spp",       "step",
                                           "seed",      "max_depth", "exposure", "threads", "time_ms",
                                           "target_error", "time_step", "comment", NULL};
        const char *P = "render";
        volux_status st = volux_json_check_keys(r, obj, P, keys);
        if (st) return st;
        const char *tech = NULL;
        double seed = 1;
        if ((st = volux_json_string(r, obj, P, "technique", &tech)) ||
            (st = volux_json_int(r, obj, P, "width", 1, VOLUX_MAX_IMAGE_DIM, &rs.width)) ||
            (st = volux_json_int(r, obj, P, "height", 1, VOLUX_MAX_IMAGE_DIM, &rs.height)) ||
            (st = volux_json_int(r, obj, P, "spp", 1, 1 << 24, &rs.spp)) ||
            (st = volux_json_float(r, obj, P, "step", 1e-3, 64, &rs.step)) ||
            (st = volux_json_number(r, obj, P, "seed", 0, 9007199254740992.0, &seed)) ||
            (st = volux_json_int(r, obj, P, "max_depth", 0, 100000, &rs.max_depth)) ||
            (st = volux_json_float(r, obj, P, "exposure", -64, 64, &rs.exposure)) ||
            (st = volux_json_int(r, obj, P, "threads", 0, 1024, &rs.threads)) ||
            (st = volux_json_number(r, obj, P, "time_ms", 0, 1e12, &rs.time_ms)) ||
            (st = volux_json_number(r, obj, P, "target_error", 0, 1e3, &rs.target_error)))
            return st;
        if (seed != floor(seed)) return volux_json_error(r, VOLUX_ERR_INVALID, "render.seed", "expected an integer");
        rs.seed = (uint64_t)seed;
        if (tech) {
            if (strlen(tech) >= sizeof rs.technique)
                return volux_json_error(r, VOLUX_ERR_INVALID, "render.technique", "name too long");
            strcpy(rs.technique, tech);
        }
    }
    volux_status st = volux_scene_set_render(sr->scene, &rs);
    if (st) volux_error_prefix(r->ctx, "%s: ", r->file);
    return st;
}

/* render.time_step: selects the step of a sequence (after the volume is
 * read; a single volume has only step 0). */
static volux_status read_time_step(scene_reader *sr, const cJSON *render) {
    volux_json_reader *r = &sr->json;
    int step = 0;
    if (!render || !cJSON_GetObjectItemCaseSensitive(render, "time_step")) return VOLUX_OK;
    volux_status st = volux_json_int(r, render, "render", "time_step", 0, VOLUX_MAX_STEPS - 1, &step);
    if (st) return st;
    if ((st = volux_scene_set_time_step(sr->scene, step))) volux_error_prefix(r->ctx, "%s: render.time_step: ", r->file);
    return st;
}

/* 1 if techniques.<tech>.<name> names a file. io sits below the technique
 * registry and cannot look the kind up, so the rule is in the name: a
 * parameter is VOLUX_PARAM_FILE exactly when its name ends in "_file"
 * (tests/invariants/test_technique_matrix.c checks every technique). */
static int is_file_param(const char *tech, const char *name) {
    (void)tech;
    size_t n = strlen(name);
    return n >= 5 && !strcmp(name + n - 5, "_file");
}

static volux_status read_techniques(scene_reader *sr, const cJSON *obj) {
    volux_json_reader *r = &sr->json;
    if (!obj) return VOLUX_OK;
    if (!cJSON_IsObject(obj)) return volux_json_error(r, VOLUX_ERR_INVALID, "techniques", "expected an object");
    /* Names are free-form here (the technique registry checks them), so
     * bound the counts before the quadratic duplicate-key check. */
    if (cJSON_GetArraySize(obj) > VOLUX_MAX_PARAMS)
        return volux_json_error(r, VOLUX_ERR_LIMIT, "techniques", "more than %d techniques", VOLUX_MAX_PARAMS);
    volux_status st = volux_json_check_keys(r, obj, "techniques", NULL);
    if (st) return st;
    for (const cJSON *t = obj->child; t; t = t->next) {
        char P[128];
        snprintf(P, sizeof P, "techniques.%.64s", t->string);
        if (!cJSON_IsObject(t)) return volux_json_error(r, VOLUX_ERR_INVALID, P, "expected an object of parameters");
        if (cJSON_GetArraySize(t) > VOLUX_MAX_PARAMS)
            return volux_json_error(r, VOLUX_ERR_LIMIT, P, "more than %d parameters", VOLUX_MAX_PARAMS);
        if ((st = volux_json_check_keys(r, t, P, NULL))) return st;
        for (const cJSON *p = t->child; p; p = p->next) {
            if (cJSON_IsNumber(p)) st = volux_scene_set_param(sr->scene, t->string, p->string, p->valuedouble, NULL);
            else if (cJSON_IsBool(p)) st = volux_scene_set_param(sr->scene, t->string, p->string, cJSON_IsTrue(p), NULL);
            else if (cJSON_IsString(p)) {
                /* A file parameter names a file like any other reference:
                 * resolved here, inside the data root when there is one. */
                const char *value = p->valuestring;
                char path[4096], key[192];
                if (*value && is_file_param(t->string, p->string)) {
                    snprintf(key, sizeof key, "%s.%.48s", P, p->string);
                    if ((st = resolve_path(sr, sr->base_dir, value, key, path, sizeof path))) return st;
                    value = path;
                }
                st = volux_scene_set_param(sr->scene, t->string, p->string, 0, value);
            } else {
                char pp[192];
                snprintf(pp, sizeof pp, "%s.%.48s", P, p->string);
                return volux_json_error(r, VOLUX_ERR_INVALID, pp, "expected a number, boolean or string");
            }
            if (st) {
                volux_error_prefix(r->ctx, "%s: ", r->file);
                return st;
            }
        }
    }
    return VOLUX_OK;
}

/* ------------------------------------------------------------------ clip */

/* "clip": {"box": {"min": [x,y,z], "max": [x,y,z]}, "planes": [{"origin":
 * [x,y,z], "normal": [x,y,z]}, ...]} (world coordinates; docs/CLIP.md). Read
 * after the volume and the TF: the clipped copy needs both. */
static volux_status read_clip(scene_reader *sr, const cJSON *obj) {
    volux_json_reader *r = &sr->json;
    volux_clip_desc d;
    memset(&d, 0, sizeof d);
    if (obj && !cJSON_IsNull(obj)) {
        static const char *const keys[] = {"box", "planes", "comment", NULL};
        static const char *const box_keys[] = {"min", "max", NULL};
        static const char *const plane_keys[] = {"origin", "normal", NULL};
        volux_status st = volux_json_check_keys(r, obj, "clip", keys);
        if (st) return st;
        /* null stands for absent (the viewer's reset) */
        const cJSON *box = cJSON_GetObjectItemCaseSensitive(obj, "box");
        if (box && !cJSON_IsNull(box)) {
            /* A missing corner is unbounded, so `--set clip.box.min=[...]` alone crops one side. */
            float lo[3] = {-COORD, -COORD, -COORD}, hi[3] = {COORD, COORD, COORD};
            if ((st = volux_json_check_keys(r, box, "clip.box", box_keys))) return st;
            if ((st = volux_json_vec3(r, box, "clip.box", "min", -COORD, COORD, lo)) ||
                (st = volux_json_vec3(r, box, "clip.box", "max", -COORD, COORD, hi)))
                return st;
            d.has_box = 1;
            for (int a = 0; a < 3; a++) d.box_min[a] = lo[a], d.box_max[a] = hi[a];
        }
        const cJSON *planes = cJSON_GetObjectItemCaseSensitive(obj, "planes");
        if (planes && !cJSON_IsNull(planes)) {
            if (!cJSON_IsArray(planes)) return volux_json_error(r, VOLUX_ERR_INVALID, "clip.planes", "expected an array");
            int n = cJSON_GetArraySize(planes);
            if (n > VOLUX_CLIP_MAX_PLANES)
                return volux_json_error(r, VOLUX_ERR_INVALID, "clip.planes", "%d planes, at most %d are allowed", n,
                                        VOLUX_CLIP_MAX_PLANES);
            int i = 0;
            for (const cJSON *p = planes->child; p; p = p->next, i++) {
                char P[32];
                snprintf(P, sizeof P, "clip.planes[%d]", i);
                float o[3], nrm[3];
                if ((st = volux_json_check_keys(r, p, P, plane_keys))) return st;
                if (!cJSON_GetObjectItemCaseSensitive(p, "origin") || !cJSON_GetObjectItemCaseSensitive(p, "normal"))
                    return volux_json_error(r, VOLUX_ERR_INVALID, P, "needs both \"origin\" and \"normal\"");
                if ((st = volux_json_vec3(r, p, P, "origin", -COORD, COORD, o)) ||
                    (st = volux_json_vec3(r, p, P, "normal", -COORD, COORD, nrm)))
                    return st;
                for (int a = 0; a < 3; a++) d.planes[i].origin[a] = o[a], d.planes[i].normal[a] = nrm[a];
            }
            d.n_planes = n;
        }
    }
    volux_status st = volux_scene_set_clip(sr->scene, &d);
    if (st) volux_error_prefix(r->ctx, "%s: ", r->file);
    return st;
}

/* ------------------------------------------------------------------ entry points */

static volux_status read_scene(scene_reader *sr, cJSON *root) {
    volux_json_reader *r = &sr->json;
    static const char *const keys[] = {"volume", "transfer_function", "clip",       "camera",  "lights",
                                       "background", "render",        "techniques", "comment", NULL};
    volux_status st = volux_json_check_keys(r, root, "", keys);
    if (st) return st;
    float bg[3] = {0, 0, 0};
    if ((st = volux_json_vec3(r, root, "", "background", 0, BIG, bg))) return st;
    /* Order matters: the TF preset is rescaled to the volume's range (of
     * time step 0, so every step of a sequence gets the same TF), and a
     * missing TF is made from the volume's histogram. */
    if ((st = read_render(sr, cJSON_GetObjectItemCaseSensitive(root, "render"))) ||
        (st = sr->supplied ? volux_scene_set_volume(sr->scene, sr->supplied)
                           : read_volume(sr, cJSON_GetObjectItemCaseSensitive(root, "volume"))) ||
        (st = read_transfer(sr, root)) ||
        (st = read_time_step(sr, cJSON_GetObjectItemCaseSensitive(root, "render"))) ||
        (st = read_clip(sr, cJSON_GetObjectItemCaseSensitive(root, "clip"))) ||
        (st = read_camera(sr, cJSON_GetObjectItemCaseSensitive(root, "camera"))) ||
        (st = read_lights(sr, cJSON_GetObjectItemCaseSensitive(root, "lights"))) ||
        (st = read_techniques(sr, cJSON_GetObjectItemCaseSensitive(root, "techniques"))))
        return st;
    volux_scene_set_background(sr->scene, (volux_vec3){bg[0], bg[1], bg[2]});
    return VOLUX_OK;
}

/* An override that reaches into a key whose value is a file name (today
 * only transfer_function, the one object a scene may give by reference):
 * the file is read into the tree first, so "--set
 * transfer_function.albedo=0.8" edits the referenced TF like an inline one
 * (its relative names keep resolving against its own folder). */
static volux_status inline_referenced(scene_reader *sr, cJSON *root, const char *assignment) {
    static const char *const by_reference[] = {"transfer_function"};
    for (size_t k = 0; k < sizeof by_reference / sizeof by_reference[0]; k++) {
        size_t len = strlen(by_reference[k]);
        if (strncmp(assignment, by_reference[k], len) || assignment[len] != '.') continue;
        cJSON *node = cJSON_GetObjectItemCaseSensitive(root, by_reference[k]);
        if (!cJSON_IsString(node)) continue;
        char path[4096];
        cJSON *tree = NULL;
        volux_status st = load_tree(sr, node->valuestring, by_reference[k], path, sizeof path, &tree);
        if (st) return st;
        if (!cJSON_IsObject(tree)) {
            cJSON_Delete(tree);
            volux_json_reader sub = {sr->json.ctx, path};
            st = volux_json_error(&sub, VOLUX_ERR_INVALID, NULL, "expected a JSON object");
            volux_error_prefix(sr->json.ctx, "%s: %s: ", sr->json.file, by_reference[k]);
            return st;
        }
        if (!cJSON_ReplaceItemInObjectCaseSensitive(root, by_reference[k], tree)) {
            cJSON_Delete(tree);
            return volux_json_error(&sr->json, VOLUX_ERR_NOMEM, by_reference[k], "out of memory");
        }
        snprintf(sr->tf_file, sizeof sr->tf_file, "%s", path);
    }
    return VOLUX_OK;
}

/* ---- the effective scene as JSON (--dump-scene) ---- */

/* "a/b/../c" style normalisation is left to realpath(); this only makes
 * `target` (absolute, normalised) relative to the folder `from` (same). */
static void relative_to(const char *from, const char *target, char *out, size_t n) {
    size_t common = 0, i = 0;
    /* The longest common prefix that ends at a folder boundary. */
    while (from[i] && target[i] && from[i] == target[i]) {
        i++;
        if ((from[i] == '/' || from[i] == 0) && (target[i] == '/' || target[i] == 0)) common = i;
    }
    if (from[0] == '/' && from[1] == 0) common = 0; /* from the root */
    size_t w = 0;
    out[0] = 0;
    for (const char *p = from + common; *p; p++)
        if (*p == '/' && w + 4 < n) w += (size_t)snprintf(out + w, n - w, "../");
    const char *rest = target + common;
    if (*rest == '/') rest++;
    snprintf(out + w, n - w, "%s", rest);
}

/* Rewrites the file name in node (relative to from_dir) for a scene file in
 * to_dir: "$VOLUX_DATA/..." when it lies under the data root (`data_root`,
 * resolved; NULL: none), so the scene works on any machine; else relative
 * when both resolve, else absolute. "$VOLUX_DATA/" names and names that
 * cannot be resolved are kept. */
static void rebase_name(cJSON *node, const char *from_dir, const char *to_dir, const char *data_root) {
    if (!cJSON_IsString(node) || !node->valuestring[0]) return;
    const char *name = node->valuestring;
    if (!strncmp(name, DATA_PREFIX, strlen(DATA_PREFIX))) return;
    char joined[4096];
    int w = name[0] == '/' ? snprintf(joined, sizeof joined, "%s", name)
                           : snprintf(joined, sizeof joined, "%s/%s", from_dir, name);
    if (w < 0 || (size_t)w >= sizeof joined) return;
    char *target = realpath(joined, NULL);
    if (!target) return;
    char *dir = to_dir ? realpath(to_dir, NULL) : NULL;
    char out[4096];
    size_t root_len = data_root ? strlen(data_root) : 0;
    if (root_len > 1 && !strncmp(target, data_root, root_len) && target[root_len] == '/')
        snprintf(out, sizeof out, DATA_PREFIX "%s", target + root_len + 1);
    else if (dir) relative_to(dir, target, out, sizeof out);
    else snprintf(out, sizeof out, "%s", target);
    free(dir);
    free(target);
    cJSON_SetValuestring(node, out);
}

static void rebase_names(cJSON *root, const char *base_dir, const char *tf_file, const char *to_dir,
                         const char *data_root) {
    rebase_name(cJSON_GetObjectItemCaseSensitive(cJSON_GetObjectItemCaseSensitive(root, "volume"), "file"), base_dir,
                to_dir, data_root);
    cJSON *tf = cJSON_GetObjectItemCaseSensitive(root, "transfer_function");
    if (cJSON_IsString(tf)) rebase_name(tf, base_dir, to_dir, data_root);
    else if (cJSON_IsObject(tf)) {
        char tf_dir[4096];
        if (tf_file && *tf_file) dir_of(tf_file, tf_dir, sizeof tf_dir);
        else snprintf(tf_dir, sizeof tf_dir, "%s", base_dir);
        rebase_name(cJSON_GetObjectItemCaseSensitive(tf, "preset"), tf_dir, to_dir, data_root);
        cJSON *m;
        cJSON_ArrayForEach(m, cJSON_GetObjectItemCaseSensitive(tf, "materials"))
        rebase_name(cJSON_GetObjectItemCaseSensitive(m, "file"), tf_dir, to_dir, data_root);
    }
    cJSON *l;
    cJSON_ArrayForEach(l, cJSON_GetObjectItemCaseSensitive(root, "lights"))
    rebase_name(cJSON_GetObjectItemCaseSensitive(l, "file"), base_dir, to_dir, data_root);
    cJSON *t, *p;
    cJSON_ArrayForEach(t, cJSON_GetObjectItemCaseSensitive(root, "techniques"))
    cJSON_ArrayForEach(p, t) if (cJSON_IsString(p) && *p->valuestring && t->string && p->string &&
                                 is_file_param(t->string, p->string)) rebase_name(p, base_dir, to_dir, data_root);
}

/* A growable text buffer in context memory. */
typedef struct text_buf {
    volux_context *ctx;
    char *p;
    size_t n, cap;
    int failed;
} text_buf;

static void put(text_buf *b, const char *fmt, ...) VOLUX_PRINTF(2, 3);
static void put(text_buf *b, const char *fmt, ...) {
    if (b->failed) return;
    va_list ap;
    va_start(ap, fmt);
    char tmp[512];
    int w = vsnprintf(tmp, sizeof tmp, fmt, ap);
    va_end(ap);
    if (w < 0) return;
    const char *src = tmp;
    char *big = NULL;
    if ((size_t)w >= sizeof tmp) { /* a long string value */
        big = volux_malloc(b->ctx, (size_t)w + 1);
        if (!big) {
            b->failed = 1;
            return;
        }
        va_start(ap, fmt);
        vsnprintf(big, (size_t)w + 1, fmt, ap);
        va_end(ap);
        src = big;
    }
    if (b->n + (size_t)w + 1 > b->cap) {
        size_t cap = b->cap ? b->cap : 4096;
        while (cap < b->n + (size_t)w + 1) cap *= 2;
        char *q = volux_malloc(b->ctx, cap);
        if (!q) {
            b->failed = 1;
            if (big) volux_free(b->ctx, big, (size_t)w + 1);
            return;
        }
        if (b->p) {
            memcpy(q, b->p, b->n);
            volux_free(b->ctx, b->p, b->cap);
        }
        b->p = q;
        b->cap = cap;
    }
    memcpy(b->p + b->n, src, (size_t)w + 1);
    b->n += (size_t)w;
    if (big) volux_free(b->ctx, big, (size_t)w + 1);
}

static void put_string(text_buf *b, const char *s) {
    put(b, "\"");
    for (; *s; s++) {
        unsigned char c = (unsigned char)*s;
        if (c == '"' || c == '\\') put(b, "\\%c", c);
        else if (c < 0x20) put(b, "\\u%04x", c);
        else put(b, "%c", c);
    }
    put(b, "\"");
}

static int is_scalar(const cJSON *v) { return !cJSON_IsArray(v) && !cJSON_IsObject(v); }

static void put_value(text_buf *b, const cJSON *v, int indent);

/* Arrays of scalars (vectors, TF rows) stay on one line; arrays of rows
 * get one row per line; objects one key per line. */
static void put_value(text_buf *b, const cJSON *v, int indent) {
    if (cJSON_IsNumber(v)) {
        double d = v->valuedouble;
        if (d == floor(d) && fabs(d) < 1e15) put(b, "%.0f", d);
        else put(b, "%.15g", d);
    } else if (cJSON_IsString(v)) put_string(b, v->valuestring);
    else if (cJSON_IsTrue(v)) put(b, "true");
    else if (cJSON_IsFalse(v)) put(b, "false");
    else if (cJSON_IsNull(v)) put(b, "null");
    else if (cJSON_IsArray(v)) {
        int flat = 1, rows = 1;
        const cJSON *c;
        cJSON_ArrayForEach(c, v) {
            if (!is_scalar(c)) flat = 0;
            if (!cJSON_IsArray(c)) rows = 0;
            else {
                const cJSON *e;
                cJSON_ArrayForEach(e, c) if (!is_scalar(e)) rows = 0;
            }
        }
        put(b, "[");
        int first = 1;
        cJSON_ArrayForEach(c, v) {
            if (!first) put(b, flat ? ", " : ",");
            if (!flat) put(b, "\n%*s", indent + 2, "");
            put_value(b, c, indent + 2);
            first = 0;
        }
        if (!flat && !first) put(b, "\n%*s", indent, "");
        put(b, "]");
        (void)rows;
    } else if (cJSON_IsObject(v)) {
        put(b, "{");
        int first = 1;
        const cJSON *c;
        cJSON_ArrayForEach(c, v) {
            put(b, "%s\n%*s", first ? "" : ",", indent + 2, "");
            put_string(b, c->string ? c->string : "");
            put(b, ": ");
            put_value(b, c, indent + 2);
            first = 0;
        }
        if (first) put(b, "}");
        else put(b, "\n%*s}", indent, "");
    }
}

volux_status volux_json_print(volux_context *ctx, const cJSON *root, char **out) {
    text_buf b = {ctx, NULL, 0, 0, 0};
    put_value(&b, root, 0);
    put(&b, "\n");
    if (b.failed || !b.p) {
        if (b.p) volux_free(ctx, b.p, b.cap);
        return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory writing the scene as JSON");
    }
    /* Hand out an exact-size block so volux_scene_json_free needs no size. */
    char *s = volux_malloc(ctx, b.n + 1);
    if (!s) {
        volux_free(ctx, b.p, b.cap);
        return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory writing the scene as JSON");
    }
    memcpy(s, b.p, b.n + 1);
    volux_free(ctx, b.p, b.cap);
    *out = s;
    return VOLUX_OK;
}

void volux_scene_json_free(volux_context *ctx, char *json) {
    if (json) volux_free(ctx, json, strlen(json) + 1);
}

volux_status volux_scene_read_tree(volux_context *ctx, const cJSON *root, const char *base_dir, const char *name,
                                   const volux_scene_files *files, volux_scene *out) {
    scene_reader sr;
    memset(&sr, 0, sizeof sr);
    sr.json = (volux_json_reader){ctx, name ? name : "scene"};
    sr.base_dir = base_dir ? base_dir : ".";
    sr.scene = out;
    sr.files = files;
    if (!cJSON_IsObject(root))
        return volux_json_error(&sr.json, VOLUX_ERR_INVALID, NULL, "the scene must be a JSON object");
    /* read_scene may add the default transfer function to a tree without
     * one (so the document shows what is rendered). */
    return read_scene(&sr, (cJSON *)root);
}

/* Exact structural equality (cJSON_Compare treats numbers within a
 * relative epsilon as equal, which would let a tiny edit go unapplied). */
static int json_same(const cJSON *a, const cJSON *b) {
    if (!a || !b) return a == b;
    if ((a->type & 0xff) != (b->type & 0xff)) return 0;
    if (cJSON_IsNumber(a)) return a->valuedouble == b->valuedouble;
    if (cJSON_IsString(a)) return !strcmp(a->valuestring, b->valuestring);
    if (cJSON_IsArray(a) || cJSON_IsObject(a)) {
        const cJSON *x = a->child, *y = b->child;
        for (; x && y; x = x->next, y = y->next) {
            if (cJSON_IsObject(a) && strcmp(x->string, y->string)) return 0;
            if (!json_same(x, y)) return 0;
        }
        return !x && !y;
    }
    return 1; /* true, false, null */
}

static const cJSON *item(const cJSON *obj, const char *key) {
    return obj ? cJSON_GetObjectItemCaseSensitive(obj, key) : NULL;
}

void volux_scene_edit_plan_free(volux_context *ctx, volux_scene_edit_plan *plan) {
    volux_free(ctx, plan->light, (size_t)plan->n_lights);
    plan->light = NULL;
    plan->n_lights = 0;
}

volux_status volux_scene_read_edit(volux_context *ctx, const cJSON *root, const cJSON *old_root,
                                   const volux_scene *live, const char *base_dir, const char *name,
                                   const volux_scene_files *files, volux_scene *candidate,
                                   volux_scene_edit_plan *plan) {
    scene_reader sr;
    memset(&sr, 0, sizeof sr);
    sr.json = (volux_json_reader){ctx, name ? name : "scene"};
    sr.base_dir = base_dir ? base_dir : ".";
    sr.scene = candidate;
    sr.files = files;
    volux_json_reader *r = &sr.json;
    memset(plan, 0, sizeof *plan);
    if (!cJSON_IsObject(root)) return volux_json_error(r, VOLUX_ERR_INVALID, NULL, "the scene must be a JSON object");
    static const char *const keys[] = {"volume", "transfer_function", "clip",       "camera",  "lights",
                                       "background", "render",        "techniques", "comment", NULL};
    volux_status st = volux_json_check_keys(r, root, "", keys);
    if (st) return st;
    float bg[3] = {0, 0, 0};
    if ((st = volux_json_vec3(r, root, "", "background", 0, BIG, bg))) return st;
    if ((st = read_render(&sr, item(root, "render")))) return st;
    /* The volume: read again only when its section changed (a file load
     * or a procedural build is the expensive part of a scene). */
    plan->volume = !json_same(item(old_root, "volume"), item(root, "volume"));
    plan->transfer = plan->volume || !json_same(item(old_root, "transfer_function"), item(root, "transfer_function"));
    volux_sequence *kept_seq = plan->volume ? NULL : volux_scene_sequence(live);
    if (plan->volume) st = read_volume(&sr, item(root, "volume"));
    else if (kept_seq && plan->transfer && volux_scene_time_step(live) != 0) {
        /* A TF is read against time step 0 (read_scene's order), so the
         * candidate starts there like a freshly loaded scene. */
        volux_volume *first;
        if (!(st = volux_sequence_acquire(kept_seq, 0, &first))) {
            st = volux_scene_set_volume(candidate, first);
            volux_volume_release(first);
        }
    } else st = volux_scene_set_volume(candidate, volux_scene_volume(live));
    if (st) return st;
    /* A new volume changes what the TF (preset rescaling) and the camera
     * (orbit radius, finite view) read from it. */
    if (plan->transfer) st = read_transfer(&sr, (cJSON *)root); /* as in volux_scene_read_tree */
    else st = volux_scene_set_transfer(candidate, volux_scene_transfer(live));
    if (st) return st;
    /* The time step, after the TF as in read_scene. A sequence the edit
     * keeps stays on the live scene (it has one owner): the candidate gets
     * the step's volume from it, and the live scene selects the step when
     * the edit is applied (plan->time_step). */
    if (!kept_seq) {
        if ((st = read_time_step(&sr, item(root, "render")))) return st;
        plan->time_step = volux_scene_time_step(candidate);
    } else {
        const cJSON *jr = item(root, "render");
        int step = 0;
        if (jr && item(jr, "time_step") &&
            (st = volux_json_int(r, jr, "render", "time_step", 0, VOLUX_MAX_STEPS - 1, &step)))
            return st;
        volux_volume *v = NULL;
        if (!(st = volux_scene_check_time_step(live, step)) && !(st = volux_sequence_acquire(kept_seq, step, &v))) {
            st = volux_scene_set_volume(candidate, v);
            volux_volume_release(v);
        }
        if (st) {
            volux_error_prefix(ctx, "%s: render.time_step: ", r->file);
            return st;
        }
        plan->time_step = step;
    }
    if ((st = read_clip(&sr, item(root, "clip")))) return st;
    plan->camera = plan->volume || !json_same(item(old_root, "camera"), item(root, "camera"));
    if (plan->camera) st = read_camera(&sr, item(root, "camera"));
    else st = volux_scene_set_camera(candidate, volux_scene_camera_desc(live));
    if (st) return st;
    const cJSON *lights = item(root, "lights"), *old_lights = item(old_root, "lights");
    if (lights) {
        if (!cJSON_IsArray(lights)) return volux_json_error(r, VOLUX_ERR_INVALID, "lights", "expected an array");
        int n = cJSON_GetArraySize(lights);
        if (n > VOLUX_MAX_LIGHTS)
            return volux_json_error(r, VOLUX_ERR_LIMIT, "lights", "at most %d lights, got %d", VOLUX_MAX_LIGHTS, n);
        if (n > 0 && !(plan->light = volux_malloc(ctx, (size_t)n)))
            return volux_json_error(r, VOLUX_ERR_NOMEM, "lights", "out of memory for the edit of %d lights", n);
        plan->n_lights = n;
        const cJSON *old = cJSON_IsArray(old_lights) ? old_lights->child : NULL;
        int i = 0;
        for (const cJSON *l = lights->child; l; l = l->next, i++) {
            const volux_light_desc *kept = volux_scene_light(live, i);
            plan->light[i] = !kept || !json_same(old, l);
            if (plan->light[i]) st = read_light(&sr, l, i);
            else st = volux_scene_set_light(candidate, i, kept); /* copies its map: no file read */
            if (st) return st;
            if (old) old = old->next;
        }
    }
    if ((st = read_techniques(&sr, item(root, "techniques")))) return st;
    volux_scene_set_background(candidate, (volux_vec3){bg[0], bg[1], bg[2]});
    return VOLUX_OK;
}

/* A transfer function with no extinction anywhere over the volume's values
 * renders nothing but the background: legal, but almost never meant. */
static void warn_if_transparent(volux_context *ctx, const volux_scene *s, const char *name) {
    const volux_transfer_lut *lut = volux_scene_transfer_lut(s);
    const volux_volume *v = volux_scene_volume(s);
    if (!lut || !v || !lut->sigma_t || lut->n < 2) return;
    double lo, hi;
    volux_volume_range(v, &lo, &hi);
    if (volux_transfer_lut_max_sigma(lut, (float)lo, (float)hi) > 0.0f) return;
    volux_warn(ctx,
               "%s: transfer_function: fully transparent over the volume's values [%g, %g] (opacity 0 everywhere): "
               "the image will show only the background",
               name ? name : "scene", lo, hi);
}

static volux_status parse_with(volux_context *ctx, const char *text, size_t n, const volux_scene_load_options *o,
                               const char *base_dir, const char *name, unsigned flags, volux_volume *supplied,
                               volux_scene **out) {
    scene_reader sr;
    memset(&sr, 0, sizeof sr);
    sr.json = (volux_json_reader){ctx, name ? name : "scene"};
    sr.base_dir = base_dir ? base_dir : ".";
    sr.flags = flags;
    sr.opt = o;
    sr.supplied = supplied;
    cJSON *root = NULL;
    volux_status st = volux_json_parse(&sr.json, text, n, &root);
    if (st) return st;
    if (!cJSON_IsObject(root)) {
        cJSON_Delete(root);
        return volux_json_error(&sr.json, VOLUX_ERR_INVALID, NULL, "the scene must be a JSON object");
    }
    for (int i = 0; o && i < o->n_overrides; i++)
        if ((st = inline_referenced(&sr, root, o->overrides[i])) ||
            (st = volux_json_apply_override(&sr.json, root, o->overrides[i]))) {
            cJSON_Delete(root);
            return st;
        }
    if ((st = volux_scene_create(ctx, &sr.scene))) {
        cJSON_Delete(root);
        return st;
    }
    st = read_scene(&sr, root);
    if (!st && o && o->effective_json) {
        const char *root_dir = data_dir(&sr);
        char *data_root = root_dir ? realpath(root_dir, NULL) : NULL;
        rebase_names(root, sr.base_dir, sr.tf_file, o->effective_dir, data_root);
        free(data_root);
        st = volux_json_print(ctx, root, o->effective_json);
    }
    cJSON_Delete(root);
    if (st) {
        volux_scene_destroy(sr.scene);
        return st;
    }
    warn_if_transparent(ctx, sr.scene, name);
    *out = sr.scene;
    return VOLUX_OK;
}

volux_status volux_scene_parse(volux_context *ctx, const char *text, size_t n, const char *base_dir,
                               const char *name, const char *const *overrides, int n_overrides, unsigned flags,
                               volux_scene **out) {
    volux_scene_load_options o;
    memset(&o, 0, sizeof o);
    o.overrides = overrides;
    o.n_overrides = n_overrides;
    return parse_with(ctx, text, n, &o, base_dir, name, flags, NULL, out);
}

volux_status volux_scene_load_string(volux_context *ctx, const char *json, const char *base_dir, const char *name,
                                     const char *const *overrides, int n_overrides, volux_scene **out) {
    return volux_scene_parse(ctx, json, strlen(json), base_dir, name, overrides, n_overrides, 0, out);
}

volux_status volux_scene_parse_with_volume(volux_context *ctx, const char *text, size_t n, const char *base_dir,
                                           const char *name, const char *const *overrides, int n_overrides,
                                           unsigned flags, volux_volume *volume, volux_scene **out) {
    volux_scene_load_options o;
    memset(&o, 0, sizeof o);
    o.overrides = overrides;
    o.n_overrides = n_overrides;
    return parse_with(ctx, text, n, &o, base_dir, name, flags, volume, out);
}

volux_status volux_scene_load_string_with_volume(volux_context *ctx, const char *json, const char *base_dir,
                                                 const char *name, const char *const *overrides, int n_overrides,
                                                 volux_volume *volume, volux_scene **out) {
    return volux_scene_parse_with_volume(ctx, json, strlen(json), base_dir, name, overrides, n_overrides, 0, volume,
                                         out);
}

volux_status volux_scene_load_ex(volux_context *ctx, const volux_scene_load_options *o, volux_scene **out) {
    if (o->effective_json) *o->effective_json = NULL;
    if (!o->path == !o->json)
        return volux_error(ctx, VOLUX_ERR_INVALID, "volux_scene_load_ex: give exactly one of path and json");
    if (o->json) return parse_with(ctx, o->json, strlen(o->json), o, o->base_dir, o->name, 0, NULL, out);
    char *text;
    size_t n;
    volux_status st = volux_json_read_file(ctx, o->path, &text, &n);
    if (st) return st;
    char dir[4096];
    dir_of(o->path, dir, sizeof dir);
    /* The parser rejects NUL bytes with their line and column. */
    st = parse_with(ctx, text, n, o, dir, o->path, 0, NULL, out);
    volux_free(ctx, text, n + 1);
    return st;
}

volux_status volux_scene_load(volux_context *ctx, const char *path, const char *const *overrides, int n_overrides,
                              volux_scene **out) {
    volux_scene_load_options o;
    memset(&o, 0, sizeof o);
    o.path = path;
    o.overrides = overrides;
    o.n_overrides = n_overrides;
    return volux_scene_load_ex(ctx, &o, out);
}
