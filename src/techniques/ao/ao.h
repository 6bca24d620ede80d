/* techniques/ao/ao.h — `ao` state, for tests that check which caches an edit rebuilt. */
#ifndef VOLUX_AO_H
#define VOLUX_AO_H

#include "techniques/scatter/base.h"
#include "techniques/scatter/envdir.h"
#include "techniques/scatter/grid.h"
#include "techniques/scatter/sat3d.h"

extern const volux_technique_class volux_ao_class;

#define AO_MIP_MAX 12

typedef struct ao_state {
    scatter_base b;
    float radius;        /* world */
    int shells;
    float ambient;       /* extra white ambient radiance */
    scatter_sat sat;
    scatter_grid occ;    /* A(x) at the volume's nodes (directional = 0) */
    /* directional occlusion (issue 28; scatter/envdir.h) */
    int directional;     /* 1: W_k(x) per direction; 0: isotropic A(x) */
    int n_dirs;          /* K: directions of the occlusion and of the environment */
    float vis_scale;     /* resolution of the per-direction grid */
    scatter_dirw vis;    /* W_k(x), K bytes per node (near field: 0 .. R) */
    int far_field;       /* 1: also the transmittance beyond R (far grid) */
    scatter_dirw far;    /* F_k(x): transmittance from R to the box exit, coarse grid */
    int mip_levels;      /* σt means over cubes of 2, 4, 8 ... voxels (the far march's cones) */
    int mip_dims[AO_MIP_MAX][3];
    float *mip[AO_MIP_MAX];
    size_t mip_bytes[AO_MIP_MAX];
    scatter_env env;     /* the environment as K directions (E_k; K = 0: none) */
    uint64_t sat_builds, occ_builds, vis_builds, far_builds, env_table_builds;
} ao_state;

/* The memory model (estimate.c, docs/SCALE.md). */
uint64_t volux_ao_estimate_bytes(const volux_scene *scene, const volux_technique_class *cls, uint64_t *volume_added);
/* The camera march as packets (march_lanes.h over render/packet_impl.h). */
void volux_ao_march_avx2(const volux_packet_march *pm, const void *tech, const volux_scene *scene,
                         const volux_tile *tile, float *rgb, volux_tile_stats *stats);
void volux_ao_march_avx512(const volux_packet_march *pm, const void *tech, const volux_scene *scene,
                           const volux_tile *tile, float *rgb, volux_tile_stats *stats);
/* The scalar shading of one packet lane (positional lights, flat volumes). */
void volux_ao_shade_lane(const void *tech, const volux_packet_lane *in, float c[3]);

#endif
