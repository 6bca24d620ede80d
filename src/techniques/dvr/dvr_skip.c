/* techniques/dvr/dvr_skip.c — the packet kernel's two-level empty-space
 * skipping structure (layout and contract in dvr.h, dvr_skip). */
#include <math.h>
#include <string.h>

#include "core/context_internal.h"
#include "dvr.h"

enum { SUB = DVR_SKIP_CELL / 2 }; /* sub-cell edge in voxels */

/* Sub-cells s along an axis of n nodes holding node `idx` (nodes are
 * inclusive: a node on a boundary bounds both neighbours), as the
 * 4³ cells' rule: [*lo, *hi] within [0, count − 1]. */
static void sub_span(int idx, int count, int *lo, int *hi) {
    int h = idx / SUB;
    *lo = idx % SUB == 0 && h > 0 ? h - 1 : h;
    *hi = h > count - 1 ? count - 1 : h;
    if (*lo > *hi) *lo = *hi;
}

static void skip_free_ranges(volux_context *ctx, dvr_skip *sk) {
    if (sk->range) volux_free(ctx, sk->range, sk->range_bytes);
    if (sk->sub_range) volux_free(ctx, sk->sub_range, sk->sub_bytes);
    sk->range = sk->sub_range = NULL;
    sk->range_bytes = sk->sub_bytes = 0;
}

/* Why separable: a sub-cell's range is the min/max over 3×3×3 nodes; reducing
 * x within a node plane, then y, then folding the plane into the (one or two)
 * sub-cell layers it bounds reads every node once (the 4³ build before this
 * updated up to 8 cells per node). */
