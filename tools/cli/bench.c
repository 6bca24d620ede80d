/*
 * tools/cli/bench.c — `volux bench SCENE.json [--technique T] [--repeat N]
 * [--edit KIND]... [--json] [--reference IMG]`.
 *
 * Metrics (DESIGN §4): prepare_ms (technique creation = building every
 * cache), render_ms (median), samples_per_s / vertices_per_s, memory_bytes
 * (with the memory model's "estimate" of it; also memory_estimate_bytes,
 * memory_estimate_total_bytes for the whole render, peak_rss_bytes),
 * warnings (how many the technique's creation gave, with their text:
 * lights it ignores), update_ms.<edit> (median time of volux_technique_update after the edit;
 * for a progressive technique its first state), refine_ms.<edit> (the
 * work it deferred, when there was any), refine_steps.<edit> (how many
 * refinement steps, i.e. frames, that took) and refine_step_ms.<edit> (the
 * median step), and with --reference a convergence series (rel_mse and
 * mse vs spp/time).
 *
 * Generic extras: the technique's own statistics (volux_technique_stats)
 * after creation, as <stat>, and after each edit's update, as <stat>.<edit>
 * (e.g. manylights: vl_count, avsm_build_ms, avsm_built).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>

#include "tools/mpi/distribute.h"
#include "scene_args.h"

#define MAX_EDITS 16
#define MAX_REPEAT 1000

typedef struct bench_out {
    int json;
    const char *scene;
    const char *technique;
    int threads, width, height;
} bench_out;

static void emit(const bench_out *o, const char *metric, double value, const char *unit, const char *extra) {
    if (o->json)
        printf("{\"scene\":\"%s\",\"technique\":\"%s\",\"metric\":\"%s\",\"value\":%.6g,\"unit\":\"%s\","
               "\"threads\":%d,\"width\":%d,\"height\":%d%s%s}\n",
               o->scene, o->technique, metric, value, unit, o->threads, o->width, o->height, extra ? "," : "",
               extra ? extra : "");
    else
        printf("%-10s %-22s %14.4g %-10s %s\n", o->technique, metric, value, unit, extra ? extra : "");
    fflush(stdout);
}

/* Warnings from the library (e.g. a light the technique cannot use): shown
 * on stderr as they come and listed in the output ("warnings" metric), so
 * that a benchmark table never compares a technique that dropped a light
 * without saying so. */
#define MAX_WARNINGS 16
typedef struct bench_messages {
    int n;
    char text[MAX_WARNINGS][256];
} bench_messages;

static void collect_message(void *user, volux_message_level level, const char *text) {
    bench_messages *m = user;
    cli_eprintf("volux: %s: %s\n", level == VOLUX_MESSAGE_WARNING ? "warning" : "note", text);
    if (level != VOLUX_MESSAGE_WARNING) return;
    if (m->n < MAX_WARNINGS) snprintf(m->text[m->n], sizeof m->text[0], "%s", text);
    m->n++;
}

static void emit_warnings(const bench_out *o, const bench_messages *m) {
    char list[MAX_WARNINGS * 300 + 32];
    size_t at = (size_t)snprintf(list, sizeof list, "\"messages\":[");
    for (int i = 0; i < m->n && i < MAX_WARNINGS; i++) {
        if (i) list[at++] = ',';
        list[at++] = '"';
        for (const char *c = m->text[i]; *c && at + 8 < sizeof list; c++) {
            if (*c == '"' || *c == '\\') list[at++] = '\\';
            list[at++] = (unsigned char)*c < 0x20 ? ' ' : *c;
        }
        list[at++] = '"';
    }
    snprintf(list + at, sizeof list - at, "]");
    emit(o, "warnings", m->n, "count", list);
}

static void usage(FILE *f) {
    fprintf(f, "usage: volux bench SCENE.json [--technique T] [--repeat N] [--edit KIND]... [--json]\n"
               "                   [--reference IMG] [scene options as for render]\n"
               "       volux bench SCENE.json --pareto ...  (the error-time plane; --pareto --help)\n"
               "                   [--distribute image|data] (under mpirun: distributed frame timings;\n"
               "                   data: also the bytes of the volume each rank holds)\n"
               "edits (default: tf camera; 'all' for every one):\n");
    for (int i = 0; volux_edit_at(i); i++) {
        const volux_edit *e = volux_edit_at(i);
        if (e->technique) fprintf(f, "  %-15s %s (%s only)\n", e->name, e->doc, e->technique);
        else fprintf(f, "  %-15s %s\n", e->name, e->doc);
    }
}

