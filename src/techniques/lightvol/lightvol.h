/*
 * techniques/lightvol/lightvol.h — `lightvol`: coherence-based light
 * propagation with selective light updates (Sundén & Ropinski 2015).
 *
 * One RGB illumination volume (optionally plus a luminance-weighted light
 * direction per voxel), stored as bfloat16 (core/bf16.h) until light
 * edits need float (`precision`, see lightvol_state.vol), holds the light that arrives at every voxel
 * from every light. Lights are grouped by the volume face their direction
 * best matches (§4); each group is propagated in one axis-aligned sweep with
 * a pair of 2-D slice buffers per light; an edit of one light subtracts its
 * old contribution and adds its new one (§5) instead of recomputing all.
 *
 * Caches and what invalidates them (see README.md for the full row):
 *   illumination volume ← volume, extinction, density, (colour if
 *                         forward_scattering > 0), scale/directional/
 *                         forward_scattering/scatter_cone params; lights
 *                         only selectively (cost rule of §5)
 *   medium grid (scale < 1), u8 class table ← volume, extinction, density, colour
 *   majorant grid ← volume, extinction, density; gradient cache ← volume
 *
 * Internal: shared by the technique's files and its tests.
 */
#ifndef VOLUX_LIGHTVOL_H
#define VOLUX_LIGHTVOL_H

#include <string.h>

#include "core/bf16.h"
#include "core/simd.h"
#include "render/lights.h"
#include "render/packet.h"
#include "render/raycaster.h"
#include "sample/gradient.h"

extern const volux_technique_class volux_lightvol_class;
/* The memory model (estimate.c, docs/SCALE.md). */
uint64_t volux_lightvol_estimate_bytes(const volux_scene *scene, const volux_technique_class *cls,
                                       uint64_t *volume_added);

/* Propagation groups g = 2·axis + (sign < 0): light travelling towards +x
 * is group 0, −x group 1, +y 2, −y 3, +z 4, −z 5. Group g sweeps slices
 * along its axis in its direction; light enters through the opposite face
 * (the face closest to the light). Same-axis groups are adjacent, so a
 * group-ordered plan processes them consecutively (§4). */
#define LV_GROUPS 6

static inline int lv_group(int axis, int sign) { return 2 * axis + (sign < 0); }

/*
 * Contribution factors (Eqs. 5a/5b, our continuous reading; see
 * docs/techniques/lightvol.md). For unit travel direction w with angles
 * β1 ≤ β2 ≤ β3 to the three principal axes (β_i = acos|w_i|):
 *     second-closest face α_sc = (β3 − β2) / (2β3 − β1 − β2)
 *     closest face        α_c  = 1 − α_sc
 * In a principal plane (β3 = 90°, β1 + β2 = 90°) this is exactly the paper's
 * α_cA = 1 − 2β1/π, α_scA = 1 − α_cA; unlike the literal Eq. 5a it stays
 * continuous when the second-closest face changes (β2 = β3 ⇒ α_sc = 0) and
 * when the closest and second-closest faces swap (β1 = β2 ⇒ ½, ½).
 * Writes the six factors (zero outside the two faces) and returns the
 * bitmask of groups with a positive factor.
 */
static inline unsigned lv_face_weights_raw(volux_vec3 w, float out[LV_GROUPS], int *g1_out, int *g2_out) {
    float c[3] = {w.x, w.y, w.z}, m[3] = {fabsf(w.x), fabsf(w.y), fabsf(w.z)};
    for (int g = 0; g < LV_GROUPS; g++) out[g] = 0.0f;
    /* axes by decreasing |component|; ties keep the lower axis first */
    int a1 = 0, a2 = 1, a3 = 2, t;
    if (m[a2] > m[a1]) t = a1, a1 = a2, a2 = t;
    if (m[a3] > m[a2]) t = a2, a2 = a3, a3 = t;
    if (m[a2] > m[a1]) t = a1, a1 = a2, a2 = t;
    float b1 = volux_acos01_deg7(m[a1]), b2 = volux_acos01_deg7(m[a2]), b3 = volux_acos01_deg7(m[a3]);
    float den = 2.0f * b3 - b1 - b2, w2;
    if (den > 1e-6f) w2 = (b3 - b2) / den;
    else w2 = 0.5f; /* w ∥ a cube diagonal: every choice is as good */
    if (!(m[a2] > 0.0f)) w2 = 0.0f;
    int g1 = lv_group(a1, c[a1] < 0.0f ? -1 : 1), g2 = lv_group(a2, c[a2] < 0.0f ? -1 : 1);
    out[g1] = 1.0f - w2;
    unsigned mask = 1u << g1;
    if (w2 > 0.0f) out[g2] = w2, mask |= 1u << g2;
    *g1_out = g1;
    *g2_out = g2;
    return mask;
}

