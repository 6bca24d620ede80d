/*
 * render/packet_impl.h — the packet camera-ray march of the illuminated
 * ray casters (`single`, `ao`, `lightvol`, ...), written once over the
 * lane vocabulary, with the technique's shading as a hook over lanes.
 * Not a normal header: a technique's `packet_avx2.c` / `packet_avx512.c`
 * include it once each after render/lanes_avx2.h or render/lanes_avx512.h
 * and its hook, then instantiate it with VOLUX_PACKET_TILE.
 *
 * WHAT IT COMPUTES: volux_ea_march (render/raycaster.h) for DVR_W rays at
 * a time — front-to-back emission–absorption over the segments of
 * sample/segment.h, pre-integrated (Engel et al. 2001) or point-sampled at
 * the segment's end, a segment of optical depth τ and emitted colour c
 * adding T·(1 − e^{−τ})·c — where the hook turns the TF colour c of the
 * compositing lanes into the radiance they emit per unit opacity (the
 * scalar march's `shade` hook, per lane). The scattering techniques'
 * scatter_march with lag 0 is this march with c → albedo·c·L_s + L_e
 * (their hooks say so).
 *
 * HOW: the ray list, packets, refill, skip check and pre-integration of
 * techniques/dvr/dvr_simd_impl.h (see its comments for the measurements
 * behind each choice), without `shaded`'s gradient and corner words:
 *   - the same segment positions (jitter from the same RNG stream) and
 *     sample positions as the scalar march, the same trilinear arithmetic
 *     on the volume's bricked copy (samples bit-identical);
 *   - the same pre-integration model, in float (render/packet.h's table);
 *   - skipping of segments inside 4³ skip cells that are exactly empty
 *     (their contribution is 0: skipping never changes pixels);
 *   - the same early-termination test (T < early_termination).
 * Differences from the scalar march are float rounding (vector exp ≤ 2
 * ulp, float integral tables, T −= T·α instead of T·(1 − α)) and whatever
 * the hook's lane arithmetic rounds differently; each technique's test
 * bounds them (tests/invariants/test_packet_march.c).
 *
 * THE HOOK: DI void HOOK(const void *tech, const pk_lanes *L, vm lit,
 * vf c[3]) — for the lanes of `lit` (others: ignore, leave c as is), c in:
 * the TF colour (σt-weighted mean over the segment with pre-integration),
 * c out: the radiance emitted per unit opacity. Lookups into the
 * technique's caches become gathers (gather_f32*); a hook that stays
 * scalar calls its per-sample function per lane with pk_shade_per_lane.
 */
#ifndef LANE_W
#error "render/packet_impl.h: include render/lanes_avx2.h or render/lanes_avx512.h first"
#endif

#include "core/camera_rays.h"
#include "core/rng.h"
#include "render/lanes_ops.h"
#include "render/raycaster.h"
#include "sample/primary.h"
#include "volux/render.h"

#define PK_NP 4 /* packets advanced together (latency hiding, as dvr_simd_impl.h) */

/* The lanes of one segment end, as the hook sees them. */
typedef struct pk_lanes {
    vf t;         /* ray parameter of the segment's end (world units)  */
    vf q[3];      /* index-space position q0 + dq·t                    */
    vf p[3];      /* world position o + d·t                            */
    vf d[3];      /* unit ray direction (away from the camera)         */
    vf s;         /* scalar value at the end                           */
    vf tau, len;  /* optical depth and length of the segment           */
} pk_lanes;

/* One lane as a scalar per-sample function sees it (pk_shade_per_lane). */
typedef void (*pk_lane_fn)(const void *tech, const volux_packet_lane *in, float c[3]);

/* The hook of a technique whose shading stays scalar: its per-sample
 * function once per lane of `lit`, the same arithmetic as its scalar march. */
