/*
 * tests/robustness/test_data_root_keys.c — no file outside the data root
 * is opened through any key of a scene document (issue 34, target "0 reads
 * outside the data root across every path-bearing key and format").
 *
 * The keys are not listed here by hand. They are enumerated from what the
 * library itself says the scene holds:
 *   - every string value of the document as the library prints it
 *     (volux_scene_doc_json) for scenes that use every file-bearing
 *     section: a volume file, a time sequence (files, pattern), a TF file,
 *     an inline TF with a ParaView preset and a MERL material, an
 *     environment map, a technique file parameter;
 *   - every technique parameter the registry declares as VOLUX_PARAM_FILE.
 * A new string key the printer emits, or a new file parameter, is attacked
 * without editing this test.
 *
 * Each key gets the hostile names a browser could send: an absolute path
 * outside, ../ out of the root, a symbolic link in the root pointing out, a
 * path through a linked folder, /proc/self/environ, missing names inside
 * and outside, and headers inside the root whose detached data lies
 * outside. An inotify watch on the outside folder sees every open of a
 * file there, whichever reader or code path would do it. Every name that
 * is not available (outside, missing) must get the same answer — outcome
 * and message with the name blanked — so a client cannot tell which exist.
 */
#include <cjson/cJSON.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/inotify.h>
#include <sys/stat.h>
#include <unistd.h>

#include "test_util.h"

static char g_dir[PATH_MAX], g_out[PATH_MAX + 16], g_root[PATH_MAX + 16];
static int g_watch = -1;

static void put(const char *dir, const char *name, const void *bytes, size_t n) {
    char p[PATH_MAX * 2];
    snprintf(p, sizeof p, "%s/%s", dir, name);
    FILE *f = fopen(p, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(bytes, 1, n, f), n);
    assert_int_equal(fclose(f), 0);
}
static void put_text(const char *dir, const char *name, const char *text) { put(dir, name, text, strlen(text)); }

static void link_to(const char *target, const char *name) {
    char p[PATH_MAX * 2];
    snprintf(p, sizeof p, "%s/%s", g_root, name);
    assert_int_equal(symlink(target, p), 0);
}

/* A valid MERL file (header + 90·90·180·3 doubles) without writing 35 MB:
 * the zeros are a hole. */
static void put_merl(const char *dir, const char *name) {
    char p[PATH_MAX * 2];
    snprintf(p, sizeof p, "%s/%s", dir, name);
    int fd = open(p, O_WRONLY | O_CREAT | O_TRUNC, 0600);
    assert_true(fd >= 0);
    int dims[3] = {90, 90, 180};
    assert_int_equal(write(fd, dims, sizeof dims), (ssize_t)sizeof dims);
    assert_int_equal(ftruncate(fd, 12 + 24LL * 90 * 90 * 180), 0);
    close(fd);
}

static void put_files(const char *dir) {
    unsigned char vox[512];
    for (int i = 0; i < 512; i++) vox[i] = (unsigned char)(i * 7);
    char nhdr[600];
    int n = snprintf(nhdr, sizeof nhdr, "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 8 8 8\nencoding: raw\n\n");
    memcpy(nhdr + n, vox, sizeof vox);
    static const char *const vols[] = {"vol.nhdr", "f0.nhdr", "f1.nhdr", "secret.nhdr", "secret0.nhdr", "secret1.nhdr"};
    for (size_t i = 0; i < sizeof vols / sizeof *vols; i++) put(dir, vols[i], nhdr, (size_t)n + sizeof vox);
    put(dir, "secret.raw", vox, sizeof vox);
    const char *tf = "{\"color\": [[0, 1, 1, 1], [255, 1, 1, 1]], \"opacity\": [[0, 0], [255, 0.5]]}";
    put_text(dir, "tf.json", tf);
    put_text(dir, "secret.json", tf);
    put_text(dir, "preset.json", "[{\"Name\": \"p\", \"RGBPoints\": [0, 0, 0, 0, 1, 1, 1, 1]}]");
    const char pfm_head[] = "PF\n2 1\n-1.0\n";
    unsigned char pfm[sizeof pfm_head - 1 + 24];
    memcpy(pfm, pfm_head, sizeof pfm_head - 1);
    float px[6] = {1, 1, 1, 1, 1, 1};
    memcpy(pfm + sizeof pfm_head - 1, px, sizeof px);
    put(dir, "env.pfm", pfm, sizeof pfm);
    put(dir, "secret.pfm", pfm, sizeof pfm);
    put_merl(dir, "brdf.binary");
    put_merl(dir, "secret.binary");
    put_text(dir, "table.bin", "not a table, but a file");
    put_text(dir, "secret.bin", "not a table, but a file");
    put_text(dir, "secret", "no extension");
}

