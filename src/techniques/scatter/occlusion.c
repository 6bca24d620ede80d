/* techniques/scatter/occlusion.c — see occlusion.h. */
#include <math.h>
#include <string.h>

#include "core/context_internal.h"
#include "occlusion.h"

#define CUBE_OF_SPHERE 1.61199195401647 /* (4π/3)^{1/3} */

void scatter_equal_volume_cube(double r, const double sp[3], int half[3]) {
    for (int a = 0; a < 3; a++) {
        double side = CUBE_OF_SPHERE * r / sp[a];
        int h = (int)floor((side - 1.0) * 0.5 + 0.5);
        half[a] = h < 0 ? 0 : h;
    }
}

uint64_t scatter_cube_voxels(const int half[3]) {
    return (uint64_t)(2 * half[0] + 1) * (uint64_t)(2 * half[1] + 1) * (uint64_t)(2 * half[2] + 1);
}

uint64_t scatter_occlusion_max_box(double R, const double sp[3]) {
    int h[3];
    scatter_equal_volume_cube(R, sp, h);
    return scatter_cube_voxels(h);
}

volux_status scatter_occlusion_build(volux_context *ctx, int threads, const scatter_sat *sat, double R, int shells,
                                     const double sp[3], scatter_grid *g) {
    if (shells < 1) shells = 1;
    if (shells > 8) shells = 8;
    int half[8][3], n = 0;
    double weight[8], r_eff[9] = {0}, count[9] = {0};
    double dv = sp[0] * sp[1] * sp[2];
    for (int i = 1; i <= shells; i++) {
        int h[3];
        scatter_equal_volume_cube(R * i / shells, sp, h);
        double N = (double)scatter_cube_voxels(h);
        if (N <= count[n]) continue; /* same cube as the previous shell */
        memcpy(half[n], h, sizeof h);
        n++;
        count[n] = N;
        r_eff[n] = cbrt(3.0 * N * dv / (4.0 * 3.14159265358979323846));
    }
    /* τ = Σ_i Δr_i (S_i − S_{i−1})/(N_i − N_{i−1}) = Σ_i c_i S_i. */
    for (int i = 1; i <= n; i++) {
        double c = (r_eff[i] - r_eff[i - 1]) / (count[i] - count[i - 1]);
        if (i < n) c -= (r_eff[i + 1] - r_eff[i]) / (count[i + 1] - count[i]);
        weight[i - 1] = c;
    }
    return scatter_sat_filter(ctx, threads, sat, n, (const int(*)[3])half, weight, 1, g->v);
}
