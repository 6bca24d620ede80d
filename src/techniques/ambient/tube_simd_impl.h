/*
 * techniques/ambient/tube_simd_impl.h — the vector tube kernels written
 * once for both widths (see tube_simd.h): the node update, the directional
 * fast path and the batch entry points. Not a normal header: tube_avx2.c
 * and tube_avx512.c each include it once, after defining
 *
 *   TUBE_W              lanes (8, 16)
 *   TUBE_VACUUM_CHAINS  1: record and skip vacuum chains (tube.h)
 *   TUBE_TARGET, TI     the target attribute of entry points / of the
 *                       inlined helpers
 *   vf, vi, vm          float lanes, int32 lanes, a lane mask
 *   TUBE_MM(op)         the width's intrinsic _mm256_op / _mm512_op
 *   TUBE_CMP(a, b, p)   the float compare with predicate p, as a vm
 *
 * and after it the operations whose form differs by width (declared
 * below), ending with `kernels` returned by their tube_kernels_* function.
 *
 * BIT-IDENTICAL to tube.c's scalar `node` and fast_run: every lane performs
 * the scalar operations in the same order (no FMA contraction: the targets
 * leave FMA out or -ffp-contract=off, the ISO C default, applies; sqrt and
 * division are IEEE), branches become selects of the value the scalar
 * branch computes, and clamped indices are computed as the scalar code
 * computes them. Any change to tube.c's `node`, `chain_start`, `box_exit`,
 * `sample_strict`, `tube_kappa`, fast_run or scatter_grid_sample must be
 * mirrored here (tests/physics/test_tube_marching.c compares every width
 * with the scalar path bit for bit).
 */

#ifndef TUBE_W
#error "tube_simd_impl.h: define the lane vocabulary first (see tube_avx2.c)"
#endif

/* ------------------------------------------- lanes: the same in both widths
 * Each is one instruction with, per lane, the result of the scalar
 * operation it names. */
TI vf f_set(float x) { return TUBE_MM(set1_ps)(x); }
TI vf f_zero(void) { return TUBE_MM(setzero_ps)(); }
TI vf f_add(vf a, vf b) { return TUBE_MM(add_ps)(a, b); }
TI vf f_sub(vf a, vf b) { return TUBE_MM(sub_ps)(a, b); }
TI vf f_mul(vf a, vf b) { return TUBE_MM(mul_ps)(a, b); }
TI vf f_div(vf a, vf b) { return TUBE_MM(div_ps)(a, b); }
TI vf f_sqrt(vf a) { return TUBE_MM(sqrt_ps)(a); }
TI vf f_min(vf a, vf b) { return TUBE_MM(min_ps)(a, b); }
TI vf f_max(vf a, vf b) { return TUBE_MM(max_ps)(a, b); }
TI vf f_from_i(vi a) { return TUBE_MM(cvtepi32_ps)(a); }
TI vi f_trunc(vf a) { return TUBE_MM(cvttps_epi32)(a); }
TI vf f_load(const float *p) { return TUBE_MM(loadu_ps)(p); }
TI void f_store(float *p, vf v) { TUBE_MM(storeu_ps)(p, v); }
TI vm f_lt(vf a, vf b) { return TUBE_CMP(a, b, _CMP_LT_OQ); }
TI vm f_le(vf a, vf b) { return TUBE_CMP(a, b, _CMP_LE_OQ); }
TI vm f_gt(vf a, vf b) { return TUBE_CMP(a, b, _CMP_GT_OQ); }
TI vm f_ge(vf a, vf b) { return TUBE_CMP(a, b, _CMP_GE_OQ); }
TI vm f_eq(vf a, vf b) { return TUBE_CMP(a, b, _CMP_EQ_OQ); }
TI vm f_nle(vf a, vf b) { return TUBE_CMP(a, b, _CMP_NLE_UQ); } /* !(a ≤ b), true for NaN */
TI vi i_set(int x) { return TUBE_MM(set1_epi32)(x); }
TI vi i_add(vi a, vi b) { return TUBE_MM(add_epi32)(a, b); }
TI vi i_mullo(vi a, vi b) { return TUBE_MM(mullo_epi32)(a, b); }
TI vi i_min(vi a, vi b) { return TUBE_MM(min_epi32)(a, b); }

