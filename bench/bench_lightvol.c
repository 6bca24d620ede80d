/*
 * bench/bench_lightvol.c — Sundén & Ropinski 2015 measurements for the
 * `lightvol` technique (public API only).
 *
 *   bench_lightvol table   SCENE.json [--repeat R] [--threads T] [--set path=value]...
 *   bench_lightvol scaling SCENE.json [--max N] [--step S] [--repeat R]
 *                          [--threads T] [--jitter DEG] [--set path=value]...
 *   bench_lightvol budget  SCENE.json [--repeat R] [--threads T] [--set path=value]...
 *   bench_lightvol sequence SCENE.json --out DIR [--spp N] [--threads T] [--set path=value]...
 *
 * table (Table 1): update_ms.full_sequential (every light, one light per
 * propagation pass), update_ms.full_coherent (lights grouped), update_ms.light
 * (the first light rotated ±10° about +Y: a state change, remove + add),
 * update_ms.light_toggle (the first light off / on), render_ms, memory_bytes.
 *
 * scaling (Fig. 10): an entire update for 1..N lights that all have the
 * direction of the scene's first light (each rotated by up to ±DEG about +Y
 * with --jitter, so they are coherent but not identical), sequential vs
 * coherent.
 *
 * budget (§7.3, techniques.lightvol.budget_ms / budget_slices; issue 17):
 * the first light rotated ±10° about +Y, then volux_technique_refine until
 * nothing is pending, as the viewer does between frames:
 * update_ms.light_first (the update a preview waits for),
 * update_ms.light_total (update + every refine step), refine_step_ms_max,
 * and refine_steps (frames to converge).
 *
 * sequence (Sundén Figs. 6 and 8 on our data): the scene's lights switched
 * on one at a time — each step a selective update of one instance — and
 * every state rendered by lightvol and by pathtrace single scattering
 * (max_depth 1, --spp samples): DIR/lv_K.pfm, DIR/pt_K.pfm (K = lights on),
 * one line per step with the update's time and `volux_image_compare`'s
 * rel_mse of lightvol against pathtrace.
 *
 * One JSON object per line in the `volux bench` contract (scene, technique,
 * metric, value = median wall ms, unit, threads, width, height) plus
 * "cpu_ms" (median process CPU time: robust on a shared machine) and, for
 * scaling, "lights".
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

static int cmp(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

static double median(double *v, int n) {
    qsort(v, (size_t)n, sizeof *v, cmp);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

static int fail(volux_context *ctx, const char *what) {
    fprintf(stderr, "bench_lightvol: %s: %s\n", what, volux_context_error(ctx));
    return 1;
}

typedef struct timing {
    double *ms, *cpu;
    int n;
} timing;

static void emit(const char *scene, const char *metric, double value, const char *unit, int threads, int w, int h,
                 const char *extra) {
    printf("{\"scene\":\"%s\",\"technique\":\"lightvol\",\"metric\":\"%s\",\"value\":%.5g,\"unit\":\"%s\","
           "\"threads\":%d,\"width\":%d,\"height\":%d%s%s}\n",
           scene, metric, value, unit, threads, w, h, extra ? "," : "", extra ? extra : "");
    fflush(stdout);
}

static void emit_timing(const char *scene, const char *metric, timing *t, int threads, int w, int h,
                        const char *more) {
    char extra[256];
    snprintf(extra, sizeof extra, "\"cpu_ms\":%.5g%s%s", median(t->cpu, t->n), more ? "," : "", more ? more : "");
    emit(scene, metric, median(t->ms, t->n), "ms", threads, w, h, extra);
}

/* Rotates the light in `slot` about +Y by `deg` (direction and position). */
static volux_status rotate_light(volux_scene *s, int slot, double deg) {
    volux_light_desc d = *volux_scene_light(s, slot);
    float a = (float)(deg * 3.14159265358979 / 180.0), c = cosf(a), sn = sinf(a);
    volux_vec3 v = d.direction, p = d.position;
    d.direction = (volux_vec3){c * v.x + sn * v.z, v.y, -sn * v.x + c * v.z};
    d.position = (volux_vec3){c * p.x + sn * p.z, p.y, -sn * p.x + c * p.z};
    return volux_scene_set_light(s, slot, &d);
}

static double token;

