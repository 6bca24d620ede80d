/* io/header_text.c — see header_text.h. */
#include "header_text.h"

#include <errno.h>
#include <locale.h>
#include <stdlib.h>
#include <string.h>

int volux_text_line(const char *bytes, size_t n, size_t *pos, volux_text *line, int *terminated) {
    if (*pos >= n) return 0;
    const char *start = bytes + *pos;
    const char *nl = memchr(start, '\n', n - *pos);
    size_t len = nl ? (size_t)(nl - start) : n - *pos;
    *pos += len + (nl ? 1 : 0);
    if (terminated) *terminated = nl != NULL;
    if (len > 0 && start[len - 1] == '\r') len--;
    line->p = start;
    line->n = len;
    return 1;
}

long volux_text_find_nul(volux_text t) {
    const char *z = memchr(t.p, 0, t.n);
    return z ? (long)(z - t.p) : -1;
}

static int is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f' || c == '\n'; }
static char lower(char c) { return c >= 'A' && c <= 'Z' ? (char)(c - 'A' + 'a') : c; }

volux_text volux_text_trim(volux_text t) {
    while (t.n > 0 && is_space(t.p[0])) {
        t.p++;
        t.n--;
    }
    while (t.n > 0 && is_space(t.p[t.n - 1])) t.n--;
    return t;
}

int volux_text_eq(volux_text t, const char *s) { return strlen(s) == t.n && memcmp(t.p, s, t.n) == 0; }

int volux_text_ieq(volux_text t, const char *s) {
    if (strlen(s) != t.n) return 0;
    for (size_t i = 0; i < t.n; i++)
        if (lower(t.p[i]) != lower(s[i])) return 0;
    return 1;
}

int volux_text_ends_with_ci(const char *s, const char *suffix) {
    size_t n = strlen(s), m = strlen(suffix);
    if (m > n) return 0;
    volux_text tail = {s + n - m, m};
    return volux_text_ieq(tail, suffix);
}

int volux_text_token(volux_text *rest, volux_text *tok) {
    size_t i = 0;
    while (i < rest->n && is_space(rest->p[i])) i++;
    if (i == rest->n) {
        rest->p += i;
        rest->n = 0;
        return 0;
    }
    size_t j = i;
    while (j < rest->n && !is_space(rest->p[j])) j++;
    tok->p = rest->p + i;
    tok->n = j - i;
    rest->p += j;
    rest->n -= j;
    return 1;
}

/* Copies a token into a NUL-terminated buffer for strto*; numbers longer
 * than the buffer are not numbers we want. */
static int to_cstr(volux_text t, char *buf, size_t cap) {
    if (t.n == 0 || t.n >= cap || memchr(t.p, 0, t.n)) return 0;
    memcpy(buf, t.p, t.n);
    buf[t.n] = 0;
    return 1;
}

int volux_text_to_i64(volux_text t, int64_t *out) {
    char buf[32], *end;
    if (!to_cstr(t, buf, sizeof buf)) return 0;
    if (!(buf[0] == '-' || buf[0] == '+' || (buf[0] >= '0' && buf[0] <= '9'))) return 0;
    errno = 0;
    long long v = strtoll(buf, &end, 10);
    if (errno || *end) return 0;
    *out = (int64_t)v;
    return 1;
}

int volux_text_to_double(volux_text t, double *out) {
    char buf[64], *end;
    if (!to_cstr(t, buf, sizeof buf)) return 0;
    if (is_space(buf[0])) return 0;
    /* Header numbers always use '.', but strtod reads the decimal point of
     * the thread's LC_NUMERIC: an application embedding the library may
     * have set a decimal-comma locale (Qt applications do at start-up).
     * Parse in the C locale; with LC_ALL_MASK, glibc's newlocale returns
     * its static C locale object (no allocation). */
    locale_t c_locale = newlocale(LC_ALL_MASK, "C", (locale_t)0);
    if (c_locale == (locale_t)0) return 0;
    locale_t previous = uselocale(c_locale);
    errno = 0;
    double v = strtod(buf, &end);
    uselocale(previous);
    freelocale(c_locale);
    /* ERANGE on underflow is fine (the value is ~0); overflow gives inf,
     * which callers reject as non-finite. */
    if (*end || end == buf) return 0;
    *out = v;
    return 1;
}

const char *volux_text_quote(volux_text t, char *buf, size_t cap) {
    size_t max = cap > 4 ? cap - 4 : 0, o = 0;
    for (size_t i = 0; i < t.n && o < max; i++) {
        unsigned char c = (unsigned char)t.p[i];
        buf[o++] = c >= 32 && c < 127 ? (char)c : '?';
    }
    if (t.n > max && cap >= 4) {
        memcpy(buf + o, "...", 3);
        o += 3;
    }
    if (cap) buf[o < cap ? o : cap - 1] = 0;
    return buf;
}
