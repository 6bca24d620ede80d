/* fuzz/fuzz_nrrd.c — libFuzzer harness for the NRRD reader (header parse
 * and the whole load of an attached .nrrd). Corpus: fuzz/corpus/nrrd/. */
#include "fuzz_common.h"

static volux_status parse(volux_context *ctx, const uint8_t *data, size_t size, volux_volume_header *out) {
    return volux_nrrd_parse_header(ctx, (const char *)data, size, "fuzz.nrrd", out);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    fuzz_volume_input(data, size, parse, VOLUX_FORMAT_NRRD, "fuzz.nrrd");
    return 0;
}
