/*
 * io/scene_doc.c — scene documents: a live scene plus the JSON it was read
 * from, edited with --set assignments (volux/io.h).
 *
 * An edit never touches the live scene until it is known to be valid: the
 * JSON is copied, the assignments are applied to the copy, the copy is read
 * into a candidate scene (sections that did not change are copied from the
 * live scene instead of being read again), the caller's validate hook runs,
 * and only then are the changed sections set on the live scene, so its
 * setters bump exactly the versions the edit changed.
 */
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "json_reader.h"
#include "scene_formats.h"
#include "core/scene_internal.h"

#define MAX_EDITS 256

struct volux_scene_doc {
    volux_context *ctx;
    char *name;     /* the scene's file name as given (messages)       */
    char *base_dir; /* absolute folder of the scene file               */
    char *root;     /* absolute, symlink-free data root                */
    cJSON *tree;    /* the JSON after every applied edit               */
    volux_scene *scene;
    volux_path_list trusted; /* files the loaded document named      */
    volux_status (*validate)(void *user, volux_context *ctx, const volux_scene *candidate);
    void *validate_user;
    uint64_t version;
};

/* ------------------------------------------------------------------ paths */

volux_status volux_path_list_add(volux_context *ctx, volux_path_list *l, const char *path) {
    if (volux_path_list_has(l, path)) return VOLUX_OK;
    if (l->n == l->cap) {
        int cap = l->cap ? 2 * l->cap : 8;
        char **items = volux_realloc(ctx, l->items, sizeof *items * (size_t)l->cap, sizeof *items * (size_t)cap);
        if (!items) return VOLUX_ERR_NOMEM;
        l->items = items;
        l->cap = cap;
    }
    char *copy = volux_strdup(ctx, path);
    if (!copy) return VOLUX_ERR_NOMEM;
    l->items[l->n++] = copy;
    return VOLUX_OK;
}

int volux_path_list_has(const volux_path_list *l, const char *path) {
    for (int i = 0; i < l->n; i++)
        if (!strcmp(l->items[i], path)) return 1;
    return 0;
}

void volux_path_list_free(volux_context *ctx, volux_path_list *l) {
    for (int i = 0; i < l->n; i++) volux_strfree(ctx, l->items[i]);
    volux_free(ctx, l->items, sizeof *l->items * (size_t)l->cap);
    memset(l, 0, sizeof *l);
}

int volux_path_inside(const char *path, const char *root) {
    size_t n = strlen(root);
    if (n == 1 && root[0] == '/') return path[0] == '/';
    /* "/data" contains "/data/x" but not "/database/x" */
    return !strncmp(path, root, n) && (path[n] == '/' || path[n] == 0);
}

static char *absolute_dir_of(volux_context *ctx, const char *path) {
    char dir[PATH_MAX], real[PATH_MAX];
    const char *slash = strrchr(path, '/');
    if (!slash) snprintf(dir, sizeof dir, ".");
    else if (slash == path) snprintf(dir, sizeof dir, "/");
    else snprintf(dir, sizeof dir, "%.*s", (int)(slash - path), path);
    if (!realpath(dir, real)) return NULL;
    return volux_strdup(ctx, real);
}

/* ------------------------------------------------------------------ load */

void volux_scene_doc_destroy(volux_scene_doc *doc) {
    if (!doc) return;
    volux_context *ctx = doc->ctx;
    volux_scene_destroy(doc->scene);
    cJSON_Delete(doc->tree);
    volux_path_list_free(ctx, &doc->trusted);
    volux_strfree(ctx, doc->name);
    volux_strfree(ctx, doc->base_dir);
    volux_strfree(ctx, doc->root);
    volux_free(ctx, doc, sizeof *doc);
}

volux_status volux_scene_doc_load(volux_context *ctx, const char *path, const char *const *overrides,
                                  int n_overrides, const volux_scene_doc_options *options, volux_scene_doc **out) {
    return volux_scene_doc_load_named(ctx, path, path, overrides, n_overrides, options, out);
}

