/*
 * bench/bench_guided.c — measurements of `guided` that `volux bench` does
 * not make (docs/techniques/guided.md; bench/guided/run.sh drives it).
 * Public API only.
 *
 *   bench_guided visibility SCENE [--set path=value]... [--repeat N] [--label L]
 *       Time to recompute the whole visibility grid (the update after a
 *       `tf` edit, which invalidates every direction), median of N, wall
 *       and CPU (all threads) milliseconds, and the technique's memory.
 *
 *   bench_guided lazy SCENE [--set ...]... [--steps N] [--spp S]
 *                [--reference PATTERN] [--label L]
 *       Plays a time-varying volume forward from step 0: per step the
 *       update time (the lazy visibility update of the scene's policy), the
 *       render time of S samples per pixel, and with a reference (a printf
 *       pattern such as ref_%04d.pfm, e.g. written by `volux render
 *       --all-steps`) the image's mean squared error. Also the time of a
 *       full update for scale.
 *
 *   bench_guided converge SCENE --reference IMG [--set ...]... [--spp S] [--seeds K] [--label L]
 *       Convergence against a reference image: after 1, 2, 4, ..., S samples
 *       per pixel (one framebuffer, accumulated), the mean squared error and
 *       the cumulative render time, wall and CPU (all threads: the fair
 *       clock on a shared machine), excluding the technique's preparation,
 *       which is reported once (prepare_ms, prepare_cpu_ms); --seeds K
 *       repeats it with seeds seed … seed+K−1 on the same instance. Works for any
 *       technique (render.technique).
 *
 * Output: one JSON object per line (DESIGN §4 bench format plus fields).
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "volux/volux.h"

#define MAX_SET 32

static double now_ms(clockid_t clock) {
    struct timespec ts;
    clock_gettime(clock, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

static int cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

static double median(double *v, int n) {
    qsort(v, (size_t)n, sizeof *v, cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

static int die(volux_context *ctx, const char *what) {
    fprintf(stderr, "bench_guided: %s: %s\n", what, ctx ? volux_context_error(ctx) : "");
    return 1;
}

typedef struct opts {
    const char *mode, *scene, *label, *reference;
    const char *sets[MAX_SET];
    int n_sets, repeat, steps, spp, seeds;
} opts;

static void emit(const opts *o, const volux_scene *s, const char *metric, double value, const char *unit,
                 const char *extra) {
    const volux_render_settings *rs = volux_scene_render(s);
    printf("{\"scene\":\"%s\",\"technique\":\"guided\",\"label\":\"%s\",\"metric\":\"%s\",\"value\":%.6g,\"unit\":\"%s\","
           "\"threads\":%d,\"width\":%d,\"height\":%d%s%s}\n",
           o->scene, o->label, metric, value, unit, rs->threads, rs->width, rs->height, extra ? "," : "",
           extra ? extra : "");
    fflush(stdout);
}

/* Full recompute of the visibility grid: update after a `tf` edit. The
 * technique is created with strategy `environment`, which never reads the
 * grid and so leaves it unswept (guided.c), and the scene's strategy is
 * restored before the first timed update: the grid is computed once per
 * repeat instead of once more at creation (brute force takes minutes). */
static int visibility(volux_context *ctx, volux_scene *s, const opts *o) {
    volux_technique *t;
    char strategy[64];
    snprintf(strategy, sizeof strategy, "%s", volux_scene_param_string(s, "guided", "strategy", "two_step"));
    if (volux_scene_set_param(s, "guided", "strategy", 0.0, "environment")) return die(ctx, "strategy");
    double t0 = now_ms(CLOCK_MONOTONIC), tc0 = now_ms(CLOCK_PROCESS_CPUTIME_ID);
    if (volux_technique_create(ctx, "guided", s, &t)) return die(ctx, "create");
    double prepare = now_ms(CLOCK_MONOTONIC) - t0, prepare_cpu = now_ms(CLOCK_PROCESS_CPUTIME_ID) - tc0;
    if (volux_scene_set_param(s, "guided", "strategy", 0.0, strategy)) return die(ctx, "strategy");
    double wall[64], cpu[64];
    const volux_edit *tf = volux_edit_find("tf");
    for (int k = 0; k < o->repeat; k++) {
        if (volux_edit_apply(tf, s, k)) return die(ctx, "tf edit");
        double w0 = now_ms(CLOCK_MONOTONIC), c0 = now_ms(CLOCK_PROCESS_CPUTIME_ID);
        if (volux_technique_update(t, s, NULL)) return die(ctx, "update");
        wall[k] = now_ms(CLOCK_MONOTONIC) - w0;
        cpu[k] = now_ms(CLOCK_PROCESS_CPUTIME_ID) - c0;
    }
    emit(o, s, "prepare_ms", prepare, "ms", NULL);
    emit(o, s, "prepare_cpu_ms", prepare_cpu, "ms", NULL);
    emit(o, s, "visibility_ms", median(wall, o->repeat), "ms", NULL);
    emit(o, s, "visibility_cpu_ms", median(cpu, o->repeat), "ms", NULL);
    emit(o, s, "memory_bytes", (double)volux_technique_memory_bytes(t), "bytes", NULL);
    volux_technique_destroy(t);
    return 0;
}

