/*
 * techniques/manylights/avsm.c — one cube-map adaptive volumetric shadow
 * map per virtual light (W13 §3.4; Salvi, Vidimče, Lauritzen & Lefohn
 * 2010).
 *
 * A texel holds m nodes (depth d_i, optical depth τ1_i) sorted by depth: the
 * transmittance from the VL along the texel's direction is the polyline
 * through (0, 1), (d_i, T_i), constant after the last node. Building marches
 * the texel-centre ray from the VL (midpoint rule on fixed steps of the
 * shadow step, empty macrocells skipped) and streams every step end into
 * the node list; when it holds m + 1 nodes, the node whose removal changes
 * the area under the curve least — the triangle it forms with its two
 * neighbours — is removed (Salvi et al. §3.2, "compression"). The newest
 * node is never removed, so the tail stays exact. The area is measured on
 * T1 = exp(−τ1), the curve at density scale 1, so which nodes survive does
 * not depend on the density scale being edited (ξ enters at look-up:
 * T = exp(−ξ·τ1) through a table over the τ1 codes, W13 §5.1's
 * T_old^(ξ_new/ξ_old) for every map at once).
 *
 * With avsm_cone > 0 the step grows with the distance from the VL as the
 * texel's width does (max(shadow step, avsm_cone·2/R·distance)): the
 * transmittance a texel stores is an estimate for its whole footprint
 * anyway, and the far half of a ray then costs a handful of samples
 * instead of hundreds (issue 27: ≈ 25 ms CPU per VL at 40² before).
 *
 * Look-ups: `point` takes the texel the direction falls in; `trilinear`
 * blends the four nearest texels of the face (bilinear, clamped at the
 * face's edge) — both interpolate linearly in depth along the polyline
 * (W13: "bilinear on the cubemap face and linear along the depth").
 */
#include <math.h>
#include <string.h>

#include "manylights.h"

void ml_layout_init(ml_layout *lay, int res, int nodes, float d_max) {
    lay->res = res;
    lay->nodes = nodes;
    lay->stride = (size_t)6 * (size_t)res * (size_t)res * (size_t)nodes;
    lay->d_unit = d_max / 65535.0f;
    lay->inv_d_unit = 65535.0f / d_max;
}

/* IEEE half-precision bits of tau ≥ 0 (round half up; saturates at the
 * largest finite half). */
uint16_t ml_tau_code(float tau) {
    if (!(tau > 0.0f)) return 0;
    if (tau >= 65504.0f) return 0x7bff;
    uint32_t b;
    memcpy(&b, &tau, sizeof b);
    int e = (int)((b >> 23) & 0xff) - 127 + 15;
    uint32_t m = b & 0x7fffff;
    if (e <= 0) { /* half subnormal: m·2^−24 */
        if (e < -10) return 0;
        m |= 0x800000;
        int shift = 14 - e;
        uint32_t h = m >> shift;
        if ((m >> (shift - 1)) & 1u) h++;
        return (uint16_t)h;
    }
    uint32_t h = ((uint32_t)e << 10) | (m >> 13);
    if (m & 0x1000u) h++; /* a carry into the exponent is still right */
    return (uint16_t)(h > 0x7bff ? 0x7bff : h);
}

float ml_tau_decode(uint16_t c) {
    int e = c >> 10, m = c & 0x3ff;
    if (e == 0) return ldexpf((float)m, -24);
    return ldexpf((float)(m | 0x400), e - 25);
}

void ml_decode_fill(float *decode, float xi) {
    for (int c = 0; c < ML_TAU_CODES; c++) decode[c] = expf(-xi * ml_tau_decode((uint16_t)c));
}

/* e^{−x} for x ≥ 0 to ~2·10⁻⁷ relative: 2^{−x·log2 e} split into an
 * exponent and a degree-6 polynomial of 2^f on f ∈ [0, 1). Only the
 * compression's area metric uses it (which node to drop), so it need not
 * be expf — but it is deterministic, like everything else. */
static inline float fast_exp_neg(float x) {
    float y = -x * 1.44269504f;
    if (y < -126.0f) return 0.0f;
    float fl = (float)(int)y; /* y ≤ 0: truncation rounds up */
    if (fl > y) fl -= 1.0f;
    float f = y - fl;
    float p = 1.0f + f * (0.69314718f + f * (0.24022652f + f * (0.05550411f + f * (0.00961813f +
                                                                            f * (0.00133336f + f * 0.00015404f)))));
    int e = (int)fl + 127;
    uint32_t bits = (uint32_t)e << 23;
    float scale;
    memcpy(&scale, &bits, sizeof scale);
    return p * scale;
}

typedef struct node {
    float d, tau, T, area; /* area: of the triangle with both neighbours */
} node;

/* The node list of one texel ray: nd[0] is the start (0, τ 0, T 1), never
 * removed; nodes 1 … n are the curve, the newest (n) never removed. */
typedef struct node_list {
    node nd[ML_MAX_NODES + 2];
    int n, m;
} node_list;

/* Twice the area of the triangle (nd[i−1], nd[i], nd[i+1]) in (depth, T1). */
static inline void update_area(node *nd, int i) {
    const node *a = &nd[i - 1], *b = &nd[i], *c = &nd[i + 1];
    nd[i].area = fabsf((b->d - a->d) * (c->T - a->T) - (c->d - a->d) * (b->T - a->T));
}

/* Streams the point (d, tau) into the list (Salvi's insertion + removal);
 * areas are kept per node and only the neighbours of a change recomputed. */
