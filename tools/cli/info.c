/* tools/cli/info.c — `volux info VOLUME`: dims, type, spacing, origin,
 * value range, memory and a text histogram of a volume file or of a
 * procedural volume ("procedural:NAME[:N]"). */
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "cli.h"

#define CMD "info"
#define BAR_WIDTH 40

static void usage(FILE *f) {
    fprintf(f,
            "usage: volux info FILE [options]\n"
            "  FILE                 " VOLUX_VOLUME_EXTENSIONS ", a raw file with --raw-*,\n"
            "                       an image (.png .pfm .exr, Radiance .hdr: size, range, metadata)\n"
            "                       or procedural:NAME[:N] (NAME: %s; N³ voxels, default 64)\n"
            "  --raw-dims X Y Z     read FILE as raw data of these dims (needs --raw-type)\n"
            "  --raw-type T         uint8 int8 uint16 int16 float32 float64\n"
            "  --raw-endian E       little (default) or big\n"
            "  --raw-spacing X Y Z  voxel spacing (default 1 1 1)\n"
            "  --raw-skip N         bytes to skip at the start of the file\n"
            "  --file-origin        report the origin stored in the file instead of the centred one\n"
            "  --allow-nonfinite    map NaN/Inf float values to the lowest value (with a warning);\n"
            "                       images: statistics of the finite values, NaN/Inf counted\n"
            "  --bins N             histogram bins (default 16)\n"
            "  --seed S             seed for procedural volumes (default 1)\n",
            volux_procedural_names());
}

typedef struct options {
    const char *file;
    volux_raw_desc raw;
    int has_raw, has_raw_type, file_origin, allow_nonfinite;
    long bins;
    long seed;
} options;

/* Returns CLI_OK, or the exit status after printing what was wrong. */
static int parse_args(int argc, char **argv, options *o) {
    memset(o, 0, sizeof *o);
    o->bins = 16;
    o->seed = 1;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        int left = argc - i - 1;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            usage(stdout);
            return -1;
        } else if (!strcmp(a, "--raw-dims") && left >= 3) {
            for (int k = 0; k < 3; k++) {
                long v;
                if (!cli_parse_int(CMD, a, argv[++i], 1, 1L << 30, &v)) return CLI_USAGE;
                o->raw.dims[k] = (int)v;
            }
            o->has_raw = 1;
        } else if (!strcmp(a, "--raw-spacing") && left >= 3) {
            for (int k = 0; k < 3; k++)
                if (!cli_parse_double(CMD, a, argv[++i], &o->raw.spacing[k])) return CLI_USAGE;
        } else if (!strcmp(a, "--raw-type") && left >= 1) {
            if (volux_scalar_type_parse(argv[++i], &o->raw.type) != 0) {
                cli_eprintf("volux info: --raw-type: unknown type '%s'\n", argv[i]);
                return CLI_USAGE;
            }
            o->has_raw_type = 1;
        } else if (!strcmp(a, "--raw-endian") && left >= 1) {
            const char *e = argv[++i];
            if (strcmp(e, "little") && strcmp(e, "big")) {
                cli_eprintf("volux info: --raw-endian: expected little or big, got '%s'\n", e);
                return CLI_USAGE;
            }
            o->raw.big_endian = !strcmp(e, "big");
        } else if (!strcmp(a, "--raw-skip") && left >= 1) {
            long v;
            if (!cli_parse_int(CMD, a, argv[++i], 0, LONG_MAX, &v)) return CLI_USAGE;
            o->raw.byte_skip = (uint64_t)v;
        } else if (!strcmp(a, "--bins") && left >= 1) {
            if (!cli_parse_int(CMD, a, argv[++i], 1, 256, &o->bins)) return CLI_USAGE;
        } else if (!strcmp(a, "--seed") && left >= 1) {
            if (!cli_parse_int(CMD, a, argv[++i], 0, LONG_MAX, &o->seed)) return CLI_USAGE;
        } else if (!strcmp(a, "--file-origin")) {
            o->file_origin = 1;
        } else if (!strcmp(a, "--allow-nonfinite")) {
            o->allow_nonfinite = 1;
        } else if (a[0] == '-' && a[1]) {
            cli_eprintf("volux info: unknown option or missing value: '%s'\n", a);
            return CLI_USAGE;
        } else if (o->file) {
            cli_eprintf("volux info: one volume at a time (got '%s' and '%s')\n", o->file, a);
            return CLI_USAGE;
        } else {
            o->file = a;
        }
    }
    if (!o->file) {
        usage(stderr);
        return CLI_USAGE;
    }
    if (o->has_raw != o->has_raw_type) {
        cli_eprintf("volux info: %s: raw data needs both --raw-dims and --raw-type\n", o->file);
        return CLI_USAGE;
    }
    return CLI_OK;
}

