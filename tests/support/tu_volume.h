/*
 * tests/support/tu_volume.h — building volume files inside tests: value
 * encoding in either byte order, gzip/zlib compression, NIfTI-1 header
 * fields, and a counting allocator (largest block, failure injection).
 */
#ifndef VOLUX_TU_VOLUME_H
#define VOLUX_TU_VOLUME_H

#include "test_util.h"

/* Writes n values (given as doubles, converted to `type`) in the given byte
 * order into out; returns the bytes written (n · type size). */
size_t tu_encode(volux_scalar_type type, int big_endian, const double *values, size_t n, unsigned char *out);

/* Compresses into a malloc'd buffer: a gzip stream (gzip = 1) or a zlib
 * stream (gzip = 0). */
unsigned char *tu_deflate(const void *data, size_t n, int gzip, size_t *out_n);

/* Writes text followed by n bytes of data to a temp file; returns its path. */
const char *tu_write_parts(const char *name, const char *text, const void *data, size_t n);

/* Little helpers for binary headers. */
void tu_put_i16(unsigned char *b, size_t off, int v, int big_endian);
void tu_put_i32(unsigned char *b, size_t off, long v, int big_endian);
void tu_put_f32(unsigned char *b, size_t off, float v, int big_endian);

/* A NIfTI-1 header of 352 bytes (header + 4-byte extension flag): magic
 * "n+1", dims, datatype/bitpix, pixdim 1, vox_offset 352, no scaling. */
void tu_nifti_header(unsigned char hdr[352], int big_endian, const int dims[3], int datatype, int bitpix);

/* A context whose allocator counts: the largest single block, the live
 * bytes, and (fail_at > 0) fails the fail_at-th allocation. */
typedef struct tu_alloc_stats {
    size_t largest;
    size_t live;
    long count;
    long fail_at;
} tu_alloc_stats;
volux_context *tu_context_counting(uint64_t max_bytes, tu_alloc_stats *stats);

/* Asserts that the context's message contains every one of the given
 * NUL-terminated substrings (list ends with NULL). */
void tu_assert_error_mentions(volux_context *ctx, ...);

#endif
