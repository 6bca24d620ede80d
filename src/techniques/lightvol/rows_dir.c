/*
 * techniques/lightvol/rows_dir.c — one row of a directional light's
 * propagation (§4; Ropinski et al. 2010): every voxel fetches the light
 * where the line towards the light crosses the previous slice — the same
 * offset for the whole pass, so the row interior runs as vector loops with
 * constant bilinear weights — attenuated by the optical depth of the
 * segment (midpoint rule between the two slices' media) and, with forward
 * scattering, blended with a cone of taps around that point. The portable
 * loops are the reference; volux_lightvol_dir_row_simd hands the row to the
 * AVX2/AVX-512 kernels (propagate_avx2.c).
 *
 * Built with -fno-math-errno -fno-trapping-math (CMakeLists.txt): nothing
 * here reads errno or FP flags, and the row loops then vectorise.
 */

#include <math.h>
#include <string.h>

#include "core/vecmath.h"
#include "rows.h"

/* Optical depths of row v over directional entry e's segments (σt into
 * tau[0], κ_c into tau[1..3] when forward scattering): midpoint rule over
 * e->nsub points, the medium interpolated between the two slices. */
static void dir_tau(const lv_sweep *J, const lv_entry *e, int v, int u0, int u1, float *tau[4]) {
    const int mu = J->mu, np = J->nplanes;
    const size_t area = J->area;
    for (int q = 0; q < np; q++) memset(tau[q], 0, (size_t)mu * sizeof(float));
    for (int i = 0; i < e->nsub && !J->simd; i++) {
        const lv_tap t = e->ts[i];
        const float wp = e->wp[i], wc = e->wc[i];
        if (J->post && u1 > u0) {
            const float l = wp + wc, tf = wc / l;
            const float *P0 = J->mp + (ptrdiff_t)(v + t.dj) * mu + t.di, *P1 = P0 + mu;
            const float *C0 = J->mc + (ptrdiff_t)(v + t.dj) * mu + t.di, *C1 = C0 + mu;
            for (int u = u0; u < u1; u++) {
                float sp = t.w00 * P0[u] + t.w10 * P0[u + 1] + t.w01 * P1[u] + t.w11 * P1[u + 1];
                float sc = t.w00 * C0[u] + t.w10 * C0[u + 1] + t.w01 * C1[u] + t.w11 * C1[u + 1];
                float m[4];
                lv_classify_s(J, sp + (sc - sp) * tf, m);
                for (int q = 0; q < np; q++) tau[q][u] += l * m[q];
            }
        }
        for (int q = 0; q < np && !J->post; q++) {
            float *d = tau[q];
            if (u1 > u0) {
                const float *P0 = J->mp + (size_t)q * area + (ptrdiff_t)(v + t.dj) * mu + t.di, *P1 = P0 + mu;
                const float *C0 = J->mc + (size_t)q * area + (ptrdiff_t)(v + t.dj) * mu + t.di, *C1 = C0 + mu;
                for (int u = u0; u < u1; u++)
                    d[u] += wp * (t.w00 * P0[u] + t.w10 * P0[u + 1] + t.w01 * P1[u] + t.w11 * P1[u + 1]) +
                            wc * (t.w00 * C0[u] + t.w10 * C0[u + 1] + t.w01 * C1[u] + t.w11 * C1[u + 1]);
            }
        }
    }
    /* row ends: per voxel, outside taps see empty medium (the AVX2 kernel
     * does the whole row) */
    for (int i = 0; i < e->nsub && !J->simd; i++)
        for (int u = 0; u < mu; u++) {
            if (u == u0 && u1 > u0) {
                u = u1 - 1;
                continue;
            }
            float tq[4] = {0, 0, 0, 0};
            lv_med_accumulate(J, (float)u + e->su[i], (float)v + e->sv[i], e->wp[i], e->wc[i], np, tq);
            for (int q = 0; q < np; q++) tau[q][u] += tq[q];
        }
    if (J->simd) volux_lightvol_dir_tau_avx2(J, e, v, u0, u1, tau);
}

