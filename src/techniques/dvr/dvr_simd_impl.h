/*
 * techniques/dvr/dvr_simd_impl.h — the `ea` / `shaded` packet ray caster
 * written once for both vector widths. Not a normal header: dvr_avx2.c
 * (8 lanes) and dvr_avx512.c (16 lanes) each include it once, after
 * defining the lane vocabulary listed below (every operation is one or a
 * few instructions whose result, lane by lane, is the IEEE operation it
 * names), so the two widths compute every lane with the same operations
 * in the same order: their images are bit-identical
 * (tests/invariants/test_ea_fastpath.c).
 *
 * Layout (bricks and 16×16 tiles measured ~2× faster for oblique rays on
 * the development machines): lanes gather their trilinear corners from the
 * volume's bricked copy (8³ cells as 9³ nodes, so the 8 corners are at 4
 * fixed offsets: one 32-bit gather returns a corner pair for 8- and 16-bit
 * data) and read their transfer-function records with one 32-byte load
 * each, transposed into 8 vectors (cheaper than 8 gathers).
 *
 * Ray list: a tile's rays that hit the volume are set up first (in blocks
 * 4 pixels wide and DVR_W/4 tall, so a packet's lanes are neighbours and
 * stay close in the volume) into a list; a packet takes the next DVR_W
 * rays of the list when all of its rays have ended (left the volume, or
 * early termination). Refilling lanes as soon as some rays end (ray
 * streaming, so lanes never idle) was measured and dropped: the refilled
 * lanes come from other pixel blocks, the packet's gathers lose their
 * locality, and on bonsai (Zen 4, 1 thread) `shaded` took 12–14 % and
 * `ea` 2–3 % longer at both widths (docs/BENCHMARKS.md). A lane's
 * arithmetic never depends on the other lanes, so the order in which rays
 * are marched cannot change a pixel.
 *
 * Same image as the scalar kernel in dvr.c, lane by lane:
 *   - the same segment positions (fixed grid t0 + (k−1+jitter)·h, the same
 *     RNG stream for the jitter), the same sample positions and trilinear
 *     arithmetic (no FMA contraction there, so samples are bit-identical);
 *   - the same pre-integration model (see march_packets), evaluated in
 *     float from dvr_state.pk.pre_f instead of double;
 *   - empty-space skipping that only drops segments lying inside skip cells
 *     (4³, finer than the scalar kernel's 8³ macrocells) where σt = 0 on
 *     every table node of the cell's value range: their contribution is
 *     exactly 0, so skipping never changes pixels;
 *   - the same early-termination test.
 * Differences are float rounding (exp approximation ≤ 2 ulp, float
 * integral tables); tests/invariants/test_ea_fastpath.c bounds them.
 *
 * `shaded` runs here too when all its lights are directional: the bricked
 * 10-bit gradient cache (dvr.c) is read at the sample's cell with 64-bit
 * gathers, and Blinn–Phong uses vector log/exp for the specular power.
 *
 * Vocabulary (render/lanes_avx2.h, render/lanes_avx512.h; the width-generic
 * helpers — volume samples, TF records, skip check, exp/log — in
 * render/lanes_ops.h, the tables in render/packet.h; DI = static
 * always_inline with the width's target):
 *   DVR_W, DVR_NP        lanes, packets marched together
 *   vf, vi, vm           float lanes, int32 lanes, lane mask
 *   f_* / i_*            arithmetic, compares (→ vm), conversions
 *   sel(m, a, b)         a where m, else b (isel for vi); f_keep(v, m): v
 *                        where m, else +0
 *   m_* and m_bits       mask logic, the mask as an int (bit l = lane l)
 *   gather_*             the volume (bricks or corner words), gradient and
 *                        skip-distance reads
 *   load_rows8           rows of 8 floats, one per lane, transposed
 *   lane_ranks/f_pick    the ray-list refill (see refill)
 */

#ifndef DVR_W
#error "dvr_simd_impl.h: include the lane vocabulary first (see dvr_avx2.c)"
#endif

#include "render/lanes_ops.h"

/* Interpolated gradient (world units) from the bricked 10-bit cache at the
 * sample's cell: the same corner order and arithmetic as
 * volux_gradient_cache_sample. Only the lanes of m read the cache (the
 * others get 0): lanes that composite nothing would otherwise fetch cache
 * lines of a 4-byte-per-node array for nothing. */
