/*
 * techniques/ao/ao.c — `ao`: SAT-based volumetric ambient occlusion after
 * Schlegel et al. 2011, the second baseline of Ament et al. 2013 (§5,
 * Table 1, Figs. 1b, 6b, 11a):
 *
 *     L_s(x) = A(x) · (Σ_j p_g(ω_j·ω) E_j(x) + L_amb)          (directional = false)
 *
 * A(x) (techniques/scatter/occlusion.h) replaces the shadow transmittance:
 * soft, local, isotropic — no directional shadows. L_amb is the mean
 * radiance of the scene's environment lights plus the `ambient` parameter.
 *
 * DIRECTIONAL OCCLUSION (`directional`, the default since issue 28).
 * Inside dense material A → 0 for every direction, so a dense surface
 * facing a bright sky (or a key light) renders black: A is the
 * transmittance averaged over the sphere, half of which lies inside the
 * object. With `directional` the transmittance is taken per direction —
 * W_k(x) = exp(−∫_0^R σt(x + t d_k) dt) for the K Fibonacci directions d_k
 * (near field, one byte each per node of a grid at vis_scale;
 * scatter/envdir.h, scatter_dirw) times F_k(x), the far field from R to
 * the volume's edge, cone-traced over a pyramid of σt means on a coarse
 * grid (`far_field`; see build_far) — and
 *
 *     L_s(x) = Σ_j p_g(ω_j·ω) E_j(x) V_j(x) + Σ_k p_g(−d_k·ω) E_k W_k F_k(x) + mean_k(W_k F_k) L_amb
 *
 * with the environment as K directions carrying the irradiance of their
 * cells (volux_environment_cells, as `single` and `lightvol`) and V_j the
 * W_k F_k interpolated around light j's direction. Near field alone (the
 * first version) misses every shadow cast from farther than R: 1.19–2.40×
 * single-scattering `pathtrace` on docs/lights.md's rows; with the far
 * field 0.93–1.13 (README.md).
 *
 * Caches and what invalidates them:
 *   SAT, occlusion volume (isotropic) or the near and far grids ← volume,
 *       extinction, density, radius, shells / directional, env_directions,
 *       vis_scale, far_field
 *   E_k (directional) ← lights, env_directions (no volume work)
 * Phase, colour, camera and light edits need no volume work (Table 1: "−").
 */
#include <math.h>
#include <string.h>

#include "ao.h"
#include "core/parallel.h"
#include "core/context_internal.h"
#include "sample/phase.h"
#include "techniques/scatter/occlusion.h"

static const volux_param_info ao_params[] = {
    SCATTER_COMMON_PARAMS,
    {"radius", VOLUX_PARAM_NUMBER, 8, 0.5, 128, NULL,
     "occlusion radius R in units of the smallest voxel spacing (the paper uses 14)"},
    {"shells", VOLUX_PARAM_INT, 3, 1, 8, NULL, "nested SAT boxes per voxel (Ament et al.: at least 3)"},
    {"ambient", VOLUX_PARAM_NUMBER, 0, 0, 1e6, NULL,
     "radiance of a white ambient light seen through the occlusion (added to environment lights)"},
    {"directional", VOLUX_PARAM_BOOL, 1, 0, 1, NULL,
     "occlusion per direction: env_directions local transmittances over the radius per node (lights and the "
     "environment's directions are seen through them), so a dense surface facing the light is lit; false: the "
     "isotropic SAT occlusion A(x) of Schlegel et al. times every light and the environment's mean radiance "
     "(src/techniques/ao/README.md)"},
    {"env_directions", VOLUX_PARAM_INT, 16, 4, SCATTER_ENV_MAX_DIRS, NULL,
     "directional: directions of the occlusion, and the environment's directions (cells of the map)"},
    {"far_field", VOLUX_PARAM_BOOL, 1, 0, 1, NULL,
     "directional: also the transmittance beyond the radius, cone-traced to the volume's edge on a coarse grid "
     "(shadows cast from farther than the radius; false: local occlusion only)"},
    {"vis_scale", VOLUX_PARAM_NUMBER, 0.5, 0.05, 1, NULL,
     "directional: resolution of the per-direction occlusion grid relative to the volume (K bytes per node)"},
    {NULL, 0, 0, 0, 0, NULL, NULL}};

