/*
 * techniques/ao/march_lanes.h — ao's shading hook over lanes for the
 * shared packet march (render/packet_impl.h): the inscatter of ao.c per
 * lane, L_s = A(x)·(Σ_j p_g(ω_j·ω) E_j + L_amb), with the occlusion-volume
 * lookup as gathers; then the radiance per unit opacity of scatter_emit
 * (albedo·c·L_s + emission·(1 − albedo·c)·c). Not a normal header:
 * march_avx2.c and march_avx512.c include it after the lane vocabulary.
 *
 * Positional lights (irradiance and direction vary with the position) and
 * a flat volume keep the scalar per-sample function, called per lane.
 */
#include "ao.h"
#include "render/packet_impl.h"

DI void ao_hook(const void *tech, const pk_lanes *L, vm lit, vf c[3]) {
    const ao_state *st = tech;
    const volux_light_list *ls = &st->b.rc.lights;
    /* the directional model reads K bytes per node of two grids and sums
     * over K: its scalar shading per lane (the packets still march) */
    int scalar = st->directional || st->occ.dims[0] < 2 || st->occ.dims[1] < 2 || st->occ.dims[2] < 2;
    for (int i = 0; i < ls->n_direct; i++) scalar |= ls->direct[i].positional;
    if (scalar) {
        pk_shade_per_lane(tech, L, lit, c, volux_ao_shade_lane);
        return;
    }
    vf A;
    pk_grid_trilinear(st->occ.v, st->occ.dims, 1, L->q[0], L->q[1], L->q[2], lit, 0, 1, &A);
    vf Ls[3] = {f_set(ls->env_mean.x + st->ambient), f_set(ls->env_mean.y + st->ambient),
                f_set(ls->env_mean.z + st->ambient)};
    const float g = st->b.rc.g;
    const vf to_eye[3] = {f_neg(L->d[0]), f_neg(L->d[1]), f_neg(L->d[2])};
    for (int i = 0; i < ls->n_direct; i++) {
        const volux_prepared_light *l = &ls->direct[i];
        const vf tr[3] = {f_set(l->travel.x), f_set(l->travel.y), f_set(l->travel.z)};
        /* volux_hg_eval(g, travel·to_eye) */
        vf ct = dot3(tr, to_eye);
        vf den = f_sub(f_set(1.0f + g * g), f_mul(f_set(2.0f * g), ct));
        den = f_max(den, f_set(1e-12f));
        vf ph = f_div(f_set(VOLUX_INV_4PI * (1.0f - g * g)), f_mul(den, f_sqrt(den)));
        const float E[3] = {l->power.x, l->power.y, l->power.z};
        for (int k = 0; k < 3; k++) Ls[k] = f_add(Ls[k], f_mul(f_set(E[k]), ph));
    }
    const vf a = f_set(st->b.rc.albedo), e = f_set(st->b.emission), one = f_set(1.0f);
    for (int k = 0; k < 3; k++) {
        vf out = f_mul(f_mul(a, c[k]), f_mul(Ls[k], A));
        if (st->b.emission > 0.0f) out = f_add(out, f_mul(f_mul(e, f_sub(one, f_mul(a, c[k]))), c[k]));
        c[k] = out;
    }
}

VOLUX_PACKET_TILE(ao_packet_tile, ao_hook)

/* ------------------------------------------------------------ near field */

/* volux_lut_sigma per lane: the same clamps and unfused lerp. */
DI vf ao_lut_sigma_lanes(const volux_transfer_lut *lut, vf s) {
    const int last = lut->n - 1;
    vf u = f_mul(f_sub(s, f_set(lut->s_min)), f_set(lut->inv_ds));
    vm lo = m_andnot(f_gt(u, f_zero()), m_all()), hi = f_ge(u, f_set((float)last));
    vf uc = f_min(f_max(u, f_zero()), f_set((float)last));
    vi i = i_min(i_trunc(uc), i_set(last > 0 ? last - 1 : 0));
    vf f = f_sub(uc, f_from_i(i));
    const vm mid = m_andnot(m_or(lo, hi), m_all()); /* the clamped lanes read nothing */
    vf a = gather_f32_masked(lut->sigma_t, i, mid), b = gather_f32_masked(lut->sigma_t + 1, i, mid);
    vf r = lerp(a, b, f);
    r = sel(lo, f_set(lut->sigma_t[0]), r);
    return sel(hi, f_set(lut->sigma_t[last]), r);
}

/* The near field's build (ao.c: near_transmittance) with the directions
 * of a node as lanes: every direction takes the same steps, so a step is
 * one trilinear gather of σt per lane group. Same arithmetic and rounding
 * as the scalar build (unfused lerps, the same clamps) but for the vector
 * exp (≤ 2 ulp): a byte may differ by 1. */