/* Events on the outside folder since the last call (0: none). */
static int outside_opens(char *what, size_t n) {
    char buf[4096] __attribute__((aligned(__alignof__(struct inotify_event))));
    int count = 0;
    what[0] = 0;
    for (;;) {
        ssize_t got = read(g_watch, buf, sizeof buf);
        if (got <= 0) break;
        for (char *p = buf; p < buf + got;) {
            struct inotify_event *e = (struct inotify_event *)p;
            if (!count && e->len) snprintf(what, n, "%s", e->name);
            count++;
            p += sizeof *e + e->len;
        }
    }
    return count;
}

static void setup_dirs(void) {
    snprintf(g_dir, sizeof g_dir, "%s", tu_temp_path("rootkeys"));
    char cmd[PATH_MAX * 2];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", g_dir);
    assert_int_equal(system(cmd), 0);
    assert_int_equal(mkdir(g_dir, 0700), 0);
    snprintf(g_out, sizeof g_out, "%s/outside", g_dir);
    snprintf(g_root, sizeof g_root, "%s/root", g_dir);
    assert_int_equal(mkdir(g_out, 0700), 0);
    assert_int_equal(mkdir(g_root, 0700), 0);
    put_files(g_out);
    put_files(g_root);
    /* Links in the root that point out of it, for every extension used. */
    static const char *const ext[] = {".nhdr", ".json", ".pfm", ".binary", ".bin", ""};
    for (size_t i = 0; i < sizeof ext / sizeof *ext; i++) {
        char target[PATH_MAX * 2], name[64];
        snprintf(target, sizeof target, "%s/secret%s", g_out, ext[i]);
        snprintf(name, sizeof name, "link%s", ext[i]);
        link_to(target, name);
    }
    for (int k = 0; k < 2; k++) {
        char target[PATH_MAX * 2], name[64];
        snprintf(target, sizeof target, "../outside/secret%d.nhdr", k);
        snprintf(name, sizeof name, "link%d.nhdr", k);
        link_to(target, name);
    }
    link_to("../outside", "dirlink");
    /* Headers inside the root whose detached data lies outside. */
    put_text(g_root, "peek.nhdr",
             "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 8 8 8\nencoding: raw\ndata file: ../outside/secret.raw\n");
    char abs[PATH_MAX * 2];
    snprintf(abs, sizeof abs,
             "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 8 8 8\nencoding: raw\ndata file: %s/secret.raw\n", g_out);
    put_text(g_root, "peekabs.nhdr", abs);
    g_watch = inotify_init1(IN_NONBLOCK | IN_CLOEXEC);
    assert_true(g_watch >= 0);
    assert_true(inotify_add_watch(g_watch, g_out, IN_OPEN | IN_ACCESS) >= 0);
}

/* The base scenes: together they use every file-bearing section. */
static const char *const base_scenes[] = {
    "{\"volume\": {\"file\": \"vol.nhdr\"}, \"transfer_function\": \"tf.json\","
    " \"lights\": [{\"type\": \"environment\", \"file\": \"env.pfm\"}, {\"type\": \"directional\", \"direction\": [0, 0, -1]}],"
    " \"render\": {\"technique\": \"ea\", \"width\": 8, \"height\": 8, \"spp\": 1},"
    " \"techniques\": {\"ambient\": {\"table_file\": \"table.bin\"}}, \"comment\": \"a\"}",
    "{\"volume\": {\"files\": [\"f0.nhdr\", \"f1.nhdr\"]},"
    " \"transfer_function\": {\"preset\": \"preset.json\", \"opacity\": [[0, 0], [255, 1]],"
    "  \"materials\": [{\"range\": [0, 255], \"type\": \"merl\", \"file\": \"brdf.binary\"}]},"
    " \"render\": {\"technique\": \"sh\", \"width\": 8, \"height\": 8}}",
    "{\"volume\": {\"pattern\": \"f%d.nhdr\", \"range\": [0, 1]},"
    " \"transfer_function\": {\"opacity\": [[0, 0], [255, 1]]}, \"render\": {\"width\": 8, \"height\": 8}}",
};

typedef struct key_list {
    char key[64][128];
    char value[64][256];
    int n;
} key_list;