/* ------------------------------- lanes: per width, defined after this file */
TI vf f_abs(vf a);            /* the sign bit cleared                       */
TI vm f_sign(vf a);           /* the lanes whose sign bit is set           */
TI vf f_set_sign(vf a, vm m); /* a with the sign bit set in the lanes of m */
TI vf sel(vm m, vf a, vf b);  /* a where m, else b                         */
TI vi lane_ids(void);         /* 0, 1, …, TUBE_W − 1                       */
TI vm m_first(int n);         /* lanes [0, n); n may exceed TUBE_W         */
TI vm m_and(vm a, vm b);
TI vm m_or(vm a, vm b);
TI vm m_andnot(vm a, vm b);   /* the lanes of b that are not in a         */
TI int m_any(vm m);
TI int m_covers(vm m, vm valid); /* every lane of valid is in m           */
/* Lanes [0, n) from / to p[0 … n − 1] (others 0; nothing past them is
 * touched), and the lanes in k (full: all of them; the same result). */
TI vf f_load_first(const float *p, int n);
TI void f_store_first(float *p, vf v, int n);
TI vf f_load_masked(const float *p, vm k, int full);
TI void f_store_masked(float *p, vf v, vm k, int full);
/* κ[j], κ[j + 1] for the lanes in k (others: any value). */
TI void kappa_pair(const float *kappa, vi j, vm k, vf *k0, vf *k1);
#if TUBE_VACUUM_CHAINS
/* A re-sum: 1 when every node of the block in `valid` (consecutive in
 * memory) is a vacuum chain; their D (+0) is then stored to out. */
TI int vac_skip(const unsigned char *vac, float *out, vm valid);
/* A march: the vacuum-chain bytes (tube.h: tube_geometry) of a block of
 * nodes (vac[l·stride] for lane l), D = res. `ok`: the lanes whose D is +0
 * for every κ with κ(0) = +0 if every node they read is; a +0 elsewhere
 * breaks the invariant (*bad). */
TI void vac_record(unsigned char *vac, ptrdiff_t stride, int *bad, vf res, vm ok, vm valid);
/* The lanes whose 8 corners are all +0 (bit pattern 0): the read of a
 * vacuum chain. */
TI vm corners_zero(const vf a[8]);
#endif

/* Grid constants broadcast once per call. */
typedef struct lane_grid {
    vf lo[3], inv_h[3], m[3]; /* m: highest node index as float */
    vi imax[3];               /* n − 2: highest cell index        */
    vi sy, sz;                /* strides in nodes                 */
    int nx, nxy;
} lane_grid;

TI void grid_consts(const tube_lanes *t, lane_grid *g) {
    for (int a = 0; a < 3; a++) {
        g->lo[a] = f_set(t->lo[a]);
        g->inv_h[a] = f_set(t->inv_h[a]);
        g->m[a] = f_set((float)(t->dims[a] - 1));
        g->imax[a] = i_set(t->dims[a] - 2);
    }
    g->nx = t->dims[0], g->nxy = t->dims[0] * t->dims[1];
    g->sy = i_set(g->nx);
    g->sz = i_set(g->nxy);
}

/* a + (b − a)·f, unfused (as the scalar code rounds it) */
TI vf lerp(vf a, vf b, vf f) { return f_add(a, f_mul(f_sub(b, a), f)); }

/* The trilinear value from the 8 corners (x fastest: a[0] = (0,0,0),
 * a[1] = (1,0,0), a[2] = (0,1,0), ...), in scatter_grid_sample's order. */
TI vf trilerp(const vf a[8], const vf f[3]) {
    vf c00 = lerp(a[0], a[1], f[0]), c10 = lerp(a[2], a[3], f[0]);
    vf c01 = lerp(a[4], a[5], f[0]), c11 = lerp(a[6], a[7], f[0]);
    vf c0 = lerp(c00, c10, f[1]), c1 = lerp(c01, c11, f[1]);
    return lerp(c0, c1, f[2]);
}