DI void pk_shade_per_lane(const void *tech, const pk_lanes *L, vm lit, vf c[3], pk_lane_fn fn) {
    _Alignas(64) float t[LANE_W], q[3][LANE_W], p[3][LANE_W], d[3][LANE_W], s[LANE_W], tau[LANE_W],
        len[LANE_W], cc[3][LANE_W];
    f_store(t, L->t), f_store(s, L->s), f_store(tau, L->tau), f_store(len, L->len);
    for (int a = 0; a < 3; a++) {
        f_store(q[a], L->q[a]), f_store(p[a], L->p[a]), f_store(d[a], L->d[a]);
        f_store(cc[a], c[a]);
    }
    for (unsigned bits = (unsigned)m_bits(lit); bits; bits &= bits - 1) {
        const int l = __builtin_ctz(bits);
        volux_packet_lane in;
        in.p = v3(p[0][l], p[1][l], p[2][l]);
        in.q = v3(q[0][l], q[1][l], q[2][l]);
        in.d = v3(d[0][l], d[1][l], d[2][l]);
        in.t = t[l], in.s = s[l], in.tau = tau[l], in.len = len[l];
        float col[3] = {cc[0][l], cc[1][l], cc[2][l]};
        fn(tech, &in, col);
        cc[0][l] = col[0], cc[1][l] = col[1], cc[2][l] = col[2];
    }
    for (int a = 0; a < 3; a++) c[a] = f_load(cc[a]);
}

/* Trilinear lookup of the lanes of m into a grid with interleaved
 * channels (stride `ch` values per node, channels [c0, c0 + n)), x fastest,
 * at grid-index positions (x, y, z) clamped into [0, dim − 1]; the scalar
 * lookups' (scatter_grid_sample_index, lightvol's illum_at) clamps and
 * unfused arithmetic. The grid is float (`grid`) or bfloat16 (`grid16`,
 * core/bf16.h, padded by one value; `grid` NULL). Grids of one node along
 * an axis are not supported (callers keep the scalar hook there). */
DI void pk_grid_trilinear_any(const float *grid, const uint16_t *grid16, const int dims[3], int ch, vf x, vf y, vf z,
                              vm m, int c0, int n, vf *out) {
    const vf zero = f_zero();
    x = f_min(f_max(x, zero), f_set((float)(dims[0] - 1)));
    y = f_min(f_max(y, zero), f_set((float)(dims[1] - 1)));
    z = f_min(f_max(z, zero), f_set((float)(dims[2] - 1)));
    vi i = i_min(i_trunc(x), i_set(dims[0] - 2));
    vi j = i_min(i_trunc(y), i_set(dims[1] - 2));
    vi k = i_min(i_trunc(z), i_set(dims[2] - 2));
    vf fx = f_sub(x, f_from_i(i)), fy = f_sub(y, f_from_i(j)), fz = f_sub(z, f_from_i(k));
    const int sx = ch, sy = dims[0] * ch, sz = dims[1] * sy;
    vi b = i_mullo(i_add(i_mullo(i_add(i_mullo(k, i_set(dims[1])), j), i_set(dims[0])), i), i_set(ch));
    const int offs[8] = {0, sx, sy, sy + sx, sz, sz + sx, sz + sy, sz + sy + sx};
    for (int c = 0; c < n; c++) {
        vf v[8];
        for (int q = 0; q < 8; q++)
            v[q] = grid ? gather_f32_masked(grid + c0 + c + offs[q], b, m)
                        : gather_bf16_masked(grid16 + c0 + c + offs[q], b, m);
        vf c00 = lerp(v[0], v[1], fx), c10 = lerp(v[2], v[3], fx);
        vf c01 = lerp(v[4], v[5], fx), c11 = lerp(v[6], v[7], fx);
        vf a0 = lerp(c00, c10, fy), a1 = lerp(c01, c11, fy);
        out[c] = lerp(a0, a1, fz);
    }
}

DI void pk_grid_trilinear(const float *grid, const int dims[3], int ch, vf x, vf y, vf z, vm m, int c0, int n,
                          vf *out) {
    pk_grid_trilinear_any(grid, NULL, dims, ch, x, y, z, m, c0, n, out);
}

