/*
 * tools/cli/scene_args.h — the scene options `render` and `bench` share:
 * SCENE.json plus --technique/--spp/--width/--height/--threads/--seed/
 * --time-step/--set, turned into --set overrides so there is one path into
 * the scene.
 */
#ifndef VOLUX_CLI_SCENE_ARGS_H
#define VOLUX_CLI_SCENE_ARGS_H

#include <stddef.h>
#include <stdint.h>

#include "cli.h"

#define CLI_MAX_OVERRIDES 128

typedef struct cli_scene_args {
    const char *scene_path;
    const char *overrides[CLI_MAX_OVERRIDES];
    char storage[CLI_MAX_OVERRIDES][160];
    int n_overrides;
    const char *dump_path; /* --dump-scene: the scene as read, as JSON */
    int quiet;             /* no notes on stderr */
    /* --distribute data: load only this brick of the scene's volume */
    const volux_volume_region *region;
    /* --memory-limit: the render's memory budget in bytes (0: the
     * library's default, 80 % of physical memory; UINT64_MAX: none) */
    uint64_t memory_limit;
    int out_of_core; /* --out-of-core: volux_context_set_out_of_core */
} cli_scene_args;

/* If argv[*i] is a scene option, consumes it (and its value), returns 1;
 * returns 0 if it is not one; -1 on a usage error (message printed). */
int cli_scene_arg(const char *cmd, cli_scene_args *a, int argc, char **argv, int *i);

/* Loads the scene with the overrides and checks technique parameters.
 * The input may also be a volume file or procedural:NAME[:N]: its quick-
 * look scene (volux_scene_default_json). With --dump-scene, writes the
 * scene as read. On error prints the message and returns the exit status
 * (nonzero); on success prints the scene's notes unless quiet. */
int cli_load_scene(const char *cmd, volux_context *ctx, const cli_scene_args *a, volux_scene **out);
/* The same without printing: the message goes to msg (for front ends that
 * print one message for many processes); notes are left to the caller. */
int cli_load_scene_quiet(const char *cmd, volux_context *ctx, const cli_scene_args *a, volux_scene **out,
                         char *msg, size_t msg_size);
/* The scene's notes, one "volux CMD: note: ..." line each, on stderr. */
/* render.technique "auto" (auto.c): replaces it with the technique and spp
 * of least expected error for render.time_ms and adds a note saying so.
 * CLI_USAGE (message) without a budget. */
int cli_resolve_auto(volux_scene *scene, const char *in, char *msg, size_t msg_size);
void cli_print_notes(const char *cmd, const volux_scene *scene);

/* All registered technique names, comma-separated (the nearest one to a
 * typo: volux_technique_closest). */
void cli_technique_names(char *out, size_t n);

#endif
