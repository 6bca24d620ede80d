/*
 * techniques/lightvol/rows_pos.c — one row of a positional light's
 * propagation (point, spot, sphere; §6): the buffers carry the intensity J
 * along the ray, initialised by the projection of the light onto the first
 * slice ahead of it (Fig. 5), and a voxel receives J/r² weighted by its own
 * Eq. 5 factor, since the direction to the light varies per voxel. The
 * previous-slice point moves affinely along a row, so the interior runs in
 * three vectorisable phases; the row ends and the slices next to the light
 * go voxel by voxel (pos_voxels). The AVX2 kernels (propagate_avx2.c) take
 * the interior when chosen.
 *
 * Built with -fno-math-errno -fno-trapping-math (CMakeLists.txt): nothing
 * here reads errno or FP flags, and the row loops then vectorise.
 */

#include <math.h>
#include <string.h>

#include "rows.h"

/* Outside-slice fallback of lv_fetch(), kept out of line. */
static __attribute__((noinline)) void fetch_slow(const lv_sweep *J, const lv_entry *e, float x, float y,
                                                 float out[3]) {
    lv_fetch(J, e, x, y, out);
}

/* Positional light, row v: ray values into out, weighted 1/r² contribution
 * into acc. Per voxel: direction, Eq. 5 factor, and the previous-slice
 * point on the line towards the light (x' = u − (u − l_u)·f: affine in u,
 * and the same row y' for the whole row). */
