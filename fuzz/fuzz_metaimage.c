/* fuzz/fuzz_metaimage.c — libFuzzer harness for the MetaImage reader
 * (header parse and the whole load of a .mha with LOCAL data). Corpus:
 * fuzz/corpus/metaimage/. */
#include "fuzz_common.h"

static volux_status parse(volux_context *ctx, const uint8_t *data, size_t size, volux_volume_header *out) {
    return volux_metaimage_parse_header(ctx, (const char *)data, size, "fuzz.mha", out);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    fuzz_volume_input(data, size, parse, VOLUX_FORMAT_METAIMAGE, "fuzz.mha");
    return 0;
}
