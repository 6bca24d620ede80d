/* fuzz/fuzz_png.c — libFuzzer harness for volux_png_read_memory. */
#include "fuzz_image_common.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    return fuzz_image_reader(volux_png_read_memory, data, size);
}
