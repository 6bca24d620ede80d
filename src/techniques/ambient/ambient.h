/*
 * techniques/ambient/ambient.h — `ambient` state (Ament et al. 2013), for
 * tests that check which caches an edit rebuilt.
 */
#ifndef VOLUX_AMBIENT_H
#define VOLUX_AMBIENT_H

#include "techniques/scatter/base.h"
#include "techniques/scatter/envdir.h"
#include "techniques/scatter/grid.h"
#include "techniques/scatter/sat3d.h"
#include "tube.h"
#include "table.h"

extern const volux_technique_class volux_ambient_class;

#define AMBIENT_ALBEDO_LUT 257

typedef struct ambient_stats {
    uint64_t sat_builds, rho_builds, rho_c_builds, occ_builds, table_loads, slice_builds;
    uint64_t cache_builds, cache_resums; /* over all slots (per slot: ambient_slot) */
    uint64_t env_vis_builds, env_table_builds; /* environment: tube-marched fit / light table */
} ambient_stats;

/* What ambient keeps per light slot. */
typedef struct ambient_slot {
    scatter_grid cache;    /* radiance cache D_j = −ln V_j                  */
    tube_geometry geo;     /* when phase_cache                              */
    int geo_ok;            /* geo matches ρ_c, radius, table, light         */
    uint64_t cache_builds; /* marches                                       */
    uint64_t cache_resums; /* phase edits: re-sums from the kept geometry   */
} ambient_slot;

/* Environment directions tube-marched at once, one per thread, each
 * single-threaded (ambient.c build_env_vis). */
#define AMBIENT_ENV_BATCH 2

typedef struct ambient_state {
    scatter_base b;
    /* parameters */
    float radius;                 /* r, world units                          */
    float cache_scale;
    int specular;
    float offset;                 /* x_o = x + offset·lag·ω (Eq. 20: 1)      */
    float offset_mfp;             /* adaptive lag ≤ offset_mfp/σt (0: lag r)  */
    int fill;                     /* offset_mode "fill" (§8): lag scaled by the
                                     sphere's fill, exact lag window          */
    int albedo_once;              /* collided light ÷ albedo·c, weight 1 − e^{−2ρ} */
    float grad_ref;               /* |∇s| (per world unit) of full specular  */
    float ao, ao_radius;          /* AO term weight, radius (world)          */
    int ao_shells;
    volux_ambient_table_desc want; /* table the parameters ask for          */
    int albedo_axis;              /* want has the albedo set                 */
    int tinted;                   /* per-channel lookups at albedo·c         */
    double albedo;                /* albedo the slice is read at             */
    char table_file[1024];
    /* the table and its slice at the current g */
    volux_ambient_table table;
    int have_table;
    char loaded_file[1024];
    float *slice;                 /* [n_sigma][n_theta]                      */
    float *kappa;                 /* [n_sigma] −ln of the normalised θ = 0 column */
    double **ln_col;              /* [n_albedo·n_g] ln of the table's (albedo,
                                     g) blocks, each [n_sigma][n_theta],
                                     computed on first use                   */
    int ln_n;                     /* entries of ln_col                       */
    size_t slice_bytes, kappa_bytes;
    float *slab;                  /* tinted: [n_albedo][n_sigma][n_theta] at g */
    size_t slab_bytes;
    float albedo_lut[AMBIENT_ALBEDO_LUT]; /* albedo i/(N−1) → fractional node */
    float u_theta, u_sigma;       /* (n−1)/π and (n−1)/Σ̃t                   */
    /* caches */
    scatter_sat sat;
    scatter_grid rho;             /* r·σ̃t at the volume's nodes             */
    scatter_grid rho_c;           /* ρ at the radiance caches' nodes (tube marching) */
    scatter_grid occ;             /* A(x), only when the AO term is on       */
    ambient_slot *slot;           /* per light slot [slot_cap]               */
    int slot_cap;
    int phase_cache;              /* keep the g-independent tube geometry    */
    /* environment light per direction (issue 28; scatter/envdir.h) */
    int env_dirs;                 /* K (0: through the AO term, as before)   */
    scatter_env env;              /* the environment as K directions         */
    scatter_dirvis env_vis;       /* fit of V_k at the sphere's entry points  */
    scatter_grid env_scratch[AMBIENT_ENV_BATCH]; /* radiance caches of the directions marched together */
    scatter_grid env_rho;         /* ρ at env_scratch's nodes (tube marching) */
    float env_scale;              /* their resolution relative to the volume */
    tube_geometry env_geo[SCATTER_ENV_MAX_DIRS]; /* per direction (phase_cache): a phase
                                     edit re-sums instead of re-marching */
    int env_geo_ok;               /* env_geo matches env_rho, radius, table  */
    volux_vec3 env_E_table[SCATTER_ENV_MAX_DIRS]; /* E_k the light table was built from */
    float *env_m;                 /* [texel][σ node][albedo block][3][4]     */
    size_t env_m_bytes;
    int env_m_alb;                /* albedo blocks in env_m (1: the slice)   */
    ambient_stats stats;
} ambient_state;

/* The memory model (estimate.c, docs/SCALE.md). */
uint64_t volux_ambient_estimate_bytes(const volux_scene *scene, const volux_technique_class *cls,
                                      uint64_t *volume_added);
/* The camera march as packets (render/packet_impl.h), for offset 0 (no
 * lag); the shading stays scalar, called per lane (volux_ambient_shade_lane). */
void volux_ambient_march_avx2(const volux_packet_march *pm, const void *tech, const volux_scene *scene,
                              const volux_tile *tile, float *rgb, volux_tile_stats *stats);
void volux_ambient_march_avx512(const volux_packet_march *pm, const void *tech, const volux_scene *scene,
                                const volux_tile *tile, float *rgb, volux_tile_stats *stats);
void volux_ambient_shade_lane(const void *tech, const volux_packet_lane *in, float c[3]);

#endif
