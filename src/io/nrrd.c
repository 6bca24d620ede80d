/*
 * io/nrrd.c — NRRD header parser (NRRD0001..NRRD0005), after the format
 * definition at teem.sourceforge.net/nrrd/format.html.
 *
 * Reads: type, dimension (3, or 4 with a size-1 first or last axis),
 * sizes, endian, encoding (raw, gzip/gz), spacings, space directions
 * (spacing = vector length; rotations are not representable in a volux
 * volume and are dropped), space origin, byte skip, line skip, data file.
 * Ignores: comments, key:=value pairs and the descriptive fields listed in
 * `ignored` below. Anything else is an unknown field and an error, as in
 * Teem: a field we do not understand may change how the data is laid out.
 */
#include <math.h>
#include <string.h>

#include "header_text.h"
#include "volume_formats.h"

#define MAX_AXES 16  /* NRRD_DIM_MAX */
#define MAX_SPACE 8  /* NRRD_SPACE_DIM_MAX */

enum field {
    F_TYPE,
    F_DIMENSION,
    F_SIZES,
    F_ENDIAN,
    F_ENCODING,
    F_SPACINGS,
    F_SPACE_DIRECTIONS,
    F_SPACE_ORIGIN,
    F_BYTE_SKIP,
    F_LINE_SKIP,
    F_DATA_FILE,
    F_SPACE,
    F_COUNT,
    F_IGNORED = F_COUNT
};

static const struct {
    const char *name;
    int id;
} known[] = {
    {"type", F_TYPE},
    {"dimension", F_DIMENSION},
    {"sizes", F_SIZES},
    {"endian", F_ENDIAN},
    {"encoding", F_ENCODING},
    {"spacings", F_SPACINGS},
    {"space directions", F_SPACE_DIRECTIONS},
    {"space origin", F_SPACE_ORIGIN},
    {"byte skip", F_BYTE_SKIP},
    {"byteskip", F_BYTE_SKIP},
    {"line skip", F_LINE_SKIP},
    {"lineskip", F_LINE_SKIP},
    {"data file", F_DATA_FILE},
    {"datafile", F_DATA_FILE},
    /* Descriptive fields: nothing in them changes where or how values are. */
    {"content", F_IGNORED},
    {"number", F_IGNORED},
    {"block size", F_IGNORED},
    {"blocksize", F_IGNORED},
    {"min", F_IGNORED},
    {"max", F_IGNORED},
    {"old min", F_IGNORED},
    {"oldmin", F_IGNORED},
    {"old max", F_IGNORED},
    {"oldmax", F_IGNORED},
    {"axis mins", F_IGNORED},
    {"axismins", F_IGNORED},
    {"axis maxs", F_IGNORED},
    {"axismaxs", F_IGNORED},
    {"thicknesses", F_IGNORED},
    {"centers", F_IGNORED},
    {"centerings", F_IGNORED},
    {"labels", F_IGNORED},
    {"units", F_IGNORED},
    {"kinds", F_IGNORED},
    {"space", F_SPACE},
    {"space dimension", F_IGNORED},
    {"space units", F_IGNORED},
    {"measurement frame", F_IGNORED},
    {"sample units", F_IGNORED},
    {"sampleunits", F_IGNORED},
};

typedef struct parser {
    volux_context *ctx;
    const char *name;
    volux_text value[F_COUNT];
    int present[F_COUNT];
} parser;

static const char *field_name(int id) {
    for (size_t i = 0; i < sizeof known / sizeof known[0]; i++)
        if (known[i].id == id) return known[i].name;
    return "?";
}

/* Parses "(a,b,c)" at the start of *rest; returns components read. */
static volux_status parse_vector(parser *p, const char *field, volux_text *rest, double *v, int *count) {
    char q[80];
    volux_text t = volux_text_trim(*rest);
    const char *close = t.n ? memchr(t.p, ')', t.n) : NULL;
    if (!t.n || t.p[0] != '(' || !close)
        return volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: %s: expected a vector like (1,0,0), got '%s'", p->name, field,
                           volux_text_quote(t, q, sizeof q));
    volux_text inner = {t.p + 1, (size_t)(close - t.p) - 1};
    rest->p = close + 1;
    rest->n = t.n - (size_t)(close - t.p) - 1;
    int n = 0;
    while (1) {
        const char *comma = inner.n ? memchr(inner.p, ',', inner.n) : NULL;
        volux_text part = {inner.p, comma ? (size_t)(comma - inner.p) : inner.n};
        if (n == MAX_SPACE || !volux_text_to_double(volux_text_trim(part), &v[n]))
            return volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: %s: bad vector component '%s'", p->name, field,
                               volux_text_quote(part, q, sizeof q));
        n++;
        if (!comma) break;
        inner.n -= (size_t)(comma - inner.p) + 1;
        inner.p = comma + 1;
    }
    *count = n;
    return VOLUX_OK;
}

