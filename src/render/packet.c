/* render/packet.c — the tables of the packet kernels (see packet.h);
 * moved from techniques/dvr/dvr.c. */
#include <math.h>
#include <stddef.h>
#include <string.h>

#include "core/context_internal.h"
#include "core/simd.h"
#include "packet.h"

/* The SIMD kernel's float copy of the pre-integration integrals (layout in
 * render/packet.h). P is rounded once from the double table; D is the float
 * difference of the rounded P, so P[i+1] − P[i] − D[i] is exactly 0 in
 * float and a segment straddling one node boundary loses nothing to
 * cancellation. Intervals where σt is 0 keep D = 0 exactly (equal doubles
 * round to equal floats), so empty space stays exactly empty. */
volux_status volux_packet_pre_table(volux_context *ctx, const volux_transfer_lut *lut, volux_packet_tables *pk) {
    size_t bytes = (size_t)lut->n * 8 * sizeof(float);
    if (bytes != pk->pre_bytes) {
        if (pk->pre_f) volux_free_aligned(ctx, pk->pre_f, pk->pre_bytes);
        pk->pre_bytes = 0;
        pk->pre_f = volux_alloc_aligned(ctx, bytes);
        if (!pk->pre_f) return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for the pre-integration table");
        pk->pre_bytes = bytes;
    }
    for (int i = 0; i < lut->n; i++) {
        float *r = pk->pre_f + 8 * (size_t)i;
        r[0] = (float)lut->int_sigma[i];
        for (int c = 0; c < 3; c++) r[1 + c] = (float)lut->int_sigma_c[3 * i + c];
    }
    for (int i = 0; i < lut->n; i++) {
        float *r = pk->pre_f + 8 * (size_t)i;
        for (int c = 0; c < 4; c++) r[4 + c] = i + 1 < lut->n ? r[8 + c] - r[c] : 0.0f;
    }
    return VOLUX_OK;
}

/* Value range of every skip cell (VOLUX_PACKET_SKIP_CELL³ cells, nodes inclusive,
 * so the trilinear field inside a cell lies in its range): TF-independent,
 * built with the volume. Finer than the 8³ macrocells because in real data
 * most samples of a non-empty macrocell still have zero opacity (bonsai:
 * 2.3 M of 14 M samples contribute), and a 4³ cell is empty much more often. */
volux_status volux_packet_skip_ranges(volux_context *ctx, const volux_volume *v, volux_packet_tables *pk) {
    int *c = pk->skip_cells;
    size_t n = 1;
    for (int a = 0; a < 3; a++) {
        c[a] = (v->dims[a] - 1 + VOLUX_PACKET_SKIP_CELL - 1) / VOLUX_PACKET_SKIP_CELL;
        if (c[a] < 1) c[a] = 1;
        n *= (size_t)c[a];
    }
    size_t bytes = 2 * n * sizeof(float);
    if (bytes != pk->range_bytes) {
        if (pk->skip_range) volux_free(ctx, pk->skip_range, pk->range_bytes);
        pk->range_bytes = 0;
        pk->skip_range = volux_malloc(ctx, bytes);
        if (!pk->skip_range) return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for the skip cells");
        pk->range_bytes = bytes;
    }
    for (size_t i = 0; i < n; i++) pk->skip_range[2 * i] = INFINITY, pk->skip_range[2 * i + 1] = -INFINITY;
    /* every node updates the (up to 8) cells it bounds */
    for (int k = 0; k < v->dims[2]; k++) {
        for (int j = 0; j < v->dims[1]; j++)
            for (int i = 0; i < v->dims[0]; i++) {
                float val = volux_volume_raw_at(v, volux_volume_index(v, i, j, k)) + v->value_offset;
                int idx[3] = {i, j, k}, lo[3], hi[3];
                for (int a = 0; a < 3; a++) {
                    hi[a] = idx[a] / VOLUX_PACKET_SKIP_CELL;
                    lo[a] = idx[a] % VOLUX_PACKET_SKIP_CELL == 0 && hi[a] > 0 ? hi[a] - 1 : hi[a];
                    if (hi[a] > c[a] - 1) hi[a] = c[a] - 1;
                }
                for (int z = lo[2]; z <= hi[2]; z++)
                    for (int y = lo[1]; y <= hi[1]; y++)
                        for (int x = lo[0]; x <= hi[0]; x++) {
                            size_t cell = ((size_t)z * (size_t)c[1] + (size_t)y) * (size_t)c[0] + (size_t)x;
                            float *r = pk->skip_range + 2 * cell;
                            if (val < r[0]) r[0] = val;
                            if (val > r[1]) r[1] = val;
                        }
            }
        /* out of core: slice k is done (volume_map.c) */
        size_t slice = (size_t)v->dims[0] * (size_t)v->dims[1] * volux_volume_elem_size(v);
        volux_volume_trim(v, (size_t)k * slice, slice);
    }
    return VOLUX_OK;
}

