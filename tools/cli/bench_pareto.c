/*
 * tools/cli/bench_pareto.c — `volux bench SCENE --pareto`: the error–time
 * plane of issue 26 for one scene.
 *
 *  1. Two converged `pathtrace` references (seed + 7919, --ref-spp samples):
 *     single scattering (max_depth 1: the model of single, ao, lightvol and
 *     sh) and all orders (the scene's max_depth: ambient, manylights, guided,
 *     and ea/shaded, which model no scattering but are compared with it).
 *  2. pathtrace's convergence series at both depths: spp 1, 2, 4, … up to
 *     --series-spp; the time of a point is prepare + every render so far.
 *  3. Each technique: prepare (create + deferred refinement) and the first
 *     image (1 spp); a progressive one (manylights, guided) also 2, 4, … up
 *     to --tech-spp. Its error against its own model's reference
 *     (rel_mse_own) and against the all-orders one (rel_mse_full), and the
 *     equal-error speed-up S = T_pathtrace(rel_mse_own) / T_technique from
 *     the series of its own model (pareto_math.h: log-log interpolation,
 *     1/spp past the ends).
 *
 * Output: `volux bench --json` lines (DESIGN §4). Metrics:
 * Times (ms) are process CPU time by default (--clock).
 *   pathtrace: pareto_reference_ms, pareto_series (value rel_mse; spp, ms,
 *     max_depth), pareto_ref_floor (the reference's own noise in rel_mse,
 *     ≈ rel_mse(1 spp)/(ref_spp+1): errors near it are bounded by it);
 *   technique: prepare_ms, first_image_ms, pareto_point (value S; spp, ms,
 *     rel_mse_own, rel_mse_full, pathtrace_ms, where = −1/0/+1 below/in/above
 *     the series) per point, and for its best point pareto_speedup (S),
 *     pareto_speedup_full (S against the all-orders series with rel_mse_full:
 *     how long pathtrace takes to the technique's error against the true
 *     image), pareto_speedup_frame (render times only, both prepared: the
 *     speed-up of a camera orbit), rel_mse_own, rel_mse_full.
 * --reference-dir DIR keeps the references as PFM files and reuses them.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>

#include "pareto_math.h"
#include "scene_args.h"

#define MAX_SERIES 32
#define MAX_TECHS 16

typedef struct pareto_opts {
    int json, ref_spp, series_spp, tech_spp, cpu_clock;
    const char *techniques;
    const char *ref_dir;
} pareto_opts;

typedef struct pareto_out {
    int json;
    const char *scene;
    int threads, width, height;
} pareto_out;

static void emit(const pareto_out *o, const char *technique, const char *metric, double value, const char *unit,
                 const char *extra) {
    if (o->json)
        printf("{\"scene\":\"%s\",\"technique\":\"%s\",\"metric\":\"%s\",\"value\":%.6g,\"unit\":\"%s\","
               "\"threads\":%d,\"width\":%d,\"height\":%d%s%s}\n",
               o->scene, technique, metric, value, unit, o->threads, o->width, o->height, extra ? "," : "",
               extra ? extra : "");
    else
        printf("%-10s %-22s %14.4g %-6s %s\n", technique, metric, value, unit, extra ? extra : "");
    fflush(stdout);
}

/* The clock every time of the plane is read on: the process's CPU time
 * (all threads; --clock cpu, the default: robust against other jobs on a
 * shared machine, and the same thread count for every technique keeps the
 * ratios) or the wall clock (--clock wall). */