static volux_status force_full(volux_scene *s, const char *mode) {
    volux_status st = volux_scene_set_param(s, "lightvol", "propagation", 0, mode);
    if (st) return st;
    token += 1.0;
    return volux_scene_set_param(s, "lightvol", "rebuild_token", token, NULL);
}

static int run_table(volux_context *ctx, volux_scene *scene, const char *path, int repeat, int threads) {
    const volux_render_settings *rs = volux_scene_render(scene);
    int w = rs->width, h = rs->height;
    int first = -1;
    for (int i = 0; i < volux_scene_light_slots(scene) && first < 0; i++)
        if (volux_scene_light(scene, i)) first = i;
    if (first < 0) {
        fprintf(stderr, "bench_lightvol: the scene has no light\n");
        return 2;
    }
    timing t = {calloc((size_t)repeat, sizeof(double)), calloc((size_t)repeat, sizeof(double)), repeat};
    volux_technique *tech = NULL;
    for (int r = 0; r < repeat; r++) {
        volux_technique_destroy(tech);
        tech = NULL;
        double w0 = now_ms(CLOCK_MONOTONIC), c0 = now_ms(CLOCK_PROCESS_CPUTIME_ID);
        if (volux_technique_create(ctx, "lightvol", scene, &tech)) return fail(ctx, "create");
        t.ms[r] = now_ms(CLOCK_MONOTONIC) - w0;
        t.cpu[r] = now_ms(CLOCK_PROCESS_CPUTIME_ID) - c0;
    }
    emit_timing(path, "prepare_ms", &t, threads, w, h, NULL);
    emit(path, "memory_bytes", (double)volux_technique_memory_bytes(tech), "bytes", threads, w, h, NULL);
    static const char *modes[2] = {"sequential", "coherent"};
    for (int m = 0; m < 2; m++) {
        for (int r = 0; r < repeat; r++) {
            if (force_full(scene, modes[m])) return fail(ctx, "param");
            double w0 = now_ms(CLOCK_MONOTONIC), c0 = now_ms(CLOCK_PROCESS_CPUTIME_ID);
            if (volux_technique_update(tech, scene, NULL)) return fail(ctx, "update");
            t.ms[r] = now_ms(CLOCK_MONOTONIC) - w0;
            t.cpu[r] = now_ms(CLOCK_PROCESS_CPUTIME_ID) - c0;
        }
        char metric[64];
        snprintf(metric, sizeof metric, "update_ms.full_%s", modes[m]);
        emit_timing(path, metric, &t, threads, w, h, NULL);
    }
    /* selective edits, coherent propagation (left set above) */
    for (int kind = 0; kind < 2; kind++) {
        for (int r = 0; r < repeat; r++) {
            volux_status st = kind == 0 ? rotate_light(scene, first, (r & 1) ? -10.0 : 10.0)
                                        : volux_scene_set_light_enabled(scene, first, r & 1);
            if (st) return fail(ctx, "edit");
            double w0 = now_ms(CLOCK_MONOTONIC), c0 = now_ms(CLOCK_PROCESS_CPUTIME_ID);
            if (volux_technique_update(tech, scene, NULL)) return fail(ctx, "update");
            t.ms[r] = now_ms(CLOCK_MONOTONIC) - w0;
            t.cpu[r] = now_ms(CLOCK_PROCESS_CPUTIME_ID) - c0;
        }
        if (kind == 1 && (repeat & 1)) { /* leave the light on */
            volux_scene_set_light_enabled(scene, first, 1);
            volux_technique_update(tech, scene, NULL);
        }
        emit_timing(path, kind == 0 ? "update_ms.light" : "update_ms.light_toggle", &t, threads, w, h, NULL);
    }
    volux_framebuffer *fb = NULL;
    if (volux_framebuffer_create(ctx, w, h, &fb)) return fail(ctx, "framebuffer");
    volux_render_limits lim = {1, 0, 0};
    volux_render_report rep;
    if (volux_render(tech, scene, fb, &lim, &rep)) return fail(ctx, "render");
    for (int r = 0; r < repeat; r++) {
        volux_framebuffer_reset(fb);
        double c0 = now_ms(CLOCK_PROCESS_CPUTIME_ID);
        if (volux_render(tech, scene, fb, &lim, &rep)) return fail(ctx, "render");
        t.ms[r] = rep.ms;
        t.cpu[r] = now_ms(CLOCK_PROCESS_CPUTIME_ID) - c0;
    }
    emit_timing(path, "render_ms", &t, threads, w, h, "\"spp\":1");
    volux_framebuffer_destroy(fb);
    volux_technique_destroy(tech);
    free(t.ms);
    free(t.cpu);
    return 0;
}

