/*
 * techniques/manylights/manylights.h — `manylights`: multiple scattering
 * through virtual (spherical) lights with transmittance cached in adaptive
 * volumetric shadow maps, after Weber, Kaplanyan, Stamminger & Dachsbacher
 * 2013, "Interactive Direct Volume Rendering with Many-light Methods and
 * Transmittance Caching" (cited as W13 below).
 *
 * Light transport is split as in W13 Fig. 1: single scattering from the
 * real lights, ray marched (accurate), plus the light of N virtual lights
 * (VLs) scattered once more towards the camera (Eq. 5). VLs are the
 * vertices of light subpaths traced from every light (§3.1–3.2); each VL
 * has a cube-map AVSM (§3.4, Salvi et al. 2010) holding the transmittance
 * from it to any point of the volume.
 *
 * FILES
 *   vl.c        light subpaths: emission sampling per light type, distance
 *               sampling by delta tracking (Alg. 1, Eq. 8), HG sampling,
 *               Russian roulette; the weights of a stored subpath (Eq. 6)
 *   avsm.c      cube-map AVSMs: build with node-removal compression, point
 *               and trilinear look-ups, ray-marched reference
 *   render.c    the tile renderer (S samples per view ray, Eq. 5)
 *   manylights.c  parameters, the edit → work mapping, progressive
 *               replacement (§4.2), statistics
 *
 * DENSITY. Every quantity that places VLs or is cached per VL uses the
 * transfer function's extinction *without* the global density scale ξ
 * (σ1 = σt/ξ, the technique's own LUT), and ξ enters only where light is
 * weighted: T = exp(−ξ·τ1). AVSMs store τ1, so a density edit re-weights
 * (W13 §5.1: T_new = T_old^(ξ_new/ξ_old)) without touching a shadow map.
 */
#ifndef VOLUX_MANYLIGHTS_H
#define VOLUX_MANYLIGHTS_H

#include "render/raycaster.h"
#include "sample/envmap.h"

extern const volux_technique_class volux_manylights_class;
/* The memory model (estimate.c, docs/SCALE.md). */
uint64_t volux_manylights_estimate_bytes(const volux_scene *scene, const volux_technique_class *cls, uint64_t *volume_added);

/* Longest stored light subpath (VL depth); max_depth − 1 is used when
 * smaller. */
#define ML_MAX_PATH 64
/* An AVSM ray stops once its unscaled optical depth exceeds this
 * (T1 = e^−16 ≈ 1e-7; still ≤ 3e-4 at density scale 0.5). */
#define ML_TAU_STOP 16.0f
/* Largest node count per texel (the `avsm_nodes` parameter's maximum). */
#define ML_MAX_NODES 32

enum { ML_T_AVSM, ML_T_AVSM_LINEAR, ML_T_RAYMARCH };

/* One virtual light: vertex k ≥ 1 of a light subpath, with what Eq. 6
 * needs to re-weight it without re-sampling. Segment k runs from `from`
 * (x_{k−1}: a point on the light, or the previous vertex) to `pos` (x_k). */
typedef struct ml_vl {
    volux_vec3 pos, from;
    volux_vec3 w;      /* unit travel direction of segment k               */
    volux_vec3 w0;     /* the subpath's emission weight per unit light
                          strength: (geometry · map radiance) / pdf         */
    float s;           /* scalar at pos (file units)                        */
    float sigma1;      /* σ1(pos): unscaled extinction, current TF          */
    float tau1;        /* ∫σ1 along segment k, current TF                   */
    float sigma1_s;    /* σ1(pos) and τ1 when the distance was sampled: its */
    float tau1_s;      /* density was scale·σ1_s·exp(−scale·τ1_s) (Alg. 1)  */
    float scale_s;     /* that scale; 0: the Eq. 8 mixture of density_min/max */
    float cos_prev;    /* k ≥ 2: cosine of the scattering angle at x_{k−1}  */
    float pdf_w;       /* k ≥ 2: density the direction was sampled with     */
    float rr;          /* k ≥ 2: Russian-roulette survival probability      */
    float inv_paths;   /* 1 / light subpaths of the set it was traced in    */
    int depth;         /* k                                                 */
    int path;          /* index of its subpath in the light's stream        */
    int slot;          /* AVSM slot in its set's pool (−1: none)            */
    volux_vec3 I;      /* derived: ρ(x_k)·β_in·inv_paths (RGB), the VL's
                          intensity before its phase function               */
} ml_vl;

/* An ordered list of complete light subpaths (vertices of a path are
 * consecutive, starting at depth 1). */
