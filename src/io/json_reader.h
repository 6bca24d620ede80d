/*
 * io/json_reader.h — strict reading of cJSON trees with paths in messages.
 *
 * Every value is read through a getter that knows its dotted path
 * ("lights[2].cone_angle"), checks type and range, and reports
 * "FILE: PATH: problem" through the context. volux_json_check_keys()
 * rejects keys an object does not define (pbrt's "unused parameter" rule,
 * DESIGN §3).
 */
#ifndef VOLUX_JSON_READER_H
#define VOLUX_JSON_READER_H

#include <cjson/cJSON.h>

#include "core/context_internal.h"

typedef struct volux_json_reader {
    volux_context *ctx;
    const char *file; /* for messages */
} volux_json_reader;

/* Deepest nesting of arrays/objects volux_json_parse accepts. Scenes and
 * presets need 4; the cap keeps cJSON's recursion (parse and delete) short. */
#define VOLUX_JSON_MAX_DEPTH 64

/* Parses text (length n; need not be NUL-terminated) into one value, with a
 * line/column message on error. Rejects NUL bytes and "\u0000" escapes
 * (they would truncate keys and file names), nesting deeper than
 * VOLUX_JSON_MAX_DEPTH (VOLUX_ERR_LIMIT), text after the value, and inputs
 * over 16 MiB. */
volux_status volux_json_parse(volux_json_reader *r, const char *text, size_t n, cJSON **out);
/* Reads a whole file (≤ 16 MiB) into a NUL-terminated buffer; free with
 * volux_free(ctx, buf, *n + 1). */
volux_status volux_json_read_file(volux_context *ctx, const char *path, char **buf, size_t *n);

/* Error at a path: "FILE: PATH: message". Returns status. */
volux_status volux_json_error(volux_json_reader *r, volux_status st, const char *path, const char *fmt, ...)
    VOLUX_PRINTF(4, 5);

/* `allowed` is NULL-terminated; NULL allows any key (then the caller bounds
 * the object's size: the duplicate check is quadratic). Rejects unknown and
 * duplicate keys, and non-objects, naming the path. */
volux_status volux_json_check_keys(volux_json_reader *r, const cJSON *obj, const char *path,
                                   const char *const *allowed);

/* Getters: absent keys leave *out unchanged and return VOLUX_OK (unless
 * documented). Paths are built as "<path>.<key>". */
volux_status volux_json_number(volux_json_reader *r, const cJSON *obj, const char *path, const char *key, double lo,
                               double hi, double *out);
volux_status volux_json_float(volux_json_reader *r, const cJSON *obj, const char *path, const char *key, double lo,
                              double hi, float *out);
volux_status volux_json_int(volux_json_reader *r, const cJSON *obj, const char *path, const char *key, long lo,
                            long hi, int *out);
volux_status volux_json_bool(volux_json_reader *r, const cJSON *obj, const char *path, const char *key, int *out);
/* *out points into the tree (valid while the tree lives). */
volux_status volux_json_string(volux_json_reader *r, const cJSON *obj, const char *path, const char *key,
                               const char **out);
volux_status volux_json_vec3(volux_json_reader *r, const cJSON *obj, const char *path, const char *key, double lo,
                             double hi, float out[3]);
/* An array of rows of exactly `width` numbers: allocates *rows (count·width
 * floats) through ctx; *count = 0 and *rows = NULL when absent. */
volux_status volux_json_rows(volux_json_reader *r, const cJSON *obj, const char *path, const char *key, int width,
                             int max_rows, float **rows, int *count);

/* Applies "dotted.path=VALUE" to the tree: VALUE is one JSON value, or a
 * bare string when it does not parse as JSON and does not start with [ { or
 * " (those are JSON errors). Numeric segments index arrays
 * ("lights.0.irradiance"); the index one past the end appends. Missing
 * keys are created: an array when the next segment is an index, else an
 * object. Errors name r->file and the assignment. */
volux_status volux_json_apply_override(volux_json_reader *r, cJSON *root, const char *assignment);

#endif
