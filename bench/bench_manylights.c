/*
 * bench/bench_manylights.c — the TF-edit timeline of `manylights` (Weber et
 * al. 2013 §4, Fig. 6), public API only.
 *
 *   bench_manylights timeline SCENE.json [--edit KIND] [--times K] [--frames F]
 *                             [--images DIR] [--set path=value]...
 *
 * Creates the technique, renders one frame, applies the edit K times
 * (default `tf` three times: extinction × 1.25³ ≈ 2), then renders frames
 * until the update has converged or F frames; a frame is what an
 * interactive front end does: one volux_technique_refine step (from the
 * second frame on) and one volux_render call. Per frame: wall and CPU ms
 * (update or refine step + render), the pending work
 * left, and the error against a fresh create of the edited scene (rel_mse
 * as `volux compare`, and the mean relative luminance difference). Also the
 * fresh create's own time (prepare_ms, render_ms) for the "first image in
 * ≤ 1/10 of a fresh create" comparison. With --images, every frame is
 * written as DIR/frame_NNN.pfm, plus DIR/before.pfm and DIR/fresh.pfm.
 *
 * One JSON object per line.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "volux/volux.h"

#define MAX_SET 32

static double now_ms(clockid_t c) {
    struct timespec ts;
    clock_gettime(c, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

static double mean_rel_diff(const volux_image *a, const volux_image *ref) {
    size_t n = (size_t)a->width * (size_t)a->height;
    double peak = 0.0, sum = 0.0;
    long used = 0;
    for (size_t i = 0; i < n; i++) {
        const float *r = &ref->rgb[3 * i];
        double l = 0.2126 * r[0] + 0.7152 * r[1] + 0.0722 * r[2];
        if (l > peak) peak = l;
    }
    for (size_t i = 0; i < n; i++) {
        const float *r = &ref->rgb[3 * i], *x = &a->rgb[3 * i];
        double lr = 0.2126 * r[0] + 0.7152 * r[1] + 0.0722 * r[2];
        double lx = 0.2126 * x[0] + 0.7152 * x[1] + 0.0722 * x[2];
        if (lr > 1e-3 * peak) {
            sum += fabs(lx - lr) / lr;
            used++;
        }
    }
    return used ? sum / (double)used : 0.0;
}

static int fail(volux_context *ctx, const char *what) {
    fprintf(stderr, "bench_manylights: %s: %s\n", what, volux_context_error(ctx));
    return 1;
}

static int save(volux_context *ctx, const char *dir, const char *name, const volux_image *img) {
    if (!dir) return 0;
    char path[1024];
    snprintf(path, sizeof path, "%s/%s.pfm", dir, name);
    return volux_image_save(ctx, path, img, 0.0f) ? fail(ctx, path) : 0;
}

static int render_image(volux_context *ctx, volux_technique *t, volux_scene *s, volux_framebuffer *fb,
                        volux_image *out, double *ms, double *cpu) {
    double w0 = now_ms(CLOCK_MONOTONIC), c0 = now_ms(CLOCK_PROCESS_CPUTIME_ID);
    if (volux_render(t, s, fb, NULL, NULL)) return fail(ctx, "render");
    *ms = now_ms(CLOCK_MONOTONIC) - w0;
    *cpu = now_ms(CLOCK_PROCESS_CPUTIME_ID) - c0;
    return volux_framebuffer_resolve(fb, out) ? fail(ctx, "resolve") : 0;
}

int main(int argc, char **argv) {
    if (argc < 3 || strcmp(argv[1], "timeline") != 0) {
        fprintf(stderr, "usage: bench_manylights timeline SCENE.json [--edit KIND] [--times K] [--frames F] "
                        "[--images DIR] [--set path=value]...\n");
        return 2;
    }
    const char *scene_path = argv[2], *edit_name = "tf", *images = NULL;
    const char *sets[MAX_SET];
    int n_set = 0, times = 3, max_frames = 1000;
    for (int i = 3; i < argc; i++) {
        if (!strcmp(argv[i], "--edit") && i + 1 < argc) edit_name = argv[++i];
        else if (!strcmp(argv[i], "--times") && i + 1 < argc) times = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--frames") && i + 1 < argc) max_frames = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--images") && i + 1 < argc) images = argv[++i];
        else if (!strcmp(argv[i], "--set") && i + 1 < argc && n_set < MAX_SET) sets[n_set++] = argv[++i];
        else {
            fprintf(stderr, "bench_manylights: unknown argument '%s'\n", argv[i]);
            return 2;
        }
    }
    const volux_edit *edit = volux_edit_find(edit_name);
    if (!edit) {
        fprintf(stderr, "bench_manylights: unknown edit '%s'\n", edit_name);
        return 2;
    }
    volux_context_desc cd = {0};
    volux_context *ctx = NULL;
    if (volux_context_create(&cd, &ctx)) return 1;
    volux_scene *scene = NULL;
    if (volux_scene_load(ctx, scene_path, sets, n_set, &scene)) return fail(ctx, scene_path);
    const volux_render_settings *rs = volux_scene_render(scene);
    int W = rs->width, H = rs->height, threads = rs->threads > 0 ? rs->threads : volux_context_threads(ctx);
#define EMIT(metric, value, unit, extra)                                                                        \
    printf("{\"scene\":\"%s\",\"technique\":\"manylights\",\"metric\":\"%s\",\"value\":%.6g,\"unit\":\"%s\","      \
           "\"threads\":%d,\"width\":%d,\"height\":%d,\"edit\":\"%s\"%s}\n",                                    \
           scene_path, metric, (double)(value), unit, threads, W, H, edit_name, extra)

    volux_technique *t = NULL;
    volux_framebuffer *fb = NULL;
    volux_image before = {0}, ref = {0}, img = {0};
    double ms, cpu;
    if (volux_technique_create(ctx, "manylights", scene, &t)) return fail(ctx, "create");
    if (volux_framebuffer_create(ctx, W, H, &fb)) return fail(ctx, "framebuffer");
    if (render_image(ctx, t, scene, fb, &before, &ms, &cpu) || save(ctx, images, "before", &before)) return 1;
    for (int k = 0; k < times; k++)
        if (volux_edit_apply(edit, scene, 2 * k)) return fail(ctx, "edit");

    /* the fresh create of the edited scene: the reference and its cost */
    {
        volux_technique *f = NULL;
        volux_framebuffer *ffb = NULL;
        double w0 = now_ms(CLOCK_MONOTONIC), c0 = now_ms(CLOCK_PROCESS_CPUTIME_ID);
        if (volux_technique_create(ctx, "manylights", scene, &f)) return fail(ctx, "fresh create");
        double prep = now_ms(CLOCK_MONOTONIC) - w0, prep_cpu = now_ms(CLOCK_PROCESS_CPUTIME_ID) - c0;
        if (volux_framebuffer_create(ctx, W, H, &ffb)) return fail(ctx, "framebuffer");
        if (render_image(ctx, f, scene, ffb, &ref, &ms, &cpu) || save(ctx, images, "fresh", &ref)) return 1;
        char extra[96];
        snprintf(extra, sizeof extra, ",\"cpu_ms\":%.3f", prep_cpu);
        EMIT("fresh_prepare_ms", prep, "ms", extra);
        snprintf(extra, sizeof extra, ",\"cpu_ms\":%.3f", cpu);
        EMIT("fresh_render_ms", ms, "ms", extra);
        volux_framebuffer_destroy(ffb);
        volux_technique_destroy(f);
    }
    volux_image_error e0;
    if (volux_image_compare(ctx, &before, &ref, &e0)) return fail(ctx, "compare");
    {
        char extra[160];
        snprintf(extra, sizeof extra, ",\"frame\":0,\"rel_mse\":%.6g,\"mean_rel_diff\":%.6g", e0.rel_mse,
                 mean_rel_diff(&before, &ref));
        EMIT("before_edit", 0, "", extra);
    }
    for (int frame = 1; frame <= max_frames; frame++) {
        uint64_t pending_before = volux_technique_pending(t);
        /* a frame: the front end's refinement step (not before the first,
         * which shows the immediate update), then volux_render */
        double refine_ms = 0.0, refine_cpu = 0.0;
        if (frame > 1) {
            double w0 = now_ms(CLOCK_MONOTONIC), c0 = now_ms(CLOCK_PROCESS_CPUTIME_ID);
            if (volux_technique_refine(t, scene, NULL, NULL)) return fail(ctx, "refine");
            refine_ms = now_ms(CLOCK_MONOTONIC) - w0;
            refine_cpu = now_ms(CLOCK_PROCESS_CPUTIME_ID) - c0;
        }
        volux_image_free(ctx, &img);
        if (render_image(ctx, t, scene, fb, &img, &ms, &cpu)) return 1;
        ms += refine_ms;
        cpu += refine_cpu;
        volux_image_error e;
        if (volux_image_compare(ctx, &img, &ref, &e)) return fail(ctx, "compare");
        char extra[256], name[32];
        snprintf(extra, sizeof extra,
                 ",\"frame\":%d,\"cpu_ms\":%.3f,\"pending\":%llu,\"rel_mse\":%.6g,\"mean_rel_diff\":%.6g", frame,
                 cpu, (unsigned long long)volux_technique_pending(t), e.rel_mse, mean_rel_diff(&img, &ref));
        EMIT("frame_ms", ms, "ms", extra);
        snprintf(name, sizeof name, "frame_%03d", frame);
        if (save(ctx, images, name, &img)) return 1;
        fflush(stdout);
        if (pending_before == 0 && frame > 1) break; /* this frame showed the converged state */
    }
    volux_image_free(ctx, &img);
    volux_image_free(ctx, &before);
    volux_image_free(ctx, &ref);
    volux_framebuffer_destroy(fb);
    volux_technique_destroy(t);
    volux_scene_destroy(scene);
    volux_context_destroy(ctx);
    return 0;
}
