/* fuzz/fuzz_tf_preset.c — the ParaView preset reader from memory.
 *
 * Each input is read twice: the first preset rescaled onto [0, 255], and
 * the preset named "Ramp" kept at its own x. A preset that loads is then
 * validated and baked the way the scene would use it. */
#include <stdint.h>

#include "fuzz_scene_common.h"

static void use_preset(volux_context *ctx, const volux_tf_preset *p) {
    static const volux_tf_scalar_point ramp[2] = {{0.0f, 0.0f}, {255.0f, 1.0f}};
    volux_transfer_desc d;
    volux_transfer_desc_defaults(&d);
    d.color = p->color;
    d.n_color = p->n_color;
    d.opacity = p->n_opacity ? p->opacity : ramp;
    d.n_opacity = p->n_opacity ? p->n_opacity : 2;
    volux_transfer_lut lut;
    if (volux_transfer_bake(ctx, &d, 0.0, 255.0, 64, 1.0f, &lut) == VOLUX_OK) volux_transfer_lut_free(ctx, &lut);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    volux_context *ctx = fuzz_context();
    static const struct {
        const char *name;
        double lo, hi;
    } modes[2] = {{NULL, 0.0, 255.0}, {"Ramp", 0.0, 0.0}};
    for (int m = 0; m < 2; m++) {
        volux_tf_preset p = {0};
        volux_status st = volux_tf_preset_parse(ctx, (const char *)data, size, "fuzz.json", modes[m].name,
                                                modes[m].lo, modes[m].hi, &p);
        if (st == VOLUX_OK) {
            use_preset(ctx, &p);
            volux_tf_preset_free(ctx, &p);
        } else {
            fuzz_check_failure(ctx, st, "fuzz.json");
        }
        fuzz_check_no_leak(ctx);
    }
    return 0;
}
