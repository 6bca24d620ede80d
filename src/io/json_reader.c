/* io/json_reader.c — see json_reader.h. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "json_reader.h"

#define JSON_MAX_BYTES (64u << 20)

volux_status volux_json_error(volux_json_reader *r, volux_status st, const char *path, const char *fmt, ...) {
    char msg[768];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    return volux_error(r->ctx, st, "%s: %s%s%s", r->file, path && *path ? path : "", path && *path ? ": " : "", msg);
}

volux_status volux_json_read_file(volux_context *ctx, const char *path, char **buf, size_t *n) {
    FILE *f = fopen(path, "rb");
    if (!f) return volux_error(ctx, VOLUX_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    if (fseek(f, 0, SEEK_END) != 0) {
        fclose(f);
        return volux_error(ctx, VOLUX_ERR_IO, "%s: cannot seek", path);
    }
    long size = ftell(f);
    if (size < 0 || (unsigned long)size > JSON_MAX_BYTES) {
        fclose(f);
        return volux_error(ctx, size < 0 ? VOLUX_ERR_IO : VOLUX_ERR_LIMIT, "%s: %s", path,
                           size < 0 ? "cannot determine the size" : "larger than 64 MiB");
    }
    rewind(f);
    char *b = volux_malloc(ctx, (size_t)size + 1);
    if (!b) {
        fclose(f);
        return volux_error(ctx, VOLUX_ERR_NOMEM, "%s: out of memory", path);
    }
    size_t got = fread(b, 1, (size_t)size, f);
    fclose(f);
    if (got != (size_t)size) {
        volux_free(ctx, b, (size_t)size + 1);
        return volux_error(ctx, VOLUX_ERR_IO, "%s: read error", path);
    }
    b[size] = 0;
    *buf = b;
    *n = (size_t)size;
    return VOLUX_OK;
}

volux_status volux_json_parse(volux_json_reader *r, const char *text, size_t n, cJSON **out) {
    if (n > JSON_MAX_BYTES) return volux_json_error(r, VOLUX_ERR_LIMIT, NULL, "JSON text larger than 64 MiB");
    const char *end = NULL;
    cJSON *root = cJSON_ParseWithLengthOpts(text, n, &end, 0);
    if (!root) {
        /* Locate the failure for the message (cJSON reports a pointer). */
        size_t at = end && end >= text && end <= text + n ? (size_t)(end - text) : 0;
        int line = 1, col = 1;
        for (size_t i = 0; i < at; i++) {
            if (text[i] == '\n') line++, col = 1;
            else col++;
        }
        return volux_json_error(r, VOLUX_ERR_FORMAT, NULL, "invalid JSON near line %d, column %d", line, col);
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
        int ok = 0;
        for (const char *const *a = allowed; *a && !ok; a++) ok = c->string && !strcmp(c->string, *a);
        if (!ok) {
            char p[256];
            join(p, sizeof p, path, c->string ? c->string : "?");
            char list[512] = "";
            for (const char *const *a = allowed; *a; a++) {
                if (strlen(list) + strlen(*a) + 3 >= sizeof list) break;
                if (*list) strcat(list, ", ");
                strcat(list, *a);
            }
            return volux_json_error(r, VOLUX_ERR_INVALID, p, "unknown key (expected one of: %s)", list);
        }
        /* cJSON keeps duplicate keys; the second would be silently ignored. */
        for (const cJSON *d = c->next; d; d = d->next)
            if (d->string && c->string && !strcmp(d->string, c->string)) {
                char p[256];
                join(p, sizeof p, path, c->string);
                return volux_json_error(r, VOLUX_ERR_INVALID, p, "duplicate key");
            }
    }
    return VOLUX_OK;
}

