/* techniques/ao/ao.h — `ao` state, for tests that check which caches an edit rebuilt. */
#ifndef VOLUX_AO_H
#define VOLUX_AO_H

#include "techniques/scatter/base.h"
#include "techniques/scatter/envdir.h"
#include "techniques/scatter/grid.h"
#include "techniques/scatter/sat3d.h"

extern const volux_technique_class volux_ao_class;

#define AO_MIP_MAX 12
/* steps of the near field's midpoint rule (h, h, 2h, 4h ... up to R) */
#define AO_NEAR_MAX_STEPS 40

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
    scatter_grid sigma;  /* the values at the volume's nodes: only while the grids build */
    scatter_dirw far;    /* F_k(x): transmittance from R to the box exit, coarse grid */
    int mip_levels;      /* σt means over cubes of 2, 4, 8 ... voxels (the far march's cones) */
    int mip_dims[AO_MIP_MAX][3];
    float *mip[AO_MIP_MAX];
    size_t mip_bytes[AO_MIP_MAX];
    int near_lanes;      /* kernel of the near field's build: 0 scalar, 8, 16 */
    scatter_env env;     /* the environment as K directions (E_k; K = 0: none) */
    uint64_t sat_builds, occ_builds, vis_builds, far_builds, env_table_builds;
} ao_state;

/* The inputs of a build of the near (ao.c: build_directional) or far
 * (build_far) grid: every direction takes the same steps from a node, so
 * a kernel may run the directions of a node as lanes. */
typedef struct ao_dir_job {
    const struct ao_state *st;   /* far: the σt pyramid, radius, voxel size     */
    const scatter_grid *sigma;   /* near: the volume's values at its nodes (floats) */
    const volux_transfer_lut *lut; /* near: σt of a value (post-classification) */
    scatter_dirw *out;           /* W_k or F_k bytes per node                 */
    volux_vec3 origin;           /* the volume's: world → index space          */
    float inv_sp[3];
    int n_steps;
    float step_mid[AO_NEAR_MAX_STEPS], step_len[AO_NEAR_MAX_STEPS]; /* world */
    const unsigned char *clear;  /* near, per macrocell: every cell within R is empty */
    int cells[3];
    /* index-space displacement per world unit along d_k; zero past K */
    float dq[3][SCATTER_ENV_MAX_DIRS];
} ao_dir_job;

/* The memory model (estimate.c, docs/SCALE.md). */
uint64_t volux_ao_estimate_bytes(const volux_scene *scene, const volux_technique_class *cls, uint64_t *volume_added);
/* The camera march as packets (march_lanes.h over render/packet_impl.h). */
void volux_ao_march_avx2(const volux_packet_march *pm, const void *tech, const volux_scene *scene,
                         const volux_tile *tile, float *rgb, volux_tile_stats *stats);
void volux_ao_march_avx512(const volux_packet_march *pm, const void *tech, const volux_scene *scene,
                           const volux_tile *tile, float *rgb, volux_tile_stats *stats);
/* The near field of z slice z of j->out, the directions of a node as
 * lanes (march_lanes.h); the scalar build rounded the same way, but for
 * the vector exp (≤ 2 ulp: a byte may differ by 1). */
/* Node (x, y) of slice z of j->out: its index-space position and bytes. */
static inline unsigned char *ao_dir_node(const ao_dir_job *j, int x, int y, int z, volux_vec3 *q) {
    const scatter_dirw *g = j->out;
    volux_vec3 p = v3(g->lo.x + (float)x * g->h[0], g->lo.y + (float)y * g->h[1], g->lo.z + (float)z * g->h[2]);
    *q = v3((p.x - j->origin.x) * j->inv_sp[0], (p.y - j->origin.y) * j->inv_sp[1], (p.z - j->origin.z) * j->inv_sp[2]);
    return g->v + (((size_t)z * (size_t)g->dims[1] + (size_t)y) * (size_t)g->dims[0] + (size_t)x) * (size_t)g->stride;
}

/* As ao_dir_node for the near field; 0 (bytes written: W = 1) when the
 * node's macrocell sees only empty cells within R. */
static inline int ao_near_node(const ao_dir_job *j, int x, int y, int z, volux_vec3 *q, unsigned char **o) {
    const scatter_dirw *g = j->out;
    *o = ao_dir_node(j, x, y, z, q);
    int c[3] = {(int)(q->x / (float)VOLUX_CELL_SIZE), (int)(q->y / (float)VOLUX_CELL_SIZE),
                (int)(q->z / (float)VOLUX_CELL_SIZE)};
    for (int a = 0; a < 3; a++) c[a] = c[a] < 0 ? 0 : (c[a] >= j->cells[a] ? j->cells[a] - 1 : c[a]);
    if (!j->clear[((size_t)c[2] * (size_t)j->cells[1] + (size_t)c[1]) * (size_t)j->cells[0] + (size_t)c[0]]) return 1;
    for (int d = 0; d < g->stride; d++) (*o)[d] = d < g->K ? 255 : 0;
    return 0;
}

/* The far field's steps from a node (ao.c: far_transmittance): steps that
 * double from R, 4 pieces each, a piece reading pyramid level l. */
#define AO_FAR_SUB 4
static inline int ao_far_level(const ao_state *st, float piece, float vox) {
    int l = (int)floorf(log2f(piece / vox) + 0.5f) - 1; /* cube of 2^(l+1) voxels ≈ the piece */
    return l < 0 ? 0 : (l >= st->mip_levels ? st->mip_levels - 1 : l);
}

void volux_ao_near_slice_avx2(const ao_dir_job *j, int z);
void volux_ao_near_slice_avx512(const ao_dir_job *j, int z);
/* The far field of z slice z of j->out, likewise (ao.c: far_transmittance). */
void volux_ao_far_slice_avx2(const ao_dir_job *j, int z);
void volux_ao_far_slice_avx512(const ao_dir_job *j, int z);
/* Mean σt around index-space point q over a cube of 2^(l+1) voxels (ao.c). */
float volux_ao_mip_sample(const ao_state *st, int l, volux_vec3 q);
/* The scalar shading of one packet lane (positional lights, flat volumes). */
void volux_ao_shade_lane(const void *tech, const volux_packet_lane *in, float c[3]);

#endif
