/*
 * tools/viewer/view.c — `volux view VOLUME|SCENE.json [serve options]`:
 * the quick look (issue 18) in the web viewer. A volume's default scene
 * (the one `volux render VOLUME` renders) is written to a private
 * temporary folder and served from there, with that folder as the data
 * root unless --data-root says otherwise: it holds only what is served
 * (the volume the scene names is trusted as the scene's own file), so an
 * edit cannot open anything else — not the volume's neighbours, and not
 * the current folder for a procedural volume. A scene file is served as
 * `volux serve` would.
 */
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "tools/cli/scene_args.h"
#include "viewer.h"

static void usage(FILE *f) {
    fprintf(f, "usage: volux view VOLUME|SCENE.json [volux serve options]\n"
               "Opens a volume (" VOLUX_VOLUME_EXTENSIONS ", procedural:NAME[:N]) in the web\n"
               "viewer with its quick-look scene (the one `volux render VOLUME` renders); a scene file\n"
               "is served as by `volux serve`. Options: see `volux serve --help`.\n");
}

int cli_view(int argc, char **argv) {
    if (argc < 2 || argv[1][0] == '-') {
        if (argc >= 2 && (!strcmp(argv[1], "-h") || !strcmp(argv[1], "--help"))) {
            usage(stdout);
            return CLI_OK;
        }
        fprintf(stderr, "volux view: missing VOLUME (or SCENE.json) as the first argument\n");
        usage(stderr);
        return CLI_USAGE;
    }
    const char *in = argv[1];
    size_t n = strlen(in);
    if (n >= 5 && !strcmp(in + n - 5, ".json")) return cli_serve(argc, argv);

    /* The default scene, as `volux render VOLUME --dump-scene` writes it. */
    const char *tmp = getenv("TMPDIR");
    char dir[PATH_MAX], scene_path[PATH_MAX + 16], msg[1024];
    snprintf(dir, sizeof dir, "%s/volux-view-XXXXXX", tmp && *tmp ? tmp : "/tmp");
    if (!mkdtemp(dir)) {
        cli_eprintf("volux view: cannot create a temporary folder in %s\n", tmp && *tmp ? tmp : "/tmp");
        return CLI_FAIL;
    }
    snprintf(scene_path, sizeof scene_path, "%s/scene.json", dir);
    volux_context *ctx = cli_context(0);
    if (!ctx) {
        rmdir(dir);
        return CLI_FAIL;
    }
    cli_scene_args a;
    memset(&a, 0, sizeof a);
    a.scene_path = in;
    a.dump_path = scene_path;
    a.quiet = 1;
    volux_scene *scene = NULL;
    int rc = cli_load_scene_quiet("view", ctx, &a, &scene, msg, sizeof msg);
    volux_scene_destroy(scene);
    volux_context_destroy(ctx);
    if (rc) {
        cli_eprintf("volux view: %s\n", msg);
        unlink(scene_path);
        rmdir(dir);
        return rc;
    }

    /* serve SCENE [--data-root VOLUME'S FOLDER] [the caller's options] */
    int has_root = 0;
    for (int i = 2; i < argc; i++) has_root |= !strcmp(argv[i], "--data-root");
    char **args = calloc((size_t)argc + 3, sizeof *args);
    if (!args) {
        unlink(scene_path);
        rmdir(dir);
        return CLI_FAIL;
    }
    int k = 0;
    args[k++] = "view";
    args[k++] = scene_path;
    if (!has_root) {
        args[k++] = "--data-root";
        args[k++] = dir;
    }
    for (int i = 2; i < argc; i++) args[k++] = argv[i];
    /* Messages and the page name the volume, not the temporary scene. */
    char name[PATH_MAX + 32];
    snprintf(name, sizeof name, "%s (quick look)", in);
    viewer_exit_cleanup(scene_path, dir);
    rc = cli_serve_named(k, args, name);
    viewer_exit_cleanup(NULL, NULL);
    free(args);
    unlink(scene_path);
    rmdir(dir);
    return rc;
}
