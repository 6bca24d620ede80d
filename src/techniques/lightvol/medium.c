/*
 * techniques/lightvol/medium.c — the medium the sweeps see. On the data grid
 * (scale 1) slices hold the scalar values and the row loops classify where
 * they sample (post-classification, like the camera ray and pathtrace); on
 * a coarser grid a medium grid holds the box means of σt and σs, built
 * here once per volume/TF change. Classification of a slice's rows runs in
 * the sweep's phases (volux_lightvol_classify_rows), one slice ahead of the
 * propagation.
 *
 * Built with -fno-math-errno -fno-trapping-math (CMakeLists.txt) like the
 * other propagation files, so the row loops vectorise.
 */

#include <math.h>
#include <string.h>

#include "core/context_internal.h"
#include "core/parallel.h"
#include "lightvol.h"
#include "sweep.h"

/* ------------------------------------------------------------ medium grid */

/* σt and σs = albedo·c·σt (rgb) of data node `idx` (DESIGN §2). */
static inline void classify(const lightvol_state *st, size_t idx, float out[4]) {
    const volux_volume *v = st->rc.volume;
    if (st->have_u8) {
        memcpy(out, &st->class_u8[4 * ((const uint8_t *)v->data)[idx]], 4 * sizeof(float));
        return;
    }
    float rgba[4];
    volux_lut_rgba(st->rc.lut, volux_volume_raw_at(v, idx) + v->value_offset, rgba);
    out[0] = rgba[3];
    for (int c = 0; c < 3; c++) out[1 + c] = st->rc.albedo * rgba[c] * rgba[3];
}

typedef struct medium_job {
    lightvol_state *st;
    int *lo[3], *hi[3];  /* per illumination node: data index box (inclusive) */
    int *first, *last;   /* per data x: illumination x nodes whose box holds it */
    float *tmp;
    size_t tmp_stride;
} medium_job;

/* Box mean of σt and σs over the data nodes nearest to each illumination
 * node of slice k: optical depth along an axis is preserved, so thin walls
 * still cast shadows at coarse scales. */
static void medium_slice(void *user, int64_t k64, int thread) {
    medium_job *J = user;
    lightvol_state *st = J->st;
    const volux_volume *v = st->rc.volume;
    int k = (int)k64, m0 = st->dims[0], m1 = st->dims[1], nx = v->dims[0], ny = v->dims[1];
    float *A = J->tmp + (size_t)thread * J->tmp_stride; /* ny × m0 × 4 */
    memset(A, 0, (size_t)ny * (size_t)m0 * 4 * sizeof(float));
    for (int z = J->lo[2][k]; z <= J->hi[2][k]; z++)
        for (int y = 0; y < ny; y++) {
            size_t base = volux_volume_index(v, 0, y, z);
            float *Ay = A + (size_t)y * (size_t)m0 * 4;
            for (int x = 0; x < nx; x++) {
                float c[4];
                classify(st, base + (size_t)x, c);
                for (int i = J->first[x]; i <= J->last[x]; i++)
                    for (int q = 0; q < 4; q++) Ay[4 * i + q] += c[q];
            }
        }
    for (int j = 0; j < m1; j++)
        for (int i = 0; i < m0; i++) {
            float s[4] = {0, 0, 0, 0};
            for (int y = J->lo[1][j]; y <= J->hi[1][j]; y++)
                for (int q = 0; q < 4; q++) s[q] += A[((size_t)y * (size_t)m0 + (size_t)i) * 4 + (size_t)q];
            float cnt = (float)(J->hi[0][i] - J->lo[0][i] + 1) * (float)(J->hi[1][j] - J->lo[1][j] + 1) *
                        (float)(J->hi[2][k] - J->lo[2][k] + 1);
            float *out = st->medium + (((size_t)k * (size_t)m1 + (size_t)j) * (size_t)m0 + (size_t)i) * 4;
            for (int q = 0; q < 4; q++) out[q] = s[q] / cnt;
        }
}

