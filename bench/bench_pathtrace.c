/*
 * bench/bench_pathtrace.c — path vertices per second of `pathtrace` with one
 * global majorant vs. the 8³ macrocell majorants, on a raw uint8 volume.
 * Public API only; the `volux bench` CLI can replace it later.
 *
 *   bench_pathtrace RAW NX NY NZ [--tf s:sigma,s:sigma,...] [--size N]
 *                   [--spp N] [--repeat N] [--threads N] [--name NAME]
 *
 * Prints one JSON object per line (DESIGN §4 bench format) per majorant
 * mode: vertices_per_s (median of the repeats, per core when --threads 1),
 * lookups_per_s, render_ms, plus the image's mean luminance so both modes
 * can be seen to agree.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "volux/volux.h"

static int cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

static double median(double *v, int n) {
    qsort(v, (size_t)n, sizeof *v, cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

static int die(volux_context *ctx, const char *what) {
    fprintf(stderr, "bench_pathtrace: %s: %s\n", what, ctx ? volux_context_error(ctx) : "");
    return 1;
}

int main(int argc, char **argv) {
    if (argc < 5) {
        fprintf(stderr, "usage: %s RAW NX NY NZ [--tf s:sigma,...] [--size N] [--spp N] [--repeat N] "
                        "[--threads N] [--name NAME]\n", argv[0]);
        return 2;
    }
    const char *path = argv[1], *name = "volume";
    int dims[3] = {atoi(argv[2]), atoi(argv[3]), atoi(argv[4])};
    int size = 64, spp = 4, repeat = 5, threads = 1;
    volux_tf_scalar_point tf[32] = {{0, 0}, {40, 0}, {80, 0.3f}, {255, 1.0f}};
    int n_tf = 4;
    for (int i = 5; i < argc; i++) {
        if (!strcmp(argv[i], "--size") && i + 1 < argc) size = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--spp") && i + 1 < argc) spp = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--repeat") && i + 1 < argc) repeat = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--threads") && i + 1 < argc) threads = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--name") && i + 1 < argc) name = argv[++i];
        else if (!strcmp(argv[i], "--tf") && i + 1 < argc) {
            n_tf = 0;
            for (char *tok = strtok(argv[++i], ","); tok && n_tf < 32; tok = strtok(NULL, ",")) {
                if (sscanf(tok, "%f:%f", &tf[n_tf].s, &tf[n_tf].v) != 2) return 2;
                n_tf++;
            }
        } else return 2;
    }
    if (repeat < 1 || repeat > 64) repeat = 5;
    size_t bytes = (size_t)dims[0] * (size_t)dims[1] * (size_t)dims[2];
    unsigned char *data = malloc(bytes);
    FILE *f = fopen(path, "rb");
    if (!data || !f || fread(data, 1, bytes, f) != bytes) {
        fprintf(stderr, "bench_pathtrace: cannot read %zu bytes from %s\n", bytes, path);
        return 1;
    }
    fclose(f);

    volux_context *ctx;
    if (volux_context_create(NULL, &ctx)) return 1;
    volux_volume_desc vd;
    memset(&vd, 0, sizeof vd);
    memcpy(vd.dims, dims, sizeof dims);
    vd.type = VOLUX_UINT8;
    vd.data = data;
    volux_volume *vol;
    if (volux_volume_create(ctx, &vd, &vol)) return die(ctx, "volume");
    free(data);
    volux_scene *s;
    if (volux_scene_create(ctx, &s) || volux_scene_set_volume(s, vol)) return die(ctx, "scene");
    volux_transfer_desc td;
    volux_transfer_desc_defaults(&td);
    td.opacity = tf;
    td.n_opacity = n_tf;
    td.extinction = 1;
    td.albedo = 0.9f;
    td.anisotropy = 0.3f;
    if (volux_scene_set_transfer(s, &td)) return die(ctx, "transfer function");
    volux_light_desc l;
    volux_light_desc_defaults(&l, VOLUX_LIGHT_ENVIRONMENT);
    l.radiance = 0.5f;
    if (volux_scene_set_light(s, 0, &l)) return die(ctx, "light");
    volux_light_desc_defaults(&l, VOLUX_LIGHT_DIRECTIONAL);
    l.direction = (volux_vec3){-0.4f, -1.0f, -0.3f};
    l.irradiance = 2.0f;
    if (volux_scene_set_light(s, 1, &l)) return die(ctx, "light");
    volux_render_settings rs;
    volux_render_settings_defaults(&rs);
    rs.width = rs.height = size;
    rs.threads = threads;
    rs.max_depth = 64;
    if (volux_scene_set_render(s, &rs)) return die(ctx, "render settings");

    const char *modes[2] = {"global", "grid"};
    double vps[2];
    for (int m = 0; m < 2; m++) {
        if (volux_scene_set_param(s, "pathtrace", "majorant", 0, modes[m])) return die(ctx, "param");
        volux_technique *t;
        if (volux_technique_create(ctx, "pathtrace", s, &t)) return die(ctx, "technique");
        volux_framebuffer *fb;
        if (volux_framebuffer_create(ctx, size, size, &fb)) return die(ctx, "framebuffer");
        double v_s[64], l_s[64], ms[64], lum = 0.0;
        for (int r = 0; r < repeat; r++) {
            volux_framebuffer_reset(fb);
            volux_render_limits lim = {(uint32_t)spp, 0, 0};
            volux_render_report rep;
            if (volux_render(t, s, fb, &lim, &rep)) return die(ctx, "render");
            ms[r] = rep.ms;
            v_s[r] = (double)rep.vertices / (rep.ms * 1e-3);
            l_s[r] = (double)rep.samples / (rep.ms * 1e-3);
            if (r == 0) {
                volux_image img;
                if (volux_framebuffer_resolve(fb, &img)) return die(ctx, "resolve");
                for (int p = 0; p < size * size; p++)
                    lum += 0.2126 * img.rgb[3 * p] + 0.7152 * img.rgb[3 * p + 1] + 0.0722 * img.rgb[3 * p + 2];
                lum /= size * size;
                volux_image_free(ctx, &img);
            }
        }
        vps[m] = median(v_s, repeat);
        const char *fmt = "{\"scene\":\"%s\",\"technique\":\"pathtrace\",\"majorant\":\"%s\",\"metric\":\"%s\","
                          "\"value\":%.6g,\"unit\":\"%s\",\"threads\":%d,\"width\":%d,\"height\":%d,\"spp\":%d}\n";
        printf(fmt, name, modes[m], "vertices_per_s", vps[m], "1/s", threads, size, size, spp);
        printf(fmt, name, modes[m], "lookups_per_s", median(l_s, repeat), "1/s", threads, size, size, spp);
        printf(fmt, name, modes[m], "render_ms", median(ms, repeat), "ms", threads, size, size, spp);
        printf(fmt, name, modes[m], "mean_luminance", lum, "W/(m^2 sr)", threads, size, size, spp);
        volux_framebuffer_destroy(fb);
        volux_technique_destroy(t);
    }
    printf("{\"scene\":\"%s\",\"technique\":\"pathtrace\",\"metric\":\"grid_speedup\",\"value\":%.3f,\"unit\":\"x\","
           "\"threads\":%d,\"width\":%d,\"height\":%d}\n", name, vps[1] / vps[0], threads, size, size);
    volux_scene_destroy(s);
    volux_volume_release(vol);
    volux_context_destroy(ctx);
    return 0;
}