/* The technique's statistics as metrics, named <stat><suffix>. */
static void emit_stats(const bench_out *o, const volux_technique *t, const char *suffix) {
    volux_technique_stat stats[32];
    int n = volux_technique_stats(t, stats, 32);
    for (int i = 0; i < n && i < 32; i++) {
        char metric[96];
        snprintf(metric, sizeof metric, "%s%s", stats[i].name, suffix);
        emit(o, metric, stats[i].value, stats[i].unit, NULL);
    }
}

/* Progressive convergence against a reference image: spp 1, 2, 4, ... */
static volux_status convergence(volux_context *ctx, volux_technique *t, volux_scene *scene, volux_framebuffer *fb,
                                const volux_image *ref, const bench_out *o) {
    uint32_t target = (uint32_t)volux_scene_render(scene)->spp;
    volux_framebuffer_reset(fb);
    double total_ms = 0.0;
    for (uint32_t spp = 1; spp <= target; spp = spp < target && spp * 2 > target ? target : spp * 2) {
        volux_render_limits lim = {spp, 0.0, 0.0};
        volux_render_report rep;
        volux_status st = volux_render(t, scene, fb, &lim, &rep);
        if (st) return st;
        total_ms += rep.ms;
        volux_image img = {0};
        if ((st = volux_framebuffer_resolve(fb, &img))) return st;
        volux_image_error err;
        st = volux_image_compare(ctx, &img, ref, &err);
        volux_image_free(ctx, &img);
        if (st) return st;
        char extra[160], rel[32] = "null"; /* null: not available below 4 spp */
        if (rep.rel_error >= 0.0) snprintf(rel, sizeof rel, "%.6g", rep.rel_error);
        snprintf(extra, sizeof extra, "\"spp\":%u,\"ms\":%.3f,\"mse\":%.6g,\"rel_error\":%s", spp, total_ms,
                 err.rmse * err.rmse, rel);
        emit(o, "convergence.rel_mse", err.rel_mse, "", extra);
        if (spp == target) break;
    }
    return VOLUX_OK;
}