/* ------------------------------------------------------------ ray list */

enum { PK_RL_CAP = VOLUX_TILE_SIZE * VOLUX_TILE_SIZE + LANE_W };

typedef struct pk_ray_list {
    int n;
    float t0[PK_RL_CAP], t1[PK_RL_CAP], jit[PK_RL_CAP];
    float o[3][PK_RL_CAP], q0[3][PK_RL_CAP], dq[3][PK_RL_CAP], d[3][PK_RL_CAP];
    float bg[3][PK_RL_CAP];
    int32_t pix[PK_RL_CAP];
} pk_ray_list;

/* The tile's rays as volux_raycaster_tile sets them up (volux_primary_ray,
 * volux_ray_clip: the same bits, the operations of dvr_simd_impl.h's
 * build_ray_list), in blocks 4 pixels wide and LANE_W/4 tall; misses get
 * the background here. */
static LANE_TARGET void pk_build_ray_list(const volux_raycaster *rc, const volux_scene *scene,
                                          const volux_tile *tile, float *rgb, pk_ray_list *rl) {
    enum { BW = 4, BH = LANE_W / 4 };
    const volux_camera *cam = &rc->camera;
    const volux_volume *vol = rc->volume;
    const int ortho = cam->projection == VOLUX_ORTHOGRAPHIC, centred = tile->sample_index == 0;
    volux_vec3 lo, hi;
    volux_volume_bounds(vol, &lo, &hi);
    const volux_vec3 inv_fwd = v3_inverse(cam->forward);
    const volux_vec3 bg_fwd = ortho ? volux_scene_escape_radiance(scene, cam->forward) : v3(0, 0, 0);
    volux_vec3 off_x[VOLUX_TILE_SIZE], off_y[VOLUX_TILE_SIZE];
    if (centred) {
        for (int x = 0; x < tile->w; x++) off_x[x] = volux_camera_offset_x(cam, (float)(tile->x0 + x) + 0.5f);
        for (int y = 0; y < tile->h; y++) off_y[y] = volux_camera_offset_y(cam, (float)(tile->y0 + y) + 0.5f);
    }
    int n = 0;
    for (int by = 0; by < tile->h; by += BH)
        for (int bx = 0; bx < tile->w; bx += BW)
            for (int y = by; y < by + BH && y < tile->h; y++)
                for (int x = bx; x < bx + BW && x < tile->w; x++) {
                    const int px = tile->x0 + x, py = tile->y0 + y;
                    float jx, jy;
                    const float jitter = volux_primary_numbers(cam, rc->seed, px, py, tile->sample_index, &jx, &jy);
                    volux_vec3 o, d;
                    if (centred)
                        volux_camera_ray_offsets(cam, off_x[x], off_y[y], &o, &d);
                    else
                        volux_camera_ray_offsets(cam, volux_camera_offset_x(cam, (float)px + jx),
                                                 volux_camera_offset_y(cam, (float)py + jy), &o, &d);
                    const volux_vec3 e = ortho ? bg_fwd : volux_scene_escape_radiance(scene, d);
                    volux_ray ray;
                    if (!volux_ray_clip_hoisted(vol, lo, hi, o, d, ortho ? inv_fwd : v3_inverse(d), &ray)) {
                        float *out = &rgb[3 * (y * tile->w + x)];
                        out[0] = e.x, out[1] = e.y, out[2] = e.z;
                        continue;
                    }
                    rl->bg[0][n] = e.x, rl->bg[1][n] = e.y, rl->bg[2][n] = e.z;
                    rl->t0[n] = ray.t0;
                    rl->t1[n] = ray.t1;
                    rl->jit[n] = jitter;
                    rl->o[0][n] = o.x, rl->o[1][n] = o.y, rl->o[2][n] = o.z;
                    rl->q0[0][n] = ray.q0.x, rl->q0[1][n] = ray.q0.y, rl->q0[2][n] = ray.q0.z;
                    rl->dq[0][n] = ray.dq.x, rl->dq[1][n] = ray.dq.y, rl->dq[2][n] = ray.dq.z;
                    rl->d[0][n] = d.x, rl->d[1][n] = d.y, rl->d[2][n] = d.z;
                    rl->pix[n] = y * tile->w + x;
                    n++;
                }
    for (int i = n; i < n + LANE_W; i++) { /* padding read by refills, then ignored */
        rl->t0[i] = rl->t1[i] = rl->jit[i] = 0.0f;
        for (int a = 0; a < 3; a++) rl->o[a][i] = rl->q0[a][i] = rl->dq[a][i] = rl->d[a][i] = rl->bg[a][i] = 0.0f;
        rl->pix[i] = 0;
    }
    rl->n = n;
}

