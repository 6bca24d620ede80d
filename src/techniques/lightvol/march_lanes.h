/*
 * techniques/lightvol/march_lanes.h — lightvol's shading hook over lanes
 * for the shared packet march (render/packet_impl.h): the illumination
 * volume lookup becomes gathers, the rest is shade_at in lightvol.c per
 * lane (the same operations, unfused, in the same order). Not a normal
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

DI void lv_hook(const void *tech, const pk_lanes *L, vm lit, vf c[3]) {
    const lightvol_state *st = tech;
    const int local = st->p.local_shading > 0.0f && st->grad.grad;
    if (local || st->p.show_illumination) {
        pk_shade_per_lane(tech, L, lit, c, volux_lightvol_shade_lane);
        return;
    }
    const int need_dir = st->ch == 6 && st->rc.g != 0.0f;
    vf I[6];
    pk_grid_trilinear_any(st->volf, st->vol, st->dims, st->ch, f_mul(L->q[0], f_set(st->data_to_ill[0])),
                          f_mul(L->q[1], f_set(st->data_to_ill[1])), f_mul(L->q[2], f_set(st->data_to_ill[2])), lit, 0,
                          need_dir ? 6 : 3, I);
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
