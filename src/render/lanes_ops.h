/*
 * render/lanes_ops.h — width-generic lane helpers written once over the
 * lane vocabulary (render/lanes_avx2.h, render/lanes_avx512.h): trilinear
 * samples from the volume's bricked copy, transfer-function coordinates
 * and pre-integration records, the empty-space skip check over the packet
 * tables (render/packet.h), and vector exp/log. Moved here from
 * techniques/dvr/dvr_simd_impl.h so the `ea`/`shaded` kernel and the
 * shared illuminated march (render/packet_impl.h) read the volume and the
 * tables with the same operations.
 *
 * Include after one of the vocabulary headers (it defines DI, vf, vi, vm).
 */
#ifndef VOLUX_LANES_OPS_H
#define VOLUX_LANES_OPS_H

#ifndef LANE_W
#error "render/lanes_ops.h: include render/lanes_avx2.h or render/lanes_avx512.h first"
#endif

#include "render/packet.h"
#include "volux/transfer.h"

/* ------------------------------------------------------------- volume */

/* Volume constants broadcast once per tile. */
typedef struct vol_consts {
    const unsigned char *bricks;
    const uint64_t *corners; /* corner words (techniques/dvr/dvr_corners.c) or NULL */
    vi imax[3];             /* highest valid cell index per axis (n − 2) */
    vi stride_y, stride_z;  /* brick strides in nodes (·729)             */
    vi wstride_y, wstride_z; /* the same in corner words (·512)          */
    vf offset;              /* file value = stored + offset              */
    vf inv_sp[3];
} vol_consts;

DI void vol_consts_init(vol_consts *vc, const volux_volume *v, const uint64_t *corners) {
    vc->bricks = v->bricks;
    for (int a = 0; a < 3; a++) vc->imax[a] = i_set(v->dims[a] > 1 ? v->dims[a] - 2 : 0);
    vc->stride_y = i_set(v->brick_counts[0] * VOLUX_BRICK_VOXELS);
    vc->stride_z = i_set(v->brick_counts[0] * v->brick_counts[1] * VOLUX_BRICK_VOXELS);
    vc->corners = corners;
    for (int a = 0; a < 3; a++) vc->inv_sp[a] = f_set(v->inv_spacing[a]);
    vc->wstride_y = i_set(v->brick_counts[0] * 512);
    vc->wstride_z = i_set(v->brick_counts[0] * v->brick_counts[1] * 512);
    vc->offset = f_set(v->value_offset);
}

DI vf lerp(vf a, vf b, vf f) {
    /* a + (b − a)·f, unfused, exactly as the scalar code rounds it */
    return f_add(a, f_mul(f_sub(b, a), f));
}

/* Where a sample fell: brick offset of its cell's low corner and the
 * fractions, for the bricked gradient cache (same layout). */
typedef struct cellv {
    vi b;
    vf fx, fy, fz;
    vi rows[4]; /* u8/u16 from the bricks: the corner rows (gradient_cell_v) */
} cellv;

/* Brick offset (in nodes) of the cell holding (i, j, k). */
DI vi brick_offset(const vol_consts *vc, vi i, vi j, vi k) {
    const vi seven = i_set(7);
    vi brick = i_add(i_mullo(i_srli(i, 3), i_set(VOLUX_BRICK_VOXELS)),
                     i_add(i_mullo(i_srli(j, 3), vc->stride_y), i_mullo(i_srli(k, 3), vc->stride_z)));
    /* 9·(j&7) + 81·(k&7) in one multiply-add of 16-bit pairs */
    vi jk = i_or(i_and(j, seven), i_slli(i_and(k, seven), 16));
    return i_add(brick, i_add(i_and(i, seven), i_madd16(jk, i_set((81 << 16) | 9))));
}

/* Index of the corner word of the cell holding (i, j, k) (dvr_corners.c):
 * the same brick, 512 words per brick, x fastest. */