/* ------------------------------------------------------------- march */

typedef struct pk_packet {
    vf t0, t1, jit, o[3], q0[3], dq[3], d[3];
    vf kf, T, C[3], t_check;
    vm active, warm, occupied;
    vi id;
    vf u_p, f_p, P_p[4], D_p[4]; /* previous segment end (pre-integration) */
    vi i_p;
    skipv sk;
} pk_packet;

typedef struct pk_consts {
    const volux_packet_march *pm;
    vol_consts vc;
    vf h, inv_h;
} pk_consts;

DI vf pk_seg_start(const pk_packet *ps, vf kf, vf h) {
    /* segment k: [max(t0, t0+(k−1+j)·h), min(t0+(k+j)·h, t1)] */
    vf k1 = f_add(f_sub(kf, f_set(1.0f)), ps->jit);
    return f_max(ps->t0, f_add(ps->t0, f_mul(k1, h)));
}

DI void pk_retire(const pk_packet *ps, vm done, const pk_ray_list *rl, float *rgb) {
    _Alignas(64) float c[3][LANE_W], t[LANE_W];
    _Alignas(64) int32_t id[LANE_W];
    for (int a = 0; a < 3; a++) f_store(c[a], ps->C[a]);
    f_store(t, ps->T);
    i_store(id, ps->id);
    for (unsigned bits = (unsigned)m_bits(done); bits; bits &= bits - 1) {
        int l = __builtin_ctz(bits), r = id[l];
        float *out = &rgb[3 * rl->pix[r]];
        out[0] = c[0][l] + t[l] * rl->bg[0][r];
        out[1] = c[1][l] + t[l] * rl->bg[1][r];
        out[2] = c[2][l] + t[l] * rl->bg[2][r];
    }
}

DI void pk_refill(const pk_consts *mc, pk_packet *ps, const pk_ray_list *rl, int *next, int preint) {
    const volux_packet_march *pm = mc->pm;
    vm free_lanes = m_andnot(ps->occupied, m_all());
    int want = __builtin_popcount((unsigned)m_bits(free_lanes)), left = rl->n - *next;
    vm fill = want <= left ? free_lanes : m_first_of(free_lanes, left);
    vi rank = lane_ranks(fill);
    const int at = *next;
    *next += want <= left ? want : left;
    ps->t0 = f_pick(ps->t0, fill, rl->t0 + at, rank);
    ps->t1 = f_pick(ps->t1, fill, rl->t1 + at, rank);
    ps->jit = f_pick(ps->jit, fill, rl->jit + at, rank);
    for (int a = 0; a < 3; a++) {
        ps->o[a] = f_pick(ps->o[a], fill, rl->o[a] + at, rank);
        ps->q0[a] = f_pick(ps->q0[a], fill, rl->q0[a] + at, rank);
        ps->dq[a] = f_pick(ps->dq[a], fill, rl->dq[a] + at, rank);
        ps->d[a] = f_pick(ps->d[a], fill, rl->d[a] + at, rank);
    }
    ps->id = isel(fill, i_add(rank, i_set(at)), ps->id);
    const vf zero = f_zero(), one = f_set(1.0f);
    ps->occupied = m_or(ps->occupied, fill);
    vm fresh = m_and(fill, f_lt(ps->t0, ps->t1));
    ps->active = m_or(ps->active, fresh);
    ps->T = sel(fill, one, ps->T);
    for (int c = 0; c < 3; c++) ps->C[c] = sel(fill, zero, ps->C[c]);
    vf k = zero;
    if (pm->skip) {
        skipv *sk = &ps->sk;
        for (int a = 0; a < 3; a++) {
            sk->up[a] = f_gt(ps->dq[a], zero);
            sk->flat[a] = f_eq(ps->dq[a], zero);
            sk->inv_dq[a] = f_div(one, ps->dq[a]);
        }
        vf t_exit, m;
        vm empty = check_cells(pm->pk->skip_dist, sk, ps->q0, ps->dq, ps->t0, ps->jit, mc->inv_h, ps->t0, fresh,
                               &t_exit, &m);
        k = sel(m_and(empty, f_gt(m, zero)), m, zero);
        ps->t_check = sel(fresh, t_exit, sel(fill, f_set(INFINITY), ps->t_check));
    } else {
        ps->t_check = f_set(INFINITY);
    }
    if (preint) {
        ps->kf = sel(fill, f_sub(k, one), ps->kf);
        ps->warm = m_or(ps->warm, fill);
    } else {
        ps->kf = sel(fill, k, ps->kf);
        ps->warm = m_andnot(fill, ps->warm);
    }
}

