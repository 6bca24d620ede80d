/* tools/cli/scene_args.c — see scene_args.h. */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

#include "scene_args.h"

static int add_override(const char *cmd, cli_scene_args *a, const char *fmt, const char *value) {
    if (a->n_overrides >= CLI_MAX_OVERRIDES) {
        cli_eprintf("volux %s: too many overrides (max %d)\n", cmd, CLI_MAX_OVERRIDES);
        return -1;
    }
    if (!strcmp(fmt, "%s")) {
        /* --set is used as given: point at argv (which outlives the
         * load) instead of copying, so a long value such as a whole TF
         * array is not cut at the storage slot's size. */
        a->overrides[a->n_overrides++] = value;
        return 1;
    }
    char *dst = a->storage[a->n_overrides];
    int n = snprintf(dst, sizeof a->storage[0], fmt, value);
    if (n < 0 || (size_t)n >= sizeof a->storage[0]) {
        cli_eprintf("volux %s: option value too long: %s\n", cmd, value);
        return -1;
    }
    a->overrides[a->n_overrides++] = dst;
    return 1;
}

/* --memory-limit SIZE: a byte count with an optional binary suffix
 * (K, M, G, T: KiB ... TiB; "8G", "512M", "1.5G") or "none". 1 on success. */
static int parse_memory_limit(const char *cmd, const char *value, uint64_t *out) {
    if (!strcmp(value, "none")) {
        *out = UINT64_MAX;
        return 1;
    }
    char *end = NULL;
    errno = 0;
    double x = strtod(value, &end);
    double unit = 1.0;
    if (end && end != value && *end) {
        static const char units[] = "KMGT";
        const char *u = strchr(units, end[0] >= 'a' && end[0] <= 'z' ? end[0] - 32 : end[0]);
        if (u && end[0]) {
            for (const char *k = units; k <= u; k++) unit *= 1024.0;
            end++;
            if (*end == 'i' && end[1] == 'B') end += 2; /* "GiB" */
            else if (*end == 'B') end++;                /* "GB": the same binary unit */
        }
    }
    if (!end || end == value || *end || errno || !(x * unit >= 1.0) || x * unit > 1.8e19) {
        cli_eprintf("volux %s: --memory-limit %s: expected a size such as 8G, 512M, 1.5G or a byte count "
                    "(at least 1), or none\n",
                    cmd, value);
        return 0;
    }
    *out = (uint64_t)(x * unit);
    return 1;
}

int cli_scene_arg(const char *cmd, cli_scene_args *a, int argc, char **argv, int *i) {
    static const struct {
        const char *opt, *fmt;
    } map[] = {
        {"--technique", "render.technique=\"%s\""}, {"--spp", "render.spp=%s"},
        {"--width", "render.width=%s"},             {"--height", "render.height=%s"},
        {"--threads", "render.threads=%s"},         {"--seed", "render.seed=%s"},
        {"--step", "render.step=%s"},               {"--exposure", "render.exposure=%s"},
        {"--time-ms", "render.time_ms=%s"},         {"--target-error", "render.target_error=%s"},
        {"--max-depth", "render.max_depth=%s"},     {"--time-step", "render.time_step=%s"},
        {"--set", "%s"},
    };
    const char *arg = argv[*i];
    if (!strcmp(arg, "--memory-limit")) {
        if (*i + 1 >= argc) {
            cli_eprintf("volux %s: --memory-limit needs a size (e.g. 8G)\n", cmd);
            return -1;
        }
        return parse_memory_limit(cmd, argv[++*i], &a->memory_limit) ? 1 : -1;
    }
    if (!strcmp(arg, "--out-of-core")) {
        a->out_of_core = 1;
        return 1;
    }
    if (!strcmp(arg, "--dump-scene")) {
        if (*i + 1 >= argc) {
            cli_eprintf("volux %s: --dump-scene needs a file name\n", cmd);
            return -1;
        }
        a->dump_path = argv[++*i];
        return 1;
    }
    for (size_t k = 0; k < sizeof map / sizeof map[0]; k++) {
        if (strcmp(arg, map[k].opt)) continue;
        if (*i + 1 >= argc) {
            cli_eprintf("volux %s: %s needs a value\n", cmd, arg);
            return -1;
        }
        const char *value = argv[++*i];
        if (!strcmp(arg, "--set") && !strchr(value, '=')) {
            cli_eprintf("volux %s: --set %s: expected dotted.path=value\n", cmd, value);
            return -1;
        }
        if (strcmp(arg, "--set") && strcmp(arg, "--technique")) {
            /* Numeric options must be numbers (JSON would accept "true"). */
            double d;
            if (!cli_parse_double(cmd, arg, value, &d)) return -1;
        }
        return add_override(cmd, a, map[k].fmt, value);
    }
    if (arg[0] != '-' && !a->scene_path) {
        a->scene_path = arg;
        return 1;
    }
    return 0;
}

