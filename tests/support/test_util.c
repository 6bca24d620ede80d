/* tests/support/test_util.c — see test_util.h. */
#include "test_util.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

volux_context *tu_context(int threads) {
    volux_context_desc d = {0};
    d.threads = threads;
    volux_context *ctx = NULL;
    assert_int_equal(volux_context_create(&d, &ctx), VOLUX_OK);
    return ctx;
}

static const char *temp_dir(void) {
    static char dir[256];
    if (!dir[0]) {
        const char *base = getenv("TMPDIR");
        snprintf(dir, sizeof dir, "%s/volux-test-%d", base && *base ? base : "/tmp", (int)getpid());
        mkdir(dir, 0700);
    }
    return dir;
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
