/* fuzz/fuzz_override.c — --set overrides on a fixed, valid scene.
 *
 * The input is up to 16 lines, each one "path=value" assignment, applied in
 * order (as repeated --set options are) before the scene is read. */
#include <stdint.h>
#include <string.h>

#include "fuzz_scene_common.h"

#define MAX_LINES 16

static const char SCENE[] =
    "{\"volume\": {\"procedural\": \"phantom\", \"dims\": [8, 8, 8]},"
    " \"transfer_function\": {\"color\": [[0, 0, 0, 1], [255, 1, 1, 1]], \"opacity\": [[0, 0], [255, 0.5]],"
    "   \"albedo\": 0.9},"
    " \"camera\": {\"orbit\": {\"azimuth\": 30, \"elevation\": 20}, \"fov_y\": 30},"
    " \"lights\": [{\"type\": \"directional\", \"direction\": [0, -1, 0]},"
    "              {\"type\": \"spot\", \"position\": [0, 20, 0], \"direction\": [0, -1, 0]}],"
    " \"background\": [0, 0, 0],"
    " \"render\": {\"technique\": \"ea\", \"width\": 16, \"height\": 16},"
    " \"techniques\": {\"ea\": {\"early_termination\": 0.01}}}";

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    volux_context *ctx = fuzz_context();
    /* Split into NUL-terminated lines (a NUL inside a line ends it early,
     * as it would on a command line). */
    char *text = malloc(size + 1);
    if (!text) return 0;
    if (size) memcpy(text, data, size);
    text[size] = 0;
    const char *lines[MAX_LINES];
    int n = 0;
    for (char *p = text; n < MAX_LINES;) {
        char *nl = strchr(p, '\n');
        if (nl) *nl = 0;
        lines[n++] = p;
        if (!nl) break;
        p = nl + 1;
    }
    volux_scene *s = NULL;
    volux_status st = volux_scene_parse(ctx, SCENE, sizeof SCENE - 1, "/nonexistent", "fixed.json", lines, n,
                                        VOLUX_SCENE_NO_FILES, &s);
    if (st == VOLUX_OK) {
        fuzz_use_scene(ctx, s);
        volux_scene_destroy(s);
    } else {
        fuzz_check_failure(ctx, st, "fixed.json");
    }
    free(text);
    fuzz_check_no_leak(ctx);
    return 0;
}