/* Smallest second-closest factor that is propagated: below it the light is
 * carried by its closest group alone, so a light within ~1° of an axis (or a
 * distant point light straight above) costs one pass, not two or five. The
 * factor is remapped continuously, α' = ½·(α − ε)/(½ − ε) for α ≥ ε, 0
 * below, which keeps both boundaries seamless (α' = ½ at a swap, 0 where the
 * second face changes) and moves Eq. 5 by less than ε. */
#define LV_MIN_FACTOR 0.01f

static inline unsigned lv_face_weights(volux_vec3 w, float out[LV_GROUPS]) {
    int g1, g2;
    unsigned mask = lv_face_weights_raw(w, out, &g1, &g2);
    if (mask == (1u << g1)) return mask;
    float a = out[g2];
    a = a <= LV_MIN_FACTOR ? 0.0f : 0.5f * (a - LV_MIN_FACTOR) / (0.5f - LV_MIN_FACTOR);
    out[g2] = a;
    out[g1] = 1.0f - a;
    return a > 0.0f ? mask : 1u << g1;
}

/* Factor of the face of axis `a` (the face the light travels towards) for
 * the magnitudes m[3] of a unit direction. Same ordering (ties keep the
 * lower axis first) and arithmetic as lv_face_weights, so the factors of a
 * direction's faces sum to 1 exactly as there. */
static inline float lv_axis_weight(const float m[3], int a) {
    /* branch-free (selects only) so that row loops vectorise */
    const int b = a == 0 ? 1 : 0, c = a == 2 ? 1 : 2; /* the other axes, b < c */
    const float ma = m[a], mb = m[b], mc = m[c];
    int rank = (mb > ma || (mb == ma && b < a)) + (mc > ma || (mc == ma && c < a));
    /* the other two in the order lv_face_weights would sort them */
    float hi = mc > mb ? mc : mb, lo = mc > mb ? mb : mc;
    float ba = volux_acos01_deg7(ma), bh = volux_acos01_deg7(hi), bl = volux_acos01_deg7(lo);
    float b1 = rank == 0 ? ba : bh, b2 = rank == 0 ? bh : ba;
    float den = 2.0f * bl - b1 - b2;
    float q = (bl - b2) / (den > 1e-6f ? den : 1.0f);
    float w2 = den > 1e-6f ? q : 0.5f;
    w2 = (rank == 0 && !(hi > 0.0f)) ? 0.0f : w2;
    w2 = w2 <= LV_MIN_FACTOR ? 0.0f : 0.5f * (w2 - LV_MIN_FACTOR) / (0.5f - LV_MIN_FACTOR);
    float w = rank == 0 ? 1.0f - w2 : w2;
    return (rank == 2 || !(ma > 0.0f)) ? 0.0f : w;
}

/* Factor of group g only (0 if g is neither of the two closest faces). */
static inline float lv_face_weight(volux_vec3 w, int g) {
    float f[LV_GROUPS];
    lv_face_weights(w, f);
    return f[g];
}

/* ---------------------------------------------------------------- lights */

enum { LV_DIRECTIONAL = 0, LV_POSITIONAL = 1 };

/* The illumination volume's padding: values stored after its last
 * voxel, so that a 32-bit gather of the last value (the packet march reads
 * a bfloat16 as the low half of a 32-bit word) stays inside the block. */
#define LV_VOL_PAD 16

/* Environment lights as up to this many directional lights (env_directions:
 * the Fibonacci set of `single`, each with the radiance over its cell). */
#define LV_MAX_ENV_DIRS 256

