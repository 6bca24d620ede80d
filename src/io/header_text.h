/*
 * io/header_text.h — small helpers for line-based text headers (NRRD,
 * MetaImage): slices of the input buffer, lines, tokens, strict numbers.
 *
 * Nothing here allocates or needs NUL-terminated input: a header is parsed
 * in place from the bytes read from the file, which may contain anything.
 */
#ifndef VOLUX_IO_HEADER_TEXT_H
#define VOLUX_IO_HEADER_TEXT_H

#include <stddef.h>
#include <stdint.h>

/* A slice of the header buffer (not NUL-terminated). */
typedef struct volux_text {
    const char *p;
    size_t n;
} volux_text;

/* Next line of bytes[0..n) starting at *pos, without its "\n" or "\r\n".
 * Returns 0 when *pos is at the end. *terminated says whether the line
 * ended with a newline (the last line of a buffer may not). */
int volux_text_line(const char *bytes, size_t n, size_t *pos, volux_text *line, int *terminated);
/* Index of the first NUL byte of t, or -1. Headers with NULs are rejected. */
long volux_text_find_nul(volux_text t);
volux_text volux_text_trim(volux_text t);
int volux_text_eq(volux_text t, const char *s);
int volux_text_ieq(volux_text t, const char *s); /* ASCII case-insensitive */
int volux_text_ends_with_ci(const char *s, const char *suffix);
/* Splits off the next whitespace-separated token from *rest; 0 if none. */
int volux_text_token(volux_text *rest, volux_text *tok);
/* Strict conversions of a whole token: no trailing junk, no overflow. */
int volux_text_to_i64(volux_text t, int64_t *out);
int volux_text_to_double(volux_text t, double *out); /* accepts nan/inf; callers check */
/* Printable, length-limited copy for messages ("abc..."), into buf. */
const char *volux_text_quote(volux_text t, char *buf, size_t cap);

#endif
