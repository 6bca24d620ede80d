/*
 * techniques/lightvol/buffers.c — the memory of the propagation: the
 * illumination volume and the medium grid (sized from the data and the
 * scale parameter), and the scratch the sweeps grow on demand and keep
 * between updates (slice buffers, medium slices, per-thread rows, x-sweep
 * staging; layout in sweep.h). Kept apart so every allocation and its
 * matching free are in one place.
 */

#include <math.h>
#include <string.h>

#include "core/context_internal.h"
#include "lightvol.h"
#include "sweep.h"

static void free_scratch(lightvol_state *st) {
    if (st->slices) volux_free_aligned(st->rc.ctx, st->slices, st->slices_bytes);
    if (st->med) volux_free_aligned(st->rc.ctx, st->med, st->med_bytes);
    if (st->rows) volux_free_aligned(st->rc.ctx, st->rows, st->rows_bytes);
    if (st->stage) volux_free_aligned(st->rc.ctx, st->stage, st->stage_bytes);
    st->slices = st->med = st->rows = st->stage = NULL;
    st->slices_bytes = st->med_bytes = st->rows_bytes = st->stage_bytes = 0;
    st->slice_cap = 0;
    st->rows_threads = 0;
}

void volux_lightvol_free_buffers(lightvol_state *st) {
    free_scratch(st);
    if (st->vol) volux_free_aligned(st->rc.ctx, st->vol, st->vol_bytes);
    if (st->volf) volux_free_aligned(st->rc.ctx, st->volf, st->vol_bytes);
    if (st->medium) volux_free_aligned(st->rc.ctx, st->medium, st->medium_bytes);
    st->vol = NULL;
    st->volf = NULL;
    st->medium = NULL;
    st->vol_bytes = st->medium_bytes = 0;
    if (st->lut_nz) volux_free(st->rc.ctx, st->lut_nz, st->lut_nz_bytes);
    st->lut_nz = NULL;
    st->lut_nz_bytes = 0;
}

volux_status volux_lightvol_promote(lightvol_state *st) {
    if (st->volf) return VOLUX_OK;
    size_t n = (st->vol_bytes / sizeof *st->vol), bytes = n * sizeof *st->volf; /* with the padding */
    float *f = volux_alloc_aligned(st->rc.ctx, bytes);
    if (!f) return volux_error(st->rc.ctx, VOLUX_ERR_NOMEM, "lightvol: out of memory for the float illumination volume");
    for (size_t i = 0; i < n; i++) f[i] = volux_bf16_to_float(st->vol[i]);
    volux_free_aligned(st->rc.ctx, st->vol, st->vol_bytes);
    st->vol = NULL;
    st->volf = f;
    st->vol_bytes = bytes;
    return VOLUX_OK;
}

size_t volux_lightvol_scratch_bytes(const lightvol_state *st) {
    return st->slices_bytes + st->med_bytes + st->rows_bytes + st->stage_bytes;
}