/* Splits the header into lines and records each field's value. */
static volux_status scan_lines(parser *p, const char *bytes, size_t n, uint64_t *data_offset, int *ended) {
    char q[80];
    size_t pos = 0;
    volux_text line = {"", 0}; /* an empty input has no first line */
    int terminated, lineno = 1;
    if (!volux_text_line(bytes, n, &pos, &line, &terminated) || line.n != 8 || memcmp(line.p, "NRRD000", 7) != 0 ||
        line.p[7] < '1' || line.p[7] > '5')
        return volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: not a NRRD file (first line '%s', expected NRRD0001..NRRD0005)",
                           p->name, volux_text_quote(line, q, sizeof q));
    *ended = 0;
    while (volux_text_line(bytes, n, &pos, &line, &terminated)) {
        lineno++;
        if (line.n == 0 && terminated) {
            *ended = 1; /* an empty line ends the header; attached data follows */
            break;
        }
        if (volux_text_find_nul(line) >= 0)
            return volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: line %d: NUL byte in the header", p->name, lineno);
        if (line.n > 0 && line.p[0] == '#') continue;
        const char *colon = memchr(line.p, ':', line.n);
        if (!colon)
            return volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: line %d: expected 'field: value', got '%s'", p->name,
                               lineno, volux_text_quote(line, q, sizeof q));
        size_t klen = (size_t)(colon - line.p);
        if (klen + 1 < line.n && colon[1] == '=') continue; /* key:=value pairs carry no layout */
        volux_text key = volux_text_trim((volux_text){line.p, klen});
        volux_text value = volux_text_trim((volux_text){colon + 1, line.n - klen - 1});
        int id = -1;
        for (size_t i = 0; i < sizeof known / sizeof known[0] && id < 0; i++)
            if (volux_text_eq(key, known[i].name)) id = known[i].id;
        if (id < 0)
            return volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: line %d: unknown field '%s'", p->name, lineno,
                               volux_text_quote(key, q, sizeof q));
        if (id == F_IGNORED) continue;
        if (p->present[id])
            return volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: %s: given twice", p->name, field_name(id));
        p->present[id] = 1;
        p->value[id] = value;
        volux_text rest = value, first;
        if (id == F_DATA_FILE && volux_text_token(&rest, &first) && volux_text_eq(first, "LIST"))
            break; /* the remaining lines are the data files' names */
    }
    if (!*ended && n >= VOLUX_MAX_HEADER_BYTES)
        return volux_error(p->ctx, VOLUX_ERR_LIMIT, "%s: header is longer than the limit of %u bytes", p->name,
                           (unsigned)VOLUX_MAX_HEADER_BYTES);
    *data_offset = pos;
    return VOLUX_OK;
}

static volux_status parse_type(parser *p, volux_volume_header *h) {
    char q[80], buf[40];
    volux_text v = p->value[F_TYPE];
    if (volux_text_eq(v, "block")) /* opaque bytes, not a scalar */
        return volux_error(p->ctx, VOLUX_ERR_UNSUPPORTED,
                           "%s: type: 'block' is not supported (use an integer or floating-point type)", p->name);
    if (v.n < sizeof buf) {
        memcpy(buf, v.p, v.n);
        buf[v.n] = 0;
        if (volux_scalar_type_parse(buf, &h->type) == 0) return VOLUX_OK;
    }
    return volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: type: unknown type '%s'", p->name, volux_text_quote(v, q, sizeof q));
}