/* The 8 corners (trilerp's order) of cells whose indices are consecutive
 * (lane 0's + lane), from lane 0's lower corner r and y and z corner rows
 * oy and oz nodes on: a plain load per corner instead of a gather. */
TI void row_corners(const float *r, ptrdiff_t oy, ptrdiff_t oz, vf a[8]) {
    const ptrdiff_t o[4] = {0, oy, oz, oy + oz};
    for (int q = 0; q < 4; q++) a[2 * q] = f_load(r + o[q]), a[2 * q + 1] = f_load(r + o[q] + 1);
}

/* Index-space position of world p, clamped to [0, n − 1] per axis, as
 * scatter_grid_sample / strict_cell compute it: u < 0 ? 0 : (u > m ? m :
 * u). max/min differ from it only in the sign of a zero, which no later
 * operation turns into a different value (cell 0, fraction ±0,
 * a + (b − a)·(±0) = a). */
TI void to_index(const lane_grid *g, const vf p[3], vf u[3]) {
    for (int a = 0; a < 3; a++) u[a] = f_min(f_max(f_mul(f_sub(p[a], g->lo[a]), g->inv_h[a]), f_zero()), g->m[a]);
}

TI vi cell_index(const lane_grid *g, const vi c[3]) {
    return i_add(i_add(i_mullo(c[2], g->sz), i_mullo(c[1], g->sy)), c[0]);
}

/* The cell of a clamped read (scatter_grid_sample on a grid with every
 * dimension ≥ 2: cells clamped to n − 2, all 8 corners exist): lower
 * corner and fractions. */
TI void clamped_cell(const lane_grid *g, const vf p[3], vi c[3], vf f[3]) {
    vf u[3];
    to_index(g, p, u);
    for (int a = 0; a < 3; a++) {
        c[a] = i_min(f_trunc(u[a]), g->imax[a]);
        f[a] = f_sub(u[a], f_from_i(c[a]));
    }
}

/* The reads, per width (each of their ways to fetch the corners ends in
 * its own trilerp, so the corners stay in registers): scatter_grid_sample
 * at p (clamped_cell); */
TI vf sample_clamped(const float *v, const lane_grid *g, const vf p[3]);
/* tube.c's strict_at for the lanes in `mask` (others: any value, no load
 * of theirs) at cells c with fractions f (strict_cell): the upper corner
 * of an axis only where the fraction is > 0; with vacuum chains, *zc (if
 * zc is not NULL): the lanes whose corners are all +0. */
#if TUBE_VACUUM_CHAINS
TI vf strict_at(const float *v, const lane_grid *g, const vi c[3], const vf f[3], vm mask, vm *zc);
#else
TI vf strict_at(const float *v, const lane_grid *g, const vi c[3], const vf f[3], vm mask);
#endif

/* The cell of a strict read (tube.c: strict_cell): lower corner and
 * fractions. */
TI void strict_cell(const lane_grid *g, const vf p[3], vi c[3], vf f[3]) {
    vf u[3];
    to_index(g, p, u);
    for (int a = 0; a < 3; a++) {
        c[a] = f_trunc(u[a]);
        f[a] = f_sub(u[a], f_from_i(c[a]));
    }
}

/* tube_kappa for every lane. */
TI vf kappa_lanes(const tube_lanes *t, vf rho) {
    const vf last = f_set((float)(t->n_sigma - 1));
    vf u = f_div(f_mul(rho, last), f_set(t->sigma_max));
    vm above = f_ge(u, last);
    /* u ≤ 0 gives cell 0 and fraction 0: κ[0] + (κ[1] − κ[0])·0 = κ[0] */
    vf uc = f_min(f_max(u, f_zero()), last);
    vi i = i_min(f_trunc(uc), i_set(t->n_sigma - 2));
    vf f = f_sub(uc, f_from_i(i)), k0, k1;
    kappa_pair(t->kappa, i, m_first(TUBE_W), &k0, &k1);
    return sel(above, f_set(t->kappa[t->n_sigma - 1]), lerp(k0, k1, f));
}