volux_status volux_scene_doc_load_named(volux_context *ctx, const char *path, const char *name,
                                        const char *const *overrides, int n_overrides,
                                        const volux_scene_doc_options *options, volux_scene_doc **out) {
    if (!name) name = path;
    volux_scene_doc *doc = volux_calloc(ctx, 1, sizeof *doc);
    if (!doc) return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for a scene document");
    doc->ctx = ctx;
    volux_json_reader r = {ctx, name};
    char *text = NULL;
    size_t n = 0;
    volux_status st = volux_json_read_file(ctx, path, &text, &n);
    if (st) goto fail;
    if (!(doc->name = volux_strdup(ctx, name))) goto nomem;
    if (!(doc->base_dir = absolute_dir_of(ctx, path))) {
        st = volux_error(ctx, VOLUX_ERR_IO, "%s: cannot resolve the scene's folder: %s", name, strerror(errno));
        goto fail;
    }
    const char *root = options && options->data_root ? options->data_root : doc->base_dir;
    char real[PATH_MAX];
    if (!realpath(root, real)) {
        st = volux_error(ctx, VOLUX_ERR_IO, "data root '%s': %s", root, strerror(errno));
        goto fail;
    }
    if (!(doc->root = volux_strdup(ctx, real))) goto nomem;
    if (options) {
        doc->validate = options->validate;
        doc->validate_user = options->validate_user;
    }
    if ((st = volux_json_parse(&r, text, n, &doc->tree))) goto fail;
    if (!cJSON_IsObject(doc->tree)) {
        st = volux_json_error(&r, VOLUX_ERR_INVALID, NULL, "the scene must be a JSON object");
        goto fail;
    }
    for (int i = 0; i < n_overrides; i++)
        if ((st = volux_json_apply_override(&r, doc->tree, overrides[i]))) goto fail;
    if ((st = volux_scene_create(ctx, &doc->scene))) goto fail;
    /* The files of the loaded document are trusted (the user chose them on
     * the command line); edits may name those or files in the data root. */
    volux_scene_files files = {&doc->trusted, NULL, NULL};
    if ((st = volux_scene_read_tree(ctx, doc->tree, doc->base_dir, name, &files, doc->scene))) goto fail;
    if (doc->validate && (st = doc->validate(doc->validate_user, ctx, doc->scene))) {
        volux_error_prefix(ctx, "%s: ", name);
        goto fail;
    }
    volux_free(ctx, text, n + 1);
    *out = doc;
    return VOLUX_OK;
nomem:
    st = volux_error(ctx, VOLUX_ERR_NOMEM, "%s: out of memory", name);
fail:
    if (text) volux_free(ctx, text, n + 1);
    volux_scene_doc_destroy(doc);
    return st;
}

volux_scene *volux_scene_doc_scene(const volux_scene_doc *doc) { return doc->scene; }
const char *volux_scene_doc_data_root(const volux_scene_doc *doc) { return doc->root; }
uint64_t volux_scene_doc_version(const volux_scene_doc *doc) { return doc->version; }

/* ------------------------------------------------------------------ edit */

/* Parameters are finite numbers or strings, so NaN marks "unset". */
static int has_param(const volux_scene *s, const char *t, const char *name) {
    return volux_scene_param_string(s, t, name, NULL) || !isnan(volux_scene_param(s, t, name, NAN));
}

static int same_params(const volux_scene *a, const volux_scene *b) {
    const char *t, *name, *str;
    double num;
    int na = 0, nb = 0;
    while (volux_scene_param_at(a, na, &t, &name, &num, &str)) na++;
    while (volux_scene_param_at(b, nb, &t, &name, &num, &str)) nb++;
    if (na != nb) return 0;
    for (int i = 0; i < na; i++) {
        volux_scene_param_at(a, i, &t, &name, &num, &str);
        const char *other = volux_scene_param_string(b, t, name, NULL);
        if (str ? !other || strcmp(str, other) : other || volux_scene_param(b, t, name, num + 1.0) != num) return 0;
    }
    return 1;
}

/* Brings `live` to `cand` with its setters, touching only what the plan
 * says changed (and, for sections always read, only what differs). */