DI void gradient_v(const dvr_state *st, const cellv *cell, vm m, vf g[3]) {
    vi w0[4], w1[4]; /* node x and x+1 of each corner row */
    gather_gradient_rows(st->grad.grad, cell->b, m, w0, w1);
    const vf scale = f_set(st->grad.scale);
    for (int a = 0; a < 3; a++) {
        const int up = 22 - 10 * a;
#define VOLUX_FIELD_(w) f_from_i(i_srai(i_slli(w, up), 22))
        vf c00 = lerp(VOLUX_FIELD_(w0[0]), VOLUX_FIELD_(w1[0]), cell->fx);
        vf c10 = lerp(VOLUX_FIELD_(w0[1]), VOLUX_FIELD_(w1[1]), cell->fx);
        vf c01 = lerp(VOLUX_FIELD_(w0[2]), VOLUX_FIELD_(w1[2]), cell->fx);
        vf c11 = lerp(VOLUX_FIELD_(w0[3]), VOLUX_FIELD_(w1[3]), cell->fx);
#undef VOLUX_FIELD_
        vf c0 = lerp(c00, c10, cell->fy), c1 = lerp(c01, c11, cell->fy);
        g[a] = f_mul(lerp(c0, c1, cell->fz), scale);
    }
}

/* `gradient: "cell"`: the gradient of the trilinear interpolant in the
 * sample's cell from its 8 corners, as volux_cell_gradient_bricked. The
 * corners are read again (the sample's gathers just brought their lines
 * into L1) rather than kept: 8 more live vectors per packet would spill. */
DI void gradient_cell_v(const vol_consts *vc, const cellv *cell, volux_storage storage, int words, vm m, vf g[3]) {
    vf c[8];
    if (!words && (storage == VOLUX_STORE_U8 || storage == VOLUX_STORE_U16)) {
        rows_to_corners(cell->rows, storage, c); /* kept by sample_v */
    } else if (storage == VOLUX_STORE_U8 || storage == VOLUX_STORE_U16) {
        /* only the compositing lanes m read (as gradient_v) */
        const int u8 = storage == VOLUX_STORE_U8, shift = u8 ? 8 : 16;
        const vi lo = i_set(u8 ? 0xff : 0xffff);
        vi w[4];
        gather_rows_masked(vc->bricks, cell->b, m, u8 ? 1 : 2, w);
        for (int r = 0; r < 4; r++) {
            c[2 * r] = f_from_i(i_and(w[r], lo));
            c[2 * r + 1] = f_from_i(i_and(i_srli(w[r], shift), lo));
        }
    } else {
        fetch_corners(vc, cell->b, storage, c, NULL);
    }
    /* ∂/∂x: the x-differences of the 4 rows blended over (y, z); likewise y, z */
    vf gx = lerp(lerp(f_sub(c[1], c[0]), f_sub(c[3], c[2]), cell->fy),
                 lerp(f_sub(c[5], c[4]), f_sub(c[7], c[6]), cell->fy), cell->fz);
    vf gy = lerp(lerp(f_sub(c[2], c[0]), f_sub(c[3], c[1]), cell->fx),
                 lerp(f_sub(c[6], c[4]), f_sub(c[7], c[5]), cell->fx), cell->fz);
    vf gz = lerp(lerp(f_sub(c[4], c[0]), f_sub(c[5], c[1]), cell->fx),
                 lerp(f_sub(c[6], c[2]), f_sub(c[7], c[3]), cell->fx), cell->fy);
    g[0] = f_mul(gx, vc->inv_sp[0]);
    g[1] = f_mul(gy, vc->inv_sp[1]);
    g[2] = f_mul(gz, vc->inv_sp[2]);
}


/* Per-lane half vectors h = normalize(L − view) of the directional lights:
 * constant along a ray, so computed once per ray, not per sample. */