static inline void add_point(node_list *l, float d, float tau) {
    node *nd = l->nd;
    int n = l->n;
    /* A flat run (same τ as the last two nodes) only moves its end: the
     * middle node would have zero area anyway. */
    if (nd[n].tau == tau && (n == 0 || nd[n - 1].tau == tau)) {
        if (n == 0) goto append; /* the start itself never moves */
        nd[n].d = d;
        if (n > 1) update_area(nd, n - 1);
        return;
    }
append:
    n++;
    nd[n].d = d;
    nd[n].tau = tau;
    nd[n].T = fast_exp_neg(tau);
    nd[n].area = INFINITY;
    if (n > 1) update_area(nd, n - 1);
    if (n > l->m) {
        int best = 1;
        float best_area = nd[1].area;
        for (int i = 2; i < n; i++)
            if (nd[i].area < best_area) best_area = nd[i].area, best = i;
        for (int i = best; i < n; i++) nd[i] = nd[i + 1];
        n--;
        if (best > 1) update_area(nd, best - 1);
        if (best < n) update_area(nd, best);
    }
    l->n = n;
}

void ml_avsm_build_face(const ml_state *st, volux_vec3 p, int face, uint32_t *out) {
    const ml_layout *lay = &st->layout;
    const volux_volume *vol = st->rc.volume;
    int R = lay->res, m = lay->nodes, a = face >> 1, b = (a + 1) % 3, c = (a + 2) % 3;
    float sign = (face & 1) ? -1.0f : 1.0f, h = st->h;
    /* a texel spans 2/R of the face at unit distance */
    float cone = st->avsm_cone * 2.0f / (float)R;
    for (int j = 0; j < R; j++)
        for (int i = 0; i < R; i++) {
            float dir3[3];
            dir3[a] = sign;
            dir3[b] = 2.0f * ((float)i + 0.5f) / (float)R - 1.0f;
            dir3[c] = 2.0f * ((float)j + 0.5f) / (float)R - 1.0f;
            volux_vec3 dir = v3_normalize(v3(dir3[0], dir3[1], dir3[2]));
            node_list l;
            l.n = 0;
            l.m = m;
            l.nd[0] = (node){0.0f, 0.0f, 1.0f, INFINITY};
            volux_ray ray;
            if (volux_ray_clip(vol, p, dir, &ray)) {
                volux_march_iter it;
                volux_interval iv;
                volux_march_init(&it, &st->grid1, &ray, ray.t0, ray.t1);
                float tau = 0.0f;
                while (tau <= ML_TAU_STOP && volux_march_next(&it, &iv)) {
                    if (!(iv.sigma_max > 0.0f)) continue;
                    add_point(&l, iv.t0, tau); /* end of the empty stretch before */
                    if (cone > 0.0f) {
                        /* steps that follow the texel's footprint (its
                         * width grows as cone·distance): as many samples
                         * per texel width far away as near, instead of a
                         * voxel step out to the far side of the volume */
                        for (float s0 = iv.t0; s0 < iv.t1;) {
                            float st_len = fmaxf(h, cone * s0), s1 = fminf(s0 + st_len, iv.t1);
                            volux_vec3 q = v3_madd(ray.q0, ray.dq, 0.5f * (s0 + s1));
                            float s = vol->bricks ? volux_volume_sample_bricked(vol, q.x, q.y, q.z, vol->storage)
                                                  : volux_volume_sample_index(vol, q.x, q.y, q.z);
                            tau += volux_lut_sigma(&st->lut1, s) * (s1 - s0);
                            add_point(&l, s1, tau);
                            if (tau > ML_TAU_STOP || !(s1 > s0)) break;
                            s0 = s1;
                        }
                        continue;
                    }
                    for (int k = (int)floorf(iv.t0 / h);; k++) {
                        float s0 = (float)k * h, s1 = s0 + h;
                        if (s0 >= iv.t1) break;
                        if (s0 < iv.t0) s0 = iv.t0;
                        if (s1 > iv.t1) s1 = iv.t1;
                        if (!(s1 > s0)) continue;
                        volux_vec3 q = v3_madd(ray.q0, ray.dq, 0.5f * (s0 + s1));
                        float s = vol->bricks ? volux_volume_sample_bricked(vol, q.x, q.y, q.z, vol->storage)
                                              : volux_volume_sample_index(vol, q.x, q.y, q.z);
                        tau += volux_lut_sigma(&st->lut1, s) * (s1 - s0);
                        add_point(&l, s1, tau);
                        if (tau > ML_TAU_STOP) break;
                    }
                }
            }
            uint32_t *o = out + ((size_t)j * (size_t)R + (size_t)i) * (size_t)m;
            uint32_t last_tau = 0;
            for (int k = 0; k < m; k++) {
                if (k < l.n) {
                    const node *nk = &l.nd[k + 1];
                    float dc = nk->d * lay->inv_d_unit + 0.5f;
                    uint32_t dcode = dc >= 65535.0f ? 65535u : (uint32_t)dc;
                    last_tau = ml_tau_code(nk->tau);
                    o[k] = dcode << 16 | last_tau;
                } else {
                    o[k] = 0xffffu << 16 | last_tau; /* padding: the curve stays at its last value */
                }
            }
        }
}

float ml_raymarch_T(const ml_state *st, volux_vec3 p, volux_vec3 v, float dist) {
    if (!(dist > 0.0f)) return 1.0f;
    float stop = st->xi > 0.0f ? 30.0f / st->xi : INFINITY;
    return expf(-st->xi * ml_tau1(st, p, v3_scale(v, 1.0f / dist), dist, stop));
}