/* Directional light, row v: values into out[c][0..mu). */
void volux_lightvol_dir_row(const lv_sweep *J, const lv_entry *e, int v, float *out[3], float *T, float *Tc[3],
                            float *cone[3], float *cen[3], float *tau[4], const lv_entry **last) {
    int mu = J->mu, mv = J->mv;
    if (e->mode == E_INIT) {
        float pw[3] = {e->s->power.x, e->s->power.y, e->s->power.z};
        for (int c = 0; c < 3; c++)
            for (int u = 0; u < mu; u++) out[c][u] = pw[c];
        return;
    }
    /* Interior: every tap inside the slice, constant weights → vector loops. */
    int u0 = -e->di_min, u1 = mu - 1 - e->di_max; /* u in [u0, u1) */
    int row_ok = v + e->dj_min >= 0 && v + e->dj_max + 1 <= mv - 1;
    if (u0 < 0) u0 = 0;
    if (u1 > mu) u1 = mu;
    if (!row_ok || u1 < u0) u0 = u1 = 0;
    /* No medium anywhere in the row's footprint (sub-sample and cone taps
     * included): the light only moves on. */
    int empty = lv_rows_empty(J, v + e->dj_min - 1, v + e->dj_max + 2);
    /* Transmittances over the segments back to the previous slice; shared
     * by consecutive lights with the same geometry (same direction). */
    const lv_entry *l = *last;
    if (!empty && (!l || l->du != e->du || l->dv != e->dv || l->len != e->len)) {
        dir_tau(J, e, v, u0, u1, tau);
        {
            float *restrict Tr = T;
            const float *restrict t0 = tau[0];
            for (int u = 0; u < mu; u++) Tr[u] = volux_exp_neg_cw7(t0[u]);
        }
        if (J->forward)
            for (int c = 0; c < 3; c++) {
                const float *restrict tk = tau[1 + c];
                float *restrict tc = Tc[c];
                for (int u = 0; u < mu; u++) tc[u] = volux_exp_neg_cw7(tk[u]);
            }
        *last = e;
    }
    if (u1 > u0) {
        const lv_tap t = e->tc;
        for (int c = 0; c < 3; c++) {
            const float *p0 = e->rd[c] + (ptrdiff_t)(v + t.dj) * mu + t.di, *p1 = p0 + mu;
            float *cc = cen[c];
            for (int u = u0; u < u1; u++)
                cc[u] = t.w00 * p0[u] + t.w10 * p0[u + 1] + t.w01 * p1[u] + t.w11 * p1[u + 1];
        }
        if (J->cone && !empty) {
            for (int c = 0; c < 3; c++) {
                float *cn = cone[c];
                for (int u = u0; u < u1; u++) cn[u] = 0.0f;
                for (int q = 0; q < 4; q++) {
                    const lv_tap t2 = e->tcone[q];
                    const float *p0 = e->rd[c] + (ptrdiff_t)(v + t2.dj) * mu + t2.di, *p1 = p0 + mu;
                    for (int u = u0; u < u1; u++)
                        cn[u] += 0.25f * (t2.w00 * p0[u] + t2.w10 * p0[u + 1] + t2.w01 * p1[u] + t2.w11 * p1[u + 1]);
                }
            }
        }
    }
    /* Edges: generic fetch with outside taps. */
    for (int u = 0; u < mu; u++) {
        if (u == u0 && u1 > u0) {
            u = u1 - 1;
            continue;
        }
        float c3[3];
        lv_fetch(J, e, (float)u + e->du, (float)v + e->dv, c3);
        for (int c = 0; c < 3; c++) cen[c][u] = c3[c];
        if (J->cone && !empty) {
            float s3[3] = {0, 0, 0};
            for (int q = 0; q < 4; q++) {
                lv_fetch(J, e, (float)u + e->cu[q], (float)v + e->cv[q], c3);
                for (int c = 0; c < 3; c++) s3[c] += 0.25f * c3[c];
            }
            for (int c = 0; c < 3; c++) cone[c][u] = s3[c];
        }
    }
    /* Combine: direct part sharp, forward-scattered part from the cone. */
    if (empty) {
        for (int c = 0; c < 3; c++) memcpy(out[c], cen[c], (size_t)mu * sizeof(float));
        return;
    }
    for (int c = 0; c < 3; c++) {
        float *restrict o = out[c];
        const float *restrict cc = cen[c];
        if (!J->forward) {
            for (int u = 0; u < mu; u++) o[u] = T[u] * cc[u];
        } else if (!J->cone) {
            const float *restrict tc = Tc[c];
            for (int u = 0; u < mu; u++) o[u] = tc[u] * cc[u];
        } else {
            const float *restrict tc = Tc[c], *restrict cn = cone[c];
            for (int u = 0; u < mu; u++) o[u] = T[u] * cc[u] + (tc[u] - T[u]) * cn[u];
        }
    }
}

