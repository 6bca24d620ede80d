/* tools/cli/render.c — `volux render SCENE.json|VOLUME -o OUT.(png|pfm|exr) [...]`. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "tools/mpi/distribute.h"
#include "scene_args.h"

static void usage(FILE *f) {
    fprintf(f,
            "usage: volux render SCENE.json|VOLUME -o OUT.(png|pfm|exr) [--technique T] [--spp N]\n"
            "                    [--width W] [--height H] [--threads N] [--seed S] [--step S]\n"
            "                    [--time-ms MS] [--target-error E] [--max-depth D] [--exposure EV]\n"
            "                    [--set dotted.path=JSON-value]... [--dump-scene OUT.json] [--quiet]\n"
            "                    [--distribute image]   (under mpirun; the default there)\n"
            "Renders until the scene's spp, time budget or target relative error is reached and\n"
            "writes the image (PNG tone-mapped with render.exposure; PFM/EXR linear).\n"
            "VOLUME (.nrrd .nhdr .mhd .mha .nii .nii.gz, or procedural:NAME[:N]) renders its quick-look\n"
            "scene: a transfer function from the histogram, an orbit camera, one key light, `shaded`.\n"
            "--dump-scene writes the scene as read (after --set and defaults) as JSON; without -o it\n"
            "only writes that.\n"
            "Non-progressive techniques (ea, shaded, ...) give the same image for every sample: spp > 1\n"
            "renders that many jittered passes (anti-aliasing). Ctrl-C (or SIGTERM) stops a render and\n"
            "writes the samples so far (spp in the message and in PNG/EXR metadata), exit 130 (143);\n"
            "a second Ctrl-C aborts at once.\n"
            "Under mpirun the ranks share the frame's tiles and render.spp samples are taken\n"
            "(time and error limits apply to a single process only); rank 0 writes the image,\n"
            "bit-identical to a single-process render. There Ctrl-C ends the job as mpirun does.\n");
}

static void format_error(double e, char *out, size_t n) {
    if (e < 0.0) snprintf(out, n, "n/a");
    else snprintf(out, n, "%.3g", e);
}

int cli_render(int argc, char **argv) {
    cli_scene_args args;
    memset(&args, 0, sizeof args);
    const char *out_path = NULL;
    dist_mode distribute = DIST_NONE;
    dist_quiet_followers();
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "-h") || !strcmp(argv[i], "--help")) {
            usage(stdout);
            return CLI_OK;
        }
        if (!strcmp(argv[i], "-o") || !strcmp(argv[i], "--output")) {
            if (++i >= argc) {
                fprintf(stderr, "volux render: -o needs a file name\n");
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
            args.quiet = 1;
            continue;
        }
        int r = cli_scene_arg("render", &args, argc, argv, &i);
        if (r < 0) return CLI_USAGE;
        if (r == 0) {
            fprintf(stderr, "volux render: unknown option '%s'\n", argv[i]);
            usage(stderr);
            return CLI_USAGE;
        }
    }
    if (!args.scene_path || (!out_path && !args.dump_path)) {
        fprintf(stderr, "volux render: %s\n",
                !args.scene_path ? "missing SCENE.json (or a volume)" : "missing -o OUT.png|pfm|exr");
        usage(stderr);
        return CLI_USAGE;
    }
    int mode = dist_begin("render", distribute);
    if (mode < 0) return CLI_USAGE;
    if (mode == DIST_DATA) {
        fprintf(stderr, "volux render: --distribute data: not available yet (use image)\n");
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
    /* Everything about the outputs is checked before any work (every rank
     * checks; one message). */
    volux_status st = out_path ? volux_image_check_output(ctx, out_path) : VOLUX_OK;
    int rc = dist_agree("render", ctx, st);
    if (rc) goto done;
    rc = args.dump_path && !cli_check_writable("--dump-scene", args.dump_path, msg, sizeof msg) ? CLI_USAGE : CLI_OK;
    if ((rc = dist_agree_msg("render", rc, msg))) goto done;
    /* One process: Ctrl-C keeps the image so far. Under mpirun the ranks
     * would have to agree on where to stop; the job ends as mpirun ends it. */
    if (dist_size() == 1) cli_catch_interrupts();
    rc = cli_load_scene_quiet("render", ctx, &args, &scene, msg, sizeof msg);
    if (rc && cli_interrupted()) rc = 128 + cli_interrupted();
    if ((rc = dist_agree_msg("render", rc, msg))) goto done;
    if (dist_rank() == 0 && !args.quiet) cli_print_notes("render", scene);
    if (!out_path) goto done; /* --dump-scene only */
    const volux_render_settings *rs = volux_scene_render(scene);
    const volux_technique_info *info = volux_technique_info_find(rs->technique);
    double t0 = cli_now_ms();
    st = volux_technique_create(ctx, rs->technique, scene, &tech);
    /* A progressive technique's deferred work is finished: an image file
     * is the final result, not the first frame of an interactive session. */
    for (int more = 1; !st && more;) st = volux_technique_refine(tech, scene, NULL, &more);
    double prepare_ms = cli_now_ms() - t0;
    if (!st) st = volux_framebuffer_create(ctx, rs->width, rs->height, &fb);
    if (st == VOLUX_ERR_CANCELLED && cli_interrupted()) {
        fprintf(stderr, "volux render: interrupted while preparing; nothing written\n");
        rc = 128 + cli_interrupted();
        goto done;
    }
    if ((rc = dist_agree("render", ctx, st))) goto done;
    dist_timing timing;
    st = dist_render_image(tech, scene, fb, &timing);
    int stopped = st == VOLUX_ERR_CANCELLED && cli_interrupted();
    if (stopped && volux_framebuffer_spp(fb) == 0) {
        fprintf(stderr, "volux render: interrupted before the first sample of every pixel; nothing written\n");
        rc = 128 + cli_interrupted();
        goto done;
    }
    if (stopped) st = VOLUX_OK; /* the samples so far are the image */
    if ((rc = dist_agree("render", ctx, st))) goto done;
    if (dist_rank() == 0) {
        double rel_error = volux_framebuffer_rel_error(fb);
        st = volux_framebuffer_resolve(fb, &img);
        if (!st) {
            /* How the image was made, in the file (PNG text, EXR attributes). */
            volux_image_meta meta;
            memset(&meta, 0, sizeof meta);
            char v[64];
            volux_image_meta_set(&meta, "Software", "volux " VOLUX_VERSION);
            volux_image_meta_set(&meta, "volux.scene", args.scene_path);
            volux_image_meta_set(&meta, "volux.technique", rs->technique);
            snprintf(v, sizeof v, "%u", volux_framebuffer_spp(fb));
            volux_image_meta_set(&meta, "volux.spp", v);
            snprintf(v, sizeof v, "%d", rs->spp);
            volux_image_meta_set(&meta, "volux.spp_target", v);
            format_error(rel_error, v, sizeof v);
            volux_image_meta_set(&meta, "volux.rel_error", v);
            volux_image_meta_set(&meta, "volux.interrupted", stopped ? "true" : "false");
            /* A second Ctrl-C while the file is written waits for the
             * rename, so it never leaves a temporary file behind. */
            cli_hold_interrupts(1);
            st = volux_image_save_meta(ctx, out_path, &img, rs->exposure, &meta);
            cli_hold_interrupts(0);
        }
        rc = st ? cli_fail("render", ctx, st) : CLI_OK;
        char err[32];
        format_error(rel_error, err, sizeof err);
        if (!rc && stopped) {
            fprintf(stderr, "volux render: interrupted at %u of %d spp (rel. error %s): wrote %s\n",
                    volux_framebuffer_spp(fb), rs->spp, err, out_path);
            rc = 128 + cli_interrupted();
        } else if (!rc && !args.quiet) {
            /* A technique that is not progressive gives the same image for
             * every sample index but the pixel jitter: say what spp > 1 did. */
            uint32_t spp = volux_framebuffer_spp(fb);
            const char *what = info && !info->progressive && spp > 1 ? " (anti-aliasing passes)" : "";
            fprintf(stderr, "volux render: %s: %s %dx%d, %u spp%s, prepare %.1f ms, render %.1f ms", args.scene_path,
                    rs->technique, rs->width, rs->height, spp, what, prepare_ms, timing.render_ms);
            if (dist_size() > 1)
                fprintf(stderr, " (%d ranks, %.1f-%.1f ms each, composite %.1f ms)", dist_size(),
                        timing.rank_render_ms_min, timing.rank_render_ms_max, timing.composite_ms);
            fprintf(stderr, ", rel. error %s -> %s\n", err, out_path);
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
