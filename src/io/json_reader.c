/* io/json_reader.c — see json_reader.h. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "core/context_internal.h"
#include "core/name_guess.h"
#include "file_open.h"
#include "json_reader.h"

#define JSON_MAX_BYTES (16u << 20) /* cJSON needs ~30× the text for arrays of numbers */
#define STR_(x) #x
#define STR(x) STR_(x)

volux_status volux_json_error(volux_json_reader *r, volux_status st, const char *path, const char *fmt, ...) {
    char msg[768];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    return volux_error(r->ctx, st, "%s: %s%s%s", r->file, path && *path ? path : "", path && *path ? ": " : "", msg);
}

volux_status volux_json_read_file(volux_context *ctx, const char *path, char **buf, size_t *n) {
    /* Regular files only, checked on the descriptor: a directory opens
     * fine on Linux (ftell then says LONG_MAX), a FIFO would block. */
    FILE *f;
    uint64_t file_size;
    volux_status st = volux_file_open_read(ctx, path, &f, &file_size);
    if (st) return st;
    if (file_size > JSON_MAX_BYTES) {
        fclose(f);
        return volux_error(ctx, VOLUX_ERR_LIMIT, "%s: larger than 16 MiB", path);
    }
    size_t size = (size_t)file_size;
    char *b = volux_malloc(ctx, size + 1);
    if (!b) {
        fclose(f);
        return volux_error(ctx, VOLUX_ERR_NOMEM, "%s: out of memory", path);
    }
    size_t got = fread(b, 1, size, f);
    fclose(f);
    if (got != size) {
        volux_free(ctx, b, size + 1);
        return volux_error(ctx, VOLUX_ERR_IO, "%s: read error", path);
    }
    b[size] = 0;
    *buf = b;
    *n = size;
    return VOLUX_OK;
}

/* Offset → "line L, column C" for messages. */
static volux_status error_at(volux_json_reader *r, volux_status st, const char *text, size_t at, const char *what) {
    int line = 1, col = 1;
    for (size_t i = 0; i < at; i++) {
        if (text[i] == '\n') line++, col = 1;
        else col++;
    }
    return volux_json_error(r, st, NULL, "%s at line %d, column %d", what, line, col);
}

static int hex_digit(char c) {
    return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f') || (c >= 'A' && c <= 'F');
}

static unsigned hex4(const char *p) {
    unsigned v = 0;
    for (int k = 0; k < 4; k++) {
        char c = p[k];
        v = v * 16 + (unsigned)(c <= '9' ? c - '0' : (c | 0x20) - 'a' + 10);
    }
    return v;
}

/* Length of the JSON number at text[i] (RFC 8259 §6:
 * -?(0|[1-9][0-9]*)(.[0-9]+)?([eE][+-]?[0-9]+)?), 0 if the characters
 * there (up to the next delimiter) are not one. */
static size_t number_length(const char *text, size_t n, size_t i) {
    size_t j = i;
    if (j < n && text[j] == '-') j++;
    if (j >= n || text[j] < '0' || text[j] > '9') return 0;
    if (text[j] == '0') j++;
    else
        while (j < n && text[j] >= '0' && text[j] <= '9') j++;
    if (j < n && text[j] == '.') {
        size_t d = ++j;
        while (j < n && text[j] >= '0' && text[j] <= '9') j++;
        if (j == d) return 0;
    }
    if (j < n && (text[j] == 'e' || text[j] == 'E')) {
        j++;
        if (j < n && (text[j] == '+' || text[j] == '-')) j++;
        size_t d = j;
        while (j < n && text[j] >= '0' && text[j] <= '9') j++;
        if (j == d) return 0;
    }
    /* a number ends at a delimiter: "064" or "1.5.2" or "12abc" are not numbers */
    if (j < n && !strchr(" \t\r\n,]}:", text[j])) return 0;
    return j - i;
}

