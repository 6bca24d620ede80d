/*
 * core/clip_internal.h — the scene's clipped copy of a volume (core/clip.c).
 */
#ifndef VOLUX_CLIP_INTERNAL_H
#define VOLUX_CLIP_INTERNAL_H

#include "volux/scene.h"

/* 1 if d clips anything (a box or at least one plane). */
int volux_clip_active(const volux_clip_desc *d);
int volux_clip_equal(const volux_clip_desc *a, const volux_clip_desc *b);
/* The stored (raw) value clipped voxels of v get under lut: the transparent
 * value nearest the bottom of v's range. VOLUX_ERR_UNSUPPORTED if the TF is
 * opaque over the whole range. */
volux_status volux_clip_fill_value(volux_context *ctx, const volux_volume *v, const volux_transfer_lut *lut,
                                   float *fill);
/* A copy of src whose voxels outside `clip` hold the raw value `fill`; same
 * shape, origin, range and part layout as src. */
volux_status volux_clip_volume(const volux_volume *src, const volux_clip_desc *clip, float fill,
                               volux_volume **out);

#endif
