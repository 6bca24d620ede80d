/*
 * techniques/manylights/manylights.c — the `manylights` class: parameters,
 * the mapping from edits to work, and the progressive replacement of
 * virtual lights (W13 §4–5).
 *
 * Edit → work (least first):
 *   camera, background, step          nothing (image only)
 *   light i colour / strength         weights only (VLs carry the emission
 *                                     per unit strength)
 *   colour curve, albedo              weights only (VL positions do not
 *                                     depend on colour: fixed-probability
 *                                     Russian roulette)
 *   density scale                     weights + the τ1 → T table (W13 §5.1:
 *                                     every AVSM rescaled at once); with the
 *                                     Eq. 8 placement that is all, else as
 *                                     extinction
 *   phase (g)                         weights; with HG sampling also as
 *                                     extinction (§5.2: isotropic sampling
 *                                     keeps positions)
 *   extinction curve                  §4: Eq. 6 now (every stored segment's
 *                                     τ1 and σ1 re-marched, weights), AVSMs
 *                                     kept; then `update_budget` VLs per
 *                                     frame replaced by the new subpaths
 *                                     with new AVSMs (rules 1 and 2)
 *   light i moved / added / removed   light i's subpaths and AVSMs; other
 *                                     lights only if their share of
 *                                     vl_count changes (whole subpaths
 *                                     added or dropped at the end)
 *   volume, seed, max_depth,          everything
 *   placement parameters
 *
 * Deferred work (volux/technique.h): while a light's set is being
 * replaced, pending() counts its VLs not yet replaced (+1 for the final
 * swap) and each refine() step — one per frame, called by the front end
 * between frames — moves whole new subpaths in (at least `update_budget`
 * VLs over all lights, in slot order) and the same number of the oldest
 * VLs out. After the last step every set is the
 * prefix of its stream a fresh instance traces, with AVSMs built for the
 * current scene: the image is bit-identical to a fresh create.
 */
#include <math.h>
#include <string.h>
#include <time.h>

#include "core/context_internal.h"
#include "core/parallel.h"
#include "core/rng.h"
#include "manylights.h"
#include "sample/sampler.h"

static const volux_param_info ml_params[] = {
    {"vl_count", VOLUX_PARAM_INT, 256, 1, 1000000, NULL,
     "virtual lights per VL set, split evenly between the enabled lights; each traces whole light subpaths until it "
     "holds its share (W13 §3.1). With passes_per_set 1 every pixel sample has its own set: n spp average n sets"},
    {"vsl_radius", VOLUX_PARAM_NUMBER, 0, 0, 10000, NULL,
     "radius of a virtual spherical light in units of the smallest voxel spacing (Eq. 5; bounds the geometry term "
     "by 2/r^2); 0: automatic, half the mean distance between VLs spread over the non-empty macrocells"},
    {"vsl_kernel", VOLUX_PARAM_STRING, 0, 0, 0, "ball",
     "a VSL's light: \"ball\" (the VL's power spread over the ball: one point of it per VL and view sample, "
     "transmittance along the VL's radial ray from that point's projection to x; keeps the energy) or \"cone\" "
     "(W13 Eq. 5: 1/(pi r^2 p(Omega)) = 2(1 - cos theta_max)/r^2 with the transmittance to the centre, the "
     "hemisphere inside the sphere; loses what a VL sends within a few radii: 0.50-0.80 of pathtrace's brightness "
     "on aneurism, engine, bonsai)"},
    {"clamp_distance", VOLUX_PARAM_NUMBER, 0, 0, 10000, NULL,
     "clamping: a VL adds at most what an isotropic point light adds at this distance (voxels), i.e. "
     "f_j*f_t*G <= 1/(16 pi^2 d^2); bounds the splotches of peaked phase functions that VSLs do not (0 = off)"},
    {"samples", VOLUX_PARAM_INT, 4, 1, 1024, NULL,
     "S: positions per view ray (per pixel sample) where real and virtual lights are gathered (Eq. 5)"},
    {"view_sampling", VOLUX_PARAM_STRING, 0, 0, 0, "opacity",
     "\"opacity\": the S positions stratified in the camera ray's opacity (pdf proportional to T*sigma_t); "
     "\"uniform\": uniform over the ray's non-empty extent (W13 §3.3)"},
    {"transmittance", VOLUX_PARAM_STRING, 0, 0, 0, "avsm",
     "VL-to-point transmittance: \"avsm\" (nearest texel, linear in depth), \"avsm_linear\" (trilinear: bilinear "
     "over the face, linear in depth), \"raymarch\" (the reference: marched per look-up along the path the "
     "cache stores — for the ball kernel the VL's radial ray between x and the ball point's projection)"},
    {"avsm_resolution", VOLUX_PARAM_INT, 16, 1, 512, NULL,
     "AVSM texels per cube-face side (W13: 40-48; 16 with footprint steps: 10x cheaper per VL than 40 with voxel "
     "steps, 1.2 % vs 0.7 % image difference to ray-marched transmittance on bonsai)"},
    {"avsm_nodes", VOLUX_PARAM_INT, 8, 2, ML_MAX_NODES, NULL, "AVSM nodes m per texel (W13: 8-12)"},
    {"single_scattering", VOLUX_PARAM_BOOL, 1, 0, 1, NULL,
     "single scattering from the real lights (ray-marched shadow rays; W13 Fig. 1a)"},
    {"multiple_scattering", VOLUX_PARAM_BOOL, 1, 0, 1, NULL, "light of the virtual lights (W13 Fig. 1b)"},
    {"passes_per_set", VOLUX_PARAM_INT, 1, 0, 1000000, NULL,
     "a fresh VL set (new light subpaths, new AVSMs) every this many pixel samples: sample p gathers from set "
     "floor(p / passes_per_set), so the accumulated image averages ever more independent sets and converges to the "
     "VSL model instead of one set's blotches; 0: set 0 only (W13: one set, re-weighted and replaced on edits)"},
    {"preview_vls", VOLUX_PARAM_INT, 32, 0, 1000000, NULL,
     "the first pixel sample of an accumulation (a fresh create's or an edit's first image) gathers from about this "
     "many VLs of set 0 — every k-th from a random offset per view sample, weighted k, so it is still unbiased — "
     "with preview_samples view samples: a fast, noisier first frame; later samples use all (0 = off)"},
    {"preview_samples", VOLUX_PARAM_INT, 1, 1, 1024, NULL, "S of the first pixel sample when preview_vls is on"},
    {"eq6_bound", VOLUX_PARAM_NUMBER, 4, 0, 1e30, NULL,
     "after an extinction edit, a re-weighted (Eq. 6) path segment carries at most this many times the weight it "
     "had in the medium it was sampled in, so stale VLs whose density rose sharply do not flash (0 = unbounded)"},
    {"avsm_cone", VOLUX_PARAM_NUMBER, 1, 0, 100, NULL,
     "AVSM texel rays step max(shadow_step, avsm_cone * texel width at that distance): the march follows the "
     "texel's footprint, so far texels cost a few samples (0: shadow_step throughout)"},
    {"update_budget", VOLUX_PARAM_INT, 100, 1, 100000000, NULL,
     "VLs (whole subpaths, at least this many) replaced per frame after an extinction edit (W13 §4.2)"},
    {"density_min", VOLUX_PARAM_NUMBER, 0.5, 0, 10000, NULL,
     "S_min of Eq. 8: VLs are placed by the mean transmittance over density scales [density_min, density_max], so "
     "density edits in that range only re-weight; 0 (either): placed for the current density scale"},
    {"density_max", VOLUX_PARAM_NUMBER, 2, 0, 10000, NULL, "S_max of Eq. 8 (see density_min)"},
    {"phase_sampling", VOLUX_PARAM_STRING, 0, 0, 0, "hg",
     "continuation directions of light subpaths: \"hg\" (importance sampling, W13 §3.1) or \"isotropic\" (§5.2: "
     "positions independent of g, so phase edits only re-weight)"},
    {"rr_survival", VOLUX_PARAM_NUMBER, 0.75, 0.05, 1, NULL,
     "Russian roulette: probability that a light subpath continues after a vertex (1 = only max_depth ends it)"},
    {"shadow_step", VOLUX_PARAM_NUMBER, 1, 0.05, 16, NULL,
     "step of every transmittance march (shadow rays, AVSM rays, subpath segments) in units of the smallest voxel "
     "spacing"},
    VOLUX_PARAM_EARLY_TERMINATION,
    {"sampler", VOLUX_PARAM_STRING, 0, 0, 0, "independent",
     "camera-side numbers (pixel position, march jitter, the first 8 view samples' offsets, light and VL-pattern "
     "draws): \"independent\" random numbers or \"sobol\" padded Owen-scrambled Sobol pairs (Burley 2020; not "
     "measured better here: the VL sets dominate the noise)"},
    {NULL, 0, 0, 0, 0, NULL, NULL}};