static double image_mse(const volux_image *a, const volux_image *b) {
    double sum = 0.0;
    size_t n = 3 * (size_t)a->width * (size_t)a->height;
    for (size_t i = 0; i < n; i++) {
        double d = (double)a->rgb[i] - (double)b->rgb[i];
        sum += d * d;
    }
    return sum / (double)n;
}

/* Plays the sequence forward: update, render, compare per step. */
static int lazy(volux_context *ctx, volux_scene *s, const opts *o) {
    int steps = o->steps < volux_scene_time_steps(s) ? o->steps : volux_scene_time_steps(s);
    if (volux_scene_set_time_step(s, 0)) return die(ctx, "time step 0");
    volux_technique *t;
    if (volux_technique_create(ctx, "guided", s, &t)) return die(ctx, "create");
    volux_framebuffer *fb;
    const volux_render_settings *rs = volux_scene_render(s);
    if (volux_framebuffer_create(ctx, rs->width, rs->height, &fb)) return die(ctx, "framebuffer");
    double upd[4096], upd_cpu[4096];
    int n_upd = 0;
    for (int step = 0; step < steps; step++) {
        double w0 = now_ms(CLOCK_MONOTONIC), c0 = now_ms(CLOCK_PROCESS_CPUTIME_ID);
        if (volux_scene_set_time_step(s, step)) return die(ctx, "time step");
        double load_ms = now_ms(CLOCK_MONOTONIC) - w0;
        w0 = now_ms(CLOCK_MONOTONIC), c0 = now_ms(CLOCK_PROCESS_CPUTIME_ID);
        if (volux_technique_update(t, s, NULL)) return die(ctx, "update");
        double update_ms = now_ms(CLOCK_MONOTONIC) - w0, update_cpu = now_ms(CLOCK_PROCESS_CPUTIME_ID) - c0;
        if (step > 0 && n_upd < 4096) upd[n_upd] = update_ms, upd_cpu[n_upd++] = update_cpu;
        volux_render_limits lim = {(uint32_t)o->spp, 0.0, 0.0};
        volux_render_report rep;
        volux_framebuffer_reset(fb);
        if (volux_render(t, s, fb, &lim, &rep)) return die(ctx, "render");
        double mse = -1.0;
        if (o->reference) {
            char path[4096];
            snprintf(path, sizeof path, o->reference, step);
            volux_image ref = {0}, img = {0};
            if (volux_image_load(ctx, path, &ref)) return die(ctx, path);
            if (volux_framebuffer_resolve(fb, &img)) return die(ctx, "resolve");
            mse = image_mse(&img, &ref);
            volux_image_free(ctx, &img);
            volux_image_free(ctx, &ref);
        }
        char extra[256];
        snprintf(extra, sizeof extra,
                 "\"step\":%d,\"load_ms\":%.3f,\"update_ms\":%.3f,\"update_cpu_ms\":%.3f,\"render_ms\":%.3f,"
                 "\"render_cpu_ms\":%.3f,\"spp\":%u,\"mse\":%.6g",
                 step, load_ms, update_ms, update_cpu, rep.ms, rep.cpu_ms, rep.spp, mse);
        emit(o, s, "lazy.step", mse, "", extra);
    }
    if (n_upd) {
        double cpu_copy[4096];
        memcpy(cpu_copy, upd_cpu, sizeof(double) * (size_t)n_upd);
        emit(o, s, "update_ms.time_step", median(upd, n_upd), "ms", NULL);
        emit(o, s, "update_cpu_ms.time_step", median(cpu_copy, n_upd), "ms", NULL);
    }
    /* a full update for scale: a `tf` edit invalidates every direction,
     * each on its source step (so this also loads steps) */
    const volux_edit *tf = volux_edit_find("tf");
    double full[8], full_cpu[8];
    for (int k = 0; k < 3; k++) {
        if (volux_edit_apply(tf, s, k)) return die(ctx, "tf edit");
        double w0 = now_ms(CLOCK_MONOTONIC), c0 = now_ms(CLOCK_PROCESS_CPUTIME_ID);
        if (volux_technique_update(t, s, NULL)) return die(ctx, "update");
        full[k] = now_ms(CLOCK_MONOTONIC) - w0;
        full_cpu[k] = now_ms(CLOCK_PROCESS_CPUTIME_ID) - c0;
    }
    emit(o, s, "update_ms.full", median(full, 3), "ms", NULL);
    emit(o, s, "update_cpu_ms.full", median(full_cpu, 3), "ms", NULL);
    volux_framebuffer_destroy(fb);
    volux_technique_destroy(t);
    return 0;
}