/* Images: a Radiance .hdr starts with "#?" (a NIfTI-1 .hdr with the
 * binary number 348); .png .pfm .exr are images by name. */
static int is_image(const char *path) {
    const char *dot = strrchr(path, '.');
    if (!dot) return 0;
    if (!strcasecmp(dot, ".png") || !strcasecmp(dot, ".pfm") || !strcasecmp(dot, ".exr")) return 1;
    if (strcasecmp(dot, ".hdr")) return 0;
    FILE *f = fopen(path, "rb");
    if (!f) return 0;
    char magic[2] = {0, 0};
    size_t got = fread(magic, 1, 2, f);
    fclose(f);
    return got == 2 && magic[0] == '#' && magic[1] == '?';
}

static int print_image_info(volux_context *ctx, const char *file, int allow_nonfinite) {
    volux_image img = {0};
    volux_image_meta meta;
    volux_status st = volux_image_load_meta(ctx, file, &img, &meta);
    if (st) return cli_fail(CMD, ctx, st);
    size_t n = (size_t)img.width * (size_t)img.height;
    /* Statistics over the finite values; NaN/Inf are counted apart (they
     * would otherwise print "min inf, max -inf" or a NaN mean). */
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY}, sum[3] = {0, 0, 0};
    size_t finite[3] = {0, 0, 0}, nan_count = 0, inf_count = 0;
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++) {
            double v = img.rgb[3 * i + (size_t)c];
            if (isnan(v)) {
                nan_count++;
                continue;
            }
            if (isinf(v)) {
                inf_count++;
                continue;
            }
            if (v < lo[c]) lo[c] = v;
            if (v > hi[c]) hi[c] = v;
            sum[c] += v;
            finite[c]++;
        }
    if ((nan_count || inf_count) && !allow_nonfinite) {
        cli_eprintf("volux " CMD ": %s: %zu NaN and %zu infinite values (give --allow-nonfinite to see the "
                    "statistics of the finite ones)\n",
                    file, nan_count, inf_count);
        volux_image_free(ctx, &img);
        return CLI_USAGE;
    }
    const char *dot = strrchr(file, '.');
    printf("file      %s\n", file);
    printf("image     %d x %d, %s, linear RGB\n", img.width, img.height, dot ? dot + 1 : "?");
    for (int c = 0; c < 3; c++) {
        if (finite[c]) printf("%c         min %g, max %g, mean %g\n", "RGB"[c], lo[c], hi[c], sum[c] / (double)finite[c]);
        else printf("%c         no finite value\n", "RGB"[c]);
    }
    if (nan_count || inf_count) printf("nonfinite %zu NaN, %zu infinite (not in the statistics)\n", nan_count, inf_count);
    for (int i = 0; i < meta.count; i++) printf("meta      %s = %s\n", meta.key[i], meta.value[i]);
    volux_image_free(ctx, &img);
    return CLI_OK;
}

static void print_size(double bytes) {
    const char *unit[] = {"B", "KiB", "MiB", "GiB", "TiB"};
    int u = 0;
    while (bytes >= 1024.0 && u < 4) {
        bytes /= 1024.0;
        u++;
    }
    printf("%.1f %s", bytes, unit[u]);
}

static const char *storage_name(volux_storage s) {
    return s == VOLUX_STORE_U8 ? "uint8" : s == VOLUX_STORE_U16 ? "uint16" : "float32";
}