volux_status volux_lightvol_build_medium(lightvol_state *st) {
    const volux_volume *v = st->rc.volume;
    const volux_transfer_lut *lut = st->rc.lut;
    size_t nzb = ((size_t)lut->n + 1) * sizeof(int);
    if (st->lut_nz_bytes != nzb) {
        if (st->lut_nz) volux_free(st->rc.ctx, st->lut_nz, st->lut_nz_bytes);
        st->lut_nz = volux_malloc(st->rc.ctx, nzb);
        st->lut_nz_bytes = st->lut_nz ? nzb : 0;
        if (!st->lut_nz) return volux_error(st->rc.ctx, VOLUX_ERR_NOMEM, "lightvol: out of memory for the TF range table");
    }
    st->lut_nz[0] = 0;
    for (int i = 0; i < lut->n; i++) st->lut_nz[i + 1] = st->lut_nz[i] + (lut->sigma_t[i] > 0.0f);
    st->have_u8 = v->storage == VOLUX_STORE_U8;
    if (st->have_u8)
        for (int i = 0; i < 256; i++) {
            float rgba[4];
            volux_lut_rgba(st->rc.lut, (float)i + v->value_offset, rgba);
            st->class_u8[4 * i] = rgba[3];
            for (int c = 0; c < 3; c++) st->class_u8[4 * i + 1 + c] = st->rc.albedo * rgba[c] * rgba[3];
        }
    if (st->on_grid) return VOLUX_OK;
    medium_job J;
    memset(&J, 0, sizeof J);
    J.st = st;
    int threads = st->rc.threads > 0 ? st->rc.threads : 1;
    size_t ints = 0;
    for (int a = 0; a < 3; a++) ints += 2 * (size_t)st->dims[a];
    ints += 2 * (size_t)v->dims[0];
    J.tmp_stride = (size_t)v->dims[1] * (size_t)st->dims[0] * 4;
    size_t tmp_bytes = J.tmp_stride * sizeof(float) * (size_t)threads;
    int *ib = volux_malloc(st->rc.ctx, ints * sizeof(int));
    J.tmp = volux_alloc_aligned(st->rc.ctx, tmp_bytes);
    if (!ib || !J.tmp) {
        volux_free(st->rc.ctx, ib, ints * sizeof(int));
        if (J.tmp) volux_free_aligned(st->rc.ctx, J.tmp, tmp_bytes);
        return volux_error(st->rc.ctx, VOLUX_ERR_NOMEM, "lightvol: out of memory for the medium grid");
    }
    int *p = ib;
    for (int a = 0; a < 3; a++) {
        J.lo[a] = p, p += st->dims[a];
        J.hi[a] = p, p += st->dims[a];
        double step = 1.0 / (double)st->data_to_ill[a], hw = 0.5 * step;
        for (int i = 0; i < st->dims[a]; i++) {
            double c = (double)i * step;
            int lo = (int)ceil(c - hw - 1e-6), hi = (int)floor(c + hw + 1e-6);
            if (lo < 0) lo = 0;
            if (hi > v->dims[a] - 1) hi = v->dims[a] - 1;
            if (hi < lo) hi = lo;
            J.lo[a][i] = lo;
            J.hi[a][i] = hi;
        }
    }
    J.first = p, p += v->dims[0];
    J.last = p;
    for (int x = 0; x < v->dims[0]; x++) {
        J.first[x] = st->dims[0];
        J.last[x] = -1;
    }
    for (int i = 0; i < st->dims[0]; i++)
        for (int x = J.lo[0][i]; x <= J.hi[0][i]; x++) {
            if (i < J.first[x]) J.first[x] = i;
            if (i > J.last[x]) J.last[x] = i;
        }
    volux_parallel_for(threads, st->dims[2], medium_slice, &J);
    volux_free(st->rc.ctx, ib, ints * sizeof(int));
    volux_free_aligned(st->rc.ctx, J.tmp, tmp_bytes);
    return VOLUX_OK;
}

/* ------------------------------------------------------------ slice rows */

