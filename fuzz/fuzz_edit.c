/* fuzz/fuzz_edit.c — edit lists on a scene document, as `volux serve`
 * receives them in POST /api/edit: [{"path": "...", "value": ...}, ...].
 *
 * Each input is applied to a fresh document of a fixed, valid scene (an
 * 8³ phantom: no file to read). Checked: a rejected edit leaves the
 * document's JSON and version unchanged and names the edit entry or the
 * scene file; an
 * accepted one leaves a live scene a renderer can use and a JSON text that
 * parses back into a scene; nothing stays allocated through the context. */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "fuzz_scene_common.h"
#include "volux/io.h"

static const char SCENE[] =
    "{\"volume\": {\"procedural\": \"phantom\", \"dims\": [8, 8, 8]},"
    " \"transfer_function\": {\"color\": [[0, 0, 0, 1], [255, 1, 1, 1]], \"opacity\": [[0, 0], [255, 0.5]],"
    "   \"albedo\": 0.9},"
    " \"camera\": {\"orbit\": {\"azimuth\": 30, \"elevation\": 20}, \"fov_y\": 30},"
    " \"lights\": [{\"type\": \"directional\", \"direction\": [0, -1, 0]},"
    "              {\"type\": \"spot\", \"position\": [0, 20, 0], \"direction\": [0, -1, 0]}],"
    " \"background\": [0, 0, 0],"
    " \"render\": {\"technique\": \"ea\", \"width\": 16, \"height\": 16},"
    " \"techniques\": {\"ea\": {\"early_termination\": 0.01}}}";

/* The scene file, written once per process into a folder of its own (the
 * document's data root). */
static char path_buf[256], dir_buf[256];

static void remove_scene(void) {
    unlink(path_buf);
    rmdir(dir_buf);
}

static const char *scene_path(void) {
    char *path = path_buf;
    if (path[0]) return path;
    char dir[] = "/tmp/volux-fuzz-edit-XXXXXX";
    if (!mkdtemp(dir)) abort();
    snprintf(path_buf, sizeof path_buf, "%s/fixed.json", dir);
    snprintf(dir_buf, sizeof dir_buf, "%s", dir);
    atexit(remove_scene);
    FILE *f = fopen(path, "w");
    if (!f || fwrite(SCENE, 1, sizeof SCENE - 1, f) != sizeof SCENE - 1 || fclose(f)) abort();
    return path;
}

static char *doc_json(volux_scene_doc *doc) {
    char *text = NULL;
    size_t n = 0;
    if (volux_scene_doc_json(doc, 0, &text, &n) != VOLUX_OK) return NULL;
    char *copy = strdup(text);
    volux_scene_doc_json_free(doc, text, n);
    return copy;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    volux_context *ctx = fuzz_context();
    const char *path = scene_path();
    volux_scene_doc *doc = NULL;
    /* Under the fuzz memory cap the fixed scene always loads. */
    if (volux_scene_doc_load(ctx, path, NULL, 0, NULL, &doc) != VOLUX_OK) {
        fprintf(stderr, "fuzz: the fixed scene did not load: %s\n", volux_context_error(ctx));
        abort();
    }
    char *before = doc_json(doc);
    uint64_t version = volux_scene_doc_version(doc);
    volux_context_clear_error(ctx);
    uint32_t changed = 0;
    volux_status st = volux_scene_doc_edit_json(doc, (const char *)data, size, &changed);
    char *after = doc_json(doc);
    if (!before || !after) abort(); /* 8³ and a short JSON fit any cap */
    if (st != VOLUX_OK) {
        if (st != VOLUX_ERR_NOMEM) {
            /* Problems of the list itself name the entry ("edit: invalid
             * JSON...", "edit[1].path: ..."); the rest come from reading
             * the edited scene and name its file. */
            if (st == VOLUX_ERR_INTERNAL || strncmp(volux_context_error(ctx), "edit", 4) != 0)
                fuzz_check_failure(ctx, st, path);
            if (strcmp(before, after) || volux_scene_doc_version(doc) != version) {
                fprintf(stderr, "fuzz: a rejected edit changed the document\n");
                abort();
            }
        }
    } else {
        fuzz_use_scene(ctx, volux_scene_doc_scene(doc));
        /* The document's JSON is a scene that loads (files, if an edit named
         * any, resolve against the scene's folder: the data root). */
        char dir[256];
        snprintf(dir, sizeof dir, "%.*s", (int)(strrchr(path, '/') - path), path);
        volux_scene *again = NULL;
        volux_context_clear_error(ctx);
        volux_status st2 = volux_scene_parse(ctx, after, strlen(after), dir, "again.json", NULL, 0, 0, &again);
        if (st2 != VOLUX_OK && st2 != VOLUX_ERR_NOMEM) {
            fprintf(stderr, "fuzz: the edited document's JSON does not load: %s\n%s\n", volux_context_error(ctx),
                    after);
            abort();
        }
        volux_scene_destroy(again);
    }
    free(before);
    free(after);
    volux_scene_doc_destroy(doc);
    fuzz_check_no_leak(ctx);
    return 0;
}