static volux_status transplant(volux_scene *live, volux_scene *cand, const volux_scene_edit_plan *plan,
                               uint32_t *changed) {
    volux_status st;
    uint32_t bits = 0;
    if (plan->volume) {
        /* A sequence read by the edit moves to the live scene (the
         * candidate, destroyed next, would take it along). */
        volux_sequence *q = volux_scene_take_sequence(cand);
        if (q) {
            if ((st = volux_scene_set_sequence(live, q, plan->time_step))) {
                volux_sequence_destroy(q);
                return st;
            }
        } else if ((st = volux_scene_set_volume(live, volux_scene_volume(cand)))) {
            return st;
        }
        bits |= VOLUX_DOC_VOLUME;
    } else if (plan->time_step != volux_scene_time_step(live)) {
        /* The sequence stays: select the step (its volume is cached). */
        if ((st = volux_scene_set_time_step(live, plan->time_step))) return st;
        bits |= VOLUX_DOC_VOLUME;
    }
    if (plan->transfer) {
        /* The setter compares old and new and bumps only what differs. */
        if ((st = volux_scene_set_transfer(live, volux_scene_transfer(cand)))) return st;
        bits |= VOLUX_DOC_TRANSFER;
    }
    /* The setter compares, and rebuilds the clipped copy only on a change. */
    volux_scene_stamp before = volux_scene_stamp_now(live);
    if ((st = volux_scene_set_clip(live, volux_scene_clip(cand)))) return st;
    if (volux_scene_changes_since(live, &before).what & VOLUX_CHANGE_VOLUME) bits |= VOLUX_DOC_VOLUME;
    if (plan->camera && memcmp(volux_scene_camera_desc(live), volux_scene_camera_desc(cand),
                               sizeof(volux_camera_desc)) != 0) {
        if ((st = volux_scene_set_camera(live, volux_scene_camera_desc(cand)))) return st;
        bits |= VOLUX_DOC_CAMERA;
    }
    int slots = volux_scene_light_slots(live);
    if (plan->n_lights > slots) slots = plan->n_lights;
    for (int i = 0; i < slots; i++) {
        if (i >= plan->n_lights) {
            if (volux_scene_light(live, i)) {
                if ((st = volux_scene_remove_light(live, i))) return st;
                bits |= VOLUX_DOC_LIGHTS;
            }
        } else if (plan->light[i]) {
            if ((st = volux_scene_set_light(live, i, volux_scene_light(cand, i)))) return st;
            bits |= VOLUX_DOC_LIGHTS;
        }
    }
    if (memcmp(volux_scene_render(live), volux_scene_render(cand), sizeof(volux_render_settings)) != 0) {
        if ((st = volux_scene_set_render(live, volux_scene_render(cand)))) return st;
        bits |= VOLUX_DOC_OTHER;
    }
    volux_vec3 bl = volux_scene_background(live), bc = volux_scene_background(cand);
    if (memcmp(&bl, &bc, sizeof bl) != 0) {
        volux_scene_set_background(live, bc);
        bits |= VOLUX_DOC_OTHER;
    }
    if (!same_params(live, cand)) {
        const char *t, *name, *str;
        double num;
        /* Drop what the candidate no longer has, then set what differs. */
        for (int i = 0; volux_scene_param_at(live, i, &t, &name, &num, &str);) {
            if (has_param(cand, t, name)) {
                i++;
                continue;
            }
            if ((st = volux_scene_remove_param(live, t, name))) return st; /* the list shifted: same i */
        }
        for (int i = 0; volux_scene_param_at(cand, i, &t, &name, &num, &str); i++) {
            const char *ls = volux_scene_param_string(live, t, name, NULL);
            double ln = volux_scene_param(live, t, name, NAN);
            int same = str ? ls && !strcmp(ls, str) : !ls && ln == num;
            if (!same && (st = volux_scene_set_param(live, t, name, num, str))) return st;
        }
        bits |= VOLUX_DOC_OTHER;
    }
    if (changed) *changed = bits;
    return VOLUX_OK;
}

