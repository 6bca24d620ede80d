/*
 * techniques/lightvol/sweep.c — the sweep driver: coherence-based light
 * propagation (§4, §6), one pass at a time.
 *
 * A pass sweeps the slices of one propagation group (an axis and a sign)
 * and carries every light of the pass in its own pair of 2-D slice buffers
 * (read = previous slice, write = current slice). Per voxel and light, the
 * light is fetched from the previous slice where the line towards the light
 * crosses it (Ropinski et al. 2010), attenuated over that segment, and the
 * forward-scattered part is gathered from a cone around that point. The
 * lights' values, weighted by their Eq. 5 contribution factors for the
 * group and signed (+1 add, −1 remove), are summed and added to the
 * illumination volume slice by slice.
 *
 * What the buffers hold, so that light is never created where none arrives:
 *   directional: irradiance E along the ray (W/m²), initialised with the
 *                light's E0 (constant projection, Fig. 5 left);
 *   point/spot:  intensity J along the ray (W/sr), initialised with the
 *                projection I·cone(θ) of the light on the first slice
 *                (Fig. 5 middle/right); the voxel receives J / r².
 * Both are constant along a ray in empty space and are only ever multiplied
 * by transmittances ≤ 1 or averaged, so they never exceed the unoccluded
 * value. The per-voxel formula of §4, l_i = (1 − α)·l_{i−1} + α·c, is read
 * as l_i = l_{i−1}·(1 − α + α·f·a·c): the absorbed-or-scattered fraction α
 * is lost except the forward-scattered part f·albedo·colour, taken in its
 * continuous (step-size independent) form
 *     l_i = l_{i−1} · exp(−len·(σt − f·σs)),   σs = albedo·c·σt,
 * with the forward-scattered share gathered from the cone.
 *
 * Built with -fno-math-errno -fno-trapping-math (CMakeLists.txt): the
 * sweeps never look at errno or FP exception flags, and without them the
 * compiler can use sqrt instructions and if-convert volux_exp_neg_cw7 and the Eq. 5
 * factors, so the row loops vectorise (same operations, same rounding).
 *
 * Slices are parallel within themselves (chunks of rows, one phase of
 * volux_parallel_phases per slice: one parallel region per sweep);
 * every voxel depends only on the complete previous slice, so the result is
 * the same for any thread count.
 *
 * This file sets a pass up (per light: offsets, taps, cone stencil,
 * sub-samples), drives its slices (volux_parallel_phases: classify the next
 * slice's medium while propagating the current one), runs each row over the
 * pass's lights (rows_dir.c, rows_pos.c) and adds or stores the row into the
 * volume (x sweeps through a staging slab); volux_lightvol_run_passes runs
 * a plan (plan.c).
 */

#include <math.h>
#include <string.h>

#include "core/bf16.h"
#include "core/context_internal.h"
#include "core/parallel.h"
#include "core/vecmath.h"
#include "rows.h"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

/* ------------------------------------------------------------ rows → volume */

/* The illumination volume is float or bfloat16 (lightvol_state.vol): a
 * bfloat16 write is "decode, add the row's float, round to nearest even"
 * (or a rounding store when an entire update overwrites), the same
 * rounding in the SSE2 steps as in the scalar tails. */
#if defined(__SSE2__)
/* Four floats to bfloat16 in the low 64 bits (volux_bf16_from_float's
 * rounding; the sums here are finite, never NaN). The rounded word >> 16
 * is sign-extended, so the signed pack keeps it exactly. */
static inline __m128i bf16_pack4(__m128 v) {
    __m128i u = _mm_castps_si128(v);
    __m128i bias = _mm_add_epi32(_mm_set1_epi32(0x7fff), _mm_and_si128(_mm_srli_epi32(u, 16), _mm_set1_epi32(1)));
    __m128i r = _mm_srai_epi32(_mm_add_epi32(u, bias), 16);
    return _mm_packs_epi32(r, r);
}