static volux_status parse_encoding(parser *p, volux_volume_header *h) {
    static const char *const unsupported[] = {"txt", "text", "ascii", "hex", "bz2", "bzip2", "zrl"};
    char q[80];
    volux_text v = p->value[F_ENCODING];
    if (volux_text_eq(v, "raw")) h->encoding = VOLUX_ENCODING_RAW;
    else if (volux_text_eq(v, "gzip") || volux_text_eq(v, "gz")) h->encoding = VOLUX_ENCODING_ZLIB;
    else {
        for (size_t i = 0; i < sizeof unsupported / sizeof unsupported[0]; i++)
            if (volux_text_eq(v, unsupported[i]))
                return volux_error(p->ctx, VOLUX_ERR_UNSUPPORTED,
                                   "%s: encoding: '%s' is not supported (use raw or gzip)", p->name, unsupported[i]);
        return volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: encoding: unknown encoding '%s'", p->name,
                           volux_text_quote(v, q, sizeof q));
    }
    return VOLUX_OK;
}

/* The anatomical spaces (NRRD format 5, "space"): all three have +z =
 * superior, the direction "up" means for medical data. Other spaces
 * (scanner-xyz, 3D-right-handed, ...) say nothing about up. */
static int anatomical_space(volux_text v) {
    static const char *const names[] = {"right-anterior-superior", "left-anterior-superior", "left-posterior-superior",
                                        "right-anterior-superior-time", "left-anterior-superior-time",
                                        "left-posterior-superior-time", "RAS", "LAS", "LPS", "RAST", "LAST", "LPST"};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++)
        if (volux_text_eq(volux_text_trim(v), names[i])) return 1;
    return 0;
}

/* Spacing per spatial axis from "spacings" or "space directions"; the
 * superior direction when the space is anatomical. */