volux_status volux_scene_doc_edit(volux_scene_doc *doc, const char *const *assignments, int n, uint32_t *changed) {
    volux_context *ctx = doc->ctx;
    volux_json_reader r = {ctx, doc->name};
    if (n < 0 || n > MAX_EDITS)
        return volux_json_error(&r, VOLUX_ERR_LIMIT, NULL, "at most %d edits at once, got %d", MAX_EDITS, n);
    cJSON *tree = cJSON_Duplicate(doc->tree, 1);
    if (!tree) return volux_json_error(&r, VOLUX_ERR_NOMEM, NULL, "out of memory for an edit");
    volux_scene *cand = NULL;
    volux_scene_edit_plan plan;
    memset(&plan, 0, sizeof plan);
    volux_status st = VOLUX_OK;
    for (int i = 0; i < n && !st; i++) st = volux_json_apply_override(&r, tree, assignments[i]);
    if (st) goto done;
    if ((st = volux_scene_create(ctx, &cand))) goto done;
    volux_scene_files files = {NULL, doc->root, &doc->trusted};
    if ((st = volux_scene_read_edit(ctx, tree, doc->tree, doc->scene, doc->base_dir, doc->name, &files, cand, &plan)))
        goto done;
    if (doc->validate && (st = doc->validate(doc->validate_user, ctx, cand))) {
        volux_error_prefix(ctx, "%s: ", doc->name);
        goto done;
    }
    if ((st = transplant(doc->scene, cand, &plan, changed))) goto done;
    cJSON_Delete(doc->tree);
    doc->tree = tree;
    tree = NULL;
    doc->version++;
done:
    volux_scene_edit_plan_free(ctx, &plan);
    cJSON_Delete(tree);
    volux_scene_destroy(cand);
    return st;
}

volux_status volux_scene_doc_edit_json(volux_scene_doc *doc, const char *text, size_t n, uint32_t *changed) {
    volux_context *ctx = doc->ctx;
    volux_json_reader r = {ctx, "edit"};
    cJSON *list = NULL;
    volux_status st = volux_json_parse(&r, text, n, &list);
    if (st) return st;
    char **assign = NULL;
    int count = 0;
    if (!cJSON_IsArray(list)) {
        st = volux_json_error(&r, VOLUX_ERR_INVALID, NULL, "expected an array of {\"path\": ..., \"value\": ...}");
        goto done;
    }
    int size = cJSON_GetArraySize(list);
    if (size > MAX_EDITS) {
        st = volux_json_error(&r, VOLUX_ERR_LIMIT, NULL, "at most %d edits at once, got %d", MAX_EDITS, size);
        goto done;
    }
    assign = volux_calloc(ctx, (size_t)(size ? size : 1), sizeof *assign);
    if (!assign) {
        st = volux_json_error(&r, VOLUX_ERR_NOMEM, NULL, "out of memory");
        goto done;
    }
    static const char *const keys[] = {"path", "value", NULL};
    for (const cJSON *e = list->child; e; e = e->next, count++) {
        char P[32];
        snprintf(P, sizeof P, "edit[%d]", count);
        if ((st = volux_json_check_keys(&r, e, P, keys))) goto done;
        const cJSON *path = cJSON_GetObjectItemCaseSensitive(e, "path");
        const cJSON *value = cJSON_GetObjectItemCaseSensitive(e, "value");
        if (!cJSON_IsString(path) || !*path->valuestring || strchr(path->valuestring, '=')) {
            char q[48];
            snprintf(q, sizeof q, "%s.path", P);
            st = volux_json_error(&r, VOLUX_ERR_INVALID, q, "expected a dotted path such as \"lights.0.irradiance\"");
            goto done;
        }
        if (!value) {
            st = volux_json_error(&r, VOLUX_ERR_INVALID, P, "missing value");
            goto done;
        }
        /* The value goes through the --set parser as JSON text, so an edit
         * means exactly what the same --set on the command line means. */
        char *json = cJSON_PrintUnformatted(value);
        if (!json) {
            st = volux_json_error(&r, VOLUX_ERR_NOMEM, P, "out of memory");
            goto done;
        }
        size_t lp = strlen(path->valuestring), lv = strlen(json);
        assign[count] = volux_malloc(ctx, lp + lv + 2);
        if (assign[count]) {
            memcpy(assign[count], path->valuestring, lp);
            assign[count][lp] = '=';
            memcpy(assign[count] + lp + 1, json, lv + 1);
        }
        cJSON_free(json);
        if (!assign[count]) {
            st = volux_json_error(&r, VOLUX_ERR_NOMEM, P, "out of memory");
            goto done;
        }
    }
    cJSON_Delete(list);
    list = NULL;
    st = volux_scene_doc_edit(doc, (const char *const *)assign, count, changed);
done:
    for (int i = 0; assign && i < count; i++)
        if (assign[i]) volux_free(ctx, assign[i], strlen(assign[i]) + 1);
    if (assign) volux_free(ctx, assign, sizeof *assign * (size_t)(size > 0 ? size : 1));
    cJSON_Delete(list);
    return st;
}

