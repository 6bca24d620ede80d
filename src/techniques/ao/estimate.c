/* techniques/ao/estimate.c — the memory model of `ao` (docs/SCALE.md):
 * isotropic: the summed-area table of σt (4 B/voxel; 8 when the largest box
 * holds more than 2^16 voxels, radius ≳ 20) and the occlusion volume
 * (4 B/voxel); directional (default): the near grid at vis_scale and the
 * far grid at spacing ≈ radius, K rounded up to 16 bytes per node each (the
 * far field's σt pyramid, 1/7 of a float volume, lives only during the
 * build). */
#include "ao.h"
#include "render/memory_model.h"
#include "techniques/scatter/occlusion.h"

/* scatter_sat_build's element: 32-bit sums while 16 bits of headroom per
 * voxel remain for the largest box, else 64-bit. */
static uint64_t sat_bytes(uint64_t voxels, uint64_t max_box) {
    int bits = 0;
    while (bits < 63 && (1ull << bits) < (max_box < 1 ? 1 : max_box)) bits++;
    return voxels * (32 - bits < 16 ? 8 : 4);
}

uint64_t volux_ao_estimate_bytes(const volux_scene *scene, const volux_technique_class *cls, uint64_t *volume_added) {
    const volux_volume *v = volux_scene_volume(scene);
    if (!v) return 0;
    uint64_t packets = volux_mm_packet_march_bytes(scene, cls, 1, volume_added); /* both models (ao.c) */
    double sp[3];
    volux_volume_spacing(v, sp);
    double min_sp = sp[0] < sp[1] ? sp[0] : sp[1];
    if (sp[2] < min_sp) min_sp = sp[2];
    double radius = (float)volux_technique_param(scene, cls, "radius") * (float)min_sp;
    uint64_t n = volux_mm_voxels(scene);
    if ((int)volux_technique_param(scene, cls, "directional")) {
        int dims[3];
        volux_mm_dims(scene, dims);
        uint64_t stride = ((uint64_t)volux_technique_param(scene, cls, "env_directions") + 15) / 16 * 16;
        uint64_t bytes = volux_mm_grid_nodes(dims, (float)volux_technique_param(scene, cls, "vis_scale")) * stride;
        if ((int)volux_technique_param(scene, cls, "far_field")) {
            float scale = (float)min_sp / (float)radius; /* ao.c: build_far */
            scale = scale > 1.0f ? 1.0f : (scale < 0.02f ? 0.02f : scale);
            bytes += volux_mm_grid_nodes(dims, scale) * stride;
        }
        return bytes + packets;
    }
    return sat_bytes(n, scatter_occlusion_max_box(radius, sp)) + n * sizeof(float) + packets;
}
