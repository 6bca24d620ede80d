/*
 * techniques/sh/deltavis.c — per-node transmittance towards each delta
 * light (issue 28: the engine's thin front plate).
 *
 * The 4-band visibility V of a node cannot hold a delta light's shadow:
 * nodes either side of a plate thinner than a coefficient cell see
 * opposite hemispheres, and the trilinear lookup lights the far side
 * through the plate (the engine was 1.27× too bright under its back
 * light). Delta lights (directional, point, spot) therefore get a scalar
 * transmittance per node instead, T_i(node), built by a sweep through the
 * grid's slices from the light's side along the dominant axis a of the
 * direction to the light (as seen from the volume's centre):
 *
 *     T_i(x) = exp(−∫_x^{x'} σt) · T_i(x'),   x' = x + Δ·ω_i(x),
 *
 * x' the point where the way towards the light crosses the previous slice
 * (read bilinearly there), the integral marched at the volume's resolution
 * (one-voxel steps, midpoint rule): every plate between two slices is
 * crossed at full resolution, only the lateral interpolation blurs. A ray
 * that leaves the box before the previous slice, the first slice, and
 * nodes whose way runs nearly parallel to the slices (|ω_a| < 0.3, a point
 * light beside them) march straight to the box's edge. The shading sample
 * marches its first `near_field` cells itself and reads T_i beyond
 * (sh.c): at the sample the nodes around it would again sit either side
 * of a plate.
 *
 * Each node's value depends only on the volume, the TF's σt and the light:
 * images do not depend on the thread count.
 */
#include <math.h>
#include <string.h>

#include "core/context_internal.h"
#include "core/parallel.h"
#include "sh.h"

/* Optical depth from fine index q along dq (fine index per world unit)
 * over `dist` world units by the trapezoid rule, an eighth of a voxel
 * apart at q and doubling to one voxel: on a dense surface the light
 * lives in the first fraction of a voxel, where one-voxel steps read the
 * air beside it (the dense test ball came out 1.9× too bright). */
float sh_tau_segment(const sh_state *st, volux_vec3 q, volux_vec3 dq, float dist) {
    const float h = st->rc.min_spacing;
    const volux_storage storage = st->rc.volume->storage;
    float tau = 0.0f, t0 = 0.0f, s0 = sh_sigma_q(st, q.x, q.y, q.z, storage);
    for (float t = 0.125f * h; t0 < dist; t = t0 < h ? 2.0f * t : t + h) {
        if (t > dist) t = dist;
        float s1 = sh_sigma_q(st, q.x + dq.x * t, q.y + dq.y * t, q.z + dq.z * t, storage);
        tau += 0.5f * (s0 + s1) * (t - t0);
        s0 = s1, t0 = t;
    }
    return tau;
}

/* World units from fine index q along dq until the box [0, dims − 1] is left. */
static float box_exit(const int *d, volux_vec3 q, volux_vec3 dq) {
    const float qa[3] = {q.x, q.y, q.z}, da[3] = {dq.x, dq.y, dq.z};
    float t = INFINITY;
    for (int a = 0; a < 3; a++) {
        if (da[a] > 1e-12f) t = fminf(t, ((float)(d[a] - 1) - qa[a]) / da[a]);
        else if (da[a] < -1e-12f) t = fminf(t, -qa[a] / da[a]);
    }
    return t > 0.0f ? t : 0.0f;
}

typedef struct dv_job {
    const sh_state *st;
    const volux_prepared_light *l;
    volux_vec3 org;      /* world position of fine index 0 */
    float sp[3];
    int axis, sign;      /* sweep axis, +1: the light lies towards larger indices */
    int slice, prev;     /* grid index along the axis being filled, and the one before (−1: none) */
    float *T;            /* this light's grid */
} dv_job;

static inline float node_coord(const sh_grid *g, const int *d, int a, int i) {
    float c = (float)(i * g->ratio);
    return c < (float)(d[a] - 1) ? c : (float)(d[a] - 1);
}

/* Unit direction towards the light from fine index q (world), and the
 * distance to a positional light (INFINITY for directional). */
static volux_vec3 towards(const dv_job *j, volux_vec3 q, float *dist) {
    const volux_prepared_light *l = j->l;
    if (!l->positional) {
        *dist = INFINITY;
        return v3_scale(l->travel, -1.0f);
    }
    volux_vec3 p = v3(j->org.x + q.x * j->sp[0], j->org.y + q.y * j->sp[1], j->org.z + q.z * j->sp[2]);
    volux_vec3 to = v3_sub(l->pos, p);
    float len = v3_length(to);
    *dist = len;
    return len > 0.0f ? v3_scale(to, 1.0f / len) : v3(0, 0, 1);
}

/* Bilinear T of slice `s` at the two lateral fine coordinates (u along
 * axis b, v along axis c). */
static float slice_lookup(const dv_job *j, int s, int b, int c, float u, float v) {
    const sh_grid *g = &j->st->grid;
    const int *gd = g->dims;
    const float inv = 1.0f / (float)g->ratio;
    float x = u * inv, y = v * inv;
    int i = (int)x, k = (int)y;
    i = i > gd[b] - 2 ? (gd[b] > 1 ? gd[b] - 2 : 0) : i < 0 ? 0 : i;
    k = k > gd[c] - 2 ? (gd[c] > 1 ? gd[c] - 2 : 0) : k < 0 ? 0 : k;
    float fx = fminf(fmaxf(x - (float)i, 0.0f), 1.0f), fy = fminf(fmaxf(y - (float)k, 0.0f), 1.0f);
    int i1 = gd[b] > 1 ? i + 1 : i, k1 = gd[c] > 1 ? k + 1 : k;
    size_t st[3] = {1, (size_t)gd[0], (size_t)gd[0] * gd[1]};
    size_t base = (size_t)s * st[j->axis];
    float t00 = j->T[base + i * st[b] + k * st[c]], t10 = j->T[base + i1 * st[b] + k * st[c]];
    float t01 = j->T[base + i * st[b] + k1 * st[c]], t11 = j->T[base + i1 * st[b] + k1 * st[c]];
    return (t00 + (t10 - t00) * fx) * (1.0f - fy) + (t01 + (t11 - t01) * fx) * fy;
}