volux_status volux_dvr_skip_ranges(volux_context *ctx, const volux_volume *v, dvr_skip *sk) {
    int c[3], s[3];
    size_t n = 1;
    for (int a = 0; a < 3; a++) {
        c[a] = (v->dims[a] - 1 + DVR_SKIP_CELL - 1) / DVR_SKIP_CELL;
        if (c[a] < 1) c[a] = 1;
        s[a] = 2 * c[a];
        n *= (size_t)c[a];
    }
    const int nx = v->dims[0], ny = v->dims[1], nz = v->dims[2];
    size_t range_bytes = 2 * n * sizeof(float), sub_bytes = 16 * n * sizeof(float);
    if (range_bytes != sk->range_bytes || sub_bytes != sk->sub_bytes) {
        skip_free_ranges(ctx, sk);
        sk->range = volux_malloc(ctx, range_bytes);
        sk->sub_range = volux_malloc(ctx, sub_bytes);
        if (!sk->range || !sk->sub_range) {
            if (sk->range) volux_free(ctx, sk->range, range_bytes);
            if (sk->sub_range) volux_free(ctx, sk->sub_range, sub_bytes);
            sk->range = sk->sub_range = NULL;
            return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for the skip cells");
        }
        sk->range_bytes = range_bytes;
        sk->sub_bytes = sub_bytes;
    }
    memcpy(sk->cells, c, sizeof sk->cells);
    for (size_t i = 0; i < 8 * n; i++) sk->sub_range[2 * i] = INFINITY, sk->sub_range[2 * i + 1] = -INFINITY;
    /* row: one node row reduced over x sub-cells; plane: a node plane
     * reduced over x and y sub-cells */
    size_t row_bytes = 2 * (size_t)s[0] * (size_t)ny * sizeof(float);
    size_t plane_bytes = 2 * (size_t)s[0] * (size_t)s[1] * sizeof(float);
    float *row = volux_malloc(ctx, row_bytes), *plane = volux_malloc(ctx, plane_bytes);
    if (!row || !plane) {
        volux_free(ctx, row, row_bytes);
        volux_free(ctx, plane, plane_bytes);
        return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for the skip cells");
    }
    for (int k = 0; k < nz; k++) {
        for (size_t i = 0; i < (size_t)s[0] * (size_t)ny; i++) row[2 * i] = INFINITY, row[2 * i + 1] = -INFINITY;
        for (size_t i = 0; i < (size_t)s[0] * (size_t)s[1]; i++)
            plane[2 * i] = INFINITY, plane[2 * i + 1] = -INFINITY;
        for (int j = 0; j < ny; j++) {
            float *r = row + 2 * (size_t)s[0] * (size_t)j;
            for (int i = 0; i < nx; i++) {
                float val = volux_volume_raw_at(v, volux_volume_index(v, i, j, k)) + v->value_offset;
                int lo, hi;
                sub_span(i, s[0], &lo, &hi);
                for (int x = lo; x <= hi; x++) {
                    if (val < r[2 * x]) r[2 * x] = val;
                    if (val > r[2 * x + 1]) r[2 * x + 1] = val;
                }
            }
            int lo, hi;
            sub_span(j, s[1], &lo, &hi);
            for (int y = lo; y <= hi; y++) {
                float *p = plane + 2 * (size_t)s[0] * (size_t)y;
                for (int x = 0; x < s[0]; x++) {
                    if (r[2 * x] < p[2 * x]) p[2 * x] = r[2 * x];
                    if (r[2 * x + 1] > p[2 * x + 1]) p[2 * x + 1] = r[2 * x + 1];
                }
            }
        }
        int zlo, zhi;
        sub_span(k, s[2], &zlo, &zhi);
        for (int z = zlo; z <= zhi; z++)
            for (int y = 0; y < s[1]; y++)
                for (int x = 0; x < s[0]; x++) {
                    const float *p = plane + 2 * ((size_t)s[0] * (size_t)y + (size_t)x);
                    size_t cell = ((size_t)(z >> 1) * (size_t)c[1] + (size_t)(y >> 1)) * (size_t)c[0] + (size_t)(x >> 1);
                    float *o = sk->sub_range + 2 * (8 * cell + (size_t)((x & 1) | (y & 1) << 1 | (z & 1) << 2));
                    if (p[0] < o[0]) o[0] = p[0];
                    if (p[1] > o[1]) o[1] = p[1];
                }
    }
    volux_free(ctx, row, row_bytes);
    volux_free(ctx, plane, plane_bytes);
    /* A cell's nodes are the union of its sub-cells' nodes, so its range is
     * the min/max of theirs: the same floats the node loop gave. */
    for (size_t cell = 0; cell < n; cell++) {
        float lo = INFINITY, hi = -INFINITY;
        for (int b = 0; b < 8; b++) {
            const float *o = sk->sub_range + 2 * (8 * cell + (size_t)b);
            if (o[0] < lo) lo = o[0];
            if (o[1] > hi) hi = o[1];
        }
        sk->range[2 * cell] = lo, sk->range[2 * cell + 1] = hi;
    }
    return VOLUX_OK;
}

/* Table nodes [i0, i1] bracketing the value range [lo, hi] (the majorant
 * grid's test: floor of the low end, ceil of the high). */
static void bracket(const volux_transfer_lut *lut, float lo, float hi, int *i0, int *i1) {
    const int last = lut->n - 1;
    float u0 = (lo - lut->s_min) * lut->inv_ds, u1 = (hi - lut->s_min) * lut->inv_ds;
    /* clamped in float first: a huge range must not overflow the int cast */
    u0 = u0 < 0.0f ? 0.0f : u0 > (float)last ? (float)last : u0;
    u1 = u1 < 0.0f ? 0.0f : u1 > (float)last ? (float)last : u1;
    *i0 = (int)floorf(u0);
    *i1 = (int)ceilf(u1);
    if (*i1 < *i0) *i1 = *i0;
}

/* Occupancy of one cell: bit b set iff sub-cell b holds a node and its range
 * brackets a table node with σt > 0. `nonzero[i]` counts such nodes below i. */