/* Stores lanes [0, n) of v at p + l·stride / loads them (others 0). */
TI void store_strided(float *p, ptrdiff_t stride, vf v, int n) {
    if (stride == 1) {
        f_store_first(p, v, n);
        return;
    }
    float tmp[TUBE_W];
    f_store(tmp, v);
    for (int l = 0; l < n; l++) p[(ptrdiff_t)l * stride] = tmp[l];
}

TI vf load_strided(const float *p, ptrdiff_t stride, int n) {
    if (stride == 1) return f_load_first(p, n);
    float tmp[TUBE_W] = {0};
    for (int l = 0; l < n; l++) tmp[l] = p[(ptrdiff_t)l * stride];
    return f_load(tmp);
}

/* 1 when every node in `valid` is provably more than two steps (2s) from
 * its chain start, without computing the box exit: along axis a the exit
 * distance (bound_a − x_a)/b_a, b = −ω, |b_a| ≤ 1, is at least
 * |bound_a − x_a|, so δ = min(dl, exit) ≥ min(dl, min_a |bound_a − x_a|).
 * The margin (2.002 s) exceeds the rounding of the exact computation by
 * far: those nodes take the deep branch either way, bit-identical. Saves
 * the three divisions of the box exit for most blocks of a march. */
TI int beyond_two_steps(const tube_lanes *t, const vf x[3], const vf w[3], vf dl, vm valid) {
    const vf zero = f_zero(), inf = f_set(INFINITY);
    vf lb = dl;
    for (int a = 0; a < 3; a++) {
        vm to_hi = f_lt(w[a], zero), to_lo = f_gt(w[a], zero);
        vf gap = sel(to_hi, f_sub(f_set(t->hi[a]), x[a]), sel(to_lo, f_sub(x[a], f_set(t->lo[a])), inf));
        lb = f_min(lb, gap);
    }
    return m_covers(f_gt(lb, f_set(2.002f * t->s)), valid);
}

/* The node update (tube.c: node) at the `count` nodes (i, j, k) + n·e_axis,
 * n ∈ [0, count), with their records at g_arg[rec0 + n·rec_stride]; a
 * march (resum = 0) or a re-sum (1), a constant after inlining: each gets
 * its own code (the re-sum's ran ≈ 3 % slower with AVX2 when it shared the
 * march's box-exit bound, which it never runs). */
