/*
 * core/clip.c — crop box and clipping planes (volux/scene.h), and the
 * clipped copy of a volume the scene renders from.
 *
 * WHY A COPY. Every technique derives σt from the volume's voxels through
 * the baked LUT, in many different ways (trilinear samples, bricks, packet
 * gathers, per-voxel tables indexed by the raw integer, summed-area
 * tables, sweeps). Clipping where σt is born — the voxels — makes every
 * one of them (camera rays, shadow rays, illumination caches, majorants)
 * see the same clipped medium without touching technique code: the copy
 * holds, at every clipped voxel, a scalar whose σt is zero. This is
 * exactly the volume a user would get by cutting the data (a procedural
 * volume zeroed outside the box), so the clip works at voxel resolution:
 * a voxel is kept or removed by its centre, and the trilinear field ramps
 * across one voxel at the cut.
 */
#include <math.h>
#include <string.h>

#include "clip_internal.h"
#include "context_internal.h"
#include "parallel.h"
#include "volume_internal.h"

static int finite3(const double v[3]) { return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]); }

volux_status volux_clip_desc_validate(volux_context *ctx, const volux_clip_desc *d) {
    if (!d) return VOLUX_OK;
    if (d->has_box) {
        if (!finite3(d->box_min)) return volux_error(ctx, VOLUX_ERR_INVALID, "clip.box.min: must be finite numbers");
        if (!finite3(d->box_max)) return volux_error(ctx, VOLUX_ERR_INVALID, "clip.box.max: must be finite numbers");
        for (int a = 0; a < 3; a++)
            if (d->box_min[a] > d->box_max[a])
                return volux_error(ctx, VOLUX_ERR_INVALID, "clip.box: min[%d] = %g > max[%d] = %g", a, d->box_min[a],
                                   a, d->box_max[a]);
    }
    if (d->n_planes < 0 || d->n_planes > VOLUX_CLIP_MAX_PLANES)
        return volux_error(ctx, VOLUX_ERR_INVALID, "clip.planes: %d planes, at most %d are allowed", d->n_planes,
                           VOLUX_CLIP_MAX_PLANES);
    for (int i = 0; i < d->n_planes; i++) {
        const volux_clip_plane *p = &d->planes[i];
        if (!finite3(p->origin))
            return volux_error(ctx, VOLUX_ERR_INVALID, "clip.planes[%d].origin: must be finite numbers", i);
        if (!finite3(p->normal))
            return volux_error(ctx, VOLUX_ERR_INVALID, "clip.planes[%d].normal: must be finite numbers", i);
        if (p->normal[0] == 0.0 && p->normal[1] == 0.0 && p->normal[2] == 0.0)
            return volux_error(ctx, VOLUX_ERR_INVALID, "clip.planes[%d].normal: is zero (it needs a direction)", i);
    }
    return VOLUX_OK;
}

int volux_clip_active(const volux_clip_desc *d) { return d && (d->has_box || d->n_planes > 0); }

int volux_clip_keeps(const volux_clip_desc *d, const double p[3]) {
    if (!d) return 1;
    if (d->has_box)
        for (int a = 0; a < 3; a++)
            if (p[a] < d->box_min[a] || p[a] > d->box_max[a]) return 0;
    for (int i = 0; i < d->n_planes; i++) {
        const volux_clip_plane *q = &d->planes[i];
        double s = 0.0;
        for (int a = 0; a < 3; a++) s += (p[a] - q->origin[a]) * q->normal[a];
        if (s > 0.0) return 0;
    }
    return 1;
}

int volux_clip_equal(const volux_clip_desc *a, const volux_clip_desc *b) {
    if (a->has_box != b->has_box || a->n_planes != b->n_planes) return 0;
    if (a->has_box && (memcmp(a->box_min, b->box_min, sizeof a->box_min) ||
                       memcmp(a->box_max, b->box_max, sizeof a->box_max)))
        return 0;
    return a->n_planes == 0 || memcmp(a->planes, b->planes, sizeof a->planes[0] * (size_t)a->n_planes) == 0;
}

/* The fill value: the transparent scalar (σt = 0 under the LUT) nearest the
 * bottom of the volume's range. It depends only on (volume range, TF), never
 * on the edit history, so an edited scene and a fresh one agree bit for bit.
 * Integer storage: every stored value of the range is a candidate (≤ 65 536
 * LUT lookups); float storage: the LUT's nodes (σt is linear between them,
 * so a zero of the table lies on a node unless it is a whole interval). */