DI vi corner_word_index(const vol_consts *vc, vi i, vi j, vi k) {
    const vi seven = i_set(7);
    vi brick = i_add(i_slli(i_srli(i, 3), 9),
                     i_add(i_mullo(i_srli(j, 3), vc->wstride_y), i_mullo(i_srli(k, 3), vc->wstride_z)));
    vi in = i_or(i_and(i, seven), i_or(i_slli(i_and(j, seven), 3), i_slli(i_and(k, seven), 6)));
    return i_add(brick, in);
}

/* The 8 corners (stored values) of the cells at brick offsets b. */
/* The 8 corners from the 4 gathered corner rows of u8/u16 bricks. */
DI void rows_to_corners(const vi g[4], volux_storage storage, vf c[8]) {
    const int u8 = storage == VOLUX_STORE_U8, shift = u8 ? 8 : 16;
    const vi lo = i_set(u8 ? 0xff : 0xffff);
    for (int r = 0; r < 4; r++) {
        c[2 * r] = f_from_i(i_and(g[r], lo));
        c[2 * r + 1] = f_from_i(i_and(i_srli(g[r], shift), lo));
    }
}

DI void fetch_corners(const vol_consts *vc, vi b, volux_storage storage, vf c[8], vi *rows) {
    if (storage == VOLUX_STORE_U8 || storage == VOLUX_STORE_U16) {
        /* One 32-bit gather per (y, z) corner row returns the x pair;
         * `rows` (if given) keeps them. */
        vi g[4];
        if (storage == VOLUX_STORE_U8) gather_rows_u8(vc->bricks, b, g);
        else gather_rows_u16(vc->bricks, b, g);
        rows_to_corners(g, storage, c);
        if (rows)
            for (int r = 0; r < 4; r++) rows[r] = g[r];
    } else {
        gather_corners_f32((const float *)(const void *)vc->bricks, b, c);
    }
}

/* Trilinear samples at index-space (x, y, z) from the bricked copy; same
 * clamping and arithmetic as volux_volume_sample_bricked. Every lane gets
 * a valid address (indices are clamped), so no masks are needed. */
DI vf sample_v(const vol_consts *vc, vf x, vf y, vf z, volux_storage storage, int words, cellv *cell) {
    const vi zero = i_zero();
    vi i = i_max(i_min(i_trunc(x), vc->imax[0]), zero);
    vi j = i_max(i_min(i_trunc(y), vc->imax[1]), zero);
    vi k = i_max(i_min(i_trunc(z), vc->imax[2]), zero);
    vf fx = f_sub(x, f_from_i(i)), fy = f_sub(y, f_from_i(j)), fz = f_sub(z, f_from_i(k));
    vi b = words && !cell ? zero : brick_offset(vc, i, j, k);
    if (cell) cell->b = b, cell->fx = fx, cell->fy = fy, cell->fz = fz;
    vf c[8]; /* c000, c100, c010, c110, c001, c101, c011, c111 */
    if (words) {
        /* 8-bit corner words: one 64-bit element per lane, the z row in
         * the low dword and the z+1 row in the high one, a byte per corner
         * in the order of c[] (the same bytes the bricked gathers read) */
        vi w[2];
        gather_corner_words(vc->corners, corner_word_index(vc, i, j, k), w);
        const vi lo = i_set(0xff);
        for (int r = 0; r < 2; r++) {
            c[4 * r] = f_from_i(i_and(w[r], lo));
            c[4 * r + 1] = f_from_i(i_and(i_srli(w[r], 8), lo));
            c[4 * r + 2] = f_from_i(i_and(i_srli(w[r], 16), lo));
            c[4 * r + 3] = f_from_i(i_srli(w[r], 24));
        }
    } else {
        fetch_corners(vc, b, storage, c, cell ? cell->rows : NULL);
    }
    vf c00 = lerp(c[0], c[1], fx), c10 = lerp(c[2], c[3], fx);
    vf c01 = lerp(c[4], c[5], fx), c11 = lerp(c[6], c[7], fx);
    vf c0 = lerp(c00, c10, fy), c1 = lerp(c01, c11, fy);
    return f_add(lerp(c0, c1, fz), vc->offset);
}

/* Software prefetch of the cells at (x, y, z) for the lanes of `m`: the
 * z and z+1 corner rows (81 nodes apart, usually two cache lines). */
