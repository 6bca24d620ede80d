/*
 * techniques/dvr/dvr.h — classical direct volume rendering, shared by the
 * `ea` (emission–absorption) and `shaded` (plus gradient Blinn–Phong)
 * techniques.
 *
 * Caches beyond the ray-caster base (render/raycaster.h) and what
 * invalidates them:
 *   skip cell ranges (SIMD skipping)     ← volume
 *   skip distances (SIMD skipping)       ← volume, extinction, density
 *   gradient cache (shaded, `gradient: "cached"` only) ← volume (bricked)
 *   ambient term (shaded only)           ← lights
 *   float pre-integration table (SIMD)   ← extinction, density, colour
 *   corner words (SIMD, 8-bit volumes)   ← volume (dvr_corners.c)
 * Colour/albedo/material edits re-read the scene's LUT only.
 *
 * Two kernels compute the same image: the scalar one in dvr.c (portable,
 * the reference) and the packet kernel of dvr_simd_impl.h, as 16-ray
 * AVX-512 packets (dvr_avx512.c) or 8-ray AVX2+FMA packets (dvr_avx2.c),
 * chosen at run time from the CPU and the parameter `kernel`. The two
 * widths give bit-identical images; against the scalar kernel they share
 * the segment positions, the pre-integration model and the skipping rule
 * and differ by float rounding (the SIMD integral tables are float).
 */
#ifndef VOLUX_DVR_H
#define VOLUX_DVR_H

#include "render/packet.h"
#include "render/raycaster.h"
#include "sample/gradient.h"

#define DVR_SIMD_MAX_LIGHTS 4 /* directional lights the SIMD shading takes */
#define DVR_SKIP_CELL VOLUX_PACKET_SKIP_CELL /* SIMD skip cells: 4³ voxels (macrocells are 8³) */
/* largest corner-word copy `volume_layout: "corner_words"` builds (≈ 320³) */
#define DVR_CORNER_WORDS_MAX_BYTES ((size_t)256 << 20)

typedef enum dvr_kernel { DVR_KERNEL_AUTO, DVR_KERNEL_SCALAR, DVR_KERNEL_SIMD, DVR_KERNEL_AVX2 } dvr_kernel;
typedef enum dvr_layout { DVR_LAYOUT_AUTO, DVR_LAYOUT_BRICKED, DVR_LAYOUT_CORNER_WORDS } dvr_layout;
/* volume_layout "auto" picks corner words on Intel CPUs from this step
 * (voxels) up (volux_dvr_auto_corner_words, dvr.c) */
#define DVR_CORNER_WORDS_MIN_STEP 2.0f

extern const volux_technique_class volux_ea_class;
extern const volux_technique_class volux_shaded_class;

typedef struct dvr_state {
    volux_raycaster rc;            /* base: volume, LUT, grid, camera, step,
                                      seed, material, lights              */
    int shaded;                    /* the `shaded` class                  */
    /* parameters */
    int preintegrate, skip_empty;
    dvr_kernel kernel;             /* `kernel` parameter                   */
    int use_simd;                  /* resolved: parameter, CPU, lights     */
    int simd_lanes;                /* 16 (AVX-512) or 8 (AVX2) when use_simd */
    float t_min;                   /* early termination when T < t_min   */
    /* shading */
    volux_gradient_cache grad;     /* shared helper (sample/gradient.h)  */
    float grad_ref;                /* |∇s| at which shading is fully on    */
    /* `gradient`: 1 "cell" (the trilinear interpolant's own gradient from
     * the sample's 8 corners, volux_cell_gradient_bricked), 0 "cached"
     * (central differences from the 10-bit cache) */
    int grad_cell;
    volux_vec3 ambient;            /* environment mean, or white 1 (VTK)   */
    /* the SIMD kernel's tables (render/packet.h): float pre-integration
     * table, 4³ skip-cell ranges and skip distances */
    volux_packet_tables pk;
    /* Corner words (dvr_corners.c): per cell of an 8-bit volume one 64-bit
     * word with its 8 corners, so a SIMD sample gathers one element instead
     * of four. NULL: the kernel gathers from the bricked copy. */
    dvr_layout layout;             /* `volume_layout` parameter            */
    int corner_words;              /* resolved: corner words wanted        */
    uint64_t *corners;
    size_t corner_bytes;
} dvr_state;

/* 1 if this CPU can run the AVX2+FMA kernel (and it was compiled in). */
int volux_dvr_simd_available(void);
/* 1 if it can also run the AVX-512 (F, BW, DQ, VL) kernel. */
int volux_dvr_avx512_available(void);
/* The SIMD kernel for one tile (same contract as render_tile; `shaded`
 * only with directional lights, see resolve_kernel in dvr.c). */
void volux_dvr_render_tile_avx2(const dvr_state *st, const volux_scene *scene, const volux_tile *tile, float *rgb,
                                volux_tile_stats *stats);
void volux_dvr_render_tile_avx512(const dvr_state *st, const volux_scene *scene, const volux_tile *tile, float *rgb,
                                  volux_tile_stats *stats);

/* 1 on an Intel CPU (the vendor the "auto" layout rule distinguishes). */
int volux_dvr_cpu_is_intel(void);
/* The "auto" layout rule: 1 = corner words (dvr.c). */
int volux_dvr_auto_corner_words(int intel, float step_voxels);

/* (Re)builds or frees the corner words after the kernel choice: built
 * when wanted and missing or the volume changed; fails never (when the
 * allocation is refused the kernel reads the bricks, same image). */
volux_status volux_dvr_corner_words_update(dvr_state *st, int volume_changed);
void volux_dvr_corner_words_free(dvr_state *st);

/* The class hooks both `ea` and `shaded` use (ea.c holds the classes). */
void volux_dvr_init(void *state);
volux_status volux_dvr_update(void *state, const volux_scene *scene, const volux_change_set *c);
void volux_dvr_render_tile(const void *state, const volux_scene *scene, const volux_tile *tile, float *rgb,
                           volux_tile_stats *stats);
/* A brick of a data-parallel render (render_tile_part); always the scalar
 * kernel: the SIMD packets clip rays to the whole volume only. */
void volux_dvr_render_tile_part(const void *state, const volux_scene *scene, const volux_tile *tile, int background,
                                float *rgbt, volux_tile_stats *stats);
size_t volux_dvr_memory_bytes(const void *state);
/* The memory model (estimate.c, docs/SCALE.md). */
uint64_t volux_dvr_estimate_bytes(const volux_scene *scene, const volux_technique_class *cls, uint64_t *volume_added);
void volux_dvr_release(void *state);

#endif