DI void half_vectors(const dvr_state *st, const vf view[3], vf hn[DVR_SIMD_MAX_LIGHTS][3]) {
    const vf one = f_set(1.0f), zero = f_zero();
    for (int i = 0; i < st->rc.lights.n_direct && i < DVR_SIMD_MAX_LIGHTS; i++) {
        const volux_prepared_light *l = &st->rc.lights.direct[i];
        vf hv[3] = {f_sub(f_set(-l->travel.x), view[0]), f_sub(f_set(-l->travel.y), view[1]),
                    f_sub(f_set(-l->travel.z), view[2])};
        vf hl = f_sqrt(dot3(hv, hv));
        vf hinv = f_div(one, hl);
        vm hpos = f_gt(hl, zero);
        for (int a = 0; a < 3; a++) hn[i][a] = sel(hpos, f_mul(hv[a], hinv), hv[a]);
    }
}

/* Blinn–Phong for directional lights, as shade() in dvr.c: normal flipped
 * towards the viewer, faded by gradient magnitude; c: colour in/out.
 * 1/|g| is the IEEE 1/sqrt (not the rsqrt estimate, whose bits differ
 * between CPU makers and widths), so images do not depend on the CPU. */
DI void shade_v(const dvr_state *st, const vf g[3], const vf view[3], const vf hn[DVR_SIMD_MAX_LIGHTS][3], vf c[3]) {
    const vf zero = f_zero(), one = f_set(1.0f);
    const volux_material *mat = &st->rc.material;
    vf g2 = dot3(g, g);
    vf gl = f_sqrt(g2);
    vf inv = f_div(one, gl);
    vf m = st->grad_ref > 0.0f ? f_mul(gl, f_set(1.0f / st->grad_ref)) : one;
    vm on = f_gt(m, zero);
    if (!m_bits(on)) return;
    m = f_min(m, one);
    vf n[3];
    for (int a = 0; a < 3; a++) n[a] = f_mul(g[a], inv);
    vm flip = f_gt(dot3(n, view), zero);
    for (int a = 0; a < 3; a++) n[a] = sel(flip, f_neg(n[a]), n[a]);
    const float amb[3] = {st->ambient.x, st->ambient.y, st->ambient.z};
    vf diff[3], spec[3] = {zero, zero, zero};
    for (int a = 0; a < 3; a++) diff[a] = f_set(amb[a] * mat->ambient);
    for (int i = 0; i < st->rc.lights.n_direct && i < DVR_SIMD_MAX_LIGHTS; i++) {
        const volux_prepared_light *l = &st->rc.lights.direct[i];
        const vf L[3] = {f_set(-l->travel.x), f_set(-l->travel.y), f_set(-l->travel.z)};
        const float E[3] = {l->power.x, l->power.y, l->power.z};
        vf ndl = dot3(n, L);
        vm lit = f_gt(ndl, zero);
        vf kd = f_keep(f_mul(f_set(mat->diffuse), ndl), lit);
        vf ndh = dot3(n, hn[i]);
        vm sp = m_and(lit, f_gt(ndh, zero));
        vf pw = exp_nonpos(f_mul(f_set(mat->specular_power), log_pos(sel(sp, ndh, one))));
        vf ks = f_keep(f_mul(f_set(mat->specular), pw), sp);
        for (int a = 0; a < 3; a++) {
            diff[a] = f_add(diff[a], f_mul(f_set(E[a]), kd));
            spec[a] = f_add(spec[a], f_mul(f_set(E[a]), ks));
        }
    }
    for (int a = 0; a < 3; a++) {
        vf lit_c = f_add(f_mul(c[a], diff[a]), spec[a]);
        c[a] = sel(on, f_add(c[a], f_mul(f_sub(lit_c, c[a]), m)), c[a]);
    }
}

/* ------------------------------------------------------------ ray list */

/* A tile's rays that hit the volume, structure of arrays, with DVR_W
 * entries of padding so a refill may read a full vector past the end. */
enum { RL_CAP = VOLUX_TILE_SIZE * VOLUX_TILE_SIZE + DVR_W };

typedef struct ray_list {
    int n;
    float t0[RL_CAP], t1[RL_CAP], jit[RL_CAP];
    float q0[3][RL_CAP], dq[3][RL_CAP], d[3][RL_CAP];
    float bg[3][RL_CAP];
    int32_t pix[RL_CAP]; /* pixel index y·w + x in the tile */
} ray_list;