volux_status volux_lightvol_alloc(lightvol_state *st) {
    const volux_volume *v = st->rc.volume;
    static const char axis_name[3] = {'x', 'y', 'z'};
    int m[3];
    for (int a = 0; a < 3; a++) {
        if (v->dims[a] < 2)
            return volux_error(st->rc.ctx, VOLUX_ERR_INVALID,
                               "lightvol: the volume needs at least 2 nodes along each axis (%c has %d)", axis_name[a],
                               v->dims[a]);
        m[a] = (int)ceil((double)v->dims[a] * (double)st->p.scale[a] - 1e-6);
        if (m[a] < 2) m[a] = 2;
        if (m[a] > v->dims[a]) m[a] = v->dims[a];
    }
    size_t n = (size_t)m[0] * (size_t)m[1] * (size_t)m[2], bytes;
    int ch = st->p.directional ? 6 : 3;
    /* float once light edits made it so (st->volf) or when asked */
    const int f32 = st->p.precision_float || st->volf;
    const size_t value = f32 ? sizeof *st->volf : sizeof *st->vol;
    if (!volux_mul_size(n, (size_t)ch * value, &bytes) || (bytes += LV_VOL_PAD * value) >
                                                              volux_context_max_bytes(st->rc.ctx))
        return volux_error(st->rc.ctx, VOLUX_ERR_LIMIT,
                           "lightvol: a %dx%dx%d illumination volume exceeds the memory cap (lower techniques.lightvol.scale)",
                           m[0], m[1], m[2]);
    volux_lightvol_drop_job(st); /* its sweep state lives in the scratch */
    st->valid = 0;
    volux_lightvol_free_buffers(st);
    void *block = volux_alloc_aligned(st->rc.ctx, bytes);
    if (!block)
        return volux_error(st->rc.ctx, VOLUX_ERR_NOMEM, "lightvol: out of memory for a %dx%dx%d illumination volume",
                           m[0], m[1], m[2]);
    if (f32) st->volf = block;
    else st->vol = block;
    st->vol_bytes = bytes;
    memset((char *)block + n * (size_t)ch * value, 0, LV_VOL_PAD * value);
    st->ch = ch;
    st->on_grid = 1;
    volux_vec3 lo, hi;
    volux_volume_bounds(v, &lo, &hi);
    st->lo = lo;
    float ext[3] = {hi.x - lo.x, hi.y - lo.y, hi.z - lo.z};
    for (int a = 0; a < 3; a++) {
        st->dims[a] = m[a];
        st->spacing[a] = ext[a] / (float)(m[a] - 1);
        st->data_to_ill[a] = (float)(m[a] - 1) / (float)(v->dims[a] - 1);
        if (m[a] != v->dims[a]) st->on_grid = 0;
    }
    if (!st->on_grid) {
        size_t mb = n * 4 * sizeof(float);
        st->medium = volux_alloc_aligned(st->rc.ctx, mb);
        if (!st->medium) return volux_error(st->rc.ctx, VOLUX_ERR_NOMEM, "lightvol: out of memory for the medium grid");
        st->medium_bytes = mb;
    }
    size_t a01 = (size_t)m[0] * (size_t)m[1], a02 = (size_t)m[0] * (size_t)m[2], a12 = (size_t)m[1] * (size_t)m[2];
    st->area = a01 > a02 ? a01 : a02;
    if (a12 > st->area) st->area = a12;
    st->valid = 0;
    return VOLUX_OK;
}

volux_status volux_lightvol_ensure_scratch(lightvol_state *st, int entries) {
    volux_context *ctx = st->rc.ctx;
    size_t need;
    if (!st->stage) {
        /* x slices are (y, z) planes */
        need = (size_t)LV_DEFER * (size_t)st->dims[1] * (size_t)st->dims[2] * (size_t)st->ch * sizeof(float);
        st->stage = volux_alloc_aligned(ctx, need);
        if (!st->stage) return volux_error(ctx, VOLUX_ERR_NOMEM, "lightvol: out of memory for the x-sweep staging");
        st->stage_bytes = need;
    }
    if (entries > st->slice_cap) {
        if (!volux_mul_size(st->area, (size_t)entries * 6 * sizeof(float), &need))
            return volux_error(ctx, VOLUX_ERR_LIMIT, "lightvol: slice buffers too large");
        if (st->slices) volux_free_aligned(ctx, st->slices, st->slices_bytes);
        st->slices = volux_alloc_aligned(ctx, need);
        st->slices_bytes = st->slices ? need : 0;
        st->slice_cap = st->slices ? entries : 0;
        if (!st->slices) return volux_error(ctx, VOLUX_ERR_NOMEM, "lightvol: out of memory for %d slice buffers", entries);
    }
    if (!st->med) {
        need = 3 * lv_med_stride(st) * sizeof(float); /* 3 slices × (4 planes + row ranges) */
        st->med = volux_alloc_aligned(ctx, need);
        if (!st->med) return volux_error(ctx, VOLUX_ERR_NOMEM, "lightvol: out of memory for slice buffers");
        st->med_bytes = need;
    }
    int mmax = st->dims[0] > st->dims[1] ? st->dims[0] : st->dims[1];
    if (st->dims[2] > mmax) mmax = st->dims[2];
    int threads = st->rc.threads > 0 ? st->rc.threads : 1;
    /* + pad: threads never share a cache line, and the AVX2 kernels' last
     * steps may read 8 floats past an array */
    size_t stride = (size_t)ROW_FLOATS * (size_t)mmax + 64;
    if (!st->rows || st->rows_threads < threads || st->row_stride != stride) {
        if (st->rows) volux_free_aligned(ctx, st->rows, st->rows_bytes);
        need = stride * (size_t)threads * sizeof(float);
        st->rows = volux_alloc_aligned(ctx, need);
        st->rows_bytes = st->rows ? need : 0;
        if (!st->rows) return volux_error(ctx, VOLUX_ERR_NOMEM, "lightvol: out of memory for row scratch");
        st->rows_threads = threads;
        st->row_stride = stride;
    }
    return VOLUX_OK;
}
