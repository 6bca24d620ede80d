/*
 * techniques/scatter/sat3d.h — a 3-D summed-area table of extinction σt
 * (Crow 1984) and box averages over it, for the ambient extinction volume
 * of `ambient` (Ament et al. 2013, §4.2.1, Eqs. 12–13) and the occlusion
 * volume of `ao` (Schlegel et al. 2011).
 *
 * PRECISION. A float SAT of a 256³–512³ volume loses the small box sums in
 * the large prefix sums (float has 24 bits). Ours is exact integer
 * arithmetic: σt is quantised to q = round(σt·scale) with
 * scale = (2^B − 1)/(σt_max · N_box) for the largest box of N_box voxels
 * that will be queried, and the prefix sums are kept modulo 2^B. A box sum
 * computed by inclusion–exclusion is then exact modulo 2^B, and since the
 * true box sum is < 2^B by the choice of scale, it is exact. B = 32
 * (4 bytes/voxel) while that leaves ≥ 16 bits per voxel value, else B = 64.
 * The only error is the quantisation of σt (≤ 0.5/scale per voxel).
 *
 * Layout: S[(z·ny + y)·nx + x] = Σ of q over [0..x]×[0..y]×[0..z].
 */
#ifndef VOLUX_SCATTER_SAT3D_H
#define VOLUX_SCATTER_SAT3D_H

#include "core/volume_internal.h"
#include "volux/transfer.h"

typedef struct scatter_sat {
    int dims[3];
    int wide;       /* 0: uint32 sums modulo 2^32; 1: uint64            */
    void *data;
    size_t bytes;
    double scale;   /* q = round(σt · scale); 0 if σt_max == 0          */
    uint64_t max_box; /* largest box (voxels) the scale was chosen for */
} scatter_sat;

/* Builds (or rebuilds in place) the SAT of σt(value) over the volume's
 * nodes, for boxes of up to max_box voxels. Runs on `threads` threads;
 * deterministic. */
volux_status scatter_sat_build(volux_context *ctx, int threads, const volux_volume *v, const volux_transfer_lut *lut,
                               uint64_t max_box, scatter_sat *sat);
void scatter_sat_free(volux_context *ctx, scatter_sat *sat);

/* Σ σt over the voxels of [x0,x1]×[y0,y1]×[z0,z1] (inclusive, each
 * already clipped to the grid; an empty range gives 0), in σt units. */
double scatter_sat_box(const scatter_sat *sat, int x0, int y0, int z0, int x1, int y1, int z1);

/* Box-filter pass: for every node v,
 *     x(v) = Σ_k weight[k] · (Σ σt over box k centred on v, clipped)
 * with box k of half-widths half[k][0..2] voxels, and
 *     out[v] = exponentiate ? exp(−x) : x.
 * Voxels outside the grid count as empty medium. At most 8 boxes. */
volux_status scatter_sat_filter(volux_context *ctx, int threads, const scatter_sat *sat, int n_boxes,
                                const int half[][3], const double *weight, int exponentiate, float *out);

#endif
