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

typedef struct node {
    float d, tau, T;
} node;

/* Streams the point (d, tau) into the list (Salvi's insertion + removal). */
static void add_point(node *nd, int *count, int m, float d, float tau) {
    int n = *count;
    /* A flat run (same τ as the last two nodes, or the start) only moves
     * its end: the middle node would have zero area anyway. */
    if (n > 0 && nd[n - 1].tau == tau && (n == 1 ? tau == 0.0f : nd[n - 2].tau == tau)) {
        nd[n - 1].d = d;
        return;
    }
    nd[n].d = d;
    nd[n].tau = tau;
    nd[n].T = expf(-tau);
    n++;
    if (n > m) {
        int best = 0;
        float best_area = INFINITY;
        for (int i = 0; i < n - 1; i++) {
            float ad = i > 0 ? nd[i - 1].d : 0.0f, aT = i > 0 ? nd[i - 1].T : 1.0f;
            const node *b = &nd[i], *c = &nd[i + 1];
            float area = fabsf((b->d - ad) * (c->T - aT) - (c->d - ad) * (b->T - aT));
            if (area < best_area) {
                best_area = area;
                best = i;
            }
        }
        memmove(&nd[best], &nd[best + 1], sizeof *nd * (size_t)(n - 1 - best));
        n--;
    }
    *count = n;
}

void ml_avsm_build_face(const ml_state *st, volux_vec3 p, int face, uint32_t *out) {
    const ml_layout *lay = &st->layout;
    int R = lay->res, m = lay->nodes, a = face >> 1, b = (a + 1) % 3, c = (a + 2) % 3;
    float sign = (face & 1) ? -1.0f : 1.0f, h = st->h;
    for (int j = 0; j < R; j++)
        for (int i = 0; i < R; i++) {
            float dir3[3];
            dir3[a] = sign;
            dir3[b] = 2.0f * ((float)i + 0.5f) / (float)R - 1.0f;
            dir3[c] = 2.0f * ((float)j + 0.5f) / (float)R - 1.0f;
            volux_vec3 dir = v3_normalize(v3(dir3[0], dir3[1], dir3[2]));
            node nd[ML_MAX_NODES + 1];
            int count = 0;
            volux_ray ray;
            if (volux_ray_clip(st->rc.volume, p, dir, &ray)) {
                volux_march_iter it;
                volux_interval iv;
                volux_march_init(&it, &st->grid1, &ray, ray.t0, ray.t1);
                float tau = 0.0f;
                while (volux_march_next(&it, &iv) && tau <= ML_TAU_STOP) {
                    if (!(iv.sigma_max > 0.0f)) continue;
                    add_point(nd, &count, m, iv.t0, tau); /* end of the empty stretch before */
                    for (int k = (int)floorf(iv.t0 / h);; k++) {
                        float s0 = (float)k * h, s1 = s0 + h;
                        if (s0 >= iv.t1) break;
                        if (s0 < iv.t0) s0 = iv.t0;
                        if (s1 > iv.t1) s1 = iv.t1;
                        if (!(s1 > s0)) continue;
                        volux_vec3 q = v3_madd(ray.q0, ray.dq, 0.5f * (s0 + s1));
                        float s = volux_volume_sample_index(st->rc.volume, q.x, q.y, q.z);
                        tau += volux_lut_sigma(&st->lut1, s) * (s1 - s0);
                        add_point(nd, &count, m, s1, tau);
                    }
                }
            }
            uint32_t *o = out + ((size_t)j * (size_t)R + (size_t)i) * (size_t)m;
            uint32_t last_tau = 0;
            for (int k = 0; k < m; k++) {
                if (k < count) {
                    float dc = nd[k].d * lay->inv_d_unit + 0.5f;
                    uint32_t dcode = dc >= 65535.0f ? 65535u : (uint32_t)dc;
                    last_tau = ml_tau_code(nd[k].tau);
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