/* ------------------------------------------------------------------ JSON out */

/* Replaces a relative file name at `node` by base/name. */
static int absolutise(cJSON *parent, cJSON *node, const char *key, int index, const char *base) {
    if (!cJSON_IsString(node) || node->valuestring[0] == '/' || !node->valuestring[0]) return 1;
    size_t n = strlen(base) + strlen(node->valuestring) + 2;
    char *abs = malloc(n);
    if (!abs) return 0;
    snprintf(abs, n, "%s/%s", base, node->valuestring);
    cJSON *s = cJSON_CreateString(abs);
    free(abs);
    if (!s) return 0;
    if (key) return cJSON_ReplaceItemInObjectCaseSensitive(parent, key, s) ? 1 : (cJSON_Delete(s), 0);
    return cJSON_ReplaceItemInArray(parent, index, s) ? 1 : (cJSON_Delete(s), 0);
}

static int absolute_lights(cJSON *root, const char *base) {
    cJSON *l = cJSON_GetObjectItemCaseSensitive(root, "lights");
    for (cJSON *e = cJSON_IsArray(l) ? l->child : NULL; e; e = e->next)
        if (cJSON_IsObject(e) && !absolutise(e, cJSON_GetObjectItemCaseSensitive(e, "file"), "file", 0, base))
            return 0;
    return 1;
}

/* Every file name the scene format has (see scene_json.c's resolve_path
 * calls): volume.file, transfer_function (a file name), its preset and
 * material files (relative to the TF's folder, which for an inline TF is
 * the scene's), lights[i].file. */
static int absolute_paths(cJSON *root, const char *base) {
    cJSON *v = cJSON_GetObjectItemCaseSensitive(root, "volume");
    if (cJSON_IsObject(v) && !absolutise(v, cJSON_GetObjectItemCaseSensitive(v, "file"), "file", 0, base)) return 0;
    cJSON *tf = cJSON_GetObjectItemCaseSensitive(root, "transfer_function");
    if (cJSON_IsString(tf)) return absolutise(root, tf, "transfer_function", 0, base) && absolute_lights(root, base);
    if (cJSON_IsObject(tf)) {
        if (!absolutise(tf, cJSON_GetObjectItemCaseSensitive(tf, "preset"), "preset", 0, base)) return 0;
        cJSON *m = cJSON_GetObjectItemCaseSensitive(tf, "materials");
        for (cJSON *e = cJSON_IsArray(m) ? m->child : NULL; e; e = e->next)
            if (cJSON_IsObject(e) && !absolutise(e, cJSON_GetObjectItemCaseSensitive(e, "file"), "file", 0, base))
                return 0;
    }
    return absolute_lights(root, base);
}

volux_status volux_scene_doc_json(const volux_scene_doc *doc, unsigned flags, char **out, size_t *len) {
    volux_context *ctx = doc->ctx;
    cJSON *tree = doc->tree, *copy = NULL;
    if (flags & VOLUX_DOC_JSON_ABSOLUTE_PATHS) {
        copy = cJSON_Duplicate(doc->tree, 1);
        if (!copy || !absolute_paths(copy, doc->base_dir)) {
            cJSON_Delete(copy);
            return volux_error(ctx, VOLUX_ERR_NOMEM, "%s: out of memory for the scene's JSON", doc->name);
        }
        tree = copy;
    }
    char *text = flags & VOLUX_DOC_JSON_PRETTY ? cJSON_Print(tree) : cJSON_PrintUnformatted(tree);
    cJSON_Delete(copy);
    if (!text) return volux_error(ctx, VOLUX_ERR_NOMEM, "%s: out of memory for the scene's JSON", doc->name);
    size_t n = strlen(text);
    char *mine = volux_malloc(ctx, n + 2);
    if (mine) {
        memcpy(mine, text, n);
        mine[n] = '\n'; /* a text file ends with a newline */
        mine[n + 1] = 0;
    }
    cJSON_free(text);
    if (!mine) return volux_error(ctx, VOLUX_ERR_NOMEM, "%s: out of memory for the scene's JSON", doc->name);
    *out = mine;
    *len = n + 1;
    return VOLUX_OK;
}

void volux_scene_doc_json_free(const volux_scene_doc *doc, char *text, size_t len) {
    if (text) volux_free(doc->ctx, text, len + 1);
}