typedef void (*pk_hook_fn)(const void *tech, const pk_lanes *L, vm lit, vf c[3]);

DI void pk_march_tile(const pk_consts *mc, const void *tech, const pk_ray_list *rl, float *rgb, uint64_t *samples,
                      int preint, volux_storage storage, pk_hook_fn hook) {
    const volux_packet_march *pm = mc->pm;
    const volux_transfer_lut *lut = pm->lut;
    const int skip = pm->skip;
    const vf zero = f_zero(), one = f_set(1.0f), h = mc->h;
    const vf t_min = f_set(pm->t_min), len_scale = f_set(lut->inv_ds);
    pk_packet P[PK_NP];
    int next = 0;
    for (int p = 0; p < PK_NP; p++) {
        pk_packet *ps = &P[p];
        memset(ps, 0, sizeof *ps);
        ps->active = ps->warm = ps->occupied = m_none();
        ps->id = i_zero();
        ps->i_p = i_zero();
        ps->t_check = f_set(INFINITY);
        if (skip) {
            const int *cells = pm->pk->skip_cells;
            for (int a = 0; a < 3; a++) ps->sk.cells_max[a] = i_set(cells[a] - 1);
            ps->sk.ncx = i_set(cells[0]);
            ps->sk.ncy = i_set(cells[1]);
        }
    }
    uint64_t count = 0;
    for (;;) {
        int any = 0;
        for (int p = 0; p < PK_NP; p++) {
            pk_packet *ps = &P[p];
            vm done = m_andnot(ps->active, ps->occupied);
            if (m_bits(done)) {
                pk_retire(ps, done, rl, rgb);
                ps->occupied = m_andnot(done, ps->occupied);
            }
            if (next < rl->n && !m_bits(ps->occupied)) pk_refill(mc, ps, rl, &next, preint);
            any |= m_bits(ps->active);
        }
        if (!any) break;
        vf a[PK_NP], b[PK_NP], len[PK_NP], kf_next[PK_NP], s[PK_NP];
        vm seg[PK_NP], jump[PK_NP];
        int seg_bits[PK_NP];
        /* Phase 1: segment bounds, activity, the skip check. */
        for (int p = 0; p < PK_NP; p++) {
            pk_packet *ps = &P[p];
            a[p] = pk_seg_start(ps, ps->kf, h);
            ps->active = m_and(ps->active, f_lt(a[p], ps->t1));
            b[p] = f_max(f_min(f_add(ps->t0, f_mul(f_add(ps->kf, ps->jit), h)), ps->t1), ps->t0);
            len[p] = f_sub(b[p], a[p]);
            seg[p] = m_and(ps->active, m_or(f_gt(len[p], zero), ps->warm));
            seg_bits[p] = m_bits(seg[p]);
            kf_next[p] = f_add(ps->kf, one);
            jump[p] = m_none();
            if (skip) {
                vm need = m_and(ps->active, f_ge(b[p], ps->t_check));
                if (m_bits(need)) {
                    vf t_exit, m;
                    vm empty = check_cells(pm->pk->skip_dist, &ps->sk, ps->q0, ps->dq, ps->t0, ps->jit, mc->inv_h,
                                           b[p], need, &t_exit, &m);
                    if (preint) m = f_sub(m, one); /* land warm one segment early (dvr_simd_impl.h) */
                    jump[p] = m_and(empty, f_gt(m, kf_next[p]));
                    kf_next[p] = sel(jump[p], m, kf_next[p]);
                    ps->t_check = sel(need, t_exit, ps->t_check);
                }
            }
        }
        /* Phase 2: the samples at the segment ends. */
        for (int p = 0; p < PK_NP; p++)
            if (seg_bits[p]) {
                const pk_packet *ps = &P[p];
                s[p] = sample_v(&mc->vc, f_add(ps->q0[0], f_mul(ps->dq[0], b[p])),
                                f_add(ps->q0[1], f_mul(ps->dq[1], b[p])), f_add(ps->q0[2], f_mul(ps->dq[2], b[p])),
                                storage, 0, NULL);
                count += (uint64_t)__builtin_popcount((unsigned)seg_bits[p]);
            }
        /* Phase 3: classification, pre-integration, shading, compositing. */
        for (int p = 0; p < PK_NP; p++) {
            pk_packet *ps = &P[p];
            if (seg_bits[p]) {
                vf tau, c[3], u, f;
                vi i;
                lut_coord_v(lut, s[p], &u, &i, &f);
                if (preint) {
                    vf Pr[4], D[4], num[4];
                    pre_record_v(pm->pk->pre_f, i, Pr, D);
                    vm same = i_eq(i, ps->i_p), fwd = i_gt(i, ps->i_p);
                    for (int ch = 0; ch < 4; ch++) { /* ΔI, as dvr_simd_impl.h */
                        vf x = f_sub(Pr[ch], ps->P_p[ch]);
                        vf up = f_fmadd(f, D[ch], f_fnmadd(ps->f_p, ps->D_p[ch], x));
                        vf down = f_fnmadd(ps->f_p, ps->D_p[ch], f_fmadd(f, D[ch], x));
                        num[ch] = sel(same, D[ch], sel(fwd, up, down));
                    }
                    vf du = sel(same, one, f_sub(u, ps->u_p));
                    vf per_u = f_div(one, du);
                    tau = f_mul(f_mul(len[p], len_scale), f_mul(num[0], per_u));
                    vm ok = f_gt(tau, zero);
                    vf inv = f_keep(f_div(one, num[0]), ok);
                    for (int ch = 0; ch < 3; ch++) c[ch] = f_mul(num[1 + ch], inv);
                    ps->u_p = u, ps->f_p = f, ps->i_p = i;
                    for (int ch = 0; ch < 4; ch++) ps->P_p[ch] = Pr[ch], ps->D_p[ch] = D[ch];
                } else {
                    vf o[8];
                    load_rows8(lut->rgba, i_slli(i, 2), o);
                    for (int ch = 0; ch < 3; ch++) c[ch] = lerp(o[ch], o[4 + ch], f);
                    tau = f_mul(lerp(o[3], o[7], f), len[p]);
                }
                vm lit = m_andnot(ps->warm, m_and(seg[p], f_gt(tau, zero)));
                if (m_bits(lit)) {
                    pk_lanes L;
                    L.t = b[p], L.s = s[p], L.tau = tau, L.len = len[p];
                    for (int ax = 0; ax < 3; ax++) {
                        L.q[ax] = f_add(ps->q0[ax], f_mul(ps->dq[ax], b[p]));
                        L.p[ax] = f_add(ps->o[ax], f_mul(ps->d[ax], b[p]));
                        L.d[ax] = ps->d[ax];
                    }
                    hook(tech, &L, lit, c);
                }
                vf alpha = f_sub(one, exp_nonpos(f_neg(tau)));
                vf w = f_keep(f_mul(ps->T, alpha), lit);
                for (int ch = 0; ch < 3; ch++) ps->C[ch] = f_add(ps->C[ch], f_mul(w, c[ch]));
                ps->T = f_sub(ps->T, w);
                ps->active = m_andnot(f_lt(ps->T, t_min), ps->active);
            }
            ps->warm = preint ? jump[p] : m_none();
            ps->kf = kf_next[p];
        }
    }
    *samples += count;
}

