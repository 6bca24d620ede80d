/* fuzz/fuzz_hdr.c — libFuzzer harness for volux_hdr_read_memory. */
#include "fuzz_image_common.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    return fuzz_image_reader(volux_hdr_read_memory, data, size);
}
