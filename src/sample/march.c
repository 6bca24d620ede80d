/* sample/march.c — majorant grid construction and the DDA interval walk. */
#include <float.h>
#include <math.h>
#include <string.h>

#include "core/vecmath.h"
#include "march.h"

/* Range-max over LUT entries with a sparse table (O(1) per query), since a
 * float volume's cells can each span thousands of entries. */
typedef struct sparse_max {
    int n, levels;
    float *t; /* levels × n */
} sparse_max;

static int sparse_build(volux_context *ctx, const float *v, int n, sparse_max *sm) {
    int levels = 1;
    while ((1 << levels) <= n) levels++;
    sm->t = volux_malloc(ctx, sizeof(float) * (size_t)levels * (size_t)n);
    if (!sm->t) return 0;
    sm->n = n;
    sm->levels = levels;
    memcpy(sm->t, v, sizeof(float) * (size_t)n);
    for (int l = 1; l < levels; l++) {
        const float *prev = sm->t + (size_t)(l - 1) * (size_t)n;
        float *cur = sm->t + (size_t)l * (size_t)n;
        int half = 1 << (l - 1);
        for (int i = 0; i < n; i++) {
            float a = prev[i], b = i + half < n ? prev[i + half] : a;
            cur[i] = a > b ? a : b;
        }
    }
    return 1;
}

static float sparse_query(const sparse_max *sm, int i0, int i1) {
    int len = i1 - i0 + 1, l = 0;
    while ((2 << l) <= len) l++;
    const float *row = sm->t + (size_t)l * (size_t)sm->n;
    float a = row[i0], b = row[i1 - (1 << l) + 1];
    return a > b ? a : b;
}

volux_status volux_majorant_grid_build(volux_context *ctx, const volux_volume *v, const volux_transfer_lut *lut,
                                       volux_majorant_grid *grid) {
    size_t n = (size_t)v->cells[0] * (size_t)v->cells[1] * (size_t)v->cells[2];
    if (!grid->sigma_max || grid->bytes != n * sizeof(float)) {
        volux_majorant_grid_free(ctx, grid);
        grid->sigma_max = volux_malloc(ctx, n * sizeof(float));
        if (!grid->sigma_max) return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory for the majorant grid");
        grid->bytes = n * sizeof(float);
    }
    memcpy(grid->cells, v->cells, sizeof grid->cells);
    sparse_max sm;
    if (!sparse_build(ctx, lut->sigma_t, lut->n, &sm)) return volux_error(ctx, VOLUX_ERR_NOMEM, "out of memory");
    int last = lut->n - 1;
    float gmax = 0.0f;
    for (size_t c = 0; c < n; c++) {
        /* The LUT is linear between nodes, so the max over a value range is
         * the max over the nodes bracketing it. */
        float u0 = (v->cell_min[c] - lut->s_min) * lut->inv_ds, u1 = (v->cell_max[c] - lut->s_min) * lut->inv_ds;
        int i0 = (int)floorf(u0), i1 = (int)ceilf(u1);
        if (i0 < 0) i0 = 0;
        if (i0 > last) i0 = last;
        if (i1 > last) i1 = last;
        if (i1 < i0) i1 = i0;
        float m = sparse_query(&sm, i0, i1);
        grid->sigma_max[c] = m;
        if (m > gmax) gmax = m;
    }
    grid->global_max = gmax;
    volux_free(ctx, sm.t, sizeof(float) * (size_t)sm.levels * (size_t)sm.n);
    return VOLUX_OK;
}

void volux_majorant_grid_free(volux_context *ctx, volux_majorant_grid *grid) {
    if (grid->sigma_max) volux_free(ctx, grid->sigma_max, grid->bytes);
    memset(grid, 0, sizeof *grid);
}

int volux_ray_clip(const volux_volume *v, volux_vec3 o, volux_vec3 d, volux_ray *ray) {
    volux_vec3 lo, hi;
    volux_volume_bounds(v, &lo, &hi);
    return volux_ray_clip_hoisted(v, lo, hi, o, d, v3_inverse(d), ray);
}

int volux_ray_clip_part(const volux_volume *v, volux_vec3 o, volux_vec3 d, volux_ray *ray) {
    if (!v->part_count) return volux_ray_clip(v, o, d, ray);
    volux_vec3 lo, hi;
    float w0, w1, t0, t1;
    volux_volume_owned_bounds(v, &lo, &hi);
    if (!v3_ray_box(o, d, lo, hi, &w0, &w1)) return 0;
    volux_volume_domain_bounds(v, &lo, &hi);
    if (!v3_ray_box(o, d, lo, hi, &t0, &t1)) return 0;
    volux_ray_fill(v, o, d, t0, t1, 1, w0, w1, ray);
    return 1;
}

void volux_march_init(volux_march_iter *it, const volux_majorant_grid *grid, const volux_ray *ray, float t_start,
                      float t_end) {
    it->grid = grid;
    it->t = t_start;
    it->t_end = t_end;
    float q[3] = {ray->q0.x + ray->dq.x * t_start, ray->q0.y + ray->dq.y * t_start, ray->q0.z + ray->dq.z * t_start};
    float dq[3] = {ray->dq.x, ray->dq.y, ray->dq.z};
    for (int a = 0; a < 3; a++) {
        float cell_f = q[a] / (float)VOLUX_CELL_SIZE;
        int c = (int)floorf(cell_f);
        if (c < 0) c = 0;
        if (c >= grid->cells[a]) c = grid->cells[a] - 1;
        it->cell[a] = c;
        if (dq[a] > 0.0f) {
            it->step[a] = 1;
            float boundary = (float)((c + 1) * VOLUX_CELL_SIZE);
            it->t_next[a] = t_start + (boundary - q[a]) / dq[a];
            it->t_delta[a] = (float)VOLUX_CELL_SIZE / dq[a];
        } else if (dq[a] < 0.0f) {
            it->step[a] = -1;
            float boundary = (float)(c * VOLUX_CELL_SIZE);
            it->t_next[a] = t_start + (boundary - q[a]) / dq[a];
            it->t_delta[a] = -(float)VOLUX_CELL_SIZE / dq[a];
        } else {
            it->step[a] = 0;
            it->t_next[a] = INFINITY;
            it->t_delta[a] = INFINITY;
        }
        if (it->t_next[a] < t_start) it->t_next[a] = t_start; /* rounding at a boundary */
    }
}

int volux_march_next(volux_march_iter *it, volux_interval *out) {
    if (it->t >= it->t_end) return 0;
    const volux_majorant_grid *g = it->grid;
    int a = it->t_next[0] < it->t_next[1] ? (it->t_next[0] < it->t_next[2] ? 0 : 2)
                                          : (it->t_next[1] < it->t_next[2] ? 1 : 2);
    float t_exit = it->t_next[a] < it->t_end ? it->t_next[a] : it->t_end;
    size_t c = ((size_t)it->cell[2] * (size_t)g->cells[1] + (size_t)it->cell[1]) * (size_t)g->cells[0] +
               (size_t)it->cell[0];
    out->t0 = it->t;
    out->t1 = t_exit;
    out->sigma_max = g->sigma_max[c];
    it->t = t_exit;
    it->cell[a] += it->step[a];
    it->t_next[a] += it->t_delta[a];
    if (it->cell[a] < 0 || it->cell[a] >= g->cells[a]) it->t = it->t_end; /* left the grid */
    return 1;
}