static inline __m128 bf16_load4(const uint16_t *p) {
    return _mm_castsi128_ps(_mm_unpacklo_epi16(_mm_setzero_si128(), _mm_loadl_epi64((const __m128i *)(const void *)p)));
}

/* Voxels u … u + 3 of the six planes as 24 interleaved floats o[0..5]. */
static inline void aos6_transpose(const float *q, size_t m, int u, __m128 o[6]) {
    __m128 a = _mm_loadu_ps(q + u), b = _mm_loadu_ps(q + m + u), c = _mm_loadu_ps(q + 2 * m + u),
           d = _mm_loadu_ps(q + 3 * m + u), e = _mm_loadu_ps(q + 4 * m + u), f = _mm_loadu_ps(q + 5 * m + u);
    _MM_TRANSPOSE4_PS(a, b, c, d); /* a: channels 0–3 of voxel u, b: of u + 1, … */
    __m128 ef_lo = _mm_unpacklo_ps(e, f), ef_hi = _mm_unpackhi_ps(e, f); /* (4, 5) of u, u+1 | u+2, u+3 */
    o[0] = a;
    o[1] = _mm_shuffle_ps(ef_lo, b, _MM_SHUFFLE(1, 0, 1, 0));
    o[2] = _mm_shuffle_ps(b, ef_lo, _MM_SHUFFLE(3, 2, 3, 2));
    o[3] = c;
    o[4] = _mm_shuffle_ps(ef_hi, d, _MM_SHUFFLE(1, 0, 1, 0));
    o[5] = _mm_shuffle_ps(d, ef_hi, _MM_SHUFFLE(3, 2, 3, 2));
}
#endif

/* dst[6u + c] (+)= q[c·m + u] for u in [0, n): a row of the six-channel
 * accumulator (planes of m floats) into the interleaved float layout (x
 * rows of y/z sweeps, the x sweeps' staging). The same single add or copy
 * per element as the plain loop (bit-identical); with SSE2 four voxels a
 * step through a 4×4 transpose, where the compiler left the interleaving
 * scalar (the fixed work of every pass, issue 17). */
static void rows_to_aos6(float *restrict dst, const float *restrict q, size_t m, int n, int overwrite) {
    int u = 0;
#if defined(__SSE2__)
    for (; u + 4 <= n; u += 4) {
        __m128 o[6];
        aos6_transpose(q, m, u, o);
        float *p = dst + 6 * (size_t)u;
        if (overwrite)
            for (int k = 0; k < 6; k++) _mm_storeu_ps(p + 4 * k, o[k]);
        else
            for (int k = 0; k < 6; k++) _mm_storeu_ps(p + 4 * k, _mm_add_ps(_mm_loadu_ps(p + 4 * k), o[k]));
    }
#endif
    for (; u < n; u++) {
        float *p = dst + 6 * (size_t)u;
        if (overwrite)
            for (int c = 0; c < 6; c++) p[c] = q[(size_t)c * m + (size_t)u];
        else
            for (int c = 0; c < 6; c++) p[c] += q[(size_t)c * m + (size_t)u];
    }
}

/* The same row into the volume's bfloat16 voxels: dst[6u + c] (+)= q[c·m + u]. */
static void rows_to_aos6_bf16(uint16_t *restrict dst, const float *restrict q, size_t m, int n, int overwrite) {
    int u = 0;
#if defined(__SSE2__)
    for (; u + 4 <= n; u += 4) {
        __m128 o[6];
        aos6_transpose(q, m, u, o);
        uint16_t *p = dst + 6 * (size_t)u;
        for (int k = 0; k < 6; k++) {
            __m128 v = overwrite ? o[k] : _mm_add_ps(bf16_load4(p + 4 * k), o[k]);
            _mm_storel_epi64((__m128i *)(void *)(p + 4 * k), bf16_pack4(v));
        }
    }
#endif
    for (; u < n; u++) {
        uint16_t *p = dst + 6 * (size_t)u;
        for (int c = 0; c < 6; c++) {
            float x = q[(size_t)c * m + (size_t)u];
            p[c] = volux_bf16_from_float(overwrite ? x : volux_bf16_to_float(p[c]) + x);
        }
    }
}

