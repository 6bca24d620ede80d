/* tools/cli/render.c — `volux render SCENE.json|VOLUME -o OUT.(png|pfm|exr) [...]`. */
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <strings.h>

#include "tools/mpi/distribute.h"
#include "pareto_math.h"
#include "scene_args.h"

static void usage(FILE *f) {
    fprintf(f,
            "usage: volux render SCENE.json|VOLUME -o OUT.(png|pfm|exr) [--technique T] [--spp N]\n"
            "                    [--width W] [--height H] [--threads N] [--seed S] [--step S]\n"
            "                    [--time-ms MS] [--target-error E] [--max-depth D] [--exposure EV]\n"
            "                    [--time-step N | --all-steps] [--set dotted.path=JSON-value]...\n"
            "                    [--dump-scene OUT.json] [--quiet] [--memory-limit SIZE] [--out-of-core]\n"
            "                    [--distribute image|data]   (under mpirun; image is the default there)\n"
            "                    [--denoise] [--aov LIST]\n"
            "Renders until the scene's spp, time budget or target relative error is reached and\n"
            "writes the image (PNG tone-mapped with render.exposure; PFM/EXR linear).\n"
            "VOLUME (" VOLUX_VOLUME_EXTENSIONS ", or procedural:NAME[:N]) renders its quick-look\n"
            "scene: a transfer function from the histogram, an orbit camera, one key light, `shaded`.\n"
            "--dump-scene writes the scene as read (after --set and defaults) as JSON; without -o it\n"
            "only writes that.\n"
            "--time-ms counts the technique's preparation (creating or updating its caches) too:\n"
            "the render gets what is left of the budget, or one pass when preparing spent it.\n"
            "Non-progressive techniques (ea, shaded, ...) give the same image for every sample: spp > 1\n"
            "renders that many jittered passes (anti-aliasing). Ctrl-C (or SIGTERM) stops a render and\n"
            "writes the samples so far (spp in the message and in PNG/EXR metadata), exit 130 (143);\n"
            "a second Ctrl-C aborts at once.\n"
            "Before any cache is built the render's memory is estimated (volume, technique caches,\n"
            "framebuffer, image; docs/SCALE.md); above --memory-limit (default 80%% of physical memory;\n"
            "SIZE like 8G, 512M, or none) it stops with exit 2 and writes nothing.\n"
            "--out-of-core maps an uncompressed native-order uint8/uint16/float32 volume file instead\n"
            "of reading it, and keeps its bricked copy in a temporary file ($TMPDIR or /var/tmp): the\n"
            "kernel pages both, so a volume larger than memory renders (other files: read, warning).\n"
            "--time-step N renders step N of a time-varying volume (render.time_step).\n"
            "--all-steps renders every step into numbered files: OUT_0000.png, OUT_0001.png, ...,\n"
            "or OUT's own printf number (-o frame%%03d.png); one technique instance is updated\n"
            "from step to step, as in an animation.\n"
            "Under mpirun the ranks share the frame's tiles and render.spp samples are taken\n"
            "(time and error limits apply to a single process only); rank 0 writes the image,\n"
            "bit-identical to a single-process render. There Ctrl-C ends the job as mpirun does.\n"
            "--distribute data (ea, shaded; a scene file with its own transfer function): rank r\n"
            "loads only brick r of the volume (a k-d split into N bricks, 2 ghost layers), renders it\n"
            "on the whole volume's sample lattice, and the bricks are composited front to back in\n"
            "visibility order (docs/DISTRIBUTED.md; matches one process within 2e-3).\n"
            "--denoise writes the image through the denoiser (volux/denoise.h: an edge-avoiding a-trous\n"
            "filter guided by first-hit features and the per-pixel variance, blended back to the raw\n"
            "accumulation as its error falls); an EXR keeps the raw accumulation as layer raw.R/G/B.\n"
            "--aov LIST (EXR only) adds first-hit feature layers, comma-separated from: depth (Z),\n"
            "albedo (albedo.R/G/B), normal (normal.X/Y/Z), coverage (A), density (density.Y),\n"
            "variance (variance.Y: of each pixel mean's luminance), or all. Features come from\n"
            "pathtrace and guided; other techniques write variance only (docs/techniques/pathtrace.md).\n");
}

