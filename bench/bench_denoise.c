/*
 * bench/bench_denoise.c — error of raw vs denoised progressive frames
 * against a converged reference, and the denoiser's time (issue 33).
 * Public API only.
 *
 *   bench_denoise SCENE.json [--size N] [--ref-spp N] [--spps 1,4,16,...]
 *                 [--threads N] [--set dotted.path=value]...
 *       Renders the scene (technique from the scene or --set) at N², the
 *       reference at --ref-spp with another seed, then one progressive
 *       accumulation that stops at each of --spps: one JSON line per spp
 *       with rel_mse of the raw and the denoised image, and the denoise ms.
 *   bench_denoise SCENE.json --time SIZE [--threads N] [--repeat R]
 *       Renders SIZE² at 4 spp and times volux_framebuffer_denoise R times
 *       with the CPU's kernel and with the baseline one (`portable`),
 *       interleaved (median wall ms, and CPU ms, of each).
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "volux/volux.h"

static double clock_ms(clockid_t id) {
    struct timespec ts;
    clock_gettime(id, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

static int cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

static int die(volux_context *ctx, const char *what) {
    fprintf(stderr, "bench_denoise: %s: %s\n", what, ctx ? volux_context_error(ctx) : "");
    return 1;
}

static int load(volux_context *ctx, const char *path, const char **sets, int n_sets, int size, int seed, int spp,
                volux_scene **out) {
    const char *ov[40];
    char sz[3][64];
    int k = 0;
    for (int i = 0; i < n_sets; i++) ov[k++] = sets[i];
    snprintf(sz[0], sizeof sz[0], "render.width=%d", size);
    snprintf(sz[1], sizeof sz[1], "render.height=%d", size);
    snprintf(sz[2], sizeof sz[2], "render.seed=%d", seed);
    ov[k++] = sz[0], ov[k++] = sz[1], ov[k++] = sz[2];
    ov[k] = NULL;
    (void)spp;
    return volux_scene_load(ctx, path, ov, k, out) ? die(ctx, path) : 0;
}

int main(int argc, char **argv) {
    if (argc < 2) {
        fprintf(stderr, "usage: %s SCENE.json [--size N] [--ref-spp N] [--spps a,b,...] [--threads N] "
                        "[--time SIZE [--repeat R]] [--set k=v]...\n", argv[0]);
        return 2;
    }
    const char *scene_path = argv[1], *sets[32], *ref_file = NULL;
    int n_sets = 0, size = 256, ref_spp = 1024, threads = 2, time_size = 0, repeat = 9;
    char spps_buf[256] = "1,4,16,64,256";
    for (int i = 2; i < argc; i++) {
        if (!strcmp(argv[i], "--size") && i + 1 < argc) size = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--ref-spp") && i + 1 < argc) ref_spp = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--spps") && i + 1 < argc) snprintf(spps_buf, sizeof spps_buf, "%s", argv[++i]);
        else if (!strcmp(argv[i], "--threads") && i + 1 < argc) threads = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--time") && i + 1 < argc) time_size = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--repeat") && i + 1 < argc) repeat = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--ref-file") && i + 1 < argc) ref_file = argv[++i];
        else if (!strcmp(argv[i], "--set") && i + 1 < argc && n_sets < 32) sets[n_sets++] = argv[++i];
        else return 2;
    }
    if (repeat < 1 || repeat > 99) repeat = 9;
    /* Denoiser settings from the environment (studies): DN_LEVELS,
     * DN_SIGMA_COLOR, DN_SIGMA_DEPTH, DN_SIGMA_ALBEDO, DN_SIGMA_NORMAL,
     * DN_SIGMA_COVERAGE, DN_NO_BLEND. */
    volux_denoise_settings ds = {0};
    if (getenv("DN_LEVELS")) ds.levels = atoi(getenv("DN_LEVELS"));
    if (getenv("DN_SIGMA_COLOR")) ds.sigma_color = (float)atof(getenv("DN_SIGMA_COLOR"));
    if (getenv("DN_SIGMA_DEPTH")) ds.sigma_depth = (float)atof(getenv("DN_SIGMA_DEPTH"));
    if (getenv("DN_SIGMA_ALBEDO")) ds.sigma_albedo = (float)atof(getenv("DN_SIGMA_ALBEDO"));
    if (getenv("DN_SIGMA_NORMAL")) ds.sigma_normal = (float)atof(getenv("DN_SIGMA_NORMAL"));
    if (getenv("DN_SIGMA_COVERAGE")) ds.sigma_coverage = (float)atof(getenv("DN_SIGMA_COVERAGE"));
    if (getenv("DN_NO_BLEND")) ds.no_blend = 1;
    volux_context *ctx = NULL;
    if (volux_context_create(NULL, &ctx)) return die(NULL, "context");
    volux_context_set_threads(ctx, threads);
    volux_scene *scene = NULL;
    volux_technique *tech = NULL;
    volux_framebuffer *fb = NULL;
    if (time_size > 0) {
        if (load(ctx, scene_path, sets, n_sets, time_size, 1, 4, &scene)) return 1;
        volux_render_limits lim = {4, 0, 0};
        if (volux_technique_create(ctx, volux_scene_render(scene)->technique, scene, &tech) ||
            volux_framebuffer_create(ctx, time_size, time_size, &fb) || volux_framebuffer_set_features(fb, 1) ||
            volux_render(tech, scene, fb, &lim, NULL))
            return die(ctx, "render");
        /* The CPU's kernel and the baseline one, interleaved per repeat
         * (a shared machine's load hits both alike). */
        double ms[2][99], cpu[2][99];
        for (int r = 0; r < repeat; r++)
            for (int k = 0; k < 2; k++) {
                volux_denoise_settings dk = ds;
                dk.portable = k;
                volux_image img = {0};
                double t0 = clock_ms(CLOCK_MONOTONIC), c0 = clock_ms(CLOCK_PROCESS_CPUTIME_ID);
                if (volux_framebuffer_denoise(fb, &dk, &img)) return die(ctx, "denoise");
                ms[k][r] = clock_ms(CLOCK_MONOTONIC) - t0;
                cpu[k][r] = clock_ms(CLOCK_PROCESS_CPUTIME_ID) - c0;
                volux_image_free(ctx, &img);
            }
        for (int k = 0; k < 2; k++) {
            qsort(ms[k], (size_t)repeat, sizeof(double), cmp_double);
            qsort(cpu[k], (size_t)repeat, sizeof(double), cmp_double);
            printf("{\"bench\":\"denoise_time\",\"kernel\":\"%s\",\"size\":%d,\"threads\":%d,\"features\":%d,"
                   "\"median_ms\":%.2f,\"min_ms\":%.2f,\"median_cpu_ms\":%.2f}\n",
                   k ? "portable" : "cpu", time_size, threads, volux_framebuffer_has_features(fb), ms[k][repeat / 2],
                   ms[k][0], cpu[k][repeat / 2]);
        }
    } else {
        /* The reference: another seed, many samples. */
        volux_image ref = {0};
        if (ref_file && !volux_image_load(ctx, ref_file, &ref)) {
            fprintf(stderr, "bench_denoise: reference from %s\n", ref_file);
            goto progressive;
        }
        volux_context_clear_error(ctx);
        if (load(ctx, scene_path, sets, n_sets, size, 1000, ref_spp, &scene)) return 1;
        volux_render_limits lim = {(uint32_t)ref_spp, 0, 0};
        double t0 = clock_ms(CLOCK_MONOTONIC);
        if (volux_technique_create(ctx, volux_scene_render(scene)->technique, scene, &tech) ||
            volux_framebuffer_create(ctx, size, size, &fb) || volux_render(tech, scene, fb, &lim, NULL) ||
            volux_framebuffer_resolve(fb, &ref))
            return die(ctx, "reference");
        fprintf(stderr, "bench_denoise: reference %d spp in %.0f ms\n", ref_spp, clock_ms(CLOCK_MONOTONIC) - t0);
        if (ref_file && volux_image_save(ctx, ref_file, &ref, 0.0f)) return die(ctx, ref_file);
        volux_framebuffer_destroy(fb);
        volux_technique_destroy(tech);
        volux_scene_destroy(scene);
        fb = NULL, tech = NULL, scene = NULL;
    progressive:
        if (load(ctx, scene_path, sets, n_sets, size, 1, 1, &scene)) return 1;
        if (volux_technique_create(ctx, volux_scene_render(scene)->technique, scene, &tech) ||
            volux_framebuffer_create(ctx, size, size, &fb) || volux_framebuffer_set_features(fb, 1))
            return die(ctx, "render");
        for (char *save = NULL, *tok = strtok_r(spps_buf, ",", &save); tok; tok = strtok_r(NULL, ",", &save)) {
            volux_render_limits l = {(uint32_t)atoi(tok), 0, 0};
            volux_render_report rep = {0};
            if (volux_render(tech, scene, fb, &l, &rep)) return die(ctx, "render");
            volux_image raw = {0}, den = {0};
            double d0 = clock_ms(CLOCK_MONOTONIC);
            if (volux_framebuffer_resolve(fb, &raw) || volux_framebuffer_denoise(fb, &ds, &den))
                return die(ctx, "denoise");
            double dms = clock_ms(CLOCK_MONOTONIC) - d0;
            volux_image_error er, ed;
            if (volux_image_compare(ctx, &raw, &ref, &er) || volux_image_compare(ctx, &den, &ref, &ed))
                return die(ctx, "compare");
            printf("{\"bench\":\"denoise\",\"scene\":\"%s\",\"technique\":\"%s\",\"size\":%d,\"spp\":%u,"
                   "\"ref_spp\":%d,\"rel_mse_raw\":%.6g,\"rel_mse_denoised\":%.6g,\"rmse_raw\":%.6g,"
                   "\"rmse_denoised\":%.6g,\"denoise_ms\":%.1f,\"features\":%d}\n",
                   scene_path, volux_scene_render(scene)->technique, size, volux_framebuffer_spp(fb), ref_spp,
                   er.rel_mse, ed.rel_mse, er.rmse, ed.rmse, dms, volux_framebuffer_has_features(fb));
            fflush(stdout);
            volux_image_free(ctx, &raw);
            volux_image_free(ctx, &den);
        }
        volux_image_free(ctx, &ref);
    }
    volux_framebuffer_destroy(fb);
    volux_technique_destroy(tech);
    volux_scene_destroy(scene);
    volux_context_destroy(ctx);
    return 0;
}