/* dst[c] (+)= src[c] for c in [0, n): floats into bfloat16 voxels. */
static void add_bf16(uint16_t *restrict dst, const float *restrict src, int n, int overwrite) {
    int c = 0;
#if defined(__SSE2__)
    for (; c + 4 <= n; c += 4) {
        __m128 v = _mm_loadu_ps(src + c);
        if (!overwrite) v = _mm_add_ps(bf16_load4(dst + c), v);
        _mm_storel_epi64((__m128i *)(void *)(dst + c), bf16_pack4(v));
    }
#endif
    for (; c < n; c++) dst[c] = volux_bf16_from_float(overwrite ? src[c] : volux_bf16_to_float(dst[c]) + src[c]);
}

/* Voxel `at` (index of its first value) (+)= src[0 .. n), either precision. */
static inline void add_voxel(const lightvol_state *st, size_t at, const float *restrict src, int n, int overwrite) {
    if (!st->volf) {
        add_bf16(st->vol + at, src, n, overwrite);
        return;
    }
    float *p = st->volf + at;
    if (overwrite)
        for (int c = 0; c < n; c++) p[c] = src[c];
    else
        for (int c = 0; c < n; c++) p[c] += src[c];
}

/* ------------------------------------------------------------ pass setup */

/* Bilinear tap at slice offset (du, dv): its cell and weights. */
static inline lv_tap make_tap(float du, float dv) {
    float fu = floorf(du), fv = floorf(dv);
    lv_tap t;
    t.di = (int)fu;
    t.dj = (int)fv;
    float a = du - fu, b = dv - fv;
    t.w00 = (1.0f - a) * (1.0f - b);
    t.w10 = a * (1.0f - b);
    t.w01 = (1.0f - a) * b;
    t.w11 = a * b;
    return t;
}

/* Widens e's tap extents (the row-interior test) to hold t. */
static inline void extend(lv_entry *e, lv_tap t) {
    if (t.di < e->di_min) e->di_min = t.di;
    if (t.di > e->di_max) e->di_max = t.di;
    if (t.dj < e->dj_min) e->dj_min = t.dj;
    if (t.dj > e->dj_max) e->dj_max = t.dj;
}

/* Medium sub-samples along a segment with sideways offset (ou, ov): one per
 * voxel of travel (see LV_MAX_SUB). */
static inline int sub_count(float ou, float ov) {
    float m = fmaxf(fabsf(ou), fabsf(ov));
    return m <= 1.0f ? 1 : (m >= (float)LV_MAX_SUB ? LV_MAX_SUB : (int)ceilf(m));
}

/* Fills e->nst/sj/si/swc/swk (see lv_entry) from the centre and cone taps. */
static void build_stencil(lv_entry *e) {
    int c0 = e->tc.di, c1 = c0, r0 = e->tc.dj, r1 = r0;
    for (int q = 0; q < 4; q++) {
        const lv_tap *t = &e->tcone[q];
        c0 = t->di < c0 ? t->di : c0, c1 = t->di > c1 ? t->di : c1;
        r0 = t->dj < r0 ? t->dj : r0, r1 = t->dj > r1 ? t->dj : r1;
    }
    e->nst = 0;
    if (c1 - c0 > 1 || r1 - r0 > 1) return; /* footprint wider than 3×3 */
    float wk[3][3] = {{0}};
    for (int q = 0; q < 4; q++) {
        const lv_tap *t = &e->tcone[q];
        int j = t->dj - r0, i = t->di - c0;
        wk[j][i] += 0.25f * t->w00, wk[j][i + 1] += 0.25f * t->w10;
        wk[j + 1][i] += 0.25f * t->w01, wk[j + 1][i + 1] += 0.25f * t->w11;
    }
    const float wc[4] = {e->tc.w00, e->tc.w10, e->tc.w01, e->tc.w11};
    int used[3][3] = {{0}}, n = 0;
    for (int k = 0; k < 4; k++) { /* the centre's nodes first */
        int j = e->tc.dj - r0 + k / 2, i = e->tc.di - c0 + k % 2;
        e->sj[n] = r0 + j, e->si[n] = c0 + i, e->swc[n] = wc[k], e->swk[n] = wk[j][i];
        used[j][i] = 1;
        n++;
    }
    for (int j = 0; j < 3; j++)
        for (int i = 0; i < 3; i++)
            if (!used[j][i] && wk[j][i] != 0.0f) e->sj[n] = r0 + j, e->si[n] = c0 + i, e->swk[n] = wk[j][i], n++;
    e->nst = n;
}