/* Ray set-up for every pixel of the tile, with the same bits as the
 * scalar kernel's per-pixel volux_primary_ray + volux_ray_clip (same RNG
 * stream, the same float operations: core/camera_rays.h,
 * volux_ray_clip_hoisted); misses get the background here. What does not
 * change across the tile is computed once: the volume box, the camera-plane
 * offset of each column and row (pixel centres, sample 0) and, for an
 * orthographic camera, the direction's inverse and the background — per
 * pixel that was ≈ 18 % of an `ea` frame at step 4 (three divisions and two
 * out-of-line calls for the clip, two divisions for the camera ray). Pixels
 * are visited in blocks 4 wide and DVR_W/4 tall, so consecutive rays
 * (neighbouring lanes) are neighbours in the image. */
static DVR_TARGET void build_ray_list(const dvr_state *st, const volux_scene *scene, const volux_tile *tile,
                                      float *rgb, ray_list *rl) {
    enum { BW = 4, BH = DVR_W / 4 };
    const volux_camera *cam = &st->rc.camera;
    const volux_volume *vol = st->rc.volume;
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
                    const float jitter =
                        volux_primary_numbers(cam, st->rc.seed, px, py, tile->sample_index, &jx, &jy);
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
                    rl->q0[0][n] = ray.q0.x, rl->q0[1][n] = ray.q0.y, rl->q0[2][n] = ray.q0.z;
                    rl->dq[0][n] = ray.dq.x, rl->dq[1][n] = ray.dq.y, rl->dq[2][n] = ray.dq.z;
                    rl->d[0][n] = d.x, rl->d[1][n] = d.y, rl->d[2][n] = d.z;
                    rl->pix[n] = y * tile->w + x;
                    n++;
                }
    /* the padding is read by refills (and then ignored): keep it defined */
    for (int i = n; i < n + DVR_W; i++) {
        rl->t0[i] = rl->t1[i] = rl->jit[i] = 0.0f;
        for (int a = 0; a < 3; a++) rl->q0[a][i] = rl->dq[a][i] = rl->d[a][i] = rl->bg[a][i] = 0.0f;
        rl->pix[i] = 0;
    }
    rl->n = n;
}

/* ------------------------------------------------------------- march */

/* Why DVR_NP packets in one loop: one sample is a ~200-cycle dependency
 * chain (position → brick index → gather → trilinear → table coordinate →
 * record loads → pre-integration → exp → compositing) but only ~80 cycles
 * of execution-port work per 8 lanes, so a single packet leaves the core
 * idle waiting on latencies. Independent packets, advanced phase by phase,
 * give the out-of-order core other chains to work on: measured (ML 256³,
 * dense, pre-integrated, AVX2) 120 M samples/s with 1 packet, 158 with 2,
 * 171 with 4 (docs/BENCHMARKS.md).
 *
 * Pre-integration model (shared with dvr.c): the running integrals
 * I(u) = P[i] + f·D[i] are linear inside a table interval, so a segment
 * whose ends fall in one interval has τ = len·D/Δs_node and c = D_c/D, and
 * otherwise τ = len·ΔI/Δs, c = ΔI_c/ΔI. In float, ΔI for ends in different
 * intervals is evaluated as (P_c − P_p) − f_p·D_p + f_c·D_c, fused in the
 * order that makes the cancelling pair exact: for adjacent intervals
 * P_c − P_p is exactly D of the lower one (D is the float difference of the
 * float P, dvr.c), so e.g. going up fma(−f_p, D_p, D_p) = D_p·(1 − f_p)
 * rounds once and the rest adds positive terms; only relative rounding
 * remains. So the absolute error of τ per segment is at most
 * ≈ 3·2⁻²⁴·len·(n−1)·σ̄ (σ̄ = mean σt over the value range; ≈ 4e-4·len·σ̄
 * for n = 4096) and vanishes where σt = 0; c inherits the same bound in
 * w·c. No division by a tiny Δs ever happens.
 *
 * A segment's front sample (pre-integration) is the previous segment's
 * end. Where there is none — a new ray, or after a skip — the lane spends
 * one iteration "warm" on the segment before: it samples that segment's
 * end (= the front it needs) and composites nothing. */
typedef struct packet_state {
    vf t0, t1, jit, q0[3], dq[3], d[3];
    vf kf, T, C[3], t_check;
    vm active, warm, occupied;        /* occupied: the lane holds a ray */
    vi id;                            /* its index in the ray list      */
    vf u_p, f_p, P_p[4], D_p[4];      /* previous segment end (pre-integration) */
    vi i_p;
    skipv sk;
    vf hn[DVR_SIMD_MAX_LIGHTS][3];    /* shaded: half vectors per light */
} packet_state;

