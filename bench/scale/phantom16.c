/*
 * bench/scale/phantom16.c — writes the procedural phantom at N³ as a
 * 16-bit volume file for the scale and loading measurements
 * (docs/SCALE.md): a detached NRRD header OUT.nhdr and its data OUT.raw
 * (uint16, little endian, value = 257 × the uint8 phantom, i.e. the same
 * shapes over the whole 16-bit range), or OUT.raw.gz with --gzip.
 *
 * Usage: bench_phantom16 N OUT.nhdr [--gzip]
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

#include "volux/volux.h"

int main(int argc, char **argv) {
    if (argc < 3 || atoi(argv[1]) < 2) {
        fprintf(stderr, "usage: bench_phantom16 N OUT.nhdr [--gzip]\n");
        return 2;
    }
    int n = atoi(argv[1]), gz = argc > 3 && !strcmp(argv[3], "--gzip");
    const char *hdr = argv[2];
    size_t len = strlen(hdr);
    if (len < 6 || strcmp(hdr + len - 5, ".nhdr")) {
        fprintf(stderr, "bench_phantom16: %s: the header must end in .nhdr\n", hdr);
        return 2;
    }
    char data[4096], base[4096];
    snprintf(data, sizeof data, "%.*s.raw%s", (int)(len - 5), hdr, gz ? ".gz" : "");
    const char *slash = strrchr(data, '/');
    snprintf(base, sizeof base, "%s", slash ? slash + 1 : data);

    volux_context *ctx = NULL;
    volux_context_desc cd = {0};
    cd.threads = 2;
    volux_volume *v = NULL;
    int dims[3] = {n, n, n};
    if (volux_context_create(&cd, &ctx) || volux_volume_procedural(ctx, "phantom", dims, 0, &v)) {
        fprintf(stderr, "bench_phantom16: %s\n", ctx ? volux_context_error(ctx) : "no context");
        return 1;
    }
    FILE *h = fopen(hdr, "w");
    if (!h) {
        perror(hdr);
        return 1;
    }
    fprintf(h, "NRRD0004\ntype: uint16\ndimension: 3\nsizes: %d %d %d\nendian: little\nencoding: %s\n"
               "spacings: 1 1 1\ndata file: %s\n",
            n, n, n, gz ? "gzip" : "raw", base);
    fclose(h);
    FILE *f = gz ? NULL : fopen(data, "wb");
    gzFile z = gz ? gzopen(data, "wb1") : NULL;
    unsigned char *row = malloc((size_t)n * 2);
    if ((!f && !z) || !row) {
        perror(data);
        return 1;
    }
    for (int k = 0; k < n; k++)
        for (int j = 0; j < n; j++) {
            for (int i = 0; i < n; i++) {
                unsigned s = (unsigned)volux_volume_value_at(v, i, j, k) * 257u;
                row[2 * i] = (unsigned char)(s & 255u); /* little endian whatever the host */
                row[2 * i + 1] = (unsigned char)(s >> 8);
            }
            int ok = gz ? gzwrite(z, row, (unsigned)n * 2) == n * 2 : fwrite(row, 2, (size_t)n, f) == (size_t)n;
            if (!ok) {
                fprintf(stderr, "bench_phantom16: %s: write failed\n", data);
                return 1;
            }
        }
    if (gz ? gzclose(z) != Z_OK : fclose(f) != 0) {
        fprintf(stderr, "bench_phantom16: %s: write failed\n", data);
        return 1;
    }
    free(row);
    volux_volume_release(v);
    volux_context_destroy(ctx);
    return 0;
}
