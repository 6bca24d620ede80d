/*
 * tools/viewer/serve.c — `volux serve SCENE.json [...]`: loads the scene as
 * a document (volux_scene_doc), starts the render thread and the HTTP
 * server, prints the URL and runs until SIGINT/SIGTERM.
 */
#include <cjson/cJSON.h>
#include <arpa/inet.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "tools/cli/scene_args.h"
#include "viewer.h"

/* ------------------------------------------------------------------ stop */

/* After SIGINT/SIGTERM the server stops in order (the render thread's
 * work is cancelled through the progress callback, connections end, the
 * scene is freed) and exits 0. Should that not be over STOP_GRACE_MS after
 * the signal (a step that never asks for cancellation), or should a second
 * signal come, the process ends at once with STOP_FORCED_STATUS, after
 * removing `volux view`'s temporary scene: SIGTERM always ends the server
 * within 2 s (docs/VIEWER.md). */
#define STOP_GRACE_MS 1500
#define STOP_FORCED_STATUS 1

static const char *exit_file, *exit_dir;
static atomic_int stop_done;

void viewer_exit_cleanup(const char *file, const char *dir) {
    exit_file = file;
    exit_dir = dir;
}

static void *stop_watchdog(void *arg) {
    const sigset_t *set = arg;
    struct timespec slice = {0, 50 * 1000 * 1000};
    const char *why = "did not end within 1.5 s";
    for (int waited = 0; waited < STOP_GRACE_MS; waited += 50) {
        if (atomic_load(&stop_done)) return NULL;
        if (sigtimedwait(set, NULL, &slice) > 0) {
            why = "a second signal";
            break;
        }
    }
    if (atomic_load(&stop_done)) return NULL;
    static const char head[] = "volux serve: stopping at once (";
    (void)!write(2, head, sizeof head - 1);
    (void)!write(2, why, strlen(why));
    (void)!write(2, ")\n", 2);
    if (exit_file) unlink(exit_file);
    if (exit_dir) rmdir(exit_dir);
    _exit(STOP_FORCED_STATUS);
}

static void usage(FILE *f) {
    fprintf(f,
            "usage: volux serve SCENE.json [--port P] [--bind ADDR] [--token T] [--data-root DIR]\n"
            "                   [--preview N] [--preview-budget MS] [--preview-step K] [--idle-ms MS]\n"
            "                   [--max-image N]\n"
            "                   [--jpeg-quality Q] [--preview-png] [--no-denoise] [--no-auto-exposure]\n"
            "                   [--max-connections N] [--timeout S] [--max-mb MB] [--quiet]\n"
            "                   [--technique T] [--spp N] [--width W] [--height H] [--threads N]\n"
            "                   [--set dotted.path=JSON-value]...\n"
            "Serves an interactive viewer of the scene at http://ADDR:P/ (default 127.0.0.1:8080):\n"
            "progressive frames, live edits (the JSON API under /api/, docs/VIEWER.md).\n"
            "  --bind ADDR        listen address (default 127.0.0.1; others warn: no authentication\n"
            "                     unless --token is given)\n"
            "  --token T          every request needs the token (or set VOLUX_SERVE_TOKEN)\n"
            "  --data-root DIR    files an edit names must lie in DIR (default: the scene's folder)\n"
            "  --preview N        longest side of the preview shown while editing (default 256)\n"
            "  --preview-budget MS  the first frame after an edit is made smaller when the technique's\n"
            "                     measured cost says the --preview size would arrive later than MS;\n"
            "                     the --preview size follows at once (default 100; 0 = always --preview)\n"
            "  --preview-step K   before making it smaller, that first frame may march at up to K times\n"
            "                     render.step (1..8, default 4; 1 = never); refinement and the final\n"
            "                     frame always use render.step\n"
            "  --idle-ms MS       quiet time before refinement starts (default 100)\n"
            "  --no-denoise       show pathtrace, guided and manylights frames raw (by default they\n"
            "                     are denoised, blended back to the raw image as samples accumulate)\n"
            "  --no-auto-exposure keep render.exposure as the scene says on a technique switch (by\n"
            "                     default it is set from the new technique's first frame, and the\n"
            "                     quick look's from its first frame, so switching keeps the brightness)\n"
            "  --max-image N      largest render.width/height an edit may set (default 4096)\n"
            "  --port 0           any free port (the URL printed says which)\n");
}

