/*
 * tools/cli/ambient_table.c — `volux ambient-table`: build, inspect or
 * verify the preintegration table of ambient volume scattering.
 *
 *   volux ambient-table -o FILE [--builtin] [--albedo A[,A...]|set] [--theta N]
 *                       [--sigma N] [--g N] [--sigma-max S] [--g-min G]
 *                       [--g-max G] [--paths N] [--seed S] [--threads N] [--json]
 *   volux ambient-table --info FILE [--json]
 *   volux ambient-table --strip FILE -o OUT
 *   volux ambient-table --slices OUT [--table FILE] [--slice-g G[,G...]]
 *                       [--slice-albedo A] [--slice-size N] [--reference WALKS]
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"

static void usage(FILE *f) {
    fprintf(f,
            "usage: volux ambient-table -o FILE [--builtin] [--albedo A[,A...]|set] [--theta N]\n"
            "                           [--sigma N] [--g N] [--sigma-max S] [--g-min G] [--g-max G]\n"
            "                           [--paths N] [--seed S] [--threads N] [--json]\n"
            "       volux ambient-table --info FILE [--json]\n"
            "       volux ambient-table --strip FILE -o OUT\n"
            "       volux ambient-table --slices OUT [--table FILE] [--slice-g G[,G...]]\n"
            "                           [--slice-albedo A] [--slice-size N] [--reference WALKS]\n"
            "Builds the preintegration table of ambient volume scattering (Ament et al. 2013,\n"
            "Sec. 4.1) by Monte-Carlo path tracing and writes it to FILE (defaults: the paper's\n"
            "256 x 256 x 19 entries, sigma in [0, 20], g in [-0.9, 0.9], albedo 0.9), or prints\n"
            "the header and noise of an existing table. --albedo takes one albedo, a list of\n"
            "increasing ones (an albedo axis, interpolated by the technique) or 'set' (0, 0.1,\n"
            "..., 0.9, 0.95, 1). --builtin starts from the description of the table built into\n"
            "the library (64 x 64 x 10, the albedo set; how src/techniques/ambient/\n"
            "builtin_table.vxat is made). --paths is the number of random walks per (sigma, g,\n"
            "albedo) column; every walk scores every theta entry. --strip copies a table without\n"
            "its per-entry error block (half the size).\n"
            "--slices draws slices of a table as the paper's Fig. 5 does: radiance over theta\n"
            "(left 0 to right pi) and sigma (bottom 0 to top the table's maximum), one slice per\n"
            "g (default -0.8,0,0.8) side by side at --slice-albedo (0.9), --slice-size N\n"
            "points per axis (64), read from --table FILE (default: the built-in table) as the\n"
            "technique reads it. OUT .png: log10 radiance in false colour over [-4, 1] (violet\n"
            "to yellow); .pfm/.exr: the linear values (for volux compare). --reference WALKS\n"
            "estimates the same points with the paper's own estimator instead (WALKS random\n"
            "walks per point from x_o, slow).\n");
}

/* "0.9" or "0,0.1,...": the albedos, comma-separated. */
static void albedo_list(const volux_ambient_table_desc *d, char *buf, size_t size) {
    size_t at = 0;
    buf[0] = 0;
    for (int i = 0; i < d->n_albedo && at < size; i++)
        at += (size_t)snprintf(buf + at, size - at, "%s%g", i ? "," : "", d->albedo[i]);
}

