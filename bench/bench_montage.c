/* bench/bench_montage.c — side-by-side montage of images of one size
 * (PFM/EXR/PNG via the public API) into one PNG, tone-mapped with the
 * given exposure: bench_montage OUT.png EXPOSURE IN1 IN2 ... */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "volux/volux.h"

int main(int argc, char **argv) {
    if (argc < 4) {
        fprintf(stderr, "usage: bench_montage OUT.png EXPOSURE IN...\n");
        return 2;
    }
    volux_context *ctx;
    volux_context_desc d = {0};
    if (volux_context_create(&d, &ctx)) return 1;
    int n = argc - 3, w = 0, h = 0, rc = 0;
    volux_image *in = calloc((size_t)n, sizeof *in), out = {0};
    for (int i = 0; i < n && !rc; i++) {
        if (volux_image_load(ctx, argv[3 + i], &in[i])) {
            fprintf(stderr, "bench_montage: %s\n", volux_context_error(ctx));
            rc = 1;
        } else if (i == 0) w = in[i].width, h = in[i].height;
        else if (in[i].width != w || in[i].height != h) {
            fprintf(stderr, "bench_montage: %s has another size\n", argv[3 + i]);
            rc = 2;
        }
    }
    if (!rc && volux_image_create(ctx, w * n, h, &out)) rc = 1;
    for (int i = 0; i < n && !rc; i++)
        for (int y = 0; y < h; y++)
            memcpy(&out.rgb[3 * ((size_t)y * w * n + (size_t)i * w)], &in[i].rgb[3 * (size_t)y * w], 3 * sizeof(float) * w);
    if (!rc && volux_image_save(ctx, argv[1], &out, (float)atof(argv[2]))) {
        fprintf(stderr, "bench_montage: %s\n", volux_context_error(ctx));
        rc = 1;
    }
    for (int i = 0; i < n; i++) volux_image_free(ctx, &in[i]);
    volux_image_free(ctx, &out);
    free(in);
    volux_context_destroy(ctx);
    return rc;
}