static int run_budget(volux_context *ctx, volux_scene *scene, const char *path, int repeat, int threads) {
    const volux_render_settings *rs = volux_scene_render(scene);
    int w = rs->width, h = rs->height, first = -1;
    for (int i = 0; i < volux_scene_light_slots(scene) && first < 0; i++)
        if (volux_scene_light(scene, i)) first = i;
    if (first < 0) {
        fprintf(stderr, "bench_lightvol: the scene has no light\n");
        return 2;
    }
    volux_technique *tech = NULL;
    if (volux_technique_create(ctx, "lightvol", scene, &tech)) return fail(ctx, "create");
    timing t1 = {calloc((size_t)repeat, sizeof(double)), calloc((size_t)repeat, sizeof(double)), repeat};
    timing tt = {calloc((size_t)repeat, sizeof(double)), calloc((size_t)repeat, sizeof(double)), repeat};
    double *steps = calloc((size_t)repeat, sizeof(double)), *step_max = calloc((size_t)repeat, sizeof(double));
    for (int r = 0; r < repeat; r++) {
        if (rotate_light(scene, first, (r & 1) ? -10.0 : 10.0)) return fail(ctx, "edit");
        double w0 = now_ms(CLOCK_MONOTONIC), c0 = now_ms(CLOCK_PROCESS_CPUTIME_ID);
        if (volux_technique_update(tech, scene, NULL)) return fail(ctx, "update");
        t1.ms[r] = now_ms(CLOCK_MONOTONIC) - w0;
        t1.cpu[r] = now_ms(CLOCK_PROCESS_CPUTIME_ID) - c0;
        int more = volux_technique_pending(tech) > 0;
        steps[r] = step_max[r] = 0;
        while (more) {
            double s0 = now_ms(CLOCK_MONOTONIC);
            if (volux_technique_refine(tech, scene, NULL, &more)) return fail(ctx, "refine");
            double d = now_ms(CLOCK_MONOTONIC) - s0;
            if (d > step_max[r]) step_max[r] = d;
            steps[r] += 1;
        }
        tt.ms[r] = now_ms(CLOCK_MONOTONIC) - w0;
        tt.cpu[r] = now_ms(CLOCK_PROCESS_CPUTIME_ID) - c0;
    }
    emit_timing(path, "update_ms.light_first", &t1, threads, w, h, NULL);
    emit_timing(path, "update_ms.light_total", &tt, threads, w, h, NULL);
    emit(path, "refine_steps", median(steps, repeat), "steps", threads, w, h, NULL);
    emit(path, "refine_step_ms_max", median(step_max, repeat), "ms", threads, w, h, NULL);
    free(t1.ms), free(t1.cpu), free(tt.ms), free(tt.cpu), free(steps), free(step_max);
    volux_technique_destroy(tech);
    return 0;
}

static volux_status render_to(volux_context *ctx, volux_technique *t, const volux_scene *scene, int spp,
                               const char *path) {
    const volux_render_settings *rs = volux_scene_render(scene);
    volux_framebuffer *fb = NULL;
    volux_image img = {0};
    volux_render_limits lim = {(uint32_t)spp, 0, 0};
    volux_status st = volux_framebuffer_create(ctx, rs->width, rs->height, &fb);
    if (!st) st = volux_render(t, scene, fb, &lim, NULL);
    if (!st) st = volux_framebuffer_resolve(fb, &img);
    if (!st) st = volux_image_save(ctx, path, &img, 0.0f);
    volux_image_free(ctx, &img);
    volux_framebuffer_destroy(fb);
    return st;
}

