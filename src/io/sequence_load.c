/*
 * io/sequence_load.c — time-varying volumes from files (a list, or a
 * printf-style pattern over a range of numbers) and the animated procedural
 * cloud, as core sequences (volux/sequence.h) whose loader reads one step
 * on demand.
 *
 * File sequences read every frame's header when they are created, so a
 * missing frame or one whose dims, type or spacing differ from the first
 * is reported at load time, naming both files (the core checks each step
 * again when it is loaded).
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "volume_formats.h"
#include "volux/sequence.h"

/* ------------------------------------------------------------------ files */

typedef struct file_frames {
    int n;
    char **paths;
    volux_volume_load_options options;
    volux_raw_desc raw; /* options.raw points here when the frames are raw */
    char *data_root;    /* options.data_root points here: frames load later */
} file_frames;

static void free_frames(volux_context *ctx, void *user) {
    file_frames *f = user;
    if (!f) return;
    for (int i = 0; i < f->n; i++) volux_strfree(ctx, f->paths[i]);
    volux_free(ctx, f->paths, sizeof *f->paths * (size_t)f->n);
    if (f->data_root) volux_strfree(ctx, f->data_root);
    volux_free(ctx, f, sizeof *f);
}

static volux_status load_frame(void *user, volux_context *ctx, int step, volux_volume **out) {
    const file_frames *f = user;
    return volux_volume_load(ctx, f->paths[step], &f->options, out);
}

static volux_status probe_frames(volux_context *ctx, const file_frames *f) {
    volux_volume_shape first, s;
    for (int i = 0; i < f->n; i++) {
        volux_status st = volux_volume_probe(ctx, f->paths[i], &f->options, i ? &s : &first);
        if (st) {
            volux_error_prefix(ctx, "time step %d: ", i);
            return st;
        }
        if (!i) continue;
        const char *what = memcmp(s.dims, first.dims, sizeof s.dims) ? "dims"
                           : s.type != first.type                    ? "scalar type"
                           : memcmp(s.spacing, first.spacing, sizeof s.spacing) ? "spacing"
                                                                                : NULL;
        if (what)
            return volux_error(ctx, VOLUX_ERR_FORMAT,
                               "time step %d (%s) is %dx%dx%d %s, spacing %g %g %g, but time step 0 (%s) is "
                               "%dx%dx%d %s, spacing %g %g %g: all frames must share dims, type and spacing (%s "
                               "differ)",
                               i, f->paths[i], s.dims[0], s.dims[1], s.dims[2], volux_scalar_type_name(s.type),
                               s.spacing[0], s.spacing[1], s.spacing[2], f->paths[0], first.dims[0], first.dims[1],
                               first.dims[2], volux_scalar_type_name(first.type), first.spacing[0], first.spacing[1],
                               first.spacing[2], what);
    }
    return VOLUX_OK;
}

/* Takes ownership of f (frees it on failure). */
static volux_status make_file_sequence(volux_context *ctx, file_frames *f, const char *name, uint64_t cache_bytes,
                                       volux_sequence **out) {
    volux_status st = probe_frames(ctx, f);
    if (st) {
        free_frames(ctx, f);
        return st;
    }
    volux_sequence_desc d = {f->n, load_frame, f, free_frames, name, cache_bytes};
    st = volux_sequence_create(ctx, &d, out);
    if (st) free_frames(ctx, f);
    return st;
}

static file_frames *new_frames(volux_context *ctx, int n, const volux_volume_load_options *options) {
    file_frames *f = volux_calloc(ctx, 1, sizeof *f);
    if (!f) return NULL;
    f->paths = volux_calloc(ctx, (size_t)n, sizeof *f->paths);
    if (!f->paths) {
        volux_free(ctx, f, sizeof *f);
        return NULL;
    }
    f->n = n;
    if (options) {
        f->options = *options;
        if (options->raw) {
            f->raw = *options->raw;
            f->options.raw = &f->raw;
        }
        /* Frames load at time-step changes, long after the caller's root
         * string is gone: keep a copy. */
        if (options->data_root && !(f->options.data_root = f->data_root = volux_strdup(ctx, options->data_root))) {
            f->n = 0;
            free_frames(ctx, f);
            return NULL;
        }
    }
    return f;
}

volux_status volux_sequence_load_files(volux_context *ctx, const char *const *paths, int n,
                                       const volux_volume_load_options *options, uint64_t cache_bytes,
                                       volux_sequence **out) {
    if (n < 1 || n > VOLUX_MAX_STEPS)
        return volux_error(ctx, VOLUX_ERR_INVALID, "a sequence needs 1 to %d files, got %d", VOLUX_MAX_STEPS, n);
    file_frames *f = new_frames(ctx, n, options);
    if (!f) return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for a file sequence");
    for (int i = 0; i < n; i++)
        if (!(f->paths[i] = volux_strdup(ctx, paths[i]))) {
            free_frames(ctx, f);
            return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for a file sequence");
        }
    return make_file_sequence(ctx, f, paths[0], cache_bytes, out);
}

