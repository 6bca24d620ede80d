/*
 * render/packet.h — what the packet (SIMD) ray casters share beyond the
 * lane vocabulary: the tables they read, the `kernel` parameter and the
 * run-time choice of the lane width.
 *
 * TABLES (volux_packet_tables), built from the ray-caster base's volume and
 * LUT (render/raycaster.h):
 *   float pre-integration table  ← volume, extinction, density, colour
 *   4³ skip-cell value ranges     ← volume
 *   signed skip distances         ← volume, extinction, density
 * The packet kernels also read the volume's bricked copy
 * (volux_volume_build_bricks; volux_packet_tables_update builds it).
 *
 * KERNELS. Two packet widths compiled with target attributes — 8 lanes
 * (AVX2+FMA, render/lanes_avx2.h) and 16 lanes (AVX-512 F/BW/DQ/VL,
 * render/lanes_avx512.h) — give bit-identical images; the scalar march of
 * the technique (volux_ea_march, scatter_march) stays the reference, and
 * the packet image differs from it by float rounding only (float integral
 * tables, vector exp): tests bound the difference per technique.
 * `ea`/`shaded` (techniques/dvr) have their own packet kernel over the
 * same vocabulary, helpers (render/lanes_ops.h) and tables; the
 * illuminated techniques share one (render/packet_impl.h) with a shading
 * hook over lanes.
 */
#ifndef VOLUX_PACKET_H
#define VOLUX_PACKET_H

#include <stddef.h>
#include <stdint.h>

#include "core/vecmath.h"
#include "core/volume_internal.h"
#include "technique_class.h"
#include "volux/transfer.h"

#define VOLUX_PACKET_SKIP_CELL 4 /* skip cells: 4³ voxels (the majorant grid's macrocells are 8³) */

typedef struct volux_packet_tables {
    /* Float pre-integration table: per table node i, 8 floats {P_σ, P_σr,
     * P_σg, P_σb, D_σ, D_σr, D_σg, D_σb} where P is the running integral
     * rounded to float and D[i] = P[i+1] − P[i] computed in float (so
     * adjacent-interval differences cancel exactly, render/lanes_ops.h).
     * 32 bytes: one unaligned 256-bit load per lane. */
    float *pre_f;
    size_t pre_bytes;
    /* Signed chessboard distance per skip cell to the nearest cell of the
     * other kind (empty > 0, non-empty < 0, |d| ≤ 127); see
     * volux_packet_skip_distance. One byte per cell (+3 bytes of padding,
     * so a 32-bit gather at any cell stays inside): 256 KiB at 256³ fits
     * the L2 cache where int32 (1 MiB) did not. */
    int8_t *skip_dist;
    size_t skip_bytes;
    float *skip_range; /* [2·cells] min, max per skip cell */
    size_t range_bytes;
    int skip_cells[3];
} volux_packet_tables;

volux_status volux_packet_pre_table(volux_context *ctx, const volux_transfer_lut *lut, volux_packet_tables *pk);
volux_status volux_packet_skip_ranges(volux_context *ctx, const volux_volume *v, volux_packet_tables *pk);
/* Needs the skip ranges of the current volume. */
volux_status volux_packet_skip_distance(volux_context *ctx, const volux_transfer_lut *lut, volux_packet_tables *pk);
/* Brings the tables (and the volume's bricked copy) up to date for change
 * set `what` (VOLUX_CHANGE_* bits), after the ray-caster base. */
volux_status volux_packet_tables_update(volux_context *ctx, volux_volume *v, const volux_transfer_lut *lut,
                                        uint32_t what, volux_packet_tables *pk);
size_t volux_packet_tables_bytes(const volux_packet_tables *pk);
void volux_packet_tables_free(volux_context *ctx, volux_packet_tables *pk);

/* What a technique hands its packet march (render/packet_impl.h). */
struct volux_raycaster;
typedef struct volux_packet_march {
    const struct volux_raycaster *rc; /* volume (bricked), camera, step, seed */
    const volux_transfer_lut *lut;
    const volux_packet_tables *pk;
    float t_min; /* early termination when T < t_min */
    int skip;    /* empty-space skipping              */
    int preint;  /* pre-integration (Engel et al. 2001) */
} volux_packet_march;

/* One lane of a packet, for a technique whose shading hook stays scalar
 * (pk_shade_per_lane). */
typedef struct volux_packet_lane {
    volux_vec3 p, q, d; /* world and index-space position, unit ray direction */
    float t, s;         /* ray parameter of the segment's end, scalar value    */
    float tau, len;     /* the segment's optical depth and length             */
} volux_packet_lane;

/* The `march_kernel` parameter of the illuminated ray casters (the words
 * and meaning of `ea`'s `kernel`). */
#define VOLUX_PARAM_PACKET_KERNEL                                                                                \
    {"march_kernel", VOLUX_PARAM_STRING, 0, 0, 0, "auto",                                                        \
     "camera-ray march: \"auto\" (SIMD packets when the CPU has AVX2+FMA, 16 lanes where it has AVX-512), "      \
     "\"scalar\" (portable reference), \"simd\" (as auto; error if unavailable) or \"avx2\" (8 lanes only); "     \
     "same image up to float rounding"}

typedef enum volux_packet_kernel {
    VOLUX_PACKET_AUTO,
    VOLUX_PACKET_SCALAR,
    VOLUX_PACKET_SIMD,
    VOLUX_PACKET_AVX2
} volux_packet_kernel;

/* 1 if this CPU can run the 8-lane (AVX2+FMA) / 16-lane (AVX-512) kernels
 * and they were compiled in. */
int volux_packet_avx2_available(void);
int volux_packet_avx512_available(void);

/* Reads techniques.<cls>.march_kernel and resolves it against the CPU: *lanes =
 * 0 (scalar march), 8 or 16. `usable` 0: the technique's current settings
 * have no packet path (then "auto" gives 0 and "simd"/"avx2" an error
 * naming `why`). */
volux_status volux_packet_kernel_choose(volux_context *ctx, const volux_scene *scene,
                                        const volux_technique_class *cls, int usable, const char *why, int *lanes);

#endif