/* The volume's values at its nodes as floats, one z slice: the near
 * field's samples interpolate them and classify (post-classification, as
 * the scalar march: interpolating σt instead made thin, steep-TF surfaces
 * 0.84–0.90 as bright on engine and aneurism), with reads of one layout
 * for the lanes' gathers whatever the storage type. */
static void value_slice(void *user, int64_t z, int thread) {
    (void)thread;
    const ao_state *st = user;
    const volux_volume *v = st->b.rc.volume;
    size_t n = (size_t)v->dims[0] * (size_t)v->dims[1], o = (size_t)z * n;
    for (size_t i = 0; i < n; i++) st->sigma.v[o + i] = volux_volume_raw_at(v, o + i) + v->value_offset;
}

static volux_status build_sigma(ao_state *st) {
    volux_raycaster *rc = &st->b.rc;
    volux_status s = scatter_grid_alloc(rc->ctx, rc->volume, 1.0f, &st->sigma, "ao: value volume");
    if (s) return s;
    volux_parallel_for(rc->threads, rc->volume->dims[2], value_slice, st);
    return VOLUX_OK;
}

/* Local transmittance W_k at index-space point q along direction k over
 * the radius R: the midpoint rule on the job's steps (h, h, 2h, 4h ...,
 * h = half the smallest voxel spacing; 5 steps for R = 8 voxels): fine
 * where the occluder is near (the dense surface the node sits on), coarse
 * farther out. The value interpolated from the float node values, then
 * classified. Outside the volume is empty. The lanes of march_lanes.h (ao_near_lanes) round the same way. */
static float near_transmittance(const ao_dir_job *j, volux_vec3 q, int k) {
    const scatter_grid *g = j->sigma;
    const float mx = (float)(g->dims[0] - 1), my = (float)(g->dims[1] - 1), mz = (float)(g->dims[2] - 1);
    float tau = 0.0f;
    for (int i = 0; i < j->n_steps; i++) {
        float t = j->step_mid[i];
        float x = q.x + j->dq[0][k] * t, y = q.y + j->dq[1][k] * t, z = q.z + j->dq[2][k] * t;
        if (x >= 0.0f && y >= 0.0f && z >= 0.0f && x <= mx && y <= my && z <= mz)
            tau += volux_lut_sigma(j->lut, scatter_grid_sample_index(g, x, y, z)) * j->step_len[i];
    }
    return tau > 11.5f ? 0.0f : expf(-tau);
}

static void near_slice_scalar(const ao_dir_job *j, int z) {
    const scatter_dirw *g = j->out;
    for (int y = 0; y < g->dims[1]; y++)
        for (int x = 0; x < g->dims[0]; x++) {
            volux_vec3 q;
            unsigned char *o;
            if (!ao_near_node(j, x, y, z, &q, &o)) continue; /* empty surroundings */
            for (int d = 0; d < g->stride; d++) {
                float W = d < g->K ? near_transmittance(j, q, d) : 0.0f;
                o[d] = (unsigned char)(W * 255.0f + 0.5f);
            }
        }
}

typedef struct dir_run {
    const ao_dir_job *job;
    int lanes; /* 0 scalar, 8, 16 */
} dir_run;

/* The parts of a build's job common to the near and far grids. */
static void dir_job_init(const ao_state *st, scatter_dirw *out, ao_dir_job *j) {
    const volux_volume *v = st->b.rc.volume;
    memset(j, 0, sizeof *j);
    j->st = st, j->out = out, j->origin = v->origin;
    for (int a = 0; a < 3; a++) j->inv_sp[a] = v->inv_spacing[a];
    for (int k = 0; k < st->n_dirs; k++) {
        volux_vec3 d = volux_fibonacci_dir(k, st->n_dirs);
        j->dq[0][k] = d.x * v->inv_spacing[0], j->dq[1][k] = d.y * v->inv_spacing[1];
        j->dq[2][k] = d.z * v->inv_spacing[2];
    }
}

static void near_slice(void *user, int64_t z, int thread) {
    (void)thread;
    const dir_run *r = user;
    if (r->lanes == 16) volux_ao_near_slice_avx512(r->job, (int)z);
    else if (r->lanes == 8) volux_ao_near_slice_avx2(r->job, (int)z);
    else near_slice_scalar(r->job, (int)z);
}