typedef struct march_consts {
    const dvr_state *st;
    vol_consts vc;
    vf h, inv_h;
    int shaded, preint, skip;
    int prefetch;     /* prefetch_cells of a later sample (coarse steps) */
    float pf_ahead;   /* segments beyond the next one to prefetch       */
    volux_storage storage;
    int words;        /* 8-bit corner words instead of the bricks       */
    int grad_cell;    /* shaded: gradient_cell_v, else the cache        */
} march_consts;

DI vf seg_start(const packet_state *ps, vf kf, vf h) {
    /* segment k: [max(t0, t0+(k−1+j)·h), min(t0+(k+j)·h, t1)] */
    vf k1 = f_add(f_sub(kf, f_set(1.0f)), ps->jit);
    return f_max(ps->t0, f_add(ps->t0, f_mul(k1, h)));
}

DI vf sample_at_t(const vol_consts *vc, const packet_state *ps, vf t, volux_storage storage, int words,
                    cellv *cell) {
    return sample_v(vc, f_add(ps->q0[0], f_mul(ps->dq[0], t)), f_add(ps->q0[1], f_mul(ps->dq[1], t)),
                    f_add(ps->q0[2], f_mul(ps->dq[2], t)), storage, words, cell);
}

/* Writes the lanes of `done` (their rays have finished) to the tile:
 * c + T·background, the scalar kernel's expression. */