static int run_sequence(volux_context *ctx, volux_scene *scene, const char *path, const char *out, int spp,
                        int threads) {
    const volux_render_settings *rs0 = volux_scene_render(scene);
    int w = rs0->width, h = rs0->height, slots[64], n = 0;
    for (int i = 0; i < volux_scene_light_slots(scene) && n < 64; i++)
        if (volux_scene_light(scene, i)) slots[n++] = i;
    for (int i = 1; i < n; i++)
        if (volux_scene_set_light_enabled(scene, slots[i], 0)) return fail(ctx, "light");
    volux_technique *lv = NULL;
    if (volux_technique_create(ctx, "lightvol", scene, &lv)) return fail(ctx, "create");
    for (int k = 1; k <= n; k++) {
        double ms = 0.0;
        if (k > 1) {
            if (volux_scene_set_light_enabled(scene, slots[k - 1], 1)) return fail(ctx, "light");
            double w0 = now_ms(CLOCK_MONOTONIC);
            if (volux_technique_update(lv, scene, NULL)) return fail(ctx, "update");
            ms = now_ms(CLOCK_MONOTONIC) - w0;
        }
        char a[1024], b[1024];
        snprintf(a, sizeof a, "%s/lv_%d.pfm", out, k);
        snprintf(b, sizeof b, "%s/pt_%d.pfm", out, k);
        if (render_to(ctx, lv, scene, 1, a)) return fail(ctx, a);
        /* the reference: pathtrace single scattering of the same state */
        volux_render_settings rs = *volux_scene_render(scene);
        volux_render_settings pt = rs;
        strcpy(pt.technique, "pathtrace");
        pt.max_depth = 1;
        volux_technique *ref = NULL;
        if (volux_scene_set_render(scene, &pt) || volux_technique_create(ctx, "pathtrace", scene, &ref) ||
            render_to(ctx, ref, scene, spp, b))
            return fail(ctx, b);
        volux_technique_destroy(ref);
        if (volux_scene_set_render(scene, &rs)) return fail(ctx, "render settings");
        volux_image ia = {0}, ib = {0};
        volux_image_error m;
        if (volux_image_load(ctx, a, &ia) || volux_image_load(ctx, b, &ib) || volux_image_compare(ctx, &ia, &ib, &m))
            return fail(ctx, "compare");
        char extra[128];
        snprintf(extra, sizeof extra, "\"lights\":%d,\"rel_mse\":%.5g,\"pathtrace_spp\":%d", k, m.rel_mse, spp);
        emit(path, "sequence.update_ms", ms, "ms", threads, w, h, extra);
        volux_image_free(ctx, &ia);
        volux_image_free(ctx, &ib);
    }
    volux_technique_destroy(lv);
    return 0;
}

static int run_scaling(volux_context *ctx, volux_scene *scene, const char *path, int repeat, int threads,
                       int max_lights, int step, double jitter) {
    const volux_render_settings *rs = volux_scene_render(scene);
    int first = -1;
    for (int i = 0; i < volux_scene_light_slots(scene) && first < 0; i++)
        if (volux_scene_light(scene, i)) first = i;
    if (first < 0) {
        fprintf(stderr, "bench_lightvol: the scene needs a light to copy\n");
        return 2;
    }
    volux_light_desc base = *volux_scene_light(scene, first);
    for (int i = 0; i < volux_scene_light_slots(scene); i++)
        if (volux_scene_light(scene, i)) volux_scene_remove_light(scene, i);
    volux_technique *t = NULL;
    timing tm = {calloc((size_t)repeat, sizeof(double)), calloc((size_t)repeat, sizeof(double)), repeat};
    for (int n = 1; n <= max_lights; n++) {
        volux_light_desc d = base;
        d.color = (volux_vec3){base.color.x / (float)max_lights, base.color.y / (float)max_lights,
                               base.color.z / (float)max_lights};
        if (volux_scene_set_light(scene, n - 1, &d)) return fail(ctx, "light");
        if (jitter != 0.0 && rotate_light(scene, n - 1, (n & 1 ? 1.0 : -1.0) * jitter * ((n + 1) / 2) / max_lights))
            return fail(ctx, "light");
        if (!t && volux_technique_create(ctx, "lightvol", scene, &t)) return fail(ctx, "lightvol");
        if (n != 1 && n != max_lights && (n - 1) % step != 0) continue;
        for (int mode = 0; mode < 2; mode++) {
            const char *name = mode ? "coherent" : "sequential";
            for (int r = 0; r < repeat; r++) {
                if (force_full(scene, name)) return fail(ctx, "param");
                double w0 = now_ms(CLOCK_MONOTONIC), c0 = now_ms(CLOCK_PROCESS_CPUTIME_ID);
                if (volux_technique_update(t, scene, NULL)) return fail(ctx, "update");
                tm.ms[r] = now_ms(CLOCK_MONOTONIC) - w0;
                tm.cpu[r] = now_ms(CLOCK_PROCESS_CPUTIME_ID) - c0;
            }
            char metric[64], more[64];
            snprintf(metric, sizeof metric, "scaling.update_ms.full_%s", name);
            snprintf(more, sizeof more, "\"lights\":%d,\"jitter_deg\":%g", n, jitter);
            emit_timing(path, metric, &tm, threads, rs->width, rs->height, more);
        }
    }
    free(tm.ms);
    free(tm.cpu);
    volux_technique_destroy(t);
    return 0;
}