typedef struct ml_list {
    ml_vl *v;
    int n, cap;
} ml_list;

/* The VLs of one light slot. Normally `cur` is the prefix of the light's
 * subpath stream (paths 0 … paths−1, keyed by seed and slot) that first
 * holds `quota` VLs — exactly what a fresh instance traces. While
 * `replacing` (W13 §4.2), `next` holds that prefix for the current scene
 * and the image uses next[0, added) ∪ cur[front, n): new subpaths are
 * added and the oldest removed, whole subpaths at a time. */
typedef struct ml_set {
    int active;
    volux_light_desc desc; /* what it was traced for (map pointer not read) */
    uint64_t map_hash;     /* environment map contents                      */
    int quota;
    ml_list cur, next;
    int paths, npaths;     /* stream paths started for cur (not replacing) /
                              for next                                      */
    int replacing, front, added;
    int removed;           /* records of cur removed during this replacement */
    uint32_t *pool;        /* AVSM slots: pool_cap × layout stride           */
    int pool_cap;
    size_t pool_size;      /* bytes allocated for pool                       */
    int *free_slots, n_free;
} ml_set;

/* AVSM layout: 6 faces × res² texels × nodes, each node a 32-bit word
 * (depth code << 16 | τ1 code). Depth codes are depth/d_max·65535; τ1 codes
 * are the IEEE half-precision bits of τ1. */
typedef struct ml_layout {
    int res, nodes;
    size_t stride;        /* words per VL */
    float d_unit;         /* world length per depth code */
    float inv_d_unit;
} ml_layout;

/* What the tile renderer reads per VL (one cache line). */
typedef struct ml_rvl {
    float px, py, pz;
    float wx, wy, wz;
    float ir, ig, ib;
    float cone_u, cone_c, cone_s; /* the VL's cone-sample pattern */
    float cone_w;                 /* and its distance along the chord (ball) */
    const uint32_t *avsm;
} ml_rvl;

typedef struct ml_state {
    volux_raycaster rc;
    /* parameters */
    int vl_count, samples, avsm_res, avsm_nodes, budget, tmode, single_on, multi_on, iso_phase, view_uniform;
    int ball;                /* VSL kernel: 0 cone (Eq. 5), 1 ball          */
    int sampler;             /* enum volux_sampler_kind (sample/sampler.h)  */
    int passes_per_set;      /* K: pixel sample p uses VL set p / K (0: set 0 always) */
    int preview_vls, preview_samples; /* pixel sample 0: about this many VLs, S (0: off) */
    float eq6_log_bound;     /* ln of the Eq. 6 re-weighting bound (INFINITY: none) */
    float avsm_cone;         /* AVSM ray step grows as avsm_cone·(2/res)·distance */
    float radius_vox, rr_survival, dmin, dmax, shadow_vox, t_min;
    /* derived */
    float radius, h;         /* VSL radius, shadow-march step (world)         */
    float clamp_fg;          /* bound of f_j·f_t·G per VL (INFINITY: none)     */
    float clamp_vox;         /* its parameter: the distance in voxels          */
    float xi;                /* density scale in effect                        */
    int place_by_xi;         /* Eq. 8 off: VLs placed for the current ξ         */
    volux_vec3 center;       /* bounding sphere of the volume                  */
    float bound_r;
    uint64_t traced_seed;    /* render settings the sets were traced with      */
    int traced_depth;
    uint32_t dirty;          /* ML_DIRTY_* work an earlier update left undone  */
    volux_transfer_lut lut1; /* extinction without density scale (colour unused) */
    volux_majorant_grid grid1;
    float *decode;           /* τ1 code → exp(−ξ τ1)                           */
    ml_layout layout;
    volux_envmap_sampler *env; /* per light slot [env_cap]                  */
    int env_cap;
    ml_set *sets;              /* per light slot [sets_cap]                 */
    int sets_cap;
    ml_rvl *rvl;             /* set 0 (the interactive set)                    */
    int n_rvl, cap_rvl;
    /* Pass set k ≥ 1 (fresh VLs and AVSMs for the current scene, built by
     * begin_pass when a wave needs it; pass_k 0: none held) */
    ml_set *psets;           /* per light slot [psets_cap]                    */
    int psets_cap, pass_k;
    ml_rvl *prvl;
    int n_prvl, cap_prvl;
    const ml_rvl *draw;      /* what render_tile gathers: rvl or prvl          */
    int n_draw;
    int draw_stride;         /* every draw_stride-th of them (×draw_stride), from a random offset */
    int samples_now;         /* S of this wave                                 */
    /* statistics of the last update or step */
    double avsm_ms, trace_ms;
    int avsm_built, traced; /* AVSMs built, VLs traced */
    double pass_avsm_ms, pass_trace_ms; /* the last pass set's build */
    int pass_avsm_built;
} ml_state;