static int use_cpu_clock = 1;
static double clock_now_ms(void) {
    if (!use_cpu_clock) return cli_now_ms();
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

/* The model a technique's own error is measured against: 1 = single
 * scattering, 0 = all orders (issue 26). */
static int own_single(const char *t) {
    static const char *const single[] = {"single", "ao", "lightvol", "sh"};
    size_t len = strcspn(t, "+"); /* T+denoise models what T does */
    for (size_t i = 0; i < sizeof single / sizeof single[0]; i++)
        if (strlen(single[i]) == len && !strncmp(t, single[i], len)) return 1;
    return 0;
}

/* The scene with the given technique, depth, spp and seed (the rest as loaded). */
static volux_status set_render(volux_scene *scene, const volux_render_settings *base, const char *technique,
                               int max_depth, int spp, uint64_t seed) {
    volux_render_settings rs = *base;
    snprintf(rs.technique, sizeof rs.technique, "%.*s", (int)sizeof rs.technique - 1, technique);
    rs.max_depth = max_depth;
    rs.spp = spp;
    rs.seed = seed;
    rs.time_ms = 0.0;
    rs.target_error = 0.0;
    return volux_scene_set_render(scene, &rs);
}

/* Creates t and finishes its deferred work; *ms the wall time of both. */
static volux_status prepare(volux_context *ctx, volux_scene *scene, const char *name, volux_technique **t,
                            double *ms) {
    double t0 = clock_now_ms();
    volux_status st = volux_technique_create(ctx, name, scene, t);
    for (int more = 1; !st && more;) st = volux_technique_refine(*t, scene, NULL, &more);
    *ms = clock_now_ms() - t0;
    return st;
}

/* Renders up to `spp` (cumulative in fb), adds the render time to *ms and
 * returns the relative MSE against ref (and against ref2 if given). */
static volux_status render_to(volux_context *ctx, volux_technique *t, volux_scene *scene, volux_framebuffer *fb,
                              uint32_t spp, int denoise, double *ms, const volux_image *ref, double *e,
                              const volux_image *ref2, double *e2, volux_image *keep) {
    volux_render_limits lim = {spp, 0.0, 0.0};
    volux_render_report rep;
    volux_status st = volux_render(t, scene, fb, &lim, &rep);
    if (st) return st;
    *ms += use_cpu_clock ? rep.cpu_ms : rep.ms;
    volux_image img = {0};
    /* A denoised point pays for its filter (on the same clock). */
    double t0 = clock_now_ms();
    st = denoise ? volux_framebuffer_denoise(fb, NULL, &img) : volux_framebuffer_resolve(fb, &img);
    if (denoise) *ms += clock_now_ms() - t0;
    if (st) return st;
    volux_image_error err;
    if (ref && !(st = volux_image_compare(ctx, &img, ref, &err))) *e = err.rel_mse;
    if (!st && ref2 && !(st = volux_image_compare(ctx, &img, ref2, &err))) *e2 = err.rel_mse;
    if (keep && !st) *keep = img;
    else volux_image_free(ctx, &img);
    return st;
}

/* The reference of one depth: loaded from the cache directory or rendered
 * (and then stored there). */
static volux_status reference(volux_context *ctx, volux_scene *scene, const volux_render_settings *base,
                              const pareto_opts *p, const pareto_out *o, int depth, volux_image *out) {
    char path[4096] = "";
    if (p->ref_dir) {
        snprintf(path, sizeof path, "%s/pathtrace_d%d_%dspp_%dx%d.pfm", p->ref_dir, depth, p->ref_spp, base->width,
                 base->height);
        struct stat sb;
        if (!stat(path, &sb)) return volux_image_load(ctx, path, out);
    }
    volux_status st = set_render(scene, base, "pathtrace", depth, p->ref_spp, base->seed + 7919);
    volux_technique *t = NULL;
    volux_framebuffer *fb = NULL;
    double prep = 0.0, ms = 0.0;
    if (!st) st = prepare(ctx, scene, "pathtrace", &t, &prep);
    if (!st) st = volux_framebuffer_create(ctx, base->width, base->height, &fb);
    if (!st) st = render_to(ctx, t, scene, fb, (uint32_t)p->ref_spp, 0, &ms, NULL, NULL, NULL, NULL, out);
    if (!st) {
        char extra[64];
        snprintf(extra, sizeof extra, "\"max_depth\":%d,\"spp\":%d", depth, p->ref_spp);
        emit(o, "pathtrace", "pareto_reference_ms", prep + ms, use_cpu_clock ? "cpu_ms" : "ms", extra);
    }
    if (!st && path[0]) st = volux_image_save(ctx, path, out, 0.0f);
    volux_framebuffer_destroy(fb);
    volux_technique_destroy(t);
    return st;
}

typedef struct pareto_series {
    pareto_point p[MAX_SERIES];
    int n;
    double prepare_ms;
} pareto_series;

/* pathtrace's convergence series at one depth against its reference. */
static volux_status series(volux_context *ctx, volux_scene *scene, const volux_render_settings *base,
                           const pareto_opts *p, const pareto_out *o, int depth, const volux_image *ref,
                           pareto_series *s) {
    volux_status st = set_render(scene, base, "pathtrace", depth, p->series_spp, base->seed);
    volux_technique *t = NULL;
    volux_framebuffer *fb = NULL;
    s->n = 0;
    if (!st) st = prepare(ctx, scene, "pathtrace", &t, &s->prepare_ms);
    if (!st) st = volux_framebuffer_create(ctx, base->width, base->height, &fb);
    double ms = s->prepare_ms;
    for (uint32_t spp = 1; !st && spp <= (uint32_t)p->series_spp && s->n < MAX_SERIES; spp *= 2) {
        double e = 0.0;
        st = render_to(ctx, t, scene, fb, spp, 0, &ms, ref, &e, NULL, NULL, NULL);
        if (st) break;
        s->p[s->n++] = (pareto_point){spp, ms, e};
        char extra[128];
        snprintf(extra, sizeof extra, "\"max_depth\":%d,\"spp\":%u,\"ms\":%.3f", depth, spp, ms);
        emit(o, "pathtrace", "pareto_series", e, "", extra);
    }
    if (!st && s->n) {
        char extra[64];
        snprintf(extra, sizeof extra, "\"max_depth\":%d,\"ref_spp\":%d", depth, p->ref_spp);
        emit(o, "pathtrace", "pareto_ref_floor", s->p[0].rel_mse / (p->ref_spp + 1.0), "", extra);
    }
    volux_framebuffer_destroy(fb);
    volux_technique_destroy(t);
    return st;
}

/* One technique's points, emitted; its best (largest S) as the headline. */
static volux_status measure(volux_context *ctx, volux_scene *scene, const volux_render_settings *base,
                            const pareto_opts *p, const pareto_out *o, const char *row, const volux_image *ref1,
                            const volux_image *reff, const pareto_series *s1, const pareto_series *sf) {
    /* "T+denoise": technique T with its frames denoised (first-hit
     * features on, the filter's time counted). */
    char name[32];
    size_t len = strcspn(row, "+");
    snprintf(name, sizeof name, "%.*s", (int)len, row);
    int denoise = row[len] == '+';
    const volux_technique_info *info = volux_technique_info_find(name);
    int single = own_single(name);
    const volux_image *own = single ? ref1 : reff;
    const pareto_series *so = single ? s1 : sf;
    int max_spp = info && info->progressive ? p->tech_spp : 1;
    volux_status st = set_render(scene, base, name, base->max_depth, max_spp, base->seed);
    volux_technique *t = NULL;
    volux_framebuffer *fb = NULL;
    double prep = 0.0;
    if (!st) st = prepare(ctx, scene, name, &t, &prep);
    if (!st) st = volux_framebuffer_create(ctx, base->width, base->height, &fb);
    if (!st && denoise) st = volux_framebuffer_set_features(fb, 1);
    if (st) goto out;
    emit(o, row, "prepare_ms", prep, use_cpu_clock ? "cpu_ms" : "ms", NULL);
    double ms = prep, best = -2.0, best_full = -1.0, best_frame = -1.0, best_own = 0.0, best_e_full = 0.0,
           best_ms = 0.0;
    uint32_t best_spp = 0;
    for (uint32_t spp = 1; spp <= (uint32_t)max_spp; spp *= 2) {
        double e_own = 0.0, e_full = 0.0;
        if ((st = render_to(ctx, t, scene, fb, spp, denoise, &ms, own, &e_own, reff, &e_full, NULL))) break;
        if (spp == 1) emit(o, row, "first_image_ms", ms - prep, use_cpu_clock ? "cpu_ms" : "ms", NULL);
        int where = 0, where_full = 0, where_frame = 0;
        double S = pareto_speedup(so->p, so->n, so->prepare_ms, e_own, ms, &where);
        /* Per frame, once both are prepared (a camera orbit): render times
         * only, pathtrace's series without its preparation. */
        pareto_point frames[MAX_SERIES];
        for (int k = 0; k < so->n; k++)
            frames[k] = (pareto_point){so->p[k].spp, so->p[k].ms - so->prepare_ms, so->p[k].rel_mse};
        double S_frame = pareto_speedup(frames, so->n, 0.0, e_own, ms - prep, &where_frame);
        double S_full = pareto_speedup(sf->p, sf->n, sf->prepare_ms, e_full, ms, &where_full);
        char extra[384];
        snprintf(extra, sizeof extra,
                 "\"spp\":%u,\"ms\":%.3f,\"rel_mse_own\":%.6g,\"rel_mse_full\":%.6g,\"own_depth\":%d,"
                 "\"pathtrace_ms\":%.3f,\"where\":%d,\"speedup_full\":%.6g,\"speedup_frame\":%.6g",
                 spp, ms, e_own, e_full, single ? 1 : base->max_depth, S > 0 ? S * ms : -1.0, where, S_full,
                 S_frame);
        emit(o, row, "pareto_point", S, "x", extra);
        if (S > best) {
            best = S;
            best_full = S_full;
            best_frame = S_frame;
            best_own = e_own;
            best_e_full = e_full;
            best_ms = ms;
            best_spp = spp;
        }
    }
    if (!st && best_spp) {
        char extra[96];
        snprintf(extra, sizeof extra, "\"spp\":%u,\"ms\":%.3f", best_spp, best_ms);
        emit(o, row, "pareto_speedup", best, "x", extra);
        emit(o, row, "pareto_speedup_full", best_full, "x", extra);
        emit(o, row, "pareto_speedup_frame", best_frame, "x", extra);
        emit(o, row, "rel_mse_own", best_own, "", extra);
        emit(o, row, "rel_mse_full", best_e_full, "", extra);
    }
out:
    volux_framebuffer_destroy(fb);
    volux_technique_destroy(t);
    return st;
}

static void usage(FILE *f) {
    fprintf(f, "usage: volux bench SCENE.json --pareto [--json] [--techniques LIST] [--ref-spp N]\n"
               "                   [--series-spp N] [--tech-spp N] [--reference-dir DIR] [--clock cpu|wall]\n"
               "                   [scene options as for render]\n"
               "The error-time plane (issue 26, docs/CHOOSING.md): pathtrace references (single\n"
               "scattering and all orders, --ref-spp, default 1024), pathtrace's convergence series\n"
               "(spp 1, 2, 4, ... --series-spp, default 64), and per technique (default: ea shaded\n"
               "single ao ambient lightvol sh manylights guided pathtrace+denoise) its prepare and\n"
               "first-image time, its error against its own model and the full one, and the\n"
               "equal-error speed-up S.\n"
               "A name T+denoise (e.g. pathtrace+denoise) measures T's frames through the denoiser.\n"
               "Progressive techniques are measured up to --tech-spp (default 16). Times are process\n"
               "CPU ms (all threads; --clock cpu, the default: robust on a shared machine) or wall ms.\n");
}

int cli_bench_pareto(int argc, char **argv) {
    cli_scene_args args = {0};
    pareto_opts p = {0, 1024, 64, 16, 1, "ea,shaded,single,ao,ambient,lightvol,sh,manylights,guided,pathtrace+denoise", NULL};
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        long v;
        if (!strcmp(a, "-h") || !strcmp(a, "--help")) {
            usage(stdout);
            return CLI_OK;
        } else if (!strcmp(a, "--pareto")) {
            continue;
        } else if (!strcmp(a, "--json")) {
            p.json = 1;
        } else if (!strcmp(a, "--ref-spp") || !strcmp(a, "--series-spp") || !strcmp(a, "--tech-spp")) {
            if (!cli_parse_int("bench", a, i + 1 < argc ? argv[++i] : NULL, 1, 1 << 20, &v)) return CLI_USAGE;
            *(a[2] == 'r' ? &p.ref_spp : a[2] == 's' ? &p.series_spp : &p.tech_spp) = (int)v;
        } else if (!strcmp(a, "--clock")) {
            const char *c = i + 1 < argc ? argv[++i] : "";
            if (strcmp(c, "cpu") && strcmp(c, "wall")) {
                cli_eprintf("volux bench: --clock: expected 'cpu' or 'wall', got '%s'\n", c);
                return CLI_USAGE;
            }
            p.cpu_clock = !strcmp(c, "cpu");
        } else if (!strcmp(a, "--techniques") || !strcmp(a, "--reference-dir")) {
            if (++i >= argc) {
                cli_eprintf("volux bench: %s needs a value\n", a);
                return CLI_USAGE;
            }
            if (a[2] == 't') p.techniques = argv[i];
            else p.ref_dir = argv[i];
        } else {
            int r = cli_scene_arg("bench", &args, argc, argv, &i);
            if (r < 0) return CLI_USAGE;
            if (r == 0) {
                cli_eprintf("volux bench: --pareto: unknown option '%s'\n", a);
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
    /* Every technique name is checked before any work. */
    char names[MAX_TECHS][32];
    int n_names = 0;
    for (const char *c = p.techniques; *c;) {
        size_t len = strcspn(c, ", ");
        if (len) {
            if (n_names == MAX_TECHS || len >= sizeof names[0]) {
                cli_eprintf("volux bench: --techniques: too many or too long names\n");
                return CLI_USAGE;
            }
            memcpy(names[n_names], c, len);
            names[n_names][len] = 0;
            /* T or T+denoise; pathtrace only denoised (raw, it is the series). */
            char *plus = strchr(names[n_names], '+');
            int denoised = plus && !strcmp(plus, "+denoise");
            if (plus) *plus = 0;
            int ok = volux_technique_info_find(names[n_names]) && (!plus || denoised) &&
                     (denoised || strcmp(names[n_names], "pathtrace"));
            if (plus) *plus = '+';
            if (!ok) {
                cli_eprintf("volux bench: --techniques: '%s' is not a technique to compare with pathtrace "
                            "(T, or T+denoise)\n",
                            names[n_names]);
                return CLI_USAGE;
            }
            n_names++;
        }
        c += len;
        while (*c == ',' || *c == ' ') c++;
    }
    if (p.ref_dir) {
        struct stat sb;
        if (stat(p.ref_dir, &sb) || !S_ISDIR(sb.st_mode)) {
            cli_eprintf("volux bench: --reference-dir %s: not a directory\n", p.ref_dir);
            return CLI_USAGE;
        }
    }
    use_cpu_clock = p.cpu_clock;
    volux_context *ctx = cli_context(0);
    if (!ctx) return CLI_FAIL;
    volux_scene *scene = NULL;
    volux_image ref1 = {0}, reff = {0};
    static pareto_series s1, sf;
    volux_status st = VOLUX_OK;
    int rc = cli_load_scene("bench", ctx, &args, &scene);
    if (rc) goto done;
    volux_render_settings base = *volux_scene_render(scene);
    pareto_out o = {p.json, args.scene_path, base.threads > 0 ? base.threads : volux_context_threads(ctx),
                    base.width, base.height};
    int need1 = 0;
    for (int i = 0; i < n_names; i++) need1 |= own_single(names[i]);
    if (need1 && ((st = reference(ctx, scene, &base, &p, &o, 1, &ref1)) ||
                  (st = series(ctx, scene, &base, &p, &o, 1, &ref1, &s1))))
        goto fail;
    if ((st = reference(ctx, scene, &base, &p, &o, base.max_depth, &reff)) ||
        (st = series(ctx, scene, &base, &p, &o, base.max_depth, &reff, &sf)))
        goto fail;
    /* A technique that fails is reported and skipped: the others' rows stay
     * useful (exit 1 at the end). */
    for (int i = 0; i < n_names; i++)
        if ((st = measure(ctx, scene, &base, &p, &o, names[i], &ref1, &reff, &s1, &sf))) {
            rc = cli_fail("bench", ctx, st);
            volux_context_clear_error(ctx);
        }
    goto done;
fail:
    rc = cli_fail("bench", ctx, st);
done:
    volux_image_free(ctx, &ref1);
    volux_image_free(ctx, &reff);
    volux_scene_destroy(scene);
    volux_context_destroy(ctx);
    return rc;
}
