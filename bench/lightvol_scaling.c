/*
 * bench/lightvol_scaling.c — the scaling test of Sundén & Ropinski 2015
 * (Fig. 10): time of an entire light update for 1..N lights that all have
 * the same direction, sequential (one light per propagation pass) vs
 * coherent (all lights of a group in one pass). Uses the public API only.
 *
 *   lightvol_scaling SCENE.json [--max N] [--step S] [--repeat R]
 *                    [--threads T] [--jitter DEG] [--set path=value]...
 *
 * The scene supplies volume, transfer function and technique parameters;
 * its lights are replaced by N copies of its first light (directional or
 * not), each rotated by ±DEG about +Y when --jitter is given (so lights are
 * coherent but not identical). Prints one JSON object per line in the
 * `volux bench` contract (scene, technique, metric, value, unit, threads,
 * width, height) plus "lights", "passes" and "cpu_ms" (process CPU time, to
 * expose contention on a shared machine).
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
    fprintf(stderr, "lightvol_scaling: %s: %s\n", what, volux_context_error(ctx));
    return 1;
}

int main(int argc, char **argv) {
    const char *scene_path = NULL;
    const char *sets[MAX_SET + 1];
    int n_sets = 0, max_lights = 40, step = 1, repeat = 3, threads = 0;
    double jitter = 0.0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "--max") && i + 1 < argc) max_lights = atoi(argv[++i]);
        else if (!strcmp(a, "--step") && i + 1 < argc) step = atoi(argv[++i]);
        else if (!strcmp(a, "--repeat") && i + 1 < argc) repeat = atoi(argv[++i]);
        else if (!strcmp(a, "--threads") && i + 1 < argc) threads = atoi(argv[++i]);
        else if (!strcmp(a, "--jitter") && i + 1 < argc) jitter = atof(argv[++i]);
        else if (!strcmp(a, "--set") && i + 1 < argc && n_sets < MAX_SET) sets[n_sets++] = argv[++i];
        else if (a[0] != '-' && !scene_path) scene_path = a;
        else {
            fprintf(stderr,
                    "usage: lightvol_scaling SCENE.json [--max N] [--step S] [--repeat R] [--threads T] "
                    "[--jitter DEG] [--set path=value]...\n");
            return 2;
        }
    }
    if (!scene_path || max_lights < 1 || max_lights > 200 || step < 1 || repeat < 1 || repeat > 100) {
        fprintf(stderr, "lightvol_scaling: bad arguments (SCENE.json, 1 <= --max <= 200, --repeat 1..100)\n");
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
    int first = -1;
    for (int i = 0; i < volux_scene_light_slots(scene); i++)
        if (volux_scene_light(scene, i) && first < 0) first = i;
    if (first < 0) {
        fprintf(stderr, "lightvol_scaling: the scene needs a light to copy\n");
        return 2;
    }
    volux_light_desc base = *volux_scene_light(scene, first);
    for (int i = 0; i < volux_scene_light_slots(scene); i++)
        if (volux_scene_light(scene, i)) volux_scene_remove_light(scene, i);
    volux_technique *t = NULL;
    double *ms = calloc((size_t)repeat, sizeof *ms), *cpu = calloc((size_t)repeat, sizeof *cpu);
    double token = 0.0;
    int nthreads = threads > 0 ? threads : volux_context_threads(ctx);
    for (int n = 1; n <= max_lights; n++) {
        volux_light_desc d = base;
        if (jitter != 0.0) {
            double a = (n & 1 ? 1.0 : -1.0) * jitter * ((n + 1) / 2) / (double)max_lights * 3.14159265358979 / 180.0;
            float c = (float)cos(a), s = (float)sin(a);
            volux_vec3 v = d.direction, p = d.position;
            d.direction = (volux_vec3){c * v.x + s * v.z, v.y, -s * v.x + c * v.z};
            d.position = (volux_vec3){c * p.x + s * p.z, p.y, -s * p.x + c * p.z};
        }
        d.color = (volux_vec3){base.color.x / (float)max_lights, base.color.y / (float)max_lights,
                               base.color.z / (float)max_lights};
        if (volux_scene_set_light(scene, n - 1, &d)) return fail(ctx, "light");
        if (!t && volux_technique_create(ctx, "lightvol", scene, &t)) return fail(ctx, "lightvol");
        if (n != 1 && n != max_lights && (n - 1) % step != 0) continue;
        for (int mode = 0; mode < 2; mode++) {
            const char *name = mode ? "coherent" : "sequential";
            if (volux_scene_set_param(scene, "lightvol", "propagation", 0, name)) return fail(ctx, "param");
            for (int r = 0; r < repeat; r++) {
                token += 1.0;
                if (volux_scene_set_param(scene, "lightvol", "rebuild_token", token, NULL)) return fail(ctx, "param");
                double w0 = now_ms(CLOCK_MONOTONIC), c0 = now_ms(CLOCK_PROCESS_CPUTIME_ID);
                if (volux_technique_update(t, scene, NULL)) return fail(ctx, "update");
                ms[r] = now_ms(CLOCK_MONOTONIC) - w0;
                cpu[r] = now_ms(CLOCK_PROCESS_CPUTIME_ID) - c0;
            }
            printf("{\"scene\":\"%s\",\"technique\":\"lightvol\",\"metric\":\"scaling.update_ms.full_%s\","
                   "\"value\":%.4g,\"unit\":\"ms\",\"threads\":%d,\"width\":%d,\"height\":%d,\"lights\":%d,"
                   "\"cpu_ms\":%.4g,\"jitter_deg\":%g}\n",
                   scene_path, name, median(ms, repeat), nthreads, rs.width, rs.height, n, median(cpu, repeat), jitter);
            fflush(stdout);
        }
    }
    free(ms);
    free(cpu);
    volux_technique_destroy(t);
    volux_scene_destroy(scene);
    volux_context_destroy(ctx);
    return 0;
}