DI void retire(const packet_state *ps, vm done, const ray_list *rl, float *rgb) {
    _Alignas(64) float c[3][DVR_W], t[DVR_W];
    _Alignas(64) int32_t id[DVR_W];
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

/* Gives the free lanes of a packet the next rays of the list (as many as
 * there are), set up as the start of a ray: the segment-0 skip check at
 * t0, and with pre-integration a warm iteration on the segment before the
 * first one visited. */
DI void refill(const march_consts *mc, packet_state *ps, const ray_list *rl, int *next) {
    const dvr_state *st = mc->st;
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
    if (mc->shaded) {
        vf hn[DVR_SIMD_MAX_LIGHTS][3];
        half_vectors(st, ps->d, hn);
        for (int i = 0; i < st->rc.lights.n_direct && i < DVR_SIMD_MAX_LIGHTS; i++)
            for (int a = 0; a < 3; a++) ps->hn[i][a] = sel(fill, hn[i][a], ps->hn[i][a]);
    }
    vf k = zero;
    if (mc->skip) {
        skipv *sk = &ps->sk;
        for (int a = 0; a < 3; a++) {
            sk->up[a] = f_gt(ps->dq[a], zero);
            sk->flat[a] = f_eq(ps->dq[a], zero);
            sk->inv_dq[a] = f_div(one, ps->dq[a]);
        }
        /* the check of segment 0, at t0 */
        vf t_exit, m;
        vm empty = check_cells(st->pk.skip_dist, sk, ps->q0, ps->dq, ps->t0, ps->jit, mc->inv_h, ps->t0, fresh, &t_exit,
                               &m);
        k = sel(m_and(empty, f_gt(m, zero)), m, zero);
        ps->t_check = sel(fresh, t_exit, sel(fill, f_set(INFINITY), ps->t_check));
    } else {
        ps->t_check = f_set(INFINITY);
    }
    if (mc->preint) {
        ps->kf = sel(fill, f_sub(k, one), ps->kf);
        ps->warm = m_or(ps->warm, fill);
    } else {
        ps->kf = sel(fill, k, ps->kf);
        ps->warm = m_andnot(fill, ps->warm);
    }
}

DI void march_tile(const march_consts *mc, const ray_list *rl, float *rgb, uint64_t *samples) {
    const dvr_state *st = mc->st;
    const volux_transfer_lut *lut = st->rc.lut;
    const int shaded = mc->shaded, preint = mc->preint, skip = mc->skip;
    const volux_storage storage = mc->storage;
    const int words = mc->words;
    const vf zero = f_zero(), one = f_set(1.0f), h = mc->h;
    const vf t_min = f_set(st->t_min), len_scale = f_set(lut->inv_ds);
    packet_state P[DVR_NP];
    int next = 0;
    for (int p = 0; p < DVR_NP; p++) {
        packet_state *ps = &P[p];
        memset(ps, 0, sizeof *ps);
        ps->active = ps->warm = ps->occupied = m_none();
        ps->id = i_zero();
        ps->i_p = i_zero();
        ps->t_check = f_set(INFINITY);
        if (skip) {
            const int *cells = st->pk.skip_cells;
            for (int a = 0; a < 3; a++) ps->sk.cells_max[a] = i_set(cells[a] - 1);
            ps->sk.ncx = i_set(cells[0]);
            ps->sk.ncy = i_set(cells[1]);
        }
    }
    uint64_t count = 0;
    for (;;) {
        /* Lanes whose rays ended give their pixel back; a packet whose
         * rays have all ended takes the next block of rays (see the top of
         * this file for why not earlier). */
        int any = 0;
        for (int p = 0; p < DVR_NP; p++) {
            packet_state *ps = &P[p];
            vm done = m_andnot(ps->active, ps->occupied);
            if (m_bits(done)) {
                retire(ps, done, rl, rgb);
                ps->occupied = m_andnot(done, ps->occupied);
            }
            int busy = __builtin_popcount((unsigned)m_bits(ps->occupied));
            if (next < rl->n && !busy) refill(mc, ps, rl, &next);
            any |= m_bits(ps->active);
        }
        if (!any) break;
        vf a[DVR_NP], b[DVR_NP], len[DVR_NP], kf_next[DVR_NP], s[DVR_NP];
        vm seg[DVR_NP], jump[DVR_NP];
        cellv cells[DVR_NP];
        int seg_bits[DVR_NP];
        /* Phase 1: segment bounds, activity, the pipelined skip check. */
        for (int p = 0; p < DVR_NP; p++) {
            packet_state *ps = &P[p];
            a[p] = seg_start(ps, ps->kf, h);
            ps->active = m_and(ps->active, f_lt(a[p], ps->t1));
            /* (the max only lifts the end of the warm segment before
             * segment 0 onto t0: the front of segment 0) */
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
                    vm empty = check_cells(st->pk.skip_dist, &ps->sk, ps->q0, ps->dq, ps->t0, ps->jit, mc->inv_h, b[p],
                                           need, &t_exit, &m);
                    /* With pre-integration the lane lands one segment early,
                     * on m − 1 (inside the empty cube, contribution 0), and
                     * spends that iteration warm. Cheaper than an extra
                     * sampling pass for the whole packet whenever one lane
                     * jumps. */
                    if (preint) m = f_sub(m, one);
                    jump[p] = m_and(empty, f_gt(m, kf_next[p]));
                    kf_next[p] = sel(jump[p], m, kf_next[p]);
                    ps->t_check = sel(need, t_exit, ps->t_check);
                }
            }
        }
        /* Phase 2: the samples at the segment ends. */
        for (int p = 0; p < DVR_NP; p++)
            if (seg_bits[p]) {
                s[p] = sample_at_t(&mc->vc, &P[p], b[p], storage, words, shaded ? &cells[p] : NULL);
                count += (uint64_t)__builtin_popcount((unsigned)seg_bits[p]);
            }
        /* while the samples above are gathered: prefetch the cells of the
         * segment end pf_ahead after the next (see render_tile_impl) */
        if (mc->prefetch)
            for (int p = 0; p < DVR_NP; p++)
                if (seg_bits[p]) {
                    const packet_state *ps = &P[p];
                    vf tn = f_min(f_add(ps->t0, f_mul(f_add(f_add(kf_next[p], f_set(mc->pf_ahead)), ps->jit), h)), ps->t1);
                    prefetch_cells(&mc->vc, f_add(ps->q0[0], f_mul(ps->dq[0], tn)),
                                   f_add(ps->q0[1], f_mul(ps->dq[1], tn)), f_add(ps->q0[2], f_mul(ps->dq[2], tn)),
                                   seg[p], storage, words);
                }
        /* Phase 3: classification, pre-integration and compositing. */
        for (int p = 0; p < DVR_NP; p++) {
            packet_state *ps = &P[p];
            if (seg_bits[p]) {
                vf tau, cr, cg, cb, u, f;
                vi i;
                lut_coord_v(lut, s[p], &u, &i, &f);
                if (preint) {
                    vf Pr[4], D[4], num[4];
                    pre_record_v(st->pk.pre_f, i, Pr, D);
                    vm same = i_eq(i, ps->i_p), fwd = i_gt(i, ps->i_p);
                    for (int ch = 0; ch < 4; ch++) {
                        /* ΔI = (P_c − P_p) − f_p·D_p + f_c·D_c, summed so the
                         * cancelling pair goes first: P_c − P_p is exactly
                         * D_p (one interval up) or −D_c (one down), and the
                         * fused step with the lower end's f leaves only the
                         * exact tail, e.g. D_p − f_p·D_p, rounded once. */
                        vf x = f_sub(Pr[ch], ps->P_p[ch]);
                        vf up = f_fmadd(f, D[ch], f_fnmadd(ps->f_p, ps->D_p[ch], x));
                        vf down = f_fnmadd(ps->f_p, ps->D_p[ch], f_fmadd(f, D[ch], x));
                        num[ch] = sel(same, D[ch], sel(fwd, up, down));
                    }
                    /* ΔI and Δu share their sign; one interval: Δu := 1 */
                    vf du = sel(same, one, f_sub(u, ps->u_p));
                    vf per_u = f_div(one, du);
                    tau = f_mul(f_mul(len[p], len_scale), f_mul(num[0], per_u));
                    vm ok = f_gt(tau, zero);
                    vf inv = f_keep(f_div(one, num[0]), ok);
                    cr = f_mul(num[1], inv);
                    cg = f_mul(num[2], inv);
                    cb = f_mul(num[3], inv);
                    ps->u_p = u, ps->f_p = f, ps->i_p = i;
                    for (int ch = 0; ch < 4; ch++) ps->P_p[ch] = Pr[ch], ps->D_p[ch] = D[ch];
                } else {
                    /* Colour and σt at s, linear between table nodes i, i+1
                     * (the 32 bytes at rgba[4i] hold both nodes). */
                    vf o[8];
                    load_rows8(lut->rgba, i_slli(i, 2), o);
                    cr = lerp(o[0], o[4], f);
                    cg = lerp(o[1], o[5], f);
                    cb = lerp(o[2], o[6], f);
                    tau = f_mul(lerp(o[3], o[7], f), len[p]);
                }
                vm lit = m_andnot(ps->warm, m_and(seg[p], f_gt(tau, zero)));
                if (shaded && m_bits(lit)) {
                    vf g[3], c3[3] = {cr, cg, cb};
                    if (mc->grad_cell) gradient_cell_v(&mc->vc, &cells[p], storage, words, lit, g);
                    else gradient_v(st, &cells[p], lit, g);
                    shade_v(st, g, ps->d, (const vf(*)[3])ps->hn, c3);
                    cr = c3[0], cg = c3[1], cb = c3[2];
                }
                vf alpha = f_sub(one, exp_nonpos(f_neg(tau)));
                vf w = f_keep(f_mul(ps->T, alpha), lit);
                ps->C[0] = f_add(ps->C[0], f_mul(w, cr));
                ps->C[1] = f_add(ps->C[1], f_mul(w, cg));
                ps->C[2] = f_add(ps->C[2], f_mul(w, cb));
                ps->T = f_sub(ps->T, w);
                /* early termination: the scalar kernel stops when T < t_min */
                ps->active = m_andnot(f_lt(ps->T, t_min), ps->active);
            }
            ps->warm = preint ? jump[p] : m_none();
            ps->kf = kf_next[p];
        }
    }
    *samples += count;
}