/* One pass over the text before cJSON sees it, enforcing what RFC 8259
 * requires and cJSON lets through (issue 16): numbers by the grammar (no
 * leading zeros "064", no "+1", ".5", "1.", "0x10"), string escapes
 * from the RFC's set only, \u with four hex digits and UTF-16 surrogates
 * in pairs, no raw control characters in strings, and UTF-8 that is valid
 * (RFC 3629: no overlongs, surrogates or values above U+10FFFF). cJSON
 * would also stop at a NUL byte and turn "\u0000" into one, silently
 * truncating a key or a file name ("vol.raw\u0000.png" would open
 * vol.raw); and it recurses once per nesting level, so nesting is capped
 * here, far below cJSON's own limit, with a message that says what is
 * wrong. The structure itself (brackets, commas, literals) is cJSON's. */
static volux_status prescan(volux_json_reader *r, const char *text, size_t n) {
    const unsigned char *u = (const unsigned char *)text;
    int depth = 0, in_string = 0;
    for (size_t i = 0; i < n;) {
        unsigned char c = u[i];
        if (c == 0) return error_at(r, VOLUX_ERR_FORMAT, text, i, "NUL byte");
        if (c >= 0x80) {
            size_t len = volux_utf8_sequence(u + i, n - i);
            if (!len) return error_at(r, VOLUX_ERR_FORMAT, text, i, "invalid UTF-8");
            if (!in_string) return error_at(r, VOLUX_ERR_FORMAT, text, i, "unexpected character outside a string");
            i += len;
            continue;
        }
        if (in_string) {
            if (c < 0x20) return error_at(r, VOLUX_ERR_FORMAT, text, i, "control character in a string (escape it)");
            if (c == '"') in_string = 0;
            if (c != '\\') {
                i++;
                continue;
            }
            char e = i + 1 < n ? text[i + 1] : 0;
            if (e && strchr("\"\\/bfnrt", e)) {
                i += 2;
                continue;
            }
            if (e != 'u') return error_at(r, VOLUX_ERR_FORMAT, text, i, "invalid escape in a string");
            if (n - i < 6 || !hex_digit(text[i + 2]) || !hex_digit(text[i + 3]) || !hex_digit(text[i + 4]) ||
                !hex_digit(text[i + 5]))
                return error_at(r, VOLUX_ERR_FORMAT, text, i, "\\u needs four hex digits");
            unsigned cp = hex4(text + i + 2);
            if (cp == 0) return error_at(r, VOLUX_ERR_FORMAT, text, i, "\\u0000 (NUL) in a string");
            if (cp >= 0xdc00 && cp <= 0xdfff)
                return error_at(r, VOLUX_ERR_FORMAT, text, i, "lone UTF-16 low surrogate in a string");
            if (cp >= 0xd800 && cp <= 0xdbff) {
                if (n - i < 12 || text[i + 6] != '\\' || text[i + 7] != 'u' || !hex_digit(text[i + 8]) ||
                    !hex_digit(text[i + 9]) || !hex_digit(text[i + 10]) || !hex_digit(text[i + 11]) ||
                    hex4(text + i + 8) < 0xdc00 || hex4(text + i + 8) > 0xdfff)
                    return error_at(r, VOLUX_ERR_FORMAT, text, i, "lone UTF-16 high surrogate in a string");
                i += 12;
            } else {
                i += 6;
            }
            continue;
        }
        if (c == '"') in_string = 1;
        else if (c == '[' || c == '{') {
            if (++depth > VOLUX_JSON_MAX_DEPTH)
                return error_at(r, VOLUX_ERR_LIMIT, text, i, "nesting deeper than " STR(VOLUX_JSON_MAX_DEPTH) " levels");
        } else if ((c == ']' || c == '}') && depth > 0) depth--;
        else if (c == '-' || c == '+' || c == '.' || (c >= '0' && c <= '9')) {
            size_t len = number_length(text, n, i);
            if (!len) return error_at(r, VOLUX_ERR_FORMAT, text, i, "invalid number");
            i += len;
            continue;
        }
        i++;
    }
    return VOLUX_OK;
}