/* The checks io cannot make (it cannot see the technique registry): the
 * messages are those `volux render` prints for the same scene. */
static volux_status validate(void *user, volux_context *ctx, const volux_scene *cand) {
    viewer *v = user;
    const volux_render_settings *rs = volux_scene_render(cand);
    if (!volux_technique_info_find(rs->technique)) {
        char names[256];
        cli_technique_names(names, sizeof names);
        const char *guess = volux_technique_closest(rs->technique);
        return volux_context_set_error(ctx, VOLUX_ERR_INVALID,
                                       "render.technique: unknown technique '%s'%s%s%s (techniques: %s)",
                                       rs->technique, guess ? "; did you mean '" : "", guess ? guess : "",
                                       guess ? "'?" : "", names);
    }
    volux_status st = volux_technique_validate_params(ctx, cand);
    if (st) return st;
    if (rs->width > v->opt.max_image || rs->height > v->opt.max_image)
        return volux_context_set_error(ctx, VOLUX_ERR_LIMIT,
                                       "render.width/height: %dx%d is larger than this viewer allows (--max-image %d)",
                                       rs->width, rs->height, v->opt.max_image);
    return VOLUX_OK;
}

static int loopback(const char *addr) {
    return !strncmp(addr, "127.", 4) || !strcmp(addr, "::1") || !strcmp(addr, "localhost");
}

int cli_serve(int argc, char **argv) { return cli_serve_named(argc, argv, NULL); }