int volux_sequence_pattern_conversions(const char *pattern) {
    int conversions = 0;
    for (const char *p = pattern; *p; p++) {
        if (*p != '%') continue;
        if (p[1] == '%') {
            p++;
            continue;
        }
        const char *q = p + 1;
        if (*q == '0') q++;
        if (*q >= '1' && *q <= '9') q++;
        if (*q != 'd') return -1;
        conversions++;
        p = q;
    }
    return conversions;
}

volux_status volux_sequence_load_pattern(volux_context *ctx, const char *pattern, int first, int last, int stride,
                                         const volux_volume_load_options *options, uint64_t cache_bytes,
                                         volux_sequence **out) {
    if (!pattern || volux_sequence_pattern_conversions(pattern) != 1)
        return volux_error(ctx, VOLUX_ERR_INVALID,
                           "pattern '%s' must hold exactly one integer conversion (%%d, %%3d or %%03d; %%%% for a "
                           "literal %%)",
                           pattern ? pattern : "(null)");
    if (stride < 1 || last < first)
        return volux_error(ctx, VOLUX_ERR_INVALID, "range [%d, %d] step %d is empty (need first <= last, step >= 1)",
                           first, last, stride);
    int64_t n = ((int64_t)last - first) / stride + 1;
    if (n > VOLUX_MAX_STEPS)
        return volux_error(ctx, VOLUX_ERR_LIMIT, "range [%d, %d] step %d has %lld frames, more than %d", first, last,
                           stride, (long long)n, VOLUX_MAX_STEPS);
    file_frames *f = new_frames(ctx, (int)n, options);
    if (!f) return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for a file sequence");
    for (int i = 0; i < (int)n; i++) {
        char path[4096];
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wformat-nonliteral"
        int w = snprintf(path, sizeof path, pattern, first + i * stride);
#pragma GCC diagnostic pop
        if (w < 0 || (size_t)w >= sizeof path) {
            free_frames(ctx, f);
            return volux_error(ctx, VOLUX_ERR_INVALID, "pattern '%s': path too long", pattern);
        }
        if (!(f->paths[i] = volux_strdup(ctx, path))) {
            free_frames(ctx, f);
            return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for a file sequence");
        }
    }
    return make_file_sequence(ctx, f, pattern, cache_bytes, out);
}

/* ------------------------------------------------------------------ procedural */

typedef struct procedural_frames {
    char name[32];
    int dims[3];
    uint64_t seed;
    double time0, time_per_step;
} procedural_frames;

static void free_procedural(volux_context *ctx, void *user) { volux_free(ctx, user, sizeof(procedural_frames)); }

static volux_status load_procedural(void *user, volux_context *ctx, int step, volux_volume **out) {
    const procedural_frames *p = user;
    return volux_volume_procedural_at(ctx, p->name, p->dims, p->seed, p->time0 + step * p->time_per_step, out);
}

volux_status volux_sequence_procedural(volux_context *ctx, const char *name, const int dims[3], uint64_t seed,
                                       double time0, double time_per_step, int steps, uint64_t cache_bytes,
                                       volux_sequence **out) {
    if (!name || strlen(name) >= sizeof((procedural_frames *)0)->name || !volux_procedural_is_animated(name))
        return volux_error(ctx, VOLUX_ERR_INVALID, "procedural:%s: not animated (only cloud has time steps)",
                           name ? name : "(null)");
    double t_end = time0 + (steps - 1.0) * time_per_step;
    if (!isfinite(t_end) || fabs(t_end) > 1e6 || fabs(time0) > 1e6)
        return volux_error(ctx, VOLUX_ERR_INVALID, "procedural:%s: times %g .. %g are outside [-1e6, 1e6]", name, time0,
                           t_end);
    procedural_frames *p = volux_calloc(ctx, 1, sizeof *p);
    if (!p) return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for a procedural sequence");
    strcpy(p->name, name);
    memcpy(p->dims, dims, sizeof p->dims);
    p->seed = seed;
    p->time0 = time0;
    p->time_per_step = time_per_step;
    char label[64];
    snprintf(label, sizeof label, "procedural:%s", name);
    volux_sequence_desc d = {steps, load_procedural, p, free_procedural, label, cache_bytes};
    volux_status st = volux_sequence_create(ctx, &d, out);
    if (st) free_procedural(ctx, p);
    return st;
}
