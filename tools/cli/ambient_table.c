/*
 * tools/cli/ambient_table.c — `volux ambient-table`: build, inspect or
 * verify the preintegration table of ambient volume scattering.
 *
 *   volux ambient-table -o FILE [--builtin] [--albedo A[,A...]|set] [--theta N]
 *                       [--sigma N] [--g N] [--sigma-max S] [--g-min G]
 *                       [--g-max G] [--paths N] [--seed S] [--threads N] [--json]
 *   volux ambient-table --info FILE [--json]
 *   volux ambient-table --strip FILE -o OUT
 */
#include <stdio.h>
#include <string.h>

#include "cli.h"

static void usage(FILE *f) {
    fprintf(f,
            "usage: volux ambient-table -o FILE [--builtin] [--albedo A[,A...]|set] [--theta N]\n"
            "                           [--sigma N] [--g N] [--sigma-max S] [--g-min G] [--g-max G]\n"
            "                           [--paths N] [--seed S] [--threads N] [--json]\n"
            "       volux ambient-table --info FILE [--json]\n"
            "       volux ambient-table --strip FILE -o OUT\n"
            "Builds the preintegration table of ambient volume scattering (Ament et al. 2013,\n"
            "Sec. 4.1) by Monte-Carlo path tracing and writes it to FILE (defaults: the paper's\n"
            "256 x 256 x 19 entries, sigma in [0, 20], g in [-0.9, 0.9], albedo 0.9), or prints\n"
            "the header and noise of an existing table. --albedo takes one albedo, a list of\n"
            "increasing ones (an albedo axis, interpolated by the technique) or 'set' (0, 0.1,\n"
            "..., 0.9, 0.95, 1). --builtin starts from the description of the table built into\n"
            "the library (64 x 64 x 10, the albedo set; how src/techniques/ambient/\n"
            "builtin_table.vxat is made). --paths is the number of random walks per (sigma, g,\n"
            "albedo) column; every walk scores every theta entry. --strip copies a table without\n"
            "its per-entry error block (half the size).\n");
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

int cli_ambient_table(int argc, char **argv) {
    volux_ambient_table_desc d;
    volux_ambient_table_desc_defaults(&d);
    const char *out = NULL, *info = NULL, *strip = NULL;
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
        } else if (!strcmp(a, "-o") || !strcmp(a, "--output") || !strcmp(a, "--info") || !strcmp(a, "--strip")) {
            if (!v) {
                cli_eprintf("volux ambient-table: %s needs a file name\n", a);
                return CLI_USAGE;
            }
            if (!strcmp(a, "--info")) info = v;
            else if (!strcmp(a, "--strip")) strip = v;
            else out = v;
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