DI void pk_render_tile(const volux_packet_march *pm, const void *tech, const volux_scene *scene,
                       const volux_tile *tile, float *rgb, volux_tile_stats *stats, int preint,
                       volux_storage storage, pk_hook_fn hook) {
    pk_ray_list rl_, *rl = &rl_;
    pk_build_ray_list(pm->rc, scene, tile, rgb, rl);
    if (!rl->n) return;
    pk_consts mc;
    mc.pm = pm;
    vol_consts_init(&mc.vc, pm->rc->volume, NULL);
    mc.h = f_set(pm->rc->step);
    mc.inv_h = f_set(1.0f / pm->rc->step);
    uint64_t samples = 0;
    pk_march_tile(&mc, tech, rl, rgb, &samples, preint, storage, hook);
    stats->samples += samples;
}

/* Defines `static LANE_TARGET void NAME(const volux_packet_march *pm, const
 * void *tech, scene, tile, rgb, stats)`: the packet march with hook HOOK,
 * specialised per pre-integration and storage type, FTZ/DAZ while it runs
 * (as the dvr kernels: transmittance products underflow on long opaque
 * rays), the caller's MXCSR restored. */
#define VOLUX_PACKET_TILE(NAME, HOOK)                                                                            \
    static LANE_TARGET __attribute__((noinline)) void NAME##_impl(                                               \
        const volux_packet_march *pm, const void *tech, const volux_scene *scene, const volux_tile *tile,         \
        float *rgb, volux_tile_stats *stats) {                                                                   \
        const volux_storage st_ = pm->rc->volume->storage;                                                       \
        if (pm->preint) {                                                                                        \
            if (st_ == VOLUX_STORE_U8) pk_render_tile(pm, tech, scene, tile, rgb, stats, 1, VOLUX_STORE_U8, HOOK); \
            else if (st_ == VOLUX_STORE_U16)                                                                     \
                pk_render_tile(pm, tech, scene, tile, rgb, stats, 1, VOLUX_STORE_U16, HOOK);                     \
            else pk_render_tile(pm, tech, scene, tile, rgb, stats, 1, VOLUX_STORE_F32, HOOK);                    \
        } else {                                                                                                 \
            if (st_ == VOLUX_STORE_U8) pk_render_tile(pm, tech, scene, tile, rgb, stats, 0, VOLUX_STORE_U8, HOOK); \
            else if (st_ == VOLUX_STORE_U16)                                                                     \
                pk_render_tile(pm, tech, scene, tile, rgb, stats, 0, VOLUX_STORE_U16, HOOK);                     \
            else pk_render_tile(pm, tech, scene, tile, rgb, stats, 0, VOLUX_STORE_F32, HOOK);                    \
        }                                                                                                        \
    }                                                                                                            \
    static LANE_TARGET void NAME(const volux_packet_march *pm, const void *tech, const volux_scene *scene,        \
                                 const volux_tile *tile, float *rgb, volux_tile_stats *stats) {                   \
        unsigned int csr_ = _mm_getcsr();                                                                        \
        _mm_setcsr(csr_ | 0x8040u); /* FTZ | DAZ */                                                              \
        NAME##_impl(pm, tech, scene, tile, rgb, stats);                                                          \
        _mm_setcsr(csr_);                                                                                        \
    }