static volux_status parse_spacing(parser *p, int ndim, const int axes[3], volux_volume_header *h) {
    char q[80];
    int anatomical = p->present[F_SPACE] && anatomical_space(p->value[F_SPACE]);
    double up[3] = {0.0, 0.0, 1.0}; /* no directions: the grid is the space */
    if (p->present[F_SPACINGS] && p->present[F_SPACE_DIRECTIONS])
        return volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: spacings: not allowed together with space directions",
                           p->name);
    if (p->present[F_SPACINGS]) {
        volux_text rest = p->value[F_SPACINGS], tok;
        double s[MAX_AXES];
        for (int i = 0; i < ndim; i++) {
            if (!volux_text_token(&rest, &tok))
                return volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: spacings: expected %d values, got %d", p->name, ndim, i);
            if (!volux_text_to_double(tok, &s[i]))
                return volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: spacings: expected a number, got '%s'", p->name,
                                   volux_text_quote(tok, q, sizeof q));
        }
        if (volux_text_token(&rest, &tok))
            return volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: spacings: more than %d values", p->name, ndim);
        for (int a = 0; a < 3; a++) {
            double v = s[axes[a]];
            if (isnan(v)) { /* NaN means "unknown" in NRRD: assumed 1, and said so */
                volux_warn(p->ctx, "%s: spacings: axis %d is NaN (unknown): 1 assumed", p->name, axes[a]);
                v = 1.0;
            }
            if (!isfinite(v) || v == 0.0)
                return volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: spacings: axis %d spacing must be nonzero and finite, got %g",
                                   p->name, axes[a], v);
            /* A negative spacing means the axis runs the other way; volux
             * grids are not mirrored, so the image would be a mirror image
             * of what the file means: say so. */
            if (v < 0.0)
                volux_warn(p->ctx, "%s: spacings: axis %d is negative (%g): rendered unmirrored, as if %g", p->name,
                           axes[a], v, -v);
            h->spacing[a] = fabs(v);
        }
    }
    if (p->present[F_SPACE_DIRECTIONS]) {
        volux_text rest = p->value[F_SPACE_DIRECTIONS], tok;
        int space = -1;
        double dir[3][MAX_SPACE];
        for (int i = 0; i < ndim; i++) {
            volux_text t = volux_text_trim(rest);
            if (t.n >= 4 && memcmp(t.p, "none", 4) == 0) {
                volux_text_token(&rest, &tok);
                if (!volux_text_eq(tok, "none"))
                    return volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: space directions: bad entry '%s'", p->name,
                                       volux_text_quote(tok, q, sizeof q));
                for (int a = 0; a < 3; a++)
                    if (axes[a] == i)
                        return volux_error(p->ctx, VOLUX_ERR_FORMAT,
                                           "%s: space directions: axis %d is spatial but its direction is 'none'",
                                           p->name, i);
                continue;
            }
            double v[MAX_SPACE];
            int n;
            volux_status st = parse_vector(p, "space directions", &rest, v, &n);
            if (st) return st;
            if (space >= 0 && n != space)
                return volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: space directions: vectors of different lengths (%d, %d)",
                                   p->name, space, n);
            space = n;
            double len2 = 0.0;
            for (int c = 0; c < n; c++) len2 += v[c] * v[c];
            double len = sqrt(len2);
            for (int a = 0; a < 3; a++)
                if (axes[a] == i) {
                    if (!isfinite(len) || len == 0.0)
                        return volux_error(p->ctx, VOLUX_ERR_FORMAT,
                                           "%s: space directions: axis %d has a zero or non-finite vector", p->name, i);
                    h->spacing[a] = len;
                    memcpy(dir[a], v, sizeof v);
                    /* Superior's component along this grid axis: the
                     * axis' unit direction · +z of the space. */
                    up[a] = n >= 3 ? v[2] / len : 0.0;
                }
        }
        if (volux_text_token(&rest, &tok))
            return volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: space directions: more than %d entries", p->name, ndim);
        /* The three spatial axes must span space: parallel (or coplanar)
         * directions are a broken header, not a volume (Gram determinant,
         * relative to the lengths; works for any space dimension). */
        double g[3][3];
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++) {
                g[i][j] = 0.0;
                for (int c = 0; c < space; c++) g[i][j] += dir[i][c] * dir[j][c];
            }
        double det = g[0][0] * (g[1][1] * g[2][2] - g[1][2] * g[2][1]) - g[0][1] * (g[1][0] * g[2][2] - g[1][2] * g[2][0]) +
                     g[0][2] * (g[1][0] * g[2][1] - g[1][1] * g[2][0]);
        if (!(det > 1e-12 * g[0][0] * g[1][1] * g[2][2]))
            return volux_error(p->ctx, VOLUX_ERR_FORMAT,
                               "%s: space directions: the vectors of axes %d, %d, %d are parallel or coplanar "
                               "(they must span the space)",
                               p->name, axes[0], axes[1], axes[2]);
    }
    if (anatomical && up[0] * up[0] + up[1] * up[1] + up[2] * up[2] > 1e-12) {
        memcpy(h->superior, up, sizeof up);
        h->has_superior = 1;
    }
    if (p->present[F_SPACE_ORIGIN]) {
        volux_text rest = p->value[F_SPACE_ORIGIN], tok;
        double v[MAX_SPACE];
        int n;
        volux_status st = parse_vector(p, "space origin", &rest, v, &n);
        if (st) return st;
        if (volux_text_token(&rest, &tok))
            return volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: space origin: unexpected '%s' after the vector", p->name,
                               volux_text_quote(tok, q, sizeof q));
        if (n < 3)
            return volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: space origin: need 3 components, got %d", p->name, n);
        for (int a = 0; a < 3; a++) {
            if (!isfinite(v[a]))
                return volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: space origin: component %d is not finite", p->name, a);
            h->origin[a] = v[a];
        }
        h->has_origin = 1;
    }
    return VOLUX_OK;
}

static volux_status parse_skips(parser *p, volux_volume_header *h) {
    char q[80];
    int64_t v;
    if (p->present[F_BYTE_SKIP]) {
        if (!volux_text_to_i64(p->value[F_BYTE_SKIP], &v))
            return volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: byte skip: expected an integer, got '%s'", p->name,
                               volux_text_quote(p->value[F_BYTE_SKIP], q, sizeof q));
        if (v < -1)
            return volux_error(p->ctx, VOLUX_ERR_FORMAT,
                               "%s: byte skip: negative value %lld (only -1, meaning 'data at the end', is allowed)",
                               p->name, (long long)v);
        if (v == -1 && h->encoding != VOLUX_ENCODING_RAW)
            return volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: byte skip: -1 is only allowed with raw encoding",
                               p->name);
        h->byte_skip = v;
    }
    if (p->present[F_LINE_SKIP]) {
        if (!volux_text_to_i64(p->value[F_LINE_SKIP], &v) || v < 0)
            return volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: line skip: expected a non-negative integer, got '%s'",
                               p->name, volux_text_quote(p->value[F_LINE_SKIP], q, sizeof q));
        h->line_skip = (uint64_t)v;
    }
    return VOLUX_OK;
}