DI void prefetch_cells(const vol_consts *vc, vf x, vf y, vf z, vm m, volux_storage storage, int words) {
    const vi zero = i_zero();
    vi i = i_max(i_min(i_trunc(x), vc->imax[0]), zero);
    vi j = i_max(i_min(i_trunc(y), vc->imax[1]), zero);
    vi k = i_max(i_min(i_trunc(z), vc->imax[2]), zero);
    _Alignas(64) int32_t off[LANE_W];
    if (words) { /* one line: the cell's corner word */
        i_store(off, corner_word_index(vc, i, j, k));
        for (unsigned bits = (unsigned)m_bits(m); bits; bits &= bits - 1)
            __builtin_prefetch(vc->corners + off[__builtin_ctz(bits)]);
        return;
    }
    i_store(off, brick_offset(vc, i, j, k));
    const size_t size = storage == VOLUX_STORE_U8 ? 1 : storage == VOLUX_STORE_U16 ? 2 : 4;
    for (unsigned bits = (unsigned)m_bits(m); bits; bits &= bits - 1) {
        const unsigned char *c = vc->bricks + size * (size_t)off[__builtin_ctz(bits)];
        __builtin_prefetch(c);
        __builtin_prefetch(c + size * 81);
    }
}

/* ------------------------------------------------------ transfer function */

/* Table coordinate u, interval i and fraction f of the samples (as
 * volux_lut_coord / volux_lut_interval). */
DI void lut_coord_v(const volux_transfer_lut *lut, vf s, vf *u, vi *i, vf *f) {
    vf x = f_mul(f_sub(s, f_set(lut->s_min)), f_set(lut->inv_ds));
    x = f_min(f_max(x, f_zero()), f_set((float)(lut->n - 1)));
    vi k = i_min(i_trunc(x), i_set(lut->n - 2));
    *u = x;
    *i = k;
    *f = f_sub(x, f_from_i(k));
}

/* Pre-integration record (P[4], D[4]) of interval i. */
DI void pre_record_v(const float *pre_f, vi i, vf P[4], vf D[4]) {
    vf o[8];
    load_rows8(pre_f, i_slli(i, 3), o);
    for (int c = 0; c < 4; c++) P[c] = o[c], D[c] = o[4 + c];
}

/* ------------------------------------------------------ empty-space skip */

/* Skipping constants of one packet's rays. */
typedef struct skipv {
    vi cells_max[3], ncx, ncy;
    vm up[3];      /* the ray moves up the axis                   */
    vm flat[3];    /* dq == 0                                      */
    vf inv_dq[3];  /* 1/dq (inf where dq = 0, masked by flat)      */
} skipv;

/* Empty-space check at world t for the lanes in `need`. One lookup of the
 * signed skip distance d of the skip cell holding q(t) (dvr.c,
 * build_skip_distance) gives a cube of r = |d| − 1 rings of cells around
 * it that are all empty (d > 0) or all non-empty (d < 0); *t_exit is where
 * the ray leaves that cube. Returns the lanes in an empty cube, which may
 * skip to *m, the last segment index whose start is ≤ *t_exit (with a
 * margin of 10⁻³ h, so rounding never skips into a non-empty cell); lanes
 * in a non-empty cube need not check again before *t_exit. */
DI vm check_cells(const int8_t *dist, const skipv *sk, const vf q0[3], const vf dq[3], vf t0, vf jit, vf inv_h,
                  vf t, vm need, vf *t_exit, vf *m) {
    const vi zero_i = i_zero(), one_i = i_set(1);
    vf q[3];
    vi c[3];
    for (int ax = 0; ax < 3; ax++) {
        q[ax] = f_add(q0[ax], f_mul(dq[ax], t));
        c[ax] = i_trunc(f_mul(q[ax], f_set(1.0f / VOLUX_PACKET_SKIP_CELL)));
        c[ax] = i_max(i_min(c[ax], sk->cells_max[ax]), zero_i);
    }
    vi cell = i_add(i_mullo(i_add(i_mullo(c[2], sk->ncy), c[1]), sk->ncx), c[0]);
    vi d = gather_i8_masked(dist, cell, need);
    vi r = i_max(i_sub(i_abs(d), one_i), zero_i);
    vf tmin = f_set(INFINITY);
    for (int ax = 0; ax < 3; ax++) {
        /* the cube's far face along the ray: cell c + r + 1 going up, c − r going down */
        vi face = isel(sk->up[ax], i_add(i_add(c[ax], r), one_i), i_sub(c[ax], r));
        vf bound = f_mul(f_from_i(face), f_set((float)VOLUX_PACKET_SKIP_CELL));
        vf ta = f_mul(f_sub(bound, q[ax]), sk->inv_dq[ax]);
        tmin = f_min(tmin, sel(sk->flat[ax], f_set(INFINITY), ta));
    }
    *t_exit = f_add(t, tmin);
    *m = f_add(f_floor(f_sub(f_mul(f_sub(*t_exit, t0), inv_h), f_add(jit, f_set(1e-3f)))), f_set(1.0f));
    return m_and(need, i_gt(d, zero_i));
}