/* ------------------------------------------------------------ rows */

/* Writes the last nb staged slices of row v (steps J->step − nb + 1 …
 * J->step, staged at step % defer) into the volume: for each u a
 * contiguous run of nb voxels along x (the sweep axis). */
static void flush_row(const lv_sweep *J, int v, int nb) {
    const lightvol_state *st = J->st;
    const int mu = J->mu, ch = st->ch;
    const size_t m = (size_t)mu;
    const size_t plane = (size_t)J->mu * (size_t)J->mv;
    /* u outer so that the nb voxels of one x-run are written together */
    const size_t su = J->vs[J->au] * (size_t)ch;
    const int k_lo = J->s > 0 ? J->step - (nb - 1) : J->ma - 1 - J->step; /* lowest x of the runs */
    const size_t value = st->volf ? sizeof *st->volf : sizeof *st->vol;
    const char *run0 = (const char *)(st->volf ? (const void *)st->volf : (const void *)st->vol) +
                       ((size_t)k_lo * J->vs[J->a] + (size_t)v * J->vs[J->av]) * (size_t)ch * value;
    const size_t run_bytes = (size_t)nb * (size_t)ch * value;
    for (int u = 0; u < mu; u++) {
        /* the runs are a whole x-row apart: prefetch a few ahead */
        if (u + 6 < mu)
            for (size_t off = 0; off < run_bytes; off += 64)
                __builtin_prefetch(run0 + (size_t)(u + 6) * su * value + off, 1, 3);
        for (int b = 0; b < nb; b++) {
            int step = J->step - (nb - 1 - b);
            int k = J->s > 0 ? step : J->ma - 1 - step;
            const size_t at = (size_t)(step % J->defer); /* where sweep_row staged it */
            const float *src = st->stage + (at * plane + (size_t)v * m + (size_t)u) * (size_t)ch;
            add_voxel(st, ((size_t)k * J->vs[J->a] + (size_t)v * J->vs[J->av]) * (size_t)ch + (size_t)u * su, src, ch,
                      J->overwrite);
        }
    }
}

/* D += ω·S over a row (a run of same-direction lights, see sweep_row). */
static void flush_run(float *d, size_t m, const float *restrict S, volux_vec3 w, int n) {
    float *restrict dx = d, *restrict dy = d + m, *restrict dz = d + 2 * m;
    for (int u = 0; u < n; u++) {
        dx[u] += w.x * S[u];
        dy[u] += w.y * S[u];
        dz[u] += w.z * S[u];
    }
}

/* Row v of the current slice: every light of the pass (rows_dir.c,
 * rows_pos.c) into its slice buffer, their weighted sum added to (first
 * pass of an entire update: stored in) the volume. */