/* --albedo: one value, a comma-separated increasing list, or "set". */
static int parse_albedos(const char *v, volux_ambient_table_desc *d) {
    if (v && !strcmp(v, "set")) {
        volux_ambient_table_desc_albedo_set(d);
        return 1;
    }
    char buf[512];
    if (!v || strlen(v) >= sizeof buf) {
        cli_eprintf("volux ambient-table: --albedo: expected a number, a list or 'set', got '%s'\n",
                v ? v : "(missing)");
        return 0;
    }
    snprintf(buf, sizeof buf, "%s", v);
    int n = 0;
    for (char *save = NULL, *tok = strtok_r(buf, ",", &save); tok; tok = strtok_r(NULL, ",", &save)) {
        double x;
        if (n == VOLUX_AMBIENT_TABLE_MAX_ALBEDO) {
            cli_eprintf("volux ambient-table: --albedo: at most %d albedos\n", VOLUX_AMBIENT_TABLE_MAX_ALBEDO);
            return 0;
        }
        if (!cli_parse_double("ambient-table", "--albedo", tok, &x)) return 0;
        d->albedo[n++] = x;
    }
    if (!n) return cli_parse_double("ambient-table", "--albedo", "", &d->albedo[0]);
    d->n_albedo = n;
    return 1; /* range and order are checked with the rest of the description */
}

static void report(const char *path, const volux_ambient_table_summary *t, int json, int threads) {
    const volux_ambient_table_desc *d = &t->desc;
    const volux_ambient_table_noise *nz = &t->noise;
    char albedos[512];
    albedo_list(d, albedos, sizeof albedos);
    if (json) {
        printf("{\"file\":\"%s\",\"n_theta\":%d,\"n_sigma\":%d,\"n_g\":%d,\"sigma_max\":%g,\"g_min\":%g,"
               "\"g_max\":%g,\"albedo\":[%s],\"paths\":%llu,\"seed\":%llu,\"build_ms\":%.1f,\"threads\":%d",
               path, d->n_theta, d->n_sigma, d->n_g, d->sigma_max, d->g_min, d->g_max, albedos,
               (unsigned long long)d->paths, (unsigned long long)d->seed, t->build_ms, threads);
        if (t->has_noise)
            printf(",\"rel_error\":{\"median\":%.4g,\"p90\":%.4g,\"p99\":%.4g,\"max\":%.4g,\"mean\":%.4g,"
                   "\"entries\":%llu}",
                   nz->median, nz->p90, nz->p99, nz->max, nz->mean, (unsigned long long)nz->entries);
        printf("}\n");
        return;
    }
    printf("%s: %d x %d x %d entries (theta x sigma x g), sigma in [0, %g], g in [%g, %g], albedo %s\n", path,
           d->n_theta, d->n_sigma, d->n_g, d->sigma_max, d->g_min, d->g_max, albedos);
    printf("  %llu walks per column, seed %llu, built in %.1f s\n", (unsigned long long)d->paths,
           (unsigned long long)d->seed, t->build_ms * 1e-3);
    if (t->has_noise) /* entries above VOLUX_AMBIENT_TABLE_NOISE_FLOOR */
        printf("  relative standard error per entry: median %.3g, p90 %.3g, p99 %.3g, max %.3g (%llu entries > 1e-6)\n",
               nz->median, nz->p90, nz->p99, nz->max, (unsigned long long)nz->entries);
}

#define SLICE_MAX_G 8
#define SLICE_LOG_MIN (-4.0) /* the PNG's colour range, log10 radiance */
#define SLICE_LOG_MAX 1.0