DI void render_tile_impl(const dvr_state *st, const volux_scene *scene, const volux_tile *tile, float *rgb,
                         volux_tile_stats *stats, int shaded, int preint, volux_storage storage, int words) {
    ray_list rl;
    build_ray_list(st, scene, tile, rgb, &rl);
    if (!rl.n) return;
    march_consts mc;
    mc.st = st;
    vol_consts_init(&mc.vc, st->rc.volume, st->corners);
    mc.h = f_set(st->rc.step);
    mc.inv_h = f_set(1.0f / st->rc.step);
    mc.shaded = shaded, mc.preint = preint, mc.skip = st->skip_empty;
    /* Software prefetch of a later sample's cells, for coarse steps only:
     * samples ≥ 2 voxels apart share few cache lines, and the gathers of
     * the volume then wait on L2/L3 misses (bonsai, Zen 4, 1 thread: step
     * 4 −12 %, step 3 −7 %, step 2 −3 to −9 %; step 1 +3 %, step 0.5 +5 %,
     * where neighbouring samples already share lines and the prefetches are
     * only extra instructions). The target is ≈ 4 voxels ahead: the next
     * segment end from step 3 on, the one after that below. */
    double sp[3];
    volux_volume_spacing(st->rc.volume, sp);
    const float step_vox = st->rc.step / (float)fmin(sp[0], fmin(sp[1], sp[2])); /* render.step */
    mc.prefetch = step_vox >= 2.0f;
    mc.pf_ahead = step_vox < 3.0f ? 1.0f : 0.0f;
    mc.storage = storage;
    mc.words = words;
    mc.grad_cell = st->grad_cell;
    uint64_t samples = 0;
    march_tile(&mc, &rl, rgb, &samples);
    stats->samples += samples;
}