static void sweep_row(const lv_sweep *J, int v, int thread) {
    lightvol_state *st = J->st;
    int mu = J->mu, ch = st->ch;
    size_t m = (size_t)mu;
    float *sc = st->rows + (size_t)thread * st->row_stride;
    float *acc = sc, *T = acc + 6 * m;
    float *Tc[3] = {T + m, T + 2 * m, T + 3 * m};
    float *cone[3] = {T + 4 * m, T + 5 * m, T + 6 * m};
    float *cen[3] = {T + 7 * m, T + 8 * m, T + 9 * m};
    float *tau[4] = {T + 10 * m, T + 11 * m, T + 12 * m, T + 13 * m};
    memset(acc, 0, (size_t)ch * m * sizeof(float));
    const lv_entry *last = NULL;
    size_t off = (size_t)v * m;
    int run = 0; /* a run of same-direction lights is open (SIMD, ch = 6) */
    lv_row_geom G = {NULL, 0, 0};
    for (int i = 0; i < J->ne; i++) {
        const lv_entry *e = &J->e[i];
        float *out[3] = {e->wr[0] + off, e->wr[1] + off, e->wr[2] + off};
        if (e->s->kind == LV_POSITIONAL) {
            volux_lightvol_pos_row(J, e, v, out, acc, ch, T + 14 * m);
            continue;
        }
        if (J->simd) {
            /* Consecutive lights with one direction: D += ω·Σ sw·lum(E_l)
             * once for the run (lum is linear), not per light; the run's sum
             * lives in the row scratch that the portable path uses for cen. */
            float *S = NULL;
            if (ch == 6) {
                const lv_entry *nx = i + 1 < J->ne ? &J->e[i + 1] : NULL;
                int same_next = nx && nx->s->kind == LV_DIRECTIONAL && nx->s->dir.x == e->s->dir.x &&
                                nx->s->dir.y == e->s->dir.y && nx->s->dir.z == e->s->dir.z;
                if (!run && same_next) memset(cen[0], 0, m * sizeof(float)), run = 1;
                S = run ? cen[0] : NULL;
                volux_lightvol_dir_row_simd(J, e, v, out, T, Tc, tau, &G, acc, ch, S);
                if (run && !same_next) {
                    flush_run(acc + 3 * m, m, cen[0], e->s->dir, mu);
                    run = 0;
                }
                continue;
            }
            volux_lightvol_dir_row_simd(J, e, v, out, T, Tc, tau, &G, acc, ch, S);
            continue;
        }
        volux_lightvol_dir_row(J, e, v, out, T, Tc, cone, cen, tau, &last);
        for (int c = 0; c < 3; c++) lv_accumulate(acc + (size_t)c * m, out[c], e->sw, mu);
        if (ch == 6) lv_accumulate_dir(acc + 3 * m, m, out, e->dsw, mu);
    }
    /* Add (or, first pass of a full rebuild, store) into the volume. */
    size_t base = (size_t)J->k * J->vs[J->a] + (size_t)v * J->vs[J->av], su = J->vs[J->au];
    const size_t stride = su * (size_t)ch;
    if (J->defer) {
        /* x sweep: park the row in the staging slab (slice-major, AoS,
         * float) and flush runs of `defer` voxels along x every `defer`
         * slices */
        int b = J->step % J->defer;
        float *restrict dst = st->stage + ((size_t)b * (size_t)J->mu * (size_t)J->mv + (size_t)v * m) * (size_t)ch;
        if (ch == 6) rows_to_aos6(dst, acc, m, mu, 1);
        else
            for (int u = 0; u < mu; u++)
                for (int c = 0; c < ch; c++) dst[(size_t)u * (size_t)ch + (size_t)c] = acc[(size_t)c * m + (size_t)u];
        /* ... and at the end of the steps of this call (a budgeted
         * update, §7.3): only the slices staged since it began */
        if (b == J->defer - 1 || J->step == J->last) {
            int nb = J->step - J->first + 1;
            flush_row(J, v, nb < b + 1 ? nb : b + 1);
        }
        return;
    }
    if (ch == 6 && stride == 6) { /* y and z sweeps: the row is contiguous along x */
        if (st->volf) rows_to_aos6(st->volf + base * 6, acc, m, mu, J->overwrite);
        else rows_to_aos6_bf16(st->vol + base * 6, acc, m, mu, J->overwrite);
        return;
    }
    for (int u = 0; u < mu; u++) {
        float x[6];
        for (int c = 0; c < ch; c++) x[c] = acc[(size_t)c * m + (size_t)u];
        add_voxel(st, base * (size_t)ch + (size_t)u * stride, x, ch, J->overwrite);
    }
}

