/*
 * tools/cli/bench_distributed.c — `volux bench` under mpirun or with
 * --distribute image (issue 15): the frame time of the distributed render
 * and where it goes.
 *
 * Metrics (rank 0 prints; every line carries "ranks"):
 *   prepare_ms              technique creation + refinement (slowest rank)
 *   render_ms               whole distributed frame, tiles to composited
 *                           sums on rank 0 (median of --repeat)
 *   composite_ms            the reduction of the sums (median)
 *   composite_fraction      composite_ms / render_ms
 *   composite_bytes_max     data-parallel: the most bytes one rank sent
 *                           compositing a frame
 *   rank_render_ms.<k>      rank k's tile rendering (median), tiles.<k>
 *                           (data-parallel: rank k's brick, all pixels)
 *   volume_bytes.<k>        data-parallel: the scalar grid rank k holds
 *   volume_fraction.<k>     ... over volume_bytes_whole (the whole grid)
 * Edits and --reference are single-process measurements: refused here.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "tools/mpi/distribute.h"
#include "scene_args.h"

#define MAX_REPEAT 1000

typedef struct line_out {
    int json, threads, width, height, ranks;
    const char *scene, *technique;
} line_out;

static void emit(const line_out *o, const char *metric, double value, const char *unit) {
    if (o->json)
        printf("{\"scene\":\"%s\",\"technique\":\"%s\",\"metric\":\"%s\",\"value\":%.6g,\"unit\":\"%s\","
               "\"threads\":%d,\"width\":%d,\"height\":%d,\"ranks\":%d}\n",
               o->scene, o->technique, metric, value, unit, o->threads, o->width, o->height, o->ranks);
    else
        printf("%-10s %-22s %14.4g %-10s ranks %d\n", o->technique, metric, value, unit, o->ranks);
    fflush(stdout);
}

int cli_bench_distributed(int argc, char **argv, int distribute_mode) {
    dist_mode requested = (dist_mode)distribute_mode;
    cli_scene_args args = {0};
    int json = 0, repeat = 5;
    dist_quiet_followers();
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "--json")) {
            json = 1;
        } else if (!strcmp(a, "--distribute")) {
            i++; /* parsed by the caller */
        } else if (!strcmp(a, "--repeat")) {
            long v;
            if (!cli_parse_int("bench", "--repeat", i + 1 < argc ? argv[++i] : NULL, 1, MAX_REPEAT, &v))
                return CLI_USAGE;
            repeat = (int)v;
        } else if (!strcmp(a, "--edit") || !strcmp(a, "--reference")) {
            cli_eprintf("volux bench: %s: not available in a distributed run (run one process)\n", a);
            return CLI_USAGE;
        } else {
            int r = cli_scene_arg("bench", &args, argc, argv, &i);
            if (r < 0) return CLI_USAGE;
            if (r == 0) {
                cli_eprintf("volux bench: unknown option '%s'\n", a);
                return CLI_USAGE;
            }
        }
    }
    if (!args.scene_path) {
        cli_eprintf("volux bench: missing SCENE.json\n");
        return CLI_USAGE;
    }
    int mode = dist_begin("bench", requested);
    if (mode < 0) return CLI_USAGE;
    volux_volume_region region;
    if (mode == DIST_DATA) {
        dist_region(&region);
        args.region = &region;
    }
    volux_context *ctx = cli_context(dist_default_threads());
    if (!ctx) {
        dist_end();
        return CLI_FAIL;
    }
    volux_context_set_progress(ctx, NULL, NULL); /* timings, not bars */
    volux_scene *scene = NULL;
    volux_technique *tech = NULL;
    volux_framebuffer *fb = NULL;
    int ranks = dist_size(), rank = dist_rank();
    double *frame = calloc((size_t)repeat, sizeof *frame), *composite = calloc((size_t)repeat, sizeof *composite),
           *mine = calloc((size_t)repeat, sizeof *mine), *all = calloc(2 * (size_t)ranks, sizeof *all);
    char msg[1024] = "";
    int rc = cli_load_scene_quiet("bench", ctx, &args, &scene, msg, sizeof msg);
    if (!rc && (!frame || !composite || !mine || !all)) {
        rc = CLI_FAIL;
        snprintf(msg, sizeof msg, "out of memory");
    }
    if ((rc = dist_agree_msg("bench", rc, msg))) goto done;
    if (mode == DIST_DATA && (rc = dist_agree("bench", ctx, dist_share_stats(scene)))) goto done;
    const volux_render_settings *rs = volux_scene_render(scene);
    line_out o = {json, volux_context_threads(ctx), rs->width, rs->height, ranks, args.scene_path, rs->technique};

    double t0 = cli_now_ms();
    volux_status st = volux_technique_create(ctx, rs->technique, scene, &tech);
    for (int more = 1; !st && more;) st = volux_technique_refine(tech, scene, NULL, &more);
    double prepare = cli_now_ms() - t0, prepare_max = prepare;
    if (!st) st = volux_framebuffer_create(ctx, rs->width, rs->height, &fb);
    if ((rc = dist_agree("bench", ctx, st))) goto done;
    dist_max(&prepare_max);

    dist_timing tm;
    volux_status (*frame_fn)(volux_technique *, const volux_scene *, volux_framebuffer *, dist_timing *) =
        mode == DIST_DATA ? dist_render_data : dist_render_image;
    st = frame_fn(tech, scene, fb, &tm); /* warm-up: connections, caches */
    int tiles = tm.tiles;
    for (int k = 0; k < repeat && !st; k++) {
        dist_barrier();
        t0 = cli_now_ms();
        st = frame_fn(tech, scene, fb, &tm);
        frame[k] = cli_now_ms() - t0;
        composite[k] = tm.composite_ms;
        mine[k] = tm.render_ms;
    }
    double sent_max = tm.composite_bytes;
    dist_max(&sent_max);
    if ((rc = dist_agree("bench", ctx, st))) goto done;
    /* Every rank's medians and tile counts to rank 0. */
    double stats[2] = {cli_median(mine, repeat), (double)tiles};
    double *gathered = rank == 0 ? all : NULL;
    dist_gather2(stats, gathered);
    /* data-parallel: the scalar grid each rank holds (bytes) */
    double held, whole, *bytes = rank == 0 ? calloc(2 * (size_t)ranks, sizeof *bytes) : NULL;
    dist_volume_bytes(scene, &held, &whole);
    double mem[2] = {held, whole};
    if (mode == DIST_DATA) dist_gather2(mem, bytes ? bytes : mem);
    if (rank == 0) {
        emit(&o, "prepare_ms", prepare_max, "ms");
        double render = cli_median(frame, repeat), comp = cli_median(composite, repeat);
        emit(&o, "render_ms", render, "ms");
        emit(&o, "composite_ms", comp, "ms");
        emit(&o, "composite_fraction", render > 0 ? comp / render : 0.0, "");
        for (int r = 0; r < ranks; r++) {
            char metric[64];
            snprintf(metric, sizeof metric, "rank_render_ms.%d", r);
            emit(&o, metric, gathered[2 * r], "ms");
            if (mode == DIST_DATA) continue; /* every rank renders every pixel of its brick */
            snprintf(metric, sizeof metric, "tiles.%d", r);
            emit(&o, metric, gathered[2 * r + 1], "tiles");
        }
        if (mode == DIST_DATA) emit(&o, "composite_bytes_max", sent_max, "bytes");
        if (mode == DIST_DATA && bytes) {
            emit(&o, "volume_bytes_whole", bytes[1], "bytes");
            for (int r = 0; r < ranks; r++) {
                char metric[64];
                snprintf(metric, sizeof metric, "volume_bytes.%d", r);
                emit(&o, metric, bytes[2 * r], "bytes");
                snprintf(metric, sizeof metric, "volume_fraction.%d", r);
                emit(&o, metric, bytes[1] > 0 ? bytes[2 * r] / bytes[1] : 0.0, "");
            }
        }
    }
    free(bytes);
done:
    free(frame);
    free(composite);
    free(mine);
    free(all);
    volux_framebuffer_destroy(fb);
    volux_technique_destroy(tech);
    volux_scene_destroy(scene);
    volux_context_destroy(ctx);
    dist_end();
    return rc;
}