static unsigned cell_occupancy(const dvr_skip *sk, const volux_transfer_lut *lut, const int32_t *nonzero,
                               size_t cell, unsigned valid) {
    int i0, i1;
    bracket(lut, sk->range[2 * cell], sk->range[2 * cell + 1], &i0, &i1);
    int32_t hits = nonzero[i1 + 1] - nonzero[i0];
    if (!hits) return 0;
    /* every node of the cell's bracket has σt > 0: so has every sub-cell's */
    if (hits == i1 - i0 + 1) return valid;
    unsigned occ = 0;
    for (int b = 0; b < 8; b++) {
        const float *o = sk->sub_range + 2 * (8 * cell + (size_t)b);
        if (!(valid >> b & 1)) continue;
        bracket(lut, o[0], o[1], &i0, &i1);
        if (nonzero[i1 + 1] != nonzero[i0]) occ |= 1u << b;
    }
    return occ;
}

/* Sub-cells of cell (x, y, z) that hold at least one node: all 8 except in
 * the last cell along an axis whose second half lies past the volume. */
static unsigned valid_subs(const volux_volume *v, const int c[3], int x, int y, int z) {
    const int at[3] = {x, y, z};
    unsigned valid = 0xff;
    for (int a = 0; a < 3; a++)
        if (at[a] == c[a] - 1 && SUB * (2 * at[a] + 1) > v->dims[a] - 1)
            for (int b = 0; b < 8; b++)
                if (b >> a & 1) valid &= ~(1u << b);
    return valid;
}

/* Chessboard (L∞) distance, in cells, from every cell of one kind to the
 * nearest cell not of that kind (capped at 127): two raster passes of the
 * 3×3×3 chamfer with unit weights give it exactly, on a grid padded by one
 * cell of CAP (never a source) so the 13 causal neighbours are fixed
 * offsets. in_kind[c] != 0 marks the kind; out[c] receives the distance for
 * the cells of the kind. */
static void chessboard(const int cells[3], const unsigned char *in_kind, int32_t *tmp, int8_t *out, int sign) {
    enum { CAP = 127 };
    const int nx = cells[0], ny = cells[1], nz = cells[2];
    const size_t px = (size_t)nx + 2, py = (size_t)ny + 2, pn = px * py * ((size_t)nz + 2);
    ptrdiff_t off[13];
    int no = 0;
    for (int dz = -1; dz <= 0; dz++)
        for (int dy = -1; dy <= 1; dy++)
            for (int dx = -1; dx <= 1; dx++)
                if (!(dz == 0 && (dy > 0 || (dy == 0 && dx >= 0))))
                    off[no++] = ((ptrdiff_t)dz * (ptrdiff_t)py + dy) * (ptrdiff_t)px + dx;
    for (size_t i = 0; i < pn; i++) tmp[i] = CAP;
    for (int z = 0; z < nz; z++)
        for (int y = 0; y < ny; y++)
            for (int x = 0; x < nx; x++) {
                size_t c = ((size_t)z * (size_t)ny + (size_t)y) * (size_t)nx + (size_t)x;
                tmp[(((size_t)z + 1) * py + (size_t)y + 1) * px + (size_t)x + 1] = in_kind[c] ? CAP : 0;
            }
    for (int pass = 0; pass < 2; pass++) {
        const ptrdiff_t dir = pass ? -1 : 1;
        for (int zi = 0; zi < nz; zi++)
            for (int yi = 0; yi < ny; yi++) {
                int z = pass ? nz - zi : zi + 1, y = pass ? ny - yi : yi + 1;
                int32_t *r = tmp + ((size_t)z * py + (size_t)y) * px;
                for (int xi = 0; xi < nx; xi++) {
                    int32_t *t = r + (pass ? nx - xi : xi + 1);
                    int32_t best = *t;
                    if (!best) continue;
                    for (int o = 0; o < 13; o++) {
                        int32_t d = t[dir * off[o]] + 1;
                        if (d < best) best = d;
                    }
                    *t = best;
                }
            }
    }
    for (int z = 0; z < nz; z++)
        for (int y = 0; y < ny; y++)
            for (int x = 0; x < nx; x++) {
                size_t c = ((size_t)z * (size_t)ny + (size_t)y) * (size_t)nx + (size_t)x;
                if (in_kind[c]) out[c] = (int8_t)(sign * tmp[(((size_t)z + 1) * py + (size_t)y + 1) * px + (size_t)x + 1]);
            }
}