/* ------------------------------------------------------------ slices */

/* One work item of a slice step: a chunk of rows of the current slice's
 * sweep, or a chunk of rows of the next slice's classification (the
 * pipeline keeps one fork/join per slice). */
static void step_item(void *user, int64_t item, int thread) {
    const lv_sweep *J = user;
    int i = (int)item, rpi = J->rows_per_item;
    if (i < J->sweep_items) {
        int v0 = i * rpi, v1 = v0 + rpi < J->mv ? v0 + rpi : J->mv;
        for (int v = v0; v < v1; v++) sweep_row(J, v, thread);
    } else {
        i -= J->sweep_items;
        int v0 = i * rpi, v1 = v0 + rpi < J->mv ? v0 + rpi : J->mv;
        volux_lightvol_classify_rows(J, J->mn, J->kn, v0, v1);
    }
}

/* Each light's slice buffers: what step k wrote is what step k + 1 reads. */
static void swap_slice_buffers(lv_entry *E, int n) {
    for (int i = 0; i < n; i++)
        for (int c = 0; c < 3; c++) {
            float *t = E[i].rd[c];
            E[i].rd[c] = E[i].wr[c];
            E[i].wr[c] = t;
        }
}

/* Serial part of sweep phase p (volux_parallel_phases; returns the phase's
 * item count for step_item). Phase 0 classifies the first slice's medium;
 * phase p ≥ 1 propagates slice step p − 1 and classifies the next slice
 * together — the propagation reads only the previous and current slices'
 * media. The media rotate through three buffers. */
static int64_t sweep_phase(void *user, int phase) {
    lv_sweep *J = user;
    phase += J->phase0; /* a call that resumes a sweep at step s0 starts at phase s0 + 1 */
    if (phase == 0) {
        J->mn = J->med[0];
        J->kn = J->s > 0 ? 0 : J->ma - 1;
        J->sweep_items = 0;
        J->class_items = J->chunks;
        return J->chunks;
    }
    int step = phase - 1;
    if (step > 0) swap_slice_buffers(J->e, J->ne);
    J->step = step;
    J->k = J->s > 0 ? step : J->ma - 1 - step;
    J->kp = J->k - J->s;
    J->mc = J->med[step % 3];
    J->mp = J->med[(step + 2) % 3];
    J->mn = J->med[(step + 1) % 3];
    J->kn = step + 1 < J->ma ? J->k + J->s : -1;
    for (int i = 0; i < J->ne; i++) {
        lv_entry *e = &J->e[i];
        if (e->s->kind == LV_DIRECTIONAL) {
            e->mode = step == 0 ? E_INIT : E_PROP;
        } else {
            /* slices ahead of the light along the sweep only (§7.3: a
             * light inside the volume needs the opposite groups too) */
            float dist = (float)J->s * ((float)J->k - e->lidx[J->a]);
            if (dist <= 0.0f) e->mode = E_SKIP;
            else if (dist <= 1.0f) e->mode = E_INIT_ATT;
            else if (step == 0) e->mode = E_INIT; /* projection onto the first slice (§6, Fig. 5) */
            else e->mode = E_PROP, e->f = 1.0f / dist;
        }
    }
    J->sweep_items = J->chunks;
    J->class_items = J->kn >= 0 ? J->chunks : 0;
    return J->sweep_items + J->class_items;
}

/* ------------------------------------------------------------ passes */

int volux_lightvol_pass_steps(const lightvol_state *st, const lv_pass *p) { return st->dims[p->g / 2]; }

double volux_lightvol_step_work(const lightvol_state *st, const lv_job *job, int p) {
    const lv_pass *ps = &job->passes[p];
    const lv_work_weights w = volux_lightvol_work_weights(st);
    double work = 1.0;
    for (int i = 0; i < ps->n; i++) work += job->items[job->idx[ps->first + i]].src.kind == LV_DIRECTIONAL ? w.dir : w.pos;
    int a = ps->g / 2;
    return work * (double)st->dims[a == 0 ? 1 : 0] * (double)st->dims[a == 2 ? 1 : 2];
}