static int print_info(const char *file, volux_volume *v, int bins) {
    int d[3];
    double s[3], lo, hi;
    volux_volume_dims(v, d);
    volux_volume_spacing(v, s);
    volux_volume_range(v, &lo, &hi);
    volux_vec3 o = volux_volume_origin(v), blo, bhi;
    volux_volume_bounds(v, &blo, &bhi);
    uint64_t voxels = (uint64_t)d[0] * (uint64_t)d[1] * (uint64_t)d[2];
    uint64_t *counts = calloc((size_t)bins, sizeof *counts);
    if (!counts) {
        cli_eprintf("volux info: out of memory\n");
        return CLI_FAIL;
    }
    volux_volume_histogram(v, bins, counts);

    printf("file      %s\n", file);
    printf("dims      %d x %d x %d  (%llu voxels)\n", d[0], d[1], d[2], (unsigned long long)voxels);
    printf("type      %s (stored as %s)\n", volux_scalar_type_name(volux_volume_type(v)),
           storage_name(volux_volume_storage_kind(v)));
    printf("spacing   %g %g %g\n", s[0], s[1], s[2]);
    printf("origin    %g %g %g\n", o.x, o.y, o.z);
    volux_vec3 up;
    if (volux_volume_superior(v, &up))
        printf("superior  %.3g %.3g %.3g  (the file's anatomical orientation: the default camera's up)\n", up.x, up.y,
               up.z);
    printf("bounds    [%g, %g] x [%g, %g] x [%g, %g]\n", blo.x, bhi.x, blo.y, bhi.y, blo.z, bhi.z);
    printf("range     %g .. %g\n", lo, hi);
    printf("memory    ");
    print_size((double)volux_volume_memory_bytes(v));
    printf(" (%zu bytes)\n", volux_volume_memory_bytes(v));
    printf("histogram %d bins over [%g, %g]\n", bins, lo, hi);

    uint64_t max = 1;
    for (int b = 0; b < bins; b++)
        if (counts[b] > max) max = counts[b];
    double width = (hi - lo) / bins;
    for (int b = 0; b < bins; b++) {
        char bar[BAR_WIDTH + 1];
        int len = (int)((double)counts[b] / (double)max * BAR_WIDTH + 0.5);
        if (len == 0 && counts[b] > 0) len = 1; /* a nonempty bin is never invisible */
        memset(bar, '#', (size_t)len);
        bar[len] = 0;
        printf("  [%10.4g, %10.4g%c %12llu %6.2f%%  %s\n", lo + b * width, lo + (b + 1) * width,
               b == bins - 1 ? ']' : ')', (unsigned long long)counts[b], 100.0 * (double)counts[b] / (double)voxels,
               bar);
    }
    free(counts);
    return CLI_OK;
}

int cli_info(int argc, char **argv) {
    options o;
    int rc = parse_args(argc, argv, &o);
    if (rc < 0) return CLI_OK; /* --help */
    if (rc != CLI_OK) return rc;
    volux_context *ctx = cli_context(0);
    if (!ctx) return CLI_FAIL;
    if (!o.has_raw && is_image(o.file)) {
        rc = print_image_info(ctx, o.file, o.allow_nonfinite);
        volux_context_destroy(ctx);
        return rc;
    }
    volux_volume *v = NULL;
    volux_status st;
    if (!strncmp(o.file, "procedural:", strlen("procedural:"))) {
        st = cli_procedural(ctx, CMD, o.file, (uint64_t)o.seed, &v, NULL, 0);
        if (st == VOLUX_ERR_INVALID && !*volux_context_error(ctx)) {
            volux_context_destroy(ctx);
            return CLI_USAGE; /* cli_parse_int already said why */
        }
    } else {
        volux_volume_load_options lo = {0};
        lo.raw = o.has_raw ? &o.raw : NULL;
        lo.use_file_origin = o.file_origin;
        lo.allow_nonfinite = o.allow_nonfinite;
        st = volux_volume_load(ctx, o.file, &lo, &v);
    }
    if (st != VOLUX_OK) {
        rc = cli_fail(CMD, ctx, st);
        volux_context_destroy(ctx);
        return rc;
    }
    rc = print_info(o.file, v, (int)o.bins);
    volux_volume_release(v);
    volux_context_destroy(ctx);
    return rc;
}