/* A light reduced to what propagation needs (world units). */
typedef struct lv_source {
    int kind;               /* LV_DIRECTIONAL / LV_POSITIONAL             */
    int spot;
    volux_vec3 power;       /* directional: irradiance·color (W/m²);
                               positional: intensity·color (W/sr)         */
    volux_vec3 dir;         /* directional: unit travel direction;
                               spot: unit cone axis                       */
    volux_vec3 pos;         /* positional: world position                 */
    float cos_cone, cos_fall; /* spot cone (same smoothstep as core)      */
    float weight[LV_GROUPS];  /* directional, and positional when `center`:
                                 Eq. 5 factors                            */
    unsigned groups;        /* groups the light is propagated in          */
    int center;             /* positional: grouped by the light-to-centre
                               direction (§4; constant factors, ≤ 2
                               groups); 0: per voxel (up to six groups)  */
} lv_source;

/* One light added (+1) or removed (−1) by an update. */
typedef struct lv_item {
    lv_source src;
    float sign;
    int slot;               /* −1: an environment direction               */
} lv_item;

/* The light in a slot as last applied to the illumination volume, so that
 * an edit can remove exactly what was added (the scene only says which
 * slots changed): its description and what propagation derived from it.
 * Two states differ iff their sources differ (an edit of a field that does
 * not affect propagation, e.g. a point light's radius, costs nothing). */
typedef struct lv_applied {
    int active;             /* contributes to the volume as a light of its
                               own (an environment never does: it is in
                               env_E, see lightvol_state)                 */
    int env;                /* the slot holds an environment light        */
    volux_light_desc desc;  /* as applied (map pointer cleared)           */
    lv_source src;          /* derived; memset-clean, so memcmp compares  */
} lv_applied;

/* --------------------------------------------------------------- params */

enum { LV_KERNEL_AUTO, LV_KERNEL_SCALAR, LV_KERNEL_SIMD, LV_KERNEL_AVX2 };

enum { LV_RULE_WORK, LV_RULE_PASSES, LV_RULE_LIGHTS, LV_RULE_SELECTIVE, LV_RULE_FULL };

enum { LV_GROUP_VOXEL, LV_GROUP_CENTER };

typedef struct lv_params {
    float scale[3];         /* illumination resolution / data resolution  */
    int coherent;           /* 1 coherent groups, 0 one light per pass    */
    int cost_rule;          /* LV_RULE_*                                   */
    int max_per_pass;       /* lights per pass (slice-buffer memory cap)  */
    float forward;          /* forward-scattered fraction f ∈ [0,1]       */
    float cone_deg;         /* forward-scattering cone half-angle         */
    int directional;        /* store the mean light direction             */
    int precision_float;    /* precision "float": never bfloat16          */
    int rebaseline;         /* full rebuild after this many selective
                               updates (0 = never)                        */
    float local_shading;    /* weight of gradient Blinn–Phong             */
    float gradient_threshold;
    int preintegrate, skip_empty;
    float t_min;
    double rebuild_token;
    int kernel;             /* LV_KERNEL_*                                 */
    int grouping;           /* LV_GROUP_*: positional lights' groups      */
    float budget_ms;        /* §7.3: propagation per update / refine step
                               (0 = all at once)                          */
    int budget_slices;      /* ... as slice steps (deterministic; wins)   */
    int show_illumination;  /* render E itself (Fig. 4b), not radiance    */
    int env_dirs;           /* environment lights as this many directional
                               lights (0: ignored, with a warning)        */
} lv_params;

/* ---------------------------------------------------------------- state */

typedef enum lv_update_kind { LV_UPDATE_NONE, LV_UPDATE_SELECTIVE, LV_UPDATE_FULL } lv_update_kind;

typedef struct lv_stats {
    lv_update_kind last;       /* what the last light/full update did     */
    const char *reason;        /* why (static string)                      */
    int passes;                /* propagation sweeps it ran               */
    int entries;               /* light×group sweeps it ran                */
    int changed, total;        /* lights changed / lights in the setup    */
    int passes_selective, passes_full; /* the cost estimate (§5)          */
    double work_selective, work_full;  /* ... weighted by entry kind       */
    int selective_since_full;  /* selective updates since the last full   */
    uint64_t full_rebuilds, selective_updates;
} lv_stats;

/* Propagation in progress (§7.3's per-frame budget): the plan of one
 * update — selective or entire — run slice step by slice step, possibly
 * over several update/refine calls. Between calls the passes' slice
 * buffers and medium slices (the scratch) hold the sweep's state, so the
 * volume ends bit-identical to running the plan at once. `applied` is
 * already the plan's target; light edits meanwhile wait (`queued`) until
 * the plan is done, then the next plan takes the volume from `applied` to
 * the scene's lights. */