static void pos_voxels(const lv_sweep *J, const lv_entry *e, int v, int ua, int ub, float *out[3], float *acc, int ch) {
    const lightvol_state *st = J->st;
    const int mu = J->mu, mv = J->mv;
    const int a = J->a, au = J->au, av = J->av, np = J->nplanes, forward = J->forward, cone = J->cone;
    const float sa = st->spacing[a], su = st->spacing[au], sv = st->spacing[av];
    const float la = e->lidx[a], lu = e->lidx[au], lv = e->lidx[av];
    const float da = ((float)J->k - la) * sa, dvw = ((float)v - lv) * sv;
    const float f = e->f, rm2 = J->rmin2, sign = e->sign;
    const float pw[3] = {e->s->power.x, e->s->power.y, e->s->power.z};
    /* previous-slice row and its sub-sample rows are the same for the row */
    const float y = (float)v - ((float)v - lv) * f, ov = y - (float)v;
    float *accs[6];
    for (int c = 0; c < 6; c++) accs[c] = acc + (size_t)c * (size_t)mu;
    for (int u = ua; u < ub; u++) {
        float d[3];
        d[a] = da;
        d[au] = ((float)u - lu) * su;
        d[av] = dvw;
        float r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        float r = sqrtf(r2), ir = 1.0f / r;
        float w[3] = {d[0] * ir, d[1] * ir, d[2] * ir};
        float val[3];
        if (e->mode != E_PROP) {
            float p[3] = {pw[0], pw[1], pw[2]};
            if (e->s->spot) {
                float sf = lv_spot_factor(e->s, w[0] * e->s->dir.x + w[1] * e->s->dir.y + w[2] * e->s->dir.z);
                p[0] *= sf, p[1] *= sf, p[2] *= sf;
            }
            if (e->mode == E_INIT_ATT) {
                /* The light sits less than one slice before this one: the
                 * segment light → voxel stays between the two slices but may
                 * run far sideways; integrate it voxel by voxel (outside the
                 * box the medium is empty). */
                float tau[4] = {0, 0, 0, 0};
                float ou = lu - (float)u, ovl = lv - (float)v;
                /* only the part inside the slice's extent carries medium:
                 * t ∈ [0, t1] (0 at the voxel, 1 at the light) */
                float t1 = 1.0f;
                if (ou > 0.0f) t1 = fminf(t1, ((float)(mu - 1) - (float)u) / ou);
                if (ou < 0.0f) t1 = fminf(t1, -(float)u / ou);
                if (ovl > 0.0f) t1 = fminf(t1, ((float)(mv - 1) - (float)v) / ovl);
                if (ovl < 0.0f) t1 = fminf(t1, -(float)v / ovl);
                float lat = fmaxf(fabsf(ou), fabsf(ovl)) * t1;
                int n = lat <= 1.0f ? 1 : (int)fminf(ceilf(lat), (float)LV_MAX_INIT_SUB);
                float axial = (float)J->s * ((float)J->k - la); /* in (0, 1] */
                for (int i = 0; i < n; i++) {
                    float t = ((float)i + 0.5f) / (float)n * t1;
                    float px = (float)u + ou * t, py = (float)v + ovl * t;
                    float wprev = J->step > 0 ? t * axial : 0.0f; /* weight of slice kp at this point */
                    float wp = wprev * r * t1 / (float)n, wc = (1.0f - t * axial) * r * t1 / (float)n;
                    lv_med_accumulate(J, px, py, wp, wc, np, tau);
                }
                for (int c = 0; c < 3; c++) val[c] = p[c] * volux_exp_neg_cw7(tau[forward ? 1 + c : 0]);
            } else {
                for (int c = 0; c < 3; c++) val[c] = p[c];
            }
        } else {
            float ou = ((float)u - lu) * -f, x = (float)u + ou;
            float len = r * f;
            /* optical depth over the segment (midpoint rule, see dir_tau) */
            float tau[4] = {0, 0, 0, 0};
            float m = fabsf(ou) > fabsf(ov) ? fabsf(ou) : fabsf(ov);
            int n = m <= 1.0f ? 1 : (m >= (float)LV_MAX_SUB ? LV_MAX_SUB : (int)ceilf(m));
            float inv_n = 1.0f / (float)n;
            for (int i = 0; i < n; i++) {
                float t = ((float)i + 0.5f) * inv_n, px = (float)u + ou * (1.0f - t), py = (float)v + ov * (1.0f - t);
                lv_med_accumulate(J, px, py, (1.0f - t) * len * inv_n, t * len * inv_n, np, tau);
            }
            float cc[3];
            int inside = x >= 0.0f && y >= 0.0f && x <= (float)(mu - 1) && y <= (float)(mv - 1);
            if (inside) lv_fetch(J, e, x, y, cc);
            else fetch_slow(J, e, x, y, cc);
            float T = volux_exp_neg_cw7(tau[0]);
            if (!forward) {
                for (int c = 0; c < 3; c++) val[c] = T * cc[c];
            } else {
                float Tc[3];
                for (int c = 0; c < 3; c++) Tc[c] = volux_exp_neg_cw7(tau[1 + c]);
                if (!cone) {
                    for (int c = 0; c < 3; c++) val[c] = Tc[c] * cc[c];
                } else {
                    float rho = len * J->tan_c, ru = rho / su, rv = rho / sv;
                    float s3[3] = {0, 0, 0}, c3[3];
                    const float ox[4] = {ru, -ru, 0.0f, 0.0f}, oy[4] = {0.0f, 0.0f, rv, -rv};
                    int in4 = inside && x - ru >= 0.0f && y - rv >= 0.0f && x + ru <= (float)(mu - 1) &&
                              y + rv <= (float)(mv - 1);
                    for (int q = 0; q < 4; q++) {
                        if (in4) lv_fetch(J, e, x + ox[q], y + oy[q], c3);
                        else fetch_slow(J, e, x + ox[q], y + oy[q], c3);
                        for (int c = 0; c < 3; c++) s3[c] += 0.25f * c3[c];
                    }
                    for (int c = 0; c < 3; c++) val[c] = T * cc[c] + (Tc[c] - T) * s3[c];
                }
            }
        }
        for (int c = 0; c < 3; c++) out[c][u] = val[c];
        /* Eq. 5 factor of this group for the local direction; the group's
         * own component is positive here (the voxel lies ahead of the light) */
        const float mag[3] = {fabsf(w[0]), fabsf(w[1]), fabsf(w[2])};
        float wg = e->s->center ? lv_center_weight(e, u, v) : lv_axis_weight(mag, a);
        if (wg <= 0.0f) continue;
        float k = sign * wg / (r2 > rm2 ? r2 : rm2);
        /* (one channel: val[1], val[2] are not propagated; × gain = power) */
        const int one = e->nch == 1;
        float er = val[0] * k * e->gain[0], eg = (one ? val[0] : val[1]) * k * e->gain[1],
              eb = (one ? val[0] : val[2]) * k * e->gain[2];
        accs[0][u] += er;
        accs[1][u] += eg;
        accs[2][u] += eb;
        if (ch == 6) {
            float lum = 0.2126f * er + 0.7152f * eg + 0.0722f * eb;
            accs[3][u] += lum * w[0];
            accs[4][u] += lum * w[1];
            accs[5][u] += lum * w[2];
        }
    }
}

