/* core/brick.c — the k-d split of a grid into bricks for data-parallel
 * rendering, the brick's place in the whole grid, and the bricks'
 * visibility order (volux/volume.h, docs/DISTRIBUTED.md). */
#include <math.h>
#include <string.h>

#include "vecmath.h"
#include "volume_internal.h"

/* One walk of the k-d tree. The box of nodes [lo, hi] (inclusive) holds
 * bricks [first, first + n): it is cut across its longest axis (in cells;
 * the lowest axis on a tie) at the node that gives each side cells in
 * proportion to its bricks, the low side taking n/2 of them. Records the
 * box of brick `target` and, when `eye_index` is given, appends the leaves
 * front to back: the side of each cut holding the eye (or, for an
 * orthographic view, the side the view direction comes from) first —
 * every ray crosses a cut plane at most once, so nothing on the far side
 * can be in front of anything on the near side (the BSP order). */
typedef struct kd_walk {
    int target, found;
    int lo[3], hi[3];
    int ok;
    const double *eye_index; /* perspective: eye in whole-grid index space */
    const double *dir_index; /* orthographic: view direction, index space */
    int *order, n_order;
} kd_walk;

static void kd(kd_walk *w, const int lo[3], const int hi[3], int first, int n) {
    if (n == 1) {
        if (first == w->target) {
            memcpy(w->lo, lo, sizeof w->lo);
            memcpy(w->hi, hi, sizeof w->hi);
            w->found = 1;
        }
        if (w->order) w->order[w->n_order++] = first;
        return;
    }
    int a = 0;
    for (int b = 1; b < 3; b++)
        if (hi[b] - lo[b] > hi[a] - lo[a]) a = b;
    int cells = hi[a] - lo[a], nl = n / 2;
    if (cells < 2) { /* no cut leaves a cell on both sides */
        w->ok = 0;
        return;
    }
    int cut = lo[a] + (int)(((int64_t)cells * nl + n / 2) / n);
    if (cut <= lo[a]) cut = lo[a] + 1;
    if (cut >= hi[a]) cut = hi[a] - 1;
    int lhi[3], rlo[3];
    memcpy(lhi, hi, sizeof lhi);
    memcpy(rlo, lo, sizeof rlo);
    lhi[a] = cut;
    rlo[a] = cut;
    int low_first = 1;
    if (w->eye_index) low_first = w->eye_index[a] < (double)cut;
    else if (w->dir_index) low_first = w->dir_index[a] >= 0.0;
    if (low_first) {
        kd(w, lo, lhi, first, nl);
        if (w->ok) kd(w, rlo, hi, first + nl, n - nl);
    } else {
        kd(w, rlo, hi, first + nl, n - nl);
        if (w->ok) kd(w, lo, lhi, first, nl);
    }
}

volux_status volux_brick_split(const int dims[3], int count, int index, int lo[3], int hi[3]) {
    if (!dims || count < 1 || index < 0 || index >= count) return VOLUX_ERR_INVALID;
    int glo[3] = {0, 0, 0}, ghi[3];
    for (int a = 0; a < 3; a++) {
        if (dims[a] < 1) return VOLUX_ERR_INVALID;
        ghi[a] = dims[a] - 1;
    }
    kd_walk w = {.target = index, .ok = 1};
    kd(&w, glo, ghi, 0, count);
    if (!w.ok || !w.found) return VOLUX_ERR_INVALID;
    memcpy(lo, w.lo, sizeof w.lo);
    memcpy(hi, w.hi, sizeof w.hi);
    return VOLUX_OK;
}

volux_status volux_brick_region(const int dims[3], int count, int index, int ghost, int stored_lo[3],
                                int stored_hi[3]) {
    int lo[3], hi[3];
    volux_status st = volux_brick_split(dims, count, index, lo, hi);
    if (st) return st;
    for (int a = 0; a < 3; a++) {
        stored_lo[a] = lo[a] - ghost < 0 ? 0 : lo[a] - ghost;
        stored_hi[a] = hi[a] + ghost + 1 > dims[a] ? dims[a] : hi[a] + ghost + 1;
    }
    return VOLUX_OK;
}

void volux_brick_visibility_order(const int dims[3], int count, const double whole_origin[3],
                                  const double spacing[3], int orthographic, volux_vec3 eye, volux_vec3 dir,
                                  int *order) {
    double e[3] = {eye.x, eye.y, eye.z}, d[3] = {dir.x, dir.y, dir.z};
    for (int a = 0; a < 3; a++) {
        e[a] = (e[a] - whole_origin[a]) / spacing[a];
        d[a] /= spacing[a];
    }
    int glo[3] = {0, 0, 0}, ghi[3] = {dims[0] - 1, dims[1] - 1, dims[2] - 1};
    kd_walk w = {.target = -1, .ok = 1, .order = order};
    if (orthographic) w.dir_index = d;
    else w.eye_index = e;
    kd(&w, glo, ghi, 0, count);
    if (!w.ok) /* an unsplittable grid never made bricks; keep a valid permutation */
        for (int i = 0; i < count; i++) order[i] = i;
}

void volux_brick_origin(const int whole_dims[3], const double spacing[3], const double *whole_origin,
                        const int stored_lo[3], double out_whole[3], double out_part[3]) {
    for (int a = 0; a < 3; a++) {
        /* volux_volume_finalize's centring, for the whole grid */
        out_whole[a] = whole_origin ? whole_origin[a] : -(double)(whole_dims[a] - 1) * spacing[a] / 2.0;
        out_part[a] = out_whole[a] + (double)stored_lo[a] * spacing[a];
    }
}

