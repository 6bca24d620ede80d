/*
 * tools/cli/auto.c — `--technique auto` / "technique": "auto" (issue 26):
 * the technique and spp with the least expected error for the scene's time
 * budget (render.time_ms), by pareto_auto_choose (pareto_math.h) over the
 * table measured by bench/pareto/run.sh (auto_table.c). The choice is a
 * scene note ("auto: chose ...").
 */
#include <stdio.h>
#include <string.h>

#include "pareto_math.h"
#include "scene_args.h"

/* Largest spp auto asks for: past it pathtrace's time budget decides. */
#define AUTO_MAX_SPP 65536

int cli_resolve_auto(volux_scene *scene, const char *in, char *msg, size_t msg_size) {
    volux_render_settings rs = *volux_scene_render(scene);
    if (!(rs.time_ms > 0.0)) {
        snprintf(msg, msg_size,
                 "%s: render.technique \"auto\" needs a time budget (render.time_ms, --time-ms) to choose for", in);
        return CLI_USAGE;
    }
    int dims[3] = {0, 0, 0};
    volux_volume_dims(volux_scene_volume(scene), dims);
    double voxels = (double)dims[0] * dims[1] * dims[2], pixels = (double)rs.width * rs.height;
    pareto_auto_choice c;
    if (!pareto_auto_choose(pareto_auto_table, pareto_auto_table_rows, rs.time_ms, voxels, pixels, AUTO_MAX_SPP, &c)) {
        snprintf(msg, msg_size, "%s: render.technique \"auto\": no measured table", in);
        return CLI_FAIL;
    }
    snprintf(rs.technique, sizeof rs.technique, "%s", c.technique);
    rs.spp = c.spp;
    volux_status st = volux_scene_set_render(scene, &rs);
    if (st) {
        snprintf(msg, msg_size, "%s: %s", in, volux_context_error(volux_scene_context(scene)));
        return cli_exit_status(st);
    }
    char note[256];
    snprintf(note, sizeof note,
             "auto: chose %s, %d spp for the %g ms budget (predicted %.0f ms, expected rel_mse %.3g%s; "
             "docs/CHOOSING.md)",
             c.technique, c.spp, rs.time_ms, c.predicted_ms, c.expected_error,
             c.fits ? "" : "; nothing fits the budget: the fastest");
    volux_scene_add_note(scene, note);
    return CLI_OK;
}