TI void nodes_pass(const tube_lanes *t, int i, int j, int k, int axis, int count, size_t rec0, ptrdiff_t rec_stride,
                   const int resum) {
    const int nx = t->dims[0], ny = t->dims[1];
    lane_grid g;
    grid_consts(t, &g);
    const vf zero = f_zero(), inf = f_set(INFINITY);
    const float s = t->s, half = 0.5f * s;
    const vf vs = f_set(s), vhalf = f_set(half), s_tol = f_set(s * 1.0001f);
    const vf inv_r = f_set(t->inv_r), neg_s = f_set(-s), neg_half = f_set(-half);
    const vf m_half = f_set(-0.5f), p_half = f_set(0.5f);
    const vi lane = lane_ids();
    const int start[3] = {i, j, k};
    const ptrdiff_t stride = axis == 0 ? 1 : axis == 1 ? (ptrdiff_t)nx : (ptrdiff_t)nx * ny;
    const size_t at0 = ((size_t)k * (size_t)ny + (size_t)j) * (size_t)nx + (size_t)i;
    float *out = t->D + at0;
    const vf hv[3] = {f_set(t->h[0]), f_set(t->h[1]), f_set(t->h[2])};
    /* Stages over chunks of up to 64 nodes, with the intermediate vectors
     * in small arrays: one block's work is a long dependency chain (sqrt →
     * divisions → gather → κ index → κ gather → gather) that no core can
     * overlap with the next block's when both sit in one loop iteration
     * (hundreds of instructions each); as separate short loops, the blocks
     * of a stage are independent iterations and their latencies overlap. */
    enum { CHUNK = 64, BLOCKS = CHUNK / TUBE_W };
    vf c_w[3][BLOCKS], c_m[3][BLOCKS], c_y[3][BLOCKS], c_delta[BLOCKS], c_arg[BLOCKS], c_k[BLOCKS];
    const int record_vac = TUBE_VACUUM_CHAINS && t->vac && !resum;
    for (int c0 = 0; c0 < count; c0 += CHUNK) {
        int nb = (count - c0 + TUBE_W - 1) / TUBE_W;
        if (nb > BLOCKS) nb = BLOCKS;
        /* a re-sum's blocks of vacuum chains: D = +0, nothing else */
        int skip[BLOCKS] = {0};
#if TUBE_VACUUM_CHAINS
        for (int bi = 0; bi < nb && t->vac && resum && stride == 1; bi++) {
            int n0 = c0 + TUBE_W * bi, left = count - n0 < TUBE_W ? count - n0 : TUBE_W;
            skip[bi] = vac_skip(t->vac + at0 + n0, out + n0, m_first(left));
        }
#endif
        /* ρ at the nodes being written is read by the nodes half a step
         * further from the light, a few slices/shells later; touching it
         * now (a cache line per 16 nodes along x) brings its lines into
         * the cache before those reads (which otherwise miss: ρ, unlike D,
         * was not written recently). */
        for (int n0 = c0; n0 < c0 + TUBE_W * nb; n0 += 16)
            _mm_prefetch((const char *)(t->rho + at0 + (ptrdiff_t)n0 * stride), _MM_HINT_T0);
        /* 1. chain geometry: ω, δ and the centre of the sphere towards
         *    the light */
        for (int bi = 0; bi < nb; bi++) {
            if (skip[bi]) continue;
            int n0 = c0 + TUBE_W * bi, left = count - n0 < TUBE_W ? count - n0 : TUBE_W;
            vi ln = i_add(i_set(n0), lane);
            /* the node: lo + (float)i·h (scatter_grid_node) */
            vf x[3], w[3], dl = inf;
            vm tiny = m_first(0), valid = m_first(left);
            for (int a = 0; a < 3; a++) {
                vi idx = i_set(start[a]);
                if (a == axis) idx = i_add(idx, ln);
                x[a] = f_add(g.lo[a], f_mul(f_from_i(idx), hv[a]));
            }
            /* chain_start: travel direction and the distance to the light */
            if (t->positional) {
                vf d[3];
                for (int a = 0; a < 3; a++) d[a] = f_sub(x[a], f_set(t->pos[a]));
                vf d2 = f_add(f_add(f_mul(d[0], d[0]), f_mul(d[1], d[1])), f_mul(d[2], d[2]));
                dl = f_sqrt(d2);
                tiny = f_lt(dl, f_set(1e-20f));
                vf inv = f_div(f_set(1.0f), dl);
                for (int a = 0; a < 3; a++) w[a] = f_mul(d[a], inv);
            } else {
                for (int a = 0; a < 3; a++) w[a] = f_set(t->dir[a]);
            }
            /* A block whose nodes are all deep (more than two steps from
             * their chain start) skips the box exit: a deep node uses no
             * δ. A re-sum knows them from the sign bit of the records (see
             * tube.h), a march of a point/spot light from a lower bound of
             * δ (directional nodes here are near their chain start: the
             * others take the fast path, so the test is not worth it). */
            int skip_exit;
            if (resum) {
                vf rec = load_strided(t->g_arg + rec0 + (size_t)((ptrdiff_t)n0 * rec_stride), rec_stride, left);
                skip_exit = m_covers(f_sign(rec), valid);
                c_arg[bi] = f_abs(rec);
            } else {
                skip_exit = t->positional && beyond_two_steps(t, x, w, dl, valid);
            }
            vf delta = inf;
            if (!skip_exit) {
                /* box_exit along back = −ω */
                vf texit = inf;
                for (int a = 0; a < 3; a++) {
                    vf b = f_mul(w[a], f_set(-1.0f));
                    vm pos = f_gt(b, zero), neg = f_lt(b, zero);
                    vf bound = sel(pos, f_set(t->hi[a]), f_set(t->lo[a]));
                    vf ta = f_div(f_sub(bound, x[a]), b);
                    ta = sel(m_or(pos, neg), ta, inf);
                    texit = sel(f_lt(ta, texit), ta, texit);
                }
                texit = sel(f_gt(texit, zero), texit, zero);
                delta = sel(f_lt(texit, dl), texit, dl);
            }
            /* a node at the light: δ = 0, ω = +z */
            delta = sel(tiny, zero, delta);
            w[0] = sel(tiny, zero, w[0]);
            w[1] = sel(tiny, zero, w[1]);
            w[2] = sel(tiny, f_set(1.0f), w[2]);
            /* the sphere between the node and the chain start (Eq. 17) or
             * s back (Eq. 16), and the node s back */
            vm near = f_le(delta, s_tol);
            vf cA = sel(near, f_mul(m_half, delta), neg_half);
            for (int a = 0; a < 3; a++) {
                c_w[a][bi] = w[a];
                c_m[a][bi] = f_add(x[a], f_mul(w[a], cA));
                c_y[a][bi] = f_add(x[a], f_mul(w[a], neg_s));
            }
            c_delta[bi] = delta;
        }
        /* 2. ρ there, as the table argument (a re-sum: the recorded one) */
        for (int bi = 0; bi < nb && !resum; bi++) {
            if (skip[bi]) continue;
            int n0 = c0 + TUBE_W * bi, left = count - n0 < TUBE_W ? count - n0 : TUBE_W;
            vf m[3] = {c_m[0][bi], c_m[1][bi], c_m[2][bi]};
            vf rhoA = sample_clamped(t->rho, &g, m);
            vm near = f_le(c_delta[bi], s_tol);
            c_arg[bi] = sel(near, f_mul(f_mul(f_mul(rhoA, p_half), vs), inv_r), f_mul(f_mul(rhoA, vhalf), inv_r));
            if (t->g_arg) {
                /* deep nodes (δ > 2s) carry the sign bit */
                vm deep = m_andnot(near, f_nle(f_sub(c_delta[bi], vs), vs));
                store_strided(t->g_arg + rec0 + (size_t)((ptrdiff_t)n0 * rec_stride), rec_stride,
                              f_set_sign(c_arg[bi], deep), left);
            }
        }
        /* 3. κ of that sphere */
        for (int bi = 0; bi < nb; bi++)
            if (!skip[bi]) c_k[bi] = kappa_lanes(t, c_arg[bi]);
        /* 4. the front s back (or the exact first step), the sum */
        for (int bi = 0; bi < nb; bi++) {
            if (skip[bi]) continue;
            int n0 = c0 + TUBE_W * bi, left = count - n0 < TUBE_W ? count - n0 : TUBE_W;
            vm valid = m_first(left);
            vf w[3] = {c_w[0][bi], c_w[1][bi], c_w[2][bi]}, y[3] = {c_y[0][bi], c_y[1][bi], c_y[2][bi]};
            vf delta = c_delta[bi], kA = c_k[bi];
            vm near = f_le(delta, s_tol);
            vf v_near = m_any(m_and(near, valid)) ? f_mul(f_div(delta, vs), kA) : zero;
            vf dy = f_sub(delta, vs);
            vm mid = m_andnot(near, f_le(dy, vs));
            vm deep = m_andnot(m_or(near, mid), valid);
            vf back = zero;
            /* a march's vacuum-chain invariant (vac_record): the lanes
             * that are +0 for every κ whose reads are */
            vm argz = f_eq(c_arg[bi], zero), ok = m_first(0);
            if (record_vac) ok = m_and(near, m_or(argz, f_eq(delta, zero)));
            if (m_any(m_and(mid, valid))) {
                /* y within the first step: its D exactly (Eq. 17) */
                vf cB = f_mul(m_half, dy), mB[3];
                for (int a = 0; a < 3; a++) mB[a] = f_add(y[a], f_mul(w[a], cB));
                vf rhoB = sample_clamped(t->rho, &g, mB);
                vf argB = f_mul(f_mul(rhoB, vhalf), inv_r);
                vf kB = kappa_lanes(t, argB);
                if (record_vac) ok = m_or(ok, m_and(m_and(mid, argz), m_or(f_eq(argB, zero), f_eq(dy, zero))));
                back = sel(mid, f_mul(f_div(dy, vs), kB), back);
            }
            if (m_any(deep)) {
                vf f[3];
                vi cell[3];
                strict_cell(&g, y, cell, f);
#if TUBE_VACUUM_CHAINS
                vm zc = m_first(0);
                int want_zc = record_vac && m_any(m_and(deep, argz));
                back = sel(deep, strict_at(t->D, &g, cell, f, deep, want_zc ? &zc : NULL), back);
                ok = m_or(ok, m_and(m_and(deep, argz), zc));
#else
                back = sel(deep, strict_at(t->D, &g, cell, f, deep), back);
#endif
            }
            vf res = sel(near, v_near, f_add(back, kA));
            store_strided(out + (ptrdiff_t)n0 * stride, stride, res, left);
#if TUBE_VACUUM_CHAINS
            if (record_vac) vac_record(t->vac + at0 + (ptrdiff_t)n0 * stride, stride, t->vac_bad, res, ok, valid);
#else
            (void)ok;
#endif
        }
    }
}

