/* tools/cli/scene_args.c — see scene_args.h. */
#include <stdio.h>
#include <string.h>

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

int cli_scene_arg(const char *cmd, cli_scene_args *a, int argc, char **argv, int *i) {
    static const struct {
        const char *opt, *fmt;
    } map[] = {
        {"--technique", "render.technique=\"%s\""}, {"--spp", "render.spp=%s"},
        {"--width", "render.width=%s"},             {"--height", "render.height=%s"},
        {"--threads", "render.threads=%s"},         {"--seed", "render.seed=%s"},
        {"--step", "render.step=%s"},               {"--exposure", "render.exposure=%s"},
        {"--time-ms", "render.time_ms=%s"},         {"--target-error", "render.target_error=%s"},
        {"--max-depth", "render.max_depth=%s"},     {"--set", "%s"},
    };
    const char *arg = argv[*i];
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

int cli_load_scene_quiet(const char *cmd, volux_context *ctx, const cli_scene_args *a, volux_scene **out,
                         char *msg, size_t msg_size) {
    if (!a->scene_path) {
        snprintf(msg, msg_size, "missing SCENE.json");
        return CLI_USAGE;
    }
    volux_scene *scene = NULL;
    volux_status st = volux_scene_load(ctx, a->scene_path, a->overrides, a->n_overrides, &scene);
    if (st) {
        const char *e = volux_context_error(ctx);
        snprintf(msg, msg_size, "%s", e && *e ? e : volux_status_name(st));
        return cli_exit_status(st);
    }
    const char *tech = volux_scene_render(scene)->technique;
    if (!volux_technique_info_find(tech)) {
        snprintf(msg, msg_size, "%s: render.technique: unknown technique '%s' (see `volux techniques`)", a->scene_path,
                 tech);
        volux_scene_destroy(scene);
        return CLI_USAGE;
    }
    if ((st = volux_technique_validate_params(ctx, scene))) {
        snprintf(msg, msg_size, "%s: %s", a->scene_path, volux_context_error(ctx));
        volux_scene_destroy(scene);
        return cli_exit_status(st);
    }
    if (volux_scene_render(scene)->threads > 0) volux_context_set_threads(ctx, volux_scene_render(scene)->threads);
    *out = scene;
    return CLI_OK;
}

int cli_load_scene(const char *cmd, volux_context *ctx, const cli_scene_args *a, volux_scene **out) {
    char msg[1024];
    int rc = cli_load_scene_quiet(cmd, ctx, a, out, msg, sizeof msg);
    if (rc) cli_eprintf("volux %s: %s\n", cmd, msg);
    return rc;
}