/* ---- scene or volume? ---- */

static int ends_with_ci(const char *s, const char *suffix) {
    size_t n = strlen(s), m = strlen(suffix);
    return n >= m && !strcasecmp(s + n - m, suffix);
}

enum { INPUT_SCENE, INPUT_VOLUME, INPUT_UNKNOWN };

static int input_kind(const char *path) {
    if (cli_is_procedural(path)) return INPUT_VOLUME;
    if (ends_with_ci(path, ".json")) return INPUT_SCENE;
    if (volux_volume_path_is_known(path)) return INPUT_VOLUME;
    /* Another name: a scene if it starts like a JSON object. A file that
     * cannot be opened goes to the scene loader, which says why. */
    struct stat sb;
    if (stat(path, &sb) != 0 || !S_ISREG(sb.st_mode)) return INPUT_SCENE;
    FILE *f = fopen(path, "rb");
    if (!f) return INPUT_SCENE;
    int c;
    do c = fgetc(f);
    while (c == ' ' || c == '\t' || c == '\n' || c == '\r');
    fclose(f);
    return c == '{' ? INPUT_SCENE : INPUT_UNKNOWN;
}

/* A JSON string literal of s (quotes, backslashes, control characters). */
static int json_string(const char *s, char *out, size_t n) {
    size_t w = 0;
    if (n < 3) return 0;
    out[w++] = '"';
    for (; *s; s++) {
        unsigned char c = (unsigned char)*s;
        if (w + 8 >= n) return 0;
        if (c == '"' || c == '\\') w += (size_t)snprintf(out + w, n - w, "\\%c", c);
        else if (c < 0x20) w += (size_t)snprintf(out + w, n - w, "\\u%04x", c);
        else out[w++] = (char)c;
    }
    out[w++] = '"';
    out[w] = 0;
    return 1;
}

static void dir_of(const char *path, char *out, size_t n) {
    const char *slash = strrchr(path, '/');
    if (!slash) snprintf(out, n, ".");
    else if (slash == path) snprintf(out, n, "/");
    else snprintf(out, n, "%.*s", (int)(slash - path), path);
}

/* The context's message (or the status name) into msg; the exit status. */
static int context_failure(volux_context *ctx, volux_status st, char *msg, size_t msg_size) {
    const char *e = volux_context_error(ctx);
    snprintf(msg, msg_size, "%s", e && *e ? e : volux_status_name(st));
    return cli_context_exit_status(ctx, st);
}

void cli_technique_names(char *out, size_t n) {
    out[0] = 0;
    for (int i = 0; i < volux_technique_count(); i++) {
        size_t w = strlen(out);
        snprintf(out + w, n - w, "%s%s", i ? ", " : "", volux_technique_info_at(i)->name);
    }
}

/* A quick look rendered with a progressive technique (--technique
 * pathtrace) accumulates until a target relative error of 2 % or a 10 s
 * budget (at most 4096 samples) instead of ending on one noisy sample,
 * unless the command line sets any of those limits itself. The one-pass
 * techniques keep one sample (more would only repeat jittered passes). */
