/*
 * techniques/ambient/tube.h — distribution of light by tube marching
 * (Ament et al. 2013, §4.2.2, Eqs. 14–17) into a radiance cache.
 *
 * V(x) ∈ [0, 1] is the fraction of a light's unshadowed irradiance that
 * arrives at x through a chain of spheres of radius s/2 laid from the light
 * (or the volume box, where the light enters it) to x:
 *
 *     V(x) = V(x − s ω) · τ(ρ(x − s/2 ω) · (s/2)/r)            (Eq. 16)
 *     V(x) = τ(ρ(x − δ/2 ω) · (s/2)/r)^{δ/s}  if the chain start is δ ≤ s
                                            away (Eq. 17's interpolation)
 *
 * The cache stores D = −ln V (an optical depth): the recursion becomes a
 * sum, D(x) = D(x − sω) + κ(ρ'), κ = −ln τ, and interpolating D between
 * nodes is exact wherever the medium is homogeneous (D linear along the
 * chain), where interpolating V would bend an exponential (several per
 * cent of error per step, measured). Readers use V = e^{−D}.
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

#include <stdint.h>

#include "techniques/scatter/grid.h"
#include "render/lights.h"

/* The g-independent part of a radiance cache that is worth keeping. The
 * phase enters tube marching only through κ (the table's θ = 0 column at
 * g); which nodes a node reads, with which weights, and the optical radius
 * of each sphere do not depend on it. The expensive g-independent part is
 * the trilinear read of ρ at the centre of the sphere towards the light
 * (about 40 % of a march); the chain geometry is cheaper to recompute than
 * to store and stream back (20 bytes per node measured slower than
 * recomputing it). A march records, per node, the κ argument
 * arg = ρ·(s/2)/r of that sphere (the directional fast path: the κ-table
 * coordinate itself); a re-sum (tube_resum) recomputes D from it with a
 * new κ, in the same sweep order, bit-identical to a march with that κ.
 * The sign bit (arg ≥ 0 otherwise) marks nodes more than two steps from
 * their chain start, whose D does not use δ: a re-sum of a block of such
 * nodes skips the box exit. Directional sweeps store the records in sweep
 * order (see tube.c: rec_index). 4 bytes per cache node.
 *
 * Vacuum chains (vac, 1 byte per node, in the cache's node order): a node
 * whose own sphere and every node its D reads (recursively) have arg = 0
 * has D = +0 for every κ with κ(0) = +0 (the τ normalisation makes κ(0) =
 * −ln 1 = 0 for every g), so a re-sum writes +0 there without computing
 * it: a third to a half of the nodes of the bench scenes (light crossing
 * empty space). The AVX-512 march records vac[x] = (D(x) == +0) and
 * checks, per node, the invariant that makes this exact: D(x) == +0 only
 * where arg = 0 (or the weight of κ is 0: δ = 0 at the chain start) and
 * every node read is +0. A node that breaks it (κ(arg) underflowing to 0,
 * a τ clamped to 1, an interpolation underflowing) clears vac_ok, and
 * re-sums then compute every node. */
typedef struct tube_geometry {
    float *arg;
    unsigned char *vac;
    int vac_ok;
    size_t n, bytes;
} tube_geometry;

enum { TUBE_KERNEL_BEST = 0, TUBE_KERNEL_SCALAR = 1, TUBE_KERNEL_AVX2 = 2 };

typedef struct tube_input {
    const scatter_grid *rho; /* optical radius r·σ̃t                       */
    const float *kappa;      /* κ = −ln τ at the table's σ̃t nodes          */
    int n_sigma;
    float sigma_max;         /* table Σ̃t                                  */
    float radius;            /* r, world units                             */
    int threads;
    int kernel_cap;          /* TUBE_KERNEL_*: the widest node update to use
                                (tests; 0 = the best this CPU has)         */
    tube_geometry *geo;      /* march: record here (allocated for V's nodes)
                                if not NULL; re-sum: read from here        */
} tube_input;

/* κ(ρ') = −ln τ(ρ'), linear over the table's σ̃t nodes (clamped). */
static inline float tube_kappa(const tube_input *in, float rho) {
    float u = rho * (float)(in->n_sigma - 1) / in->sigma_max;
    if (u <= 0.0f) return in->kappa[0];
    int last = in->n_sigma - 1;
    if (u >= (float)last) return in->kappa[last];
    int i = (int)u;
    float f = u - (float)i;
    return in->kappa[i] + (in->kappa[i + 1] - in->kappa[i]) * f;
}

/* κ from τ, capped where τ underflows; κ(1) = +0 (not −0: vacuum chains,
 * tube_geometry, and the scalar path, which returns κ[0] itself for ρ = 0,
 * then give the +0 of the vector paths' interpolation). */
static inline float tube_kappa_of_tau(float tau) { return tau > 1e-30f ? 0.0f - logf(tau) : 69.0f; }

/* The marching step s (world) for light l on cache grid V. */
float tube_step(const tube_input *in, const scatter_grid *V, const volux_prepared_light *l);

/* Fills the cache (already allocated over the volume box) with D = −ln V
 * for light l. Allocates a little scratch through ctx (point lights). */
volux_status tube_march(volux_context *ctx, const tube_input *in, const volux_prepared_light *l, scatter_grid *V);

/* Recomputes D from in->geo (recorded by a march of the same light on the
 * same grid, ρ, radius and table size) with in->kappa. */
volux_status tube_resum(volux_context *ctx, const tube_input *in, const volux_prepared_light *l, scatter_grid *V);

/* (Re)allocates g for n nodes (kept if it has that size) / frees it. */
volux_status tube_geometry_alloc(volux_context *ctx, size_t n, tube_geometry *g);
void tube_geometry_free(volux_context *ctx, tube_geometry *g);

/* V (not D) at one point by walking the chain directly (no cache reads):
 * the closed-form product of table look-ups the sweep must reproduce, for
 * tests. */
float tube_chain(const tube_input *in, const volux_prepared_light *l, const scatter_grid *V, volux_vec3 x);

#endif
