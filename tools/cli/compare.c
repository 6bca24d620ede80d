/* tools/cli/compare.c — `volux compare A B [--json] [--diff OUT.png] [--scale S]`.
 *
 * Error metrics of image A against the reference B, over all channels of
 * the linear float pixels (volux_image_compare). Text output is one
 * "key value" per line; --json prints one JSON object. JSON has no infinity,
 * so for identical images (rmse 0) psnr is the string "Infinity", which
 * Python's float(), JavaScript's Number() and C's strtod() all parse; a NaN
 * metric (NaN pixels) is null. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "cli.h"

#define CMD "compare"

static const char usage_text[] =
    "usage: volux compare A B [--json] [--diff OUT.png] [--scale S]\n"
    "\n"
    "Error of image A against the reference B (PNG/PFM/EXR/HDR; linear floats, all channels):\n"
    "  rmse     root mean squared error\n"
    "  rel_mse  mean of (A-B)^2 / (B^2 + 0.01)\n"
    "  psnr     20 log10(max(B) / rmse) in dB; inf (JSON: \"Infinity\") when A == B\n"
    "  max_abs  largest absolute difference\n"
    "\n"
    "  --json        print one JSON object instead of key/value lines\n"
    "  --diff OUT    write a false-colour map of each pixel's largest channel |A-B|\n"
    "                (dark violet = 0 ... yellow = scale), atomically\n"
    "  --scale S     difference shown as yellow (default: max_abs)\n";

static volux_status write_diff(volux_context *ctx, const char *path, const volux_image *a, const volux_image *b,
                               double scale) {
    volux_image d;
    volux_status st = volux_image_create(ctx, a->width, a->height, &d);
    if (st) return st;
    size_t pixels = (size_t)a->width * (size_t)a->height;
    for (size_t p = 0; p < pixels; p++) {
        double m = 0.0;
        for (int k = 0; k < 3; k++) {
            double e = fabs((double)a->rgb[p * 3 + k] - (double)b->rgb[p * 3 + k]);
            if (e > m || e != e) m = e;
        }
        cli_ramp_color(scale > 0.0 ? m / scale : 0.0, d.rgb + p * 3);
    }
    st = volux_image_save(ctx, path, &d, 0.0f);
    volux_image_free(ctx, &d);
    return st;
}

/* A JSON value for a metric: a number, "Infinity"/"-Infinity", or null. */
static void json_number(char *buf, size_t n, double v) {
    if (isnan(v))
        snprintf(buf, n, "null");
    else if (isinf(v))
        snprintf(buf, n, v > 0 ? "\"Infinity\"" : "\"-Infinity\"");
    else
        snprintf(buf, n, "%.9g", v);
}

static void print_metrics(const volux_image_error *e, int json) {
    if (json) {
        char v[4][48];
        json_number(v[0], sizeof v[0], e->rmse);
        json_number(v[1], sizeof v[1], e->rel_mse);
        json_number(v[2], sizeof v[2], e->psnr);
        json_number(v[3], sizeof v[3], e->max_abs);
        printf("{\"rmse\":%s,\"rel_mse\":%s,\"psnr\":%s,\"max_abs\":%s}\n", v[0], v[1], v[2], v[3]);
    } else {
        printf("rmse %.9g\nrel_mse %.9g\npsnr %.9g\nmax_abs %.9g\n", e->rmse, e->rel_mse, e->psnr, e->max_abs);
    }
}

int cli_compare(int argc, char **argv) {
    const char *paths[2] = {NULL, NULL}, *diff = NULL;
    int n_paths = 0, json = 0;
    double scale = 0.0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            fputs(usage_text, stdout);
            return CLI_OK;
        } else if (!strcmp(a, "--json")) {
            json = 1;
        } else if (!strcmp(a, "--diff")) {
            if (++i >= argc) {
                cli_eprintf("volux " CMD ": --diff needs an output file\n");
                return CLI_USAGE;
            }
            diff = argv[i];
        } else if (!strcmp(a, "--scale")) {
            if (!cli_parse_double(CMD, "--scale", i + 1 < argc ? argv[i + 1] : NULL, &scale)) return CLI_USAGE;
            i++;
            if (!(scale > 0.0) || isinf(scale)) {
                cli_eprintf("volux " CMD ": --scale: must be a positive number, got '%s'\n", argv[i]);
                return CLI_USAGE;
            }
        } else if (a[0] == '-' && a[1] == '-') {
            cli_eprintf("volux " CMD ": unknown option '%s'\n\n%s", a, usage_text);
            return CLI_USAGE;
        } else if (n_paths < 2) {
            paths[n_paths++] = a;
        } else {
            cli_eprintf("volux " CMD ": unexpected argument '%s' (give two images)\n\n%s", a, usage_text);
            return CLI_USAGE;
        }
    }
    if (n_paths != 2) {
        cli_eprintf("volux " CMD ": need two images, A and the reference B\n\n%s", usage_text);
        return CLI_USAGE;
    }

    volux_context *ctx = cli_context(0);
    if (!ctx) return CLI_FAIL;
    volux_image a = {0}, b = {0};
    volux_image_error e;
    int rc = CLI_OK;
    volux_status st = volux_image_load(ctx, paths[0], &a);
    if (!st) st = volux_image_load(ctx, paths[1], &b);
    if (st) {
        rc = cli_fail(CMD, ctx, st);
        goto done;
    }
    if (a.width != b.width || a.height != b.height) {
        cli_eprintf("volux " CMD ": '%s' is %dx%d but the reference '%s' is %dx%d\n", paths[0], a.width,
                a.height, paths[1], b.width, b.height);
        rc = CLI_USAGE;
        goto done;
    }
    st = volux_image_compare(ctx, &a, &b, &e);
    if (!st && diff) st = write_diff(ctx, diff, &a, &b, scale > 0.0 ? scale : e.max_abs);
    if (st) {
        rc = cli_fail(CMD, ctx, st);
        goto done;
    }
    print_metrics(&e, json);
done:
    volux_image_free(ctx, &a);
    volux_image_free(ctx, &b);
    volux_context_destroy(ctx);
    return rc;
}
