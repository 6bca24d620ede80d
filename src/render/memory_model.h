/*
 * render/memory_model.h — what a render will hold, estimated from the scene
 * before anything is allocated, and the check against the context's
 * memory limit (docs/SCALE.md has the per-technique tables).
 *
 * A render holds the volume (loaded before the technique exists), the
 * instance (state block, the shared ray-caster base: majorant grid,
 * prepared lights), the technique's own caches (its class's
 * estimate_bytes, the model of what memory_bytes reports after the
 * fact), the framebuffer (Σ radiance and Σ luminance² in double) and the
 * resolved float image an output writer encodes row by row. The helpers
 * below size the caches several techniques share, with the same rounding
 * as their allocators, so a technique's model is a few lines.
 */
#ifndef VOLUX_MEMORY_MODEL_H
#define VOLUX_MEMORY_MODEL_H

#include <stdint.h>

#include "technique_class.h"
#include "volux/technique.h"

/* Framebuffer bytes per pixel: 3 doubles Σ radiance + 1 double Σ lum². */
#define VOLUX_MM_FRAMEBUFFER_PER_PIXEL 32u
/* The resolved image (3 floats per pixel) the output writers encode. */
#define VOLUX_MM_IMAGE_PER_PIXEL 12u

/* The scene volume's node counts (1,1,1 if it has none). */
void volux_mm_dims(const volux_scene *scene, int dims[3]);
/* Nodes of the volume. */
uint64_t volux_mm_voxels(const volux_scene *scene);
/* Bytes of the bricked, quantised gradient cache (sample/gradient.h):
 * one 32-bit word per node of every 9³-node brick over 8³ cells, ≈ 5.7 B
 * per voxel. */
uint64_t volux_mm_gradient_bytes(const int dims[3]);
/* Nodes of a scatter grid at `scale` of the volume's resolution, with
 * scatter_grid_alloc's rounding (m = max(2, ⌈(n − 1)·scale⌉ + 1)). */
uint64_t volux_mm_grid_nodes(const int dims[3], double scale);
/* The scene's enabled lights: those other than environments (the base's
 * `direct` list), environments, and the texels of the environments' maps. */
typedef struct volux_mm_lights {
    int direct, env, slots;
    uint64_t env_texels;
} volux_mm_lights;
volux_mm_lights volux_mm_count_lights(const volux_scene *scene);
/* The bricked copy of the volume (volux_volume_build_bricks) if it is not
 * built yet: 9³ nodes per 8³ cells, ≈ 1.42× the volume. */
uint64_t volux_mm_bricks_to_build(const volux_scene *scene);
/* The packet march's tables (render/packet.h): the float pre-integration
 * table (8 floats per TF entry), the value range and skip distance of
 * every 4³ skip cell (9 B each). */
uint64_t volux_mm_packet_tables_bytes(const volux_scene *scene);
/* What the packet march adds to a scattering technique when its
 * `march_kernel` will resolve to SIMD on this CPU (`usable`: the
 * technique can march packets with these parameters): the tables, and the
 * bricked copy of the volume into *volume_added (NULL: the caller counts
 * it already). 0 for the scalar march. */
uint64_t volux_mm_packet_march_bytes(const volux_scene *scene, const volux_technique_class *cls, int usable,
                                     uint64_t *volume_added);
/* Entries of the scene's baked TF table (0 if not baked). */
int volux_mm_lut_entries(const volux_scene *scene);
/* Macrocells of the volume (8³ cells each). */
uint64_t volux_mm_macrocells(const int dims[3]);

/* 1 while the context uses the default limit (for messages). */
int volux_context_memory_limit_is_default(const volux_context *ctx);

/* Fills *out for a render of `scene` with class `cls` (framebuffer and
 * image at the scene's render.width × height). */
void volux_memory_estimate_class(const volux_technique_class *cls, const volux_scene *scene,
                                 volux_memory_estimate *out);
/* VOLUX_ERR_LIMIT, naming the estimate, its largest parts and the limit,
 * when e->total exceeds the context's memory limit; VOLUX_OK otherwise.
 * `who`: the message's prefix (e.g. the technique's name). */
volux_status volux_memory_check(volux_context *ctx, const char *who, const volux_memory_estimate *e);

#endif