TI void nodes_body(const tube_lanes *t, int i, int j, int k, int axis, int count, size_t rec0, ptrdiff_t rec_stride) {
    if (t->resum) nodes_pass(t, i, j, k, axis, count, rec0, rec_stride, 1);
    else nodes_pass(t, i, j, k, axis, count, rec0, rec_stride, 0);
}

/* Σ_c a[c]·p[o[c]] over the 8 corners, left to right and unfused (the
 * scalar loop's sum), for the lanes in k; the loaded corners to dv if it
 * is not NULL (else each load folds into its multiply: AVX2 has too few
 * registers to keep them). */
TI vf corner_sum(const vf a[8], const float *p, const ptrdiff_t *o, vm k, int full, vf *dv) {
    vf sum = f_zero();
    for (int c = 0; c < 8; c++) {
        vf x = f_load_masked(p + o[c], k, full);
        if (dv) dv[c] = x;
        sum = c ? f_add(sum, f_mul(a[c], x)) : f_mul(a[c], x);
    }
    return sum;
}

/* tube.c's fast_run on TUBE_W nodes at a time: out[i] for i < count from
 * D and R at the constant offsets; the tail is masked (no element past the
 * run is touched). */
TI void fast_body(const tube_fast *fr, float *out, const float *D, const float *R, float *u_io, unsigned char *vac,
                  int resum, int count) {
    const ptrdiff_t *ov = fr->off_v, *orr = fr->off_r;
    vf a[8], b[8];
    for (int c = 0; c < 8; c++) a[c] = f_set(fr->w_v[c]), b[c] = f_set(fr->w_r[c]);
    const vf kscale = f_set(fr->kscale), last = f_set(fr->last), half = f_set(0.5f);
    for (int i = 0; i < count; i += TUBE_W) {
        const float *d = D + i, *r = R + i;
        const int full = count - i >= TUBE_W;
        const vm k = m_first(count - i);
#if TUBE_VACUUM_CHAINS
        if (vac && resum && vac_skip(vac + i, out + i, k)) continue;
#endif
        /* ρ (or the recorded coordinates) was not touched since the last
         * sweep: the rows' lines come from memory. Prefetch them a few
         * hundred nodes ahead (the four corner rows of the read; the
         * hardware prefetcher does not keep up with 9 concurrent streams). */
        if (!(i & 15)) {
            if (resum) {
                _mm_prefetch((const char *)(u_io + i + 256), _MM_HINT_T0);
            } else {
                for (int c = 0; c < 8; c += 2) _mm_prefetch((const char *)(r + orr[c] + 256), _MM_HINT_T0);
            }
        }
        vf dv[8]; /* the D corners, for the vacuum-chain test */
        vf back = corner_sum(a, d, ov, k, full, TUBE_VACUUM_CHAINS ? dv : NULL);
        vf u;
        if (resum) {
            u = f_load_masked(u_io + i, k, full);
        } else {
            vf x = f_mul(corner_sum(b, r, orr, k, full, NULL), kscale);
            /* min(x, last) as the scalar code writes it: 0.5 (x + last − |x − last|) */
            u = f_mul(half, f_sub(f_add(x, last), f_abs(f_sub(x, last))));
            if (u_io) f_store_masked(u_io + i, u, k, full);
        }
        vi j = f_trunc(u);
        vf f = f_sub(u, f_from_i(j)), k0, k1;
        kappa_pair(fr->kappa, j, k, &k0, &k1);
        vf res = f_add(f_add(back, k0), f_mul(f_sub(k1, k0), f));
        f_store_masked(out + i, res, k, full);
#if TUBE_VACUUM_CHAINS
        if (vac && !resum) {
            /* +0 for every κ with κ(0) = +0: u = 0 and every node read +0 */
            vm uz = f_eq(u, f_zero());
            vac_record(vac + i, 1, fr->vac_bad, res, m_any(uz) ? m_and(uz, corners_zero(dv)) : m_first(0), k);
        }
#else
        (void)vac;
#endif
    }
}