/* Positional light, row v. Propagation rows: the interior (every tap of
 * every voxel inside the slice) in three phases — geometry and Eq. 5
 * factors (vector loops), medium and light gathers without bounds checks,
 * transmittances and accumulation (vector loops); the row ends and the
 * initialisation slices per voxel (pos_voxels). */
void volux_lightvol_pos_row(const lv_sweep *J, const lv_entry *e, int v, float *out[3], float *acc, int ch,
                            float *scr) {
    const lightvol_state *st = J->st;
    const int mu = J->mu, mv = J->mv;
    if (e->mode == E_SKIP) {
        for (int c = 0; c < 3; c++) memset(out[c], 0, (size_t)mu * sizeof(float));
        return;
    }
    if (e->mode != E_PROP || mu < 8) {
        pos_voxels(J, e, v, 0, mu, out, acc, ch);
        return;
    }
    const size_t m = (size_t)mu, area = J->area;
    const int a = J->a, au = J->au, av = J->av, np = J->nplanes, forward = J->forward, cone = J->cone;
    const float su = st->spacing[au], sv = st->spacing[av];
    const float la = e->lidx[a], lu = e->lidx[au], lv = e->lidx[av];
    const float da = ((float)J->k - la) * st->spacing[a], dvw = ((float)v - lv) * sv;
    const float f = e->f, rm2 = J->rmin2, sign = e->sign, tan_c = J->tan_c;
    const float y = (float)v - ((float)v - lv) * f, ov = y - (float)v;
    /* scratch: X LEN K WA WU WV TAU[4] CEN[3] CON[3] = 16·mu floats; the
     * AVX2 kernels use the first 10 with a stride rounded up to 8 */
    const int simd = J->simd;
    const size_t ms = simd ? (m + 7) & ~(size_t)7 : m;
    float *restrict X = scr, *restrict LEN = X + ms, *restrict K = LEN + ms, *restrict WA = K + ms,
                    *restrict WU = WA + ms, *restrict WV = WU + ms, *TAU = WV + ms, *CEN = TAU + 4 * m, *CON = CEN + 3 * m;
    lv_pos_row R = {.v = v, .ms = ms, .X = X, .LEN = LEN, .K = K, .WA = WA, .WU = WU, .WV = WV, .TAU = TAU, .y = y};
    /* Phase 1: geometry, factor of this group, 1/r² (vector loops) */
    const float da2 = da * da, dv2 = dvw * dvw, ada = fabsf(da), adv = fabsf(dvw);
    const int center = e->s->center;
    if (simd) volux_lightvol_pos_geometry_avx2(J, e, &R);
    for (int u = 0; u < mu && !simd; u++) {
        float du = ((float)u - lu) * su, du2 = du * du;
        /* r² summed in x, y, z order like pos_voxels, so the factors of the
         * groups of a voxel match theirs exactly */
        float r2 = a == 0 ? (da2 + du2) + dv2 : a == 1 ? (du2 + da2) + dv2 : (du2 + dv2) + da2;
        float r = sqrtf(r2), ir = 1.0f / r;
        float mag[3];
        mag[a] = ada * ir;
        mag[au] = fabsf(du) * ir;
        mag[av] = adv * ir;
        float wg = center ? lv_center_weight(e, u, v) : lv_axis_weight(mag, a);
        K[u] = sign * wg / (r2 > rm2 ? r2 : rm2);
        WA[u] = da * ir;
        WU[u] = du * ir;
        WV[u] = dvw * ir;
        X[u] = (float)u - ((float)u - lu) * f;
        LEN[u] = r * f;
    }
    /* interior: X is increasing in u; cone radii are largest at a row end */
    float rho_max = cone ? fmaxf(LEN[0], LEN[mu - 1]) * tan_c : 0.0f;
    float ru_max = rho_max / su, rv_max = rho_max / sv;
    int u0 = 0, u1 = 0;
    if (y - rv_max >= 0.0f && y + rv_max <= (float)(mv - 1)) {
        u0 = 0;
        while (u0 < mu && X[u0] - ru_max < 0.0f) u0++;
        u1 = mu;
        while (u1 > u0 && X[u1 - 1] + ru_max > (float)(mu - 1)) u1--;
    }
    if (u1 > u0) {
        /* Phase 2: gathers. Rows of the previous slice are row constants. */
        float m0 = fabsf(X[0]), m1 = fabsf(X[mu - 1] - (float)(mu - 1));
        float lat = fmaxf(fmaxf(m0, m1), fabsf(ov));
        int n = lat <= 1.0f ? 1 : (lat >= (float)LV_MAX_SUB ? LV_MAX_SUB : (int)ceilf(lat));
        float inv_n = 1.0f / (float)n;
        int jrow[LV_MAX_SUB];
        float ay[LV_MAX_SUB], tt[LV_MAX_SUB];
        for (int i = 0; i < n; i++) {
            tt[i] = ((float)i + 0.5f) * inv_n;
            float py = (float)v + ov * (1.0f - tt[i]);
            int j = (int)py;
            if (j > mv - 2) j = mv - 2;
            jrow[i] = j;
            ay[i] = py - (float)j;
        }
        int jc = (int)y;
        if (jc > mv - 2) jc = mv - 2;
        float ayc = y - (float)jc;
        /* rows between v and y (and the cone's) without medium: T = 1 */
        int jlo = (int)floorf(fminf((float)v, y - rv_max)) - 1, jhi = (int)ceilf(fmaxf((float)v, y + rv_max)) + 1;
        int empty = lv_rows_empty(J, jlo, jhi);
        for (int q = 0; q < np; q++) memset(TAU + (size_t)q * ms + u0, 0, (size_t)(u1 - u0) * sizeof(float));
        if (simd) {
            R.u0 = u0, R.u1 = u1, R.n = n, R.inv_n = inv_n, R.jc = jc, R.ayc = ayc, R.empty = empty;
            for (int i = 0; i < n; i++) R.tt[i] = tt[i], R.ay[i] = ay[i], R.jrow[i] = jrow[i];
            if (!empty) volux_lightvol_pos_tau_avx2(J, &R);
            volux_lightvol_pos_light_avx2(J, e, &R, out, acc, m, ch);
            goto ends;
        }
        for (int i = 0; i < n && !empty; i++) {
            const float t = tt[i], om = 1.0f - t, ayi = ay[i];
            const size_t rb = (size_t)jrow[i] * m;
            for (int u = u0; u < u1; u++) {
                float px = (float)u + (X[u] - (float)u) * om;
                int ix = (int)px;
                if (ix > mu - 2) ix = mu - 2;
                float ax = px - (float)ix;
                float w00 = (1.0f - ax) * (1.0f - ayi), w10 = ax * (1.0f - ayi), w01 = (1.0f - ax) * ayi, w11 = ax * ayi;
                float wp = om * LEN[u] * inv_n, wc = t * LEN[u] * inv_n;
                size_t b = rb + (size_t)ix;
                if (J->post) {
                    const float *P = J->mp + b, *C = J->mc + b;
                    float sp = w00 * P[0] + w10 * P[1] + w01 * P[mu] + w11 * P[mu + 1];
                    float sc = w00 * C[0] + w10 * C[1] + w01 * C[mu] + w11 * C[mu + 1];
                    float mm[4];
                    lv_classify_s(J, sp + (sc - sp) * t, mm);
                    for (int q = 0; q < np; q++) TAU[(size_t)q * m + (size_t)u] += (wp + wc) * mm[q];
                    continue;
                }
                for (int q = 0; q < np; q++) {
                    const float *P = J->mp + (size_t)q * area + b, *C = J->mc + (size_t)q * area + b;
                    TAU[(size_t)q * m + (size_t)u] += wp * (w00 * P[0] + w10 * P[1] + w01 * P[mu] + w11 * P[mu + 1]) +
                                                      wc * (w00 * C[0] + w10 * C[1] + w01 * C[mu] + w11 * C[mu + 1]);
                }
            }
        }
        const float *R0 = e->rd[0], *R1 = e->rd[1], *R2 = e->rd[2];
        for (int u = u0; u < u1; u++) {
            float px = X[u];
            int ix = (int)px;
            if (ix > mu - 2) ix = mu - 2;
            float ax = px - (float)ix;
            size_t b = (size_t)jc * m + (size_t)ix;
            float w00 = (1.0f - ax) * (1.0f - ayc), w10 = ax * (1.0f - ayc), w01 = (1.0f - ax) * ayc, w11 = ax * ayc;
            CEN[u] = w00 * R0[b] + w10 * R0[b + 1] + w01 * R0[b + m] + w11 * R0[b + m + 1];
            CEN[m + (size_t)u] = w00 * R1[b] + w10 * R1[b + 1] + w01 * R1[b + m] + w11 * R1[b + m + 1];
            CEN[2 * m + (size_t)u] = w00 * R2[b] + w10 * R2[b + 1] + w01 * R2[b + m] + w11 * R2[b + m + 1];
        }
        if (cone && !empty)
            for (int u = u0; u < u1; u++) {
                float rho = LEN[u] * tan_c, ru = rho / su, rv = rho / sv;
                const float ox[4] = {ru, -ru, 0.0f, 0.0f}, oy[4] = {0.0f, 0.0f, rv, -rv};
                float s3[3] = {0, 0, 0};
                for (int q = 0; q < 4; q++) {
                    float c3[3];
                    lv_fetch(J, e, X[u] + ox[q], y + oy[q], c3);
                    for (int c = 0; c < 3; c++) s3[c] += 0.25f * c3[c];
                }
                for (int c = 0; c < 3; c++) CON[(size_t)c * m + (size_t)u] = s3[c];
            }
        /* Phase 3: transmittances, values, accumulation (vector loops) */
        float *restrict o0 = out[0], *restrict o1 = out[1], *restrict o2 = out[2];
        const float *restrict t0 = TAU;
        for (int u = u0; u < u1; u++) {
            float T = volux_exp_neg_cw7(t0[u]);
            float v0 = T * CEN[u], v1 = T * CEN[m + (size_t)u], v2 = T * CEN[2 * m + (size_t)u];
            if (forward && !empty) {
                float T0 = volux_exp_neg_cw7(TAU[m + (size_t)u]), T1 = volux_exp_neg_cw7(TAU[2 * m + (size_t)u]),
                      T2 = volux_exp_neg_cw7(TAU[3 * m + (size_t)u]);
                if (cone) {
                    v0 += (T0 - T) * CON[u];
                    v1 += (T1 - T) * CON[m + (size_t)u];
                    v2 += (T2 - T) * CON[2 * m + (size_t)u];
                } else {
                    v0 = T0 * CEN[u];
                    v1 = T1 * CEN[m + (size_t)u];
                    v2 = T2 * CEN[2 * m + (size_t)u];
                }
            }
            o0[u] = v0, o1[u] = v1, o2[u] = v2;
        }
        float *restrict a0 = acc, *restrict a1 = acc + m, *restrict a2 = acc + 2 * m;
        for (int u = u0; u < u1; u++) {
            float k = K[u];
            a0[u] += o0[u] * k;
            a1[u] += o1[u] * k;
            a2[u] += o2[u] * k;
        }
        if (ch == 6) {
            float *restrict ad[3] = {acc + 3 * m, acc + 4 * m, acc + 5 * m};
            float *restrict dx = ad[a], *restrict dy = ad[au], *restrict dz = ad[av];
            for (int u = u0; u < u1; u++) {
                float k = K[u];
                float lum = (0.2126f * o0[u] + 0.7152f * o1[u] + 0.0722f * o2[u]) * k;
                dx[u] += lum * WA[u];
                dy[u] += lum * WU[u];
                dz[u] += lum * WV[u];
            }
        }
    }
ends:
    if (u0 > 0) pos_voxels(J, e, v, 0, u0, out, acc, ch);
    if (u1 < mu) pos_voxels(J, e, v, u1 > u0 ? u1 : u0, mu, out, acc, ch);
}
