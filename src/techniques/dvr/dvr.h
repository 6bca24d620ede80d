/*
 * techniques/dvr/dvr.h — classical direct volume rendering, shared by the
 * `ea` (emission–absorption) and `shaded` (plus gradient Blinn–Phong)
 * techniques.
 *
 * Caches beyond the ray-caster base (render/raycaster.h) and what
 * invalidates them:
 *   skip (sub-)cell ranges (SIMD)        ← volume
 *   skip distances + occupancy (SIMD)    ← volume, extinction, density
 *   gradient cache (shaded only)         ← volume (bricked, see dvr.c)
 *   ambient term (shaded only)           ← lights
 *   float pre-integration table (SIMD)   ← extinction, density, colour
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

#include "render/raycaster.h"
#include "sample/gradient.h"

#define DVR_SIMD_MAX_LIGHTS 4 /* directional lights the SIMD shading takes */
#define DVR_SKIP_CELL 4       /* SIMD skip cells: 4³ voxels (macrocells are 8³) */

typedef enum dvr_kernel { DVR_KERNEL_AUTO, DVR_KERNEL_SCALAR, DVR_KERNEL_SIMD, DVR_KERNEL_AVX2 } dvr_kernel;

extern const volux_technique_class volux_ea_class;
extern const volux_technique_class volux_shaded_class;

/* Two-level empty-space skipping for the packet kernel (dvr_skip.c).
 *
 * Level 1: skip cells of DVR_SKIP_CELL³ = 4³ voxels (finer than the 8³
 * macrocells: in real data most samples of a non-empty macrocell still have
 * zero opacity; bonsai: 2.3 M of 14 M lane samples contribute). Level 2:
 * the 8 sub-cells of 2³ voxels of each cell. A (sub-)cell is empty when
 * σt = 0 on every table node bracketing its value range (the majorant
 * grid's test), so every segment with both ends in one connected run of
 * empty (sub-)cells contributes exactly 0, pre-integrated or not.
 *
 * TF-independent (built with the volume): the value range of every cell
 * and sub-cell, nodes inclusive, so the trilinear field inside lies in it.
 * Per transfer function (rebuilt on extinction/density edits, within the
 * TF-edit budget): per cell two bytes, read by one 32-bit gather —
 *   code[2c]     signed chessboard distance d: d ≥ 1 for an empty cell
 *                (all cells within d − 1 rings are empty too), d ≤ −1 for a
 *                full cell (every sub-cell non-empty; −d − 1 rings of full
 *                cells around it), 0 for a mixed cell; |d| ≤ 127;
 *   code[2c + 1] occupancy: bit sx + 2·sy + 4·sz set iff that sub-cell is
 *                non-empty (sub-cells past the volume's last node: 0).
 * Why: one lookup tells a lane how far it can go before the emptiness can
 * change — a cube of empty cells to skip, a cube of full cells to march
 * without checking — and in a mixed cell whether its 2³ sub-cell may be
 * skipped. Memory: 2 bytes per cell (512 KiB at 256³) per TF; the ranges
 * 72 bytes per cell (18 MiB at 256³). */
typedef struct dvr_skip {
    int cells[3];          /* skip cells per axis: ⌈(dims − 1)/4⌉          */
    float *range;          /* [2·cells] min, max per cell                    */
    float *sub_range;      /* [16·cells] min, max of sub-cell b of cell c at
                              2·(8c + b); empty (∞, −∞) past the volume     */
    int8_t *dist;          /* [cells + 3] signed distance                    */
    uint8_t *occ;          /* [cells + 3] sub-cell occupancy bits            */
    size_t range_bytes, sub_bytes, bytes;
} dvr_skip;

/* Builds sk's cell and sub-cell value ranges for volume v (and its cell
 * counts); reuses the buffers when the size matches. */
volux_status volux_dvr_skip_ranges(volux_context *ctx, const volux_volume *v, dvr_skip *sk);
/* Builds (in place) sk's distance and occupancy bytes for lut, from the
 * ranges of volume v built by volux_dvr_skip_ranges. */
volux_status volux_dvr_skip_classify(volux_context *ctx, const volux_volume *v, const volux_transfer_lut *lut,
                                     dvr_skip *sk);
void volux_dvr_skip_free(volux_context *ctx, dvr_skip *sk);

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
    volux_vec3 ambient;            /* environment mean, or white 1 (VTK)   */
    /* Float pre-integration table for the SIMD kernel: per table node i,
     * 8 floats {P_σ, P_σr, P_σg, P_σb, D_σ, D_σr, D_σg, D_σb} where P is the
     * running integral rounded to float and D[i] = P[i+1] − P[i] computed in
     * float (so adjacent-interval differences cancel exactly, see
     * dvr_avx2.c). 32 bytes: one unaligned 256-bit load per lane. */
    float *pre_f;
    size_t pre_bytes;
    dvr_skip skip;                 /* packet kernel's empty-space skipping */
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
void volux_dvr_release(void *state);

#endif
