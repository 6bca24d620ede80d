/*
 * techniques/scatter/occlusion.h — SAT-based ambient occlusion after
 * Schlegel, Makhinya & Pajarola 2011 (as used by Ament et al. 2013, §5 and
 * Table 1): the occlusion of a point is the transmittance from it to the
 * radius R of its neighbourhood, with the extinction assumed piecewise
 * constant over n nested shells whose means come from n SAT box sums:
 *
 *     A(x) = exp(−Σ_i σ̄_shell,i · (r_i − r_{i−1})),
 *     σ̄_shell,i = (S_i − S_{i−1}) / (N_i − N_{i−1})
 *
 * where S_i is Σσt over the cube of the same volume as the sphere of radius
 * r_i = R·i/n (N_i voxels) and r_i is recomputed from N_i (so the discrete
 * cube and its radius agree). A is linear in the S_i inside the exponent,
 * so one SAT filter pass computes it. Ament et al. note that it needs at
 * least three SAT evaluations per voxel (the default n = 3).
 */
#ifndef VOLUX_SCATTER_OCCLUSION_H
#define VOLUX_SCATTER_OCCLUSION_H

#include "grid.h"
#include "sat3d.h"

/* Half-widths (voxels, per axis) of the cube with the volume of a sphere of
 * radius r (world units) on spacing sp: side = (4π/3)^{1/3}·r/sp, rounded
 * to the nearest odd voxel count. */
void scatter_equal_volume_cube(double r, const double sp[3], int half[3]);
/* Voxel count of such a cube. */
uint64_t scatter_cube_voxels(const int half[3]);

/* Largest box (voxels) the occlusion of radius R needs (for the SAT scale). */
uint64_t scatter_occlusion_max_box(double R, const double sp[3]);

/* Fills g (allocated at scale 1, i.e. the volume's nodes) with A(x). */
volux_status scatter_occlusion_build(volux_context *ctx, int threads, const scatter_sat *sat, double R, int shells,
                                     const double sp[3], scatter_grid *g);

#endif