DI void ao_near_lanes(const ao_dir_job *j, int z) {
    const scatter_dirw *g = j->out;
    const int *dims = j->sigma->dims;
    const vf zero = f_zero(), mx = f_set((float)(dims[0] - 1)), my = f_set((float)(dims[1] - 1)),
             mz = f_set((float)(dims[2] - 1));
    int32_t bytes[LANE_W];
    for (int y = 0; y < g->dims[1]; y++)
        for (int x = 0; x < g->dims[0]; x++) {
            volux_vec3 q;
            unsigned char *o;
            if (!ao_near_node(j, x, y, z, &q, &o)) continue; /* empty surroundings */
            for (int d0 = 0; d0 < g->stride; d0 += LANE_W) {
                const vf dx = f_load(j->dq[0] + d0), dy = f_load(j->dq[1] + d0), dz = f_load(j->dq[2] + d0);
                vf tau = zero;
                for (int i = 0; i < j->n_steps; i++) {
                    const vf t = f_set(j->step_mid[i]);
                    vf sx = f_add(f_set(q.x), f_mul(dx, t)), sy = f_add(f_set(q.y), f_mul(dy, t)),
                       sz = f_add(f_set(q.z), f_mul(dz, t));
                    vm in = m_and(m_and(m_and(f_ge(sx, zero), f_ge(sy, zero)), m_and(f_ge(sz, zero), f_ge(mx, sx))),
                                  m_and(f_ge(my, sy), f_ge(mz, sz)));
                    if (!m_bits(in)) continue;
                    vf val;
                    pk_grid_trilinear(j->sigma->v, dims, 1, sx, sy, sz, m_all(), 0, 1, &val);
                    vf sigma = ao_lut_sigma_lanes(j->lut, val);
                    tau = f_add(tau, f_mul(f_keep(sigma, in), f_set(j->step_len[i])));
                }
                vf W = f_keep(exp_nonpos(f_neg(tau)), m_andnot(f_gt(tau, f_set(11.5f)), m_all()));
                i_store(bytes, i_trunc(f_add(f_mul(W, f_set(255.0f)), f_set(0.5f))));
                for (int l = 0; l < LANE_W; l++) o[d0 + l] = d0 + l < g->K ? (unsigned char)bytes[l] : 0;
            }
        }
}

/* ------------------------------------------------------------ far field */

/* Pyramid level l at the lanes of m (index-space positions): as
 * volux_ao_mip_sample (the same clamps, unfused lerps); levels one node
 * thin along an axis take the scalar lookup per lane. */
DI vf ao_mip_lanes(const ao_state *st, int l, vf x, vf y, vf z, vm m) {
    const int *d = st->mip_dims[l];
    if (d[0] >= 2 && d[1] >= 2 && d[2] >= 2) {
        const vf c = f_set((float)(2 << l)), half = f_set(0.5f);
        vf out;
        pk_grid_trilinear(st->mip[l], d, 1, f_sub(f_div(f_add(x, half), c), half),
                          f_sub(f_div(f_add(y, half), c), half), f_sub(f_div(f_add(z, half), c), half), m, 0, 1,
                          &out);
        return out;
    }
    _Alignas(64) float qx[LANE_W], qy[LANE_W], qz[LANE_W], r[LANE_W];
    f_store(qx, x), f_store(qy, y), f_store(qz, z);
    for (int i = 0; i < LANE_W; i++)
        r[i] = (m_bits(m) >> i) & 1 ? volux_ao_mip_sample(st, l, v3(qx[i], qy[i], qz[i])) : 0.0f;
    return f_load(r);
}

/* The far field's build (ao.c: far_transmittance) with the directions of
 * a node as lanes: the doubling steps and their pyramid level are the
 * same for every direction, only where each leaves the box differs. */
DI void ao_far_lanes(const ao_dir_job *j, int z) {
    const scatter_dirw *g = j->out;
    const ao_state *st = j->st;
    const int *dims = st->b.rc.volume->dims;
    const float vox = st->b.rc.min_spacing;
    const vf zero = f_zero(), half = f_set(0.5f), eps = f_set(1e-12f), neps = f_set(-1e-12f);
    int32_t bytes[LANE_W];
    for (int y = 0; y < g->dims[1]; y++)
        for (int x = 0; x < g->dims[0]; x++) {
            volux_vec3 q;
            unsigned char *o = ao_dir_node(j, x, y, z, &q);
            const vf qv[3] = {f_set(q.x), f_set(q.y), f_set(q.z)};
            for (int d0 = 0; d0 < g->stride; d0 += LANE_W) {
                vf dq[3], t_exit = f_set(1e30f);
                for (int a = 0; a < 3; a++) {
                    dq[a] = f_load(j->dq[a] + d0);
                    vf up = f_div(f_sub(f_set((float)(dims[a] - 1)), qv[a]), dq[a]);
                    vf down = f_div(f_neg(qv[a]), dq[a]);
                    vf e = sel(f_gt(dq[a], eps), up, sel(f_lt(dq[a], neps), down, f_set(1e30f)));
                    t_exit = f_min(t_exit, e);
                }
                vf tau = zero;
                float t = st->radius;
                for (vm live = f_lt(f_set(t), t_exit); m_bits(live); live = f_lt(f_set(t), t_exit)) {
                    const float len = t, piece = len / (float)AO_FAR_SUB;
                    const int l = ao_far_level(st, piece, vox);
                    const vf end = f_min(f_set(t + len), t_exit);
                    for (int i = 0; i < AO_FAR_SUB; i++) {
                        const float a = t + (float)i * piece;
                        vf b = f_min(f_set(a + piece), end);
                        vm m = m_and(live, f_gt(b, f_set(a)));
                        if (!m_bits(m)) continue;
                        vf tm = f_mul(half, f_add(f_set(a), b));
                        vf s = ao_mip_lanes(st, l, f_add(qv[0], f_mul(dq[0], tm)), f_add(qv[1], f_mul(dq[1], tm)),
                                            f_add(qv[2], f_mul(dq[2], tm)), m);
                        tau = f_add(tau, f_keep(f_mul(s, f_sub(b, f_set(a))), m));
                    }
                    if (!m_bits(m_and(live, m_andnot(f_gt(tau, f_set(11.5f)), m_all())))) break;
                    t = t + len; /* lanes whose box ends before leave the loop */
                }
                vf W = f_keep(exp_nonpos(f_neg(tau)), m_andnot(f_gt(tau, f_set(11.5f)), m_all()));
                i_store(bytes, i_trunc(f_add(f_mul(W, f_set(255.0f)), f_set(0.5f))));
                for (int l = 0; l < LANE_W; l++) o[d0 + l] = d0 + l < g->K ? (unsigned char)bytes[l] : 0;
            }
        }
}