static void format_error(double e, char *out, size_t n) {
    if (e < 0.0) snprintf(out, n, "n/a");
    else snprintf(out, n, "%.3g", e);
}

/* The output file of step `step`: OUT's printf number, or _%04d before the
 * extension. 0 if the name does not fit. */
static int step_path(const char *out, int has_pattern, int step, char *buf, size_t n) {
    int w;
    if (has_pattern) {
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wformat-nonliteral"
        w = snprintf(buf, n, out, step); /* checked by volux_sequence_pattern_conversions */
#pragma GCC diagnostic pop
    } else {
        const char *dot = strrchr(out, '.');
        w = snprintf(buf, n, "%.*s_%04d%s", (int)(dot - out), out, step, dot);
    }
    return w >= 0 && (size_t)w < n;
}

/* --aov names → bits. */
enum { AOV_DEPTH = 1, AOV_ALBEDO = 2, AOV_NORMAL = 4, AOV_COVERAGE = 8, AOV_DENSITY = 16, AOV_VARIANCE = 32 };
static const char *const aov_names[] = {"depth", "albedo", "normal", "coverage", "density", "variance", NULL};

static int parse_aovs(const char *list, unsigned *bits) {
    *bits = 0;
    char buf[256];
    if (!list || snprintf(buf, sizeof buf, "%s", list) >= (int)sizeof buf) return 0;
    for (char *save = NULL, *t = strtok_r(buf, ",", &save); t; t = strtok_r(NULL, ",", &save)) {
        if (!strcmp(t, "all")) {
            *bits |= 63u;
            continue;
        }
        int k = 0;
        while (aov_names[k] && strcmp(aov_names[k], t)) k++;
        if (!aov_names[k]) {
            const char *guess = volux_name_closest(t, (const char *const *)aov_names);
            cli_eprintf("volux render: --aov: unknown layer '%s'%s%s%s (known: depth, albedo, normal, coverage, "
                        "density, variance, all)\n",
                        t, guess ? "; did you mean '" : "", guess ? guess : "", guess ? "'?" : "");
            return 0;
        }
        *bits |= 1u << k;
    }
    return *bits != 0;
}

/* Writes img (denoised when `denoised`) with the layers asked for. */
static volux_status save_output(volux_context *ctx, const char *out, const volux_image *img, const volux_image *raw,
                                volux_framebuffer *fb, unsigned aovs, float exposure, const volux_image_meta *meta) {
    volux_image_layer layers[8];
    int n = 0;
    volux_features f;
    memset(&f, 0, sizeof f);
    volux_status st = VOLUX_OK;
    if (raw) layers[n++] = (volux_image_layer){"raw", 3, {"R", "G", "B", NULL}, raw->rgb};
    if (aovs) {
        if ((st = volux_framebuffer_resolve_features(fb, &f))) return st;
        if (!f.depth && (aovs & ~(unsigned)AOV_VARIANCE))
            cli_eprintf("volux render: note: the technique records no first-hit features (pathtrace and guided "
                        "do); of the --aov layers only variance is written\n");
        if (f.depth && (aovs & AOV_DEPTH)) layers[n++] = (volux_image_layer){NULL, 1, {"Z", NULL, NULL, NULL}, f.depth};
        if (f.albedo && (aovs & AOV_ALBEDO))
            layers[n++] = (volux_image_layer){"albedo", 3, {"R", "G", "B", NULL}, f.albedo};
        if (f.normal && (aovs & AOV_NORMAL))
            layers[n++] = (volux_image_layer){"normal", 3, {"X", "Y", "Z", NULL}, f.normal};
        if (f.coverage && (aovs & AOV_COVERAGE))
            layers[n++] = (volux_image_layer){NULL, 1, {"A", NULL, NULL, NULL}, f.coverage};
        if (f.density && (aovs & AOV_DENSITY))
            layers[n++] = (volux_image_layer){"density", 1, {"Y", NULL, NULL, NULL}, f.density};
        if (aovs & AOV_VARIANCE) layers[n++] = (volux_image_layer){"variance", 1, {"Y", NULL, NULL, NULL}, f.variance};
    }
    /* A PNG or PFM gets the image alone (the layers need EXR; checked
     * before the render). */
    const char *dot = strrchr(out, '.');
    int exr = dot && !strcasecmp(dot, ".exr");
    st = volux_image_save_layers(ctx, out, img, exposure, meta, layers, exr ? n : 0);
    volux_features_free(ctx, &f);
    return st;
}