/* One row of volux_lightvol_classify_rows. */
static void classify_one_row(const lv_sweep *J, const lightvol_state *st, const volux_volume *vol, float *restrict sig,
                             float *restrict kr, float *restrict kg, float *restrict kb, size_t base, size_t ustep,
                             float f, int forward, int mu) {
    (void)J;
    {
        if (st->on_grid && st->have_u8) {
            const uint8_t *d = (const uint8_t *)vol->data + base;
            const float *tab = st->class_u8;
            if (ustep > 16) /* x sweeps read one byte per x-row: prefetch ahead */
                for (int u = 0; u < mu && u < 32; u++) __builtin_prefetch(d + (size_t)u * ustep, 0, 1);
            if (!forward && ustep > 16) {
                for (int u = 0; u < mu; u++) {
                    if (u + 32 < mu) __builtin_prefetch(d + (size_t)(u + 32) * ustep, 0, 1);
                    sig[u] = tab[4 * d[(size_t)u * ustep]];
                }
            } else if (!forward) {
                for (int u = 0; u < mu; u++) sig[u] = tab[4 * d[(size_t)u * ustep]];
            } else {
                for (int u = 0; u < mu; u++) {
                    const float *c = tab + 4 * d[(size_t)u * ustep];
                    float s0 = c[0], r = s0 - f * c[1], g = s0 - f * c[2], b = s0 - f * c[3];
                    sig[u] = s0;
                    kr[u] = r > 0.0f ? r : 0.0f;
                    kg[u] = g > 0.0f ? g : 0.0f;
                    kb[u] = b > 0.0f ? b : 0.0f;
                }
            }
            return;
        }
        for (int u = 0; u < mu; u++) {
            float c[4];
            if (st->on_grid) classify(st, base + (size_t)u * ustep, c);
            else memcpy(c, st->medium + (base + (size_t)u * ustep) * 4, sizeof c);
            float r = c[0] - f * c[1], g = c[0] - f * c[2], b = c[0] - f * c[3];
            sig[u] = c[0];
            if (forward) {
                kr[u] = r > 0.0f ? r : 0.0f;
                kg[u] = g > 0.0f ? g : 0.0f;
                kb[u] = b > 0.0f ? b : 0.0f;
            }
        }
    }
}

/* Medium of rows [v0, v1) of slice k into `dst` (4 planes): σt and
 * κ_c = σt − f·σs_c (sweep.h). */
void volux_lightvol_classify_rows(const lv_sweep *J, float *dst, int k, int v0, int v1) {
    const lightvol_state *st = J->st;
    const volux_volume *vol = st->rc.volume;
    int mu = J->mu;
    size_t area = J->area;
    const float f = J->fwd;
    const int forward = J->forward;
    /* node (u, v, k) → linear index: base(v) + u·step (data grid when on
     * grid, else the medium grid; both x fastest) */
    const int *dims = st->on_grid ? vol->dims : st->dims;
    size_t stride[3] = {1, (size_t)dims[0], (size_t)dims[0] * (size_t)dims[1]};
    size_t ustep = stride[J->au];
    for (int v = v0; v < v1; v++) {
        size_t off = (size_t)v * (size_t)mu;
        float *restrict sig = dst + off, *restrict kr = dst + area + off, *restrict kg = dst + 2 * area + off,
                        *restrict kb = dst + 3 * area + off;
        size_t base = (size_t)k * stride[J->a] + (size_t)v * stride[J->av];
        float *info = dst + 4 * area + 2 * (size_t)v; /* row min, max */
        if (J->post) {
            /* scalar values (file units); the row's value range */
            const float off_v = vol->value_offset;
            float lo = INFINITY, hi = -INFINITY;
            if (vol->storage == VOLUX_STORE_U8) {
                const uint8_t *d = (const uint8_t *)vol->data + base;
                if (ustep > 16)
                    for (int u = 0; u < mu && u < 32; u++) __builtin_prefetch(d + (size_t)u * ustep, 0, 1);
                for (int u = 0; u < mu; u++) {
                    if (ustep > 16 && u + 32 < mu) __builtin_prefetch(d + (size_t)(u + 32) * ustep, 0, 1);
                    sig[u] = (float)d[(size_t)u * ustep] + off_v;
                }
            } else {
                for (int u = 0; u < mu; u++) sig[u] = volux_volume_raw_at(vol, base + (size_t)u * ustep) + off_v;
            }
            for (int u = 0; u < mu; u++) {
                lo = sig[u] < lo ? sig[u] : lo;
                hi = sig[u] > hi ? sig[u] : hi;
            }
            info[0] = lo;
            info[1] = hi;
            continue;
        }
        classify_one_row(J, st, vol, sig, kr, kg, kb, base, ustep, f, forward, mu);
        float mx = 0.0f;
        for (int u = 0; u < mu; u++) mx = sig[u] > mx ? sig[u] : mx;
        info[0] = 0.0f;
        info[1] = mx;
    }
}
