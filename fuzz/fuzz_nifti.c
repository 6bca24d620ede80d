/* fuzz/fuzz_nifti.c — libFuzzer harness for the NIfTI-1/NIfTI-2 reader: the header
 * parse (named .hdr, so "ni1" pair headers are parsed too) and the whole
 * load of a .nii, or of a .nii.gz when the input starts like gzip. Corpus:
 * fuzz/corpus/nifti/. */
#include "fuzz_common.h"

static volux_status parse(volux_context *ctx, const uint8_t *data, size_t size, volux_volume_header *out) {
    return volux_nifti_parse_header(ctx, data, size, "fuzz.hdr", out);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    int gz = size >= 2 && data[0] == 0x1f && data[1] == 0x8b;
    fuzz_volume_input(data, size, parse, gz ? VOLUX_FORMAT_NIFTI_GZ : VOLUX_FORMAT_NIFTI, gz ? "fuzz.nii.gz" : "fuzz.nii");
    return 0;
}