static void quick_look_limits(const cli_scene_args *a, const char **out, const char *const **overrides, int *n) {
    const char *tech = "shaded";
    char name[64];
    for (int i = 0; i < a->n_overrides; i++) {
        const char *o = a->overrides[i];
        if (!strncmp(o, "render.spp=", 11) || !strncmp(o, "render.time_ms=", 15) ||
            !strncmp(o, "render.target_error=", 20))
            return;
        if (!strncmp(o, "render.technique=", 17)) {
            const char *v = o + 17;
            if (*v == '"') v++;
            snprintf(name, sizeof name, "%s", v);
            size_t len = strlen(name);
            if (len && name[len - 1] == '"') name[len - 1] = 0;
            tech = name;
        }
    }
    const volux_technique_info *info = volux_technique_info_find(tech);
    if (!info || !info->progressive) return;
    int k = 0;
    out[k++] = "render.spp=4096";
    out[k++] = "render.target_error=0.02";
    out[k++] = "render.time_ms=10000";
    for (int i = 0; i < a->n_overrides; i++) out[k++] = a->overrides[i];
    *overrides = out;
    *n = k;
}

int cli_load_scene_quiet(const char *cmd, volux_context *ctx, const cli_scene_args *a, volux_scene **out,
                         char *msg, size_t msg_size) {
    msg[0] = 0;
    if (a->memory_limit) volux_context_set_memory_limit(ctx, a->memory_limit);
    if (a->out_of_core) volux_context_set_out_of_core(ctx, 1);
    if (!a->scene_path) {
        snprintf(msg, msg_size, "missing SCENE.json (or a volume)");
        return CLI_USAGE;
    }
    const char *in = a->scene_path;
    int kind = input_kind(in);
    if (kind == INPUT_VOLUME && ends_with_ci(in, ".hdr")) {
        /* .hdr is also Radiance's image format ("#?RADIANCE"): say what it
         * is instead of letting the NIfTI reader blame its header size. */
        FILE *f = fopen(in, "rb");
        char magic[2] = {0, 0};
        if (f) {
            size_t got = fread(magic, 1, 2, f);
            fclose(f);
            if (got == 2 && magic[0] == '#' && magic[1] == '?') {
                snprintf(msg, msg_size,
                         "%s: a Radiance HDR image, not a volume (use it as an environment light: "
                         "\"lights\": [{\"type\": \"environment\", \"file\": ...}])",
                         in);
                return CLI_USAGE;
            }
        }
    }
    if (kind == INPUT_UNKNOWN) {
        snprintf(msg, msg_size,
                 "%s: neither a scene (a JSON object) nor a volume (" VOLUX_VOLUME_EXTENSIONS ", procedural:NAME[:N])", in);
        return CLI_USAGE;
    }
    if (a->region && kind == INPUT_VOLUME) {
        /* A quick look's transfer function comes from the volume's
         * histogram, which a brick does not have. */
        snprintf(msg, msg_size,
                 "%s: --distribute data needs a scene file (a quick look's transfer function comes from the "
                 "whole volume's histogram; write one with --dump-scene)",
                 in);
        return CLI_USAGE;
    }
    volux_scene_load_options o;
    memset(&o, 0, sizeof o);
    o.region = a->region;
    o.overrides = a->overrides;
    o.n_overrides = a->n_overrides;
    o.data_dir = cli_data_dir();
    char *dump = NULL, dump_dir[4096];
    if (a->dump_path) {
        dir_of(a->dump_path, dump_dir, sizeof dump_dir);
        o.effective_json = &dump;
        o.effective_dir = dump_dir;
    }
    volux_volume *vol = NULL;
    char *json = NULL;
    volux_status st = VOLUX_OK;
    const char *limits[CLI_MAX_OVERRIDES + 3];
    if (kind == INPUT_VOLUME) {
        /* A quick look: the default scene of the volume, loaded once. */
        char vjson[4200];
        if (cli_is_procedural(in)) {
            if (!cli_procedural_size_ok(in)) {
                snprintf(msg, msg_size, "%s: the size must be an integer in [1, %d]", in, VOLUX_MAX_DIM);
                return CLI_USAGE;
            }
            st = cli_procedural(ctx, cmd, in, 1, &vol, vjson, sizeof vjson);
        } else {
            char quoted[4096];
            if (!json_string(in, quoted, sizeof quoted)) {
                snprintf(msg, msg_size, "%s: path too long", in);
                return CLI_USAGE;
            }
            snprintf(vjson, sizeof vjson, "{\"file\": %s}", quoted);
            st = volux_volume_load(ctx, in, NULL, &vol);
        }
        if (!st) st = volux_scene_default_json(ctx, vjson, vol, &json);
        if (st) {
            volux_volume_release(vol);
            return context_failure(ctx, st, msg, msg_size);
        }
        o.json = json;
        o.base_dir = ".";
        o.name = in;
        quick_look_limits(a, limits, &o.overrides, &o.n_overrides);
        o.volume = vol;
        o.volume_file = cli_is_procedural(in) ? NULL : in;
    } else {
        o.path = in;
    }
    volux_scene *scene = NULL;
    st = volux_scene_load_ex(ctx, &o, &scene);
    volux_scene_json_free(ctx, json);
    volux_volume_release(vol);
    if (st) return context_failure(ctx, st, msg, msg_size);
    if (dump && (st = volux_file_save(ctx, a->dump_path, dump, strlen(dump)))) {
        snprintf(msg, msg_size, "--dump-scene: %s", volux_context_error(ctx));
        volux_scene_json_free(ctx, dump);
        volux_scene_destroy(scene);
        return CLI_FAIL;
    }
    volux_scene_json_free(ctx, dump);
    const char *tech = volux_scene_render(scene)->technique;
    if (!strcmp(tech, "auto")) {
        int rc = cli_resolve_auto(scene, in, msg, msg_size);
        if (rc) {
            volux_scene_destroy(scene);
            return rc;
        }
        tech = volux_scene_render(scene)->technique;
    }
    if (!volux_technique_info_find(tech)) {
        char names[256];
        cli_technique_names(names, sizeof names);
        const char *guess = volux_technique_closest(tech);
        snprintf(msg, msg_size, "%s: render.technique: unknown technique '%s'%s%s%s (techniques: %s)", in, tech,
                 guess ? "; did you mean '" : "", guess ? guess : "", guess ? "'?" : "", names);
        volux_scene_destroy(scene);
        return CLI_USAGE;
    }
    if ((st = volux_technique_validate_params(ctx, scene))) {
        snprintf(msg, msg_size, "%s: %s", in, volux_context_error(ctx));
        volux_scene_destroy(scene);
        return cli_exit_status(st);
    }
    if (volux_scene_render(scene)->threads > 0) volux_context_set_threads(ctx, volux_scene_render(scene)->threads);
    *out = scene;
    return CLI_OK;
}

void cli_print_notes(const char *cmd, const volux_scene *scene) {
    /* One "volux CMD: note:" line per note. */
    for (const char *p = volux_scene_notes(scene); *p;) {
        const char *nl = strchr(p, '\n');
        int len = nl ? (int)(nl - p) : (int)strlen(p);
        cli_eprintf("volux %s: note: %.*s\n", cmd, len, p);
        p += len + (nl ? 1 : 0);
    }
}

int cli_load_scene(const char *cmd, volux_context *ctx, const cli_scene_args *a, volux_scene **out) {
    char msg[1024];
    int rc = cli_load_scene_quiet(cmd, ctx, a, out, msg, sizeof msg);
    if (rc) cli_eprintf("volux %s: %s\n", cmd, msg);
    else if (!a->quiet) cli_print_notes(cmd, *out);
    return rc;
}