/* MSE after 1, 2, 4, ... spp with cumulative wall and CPU time. */
static int converge(volux_context *ctx, volux_scene *s, const opts *o) {
    if (!o->reference) return die(NULL, "converge needs --reference");
    volux_image ref = {0};
    if (volux_image_load(ctx, o->reference, &ref)) return die(ctx, o->reference);
    const volux_render_settings *rs = volux_scene_render(s);
    volux_technique *t;
    double w0 = now_ms(CLOCK_MONOTONIC), c0 = now_ms(CLOCK_PROCESS_CPUTIME_ID);
    if (volux_technique_create(ctx, rs->technique, s, &t)) return die(ctx, "create");
    char extra[320];
    snprintf(extra, sizeof extra, "\"render_technique\":\"%s\"", rs->technique);
    emit(o, s, "prepare_ms", now_ms(CLOCK_MONOTONIC) - w0, "ms", extra);
    emit(o, s, "prepare_cpu_ms", now_ms(CLOCK_PROCESS_CPUTIME_ID) - c0, "ms", extra);
    volux_framebuffer *fb;
    if (volux_framebuffer_create(ctx, rs->width, rs->height, &fb)) return die(ctx, "framebuffer");
    /* --seeds K: K independent runs on the same instance, seeds seed,
     * seed+1, ... (a seed edit changes no cache: the visibility grid is
     * built once for all of them) */
    uint64_t seed0 = rs->seed;
    for (int k = 0; k < o->seeds; k++) {
        if (k > 0) {
            volux_render_settings r = *volux_scene_render(s);
            r.seed = seed0 + (uint64_t)k;
            if (volux_scene_set_render(s, &r)) return die(ctx, "seed");
            volux_framebuffer_reset(fb);
        }
        double wall = 0.0, cpu = 0.0;
        for (int spp = 1; spp <= o->spp; spp *= 2) {
            volux_render_limits lim = {(uint32_t)spp, 0.0, 0.0};
            volux_render_report rep;
            double a = now_ms(CLOCK_MONOTONIC), b = now_ms(CLOCK_PROCESS_CPUTIME_ID);
            if (volux_render(t, s, fb, &lim, &rep)) return die(ctx, "render");
            wall += now_ms(CLOCK_MONOTONIC) - a;
            cpu += now_ms(CLOCK_PROCESS_CPUTIME_ID) - b;
            volux_image img = {0};
            if (volux_framebuffer_resolve(fb, &img)) return die(ctx, "resolve");
            double mse = image_mse(&img, &ref);
            volux_image_free(ctx, &img);
            snprintf(extra, sizeof extra,
                     "\"render_technique\":\"%s\",\"spp\":%d,\"ms\":%.3f,\"cpu_ms\":%.3f,\"mse\":%.6g,\"seed\":%llu",
                     rs->technique, spp, wall, cpu, mse, (unsigned long long)volux_scene_render(s)->seed);
            emit(o, s, "convergence.mse", mse, "", extra);
        }
    }
    volux_framebuffer_destroy(fb);
    volux_technique_destroy(t);
    volux_image_free(ctx, &ref);
    return 0;
}

int main(int argc, char **argv) {
    opts o = {0};
    o.repeat = 3;
    o.steps = 1 << 30;
    o.spp = 4;
    o.seeds = 1;
    o.label = "";
    if (argc < 3) {
        fprintf(stderr, "usage: bench_guided visibility|lazy|converge SCENE [--set path=value]... [--repeat N] [--steps N] "
                        "[--spp S] [--seeds K] [--reference PATTERN] [--label L]\n");
        return 2;
    }
    o.mode = argv[1];
    o.scene = argv[2];
    for (int i = 3; i < argc; i++) {
        if (!strcmp(argv[i], "--set") && i + 1 < argc && o.n_sets < MAX_SET) o.sets[o.n_sets++] = argv[++i];
        else if (!strcmp(argv[i], "--repeat") && i + 1 < argc) o.repeat = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--steps") && i + 1 < argc) o.steps = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--spp") && i + 1 < argc) o.spp = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--seeds") && i + 1 < argc) o.seeds = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--reference") && i + 1 < argc) o.reference = argv[++i];
        else if (!strcmp(argv[i], "--label") && i + 1 < argc) o.label = argv[++i];
        else {
            fprintf(stderr, "bench_guided: unknown option %s\n", argv[i]);
            return 2;
        }
    }
    if (o.repeat < 1 || o.repeat > 64) o.repeat = 3;
    if (o.seeds < 1 || o.seeds > 64) o.seeds = 1;
    volux_context *ctx;
    if (volux_context_create(NULL, &ctx)) return 1;
    volux_scene *s;
    if (volux_scene_load(ctx, o.scene, o.sets, o.n_sets, &s)) return die(ctx, o.scene);
    if (volux_scene_render(s)->threads > 0) volux_context_set_threads(ctx, volux_scene_render(s)->threads);
    int rc = !strcmp(o.mode, "visibility") ? visibility(ctx, s, &o)
             : !strcmp(o.mode, "lazy")     ? lazy(ctx, s, &o)
             : !strcmp(o.mode, "converge") ? converge(ctx, s, &o)
                                           : 2;
    volux_scene_destroy(s);
    volux_context_destroy(ctx);
    return rc;
}