volux_status volux_json_parse(volux_json_reader *r, const char *text, size_t n, cJSON **out) {
    if (n > JSON_MAX_BYTES) return volux_json_error(r, VOLUX_ERR_LIMIT, NULL, "JSON text larger than 16 MiB");
    volux_status st = prescan(r, text, n);
    if (st) return st;
    /* cJSON gets a NUL-terminated copy: callers (and fuzzers) may pass a
     * buffer that ends exactly at n, and cJSON looks one byte past the
     * end of some truncated tokens. */
    char *copy = volux_malloc(r->ctx, n + 1);
    if (!copy) return volux_json_error(r, VOLUX_ERR_NOMEM, NULL, "out of memory for %zu bytes of JSON", n);
    if (n) memcpy(copy, text, n);
    copy[n] = 0;
    const char *end = NULL;
    cJSON *root = cJSON_ParseWithLengthOpts(copy, n, &end, 0);
    size_t at = end && end >= copy && end <= copy + n ? (size_t)(end - copy) : 0;
    volux_free(r->ctx, copy, n + 1);
    if (!root) return error_at(r, VOLUX_ERR_FORMAT, text, at, "invalid JSON");
    /* cJSON stops after the first value; anything but whitespace after it
     * is a mistake (a second object pasted in, a stray bracket). */
    while (at < n && (text[at] == ' ' || text[at] == '\t' || text[at] == '\n' || text[at] == '\r')) at++;
    if (at < n) {
        cJSON_Delete(root);
        return error_at(r, VOLUX_ERR_FORMAT, text, at, "unexpected text after the JSON value");
    }
    *out = root;
    return VOLUX_OK;
}

static void join(char *dst, size_t n, const char *path, const char *key) {
    if (path && *path) snprintf(dst, n, "%s.%s", path, key);
    else snprintf(dst, n, "%s", key);
}

volux_status volux_json_check_keys(volux_json_reader *r, const cJSON *obj, const char *path,
                                   const char *const *allowed) {
    if (!cJSON_IsObject(obj)) return volux_json_error(r, VOLUX_ERR_INVALID, path, "expected an object");
    for (const cJSON *c = obj->child; c; c = c->next) {
        int ok = !allowed;
        for (const char *const *a = allowed; a && *a && !ok; a++) ok = c->string && !strcmp(c->string, *a);
        if (!ok) {
            char p[256];
            join(p, sizeof p, path, c->string ? c->string : "?");
            char list[512] = "";
            volux_name_guess g = {0};
            for (const char *const *a = allowed; *a; a++) {
                if (c->string) volux_name_guess_try(&g, c->string, *a);
                if (strlen(list) + strlen(*a) + 3 >= sizeof list) continue;
                if (*list) strcat(list, ", ");
                strcat(list, *a);
            }
            const char *guess = c->string ? volux_name_guess_best(&g, c->string) : NULL;
            if (guess)
                return volux_json_error(r, VOLUX_ERR_INVALID, p, "unknown key; did you mean '%s'? (expected one of: %s)",
                                        guess, list);
            return volux_json_error(r, VOLUX_ERR_INVALID, p, "unknown key (expected one of: %s)", list);
        }
        /* cJSON keeps duplicate keys; the second would be silently ignored.
         * With a key list this stops at the first repeat, so the scan is
         * O(keys in the list × object size); without one the caller bounds
         * the object size. */
        for (const cJSON *d = c->next; d; d = d->next)
            if (d->string && c->string && !strcmp(d->string, c->string)) {
                char p[256];
                join(p, sizeof p, path, c->string);
                return volux_json_error(r, VOLUX_ERR_INVALID, p, "duplicate key");
            }
    }
    return VOLUX_OK;
}

/* A bound as people write it: integers in full (16777216, not
 * 1.67772e+07), other numbers with %g. */
static const char *bound(char buf[32], double v) {
    if (v == floor(v) && fabs(v) < 1e15) snprintf(buf, 32, "%.0f", v);
    else snprintf(buf, 32, "%g", v);
    return buf;
}