/* ------------------------------------------------------------- shading */

/* e^x for x ≤ 0 (Cephes expf: round to the nearest power of two, degree-6
 * polynomial on [−ln2/2, ln2/2]); ≤ 2 ulp from libm's expf; the result
 * stays a tiny normal below −87.3 (not needed there). */
DI vf exp_nonpos(vf x) {
    x = f_max(x, f_set(-87.3f));
    vf n = f_round(f_mul(x, f_set(1.44269504088896341f)));
    vf r = f_fnmadd(n, f_set(0.693359375f), x);
    r = f_fnmadd(n, f_set(-2.12194440e-4f), r);
    vf y = f_set(1.9875691500e-4f);
    y = f_fmadd(y, r, f_set(1.3981999507e-3f));
    y = f_fmadd(y, r, f_set(8.3334519073e-3f));
    y = f_fmadd(y, r, f_set(4.1665795894e-2f));
    y = f_fmadd(y, r, f_set(1.6666665459e-1f));
    y = f_fmadd(y, r, f_set(5.0000001201e-1f));
    y = f_fmadd(y, f_mul(r, r), r);
    y = f_add(y, f_set(1.0f));
    vi e = i_slli(i_add(i_round(n), i_set(127)), 23);
    return f_mul(y, i_as_f(e));
}

/* ln x for x > 0 (Cephes logf: mantissa in [√½, √2), degree-8
 * polynomial); ≤ 2 ulp from libm. With DAZ, denormal x reads as 0: callers
 * mask x ≤ 0. */
DI vf log_pos(vf x) {
    vi xi = f_as_i(x);
    vf e = f_from_i(i_sub(i_srli(xi, 23), i_set(126)));
    vf m = i_as_f(i_or(i_and(xi, i_set((int32_t)0x807fffff)), i_set(0x3f000000)));
    vm small = f_lt(m, f_set(0.707106781186547524f));
    e = f_sub(e, f_keep(f_set(1.0f), small));
    vf t = f_sub(f_add(m, f_keep(m, small)), f_set(1.0f));
    vf z = f_mul(t, t);
    vf y = f_set(7.0376836292e-2f);
    y = f_fmadd(y, t, f_set(-1.1514610310e-1f));
    y = f_fmadd(y, t, f_set(1.1676998740e-1f));
    y = f_fmadd(y, t, f_set(-1.2420140846e-1f));
    y = f_fmadd(y, t, f_set(1.4249322787e-1f));
    y = f_fmadd(y, t, f_set(-1.6668057665e-1f));
    y = f_fmadd(y, t, f_set(2.0000714765e-1f));
    y = f_fmadd(y, t, f_set(-2.4999993993e-1f));
    y = f_fmadd(y, t, f_set(3.3333331174e-1f));
    y = f_mul(f_mul(y, t), z);
    y = f_fmadd(e, f_set(-2.12194440e-4f), y);
    y = f_fnmadd(z, f_set(0.5f), y);
    return f_fmadd(e, f_set(0.693359375f), f_add(t, y));
}

DI vf dot3(const vf a[3], const vf b[3]) {
    return f_add(f_add(f_mul(a[0], b[0]), f_mul(a[1], b[1])), f_mul(a[2], b[2]));
}

#endif