/* The Fig. 5 slices side by side (one per g, a 2-pixel black gap). */
static int write_slices(volux_context *ctx, const char *out, const char *table, const double *g, int n_g,
                        double albedo, int n, uint64_t reference) {
    const char *ext = strrchr(out, '.');
    int png = ext && !strcmp(ext, ".png");
    volux_status st = volux_image_check_output(ctx, out);
    if (st) return cli_fail("ambient-table", ctx, st);
    const int gap = 2, width = n_g * n + (n_g - 1) * gap;
    float *v = malloc((size_t)n * n * sizeof *v);
    volux_image img = {0};
    if (!v || volux_image_create(ctx, width, n, &img)) {
        free(v);
        cli_eprintf("volux ambient-table: out of memory for the slices\n");
        return CLI_FAIL;
    }
    memset(img.rgb, 0, (size_t)width * n * 3 * sizeof(float));
    double lo = INFINITY, hi = -INFINITY;
    for (int k = 0; k < n_g && !st; k++) {
        if ((st = volux_ambient_table_slice(ctx, table, g[k], albedo, n, n, reference, v))) break;
        for (int is = 0; is < n; is++)
            for (int it = 0; it < n; it++) {
                double x = v[(size_t)is * n + it];
                float *px = img.rgb + 3 * ((size_t)(n - 1 - is) * width + (size_t)k * (n + gap) + it);
                lo = x < lo ? x : lo, hi = x > hi ? x : hi;
                if (png) cli_ramp_color((log10(x > 1e-30 ? x : 1e-30) - SLICE_LOG_MIN) / (SLICE_LOG_MAX - SLICE_LOG_MIN), px);
                else px[0] = px[1] = px[2] = (float)x;
            }
    }
    if (!st) st = volux_image_save(ctx, out, &img, 0.0f);
    volux_image_free(ctx, &img);
    free(v);
    if (st) return cli_fail("ambient-table", ctx, st);
    printf("%s: %d slice%s of %d x %d (theta x sigma), albedo %g, %s; radiance %.3g ... %.3g\n", out, n_g,
           n_g > 1 ? "s" : "", n, n, albedo, reference ? "the paper's estimator" : table ? table : "built-in table",
           lo, hi);
    return CLI_OK;
}