static volux_status build_directional(ao_state *st) {
    volux_raycaster *rc = &st->b.rc;
    volux_status s = scatter_dirw_alloc(rc->ctx, rc->volume, st->vis_scale, st->n_dirs, &st->vis);
    if (s) return s;
    /* Empty space: a node whose macrocell has only empty cells within the
     * radius (majorant grid, dilated by D cells) sees W = 1 everywhere. */
    const volux_majorant_grid *mg = &rc->grid;
    size_t n = (size_t)mg->cells[0] * (size_t)mg->cells[1] * (size_t)mg->cells[2];
    unsigned char *clear = volux_malloc(rc->ctx, n ? n : 1);
    if (!clear) return volux_error(rc->ctx, VOLUX_ERR_NOMEM, "ao: out of memory for the empty-space mask");
    int D = (int)ceilf(st->radius / rc->min_spacing / (float)VOLUX_CELL_SIZE) + 1;
    for (int z = 0; z < mg->cells[2]; z++)
        for (int y = 0; y < mg->cells[1]; y++)
            for (int x = 0; x < mg->cells[0]; x++) {
                int empty = 1;
                for (int cz = z - D; cz <= z + D && empty; cz++)
                    for (int cy = y - D; cy <= y + D && empty; cy++)
                        for (int cx = x - D; cx <= x + D && empty; cx++)
                            if (cx >= 0 && cy >= 0 && cz >= 0 && cx < mg->cells[0] && cy < mg->cells[1] &&
                                cz < mg->cells[2] &&
                                mg->sigma_max[((size_t)cz * (size_t)mg->cells[1] + (size_t)cy) * (size_t)mg->cells[0] +
                                              (size_t)cx] > 0.0f)
                                empty = 0;
                clear[((size_t)z * (size_t)mg->cells[1] + (size_t)y) * (size_t)mg->cells[0] + (size_t)x] =
                    (unsigned char)empty;
            }
    ao_dir_job job;
    dir_job_init(st, &st->vis, &job);
    const volux_volume *v = rc->volume;
    job.sigma = &st->sigma;
    job.lut = rc->lut;
    job.clear = clear;
    for (int a = 0; a < 3; a++) job.cells[a] = mg->cells[a];
    float t = 0.0f, h = 0.5f * rc->min_spacing;
    for (int i = 0; t < st->radius && i < AO_NEAR_MAX_STEPS; i++) {
        float len = st->radius - t < h ? st->radius - t : h;
        job.step_mid[i] = t + 0.5f * len, job.step_len[i] = len;
        job.n_steps = i + 1;
        t += len;
        if (i >= 1) h *= 2.0f;
    }
    /* the lanes' trilinear reads need two nodes along every axis */
    int flat = v->dims[0] < 2 || v->dims[1] < 2 || v->dims[2] < 2;
    dir_run run = {&job, flat ? 0 : st->near_lanes};
    volux_parallel_for(rc->threads, st->vis.dims[2], near_slice, &run);
    volux_free(rc->ctx, clear, n ? n : 1);
    st->vis_builds++;
    return VOLUX_OK;
}

/* ------------------------------------------------------------------ far field */

/* The near field W_k only reaches R: every shadow cast from farther away
 * is missed, which made `directional` 1.2–2.4× brighter than single
 * scattering (docs/lights.md). The far field F_k(x) is the transmittance
 * from x + R d_k to where d_k leaves the volume box, cone-traced: steps
 * that double (R, 2R, 4R ...; a step's length is its start distance), each
 * reading the mean σt over a cube as wide as the step (≈ the cone of one
 * of K = 16 equal-area cells, half-angle ≈ 29°) from a pyramid of cube
 * means, so thin structures are averaged in rather than stepped over (a
 * point sample every 2^n voxels misses them: with R = 128 and point samples
 * the rows stayed 1.3–1.75× too bright). It varies over ≈ R, so it lives on
 * a coarse grid (spacing ≈ R/2) and costs little next to the near field. */

static void ao_mip_free(ao_state *st) {
    for (int l = 0; l < AO_MIP_MAX; l++) {
        volux_free(st->b.rc.ctx, st->mip[l], st->mip_bytes[l]);
        st->mip[l] = NULL, st->mip_bytes[l] = 0;
    }
    st->mip_levels = 0;
}

typedef struct mip_job {
    ao_state *st;
    int l;
} mip_job;

