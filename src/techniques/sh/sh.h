/*
 * techniques/sh/sh.h — `sh`: light–material interaction with spherical
 * harmonics (Lindemann & Ropinski 2010). State and the internal entry
 * points of its passes, for the class (sh.c) and white-box tests.
 *
 * Caches and what invalidates them (details in README.md):
 *   coefficient volume L'_mi (projection + scattering)
 *        ← volume, extinction, density, projection/scattering parameters,
 *          colour (only with bleeding, only the colour curve and albedo)
 *   light SH L_i (per slot)          ← that light, volume (distant centre)
 *   shade volume S = ∫L'_mi L_i / ∫L_i  ← coefficient volume, lights
 *   material SH tables (per θ_o)     ← material channel
 *   material–light tables F(n, ω_o)  ← material channel, lights
 *   material index over the TF domain ← material channel, volume
 *   gradient cache (BRDF normals)    ← volume (only with BRDF materials)
 * Camera, phase (g is read per ray) and render edits touch none.
 */
#ifndef VOLUX_SH_H
#define VOLUX_SH_H

#include "dipole.h"
#include "render/raycaster.h"
#include "sample/gradient.h"
#include "shbasis.h"

extern const volux_technique_class volux_sh_class;
/* The memory model (estimate.c, docs/SCALE.md). */
uint64_t volux_sh_estimate_bytes(const volux_scene *scene, const volux_technique_class *cls, uint64_t *volume_added);

/* A node-centred grid over the volume: node i lies at fine index i·ratio
 * (the last node may sit past the last voxel; samples clamp). */
typedef struct sh_grid {
    int dims[3];
    int ratio;
    size_t nodes;
} sh_grid;

/* How coefficients are stored per node: `channels` channels (1 grey, 3 RGB
 * or Y/Cb/Cr), channel c with bands[c]² coefficients at offset[c]. */
typedef struct sh_layout {
    int channels, ycc;
    int bands[3], offset[3], stride;
} sh_layout;

/* What a projection computes (parameters that change its result). */
typedef struct sh_projection_params {
    int bands, chroma_bands, downsample, rays, bleeding, scattering, scatter_preset, progressive;
    float step_growth, ray_opacity, neighbourhood, scatter_scale;
    float surface_offset; /* coefficient cells: a surface node's rays start on its empty side (issue 28) */
} sh_projection_params;

#define SH_MAX_MATERIALS (VOLUX_TF_MAX_MATERIALS + 1)
#define SH_TABLE_THETA 32 /* material SH tables: θ_o samples over [0, π/2] */
#define SH_OCTA 16        /* material–light tables: octahedral n and ω_o   */
#define SH_MAX_DELTA 16   /* delta lights the surface attenuation weighs one by one */
#define SH_KD_N 129       /* kdepth: D = 0 … SH_KD_MAX in 128 steps        */
#define SH_KD_MAX 16.0f

/* One material of the channel, prepared. */
typedef struct sh_material {
    int kind;   /* volux_material_kind */
    float g;    /* phase                */
    int brdf;   /* needs a normal       */
    /* BRDF: per θ_o, the SH of M(·, ω_o)·cos⁺ in the local frame, diffuse
     * (× TF colour) and specular (white; MERL: per channel) parts */
    float (*table)[4][SH_MAX_COEFFS]; /* [SH_TABLE_THETA][d, sR, sG, sB] */
    /* material–light table: [n octa][ω_o octa][6] = F_d rgb, F_s rgb */
    float *light_table;
} sh_material;

/* One light's projection, RGB. */
typedef struct sh_light_coeffs {
    float c[3][SH_MAX_COEFFS];
} sh_light_coeffs;