/* Steps [s0, s1) of one propagation pass: group g, the lights
 * items[idx[0..n)], entries E. */
static void sweep(lightvol_state *st, int g, const lv_item *items, const int *idx, int n, int overwrite, lv_entry *E,
                  int s0, int s1) {
    lv_sweep J;
    memset(&J, 0, sizeof J);
    J.st = st;
    J.g = g;
    J.a = g / 2;
    J.s = (g & 1) ? -1 : 1;
    J.au = J.a == 0 ? 1 : 0;
    J.av = J.a == 2 ? 1 : 2;
    J.mu = st->dims[J.au];
    J.mv = st->dims[J.av];
    J.ma = st->dims[J.a];
    J.vs[0] = 1;
    J.vs[1] = (size_t)st->dims[0];
    J.vs[2] = (size_t)st->dims[0] * (size_t)st->dims[1];
    J.area = st->area;
    J.overwrite = overwrite;
    J.fwd = st->p.forward;
    J.forward = st->p.forward > 0.0f;
    J.cone = J.forward && st->p.cone_deg > 0.0f;
    J.tan_c = tanf(st->p.cone_deg * VOLUX_PI / 180.0f) * 0.70710678f; /* disc of radius ρ ↔ 4 taps at ρ/√2 */
    J.rmin2 = lv_rmin2(st);
    J.nplanes = J.forward ? 4 : 1;
    J.post = st->on_grid;
    J.lut = st->rc.lut;
    J.albedo = st->rc.albedo;
    /* the AVX2 row-end steps read 9-column windows */
    J.simd = st->use_simd && J.mu >= 9;
    J.avx512 = J.simd && st->use_avx512;
    J.ne = n;
    /* x sweeps write the volume a whole x-row apart per voxel; staging
     * `LV_DEFER` slices turns that into runs along x (same values) */
    J.defer = J.a == 0 ? LV_DEFER : 0;
    J.e = E;
    size_t plane = st->area;
    for (int i = 0; i < n; i++) {
        lv_entry *e = &E[i];
        memset(e, 0, sizeof *e);
        const lv_item *it = &items[idx[i]];
        e->s = &it->src;
        e->sign = it->sign;
        e->nch = 3;
        e->gain[0] = e->gain[1] = e->gain[2] = 1.0f;
        if (J.simd && !J.forward) {
            e->nch = 1;
            e->norm = it->src;
            e->norm.power = v3(1.0f, 1.0f, 1.0f);
            e->s = &e->norm;
            e->gain[0] = it->src.power.x, e->gain[1] = it->src.power.y, e->gain[2] = it->src.power.z;
        }
        float *b = st->slices + (size_t)i * 6 * plane;
        for (int c = 0; c < 3; c++) {
            e->rd[c] = b + (size_t)c * plane;
            e->wr[c] = b + (size_t)(3 + c) * plane;
        }
        if (e->s->kind == LV_DIRECTIONAL) {
            float w[3] = {e->s->dir.x, e->s->dir.y, e->s->dir.z};
            e->sw = e->sign * e->s->weight[g];
            e->dsw = v3_scale(e->s->dir, e->sw);
            /* Back along the light to the previous slice: one slice spacing
             * along the axis (Ropinski et al. 2010). */
            float t = st->spacing[J.a] / fabsf(w[J.a]);
            float lim = 4.0f * (float)(J.mu + J.mv);
            e->du = clampf(-w[J.au] * t / st->spacing[J.au], -lim, lim);
            e->dv = clampf(-w[J.av] * t / st->spacing[J.av], -lim, lim);
            e->len = t;
            e->tc = make_tap(e->du, e->dv);
            e->di_min = e->di_max = e->tc.di;
            e->dj_min = e->dj_max = e->tc.dj;
            if (J.cone) {
                float rho = t * J.tan_c, ru = rho / st->spacing[J.au], rv = rho / st->spacing[J.av];
                const float ox[4] = {ru, -ru, 0.0f, 0.0f}, oy[4] = {0.0f, 0.0f, rv, -rv};
                for (int q = 0; q < 4; q++) {
                    e->cu[q] = clampf(e->du + ox[q], -lim, lim);
                    e->cv[q] = clampf(e->dv + oy[q], -lim, lim);
                    e->tcone[q] = make_tap(e->cu[q], e->cv[q]);
                    extend(e, e->tcone[q]);
                }
            }
            if (J.cone) build_stencil(e);
            e->nsub = sub_count(e->du, e->dv);
            for (int q = 0; q < e->nsub; q++) {
                float tq = ((float)q + 0.5f) / (float)e->nsub;
                e->su[q] = e->du * (1.0f - tq);
                e->sv[q] = e->dv * (1.0f - tq);
                e->wp[q] = (1.0f - tq) * t / (float)e->nsub;
                e->wc[q] = tq * t / (float)e->nsub;
                e->ts[q] = make_tap(e->su[q], e->sv[q]);
                extend(e, e->ts[q]);
            }
        } else {
            volux_vec3 q = v3_sub(e->s->pos, st->lo);
            e->lidx[0] = q.x / st->spacing[0];
            e->lidx[1] = q.y / st->spacing[1];
            e->lidx[2] = q.z / st->spacing[2];
            if (e->s->center) {
                e->cw = e->s->weight[g];
                for (int h = 0; h < LV_GROUPS; h++) {
                    if (h == g || !(e->s->groups & (1u << h))) continue;
                    int ah = h / 2; /* never J.a: the two closest faces lie on different axes */
                    e->oax = ah == J.au ? 1 : 2;
                    e->osg = (h & 1) ? -1 : 1;
                    e->ol = e->lidx[ah];
                }
            }
        }
    }
    /* Work split: chunks of rows worth ~4k voxel·lights each; small slices
     * run on one thread (fork/join would cost more than the work). */
    const size_t sb = lv_med_stride(st);
    int threads = st->rc.threads > 0 ? st->rc.threads : 1;
    size_t work = (size_t)J.mu * (size_t)J.mv * (size_t)(n + 1);
    if (work < 16384) threads = 1;
    size_t row_work = (size_t)J.mu * (size_t)(n + 1);
    J.rows_per_item = (int)((4096 + row_work - 1) / row_work);
    if (J.rows_per_item < 1) J.rows_per_item = 1;
    if (threads > 1 && J.rows_per_item * 4 * threads > J.mv) {
        J.rows_per_item = J.mv / (4 * threads);
        if (J.rows_per_item < 1) J.rows_per_item = 1;
    }
    J.chunks = (J.mv + J.rows_per_item - 1) / J.rows_per_item;
    J.med[0] = st->med;
    J.med[1] = st->med + sb;
    J.med[2] = st->med + 2 * sb;
    /* Resuming at step s0 > 0: the medium of slices s0 − 1 and s0 is still
     * in med[(s0 − 1) % 3] and med[s0 % 3] (the rotation is by step), and
     * step s0 − 1 wrote each light's buffer set (s0 − 1) % 2 (step k
     * writes set k % 2, reads the other): the phase of step s0 swaps once
     * more, so start from the sets swapped when s0 is even. */
    if (s0 > 0 && s0 % 2 == 0) swap_slice_buffers(E, n);
    J.first = s0;
    J.last = s1 - 1;
    J.phase0 = s0 == 0 ? 0 : s0 + 1;
    /* one parallel region for the whole sweep: a fork/join per slice left the
     * second thread waiting to be woken (or spinning) at every slice */
    volux_parallel_phases(threads, s1 + 1 - J.phase0, sweep_phase, step_item, &J);
}

void volux_lightvol_sweep_steps(lightvol_state *st, const lv_job *job, int p, int s0, int s1, lv_entry *E) {
    const lv_pass *ps = &job->passes[p];
    sweep(st, ps->g, job->items, job->idx + ps->first, ps->n, job->full && p == 0, E, s0, s1);
}