/* "LIST [subdim]" or "FORMAT MIN MAX STEP [subdim]" (NRRD0004 §data file). */
static int is_multi_file(volux_text value) {
    volux_text rest = value, tok;
    int tokens = 0, numeric = 0;
    int64_t ignored;
    while (volux_text_token(&rest, &tok)) {
        if (tokens == 0 && volux_text_eq(tok, "LIST")) return 1;
        if (tokens > 0) numeric += volux_text_to_i64(tok, &ignored);
        tokens++;
    }
    return (tokens == 4 || tokens == 5) && numeric == tokens - 1;
}

/* A printf format with exactly one integer conversion (%d %i %u %x %X
 * %o with flags and width, no precision/length) and no other '%' but
 * "%%": what the slice numbers are formatted with. */
static int valid_number_format(const char *f) {
    int conversions = 0;
    for (const char *c = f; *c; c++) {
        if (*c != '%') continue;
        if (c[1] == '%') {
            c++;
            continue;
        }
        c++;
        while (*c && strchr("-+ 0#", *c)) c++;
        for (int digits = 0; *c >= '0' && *c <= '9'; c++)
            if (++digits > 3) return 0;
        if (!*c || !strchr("diuxXo", *c)) return 0;
        conversions++;
    }
    return conversions == 1;
}

static volux_status parse_multi_file(parser *p, int ndim, const int64_t *sizes, uint64_t list_offset,
                                     volux_volume_header *h) {
    char q[80];
    volux_text rest = p->value[F_DATA_FILE], tok[5];
    int n = 0;
    while (n < 5 && volux_text_token(&rest, &tok[n])) n++;
    int list = volux_text_eq(tok[0], "LIST");
    if (volux_text_token(&rest, &tok[0]) || (list && n > 2))
        return volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: data file: too many words in '%s'", p->name,
                           volux_text_quote(p->value[F_DATA_FILE], q, sizeof q));
    /* subdim: the dimension of each file's data (default: all but the
     * slowest axis, i.e. one file per slice). */
    int64_t subdim = ndim - 1;
    int has_sub = list ? n == 2 : n == 5;
    if (has_sub && (!volux_text_to_i64(tok[n - 1], &subdim) || subdim < 1 || subdim > ndim))
        return volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: data file: subdim must be in [1, %d], got '%s'", p->name,
                           ndim, volux_text_quote(tok[n - 1], q, sizeof q));
    int64_t files = 1;
    for (int a = (int)subdim; a < ndim && files <= VOLUX_MAX_DATA_FILES; a++) files *= sizes[a]; /* ≤ 2^14 · 2^14 */
    if (files > VOLUX_MAX_DATA_FILES || files < 1)
        return volux_error(p->ctx, VOLUX_ERR_LIMIT, "%s: data file: %lld files (subdim %lld) is over the limit of %d",
                           p->name, (long long)files, (long long)subdim, VOLUX_MAX_DATA_FILES);
    h->file_count = (int)files;
    h->data_offset = 0;
    if (list) {
        h->file_list = 1;
        h->list_offset = list_offset;
        return VOLUX_OK;
    }
    int64_t lo, hi, step;
    volux_text_to_i64(tok[1], &lo);
    volux_text_to_i64(tok[2], &hi);
    volux_text_to_i64(tok[3], &step);
    if (step == 0 || (step > 0 ? hi < lo : hi > lo))
        return volux_error(p->ctx, VOLUX_ERR_FORMAT, "%s: data file: step %lld never goes from %lld to %lld", p->name,
                           (long long)step, (long long)lo, (long long)hi);
    /* |hi − lo| fits: both are int64 parsed from text, but their difference
     * may not; compare in unsigned arithmetic. */
    uint64_t span = step > 0 ? (uint64_t)hi - (uint64_t)lo : (uint64_t)lo - (uint64_t)hi;
    uint64_t mag = step > 0 ? (uint64_t)step : 0 - (uint64_t)step;
    if (span / mag + 1 != (uint64_t)files)
        return volux_error(p->ctx, VOLUX_ERR_FORMAT,
                           "%s: data file: %lld..%lld step %lld names %llu files, the sizes need %lld", p->name,
                           (long long)lo, (long long)hi, (long long)step, (unsigned long long)(span / mag + 1),
                           (long long)files);
    if (tok[0].n > VOLUX_MAX_DATA_NAME - 24)
        return volux_error(p->ctx, VOLUX_ERR_LIMIT, "%s: data file: format of %zu characters is too long", p->name,
                           tok[0].n);
    memcpy(h->data_file, tok[0].p, tok[0].n);
    h->data_file[tok[0].n] = 0;
    if (!valid_number_format(h->data_file))
        return volux_error(p->ctx, VOLUX_ERR_FORMAT,
                           "%s: data file: '%s' must hold exactly one integer conversion such as %%03d", p->name,
                           volux_text_quote(tok[0], q, sizeof q));
    h->file_first = lo;
    h->file_step = step;
    return VOLUX_OK;
}