typedef struct lv_pass lv_pass;
typedef struct lv_job {
    int active;                /* a plan is being propagated              */
    int full;                  /* entire update: its first pass overwrites */
    int n, np;                 /* items, passes                            */
    lv_item *items;
    lv_pass *passes;
    int *idx;
    size_t items_bytes, passes_bytes, idx_bytes;
    int pass, step;            /* next pass and slice step                 */
    uint64_t left;             /* slice steps left in the plan             */
    uint64_t queued;           /* slice steps of the plan queued behind it */
    double ms_per_work;        /* measured rate for budget_ms (0: none yet) */
} lv_job;

typedef struct lightvol_state {
    volux_raycaster rc;            /* base: volume, LUT, grid, camera, step,
                                      seed, g, albedo, material, threads  */
    volux_gradient_cache grad;
    lv_params p;
    int use_simd;                  /* resolved kernel: AVX2 row kernels      */
    int use_avx512;                /* ... and AVX-512 directional steps       */
    float grad_ref;

    /* illumination grid: node (i,j,k) at lo + (i,j,k)·spacing; node-centred
     * like the data and spanning the same box */
    int dims[3];
    float spacing[3];
    volux_vec3 lo;
    float data_to_ill[3];          /* (m−1)/(n−1) per axis                  */
    int ch;                        /* 3: RGB; 6: RGB + Σ lum·direction      */
    /* The volume in one of two precisions (the other pointer is NULL):
     * bfloat16 (core/bf16.h, + LV_VOL_PAD zeros) after an entire update
     * with `precision: "auto"`, half the bytes of float; float once a
     * selective update is due (or with `precision: "float"`), because
     * selective updates add and subtract into the stored sums and at 8
     * significant bits a small change vanishes in a large sum and the
     * rounding of a removed light's share stays (measured: 31 % of the
     * maximum after 250 random edits). Read with lv_vol_get. */
    uint16_t *vol;
    float *volf;
    size_t vol_bytes;

    /* medium seen by the sweeps. On the data grid it is post-classified:
     * slices hold scalar values, every medium sample interpolates the scalar
     * and looks σt, σs up in the TF table (as the camera ray and pathtrace
     * do); on a coarser grid it is the box mean of σt and σs. */
    int on_grid;                   /* 1: illumination nodes = data nodes    */
    int *lut_nz;                   /* prefix counts of TF entries with σt > 0 */
    size_t lut_nz_bytes;
    float *medium;                 /* scale < 1: 4 floats per node (box means) */
    size_t medium_bytes;
    float class_u8[256 * 4];       /* u8 storage: σt, σs rgb per value      */
    int have_u8;

    /* propagation scratch, kept between updates (grown on demand) */
    float *slices;                 /* cap × 2 buffers × 3 planes × area     */
    size_t slices_bytes;
    int slice_cap;
    size_t area;                   /* largest slice area                    */
    float *med;                    /* 2 slices × 4 planes × area            */
    size_t med_bytes;
    float *rows;                   /* per thread row scratch                */
    size_t rows_bytes;
    float *stage;                  /* x sweeps: staged slices (see sweep.c) */
    size_t stage_bytes;
    int rows_threads;
    size_t row_stride;

    lv_applied *applied;           /* per light slot [applied_cap]          */
    int applied_cap;
    /* the scene's environment lights as p.env_dirs directional lights,
     * travelling −volux_fibonacci_dir(k, K), each with the irradiance of its
     * cell summed over the environments — as applied to the volume. The
     * directions are fixed, so an environment edit (rotation, intensity,
     * map) only changes these irradiances and is propagated as their
     * differences, one entry per direction. */
    volux_vec3 env_E[LV_MAX_ENV_DIRS];
    /* their cell integrals, memoised (render/lights.h): an update that
     * re-derives the environment without changing its map, rotation or
     * env_dirs does not integrate the map again */
    volux_env_cells_cache env_cells;
    int valid;                     /* the volume matches `applied` once the
                                      job (if any) has run                 */
    lv_job job;
    double frame_budget_ms;        /* volux_technique_set_budget (0: the
                                      scene's budget_ms / budget_slices)  */
    lv_stats stats;
    /* the camera march (march_kernel): 0 scalar volux_ea_march, else the
     * packet march's lanes (8/16, march_avx2.c / march_avx512.c) and its
     * tables */
    int march_lanes;
    volux_packet_tables pk;
} lightvol_state;

