/* tools/mpi/mode.c — the --distribute option, with or without MPI. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "distribute.h"
#include "tools/cli/cli.h"

int dist_parse_mode(const char *cmd, const char *value, dist_mode *out) {
    if (value && !strcmp(value, "image")) *out = DIST_IMAGE;
    else if (value && !strcmp(value, "data")) *out = DIST_DATA;
    else {
        cli_eprintf("volux %s: --distribute: expected 'image' or 'data', got '%s'\n", cmd,
                value ? value : "(missing)");
        return 0;
    }
    return 1;
}

/* mpirun (Open MPI, or any PMI/PMIx launcher) leaves these in the
 * environment of every process it starts. */
int dist_launched(void) { return getenv("OMPI_COMM_WORLD_SIZE") || getenv("PMIX_RANK") || getenv("PMI_RANK"); }

volux_status dist_render_local(volux_technique *t, const volux_scene *scene, volux_framebuffer *fb,
                               dist_timing *timing) {
    memset(timing, 0, sizeof *timing);
    volux_render_report rep = {0};
    volux_status st = volux_render(t, scene, fb, NULL, &rep);
    timing->render_ms = timing->rank_render_ms_min = timing->rank_render_ms_max = rep.ms;
    timing->tiles = volux_framebuffer_tile_count(fb);
    return st;
}

void dist_volume_bytes(const volux_scene *scene, double *held, double *whole) {
    const volux_volume *v = volux_scene_volume(scene);
    int dims[3];
    volux_volume_dims(v, dims);
    volux_storage k = volux_volume_storage_kind(v);
    double elem = k == VOLUX_STORE_U8 ? 1.0 : k == VOLUX_STORE_U16 ? 2.0 : 4.0;
    *held = elem * dims[0] * dims[1] * dims[2];
    volux_brick_info b;
    if (volux_volume_brick(v, &b)) *whole = elem * b.whole_dims[0] * b.whole_dims[1] * b.whole_dims[2];
    else *whole = *held;
}