/* Directional light, row v, with the AVX2 kernels: as volux_lightvol_dir_row
 * followed by sweep_row's accumulation (sweep.c), the whole row in one fused
 * pass (volux_lightvol_dir_light_avx2/avx512; the row ends by lv_fetch()'s
 * rules per lane); the transmittances and footprint test shared with the
 * previous light of the same geometry. */
void volux_lightvol_dir_row_simd(const lv_sweep *J, const lv_entry *e, int v, float *out[3], float *T, float *Tc[3],
                                 float *tau[4], lv_row_geom *G, float *acc, int ch, float *S) {
    const int mu = J->mu, mv = J->mv;
    const size_t m = (size_t)mu;
    const int one = e->nch == 1;
    if (e->mode == E_INIT) {
        float pw[3] = {e->s->power.x, e->s->power.y, e->s->power.z};
        for (int c = 0; c < e->nch; c++)
            for (int u = 0; u < mu; u++) out[c][u] = pw[c];
        float *o3[3] = {out[0], out[one ? 0 : 1], out[one ? 0 : 2]};
        for (int c = 0; c < 3; c++) lv_accumulate(acc + (size_t)c * m, o3[c], e->sw * e->gain[c], mu);
        if (ch == 6) {
            volux_vec3 d = e->dsw;
            if (one) d = v3_scale(d, 0.2126f * e->gain[0] + 0.7152f * e->gain[1] + 0.0722f * e->gain[2]);
            if (one) lv_accumulate(acc + 3 * m, out[0], d.x, mu), lv_accumulate(acc + 4 * m, out[0], d.y, mu),
                lv_accumulate(acc + 5 * m, out[0], d.z, mu);
            else lv_accumulate_dir(acc + 3 * m, m, o3, d, mu);
        }
        return;
    }
    int u0 = -e->di_min, u1 = mu - 1 - e->di_max;
    int row_ok = v + e->dj_min >= 0 && v + e->dj_max + 1 <= mv - 1;
    if (u0 < 0) u0 = 0;
    if (u1 > mu) u1 = mu;
    if (!row_ok || u1 < u0) u0 = u1 = 0;
    /* a light with the previous one's geometry shares its footprint test and
     * transmittances */
    const lv_entry *l = G->e;
    const int same = l && l->du == e->du && l->dv == e->dv && l->len == e->len && l->dj_min == e->dj_min &&
                     l->dj_max == e->dj_max && l->di_min == e->di_min && l->di_max == e->di_max;
    int empty = same ? G->empty : lv_rows_empty(J, v + e->dj_min - 1, v + e->dj_max + 2);
    if (!same) G->e = e, G->empty = empty, G->have_T = 0;
    if (!empty && !G->have_T) {
        dir_tau(J, e, v, u0, u1, tau);
        volux_lightvol_exp_avx2(T, tau[0], mu);
        if (J->forward)
            for (int c = 0; c < 3; c++) volux_lightvol_exp_avx2(Tc[c], tau[1 + c], mu);
        G->have_T = 1;
    }
    if (J->avx512) volux_lightvol_dir_light_avx512(J, e, v, u0, u1, T, Tc, empty, out, acc, m, ch, S);
    else volux_lightvol_dir_light_avx2(J, e, v, u0, u1, T, Tc, empty, out, acc, m, ch, S);
}
