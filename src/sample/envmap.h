/*
 * sample/envmap.h — importance sampling of an environment light by solid
 * angle (constant or equirectangular map, DESIGN §2 mapping and rotation_y).
 *
 * Map: the sampling table has one cell per texel. A cell's weight is
 *     w = sin θ_row · luminance(∫cell of the bilinear reconstruction),
 * where the integral of the bilinear lookup of volux_environment_radiance
 * over the texel's cell is the separable kernel (1/8, 3/4, 1/8) over the
 * 3×3 neighbours (wrapping in u, clamping in v like the lookup); negative
 * texels count as 0. So the density is > 0 wherever the looked-up radiance
 * is > 0 and light sampling alone is unbiased. sin θ accounts for the area
 * of equirectangular rows on the sphere. The density in (u,v) becomes a
 * solid-angle density with the Jacobian dω = 2π² sin θ du dv, i.e.
 * p(ω) = p(u,v) / (2π² sin θ) (pbrt 3rd ed. §14.2.4, "Infinite Area
 * Lights").
 *
 * Constant environment: uniform sphere sampling, pdf 1/(4π).
 *
 * The light description is borrowed at every call (its map must be the one
 * the sampler was built from). Read-only after build; thread-safe.
 */
#ifndef VOLUX_ENVMAP_H
#define VOLUX_ENVMAP_H

#include "distribution2d.h"
#include "volux/light.h"

typedef struct volux_envmap_sampler {
    int has_map;
    volux_distribution2d dist; /* map only */
} volux_envmap_sampler;

/* Builds the sampler for environment light d (rebuilds in place). */
volux_status volux_envmap_sampler_build(volux_context *ctx, const volux_light_desc *d, volux_envmap_sampler *s);
void volux_envmap_sampler_free(volux_context *ctx, volux_envmap_sampler *s);
size_t volux_envmap_sampler_bytes(const volux_envmap_sampler *s);

/* Samples a world direction; returns its solid-angle pdf (0: no sample —
 * an all-black map, or a pole). */
float volux_envmap_sample(const volux_envmap_sampler *s, const volux_light_desc *d, float u0, float u1,
                          volux_vec3 *dir);
/* Solid-angle pdf of sampling direction dir (unit). */
float volux_envmap_pdf(const volux_envmap_sampler *s, const volux_light_desc *d, volux_vec3 dir);

#endif