static void add_key(key_list *k, const char *key, const char *value) {
    for (int i = 0; i < k->n; i++)
        if (!strcmp(k->key[i], key)) return;
    assert_true(k->n < 64);
    snprintf(k->key[k->n], sizeof k->key[0], "%s", key);
    snprintf(k->value[k->n], sizeof k->value[0], "%s", value);
    k->n++;
}

static void collect_strings(const cJSON *node, const char *prefix, key_list *out) {
    int i = 0;
    for (const cJSON *c = node->child; c; c = c->next, i++) {
        char key[128];
        if (cJSON_IsArray(node)) snprintf(key, sizeof key, "%s%s%d", prefix, *prefix ? "." : "", i);
        else snprintf(key, sizeof key, "%s%s%s", prefix, *prefix ? "." : "", c->string);
        if (cJSON_IsString(c)) add_key(out, key, c->valuestring);
        else if (cJSON_IsObject(c) || cJSON_IsArray(c)) collect_strings(c, key, out);
    }
}

/* One edit of `key` to the string `value`: its status and message (with
 * every occurrence of `value` blanked, so answers for different names
 * compare). */
static volux_status edit_to(volux_scene_doc *doc, volux_context *ctx, const char *key, const char *value, char *msg,
                            size_t n) {
    cJSON *arr = cJSON_CreateArray(), *e = cJSON_CreateObject();
    cJSON_AddStringToObject(e, "path", key);
    cJSON_AddStringToObject(e, "value", value);
    cJSON_AddItemToArray(arr, e);
    char *text = cJSON_PrintUnformatted(arr);
    cJSON_Delete(arr);
    volux_context_clear_error(ctx);
    volux_status st = volux_scene_doc_edit_json(doc, text, strlen(text), NULL);
    free(text);
    msg[0] = 0;
    if (st) {
        const char *m = volux_context_error(ctx);
        size_t o = 0, vl = strlen(value);
        while (*m && o + 4 < n) {
            if (vl && !strncmp(m, value, vl)) {
                memcpy(msg + o, "<V>", 3), o += 3, m += vl;
            } else msg[o++] = *m++;
        }
        msg[o] = 0;
    }
    volux_context_clear_error(ctx);
    return st;
}

static void attack_key(volux_scene_doc *doc, volux_context *ctx, const char *key, const char *orig, int *attacked) {
    const char *dot = strrchr(orig, '.');
    const char *ext = dot && !strchr(dot, '/') ? dot : "";
    const char *pat = strstr(orig, "%d") ? "%d" : "";
    char unavailable[7][PATH_MAX * 2];
    snprintf(unavailable[0], sizeof unavailable[0], "%s/secret%s%s", g_out, pat, ext);
    snprintf(unavailable[1], sizeof unavailable[1], "../outside/secret%s%s", pat, ext);
    snprintf(unavailable[2], sizeof unavailable[2], "link%s%s", pat, ext);
    snprintf(unavailable[3], sizeof unavailable[3], "dirlink/secret%s%s", pat, ext);
    snprintf(unavailable[4], sizeof unavailable[4], "nothere%s%s", pat, ext);
    snprintf(unavailable[5], sizeof unavailable[5], "%s/nothere%s%s", g_out, pat, ext);
    snprintf(unavailable[6], sizeof unavailable[6], "/proc/self/environ");
    char msg[7][1024], what[256];
    volux_status st[7];
    for (int v = 0; v < 7; v++) {
        st[v] = edit_to(doc, ctx, key, unavailable[v], msg[v], sizeof msg[v]);
        if (outside_opens(what, sizeof what))
            fail_msg("%s = \"%s\" opened outside/%s (status %d: %s)", key, unavailable[v], what, st[v], msg[v]);
        if (st[v] == VOLUX_OK) { /* a key that is not a file name: put it back */
            char back[1024];
            assert_int_equal(edit_to(doc, ctx, key, orig, back, sizeof back), VOLUX_OK);
            assert_int_equal(outside_opens(what, sizeof what), 0);
        }
    }
    /* A file key is one that refuses a missing name inside the root as not
     * available; for it every unavailable name gets the same answer. For
     * other keys, names of the same form must too (an existing and a
     * missing file outside; a link out and a missing name inside). */
    const char *tail = strstr(msg[4], "not available in the data root");
    int file_key = st[4] != VOLUX_OK && tail;
    /* the root is not named (`volux view`'s is a private temporary folder) */
    if (tail && strchr(tail, '/')) fail_msg("%s: the message names a folder: %s", key, msg[4]);
    static const int pairs[][2] = {{0, 5}, {2, 4}};
    for (int v = 1; v < 7; v++) {
        int compared = file_key;
        for (size_t p = 0; p < sizeof pairs / sizeof *pairs; p++) compared |= pairs[p][1] == v;
        int ref = file_key ? 0 : v == 5 ? 0 : 2;
        if (compared && (st[v] != st[ref] || strcmp(msg[v], msg[ref])))
            fail_msg("%s: \"%s\" and \"%s\" get different answers, which tells what exists:\n  %d %s\n  %d %s", key,
                     unavailable[ref], unavailable[v], st[ref], msg[ref], st[v], msg[v]);
    }
    if (file_key) (*attacked)++;
    char pmsg[1024];
    /* Headers inside the root whose data lies outside: readable names, so
     * their answer may differ, but nothing outside is opened. */
    static const char *const peeks[] = {"peek.nhdr", "peekabs.nhdr"};
    for (int v = 0; v < 2; v++) {
        volux_status ps = edit_to(doc, ctx, key, peeks[v], pmsg, sizeof pmsg);
        if (outside_opens(what, sizeof what))
            fail_msg("%s = \"%s\" opened outside/%s (status %d: %s)", key, peeks[v], what, ps, pmsg);
        if (ps == VOLUX_OK) assert_int_equal(edit_to(doc, ctx, key, orig, pmsg, sizeof pmsg), VOLUX_OK);
    }
}

