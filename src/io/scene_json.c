/*
 * io/scene_json.c — the scene file of DESIGN §3.
 *
 * Loading is two-phase: parse + apply --set overrides to the JSON tree, then
 * read it strictly into a fresh scene (unknown keys are errors naming their
 * path). Relative file names resolve against the scene file's folder.
 */
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "json_reader.h"
#include "merl.h"
#include "scene_formats.h"

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
} scene_reader;

/* dir + "/" + name unless name is absolute. `key` is the scene path of the
 * name, for messages. Every file the scene names passes through here, so
 * this is where VOLUX_SCENE_NO_FILES stops them. */
static volux_status resolve_path(scene_reader *sr, const char *base_dir, const char *name, const char *key,
                                 char *out, size_t n) {
    if (sr->flags & VOLUX_SCENE_NO_FILES)
        return volux_json_error(&sr->json, VOLUX_ERR_UNSUPPORTED, key, "file references are disabled here");
    if (!*name) return volux_json_error(&sr->json, VOLUX_ERR_INVALID, key, "empty file name");
    int w = name[0] == '/' || !base_dir || !*base_dir ? snprintf(out, n, "%s", name)
                                                      : snprintf(out, n, "%s/%s", base_dir, name);
    if (w < 0 || (size_t)w >= n) return volux_json_error(&sr->json, VOLUX_ERR_INVALID, key, "path too long");
    return VOLUX_OK;
}

static void dir_of(const char *path, char *out, size_t n) {
    const char *slash = strrchr(path, '/');
    if (!slash) snprintf(out, n, ".");
    else if (slash == path) snprintf(out, n, "/");
    else snprintf(out, n, "%.*s", (int)(slash - path), path);
}

/* ------------------------------------------------------------------ volume */

static volux_status read_volume(scene_reader *sr, const cJSON *obj) {
    volux_json_reader *r = &sr->json;
    /* Keys per kind: a raw-file key on a procedural volume (or a seed on a
     * file) would otherwise be silently ignored. */
    static const char *const file_keys[] = {"file",      "dims",           "type",   "endian",
                                            "spacing",   "byte_skip",      "use_file_origin",
                                            "allow_outside_dir", "allow_nonfinite", "comment", NULL};
    static const char *const proc_keys[] = {"procedural", "dims", "seed", "comment", NULL};
    volux_status st;
    if (!obj) return volux_json_error(r, VOLUX_ERR_INVALID, "volume", "missing (a file or a procedural volume)");
    if (!cJSON_IsObject(obj)) return volux_json_error(r, VOLUX_ERR_INVALID, "volume", "expected an object");
    int has_file = cJSON_GetObjectItemCaseSensitive(obj, "file") != NULL;
    if (has_file == (cJSON_GetObjectItemCaseSensitive(obj, "procedural") != NULL))
        return volux_json_error(r, VOLUX_ERR_INVALID, "volume", "give exactly one of file, procedural");
    if ((st = volux_json_check_keys(r, obj, "volume", has_file ? file_keys : proc_keys))) return st;
    const char *file = NULL, *proc = NULL, *type = NULL, *endian = NULL;
    if ((st = volux_json_string(r, obj, "volume", "file", &file)) ||
        (st = volux_json_string(r, obj, "volume", "procedural", &proc)) ||
        (st = volux_json_string(r, obj, "volume", "type", &type)) ||
        (st = volux_json_string(r, obj, "volume", "endian", &endian)))
        return st;
    int dims[3] = {0, 0, 0}, use_file_origin = 0, allow_outside = 0, allow_nonfinite = 0;
    float spacing[3] = {1, 1, 1};
    double seed = 1, byte_skip = 0;
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
        (st = volux_json_bool(r, obj, "volume", "allow_nonfinite", &allow_nonfinite)))
        return st;
    if (seed != floor(seed)) return volux_json_error(r, VOLUX_ERR_INVALID, "volume.seed", "expected an integer");
    if (byte_skip != floor(byte_skip))
        return volux_json_error(r, VOLUX_ERR_INVALID, "volume.byte_skip", "expected an integer");

    volux_volume *vol = NULL;
    if (proc) {
        if (!jd) dims[0] = dims[1] = dims[2] = 64;
        st = volux_volume_procedural(r->ctx, proc, dims, (uint64_t)seed, &vol);
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
        /* The layout is checked first: its errors do not depend on the file. */
        char path[4096];
        if ((st = resolve_path(sr, sr->base_dir, file, "volume.file", path, sizeof path))) return st;
        st = volux_volume_load(r->ctx, path, &opt, &vol);
        if (st) {
            /* The loader's message names the file; add where it came from. */
            volux_error_prefix(r->ctx, "%s: volume.file: ", r->file);
            return st;
        }
    }
    st = volux_scene_set_volume(sr->scene, vol);
    volux_volume_release(vol);
    return st;
}

/* ------------------------------------------------------------------ TF */

static volux_status read_tf_object(scene_reader *sr, const cJSON *obj, const char *tf_dir);