/* One z slice of level l: cube means of σt over 2^(l+1) voxels, level 0
 * from the volume's nodes, the others from the level below (clipped cubes
 * average what is inside the grid). */
static void mip_slice(void *user, int64_t z, int thread) {
    (void)thread;
    const mip_job *j = user;
    const ao_state *st = j->st;
    const volux_volume *v = st->b.rc.volume;
    const int *d = st->mip_dims[j->l];
    const int *s = j->l ? st->mip_dims[j->l - 1] : v->dims;
    const float *src = j->l ? st->mip[j->l - 1] : st->sigma.v;
    float *out = st->mip[j->l];
    for (int y = 0; y < d[1]; y++)
        for (int x = 0; x < d[0]; x++) {
            float sum = 0.0f;
            int n = 0;
            for (int c = 0; c < 8; c++) {
                int xi = 2 * x + (c & 1), yi = 2 * y + ((c >> 1) & 1), zi = 2 * (int)z + (c >> 2);
                if (xi >= s[0] || yi >= s[1] || zi >= s[2]) continue;
                float val = src[((size_t)zi * (size_t)s[1] + (size_t)yi) * (size_t)s[0] + (size_t)xi];
                sum += j->l ? val : volux_lut_sigma(st->b.rc.lut, val); /* level 0: σt of the node values */
                n++;
            }
            out[((size_t)z * (size_t)d[1] + (size_t)y) * (size_t)d[0] + (size_t)x] = n ? sum / (float)n : 0.0f;
        }
}

static volux_status ao_mip_build(ao_state *st) {
    volux_raycaster *rc = &st->b.rc;
    ao_mip_free(st);
    const int *s = rc->volume->dims;
    for (int l = 0; l < AO_MIP_MAX; l++) {
        int *d = st->mip_dims[l];
        for (int a = 0; a < 3; a++) d[a] = ((l ? st->mip_dims[l - 1][a] : s[a]) + 1) / 2;
        size_t n = (size_t)d[0] * (size_t)d[1] * (size_t)d[2];
        st->mip[l] = volux_malloc(rc->ctx, n * sizeof(float));
        if (!st->mip[l]) return volux_error(rc->ctx, VOLUX_ERR_NOMEM, "ao: out of memory for the far field's pyramid");
        st->mip_bytes[l] = n * sizeof(float);
        st->mip_levels = l + 1;
        mip_job job = {st, l};
        volux_parallel_for(rc->threads, d[2], mip_slice, &job);
        if (d[0] == 1 && d[1] == 1 && d[2] == 1) break;
    }
    return VOLUX_OK;
}

/* Mean σt around index-space point q over a cube of 2^(l+1) voxels
 * (trilinear between the level's cube centres, clamped to its grid). */
float volux_ao_mip_sample(const ao_state *st, int l, volux_vec3 q) {
    const int *d = st->mip_dims[l];
    const float c = (float)(2 << l);
    float u[3] = {(q.x + 0.5f) / c - 0.5f, (q.y + 0.5f) / c - 0.5f, (q.z + 0.5f) / c - 0.5f};
    int i[3];
    float f[3];
    for (int a = 0; a < 3; a++) {
        float m = (float)(d[a] - 1);
        u[a] = u[a] < 0.0f ? 0.0f : (u[a] > m ? m : u[a]);
        i[a] = (int)u[a];
        if (i[a] > d[a] - 2) i[a] = d[a] > 1 ? d[a] - 2 : 0;
        f[a] = d[a] > 1 ? u[a] - (float)i[a] : 0.0f;
    }
    size_t sx = d[0] > 1 ? 1 : 0, sy = d[1] > 1 ? (size_t)d[0] : 0, sz = d[2] > 1 ? (size_t)d[0] * (size_t)d[1] : 0;
    const float *b = st->mip[l] + ((size_t)i[2] * (size_t)d[1] + (size_t)i[1]) * (size_t)d[0] + (size_t)i[0];
    float n[8] = {b[0], b[sx], b[sy], b[sy + sx], b[sz], b[sz + sx], b[sz + sy], b[sz + sy + sx]};
    return volux_lerp3(n, f[0], f[1], f[2]);
}

/* Where direction k (index-space dq) leaves the index box [0, n−1]³ from
 * q: a world distance. */