volux_status volux_nrrd_parse_header(volux_context *ctx, const char *bytes, size_t n, const char *name,
                                     volux_volume_header *out) {
    char q[80];
    parser p;
    memset(&p, 0, sizeof p);
    p.ctx = ctx;
    p.name = name;
    volux_volume_header h;
    volux_volume_header_init(&h);
    uint64_t header_end = 0;
    int ended = 0;
    volux_status st = scan_lines(&p, bytes, n, &header_end, &ended);
    if (st) return st;

    static const int required[] = {F_TYPE, F_DIMENSION, F_SIZES, F_ENCODING};
    for (size_t i = 0; i < sizeof required / sizeof required[0]; i++)
        if (!p.present[required[i]])
            return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: missing required field '%s'", name, field_name(required[i]));

    int64_t ndim;
    if (!volux_text_to_i64(p.value[F_DIMENSION], &ndim) || ndim < 1 || ndim > MAX_AXES)
        return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: dimension: expected an integer in [1, %d], got '%s'", name,
                           MAX_AXES, volux_text_quote(p.value[F_DIMENSION], q, sizeof q));
    int64_t sizes[MAX_AXES];
    int axes[3];
    if ((st = volux_header_sizes(ctx, name, "sizes", p.value[F_SIZES], (int)ndim, sizes))) return st;
    if ((st = volux_header_axes(ctx, name, "sizes", sizes, (int)ndim, &h, axes))) return st;
    if ((st = parse_type(&p, &h))) return st;
    if ((st = parse_encoding(&p, &h))) return st;

    if (p.present[F_ENDIAN]) {
        volux_text v = p.value[F_ENDIAN];
        if (volux_text_eq(v, "big")) h.big_endian = 1;
        else if (!volux_text_eq(v, "little"))
            return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: endian: expected 'little' or 'big', got '%s'", name,
                               volux_text_quote(v, q, sizeof q));
    } else if (volux_scalar_type_size(h.type) > 1) {
        return volux_error(ctx, VOLUX_ERR_FORMAT, "%s: endian: missing, but %s data needs a byte order", name,
                           volux_scalar_type_name(h.type));
    }
    if ((st = parse_spacing(&p, (int)ndim, axes, &h))) return st;
    if ((st = parse_skips(&p, &h))) return st;
    /* Teem reads raw data followed by more bytes, with a warning. */
    h.trailing_ok = h.encoding == VOLUX_ENCODING_RAW;

    if (p.present[F_DATA_FILE] && is_multi_file(p.value[F_DATA_FILE])) {
        if ((st = parse_multi_file(&p, (int)ndim, sizes, header_end, &h))) return st;
    } else if (p.present[F_DATA_FILE]) {
        if ((st = volux_header_data_file(ctx, name, "data file", p.value[F_DATA_FILE], &h))) return st;
    } else if (!ended) {
        return volux_error(ctx, VOLUX_ERR_FORMAT,
                           "%s: no 'data file' field and no empty line ending the header, so there is no data", name);
    } else {
        h.data_offset = header_end;
    }
    if ((st = volux_volume_header_check(ctx, name, &h))) return st;
    *out = h;
    return VOLUX_OK;
}