int cli_serve_named(int argc, char **argv, const char *display_name) {
    cli_scene_args args = {0};
    viewer *v = calloc(1, sizeof *v);
    if (!v) return CLI_FAIL;
    viewer_options *o = &v->opt;
    o->bind = "127.0.0.1";
    o->port = 8080;
    o->preview_max = 256;
    o->idle_ms = 100;
    o->preview_budget_ms = 100;
    o->preview_step_max = 4;
    o->max_image = 4096;
    o->jpeg_quality = 85;
    o->max_connections = 64;
    o->timeout_s = 10;
    o->auto_exposure = 1;
    /* the quick look's scene was written for it: its exposure is set from
     * the first frame too (a scene file's exposure is its author's) */
    o->auto_exposure_start = display_name != NULL;
    o->token = getenv("VOLUX_SERVE_TOKEN");
    if (o->token && !*o->token) o->token = NULL;
    long max_mb = 0; /* 0: the context's default limit, 80 % of physical memory */
    int max_mb_given = 0;
    int rc = CLI_USAGE;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        long n;
        double d;
        if (!strcmp(a, "-h") || !strcmp(a, "--help")) {
            usage(stdout);
            free(v);
            return CLI_OK;
        }
        if (!strcmp(a, "--quiet")) {
            o->quiet = 1;
            continue;
        }
        if (!strcmp(a, "--no-denoise")) {
            o->no_denoise = 1;
            continue;
        }
        if (!strcmp(a, "--no-auto-exposure")) {
            o->auto_exposure = 0;
            continue;
        }
        if (!strcmp(a, "--preview-png")) {
            o->preview_png = 1;
            continue;
        }
        static const char *const valued[] = {"--port",    "--bind",        "--token",           "--data-root",
                                             "--preview", "--idle-ms",     "--max-image",       "--jpeg-quality",
                                             "--timeout", "--max-mb",      "--max-connections", "--preview-budget", "--preview-step",
                                             NULL};
        int is_valued = 0;
        for (int k = 0; valued[k]; k++) is_valued |= !strcmp(a, valued[k]);
        if (is_valued) {
            if (i + 1 >= argc) {
                cli_eprintf("volux serve: %s needs a value\n", a);
                goto out;
            }
            const char *val = argv[++i];
            if (!strcmp(a, "--port")) {
                if (!cli_parse_int("serve", a, val, 0, 65535, &n)) goto out;
                o->port = (int)n;
            } else if (!strcmp(a, "--bind")) {
                unsigned char probe[16];
                if (strcmp(val, "localhost") && inet_pton(AF_INET, val, probe) != 1 &&
                    inet_pton(AF_INET6, val, probe) != 1) {
                    cli_eprintf("volux serve: --bind %s: expected an IPv4 or IPv6 address\n", val);
                    goto out;
                }
                o->bind = val;
            } else if (!strcmp(a, "--token")) {
                if (!*val) {
                    fprintf(stderr, "volux serve: --token: empty token\n");
                    goto out;
                }
                o->token = val;
            } else if (!strcmp(a, "--data-root")) {
                o->data_root = val;
            } else if (!strcmp(a, "--preview")) {
                if (!cli_parse_int("serve", a, val, 16, 4096, &n)) goto out;
                o->preview_max = (int)n;
            } else if (!strcmp(a, "--idle-ms")) {
                if (!cli_parse_double("serve", a, val, &d)) goto out;
                if (!(d >= 0 && d <= 60000)) {
                    cli_eprintf("volux serve: --idle-ms: expected 0..60000, got %s\n", val);
                    goto out;
                }
                o->idle_ms = d;
            } else if (!strcmp(a, "--preview-budget")) {
                if (!cli_parse_double("serve", a, val, &d)) goto out;
                if (!(d >= 0 && d <= 60000)) {
                    cli_eprintf("volux serve: --preview-budget: expected 0..60000, got %s\n", val);
                    goto out;
                }
                o->preview_budget_ms = d;
            } else if (!strcmp(a, "--preview-step")) {
                if (!cli_parse_double("serve", a, val, &d)) goto out;
                if (!(d >= 1 && d <= 8)) {
                    cli_eprintf("volux serve: --preview-step: expected 1..8, got %s\n", val);
                    goto out;
                }
                o->preview_step_max = d;
            } else if (!strcmp(a, "--max-image")) {
                if (!cli_parse_int("serve", a, val, 16, VOLUX_MAX_IMAGE_DIM, &n)) goto out;
                o->max_image = (int)n;
            } else if (!strcmp(a, "--jpeg-quality")) {
                if (!cli_parse_int("serve", a, val, 1, 100, &n)) goto out;
                o->jpeg_quality = (int)n;
            } else if (!strcmp(a, "--timeout")) {
                if (!cli_parse_int("serve", a, val, 1, 3600, &n)) goto out;
                o->timeout_s = (int)n;
            } else if (!strcmp(a, "--max-mb")) {
                if (!cli_parse_int("serve", a, val, 1, 1 << 20, &max_mb)) goto out;
                max_mb_given = 1;
            } else if (!strcmp(a, "--max-connections")) {
                if (!cli_parse_int("serve", a, val, 4, 1024, &n)) goto out;
                o->max_connections = (int)n;
            }
            continue;
        }
        int r = cli_scene_arg("serve", &args, argc, argv, &i);
        if (r < 0) goto out;
        if (r == 0) {
            cli_eprintf("volux serve: unknown option '%s'\n", a);
            usage(stderr);
            goto out;
        }
    }
    if (max_mb_given && args.memory_limit) {
        cli_eprintf("volux serve: --max-mb and --memory-limit set the same budget: give one\n");
        goto out;
    }
    if (!args.scene_path) {
        fprintf(stderr, "volux serve: missing SCENE.json\n");
        usage(stderr);
        goto out;
    }
    o->scene_path = args.scene_path;
    o->scene_name = display_name ? display_name : args.scene_path;
    o->overrides = args.overrides;
    o->n_overrides = args.n_overrides;

    /* Signals: every thread inherits the mask; main waits for them. A
     * client that disconnects must never kill the server (SIGPIPE). */
    signal(SIGPIPE, SIG_IGN);
    sigset_t stop;
    sigemptyset(&stop);
    sigaddset(&stop, SIGINT);
    sigaddset(&stop, SIGTERM);
    pthread_sigmask(SIG_BLOCK, &stop, NULL);

    /* One budget (issue 34 D5): --max-mb (or --memory-limit, the render
     * command's spelling) is the context's memory limit, which every
     * allocation through it is held under, and the cap on one allocation. */
    uint64_t budget = args.memory_limit ? args.memory_limit
                      : max_mb           ? (uint64_t)max_mb << 20
                                         : volux_context_default_memory_limit();
    volux_context_desc cd = {0};
    cd.max_bytes = budget < VOLUX_DEFAULT_MAX_BYTES ? budget : 0; /* 0: the library's per-allocation cap */
    if (volux_context_create(&cd, &v->ctx) || volux_context_create(&cd, &v->enc_ctx)) {
        fprintf(stderr, "volux serve: out of memory\n");
        rc = CLI_FAIL;
        goto out;
    }
    volux_context_set_memory_limit(v->ctx, budget);
    volux_context_set_memory_limit(v->enc_ctx, budget);
    pthread_mutex_init(&v->lock, NULL);
    pthread_mutex_init(&v->snap_lock, NULL);
    pthread_mutex_init(&v->frame_lock, NULL);
    pthread_cond_init(&v->work, NULL);
    pthread_cond_init(&v->turn, NULL);
    pthread_cond_init(&v->frame_cv, NULL);
    volux_scene_doc_options dopt = {o->data_root, validate, v};
    volux_status st =
        volux_scene_doc_load_named(v->ctx, o->scene_path, o->scene_name, o->overrides, o->n_overrides, &dopt, &v->doc);
    if (st) {
        rc = cli_fail("serve", v->ctx, st);
        goto out;
    }
    /* `volux view` serves from its private temporary folder (the data root
     * holds only the quick look's own scene): never show that path. */
    o->data_root_shown = display_name ? "the quick look's own files (--data-root DIR opens others)"
                                      : volux_scene_doc_data_root(v->doc);
    const volux_render_settings *rs = volux_scene_render(volux_scene_doc_scene(v->doc));
    if (rs->threads > 0) volux_context_set_threads(v->ctx, rs->threads);
    if (!viewer_snapshot(v)) {
        fprintf(stderr, "volux serve: out of memory\n");
        rc = CLI_FAIL;
        goto out;
    }
    if (!viewer_render_start(v)) {
        fprintf(stderr, "volux serve: cannot start the render thread\n");
        rc = CLI_FAIL;
        goto out_doc;
    }
    if (!viewer_http_start(v)) {
        rc = CLI_FAIL;
        goto out_render;
    }
    if (!loopback(o->bind))
        cli_eprintf(o->token ? "volux serve: listening on %s: every request needs the token\n"
                         : "volux serve: WARNING: listening on %s without authentication: anyone who can reach "
                           "this address can view the scene and make this process read files in %s; give "
                           "--token to require one\n",
                o->bind, o->data_root_shown);
    const char *host = strchr(o->bind, ':') ? NULL : o->bind;
    if (host) printf("volux serve: http://%s:%d/%s%s\n", host, v->port, o->token ? "?token=" : "",
                     o->token ? o->token : "");
    else printf("volux serve: http://[%s]:%d/%s%s\n", o->bind, v->port, o->token ? "?token=" : "",
                o->token ? o->token : "");
    if (!o->quiet)
        cli_eprintf("volux serve: %s (%s, %dx%d, %d threads); data root %s; Ctrl-C stops\n", o->scene_name,
                rs->technique, rs->width, rs->height, volux_context_threads(v->ctx), o->data_root_shown);
    fflush(stdout);
    int sig = 0;
    sigwait(&stop, &sig);
    /* the render thread's work in flight is cancelled from here on */
    atomic_store(&v->quit, 1);
    pthread_t watchdog;
    atomic_store(&stop_done, 0);
    int watching = pthread_create(&watchdog, NULL, stop_watchdog, &stop) == 0;
    if (!o->quiet) fprintf(stderr, "volux serve: stopping (%s)\n", sig == SIGINT ? "SIGINT" : "SIGTERM");
    rc = CLI_OK;
    viewer_http_stop(v);
    viewer_render_stop(v);
    atomic_store(&stop_done, 1);
    if (watching) pthread_join(watchdog, NULL);
    goto out_doc;
out_render:
    viewer_render_stop(v);
out_doc:
out:
    if (v->doc) volux_scene_doc_destroy(v->doc);
    cJSON_Delete(v->vol_info);
    free(v->scene_json);
    free(v->scene_json_abs);
    free(v->state_json);
    viewer_pixels_release(v->frame.px); /* the last reference: every connection has ended */
    volux_context_destroy(v->enc_ctx);
    volux_context_destroy(v->ctx);
    free(v);
    return rc;
}