/* The camera march as packets (march_lanes.h); the same contract as a
 * tile renderer. */
void volux_lightvol_march_avx2(const volux_packet_march *pm, const void *tech, const volux_scene *scene,
                               const volux_tile *tile, float *rgb, volux_tile_stats *stats);
void volux_lightvol_march_avx512(const volux_packet_march *pm, const void *tech, const volux_scene *scene,
                                 const volux_tile *tile, float *rgb, volux_tile_stats *stats);
/* The scalar march's shading (shade_at) of one packet lane: the hook of
 * the lanes that keep it (local shading, show: "illumination"). */
void volux_lightvol_shade_lane(const void *tech, const volux_packet_lane *in, float c[3]);

/* Value i of the illumination volume, whichever its precision. */
static inline float lv_vol_get(const lightvol_state *st, size_t i) {
    return st->volf ? st->volf[i] : volux_bf16_to_float(st->vol[i]);
}

/* The budget in force: the front end's per-frame budget when set (it wins
 * over the scene's), else budget_slices (wins) or budget_ms; *slices and
 * *ms are 0 when that kind is not in force. 1 if any budget is. */
static inline int lv_budget(const lightvol_state *st, int *slices, double *ms) {
    *slices = st->frame_budget_ms > 0.0 ? 0 : st->p.budget_slices;
    *ms = st->frame_budget_ms > 0.0 ? st->frame_budget_ms : *slices > 0 ? 0.0 : (double)st->p.budget_ms;
    return *slices > 0 || *ms > 0.0;
}

/* propagation (buffers.c, medium.c, sources.c, update.c; the files and
 * their internal interface: sweep.h) */
volux_status volux_lightvol_alloc(lightvol_state *st);
volux_status volux_lightvol_build_medium(lightvol_state *st);
/* Brings the volume up to date with the scene's lights. `force_full`
 * rebuilds everything; otherwise the lights whose slots are set in `c` are
 * updated selectively or fully per the cost rule (§5). */
volux_status volux_lightvol_update_lights(lightvol_state *st, const volux_scene *scene, const volux_change_set *c,
                                          int force_full, const char *reason);
/* One budget of the propagation in progress (all of it when no budget is
 * set), starting the queued plan when the current one ends; *did is set
 * when the volume changed. */
volux_status volux_lightvol_continue(lightvol_state *st, const volux_scene *scene, int *did);
/* Slice steps of propagation still to run (current and queued plan). */
uint64_t volux_lightvol_pending(const lightvol_state *st);
/* Drops the propagation in progress (the volume is then invalid). */
void volux_lightvol_drop_job(lightvol_state *st);
/* Fills src from a light; returns 0 if the light does not take part in
 * propagation (disabled, environment, zero power). */
int volux_lightvol_source(const lightvol_state *st, const volux_light_desc *d, lv_source *src);
/* Environment direction k of the p.env_dirs as a directional source of
 * irradiance `power` (which may be a difference of two, negative). */
void volux_lightvol_env_source(const lightvol_state *st, int k, volux_vec3 power, lv_source *src);
/* The scene's enabled environment lights integrated into the p.env_dirs
 * directions' cells (E[0..env_dirs) overwritten). */
void volux_lightvol_env_irradiance(const lightvol_state *st, volux_env_cells_cache *cells, const volux_scene *scene,
                                   volux_vec3 *E);
/* Unoccluded value a light sends to world point p: directional E0,
 * positional I·cone(θ)/max(r², r_min²) (rgb). */
void volux_lightvol_unoccluded(const lightvol_state *st, const lv_source *s, volux_vec3 p, float out[3]);
size_t volux_lightvol_scratch_bytes(const lightvol_state *st);
/* The volume from bfloat16 to float (values kept: a budgeted update that
 * follows shows them until it overwrites them); no-op when float. */
volux_status volux_lightvol_promote(lightvol_state *st);
void volux_lightvol_free_buffers(lightvol_state *st);

#endif
