/* fuzz/fuzz_scene.c — the scene loader on arbitrary text.
 *
 * Procedural volumes only: VOLUX_SCENE_NO_FILES makes every file reference
 * an error before a path is opened, so inputs cannot touch the file system;
 * the context's small max_bytes caps procedural dims. */
#include <stdint.h>

#include "fuzz_scene_common.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    volux_context *ctx = fuzz_context();
    volux_scene *s = NULL;
    volux_status st = volux_scene_parse(ctx, (const char *)data, size, "/nonexistent", "fuzz.json", NULL, 0,
                                        VOLUX_SCENE_NO_FILES, &s);
    if (st == VOLUX_OK) {
        fuzz_use_scene(ctx, s);
        volux_scene_destroy(s);
    } else {
        fuzz_check_failure(ctx, st, "fuzz.json");
    }
    fuzz_check_no_leak(ctx);
    return 0;
}