static float far_exit(const ao_dir_job *j, volux_vec3 q, int k) {
    const volux_volume *v = j->st->b.rc.volume;
    float t_exit = 1e30f;
    const float qa[3] = {q.x, q.y, q.z};
    for (int a = 0; a < 3; a++) {
        float da = j->dq[a][k];
        if (da > 1e-12f) t_exit = fminf(t_exit, ((float)(v->dims[a] - 1) - qa[a]) / da);
        else if (da < -1e-12f) t_exit = fminf(t_exit, -qa[a] / da);
    }
    return t_exit;
}

static float far_transmittance(const ao_dir_job *j, volux_vec3 q, int k) {
    const ao_state *st = j->st;
    const float t_exit = far_exit(j, q, k), vox = st->b.rc.min_spacing;
    const volux_vec3 dq = v3(j->dq[0][k], j->dq[1][k], j->dq[2][k]);
    float t = st->radius, tau = 0.0f;
    while (t < t_exit) {
        float len = t, end = t + len < t_exit ? t + len : t_exit;
        float piece = len / (float)AO_FAR_SUB;
        int l = ao_far_level(st, piece, vox);
        for (int i = 0; i < AO_FAR_SUB; i++) {
            float a = t + (float)i * piece, b = a + piece < end ? a + piece : end;
            if (b > a) tau += volux_ao_mip_sample(st, l, v3_madd(q, dq, 0.5f * (a + b))) * (b - a);
        }
        if (tau > 11.5f) return 0.0f;
        t = end; /* the next step is as long as its start distance */
    }
    return expf(-tau);
}

static void far_slice_scalar(const ao_dir_job *j, int z) {
    const scatter_dirw *g = j->out;
    for (int y = 0; y < g->dims[1]; y++)
        for (int x = 0; x < g->dims[0]; x++) {
            volux_vec3 q;
            unsigned char *o = ao_dir_node(j, x, y, z, &q);
            for (int d = 0; d < g->stride; d++) {
                float W = d < g->K ? far_transmittance(j, q, d) : 0.0f;
                o[d] = (unsigned char)(W * 255.0f + 0.5f);
            }
        }
}

static void far_slice(void *user, int64_t z, int thread) {
    (void)thread;
    const dir_run *r = user;
    if (r->lanes == 16) volux_ao_far_slice_avx512(r->job, (int)z);
    else if (r->lanes == 8) volux_ao_far_slice_avx2(r->job, (int)z);
    else far_slice_scalar(r->job, (int)z);
}

static volux_status build_far(ao_state *st) {
    volux_raycaster *rc = &st->b.rc;
    volux_status s;
    if ((s = ao_mip_build(st))) return s;
    /* node spacing ≈ R (scale relative to the volume's resolution) */
    float scale = rc->min_spacing / st->radius;
    scale = scale > 1.0f ? 1.0f : (scale < 0.02f ? 0.02f : scale);
    if ((s = scatter_dirw_alloc(rc->ctx, rc->volume, scale, st->n_dirs, &st->far))) return s;
    ao_dir_job job;
    dir_job_init(st, &st->far, &job);
    dir_run run = {&job, st->near_lanes};
    volux_parallel_for(rc->threads, st->far.dims[2], far_slice, &run);
    ao_mip_free(st);
    st->far_builds++;
    return VOLUX_OK;
}