volux_status volux_json_number(volux_json_reader *r, const cJSON *obj, const char *path, const char *key, double lo,
                               double hi, double *out) {
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, key);
    if (!v) return VOLUX_OK;
    char p[256];
    join(p, sizeof p, path, key);
    if (!cJSON_IsNumber(v)) return volux_json_error(r, VOLUX_ERR_INVALID, p, "expected a number");
    double d = v->valuedouble;
    if (!isfinite(d) || d < lo || d > hi)
        return volux_json_error(r, VOLUX_ERR_INVALID, p, "%g is outside [%g, %g]", d, lo, hi);
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
        if (!cJSON_IsNumber(c) || !isfinite(c->valuedouble) || c->valuedouble < lo || c->valuedouble > hi)
            return volux_json_error(r, VOLUX_ERR_INVALID, p, "element %d must be a number in [%g, %g]", i, lo, hi);
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
        if (!cJSON_IsArray(row) || cJSON_GetArraySize(row) != width) {
            volux_free(r->ctx, out, sizeof(float) * (size_t)n * (size_t)width);
            return volux_json_error(r, VOLUX_ERR_INVALID, p, "row %d: expected %d numbers", i, width);
        }
        int j = 0;
        for (const cJSON *c = row->child; c; c = c->next, j++) {
            if (!cJSON_IsNumber(c) || !isfinite(c->valuedouble) || fabs(c->valuedouble) > 1e30) {
                volux_free(r->ctx, out, sizeof(float) * (size_t)n * (size_t)width);
                return volux_json_error(r, VOLUX_ERR_INVALID, p, "row %d: element %d is not a finite number", i, j);
            }
            out[(size_t)i * (size_t)width + (size_t)j] = (float)c->valuedouble;
        }
    }
    *rows = out;
    *count = n;
    return VOLUX_OK;
}

static int is_index(const char *s, long *out) {
    if (!*s) return 0;
    char *end;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (*end || errno || v < 0) return 0;
    *out = v;
    return 1;
}

volux_status volux_json_apply_override(volux_json_reader *r, cJSON *root, const char *assignment) {
    const char *eq = strchr(assignment, '=');
    if (!eq || eq == assignment)
        return volux_error(r->ctx, VOLUX_ERR_INVALID, "--set %s: expected dotted.path=value", assignment);
    size_t path_len = (size_t)(eq - assignment);
    char path[512];
    if (path_len >= sizeof path) return volux_error(r->ctx, VOLUX_ERR_INVALID, "--set: path too long");
    memcpy(path, assignment, path_len);
    path[path_len] = 0;
    const char *value_text = eq + 1;
    cJSON *value = cJSON_Parse(value_text);
    if (!value) value = cJSON_CreateString(value_text); /* bare words: render.technique=shaded */
    if (!value) return volux_error(r->ctx, VOLUX_ERR_NOMEM, "--set: out of memory");

    cJSON *node = root;
    char *save = NULL;
    char *seg = strtok_r(path, ".", &save);
    while (seg) {
        char *next = strtok_r(NULL, ".", &save);
        long idx;
        if (cJSON_IsArray(node)) {
            if (!is_index(seg, &idx) || idx >= cJSON_GetArraySize(node)) {
                cJSON_Delete(value);
                return volux_error(r->ctx, VOLUX_ERR_INVALID, "--set %.*s: '%s' is not an index of the array",
                                   (int)path_len, assignment, seg);
            }
            if (!next) {
                cJSON_ReplaceItemInArray(node, (int)idx, value);
                return VOLUX_OK;
            }
            node = cJSON_GetArrayItem(node, (int)idx);
        } else if (cJSON_IsObject(node)) {
            cJSON *child = cJSON_GetObjectItemCaseSensitive(node, seg);
            if (!next) {
                if (child) cJSON_ReplaceItemInObjectCaseSensitive(node, seg, value);
                else cJSON_AddItemToObject(node, seg, value);
                return VOLUX_OK;
            }
            if (!child) {
                child = cJSON_AddObjectToObject(node, seg);
                if (!child) {
                    cJSON_Delete(value);
                    return volux_error(r->ctx, VOLUX_ERR_NOMEM, "--set: out of memory");
                }
            }
            node = child;
        } else {
            cJSON_Delete(value);
            return volux_error(r->ctx, VOLUX_ERR_INVALID, "--set %.*s: '%s' is inside a value that is not an object",
                               (int)path_len, assignment, seg);
        }
        seg = next;
    }
    cJSON_Delete(value);
    return volux_error(r->ctx, VOLUX_ERR_INVALID, "--set %s: empty path", assignment);
}