static volux_status read_transfer(scene_reader *sr, const cJSON *obj) {
    volux_json_reader *r = &sr->json;
    if (!obj) return volux_json_error(r, VOLUX_ERR_INVALID, "transfer_function", "missing");
    if (cJSON_IsString(obj)) {
        /* "transfer_function": "tf.json" — the same TF file the peers read. */
        char path[4096];
        volux_status st = resolve_path(sr, sr->base_dir, obj->valuestring, "transfer_function", path, sizeof path);
        if (st) return st;
        char *text;
        size_t n;
        if ((st = volux_json_read_file(r->ctx, path, &text, &n))) {
            volux_error_prefix(r->ctx, "%s: transfer_function: ", r->file);
            return st;
        }
        /* Messages from inside the TF file name that file (keys are read
         * under the same "transfer_function." paths), after the scene. */
        volux_json_reader sub = {r->ctx, path};
        cJSON *tree = NULL;
        st = volux_json_parse(&sub, text, n, &tree);
        volux_free(r->ctx, text, n + 1);
        if (!st) {
            char dir[4096];
            dir_of(path, dir, sizeof dir);
            scene_reader sub_sr = {sub, sr->base_dir, sr->scene, sr->flags};
            st = read_tf_object(&sub_sr, tree, dir);
            cJSON_Delete(tree);
        }
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
    static const char *const keys[] = {"type", "eye", "look_at", "up", "fov_y", "height", "orbit", "comment", NULL};
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
    if (eye) {
        float e[3], at[3] = {0, 0, 0}, up[3] = {0, 1, 0};
        d.use_orbit = 0;
        if ((st = volux_json_vec3(r, obj, "camera", "eye", -COORD, COORD, e)) ||
            (st = volux_json_vec3(r, obj, "camera", "look_at", -COORD, COORD, at)) ||
            (st = volux_json_vec3(r, obj, "camera", "up", -COORD, COORD, up)))
            return st;
        d.eye = (volux_vec3){e[0], e[1], e[2]};
        d.look_at = (volux_vec3){at[0], at[1], at[2]};
        d.up = (volux_vec3){up[0], up[1], up[2]};
    } else {
        if (cJSON_GetObjectItemCaseSensitive(obj, "look_at") || cJSON_GetObjectItemCaseSensitive(obj, "up"))
            return volux_json_error(r, VOLUX_ERR_INVALID, "camera", "look_at/up need an eye");
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
                                           "target_error", "comment", NULL};
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
            else if (cJSON_IsString(p)) st = volux_scene_set_param(sr->scene, t->string, p->string, 0, p->valuestring);
            else {
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

/* ------------------------------------------------------------------ entry points */

static volux_status read_scene(scene_reader *sr, const cJSON *root) {
    volux_json_reader *r = &sr->json;
    static const char *const keys[] = {"volume", "transfer_function", "camera", "lights", "background",
                                       "render", "techniques", "comment", NULL};
    volux_status st = volux_json_check_keys(r, root, "", keys);
    if (st) return st;
    float bg[3] = {0, 0, 0};
    if ((st = volux_json_vec3(r, root, "", "background", 0, BIG, bg))) return st;
    /* Order matters: the TF preset is rescaled to the volume's range. */
    if ((st = read_render(sr, cJSON_GetObjectItemCaseSensitive(root, "render"))) ||
        (st = read_volume(sr, cJSON_GetObjectItemCaseSensitive(root, "volume"))) ||
        (st = read_transfer(sr, cJSON_GetObjectItemCaseSensitive(root, "transfer_function"))) ||
        (st = read_camera(sr, cJSON_GetObjectItemCaseSensitive(root, "camera"))) ||
        (st = read_lights(sr, cJSON_GetObjectItemCaseSensitive(root, "lights"))) ||
        (st = read_techniques(sr, cJSON_GetObjectItemCaseSensitive(root, "techniques"))))
        return st;
    volux_scene_set_background(sr->scene, (volux_vec3){bg[0], bg[1], bg[2]});
    return VOLUX_OK;
}

volux_status volux_scene_parse(volux_context *ctx, const char *text, size_t n, const char *base_dir,
                               const char *name, const char *const *overrides, int n_overrides, unsigned flags,
                               volux_scene **out) {
    scene_reader sr = {{ctx, name ? name : "scene"}, base_dir ? base_dir : ".", NULL, flags};
    cJSON *root = NULL;
    volux_status st = volux_json_parse(&sr.json, text, n, &root);
    if (st) return st;
    if (!cJSON_IsObject(root)) {
        cJSON_Delete(root);
        return volux_json_error(&sr.json, VOLUX_ERR_INVALID, NULL, "the scene must be a JSON object");
    }
    for (int i = 0; i < n_overrides; i++)
        if ((st = volux_json_apply_override(&sr.json, root, overrides[i]))) {
            cJSON_Delete(root);
            return st;
        }
    if ((st = volux_scene_create(ctx, &sr.scene))) {
        cJSON_Delete(root);
        return st;
    }
    st = read_scene(&sr, root);
    cJSON_Delete(root);
    if (st) {
        volux_scene_destroy(sr.scene);
        return st;
    }
    *out = sr.scene;
    return VOLUX_OK;
}

volux_status volux_scene_load_string(volux_context *ctx, const char *json, const char *base_dir, const char *name,
                                     const char *const *overrides, int n_overrides, volux_scene **out) {
    return volux_scene_parse(ctx, json, strlen(json), base_dir, name, overrides, n_overrides, 0, out);
}

volux_status volux_scene_load(volux_context *ctx, const char *path, const char *const *overrides, int n_overrides,
                              volux_scene **out) {
    char *text;
    size_t n;
    volux_status st = volux_json_read_file(ctx, path, &text, &n);
    if (st) return st;
    char dir[4096];
    dir_of(path, dir, sizeof dir);
    /* The parser rejects NUL bytes with their line and column. */
    st = volux_scene_parse(ctx, text, n, dir, path, overrides, n_overrides, 0, out);
    volux_free(ctx, text, n + 1);
    return st;
}