typedef struct sh_state {
    volux_raycaster rc;
    /* render parameters */
    int preintegrate, skip_empty;
    float t_min, grad_ref;
    int progressive;
    /* projection: what the current coefficient volume was made from */
    sh_projection_params applied;
    uint64_t applied_color;   /* hash of colour curve + albedo (bleeding) */
    int have_coef;            /* 0: rebuild at the next update            */
    int coarse;               /* progressive: the coefficient volume is the coarse level */
    sh_grid grid;
    sh_layout layout;
    float *coef;              /* layout.stride floats per node            */
    size_t coef_bytes;
    /* lights */
    sh_light_coeffs *light_sh;   /* per light slot [light_sh_cap]          */
    int light_sh_cap;
    float li[3][SH_MAX_COEFFS];  /* Σ over enabled lights, RGB             */
    /* shade volume: S(x) RGB per node (4 floats, w unused); with the
     * triple product, S of the delta lights only (li − le) */
    float *shade;
    size_t shade_bytes;
    int have_shade;
    /* triple product for environment lights (`env_product`): le = their
     * part of li; the product volume holds (L_env·L'_mi) projected, 16
     * coefficients per colour channel and node (Γ from sh_triple_init) */
    int env_product;             /* parameter                               */
    int product_on;              /* env_product and an environment is lit   */
    float le[3][SH_MAX_COEFFS];
    float *prod;
    size_t prod_bytes;
    sh_triple triple;
    int have_triple;
    /* material channel */
    int n_materials;
    sh_material mat[SH_MAX_MATERIALS];
    int any_brdf, have_tables, have_light_tables;
    uint8_t mat_index[4096];  /* per LUT entry: material, 255 = the TF's phase */
    volux_gradient_cache grad;
    int have_grad;
    size_t table_bytes;
    /* surfaces (issue 28, `surface_offset`): a shading sample on a surface
     * reads the grid surface_offset cells outward along the opacity
     * gradient and attenuates it by the optical depth D crossed on the way,
     * per light direction: delta lights exactly (directions from the
     * volume's centre, weights their ∫L per colour), environments by
     * Funk–Hecke with the zonal kernel's Legendre coefficients kdepth */
    float surface_offset;
    int n_delta;
    volux_vec3 delta_dir[SH_MAX_DELTA];
    float delta_w[SH_MAX_DELTA][3];
    /* 1: a true delta (directional, point, spot), whose phase function the
     * first factor of Eq. 3 evaluates exactly instead of at 4 bands */
    unsigned char delta_exact[SH_MAX_DELTA];
    int delta_light[SH_MAX_DELTA]; /* its index in rc.lights.all */
    float delta_e0[SH_MAX_DELTA];  /* Σrgb of its irradiance at the volume's centre */
    float delta_sum[3], env_sum[3];
    float kdepth[SH_KD_N][SH_MAX_BANDS];
    float hc, sp_inv[3];
    /* delta lights' shadows (issue 28, `delta_shadows`, deltavis.c): per
     * node the transmittance towards each true delta light (n_dvis grids of
     * grid.nodes floats; dvis_light: its index in delta_*), read
     * `near_field` cells towards the light after marching that far; S then
     * holds the other lights only (see dvis_on) */
    int delta_shadows;           /* parameter                               */
    float near_field;            /* parameter, coefficient cells            */
    int dvis_on;                 /* delta_shadows and shadows-only coefficients */
    float *dvis;
    size_t dvis_bytes;
    int n_dvis;
    int dvis_light[SH_MAX_DELTA];
    float dvis_w[SH_MAX_DELTA][3]; /* delta_w / ∫ of the lights S is normalised over */
    float rest_sum[3];             /* delta_sum without the true delta lights */
    int grid_lights;               /* the shade/product volumes hold light   */
    /* statistics (tests, bench) */
    uint64_t projections, bakes, light_projections;
    uint64_t rays_cast;       /* projection rays, all projections so far */
    double projection_ms;
} sh_state;

/* Coefficient volume L_mi (and L'_mi with scattering) for the state's
 * volume and LUT with parameters p on grid `ratio`: allocates *out
 * (layout in *lay) through ctx. Parallel, progress "sh projection". */
