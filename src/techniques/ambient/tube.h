/*
 * techniques/ambient/tube.h — distribution of light by tube marching
 * (Ament et al. 2013, §4.2.2, Eqs. 14–17) into a radiance cache.
 *
 * The cache holds V(x) ∈ [0, 1], the fraction of a light's unshadowed
 * irradiance that arrives at x through a chain of spheres of radius s/2
 * laid from the light (or the volume box, where the light enters it) to x:
 *
 *     V(x) = V(x − s ω) · τ(ρ(x − s/2 ω) · (s/2)/r)            (Eq. 16)
 *     V(x) = τ(ρ(x − δ/2 ω) · (δ/2)/r)  if the chain start is δ ≤ s away
 *
 * with ω the light's travel direction at x, ρ = r σ̃t the optical radius
 * from the ambient extinction volume, and τ(ρ) = L̃o(0, ρ, g) / L̃o(0, 0, g)
 * the normalised θ = 0 column of the table (see ambient.c for why the
 * normalisation and the clamp τ ≤ 1). The step is s = 2r (Δx = 2r in the
 * paper) unless the cache is too coarse for it (see tube_step).
 *
 * Every node is its own chain end, so the paper's interpolation between
 * x_k and x_{k+1} (Eq. 17) is replaced by exact chain ends; V(x − sω) is
 * read trilinearly from nodes finished earlier: directional lights sweep
 * slices along the dominant axis, point lights sweep Chebyshev shells
 * around the light, and s is large enough that every node read lies in an
 * earlier slice/shell. Nodes of one slice/shell are independent, so the
 * sweep is parallel and deterministic.
 */
#ifndef VOLUX_AMBIENT_TUBE_H
#define VOLUX_AMBIENT_TUBE_H

#include "techniques/scatter/grid.h"
#include "techniques/scatter/lights.h"

typedef struct tube_input {
    const scatter_grid *rho; /* optical radius r·σ̃t                       */
    const float *tau;        /* τ at the table's σ̃t nodes                  */
    int n_sigma;
    float sigma_max;         /* table Σ̃t                                  */
    float radius;            /* r, world units                             */
    int threads;
} tube_input;

/* τ(ρ') by linear interpolation over the table's σ̃t nodes (clamped). */
static inline float tube_tau(const tube_input *in, float rho) {
    float u = rho * (float)(in->n_sigma - 1) / in->sigma_max;
    if (u <= 0.0f) return in->tau[0];
    int last = in->n_sigma - 1;
    if (u >= (float)last) return in->tau[last];
    int i = (int)u;
    float f = u - (float)i;
    return in->tau[i] + (in->tau[i + 1] - in->tau[i]) * f;
}

/* The marching step s (world) for light l on cache grid V. */
float tube_step(const tube_input *in, const scatter_grid *V, const scatter_light *l);

/* Fills V (already allocated over the volume box) for light l. */
void tube_march(const tube_input *in, const scatter_light *l, scatter_grid *V);

/* V at one node by walking the chain directly (no cache reads): the
 * closed-form product of table look-ups the sweep must reproduce, for
 * tests. */
float tube_chain(const tube_input *in, const scatter_light *l, const scatter_grid *V, volux_vec3 x);

#endif