volux_status volux_json_number(volux_json_reader *r, const cJSON *obj, const char *path, const char *key, double lo,
                               double hi, double *out) {
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, key);
    if (!v) return VOLUX_OK;
    char p[256];
    join(p, sizeof p, path, key);
    if (!cJSON_IsNumber(v)) return volux_json_error(r, VOLUX_ERR_INVALID, p, "expected a number");
    double d = v->valuedouble;
    if (!isfinite(d) || d < lo || d > hi) {
        char a[32], b[32], c[32];
        return volux_json_error(r, VOLUX_ERR_INVALID, p, "%s is outside [%s, %s]", bound(c, d), bound(a, lo),
                                bound(b, hi));
    }
    *out = d;
    return VOLUX_OK;
}

volux_status volux_json_float(volux_json_reader *r, const cJSON *obj, const char *path, const char *key, double lo,
                              double hi, float *out) {
    double d = *out;
    volux_status st = volux_json_number(r, obj, path, key, lo, hi, &d);
    if (!st) *out = (float)d;
    return st;
}

volux_status volux_json_int(volux_json_reader *r, const cJSON *obj, const char *path, const char *key, long lo,
                            long hi, int *out) {
    double d = *out;
    volux_status st = volux_json_number(r, obj, path, key, (double)lo, (double)hi, &d);
    if (st) return st;
    if (d != floor(d)) {
        char p[256];
        join(p, sizeof p, path, key);
        return volux_json_error(r, VOLUX_ERR_INVALID, p, "expected an integer, got %g", d);
    }
    *out = (int)d;
    return VOLUX_OK;
}

volux_status volux_json_bool(volux_json_reader *r, const cJSON *obj, const char *path, const char *key, int *out) {
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, key);
    if (!v) return VOLUX_OK;
    if (!cJSON_IsBool(v)) {
        char p[256];
        join(p, sizeof p, path, key);
        return volux_json_error(r, VOLUX_ERR_INVALID, p, "expected true or false");
    }
    *out = cJSON_IsTrue(v);
    return VOLUX_OK;
}

volux_status volux_json_string(volux_json_reader *r, const cJSON *obj, const char *path, const char *key,
                               const char **out) {
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, key);
    if (!v) return VOLUX_OK;
    if (!cJSON_IsString(v) || !v->valuestring) {
        char p[256];
        join(p, sizeof p, path, key);
        return volux_json_error(r, VOLUX_ERR_INVALID, p, "expected a string");
    }
    *out = v->valuestring;
    return VOLUX_OK;
}

volux_status volux_json_vec3(volux_json_reader *r, const cJSON *obj, const char *path, const char *key, double lo,
                             double hi, float out[3]) {
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, key);
    if (!v) return VOLUX_OK;
    char p[256];
    join(p, sizeof p, path, key);
    if (!cJSON_IsArray(v) || cJSON_GetArraySize(v) != 3)
        return volux_json_error(r, VOLUX_ERR_INVALID, p, "expected an array of 3 numbers");
    float tmp[3];
    int i = 0;
    for (const cJSON *c = v->child; c; c = c->next, i++) {
        if (!cJSON_IsNumber(c) || !isfinite(c->valuedouble) || c->valuedouble < lo || c->valuedouble > hi) {
            char pi[280];
            snprintf(pi, sizeof pi, "%s[%d]", p, i);
            char a[32], b[32];
            return volux_json_error(r, VOLUX_ERR_INVALID, pi, "must be a number in [%s, %s]", bound(a, lo),
                                    bound(b, hi));
        }
        tmp[i] = (float)c->valuedouble;
    }
    memcpy(out, tmp, sizeof tmp);
    return VOLUX_OK;
}