static double now_ms(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

/* ------------------------------------------------------------------ parameters */

static volux_status read_params(ml_state *st, const volux_scene *scene) {
    const volux_technique_class *cls = &volux_manylights_class;
    volux_context *ctx = st->rc.ctx;
    const char *tm = volux_technique_param_string(scene, cls, "transmittance");
    int tmode = !strcmp(tm, "avsm") ? ML_T_AVSM
                : !strcmp(tm, "avsm_linear") ? ML_T_AVSM_LINEAR
                : !strcmp(tm, "raymarch") ? ML_T_RAYMARCH
                                          : -1;
    if (tmode < 0)
        return volux_error(ctx, VOLUX_ERR_INVALID,
                           "techniques.manylights.transmittance: expected \"avsm\", \"avsm_linear\" or \"raymarch\", "
                           "got \"%s\"",
                           tm);
    const char *vs = volux_technique_param_string(scene, cls, "view_sampling");
    if (strcmp(vs, "opacity") != 0 && strcmp(vs, "uniform") != 0)
        return volux_error(ctx, VOLUX_ERR_INVALID,
                           "techniques.manylights.view_sampling: expected \"opacity\" or \"uniform\", got \"%s\"", vs);
    const char *ps = volux_technique_param_string(scene, cls, "phase_sampling");
    if (strcmp(ps, "hg") != 0 && strcmp(ps, "isotropic") != 0)
        return volux_error(ctx, VOLUX_ERR_INVALID,
                           "techniques.manylights.phase_sampling: expected \"hg\" or \"isotropic\", got \"%s\"", ps);
    const char *vk = volux_technique_param_string(scene, cls, "vsl_kernel");
    if (strcmp(vk, "cone") != 0 && strcmp(vk, "ball") != 0)
        return volux_error(ctx, VOLUX_ERR_INVALID,
                           "techniques.manylights.vsl_kernel: expected \"cone\" or \"ball\", got \"%s\"", vk);
    const char *sm = volux_technique_param_string(scene, cls, "sampler");
    int sampler = volux_sampler_parse(sm);
    if (sampler < 0)
        return volux_error(ctx, VOLUX_ERR_INVALID,
                           "techniques.manylights.sampler: expected \"sobol\" or \"independent\", got \"%s\"", sm);
    st->sampler = sampler;
    float dmin = (float)volux_technique_param(scene, cls, "density_min");
    float dmax = (float)volux_technique_param(scene, cls, "density_max");
    if (dmin > 0.0f && dmax > 0.0f && dmin > dmax)
        return volux_error(ctx, VOLUX_ERR_INVALID,
                           "techniques.manylights.density_min: %g is above density_max %g", dmin, dmax);
    int samples = (int)volux_technique_param(scene, cls, "samples");
    int res = (int)volux_technique_param(scene, cls, "avsm_resolution");
    int nodes = (int)volux_technique_param(scene, cls, "avsm_nodes");
    int iso = !strcmp(ps, "isotropic");
    float rr = (float)volux_technique_param(scene, cls, "rr_survival");
    float shadow = (float)volux_technique_param(scene, cls, "shadow_step");
    /* What moves VLs or changes their AVSMs rebuilds everything. */
    if (res != st->avsm_res || nodes != st->avsm_nodes || iso != st->iso_phase || rr != st->rr_survival ||
        shadow != st->shadow_vox || dmin != st->dmin || dmax != st->dmax)
        st->dirty |= ML_DIRTY_FULL;
    st->tmode = tmode;
    st->view_uniform = !strcmp(vs, "uniform");
    st->ball = !strcmp(vk, "ball");
    st->iso_phase = iso;
    st->dmin = dmin;
    st->dmax = dmax;
    st->place_by_xi = !(dmin > 0.0f && dmax > 0.0f);
    st->samples = st->samples_now = samples;
    st->avsm_res = res;
    st->avsm_nodes = nodes;
    st->rr_survival = rr;
    st->shadow_vox = shadow;
    st->vl_count = (int)volux_technique_param(scene, cls, "vl_count");
    st->radius_vox = (float)volux_technique_param(scene, cls, "vsl_radius");
    st->clamp_vox = (float)volux_technique_param(scene, cls, "clamp_distance");
    st->single_on = volux_technique_param(scene, cls, "single_scattering") != 0.0;
    st->multi_on = volux_technique_param(scene, cls, "multiple_scattering") != 0.0;
    st->budget = (int)volux_technique_param(scene, cls, "update_budget");
    st->passes_per_set = (int)volux_technique_param(scene, cls, "passes_per_set");
    st->preview_vls = (int)volux_technique_param(scene, cls, "preview_vls");
    st->preview_samples = (int)volux_technique_param(scene, cls, "preview_samples");
    {
        double b = volux_technique_param(scene, cls, "eq6_bound");
        st->eq6_log_bound = b > 0.0 ? (float)log(b) : INFINITY;
    }
    float cone = (float)volux_technique_param(scene, cls, "avsm_cone");
    if (cone != st->avsm_cone) st->dirty |= ML_DIRTY_FULL;
    st->avsm_cone = cone;
    st->t_min = (float)volux_technique_param(scene, cls, "early_termination");
    return VOLUX_OK;
}

/* ------------------------------------------------------------------ sets */

static void list_free(volux_context *ctx, ml_list *l) {
    volux_free(ctx, l->v, sizeof *l->v * (size_t)l->cap);
    memset(l, 0, sizeof *l);
}

static volux_status list_reserve(volux_context *ctx, ml_list *l, int need) {
    if (need <= l->cap) return VOLUX_OK;
    ml_vl *v = volux_realloc(ctx, l->v, sizeof *v * (size_t)l->cap, sizeof *v * (size_t)need);
    if (!v) return volux_error(ctx, VOLUX_ERR_NOMEM, "manylights: out of memory for %d virtual lights", need);
    l->v = v;
    l->cap = need;
    return VOLUX_OK;
}

static void set_free(ml_state *st, ml_set *set) {
    volux_context *ctx = st->rc.ctx;
    list_free(ctx, &set->cur);
    list_free(ctx, &set->next);
    volux_free(ctx, set->pool, set->pool_size);
    volux_free(ctx, set->free_slots, sizeof(int) * (size_t)set->pool_cap);
    memset(set, 0, sizeof *set);
}

/* Grows the set's AVSM pool to hold `cap` maps (contents kept; new slots
 * go on the free stack). On failure the set is as it was (the pool may be
 * larger). */
static volux_status pool_reserve(ml_state *st, ml_set *set, int cap) {
    volux_context *ctx = st->rc.ctx;
    if (cap <= set->pool_cap) return VOLUX_OK;
    size_t bytes;
    if (!volux_mul_size((size_t)cap, st->layout.stride * sizeof(uint32_t), &bytes))
        return volux_error(ctx, VOLUX_ERR_LIMIT, "manylights: %d AVSMs do not fit in memory", cap);
    if (bytes > set->pool_size) {
        uint32_t *pool = volux_realloc(ctx, set->pool, set->pool_size, bytes);
        if (!pool)
            return volux_error(ctx, VOLUX_ERR_NOMEM, "manylights: out of memory (%zu bytes) for %d AVSMs", bytes, cap);
        set->pool = pool;
        set->pool_size = bytes;
    }
    int *fs = volux_realloc(ctx, set->free_slots, sizeof(int) * (size_t)set->pool_cap, sizeof(int) * (size_t)cap);
    if (!fs) return volux_error(ctx, VOLUX_ERR_NOMEM, "manylights: out of memory for %d AVSM slots", cap);
    set->free_slots = fs;
    for (int s = cap - 1; s >= set->pool_cap; s--) set->free_slots[set->n_free++] = s;
    set->pool_cap = cap;
    return VOLUX_OK;
}

/* ------------------------------------------------------------------ AVSM builds */

typedef struct avsm_job {
    const ml_state *st;
    const ml_vl *v;
    uint32_t *pool;
} avsm_job;

static void avsm_item(void *user, int64_t i, int thread) {
    (void)thread;
    const avsm_job *job = user;
    const ml_vl *v = &job->v[i / 6];
    const ml_layout *lay = &job->st->layout;
    int face = (int)(i % 6);
    uint32_t *dst = job->pool + (size_t)v->slot * lay->stride + (size_t)face * lay->stride / 6;
    ml_avsm_build_face(job->st, v->pos, face, dst);
}

/* AVSMs of v[0, n) (their slots assigned), one item per cube face. */
static void build_avsms(ml_state *st, ml_set *set, const ml_vl *v, int n) {
    if (n <= 0) return;
    double t0 = now_ms();
    avsm_job job = {st, v, set->pool};
    volux_parallel_for(st->rc.threads, 6 * (int64_t)n, avsm_item, &job);
    st->avsm_ms += now_ms() - t0;
    st->avsm_built += n;
}

static void assign_slots(ml_set *set, ml_vl *v, int n) {
    for (int i = 0; i < n; i++) v[i].slot = set->free_slots[--set->n_free];
}

static void release_slots(ml_set *set, const ml_vl *v, int n) {
    for (int i = 0; i < n; i++)
        if (v[i].slot >= 0) set->free_slots[set->n_free++] = v[i].slot;
}

/* End (exclusive) of the subpath that starts at record i. */
static int path_end(const ml_list *l, int i) {
    int e = i + 1;
    while (e < l->n && l->v[e].depth > 1) e++;
    return e;
}

/* ------------------------------------------------------------------ set operations */

static volux_status trace_timed(ml_state *st, const volux_prepared_light *l, int set_index, int quota, ml_list *list,
                                int *paths) {
    double t0 = now_ms();
    int before = list->n;
    volux_status s = ml_trace(st, l, set_index, quota, list, paths);
    st->trace_ms += now_ms() - t0;
    st->traced += list->n - before;
    return s;
}

/* The light's set from scratch: the stream prefix and every AVSM. */
static volux_status trace_fresh(ml_state *st, ml_set *set, const volux_prepared_light *l, int set_index, int quota) {
    volux_context *ctx = st->rc.ctx;
    ml_list list = {0};
    int paths = 0;
    volux_status s = trace_timed(st, l, set_index, quota, &list, &paths);
    ml_set fresh = {0};
    if (!s) s = pool_reserve(st, &fresh, list.n);
    if (s) {
        list_free(ctx, &list);
        set_free(st, &fresh);
        return s;
    }
    assign_slots(&fresh, list.v, list.n);
    build_avsms(st, &fresh, list.v, list.n);
    set_free(st, set);
    *set = fresh;
    set->cur = list;
    set->paths = paths;
    set->active = 1;
    set->quota = quota;
    return VOLUX_OK;
}

/* A replacement in progress becomes the current list, oldest first:
 * cur[front, n) then next[0, added) (whole subpaths, slots kept). */
static volux_status materialize(ml_state *st, ml_set *set) {
    if (!set->replacing) return VOLUX_OK;
    int keep = set->cur.n - set->front, n = keep + set->added;
    volux_status s = list_reserve(st->rc.ctx, &set->cur, n);
    if (s) return s;
    memmove(set->cur.v, set->cur.v + set->front, sizeof *set->cur.v * (size_t)keep);
    memcpy(set->cur.v + keep, set->next.v, sizeof *set->cur.v * (size_t)set->added);
    set->cur.n = n;
    set->next.n = 0;
    set->replacing = set->front = set->added = set->removed = 0;
    return VOLUX_OK;
}

/* W13 §4: the current VLs keep positions and AVSMs and get Eq. 6 weights
 * for the new medium; the new subpaths go to `next` for refine(). */
static volux_status begin_replacement(ml_state *st, ml_set *set, const volux_prepared_light *l, int quota) {
    volux_status s = materialize(st, set);
    if (s) return s;
    ml_retrace(st, &set->cur);
    set->next.n = 0;
    set->npaths = 0;
    if ((s = trace_timed(st, l, 0, quota, &set->next, &set->npaths))) return s;
    int need = set->cur.n > set->next.n ? set->cur.n : set->next.n;
    if ((s = pool_reserve(st, set, need))) return s;
    set->replacing = 1;
    set->front = set->added = set->removed = 0;
    set->quota = quota;
    return VOLUX_OK;
}

/* A new share of vl_count: whole subpaths of the stream dropped from the
 * end or traced on (with their AVSMs), so the set is again the prefix a
 * fresh trace holds. */
static volux_status requota(ml_state *st, ml_set *set, const volux_prepared_light *l, int quota) {
    volux_context *ctx = st->rc.ctx;
    volux_status s;
    if (set->replacing) {
        /* next is a stream prefix too: re-trace it for the new share and
         * keep the slots of the part already shown */
        ml_list nl = {0};
        int np = 0;
        if ((s = trace_timed(st, l, 0, quota, &nl, &np))) {
            list_free(ctx, &nl);
            return s;
        }
        int need = set->cur.n > nl.n ? set->cur.n : nl.n;
        if ((s = pool_reserve(st, set, need))) {
            list_free(ctx, &nl);
            return s;
        }
        int keep = set->added < nl.n ? set->added : nl.n;
        for (int i = 0; i < keep; i++) nl.v[i].slot = set->next.v[i].slot;
        release_slots(set, set->next.v + keep, set->added - keep);
        list_free(ctx, &set->next);
        set->next = nl;
        set->npaths = np;
        set->added = keep;
        set->quota = quota;
        return VOLUX_OK;
    }
    ml_list *cur = &set->cur;
    if (cur->n >= quota) {
        /* the shortest prefix of whole subpaths holding the quota */
        int e = 0;
        while (e < cur->n && e < quota) e = path_end(cur, e);
        release_slots(set, cur->v + e, cur->n - e);
        cur->n = e;
        set->paths = e > 0 ? cur->v[e - 1].path + 1 : 0;
        ml_set_paths(cur, set->paths);
    } else {
        int old_n = cur->n, old_paths = set->paths;
        if ((s = trace_timed(st, l, 0, quota, cur, &set->paths)) || (s = pool_reserve(st, set, cur->n))) {
            /* back to the old prefix: the retry traces the same paths */
            cur->n = old_n;
            set->paths = old_paths;
            ml_set_paths(cur, old_paths);
            return s;
        }
        assign_slots(set, cur->v + old_n, cur->n - old_n);
        build_avsms(st, set, cur->v + old_n, cur->n - old_n);
    }
    set->quota = quota;
    return VOLUX_OK;
}

/* FNV-1a over an environment map's size and texels: a light edit that
 * changes only colour or strength keeps the map, but the scene stores a
 * fresh copy on every edit, so the pointer cannot tell. */
static uint64_t map_hash(const volux_light_desc *d) {
    if (!d->map) return 0;
    uint64_t h = 0xcbf29ce484222325ull;
    int dims[2] = {d->map->width, d->map->height};
    const unsigned char *p = (const unsigned char *)dims;
    for (size_t i = 0; i < sizeof dims; i++) h = (h ^ p[i]) * 0x100000001b3ull;
    p = (const unsigned char *)d->map->rgb;
    size_t n = 3 * sizeof(float) * (size_t)d->map->width * (size_t)d->map->height;
    for (size_t i = 0; i < n; i++) h = (h ^ p[i]) * 0x100000001b3ull;
    return h | 1; /* never 0, the "no map" value */
}

static int v3_eq(volux_vec3 a, volux_vec3 b) { return a.x == b.x && a.y == b.y && a.z == b.z; }

/* 1 if the light emits from elsewhere or elsewhere to (anything but its
 * colour, strength, visibility). */
static int light_moved(const volux_light_desc *a, uint64_t ha, const volux_light_desc *b, uint64_t hb) {
    return a->type != b->type || !v3_eq(a->direction, b->direction) || !v3_eq(a->position, b->position) ||
           a->radius != b->radius || a->cone_angle_deg != b->cone_angle_deg ||
           a->falloff_angle_deg != b->falloff_angle_deg || a->rotation_y_deg != b->rotation_y_deg || ha != hb;
}

static volux_status update_sets(ml_state *st, const volux_scene *scene, const volux_change_set *c) {
    const volux_light_list *ll = &st->rc.lights;
    int n = ll->n_all;
    volux_status g = volux_grow_slots(st->rc.ctx, &st->sets, &st->sets_cap, volux_scene_light_slots(scene),
                                      sizeof *st->sets, "manylights: per-light VL sets");
    if (g) return g;
    /* drop the sets of slots without an enabled light (ll->all is in slot
     * order: one merge pass) */
    for (int slot = 0, i = 0; slot < st->sets_cap; slot++) {
        while (i < n && ll->all[i].slot < slot) i++;
        if (st->sets[slot].active && !(i < n && ll->all[i].slot == slot)) set_free(st, &st->sets[slot]);
    }
    for (int i = 0; i < n; i++) {
        const volux_prepared_light *l = &ll->all[i];
        ml_set *set = &st->sets[l->slot];
        int quota = st->vl_count / n + (i < st->vl_count % n);
        uint64_t hash = set->map_hash;
        if (!set->active || volux_change_light(c, l->slot)) hash = map_hash(l->desc);
        volux_status s = VOLUX_OK;
        if (!set->active || (st->dirty & ML_DIRTY_FULL) || light_moved(&set->desc, set->map_hash, l->desc, hash))
            s = trace_fresh(st, set, l, 0, quota);
        else if (st->dirty & ML_DIRTY_PLACE)
            s = begin_replacement(st, set, l, quota);
        else if (quota != set->quota)
            s = requota(st, set, l, quota);
        if (s) return s;
        /* committed only now: a failed update is retried from here */
        set->desc = *l->desc;
        set->desc.map = NULL;
        set->map_hash = hash;
    }
    st->dirty &= ~(uint32_t)(ML_DIRTY_FULL | ML_DIRTY_PLACE);
    return VOLUX_OK;
}

/* ------------------------------------------------------------------ what the renderer reads */

static int display_bound(const ml_state *st) {
    int bound = 0;
    for (int slot = 0; slot < st->sets_cap; slot++) {
        const ml_set *set = &st->sets[slot];
        if (!set->active) continue;
        bound += set->replacing && set->next.n > set->cur.n ? set->next.n : set->cur.n;
    }
    return bound;
}

static void rvl_fill(const ml_state *st, ml_rvl *r, const ml_vl *v, const ml_set *set, int light_slot, int set_index) {
    r->px = v->pos.x, r->py = v->pos.y, r->pz = v->pos.z;
    r->wx = v->w.x, r->wy = v->w.y, r->wz = v->w.z;
    r->ir = v->I.x, r->ig = v->I.y, r->ib = v->I.z;
    /* the VL's cone-sample pattern: a pure function of its stream identity */
    volux_rng rng = volux_rng_make(st->rc.seed ^ 0x76736c70617474ull, (uint64_t)light_slot, (uint64_t)v->path,
                                   16 + (uint64_t)v->depth + ((uint64_t)set_index << 8));
    r->cone_u = volux_rng_float(&rng);
    float phi = 2.0f * VOLUX_PI * volux_rng_float(&rng);
    r->cone_c = cosf(phi);
    r->cone_s = sinf(phi);
    r->cone_w = volux_rng_float(&rng);
    r->avsm = set->pool + (size_t)v->slot * st->layout.stride;
}

/* The displayed VLs in slot order: next[0, added) then cur[front, n) while
 * replacing, else cur. Allocates only when `may_alloc`. */
static volux_status prepare_render(ml_state *st, int may_alloc) {
    int bound = display_bound(st);
    if (bound > st->cap_rvl) {
        if (!may_alloc) return volux_error(st->rc.ctx, VOLUX_ERR_INTERNAL, "manylights: render list too small");
        ml_rvl *r = volux_realloc(st->rc.ctx, st->rvl, sizeof *r * (size_t)st->cap_rvl, sizeof *r * (size_t)bound);
        if (!r) return volux_error(st->rc.ctx, VOLUX_ERR_NOMEM, "manylights: out of memory for %d virtual lights", bound);
        st->rvl = r;
        st->cap_rvl = bound;
    }
    int n = 0;
    for (int slot = 0; slot < st->sets_cap; slot++) {
        const ml_set *set = &st->sets[slot];
        if (!set->active) continue;
        if (set->replacing)
            for (int i = 0; i < set->added; i++) rvl_fill(st, &st->rvl[n++], &set->next.v[i], set, slot, 0);
        for (int i = set->replacing ? set->front : 0; i < set->cur.n; i++)
            rvl_fill(st, &st->rvl[n++], &set->cur.v[i], set, slot, 0);
    }
    st->n_rvl = n;
    st->draw = st->rvl;
    st->n_draw = n;
    return VOLUX_OK;
}

/* ------------------------------------------------------------------ pass sets */

static void free_pass_sets(ml_state *st) {
    for (int slot = 0; slot < st->psets_cap; slot++) set_free(st, &st->psets[slot]);
    st->pass_k = 0;
}

/* Pass set k ≥ 1 for every enabled light: the prefix of its stream k that
 * holds the light's share of vl_count, every AVSM built for the current
 * scene — what set 0 of a fresh create is, with other random numbers.
 * Sample p of an accumulation reads set p / passes_per_set, so the image
 * averages independent estimates of the VSL model (docs: "what it
 * converges to") instead of one set's fixed error. */
static volux_status build_pass_sets(ml_state *st, const volux_scene *scene, int k) {
    const volux_light_list *ll = &st->rc.lights;
    volux_status s = volux_grow_slots(st->rc.ctx, &st->psets, &st->psets_cap, volux_scene_light_slots(scene),
                                      sizeof *st->psets, "manylights: per-light pass VL sets");
    if (s) return s;
    st->pass_k = 0;
    int n = ll->n_all, total = 0;
    for (int slot = 0; slot < st->psets_cap; slot++)
        if (st->psets[slot].active) set_free(st, &st->psets[slot]);
    for (int i = 0; i < n; i++) {
        const volux_prepared_light *l = &ll->all[i];
        ml_set *set = &st->psets[l->slot];
        int quota = st->vl_count / n + (i < st->vl_count % n);
        if ((s = trace_fresh(st, set, l, k, quota))) return s;
        ml_weights(st, l, &set->cur);
        total += set->cur.n;
    }
    if (total > st->cap_prvl) {
        ml_rvl *r = volux_realloc(st->rc.ctx, st->prvl, sizeof *r * (size_t)st->cap_prvl, sizeof *r * (size_t)total);
        if (!r) return volux_error(st->rc.ctx, VOLUX_ERR_NOMEM, "manylights: out of memory for %d virtual lights", total);
        st->prvl = r;
        st->cap_prvl = total;
    }
    int m = 0;
    for (int slot = 0; slot < st->psets_cap; slot++) {
        const ml_set *set = &st->psets[slot];
        if (!set->active) continue;
        for (int i = 0; i < set->cur.n; i++) rvl_fill(st, &st->prvl[m++], &set->cur.v[i], set, slot, k);
    }
    st->n_prvl = m;
    st->pass_k = k;
    return VOLUX_OK;
}

/* begin_pass: which VL set this wave gathers from. Set 0 stays with the
 * instance (edits re-weight and replace it, W13 §4); pass set k is built
 * the first time a wave needs it and kept until the next one (or an
 * update) — one set's AVSMs at a time. */
static volux_status ml_begin_pass(void *state, const volux_scene *scene, uint32_t sample_index) {
    ml_state *st = state;
    int k = st->passes_per_set > 0 ? (int)(sample_index / (uint32_t)st->passes_per_set) : 0;
    st->draw_stride = 1;
    st->samples_now = st->samples;
    if (sample_index == 0 && st->preview_vls > 0) {
        /* the preview: what the first image costs (issue 27: ≤ 2 s after a
         * create, ≤ 0.2 s after an edit), not what the accumulation
         * converges to — each VL is gathered with probability 1/stride and
         * weight stride, so the first sample stays an estimate of the same
         * model */
        st->draw_stride = st->n_rvl > st->preview_vls ? (st->n_rvl + st->preview_vls - 1) / st->preview_vls : 1;
        st->samples_now = st->preview_samples < st->samples ? st->preview_samples : st->samples;
    }
    if (k == 0 || !st->multi_on || st->rc.max_depth < 2 || st->n_rvl == 0) {
        st->draw = st->rvl;
        st->n_draw = st->n_rvl;
        return VOLUX_OK;
    }
    if (k != st->pass_k) {
        /* the update statistics stay those of the last update or step */
        double am = st->avsm_ms, tm = st->trace_ms;
        int ab = st->avsm_built, tr = st->traced;
        st->avsm_ms = st->trace_ms = 0.0;
        st->avsm_built = st->traced = 0;
        volux_status s = build_pass_sets(st, scene, k);
        st->pass_avsm_ms = st->avsm_ms;
        st->pass_trace_ms = st->trace_ms;
        st->pass_avsm_built = st->avsm_built;
        st->avsm_ms = am, st->trace_ms = tm, st->avsm_built = ab, st->traced = tr;
        if (s) {
            free_pass_sets(st);
            st->draw = st->rvl;
            st->n_draw = st->n_rvl;
            return s;
        }
    }
    st->draw = st->prvl;
    st->n_draw = st->n_prvl;
    return VOLUX_OK;
}

/* ------------------------------------------------------------------ class hooks */

static void ml_init(void *state) {
    ml_state *st = state;
    st->dirty = ML_DIRTY_FULL;
    st->traced_depth = -1;
    st->draw_stride = 1;
}

/* Half the mean spacing of vl_count points spread over the volume the
 * transfer function leaves non-empty (the macrocells with σ1 > 0), so
 * neighbouring VSLs about touch (after the density-adaptive radius of
 * Hašan et al. 2009, here one radius for all). */
static float auto_radius(const ml_state *st) {
    const volux_volume *v = st->rc.volume;
    size_t n = (size_t)st->grid1.cells[0] * (size_t)st->grid1.cells[1] * (size_t)st->grid1.cells[2], occupied = 0;
    for (size_t c = 0; c < n; c++) occupied += st->grid1.sigma_max[c] > 0.0f;
    double cell = (double)VOLUX_CELL_SIZE;
    double vol = (double)occupied * cell * cell * cell * v->spacing[0] * v->spacing[1] * v->spacing[2];
    int count = st->vl_count > 0 ? st->vl_count : 1;
    float r = (float)(0.5 * cbrt(vol / count));
    return r > 0.0f ? r : st->rc.min_spacing;
}

static volux_status update_env_samplers(ml_state *st, const volux_scene *scene, const volux_change_set *c) {
    volux_status g = volux_grow_slots(st->rc.ctx, &st->env, &st->env_cap, volux_scene_light_slots(scene),
                                      sizeof *st->env, "manylights: environment tables");
    if (g) return g;
    for (int i = 0; i < st->env_cap; i++) {
        if (!volux_change_light(c, i)) continue;
        const volux_light_desc *d = volux_scene_light(scene, i);
        if (d && d->type == VOLUX_LIGHT_ENVIRONMENT) {
            volux_status s = volux_envmap_sampler_build(st->rc.ctx, d, &st->env[i]);
            if (s) return s;
        } else {
            volux_envmap_sampler_free(st->rc.ctx, &st->env[i]);
        }
    }
    return VOLUX_OK;
}

static volux_status ml_update(void *state, const volux_scene *scene, const volux_change_set *c) {
    ml_state *st = state;
    volux_raycaster *rc = &st->rc;
    volux_context *ctx = rc->ctx;
    uint32_t w = c->what;
    volux_status s;
    st->avsm_ms = st->trace_ms = 0.0;
    st->avsm_built = st->traced = 0;
    /* any edit may change a pass set (they are cheap to rebuild next to
     * keeping track of which edit changes what in them) */
    free_pass_sets(st);
    if ((w & VOLUX_CHANGE_PARAMS) && (s = read_params(st, scene))) return s;
    if (w & VOLUX_CHANGE_VOLUME) {
        /* AVSM rays read the bricked copy (same values, fewer cache lines) */
        if ((s = volux_volume_build_bricks(rc->volume))) return s;
        volux_vec3 lo, hi;
        volux_volume_bounds(rc->volume, &lo, &hi);
        st->center = v3_scale(v3_add(lo, hi), 0.5f);
        st->bound_r = fmaxf(0.5f * v3_length(v3_sub(hi, lo)), 1e-6f);
        st->dirty |= ML_DIRTY_FULL;
    }
    if (w & (VOLUX_CHANGE_VOLUME | VOLUX_CHANGE_EXTINCTION)) {
        /* σ1: the scene's extinction curve at density scale 1 */
        volux_transfer_desc tf = *volux_scene_transfer(scene);
        tf.density_scale = 1.0f;
        double lo, hi;
        volux_volume_range(rc->volume, &lo, &hi);
        volux_transfer_lut lut;
        if ((s = volux_transfer_bake(ctx, &tf, lo, hi, 0, rc->min_spacing, &lut))) return s;
        volux_transfer_lut_free(ctx, &st->lut1);
        st->lut1 = lut;
        if ((s = volux_majorant_grid_build(ctx, rc->volume, &st->lut1, &st->grid1))) return s;
        if (!(w & VOLUX_CHANGE_VOLUME)) st->dirty |= ML_DIRTY_PLACE;
    }
    if (w & (VOLUX_CHANGE_VOLUME | VOLUX_CHANGE_EXTINCTION | VOLUX_CHANGE_DENSITY)) {
        if (!st->decode && !(st->decode = volux_malloc(ctx, sizeof(float) * ML_TAU_CODES)))
            return volux_error(ctx, VOLUX_ERR_NOMEM, "manylights: out of memory for the transmittance table");
        float xi = volux_scene_transfer(scene)->density_scale;
        /* σt = ξ·σ1 stays within VOLUX_SIGMA_T_MAX like every baked table
         * (volux/transfer.h): an extinction of 1e30 at density scale 1e30
         * overflowed to inf (Inf pixels; delta tracking could not step).
         * Only media opaque within far less than a voxel get a smaller ξ. */
        float s1 = st->grid1.global_max;
        if (s1 > 0.0f && xi > VOLUX_SIGMA_T_MAX / s1) xi = VOLUX_SIGMA_T_MAX / s1;
        if (xi != st->xi && st->place_by_xi) st->dirty |= ML_DIRTY_PLACE;
        st->xi = xi;
        ml_decode_fill(st->decode, xi); /* W13 §5.1: every AVSM rescaled at once */
    }
    if ((w & VOLUX_CHANGE_PHASE) && !st->iso_phase) st->dirty |= ML_DIRTY_PLACE;
    if (rc->seed != st->traced_seed || rc->max_depth != st->traced_depth) {
        st->dirty |= ML_DIRTY_FULL;
        st->traced_seed = rc->seed;
        st->traced_depth = rc->max_depth;
    }
    st->radius = st->radius_vox > 0.0f ? st->radius_vox * rc->min_spacing : auto_radius(st);
    {
        float dc = st->clamp_vox * rc->min_spacing;
        st->clamp_fg = dc > 0.0f ? VOLUX_INV_4PI * VOLUX_INV_4PI / (dc * dc) : INFINITY;
    }
    st->h = st->shadow_vox * rc->min_spacing;
    ml_layout_init(&st->layout, st->avsm_res, st->avsm_nodes, 2.0f * st->bound_r);
    if ((w & VOLUX_CHANGE_LIGHTS) && (s = update_env_samplers(st, scene, c))) return s;
    if ((s = update_sets(st, scene, c))) return s;
    /* an even share of vl_count: with more lights than VLs, the lights past
     * the first vl_count get none (their multiple scattering is missing) */
    if ((w & (VOLUX_CHANGE_LIGHTS | VOLUX_CHANGE_PARAMS)) && st->multi_on && rc->max_depth > 1 &&
        rc->lights.n_all > st->vl_count)
        volux_message(ctx, VOLUX_MESSAGE_WARNING,
                      "manylights: %d lights share techniques.manylights.vl_count = %d virtual lights: the lights "
                      "after the first %d (in slot order) get none, so their multiple scattering is missing (set "
                      "vl_count to at least the number of lights)",
                      rc->lights.n_all, st->vl_count, st->vl_count);
    /* weights of everything (cheap: a few operations per VL) */
    for (int i = 0; i < rc->lights.n_all; i++) {
        const volux_prepared_light *l = &rc->lights.all[i];
        ml_set *set = &st->sets[l->slot];
        ml_weights(st, l, &set->cur);
        if (set->replacing) ml_weights(st, l, &set->next);
    }
    return prepare_render(st, 1);
}

static uint64_t ml_pending(const void *state) {
    const ml_state *st = state;
    uint64_t n = 0;
    for (int slot = 0; slot < st->sets_cap; slot++) {
        const ml_set *set = &st->sets[slot];
        if (set->active && set->replacing) n += (uint64_t)(set->next.n - set->added) + 1;
    }
    return n;
}

/* One frame of W13 §4.2: at least `update_budget` VLs (whole subpaths)
 * move from `next` into the image with new AVSMs (rule 1), the same number
 * of the oldest leave it; the others keep their AVSMs (rule 2). Allocates
 * nothing (update reserved the pool and the render list). */
static volux_status ml_refine(void *state, const volux_scene *scene, int *changed, int *more) {
    (void)scene;
    ml_state *st = state;
    *changed = ml_pending(state) > 0;
    if (!*changed) {
        *more = 0;
        return VOLUX_OK;
    }
    st->avsm_ms = st->trace_ms = 0.0;
    st->avsm_built = st->traced = 0;
    int budget = st->budget;
    for (int slot = 0; slot < st->sets_cap && budget > 0; slot++) {
        ml_set *set = &st->sets[slot];
        while (set->active && set->replacing && budget > 0) {
            int k_end = set->added;
            while (k_end < set->next.n && k_end - set->added < budget) k_end = path_end(&set->next, k_end);
            int count = k_end - set->added, finishing = k_end == set->next.n;
            /* remove the oldest whole subpaths first, so the new ones find
             * free slots */
            while (set->front < set->cur.n && (finishing || set->removed < k_end)) {
                int e = path_end(&set->cur, set->front);
                release_slots(set, set->cur.v + set->front, e - set->front);
                set->removed += e - set->front;
                set->front = e;
            }
            assign_slots(set, set->next.v + set->added, count);
            build_avsms(st, set, set->next.v + set->added, count);
            set->added = k_end;
            budget -= count > 0 ? count : 1;
            if (finishing) {
                ml_list old = set->cur;
                set->cur = set->next;
                set->next = old;
                set->next.n = 0;
                set->paths = set->npaths;
                set->replacing = set->front = set->added = set->removed = 0;
            }
        }
    }
    *more = ml_pending(state) > 0;
    return prepare_render(st, 0);
}

static int ml_stats(const void *state, volux_technique_stat *out, int max) {
    const ml_state *st = state;
    double paths = 0.0, avsm_bytes = 0.0;
    for (int slot = 0; slot < st->sets_cap; slot++) {
        const ml_set *set = &st->sets[slot];
        if (!set->active) continue;
        paths += set->replacing ? set->npaths : set->paths;
        avsm_bytes += (double)set->pool_size;
    }
    volux_technique_stat all[] = {
        {"vl_count", (double)st->n_rvl, "VLs"},
        {"vsl_radius", st->radius / st->rc.min_spacing, "voxels"},
        {"vl_paths", paths, "paths"},
        {"avsm_build_ms", st->avsm_ms, "ms"},
        {"avsm_built", (double)st->avsm_built, "AVSMs"},
        {"vl_trace_ms", st->trace_ms, "ms"},
        {"vl_traced", (double)st->traced, "VLs"},
        {"avsm_bytes", avsm_bytes, "bytes"},
        {"pending", (double)ml_pending(state), "VLs"},
        {"pass_set", (double)st->pass_k, "set"},
        {"pass_avsm_ms", st->pass_avsm_ms, "ms"},
        {"pass_avsm_built", (double)st->pass_avsm_built, "AVSMs"},
        {"pass_trace_ms", st->pass_trace_ms, "ms"},
    };
    int n = (int)(sizeof all / sizeof all[0]);
    for (int i = 0; i < n && i < max; i++) out[i] = all[i];
    return n;
}

static size_t ml_memory_bytes(const void *state) {
    const ml_state *st = state;
    size_t n = st->grid1.bytes + (size_t)st->cap_rvl * sizeof(ml_rvl);
    if (st->decode) n += sizeof(float) * ML_TAU_CODES;
    n += (size_t)st->lut1.n * (5 * sizeof(float) + 4 * sizeof(double));
    n += sizeof *st->env * (size_t)st->env_cap + sizeof *st->sets * (size_t)st->sets_cap;
    for (int slot = 0; slot < st->env_cap; slot++) n += volux_envmap_sampler_bytes(&st->env[slot]);
    for (int slot = 0; slot < st->sets_cap; slot++) {
        const ml_set *set = &st->sets[slot];
        if (!set->active) continue;
        n += sizeof(ml_vl) * (size_t)(set->cur.cap + set->next.cap) + set->pool_size +
             sizeof(int) * (size_t)set->pool_cap;
    }
    n += sizeof *st->psets * (size_t)st->psets_cap + sizeof(ml_rvl) * (size_t)st->cap_prvl;
    for (int slot = 0; slot < st->psets_cap; slot++) {
        const ml_set *set = &st->psets[slot];
        if (set->active) n += sizeof(ml_vl) * (size_t)set->cur.cap + set->pool_size + sizeof(int) * (size_t)set->pool_cap;
    }
    return n;
}

static void ml_release(void *state) {
    ml_state *st = state;
    volux_context *ctx = st->rc.ctx;
    for (int slot = 0; slot < st->sets_cap; slot++) set_free(st, &st->sets[slot]);
    free_pass_sets(st);
    volux_free(ctx, st->psets, sizeof *st->psets * (size_t)st->psets_cap);
    volux_free(ctx, st->prvl, sizeof(ml_rvl) * (size_t)st->cap_prvl);
    st->psets = NULL;
    st->prvl = NULL;
    st->psets_cap = st->cap_prvl = st->n_prvl = 0;
    for (int slot = 0; slot < st->env_cap; slot++) volux_envmap_sampler_free(ctx, &st->env[slot]);
    volux_free(ctx, st->sets, sizeof *st->sets * (size_t)st->sets_cap);
    volux_free(ctx, st->env, sizeof *st->env * (size_t)st->env_cap);
    st->sets = NULL;
    st->env = NULL;
    st->sets_cap = st->env_cap = 0;
    volux_transfer_lut_free(ctx, &st->lut1);
    volux_majorant_grid_free(ctx, &st->grid1);
    volux_free(ctx, st->decode, sizeof(float) * ML_TAU_CODES);
    volux_free(ctx, st->rvl, sizeof(ml_rvl) * (size_t)st->cap_rvl);
    st->decode = NULL;
    st->rvl = NULL;
    st->cap_rvl = st->n_rvl = 0;
}

const volux_technique_class volux_manylights_class = {
    {"manylights",
     "multiple scattering from virtual spherical lights with AVSM transmittance caching and progressive TF edits "
     "(Weber et al. 2013)",
     ml_params, 1},
    sizeof(ml_state), 0, 0,
    ml_init, ml_update, ml_render_tile, ml_memory_bytes, ml_release,
    ml_refine, ml_pending, ml_stats,
    NULL, /* no bricks: its light leaves the camera ray (scattering, shadows) */
    NULL, /* no per-frame budget (volux_technique_set_budget) */
    volux_manylights_estimate_bytes,
    ml_begin_pass,
};
