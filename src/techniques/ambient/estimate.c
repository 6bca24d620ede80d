/* techniques/ambient/estimate.c — the memory model of `ambient`
 * (docs/SCALE.md): per voxel the summed-area table (4 B, 8 for very large
 * radii), ρ = r·σ̃t (4 B) and, with the AO term or an environment light,
 * the occlusion volume (4 B); at cache_scale ρ_c (4 B per cache node) and
 * per enabled non-environment light a radiance cache (4 B) plus, with
 * phase_cache, its tube geometry (5 B per node); the bricked copy of the
 * volume; and the preintegration table's slice, slab and log columns
 * (≈ 1.2 MB for the built-in 64×64×10×12 table). */
#include "ambient.h"
#include "render/memory_model.h"
#include "techniques/scatter/envdir.h"
#include "techniques/scatter/occlusion.h"

static uint64_t sat_bytes(uint64_t voxels, uint64_t max_box) {
    int bits = 0;
    while (bits < 63 && (1ull << bits) < (max_box < 1 ? 1 : max_box)) bits++;
    return voxels * (32 - bits < 16 ? 8 : 4);
}

uint64_t volux_ambient_estimate_bytes(const volux_scene *scene, const volux_technique_class *cls,
                                      uint64_t *volume_added) {
    const volux_volume *v = volux_scene_volume(scene);
    if (!v) return 0;
    *volume_added += volux_mm_bricks_to_build(scene);
    int d[3];
    volux_mm_dims(scene, d);
    double sp[3];
    volux_volume_spacing(v, sp);
    double min_sp = sp[0] < sp[1] ? sp[0] : sp[1];
    if (sp[2] < min_sp) min_sp = sp[2];
    volux_mm_lights l = volux_mm_count_lights(scene);
    double r = volux_technique_param(scene, cls, "radius") * min_sp;
    double ao = volux_technique_param(scene, cls, "ao"), ao_r = volux_technique_param(scene, cls, "ao_radius");
    /* the occlusion volume: the AO term, or an environment with
     * env_directions 0 (ambient.c) */
    int occ = ao > 0.0 || (l.env > 0 && (int)volux_technique_param(scene, cls, "env_directions") == 0);
    /* the sphere's equal-volume box bounds the SAT's largest box; the AO
     * boxes may be larger */
    uint64_t max_box = (uint64_t)(4.2 * r * r * r / (sp[0] * sp[1] * sp[2])) + 8;
    if (occ) {
        uint64_t m = scatter_occlusion_max_box((ao_r > 0.0 ? ao_r : volux_technique_param(scene, cls, "radius")) * min_sp, sp);
        if (m > max_box) max_box = m;
    }
    uint64_t n = volux_mm_voxels(scene);
    uint64_t bytes = sat_bytes(n, max_box) + n * sizeof(float) * (occ ? 2 : 1);
    uint64_t cache = volux_mm_grid_nodes(d, (float)volux_technique_param(scene, cls, "cache_scale"));
    int phase_cache = (int)volux_technique_param(scene, cls, "phase_cache");
    bytes += cache * sizeof(float) + (uint64_t)l.direct * cache * (sizeof(float) + (phase_cache ? 5 : 0));
    bytes += (uint64_t)l.slots * sizeof(ambient_slot);
    /* the table (built-in 64 × 64 × 10 × 12 albedos) at the parameters' size */
    uint64_t nt = (uint64_t)volux_technique_param(scene, cls, "table_theta"),
             ns = (uint64_t)volux_technique_param(scene, cls, "table_sigma"),
             ng = (uint64_t)volux_technique_param(scene, cls, "table_g");
    uint64_t na = (int)volux_technique_param(scene, cls, "table_albedo_axis") ? 12 : 1;
    int tinted = (int)volux_technique_param(scene, cls, "tinted");
    bytes += nt * ns * ng * sizeof(float) + ns * nt * sizeof(float) + ns * sizeof(float) +
             na * ng * sizeof(double *) + 2 * na * ns * nt * sizeof(double) +
             (tinted && na > 1 ? na * ns * nt * sizeof(float) : 0);
    /* the environment as K directions (ambient.c build_env_vis /
     * build_env_table): 4 visibility grids, AMBIENT_ENV_BATCH scratch grids and a ρ grid at
     * cache_scale · env_scale, with phase_cache each direction's march
     * geometry (5 B per node), and the light table over the octahedral
     * directions */
    int env_dirs = (int)volux_technique_param(scene, cls, "env_directions");
    if (l.env > 0 && env_dirs > 0) {
        double es = volux_technique_param(scene, cls, "cache_scale") * volux_technique_param(scene, cls, "env_scale");
        uint64_t m = volux_mm_grid_nodes(d, (float)(es < 0.05 ? 0.05 : es));
        bytes += (5 + (env_dirs < AMBIENT_ENV_BATCH ? env_dirs : AMBIENT_ENV_BATCH)) * m * sizeof(float);
        if (phase_cache) bytes += (uint64_t)env_dirs * (m * (sizeof(float) + 1) + 16) /* tube.c VAC_PAD */;
        bytes += (uint64_t)SCATTER_ENV_OCT_TEXELS * ns * na * 12 * sizeof(float);
    }
    /* the packet march serves offset 0 only (no lagged transmittance); its
     * bricked copy is counted above */
    bytes += volux_mm_packet_march_bytes(scene, cls, volux_technique_param(scene, cls, "offset") == 0.0, NULL);
    return bytes;
}
