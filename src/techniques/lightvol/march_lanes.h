/*
 * techniques/lightvol/march_lanes.h — lightvol's shading hook over lanes
 * for the shared packet march (render/packet_impl.h): the illumination
 * volume lookup becomes gathers, the rest is shade_at in lightvol.c per
 * lane (the same operations, unfused, in the same order; the RGB of the
 * 6-channel volume by row loads, lv_illum_rgb6). Not a normal
 * header: march_avx2.c and march_avx512.c include it after the lane
 * vocabulary.
 *
 * Local shading (gradient Blinn–Phong) and `show: "illumination"` keep the
 * scalar per-sample function, called per lane (pk_shade_per_lane).
 */
#include "lightvol.h"
#include "render/packet_impl.h"

/* hg(g, cosθ) as lightvol.c's hg: 1/(4π)·(1 − g²)/(d·√d), d = 1 + g² − 2g·cosθ */
DI vf lv_hg_v(vf g, vf cos_theta) {
    vf g2 = f_mul(g, g);
    vf d = f_sub(f_add(f_set(1.0f), g2), f_mul(f_mul(f_set(2.0f), g), cos_theta));
    return f_div(f_mul(f_set(VOLUX_INV_4PI), f_sub(f_set(1.0f), g2)), f_mul(d, f_sqrt(d)));
}

/* The RGB channels of a 6-channel illumination volume (RGB + mean light
 * direction, interleaved per node) at grid-index (x, y, z): pk_grid_trilinear
 * with the same clamps and the same lerps in the same order (bit-identical),
 * but each corner row's node x (6 channels) and node x+1's first two come
 * in one 8-float row load per lane (load_rows8, transposed), leaving one
 * gather per row for node x+1's blue: 4 gathers instead of 24. The row
 * load never leaves the array (node x+1 exists: x ≤ dims − 2). */
DI void lv_illum_rgb6(const lightvol_state *st, vf x, vf y, vf z, vm m, vf out[3]) {
    const int *dims = st->dims;
    const vf zero = f_zero();
    x = f_min(f_max(x, zero), f_set((float)(dims[0] - 1)));
    y = f_min(f_max(y, zero), f_set((float)(dims[1] - 1)));
    z = f_min(f_max(z, zero), f_set((float)(dims[2] - 1)));
    vi i = i_min(i_trunc(x), i_set(dims[0] - 2));
    vi j = i_min(i_trunc(y), i_set(dims[1] - 2));
    vi k = i_min(i_trunc(z), i_set(dims[2] - 2));
    vf fx = f_sub(x, f_from_i(i)), fy = f_sub(y, f_from_i(j)), fz = f_sub(z, f_from_i(k));
    const int sy = dims[0] * 6, sz = dims[1] * sy;
    const int rows[4] = {0, sy, sz, sz + sy}; /* corner rows (y, z), (y+1, z), (y, z+1), (y+1, z+1) */
    vi b = i_mullo(i_add(i_mullo(i_add(i_mullo(k, i_set(dims[1])), j), i_set(dims[0])), i), i_set(6));
    vf r[4][3];
    for (int q = 0; q < 4; q++) {
        vf o[8];
        load_rows8(st->vol, i_add(b, i_set(rows[q])), o);
        vf blue1 = gather_f32_masked(st->vol + rows[q] + 8, b, m);
        r[q][0] = lerp(o[0], o[6], fx);
        r[q][1] = lerp(o[1], o[7], fx);
        r[q][2] = lerp(o[2], blue1, fx);
    }
    for (int c = 0; c < 3; c++) {
        vf a0 = lerp(r[0][c], r[1][c], fy), a1 = lerp(r[2][c], r[3][c], fy);
        out[c] = lerp(a0, a1, fz);
    }
}

DI void lv_hook(const void *tech, const pk_lanes *L, vm lit, vf c[3]) {
    const lightvol_state *st = tech;
    const int local = st->p.local_shading > 0.0f && st->grad.grad;
    if (local || st->p.show_illumination) {
        pk_shade_per_lane(tech, L, lit, c, volux_lightvol_shade_lane);
        return;
    }
    const int need_dir = st->ch == 6 && st->rc.g != 0.0f;
    vf I[6];
    const vf qx = f_mul(L->q[0], f_set(st->data_to_ill[0])), qy = f_mul(L->q[1], f_set(st->data_to_ill[1])),
             qz = f_mul(L->q[2], f_set(st->data_to_ill[2]));
    if (st->ch == 6 && !need_dir) lv_illum_rgb6(st, qx, qy, qz, lit, I);
    else pk_grid_trilinear(st->vol, st->dims, st->ch, qx, qy, qz, lit, 0, need_dir ? 6 : 3, I);
    const vf zero = f_zero();
    vf E[3] = {f_max(I[0], zero), f_max(I[1], zero), f_max(I[2], zero)};
    vf lum = f_add(f_add(f_mul(f_set(0.2126f), E[0]), f_mul(f_set(0.7152f), E[1])), f_mul(f_set(0.0722f), E[2]));
    vm on = f_gt(lum, zero);
    vf phase = f_set(VOLUX_INV_4PI);
    if (need_dir) {
        vf D[3] = {I[3], I[4], I[5]};
        vf dl = f_sqrt(dot3(D, D));
        vm has = m_and(on, f_gt(dl, zero));
        if (m_bits(has)) {
            vf inv = f_div(f_set(1.0f), sel(has, dl, f_set(1.0f)));
            vf wbar[3] = {f_mul(D[0], inv), f_mul(D[1], inv), f_mul(D[2], inv)};
            vf r = f_min(f_div(dl, sel(on, lum, f_set(1.0f))), f_set(1.0f));
            vf ph = lv_hg_v(f_mul(f_set(st->rc.g), r), f_neg(dot3(wbar, L->d)));
            phase = sel(has, ph, phase);
        }
    }
    const vf a = f_set(st->rc.albedo);
    for (int k = 0; k < 3; k++) c[k] = f_keep(f_mul(f_mul(f_mul(a, c[k]), E[k]), phase), on);
}

VOLUX_PACKET_TILE(lv_packet_tile, lv_hook)
