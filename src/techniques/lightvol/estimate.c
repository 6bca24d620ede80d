/* techniques/lightvol/estimate.c — the memory model of `lightvol`
 * (docs/SCALE.md), from buffers.c's sizes: the illumination volume (m³
 * nodes at `scale` × 3 bfloat16 values, 6 when directional: 12 B/voxel
 * by default; float with precision "float"), the medium grid below
 * scale 1 (16 B per node), the x-sweep staging (8 slices of m_y·m_z
 * nodes), the slice buffers (24 B per node of the largest slice per light
 * of the largest pass), three medium slices, per-thread rows, the bricked
 * copy of the volume, the gradient cache with local shading, the
 * per-slot records. */
#include <string.h>

#include "core/parallel.h"
#include "lightvol.h"
#include "render/memory_model.h"
#include "sweep.h"

uint64_t volux_lightvol_estimate_bytes(const volux_scene *scene, const volux_technique_class *cls,
                                       uint64_t *volume_added) {
    int d[3], m[3];
    volux_mm_dims(scene, d);
    *volume_added += volux_mm_bricks_to_build(scene);
    double scale = volux_technique_param(scene, cls, "scale");
    static const char *axes[3] = {"scale_x", "scale_y", "scale_z"};
    for (int a = 0; a < 3; a++) {
        double s = volux_technique_param(scene, cls, axes[a]);
        s = s != 0.0 ? s : scale;
        m[a] = (int)ceil((double)d[a] * (double)(float)s - 1e-6);
        if (m[a] < 2) m[a] = 2;
        if (m[a] > d[a]) m[a] = d[a];
    }
    uint64_t nodes = (uint64_t)m[0] * (uint64_t)m[1] * (uint64_t)m[2];
    uint64_t ch = (int)volux_technique_param(scene, cls, "directional") ? 6 : 3;
    /* bfloat16 after an entire update (precision auto); float from the
     * first selective light update on, which meets the limit as an
     * allocation then (docs/SCALE.md) */
    const int f32 = !strcmp(volux_technique_param_string(scene, cls, "precision"), "float");
    uint64_t bytes = (nodes * ch + LV_VOL_PAD) * (f32 ? sizeof(float) : sizeof(uint16_t));
    if (m[0] != d[0] || m[1] != d[1] || m[2] != d[2]) bytes += nodes * 4 * sizeof(float);
    uint64_t a01 = (uint64_t)m[0] * (uint64_t)m[1], a02 = (uint64_t)m[0] * (uint64_t)m[2],
             a12 = (uint64_t)m[1] * (uint64_t)m[2], area = a01 > a02 ? a01 : a02;
    if (a12 > area) area = a12;
    int mmax = m[0] > m[1] ? m[0] : m[1];
    if (m[2] > mmax) mmax = m[2];
    /* slice buffers for the largest pass: coherent propagation sweeps the
     * lights of one group together (at most max_lights_per_pass), so count
     * the lights per group; a positional light may reach every group */
    volux_mm_lights l = volux_mm_count_lights(scene);
    int env_dirs = (int)volux_technique_param(scene, cls, "env_directions");
    int per_group[LV_GROUPS] = {0};
    float f[LV_GROUPS];
    for (int slot = 0; slot < l.slots; slot++) {
        const volux_light_desc *ld = volux_scene_light(scene, slot);
        if (!ld || !ld->enabled || ld->type == VOLUX_LIGHT_ENVIRONMENT) continue;
        unsigned mask = ld->type == VOLUX_LIGHT_DIRECTIONAL ? lv_face_weights(v3_normalize(ld->direction), f) : 0x3fu;
        for (int g = 0; g < LV_GROUPS; g++) per_group[g] += (mask >> g) & 1u;
    }
    for (int k = 0; l.env && k < env_dirs; k++) {
        unsigned mask = lv_face_weights(v3_scale(volux_fibonacci_dir(k, env_dirs), -1.0f), f);
        for (int g = 0; g < LV_GROUPS; g++) per_group[g] += (mask >> g) & 1u;
    }
    int entries = 0;
    for (int g = 0; g < LV_GROUPS; g++) entries = per_group[g] > entries ? per_group[g] : entries;
    int per_pass = (int)volux_technique_param(scene, cls, "max_lights_per_pass");
    if (strcmp(volux_technique_param_string(scene, cls, "propagation"), "coherent") != 0) per_pass = 1;
    if (entries > per_pass) entries = per_pass;
    if (entries > 0) {
        const volux_render_settings *rs = volux_scene_render(scene);
        uint64_t threads = (uint64_t)(rs->threads > 0 ? rs->threads : volux_parallel_max_threads());
        bytes += LV_DEFER * a12 * ch * sizeof(float) + area * (uint64_t)entries * 6 * sizeof(float) +
                 3 * (4 * area + 2 * (uint64_t)mmax) * sizeof(float) +
                 ((uint64_t)ROW_FLOATS * (uint64_t)mmax + 64) * threads * sizeof(float);
    }
    if (volux_technique_param(scene, cls, "local_shading") > 0.0) bytes += volux_mm_gradient_bytes(d);
    bytes += volux_mm_packet_march_bytes(scene, cls, 1, NULL); /* its bricked copy is counted above */
    return bytes + (uint64_t)(volux_mm_lut_entries(scene) + 1) * sizeof(int) + (uint64_t)l.slots * sizeof(lv_applied);
}