enum {
    ML_DIRTY_FULL = 1,   /* retrace every set and build every AVSM           */
    ML_DIRTY_PLACE = 2,  /* placement is stale: Eq. 6 now, replace later     */
};

/* vl.c */
/* Traces the light's stream of VL set `set_index` (0: the interactive set,
 * k ≥ 1: pass set k) from path *paths on, appending to *list until
 * it holds ≥ quota VLs (or the stream's path cap); *paths becomes the
 * stream paths started and every VL of the list gets 1/paths. */
volux_status ml_trace(const ml_state *st, const volux_prepared_light *l, int set_index, int quota, ml_list *list,
                      int *paths);
/* Every VL of a pure stream prefix gets 1/paths. */
void ml_set_paths(ml_list *list, int paths);
/* Eq. 6 preparation: τ1 and σ1 of every stored segment under the current
 * extinction (positions and sampling densities unchanged). */
void ml_retrace(const ml_state *st, ml_list *list);
/* The intensities I of every VL of a list (Eq. 6 weights with the current
 * colour, albedo, density scale, phase and light strength). */
void ml_weights(const ml_state *st, const volux_prepared_light *l, ml_list *list);
/* Emission scale of a light (colour × strength). */
volux_vec3 ml_light_scale(const volux_light_desc *d);
/* Unscaled extinction at a world point (0 outside the box). */
float ml_sigma1_at(const ml_state *st, volux_vec3 p, float *s_out);
/* ∫σ1 from o along unit d over [0, len] (fixed midpoint segments of the
 * shadow step from o, empty macrocells skipped; stops above tau_stop). */
float ml_tau1(const ml_state *st, volux_vec3 o, volux_vec3 d, float len, float tau_stop);

/* avsm.c */
void ml_layout_init(ml_layout *lay, int res, int nodes, float d_max);
/* Fills the decode table for density scale xi (ML_TAU_CODES entries). */
#define ML_TAU_CODES 0x7c00
void ml_decode_fill(float *decode, float xi);
uint16_t ml_tau_code(float tau);
float ml_tau_decode(uint16_t code);
/* Builds the AVSM of a VL at p, face f (res² texels × nodes words). */
void ml_avsm_build_face(const ml_state *st, volux_vec3 p, int face, uint32_t *out);
/* Look-ups: avsm.h. */
/* Ray-marched reference: exp(−ξ·τ1) from p to p + v. */
float ml_raymarch_T(const ml_state *st, volux_vec3 p, volux_vec3 v, float dist);

/* render.c */
/* Mean of 1/|x − y|² over a ball of radius r whose centre is d from x. */
float ml_ball_geometry(float d, float r);

/* One point y of a VSL's ball (radius r, centre d from x) for the `ball`
 * kernel: a direction uniform in the cone the ball subtends from x (the
 * whole sphere from inside), its cosine *ct to the axis x → centre from u,
 * and a distance *s uniform over the chord from w. Returns the weight
 * Ω·(s1 − s0)/V, whose mean over (u, w) is ml_ball_geometry(d, r): the
 * estimate of (1/V)∫_ball g(y)/|x − y|² dy is weight·g(y). */
static inline float ml_vsl_ball(float d, float r, float u, float w, float *ct, float *s) {
    float r2 = r * r, s0, s1, omega;
    if (d > r) {
        float sin2 = r2 / (d * d), omc = sin2 / (1.0f + sqrtf(1.0f - sin2));
        omega = 2.0f * VOLUX_PI * omc;
        *ct = 1.0f - u * omc;
        float sq = sqrtf(fmaxf(0.0f, r2 - d * d * (1.0f - *ct * *ct)));
        s0 = d * *ct - sq;
        s1 = d * *ct + sq;
    } else {
        omega = 4.0f * VOLUX_PI;
        *ct = 1.0f - 2.0f * u;
        s0 = 0.0f;
        s1 = d * *ct + sqrtf(fmaxf(0.0f, r2 - d * d * (1.0f - *ct * *ct)));
    }
    *s = s0 + w * (s1 - s0);
    return omega * (s1 - s0) / (4.0f / 3.0f * VOLUX_PI * r2 * r);
}
void ml_render_tile(const void *state, const volux_scene *scene, const volux_tile *tile, float *rgb,
                    volux_tile_stats *stats);

#endif
