/* fuzz/fuzz_merl.c — libFuzzer harness for volux_merl_parse (MERL .binary
 * BRDFs, read by `sh`): a 1 MiB memory cap so absurd bin counts fail fast,
 * every value of an accepted table evaluated through the lookup, and any
 * context memory left afterwards is a finding (leak on an error path). */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>

#include "io/merl.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    static volux_context *ctx;
    if (!ctx) {
        volux_context_desc d = {0};
        d.threads = 1;
        d.max_bytes = 1u << 20;
        if (volux_context_create(&d, &ctx) != VOLUX_OK) abort();
    }
    volux_merl m = {{0, 0, 0}, NULL, 0};
    if (volux_merl_parse(ctx, data, size, "fuzz-input", &m) == VOLUX_OK) {
        size_t n = (size_t)m.dims[0] * (size_t)m.dims[1] * (size_t)m.dims[2];
        volatile float sum = 0.0f;
        for (size_t i = 0; i < 3 * n; i++) {
            if (!(m.rgb[i] >= 0.0f) || !isfinite(m.rgb[i])) abort();
            sum += m.rgb[i];
        }
        /* lookups at grazing, normal and mirrored directions stay in range */
        const double dirs[4][3] = {{0, 0, 1}, {0.999, 0, 0.0447}, {-0.6, 0.64, 0.48}, {0.3, -0.2, 0.9327}};
        for (int a = 0; a < 4; a++)
            for (int b = 0; b < 4; b++) {
                double rgb[3];
                volux_merl_eval(&m, dirs[a], dirs[b], rgb);
                sum += (float)rgb[0];
            }
        (void)sum;
        volux_merl_free(ctx, &m);
    } else if (m.rgb) {
        abort(); /* a failed parse must leave *out untouched */
    }
    if (volux_context_bytes_in_use(ctx) != 0) abort();
    return 0;
}