int cli_render(int argc, char **argv) {
    cli_scene_args args;
    memset(&args, 0, sizeof args);
    const char *out_path = NULL;
    int all_steps = 0, one_step = 0, denoise = 0;
    unsigned aovs = 0;
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
            args.quiet = 1;
            continue;
        }
        if (!strcmp(argv[i], "--all-steps")) {
            all_steps = 1;
            continue;
        }
        if (!strcmp(argv[i], "--denoise")) {
            denoise = 1;
            continue;
        }
        if (!strcmp(argv[i], "--aov")) {
            if (++i >= argc) {
                cli_eprintf("volux render: --aov needs a list (depth,albedo,normal,coverage,density,variance|all)\n");
                return CLI_USAGE;
            }
            if (!parse_aovs(argv[i], &aovs)) return CLI_USAGE;
            continue;
        }
        if (!strcmp(argv[i], "--time-step")) one_step = 1;
        int r = cli_scene_arg("render", &args, argc, argv, &i);
        if (r < 0) return CLI_USAGE;
        if (r == 0) {
            static const char *const options[] = {"--output", "--distribute", "--quiet", "--all-steps", "--help",
                                                  "--dump-scene", "--technique", "--spp", "--width", "--height",
                                                  "--threads", "--seed", "--step", "--exposure", "--time-ms",
                                                  "--target-error", "--max-depth", "--time-step", "--set", "--denoise",
                                                  "--aov", NULL};
            const char *guess = volux_name_closest(argv[i], options);
            cli_eprintf("volux render: unknown option '%s'%s%s%s\n", argv[i], guess ? "; did you mean '" : "",
                        guess ? guess : "", guess ? "'?" : "");
            usage(stderr);
            return CLI_USAGE;
        }
    }
    if (!args.scene_path || (!out_path && !args.dump_path)) {
        cli_eprintf("volux render: %s\n",
                !args.scene_path ? "missing SCENE.json (or a volume)" : "missing -o OUT.png|pfm|exr");
        usage(stderr);
        return CLI_USAGE;
    }
    if (all_steps && one_step) {
        cli_eprintf("volux render: give --time-step or --all-steps, not both\n");
        return CLI_USAGE;
    }
    if (aovs && out_path) {
        const char *dot = strrchr(out_path, '.');
        if (!dot || strcasecmp(dot, ".exr")) {
            cli_eprintf("volux render: --aov %s: feature layers need an OpenEXR output (-o OUT.exr)\n", out_path);
            return CLI_USAGE;
        }
    }
    int pattern = out_path ? volux_sequence_pattern_conversions(out_path) : 0; /* 1: a numbered output */
    if (pattern < 0 || pattern > 1 || (pattern && !all_steps)) {
        cli_eprintf("volux render: -o %s: %s\n", out_path,
                pattern != 1 ? "a numbered output holds one %d, %Nd or %0Nd (%% for a literal %)"
                            : "a numbered output (%d) needs --all-steps");
        return CLI_USAGE;
    }
    int mode = dist_begin("render", distribute);
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
    /* --quiet silences progress, not warnings and notes; other ranks repeat
     * rank 0's messages, so only rank 0 prints them */
    if (args.quiet) cli_quiet_progress();
    if (dist_rank() > 0) volux_context_set_progress(ctx, NULL, NULL);
    if (dist_rank() > 0) volux_context_set_message(ctx, NULL, NULL);
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
    if (!rc && args.dump_path && out_path && cli_same_file(args.dump_path, out_path)) {
        snprintf(msg, sizeof msg, "--dump-scene %s: the same file as -o (the scene would replace the image)",
                 args.dump_path);
        rc = CLI_USAGE;
    }
    if ((rc = dist_agree_msg("render", rc, msg))) goto done;
    /* One process: Ctrl-C keeps the image so far. Under mpirun the ranks
     * would have to agree on where to stop; the job ends as mpirun ends it. */
    if (dist_size() == 1) cli_catch_interrupts();
    rc = cli_load_scene_quiet("render", ctx, &args, &scene, msg, sizeof msg);
    if (rc && cli_interrupted()) rc = 128 + cli_interrupted();
    if ((rc = dist_agree_msg("render", rc, msg))) goto done;
    if (mode == DIST_DATA && (rc = dist_agree("render", ctx, dist_share_stats(scene)))) goto done;
    if (dist_rank() == 0 && !args.quiet) cli_print_notes("render", scene);
    if (!out_path) goto done; /* --dump-scene only */
    const volux_render_settings *rs = volux_scene_render(scene);
    const volux_technique_info *info = volux_technique_info_find(rs->technique);
    int first = volux_scene_time_step(scene), last = all_steps ? volux_scene_time_steps(scene) - 1 : first;
    if (all_steps) first = 0;
    for (int step = first; step <= last && !rc; step++) {
        char path[4096];
        const char *out = out_path;
        if (all_steps) {
            if (!step_path(out_path, pattern, step, path, sizeof path)) {
                if (dist_rank() == 0) cli_eprintf("volux render: -o %s: output name too long\n", out_path);
                rc = CLI_USAGE;
                goto done;
            }
            out = path;
        }
        /* The first step creates the technique; later steps are edits it
         * updates (the accumulation restarts). */
        double t0 = cli_now_ms();
        st = volux_scene_set_time_step(scene, step);
        if (!st) {
            if (!tech) st = volux_technique_create(ctx, rs->technique, scene, &tech);
            else st = volux_technique_update(tech, scene, NULL);
        }
        /* A progressive technique's deferred work is finished: an image file
         * is the final result, not the first frame of an interactive session. */
        for (int more = 1; !st && more;) st = volux_technique_refine(tech, scene, NULL, &more);
        double prepare_ms = cli_now_ms() - t0;
        if (!st && !fb) {
            st = volux_framebuffer_create(ctx, rs->width, rs->height, &fb);
            /* First-hit features guide the denoiser and are the AOVs. */
            if (!st && (denoise || aovs)) st = volux_framebuffer_set_features(fb, 1);
        } else if (!st) {
            volux_framebuffer_reset(fb);
        }
        if (st == VOLUX_ERR_CANCELLED && cli_interrupted()) {
            cli_eprintf("volux render: interrupted while preparing; nothing written\n");
            rc = 128 + cli_interrupted();
            goto done;
        }
        if ((rc = dist_agree("render", ctx, st))) goto done;
        dist_timing timing;
        /* --time-ms covers the preparation above too (issue 26: a 120 s
         * budget once ran 222 s): the render gets what is left of it, and
         * one complete pass when the preparation used it all. Under mpirun
         * the time limit does not apply (see usage). */
        int one_pass = 0;
        double left_ms = pareto_remaining_budget(rs->time_ms, prepare_ms, &one_pass);
        if (rs->time_ms > 0.0 && mode == DIST_NONE && dist_size() == 1) {
            volux_render_limits lim = {one_pass ? 1u : (uint32_t)rs->spp, left_ms, rs->target_error};
            if (one_pass && !args.quiet)
                cli_eprintf("volux render: note: preparing took %.0f ms of the %g ms budget; rendering one pass\n",
                        prepare_ms, rs->time_ms);
            memset(&timing, 0, sizeof timing);
            volux_render_report rep = {0};
            st = volux_render(tech, scene, fb, &lim, &rep);
            timing.render_ms = timing.rank_render_ms_min = timing.rank_render_ms_max = rep.ms;
        } else {
            st = mode == DIST_DATA ? dist_render_data(tech, scene, fb, &timing)
                                   : dist_render_image(tech, scene, fb, &timing);
        }
        int stopped = st == VOLUX_ERR_CANCELLED && cli_interrupted();
        if (stopped && volux_framebuffer_spp(fb) == 0) {
            cli_eprintf("volux render: interrupted before the first sample of every pixel; nothing written\n");
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
                snprintf(v, sizeof v, "%.2f", (double)rs->exposure);
                volux_image_meta_set(&meta, "volux.exposure", v); /* PNG: the ×2^EV applied */
                snprintf(v, sizeof v, "%u", volux_framebuffer_spp(fb));
                volux_image_meta_set(&meta, "volux.spp", v);
                snprintf(v, sizeof v, "%d", rs->spp);
                volux_image_meta_set(&meta, "volux.spp_target", v);
                format_error(rel_error, v, sizeof v);
                volux_image_meta_set(&meta, "volux.rel_error", v);
                volux_image_meta_set(&meta, "volux.interrupted", stopped ? "true" : "false");
                snprintf(v, sizeof v, "%d", step);
                if (volux_scene_time_steps(scene) > 1) volux_image_meta_set(&meta, "volux.time_step", v);
                /* A second Ctrl-C while the file is written waits for the
                 * rename, so it never leaves a temporary file behind. */
                volux_image shown = {0};
                if (denoise) {
                    volux_image_meta_set(&meta, "volux.denoised", "true");
                    st = volux_framebuffer_denoise(fb, NULL, &shown);
                }
                cli_hold_interrupts(1);
                if (!st)
                    st = save_output(ctx, out, denoise ? &shown : &img, denoise ? &img : NULL, fb, aovs,
                                     rs->exposure, &meta);
                cli_hold_interrupts(0);
                volux_image_free(ctx, &shown);
            }
            volux_image_free(ctx, &img);
            rc = st ? cli_fail("render", ctx, st) : CLI_OK;
            char err[32];
            format_error(rel_error, err, sizeof err);
            if (!rc && stopped) {
                cli_eprintf("volux render: interrupted at %u of %d spp (rel. error %s): wrote %s\n",
                        volux_framebuffer_spp(fb), rs->spp, err, out);
                rc = 128 + cli_interrupted();
            } else if (!rc && !args.quiet) {
                /* A technique that is not progressive gives the same image for
                 * every sample index but the pixel jitter: say what spp > 1 did. */
                uint32_t spp = volux_framebuffer_spp(fb);
                const char *what = info && !info->progressive && spp > 1 ? " (anti-aliasing passes)" : "";
                cli_eprintf("volux render: %s: ", args.scene_path);
                if (all_steps) cli_eprintf("step %d/%d: ", step, last + 1);
                cli_eprintf("%s %dx%d, %u spp%s, %s %.1f ms, render %.1f ms", rs->technique, rs->width,
                        rs->height, spp, what, step == first ? "prepare" : "update", prepare_ms, timing.render_ms);
                if (rs->time_ms > 0.0 && dist_size() == 1)
                    cli_eprintf(" (budget %g ms: %.1f ms left after preparing%s)", rs->time_ms, left_ms,
                            one_pass ? ", spent: one pass" : "");
                if (dist_size() > 1)
                    cli_eprintf(" (%d ranks, %.1f-%.1f ms each, composite %.1f ms)", dist_size(),
                            timing.rank_render_ms_min, timing.rank_render_ms_max, timing.composite_ms);
                cli_eprintf(", rel. error %s -> %s\n", err, out);
            }
        }
        rc = dist_share_exit(rc);
    }
done:
    volux_image_free(ctx, &img);
    volux_framebuffer_destroy(fb);
    volux_technique_destroy(tech);
    volux_scene_destroy(scene);
    volux_context_destroy(ctx);
    dist_end();
    return rc;
}