volux_status volux_json_rows(volux_json_reader *r, const cJSON *obj, const char *path, const char *key, int width,
                             int max_rows, float **rows, int *count) {
    *rows = NULL;
    *count = 0;
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, key);
    if (!v) return VOLUX_OK;
    char p[256];
    join(p, sizeof p, path, key);
    if (!cJSON_IsArray(v)) return volux_json_error(r, VOLUX_ERR_INVALID, p, "expected an array of [s, ...] rows");
    int n = cJSON_GetArraySize(v);
    if (n < 1 || n > max_rows)
        return volux_json_error(r, VOLUX_ERR_INVALID, p, "needs 1..%d rows, got %d", max_rows, n);
    float *out = volux_malloc(r->ctx, sizeof(float) * (size_t)n * (size_t)width);
    if (!out) return volux_json_error(r, VOLUX_ERR_NOMEM, p, "out of memory");
    int i = 0;
    for (const cJSON *row = v->child; row; row = row->next, i++) {
        char pi[300];
        if (!cJSON_IsArray(row) || cJSON_GetArraySize(row) != width) {
            volux_free(r->ctx, out, sizeof(float) * (size_t)n * (size_t)width);
            snprintf(pi, sizeof pi, "%s[%d]", p, i);
            return volux_json_error(r, VOLUX_ERR_INVALID, pi, "expected a row of %d numbers", width);
        }
        int j = 0;
        for (const cJSON *c = row->child; c; c = c->next, j++) {
            if (!cJSON_IsNumber(c) || !isfinite(c->valuedouble) || fabs(c->valuedouble) > 1e30) {
                volux_free(r->ctx, out, sizeof(float) * (size_t)n * (size_t)width);
                snprintf(pi, sizeof pi, "%s[%d][%d]", p, i, j);
                return volux_json_error(r, VOLUX_ERR_INVALID, pi, "expected a number in [-1e30, 1e30]");
            }
            out[(size_t)i * (size_t)width + (size_t)j] = (float)c->valuedouble;
        }
    }
    *rows = out;
    *count = n;
    return VOLUX_OK;
}

/* A segment that is all digits (no sign, space or exponent, as strtol
 * would accept) and small enough to be an index. */
static int is_index(const char *s, long *out) {
    size_t n = strlen(s);
    if (n == 0 || n > 9) return 0;
    long v = 0;
    for (size_t i = 0; i < n; i++) {
        if (s[i] < '0' || s[i] > '9') return 0;
        v = v * 10 + (s[i] - '0');
    }
    *out = v;
    return 1;
}

/* The value of an override: JSON when it is JSON, else the text as a
 * string so bare words work (render.technique=shaded). The whole text must
 * be one value: "64abc" or "true_x" must not become 64 or true. Text that
 * starts like a JSON array/object/string but does not parse is an error,
 * not a string, so a typo in "[1,2" is reported where it is. */
static volux_status override_value(volux_json_reader *r, const char *assignment, const char *text, cJSON **out) {
    volux_context *ctx = r->ctx;
    char saved[VOLUX_ERROR_MAX];
    volux_status saved_status = volux_context_error_status(ctx);
    memcpy(saved, ctx->error, sizeof saved);
    volux_json_reader quiet = {ctx, assignment};
    cJSON *v = NULL;
    volux_status st = volux_json_parse(&quiet, text, strlen(text), &v);
    if (!st) {
        *out = v;
        return VOLUX_OK;
    }
    if (st == VOLUX_ERR_NOMEM) return st;
    const char *first = text + strspn(text, " \t\r\n");
    if (*first == '[' || *first == '{' || *first == '"') {
        /* Keep the parser's "at line, column" but name the override. */
        volux_error_prefix(ctx, "%s: --set ", r->file);
        return VOLUX_ERR_INVALID;
    }
    memcpy(ctx->error, saved, sizeof saved); /* a bare word is not an error */
    ctx->error_status = saved_status;
    v = cJSON_CreateString(text);
    if (!v) return volux_json_error(r, VOLUX_ERR_NOMEM, NULL, "--set %s: out of memory", assignment);
    *out = v;
    return VOLUX_OK;
}