#define VOLUX_INSTANCE_(NAME, SH, PRE, STORE, WORDS)                                                                  \
    static DVR_TARGET __attribute__((noinline)) void NAME(const dvr_state *st, const volux_scene *scene,              \
                                                          const volux_tile *tile, float *rgb,                         \
                                                          volux_tile_stats *stats) {                                  \
        render_tile_impl(st, scene, tile, rgb, stats, SH, PRE, STORE, WORDS);                                         \
    }
VOLUX_INSTANCE_(ea_u8_pre, 0, 1, VOLUX_STORE_U8, 0)
VOLUX_INSTANCE_(ea_u8, 0, 0, VOLUX_STORE_U8, 0)
VOLUX_INSTANCE_(ea_u16_pre, 0, 1, VOLUX_STORE_U16, 0)
VOLUX_INSTANCE_(ea_u16, 0, 0, VOLUX_STORE_U16, 0)
VOLUX_INSTANCE_(ea_f32_pre, 0, 1, VOLUX_STORE_F32, 0)
VOLUX_INSTANCE_(ea_f32, 0, 0, VOLUX_STORE_F32, 0)
VOLUX_INSTANCE_(sh_u8_pre, 1, 1, VOLUX_STORE_U8, 0)
VOLUX_INSTANCE_(sh_u8, 1, 0, VOLUX_STORE_U8, 0)
VOLUX_INSTANCE_(sh_u16_pre, 1, 1, VOLUX_STORE_U16, 0)
VOLUX_INSTANCE_(sh_u16, 1, 0, VOLUX_STORE_U16, 0)
VOLUX_INSTANCE_(sh_f32_pre, 1, 1, VOLUX_STORE_F32, 0)
VOLUX_INSTANCE_(sh_f32, 1, 0, VOLUX_STORE_F32, 0)
/* 8-bit volumes with corner words (dvr_corners.c) */
VOLUX_INSTANCE_(ea_w8_pre, 0, 1, VOLUX_STORE_U8, 1)
VOLUX_INSTANCE_(ea_w8, 0, 0, VOLUX_STORE_U8, 1)
VOLUX_INSTANCE_(sh_w8_pre, 1, 1, VOLUX_STORE_U8, 1)
VOLUX_INSTANCE_(sh_w8, 1, 0, VOLUX_STORE_U8, 1)
#undef VOLUX_INSTANCE_

typedef void (*tile_fn)(const dvr_state *, const volux_scene *, const volux_tile *, float *, volux_tile_stats *);

/* The tile function for the state's technique, pre-integration and storage. */
static tile_fn pick_tile_fn(const dvr_state *st) {
    static const tile_fn table[2][2][3] = {
        {{ea_u8, ea_u16, ea_f32}, {ea_u8_pre, ea_u16_pre, ea_f32_pre}},
        {{sh_u8, sh_u16, sh_f32}, {sh_u8_pre, sh_u16_pre, sh_f32_pre}},
    };
    static const tile_fn words[2][2] = {{ea_w8, ea_w8_pre}, {sh_w8, sh_w8_pre}};
    int storage = st->rc.volume->storage == VOLUX_STORE_U8 ? 0 : st->rc.volume->storage == VOLUX_STORE_U16 ? 1 : 2;
    if (st->corners && storage == 0) return words[st->shaded ? 1 : 0][st->preintegrate ? 1 : 0];
    return table[st->shaded ? 1 : 0][st->preintegrate ? 1 : 0][storage];
}