void volux_volume_make_part(volux_volume *v, int count, int index, const int whole_dims[3], const int stored_lo[3],
                            const double whole_origin[3]) {
    int lo[3], hi[3];
    if (volux_brick_split(whole_dims, count, index, lo, hi)) return; /* the loader checked it */
    v->part_count = count;
    v->part_index = index;
    for (int a = 0; a < 3; a++) {
        v->whole_dims[a] = whole_dims[a];
        v->stored_lo[a] = stored_lo[a];
        v->owned_lo[a] = lo[a];
        v->owned_hi[a] = hi[a];
    }
    v->whole_origin = v3((float)whole_origin[0], (float)whole_origin[1], (float)whole_origin[2]);
}

int volux_volume_brick(const volux_volume *v, volux_brick_info *out) {
    if (!v || !v->part_count) return 0;
    out->count = v->part_count;
    out->index = v->part_index;
    for (int a = 0; a < 3; a++) {
        out->whole_dims[a] = v->whole_dims[a];
        out->owned_lo[a] = v->owned_lo[a];
        out->owned_hi[a] = v->owned_hi[a];
        out->stored_lo[a] = v->stored_lo[a];
    }
    volux_volume_domain_bounds(v, &out->whole_lo, &out->whole_hi);
    return 1;
}

float volux_volume_gradient_max(const volux_volume *v, const int lo[3], const int hi[3]) {
    float gmax = 0.0f, g[3];
    for (int k = lo[2]; k < hi[2]; k++)
        for (int j = lo[1]; j < hi[1]; j++)
            for (int i = lo[0]; i < hi[0]; i++) {
                volux_volume_node_gradient(v, i, j, k, g);
                for (int a = 0; a < 3; a++)
                    if (fabsf(g[a]) > gmax) gmax = fabsf(g[a]);
            }
    return gmax;
}

void volux_volume_stats_of(const volux_volume *v, volux_volume_stats *out) {
    out->value_min = v->vmin;
    out->value_max = v->vmax;
    if (v->whole_gradient_max > 0.0f) {
        out->gradient_max = v->whole_gradient_max;
        return;
    }
    int lo[3] = {0, 0, 0}, hi[3] = {v->dims[0], v->dims[1], v->dims[2]};
    if (v->part_count) /* the owned nodes, in this volume's indices */
        for (int a = 0; a < 3; a++) {
            lo[a] = v->owned_lo[a] - v->stored_lo[a];
            hi[a] = v->owned_hi[a] - v->stored_lo[a] + 1;
        }
    out->gradient_max = volux_volume_gradient_max(v, lo, hi);
}

volux_status volux_volume_set_whole_stats(volux_volume *v, const volux_volume_stats *w) {
    if (!v || !w) return VOLUX_ERR_INVALID;
    if (!(w->value_min <= v->vmin) || !(w->value_max >= v->vmax) || !isfinite(w->value_min) ||
        !isfinite(w->value_max) || !(w->gradient_max >= 0.0) || !isfinite(w->gradient_max) ||
        w->gradient_max > 3e38)
        return volux_error(v->ctx, VOLUX_ERR_INVALID,
                           "whole-volume statistics: range [%g, %g] (must contain the volume's own [%g, %g]), "
                           "gradient max %g (finite, >= 0)",
                           w->value_min, w->value_max, v->vmin, v->vmax, w->gradient_max);
    v->vmin = w->value_min;
    v->vmax = w->value_max;
    v->whole_gradient_max = (float)w->gradient_max;
    return VOLUX_OK;
}

/* The same float arithmetic as volux_volume_bounds of a whole volume, so a
 * part's rays enter the whole box at exactly the single-process t. */
void volux_volume_domain_bounds(const volux_volume *v, volux_vec3 *lo, volux_vec3 *hi) {
    if (!v->part_count) {
        volux_volume_bounds(v, lo, hi);
        return;
    }
    *lo = v->whole_origin;
    *hi = v3(v->whole_origin.x + (float)((v->whole_dims[0] - 1) * v->spacing[0]),
             v->whole_origin.y + (float)((v->whole_dims[1] - 1) * v->spacing[1]),
             v->whole_origin.z + (float)((v->whole_dims[2] - 1) * v->spacing[2]));
}

/* Both neighbours compute their shared face from the whole grid's origin
 * and the same node index, so the face is one float and a ray leaves one
 * brick at exactly the t where it enters the next. */
void volux_volume_owned_bounds(const volux_volume *v, volux_vec3 *lo, volux_vec3 *hi) {
    if (!v->part_count) {
        volux_volume_bounds(v, lo, hi);
        return;
    }
    *lo = v3(v->whole_origin.x + (float)(v->owned_lo[0] * v->spacing[0]),
             v->whole_origin.y + (float)(v->owned_lo[1] * v->spacing[1]),
             v->whole_origin.z + (float)(v->owned_lo[2] * v->spacing[2]));
    *hi = v3(v->whole_origin.x + (float)(v->owned_hi[0] * v->spacing[0]),
             v->whole_origin.y + (float)(v->owned_hi[1] * v->spacing[1]),
             v->whole_origin.z + (float)(v->owned_hi[2] * v->spacing[2]));
}