int cli_ambient_table(int argc, char **argv) {
    volux_ambient_table_desc d;
    volux_ambient_table_desc_defaults(&d);
    const char *out = NULL, *info = NULL, *strip = NULL, *slices = NULL, *table = NULL;
    double slice_g[SLICE_MAX_G] = {-0.8, 0.0, 0.8}, slice_albedo = 0.9;
    int n_slice_g = 3;
    long slice_size = 64, reference = 0;
    int json = 0;
    long threads = 0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        long n;
        double x;
        if (!strcmp(a, "-h") || !strcmp(a, "--help")) {
            usage(stdout);
            return CLI_OK;
        } else if (!strcmp(a, "--json")) {
            json = 1;
        } else if (!strcmp(a, "--builtin")) {
            volux_ambient_table_desc_builtin(&d); /* options after it adjust it */
        } else if (!strcmp(a, "-o") || !strcmp(a, "--output") || !strcmp(a, "--info") || !strcmp(a, "--strip") ||
                   !strcmp(a, "--slices") || !strcmp(a, "--table")) {
            if (!v) {
                cli_eprintf("volux ambient-table: %s needs a file name\n", a);
                return CLI_USAGE;
            }
            if (!strcmp(a, "--info")) info = v;
            else if (!strcmp(a, "--strip")) strip = v;
            else if (!strcmp(a, "--slices")) slices = v;
            else if (!strcmp(a, "--table")) table = v;
            else out = v;
            i++;
        } else if (!strcmp(a, "--slice-g")) {
            char buf[256];
            snprintf(buf, sizeof buf, "%s", v ? v : "");
            n_slice_g = 0;
            for (char *tok = strtok(buf, ","); tok; tok = strtok(NULL, ",")) {
                if (n_slice_g == SLICE_MAX_G) {
                    cli_eprintf("volux ambient-table: --slice-g: at most %d values\n", SLICE_MAX_G);
                    return CLI_USAGE;
                }
                if (!cli_parse_double("ambient-table", a, tok, &slice_g[n_slice_g])) return CLI_USAGE;
                if (!(slice_g[n_slice_g] > -1.0 && slice_g[n_slice_g] < 1.0)) {
                    cli_eprintf("volux ambient-table: --slice-g: %s is not in (-1, 1)\n", tok);
                    return CLI_USAGE;
                }
                n_slice_g++;
            }
            if (!n_slice_g && !cli_parse_double("ambient-table", a, "", &slice_g[0])) return CLI_USAGE;
            i++;
        } else if (!strcmp(a, "--slice-albedo")) {
            if (!cli_parse_double("ambient-table", a, v, &slice_albedo)) return CLI_USAGE;
            if (!(slice_albedo >= 0.0 && slice_albedo <= 1.0)) {
                cli_eprintf("volux ambient-table: --slice-albedo: %s is not in [0, 1]\n", v);
                return CLI_USAGE;
            }
            i++;
        } else if (!strcmp(a, "--slice-size") || !strcmp(a, "--reference")) {
            if (!cli_parse_int("ambient-table", a, v, !strcmp(a, "--reference") ? 1 : 2,
                               !strcmp(a, "--reference") ? 100000000L : 1024, !strcmp(a, "--reference") ? &reference : &slice_size))
                return CLI_USAGE;
            i++;
        } else if (!strcmp(a, "--theta") || !strcmp(a, "--sigma") || !strcmp(a, "--g")) {
            if (!cli_parse_int("ambient-table", a, v, 2, VOLUX_AMBIENT_TABLE_MAX_DIM, &n)) return CLI_USAGE;
            if (!strcmp(a, "--theta")) d.n_theta = (int)n;
            else if (!strcmp(a, "--sigma")) d.n_sigma = (int)n;
            else d.n_g = (int)n;
            i++;
        } else if (!strcmp(a, "--paths") || !strcmp(a, "--seed") || !strcmp(a, "--threads")) {
            if (!cli_parse_int("ambient-table", a, v, !strcmp(a, "--paths") ? 1 : 0,
                               !strcmp(a, "--threads") ? 1024 : 2147483647L, &n))
                return CLI_USAGE;
            if (!strcmp(a, "--paths")) d.paths = (uint64_t)n;
            else if (!strcmp(a, "--seed")) d.seed = (uint64_t)n;
            else threads = n;
            i++;
        } else if (!strcmp(a, "--albedo")) {
            if (!parse_albedos(v, &d)) return CLI_USAGE;
            i++;
        } else if (!strcmp(a, "--sigma-max") || !strcmp(a, "--g-min") || !strcmp(a, "--g-max")) {
            if (!cli_parse_double("ambient-table", a, v, &x)) return CLI_USAGE;
            if (!strcmp(a, "--sigma-max")) d.sigma_max = x;
            else if (!strcmp(a, "--g-min")) d.g_min = x;
            else d.g_max = x;
            i++;
        } else {
            cli_eprintf("volux ambient-table: unknown option '%s'\n", a);
            usage(stderr);
            return CLI_USAGE;
        }
    }
    if (slices) {
        if (out || info || strip) {
            cli_eprintf("volux ambient-table: --slices takes no -o, --info or --strip\n");
            return CLI_USAGE;
        }
        volux_context *ctx = cli_context((int)threads);
        if (!ctx) return CLI_FAIL;
        int rc = write_slices(ctx, slices, table, slice_g, n_slice_g, slice_albedo, (int)slice_size, (uint64_t)reference);
        volux_context_destroy(ctx);
        return rc;
    }
    if (table || reference) {
        cli_eprintf("volux ambient-table: --table and --reference go with --slices\n");
        return CLI_USAGE;
    }
    if (strip) {
        if (!out || info) {
            cli_eprintf("volux ambient-table: --strip FILE needs -o OUT (and no --info)\n");
            return CLI_USAGE;
        }
        volux_context *ctx = cli_context((int)threads);
        if (!ctx) return CLI_FAIL;
        volux_status st = volux_ambient_table_strip(ctx, strip, out);
        int rc = st ? cli_fail("ambient-table", ctx, st) : CLI_OK;
        volux_context_destroy(ctx);
        return rc;
    }
    if (!out == !info) {
        cli_eprintf("volux ambient-table: give exactly one of -o FILE or --info FILE\n");
        usage(stderr);
        return CLI_USAGE;
    }
    volux_context *ctx = cli_context((int)threads);
    if (!ctx) return CLI_FAIL;
    volux_ambient_table_summary summary;
    volux_status st = info ? volux_ambient_table_inspect(ctx, info, &summary)
                           : volux_ambient_table_write(ctx, &d, out, &summary);
    int rc = st ? cli_fail("ambient-table", ctx, st) : CLI_OK;
    if (!st) report(info ? info : out, &summary, json, volux_context_threads(ctx));
    volux_context_destroy(ctx);
    return rc;
}