/* Chessboard (L∞) distance, in skip cells, from every skip cell to the
 * nearest cell of the other kind, stored signed: d ≥ 1 for an empty cell
 * (σt = 0 on every table node bracketing its value range, the majorant
 * grid's test; all cells within d − 1 of it are empty too), d ≤ −1 for a
 * non-empty one (−d − 1 rings around it hold no empty cell); capped at 127.
 * Why: one lookup tells the SIMD kernel how far a ray can go before the
 * emptiness can change — a whole cube of empty cells to skip, or a cube of
 * non-empty cells to march without checking again — instead of one cell
 * per lookup. Two raster passes of the 3×3×3 chamfer with unit weights
 * give the exact chessboard distance. Rebuilt when extinction changes. */
volux_status volux_packet_skip_distance(volux_context *ctx, const volux_transfer_lut *lut, volux_packet_tables *pk) {
    const int nx = pk->skip_cells[0], ny = pk->skip_cells[1], nz = pk->skip_cells[2];
    size_t n = (size_t)nx * (size_t)ny * (size_t)nz, bytes = n + 3;
    if (bytes != pk->skip_bytes) {
        if (pk->skip_dist) volux_free(ctx, pk->skip_dist, pk->skip_bytes);
        pk->skip_bytes = 0;
        pk->skip_dist = volux_malloc(ctx, bytes);
        if (!pk->skip_dist) return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for the skip distances");
        pk->skip_bytes = bytes;
    }
    memset(pk->skip_dist + n, 0, 3); /* padding read (and discarded) by the 32-bit gathers */
    /* nonzero[i] = number of table nodes below i with σt > 0: a node range
     * [i0, i1] is empty iff nonzero[i1 + 1] == nonzero[i0] (O(1) per cell) */
    size_t nz_bytes = ((size_t)lut->n + 1) * sizeof(int32_t);
    int32_t *nonzero = volux_malloc(ctx, nz_bytes);
    if (!nonzero) return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for the skip distances");
    nonzero[0] = 0;
    for (int i = 0; i < lut->n; i++) nonzero[i + 1] = nonzero[i] + (lut->sigma_t[i] > 0.0f);
    const int last = lut->n - 1;
    for (size_t c = 0; c < n; c++) {
        /* the majorant grid's bracketing: floor of the low end, ceil of the high */
        float u0 = (pk->skip_range[2 * c] - lut->s_min) * lut->inv_ds;
        float u1 = (pk->skip_range[2 * c + 1] - lut->s_min) * lut->inv_ds;
        int i0 = (int)floorf(u0), i1 = (int)ceilf(u1);
        if (i0 < 0) i0 = 0;
        if (i0 > last) i0 = last;
        if (i1 > last) i1 = last;
        if (i1 < i0) i1 = i0;
        pk->skip_dist[c] = (int8_t)(nonzero[i1 + 1] == nonzero[i0]); /* 1: empty, 0: not (for now) */
    }
    volux_free(ctx, nonzero, nz_bytes);
    /* Chamfer on a grid padded by one cell of CAP (never a source), so the
     * 13 causal neighbours are fixed offsets without bounds tests. */
    enum { CAP = 127 };
    const size_t px = (size_t)nx + 2, py = (size_t)ny + 2, pz = (size_t)nz + 2, pn = px * py * pz;
    size_t tmp_bytes = pn * sizeof(int32_t);
    int32_t *tmp = volux_malloc(ctx, tmp_bytes);
    unsigned char *flag = volux_malloc(ctx, n);
    if (!tmp || !flag) {
        volux_free(ctx, tmp, tmp_bytes);
        volux_free(ctx, flag, n);
        return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for the skip distances");
    }
    for (size_t c = 0; c < n; c++) flag[c] = (unsigned char)pk->skip_dist[c];
    ptrdiff_t off[13];
    int no = 0;
    for (int dz = -1; dz <= 0; dz++)
        for (int dy = -1; dy <= 1; dy++)
            for (int dx = -1; dx <= 1; dx++)
                if (!(dz == 0 && (dy > 0 || (dy == 0 && dx >= 0))))
                    off[no++] = ((ptrdiff_t)dz * (ptrdiff_t)py + dy) * (ptrdiff_t)px + dx;
    for (int kind = 0; kind < 2; kind++) { /* 0: empty cells, 1: non-empty cells */
        /* distance from each cell of this kind to the nearest of the other */
        for (size_t i = 0; i < pn; i++) tmp[i] = CAP;
        for (int z = 0; z < nz; z++)
            for (int y = 0; y < ny; y++)
                for (int x = 0; x < nx; x++) {
                    size_t c = ((size_t)z * (size_t)ny + (size_t)y) * (size_t)nx + (size_t)x;
                    tmp[(((size_t)z + 1) * py + (size_t)y + 1) * px + (size_t)x + 1] =
                        (flag[c] != 0) == (kind == 0) ? CAP : 0;
                }
        for (int pass = 0; pass < 2; pass++) {
            const ptrdiff_t dir = pass ? -1 : 1;
            for (int zi = 0; zi < nz; zi++)
                for (int yi = 0; yi < ny; yi++) {
                    int z = pass ? nz - zi : zi + 1, y = pass ? ny - yi : yi + 1;
                    int32_t *row = tmp + ((size_t)z * py + (size_t)y) * px;
                    for (int xi = 0; xi < nx; xi++) {
                        int32_t *t = row + (pass ? nx - xi : xi + 1);
                        int32_t best = *t;
                        if (!best) continue;
                        for (int o = 0; o < 13; o++) {
                            int32_t v = t[dir * off[o]] + 1;
                            if (v < best) best = v;
                        }
                        *t = best;
                    }
                }
        }
        for (int z = 0; z < nz; z++)
            for (int y = 0; y < ny; y++)
                for (int x = 0; x < nx; x++) {
                    size_t c = ((size_t)z * (size_t)ny + (size_t)y) * (size_t)nx + (size_t)x;
                    int32_t d = tmp[(((size_t)z + 1) * py + (size_t)y + 1) * px + (size_t)x + 1];
                    if ((flag[c] != 0) == (kind == 0)) pk->skip_dist[c] = (int8_t)(kind == 0 ? d : -d);
                }
    }
    volux_free(ctx, tmp, tmp_bytes);
    volux_free(ctx, flag, n);
    return VOLUX_OK;
}

