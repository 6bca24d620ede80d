/* tools/cli/render.c — `volux render SCENE.json -o OUT.(png|pfm|exr) [...]`. */
#include <stdio.h>
#include <string.h>
#include <strings.h>

#include "tools/mpi/distribute.h"
#include "scene_args.h"

static void usage(FILE *f) {
    fprintf(f,
            "usage: volux render SCENE.json -o OUT.(png|pfm|exr) [--technique T] [--spp N]\n"
            "                    [--width W] [--height H] [--threads N] [--seed S] [--step S]\n"
            "                    [--time-ms MS] [--target-error E] [--max-depth D] [--exposure EV]\n"
            "                    [--set dotted.path=JSON-value]... [--quiet]\n"
            "                    [--distribute image]   (under mpirun; the default there)\n"
            "Renders until the scene's spp, time budget or target relative error is reached and\n"
            "writes the image (PNG tone-mapped with render.exposure; PFM/EXR linear).\n"
            "Under mpirun the ranks share the frame's tiles and render.spp samples are taken\n"
            "(time and error limits apply to a single process only); rank 0 writes the image,\n"
            "bit-identical to a single-process render.\n");
}

static int supported_output(const char *path) {
    const char *dot = strrchr(path, '.');
    return dot && (!strcasecmp(dot, ".png") || !strcasecmp(dot, ".pfm") || !strcasecmp(dot, ".exr"));
}

int cli_render(int argc, char **argv) {
    cli_scene_args args = {0};
    const char *out_path = NULL;
    int quiet = 0;
    dist_mode distribute = DIST_NONE;
    dist_quiet_followers();
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "-h") || !strcmp(argv[i], "--help")) {
            usage(stdout);
            return CLI_OK;
        }
        if (!strcmp(argv[i], "-o") || !strcmp(argv[i], "--output")) {
            if (++i >= argc) {
                cli_eprintf("volux render: -o needs a file name\n");
                return CLI_USAGE;
            }
            out_path = argv[i];
            continue;
        }
        if (!strcmp(argv[i], "--distribute")) {
            if (!dist_parse_mode("render", ++i < argc ? argv[i] : NULL, &distribute)) return CLI_USAGE;
            continue;
        }
        if (!strcmp(argv[i], "--quiet")) {
            quiet = 1;
            continue;
        }
        int r = cli_scene_arg("render", &args, argc, argv, &i);
        if (r < 0) return CLI_USAGE;
        if (r == 0) {
            cli_eprintf("volux render: unknown option '%s'\n", argv[i]);
            usage(stderr);
            return CLI_USAGE;
        }
    }
    if (!args.scene_path || !out_path) {
        cli_eprintf("volux render: %s\n", !args.scene_path ? "missing SCENE.json" : "missing -o OUT.png|pfm|exr");
        usage(stderr);
        return CLI_USAGE;
    }
    if (!supported_output(out_path)) {
        cli_eprintf("volux render: -o %s: unsupported image type (use .png, .pfm or .exr)\n", out_path);
        return CLI_USAGE;
    }
    int mode = dist_begin("render", distribute);
    if (mode < 0) return CLI_USAGE;
    if (mode == DIST_DATA) {
        cli_eprintf("volux render: --distribute data: not available yet (use image)\n");
        dist_end();
        return CLI_USAGE;
    }
    volux_context *ctx = cli_context(dist_default_threads());
    if (!ctx) {
        dist_end();
        return CLI_FAIL;
    }
    if (dist_rank() > 0) volux_context_set_progress(ctx, NULL, NULL);
    volux_scene *scene = NULL;
    volux_technique *tech = NULL;
    volux_framebuffer *fb = NULL;
    volux_image img = {0};
    char msg[1024] = "";
    int rc = cli_load_scene_quiet("render", ctx, &args, &scene, msg, sizeof msg);
    if ((rc = dist_agree_msg("render", rc, msg))) goto done;
    const volux_render_settings *rs = volux_scene_render(scene);
    double t0 = cli_now_ms();
    volux_status st = volux_technique_create(ctx, rs->technique, scene, &tech);
    /* A progressive technique's deferred work is finished: an image file
     * is the final result, not the first frame of an interactive session. */
    for (int more = 1; !st && more;) st = volux_technique_refine(tech, scene, NULL, &more);
    double prepare_ms = cli_now_ms() - t0;
    if (!st) st = volux_framebuffer_create(ctx, rs->width, rs->height, &fb);
    if ((rc = dist_agree("render", ctx, st))) goto done;
    dist_timing timing;
    st = dist_render_image(tech, scene, fb, &timing);
    if ((rc = dist_agree("render", ctx, st))) goto done;
    if (dist_rank() == 0) {
        st = volux_framebuffer_resolve(fb, &img);
        if (!st) st = volux_image_save(ctx, out_path, &img, rs->exposure);
        rc = st ? cli_fail("render", ctx, st) : CLI_OK;
        if (!rc && !quiet) {
            cli_eprintf("volux render: %s: %s %dx%d, %u spp, prepare %.1f ms, render %.1f ms", args.scene_path,
                    rs->technique, rs->width, rs->height, volux_framebuffer_spp(fb), prepare_ms, timing.render_ms);
            if (dist_size() > 1)
                cli_eprintf(" (%d ranks, %.1f-%.1f ms each, composite %.1f ms)", dist_size(),
                        timing.rank_render_ms_min, timing.rank_render_ms_max, timing.composite_ms);
            cli_eprintf(", rel. error %.3g -> %s\n", volux_framebuffer_rel_error(fb), out_path);
        }
    }
    rc = dist_share_exit(rc);
done:
    volux_image_free(ctx, &img);
    volux_framebuffer_destroy(fb);
    volux_technique_destroy(tech);
    volux_scene_destroy(scene);
    volux_context_destroy(ctx);
    dist_end();
    return rc;
}