/* An empty array or object for a path segment that does not exist yet:
 * an array when the next segment is an index ("lights.0.type=point" in a
 * scene without lights). */
static cJSON *new_container(const char *next) {
    size_t len = strcspn(next, ".");
    int digits = len > 0 && strspn(next, "0123456789") >= len;
    return digits ? cJSON_CreateArray() : cJSON_CreateObject();
}

volux_status volux_json_apply_override(volux_json_reader *r, cJSON *root, const char *assignment) {
    const char *eq = strchr(assignment, '=');
    if (!eq || eq == assignment)
        return volux_json_error(r, VOLUX_ERR_INVALID, NULL, "--set %s: expected dotted.path=value", assignment);
    size_t path_len = (size_t)(eq - assignment);
    char path[512];
    if (path_len >= sizeof path)
        return volux_json_error(r, VOLUX_ERR_INVALID, NULL, "--set %.64s...: path longer than %zu characters",
                                assignment, sizeof path - 1);
    memcpy(path, assignment, path_len);
    path[path_len] = 0;
    /* Reject "a..b", ".a", "a." before touching the tree (strtok would
     * silently merge them into "a.b"). */
    if (path[0] == '.' || path[path_len - 1] == '.' || strstr(path, ".."))
        return volux_json_error(r, VOLUX_ERR_INVALID, NULL, "--set %.*s: empty key in the path", (int)path_len,
                                assignment);
    cJSON *value = NULL;
    volux_status st = override_value(r, assignment, eq + 1, &value);
    if (st) return st;

    cJSON *node = root, *child = NULL;
    char *seg = path;
    for (;;) {
        char *dot = strchr(seg, '.');
        char *next = NULL;
        if (dot) {
            *dot = 0;
            next = dot + 1;
        }
        /* The path up to and including this segment, for messages. */
        int upto = (int)(seg - path + (ptrdiff_t)strlen(seg));
        long idx;
        child = NULL;
        if (cJSON_IsArray(node)) {
            int size = cJSON_GetArraySize(node);
            if (!is_index(seg, &idx) || idx > size) {
                cJSON_Delete(value);
                char range[48] = "empty";
                if (size > 0) snprintf(range, sizeof range, "0..%d", size - 1);
                return volux_json_error(r, VOLUX_ERR_INVALID, NULL,
                                        "--set %.*s: '%s' is not an index of the array (%s; %d appends)", upto,
                                        assignment, seg, range, size);
            }
            if (idx == size) { /* append */
                child = next ? new_container(next) : value;
                if (!child || !cJSON_AddItemToArray(node, child)) goto nomem_child;
                if (!next) return VOLUX_OK;
            } else if (!next) {
                if (!cJSON_ReplaceItemInArray(node, (int)idx, value)) goto nomem;
                return VOLUX_OK;
            } else {
                child = cJSON_GetArrayItem(node, (int)idx);
            }
        } else if (cJSON_IsObject(node)) {
            child = cJSON_GetObjectItemCaseSensitive(node, seg);
            if (!next) {
                if (child ? !cJSON_ReplaceItemInObjectCaseSensitive(node, seg, value)
                          : !cJSON_AddItemToObject(node, seg, value))
                    goto nomem;
                return VOLUX_OK;
            }
            if (!child) {
                child = new_container(next);
                if (!child || !cJSON_AddItemToObject(node, seg, child)) goto nomem_child;
            }
        } else {
            cJSON_Delete(value);
            int before = seg > path ? (int)(seg - path - 1) : 0;
            return volux_json_error(r, VOLUX_ERR_INVALID, NULL, "--set %.*s: '%.*s' is a value, not an object or array",
                                    (int)path_len, assignment, before, assignment);
        }
        node = child;
        seg = next;
    }
nomem_child:
    if (child && child != value) cJSON_Delete(child);
nomem:
    cJSON_Delete(value);
    return volux_json_error(r, VOLUX_ERR_NOMEM, NULL, "--set %s: out of memory", assignment);
}