static void test_no_key_reads_outside_the_root(void **state) {
    (void)state;
    setup_dirs();
    char what[256];
    /* The watch works: a direct open is seen. */
    char probe[PATH_MAX * 2];
    snprintf(probe, sizeof probe, "%s/secret.json", g_out);
    FILE *f = fopen(probe, "rb");
    assert_non_null(f);
    fclose(f);
    assert_true(outside_opens(what, sizeof what) > 0);

    volux_context *ctx = tu_context(1);
    int file_keys = 0, keys = 0;
    for (size_t s = 0; s < sizeof base_scenes / sizeof *base_scenes; s++) {
        char name[64];
        snprintf(name, sizeof name, "scene%zu.json", s);
        put_text(g_root, name, base_scenes[s]);
        char path[PATH_MAX * 2];
        snprintf(path, sizeof path, "%s/%s", g_root, name);
        volux_scene_doc_options o = {.data_root = g_root};
        volux_scene_doc *doc = NULL;
        if (volux_scene_doc_load(ctx, path, NULL, 0, &o, &doc))
            fail_msg("base scene %zu: %s", s, volux_context_error(ctx));
        assert_int_equal(outside_opens(what, sizeof what), 0);
        char *json = NULL;
        size_t len = 0;
        assert_int_equal(volux_scene_doc_json(doc, 0, &json, &len), VOLUX_OK);
        cJSON *tree = cJSON_Parse(json);
        assert_non_null(tree);
        volux_scene_doc_json_free(doc, json, len);
        key_list k = {.n = 0};
        collect_strings(tree, "", &k);
        cJSON_Delete(tree);
        /* Every file parameter any technique declares. */
        for (int t = 0; volux_technique_info_at(t); t++) {
            const volux_technique_info *info = volux_technique_info_at(t);
            for (const volux_param_info *p = info->params; p && p->name; p++) {
                if (p->kind != VOLUX_PARAM_FILE) continue;
                char key[128];
                snprintf(key, sizeof key, "techniques.%s.%s", info->name, p->name);
                char msg[512];
                /* The key is live: a file inside the root is accepted. */
                if (edit_to(doc, ctx, key, "table.bin", msg, sizeof msg))
                    fail_msg("%s = table.bin (inside the root): %s", key, msg);
                add_key(&k, key, "table.bin");
            }
        }
        for (int i = 0; i < k.n; i++) attack_key(doc, ctx, k.key[i], k.value[i], &file_keys);
        keys += k.n;
        volux_scene_doc_destroy(doc);
    }
    print_message("%d string keys attacked, %d of them file names (all refused alike)\n", keys, file_keys);
    /* The scenes name a volume file, time-sequence files and a pattern, a TF
     * file, a preset, a MERL file, an environment map and a table file. */
    assert_true(file_keys >= 8);
    volux_context_destroy(ctx);
    close(g_watch);
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_no_key_reads_outside_the_root),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
