/*
 * techniques/scatter/hg.h — the Henyey–Greenstein phase function in double
 * precision, for the ambient preintegration table's random walks (a walk in
 * a thick sphere takes hundreds of steps). Renderers use the float
 * versions of sample/phase.h (same convention).
 *
 * CONVENTION. cos_theta is the cosine of the scattering angle between the
 * direction light travels before and after the event (g > 0: forward).
 * Normalised per steradian (DESIGN §2):
 *
 *     p(cos θ) = (1 − g²) / (4π (1 + g² − 2g cos θ)^{3/2})
 *
 * which is Ament et al. 2013, Eq. 10, times 1/(4π) (their P/4π is the
 * density; Eqs. 4, 6 and 11 carry the 1/(4π) explicitly).
 *
 * In a backward (camera-to-light) walk that arrived along d and continues
 * along ω, light travels −ω then −d, so cos θ = dot(ω, d); hg_sample
 * returns ω around d.
 *
 * DOES NOT: know lights or media.
 */
#ifndef VOLUX_SCATTER_HG_H
#define VOLUX_SCATTER_HG_H

#include <math.h>

#include "core/vecmath.h"

#define SCATTER_INV_4PI_D 0.0795774715459476678844

static inline double scatter_hg_d(double g, double cos_theta) {
    double denom = 1.0 + g * g - 2.0 * g * cos_theta;
    if (denom < 1e-300) denom = 1e-300;
    return SCATTER_INV_4PI_D * (1.0 - g * g) / (denom * sqrt(denom));
}

/* cos θ drawn from p by inverting its CDF in cos θ (u uniform in [0,1)). */
static inline double scatter_hg_sample_cos(double g, double u) {
    if (fabs(g) < 1e-4) return 1.0 - 2.0 * u;
    double s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u);
    double c = (1.0 + g * g - s * s) / (2.0 * g);
    return c < -1.0 ? -1.0 : (c > 1.0 ? 1.0 : c);
}

typedef struct scatter_dvec3 {
    double x, y, z;
} scatter_dvec3;

/* Unit ω with dot(ω, d) distributed by p and uniform azimuth; d unit.
 * Orthonormal basis after Duff et al. 2017. */
static inline scatter_dvec3 scatter_hg_sample_dir(double g, scatter_dvec3 d, double u0, double u1) {
    double ct = scatter_hg_sample_cos(g, u0);
    double st = sqrt(fmax(0.0, 1.0 - ct * ct));
    double phi = 2.0 * 3.14159265358979323846 * u1;
    double sign = copysign(1.0, d.z);
    double a = -1.0 / (sign + d.z), b = d.x * d.y * a;
    scatter_dvec3 t = {1.0 + sign * d.x * d.x * a, sign * b, -sign * d.x};
    scatter_dvec3 bt = {b, sign + d.y * d.y * a, -d.y};
    double cp = cos(phi) * st, sp = sin(phi) * st;
    scatter_dvec3 w = {d.x * ct + t.x * cp + bt.x * sp, d.y * ct + t.y * cp + bt.y * sp,
                       d.z * ct + t.z * cp + bt.z * sp};
    return w;
}

#endif