/* ---------------------------------------------------------- entry points */

TUBE_TARGET static void tube_nodes(const tube_lanes *t, int i, int j, int k, int axis, int count, size_t rec0,
                                   ptrdiff_t rec_stride) {
    nodes_body(t, i, j, k, axis, count, rec0, rec_stride);
}

/* Runs (i, j, k, axis, count) of a point sweep in one call: the records
 * are in node order. One call per batch keeps the switches between this
 * code and the scalar caller rare (measured with AVX-512: a tenth of a
 * re-sum's time went to them with one call per run). */
TUBE_TARGET static void tube_runs(const tube_lanes *t, const int (*runs)[5], int n_runs) {
    const size_t nx = (size_t)t->dims[0], nxy = nx * (size_t)t->dims[1];
    for (int r = 0; r < n_runs; r++) {
        const int *q = runs[r];
        ptrdiff_t stride = q[3] == 0 ? 1 : q[3] == 1 ? (ptrdiff_t)nx : (ptrdiff_t)nxy;
        nodes_body(t, q[0], q[1], q[2], q[3], q[4], (size_t)q[2] * nxy + (size_t)q[1] * nx + (size_t)q[0], stride);
    }
}

TUBE_TARGET static void tube_fast_run(const tube_fast *fr, float *out, const float *D, const float *R, float *u_io,
                                      unsigned char *vac, int resum, int count) {
    fast_body(fr, out, D, R, u_io, vac, resum, count);
}

/* A directional row along x in one call: nodes [0, c0) and (c1, n) by the
 * node update, [c0, c1] by the fast path (c1 < c0: none). */
TUBE_TARGET static void tube_row(const tube_lanes *t, const tube_fast *fr, int j, int k, int n, int c0, int c1,
                                 size_t rec0, int resum) {
    const size_t at = ((size_t)k * (size_t)t->dims[1] + (size_t)j) * (size_t)t->dims[0];
    int f0 = c1 >= c0 ? c0 : n, f1 = c1 >= c0 ? c1 + 1 : n;
    if (f0 > 0) nodes_body(t, 0, j, k, 0, f0, rec0, 1);
    if (f1 > f0)
        fast_body(fr, t->D + at + f0, t->D + at + f0, t->rho + at + f0, t->g_arg ? t->g_arg + rec0 + f0 : NULL,
                  t->vac ? t->vac + at + f0 : NULL, resum, f1 - f0);
    if (n > f1) nodes_body(t, f1, j, k, 0, n - f1, rec0 + (size_t)f1, 1);
}

static const tube_kernels kernels = {TUBE_W, TUBE_VACUUM_CHAINS, tube_nodes, tube_runs, tube_row, tube_fast_run};
