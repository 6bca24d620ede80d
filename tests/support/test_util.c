/* tests/support/test_util.c — see test_util.h. */
#define _XOPEN_SOURCE 700 /* nftw, mkdtemp */
#include "test_util.h"

#include <ftw.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

volux_context *tu_context(int threads) {
    volux_context_desc d = {0};
    d.threads = threads;
    d.cache_dir = tu_temp_path("cache");
    volux_context *ctx = NULL;
    assert_int_equal(volux_context_create(&d, &ctx), VOLUX_OK);
    return ctx;
}

/* The per-process temp folder: a fresh mkdtemp folder, removed with its
 * contents when the test process exits. (A folder named by the pid alone
 * collided with the leftovers of earlier runs once pids wrapped: a test
 * that makes a symbolic link failed with EEXIST.) Only the process that
 * made it removes it, not a forked child that exits. */
static char temp_folder[256];
static pid_t temp_owner;

static int remove_entry(const char *path, const struct stat *sb, int flag, struct FTW *ftw) {
    (void)sb, (void)flag, (void)ftw;
    remove(path);
    return 0;
}

static void remove_temp_folder(void) {
    if (getpid() == temp_owner) nftw(temp_folder, remove_entry, 16, FTW_DEPTH | FTW_PHYS);
}

static const char *temp_dir(void) {
    if (!temp_folder[0]) {
        const char *base = getenv("TMPDIR");
        snprintf(temp_folder, sizeof temp_folder, "%s/volux-test-XXXXXX", base && *base ? base : "/tmp");
        if (!mkdtemp(temp_folder)) {
            perror("volux tests: mkdtemp");
            abort();
        }
        temp_owner = getpid();
        atexit(remove_temp_folder);
    }
    return temp_folder;
}

void tu_collect_messages(void *user, volux_message_level level, const char *text) {
    tu_messages *m = user;
    if (level == VOLUX_MESSAGE_WARNING)
        m->warnings++;
    else
        m->notes++;
    snprintf(m->last, sizeof m->last, "%s", text);
}

const char *tu_temp_path(const char *name) {
    static char paths[16][512];
    static int next;
    char *p = paths[next++ % 16];
    snprintf(p, 512, "%s/%s", temp_dir(), name);
    return p;
}

const char *tu_write_file(const char *name, const void *data, size_t size) {
    const char *path = tu_temp_path(name);
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    if (size) assert_int_equal(fwrite(data, 1, size, f), size);
    fclose(f);
    return path;
}

int tu_run_cli(const char *args, const char **err) {
    static char buf[8192];
    const char *errpath = tu_temp_path("cli.err");
    char cmd[4096];
    snprintf(cmd, sizeof cmd, "%s %s 2>%s >/dev/null", VOLUX_CLI, args, errpath);
    int rc = system(cmd);
    buf[0] = 0;
    FILE *f = fopen(errpath, "rb");
    if (f) {
        size_t n = fread(buf, 1, sizeof buf - 1, f);
        buf[n] = 0;
        fclose(f);
    }
    if (err) *err = buf;
    return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

volux_scene *tu_scene(volux_context *ctx, const char *json) {
    volux_scene *s = NULL;
    volux_status st = volux_scene_load_string(ctx, json, tu_temp_path(""), "test-scene", NULL, 0, &s);
    if (st) fail_msg("scene: %s", volux_context_error(ctx));
    return s;
}

volux_image tu_render_with(volux_context *ctx, volux_scene *s, volux_technique *t) {
    const volux_render_settings *rs = volux_scene_render(s);
    volux_framebuffer *fb = NULL;
    volux_image img = {0};
    assert_int_equal(volux_framebuffer_create(ctx, rs->width, rs->height, &fb), VOLUX_OK);
    volux_status st = volux_render(t, s, fb, NULL, NULL);
    if (st) fail_msg("render: %s", volux_context_error(ctx));
    assert_int_equal(volux_framebuffer_resolve(fb, &img), VOLUX_OK);
    volux_framebuffer_destroy(fb);
    return img;
}

volux_image tu_render(volux_context *ctx, volux_scene *s, const char *technique) {
    volux_technique *t = NULL;
    volux_status st = volux_technique_create(ctx, technique ? technique : volux_scene_render(s)->technique, s, &t);
    if (st) fail_msg("technique: %s", volux_context_error(ctx));
    volux_image img = tu_render_with(ctx, s, t);
    volux_technique_destroy(t);
    return img;
}

double tu_mean_luminance(const volux_image *img) {
    double s = 0.0;
    size_t n = (size_t)img->width * (size_t)img->height;
    for (size_t i = 0; i < n; i++)
        s += 0.2126 * img->rgb[3 * i] + 0.7152 * img->rgb[3 * i + 1] + 0.0722 * img->rgb[3 * i + 2];
    return s / (double)n;
}

double tu_max_abs_diff(const volux_image *a, const volux_image *b) {
    assert_int_equal(a->width, b->width);
    assert_int_equal(a->height, b->height);
    double m = 0.0;
    for (size_t i = 0; i < (size_t)a->width * (size_t)a->height * 3; i++) {
        double d = fabs((double)a->rgb[i] - (double)b->rgb[i]);
        if (d > m || d != d) m = d != d ? INFINITY : d;
    }
    return m;
}

float tu_pixel(const volux_image *img, int x, int y, int c) {
    return img->rgb[3 * ((size_t)y * (size_t)img->width + (size_t)x) + (size_t)c];
}
