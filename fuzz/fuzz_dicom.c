/* fuzz/fuzz_dicom.c — libFuzzer harness for the DICOM reader: one file
 * held in memory through the GDCM adapter (src/io/dicom_gdcm.cxx) and the
 * series checks of src/io/dicom.c, under a 1 MiB memory cap; any byte
 * still allocated through the context afterwards is a leak. Without GDCM
 * at build time it only checks that the refusal is clean. Corpus:
 * fuzz/corpus/dicom/ (files written by GDCM, see tests/io/dicom_gen.cxx). */
#include <stdint.h>
#include <stdlib.h>

#include "core/volume_internal.h"
#include "io/volume_formats.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    volux_context_desc d = {0};
    d.threads = 1;
    d.max_bytes = 1u << 20;
    volux_context *ctx;
    if (volux_context_create(&d, &ctx) != VOLUX_OK) return 0;
    volux_volume_load_options o = {0};
    o.use_file_origin = size & 1; /* both origin paths */
    volux_volume *v = NULL;
    if (volux_dicom_load_memory(ctx, data, size, "fuzz.dcm", &o, &v) == VOLUX_OK) {
        double lo, hi;
        volux_volume_range(v, &lo, &hi);
        if (!(lo <= hi)) abort();
        volux_volume_release(v);
    } else if (v) {
        abort(); /* out-params are written only on success */
    }
    if (volux_context_bytes_in_use(ctx) != 0) abort();
    volux_context_destroy(ctx);
    return 0;
}
