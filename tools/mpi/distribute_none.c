/* tools/mpi/distribute_none.c — the front end of a build without MPI: one
 * process, and a clear message for --distribute (see distribute.h). */
#include <stdio.h>
#include <string.h>

#include "tools/cli/cli.h"
#include "distribute.h"

int dist_begin(const char *cmd, dist_mode requested) {
    if (!requested && !dist_launched()) return DIST_NONE;
    /* Under mpirun every process would render the whole frame and write
     * the same file: refuse instead. */
    cli_eprintf(
            "volux %s: %s: this volux was built without MPI (install libopenmpi-dev and "
            "configure with -DVOLUX_MPI=ON)\n",
            cmd, requested ? "--distribute" : "started by mpirun");
    return -1;
}

void dist_quiet_followers(void) {}
void dist_end(void) {}
void dist_barrier(void) {}
void dist_max(double *v) { (void)v; }
void dist_gather2(const double v[2], double *out) { memcpy(out, v, 2 * sizeof *v); }
int dist_rank(void) { return 0; }
int dist_size(void) { return 1; }
int dist_default_threads(void) { return 0; }
int dist_agree(const char *cmd, volux_context *ctx, volux_status st) { return st ? cli_fail(cmd, ctx, st) : 0; }
int dist_agree_msg(const char *cmd, int rc, const char *msg) {
    if (rc) cli_eprintf("volux %s: %s\n", cmd, msg);
    return rc;
}
int dist_share_exit(int rc) { return rc; }

volux_status dist_render_image(volux_technique *t, const volux_scene *scene, volux_framebuffer *fb,
                               dist_timing *timing) {
    return dist_render_local(t, scene, fb, timing);
}

void dist_region(volux_volume_region *out) {
    memset(out, 0, sizeof *out);
    out->count = 1;
}
volux_status dist_share_stats(volux_scene *scene) {
    (void)scene;
    return VOLUX_OK;
}
volux_status dist_render_data(volux_technique *t, const volux_scene *scene, volux_framebuffer *fb,
                              dist_timing *timing) {
    return dist_render_local(t, scene, fb, timing);
}