int cli_bench(int argc, char **argv) {
    /* Under mpirun or with --distribute: the distributed frame's timings. */
    dist_mode distribute = DIST_NONE;
    for (int i = 1; i < argc; i++)
        if (!strcmp(argv[i], "--distribute") && !dist_parse_mode("bench", i + 1 < argc ? argv[i + 1] : NULL, &distribute))
            return CLI_USAGE;
    if (distribute || dist_launched()) return cli_bench_distributed(argc, argv, distribute);
    for (int i = 1; i < argc; i++)
        if (!strcmp(argv[i], "--pareto")) return cli_bench_pareto(argc, argv);
    cli_scene_args args = {0};
    const volux_edit *edits[MAX_EDITS];
    int n_edits = 0, json = 0, repeat = 5;
    const char *reference = NULL;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "-h") || !strcmp(a, "--help")) {
            usage(stdout);
            return CLI_OK;
        } else if (!strcmp(a, "--json")) {
            json = 1;
        } else if (!strcmp(a, "--repeat")) {
            long v;
            if (!cli_parse_int("bench", "--repeat", i + 1 < argc ? argv[++i] : NULL, 1, MAX_REPEAT, &v))
                return CLI_USAGE;
            repeat = (int)v;
        } else if (!strcmp(a, "--reference")) {
            if (++i >= argc) {
                cli_eprintf("volux bench: --reference needs an image\n");
                return CLI_USAGE;
            }
            reference = argv[i];
        } else if (!strcmp(a, "--edit")) {
            if (++i >= argc) {
                cli_eprintf("volux bench: --edit needs a kind\n");
                return CLI_USAGE;
            }
            if (!strcmp(argv[i], "all")) {
                for (int k = 0; volux_edit_at(k) && n_edits < MAX_EDITS; k++) edits[n_edits++] = volux_edit_at(k);
                continue;
            }
            const volux_edit *e = volux_edit_find(argv[i]);
            if (!e) {
                cli_eprintf("volux bench: --edit %s: unknown edit\n", argv[i]);
                usage(stderr);
                return CLI_USAGE;
            }
            if (n_edits < MAX_EDITS) edits[n_edits++] = e;
        } else {
            int r = cli_scene_arg("bench", &args, argc, argv, &i);
            if (r < 0) return CLI_USAGE;
            if (r == 0) {
                cli_eprintf("volux bench: unknown option '%s'\n", a);
                usage(stderr);
                return CLI_USAGE;
            }
        }
    }
    if (!args.scene_path) {
        cli_eprintf("volux bench: missing SCENE.json\n");
        usage(stderr);
        return CLI_USAGE;
    }
    if (!n_edits) {
        edits[n_edits++] = volux_edit_find("tf");
        edits[n_edits++] = volux_edit_find("camera");
    }
    volux_context *ctx = cli_context(0);
    if (!ctx) return CLI_FAIL;
    static bench_messages messages;
    volux_context_set_message(ctx, collect_message, &messages);
    volux_scene *scene = NULL;
    volux_technique *tech = NULL;
    volux_framebuffer *fb = NULL;
    volux_image ref = {0};
    double *times = NULL;
    volux_status st = VOLUX_OK;
    int rc = cli_load_scene("bench", ctx, &args, &scene);
    if (rc) goto done;
    if (reference && (st = volux_image_load(ctx, reference, &ref))) goto fail;
    const volux_render_settings *rs = volux_scene_render(scene);
    bench_out o = {json, args.scene_path, rs->technique, volux_context_threads(ctx), rs->width, rs->height};
    times = calloc((size_t)repeat, sizeof *times);
    if (!times) {
        rc = CLI_FAIL;
        goto done;
    }

    /* The memory model's estimate (docs/SCALE.md), before the first
     * creation: what memory_bytes should come to, and the whole render. */
    volux_memory_estimate est;
    if ((st = volux_technique_estimate_memory(ctx, rs->technique, scene, &est))) goto fail;
    /* prepare_ms: building every cache from scratch. */
    for (int k = 0; k < repeat; k++) {
        volux_technique_destroy(tech);
        tech = NULL;
        messages.n = 0; /* each creation warns again: keep one's */
        double t0 = cli_now_ms();
        if ((st = volux_technique_create(ctx, rs->technique, scene, &tech))) goto fail;
        times[k] = cli_now_ms() - t0;
    }
    emit(&o, "prepare_ms", cli_median(times, repeat), "ms", NULL);
    emit_warnings(&o, &messages);
    /* A progressive technique renders its refined state below. */
    for (int more = 1; more;)
        if ((st = volux_technique_refine(tech, scene, NULL, &more))) goto fail;
    emit_stats(&o, tech, "");
    if ((st = volux_framebuffer_create(ctx, rs->width, rs->height, &fb))) goto fail;

    /* render_ms: one warm-up frame, then the median of `repeat` frames. */
    volux_render_report rep;
    if ((st = volux_render(tech, scene, fb, NULL, &rep))) goto fail;
    double samples_rate[MAX_REPEAT], vertex_rate[MAX_REPEAT], cpu[MAX_REPEAT], cpu_rate[MAX_REPEAT],
        vertex_cpu_rate[MAX_REPEAT];
    for (int k = 0; k < repeat; k++) {
        volux_framebuffer_reset(fb);
        if ((st = volux_render(tech, scene, fb, NULL, &rep))) goto fail;
        times[k] = rep.ms;
        samples_rate[k] = rep.ms > 0 ? (double)rep.samples / (rep.ms * 1e-3) : 0.0;
        vertex_rate[k] = rep.ms > 0 ? (double)rep.vertices / (rep.ms * 1e-3) : 0.0;
        cpu[k] = rep.cpu_ms;
        /* per core from CPU time: robust against other jobs on a shared machine */
        cpu_rate[k] = rep.cpu_ms > 0 ? (double)rep.samples / (rep.cpu_ms * 1e-3) : 0.0;
        vertex_cpu_rate[k] = rep.cpu_ms > 0 ? (double)rep.vertices / (rep.cpu_ms * 1e-3) : 0.0;
    }
    char extra[96];
    snprintf(extra, sizeof extra, "\"spp\":%u", rep.spp);
    emit(&o, "render_ms", cli_median(times, repeat), "ms", extra);
    emit(&o, "render_cpu_ms", cli_median(cpu, repeat), "ms", NULL);
    double sps = cli_median(samples_rate, repeat), vps = cli_median(vertex_rate, repeat);
    if (sps > 0) {
        emit(&o, "samples_per_s", sps, "1/s", NULL);
        emit(&o, "samples_per_s_per_thread", sps / o.threads, "1/s", NULL);
        emit(&o, "samples_per_cpu_s", cli_median(cpu_rate, repeat), "1/s", NULL);
    }
    if (vps > 0) {
        emit(&o, "vertices_per_s", vps, "1/s", NULL);
        emit(&o, "vertices_per_cpu_s", cli_median(vertex_cpu_rate, repeat), "1/s", NULL);
    }
    /* pixel samples (camera paths for a path tracer) per second */
    emit(&o, "pixel_samples_per_s",
         (double)rs->width * rs->height * rep.spp / (cli_median(times, repeat) * 1e-3), "1/s", NULL);
    /* memory_bytes and the model's estimate of it side by side, then the
     * whole render's estimate (volume, caches, framebuffer, image) and the
     * process's peak resident memory (all of it, the volume's load too). */
    snprintf(extra, sizeof extra, "\"estimate\":%.0f", (double)(est.instance + est.technique));
    emit(&o, "memory_bytes", (double)(volux_technique_memory_bytes(tech)), "bytes", extra);
    emit(&o, "memory_estimate_bytes", (double)(est.instance + est.technique), "bytes", NULL);
    emit(&o, "memory_estimate_total_bytes", (double)est.total, "bytes", NULL);
    struct rusage ru;
    if (getrusage(RUSAGE_SELF, &ru) == 0) emit(&o, "peak_rss_bytes", (double)ru.ru_maxrss * 1024.0, "bytes", NULL);

    /* Convergence before the edits: they leave the scene changed. */
    if (reference && (st = convergence(ctx, tech, scene, fb, &ref, &o))) goto fail;

    /* update_ms.<edit>: only the technique's reaction to the edit (for a
     * progressive technique its first state); refine_ms.<edit>: the
     * deferred rest, when there is any, driven to its end so that every
     * repeat starts from a finished state; refine_steps.<edit> and
     * refine_step_ms.<edit>: how many steps (frames) that took and the
     * median step. */
    double *refine = NULL, *steps = NULL, *frames = NULL;
    size_t n_steps = 0, cap_steps = 0;
    if (!(refine = calloc((size_t)repeat, sizeof *refine)) || !(frames = calloc((size_t)repeat, sizeof *frames))) {
        rc = CLI_FAIL;
        goto edits_done;
    }
    for (int e = 0; e < n_edits; e++) {
        int ok = 1, deferred = 0;
        n_steps = 0;
        for (int k = 0; k < repeat && ok; k++) {
            st = volux_edit_apply(edits[e], scene, k);
            if (st) {
                cli_eprintf("volux bench: skipped: %s\n", volux_context_error(ctx));
                volux_context_clear_error(ctx);
                st = VOLUX_OK;
                ok = 0;
                break;
            }
            double t0 = cli_now_ms();
            if ((st = volux_technique_update(tech, scene, NULL))) goto edits_fail;
            times[k] = cli_now_ms() - t0;
            if (k == repeat - 1) {
                char suffix[48];
                snprintf(suffix, sizeof suffix, ".%s", edits[e]->name);
                emit_stats(&o, tech, suffix);
            }
            refine[k] = frames[k] = 0.0;
            for (int more = 1; more;) {
                int refined = 0;
                double s0 = cli_now_ms();
                if ((st = volux_technique_refine(tech, scene, &refined, &more))) goto edits_fail;
                double ms = cli_now_ms() - s0;
                refine[k] += ms;
                if (!refined) continue;
                deferred = 1;
                frames[k] += 1.0;
                if (n_steps == cap_steps) {
                    size_t cap = cap_steps ? 2 * cap_steps : 256;
                    double *q = realloc(steps, cap * sizeof *q);
                    if (!q) {
                        rc = CLI_FAIL;
                        goto edits_done;
                    }
                    steps = q;
                    cap_steps = cap;
                }
                steps[n_steps++] = ms;
            }
        }
        if (!ok) continue;
        char metric[64];
        snprintf(metric, sizeof metric, "update_ms.%s", edits[e]->name);
        emit(&o, metric, cli_median(times, repeat), "ms", NULL);
        if (deferred) {
            snprintf(metric, sizeof metric, "refine_ms.%s", edits[e]->name);
            emit(&o, metric, cli_median(refine, repeat), "ms", NULL);
            snprintf(metric, sizeof metric, "refine_steps.%s", edits[e]->name);
            emit(&o, metric, cli_median(frames, repeat), "steps", NULL);
            snprintf(metric, sizeof metric, "refine_step_ms.%s", edits[e]->name);
            emit(&o, metric, cli_median(steps, (int)n_steps), "ms", NULL);
        }
    }
    goto edits_done;
edits_fail:
    rc = cli_fail("bench", ctx, st);
edits_done:
    free(refine);
    free(steps);
    free(frames);
    goto done;
fail:
    rc = cli_fail("bench", ctx, st);
done:
    free(times);
    volux_image_free(ctx, &ref);
    volux_framebuffer_destroy(fb);
    volux_technique_destroy(tech);
    volux_scene_destroy(scene);
    volux_context_destroy(ctx);
    return rc;
}