int main(int argc, char **argv) {
    const char *scene_path = NULL, *mode = argc > 1 ? argv[1] : "";
    const char *sets[MAX_SET + 1];
    int n_sets = 0, max_lights = 40, step = 1, repeat = 3, threads = 0;
    double jitter = 0.0;
    int table = !strcmp(mode, "table"), budget = !strcmp(mode, "budget"), sequence = !strcmp(mode, "sequence");
    const char *out = NULL;
    int spp = 256;
    if (!table && !budget && !sequence && strcmp(mode, "scaling")) {
        fprintf(stderr, "usage: bench_lightvol table|scaling|budget|sequence SCENE.json [options] (see the source header)\n");
        return 2;
    }
    for (int i = 2; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "--max") && i + 1 < argc) max_lights = atoi(argv[++i]);
        else if (!strcmp(a, "--step") && i + 1 < argc) step = atoi(argv[++i]);
        else if (!strcmp(a, "--repeat") && i + 1 < argc) repeat = atoi(argv[++i]);
        else if (!strcmp(a, "--threads") && i + 1 < argc) threads = atoi(argv[++i]);
        else if (!strcmp(a, "--jitter") && i + 1 < argc) jitter = atof(argv[++i]);
        else if (!strcmp(a, "--out") && i + 1 < argc) out = argv[++i];
        else if (!strcmp(a, "--spp") && i + 1 < argc) spp = atoi(argv[++i]);
        else if (!strcmp(a, "--set") && i + 1 < argc && n_sets < MAX_SET) sets[n_sets++] = argv[++i];
        else if (a[0] != '-' && !scene_path) scene_path = a;
        else {
            fprintf(stderr, "bench_lightvol: unknown or incomplete option '%s'\n", a);
            return 2;
        }
    }
    if (sequence && (!out || spp < 1)) {
        fprintf(stderr, "bench_lightvol: sequence needs --out DIR (and --spp >= 1)\n");
        return 2;
    }
    if (!scene_path || max_lights < 1 || max_lights > 200 || step < 1 || repeat < 1 || repeat > 100) {
        fprintf(stderr, "bench_lightvol: bad arguments (SCENE.json, 1 <= --max <= 200, --repeat 1..100)\n");
        return 2;
    }
    sets[n_sets] = NULL;
    volux_context_desc cd = {0};
    cd.threads = threads;
    volux_context *ctx = NULL;
    if (volux_context_create(&cd, &ctx)) return 1;
    volux_scene *scene = NULL;
    if (volux_scene_load(ctx, scene_path, sets, n_sets, &scene)) return fail(ctx, scene_path);
    volux_render_settings rs = *volux_scene_render(scene);
    strcpy(rs.technique, "lightvol");
    rs.threads = threads;
    if (volux_scene_set_render(scene, &rs)) return fail(ctx, "render settings");
    int nthreads = threads > 0 ? threads : volux_context_threads(ctx);
    int rc = table    ? run_table(ctx, scene, scene_path, repeat, nthreads)
             : budget ? run_budget(ctx, scene, scene_path, repeat, nthreads)
             : sequence ? run_sequence(ctx, scene, scene_path, out, spp, nthreads)
                      : run_scaling(ctx, scene, scene_path, repeat, nthreads, max_lights, step, jitter);
    volux_scene_destroy(scene);
    volux_context_destroy(ctx);
    return rc;
}