volux_status volux_dvr_skip_classify(volux_context *ctx, const volux_volume *v, const volux_transfer_lut *lut,
                                     dvr_skip *sk) {
    const int nx = sk->cells[0], ny = sk->cells[1], nz = sk->cells[2];
    size_t n = (size_t)nx * (size_t)ny * (size_t)nz, bytes = n + 3;
    if (bytes != sk->bytes) {
        volux_free(ctx, sk->dist, sk->bytes);
        volux_free(ctx, sk->occ, sk->bytes);
        sk->bytes = 0;
        sk->dist = volux_malloc(ctx, bytes);
        sk->occ = volux_malloc(ctx, bytes);
        if (!sk->dist || !sk->occ) {
            volux_free(ctx, sk->dist, bytes);
            volux_free(ctx, sk->occ, bytes);
            sk->dist = NULL, sk->occ = NULL;
            return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for the skip distances");
        }
        sk->bytes = bytes;
    }
    /* padding read (and discarded) by the 32-bit gathers */
    memset(sk->dist + n, 0, 3);
    memset(sk->occ + n, 0, 3);
    size_t nz_bytes = ((size_t)lut->n + 1) * sizeof(int32_t);
    size_t tmp_bytes = ((size_t)nx + 2) * ((size_t)ny + 2) * ((size_t)nz + 2) * sizeof(int32_t);
    int32_t *nonzero = volux_malloc(ctx, nz_bytes), *tmp = volux_malloc(ctx, tmp_bytes);
    unsigned char *kind = volux_malloc(ctx, n), *flags = volux_malloc(ctx, n);
    int8_t *dist = sk->dist;
    volux_status s = VOLUX_OK;
    if (!nonzero || !tmp || !kind || !flags) {
        s = volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for the skip distances");
        goto done;
    }
    nonzero[0] = 0;
    for (int i = 0; i < lut->n; i++) nonzero[i + 1] = nonzero[i] + (lut->sigma_t[i] > 0.0f);
    /* kind: 0 empty, 1 not */
    for (int z = 0; z < nz; z++)
        for (int y = 0; y < ny; y++)
            for (int x = 0; x < nx; x++) {
                size_t c = ((size_t)z * (size_t)ny + (size_t)y) * (size_t)nx + (size_t)x;
                unsigned valid = valid_subs(v, sk->cells, x, y, z);
                unsigned occ = cell_occupancy(sk, lut, nonzero, c, valid);
                /* sub-cells past the volume (never sampled) count as occupied
                 * in a non-empty cell, so a full cell reads 0xff */
                if (occ) occ |= ~valid & 0xffu;
                sk->occ[c] = (uint8_t)occ;
                kind[c] = occ != 0;
                dist[c] = 0;
            }
    /* empty cells: distance to the nearest non-empty one (≥ 1); non-empty
     * cells: to the nearest empty one (≤ −1) */
    for (int pass = 0; pass < 2; pass++) {
        for (size_t c = 0; c < n; c++) flags[c] = kind[c] == pass;
        chessboard(sk->cells, flags, tmp, dist, pass ? -1 : 1);
    }
done:
    volux_free(ctx, nonzero, nz_bytes);
    volux_free(ctx, tmp, tmp_bytes);
    volux_free(ctx, kind, n);
    volux_free(ctx, flags, n);
    return s;
}

void volux_dvr_skip_free(volux_context *ctx, dvr_skip *sk) {
    skip_free_ranges(ctx, sk);
    volux_free(ctx, sk->dist, sk->bytes);
    volux_free(ctx, sk->occ, sk->bytes);
    sk->dist = NULL, sk->occ = NULL;
    sk->bytes = 0;
}