static volux_status ao_update(void *state, const volux_scene *scene, const volux_change_set *c) {
    ao_state *st = state;
    volux_raycaster *rc = &st->b.rc;
    volux_status s;
    scatter_base_update(&st->b, scene, c);
    /* The lane hook (march_lanes.h) shades the isotropic model with
     * gathers, the directional one per lane. */
    if ((s = scatter_base_packet_update(&st->b, scene, c, 1, NULL))) return s;
    int rebuild = (c->what & (VOLUX_CHANGE_VOLUME | VOLUX_CHANGE_EXTINCTION | VOLUX_CHANGE_DENSITY)) != 0;
    int env = (c->what & (VOLUX_CHANGE_LIGHTS | VOLUX_CHANGE_PHASE)) != 0;
    if (c->what & (VOLUX_CHANGE_PARAMS | VOLUX_CHANGE_VOLUME)) {
        float radius = (float)volux_technique_param(scene, rc->cls, "radius") * rc->min_spacing;
        int shells = (int)volux_technique_param(scene, rc->cls, "shells");
        int directional = (int)volux_technique_param(scene, rc->cls, "directional");
        int dirs = (int)volux_technique_param(scene, rc->cls, "env_directions");
        float vis_scale = (float)volux_technique_param(scene, rc->cls, "vis_scale");
        int far_field = (int)volux_technique_param(scene, rc->cls, "far_field");
        if (radius != st->radius || shells != st->shells || directional != st->directional || dirs != st->n_dirs ||
            vis_scale != st->vis_scale || far_field != st->far_field)
            rebuild = 1;
        st->far_field = far_field;
        if (directional != st->directional || dirs != st->n_dirs) env = 1;
        st->radius = radius, st->shells = shells;
        st->directional = directional, st->n_dirs = dirs, st->vis_scale = vis_scale;
        st->ambient = (float)volux_technique_param(scene, rc->cls, "ambient");
    }
    if (env) { /* the environment as K directions: no volume work */
        scatter_env_prepare(&st->env, &rc->lights, st->directional ? st->n_dirs : 0);
        st->env_table_builds++;
    }
    if (st->directional && (c->what & VOLUX_CHANGE_PARAMS)) {
        /* the near field's kernel follows march_kernel ("scalar": the
         * portable reference for both); bytes may differ by 1 between
         * kernels, so a change rebuilds (incremental == fresh) */
        if (st->b.march_lanes != st->near_lanes) rebuild = 1;
        st->near_lanes = st->b.march_lanes;
    }
    if (!rebuild) return VOLUX_OK;
    if (st->directional) {
        scatter_sat_free(rc->ctx, &st->sat);
        scatter_grid_free(rc->ctx, &st->occ);
        if (!(s = build_sigma(st)) && !(s = build_directional(st))) {
            if (st->far_field) s = build_far(st);
            else scatter_dirw_free(rc->ctx, &st->far);
        }
        scatter_grid_free(rc->ctx, &st->sigma);
        return s;
    }
    scatter_dirw_free(rc->ctx, &st->vis);
    scatter_dirw_free(rc->ctx, &st->far);
    double sp[3];
    volux_volume_spacing(rc->volume, sp);
    if ((s = scatter_sat_build(rc->ctx, rc->threads, rc->volume, rc->lut, scatter_occlusion_max_box(st->radius, sp),
                               &st->sat)))
        return s;
    st->sat_builds++;
    if ((s = scatter_grid_alloc(rc->ctx, rc->volume, 1.0f, &st->occ, "ao: occlusion volume"))) return s;
    if ((s = scatter_occlusion_build(rc->ctx, rc->threads, &st->sat, st->radius, st->shells, sp, &st->occ))) return s;
    st->occ_builds++;
    return VOLUX_OK;
}

static void ao_init(void *state) {
    ao_state *st = state;
    st->directional = -1;
    st->near_lanes = -1;
}

static void ao_release(void *state) {
    ao_state *st = state;
    scatter_sat_free(st->b.rc.ctx, &st->sat);
    scatter_grid_free(st->b.rc.ctx, &st->occ);
    scatter_dirw_free(st->b.rc.ctx, &st->vis);
    scatter_dirw_free(st->b.rc.ctx, &st->far);
    scatter_grid_free(st->b.rc.ctx, &st->sigma);
    ao_mip_free(st);
    scatter_base_packet_release(&st->b);
}

static size_t ao_memory_bytes(const void *state) {
    const ao_state *st = state;
    return st->sat.bytes + st->occ.bytes + st->vis.bytes + st->far.bytes + volux_packet_tables_bytes(&st->b.pk);
}

/* In-scattering of the directional model at one view sample (per lane:
 * reads the K transmittances at p). Environment direction k: E_k W_k
 * p_g(−d_k·ω) exactly; a direct light: W interpolated between the
 * directions around its own with weights max(0, d·d_k)^8 (≈ 33° half
 * width; the Fibonacci directions of K = 16 are ≈ 50° apart). */