size_t volux_packet_tables_bytes(const volux_packet_tables *t) { return t->pre_bytes + t->skip_bytes + t->range_bytes; }

void volux_packet_tables_free(volux_context *ctx, volux_packet_tables *t) {
    if (t->pre_f) volux_free_aligned(ctx, t->pre_f, t->pre_bytes);
    if (t->skip_dist) volux_free(ctx, t->skip_dist, t->skip_bytes);
    if (t->skip_range) volux_free(ctx, t->skip_range, t->range_bytes);
    memset(t, 0, sizeof *t);
}

volux_status volux_packet_tables_update(volux_context *ctx, volux_volume *v, const volux_transfer_lut *lut,
                                        uint32_t what, volux_packet_tables *pk) {
    volux_status s;
    if ((what & VOLUX_CHANGE_VOLUME) || !pk->skip_range)
        if ((s = volux_volume_build_bricks(v)) || (s = volux_packet_skip_ranges(ctx, v, pk))) return s;
    if ((what & (VOLUX_CHANGE_VOLUME | VOLUX_CHANGE_EXTINCTION | VOLUX_CHANGE_DENSITY | VOLUX_CHANGE_COLOR)) ||
        !pk->pre_f)
        if ((s = volux_packet_pre_table(ctx, lut, pk))) return s;
    if ((what & (VOLUX_CHANGE_VOLUME | VOLUX_CHANGE_EXTINCTION | VOLUX_CHANGE_DENSITY)) || !pk->skip_dist)
        if ((s = volux_packet_skip_distance(ctx, lut, pk))) return s;
    return VOLUX_OK;
}

int volux_packet_avx2_available(void) {
#if VOLUX_X86_GNUC
    return volux_cpu_has_avx2_fma();
#else
    return 0;
#endif
}

int volux_packet_avx512_available(void) {
#if VOLUX_X86_GNUC
    return volux_packet_avx2_available() && volux_cpu_has_avx512f() && VOLUX_CPU_HAS("avx512bw") &&
           VOLUX_CPU_HAS("avx512dq") && VOLUX_CPU_HAS("avx512vl");
#else
    return 0;
#endif
}

volux_status volux_packet_kernel_choose(volux_context *ctx, const volux_scene *scene,
                                        const volux_technique_class *cls, int usable, const char *why, int *lanes) {
    const char *k = volux_technique_param_string(scene, cls, "march_kernel");
    volux_packet_kernel kernel;
    if (!strcmp(k, "auto")) kernel = VOLUX_PACKET_AUTO;
    else if (!strcmp(k, "scalar")) kernel = VOLUX_PACKET_SCALAR;
    else if (!strcmp(k, "simd")) kernel = VOLUX_PACKET_SIMD;
    else if (!strcmp(k, "avx2")) kernel = VOLUX_PACKET_AVX2;
    else
        return volux_error(ctx, VOLUX_ERR_INVALID,
                           "techniques.%s.march_kernel: expected \"auto\", \"scalar\", \"simd\" or \"avx2\", "
                           "got \"%s\"",
                           cls->info.name, k);
    const int cpu = volux_packet_avx2_available();
    if ((kernel == VOLUX_PACKET_SIMD || kernel == VOLUX_PACKET_AVX2) && !(cpu && usable))
        return volux_error(ctx, VOLUX_ERR_UNSUPPORTED, "techniques.%s.march_kernel: \"%s\" needs %s", cls->info.name, k,
                           cpu ? why : "a CPU with AVX2 and FMA");
    *lanes = 0;
    if (kernel != VOLUX_PACKET_SCALAR && cpu && usable)
        *lanes = kernel != VOLUX_PACKET_AVX2 && volux_packet_avx512_available() ? 16 : 8;
    return VOLUX_OK;
}