volux_status sh_project(sh_state *st, const sh_projection_params *p, int ratio, int rays, sh_grid *grid,
                        sh_layout *lay, float **out, size_t *out_bytes);
/* SH of one light seen from `centre` (RGB × 16), distant approximation. */
volux_status sh_light_project(volux_context *ctx, const volux_light_desc *d, volux_vec3 centre, float out[3][16]);
/* Material SH tables (allocates m->table). */
volux_status sh_material_prepare(volux_context *ctx, const volux_tf_material *t, sh_material *m);
/* Material–light table for lights li (allocates m->light_table). */
volux_status sh_material_light_table(volux_context *ctx, sh_material *m, const float li[3][SH_MAX_COEFFS]);
void sh_material_free(volux_context *ctx, sh_material *m);
/* BRDF·cos⁺ of a material in the local frame (z = normal): diffuse part
 * (to be tinted) and specular rgb. For tests. */
void sh_material_eval(const volux_tf_material *t, const void *merl, const double wi[3], const double wo[3],
                      double *diffuse, double spec[3]);

/* Per-node transmittance towards each true delta light (deltavis.c) for
 * the state's grid and lights; fills st->dvis, n_dvis, dvis_light. */
volux_status sh_delta_visibility(sh_state *st);
void sh_delta_visibility_free(sh_state *st);
/* Optical depth from fine index q along dq (fine index per world unit)
 * over dist world units at the volume's resolution. */
float sh_tau_segment(const sh_state *st, volux_vec3 q, volux_vec3 dq, float dist);

/* σt at fine index q; 0 outside the volume's box [0, dims − 1] (issue 28):
 * the medium ends there, as for `pathtrace`, so a volume cut through
 * dense material (the bonsai pot, the engine block) is a surface facing
 * out of the box. Clamped, the cut had no gradient across it and the
 * surface term took its normal from the structure just below: the pot's
 * cut face got dark patches and a bright rim, the engine's front face its
 * back light (the blue tint). */
static inline __attribute__((always_inline)) float sh_sigma_q(const sh_state *st, float x, float y, float z,
                                                              volux_storage storage) {
    const int *d = st->rc.volume->dims;
    if (!(x >= 0.0f && y >= 0.0f && z >= 0.0f && x <= (float)(d[0] - 1) && y <= (float)(d[1] - 1) &&
          z <= (float)(d[2] - 1)))
        return 0.0f;
    return volux_lut_sigma(st->rc.lut, volux_volume_sample_bricked(st->rc.volume, x, y, z, storage));
}

/* Octahedral map of a unit direction to [0,1)² and back. */
static inline void sh_octa_encode(volux_vec3 d, float *u, float *v) {
    float s = fabsf(d.x) + fabsf(d.y) + fabsf(d.z);
    float x = d.x / s, y = d.y / s;
    if (d.z < 0.0f) {
        float ox = (1.0f - fabsf(y)) * (x >= 0.0f ? 1.0f : -1.0f);
        float oy = (1.0f - fabsf(x)) * (y >= 0.0f ? 1.0f : -1.0f);
        x = ox, y = oy;
    }
    *u = 0.5f * x + 0.5f;
    *v = 0.5f * y + 0.5f;
}
static inline volux_vec3 sh_octa_decode(float u, float v) {
    float x = 2.0f * u - 1.0f, y = 2.0f * v - 1.0f, z = 1.0f - fabsf(x) - fabsf(y);
    if (z < 0.0f) {
        float ox = (1.0f - fabsf(y)) * (x >= 0.0f ? 1.0f : -1.0f);
        float oy = (1.0f - fabsf(x)) * (y >= 0.0f ? 1.0f : -1.0f);
        x = ox, y = oy;
    }
    return v3_normalize(v3(x, y, z));
}

#endif