static inline __attribute__((always_inline)) volux_vec3 ao_directional_light(const ao_state *st, volux_vec3 p,
                                                                             volux_vec3 to_eye) {
    const volux_light_list *ls = &st->b.rc.lights;
    const int K = st->vis.K;
    const float g = st->b.rc.g;
    float W[SCATTER_ENV_MAX_DIRS];
    scatter_dirw_sample(&st->vis, p, W);
    if (st->far.v) {
        float F[SCATTER_ENV_MAX_DIRS];
        scatter_dirw_sample(&st->far, p, F);
        for (int k = 0; k < K; k++) W[k] *= F[k];
    }
    float mean = 0.0f;
    for (int k = 0; k < K; k++) mean += W[k];
    mean /= (float)K;
    volux_vec3 L = v3(st->ambient * mean, st->ambient * mean, st->ambient * mean);
    for (int i = 0; i < ls->n_direct; i++) {
        volux_vec3 travel;
        volux_vec3 E = volux_light_irradiance(&ls->direct[i], p, &travel);
        float num = 0.0f, den = 0.0f;
        for (int k = 0; k < K; k++) {
            volux_vec3 d = st->env.from[k];
            float c = -(travel.x * d.x + travel.y * d.y + travel.z * d.z);
            c = c > 0.0f ? c : 0.0f;
            c *= c, c *= c, c *= c;
            num += c * W[k], den += c;
        }
        float V = den > 0.0f ? num / den : mean;
        L = v3_add(L, v3_scale(E, V * volux_hg_eval(g, v3_dot(travel, to_eye))));
    }
    if (st->env.K) {
        float r = 0.0f, gr = 0.0f, b = 0.0f;
        for (int k = 0; k < K; k++) {
            float f = W[k] * volux_hg_eval(g, -v3_dot(st->env.from[k], to_eye));
            r += f * st->env.E[k].x, gr += f * st->env.E[k].y, b += f * st->env.E[k].z;
        }
        L = v3_add(L, v3(r, gr, b));
    }
    return L;
}

static inline __attribute__((always_inline)) void inscatter(const void *tech, const scatter_sample *smp,
                                                            volux_vec3 *Ls, volux_vec3 *extra) {
    (void)extra;
    const ao_state *st = tech;
    if (st->directional) {
        *Ls = ao_directional_light(st, smp->p, smp->to_eye);
        return;
    }
    const volux_light_list *ls = &st->b.rc.lights;
    float A = scatter_grid_sample_index(&st->occ, smp->q.x, smp->q.y, smp->q.z);
    volux_vec3 L = v3_add(ls->env_mean, v3(st->ambient, st->ambient, st->ambient));
    for (int i = 0; i < ls->n_direct; i++) {
        volux_vec3 travel;
        volux_vec3 E = volux_light_irradiance(&ls->direct[i], smp->p, &travel);
        L = v3_add(L, v3_scale(E, volux_hg_eval(st->b.rc.g, v3_dot(travel, smp->to_eye))));
    }
    *Ls = v3_scale(L, A);
}

SCATTER_RENDER_TILE(ao_render_tile_scalar, ao_state, 0.0f, NULL, inscatter)

void volux_ao_shade_lane(const void *tech, const volux_packet_lane *in, float c[3]) {
    const ao_state *st = tech;
    scatter_sample smp;
    scatter_sample_of_lane(in, c, &smp);
    volux_vec3 Ls = v3(0, 0, 0), Lx = v3(0, 0, 0);
    inscatter(tech, &smp, &Ls, &Lx);
    scatter_emit(&st->b, c, Ls, Lx);
}

/* The packet march (march_lanes.h) when march_kernel resolved to SIMD. */
static void ao_render_tile(const void *state, const volux_scene *scene, const volux_tile *tile, float *rgb,
                           volux_tile_stats *stats) {
    const ao_state *st = state;
    if (st->b.march_lanes)
        scatter_packet_tile(&st->b, st, scene, tile, rgb, stats, volux_ao_march_avx2, volux_ao_march_avx512);
    else ao_render_tile_scalar(state, scene, tile, rgb, stats);
}

const volux_technique_class volux_ao_class = {
    {"ao", "SAT ambient occlusion (Schlegel et al. 2011) lighting single scattering (Ament 2013 baseline)",
     ao_params, 0},
    sizeof(ao_state), 0, 0,
    ao_init, ao_update, ao_render_tile, ao_memory_bytes, ao_release,
    NULL, NULL, NULL, /* no refine, pending work or statistics */
    NULL, /* no bricks: its light leaves the camera ray (scattering, shadows) */
    NULL, /* no per-frame budget (volux_technique_set_budget) */
    volux_ao_estimate_bytes,
    NULL, /* nothing per pass */
};
