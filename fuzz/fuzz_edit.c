/* fuzz/fuzz_edit.c — edit lists on a scene document, as `volux serve`
 * receives them in POST /api/edit: [{"path": "...", "value": ...}, ...].
 *
 * Each input is applied to a fresh document of a fixed, valid scene (an
 * 8³ phantom: no file to read). Checked: a rejected edit leaves the
 * document's JSON and version unchanged and names the edit entry or the
 * scene file; an
 * accepted one leaves a live scene a renderer can use and a JSON text that
 * parses back into a scene; nothing stays allocated through the context.
 *
 * Hostile paths (issue 34): the scene's folder — the document's data root —
 * holds files an edit may name (a volume, an environment map, a TF file, a
 * preset, a table) and links that point out of it (a file link, a folder
 * link, a header whose detached data lies outside); a sibling folder
 * "outside" holds the targets. An inotify watch on "outside" sees every open
 * there: any edit that makes the library open a file outside the data root
 * aborts, whichever key or reader did it (corpus: fuzz/corpus/edit/path_*). */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/inotify.h>
#include <sys/stat.h>
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

/* The folder tree, made once per process: TOP/root (the scene file and the
 * files an edit may name: the data root) and TOP/outside. */
static char top[64], path_buf[128];
static int watch = -1;

/* name (in root, then outside), target of a link ("" = a file) */
static const struct {
    const char *name, *link;
} ROOT_FILES[] = {
    {"vol.nhdr", ""},    {"env.pfm", ""},   {"tf.json", ""},  {"preset.json", ""},
    {"table.bin", ""},   {"peek.nhdr", ""}, {"link.nhdr", "../outside/secret.nhdr"},
    {"link.json", "../outside/secret.json"}, {"link.pfm", "../outside/secret.pfm"},
    {"dirlink", "../outside"},
};
static const char *const OUTSIDE_FILES[] = {"secret.nhdr", "secret.json", "secret.pfm", "secret.raw", "secret.bin"};

static void put(const char *folder, const char *name, const void *bytes, size_t n) {
    char p[256];
    snprintf(p, sizeof p, "%s/%s/%s", top, folder, name);
    FILE *f = fopen(p, "wb");
    if (!f || fwrite(bytes, 1, n, f) != n || fclose(f)) abort();
}

/* The same content under a name in either folder. */
static void put_named(const char *folder, const char *name) {
    static const char nhdr[] = "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: ascii\n\n"
                               "0 10 20 30 40 50 60 70\n";
    static const char pfm[] = "PF\n1 1\n-1.0\n\0\0\x80?\0\0\x80?\0\0\x80?";
    static const char tf[] = "{\"color\": [[0, 1, 1, 1], [255, 1, 1, 1]], \"opacity\": [[0, 0], [255, 0.5]]}";
    static const char preset[] = "[{\"Name\": \"p\", \"RGBPoints\": [0, 0, 0, 0, 1, 1, 1, 1]}]";
    static const char peek[] = "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n"
                               "data file: ../outside/secret.raw\n";
    const char *ext = strrchr(name, '.');
    if (!strcmp(name, "peek.nhdr")) put(folder, name, peek, sizeof peek - 1);
    else if (!strcmp(ext, ".nhdr")) put(folder, name, nhdr, sizeof nhdr - 1);
    else if (!strcmp(ext, ".pfm")) put(folder, name, pfm, sizeof pfm - 1);
    else if (!strcmp(name, "preset.json")) put(folder, name, preset, sizeof preset - 1);
    else if (!strcmp(ext, ".json")) put(folder, name, tf, sizeof tf - 1);
    else put(folder, name, "\0\1\2\3\4\5\6\7", 8);
}

static void remove_tree(void) {
    char p[256];
    for (size_t i = 0; i < sizeof ROOT_FILES / sizeof *ROOT_FILES; i++) {
        snprintf(p, sizeof p, "%s/root/%s", top, ROOT_FILES[i].name);
        unlink(p);
    }
    for (size_t i = 0; i < sizeof OUTSIDE_FILES / sizeof *OUTSIDE_FILES; i++) {
        snprintf(p, sizeof p, "%s/outside/%s", top, OUTSIDE_FILES[i]);
        unlink(p);
    }
    unlink(path_buf);
    snprintf(p, sizeof p, "%s/root", top);
    rmdir(p);
    snprintf(p, sizeof p, "%s/outside", top);
    rmdir(p);
    rmdir(top);
}

static const char *scene_path(void) {
    if (path_buf[0]) return path_buf;
    snprintf(top, sizeof top, "/tmp/volux-fuzz-edit-XXXXXX");
    if (!mkdtemp(top)) abort();
    char p[256];
    snprintf(p, sizeof p, "%s/root", top);
    if (mkdir(p, 0700)) abort();
    snprintf(p, sizeof p, "%s/outside", top);
    if (mkdir(p, 0700)) abort();
    atexit(remove_tree);
    snprintf(path_buf, sizeof path_buf, "%s/root/fixed.json", top);
    put("root", "fixed.json", SCENE, sizeof SCENE - 1);
    for (size_t i = 0; i < sizeof ROOT_FILES / sizeof *ROOT_FILES; i++) {
        if (!*ROOT_FILES[i].link) {
            put_named("root", ROOT_FILES[i].name);
            continue;
        }
        snprintf(p, sizeof p, "%s/root/%s", top, ROOT_FILES[i].name);
        if (symlink(ROOT_FILES[i].link, p)) abort();
    }
    for (size_t i = 0; i < sizeof OUTSIDE_FILES / sizeof *OUTSIDE_FILES; i++) put_named("outside", OUTSIDE_FILES[i]);
    snprintf(p, sizeof p, "%s/outside", top);
    watch = inotify_init1(IN_NONBLOCK | IN_CLOEXEC);
    if (watch < 0 || inotify_add_watch(watch, p, IN_OPEN | IN_ACCESS) < 0) abort();
    return path_buf;
}

/* Aborts when anything under "outside" was opened since the last call. */
static void check_nothing_opened_outside(const uint8_t *data, size_t size) {
    char buf[4096] __attribute__((aligned(__alignof__(struct inotify_event))));
    ssize_t got = read(watch, buf, sizeof buf);
    if (got <= 0) return;
    const struct inotify_event *e = (const struct inotify_event *)buf;
    fprintf(stderr, "fuzz: the edit opened a file outside the data root (outside/%s): %.*s\n", e->len ? e->name : "",
            (int)(size < 400 ? size : 400), (const char *)data);
    abort();
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
    check_nothing_opened_outside(data, size);
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
        check_nothing_opened_outside(data, size);
    }
    free(before);
    free(after);
    volux_scene_doc_destroy(doc);
    fuzz_check_no_leak(ctx);
    return 0;
}