static void dv_row(void *user, int64_t row, int thread) {
    (void)thread;
    const dv_job *j = user;
    const sh_state *st = j->st;
    const sh_grid *g = &st->grid;
    const int *d = st->rc.volume->dims, a = j->axis, b = a == 0 ? 1 : 0, c = a == 2 ? 1 : 2;
    size_t stride[3] = {1, (size_t)g->dims[0], (size_t)g->dims[0] * g->dims[1]};
    const int ic = (int)(row / g->dims[b]), ib = (int)(row % g->dims[b]);
    float qa[3];
    qa[a] = node_coord(g, d, a, j->slice), qa[b] = node_coord(g, d, b, ib), qa[c] = node_coord(g, d, c, ic);
    const volux_vec3 q = v3(qa[0], qa[1], qa[2]);
    float dist;
    const volux_vec3 w = towards(j, q, &dist);
    const float wa[3] = {w.x, w.y, w.z};
    const volux_vec3 dq = v3(w.x / j->sp[0], w.y / j->sp[1], w.z / j->sp[2]);
    const float dqa[3] = {dq.x, dq.y, dq.z};
    float out = dist, T;
    float exit = box_exit(d, q, dq);
    if (exit < out) out = exit;
    if (j->prev >= 0 && wa[a] * (float)j->sign >= 0.3f) {
        /* to the previous slice, if the way gets there inside the box */
        float step = (node_coord(g, d, a, j->prev) - qa[a]) / dqa[a];
        float ub = qa[b] + dqa[b] * step, vc = qa[c] + dqa[c] * step;
        if (step < out && ub >= 0.0f && ub <= (float)(d[b] - 1) && vc >= 0.0f && vc <= (float)(d[c] - 1)) {
            T = expf(-sh_tau_segment(st, q, dq, step)) * slice_lookup(j, j->prev, b, c, ub, vc);
            goto store;
        }
    }
    T = expf(-sh_tau_segment(st, q, dq, out));
store:
    j->T[(size_t)j->slice * stride[a] + (size_t)ib * stride[b] + (size_t)ic * stride[c]] = T;
}

volux_status sh_delta_visibility(sh_state *st) {
    volux_context *ctx = st->rc.ctx;
    const sh_grid *g = &st->grid;
    const volux_light_list *ll = &st->rc.lights;
    int n = 0;
    st->n_dvis = 0; /* nothing to read until the grids are built */
    for (int i = 0; i < st->n_delta; i++) n += st->delta_exact[i] && st->delta_light[i] >= 0;
    size_t bytes = (size_t)n * g->nodes * sizeof(float);
    if (bytes != st->dvis_bytes) {
        if (st->dvis) volux_free_aligned(ctx, st->dvis, st->dvis_bytes);
        st->dvis = NULL;
        st->dvis_bytes = 0;
        if (bytes && !(st->dvis = volux_alloc_aligned(ctx, bytes)))
            return volux_error(ctx, VOLUX_ERR_NOMEM, "sh: out of memory for the delta lights' transmittance");
        st->dvis_bytes = bytes;
    }
    volux_vec3 lo, hi, centre;
    volux_volume_bounds(st->rc.volume, &lo, &hi);
    centre = v3_scale(v3_add(lo, hi), 0.5f);
    double sp[3];
    volux_volume_spacing(st->rc.volume, sp);
    int k = 0;
    for (int i = 0; i < st->n_delta; i++) {
        if (!st->delta_exact[i] || st->delta_light[i] < 0) continue;
        dv_job j;
        memset(&j, 0, sizeof j);
        j.st = st;
        j.l = &ll->all[st->delta_light[i]];
        j.org = lo;
        for (int a = 0; a < 3; a++) j.sp[a] = (float)sp[a];
        float dist;
        volux_vec3 wc = towards(&j, v3((centre.x - lo.x) / j.sp[0], (centre.y - lo.y) / j.sp[1],
                                         (centre.z - lo.z) / j.sp[2]), &dist);
        const float wa[3] = {wc.x, wc.y, wc.z};
        j.axis = fabsf(wa[0]) >= fabsf(wa[1]) && fabsf(wa[0]) >= fabsf(wa[2]) ? 0 : fabsf(wa[1]) >= fabsf(wa[2]) ? 1 : 2;
        j.sign = wa[j.axis] >= 0.0f ? 1 : -1;
        j.T = st->dvis + (size_t)k * g->nodes;
        const int a = j.axis, b = a == 0 ? 1 : 0, c = a == 2 ? 1 : 2, m = g->dims[a];
        /* from the light's side inwards */
        for (int s = 0; s < m; s++) {
            j.slice = j.sign > 0 ? m - 1 - s : s;
            j.prev = s == 0 ? -1 : j.slice + j.sign;
            volux_parallel_for(st->rc.threads, (int64_t)g->dims[b] * g->dims[c], dv_row, &j);
        }
        st->dvis_light[k] = i;
        k++;
    }
    st->n_dvis = k;
    return VOLUX_OK;
}

void sh_delta_visibility_free(sh_state *st) {
    if (st->dvis) volux_free_aligned(st->rc.ctx, st->dvis, st->dvis_bytes);
    st->dvis = NULL;
    st->dvis_bytes = 0;
    st->n_dvis = 0;
}
