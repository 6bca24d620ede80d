/* fuzz/fuzz_vti.c — libFuzzer harness for the VTK XML ImageData reader
 * (header parse to the chosen array, and the whole load: ascii, base64,
 * appended, zlib blocks). Corpus: fuzz/corpus/vti/ (VTK-written files from
 * tests/data/vti/ and edited ones); dictionary fuzz/vti.dict. */
#include "fuzz_common.h"

static volux_status parse(volux_context *ctx, const uint8_t *data, size_t size, volux_volume_header *out) {
    volux_source src;
    volux_source_memory(data, size, "fuzz.vti", &src);
    return volux_vti_parse_header(ctx, &src, out);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    fuzz_volume_input(data, size, parse, VOLUX_FORMAT_VTI, "fuzz.vti");
    return 0;
}
