/* techniques/dvr/ea.c — `ea`: emission–absorption, L = ∫ T σt c dx + T·background
 * (DESIGN §2), with pre-integrated segments and empty-space skipping. */
#include "dvr.h"

#define DVR_COMMON_PARAMS                                                                                        \
    VOLUX_PARAM_PREINTEGRATE, VOLUX_PARAM_EARLY_TERMINATION, VOLUX_PARAM_SKIP_EMPTY,                             \
        {"kernel", VOLUX_PARAM_STRING, 0, 0, 0, "auto",                                                          \
         "\"auto\" (SIMD when the CPU has AVX2+FMA, 16-lane AVX-512 packets where it has those too; shaded: with " \
         "at most 4 lights, all directional), \"scalar\" (portable reference), \"simd\" (as auto; error if "     \
         "unavailable) or \"avx2\" (8-lane packets only, the same image); same image up to float rounding"},        \
        {"volume_layout", VOLUX_PARAM_STRING, 0, 0, 0, "auto",                                                   \
         "\"auto\" (corner_words on Intel CPUs at render.step >= 2 voxels, else bricked: the per-CPU rule of "      \
         "docs/BENCHMARKS.md), \"bricked\" (the volume's bricked copy) or \"corner_words\" (SIMD kernel, 8-bit "   \
         "volumes: a per-cell copy with the 8 corners in one 64-bit word, 8 bytes per voxel, up to 256 MiB; "     \
         "slower where gathers are cheap); the same image"}

static const volux_param_info ea_params[] = {DVR_COMMON_PARAMS, {NULL, 0, 0, 0, 0, NULL, NULL}};

/* Lights, the phase function and the scattering albedo never reach an
 * emission–absorption image. */
const volux_technique_class volux_ea_class = {
    {"ea", "emission-absorption ray casting (no lighting)", ea_params, 0},
    sizeof(dvr_state), VOLUX_CHANGE_LIGHTS | VOLUX_CHANGE_PHASE | VOLUX_CHANGE_ALBEDO, 0,
    volux_dvr_init, volux_dvr_update, volux_dvr_render_tile, volux_dvr_memory_bytes, volux_dvr_release,
    NULL, NULL, NULL, /* no refine, pending work or statistics */
    volux_dvr_render_tile_part,
    NULL, /* no per-frame budget: nothing to defer */
    volux_dvr_estimate_bytes,
    NULL, /* nothing per pass */
};

static const volux_param_info shaded_params[] = {
    DVR_COMMON_PARAMS,
    /* below it the sample fades to unshaded emission, so homogeneous
     * regions do not flicker */
    VOLUX_PARAM_GRADIENT_THRESHOLD("shading is"),
    {"gradient", VOLUX_PARAM_STRING, 0, 0, 0, "cell",
     "\"cell\" (the gradient of the trilinear interpolant, from the 8 corners the sample reads: no cache, "
     "sharper) or \"cached\" (central differences at the nodes, 10-bit cache of 4 bytes per voxel, interpolated: "
     "smoother, the default up to 0.2.0)"},
    {NULL, 0, 0, 0, 0, NULL, NULL}};

/* Blinn–Phong has no phase function and no scattering albedo. */
const volux_technique_class volux_shaded_class = {
    {"shaded", "emission-absorption plus gradient Blinn-Phong from all non-ambient lights", shaded_params, 0},
    sizeof(dvr_state), VOLUX_CHANGE_PHASE | VOLUX_CHANGE_ALBEDO, 0,
    volux_dvr_init, volux_dvr_update, volux_dvr_render_tile, volux_dvr_memory_bytes, volux_dvr_release,
    NULL, NULL, NULL, /* no refine, pending work or statistics */
    volux_dvr_render_tile_part,
    NULL, /* no per-frame budget: nothing to defer */
    volux_dvr_estimate_bytes,
    NULL, /* nothing per pass */
};