volux_status volux_clip_fill_value(volux_context *ctx, const volux_volume *v, const volux_transfer_lut *lut,
                                   float *fill) {
    double lo, hi;
    volux_volume_range(v, &lo, &hi);
    if (v->storage != VOLUX_STORE_F32) {
        long r0 = lrint(lo - v->value_offset), r1 = lrint(hi - v->value_offset);
        for (long r = r0; r <= r1; r++) {
            float s = (float)r + v->value_offset;
            if (volux_transfer_lut_max_sigma(lut, s, s) == 0.0f) {
                *fill = (float)r;
                return VOLUX_OK;
            }
        }
    } else {
        for (int i = 0; i < lut->n; i++) {
            float s = i == lut->n - 1 ? lut->s_max : lut->s_min + (float)i / lut->inv_ds;
            if (lut->inv_ds == 0.0f) s = lut->s_min;
            if (s >= (float)lo && s <= (float)hi && volux_transfer_lut_max_sigma(lut, s, s) == 0.0f) {
                *fill = s;
                return VOLUX_OK;
            }
        }
    }
    return volux_error(ctx, VOLUX_ERR_UNSUPPORTED,
                       "clip: the transfer function is opaque at every value in the volume's range [%g, %g], so "
                       "there is no empty value to fill clipped voxels with; give some value opacity 0",
                       lo, hi);
}

typedef struct clip_job {
    volux_volume *dst;
    const volux_clip_desc *clip;
    float fill; /* stored (raw) value */
} clip_job;

static void store_raw(volux_volume *v, size_t idx, float raw) {
    switch (v->storage) {
    case VOLUX_STORE_U8: ((uint8_t *)v->data)[idx] = (uint8_t)raw; break;
    case VOLUX_STORE_U16: ((uint16_t *)v->data)[idx] = (uint16_t)raw; break;
    case VOLUX_STORE_F32: ((float *)v->data)[idx] = raw; break;
    }
}

/* One z slice: voxel centres (node positions) outside the clip get the fill. */
static void clip_slice(void *user, int64_t k, int thread) {
    (void)thread;
    clip_job *j = user;
    volux_volume *v = j->dst;
    double p[3];
    p[2] = (double)v->origin.z + (double)k * v->spacing[2];
    for (int y = 0; y < v->dims[1]; y++) {
        p[1] = (double)v->origin.y + (double)y * v->spacing[1];
        size_t row = volux_volume_index(v, 0, y, (int)k);
        for (int x = 0; x < v->dims[0]; x++) {
            p[0] = (double)v->origin.x + (double)x * v->spacing[0];
            if (!volux_clip_keeps(j->clip, p)) store_raw(v, row + (size_t)x, j->fill);
        }
    }
}

volux_status volux_clip_volume(const volux_volume *src, const volux_clip_desc *clip, float fill,
                               volux_volume **out) {
    volux_context *ctx = src->ctx;
    volux_volume *v;
    volux_status st = volux_volume_create_storage(ctx, src->dims, src->spacing, src->type, &v);
    if (st) return st;
    memcpy(v->data, src->data, src->data_bytes);
    double origin[3] = {src->origin.x, src->origin.y, src->origin.z};
    v->value_offset = src->value_offset;
    v->origin = src->origin;
    clip_job job = {v, clip, fill};
    volux_parallel_for(volux_context_threads(ctx), v->dims[2], clip_slice, &job);
    if ((st = volux_volume_finalize(v, origin))) {
        volux_volume_release(v);
        return st;
    }
    /* The source's range, not the copy's: the LUT (baked over the range)
     * and everything scaled by it stay those of the uncut volume. */
    v->vmin = src->vmin;
    v->vmax = src->vmax;
    v->superior = src->superior;
    v->has_superior = src->has_superior;
    v->part_count = src->part_count;
    v->part_index = src->part_index;
    memcpy(v->whole_dims, src->whole_dims, sizeof v->whole_dims);
    memcpy(v->owned_lo, src->owned_lo, sizeof v->owned_lo);
    memcpy(v->owned_hi, src->owned_hi, sizeof v->owned_hi);
    memcpy(v->stored_lo, src->stored_lo, sizeof v->stored_lo);
    v->whole_origin = src->whole_origin;
    v->whole_gradient_max = src->whole_gradient_max;
    *out = v;
    return VOLUX_OK;
}
